//! `bayes.tmcmc`: samples the posterior of a model's parameters by transitional MCMC and
//! reports the model evidence (docs/theory.md §15). The likelihood is the update's output
//! error (§12): the complex FRFs at the measured lines (modal summation, `frf_modal`, or the
//! direct solution, `frf_direct`; `band_hz`/`exclude_hz` select the lines), the FRFs up to the
//! scale or phase the correlation coefficients are blind to (`chi_s`, `chi_a`), the measured
//! natural frequencies (`natural_frequencies`, paired with the model's elastic modes in order),
//! or frequencies and mode shapes (`modes`, MAC-paired at every sample), under a stated noise;
//! with `map` (test.pair's) the measured DOFs are read through the test map, as `update` reads
//! them. Writes a `posterior` artefact (sample statistics, the samples, the evidence and the
//! stages) with the marginal and pair figures.

use crate::artefact::kinds::Kind;
use crate::artefact::kinds::posterior::{PosteriorKind, PosteriorRecord, Sampling};
use crate::artefact::kinds::tmcmc_population::{ChainBatch, PopulationRecord, TmcmcPopulationKind};
use crate::artefact::{Artefact, ArtefactKind};
use crate::core::DofId;
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::frf::ModalDamping;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::report::posterior_plot::{PosteriorPlot, marginal_plot, pair_plot};
use crate::stages::params::{Band, Count, Damping, Modes, OpenFraction, Positive};
use crate::stages::update::{
    NoiseParams, OneOrMany, Reduction, build_model, elastic_measured_modes, measured_frf,
    measured_modes, snr_sigmas,
};
use crate::updating::UpdatingError;
use crate::updating::posterior::{
    Coefficient, CorrelationLikelihood, DirectFrfLikelihood, Likelihood, ModalDataLikelihood,
    ModalFrfLikelihood, Noise, likelihood_lines,
};
use crate::updating::tmcmc::{
    Chains, ParamPrior, Population, PopulationStore, TmcmcSettings, tmcmc_stored, to_posterior,
};
use indexmap::IndexMap;

/// The stage.
pub struct BayesTmcmc;

/// The likelihood: which measured quantities, predicted how.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    serde::Deserialize,
    serde::Serialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum LikelihoodChoice {
    /// Complex FRFs by modal summation with the modal `damping` (the P-C's predictions).
    #[default]
    FrfModal,
    /// Complex FRFs by the direct solution with a uniform structural `damping` (the RFM's).
    FrfDirect,
    /// Measured natural frequencies (input `measured_modes`), relative errors.
    NaturalFrequencies,
    /// Measured natural frequencies and mode shapes at `measured_dofs` (input
    /// `measured_modes`), each measured mode paired by MAC with a model mode at every sample;
    /// shape rows are the measured shape scaled to unit length against the model's scaled by
    /// the modal scale factor (noise `shape_noise`).
    Modes,
    /// The shape correlation `χ_s` (4.8): the FRFs by modal summation up to a complex scale
    /// fitted at every line, so the squared residual of a line is `|x|² (1 − χ_s)` (data whose
    /// force calibration is not trusted; two FRFs at least).
    ChiS,
    /// The amplitude correlation `χ_a` (4.9): the FRFs by modal summation up to a phase fitted
    /// at every line, so the squared residual of a line is `(|x|² + |a|²)(1 − χ_a)`.
    ChiA,
}

impl LikelihoodChoice {
    fn name(self) -> &'static str {
        match self {
            LikelihoodChoice::FrfModal => "frf_modal",
            LikelihoodChoice::FrfDirect => "frf_direct",
            LikelihoodChoice::NaturalFrequencies => "natural_frequencies",
            LikelihoodChoice::Modes => "modes",
            LikelihoodChoice::ChiS => "chi_s",
            LikelihoodChoice::ChiA => "chi_a",
        }
    }

    /// Whether it reads measured modes (else measured FRFs).
    fn on_modes(self) -> bool {
        matches!(
            self,
            LikelihoodChoice::NaturalFrequencies | LikelihoodChoice::Modes
        )
    }
}

/// The prior of one parameter, on its absolute value in SI.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum PriorSpec {
    /// Uniform on `[lower, upper]`.
    Uniform([f64; 2]),
    /// Normal.
    Normal {
        /// Mean.
        mean: f64,
        /// Standard deviation.
        sd: f64,
    },
    /// Lognormal: `ln φ ~ N(ln median, log_sd²)`.
    Lognormal {
        /// Median.
        median: f64,
        /// Standard deviation of `ln φ` (≈ the relative spread when small).
        log_sd: f64,
    },
    /// A normal truncated to `[lower, upper]`.
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

impl PriorSpec {
    fn prior(&self) -> ParamPrior {
        match *self {
            PriorSpec::Uniform([lower, upper]) => ParamPrior::Uniform { lower, upper },
            PriorSpec::Normal { mean, sd } => ParamPrior::Normal { mean, sd },
            PriorSpec::Lognormal { median, log_sd } => ParamPrior::LogNormal { median, log_sd },
            PriorSpec::Bounded {
                mean,
                sd,
                lower,
                upper,
            } => ParamPrior::Bounded {
                mean,
                sd,
                lower,
                upper,
            },
        }
    }
}

/// Parameters of `bayes.tmcmc`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// The likelihood: `frf_modal` (default), `frf_direct`, `chi_s` or `chi_a` (FRFs up to a
    /// scale or phase per line), `natural_frequencies`, or `modes` (frequencies and MAC-paired
    /// shapes).
    #[serde(default)]
    pub likelihood: LikelihoodChoice,
    /// The prior of every sampled parameter by name, e.g. `m2: {uniform: [0.5, 2.0]}`,
    /// `k: {normal: {mean: 1e4, sd: 1e3}}`, `{lognormal: {median: 1e4, log_sd: 0.2}}`,
    /// `{bounded: {mean, sd, lower, upper}}`; the model's other parameters stay at their
    /// values.
    pub priors: IndexMap<String, PriorSpec>,
    /// Known true values by name (simulated data): marked on the figures.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub truth: IndexMap<String, f64>,
    /// The measurement noise, stated: `{sigma: 1e-6}` or one per FRF (per mode), `{relative:
    /// 0.05}`, `{snr_db: 30}` (FRF likelihoods; as in `update`'s posterior); `estimated` is refused: the evidence needs a
    /// proper noise model. For `modes` it is the frequencies' (relative errors).
    pub noise: NoiseParams,
    /// With `likelihood: modes`: the standard deviation of every component of a measured shape
    /// scaled to unit length (default: the frequencies' noise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape_noise: Option<Positive>,
    /// With `likelihood: modes`: the DOFs of the measured shapes used, e.g. `["12:uz"]`
    /// (default: every DOF of `measured_modes`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub measured_dofs: Vec<DofId>,
    /// Samples per stage.
    #[serde(default = "samples")]
    pub samples: Count,
    /// Seed of every chain's stream.
    #[serde(default)]
    pub seed: u64,
    /// Target coefficient of variation of the plausibility weights (15.3).
    #[serde(default = "target_cov")]
    pub target_cov: Positive,
    /// `β²`, the scale of the proposal covariance (15.5).
    #[serde(default = "proposal_scale")]
    pub proposal_scale: Positive,
    /// Metropolis-Hastings steps of every chain per stage.
    #[serde(default = "one")]
    pub mh_steps: Count,
    /// Most stages.
    #[serde(default = "max_stages")]
    pub max_stages: Count,
    /// Probability of the central credible intervals.
    #[serde(default = "level")]
    pub credible_level: OpenFraction,
    /// Mass matrix of a mesh model.
    #[serde(default)]
    pub mass: MassKind,
    /// Damping of the predictions (`frf_modal`: modal `structural` or `viscous`; `frf_direct`:
    /// a uniform `structural` loss factor).
    #[serde(default)]
    pub damping: Damping,
    /// The modal basis (default: every mode up to twice the highest measured line; for
    /// natural frequencies, three times as many modes as measured plus six).
    #[serde(default)]
    pub modes: Modes,
    /// With `partition` connected: the component mode synthesis the mesh is analysed by.
    #[serde(default)]
    pub reduction: Reduction,
    /// Only measured lines in `[lo, hi]` Hz are used (default: all).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band_hz: Option<Band>,
    /// Measured lines inside any of these bands are left out.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exclude_hz: Vec<Band>,
    /// Processes that share every stage's chains through the cache: each stage's chains are
    /// split into this many batches, each kept in the cache as it is done, so that runs of the
    /// same pipeline with `worker: 0 … workers − 1` (e.g. the points of a sweep over `worker`,
    /// local or a Slurm job array, on one cache) compute a stage together; every one of them
    /// writes the posterior one process alone writes.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub workers: Count,
    /// This process's batch (0-based, below `workers`): the one it computes first.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub worker: u64,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

fn is_one(c: &Count) -> bool {
    c.get() == 1
}

fn samples() -> Count {
    Count::of_default(TmcmcSettings::default().samples)
}
fn target_cov() -> Positive {
    Positive::of_default(TmcmcSettings::default().target_cov)
}
fn proposal_scale() -> Positive {
    Positive::of_default(TmcmcSettings::default().proposal_scale)
}
fn one() -> Count {
    Count::of_default(1)
}
fn max_stages() -> Count {
    Count::of_default(TmcmcSettings::default().max_stages)
}
fn level() -> OpenFraction {
    OpenFraction::of_default(0.9)
}

impl TypedStage for BayesTmcmc {
    type Params = Params;
    const KIND: &'static str = "bayes.tmcmc";
    const SUMMARY: &'static str =
        "Posterior samples of model parameters and the model evidence by transitional MCMC";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::optional(
                "mesh",
                ArtefactKind::Mesh,
                "a finite-element model with declared parameters",
            ),
            PortSpec::optional(
                "model",
                ArtefactKind::Matrices,
                "matrices with linear parameters (model.lumped)",
            ),
            PortSpec::optional("measured", ArtefactKind::Frf, "measured FRFs (frf_*)"),
            PortSpec::optional(
                "measured_modes",
                ArtefactKind::Modes,
                "measured modes (natural_frequencies)",
            ),
            PortSpec::optional(
                "partition",
                ArtefactKind::Partition,
                "substructures: analyse the mesh through `reduction`",
            ),
            PortSpec::optional(
                "map",
                ArtefactKind::TestMap,
                "test.pair's map: every measured DOF is its weighted sum of model DOFs (14.7)",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "posterior",
            ArtefactKind::Posterior,
            "sample statistics, samples, log evidence, tempering stages, marginal and pair figures",
        )]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if p.priors.is_empty() {
            issues.push(ParamIssue::at(
                "priors",
                "give the prior of at least one parameter, e.g. `m2: {uniform: [0.5, 2.0]}`",
            ));
        }
        for (name, spec) in &p.priors {
            if let Err(e) = spec.prior().check() {
                issues.push(ParamIssue::at(&format!("priors.{name}"), e));
            }
        }
        if let Some(name) = p.truth.keys().find(|k| !p.priors.contains_key(*k)) {
            issues.push(ParamIssue::at(
                &format!("truth.{name}"),
                "a truth is marked only for a sampled parameter: give it a prior or drop it",
            ));
        }
        match &p.noise {
            NoiseParams::Estimated => issues.push(ParamIssue::at(
                "noise",
                "TMCMC needs the noise stated (`sigma`, `relative` or `snr_db`): an estimated noise has no proper prior, and the evidence would be undefined",
            )),
            NoiseParams::SnrDb(s) if !s.is_finite() => {
                issues.push(ParamIssue::at("noise.snr_db", "give a finite SNR in dB"))
            }
            NoiseParams::SnrDb(_) if p.likelihood.on_modes() => issues.push(ParamIssue::at(
                "noise",
                "`snr_db` describes FRF noise: give `sigma` (relative frequency errors) or `relative`",
            )),
            _ => {}
        }
        if p.worker >= p.workers.get() as u64 {
            issues.push(ParamIssue::at(
                "worker",
                format!(
                    "worker {} of {}: give 0 … {} (one per process that shares the stages)",
                    p.worker,
                    p.workers.get(),
                    p.workers.get() - 1
                ),
            ));
        }
        if p.samples.get() < 2 {
            issues.push(ParamIssue::at(
                "samples",
                "give at least 2 samples per stage (hundreds for a useful posterior)",
            ));
        }
        issues.extend(p.modes.issues("modes"));
        if p.likelihood != LikelihoodChoice::Modes {
            if p.shape_noise.is_some() {
                issues.push(ParamIssue::at(
                    "shape_noise",
                    "a shape noise is for `likelihood: modes`: drop it or choose that likelihood",
                ));
            }
            if !p.measured_dofs.is_empty() {
                issues.push(ParamIssue::at(
                    "measured_dofs",
                    "measured shape DOFs are for `likelihood: modes`: drop them or choose that likelihood",
                ));
            }
        }
        let modal = matches!(
            p.likelihood,
            LikelihoodChoice::FrfModal | LikelihoodChoice::ChiS | LikelihoodChoice::ChiA
        );
        if modal && matches!(p.damping, Damping::Rayleigh { .. }) {
            issues.push(ParamIssue::at(
                "damping",
                "frf_modal, chi_s and chi_a predict by modal summation: give `structural` or `viscous` modal damping",
            ));
        }
        if p.likelihood == LikelihoodChoice::FrfDirect
            && !matches!(p.damping, Damping::None | Damping::Structural(_))
        {
            issues.push(ParamIssue::at(
                "damping",
                "frf_direct takes a uniform `structural` loss factor",
            ));
        }
        if p.damping.is_per_mode() {
            issues.push(ParamIssue::at(
                "damping",
                "give one uniform damping value (per-mode damping needs a fixed modal basis)",
            ));
        }
        if ctx.connected.is_empty() {
            return issues;
        }
        if ctx.is_connected("mesh") == ctx.is_connected("model") {
            issues.push(ParamIssue::at(
                "",
                "connect exactly one of the inputs `mesh` (a finite-element model) and `model` (matrices from model.lumped)",
            ));
        }
        let port = if p.likelihood.on_modes() {
            "measured_modes"
        } else {
            "measured"
        };
        if !ctx.is_connected(port) {
            issues.push(ParamIssue::at(
                "likelihood",
                format!(
                    "the likelihood {} needs the input `{port}`",
                    p.likelihood.name()
                ),
            ));
        }
        if ctx.is_connected("partition") && !ctx.is_connected("mesh") {
            issues.push(ParamIssue::at(
                "reduction",
                "a partition reduces a mesh: connect `mesh` (not `model`) with it",
            ));
        }
        if ctx.is_connected("map") && !ctx.is_connected("mesh") {
            issues.push(ParamIssue::at(
                "",
                "a test map names grids of a mesh: connect `mesh` (not `model`) with `map`",
            ));
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let names: Vec<String> = p.priors.keys().cloned().collect();
        let model = build_model(
            inputs,
            Some(&names),
            p.mass,
            &p.reduction,
            p.modes.is_given(),
        )?;
        let model = model.as_ref();
        let params = model.parameters();
        // The sampled parameters in the model's order, each with its prior.
        let priors: Vec<ParamPrior> = params
            .iter()
            .map(|q| {
                p.priors.get(&q.name).map(PriorSpec::prior).ok_or_else(|| {
                    StageError::input(
                        "priors",
                        format!("the model's parameter `{}` has no prior", q.name),
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        let settings = TmcmcSettings {
            samples: p.samples.get(),
            target_cov: p.target_cov.get(),
            proposal_scale: p.proposal_scale.get(),
            mh_steps: p.mh_steps.get(),
            max_stages: p.max_stages.get(),
            seed: p.seed,
        };
        let initial = model.initial_values();
        let measured = match p.likelihood.on_modes() {
            true => None,
            false => Some(measured_frf(inputs, p.band_hz, &p.exclude_hz)?),
        };
        let noise = noise(&p.noise, measured.as_ref())?;
        let store = CachedPopulations {
            inputs,
            key: populations_key(p, inputs),
            parameters: params.iter().map(|q| q.name.clone()).collect(),
            sharing: (p.workers.get(), p.worker as usize),
        };
        let run = |lik: &dyn Likelihood, noise: &Noise| {
            tmcmc_stored(lik, &priors, noise, &settings, &store)
                .map_err(StageError::from_numerics(""))
                .map(|t| (t, lik.group_names()))
        };
        let (t, groups) = match (p.likelihood, &measured) {
            (LikelihoodChoice::FrfModal, Some(measured)) => {
                let (modes, damping, lines) = modal_prediction(p, model, measured, &initial)?;
                run(
                    &ModalFrfLikelihood::new(model, measured, lines, modes, damping),
                    &noise,
                )?
            }
            (LikelihoodChoice::FrfDirect, Some(measured)) => {
                let lines = (0..measured.freqs_hz.len()).collect();
                let eta = p.damping.direct().structural_eta;
                run(
                    &DirectFrfLikelihood::new(model, measured, lines, eta),
                    &noise,
                )?
            }
            (LikelihoodChoice::ChiS | LikelihoodChoice::ChiA, Some(measured)) => {
                if p.likelihood == LikelihoodChoice::ChiS && measured.pairs.len() < 2 {
                    return Err(StageError::input(
                        "likelihood",
                        "chi_s fits a scale at every line: with one measured FRF nothing is left to learn; use chi_a or frf_modal",
                    ));
                }
                let coefficient = match p.likelihood {
                    LikelihoodChoice::ChiS => Coefficient::Shape,
                    _ => Coefficient::Amplitude,
                };
                let (modes, damping, lines) = modal_prediction(p, model, measured, &initial)?;
                run(
                    &CorrelationLikelihood::new(
                        model,
                        measured,
                        lines,
                        modes,
                        damping,
                        coefficient,
                    ),
                    &noise,
                )?
            }
            _ => {
                let shapes = p.likelihood == LikelihoodChoice::Modes;
                let dofs = match (shapes, p.measured_dofs.is_empty()) {
                    (false, _) => Vec::new(),
                    (true, true) => measured_modes(inputs)?.dofs,
                    (true, false) => p.measured_dofs.clone(),
                };
                let m = elastic_measured_modes(inputs, None, &dofs)?;
                let fx: Vec<f64> = m
                    .eigenvalues
                    .iter()
                    .map(|l| l.sqrt() / (2.0 * std::f64::consts::PI))
                    .collect();
                let selection = p.modes.selection_or(ModeSelection::Count(3 * fx.len() + 6));
                let (state, _) = model
                    .modal_state(&initial, selection)
                    .map_err(StageError::from_numerics(""))?;
                let elastic: Vec<usize> = (0..state.modes.len())
                    .filter(|&r| state.modes.eigenvalues[r] > 0.0)
                    .collect();
                if elastic.len() < fx.len() {
                    return Err(StageError::input(
                        "modes",
                        format!(
                            "{} measured elastic modes but {} in the model's basis: widen `modes`",
                            fx.len(),
                            elastic.len()
                        ),
                    ));
                }
                let pairs = fx.iter().copied().zip(elastic.iter().copied()).collect();
                let lik = ModalDataLikelihood::new(model, selection, pairs);
                match m.shapes {
                    None => run(&lik, &noise)?,
                    Some((dofs, x)) => {
                        let noise = match p.shape_noise {
                            Some(s) => with_shape_noise(noise.clone(), fx.len(), s.get())?,
                            None => noise.clone(),
                        };
                        let lik = lik
                            .with_shapes(dofs, x.as_ref())
                            .map_err(StageError::from_numerics("measured_modes"))?;
                        run(&lik, &noise)?
                    }
                }
            }
        };
        tracing::info!(
            "TMCMC: {} stages, ln evidence {:.4}, {} failed evaluations",
            t.stages.len(),
            t.log_evidence,
            t.failed
        );
        let posterior = to_posterior(&t, params, groups, p.credible_level.get(), p.seed);
        for m in &posterior.marginals {
            tracing::info!(
                "posterior {}: {:.6e} ± {:.3e} ({}% credible [{:.6e}, {:.6e}])",
                m.name,
                m.mean,
                m.sd,
                100.0 * p.credible_level.get(),
                m.lower,
                m.upper
            );
        }
        let truth = (!p.truth.is_empty()).then(|| {
            params
                .iter()
                .map(|q| p.truth.get(&q.name).copied().unwrap_or(f64::NAN))
                .collect()
        });
        let names: Vec<String> = params.iter().map(|q| q.name.clone()).collect();
        let a = PosteriorKind::to_artefact(&PosteriorRecord {
            method: "tmcmc".into(),
            likelihood: p.likelihood.name().into(),
            noise: noise_name(&p.noise).into(),
            sampling: Some(Sampling {
                log_evidence: t.log_evidence,
                stages: t.stages.clone(),
            }),
            mcmc: None,
            posterior: posterior.clone(),
        });
        let a = with_figures(a, "TMCMC posterior", names, &posterior.samples, truth, None);
        Ok(StageOutputs::from([("posterior".to_string(), a)]))
    }
}

/// The part kind and version of a stored population ([`CachedPopulations`]); the version is
/// bumped whenever the numbers a stage computes change.
const POPULATION_PART: &str = "bayes.tmcmc/population";
const POPULATION_VERSION: u32 = 1;

/// What every population of a run depends on: the inputs' digests and every setting but those
/// that only shape the summary (`truth`, `credible_level`), end the run (`max_stages`) or say
/// who computes what (`workers`, `worker`), so that a run stopped at `max_stages` resumes when
/// it is raised, and any process finds what another one computed.
fn populations_key(p: &Params, inputs: &StageInputs) -> serde_json::Value {
    let mut settings = serde_json::to_value(p).unwrap_or_default();
    if let Some(o) = settings.as_object_mut() {
        for k in ["truth", "credible_level", "max_stages", "workers", "worker"] {
            o.remove(k);
        }
    }
    serde_json::json!({"inputs": inputs.digests, "settings": settings})
}

/// The populations of the tempering stages as parts of the run's cache, so that a stopped
/// run (interrupted, failed, or ended at `max_stages`) resumes from its last finished stage
/// and gives the samples an uninterrupted run gives.
struct CachedPopulations<'a> {
    inputs: &'a StageInputs,
    key: serde_json::Value,
    parameters: Vec<String>,
    /// `(workers, worker)`.
    sharing: (usize, usize),
}

impl CachedPopulations<'_> {
    /// The value of `key`'s part: computed by `compute` and committed as `record` of it (and
    /// used as computed), or read and `decode`d; a computing error is returned as it is.
    fn part<T>(
        &self,
        key: &serde_json::Value,
        what: &str,
        compute: &mut dyn FnMut() -> Result<T, UpdatingError>,
        record: impl Fn(&T) -> PopulationRecord,
        decode: impl FnOnce(PopulationRecord) -> Result<T, UpdatingError>,
    ) -> Result<T, UpdatingError> {
        let (mut computed, mut failure) = (None, None);
        let part = self.inputs.part(
            POPULATION_PART,
            POPULATION_VERSION,
            key,
            ArtefactKind::TmcmcPopulation,
            || match compute() {
                Ok(value) => {
                    let a = TmcmcPopulationKind::to_artefact(&record(&value));
                    computed = Some(value);
                    Ok(a)
                }
                Err(e) => {
                    let message = e.to_string();
                    failure = Some(e);
                    Err(StageError::Failed(message))
                }
            },
        );
        if let Some(e) = failure {
            return Err(e);
        }
        let a = part.map_err(|e| UpdatingError::Data(format!("{what}: {e}")))?;
        if let Some(value) = computed {
            return Ok(value);
        }
        let r = TmcmcPopulationKind::from_artefact(&a)
            .map_err(|e| UpdatingError::Data(format!("the stored {what}: {e}")))?;
        decode(r)
    }
}

impl PopulationStore for CachedPopulations<'_> {
    fn population(
        &self,
        stage: usize,
        compute: &mut dyn FnMut() -> Result<Population, UpdatingError>,
    ) -> Result<Population, UpdatingError> {
        let mut key = self.key.clone();
        key["stage"] = stage.into();
        let what = format!("population of TMCMC stage {stage}");
        self.part(
            &key,
            &what,
            compute,
            |population| PopulationRecord {
                parameters: self.parameters.clone(),
                population: population.clone(),
                batch: None,
            },
            |r| Ok(r.population),
        )
    }

    fn sharing(&self) -> (usize, usize) {
        self.sharing
    }

    fn chains(
        &self,
        stage: usize,
        batch: usize,
        batches: usize,
        compute: &mut dyn FnMut() -> Result<Chains, UpdatingError>,
    ) -> Result<Chains, UpdatingError> {
        if batches == 1 {
            return compute();
        }
        let mut key = self.key.clone();
        key["stage"] = stage.into();
        key["batch"] = serde_json::json!([batch, batches]);
        let what = format!("batch {batch} of {batches} of TMCMC stage {stage}");
        let record = |c: &Chains| PopulationRecord {
            parameters: self.parameters.clone(),
            population: Population {
                samples: c.samples.clone(),
                log_likelihood: c.log_likelihood.clone(),
                stages: Vec::new(),
                failed: c.failed,
            },
            batch: Some(ChainBatch {
                stage,
                index: batch,
                of: batches,
                accepted: c.accepted,
            }),
        };
        let decode = |r: PopulationRecord| {
            let b = r
                .batch
                .ok_or_else(|| UpdatingError::Data(format!("the stored {what} is a population")))?;
            Ok(Chains {
                samples: r.population.samples,
                log_likelihood: r.population.log_likelihood,
                accepted: b.accepted,
                failed: r.population.failed,
            })
        };
        self.part(&key, &what, compute, record, decode)
    }
}

/// The stated noise model (an SNR turned into per-FRF levels from `measured`).
fn noise(n: &NoiseParams, measured: Option<&crate::frf::FrfSet>) -> Result<Noise, StageError> {
    Ok(match n {
        NoiseParams::Estimated => {
            return Err(StageError::input(
                "noise",
                "TMCMC needs the noise stated (`sigma`, `relative` or `snr_db`)",
            ));
        }
        NoiseParams::Sigma(OneOrMany::One(s)) => Noise::Absolute(vec![s.get()]),
        NoiseParams::Sigma(OneOrMany::Many(s)) => {
            Noise::Absolute(s.iter().map(|v| v.get()).collect())
        }
        NoiseParams::Relative(c) => Noise::Relative(c.get()),
        NoiseParams::SnrDb(snr) => match measured {
            Some(m) => Noise::Absolute(snr_sigmas(m, *snr)),
            None => {
                return Err(StageError::input(
                    "noise",
                    "`snr_db` describes FRF noise: give `sigma` or `relative` for natural frequencies",
                ));
            }
        },
    })
}

/// What the modal-summation likelihoods (`frf_modal`, `chi_s`, `chi_a`) predict with: the modal
/// basis (default: every mode up to twice the highest measured line), the modal damping, and the
/// lines (off the resonances of the model at `initial` when undamped).
fn modal_prediction(
    p: &Params,
    model: &dyn crate::updating::ParametricModel,
    measured: &crate::frf::FrfSet,
    initial: &[f64],
) -> Result<(ModeSelection, ModalDamping, Vec<usize>), StageError> {
    let top_hz = measured.freqs_hz.last().copied().unwrap_or(0.0);
    let modes = p.modes.selection_or(ModeSelection::BelowHz(2.0 * top_hz));
    let damping = p.damping.modal();
    let undamped = matches!(damping, ModalDamping::None);
    let lines = likelihood_lines(model, measured, initial, modes, undamped, 1.0)
        .map_err(StageError::from_numerics(""))?;
    Ok((modes, damping, lines))
}

/// The noise of `modes`: the frequencies' noise for the first `modes` groups, `shape` for the
/// shapes' (one group per mode each).
fn with_shape_noise(noise: Noise, modes: usize, shape: f64) -> Result<Noise, StageError> {
    let frequencies = match noise {
        Noise::Absolute(s) if s.len() == 1 => vec![s[0]; modes],
        Noise::Absolute(s) if s.len() == modes => s,
        Noise::Absolute(s) => {
            return Err(StageError::input(
                "noise.sigma",
                format!(
                    "{} noise levels for {modes} measured modes: give one, or one per mode",
                    s.len()
                ),
            ));
        }
        // Frequency rows are ratios to the measured frequency: relative and absolute agree.
        Noise::Relative(c) => vec![c; modes],
        Noise::Estimated => {
            return Err(StageError::input("noise", "TMCMC needs the noise stated"));
        }
    };
    let mut all = frequencies;
    all.extend(std::iter::repeat_n(shape, modes));
    Ok(Noise::Absolute(all))
}

fn noise_name(n: &NoiseParams) -> &'static str {
    match n {
        NoiseParams::Estimated => "estimated",
        NoiseParams::Sigma(_) => "sigma",
        NoiseParams::Relative(_) => "relative",
        NoiseParams::SnrDb(_) => "snr_db",
    }
}

/// Adds the marginal and pair figures of `samples` to a posterior artefact as the blobs
/// `marginals.{png,svg}` and `pairs.{png,svg}`; `gaussian`: the Laplace marginals drawn over
/// the histograms. A figure that cannot be drawn is left out with a warning.
pub(crate) fn with_figures(
    mut a: Artefact,
    title: &str,
    names: Vec<String>,
    samples: &[Vec<f64>],
    truth: Option<Vec<f64>>,
    gaussian: Option<Vec<(f64, f64)>>,
) -> Artefact {
    if samples.is_empty() || names.is_empty() {
        return a;
    }
    let plot = PosteriorPlot {
        title: title.into(),
        names,
        samples,
        truth,
        gaussian,
    };
    for (name, fig) in [
        ("marginals", marginal_plot(&plot)),
        ("pairs", pair_plot(&plot)),
    ] {
        match fig {
            Ok(f) => {
                a.blobs.insert(format!("{name}.png"), f.png);
                a.blobs.insert(format!("{name}.svg"), f.svg.into_bytes());
            }
            Err(e) => tracing::warn!("the posterior figure `{name}` was not drawn: {e}"),
        }
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    fn check(
        with: serde_json::Value,
        ports: &[&str],
    ) -> Result<serde_json::Value, Vec<ParamIssue>> {
        Typed::<BayesTmcmc>::new().check(&with, &CheckContext::with_ports(ports))
    }

    #[test]
    fn bad_parameters_are_named() {
        let ports = ["model", "measured"];
        let e = check(
            serde_json::json!({"priors": {"m1": {"uniform": [0.5, 2.0]}}, "noise": "estimated"}),
            &ports,
        )
        .unwrap_err();
        assert_eq!(e[0].path, vec!["noise"]);
        let e = check(
            serde_json::json!({"priors": {"m1": {"normal": {"mean": 1.0, "sd": -1.0}}}, "noise": {"sigma": 1e-6}}),
            &ports,
        )
        .unwrap_err();
        assert_eq!(e[0].path, vec!["priors", "m1"]);
        let e = check(
            serde_json::json!({"priors": {"m1": {"uniform": [0.5, 2.0]}}, "truth": {"m2": 1.0}, "noise": {"sigma": 1e-6}}),
            &ports,
        )
        .unwrap_err();
        assert_eq!(e[0].path, vec!["truth", "m2"]);
        let e = check(
            serde_json::json!({"priors": {"m1": {"uniform": [0.5, 2.0]}}, "noise": {"sigma": 1e-6}, "likelihood": "natural_frequencies"}),
            &ports,
        )
        .unwrap_err();
        assert_eq!(e[0].path, vec!["likelihood"]);
        let e = check(
            serde_json::json!({"priors": {"m1": {"uniform": [0.5, 2.0]}}, "noise": {"sigma": 0.01}, "shape_noise": 0.02, "measured_dofs": ["1:ux"]}),
            &ports,
        )
        .unwrap_err();
        let paths: Vec<_> = e.iter().map(|i| i.path.join(".")).collect();
        assert_eq!(paths, ["shape_noise", "measured_dofs"]);
        let modal = ["model", "measured_modes"];
        let e = check(
            serde_json::json!({"priors": {"m1": {"uniform": [0.5, 2.0]}}, "noise": {"snr_db": 30.0}, "likelihood": "modes"}),
            &modal,
        )
        .unwrap_err();
        assert_eq!(e[0].path, vec!["noise"]);
        check(
            serde_json::json!({"priors": {"m1": {"uniform": [0.5, 2.0]}}, "noise": {"sigma": 0.01}, "likelihood": "modes", "shape_noise": 0.02, "measured_dofs": ["1:ux"]}),
            &modal,
        )
        .unwrap();
        let e = check(
            serde_json::json!({"priors": {"m1": {"uniform": [0.5, 2.0]}}, "noise": {"snr_db": 30.0}, "likelihood": "chi_s", "damping": {"rayleigh": {"alpha": 1.0, "beta": 1e-5}}}),
            &ports,
        )
        .unwrap_err();
        assert_eq!(e[0].path, vec!["damping"]);
        let v = check(
            serde_json::json!({"priors": {"m1": {"lognormal": {"median": 1.0, "log_sd": 0.2}}}, "noise": {"snr_db": 30.0}}),
            &ports,
        )
        .unwrap();
        assert_eq!(v["samples"], 1000);
        assert_eq!(v["proposal_scale"], 0.04);
    }
}
