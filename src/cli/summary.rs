//! What a run leaves for its reader: the warnings its stages recorded in their artefacts'
//! meta, the run record written beside `femu.lock.json`, and the key results of an artefact
//! (natural frequencies, mean `χ`, updated parameters) that `femu show` prints for a run.

use crate::artefact::codec::{DirMeta, read_dir, read_ipc, read_meta, read_parquet};
use crate::artefact::{Column, Table};
use serde_json::{Map, Value};
use std::path::Path;

pub(super) use crate::run_report::record::{
    RUN_RECORD_FILE, RunRecord, RunRecordStage, stage_warnings,
};

/// The artefact meta (the `meta` object of `meta.json`).
pub(super) fn artefact_meta(m: &DirMeta) -> Map<String, Value> {
    m.raw
        .get("meta")
        .and_then(|v| v.as_object())
        .cloned()
        .unwrap_or_default()
}

/// Prints warnings grouped by stage (only stages that have some) to `out`.
pub(super) fn print_warnings(
    groups: &[(String, String, Vec<String>)],
    out: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    let total: usize = groups.iter().map(|g| g.2.len()).sum();
    if total == 0 {
        return Ok(());
    }
    writeln!(
        out,
        "warnings ({total}, from {} stage{}):",
        groups.iter().filter(|g| !g.2.is_empty()).count(),
        if groups.iter().filter(|g| !g.2.is_empty()).count() == 1 {
            ""
        } else {
            "s"
        }
    )?;
    for (stage, label, warnings) in groups.iter().filter(|g| !g.2.is_empty()) {
        writeln!(out, "  {stage} ({label}):")?;
        for w in warnings {
            writeln!(out, "    - {w}")?;
        }
    }
    Ok(())
}

/// One table of an artefact directory, reading only its file where the format allows.
pub(super) fn read_table(dir: &Path, meta: &DirMeta, name: &str) -> Option<Table> {
    let entry = meta.raw.get("tables")?.get(name)?;
    let file = entry.get("file").and_then(|f| f.as_str());
    let storage = entry.get("storage").and_then(|s| s.as_str());
    match (file, storage) {
        (Some(file), Some("parquet")) if crate::cache::names::unsafe_reason(file).is_none() => {
            read_parquet(&dir.join(file)).ok()
        }
        (Some(file), Some("arrow_ipc")) if crate::cache::names::unsafe_reason(file).is_none() => {
            read_ipc(&dir.join(file)).ok()
        }
        _ => read_dir(dir).ok()?.tables.remove(name).map(|(t, _)| t),
    }
}

fn f64s<'t>(t: &'t Table, c: &str) -> Option<&'t [f64]> {
    match t.column(c)? {
        Column::F64(v) => Some(v),
        _ => None,
    }
}

fn strs<'t>(t: &'t Table, c: &str) -> Option<&'t [String]> {
    match t.column(c)? {
        Column::Str(v) => Some(v),
        _ => None,
    }
}

/// A list of numbers, the first `show` of them and a count of the rest.
fn some_numbers(v: &[f64], show: usize, fmt: impl Fn(f64) -> String) -> String {
    let mut s: Vec<String> = v.iter().take(show).map(|x| fmt(*x)).collect();
    if v.len() > show {
        s.push(format!("… ({} more)", v.len() - show));
    }
    s.join(", ")
}

/// The key results of the artefact in `dir`, one line each (empty for kinds without any).
pub(super) fn key_results(dir: &Path, meta: &DirMeta) -> Vec<String> {
    use crate::artefact::ArtefactKind as K;
    let m = artefact_meta(meta);
    let num = |k: &str| m.get(k).and_then(|v| v.as_f64());
    let mut out = Vec::new();
    match meta.kind {
        K::Modes => {
            if let Some(t) = read_table(dir, meta, "frequencies")
                && let Some(f) = f64s(&t, "freq_hz")
            {
                out.push(format!(
                    "{} modes, natural frequencies (Hz): {}",
                    f.len(),
                    some_numbers(f, 12, |x| format!("{x:.4}"))
                ));
            }
        }
        K::Correlation => {
            if let Some(s) = m.get("summary") {
                let g = |k: &str| s.get(k).and_then(|v| v.as_f64());
                if let (Some(cs), Some(ca)) = (g("mean_chi_s"), g("mean_chi_a")) {
                    out.push(format!(
                        "mean χ_s {cs:.4}, mean χ_a {ca:.4} over {} lines of {} FRFs",
                        s.get("n_lines").map(|v| v.to_string()).unwrap_or_default(),
                        s.get("n_frfs").map(|v| v.to_string()).unwrap_or_default()
                    ));
                }
            }
        }
        K::UpdateResult => {
            let stop = m.get("stop").and_then(|v| v.as_str()).unwrap_or("?");
            let iterations = match m.get("iterations") {
                Some(n) if n.as_u64() == Some(1) => "1 iteration".to_string(),
                Some(n) => format!("{n} iterations"),
                None => "? iterations".to_string(),
            };
            let method = m.get("method").and_then(|v| v.as_str()).unwrap_or("?");
            out.push(format!(
                "{method}: {iterations}, stopped: {stop}{}",
                m.get("returned_iteration")
                    .filter(|v| !v.is_null())
                    .map(|v| format!(" (returned iteration {v})"))
                    .unwrap_or_default()
            ));
            if let Some(t) = read_table(dir, meta, "parameters")
                && let (Some(names), Some(initial), Some(fin)) = (
                    strs(&t, "parameter"),
                    f64s(&t, "initial"),
                    f64s(&t, "final"),
                )
            {
                for ((n, a), b) in names.iter().zip(initial).zip(fin).take(SHOWN_PARAMETERS) {
                    let change = if *a != 0.0 {
                        format!(" ({:+.2} %)", 100.0 * (b - a) / a)
                    } else {
                        String::new()
                    };
                    out.push(format!("  {n}: {a:.6e} → {b:.6e}{change}"));
                }
                out.extend(more_parameters(names.len()));
            }
            if let Some(t) = read_table(dir, meta, "iterations")
                && let (Some(cs), Some(ca)) = (f64s(&t, "mean_chi_s"), f64s(&t, "mean_chi_a"))
                && let (Some(s0), Some(a0), Some(s1), Some(a1)) =
                    (cs.first(), ca.first(), cs.last(), ca.last())
            {
                out.push(format!(
                    "  mean χ_s {s0:.4} → {s1:.4}, mean χ_a {a0:.4} → {a1:.4}"
                ));
            }
        }
        K::Posterior => {
            // TMCMC samples the posterior itself; an update's posterior is Laplace's Gaussian
            // about the likelihood's mode near the update's result, or MCMC samples from there.
            let method = m.get("method").and_then(|v| v.as_str()).unwrap_or("?");
            let mut head = match (method, m.get("sampler").and_then(|v| v.as_str())) {
                ("tmcmc", _) => "TMCMC posterior".to_string(),
                (_, Some(sampler)) => {
                    format!(
                        "{} posterior about the {method} result",
                        sampler.to_uppercase()
                    )
                }
                _ => format!("Laplace posterior about the {method} result"),
            };
            if let Some(n) = num("samples").filter(|&n| n > 0.0) {
                head += &format!(", {n} samples");
            }
            if let Some(e) = num("log_evidence") {
                head += &format!(", ln evidence {e:.6e}");
            }
            let level = num("credible_level")
                .map_or("credible".to_string(), |l| format!("{:.0} %", 100.0 * l));
            out.push(head);
            if let Some(t) = read_table(dir, meta, "parameters")
                && let (Some(names), Some(mean), Some(sd), Some(lower), Some(upper)) = (
                    strs(&t, "parameter"),
                    f64s(&t, "mean"),
                    f64s(&t, "sd"),
                    f64s(&t, "lower"),
                    f64s(&t, "upper"),
                )
            {
                // An unidentified parameter (infinite sd) has no interval to show: those are
                // named together, after the identified ones.
                let rows = [mean.len(), sd.len(), lower.len(), upper.len()]
                    .into_iter()
                    .fold(names.len(), usize::min);
                let (identified, unidentified): (Vec<usize>, Vec<usize>) =
                    (0..rows).partition(|&i| sd[i].is_finite());
                for &i in identified.iter().take(SHOWN_PARAMETERS) {
                    let (n, mean, sd, lo, hi) = (&names[i], mean[i], sd[i], lower[i], upper[i]);
                    out.push(format!(
                        "  {n}: {mean:.6e} ± {sd:.3e} ({level} interval {lo:.6e} to {hi:.6e})"
                    ));
                }
                out.extend(more_parameters(identified.len()));
                if !unidentified.is_empty() {
                    out.push(format!(
                        "  unidentified (the data leave them unbounded): {}",
                        crate::core::first_of(unidentified.iter().map(|&i| &names[i]), SHOWN_NAMES)
                    ));
                }
            }
            if let Some(t) = read_table(dir, meta, "covariance") {
                out.extend(ridges(&t));
            }
        }
        K::ModalCorrelation => {
            if let Some(n) = num("n_pairs") {
                out.push(format!(
                    "{n} mode pairs ({} in band), largest |eigenvalue error| in band {}",
                    m.get("n_pairs_in_band")
                        .map(|v| v.to_string())
                        .unwrap_or_default(),
                    m.get("max_abs_eigenvalue_error_in_band")
                        .map(|v| v.to_string())
                        .unwrap_or_else(|| "-".into())
                ));
            }
        }
        K::Frf => {
            if let (Some(f), Some(l)) = (num("n_frfs"), num("n_lines")) {
                out.push(format!(
                    "{f} FRFs × {l} lines ({})",
                    m.get("quantity").and_then(|v| v.as_str()).unwrap_or("?")
                ));
            }
        }
        K::Leverage => {
            if let Some(t) = read_table(dir, meta, "candidates")
                && let (Some(c), Some(n), Some(r)) = (
                    strs(&t, "candidate"),
                    f64s(&t, "normalised"),
                    t.i64s("candidates", "rank").ok(),
                )
            {
                let mut order: Vec<usize> = (0..c.len()).collect();
                order.sort_by_key(|&i| r[i]);
                let top: Vec<String> = order
                    .iter()
                    .take(5)
                    .map(|&i| format!("{} ({:.3})", c[i], n[i]))
                    .collect();
                out.push(format!(
                    "{} candidates; highest leverage: {}",
                    c.len(),
                    top.join(", ")
                ));
            }
        }
        _ => {}
    }
    out
}

/// Parameters listed one per line in a result's summary; the rest are counted.
const SHOWN_PARAMETERS: usize = 20;

/// Names listed on one line of a summary (parameters, ridges); the rest are counted.
const SHOWN_NAMES: usize = 5;

/// The line naming a posterior's ridges, strongest first: parameter pairs whose correlation
/// (the `covariance` table's, over every direction above round-off) exceeds
/// [`crate::run_report::RUN_RIDGE`] in magnitude — parameters the data can trade
/// against each other, the sign telling which way.
fn ridges(covariance: &Table) -> Option<String> {
    let (Some(a), Some(b), Some(r)) = (
        strs(covariance, "parameter_i"),
        strs(covariance, "parameter_j"),
        f64s(covariance, "correlation"),
    ) else {
        return None;
    };
    let mut pairs: Vec<(&String, &String, f64)> = a
        .iter()
        .zip(b)
        .zip(r)
        .filter(|((a, b), r)| a < b && r.abs() > crate::run_report::RUN_RIDGE)
        .map(|((a, b), &r)| (a, b, r))
        .collect();
    if pairs.is_empty() {
        return None;
    }
    pairs.sort_by(|x, y| {
        y.2.abs()
            .total_cmp(&x.2.abs())
            .then((x.0, x.1).cmp(&(y.0, y.1)))
    });
    let named = pairs.iter().map(|(a, b, r)| format!("{a} ~ {b} {r:+.3}"));
    Some(format!(
        "  ridges (|correlation| > {}): {}",
        crate::run_report::RUN_RIDGE,
        crate::core::first_of(named, SHOWN_NAMES)
    ))
}

/// The line that counts the parameters past [`SHOWN_PARAMETERS`] of `total`, if any.
fn more_parameters(total: usize) -> Option<String> {
    (total > SHOWN_PARAMETERS)
        .then(|| format!("  … ({} more parameters)", total - SHOWN_PARAMETERS))
}

/// The width of a table column: its longest entry, at least `least` (the width it had).
pub(super) fn column_width<'a>(entries: impl Iterator<Item = &'a str>, least: usize) -> usize {
    entries.map(|e| e.chars().count()).fold(least, usize::max)
}

/// Whether `dir` holds an artefact.
pub(super) fn is_artefact(dir: &Path) -> bool {
    dir.join(crate::artefact::codec::META_FILE).is_file()
}

/// Reads the meta of `dir/stage/port`, if it is an artefact.
pub(super) fn output_meta(dir: &Path) -> Option<DirMeta> {
    read_meta(dir).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_report::record::meta_warnings;

    /// The key results `femu show` prints for artefact `a`, written to a folder and read back.
    fn summary_of(a: &crate::artefact::Artefact) -> Vec<String> {
        let dir = tempfile::tempdir().unwrap();
        crate::artefact::codec::write_dir(a, dir.path(), crate::artefact::Format::Arrow, None)
            .unwrap();
        let meta = read_meta(dir.path()).unwrap();
        key_results(dir.path(), &meta)
    }

    /// A sampled posterior is summarised by its method, samples and evidence, then each
    /// parameter's mean, sd and credible interval.
    #[test]
    fn a_tmcmc_posterior_shows_its_evidence_and_intervals() {
        use crate::artefact::{Artefact, ArtefactKind, Storage};
        let parameters = Table::new()
            .with("parameter", Column::Str(vec!["t2_2".into()]))
            .with("updated", Column::F64(vec![1.7e-3]))
            .with("mean", Column::F64(vec![1.699955e-3]))
            .with("sd", Column::F64(vec![2.478e-8]))
            .with("lower", Column::F64(vec![1.699917e-3]))
            .with("upper", Column::F64(vec![1.699998e-3]))
            .with("relative_sd", Column::F64(vec![1.46e-5]));
        let a = Artefact::new(ArtefactKind::Posterior)
            .with_meta("method", "tmcmc".into())
            .with_meta("samples", 200.into())
            .with_meta("log_evidence", 349049.656.into())
            .with_meta("credible_level", 0.9.into())
            .with_table("parameters", parameters, Storage::Parquet);
        assert_eq!(
            summary_of(&a),
            [
                "TMCMC posterior, 200 samples, ln evidence 3.490497e5",
                "  t2_2: 1.699955e-3 ± 2.478e-8 (90 % interval 1.699917e-3 to 1.699998e-3)",
            ]
        );
    }

    /// A Laplace posterior with an unidentified parameter names it apart (its interval would
    /// read "-inf to inf"), and its ridges strongest first, each pair once.
    #[test]
    fn unidentified_parameters_are_named_apart_and_ridges_listed() {
        use crate::artefact::{Artefact, ArtefactKind, Storage};
        let inf = f64::INFINITY;
        let parameters = Table::new()
            .with(
                "parameter",
                Column::Str(vec!["a".into(), "b".into(), "c".into()]),
            )
            .with("mean", Column::F64(vec![1.0, 2.0, 3.0]))
            .with("sd", Column::F64(vec![0.1, inf, 0.2]))
            .with("lower", Column::F64(vec![0.8, -inf, 2.6]))
            .with("upper", Column::F64(vec![1.2, inf, 3.4]));
        let (names, pairs): (Vec<String>, Vec<(usize, usize)>) = (
            ["a", "b", "c"].map(String::from).to_vec(),
            (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).collect(),
        );
        let rho = |i: usize, j: usize| match (i.min(j), i.max(j)) {
            _ if i == j => 1.0,
            (0, 2) => -0.95,
            (1, 2) => 0.99,
            _ => 0.5,
        };
        let covariance = Table::new()
            .with(
                "parameter_i",
                Column::Str(pairs.iter().map(|p| names[p.0].clone()).collect()),
            )
            .with(
                "parameter_j",
                Column::Str(pairs.iter().map(|p| names[p.1].clone()).collect()),
            )
            .with(
                "correlation",
                Column::F64(pairs.iter().map(|&(i, j)| rho(i, j)).collect()),
            );
        let a = Artefact::new(ArtefactKind::Posterior)
            .with_meta("method", "pc".into())
            .with_meta("samples", 100.into())
            .with_meta("credible_level", 0.9.into())
            .with_table("parameters", parameters, Storage::Parquet)
            .with_table("covariance", covariance, Storage::Parquet);
        assert_eq!(
            summary_of(&a),
            [
                "Laplace posterior about the pc result, 100 samples",
                "  a: 1.000000e0 ± 1.000e-1 (90 % interval 8.000000e-1 to 1.200000e0)",
                "  c: 3.000000e0 ± 2.000e-1 (90 % interval 2.600000e0 to 3.400000e0)",
                "  unidentified (the data leave them unbounded): b",
                "  ridges (|correlation| > 0.9): b ~ c +0.990, a ~ c -0.950",
            ]
        );
    }

    #[test]
    fn warnings_come_from_warning_and_note_keys_and_dropped_cards() {
        let meta: Map<String, Value> = serde_json::from_value(serde_json::json!({
            "import_notes": ["converted mm/N to m/N", "sign of 3:uz flipped"],
            "import_warnings": ["PARAM WTMASS 0.00259 applied"],
            "warnings": "one",
            "ignored_cards": {"CGAP": 2},
            "skipped_cards": {},
            "n_frfs": 3,
            "notes_count": 4
        }))
        .unwrap();
        let w = meta_warnings(&meta);
        assert_eq!(
            w,
            [
                "converted mm/N to m/N",
                "sign of 3:uz flipped",
                "PARAM WTMASS 0.00259 applied",
                "one",
                "cards dropped as `ignore_cards` or `on_unsupported` asks (the model lacks what they define): CGAP ×2",
            ]
        );
        let both = stage_warnings([&meta, &meta]);
        assert_eq!(both, w, "each warning once");
        let mut text = Vec::new();
        print_warnings(&[("import".into(), "frf.import".into(), w)], &mut text).unwrap();
        let text = String::from_utf8(text).unwrap();
        assert!(
            text.starts_with(
                "warnings (5, from 1 stage):\n  import (frf.import):\n    - converted"
            )
        );
    }
}
