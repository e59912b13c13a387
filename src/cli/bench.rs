//! `femu bench`: time assembly and the lowest modes of a plate or the muffler box, the direct
//! FRF, one P-C iteration, component mode synthesis, or the Nastran import; print the figures
//! and write them as JSON.

use super::{BenchArgs, Failure};

/// `femu bench`: `--cms`, `--pc-iteration` or the model benchmark, in that precedence.
pub(super) fn run(a: BenchArgs) -> Result<u8, Failure> {
    if a.study.is_some() {
        study(a)
    } else if a.pipeline {
        pipeline(a)
    } else if a.frf {
        frf(a)
    } else if a.import {
        import(a)
    } else if a.cms {
        cms(a)
    } else if a.pc_iteration {
        pc_iteration(a)
    } else {
        models(a)
    }
}

/// `femu bench --study PIPELINE`.
fn study(a: BenchArgs) -> Result<u8, Failure> {
    let Some(file) = a.study.clone() else {
        return Ok(0);
    };
    let sizes: Vec<Option<usize>> = if a.dofs.is_empty() {
        vec![None]
    } else {
        a.dofs.iter().copied().map(Some).collect()
    };
    println!(
        "{} through the pipeline executor on a fresh cache, {} threads",
        file.display(),
        rayon::current_num_threads()
    );
    let mut all = Vec::new();
    for size in sizes {
        let mut sets = a.set.clone();
        if let Some(n) = size {
            sets.push(format!("nominal.dofs={n}"));
        }
        // The pipeline's own diagnostics already say `error:`.
        let b = crate::bench::study_bench(&file, &sets, &a.only)
            .map_err(|e| anyhow::anyhow!(e.trim_start_matches("error: ").to_string()))?;
        println!(
            "\n{} (nominal.dofs = {}): {:.1} s, peak {} MiB",
            b.pipeline,
            size.map_or_else(|| "as in the file".to_string(), |n| n.to_string()),
            b.run_seconds,
            b.run_peak_rss_mib
                .map_or_else(|| "?".to_string(), |m| format!("{m:.0}"))
        );
        println!("{:<32} {:<20} {:>9}  notes", "stage", "kind", "s");
        for st in &b.stages {
            println!(
                "{:<32} {:<20} {:>9.2}  {}",
                st.stage, st.kind, st.seconds, st.notes
            );
        }
        all.push(b);
    }
    write_json(a.json, &all)?;
    Ok(0)
}

/// `femu bench --pipeline`.
fn pipeline(a: BenchArgs) -> Result<u8, Failure> {
    let dofs = if a.dofs.is_empty() {
        vec![300_000]
    } else {
        a.dofs
    };
    let count = a.modes.first().copied().unwrap_or(50);
    println!(
        "clamped plate through the pipeline executor (mesh.generate -> assemble -> modes, {count} modes, tolerance 1e-8, fresh cache) and by the kernels, {} threads",
        rayon::current_num_threads()
    );
    println!(
        "{:>9} {:>10} {:>10} {:>10} {:>9} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "dofs",
        "generate s",
        "assemble s",
        "modes s",
        "run s",
        "run MiB",
        "k.assem s",
        "k.modes s",
        "k.MiB",
        "run/kernel"
    );
    let mut all = Vec::new();
    for n in dofs {
        let b = crate::bench::pipeline_bench(n, count).map_err(|e| anyhow::anyhow!(e))?;
        let stage = |kind: &str| {
            b.stage_seconds
                .iter()
                .find(|s| s.0 == kind)
                .map_or(f64::NAN, |s| s.1)
        };
        let kernel = b.kernel_generate_seconds + b.kernel_assembly_seconds + b.kernel_modes_seconds;
        println!(
            "{:>9} {:>10.2} {:>10.2} {:>10.2} {:>9.2} {:>10.0} {:>10.2} {:>10.2} {:>10.0} {:>9.2}x",
            b.dofs,
            stage("mesh.generate"),
            stage("assemble"),
            stage("modes"),
            b.run_seconds,
            b.run_peak_rss_mib.unwrap_or(f64::NAN),
            b.kernel_assembly_seconds,
            b.kernel_modes_seconds,
            b.kernel_peak_rss_mib.unwrap_or(f64::NAN),
            b.run_seconds / kernel
        );
        let writes: Vec<String> = b
            .cache_write_seconds
            .iter()
            .map(|(kind, seconds)| format!("{kind} {seconds:.2} s"))
            .collect();
        println!(
            "{:>9} cache entries written in the background: {}",
            "",
            writes.join(", ")
        );
        all.push(b);
    }
    write_json(a.json, &all)?;
    Ok(0)
}

/// `femu bench --frf`.
fn frf(a: BenchArgs) -> Result<u8, Failure> {
    let dofs = if a.dofs.is_empty() {
        vec![3_900, 100_000]
    } else {
        a.dofs
    };
    println!(
        "direct FRF of a clamped plate, eta = 0.01, 0-800 Hz, one excitation, {} threads",
        rayon::current_num_threads()
    );
    println!(
        "{:>9} {:>6} {:>5} {:>9} {:>9} {:>7} {:>7} {:>9} {:>9} {:>9} {:>9}",
        "dofs",
        "lines",
        "resp",
        "LDLt s",
        "ms/line",
        "by LU",
        "LU lines",
        "LU s",
        "speed-up",
        "max diff",
        "peak MiB"
    );
    let mut all = Vec::new();
    for n in dofs {
        let lines = a.lines.unwrap_or(if n <= 10_000 { 801 } else { 100 });
        // The plain LU on a subset: every line of it costs what the whole band does by LDLᵀ.
        let lu_lines = if n <= 10_000 { 40 } else { 2 };
        let b = crate::bench::frf_bench(n, lines, 10, lu_lines).map_err(|e| anyhow::anyhow!(e))?;
        println!(
            "{:>9} {:>6} {:>5} {:>9.2} {:>9.2} {:>7} {:>7} {:>9.2} {:>8.1}x {:>9.1e} {:>9.0}",
            b.dofs,
            b.lines,
            b.responses,
            b.ldlt_seconds,
            1e3 * b.ldlt_seconds / b.lines as f64,
            b.lines_by_lu,
            b.lu_lines,
            b.lu_seconds,
            b.speed_up,
            b.max_relative_difference,
            b.peak_rss_mib.unwrap_or(f64::NAN)
        );
        println!(
            "{:>9} factor: {} supernodes, {} entries ({:.1} MiB), {:.1} Mflop a line, {:.2} GFlop/s over the band",
            "",
            b.supernodes,
            b.factor_entries,
            b.factor_entries as f64 * 16.0 / 1048576.0,
            b.factor_mflop,
            b.gflop_per_second
        );
        println!(
            "{:>9} Krylov sweep: {:.2} s ({:.1}x the LDLt), {} expansion points, {} basis vectors, worst estimate {:.1e} (tolerance {:.0e}), largest difference from the LDLt {:.1e} of each FRF's peak",
            "",
            b.krylov_seconds,
            b.ldlt_seconds / b.krylov_seconds,
            b.krylov_points,
            b.krylov_basis,
            b.krylov_worst_estimate,
            b.krylov_tolerance,
            b.krylov_difference
        );
        all.push(b);
    }
    write_json(a.json, &all)?;
    Ok(0)
}

/// `femu bench --import`.
fn import(a: BenchArgs) -> Result<u8, Failure> {
    let dofs = if a.dofs.is_empty() {
        vec![100_000, 1_000_000]
    } else {
        a.dofs
    };
    println!("Nastran import of a clamped plate deck (GRID, CQUAD4, SPC1; large field)");
    println!(
        "{:>9} {:>9} {:>9} {:>10} {:>9} {:>9}",
        "dofs", "grids", "elements", "deck MiB", "import s", "peak MiB"
    );
    let mut all = Vec::new();
    for n in dofs {
        let b = crate::bench::import_bench(n).map_err(|e| anyhow::anyhow!(e))?;
        println!(
            "{:>9} {:>9} {:>9} {:>10.1} {:>9.2} {:>9.0}",
            b.dofs,
            b.grids,
            b.elements,
            b.deck_bytes as f64 / (1024.0 * 1024.0),
            b.import_seconds,
            b.peak_rss_mib.unwrap_or(f64::NAN)
        );
        all.push(b);
    }
    write_json(a.json, &all)?;
    Ok(0)
}

/// `femu bench --cms`.
fn cms(a: BenchArgs) -> Result<u8, Failure> {
    let BenchArgs {
        dofs,
        modes,
        json,
        parts,
        ..
    } = a;
    let dofs = if dofs.is_empty() { vec![100_000] } else { dofs };
    let parts = if parts.is_empty() { vec![8, 64] } else { parts };
    let count = modes.first().copied().unwrap_or(50);
    let mut all = Vec::new();
    for n in dofs {
        let b = crate::bench::cms_bench(n, &parts, count).map_err(|e| anyhow::anyhow!(e))?;
        println!(
            "muffler {} DOFs, lowest {} modes: assembly {:.2} s, direct eigen {:.2} s (peak {:.0} MiB); Craig-Bampton, component and interface modes to {:.0} Hz",
            b.dofs,
            b.modes,
            b.assembly_seconds,
            b.direct_seconds,
            b.direct_peak_rss_mib.unwrap_or(f64::NAN),
            b.component_cut_off_hz
        );
        println!(
            "{:>6} {:>9} {:>10} {:>12} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10} {:>11} {:>8} {:>9}",
            "parts",
            "junction",
            "max part",
            "iface+modal",
            "partition",
            "condense",
            "interface",
            "reduce",
            "modes",
            "max err",
            "re-analyse",
            "speed-up",
            "peak MiB"
        );
        for s in &b.splits {
            println!(
                "{:>6} {:>9} {:>10} {:>12} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>10.1e} {:>11.2} {:>7.1}x {:>9.0}",
                s.parts,
                s.junction_dofs,
                s.largest_part_dofs,
                format!(
                    "{}+{}",
                    s.interface_modes,
                    s.reduced_size.1 - s.interface_modes
                ),
                s.partition_seconds,
                s.condensation_seconds,
                s.interface_seconds,
                s.reduce_seconds,
                s.reduced_modes_seconds,
                s.max_eigenvalue_error,
                s.reanalysis_seconds,
                s.speed_up,
                s.peak_rss_mib.unwrap_or(f64::NAN)
            );
        }
        all.push(b);
    }
    write_json(json, &all)?;
    Ok(0)
}

/// `femu bench --pc-iteration`.
fn pc_iteration(a: BenchArgs) -> Result<u8, Failure> {
    let BenchArgs {
        dofs, modes, json, ..
    } = a;
    let dofs = if dofs.is_empty() { vec![100_000] } else { dofs };
    let basis = modes.first().copied().unwrap_or(100);
    let mut all = Vec::new();
    for n in dofs {
        let b = crate::bench::pc_iteration_bench(n, 50, 10, 1000, basis)
            .map_err(|e| anyhow::anyhow!(e))?;
        println!(
            "P-C iteration, muffler {} DOFs, {} parameters, {} FRFs, {} lines, {} modes:\n  initial analysis: eigen {:.2} s (factor {:.1} s: ordering and symbolic {:.1} s, numeric {:.1} s);\n  assembly + derivatives {:.2} s, eigen {:.2} s (factor {:.1} s: {} {:.2} s, numeric {:.1} s, {} entries; {} solves {:.1} s, orthogonalisation {:.1} s, M products {:.1} s, refinement {:.1} s),\n  projections {:.2} s, static correction {:.2} s ({}),\n  prediction {:.3} s, sensitivity sweep {:.3} s ({:.0} GFLOP/s direct-sum equivalent), solve {:.3} s;\n  iteration {:.2} s, peak memory {:.0} MiB",
            b.dofs,
            b.parameters,
            b.frfs,
            b.lines,
            b.modes,
            b.initial_eigen_seconds,
            b.initial_eigen.factor_seconds,
            b.initial_eigen.factor.symbolic_seconds,
            b.initial_eigen.factor.numeric_seconds,
            b.assembly_seconds,
            b.eigen_seconds,
            b.eigen.factor_seconds,
            if b.eigen.factor.structure_reused {
                "the initial analysis's structure, pattern checked in"
            } else {
                "ordering and symbolic"
            },
            b.eigen.factor.symbolic_seconds,
            b.eigen.factor.numeric_seconds,
            b.eigen.factor.factor_entries,
            b.eigen.solves,
            b.eigen.solve_seconds,
            b.eigen.orthogonalisation_seconds,
            b.eigen.mass_product_seconds,
            b.eigen.refinement_seconds,
            b.projection_seconds,
            b.static_correction_seconds,
            match b.static_shift_steps {
                Some(k) => format!("the eigensolver's factor, {k} shift steps"),
                None => "a second factorisation".to_string(),
            },
            b.prediction_seconds,
            b.sweep_seconds,
            b.sweep_gflops,
            b.solve_seconds,
            b.iteration_seconds,
            b.peak_rss_mib.unwrap_or(f64::NAN)
        );
        all.push(b);
    }
    write_json(json, &all)?;
    Ok(0)
}

/// `femu bench` of the plate, or of the muffler with `--muffler`.
fn models(a: BenchArgs) -> Result<u8, Failure> {
    let BenchArgs {
        dofs,
        modes,
        json,
        muffler,
        ..
    } = a;
    let which = if muffler {
        crate::bench::BenchModel::Muffler
    } else {
        crate::bench::BenchModel::Plate
    };
    let dofs = if dofs.is_empty() {
        vec![10_000, 100_000]
    } else {
        dofs
    };
    let modes = if modes.is_empty() {
        vec![50, 100]
    } else {
        modes
    };
    let threads = rayon::current_num_threads();
    println!(
        "{}, four-node shells, {threads} threads",
        if muffler {
            "free-free muffler-like box"
        } else {
            "clamped steel plate"
        }
    );
    println!(
        "{:>9} {:>11} {:>9} {:>9} {:>6} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>12} {:>10}",
        "dofs",
        "nnz(K)",
        "assemble",
        "peak MiB",
        "modes",
        "total",
        "factor",
        "solves",
        "orthog",
        "M*x",
        "refine",
        "nnz(L)",
        "peak MiB"
    );
    let mut all = Vec::new();
    for n in dofs {
        let b = crate::bench::model_bench(which, n, &modes).map_err(|e| anyhow::anyhow!(e))?;
        for m in &b.modes {
            println!(
                "{:>9} {:>11} {:>9.2} {:>9.0} {:>6} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>12} {:>10.0}",
                b.dofs,
                b.nnz,
                b.assembly_seconds,
                b.peak_rss_mib.unwrap_or(f64::NAN),
                m.count,
                m.seconds,
                m.info.factor_seconds,
                m.info.solve_seconds,
                m.info.orthogonalisation_seconds,
                m.info.mass_product_seconds,
                m.info.refinement_seconds,
                m.info.factor.factor_entries,
                m.peak_rss_mib.unwrap_or(f64::NAN)
            );
        }
        all.push(b);
    }
    write_json(json, &all)?;
    Ok(0)
}

/// Writes the figures as JSON to `path`, when given.
fn write_json(
    path: Option<std::path::PathBuf>,
    figures: &impl serde::Serialize,
) -> Result<(), Failure> {
    if let Some(path) = path {
        let text = serde_json::to_string_pretty(figures).map_err(|e| anyhow::anyhow!(e))?;
        std::fs::write(&path, text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    }
    Ok(())
}
