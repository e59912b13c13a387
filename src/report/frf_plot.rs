//! Overlay of measured and predicted FRFs: amplitude (dB), phase and the correlation
//! coefficients `χ_s`, `χ_a` in three stacked panels on a common frequency axis.
//!
//! The figure is rendered twice from the same layout, into an in-memory RGB bitmap that is
//! encoded as PNG and into an SVG string, with the shared infrastructure of [`super::figure`].
//!
//! Non-finite values (zero amplitude in dB, NaN, ±inf) are skipped: lines break there, and the
//! axes are fitted to the finite data only.

use faer::c64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::figure::{
    Axis, Extent, Metrics, PALETTE, backend_error, nice_step, render, text_style, widen,
};
pub use super::figure::{Figure, MAX_SIDE_PX, MIN_SIDE_PX, PlotError};

use crate::correlation::FrfCorrelation;
use crate::frf::{FrfPair, FrfSet, Quantity};

/// What to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct FrfPlotOptions {
    /// Figure title, drawn centred above the panels.
    pub title: String,
    /// Figure width in pixels (PNG) and user units (SVG).
    pub width_px: u32,
    /// Figure height in pixels (PNG) and user units (SVG).
    pub height_px: u32,
    /// Most FRFs drawn, one colour each (1 to [`MAX_FRFS`]); default 4.
    pub max_frfs: usize,
    /// FRFs to draw, in legend order; `None` draws the first `max_frfs` of the measured set.
    pub pairs: Option<Vec<FrfPair>>,
}

impl Default for FrfPlotOptions {
    fn default() -> Self {
        FrfPlotOptions {
            title: "FRF overlay".to_string(),
            width_px: 1200,
            height_px: 900,
            max_frfs: 4,
            pairs: None,
        }
    }
}

/// Largest `max_frfs`: the number of distinct FRF colours.
pub const MAX_FRFS: usize = PALETTE.len();

/// Renders measured FRFs, optionally overlaid with predictions and the correlation, as PNG and SVG.
pub fn frf_overlay(
    measured: &FrfSet,
    predicted: Option<&FrfSet>,
    correlation: Option<&FrfCorrelation>,
    opts: &FrfPlotOptions,
) -> Result<Figure, PlotError> {
    let plan = Plan::new(measured, predicted, correlation, opts)?;
    render(
        opts.width_px,
        opts.height_px,
        &|root| draw(root, &plan),
        &|root| draw(root, &plan),
    )
}

// ---------------------------------------------------------------------------------------------
// Data preparation: everything is validated and reduced to finite polylines before drawing.

const INK: RGBColor = RGBColor(30, 30, 30);
const MUTED: RGBColor = RGBColor(100, 100, 100);
const CHI_A: RGBColor = RGBColor(90, 90, 90);

/// A polyline broken where data are missing: each run is drawn as one connected line.
type Runs = Vec<Vec<(f64, f64)>>;

/// One FRF ready to draw.
struct Curve {
    label: String,
    color: RGBColor,
    frac: Option<f64>,
    measured_db: Runs,
    measured_phase: Runs,
    predicted_db: Option<Runs>,
    predicted_phase: Option<Runs>,
}

/// One correlation coefficient ready to draw.
struct ChiCurve {
    runs: Runs,
    mean: Option<f64>,
}

/// Everything the drawing code needs, validated.
struct Plan {
    title: String,
    db_label: String,
    curves: Vec<Curve>,
    has_prediction: bool,
    /// Measured frequency lines (sets the measured dot size).
    lines: usize,
    chi: Option<(ChiCurve, ChiCurve)>,
    x_axis: Axis,
    db_axis: Axis,
    db_has_data: bool,
    phase_axis: Axis,
    chi_axis: Axis,
}

impl Plan {
    fn new(
        measured: &FrfSet,
        predicted: Option<&FrfSet>,
        correlation: Option<&FrfCorrelation>,
        opts: &FrfPlotOptions,
    ) -> Result<Plan, PlotError> {
        check_inputs(measured, predicted, correlation, opts)?;
        let selected = select_pairs(measured, opts)?;
        let curves = curves(measured, predicted, correlation, &selected)?;
        let chi = correlation.map(|c| {
            (
                chi_curve(&c.freqs_hz, &c.chi_s),
                chi_curve(&c.freqs_hz, &c.chi_a),
            )
        });
        let (x_axis, db_axis, db_has_data) = data_axes(measured, &curves, chi.as_ref())?;
        Ok(Plan {
            title: opts.title.clone(),
            db_label: format!("Amplitude (dB re 1 {})", pretty_unit(measured.quantity)),
            curves,
            has_prediction: predicted.is_some(),
            lines: measured.freqs_hz.len(),
            chi,
            x_axis,
            db_axis,
            db_has_data,
            phase_axis: Axis::phase(),
            chi_axis: Axis::unit_interval(),
        })
    }
}

/// The figure size, `max_frfs`, the sets' shapes and quantities and the correlation's lengths.
fn check_inputs(
    measured: &FrfSet,
    predicted: Option<&FrfSet>,
    correlation: Option<&FrfCorrelation>,
    opts: &FrfPlotOptions,
) -> Result<(), PlotError> {
    let size_ok = |s: u32| (MIN_SIDE_PX..=MAX_SIDE_PX).contains(&s);
    if !size_ok(opts.width_px) || !size_ok(opts.height_px) {
        return Err(PlotError::Size {
            width: opts.width_px,
            height: opts.height_px,
            min: MIN_SIDE_PX,
            max: MAX_SIDE_PX,
        });
    }
    if opts.max_frfs == 0 || opts.max_frfs > MAX_FRFS {
        return Err(PlotError::MaxFrfs {
            given: opts.max_frfs,
            limit: MAX_FRFS,
        });
    }
    check_shape("measured", measured)?;
    if measured.pairs.is_empty() || measured.freqs_hz.is_empty() {
        return Err(PlotError::Empty {
            pairs: measured.pairs.len(),
            lines: measured.freqs_hz.len(),
        });
    }
    if let Some(p) = predicted {
        check_shape("predicted", p)?;
        if p.quantity != measured.quantity {
            return Err(PlotError::Quantity {
                measured: measured.quantity.name(),
                predicted: p.quantity.name(),
            });
        }
    }
    if let Some(c) = correlation
        .filter(|c| c.chi_s.len() != c.freqs_hz.len() || c.chi_a.len() != c.freqs_hz.len())
    {
        return Err(PlotError::CorrelationShape {
            lines: c.freqs_hz.len(),
            chi_s: c.chi_s.len(),
            chi_a: c.chi_a.len(),
        });
    }
    Ok(())
}

/// One curve per selected FRF (measured column `col`), its prediction and FRAC, in legend
/// order and colour.
fn curves(
    measured: &FrfSet,
    predicted: Option<&FrfSet>,
    correlation: Option<&FrfCorrelation>,
    selected: &[(FrfPair, usize)],
) -> Result<Vec<Curve>, PlotError> {
    let mut curves = Vec::with_capacity(selected.len());
    for (n, (pair, col)) in selected.iter().enumerate() {
        let pred_col = match predicted {
            Some(p) => Some((
                p,
                p.pair_index(pair)
                    .ok_or_else(|| PlotError::MissingPrediction {
                        pair: pair_name(pair),
                        known: pair_list(&p.pairs),
                    })?,
            )),
            None => None,
        };
        let frac = correlation.and_then(|c| {
            let i = c.pairs.iter().position(|q| q == pair)?;
            c.frac.get(i).copied().filter(|v| v.is_finite())
        });
        let (measured_db, measured_phase) = frf_runs(measured, *col);
        let (predicted_db, predicted_phase) = match pred_col {
            Some((p, j)) => {
                let (d, ph) = frf_runs(p, j);
                (Some(d), Some(ph))
            }
            None => (None, None),
        };
        curves.push(Curve {
            label: format!("H {}", pair_name(pair)),
            color: PALETTE[n % PALETTE.len()],
            frac,
            measured_db,
            measured_phase,
            predicted_db,
            predicted_phase,
        });
    }
    Ok(curves)
}

/// The frequency axis (the finite extent of everything drawn) and the amplitude axis, with
/// whether any amplitude is finite.
fn data_axes(
    measured: &FrfSet,
    curves: &[Curve],
    chi: Option<&(ChiCurve, ChiCurve)>,
) -> Result<(Axis, Axis, bool), PlotError> {
    let mut fx = Extent::default();
    let mut db = Extent::default();
    for c in curves {
        for runs in [Some(&c.measured_db), c.predicted_db.as_ref()]
            .into_iter()
            .flatten()
        {
            for &(f, v) in runs.iter().flatten() {
                fx.add(f);
                db.add(v);
            }
        }
    }
    if let Some((s, a)) = chi {
        for &(f, _) in s.runs.iter().chain(&a.runs).flatten() {
            fx.add(f);
        }
    }
    // Lines whose values are all non-finite still set the frequency extent.
    for f in &measured.freqs_hz {
        fx.add(*f);
    }
    let (flo, fhi) = fx.get().ok_or(PlotError::NoFrequencies)?;
    if !(fhi - flo).is_finite() {
        return Err(PlotError::FrequencySpan { lo: flo, hi: fhi });
    }
    let x_axis = Axis::frequency(flo, fhi);
    let (db_axis, db_has_data) = match db.get() {
        Some((lo, hi)) => (Axis::decibel(lo, hi), true),
        None => (Axis::decibel(-60.0, 0.0), false),
    };
    Ok((x_axis, db_axis, db_has_data))
}

fn check_shape(which: &'static str, set: &FrfSet) -> Result<(), PlotError> {
    let (rows, cols) = (set.values.nrows(), set.values.ncols());
    if rows != set.freqs_hz.len() || cols != set.pairs.len() {
        return Err(PlotError::Shape {
            which,
            rows,
            cols,
            lines: set.freqs_hz.len(),
            pairs: set.pairs.len(),
        });
    }
    Ok(())
}

/// The FRFs to draw with their measured column, in legend order.
fn select_pairs(
    measured: &FrfSet,
    opts: &FrfPlotOptions,
) -> Result<Vec<(FrfPair, usize)>, PlotError> {
    let Some(requested) = &opts.pairs else {
        return Ok(measured
            .pairs
            .iter()
            .copied()
            .enumerate()
            .take(opts.max_frfs)
            .map(|(i, p)| (p, i))
            .collect());
    };
    if requested.is_empty() {
        return Err(PlotError::NoneSelected {
            known: pair_list(&measured.pairs),
        });
    }
    if requested.len() > opts.max_frfs {
        return Err(PlotError::TooMany {
            requested: requested.len(),
            max: opts.max_frfs,
            limit: MAX_FRFS,
        });
    }
    let mut out: Vec<(FrfPair, usize)> = Vec::with_capacity(requested.len());
    for pair in requested {
        if out.iter().any(|(p, _)| p == pair) {
            return Err(PlotError::DuplicatePair {
                pair: pair_name(pair),
            });
        }
        let col = measured
            .pair_index(pair)
            .ok_or_else(|| PlotError::UnknownPair {
                pair: pair_name(pair),
                known: pair_list(&measured.pairs),
            })?;
        out.push((*pair, col));
    }
    Ok(out)
}

fn pair_name(p: &FrfPair) -> String {
    format!("{}/{}", p.response, p.excitation)
}

/// Pairs as a readable list, shortened when long.
fn pair_list(pairs: &[FrfPair]) -> String {
    const SHOWN: usize = 12;
    if pairs.is_empty() {
        return "(none)".to_string();
    }
    let mut s = pairs
        .iter()
        .take(SHOWN)
        .map(pair_name)
        .collect::<Vec<_>>()
        .join(", ");
    if pairs.len() > SHOWN {
        s.push_str(&format!(", … ({} in all)", pairs.len()));
    }
    s
}

fn pretty_unit(q: Quantity) -> String {
    q.unit().replace("^2", "²")
}

/// Amplitude (dB) and phase (degrees) runs of one column, skipping non-finite points.
fn frf_runs(set: &FrfSet, col: usize) -> (Runs, Runs) {
    let mut db = RunBuilder::default();
    let mut phase = RunBuilder::default();
    for (k, &f) in set.freqs_hz.iter().enumerate() {
        let v: c64 = set.values[(k, col)];
        let finite = f.is_finite() && v.re.is_finite() && v.im.is_finite();
        let amp = v.re.hypot(v.im);
        let d = 20.0 * amp.log10();
        if finite && d.is_finite() {
            db.push(f, d);
        } else {
            db.gap();
        }
        if finite && amp > 0.0 {
            let p = v.im.atan2(v.re).to_degrees();
            // A wrap from +180 to −180 is not a jump of the response: break the line there.
            if phase.last().is_some_and(|(_, q)| (p - q).abs() > 180.0) {
                phase.gap();
            }
            phase.push(f, p);
        } else {
            phase.gap();
        }
    }
    (db.finish(), phase.finish())
}

fn chi_curve(freqs: &[f64], chi: &[f64]) -> ChiCurve {
    let mut runs = RunBuilder::default();
    let (mut sum, mut n) = (0.0, 0usize);
    for (&f, &c) in freqs.iter().zip(chi) {
        if f.is_finite() && c.is_finite() {
            let c = c.clamp(0.0, 1.0);
            runs.push(f, c);
            sum += c;
            n += 1;
        } else {
            runs.gap();
        }
    }
    ChiCurve {
        runs: runs.finish(),
        mean: (n > 0).then(|| sum / n as f64),
    }
}

#[derive(Default)]
struct RunBuilder {
    runs: Runs,
    open: bool,
}

impl RunBuilder {
    fn push(&mut self, x: f64, y: f64) {
        if !self.open {
            self.runs.push(Vec::new());
            self.open = true;
        }
        if let Some(run) = self.runs.last_mut() {
            run.push((x, y));
        }
    }

    fn gap(&mut self) {
        self.open = false;
    }

    fn last(&self) -> Option<(f64, f64)> {
        if self.open {
            self.runs.last().and_then(|r| r.last().copied())
        } else {
            None
        }
    }

    fn finish(self) -> Runs {
        self.runs
    }
}

// ---------------------------------------------------------------------------------------------
// Axes of the panels with its own tick positions, so ticks are chosen here (nice steps,

impl Axis {
    /// Exactly the data extent (widened if it is a single line).
    fn frequency(lo: f64, hi: f64) -> Axis {
        let (lo, hi) = widen(lo, hi, 0.5);
        Axis::with_ticks(lo, hi, 8)
    }

    /// Data extent with headroom, snapped outward to ticks.
    fn decibel(lo: f64, hi: f64) -> Axis {
        let (lo, hi) = widen(lo, hi, 5.0);
        let pad = ((hi - lo) * 0.06).max(2.0);
        let (lo, hi) = (lo - pad, hi + pad);
        let step = nice_step((hi - lo) / 6.0);
        let (lo, hi) = ((lo / step).floor() * step, (hi / step).ceil() * step);
        Axis::with_ticks(lo, hi, 6)
    }

    fn phase() -> Axis {
        Axis {
            lo: -200.0,
            hi: 200.0,
            major: vec![-180.0, -90.0, 0.0, 90.0, 180.0],
            minor: (-4..=4).map(|k| 45.0 * k as f64).collect(),
            decimals: 0,
        }
    }

    fn unit_interval() -> Axis {
        Axis {
            lo: -0.04,
            hi: 1.06,
            major: vec![0.0, 0.25, 0.5, 0.75, 1.0],
            minor: (0..=8).map(|k| 0.125 * k as f64).collect(),
            decimals: 2,
        }
    }
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, plan: &Plan) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(backend_error)?;
    let (w, h) = root.dim_in_pixel();
    let m = Metrics {
        // Sizes are designed at 1200x900 and scale sub-linearly, so small figures keep legible
        // text and large ones do not get oversized type.
        u: (w as f64 / 1200.0).min(h as f64 / 900.0).powf(0.7),
    };

    // Title strip.
    let title_font = m.font(20.0);
    let title_h = (title_font * 2.2).round() as i32;
    let (title_area, body) = root.split_vertically(title_h);
    let title_style = text_style(
        title_font,
        FontStyle::Bold,
        INK,
        Pos::new(HPos::Center, VPos::Center),
    );
    title_area
        .draw_text(
            &plan.title,
            &title_style,
            (w as i32 / 2, title_h / 2 + m.px(2.0)),
        )
        .map_err(backend_error)?;

    // Plots on the left, legend column on the right.
    let body = body.margin(0, m.px(10.0), m.px(8.0), m.px(12.0));
    let (bw, bh) = body.dim_in_pixel();
    let legend_w = legend_width(&body, plan, &m)?.min(bw as i32 * 2 / 5);
    let (plots, legend) = body.split_horizontally(bw as i32 - legend_w);

    // Panel heights: plotting heights in the ratio of `weights`, the bottom panel also carries
    // the frequency labels.
    let gap = m.px(10.0);
    let x_label_h = m.px(46.0);
    let weights: &[f64] = if plan.chi.is_some() {
        &[0.44, 0.25, 0.31]
    } else {
        &[0.62, 0.38]
    };
    let avail =
        (bh as i32 - x_label_h - gap * weights.len() as i32).max(weights.len() as i32) as f64;
    let mut breaks = Vec::new();
    let mut y = 0i32;
    for wt in &weights[..weights.len() - 1] {
        y += (wt * avail).round() as i32 + gap;
        breaks.push(y);
    }
    let panels = plots.split_by_breakpoints([] as [i32; 0], &breaks);
    // The FRF legend may use the height of the amplitude and phase panels; the χ legend sits
    // beside the correlation panel.
    let (frf_legend, chi_legend) = match breaks.get(1) {
        Some(&y) => {
            let (top, bottom) = legend.split_vertically(y);
            (top, Some(bottom))
        }
        None => (legend, None),
    };
    let n = panels.len();

    let ctx = PanelCtx {
        plan,
        m: &m,
        gap,
        x_label_h,
    };
    if let Some(p) = panels.first() {
        ctx.amplitude_panel(p, n == 1)?;
    }
    if let Some(p) = panels.get(1) {
        ctx.phase_panel(p, n == 2)?;
    }
    if let Some(p) = panels.get(2) {
        ctx.chi_panel(p)?;
    }
    ctx.frf_legend(&frf_legend)?;
    if let Some(l) = &chi_legend {
        ctx.chi_legend(l)?;
    }
    Ok(())
}

fn legend_text_style<'a>(m: &Metrics) -> TextStyle<'a> {
    text_style(
        m.font(14.0),
        FontStyle::Normal,
        INK,
        Pos::new(HPos::Left, VPos::Center),
    )
}

fn note_text_style<'a>(m: &Metrics) -> TextStyle<'a> {
    text_style(
        m.font(12.0),
        FontStyle::Normal,
        MUTED,
        Pos::new(HPos::Left, VPos::Center),
    )
}

/// Legend labels: FRF names, then their FRAC line.
fn frf_label(c: &Curve) -> (String, Option<String>) {
    (c.label.clone(), c.frac.map(|f| format!("FRAC {f:.3}")))
}

fn chi_labels(plan: &Plan) -> Vec<(String, Option<String>)> {
    let Some((s, a)) = &plan.chi else {
        return Vec::new();
    };
    let mean = |c: &ChiCurve| c.mean.map(|v| format!("mean {v:.3}"));
    vec![
        ("χₛ  shape".to_string(), mean(s)),
        ("χₐ  amplitude".to_string(), mean(a)),
    ]
}

fn legend_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    plan: &Plan,
    m: &Metrics,
) -> Result<i32, PlotError> {
    let main = legend_text_style(m);
    let note = note_text_style(m);
    let mut widest = area
        .estimate_text_size("predicted", &main)
        .map_err(backend_error)?
        .0;
    let labels = plan.curves.iter().map(frf_label).chain(chi_labels(plan));
    for (label, sub) in labels {
        widest = widest.max(
            area.estimate_text_size(&label, &main)
                .map_err(backend_error)?
                .0,
        );
        if let Some(sub) = sub {
            widest = widest.max(
                area.estimate_text_size(&sub, &note)
                    .map_err(backend_error)?
                    .0,
            );
        }
    }
    Ok(widest as i32 + m.px(24.0) + m.px(38.0) + m.px(16.0))
}

struct PanelCtx<'p> {
    plan: &'p Plan,
    m: &'p Metrics,
    gap: i32,
    x_label_h: i32,
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<Axis, Axis>>;

impl PanelCtx<'_> {
    /// A chart on `area` sharing the frequency axis; only the bottom panel shows frequencies.
    fn chart<'a, DB: DrawingBackend>(
        &self,
        area: &'a DrawingArea<DB, Shift>,
        y: &Axis,
        y_desc: &str,
        bottom: bool,
    ) -> Result<Chart<'a, DB>, PlotError> {
        let m = self.m;
        let mut chart = ChartBuilder::on(area)
            .margin_top(self.gap)
            .margin_right(m.px(4.0))
            .set_label_area_size(LabelAreaPosition::Left, m.px(68.0))
            .set_label_area_size(
                LabelAreaPosition::Bottom,
                if bottom { self.x_label_h } else { 0 },
            )
            .build_cartesian_2d(self.plan.x_axis.clone(), y.clone())
            .map_err(backend_error)?;
        let x_axis = &self.plan.x_axis;
        let x_fmt = |v: &f64| x_axis.label(*v);
        let y_fmt = |v: &f64| y.label(*v);
        let tick_font = ("sans-serif", m.font(12.0)).into_font().color(&INK);
        let desc_font = ("sans-serif", m.font(14.0)).into_font().color(&INK);
        let mut mesh = chart.configure_mesh();
        mesh.x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .label_style(tick_font)
            .axis_desc_style(desc_font)
            .bold_line_style(RGBColor(200, 200, 200).stroke_width(1))
            .light_line_style(RGBColor(236, 236, 236).stroke_width(1))
            .axis_style(INK.stroke_width(1))
            .set_all_tick_mark_size(m.px(5.0))
            .y_desc(y_desc);
        if bottom {
            mesh.x_desc("Frequency (Hz)");
        }
        mesh.draw().map_err(backend_error)?;
        // Close the frame so stacked panels read as one figure.
        let (x, y) = (&self.plan.x_axis, y);
        chart
            .plotting_area()
            .draw(&Rectangle::new(
                [(x.lo, y.lo), (x.hi, y.hi)],
                INK.stroke_width(1),
            ))
            .map_err(backend_error)?;
        Ok(chart)
    }

    fn amplitude_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        bottom: bool,
    ) -> Result<(), PlotError> {
        let plan = self.plan;
        let mut chart = self.chart(area, &plan.db_axis, &plan.db_label, bottom)?;
        for c in &plan.curves {
            self.draw_curve(&mut chart, &c.measured_db, c.predicted_db.as_ref(), c.color)?;
        }
        if !plan.db_has_data {
            self.note(
                &chart,
                "no finite amplitude: every value is zero, NaN or infinite",
            )?;
        }
        Ok(())
    }

    fn phase_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        bottom: bool,
    ) -> Result<(), PlotError> {
        let plan = self.plan;
        let mut chart = self.chart(area, &plan.phase_axis, "Phase (°)", bottom)?;
        for c in &plan.curves {
            self.draw_curve(
                &mut chart,
                &c.measured_phase,
                c.predicted_phase.as_ref(),
                c.color,
            )?;
        }
        let empty = plan.curves.iter().all(|c| {
            c.measured_phase.is_empty() && c.predicted_phase.as_ref().is_none_or(|r| r.is_empty())
        });
        if empty {
            self.note(&chart, "no phase: every value is zero, NaN or infinite")?;
        }
        Ok(())
    }

    fn chi_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<(), PlotError> {
        let plan = self.plan;
        let mut chart = self.chart(area, &plan.chi_axis, "Correlation", true)?;
        let Some((s, a)) = &plan.chi else {
            return Ok(());
        };
        for run in &a.runs {
            self.chi_a_line(&mut chart, run)?;
        }
        for run in &s.runs {
            self.chi_s_line(&mut chart, run)?;
        }
        if s.runs.is_empty() && a.runs.is_empty() {
            self.note(&chart, "no finite χs or χa values")?;
        }
        Ok(())
    }

    fn chi_s_line<DB: DrawingBackend>(
        &self,
        chart: &mut Chart<'_, DB>,
        run: &[(f64, f64)],
    ) -> Result<(), PlotError> {
        chart
            .draw_series(LineSeries::new(
                run.iter().copied(),
                INK.stroke_width(self.m.line()),
            ))
            .map_err(backend_error)?;
        Ok(())
    }

    fn chi_a_line<DB: DrawingBackend>(
        &self,
        chart: &mut Chart<'_, DB>,
        run: &[(f64, f64)],
    ) -> Result<(), PlotError> {
        let m = self.m;
        let style = CHI_A.stroke_width(m.line());
        chart
            .draw_series(DashedLineSeries::new(
                run.iter().copied(),
                m.px(7.0),
                m.px(4.0),
                style,
            ))
            .map_err(backend_error)?;
        Ok(())
    }

    /// Predicted as a solid line, measured as small dots of the same colour on top.
    fn draw_curve<DB: DrawingBackend>(
        &self,
        chart: &mut Chart<'_, DB>,
        measured: &Runs,
        predicted: Option<&Runs>,
        color: RGBColor,
    ) -> Result<(), PlotError> {
        let m = self.m;
        if let Some(runs) = predicted {
            let style = color.stroke_width(m.line());
            for run in runs {
                if run.len() == 1 {
                    chart
                        .draw_series(
                            run.iter()
                                .map(|p| Circle::new(*p, m.px(1.5), style.filled())),
                        )
                        .map_err(backend_error)?;
                } else {
                    chart
                        .draw_series(LineSeries::new(run.iter().copied(), style))
                        .map_err(backend_error)?;
                }
            }
        }
        // Small dots where lines are dense, larger ones where each line is seen on its own.
        let plot_w = chart.plotting_area().dim_in_pixel().0 as f64;
        let spacing = plot_w / self.plan.lines.max(1) as f64;
        let r = if spacing >= 6.0 * m.u {
            m.px(2.4)
        } else {
            m.px(1.4)
        };
        let dot = color.filled();
        for run in measured {
            chart
                .draw_series(run.iter().map(|p| Circle::new(*p, r, dot)))
                .map_err(backend_error)?;
        }
        Ok(())
    }

    fn note<DB: DrawingBackend>(&self, chart: &Chart<'_, DB>, text: &str) -> Result<(), PlotError> {
        let area = chart.plotting_area().strip_coord_spec();
        let (w, h) = area.dim_in_pixel();
        let style = text_style(
            self.m.font(14.0),
            FontStyle::Italic,
            MUTED,
            Pos::new(HPos::Center, VPos::Center),
        );
        area.draw_text(text, &style, (w as i32 / 2, h as i32 / 2))
            .map_err(backend_error)
    }

    /// Legend rows: a swatch drawn by `swatch` at `(x0..x1, y)`, a label and an optional note.
    fn legend_rows<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        rows: Vec<(String, Option<String>, Swatch)>,
    ) -> Result<(), PlotError> {
        let m = self.m;
        let main = legend_text_style(m);
        let note = note_text_style(m);
        let x0 = m.px(24.0);
        let x1 = x0 + m.px(30.0);
        let tx = x1 + m.px(8.0);
        let mut y = self.gap + m.px(12.0);
        for (label, sub, swatch) in rows {
            match swatch {
                Swatch::Line(c, width) => area
                    .draw(&PathElement::new(
                        vec![(x0, y), (x1, y)],
                        c.stroke_width(width),
                    ))
                    .map_err(backend_error)?,
                Swatch::Dashed(c, width) => area
                    .draw(&plotters::element::DashedPathElement::new(
                        vec![(x0, y), (x1, y)],
                        m.px(7.0),
                        m.px(4.0),
                        c.stroke_width(width),
                    ))
                    .map_err(backend_error)?,
                Swatch::Dots(c) => {
                    for k in 0..4 {
                        let x = x0 + (x1 - x0) * k / 3;
                        area.draw(&Circle::new((x, y), m.px(1.8), c.filled()))
                            .map_err(backend_error)?;
                    }
                }
                Swatch::Gap => {}
            }
            area.draw_text(&label, &main, (tx, y))
                .map_err(backend_error)?;
            y += m.px(20.0);
            if let Some(sub) = sub {
                area.draw_text(&sub, &note, (tx, y - m.px(3.0)))
                    .map_err(backend_error)?;
                y += m.px(18.0);
            }
        }
        Ok(())
    }

    fn frf_legend<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<(), PlotError> {
        let m = self.m;
        let mut rows: Vec<_> = self
            .plan
            .curves
            .iter()
            .map(|c| {
                let (label, sub) = frf_label(c);
                (label, sub, Swatch::Line(c.color, m.px(3.0) as u32))
            })
            .collect();
        rows.push((String::new(), None, Swatch::Gap));
        rows.push(("measured".to_string(), None, Swatch::Dots(MUTED)));
        if self.plan.has_prediction {
            rows.push(("predicted".to_string(), None, Swatch::Line(MUTED, m.line())));
        }
        self.legend_rows(area, rows)
    }

    fn chi_legend<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<(), PlotError> {
        let width = self.m.line();
        let swatches = [Swatch::Line(INK, width), Swatch::Dashed(CHI_A, width)];
        let rows = chi_labels(self.plan)
            .into_iter()
            .zip(swatches)
            .map(|((l, s), sw)| (l, s, sw))
            .collect();
        self.legend_rows(area, rows)
    }
}

enum Swatch {
    Line(RGBColor, u32),
    Dashed(RGBColor, u32),
    Dots(RGBColor),
    Gap,
}

// ---------------------------------------------------------------------------------------------
// Small multiples: one small panel per FRF, |H| against frequency on log axes.

/// Most panels in one small-multiples figure.
pub const MAX_PANELS: usize = 64;
/// Panel size in pixels.
const SM_PANEL: (u32, u32) = (320, 250);
/// Height of the title and legend band.
const SM_HEAD: u32 = 92;

/// What to draw as small multiples.
#[derive(Clone, Debug, PartialEq)]
pub struct SmallMultiplesOptions {
    /// Figure title.
    pub title: String,
    /// FRFs to draw, in panel order; `None` draws every measured FRF (at most [`MAX_PANELS`]).
    pub pairs: Option<Vec<FrfPair>>,
}

/// One panel of the small multiples: its caption and its curves as `(log10 f, log10 |H|)`.
struct SmPanel {
    caption: String,
    measured: Runs,
    predicted: Option<Runs>,
}

/// Everything the small multiples draw, validated.
struct SmPlan {
    title: String,
    subtitle: String,
    y_desc: String,
    panels: Vec<SmPanel>,
    columns: usize,
    x_axis: Axis,
    y_axis: Axis,
}

/// Renders one panel per FRF — measured (dark line) and predicted (coloured line) magnitude on
/// logarithmic frequency and magnitude axes shared by all panels, the FRAC (4.10) in each
/// caption and the mean `χ_s`, `χ_a` (4.5, 4.6) under the title when a correlation is given —
/// as PNG and SVG. More than [`MAX_PANELS`] FRFs draw the first ones and say so in the title.
pub fn frf_small_multiples(
    measured: &FrfSet,
    predicted: Option<&FrfSet>,
    correlation: Option<&FrfCorrelation>,
    opts: &SmallMultiplesOptions,
) -> Result<Figure, PlotError> {
    let plan = SmPlan::new(measured, predicted, correlation, opts)?;
    let rows = plan.panels.len().div_ceil(plan.columns);
    let w = SM_PANEL.0 * plan.columns as u32 + 24;
    let h = SM_HEAD + SM_PANEL.1 * rows as u32 + 8;
    render(w, h, &|root| draw_small_multiples(root, &plan), &|root| {
        draw_small_multiples(root, &plan)
    })
}

/// `log10` of the finite positive points of dB runs (`|H|` in dB → `log10 |H|`), keeping only
/// positive frequencies.
fn log_runs(db: &Runs) -> Runs {
    let mut out = RunBuilder::default();
    for run in db {
        for &(f, d) in run {
            if f > 0.0 && f.is_finite() {
                out.push(f.log10(), d / 20.0);
            } else {
                out.gap();
            }
        }
        out.gap();
    }
    out.finish()
}

impl SmPlan {
    fn new(
        measured: &FrfSet,
        predicted: Option<&FrfSet>,
        correlation: Option<&FrfCorrelation>,
        opts: &SmallMultiplesOptions,
    ) -> Result<SmPlan, PlotError> {
        let all = opts
            .pairs
            .as_ref()
            .map_or(measured.pairs.len(), |p| p.len());
        let checked = FrfPlotOptions {
            title: opts.title.clone(),
            max_frfs: usize::MAX,
            pairs: opts.pairs.clone(),
            ..FrfPlotOptions::default()
        };
        check_inputs(
            measured,
            predicted,
            correlation,
            &FrfPlotOptions {
                max_frfs: MAX_FRFS,
                ..checked.clone()
            },
        )?;
        let mut selected = select_pairs(measured, &checked)?;
        selected.truncate(MAX_PANELS);
        let curves = curves(measured, predicted, correlation, &selected)?;
        let (mut fx, mut mag) = (Extent::default(), Extent::default());
        let panels: Vec<SmPanel> = curves
            .iter()
            .map(|c| {
                let m = log_runs(&c.measured_db);
                let p = c.predicted_db.as_ref().map(log_runs);
                for &(f, v) in m.iter().chain(p.iter().flatten()).flatten() {
                    fx.add(f);
                    mag.add(v);
                }
                let caption = match c.frac {
                    Some(frac) => format!("{} · FRAC {frac:.2}", c.label),
                    None => c.label.clone(),
                };
                SmPanel {
                    caption,
                    measured: m,
                    predicted: p,
                }
            })
            .collect();
        for f in measured.freqs_hz.iter().filter(|f| **f > 0.0) {
            fx.add(f.log10());
        }
        let (flo, fhi) = fx.get().ok_or(PlotError::NoFrequencies)?;
        let (mlo, mhi) = mag.get().unwrap_or((-6.0, 0.0));
        let mut title = opts.title.clone();
        if all > selected.len() {
            title.push_str(&format!(" (first {} of {all} FRFs)", selected.len()));
        }
        let subtitle = match correlation {
            Some(c) => format!(
                "measured: dark line, predicted: coloured line; mean χs = {:.3}, mean χa = {:.3}",
                c.mean_chi_s(),
                c.mean_chi_a()
            ),
            None if predicted.is_some() => {
                "measured: dark line, predicted: coloured line".to_string()
            }
            None => "measured".to_string(),
        };
        let columns = (panels.len() as f64).sqrt().ceil().clamp(1.0, 8.0) as usize;
        Ok(SmPlan {
            title,
            subtitle,
            y_desc: format!("|H| ({})", pretty_unit(measured.quantity)),
            columns,
            panels,
            x_axis: Axis::log_decades(flo, fhi, 4, false),
            y_axis: Axis::log_decades(mlo, mhi, 4, true),
        })
    }
}

impl Axis {
    /// A logarithmic axis in `log10` units over `[lo, hi]`, snapped out to whole decades when
    /// `snap`: labelled ticks on at most `labels` decades (on 1, 2 and 5 times a decade when
    /// fewer than two decades fall inside), minor ticks at 1…9 times each decade.
    fn log_decades(lo: f64, hi: f64, labels: usize, snap: bool) -> Axis {
        let (mut lo, mut hi) = if snap {
            (lo.floor(), hi.ceil())
        } else {
            (lo, hi)
        };
        if !(lo.is_finite() && hi.is_finite()) {
            (lo, hi) = (0.0, 1.0);
        }
        if hi - lo < 1e-9 {
            (lo, hi) = (lo - 0.5, hi + 0.5);
        }
        let tol = 1e-9;
        let (first, last) = (lo.floor() as i64, hi.ceil() as i64);
        let inside = |v: &f64| *v >= lo - tol && *v <= hi + tol;
        let decades: Vec<f64> = (first..=last).map(|k| k as f64).filter(inside).collect();
        let every = decades
            .len()
            .saturating_sub(1)
            .div_ceil(labels.max(1))
            .max(1);
        let mut major: Vec<f64> = decades.iter().copied().step_by(every).collect();
        if major.len() < 2 {
            major = (first..=last)
                .flat_map(|k| [1.0f64, 2.0, 5.0].map(|m| k as f64 + m.log10()))
                .filter(inside)
                .collect();
        }
        let minor: Vec<f64> = if last - first <= 8 {
            (first..=last)
                .flat_map(|k| (1..10).map(move |m| k as f64 + (m as f64).log10()))
                .filter(inside)
                .collect()
        } else {
            decades
        };
        Axis {
            lo,
            hi,
            major,
            minor,
            decimals: 0,
        }
    }
}

/// The label of `10^v` (a tick of a log axis, one significant digit): written out for
/// moderate sizes, else as `m e±k`.
fn decade_label(v: f64) -> String {
    let k = v.floor() as i32;
    let m = 10f64.powf(v - k as f64).round();
    let (m, k) = if m >= 10.0 { (1.0, k + 1) } else { (m, k) };
    let s = if (-3..=4).contains(&k) {
        format!("{:.*}", (-k).max(0) as usize, m * 10f64.powi(k))
    } else if m == 1.0 {
        format!("1e{k}")
    } else {
        format!("{m}e{k}")
    };
    s.replace('-', "−")
}

fn draw_small_multiples<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plan: &SmPlan,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(backend_error)?;
    let (w, _) = root.dim_in_pixel();
    let centre = Pos::new(HPos::Center, VPos::Center);
    root.draw(&Text::new(
        plan.title.clone(),
        (w as i32 / 2, 24),
        text_style(22.0, FontStyle::Bold, INK, centre),
    ))
    .map_err(backend_error)?;
    root.draw(&Text::new(
        plan.subtitle.clone(),
        (w as i32 / 2, 62),
        text_style(18.0, FontStyle::Normal, MUTED, centre),
    ))
    .map_err(backend_error)?;
    let body = root.margin(SM_HEAD as i32, 8, 8, 16);
    let rows = plan.panels.len().div_ceil(plan.columns);
    let tick_font = ("sans-serif", 16.0).into_font().color(&INK);
    let desc_font = ("sans-serif", 18.0).into_font().color(&INK);
    let cap_style = text_style(16.0, FontStyle::Normal, INK, centre);
    let x_fmt = |v: &f64| decade_label(*v);
    for (k, panel) in plan.panels.iter().enumerate() {
        let (c, r) = (k % plan.columns, k / plan.columns);
        let (left, top) = (
            (c as u32 * SM_PANEL.0) as i32,
            (r as u32 * SM_PANEL.1) as i32,
        );
        let area = body.clone().shrink((left, top), SM_PANEL);
        let (first_col, last_row) = (c == 0, r + 1 == rows);
        let mut chart = ChartBuilder::on(&area)
            .margin_top(30)
            .margin_right(10)
            .set_label_area_size(LabelAreaPosition::Left, if first_col { 78 } else { 52 })
            .set_label_area_size(LabelAreaPosition::Bottom, if last_row { 58 } else { 28 })
            .build_cartesian_2d(plan.x_axis.clone(), plan.y_axis.clone())
            .map_err(backend_error)?;
        let mut mesh = chart.configure_mesh();
        mesh.x_label_formatter(&x_fmt)
            .y_label_formatter(&x_fmt)
            .label_style(tick_font.clone())
            .axis_desc_style(desc_font.clone())
            .bold_line_style(RGBColor(205, 205, 205).stroke_width(1))
            .light_line_style(RGBColor(238, 238, 238).stroke_width(1))
            .axis_style(INK.stroke_width(1))
            .set_all_tick_mark_size(4);
        if first_col {
            mesh.y_desc(plan.y_desc.as_str());
        }
        if last_row {
            mesh.x_desc("Frequency (Hz)");
        }
        mesh.draw().map_err(backend_error)?;
        let (x, y) = (&plan.x_axis, &plan.y_axis);
        // The panel's frame: one per FRF.
        chart
            .plotting_area()
            .draw(&Rectangle::new(
                [(x.lo, y.lo), (x.hi, y.hi)],
                INK.stroke_width(1),
            ))
            .map_err(backend_error)?;
        for run in &panel.measured {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    run.clone(),
                    INK.stroke_width(1),
                )))
                .map_err(backend_error)?;
        }
        for run in panel.predicted.iter().flatten() {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    run.clone(),
                    PALETTE[1].stroke_width(2),
                )))
                .map_err(backend_error)?;
        }
        area.draw(&Text::new(
            panel.caption.clone(),
            (SM_PANEL.0 as i32 / 2 + 16, 14),
            cap_style.clone(),
        ))
        .map_err(backend_error)?;
    }
    Ok(())
}

#[cfg(test)]
#[path = "frf_plot_tests.rs"]
mod tests;
