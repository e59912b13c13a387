//! Sweep files are input from anyone: names and Slurm values that would inject commands into the
//! batch scripts or move the state out of the cache are refused where they are written; odd but
//! legal paths are quoted (the generated scripts are run under bash to prove it); one process
//! drives a sweep at a time; a byte-order mark, oversized files and floods of errors are
//! handled; and a bounded fuzz test feeds the parser arbitrary bytes and mutated shipped sweeps.

mod common;

use femu::sweep::spec::{MAX_REPORTED_ERRORS, parse_sweep_limited, read_sweep_limited};
use femu::sweep::{StateDir, SweepError, parse_sweep, read_sweep, resolve, slurm};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn four_dof() -> String {
    common::pipeline("four-dof").display().to_string()
}

/// Sweep text over the four-DOF pipeline: lines 1–4 are fixed, `tail` starts on line 5.
fn text(tail: &str) -> String {
    format!(
        "pipeline: {}\nonly: [correlation]\nmatrix:\n  measured.with.seed: [1, 2]\n{tail}",
        four_dof()
    )
}

/// The errors of reading (and resolving) `tail` as `s.yaml`.
fn refusal(tail: &str) -> String {
    match parse_sweep(Path::new("s.yaml"), &text(tail)).and_then(|s| resolve(&s).map(|_| ())) {
        Ok(()) => panic!("accepted:\n{tail}"),
        Err(e) => e.to_string(),
    }
}

/// Every hostile name or Slurm value is refused when the file is read, at its line and field,
/// saying what is valid; nothing of the value leaks out unescaped (no raw line break).
#[test]
fn hostile_names_and_slurm_values_are_refused_where_they_are_written() {
    let cases: &[(&str, &str, &str)] = &[
        // (tail, position prefix, field)
        ("name: \"x\\ntouch PWNED\"\n", "s.yaml:5:7:", "`name`"),
        ("name: ../escape\n", "s.yaml:5:7:", "`name`"),
        ("name: ../../../tmp/escape\n", "s.yaml:5:7:", "`name`"),
        ("name: /tmp/absolute\n", "s.yaml:5:7:", "`name`"),
        ("name: a/b\n", "s.yaml:5:7:", "`name`"),
        ("name: '..'\n", "s.yaml:5:7:", "`name`"),
        ("name: .hidden\n", "s.yaml:5:7:", "`name`"),
        ("name: -rf\n", "s.yaml:5:7:", "`name`"),
        ("name: ''\n", "s.yaml:5:7:", "`name`"),
        ("name: two words\n", "s.yaml:5:7:", "`name`"),
        (
            "slurm:\n  partition: \"short\\n#SBATCH --wrap=id\"\n",
            "s.yaml:6:14:",
            "`slurm.partition`",
        ),
        (
            "slurm:\n  partition: short;touch PWNED\n",
            "s.yaml:6:14:",
            "`slurm.partition`",
        ),
        (
            "slurm:\n  account: \"a b\"\n",
            "s.yaml:6:12:",
            "`slurm.account`",
        ),
        (
            "slurm:\n  account: \"a\\u0000b\"\n",
            "s.yaml:6:12:",
            "`slurm.account`",
        ),
        (
            "slurm:\n  time: \"00:10:00\\ntouch PWNED\"\n",
            "s.yaml:6:9:",
            "`slurm.time`",
        ),
        (
            "slurm:\n  mem: \"1G\\rtouch PWNED\"\n",
            "s.yaml:6:8:",
            "`slurm.mem`",
        ),
        (
            "slurm:\n  extra: [\"--qos=low\\ntouch PWNED\"]\n",
            "s.yaml:6:11:",
            "`slurm.extra.0`",
        ),
        (
            "slurm:\n  extra: [--qos=low, \"--comment=two words\"]\n",
            "s.yaml:6:22:",
            "`slurm.extra.1`",
        ),
        (
            "slurm:\n  extra: [\"--comment='quoted'\"]\n",
            "s.yaml:6:11:",
            "`slurm.extra.0`",
        ),
        (
            "slurm:\n  extra: [--arr=0-99]\n",
            "s.yaml:6:11:",
            "`slurm.extra.0`",
        ),
        (
            "slurm:\n  extra: [--out=/etc/x]\n",
            "s.yaml:6:11:",
            "`slurm.extra.0`",
        ),
        (
            "slurm:\n  femu: \"/opt/femu\\ntouch PWNED\"\n",
            "s.yaml:6:9:",
            "`slurm.femu`",
        ),
        (
            "zip:\n  - {\"measured.with.level\\ntouch PWNED\": [0.1]}\n",
            "s.yaml:6:6:",
            "`zip.0.measured.with.level\\ntouch PWNED`",
        ),
        (
            "zip:\n  - {measured.with.level/../x: [0.1]}\n",
            "s.yaml:6:6:",
            "`zip.0.measured.with.level/../x`",
        ),
    ];
    for (tail, at, field) in cases {
        let e = refusal(tail);
        assert!(e.starts_with(&format!("error: {at}")), "{tail:?}:\n{e}");
        // The field is named (a key with a line break in it is shown escaped).
        let first = e.lines().next().unwrap_or("");
        assert!(first.contains(&format!("field {field}")), "{tail:?}:\n{e}");
        assert!(e.contains("\n  help: "), "{tail:?}: no help:\n{e}");
        // No line of the message starts with what the value would have injected.
        assert!(
            e.lines()
                .all(|l| !l.starts_with("touch") && !l.starts_with("#SBATCH")),
            "{tail:?}:\n{e}"
        );
    }
    // Legal values, odd ones included, are accepted.
    let ok = text(
        "name: four-dof_v2.1\nslurm:\n  partition: short,long\n  account: proj-42\n  femu: \"/opt/my femu/it's \\\"here\\\"/femu\"\n  extra: [--qos=low, \"--constraint=[a|b]&c\", \"--exclude=node[1-3]\", --mail-user=a@b.c]\n",
    );
    parse_sweep(Path::new("s.yaml"), &ok).unwrap_or_else(|e| panic!("{e}"));
}

/// A sweep named after its file must have a usable file name, or say to give a `name:`.
#[test]
fn an_unusable_file_name_asks_for_a_name() {
    let e = parse_sweep(Path::new("dir/my sweep.yaml"), &text("")).unwrap_err();
    let e = e.to_string();
    assert!(
        e.starts_with("error: dir/my sweep.yaml: field `name`:"),
        "{e}"
    );
    assert!(e.contains("give the sweep a `name:`"), "{e}");
    parse_sweep(Path::new("dir/my sweep.yaml"), &text("name: my-sweep\n"))
        .unwrap_or_else(|e| panic!("{e}"));
}

/// The state directory's constructor refuses any name that is not one safe path component, and
/// creates nothing outside the cache.
#[test]
fn the_state_dir_constructor_refuses_names_that_leave_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("c").join("cache");
    std::fs::create_dir_all(&cache).unwrap();
    for name in [
        "../x", "../../x", "/tmp/x", "a/b", "a\\b", "..", ".", "", "x\ny", ".hidden", "-option",
        "a b",
    ] {
        match StateDir::for_sweep(&cache, name) {
            Err(SweepError::Usage(m)) => assert!(m.contains("not a usable sweep name"), "{m}"),
            other => panic!("{name:?}: {other:?}"),
        }
    }
    // Nothing was made beside the cache, nor in it.
    let mut made: Vec<_> = std::fs::read_dir(dir.path().join("c"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    made.sort();
    assert_eq!(made, ["cache"]);
    assert!(!cache.join("sweeps").exists());
    let s = StateDir::for_sweep(&cache, "four-dof_v2.1").unwrap();
    assert_eq!(
        s.root(),
        std::fs::canonicalize(cache.join("sweeps/four-dof_v2.1")).unwrap()
    );
}

/// Through the command line: a `../` name exits 2 with a located message and writes nothing
/// outside the cache.
#[test]
fn the_cli_keeps_a_dotdot_name_inside_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.yaml");
    std::fs::write(&file, text("name: ../../escaped\n")).unwrap();
    let cache = dir.path().join("c").join("cache");
    let out = common::femu()
        .args(["sweep", "--dry-run", "--cache-dir"])
        .arg(&cache)
        .arg(&file)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("bad.yaml:5:7: field `name`:"), "{err}");
    assert!(!dir.path().join("escaped").exists());
    assert!(!dir.path().join("c").join("escaped").exists());
}

/// A stand-in femu at `path` that appends its arguments, each ended by a NUL, to `args` beside it.
fn stub_femu(path: &Path) {
    std::fs::write(
        path,
        "#!/bin/bash\nprintf '%s\\0' \"$@\" >> \"$(dirname \"$0\")/args\"\nprintf '\\1' >> \"$(dirname \"$0\")/args\"\n",
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// Files anywhere below `dir` whose name starts with `PWNED`.
fn markers(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if e.file_name().to_string_lossy().starts_with("PWNED") {
                out.push(p.clone());
            }
            if p.is_dir() {
                stack.push(p);
            }
        }
    }
    out
}

/// Paths with spaces, quotes, `$( )`, backquotes, `;`, `#`, `%` and a line break are legal: the
/// scripts quote every one in commands and keep them out of `#SBATCH` lines. Both scripts run
/// under bash with a stub femu; no injected command runs, and femu receives exactly the paths.
#[test]
fn odd_paths_are_quoted_and_the_scripts_run_nothing_injected() {
    let dir = tempfile::tempdir().unwrap();
    let base = std::fs::canonicalize(dir.path()).unwrap();
    let odd = base.join("it's \"odd\" $(touch PWNED1); `touch PWNED2`\ntouch PWNED3 #%a");
    std::fs::create_dir_all(&odd).unwrap();
    let sweep_file = odd.join("sweep.yaml");
    std::fs::write(&sweep_file, text("name: odd\n")).unwrap();
    let cache = odd.join("cache $(touch PWNED4)");
    std::fs::create_dir_all(&cache).unwrap();
    let state = StateDir::open(&odd.join("state'; touch PWNED5; '")).unwrap();
    // The femu path may hold anything but control characters.
    let bin = base.join("bin it's \"odd\" $(touch PWNED8); `touch PWNED9` #%a");
    std::fs::create_dir_all(&bin).unwrap();
    let exe = bin.join("fe mu's \"stub\"");
    stub_femu(&exe);
    let mut sweep = read_sweep(&sweep_file).unwrap();
    let sets = [
        "measured.with.level=0.1 # '$(touch PWNED6)'".to_string(),
        "measured.with.interval=[-1, 1] # it's `touch PWNED7`".to_string(),
    ];
    sweep.apply_overrides(&sets).unwrap();
    let r = resolve(&sweep).unwrap_or_else(|e| panic!("{e}"));
    let sub = slurm::prepare(&r, &state, &cache, &exe, "b1-2").unwrap();
    let common = sub.common_script.clone().expect("a common-stages job");
    for script in [&common, &sub.array_script] {
        for l in script.lines().filter(|l| l.starts_with("#SBATCH")) {
            assert!(
                l.chars().all(|c| c.is_ascii_graphic() || c == ' ') && !l.contains("PWNED"),
                "{l}"
            );
        }
        // The log path is relative to the state directory, whose own path is not directive-safe.
        assert!(
            script.contains("#SBATCH --output=slurm/logs/b1-2_"),
            "{script}"
        );
    }
    // Run both as Slurm would, from the state directory (there is only one array task).
    std::fs::create_dir_all(state.root().join("slurm")).unwrap();
    for (name, script) in [
        ("common.sbatch", &common),
        ("array.sbatch", &sub.array_script),
    ] {
        let path = state.root().join("slurm").join(name);
        std::fs::write(&path, script).unwrap();
        let out = std::process::Command::new("bash")
            .arg(&path)
            .current_dir(state.root())
            .env("SLURM_ARRAY_TASK_ID", "0")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert_eq!(markers(&base), Vec::<PathBuf>::new());
    // The stub saw every path whole.
    let args = std::fs::read(bin.join("args")).unwrap();
    let calls: Vec<Vec<String>> = args
        .split(|b| *b == 1)
        .filter(|c| !c.is_empty())
        .map(|c| {
            c.split(|b| *b == 0)
                .filter(|a| !a.is_empty())
                .map(|a| String::from_utf8(a.to_vec()).unwrap())
                .collect()
        })
        .collect();
    let show = |p: &Path| p.display().to_string();
    let canon = |p: &Path| show(&std::fs::canonicalize(p).unwrap());
    let mut head = vec![
        "sweep".to_string(),
        "run-point".into(),
        canon(&sweep_file),
        "--cache-dir".into(),
        canon(&cache),
        "--out".into(),
        show(state.root()),
    ];
    for s in &sets {
        head.extend(["--set".to_string(), s.clone()]);
    }
    let mut first = head.clone();
    first.extend(["--common".into(), "--batch".into(), "b1-2".into()]);
    let mut second = head;
    second.extend([
        "--tasks".into(),
        show(&sub.tasks_file),
        "--task".into(),
        "0".into(),
        "--per-task".into(),
        sub.per_task.to_string(),
    ]);
    assert_eq!(calls, [first, second]);
}

/// A spec changed in code after it was read is checked again before any script is written.
#[test]
fn prepare_refuses_hostile_values_set_in_code() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("s.yaml");
    std::fs::write(&file, text("")).unwrap();
    let r = resolve(&read_sweep(&file).unwrap()).unwrap();
    let state = StateDir::open(&dir.path().join("state")).unwrap();
    let exe = Path::new("/usr/bin/femu");
    type Edit = fn(&mut femu::sweep::spec::SweepSpec);
    let edits: [(&str, Edit); 6] = [
        ("`name`", |s| s.name = Some("x\ntouch PWNED".into())),
        ("`name`", |s| s.name = Some("../../x".into())),
        ("`slurm.partition`", |s| {
            s.slurm.partition = Some("a\ntouch PWNED".into())
        }),
        ("`slurm.time`", |s| s.slurm.time = Some("1\nid".into())),
        ("`slurm.extra`", |s| {
            s.slurm.extra = vec!["--qos=a\ntouch PWNED".into()]
        }),
        ("`slurm.femu`", |s| s.slurm.femu = Some("femu\nid".into())),
    ];
    for (field, edit) in edits {
        let mut bad = r.clone();
        edit(&mut bad.sweep.spec);
        match slurm::prepare(&bad, &state, dir.path(), exe, "b1") {
            Err(SweepError::Usage(m)) => assert!(m.contains(&format!("field {field}")), "{m}"),
            other => panic!("{field}: {other:?}"),
        }
    }
    match slurm::prepare(&r, &state, dir.path(), exe, "b1/../x") {
        Err(SweepError::Usage(m)) => assert!(m.contains("field `batch`"), "{m}"),
        other => panic!("{other:?}"),
    }
    slurm::prepare(&r, &state, dir.path(), exe, "b1").unwrap();
}

/// Eight threads racing for the lock of one state directory, 200 rounds: exactly one holds it
/// each round (the old create-then-take-over-if-stale lock let two through in ~10 % of rounds),
/// and the others are told who (this process) at once. Meanwhile another thread forks and
/// execs processes without pause, as the other tests of this binary do: a fork shares the lock
/// file's open description until its exec, so a released lock can stay held for a moment (all
/// eight were once refused, with no holder named).
#[test]
fn the_sweep_lock_admits_exactly_one_of_many_racing_takers() {
    let dir = tempfile::tempdir().unwrap();
    let state = StateDir::open(dir.path()).unwrap();
    let me = std::process::id();
    let racing = std::sync::atomic::AtomicBool::new(true);
    std::thread::scope(|s| {
        s.spawn(|| {
            while racing.load(std::sync::atomic::Ordering::Relaxed) {
                let _ = std::process::Command::new("true").status();
            }
        });
        let raced = std::panic::catch_unwind(|| race_for_the_lock(&state, me));
        racing.store(false, std::sync::atomic::Ordering::Relaxed);
        if let Err(panic) = raced {
            std::panic::resume_unwind(panic);
        }
    });
    // Released: the next taker gets it.
    drop(state.lock().unwrap());
}

/// 200 rounds of eight threads taking `state`'s lock at once (see the test above).
fn race_for_the_lock(state: &StateDir, me: u32) {
    for round in 0..200 {
        let n = 8;
        let start = std::sync::Barrier::new(n);
        let tried = std::sync::Barrier::new(n);
        let results: Vec<Result<(), String>> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..n)
                .map(|_| {
                    s.spawn(|| {
                        start.wait();
                        let r = state.lock();
                        // Hold it until every thread has tried.
                        tried.wait();
                        r.map(drop).map_err(|e| match e {
                            SweepError::Busy { pid, .. } => {
                                assert_eq!(pid, me);
                                e.to_string()
                            }
                            e => panic!("not busy: {e}"),
                        })
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let held = results.iter().filter(|r| r.is_ok()).count();
        assert_eq!(held, 1, "round {round}: {results:?}");
        for m in results.iter().filter_map(|r| r.as_ref().err()) {
            assert!(m.contains(&format!("pid {me} on ")), "{m}");
            assert!(m.contains("exit code 1"), "{m}");
        }
    }
}

/// A four-DOF sweep of 12 points in `dir`, for the process tests.
fn twelve_points(dir: &Path) -> PathBuf {
    let file = dir.join("race.yaml");
    std::fs::write(
        &file,
        format!(
            "pipeline: {}\nonly: [correlation]\nmatrix:\n  measured.with.level: [0.05, 0.1, 0.15]\n  measured.with.seed: {{range: [1, 4]}}\n",
            four_dof()
        ),
    )
    .unwrap();
    file
}

/// While a sweep's lock is held, `femu sweep` on it fails at once with exit code 1, naming the
/// holder, and runs nothing.
#[test]
fn a_second_femu_sweep_fails_at_once_naming_the_holder() {
    let dir = tempfile::tempdir().unwrap();
    let file = twelve_points(dir.path());
    let cache = dir.path().join("cache");
    let state = StateDir::for_sweep(&cache, "race").unwrap();
    let held = state.lock().unwrap();
    let t0 = Instant::now();
    let out = common::femu()
        .args(["sweep", "--quiet", "--cache-dir"])
        .arg(&cache)
        .arg(&file)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(20));
    let holder = format!(
        "pid {} on {}",
        std::process::id(),
        femu::sweep::state::host_name()
    );
    assert!(err.contains(&holder), "{err}");
    assert!(err.contains("exit code 1"), "{err}");
    assert!(err.contains(&held.path().display().to_string()), "{err}");
    assert!(state.runs().is_empty());
    assert!(
        std::fs::read_dir(state.root().join("points"))
            .unwrap()
            .next()
            .is_none()
    );
}

/// Two `femu sweep` processes started together on one state directory: each point runs once,
/// none fails, and a process that finds the sweep busy exits 1 naming the other.
#[test]
fn two_sweeps_started_together_run_each_point_once() {
    let dir = tempfile::tempdir().unwrap();
    let file = twelve_points(dir.path());
    for trial in 0..3 {
        let cache = dir.path().join(format!("cache{trial}"));
        let spawn = || {
            common::femu()
                .args([
                    "sweep",
                    "--jobs",
                    "1",
                    "--no-collect",
                    "--quiet",
                    "--cache-dir",
                ])
                .arg(&cache)
                .arg(&file)
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (a, b) = (spawn(), spawn());
        let mut ran = 0;
        let mut busy = 0;
        for child in [a, b] {
            let out = child.wait_with_output().unwrap();
            let stdout = String::from_utf8_lossy(&out.stdout);
            let stderr = String::from_utf8_lossy(&out.stderr);
            match out.status.code() {
                Some(0) => {
                    let n: usize = stdout
                        .split(" points run, 0 failed")
                        .next()
                        .and_then(|s| s.split_whitespace().last())
                        .and_then(|n| n.parse().ok())
                        .unwrap_or_else(|| panic!("trial {trial}: {stdout}{stderr}"));
                    ran += n;
                }
                Some(1) if stderr.contains("is driving this sweep") => busy += 1,
                c => panic!("trial {trial}: exit {c:?}\n{stdout}{stderr}"),
            }
        }
        assert_eq!(ran, 12, "trial {trial}: {busy} busy");
        let state = StateDir::for_sweep(&cache, "race").unwrap();
        let runs = state.runs();
        assert_eq!(runs.iter().map(|r| r.points).sum::<usize>(), 12, "{runs:?}");
        assert!(runs.iter().all(|r| r.failed == 0), "{runs:?}");
    }
}

/// A UTF-8 byte-order mark (legal YAML) is skipped, and positions still count from line 1.
#[test]
fn a_byte_order_mark_is_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bom.yaml");
    std::fs::write(&file, format!("\u{feff}{}", text("name: bom\n"))).unwrap();
    let s = read_sweep(&file).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.name(), "bom");
    assert_eq!(resolve(&s).unwrap().unique.len(), 2);
    let e = parse_sweep(
        Path::new("s.yaml"),
        &format!("\u{feff}{}", text("slurm:\n  mem: lots\n")),
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("error: s.yaml:6:8: field `slurm.mem`"), "{e}");
}

/// Files over the size limit are refused with the limit and how to raise it.
#[test]
fn oversized_sweep_files_are_refused_naming_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("big.yaml");
    // Over the default 16 MiB: a valid file padded with a comment.
    let mut body = text("");
    body.push('#');
    body.push_str(&"x".repeat(16 * 1024 * 1024));
    std::fs::write(&file, &body).unwrap();
    let e = read_sweep(&file).unwrap_err().to_string();
    assert!(e.contains("big.yaml"), "{e}");
    assert!(e.contains("limit of 16 MiB (16777216 bytes)"), "{e}");
    assert!(e.contains("FEMU_SWEEP_MAX_BYTES"), "{e}");
    let e = parse_sweep(&file, &body).unwrap_err().to_string();
    assert!(e.contains("limit of 16 MiB"), "{e}");
    // A raised limit reads it.
    read_sweep_limited(&file, 32 << 20).unwrap_or_else(|e| panic!("{e}"));
    parse_sweep_limited(&file, &body, 32 << 20).unwrap_or_else(|e| panic!("{e}"));
    // The limit is set through the environment on the command line.
    let small = dir.path().join("small.yaml");
    std::fs::write(&small, text("")).unwrap();
    for (limit, says) in [
        ("100", "limit of 100 bytes"),
        (
            "lots",
            "FEMU_SWEEP_MAX_BYTES=`lots` is not a positive whole number",
        ),
    ] {
        let out = common::femu()
            .args(["sweep", "--dry-run", "--cache-dir"])
            .arg(dir.path().join("cache"))
            .arg(&small)
            .env("FEMU_SWEEP_MAX_BYTES", limit)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains("small.yaml"), "{err}");
        assert!(err.contains(says), "{err}");
    }
}

/// A flood of errors is cut to the first [`MAX_REPORTED_ERRORS`] and a count of the rest, both
/// when reading the file and when resolving it.
#[test]
fn errors_are_capped_with_a_count_of_the_rest() {
    let extras: Vec<String> = (0..120).map(|i| format!("q{i}")).collect();
    let e = refusal(&format!("slurm:\n  extra: [{}]\n", extras.join(", ")));
    assert_eq!(
        e.matches("error: s.yaml").count(),
        MAX_REPORTED_ERRORS + 1,
        "{e}"
    );
    assert!(e.contains("… and 70 more problems"), "{e}");
    assert!(e.contains("q49") && !e.contains("q50`"), "{e}");
    let holes: Vec<String> = (0..90)
        .map(|i| format!("  - {{measured.with.seed: {}}}\n", 100 + i))
        .collect();
    let e = refusal(&format!("exclude:\n{}", holes.concat()));
    assert_eq!(
        e.matches("error: s.yaml").count(),
        MAX_REPORTED_ERRORS + 1,
        "{e}"
    );
    assert!(e.contains("… and 40 more problems"), "{e}");
}

mod fuzz {
    //! Bounded fuzzing of the sweep-file parser: never a panic, every error names a file.

    use super::*;
    use proptest::prelude::*;

    /// The shipped sweeps, by path, with their text.
    fn shipped() -> Vec<(PathBuf, String)> {
        let mut out: Vec<(PathBuf, String)> = std::fs::read_dir(common::root().join("sweeps"))
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
            .map(|p| {
                let t = std::fs::read_to_string(&p).unwrap();
                (p, t)
            })
            .collect();
        out.sort();
        out
    }

    /// Checks that every diagnostic names `file` (or, for problems in the pipeline, the
    /// pipeline file) and that the message says so.
    fn names_the_file(e: &femu::pipeline::Diagnostics, file: &str, pipeline: Option<&str>) {
        assert!(!e.0.is_empty());
        for d in &e.0 {
            assert!(
                d.file == file || Some(d.file.as_str()) == pipeline,
                "{:?} names neither {file:?} nor {pipeline:?}: {d}",
                d.file
            );
            assert!(d.to_string().starts_with(&d.file));
        }
    }

    /// Bits of YAML and of sweeps that mutations insert.
    const TOKENS: &[&str] = &[
        ":",
        "- ",
        "[",
        "]",
        "{",
        "}",
        ",",
        "\n",
        "  ",
        "\t",
        "'",
        "\"",
        "#",
        "&a ",
        "*a",
        "!!str ",
        "? ",
        "|\n",
        ">\n",
        "~",
        "null",
        "\u{feff}",
        "\r\n",
        "...\n",
        "---\n",
        "name: ../x\n",
        "name: \"a\\nb\"\n",
        "{range: [1, 1e300]}",
        "{range: [0, 1], step: 1e-300}",
        "[[[[[[",
        "measured.with.seed: ",
        "slurm: {partition: \"a\\nb\"}\n",
        "zip: [{}]\n",
        "exclude: [{}]\n",
        "collect: {a: b}\n",
        "plots: [{column: a, by: b}]\n",
        "1e999",
        "-0",
        "0x1F",
        "é",
        "\u{0}",
    ];

    #[derive(Clone, Debug)]
    enum Edit {
        Insert(usize, usize),
        Delete(usize, usize),
        DuplicateLine(usize),
        SwapLines(usize, usize),
        Truncate(usize),
        ReplaceChar(usize, char),
    }

    fn edit() -> impl Strategy<Value = Edit> {
        prop_oneof![
            (any::<usize>(), 0..TOKENS.len()).prop_map(|(a, t)| Edit::Insert(a, t)),
            (any::<usize>(), 1usize..40).prop_map(|(a, n)| Edit::Delete(a, n)),
            any::<usize>().prop_map(Edit::DuplicateLine),
            (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
            any::<usize>().prop_map(Edit::Truncate),
            (any::<usize>(), any::<char>()).prop_map(|(a, c)| Edit::ReplaceChar(a, c)),
        ]
    }

    /// The char boundary of `s` nearest below `at % (len + 1)`.
    fn boundary(s: &str, at: usize) -> usize {
        let mut i = at % (s.len() + 1);
        while !s.is_char_boundary(i) {
            i -= 1;
        }
        i
    }

    fn apply(text: &str, e: &Edit) -> String {
        let mut s = text.to_string();
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let joined = |l: Vec<String>| l.join("\n") + "\n";
        match *e {
            Edit::Insert(at, t) => s.insert_str(boundary(&s, at), TOKENS[t]),
            Edit::Delete(at, n) => {
                let a = boundary(&s, at);
                let b = boundary(&s, a + n.min(s.len() - a));
                s.replace_range(a..b, "");
            }
            Edit::DuplicateLine(i) if !lines.is_empty() => {
                let i = i % lines.len();
                lines.insert(i, lines[i].clone());
                s = joined(lines);
            }
            Edit::SwapLines(i, j) if !lines.is_empty() => {
                let n = lines.len();
                lines.swap(i % n, j % n);
                s = joined(lines);
            }
            Edit::Truncate(at) => s.truncate(boundary(&s, at)),
            Edit::ReplaceChar(at, c) if !s.is_empty() => {
                let a = boundary(&s, at % s.len());
                let b = a + s[a..].chars().next().map_or(0, char::len_utf8);
                s.replace_range(a..b, c.encode_utf8(&mut [0; 4]));
            }
            _ => {}
        }
        s
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 300,
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// Arbitrary bytes, as a file (not UTF-8, BOM, anything) and as text.
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("fuzz.yaml");
            std::fs::write(&path, &bytes).unwrap();
            let file = path.display().to_string();
            if let Err(e) = read_sweep_limited(&path, 1 << 20) {
                names_the_file(&e, &file, None);
            }
            let text = String::from_utf8_lossy(&bytes);
            if let Err(e) = parse_sweep(Path::new("fuzz.yaml"), &text) {
                names_the_file(&e, "fuzz.yaml", None);
            }
        }

        /// Arbitrary text made of YAML and sweep tokens.
        #[test]
        fn token_soup_never_panics(tokens in proptest::collection::vec(0..TOKENS.len(), 0..60)) {
            let text: String = tokens.iter().map(|t| TOKENS[*t]).collect();
            if let Err(e) = parse_sweep(Path::new("soup.yaml"), &text) {
                names_the_file(&e, "soup.yaml", None);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 300,
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// The shipped sweeps after a few structured edits: read, then (when read) expanded
        /// against their real pipelines, and resolved (every point planned) when small.
        #[test]
        fn mutated_shipped_sweeps_never_panic(
            which in any::<usize>(),
            edits in proptest::collection::vec(edit(), 1..4),
        ) {
            let all = shipped();
            let (path, original) = &all[which % all.len()];
            let text = edits.iter().fold(original.clone(), |t, e| apply(&t, e));
            let file = path.display().to_string();
            match parse_sweep(path, &text) {
                Err(e) => names_the_file(&e, &file, None),
                Ok(s) => {
                    let pipeline = s.pipeline_path().display().to_string();
                    // Expanded always; planned (the slow part) when it has few points.
                    let expanded = femu::sweep::expand::base_pipeline(&s)
                        .and_then(|b| femu::sweep::expand(&s, &b));
                    match expanded {
                        Err(e) => names_the_file(&e, &file, Some(&pipeline)),
                        Ok(x) if x.points.len() <= 16 => {
                            if let Err(e) = resolve(&s) {
                                names_the_file(&e, &file, Some(&pipeline));
                            }
                        }
                        Ok(_) => {}
                    }
                }
            }
        }
    }

    /// Deep nesting is an error or a parse, never a stack overflow.
    #[test]
    fn deep_nesting_does_not_crash() {
        for open in ["[", "{a: ", "- "] {
            let text = format!("pipeline: p.yaml\nset: {{x: {}}}\n", open.repeat(20_000));
            if let Err(e) = parse_sweep(Path::new("deep.yaml"), &text) {
                names_the_file(&e, "deep.yaml", None);
            }
        }
    }
}
