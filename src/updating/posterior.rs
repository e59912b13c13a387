//! The Laplace (Gaussian) posterior of the updating parameters (docs/theory.md §12).
//!
//! The likelihood is an output error on the quantities a method fits, `y = f(φ) + e`,
//! `e ~ N(0, Σ_ε)`, `Σ_ε = diag(σ_i²)`: the complex FRFs at the likelihood's lines (real and
//! imaginary parts stacked) for the FRF methods, the natural frequencies of the paired modes for
//! inverse eigensensitivity. With an optional Gaussian prior `N(φ₀, diag(s₀²))` the negative
//! log posterior is `Q(φ) = ½ rᵀΣ_ε⁻¹r + ½ Σ_j ((φ_j − φ₀_j)/s₀_j)²`, `r = y − f(φ)`.
//!
//! The P-C and the RFM minimise other objectives, so their optimum is not `Q`'s minimum: a few
//! Gauss-Newton steps on `Q` ([`refine`], bounded, each accepted only when `Q` falls) move from
//! the update's result to the mode `φ̂`. There, in unity coordinates `u_j = δφ_j/φ̂_j` with the
//! Jacobian `J = ∂f/∂u` (the exact sensitivities, `φ_j ∂f/∂φ_j`), the Laplace covariance is
//! `Σ_u = (JᵀΣ_ε⁻¹J + P)⁻¹`, `P = diag(φ̂_j²/s₀_j²)` (0 for a flat prior), and
//! `Σ_φ = diag(φ̂) Σ_u diag(φ̂)`. Directions of `F = JᵀΣ_ε⁻¹J + P` whose eigenvalue is below
//! [`UNIDENTIFIED`]`·μ_max` are unidentified: their variance is unbounded and every parameter
//! with a share in them gets an infinite standard deviation. The correlations take every
//! direction above round-off ([`RIDGE_ROUNDOFF`]), so a ridge — parameters that compensate each
//! other — shows as `|ρ| → 1` with the sign of the trade-off; a parameter the data do not see
//! at all (its column of `J` at round-off) is split off as its own unidentified direction.
//!
//! With the noise estimated, `σ_g² = (r_gᵀr_g / m_g) · m/(m − n)` per noise group `g` (an FRF;
//! all modes pooled), recomputed at the mode: `σ̂² = rᵀr/(m − n)` when there is one group.
//!
//! Predictive bands: to first order `var y ≈ gᵀΣ_u g`, `g = ∂y/∂u`; by sampling, `φ_s = φ̂ +
//! diag(φ̂) L z_s`, `Σ_u = L Lᵀ`, `z_s` standard normal from a seeded ChaCha8 stream, each
//! sample evaluated through the model.

pub use super::likelihoods::{
    Coefficient, CorrelationLikelihood, DampingLikelihood, DirectFrfLikelihood,
    ModalDataLikelihood, ModalFrfLikelihood, NaturalFrequencies, likelihood_lines,
};
use super::model::{UpdatingError, UpdatingParameter};
use super::solve::least_squares;
use faer::{Mat, MatRef, Side};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Eigenvalues of the posterior precision below this fraction of the largest are unidentified.
pub const UNIDENTIFIED: f64 = 1e-12;

/// Eigenvalues of the posterior precision below this fraction of the largest are round-off
/// (16 ε): the correlations take every direction above it, identified or not.
pub const RIDGE_ROUNDOFF: f64 = 16.0 * f64::EPSILON;

/// An estimated noise below this fraction of its data's rms is round-off: a model that fits
/// its data that closely was given noise-free data (measured noise, even of a good test, is
/// 10⁻⁴–10⁻² of the signal; the solvers' round-off is 10⁻¹⁶–10⁻¹²).
pub const ROUNDOFF_NOISE: f64 = 1e-9;

/// The model's predictions of the fitted quantities at parameter values.
#[derive(Clone, Debug)]
pub struct Prediction {
    /// `f(φ)`, one value per row.
    pub values: Vec<f64>,
    /// `∂f/∂u_j = φ_j ∂f/∂φ_j` (rows × parameters), when asked for.
    pub jacobian: Option<Mat<f64>>,
}

/// An output-error likelihood: measured values, their noise groups and the model's predictions.
pub trait Likelihood: Sync {
    /// The measured values `y`, one per row.
    fn measured(&self) -> &[f64];
    /// Noise group of every row (an FRF, or a mode).
    fn groups(&self) -> &[usize];
    /// Names of the noise groups.
    fn group_names(&self) -> Vec<String>;
    /// Whether an estimated noise is pooled over all groups (modes) instead of per group (FRFs).
    fn pooled(&self) -> bool;
    /// The reference magnitude of every row for a relative noise (`|H|` of the measured FRF
    /// at the row's line and pair; 1 for relative frequency errors).
    fn scale(&self) -> Vec<f64>;
    /// `f(φ)` and, with `jacobian`, `∂f/∂u`.
    fn predict(&self, values: &[f64], jacobian: bool) -> Result<Prediction, UpdatingError>;
    /// `f(φ)` at a posterior sample: a reduced model answers on the held bases of its last
    /// full analysis (the mode's, or the refinement's last trial point beside it), by
    /// [`super::model::sample_state`].
    fn predict_sample(&self, values: &[f64]) -> Result<Vec<f64>, UpdatingError> {
        Ok(self.predict(values, false)?.values)
    }
    /// The complex layout of FRF rows: per line, per pair, real then imaginary part.
    fn frf_layout(&self) -> Option<FrfLayout> {
        None
    }
}

/// How the rows of an FRF likelihood are laid out.
#[derive(Clone, Debug, PartialEq)]
pub struct FrfLayout {
    /// The lines, Hz.
    pub freqs_hz: Vec<f64>,
    /// `response/excitation` label of every pair.
    pub pairs: Vec<String>,
}

/// The noise model of the likelihood.
#[derive(Clone, Debug, PartialEq)]
pub enum Noise {
    /// Estimated from the residuals at the mode (per FRF, or pooled over the modes).
    Estimated,
    /// Standard deviation of every row (of each real and each imaginary part), one value for all
    /// groups or one per group.
    Absolute(Vec<f64>),
    /// `σ_i = c · scale_i` (a fraction of `|H|`, or of the measured frequency).
    Relative(f64),
}

/// A Gaussian prior on the parameters (absolute values, SI).
#[derive(Clone, Debug, PartialEq)]
pub struct Prior {
    /// Means.
    pub mean: Vec<f64>,
    /// Standard deviations.
    pub sd: Vec<f64>,
}

/// Settings of the posterior.
#[derive(Clone, Debug)]
pub struct PosteriorSettings {
    /// The noise model.
    pub noise: Noise,
    /// Optional Gaussian prior; `None`: flat.
    pub prior: Option<Prior>,
    /// Probability of the central credible intervals.
    pub credible_level: f64,
    /// Most Gauss-Newton steps toward the likelihood's mode.
    pub refine_iterations: usize,
    /// Parameter samples drawn from the Gaussian.
    pub samples: usize,
    /// How many of them are evaluated through the model for the sampled predictive bands.
    pub predictive_samples: usize,
    /// Seed of the samples.
    pub seed: u64,
}

impl Default for PosteriorSettings {
    fn default() -> Self {
        PosteriorSettings {
            noise: Noise::Estimated,
            prior: None,
            credible_level: 0.9,
            refine_iterations: 5,
            samples: 1000,
            predictive_samples: 20,
            seed: 0,
        }
    }
}

/// What the Gauss-Newton refinement did.
#[derive(Clone, Debug, PartialEq)]
pub struct Refinement {
    /// Steps accepted.
    pub steps: usize,
    /// `Q` at the update's result.
    pub objective_start: f64,
    /// `Q` at the mode.
    pub objective_mode: f64,
    /// Whether the last step was below the tolerance (or no step lowered `Q`).
    pub converged: bool,
}

/// One parameter's marginal.
#[derive(Clone, Debug, PartialEq)]
pub struct Marginal {
    /// Name.
    pub name: String,
    /// The update's result.
    pub updated: f64,
    /// Posterior mean (the mode `φ̂`).
    pub mean: f64,
    /// Standard deviation (infinite when unidentified).
    pub sd: f64,
    /// Lower end of the central credible interval.
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
}

/// A principal direction of the posterior covariance in unity coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Direction {
    /// Standard deviation along it (relative), infinite when unidentified.
    pub sd: f64,
    /// Unit vector over the parameters (largest entry positive).
    pub vector: Vec<f64>,
}

/// A predictive band of one quantity.
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    /// Label (`mode 2`, or `2:ux/1:ux`).
    pub label: String,
    /// Frequency, Hz (the line, or the natural frequency at the mode).
    pub freq_hz: f64,
    /// The value at the mode (`f_r` in Hz, or `|H|`).
    pub value: f64,
    /// First-order standard deviation `√(gᵀΣ_u g)`.
    pub sd_linear: f64,
    /// Standard deviation over the evaluated samples (NaN without samples).
    pub sd_sampled: f64,
}

/// The Laplace posterior.
#[derive(Clone, Debug, PartialEq)]
pub struct Posterior {
    /// Per parameter.
    pub marginals: Vec<Marginal>,
    /// Covariance `Σ_φ` (SI²), row-major, `n × n`; infinite entries for unidentified ones.
    pub covariance: Vec<Vec<f64>>,
    /// Correlations `ρ_ij` over every direction of the precision above round-off
    /// ([`RIDGE_ROUNDOFF`]): along a ridge they tend to ±1 even where the standard deviations
    /// are infinite; NaN for a parameter the data do not see.
    pub correlation: Vec<Vec<f64>>,
    /// Principal directions, largest variance first.
    pub directions: Vec<Direction>,
    /// Noise standard deviation per group, as used.
    pub sigma: Vec<f64>,
    /// Group names.
    pub groups: Vec<String>,
    /// Whether `sigma` was estimated from the residuals.
    pub sigma_estimated: bool,
    /// Rows of the likelihood.
    pub rows: usize,
    /// `−log p(y|φ̂)`, with the noise as used.
    pub neg_log_likelihood: f64,
    /// The refinement.
    pub refinement: Refinement,
    /// The credible level.
    pub credible_level: f64,
    /// Parameter samples (absolute values), `samples × n`.
    pub samples: Vec<Vec<f64>>,
    /// Samples evaluated for the sampled bands (those within the bounds).
    pub predictive_samples: usize,
    /// Natural-frequency bands.
    pub natural_frequencies: Vec<Band>,
    /// `|H|` bands at the lines of an FRF likelihood.
    pub frf: Vec<Band>,
    /// The seed.
    pub seed: u64,
    /// What the user should know about this posterior (e.g. a noise estimated at round-off),
    /// recorded with it so that a cached result tells it again.
    pub warnings: Vec<String>,
}

/// Standard normal CDF, `Φ(x) = ½(1 + erf(x/√2))`, with `erf` from its everywhere-positive
/// series `erf(x) = 2/√π e^{−x²} Σ 2ⁿ x^{2n+1}/(1·3···(2n+1))` below 6 (accurate to round-off).
pub fn normal_cdf(x: f64) -> f64 {
    let t = x.abs() / std::f64::consts::SQRT_2;
    let erf = if t > 6.0 {
        1.0
    } else {
        let (mut term, mut sum, mut k) = (t, t, 0.0);
        while term > 1e-17 * sum {
            k += 1.0;
            term *= 2.0 * t * t / (2.0 * k + 1.0);
            sum += term;
        }
        (2.0 / PI.sqrt() * (-t * t).exp() * sum).min(1.0)
    };
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

/// The standard normal quantile `z` with `Φ(z) = p`, by bisection, for `p` in (0, 1).
pub fn normal_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (-40.0_f64, 40.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if normal_cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// `σ_i` of every row from the noise model and the residual at the mode; the per-group values
/// and whether they were estimated.
pub(crate) fn row_sigmas(
    lik: &dyn Likelihood,
    noise: &Noise,
    residual: &[f64],
    n_params: usize,
) -> Result<(Vec<f64>, Vec<f64>), UpdatingError> {
    let groups = lik.groups();
    let ng = lik.group_names().len();
    let m = residual.len();
    match noise {
        Noise::Absolute(s) => {
            let per: Vec<f64> = match s.len() {
                1 => vec![s[0]; ng],
                k if k == ng => s.clone(),
                k => {
                    return Err(UpdatingError::Settings(format!(
                        "{k} noise levels for {ng} noise groups ({}): give one, or one per group",
                        lik.group_names().join(", ")
                    )));
                }
            };
            if per.iter().any(|s| !(*s > 0.0 && s.is_finite())) {
                return Err(UpdatingError::Settings(
                    "every noise level must be positive and finite".into(),
                ));
            }
            Ok((groups.iter().map(|&g| per[g]).collect(), per))
        }
        Noise::Relative(c) => {
            let scale = lik.scale();
            let rows: Vec<f64> = scale.iter().map(|s| c * s.max(f64::MIN_POSITIVE)).collect();
            let mut per = vec![0.0; ng];
            let mut count = vec![0usize; ng];
            for (&g, s) in groups.iter().zip(&rows) {
                per[g] += s * s;
                count[g] += 1;
            }
            let per = per
                .iter()
                .zip(&count)
                .map(|(s, &c)| (s / c.max(1) as f64).sqrt())
                .collect();
            Ok((rows, per))
        }
        Noise::Estimated => {
            if m <= n_params {
                return Err(UpdatingError::Data(format!(
                    "{m} data for {n_params} parameters: the noise cannot be estimated; give it"
                )));
            }
            let dof = m as f64 / (m - n_params) as f64;
            let (mut ss, mut count) = (vec![0.0; ng], vec![0usize; ng]);
            for (&g, r) in groups.iter().zip(residual) {
                let g = if lik.pooled() { 0 } else { g };
                ss[g] += r * r;
                count[g] += 1;
            }
            let mut per: Vec<f64> = (0..ng)
                .map(|g| (dof * ss[g] / count[g].max(1) as f64).sqrt())
                .collect();
            if lik.pooled()
                && let Some(&first) = per.first()
            {
                per = vec![first; ng];
            }
            // No noise below round-off can be claimed: σ_g ≥ ε·rms(y_g) (noise-free data).
            let per: Vec<f64> = per
                .iter()
                .zip(data_rms(lik))
                .map(|(s, rms)| s.max(f64::EPSILON * rms).max(f64::MIN_POSITIVE))
                .collect();
            Ok((groups.iter().map(|&g| per[g]).collect(), per))
        }
    }
}

/// The rms of the measured values of every noise group (of all of them when the noise is
/// pooled, or when a group's values are all zero).
fn data_rms(lik: &dyn Likelihood) -> Vec<f64> {
    let ng = lik.group_names().len();
    let y = lik.measured();
    let (mut ys, mut yc) = (vec![0.0; ng], vec![0usize; ng]);
    for (&g, v) in lik.groups().iter().zip(y) {
        let g = if lik.pooled() { 0 } else { g };
        ys[g] += v * v;
        yc[g] += 1;
    }
    let overall = (ys.iter().sum::<f64>() / y.len().max(1) as f64).sqrt();
    (0..ng)
        .map(|g| {
            let k = if lik.pooled() { 0 } else { g };
            let rms = (ys[k] / yc[k].max(1) as f64).sqrt();
            if rms > 0.0 { rms } else { overall }
        })
        .collect()
}

/// The noise groups whose estimated noise `per_group` lies below [`ROUNDOFF_NOISE`] of their
/// data's rms, with that ratio: the model fits those data to working precision (noise-free
/// data, e.g. simulated by the model being updated), so a posterior on that noise shows
/// round-off, not measurement uncertainty.
pub fn noise_at_roundoff(lik: &dyn Likelihood, per_group: &[f64]) -> Vec<(String, f64)> {
    lik.group_names()
        .into_iter()
        .zip(per_group.iter().zip(data_rms(lik)))
        .map(|(name, (s, rms))| (name, s / rms))
        .filter(|(_, ratio)| *ratio < ROUNDOFF_NOISE)
        .collect()
}

/// `Q(φ)` and the weighted, stacked Gauss-Newton system at `values` (rows `r_i/σ_i`, `J/σ_i`,
/// then the prior's `√P` rows).
struct Linearised {
    objective: f64,
    a: Mat<f64>,
    b: Vec<f64>,
}

fn prior_terms(prior: Option<&Prior>, values: &[f64]) -> (f64, Vec<(f64, f64)>) {
    let Some(p) = prior else {
        return (0.0, Vec::new());
    };
    let mut q = 0.0;
    let rows = values
        .iter()
        .enumerate()
        .map(|(j, &v)| {
            let z = (v - p.mean[j]) / p.sd[j];
            q += 0.5 * z * z;
            // √P_jj = φ_j/s₀_j; right-hand side √P (φ₀ − φ)/φ = (φ₀ − φ)/s₀.
            (v / p.sd[j], -z)
        })
        .collect();
    (q, rows)
}

fn objective(r: &[f64], sigma: &[f64], prior: Option<&Prior>, values: &[f64]) -> f64 {
    let data: f64 = r.iter().zip(sigma).map(|(r, s)| (r / s).powi(2)).sum();
    0.5 * data + prior_terms(prior, values).0
}

fn linearise(
    y: &[f64],
    pred: &Prediction,
    sigma: &[f64],
    prior: Option<&Prior>,
    values: &[f64],
) -> Linearised {
    let j = pred.jacobian.as_ref().expect("a Jacobian was asked for");
    let (m, n) = (y.len(), values.len());
    let (qp, prior_rows) = prior_terms(prior, values);
    let r: Vec<f64> = y.iter().zip(&pred.values).map(|(a, b)| a - b).collect();
    let extra = prior_rows.len();
    let a = Mat::from_fn(m + extra, n, |i, c| {
        if i < m {
            j[(i, c)] / sigma[i]
        } else if i - m == c {
            prior_rows[c].0
        } else {
            0.0
        }
    });
    let mut b: Vec<f64> = r.iter().zip(sigma).map(|(r, s)| r / s).collect();
    b.extend(prior_rows.iter().map(|p| p.1));
    let data: f64 = b[..m].iter().map(|x| x * x).sum();
    Linearised {
        objective: 0.5 * data + qp,
        a,
        b,
    }
}

/// Gauss-Newton steps on `Q` from `start` (its prediction `start_pred`, with the Jacobian)
/// toward the mode, at most `max_steps`, each halved up
/// to six times until `Q` falls and stopped when the largest relative step is below 1e-9;
/// values are clamped to the bounds. Returns the mode, the linearisation there and the record.
fn refine(
    lik: &dyn Likelihood,
    params: &[UpdatingParameter],
    start: &[f64],
    start_pred: Prediction,
    sigma: &[f64],
    prior: Option<&Prior>,
    max_steps: usize,
) -> Result<(Vec<f64>, Prediction, Refinement), UpdatingError> {
    let y = lik.measured();
    let mut values = start.to_vec();
    let mut pred = start_pred;
    let mut lin = linearise(y, &pred, sigma, prior, &values);
    let objective_start = lin.objective;
    let (mut steps, mut converged) = (0, false);
    for _ in 0..max_steps {
        let delta = least_squares(lin.a.as_ref(), &lin.b, 1e-12);
        let mut t = 1.0;
        let mut accepted = None;
        for _ in 0..=super::MAX_HALVINGS {
            let scaled: Vec<f64> = delta.iter().map(|d| t * d).collect();
            let (next, _) = super::apply_step(params, &values, &scaled);
            // A trial point the model cannot be analysed at is a rejected step.
            // Analysed in full: a long Gauss-Newton step along a poorly determined direction
            // can leave what the held bases of a reduced model describe.
            let Ok(p) = lik.predict(&next, false) else {
                t *= 0.5;
                continue;
            };
            let r: Vec<f64> = y.iter().zip(&p.values).map(|(a, b)| a - b).collect();
            if objective(&r, sigma, prior, &next) < lin.objective {
                accepted = Some(next);
                break;
            }
            t *= 0.5;
        }
        let Some(next) = accepted else {
            converged = true;
            break;
        };
        let biggest = delta.iter().fold(0.0_f64, |a, d| a.max((t * d).abs()));
        values = next;
        pred = lik.predict(&values, true)?;
        lin = linearise(y, &pred, sigma, prior, &values);
        steps += 1;
        if biggest < 1e-9 {
            converged = true;
            break;
        }
    }
    Ok((
        values,
        pred,
        Refinement {
            steps,
            objective_start,
            objective_mode: lin.objective,
            converged,
        },
    ))
}

/// Relative change of a parameter from the update's result to the likelihood's mode beyond
/// which the posterior warns that it describes another point than the update's.
const FAR_MODE: f64 = 0.1;

/// The warning for identified parameters whose Gaussian credible interval reaches past the
/// parameter's own bounds (a loss factor's below zero, or a mode at a bound): there the
/// posterior, whose prior stops at the bounds, is cut off, which a Gaussian about the mode does
/// not describe. `None` when every finite interval lies within its bounds.
fn intervals_past_bounds(
    marginals: &[Marginal],
    params: &[UpdatingParameter],
    credible_level: f64,
) -> Option<String> {
    let past: Vec<(&Marginal, &UpdatingParameter)> = (marginals.iter().zip(params))
        .filter(|(m, p)| m.sd.is_finite() && (m.lower < p.lower || m.upper > p.upper))
        .collect();
    let (m, p) = past.first()?;
    let (intervals, reach, eg) = if past.len() == 1 {
        ("interval", "reaches past its bounds", "")
    } else {
        ("intervals", "reach past their bounds", "e.g. ")
    };
    Some(format!(
        "the {:.0} % {intervals} of {} {reach} ({eg}{}: mode {:.3e}, interval {:.3e} to {:.3e}, bounds {:e} to {:e}): the posterior is cut off at a bound, which the Laplace (Gaussian) approximation about the mode does not describe — `bayes.tmcmc` samples the posterior within the bounds",
        100.0 * credible_level,
        crate::core::first_of(past.iter().map(|(m, _)| &m.name), 8),
        m.name,
        m.mean,
        m.lower,
        m.upper,
        p.lower,
        p.upper,
    ))
}

/// Eigen-decomposition of the precision `F` in unity coordinates: `(μ, V)`, μ descending.
fn precision_eigen(a: MatRef<'_, f64>) -> Result<(Vec<f64>, Mat<f64>), UpdatingError> {
    // `AᵀA` by fixed-order sums: a parallel product's last bits could depend on the thread
    // count, and results must not.
    let n = a.ncols();
    let mut f = Mat::<f64>::zeros(n, n);
    for i in 0..n {
        for j in 0..=i {
            let v: f64 = (0..a.nrows()).map(|k| a[(k, i)] * a[(k, j)]).sum();
            f[(i, j)] = v;
            f[(j, i)] = v;
        }
    }
    if f.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
        return Err(UpdatingError::Model(
            "the posterior precision is not finite (a noise level of zero?)".into(),
        ));
    }
    // A parameter the data do not see (`F_ii` at round-off, e.g. an out-of-plane stiffness
    // under in-plane measurements) is an unidentified direction of its own: left in, the
    // null space's eigenvectors would mix it with every other parameter at round-off level
    // and leave none identified.
    let largest = (0..n).map(|i| f[(i, i)]).fold(0.0_f64, f64::max);
    let (seen, unseen): (Vec<usize>, Vec<usize>) =
        (0..n).partition(|&i| f[(i, i)] > UNIDENTIFIED * largest);
    let sub = Mat::from_fn(seen.len(), seen.len(), |i, j| f[(seen[i], seen[j])]);
    let evd = sub.self_adjoint_eigen(Side::Lower).map_err(|_| {
        UpdatingError::Model("eigen-decomposition of the posterior precision".into())
    })?;
    // Ascending from faer: reversed to descending, then the unseen parameters at μ = 0.
    let k = seen.len();
    let mut mu: Vec<f64> = (0..k).rev().map(|i| evd.S()[i].max(0.0)).collect();
    mu.extend(std::iter::repeat_n(0.0, unseen.len()));
    let u = evd.U();
    let mut v = Mat::<f64>::zeros(n, n);
    for (a, &i) in seen.iter().enumerate() {
        for j in 0..k {
            v[(i, j)] = u[(a, k - 1 - j)];
        }
    }
    for (j, &i) in unseen.iter().enumerate() {
        v[(i, k + j)] = 1.0;
    }
    Ok((mu, v))
}

/// The Laplace posterior of `params` (of which `updated` is the update's result) under `lik`.
/// `natural` gives the natural frequencies and their unity derivatives at parameter values
/// (for the bands; `None`: no frequency band).
pub fn laplace(
    lik: &dyn Likelihood,
    params: &[UpdatingParameter],
    updated: &[f64],
    settings: &PosteriorSettings,
    natural: Option<&NaturalFrequencies<'_>>,
) -> Result<Posterior, UpdatingError> {
    let n = params.len();
    if updated.len() != n {
        return Err(UpdatingError::Settings(format!(
            "{} values for {n} parameters",
            updated.len()
        )));
    }
    if !(settings.credible_level > 0.0 && settings.credible_level < 1.0) {
        return Err(UpdatingError::Settings(format!(
            "credible level {} is not in (0, 1)",
            settings.credible_level
        )));
    }
    if let Some(p) = &settings.prior
        && (p.mean.len() != n
            || p.sd.len() != n
            || p.sd.iter().any(|s| !(*s > 0.0 && s.is_finite())))
    {
        return Err(UpdatingError::Settings(format!(
            "the prior needs {n} means and {n} positive standard deviations"
        )));
    }
    let prior = settings.prior.as_ref();
    let y = lik.measured();
    let estimated = settings.noise == Noise::Estimated;
    if estimated && y.len() <= n {
        let mut p = unknown(lik, params, updated, settings);
        p.warnings.push(format!(
            "{} data for {n} parameters leave no degree of freedom to estimate the noise; give it (`posterior.noise`) — the posterior is reported as unknown (NaN)",
            y.len()
        ));
        return Ok(p);
    }
    let mut warnings = Vec::new();
    // Noise at the update's result, the mode under it, and (estimated) the noise again there.
    // One analysis serves both: its Jacobian starts the refinement.
    let start_pred = lik.predict(updated, true)?;
    let r0: Vec<f64> = y
        .iter()
        .zip(&start_pred.values)
        .map(|(a, b)| a - b)
        .collect();
    let (mut sigma, mut per_group) = row_sigmas(lik, &settings.noise, &r0, n)?;
    let (mode, mut pred, mut refinement) = refine(
        lik,
        params,
        updated,
        start_pred,
        &sigma,
        prior,
        settings.refine_iterations,
    )?;
    // A mode far from the update's result: the method's objective and this likelihood
    // disagree (a χ-based method against the FRF output error under a noise model that does
    // not describe the data), and the posterior describes the likelihood's mode, not the
    // update's result.
    if let Some((j, moved)) = (0..n)
        .map(|j| (j, (mode[j] - updated[j]) / updated[j]))
        .filter(|(_, m)| m.is_finite())
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        && moved.abs() > FAR_MODE
    {
        warnings.push(format!(
            "the likelihood's mode lies far from the update's result ({} moved by {:+.0} %): this likelihood and the method's objective disagree — check the noise model (e.g. `relative` for noise proportional to |H|), or set `refine_iterations: 0` to describe the update's result",
            params[j].name,
            100.0 * moved
        ));
    }
    let r: Vec<f64> = y.iter().zip(&pred.values).map(|(a, b)| a - b).collect();
    if estimated {
        (sigma, per_group) = row_sigmas(lik, &settings.noise, &r, n)?;
        refinement.objective_start = objective(&r0, &sigma, prior, updated);
        refinement.objective_mode = objective(&r, &sigma, prior, &mode);
        let exact = noise_at_roundoff(lik, &per_group);
        // The message holds no value at round-off, so that it is the same on every machine.
        if !exact.is_empty() {
            let names = crate::core::first_of(exact.iter().map(|(name, _)| name), 5);
            let noise = if lik.pooled() {
                format!(
                    "the noise estimated for all {} groups together",
                    per_group.len()
                )
            } else if per_group.len() == 1 {
                format!("the noise estimated for {names}")
            } else {
                format!(
                    "the noise estimated for {} of {} noise groups ({names})",
                    exact.len(),
                    per_group.len()
                )
            };
            warnings.push(format!(
                "{noise} is at round-off (below {ROUNDOFF_NOISE:.0e} of the data's rms): the model fits these data to working precision (noise-free data?), so the posterior's spreads show round-off, not measurement uncertainty — give `posterior.noise` (e.g. `{{relative: 0.01}}`) for the spread a measurement would leave"
            ));
        }
    }
    let lin = linearise(y, &pred, &sigma, prior, &mode);
    let (mu, v) = precision_eigen(lin.a.as_ref())?;
    let mu_max = mu.first().copied().unwrap_or(0.0);
    let identified: Vec<bool> = mu
        .iter()
        .map(|&m| mu_max > 0.0 && m > UNIDENTIFIED * mu_max)
        .collect();
    // Σ_u = V diag(1/μ) Vᵀ over the identified directions; infinite along the others. The
    // correlations also take the directions below the identification level but above the
    // precision's round-off: a ridge of the likelihood is such a direction, and the sign of
    // its parameters' correlation says which way it runs (one up, the other down).
    let mut cov_u = vec![vec![0.0; n]; n];
    let mut cov_ridge = vec![vec![0.0; n]; n];
    let mut unbounded = vec![false; n];
    for k in 0..n {
        if identified[k] {
            for i in 0..n {
                for j in 0..n {
                    cov_u[i][j] += v[(i, k)] * v[(j, k)] / mu[k];
                }
            }
        } else {
            for (i, u) in unbounded.iter_mut().enumerate() {
                *u |= v[(i, k)].abs() > 1e-8;
            }
        }
        if mu_max > 0.0 && mu[k] > RIDGE_ROUNDOFF * mu_max {
            for i in 0..n {
                for j in 0..n {
                    cov_ridge[i][j] += v[(i, k)] * v[(j, k)] / mu[k];
                }
            }
        }
    }
    let z = normal_quantile(0.5 + 0.5 * settings.credible_level);
    let cov: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    if unbounded[i] || unbounded[j] {
                        f64::INFINITY
                    } else {
                        mode[i] * mode[j] * cov_u[i][j]
                    }
                })
                .collect()
        })
        .collect();
    let sd: Vec<f64> = (0..n).map(|i| cov[i][i].max(0.0).sqrt()).collect();
    let correlation = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let (a, b) = (cov_ridge[i][i], cov_ridge[j][j]);
                    if i == j {
                        1.0
                    } else if a > 0.0 && b > 0.0 {
                        cov_ridge[i][j] / (a * b).sqrt()
                    } else {
                        f64::NAN
                    }
                })
                .collect()
        })
        .collect();
    let marginals: Vec<Marginal> = (0..n)
        .map(|i| Marginal {
            name: params[i].name.clone(),
            updated: updated[i],
            mean: mode[i],
            sd: sd[i],
            lower: mode[i] - z * sd[i],
            upper: mode[i] + z * sd[i],
        })
        .collect();
    if let Some(w) = intervals_past_bounds(&marginals, params, settings.credible_level) {
        warnings.push(w);
    }
    let directions: Vec<Direction> = (0..n)
        .rev()
        .map(|k| Direction {
            sd: if identified[k] {
                1.0 / mu[k].sqrt()
            } else {
                f64::INFINITY
            },
            vector: sign_fixed((0..n).map(|i| v[(i, k)]).collect()),
        })
        .collect();

    // Samples z ~ N(0, I) in the identified directions: u = Σ_k v_k z_k/√μ_k.
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let samples: Vec<Vec<f64>> = (0..settings.samples)
        .map(|_| {
            let mut u = vec![0.0; n];
            for k in 0..n {
                let g: f64 = StandardNormal.sample(&mut rng);
                if identified[k] {
                    for (i, ui) in u.iter_mut().enumerate() {
                        *ui += v[(i, k)] * g / mu[k].sqrt();
                    }
                }
            }
            (0..n).map(|i| mode[i] * (1.0 + u[i])).collect()
        })
        .collect();
    let within: Vec<Vec<f64>> = samples
        .iter()
        .filter(|s| {
            s.iter()
                .zip(params)
                .all(|(v, p)| p.lower <= *v && *v <= p.upper)
        })
        .take(settings.predictive_samples)
        .cloned()
        .collect();
    let quad = |g: &[f64]| -> f64 {
        let mut s = 0.0;
        for i in 0..n {
            for j in 0..n {
                s += g[i] * cov_u[i][j] * g[j];
            }
        }
        if (0..n).any(|i| unbounded[i] && g[i] != 0.0) {
            f64::INFINITY
        } else {
            s.max(0.0).sqrt()
        }
    };
    let sample_sd = |values: &[Vec<f64>], k: usize| -> f64 {
        if values.len() < 2 {
            return f64::NAN;
        }
        let m = values.iter().map(|v| v[k]).sum::<f64>() / values.len() as f64;
        (values.iter().map(|v| (v[k] - m).powi(2)).sum::<f64>() / (values.len() - 1) as f64).sqrt()
    };

    // |H| bands at the lines of an FRF likelihood.
    let mut frf = Vec::new();
    if let Some(layout) = lik.frf_layout() {
        let jac = pred.jacobian.take().unwrap_or_else(|| Mat::zeros(0, n));
        let np = layout.pairs.len();
        let abs_of = |vals: &[f64]| -> Vec<f64> {
            (0..vals.len() / 2)
                .map(|i| vals[2 * i].hypot(vals[2 * i + 1]))
                .collect()
        };
        // Samples the model cannot be analysed at are left out of the band.
        let sampled: Vec<Vec<f64>> = within
            .par_iter()
            .filter_map(|s| lik.predict_sample(s).ok().map(|p| abs_of(&p)))
            .collect();
        for (k, &f) in layout.freqs_hz.iter().enumerate() {
            for (q, label) in layout.pairs.iter().enumerate() {
                let i = k * np + q;
                let (re, im) = (pred.values[2 * i], pred.values[2 * i + 1]);
                let a = re.hypot(im);
                let g: Vec<f64> = (0..n)
                    .map(|c| {
                        if a > 0.0 {
                            (re * jac[(2 * i, c)] + im * jac[(2 * i + 1, c)]) / a
                        } else {
                            0.0
                        }
                    })
                    .collect();
                frf.push(Band {
                    label: label.clone(),
                    freq_hz: f,
                    value: a,
                    sd_linear: quad(&g),
                    sd_sampled: sample_sd(&sampled, i),
                });
            }
        }
    }
    let mut natural_frequencies = Vec::new();
    if let Some(nat) = natural {
        let (f, g) = nat.at(&mode)?;
        let sampled: Vec<Vec<f64>> = within
            .par_iter()
            .filter_map(|s| nat.sampled(s).ok())
            .collect();
        let sampled: Vec<Vec<f64>> = sampled.into_iter().filter(|s| s.len() >= f.len()).collect();
        for (r, &fr) in f.iter().enumerate() {
            natural_frequencies.push(Band {
                label: format!("mode {}", r + 1),
                freq_hz: fr,
                value: fr,
                sd_linear: quad(&g[r]),
                sd_sampled: sample_sd(&sampled, r),
            });
        }
    }
    let neg_log_likelihood = 0.5
        * r.iter()
            .zip(&sigma)
            .map(|(r, s)| (r / s).powi(2) + (2.0 * PI * s * s).ln())
            .sum::<f64>();
    Ok(Posterior {
        marginals,
        covariance: cov,
        correlation,
        directions,
        sigma: per_group,
        groups: lik.group_names(),
        sigma_estimated: estimated,
        rows: y.len(),
        neg_log_likelihood,
        refinement,
        credible_level: settings.credible_level,
        samples,
        predictive_samples: within.len(),
        natural_frequencies,
        frf,
        seed: settings.seed,
        warnings,
    })
}

/// The posterior when it cannot be computed (the noise neither given nor estimable, or the
/// model not analysable at the mode): every number NaN, the means the update's result.
pub fn unknown(
    lik: &dyn Likelihood,
    params: &[UpdatingParameter],
    updated: &[f64],
    settings: &PosteriorSettings,
) -> Posterior {
    let n = params.len();
    let nan = f64::NAN;
    Posterior {
        marginals: (0..n)
            .map(|i| Marginal {
                name: params[i].name.clone(),
                updated: updated[i],
                mean: updated[i],
                sd: nan,
                lower: nan,
                upper: nan,
            })
            .collect(),
        covariance: vec![vec![nan; n]; n],
        correlation: vec![vec![nan; n]; n],
        directions: Vec::new(),
        sigma: vec![nan; lik.group_names().len()],
        groups: lik.group_names(),
        sigma_estimated: true,
        rows: lik.measured().len(),
        neg_log_likelihood: nan,
        refinement: Refinement {
            steps: 0,
            objective_start: nan,
            objective_mode: nan,
            converged: false,
        },
        credible_level: settings.credible_level,
        samples: Vec::new(),
        predictive_samples: 0,
        natural_frequencies: Vec::new(),
        frf: Vec::new(),
        seed: settings.seed,
        warnings: Vec::new(),
    }
}

/// A direction with its largest entry positive.
fn sign_fixed(mut v: Vec<f64>) -> Vec<f64> {
    let big = v
        .iter()
        .copied()
        .fold(0.0_f64, |a, b| if b.abs() > a.abs() { b } else { a });
    if big < 0.0 {
        v.iter_mut().for_each(|x| *x = -*x);
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eigen::ModeSelection;
    use crate::frf::{ModalDamping, frequency_lines};
    use crate::updating::ParametricModel;
    use crate::updating::tests::{chain_model, measured};
    use crate::updating::toy::Linear;

    fn params(values: &[f64]) -> Vec<UpdatingParameter> {
        values
            .iter()
            .enumerate()
            .map(|(i, &v)| UpdatingParameter {
                name: format!("p{i}"),
                initial: v,
                lower: -1e9,
                upper: 1e9,
            })
            .collect()
    }

    fn linear_problem() -> Linear {
        let a = Mat::from_fn(12, 3, |i, j| {
            ((i * 3 + j * 5) as f64 * 0.7).sin() + (i == j) as u8 as f64
        });
        let y = (0..12).map(|i| 1.0 + 0.3 * (i as f64).cos()).collect();
        Linear {
            a,
            y,
            groups: vec![0; 12],
        }
    }

    /// `(AᵀA/σ² + P)⁻¹` by a plain inverse.
    fn analytic(a: &Mat<f64>, sigma: f64, prior_sd: Option<&[f64]>) -> Mat<f64> {
        let n = a.ncols();
        let mut f = a.transpose() * a * faer::Scale(1.0 / (sigma * sigma));
        if let Some(s) = prior_sd {
            for j in 0..n {
                f[(j, j)] += 1.0 / (s[j] * s[j]);
            }
        }
        use faer::linalg::solvers::DenseSolveCore;
        f.partial_piv_lu().inverse()
    }

    /// A linear-Gaussian problem: from a start away from the solution, one Gauss-Newton step
    /// reaches the least-squares solution and the Laplace covariance is `σ²(AᵀA)⁻¹` to 1e-12
    /// (relative to the largest entry); with a Gaussian prior `(AᵀA/σ² + diag(1/s₀²))⁻¹`, and
    /// the mean moves toward the prior mean. The estimated noise is `rᵀr/(m − n)`.
    /// An identified parameter whose Gaussian interval reaches past its bounds is named (the
    /// first with its mode, interval and bounds); an unidentified one (infinite sd) and one
    /// inside its bounds are not.
    #[test]
    fn intervals_past_their_bounds_are_named() {
        let marginal = |name: &str, sd: f64| Marginal {
            name: name.into(),
            updated: 0.01,
            mean: 0.01,
            sd,
            lower: 0.01 - 1.645 * sd,
            upper: 0.01 + 1.645 * sd,
        };
        let parameter = |name: &str| UpdatingParameter {
            name: name.into(),
            initial: 0.01,
            lower: 1e-4,
            upper: 1.0,
        };
        let params = ["eta_1", "eta_2", "eta_3", "eta_4"].map(parameter);
        let marginals = [
            marginal("eta_1", 0.001),
            marginal("eta_2", 0.02),
            marginal("eta_3", f64::INFINITY),
            marginal("eta_4", 0.03),
        ];
        assert_eq!(
            intervals_past_bounds(&marginals, &params, 0.9).as_deref(),
            Some(
                "the 90 % intervals of eta_2, eta_4 reach past their bounds (e.g. eta_2: mode 1.000e-2, interval -2.290e-2 to 4.290e-2, bounds 1e-4 to 1e0): the posterior is cut off at a bound, which the Laplace (Gaussian) approximation about the mode does not describe — `bayes.tmcmc` samples the posterior within the bounds"
            )
        );
        assert!(
            intervals_past_bounds(&marginals[..2], &params[..2], 0.9).is_some_and(
                |w| w.starts_with("the 90 % interval of eta_2 reaches past its bounds")
            )
        );
        assert_eq!(
            intervals_past_bounds(&marginals[..1], &params[..1], 0.9),
            None
        );
        assert_eq!(
            intervals_past_bounds(&marginals[2..3], &params[2..3], 0.9),
            None
        );
    }

    #[test]
    fn linear_gaussian_covariance_is_exact() {
        let lik = linear_problem();
        let start = [2.0, -1.0, 0.5];
        let p = params(&start);
        let sigma = 0.05;
        let settings = PosteriorSettings {
            noise: Noise::Absolute(vec![sigma]),
            samples: 4000,
            ..Default::default()
        };
        let post = laplace(&lik, &p, &start, &settings, None).unwrap();
        let want = analytic(&lik.a, sigma, None);
        let scale = (0..3).map(|i| want[(i, i)]).fold(0.0, f64::max);
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    (post.covariance[i][j] - want[(i, j)]).abs() < 1e-12 * scale,
                    "{i}{j}: {} vs {}",
                    post.covariance[i][j],
                    want[(i, j)]
                );
            }
        }
        let ls = least_squares(lik.a.as_ref(), &lik.y, 1e-14);
        for (m, l) in post.marginals.iter().zip(&ls) {
            assert!((m.mean - l).abs() < 1e-10, "{m:?}");
        }
        assert!(post.refinement.steps >= 1 && post.refinement.converged);
        // The credible interval is mean ± 1.6449 sd.
        let m = &post.marginals[0];
        assert!(((m.upper - m.mean) / m.sd - 1.6448536269514722).abs() < 1e-9);
        // Sample covariance approaches Σ.
        let ns = post.samples.len() as f64;
        let mean0 = post.samples.iter().map(|s| s[0]).sum::<f64>() / ns;
        let var0 = post
            .samples
            .iter()
            .map(|s| (s[0] - mean0).powi(2))
            .sum::<f64>()
            / (ns - 1.0);
        assert!((var0 / want[(0, 0)] - 1.0).abs() < 0.1, "{var0}");

        // With a prior.
        let prior_sd = [0.01, 0.2, 0.05];
        let settings = PosteriorSettings {
            noise: Noise::Absolute(vec![sigma]),
            prior: Some(Prior {
                mean: vec![0.0, 0.0, 0.0],
                sd: prior_sd.to_vec(),
            }),
            ..Default::default()
        };
        let post = laplace(&lik, &p, &start, &settings, None).unwrap();
        let want = analytic(&lik.a, sigma, Some(&prior_sd));
        let scale = (0..3).map(|i| want[(i, i)]).fold(0.0, f64::max);
        for i in 0..3 {
            for j in 0..3 {
                assert!((post.covariance[i][j] - want[(i, j)]).abs() < 1e-12 * scale);
            }
        }
        assert!(post.marginals[0].mean.abs() < ls[0].abs());

        // Estimated noise: σ̂² = rᵀr/(m − n) at the solution.
        let settings = PosteriorSettings::default();
        let post = laplace(&lik, &p, &start, &settings, None).unwrap();
        let r: Vec<f64> = (0..12)
            .map(|i| lik.y[i] - (0..3).map(|j| lik.a[(i, j)] * ls[j]).sum::<f64>())
            .collect();
        let s2 = r.iter().map(|x| x * x).sum::<f64>() / 9.0;
        assert!((post.sigma[0] / s2.sqrt() - 1.0).abs() < 1e-10);
        assert!(post.sigma_estimated);
    }

    /// The posterior of three parameters at 1 from the linear likelihood `a` (8 rows, data
    /// `3 + i`, noise 0.1).
    fn eight_rows_at_unit_values(a: Mat<f64>) -> Posterior {
        let y = (0..8).map(|i| 3.0 + i as f64).collect();
        let lik = Linear {
            a,
            y,
            groups: vec![0; 8],
        };
        let start = [1.0, 1.0, 1.0];
        let settings = PosteriorSettings {
            noise: Noise::Absolute(vec![0.1]),
            ..Default::default()
        };
        laplace(&lik, &params(&start), &start, &settings, None).unwrap()
    }

    /// A dependent column: the direction it spans is unidentified, the parameters in it have
    /// infinite standard deviations, the other stays finite, and the largest-variance direction
    /// is the null-space direction.
    #[test]
    fn an_unidentified_direction_is_reported() {
        let a = Mat::from_fn(8, 3, |i, j| match j {
            0 => 1.0 + i as f64,
            1 => (i as f64).sin(),
            _ => 2.0 * (1.0 + i as f64),
        });
        let post = eight_rows_at_unit_values(a);
        assert!(post.marginals[0].sd.is_infinite() && post.marginals[2].sd.is_infinite());
        assert!(post.marginals[1].sd.is_finite());
        assert!(post.directions[0].sd.is_infinite());
        let d = &post.directions[0].vector;
        assert!(d[1].abs() < 1e-8, "{d:?}");
    }

    /// A ridge: two parameters that compensate each other (equal columns but for 3e-7 of
    /// another shape) are unidentified — infinite standard deviations — and their correlation
    /// says which way the ridge runs, −1 to 1e-6 (one up, the other down); a parameter the data
    /// do not see (a zero column) has no correlation at all, and its own direction.
    #[test]
    fn a_ridge_shows_in_the_correlations() {
        let a = Mat::from_fn(8, 3, |i, j| {
            let x = 1.0 + i as f64;
            match j {
                0 => x,
                1 => x + 3e-7 * (x * 0.7).sin(),
                _ => 0.0,
            }
        });
        let post = eight_rows_at_unit_values(a);
        assert!(post.marginals.iter().all(|m| m.sd.is_infinite()));
        assert!(
            (post.correlation[0][1] + 1.0).abs() < 1e-6,
            "{:?}",
            post.correlation
        );
        assert!(post.correlation[0][2].is_nan() && post.correlation[2][1].is_nan());
        assert_eq!(post.correlation[2][2], 1.0);
        assert!(post.directions.iter().any(|d| d.vector == [0.0, 0.0, 1.0]));
    }

    /// Data the model reproduces exactly (`y = A x`) leave an estimated noise at round-off,
    /// and it is named as such; the noisy data of [`linear_problem`] are not, nor is a stated
    /// noise however small.
    #[test]
    fn noise_estimated_at_round_off_is_named() {
        let noisy = linear_problem();
        let x = [0.8, -0.4, 1.7];
        let exact = Linear {
            y: (0..12)
                .map(|i| (0..3).map(|j| noisy.a[(i, j)] * x[j]).sum())
                .collect(),
            ..linear_problem()
        };
        let start = [1.0, 1.0, 1.0];
        let post = laplace(&exact, &params(&start), &start, &Default::default(), None).unwrap();
        let named = noise_at_roundoff(&exact, &post.sigma);
        assert_eq!(named.len(), 1, "{named:?} (sigma {:?})", post.sigma);
        assert_eq!(named[0].0, "all");
        assert!(named[0].1 < ROUNDOFF_NOISE);
        let at_roundoff = |p: &Posterior| p.warnings.iter().any(|w| w.contains("round-off"));
        assert!(at_roundoff(&post), "{:?}", post.warnings);
        // A stated noise is the user's: no warning, however small.
        let stated = PosteriorSettings {
            noise: Noise::Absolute(vec![1e-14]),
            ..Default::default()
        };
        let post = laplace(&exact, &params(&start), &start, &stated, None).unwrap();
        assert!(!at_roundoff(&post), "{:?}", post.warnings);
        let post = laplace(&noisy, &params(&start), &start, &Default::default(), None).unwrap();
        assert!(post.sigma[0] > 0.01, "{:?}", post.sigma);
        assert!(noise_at_roundoff(&noisy, &post.sigma).is_empty());
        assert!(!at_roundoff(&post), "{:?}", post.warnings);
        // Only an estimate is checked by the posterior; the function itself compares levels.
        assert_eq!(noise_at_roundoff(&noisy, &[1e-12]).len(), 1);
        assert!(noise_at_roundoff(&noisy, &[1e-8]).is_empty());
    }

    /// Estimated noise with no degree of freedom left: reported as unknown, not as certainty.
    #[test]
    fn noise_that_cannot_be_estimated_gives_an_unknown_posterior() {
        let a = Mat::from_fn(3, 3, |i, j| if i == j { 1.0 } else { 0.1 });
        let lik = Linear {
            a,
            y: vec![1.0, 2.0, 3.0],
            groups: vec![0; 3],
        };
        let start = [1.0, 1.0, 1.0];
        let post = laplace(&lik, &params(&start), &start, &Default::default(), None).unwrap();
        assert!(
            post.marginals
                .iter()
                .all(|m| m.sd.is_nan() && m.mean == 1.0)
        );
        assert!(post.sigma[0].is_nan() && post.samples.is_empty());
        assert!(
            post.warnings.len() == 1 && post.warnings[0].contains("no degree of freedom"),
            "{:?}",
            post.warnings
        );
    }

    #[test]
    fn normal_quantiles() {
        assert!((normal_quantile(0.95) - 1.6448536269514722).abs() < 1e-12);
        assert!((normal_quantile(0.975) - 1.959963984540054).abs() < 1e-12);
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-16);
        assert!((normal_cdf(-3.0) - 0.0013498980316301).abs() < 1e-13);
    }

    /// Every Jacobian column against a central difference `(f(φ(1+h)) − f(φ(1−h)))/2h`,
    /// `h = 1e-6`, to 1e-6 of the column's largest entry.
    fn check_jacobian(lik: &dyn Likelihood, values: &[f64]) {
        check_columns(lik, values, 0..values.len());
    }

    /// [`check_jacobian`] on the columns `columns` only.
    fn check_columns(lik: &dyn Likelihood, values: &[f64], columns: std::ops::Range<usize>) {
        let p = lik.predict(values, true).unwrap();
        let j = p.jacobian.unwrap();
        let h = 1e-6;
        for c in columns {
            let mut up = values.to_vec();
            let mut dn = values.to_vec();
            up[c] *= 1.0 + h;
            dn[c] *= 1.0 - h;
            let (fu, fd) = (
                lik.predict(&up, false).unwrap().values,
                lik.predict(&dn, false).unwrap().values,
            );
            let big = (0..j.nrows()).map(|i| j[(i, c)].abs()).fold(0.0, f64::max);
            assert!(big > 0.0, "column {c} is zero");
            for i in 0..j.nrows() {
                let fd_i = (fu[i] - fd[i]) / (2.0 * h);
                assert!(
                    (fd_i - j[(i, c)]).abs() < 1e-6 * big,
                    "row {i} column {c}: {fd_i} vs {}",
                    j[(i, c)]
                );
            }
        }
    }

    /// The modal, direct, modal-data (frequencies, and MAC-paired shapes), correlation and
    /// damping Jacobians against central differences on the damped four-DOF chain (m2 = 1.3 kg).
    #[test]
    fn jacobians_match_central_differences() {
        use crate::correlation::frf::{amplitude_correlation, shape_correlation};
        use faer::c64;
        let model = chain_model(&[1.0, 1.3, 1.0, 1.0]);
        let values = model.initial_values();
        let freqs = frequency_lines(1.0, 40.0, 0.5);
        let x = measured(0.02, &freqs);
        let lines: Vec<usize> = (0..freqs.len()).collect();
        let modal = ModalFrfLikelihood::new(
            &model,
            &x,
            lines.clone(),
            ModeSelection::All,
            ModalDamping::Structural(vec![0.02; 4]),
        );
        check_jacobian(&modal, &values);
        let direct = DirectFrfLikelihood::new(&model, &x, lines.clone(), 0.02);
        check_jacobian(&direct, &values);
        // The modal and direct predictions agree for a uniform loss factor on a complete basis.
        let (a, b) = (
            modal.predict(&values, true).unwrap(),
            direct.predict(&values, true).unwrap(),
        );
        let big = a.values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for (u, v) in a.values.iter().zip(&b.values) {
            assert!((u - v).abs() < 1e-9 * big);
        }
        let freq = ModalDataLikelihood::new(&model, ModeSelection::All, vec![(9.8, 0), (18.7, 1)]);
        check_jacobian(&freq, &values);
        // Frequencies and MAC-paired shapes at three DOFs, the shapes of the true chain scaled
        // and flipped (the rows see neither).
        let truth = chain_model(&[1.0; 4]);
        let (t, _) = truth
            .modal_state(&truth.initial_values(), ModeSelection::All)
            .unwrap();
        let dofs = t.dofs[1..].to_vec();
        let shapes = t.shapes_at(&dofs).unwrap();
        let shapes = Mat::from_fn(3, 2, |i, r| [2.5, -0.1][r] * shapes[(i, r + 1)]);
        let fx = t.modes.frequencies_hz();
        let modal_data =
            ModalDataLikelihood::new(&model, ModeSelection::All, vec![(fx[1], 1), (fx[2], 2)])
                .with_shapes(dofs, shapes.as_ref())
                .unwrap();
        assert_eq!(modal_data.measured().len(), 2 + 2 * 3);
        check_jacobian(&modal_data, &values);
        // At the truth every row matches: frequency ratios 1, shapes equal after scaling.
        let at_truth = modal_data
            .predict(&truth.initial_values(), false)
            .unwrap()
            .values;
        for (p, y) in at_truth.iter().zip(modal_data.measured()) {
            assert!((p - y).abs() < 1e-12, "{p} vs {y}");
        }
        // The correlation likelihoods: their residuals at a line are X(1 − χ_s) and
        // (X + A)(1 − χ_a) of the correlation module (squared norms).
        let predicted = modal.predict(&values, false).unwrap().values;
        for coefficient in [Coefficient::Shape, Coefficient::Amplitude] {
            let lik = CorrelationLikelihood::new(
                &model,
                &x,
                lines.clone(),
                ModeSelection::All,
                ModalDamping::Structural(vec![0.02; 4]),
                coefficient,
            );
            let p = lik.predict(&values, true).unwrap();
            if coefficient == Coefficient::Shape {
                // The direction of the response to a force at mass 1 does not depend on the
                // dynamic stiffness there (`(Z + δ e₁e₁ᵀ)⁻¹e₁ ∥ Z⁻¹e₁`): χ_s is blind to m1.
                let j = p.jacobian.unwrap();
                let col = |c: usize| (0..j.nrows()).map(|i| j[(i, c)].abs()).fold(0.0, f64::max);
                assert!(col(0) < 1e-12 * col(1), "{} vs {}", col(0), col(1));
                check_columns(&lik, &values, 1..4);
            } else {
                check_jacobian(&lik, &values);
            }
            let p = p.values;
            let y = lik.measured();
            for l in [3, 40, 70] {
                let rows = 8 * l..8 * (l + 1);
                let complex = |v: &[f64]| -> Vec<c64> {
                    (0..4)
                        .map(|q| c64::new(v[8 * l + 2 * q], v[8 * l + 2 * q + 1]))
                        .collect()
                };
                let (xs, a) = (complex(y), complex(&predicted));
                let (xx, aa): (f64, f64) = (
                    xs.iter().map(|v| v.norm_sqr()).sum(),
                    a.iter().map(|v| v.norm_sqr()).sum(),
                );
                let expected = match coefficient {
                    Coefficient::Shape => xx * (1.0 - shape_correlation(&xs, &a)),
                    Coefficient::Amplitude => (xx + aa) * (1.0 - amplitude_correlation(&xs, &a)),
                };
                let got: f64 = rows.map(|i| (y[i] - p[i]).powi(2)).sum();
                assert!(
                    (got - expected).abs() < 1e-9 * xx,
                    "{coefficient:?} line {l}: {got} vs {expected}"
                );
            }
        }
        let (state, _) = model.modal_state(&values, ModeSelection::All).unwrap();
        let damping = DampingLikelihood::new(
            &state,
            &x,
            lines,
            Box::new(|v: &[f64]| {
                let mut all = vec![0.02; 4];
                all[0] = v[0];
                all[1] = v[1];
                ModalDamping::Structural(all)
            }),
            vec![0, 1],
        );
        check_jacobian(&damping, &[0.03, 0.01]);
    }

    /// Sampled and first-order bands agree on the nearly linear chain, and natural-frequency
    /// bands come out for every elastic mode.
    #[test]
    fn predictive_bands_agree_to_first_order() {
        let model = chain_model(&[1.0, 1.0, 1.0, 1.0]);
        let values = model.initial_values();
        let freqs = frequency_lines(1.0, 40.0, 0.5);
        let x = measured(0.02, &freqs);
        let lines: Vec<usize> = (0..freqs.len()).collect();
        let lik = ModalFrfLikelihood::new(
            &model,
            &x,
            lines,
            ModeSelection::All,
            ModalDamping::Structural(vec![0.02; 4]),
        );
        let settings = PosteriorSettings {
            noise: Noise::Relative(0.01),
            predictive_samples: 400,
            ..Default::default()
        };
        let natural = NaturalFrequencies {
            model: &model,
            selection: ModeSelection::All,
            count: 4,
            max_hz: f64::INFINITY,
        };
        let post = laplace(&lik, model.parameters(), &values, &settings, Some(&natural)).unwrap();
        assert_eq!(post.natural_frequencies.len(), 4);
        assert_eq!(post.predictive_samples, 400);
        for b in &post.natural_frequencies {
            assert!(b.sd_linear > 0.0);
            assert!((b.sd_sampled / b.sd_linear - 1.0).abs() < 0.15, "{b:?}");
        }
        let b = &post.frf[10];
        assert!((b.sd_sampled / b.sd_linear - 1.0).abs() < 0.15, "{b:?}");
        // Noise-free data at the truth: the mode is the truth.
        for m in &post.marginals {
            assert!((m.mean - 1.0).abs() < 1e-9, "{m:?}");
        }
    }
}
