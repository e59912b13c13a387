//! `method: damping`: the modal damping identification (thesis ch. 6): one modal analysis of
//! the fixed model, then the P-C on the `η_r` (structural) or `ζ_r` (viscous) of chosen elastic
//! modes; the result gains the table `modal_damping`.

use super::{PosteriorParams, Reduction, build_model, max_iterations, measured_frf};
use crate::artefact::kinds::matrices_to_artefact;
use crate::artefact::update::{IdentifiedDamping, update_result_to_artefact, with_modal_damping};
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::frf::{FrfSet, ModalDamping};
use crate::pipeline::{ParamIssue, StageError, StageInputs, StageOutputs};
use crate::stages::params::{
    AtLeastOne, Band, Count, Damping, Deprecation, Fraction, Modes, NonNegative, OpenFraction,
    Positive, migrate_mode_fields,
};
use crate::updating::damping::{
    DampingIdentification, DampingKind, DampingParameters, DampingSettings, equivalent_loss_factor,
};
use crate::updating::posterior::DampingLikelihood;
use crate::updating::{ModalState, ParametricModel, UpdateHistory, run};

/// Parameters of `method: damping`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DampingMethod {
    /// Most iterations.
    #[serde(default = "max_iterations")]
    pub max_iterations: usize,
    /// Mass matrix of a mesh model.
    #[serde(default)]
    pub mass: MassKind,
    /// The starting modal damping, which also says what is identified: `{structural: 0.01}`
    /// (`η_r`) or `{viscous: 0.005}` (`ζ_r`); uniform, one per mode, or `{all, modes}`.
    #[serde(default)]
    pub damping: Damping,
    /// The modal basis, `{count: N}` or `{max_freq_hz: F}` (default: every mode up to twice the
    /// highest measured line).
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
    /// 1-based numbers of the modes whose damping is identified, counting rigid-body modes
    /// (default: every elastic mode inside the measured band).
    #[serde(default)]
    pub damping_modes: Vec<Count>,
    /// P-C settings of the identification.
    #[serde(default)]
    pub pc: DampingPcParams,
    /// Stop when every relative change is below this.
    #[serde(default = "tolerance")]
    pub tolerance: OpenFraction,
    /// With `partition` connected: the component mode synthesis the mesh is analysed by.
    #[serde(default)]
    pub reduction: Reduction,
    /// The Laplace posterior of the identified damping (docs/theory.md §12), on the complex
    /// FRFs at every line.
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

/// The P-C settings of the damping identification; defaults: [`DampingSettings::default`]
/// (every line, the step tolerance as the stop rule, `κ = 1e7`).
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DampingPcParams {
    /// Lines with `(χ_s + χ_a)/2` above this are not used (4.20).
    #[serde(default = "kappa_f")]
    pub kappa_f: Fraction,
    /// Lines within this many line spacings of a predicted natural frequency are not used.
    #[serde(default = "resonance_lines")]
    pub resonance_lines: NonNegative,
    /// Stop when the mean of `(χ_s + χ_a)/2` over all lines reaches this (4.23).
    #[serde(default = "stop_chi")]
    pub stop_chi: Fraction,
    /// `κ` of the subset selection (5.14), which leaves alone the modes the measurements cannot
    /// see; `null`: every mode.
    #[serde(default = "subset_kappa")]
    pub subset_kappa: Option<AtLeastOne>,
    /// Largest relative change of a loss factor in one step.
    #[serde(default = "max_step")]
    pub max_step: Positive,
}

fn kappa_f() -> Fraction {
    Fraction::of_default(DampingSettings::default().kappa_f)
}
fn resonance_lines() -> NonNegative {
    NonNegative::of_default(DampingSettings::default().resonance_lines)
}
fn stop_chi() -> Fraction {
    Fraction::of_default(DampingSettings::default().stop_chi)
}
fn subset_kappa() -> Option<AtLeastOne> {
    DampingSettings::default()
        .subset_kappa
        .map(AtLeastOne::of_default)
}
fn max_step() -> Positive {
    Positive::of_default(DampingSettings::default().max_step)
}
fn tolerance() -> OpenFraction {
    OpenFraction::of_default(DampingSettings::default().tolerance)
}

impl Default for DampingPcParams {
    fn default() -> Self {
        DampingPcParams {
            kappa_f: kappa_f(),
            resonance_lines: resonance_lines(),
            stop_chi: stop_chi(),
            subset_kappa: subset_kappa(),
            max_step: max_step(),
        }
    }
}

impl DampingMethod {
    pub(super) fn migrate(&mut self, found: &mut Vec<Deprecation>) -> Vec<ParamIssue> {
        let (count, hz) = (self.mode_count.take(), self.modes_max_hz.take());
        migrate_mode_fields(&mut self.modes, count, hz, found)
    }

    pub(super) fn issues(&self) -> Vec<ParamIssue> {
        let mut issues = self.modes.issues("modes");
        if !matches!(self.damping, Damping::Structural(_) | Damping::Viscous(_)) {
            issues.push(ParamIssue::at(
                "damping",
                "damping identification starts from modal damping: give `{structural: 0.01}` (identifies η_r) or `{viscous: 0.005}` (identifies ζ_r)",
            ));
        }
        issues
    }

    pub(super) fn run(&self, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = build_model(
            inputs,
            None,
            self.mass,
            &self.reduction,
            self.modes.is_given(),
        )?;
        let measured = measured_frf(inputs, self.band_hz, &self.exclude_hz)?;
        let top_hz = measured.freqs_hz.last().copied().unwrap_or(0.0);
        let basis = self
            .modes
            .selection_or(ModeSelection::BelowHz(2.0 * top_hz));
        let (state, evaluated) = model
            .modal_state(&model.initial_values(), basis)
            .map_err(StageError::from_numerics(""))?;
        let (kind, initial) = self.start(state.modes.len())?;
        let modes = self.identified_modes(&state, &measured)?;
        let method = DampingIdentification::new(
            &measured,
            &state,
            DampingSettings {
                kind,
                initial,
                modes: modes.clone(),
                kappa_f: self.pc.kappa_f.get(),
                resonance_lines: self.pc.resonance_lines.get(),
                stop_chi: self.pc.stop_chi.get(),
                tolerance: self.tolerance.get(),
                max_step: self.pc.max_step.get(),
                subset_kappa: self.pc.subset_kappa.map(AtLeastOne::get),
            },
        )
        .map_err(StageError::input_at("damping_modes"))?;
        let system = match evaluated {
            Some(ev) => ev.system,
            None => {
                (model.evaluate(&model.initial_values()))
                    .map_err(StageError::from_numerics(""))?
                    .system
            }
        };
        let parameters = DampingParameters::new(&method, system);
        let history = run(&method, &parameters, self.max_iterations)
            .map_err(StageError::from_numerics(""))?;
        let result = result(&history, kind, &modes, &state.modes.frequencies_hz());
        let system = (parameters.evaluate(&history.final_values))
            .map_err(StageError::from_numerics(""))?
            .system;
        // The output error on the complex FRFs at every line (the predictions are damped).
        let lik = DampingLikelihood::new(
            &state,
            &measured,
            (0..measured.freqs_hz.len()).collect(),
            Box::new(|v: &[f64]| method.damping(v)),
            modes.clone(),
        );
        let posterior = self.posterior.artefact(
            &lik,
            parameters.parameters(),
            &history.final_values,
            Some(&measured),
            None,
            "damping",
            "frf_damping",
        )?;
        Ok(StageOutputs::from([
            ("result".to_string(), result),
            ("model".to_string(), matrices_to_artefact(&system)),
            ("posterior".to_string(), posterior),
        ]))
    }

    /// The damping model identified and its start, one value per mode of a basis of `m`.
    fn start(&self, m: usize) -> Result<(DampingKind, Vec<f64>), StageError> {
        match self.damping.modal_for(m) {
            Ok(ModalDamping::Structural(v)) => Ok((DampingKind::Structural, v)),
            Ok(ModalDamping::Viscous(v)) => Ok((DampingKind::Viscous, v)),
            Ok(ModalDamping::None) => Err(StageError::input(
                "damping",
                "damping identification needs a starting modal damping in `damping`",
            )),
            Err(e) => Err(StageError::input(
                "damping",
                format!("(a modal basis of {m} modes): {e}"),
            )),
        }
    }

    /// The 0-based modes identified: those named, or every elastic mode in the measured band.
    fn identified_modes(
        &self,
        state: &ModalState,
        measured: &FrfSet,
    ) -> Result<Vec<usize>, StageError> {
        if !self.damping_modes.is_empty() {
            return Ok(self.damping_modes.iter().map(|r| r.get() - 1).collect());
        }
        let natural = state.modes.frequencies_hz();
        let (lo, hi) = match (measured.freqs_hz.first(), measured.freqs_hz.last()) {
            (Some(&lo), Some(&hi)) => (lo, hi),
            _ => return Err(StageError::input("", "the measured FRFs have no lines")),
        };
        Ok((0..state.modes.len())
            .filter(|&r| state.modes.eigenvalues[r] > 0.0 && natural[r] >= lo && natural[r] <= hi)
            .collect())
    }
}

/// The update result with the table `modal_damping` (each mode's identified value and its
/// equivalent loss factor).
fn result(
    history: &UpdateHistory,
    kind: DampingKind,
    modes: &[usize],
    natural: &[f64],
) -> crate::artefact::Artefact {
    let identified: Vec<IdentifiedDamping> = modes
        .iter()
        .zip(history.parameters.iter().zip(&history.final_values))
        .map(|(&r, (q, &v))| IdentifiedDamping {
            mode: r + 1,
            natural_hz: natural[r],
            initial: q.initial,
            identified: v,
            equivalent_loss_factor: match kind {
                DampingKind::Structural => v,
                DampingKind::Viscous => equivalent_loss_factor(v),
            },
        })
        .collect();
    let kind_name = match kind {
        DampingKind::Structural => "structural",
        DampingKind::Viscous => "viscous",
    };
    with_modal_damping(
        update_result_to_artefact(history, "damping"),
        kind_name,
        &identified,
    )
}
