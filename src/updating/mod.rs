//! Model updating (docs/theory.md §5, §6, §11): the predictor-corrector on FRF correlation
//! coefficients, the response function method as baseline and classical inverse eigensensitivity,
//! all driven one iteration at a time by [`run`], which owns the loop, the stop rule and the
//! history.
//!
//! Changes are unity-based (2.13–2.16: (2.13), (2.14), (2.15), (2.16)): every method solves for the
//! relative changes `Δφ_i/φ_i` with sensitivities `φ_i ∂(·)/∂φ_i`, and new values are clamped to
//! the bounds.

pub mod damping;
pub mod eigensensitivity;
pub mod model;
pub mod pc;
pub mod posterior;
pub mod rfm;
pub mod sensitive_start;
pub mod solve;
pub mod tmcmc;

pub use model::{
    Evaluated, FeModel, LinearModel, ModalState, ParametricModel, ReducedFeModel, UpdatingError,
    UpdatingParameter,
};
pub use solve::{Diagnostics, ParameterWeighting};

/// One iteration as recorded in the result.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct IterationRecord {
    /// 0-based iteration number (0 = the initial model).
    pub iteration: usize,
    /// Parameter values the iteration started from.
    pub values: Vec<f64>,
    /// Relative change applied, `Δφ_i/φ_i` (0 for frozen parameters and on the last record).
    pub relative_change: Vec<f64>,
    /// Parameters updated in this iteration (subset selection, bounds).
    pub active: Vec<bool>,
    /// Frequency lines (or modes) used for the equations.
    pub lines_used: usize,
    /// Mean `χ_s` over all measured lines (NaN where the method has no FRFs).
    pub mean_chi_s: f64,
    /// Mean `χ_a` over all measured lines.
    pub mean_chi_a: f64,
    /// Norm of the residual vector the step was solved from.
    pub residual_norm: f64,
    /// `κ_mn` of the subset selection (NaN when not used).
    pub condition_limit: f64,
    /// Added loss factor `g` of the frequency smoothing this iteration's equations were
    /// written with (0: none; see `frf::smoothing`).
    pub smoothing: f64,
    /// Mean `(χ_s + χ_a)/2` of the smoothed FRFs, the merit of a smoothed iteration (NaN when
    /// not smoothed); `mean_chi_s` and `mean_chi_a` are always those of the FRFs themselves.
    pub smoothed_mean_chi: f64,
    /// SVD of the (weighted) sensitivity matrix over all parameters.
    pub diagnostics: Diagnostics,
}

impl IterationRecord {
    /// `(χ_s + χ_a)/2` averaged over all lines: the P-C stop figure (4.23).
    pub fn mean_chi(&self) -> f64 {
        0.5 * (self.mean_chi_s + self.mean_chi_a)
    }

    /// One progress line: mean `χ_s`, `χ_a`, the active parameters, the largest relative step
    /// and the condition number of `S` (`step: false` for the closing analysis, which takes none).
    pub fn progress_line(&self, step: bool) -> String {
        let mut line = format!(
            "iteration {}: mean χ_s {:.4}, χ_a {:.4}",
            self.iteration, self.mean_chi_s, self.mean_chi_a
        );
        if step {
            let active = self.active.iter().filter(|a| **a).count();
            let biggest = self
                .relative_change
                .iter()
                .fold(0.0_f64, |a, d| a.max(d.abs()));
            line += &format!(
                ", {active}/{} parameters active, step {biggest:.3e}, condition {:.3e}",
                self.active.len(),
                self.diagnostics.condition
            );
        } else {
            line += " (final analysis)";
        }
        if self.smoothing > 0.0 {
            line += &format!(", smoothed (g = {:.3e})", self.smoothing);
        }
        line
    }
}

/// Why the iterations ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The stop rule was met (P-C: mean correlation; others: changes below tolerance).
    Converged,
    /// No equation was left to solve (every line already well correlated).
    NothingToUpdate,
    /// The step vanished (every parameter frozen or at a bound).
    Stalled,
    /// The maximum number of iterations was reached first.
    MaxIterations,
}

/// The outcome of one call of a method.
#[derive(Clone, Debug)]
pub struct Step {
    /// The record (values, correlation, diagnostics, the change applied).
    pub record: IterationRecord,
    /// Why to stop now, if so (no change was applied then).
    pub stop: Option<StopReason>,
    /// Safer steps to try, in order, when the step in `record` lowers the merit (e.g.
    /// increasingly damped ones); when empty the step is halved instead.
    pub fallbacks: Vec<Vec<f64>>,
    /// Steps of another kind, tried only when neither the step nor a fallback raises the merit
    /// (the P-C's Gauss-Newton steps on its stop figure, which rescue a stalled iteration).
    pub rescues: Vec<Vec<f64>>,
}

impl Step {
    /// A step without fallbacks.
    pub fn new(record: IterationRecord, stop: Option<StopReason>) -> Self {
        Step {
            record,
            stop,
            fallbacks: Vec::new(),
            rescues: Vec::new(),
        }
    }
}

/// An updating method: one iteration per call, from given parameter values.
pub trait UpdateMethod {
    /// Analyses the model at `values`, decides whether to stop, otherwise computes the step.
    fn iterate(
        &self,
        model: &dyn ParametricModel,
        values: &[f64],
        iteration: usize,
    ) -> Result<Step, UpdatingError>;
    /// Whether a step this small means convergence (methods without a correlation stop rule).
    fn converged_by_step(&self, _relative_change: &[f64]) -> bool {
        false
    }
    /// Whether the merit moved so little from `before` to `after` that iterating on is pointless
    /// (for methods whose data cannot be matched exactly, so the step never vanishes).
    fn converged_by_merit(&self, _before: &IterationRecord, _after: &IterationRecord) -> bool {
        false
    }
    /// A figure that a good step raises (none: every step is taken as computed).
    fn merit(&self, _record: &IterationRecord) -> Option<f64> {
        None
    }
}

/// The history of a run.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UpdateHistory {
    /// The parameters.
    pub parameters: Vec<UpdatingParameter>,
    /// One record per iteration; the last one is the final model's.
    pub iterations: Vec<IterationRecord>,
    /// Final values.
    pub final_values: Vec<f64>,
    /// Why it stopped.
    pub stop: StopReason,
    /// When the last iterate's merit fell below an earlier one's and the stop rule was not met,
    /// the iteration whose values are returned as `final_values` instead (the best seen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub returned_iteration: Option<usize>,
}

/// Applies a relative step with the bounds: `φ (1 + Δ)` clamped to `[lower, upper]`; returns the
/// new values and the relative change actually applied.
pub fn apply_step(
    params: &[UpdatingParameter],
    values: &[f64],
    delta: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let mut next = Vec::with_capacity(values.len());
    let mut applied = Vec::with_capacity(values.len());
    for ((p, &v), &d) in params.iter().zip(values).zip(delta) {
        let n = (v * (1.0 + d)).clamp(p.lower, p.upper);
        applied.push(if v != 0.0 { n / v - 1.0 } else { 0.0 });
        next.push(n);
    }
    (next, applied)
}

/// Most halvings of a step that made the method's merit worse.
pub const MAX_HALVINGS: usize = 6;

/// Iterates `method` from the model's initial values: at most `max_iterations` steps, then one
/// last analysis of the final model. Where the method has a merit (the P-C's mean
/// correlation) and offers fallback steps (the P-C's Levenberg-Marquardt damped steps), every
/// candidate is analysed and the one with the highest merit is taken — a small trust-region
/// search: far from the solution the undamped linearised step can improve the merit by a hair
/// and land badly. Without fallbacks a step that lowers the merit is halved, at most
/// [`MAX_HALVINGS`] times. The analysis at the chosen candidate is the next iteration's.
pub fn run(
    method: &dyn UpdateMethod,
    model: &dyn ParametricModel,
    max_iterations: usize,
) -> Result<UpdateHistory, UpdatingError> {
    run_from(method, model, &model.initial_values(), max_iterations)
}

/// Runs `phases` one after another, each from where the last ended (a continuation, e.g. the
/// P-C's smoothing phases before the P-C proper), sharing `max_iterations`: a phase that ends
/// early leaves its iterations to the next. The history holds every phase's iterations,
/// numbered on; a phase's closing analysis gives way to the next phase's opening one at the
/// same values. The stop reason is the last phase's.
pub fn run_phases(
    phases: &[&dyn UpdateMethod],
    model: &dyn ParametricModel,
    start: &[f64],
    max_iterations: usize,
) -> Result<UpdateHistory, UpdatingError> {
    let Some((last, first)) = phases.split_last() else {
        return Err(UpdatingError::Settings("no updating method to run".into()));
    };
    let mut done: Vec<IterationRecord> = Vec::new();
    let mut values = start.to_vec();
    let mut remaining = max_iterations;
    for phase in first {
        let mut h = run_from(*phase, model, &values, remaining)?;
        h.iterations.pop();
        remaining -= h.iterations.len();
        renumber(&mut h.iterations, done.len());
        done.append(&mut h.iterations);
        values = h.final_values;
    }
    let mut h = run_from(*last, model, &values, remaining)?;
    renumber(&mut h.iterations, done.len());
    done.append(&mut h.iterations);
    h.iterations = done;
    Ok(h)
}

fn renumber(records: &mut [IterationRecord], offset: usize) {
    for r in records {
        r.iteration += offset;
    }
}

/// [`run`] from `start` instead of the model's initial values (e.g. after
/// [`sensitive_start::sensitive_start`]); each start value must lie within its bounds.
pub fn run_from(
    method: &dyn UpdateMethod,
    model: &dyn ParametricModel,
    start: &[f64],
    max_iterations: usize,
) -> Result<UpdateHistory, UpdatingError> {
    let params = model.parameters().to_vec();
    if start.len() != params.len() {
        return Err(UpdatingError::Settings(format!(
            "{} start values for {} parameters",
            start.len(),
            params.len()
        )));
    }
    for (p, &v) in params.iter().zip(start) {
        if !(v.is_finite() && v != 0.0) {
            return Err(UpdatingError::Settings(format!(
                "parameter `{}` starts at {v}: unity-based updating needs a finite non-zero value",
                p.name
            )));
        }
        if !(p.lower <= v && v <= p.upper) {
            return Err(UpdatingError::Settings(format!(
                "parameter `{}` starts at {v:e}, outside its bounds [{:e}, {:e}]",
                p.name, p.lower, p.upper
            )));
        }
    }
    let n = params.len();
    let mut values = start.to_vec();
    let mut iterations = Vec::new();
    let mut current = method.iterate(model, &values, 0)?;
    let finish = |mut record: IterationRecord,
                  mut iterations: Vec<IterationRecord>,
                  values: Vec<f64>,
                  stop: StopReason| {
        record.relative_change = vec![0.0; n];
        record.active = vec![false; n];
        crate::core::progress::note(|| record.progress_line(false));
        iterations.push(record);
        let mut history = UpdateHistory {
            parameters: params.clone(),
            iterations,
            final_values: values,
            stop,
            returned_iteration: None,
        };
        keep_best_iterate(method, &mut history);
        Ok(history)
    };
    for it in 0..max_iterations {
        if let Some(stop) = current.stop {
            return finish(current.record, iterations, values, stop);
        }
        let mut delta = current.record.relative_change.clone();
        let (mut next_values, mut applied) = apply_step(&params, &values, &delta);
        let mut next = method.iterate(model, &next_values, it + 1)?;
        if let (Some(before), Some(_)) = (method.merit(&current.record), method.merit(&next.record))
        {
            if !current.fallbacks.is_empty() {
                // A trust-region search: the candidate with the highest merit wins.
                for f in &current.fallbacks {
                    let (v, a) = apply_step(&params, &values, f);
                    let candidate = method.iterate(model, &v, it + 1)?;
                    if method.merit(&candidate.record) > method.merit(&next.record) {
                        (next_values, applied, next) = (v, a, candidate);
                    }
                }
                if method.merit(&next.record) <= Some(before) {
                    for f in &current.rescues {
                        let (v, a) = apply_step(&params, &values, f);
                        let candidate = method.iterate(model, &v, it + 1)?;
                        if method.merit(&candidate.record) > method.merit(&next.record) {
                            (next_values, applied, next) = (v, a, candidate);
                        }
                    }
                }
            } else {
                let mut tries = 0;
                while tries < MAX_HALVINGS
                    && method
                        .merit(&next.record)
                        .is_some_and(|after| after < before)
                {
                    delta.iter_mut().for_each(|d| *d *= 0.5);
                    (next_values, applied) = apply_step(&params, &values, &delta);
                    next = method.iterate(model, &next_values, it + 1)?;
                    tries += 1;
                }
            }
        }
        let converged = method.converged_by_step(&applied)
            || method.converged_by_merit(&current.record, &next.record);
        let stalled = applied.iter().all(|d| d.abs() < 1e-12);
        let mut record = current.record;
        record.relative_change = applied;
        crate::core::progress::note(|| record.progress_line(true));
        iterations.push(record);
        values = next_values;
        current = next;
        if converged || stalled {
            let stop = current.stop.unwrap_or(if converged {
                StopReason::Converged
            } else {
                StopReason::Stalled
            });
            return finish(current.record, iterations, values, stop);
        }
    }
    let stop = current.stop.unwrap_or(StopReason::MaxIterations);
    finish(current.record, iterations, values, stop)
}

/// An update that did not meet its stop rule (iterations exhausted, or stalled) and whose last
/// iterate has a lower merit than an earlier one returns the best iterate's values instead,
/// with a warning: a model worse than the one the user started from must never be handed on
/// silently as "updated".
fn keep_best_iterate(method: &dyn UpdateMethod, history: &mut UpdateHistory) {
    if matches!(
        history.stop,
        StopReason::Converged | StopReason::NothingToUpdate
    ) {
        return;
    }
    let merits: Vec<f64> = history
        .iterations
        .iter()
        .filter_map(|r| method.merit(r))
        .collect();
    if merits.len() != history.iterations.len() {
        return;
    }
    let (Some(&last), Some(&first)) = (merits.last(), merits.first()) else {
        return;
    };
    let best = (0..merits.len())
        .max_by(|&a, &b| merits[a].total_cmp(&merits[b]).then(b.cmp(&a)))
        .unwrap_or(0);
    if !(merits[best] > last) {
        return;
    }
    let record = &history.iterations[best];
    if last < first {
        tracing::warn!(
            "the update ended ({:?}) worse than it began: merit {last:.4} against {first:.4} at the start; returning iteration {} (merit {:.4}) instead of the last iterate",
            history.stop,
            record.iteration,
            merits[best]
        );
    } else {
        tracing::warn!(
            "the update ended ({:?}) below its best iterate: merit {last:.4} against {:.4} at iteration {}; returning that iteration",
            history.stop,
            merits[best],
            record.iteration
        );
    }
    history.final_values = record.values.clone();
    history.returned_iteration = Some(record.iteration);
}

#[cfg(test)]
mod tests;
