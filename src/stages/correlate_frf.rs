//! `correlate.frf`: the shape and amplitude correlation coefficients `χ_s(ω)`, `χ_a(ω)` per line
//! (4.8, 4.9), FRAC per measured FRF (1.19), and their summary (docs/theory.md §4).

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{correlation_to_artefact, frf_from_artefact};
use crate::correlation::correlate;
use crate::pipeline::{PortSpec, StageError, StageInputs, StageOutputs, TypedStage};

/// The stage.
pub struct CorrelateFrf;

/// Parameters of `correlate.frf` (none yet; unknown keys are errors).
#[derive(Clone, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {}

impl TypedStage for CorrelateFrf {
    type Params = Params;
    const KIND: &'static str = "correlate.frf";
    const SUMMARY: &'static str =
        "Shape and amplitude correlation chi_s, chi_a per line and FRAC per FRF";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required("measured", ArtefactKind::Frf, "measured (reference) FRFs"),
            PortSpec::required(
                "predicted",
                ArtefactKind::Frf,
                "predicted FRFs on the same lines, holding every measured pair",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "correlation",
            ArtefactKind::Correlation,
            "chi_s, chi_a per line; FRAC per FRF",
        )]
    }

    fn run(_: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let measured = frf_from_artefact(inputs.require("measured")?)?;
        let predicted = frf_from_artefact(inputs.require("predicted")?)?;
        let c = correlate(&measured, &predicted).map_err(StageError::from_numerics(""))?;
        Ok(StageOutputs::from([(
            "correlation".to_string(),
            correlation_to_artefact(&c),
        )]))
    }
}
