//! The JSON Schemas in `schemas/` are generated from the code; this keeps them in step.
//! `FEMU_BLESS=1 cargo test --release --test schemas` (or `femu schema`) rewrites them.

mod common;

#[test]
fn committed_schemas_match_the_code() {
    let tmp = tempfile::tempdir().unwrap();
    femu::cli::write_schemas(tmp.path()).unwrap();
    let committed = common::root().join("schemas");
    if std::env::var_os("FEMU_BLESS").is_some() {
        femu::cli::write_schemas(&committed).unwrap();
        return;
    }
    for rel in [
        "pipeline.schema.json",
        "sweep.schema.json",
        "artefacts/matrices.schema.json",
        "artefacts/modes.schema.json",
        "artefacts/frf.schema.json",
        "artefacts/correlation.schema.json",
        "artefacts/plot.schema.json",
        "artefacts/mesh.schema.json",
    ] {
        let want = std::fs::read_to_string(committed.join(rel))
            .unwrap_or_else(|_| panic!("schemas/{rel} is missing; run `femu schema`"));
        let got = std::fs::read_to_string(tmp.path().join(rel)).unwrap();
        assert!(
            want == got,
            "schemas/{rel} is out of date with the code; run `femu schema` (or FEMU_BLESS=1)"
        );
    }
}

/// Every stage of every shipped pipeline is a known kind with its ports wired (the plan is the
/// schema's semantic twin), and each `with:` block satisfies the stage's parameter schema keys.
#[test]
fn shipped_pipelines_are_valid() {
    for e in std::fs::read_dir(common::root().join("pipelines"))
        .unwrap()
        .flatten()
    {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "yaml") {
            common::load(&p, &[]);
        }
    }
}
