//! Helpers shared by the integration tests.
#![allow(dead_code)]

use femu::cache::Cache;
use femu::pipeline::{Plan, ProgressMode, RunOptions, RunReport, execute, plan, read_pipeline};
use std::path::{Path, PathBuf};

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A shipped pipeline by name.
pub fn pipeline(name: &str) -> PathBuf {
    root().join("pipelines").join(format!("{name}.yaml"))
}

/// Plans a pipeline with overrides.
pub fn load(path: &Path, sets: &[&str]) -> Plan {
    let mut src = read_pipeline(path).unwrap_or_else(|e| panic!("{e}"));
    src.apply_overrides(&sets.iter().map(|s| s.to_string()).collect::<Vec<_>>())
        .unwrap_or_else(|e| panic!("{e}"));
    plan(&src, &femu::stages::registry()).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs a pipeline against a cache directory, quietly.
pub fn run(path: &Path, cache_dir: &Path, sets: &[&str]) -> (Plan, RunReport, Cache) {
    let plan = load(path, sets);
    let cache = Cache::open(cache_dir).unwrap();
    let opts = RunOptions {
        progress: ProgressMode::Quiet,
        ..Default::default()
    };
    let report = execute(&plan, &cache, &opts).unwrap_or_else(|e| panic!("{e}"));
    (plan, report, cache)
}

/// Names of the stages that were computed (not cached).
pub fn executed(report: &RunReport) -> Vec<String> {
    report
        .stages
        .iter()
        .filter(|s| s.status != femu::pipeline::Status::Cached)
        .map(|s| s.name.clone())
        .collect()
}

/// The femu binary.
pub fn femu() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_femu"))
}
