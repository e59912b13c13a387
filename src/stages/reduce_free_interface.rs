//! `reduce.free_interface`: MacNeal/Rubin free interface: free modes plus residual flexibility, inertia-relief projection
//! for floating substructures (thesis 3.22–3.39: (3.22), (3.23), (3.24), (3.25), (3.26), (3.27),
//! (3.28), (3.29), (3.30), (3.31), (3.32), (3.33), (3.34), (3.35), (3.36), (3.37), (3.38), (3.39)),
//! assembled at the junction DOFs (3.14).

use super::reduce_common::{self, ModalReductionParams};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::reduction::Method;

/// The stage.
pub struct ReduceFreeInterface;

/// Parameters: the component modes and the mass kind.
pub type Params = ModalReductionParams;

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
        p.issues()
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        reduce_common::run(
            Method::FreeInterface {
                modes: p.modes().selection(),
            },
            p.mass,
            p.interface_selection(),
            inputs,
        )
    }
}
