//! `femu sweep`: run a sweep on a backend, show its status, collect it, and the worker command
//! every local worker process and Slurm task runs.

use super::{CacheArgs, Failure};
use crate::cache::Cache;
use crate::sweep::run::{Standing, run_common};
use crate::sweep::slurm::{self, FollowOptions};
use crate::sweep::{
    LocalOptions, Resolved, StateDir, SweepError, SweepReport, collect, read_sweep, resolve,
    run_local, run_point, status_summary,
};
use clap::{Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Arguments of `femu sweep`.
#[derive(clap::Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub(super) struct SweepArgs {
    #[command(subcommand)]
    action: Option<SweepAction>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(clap::Args, Debug)]
struct Where {
    #[command(flatten)]
    c: CacheArgs,
    /// The sweep's state directory (default: CACHE_DIR/sweeps/NAME).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// New values for a swept parameter, or a fixed one: STAGE.with.PARAM=VALUE (YAML);
    /// repeatable. Give the same to `status` and `collect`.
    #[arg(long = "set", value_name = "STAGE.with.PARAM=VALUE")]
    sets: Vec<String>,
}

fn load(file: &Path, w: &Where) -> Result<crate::sweep::SourcedSweep, Failure> {
    let mut sweep = read_sweep(file).map_err(|d| fail(d.into()))?;
    sweep.apply_overrides(&w.sets).map_err(|d| fail(d.into()))?;
    Ok(sweep)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Backend {
    /// Worker processes on this machine.
    Local,
    /// A Slurm job array.
    Slurm,
}

#[derive(clap::Args, Debug)]
struct RunArgs {
    /// The sweep YAML file.
    #[arg(required = true)]
    file: Option<PathBuf>,
    /// Where the points run.
    #[arg(long, value_enum, default_value_t = Backend::Local)]
    backend: Backend,
    /// Worker processes at once (local backend; default: the number of cores).
    #[arg(long, short)]
    jobs: Option<usize>,
    /// Show the points (local) or print the batch scripts (slurm) without running anything.
    #[arg(long)]
    dry_run: bool,
    /// Do not collect after the run.
    #[arg(long)]
    no_collect: bool,
    /// Slurm: submit and return without following the jobs.
    #[arg(long)]
    no_follow: bool,
    /// Slurm: seconds between `squeue` polls.
    #[arg(long, default_value_t = 5.0)]
    poll: f64,
    /// Slurm: stop following after this many seconds (the jobs go on).
    #[arg(long)]
    timeout: Option<f64>,
    /// No progress lines.
    #[arg(long, short)]
    quiet: bool,
    #[command(flatten)]
    w: Where,
}

#[derive(Subcommand, Debug)]
enum SweepAction {
    /// Show every point's state: done, running, failed (with the message) or pending.
    Status {
        /// The sweep YAML file.
        file: PathBuf,
        /// List every point, not only the running and failed ones.
        #[arg(long, short)]
        all: bool,
        #[command(flatten)]
        w: Where,
    },
    /// Join the finished points' parameters and collected columns into one Parquet table.
    Collect {
        /// The sweep YAML file.
        file: PathBuf,
        /// Output directory (default: the state directory's `collected/`).
        #[arg(long, value_name = "DIR")]
        to: Option<PathBuf>,
        #[command(flatten)]
        w: Where,
    },
    /// Run points in this process (what each local worker and Slurm task does).
    RunPoint {
        /// The sweep YAML file.
        file: PathBuf,
        /// The point, by name.
        #[arg(long, conflicts_with_all = ["tasks", "common"])]
        point: Option<String>,
        /// Fail instead of running when the point's plan hash differs (the sweep changed).
        #[arg(long, value_name = "HASH")]
        plan_hash: Option<String>,
        /// A task list (one `name<TAB>plan hash` per line) ...
        #[arg(long, value_name = "FILE", requires = "task")]
        tasks: Option<PathBuf>,
        /// ... and the task index (the Slurm array task id) ...
        #[arg(long)]
        task: Option<usize>,
        /// ... running points TASK*K .. TASK*K+K-1.
        #[arg(long, default_value_t = 1)]
        per_task: usize,
        /// Compute the stages common to every unfinished point.
        #[arg(long, requires = "batch")]
        common: bool,
        /// Batch id of the Slurm submission (with --common).
        #[arg(long)]
        batch: Option<String>,
        #[command(flatten)]
        w: Where,
    },
}

fn fail(e: SweepError) -> Failure {
    let code = if e.is_bad_input() { 2 } else { 1 };
    match e {
        SweepError::Invalid(d) => Failure {
            code,
            error: d.into(),
        },
        e => Failure {
            code,
            error: e.into(),
        },
    }
}

fn open(file: &Path, w: &Where) -> Result<(Resolved, Cache, StateDir), Failure> {
    let sweep = load(file, w)?;
    let resolved = resolve(&sweep).map_err(|d| fail(d.into()))?;
    let cache_dir = w.c.dir();
    let cache = Cache::open(&cache_dir)?;
    let state = state_dir(&cache_dir, &sweep, w)?;
    Ok((resolved, cache, state))
}

/// The state directory: `--out DIR`, or the sweep's own directory in the cache.
fn state_dir(
    cache_dir: &Path,
    sweep: &crate::sweep::SourcedSweep,
    w: &Where,
) -> Result<StateDir, Failure> {
    match &w.out {
        Some(out) => StateDir::open(out),
        None => StateDir::for_sweep(cache_dir, &sweep.name()),
    }
    .map_err(fail)
}

/// `femu sweep …`.
pub(super) fn dispatch(args: SweepArgs) -> Result<u8, Failure> {
    match args.action {
        Some(SweepAction::Status { file, all, w }) => status(&file, all, &w),
        Some(SweepAction::Collect { file, to, w }) => {
            let (resolved, cache, state) = open(&file, &w)?;
            let to = to.unwrap_or_else(|| state.root().join("collected"));
            print_collect(&resolved, &state, &cache, &to)?;
            Ok(0)
        }
        Some(SweepAction::RunPoint {
            file,
            point,
            plan_hash,
            tasks,
            task,
            per_task,
            common,
            batch,
            w,
        }) => {
            let sweep = load(&file, &w)?;
            let cache_dir = w.c.dir();
            let cache = Cache::open(&cache_dir)?;
            let state = state_dir(&cache_dir, &sweep, &w)?;
            if common {
                let (requested, executed) = run_common(&sweep, &cache, &state).map_err(fail)?;
                let record = serde_json::json!({"requested": requested, "executed": executed});
                let batch = batch.unwrap_or_default();
                crate::sweep::state::write_atomic(
                    &slurm::common_record_path(&state, &batch),
                    record.to_string().as_bytes(),
                )
                .map_err(fail)?;
                println!("common stages: {requested} requested, {executed} executed");
                return Ok(0);
            }
            let points: Vec<(String, Option<String>)> = match (point, tasks, task) {
                (Some(p), _, _) => vec![(p, plan_hash)],
                (None, Some(list), Some(t)) => {
                    let text = std::fs::read_to_string(&list)
                        .map_err(|e| anyhow::anyhow!("reading {}: {e}", list.display()))?;
                    let k = per_task.max(1);
                    text.lines()
                        .skip(t * k)
                        .take(k)
                        .map(|l| match l.split_once('\t') {
                            Some((n, h)) => (n.to_string(), Some(h.to_string())),
                            None => (l.to_string(), None),
                        })
                        .collect()
                }
                _ => {
                    return Err(Failure {
                        code: 2,
                        error: anyhow::anyhow!(
                            "name the work: --point NAME, --tasks FILE --task I, or --common --batch B"
                        ),
                    });
                }
            };
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
        None => run(args.run),
    }
}

fn run(a: RunArgs) -> Result<u8, Failure> {
    let Some(file) = a.file.clone() else {
        return Err(Failure {
            code: 2,
            error: anyhow::anyhow!("name the sweep file: femu sweep FILE"),
        });
    };
    let (resolved, cache, state) = open(&file, &a.w)?;
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
    let exe = std::env::current_exe().map_err(|e| anyhow::anyhow!("locating femu: {e}"))?;
    let report = match a.backend {
        Backend::Local if a.dry_run => {
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
            return Ok(0);
        }
        Backend::Local => {
            let jobs = a
                .jobs
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
            let r = run_local(
                &resolved,
                &cache,
                &state,
                &LocalOptions {
                    jobs,
                    exe,
                    progress: !a.quiet,
                },
            )
            .map_err(fail)?;
            println!("local backend, {jobs} workers:");
            r
        }
        Backend::Slurm => {
            let batch = format!(
                "b{}-{}",
                crate::sweep::state::now_unix(),
                std::process::id()
            );
            let sub =
                slurm::prepare(&resolved, &state, cache.root(), &exe, &batch).map_err(fail)?;
            if a.dry_run {
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
                return Ok(0);
            }
            if sub.points.is_empty() {
                println!("every point is done");
                SweepReport::default()
            } else {
                let _lock = state.lock().map_err(fail)?;
                slurm::ensure_idle(&state).map_err(fail)?;
                let jobs = slurm::submit(&sub, &state).map_err(fail)?;
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
                    return Ok(0);
                }
                slurm::follow(
                    &sub,
                    &jobs,
                    &state,
                    &FollowOptions {
                        poll: Duration::from_secs_f64(a.poll.max(0.05)),
                        timeout: a.timeout.map(|t| Duration::from_secs_f64(t.max(0.0))),
                        progress: !a.quiet,
                    },
                )
                .map_err(fail)?
            }
        }
    };
    let done_before = state_done_count(&resolved, &state) - report.ran;
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
    let has_collect = !resolved.sweep.spec.collect.is_empty();
    if has_collect && !a.no_collect && state_done_count(&resolved, &state) > 0 {
        print_collect(&resolved, &state, &cache, &state.root().join("collected"))?;
    }
    Ok(if report.failed.is_empty() { 0 } else { 1 })
}

fn state_done_count(resolved: &Resolved, state: &StateDir) -> usize {
    resolved
        .unique
        .iter()
        .filter(|u| state.is_done(&u.point.name, &u.plan_hash))
        .count()
}

fn print_collect(
    resolved: &Resolved,
    state: &StateDir,
    cache: &Cache,
    to: &Path,
) -> Result<(), Failure> {
    let c = collect(resolved, state, cache, to).map_err(fail)?;
    println!(
        "collected {} points, {} rows into {} (digest {})",
        c.points,
        c.table.rows(),
        c.path.display(),
        &c.digest[..16]
    );
    if !c.missing.is_empty() {
        println!(
            "  {} points are not finished and not in the table (`femu sweep status`)",
            c.missing.len()
        );
    }
    for p in &c.plots {
        println!("  plot {}", p.display());
    }
    Ok(())
}

fn status(file: &Path, all: bool, w: &Where) -> Result<u8, Failure> {
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
