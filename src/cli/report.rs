//! `femu report`: the run report of an output directory, as one self-contained HTML page.

use super::Failure;
use crate::run_report::{ReportOptions, write_report};
use std::path::Path;

/// `femu report OUT [--output FILE]`. A directory that is not a run's output is bad input
/// (exit 2); the times of the stages are not in the directory, so the page says so.
pub(super) fn run(out: &Path, output: Option<&Path>) -> Result<u8, Failure> {
    let command: Vec<String> = std::env::args().collect();
    let opts = ReportOptions {
        command: Some(command.join(" ")),
        ..ReportOptions::default()
    };
    let page = write_report(out, output, &opts).map_err(|e| {
        if e.is_input {
            Failure::bad_input(e)
        } else {
            Failure::from(e)
        }
    })?;
    println!("report in {}", page.display());
    Ok(0)
}
