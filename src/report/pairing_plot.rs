//! Test points over the model (the pairing of docs/theory.md §14): the mesh in light grey,
//! seen along a fixed view as in [`super::mesh_plot`], each aligned test point a dot coloured by
//! its pairing distance on a scale up to the tolerance, labelled with its node, and ringed in
//! red when beyond the tolerance, with the orientation triad of the mesh plots. Equal inputs give
//! byte-identical files.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::figure::{Figure, PlotError, backend_error, render, text_style};
use super::mesh_plot::{EDGE, Fit, NO_VALUE, SEQUENTIAL, View, axes, dot, draw_triad, items, ramp};
use crate::model::Model;

/// One test point to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotPoint {
    /// Test node label.
    pub node: u64,
    /// Aligned position in model coordinates, m.
    pub xyz: [f64; 3],
    /// Pairing distance, m.
    pub distance: f64,
    /// Whether `distance` is within the tolerance.
    pub within: bool,
}

/// What to draw.
#[derive(Clone, Debug)]
pub struct PairingPlot<'a> {
    /// Figure title.
    pub title: String,
    /// The mesh.
    pub model: &'a Model,
    /// The test points.
    pub points: Vec<PlotPoint>,
    /// The tolerance, m: the top of the colour scale.
    pub tolerance: f64,
    /// Viewing direction.
    pub view: View,
}

const INK: RGBColor = RGBColor(33, 33, 33);
const MARK: RGBColor = RGBColor(220, 20, 30);
const SIZE: (u32, u32) = (820, 600);
const TITLE_H: u32 = 44;
const BAR_W: u32 = 130;

fn text<'a>(size: f64, bold: bool, pos: Pos) -> TextStyle<'a> {
    let style = if bold {
        FontStyle::Bold
    } else {
        FontStyle::Normal
    };
    text_style(size, style, INK, pos)
}

/// Renders the figure as PNG and SVG.
pub fn pairing_plot(plot: &PairingPlot<'_>) -> Result<Figure, PlotError> {
    let (w, h) = (SIZE.0 + BAR_W, SIZE.1 + TITLE_H);
    render(w, h, &|root| draw(root, plot), &|root| draw(root, plot))
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &PairingPlot<'_>,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(backend_error)?;
    let centre = Pos::new(HPos::Center, VPos::Center);
    root.draw(&Text::new(
        plot.title.clone(),
        (SIZE.0 as i32 / 2, TITLE_H as i32 / 2),
        text(20.0, true, centre),
    ))
    .map_err(backend_error)?;
    let faces = items(plot.model, plot.view);
    let (right, up, _) = axes(plot.view);
    let projected: Vec<(f64, f64)> = plot
        .points
        .iter()
        .map(|p| (dot(p.xyz, right), dot(p.xyz, up)))
        .collect();
    // One fit for the mesh and the points.
    let (pw, ph) = (SIZE.0 as f64, SIZE.1 as f64);
    let fit = Fit::new(
        faces.iter().flat_map(|i| &i.points).chain(&projected),
        (0.0, TITLE_H as f64, pw, ph),
        40.0,
    );
    let px = |p: &(f64, f64)| fit.px(p);
    for item in &faces {
        let pts: Vec<(i32, i32)> = item.points.iter().map(px).collect();
        if item.face {
            root.draw(&Polygon::new(pts.clone(), NO_VALUE.filled()))
                .map_err(backend_error)?;
            let mut ring = pts.clone();
            ring.push(pts[0]);
            root.draw(&PathElement::new(ring, EDGE.stroke_width(1)))
                .map_err(backend_error)?;
        } else {
            root.draw(&PathElement::new(pts, EDGE.stroke_width(3)))
                .map_err(backend_error)?;
        }
    }
    let tol = plot.tolerance;
    for (p, q) in plot.points.iter().zip(&projected) {
        if !(q.0.is_finite() && q.1.is_finite()) {
            continue;
        }
        let c = px(q);
        let t = if tol > 0.0 { p.distance / tol } else { 1.0 };
        let fill = ramp(&SEQUENTIAL, t);
        if !p.within {
            root.draw(&Circle::new(c, 10, MARK.stroke_width(3)))
                .map_err(backend_error)?;
        }
        root.draw(&Circle::new(c, 6, fill.filled()))
            .map_err(backend_error)?;
        root.draw(&Circle::new(c, 6, INK.stroke_width(1)))
            .map_err(backend_error)?;
        root.draw(&Text::new(
            p.node.to_string(),
            (c.0 + 9, c.1 - 9),
            text(11.0, false, Pos::new(HPos::Left, VPos::Bottom)),
        ))
        .map_err(backend_error)?;
    }
    draw_triad(
        root,
        plot.view,
        (48, TITLE_H as i32 + SIZE.1 as i32 - 48),
        30.0,
    )?;
    colour_bar(root, plot)
}

fn colour_bar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &PairingPlot<'_>,
) -> Result<(), PlotError> {
    let bx = SIZE.0 as i32 + 18;
    let (by0, by1) = (TITLE_H as i32 + 60, TITLE_H as i32 + SIZE.1 as i32 - 110);
    let steps = 120;
    for i in 0..steps {
        let (t0, t1) = (i as f64 / steps as f64, (i + 1) as f64 / steps as f64);
        let ya = by1 - ((by1 - by0) as f64 * t1).round() as i32;
        let yb = by1 - ((by1 - by0) as f64 * t0).round() as i32;
        root.draw(&Rectangle::new(
            [(bx, ya), (bx + 22, yb)],
            ramp(&SEQUENTIAL, (t0 + t1) / 2.0).filled(),
        ))
        .map_err(backend_error)?;
    }
    root.draw(&Rectangle::new(
        [(bx, by0), (bx + 22, by1)],
        INK.stroke_width(1),
    ))
    .map_err(backend_error)?;
    for i in 0..=4 {
        let t = i as f64 / 4.0;
        let y = by1 - ((by1 - by0) as f64 * t).round() as i32;
        root.draw(&PathElement::new(
            vec![(bx + 22, y), (bx + 27, y)],
            INK.stroke_width(1),
        ))
        .map_err(backend_error)?;
        root.draw(&Text::new(
            format!("{:.3}", plot.tolerance * t * 1e3),
            (bx + 30, y),
            text(12.0, false, Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(backend_error)?;
    }
    root.draw(&Text::new(
        "distance, mm".to_string(),
        (bx + 11, by0 - 22),
        text(12.0, false, Pos::new(HPos::Center, VPos::Center)),
    ))
    .map_err(backend_error)?;
    let ly = by1 + 30;
    root.draw(&Circle::new((bx + 6, ly), 8, MARK.stroke_width(3)))
        .map_err(backend_error)?;
    root.draw(&Text::new(
        "beyond tolerance".to_string(),
        (bx + 20, ly),
        text(12.0, false, Pos::new(HPos::Left, VPos::Center)),
    ))
    .map_err(backend_error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::generate::{FlatPlate, PlateSupport, flat_plate, steel};

    #[test]
    fn draws_points_over_the_mesh_deterministically() {
        let model = flat_plate(&FlatPlate {
            a: 0.4,
            b: 0.3,
            nx: 4,
            ny: 3,
            thickness: 0.002,
            material: steel(),
            support: PlateSupport::Free,
        });
        let plot = PairingPlot {
            title: "pairing".into(),
            model: &model,
            points: vec![
                PlotPoint {
                    node: 1,
                    xyz: [0.1, 0.1, 0.0],
                    distance: 0.0,
                    within: true,
                },
                PlotPoint {
                    node: 9001,
                    xyz: [0.15, 0.12, 0.01],
                    distance: 0.01,
                    within: false,
                },
            ],
            tolerance: 0.005,
            view: View::default(),
        };
        let a = pairing_plot(&plot).unwrap();
        assert_eq!(a, pairing_plot(&plot).unwrap());
        assert!(a.png.starts_with(b"\x89PNG") && a.svg.contains("9001"));
        crate::report::mac_plot::check::svg_elements(&a.svg).unwrap();
        assert_eq!(
            crate::report::mac_plot::check::count_with(&a.svg, "text", "font-style=\"italic\""),
            3,
            "one orientation triad"
        );
        assert!(image::load_from_memory(&a.png).is_ok());
    }
}
