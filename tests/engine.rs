//! The engine on real pipelines: determinism, cache hits, partial re-runs, early cutoff,
//! corruption recovery, concurrent processes, `femu diff`.

mod common;

use common::*;
use femu::pipeline::Status;
use std::collections::BTreeMap;

fn digests(report: &femu::pipeline::RunReport) -> BTreeMap<String, String> {
    report
        .stages
        .iter()
        .flat_map(|s| {
            s.outputs
                .iter()
                .map(move |(p, o)| (format!("{}.{p}", s.name), o.digest.clone()))
        })
        .collect()
}

#[test]
fn two_runs_in_fresh_caches_give_identical_digests() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let (_, r1, _) = run(&pipeline("four-dof"), a.path(), &[]);
    let (_, r2, _) = run(&pipeline("four-dof"), b.path(), &[]);
    assert_eq!(digests(&r1), digests(&r2));
    assert_eq!(executed(&r2).len(), r2.stages.len());
}

#[test]
fn an_unchanged_rerun_executes_no_stage() {
    let dir = tempfile::tempdir().unwrap();
    let (_, first, _) = run(&pipeline("four-dof"), dir.path(), &[]);
    assert_eq!(executed(&first).len(), first.stages.len());
    let (_, second, _) = run(&pipeline("four-dof"), dir.path(), &[]);
    assert_eq!(executed(&second), Vec::<String>::new());
    assert_eq!(digests(&first), digests(&second));
}

#[test]
fn changing_one_param_reruns_only_downstream() {
    let dir = tempfile::tempdir().unwrap();
    run(&pipeline("four-dof"), dir.path(), &[]);
    let (plan, report, _) = run(&pipeline("four-dof"), dir.path(), &["measured.seed=2"]);
    let ran = executed(&report);
    let measured = plan.index("measured").unwrap();
    let downstream: Vec<String> = plan
        .nodes
        .iter()
        .enumerate()
        .filter(|(i, _)| *i == measured || plan.upstream_closure(&[*i]).contains(&measured))
        .map(|(_, n)| n.name.clone())
        .collect();
    assert!(
        ran.contains(&"measured".to_string()) && ran.contains(&"correlation".to_string()),
        "{ran:?}"
    );
    assert_eq!(ran, downstream);
}

/// A stage re-run with other parameters but identical outputs leaves its consumers cached.
#[test]
fn identical_outputs_stop_recomputation_downstream() {
    let dir = tempfile::tempdir().unwrap();
    let p = pipeline("four-dof");
    let text = std::fs::read_to_string(&p).unwrap().replace(
        "  analytical_modes:\n    kind: modes\n    inputs: {model: analytical}\n",
        "  analytical_modes:\n    kind: modes\n    inputs: {model: analytical}\n    with: {count: 4}\n\n  modal:\n    kind: frf.synthesise\n    inputs: {modes: analytical_modes}\n    with: {responses: [\"1:ux\"], excitations: [\"1:ux\"], band_hz: [1, 5], step_hz: 1}\n",
    );
    let file = dir.path().join("p.yaml");
    std::fs::write(&file, text).unwrap();
    let cache = dir.path().join("cache");
    run(&file, &cache, &[]);
    // All four modes either way: `max_freq_hz: 100` changes the key, not the content.
    let (_, report, _) = run(
        &file,
        &cache,
        &[
            "analytical_modes.count=null",
            "analytical_modes.max_freq_hz=100",
        ],
    );
    assert_eq!(executed(&report), vec!["analytical_modes".to_string()]);
}

#[test]
fn a_corrupted_artefact_is_detected_and_recomputed() {
    let dir = tempfile::tempdir().unwrap();
    let (_, first, cache) = run(&pipeline("four-dof"), dir.path(), &[]);
    let victim = first.stages.iter().find(|s| s.name == "predicted").unwrap();
    let file = cache
        .artefact_dir(&victim.key, "frf")
        .unwrap()
        .join("frf.parquet");
    let mut bytes = std::fs::read(&file).unwrap();
    let n = bytes.len();
    bytes[n / 2] ^= 0x5a;
    std::fs::write(&file, bytes).unwrap();
    let (_, second, _) = run(&pipeline("four-dof"), dir.path(), &[]);
    let s = second
        .stages
        .iter()
        .find(|s| s.name == "predicted")
        .unwrap();
    assert_eq!(s.status, Status::Recovered);
    assert!(s.note.as_deref().unwrap_or("").contains("corrupt"));
    assert_eq!(
        executed(&second),
        vec!["predicted".to_string()],
        "downstream stays cached: same digest"
    );
    assert_eq!(digests(&first), digests(&second));
}

#[test]
fn two_processes_on_one_cache_both_succeed() {
    let dir = tempfile::tempdir().unwrap();
    let spawn = |out: &str| {
        femu()
            .args(["run", "--quiet", "--cache-dir"])
            .arg(dir.path().join("cache"))
            .arg("--out")
            .arg(dir.path().join(out))
            .arg(pipeline("four-dof"))
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let (mut a, mut b) = (spawn("a"), spawn("b"));
    assert!(a.wait().unwrap().success());
    assert!(b.wait().unwrap().success());
    let la = std::fs::read_to_string(dir.path().join("a/femu.lock.json")).unwrap();
    let lb = std::fs::read_to_string(dir.path().join("b/femu.lock.json")).unwrap();
    assert_eq!(la, lb);
    let status = femu()
        .arg("diff")
        .arg(dir.path().join("a"))
        .arg(dir.path().join("b"))
        .output()
        .unwrap();
    assert_eq!(status.status.code(), Some(0));
}

#[test]
fn diff_finds_a_changed_value_and_exits_one() {
    let dir = tempfile::tempdir().unwrap();
    let run_to = |out: &str, seed: &str| {
        let s = femu()
            .args(["run", "--quiet", "--cache-dir"])
            .arg(dir.path().join("cache"))
            .arg("--out")
            .arg(dir.path().join(out))
            .args(["--set", &format!("measured.seed={seed}")])
            .arg(pipeline("four-dof"))
            .output()
            .unwrap();
        assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
    };
    run_to("a", "1");
    run_to("b", "2");
    let same = femu()
        .arg("diff")
        .arg(dir.path().join("a/predicted/frf"))
        .arg(dir.path().join("b/predicted/frf"))
        .output()
        .unwrap();
    assert_eq!(same.status.code(), Some(0));
    let d = femu()
        .arg("diff")
        .arg(dir.path().join("a/measured/frf"))
        .arg(dir.path().join("b/measured/frf"))
        .output()
        .unwrap();
    assert_eq!(d.status.code(), Some(1));
    let text = String::from_utf8_lossy(&d.stdout);
    assert!(
        text.contains("DIFFERENT") && text.contains("frf.re row"),
        "{text}"
    );
    // Thesis noise at 5 % changes values by less than 5.1 %: a loose tolerance accepts it.
    let loose = femu()
        .arg("diff")
        .args(["--rtol", "0.06"])
        .arg(dir.path().join("a/measured/frf"))
        .arg(dir.path().join("b/measured/frf"))
        .output()
        .unwrap();
    assert_eq!(
        loose.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&loose.stdout)
    );
    let missing = femu()
        .arg("diff")
        .arg(dir.path().join("nope"))
        .arg(dir.path().join("b"))
        .output()
        .unwrap();
    assert_eq!(missing.status.code(), Some(2));
}

#[test]
fn only_runs_the_stage_and_its_upstream() {
    let dir = tempfile::tempdir().unwrap();
    let plan = load(&pipeline("four-dof"), &[]);
    let cache = femu::cache::Cache::open(dir.path()).unwrap();
    let opts = femu::pipeline::RunOptions {
        only: vec!["measured".into()],
        progress: femu::pipeline::ProgressMode::Quiet,
        ..Default::default()
    };
    let r = femu::pipeline::execute(&plan, &cache, &opts).unwrap();
    let names: Vec<&str> = r.stages.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, vec!["truth", "measured_clean", "measured"]);
    let forced = femu::pipeline::execute(
        &plan,
        &cache,
        &femu::pipeline::RunOptions {
            force: true,
            ..opts
        },
    )
    .unwrap();
    assert_eq!(executed(&forced).len(), 3);
}

/// `format: hdf5` writes one `data.h5` per artefact; the content digests are the same as with
/// Parquet/IPC, so the choice of storage never changes a downstream key's inputs.
#[cfg(feature = "hdf5")]
#[test]
fn hdf5_outputs_have_the_same_digests() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(pipeline("four-dof")).unwrap();
    let mut hdf = String::new();
    for line in text.lines() {
        hdf.push_str(line);
        hdf.push('\n');
        if line.starts_with("    kind: ") {
            hdf.push_str("    format: hdf5\n");
        }
    }
    let file = dir.path().join("p.yaml");
    std::fs::write(&file, hdf).unwrap();
    let (_, a, cache) = run(&file, &dir.path().join("c1"), &[]);
    let (_, b, _) = run(&pipeline("four-dof"), &dir.path().join("c2"), &[]);
    assert_eq!(digests(&a), digests(&b));
    let s = &a.stages[0];
    assert!(
        cache
            .artefact_dir(&s.key, "model")
            .unwrap()
            .join("data.h5")
            .exists()
    );
}

/// Cache entries are written in the background while the stages downstream run: when the run
/// returns, every stage that ran has its entry committed (a second run is served whole from the
/// cache, with the same digests) and its write time reported; a cached stage reports none.
#[test]
fn background_commits_are_complete_when_the_run_returns() {
    let dir = tempfile::tempdir().unwrap();
    let (_, first, cache) = run(&pipeline("four-dof"), dir.path(), &[]);
    for s in &first.stages {
        assert!(
            s.cache_write.is_some(),
            "{} ran: its write is timed",
            s.name
        );
        assert!(
            matches!(cache.lookup(&s.key), femu::cache::Lookup::Hit(_)),
            "{}'s entry is committed",
            s.name
        );
    }
    let (_, second, _) = run(&pipeline("four-dof"), dir.path(), &[]);
    assert_eq!(executed(&second), Vec::<String>::new());
    assert!(second.stages.iter().all(|s| s.cache_write.is_none()));
    assert_eq!(digests(&first), digests(&second));
}

/// A cache entry that cannot be written fails the run, naming the stage, once every other
/// write has finished; nothing of it is left committed or half-written.
#[test]
fn a_failed_background_commit_fails_the_run_naming_its_stage() {
    let dir = tempfile::tempdir().unwrap();
    let cache = femu::cache::Cache::open(dir.path()).unwrap();
    // Work in progress goes under `tmp/`: a file there makes every commit fail (whoever runs
    // the test, root included), while the cache still opens and counts as writable.
    let tmp = dir.path().join("tmp");
    std::fs::remove_dir_all(&tmp).ok();
    std::fs::write(&tmp, b"not a directory").unwrap();
    let plan = load(&pipeline("four-dof"), &[]);
    let opts = femu::pipeline::RunOptions {
        progress: femu::pipeline::ProgressMode::Quiet,
        ..Default::default()
    };
    let err = femu::pipeline::execute(&plan, &cache, &opts).unwrap_err();
    // Every write fails; which one is found first depends on when each writer ends.
    match &err {
        femu::pipeline::executor::RunError::Cache { stage, .. } => assert!(
            plan.nodes.iter().any(|n| &n.name == stage) && err.to_string().contains(stage.as_str()),
            "{err}"
        ),
        other => panic!("expected a cache error, got {other}"),
    }
    assert!(err.to_string().contains("Not a directory"), "{err}");
    let entries = std::fs::read_dir(dir.path().join("entries"))
        .map(|d| d.count())
        .unwrap_or(0);
    assert_eq!(entries, 0, "no entry is committed");
}
