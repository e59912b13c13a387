//! `reduce.craig_bampton`: Craig-Bampton: constraint modes `−K_ii⁻¹K_ij` (sparse Cholesky) and fixed-interface normal modes up to a cut-off
//! (thesis 3.5–3.13: (3.5), (3.6), (3.7), (3.8), (3.9), (3.10), (3.11), (3.12), (3.13)), per
//! substructure in parallel, assembled at the junction DOFs (3.14).

use super::reduce_common::{self, ModalReductionParams};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::reduction::Method;

/// The stage.
pub struct ReduceCraigBampton;

/// Parameters: the component modes and the mass kind.
pub type Params = ModalReductionParams;

impl TypedStage for ReduceCraigBampton {
    type Params = Params;
    const KIND: &'static str = "reduce.craig_bampton";
    const SUMMARY: &'static str = "Craig-Bampton reduction: constraint modes plus fixed-interface normal modes per substructure (3.5-3.13)";
    const IMPL_VERSION: u32 = 2;

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
            Method::CraigBampton {
                modes: p.modes().selection(),
            },
            p.mass,
            p.interface_selection(),
            inputs,
        )
    }
}
