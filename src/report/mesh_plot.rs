//! A shell-and-beam mesh coloured by a value per element (an error-localisation map, thesis
//! figs. 5.3–5.7), in one or more panels sharing a colour bar, as PNG and SVG.
//!
//! The 3D mesh is projected orthographically along a fixed view (azimuth about `z`, elevation
//! above the `xy` plane). Faces and beams are drawn far to near (painter's algorithm by mean
//! depth, ties broken by element id), filled by a colour map of the value — a viridis-like ramp
//! for values in `[0, 1]`, a blue-white-red ramp when some are negative (`[−1, 1]`) — with dark
//! edges; elements without a value are light grey; highlighted elements get thick red edges.
//! An orientation triad in each panel's lower left corner shows where `x`, `y` and `z` point.
//! Equal inputs give byte-identical files.

use std::collections::{BTreeMap, BTreeSet};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::figure::{Figure, PlotError, backend_error, render, text_style};
use crate::model::{Element, Model};

/// Viewing direction: the camera looks at the mesh from this azimuth and elevation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Rotation about `z` from `+x` toward `+y`, degrees.
    pub azimuth_deg: f64,
    /// Angle above the `xy` plane, degrees.
    pub elevation_deg: f64,
}

impl Default for View {
    fn default() -> Self {
        View {
            azimuth_deg: -60.0,
            elevation_deg: 30.0,
        }
    }
}

/// One panel: a title and a value per element id (elements without one are grey).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshPanel {
    /// Panel title.
    pub title: String,
    /// Value per element, on the scale of the colour bar.
    pub values: BTreeMap<u64, f64>,
}

/// What to draw.
#[derive(Clone, Debug)]
pub struct MeshPlot<'a> {
    /// Figure title.
    pub title: String,
    /// The mesh.
    pub model: &'a Model,
    /// Panels, laid out row by row.
    pub panels: Vec<MeshPanel>,
    /// Panels per row.
    pub columns: usize,
    /// Viewing direction.
    pub view: View,
    /// Elements drawn with thick red edges (e.g. the known error).
    pub highlight: BTreeSet<u64>,
    /// Label of the colour bar.
    pub colour_label: String,
}

const INK: RGBColor = RGBColor(33, 33, 33);
pub(super) const EDGE: RGBColor = RGBColor(60, 60, 60);
pub(super) const NO_VALUE: RGBColor = RGBColor(215, 215, 215);
const MARK: RGBColor = RGBColor(220, 20, 30);
/// Panel size in pixels.
const PANEL: (u32, u32) = (560, 430);
const TITLE_H: u32 = 44;
const BAR_W: u32 = 110;

/// Viridis-like ramp: control points at 0, 1/8, …, 1.
pub(super) const SEQUENTIAL: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 44, 122),
    (59, 81, 139),
    (44, 113, 142),
    (33, 144, 141),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];
/// Blue-white-red ramp for `[−1, 1]`.
const DIVERGING: [(u8, u8, u8); 5] = [
    (33, 102, 172),
    (146, 197, 222),
    (247, 247, 247),
    (244, 165, 130),
    (178, 24, 43),
];

pub(super) fn ramp(points: &[(u8, u8, u8)], t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (points.len() - 1) as f64;
    let i = (x.floor() as usize).min(points.len() - 2);
    let f = x - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (points[i], points[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The colour scale: `[0, 1]` sequential, or `[−1, 1]` diverging.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scale {
    Sequential,
    Diverging,
}

impl Scale {
    fn of(panels: &[MeshPanel]) -> Self {
        if panels
            .iter()
            .flat_map(|p| p.values.values())
            .any(|v| *v < 0.0)
        {
            Scale::Diverging
        } else {
            Scale::Sequential
        }
    }
    fn range(self) -> (f64, f64) {
        match self {
            Scale::Sequential => (0.0, 1.0),
            Scale::Diverging => (-1.0, 1.0),
        }
    }
    fn colour(self, v: f64) -> RGBColor {
        match self {
            Scale::Sequential => ramp(&SEQUENTIAL, v),
            Scale::Diverging => ramp(&DIVERGING, 0.5 * (v + 1.0)),
        }
    }
}

/// One drawable: a face (3 or 4 corners) or a beam (2 ends), projected.
pub(super) struct Item {
    pub(super) id: u64,
    pub(super) depth: f64,
    pub(super) points: Vec<(f64, f64)>,
    pub(super) face: bool,
}

/// Orthographic projection: screen right, screen up, toward the camera.
pub(super) fn axes(view: View) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let (a, e) = (
        view.azimuth_deg.to_radians(),
        view.elevation_deg.to_radians(),
    );
    let toward = [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()];
    let right = [-a.sin(), a.cos(), 0.0];
    let up = [-e.sin() * a.cos(), -e.sin() * a.sin(), e.cos()];
    (right, up, toward)
}

pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The boundary of a quadratic face: each corner followed by its edge's midside node if present.
fn outline(corners: &[u64], midside: &[Option<u64>]) -> Vec<u64> {
    corners
        .iter()
        .zip(midside)
        .flat_map(|(c, m)| std::iter::once(*c).chain(*m))
        .collect()
}

/// The fit of projected points into a box of the figure: screen pixel of a projected point.
#[derive(Clone, Copy, Debug)]
pub(super) struct Fit {
    /// Pixels per metre.
    pub(super) s: f64,
    /// Pixel of the projected origin.
    pub(super) ox: f64,
    pub(super) oy: f64,
}

impl Fit {
    /// Fits the finite `points` (projected, m) centred into the box at `(left, top)` of size
    /// `w × h` pixels with `margin` on every side; a degenerate extent is widened.
    pub(super) fn new<'p>(
        points: impl IntoIterator<Item = &'p (f64, f64)>,
        (left, top, w, h): (f64, f64, f64, f64),
        margin: f64,
    ) -> Fit {
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for p in points {
            if p.0.is_finite() && p.1.is_finite() {
                x0 = x0.min(p.0);
                x1 = x1.max(p.0);
                y0 = y0.min(p.1);
                y1 = y1.max(p.1);
            }
        }
        if !(x1 > x0) {
            (x0, x1) = (x0.min(0.0) - 1.0, x1.max(0.0) + 1.0);
        }
        if !(y1 > y0) {
            (y0, y1) = (y0.min(0.0) - 1.0, y1.max(0.0) + 1.0);
        }
        let s = ((w - 2.0 * margin) / (x1 - x0)).min((h - 2.0 * margin) / (y1 - y0));
        Fit {
            s,
            ox: left + w / 2.0 - s * (x0 + x1) / 2.0,
            oy: top + h / 2.0 + s * (y0 + y1) / 2.0,
        }
    }

    /// The pixel of a projected point.
    pub(super) fn px(&self, p: &(f64, f64)) -> (i32, i32) {
        (
            (self.ox + self.s * p.0).round() as i32,
            (self.oy - self.s * p.1).round() as i32,
        )
    }
}

/// The triad's arrows: each axis's label and its screen direction (right, down) for a unit
/// vector along it, as seen along `view`.
pub(super) fn triad(view: View) -> [(&'static str, (f64, f64)); 3] {
    let (right, up, _) = axes(view);
    let dir = |e: [f64; 3]| (dot(e, right), -dot(e, up));
    [
        ("x", dir([1.0, 0.0, 0.0])),
        ("y", dir([0.0, 1.0, 0.0])),
        ("z", dir([0.0, 0.0, 1.0])),
    ]
}

/// Draws the orientation triad with its origin at `at`: an arrow of `len` pixels (projected)
/// per axis, labelled at its tip.
pub(super) fn draw_triad<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    view: View,
    at: (i32, i32),
    len: f64,
) -> Result<(), PlotError> {
    let centre = Pos::new(HPos::Center, VPos::Center);
    for (name, (dx, dy)) in triad(view) {
        let tip = (
            at.0 + (len * dx).round() as i32,
            at.1 + (len * dy).round() as i32,
        );
        root.draw(&PathElement::new(vec![at, tip], INK.stroke_width(2)))
            .map_err(backend_error)?;
        let n = dx.hypot(dy);
        if n > 0.2 {
            // Arrow head: two strokes back from the tip at ±25°.
            let (ux, uy) = (dx / n, dy / n);
            for a in [0.44_f64, -0.44] {
                let (c, s) = (a.cos(), a.sin());
                let back = (
                    tip.0 - (8.0 * (ux * c - uy * s)).round() as i32,
                    tip.1 - (8.0 * (ux * s + uy * c)).round() as i32,
                );
                root.draw(&PathElement::new(vec![tip, back], INK.stroke_width(2)))
                    .map_err(backend_error)?;
            }
        }
        let label = (
            at.0 + ((len + 13.0) * dx).round() as i32,
            at.1 + ((len + 13.0) * dy).round() as i32,
        );
        root.draw(&Text::new(
            name.to_string(),
            label,
            text_style(16.0, FontStyle::Italic, INK, centre),
        ))
        .map_err(backend_error)?;
    }
    Ok(())
}

/// Projected faces and beams, far to near.
pub(super) fn items(model: &Model, view: View) -> Vec<Item> {
    let (right, up, toward) = axes(view);
    let mut out = Vec::new();
    for (&id, e) in &model.elements {
        if let Element::Solid { kind, nodes, .. } = e {
            // Each face of a solid, drawn like a shell facet of the element.
            for f in kind.corner_faces() {
                let xyz: Vec<[f64; 3]> = f
                    .iter()
                    .filter_map(|&k| model.nodes.get(nodes.get(k)?).copied())
                    .collect();
                if xyz.len() != f.len() {
                    continue;
                }
                let depth = xyz.iter().map(|p| dot(*p, toward)).sum::<f64>() / xyz.len() as f64;
                out.push(Item {
                    id,
                    depth,
                    points: xyz.iter().map(|p| (dot(*p, right), dot(*p, up))).collect(),
                    face: true,
                });
            }
            continue;
        }
        let (nodes, face): (Vec<u64>, bool) = match e {
            Element::Quad4 { nodes, .. } => (nodes.to_vec(), true),
            Element::Tria3 { nodes, .. } => (nodes.to_vec(), true),
            // The outline through the corners and the midside nodes that are present.
            Element::Quad8 {
                corners, midside, ..
            } => (outline(corners, midside), true),
            Element::Tria6 {
                corners, midside, ..
            } => (outline(corners, midside), true),
            Element::Beam { nodes, .. } | Element::Rod { nodes, .. } => (nodes.to_vec(), false),
            _ => continue,
        };
        let xyz: Vec<[f64; 3]> = nodes
            .iter()
            .filter_map(|n| model.nodes.get(n).copied())
            .collect();
        if xyz.len() != nodes.len() {
            continue;
        }
        let depth = xyz.iter().map(|p| dot(*p, toward)).sum::<f64>() / xyz.len() as f64;
        out.push(Item {
            id,
            depth,
            points: xyz.iter().map(|p| (dot(*p, right), dot(*p, up))).collect(),
            face,
        });
    }
    out.sort_by(|a, b| a.depth.total_cmp(&b.depth).then(a.id.cmp(&b.id)));
    out
}

/// Renders the panels as PNG and SVG.
pub fn mesh_plot(plot: &MeshPlot<'_>) -> Result<Figure, PlotError> {
    let columns = plot.columns.clamp(1, plot.panels.len().max(1));
    let rows = plot.panels.len().max(1).div_ceil(columns);
    let w = PANEL.0 * columns as u32 + BAR_W;
    let h = TITLE_H + PANEL.1 * rows as u32;
    let items = items(plot.model, plot.view);
    render(w, h, &|root| draw(root, plot, &items, columns), &|root| {
        draw(root, plot, &items, columns)
    })
}

fn text<'a>(size: f64, bold: bool, pos: Pos) -> TextStyle<'a> {
    let style = if bold {
        FontStyle::Bold
    } else {
        FontStyle::Normal
    };
    text_style(size, style, INK, pos)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &MeshPlot<'_>,
    items: &[Item],
    columns: usize,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(backend_error)?;
    let (w, _) = root.dim_in_pixel();
    let centre = Pos::new(HPos::Center, VPos::Center);
    root.draw(&Text::new(
        plot.title.clone(),
        ((w - BAR_W) as i32 / 2, TITLE_H as i32 / 2),
        text(20.0, true, centre),
    ))
    .map_err(backend_error)?;
    let (pw, ph) = (PANEL.0 as f64, PANEL.1 as f64);
    let (margin, caption) = (24.0, 34.0);
    // One fit for every panel (the projected bounding box), shifted to each panel.
    let fit = Fit::new(
        items.iter().flat_map(|i| &i.points),
        (0.0, caption, pw, ph - caption),
        margin,
    );
    let scale = Scale::of(&plot.panels);
    for (k, panel) in plot.panels.iter().enumerate() {
        let (c, r) = ((k % columns) as f64, (k / columns) as f64);
        let left = c * pw;
        let top = TITLE_H as f64 + r * ph;
        root.draw(&Text::new(
            panel.title.clone(),
            ((left + pw / 2.0) as i32, (top + caption / 2.0 + 4.0) as i32),
            text(16.0, false, centre),
        ))
        .map_err(backend_error)?;
        let at = Fit {
            ox: fit.ox + left,
            oy: fit.oy + top,
            ..fit
        };
        let px = |p: &(f64, f64)| at.px(p);
        for item in items {
            let value = panel.values.get(&item.id).copied();
            let fill = value.map_or(NO_VALUE, |v| scale.colour(v));
            let pts: Vec<(i32, i32)> = item.points.iter().map(px).collect();
            let marked = plot.highlight.contains(&item.id);
            if item.face {
                root.draw(&Polygon::new(pts.clone(), fill.filled()))
                    .map_err(backend_error)?;
                let mut ring = pts.clone();
                ring.push(pts[0]);
                let edge = if marked {
                    MARK.stroke_width(3)
                } else {
                    EDGE.stroke_width(1)
                };
                root.draw(&PathElement::new(ring, edge))
                    .map_err(backend_error)?;
            } else {
                let colour = if value.is_some() { fill } else { EDGE };
                if marked {
                    root.draw(&PathElement::new(pts.clone(), MARK.stroke_width(6)))
                        .map_err(backend_error)?;
                }
                root.draw(&PathElement::new(pts, colour.stroke_width(3)))
                    .map_err(backend_error)?;
            }
        }
        draw_triad(
            root,
            plot.view,
            ((left + 44.0) as i32, (top + ph - 44.0) as i32),
            26.0,
        )?;
    }
    draw_colour_bar(root, plot, &scale, w)
}

/// The colour bar right of the panels with its ticks and label, and the keys of the "no
/// value" fill and of marked elements.
fn draw_colour_bar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &MeshPlot<'_>,
    scale: &Scale,
    w: u32,
) -> Result<(), PlotError> {
    let centre = Pos::new(HPos::Center, VPos::Center);
    let (lo, hi) = scale.range();
    let bx = (w - BAR_W) as i32 + 18;
    let (by0, by1) = (TITLE_H as i32 + 50, TITLE_H as i32 + PANEL.1 as i32 - 90);
    let steps = 120;
    for i in 0..steps {
        let t0 = i as f64 / steps as f64;
        let t1 = (i + 1) as f64 / steps as f64;
        let ya = by1 - ((by1 - by0) as f64 * t1).round() as i32;
        let yb = by1 - ((by1 - by0) as f64 * t0).round() as i32;
        let v = lo + (hi - lo) * (t0 + t1) / 2.0;
        root.draw(&Rectangle::new(
            [(bx, ya), (bx + 22, yb)],
            scale.colour(v).filled(),
        ))
        .map_err(backend_error)?;
    }
    root.draw(&Rectangle::new(
        [(bx, by0), (bx + 22, by1)],
        INK.stroke_width(1),
    ))
    .map_err(backend_error)?;
    let ticks = 4;
    for i in 0..=ticks {
        let t = i as f64 / ticks as f64;
        let y = by1 - ((by1 - by0) as f64 * t).round() as i32;
        root.draw(&PathElement::new(
            vec![(bx + 22, y), (bx + 27, y)],
            INK.stroke_width(1),
        ))
        .map_err(backend_error)?;
        let v = lo + (hi - lo) * t;
        root.draw(&Text::new(
            format!("{v:.2}"),
            (bx + 30, y),
            text(12.0, false, Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(backend_error)?;
    }
    root.draw(&Text::new(
        plot.colour_label.clone(),
        (bx + 11, by0 - 20),
        text(12.0, false, centre),
    ))
    .map_err(backend_error)?;
    let legend_y = by1 + 22;
    root.draw(&Rectangle::new(
        [(bx, legend_y - 6), (bx + 12, legend_y + 6)],
        NO_VALUE.filled(),
    ))
    .map_err(backend_error)?;
    root.draw(&Text::new(
        "no value".to_string(),
        (bx + 16, legend_y),
        text(12.0, false, Pos::new(HPos::Left, VPos::Center)),
    ))
    .map_err(backend_error)?;
    if !plot.highlight.is_empty() {
        root.draw(&Rectangle::new(
            [(bx, legend_y + 16), (bx + 12, legend_y + 28)],
            MARK.stroke_width(3),
        ))
        .map_err(backend_error)?;
        root.draw(&Text::new(
            "marked".to_string(),
            (bx + 16, legend_y + 22),
            text(12.0, false, Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(backend_error)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::generate::{BentPlate, bent_plate};

    #[test]
    fn ramps_hit_their_ends() {
        assert_eq!(ramp(&SEQUENTIAL, 0.0), RGBColor(68, 1, 84));
        assert_eq!(ramp(&SEQUENTIAL, 1.0), RGBColor(253, 231, 37));
        assert_eq!(ramp(&SEQUENTIAL, f64::NAN), RGBColor(68, 1, 84));
        assert_eq!(Scale::Diverging.colour(0.0), RGBColor(247, 247, 247));
    }

    /// Far faces come first; equal inputs give equal bytes.
    #[test]
    fn painter_order_and_determinism() {
        let model = bent_plate(&BentPlate::default());
        let it = items(&model, View::default());
        assert_eq!(it.len(), 123);
        assert!(it.windows(2).all(|w| w[0].depth <= w[1].depth));
        let values: BTreeMap<u64, f64> = (1..=98).map(|e| (e, e as f64 / 98.0)).collect();
        let plot = MeshPlot {
            title: "t".into(),
            model: &model,
            panels: vec![
                MeshPanel {
                    title: "a".into(),
                    values: values.clone(),
                },
                MeshPanel {
                    title: "b".into(),
                    values: values.iter().map(|(k, v)| (*k, -v)).collect(),
                },
            ],
            columns: 2,
            view: View::default(),
            highlight: [7, 14].into_iter().collect(),
            colour_label: "L / max".into(),
        };
        let a = mesh_plot(&plot).unwrap();
        assert_eq!(a, mesh_plot(&plot).unwrap());
        assert!(a.png.starts_with(b"\x89PNG") && a.svg.contains("<svg"));
        // A triad per panel: three italic axis labels each.
        crate::report::mac_plot::check::svg_elements(&a.svg).unwrap();
        assert_eq!(
            crate::report::mac_plot::check::count_with(&a.svg, "text", "font-style=\"italic\""),
            2 * 3
        );
        for name in ["x", "y", "z"] {
            assert_eq!(a.svg.matches(&format!(">\n{name}\n<")).count(), 2, "{name}");
        }
        assert!(image::load_from_memory(&a.png).is_ok());
        if std::env::var_os("FEMU_WRITE_FIGURES").is_some() {
            std::fs::write("/tmp/mesh_plot_example.png", &a.png).unwrap();
        }
    }

    /// The triad follows the view: `z` points straight up on the screen from the default view
    /// and vanishes into the screen from above, where `x` points right and `y` up.
    #[test]
    fn triad_follows_the_view() {
        let close =
            |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12;
        let t = triad(View::default());
        assert_eq!(t.map(|a| a.0), ["x", "y", "z"]);
        let e = 30f64.to_radians();
        assert!(close(t[2].1, (0.0, -e.cos())));
        assert!(
            t[0].1.0 > 0.0 && t[1].1.0 > 0.0,
            "x and y both lean right from azimuth −60°"
        );
        let top = triad(View {
            azimuth_deg: -90.0,
            elevation_deg: 90.0,
        });
        assert!(close(top[0].1, (1.0, 0.0)));
        assert!(close(top[1].1, (0.0, -1.0)));
        assert!(top[2].1.0.hypot(top[2].1.1) < 1e-12);
    }

    /// The shared fit centres the points in the box and keeps the aspect ratio.
    #[test]
    fn fit_centres_and_keeps_aspect() {
        let pts = [(0.0, 0.0), (2.0, 1.0)];
        let f = Fit::new(&pts, (100.0, 50.0, 400.0, 300.0), 20.0);
        assert_eq!(f.s, 180.0);
        assert_eq!(f.px(&(1.0, 0.5)), (300, 200));
        assert_eq!(f.px(&(0.0, 0.0)), (120, 290));
        // Nothing finite: a unit box around the origin.
        let g = Fit::new(&[(f64::NAN, 0.0)], (0.0, 0.0, 200.0, 200.0), 0.0);
        assert_eq!(g.px(&(0.0, 0.0)), (100, 100));
    }
}
