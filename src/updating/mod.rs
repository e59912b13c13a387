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
pub mod likelihoods;
pub mod mala;
pub mod model;
pub mod pc;
pub mod posterior;
pub mod rfm;
pub mod sensitive_start;
pub mod solve;
pub mod tmcmc;
#[cfg(test)]
mod toy;
pub mod trial_projection;

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

    /// One progress line, numbered `first + iteration` (`first`: the iterations of earlier
    /// phases): mean `χ_s`, `χ_a`, then for a step the active parameters, the lines used
    /// (`used` names them: [`UpdateMethod::equations_from`]), the largest relative step and
    /// the condition number of `S`, or for the closing analysis, which takes no step, what it
    /// closes (`Closing`).
    pub fn progress_line(&self, first: usize, step: Result<&str, Closing>) -> String {
        let mut line = format!(
            "iteration {}: mean χ_s {:.4}, χ_a {:.4}",
            first + self.iteration,
            self.mean_chi_s,
            self.mean_chi_a
        );
        match step {
            Ok(used) => {
                let active = self.active.iter().filter(|a| **a).count();
                let biggest = self
                    .relative_change
                    .iter()
                    .fold(0.0_f64, |a, d| a.max(d.abs()));
                // Fewer equations than parameters (few lines chosen) leave `S` rank-deficient:
                // its condition number is then infinite, which says less than the word.
                let condition = match self.diagnostics.condition {
                    c if c.is_infinite() => "S rank-deficient".to_string(),
                    c => format!("condition {c:.3e}"),
                };
                line += &format!(
                    ", {active}/{} parameters active, {} {used}, step {biggest:.3e}, {condition}",
                    self.active.len(),
                    self.lines_used,
                );
            }
            Err(Closing::Update) => line += " (final analysis)",
            Err(Closing::Phase { phase, phases }) => {
                line += &format!(" (end of phase {phase} of {phases})")
            }
        }
        if self.smoothing > 0.0 {
            line += &format!(", smoothed (g = {:.3e})", self.smoothing);
        }
        line
    }
}

/// What the analysis closing a run of iterations closes (its progress line says it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Closing {
    /// The update: its final analysis.
    Update,
    /// A phase of a continuation ([`run_phases`]); the next phase opens at the same values.
    Phase {
        /// Which phase, from 1.
        phase: usize,
        /// How many phases the update has.
        phases: usize,
    },
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
    /// Other candidate steps beside the one in `record` (e.g. increasingly damped ones), for
    /// the trust-region search of [`run_from`]; when empty a step that lowers the merit is
    /// halved instead.
    pub fallbacks: Vec<Vec<f64>>,
}

impl Step {
    /// A step without fallbacks.
    pub fn new(record: IterationRecord, stop: Option<StopReason>) -> Self {
        Step {
            record,
            stop,
            fallbacks: Vec::new(),
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
    /// What its equations come from, as [`IterationRecord::lines_used`] counts them.
    fn equations_from(&self) -> &'static str {
        "lines"
    }
    /// A figure that a good step raises (none: every step is taken as computed).
    fn merit(&self, _record: &IterationRecord) -> Option<f64> {
        None
    }
    /// The merit at `values` from a trial analysis cheaper than [`Self::iterate`]'s, to rank
    /// candidate steps ([`ParametricModel::trial_modal_state`]); `None` when there is none and
    /// each candidate is analysed in full.
    fn trial_merit(
        &self,
        _model: &dyn ParametricModel,
        _values: &[f64],
    ) -> Result<Option<f64>, UpdatingError> {
        Ok(None)
    }
}

/// A candidate step of the trust-region search in [`run_from`].
struct Candidate {
    values: Vec<f64>,
    applied: Vec<f64>,
    /// The trial merit, or the full analysis's when `full` holds it.
    merit: f64,
    full: Option<Step>,
}

impl Candidate {
    /// The step `delta` from `values`, ranked by its trial merit where the method has one, else
    /// analysed in full.
    fn assess(
        method: &dyn UpdateMethod,
        model: &dyn ParametricModel,
        params: &[UpdatingParameter],
        values: &[f64],
        delta: &[f64],
        iteration: usize,
    ) -> Result<Candidate, UpdatingError> {
        let (values, applied) = apply_step(params, values, delta);
        // A trial that fails (its held basis no longer fits) is no verdict: the candidate is
        // analysed in full, and an error there is the model's.
        let trial = method.trial_merit(model, &values).unwrap_or_else(|e| {
            tracing::debug!("trial merit failed ({e}): analysing the candidate in full");
            None
        });
        let (merit, full) = match trial {
            Some(m) => (m, None),
            None => {
                let step = method.iterate(model, &values, iteration)?;
                (
                    method.merit(&step.record).unwrap_or(f64::NEG_INFINITY),
                    Some(step),
                )
            }
        };
        Ok(Candidate {
            values,
            applied,
            merit: if merit.is_nan() {
                f64::NEG_INFINITY
            } else {
                merit
            },
            full,
        })
    }
}

/// The trust-region search of [`run_from`]: the step in `current` and its fallbacks ranked by
/// merit — a trial merit where the method has one ([`UpdateMethod::trial_merit`]), else a full
/// analysis's — and analysed in full in that order until the best analysed is confirmed (see
/// the loop); the best full analysis wins. Returns the values, the change applied and the
/// analysis there.
fn trust_region_step(
    method: &dyn UpdateMethod,
    model: &dyn ParametricModel,
    params: &[UpdatingParameter],
    values: &[f64],
    current: &Step,
    before: f64,
    iteration: usize,
) -> Result<(Vec<f64>, Vec<f64>, Step), UpdatingError> {
    let assess =
        |delta: &Vec<f64>| Candidate::assess(method, model, params, values, delta, iteration);
    let mut candidates = std::iter::once(&current.record.relative_change)
        .chain(&current.fallbacks)
        .map(assess)
        .collect::<Result<Vec<_>, _>>()?;
    // Best first; among equals the earlier (the undamped step before its damped relatives).
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&a, &b| candidates[b].merit.total_cmp(&candidates[a].merit));
    tracing::debug!(
        "iteration {iteration}: candidates ranked {:?}",
        order
            .iter()
            .map(|&i| format!("{i}: {:.6}", candidates[i].merit))
            .collect::<Vec<_>>()
    );
    let mut best: Option<(usize, Step, f64)> = None;
    let mut misled = false;
    for (rank, &i) in order.iter().enumerate() {
        let exact = candidates[i].full.is_some();
        let step = match candidates[i].full.take() {
            Some(step) => step,
            None => method.iterate(model, &candidates[i].values, iteration)?,
        };
        let merit = method.merit(&step.record).unwrap_or(f64::NEG_INFINITY);
        tracing::debug!(
            "iteration {iteration}: candidate {i} of {}: merit {:.6} ranked, {merit:.6} analysed (from {before:.6})",
            candidates.len(),
            candidates[i].merit
        );
        if best.as_ref().is_none_or(|(_, _, m)| merit > *m) {
            best = Some((i, step, merit));
        }
        // A full merit ranks exactly: the first is the best. Trial merits rank while the
        // analyses confirm them: once one misses its analysed merit by more than
        // TRIAL_ACCURACY of the gain it promised (either way: a step the held bases cannot
        // follow), every candidate is analysed. Trusted, the search ends when the best
        // analysed raises the merit and no candidate left is ranked above it, or after
        // MAX_CONFIRMATIONS analyses that raised it.
        let promised = candidates[i].merit - before;
        misled |= (merit - candidates[i].merit).abs() > TRIAL_ACCURACY * promised.abs();
        let best_merit = best.as_ref().map_or(f64::NEG_INFINITY, |b| b.2);
        let next = order.get(rank + 1).map(|&j| candidates[j].merit);
        if exact
            || (!misled
                && best_merit > before
                && (next.is_none_or(|m| m <= best_merit) || rank + 1 >= MAX_CONFIRMATIONS))
        {
            break;
        }
    }
    let (i, step, _) = best.ok_or_else(|| UpdatingError::Settings("no candidate step".into()))?;
    let c = candidates.swap_remove(i);
    Ok((c.values, c.applied, step))
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
    /// What the user should know about this result (e.g. that the best iterate was returned),
    /// recorded with it so that a cached result tells it again.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
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

/// How closely, as a share of the merit gain a trial analysis promised, the full analysis must
/// confirm it for the trial merits to keep ranking the candidates ([`run_from`]).
pub const TRIAL_ACCURACY: f64 = 0.5;

/// Most full analyses of trial-ranked candidate steps per iteration once one of them has
/// raised the merit ([`run_from`]'s trust-region search).
pub const MAX_CONFIRMATIONS: usize = 3;

/// Iterates `method` from the model's initial values: at most `max_iterations` steps, then one
/// last analysis of the final model. Where the method has a merit (the P-C's mean
/// correlation) and offers fallback steps (the P-C's Levenberg-Marquardt damped steps), the
/// candidate with the highest merit is taken — a small trust-region search
/// ([`trust_region_step`]; far from the solution the undamped linearised step can improve the
/// merit by a hair and land badly), ranked on trial analyses where the model has them. Without
/// fallbacks a step that lowers the merit is halved, at most [`MAX_HALVINGS`] times. The
/// analysis at the chosen candidate is the next iteration's.
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
/// same values. The stop reason is the last phase's; every phase's warnings are kept.
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
    let mut warnings = Vec::new();
    let mut values = start.to_vec();
    let mut remaining = max_iterations;
    for (k, phase) in first.iter().enumerate() {
        let closing = Closing::Phase {
            phase: k + 1,
            phases: phases.len(),
        };
        let mut h = run_numbered(*phase, model, &values, remaining, (done.len(), closing))?;
        h.iterations.pop();
        remaining -= h.iterations.len();
        renumber(&mut h.iterations, done.len());
        done.append(&mut h.iterations);
        warnings.extend(
            h.warnings
                .into_iter()
                .map(|w| format!("phase {} of {}: {w}", k + 1, phases.len())),
        );
        values = h.final_values;
    }
    let mut h = run_numbered(
        *last,
        model,
        &values,
        remaining,
        (done.len(), Closing::Update),
    )?;
    renumber(&mut h.iterations, done.len());
    done.append(&mut h.iterations);
    h.iterations = done;
    warnings.append(&mut h.warnings);
    h.warnings = warnings;
    h.warnings.extend(never_selected(&h));
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
    let mut h = run_numbered(method, model, start, max_iterations, (0, Closing::Update))?;
    h.warnings.extend(never_selected(&h));
    Ok(h)
}

/// The warning for the parameters that no step of an update selected: the subset selection
/// (5.14) left them out every time — the data barely see them — so they keep their start
/// values, which the data neither confirm nor correct. `None` when every parameter was
/// selected at least once, or no step was taken.
pub(crate) fn never_selected(history: &UpdateHistory) -> Option<String> {
    // The last record is the closing analysis, which takes no step.
    let (_, steps) = history.iterations.split_last()?;
    if steps.is_empty() {
        return None;
    }
    let left_out: Vec<&str> = (history.parameters.iter().enumerate())
        .filter(|(j, _)| !steps.iter().any(|r| r.active.get(*j) == Some(&true)))
        .map(|(_, p)| p.name.as_str())
        .collect();
    if left_out.is_empty() {
        return None;
    }
    let (were, keep, them) = if left_out.len() == 1 {
        ("was", "keeps its start value", "it")
    } else {
        ("were", "keep their start values", "them")
    };
    Some(format!(
        "{} of {} parameters {were} never selected in {} iteration{} and {keep}: {} — the subset selection left {them} out of every step (the data barely see {them})",
        left_out.len(),
        history.parameters.len(),
        steps.len(),
        if steps.len() == 1 { "" } else { "s" },
        crate::core::first_of(left_out.iter(), 8)
    ))
}

/// [`run_from`] as a phase whose iterations [`run_phases`] numbers on from `first`: the
/// returned iteration, the warnings and the progress lines count from there, and the closing
/// analysis's line says what it closes.
fn run_numbered(
    method: &dyn UpdateMethod,
    model: &dyn ParametricModel,
    start: &[f64],
    max_iterations: usize,
    (first, closing): (usize, Closing),
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
        crate::core::progress::note(|| record.progress_line(first, Err(closing)));
        iterations.push(record);
        let mut history = UpdateHistory {
            parameters: params.clone(),
            iterations,
            final_values: values,
            stop,
            returned_iteration: None,
            warnings: Vec::new(),
        };
        keep_best_iterate(method, &mut history, first);
        Ok(history)
    };
    for it in 0..max_iterations {
        if let Some(stop) = current.stop {
            return finish(current.record, iterations, values, stop);
        }
        let before = method.merit(&current.record);
        let (next_values, applied, next) = match before {
            Some(before) if !current.fallbacks.is_empty() => {
                trust_region_step(method, model, &params, &values, &current, before, it + 1)?
            }
            _ => {
                let mut delta = current.record.relative_change.clone();
                let (mut next_values, mut applied) = apply_step(&params, &values, &delta);
                let mut next = method.iterate(model, &next_values, it + 1)?;
                if let Some(before) = before {
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
                (next_values, applied, next)
            }
        };
        let converged = method.converged_by_step(&applied)
            || method.converged_by_merit(&current.record, &next.record);
        let stalled = applied.iter().all(|d| d.abs() < 1e-12);
        let mut record = current.record;
        record.relative_change = applied;
        crate::core::progress::note(|| record.progress_line(first, Ok(method.equations_from())));
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

/// `values` written with four significant digits, or as many more (up to 10) as show the
/// different ones apart (merits [`keep_best_iterate`] tells apart differ by more than
/// [`MERIT_TIE`]).
fn apart<const N: usize>(values: [f64; N]) -> [String; N] {
    let magnitude = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let leading = if magnitude > 0.0 && magnitude.is_finite() {
        magnitude.log10().floor() as i32
    } else {
        0
    };
    let write = |significant: i32| {
        let decimals = (significant - 1 - leading).clamp(0, 17) as usize;
        values.map(|x| format!("{x:.decimals$}"))
    };
    let shows_apart =
        |w: &[String; N]| (0..N).all(|i| (0..i).all(|j| values[i] == values[j] || w[i] != w[j]));
    (4..=10)
        .map(write)
        .find(shows_apart)
        .unwrap_or_else(|| write(10))
}

/// Merits closer than this fraction of the larger are taken as equal: an iterate is not
/// returned for a gain at round-off (which would make the result depend on the machine).
const MERIT_TIE: f64 = 1e-9;

/// An update that did not meet its stop rule (iterations exhausted, or stalled) and whose last
/// iterate has a lower merit than an earlier one returns the best iterate's values instead,
/// with a warning in the history: a model worse than the one the user started from must never
/// be handed on silently as "updated". The history's iterations are numbered from
/// `first_iteration` in the whole update (a later phase of [`run_phases`]).
fn keep_best_iterate(
    method: &dyn UpdateMethod,
    history: &mut UpdateHistory,
    first_iteration: usize,
) {
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
    let (Some(&last), Some(&start)) = (merits.last(), merits.first()) else {
        return;
    };
    let best = (0..merits.len())
        .max_by(|&a, &b| merits[a].total_cmp(&merits[b]).then(b.cmp(&a)))
        .unwrap_or(0);
    if !(merits[best] - last > MERIT_TIE * merits[best].abs().max(last.abs())) {
        return;
    }
    let record = &history.iterations[best];
    let returned = first_iteration + record.iteration;
    let [last_text, start_text, best_text] = apart([last, start, merits[best]]);
    let warning = if last < start {
        format!(
            "the update ended ({:?}) worse than it began: merit {last_text} against {start_text} at the start; iteration {returned} (merit {best_text}) is returned instead of the last iterate",
            history.stop
        )
    } else {
        format!(
            "the update ended ({:?}) below its best iterate: merit {last_text} against {best_text} at iteration {returned}, which is returned",
            history.stop
        )
    };
    history.warnings.push(warning);
    history.final_values = record.values.clone();
    history.returned_iteration = Some(returned);
}

#[cfg(test)]
mod tests;
