//! `reduce.free_interface`: MacNeal/Rubin free interface: free modes plus residual flexibility, inertia-relief projection
//! for floating substructures (thesis 3.22–3.39), assembled at the junction DOFs (3.14).

use super::reduce_common::{self, ComponentModes};
use crate::fe::element::MassKind;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::reduction::Method;

/// The stage.
pub struct ReduceFreeInterface;

/// Parameters.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
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

impl TypedStage for ReduceFreeInterface {
    type Params = Params;
    const KIND: &'static str = "reduce.free_interface";
    const SUMMARY: &'static str = "MacNeal/Rubin free-interface reduction with residual flexibility and inertia relief (3.26-3.39)";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        reduce_common::inputs()
    }

    fn outputs() -> Vec<PortSpec> {
        reduce_common::outputs()
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        modes(p).issues()
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        reduce_common::run(
            Method::FreeInterface {
                modes: modes(p).selection(),
            },
            p.mass,
            inputs,
        )
    }
}

fn modes(p: &Params) -> ComponentModes {
    ComponentModes {
        max_freq_hz: p.max_freq_hz,
        count: p.count,
    }
}
