//! The run report: one self-contained HTML page for a run's output directory (the one `femu run
//! --out` writes), with the pipeline as a graph, every FRF overlaid with its correlation, the MAC
//! as a heat map, the updating history, localisation maps on the mesh in 3-D, the figures the
//! stages drew, every table, and every warning. Scripts, styles and data are inlined: the page
//! needs no network and opens from a `file://` URL or an artefact store. The page is a function
//! of the directory (and of the run's timings when given), so two identical runs write identical
//! reports.
//!
//! This is engine-side code (it reads artefacts and the lock file); the numerics never see it.

mod collect;
mod page;
pub mod record;
mod svg;

pub use collect::{RUN_RIDGE, RunView, StageTiming, collect};
pub use page::render_html;

use std::path::{Path, PathBuf};

/// The report's file name inside the output directory.
pub const REPORT_FILE: &str = "report.html";

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct ReportError {
    /// The file or directory at fault.
    pub path: PathBuf,
    /// What is wrong and what would be valid.
    pub message: String,
    /// Whether the directory given is at fault (not a run's output), not the writing.
    pub is_input: bool,
}

impl ReportError {
    /// The directory given is not a run's output.
    pub(crate) fn new(path: &Path, message: impl Into<String>) -> Self {
        ReportError {
            path: path.to_path_buf(),
            message: message.into(),
            is_input: true,
        }
    }

    /// The page could not be written.
    fn write(path: &Path, e: std::io::Error) -> Self {
        ReportError {
            path: path.to_path_buf(),
            message: format!("cannot write: {e}"),
            is_input: false,
        }
    }
}

/// What the report says about how it was made.
#[derive(Clone, Debug, Default)]
pub struct ReportOptions {
    /// Per stage: cached or ran, and the time it took (only known right after a run).
    pub timings: std::collections::BTreeMap<String, StageTiming>,
    /// The command line that produced the run, if known.
    pub command: Option<String>,
}

/// Writes `report.html` (or `target`) for the run output directory `out`, atomically (a
/// temporary file renamed into place), and returns its path.
pub fn write_report(
    out: &Path,
    target: Option<&Path>,
    opts: &ReportOptions,
) -> Result<PathBuf, ReportError> {
    let view = collect(out, opts)?;
    let html = render_html(&view);
    let path = target
        .map(Path::to_path_buf)
        .unwrap_or_else(|| out.join(REPORT_FILE));
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .ok_or_else(|| ReportError::new(&path, "is not a file name; give e.g. report.html"))?;
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    std::fs::write(&tmp, html.as_bytes()).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        ReportError::write(&tmp, e)
    })?;
    std::fs::rename(&tmp, &path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        ReportError::write(&path, e)
    })?;
    Ok(path)
}

impl ReportOptions {
    /// The options right after a run: each stage's status and time, and the command.
    pub fn from_run(report: &crate::pipeline::RunReport, command: Option<String>) -> Self {
        ReportOptions {
            timings: report
                .stages
                .iter()
                .map(|s| {
                    (
                        s.name.clone(),
                        StageTiming {
                            status: s.status.label().to_string(),
                            seconds: s.elapsed.as_secs_f64(),
                        },
                    )
                })
                .collect(),
            command,
        }
    }
}

#[cfg(test)]
mod tests;
