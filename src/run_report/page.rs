//! The report page: HTML with the styles, the script and the data inlined.

use super::collect::{ArtefactView, PosteriorView, RUN_RIDGE, RunView, TestPointsView};
use super::svg::{correlation_heat_map, escape, mac_heat_map, pipeline_graph};
use crate::artefact::Table;
use std::fmt::Write;

const STYLE: &str = include_str!("assets/report.css");
const SCRIPT: &str = include_str!("assets/report.js");

/// The page for `view`.
pub fn render_html(view: &RunView) -> String {
    let mut h = String::with_capacity(1 << 16);
    let title = format!("femu run report: {}", view.pipeline);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><meta name=\"generator\" content=\"femu {}\"><title>{}</title><style>{STYLE}</style></head><body data-rendered=\"no\">",
        escape(&view.report_version),
        escape(&title)
    );
    let _ = write!(
        h,
        "<header><h1>{}</h1><p class=\"sub\">run by femu {}, report by femu {}{}</p></header>",
        escape(&title),
        escape(&view.femu_version),
        escape(&view.report_version),
        view.command
            .as_ref()
            .map(|c| format!(" · command: <code>{}</code>", escape(c)))
            .unwrap_or_default()
    );
    h.push_str("<div id=\"report-errors\" hidden></div><nav>");
    let mut sections = vec![("pipeline", "Pipeline")];
    if !view.warnings.is_empty() {
        sections.push(("warnings", "Warnings"));
    }
    if !view.frfs.is_empty() || !view.correlations.is_empty() {
        sections.push(("frf", "FRFs"));
    }
    if !view.frequencies.is_empty() || !view.macs.is_empty() {
        sections.push(("modal", "Modes"));
    }
    if !view.updates.is_empty() {
        sections.push(("updating", "Updating"));
    }
    if !view.meshes.is_empty() {
        sections.push(("mesh", "Mesh"));
    }
    if !view.test_points.is_empty() {
        sections.push(("pairing", "Test points"));
    }
    if !view.posteriors.is_empty() {
        sections.push(("posterior", "Posterior"));
    }
    if !view.figures.is_empty() {
        sections.push(("figures", "Figures"));
    }
    sections.push(("artefacts", "Artefacts"));
    for (id, name) in &sections {
        let _ = write!(h, "<a href=\"#{id}\">{name}</a>");
    }
    h.push_str("</nav><main>");
    pipeline_section(&mut h, view);
    warnings_section(&mut h, view);
    if !view.frfs.is_empty() || !view.correlations.is_empty() {
        h.push_str(
            "<section id=\"frf\"><h2>Frequency responses</h2><p class=\"hint\">Choose an FRF and the sets to overlay. Drag across a plot to zoom, double-click to reset.</p><div id=\"frf-viewer\" class=\"viewer\"></div></section>",
        );
    }
    modal_section(&mut h, view);
    if !view.updates.is_empty() {
        h.push_str("<section id=\"updating\"><h2>Updating</h2>");
        for u in &view.updates {
            let _ = write!(
                h,
                "<h3>{}</h3><p>method <b>{}</b>, stopped: <b>{}</b></p>",
                escape(&u.id),
                escape(&u.method),
                escape(&u.stop)
            );
            if let Some(a) = view.artefacts.iter().find(|a| a.id == u.id) {
                for t in a.tables.iter().filter(|t| t.name == "parameters") {
                    table_html(&mut h, &t.header, &t.shown, t.rows);
                }
            }
        }
        h.push_str("<div id=\"update-viewer\" class=\"viewer\"></div></section>");
    }
    if !view.meshes.is_empty() {
        h.push_str("<section id=\"mesh\"><h2>Mesh and localisation</h2><p class=\"hint\">Drag to rotate, wheel to zoom, hover for the element.</p>");
        for m in &view.meshes {
            if let Some(n) = &m.note {
                let _ = write!(h, "<p class=\"note\">{}: {}</p>", escape(&m.id), escape(n));
            }
        }
        h.push_str("<div id=\"mesh-viewer\" class=\"viewer\"></div></section>");
    }
    for t in &view.test_points {
        pairing_section(&mut h, t);
    }
    if !view.posteriors.is_empty() {
        h.push_str("<section id=\"posterior\"><h2>Posterior of the parameters</h2><p class=\"hint\">Marginal mean, standard deviation and credible interval per parameter (docs/theory.md §12), and how the parameters are correlated.</p>");
        for p in &view.posteriors {
            posterior_section(&mut h, p);
        }
        h.push_str("<div id=\"posterior-viewer\" class=\"viewer\"></div></section>");
    }
    if !view.figures.is_empty() {
        h.push_str("<section id=\"figures\"><h2>Figures</h2>");
        for f in &view.figures {
            let _ = write!(h, "<h3>{}</h3><div class=\"figures\">", escape(&f.title));
            for (file, bytes) in &f.images {
                let mime = if file.ends_with(".svg") {
                    "image/svg+xml"
                } else {
                    "image/png"
                };
                let _ = write!(
                    h,
                    "<figure><img alt=\"{}\" src=\"data:{mime};base64,{}\"><figcaption>{} · {}</figcaption></figure>",
                    escape(file),
                    base64(bytes),
                    escape(&f.id),
                    escape(file)
                );
            }
            h.push_str("</div>");
        }
        h.push_str("</section>");
    }
    artefacts_section(&mut h, &view.artefacts);
    h.push_str("</main>");
    let data = serde_json::json!({
        "frfs": view.frfs,
        "correlations": view.correlations,
        "meshes": view.meshes,
        "fields": view.fields,
        "updates": view.updates,
        "test_points": view.test_points,
        "posteriors": view.posteriors,
    });
    // `<` never appears raw inside the script element, so no text can close it.
    let json = data.to_string().replace('<', "\\u003c");
    let _ = writeln!(
        h,
        "<script type=\"application/json\" id=\"femu-data\">{json}</script><script>{SCRIPT}</script></body></html>"
    );
    h
}

/// A number as a reader wants it, with a typographic minus.
fn number(v: Option<f64>) -> String {
    match v {
        None => "—".into(),
        Some(x) if x == 0.0 || (1e-3..1e5).contains(&x.abs()) => {
            format!("{}", (x * 1e4).round() / 1e4).replace('-', "−")
        }
        Some(x) => format!("{x:.4e}").replace('-', "−"),
    }
}

/// The test points of one `test_map`: what each was paired to and how far, farthest first.
fn pairing_section(h: &mut String, t: &TestPointsView) {
    let _ = write!(
        h,
        "<section id=\"pairing\"><h2>Test points: {}</h2><p class=\"hint\">{} point(s){}{}. Farthest first; in the mesh view each point is a marker coloured by its distance.</p>",
        escape(&t.id),
        t.points.len(),
        t.tolerance_m
            .map(|v| format!(", tolerance {} mm", number(Some(v * 1e3))))
            .unwrap_or_default(),
        t.mesh
            .as_ref()
            .map(|m| format!(", paired to the mesh {}", escape(m)))
            .unwrap_or_default()
    );
    let mut order: Vec<usize> = (0..t.points.len()).collect();
    order.sort_by(|&a, &b| {
        let d = |k: usize| t.points[k].distance_m.unwrap_or(f64::INFINITY);
        d(b).total_cmp(&d(a)).then(a.cmp(&b))
    });
    h.push_str("<div class=\"scroll\"><table class=\"pairing\"><thead><tr><th>test point</th><th>paired to</th><th>distance (mm)</th><th>status</th></tr></thead><tbody>");
    for k in order {
        let p = &t.points[k];
        let to = match (p.fe_node, p.fe_element) {
            (Some(n), _) => format!("node {n}"),
            (None, Some(e)) => format!("element {e}"),
            (None, None) => "—".into(),
        };
        let bad = p.status != "ok";
        let _ = write!(
            h,
            "<tr{}><td>{}</td><td>{}</td><td class=\"num\">{}</td><td>{}</td></tr>",
            if bad { " class=\"bad\"" } else { "" },
            p.node,
            escape(&to),
            number(p.distance_m.map(|d| d * 1e3)),
            escape(&p.status)
        );
    }
    h.push_str("</tbody></table></div></section>");
}

/// The sentence on two parameters on a ridge of the likelihood.
pub(super) fn ridge_sentence(a: &str, b: &str, r: f64) -> String {
    let r = format!("{r:.2}").replace('-', "−");
    format!("{a} and {b} are correlated at {r}: the data determine their combination, not each.")
}

/// One posterior: the marginals, the ridges in words, the correlation matrix.
fn posterior_section(h: &mut String, p: &PosteriorView) {
    let level = p
        .level
        .map(|l| format!("{} %", (l * 1000.0).round() / 10.0))
        .unwrap_or_else(|| "credible".into());
    let chains = p.parameters.iter().any(|q| q.r_hat.is_some());
    let how = match (p.sampler.as_str(), p.log_evidence) {
        ("TMCMC", Some(e)) => format!("TMCMC samples, ln evidence {}", number(Some(e))),
        ("Laplace", _) => "Laplace (Gaussian at the mode)".into(),
        (s, _) => format!("{s} samples"),
    };
    let _ = write!(
        h,
        "<h3>{} <span class=\"sampler\">{}</span></h3><div class=\"scroll\"><table><thead><tr><th>parameter</th><th>updated</th><th>mean</th><th>sd</th><th>{} interval</th>{}</tr></thead><tbody>",
        escape(&p.id),
        escape(&how),
        escape(&level),
        if chains {
            "<th>R̂</th><th>effective samples</th>"
        } else {
            ""
        }
    );
    for q in &p.parameters {
        let _ = write!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">[{}, {}]</td>",
            escape(&q.name),
            number(q.updated),
            number(q.mean),
            number(q.sd),
            number(q.lower),
            number(q.upper)
        );
        if chains {
            let poor = q.r_hat.is_some_and(|r| r > 1.05) || q.ess.is_some_and(|e| e < 100.0);
            let _ = write!(
                h,
                "<td class=\"num{}\">{}</td><td class=\"num\">{}</td>",
                if poor { " warn" } else { "" },
                number(q.r_hat),
                q.ess.map_or("—".into(), |e| format!("{e:.0}"))
            );
        }
        h.push_str("</tr>");
    }
    h.push_str("</tbody></table></div>");
    if p.ridges.is_empty() {
        let _ = write!(
            h,
            "<p class=\"ridge none\">No two parameters are correlated beyond ±{RUN_RIDGE}: the data determine each of them.</p>"
        );
    }
    for (a, b, r) in &p.ridges {
        let _ = write!(
            h,
            "<p class=\"ridge\">{}</p>",
            escape(&ridge_sentence(a, b, *r))
        );
    }
    if p.parameters.len() > 1 {
        let _ = write!(h, "<div class=\"scroll\">{}</div>", correlation_heat_map(p));
    }
    if !p.bands.is_empty() {
        h.push_str("<p class=\"hint\">Its predictive bands of |H| (± 2 sd) are drawn in the FRF viewer.</p>");
    }
}

fn pipeline_section(h: &mut String, view: &RunView) {
    let _ = write!(
        h,
        "<section id=\"pipeline\"><h2>Pipeline</h2><div class=\"scroll\">{}</div><table><thead><tr><th>stage</th><th>kind</th><th>status</th><th>time (s)</th><th>outputs (digest)</th></tr></thead><tbody>",
        pipeline_graph(&view.stages)
    );
    for s in &view.stages {
        let (status, time) = match &s.timing {
            Some(t) => (t.status.clone(), format!("{:.3}", t.seconds)),
            None => ("—".into(), "—".into()),
        };
        let outs: Vec<String> = s
            .outputs
            .iter()
            .map(|(p, k, d)| {
                format!(
                    "{} <span class=\"kind\">{}</span> <code title=\"{}\">{}</code>",
                    escape(p),
                    escape(k),
                    escape(d),
                    escape(d.get(..12).unwrap_or(d))
                )
            })
            .collect();
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{}</td><td>{}</td></tr>",
            escape(&s.name),
            escape(&s.kind),
            escape(&status),
            time,
            outs.join("<br>")
        );
    }
    h.push_str("</tbody></table></section>");
}

fn warnings_section(h: &mut String, view: &RunView) {
    if view.warnings.is_empty() {
        return;
    }
    let _ = write!(
        h,
        "<section id=\"warnings\"><h2>Warnings <span class=\"count\">{}</span></h2>",
        view.warnings.len()
    );
    let mut last = "";
    for (stage, text) in &view.warnings {
        if stage != last {
            if !last.is_empty() {
                h.push_str("</ul>");
            }
            let _ = write!(h, "<h3>{}</h3><ul>", escape(stage));
            last = stage;
        }
        let _ = write!(h, "<li>{}</li>", escape(text));
    }
    h.push_str("</ul></section>");
}

fn modal_section(h: &mut String, view: &RunView) {
    if view.frequencies.is_empty() && view.macs.is_empty() {
        return;
    }
    h.push_str("<section id=\"modal\"><h2>Modes</h2>");
    for (id, f) in &view.frequencies {
        let _ = write!(
            h,
            "<h3>{}: natural frequencies</h3><div class=\"freqs\">",
            escape(id)
        );
        for (k, v) in f.iter().enumerate() {
            let _ = write!(h, "<span><b>{}</b> {:.4} Hz</span>", k + 1, v);
        }
        h.push_str("</div>");
    }
    for m in &view.macs {
        let _ = write!(
            h,
            "<h3>{}: MAC</h3><div class=\"scroll\">{}</div>",
            escape(&m.id),
            mac_heat_map(m)
        );
        if let Some((_, t)) = view.modal_pairs.iter().find(|(id, _)| id == &m.id) {
            table_of(h, t);
        }
    }
    h.push_str("</section>");
}

fn table_of(h: &mut String, t: &Table) {
    let header: Vec<String> = t.columns.iter().map(|c| c.0.clone()).collect();
    let rows: Vec<Vec<String>> = (0..t.rows())
        .map(|r| t.columns.iter().map(|c| c.1.cell(r)).collect())
        .collect();
    table_html(h, &header, &rows, t.rows());
}

fn table_html(h: &mut String, header: &[String], rows: &[Vec<String>], total: usize) {
    h.push_str("<div class=\"scroll\"><table><thead><tr>");
    for c in header {
        let _ = write!(h, "<th>{}</th>", escape(c));
    }
    h.push_str("</tr></thead><tbody>");
    for r in rows {
        h.push_str("<tr>");
        for c in r {
            let _ = write!(h, "<td>{}</td>", escape(c));
        }
        h.push_str("</tr>");
    }
    h.push_str("</tbody></table>");
    if total > rows.len() {
        let _ = write!(
            h,
            "<p class=\"note\">first {} of {} rows; the artefact holds all</p>",
            rows.len(),
            total
        );
    }
    h.push_str("</div>");
}

fn artefacts_section(h: &mut String, artefacts: &[ArtefactView]) {
    h.push_str("<section id=\"artefacts\"><h2>Artefacts</h2>");
    for a in artefacts {
        let _ = write!(
            h,
            "<details><summary><b>{}</b> <span class=\"kind\">{}</span> <code>{}</code></summary>",
            escape(&a.id),
            escape(&a.kind),
            escape(a.digest.get(..16).unwrap_or(&a.digest))
        );
        if let Some(e) = &a.error {
            let _ = write!(h, "<p class=\"error\">cannot be read: {}</p>", escape(e));
        }
        for t in &a.tables {
            let _ = write!(
                h,
                "<h4>{} <span class=\"kind\">{} rows</span></h4>",
                escape(&t.name),
                t.rows
            );
            table_html(h, &t.header, &t.shown, t.rows);
        }
        if !a.meta.is_empty() {
            let _ = write!(h, "<h4>meta</h4><pre>{}</pre>", escape(&a.meta));
        }
        h.push_str("</details>");
    }
    h.push_str("</section>");
}

/// Standard base64 (RFC 4648, with padding), for images inlined as data URLs.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        let k = c.len() + 1;
        for i in 0..4 {
            if i < k {
                out.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
pub(super) fn base64_for_test(bytes: &[u8]) -> String {
    base64(bytes)
}
