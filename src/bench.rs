//! Benchmarks behind `femu bench` and `benches/`: sparse assembly, factorisation and the lowest
//! modes of a clamped flat steel plate of four-node shells at a chosen size, with where the time
//! goes and the peak memory. Figures go to a report; no test depends on a time.

use crate::eigen::{ModeSelection, SparseEigenInfo, SparseEigenParams, lowest_modes};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::assemble_model;
use crate::model::generate::scale::{muffler, muffler_element_size};
use crate::model::generate::{FlatPlate, PlateSupport, flat_plate, steel};
use std::time::Instant;

/// One model's figures.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PlateBench {
    /// Elements per side.
    pub elements_per_side: usize,
    /// Free DOFs.
    pub dofs: usize,
    /// Non-zeros of `K` (full storage).
    pub nnz: usize,
    /// Seconds to generate the mesh.
    pub generate_seconds: f64,
    /// Seconds to assemble `K` and `M`.
    pub assembly_seconds: f64,
    /// Per requested mode count: total seconds and the solver's breakdown.
    pub modes: Vec<ModesBench>,
    /// Peak resident memory of the process so far, MiB (Linux `VmHWM`).
    pub peak_rss_mib: Option<f64>,
}

/// Figures of one eigen solve.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ModesBench {
    /// Modes asked for.
    pub count: usize,
    /// Wall time, s.
    pub seconds: f64,
    /// Lowest and highest frequency found, Hz.
    pub band_hz: (f64, f64),
    /// Largest relative residual.
    pub max_residual: f64,
    /// Solver breakdown.
    pub info: SparseEigenInfo,
}

/// Peak resident set size of this process, MiB.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Which structure a benchmark builds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum BenchModel {
    /// A clamped 1 m × 1 m × 5 mm steel plate.
    Plate,
    /// The free-free muffler-like box with two baffles (CASES.md C5).
    Muffler,
}

/// Benchmarks a clamped 1 m × 1 m × 5 mm steel plate of about `target_dofs` free DOFs.
pub fn plate_bench(target_dofs: usize, mode_counts: &[usize]) -> Result<PlateBench, String> {
    model_bench(BenchModel::Plate, target_dofs, mode_counts)
}

/// Benchmarks `which` at about `target_dofs` DOFs.
pub fn model_bench(
    which: BenchModel,
    target_dofs: usize,
    mode_counts: &[usize],
) -> Result<PlateBench, String> {
    let side = ((target_dofs as f64 / 6.0).sqrt().round() as usize).max(2);
    let t = Instant::now();
    let model = match which {
        BenchModel::Plate => flat_plate(&FlatPlate {
            a: 1.0,
            b: 1.0,
            nx: side,
            ny: side,
            thickness: 0.005,
            material: steel(),
            support: PlateSupport::ClampedEdge,
        }),
        BenchModel::Muffler => muffler(muffler_element_size(target_dofs, 2), 2),
    };
    let generate_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (sys, info) = assemble_model(&model, MassKind::Consistent).map_err(|e| e.to_string())?;
    let assembly_seconds = t.elapsed().as_secs_f64();
    drop(model);
    let mut modes = Vec::new();
    for &count in mode_counts {
        let t = Instant::now();
        let params = SparseEigenParams {
            tolerance: 1e-8,
            ..Default::default()
        };
        let (m, info) = lowest_modes(
            &sys.k,
            &sys.m,
            &sys.dofs,
            ModeSelection::Count(count),
            &params,
        )
        .map_err(|e| e.to_string())?;
        let f = m.frequencies_hz();
        modes.push(ModesBench {
            count,
            seconds: t.elapsed().as_secs_f64(),
            band_hz: (
                f.first().copied().unwrap_or(0.0),
                f.last().copied().unwrap_or(0.0),
            ),
            max_residual: m.residuals.iter().copied().fold(0.0, f64::max),
            info,
        });
    }
    Ok(PlateBench {
        elements_per_side: side,
        dofs: sys.n(),
        nnz: info.nnz,
        generate_seconds,
        assembly_seconds,
        modes,
        peak_rss_mib: peak_rss_mib(),
    })
}
