//! Every shipped pipeline runs here and its artefacts are diffed against the golden artefacts in
//! `fixtures/golden/<pipeline>/` with the per-column tolerances in its `tolerances.yaml`.
//! `FEMU_BLESS=1 cargo test --release --test golden` regenerates them on purpose.

mod common;

use common::*;
use femu::artefact::codec::read_dir;
use femu::artefact::compare::{Tolerances, compare};
use femu::artefact::kinds::check_layout;
use std::path::Path;

fn artefact_dirs(root: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for stage in std::fs::read_dir(root)
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_dir())
    {
        for port in std::fs::read_dir(stage.path())
            .unwrap()
            .flatten()
            .filter(|e| e.path().is_dir())
        {
            out.push(port.path().strip_prefix(root).unwrap().to_path_buf());
        }
    }
    out.sort();
    out
}

fn check_pipeline(name: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(&pipeline(name), &tmp.path().join("cache"), &[]);
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    let golden = root().join("fixtures/golden").join(name);
    let tolerances: Tolerances = serde_yaml::from_str(
        &std::fs::read_to_string(golden.join("tolerances.yaml"))
            .expect("tolerances.yaml beside the golden artefacts"),
    )
    .unwrap();
    if std::env::var_os("FEMU_BLESS").is_some() {
        for rel in artefact_dirs(&golden) {
            std::fs::remove_dir_all(golden.join(&rel)).unwrap();
        }
        for rel in artefact_dirs(&out) {
            let (src, dst) = (out.join(&rel), golden.join(&rel));
            std::fs::create_dir_all(&dst).unwrap();
            for f in std::fs::read_dir(&src).unwrap().flatten() {
                std::fs::copy(f.path(), dst.join(f.file_name())).unwrap();
            }
        }
        eprintln!("blessed {}", golden.display());
        return;
    }
    let (got, want) = (artefact_dirs(&out), artefact_dirs(&golden));
    assert_eq!(
        got, want,
        "the pipeline's artefacts differ from the golden set; bless on purpose with FEMU_BLESS=1"
    );
    let mut failures = Vec::new();
    for rel in &got {
        let a = read_dir(&out.join(rel)).unwrap();
        check_layout(&a).unwrap_or_else(|e| panic!("{}: {e}", rel.display()));
        let b = read_dir(&golden.join(rel)).unwrap();
        let c = compare(&a, &b, &tolerances);
        if !c.same() {
            failures.push(format!(
                "{}: {} values differ, e.g. {:?}",
                rel.display(),
                c.count,
                c.differences.first()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
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
