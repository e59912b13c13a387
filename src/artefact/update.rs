//! The `update_result` artefact: an updating run as tables a user can plot without femu —
//! per iteration and parameter the value and relative change and whether it was updated, per
//! iteration the correlation and the conditioning of `S`, its singular values and null-space
//! directions (docs/theory.md §11), and per parameter the initial and final values.

use super::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::updating::UpdateHistory;

const K: ArtefactKind = ArtefactKind::UpdateResult;

/// An update history as an artefact; `method` names the method.
pub fn update_result_to_artefact(h: &UpdateHistory, method: &str) -> Artefact {
    let names: Vec<&str> = h.parameters.iter().map(|p| p.name.as_str()).collect();
    let mut history = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut sv = (Vec::new(), Vec::new(), Vec::new());
    let mut null = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for r in &h.iterations {
        for (p, name) in names.iter().enumerate() {
            history.0.push(r.iteration as i64);
            history.1.push(name.to_string());
            history.2.push(r.values[p]);
            history.3.push(r.relative_change[p]);
            history.4.push(r.active[p] as i64);
        }
        for (i, v) in r.diagnostics.singular_values.iter().enumerate() {
            sv.0.push(r.iteration as i64);
            sv.1.push(i as i64 + 1);
            sv.2.push(*v);
        }
        let weakest = std::iter::once(("weakest", &r.diagnostics.weakest_direction));
        let nulls = r.diagnostics.null_space.iter().map(|d| ("null", d));
        for (k, (what, dir)) in weakest.chain(nulls).enumerate() {
            for (p, v) in dir.iter().enumerate() {
                null.0.push(r.iteration as i64);
                null.1.push(format!("{what}_{k}"));
                null.2.push(names.get(p).unwrap_or(&"").to_string());
                null.3.push(*v);
            }
        }
    }
    let iterations = Table::new()
        .with(
            "iteration",
            Column::I64(h.iterations.iter().map(|r| r.iteration as i64).collect()),
        )
        .with(
            "lines_used",
            Column::I64(h.iterations.iter().map(|r| r.lines_used as i64).collect()),
        )
        .with(
            "mean_chi_s",
            Column::F64(h.iterations.iter().map(|r| r.mean_chi_s).collect()),
        )
        .with(
            "mean_chi_a",
            Column::F64(h.iterations.iter().map(|r| r.mean_chi_a).collect()),
        )
        .with(
            "mean_chi",
            Column::F64(h.iterations.iter().map(|r| r.mean_chi()).collect()),
        )
        .with(
            "smoothing",
            Column::F64(h.iterations.iter().map(|r| r.smoothing).collect()),
        )
        .with(
            "smoothed_mean_chi",
            Column::F64(h.iterations.iter().map(|r| r.smoothed_mean_chi).collect()),
        )
        .with(
            "residual_norm",
            Column::F64(h.iterations.iter().map(|r| r.residual_norm).collect()),
        )
        .with(
            "condition",
            Column::F64(
                h.iterations
                    .iter()
                    .map(|r| r.diagnostics.condition)
                    .collect(),
            ),
        )
        .with(
            "condition_limit",
            Column::F64(h.iterations.iter().map(|r| r.condition_limit).collect()),
        )
        .with(
            "active_count",
            Column::I64(
                h.iterations
                    .iter()
                    .map(|r| r.active.iter().filter(|a| **a).count() as i64)
                    .collect(),
            ),
        );
    let parameters = Table::new()
        .with(
            "parameter",
            Column::Str(names.iter().map(|s| s.to_string()).collect()),
        )
        .with(
            "initial",
            Column::F64(h.parameters.iter().map(|p| p.initial).collect()),
        )
        .with("final", Column::F64(h.final_values.clone()))
        .with(
            "relative_change",
            Column::F64(
                h.parameters
                    .iter()
                    .zip(&h.final_values)
                    .map(|(p, v)| v / p.initial - 1.0)
                    .collect(),
            ),
        )
        .with(
            "lower",
            Column::F64(h.parameters.iter().map(|p| p.lower).collect()),
        )
        .with(
            "upper",
            Column::F64(h.parameters.iter().map(|p| p.upper).collect()),
        );
    let last = h.iterations.last();
    let a = Artefact::new(K);
    // Only when the best iterate was returned, so ordinary results keep their digests.
    let a = match h.returned_iteration {
        Some(i) => a.with_meta("returned_iteration", i.into()),
        None => a,
    };
    a.with_meta("method", method.into())
        .with_meta(
            "stop",
            serde_json::to_value(h.stop).unwrap_or(serde_json::Value::Null),
        )
        .with_meta("iterations", (h.iterations.len().saturating_sub(1)).into())
        .with_meta(
            "final_mean_chi",
            last.map(|r| r.mean_chi())
                .filter(|v| v.is_finite())
                .map(serde_json::Value::from)
                .unwrap_or(serde_json::Value::Null),
        )
        .with_table("parameters", parameters, Storage::Parquet)
        .with_table("iterations", iterations, Storage::Parquet)
        .with_table(
            "history",
            Table::new()
                .with("iteration", Column::I64(history.0))
                .with("parameter", Column::Str(history.1))
                .with("value", Column::F64(history.2))
                .with("relative_change", Column::F64(history.3))
                .with("active", Column::I64(history.4)),
            Storage::Parquet,
        )
        .with_table(
            "singular_values",
            Table::new()
                .with("iteration", Column::I64(sv.0))
                .with("index", Column::I64(sv.1))
                .with("value", Column::F64(sv.2)),
            Storage::Parquet,
        )
        .with_table(
            "directions",
            Table::new()
                .with("iteration", Column::I64(null.0))
                .with("direction", Column::Str(null.1))
                .with("parameter", Column::Str(null.2))
                .with("component", Column::F64(null.3)),
            Storage::Parquet,
        )
}

/// One identified mode of a damping identification.
#[derive(Clone, Debug)]
pub struct IdentifiedDamping {
    /// 1-based mode number.
    pub mode: usize,
    /// Natural frequency, Hz.
    pub natural_hz: f64,
    /// `η` or `ζ` before.
    pub initial: f64,
    /// `η` or `ζ` identified.
    pub identified: f64,
    /// The structural loss factor it is equivalent to at resonance (`η`, or `2ζ`).
    pub equivalent_loss_factor: f64,
}

/// Adds the table `modal_damping` (mode, natural frequency, initial and identified damping, the
/// equivalent loss factor) to an update result; `kind` is `structural` or `viscous`.
pub fn with_modal_damping(a: Artefact, kind: &str, modes: &[IdentifiedDamping]) -> Artefact {
    let table = Table::new()
        .with(
            "mode",
            Column::I64(modes.iter().map(|m| m.mode as i64).collect()),
        )
        .with(
            "natural_hz",
            Column::F64(modes.iter().map(|m| m.natural_hz).collect()),
        )
        .with(
            "initial",
            Column::F64(modes.iter().map(|m| m.initial).collect()),
        )
        .with(
            "identified",
            Column::F64(modes.iter().map(|m| m.identified).collect()),
        )
        .with(
            "equivalent_loss_factor",
            Column::F64(modes.iter().map(|m| m.equivalent_loss_factor).collect()),
        );
    a.with_meta("damping_model", kind.into())
        .with_table("modal_damping", table, Storage::Parquet)
}

/// Refuses an artefact of another kind than `update_result`.
fn expect_update_result(a: &Artefact) -> Result<(), ArtefactError> {
    if a.kind == K {
        Ok(())
    } else {
        Err(ArtefactError::schema(
            a.kind,
            format!("expected an `{}` artefact", K.name()),
        ))
    }
}

/// Final value of each parameter, by name, from an `update_result`.
pub fn final_values(a: &Artefact) -> Result<Vec<(String, f64)>, ArtefactError> {
    expect_update_result(a)?;
    let t = a.table("parameters")?;
    let names = t.strs("parameters", "parameter")?;
    let values = t.f64s("parameters", "final")?;
    Ok(names.iter().cloned().zip(values.iter().copied()).collect())
}

/// An updating run's history as read back for plotting: per parameter its initial value and its
/// value at each recorded iteration, and the mean correlation per iteration.
#[derive(Clone, Debug, PartialEq)]
pub struct Convergence {
    /// The method that ran.
    pub method: String,
    /// Parameter names, in the result's order.
    pub parameters: Vec<String>,
    /// Initial values.
    pub initial: Vec<f64>,
    /// `values[p][k]`: parameter `p` at the `k`-th recorded iteration (NaN when not recorded).
    pub values: Vec<Vec<f64>>,
    /// Mean `χ_s` per recorded iteration.
    pub mean_chi_s: Vec<f64>,
    /// Mean `χ_a` per recorded iteration.
    pub mean_chi_a: Vec<f64>,
}

/// Reads the history of an `update_result` (tables `parameters`, `iterations`, `history`).
pub fn convergence_from_artefact(a: &Artefact) -> Result<Convergence, ArtefactError> {
    expect_update_result(a)?;
    let params = a.table("parameters")?;
    let parameters = params.strs("parameters", "parameter")?.to_vec();
    let initial = params.f64s("parameters", "initial")?.to_vec();
    let iters = a.table("iterations")?;
    let steps = iters.i64s("iterations", "iteration")?;
    let position: std::collections::HashMap<i64, usize> =
        steps.iter().enumerate().map(|(k, &i)| (i, k)).collect();
    let history = a.table("history")?;
    let (h_iter, h_name, h_value) = (
        history.i64s("history", "iteration")?,
        history.strs("history", "parameter")?,
        history.f64s("history", "value")?,
    );
    let index: std::collections::HashMap<&str, usize> = parameters
        .iter()
        .enumerate()
        .map(|(p, n)| (n.as_str(), p))
        .collect();
    let mut values = vec![vec![f64::NAN; steps.len()]; parameters.len()];
    for ((i, name), v) in h_iter.iter().zip(h_name).zip(h_value) {
        let (Some(&k), Some(&p)) = (position.get(i), index.get(name.as_str())) else {
            return Err(ArtefactError::schema(
                a.kind,
                format!(
                    "history row ({i}, {name}) names an iteration or parameter the `iterations` and `parameters` tables do not hold"
                ),
            ));
        };
        values[p][k] = *v;
    }
    Ok(Convergence {
        method: a
            .meta
            .get("method")
            .and_then(|m| m.as_str())
            .unwrap_or("")
            .to_string(),
        parameters,
        initial,
        values,
        mean_chi_s: iters.f64s("iterations", "mean_chi_s")?.to_vec(),
        mean_chi_a: iters.f64s("iterations", "mean_chi_a")?.to_vec(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::updating::{Diagnostics, IterationRecord, StopReason, UpdatingParameter};

    /// Written and read back, the artefact keeps its digest — NaN and infinite entries (no
    /// subset limit, a singular `S`) included, and a metadata float whose last digit JSON
    /// parsing used to lose (`serde_json`'s `float_roundtrip` keeps it).
    #[test]
    fn round_trip_keeps_the_digest() {
        let record = |i: usize| IterationRecord {
            iteration: i,
            values: vec![1.0, 2.0],
            relative_change: vec![0.1, -0.0],
            active: vec![true, false],
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
                null_space: vec![vec![0.0, 1.0]],
                weakest_direction: vec![0.0, 1.0],
            },
        };
        let h = UpdateHistory {
            parameters: ["a", "b"]
                .map(|n| UpdatingParameter {
                    name: n.into(),
                    initial: 1.0,
                    lower: 0.1,
                    upper: 10.0,
                })
                .to_vec(),
            iterations: vec![record(0), record(1)],
            final_values: vec![1.1, 2.0],
            returned_iteration: None,
            stop: StopReason::MaxIterations,
        };
        let a = update_result_to_artefact(&h, "pc");
        let dir = tempfile::tempdir().unwrap();
        crate::artefact::codec::write_dir(&a, dir.path(), crate::artefact::Format::Arrow, None)
            .unwrap();
        let b = crate::artefact::codec::read_dir(dir.path()).unwrap();
        assert_eq!(a.digest(), b.digest());
        // The convergence reader gives back what was recorded, per parameter and iteration.
        let c = convergence_from_artefact(&b).unwrap();
        assert_eq!(c.method, "pc");
        assert_eq!(c.parameters, ["a", "b"]);
        assert_eq!(c.initial, [1.0, 1.0]);
        assert_eq!(c.values, [vec![1.0, 1.0], vec![2.0, 2.0]]);
        assert_eq!(c.mean_chi_s, [0.9, 0.9]);
        assert!(c.mean_chi_a[0].is_nan() && c.mean_chi_a[1] == 0.9816106067610754);
    }
}
