//! Box plots of a distribution per group (e.g. an updated parameter per noise level), optionally
//! split into coloured boxes per series (e.g. per parameter), as PNG and SVG.
//!
//! A box spans the lower and upper quartiles with the median drawn across; quartiles are
//! Hyndman and Fan's type 7 (linear interpolation between order statistics, the default of R and
//! NumPy). Whiskers reach the furthest data within 1.5 interquartile ranges of the box (Tukey);
//! points beyond are drawn one by one. Rendering uses the embedded DejaVu Sans faces, so equal
//! data give byte-identical files on any machine.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::ops::Range;

use super::figure::{Axis, Figure, PALETTE, PlotError, backend_error, nice_step, render};

/// What to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct BoxPlotData {
    /// Figure title.
    pub title: String,
    /// Name of the grouping variable (x axis).
    pub x_label: String,
    /// Name of the value (y axis).
    pub y_label: String,
    /// Series names, one box per series in each group; empty for one unnamed series.
    pub series: Vec<String>,
    /// Groups in order: label and, per series, the values.
    pub groups: Vec<(String, Vec<Vec<f64>>)>,
}

/// The five numbers of a box and its outliers.
#[derive(Clone, Debug, PartialEq)]
pub struct BoxStats {
    /// Lower whisker end.
    pub lo: f64,
    /// Lower quartile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Upper quartile.
    pub q3: f64,
    /// Upper whisker end.
    pub hi: f64,
    /// Values beyond the whiskers.
    pub outliers: Vec<f64>,
    /// Number of values.
    pub n: usize,
}

fn quantile(sorted: &[f64], p: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * p;
    let (i, f) = (h.floor() as usize, h - h.floor());
    match sorted.get(i + 1) {
        Some(next) => sorted[i] + f * (next - sorted[i]),
        None => sorted[i],
    }
}

/// Box statistics of the finite values; `None` when there are none.
pub fn box_stats(values: &[f64]) -> Option<BoxStats> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let (q1, median, q3) = (quantile(&v, 0.25), quantile(&v, 0.5), quantile(&v, 0.75));
    let iqr = q3 - q1;
    let (fence_lo, fence_hi) = (q1 - 1.5 * iqr, q3 + 1.5 * iqr);
    let inside: Vec<f64> = v
        .iter()
        .copied()
        .filter(|x| *x >= fence_lo && *x <= fence_hi)
        .collect();
    Some(BoxStats {
        lo: inside.first().copied().unwrap_or(q1),
        hi: inside.last().copied().unwrap_or(q3),
        outliers: v
            .iter()
            .copied()
            .filter(|x| *x < fence_lo || *x > fence_hi)
            .collect(),
        q1,
        median,
        q3,
        n: v.len(),
    })
}

const INK: RGBColor = RGBColor(33, 33, 33);

/// Figure size in pixels.
const SIZE: (u32, u32) = (1000, 650);

/// The category axis: groups at 0, 1, …, labelled by name.
#[derive(Clone)]
struct Categories {
    labels: Vec<String>,
}

impl Ranged for Categories {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let n = self.labels.len().max(1) as f64;
        let t = (value + 0.5) / n;
        (limit.0 as f64 + t * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            (0..self.labels.len()).map(|i| i as f64).collect()
        }
    }

    fn range(&self) -> Range<f64> {
        -0.5..self.labels.len() as f64 - 0.5
    }
}

/// The value axis: the data range with 6 % headroom, about six ticks at a nice step, no minor
/// ticks.
fn value_axis(lo: f64, hi: f64) -> Axis {
    let (lo, hi) = if hi > lo {
        let pad = (hi - lo) * 0.06;
        (lo - pad, hi + pad)
    } else {
        let half = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        (lo - half, hi + half)
    };
    let step = nice_step((hi - lo) / 6.0);
    let first = (lo / step).ceil() as i64;
    let ticks = (0..40)
        .map(|k| (first + k) as f64 * step)
        .take_while(|v| *v <= hi)
        .map(|v| if v.abs() < step * 1e-9 { 0.0 } else { v })
        .collect();
    Axis {
        lo,
        hi,
        major: ticks,
        minor: Vec::new(),
        decimals: 0,
    }
}

fn tick_label(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.2e}")
    } else {
        let s = format!("{v:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// Renders the box plot as PNG and SVG.
pub fn box_plot(data: &BoxPlotData) -> Result<Figure, PlotError> {
    let (w, h) = SIZE;
    render(w, h, &|root| draw(root, data), &|root| draw(root, data))
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    data: &BoxPlotData,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(backend_error)?;
    let n_series = data.series.len().max(1);
    let stats: Vec<Vec<Option<BoxStats>>> = data
        .groups
        .iter()
        .map(|(_, s)| s.iter().map(|v| box_stats(v)).collect())
        .collect();
    let (lo, hi) = value_extent(&stats);
    let y = value_axis(lo, hi);
    let x = Categories {
        labels: data.groups.iter().map(|g| g.0.clone()).collect(),
    };
    let legend_font = TextStyle::from(("sans-serif", 14).into_font());
    let mut legend_w = 0;
    for name in &data.series {
        let (tw, _) = root
            .estimate_text_size(name, &legend_font)
            .map_err(backend_error)?;
        legend_w = legend_w.max(tw as i32 + 56);
    }
    let legend_w = legend_w.min(w_of(root) * 2 / 5);
    let (plot_area, legend) = root.split_horizontally(w_of(root) - legend_w);
    let mut chart = ChartBuilder::on(&plot_area)
        .caption(
            &data.title,
            ("sans-serif", 20, FontStyle::Bold).into_font().color(&INK),
        )
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(80)
        .build_cartesian_2d(x.clone(), y.clone())
        .map_err(backend_error)?;
    let labels = x.labels.clone();
    let x_fmt = move |v: &f64| {
        let i = v.round();
        if i >= 0.0 && (i as usize) < labels.len() {
            labels[i as usize].clone()
        } else {
            String::new()
        }
    };
    let y_fmt = |v: &f64| tick_label(*v);
    chart
        .configure_mesh()
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .x_desc(&data.x_label)
        .y_desc(&data.y_label)
        .label_style(("sans-serif", 14).into_font().color(&INK))
        .axis_desc_style(("sans-serif", 16).into_font().color(&INK))
        .bold_line_style(RGBColor(225, 225, 225).stroke_width(1))
        .axis_style(INK.stroke_width(1))
        .disable_x_mesh()
        .draw()
        .map_err(backend_error)?;
    let slot = 0.8 / n_series as f64;
    let half = slot * 0.38;
    for (g, boxes) in stats.iter().enumerate() {
        for (s, b) in boxes.iter().enumerate() {
            let Some(b) = b else { continue };
            let color = PALETTE[s % PALETTE.len()];
            let cx = g as f64 - 0.4 + slot * (s as f64 + 0.5);
            draw_box(chart.plotting_area(), cx, half, b, color)?;
        }
        let n: usize = boxes.iter().flatten().map(|b| b.n).sum();
        let style = TextStyle::from(("sans-serif", 12).into_font())
            .color(&RGBColor(110, 110, 110))
            .pos(Pos::new(HPos::Center, VPos::Top));
        chart
            .plotting_area()
            .draw(&Text::new(format!("n={n}"), (g as f64, y.hi), style))
            .map_err(backend_error)?;
    }
    if !data.series.is_empty() {
        draw_legend(&legend, &data.series)?;
    }
    Ok(())
}

fn w_of<DB: DrawingBackend>(a: &DrawingArea<DB, Shift>) -> i32 {
    a.dim_in_pixel().0 as i32
}

/// The range of every whisker and outlier, `(0, 1)` when there is none.
fn value_extent(stats: &[Vec<Option<BoxStats>>]) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in stats.iter().flatten().flatten() {
        lo = lo
            .min(s.lo)
            .min(s.outliers.iter().copied().fold(f64::INFINITY, f64::min));
        hi = hi
            .max(s.hi)
            .max(s.outliers.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    }
    if !lo.is_finite() || !hi.is_finite() {
        (lo, hi) = (0.0, 1.0);
    }
    (lo, hi)
}

/// One box centred at `cx`, `half` wide each side: the quartile box, the median, the
/// whiskers with their caps and the outliers.
fn draw_box<DB: DrawingBackend>(
    area: &DrawingArea<DB, Cartesian2d<Categories, Axis>>,
    cx: f64,
    half: f64,
    b: &BoxStats,
    color: RGBColor,
) -> Result<(), PlotError> {
    area.draw(&Rectangle::new(
        [(cx - half, b.q1), (cx + half, b.q3)],
        color.mix(0.25).filled(),
    ))
    .map_err(backend_error)?;
    area.draw(&Rectangle::new(
        [(cx - half, b.q1), (cx + half, b.q3)],
        color.stroke_width(2),
    ))
    .map_err(backend_error)?;
    area.draw(&PathElement::new(
        vec![(cx - half, b.median), (cx + half, b.median)],
        INK.stroke_width(3),
    ))
    .map_err(backend_error)?;
    for (from, to) in [(b.q1, b.lo), (b.q3, b.hi)] {
        area.draw(&PathElement::new(
            vec![(cx, from), (cx, to)],
            color.stroke_width(2),
        ))
        .map_err(backend_error)?;
        area.draw(&PathElement::new(
            vec![(cx - half * 0.5, to), (cx + half * 0.5, to)],
            color.stroke_width(2),
        ))
        .map_err(backend_error)?;
    }
    for o in &b.outliers {
        area.draw(&Circle::new((cx, *o), 3, color.stroke_width(1)))
            .map_err(backend_error)?;
    }
    Ok(())
}

/// The legend: one swatch per series, in the series' colour.
fn draw_legend<DB: DrawingBackend>(
    legend: &DrawingArea<DB, Shift>,
    series: &[String],
) -> Result<(), PlotError> {
    let style = TextStyle::from(("sans-serif", 14).into_font())
        .color(&INK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    for (i, name) in series.iter().enumerate() {
        let yy = 70 + 26 * i as i32;
        let color = PALETTE[i % PALETTE.len()];
        legend
            .draw(&Rectangle::new(
                [(8, yy - 8), (28, yy + 8)],
                color.mix(0.25).filled(),
            ))
            .map_err(backend_error)?;
        legend
            .draw(&Rectangle::new(
                [(8, yy - 8), (28, yy + 8)],
                color.stroke_width(2),
            ))
            .map_err(backend_error)?;
        legend
            .draw(&Text::new(name.clone(), (36, yy), style.clone()))
            .map_err(backend_error)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quartiles_and_whiskers() {
        let s = box_stats(&[1.0, 2.0, 3.0, 4.0, 100.0]).unwrap();
        assert_eq!((s.q1, s.median, s.q3), (2.0, 3.0, 4.0));
        assert_eq!((s.lo, s.hi), (1.0, 4.0));
        assert_eq!(s.outliers, vec![100.0]);
        assert!(box_stats(&[f64::NAN]).is_none());
    }

    #[test]
    fn rendering_is_deterministic() {
        let data = BoxPlotData {
            title: "t".into(),
            x_label: "level".into(),
            y_label: "chi".into(),
            series: vec!["a".into(), "b".into()],
            groups: vec![
                ("0.0".into(), vec![vec![1.0, 2.0, 3.0], vec![2.0, 2.5]]),
                ("0.1".into(), vec![vec![1.5, 2.0, 9.0, 2.2, 2.1], vec![]]),
            ],
        };
        let a = box_plot(&data).unwrap();
        let b = box_plot(&data).unwrap();
        assert_eq!(a, b);
        assert!(a.png.starts_with(b"\x89PNG") && a.svg.contains("<svg"));
    }
}
