//! The `posterior` output of `update`: the Laplace posterior of the updated parameters
//! (docs/theory.md §12), computed after every method with the settings under `posterior:`.

use crate::artefact::Artefact;
use crate::artefact::kinds::Kind;
use crate::artefact::kinds::posterior::{Mcmc, PosteriorKind, PosteriorRecord};
use crate::core::InputFault;
use crate::frf::FrfSet;
use crate::pipeline::{ParamIssue, StageError};
use crate::stages::params::{Count, OpenFraction, Positive};
use crate::updating::UpdatingParameter;
use crate::updating::mala::{MalaSettings, mala};
use crate::updating::posterior::Posterior;
use crate::updating::posterior::{
    Likelihood, NaturalFrequencies, Noise, PosteriorSettings, Prior, laplace, unknown,
};
use crate::updating::tmcmc::{ParamPrior, SampleSet, summarise};

/// The Laplace posterior computed after the update (docs/theory.md §12): a Gaussian at the
/// mode of an output-error likelihood on the quantities the method fits (complex FRFs; natural
/// frequencies for `eigensensitivity`), reached by a few Gauss-Newton steps from the update's
/// result.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PosteriorParams {
    /// The measurement noise: `estimated` (default: per FRF from the residuals at the mode,
    /// `σ² = rᵀr/(m − n)` scaled per FRF; pooled over the modes), `{sigma: 1e-6}` or
    /// `{sigma: [..]}` (standard deviation of each real and imaginary part, in the FRFs' units,
    /// one for all or one per FRF; for `eigensensitivity` the relative frequency error, one or
    /// one per mode), `{relative: 0.05}` (a fraction of the measured `|H|`, or of the
    /// frequency), `{snr_db: 40}` (per FRF as `noise.add`'s Gaussian model:
    /// `σ² = mean|H|²/10^(SNR/10)/2`).
    #[serde(default)]
    pub noise: NoiseParams,
    /// Probability of the central credible intervals.
    #[serde(default = "level")]
    pub credible_level: OpenFraction,
    /// Most Gauss-Newton steps from the update's result to the likelihood's mode.
    #[serde(default = "refine")]
    pub refine_iterations: usize,
    /// Parameter samples drawn from the Gaussian (seeded).
    #[serde(default = "samples")]
    pub samples: usize,
    /// How many of the samples are evaluated through the model for the sampled predictive
    /// bands (each one a modal or direct analysis).
    #[serde(default = "predictive")]
    pub predictive_samples: usize,
    /// Seed of the samples.
    #[serde(default)]
    pub seed: u64,
    /// A Gaussian prior on the parameters; omitted: flat.
    #[serde(default)]
    pub prior: Option<PriorParams>,
    /// Sample the posterior by the gradient-based sampler MALA (docs/theory.md §16), e.g.
    /// `mala: {samples: 500}`: Markov chains started from the Laplace Gaussian with its
    /// covariance as the metric, moved along the exact gradient of the log posterior; the
    /// statistics and samples are then the chains' (the predictive bands stay the Gaussian's),
    /// with the Laplace marginals drawn over their histograms and `R̂` and the effective sample
    /// size per parameter. The prior is the Gaussian one, or flat, within the parameters'
    /// bounds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mala: Option<MalaParams>,
}

/// Settings of the MALA chains.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MalaParams {
    /// Independent chains (at least 2: `R̂` compares them).
    #[serde(default = "chains")]
    pub chains: Count,
    /// Warm-up steps of every chain, in which its step adapts to an acceptance of 0.574.
    #[serde(default = "warmup")]
    pub warmup: Count,
    /// Samples kept per chain.
    #[serde(default = "chain_samples")]
    pub samples: Count,
}

fn chains() -> Count {
    Count::of_default(MalaSettings::default().chains)
}
fn warmup() -> Count {
    Count::of_default(MalaSettings::default().warmup)
}
fn chain_samples() -> Count {
    Count::of_default(MalaSettings::default().samples)
}

impl Default for PosteriorParams {
    fn default() -> Self {
        PosteriorParams {
            noise: NoiseParams::default(),
            credible_level: level(),
            refine_iterations: refine(),
            samples: samples(),
            predictive_samples: predictive(),
            seed: 0,
            prior: None,
            mala: None,
        }
    }
}

fn level() -> OpenFraction {
    OpenFraction::of_default(PosteriorSettings::default().credible_level)
}
fn refine() -> usize {
    PosteriorSettings::default().refine_iterations
}
fn samples() -> usize {
    PosteriorSettings::default().samples
}
fn predictive() -> usize {
    PosteriorSettings::default().predictive_samples
}

/// The noise model of the likelihood.
#[derive(Clone, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum NoiseParams {
    /// Estimated from the residuals at the mode.
    #[default]
    Estimated,
    /// Standard deviations: one for all, or one per FRF (per mode).
    Sigma(OneOrMany),
    /// A fraction of the measured `|H|` (of the measured frequency).
    Relative(Positive),
    /// Per FRF from a signal-to-noise ratio in dB, as `noise.add`'s Gaussian noise.
    SnrDb(f64),
}

/// One number or a list.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum OneOrMany {
    /// One value for all.
    One(Positive),
    /// One per group.
    Many(Vec<Positive>),
}

/// A Gaussian prior: standard deviations absolute (`sd`, one per parameter) or relative to
/// the means (`relative_sd`); means given or the initial values.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PriorParams {
    /// Prior means in SI, one per updated parameter (default: the initial values).
    #[serde(default)]
    pub mean: Vec<f64>,
    /// Prior standard deviations in SI, one per updated parameter.
    #[serde(default)]
    pub sd: Vec<Positive>,
    /// Prior standard deviation as a fraction of each mean, e.g. 0.3.
    #[serde(default)]
    pub relative_sd: Option<Positive>,
}

impl PosteriorParams {
    /// Problems the types cannot state.
    pub(super) fn issues(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if let Some(p) = &self.prior
            && p.sd.is_empty() == p.relative_sd.is_none()
        {
            issues.push(ParamIssue::at(
                "posterior.prior",
                "give exactly one of `sd` (one per parameter) and `relative_sd`",
            ));
        }
        if let Some(m) = &self.mala
            && m.chains.get() < 2
        {
            issues.push(ParamIssue::at(
                "posterior.mala.chains",
                "give at least 2 chains: R-hat compares them",
            ));
        }
        if let Some(m) = &self.mala
            && m.samples.get() < 4
        {
            issues.push(ParamIssue::at(
                "posterior.mala.samples",
                "give at least 4 samples per chain (hundreds for useful statistics)",
            ));
        }
        if let NoiseParams::SnrDb(s) = self.noise
            && !s.is_finite()
        {
            issues.push(ParamIssue::at(
                "posterior.noise.snr_db",
                "give a finite SNR in dB",
            ));
        }
        issues
    }

    /// The numerics' settings for `params` (initial values as prior means by default);
    /// `measured` turns an SNR into per-FRF levels.
    fn settings(
        &self,
        params: &[UpdatingParameter],
        measured: Option<&FrfSet>,
    ) -> Result<PosteriorSettings, StageError> {
        let n = params.len();
        let noise = match &self.noise {
            NoiseParams::Estimated => Noise::Estimated,
            NoiseParams::Sigma(OneOrMany::One(s)) => Noise::Absolute(vec![s.get()]),
            NoiseParams::Sigma(OneOrMany::Many(s)) => {
                Noise::Absolute(s.iter().map(|v| v.get()).collect())
            }
            NoiseParams::Relative(c) => Noise::Relative(c.get()),
            NoiseParams::SnrDb(snr) => {
                let Some(m) = measured else {
                    return Err(StageError::input(
                        "posterior.noise",
                        "`snr_db` describes FRF noise: give `sigma` (relative frequency errors) or `relative` for measured modes",
                    ));
                };
                Noise::Absolute(snr_sigmas(m, *snr))
            }
        };
        let prior = match &self.prior {
            None => None,
            Some(p) => {
                let mean = if p.mean.is_empty() {
                    params.iter().map(|q| q.initial).collect()
                } else {
                    p.mean.clone()
                };
                if mean.len() != n {
                    return Err(StageError::input(
                        "posterior.prior.mean",
                        format!("{} means for {n} updated parameters", mean.len()),
                    ));
                }
                let sd: Vec<f64> = match p.relative_sd {
                    Some(r) => mean.iter().map(|m| r.get() * m.abs()).collect(),
                    None => p.sd.iter().map(|s| s.get()).collect(),
                };
                if sd.len() != n || sd.iter().any(|s| !(*s > 0.0)) {
                    return Err(StageError::input(
                        "posterior.prior.sd",
                        format!("give {n} positive standard deviations (got {})", sd.len()),
                    ));
                }
                Some(Prior { mean, sd })
            }
        };
        Ok(PosteriorSettings {
            noise,
            prior,
            credible_level: self.credible_level.get(),
            refine_iterations: self.refine_iterations,
            samples: self.samples,
            predictive_samples: self.predictive_samples.min(self.samples),
            seed: self.seed,
        })
    }

    /// The name of the noise model in the artefact.
    fn noise_name(&self) -> &'static str {
        match self.noise {
            NoiseParams::Estimated => "estimated",
            NoiseParams::Sigma(_) => "sigma",
            NoiseParams::Relative(_) => "relative",
            NoiseParams::SnrDb(_) => "snr_db",
        }
    }

    /// The posterior artefact of `lik` at the update's `final_values`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn artefact(
        &self,
        lik: &dyn Likelihood,
        params: &[UpdatingParameter],
        final_values: &[f64],
        measured: Option<&FrfSet>,
        natural: Option<&NaturalFrequencies<'_>>,
        method: &str,
        likelihood: &str,
    ) -> Result<Artefact, StageError> {
        let settings = self.settings(params, measured)?;
        let mut mcmc = None;
        let posterior = match laplace(lik, params, final_values, &settings, natural) {
            Ok(p) => match &self.mala {
                None => p,
                // An unknown Laplace posterior (its noise unknown) gives MALA nothing to
                // start from: it stays unknown, with the warning that says why.
                Some(_) if p.sigma.iter().any(|s| s.is_nan()) => p,
                Some(m) => {
                    let (sampled, chains) = self.sampled(lik, params, &settings, p, m)?;
                    mcmc = chains;
                    sampled
                }
            },
            Err(e) if e.is_input() => return Err(StageError::from_numerics("posterior")(e)),
            // The update stands; its posterior is reported as unknown rather than failing it.
            Err(e) => {
                let mut u = unknown(lik, params, final_values, &settings);
                u.warnings.push(format!(
                    "the posterior could not be computed ({e}); it is reported as unknown (NaN)"
                ));
                u
            }
        };
        for m in &posterior.marginals {
            tracing::info!(
                "posterior {}: {:.6e} ± {:.3e} ({}% credible [{:.6e}, {:.6e}])",
                m.name,
                m.mean,
                m.sd,
                100.0 * settings.credible_level,
                m.lower,
                m.upper
            );
        }
        // The figures: the Gaussian's samples with its marginals drawn over them.
        let names = posterior.marginals.iter().map(|m| m.name.clone()).collect();
        let gaussian = posterior.marginals.iter().map(|m| (m.mean, m.sd)).collect();
        let gaussian = match &mcmc {
            Some((_, laplace)) => laplace.clone(),
            None => gaussian,
        };
        let samples = posterior.samples.clone();
        let band = measured.and_then(|m| band_figure(&posterior.frf, m));
        let a = PosteriorKind::to_artefact(&PosteriorRecord {
            method: method.into(),
            likelihood: likelihood.into(),
            noise: self.noise_name().into(),
            posterior,
            sampling: None,
            mcmc: mcmc.as_ref().map(|(m, _)| m.clone()),
        });
        let title = match mcmc {
            Some(_) => "MALA posterior (Laplace marginals drawn over)",
            None => "Laplace posterior",
        };
        let mut a = crate::stages::bayes_tmcmc::with_figures(
            a,
            title,
            names,
            &samples,
            None,
            Some(gaussian),
        );
        if let Some(f) = band {
            a.blobs.insert("frf_band.png".into(), f.png);
            a.blobs.insert("frf_band.svg".into(), f.svg.into_bytes());
        }
        Ok(a)
    }
}

impl PosteriorParams {
    /// The Laplace posterior `laplace` replaced by MALA's samples and statistics (its bands,
    /// noise and refinement kept), with the chains and the Laplace marginals `(mean, sd)`;
    /// unchanged, with a warning, when the Laplace covariance cannot be the metric.
    #[allow(clippy::type_complexity)]
    fn sampled(
        &self,
        lik: &dyn Likelihood,
        params: &[UpdatingParameter],
        settings: &PosteriorSettings,
        laplace: Posterior,
        m: &MalaParams,
    ) -> Result<(Posterior, Option<(Mcmc, Vec<(f64, f64)>)>), StageError> {
        // The bounds, an unbounded side cut 1000 Laplace sds from the mode (where the flat
        // prior's density no longer matters: the chains never get there).
        let priors: Vec<ParamPrior> = params
            .iter()
            .zip(&laplace.marginals)
            .enumerate()
            .map(|(j, (q, l))| {
                let lower = q.lower.max(l.mean - 1e3 * l.sd);
                let upper = q.upper.min(l.mean + 1e3 * l.sd);
                match &settings.prior {
                    None => ParamPrior::Uniform { lower, upper },
                    Some(p) => ParamPrior::Bounded {
                        mean: p.mean[j],
                        sd: p.sd[j],
                        lower,
                        upper,
                    },
                }
            })
            .collect();
        // The noise as the Laplace posterior used it (estimated there, or as stated).
        let noise = match &settings.noise {
            Noise::Estimated => Noise::Absolute(laplace.sigma.clone()),
            n => n.clone(),
        };
        let mode: Vec<f64> = laplace.marginals.iter().map(|q| q.mean).collect();
        let mala_settings = MalaSettings {
            chains: m.chains.get(),
            warmup: m.warmup.get(),
            samples: m.samples.get(),
            seed: settings.seed,
            ..Default::default()
        };
        let run = mala(
            lik,
            &priors,
            &noise,
            &mode,
            &laplace.covariance,
            &mala_settings,
        );
        let r = match run {
            Ok(r) => r,
            Err(e) if matches!(e, crate::updating::UpdatingError::Settings(_)) => {
                let mut laplace = laplace;
                laplace.warnings.push(format!(
                    "posterior.mala: {e}; the Laplace posterior is reported"
                ));
                return Ok((laplace, None));
            }
            Err(e) => return Err(StageError::from_numerics("posterior.mala")(e)),
        };
        for (c, ch) in r.chains.iter().enumerate() {
            tracing::info!(
                "MALA chain {c}: step {:.3e}, acceptance {:.3}, {} proposals failed",
                ch.step,
                ch.acceptance,
                ch.failed
            );
        }
        let mut warnings = laplace.warnings;
        for (q, (rh, ess)) in params.iter().zip(r.r_hat.iter().zip(&r.ess)) {
            tracing::info!("MALA {}: R-hat {rh:.4}, effective samples {ess:.0}", q.name);
            if *rh > 1.05 || *ess < 100.0 {
                warnings.push(format!(
                    "MALA {}: R-hat {rh:.3}, {ess:.0} effective samples — the chains have not mixed well; raise `posterior.mala.warmup` or `samples`",
                    q.name
                ));
            }
        }
        let mut p = summarise(
            &SampleSet {
                samples: &r.samples,
                log_likelihood: &r.log_likelihood,
                sigma: &laplace.sigma,
                rows: r.rows,
            },
            params,
            laplace.groups.clone(),
            settings.credible_level,
            settings.seed,
        );
        for (s, l) in p.marginals.iter_mut().zip(&laplace.marginals) {
            s.updated = l.updated;
        }
        let gaussian = laplace.marginals.iter().map(|q| (q.mean, q.sd)).collect();
        p.sigma_estimated = laplace.sigma_estimated;
        p.neg_log_likelihood = laplace.neg_log_likelihood;
        p.refinement = laplace.refinement;
        p.predictive_samples = laplace.predictive_samples;
        p.natural_frequencies = laplace.natural_frequencies;
        p.frf = laplace.frf;
        p.warnings = warnings;
        let mcmc = Mcmc {
            sampler: "mala".into(),
            chains: r.chains,
            r_hat: r.r_hat,
            ess: r.ess,
        };
        Ok((p, Some((mcmc, gaussian))))
    }
}

/// The FRF overlay of the predictive bands `bands` (`|H| ± 2 sd`, the sampled sd where there
/// is one, else the first-order one) with the measured `|H|` at the same lines; `None` without
/// bands or where they make no figure (a band at one line: an update at single lines), and
/// with a warning when the drawing fails.
fn band_figure(
    bands: &[crate::updating::posterior::Band],
    measured: &FrfSet,
) -> Option<crate::report::figure::Figure> {
    use crate::report::band_plot::{BandPanel, BandPlot, band_plot};
    if bands.is_empty() {
        return None;
    }
    // A band over fewer than two lines (an update at single lines) is not a figure.
    let pair_of: std::collections::HashMap<String, usize> = measured
        .pairs
        .iter()
        .enumerate()
        .map(|(q, p)| (format!("{}/{}", p.response, p.excitation), q))
        .collect();
    let line_of: std::collections::HashMap<u64, usize> = measured
        .freqs_hz
        .iter()
        .enumerate()
        .map(|(k, f)| (f.to_bits(), k))
        .collect();
    let mut panels: Vec<BandPanel> = Vec::new();
    for b in bands {
        let at = match panels.iter().position(|p| p.label == b.label) {
            Some(i) => i,
            None => {
                panels.push(BandPanel {
                    label: b.label.clone(),
                    freqs_hz: Vec::new(),
                    value: Vec::new(),
                    sd: Vec::new(),
                    measured: Vec::new(),
                });
                panels.len() - 1
            }
        };
        let p = &mut panels[at];
        let x = match (pair_of.get(&b.label), line_of.get(&b.freq_hz.to_bits())) {
            (Some(&q), Some(&k)) => measured.values[(k, q)].norm(),
            _ => f64::NAN,
        };
        p.freqs_hz.push(b.freq_hz);
        p.value.push(b.value);
        p.sd.push(if b.sd_sampled.is_finite() {
            b.sd_sampled
        } else {
            b.sd_linear
        });
        p.measured.push(x);
    }
    let plot = BandPlot {
        title: "Predicted |H| at the mode (line), its ± 2 sd band (shaded), the measurement (dots)"
            .into(),
        panels,
        unit: measured.quantity.unit().into(),
    };
    match band_plot(&plot) {
        Ok(f) => Some(f),
        // E.g. an update at single lines: a band over one line is no figure.
        Err(e @ crate::report::figure::PlotError::Input(_)) => {
            tracing::debug!("no figure `frf_band`: {e}");
            None
        }
        Err(e) => {
            tracing::warn!("the figure `frf_band` was not drawn: {e}");
            None
        }
    }
}

/// Per FRF, the `σ` of each real and imaginary part of `noise.add`'s Gaussian noise at `snr_db`:
/// `σ² = mean_k |H_k|² / 10^(SNR/10) / 2` over the measured lines.
pub fn snr_sigmas(measured: &FrfSet, snr_db: f64) -> Vec<f64> {
    let lines = measured.freqs_hz.len().max(1) as f64;
    (0..measured.pairs.len())
        .map(|q| {
            let power = (0..measured.freqs_hz.len())
                .map(|k| measured.values[(k, q)].norm_sqr())
                .sum::<f64>()
                / lines;
            (power / 10f64.powf(snr_db / 10.0) / 2.0).sqrt()
        })
        .collect()
}
