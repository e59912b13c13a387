//! Results do not depend on the thread count (DESIGN, "Determinism"): at 1, 2 and 7 threads the
//! sparse eigensolver and the assembly give the same bits in-process, and through the `femu`
//! binary (`RAYON_NUM_THREADS`, which sets the threads of rayon and of faer's `Par::rayon(0)`) a
//! small sweep and a few predictor-corrector iterations give the same artefact digests and the
//! same collected table.

mod common;

use femu::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use femu::fe::element::MassKind;
use femu::fe::model_assembly::assemble_model;
use femu::model::generate::{BentPlate, bent_plate};
use std::collections::BTreeMap;
use std::path::Path;

/// The thread counts compared: serial, the machine's two cores, and more threads than cores.
const THREADS: [usize; 3] = [1, 2, 7];

/// `f` run on a rayon pool of `n` threads.
fn on_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
        .install(f)
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The bent plate with its bar at refinement 3: shells and beams, free-free, a few thousand DOFs.
fn plate() -> femu::model::structure::Model {
    bent_plate(&BentPlate {
        refine: 3,
        ..Default::default()
    })
}

/// A sparse matrix as its pattern and the bits of its values.
type SparseBits = (Vec<usize>, Vec<usize>, Vec<u64>);

fn sparse_bits(a: &femu::core::sparse::SparseMatrix) -> SparseBits {
    let s = a.symbolic();
    (s.col_ptr().to_vec(), s.row_idx().to_vec(), bits(a.val()))
}

#[test]
fn assembly_is_bit_identical_at_1_2_and_7_threads() {
    let model = plate();
    let runs: Vec<_> = THREADS
        .iter()
        .map(|&n| {
            on_threads(n, || {
                let (sys, _) = assemble_model(&model, MassKind::Consistent).unwrap();
                (sys.dofs.clone(), sparse_bits(&sys.k), sparse_bits(&sys.m))
            })
        })
        .collect();
    assert!(runs[0].0.len() > 3000, "{} DOFs", runs[0].0.len());
    for (n, run) in THREADS.iter().zip(&runs).skip(1) {
        assert!(run.0 == runs[0].0, "DOF order differs at {n} threads");
        assert!(run.1 == runs[0].1, "K differs at {n} threads");
        assert!(run.2 == runs[0].2, "M differs at {n} threads");
    }
}

#[test]
fn sparse_eigensolver_is_bit_identical_at_1_2_and_7_threads() {
    let (sys, _) = assemble_model(&plate(), MassKind::Consistent).unwrap();
    let params = SparseEigenParams::default();
    assert!(sys.dofs.len() > params.dense_limit, "the sparse path runs");
    let runs: Vec<_> = THREADS
        .iter()
        .map(|&n| {
            on_threads(n, || {
                let (modes, _) =
                    lowest_modes(&sys.k, &sys.m, &sys.dofs, ModeSelection::Count(20), &params)
                        .unwrap();
                let shapes: Vec<u64> = (0..modes.shapes.ncols())
                    .flat_map(|j| {
                        modes
                            .shapes
                            .col(j)
                            .iter()
                            .map(|x| x.to_bits())
                            .collect::<Vec<_>>()
                    })
                    .collect();
                (bits(&modes.eigenvalues), shapes, bits(&modes.residuals))
            })
        })
        .collect();
    assert_eq!(runs[0].0.len(), 20);
    for (n, run) in THREADS.iter().zip(&runs).skip(1) {
        assert!(run.0 == runs[0].0, "eigenvalues differ at {n} threads");
        assert!(run.1 == runs[0].1, "mode shapes differ at {n} threads");
        assert!(run.2 == runs[0].2, "residuals differ at {n} threads");
    }
}

/// Runs the binary with `RAYON_NUM_THREADS=n`; asserts success.
fn femu_at(n: usize, args: &[&str], cache: &Path) {
    let out = common::femu()
        .env("RAYON_NUM_THREADS", n.to_string())
        .args(args)
        .arg("--cache-dir")
        .arg(cache)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?} at {n} threads: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Stage name → its outputs (port → kind and digest) from a lock file.
fn output_digests(lock: &Path) -> BTreeMap<String, serde_json::Value> {
    let text = std::fs::read_to_string(lock).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["stages"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(name, s)| (name.clone(), s["outputs"].clone()))
        .collect()
}

/// Three P-C iterations on the bent plate's Craig-Bampton model (C2), with everything upstream
/// (mesh, assembly, FRF synthesis, noise, partition, component modes), each thread count with a
/// cache of its own: every stage's output digests agree.
#[test]
fn pc_iterations_give_the_same_digests_at_1_2_and_7_threads() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = common::pipeline("bent-plate-pc");
    let runs: Vec<_> = THREADS
        .iter()
        .map(|&n| {
            let out = dir.path().join(format!("out-{n}"));
            femu_at(
                n,
                &[
                    "run",
                    pipeline.to_str().unwrap(),
                    "--quiet",
                    "--only",
                    "pc_three_frfs",
                    "--set",
                    "pc_three_frfs.max_iterations=3",
                    "--out",
                    out.to_str().unwrap(),
                ],
                &dir.path().join(format!("cache-{n}")),
            );
            output_digests(&out.join("femu.lock.json"))
        })
        .collect();
    assert!(runs[0].contains_key("pc_three_frfs"), "{runs:?}");
    for (n, run) in THREADS.iter().zip(&runs).skip(1) {
        for (stage, outputs) in &runs[0] {
            assert_eq!(
                run.get(stage),
                Some(outputs),
                "stage {stage}: outputs differ between 1 and {n} threads"
            );
        }
        assert_eq!(run.len(), runs[0].len());
    }
}

/// A small sweep of the C1 non-uniqueness study (two seeds: RFM and P-C per point) through
/// `femu sweep`, whose workers inherit the thread count: the collected tables are the same
/// bytes.
#[test]
fn a_sweep_collects_the_same_table_at_1_2_and_7_threads() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = common::root().join("sweeps/four-dof-noise.yaml");
    let tables: Vec<Vec<u8>> = THREADS
        .iter()
        .map(|&n| {
            let cache = dir.path().join(format!("cache-{n}"));
            femu_at(
                n,
                &[
                    "sweep",
                    "--quiet",
                    "--jobs",
                    "1",
                    "--set",
                    "noisy_05.with.seed=[1, 2]",
                    "--set",
                    "noisy_05.with.level=[0.05]",
                    "--set",
                    r#"complete.with.responses=[["1:ux", "2:ux", "3:ux", "4:ux"]]"#,
                    sweep.to_str().unwrap(),
                ],
                &cache,
            );
            std::fs::read(cache.join("sweeps/four-dof-noise/collected/collected.parquet")).unwrap()
        })
        .collect();
    assert!(!tables[0].is_empty());
    for (n, table) in THREADS.iter().zip(&tables).skip(1) {
        assert!(
            *table == tables[0],
            "the collected table differs between 1 and {n} threads"
        );
    }
}
