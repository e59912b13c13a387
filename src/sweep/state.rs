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

/// Seconds since the Unix epoch.
pub fn now_unix() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// This machine's host name.
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "localhost".into())
}

/// Whether process `pid` is alive on this host (Linux `/proc`; elsewhere assumed dead).
pub fn pid_alive(pid: u32) -> bool {
    Path::new("/proc").join(pid.to_string()).exists()
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

    /// Takes the sweep lock, or says who holds it.
    pub fn lock(&self) -> Result<SweepLock, SweepError> {
        let path = self.root.join("sweep.lock");
        let me = format!("{} {}", std::process::id(), host_name());
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    f.write_all(me.as_bytes()).map_err(io(&path))?;
                    return Ok(SweepLock { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let text = std::fs::read_to_string(&path).unwrap_or_default();
                    let mut it = text.split_whitespace();
                    let pid: Option<u32> = it.next().and_then(|p| p.parse().ok());
                    let host = it.next().unwrap_or("").to_string();
                    let alive = pid.is_some_and(|p| host == host_name() && pid_alive(p));
                    if alive {
                        return Err(SweepError::Busy {
                            pid: pid.unwrap_or(0),
                            host,
                            lock: path,
                        });
                    }
                    // A stale lock of a process that died: take it over.
                    let _ = std::fs::remove_file(&path);
                }
                Err(e) => return Err(io(&path)(e)),
            }
        }
        Err(SweepError::Busy {
            pid: 0,
            host: String::new(),
            lock: path,
        })
    }
}

/// The held sweep lock; released when dropped.
#[derive(Debug)]
pub struct SweepLock {
    path: PathBuf,
}

impl Drop for SweepLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}
