//! The state directory of a sweep: one status file per point, written atomically by whoever runs
//! the point (a local worker process or a Slurm task), the task lists handed to workers, the
//! Slurm scripts and logs, and one line per invocation with its cache statistics.
//!
//! ```text
//! points/<point>/status.json   state (running, done, failed), plan hash, stage keys, message
//! points/<point>/log.txt       standard error of the worker that ran it
//! tasks/<batch>.txt            point names, one per line, indexed by the Slurm array task
//! slurm/<batch>.sbatch         the batch script; slurm/logs/ its output
//! runs.jsonl                   per invocation: backend, points, stages requested and executed
//! sweep.lock                   held by the `femu sweep` process driving the sweep
//! ```
//! A point is finished when its status says `done` with the plan hash of the current plan;
//! anything else (never started, failed, interrupted, planned differently) is run again.

use super::SweepError;
use crate::cache::OutputRecord;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// What a point's status file says.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PointState {
    /// A worker is (or was, if it died) running it.
    Running,
    /// Finished; its outputs are in the cache.
    Done,
    /// Failed; `message` says why.
    Failed,
}

/// One stage of a finished point.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StageRecord {
    /// Stage kind.
    pub kind: String,
    /// Cache key.
    pub key: String,
    /// `ran`, `cached` or `recomputed`.
    pub status: String,
    /// Outputs by port.
    pub outputs: BTreeMap<String, OutputRecord>,
}

/// The status file of one point.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PointStatus {
    /// Point name.
    pub point: String,
    /// State.
    pub state: PointState,
    /// Plan hash the point was run with.
    pub plan_hash: String,
    /// Its `--set` overrides.
    pub overrides: Vec<String>,
    /// Host of the worker.
    pub host: String,
    /// Process id of the worker.
    pub pid: u32,
    /// Slurm job and array task (`JOBID_TASK`), when run by Slurm.
    #[serde(default)]
    pub slurm_job: Option<String>,
    /// Start, seconds since the Unix epoch.
    pub started_unix: u64,
    /// Wall time in seconds (when finished).
    #[serde(default)]
    pub seconds: f64,
    /// Stages in the point's plan.
    #[serde(default)]
    pub requested: usize,
    /// Stages computed (not served by the cache).
    #[serde(default)]
    pub executed: usize,
    /// Why it failed.
    #[serde(default)]
    pub message: Option<String>,
    /// Stages by name (when done).
    #[serde(default)]
    pub stages: BTreeMap<String, StageRecord>,
}

/// One invocation of a backend, for the cache statistics.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunRecord {
    /// `local` or `slurm`.
    pub backend: String,
    /// Points run by this invocation.
    pub points: usize,
    /// Points that failed.
    pub failed: usize,
    /// Stages requested: the sum of the plans' sizes (plus the common stages computed first).
    pub requested: usize,
    /// Stages computed.
    pub executed: usize,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// A sweep's state directory.
#[derive(Clone, Debug)]
pub struct StateDir {
    root: PathBuf,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> SweepError + '_ {
    move |source| SweepError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `bytes` to `path` through a temporary file and a rename, so readers never see half.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SweepError> {
    let tmp = path.with_extension(format!("tmp.{}", std::process::id()));
    {
        let mut f = std::fs::File::create(&tmp).map_err(io(&tmp))?;
        f.write_all(bytes).map_err(io(&tmp))?;
        f.sync_all().map_err(io(&tmp))?;
    }
    std::fs::rename(&tmp, path).map_err(io(path))
}

/// Whether `point` is a usable point name: one path component of the characters point names
/// are made of (ASCII letters, digits and `._-@,~=+`), not starting with `.`.
pub fn valid_point_name(point: &str) -> bool {
    !point.is_empty()
        && point.len() <= 255
        && !point.starts_with('.')
        && point
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "._-@,~=+".contains(c))
}

/// Refuses a point name that could leave the state directory or break a task list.
pub fn check_point_name(point: &str) -> Result<(), SweepError> {
    if valid_point_name(point) {
        Ok(())
    } else {
        Err(SweepError::Usage(format!(
            "{point:?} is not a point name: point names are one path component of ASCII letters, digits and `._-@,~=+`"
        )))
    }
}

/// Seconds since the Unix epoch.
pub fn now_unix() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// This machine's host name (the cache's owner tags read the same).
pub use crate::cache::owner::host_name;

/// Whether process `pid` is alive on this host (the cache's test for a dead owner, so both
/// judge processes alike).
pub fn pid_alive(pid: u32) -> bool {
    !crate::cache::owner::process_is_dead(pid)
}

impl StateDir {
    /// Opens (creating) the state directory at `root`.
    pub fn open(root: &Path) -> Result<StateDir, SweepError> {
        for sub in ["points", "tasks", "slurm/logs"] {
            let p = root.join(sub);
            std::fs::create_dir_all(&p).map_err(io(&p))?;
        }
        let root = std::fs::canonicalize(root).map_err(io(root))?;
        Ok(StateDir { root })
    }

    /// Opens (creating) the state directory of the sweep `name` in a cache: `CACHE/sweeps/NAME`.
    /// A name that is not one safe path component (see [`super::spec::valid_sweep_name`]) is
    /// refused, so no name can put the state outside the cache.
    pub fn for_sweep(cache_dir: &Path, name: &str) -> Result<StateDir, SweepError> {
        if !super::spec::valid_sweep_name(name) {
            return Err(SweepError::Usage(format!(
                "{name:?} is not a usable sweep name; {}",
                super::spec::SWEEP_NAME_HELP
            )));
        }
        StateDir::open(&cache_dir.join("sweeps").join(name))
    }

    /// The directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Directory of one point.
    pub fn point_dir(&self, point: &str) -> PathBuf {
        self.root.join("points").join(point)
    }

    /// The worker log of one point.
    pub fn log_path(&self, point: &str) -> PathBuf {
        self.point_dir(point).join("log.txt")
    }

    /// A point's status, if any was written (an unreadable one counts as none).
    pub fn status(&self, point: &str) -> Option<PointStatus> {
        let text = std::fs::read_to_string(self.point_dir(point).join("status.json")).ok()?;
        serde_json::from_str(&text).ok()
    }

    /// Writes a point's status atomically.
    pub fn write_status(&self, s: &PointStatus) -> Result<(), SweepError> {
        check_point_name(&s.point)?;
        let dir = self.point_dir(&s.point);
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let text = serde_json::to_string_pretty(s).map_err(|e| SweepError::Io {
            path: dir.clone(),
            source: std::io::Error::other(e),
        })?;
        write_atomic(&dir.join("status.json"), text.as_bytes())
    }

    /// Whether a point is finished with `plan_hash`.
    pub fn is_done(&self, point: &str, plan_hash: &str) -> bool {
        self.status(point)
            .is_some_and(|s| s.state == PointState::Done && s.plan_hash == plan_hash)
    }

    /// Appends an invocation record to `runs.jsonl`.
    pub fn append_run(&self, r: &RunRecord) -> Result<(), SweepError> {
        let path = self.root.join("runs.jsonl");
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(io(&path))?;
        let line = serde_json::to_string(r).unwrap_or_default();
        writeln!(f, "{line}").map_err(io(&path))
    }

    /// Every invocation recorded.
    pub fn runs(&self) -> Vec<RunRecord> {
        std::fs::read_to_string(self.root.join("runs.jsonl"))
            .unwrap_or_default()
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect()
    }

    /// Takes the sweep lock, or says at once who holds it.
    ///
    /// The lock is `flock(2)` on `sweep.lock` (held for the life of the returned guard, released
    /// by the kernel when the holder exits or dies, so there is no stale lock to clean up); the
    /// file says who holds it, for the message of the process that is refused. Taking the lock
    /// and testing it are one system call, so two processes started together cannot both pass.
    ///
    /// A refused taker that finds the file empty tries again for up to two seconds: either the
    /// holder has only just taken the lock and not yet written its name, or the lock outlives
    /// its holder for a moment because a process forked elsewhere still shares the descriptor
    /// until it execs (the descriptor is close-on-exec, but `flock` belongs to the open file,
    /// which the fork duplicates).
    pub fn lock(&self) -> Result<SweepLock, SweepError> {
        let path = self.root.join("sweep.lock");
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io(&path))?;
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(2);
        while !try_lock_file(&file).map_err(io(&path))? {
            let holder = read_holder(&path);
            if holder.is_some() || std::time::Instant::now() >= deadline {
                let (pid, host) = holder.unwrap_or_default();
                return Err(SweepError::Busy {
                    pid,
                    host,
                    lock: path,
                });
            }
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        // The holder's identity, written under the lock; a reader may see it empty for a moment.
        let me = format!("{} {}\n", std::process::id(), host_name());
        file.set_len(0).map_err(io(&path))?;
        file.write_all(me.as_bytes()).map_err(io(&path))?;
        Ok(SweepLock { file, path })
    }
}

/// Takes an exclusive lock on `file` without waiting: `Ok(false)` when another holds it.
#[cfg(unix)]
fn try_lock_file(file: &std::fs::File) -> std::io::Result<bool> {
    use std::os::unix::io::AsRawFd;
    loop {
        // SAFETY: flock on a descriptor this `File` owns and keeps open.
        let r = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
        if r == 0 {
            return Ok(true);
        }
        let e = std::io::Error::last_os_error();
        match e.raw_os_error() {
            Some(libc::EWOULDBLOCK) => return Ok(false),
            Some(libc::EINTR) => continue,
            _ => return Err(e),
        }
    }
}

/// Takes an exclusive lock on `file` without waiting: `Ok(false)` when another holds it.
#[cfg(not(unix))]
fn try_lock_file(file: &std::fs::File) -> std::io::Result<bool> {
    match file.try_lock() {
        Ok(()) => Ok(true),
        Err(std::fs::TryLockError::WouldBlock) => Ok(false),
        Err(std::fs::TryLockError::Error(e)) => Err(e),
    }
}

/// The pid and host written in a held lock file; `None` while it is empty.
fn read_holder(path: &Path) -> Option<(u32, String)> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut it = text.split_whitespace();
    let pid = it.next()?.parse().ok()?;
    Some((pid, it.next().unwrap_or_default().to_string()))
}

/// The held sweep lock; released when dropped (or when the process ends, however it ends).
///
/// The file is emptied but not removed: removing it would let a process that opened it just
/// before lock the removed file while a third creates and locks a new one.
#[derive(Debug)]
pub struct SweepLock {
    file: std::fs::File,
    path: PathBuf,
}

impl SweepLock {
    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for SweepLock {
    fn drop(&mut self) {
        // Closing the file releases the lock.
        let _ = self.file.set_len(0);
    }
}
