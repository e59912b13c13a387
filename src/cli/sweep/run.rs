//! `femu sweep FILE`: run a sweep's points on the local or the Slurm backend, report, collect.

use super::collect::print_collect;
use super::{Backend, Failure, RunArgs, fail, open};
use crate::cache::Cache;
use crate::sweep::slurm::{self, FollowOptions};
use crate::sweep::{LocalOptions, Resolved, StateDir, SweepReport, run_local};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// `femu sweep FILE`.
pub(super) fn run(a: RunArgs) -> Result<u8, Failure> {
    let Some(file) = a.file.clone() else {
        return Err(Failure {
            code: 2,
            error: anyhow::anyhow!("name the sweep file: femu sweep FILE"),
        });
    };
    let (resolved, cache, state) = open(&file, &a.w)?;
    print_plan(&resolved);
    let exe = std::env::current_exe().map_err(|e| anyhow::anyhow!("locating femu: {e}"))?;
    let report = match a.backend {
        Backend::Local if a.dry_run => {
            print_local_dry_run(&resolved, &state);
            return Ok(0);
        }
        Backend::Local => local(&a, &resolved, &cache, &state, exe)?,
        Backend::Slurm => match slurm(&a, &file, &resolved, &cache, &state, &exe)? {
            Some(report) => report,
            None => return Ok(0),
        },
    };
    print_report(&report, &resolved, &state, &file);
    let has_collect = !resolved.sweep.spec.collect.is_empty();
    if has_collect && !a.no_collect && state_done_count(&resolved, &state) > 0 {
        print_collect(&resolved, &state, &cache, &state.root().join("collected"))?;
    }
    Ok(if report.failed.is_empty() { 0 } else { 1 })
}

/// The points, the exclusions, the duplicates and the stages computed once for all.
fn print_plan(resolved: &Resolved) {
    let x = &resolved.expansion;
    println!(
        "sweep {}: {} points ({} excluded), {} unique{}",
        resolved.sweep.name(),
        x.points.len(),
        x.excluded,
        resolved.unique.len(),
        if resolved.common.is_empty() {
            String::new()
        } else {
            format!("; computed once for all: {}", resolved.common.join(", "))
        }
    );
    for (dup, kept) in &resolved.duplicates {
        println!("  {dup}: same plan as {kept}, not run again");
    }
}

/// `--dry-run` on the local backend: each unique point's state and its `femu run` command.
fn print_local_dry_run(resolved: &Resolved, state: &StateDir) {
    let pipeline = resolved.sweep.pipeline_path();
    for u in &resolved.unique {
        let done = state.is_done(&u.point.name, &u.plan_hash);
        let sets: Vec<String> = u
            .point
            .overrides
            .iter()
            .map(|o| format!("--set {}", slurm::sh_quote(o)))
            .collect();
        println!(
            "{:<7} {}\n        femu run {} {}",
            if done { "done" } else { "pending" },
            u.point.name,
            pipeline.display(),
            sets.join(" ")
        );
    }
}

/// The points on worker processes of this machine.
fn local(
    a: &RunArgs,
    resolved: &Resolved,
    cache: &Cache,
    state: &StateDir,
    exe: PathBuf,
) -> Result<SweepReport, Failure> {
    let jobs = a
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let r = run_local(
        resolved,
        cache,
        state,
        &LocalOptions {
            jobs,
            exe,
            progress: !a.quiet,
        },
    )
    .map_err(fail)?;
    println!("local backend, {jobs} workers:");
    Ok(r)
}

/// The points as a Slurm job array: the batch scripts (`--dry-run`), or submitted and, unless
/// `--no-follow`, followed to the end. `None` when nothing is left to report.
fn slurm(
    a: &RunArgs,
    file: &Path,
    resolved: &Resolved,
    cache: &Cache,
    state: &StateDir,
    exe: &Path,
) -> Result<Option<SweepReport>, Failure> {
    let batch = format!(
        "b{}-{}",
        crate::sweep::state::now_unix(),
        std::process::id()
    );
    let sub = slurm::prepare(resolved, state, cache.root(), exe, &batch).map_err(fail)?;
    if a.dry_run {
        print_slurm_dry_run(&sub);
        return Ok(None);
    }
    if sub.points.is_empty() {
        println!("every point is done");
        return Ok(Some(SweepReport::default()));
    }
    let _lock = state.lock().map_err(fail)?;
    slurm::ensure_idle(state).map_err(fail)?;
    let jobs = slurm::submit(&sub, state).map_err(fail)?;
    println!(
        "submitted {} points in {} array tasks: job {}",
        sub.points.len(),
        sub.tasks,
        jobs.join(", ")
    );
    if a.no_follow {
        println!(
            "follow with `femu sweep status {}`; collect with `femu sweep collect {}`",
            file.display(),
            file.display()
        );
        return Ok(None);
    }
    let report = slurm::follow(
        &sub,
        &jobs,
        state,
        &FollowOptions {
            poll: Duration::from_secs_f64(a.poll.max(0.05)),
            timeout: a.timeout.map(|t| Duration::from_secs_f64(t.max(0.0))),
            progress: !a.quiet,
        },
    )
    .map_err(fail)?;
    Ok(Some(report))
}

/// `--dry-run` on Slurm: the batch scripts in submission order.
fn print_slurm_dry_run(sub: &slurm::Submission) {
    if let Some(c) = &sub.common_script {
        println!("# ---- {}_common.sbatch (submitted first)", sub.batch);
        print!("{c}");
    }
    println!(
        "# ---- {}.sbatch{}; task list {} with {} point(s)",
        sub.batch,
        if sub.common_script.is_some() {
            " (submitted with --dependency=afterany on the first)"
        } else {
            ""
        },
        sub.tasks_file.display(),
        sub.points.len()
    );
    print!("{}", sub.array_script);
}

/// Points run and failed, time, the cache's share, and the first ten failures.
fn print_report(report: &SweepReport, resolved: &Resolved, state: &StateDir, file: &Path) {
    let done_before = state_done_count(resolved, state) - report.ran;
    println!(
        "  {} points run, {} failed, {} were done already; {:.2} s ({:.0} points/min)",
        report.ran,
        report.failed.len(),
        done_before,
        report.seconds,
        report.points_per_minute()
    );
    println!(
        "  cache: {} stages requested, {} executed ({:.0} % served by the cache)",
        report.requested,
        report.executed,
        100.0 * report.cache_share()
    );
    for (name, msg) in report.failed.iter().take(10) {
        println!("  FAILED {name}: {msg}");
    }
    if report.failed.len() > 10 {
        println!(
            "  … and {} more failures: `femu sweep status {}`",
            report.failed.len() - 10,
            file.display()
        );
    }
}

fn state_done_count(resolved: &Resolved, state: &StateDir) -> usize {
    resolved
        .unique
        .iter()
        .filter(|u| state.is_done(&u.point.name, &u.plan_hash))
        .count()
}
