//! The predictor-corrector (P-C) method (docs/theory.md §5; thesis 4.16–4.23: (4.16), (4.17),
//! (4.18), (4.19), (4.20), (4.21), (4.22), (4.23); 5.13–5.14: (5.13), (5.14)).
//!
//! At each updating line `ω_k`: `[1 − χ_s(ω_k); 1 − χ_a(ω_k)] = [∂χ_s/∂φ; ∂χ_a/∂φ] Δφ`, stacked into
//! `ε = S Δφ` (`2N_fu × N_φ`, real, unity-based). The lines are all measured lines except those
//! already well correlated, `(χ_s + χ_a)/2 > κ_f` (4.20), and those within `resonance_lines` line
//! spacings of a predicted natural frequency; they change every iteration. Rows are weighted by
//! `W_f = diag(χ_s, χ_a)` (4.21); the step minimises `εᵀW_fε + Δφᵀ W_φ Δφ` (4.18, 4.19) over the
//! parameters chosen by QR subset selection (5.13, 5.14). Stop (4.23) when the mean over all
//! lines of `(χ_s + χ_a)/2` reaches `stop_chi`. With a single FRF `χ_s ≡ 1` carries no
//! information, so only the `χ_a` rows are kept.

use super::model::{ModalState, ParametricModel, UpdatingError};
use super::solve::{
    ParameterWeighting, damped_step, diagnostics, select_subset, subset_condition_limit,
};
use super::{IterationRecord, Step, StopReason, UpdateMethod};
use crate::correlation::frf::{amplitude_correlation, shape_correlation};
use crate::eigen::ModeSelection;
use crate::frf::{FrequencySmoothing, FrfSet, ModalDamping, modal_receptance};
use crate::localisation::leverage::add_static_receptance;
use crate::sensitivity::{ModalFrfModel, chi_sensitivity, frf_sensitivities};
use faer::{Mat, MatRef, c64};

/// Settings of the P-C.
#[derive(Clone, Debug)]
pub struct PcSettings {
    /// Lines with `(χ_s + χ_a)/2 > κ_f` are left out (4.20); when no line remains, the
    /// worst-correlated lines, one per parameter, are taken instead ([`worst_lines`]).
    pub kappa_f: f64,
    /// Lines within this many line spacings of a predicted natural frequency are left out.
    pub resonance_lines: f64,
    /// Stop when the mean of `(χ_s + χ_a)/2` over all lines reaches this (4.23).
    pub stop_chi: f64,
    /// `κ` of the subset selection `κ_mn = 1 + κ(n/m)²`; `None` updates every parameter.
    pub subset_kappa: Option<f64>,
    /// `W_φ`.
    pub weighting: ParameterWeighting,
    /// Largest relative change of one parameter in one step (the step is scaled down to it).
    pub max_step: f64,
    /// Modes of the basis (the thesis: twice the band).
    pub modes: ModeSelection,
    /// Modal damping of the predictions.
    pub damping: ModalDamping,
    /// Add the truncated modes' static share to the mode-shape derivatives (see
    /// `sensitivity::frf::static_shape_correction`); off: the thesis's truncated form.
    pub static_correction: bool,
    /// Added loss factor `g` of a frequency smoothing of measured and predicted FRFs and of
    /// the sensitivities (`frf::smoothing`), 0 for none. With smoothing the equations use every
    /// line (the smoothed responses are defined at resonances too), the merit and the stop rule
    /// are the smoothed mean correlation, and the run ends when an iteration gains less than
    /// [`SMOOTHED_MERIT_GAIN`]: a continuation phase, not the final answer.
    pub smoothing: f64,
    /// Offer the Gauss-Newton steps on the stop figure itself ([`merit_equations`]) beside the
    /// P-C's own: the candidate with the highest mean correlation wins. Off: the thesis's
    /// steps alone.
    pub merit_steps: bool,
    /// Add the truncated modes' residual flexibility `R = G − Σ φφᵀ/(λ − σ)` at the measured
    /// DOFs to every prediction, and its derivative `∂R` to `S` (docs/theory.md §13, as in the
    /// localisation's static share); for models with physical matrices (a reduced model's
    /// constraint modes already hold the static share). Off: the modal sum alone (the thesis).
    pub residual_flexibility: bool,
}

/// A smoothed P-C phase ends when an iteration raises the smoothed mean correlation by less.
pub const SMOOTHED_MERIT_GAIN: f64 = 1e-3;

impl Default for PcSettings {
    fn default() -> Self {
        PcSettings {
            kappa_f: 0.95,
            resonance_lines: 1.0,
            stop_chi: 0.99,
            subset_kappa: None,
            weighting: ParameterWeighting::None,
            max_step: 1.0,
            modes: ModeSelection::All,
            damping: ModalDamping::None,
            static_correction: true,
            smoothing: 0.0,
            merit_steps: false,
            residual_flexibility: false,
        }
    }
}

/// The P-C against one measured FRF set.
pub struct PredictorCorrector<'a> {
    measured: &'a FrfSet,
    settings: PcSettings,
    /// With `settings.smoothing > 0`: the operator and the smoothed measurement.
    smoothed: Option<(FrequencySmoothing, FrfSet)>,
    /// With `settings.residual_flexibility`: the last full analysis's `R` at the measured pairs
    /// (each pair's rows, the matrix), added to trial predictions, which have no physical
    /// matrices to form their own.
    held_residual: std::sync::Mutex<Option<HeldResidual>>,
}

/// Each measured pair's (response, excitation) rows and `R` at the measured DOFs.
type HeldResidual = (Vec<(usize, usize)>, Mat<f64>);

impl<'a> PredictorCorrector<'a> {
    /// The P-C against `measured` (smoothed once here when `settings.smoothing > 0`).
    pub fn new(measured: &'a FrfSet, settings: PcSettings) -> Self {
        let smoothed = (settings.smoothing > 0.0).then(|| {
            let op = FrequencySmoothing::new(&measured.freqs_hz, settings.smoothing);
            let m = smooth_set(&op, measured);
            (op, m)
        });
        PredictorCorrector {
            measured,
            settings,
            smoothed,
            held_residual: std::sync::Mutex::new(None),
        }
    }
}

fn smooth_set(op: &FrequencySmoothing, set: &FrfSet) -> FrfSet {
    FrfSet {
        values: op.apply(set.values.as_ref()),
        ..set.clone()
    }
}

/// `χ_s(ω_k)`, `χ_a(ω_k)` of a prediction against the measurement at every measured line (4.8, 4.9).
#[derive(Clone, Debug)]
pub struct LineCorrelation {
    /// `χ_s` per line.
    pub chi_s: Vec<f64>,
    /// `χ_a` per line.
    pub chi_a: Vec<f64>,
}

impl LineCorrelation {
    /// Correlates `predicted` with `measured` line by line (same pairs and lines).
    pub fn new(measured: &FrfSet, predicted: &FrfSet) -> Self {
        let (nf, nq) = (measured.freqs_hz.len(), measured.pairs.len());
        let mut chi_s = Vec::with_capacity(nf);
        let mut chi_a = Vec::with_capacity(nf);
        for k in 0..nf {
            let x: Vec<c64> = (0..nq).map(|q| measured.values[(k, q)]).collect();
            let a: Vec<c64> = (0..nq).map(|q| predicted.values[(k, q)]).collect();
            chi_s.push(shape_correlation(&x, &a));
            chi_a.push(amplitude_correlation(&x, &a));
        }
        LineCorrelation { chi_s, chi_a }
    }

    /// Mean of `(χ_s + χ_a)/2` over all lines: the stop figure (4.23).
    pub fn mean_chi(&self) -> f64 {
        0.5 * (mean(&self.chi_s) + mean(&self.chi_a))
    }
}

/// The updating lines (4.20): lines with `(χ_s + χ_a)/2 ≤ κ_f` among the
/// [`off_resonance_lines`].
pub fn select_lines(
    freqs_hz: &[f64],
    lines: &LineCorrelation,
    natural_hz: &[f64],
    kappa_f: f64,
    resonance_lines: f64,
) -> Vec<usize> {
    off_resonance_lines(freqs_hz, natural_hz, resonance_lines)
        .into_iter()
        .filter(|&k| 0.5 * (lines.chi_s[k] + lines.chi_a[k]) <= kappa_f)
        .collect()
}

/// The `count` worst-correlated lines (lowest `(χ_s + χ_a)/2`, ascending line order) among the
/// [`off_resonance_lines`]: the updating lines when no line passes `κ_f`
/// (4.20), docs/theory.md (14.10). On ordinary lab data every line can correlate above the thesis's `κ_f = 0.95`
/// while the mean stays below the stop figure (4.23) (noise and small model errors spread
/// `1 − χ` thinly over the band), and the P-C would end with nothing to update; the worst
/// lines still carry the gradient toward the stop figure.
pub fn worst_lines(
    freqs_hz: &[f64],
    lines: &LineCorrelation,
    natural_hz: &[f64],
    resonance_lines: f64,
    count: usize,
) -> Vec<usize> {
    let mean = |k: usize| 0.5 * (lines.chi_s[k] + lines.chi_a[k]);
    let mut off = off_resonance_lines(freqs_hz, natural_hz, resonance_lines);
    off.retain(|&k| mean(k).is_finite());
    off.sort_by(|&a, &b| mean(a).total_cmp(&mean(b)).then(a.cmp(&b)));
    off.truncate(count);
    off.sort_unstable();
    off
}

/// The lines that lie more than `resonance_lines` line spacings from every predicted (elastic)
/// natural frequency.
pub fn off_resonance_lines(
    freqs_hz: &[f64],
    natural_hz: &[f64],
    resonance_lines: f64,
) -> Vec<usize> {
    let f = freqs_hz;
    let spacing = |k: usize| {
        let prev = if k > 0 { f[k] - f[k - 1] } else { 0.0 };
        let next = if k + 1 < f.len() {
            f[k + 1] - f[k]
        } else {
            0.0
        };
        prev.max(next)
    };
    (0..f.len())
        .filter(|&k| {
            let band = resonance_lines * spacing(k);
            natural_hz
                .iter()
                .all(|&fr| fr == 0.0 || (f[k] - fr).abs() > band)
        })
        .collect()
}

/// The P-C's linear equations `ε = S Δφ` (4.16) at the updating lines `chosen`.
///
/// `sensitivities[p]` is `∂H/∂φ_p` (already unity-scaled where the method wants it), `N_fu ×
/// N_pairs`, its row `i` at line `chosen[i]`. Per line the rows are `1 − χ_s` and `1 − χ_a` with
/// their gradients; with one FRF only the `χ_a` row (`χ_s ≡ 1`). With `weighted` every row is
/// multiplied by `√χ` of its own coefficient, so that least squares minimises `εᵀW_fε` (4.21).
pub fn correlation_equations(
    measured: &FrfSet,
    predicted: &FrfSet,
    chosen: &[usize],
    sensitivities: &[Mat<c64>],
    weighted: bool,
) -> (Mat<f64>, Vec<f64>) {
    let n = sensitivities.len();
    let nq = measured.pairs.len();
    let with_shape = nq > 1;
    let rows_per_line = if with_shape { 2 } else { 1 };
    let m = rows_per_line * chosen.len();
    let mut s = Mat::<f64>::zeros(m, n);
    let mut eps = vec![0.0; m];
    let weight = |chi: f64| if weighted { chi.max(0.0).sqrt() } else { 1.0 };
    for (row, &k) in chosen.iter().enumerate() {
        let x: Vec<c64> = (0..nq).map(|q| measured.values[(k, q)]).collect();
        let a: Vec<c64> = (0..nq).map(|q| predicted.values[(k, q)]).collect();
        let cols: Vec<Vec<c64>> = sensitivities
            .iter()
            .map(|sp| (0..nq).map(|q| sp[(row, q)]).collect())
            .collect();
        let refs: Vec<&[c64]> = cols.iter().map(|c| c.as_slice()).collect();
        let c = chi_sensitivity(&x, &a, &refs);
        let base = rows_per_line * row;
        let ra = if with_shape {
            let ws = weight(c.chi_s);
            eps[base] = ws * (1.0 - c.chi_s);
            for p in 0..n {
                s[(base, p)] = ws * c.d_chi_s[p];
            }
            base + 1
        } else {
            base
        };
        let wa = weight(c.chi_a);
        eps[ra] = wa * (1.0 - c.chi_a);
        for p in 0..n {
            s[(ra, p)] = wa * c.d_chi_a[p];
        }
    }
    (s, eps)
}

/// The equations of the Gauss-Newton step on the stop figure itself (4.23), from the
/// unweighted P-C equations `(S, ε)` (`ε = 1 − χ` per row) at every line that is not next to a
/// resonance.
///
/// Maximising the mean of `(χ_s + χ_a)/2` over the lines is minimising `Σ r²` with residuals
/// `r = √(1 − χ)`, whose Jacobian rows are `−∂χ/(2r)`. Their Gauss-Newton equations are the P-C's
/// rows scaled by `1/r` with right-hand side `2r`: the P-C's equations with `W_f = 1/(1 − χ)`
/// instead of `χ` (4.21), every line instead of the poorly correlated ones (4.20), and a
/// doubled right-hand side. Its fixed points are stationary points of the stop figure, which
/// the P-C's are not: with (4.20) and (4.21) the step can vanish where the mean correlation
/// still rises toward the solution (the bent plate of CASES C2 §4.6 stalls at 0.94 that way).
/// Near a perfect match `χ ≈ 1 − c e²`, so `r ≈ √c |e|` is linear in the error and the step
/// goes the whole way, where the P-C's goes half of it. `r` is floored at 10⁻⁶ so that a
/// perfectly matched line stays finite.
pub fn merit_equations(s: &mut Mat<f64>, eps: &mut [f64]) {
    for (i, e) in eps.iter_mut().enumerate() {
        let r = e.max(0.0).sqrt().max(1e-6);
        for p in 0..s.ncols() {
            s[(i, p)] /= r;
        }
        *e = 2.0 * r;
    }
}

/// The opening every correlation-based iteration shares: the record of the prediction's
/// correlation, then a stop by the rule (4.23) or for want of lines, or the updating lines
/// (4.20) — the [`worst_lines`], one per parameter, with a warning, when none passes `κ_f`
/// (the thesis's selection is kept whenever it leaves any line).
#[allow(clippy::too_many_arguments)]
pub(super) fn open_iteration(
    measured: &FrfSet,
    predicted: &FrfSet,
    natural_hz: &[f64],
    values: &[f64],
    iteration: usize,
    kappa_f: f64,
    resonance_lines: f64,
    stop_chi: f64,
) -> (IterationRecord, Option<StopReason>, Vec<usize>) {
    let n = values.len();
    let lines = LineCorrelation::new(measured, predicted);
    let mut record = IterationRecord {
        iteration,
        values: values.to_vec(),
        relative_change: vec![0.0; n],
        active: vec![false; n],
        lines_used: 0,
        mean_chi_s: mean(&lines.chi_s),
        mean_chi_a: mean(&lines.chi_a),
        residual_norm: 0.0,
        condition_limit: f64::NAN,
        smoothing: 0.0,
        smoothed_mean_chi: f64::NAN,
        diagnostics: Default::default(),
    };
    if record.mean_chi() >= stop_chi {
        return (record, Some(StopReason::Converged), Vec::new());
    }
    let mut chosen = select_lines(
        &measured.freqs_hz,
        &lines,
        natural_hz,
        kappa_f,
        resonance_lines,
    );
    if chosen.is_empty() {
        let worst = worst_lines(&measured.freqs_hz, &lines, natural_hz, resonance_lines, n);
        if worst.len() > chosen.len() {
            // A routine turn near convergence with the defaults: said beside the iteration's
            // line (a log warning broke into the progress lines with its own format).
            crate::core::progress::note(|| {
                format!(
                    "no line has (χ_s + χ_a)/2 ≤ kappa_f = {kappa_f} (mean χ {:.4}, stop at {stop_chi}): the {} worst-correlated lines off the resonances are used, one per parameter (raise kappa_f to choose the lines yourself)",
                    record.mean_chi(),
                    worst.len()
                )
            });
            chosen = worst;
        }
    }
    record.lines_used = chosen.len();
    let stop = chosen.is_empty().then_some(StopReason::NothingToUpdate);
    (record, stop, chosen)
}

/// The closing every correlation-based iteration shares, from the weighted `S` and `ε`: the
/// residual and the diagnostics of `S`, the active parameters (QR subset selection with
/// `κ_mn`, 5.13–5.14: (5.13), (5.14); or every parameter `S` sees), and the Gauss-Newton step with
/// its candidates ([`candidate_steps`]), each scaled down to a largest relative change of
/// `max_step`.
pub(super) fn close_iteration(
    mut record: IterationRecord,
    sw: MatRef<'_, f64>,
    ew: &[f64],
    subset_kappa: Option<f64>,
    weighting: ParameterWeighting,
    max_step: f64,
    merit: Option<(MatRef<'_, f64>, &[f64])>,
) -> Step {
    let (m, n) = (sw.nrows(), sw.ncols());
    record.residual_norm = ew.iter().map(|e| e * e).sum::<f64>().sqrt();
    record.diagnostics = diagnostics(sw);
    let active: Vec<usize> = match subset_kappa {
        Some(kappa) => {
            let limit = subset_condition_limit(kappa, m, n);
            record.condition_limit = limit;
            select_subset(sw, limit)
        }
        None => (0..n)
            .filter(|&p| (0..m).any(|i| sw[(i, p)] != 0.0))
            .collect(),
    };
    let cap = |mut d: Vec<f64>| {
        let biggest = d.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
        if biggest > max_step {
            let f = max_step / biggest;
            d.iter_mut().for_each(|x| *x *= f);
        }
        d
    };
    let step = |mu: f64| cap(damped_step(sw, ew, &active, weighting, mu));
    let delta = step(0.0);
    let mut fallbacks = candidate_steps(&delta, &cap, step);
    // The merit's Gauss-Newton step and its Levenberg-Marquardt relatives (μ = 10⁻¹ … 10²).
    if let Some((sm, em)) = merit {
        let merit_step = |mu: f64| cap(damped_step(sm, em, &active, weighting, mu));
        fallbacks.extend(
            std::iter::once(0.0)
                .chain((-1..=2).map(|e| 10f64.powi(e)))
                .map(merit_step),
        );
    }
    for &a in &active {
        record.active[a] = true;
    }
    record.relative_change = delta;
    Step {
        record,
        stop: None,
        fallbacks,
    }
}

/// The candidates beside the Gauss-Newton step `delta` that [`super::run`] analyses, keeping the
/// one with the highest mean correlation: the doubled step, then Levenberg-Marquardt steps with
/// `μ = 10⁻², …, 10²` (`damped(μ)`), each capped by `cap`.
///
/// Why the doubled step: a perfect match is a maximum of `χ`, so near it `1 − χ` is quadratic
/// in the parameter error `e` (`½ eᵀHe`) and its gradient linear (`He`). The equations
/// `S Δ = 1 − χ` (4.16) are then Newton's method on a double root, whose least-squares step is
/// `Δ = −e/2`: the error halves per iteration. `2Δ` restores the full step there; far from the
/// solution, or with noisy data whose best `χ` stays below 1, the merit decides.
fn candidate_steps(
    delta: &[f64],
    cap: &impl Fn(Vec<f64>) -> Vec<f64>,
    damped: impl Fn(f64) -> Vec<f64>,
) -> Vec<Vec<f64>> {
    std::iter::once(cap(delta.iter().map(|d| 2.0 * d).collect()))
        .chain((-2..=2).map(|e| damped(10f64.powi(e))))
        .collect()
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Predicted FRFs at the measured pairs and lines from a modal state.
pub fn predict(
    state: &ModalState,
    measured: &FrfSet,
    damping: &ModalDamping,
) -> Result<FrfSet, UpdatingError> {
    let dofs = measured.dofs();
    let modes = crate::eigen::Modes {
        eigenvalues: state.modes.eigenvalues.clone(),
        shapes: state.shapes_at(&dofs)?,
        residuals: Vec::new(),
        orthogonality_error: state.modes.orthogonality_error,
        rigid_body_modes: state.modes.rigid_body_modes,
    };
    Ok(modal_receptance(
        &modes,
        &dofs,
        damping,
        &measured.pairs,
        &measured.freqs_hz,
        measured.quantity,
    )?)
}

/// Per parameter: Wang's `ρ` (measured DOFs × modes) and `φ ∂R/∂φ` (measured DOFs²).
type ShareTerms = (Mat<f64>, Mat<f64>);

/// The truncated modes' residual flexibility at the measured DOFs (docs/theory.md §13, as in
/// `localisation::residual`): `R = G − Σ_kept φφᵀ/(λ − σ)` added to each prediction (times the
/// quantity's `(iω)ⁿ`), and per parameter `∂R` added to the FRF sensitivities. Through a test
/// map both are read at the model DOFs it names and combined, `W R Wᵀ` (14.9).
struct ResidualFlexibility {
    share: crate::localisation::StaticShare,
    /// The kept modes at the model DOFs read.
    shapes: Mat<f64>,
    weights: Option<crate::sensitivity::RowWeights>,
    /// Each measured pair's (response, excitation) rows in the measured DOFs.
    rows: Vec<(usize, usize)>,
}

impl ResidualFlexibility {
    fn new(
        evaluated: &super::model::Evaluated,
        state: &ModalState,
        measured: &FrfSet,
    ) -> Result<Self, UpdatingError> {
        let dofs = measured.dofs();
        let through = state.sensor_rows(&dofs)?;
        let udofs = through.as_ref().map_or(&dofs, |(u, _)| u);
        let shapes = state.model_shapes_at(udofs)?;
        // The eigensolver's factor serves when it factored this model (a trial state has none).
        let eigen_factor =
            state
                .factor
                .as_deref()
                .map(|factor| crate::sensitivity::frf::EigenFactor {
                    factor,
                    shapes: state.modes.shapes.as_ref(),
                });
        let share = crate::localisation::StaticShare::with_factor(
            &evaluated.system,
            &state.modes,
            udofs,
            eigen_factor,
        )
        .map_err(|e| UpdatingError::Model(format!("residual_flexibility: {e}")))?;
        let rows = crate::sensitivity::frf::pair_rows(&dofs, &measured.pairs)?;
        Ok(ResidualFlexibility {
            share,
            shapes,
            weights: through.map(|(_, w)| w),
            rows,
        })
    }

    fn combined(&self, r: Mat<f64>) -> Mat<f64> {
        match &self.weights {
            Some(w) => w.both_sides(r.as_ref()),
            None => r,
        }
    }

    /// `R` at the measured DOFs (through the map, `W R Wᵀ`).
    fn matrix(&self, eigenvalues: &[f64]) -> Mat<f64> {
        self.combined(self.share.flexibility(eigenvalues, self.shapes.as_ref()))
    }

    /// Per parameter, unity-scaled: Wang's correction `ρ` of the kept mode-shape derivatives
    /// at the measured DOFs and `φ ∂R/∂φ`, both about this share's shift (the modal part's `ρ`
    /// must be this one for the truncated shares of `H` and `R` to cancel as they should).
    fn terms(
        &self,
        evaluated: &super::model::Evaluated,
        values: &[f64],
        state: &ModalState,
    ) -> Result<Vec<ShareTerms>, UpdatingError> {
        use rayon::prelude::*;
        let eigenvalues = state.modes.eigenvalues.as_slice();
        let phi = state.modes.shapes.as_ref();
        evaluated
            .derivatives
            .par_iter()
            .zip(values.par_iter())
            .zip(state.projected.par_iter())
            .map(|(((dk, dm), &value), p)| {
                let d = crate::localisation::LocalDerivative::from_global(dk, dm)
                    .map_err(|e| UpdatingError::Model(format!("residual_flexibility: {e}")))?;
                let (rho, dr) = self.share.candidate_terms(
                    &d,
                    value,
                    eigenvalues,
                    phi,
                    self.shapes.as_ref(),
                    p,
                );
                Ok(match &self.weights {
                    Some(w) => (w.rows(rho.as_ref()), w.both_sides(dr.as_ref())),
                    None => (rho, dr),
                })
            })
            .collect()
    }

    /// Adds each parameter's `φ ∂R/∂φ` (from [`Self::terms`]) to its sensitivities at
    /// `freqs_hz`.
    fn add_derivatives(
        &self,
        sens: &mut [Mat<c64>],
        terms: &[ShareTerms],
        freqs_hz: &[f64],
        quantity: crate::frf::Quantity,
    ) {
        for (s, (_, dr)) in sens.iter_mut().zip(terms) {
            add_static_receptance(s, freqs_hz, quantity, &self.rows, dr.as_ref());
        }
    }
}

impl UpdateMethod for PredictorCorrector<'_> {
    fn iterate(
        &self,
        model: &dyn ParametricModel,
        values: &[f64],
        iteration: usize,
    ) -> Result<Step, UpdatingError> {
        let s = &self.settings;
        let (state, evaluated) = model.modal_state(values, s.modes)?;
        let (raw, residual) = self.prediction(&state, evaluated.as_ref())?;
        let residual = residual.zip(evaluated.as_ref());
        let natural_hz = state.modes.frequencies_hz();
        // Smoothed responses are defined at resonances: no line is left out for being next to
        // one.
        let own = self
            .smoothed
            .as_ref()
            .map(|_| LineCorrelation::new(self.measured, &raw));
        let (measured, predicted, resonances) = match &self.smoothed {
            Some((op, m)) => (m, smooth_set(op, &raw), &[][..]),
            None => (self.measured, raw, &natural_hz[..]),
        };
        let (mut record, stop, chosen) = open_iteration(
            measured,
            &predicted,
            resonances,
            values,
            iteration,
            s.kappa_f,
            s.resonance_lines,
            s.stop_chi,
        );
        if let Some(own) = own {
            record.smoothing = s.smoothing;
            record.smoothed_mean_chi = record.mean_chi();
            record.mean_chi_s = mean(&own.chi_s);
            record.mean_chi_a = mean(&own.chi_a);
        }
        if stop.is_some() {
            return Ok(Step::new(record, stop));
        }

        // Sensitivities on the DOFs the pairs need: at every line when smoothing (which mixes
        // them), at every line off the resonances for the merit's steps, else at the P-C's
        // chosen lines (always among them).
        let all_lines = match &self.smoothed {
            Some(_) => (0..measured.freqs_hz.len()).collect(),
            None if !s.merit_steps => chosen.clone(),
            None => off_resonance_lines(&measured.freqs_hz, resonances, s.resonance_lines),
        };
        let dofs = self.measured.dofs();
        let shapes = state.shapes_at(&dofs)?;
        let modal = ModalFrfModel {
            eigenvalues: &state.modes.eigenvalues,
            shapes: shapes.as_ref(),
            dofs: &dofs,
            damping: &s.damping,
        };
        let freqs: Vec<f64> = all_lines.iter().map(|&k| measured.freqs_hz[k]).collect();
        // A reduced model's constraint/residual modes already hold the static share. With the
        // residual flexibility, Wang's `ρ` comes from its share (the same shift as `∂R`).
        let residual_terms = match &residual {
            Some((r, ev)) => Some(r.terms(ev, values, &state)?),
            None => None,
        };
        let corrections = match (&residual_terms, &evaluated, s.static_correction) {
            (Some(t), _, _) => Some(t.iter().map(|(rho, _)| rho.clone()).collect::<Vec<_>>()),
            (None, Some(ev), true) => Some(state.shape_corrections(ev, values, &dofs)?),
            _ => None,
        };
        let mut sens = frf_sensitivities(
            &modal,
            &measured.pairs,
            &freqs,
            measured.quantity,
            &state.projected,
            corrections.as_deref(),
        )?;
        if let (Some((r, _)), Some(t)) = (&residual, &residual_terms) {
            r.add_derivatives(&mut sens, t, &freqs, measured.quantity);
        }
        if let Some((op, _)) = &self.smoothed {
            sens = sens.iter().map(|d| op.apply(d.as_ref())).collect();
        }

        // S and ε at the chosen lines, rows weighted by W_f^{1/2} (4.21); and the merit's
        // Gauss-Newton equations at all of them.
        let picked;
        let chosen_sens = if all_lines == chosen {
            &sens
        } else {
            // Both ascending, `chosen` within `all_lines`.
            let rows: Vec<usize> = chosen
                .iter()
                .map(|k| all_lines.binary_search(k).unwrap_or_default())
                .collect();
            picked = sens
                .iter()
                .map(|d| Mat::from_fn(rows.len(), d.ncols(), |i, q| d[(rows[i], q)]))
                .collect::<Vec<Mat<c64>>>();
            &picked
        };
        let (sw, ew) = correlation_equations(measured, &predicted, &chosen, chosen_sens, true);
        let merit = s.merit_steps.then(|| {
            let (mut sm, mut em) =
                correlation_equations(measured, &predicted, &all_lines, &sens, false);
            merit_equations(&mut sm, &mut em);
            (sm, em)
        });
        Ok(close_iteration(
            record,
            sw.as_ref(),
            &ew,
            s.subset_kappa,
            s.weighting,
            s.max_step,
            merit.as_ref().map(|(sm, em)| (sm.as_ref(), &em[..])),
        ))
    }

    /// A smoothed phase ends when the smoothed merit stops rising.
    fn converged_by_merit(&self, before: &IterationRecord, after: &IterationRecord) -> bool {
        self.smoothed.is_some()
            && after.smoothed_mean_chi - before.smoothed_mean_chi < SMOOTHED_MERIT_GAIN
    }

    fn merit(&self, record: &IterationRecord) -> Option<f64> {
        Some(match self.smoothed {
            Some(_) => record.smoothed_mean_chi,
            None => record.mean_chi(),
        })
    }

    /// [`Self::merit`] of the prediction on the model's trial state, without sensitivities.
    fn trial_merit(
        &self,
        model: &dyn ParametricModel,
        values: &[f64],
    ) -> Result<Option<f64>, UpdatingError> {
        let Some(state) = model.trial_modal_state(values, self.settings.modes)? else {
            return Ok(None);
        };
        let (raw, _) = self.prediction(&state, None)?;
        Ok(Some(match &self.smoothed {
            Some((op, m)) => LineCorrelation::new(m, &smooth_set(op, &raw)).mean_chi(),
            None => LineCorrelation::new(self.measured, &raw).mean_chi(),
        }))
    }
}

impl PredictorCorrector<'_> {
    /// The predicted FRFs at the measured pairs and lines, with the residual flexibility added
    /// when asked for and the physical matrices are at hand (`evaluated`).
    fn prediction(
        &self,
        state: &ModalState,
        evaluated: Option<&super::model::Evaluated>,
    ) -> Result<(FrfSet, Option<ResidualFlexibility>), UpdatingError> {
        let mut raw = predict(state, self.measured, &self.settings.damping)?;
        if !self.settings.residual_flexibility {
            return Ok((raw, None));
        }
        let residual = match evaluated {
            Some(ev) => {
                let r = ResidualFlexibility::new(ev, state, self.measured)?;
                let matrix = r.matrix(state.modes.eigenvalues.as_slice());
                if let Ok(mut held) = self.held_residual.lock() {
                    *held = Some((r.rows.clone(), matrix.clone()));
                }
                add_residual(&mut raw, &r.rows, matrix.as_ref());
                Some(r)
            }
            // A trial state: the residual flexibility of the last full analysis, held like its
            // basis (it changes with the parameters far less than the kept modes do).
            None => {
                let held = self.held_residual.lock().ok().and_then(|h| h.clone());
                if let Some((rows, matrix)) = held {
                    add_residual(&mut raw, &rows, matrix.as_ref());
                }
                None
            }
        };
        Ok((raw, residual))
    }
}

/// Adds the static receptance `r` (measured DOFs²) to every line of `set` at the pairs' `rows`.
fn add_residual(set: &mut FrfSet, rows: &[(usize, usize)], r: MatRef<'_, f64>) {
    add_static_receptance(&mut set.values, &set.freqs_hz, set.quantity, rows, r);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::element::MassKind;
    use crate::frf::Quantity;
    use crate::updating::model::FeModel;

    /// The residual flexibility on the thesis's truncated basis (modes to 200 Hz, lines to
    /// 120 Hz, clamped bent plate): the prediction comes closer to the complete basis's
    /// (at least 5×), and the P-C's sensitivities with `ρ` and `∂R` match central differences
    /// of the corrected prediction `H + R` to 1 % of each FRF's largest derivative, at most
    /// 0.8 of the miss of the truncated sum's sensitivities against its own differences: the
    /// approximations of `ρ` (Wang's, exact to `λ_r/λ_s` of the truncated modes) enter `∂H`
    /// and `∂R` with opposite signs and cancel below the cut. On the complete basis `∂R`
    /// vanishes to rounding.
    #[test]
    fn residual_flexibility_prediction_and_derivative() {
        use crate::updating::tests::{clamped_plate_three_strips, three_measured_dofs};
        let fe = FeModel::new(clamped_plate_three_strips(), &[], MassKind::Consistent).unwrap();
        let values = fe.initial_values();
        let dofs = three_measured_dofs();
        let pairs = FrfSet::all_pairs(&dofs, &dofs[..1]);
        let freqs = [13.0, 37.5, 61.0, 88.0];
        let damping = ModalDamping::Structural(vec![0.01]);
        let sel = ModeSelection::BelowHz(200.0);
        let predict_at = |v: &[f64], sel: ModeSelection, residual: bool| {
            let ev = fe.evaluate(v).unwrap();
            let st = ModalState::new(&ev, v, sel).unwrap();
            let mut h = crate::frf::modal_receptance(
                &st.modes,
                &st.dofs,
                &damping,
                &pairs,
                &freqs,
                Quantity::Receptance,
            )
            .unwrap();
            if residual {
                let r = ResidualFlexibility::new(&ev, &st, &h).unwrap();
                add_residual(&mut h, &r.rows, r.matrix(&st.modes.eigenvalues).as_ref());
            }
            h
        };
        let complete = predict_at(&values, ModeSelection::All, false);
        let err = |h: &FrfSet| {
            (0..freqs.len())
                .flat_map(|k| (0..pairs.len()).map(move |q| (k, q)))
                .map(|(k, q)| {
                    (h.values[(k, q)] - complete.values[(k, q)]).norm()
                        / complete.values[(k, q)].norm()
                })
                .fold(0.0, f64::max)
        };
        let (plain, corrected) = (
            err(&predict_at(&values, sel, false)),
            err(&predict_at(&values, sel, true)),
        );
        println!("truncated: {plain:.3e}, with R: {corrected:.3e}");
        assert!(corrected < 0.2 * plain, "{plain:.3e} -> {corrected:.3e}");

        let ev = fe.evaluate(&values).unwrap();
        let st = ModalState::new(&ev, &values, sel).unwrap();
        let shapes = st.shapes_at(&dofs).unwrap();
        let modal = ModalFrfModel {
            eigenvalues: &st.modes.eigenvalues,
            shapes: shapes.as_ref(),
            dofs: &dofs,
            damping: &damping,
        };
        let h = predict_at(&values, sel, false);
        let r = ResidualFlexibility::new(&ev, &st, &h).unwrap();
        let terms = r.terms(&ev, &values, &st).unwrap();
        let corr: Vec<Mat<f64>> = terms.iter().map(|t| t.0.clone()).collect();
        let plain_sens = frf_sensitivities(
            &modal,
            &pairs,
            &freqs,
            Quantity::Receptance,
            &st.projected,
            Some(&corr),
        )
        .unwrap();
        let mut sens = plain_sens.clone();
        r.add_derivatives(&mut sens, &terms, &freqs, Quantity::Receptance);
        for p in 0..values.len() {
            let step = 1e-4;
            let (mut up, mut down) = (values.clone(), values.clone());
            up[p] *= 1.0 + step;
            down[p] *= 1.0 - step;
            let difference = |residual: bool| {
                let (hu, hd) = (
                    predict_at(&up, sel, residual),
                    predict_at(&down, sel, residual),
                );
                Mat::from_fn(freqs.len(), pairs.len(), |k, q| {
                    (hu.values[(k, q)] - hd.values[(k, q)]) / c64::new(2.0 * step, 0.0)
                })
            };
            let (fd, fd_plain) = (difference(true), difference(false));

            // Each FRF's error against its largest derivative over the lines.
            let worst = |s: &Mat<c64>, against: &Mat<c64>| {
                (0..pairs.len())
                    .map(|q| {
                        let scale = (0..freqs.len())
                            .map(|k| against[(k, q)].norm())
                            .fold(0.0, f64::max);
                        (0..freqs.len())
                            .map(|k| (s[(k, q)] - against[(k, q)]).norm() / scale)
                            .fold(0.0, f64::max)
                    })
                    .fold(0.0, f64::max)
            };
            let (with, plain) = (worst(&sens[p], &fd), worst(&plain_sens[p], &fd_plain));
            println!("t{p}: with R and dR {with:.2e}; the truncated sum alone {plain:.2e}");
            assert!(with < 1e-2, "parameter {p}: {with:.3e}");
            assert!(
                with < 0.8 * plain,
                "parameter {p}: {with:.3e} against {plain:.3e}"
            );
        }

        // On the complete basis R vanishes, and so must ∂R: its two parts, −G ∂Z_σ G and the
        // kept modes' ∂Σ φφᵀ/(λ − σ), cancel to rounding (a wrong sign or scale of either
        // would leave them apart by their own size).
        let full = ModalState::new(&ev, &values, ModeSelection::All).unwrap();
        let r_full = ResidualFlexibility::new(&ev, &full, &h).unwrap();
        let size = terms.iter().map(|t| t.1.norm_max()).fold(0.0, f64::max);
        let own = r_full.share.x.norm_max();
        for (p, (_, dr)) in r_full
            .terms(&ev, &values, &full)
            .unwrap()
            .iter()
            .enumerate()
        {
            println!(
                "complete basis: |dR| {:.2e} (truncated {size:.2e}, |G| {own:.2e})",
                dr.norm_max()
            );
            assert!(
                dr.norm_max() < 1e-6 * own,
                "parameter {p}: {:.3e}",
                dr.norm_max()
            );
        }
    }
}
