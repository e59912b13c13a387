//! `method: eigensensitivity`: inverse eigensensitivity from measured natural frequencies and,
//! with `measured_dofs`, shapes paired by MAC (docs/theory.md §5).

use super::pc::weighting;
use super::{
    Method, PosteriorParams, Reduction, SensitiveStartParams, build_model, elastic_measured_modes,
    max_iterations, run_and_write,
};
use crate::core::DofId;
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::pipeline::{ParamIssue, StageError, StageInputs, StageOutputs};
use crate::stages::params::{
    AtLeastOne, Count, Deprecation, Fraction, Modes, NonNegative, OpenFraction, Positive,
    migrate_mode_fields,
};
use crate::updating::eigensensitivity::{EigenSettings, InverseEigensensitivity};
use crate::updating::posterior::{ModalDataLikelihood, NaturalFrequencies};

/// Parameters of `method: eigensensitivity`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EigensensitivityMethod {
    /// Names of the parameters to update (default: all the model declares).
    #[serde(default)]
    pub parameters: Vec<String>,
    /// Most iterations.
    #[serde(default = "max_iterations")]
    pub max_iterations: usize,
    /// Mass matrix of a mesh model.
    #[serde(default)]
    pub mass: MassKind,
    /// The modal basis, `{count: N}` or `{max_freq_hz: F}` (default: three times the measured
    /// modes' count, plus six). A reduced model of up to 2000 DOFs uses its complete basis.
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
    /// Stop when every relative change is below this.
    #[serde(default = "tolerance")]
    pub tolerance: OpenFraction,
    /// DOFs of the measured shapes used to pair modes by MAC (default: pair in order of
    /// frequency).
    #[serde(default)]
    pub measured_dofs: Vec<DofId>,
    /// How many of the measured (elastic) modes to use (default: all).
    #[serde(default)]
    pub measured_modes: Option<Count>,
    /// Smallest MAC of a pair.
    #[serde(default = "min_mac")]
    pub min_mac: Fraction,
    /// `κ` of the subset selection, `κ_mn = 1 + κ(n/m)²` (5.14); omitted: every parameter.
    #[serde(default)]
    pub subset_kappa: Option<AtLeastOne>,
    /// `γ` of the parameter weighting `W_φ`; omitted or 0: plain least squares.
    #[serde(default)]
    pub weighting_gamma: Option<NonNegative>,
    /// Deprecated place of `subset_kappa` and `weighting_gamma`.
    #[serde(default, skip_serializing)]
    #[schemars(extend("deprecated" = true))]
    pub pc: Option<LegacyEigenPc>,
    /// Before updating, move these parameters' starting values into their sensitive regions
    /// (thesis §5.4).
    #[serde(default)]
    pub sensitive_start: Option<SensitiveStartParams>,
    /// With `partition` connected: the component mode synthesis the mesh is analysed by.
    #[serde(default)]
    pub reduction: Reduction,
    /// The Laplace posterior computed after the update (docs/theory.md §12), on the paired
    /// natural frequencies (noise levels are relative frequency errors, one or one per mode).
    #[serde(default)]
    pub posterior: PosteriorParams,
}

/// The P-C block as inverse eigensensitivity read it before it had its own fields: only these
/// two settings applied.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LegacyEigenPc {
    /// Now `subset_kappa`.
    #[serde(default)]
    pub subset_kappa: Option<AtLeastOne>,
    /// Now `weighting_gamma`.
    #[serde(default)]
    pub weighting_gamma: Option<NonNegative>,
}

fn tolerance() -> OpenFraction {
    OpenFraction::of_default(EigenSettings::default().tolerance)
}
fn min_mac() -> Fraction {
    Fraction::of_default(EigenSettings::default().min_mac)
}

impl EigensensitivityMethod {
    pub(super) fn migrate(&mut self, found: &mut Vec<Deprecation>) -> Vec<ParamIssue> {
        let (count, hz) = (self.mode_count.take(), self.modes_max_hz.take());
        let mut issues = migrate_mode_fields(&mut self.modes, count, hz, found);
        if let Some(old) = self.pc.take() {
            if let Some(k) = old.subset_kappa {
                found.push(Deprecation {
                    old: "pc.subset_kappa",
                    new: "subset_kappa",
                });
                if self.subset_kappa.replace(k).is_some() {
                    issues.push(ParamIssue::at(
                        "subset_kappa",
                        "give `subset_kappa` alone: `pc.subset_kappa` is its old spelling",
                    ));
                }
            }
            if let Some(g) = old.weighting_gamma {
                found.push(Deprecation {
                    old: "pc.weighting_gamma",
                    new: "weighting_gamma",
                });
                if self.weighting_gamma.replace(g).is_some() {
                    issues.push(ParamIssue::at(
                        "weighting_gamma",
                        "give `weighting_gamma` alone: `pc.weighting_gamma` is its old spelling",
                    ));
                }
            }
        }
        issues
    }

    pub(super) fn issues(&self) -> Vec<ParamIssue> {
        let mut issues = self.modes.issues("modes");
        if let Some(ss) = &self.sensitive_start {
            issues.extend(ss.issues());
        }
        issues
    }

    pub(super) fn run(&self, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = build_model(
            inputs,
            Some(&self.parameters),
            self.mass,
            &self.reduction,
            self.modes.is_given(),
        )?;
        let measured = elastic_measured_modes(
            inputs,
            self.measured_modes.map(Count::get),
            &self.measured_dofs,
        )?;
        let count = 3 * measured.eigenvalues.len() + 6;
        let method = InverseEigensensitivity {
            measured: &measured,
            settings: EigenSettings {
                modes: self.modes.selection_or(ModeSelection::Count(count)),
                min_mac: self.min_mac.get(),
                tolerance: self.tolerance.get(),
                subset_kappa: self.subset_kappa.map(AtLeastOne::get),
                weighting: weighting(self.weighting_gamma),
            },
        };
        let model = model.as_ref();
        let selection = method.settings.modes;
        // The output error on the paired natural frequencies, the pairs held from the result.
        let posterior = |h: &crate::updating::UpdateHistory| {
            let (state, _) = model
                .modal_state(&h.final_values, selection)
                .map_err(StageError::from_numerics("posterior"))?;
            let pairs: Vec<(f64, usize)> = method
                .pairs(&state)
                .map_err(StageError::from_numerics("posterior"))?
                .iter()
                .zip(&measured.eigenvalues)
                .filter_map(|(a, &l)| a.map(|a| (l.sqrt() / (2.0 * std::f64::consts::PI), a)))
                .collect();
            let lik = ModalDataLikelihood::new(model, selection, pairs);
            let natural = NaturalFrequencies {
                model,
                selection,
                count: measured.eigenvalues.len(),
                max_hz: f64::INFINITY,
            };
            self.posterior.artefact(
                &lik,
                model.parameters(),
                &h.final_values,
                None,
                Some(&natural),
                Method::Eigensensitivity.name(),
                "natural_frequencies",
            )
        };
        run_and_write(
            model,
            &[&method],
            self.sensitive_start.as_ref(),
            self.max_iterations,
            Method::Eigensensitivity,
            &posterior,
        )
    }
}
