//! Helpers shared by the integration tests.
#![allow(dead_code)]

use femu::artefact::codec::read_dir;
use femu::artefact::compare::{Tolerances, compare};
use femu::artefact::kinds::check_layout;
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

/// `stage/port` directories under `root`, sorted.
pub fn artefact_dirs(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let dirs = |p: &Path| -> Vec<PathBuf> {
        std::fs::read_dir(p)
            .map(|r| {
                r.flatten()
                    .map(|e| e.path())
                    .filter(|p| p.is_dir())
                    .collect()
            })
            .unwrap_or_default()
    };
    for stage in dirs(root) {
        for port in dirs(&stage) {
            out.push(port.strip_prefix(root).unwrap().to_path_buf());
        }
    }
    out.sort();
    out
}

/// Diffs the artefacts a run materialised in `out` against `fixtures/golden/<name>/`, with the
/// per-column tolerances of its `tolerances.yaml`: every artefact when `stages` is empty, else
/// only those of the named stages. `FEMU_BLESS=1` rewrites the golden set on purpose.
pub fn check_golden(name: &str, out: &Path, stages: &[&str]) {
    let golden = root().join("fixtures/golden").join(name);
    let tolerances: Tolerances = serde_yaml::from_str(
        &std::fs::read_to_string(golden.join("tolerances.yaml"))
            .expect("tolerances.yaml beside the golden artefacts"),
    )
    .unwrap();
    let chosen = |rel: &PathBuf| stages.is_empty() || stages.iter().any(|s| rel.starts_with(s));
    let got: Vec<PathBuf> = artefact_dirs(out).into_iter().filter(chosen).collect();
    if std::env::var_os("FEMU_BLESS").is_some() {
        for rel in artefact_dirs(&golden) {
            std::fs::remove_dir_all(golden.join(&rel)).unwrap();
        }
        for rel in &got {
            let (src, dst) = (out.join(rel), golden.join(rel));
            std::fs::create_dir_all(&dst).unwrap();
            let dropped = dropped_blobs(&src);
            for f in std::fs::read_dir(&src).unwrap().flatten() {
                let name = f.file_name().to_string_lossy().into_owned();
                if !dropped.contains(&name) {
                    std::fs::copy(f.path(), dst.join(&name)).unwrap();
                }
            }
            if !dropped.is_empty() {
                let path = dst.join("meta.json");
                let mut meta: serde_json::Value =
                    serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
                meta["blobs"] = serde_json::json!([]);
                let text = serde_json::to_string_pretty(&meta).unwrap() + "\n";
                std::fs::write(&path, text).unwrap();
            }
        }
        eprintln!("blessed {}", golden.display());
        return;
    }
    let want = artefact_dirs(&golden);
    assert_eq!(
        got, want,
        "the pipeline's artefacts differ from the golden set; bless on purpose with FEMU_BLESS=1"
    );
    let mut failures = Vec::new();
    for rel in &got {
        let a = read_dir(&out.join(rel)).unwrap();
        check_layout(&a).unwrap_or_else(|e| panic!("{}: {e}", rel.display()));
        let b = read_dir(&golden.join(rel)).unwrap();
        let c = compare(&a, &b, &tolerances);
        if !c.same() {
            failures.push(format!(
                "{}: {} values differ, e.g. {:?}",
                rel.display(),
                c.count,
                c.differences.first()
            ));
        }
    }
    assert!(failures.is_empty(), "{name}:\n{}", failures.join("\n"));
}

/// The blobs of the artefact in `dir` that a golden set leaves out: a posterior's plots are
/// pictures of the samples its tables hold (megabytes that the comparison does not read).
fn dropped_blobs(dir: &Path) -> Vec<String> {
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("meta.json")).unwrap()).unwrap();
    if meta["femu_artefact"] != "posterior" {
        return Vec::new();
    }
    let blobs = meta["blobs"].as_array().cloned().unwrap_or_default();
    blobs
        .iter()
        .filter_map(|b| b.as_str().map(str::to_string))
        .collect()
}

/// Final parameter values of an `update` stage's result in a run's `--out` directory.
pub fn results(out: &Path, stage: &str) -> std::collections::BTreeMap<String, f64> {
    let a = read_dir(&out.join(stage).join("result")).unwrap();
    femu::artefact::update::final_values(&a)
        .unwrap()
        .into_iter()
        .collect()
}

/// One meta value of an `update` stage's result in a run's `--out` directory (null if absent).
pub fn meta(out: &Path, stage: &str, key: &str) -> serde_json::Value {
    let a = read_dir(&out.join(stage).join("result")).unwrap();
    a.meta.get(key).cloned().unwrap_or_default()
}
