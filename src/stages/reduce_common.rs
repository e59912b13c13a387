//! Glue shared by the `reduce.*` stages (not a stage kind): component-mode selection, reading
//! mesh and partition, reducing, and the reduced derivatives of every model parameter.

use crate::artefact::mesh::mesh_from_artefact;
use crate::artefact::reduced::{partition_from_artefact, reduced_to_artefact};
use crate::artefact::{Artefact, ArtefactKind};
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::pipeline::{ParamIssue, PortSpec, StageError, StageInputs, StageOutputs};
use crate::reduction::{Method, reduce, reduced_parameter_derivative};

/// Component modes kept per substructure: `max_freq_hz` (default 200 Hz, the thesis's C3
/// cut-off) or `count`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ComponentModes {
    /// Keep component modes up to this frequency, Hz (thesis: twice the top of the band).
    #[serde(default)]
    pub max_freq_hz: Option<f64>,
    /// Keep this many component modes per substructure.
    #[serde(default)]
    pub count: Option<usize>,
}

impl ComponentModes {
    /// Checks the pair.
    pub fn issues(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        if self.max_freq_hz.is_some() && self.count.is_some() {
            v.push(ParamIssue::at(
                "max_freq_hz",
                "give `max_freq_hz` or `count`, not both",
            ));
        }
        if let Some(f) = self.max_freq_hz {
            if !(f.is_finite() && f > 0.0) {
                v.push(ParamIssue::at(
                    "max_freq_hz",
                    format!("{f} must be a positive frequency in Hz"),
                ));
            }
        }
        if self.count == Some(0) {
            v.push(ParamIssue::at("count", "must be at least 1"));
        }
        v
    }

    /// The selection (default: modes to 200 Hz).
    pub fn selection(&self) -> ModeSelection {
        match (self.count, self.max_freq_hz) {
            (Some(c), _) => ModeSelection::Count(c),
            (_, Some(f)) => ModeSelection::BelowHz(f),
            _ => ModeSelection::BelowHz(200.0),
        }
    }
}

/// Parameters of the reductions that need only component modes and the mass kind
/// (`reduce.craig_bampton`, `reduce.free_interface`).
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ModalReductionParams {
    /// Keep component modes up to this frequency, Hz (default 200 Hz when `count` is absent;
    /// the thesis kept twice the top of the band).
    #[serde(default)]
    pub max_freq_hz: Option<f64>,
    /// Keep this many component modes per substructure.
    #[serde(default)]
    pub count: Option<usize>,
    /// Mass matrix kind.
    #[serde(default)]
    pub mass: MassKind,
}

impl ModalReductionParams {
    /// The component-mode choice.
    pub fn modes(&self) -> ComponentModes {
        ComponentModes {
            max_freq_hz: self.max_freq_hz,
            count: self.count,
        }
    }
}

/// Input ports of every `reduce.*` stage.
pub fn inputs() -> Vec<PortSpec> {
    vec![
        PortSpec::required("mesh", ArtefactKind::Mesh, "the model"),
        PortSpec::required("partition", ArtefactKind::Partition, "its substructures"),
    ]
}

/// Output ports of every `reduce.*` stage.
pub fn outputs() -> Vec<PortSpec> {
    vec![PortSpec::required(
        "reduced",
        ArtefactKind::ReducedModel,
        "reduced K, M, transformations and reduced parameter derivatives",
    )]
}

/// Reduces and writes the artefact with the reduced derivatives of every model parameter.
pub fn run(
    method: Method,
    mass: MassKind,
    inputs: &StageInputs,
) -> Result<StageOutputs, StageError> {
    let model = mesh_from_artefact(inputs.require("mesh")?)?;
    let part = partition_from_artefact(inputs.require("partition")?)?;
    let r = reduce(&model, &part, &method, mass).map_err(StageError::failed)?;
    let mut derivs = Vec::new();
    for param in &model.parameters {
        let (dk, dm) = reduced_parameter_derivative(&model, &part, &r, param, mass)
            .map_err(|e| StageError::Failed(format!("parameter `{}`: {e}", param.name)))?;
        derivs.push((param.name.clone(), dk, dm));
    }
    let a: Artefact = reduced_to_artefact(&r, &derivs);
    Ok(StageOutputs::from([("reduced".to_string(), a)]))
}
