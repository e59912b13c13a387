//! Seeing a run (issue 27): progress lines, the stages' warnings at the end of `femu run`,
//! `femu show` on a run's output, `femu diff`'s summary and named rows, and `femu explain`'s
//! changed parameters — all through the binary.

mod common;

use common::{femu, pipeline};
use std::path::Path;
use std::process::Output;

fn run(cache: &Path, args: &[&str]) -> Output {
    let out = femu()
        .arg("run")
        .arg("--cache-dir")
        .arg(cache)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).to_string()
}

/// Without a terminal, progress is plain lines: each stage's start and end, and what its
/// numerics report (here the direct FRF's lines; the first report of a stage always shows);
/// `-q` prints nothing on standard error.
#[test]
fn progress_is_plain_lines_off_a_terminal_and_quiet_prints_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let p = pipeline("four-dof");
    let loud = run(&tmp.path().join("c1"), &[p.to_str().unwrap()]);
    let err = text(&loud.stderr);
    assert!(
        err.contains("[femu] measured_clean (frf.synthesise): running"),
        "{err}"
    );
    assert!(
        err.contains("[femu] measured_clean: FRF lines (direct, 4 DOFs) 0/801 (0 %)"),
        "{err}"
    );
    assert!(
        err.contains("[femu] measured_clean (frf.synthesise): ran in"),
        "{err}"
    );
    let quiet = run(&tmp.path().join("c2"), &["--quiet", p.to_str().unwrap()]);
    assert_eq!(text(&quiet.stderr), "", "-q prints nothing on stderr");
    assert!(text(&quiet.stdout).contains("pipeline four-dof: 9 stages, 9 ran"));
}

/// An update shows one line per iteration with the mean correlation, the active parameters,
/// the step and the condition number.
#[test]
fn update_prints_one_line_per_iteration() {
    let tmp = tempfile::tempdir().unwrap();
    let p = pipeline("four-dof-rfm");
    let out = run(
        &tmp.path().join("c"),
        &["--only", "rfm_complete_5hz", p.to_str().unwrap()],
    );
    let err = text(&out.stderr);
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("[femu] rfm_complete_5hz: iteration "))
        .collect();
    assert!(lines.len() >= 2, "{err}");
    assert!(
        lines[0].starts_with("[femu] rfm_complete_5hz: iteration 0: mean χ_s ")
            && lines[0].contains("parameters active, ")
            && lines[0].contains(" lines, step ")
            && lines[0].contains("condition "),
        "{err}"
    );
    assert!(lines.last().unwrap().contains("(final analysis)"), "{err}");
}

/// A one-stage pipeline importing FRFs from a CSV table in mm/N: the import records the
/// conversion in its meta, and `femu run` prints it once at the end, grouped by stage, on a
/// fresh and on a cached run.
#[test]
fn warnings_print_once_at_the_end_also_when_cached() {
    let tmp = tempfile::tempdir().unwrap();
    let mut csv = String::from("freq_hz,response,excitation,re,im,unit\n");
    for k in 1..=5 {
        csv.push_str(&format!("{k},1:ux,1:ux,{},0.5,mm/N\n", k as f64 * 0.1));
    }
    std::fs::write(tmp.path().join("lab.csv"), csv).unwrap();
    let file = tmp.path().join("p.yaml");
    std::fs::write(
        &file,
        "name: imp\nstages:\n  imp:\n    kind: frf.import\n    with: {path: lab.csv}\n",
    )
    .unwrap();
    let cache = tmp.path().join("c");
    for (round, status) in [(1, "frf.import"), (2, "frf.import, cached")] {
        let out = run(&cache, &[file.to_str().unwrap()]);
        let err = text(&out.stderr);
        assert_eq!(err.matches("warnings (").count(), 1, "round {round}: {err}");
        let at = err.find("warnings (").unwrap();
        let block = &err[at..];
        assert!(
            block.contains(&format!("\n  imp ({status}):\n    - ")),
            "round {round}: {err}"
        );
        assert!(block.contains("mm/N"), "round {round}: {err}");
        // The block comes after every progress line.
        assert!(!block.contains("[femu]"), "round {round}: {err}");
    }
}

/// `femu show OUT` summarises a run: stages with status and time, natural frequencies, mean
/// `χ`, the update's parameters; a directory that is neither a run nor an artefact is refused
/// with a clear message (exit 2); `femu show` of one artefact is as before.
#[test]
fn show_summarises_a_run_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("c");
    let out = tmp.path().join("out");
    run(
        &cache,
        &[
            "--quiet",
            "--out",
            out.to_str().unwrap(),
            pipeline("four-dof").to_str().unwrap(),
        ],
    );
    let show = femu().arg("show").arg(&out).output().unwrap();
    let s = text(&show.stdout);
    assert_eq!(show.status.code(), Some(0), "{s}{}", text(&show.stderr));
    assert!(s.contains("run of pipeline `four-dof`"), "{s}");
    assert!(s.contains("9 ran, 0 cached"), "{s}");
    assert!(
        s.lines()
            .any(|l| l.starts_with("truth_modes") && l.contains("modes") && l.contains("ran")),
        "{s}"
    );
    assert!(
        s.contains("truth_modes (modes): 4 modes, natural frequencies (Hz): "),
        "{s}"
    );
    assert!(
        s.contains("correlation (correlate.frf): mean χ_s 0."),
        "{s}"
    );
    assert!(s.contains("no warnings"), "{s}");

    let rfm_out = tmp.path().join("rfm");
    run(
        &cache,
        &[
            "--quiet",
            "--only",
            "rfm_complete_5hz",
            "--out",
            rfm_out.to_str().unwrap(),
            pipeline("four-dof-rfm").to_str().unwrap(),
        ],
    );
    let s = text(&femu().arg("show").arg(&rfm_out).output().unwrap().stdout);
    assert!(s.contains("rfm_complete_5hz (update): rfm: "), "{s}");
    assert!(s.contains(" → "), "{s}");
    // The update's posterior: what it is, then each parameter's mean, sd and interval.
    assert!(
        s.contains("rfm_complete_5hz (update): Laplace posterior about the rfm result, "),
        "{s}"
    );
    assert!(
        s.lines()
            .any(|l| l.contains(" ± ") && l.contains("(90 % interval ") && l.contains(" to ")),
        "{s}"
    );

    let one = femu()
        .arg("show")
        .arg(out.join("truth_modes/modes"))
        .output()
        .unwrap();
    assert_eq!(one.status.code(), Some(0));
    assert!(text(&one.stdout).contains("`modes` artefact"));

    let neither = femu().arg("show").arg(tmp.path()).output().unwrap();
    assert_eq!(neither.status.code(), Some(2));
    let e = text(&neither.stderr);
    assert!(
        e.contains("is not a femu artefact (")
            && e.contains("nor a run's output")
            && e.contains("femu.lock.json"),
        "{e}"
    );
    assert!(!e.contains("No such file"), "{e}");
}

/// `femu diff` of two runs: a summary first, the tolerances it used, rows named by their key
/// columns, `--full` listing every row; exit codes 0 same, 1 different.
#[test]
fn diff_summarises_and_names_rows() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let p = pipeline("four-dof");
    for (out, seed) in [("a", "1"), ("b", "2"), ("a2", "1")] {
        run(
            &cache,
            &[
                "--quiet",
                "--out",
                tmp.path().join(out).to_str().unwrap(),
                "--set",
                &format!("measured.seed={seed}"),
                p.to_str().unwrap(),
            ],
        );
    }
    let diff = |args: &[&str], a: &str, b: &str| {
        femu()
            .arg("diff")
            .args(args)
            .arg(tmp.path().join(a))
            .arg(tmp.path().join(b))
            .output()
            .unwrap()
    };
    let d = diff(&[], "a", "b");
    assert_eq!(d.status.code(), Some(1));
    let s = text(&d.stdout);
    let first = s.lines().next().unwrap();
    assert!(
        first.starts_with("comparing ")
            && first.contains("9 artefacts, ")
            && first.ends_with(" different"),
        "{s}"
    );
    assert!(s.contains("largest differences by column:"), "{s}");
    assert!(s.contains("  measured/frf: frf.re: "), "{s}");
    assert!(
        s.contains("tolerances (femu's defaults per artefact kind"),
        "{s}"
    );
    assert!(
        s.contains("  modes: every number: |a − b| ≤ 1e-9·max(|a|, |b|)")
            && s.contains("shapes.phi_* (up to sign"),
        "{s}"
    );
    assert!(
        s.contains("    frf.re row ") && s.contains(" (response 1:ux, excitation 1:ux, freq_hz "),
        "{s}"
    );
    assert!(s.contains("more in frf.re (--full lists every one)"), "{s}");
    let summary_at = s.find("largest differences").unwrap();
    let details_at = s.find("DIFFERENT").unwrap();
    assert!(summary_at < details_at, "summary first: {s}");

    let full = text(&diff(&["--full"], "a", "b").stdout);
    let listed = |t: &str| {
        t.lines()
            .filter(|l| l.starts_with("    frf.re row"))
            .count()
    };
    assert!(listed(&full) > 5 && listed(&s) == 5, "{}", listed(&full));
    assert!(!full.contains("--full lists every one"));

    let same = diff(&[], "a", "a2");
    assert_eq!(same.status.code(), Some(0), "{}", text(&same.stdout));
    assert!(text(&same.stdout).contains("9 artefacts, 9 same, 0 different"));
    let given = text(&diff(&["--rtol", "0.06"], "a", "b").stdout);
    assert!(
        given.contains("tolerances (from --rtol/--atol):"),
        "{given}"
    );
}

/// `femu explain` names the parameters that changed since the last run.
#[test]
fn explain_names_the_changed_parameters() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("c");
    let p = pipeline("four-dof");
    run(&cache, &["--quiet", p.to_str().unwrap()]);
    let out = femu()
        .args(["explain", "--cache-dir"])
        .arg(&cache)
        .args(["--set", "measured.seed=7", p.to_str().unwrap()])
        .output()
        .unwrap();
    let s = text(&out.stdout);
    assert!(out.status.success(), "{s}");
    assert!(s.contains("(params changed since: seed: 1 → 7)"), "{s}");
    assert!(s.contains("(params unchanged)"), "{s}");
}
