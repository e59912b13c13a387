//! `femu explain`: the resolved plan with wiring, parameters and the last run's cache state.

use super::load::load_plan;
use super::{CacheArgs, Failure, PipelineArgs};
use crate::cache::Cache;
use crate::pipeline::Plan;
use crate::pipeline::lock::LockFile;
use std::path::Path;

/// `femu explain`.
pub(super) fn run(p: &PipelineArgs, c: &CacheArgs) -> Result<u8, Failure> {
    let plan = load_plan(p)?;
    explain(&plan, &c.dir());
    Ok(0)
}

fn explain(plan: &Plan, cache_dir: &Path) {
    println!("pipeline `{}`: {}", plan.name, plan.description.trim());
    let cache = Cache::open(cache_dir).ok();
    for (i, n) in plan.nodes.iter().enumerate() {
        println!(
            "\n{}. {} ({}) — {}",
            i + 1,
            n.name,
            n.stage.kind(),
            n.stage.summary()
        );
        if !n.description.is_empty() {
            println!("   {}", n.description.trim());
        }
        for (port, r) in &n.inputs {
            println!("   in  {port} <- {}.{}", plan.nodes[r.node].name, r.port);
        }
        for p in n.stage.outputs() {
            println!("   out {} ({})", p.name, p.kind);
        }
        let params = serde_yaml::to_string(&n.params).unwrap_or_default();
        for line in params.lines() {
            println!("   | {line}");
        }
        if let Some(lock) = cache
            .as_ref()
            .and_then(|c| c.lock_path(&plan.name).ok())
            .and_then(|p| std::fs::read_to_string(p).ok())
        {
            if let Ok(lock) = serde_json::from_str::<LockFile>(&lock) {
                if let Some(s) = lock.stages.get(&n.name) {
                    println!(
                        "   last run: key {} (params {})",
                        &s.key[..16],
                        if s.params == n.params {
                            "unchanged"
                        } else {
                            "changed since"
                        }
                    );
                }
            }
        }
    }
}
