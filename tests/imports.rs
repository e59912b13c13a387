//! Real model and test-data files through pipelines: Nastran bulk data into modes, UFF 58
//! measurements into the correlation, with cache keys that follow content, not paths.

mod common;

use common::*;
use femu::artefact::kinds::{correlation_from_artefact, frf_from_artefact};
use femu::pipeline::Status;

#[test]
fn a_nastran_deck_runs_to_modes() {
    let dir = tempfile::tempdir().unwrap();
    let deck = root().join("fixtures/nastran/plate_with_bar.bdf");
    std::fs::copy(&deck, dir.path().join("plate.bdf")).unwrap();
    let text = "name: nastran\nstages:\n  mesh:\n    kind: mesh.import\n    with: {path: plate.bdf}\n  matrices:\n    kind: assemble\n    inputs: {mesh: mesh}\n  modes:\n    kind: modes\n    inputs: {model: matrices}\n    with: {count: 6}\n";
    let file = dir.path().join("p.yaml");
    std::fs::write(&file, text).unwrap();
    let (_, report, cache) = run(&file, &dir.path().join("cache"), &[]);
    let modes = report.stages.iter().find(|s| s.name == "modes").unwrap();
    let a = cache
        .read(&modes.key, "modes", femu::artefact::ArtefactKind::Modes)
        .unwrap();
    let m = femu::artefact::kinds::modes_from_artefact(&a).unwrap();
    assert_eq!(m.modes.len(), 6);
    assert_eq!(
        m.modes.rigid_body_modes, 0,
        "the SPC1 clamp holds the plate"
    );
    assert!(m.modes.residuals.iter().all(|r| *r < 1e-8));

    // Same content under another name: every stage cached (the key holds the model's digest).
    std::fs::rename(dir.path().join("plate.bdf"), dir.path().join("renamed.bdf")).unwrap();
    std::fs::write(&file, text.replace("plate.bdf", "renamed.bdf")).unwrap();
    let (_, again, _) = run(&file, &dir.path().join("cache"), &[]);
    let statuses: Vec<_> = again
        .stages
        .iter()
        .map(|s| (s.name.clone(), s.status))
        .collect();
    assert!(
        again.stages.iter().all(|s| s.status == Status::Cached),
        "{statuses:?}"
    );

    // Exported and re-imported, the model is the same.
    let model = femu::model::import::nastran::read_bulk(dir.path().join("renamed.bdf"))
        .unwrap()
        .model;
    let text = femu::model::export::nastran::write_bulk(&model);
    let back = femu::model::import::nastran::parse_bulk(&text, "exported.bdf")
        .unwrap()
        .model;
    assert_eq!(back, model);
}

#[test]
fn a_bad_card_is_reported_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("bad.bdf"),
        "BEGIN BULK\nGRID,1,,0.,0.,abc\nENDDATA\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("p.yaml"),
        "name: bad\nstages:\n  mesh:\n    kind: mesh.import\n    with: {path: bad.bdf}\n",
    )
    .unwrap();
    let out = femu()
        .arg("validate")
        .arg(dir.path().join("p.yaml"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("p.yaml:5:") && err.contains("bad.bdf") && err.contains("GRID"),
        "{err}"
    );
}

/// The four-DOF "measurements" written to UFF 58 (ASCII and binary) and read back by `frf.import`
/// give the same correlation as the synthesised artefact they came from.
#[test]
fn uff_measurements_feed_the_correlation() {
    let dir = tempfile::tempdir().unwrap();
    let (_, report, cache) = run(&pipeline("four-dof"), &dir.path().join("cache"), &[]);
    let stage = |name: &str| {
        report
            .stages
            .iter()
            .find(|s| s.name == name)
            .unwrap()
            .key
            .clone()
    };
    let measured = frf_from_artefact(
        &cache
            .read(&stage("measured"), "frf", femu::artefact::ArtefactKind::Frf)
            .unwrap(),
    )
    .unwrap();
    let reference = correlation_from_artefact(
        &cache
            .read(
                &stage("correlation"),
                "correlation",
                femu::artefact::ArtefactKind::Correlation,
            )
            .unwrap(),
    )
    .unwrap();
    for (name, binary, tol) in [("m.uff", true, 1e-15), ("a.uff", false, 1e-10)] {
        std::fs::write(
            dir.path().join(name),
            femu::model::export::uff::write_uff58(&measured, binary),
        )
        .unwrap();
        let text = std::fs::read_to_string(pipeline("four-dof")).unwrap().replace(
            "  measured:\n    kind: noise.add",
            &format!("  measured:\n    kind: frf.import\n    with: {{path: {name}}}\n  unused:\n    kind: noise.add"),
        );
        let file = dir.path().join("p.yaml");
        std::fs::write(&file, text).unwrap();
        let (_, r, cache) = run(&file, &dir.path().join("cache"), &[]);
        let key = r
            .stages
            .iter()
            .find(|s| s.name == "correlation")
            .unwrap()
            .key
            .clone();
        let c = correlation_from_artefact(
            &cache
                .read(
                    &key,
                    "correlation",
                    femu::artefact::ArtefactKind::Correlation,
                )
                .unwrap(),
        )
        .unwrap();
        for k in 0..c.chi_s.len() {
            assert!(
                (c.chi_s[k] - reference.chi_s[k]).abs() <= tol
                    && (c.chi_a[k] - reference.chi_a[k]).abs() <= tol,
                "{name} line {k}"
            );
        }
    }
}
