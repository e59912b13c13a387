//! `femu validate` checks what it can know from the files before anything runs (issue 25): a
//! parameter on a set the model lacks or of a kind the set's elements do not carry, values for
//! undeclared parameters, and measured DOFs that are not model DOFs — each reported at its
//! stage and field with the pipeline file's line, where the run used to fail later.

mod common;

use common::root;
use std::process::Command;

/// Runs `femu validate` on `yaml` (beside a copy of the lab fixture); exit code and output.
fn validate(yaml: &str) -> (i32, String) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        root().join("tests/fixtures/uff/lab-plate.uff"),
        dir.path().join("lab-plate.uff"),
    )
    .unwrap();
    let file = dir.path().join("p.yaml");
    std::fs::write(&file, yaml).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_femu"))
        .arg("validate")
        .arg(&file)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.code().unwrap_or(-1), text)
}

const BEAMS: &str =
    "name: pre\nstages:\n  beams:\n    kind: mesh.generate\n    with: {geometry: three_beam}\n";

#[test]
fn parameters_are_checked_against_the_model() {
    let (code, ok) = validate(&format!(
        "{BEAMS}  params:\n    kind: mesh.parameters\n    inputs: {{mesh: beams}}\n    with:\n      declare:\n        - {{name: m1, kind: {{lumped_mass: ux}}, set: mass_1}}\n"
    ));
    assert_eq!(code, 0, "{ok}");
    assert!(ok.contains("valid pipeline"), "{ok}");

    let (code, text) = validate(&format!(
        "{BEAMS}  params:\n    kind: mesh.parameters\n    inputs: {{mesh: beams}}\n    with:\n      declare:\n        - {{name: m1, kind: {{lumped_mass: ux}}, set: mass_1}}\n        - {{name: t, kind: shell_thickness, set: beam_1}}\n        - {{name: k, kind: {{spring_stiffness: uy}}, set: beam_4}}\n      values: {{m9: 0.1}}\n"
    ));
    assert_eq!(code, 2, "{text}");
    // The thickness on a beam set: at its `kind`, line 12 of the file.
    assert!(
        text.contains("p.yaml:12")
            && text.contains("with.declare.1.kind")
            && text.contains("cannot act on element"),
        "{text}"
    );
    // The set that does not exist: at its `set`, with the nearest name.
    assert!(
        text.contains("p.yaml:13")
            && text.contains("with.declare.2.set")
            && text.contains("did you mean `beam_"),
        "{text}"
    );
    assert!(
        text.contains("with.values.m9") && text.contains("`m9` is not a parameter"),
        "{text}"
    );
}

#[test]
fn measured_dofs_are_checked_against_the_model() {
    let plate = "  plate:\n    kind: mesh.generate\n    with: {geometry: flat_plate, a_m: 0.4, b_m: 0.3, nx: 4, ny: 3, thickness_m: 0.002}\n  params:\n    kind: mesh.parameters\n    inputs: {mesh: plate}\n    with:\n      declare: [{name: t, kind: shell_thickness, set: plate}]\n";
    let (code, text) = validate(&format!(
        "name: pre\nstages:\n{plate}  lab:\n    kind: frf.import\n    with: {{path: lab-plate.uff}}\n  update:\n    kind: update\n    inputs: {{mesh: params, measured: lab.frf}}\n    with: {{method: pc}}\n"
    ));
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("p.yaml:17")
            && text.contains("stage `update`")
            && text.contains("6 measured DOF(s) are not DOFs of the model")
            && text.contains("120:uz (excitation: no grid 120)")
            && text.contains("9001:uz (response: no grid 9001)")
            && text.contains(", and 1 more. Measured DOFs must be model DOFs")
            && text.contains("test.pair"),
        "{text}"
    );
}
