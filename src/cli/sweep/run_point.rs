//! `femu sweep run-point`: run named points, a slice of a task list, or the common stages, in
//! this process (what each local worker and Slurm task does).

use super::{Failure, RunPointArgs, fail, load, state_dir};
use crate::cache::Cache;
use crate::sweep::run::run_common;
use crate::sweep::{SourcedSweep, StateDir, run_point, slurm};

/// `femu sweep run-point`.
pub(super) fn run(a: RunPointArgs) -> Result<u8, Failure> {
    let sweep = load(&a.file, &a.w)?;
    let cache_dir = a.w.c.dir();
    let cache = Cache::open(&cache_dir)?;
    let state = state_dir(&cache_dir, &sweep, &a.w)?;
    if a.common {
        return common(&sweep, &cache, &state, a.batch.unwrap_or_default());
    }
    let points = work(a)?;
    let mut failed = 0;
    for (name, hash) in points {
        let s = run_point(&sweep, &name, hash.as_deref(), &cache, &state).map_err(fail)?;
        match &s.message {
            Some(m) if s.state != crate::sweep::PointState::Done => {
                failed += 1;
                eprintln!("point {name} failed: {m}");
            }
            _ => println!(
                "point {name}: done, {} of {} stages executed",
                s.executed, s.requested
            ),
        }
    }
    Ok(if failed == 0 { 0 } else { 1 })
}

/// `--common --batch B`: the stages every unfinished point shares, recorded for the batch.
fn common(
    sweep: &SourcedSweep,
    cache: &Cache,
    state: &StateDir,
    batch: String,
) -> Result<u8, Failure> {
    let (requested, executed) = run_common(sweep, cache, state).map_err(fail)?;
    let record = serde_json::json!({"requested": requested, "executed": executed});
    crate::sweep::state::write_atomic(
        &slurm::common_record_path(state, &batch),
        record.to_string().as_bytes(),
    )
    .map_err(fail)?;
    println!("common stages: {requested} requested, {executed} executed");
    Ok(0)
}

/// The points to run, with the plan hash each must have: `--point NAME [--plan-hash H]`, or
/// lines TASK*K .. TASK*K+K-1 of `--tasks FILE` (`name<TAB>plan hash`).
fn work(a: RunPointArgs) -> Result<Vec<(String, Option<String>)>, Failure> {
    match (a.point, a.tasks, a.task) {
        (Some(p), _, _) => Ok(vec![(p, a.plan_hash)]),
        (None, Some(list), Some(t)) => {
            let text = std::fs::read_to_string(&list)
                .map_err(|e| anyhow::anyhow!("reading {}: {e}", list.display()))?;
            let k = a.per_task.max(1);
            Ok(text
                .lines()
                .skip(t * k)
                .take(k)
                .map(|l| match l.split_once('\t') {
                    Some((n, h)) => (n.to_string(), Some(h.to_string())),
                    None => (l.to_string(), None),
                })
                .collect())
        }
        _ => Err(Failure {
            code: 2,
            error: anyhow::anyhow!(
                "name the work: --point NAME, --tasks FILE --task I, or --common --batch B"
            ),
        }),
    }
}
