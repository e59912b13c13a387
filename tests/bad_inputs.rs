//! The catalogue of bad inputs: each case runs the `femu` binary on a pipeline (or command line)
//! that a user could write, and fixes the exit code (2 for bad input or usage, 1 for a failure)
//! and what the message must say — where (file:line, stage, field) and what would be valid.
//! Cases that once passed silently (exit 0 with a wrong or empty result) or failed late with
//! exit 1 are here so they stay fixed.

mod common;

use std::path::Path;

/// A two-mass chain: modes, a modal FRF and a correlation against itself, and an update of the
/// second mass. Each case edits one line of it.
const BASE: &str = r#"name: catalogue
stages:
  model:
    kind: model.lumped
    with:
      masses: [{dof: "1:ux", m: 1.0}, {dof: "2:ux", m: 1.3}]
      springs: [{from: "1:ux", k: 1.0e4}, {from: "1:ux", to: "2:ux", k: 1.0e4}]
      parameters: [{name: m2, mass: "2:ux"}]
  truth:
    kind: model.lumped
    with:
      masses: [{dof: "1:ux", m: 1.0}, {dof: "2:ux", m: 1.0}]
      springs: [{from: "1:ux", k: 1.0e4}, {from: "1:ux", to: "2:ux", k: 1.0e4}]
  modes:
    kind: modes
    inputs: {model: model}
  measured:
    kind: frf.synthesise
    inputs: {model: truth}
    with: {method: direct, responses: ["1:ux", "2:ux"], excitations: ["1:ux"], band_hz: [0.5, 40], step_hz: 0.5, damping: {structural: 0.02}}
  predicted:
    kind: frf.synthesise
    inputs: {modes: modes}
    with: {responses: ["1:ux", "2:ux"], excitations: ["1:ux"], band_hz: [0.5, 40], step_hz: 0.5, damping: {structural: 0.02}}
  correlation:
    kind: correlate.frf
    inputs: {measured: measured, predicted: predicted}
  updated:
    kind: update
    inputs: {model: model, measured: measured}
    with: {method: rfm, lines_hz: [5.0, 12.0], max_iterations: 5}
"#;

/// What a case must give.
struct Expect {
    code: i32,
    /// Fragments the standard error must hold.
    says: &'static [&'static str],
}

/// Runs `femu ARGS` in a fresh directory holding `pipeline.yaml` (the text given) and returns
/// the exit code and standard error.
fn femu_on(text: &str, args: &[&str]) -> (i32, String, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("pipeline.yaml"), text).unwrap();
    let out = common::femu()
        .current_dir(dir.path())
        .args(args)
        .env("FEMU_CACHE_DIR", dir.path().join("cache"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    (out.status.code().unwrap_or(-1), err, dir)
}

/// `BASE` with `from` replaced by `to` (the case must change something).
fn edited(from: &str, to: &str) -> String {
    assert!(
        BASE.contains(from),
        "test bug: `{from}` not in the pipeline"
    );
    BASE.replacen(from, to, 1)
}

fn check(name: &str, text: &str, args: &[&str], expect: Expect) {
    let (code, err, _dir) = femu_on(text, args);
    assert_eq!(
        code, expect.code,
        "case `{name}`: exit {code}, expected {}; stderr:\n{err}",
        expect.code
    );
    for s in expect.says {
        assert!(err.contains(s), "case `{name}`: stderr lacks `{s}`:\n{err}");
    }
    assert!(!err.contains("panicked"), "case `{name}` panicked:\n{err}");
}

#[test]
fn the_base_pipeline_runs() {
    let (code, err, _dir) = femu_on(BASE, &["run", "pipeline.yaml", "-q"]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn usage_errors_exit_two() {
    check(
        "--only names no stage",
        BASE,
        &["run", "pipeline.yaml", "--only", "nosuch"],
        Expect {
            code: 2,
            says: &["--only nosuch: no such stage", "stages: model"],
        },
    );
    check(
        "show of a path that is no artefact",
        BASE,
        &["show", "nowhere"],
        Expect {
            code: 2,
            says: &["nowhere is not a femu artefact"],
        },
    );
    check(
        "negative diff tolerance",
        BASE,
        &["diff", ".", ".", "--rtol=-1"],
        Expect {
            code: 2,
            says: &["--rtol/--atol: default: rtol = -1 must be a finite number >= 0"],
        },
    );
    check(
        "NaN diff tolerance",
        BASE,
        &["diff", ".", ".", "--atol=NaN"],
        Expect {
            code: 2,
            says: &["atol = NaN"],
        },
    );
    check(
        "a tolerance file that is not a file",
        BASE,
        &["diff", ".", ".", "--tolerances", "/dev/zero"],
        Expect {
            code: 2,
            says: &["not a regular file"],
        },
    );
    check(
        "a pipeline that is a device",
        BASE,
        &["validate", "/dev/zero"],
        Expect {
            code: 2,
            says: &["/dev/zero:", "not a regular file"],
        },
    );
}

#[test]
fn run_time_bad_input_is_located_and_exits_two() {
    // The parameter list names a parameter the model lacks: known only once the upstream model
    // exists, and still the user's input, located at the field.
    check(
        "update names an unknown parameter",
        BASE,
        &[
            "run",
            "pipeline.yaml",
            "-q",
            "--set",
            r#"updated.parameters=["nosuch"]"#,
        ],
        Expect {
            code: 2,
            says: &[
                "pipeline.yaml:",
                "stage `updated`, field `with.parameters`",
                "`nosuch` is not a parameter of the model (it has: m2)",
            ],
        },
    );
    check(
        "predicted lines differ from the measured ones",
        &edited(
            "band_hz: [0.5, 40], step_hz: 0.5, damping: {structural: 0.02}}\n  correlation",
            "band_hz: [0.5, 20], step_hz: 0.5, damping: {structural: 0.02}}\n  correlation",
        ),
        &["run", "pipeline.yaml", "-q", "--only", "correlation"],
        Expect {
            code: 2,
            says: &[
                "stage `correlation`",
                "80 measured lines but 40 predicted; measured line 41 (20.5 Hz) has no predicted counterpart",
            ],
        },
    );
    check(
        "a frequency limit below the first mode",
        &edited(
            "    inputs: {model: model}\n  measured",
            "    inputs: {model: model}\n    with: {max_freq_hz: 1.0}\n  measured",
        ),
        &["run", "pipeline.yaml", "-q", "--only", "modes"],
        Expect {
            code: 2,
            says: &[
                "stage `modes`, field `with.max_freq_hz`",
                "no mode lies below 1 Hz (the lowest is at",
            ],
        },
    );
}

#[test]
fn numbers_that_cannot_be_honoured_are_refused_before_running() {
    check(
        "a step too small to separate lines",
        &edited(
            "band_hz: [0.5, 40], step_hz: 0.5",
            "band_hz: [0, 1.0e6], step_hz: 1.0e-17",
        ),
        &["validate", "pipeline.yaml"],
        Expect {
            code: 2,
            says: &[
                "stage `measured`, field `with.step_hz`",
                "too small to separate lines",
            ],
        },
    );
    check(
        "a billion lines",
        &edited(
            "band_hz: [0.5, 40], step_hz: 0.5",
            "band_hz: [0, 1.0e6], step_hz: 1.0e-3",
        ),
        &["validate", "pipeline.yaml"],
        Expect {
            code: 2,
            says: &[
                "field `with.step_hz`",
                "1.000e9 lines, above the limit of 1000000",
            ],
        },
    );
    check(
        "NaN in a parameter",
        &edited(
            "k: 1.0e4}, {from: \"1:ux\", to",
            "k: .nan}, {from: \"1:ux\", to",
        ),
        &["validate", "pipeline.yaml"],
        Expect {
            code: 2,
            says: &[
                "pipeline.yaml:7:",
                "NaN is not a finite number",
                "stages.model.with.springs.0.k",
            ],
        },
    );
    check(
        "infinity through --set",
        BASE,
        &[
            "validate",
            "pipeline.yaml",
            "--set",
            "measured.step_hz=.inf",
        ],
        Expect {
            code: 2,
            says: &["--set", "inf, not a finite number"],
        },
    );
}

#[test]
fn names_that_would_leave_the_cache_are_refused() {
    for name in [
        "../../escape",
        "/tmp/escape",
        "a/b",
        ".hidden",
        "two\\nlines",
    ] {
        check(
            &format!("pipeline name {name}"),
            &edited("name: catalogue", &format!("name: \"{name}\"")),
            &["validate", "pipeline.yaml"],
            Expect {
                code: 2,
                says: &["pipeline.yaml:1:", "is not a valid pipeline name"],
            },
        );
    }
}

#[test]
fn a_byte_order_mark_is_legal_yaml() {
    let (code, err, _dir) = femu_on(&format!("\u{feff}{BASE}"), &["validate", "pipeline.yaml"]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn megabytes_of_junk_fail_fast_with_few_lines() {
    let dir = tempfile::tempdir().unwrap();
    let junk: String = (0..400_000).map(|i| format!("k{i}: [\n")).collect();
    let file = dir.path().join("junk.yaml");
    std::fs::write(&file, &junk).unwrap();
    let out = common::femu().arg("validate").arg(&file).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("larger than the limit of 4194304 bytes"),
        "{err}"
    );
    // Under the size limit, a file of thousands of errors prints the first ones and a count.
    let dup: String = std::iter::once("name: dup\nstages:\n".to_string())
        .chain((0..5000).map(|_| "  s: {kind: modes}\n".to_string()))
        .collect();
    std::fs::write(&file, &dup).unwrap();
    let out = common::femu().arg("validate").arg(&file).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("… and 4949 more problems"), "{err}");
    assert!(err.lines().count() < 120, "{} lines", err.lines().count());
}

#[test]
fn an_unreadable_pipeline_names_itself() {
    let (code, err, dir) = femu_on(BASE, &["validate", "missing.yaml"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("missing.yaml: cannot read the pipeline file"),
        "{err}"
    );
    drop(dir);
    let _ = Path::new(".");
}

#[test]
fn exponential_aliases_are_located() {
    let mut text = String::from(
        "name: laughs\nstages:\n  model:\n    kind: model.lumped\n    with:\n      a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n",
    );
    for i in 1..10 {
        let prev = i - 1;
        text.push_str(&format!(
            "      a{i}: &a{i} [*a{prev}, *a{prev}, *a{prev}, *a{prev}, *a{prev}, *a{prev}, *a{prev}, *a{prev}, *a{prev}, *a{prev}]\n"
        ));
    }
    let (code, err, _dir) = femu_on(&text, &["validate", "pipeline.yaml"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("pipeline.yaml:7:"), "{err}");
}

#[test]
fn confined_reads_stay_in_the_pipeline_tree() {
    let dir = tempfile::tempdir().unwrap();
    let inner = dir.path().join("study");
    std::fs::create_dir(&inner).unwrap();
    std::fs::write(dir.path().join("outside.bdf"), "BEGIN BULK\nENDDATA\n").unwrap();
    let text = "name: confined\nstages:\n  mesh:\n    kind: mesh.import\n    with: {path: ../outside.bdf}\n";
    std::fs::write(inner.join("pipeline.yaml"), text).unwrap();
    let out = common::femu()
        .current_dir(&inner)
        .args(["validate", "pipeline.yaml", "--confine-reads"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("to which input files are confined"), "{err}");
    assert!(err.contains("pipeline.yaml:5:"), "{err}");
    let out = common::femu()
        .current_dir(&inner)
        .args(["validate", "pipeline.yaml", "--max-input-bytes", "lots"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--max-input-bytes lots"));
}

#[test]
fn a_model_without_free_dofs_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let deck = "BEGIN BULK\n\
                GRID,1,,0.,0.,0.\n\
                GRID,2,,1.,0.,0.\n\
                MAT1,1,2.1+11,,.3,7850.\n\
                PBAR,1,1,1.-4,1.-8,1.-8,2.-8\n\
                CBAR,1,1,1,2,0.,1.,0.\n\
                SPC1,1,123456,1,2\n\
                ENDDATA\n";
    std::fs::write(dir.path().join("fixed.bdf"), deck).unwrap();
    let text = "name: fixed\nstages:\n  mesh:\n    kind: mesh.import\n    with: {path: fixed.bdf}\n  matrices:\n    kind: assemble\n    inputs: {mesh: mesh}\n";
    std::fs::write(dir.path().join("pipeline.yaml"), text).unwrap();
    let out = common::femu()
        .current_dir(dir.path())
        .args(["run", "pipeline.yaml", "-q"])
        .env("FEMU_CACHE_DIR", dir.path().join("cache"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("stage `matrices`") && err.contains("no free DOFs"),
        "{err}"
    );
    assert!(!err.contains("not positive definite"), "{err}");
}

/// The pipeline reader and planner never panic, whatever the text, and every problem names the
/// file: arbitrary bytes, and shipped pipelines with lines deleted, duplicated or cut.
mod fuzz {
    use proptest::prelude::*;

    fn shipped() -> Vec<String> {
        ["four-dof", "four-dof-rfm", "bent-plate-pc"]
            .iter()
            .map(|n| std::fs::read_to_string(super::common::pipeline(n)).unwrap())
            .collect()
    }

    fn check(text: &str) {
        let registry = femu::stages::registry();
        let result = femu::pipeline::parse_pipeline("fuzz.yaml", text)
            .and_then(|s| femu::pipeline::plan(&s, &registry).map(|_| ()));
        if let Err(d) = result {
            assert!(!d.0.is_empty());
            assert!(d.0.iter().all(|d| d.file == "fuzz.yaml"), "{d}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

        #[test]
        fn arbitrary_text(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
            check(&String::from_utf8_lossy(&bytes));
        }

        #[test]
        fn mutated_pipelines(which in 0usize..3, edits in prop::collection::vec((0usize..4, any::<prop::sample::Index>(), any::<u8>()), 1..6)) {
            let mut lines: Vec<String> = shipped()[which].lines().map(str::to_string).collect();
            for (op, at, byte) in edits {
                if lines.is_empty() { break; }
                let i = at.index(lines.len());
                match op {
                    0 => { lines.remove(i); }
                    1 => { let l = lines[i].clone(); lines.insert(i, l); }
                    2 => {
                        let mut k = lines[i].len() / 2;
                        while !lines[i].is_char_boundary(k) { k -= 1; }
                        lines[i].truncate(k);
                    }
                    _ => { lines[i].push(char::from(byte % 95 + 32)); }
                }
            }
            check(&lines.join("\n"));
        }
    }
}
