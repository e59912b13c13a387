//! Test modes in and predictions out (issue 25): `test.export` writes a model's modes at the
//! lab's measured DOFs (through a `test.pair` map) and predicted FRFs as a Universal File, and
//! `modes.import` and `frf.import` read them back. Checked against the model's own modes
//! combined with the map's weights by hand, and against the predicted FRFs.
//!
//! The lab fixture is `tests/fixtures/uff/lab-plate.uff` (see tests/pairing.rs).

mod common;

use common::root;
use femu::artefact::ArtefactKind;
use femu::artefact::kinds::test_geometry::test_geometry_from_artefact;
use femu::artefact::kinds::test_map::test_map_from_artefact;
use femu::artefact::kinds::universal_file::{UniversalFile, UniversalFileKind};
use femu::artefact::kinds::{Kind, frf_from_artefact, modes_from_artefact};
use femu::cache::Cache;
use femu::frf::io::uff::parse_uff;
use femu::pipeline::RunReport;
use femu::stages::frf_import::geometry_of;
use std::path::Path;

const PLATE: &str = "  plate:\n    kind: mesh.generate\n    with: {geometry: flat_plate, a_m: 0.4, b_m: 0.3, nx: 4, ny: 3, thickness_m: 0.002}\n";
const FIT: &str =
    "{fit: [{test: 101, fe: 1}, {test: 105, fe: 5}, {test: 120, fe: 20}, {test: 116, fe: 16}]}";

fn output(
    report: &RunReport,
    cache: &Cache,
    stage: &str,
    port: &str,
    kind: ArtefactKind,
) -> femu::artefact::Artefact {
    let key = &report.stages.iter().find(|s| s.name == stage).unwrap().key;
    cache.read(key, port, kind).unwrap()
}

fn global() -> [[f64; 3]; 3] {
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
}

fn write(dir: &Path, name: &str, yaml: &str) -> std::path::PathBuf {
    let file = dir.join(name);
    std::fs::write(&file, yaml).unwrap();
    file
}

/// The model's modes at the lab's points go out as dataset 55 and come back through
/// `modes.import` as `W φ` (to the `E13.5` columns: 7 significant digits, 6 for a negative
/// value, so 5e-6 of the largest component), at the model's
/// frequencies; the predicted FRFs go out as dataset 58 and come back as they were.
#[test]
fn modes_and_frfs_go_out_at_the_measured_dofs_and_come_back() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        root().join("tests/fixtures/uff/lab-plate.uff"),
        dir.path().join("lab-plate.uff"),
    )
    .unwrap();
    let yaml = format!(
        "name: lab-out\nstages:\n{PLATE}  lab:\n    kind: frf.import\n    with: {{path: lab-plate.uff}}\n  pair:\n    kind: test.pair\n    inputs: {{mesh: plate, geometry: lab.geometry, frf: lab.frf}}\n    with: {{tolerance_m: 0.002, alignment: {FIT}}}\n  matrices:\n    kind: assemble\n    inputs: {{mesh: plate}}\n  modes:\n    kind: modes\n    inputs: {{model: matrices}}\n    with: {{count: 12}}\n  predicted:\n    kind: frf.synthesise\n    inputs: {{model: matrices, template: lab.frf, map: pair.map}}\n    with: {{method: direct, damping: {{structural: 0.01}}}}\n  export:\n    kind: test.export\n    inputs: {{modes: modes.modes, map: pair.map, frf: predicted}}\n    with: {{file_name: predicted.uff}}\n"
    );
    let file = write(dir.path(), "out.yaml", &yaml);
    let (_, report, cache) = common::run(&file, &dir.path().join("cache"), &[]);
    let uff: UniversalFile = UniversalFileKind::from_artefact(&output(
        &report,
        &cache,
        "export",
        "file",
        ArtefactKind::UniversalFile,
    ))
    .unwrap();
    assert_eq!(uff.name, "predicted.uff");
    assert_eq!(uff.datasets[0], (164, 1));
    assert_eq!(uff.datasets[2], (55, 12));
    let model = modes_from_artefact(&output(
        &report,
        &cache,
        "modes",
        "modes",
        ArtefactKind::Modes,
    ))
    .unwrap();
    let map = test_map_from_artefact(&output(
        &report,
        &cache,
        "pair",
        "map",
        ArtefactKind::TestMap,
    ))
    .unwrap();
    let predicted = frf_from_artefact(&output(
        &report,
        &cache,
        "predicted",
        "frf",
        ArtefactKind::Frf,
    ))
    .unwrap();
    std::fs::write(dir.path().join("predicted.uff"), &uff.bytes).unwrap();

    // Read back beside the first pipeline's stages (cached), and correlated through the map.
    let back = format!(
        "{}  test_modes:\n    kind: modes.import\n    with: {{path: predicted.uff}}\n  test_frf:\n    kind: frf.import\n    with: {{path: predicted.uff}}\n  mac:\n    kind: correlate.modes\n    inputs: {{reference: test_modes.modes, predicted: modes.modes, map: pair.map}}\n",
        yaml.replace("name: lab-out", "name: lab-in")
    );
    let file = write(dir.path(), "in.yaml", &back);
    let (_, report, cache) = common::run(&file, &dir.path().join("cache"), &[]);
    let a = output(&report, &cache, "test_modes", "modes", ArtefactKind::Modes);
    assert_eq!(a.meta["normalisation"], "as_measured");
    let test = modes_from_artefact(&a).unwrap();
    let f_model = model.modes.frequencies_hz();
    let f_test = test.modes.frequencies_hz();
    assert_eq!(f_test.len(), 12);
    for (a, b) in f_test.iter().zip(&f_model) {
        // Rigid-body modes (the plate is free) to 1e-6 Hz, elastic ones to 1e-6 relative.
        assert!((a - b).abs() <= 1e-6 * b.max(1.0), "{a} vs {b}");
    }
    // By hand: φ_t(d) = Σ w φ(fe) over the map's rows of d, with the model's rows by label.
    let row = |d: &femu::core::DofId| model.dofs.iter().position(|x| x == d).unwrap();
    for (i, d) in test.dofs.iter().enumerate() {
        for c in 0..12 {
            let want: f64 = map
                .rows
                .iter()
                .filter(|r| r.test_dof == *d)
                .map(|r| r.weight * model.modes.shapes[(row(&r.fe_dof), c)])
                .sum();
            let scale = (0..test.dofs.len())
                .map(|k| test.modes.shapes[(k, c)].abs())
                .fold(0.0, f64::max);
            let got = test.modes.shapes[(i, c)];
            // The reader fixes each shape's sign by its largest component.
            let sign = if (got - want).abs() <= (got + want).abs() {
                1.0
            } else {
                -1.0
            };
            assert!(
                (got - sign * want).abs() <= 5e-6 * scale,
                "{d} mode {}: {got} vs {want}",
                c + 1
            );
        }
    }
    let frf = frf_from_artefact(&output(
        &report,
        &cache,
        "test_frf",
        "frf",
        ArtefactKind::Frf,
    ))
    .unwrap();
    assert_eq!(frf.pairs, predicted.pairs);
    assert_eq!(frf.freqs_hz, predicted.freqs_hz);
    for l in 0..frf.freqs_hz.len() {
        for j in 0..frf.pairs.len() {
            let (a, b) = (frf.values[(l, j)], predicted.values[(l, j)]);
            assert!(
                (a - b).norm() <= 1e-11 * b.norm(),
                "line {l} pair {j}: {a} vs {b}"
            );
        }
    }
}

/// The lab geometry's skewed and upside-down sensor frames go out as dataset 2420 systems that
/// the points' 2411 records name, and come back as they were (17 digits: to 1e-15); a map
/// without modes is refused before running.
#[test]
fn frames_go_out_as_2420_and_what_cannot_be_written_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        root().join("tests/fixtures/uff/lab-plate.uff"),
        dir.path().join("lab-plate.uff"),
    )
    .unwrap();
    let yaml = "name: lab-geo\nstages:\n  lab:\n    kind: frf.import\n    with: {path: lab-plate.uff}\n  export:\n    kind: test.export\n    inputs: {geometry: lab.geometry}\n";
    let file = write(dir.path(), "geo.yaml", yaml);
    let (_, report, cache) = common::run(&file, &dir.path().join("cache"), &[]);
    let uff: UniversalFile = UniversalFileKind::from_artefact(&output(
        &report,
        &cache,
        "export",
        "file",
        ArtefactKind::UniversalFile,
    ))
    .unwrap();
    let lab = test_geometry_from_artefact(&output(
        &report,
        &cache,
        "lab",
        "geometry",
        ArtefactKind::TestGeometry,
    ))
    .unwrap();
    let framed = lab.points.iter().filter(|p| p.axes != global()).count();
    assert!(framed >= 2, "the fixture has a skewed and a -Z sensor");
    assert_eq!(uff.datasets[1].0, 2420);
    assert_eq!(uff.datasets[2], (2411, lab.points.len()));
    let back = geometry_of(&parse_uff(&uff.bytes, "geo.uff").unwrap());
    assert_eq!(back.points.len(), lab.points.len());
    for (a, b) in back.points.iter().zip(&lab.points) {
        assert_eq!(a.node, b.node);
        for k in 0..3 {
            assert!((a.xyz[k] - b.xyz[k]).abs() <= 1e-15 * b.xyz[k].abs().max(1.0));
            for j in 0..3 {
                assert!(
                    (a.axes[k][j] - b.axes[k][j]).abs() <= 1e-15,
                    "node {}: axes {:?} vs {:?}",
                    a.node,
                    a.axes,
                    b.axes
                );
            }
        }
    }

    let yaml = format!(
        "name: lab-bad\nstages:\n{PLATE}  lab:\n    kind: frf.import\n    with: {{path: lab-plate.uff}}\n  pair:\n    kind: test.pair\n    inputs: {{mesh: plate, geometry: lab.geometry}}\n    with: {{tolerance_m: 0.002, alignment: {FIT}}}\n  export:\n    kind: test.export\n    inputs: {{frf: lab.frf, map: pair.map}}\n"
    );
    let file = write(dir.path(), "bad.yaml", &yaml);
    let mut src = femu::pipeline::read_pipeline(&file).unwrap();
    src.apply_overrides(&[]).unwrap();
    let Err(e) = femu::pipeline::plan(&src, &femu::stages::registry()) else {
        panic!("a map without modes was accepted");
    };
    let e = e.to_string();
    assert!(
        e.contains("export") && e.contains("connect `modes` too"),
        "{e}"
    );
}
