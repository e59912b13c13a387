//! From the lab to the model (issue 25): `frf.import` gives the test geometry of a lab-style
//! Universal File, and `test.pair` aligns it to a generated plate, pairs every point and maps
//! every measured DOF to weighted model DOFs.
//!
//! The fixture `tests/fixtures/uff/lab-plate.uff` is a 0.4 × 0.3 m plate measured in mm
//! (dataset 164) in a test frame turned 90° about z and shifted: `x_test = (y + 0.2, 0.5 − x,
//! z − 0.1)` m. Its points: corners 101, 105, 120, 116 (model grids 1, 5, 20, 16); 9001 between
//! grids (element 6 at ξ = 0.5, η = −0.5) measured along −Z (direction −3 in dataset 58);
//! 9002 0.3 mm from grid 14 in an upside-down displacement system (its +Z is the model's −z);
//! 9003 between grids (element 3, centre) on a skewed mount whose x axis is the model's
//! (0.6, 0, 0.8); 9004 1 mm above element 12 at ξ = −0.8, η = −0.6. Accelerance in g/N,
//! excitation at 120:+Z.

mod common;

use common::root;
use femu::artefact::ArtefactKind;
use femu::artefact::kinds::test_geometry::test_geometry_from_artefact;
use femu::artefact::kinds::test_map::test_map_from_artefact;
use femu::cache::Cache;
use femu::pairing::{PairedBy, TestMap};
use std::path::Path;

const PLATE: &str = "  plate:\n    kind: mesh.generate\n    with: {geometry: flat_plate, a_m: 0.4, b_m: 0.3, nx: 4, ny: 3, thickness_m: 0.002}\n";
const LAB: &str = "  lab:\n    kind: frf.import\n    with: {path: lab-plate.uff}\n";
const FIT: &str =
    "{fit: [{test: 101, fe: 1}, {test: 105, fe: 5}, {test: 120, fe: 20}, {test: 116, fe: 16}]}";

/// Writes the pipeline beside a copy of the fixture and runs it; the error text on failure.
fn try_run(dir: &Path, pair_with: &str) -> Result<(femu::pipeline::RunReport, Cache), String> {
    std::fs::copy(
        root().join("tests/fixtures/uff/lab-plate.uff"),
        dir.join("lab-plate.uff"),
    )
    .unwrap();
    let yaml = format!(
        "name: lab-pair\nstages:\n{PLATE}{LAB}  pair:\n    kind: test.pair\n    inputs: {{mesh: plate, geometry: lab.geometry, frf: lab.frf}}\n    with: {pair_with}\n"
    );
    let file = dir.join("p.yaml");
    std::fs::write(&file, yaml).unwrap();
    let mut src = femu::pipeline::read_pipeline(&file).map_err(|e| e.to_string())?;
    src.apply_overrides(&[]).map_err(|e| e.to_string())?;
    let plan = femu::pipeline::plan(&src, &femu::stages::registry()).map_err(|e| e.to_string())?;
    let cache = Cache::open(&dir.join("cache")).unwrap();
    let opts = femu::pipeline::RunOptions {
        progress: femu::pipeline::ProgressMode::Quiet,
        ..Default::default()
    };
    let report = femu::pipeline::execute(&plan, &cache, &opts).map_err(|e| {
        let mut s = e.to_string();
        let mut src = std::error::Error::source(&e);
        while let Some(x) = src {
            s.push_str(&format!(": {x}"));
            src = x.source();
        }
        s
    })?;
    Ok((report, cache))
}

fn output(
    report: &femu::pipeline::RunReport,
    cache: &Cache,
    stage: &str,
    port: &str,
    kind: ArtefactKind,
) -> femu::artefact::Artefact {
    let key = &report.stages.iter().find(|s| s.name == stage).unwrap().key;
    cache.read(key, port, kind).unwrap()
}

fn map_of(pair_with: &str) -> (TestMap, femu::pipeline::RunReport, Cache, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let (report, cache) = try_run(dir.path(), pair_with).unwrap_or_else(|e| panic!("{e}"));
    let a = output(&report, &cache, "pair", "map", ArtefactKind::TestMap);
    (test_map_from_artefact(&a).unwrap(), report, cache, dir)
}

fn weights(map: &TestMap, test_dof: &str) -> Vec<(String, f64)> {
    map.rows
        .iter()
        .filter(|r| r.test_dof.to_string() == test_dof)
        .map(|r| (r.fe_dof.to_string(), r.weight))
        .collect()
}

fn assert_weights(map: &TestMap, test_dof: &str, want: &[(&str, f64)], tol: f64) {
    let got = weights(map, test_dof);
    assert_eq!(got.len(), want.len(), "{test_dof}: {got:?}");
    for ((g, gw), (w, ww)) in got.iter().zip(want) {
        assert_eq!(g, w, "{test_dof}: {got:?}");
        assert!((gw - ww).abs() < tol, "{test_dof}: {got:?} vs {want:?}");
    }
}

/// The geometry leaves `frf.import` in metres and global test coordinates, with the skewed and
/// upside-down displacement frames; the fit recovers the frame change and every DOF maps as
/// worked out by hand.
#[test]
fn lab_file_pairs_to_the_plate_with_fit_interpolation_and_directions() {
    let (map, report, cache, _dir) = map_of(&format!("{{tolerance_m: 0.002, alignment: {FIT}}}"));
    let g = test_geometry_from_artefact(&output(
        &report,
        &cache,
        "lab",
        "geometry",
        ArtefactKind::TestGeometry,
    ))
    .unwrap();
    assert_eq!(g.points.len(), 8);
    let p9003 = g.points.iter().find(|p| p.node == 9003).unwrap();
    assert!((p9003.xyz[0] - 0.25).abs() < 1e-15 && (p9003.xyz[2] + 0.1).abs() < 1e-15);
    assert_eq!(p9003.axes[0], [0.0, -0.6, 0.8]);
    assert_eq!(g.systems[5], [0, 4]);
    assert_eq!(g.trace_lines, vec![(1, vec![101, 105, 120, 116, 101])]);

    // The fit: x_model = R x_test + t with R a quarter turn about z, t = (0.5, -0.2, 0.1).
    let fit = map.fit.as_ref().unwrap();
    assert!(fit.rms < 1e-12, "{fit:?}");
    let want_r = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    for (got, want) in map.transform.rotation.iter().zip(&want_r) {
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-12, "{:?}", map.transform.rotation);
        }
    }
    let t = map.transform.translation;
    assert!((t[0] - 0.5).abs() < 1e-12 && (t[1] + 0.2).abs() < 1e-12 && (t[2] - 0.1).abs() < 1e-12);

    let tol = 1e-9;
    // Corners on their grids; the excitation too.
    assert_weights(&map, "101:uz", &[("1:uz", 1.0)], tol);
    assert_weights(&map, "120:uz", &[("20:uz", 1.0)], tol);
    // −Z sensor: the reader referred its data to +Z, so the weights are the shape functions.
    assert_weights(
        &map,
        "9001:uz",
        &[
            ("7:uz", 0.1875),
            ("8:uz", 0.5625),
            ("13:uz", 0.1875),
            ("12:uz", 0.0625),
        ],
        tol,
    );
    // Upside-down mount 0.3 mm from grid 14: snapped, weight −1.
    assert_weights(&map, "9002:uz", &[("14:uz", -1.0)], tol);
    let p = map.points.iter().find(|p| p.test_node == 9002).unwrap();
    assert_eq!(p.paired_by, PairedBy::Node(14));
    assert!((p.distance - 3e-4).abs() < 1e-9);
    // Skewed mount at the centre of element 3 (grids 3, 4, 9, 8): 0.25 × (0.6 ux, 0.8 uz).
    assert_weights(
        &map,
        "9003:ux",
        &[
            ("3:ux", 0.15),
            ("3:uz", 0.2),
            ("4:ux", 0.15),
            ("4:uz", 0.2),
            ("9:ux", 0.15),
            ("9:uz", 0.2),
            ("8:ux", 0.15),
            ("8:uz", 0.2),
        ],
        tol,
    );
    // 1 mm above element 12 (grids 14, 15, 20, 19) at ξ = −0.8, η = −0.6.
    let n = |a: f64, b: f64| 0.25 * (1.0 + a * -0.8) * (1.0 + b * -0.6);
    assert_weights(
        &map,
        "9004:uz",
        &[
            ("14:uz", n(-1.0, -1.0)),
            ("15:uz", n(1.0, -1.0)),
            ("20:uz", n(1.0, 1.0)),
            ("19:uz", n(-1.0, 1.0)),
        ],
        tol,
    );
    let p = map.points.iter().find(|p| p.test_node == 9004).unwrap();
    assert!(matches!(p.paired_by, PairedBy::Element { id: 12, .. }));
    assert!((p.distance - 0.001).abs() < 1e-9 && p.within_tolerance);

    let plot = output(&report, &cache, "pair", "plot", ArtefactKind::Plot);
    assert!(plot.blobs.contains_key("pairing.png") && plot.blobs.contains_key("pairing.svg"));
}

/// The same frame change stated as a transform gives the same map; the figure is the same.
#[test]
fn a_stated_transform_gives_the_fitted_map() {
    let (fitted, ..) = map_of(&format!("{{tolerance_m: 0.002, alignment: {FIT}}}"));
    let (stated, ..) = map_of(
        "{tolerance_m: 0.002, alignment: {transform: {rotation: {euler_xyz_deg: [0, 0, 90]}, translation_m: [0.5, -0.2, 0.1]}}}",
    );
    assert_eq!(fitted.rows.len(), stated.rows.len());
    for (a, b) in fitted.rows.iter().zip(&stated.rows) {
        assert_eq!((a.test_dof, a.fe_dof), (b.test_dof, b.fe_dof));
        assert!((a.weight - b.weight).abs() < 1e-9);
    }
    assert!(stated.fit.is_none());
}

/// Points beyond the tolerance are refused by name (or paired with a warning); without
/// alignment nothing is near the plate; a correspondence naming an unknown node is named.
#[test]
fn bad_pairings_name_the_test_node_and_what_would_be_valid() {
    let dir = tempfile::tempdir().unwrap();
    let e = try_run(
        dir.path(),
        &format!("{{tolerance_m: 0.0005, snap_m: 0.0004, alignment: {FIT}}}"),
    )
    .unwrap_err();
    assert!(
        e.contains("test node 9004") && e.contains("tolerance_m") && !e.contains("test node 9001"),
        "{e}"
    );
    let (warned, ..) = map_of(&format!(
        "{{tolerance_m: 0.0005, snap_m: 0.0004, beyond_tolerance: warn, alignment: {FIT}}}"
    ));
    assert_eq!(warned.warnings.len(), 1);
    assert!(warned.warnings[0].contains("test node 9004"));
    let dir = tempfile::tempdir().unwrap();
    let e = try_run(dir.path(), "{tolerance_m: 0.002}").unwrap_err();
    assert!(
        e.contains("test point(s) lie beyond") && e.contains("test node 101"),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let e = try_run(
        dir.path(),
        "{tolerance_m: 0.002, alignment: {fit: [{test: 101, fe: 1}, {test: 105, fe: 5}, {test: 999, fe: 20}]}}",
    )
    .unwrap_err();
    assert!(
        e.contains("test node 999") && e.contains("101, 105, 120"),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let e = try_run(
        dir.path(),
        "{tolerance_m: 0.002, alignment: {fit: [{test: 101, fe: 1}, {test: 105, fe: 3}, {test: 120, fe: 5}]}}",
    )
    .unwrap_err();
    assert!(
        e.contains("one line") && e.contains("test 101 → FE 1"),
        "{e}"
    );
}

/// `frf.synthesise` with the measured FRFs as template predicts exactly the measured pairs on
/// the measured lines in the measured quantity; through the map, each is the weighted sum of
/// model FRFs (14.7), here checked against FRFs synthesised at the model DOFs directly.
#[test]
fn predictions_follow_the_test_through_the_map() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        root().join("tests/fixtures/uff/lab-plate.uff"),
        dir.path().join("lab-plate.uff"),
    )
    .unwrap();
    let yaml = format!(
        "name: lab-predict\nstages:\n{PLATE}{LAB}  pair:\n    kind: test.pair\n    inputs: {{mesh: plate, geometry: lab.geometry, frf: lab.frf}}\n    with: {{tolerance_m: 0.002, alignment: {FIT}}}\n  matrices:\n    kind: assemble\n    inputs: {{mesh: plate}}\n  predicted:\n    kind: frf.synthesise\n    inputs: {{model: matrices, template: lab.frf, map: pair.map}}\n    with: {{method: direct, damping: {{structural: 0.01}}}}\n  direct:\n    kind: frf.synthesise\n    inputs: {{model: matrices}}\n    with: {{method: direct, damping: {{structural: 0.01}}, quantity: accelerance, responses: [\"1:uz\", \"14:uz\", \"3:ux\", \"3:uz\", \"4:ux\", \"4:uz\", \"9:ux\", \"9:uz\", \"8:ux\", \"8:uz\"], excitations: [\"20:uz\"], band_hz: [10, 80], step_hz: 10}}\n"
    );
    let file = dir.path().join("p.yaml");
    std::fs::write(&file, yaml).unwrap();
    let (_, report, cache) = common::run(&file, &dir.path().join("cache"), &[]);
    let set = |stage: &str, port: &str| {
        femu::artefact::kinds::frf_from_artefact(&output(
            &report,
            &cache,
            stage,
            port,
            ArtefactKind::Frf,
        ))
        .unwrap()
    };
    let (measured, predicted, direct) = (
        set("lab", "frf"),
        set("predicted", "frf"),
        set("direct", "frf"),
    );
    assert_eq!(predicted.pairs, measured.pairs);
    assert_eq!(predicted.freqs_hz, measured.freqs_hz);
    assert_eq!(predicted.quantity, measured.quantity);
    assert_eq!(direct.freqs_hz, measured.freqs_hz);
    let h = |r: &str| {
        let pair = femu::frf::FrfPair {
            response: r.parse().unwrap(),
            excitation: "20:uz".parse().unwrap(),
        };
        direct.pair_index(&pair).unwrap()
    };
    let col = |r: &str| {
        let pair = femu::frf::FrfPair {
            response: r.parse().unwrap(),
            excitation: "120:uz".parse().unwrap(),
        };
        predicted.pair_index(&pair).unwrap()
    };
    for l in 0..measured.freqs_hz.len() {
        let near = |a: faer::c64, b: faer::c64| (a - b).norm() <= 1e-9 * (1.0 + b.norm());
        assert!(near(
            predicted.values[(l, col("101:uz"))],
            direct.values[(l, h("1:uz"))]
        ));
        assert!(near(
            predicted.values[(l, col("9002:uz"))],
            -direct.values[(l, h("14:uz"))]
        ));
        let skew = ["3", "4", "9", "8"]
            .iter()
            .fold(faer::c64::new(0.0, 0.0), |acc, n| {
                acc + direct.values[(l, h(&format!("{n}:ux")))] * 0.15
                    + direct.values[(l, h(&format!("{n}:uz")))] * 0.2
            });
        assert!(
            near(predicted.values[(l, col("9003:ux"))], skew),
            "line {l}"
        );
    }
    // Without the map the measured DOFs are taken as the model's own, and 9001 is not one.
    let e = {
        let yaml = std::fs::read_to_string(&file).unwrap();
        std::fs::write(
            &file,
            format!("{yaml}  as_named:\n    kind: frf.synthesise\n    inputs: {{model: matrices, template: lab.frf}}\n    with: {{method: direct, damping: {{structural: 0.01}}}}\n"),
        )
        .unwrap();
        let mut src = femu::pipeline::read_pipeline(&file).unwrap();
        src.apply_overrides(&[]).unwrap();
        let plan = femu::pipeline::plan(&src, &femu::stages::registry()).unwrap();
        let opts = femu::pipeline::RunOptions {
            progress: femu::pipeline::ProgressMode::Quiet,
            ..Default::default()
        };
        match femu::pipeline::execute(&plan, &cache, &opts) {
            Ok(_) => String::new(),
            Err(e) => format!(
                "{e} {:?}",
                std::error::Error::source(&e).map(|s| s.to_string())
            ),
        }
    };
    assert!(e.contains("9001"), "{e}");
}

/// With `template` connected the lines and pairs are the template's: giving them as well is
/// refused before anything runs, and a map needs a template.
#[test]
fn template_and_map_wiring_is_checked_before_running() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        root().join("tests/fixtures/uff/lab-plate.uff"),
        dir.path().join("lab-plate.uff"),
    )
    .unwrap();
    let check = |predicted: &str| -> String {
        let yaml = format!(
            "name: lab-check\nstages:\n{PLATE}{LAB}  pair:\n    kind: test.pair\n    inputs: {{mesh: plate, geometry: lab.geometry}}\n    with: {{tolerance_m: 0.002, alignment: {FIT}}}\n  matrices:\n    kind: assemble\n    inputs: {{mesh: plate}}\n{predicted}"
        );
        let file = dir.path().join("p.yaml");
        std::fs::write(&file, yaml).unwrap();
        let mut src = femu::pipeline::read_pipeline(&file).unwrap();
        src.apply_overrides(&[]).unwrap();
        match femu::pipeline::plan(&src, &femu::stages::registry()) {
            Ok(_) => String::new(),
            Err(e) => e.to_string(),
        }
    };
    let e = check(
        "  predicted:\n    kind: frf.synthesise\n    inputs: {model: matrices, template: lab.frf}\n    with: {method: direct, responses: [\"1:uz\"], band_hz: [0, 10], step_hz: 1}\n",
    );
    assert!(
        e.contains("responses") && e.contains("band_hz") && e.contains("template"),
        "{e}"
    );
    let e = check(
        "  predicted:\n    kind: frf.synthesise\n    inputs: {model: matrices, map: pair.map}\n    with: {method: direct, responses: [\"1:uz\"], excitations: [\"1:uz\"], band_hz: [0, 10], step_hz: 1}\n",
    );
    assert!(e.contains("needs the measured FRFs on `template`"), "{e}");
    assert!(
        check(
            "  predicted:\n    kind: frf.synthesise\n    inputs: {model: matrices, template: lab.frf, map: pair.map}\n    with: {method: direct}\n"
        )
        .is_empty()
    );
}
