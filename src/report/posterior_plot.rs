//! Figures of a posterior's samples (docs/theory.md §12, §15): the marginal histogram of every
//! parameter, with the Laplace Gaussian `N(φ̂_j, s_j²)` drawn over it as a density when given,
//! and the pair plot (scatter of every pair of parameters below the diagonal, the histograms on
//! it). The truth, where known, is a vertical line on the marginals and a cross on the pairs.
//! Equal inputs give byte-identical files.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::figure::{Figure, PlotError, backend_error, render, titled_figure};

/// What to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct PosteriorPlot<'a> {
    /// Figure title.
    pub title: String,
    /// Parameter names.
    pub names: Vec<String>,
    /// Samples, `samples × parameters`.
    pub samples: &'a [Vec<f64>],
    /// The truth per parameter (NaN: unknown); `None`: not known at all.
    pub truth: Option<Vec<f64>>,
    /// A Gaussian per parameter (mean, sd) drawn over the histogram (the Laplace marginals).
    pub gaussian: Option<Vec<(f64, f64)>>,
}

const INK: RGBColor = RGBColor(33, 33, 33);
const BAR: RGBColor = RGBColor(0, 114, 178);
const CURVE: RGBColor = RGBColor(230, 159, 0);
const TRUTH: RGBColor = RGBColor(213, 94, 0);
const PANEL: (u32, u32) = (380, 300);
const PAIR_CELL: u32 = 220;
const TITLE_H: u32 = 44;
/// Parameters in a pair plot at most (the first ones); the marginals show all.
pub const MAX_PAIR_PARAMETERS: usize = 6;
/// Points drawn per scatter at most (every k-th sample beyond).
const MAX_POINTS: usize = 600;
/// Marginal panels per row.
const COLUMNS: usize = 3;
/// Histogram bins.
const BINS: usize = 30;

/// The extent of one parameter over the samples, its truth and ±4 sd of its Gaussian,
/// widened when degenerate.
fn extent(plot: &PosteriorPlot<'_>, j: usize) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut add = |v: f64| {
        if v.is_finite() {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    };
    for s in plot.samples {
        add(s[j]);
    }
    if let Some(t) = &plot.truth {
        add(t[j]);
    }
    if let Some(g) = &plot.gaussian
        && g[j].1.is_finite()
    {
        add(g[j].0 - 4.0 * g[j].1);
        add(g[j].0 + 4.0 * g[j].1);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo <= 1e-12 * lo.abs().max(1e-300) {
        let d = 0.01 * lo.abs().max(1e-12);
        return (lo - d, hi + d);
    }
    let pad = 0.04 * (hi - lo);
    (lo - pad, hi + pad)
}

/// Histogram densities over `BINS` bins of `[lo, hi]`.
fn histogram(values: impl Iterator<Item = f64>, lo: f64, hi: f64) -> Vec<f64> {
    let mut counts = vec![0usize; BINS];
    let mut total = 0usize;
    let w = (hi - lo) / BINS as f64;
    for v in values.filter(|v| v.is_finite()) {
        let b = (((v - lo) / w).floor().max(0.0) as usize).min(BINS - 1);
        counts[b] += 1;
        total += 1;
    }
    counts
        .iter()
        .map(|&c| c as f64 / (total.max(1) as f64 * w))
        .collect()
}

fn check(plot: &PosteriorPlot<'_>) -> Result<(), PlotError> {
    let n = plot.names.len();
    if n == 0 || plot.samples.is_empty() {
        return Err(PlotError::Input(format!(
            "{n} parameter(s), {} sample(s); give at least one of each",
            plot.samples.len()
        )));
    }
    if plot.samples.iter().any(|s| s.len() != n)
        || plot.truth.as_ref().is_some_and(|t| t.len() != n)
        || plot.gaussian.as_ref().is_some_and(|g| g.len() != n)
    {
        return Err(PlotError::Input(format!(
            "every sample, the truth and the Gaussian need one value per parameter ({n})"
        )));
    }
    Ok(())
}

/// The marginal histograms, one panel per parameter.
pub fn marginal_plot(plot: &PosteriorPlot<'_>) -> Result<Figure, PlotError> {
    check(plot)?;
    let n = plot.names.len();
    let columns = COLUMNS.min(n);
    let rows = n.div_ceil(columns);
    let (w, h) = (PANEL.0 * columns as u32, TITLE_H + PANEL.1 * rows as u32);
    render(w, h, &|root| draw_marginals(root, plot, columns), &|root| {
        draw_marginals(root, plot, columns)
    })
}

fn draw_marginals<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &PosteriorPlot<'_>,
    columns: usize,
) -> Result<(), PlotError> {
    let body = titled_figure(root, &plot.title, TITLE_H, &INK)?;
    let rows = plot.names.len().div_ceil(columns);
    let cells = body.split_evenly((rows, columns));
    for (j, cell) in cells.iter().enumerate().take(plot.names.len()) {
        draw_histogram(cell, plot, j, true)?;
    }
    Ok(())
}

/// One histogram of parameter `j`, with its Gaussian and truth; `labels`: axis labels and
/// caption.
fn draw_histogram<DB: DrawingBackend>(
    cell: &DrawingArea<DB, Shift>,
    plot: &PosteriorPlot<'_>,
    j: usize,
    labels: bool,
) -> Result<(), PlotError> {
    let (lo, hi) = extent(plot, j);
    let dens = histogram(plot.samples.iter().map(|s| s[j]), lo, hi);
    let gauss = plot.gaussian.as_ref().map(|g| g[j]);
    let curve: Vec<(f64, f64)> = match gauss {
        Some((m, s)) if s.is_finite() && s > 0.0 => (0..=200)
            .map(|k| {
                let x = lo + (hi - lo) * k as f64 / 200.0;
                let z = (x - m) / s;
                (
                    x,
                    (-0.5 * z * z).exp() / (s * (2.0 * std::f64::consts::PI).sqrt()),
                )
            })
            .collect(),
        _ => Vec::new(),
    };
    let top = dens
        .iter()
        .chain(curve.iter().map(|c| &c.1))
        .copied()
        .fold(0.0, f64::max);
    let top = if top > 0.0 { 1.08 * top } else { 1.0 };
    let mut builder = ChartBuilder::on(cell);
    builder
        .margin(10)
        .x_label_area_size(if labels { 34 } else { 18 });
    builder.y_label_area_size(if labels { 50 } else { 8 });
    if labels {
        builder.caption(&plot.names[j], ("sans-serif", 15).into_font().color(&INK));
    }
    let mut chart = builder
        .build_cartesian_2d(lo..hi, 0.0..top)
        .map_err(backend_error)?;
    chart
        .configure_mesh()
        .x_labels(4)
        .y_labels(if labels { 4 } else { 0 })
        .x_label_formatter(&|v| format!("{v:.3e}"))
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .label_style(("sans-serif", 11).into_font().color(&INK))
        .bold_line_style(RGBColor(225, 225, 225).stroke_width(1))
        .light_line_style(WHITE.stroke_width(0))
        .axis_style(INK.stroke_width(1))
        .draw()
        .map_err(backend_error)?;
    let bw = (hi - lo) / BINS as f64;
    chart
        .draw_series(dens.iter().enumerate().map(|(b, &d)| {
            let x0 = lo + b as f64 * bw;
            Rectangle::new([(x0, 0.0), (x0 + bw, d)], BAR.mix(0.6).filled())
        }))
        .map_err(backend_error)?;
    if !curve.is_empty() {
        chart
            .draw_series(LineSeries::new(curve, CURVE.stroke_width(2)))
            .map_err(backend_error)?;
    }
    if let Some(t) = plot.truth.as_ref().map(|t| t[j])
        && t.is_finite()
    {
        chart
            .draw_series(LineSeries::new([(t, 0.0), (t, top)], TRUTH.stroke_width(2)))
            .map_err(backend_error)?;
    }
    Ok(())
}

/// The pair plot of the first [`MAX_PAIR_PARAMETERS`] parameters: scatters below the
/// diagonal, histograms on it, names along the left and bottom.
pub fn pair_plot(plot: &PosteriorPlot<'_>) -> Result<Figure, PlotError> {
    check(plot)?;
    let n = plot.names.len().min(MAX_PAIR_PARAMETERS);
    let side = 40 + PAIR_CELL * n as u32;
    render(
        side,
        TITLE_H + side,
        &|root| draw_pairs(root, plot, n),
        &|root| draw_pairs(root, plot, n),
    )
}

fn draw_pairs<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &PosteriorPlot<'_>,
    n: usize,
) -> Result<(), PlotError> {
    let body = titled_figure(root, &plot.title, TITLE_H, &INK)?;
    let (left, rest) = body.split_horizontally(40);
    let (grid, bottom) = rest.split_vertically(PAIR_CELL * n as u32);
    let _ = bottom;
    let font = ("sans-serif", 14).into_font().color(&INK);
    let cells = grid.split_evenly((n, n));
    let step = plot.samples.len().div_ceil(MAX_POINTS).max(1);
    for i in 0..n {
        // Row names down the left side.
        let y = (i as u32 * PAIR_CELL + PAIR_CELL / 2) as i32;
        left.draw(&Text::new(plot.names[i].clone(), (4, y), font.clone()))
            .map_err(backend_error)?;
        for j in 0..n {
            let cell = &cells[i * n + j];
            if i == j {
                draw_histogram(cell, plot, j, false)?;
                cell.draw(&Text::new(plot.names[j].clone(), (14, 6), font.clone()))
                    .map_err(backend_error)?;
                continue;
            }
            if j > i {
                continue;
            }
            let (xl, xh) = extent(plot, j);
            let (yl, yh) = extent(plot, i);
            let mut chart = ChartBuilder::on(cell)
                .margin(10)
                .x_label_area_size(18)
                .y_label_area_size(8)
                .build_cartesian_2d(xl..xh, yl..yh)
                .map_err(backend_error)?;
            chart
                .configure_mesh()
                .x_labels(3)
                .y_labels(0)
                .x_label_formatter(&|v| format!("{v:.2e}"))
                .label_style(("sans-serif", 10).into_font().color(&INK))
                .bold_line_style(RGBColor(225, 225, 225).stroke_width(1))
                .light_line_style(WHITE.stroke_width(0))
                .axis_style(INK.stroke_width(1))
                .draw()
                .map_err(backend_error)?;
            chart
                .draw_series(
                    plot.samples
                        .iter()
                        .step_by(step)
                        .filter(|s| s[i].is_finite() && s[j].is_finite())
                        .map(|s| Circle::new((s[j], s[i]), 2, BAR.mix(0.5).filled())),
                )
                .map_err(backend_error)?;
            if let Some(t) = &plot.truth
                && t[i].is_finite()
                && t[j].is_finite()
            {
                chart
                    .draw_series([Cross::new((t[j], t[i]), 6, TRUTH.stroke_width(2))])
                    .map_err(backend_error)?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_deterministic_and_checked() {
        let samples: Vec<Vec<f64>> = (0..500)
            .map(|k| {
                let a = (k as f64 * 0.731).sin();
                let b = (k as f64 * 1.37).cos();
                vec![1.0 + 0.01 * a, 2.0 + 0.02 * (a + b), 3.0 + 0.005 * b]
            })
            .collect();
        let plot = PosteriorPlot {
            title: "posterior".into(),
            names: vec!["m1".into(), "m2".into(), "k".into()],
            samples: &samples,
            truth: Some(vec![1.0, f64::NAN, 3.001]),
            gaussian: Some(vec![(1.0, 0.007), (2.0, 0.014), (3.0, 0.0035)]),
        };
        let m = marginal_plot(&plot).unwrap();
        assert_eq!(m, marginal_plot(&plot).unwrap());
        assert!(m.png.starts_with(b"\x89PNG"));
        let p = pair_plot(&plot).unwrap();
        assert_eq!(p, pair_plot(&plot).unwrap());
        assert!(p.svg.contains("m2"));
        let bad = PosteriorPlot {
            truth: Some(vec![1.0]),
            ..plot.clone()
        };
        assert!(marginal_plot(&bad).is_err());
        // Identical samples still draw.
        let same = vec![vec![1.0]; 10];
        let one = PosteriorPlot {
            title: "t".into(),
            names: vec!["a".into()],
            samples: &same,
            truth: None,
            gaussian: None,
        };
        marginal_plot(&one).unwrap();
        pair_plot(&one).unwrap();
    }
}
