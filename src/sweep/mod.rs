//! Parameter sweeps: a `matrix:` over stage parameters of one pipeline, expanded into points
//! (each the pipeline with `--set` overrides), deduplicated by plan hash, run on a backend —
//! `local` worker processes or a Slurm job array — against one shared cache, and collected into
//! one Parquet table with box plots.
//!
//! The thesis's finding that updated parameters are not unique (Grafe 1998, §2.5–2.6) needs the
//! same pipeline run over many noise draws, measurement sets and parameter sets; a sweep makes
//! that one command. DVC's `matrix` (`dvc/parsing/__init__.py`) is the model for the expansion
//! and the `stage@value` names.

pub mod collect;
pub mod expand;
pub mod run;
pub mod schema;
pub mod slurm;
pub mod spec;
pub mod state;

pub use collect::{Collected, collect};
pub use expand::{Expansion, PlannedPoint, Point, Resolved, expand, resolve};
pub use run::{LocalOptions, SweepReport, run_local, run_point, status_summary};
pub use spec::{SourcedSweep, SweepSpec, parse_sweep, read_sweep};
pub use state::{PointState, PointStatus, StateDir};

use std::path::PathBuf;

/// Why a sweep could not be run, followed or collected.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The sweep file or its pipeline is not valid.
    #[error(transparent)]
    Invalid(#[from] crate::pipeline::Diagnostics),
    /// File system failure in the state directory.
    #[error("sweep state {path}: {source}")]
    Io {
        /// Path involved.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The cache failed.
    #[error(transparent)]
    Cache(#[from] crate::cache::CacheError),
    /// A point was asked for that the sweep does not have.
    #[error("{0}")]
    Usage(String),
    /// Another process drives the same sweep.
    #[error(
        "another `femu sweep` ({}) holds {} and is driving this sweep; this one stops with exit code 1 (the sweep is busy, the input is fine): wait for it to finish, or follow it with `femu sweep status`",
        busy_holder(*.pid, .host),
        .lock.display()
    )]
    Busy {
        /// Its process id.
        pid: u32,
        /// Its host.
        host: String,
        /// The lock file.
        lock: PathBuf,
    },
    /// A worker could not be started.
    #[error("cannot start the worker {exe}: {source}")]
    Spawn {
        /// The executable.
        exe: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Slurm refused or failed.
    #[error("slurm: {0}")]
    Slurm(String),
    /// Collection failed.
    #[error("collect: {0}")]
    Collect(String),
    /// An artefact could not be read or the table written.
    #[error(transparent)]
    Artefact(#[from] crate::artefact::ArtefactError),
    /// A plot could not be drawn.
    #[error("plot: {0}")]
    Plot(String),
}

/// Who holds a sweep lock, for messages.
fn busy_holder(pid: u32, host: &str) -> String {
    if pid == 0 || host.is_empty() {
        "which has not written its pid yet".to_string()
    } else {
        format!("pid {pid} on {host}")
    }
}

impl SweepError {
    /// Whether the error is the user's input (exit code 2) rather than a failure (1).
    pub fn is_bad_input(&self) -> bool {
        matches!(self, SweepError::Invalid(_) | SweepError::Usage(_))
    }
}
