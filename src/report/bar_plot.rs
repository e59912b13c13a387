//! Bar charts of one value per named item (leverage per candidate, eigenvalue sensitivity per
//! candidate and mode), one panel per series, as PNG and SVG. Marked bars (e.g. the known error)
//! are drawn in a second colour. Equal inputs give byte-identical files.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::figure::{Figure, PlotError, backend_error, render, titled_figure};

/// One panel.
#[derive(Clone, Debug, PartialEq)]
pub struct BarPanel {
    /// Panel title.
    pub title: String,
    /// Bar labels, in drawing order.
    pub labels: Vec<String>,
    /// Bar heights (non-finite values are drawn as 0).
    pub values: Vec<f64>,
    /// Bars drawn in the marking colour.
    pub marked: Vec<bool>,
    /// Draw `|value|` on a logarithmic axis (zero and non-finite values get no bar).
    pub log: bool,
}

/// What to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct BarPlot {
    /// Figure title.
    pub title: String,
    /// Value axis label.
    pub y_label: String,
    /// Panels, row by row.
    pub panels: Vec<BarPanel>,
    /// Panels per row.
    pub columns: usize,
    /// Legend text of marked bars (empty: no legend).
    pub marked_label: String,
}

const INK: RGBColor = RGBColor(33, 33, 33);
const BAR: RGBColor = RGBColor(0, 114, 178);
const MARK: RGBColor = RGBColor(213, 94, 0);
const PANEL: (u32, u32) = (620, 360);
const TITLE_H: u32 = 44;
/// Most tick labels on the category axis; beyond, every k-th bar is labelled.
const MAX_LABELS: usize = 28;

/// Renders the chart as PNG and SVG.
pub fn bar_plot(plot: &BarPlot) -> Result<Figure, PlotError> {
    let columns = plot.columns.clamp(1, plot.panels.len().max(1));
    let rows = plot.panels.len().max(1).div_ceil(columns);
    let (w, h) = (PANEL.0 * columns as u32, TITLE_H + PANEL.1 * rows as u32);
    render(w, h, &|root| draw(root, plot, columns), &|root| {
        draw(root, plot, columns)
    })
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &BarPlot,
    columns: usize,
) -> Result<(), PlotError> {
    let body = titled_figure(root, &plot.title, TITLE_H, &INK)?;
    let rows = plot.panels.len().max(1).div_ceil(columns);
    let cells = body.split_evenly((rows, columns));
    for (panel, cell) in plot.panels.iter().zip(cells.iter()) {
        draw_panel(cell, plot, panel)?;
    }
    Ok(())
}

/// One panel: its bars (marked ones in the mark colour) on a linear or log axis, and the
/// marked bars' legend.
fn draw_panel<DB: DrawingBackend>(
    cell: &DrawingArea<DB, Shift>,
    plot: &BarPlot,
    panel: &BarPanel,
) -> Result<(), PlotError> {
    let n = panel.values.len();
    let finite = |v: &f64| if v.is_finite() { *v } else { 0.0 };
    let (heights, y_lo, y_hi, base) = bar_heights(panel);
    let mut chart = ChartBuilder::on(cell)
        .caption(&panel.title, ("sans-serif", 16).into_font().color(&INK))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(-0.5..(n.max(1) as f64 - 0.5), y_lo..y_hi)
        .map_err(backend_error)?;
    let step = n.div_ceil(MAX_LABELS).max(1);
    let labels = panel.labels.clone();
    let x_fmt = move |v: &f64| {
        let i = v.round();
        if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < labels.len() {
            labels[i as usize].clone()
        } else {
            String::new()
        }
    };
    let log = panel.log;
    let y_fmt = move |v: &f64| {
        if log {
            // Decades only: 10^k at integer k.
            let k = v.round();
            return if (v - k).abs() < 1e-9 {
                format!("1e{k:.0}")
            } else {
                String::new()
            };
        }
        let s = format!("{v:.2}");
        if s == "-0.00" { "0.00".into() } else { s }
    };
    chart
        .configure_mesh()
        .x_labels(n.div_ceil(step).max(1))
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .y_desc(&plot.y_label)
        .label_style(("sans-serif", 12).into_font().color(&INK))
        .axis_desc_style(("sans-serif", 14).into_font().color(&INK))
        .bold_line_style(RGBColor(225, 225, 225).stroke_width(1))
        .light_line_style(WHITE.stroke_width(0))
        .axis_style(INK.stroke_width(1))
        .disable_x_mesh()
        .draw()
        .map_err(backend_error)?;
    let area = chart.plotting_area();
    for (i, v) in heights.iter().enumerate() {
        if panel.log && !v.is_finite() {
            continue;
        }
        let colour = if panel.marked.get(i).copied().unwrap_or(false) {
            MARK
        } else {
            BAR
        };
        let x = i as f64;
        area.draw(&Rectangle::new(
            [(x - 0.38, base), (x + 0.38, finite(v))],
            colour.filled(),
        ))
        .map_err(backend_error)?;
    }
    if !plot.marked_label.is_empty() && panel.marked.iter().any(|m| *m) {
        let (pw, _) = cell.dim_in_pixel();
        let x = pw as i32 - 30 - 7 * plot.marked_label.chars().count() as i32;
        cell.draw(&Rectangle::new([(x, 30), (x + 12, 42)], MARK.filled()))
            .map_err(backend_error)?;
        cell.draw(&Text::new(
            plot.marked_label.clone(),
            (x + 16, 30),
            ("sans-serif", 12).into_font().color(&INK),
        ))
        .map_err(backend_error)?;
    }
    Ok(())
}

/// The bars' heights on the drawn axis (log10 of the magnitude on a log axis, NaN where
/// nothing is drawn), the axis range and the base the bars rise from.
fn bar_heights(panel: &BarPanel) -> (Vec<f64>, f64, f64, f64) {
    let finite = |v: &f64| if v.is_finite() { *v } else { 0.0 };
    if panel.log {
        let h: Vec<f64> = panel
            .values
            .iter()
            .map(|v| {
                if v.is_finite() && *v != 0.0 {
                    v.abs().log10()
                } else {
                    f64::NAN
                }
            })
            .collect();
        let shown = h.iter().copied().filter(|v| v.is_finite());
        let lo = shown.clone().fold(f64::INFINITY, f64::min).floor();
        let hi = shown.fold(f64::NEG_INFINITY, f64::max).ceil();
        let (lo, hi) = if lo.is_finite() && hi > lo {
            (lo, hi)
        } else if lo.is_finite() {
            (lo, lo + 1.0)
        } else {
            (0.0, 1.0)
        };
        (h, lo, hi, lo)
    } else {
        let lo = panel.values.iter().map(finite).fold(0.0_f64, f64::min);
        let hi = panel.values.iter().map(finite).fold(0.0_f64, f64::max);
        let (lo, hi) = if hi > lo { (lo, hi) } else { (0.0, 1.0) };
        let pad = 0.05 * (hi - lo);
        let y_lo = if lo < 0.0 { lo - pad } else { 0.0 };
        (panel.values.clone(), y_lo, hi + pad, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rendering_is_deterministic() {
        let panel = |title: &str, sign: f64| BarPanel {
            title: title.into(),
            labels: (1..=40).map(|i| format!("e{i}")).collect(),
            values: (1..=40).map(|i| sign * i as f64 / 40.0).collect(),
            marked: (1..=40).map(|i| i == 7).collect(),
            log: sign > 0.0,
        };
        let plot = BarPlot {
            title: "t".into(),
            y_label: "L / max".into(),
            panels: vec![panel("a", 1.0), panel("b", -1.0), panel("c", f64::NAN)],
            columns: 2,
            marked_label: "marked".into(),
        };
        let a = bar_plot(&plot).unwrap();
        assert_eq!(a, bar_plot(&plot).unwrap());
        assert!(a.png.starts_with(b"\x89PNG"));
    }
}
