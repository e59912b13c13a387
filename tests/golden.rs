//! Every shipped pipeline runs here and its artefacts are diffed against the golden artefacts in
//! `fixtures/golden/<pipeline>/` with the per-column tolerances in its `tolerances.yaml`.
//! `FEMU_BLESS=1 cargo test --release --test golden` regenerates them on purpose.

mod common;

use common::*;

fn check_pipeline(name: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(&pipeline(name), &tmp.path().join("cache"), &[]);
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    check_golden(name, &out, &[]);
}

#[test]
fn four_dof_matches_its_golden_artefacts() {
    check_pipeline("four-dof");
}

#[test]
fn four_dof_rfm_matches_its_golden_artefacts() {
    check_pipeline("four-dof-rfm");
}

#[test]
fn structures_modes_match_their_golden_artefacts() {
    check_pipeline("structures-modes");
}
