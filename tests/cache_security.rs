//! The cache and `--out` against hostile names, planted links, forged entries, read-only
//! caches and the leftovers of killed processes.

mod common;

use common::*;
use femu::cache::{Cache, Lookup, owner};
use femu::pipeline::Status;
use femu::pipeline::executor::materialise_with_lock;
use femu::pipeline::lock::LockFile;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A small pipeline named `name`: two lumped models (same port and kind, other content) and
/// the modes of one.
fn tiny(dir: &Path, name: &str) -> PathBuf {
    let model = |m2: f64| {
        format!(
            "    kind: model.lumped\n    with:\n      masses:\n        - {{dof: \"1:ux\", m: 1.0}}\n        - {{dof: \"2:ux\", m: {m2}}}\n      springs:\n        - {{from: \"1:ux\", k: 1.0e4}}\n        - {{from: \"1:ux\", to: \"2:ux\", k: 1.0e4}}\n"
        )
    };
    let text = format!(
        "name: {name:?}\nstages:\n  truth:\n{}  analytical:\n{}  truth_modes:\n    kind: modes\n    inputs: {{model: truth}}\n",
        model(1.0),
        model(1.3)
    );
    let file = dir.join("p.yaml");
    std::fs::write(&file, text).unwrap();
    file
}

/// Every file and directory under `root` with its size and modification time.
fn snapshot(root: &Path) -> BTreeMap<PathBuf, (u64, std::time::SystemTime)> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let m = std::fs::symlink_metadata(e.path()).unwrap();
            out.insert(e.path(), (m.len(), m.modified().unwrap()));
            if m.is_dir() {
                stack.push(e.path());
            }
        }
    }
    out
}

// --- 1. lock paths -------------------------------------------------------------------------

/// A pipeline name that is not one plain file name never becomes a path outside `locks/`.
#[test]
fn lock_paths_refuse_names_that_leave_locks() {
    let dir = tempfile::tempdir().unwrap();
    let cache = Cache::open(&dir.path().join("cache")).unwrap();
    let abs = dir.path().join("abs").join("x");
    for name in [
        "../../x",
        "../x",
        "a/b",
        "..",
        ".",
        "",
        abs.to_str().unwrap(),
        "x\0y",
    ] {
        let e = cache.lock_path(name).unwrap_err().to_string();
        assert!(
            e.contains("pipeline name") && e.contains("one plain file name"),
            "{name:?}: {e}"
        );
    }
    assert_eq!(
        cache.lock_path("four-dof").unwrap(),
        dir.path().join("cache/locks/four-dof.lock.json")
    );
}

/// End to end: `name: ../../x` and `name: /abs/dir/x` write nothing outside the cache.
#[test]
fn a_run_never_writes_a_lock_file_outside_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("deep/cache");
    std::fs::create_dir_all(&cache).unwrap();
    let abs = dir.path().join("abs/escaped");
    for name in ["../../escaped", abs.to_str().unwrap()] {
        let p = tiny(dir.path(), name);
        let run = femu()
            .args(["run", "--quiet", "--cache-dir"])
            .arg(&cache)
            .arg(&p)
            .output()
            .unwrap();
        assert!(!run.status.success(), "{name}: the run must be refused");
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(stderr.contains("escaped"), "{name}: {stderr}");
    }
    for f in [
        dir.path().join("escaped.lock.json"),
        dir.path().join("deep/escaped.lock.json"),
        dir.path().join("abs/escaped.lock.json"),
    ] {
        assert!(!f.exists(), "{} was written", f.display());
    }
}

// --- 2. --out ------------------------------------------------------------------------------

/// A run in a fresh cache, and its lock file.
fn cached_run(dir: &Path) -> (femu::pipeline::RunReport, Cache, LockFile) {
    let p = tiny(dir, "tiny");
    let (plan, report, cache) = run(&p, &dir.join("cache"), &[]);
    let lock = LockFile::from_run(&plan, &report);
    (report, cache, lock)
}

#[test]
fn out_replaces_an_earlier_output_and_leaves_no_staging() {
    let dir = tempfile::tempdir().unwrap();
    let (report, cache, lock) = cached_run(dir.path());
    let out = dir.path().join("out");
    materialise_with_lock(&report, &cache, &out, Some(&lock)).unwrap();
    std::fs::create_dir_all(out.join("old_stage/port")).unwrap();
    materialise_with_lock(&report, &cache, &out, Some(&lock)).unwrap();
    assert!(out.join("femu.lock.json").is_file());
    assert!(out.join("truth_modes/modes/meta.json").is_file());
    assert!(
        !out.join("old_stage").exists(),
        "the earlier output is replaced whole"
    );
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert!(
        names
            .iter()
            .all(|n| !n.contains("femu-staging") && !n.contains("femu-old")),
        "{names:?}"
    );
}

/// A link planted inside an earlier output is refused by name; its target is neither emptied
/// nor written.
#[cfg(unix)]
#[test]
fn out_never_deletes_or_writes_through_a_planted_link() {
    let dir = tempfile::tempdir().unwrap();
    let (report, cache, lock) = cached_run(dir.path());
    let out = dir.path().join("out");
    materialise_with_lock(&report, &cache, &out, Some(&lock)).unwrap();
    let victim = dir.path().join("victim");
    std::fs::create_dir_all(victim.join("modes")).unwrap();
    std::fs::write(victim.join("modes/precious.txt"), "keep me").unwrap();
    std::fs::remove_dir_all(out.join("truth_modes")).unwrap();
    std::os::unix::fs::symlink(&victim, out.join("truth_modes")).unwrap();
    let e = materialise_with_lock(&report, &cache, &out, Some(&lock))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&out.join("truth_modes").display().to_string()) && e.contains("symbolic link"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(victim.join("modes/precious.txt")).unwrap(),
        "keep me"
    );
    assert_eq!(std::fs::read_dir(victim.join("modes")).unwrap().count(), 1);
}

/// `--out` that is itself a link, or whose lock file is a link, is refused; the target is kept.
#[cfg(unix)]
#[test]
fn out_refuses_a_link_as_the_directory_or_the_lock_file() {
    let dir = tempfile::tempdir().unwrap();
    let (report, cache, lock) = cached_run(dir.path());
    let victim = dir.path().join("victim");
    std::fs::create_dir_all(&victim).unwrap();
    std::fs::write(victim.join("precious.txt"), "keep me").unwrap();
    let out = dir.path().join("out-link");
    std::os::unix::fs::symlink(&victim, &out).unwrap();
    let e = materialise_with_lock(&report, &cache, &out, Some(&lock))
        .unwrap_err()
        .to_string();
    assert!(e.contains("out-link") && e.contains("symbolic link"), "{e}");
    // An "earlier output" whose lock file points elsewhere is not one.
    let out = dir.path().join("out2");
    std::fs::create_dir_all(out.join("truth")).unwrap();
    std::os::unix::fs::symlink(victim.join("precious.txt"), out.join("femu.lock.json")).unwrap();
    let e = materialise_with_lock(&report, &cache, &out, Some(&lock))
        .unwrap_err()
        .to_string();
    assert!(e.contains("out2") && e.contains("femu.lock.json"), "{e}");
    assert_eq!(std::fs::read_dir(&victim).unwrap().count(), 1);
    assert_eq!(
        std::fs::read_to_string(victim.join("precious.txt")).unwrap(),
        "keep me"
    );
}

/// A non-empty directory that is not an earlier femu output, or a file, is not cleared.
#[test]
fn out_refuses_what_femu_does_not_own() {
    let dir = tempfile::tempdir().unwrap();
    let (report, cache, lock) = cached_run(dir.path());
    let home = dir.path().join("home");
    std::fs::create_dir_all(home.join("thesis")).unwrap();
    std::fs::write(home.join("thesis/ch1.tex"), "text").unwrap();
    let e = materialise_with_lock(&report, &cache, &home, Some(&lock))
        .unwrap_err()
        .to_string();
    assert!(e.contains("home") && e.contains("femu.lock.json"), "{e}");
    assert!(home.join("thesis/ch1.tex").is_file());
    assert_eq!(std::fs::read_dir(&home).unwrap().count(), 1);
    let file = dir.path().join("file");
    std::fs::write(&file, "x").unwrap();
    let e = materialise_with_lock(&report, &cache, &file, Some(&lock))
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a directory"), "{e}");
    // An empty directory is fine.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    materialise_with_lock(&report, &cache, &empty, Some(&lock)).unwrap();
    assert!(empty.join("truth/model/meta.json").is_file());
}

// --- 3. forged entries ---------------------------------------------------------------------

/// Copies the files of `from`'s output `port` over `to`'s and rewrites `to`'s manifest so that
/// every hash and digest is consistent: only the producer recorded in `meta.json` tells.
fn forge(cache: &Cache, from: &str, to: &str, port: &str) {
    let (src, dst) = (
        cache.artefact_dir(from, port).unwrap(),
        cache.artefact_dir(to, port).unwrap(),
    );
    std::fs::remove_dir_all(&dst).unwrap();
    std::fs::create_dir(&dst).unwrap();
    for f in std::fs::read_dir(&src).unwrap().flatten() {
        std::fs::copy(f.path(), dst.join(f.file_name())).unwrap();
    }
    let entry = |k: &str| cache.root().join("entries").join(k).join("manifest.json");
    let read = |k: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(entry(k)).unwrap()).unwrap()
    };
    let (donor, mut m) = (read(from), read(to));
    m["outputs"][port] = donor["outputs"][port].clone();
    let files = m["files"].as_object_mut().unwrap();
    files.retain(|rel, _| !rel.starts_with(&format!("{port}/")));
    for f in std::fs::read_dir(&dst).unwrap().flatten() {
        let bytes = std::fs::read(f.path()).unwrap();
        files.insert(
            format!("{port}/{}", f.file_name().to_string_lossy()),
            femu::artefact::digest::hash_bytes(&bytes).into(),
        );
    }
    std::fs::write(entry(to), serde_json::to_string_pretty(&m).unwrap()).unwrap();
}

#[test]
fn an_entry_forged_from_another_is_detected_evicted_and_recomputed() {
    let dir = tempfile::tempdir().unwrap();
    let p = tiny(dir.path(), "tiny");
    let (_, first, cache) = run(&p, &dir.path().join("cache"), &[]);
    let key = |name: &str| {
        first
            .stages
            .iter()
            .find(|s| s.name == name)
            .unwrap()
            .key
            .clone()
    };
    let (truth, analytical) = (key("truth"), key("analytical"));
    forge(&cache, &truth, &analytical, "model");
    // The hashes agree with the files: the old checks pass.
    let manifest: femu::cache::Manifest = serde_json::from_str(
        &std::fs::read_to_string(
            cache
                .root()
                .join("entries")
                .join(&analytical)
                .join("manifest.json"),
        )
        .unwrap(),
    )
    .unwrap();
    assert_eq!(manifest.key, analytical);
    let (_, second, _) = run(&p, &dir.path().join("cache"), &[]);
    let s = second
        .stages
        .iter()
        .find(|s| s.name == "analytical")
        .unwrap();
    assert_eq!(s.status, Status::Recovered, "{:?}", s.note);
    let note = s.note.as_deref().unwrap_or("");
    assert!(note.contains("producer") && note.contains(&truth), "{note}");
    assert_eq!(executed(&second), vec!["analytical".to_string()]);
    assert_eq!(
        s.outputs,
        first
            .stages
            .iter()
            .find(|s| s.name == "analytical")
            .unwrap()
            .outputs,
        "recomputed to the true content"
    );
    assert!(matches!(cache.lookup(&analytical), Lookup::Hit(_)));
}

// --- 4. read-only caches -------------------------------------------------------------------

/// A fully cached run on a cache opened read-only succeeds and changes nothing in it.
#[test]
fn a_read_only_cache_serves_a_cached_run_and_is_not_touched() {
    let dir = tempfile::tempdir().unwrap();
    let p = tiny(dir.path(), "tiny");
    let root = dir.path().join("cache");
    run(&p, &root, &[]);
    let before = snapshot(&root);
    let cache = Cache::open_read_only(&root).unwrap();
    assert!(cache.read_only().is_some());
    let plan = load(&p, &[]);
    let opts = femu::pipeline::RunOptions {
        progress: femu::pipeline::ProgressMode::Quiet,
        ..Default::default()
    };
    let report = femu::pipeline::execute(&plan, &cache, &opts).unwrap();
    assert_eq!(executed(&report), Vec::<String>::new());
    let lock = LockFile::from_run(&plan, &report);
    let warning = lock.record_in(&cache, &plan.name).unwrap();
    assert!(
        warning.as_deref().unwrap_or("").contains("not written"),
        "{warning:?}"
    );
    let out = dir.path().join("out");
    materialise_with_lock(&report, &cache, &out, Some(&lock)).unwrap();
    assert!(out.join("truth_modes/modes/meta.json").is_file());
    assert_eq!(
        snapshot(&root),
        before,
        "a read-only cache is never written"
    );
    // A stage that is not cached cannot be stored: a clear error, not a half-written entry.
    let changed = load(&p, &["truth_modes.count=1"]);
    let e = femu::pipeline::execute(&changed, &cache, &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("read-only") && e.contains("--cache-dir"), "{e}");
    assert_eq!(snapshot(&root), before);
}

/// The binary on a cache it cannot write (here `tmp` is a file, so the first write fails even
/// for root): the cached run succeeds, warns that the lock file was not written, and `--out`
/// works.
#[test]
fn the_binary_runs_a_cached_pipeline_on_an_unwritable_cache() {
    let dir = tempfile::tempdir().unwrap();
    let p = tiny(dir.path(), "tiny");
    let root = dir.path().join("cache");
    run(&p, &root, &[]);
    std::fs::remove_dir_all(root.join("tmp")).unwrap();
    std::fs::write(root.join("tmp"), "not a directory").unwrap();
    std::fs::remove_file(root.join("locks/tiny.lock.json")).ok();
    let out = dir.path().join("out");
    let r = femu()
        .args(["run", "--quiet", "--cache-dir"])
        .arg(&root)
        .arg("--out")
        .arg(&out)
        .arg(&p)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning") && stderr.contains("read-only") && stderr.contains("lock file"),
        "{stderr}"
    );
    assert!(!root.join("locks/tiny.lock.json").exists());
    assert!(out.join("femu.lock.json").is_file());
    assert!(out.join("truth_modes/modes/meta.json").is_file());
}

/// With real permission bits (skipped where they do not bite, e.g. as root).
#[cfg(unix)]
#[test]
fn the_binary_runs_a_cached_pipeline_on_a_cache_without_write_permission() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let p = tiny(dir.path(), "tiny");
    let root = dir.path().join("cache");
    run(&p, &root, &[]);
    let set = |mode: u32| {
        for d in [
            root.join("tmp"),
            root.join("locks"),
            root.join("entries"),
            root.clone(),
        ] {
            std::fs::set_permissions(&d, std::fs::Permissions::from_mode(mode)).unwrap();
        }
    };
    set(0o555);
    let bites = std::fs::write(root.join("tmp/probe"), "x").is_err();
    if bites {
        let out = dir.path().join("out");
        let r = femu()
            .args(["run", "--quiet", "--cache-dir"])
            .arg(&root)
            .arg("--out")
            .arg(&out)
            .arg(&p)
            .output()
            .unwrap();
        set(0o755);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{stderr}");
        assert!(stderr.contains("lock file"), "{stderr}");
        assert!(out.join("truth/model/meta.json").is_file());
    } else {
        set(0o755);
        eprintln!("skipped: permission bits do not stop this user (root?)");
    }
}

// --- 5. stale temporaries ------------------------------------------------------------------

/// Opening a cache removes the temporaries of dead processes of this host, and only those.
#[test]
fn opening_a_cache_removes_the_temporaries_of_dead_processes() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("cache");
    Cache::open(&root).unwrap();
    let mut child = std::process::Command::new("sh")
        .args(["-c", "exit 0"])
        .spawn()
        .unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let tmp = root.join("tmp");
    let make = |name: &str| {
        let d = tmp.join(name);
        std::fs::create_dir_all(d.join("frf")).unwrap();
        std::fs::write(d.join("frf/t.parquet"), vec![0u8; 4096]).unwrap();
        d
    };
    let killed = make(&format!("abc.0.1.{}", owner::owner_suffix(dead)));
    let evicting = make(&format!("evict-abc.3.4.{}", owner::owner_suffix(dead)));
    let live = make(&format!(
        "abc.0.2.{}",
        owner::owner_suffix(std::process::id())
    ));
    let elsewhere = make(&format!("abc.0.3.{dead}@some-other-host"));
    let old_style = make(&format!("abc.{dead}.0.5"));
    Cache::open(&root).unwrap();
    assert!(
        !killed.exists() && !evicting.exists(),
        "dead processes' work is removed"
    );
    for kept in [&live, &elsewhere, &old_style] {
        assert!(kept.exists(), "{} must be left alone", kept.display());
    }
}
