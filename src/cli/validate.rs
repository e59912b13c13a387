//! `femu validate`: check a pipeline without running it: each stage's parameters and wiring,
//! then the checks that need what the importing stages give ([`crate::pipeline::preflight`]).

use super::load::load_sourced_plan;
use super::{Failure, PipelineArgs};
use crate::pipeline::{Diagnostics, preflight};

/// `femu validate`.
pub(super) fn run(p: &PipelineArgs) -> Result<u8, Failure> {
    let (src, plan) = load_sourced_plan(p)?;
    let found = preflight(&src, &plan);
    if !found.0.is_empty() {
        return Err(Diagnostics::capped(&src.file, found.0).into());
    }
    println!(
        "{}: valid pipeline `{}` with {} stages",
        p.pipeline.display(),
        plan.name,
        plan.nodes.len()
    );
    Ok(0)
}
