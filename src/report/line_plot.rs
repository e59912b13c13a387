//! Line charts of values against an integer step (an updating run's parameter and correlation
//! history), one panel per quantity stacked vertically, as PNG and SVG. Each series may carry a
//! reference value (the known truth), drawn as a dashed line in the series' colour. Equal inputs
//! give byte-identical files.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::figure::{Figure, PlotError, backend_error, render, titled_figure};

/// One line.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Legend text.
    pub label: String,
    /// Value at each step `0, 1, …` (non-finite values break the line).
    pub values: Vec<f64>,
    /// A reference level drawn dashed in the same colour.
    pub reference: Option<f64>,
}

/// One panel.
#[derive(Clone, Debug, PartialEq)]
pub struct LinePanel {
    /// Panel title.
    pub title: String,
    /// Value axis label.
    pub y_label: String,
    /// Lines, in legend order.
    pub series: Vec<Line>,
}

/// What to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct LinePlot {
    /// Figure title.
    pub title: String,
    /// Step axis label.
    pub x_label: String,
    /// Panels, top to bottom.
    pub panels: Vec<LinePanel>,
}

const INK: RGBColor = RGBColor(33, 33, 33);
/// Colour-blind-safe palette (Okabe–Ito), then darker variants.
const PALETTE: [RGBColor; 12] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(120, 120, 120),
    RGBColor(0, 0, 0),
    RGBColor(0, 70, 110),
    RGBColor(140, 60, 0),
    RGBColor(0, 100, 70),
    RGBColor(130, 70, 110),
];
const PANEL: (u32, u32) = (960, 400);
const TITLE_H: u32 = 44;
const LEGEND_W: u32 = 150;

/// Renders the chart as PNG and SVG.
pub fn line_plot(plot: &LinePlot) -> Result<Figure, PlotError> {
    let rows = plot.panels.len().max(1) as u32;
    let (w, h) = (PANEL.0 + LEGEND_W, TITLE_H + PANEL.1 * rows);
    render(w, h, &|root| draw(root, plot), &|root| draw(root, plot))
}

/// The value range of a panel (values and references), padded by 5 %.
fn value_range(panel: &LinePanel) -> (f64, f64) {
    let all = panel
        .series
        .iter()
        .flat_map(|s| s.values.iter().copied().chain(s.reference))
        .filter(|v| v.is_finite());
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        0.05 * lo.abs().max(1e-12)
    };
    (lo - pad, hi + pad)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &LinePlot,
) -> Result<(), PlotError> {
    let body = titled_figure(root, &plot.title, TITLE_H, &INK)?;
    let cells = body.split_evenly((plot.panels.len().max(1), 1));
    for (panel, cell) in plot.panels.iter().zip(cells.iter()) {
        draw_panel(cell, plot, panel)?;
    }
    Ok(())
}

/// One panel: the series as lines with markers over the step axis, their reference levels
/// dashed, and the legend on the right.
fn draw_panel<DB: DrawingBackend>(
    cell: &DrawingArea<DB, Shift>,
    plot: &LinePlot,
    panel: &LinePanel,
) -> Result<(), PlotError> {
    let (chart_area, legend) = cell.split_horizontally(PANEL.0);
    let steps = panel
        .series
        .iter()
        .map(|s| s.values.len())
        .max()
        .unwrap_or(1);
    let x_hi = (steps.max(2) - 1) as f64;
    let (y_lo, y_hi) = value_range(panel);
    let mut chart = ChartBuilder::on(&chart_area)
        .caption(&panel.title, ("sans-serif", 16).into_font().color(&INK))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(-0.2..x_hi + 0.2, y_lo..y_hi)
        .map_err(backend_error)?;
    let x_fmt = |v: &f64| {
        let i = v.round();
        if (v - i).abs() < 1e-6 && i >= 0.0 {
            format!("{i:.0}")
        } else {
            String::new()
        }
    };
    let span = y_hi - y_lo;
    let digits = if span > 0.0 {
        (-(span.log10().floor()) + 1.0).clamp(0.0, 6.0) as usize
    } else {
        3
    };
    let y_fmt = move |v: &f64| {
        let s = format!("{v:.digits$}");
        if s.starts_with('-') && s.trim_start_matches(['-', '0', '.']).is_empty() {
            s[1..].to_string()
        } else {
            s
        }
    };
    chart
        .configure_mesh()
        .x_labels(steps.clamp(2, 21))
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .x_desc(&plot.x_label)
        .y_desc(&panel.y_label)
        .label_style(("sans-serif", 12).into_font().color(&INK))
        .axis_desc_style(("sans-serif", 14).into_font().color(&INK))
        .bold_line_style(RGBColor(225, 225, 225).stroke_width(1))
        .light_line_style(WHITE.stroke_width(0))
        .axis_style(INK.stroke_width(1))
        .draw()
        .map_err(backend_error)?;
    for (k, s) in panel.series.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let runs = finite_runs(&s.values);
        for r in &runs {
            chart
                .draw_series(LineSeries::new(r.iter().copied(), colour.stroke_width(2)))
                .map_err(backend_error)?;
            chart
                .draw_series(r.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(backend_error)?;
        }
        if let Some(level) = s.reference.filter(|v| v.is_finite()) {
            chart
                .draw_series(DashedLineSeries::new(
                    [(-0.2, level), (x_hi + 0.2, level)],
                    8,
                    5,
                    colour.stroke_width(1),
                ))
                .map_err(backend_error)?;
        }
        let y = 40 + 18 * k as i32;
        legend
            .draw(&Rectangle::new([(4, y), (20, y + 3)], colour.filled()))
            .map_err(backend_error)?;
        legend
            .draw(&Text::new(
                s.label.clone(),
                (26, y - 6),
                ("sans-serif", 12).into_font().color(&INK),
            ))
            .map_err(backend_error)?;
    }
    if panel.series.iter().any(|s| s.reference.is_some()) {
        draw_reference_key(&legend, panel.series.len())?;
    }
    Ok(())
}

/// The finite stretches of `values` as separate polylines over the step index.
fn finite_runs(values: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut run: Vec<(f64, f64)> = Vec::new();
    let mut runs = Vec::new();
    for (i, v) in values.iter().enumerate() {
        if v.is_finite() {
            run.push((i as f64, *v));
        } else if !run.is_empty() {
            runs.push(std::mem::take(&mut run));
        }
    }
    if !run.is_empty() {
        runs.push(run);
    }
    runs
}

/// The legend's key for the dashed reference levels, below the `series` entries.
fn draw_reference_key<DB: DrawingBackend>(
    legend: &DrawingArea<DB, Shift>,
    series: usize,
) -> Result<(), PlotError> {
    let y = 40 + 18 * series as i32 + 6;
    legend
        .draw(&PathElement::new(
            vec![(4, y + 1), (9, y + 1)],
            INK.stroke_width(1),
        ))
        .map_err(backend_error)?;
    legend
        .draw(&PathElement::new(
            vec![(14, y + 1), (20, y + 1)],
            INK.stroke_width(1),
        ))
        .map_err(backend_error)?;
    legend
        .draw(&Text::new(
            "true value",
            (26, y - 5),
            ("sans-serif", 12).into_font().color(&INK),
        ))
        .map_err(backend_error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> LinePlot {
        LinePlot {
            title: "Convergence".into(),
            x_label: "iteration".into(),
            panels: vec![
                LinePanel {
                    title: "parameters".into(),
                    y_label: "value / initial".into(),
                    series: vec![
                        Line {
                            label: "t1".into(),
                            values: vec![1.0, 1.4, 1.7, 1.75],
                            reference: Some(1.75),
                        },
                        Line {
                            label: "t2".into(),
                            values: vec![1.0, 0.98, f64::NAN, 1.01],
                            reference: None,
                        },
                    ],
                },
                LinePanel {
                    title: "correlation".into(),
                    y_label: "mean".into(),
                    series: vec![Line {
                        label: "chi_s".into(),
                        values: vec![0.8, 0.9, 0.95, 0.96],
                        reference: None,
                    }],
                },
            ],
        }
    }

    #[test]
    fn renders_deterministically_with_gaps_and_references() {
        let a = line_plot(&example()).unwrap();
        let b = line_plot(&example()).unwrap();
        assert_eq!(a, b);
        assert!(a.png.starts_with(b"\x89PNG"));
        assert!(
            a.svg.contains("true value"),
            "the legend explains the dashed lines"
        );
        // A different history draws a different figure.
        let mut other = example();
        other.panels[0].series[0].values[3] = 1.5;
        assert_ne!(line_plot(&other).unwrap().png, a.png);
    }

    #[test]
    fn an_empty_or_flat_panel_still_draws() {
        let plot = LinePlot {
            title: "flat".into(),
            x_label: "iteration".into(),
            panels: vec![LinePanel {
                title: "one step".into(),
                y_label: "v".into(),
                series: vec![Line {
                    label: "a".into(),
                    values: vec![2.0],
                    reference: None,
                }],
            }],
        };
        assert!(line_plot(&plot).is_ok());
    }
}
