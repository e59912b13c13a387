//! `femu validate`: check a pipeline without running it.

use super::load::load_plan;
use super::{Failure, PipelineArgs};

/// `femu validate`.
pub(super) fn run(p: &PipelineArgs) -> Result<u8, Failure> {
    let plan = load_plan(p)?;
    println!(
        "{}: valid pipeline `{}` with {} stages",
        p.pipeline.display(),
        plan.name,
        plan.nodes.len()
    );
    Ok(0)
}
