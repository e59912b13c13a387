//! The pipeline named on the command line: its read policy, overrides and plan.

use super::PipelineArgs;
use crate::pipeline::{Diagnostic, Diagnostics, Plan, SourcedSpec, plan, read_pipeline};
use crate::stages::registry;
use std::path::PathBuf;

impl PipelineArgs {
    /// Sets the process-wide policy for reading the files a pipeline names.
    fn set_read_policy(&self) -> Result<(), Diagnostics> {
        use crate::core::input::{InputPolicy, parse_byte_count, set_policy};
        let fail = |m: String| Diagnostics(vec![Diagnostic::new("femu", m)]);
        let mut policy = InputPolicy::from_env().map_err(|e| fail(e.to_string()))?;
        if let Some(text) = &self.max_input_bytes {
            policy.max_bytes = parse_byte_count(text).ok_or_else(|| {
                fail(format!(
                    "--max-input-bytes {text}: give a positive byte count such as 500M or 4G"
                ))
            })?;
        }
        if self.confine_reads {
            let dir = match self.pipeline.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            policy = policy
                .confined_to(&dir)
                .map_err(|e| fail(format!("--confine-reads: {e}")))?;
        }
        set_policy(policy);
        Ok(())
    }
}

pub(super) fn load_plan(p: &PipelineArgs) -> Result<Plan, Diagnostics> {
    load_sourced_plan(p).map(|(_, plan)| plan)
}

/// The plan with the file it came from, to locate errors found while running.
pub(super) fn load_sourced_plan(p: &PipelineArgs) -> Result<(SourcedSpec, Plan), Diagnostics> {
    let file = p.pipeline.display().to_string();
    let cap = |d: Diagnostics| Diagnostics::capped(&file, d.0);
    p.set_read_policy()?;
    let mut src = read_pipeline(&p.pipeline).map_err(cap)?;
    src.apply_overrides(&p.sets).map_err(cap)?;
    let plan = plan(&src, &registry()).map_err(cap)?;
    Ok((src, plan))
}
