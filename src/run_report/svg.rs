//! The report's static drawings, as inline SVG: the pipeline graph, the MAC heat map and the
//! posterior's correlation matrix.

use super::collect::{MacView, PosteriorView, StageView};
use std::collections::BTreeMap;
use std::fmt::Write;

/// Text for HTML and SVG: `&`, `<`, `>`, quotes escaped.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

const BOX_W: f64 = 190.0;
const BOX_H: f64 = 54.0;
const GAP_X: f64 = 60.0;
const GAP_Y: f64 = 18.0;

/// The pipeline as a graph: one column per dependency depth, a box per stage (name, kind,
/// status and time when known; digests on hover), an arrow per wired input.
pub fn pipeline_graph(stages: &[StageView]) -> String {
    let mut depth: BTreeMap<&str, usize> = BTreeMap::new();
    for s in stages {
        let d = s
            .inputs
            .values()
            .filter_map(|from| depth.get(from.split('.').next().unwrap_or_default()))
            .map(|d| d + 1)
            .max()
            .unwrap_or(0);
        depth.insert(&s.name, d);
    }
    let mut row_of: BTreeMap<&str, usize> = BTreeMap::new();
    let mut rows: Vec<usize> = Vec::new();
    for s in stages {
        let d = depth[s.name.as_str()];
        if rows.len() <= d {
            rows.resize(d + 1, 0);
        }
        row_of.insert(&s.name, rows[d]);
        rows[d] += 1;
    }
    let pos = |name: &str| -> Option<(f64, f64)> {
        Some((
            10.0 + *depth.get(name)? as f64 * (BOX_W + GAP_X),
            10.0 + *row_of.get(name)? as f64 * (BOX_H + GAP_Y),
        ))
    };
    let width = 20.0 + rows.len() as f64 * (BOX_W + GAP_X) - GAP_X;
    let height = 20.0 + rows.iter().copied().max().unwrap_or(0) as f64 * (BOX_H + GAP_Y) - GAP_Y;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r##"<svg class="graph" xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" role="img" aria-label="pipeline graph"><defs><marker id="arrow" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" orient="auto"><path d="M0,0L10,5L0,10z" fill="#667"/></marker></defs>"##
    );
    for s in stages {
        let Some((x1, y1)) = pos(&s.name) else {
            continue;
        };
        for from in s.inputs.values() {
            let up = from.split('.').next().unwrap_or_default();
            if let Some((x0, y0)) = pos(up) {
                let (ax, ay, bx, by) = (x0 + BOX_W, y0 + BOX_H / 2.0, x1, y1 + BOX_H / 2.0);
                let mx = (ax + bx) / 2.0;
                let _ = write!(
                    svg,
                    r##"<path d="M{ax},{ay} C{mx},{ay} {mx},{by} {bx},{by}" fill="none" stroke="#667" stroke-width="1.3" marker-end="url(#arrow)"/>"##
                );
            }
        }
    }
    for s in stages {
        let Some((x, y)) = pos(&s.name) else {
            continue;
        };
        let (class, status) = match &s.timing {
            Some(t) => (
                if t.status.starts_with("ran") {
                    "ran"
                } else {
                    "cached"
                },
                format!("{} · {:.3} s", t.status, t.seconds),
            ),
            None => ("unknown", "time not recorded".to_string()),
        };
        let digests: Vec<String> = s
            .outputs
            .iter()
            .map(|(p, k, d)| format!("{p} ({k}): {d}"))
            .collect();
        let _ = write!(
            svg,
            r##"<g class="stage {class}"><title>{}</title><rect x="{x}" y="{y}" width="{BOX_W}" height="{BOX_H}" rx="6"/><text x="{}" y="{}" class="name">{}</text><text x="{}" y="{}">{}</text><text x="{}" y="{}" class="status">{}</text></g>"##,
            escape(&digests.join("\n")),
            x + 8.0,
            y + 17.0,
            escape(&clip(&s.name, 26)),
            x + 8.0,
            y + 32.0,
            escape(&clip(&s.kind, 30)),
            x + 8.0,
            y + 47.0,
            escape(&status),
        );
    }
    svg.push_str("</svg>");
    svg
}

/// At most `n` characters, an ellipsis marking the cut.
fn clip(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(n - 1).collect();
        t.push('…');
        t
    }
}

/// A colour from white (0) to deep blue (1).
fn blue(v: f64) -> String {
    let t = v.clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    format!(
        "#{:02x}{:02x}{:02x}",
        lerp(255.0, 8.0),
        lerp(255.0, 48.0),
        lerp(255.0, 107.0)
    )
}

/// The MAC matrix as a heat map: reference modes down, predicted modes across, the chosen
/// pairs outlined, values written in the cells when they fit, a colour bar from 0 to 1.
pub fn mac_heat_map(m: &MacView) -> String {
    let (nr, np) = (m.reference.len(), m.predicted.len());
    let cell = (480.0 / nr.max(np).max(1) as f64).clamp(6.0, 36.0);
    let (left, top) = (64.0, 40.0);
    let w = left + np as f64 * cell + 90.0;
    let h = top + nr as f64 * cell + 30.0;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r##"<svg class="mac" xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" role="img" aria-label="MAC matrix">"##
    );
    let _ = write!(
        svg,
        r##"<text x="{}" y="14" text-anchor="middle">predicted mode</text><text transform="translate(14,{}) rotate(-90)" text-anchor="middle">reference mode</text>"##,
        left + np as f64 * cell / 2.0,
        top + nr as f64 * cell / 2.0
    );
    let label_every = (14.0 / cell).ceil().max(1.0) as usize;
    for (j, p) in m.predicted.iter().enumerate() {
        if j % label_every == 0 {
            let _ = write!(
                svg,
                r##"<text x="{}" y="{}" text-anchor="middle" class="tick">{p}</text>"##,
                left + (j as f64 + 0.5) * cell,
                top - 6.0
            );
        }
    }
    for (i, r) in m.reference.iter().enumerate() {
        if i % label_every == 0 {
            let _ = write!(
                svg,
                r##"<text x="{}" y="{}" text-anchor="end" class="tick">{r}</text>"##,
                left - 6.0,
                top + (i as f64 + 0.5) * cell + 4.0
            );
        }
        for (j, p) in m.predicted.iter().enumerate() {
            let v = m.mac.get(&(*r, *p)).copied().unwrap_or(0.0);
            let (x, y) = (left + j as f64 * cell, top + i as f64 * cell);
            let _ = write!(
                svg,
                r##"<rect x="{x}" y="{y}" width="{cell}" height="{cell}" fill="{}"><title>reference {r}, predicted {p}: MAC {v:.4}</title></rect>"##,
                blue(v)
            );
            if cell >= 28.0 {
                let ink = if v > 0.55 { "#fff" } else { "#223" };
                let _ = write!(
                    svg,
                    r##"<text x="{}" y="{}" text-anchor="middle" class="cell" fill="{ink}">{}</text>"##,
                    x + cell / 2.0,
                    y + cell / 2.0 + 4.0,
                    (v * 100.0).round() / 100.0
                );
            }
        }
    }
    for (i, r) in m.reference.iter().enumerate() {
        for (j, p) in m.predicted.iter().enumerate() {
            if m.pairs.contains(&(*r, *p)) {
                let _ = write!(
                    svg,
                    r##"<rect x="{}" y="{}" width="{cell}" height="{cell}" fill="none" stroke="#d62728" stroke-width="2"><title>paired: reference {r}, predicted {p}</title></rect>"##,
                    left + j as f64 * cell,
                    top + i as f64 * cell
                );
            }
        }
    }
    let (bx, bh) = (left + np as f64 * cell + 24.0, nr as f64 * cell);
    for k in 0..50 {
        let v = 1.0 - k as f64 / 49.0;
        let _ = write!(
            svg,
            r##"<rect x="{bx}" y="{}" width="14" height="{}" fill="{}"/>"##,
            top + k as f64 * bh / 50.0,
            bh / 50.0 + 0.5,
            blue(v)
        );
    }
    let _ = write!(
        svg,
        r##"<text x="{}" y="{}" class="tick">1</text><text x="{}" y="{}" class="tick">0</text><text x="{}" y="{}" class="tick">MAC</text></svg>"##,
        bx + 18.0,
        top + 8.0,
        bx + 18.0,
        top + bh,
        bx - 4.0,
        top - 6.0
    );
    svg
}

/// Blue (−1) through white (0) to red (+1).
fn diverging(v: f64) -> String {
    let t = v.clamp(-1.0, 1.0);
    let (end, a) = if t < 0.0 {
        ((33.0, 102.0, 172.0), -t)
    } else {
        ((178.0, 24.0, 43.0), t)
    };
    let lerp = |e: f64| (247.0 + (e - 247.0) * a).round() as u8;
    format!("#{:02x}{:02x}{:02x}", lerp(end.0), lerp(end.1), lerp(end.2))
}

/// The posterior's correlation matrix as a heat map on `[−1, 1]`: parameters down and across,
/// the correlation written in each cell when it fits and on hover, a colour bar.
pub fn correlation_heat_map(p: &PosteriorView) -> String {
    let n = p.parameters.len();
    let cell = (400.0 / n.max(1) as f64).clamp(8.0, 48.0);
    let longest = p
        .parameters
        .iter()
        .map(|q| q.name.chars().count())
        .max()
        .unwrap_or(1) as f64;
    let (left, top) = ((longest * 7.0 + 16.0).clamp(40.0, 200.0), 24.0);
    let w = left + n as f64 * cell + 90.0;
    let h = top + n as f64 * cell + 20.0 + longest.min(28.0) * 6.0;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r##"<svg class="correlation" xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" role="img" aria-label="posterior correlation matrix">"##
    );
    let every = (14.0 / cell).ceil().max(1.0) as usize;
    for (i, a) in p.parameters.iter().enumerate() {
        if i % every == 0 {
            let _ = write!(
                svg,
                r##"<text x="{}" y="{}" text-anchor="end" class="tick">{}</text>"##,
                left - 6.0,
                top + (i as f64 + 0.5) * cell + 4.0,
                escape(&a.name)
            );
            let (x, y) = (left + (i as f64 + 0.5) * cell, top + n as f64 * cell + 8.0);
            let _ = write!(
                svg,
                r##"<text x="{x}" y="{y}" text-anchor="end" class="tick" transform="rotate(-60,{x},{y})">{}</text>"##,
                escape(&a.name)
            );
        }
        for (j, b) in p.parameters.iter().enumerate() {
            let v = p.correlation[i][j];
            let (x, y) = (left + j as f64 * cell, top + i as f64 * cell);
            let shown = v.map_or("—".to_string(), |v| format!("{v:.2}").replace('-', "−"));
            let _ = write!(
                svg,
                r##"<rect class="corr" x="{x}" y="{y}" width="{cell}" height="{cell}" fill="{}"><title>{} and {}: correlation {shown}</title></rect>"##,
                v.map_or("#dddddd".to_string(), diverging),
                escape(&a.name),
                escape(&b.name)
            );
            if cell >= 36.0 {
                let ink = if v.is_some_and(|v| v.abs() > 0.6) {
                    "#fff"
                } else {
                    "#223"
                };
                let _ = write!(
                    svg,
                    r##"<text x="{}" y="{}" text-anchor="middle" class="cell" fill="{ink}">{shown}</text>"##,
                    x + cell / 2.0,
                    y + cell / 2.0 + 4.0
                );
            }
        }
    }
    let (bx, bh) = (left + n as f64 * cell + 24.0, n as f64 * cell);
    for k in 0..50 {
        let v = 1.0 - 2.0 * k as f64 / 49.0;
        let _ = write!(
            svg,
            r##"<rect x="{bx}" y="{}" width="14" height="{}" fill="{}"/>"##,
            top + k as f64 * bh / 50.0,
            bh / 50.0 + 0.5,
            diverging(v)
        );
    }
    let _ = write!(
        svg,
        r##"<text x="{}" y="{}" class="tick">1</text><text x="{}" y="{}" class="tick">−1</text><text x="{}" y="{}" class="tick">correlation</text></svg>"##,
        bx + 18.0,
        top + 8.0,
        bx + 18.0,
        top + bh,
        bx - 20.0,
        top - 8.0
    );
    svg
}
