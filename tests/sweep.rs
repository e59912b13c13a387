//! Sweeps: expansion (cartesian, zip, exclude, range), stable names, dedupe by plan hash, bad
//! sweep files (snapshots in `tests/snapshots/`), resumability after an interruption, and the
//! local backend's collected table (deterministic, equal to single runs).

mod common;

use femu::cache::Cache;
use femu::sweep::{
    LocalOptions, PointState, StateDir, collect, parse_sweep, read_sweep, resolve, run_local,
};
use serde_json::json;
use std::path::{Path, PathBuf};

fn four_dof() -> String {
    common::pipeline("four-dof").display().to_string()
}

/// A sweep file over the four-DOF pipeline with `body` after the `pipeline:` line.
fn sweep_text(body: &str) -> String {
    format!("pipeline: {}\nonly: [correlation]\n{body}", four_dof())
}

fn resolved(body: &str) -> femu::sweep::Resolved {
    let s = parse_sweep(Path::new("s.yaml"), &sweep_text(body)).unwrap_or_else(|e| panic!("{e}"));
    resolve(&s).unwrap_or_else(|e| panic!("{e}"))
}

fn names(r: &femu::sweep::Resolved) -> Vec<String> {
    r.expansion.points.iter().map(|p| p.name.clone()).collect()
}

#[test]
fn cartesian_product_first_axis_slowest() {
    let r =
        resolved("matrix:\n  measured.with.level: [0.05, 0.1]\n  measured.with.seed: [1, 2, 3]\n");
    assert_eq!(
        names(&r),
        [
            "measured.level@0.05,measured.seed@1",
            "measured.level@0.05,measured.seed@2",
            "measured.level@0.05,measured.seed@3",
            "measured.level@0.1,measured.seed@1",
            "measured.level@0.1,measured.seed@2",
            "measured.level@0.1,measured.seed@3",
        ]
    );
    let p = &r.expansion.points[4];
    assert_eq!(p.overrides, ["measured.level=0.1", "measured.seed=2"]);
    assert_eq!(r.unique.len(), 6);
    // The models, their FRFs on the same lines: common to every point.
    assert_eq!(
        r.common,
        ["truth", "analytical", "measured_clean", "predicted"]
    );
}

#[test]
fn zip_groups_vary_together() {
    let r = resolved(
        "matrix:\n  measured.with.seed: [1, 2]\nzip:\n  - measured.with.level: [0.0, 0.05, 0.1]\n    measured.with.interval: [[0, 1], [-1, 1], [0, 1]]\n",
    );
    assert_eq!(r.expansion.points.len(), 6);
    let pairs: Vec<(f64, serde_json::Value)> = r
        .expansion
        .points
        .iter()
        .map(|p| (p.values[1].1.as_f64().unwrap(), p.values[2].1.clone()))
        .collect();
    assert_eq!(pairs[1], (0.05, json!([-1, 1])));
    assert_eq!(pairs[5], (0.1, json!([0, 1])));
}

#[test]
fn exclusions_and_ranges() {
    let r = resolved(
        "matrix:\n  measured.with.level: {range: [0.0, 0.15], step: 0.05}\n  measured.with.seed: {range: [1, 5], step: 2}\nexclude:\n  - {measured.with.level: 0.0}\n  - {measured.with.level: 0.1, measured.with.seed: 3}\n",
    );
    let levels: Vec<f64> = r
        .expansion
        .points
        .iter()
        .map(|p| p.values[0].1.as_f64().unwrap())
        .collect();
    // 4 levels x 3 seeds, less 3 at level 0 and one at (0.1, 3); 3 * 0.05 is named 0.15.
    assert_eq!(r.expansion.points.len(), 8);
    assert_eq!(r.expansion.excluded, 4);
    assert!(!levels.contains(&0.0));
    assert!(names(&r).contains(&"measured.level@0.15,measured.seed@5".to_string()));
    assert!(!names(&r).contains(&"measured.level@0.1,measured.seed@3".to_string()));
    let seeds: Vec<i64> = r.expansion.points[..3]
        .iter()
        .map(|p| p.values[1].1.as_i64().unwrap())
        .collect();
    assert_eq!(seeds, [1, 3, 5]);
}

#[test]
fn names_are_stable_under_reordering_and_insertion() {
    let a = resolved("matrix:\n  measured.with.level: [0.05, 0.1]\n  measured.with.seed: [1, 2]\n");
    let b = resolved(
        "matrix:\n  measured.with.seed: [2, 1]\n  measured.with.level: [0.1, 0.07, 0.05]\n",
    );
    let (mut na, nb) = (names(&a), names(&b));
    for n in &na {
        assert!(nb.contains(n), "{n} renamed: {nb:?}");
    }
    // The same name is the same computation.
    let hash = |r: &femu::sweep::Resolved, n: &str| {
        r.unique
            .iter()
            .find(|u| u.point.name == n)
            .map(|u| u.plan_hash.clone())
    };
    for n in &na {
        assert_eq!(hash(&a, n), hash(&b, n));
    }
    // Lists are named by content, not position.
    let c =
        resolved("matrix:\n  measured_clean.with.responses: [[\"1:ux\", \"2:ux\"], [\"3:ux\"]]\n");
    let d = resolved(
        "matrix:\n  measured_clean.with.responses: [[\"3:ux\"], [\"4:ux\"], [\"1:ux\", \"2:ux\"]]\n",
    );
    na = names(&c);
    for n in &na {
        assert!(names(&d).contains(n), "{n}");
    }
}

#[test]
fn points_with_identical_plans_run_once() {
    // The plot is not run (`only: [correlation]`), so its title does not change the plan.
    let r = resolved("matrix:\n  measured.with.seed: [1, 2]\n  plot.with.title: [a, b, c]\n");
    assert_eq!(r.expansion.points.len(), 6);
    assert_eq!(r.unique.len(), 2);
    assert_eq!(r.duplicates.len(), 4);
    assert_eq!(
        r.duplicates[0],
        (
            "measured.seed@1,plot.title@b".to_string(),
            "measured.seed@1,plot.title@a".to_string()
        )
    );
}

/// The error messages for a sweep file.
fn errors(body: &str) -> String {
    let text = format!("pipeline: {}\n{body}", four_dof());
    let result = parse_sweep(Path::new("bad.yaml"), &text).and_then(|s| resolve(&s).map(|_| ()));
    match result {
        Ok(()) => panic!("expected an error for:\n{body}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_unknown_top_level_key() {
    insta::assert_snapshot!(errors("matrx:\n  measured.with.seed: [1, 2]\n"));
}

#[test]
fn bad_unknown_stage_in_a_path() {
    insta::assert_snapshot!(errors("matrix:\n  mesured.with.seed: [1, 2]\n"));
}

#[test]
fn bad_path_without_with() {
    insta::assert_snapshot!(errors("matrix:\n  measured.seed: [1, 2]\n"));
}

#[test]
fn bad_value_is_reported_at_its_position() {
    insta::assert_snapshot!(errors(
        "matrix:\n  measured.with.level: [0.05, -0.1, 0.2]\n"
    ));
}

#[test]
fn bad_unknown_parameter() {
    insta::assert_snapshot!(errors("matrix:\n  measured.with.sead: [1, 2]\n"));
}

#[test]
fn bad_zip_lengths() {
    insta::assert_snapshot!(errors(
        "zip:\n  - measured.with.level: [0.0, 0.05]\n    measured.with.seed: [1, 2, 3]\n"
    ));
}

#[test]
fn bad_exclusions() {
    insta::assert_snapshot!(errors(
        "matrix:\n  measured.with.seed: [1, 2]\nexclude:\n  - {measured.with.level: 0.1}\n  - {measured.with.seed: 7}\n"
    ));
}

#[test]
fn bad_range() {
    insta::assert_snapshot!(errors(
        "matrix:\n  measured.with.seed: {range: [5, 1]}\n  measured.with.level: {range: [0, 1], stp: 0.1}\n"
    ));
}

#[test]
fn bad_value_listed_twice() {
    insta::assert_snapshot!(errors(
        "matrix:\n  measured.with.level: [0.05, 0.1, 0.050]\n"
    ));
}

#[test]
fn bad_collect_and_plots() {
    insta::assert_snapshot!(errors(
        "matrix:\n  measured.with.seed: [1, 2]\ncollect:\n  chi: correlation.correlation.lines.chi_z\n  m: {from: correlation.correlatio.lines.chi_s, reduce: mean}\n  r: {from: correlation.correlation.lines.chi_s, reduce: median}\nplots:\n  - {column: nope, by: measured.with.level}\n"
    ));
}

#[test]
fn bad_slurm_resources() {
    insta::assert_snapshot!(errors(
        "matrix:\n  measured.with.seed: [1, 2]\nslurm:\n  time: 2h\n  mem: 1.5G\n  cpus_per_task: 0\n  extra: [qos=short]\n"
    ));
}

#[test]
fn bad_duplicate_key_and_missing_pipeline() {
    insta::assert_snapshot!(errors(
        "matrix:\n  measured.with.seed: [1]\n  measured.with.seed: [2]\n"
    ));
    let e = parse_sweep(Path::new("bad.yaml"), "pipeline: nowhere.yaml\n")
        .and_then(|s| resolve(&s).map(|_| ()))
        .unwrap_err();
    insta::assert_snapshot!("missing_pipeline", e.to_string());
}

/// Writes a sweep file into `dir`.
fn write_sweep(dir: &Path, body: &str) -> PathBuf {
    let path = dir.join("sweep.yaml");
    std::fs::write(&path, sweep_text(body)).unwrap();
    path
}

const SMALL: &str = "matrix:\n  measured.with.level: [0.0, 0.05, 0.1]\n  measured.with.seed: {range: [1, 4]}\ncollect:\n  mean_chi_s: correlation.correlation.meta.summary.mean_chi_s\n  min_chi_a: {from: correlation.correlation.lines.chi_a, reduce: min}\nplots:\n  - {column: mean_chi_s, by: measured.with.level}\n";

fn local(jobs: usize) -> LocalOptions {
    LocalOptions {
        jobs,
        exe: PathBuf::from(env!("CARGO_BIN_EXE_femu")),
        progress: false,
    }
}

fn run_sweep(
    dir: &Path,
    body: &str,
    jobs: usize,
) -> (
    femu::sweep::Resolved,
    femu::sweep::SweepReport,
    Cache,
    StateDir,
) {
    let file = write_sweep(dir, body);
    let r = resolve(&read_sweep(&file).unwrap()).unwrap();
    let cache = Cache::open(&dir.join("cache")).unwrap();
    let state = StateDir::open(&dir.join("state")).unwrap();
    let report = run_local(&r, &cache, &state, &local(jobs)).unwrap();
    (r, report, cache, state)
}

#[test]
fn local_backend_collects_a_deterministic_table_equal_to_single_runs() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let (ra, rep_a, cache_a, state_a) = run_sweep(a.path(), SMALL, 2);
    let (rb, rep_b, cache_b, state_b) = run_sweep(b.path(), SMALL, 1);
    assert_eq!((rep_a.ran, rep_a.failed.len()), (12, 0));
    assert_eq!(rep_b.ran, 12);
    // The common upstream ran once: 4 stages, then per point the noise and the correlation at
    // most (level 0 gives the same noisy FRF for every seed, so its correlation is cut off early).
    assert_eq!(rep_a.requested, 4 + 12 * 6);
    assert!(rep_a.executed <= 4 + 12 * 2, "{rep_a:?}");
    let ca = collect(&ra, &state_a, &cache_a, &a.path().join("out")).unwrap();
    let cb = collect(&rb, &state_b, &cache_b, &b.path().join("out")).unwrap();
    assert_eq!(ca.digest, cb.digest);
    assert_eq!(
        std::fs::read(&ca.path).unwrap(),
        std::fs::read(&cb.path).unwrap()
    );
    assert_eq!(ca.plots.len(), 2);
    for (x, y) in ca.plots.iter().zip(&cb.plots) {
        assert_eq!(std::fs::read(x).unwrap(), std::fs::read(y).unwrap());
    }
    let t = &ca.table;
    let cols: Vec<&str> = t.columns.iter().map(|c| c.0.as_str()).collect();
    assert_eq!(
        cols,
        [
            "point",
            "measured.level",
            "measured.seed",
            "mean_chi_s",
            "min_chi_a"
        ]
    );
    assert_eq!(t.rows(), 12);
    // Row 5 is level 0.05, seed 2: the same as `femu run --set`.
    let (_, single, cache) = common::run(
        &common::pipeline("four-dof"),
        &a.path().join("single"),
        &["measured.level=0.05", "measured.seed=2"],
    );
    let corr = single
        .stages
        .iter()
        .find(|s| s.name == "correlation")
        .unwrap();
    let art = cache
        .read(
            &corr.key,
            "correlation",
            femu::artefact::ArtefactKind::Correlation,
        )
        .unwrap();
    let want = art.meta["summary"]["mean_chi_s"].as_f64().unwrap();
    assert_eq!(t.f64s("t", "mean_chi_s").unwrap()[5], want);
    assert_eq!(t.f64s("t", "measured.level").unwrap()[5], 0.05);
    assert_eq!(t.i64s("t", "measured.seed").unwrap()[5], 2);
    // The table opens as plain Parquet.
    let back = femu::artefact::codec::read_parquet(&ca.path).unwrap();
    assert_eq!(&back, t);
}

#[test]
fn whole_columns_are_collected_in_long_form() {
    let dir = tempfile::tempdir().unwrap();
    let body = "matrix:\n  measured.with.seed: [1, 2]\ncollect:\n  mean_chi: correlation.correlation.meta.summary.mean_chi\n  frac: correlation.correlation.frac\n";
    let (r, rep, cache, state) = run_sweep(dir.path(), body, 2);
    assert_eq!(rep.ran, 2);
    let c = collect(&r, &state, &cache, &dir.path().join("out")).unwrap();
    let cols: Vec<&str> = c.table.columns.iter().map(|c| c.0.as_str()).collect();
    assert_eq!(
        cols,
        [
            "point",
            "measured.seed",
            "row",
            "mean_chi",
            "frac.response",
            "frac.excitation",
            "frac.frac"
        ]
    );
    // Four FRFs per point.
    assert_eq!(c.table.rows(), 8);
    assert_eq!(*c.table.i64s("t", "row").unwrap(), [0, 1, 2, 3, 0, 1, 2, 3]);
}

#[test]
fn a_rerun_runs_only_unfinished_points() {
    let dir = tempfile::tempdir().unwrap();
    let (r, first, cache, state) = run_sweep(dir.path(), SMALL, 2);
    assert_eq!(first.ran, 12);
    // Nothing to do the second time.
    let again = run_local(&r, &cache, &state, &local(2)).unwrap();
    assert_eq!((again.ran, again.already_done, again.executed), (0, 12, 0));
    // Lose two points, and leave one "running" by a process that is gone.
    for u in &r.unique[..2] {
        std::fs::remove_dir_all(state.point_dir(&u.point.name)).unwrap();
    }
    let mut s = state.status(&r.unique[2].point.name).unwrap();
    s.state = PointState::Running;
    s.pid = u32::MAX - 1;
    state.write_status(&s).unwrap();
    let third = run_local(&r, &cache, &state, &local(2)).unwrap();
    assert_eq!((third.ran, third.already_done), (3, 9));
    // Their stages are all in the cache already.
    assert_eq!(third.executed, 0);
}

#[test]
fn an_interrupted_sweep_resumes_where_it_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let body = "matrix:\n  measured.with.level: [0.02, 0.04, 0.06, 0.08, 0.1]\n  measured.with.seed: {range: [1, 12]}\n";
    let file = write_sweep(dir.path(), body);
    let cache_dir = dir.path().join("cache");
    let out = dir.path().join("state");
    let mut child = common::femu()
        .args(["sweep", "--jobs", "1", "--quiet", "--cache-dir"])
        .arg(&cache_dir)
        .arg("--out")
        .arg(&out)
        .arg(&file)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let r = resolve(&read_sweep(&file).unwrap()).unwrap();
    let state = StateDir::open(&out).unwrap();
    let done = |state: &StateDir| {
        r.unique
            .iter()
            .filter(|u| state.is_done(&u.point.name, &u.plan_hash))
            .count()
    };
    let t0 = std::time::Instant::now();
    while done(&state) < 5 && t0.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    // The worker of the moment may still finish its point; wait for it to settle.
    std::thread::sleep(std::time::Duration::from_millis(500));
    let before = done(&state);
    assert!(
        before >= 5,
        "only {before} points finished before the interruption"
    );
    if before == r.unique.len() {
        eprintln!("the sweep finished before it could be interrupted; nothing to resume");
        return;
    }
    let cache = Cache::open(&cache_dir).unwrap();
    let rest = run_local(&r, &cache, &state, &local(2)).unwrap();
    assert_eq!(rest.already_done, before);
    assert_eq!(rest.ran, r.unique.len() - before);
    assert!(rest.failed.is_empty());
}

#[test]
fn the_cli_runs_reports_status_with_failures_and_collects() {
    let dir = tempfile::tempdir().unwrap();
    let body = "matrix:\n  measured_clean.with.responses: [[\"1:ux\", \"2:ux\"], [\"1:ux\", \"9:ux\"]]\ncollect:\n  mean_chi: correlation.correlation.meta.summary.mean_chi\n";
    let file = write_sweep(dir.path(), body);
    let cache = dir.path().join("cache");
    let run = common::femu()
        .args(["sweep", "--quiet", "--cache-dir"])
        .arg(&cache)
        .arg(&file)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert_eq!(run.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains("1 points run, 1 failed"), "{stdout}");
    assert!(stdout.contains("stages requested"), "{stdout}");
    assert!(stdout.contains("collected 1 points"), "{stdout}");
    let status = common::femu()
        .args(["sweep", "status", "--cache-dir"])
        .arg(&cache)
        .arg(&file)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&status.stdout);
    assert!(
        text.contains("1 done, 0 running, 1 failed, 0 pending"),
        "{text}"
    );
    assert!(
        text.contains("DOF 9:ux is not a DOF of the model"),
        "{text}"
    );
    // Bad input exits 2 with a located message.
    std::fs::write(
        dir.path().join("bad.yaml"),
        sweep_text("matrix:\n  measured.with.level: [x]\n"),
    )
    .unwrap();
    let bad = common::femu()
        .args(["sweep", "--dry-run", "--cache-dir"])
        .arg(&cache)
        .arg(dir.path().join("bad.yaml"))
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("bad.yaml:4:25:"), "{err}");
}

#[test]
fn slurm_dry_run_prints_the_job_array_without_slurm() {
    let dir = tempfile::tempdir().unwrap();
    let body = format!(
        "{SMALL}slurm:\n  partition: short\n  time: \"00:20:00\"\n  mem: 2G\n  cpus_per_task: 2\n  array_limit: 4\n  extra: [--qos=low]\n"
    );
    let file = write_sweep(dir.path(), &body);
    let out = common::femu()
        .args(["sweep", "--backend", "slurm", "--dry-run", "--cache-dir"])
        .arg(dir.path().join("cache"))
        .arg(&file)
        .env("PATH", "/nonexistent")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{text}");
    for line in [
        "#SBATCH --array=0-11%4",
        "#SBATCH --partition=short",
        "#SBATCH --time=00:20:00",
        "#SBATCH --mem=2G",
        "#SBATCH --cpus-per-task=2",
        "#SBATCH --qos=low",
        "#SBATCH --job-name=femu-sweep-common",
        "--task \"${SLURM_ARRAY_TASK_ID}\" --per-task 1",
        "--common --batch",
    ] {
        assert!(text.contains(line), "missing `{line}` in:\n{text}");
    }
    // Nothing was submitted or recorded.
    assert!(!dir.path().join("cache/sweeps/sweep/runs.jsonl").exists());
    // Without Slurm, a real submission says what is missing.
    let out = common::femu()
        .args(["sweep", "--backend", "slurm", "--cache-dir"])
        .arg(dir.path().join("cache"))
        .arg(&file)
        .env("PATH", "/nonexistent")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("is Slurm installed"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn shipped_sweeps_are_valid() {
    for e in std::fs::read_dir(common::root().join("sweeps"))
        .unwrap()
        .flatten()
    {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "yaml") {
            let s = read_sweep(&p).unwrap_or_else(|e| panic!("{e}"));
            let r = resolve(&s).unwrap_or_else(|e| panic!("{e}"));
            assert!(!r.unique.is_empty(), "{}", p.display());
        }
    }
}

/// The sweep file shown in the README is valid.
#[test]
fn the_readme_sweep_is_valid() {
    let readme = std::fs::read_to_string(common::root().join("README.md")).unwrap();
    let section = &readme[readme
        .find("## Parameter sweeps")
        .expect("README has a sweeps section")..];
    let start = section.find("```yaml\n").expect("a YAML block") + 8;
    let end = start + section[start..].find("```").unwrap();
    let text = section[start..end].replace("../pipelines/four-dof.yaml", &four_dof());
    let s = parse_sweep(Path::new("README.md"), &text).unwrap_or_else(|e| panic!("{e}"));
    let r = resolve(&s).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.expansion.points.len(), 4 * 25 * 2 - 2);
}

/// Stand-ins for `sbatch`, `squeue` and `sacct` that run the submitted scripts at once, skipping
/// the array task `$FAKE_SKIP_TASK` as if Slurm had killed it at its time limit.
fn fake_slurm(dir: &Path) -> String {
    let bin = dir.join("fake-bin");
    std::fs::create_dir_all(&bin).unwrap();
    let sbatch = r#"#!/bin/bash
for last; do :; done
dir=$(dirname "$0")
id=$(( $(cat "$dir/next" 2>/dev/null || echo 100) + 1 )); echo "$id" > "$dir/next"
n=$(sed -n 's/^#SBATCH --array=0-\([0-9]*\).*/\1/p' "$last")
if [ -n "$n" ]; then
  for i in $(seq 0 "$n"); do
    if [ "$i" = "${FAKE_SKIP_TASK:-x}" ]; then echo "${id}_$i|TIMEOUT|0:15" >> "$dir/sacct.txt"; continue; fi
    SLURM_ARRAY_JOB_ID=$id SLURM_ARRAY_TASK_ID=$i bash "$last" > /dev/null 2>&1
    echo "${id}_$i|COMPLETED|0:0" >> "$dir/sacct.txt"
  done
else
  SLURM_JOB_ID=$id bash "$last" > /dev/null 2>&1
fi
echo "$id"
"#;
    let tools = [
        ("sbatch", sbatch.to_string()),
        ("squeue", "#!/bin/sh\nexit 0\n".to_string()),
        (
            "sacct",
            "#!/bin/sh\ncat \"$(dirname \"$0\")/sacct.txt\" 2>/dev/null\n".to_string(),
        ),
    ];
    for (name, text) in tools {
        let p = bin.join(name);
        std::fs::write(&p, text).unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    )
}

#[test]
fn slurm_backend_records_tasks_slurm_killed_and_resubmits_only_them() {
    let dir = tempfile::tempdir().unwrap();
    let body = format!("{SMALL}slurm:\n  points_per_task: 5\n");
    let file = write_sweep(dir.path(), &body);
    let path = fake_slurm(dir.path());
    let sweep = |skip: &str| {
        common::femu()
            .args([
                "sweep",
                "--backend",
                "slurm",
                "--quiet",
                "--poll",
                "0.05",
                "--cache-dir",
            ])
            .arg(dir.path().join("cache"))
            .arg(&file)
            .env("PATH", &path)
            .env("FAKE_SKIP_TASK", skip)
            .output()
            .unwrap()
    };
    // 12 points in tasks of 5: task 1 (points 5..10) is "killed".
    let first = sweep("1");
    let text = String::from_utf8_lossy(&first.stdout);
    assert_eq!(first.status.code(), Some(1), "{text}");
    assert!(text.contains("7 points run, 5 failed"), "{text}");
    assert!(
        text.contains("Slurm ended task 1 as TIMEOUT (exit 0:15)"),
        "{text}"
    );
    assert!(text.contains("collected 7 points"), "{text}");
    let status = common::femu()
        .args(["sweep", "status", "--cache-dir"])
        .arg(dir.path().join("cache"))
        .arg(&file)
        .env("PATH", &path)
        .output()
        .unwrap();
    let st = String::from_utf8_lossy(&status.stdout);
    assert!(
        st.contains("7 done, 0 running, 5 failed, 0 pending"),
        "{st}"
    );
    // The rerun submits the five failed points only, in one task.
    let second = sweep("none");
    let text = String::from_utf8_lossy(&second.stdout);
    assert_eq!(second.status.code(), Some(0), "{text}");
    assert!(
        text.contains("submitted 5 points in 1 array tasks"),
        "{text}"
    );
    assert!(text.contains("collected 12 points"), "{text}");
    // The same table as the local backend's.
    let local_dir = tempfile::tempdir().unwrap();
    let (r, _, cache, state) = run_sweep(local_dir.path(), &body, 2);
    let local = collect(&r, &state, &cache, &local_dir.path().join("out")).unwrap();
    let slurm = std::fs::read(
        dir.path()
            .join("cache/sweeps/sweep/collected/collected.parquet"),
    )
    .unwrap();
    assert_eq!(std::fs::read(&local.path).unwrap(), slurm);
}

fn shipped(name: &str) -> PathBuf {
    common::root().join("sweeps").join(format!("{name}.yaml"))
}

/// Runs the shipped sweep `name` on two workers with the cache in `cache` and the given
/// `--set`s; asserts success and returns what it printed.
fn run_shipped_sweep(cache: &Path, name: &str, sets: &[&str]) -> String {
    let mut cmd = common::femu();
    cmd.args(["sweep", "--quiet", "--jobs", "2", "--cache-dir"])
        .arg(cache)
        .arg(shipped(name));
    for s in sets {
        cmd.args(["--set", s]);
    }
    let out = cmd.output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// The C1 non-uniqueness sweep, narrowed by `--set` to two seeds and the complete data: the RFM
/// recovers every mass exactly from noise-free data, and noise moves the estimates.
#[test]
fn four_dof_noise_sweep_narrowed_by_set() {
    let dir = tempfile::tempdir().unwrap();
    let out = common::femu()
        .args(["sweep", "--quiet", "--jobs", "2", "--cache-dir"])
        .arg(dir.path())
        .arg(shipped("four-dof-noise"))
        .args(["--set", "noisy_05.with.seed=[1, 2]"])
        .args([
            "--set",
            r#"complete.with.responses=[["1:ux", "2:ux", "3:ux", "4:ux"]]"#,
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("8 points run, 0 failed"), "{text}");
    let table = femu::artefact::codec::read_parquet(
        &dir.path()
            .join("sweeps/four-dof-noise/collected/collected.parquet"),
    )
    .unwrap();
    assert_eq!(table.rows(), 8 * 4);
    let level = table.f64s("t", "noisy_05.level").unwrap();
    let rfm = table.f64s("t", "rfm.final").unwrap();
    let pc = table.f64s("t", "pc_final").unwrap();
    for i in 0..table.rows() {
        if level[i] == 0.0 {
            assert!((rfm[i] - 1.0).abs() < 1e-6, "row {i}: RFM {}", rfm[i]);
        }
        assert!(rfm[i].is_finite() && pc[i].is_finite());
    }
    let noisy: Vec<f64> = (0..table.rows())
        .filter(|&i| level[i] == 0.15)
        .map(|i| rfm[i])
        .collect();
    assert!(noisy.iter().any(|m| (m - 1.0).abs() > 1e-3), "{noisy:?}");
}

/// The C2 P-C sweep at its small default size, then grown by `--set`: only the new points run.
#[test]
fn bent_plate_pc_sweep_grows_by_set() {
    let dir = tempfile::tempdir().unwrap();
    let run = |sets: &[&str]| run_shipped_sweep(dir.path(), "bent-plate-pc-noise", sets);
    let first = run(&[]);
    assert!(first.contains("4 points run, 0 failed"), "{first}");
    assert!(first.contains("collected 4 points, 36 rows"), "{first}");
    let second = run(&["measured.with.seed={range: [1, 3]}"]);
    assert!(
        second.contains("2 points run, 0 failed, 4 were done already"),
        "{second}"
    );
    assert!(second.contains("collected 6 points, 54 rows"), "{second}");
    let table = femu::artefact::codec::read_parquet(
        &dir.path()
            .join("sweeps/bent-plate-pc-noise/collected/collected.parquet"),
    )
    .unwrap();
    let names = table.strs("t", "t.parameter").unwrap();
    let t = table.f64s("t", "t.final").unwrap();
    let init = table.f64s("t", "t.initial").unwrap();
    // Every strip's estimate within its bounds; the wrong strip (t5, strip 7) starts at 0.8 mm everywhere
    // (where it ends depends on the noise draw: the spread the sweep is for).
    let lower = table.f64s("t", "t.lower").unwrap();
    let upper = table.f64s("t", "t.upper").unwrap();
    for i in 0..table.rows() {
        assert!(t[i] >= lower[i] && t[i] <= upper[i], "row {i}: {}", t[i]);
        if names[i] == "t5" {
            assert_eq!(init[i], 0.8e-3);
        }
    }
    assert_eq!(names.iter().filter(|n| *n == "t5").count(), 6);
}

/// The C2 P-C over six choices of measured points, with and without noise: the thesis's stop
/// rule is met every time with the strips beside the bend split wrongly (t5 more than 5 % under
/// its true 1.4 mm) but their sum near the true 2.8 mm, noise-free data included. This pins the
/// finding that the 5 % target on t5 is out of reach of the stop rule on this reconstruction
/// (see the sweep's description); a change to the method that moved it would show here.
#[test]
fn bent_plate_pc_stops_on_the_bend_ridge_for_every_point_choice() {
    let dir = tempfile::tempdir().unwrap();
    run_shipped_sweep(dir.path(), "bent-plate-pc-points", &[]);
    let table = femu::artefact::codec::read_parquet(
        &dir.path()
            .join("sweeps/bent-plate-pc-points/collected/collected.parquet"),
    )
    .unwrap();
    let points = table.strs("point", "point").unwrap();
    let names = table.strs("t", "t.parameter").unwrap();
    let t = table.f64s("t", "t.final").unwrap();
    let chi = table.f64s("mean_chi", "mean_chi").unwrap();
    let mut seen = 0;
    for i in (0..table.rows()).filter(|&i| names[i] == "t5") {
        let j = (0..table.rows())
            .find(|&j| points[j] == points[i] && names[j] == "t6")
            .unwrap();
        assert!(chi[i] >= 0.99, "{}: mean chi {}", points[i], chi[i]);
        assert!(
            t[i] < 0.95 * 1.4e-3 && t[i] > 1.0e-3,
            "{}: t5 {}",
            points[i],
            t[i]
        );
        assert!(
            ((t[i] + t[j]) / 2.8e-3 - 1.0).abs() < 0.05,
            "{}: t5 + t6 = {}",
            points[i],
            t[i] + t[j]
        );
        seen += 1;
    }
    assert_eq!(seen, 12);
}

/// The coverage sweep of the credible intervals, narrowed by `--set` to three seeds: per point
/// the Laplace and TMCMC posteriors of the four masses, their intervals collected in long form
/// (a row per mass and point) from which the coverage is counted.
#[test]
fn four_dof_bayes_coverage_sweep_narrowed_by_set() {
    let dir = tempfile::tempdir().unwrap();
    let text = run_shipped_sweep(
        dir.path(),
        "four-dof-bayes-coverage",
        &["measured.with.seed=[1, 2, 3]"],
    );
    assert!(text.contains("3 points run, 0 failed"), "{text}");
    let table = femu::artefact::codec::read_parquet(
        &dir.path()
            .join("sweeps/four-dof-bayes-coverage/collected/collected.parquet"),
    )
    .unwrap();
    assert_eq!(table.rows(), 3 * 4);
    for method in ["laplace", "tmcmc"] {
        let (lo, hi) = (
            table.f64s("t", &format!("{method}.lower")).unwrap(),
            table.f64s("t", &format!("{method}.upper")).unwrap(),
        );
        for i in 0..table.rows() {
            assert!(
                lo[i] < hi[i] && hi[i] - lo[i] < 0.05,
                "{method} row {i}: [{}, {}]",
                lo[i],
                hi[i]
            );
        }
    }
}
