//! The generic test over every kind: each registered kind's examples are written, checked
//! against the kind's layout exactly, stored and read back in every codec, and read into a value
//! that writes the same artefact again (the comparison is by digest, so NaN entries compare).

use super::*;
use crate::artefact::Format;
use crate::artefact::codec::{read_dir, write_dir};
use crate::core::sparse::sparse_to_dense;
use crate::correlation::{FrfCorrelation, ModeCorrelation, ModePair};
use crate::eigen::{ModeSelection, Modes};
use crate::fe::element::MassKind;
use crate::fe::lumped::assemble_lumped;
use crate::frf::{FrfSet, Quantity};
use crate::localisation::{Candidate, EigenMap};
use crate::model::generate::{BentPlate, ThreeBeam, bent_plate, three_beam};
use crate::model::{Element, LumpedModel, Model, ParameterKind};
use crate::reduction::force_coupling::MasterSelection;
use crate::reduction::{Method, Partition, ReducedModel, reduce, reduce_with_interface};
use crate::updating::{Diagnostics, IterationRecord, StopReason, UpdateHistory, UpdatingParameter};
use eigenvalue_sensitivity::EigenSensitivityRecord;
use faer::{Mat, c64};
use leverage::{LeverageRecord, LeverageRow, LineRow};
use modal_correlation::{ModalCorrelationContext, ModalCorrelationRecord};
use reduced_model::ReducedModelArtefact;
use std::sync::OnceLock;
use update_result::{IdentifiedDamping, ModalDamping, UpdateResult};

/// Representative values of a kind: every table and optional part its writer can produce.
pub(super) trait Example: Kind {
    fn examples() -> Vec<Self::Value>;
}

/// Write, check the layout, store and read back in every codec, read the value, write again.
pub(super) fn round_trip<K: Example>() {
    let examples = K::examples();
    assert!(!examples.is_empty(), "`{}` has no examples", K::NAME);
    let mut formats = vec![Format::Arrow];
    if cfg!(feature = "hdf5") {
        formats.push(Format::Hdf5);
    }
    for (i, v) in examples.iter().enumerate() {
        let what = format!("`{}` example {i}", K::NAME);
        let a = K::to_artefact(v);
        assert_eq!(a.kind, K::KIND, "{what}");
        check_layout(&a).unwrap_or_else(|e| panic!("{what}: {e}"));
        let again = K::to_artefact(&K::from_artefact(&a).unwrap_or_else(|e| panic!("{what}: {e}")));
        assert_eq!(again.digest(), a.digest(), "{what}: read back in memory");
        for &format in &formats {
            let dir = tempfile::tempdir().unwrap();
            write_dir(&a, dir.path(), format, None).unwrap_or_else(|e| panic!("{what}: {e}"));
            let b = read_dir(dir.path()).unwrap_or_else(|e| panic!("{what} {format:?}: {e}"));
            assert_eq!(b.digest(), a.digest(), "{what} {format:?}: stored");
            check_layout(&b).unwrap_or_else(|e| panic!("{what} {format:?}: {e}"));
            let back = K::from_artefact(&b).unwrap_or_else(|e| panic!("{what} {format:?}: {e}"));
            assert_eq!(
                K::to_artefact(&back).digest(),
                a.digest(),
                "{what} {format:?}: read back from disk"
            );
        }
        // Another tool may write 32-bit integers where femu writes 64-bit ones (pandas and
        // MATLAB often do, for ids and counts): the reader takes them at either width.
        let narrowed = narrow_integers(&a);
        let back = K::from_artefact(&narrowed)
            .unwrap_or_else(|e| panic!("{what} with 32-bit integer columns: {e}"));
        assert_eq!(
            K::to_artefact(&back).digest(),
            a.digest(),
            "{what}: read from 32-bit integer columns"
        );
    }
}

/// `a` with every 64-bit integer column whose values fit narrowed to 32 bits.
fn narrow_integers(a: &Artefact) -> Artefact {
    let mut b = a.clone();
    for (table, _) in b.tables.values_mut() {
        for (_, column) in &mut table.columns {
            if let Column::I64(v) = column
                && let Ok(narrow) = v.iter().map(|&x| i32::try_from(x)).collect()
            {
                *column = Column::I32(narrow);
            }
        }
    }
    b
}

#[test]
fn every_kind_round_trips_and_fits_its_layout() {
    for kind in ArtefactKind::ALL {
        test_kind(kind);
    }
}

/// The warnings a posterior or an update result records are its stage's warnings: `femu run`
/// prints them (for a cached stage too), the run record and the report list them.
#[test]
fn recorded_warnings_are_the_stages_warnings() {
    use crate::run_report::record::meta_warnings;
    let mut shown = 0;
    for r in <posterior::PosteriorKind as Example>::examples() {
        let a = posterior::PosteriorKind::to_artefact(&r);
        assert_eq!(meta_warnings(&a.meta), r.posterior.warnings);
        shown += r.posterior.warnings.len();
    }
    for r in <update_result::UpdateResultKind as Example>::examples() {
        let a = update_result::UpdateResultKind::to_artefact(&r);
        assert_eq!(meta_warnings(&a.meta), r.history.warnings);
        shown += r.history.warnings.len();
    }
    assert_eq!(shown, 2, "one example of each records a warning");
}

/// The registry is the engine's list of kinds: each entry reports its own tag, names are
/// unique and found again, and `schemas/artefacts/` holds exactly one schema per kind.
#[test]
fn the_registry_is_every_kind() {
    let mut names = std::collections::BTreeSet::new();
    for kind in ArtefactKind::ALL {
        assert_eq!(registered_tag(kind), kind);
        assert!(names.insert(kind.name()), "{kind} registered twice");
        assert_eq!(ArtefactKind::from_name(kind.name()), Some(kind));
        let l = kind_layout(kind);
        let mut tables = std::collections::BTreeSet::new();
        assert!(l.tables.iter().all(|t| tables.insert(t.name)), "{kind}");
        let mut keys = std::collections::BTreeSet::new();
        assert!(l.meta.iter().all(|m| keys.insert(m.key)), "{kind}");
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("schemas/artefacts");
    let files: std::collections::BTreeSet<String> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter_map(|e| {
            let n = e.file_name().to_string_lossy().to_string();
            n.strip_suffix(".schema.json").map(str::to_string)
        })
        .collect();
    let names: std::collections::BTreeSet<String> = names.iter().map(|s| s.to_string()).collect();
    assert_eq!(files, names);
}

/// The exact check refuses what the layout does not declare and what it requires but lacks.
#[test]
fn check_layout_is_exact() {
    let ok = FrfKind::to_artefact(&frf_example());
    check_layout(&ok).unwrap();
    let extra_meta = ok.clone().with_meta("unknown", 1.into());
    assert!(check_layout(&extra_meta).is_err());
    let mut extra_col = ok.clone();
    if let Some((t, _)) = extra_col.tables.get_mut("frf") {
        t.columns
            .push(("extra".into(), Column::F64(vec![0.0; t.rows()])));
    }
    let e = check_layout(&extra_col).unwrap_err().to_string();
    assert!(e.contains("`extra` is not in the layout"), "{e}");
    let mut missing = ok.clone();
    missing.meta.remove("quantity");
    assert!(check_layout(&missing).is_err());
    let mut wrong_storage = ok.clone();
    if let Some(t) = wrong_storage.tables.get_mut("frf") {
        t.1 = Storage::Ipc;
    }
    assert!(check_layout(&wrong_storage).is_err());
    let extra_table = ok.with_table("other", Table::new(), Storage::Parquet);
    assert!(check_layout(&extra_table).is_err());
    let modes = ModesKind::to_artefact(&ModesKind::examples()[0]);
    let mut gap = modes.clone();
    if let Some((t, _)) = gap.tables.get_mut("shapes") {
        t.columns.remove(1);
    }
    let e = check_layout(&gap).unwrap_err().to_string();
    assert!(e.contains("phi_2"), "{e}");
}

fn dof(s: &str) -> crate::core::DofId {
    s.parse().unwrap()
}

fn frf_example() -> FrfSet {
    let dofs = [dof("1:ux"), dof("2:uz")];
    FrfSet {
        quantity: Quantity::Mobility,
        freqs_hz: vec![1.0, 2.0, 3.0],
        pairs: FrfSet::all_pairs(&dofs, &dofs[..1]),
        values: Mat::from_fn(3, 2, |k, p| c64::new(k as f64, p as f64 - 0.5)),
    }
}

impl Example for MatricesKind {
    fn examples() -> Vec<crate::fe::SystemMatrices> {
        let sys = assemble_lumped(&LumpedModel::chain(&[1.0, 1.3, 1.0], 10.0)).unwrap();
        let mut damped = sys.clone();
        damped.c = Some(sys.k.clone());
        damped.d = Some(sys.m.clone());
        vec![sys, damped]
    }
}

impl Example for ModesKind {
    fn examples() -> Vec<ModesArtefact> {
        vec![ModesArtefact {
            dofs: vec![dof("1:ux"), dof("1:uz"), dof("2:ry")],
            modes: Modes {
                eigenvalues: vec![0.0, 4.0, 9.5],
                shapes: Mat::from_fn(3, 3, |i, j| (i as f64 + 1.0) * (j as f64 - 0.25)),
                residuals: vec![1e-12, 2e-13, f64::NAN],
                orthogonality_error: 3e-15,
                rigid_body_modes: 1,
            },
        }]
    }
}

impl Example for FrfKind {
    fn examples() -> Vec<FrfSet> {
        vec![frf_example()]
    }
}

impl Example for CorrelationKind {
    fn examples() -> Vec<FrfCorrelation> {
        let set = frf_example();
        vec![FrfCorrelation {
            freqs_hz: set.freqs_hz,
            chi_s: vec![0.9, 0.5, 1.0],
            chi_a: vec![0.8, f64::NAN, 0.7],
            pairs: set.pairs,
            frac: vec![0.95, 0.25],
        }]
    }
}

impl Example for PlotKind {
    fn examples() -> Vec<Plot> {
        vec![Plot {
            name: "frf".into(),
            title: "an FRF".into(),
            png: vec![0x89, b'P', b'N', b'G', 0, 1, 2],
            svg: "<svg xmlns=\"http://www.w3.org/2000/svg\"/>".into(),
        }]
    }
}

impl Example for mesh::MeshKind {
    fn examples() -> Vec<Model> {
        let mut lumped = three_beam(&ThreeBeam::default());
        let node = *lumped.nodes.keys().next().unwrap();
        let id = lumped.elements.keys().max().unwrap() + 1;
        lumped.elements.insert(
            id,
            Element::ScalarSpring {
                dof: dof(&format!("{node}:uz")),
                other: None,
                k: 1e5,
            },
        );
        // Multipoint constraints (table `mpcs`): one with terms, one without.
        let free: Vec<u64> = lumped
            .nodes
            .keys()
            .copied()
            .filter(|n| !lumped.constraints.iter().any(|d| d.node == *n))
            .collect();
        lumped.mpcs = vec![
            crate::model::MultipointConstraint {
                dependent: dof(&format!("{}:ux", free[1])),
                terms: vec![
                    (dof(&format!("{}:ux", free[0])), 1.0),
                    (dof(&format!("{}:rz", free[0])), -0.5),
                ],
                origin: "RBE2 7".into(),
            },
            crate::model::MultipointConstraint {
                dependent: dof(&format!("{}:uy", free[2])),
                terms: vec![],
                origin: "MPC 1".into(),
            },
        ];
        vec![bent_plate(&Default::default()), lumped]
    }
}

fn record(i: usize) -> IterationRecord {
    IterationRecord {
        iteration: i,
        values: vec![1.0 + i as f64, 2.0],
        relative_change: vec![0.1, -0.0],
        active: vec![true, i > 0],
        lines_used: 3,
        mean_chi_s: 0.9,
        mean_chi_a: if i == 0 { f64::NAN } else { 0.9816106067610754 },
        residual_norm: 0.5,
        condition_limit: f64::NAN,
        smoothing: if i == 0 { 0.1 } else { 0.0 },
        smoothed_mean_chi: if i == 0 { 0.95 } else { f64::NAN },
        diagnostics: Diagnostics {
            singular_values: vec![2.0, 0.0],
            condition: f64::INFINITY,
            null_space: vec![vec![0.0, 1.0], vec![1.0, 0.0]],
            weakest_direction: vec![0.0, 1.0],
        },
    }
}

impl Example for update_result::UpdateResultKind {
    fn examples() -> Vec<UpdateResult> {
        let history = UpdateHistory {
            parameters: ["a", "b"]
                .map(|n| UpdatingParameter {
                    name: n.into(),
                    initial: 1.0,
                    lower: 0.1,
                    upper: 10.0,
                })
                .to_vec(),
            iterations: vec![record(0), record(1), record(2)],
            final_values: vec![1.1, 2.0],
            returned_iteration: None,
            stop: StopReason::MaxIterations,
            warnings: Vec::new(),
        };
        let damped = UpdateResult {
            history: UpdateHistory {
                returned_iteration: Some(1),
                stop: StopReason::MaxIterations,
                warnings: vec!["the update ended (MaxIterations) below its best iterate".into()],
                ..history.clone()
            },
            method: "damping".into(),
            damping: Some(ModalDamping {
                model: "viscous".into(),
                modes: vec![IdentifiedDamping {
                    mode: 7,
                    natural_hz: 41.5,
                    initial: 0.01,
                    identified: 0.02,
                    equivalent_loss_factor: 0.04,
                }],
            }),
        };
        vec![
            UpdateResult {
                history,
                method: "pc".into(),
                damping: None,
            },
            damped,
        ]
    }
}

/// The bent plate of two plates, its partition, and its reductions: Craig-Bampton (with and
/// without interface modes, and the memory-lean interface route) and force coupling.
struct Reductions {
    partition: Partition,
    models: Vec<ReducedModel>,
}

fn reductions() -> &'static Reductions {
    static R: OnceLock<Reductions> = OnceLock::new();
    R.get_or_init(|| {
        let mass = MassKind::Consistent;
        let model = bent_plate(&BentPlate {
            with_bar: false,
            ..Default::default()
        });
        let partition =
            Partition::from_sets(&model, &["plate_1".into(), "plate_2".into()], mass).unwrap();
        let modes = ModeSelection::BelowHz(200.0);
        let cb = Method::CraigBampton { modes };
        let fc = Method::ForceCoupling {
            modes,
            masters: MasterSelection::default(),
            second_level: None,
        };
        let plain = reduce(&model, &partition, &cb, mass).unwrap();
        let interface = plain
            .clone()
            .with_interface_modes(ModeSelection::Count(6))
            .unwrap();
        let lean =
            reduce_with_interface(&model, &partition, &cb, mass, Some(ModeSelection::Count(6)))
                .unwrap();
        let force = reduce(&model, &partition, &fc, mass).unwrap();
        Reductions {
            partition,
            models: vec![plain, interface, lean, force],
        }
    })
}

impl Example for partition::PartitionKind {
    fn examples() -> Vec<Partition> {
        vec![reductions().partition.clone()]
    }
}

impl Example for reduced_model::ReducedModelKind {
    fn examples() -> Vec<ReducedModelArtefact> {
        reductions()
            .models
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let derivatives = match i {
                    0 => vec![("t_1".to_string(), r.k.clone(), r.m.clone())],
                    _ => vec![],
                };
                let a = reduced_model::reduced_to_artefact(r, &derivatives);
                reduced_model::ReducedModelKind::from_artefact(&a).unwrap()
            })
            .collect()
    }
}

impl Example for reduced_component::ReducedComponentKind {
    fn examples() -> Vec<crate::reduction::ComponentReduction> {
        let models = &reductions().models;
        let mut out = models[0].components.clone();
        out.extend(models[3].components.iter().cloned());
        for c in &mut out {
            c.info.seconds = 0.0;
        }
        out
    }
}

impl Example for modal_correlation::ModalCorrelationKind {
    fn examples() -> Vec<ModalCorrelationRecord> {
        let pair = |reference, predicted, mac| ModePair {
            reference,
            predicted,
            mac,
            eigenvalue_error: 0.01 * reference as f64,
            frequency_error: 0.005 * reference as f64,
        };
        let c = ModeCorrelation {
            pairs: vec![pair(1, 1, 0.99), pair(2, 3, 0.8)],
            unpaired: vec![3],
            mac: Mat::from_fn(3, 3, |i, j| if i == j { 0.9 } else { 0.1 * (i + j) as f64 }),
            comac: vec![0.9, 0.8],
        };
        let dofs = [dof("1:uz"), dof("2:uz")];
        let at = ModalCorrelationContext {
            reference_hz: &[0.0, 10.0, 20.0, 30.0],
            predicted_hz: &[0.0, 10.5, 19.0, 21.0],
            rigid_body_modes: (1, 1),
            dofs: &dofs,
            band_hz: Some(25.0),
            pairing: ("mac", 0.6),
        };
        vec![
            ModalCorrelationRecord::new(&c, &at),
            ModalCorrelationRecord::new(
                &c,
                &ModalCorrelationContext {
                    band_hz: None,
                    pairing: ("order", 0.0),
                    ..at.clone()
                },
            ),
        ]
    }
}

fn candidate(name: &str, elements: Vec<u64>) -> Candidate {
    Candidate {
        name: name.into(),
        kind: ParameterKind::YoungsModulus,
        set: format!("set_{name}"),
        elements,
        value: 7e10,
    }
}

impl Example for leverage::LeverageKind {
    fn examples() -> Vec<LeverageRecord> {
        let row = |name: &str, leverage: f64, rank| LeverageRow {
            candidate: name.into(),
            kind: "youngs_modulus".into(),
            set: format!("set_{name}"),
            value: 7e10,
            leverage,
            normalised: leverage / 2.0,
            rank,
            change: -0.1,
            residual_fraction: leverage / 4.0,
        };
        let line = |f: f64, used| LineRow {
            freq_hz: f,
            chi_s: 0.9,
            chi_a: 0.7,
            used,
        };
        vec![LeverageRecord {
            band_hz: Some([5.0, 100.0]),
            lines_used: 1,
            residual_norm2: 4.0,
            modes: 12,
            candidates: vec![row("a", 2.0, 1), row("b", 1.0, 2)],
            members: leverage::members_of(&[candidate("a", vec![1, 2]), candidate("b", vec![3])]),
            lines: vec![line(10.0, true), line(20.0, false)],
        }]
    }
}

impl Example for eigenvalue_sensitivity::EigenvalueSensitivityKind {
    fn examples() -> Vec<EigenSensitivityRecord> {
        let map = EigenMap {
            candidates: vec![candidate("a", vec![1, 2]), candidate("b", vec![3])],
            modes: vec![7, 8],
            freqs_hz: vec![12.0, 15.0],
            values: vec![vec![1.0, -3.0], vec![0.5, 2.0]],
            normalised: vec![vec![1.0, -1.0], vec![0.5, 2.0 / 3.0]],
        };
        vec![EigenSensitivityRecord::new(&map)]
    }
}

impl Example for test_geometry::TestGeometryKind {
    fn examples() -> Vec<crate::pairing::TestGeometry> {
        use crate::pairing::{TestGeometry, TestPoint};
        let c = std::f64::consts::FRAC_1_SQRT_2;
        let points = vec![
            TestPoint::global(1, [0.0, 0.0, 0.0]),
            TestPoint {
                node: 12,
                xyz: [0.1, 0.025, -0.003],
                axes: [[c, c, 0.0], [-c, c, 0.0], [0.0, 0.0, 1.0]],
            },
        ];
        vec![
            TestGeometry {
                points: points.clone(),
                systems: vec![[0, 0], [3, 7]],
                trace_lines: vec![(1, vec![1, 12, 0, 12]), (4, vec![12, 1])],
            },
            TestGeometry {
                points,
                systems: vec![[0, 0], [0, 0]],
                trace_lines: vec![],
            },
            TestGeometry::default(),
        ]
    }
}

impl Example for test_map::TestMapKind {
    fn examples() -> Vec<crate::pairing::TestMap> {
        use crate::pairing::*;
        let t = RigidTransform::new(
            &Rotation::AxisAngle {
                axis: [0.0, 0.0, 1.0],
                angle_deg: 30.0,
            },
            [0.1, 0.0, -0.2],
        )
        .unwrap();
        let points = vec![
            PointPairing {
                test_node: 3,
                xyz: [0.1, 0.2, 0.0],
                paired_by: PairedBy::Node(14),
                nodes: vec![(14, 1.0)],
                distance: 1e-4,
                nearest_node: (14, 1e-4),
                within_tolerance: true,
            },
            PointPairing {
                test_node: 9001,
                xyz: [0.175, 0.125, 0.002],
                paired_by: PairedBy::Element {
                    id: 6,
                    shape: Shape::Quad4,
                    natural: [0.5, -0.5, 0.0],
                },
                nodes: vec![(7, 0.1875), (8, 0.5625), (13, 0.1875), (12, 0.0625)],
                distance: 0.002,
                nearest_node: (8, 0.0354),
                within_tolerance: false,
            },
        ];
        let rows = vec![
            MapRow {
                test_dof: dof("3:uz"),
                fe_dof: dof("14:uz"),
                weight: -1.0,
            },
            MapRow {
                test_dof: dof("9001:ux"),
                fe_dof: dof("7:ux"),
                weight: 0.1875 * 0.6,
            },
            MapRow {
                test_dof: dof("9001:ux"),
                fe_dof: dof("7:uy"),
                weight: 0.1875 * 0.8,
            },
        ];
        vec![
            TestMap {
                transform: t,
                fit: Some(FitReport {
                    transform: t,
                    residuals: vec![(3, 14, 1e-4), (5, 1, 2e-4), (7, 2, 0.0)],
                    rms: 1.29e-4,
                }),
                method: "auto".into(),
                tolerance: 0.005,
                points: points.clone(),
                rows: rows.clone(),
                warnings: vec!["test node 9001 beyond".into()],
            },
            TestMap {
                transform: RigidTransform::identity(),
                fit: None,
                method: "nearest".into(),
                tolerance: 0.01,
                points,
                rows,
                warnings: vec![],
            },
        ]
    }
}

impl Example for universal_file::UniversalFileKind {
    fn examples() -> Vec<universal_file::UniversalFile> {
        vec![universal_file::UniversalFile {
            name: "plate.uff".into(),
            bytes: b"    -1\n  2411\n    -1\n".to_vec(),
            datasets: vec![(2411, 1), (58, 0)],
            source: "frf.synthesise abc".into(),
        }]
    }
}

impl Example for nastran_deck::NastranDeckKind {
    fn examples() -> Vec<nastran_deck::NastranDeck> {
        vec![nastran_deck::NastranDeck {
            files: vec![
                (
                    "wing.bdf".into(),
                    b"BEGIN BULK\r\nINCLUDE 'props.bdf'\r\nENDDATA\r\n".to_vec(),
                ),
                (
                    "props.bdf".into(),
                    b"PSHELL*  1               1               .002\n".to_vec(),
                ),
            ],
            changes: vec![crate::model::export::deck_update::DeckChange {
                file: "in/props.bdf".into(),
                line: 1,
                card: "PSHELL 1".into(),
                field: "T".into(),
                old: ".0025".into(),
                new: ".002".into(),
            }],
            source: "update_result 0123".into(),
        }]
    }
}

/// Beyond the digest: a reduced model reads back with its method, coordinates, `K`, interface
/// modes, couplings (positional ones stay positional, as the lean interface route makes them)
/// and transformations; a component with everything but its timing. (Moved from the reduction
/// tests, which must not import the artefact layer.)
#[test]
fn reduced_models_read_back_their_structure() {
    for r in &reductions().models {
        let back =
            reduced_model::reduced_from_artefact(&reduced_model::reduced_to_artefact(r, &[]))
                .unwrap();
        let name = r.method.name();
        assert_eq!(back.method, r.method, "{name}");
        assert_eq!(back.coords, r.coords, "{name}");
        assert_eq!(back.k, r.k, "{name}");
        assert_eq!(back.interface, r.interface, "{name}");
        assert_eq!(back.couplings, r.couplings, "{name}");
        for k in 0..r.components.len() {
            assert_eq!(back.transformation(k), r.transformation(k), "{name} {k}");
            let c = reduced_component::ReducedComponentKind::from_artefact(
                &reduced_component::component_to_artefact(&r.components[k]),
            )
            .unwrap();
            let mut want = r.components[k].clone();
            want.info.seconds = 0.0;
            assert_eq!(c, want, "{name} component {k}");
        }
    }
    let p = &reductions().partition;
    assert_eq!(
        partition::partition_from_artefact(&partition::partition_to_artefact(p)).unwrap(),
        *p
    );
}

/// Beam offsets and pins go into the mesh artefact's `beam_ends` meta and back; a mesh whose
/// beams have none writes no such key (so plain meshes keep their bytes).
#[test]
fn beam_ends_round_trip_through_the_mesh_artefact() {
    use crate::model::import::nastran::parse_bulk;
    let deck = "MAT1,1,2.1+11,,.3,7850.\nPBAR,7,1,1.-3,3.-7,3.-7,1.-7\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,2.,0.,0.\n\
                CBAR,1,7,1,2,0.,1.,0.\n,5,46,.1,.2,.3,.4,.5,.6\nCBAR,2,7,2,3,0.,1.,0.\n";
    let m = parse_bulk(deck, "ends.bdf").unwrap().model;
    let a = mesh::mesh_to_artefact(&m);
    assert!(a.meta.contains_key("beam_ends"));
    assert_eq!(mesh::mesh_from_artefact(&a).unwrap().elements, m.elements);
    let plain = parse_bulk(&deck.replace(",5,46,.1,.2,.3,.4,.5,.6\n", ""), "plain.bdf")
        .unwrap()
        .model;
    assert!(
        !mesh::mesh_to_artefact(&plain)
            .meta
            .contains_key("beam_ends")
    );
}

/// The mesh artefact's node and element rows read in any order (femu writes them ascending; the
/// tables are built at once from the sorted rows), and a node or element defined twice is an
/// error naming both rows, not the later row silently replacing the earlier.
#[test]
fn mesh_rows_read_in_any_order_and_each_id_once() {
    use crate::model::import::nastran::parse_bulk;
    let deck = "MAT1,1,2.1+11,,.3,7850.\nPBAR,7,1,1.-3,3.-7,3.-7,1.-7\nGRID,1,,0.,0.,0.\n\
                GRID,2,,1.,0.,0.\nGRID,3,,2.,0.,0.\nCBAR,1,7,1,2,0.,1.,0.\nCBAR,2,7,2,3,0.,1.,0.\n";
    let m = parse_bulk(deck, "order.bdf").unwrap().model;
    let a = mesh::mesh_to_artefact(&m);
    // Every column of table `name` with its rows taken in the order `rows`.
    let reorder = |a: &Artefact, name: &str, rows: &[usize]| {
        let mut a = a.clone();
        let (t, _) = a.tables.get_mut(name).unwrap();
        for (_, c) in &mut t.columns {
            *c = match c {
                Column::F64(v) => Column::F64(rows.iter().map(|&r| v[r]).collect()),
                Column::I64(v) => Column::I64(rows.iter().map(|&r| v[r]).collect()),
                Column::I32(v) => Column::I32(rows.iter().map(|&r| v[r]).collect()),
                Column::Str(v) => Column::Str(rows.iter().map(|&r| v[r].clone()).collect()),
            };
        }
        a
    };
    let reversed = reorder(&reorder(&a, "nodes", &[2, 1, 0]), "elements", &[1, 0]);
    assert_eq!(mesh::mesh_from_artefact(&reversed).unwrap(), m);
    let e = mesh::mesh_from_artefact(&reorder(&a, "nodes", &[0, 1, 2, 1]))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("nodes rows 1 and 3: node 2 is defined twice"),
        "{e}"
    );
    let e = mesh::mesh_from_artefact(&reorder(&a, "elements", &[1, 0, 1]))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("elements rows 0 and 2: element 2 is defined twice"),
        "{e}"
    );
}

/// Matrices are written as lower triangles (half the entries of the full tables, plus the
/// diagonal) and read back as the same symmetric matrices, bit for bit; a full table without
/// the meta still reads (and is checked for symmetry); a lower-marked table with an entry above
/// the diagonal, or an unknown `triangle`, is an error naming it.
#[test]
fn matrices_are_stored_as_lower_triangles_and_read_back_whole() {
    let sys = assemble_lumped(&LumpedModel::chain(&[1.0, 1.3, 1.0, 0.7], 10.0)).unwrap();
    let a = matrices_to_artefact(&sys);
    assert_eq!(a.meta["triangle"], "lower");
    let k = &a.tables["K"].0;
    assert!(
        matches!(k.column("row"), Some(Column::I32(_))),
        "32-bit indices"
    );
    let (rows, cols) = (
        k.indices("K", "row").unwrap(),
        k.indices("K", "col").unwrap(),
    );
    let (rows, cols) = (rows.to_i64(), cols.to_i64());
    assert!(rows.iter().zip(cols.iter()).all(|(r, c)| r >= c));
    let full = sys.k.compute_nnz();
    assert_eq!(
        rows.len(),
        (full + sys.n()) / 2,
        "off-diagonal pairs once, diagonal once"
    );
    let back = matrices_from_artefact(&a).unwrap();
    assert_eq!(sparse_to_dense(&back.k), sparse_to_dense(&sys.k));
    assert_eq!(sparse_to_dense(&back.m), sparse_to_dense(&sys.m));
    assert_eq!(back.k.compute_nnz(), full);
    // A full table without `triangle` (written by another tool) reads whole.
    let mut whole = a.clone();
    whole.meta.remove("triangle");
    for name in ["K", "M"] {
        let m = if name == "K" { &sys.k } else { &sys.m };
        whole = whole.with_table(name, triplet_table(m), Storage::Ipc);
    }
    let read = matrices_from_artefact(&whole).unwrap();
    assert_eq!(sparse_to_dense(&read.k), sparse_to_dense(&sys.k));
    // The same full table under `triangle: lower` is refused: it has entries above the diagonal.
    let mut lying = whole.clone();
    lying.meta.insert("triangle".into(), "lower".into());
    let e = matrices_from_artefact(&lying).unwrap_err().to_string();
    assert!(e.contains("lies above the diagonal"), "{e}");
    let mut odd = a.clone();
    odd.meta.insert("triangle".into(), "upper".into());
    let e = matrices_from_artefact(&odd).unwrap_err().to_string();
    assert!(e.contains("valid: \"lower\""), "{e}");
}

/// A matrix of many column blocks (the table is filled block by block in parallel) gives the
/// lower triangle in column-major order, entry for entry, and reads back whole.
#[test]
fn a_large_matrix_table_holds_its_lower_triangle_in_column_order() {
    // A banded symmetric matrix, band 3, over 10,001 columns (three blocks of 4,096 and a rest).
    let n: usize = 10_001;
    let mut trip = Vec::new();
    for j in 0..n {
        for i in j.saturating_sub(3)..(j + 4).min(n) {
            let (a, b) = (i.max(j), i.min(j));
            trip.push((i, j, (1 + a * 7 + b) as f64 / 8.0));
        }
    }
    let m = sparse_from_triplets("K", n, &trip).unwrap();
    let t = lower_triplet_table(&m);
    let want: Vec<(i64, i64, f64)> = trip
        .iter()
        .filter(|(i, j, _)| i >= j)
        .map(|&(i, j, v)| (i as i64, j as i64, v))
        .collect();
    let (rows, cols) = (
        t.indices("K", "row").unwrap(),
        t.indices("K", "col").unwrap(),
    );
    let (rows, cols) = (rows.to_i64(), cols.to_i64());
    let values = t.f64s("K", "value").unwrap();
    let got: Vec<(i64, i64, f64)> = rows
        .iter()
        .zip(cols.iter())
        .zip(values)
        .map(|((&i, &j), &v)| (i, j, v))
        .collect();
    assert_eq!(got, want);
    let sys = crate::fe::SystemMatrices {
        k: m.clone(),
        m: m.clone(),
        c: None,
        d: None,
        dofs: (0..n)
            .map(|i| crate::core::DofId::new(i as u64 / 6 + 1, crate::core::Component::ALL[i % 6]))
            .collect(),
    };
    let a = matrices_to_artefact(&sys);
    let back = matrices_from_artefact(&a).unwrap();
    assert_eq!(back.k.col_ptr(), m.col_ptr());
    assert_eq!(back.k.row_idx(), m.row_idx());
    assert_eq!(back.k.val(), m.val());
    // The same table with 64-bit indices (schema version 2, or another writer's) takes the
    // direct mirror too, and gives the same bits.
    let wide = a.clone().with_table(
        "K",
        Table::new()
            .with("row", Column::I64(rows.to_vec()))
            .with("col", Column::I64(cols.to_vec()))
            .with("value", Column::F64(values.to_vec())),
        Storage::Ipc,
    );
    let back = matrices_from_artefact(&wide).unwrap();
    assert_eq!(back.k.row_idx(), m.row_idx());
    assert_eq!(back.k.val(), m.val());
    // The same lower triangle in reverse order (another writer's) reads as the same matrix,
    // through the general path instead of the direct mirror.
    let mut reversed = a.clone();
    let table = Table::new()
        .with("row", Column::I64(rows.iter().rev().copied().collect()))
        .with("col", Column::I64(cols.iter().rev().copied().collect()))
        .with("value", Column::F64(values.iter().rev().copied().collect()));
    reversed = reversed.with_table("K", table, Storage::Ipc);
    let back = matrices_from_artefact(&reversed).unwrap();
    assert_eq!(back.k.row_idx(), m.row_idx());
    assert_eq!(back.k.val(), m.val());
}

/// The `modes` stage's pencil read straight from the lower tables equals the pencil of the
/// matrices read whole, in its dense copies and its products (bit for bit); tables in another
/// writer's order and full tables (no `triangle`) give the same through the general path; a
/// value that is not finite is named by its DOFs; a lying `triangle` is refused as before.
#[test]
fn the_pencil_reads_straight_from_the_lower_tables() {
    use crate::artefact::kinds::pencil_from_matrices;
    use crate::sparse::SymmetricPencil;
    let sys = assemble_lumped(&LumpedModel::chain(&[1.0, 1.3, 1.0, 0.7], 10.0)).unwrap();
    let a = matrices_to_artefact(&sys);
    let (pencil, dofs) = pencil_from_matrices(&a).unwrap();
    assert_eq!(dofs, sys.dofs);
    assert_eq!(pencil.k_dense(), sparse_to_dense(&sys.k));
    assert_eq!(pencil.m_dense(), sparse_to_dense(&sys.m));
    let n = sys.n();
    let x = faer::Mat::from_fn(n, 3, |i, c| 1.0 + (i * 3 + c) as f64 / 7.0);
    let products = |p: &crate::sparse::LowerPencil| {
        let (mut kx, mut mx) = (faer::Mat::zeros(n, 3), faer::Mat::zeros(n, 3));
        p.products(x.as_ref(), kx.as_mut(), mx.as_mut(), faer::Par::Seq);
        (kx, mx)
    };
    let want = products(&pencil);
    // Reversed rows (another writer's order) and full tables: the general path.
    let mut reversed = a.clone();
    for name in ["K", "M"] {
        let t = &a.tables[name].0;
        let rev_i = |c: &str| {
            let indices = t.indices(name, c).unwrap().to_i64();
            Column::I64(indices.iter().rev().copied().collect())
        };
        let values = t
            .f64s(name, "value")
            .unwrap()
            .iter()
            .rev()
            .copied()
            .collect();
        let table = Table::new()
            .with("row", rev_i("row"))
            .with("col", rev_i("col"))
            .with("value", Column::F64(values));
        reversed = reversed.with_table(name, table, Storage::Ipc);
    }
    let mut whole = a.clone();
    whole.meta.remove("triangle");
    for name in ["K", "M"] {
        let m = if name == "K" { &sys.k } else { &sys.m };
        whole = whole.with_table(name, triplet_table(m), Storage::Ipc);
    }
    // 64-bit indices in order (schema version 2): the direct path, for both matrices or for
    // `M` alone beside `K`'s 32-bit ones.
    let widened = |names: &[&str]| {
        let mut b = a.clone();
        for &name in names {
            let t = &a.tables[name].0;
            let wide = |c: &str| Column::I64(t.indices(name, c).unwrap().to_i64().into_owned());
            let table = Table::new()
                .with("row", wide("row"))
                .with("col", wide("col"))
                .with(
                    "value",
                    Column::F64(t.f64s(name, "value").unwrap().to_vec()),
                );
            b = b.with_table(name, table, Storage::Ipc);
        }
        b
    };
    let (both, mass_only) = (widened(&["K", "M"]), widened(&["M"]));
    for other in [&reversed, &whole, &both, &mass_only] {
        let (p, d) = pencil_from_matrices(other).unwrap();
        assert_eq!(d, sys.dofs);
        assert_eq!(products(&p), want);
    }
    // A NaN in M is named by its DOFs.
    let mut nan = a.clone();
    let t = &a.tables["M"].0;
    let mut values = t.f64s("M", "value").unwrap().to_vec();
    let (rows, cols) = (
        t.indices("M", "row").unwrap(),
        t.indices("M", "col").unwrap(),
    );
    let (rows, cols) = (rows.to_i64(), cols.to_i64());
    let last = values.len() - 1;
    values[last] = f64::NAN;
    let table = Table::new()
        .with("row", Column::I64(rows.to_vec()))
        .with("col", Column::I64(cols.to_vec()))
        .with("value", Column::F64(values));
    nan = nan.with_table("M", table, Storage::Ipc);
    let e = pencil_from_matrices(&nan).unwrap_err().to_string();
    let (r, c) = (sys.dofs[rows[last] as usize], sys.dofs[cols[last] as usize]);
    assert!(
        e.contains("matrix M") && e.contains(&format!("({r}, {c})")) && e.contains("NaN"),
        "{e}"
    );
    let mut lying = whole.clone();
    lying.meta.insert("triangle".into(), "lower".into());
    let e = pencil_from_matrices(&lying).unwrap_err().to_string();
    assert!(e.contains("lies above the diagonal"), "{e}");
}

#[test]
fn a_matrix_table_in_any_row_order_reads_as_the_same_matrix() {
    // The sorted table takes the direct path, shuffled and duplicated rows the triplet path.
    let n = 4;
    let trip = [
        (0, 0, 4.0),
        (1, 0, -1.0),
        (3, 0, 0.5),
        (0, 1, -1.0),
        (1, 1, 4.0),
        (2, 2, 2.0),
        (0, 3, 0.5),
        (3, 3, 1.0),
    ];
    let m = sparse_from_triplets("K", n, &trip).unwrap();
    let sorted = triplet_table(&m);
    let mut shuffled = Table::new();
    let order = [5usize, 0, 7, 2, 1, 6, 3, 4];
    let (r, c, v) = (
        sorted.indices("K", "row").unwrap().to_i64(),
        sorted.indices("K", "col").unwrap().to_i64(),
        sorted.f64s("K", "value").unwrap(),
    );
    // (1, 1) split into two halves: duplicates are summed.
    let mut rows: Vec<i64> = order.iter().map(|&k| r[k]).collect();
    let mut cols: Vec<i64> = order.iter().map(|&k| c[k]).collect();
    let mut vals: Vec<f64> = order
        .iter()
        .map(|&k| if (r[k], c[k]) == (1, 1) { 2.0 } else { v[k] })
        .collect();
    rows.push(1);
    cols.push(1);
    vals.push(2.0);
    shuffled = shuffled
        .with("row", Column::I64(rows))
        .with("col", Column::I64(cols))
        .with("value", Column::F64(vals));
    for table in [sorted, shuffled] {
        let a = Artefact::new(ArtefactKind::Matrices).with_table("K", table, Storage::Ipc);
        let read = read_sparse(&a, "K", n).unwrap().unwrap();
        assert_eq!(sparse_to_dense(&read), sparse_to_dense(&m));
    }
    // An index out of range is an error on either path.
    let bad = Table::new()
        .with("row", Column::I64(vec![0, 4]))
        .with("col", Column::I64(vec![0, 0]))
        .with("value", Column::F64(vec![1.0, 1.0]));
    let a = Artefact::new(ArtefactKind::Matrices).with_table("K", bad, Storage::Ipc);
    assert!(read_sparse(&a, "K", n).is_err());
}

impl Example for posterior::PosteriorKind {
    fn examples() -> Vec<posterior::PosteriorRecord> {
        use crate::updating::posterior::{Band, Direction, Marginal, Posterior, Refinement};
        let marginal = |name: &str, mean: f64, sd: f64| Marginal {
            name: name.into(),
            updated: mean * 1.01,
            mean,
            sd,
            lower: mean - 1.64 * sd,
            upper: mean + 1.64 * sd,
        };
        let band = |label: &str, f: f64| Band {
            label: label.into(),
            freq_hz: f,
            value: 2.0 * f,
            sd_linear: 0.1,
            sd_sampled: 0.11,
        };
        let frf = Posterior {
            marginals: vec![marginal("m1", 1.0, 0.01), marginal("m2", 2.0, 0.03)],
            covariance: vec![vec![1e-4, -1.5e-4], vec![-1.5e-4, 9e-4]],
            correlation: vec![vec![1.0, -0.5], vec![-0.5, 1.0]],
            directions: vec![
                Direction {
                    sd: 0.02,
                    vector: vec![0.3, 0.95],
                },
                Direction {
                    sd: 0.005,
                    vector: vec![0.95, -0.3],
                },
            ],
            sigma: vec![1e-6, 2e-6],
            groups: vec!["1:ux/1:ux".into(), "2:ux/1:ux".into()],
            sigma_estimated: false,
            rows: 40,
            neg_log_likelihood: -512.5,
            refinement: Refinement {
                steps: 2,
                objective_start: 30.0,
                objective_mode: 19.5,
                converged: true,
            },
            credible_level: 0.9,
            samples: vec![vec![1.01, 1.98], vec![0.99, 2.02], vec![1.0, 2.0]],
            predictive_samples: 2,
            natural_frequencies: vec![band("mode 1", 9.8), band("mode 2", 18.7)],
            frf: vec![band("1:ux/1:ux", 1.0), band("2:ux/1:ux", 1.0)],
            seed: 7,
            warnings: Vec::new(),
        };
        let unidentified = Posterior {
            marginals: vec![marginal("k", 1e4, f64::INFINITY)],
            covariance: vec![vec![f64::INFINITY]],
            correlation: vec![vec![1.0]],
            directions: vec![Direction {
                sd: f64::INFINITY,
                vector: vec![1.0],
            }],
            sigma: vec![0.01, 0.01],
            groups: vec!["9.8 Hz".into(), "18.7 Hz".into()],
            sigma_estimated: true,
            natural_frequencies: Vec::new(),
            frf: Vec::new(),
            samples: Vec::new(),
            predictive_samples: 0,
            warnings: vec![
                "the noise estimated for 2 of 2 noise groups (9.8 Hz, 18.7 Hz) is at round-off"
                    .into(),
            ],
            ..frf.clone()
        };
        vec![
            posterior::PosteriorRecord {
                method: "pc".into(),
                likelihood: "frf_modal".into(),
                noise: "sigma".into(),
                posterior: frf.clone(),
                sampling: None,
                mcmc: None,
            },
            posterior::PosteriorRecord {
                method: "pc".into(),
                likelihood: "frf_modal".into(),
                noise: "snr_db".into(),
                posterior: frf.clone(),
                sampling: None,
                mcmc: Some(posterior::Mcmc {
                    sampler: "mala".into(),
                    chains: vec![
                        crate::updating::mala::ChainReport {
                            step: 1.25,
                            acceptance: 0.5625,
                            failed: 0,
                        },
                        crate::updating::mala::ChainReport {
                            step: 1.5,
                            acceptance: 0.625,
                            failed: 3,
                        },
                    ],
                    r_hat: frf.marginals.iter().map(|_| 1.0078125).collect(),
                    ess: frf.marginals.iter().map(|_| 812.5).collect(),
                }),
            },
            posterior::PosteriorRecord {
                method: "tmcmc".into(),
                likelihood: "frf_modal".into(),
                noise: "sigma".into(),
                posterior: frf,
                sampling: Some(posterior::Sampling {
                    log_evidence: -123.25,
                    stages: vec![
                        crate::updating::tmcmc::TmcmcStage {
                            exponent: 0.01,
                            log_evidence: -100.0,
                            acceptance: 0.4,
                            distinct: 600,
                        },
                        crate::updating::tmcmc::TmcmcStage {
                            exponent: 1.0,
                            log_evidence: -23.25,
                            acceptance: 0.3,
                            distinct: 550,
                        },
                    ],
                }),
                mcmc: None,
            },
            posterior::PosteriorRecord {
                method: "eigensensitivity".into(),
                likelihood: "natural_frequencies".into(),
                noise: "estimated".into(),
                posterior: unidentified,
                sampling: None,
                mcmc: None,
            },
        ]
    }
}

impl Example for tmcmc_population::TmcmcPopulationKind {
    fn examples() -> Vec<tmcmc_population::PopulationRecord> {
        use crate::updating::tmcmc::{Population, TmcmcStage};
        let prior_like = || Population {
            samples: vec![vec![1.5, 2.0e-3], vec![0.75, 1.25e-3], vec![1.0, 3.0e-3]],
            log_likelihood: vec![-12.5, f64::NEG_INFINITY, -3.25],
            stages: vec![],
            failed: 1,
        };
        let prior = prior_like();
        let tempered = Population {
            stages: vec![TmcmcStage {
                exponent: 0.125,
                log_evidence: -4.5,
                acceptance: 0.5,
                distinct: 2,
            }],
            ..prior.clone()
        };
        let batch = Some(tmcmc_population::ChainBatch {
            stage: 3,
            index: 1,
            of: 4,
            accepted: 2,
        });
        [(prior, None), (tempered, None), (prior_like(), batch)]
            .into_iter()
            .map(|(population, batch)| tmcmc_population::PopulationRecord {
                parameters: vec!["m2".into(), "t".into()],
                population,
                batch,
            })
            .collect()
    }
}

/// The DOF index digest is blake3 of the labels joined by newlines, however many pieces the
/// labels are formatted in (200,000 DOFs: four pieces).
#[test]
fn the_dof_index_digest_is_the_hash_of_the_joined_labels() {
    let dofs: Vec<DofId> = (0..200_000u64)
        .map(|i| DofId::new(i / 6 + 1, crate::core::Component::ALL[(i % 6) as usize]))
        .collect();
    let joined: Vec<String> = dofs.iter().map(|d| d.to_string()).collect();
    assert_eq!(
        dof_index_digest(&dofs),
        crate::artefact::digest::hash_bytes(joined.join("\n").as_bytes())
    );
    assert_eq!(
        dof_index_digest(&dofs[..1]),
        crate::artefact::digest::hash_bytes(b"1:ux")
    );
}
