//! The FRF overlay of a posterior (docs/theory.md §12): per FRF, the predicted `|H|` at the
//! mode with its predictive band `± 2 sd` shaded, and the measured `|H|` at the same lines, on
//! a logarithmic axis. Equal inputs give byte-identical files.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::figure::{Figure, PlotError, backend_error, render, titled_figure};

/// One FRF's panel.
#[derive(Clone, Debug, PartialEq)]
pub struct BandPanel {
    /// `response/excitation`.
    pub label: String,
    /// The lines, Hz, ascending.
    pub freqs_hz: Vec<f64>,
    /// Predicted `|H|` at the mode.
    pub value: Vec<f64>,
    /// Its standard deviation (NaN where unknown: no band there).
    pub sd: Vec<f64>,
    /// Measured `|H|` at the same lines (NaN: not measured there).
    pub measured: Vec<f64>,
}

/// What to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct BandPlot {
    /// Figure title.
    pub title: String,
    /// One panel per FRF.
    pub panels: Vec<BandPanel>,
    /// The unit of `|H|` for the axis label.
    pub unit: String,
}

const INK: RGBColor = RGBColor(33, 33, 33);
const BAND: RGBColor = RGBColor(0, 114, 178);
const MEASURED: RGBColor = RGBColor(213, 94, 0);
const PANEL: (u32, u32) = (560, 300);
const TITLE_H: u32 = 44;
/// Panels per row.
const COLUMNS: usize = 2;
/// FRFs drawn at most (the first ones).
pub const MAX_PANELS: usize = 12;

/// The overlay, one panel per FRF (the first [`MAX_PANELS`]).
pub fn band_plot(plot: &BandPlot) -> Result<Figure, PlotError> {
    let panels = &plot.panels[..plot.panels.len().min(MAX_PANELS)];
    if panels.is_empty() {
        return Err(PlotError::Input("no FRF has a predictive band".into()));
    }
    for p in panels {
        let n = p.freqs_hz.len();
        if n < 2 || p.value.len() != n || p.sd.len() != n || p.measured.len() != n {
            return Err(PlotError::Input(format!(
                "the band of {} needs at least two lines and one value, sd and measurement per line",
                p.label
            )));
        }
    }
    let columns = COLUMNS.min(panels.len());
    let rows = panels.len().div_ceil(columns);
    let (w, h) = (PANEL.0 * columns as u32, TITLE_H + PANEL.1 * rows as u32);
    render(w, h, &|root| draw(root, plot, panels, columns), &|root| {
        draw(root, plot, panels, columns)
    })
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &BandPlot,
    panels: &[BandPanel],
    columns: usize,
) -> Result<(), PlotError> {
    let body = titled_figure(root, &plot.title, TITLE_H, &INK)?;
    let rows = panels.len().div_ceil(columns);
    let cells = body.split_evenly((rows, columns));
    for (p, cell) in panels.iter().zip(&cells) {
        draw_panel(cell, p, &plot.unit)?;
    }
    Ok(())
}

/// One FRF: the band as a shaded polygon between `|H| ∓ 2 sd` (the lower edge floored at a
/// thousandth of the smallest positive value, the axis being logarithmic), `|H|` as a line,
/// the measurement as dots.
fn draw_panel<DB: DrawingBackend>(
    cell: &DrawingArea<DB, Shift>,
    p: &BandPanel,
    unit: &str,
) -> Result<(), PlotError> {
    let positive = p
        .value
        .iter()
        .chain(&p.measured)
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = positive.fold((f64::INFINITY, 0.0_f64), |(a, b), v| (a.min(v), b.max(v)));
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo / 2.0, hi * 2.0)
    } else {
        (1e-12, 1.0)
    };
    let floor = lo;
    let (f0, f1) = (p.freqs_hz[0], p.freqs_hz[p.freqs_hz.len() - 1]);
    let mut chart = ChartBuilder::on(cell)
        .margin(10)
        .caption(&p.label, ("sans-serif", 15).into_font().color(&INK))
        .x_label_area_size(34)
        .y_label_area_size(60)
        .build_cartesian_2d(f0..f1, (lo..hi).log_scale())
        .map_err(backend_error)?;
    chart
        .configure_mesh()
        .x_labels(6)
        .y_labels(5)
        .x_desc("Hz")
        .y_desc(format!("|H| ({unit})"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 11).into_font().color(&INK))
        .bold_line_style(RGBColor(225, 225, 225).stroke_width(1))
        .light_line_style(WHITE.stroke_width(0))
        .axis_style(INK.stroke_width(1))
        .draw()
        .map_err(backend_error)?;
    let edge = |sign: f64| -> Vec<(f64, f64)> {
        (0..p.freqs_hz.len())
            .filter(|&k| p.sd[k].is_finite() && p.value[k].is_finite())
            .map(|k| {
                let v = (p.value[k] + sign * 2.0 * p.sd[k]).clamp(floor, hi);
                (p.freqs_hz[k], v)
            })
            .collect()
    };
    let (upper, mut lower) = (edge(1.0), edge(-1.0));
    if upper.len() >= 2 {
        lower.reverse();
        let outline: Vec<(f64, f64)> = upper.into_iter().chain(lower).collect();
        chart
            .draw_series(std::iter::once(Polygon::new(
                outline,
                BAND.mix(0.25).filled(),
            )))
            .map_err(backend_error)?;
    }
    let line: Vec<(f64, f64)> = (0..p.freqs_hz.len())
        .filter(|&k| p.value[k].is_finite() && p.value[k] > 0.0)
        .map(|k| (p.freqs_hz[k], p.value[k]))
        .collect();
    chart
        .draw_series(LineSeries::new(line, BAND.stroke_width(2)))
        .map_err(backend_error)?;
    chart
        .draw_series(
            (0..p.freqs_hz.len())
                .filter(|&k| p.measured[k].is_finite() && p.measured[k] > 0.0)
                .map(|k| Circle::new((p.freqs_hz[k], p.measured[k]), 2, MEASURED.filled())),
        )
        .map_err(backend_error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn panel(label: &str) -> BandPanel {
        let freqs_hz: Vec<f64> = (1..=80).map(|k| 0.5 * k as f64).collect();
        let value: Vec<f64> = freqs_hz
            .iter()
            .map(|f| 1e-4 / ((1.0 - (f / 16.0f64).powi(2)).abs() + 0.02))
            .collect();
        let sd = value.iter().map(|v| 0.05 * v).collect();
        let measured = value
            .iter()
            .enumerate()
            .map(|(k, v)| v * (1.0 + 0.03 * (k as f64).sin()))
            .collect();
        BandPanel {
            label: label.into(),
            freqs_hz,
            value,
            sd,
            measured,
        }
    }

    /// Equal inputs give equal files; a panel without a value per line, or with one line, is
    /// refused by name as the data's limit.
    #[test]
    fn band_figure_is_deterministic_and_checked() {
        let plot = BandPlot {
            title: "predictive band".into(),
            panels: vec![panel("1:ux/1:ux"), panel("2:ux/1:ux"), panel("3:ux/1:ux")],
            unit: "m/N".into(),
        };
        let a = band_plot(&plot).unwrap();
        let b = band_plot(&plot).unwrap();
        assert_eq!(a.png, b.png);
        assert_eq!(a.svg, b.svg);
        assert!(a.svg.contains("2:ux/1:ux"));
        let mut bad = plot.clone();
        bad.panels[1].sd.pop();
        let e = band_plot(&bad).unwrap_err().to_string();
        assert!(e.contains("2:ux/1:ux"), "{e}");
        // A band at one line (an update at single lines) is the data's limit, not a fault of
        // the backend.
        let mut single = plot.clone();
        for p in &mut single.panels {
            p.freqs_hz.truncate(1);
            p.value.truncate(1);
            p.sd.truncate(1);
            p.measured.truncate(1);
        }
        let e = band_plot(&single).unwrap_err();
        assert!(matches!(e, PlotError::Input(_)), "{e:?}");
        assert!(!e.to_string().contains("backend"), "{e}");
    }
}
