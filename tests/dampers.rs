//! Element dampers through the pipeline: a Nastran deck with a scalar-point oscillator
//! (CELAS4, CMASS4, CDAMP4) imported, assembled (the matrices carry the dampers' `C`) and
//! synthesised directly, against `1/(k − ω²m + iωc)`.

mod common;

use common::*;

fn write_pipeline(dir: &std::path::Path, method: &str, inputs: &str) -> std::path::PathBuf {
    let deck = "SPOINT,1\nCELAS4,1,4.+4,1\nCMASS4,2,1.5,1\nCDAMP4,3,12.,1\n";
    std::fs::write(dir.join("osc.bdf"), deck).unwrap();
    let text = format!(
        "name: dampers\nstages:\n  mesh:\n    kind: mesh.import\n    with: {{path: osc.bdf}}\n  matrices:\n    kind: assemble\n    inputs: {{mesh: mesh}}\n  modes:\n    kind: modes\n    inputs: {{model: matrices}}\n    with: {{count: 1}}\n  frf:\n    kind: frf.synthesise\n    inputs: {inputs}\n    with: {{method: {method}, responses: [\"1:s\"], excitations: [\"1:0\"], band_hz: [1, 40], step_hz: 13}}\n"
    );
    let file = dir.join("p.yaml");
    std::fs::write(&file, text).unwrap();
    file
}

/// Tolerance 1e-12 relative: one sparse LU of a 1×1 system per line, round-off only.
#[test]
fn a_damped_scalar_oscillator_matches_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_pipeline(dir.path(), "direct", "{model: matrices}");
    let (_, report, cache) = run(&file, &dir.path().join("cache"), &[]);
    let frf = report.stages.iter().find(|s| s.name == "frf").unwrap();
    let a = cache
        .read(&frf.key, "frf", femu::artefact::ArtefactKind::Frf)
        .unwrap();
    let set = femu::artefact::kinds::frf_from_artefact(&a).unwrap();
    assert_eq!(set.freqs_hz, [1.0, 14.0, 27.0, 40.0]);
    for (r, f) in set.freqs_hz.iter().enumerate() {
        let w = 2.0 * std::f64::consts::PI * f;
        let want = faer::c64::new(1.0, 0.0) / faer::c64::new(4e4 - w * w * 1.5, w * 12.0);
        let got = set.values[(r, 0)];
        assert!(
            (got - want).norm() < 1e-12 * want.norm(),
            "{f} Hz: {got} vs {want}"
        );
    }
}

/// A modal FRF of a model with element dampers is refused: they are not in the modal damping.
#[test]
fn a_modal_frf_with_element_dampers_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_pipeline(dir.path(), "modal", "{model: matrices, modes: modes}");
    let plan = load(&file, &[]);
    let cache = femu::cache::Cache::open(&dir.path().join("cache")).unwrap();
    let opts = femu::pipeline::RunOptions {
        progress: femu::pipeline::ProgressMode::Quiet,
        ..Default::default()
    };
    let e = match femu::pipeline::execute(&plan, &cache, &opts) {
        Ok(_) => panic!("the modal FRF should be refused"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("element dampers") && e.contains("method: direct"),
        "{e}"
    );
}
