//! The `update_result` kind: an updating run as tables a user can plot without femu — per
//! iteration and parameter the value and relative change and whether it was updated, per
//! iteration the correlation and the conditioning of `S`, its singular values and null-space
//! directions (docs/theory.md §11), per parameter the initial and final values, and for a
//! damping identification the identified damping per mode.

use super::{
    Kind, Layout, TableLayout, col, expect_kind, meta, meta_opt, meta_value, optional_meta, table,
};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::updating::{Diagnostics, IterationRecord, UpdateHistory, UpdatingParameter};
use std::collections::HashMap;

const K: ArtefactKind = ArtefactKind::UpdateResult;

/// An updating run as stored.
#[derive(Clone, Debug, PartialEq)]
pub struct UpdateResult {
    /// Its history.
    pub history: UpdateHistory,
    /// The method that ran (`pc`, `rfm`, `eigensensitivity`, `damping`).
    pub method: String,
    /// The identified damping of a damping identification.
    pub damping: Option<ModalDamping>,
}

/// The damping a damping identification found, per mode.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalDamping {
    /// `structural` or `viscous`.
    pub model: String,
    /// Per identified mode.
    pub modes: Vec<IdentifiedDamping>,
}

/// One identified mode of a damping identification.
#[derive(Clone, Debug, PartialEq)]
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

/// The `update_result` kind.
pub struct UpdateResultKind;

impl Kind for UpdateResultKind {
    const KIND: ArtefactKind = K;
    const NAME: &'static str = "update_result";
    type Value = UpdateResult;

    fn layout() -> Layout {
        Layout {
            tables: table_layouts(),
            meta: vec![
                meta("method", "the method that ran"),
                meta("stop", "why it stopped"),
                meta("iterations", "iterations run"),
                meta(
                    "final_mean_chi",
                    "mean (chi_s + chi_a)/2 at the end, null if none",
                ),
                meta_opt(
                    "returned_iteration",
                    "the iteration whose values were returned, when not the last",
                ),
                meta_opt(
                    "update_warnings",
                    "what the user should know about the result (e.g. that the best iterate was returned)",
                ),
                meta_opt(
                    "damping_model",
                    "structural or viscous (damping identification)",
                ),
                meta_opt(
                    "sensitive_start",
                    "parameters moved off a start the sensitivities vanish at",
                ),
                meta_opt(
                    "cms",
                    "with a partition: substructures, analyses, substructure reductions computed and reused",
                ),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(r: &UpdateResult) -> Artefact {
        let a = update_result_to_artefact(&r.history, &r.method);
        match &r.damping {
            Some(d) => with_modal_damping(a, &d.model, &d.modes),
            None => a,
        }
    }

    fn from_artefact(a: &Artefact) -> Result<UpdateResult, ArtefactError> {
        expect_kind(a, K)?;
        Ok(UpdateResult {
            history: read_history(a)?,
            method: a.meta_str("method")?.to_string(),
            damping: read_damping(a)?,
        })
    }
}

fn table_layouts() -> Vec<TableLayout> {
    let s = Storage::Parquet;
    vec![
        table(
            "parameters",
            s,
            true,
            vec![
                col("parameter", "string", "", "parameter name"),
                col("initial", "float64", "SI", "value in the initial model"),
                col("final", "float64", "SI", "updated value"),
                col("relative_change", "float64", "", "final/initial - 1"),
                col("lower", "float64", "SI", "lower bound"),
                col("upper", "float64", "SI", "upper bound"),
            ],
        ),
        iterations_layout(),
        table(
            "history",
            s,
            true,
            vec![
                col("iteration", "int64", "", "iteration"),
                col("parameter", "string", "", "parameter name"),
                col(
                    "value",
                    "float64",
                    "SI",
                    "value at the start of the iteration",
                ),
                col("relative_change", "float64", "", "relative change applied"),
                col("active", "int64", "", "1 when updated in this iteration"),
            ],
        ),
        table(
            "singular_values",
            s,
            true,
            vec![
                col("iteration", "int64", "", "iteration"),
                col("index", "int64", "", "from 1, descending values"),
                col("value", "float64", "", "singular value of weighted S"),
            ],
        ),
        table(
            "directions",
            s,
            true,
            vec![
                col("iteration", "int64", "", "iteration"),
                col(
                    "direction",
                    "string",
                    "",
                    "weakest_0, or null_k for the null space",
                ),
                col("parameter", "string", "", "parameter name"),
                col(
                    "component",
                    "float64",
                    "",
                    "component of the unit direction",
                ),
            ],
        ),
        table(
            "modal_damping",
            s,
            false,
            vec![
                col("mode", "int64", "", "mode number, 1-based over all modes"),
                col("natural_hz", "float64", "Hz", "its natural frequency"),
                col(
                    "initial",
                    "float64",
                    "",
                    "initial eta (structural) or zeta (viscous)",
                ),
                col("identified", "float64", "", "identified eta or zeta"),
                col(
                    "equivalent_loss_factor",
                    "float64",
                    "",
                    "the structural loss factor it equals at resonance (eta, or 2 zeta)",
                ),
            ],
        ),
    ]
}

/// Per iteration: correlation, residual, conditioning, parameters updated.
fn iterations_layout() -> TableLayout {
    let s = Storage::Parquet;
    table(
        "iterations",
        s,
        true,
        vec![
            col("iteration", "int64", "", "0 = initial model"),
            col("lines_used", "int64", "", "updating lines (or modes) used"),
            col(
                "mean_chi_s",
                "float64",
                "",
                "mean shape correlation, all lines",
            ),
            col("mean_chi_a", "float64", "", "mean amplitude correlation"),
            col("mean_chi", "float64", "", "mean (chi_s + chi_a)/2 (4.23)"),
            col(
                "smoothing",
                "float64",
                "",
                "added loss factor of the P-C's frequency smoothing, 0 = none",
            ),
            col(
                "smoothed_mean_chi",
                "float64",
                "",
                "mean (chi_s + chi_a)/2 of the smoothed FRFs (the merit), NaN = none",
            ),
            col(
                "residual_norm",
                "float64",
                "",
                "norm of the weighted residual",
            ),
            col("condition", "float64", "", "condition number of S"),
            col(
                "condition_limit",
                "float64",
                "",
                "kappa_mn of subset selection",
            ),
            col("active_count", "int64", "", "parameters updated"),
        ],
    )
}

/// An update history as an artefact; `method` names the method.
pub fn update_result_to_artefact(h: &UpdateHistory, method: &str) -> Artefact {
    let last = h.iterations.last();
    let a = Artefact::new(K);
    // Only when the best iterate was returned, so ordinary results keep their digests.
    let a = match h.returned_iteration {
        Some(i) => a.with_meta("returned_iteration", i.into()),
        None => a,
    };
    let a = if h.warnings.is_empty() {
        a
    } else {
        a.with_meta("update_warnings", h.warnings.clone().into())
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
        .with_table("parameters", parameters_table(h), Storage::Parquet)
        .with_table("iterations", iterations_table(h), Storage::Parquet)
        .with_table("history", history_table(h), Storage::Parquet)
        .with_table(
            "singular_values",
            singular_values_table(h),
            Storage::Parquet,
        )
        .with_table("directions", directions_table(h), Storage::Parquet)
}

fn names(h: &UpdateHistory) -> Vec<String> {
    h.parameters.iter().map(|p| p.name.clone()).collect()
}

fn parameters_table(h: &UpdateHistory) -> Table {
    let p = &h.parameters;
    Table::new()
        .with("parameter", Column::Str(names(h)))
        .with(
            "initial",
            Column::F64(p.iter().map(|p| p.initial).collect()),
        )
        .with("final", Column::F64(h.final_values.clone()))
        .with(
            "relative_change",
            Column::F64(
                p.iter()
                    .zip(&h.final_values)
                    .map(|(p, v)| v / p.initial - 1.0)
                    .collect(),
            ),
        )
        .with("lower", Column::F64(p.iter().map(|p| p.lower).collect()))
        .with("upper", Column::F64(p.iter().map(|p| p.upper).collect()))
}

fn iterations_table(h: &UpdateHistory) -> Table {
    let it = &h.iterations;
    let f = |g: fn(&IterationRecord) -> f64| Column::F64(it.iter().map(g).collect());
    let i =
        |g: fn(&IterationRecord) -> usize| Column::I64(it.iter().map(|r| g(r) as i64).collect());
    Table::new()
        .with("iteration", i(|r| r.iteration))
        .with("lines_used", i(|r| r.lines_used))
        .with("mean_chi_s", f(|r| r.mean_chi_s))
        .with("mean_chi_a", f(|r| r.mean_chi_a))
        .with("mean_chi", f(|r| r.mean_chi()))
        .with("smoothing", f(|r| r.smoothing))
        .with("smoothed_mean_chi", f(|r| r.smoothed_mean_chi))
        .with("residual_norm", f(|r| r.residual_norm))
        .with("condition", f(|r| r.diagnostics.condition))
        .with("condition_limit", f(|r| r.condition_limit))
        .with(
            "active_count",
            i(|r| r.active.iter().filter(|a| **a).count()),
        )
}

fn history_table(h: &UpdateHistory) -> Table {
    let names = names(h);
    let (mut it, mut name, mut value, mut change, mut active) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for r in &h.iterations {
        for (p, n) in names.iter().enumerate() {
            it.push(r.iteration as i64);
            name.push(n.clone());
            value.push(r.values[p]);
            change.push(r.relative_change[p]);
            active.push(r.active[p] as i64);
        }
    }
    Table::new()
        .with("iteration", Column::I64(it))
        .with("parameter", Column::Str(name))
        .with("value", Column::F64(value))
        .with("relative_change", Column::F64(change))
        .with("active", Column::I64(active))
}

fn singular_values_table(h: &UpdateHistory) -> Table {
    let (mut it, mut index, mut value) = (Vec::new(), Vec::new(), Vec::new());
    for r in &h.iterations {
        for (i, v) in r.diagnostics.singular_values.iter().enumerate() {
            it.push(r.iteration as i64);
            index.push(i as i64 + 1);
            value.push(*v);
        }
    }
    Table::new()
        .with("iteration", Column::I64(it))
        .with("index", Column::I64(index))
        .with("value", Column::F64(value))
}

/// The weakest direction (`weakest_0`) and the null-space directions (`null_k`) per iteration.
fn directions_table(h: &UpdateHistory) -> Table {
    let names = names(h);
    let (mut it, mut label, mut name, mut component) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for r in &h.iterations {
        let weakest = std::iter::once(("weakest", &r.diagnostics.weakest_direction));
        let nulls = r.diagnostics.null_space.iter().map(|d| ("null", d));
        for (k, (what, dir)) in weakest.chain(nulls).enumerate() {
            for (p, v) in dir.iter().enumerate() {
                it.push(r.iteration as i64);
                label.push(format!("{what}_{k}"));
                name.push(names.get(p).cloned().unwrap_or_default());
                component.push(*v);
            }
        }
    }
    Table::new()
        .with("iteration", Column::I64(it))
        .with("direction", Column::Str(label))
        .with("parameter", Column::Str(name))
        .with("component", Column::F64(component))
}

/// Adds the table `modal_damping` (mode, natural frequency, initial and identified damping, the
/// equivalent loss factor) to an update result; `kind` is `structural` or `viscous`.
pub fn with_modal_damping(a: Artefact, kind: &str, modes: &[IdentifiedDamping]) -> Artefact {
    let f = |g: fn(&IdentifiedDamping) -> f64| Column::F64(modes.iter().map(g).collect());
    let table = Table::new()
        .with(
            "mode",
            Column::I64(modes.iter().map(|m| m.mode as i64).collect()),
        )
        .with("natural_hz", f(|m| m.natural_hz))
        .with("initial", f(|m| m.initial))
        .with("identified", f(|m| m.identified))
        .with("equivalent_loss_factor", f(|m| m.equivalent_loss_factor));
    a.with_meta("damping_model", kind.into())
        .with_table("modal_damping", table, Storage::Parquet)
}

fn schema(m: String) -> ArtefactError {
    ArtefactError::schema(K, m)
}

/// The whole history: parameters and final values, then per iteration its row of
/// `iterations`, its `history` rows, singular values and directions.
fn read_history(a: &Artefact) -> Result<UpdateHistory, ArtefactError> {
    let t = a.table("parameters")?;
    let n = "parameters";
    let (name, initial, lower, upper) = (
        t.strs(n, "parameter")?,
        t.f64s(n, "initial")?,
        t.f64s(n, "lower")?,
        t.f64s(n, "upper")?,
    );
    let parameters: Vec<UpdatingParameter> = (0..name.len())
        .map(|p| UpdatingParameter {
            name: name[p].clone(),
            initial: initial[p],
            lower: lower[p],
            upper: upper[p],
        })
        .collect();
    let mut iterations = read_iterations(a)?;
    let position: HashMap<usize, usize> = iterations
        .iter()
        .enumerate()
        .map(|(k, r)| (r.iteration, k))
        .collect();
    let slot = |i: i64, table: &str| {
        usize::try_from(i)
            .ok()
            .and_then(|i| position.get(&i).copied())
            .ok_or_else(|| {
                schema(format!(
                    "table `{table}`: iteration {i} is not in `iterations`"
                ))
            })
    };
    read_history_rows(a, &mut iterations, &slot)?;
    read_diagnostics(a, &mut iterations, &slot)?;
    Ok(UpdateHistory {
        parameters,
        iterations,
        final_values: t.f64s(n, "final")?.to_vec(),
        stop: meta_value(a, "stop")?,
        returned_iteration: meta_value(a, "returned_iteration")?,
        warnings: optional_meta(a, "update_warnings")?,
    })
}

/// One record per row of `iterations`, without the per-parameter vectors and diagnostics.
fn read_iterations(a: &Artefact) -> Result<Vec<IterationRecord>, ArtefactError> {
    let n = "iterations";
    let t = a.table(n)?;
    let (it, lines) = (t.i64s(n, "iteration")?, t.i64s(n, "lines_used")?);
    let f = |c: &str| t.f64s(n, c);
    let (chi_s, chi_a, smoothing, smoothed) = (
        f("mean_chi_s")?,
        f("mean_chi_a")?,
        f("smoothing")?,
        f("smoothed_mean_chi")?,
    );
    let (residual, condition, limit) =
        (f("residual_norm")?, f("condition")?, f("condition_limit")?);
    (0..it.len())
        .map(|k| {
            let count = |v: i64| {
                usize::try_from(v).map_err(|_| schema(format!("table `{n}` row {k}: {v} < 0")))
            };
            Ok(IterationRecord {
                iteration: count(it[k])?,
                values: vec![],
                relative_change: vec![],
                active: vec![],
                lines_used: count(lines[k])?,
                mean_chi_s: chi_s[k],
                mean_chi_a: chi_a[k],
                residual_norm: residual[k],
                condition_limit: limit[k],
                smoothing: smoothing[k],
                smoothed_mean_chi: smoothed[k],
                diagnostics: Diagnostics {
                    condition: condition[k],
                    ..Default::default()
                },
            })
        })
        .collect()
}

/// Values, relative changes and activity per iteration, in the rows' (parameter) order.
fn read_history_rows(
    a: &Artefact,
    iterations: &mut [IterationRecord],
    slot: &dyn Fn(i64, &str) -> Result<usize, ArtefactError>,
) -> Result<(), ArtefactError> {
    let n = "history";
    let t = a.table(n)?;
    let (it, value) = (t.i64s(n, "iteration")?, t.f64s(n, "value")?);
    let (change, active) = (t.f64s(n, "relative_change")?, t.i64s(n, "active")?);
    for row in 0..it.len() {
        let r = &mut iterations[slot(it[row], n)?];
        r.values.push(value[row]);
        r.relative_change.push(change[row]);
        r.active.push(active[row] != 0);
    }
    Ok(())
}

/// Singular values, the weakest direction and the null space per iteration.
fn read_diagnostics(
    a: &Artefact,
    iterations: &mut [IterationRecord],
    slot: &dyn Fn(i64, &str) -> Result<usize, ArtefactError>,
) -> Result<(), ArtefactError> {
    let n = "singular_values";
    let t = a.table(n)?;
    for (i, v) in t.i64s(n, "iteration")?.iter().zip(t.f64s(n, "value")?) {
        iterations[slot(*i, n)?]
            .diagnostics
            .singular_values
            .push(*v);
    }
    let n = "directions";
    let t = a.table(n)?;
    let (it, label, component) = (
        t.i64s(n, "iteration")?,
        t.strs(n, "direction")?,
        t.f64s(n, "component")?,
    );
    for row in 0..it.len() {
        let d = &mut iterations[slot(it[row], n)?].diagnostics;
        let fresh = row == 0 || it[row - 1] != it[row] || label[row - 1] != label[row];
        if label[row].starts_with("weakest") {
            d.weakest_direction.push(component[row]);
        } else if label[row].starts_with("null") {
            if fresh {
                d.null_space.push(Vec::new());
            }
            if let Some(v) = d.null_space.last_mut() {
                v.push(component[row]);
            }
        } else {
            return Err(schema(format!(
                "table `{n}` row {row}: direction `{}` is not weakest_0 or null_k",
                label[row]
            )));
        }
    }
    Ok(())
}

fn read_damping(a: &Artefact) -> Result<Option<ModalDamping>, ArtefactError> {
    let Some((t, _)) = a.tables.get("modal_damping") else {
        return Ok(None);
    };
    let n = "modal_damping";
    let mode = t.i64s(n, "mode")?;
    let f = |c: &str| t.f64s(n, c);
    let (hz, initial, identified, eq) = (
        f("natural_hz")?,
        f("initial")?,
        f("identified")?,
        f("equivalent_loss_factor")?,
    );
    Ok(Some(ModalDamping {
        model: a.meta_str("damping_model")?.to_string(),
        modes: (0..mode.len())
            .map(|k| IdentifiedDamping {
                mode: mode[k].max(0) as usize,
                natural_hz: hz[k],
                initial: initial[k],
                identified: identified[k],
                equivalent_loss_factor: eq[k],
            })
            .collect(),
    }))
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
            warnings: Vec::new(),
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
