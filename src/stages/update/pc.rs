//! `method: pc`: the predictor-corrector on the FRF correlation coefficients `χ_s`, `χ_a`
//! (docs/theory.md §5; thesis ch. 4), with optional continuation phases on smoothed FRFs.

use super::{
    Method, PosteriorParams, Reduction, SensitiveStartParams, build_model, max_iterations,
    measured_frf, run_and_write,
};
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::frf::ModalDamping;
use crate::pipeline::{ParamIssue, StageError, StageInputs, StageOutputs};
use crate::stages::params::{
    AtLeastOne, Band, Count, Damping, Deprecation, Fraction, Modes, NonNegative, Positive,
    migrate_mode_fields,
};
use crate::updating::pc::{PcSettings, PredictorCorrector};
use crate::updating::posterior::{ModalFrfLikelihood, NaturalFrequencies, likelihood_lines};
use crate::updating::{ParameterWeighting, UpdateMethod};

/// Parameters of `method: pc`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PcMethod {
    /// Names of the parameters to update (default: all the model declares).
    #[serde(default)]
    pub parameters: Vec<String>,
    /// Most iterations (all phases together).
    #[serde(default = "max_iterations")]
    pub max_iterations: usize,
    /// Mass matrix of a mesh model.
    #[serde(default)]
    pub mass: MassKind,
    /// Modal damping of the predictions, one uniform `structural` or `viscous` value.
    #[serde(default)]
    pub damping: Damping,
    /// The modal basis, `{count: N}` or `{max_freq_hz: F}` (default: every mode up to twice the
    /// highest measured line, the thesis's `2m` modes). A reduced model (`partition`
    /// connected) of up to 2000 DOFs is analysed on its complete modal basis whatever this
    /// says: its component modes already chose the band.
    #[serde(default)]
    pub modes: Modes,
    /// Deprecated spelling of `modes.count`.
    #[serde(default, skip_serializing)]
    #[schemars(extend("deprecated" = true))]
    pub mode_count: Option<Count>,
    /// Deprecated spelling of `modes.max_freq_hz`.
    #[serde(default, skip_serializing)]
    #[schemars(extend("deprecated" = true))]
    pub modes_max_hz: Option<Positive>,
    /// P-C settings.
    #[serde(default)]
    pub pc: PcParams,
    /// Before updating, move these parameters' starting values into their sensitive regions
    /// (thesis §5.4): lumped springs and masses whose initial estimates no eigenvalue feels.
    #[serde(default)]
    pub sensitive_start: Option<SensitiveStartParams>,
    /// With `partition` connected: the component mode synthesis the mesh is analysed by; only
    /// substructures holding a changed parameter are reduced again at each iteration.
    #[serde(default)]
    pub reduction: Reduction,
    /// The Laplace posterior computed after the update (docs/theory.md §12).
    #[serde(default)]
    pub posterior: PosteriorParams,
    /// Only measured lines in `[lo, hi]` Hz are used (default: all).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band_hz: Option<Band>,
    /// Measured lines inside any of these bands are left out, e.g. `[[0, 0]]` for the static
    /// line or `[[49, 51]]` for mains hum (default: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exclude_hz: Vec<Band>,
}

/// Settings of the P-C (docs/theory.md §5); defaults: [`PcSettings::default`].
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PcParams {
    /// Lines with `(χ_s + χ_a)/2` above this are not used (4.20); the thesis uses 0.9 to 1.
    #[serde(default = "kappa_f")]
    pub kappa_f: Fraction,
    /// Lines within this many line spacings of a predicted natural frequency are not used.
    #[serde(default = "resonance_lines")]
    pub resonance_lines: NonNegative,
    /// Stop when the mean of `(χ_s + χ_a)/2` over all lines reaches this (4.23).
    #[serde(default = "stop_chi")]
    pub stop_chi: Fraction,
    /// `κ` of the subset selection, `κ_mn = 1 + κ(n/m)²` (5.14); the thesis uses 1e7 to
    /// 1e10. Omitted: every parameter.
    #[serde(default)]
    pub subset_kappa: Option<AtLeastOne>,
    /// `γ` of the parameter weighting `W_φ` (see `ParameterWeighting::Variance`); omitted or 0:
    /// plain weighted least squares.
    #[serde(default)]
    pub weighting_gamma: Option<NonNegative>,
    /// Largest relative change of a parameter in one step.
    #[serde(default = "max_step")]
    pub max_step: Positive,
    /// Add the truncated modes' static share to the mode-shape derivatives (Wang's correction:
    /// one sparse Cholesky of K per iteration); `false`: the thesis's truncated sensitivities.
    #[serde(default = "static_correction")]
    pub static_correction: bool,
    /// Continuation phases before the P-C proper, e.g. `[0.1, 0.03]`: each an added loss
    /// factor `g` in (0, 1] by which measured and predicted FRFs are smoothed over frequency
    /// (a Poisson kernel of half-width `g f / 2`: every mode seen with that much more damping).
    /// Broadened peaks overlap when the initial model's resonances lie many half-power
    /// bandwidths from the measured ones, where the unsmoothed correlation no longer tells which
    /// way to go. Each phase runs until its smoothed mean correlation reaches the stop rule or
    /// gains less than 1e-3 per iteration; the phases share `max_iterations` with the final,
    /// unsmoothed P-C.
    #[serde(default)]
    pub smoothing: Vec<Fraction>,
    /// Also try, at every iteration, the Gauss-Newton steps on the stop figure (the mean
    /// correlation) itself: the P-C's equations with weights `1/(1 − χ)` over every line. The
    /// thesis's line choice (4.20) and weights (4.21) can stall where the mean correlation
    /// still rises toward the solution; these steps do not. Off: the thesis's steps alone.
    #[serde(default = "merit_steps")]
    pub merit_steps: bool,
    /// Add the truncated modes' residual (static) flexibility at the measured DOFs to every
    /// prediction and its derivative to the sensitivities (full models; one more sparse
    /// factorisation of `K − σM` per analysis). Default `false`: the modal sum alone, as in
    /// the thesis. (A partition's Craig-Bampton model holds the static share already; the
    /// Laplace `posterior` still linearises the modal sum without it.)
    #[serde(default)]
    pub residual_flexibility: bool,
}

fn kappa_f() -> Fraction {
    Fraction::of_default(PcSettings::default().kappa_f)
}
fn resonance_lines() -> NonNegative {
    NonNegative::of_default(PcSettings::default().resonance_lines)
}
fn stop_chi() -> Fraction {
    Fraction::of_default(PcSettings::default().stop_chi)
}
fn max_step() -> Positive {
    Positive::of_default(PcSettings::default().max_step)
}
fn static_correction() -> bool {
    PcSettings::default().static_correction
}
fn merit_steps() -> bool {
    PcSettings::default().merit_steps
}

impl Default for PcParams {
    fn default() -> Self {
        let d = PcSettings::default();
        PcParams {
            kappa_f: kappa_f(),
            resonance_lines: resonance_lines(),
            stop_chi: stop_chi(),
            subset_kappa: d.subset_kappa.map(AtLeastOne::of_default),
            weighting_gamma: None,
            max_step: max_step(),
            static_correction: d.static_correction,
            smoothing: Vec::new(),
            merit_steps: d.merit_steps,
            residual_flexibility: d.residual_flexibility,
        }
    }
}

/// `W_φ` from `γ`: none when omitted or 0.
pub(super) fn weighting(gamma: Option<NonNegative>) -> ParameterWeighting {
    match gamma.map(NonNegative::get) {
        Some(g) if g > 0.0 => ParameterWeighting::Variance { gamma: g },
        _ => ParameterWeighting::None,
    }
}

impl PcMethod {
    pub(super) fn migrate(&mut self, found: &mut Vec<Deprecation>) -> Vec<ParamIssue> {
        let (count, hz) = (self.mode_count.take(), self.modes_max_hz.take());
        migrate_mode_fields(&mut self.modes, count, hz, found)
    }

    pub(super) fn issues(&self) -> Vec<ParamIssue> {
        let mut issues = self.modes.issues("modes");
        if matches!(self.damping, Damping::Rayleigh { .. }) {
            issues.push(ParamIssue::at(
                "damping",
                "the P-C predicts by modal summation: give `structural` or `viscous` modal damping",
            ));
        }
        if self.damping.is_per_mode() {
            issues.push(ParamIssue::at(
                "damping",
                "per-mode damping needs a fixed modal basis: only the method `damping` takes it; give one uniform value",
            ));
        }
        if let Some(ss) = &self.sensitive_start {
            issues.extend(ss.issues());
        }
        issues
    }

    /// The settings of one phase (`smoothing` 0: the P-C proper).
    fn settings(&self, modes: ModeSelection, smoothing: f64) -> PcSettings {
        let pc = &self.pc;
        PcSettings {
            kappa_f: pc.kappa_f.get(),
            resonance_lines: pc.resonance_lines.get(),
            stop_chi: pc.stop_chi.get(),
            subset_kappa: pc.subset_kappa.map(AtLeastOne::get),
            weighting: weighting(pc.weighting_gamma),
            max_step: pc.max_step.get(),
            modes,
            damping: self.damping.modal(),
            static_correction: pc.static_correction,
            smoothing,
            merit_steps: pc.merit_steps,
            residual_flexibility: pc.residual_flexibility,
        }
    }

    pub(super) fn run(&self, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = build_model(
            inputs,
            Some(&self.parameters),
            self.mass,
            &self.reduction,
            self.modes.is_given(),
        )?;
        let measured = measured_frf(inputs, self.band_hz, &self.exclude_hz)?;
        let top_hz = measured.freqs_hz.last().copied().unwrap_or(0.0);
        let modes = self
            .modes
            .selection_or(ModeSelection::BelowHz(2.0 * top_hz));
        if let ModalDamping::None = self.damping.modal() {
            tracing::info!("P-C with undamped predictions: lines at resonances are excluded");
        }
        // The smoothing phases (continuation), each its own method, then the P-C proper.
        let phases: Vec<PredictorCorrector> = (self.pc.smoothing.iter().map(|g| g.get()))
            .chain([0.0])
            .map(|g| PredictorCorrector::new(&measured, self.settings(modes, g)))
            .collect();
        let phases: Vec<&dyn UpdateMethod> = phases.iter().map(|m| m as _).collect();
        let damping = self.damping.modal();
        let undamped = matches!(damping, ModalDamping::None);
        let model = model.as_ref();
        // The output error on the complex FRFs at every line (off the resonances when the
        // predictions are undamped), with the P-C's modal predictions.
        let posterior = |h: &crate::updating::UpdateHistory| {
            let lines = likelihood_lines(
                model,
                &measured,
                &h.final_values,
                modes,
                undamped,
                self.pc.resonance_lines.get(),
            )
            .map_err(StageError::from_numerics("posterior"))?;
            let lik = ModalFrfLikelihood::new(model, &measured, lines, modes, damping.clone());
            let natural = NaturalFrequencies {
                model,
                selection: modes,
                count: usize::MAX,
                max_hz: top_hz,
            };
            self.posterior.artefact(
                &lik,
                model.parameters(),
                &h.final_values,
                Some(&measured),
                Some(&natural),
                Method::Pc.name(),
                "frf_modal",
            )
        };
        run_and_write(
            model,
            &phases,
            self.sensitive_start.as_ref(),
            self.max_iterations,
            Method::Pc,
            &posterior,
        )
    }
}
