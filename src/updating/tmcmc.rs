//! Transitional Markov chain Monte Carlo (Ching and Chen 2007; docs/theory.md §15): samples of
//! the posterior `p(φ|y) ∝ p(y|φ) p(φ)` and the model evidence `p(y) = ∫ p(y|φ) p(φ) dφ`.
//!
//! The likelihood is the output error of [`Likelihood`], `y = f(φ) + e`, `e ~ N(0, diag σ_i²)`,
//! with every normalising constant kept (15.1): `ln p(y|φ) = −½ Σ_i (r_i/σ_i)² − Σ_i ln σ_i −
//! (m/2) ln 2π`, so that the evidence of different parameterisations of one data set can be
//! compared. The noise must be stated ([`Noise::Absolute`] or [`Noise::Relative`]):
//! [`Noise::Estimated`] is refused. Integrating a per-group `σ` out under a Jeffreys prior
//! `p(σ) ∝ 1/σ` would give a Student-t marginal, but that prior is improper, so the evidence
//! would be defined only up to an arbitrary constant per noise group and could not be reported
//! as a number; a stated noise keeps the evidence absolute.
//!
//! Stages `j = 0, 1, …` sample the tempered densities `p_j(φ) ∝ p(y|φ)^{β_j} p(φ)`, `0 = β_0 <
//! β_1 < … < β_J = 1` (15.2). From the samples `φ_k` of stage `j` the plausibility weights
//! `w_k = p(y|φ_k)^{β_{j+1} − β_j}` (15.3) are formed, `β_{j+1}` chosen by bisection so that
//! their coefficient of variation is the target (1: an effective sample size of half the
//! samples), or 1 when that is reached sooner. The mean weight `S_j = (1/N) Σ_k w_k` estimates
//! the ratio of the stages' normalising constants, so `ln p(y) = Σ_j ln S_j` (15.4), summed
//! with the largest log-likelihood factored out (log-sum-exp). The samples are resampled in
//! proportion to `w_k` and every one moves by Metropolis-Hastings steps under `p_{j+1}` with
//! the Gaussian proposal `N(φ, β² Σ_j)`, `Σ_j` the weighted sample covariance (15.5),
//! `β² = 0.04` by default.
//!
//! The likelihood evaluations of a stage run in parallel (rayon); every chain draws from its
//! own ChaCha8 stream seeded by `(seed, stage, chain)`, so the result is the same for any
//! thread count.

use super::model::{UpdatingError, UpdatingParameter};
use super::posterior::{
    Direction, Likelihood, Marginal, Noise, Posterior, Refinement, normal_cdf, normal_quantile,
    row_sigmas,
};
use crate::core::progress;
use faer::{Mat, Side};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use std::f64::consts::PI;

/// The prior of one parameter, on its absolute value (SI).
#[derive(Clone, Debug, PartialEq)]
pub enum ParamPrior {
    /// Uniform on `[lower, upper]`.
    Uniform {
        /// Lower end.
        lower: f64,
        /// Upper end.
        upper: f64,
    },
    /// Normal `N(mean, sd²)`.
    Normal {
        /// Mean.
        mean: f64,
        /// Standard deviation.
        sd: f64,
    },
    /// Lognormal: `ln φ ~ N(ln median, log_sd²)`.
    LogNormal {
        /// Median.
        median: f64,
        /// Standard deviation of `ln φ`.
        log_sd: f64,
    },
    /// Normal `N(mean, sd²)` truncated to `[lower, upper]`.
    Bounded {
        /// Mean of the untruncated normal.
        mean: f64,
        /// Its standard deviation.
        sd: f64,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
}

const LN_2PI: f64 = 1.837_877_066_409_345_5;

impl ParamPrior {
    /// Why the prior is not a proper density, if it is not.
    pub fn check(&self) -> Result<(), String> {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        match *self {
            ParamPrior::Uniform { lower, upper } if !(finite(&[lower, upper]) && lower < upper) => {
                Err(format!(
                    "uniform prior [{lower}, {upper}]: give finite bounds, lower < upper"
                ))
            }
            ParamPrior::Normal { mean, sd } if !(finite(&[mean, sd]) && sd > 0.0) => Err(format!(
                "normal prior: mean {mean}, sd {sd}; give a finite mean and a positive sd"
            )),
            ParamPrior::LogNormal { median, log_sd }
                if !(finite(&[median, log_sd]) && median > 0.0 && log_sd > 0.0) =>
            {
                Err(format!(
                    "lognormal prior: median {median}, log_sd {log_sd}; both must be positive"
                ))
            }
            ParamPrior::Bounded {
                mean,
                sd,
                lower,
                upper,
            } if !(finite(&[mean, sd, lower, upper]) && sd > 0.0 && lower < upper) => Err(format!(
                "bounded prior: mean {mean}, sd {sd} on [{lower}, {upper}]; give a positive sd and lower < upper"
            )),
            ParamPrior::Bounded {
                mean,
                sd,
                lower,
                upper,
            } if normal_cdf((upper - mean) / sd) - normal_cdf((lower - mean) / sd) <= 1e-12 => {
                Err(format!(
                    "bounded prior: [{lower}, {upper}] holds no probability of N({mean}, {sd}²)"
                ))
            }
            _ => Ok(()),
        }
    }

    /// `ln p(φ)`, `−∞` outside the support.
    pub fn log_density(&self, x: f64) -> f64 {
        match *self {
            ParamPrior::Uniform { lower, upper } => {
                if (lower..=upper).contains(&x) {
                    -(upper - lower).ln()
                } else {
                    f64::NEG_INFINITY
                }
            }
            ParamPrior::Normal { mean, sd } => {
                let z = (x - mean) / sd;
                -0.5 * z * z - sd.ln() - 0.5 * LN_2PI
            }
            ParamPrior::LogNormal { median, log_sd } => {
                if x <= 0.0 {
                    return f64::NEG_INFINITY;
                }
                let z = (x.ln() - median.ln()) / log_sd;
                -0.5 * z * z - log_sd.ln() - x.ln() - 0.5 * LN_2PI
            }
            ParamPrior::Bounded {
                mean,
                sd,
                lower,
                upper,
            } => {
                if !(lower..=upper).contains(&x) {
                    return f64::NEG_INFINITY;
                }
                let z = (x - mean) / sd;
                let mass = normal_cdf((upper - mean) / sd) - normal_cdf((lower - mean) / sd);
                -0.5 * z * z - sd.ln() - 0.5 * LN_2PI - mass.ln()
            }
        }
    }

    /// `∂ ln p(φ)/∂φ` inside the support (0 for the uniform prior).
    pub fn grad_log_density(&self, x: f64) -> f64 {
        match *self {
            ParamPrior::Uniform { .. } => 0.0,
            ParamPrior::Normal { mean, sd } | ParamPrior::Bounded { mean, sd, .. } => {
                -(x - mean) / (sd * sd)
            }
            ParamPrior::LogNormal { median, log_sd } => {
                -((x.ln() - median.ln()) / (log_sd * log_sd) + 1.0) / x
            }
        }
    }

    /// One draw.
    pub fn sample(&self, rng: &mut ChaCha8Rng) -> f64 {
        let z = |rng: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(rng) };
        match *self {
            ParamPrior::Uniform { lower, upper } => lower + (upper - lower) * rng.random::<f64>(),
            ParamPrior::Normal { mean, sd } => mean + sd * z(rng),
            ParamPrior::LogNormal { median, log_sd } => median * (log_sd * z(rng)).exp(),
            ParamPrior::Bounded {
                mean,
                sd,
                lower,
                upper,
            } => {
                // Inverse CDF on the truncated range.
                let (a, b) = (
                    normal_cdf((lower - mean) / sd),
                    normal_cdf((upper - mean) / sd),
                );
                let u = a + (b - a) * rng.random::<f64>();
                (mean + sd * normal_quantile(u)).clamp(lower, upper)
            }
        }
    }

    /// The prior's mean and standard deviation (for tests and summaries).
    pub fn moments(&self) -> (f64, f64) {
        match *self {
            ParamPrior::Uniform { lower, upper } => {
                (0.5 * (lower + upper), (upper - lower) / 12f64.sqrt())
            }
            ParamPrior::Normal { mean, sd } => (mean, sd),
            ParamPrior::LogNormal { median, log_sd } => {
                let s2 = log_sd * log_sd;
                let m = median * (0.5 * s2).exp();
                (m, m * (s2.exp() - 1.0).sqrt())
            }
            ParamPrior::Bounded {
                mean,
                sd,
                lower,
                upper,
            } => {
                let (a, b) = ((lower - mean) / sd, (upper - mean) / sd);
                let pdf = |t: f64| (-0.5 * t * t).exp() / (2.0 * PI).sqrt();
                let z = normal_cdf(b) - normal_cdf(a);
                let d = (pdf(a) - pdf(b)) / z;
                let v = 1.0 + (a * pdf(a) - b * pdf(b)) / z - d * d;
                (mean + sd * d, sd * v.max(0.0).sqrt())
            }
        }
    }
}

/// Settings of TMCMC.
#[derive(Clone, Debug)]
pub struct TmcmcSettings {
    /// Samples per stage `N`.
    pub samples: usize,
    /// Target coefficient of variation of the plausibility weights.
    pub target_cov: f64,
    /// Scale `β²` of the proposal covariance.
    pub proposal_scale: f64,
    /// Metropolis-Hastings steps of every chain per stage.
    pub mh_steps: usize,
    /// Most stages before giving up.
    pub max_stages: usize,
    /// Seed.
    pub seed: u64,
}

impl Default for TmcmcSettings {
    fn default() -> Self {
        TmcmcSettings {
            samples: 1000,
            target_cov: 1.0,
            proposal_scale: 0.04,
            mh_steps: 1,
            max_stages: 200,
            seed: 0,
        }
    }
}

/// One tempering stage.
#[derive(Clone, Debug, PartialEq)]
pub struct TmcmcStage {
    /// The exponent `β_{j+1}` reached.
    pub exponent: f64,
    /// `ln S_j`, the stage's share of the log evidence (15.4).
    pub log_evidence: f64,
    /// Fraction of accepted Metropolis-Hastings proposals.
    pub acceptance: f64,
    /// Distinct samples kept by the resampling.
    pub distinct: usize,
}

/// What TMCMC returns.
#[derive(Clone, Debug, PartialEq)]
pub struct Tmcmc {
    /// Samples of the posterior (absolute values), `N × n`.
    pub samples: Vec<Vec<f64>>,
    /// Their weights (equal: the last stage ends with `β = 1` after resampling and moves).
    pub weights: Vec<f64>,
    /// `ln p(y|φ_k)` of every sample.
    pub log_likelihood: Vec<f64>,
    /// `ln p(y)`.
    pub log_evidence: f64,
    /// The stages in order.
    pub stages: Vec<TmcmcStage>,
    /// Noise standard deviation per group, as used.
    pub sigma: Vec<f64>,
    /// Rows of the likelihood.
    pub rows: usize,
    /// Evaluations that failed (the model could not be analysed there): taken as zero
    /// likelihood.
    pub failed: usize,
}

/// The samples after a tempering stage: the prior's for stage 0, those of `p_j` after stage
/// `j` (resampled and moved).
#[derive(Clone, Debug, PartialEq)]
pub struct Population {
    /// Samples (absolute values), `N × n`.
    pub samples: Vec<Vec<f64>>,
    /// `ln p(y|φ_k)` of every sample (`−∞` where the model could not be analysed).
    pub log_likelihood: Vec<f64>,
    /// The stages so far, in order.
    pub stages: Vec<TmcmcStage>,
    /// Evaluations that failed so far.
    pub failed: usize,
}

impl Population {
    /// The tempering exponent `β_j` the samples follow.
    pub fn exponent(&self) -> f64 {
        self.stages.last().map_or(0.0, |s| s.exponent)
    }

    /// `Σ ln S_j` over the stages so far (15.4).
    pub fn log_evidence(&self) -> f64 {
        self.stages.iter().map(|s| s.log_evidence).sum()
    }

    /// That a population read from a store is the one asked for.
    fn check_shape(&self, stage: usize, samples: usize, n: usize) -> Result<(), UpdatingError> {
        let ok = self.stages.len() == stage
            && self.samples.len() == samples
            && self.log_likelihood.len() == samples
            && self.samples.iter().all(|x| x.len() == n);
        if ok {
            Ok(())
        } else {
            Err(UpdatingError::Data(format!(
                "the stored population of TMCMC stage {stage} has {} samples of {} parameters after {} stages where {samples} of {n} after {stage} were asked for: the store is inconsistent (clear the cache entry)",
                self.samples.len(),
                self.samples.first().map_or(0, Vec::len),
                self.stages.len()
            )))
        }
    }
}

/// Where the populations of finished stages are kept so that a stopped run resumes (a pipeline
/// stage keeps them in the run's cache).
pub trait PopulationStore: Sync {
    /// The population after stage `stage`: read from the store, or `compute`d and stored.
    fn population(
        &self,
        stage: usize,
        compute: &mut dyn FnMut() -> Result<Population, UpdatingError>,
    ) -> Result<Population, UpdatingError>;

    /// How this process shares each stage's chains with others that run the same sampling
    /// against the same store: `(batches, own batch)`; `(1, 0)` when it works alone.
    fn sharing(&self) -> (usize, usize) {
        (1, 0)
    }

    /// Batch `batch` of `batches` of stage `stage`'s chains: read from the store, or
    /// `compute`d and stored.
    fn chains(
        &self,
        _stage: usize,
        _batch: usize,
        _batches: usize,
        compute: &mut dyn FnMut() -> Result<Chains, UpdatingError>,
    ) -> Result<Chains, UpdatingError> {
        compute()
    }
}

/// No store: every population is computed.
pub struct Unstored;

impl PopulationStore for Unstored {
    fn population(
        &self,
        _stage: usize,
        compute: &mut dyn FnMut() -> Result<Population, UpdatingError>,
    ) -> Result<Population, UpdatingError> {
        compute()
    }
}

/// A ChaCha8 stream of its own for `(seed, stage, chain)`.
pub fn chain_rng(seed: u64, stage: u64, chain: u64) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    key[8..16].copy_from_slice(&stage.to_le_bytes());
    key[16..24].copy_from_slice(&chain.to_le_bytes());
    key[24..].copy_from_slice(b"femutmcm");
    ChaCha8Rng::from_seed(key)
}

/// `ln Σ_k exp(a_k)` (stable; `−∞` for an empty or all-`−∞` set).
pub fn log_sum_exp(a: &[f64]) -> f64 {
    let max = a.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return f64::NEG_INFINITY;
    }
    max + a.iter().map(|v| (v - max).exp()).sum::<f64>().ln()
}

/// The coefficient of variation of `w_k = exp(Δ ℓ_k)` (15.3).
pub fn weight_cov(log_lik: &[f64], delta: f64) -> f64 {
    let max = log_lik.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let w: Vec<f64> = log_lik
        .iter()
        .map(|l| {
            if *l == f64::NEG_INFINITY {
                0.0
            } else {
                (delta * (l - max)).exp()
            }
        })
        .collect();
    let n = w.len() as f64;
    let mean = w.iter().sum::<f64>() / n;
    let var = w.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    var.sqrt() / mean
}

/// The next exponent from `beta`: the `β' ∈ (β, 1]` whose weights have the target coefficient
/// of variation (bisection on `β' − β`), or 1 when the weights to 1 are below it.
pub fn next_exponent(log_lik: &[f64], beta: f64, target_cov: f64) -> f64 {
    let span = 1.0 - beta;
    if weight_cov(log_lik, span) <= target_cov {
        return 1.0;
    }
    let (mut lo, mut hi) = (0.0, span);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if weight_cov(log_lik, mid) > target_cov {
            hi = mid;
        } else {
            lo = mid;
        }
        if hi - lo <= 1e-15 * span.max(1e-300) {
            break;
        }
    }
    // Never stand still: a step of at least round-off above β.
    (beta + lo.max(f64::EPSILON * span)).min(1.0)
}

/// Lower Cholesky factor of a small symmetric positive semi-definite matrix, with a diagonal
/// jitter of `1e-12·max diag` (repeated ×10 as needed) for directions the samples collapsed.
pub(crate) fn cholesky(c: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = c.len();
    let scale = (0..n)
        .map(|i| c[i][i].abs())
        .fold(0.0, f64::max)
        .max(1e-300);
    let mut jitter = 0.0;
    loop {
        let mut l = vec![vec![0.0; n]; n];
        let mut ok = true;
        'outer: for i in 0..n {
            for j in 0..=i {
                let dot: f64 = l[i][..j].iter().zip(&l[j][..j]).map(|(a, b)| a * b).sum();
                let s = c[i][j] + if i == j { jitter } else { 0.0 } - dot;
                if i == j {
                    if s <= 0.0 || !s.is_finite() {
                        ok = false;
                        break 'outer;
                    }
                    l[i][i] = s.sqrt();
                } else {
                    l[i][j] = s / l[j][j];
                }
            }
        }
        if ok {
            return l;
        }
        jitter = if jitter == 0.0 {
            1e-12 * scale
        } else {
            jitter * 10.0
        };
    }
}

/// The log-likelihood (15.1) with the rows' `σ_i`.
struct LogLik<'a> {
    lik: &'a dyn Likelihood,
    sigma: Vec<f64>,
    constant: f64,
}

impl LogLik<'_> {
    /// `ln p(y|φ)`; `None` when the model cannot be analysed at `φ`.
    fn eval(&self, values: &[f64]) -> Option<f64> {
        let p = self.lik.predict(values, false).ok()?;
        let y = self.lik.measured();
        let q: f64 = (y.iter().zip(&p.values).zip(&self.sigma))
            .map(|((a, b), s)| ((a - b) / s).powi(2))
            .sum();
        let v = self.constant - 0.5 * q;
        v.is_finite().then_some(v)
    }
}

fn log_prior(priors: &[ParamPrior], x: &[f64]) -> f64 {
    priors.iter().zip(x).map(|(p, v)| p.log_density(*v)).sum()
}

/// Samples the posterior of the parameters under `lik` and the `priors` (one per parameter)
/// by TMCMC, with the noise `noise` stated.
pub fn tmcmc(
    lik: &dyn Likelihood,
    priors: &[ParamPrior],
    noise: &Noise,
    settings: &TmcmcSettings,
) -> Result<Tmcmc, UpdatingError> {
    tmcmc_stored(lik, priors, noise, settings, &Unstored)
}

/// [`tmcmc`] with every stage's population kept in `store`: a run that stopped (interrupted,
/// or at `max_stages`) resumes from the last population stored, and gives the samples an
/// uninterrupted run gives (every stage draws from streams seeded by `(seed, stage, chain)`).
pub fn tmcmc_stored(
    lik: &dyn Likelihood,
    priors: &[ParamPrior],
    noise: &Noise,
    settings: &TmcmcSettings,
    store: &dyn PopulationStore,
) -> Result<Tmcmc, UpdatingError> {
    let n = priors.len();
    let big_n = settings.samples;
    if n == 0 {
        return Err(UpdatingError::Settings(
            "no parameter to sample: give at least one prior".into(),
        ));
    }
    if big_n < 2 {
        return Err(UpdatingError::Settings(format!(
            "{big_n} samples per stage: give at least 2 (hundreds for a useful posterior)"
        )));
    }
    if !(settings.target_cov > 0.0 && settings.target_cov.is_finite()) {
        return Err(UpdatingError::Settings(
            "the target coefficient of variation must be positive".into(),
        ));
    }
    if !(settings.proposal_scale > 0.0 && settings.proposal_scale.is_finite()) {
        return Err(UpdatingError::Settings(
            "the proposal scale β² must be positive".into(),
        ));
    }
    for (j, p) in priors.iter().enumerate() {
        p.check()
            .map_err(|e| UpdatingError::Settings(format!("parameter {}: {e}", j + 1)))?;
    }
    if matches!(noise, Noise::Estimated) {
        return Err(UpdatingError::Settings(
            "TMCMC needs the noise stated (sigma, relative or snr_db): an estimated noise has no proper prior, so the evidence would be undefined".into(),
        ));
    }
    let (sigma_rows, sigma) = row_sigmas(lik, noise, &[], n)?;
    let m = lik.measured().len();
    if m == 0 {
        return Err(UpdatingError::Data("the likelihood has no data".into()));
    }
    let constant = -sigma_rows.iter().map(|s| s.ln()).sum::<f64>() - 0.5 * m as f64 * LN_2PI;
    let ll = LogLik {
        lik,
        sigma: sigma_rows,
        constant,
    };
    let mut population = store.population(0, &mut || {
        let chains = shared_chains(store, 0, big_n, &|range| {
            Ok(prior_chains(&ll, priors, settings, range))
        })?;
        Ok(Population {
            samples: chains.samples,
            log_likelihood: chains.log_likelihood,
            stages: Vec::new(),
            failed: chains.failed,
        })
    })?;
    population.check_shape(0, big_n, n)?;
    if population.failed == big_n {
        return Err(UpdatingError::Model(
            "the model could not be analysed at any sample of the prior".into(),
        ));
    }
    while population.exponent() < 1.0 {
        let stage = population.stages.len() + 1;
        if stage > settings.max_stages {
            return Err(UpdatingError::Settings(format!(
                "TMCMC did not reach β = 1 in {} stages (β = {:.3e}): raise max_stages or the target coefficient of variation",
                settings.max_stages,
                population.exponent()
            )));
        }
        let before = &population;
        let next = store.population(stage, &mut || {
            let plan = StagePlan::new(settings, before);
            let chains = shared_chains(store, stage, big_n, &|range| {
                Ok(plan.move_chains(&ll, priors, settings, before, range))
            })?;
            Ok(plan.finish(settings, before, chains))
        })?;
        next.check_shape(stage, big_n, n)?;
        population = next;
    }
    Ok(Tmcmc {
        weights: vec![1.0 / big_n as f64; big_n],
        log_evidence: population.log_evidence(),
        samples: population.samples,
        log_likelihood: population.log_likelihood,
        stages: population.stages,
        sigma,
        rows: m,
        failed: population.failed,
    })
}

/// The chains of `range` of a stage (or the samples of the prior), in chain order.
#[derive(Clone, Debug, PartialEq)]
pub struct Chains {
    /// Samples (absolute values).
    pub samples: Vec<Vec<f64>>,
    /// `ln p(y|φ_k)` of each (`−∞` where the model could not be analysed).
    pub log_likelihood: Vec<f64>,
    /// Metropolis-Hastings proposals accepted (0 for the prior).
    pub accepted: usize,
    /// Evaluations that failed.
    pub failed: usize,
}

/// Chain ranges of `n` chains split into `batches` contiguous ones, the first ones one longer.
pub fn batch_ranges(n: usize, batches: usize) -> Vec<std::ops::Range<usize>> {
    let b = batches.clamp(1, n.max(1));
    let (size, extra) = (n / b, n % b);
    let mut start = 0;
    (0..b)
        .map(|i| {
            let len = size + usize::from(i < extra);
            let r = start..start + len;
            start += len;
            r
        })
        .collect()
}

/// The chains of stage `stage` through `store`'s sharing: each batch read from the store or
/// computed by `compute` (this process's own batch first, then the others in turn, so that
/// processes started together work on different batches and a slow or lost one is covered by
/// the others), joined in chain order.
fn shared_chains(
    store: &dyn PopulationStore,
    stage: usize,
    n: usize,
    compute: &(dyn Fn(std::ops::Range<usize>) -> Result<Chains, UpdatingError> + Sync),
) -> Result<Chains, UpdatingError> {
    let (batches, own) = store.sharing();
    let ranges = batch_ranges(n, batches);
    let b = ranges.len();
    let mut parts: Vec<Option<Chains>> = vec![None; b];
    for r in 0..b {
        let i = (own + r) % b;
        let range = ranges[i].clone();
        let chains = store.chains(stage, i, b, &mut || compute(range.clone()))?;
        if chains.samples.len() != range.len() || chains.log_likelihood.len() != range.len() {
            return Err(UpdatingError::Data(format!(
                "the stored batch {i} of {b} of TMCMC stage {stage} has {} chains where {} were asked for: the store is inconsistent (clear the cache entry)",
                chains.samples.len(),
                range.len()
            )));
        }
        parts[i] = Some(chains);
    }
    let mut all = Chains {
        samples: Vec::with_capacity(n),
        log_likelihood: Vec::with_capacity(n),
        accepted: 0,
        failed: 0,
    };
    for c in parts.into_iter().flatten() {
        all.samples.extend(c.samples);
        all.log_likelihood.extend(c.log_likelihood);
        all.accepted += c.accepted;
        all.failed += c.failed;
    }
    Ok(all)
}

/// Stage 0: samples `range` of the prior and their log-likelihoods.
fn prior_chains(
    ll: &LogLik<'_>,
    priors: &[ParamPrior],
    settings: &TmcmcSettings,
    range: std::ops::Range<usize>,
) -> Chains {
    let done = progress::task(
        || "TMCMC stage 0 (the prior): samples".into(),
        range.len() as u64,
    );
    let first: Vec<(Vec<f64>, Option<f64>)> = range
        .into_par_iter()
        .map(|k| {
            let mut rng = chain_rng(settings.seed, 0, k as u64);
            let x: Vec<f64> = priors.iter().map(|p| p.sample(&mut rng)).collect();
            let l = ll.eval(&x);
            done.advance(1);
            (x, l)
        })
        .collect();
    Chains {
        failed: first.iter().filter(|s| s.1.is_none()).count(),
        log_likelihood: first
            .iter()
            .map(|s| s.1.unwrap_or(f64::NEG_INFINITY))
            .collect(),
        samples: first.into_iter().map(|s| s.0).collect(),
        accepted: 0,
    }
}

/// What every chain of a tempering stage shares, from the population `before` (15.3–15.5):
/// the next exponent, the stage's share of the evidence, the proposal's Cholesky factor and
/// the resampled starting points. Deterministic, so every process that shares the stage's
/// chains forms the same plan.
struct StagePlan {
    stage: usize,
    next: f64,
    log_s: f64,
    chol: Vec<Vec<f64>>,
    picks: Vec<usize>,
    distinct: usize,
}

impl StagePlan {
    fn new(settings: &TmcmcSettings, before: &Population) -> StagePlan {
        let (x, l) = (&before.samples, &before.log_likelihood);
        let (n, big_n, seed) = (
            x.first().map_or(0, Vec::len),
            settings.samples,
            settings.seed,
        );
        let stage = before.stages.len() + 1;
        let next = next_exponent(l, before.exponent(), settings.target_cov);
        let delta = next - before.exponent();
        // ln S_j = ln((1/N) Σ exp(Δ ℓ_k)), log-sum-exp (15.4).
        let a: Vec<f64> = l
            .iter()
            .map(|v| {
                if *v == f64::NEG_INFINITY {
                    f64::NEG_INFINITY
                } else {
                    delta * v
                }
            })
            .collect();
        let lse = log_sum_exp(&a);
        let log_s = lse - (big_n as f64).ln();
        let w: Vec<f64> = a.iter().map(|v| (v - lse).exp()).collect();
        // Weighted mean and covariance (15.5).
        let mean: Vec<f64> = (0..n)
            .map(|i| (0..big_n).map(|k| w[k] * x[k][i]).sum())
            .collect();
        let cov: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        settings.proposal_scale
                            * (0..big_n)
                                .map(|k| w[k] * (x[k][i] - mean[i]) * (x[k][j] - mean[j]))
                                .sum::<f64>()
                    })
                    .collect()
            })
            .collect();
        let chol = cholesky(&cov);
        // Multinomial resampling from one stream of its own (chain index N).
        let mut rng = chain_rng(seed, stage as u64, big_n as u64);
        let cdf: Vec<f64> = w
            .iter()
            .scan(0.0, |s, v| {
                *s += v;
                Some(*s)
            })
            .collect();
        let total = *cdf.last().unwrap_or(&1.0);
        let mut picks: Vec<usize> = (0..big_n)
            .map(|_| {
                let u = rng.random::<f64>() * total;
                cdf.partition_point(|c| *c <= u).min(big_n - 1)
            })
            .collect();
        picks.sort_unstable();
        let mut distinct = picks.clone();
        distinct.dedup();
        StagePlan {
            stage,
            next,
            log_s,
            chol,
            picks,
            distinct: distinct.len(),
        }
    }

    /// Chains `range`: each from its resampled start, `mh_steps` Metropolis-Hastings steps under
    /// `p_{j+1} ∝ p(y|φ)^{β'} p(φ)`, in parallel.
    fn move_chains(
        &self,
        ll: &LogLik<'_>,
        priors: &[ParamPrior],
        settings: &TmcmcSettings,
        before: &Population,
        range: std::ops::Range<usize>,
    ) -> Chains {
        let (x, l) = (&before.samples, &before.log_likelihood);
        let (n, seed, stage, next, chol) = (
            priors.len(),
            settings.seed,
            self.stage,
            self.next,
            &self.chol,
        );
        let done = progress::task(
            || format!("TMCMC stage {stage} (β = {next:.3e}): chains"),
            range.len() as u64,
        );
        let moved: Vec<(Vec<f64>, f64, usize, usize)> = range
            .into_par_iter()
            .map(|c| {
                let k = self.picks[c];
                let mut rng = chain_rng(seed, stage as u64, c as u64);
                let (mut cur, mut cur_l) = (x[k].clone(), l[k]);
                let mut cur_p = log_prior(priors, &cur);
                let (mut accepted, mut failures) = (0, 0);
                for _ in 0..settings.mh_steps {
                    let z: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
                    let prop: Vec<f64> = (0..n)
                        .map(|i| cur[i] + (0..=i).map(|j| chol[i][j] * z[j]).sum::<f64>())
                        .collect();
                    let u: f64 = rng.random();
                    let prop_p = log_prior(priors, &prop);
                    if prop_p == f64::NEG_INFINITY {
                        continue;
                    }
                    let Some(prop_l) = ll.eval(&prop) else {
                        failures += 1;
                        continue;
                    };
                    let log_ratio = next * (prop_l - cur_l) + prop_p - cur_p;
                    if cur_l == f64::NEG_INFINITY || u.ln() < log_ratio {
                        cur = prop;
                        cur_l = prop_l;
                        cur_p = prop_p;
                        accepted += 1;
                    }
                }
                done.advance(1);
                (cur, cur_l, accepted, failures)
            })
            .collect();
        Chains {
            accepted: moved.iter().map(|m| m.2).sum(),
            failed: moved.iter().map(|m| m.3).sum(),
            log_likelihood: moved.iter().map(|m| m.1).collect(),
            samples: moved.into_iter().map(|m| m.0).collect(),
        }
    }

    /// The population after the stage from its moved `chains`.
    fn finish(&self, settings: &TmcmcSettings, before: &Population, chains: Chains) -> Population {
        let acceptance =
            chains.accepted as f64 / (settings.samples * settings.mh_steps).max(1) as f64;
        let summary = format!(
            "TMCMC stage {}: β = {:.4e}, ln S = {:.4}, acceptance {acceptance:.3}, {} distinct",
            self.stage, self.next, self.log_s, self.distinct
        );
        tracing::debug!("{summary}");
        progress::note(|| summary);
        let mut stages = before.stages.clone();
        stages.push(TmcmcStage {
            exponent: self.next,
            log_evidence: self.log_s,
            acceptance,
            distinct: self.distinct,
        });
        Population {
            samples: chains.samples,
            log_likelihood: chains.log_likelihood,
            stages,
            failed: before.failed + chains.failed,
        }
    }
}

/// The `q`-quantile of sorted values (linear interpolation between order statistics).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let h = q * (sorted.len() - 1) as f64;
    let (i, f) = (h.floor() as usize, h - h.floor());
    let j = (i + 1).min(sorted.len() - 1);
    sorted[i] + f * (sorted[j] - sorted[i])
}

/// The samples summarised as a [`Posterior`]: sample means, standard deviations, central
/// credible intervals from the sample quantiles, covariance, correlation, and the principal
/// directions of the covariance in unity coordinates `δφ_j/φ̄_j`. `updated` is reported as the
/// best sample (largest likelihood); the refinement fields are not applicable (NaN, 0 steps).
pub fn to_posterior(
    t: &Tmcmc,
    params: &[UpdatingParameter],
    groups: Vec<String>,
    credible_level: f64,
    seed: u64,
) -> Posterior {
    summarise(
        &SampleSet {
            samples: &t.samples,
            log_likelihood: &t.log_likelihood,
            sigma: &t.sigma,
            rows: t.rows,
        },
        params,
        groups,
        credible_level,
        seed,
    )
}

/// Equally weighted posterior samples and what they were drawn under.
pub struct SampleSet<'a> {
    /// Samples (absolute values), `N × n`.
    pub samples: &'a [Vec<f64>],
    /// `ln p(y|φ_k)` of every sample.
    pub log_likelihood: &'a [f64],
    /// Noise standard deviation per group, as used.
    pub sigma: &'a [f64],
    /// Rows of the likelihood.
    pub rows: usize,
}

/// [`to_posterior`] of any equally weighted samples (TMCMC's, or a Markov chain's).
pub fn summarise(
    set: &SampleSet<'_>,
    params: &[UpdatingParameter],
    groups: Vec<String>,
    credible_level: f64,
    seed: u64,
) -> Posterior {
    let n = params.len();
    let t = set;
    let s = t.samples;
    let count = s.len().max(1) as f64;
    let mean: Vec<f64> = (0..n)
        .map(|i| s.iter().map(|x| x[i]).sum::<f64>() / count)
        .collect();
    let cov: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    s.iter()
                        .map(|x| (x[i] - mean[i]) * (x[j] - mean[j]))
                        .sum::<f64>()
                        / (count - 1.0).max(1.0)
                })
                .collect()
        })
        .collect();
    let sd: Vec<f64> = (0..n).map(|i| cov[i][i].sqrt()).collect();
    let correlation = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    if i == j {
                        1.0
                    } else {
                        cov[i][j] / (sd[i] * sd[j])
                    }
                })
                .collect()
        })
        .collect();
    let best = (0..s.len())
        .max_by(|&a, &b| t.log_likelihood[a].total_cmp(&t.log_likelihood[b]))
        .unwrap_or(0);
    let lo_q = 0.5 * (1.0 - credible_level);
    let marginals = params
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut v: Vec<f64> = s.iter().map(|x| x[i]).collect();
            v.sort_by(f64::total_cmp);
            Marginal {
                name: p.name.clone(),
                updated: s.get(best).map_or(f64::NAN, |x| x[i]),
                mean: mean[i],
                sd: sd[i],
                lower: quantile(&v, lo_q),
                upper: quantile(&v, 1.0 - lo_q),
            }
        })
        .collect();
    let cu = Mat::from_fn(n, n, |i, j| cov[i][j] / (mean[i] * mean[j]));
    let directions = match cu.self_adjoint_eigen(Side::Lower) {
        Ok(evd) => (0..n)
            .rev()
            .map(|k| {
                let mut v: Vec<f64> = (0..n).map(|i| evd.U()[(i, k)]).collect();
                let big = v
                    .iter()
                    .copied()
                    .fold(0.0, |a: f64, b| if b.abs() > a.abs() { b } else { a });
                if big < 0.0 {
                    v.iter_mut().for_each(|c| *c = -*c);
                }
                Direction {
                    sd: evd.S()[k].max(0.0).sqrt(),
                    vector: v,
                }
            })
            .collect(),
        Err(_) => Vec::new(),
    };
    let nll = -t.log_likelihood.get(best).copied().unwrap_or(f64::NAN);
    Posterior {
        marginals,
        covariance: cov,
        correlation,
        directions,
        sigma: t.sigma.to_vec(),
        groups,
        sigma_estimated: false,
        rows: t.rows,
        neg_log_likelihood: nll,
        refinement: Refinement {
            steps: 0,
            objective_start: f64::NAN,
            objective_mode: f64::NAN,
            converged: true,
        },
        credible_level,
        samples: s.to_vec(),
        predictive_samples: 0,
        natural_frequencies: Vec::new(),
        frf: Vec::new(),
        seed,
        warnings: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::updating::toy::Linear;

    /// One parameter, `y_i = θ + e_i`, prior `N(μ₀, s₀²)`: the evidence in closed form,
    /// `y ~ N(μ₀ 1, σ² I + s₀² 1 1ᵀ)`.
    fn scalar_problem(m: usize) -> (Linear, f64, f64, f64) {
        let y: Vec<f64> = (0..m)
            .map(|i| 1.0 + 0.1 * ((i * 7 % 5) as f64 - 2.0))
            .collect();
        let (mu0, s0, sigma) = (0.5, 0.4, 0.1);
        let lin = Linear {
            a: Mat::from_fn(m, 1, |_, _| 1.0),
            y,
            groups: vec![0; m],
        };
        (lin, mu0, s0, sigma)
    }

    fn scalar_evidence(y: &[f64], mu0: f64, s0: f64, sigma: f64) -> f64 {
        // det(σ²I + s₀²11ᵀ) = σ^{2m}(1 + m s₀²/σ²); its inverse by Sherman-Morrison.
        let m = y.len() as f64;
        let (s2, t2) = (sigma * sigma, s0 * s0);
        let r: Vec<f64> = y.iter().map(|v| v - mu0).collect();
        let rr: f64 = r.iter().map(|v| v * v).sum();
        let rs: f64 = r.iter().sum();
        let quad = rr / s2 - t2 / (s2 * (s2 + m * t2)) * rs * rs;
        let logdet = m * s2.ln() + (1.0 + m * t2 / s2).ln();
        -0.5 * (quad + logdet + m * LN_2PI)
    }

    #[test]
    fn exponent_bisection_meets_the_target_cov() {
        let l: Vec<f64> = (0..500)
            .map(|k| -0.5 * (k as f64 * 0.37).sin().powi(2) * 400.0)
            .collect();
        let b = next_exponent(&l, 0.0, 1.0);
        assert!(b > 0.0 && b < 1.0);
        assert!(
            (weight_cov(&l, b) - 1.0).abs() < 1e-9,
            "{}",
            weight_cov(&l, b)
        );
        // Flat enough: straight to 1.
        let flat: Vec<f64> = (0..100).map(|k| -1e-3 * k as f64).collect();
        assert_eq!(next_exponent(&flat, 0.3, 1.0), 1.0);
        // −∞ entries carry no weight and do not stop the search.
        let mut some = l.clone();
        some[3] = f64::NEG_INFINITY;
        let b2 = next_exponent(&some, 0.0, 1.0);
        assert!((weight_cov(&some, b2) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn log_sum_exp_is_stable() {
        assert!((log_sum_exp(&[1000.0, 1000.0]) - (1000.0 + 2f64.ln())).abs() < 1e-12);
        assert!((log_sum_exp(&[-1e4, f64::NEG_INFINITY]) + 1e4).abs() < 1e-9);
        assert_eq!(log_sum_exp(&[f64::NEG_INFINITY]), f64::NEG_INFINITY);
    }

    #[test]
    fn priors_integrate_to_one_and_sample_their_moments() {
        let priors = [
            ParamPrior::Uniform {
                lower: 1.0,
                upper: 3.0,
            },
            ParamPrior::Normal { mean: 2.0, sd: 0.5 },
            ParamPrior::LogNormal {
                median: 2.0,
                log_sd: 0.3,
            },
            ParamPrior::Bounded {
                mean: 2.0,
                sd: 1.0,
                lower: 1.5,
                upper: 4.0,
            },
        ];
        for p in &priors {
            p.check().unwrap();
            // Trapezoid over [-2, 8].
            let h = 1e-4;
            let mass: f64 = (0..100_000)
                .map(|k| (p.log_density(-2.0 + (k as f64 + 0.5) * h)).exp() * h)
                .sum();
            assert!((mass - 1.0).abs() < 1e-4, "{p:?}: {mass}");
            let mut rng = chain_rng(3, 0, 0);
            let draws: Vec<f64> = (0..40_000).map(|_| p.sample(&mut rng)).collect();
            let mean = draws.iter().sum::<f64>() / draws.len() as f64;
            let sd =
                (draws.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / draws.len() as f64).sqrt();
            let (m0, s0) = p.moments();
            assert!(
                (mean - m0).abs() < 4.0 * s0 / 200.0,
                "{p:?}: {mean} vs {m0}"
            );
            assert!((sd / s0 - 1.0).abs() < 0.03, "{p:?}: {sd} vs {s0}");
            assert!(draws.iter().all(|v| p.log_density(*v).is_finite()));
        }
        assert!(
            ParamPrior::Uniform {
                lower: 1.0,
                upper: 1.0
            }
            .check()
            .is_err()
        );
    }

    /// The evidence of the scalar linear-Gaussian problem against its closed form, and the
    /// posterior mean and sd against the conjugate ones.
    #[test]
    fn evidence_and_posterior_of_a_linear_gaussian_toy() {
        let (lin, mu0, s0, sigma) = scalar_problem(20);
        let settings = TmcmcSettings {
            samples: 2000,
            mh_steps: 3,
            seed: 7,
            ..Default::default()
        };
        let t = tmcmc(
            &lin,
            &[ParamPrior::Normal { mean: mu0, sd: s0 }],
            &Noise::Absolute(vec![sigma]),
            &settings,
        )
        .unwrap();
        let exact = scalar_evidence(&lin.y, mu0, s0, sigma);
        assert!(
            (t.log_evidence - exact).abs() < 0.15,
            "{} vs {exact}",
            t.log_evidence
        );
        let m = lin.y.len() as f64;
        let prec = 1.0 / (s0 * s0) + m / (sigma * sigma);
        let post_mean = (mu0 / (s0 * s0) + lin.y.iter().sum::<f64>() / (sigma * sigma)) / prec;
        let post_sd = prec.sqrt().recip();
        let p = to_posterior(
            &t,
            &[UpdatingParameter {
                name: "theta".into(),
                initial: mu0,
                lower: -10.0,
                upper: 10.0,
            }],
            vec!["all".into()],
            0.9,
            7,
        );
        let mg = &p.marginals[0];
        assert!((mg.mean - post_mean).abs() < 0.1 * post_sd, "{}", mg.mean);
        assert!(
            (mg.sd / post_sd - 1.0).abs() < 0.1,
            "{} vs {post_sd}",
            mg.sd
        );
        assert_eq!(t.stages.last().unwrap().exponent, 1.0);
        assert!(t.stages.len() > 2);
        assert!(t.stages.iter().all(|s| s.acceptance > 0.05));
    }

    #[test]
    fn estimated_noise_and_bad_settings_are_refused() {
        let (lin, ..) = scalar_problem(5);
        let prior = [ParamPrior::Normal { mean: 0.0, sd: 1.0 }];
        let e = tmcmc(&lin, &prior, &Noise::Estimated, &TmcmcSettings::default()).unwrap_err();
        assert!(e.to_string().contains("stated"), "{e}");
        let few = TmcmcSettings {
            samples: 1,
            ..Default::default()
        };
        assert!(tmcmc(&lin, &prior, &Noise::Absolute(vec![0.1]), &few).is_err());
        let bad = [ParamPrior::Normal {
            mean: 0.0,
            sd: -1.0,
        }];
        assert!(
            tmcmc(
                &lin,
                &bad,
                &Noise::Absolute(vec![0.1]),
                &TmcmcSettings::default()
            )
            .is_err()
        );
    }

    /// The same samples and evidence in a 1-thread and a 2-thread pool.
    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let (lin, mu0, s0, sigma) = scalar_problem(10);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    tmcmc(
                        &lin,
                        &[ParamPrior::Normal { mean: mu0, sd: s0 }],
                        &Noise::Absolute(vec![sigma]),
                        &TmcmcSettings {
                            samples: 300,
                            seed: 11,
                            ..Default::default()
                        },
                    )
                    .unwrap()
                })
        };
        let (a, b) = (run(1), run(2));
        assert_eq!(a, b);
        assert_eq!(a.log_evidence.to_bits(), b.log_evidence.to_bits());
    }
}
