//! `femu run`: run a pipeline, record its lock file, copy the artefacts out and print a summary.

use super::load::load_sourced_plan;
use super::{CacheArgs, Failure, PipelineArgs};
use crate::cache::Cache;
use crate::pipeline::executor::{RunError, RunReport};
use crate::pipeline::lock::LockFile;
use crate::pipeline::{
    Diagnostic, Diagnostics, ProgressMode, RunOptions, SourcedSpec, StageError, Status, execute,
};
use anyhow::Context;
use std::path::PathBuf;

/// The options of `femu run` beyond the pipeline and the cache.
pub(super) struct RunFlags {
    pub(super) out: Option<PathBuf>,
    pub(super) only: Vec<String>,
    pub(super) force: bool,
    pub(super) quiet: bool,
    pub(super) report: bool,
}

/// `femu run`.
pub(super) fn run(p: &PipelineArgs, c: &CacheArgs, flags: RunFlags) -> Result<u8, Failure> {
    let RunFlags {
        out,
        only,
        force,
        quiet,
        report: with_report,
    } = flags;
    let (src, plan) = load_sourced_plan(p)?;
    let cache = Cache::open(&c.dir())?;
    let opts = RunOptions {
        force,
        only,
        progress: if quiet {
            ProgressMode::Quiet
        } else {
            ProgressMode::Auto
        },
    };
    let report = execute(&plan, &cache, &opts).map_err(|e| locate_run_error(&src, e))?;
    let lock = LockFile::from_run(&plan, &report);
    if opts.only.is_empty() {
        let recorded = lock.record_in(&cache, &plan.name);
        if let Some(warning) = recorded.context("writing the lock file")? {
            eprintln!("warning: {warning}");
        }
    }
    if let Some(out) = &out {
        crate::pipeline::executor::materialise_with_lock(&report, &cache, out, Some(&lock))?;
    }
    print_summary(&plan.name, &report);
    if let Some(out) = out {
        println!("artefacts in {}", out.display());
        if with_report {
            let command: Vec<String> = std::env::args().collect();
            let opts = crate::run_report::ReportOptions::from_run(&report, Some(command.join(" ")));
            let page = crate::run_report::write_report(&out, None, &opts)?;
            println!("report in {}", page.display());
        }
    }
    Ok(0)
}

/// The run's table: one line per stage with its status, time and output digests.
fn print_summary(name: &str, report: &RunReport) {
    println!(
        "pipeline {}: {} stages, {} ran, {} cached",
        name,
        report.stages.len(),
        report.executed(),
        report
            .stages
            .iter()
            .filter(|s| s.status == Status::Cached)
            .count()
    );
    println!(
        "{:<20} {:<18} {:<34} {:>9}  outputs",
        "stage", "kind", "status", "time (s)"
    );
    for s in &report.stages {
        let outs: Vec<String> = s
            .outputs
            .iter()
            .map(|(p, r)| format!("{p}={}", &r.digest[..12]))
            .collect();
        println!(
            "{:<20} {:<18} {:<34} {:>9.3}  {}",
            s.name,
            s.kind,
            s.status.label(),
            s.elapsed.as_secs_f64(),
            outs.join(" ")
        );
    }
}

/// A stage's bad input found while running, located in the pipeline file like the errors
/// `validate` finds (stage, field, line); other run errors unchanged.
fn locate_run_error(src: &SourcedSpec, error: RunError) -> anyhow::Error {
    let RunError::Stage {
        stage,
        source: StageError::Input { field, message, .. },
        ..
    } = &error
    else {
        return error.into();
    };
    let mut path = vec!["stages", stage.as_str()];
    if !field.is_empty() {
        path.push("with");
        path.extend(field.split('.'));
    }
    let pos = src.locator.value(&path);
    let mut d = Diagnostic::new(&src.file, message.clone())
        .at(pos)
        .stage(stage);
    if !field.is_empty() {
        d = d.field(format!("with.{field}"));
    }
    Diagnostics(vec![d]).into()
}
