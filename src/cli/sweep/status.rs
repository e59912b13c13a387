//! `femu sweep status`: every point's state, the Slurm jobs queued and the cache's share.

use super::{Failure, Where, open};
use crate::sweep::run::Standing;
use crate::sweep::{slurm, status_summary};
use std::path::Path;

/// `femu sweep status`.
pub(super) fn run(file: &Path, all: bool, w: &Where) -> Result<u8, Failure> {
    let (resolved, _cache, state) = open(file, w)?;
    // The sweep's Slurm jobs still queued, asked of squeue when there are any.
    let jobs = slurm::submitted_jobs(&state);
    let active = slurm::queued(&jobs).unwrap_or_default();
    let rows = status_summary(&resolved, &state, &active);
    let count = |f: fn(&Standing) -> bool| rows.iter().filter(|r| f(&r.1)).count();
    if !active.is_empty() {
        println!("slurm jobs queued or running: {}", active.join(", "));
    }
    println!(
        "sweep {} ({}): {} unique points: {} done, {} running, {} failed, {} pending",
        resolved.sweep.name(),
        state.root().display(),
        rows.len(),
        count(|s| *s == Standing::Done),
        count(|s| *s == Standing::Running),
        count(|s| matches!(s, Standing::Failed(_))),
        count(|s| *s == Standing::Pending),
    );
    for (name, standing, s) in &rows {
        match standing {
            Standing::Failed(m) => println!("  failed  {name}: {m}"),
            Standing::Running => {
                let who = s
                    .as_ref()
                    .map(|s| match &s.slurm_job {
                        Some(j) => format!("slurm job {j}"),
                        None => format!("pid {} on {}", s.pid, s.host),
                    })
                    .unwrap_or_default();
                println!("  running {name} ({who})");
            }
            Standing::Done if all => {
                let (e, r) = s.as_ref().map_or((0, 0), |s| (s.executed, s.requested));
                println!("  done    {name} ({e} of {r} stages executed)");
            }
            Standing::Pending if all => println!("  pending {name}"),
            _ => {}
        }
    }
    let runs = state.runs();
    if !runs.is_empty() {
        let req: usize = runs.iter().map(|r| r.requested).sum();
        let exe: usize = runs.iter().map(|r| r.executed).sum();
        let share = if req == 0 {
            0.0
        } else {
            100.0 * (1.0 - exe as f64 / req as f64)
        };
        println!(
            "cache: over {} runs, {req} stages requested, {exe} executed ({share:.0} % served by the cache)",
            runs.len()
        );
    }
    Ok(0)
}
