//! `method: rfm`: Lin and Ewins's response function method at chosen measured lines, the
//! unmeasured coordinates taken from the model (docs/theory.md §5).

use super::{
    Method, PosteriorParams, Reduction, SensitiveStartParams, build_model, max_iterations,
    measured_frf,
};
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::pipeline::{ParamIssue, StageError, StageInputs, StageOutputs};
use crate::stages::params::{Band, Damping, NonNegative, OpenFraction, PerMode};
use crate::updating::posterior::{DirectFrfLikelihood, NaturalFrequencies};
use crate::updating::rfm::{ResponseFunctionMethod, RfmSettings};

/// Parameters of `method: rfm`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RfmMethod {
    /// Names of the parameters to update (default: all the model declares).
    #[serde(default)]
    pub parameters: Vec<String>,
    /// Most iterations.
    #[serde(default = "max_iterations")]
    pub max_iterations: usize,
    /// Mass matrix of a mesh model.
    #[serde(default)]
    pub mass: MassKind,
    /// Damping of the model: none, or a uniform structural loss factor `{structural: 0.01}`.
    #[serde(default)]
    pub damping: Damping,
    /// The lines in Hz at which the equations are written (measured lines), e.g. `[9.0, 18.0]`.
    #[serde(default)]
    pub lines_hz: Vec<NonNegative>,
    /// Stop when every relative change is below this.
    #[serde(default = "tolerance")]
    pub tolerance: OpenFraction,
    /// Before updating, move these parameters' starting values into their sensitive regions
    /// (thesis §5.4).
    #[serde(default)]
    pub sensitive_start: Option<SensitiveStartParams>,
    /// The Laplace posterior computed after the update (docs/theory.md §12), on the complex
    /// FRFs at `lines_hz`.
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

fn tolerance() -> OpenFraction {
    OpenFraction::of_default(RfmSettings::default().tolerance)
}

impl RfmMethod {
    pub(super) fn issues(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if self.lines_hz.is_empty() {
            issues.push(ParamIssue::at(
                "lines_hz",
                "the RFM needs the lines (Hz) at which to write its equations, e.g. [9.0, 18.0]",
            ));
        }
        if !matches!(
            self.damping,
            Damping::None | Damping::Structural(PerMode::Uniform(_))
        ) {
            issues.push(ParamIssue::at(
                "damping",
                "the RFM takes no damping or a uniform structural loss factor `{structural: 0.01}`",
            ));
        }
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
            &Reduction::default(),
            false,
        )?;
        let measured = measured_frf(inputs, self.band_hz, &self.exclude_hz)?;
        let lines_hz: Vec<f64> = self.lines_hz.iter().map(|f| f.get()).collect();
        let eta = self.damping.direct().structural_eta;
        let model = model.as_ref();
        let top_hz = measured.freqs_hz.last().copied().unwrap_or(0.0);
        // The output error on the complex direct FRFs at the RFM's lines.
        let posterior = |h: &crate::updating::UpdateHistory| {
            let lines: Vec<usize> = lines_hz
                .iter()
                .filter_map(|&l| {
                    (measured.freqs_hz.iter())
                        .position(|&x| (x - l).abs() <= 1e-9 * l.abs().max(1.0))
                })
                .collect();
            let lik = DirectFrfLikelihood::new(model, &measured, lines, eta);
            let natural = NaturalFrequencies {
                model,
                selection: ModeSelection::BelowHz(2.0 * top_hz),
                count: usize::MAX,
                max_hz: top_hz,
            };
            self.posterior.artefact(
                &lik,
                model.parameters(),
                &h.final_values,
                Some(&measured),
                Some(&natural),
                Method::Rfm.name(),
                "frf_direct",
            )
        };
        let method = ResponseFunctionMethod {
            measured: &measured,
            settings: RfmSettings {
                lines_hz: lines_hz.clone(),
                eta,
                tolerance: self.tolerance.get(),
                ..RfmSettings::default()
            },
        };
        super::run_and_write(
            model,
            &[&method],
            self.sensitive_start.as_ref(),
            self.max_iterations,
            Method::Rfm,
            &posterior,
        )
    }
}
