//! `femu sweep`: run a sweep on a backend, show its status, collect it, and the worker command
//! every local worker process and Slurm task runs. One file per action.

use super::{CacheArgs, Failure};
use crate::cache::Cache;
use crate::sweep::{Resolved, StateDir, SweepError, read_sweep, resolve};
use clap::{Subcommand, ValueEnum};
use std::path::{Path, PathBuf};

mod collect;
mod run;
mod run_point;
mod status;

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
    RunPoint(RunPointArgs),
}

#[derive(clap::Args, Debug)]
struct RunPointArgs {
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
        Some(SweepAction::Status { file, all, w }) => status::run(&file, all, &w),
        Some(SweepAction::Collect { file, to, w }) => collect::run(&file, to, &w),
        Some(SweepAction::RunPoint(a)) => run_point::run(a),
        None => run::run(args.run),
    }
}
