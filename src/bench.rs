//! Benchmarks behind `femu bench` and `benches/`: sparse assembly, factorisation and the lowest
//! modes of a clamped flat steel plate of four-node shells at a chosen size, with where the time
//! goes and the peak memory. Figures go to a report; no test depends on a time.

use crate::eigen::{
    ModeSelection, SparseEigenInfo, SparseEigenParams, lowest_modes, lowest_modes_keeping_factor,
    pencil_modes,
};
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
    /// Peak resident memory of generation and assembly, MiB (Linux `VmHWM`).
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
    /// Peak resident memory during this solve, MiB: the model's `K` and `M` and everything the
    /// solver holds (the peak is reset just before; Linux only).
    pub peak_rss_mib: Option<f64>,
}

/// Peak resident set size of this process, MiB.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Starts a new peak: returns freed heap memory to the kernel and resets `VmHWM` (Linux
/// `clear_refs` 5), so that [`peak_rss_mib`] measures what follows alone. A no-op where either is
/// unavailable.
pub fn reset_peak_rss() {
    crate::core::memory::release_freed_memory();
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Which structure a benchmark builds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum BenchModel {
    /// A clamped 1 m × 1 m × 5 mm steel plate.
    Plate,
    /// The free-free muffler-like box with two baffles (CASES.md C5).
    Muffler,
}

/// One Nastran import timing.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ImportBench {
    /// Free DOFs of the model.
    pub dofs: usize,
    /// GRID cards.
    pub grids: usize,
    /// Element cards.
    pub elements: usize,
    /// Size of the deck.
    pub deck_bytes: u64,
    /// `read_bulk` wall time.
    pub import_seconds: f64,
    /// Peak resident memory during the import, MiB (Linux).
    pub peak_rss_mib: Option<f64>,
}

/// Writes the clamped plate of about `target_dofs` DOFs as a deck (large field, as
/// [`crate::model::export::nastran::write_bulk`] writes) and times reading it back.
pub fn import_bench(target_dofs: usize) -> Result<ImportBench, String> {
    let side = ((target_dofs as f64 / 6.0).sqrt().round() as usize).max(2);
    let model = flat_plate(&FlatPlate {
        a: 1.0,
        b: 1.0,
        nx: side,
        ny: side,
        thickness: 0.005,
        material: steel(),
        support: PlateSupport::ClampedEdge,
    });
    let dofs = model.n_dofs();
    let (grids, elements) = (model.nodes.len(), model.elements.len());
    let text = crate::model::export::nastran::write_bulk(&model);
    drop(model);
    let path = std::env::temp_dir().join(format!("femu-bench-import-{}.bdf", std::process::id()));
    std::fs::write(&path, &text).map_err(|e| format!("{}: {e}", path.display()))?;
    let deck_bytes = text.len() as u64;
    drop(text);
    reset_peak_rss();
    let t = Instant::now();
    let read = crate::model::import::nastran::read_bulk(&path);
    let import_seconds = t.elapsed().as_secs_f64();
    let peak_rss_mib = peak_rss_mib();
    let _ = std::fs::remove_file(&path);
    let b = read.map_err(|e| e.to_string())?;
    if b.model.elements.len() != elements {
        return Err(format!(
            "the import read {} elements of {elements}",
            b.model.elements.len()
        ));
    }
    Ok(ImportBench {
        dofs,
        grids,
        elements,
        deck_bytes,
        import_seconds,
        peak_rss_mib,
    })
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
    drop(model);
    // What the `modes` stage holds: K and M as lower triangles on one pattern.
    let pencil =
        crate::sparse::LowerPencil::from_full(&sys.k, &sys.m).map_err(|e| e.to_string())?;
    let dofs = sys.dofs.clone();
    drop(sys);
    crate::core::memory::release_freed_memory();
    let assembly_seconds = t.elapsed().as_secs_f64();
    let assembly_peak = peak_rss_mib();
    let mut modes = Vec::new();
    for &count in mode_counts {
        reset_peak_rss();
        let t = Instant::now();
        let params = SparseEigenParams {
            tolerance: 1e-8,
            ..Default::default()
        };
        let (m, info) = pencil_modes(&pencil, &dofs, ModeSelection::Count(count), &params)
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
            peak_rss_mib: peak_rss_mib(),
        });
    }
    Ok(PlateBench {
        elements_per_side: side,
        dofs: dofs.len(),
        nnz: info.nnz,
        generate_seconds,
        assembly_seconds,
        modes,
        peak_rss_mib: assembly_peak,
    })
}

/// Figures of one predictor-corrector iteration on a large model (issue 5's speed goal).
#[derive(Clone, Debug, serde::Serialize)]
pub struct PcIterationBench {
    /// Free DOFs.
    pub dofs: usize,
    /// Updating parameters (shell thicknesses of element groups).
    pub parameters: usize,
    /// Measured FRFs.
    pub frfs: usize,
    /// Frequency lines (all used: the synthetic "measurement" differs at every line).
    pub lines: usize,
    /// Modes of the basis.
    pub modes: usize,
    /// Rebuilding the model at the parameter values, assembling `K`, `M` and every `∂K/∂φ`,
    /// `∂M/∂φ`, s.
    pub assembly_seconds: f64,
    /// The lowest modes in an iteration, on the factor structure of the analysis before, s.
    pub eigen_seconds: f64,
    /// Where the eigen solve's time went.
    pub eigen: SparseEigenInfo,
    /// The initial analysis's eigen solve, which orders the pattern and finds the factor
    /// structure the iterations then use, s.
    pub initial_eigen_seconds: f64,
    /// Where its time went.
    pub initial_eigen: SparseEigenInfo,
    /// `Φᵀ ∂K/∂φ Φ`, `Φᵀ ∂M/∂φ Φ` of every parameter, s.
    pub projection_seconds: f64,
    /// Static correction of the truncated mode-shape derivatives (solves per measured DOF with
    /// the eigensolver's factor, its shift moved by fixed-point steps, and the cross
    /// projections `Xᵀ ∂K/∂φ Φ`), s.
    pub static_correction_seconds: f64,
    /// Fixed-point steps that moved the eigensolver's shift to the static one (`None`: `K − σM`
    /// was factored again).
    pub static_shift_steps: Option<usize>,
    /// Predicted FRFs and their correlation, s.
    pub prediction_seconds: f64,
    /// FRF sensitivities of every parameter at every line (the sweep), s.
    pub sweep_seconds: f64,
    /// Its rate counted as the direct double sum over modes the projection form replaces
    /// (`8 m²` flops per line, pair and parameter): the "direct-sum equivalent", GFLOP/s.
    pub sweep_gflops: f64,
    /// `χ` sensitivities, `S`, its SVD, subset selection and the step, s.
    pub solve_seconds: f64,
    /// Everything above, s.
    pub iteration_seconds: f64,
    /// Peak resident memory of the process so far, MiB.
    pub peak_rss_mib: Option<f64>,
}

/// One P-C iteration on the muffler-like box of about `target_dofs` DOFs with `parameters`
/// thickness parameters (contiguous groups of shells), `frfs` FRFs (one excitation), `lines`
/// lines and a basis of `modes` modes, timed part by part as `PredictorCorrector::iterate`
/// runs them.
pub fn pc_iteration_bench(
    target_dofs: usize,
    parameters: usize,
    frfs: usize,
    lines: usize,
    modes: usize,
) -> Result<PcIterationBench, String> {
    use crate::frf::ModalDamping;
    use crate::updating::model::FeModel;
    use crate::updating::{ParametricModel, UpdatingError};

    let mut model = muffler(muffler_element_size(target_dofs, 2), 2);
    let groups = thickness_groups(&mut model, parameters);
    let nodes: Vec<u64> = model.nodes.keys().copied().collect();
    let fe = FeModel::new(model, &[], MassKind::Consistent).map_err(|e| e.to_string())?;
    let values = fe.initial_values();
    let t = Instant::now();
    let evaluated = fe
        .evaluate(&values)
        .map_err(|e: UpdatingError| e.to_string())?;
    let assembly_seconds = t.elapsed().as_secs_f64();
    // The initial analysis: the measurement is made from its modes, and its factor structure
    // serves the iteration's analysis (as every analysis of an update after the first), which
    // runs after it is freed.
    let initial = pc_basis(&evaluated, &values, modes, None)?;
    let damping = ModalDamping::Structural(vec![0.01]);
    let measured = pc_measurement(&initial.state, &nodes, frfs, lines, &damping)?;
    let structure = (initial.state.factor.as_ref()).map(|f| f.factor.structure().clone());
    let (initial_eigen_seconds, initial_eigen) = (initial.eigen_seconds, initial.eigen.clone());
    drop(initial);
    let basis = pc_basis(&evaluated, &values, modes, structure)?;
    let state = &basis.state;
    let it = pc_iterate(state, &evaluated, &values, &measured, &damping)?;
    let pairs = measured.pairs.len();
    let m = state.modes.len() as f64;
    let flops = 8.0 * m * m * it.lines as f64 * pairs as f64 * groups as f64;
    Ok(PcIterationBench {
        dofs: state.dofs.len(),
        parameters: groups,
        frfs: pairs,
        lines: it.lines,
        modes: state.modes.len(),
        assembly_seconds,
        eigen_seconds: basis.eigen_seconds,
        eigen: basis.eigen,
        initial_eigen_seconds,
        initial_eigen,
        projection_seconds: basis.projection_seconds,
        static_correction_seconds: it.static_correction_seconds,
        static_shift_steps: it.static_shift_steps,
        prediction_seconds: it.prediction_seconds,
        sweep_seconds: it.sweep_seconds,
        sweep_gflops: flops / it.sweep_seconds.max(1e-12) / 1e9,
        solve_seconds: it.solve_seconds,
        iteration_seconds: assembly_seconds
            + basis.eigen_seconds
            + basis.projection_seconds
            + it.static_correction_seconds
            + it.prediction_seconds
            + it.sweep_seconds
            + it.solve_seconds,
        peak_rss_mib: peak_rss_mib(),
    })
}

/// Adds about `parameters` thickness parameters to `model`: its shells by property (a parameter
/// must hold one thickness), split into contiguous groups in proportion to each property's
/// share. Returns the number of groups.
fn thickness_groups(model: &mut crate::model::Model, parameters: usize) -> usize {
    use crate::model::{Element, Parameter, ParameterKind};
    let mut by_property: std::collections::BTreeMap<u64, Vec<u64>> = Default::default();
    for (&id, e) in &model.elements {
        if let Element::Quad4 { property, .. }
        | Element::Tria3 { property, .. }
        | Element::Quad8 { property, .. }
        | Element::Tria6 { property, .. } = e
        {
            by_property.entry(*property).or_default().push(id);
        }
    }
    let total: usize = by_property.values().map(Vec::len).sum();
    let mut groups = 0;
    for ids in by_property.values() {
        let share = ((parameters * ids.len()) as f64 / total.max(1) as f64).round() as usize;
        let k = share.clamp(1, ids.len());
        for g in 0..k {
            groups += 1;
            let set = format!("bench_group_{groups}");
            model.sets.insert(
                set.clone(),
                ids[g * ids.len() / k..(g + 1) * ids.len() / k].to_vec(),
            );
            model.parameters.push(Parameter {
                name: format!("t{groups}"),
                kind: ParameterKind::ShellThickness,
                set,
                lower: 1e-4,
                upper: 1e-2,
            });
        }
    }
    groups
}

/// The modal state of one iteration with the time of its eigen solve and projections.
struct PcBasis {
    state: crate::updating::model::ModalState,
    eigen: SparseEigenInfo,
    eigen_seconds: f64,
    projection_seconds: f64,
}

/// The lowest `modes` modes (the factor kept; on `structure`, when given, as an update's
/// analyses after its first) and `Φᵀ ∂K/∂φ Φ`, `Φᵀ ∂M/∂φ Φ`, timed.
fn pc_basis(
    evaluated: &crate::updating::model::Evaluated,
    values: &[f64],
    modes: usize,
    structure: Option<crate::sparse::FactorStructure>,
) -> Result<PcBasis, String> {
    use crate::updating::model::{ModalState, project_derivatives, update_eigen_params};
    let t = Instant::now();
    let (found, eigen, factor) = lowest_modes_keeping_factor(
        &evaluated.system.k,
        &evaluated.system.m,
        &evaluated.system.dofs,
        ModeSelection::Count(modes),
        &update_eigen_params(None, structure),
    )
    .map_err(|e| e.to_string())?;
    let eigen_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let projected = project_derivatives(&evaluated.derivatives, values, found.shapes.as_ref());
    let projection_seconds = t.elapsed().as_secs_f64();
    let state = ModalState {
        modes: found,
        dofs: evaluated.system.dofs.clone(),
        projected,
        reduced: None,
        factor: factor.map(std::sync::Arc::new),
        sensors: None,
    };
    Ok(PcBasis {
        state,
        eigen,
        eigen_seconds,
        projection_seconds,
    })
}

/// The measurement: `frfs` vertical FRFs of nodes spread over the model (one excitation) on
/// `lines` lines up to the middle elastic mode, the prediction with a smooth, line-dependent
/// 10 % distortion, so that every line stays below κ_f and enters the equations.
fn pc_measurement(
    state: &crate::updating::model::ModalState,
    nodes: &[u64],
    frfs: usize,
    lines: usize,
    damping: &crate::frf::ModalDamping,
) -> Result<crate::frf::FrfSet, String> {
    use crate::core::{Component, DofId};
    use crate::frf::{FrfPair, FrfSet};
    use crate::updating::pc::predict;
    let free: std::collections::HashSet<DofId> = state.dofs.iter().copied().collect();
    let picks: Vec<DofId> = (0..nodes.len())
        .step_by((nodes.len() / (4 * frfs.max(1))).max(1))
        .map(|i| DofId::new(nodes[i], Component::Uz))
        .filter(|d| free.contains(d))
        .take(frfs.max(1))
        .collect();
    let pairs: Vec<FrfPair> = picks
        .iter()
        .map(|&response| FrfPair {
            response,
            excitation: picks[0],
        })
        .collect();
    let f = state.modes.frequencies_hz();
    let elastic: Vec<f64> = f.iter().copied().filter(|&x| x > 1e-3).collect();
    let top = elastic.get(elastic.len() / 2).copied().unwrap_or(100.0);
    let step = top / lines.max(1) as f64;
    let freqs: Vec<f64> = (1..=lines).map(|k| k as f64 * step).collect();
    let mut measured = FrfSet {
        quantity: crate::frf::Quantity::Receptance,
        freqs_hz: freqs.clone(),
        pairs: pairs.clone(),
        values: faer::Mat::zeros(freqs.len(), pairs.len()),
    };
    let clean = predict(state, &measured, damping).map_err(|e| e.to_string())?;
    measured.values = faer::Mat::from_fn(freqs.len(), pairs.len(), |k, q| {
        clean.values[(k, q)] * (1.0 + 0.1 * (0.37 * k as f64 + q as f64).cos())
    });
    Ok(measured)
}

/// The timed parts of one iteration after the modal basis, and the lines it used.
struct PcTimes {
    static_correction_seconds: f64,
    static_shift_steps: Option<usize>,
    prediction_seconds: f64,
    sweep_seconds: f64,
    solve_seconds: f64,
    lines: usize,
}

/// The rest of `PredictorCorrector::iterate`, timed part by part: static correction of the
/// shape derivatives, prediction and line selection, the sensitivity sweep, and the solve.
fn pc_iterate(
    state: &crate::updating::model::ModalState,
    evaluated: &crate::updating::model::Evaluated,
    values: &[f64],
    measured: &crate::frf::FrfSet,
    damping: &crate::frf::ModalDamping,
) -> Result<PcTimes, String> {
    use crate::sensitivity::frf::{EigenFactor, shift_steps, static_shift};
    use crate::sensitivity::{ModalFrfModel, frf_sensitivities};
    use crate::updating::UpdatingError;
    use crate::updating::pc::{LineCorrelation, correlation_equations, predict, select_lines};
    use crate::updating::solve::{
        ParameterWeighting, damped_step, diagnostics, select_subset, subset_condition_limit,
    };
    let err = |e: UpdatingError| e.to_string();
    let f = state.modes.frequencies_hz();
    let t = Instant::now();
    let dofs = measured.dofs();
    let corrections = state
        .shape_corrections(evaluated, values, &dofs)
        .map_err(err)?;
    let static_correction_seconds = t.elapsed().as_secs_f64();
    let static_shift_steps = state.factor.as_deref().and_then(|factor| {
        let eigenvalues = &state.modes.eigenvalues;
        shift_steps(
            EigenFactor {
                factor,
                shapes: state.modes.shapes.as_ref(),
            },
            eigenvalues,
            static_shift(eigenvalues),
            state.dofs.len(),
        )
    });
    let t = Instant::now();
    let predicted = predict(state, measured, damping).map_err(err)?;
    let correlation = LineCorrelation::new(measured, &predicted);
    // κ_f = 1: every line enters, as the speed goal asks ("all parameters at all lines").
    let chosen = select_lines(&measured.freqs_hz, &correlation, &f, 1.0, 1.0);
    let prediction_seconds = t.elapsed().as_secs_f64();
    let shapes = state.shapes_at(&dofs).map_err(err)?;
    let modal = ModalFrfModel {
        eigenvalues: &state.modes.eigenvalues,
        shapes: shapes.as_ref(),
        dofs: &dofs,
        damping,
    };
    let chosen_hz: Vec<f64> = chosen.iter().map(|&k| measured.freqs_hz[k]).collect();
    let t = Instant::now();
    let sens = frf_sensitivities(
        &modal,
        &measured.pairs,
        &chosen_hz,
        measured.quantity,
        &state.projected,
        Some(&corrections),
    )
    .map_err(|e| e.to_string())?;
    let sweep_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (s, eps) = correlation_equations(measured, &predicted, &chosen, &sens, true);
    let _ = diagnostics(s.as_ref());
    let active = select_subset(
        s.as_ref(),
        subset_condition_limit(1e7, s.nrows(), s.ncols()),
    );
    let _ = damped_step(s.as_ref(), &eps, &active, ParameterWeighting::None, 0.0);
    let solve_seconds = t.elapsed().as_secs_f64();
    Ok(PcTimes {
        static_correction_seconds,
        static_shift_steps,
        prediction_seconds,
        sweep_seconds,
        solve_seconds,
        lines: chosen.len(),
    })
}

/// Figures of one split of the muffler into substructures (issue 4's re-analysis goal).
#[derive(Clone, Debug, serde::Serialize)]
pub struct CmsSplitBench {
    /// Substructures.
    pub parts: usize,
    /// Junction DOFs of the partition.
    pub junction_dofs: usize,
    /// Largest substructure, DOFs.
    pub largest_part_dofs: usize,
    /// Reduced coordinates (physical, modal) before the interface reduction.
    pub craig_bampton_size: (usize, usize),
    /// Interface modes kept (junction's Guyan modes to the component cut-off).
    pub interface_modes: usize,
    /// Reduced coordinates (physical, modal) after it.
    pub reduced_size: (usize, usize),
    /// Seconds for every substructure's junction condensation (its Guyan model).
    pub condensation_seconds: f64,
    /// Seconds for the interface modes (the junction's Guyan modes).
    pub interface_seconds: f64,
    /// Seconds to partition.
    pub partition_seconds: f64,
    /// Seconds to reduce every substructure on the interface modes, and synthesise.
    pub reduce_seconds: f64,
    /// Seconds for the reduced model's lowest modes.
    pub reduced_modes_seconds: f64,
    /// Largest relative eigenvalue error (3.54) of the reduced model's elastic modes against
    /// the direct solution, over the modes asked for.
    pub max_eigenvalue_error: f64,
    /// Seconds to re-analyse after a thickness change in one substructure: its reduction, the
    /// synthesis and the reduced model's modes.
    pub reanalysis_seconds: f64,
    /// Of which the one substructure's reduction.
    pub reanalysis_reduce_seconds: f64,
    /// Direct full solve time over re-analysis time.
    pub speed_up: f64,
    /// Peak resident memory of this split alone (from its partition to its re-analysis, the
    /// model and the direct modes held), MiB.
    pub peak_rss_mib: Option<f64>,
}

/// Figures of the CMS benchmark: the direct solve and each split.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CmsBench {
    /// Free DOFs of the full model.
    pub dofs: usize,
    /// Modes asked for.
    pub modes: usize,
    /// Component modes kept up to this frequency (twice the highest mode asked for), Hz.
    pub component_cut_off_hz: f64,
    /// Seconds to assemble the full model.
    pub assembly_seconds: f64,
    /// Seconds for the direct sparse eigen solve of the full model.
    pub direct_seconds: f64,
    /// Peak memory after the direct solve, MiB.
    pub direct_peak_rss_mib: Option<f64>,
    /// Per split.
    pub splits: Vec<CmsSplitBench>,
}

/// Benchmarks component mode synthesis on the muffler-like box at about `target_dofs` DOFs:
/// the direct lowest `modes` modes; then, per entry of `parts`, an automatic partition,
/// Craig-Bampton with component modes to twice the top of the band (the thesis's rule) and
/// interface modes to the same frequency, the reduced model's modes against the direct ones,
/// and the re-analysis after one substructure's shell thickness changes by 5 % (only that
/// substructure is reduced again; the interface basis is held).
pub fn cms_bench(target_dofs: usize, parts: &[usize], modes: usize) -> Result<CmsBench, String> {
    let model = muffler(muffler_element_size(target_dofs, 2), 2);
    let t = Instant::now();
    let (sys, _) = assemble_model(&model, MassKind::Consistent).map_err(|e| e.to_string())?;
    let assembly_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let params = SparseEigenParams {
        tolerance: 1e-8,
        ..Default::default()
    };
    let (direct, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(modes),
        &params,
    )
    .map_err(|e| e.to_string())?;
    let direct_seconds = t.elapsed().as_secs_f64();
    tracing::info!("direct eigen solve {direct_seconds:.1} s");
    let dofs = sys.n();
    drop(sys);
    let direct_peak_rss_mib = peak_rss_mib();
    reset_peak_rss();
    let top_hz = direct.frequencies_hz().last().copied().unwrap_or(0.0);
    let cut_off = 2.0 * top_hz;
    let splits = parts
        .iter()
        .map(|&k| cms_split(&model, k, cut_off, modes, &direct, direct_seconds))
        .collect::<Result<Vec<_>, String>>()?;
    Ok(CmsBench {
        dofs,
        modes,
        component_cut_off_hz: cut_off,
        assembly_seconds,
        direct_seconds,
        direct_peak_rss_mib,
        splits,
    })
}

/// One partition of the CMS benchmark: partition, reduce, solve the reduced modes against the
/// `direct` ones, then re-analyse after one substructure changed.
fn cms_split(
    model: &crate::model::Model,
    k: usize,
    cut_off: f64,
    modes: usize,
    direct: &crate::eigen::Modes,
    direct_seconds: f64,
) -> Result<CmsSplitBench, String> {
    use crate::reduction::{Method, Partition};
    reset_peak_rss();
    let method = Method::CraigBampton {
        modes: ModeSelection::BelowHz(cut_off),
    };
    let t = Instant::now();
    let partition =
        Partition::automatic(model, k, MassKind::Consistent).map_err(|e| e.to_string())?;
    let partition_seconds = t.elapsed().as_secs_f64();
    let CmsReduction {
        mut reduced,
        craig_bampton_size,
        condensation_seconds,
        interface_seconds,
        reduce_seconds,
    } = cms_reduce(model, &partition, &method, cut_off, k)?;
    let interface_modes = reduced.interface.as_ref().map_or(0, |p| p.ncols());
    let t = Instant::now();
    let red_modes = reduced
        .modes(ModeSelection::Count(modes))
        .map_err(|e| e.to_string())?;
    let reduced_modes_seconds = t.elapsed().as_secs_f64();
    let changed = changed_part_model(model, &partition)?;
    let (reanalysis_reduce_seconds, reanalysis_seconds) =
        cms_reanalyse(&changed, &partition, &method, &mut reduced, modes)?;
    Ok(CmsSplitBench {
        parts: k,
        junction_dofs: partition.junction.len(),
        largest_part_dofs: partition
            .substructures
            .iter()
            .map(|s| s.dofs.len())
            .max()
            .unwrap_or(0),
        craig_bampton_size,
        interface_modes,
        reduced_size: reduced.size(),
        condensation_seconds,
        interface_seconds,
        partition_seconds,
        reduce_seconds,
        reduced_modes_seconds,
        max_eigenvalue_error: max_eigenvalue_error(direct, &red_modes),
        reanalysis_seconds,
        reanalysis_reduce_seconds,
        speed_up: direct_seconds / reanalysis_seconds,
        peak_rss_mib: peak_rss_mib(),
    })
}

/// A partition reduced on its interface modes, with the time of each phase.
struct CmsReduction {
    reduced: crate::reduction::ReducedModel,
    craig_bampton_size: (usize, usize),
    condensation_seconds: f64,
    interface_seconds: f64,
    reduce_seconds: f64,
}

/// Junction condensations, interface modes below `cut_off`, then every substructure reduced on
/// the interface modes alone (`reduce_with_interface`'s route, timed by phase).
fn cms_reduce(
    model: &crate::model::Model,
    partition: &crate::reduction::Partition,
    method: &crate::reduction::Method,
    cut_off: f64,
    parts: usize,
) -> Result<CmsReduction, String> {
    use crate::reduction::craig_bampton::junction_condensation;
    use crate::reduction::{
        ReducedModel, interface_basis_from_condensations, reduce_substructure_on_interface,
        substructure_matrices,
    };
    use rayon::prelude::*;
    let t = Instant::now();
    let condensations = partition
        .substructures
        .par_iter()
        .map(|sub| {
            let sys = substructure_matrices(model, sub, MassKind::Consistent)?;
            junction_condensation(&sub.name, &sys, &sub.junction)
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let condensation_seconds = t.elapsed().as_secs_f64();
    tracing::info!(
        "{parts} parts, {} junction DOFs: condensations {condensation_seconds:.1} s",
        partition.junction.len()
    );
    let t = Instant::now();
    let psi = interface_basis_from_condensations(
        &partition.junction,
        condensations,
        ModeSelection::BelowHz(cut_off),
    )
    .map_err(|e| e.to_string())?
    .ok_or("the partition has no junction: ask for more than one part")?;
    let interface_seconds = t.elapsed().as_secs_f64();
    tracing::info!("{parts} parts: interface modes {interface_seconds:.1} s");
    let t = Instant::now();
    let components = (0..partition.substructures.len())
        .into_par_iter()
        .map(|k| {
            reduce_substructure_on_interface(
                model,
                partition,
                k,
                method,
                MassKind::Consistent,
                psi.as_ref(),
            )
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let craig_bampton_size = (
        partition.junction.len(),
        components.iter().map(|c| c.mode_frequencies_hz.len()).sum(),
    );
    let reduced = ReducedModel::synthesise_with_interface(
        method.clone(),
        partition.junction.clone(),
        components,
        Some(psi),
    )
    .map_err(|e| e.to_string())?;
    Ok(CmsReduction {
        reduced,
        craig_bampton_size,
        condensation_seconds,
        interface_seconds,
        reduce_seconds: t.elapsed().as_secs_f64(),
    })
}

/// The model with one substructure's shells of one property (one thickness) 5 % thicker.
fn changed_part_model(
    model: &crate::model::Model,
    partition: &crate::reduction::Partition,
) -> Result<crate::model::Model, String> {
    use crate::model::{Element, Parameter, ParameterKind};
    use crate::updating::ParametricModel;
    use crate::updating::model::FeModel;
    let mut changed = model.clone();
    let shell_property = |e: &u64| match changed.elements.get(e) {
        Some(
            Element::Quad4 { property, .. }
            | Element::Tria3 { property, .. }
            | Element::Quad8 { property, .. }
            | Element::Tria6 { property, .. },
        ) => Some(*property),
        _ => None,
    };
    let members = &partition.substructures[0].elements;
    let property = members.iter().find_map(shell_property);
    let shells: Vec<u64> = members
        .iter()
        .copied()
        .filter(|e| property.is_some() && shell_property(e) == property)
        .collect();
    changed.sets.insert("bench_part".into(), shells);
    changed.parameters = vec![Parameter {
        name: "t_part".into(),
        kind: ParameterKind::ShellThickness,
        set: "bench_part".into(),
        lower: 1e-5,
        upper: 1.0,
    }];
    let fe = FeModel::new(changed, &[], MassKind::Consistent).map_err(|e| e.to_string())?;
    let values: Vec<f64> = fe.initial_values().iter().map(|v| 1.05 * v).collect();
    fe.model_at(&values).map_err(|e| e.to_string())
}

/// Re-analysis after substructure 0 changed: its reduction on the kept interface basis, then
/// the reduced modes; returns (reduction, whole re-analysis) seconds.
fn cms_reanalyse(
    changed: &crate::model::Model,
    partition: &crate::reduction::Partition,
    method: &crate::reduction::Method,
    reduced: &mut crate::reduction::ReducedModel,
    modes: usize,
) -> Result<(f64, f64), String> {
    use crate::reduction::reduce_substructure_on_interface;
    let t = Instant::now();
    let psi = reduced
        .interface
        .clone()
        .ok_or("the reduced model lost its interface basis")?;
    let component = reduce_substructure_on_interface(
        changed,
        partition,
        0,
        method,
        MassKind::Consistent,
        psi.as_ref(),
    )
    .map_err(|e| e.to_string())?;
    let reduce_seconds = t.elapsed().as_secs_f64();
    reduced.replace(component).map_err(|e| e.to_string())?;
    reduced
        .modes(ModeSelection::Count(modes))
        .map_err(|e| e.to_string())?;
    Ok((reduce_seconds, t.elapsed().as_secs_f64()))
}

/// The largest relative error of the reduced eigenvalues against the direct ones (positive
/// direct eigenvalues only; a missing reduced one counts as infinite).
fn max_eigenvalue_error(direct: &crate::eigen::Modes, reduced: &crate::eigen::Modes) -> f64 {
    let mut worst = 0.0f64;
    for (k, l) in direct.eigenvalues.iter().enumerate() {
        if *l > 0.0 {
            let lc = reduced.eigenvalues.get(k).copied().unwrap_or(f64::INFINITY);
            worst = worst.max(((lc - l) / l).abs());
        }
    }
    worst
}

/// Figures of the direct FRF of the clamped plate (issue 26's speed goal).
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrfBench {
    /// Free DOFs.
    pub dofs: usize,
    /// Frequency lines, evenly spaced over 0–800 Hz.
    pub lines: usize,
    /// Response DOFs (`uz`, spread over the plate); the first is also the one excitation.
    pub responses: usize,
    /// Seconds to generate and assemble the plate.
    pub assembly_seconds: f64,
    /// Seconds of the direct FRF by `LDLᵀ` per line (symbolic analysis included).
    pub ldlt_seconds: f64,
    /// Lines the `LDLᵀ` handed to the pivoted LU (a zero pivot or a poor backward error).
    pub lines_by_lu: usize,
    /// Supernodes of the `LDLᵀ` factor.
    pub supernodes: usize,
    /// Stored entries of the factor.
    pub factor_entries: usize,
    /// Real floating-point operations (millions) of one numeric factorisation.
    pub factor_mflop: f64,
    /// The factorisations' operations over the `LDLᵀ` run's time (solves and checks counted
    /// as time, not as operations).
    pub gflop_per_second: f64,
    /// Lines also solved by the plain pivoted LU per line, an even subset of the lines.
    pub lu_lines: usize,
    /// Seconds of the LU on those lines.
    pub lu_seconds: f64,
    /// LU time per line over `LDLᵀ` time per line.
    pub speed_up: f64,
    /// Largest difference of the two on the LU's lines, relative to the largest value of its
    /// pair.
    pub max_relative_difference: f64,
    /// Peak resident memory of the `LDLᵀ` run, MiB (Linux only).
    pub peak_rss_mib: Option<f64>,
    /// Seconds of the Krylov sweep (`method: krylov`) over every line, at its default options.
    pub krylov_seconds: f64,
    /// Its expansion points and basis columns.
    pub krylov_points: usize,
    /// Columns of its basis.
    pub krylov_basis: usize,
    /// Its tolerance on the relative load residual.
    pub krylov_tolerance: f64,
    /// The largest estimate (relative load residual) of its lines.
    pub krylov_worst_estimate: f64,
    /// Largest difference from the `LDLᵀ` over every line, relative to each pair's largest
    /// value.
    pub krylov_difference: f64,
}

/// Times the direct FRF of the clamped 1 m × 1 m × 5 mm steel plate of about `target_dofs`
/// DOFs (η = 0.01) at `lines` lines over 0–800 Hz for `responses` responses to one excitation,
/// by `LDLᵀ` at every line and by the pivoted LU at `lu_lines` of them.
pub fn frf_bench(
    target_dofs: usize,
    lines: usize,
    responses: usize,
    lu_lines: usize,
) -> Result<FrfBench, String> {
    use crate::core::Component;
    use crate::frf::direct::{DirectDamping, DirectSolver, direct_receptance_by};
    use crate::frf::{FrfSet, Quantity};
    let side = ((target_dofs as f64 / 6.0).sqrt().round() as usize).max(2);
    let t = Instant::now();
    let model = flat_plate(&FlatPlate {
        a: 1.0,
        b: 1.0,
        nx: side,
        ny: side,
        thickness: 0.005,
        material: steel(),
        support: PlateSupport::ClampedEdge,
    });
    let (sys, _) = assemble_model(&model, MassKind::Consistent).map_err(|e| e.to_string())?;
    let assembly_seconds = t.elapsed().as_secs_f64();
    let uz: Vec<_> = sys
        .dofs
        .iter()
        .filter(|d| d.comp == Component::Uz)
        .collect();
    let responses = responses.clamp(1, uz.len());
    let picked: Vec<_> = (0..responses)
        .map(|k| *uz[(2 * k + 1) * uz.len() / (2 * responses)])
        .collect();
    let pairs = FrfSet::all_pairs(&picked, &picked[..1]);
    let lines = lines.max(1);
    let freqs: Vec<f64> = (0..lines)
        .map(|k| 800.0 * k as f64 / (lines - 1).max(1) as f64)
        .collect();
    let damping = DirectDamping {
        structural_eta: 0.01,
        rayleigh: None,
    };
    reset_peak_rss();
    let t = Instant::now();
    let (ldlt, report) = direct_receptance_by(
        &sys,
        &damping,
        &pairs,
        &freqs,
        Quantity::Receptance,
        DirectSolver::Ldlt,
    )
    .map_err(|e| e.to_string())?;
    let ldlt_seconds = t.elapsed().as_secs_f64();
    let peak_rss_mib = peak_rss_mib();
    let t = Instant::now();
    let options = crate::frf::KrylovOptions::default();
    let (krylov, krylov_report) = crate::frf::krylov_receptance(
        &sys,
        &damping,
        &pairs,
        &freqs,
        Quantity::Receptance,
        &options,
    )
    .map_err(|e| e.to_string())?;
    let krylov_seconds = t.elapsed().as_secs_f64();
    let mut krylov_difference = 0.0f64;
    for p in 0..pairs.len() {
        let scale = (0..lines)
            .map(|k| ldlt.values[(k, p)].norm())
            .fold(0.0, f64::max);
        for k in 0..lines {
            let d = (krylov.values[(k, p)] - ldlt.values[(k, p)]).norm() / scale;
            krylov_difference = krylov_difference.max(d);
        }
    }
    let lu_lines = lu_lines.clamp(1, lines);
    let subset: Vec<usize> = (0..lu_lines)
        .map(|k| (2 * k + 1) * lines / (2 * lu_lines))
        .collect();
    let sub_freqs: Vec<f64> = subset.iter().map(|&k| freqs[k]).collect();
    let t = Instant::now();
    let (lu, _) = direct_receptance_by(
        &sys,
        &damping,
        &pairs,
        &sub_freqs,
        Quantity::Receptance,
        DirectSolver::Lu,
    )
    .map_err(|e| e.to_string())?;
    let lu_seconds = t.elapsed().as_secs_f64();
    let mut max_relative_difference = 0.0f64;
    for p in 0..pairs.len() {
        let scale = (0..lu_lines)
            .map(|k| lu.values[(k, p)].norm())
            .fold(0.0, f64::max);
        for (k, &line) in subset.iter().enumerate() {
            let d = (ldlt.values[(line, p)] - lu.values[(k, p)]).norm() / scale;
            max_relative_difference = max_relative_difference.max(d);
        }
    }
    Ok(FrfBench {
        dofs: sys.n(),
        lines,
        responses,
        assembly_seconds,
        ldlt_seconds,
        lines_by_lu: report.lines_by_lu,
        supernodes: report.supernodes,
        factor_entries: report.factor_entries,
        factor_mflop: report.factor_flops / 1e6,
        gflop_per_second: report.factor_flops * lines as f64 / ldlt_seconds / 1e9,
        lu_lines,
        lu_seconds,
        speed_up: (lu_seconds / lu_lines as f64) / (ldlt_seconds / lines as f64),
        max_relative_difference,
        peak_rss_mib,
        krylov_seconds,
        krylov_points: krylov_report.expansion_hz.len(),
        krylov_basis: krylov_report.basis_size,
        krylov_tolerance: options.tolerance,
        krylov_worst_estimate: krylov_report.estimates.iter().copied().fold(0.0, f64::max),
        krylov_difference,
    })
}

/// Figures of the plate pipeline run through the executor, as `femu run` runs it, beside the
/// kernels on the same plate (issue 26: what users run must be as fast as the benchmark).
#[derive(Clone, Debug, serde::Serialize)]
pub struct PipelineBench {
    /// Free DOFs.
    pub dofs: usize,
    /// Modes asked for.
    pub modes: usize,
    /// Wall seconds of each stage (`mesh.generate`, `assemble`, `modes`), in order: its work
    /// and its outputs' digests.
    pub stage_seconds: Vec<(String, f64)>,
    /// Wall seconds of writing each stage's cache entry, in the background beside the stages
    /// after it (the last stage's is waited for by the run).
    pub cache_write_seconds: Vec<(String, f64)>,
    /// Wall seconds of the whole run (planning, cache writes and reads included).
    pub run_seconds: f64,
    /// Peak resident memory of the run, MiB (Linux only).
    pub run_peak_rss_mib: Option<f64>,
    /// The kernels on the same plate: generation, assembly and the modes.
    pub kernel_generate_seconds: f64,
    /// Kernel assembly seconds.
    pub kernel_assembly_seconds: f64,
    /// Kernel eigensolver seconds.
    pub kernel_modes_seconds: f64,
    /// Peak resident memory of the kernels' eigen solve, MiB.
    pub kernel_peak_rss_mib: Option<f64>,
}

/// Runs `f` with a fresh scratch folder under the system's temporary directory, removed after.
fn in_scratch_folder<T>(
    tag: &str,
    f: impl FnOnce(&std::path::Path) -> Result<T, String>,
) -> Result<T, String> {
    let folder = std::env::temp_dir().join(format!("femu-bench-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&folder).map_err(|e| format!("{}: {e}", folder.display()))?;
    let result = f(&folder);
    std::fs::remove_dir_all(&folder).ok();
    result
}

/// A pipeline run through the executor on a fresh cache, as `femu run` runs it.
struct TimedRun {
    report: crate::pipeline::RunReport,
    cache: crate::cache::Cache,
    seconds: f64,
    peak_rss_mib: Option<f64>,
}

/// Runs `spec` (only the stages `only` and what they need, when given) on a fresh cache in
/// `folder`, quietly, timing the whole run and its peak memory.
fn run_on_fresh_cache(
    folder: &std::path::Path,
    spec: &crate::pipeline::SourcedSpec,
    only: &[String],
) -> Result<TimedRun, String> {
    use crate::pipeline::{ProgressMode, RunOptions, execute, plan};
    let plan = plan(spec, &crate::stages::registry()).map_err(|e| e.to_string())?;
    let cache = crate::cache::Cache::open(&folder.join("cache")).map_err(|e| e.to_string())?;
    let opts = RunOptions {
        only: only.to_vec(),
        progress: ProgressMode::Quiet,
        ..Default::default()
    };
    reset_peak_rss();
    let t = Instant::now();
    let report = execute(&plan, &cache, &opts).map_err(|e| e.to_string())?;
    Ok(TimedRun {
        report,
        cache,
        seconds: t.elapsed().as_secs_f64(),
        peak_rss_mib: peak_rss_mib(),
    })
}

/// Runs `mesh.generate` (the clamped 1 m × 1 m × 5 mm steel plate of about `target_dofs`
/// DOFs) → `assemble` → `modes` (`count`, tolerance 1e-8) through the pipeline executor on a
/// fresh cache in a temporary folder, then the same steps by the kernels.
pub fn pipeline_bench(target_dofs: usize, count: usize) -> Result<PipelineBench, String> {
    let side = ((target_dofs as f64 / 6.0).sqrt().round() as usize).max(2);
    type Timed = (Vec<(String, f64)>, Vec<(String, f64)>, f64, Option<f64>);
    let (stage_seconds, cache_write_seconds, run_seconds, run_peak_rss_mib) = in_scratch_folder(
        "pipeline",
        |folder| -> Result<Timed, String> {
            let file = folder.join("plate-modes.yaml");
            let text = format!(
                "name: plate-modes\nstages:\n  plate:\n    kind: mesh.generate\n    with: {{geometry: flat_plate, a_m: 1.0, b_m: 1.0, nx: {side}, ny: {side}, thickness_m: 0.005, support: clamped_edge}}\n  matrices:\n    kind: assemble\n    inputs: {{mesh: plate}}\n  modes:\n    kind: modes\n    inputs: {{model: matrices}}\n    with: {{count: {count}, tolerance: 1.0e-8}}\n"
            );
            std::fs::write(&file, text).map_err(|e| format!("{}: {e}", file.display()))?;
            let spec = crate::pipeline::read_pipeline(&file).map_err(|e| e.to_string())?;
            let run = run_on_fresh_cache(folder, &spec, &[])?;
            let stage_seconds = run
                .report
                .stages
                .iter()
                .map(|s| (s.kind.clone(), s.elapsed.as_secs_f64()))
                .collect();
            let cache_write_seconds = run
                .report
                .stages
                .iter()
                .filter_map(|s| Some((s.kind.clone(), s.cache_write?.as_secs_f64())))
                .collect();
            Ok((
                stage_seconds,
                cache_write_seconds,
                run.seconds,
                run.peak_rss_mib,
            ))
        },
    )?;
    reset_peak_rss();
    let kernel = plate_bench(target_dofs, &[count])?;
    let solve = kernel
        .modes
        .first()
        .ok_or("the kernel benchmark solved nothing")?;
    Ok(PipelineBench {
        dofs: kernel.dofs,
        modes: count,
        stage_seconds,
        cache_write_seconds,
        run_seconds,
        run_peak_rss_mib,
        kernel_generate_seconds: kernel.generate_seconds,
        kernel_assembly_seconds: kernel.assembly_seconds,
        kernel_modes_seconds: solve.seconds,
        kernel_peak_rss_mib: solve.peak_rss_mib,
    })
}

/// One stage of a study run by [`study_bench`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct StudyStage {
    /// Stage name.
    pub stage: String,
    /// Stage kind.
    pub kind: String,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// What the stage reported: DOFs of a model, an update's iterations, stop, final mean
    /// correlation, seconds per analysis and component mode synthesis reuse.
    pub notes: String,
}

/// A study pipeline run through the executor (`femu bench --study`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct StudyBench {
    /// Pipeline name.
    pub pipeline: String,
    /// The overrides applied.
    pub sets: Vec<String>,
    /// Per stage, in run order.
    pub stages: Vec<StudyStage>,
    /// Whole run, seconds.
    pub run_seconds: f64,
    /// Peak resident memory of the process during the run, MiB (where the platform tells).
    pub run_peak_rss_mib: Option<f64>,
}

/// Runs the pipeline `file` with the overrides `sets` (only the stages `only` and what they
/// need, when given) on a fresh temporary cache, timing every stage.
pub fn study_bench(
    file: &std::path::Path,
    sets: &[String],
    only: &[String],
) -> Result<StudyBench, String> {
    let mut spec = crate::pipeline::read_pipeline(file).map_err(|e| e.to_string())?;
    spec.apply_overrides(sets).map_err(|e| e.to_string())?;
    in_scratch_folder("study", |folder| {
        let run = run_on_fresh_cache(folder, &spec, only)?;
        let stages = run
            .report
            .stages
            .iter()
            .map(|st| {
                let seconds = st.elapsed.as_secs_f64();
                StudyStage {
                    stage: st.name.clone(),
                    kind: st.kind.clone(),
                    seconds,
                    notes: study_notes(&run.cache, &st.key, seconds),
                }
            })
            .collect();
        Ok(StudyBench {
            pipeline: spec.spec.name.clone(),
            sets: sets.to_vec(),
            stages,
            run_seconds: run.seconds,
            run_peak_rss_mib: run.peak_rss_mib,
        })
    })
}

/// What a study stage's outputs say about its size and work (see [`StudyStage::notes`]),
/// from their `meta.json` in the cache alone (a 1M-DOF matrices artefact is not read).
fn study_notes(cache: &crate::cache::Cache, key: &str, seconds: f64) -> String {
    let meta_of = |port: &str| {
        let dir = cache.artefact_dir(key, port).ok()?;
        let raw = crate::artefact::codec::read_meta(&dir).ok()?.raw;
        raw.get("meta")?.as_object().cloned()
    };
    if let Some(meta) = meta_of("result") {
        let meta = |k: &str| meta.get(k).cloned().unwrap_or_default();
        let iterations = meta("iterations").as_u64().unwrap_or(0);
        let mut notes = format!(
            "{iterations} iterations, stop {}, mean chi {:.4}",
            meta("stop").as_str().unwrap_or("?"),
            meta("final_mean_chi").as_f64().unwrap_or(f64::NAN)
        );
        let cms = meta("cms");
        if let (Some(analyses), Some(reductions), Some(parts)) = (
            cms["analyses"].as_u64(),
            cms["reductions"].as_u64(),
            cms["substructures"].as_u64(),
        ) {
            notes += &format!(
                ", {:.2} s per iteration, {analyses} full analyses and {} candidate steps ranked on held bases, {reductions} of {} substructure reductions computed",
                seconds / (iterations + 1) as f64,
                cms["trials"].as_u64().unwrap_or(0),
                analyses * parts
            );
        } else {
            notes += &format!(", {:.2} s per iteration", seconds / (iterations + 1) as f64);
        }
        return notes;
    }
    meta_of("model")
        .and_then(|m| m.get("n_dofs").and_then(|v| v.as_u64()))
        .map_or_else(String::new, |n| format!("{n} DOFs"))
}
