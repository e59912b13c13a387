//! Error messages for bad pipelines: each names the file, line and column, the stage and field,
//! and what would be valid. Snapshots in `tests/snapshots/` fix their wording.

mod common;

use femu::pipeline::{parse_pipeline, plan};

const GOOD: &str = r#"name: t
stages:
  model:
    kind: model.lumped
    with:
      masses: [{dof: "1:ux", m: 1.0}]
      springs: [{from: "1:ux", k: 100.0}]
  frf:
    kind: frf.synthesise
    inputs: {model: model}
    with: {responses: ["1:ux"], excitations: ["1:ux"], band_hz: [0, 2], step_hz: 0.5}
  noisy:
    kind: noise.add
    inputs: {frf: frf}
    with: {level: 0.05, seed: 1}
"#;

/// The messages for `GOOD` with `from` replaced by `to`.
fn errors(from: &str, to: &str) -> String {
    assert!(
        GOOD.contains(from),
        "test bug: `{from}` not in the pipeline"
    );
    let text = GOOD.replacen(from, to, 1);
    let result = parse_pipeline("bad.yaml", &text)
        .and_then(|s| plan(&s, &femu::stages::registry()).map(|_| ()));
    match result {
        Ok(()) => panic!("expected an error for: {to}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_reference_pipeline_is_valid() {
    let s = parse_pipeline("good.yaml", GOOD).unwrap();
    plan(&s, &femu::stages::registry()).unwrap();
}

#[test]
fn unknown_kind_suggests_the_nearest() {
    insta::assert_snapshot!(errors("kind: noise.add", "kind: noise.ad"));
}

#[test]
fn unknown_input_port() {
    insta::assert_snapshot!(errors("inputs: {frf: frf}", "inputs: {frfs: frf}"));
}

#[test]
fn missing_required_input() {
    insta::assert_snapshot!(errors("    inputs: {frf: frf}\n", ""));
}

#[test]
fn unknown_upstream_stage() {
    insta::assert_snapshot!(errors("inputs: {frf: frf}", "inputs: {frf: fr}"));
}

#[test]
fn wrong_artefact_kind_on_a_port() {
    insta::assert_snapshot!(errors("inputs: {frf: frf}", "inputs: {frf: model}"));
}

#[test]
fn parameter_out_of_range() {
    insta::assert_snapshot!(errors("level: 0.05", "level: -0.05"));
}

#[test]
fn parameter_of_the_wrong_type() {
    insta::assert_snapshot!(errors("step_hz: 0.5", "step_hz: fast"));
}

#[test]
fn unknown_parameter() {
    insta::assert_snapshot!(errors("seed: 1", "sead: 1"));
}

#[test]
fn bad_dof_label() {
    insta::assert_snapshot!(errors(r#"responses: ["1:ux"]"#, r#"responses: ["1:ua"]"#));
}

#[test]
fn cycle() {
    let text = "name: c\nstages:\n  a:\n    kind: noise.add\n    inputs: {frf: b}\n    with: {level: 0.1}\n  b:\n    kind: noise.add\n    inputs: {frf: a}\n    with: {level: 0.1}\n";
    let s = parse_pipeline("bad.yaml", text).unwrap();
    let e = plan(&s, &femu::stages::registry()).err().expect("a cycle");
    insta::assert_snapshot!(e.to_string());
}

#[test]
fn duplicate_stage_name() {
    insta::assert_snapshot!(errors("  noisy:\n", "  frf:\n"));
}

#[test]
fn unknown_stage_key() {
    insta::assert_snapshot!(errors("    with: {level", "    wiht: {level"));
}

#[test]
fn yaml_syntax_error() {
    insta::assert_snapshot!(errors("band_hz: [0, 2]", "band_hz: [0, 2"));
}

#[test]
fn several_errors_are_all_reported() {
    let text = GOOD.replacen("level: 0.05", "level: -1", 1).replacen(
        "kind: frf.synthesise",
        "kind: frf.synth",
        1,
    );
    let e = parse_pipeline("bad.yaml", &text)
        .and_then(|s| plan(&s, &femu::stages::registry()).map(|_| ()))
        .unwrap_err();
    assert_eq!(e.0.len(), 2, "{e}");
}

#[test]
fn the_cli_exits_two_on_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.yaml");
    std::fs::write(&file, GOOD.replacen("level: 0.05", "level: -1", 1)).unwrap();
    let out = common::femu().arg("validate").arg(&file).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.yaml:15:") && err.contains("stage `noisy`, field `with.level`"),
        "{err}"
    );
    let out = common::femu()
        .args(["run", "--set", "nope.level=1"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = common::femu().args(["frobnicate"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}
