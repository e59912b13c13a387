//! Running points: one point in this process ([`run_point`], what a worker or a Slurm task
//! does), and the local backend ([`run_local`]).
//!
//! The local backend runs each point in its own worker process — the current `femu` executable
//! with `sweep run-point` — rather than in threads of this process. A worker is exactly what a
//! Slurm task runs, so both backends share one code path and one on-disk protocol (status files,
//! cache); a point that aborts, runs out of memory or is killed takes down only its worker and
//! is recorded as failed; and the cache's cross-process safety (atomic renames) is what the
//! workers rely on, the same as on a cluster's shared filesystem. Starting a worker costs a few
//! milliseconds, small against any stage worth sweeping.
//!
//! Before the workers start, the stages common to every point (the models, the reductions, the
//! clean "measured" FRFs) are computed once in this process, so that parallel workers find them
//! in the cache instead of computing them side by side.

use super::SweepError;
use super::expand::{Resolved, base_pipeline, expand, plan_point};
use super::spec::SourcedSweep;
use super::state::{
    PointState, PointStatus, RunRecord, StageRecord, StateDir, host_name, now_unix, pid_alive,
};
use crate::cache::Cache;
use crate::pipeline::lock::LockFile;
use crate::pipeline::{ProgressMode, RunOptions, Status, execute};
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Runs one point of a sweep in this process and records its status. A failing pipeline is a
/// `failed` status, not an error; errors are for what prevents recording at all.
pub fn run_point(
    sweep: &SourcedSweep,
    point: &str,
    expect_plan: Option<&str>,
    cache: &Cache,
    state: &StateDir,
) -> Result<PointStatus, SweepError> {
    let base = base_pipeline(sweep)?;
    let expansion = expand(sweep, &base)?;
    let Some(p) = expansion.points.iter().find(|p| p.name == point) else {
        return Err(SweepError::Usage(format!(
            "the sweep {} has no point `{point}` ({} points; `femu sweep FILE --dry-run` lists them)",
            sweep.file,
            expansion.points.len()
        )));
    };
    let planned = plan_point(&base, p, &sweep.spec.only)?;
    let t0 = Instant::now();
    let mut status = PointStatus {
        point: point.to_string(),
        state: PointState::Running,
        plan_hash: planned.plan_hash.clone(),
        overrides: p.overrides.clone(),
        host: host_name(),
        pid: std::process::id(),
        slurm_job: slurm_task_id(),
        started_unix: now_unix(),
        seconds: 0.0,
        requested: planned.plan.nodes.len(),
        executed: 0,
        message: None,
        stages: BTreeMap::new(),
    };
    if let Some(want) = expect_plan
        && want != planned.plan_hash
    {
        status.state = PointState::Failed;
        status.message = Some(
                "the sweep file or its pipeline changed after the sweep started; run `femu sweep` again"
                    .into(),
            );
        state.write_status(&status)?;
        return Ok(status);
    }
    state.write_status(&status)?;
    let opts = RunOptions {
        progress: ProgressMode::Quiet,
        ..Default::default()
    };
    match execute(&planned.plan, cache, &opts) {
        Ok(report) => {
            // The point's lock file keeps its entries through `femu cache gc`.
            let lock = LockFile::from_run(&planned.plan, &report);
            let lock_name = format!("{}@{}", sweep.name(), point_file_name(point));
            match lock.record_in(cache, &lock_name) {
                Ok(None) => {}
                Ok(Some(w)) => status.message = Some(format!("warning: {w}")),
                Err(e) => status.message = Some(format!("warning: lock file not written: {e}")),
            }
            status.executed = report.executed();
            status.stages = report
                .stages
                .iter()
                .map(|s| {
                    let st = match s.status {
                        Status::Ran => "ran",
                        Status::Cached => "cached",
                        Status::Recovered => "recomputed",
                    };
                    (
                        s.name.clone(),
                        StageRecord {
                            kind: s.kind.clone(),
                            key: s.key.clone(),
                            status: st.into(),
                            outputs: s.outputs.clone(),
                        },
                    )
                })
                .collect();
            status.state = PointState::Done;
        }
        Err(e) => {
            status.state = PointState::Failed;
            status.message = Some(e.to_string());
        }
    }
    status.seconds = t0.elapsed().as_secs_f64();
    state.write_status(&status)?;
    Ok(status)
}

/// A point name as a file name (names are made of safe characters already; this guards `/`).
fn point_file_name(point: &str) -> String {
    point.replace(['/', '\\'], "_")
}

/// `JOBID_TASK` when running as a Slurm array task.
fn slurm_task_id() -> Option<String> {
    let job = std::env::var("SLURM_ARRAY_JOB_ID")
        .or_else(|_| std::env::var("SLURM_JOB_ID"))
        .ok()?;
    Some(match std::env::var("SLURM_ARRAY_TASK_ID") {
        Ok(t) => format!("{job}_{t}"),
        Err(_) => job,
    })
}

/// Options of the local backend.
#[derive(Clone, Debug)]
pub struct LocalOptions {
    /// Worker processes at once.
    pub jobs: usize,
    /// The femu executable the workers run.
    pub exe: PathBuf,
    /// Show progress on standard error.
    pub progress: bool,
}

/// What one invocation of a backend did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SweepReport {
    /// Points in the expansion (after exclusion).
    pub points: usize,
    /// Unique points (after dedupe).
    pub unique: usize,
    /// Points already finished before this invocation.
    pub already_done: usize,
    /// Points run now that finished.
    pub ran: usize,
    /// Points run now that failed: name and message.
    pub failed: Vec<(String, String)>,
    /// Stages requested by the points run now (plus the common stages computed first).
    pub requested: usize,
    /// Stages computed by this invocation.
    pub executed: usize,
    /// Wall time.
    pub seconds: f64,
}

impl SweepReport {
    /// Points per minute of this invocation.
    pub fn points_per_minute(&self) -> f64 {
        let n = self.ran + self.failed.len();
        if self.seconds > 0.0 {
            n as f64 * 60.0 / self.seconds
        } else {
            0.0
        }
    }

    /// Share of requested stages the cache served, in [0, 1].
    pub fn cache_share(&self) -> f64 {
        if self.requested == 0 {
            0.0
        } else {
            1.0 - self.executed as f64 / self.requested as f64
        }
    }
}

/// The unique points not yet finished, in expansion order.
pub fn pending<'a>(resolved: &'a Resolved, state: &StateDir) -> Vec<&'a super::PlannedPoint> {
    resolved
        .unique
        .iter()
        .filter(|u| !state.is_done(&u.point.name, &u.plan_hash))
        .collect()
}

/// Computes the stages common to every pending point once, in this process. Returns (requested,
/// executed).
pub fn warm_up(
    resolved: &Resolved,
    todo: &[&super::PlannedPoint],
    cache: &Cache,
) -> Result<(usize, usize), SweepError> {
    let (Some(first), false) = (todo.first(), resolved.common.is_empty()) else {
        return Ok((0, 0));
    };
    if todo.len() < 2 {
        return Ok((0, 0));
    }
    let opts = RunOptions {
        only: resolved.common.clone(),
        progress: ProgressMode::Quiet,
        ..Default::default()
    };
    // A failure here shows again, with its message, in every point that needs the stage.
    match execute(&first.plan, cache, &opts) {
        Ok(r) => Ok((r.stages.len(), r.executed())),
        Err(_) => Ok((0, 0)),
    }
}

/// Computes the stages common to the unfinished points (what the Slurm backend's first job
/// does). Returns (requested, executed).
pub fn run_common(
    sweep: &SourcedSweep,
    cache: &Cache,
    state: &StateDir,
) -> Result<(usize, usize), SweepError> {
    let resolved = super::expand::resolve(sweep)?;
    let todo = pending(&resolved, state);
    warm_up(&resolved, &todo, cache)
}

/// Runs the unfinished points of a sweep in worker processes.
pub fn run_local(
    resolved: &Resolved,
    cache: &Cache,
    state: &StateDir,
    opts: &LocalOptions,
) -> Result<SweepReport, SweepError> {
    let _lock = state.lock()?;
    let t0 = Instant::now();
    let todo = pending(resolved, state);
    let mut report = SweepReport {
        points: resolved.expansion.points.len(),
        unique: resolved.unique.len(),
        already_done: resolved.unique.len() - todo.len(),
        ..Default::default()
    };
    let (req, exe) = warm_up(resolved, &todo, cache)?;
    report.requested += req;
    report.executed += exe;
    let jobs = opts.jobs.max(1);
    let threads = std::env::var("RAYON_NUM_THREADS").ok().unwrap_or_else(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (cores / jobs).max(1).to_string()
    });
    let sweep_file =
        std::fs::canonicalize(&resolved.sweep.path).map_err(|source| SweepError::Io {
            path: resolved.sweep.path.clone(),
            source,
        })?;
    let progress = WorkerProgress {
        bar: progress_bar(opts.progress, todo.len()),
        show: opts.progress,
        step: todo.len().div_ceil(10).max(1),
        total: todo.len(),
        t0,
    };
    let mut queue = todo.iter();
    let mut running: Vec<(Child, &super::PlannedPoint)> = Vec::new();
    loop {
        while running.len() < jobs {
            let Some(p) = queue.next() else { break };
            let child = spawn_worker(
                &opts.exe,
                &sweep_file,
                p,
                cache.root(),
                state,
                &threads,
                &resolved.sweep.overrides,
            )?;
            running.push((child, p));
        }
        if running.is_empty() {
            break;
        }
        let mut i = 0;
        let mut finished_any = false;
        while i < running.len() {
            let exited = running[i]
                .0
                .try_wait()
                .map_err(|source| SweepError::Spawn {
                    exe: opts.exe.clone(),
                    source,
                })?;
            match exited {
                None => i += 1,
                Some(code) => {
                    let (_, p) = running.swap_remove(i);
                    finished_any = true;
                    let s = finish_worker(state, p, code)?;
                    progress.record(&mut report, &p.point.name, s);
                }
            }
        }
        if !finished_any {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
    if let Some(b) = progress.bar {
        b.finish_and_clear();
    }
    report.seconds = t0.elapsed().as_secs_f64();
    state.append_run(&RunRecord {
        backend: "local".into(),
        points: report.ran + report.failed.len(),
        failed: report.failed.len(),
        requested: report.requested,
        executed: report.executed,
        seconds: report.seconds,
    })?;
    Ok(report)
}

/// Progress of the local workers: a bar on a terminal, else (when shown) lines on stderr.
struct WorkerProgress {
    bar: Option<indicatif::ProgressBar>,
    show: bool,
    /// Points between plain progress lines: a tenth of the way.
    step: usize,
    total: usize,
    t0: Instant,
}

impl WorkerProgress {
    /// Counts a finished point in the report and shows the progress.
    fn record(&self, report: &mut SweepReport, name: &str, s: PointStatus) {
        report.requested += s.requested;
        report.executed += s.executed;
        if s.state == PointState::Done {
            report.ran += 1;
        } else {
            let msg = s.message.clone().unwrap_or_default();
            // The first few failures as they happen; all of them in the report.
            if report.failed.len() < 3 {
                let line = format!("point {name} failed: {msg}");
                match &self.bar {
                    Some(b) => b.println(line),
                    None if self.show => eprintln!("[femu] {line}"),
                    None => {}
                }
            }
            report.failed.push((name.to_string(), msg));
        }
        let finished = report.ran + report.failed.len();
        match &self.bar {
            Some(b) => {
                b.set_message(format!("{} failed", report.failed.len()));
                b.inc(1)
            }
            // Plain lines at every tenth of the way, for logs.
            None if self.show && finished.is_multiple_of(self.step) => {
                let elapsed = self.t0.elapsed().as_secs_f64();
                let left = elapsed / finished as f64 * (self.total - finished) as f64;
                eprintln!(
                    "[femu] {finished}/{} points ({} failed), {elapsed:.1} s, about {left:.0} s left",
                    self.total,
                    report.failed.len(),
                )
            }
            None => {}
        }
    }
}

fn progress_bar(show: bool, n: usize) -> Option<indicatif::ProgressBar> {
    if !show || !std::io::stderr().is_terminal() || n == 0 {
        return None;
    }
    let b = indicatif::ProgressBar::new(n as u64);
    b.set_message("0 failed");
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{bar:40} {pos}/{len} points, {msg}  {elapsed} ({eta} left)",
    ) {
        b.set_style(style);
    }
    Some(b)
}

fn spawn_worker(
    exe: &Path,
    sweep_file: &Path,
    p: &super::PlannedPoint,
    cache_dir: &Path,
    state: &StateDir,
    threads: &str,
    sets: &[String],
) -> Result<Child, SweepError> {
    super::state::check_point_name(&p.point.name)?;
    let dir = state.point_dir(&p.point.name);
    std::fs::create_dir_all(&dir).map_err(|source| SweepError::Io {
        path: dir.clone(),
        source,
    })?;
    let log_path = state.log_path(&p.point.name);
    let log = std::fs::File::create(&log_path).map_err(|source| SweepError::Io {
        path: log_path,
        source,
    })?;
    Command::new(exe)
        .arg("sweep")
        .arg("run-point")
        .arg(sweep_file)
        .arg("--point")
        .arg(&p.point.name)
        .arg("--plan-hash")
        .arg(&p.plan_hash)
        .args(sets.iter().flat_map(|s| ["--set", s.as_str()]))
        .arg("--cache-dir")
        .arg(cache_dir)
        .arg("--out")
        .arg(state.root())
        .env("RAYON_NUM_THREADS", threads)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(log))
        .spawn()
        .map_err(|source| SweepError::Spawn {
            exe: exe.to_path_buf(),
            source,
        })
}

/// Reads the status a worker left; a worker that died without one is recorded as failed.
fn finish_worker(
    state: &StateDir,
    p: &super::PlannedPoint,
    code: std::process::ExitStatus,
) -> Result<PointStatus, SweepError> {
    if let Some(s) = state.status(&p.point.name)
        && s.state != PointState::Running
        && s.plan_hash == p.plan_hash
    {
        return Ok(s);
    }
    let log = std::fs::read_to_string(state.log_path(&p.point.name)).unwrap_or_default();
    let tail: Vec<&str> = log.lines().rev().take(5).collect();
    let tail: Vec<&str> = tail.into_iter().rev().collect();
    let s = PointStatus {
        point: p.point.name.clone(),
        state: PointState::Failed,
        plan_hash: p.plan_hash.clone(),
        overrides: p.point.overrides.clone(),
        host: host_name(),
        pid: 0,
        slurm_job: None,
        started_unix: now_unix(),
        seconds: 0.0,
        requested: p.plan.nodes.len(),
        executed: 0,
        message: Some(format!(
            "the worker ended ({code}) without recording a result{}",
            if tail.is_empty() {
                String::new()
            } else {
                format!(": {}", tail.join(" | "))
            }
        )),
        stages: BTreeMap::new(),
    };
    state.write_status(&s)?;
    Ok(s)
}

/// How a point stands, as `femu sweep status` shows it.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Standing {
    /// Finished with the current plan.
    Done,
    /// A worker is running it now.
    Running,
    /// Failed, with the message.
    Failed(String),
    /// Never started, interrupted, or finished with another plan.
    Pending,
}

/// Every unique point's standing, in expansion order. `active_jobs` are Slurm job ids still
/// queued or running (a `running` status from such a job counts as running).
pub fn status_summary(
    resolved: &Resolved,
    state: &StateDir,
    active_jobs: &[String],
) -> Vec<(String, Standing, Option<PointStatus>)> {
    let here = host_name();
    resolved
        .unique
        .iter()
        .map(|u| {
            let s = state.status(&u.point.name);
            let standing = match &s {
                None => Standing::Pending,
                Some(s) if s.plan_hash != u.plan_hash => Standing::Pending,
                Some(s) => match s.state {
                    PointState::Done => Standing::Done,
                    PointState::Failed => Standing::Failed(s.message.clone().unwrap_or_default()),
                    PointState::Running => {
                        let by_slurm = s.slurm_job.as_ref().is_some_and(|j| {
                            let job = j.split('_').next().unwrap_or(j);
                            active_jobs.iter().any(|a| a == job || a == j)
                        });
                        let by_pid = s.slurm_job.is_none() && s.host == here && pid_alive(s.pid);
                        if by_slurm || by_pid {
                            Standing::Running
                        } else {
                            Standing::Pending
                        }
                    }
                },
            };
            (u.point.name.clone(), standing, s)
        })
        .collect()
}
