//! `femu run`: run a pipeline, record its lock file, copy the artefacts out and print a summary.

use super::load::load_sourced_plan;
use super::summary::{
    RUN_RECORD_FILE, RunRecord, RunRecordStage, artefact_meta, column_width, print_warnings,
    stage_warnings,
};
use super::{CacheArgs, Failure, PipelineArgs};
use crate::artefact::codec::read_meta;
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
    let warnings = run_warnings(&report, &cache);
    if let Some(out) = &out {
        let record = run_record(&plan.name, &report, &warnings);
        let text = serde_json::to_string_pretty(&record).context("the run record")? + "\n";
        crate::pipeline::executor::materialise_run(
            &report,
            &cache,
            out,
            Some(&lock),
            &[(RUN_RECORD_FILE, text.as_bytes())],
        )?;
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
    // Once, at the end, so that they are not lost among the progress lines; cached stages' too.
    let _ = print_warnings(&warnings, &mut std::io::stderr().lock());
    Ok(0)
}

/// Per stage (plan order): name, `kind[, cached]` and the warnings its outputs' meta records;
/// a cached stage's are read from its cache entry.
fn run_warnings(report: &RunReport, cache: &Cache) -> Vec<(String, String, Vec<String>)> {
    report
        .stages
        .iter()
        .map(|s| {
            let metas: Vec<_> = s
                .outputs
                .keys()
                .filter_map(|port| cache.artefact_dir(&s.key, port).ok())
                .filter_map(|dir| read_meta(&dir).ok())
                .map(|m| artefact_meta(&m))
                .collect();
            let label = match s.status {
                Status::Cached => format!("{}, cached", s.kind),
                _ => s.kind.clone(),
            };
            (s.name.clone(), label, stage_warnings(&metas))
        })
        .collect()
}

/// The run record written beside the lock file in `--out`.
fn run_record(
    pipeline: &str,
    report: &RunReport,
    warnings: &[(String, String, Vec<String>)],
) -> RunRecord {
    RunRecord {
        pipeline: pipeline.to_string(),
        femu_version: env!("CARGO_PKG_VERSION").into(),
        command: std::env::args().collect(),
        stages: report
            .stages
            .iter()
            .map(|s| RunRecordStage {
                name: s.name.clone(),
                kind: s.kind.clone(),
                status: match s.status {
                    Status::Ran => "ran",
                    Status::Cached => "cached",
                    Status::Recovered => "recomputed",
                }
                .into(),
                seconds: s.elapsed.as_secs_f64(),
            })
            .collect(),
        warnings: warnings
            .iter()
            .filter(|w| !w.2.is_empty())
            .map(|(stage, _, w)| (stage.clone(), w.clone()))
            .collect(),
    }
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
    // Columns as wide as their longest entry (at least as wide as they were), so that a long
    // stage name does not push its row out of line.
    let stages = &report.stages;
    let name_w = column_width(stages.iter().map(|s| s.name.as_str()), 20);
    let kind_w = column_width(stages.iter().map(|s| s.kind.as_str()), 18);
    println!(
        "{:<name_w$} {:<kind_w$} {:<34} {:>9}  outputs",
        "stage", "kind", "status", "time (s)"
    );
    for s in &report.stages {
        let outs: Vec<String> = s
            .outputs
            .iter()
            .map(|(p, r)| format!("{p}={}", &r.digest[..12]))
            .collect();
        println!(
            "{:<name_w$} {:<kind_w$} {:<34} {:>9.3}  {}",
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
