//! The Slurm backend: a job array whose tasks each run `femu sweep run-point` on their points
//! against a cache on a shared filesystem, after one job that computes the stages common to every
//! point (the array depends on it with `afterany`, so a failure there is reported by the points
//! that need the stage rather than hanging the array).
//!
//! Submission is `sbatch --parsable`; following polls `squeue` until the jobs leave the queue,
//! then asks `sacct` (when the cluster keeps accounting) how each task ended, so that a task
//! killed by Slurm (time limit, memory) is recorded as failed with Slurm's reason.

use super::SweepError;
use super::expand::Resolved;
use super::run::{SweepReport, pending};
use super::spec::SlurmSpec;
use super::state::{PointState, PointStatus, RunRecord, StateDir, host_name, now_unix};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// What will be submitted.
#[derive(Clone, Debug)]
pub struct Submission {
    /// Batch id: names the task list, the scripts and the logs.
    pub batch: String,
    /// Points to run (name, plan hash), in task order.
    pub points: Vec<(String, String)>,
    /// Points per array task.
    pub per_task: usize,
    /// Array tasks.
    pub tasks: usize,
    /// The job computing the common stages (None when no stage is common or one point runs).
    pub common_script: Option<String>,
    /// The array job script.
    pub array_script: String,
    /// Where the task list goes.
    pub tasks_file: PathBuf,
}

/// Quotes `s` for a POSIX shell.
pub fn sh_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

fn job_name(sweep: &str) -> String {
    let n: String = sweep
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("femu-{n}")
}

/// Whether `p` can stand in an `#SBATCH --output=` line as it is: ASCII letters, digits and
/// `/._-+,@=:~` (no spaces or quotes, which a directive cannot quote, and no `%`, which Slurm
/// expands in file names).
fn directive_safe_path(p: &str) -> bool {
    !p.is_empty()
        && p.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+,@=:~".contains(c))
}

/// Text for a comment line of a script: control characters (a line break would end the comment
/// and start a command) shown as `?`.
fn comment_text(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect()
}

/// Checks everything `prepare` writes into the scripts unquoted or into the task list, again:
/// the sweep file was checked when read, but a spec built or changed in code was not.
fn check_script_inputs(resolved: &Resolved, batch: &str, femu: &str) -> Result<(), SweepError> {
    use super::spec::{
        valid_directive_value, valid_executable, valid_mem, valid_slurm_word, valid_sweep_name,
        valid_time,
    };
    let sl = &resolved.sweep.spec.slurm;
    let bad = |field: &str, value: &str, valid: &str| {
        Err(SweepError::Usage(format!(
            "{}: field `{field}`: {value:?} cannot be written into a batch script; {valid}",
            resolved.sweep.file
        )))
    };
    let name = resolved.sweep.name();
    if !valid_sweep_name(&name) {
        return bad("name", &name, super::spec::SWEEP_NAME_HELP);
    }
    if !valid_sweep_name(batch) {
        return bad(
            "batch",
            batch,
            "a batch id is ASCII letters, digits, `.`, `_` and `-`",
        );
    }
    let words = [
        ("slurm.partition", &sl.partition, true),
        ("slurm.account", &sl.account, false),
    ];
    for (field, v, list) in words {
        if let Some(v) = v.as_deref().filter(|v| !valid_slurm_word(v, list)) {
            return bad(field, v, "give ASCII letters, digits, `.`, `_` and `-`");
        }
    }
    if let Some(t) = sl.time.as_deref().filter(|t| !valid_time(t)) {
        return bad(
            "slurm.time",
            t,
            "write `MM`, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM` or `D-HH:MM:SS`",
        );
    }
    if let Some(m) = sl.mem.as_deref().filter(|m| !valid_mem(m)) {
        return bad(
            "slurm.mem",
            m,
            "write a whole number with an optional unit K, M, G or T",
        );
    }
    for e in &sl.extra {
        if !e.starts_with("--") || !valid_directive_value(e) {
            return bad(
                "slurm.extra",
                e,
                "write `--NAME=VALUE` in printable ASCII without spaces, quotes, backslashes or `#`",
            );
        }
    }
    if !valid_executable(femu) {
        return bad("slurm.femu", femu, "give a path without control characters");
    }
    for u in &resolved.unique {
        super::state::check_point_name(&u.point.name)?;
    }
    Ok(())
}

/// Points per array task and array tasks for `points` points: `points_per_task` (default 1),
/// raised so that the array stays within `max_array_size` (default 1000).
fn array_layout(sl: &SlurmSpec, points: usize) -> (usize, usize) {
    let max_array = sl.max_array_size.unwrap_or(1000).max(1) as usize;
    let mut per_task = sl.points_per_task.unwrap_or(1).max(1) as usize;
    if points.div_ceil(per_task) > max_array {
        per_task = points.div_ceil(max_array);
    }
    (per_task, points.div_ceil(per_task))
}

/// The `#SBATCH` directives of the sweep's resources, in a fixed order, then `extra`.
fn resource_directives(sl: &SlurmSpec) -> Vec<String> {
    let mut resources = Vec::new();
    if let Some(p) = &sl.partition {
        resources.push(format!("#SBATCH --partition={p}"));
    }
    if let Some(t) = &sl.time {
        resources.push(format!("#SBATCH --time={t}"));
    }
    if let Some(m) = &sl.mem {
        resources.push(format!("#SBATCH --mem={m}"));
    }
    if let Some(c) = sl.cpus_per_task {
        resources.push(format!("#SBATCH --cpus-per-task={c}"));
    }
    if let Some(a) = &sl.account {
        resources.push(format!("#SBATCH --account={a}"));
    }
    for e in &sl.extra {
        resources.push(format!("#SBATCH {e}"));
    }
    resources
}

/// A batch script: the shebang, `header`, the resource directives, strict variables, the
/// rayon thread count from Slurm's CPUs, then `body`.
fn batch_script(header: &str, resources: &[String], body: &str) -> String {
    let mut s = String::from("#!/bin/bash\n");
    s.push_str(header);
    for r in resources {
        s.push_str(r);
        s.push('\n');
    }
    s.push_str("set -u\n");
    s.push_str("export RAYON_NUM_THREADS=\"${SLURM_CPUS_PER_TASK:-1}\"\n");
    s.push_str(body);
    s
}

/// Prepares the submission of the unfinished points (nothing is written). Every value written
/// into an `#SBATCH` line is checked against a safe alphabet, and everything in a command is
/// shell-quoted.
pub fn prepare(
    resolved: &Resolved,
    state: &StateDir,
    cache_dir: &Path,
    exe: &Path,
    batch: &str,
) -> Result<Submission, SweepError> {
    let sl = &resolved.sweep.spec.slurm;
    let todo = pending(resolved, state);
    let points: Vec<(String, String)> = todo
        .iter()
        .map(|p| (p.point.name.clone(), p.plan_hash.clone()))
        .collect();
    let (per_task, tasks) = array_layout(sl, points.len());
    let femu = sl.femu.clone().unwrap_or_else(|| exe.display().to_string());
    check_script_inputs(resolved, batch, &femu)?;
    let sweep_file =
        std::fs::canonicalize(&resolved.sweep.path).map_err(|source| SweepError::Io {
            path: resolved.sweep.path.clone(),
            source,
        })?;
    let cache_dir = std::fs::canonicalize(cache_dir).map_err(|source| SweepError::Io {
        path: cache_dir.to_path_buf(),
        source,
    })?;
    let root = state.root();
    let tasks_file = root.join("tasks").join(format!("{batch}.txt"));
    let name = resolved.sweep.name();
    let resources = resource_directives(sl);
    // femu submits from the state directory, so a relative path reaches the same logs when the
    // state directory's own path cannot be written in a directive.
    let logs = root.join("slurm").join("logs").display().to_string();
    let logs = if directive_safe_path(&logs) {
        logs
    } else {
        "slurm/logs".to_string()
    };
    let common = |body: &str, header: &str| batch_script(header, &resources, body);
    let mut args = format!(
        "{} --cache-dir {} --out {}",
        sh_quote(&sweep_file.display().to_string()),
        sh_quote(&cache_dir.display().to_string()),
        sh_quote(&root.display().to_string()),
    );
    for s in &resolved.sweep.overrides {
        args.push_str(&format!(" --set {}", sh_quote(s)));
    }
    let limit = sl.array_limit.map(|l| format!("%{l}")).unwrap_or_default();
    let array_header = format!(
        "# femu sweep `{}`: {} point(s) in {tasks} array task(s) of {per_task}, batch {batch}\n\
         #SBATCH --job-name={}\n\
         #SBATCH --array=0-{}{limit}\n\
         #SBATCH --output={logs}/{batch}_%a.out\n",
        comment_text(&name),
        points.len(),
        job_name(&name),
        tasks.saturating_sub(1),
    );
    let array_body = format!(
        "exec {} sweep run-point {args} --tasks {} --task \"${{SLURM_ARRAY_TASK_ID}}\" --per-task {per_task}\n",
        sh_quote(&femu),
        sh_quote(&tasks_file.display().to_string()),
    );
    let common_script = (!resolved.common.is_empty() && points.len() > 1).then(|| {
        let header = format!(
            "# femu sweep `{}`: the stages common to every point ({}), computed once, batch {batch}\n\
             #SBATCH --job-name={}-common\n\
             #SBATCH --output={logs}/{batch}_common.out\n",
            comment_text(&name),
            comment_text(&resolved.common.join(", ")),
            job_name(&name),
        );
        let body = format!(
            "exec {} sweep run-point {args} --common --batch {}\n",
            sh_quote(&femu),
            sh_quote(batch)
        );
        common(&body, &header)
    });
    Ok(Submission {
        batch: batch.to_string(),
        per_task,
        tasks,
        common_script,
        array_script: common(&array_body, &array_header),
        points,
        tasks_file,
    })
}

fn run_tool(cmd: &mut Command, what: &str) -> Result<String, SweepError> {
    let out = cmd.output().map_err(|e| {
        SweepError::Slurm(format!(
            "cannot run `{what}` ({e}); is Slurm installed and on PATH? `--dry-run` prints the script without Slurm"
        ))
    })?;
    if !out.status.success() {
        return Err(SweepError::Slurm(format!(
            "`{what}` failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Writes the task list and scripts, and submits them; returns the job ids (common, array).
pub fn submit(sub: &Submission, state: &StateDir) -> Result<Vec<String>, SweepError> {
    let mut list = String::new();
    for (name, hash) in &sub.points {
        list.push_str(&format!("{name}\t{hash}\n"));
    }
    super::state::write_atomic(&sub.tasks_file, list.as_bytes())?;
    let dir = state.root().join("slurm");
    let mut ids = Vec::new();
    let mut dependency = None;
    if let Some(script) = &sub.common_script {
        let path = dir.join(format!("{}_common.sbatch", sub.batch));
        super::state::write_atomic(&path, script.as_bytes())?;
        let id = parse_job_id(&run_tool(
            Command::new("sbatch")
                .current_dir(state.root())
                .arg("--parsable")
                .arg(&path),
            "sbatch",
        )?)?;
        dependency = Some(format!("--dependency=afterany:{id}"));
        ids.push(id);
    }
    let path = dir.join(format!("{}.sbatch", sub.batch));
    super::state::write_atomic(&path, sub.array_script.as_bytes())?;
    let mut cmd = Command::new("sbatch");
    // Submitted from the state directory: relative log paths in the scripts start there.
    cmd.current_dir(state.root()).arg("--parsable");
    if let Some(d) = &dependency {
        cmd.arg(d);
    }
    let id = parse_job_id(&run_tool(cmd.arg(&path), "sbatch")?)?;
    ids.push(id);
    let record = dir.join("jobs.txt");
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&record)
        .map_err(|source| SweepError::Io {
            path: record.clone(),
            source,
        })?;
    use std::io::Write;
    writeln!(f, "{} {}", sub.batch, ids.join(" ")).map_err(|source| SweepError::Io {
        path: record,
        source,
    })?;
    Ok(ids)
}

/// Every job id this sweep has submitted.
pub fn submitted_jobs(state: &StateDir) -> Vec<String> {
    std::fs::read_to_string(state.root().join("slurm").join("jobs.txt"))
        .unwrap_or_default()
        .lines()
        .flat_map(|l| {
            l.split_whitespace()
                .skip(1)
                .map(str::to_string)
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Refuses to submit while jobs of an earlier submission are still queued: their points would
/// run twice.
pub fn ensure_idle(state: &StateDir) -> Result<(), SweepError> {
    let jobs = submitted_jobs(state);
    let active = queued(&jobs)?;
    if active.is_empty() {
        Ok(())
    } else {
        Err(SweepError::Slurm(format!(
            "jobs {} of an earlier submission are still queued; follow them with `femu sweep status`, or cancel them (scancel) before submitting again",
            active.join(", ")
        )))
    }
}

/// The job id of `sbatch --parsable` output (`ID` or `ID;CLUSTER`).
pub fn parse_job_id(out: &str) -> Result<String, SweepError> {
    let id = out
        .lines()
        .last()
        .unwrap_or("")
        .split(';')
        .next()
        .unwrap_or("")
        .trim();
    if !id.is_empty() && id.chars().all(|c| c.is_ascii_digit()) {
        Ok(id.to_string())
    } else {
        Err(SweepError::Slurm(format!(
            "sbatch printed `{out}`, not a job id"
        )))
    }
}

/// Job ids of `jobs` still in the queue (pending, running, completing).
pub fn queued(jobs: &[String]) -> Result<Vec<String>, SweepError> {
    if jobs.is_empty() {
        return Ok(Vec::new());
    }
    let out = Command::new("squeue")
        .args(["-h", "-o", "%i|%T", "-j", &jobs.join(",")])
        .output()
        .map_err(|e| SweepError::Slurm(format!("cannot run `squeue`: {e}")))?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        // A job that has left the queue is an "invalid job id" to squeue.
        if err.contains("Invalid job id") {
            return Ok(Vec::new());
        }
        return Err(SweepError::Slurm(format!(
            "`squeue` failed: {}",
            err.trim()
        )));
    }
    let mut ids: Vec<String> = text
        .lines()
        .filter_map(|l| l.split('|').next())
        .map(|id| id.split('_').next().unwrap_or(id).to_string())
        .filter(|id| jobs.contains(id))
        .collect();
    ids.sort();
    ids.dedup();
    Ok(ids)
}

/// How each array task ended, by task index, from `sacct` (empty when accounting is off).
pub fn task_states(job: &str) -> BTreeMap<usize, String> {
    let Ok(out) = Command::new("sacct")
        .args(["-n", "-P", "-X", "-o", "JobID,State,ExitCode", "-j", job])
        .output()
    else {
        return BTreeMap::new();
    };
    if !out.status.success() {
        return BTreeMap::new();
    }
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let mut f = l.split('|');
            let id = f.next()?;
            let st = f.next()?;
            let code = f.next().unwrap_or("");
            let (_, task) = id.split_once('_')?;
            Some((task.parse().ok()?, format!("{st} (exit {code})")))
        })
        .collect()
}

/// Options of following a submission.
#[derive(Clone, Debug)]
pub struct FollowOptions {
    /// Time between `squeue` polls.
    pub poll: Duration,
    /// Give up following after this long (the jobs go on).
    pub timeout: Option<Duration>,
    /// Print progress lines.
    pub progress: bool,
}

/// Follows submitted jobs until they leave the queue, then records tasks Slurm ended without a
/// result as failed. Returns the report over the submitted points.
pub fn follow(
    sub: &Submission,
    jobs: &[String],
    state: &StateDir,
    opts: &FollowOptions,
) -> Result<SweepReport, SweepError> {
    let t0 = Instant::now();
    wait_for_jobs(sub, jobs, state, opts, t0)?;
    let array = jobs.last().cloned().unwrap_or_default();
    let states = task_states(&array);
    let mut report = SweepReport::default();
    for (i, (name, hash)) in sub.points.iter().enumerate() {
        let task = i / sub.per_task.max(1);
        let s = match state.status(name) {
            Some(s) if s.plan_hash == *hash && s.state != PointState::Running => s,
            other => {
                let why = states
                    .get(&task)
                    .map(|s| format!("Slurm ended task {task} as {s}"))
                    .unwrap_or_else(|| {
                        format!("array task {task} ended without recording a result")
                    });
                let log = state
                    .root()
                    .join("slurm/logs")
                    .join(format!("{}_{task}.out", sub.batch));
                let s = lost_point_status(
                    name,
                    hash,
                    other,
                    format!("{array}_{task}"),
                    format!("{why}; see {}", log.display()),
                );
                state.write_status(&s)?;
                s
            }
        };
        report.requested += s.requested;
        report.executed += s.executed;
        match s.state {
            PointState::Done => report.ran += 1,
            _ => report
                .failed
                .push((name.clone(), s.message.clone().unwrap_or_default())),
        }
    }
    if let Some(c) = read_common_record(state, &sub.batch) {
        report.requested += c.0;
        report.executed += c.1;
    }
    report.seconds = t0.elapsed().as_secs_f64();
    state.append_run(&RunRecord {
        backend: "slurm".into(),
        points: report.ran + report.failed.len(),
        failed: report.failed.len(),
        requested: report.requested,
        executed: report.executed,
        seconds: report.seconds,
    })?;
    Ok(report)
}

/// Polls `squeue` every `opts.poll` until none of `jobs` is queued, reporting the finished
/// points as they change; an error once `opts.timeout` has passed (the jobs go on).
fn wait_for_jobs(
    sub: &Submission,
    jobs: &[String],
    state: &StateDir,
    opts: &FollowOptions,
    t0: Instant,
) -> Result<(), SweepError> {
    let mut last = usize::MAX;
    loop {
        let active = queued(jobs)?;
        let finished = sub
            .points
            .iter()
            .filter(|(n, h)| {
                state
                    .status(n)
                    .is_some_and(|s| s.plan_hash == *h && s.state != PointState::Running)
            })
            .count();
        if opts.progress && finished != last {
            eprintln!(
                "[femu] slurm jobs {}: {finished}/{} points finished",
                jobs.join(", "),
                sub.points.len()
            );
            last = finished;
        }
        if active.is_empty() {
            break;
        }
        if opts.timeout.is_some_and(|t| t0.elapsed() > t) {
            return Err(SweepError::Slurm(format!(
                "jobs {} still queued after {:.0} s; they go on: `femu sweep status` follows them",
                active.join(", "),
                t0.elapsed().as_secs_f64()
            )));
        }
        std::thread::sleep(opts.poll);
    }
    Ok(())
}

/// The failed status of a point whose array task `job` ended without recording a result,
/// keeping what its last status (`other`) knew.
fn lost_point_status(
    name: &str,
    hash: &str,
    other: Option<PointStatus>,
    job: String,
    message: String,
) -> PointStatus {
    PointStatus {
        point: name.to_string(),
        state: PointState::Failed,
        plan_hash: hash.to_string(),
        overrides: other
            .as_ref()
            .map(|o| o.overrides.clone())
            .unwrap_or_default(),
        host: other
            .as_ref()
            .map(|o| o.host.clone())
            .unwrap_or_else(host_name),
        pid: other.as_ref().map(|o| o.pid).unwrap_or(0),
        slurm_job: Some(job),
        started_unix: other
            .as_ref()
            .map(|o| o.started_unix)
            .unwrap_or_else(now_unix),
        seconds: 0.0,
        requested: 0,
        executed: 0,
        message: Some(message),
        stages: BTreeMap::new(),
    }
}

/// Path where the common-stages job records (requested, executed).
pub fn common_record_path(state: &StateDir, batch: &str) -> PathBuf {
    state
        .root()
        .join("slurm")
        .join(format!("{batch}_common.json"))
}

fn read_common_record(state: &StateDir, batch: &str) -> Option<(usize, usize)> {
    let text = std::fs::read_to_string(common_record_path(state, batch)).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some((
        v.get("requested")?.as_u64()? as usize,
        v.get("executed")?.as_u64()? as usize,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoting_and_ids() {
        assert_eq!(sh_quote("a b"), "'a b'");
        assert_eq!(sh_quote("it's"), r"'it'\''s'");
        assert_eq!(parse_job_id("1234\n").unwrap(), "1234");
        assert_eq!(parse_job_id("77;cluster").unwrap(), "77");
        assert!(parse_job_id("Submitted batch job").is_err());
        assert_eq!(job_name("four dof"), "femu-four_dof");
    }
}
