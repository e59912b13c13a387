//! Comparison of two artefacts with tolerances: tables column by column, matrices entry-wise
//! (as sparse maps, so storage order does not matter), mode shapes up to sign, metadata numbers
//! with the same tolerances. Used by `femu diff` and the golden-artefact tests.

use super::{Artefact, ArtefactKind, Column, Table};
use std::collections::BTreeMap;

/// Relative and absolute tolerance: `|a − b| ≤ atol + rtol · max(|a|, |b|)`; or, with `max`, an
/// upper bound `|a|, |b| ≤ max` instead (for round-off-level figures such as residuals, which
/// must stay small rather than equal: `rtol: 1` would accept anything of one sign).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Tol {
    /// Relative tolerance.
    #[serde(default)]
    pub rtol: f64,
    /// Absolute tolerance.
    #[serde(default)]
    pub atol: f64,
    /// Upper bound on both values' magnitudes, replacing the comparison.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
}

impl Tol {
    /// Whether `a` and `b` agree.
    pub fn accepts(&self, a: f64, b: f64) -> bool {
        if let Some(m) = self.max {
            return a.abs() <= m && b.abs() <= m;
        }
        if a == b || (a.is_nan() && b.is_nan()) {
            return true;
        }
        // An infinity equals only itself (the relative bound would grow with it and accept any
        // finite value).
        a.is_finite()
            && b.is_finite()
            && (a - b).abs() <= self.atol + self.rtol * a.abs().max(b.abs())
    }
}

/// Tolerances for a comparison, per `table.column` where given.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerances {
    /// Default tolerance.
    #[serde(default = "default_tol")]
    pub default: Tol,
    /// Per `table.column` (or `meta.key`) overrides.
    #[serde(default)]
    pub columns: BTreeMap<String, Tol>,
    /// Ignore binary blobs (figures).
    #[serde(default)]
    pub skip_blobs: bool,
}

impl Tolerances {
    /// Checks that every tolerance is a finite number `>= 0` (a negative or NaN tolerance would
    /// make every comparison fail, or pass); the error names the offending entry.
    pub fn check(&self) -> Result<(), String> {
        let entries = std::iter::once(("default", &self.default))
            .chain(self.columns.iter().map(|(k, t)| (k.as_str(), t)));
        for (name, t) in entries {
            for (what, v) in [
                ("rtol", t.rtol),
                ("atol", t.atol),
                ("max", t.max.unwrap_or(0.0)),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(format!("{name}: {what} = {v} must be a finite number >= 0"));
                }
            }
        }
        Ok(())
    }
}

fn default_tol() -> Tol {
    Tol {
        rtol: 1e-9,
        atol: 0.0,
        max: None,
    }
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            default: default_tol(),
            columns: BTreeMap::new(),
            skip_blobs: false,
        }
    }
}

impl Tolerances {
    /// The tolerance of `table.column`.
    pub fn of(&self, table: &str, column: &str) -> Tol {
        let stem = column.split('_').next().unwrap_or(column);
        self.columns
            .get(&format!("{table}.{column}"))
            .or_else(|| self.columns.get(&format!("{table}.{stem}_*")))
            .copied()
            .unwrap_or(self.default)
    }
}

/// One difference found.
#[derive(Clone, Debug, PartialEq)]
pub struct Difference {
    /// Where (`frf.re row 12`, `meta.summary.mean_chi`, `K (3, 4)`).
    pub location: String,
    /// What differs.
    pub detail: String,
}

/// The outcome of a comparison.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Comparison {
    /// Differences, at most [`MAX_LISTED`] listed per table or column.
    pub differences: Vec<Difference>,
    /// Total count of differing values.
    pub count: usize,
    /// Largest absolute difference per `table.column`.
    pub max_abs: BTreeMap<String, f64>,
}

/// How many differences are listed per column before counting only.
pub const MAX_LISTED: usize = 5;

impl Comparison {
    /// True when nothing differs.
    pub fn same(&self) -> bool {
        self.count == 0
    }

    fn push(&mut self, listed_in_column: &mut usize, location: String, detail: String) {
        self.count += 1;
        if *listed_in_column < MAX_LISTED {
            self.differences.push(Difference { location, detail });
        }
        *listed_in_column += 1;
    }
}

/// Compares `a` (new) against `b` (reference).
pub fn compare(a: &Artefact, b: &Artefact, tol: &Tolerances) -> Comparison {
    let mut out = Comparison::default();
    let mut n = 0;
    if a.kind != b.kind {
        out.push(
            &mut n,
            "kind".into(),
            format!("`{}` vs `{}`", a.kind, b.kind),
        );
        return out;
    }
    compare_json(
        "meta",
        &serde_json::Value::Object(a.meta.clone()),
        &serde_json::Value::Object(b.meta.clone()),
        tol,
        &mut out,
    );
    let names: std::collections::BTreeSet<&String> =
        a.tables.keys().chain(b.tables.keys()).collect();
    for name in names {
        let mut n = 0;
        match (a.tables.get(name), b.tables.get(name)) {
            (Some((ta, _)), Some((tb, _))) => match (a.kind, name.as_str()) {
                // Every matrices table but the DOF list and the rigid elements' equations is a
                // sparse matrix.
                (ArtefactKind::Matrices, t) if t != "dofs" && t != "dependent" => {
                    compare_sparse(name, ta, tb, tol, &mut out)
                }
                // Shapes at the free and at the dependent DOFs, both up to sign.
                (ArtefactKind::Modes, "shapes" | "dependent_shapes") => {
                    compare_shapes(name, a, ta, tb, tol, &mut out)
                }
                _ => compare_table(name, ta, tb, tol, false, &mut out),
            },
            (Some(_), None) => out.push(&mut n, name.clone(), "table only in the first".into()),
            (None, Some(_)) => out.push(&mut n, name.clone(), "table only in the second".into()),
            (None, None) => {}
        }
    }
    if !tol.skip_blobs {
        let names: std::collections::BTreeSet<&String> =
            a.blobs.keys().chain(b.blobs.keys()).collect();
        for name in names {
            let mut n = 0;
            if a.blobs.get(name) != b.blobs.get(name) {
                out.push(&mut n, name.clone(), "file content differs".into());
            }
        }
    }
    out
}

fn compare_json(
    path: &str,
    a: &serde_json::Value,
    b: &serde_json::Value,
    tol: &Tolerances,
    out: &mut Comparison,
) {
    use serde_json::Value;
    let mut n = 0;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                let p = format!("{path}.{k}");
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => compare_json(&p, u, v, tol, out),
                    _ => out.push(&mut n, p, "key present on one side only".into()),
                }
            }
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                compare_json(&format!("{path}[{i}]"), u, v, tol, out);
            }
        }
        (Value::Number(x), Value::Number(y)) => {
            let (u, v) = (
                x.as_f64().unwrap_or(f64::NAN),
                y.as_f64().unwrap_or(f64::NAN),
            );
            let t = tol.columns.get(path).copied().unwrap_or(tol.default);
            if !t.accepts(u, v) {
                out.push(&mut n, path.to_string(), format!("{u:e} vs {v:e}"));
            }
        }
        (x, y) if x != y => out.push(&mut n, path.to_string(), format!("{x} vs {y}")),
        _ => {}
    }
}

fn compare_table(
    name: &str,
    a: &Table,
    b: &Table,
    tol: &Tolerances,
    up_to_sign: bool,
    out: &mut Comparison,
) {
    let mut n = 0;
    let ca: Vec<(&str, &str)> = a
        .columns
        .iter()
        .map(|(c, v)| (c.as_str(), v.type_name()))
        .collect();
    let cb: Vec<(&str, &str)> = b
        .columns
        .iter()
        .map(|(c, v)| (c.as_str(), v.type_name()))
        .collect();
    if ca != cb {
        out.push(
            &mut n,
            name.to_string(),
            format!("columns differ: {ca:?} vs {cb:?}"),
        );
        return;
    }
    if a.rows() != b.rows() {
        out.push(
            &mut n,
            name.to_string(),
            format!("{} rows vs {}", a.rows(), b.rows()),
        );
        return;
    }
    for ((cname, x), (_, y)) in a.columns.iter().zip(&b.columns) {
        let loc = format!("{name}.{cname}");
        let mut listed = 0;
        match (x, y) {
            (Column::F64(x), Column::F64(y)) => {
                let t = tol.of(name, cname);
                let sign = if up_to_sign && cname.starts_with("phi_") {
                    best_sign(x, y)
                } else {
                    1.0
                };
                let mut worst = 0.0f64;
                for (row, (u, v)) in x.iter().zip(y).enumerate() {
                    let u = sign * u;
                    worst = worst.max((u - v).abs());
                    if !t.accepts(u, *v) {
                        out.push(
                            &mut listed,
                            format!("{loc} row {row}"),
                            format!("{u:e} vs {v:e} (rtol {:e}, atol {:e})", t.rtol, t.atol),
                        );
                    }
                }
                out.max_abs.insert(loc, worst);
            }
            (Column::I64(x), Column::I64(y)) => {
                for (row, (u, v)) in x.iter().zip(y).enumerate() {
                    if u != v {
                        out.push(
                            &mut listed,
                            format!("{loc} row {row}"),
                            format!("{u} vs {v}"),
                        );
                    }
                }
            }
            (Column::Str(x), Column::Str(y)) => {
                for (row, (u, v)) in x.iter().zip(y).enumerate() {
                    if u != v {
                        out.push(
                            &mut listed,
                            format!("{loc} row {row}"),
                            format!("`{u}` vs `{v}`"),
                        );
                    }
                }
            }
            _ => out.push(&mut listed, loc, "column types differ".into()),
        }
    }
}

/// Groups of mode indices with equal eigenvalues (relative 1e-8; all rigid-body modes together).
fn repeated_groups(eigenvalues: &[f64]) -> Vec<Vec<usize>> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, l) in eigenvalues.iter().enumerate() {
        match groups.last_mut() {
            Some(g)
                if {
                    let p = eigenvalues[g[0]];
                    (l - p).abs() <= 1e-8 * l.abs().max(p.abs())
                } =>
            {
                g.push(i)
            }
            _ => groups.push(vec![i]),
        }
    }
    groups
}

/// Mode shapes: a single mode up to sign; a repeated mode (e.g. the rigid-body modes) as a
/// subspace, since any basis of it is as right as another: each new shape must lie in the span
/// of the reference group to the column tolerance.
fn compare_shapes(
    name: &str,
    a: &Artefact,
    ta: &Table,
    tb: &Table,
    tol: &Tolerances,
    out: &mut Comparison,
) {
    let lambdas = a
        .table("frequencies")
        .ok()
        .and_then(|f| f.f64s("frequencies", "eigenvalue_rad2_s2").ok())
        .map(|v| v.to_vec());
    let Some(lambdas) = lambdas else {
        return compare_table(name, ta, tb, tol, true, out);
    };
    let groups = repeated_groups(&lambdas);
    let (mut sa, mut sb) = (Table::new(), Table::new());
    for g in &groups {
        if g.len() == 1 {
            let column = format!("phi_{}", g[0] + 1);
            if let (Some(x), Some(y)) = (ta.column(&column), tb.column(&column)) {
                sa.columns.push((column.clone(), x.clone()));
                sb.columns.push((column, y.clone()));
            }
        }
    }
    if let (Some(x), Some(y)) = (ta.column("dof"), tb.column("dof")) {
        sa.columns.insert(0, ("dof".into(), x.clone()));
        sb.columns.insert(0, ("dof".into(), y.clone()));
    }
    compare_table(name, &sa, &sb, tol, true, out);
    let t = tol.of(name, "phi_1");
    for g in groups.iter().filter(|g| g.len() > 1) {
        let cols = |tab: &Table| -> Option<Vec<Vec<f64>>> {
            g.iter()
                .map(|i| match tab.column(&format!("phi_{}", i + 1)) {
                    Some(Column::F64(v)) => Some(v.clone()),
                    _ => None,
                })
                .collect()
        };
        let (Some(xa), Some(xb)) = (cols(ta), cols(tb)) else {
            let mut n = 0;
            out.push(
                &mut n,
                format!("{name} phi_{}..", g[0] + 1),
                "repeated modes missing".into(),
            );
            continue;
        };
        // Project each new shape on the reference group: r = a − B (BᵀB)⁻¹ Bᵀ a.
        let k = xb.len();
        let gram = faer::Mat::from_fn(k, k, |i, j| {
            xb[i].iter().zip(&xb[j]).map(|(u, v)| u * v).sum::<f64>()
        });
        let Ok(llt) = gram.llt(faer::Side::Lower) else {
            let mut n = 0;
            out.push(
                &mut n,
                format!("{name} phi_{}..", g[0] + 1),
                "reference shapes of a repeated mode are dependent".into(),
            );
            continue;
        };
        let mut listed = 0;
        for (c, x) in xa.iter().enumerate() {
            let rhs = faer::Mat::from_fn(k, 1, |i, _| {
                xb[i].iter().zip(x).map(|(u, v)| u * v).sum::<f64>()
            });
            let coef = faer::linalg::solvers::Solve::solve(&llt, &rhs);
            let (mut r2, mut a2) = (0.0, 0.0);
            for row in 0..x.len() {
                let proj: f64 = (0..k).map(|i| coef[(i, 0)] * xb[i][row]).sum();
                r2 += (x[row] - proj).powi(2);
                a2 += x[row] * x[row];
            }
            let rel = (r2 / a2.max(f64::MIN_POSITIVE)).sqrt();
            if rel > t.rtol.max(1e-12) {
                out.push(&mut listed, format!("{name}.phi_{}", g[c] + 1), format!("lies {rel:e} (relative) outside the reference span of the repeated modes {}..{}", g[0] + 1, g[k - 1] + 1));
            }
        }
    }
}

/// +1 or −1, whichever brings `x` closer to `y`.
fn best_sign(x: &[f64], y: &[f64]) -> f64 {
    let dot: f64 = x.iter().zip(y).map(|(u, v)| u * v).sum();
    if dot < 0.0 { -1.0 } else { 1.0 }
}

fn sparse_map(t: &Table, name: &str) -> Option<BTreeMap<(i64, i64), f64>> {
    let (r, c, v) = (
        t.i64s(name, "row").ok()?,
        t.i64s(name, "col").ok()?,
        t.f64s(name, "value").ok()?,
    );
    let mut m = BTreeMap::new();
    for ((r, c), v) in r.iter().zip(c).zip(v) {
        *m.entry((*r, *c)).or_insert(0.0) += v;
    }
    Some(m)
}

fn compare_sparse(name: &str, a: &Table, b: &Table, tol: &Tolerances, out: &mut Comparison) {
    let mut n = 0;
    let (Some(ma), Some(mb)) = (sparse_map(a, name), sparse_map(b, name)) else {
        out.push(
            &mut n,
            name.to_string(),
            "not a row/col/value triplet table".into(),
        );
        return;
    };
    let t = tol.of(name, "value");
    let scale = mb.values().fold(0.0f64, |s, v| s.max(v.abs()));
    let keys: std::collections::BTreeSet<&(i64, i64)> = ma.keys().chain(mb.keys()).collect();
    let mut worst = 0.0f64;
    for k in keys {
        let (u, v) = (
            ma.get(k).copied().unwrap_or(0.0),
            mb.get(k).copied().unwrap_or(0.0),
        );
        worst = worst.max((u - v).abs());
        // Entries are judged against the matrix's scale: a structural zero vs 1e-30 is no change.
        if !t.accepts(u, v) && (u - v).abs() > t.rtol * scale {
            out.push(
                &mut n,
                format!("{name} ({}, {})", k.0, k.1),
                format!("{u:e} vs {v:e}"),
            );
        }
    }
    out.max_abs.insert(format!("{name}.value"), worst);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::Storage;

    fn frf(v: f64) -> Artefact {
        Artefact::new(ArtefactKind::Frf).with_table(
            "frf",
            Table::new().with("re", Column::F64(vec![1.0, v])),
            Storage::Parquet,
        )
    }

    #[test]
    fn detects_a_changed_value_and_respects_tolerance() {
        let t = Tolerances::default();
        assert!(compare(&frf(2.0), &frf(2.0), &t).same());
        let c = compare(&frf(2.0 + 1e-6), &frf(2.0), &t);
        assert_eq!(c.count, 1);
        assert_eq!(c.differences[0].location, "frf.re row 1");
        let loose = Tolerances {
            default: Tol {
                rtol: 1e-3,
                atol: 0.0,
                max: None,
            },
            ..Default::default()
        };
        assert!(compare(&frf(2.0 + 1e-6), &frf(2.0), &loose).same());
        let bounded = Tol {
            max: Some(3.0),
            ..Default::default()
        };
        assert!(bounded.accepts(2.5, -1.0));
        let t = Tol::default();
        assert!(t.accepts(f64::INFINITY, f64::INFINITY));
        assert!(!t.accepts(f64::INFINITY, 8e15) && !t.accepts(1.0, f64::NEG_INFINITY));
        assert!(!bounded.accepts(3.5, 2.0));
        assert!(!bounded.accepts(2.0, 3.5));
    }

    #[test]
    fn repeated_modes_compare_as_a_subspace() {
        let modes = |c: f64, s: f64, third: f64| {
            Artefact::new(ArtefactKind::Modes)
                .with_table(
                    "frequencies",
                    Table::new().with("eigenvalue_rad2_s2", Column::F64(vec![0.0, 0.0, 5.0])),
                    Storage::Parquet,
                )
                .with_table(
                    "shapes",
                    Table::new()
                        .with("phi_1", Column::F64(vec![c, s, 0.0]))
                        .with("phi_2", Column::F64(vec![-s, c, 0.0]))
                        .with("phi_3", Column::F64(vec![0.0, 0.0, third])),
                    Storage::Ipc,
                )
        };
        let t = Tolerances::default();
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        assert!(
            compare(&modes(c, s, 1.0), &modes(1.0, 0.0, 1.0), &t).same(),
            "a rotated rigid basis is the same subspace"
        );
        assert!(!compare(&modes(c, s, 1.1), &modes(1.0, 0.0, 1.0), &t).same());
        // Leaving the subspace is a difference.
        let mut off = modes(1.0, 0.0, 1.0);
        if let Some((tab, _)) = off.tables.get_mut("shapes") {
            tab.columns[0].1 = Column::F64(vec![1.0, 0.0, 0.1]);
        }
        assert!(!compare(&off, &modes(1.0, 0.0, 1.0), &t).same());
    }

    #[test]
    fn mode_shapes_compare_up_to_sign() {
        let modes = |s: f64| {
            Artefact::new(ArtefactKind::Modes).with_table(
                "shapes",
                Table::new().with("phi_1", Column::F64(vec![s, -2.0 * s])),
                Storage::Ipc,
            )
        };
        assert!(compare(&modes(1.0), &modes(-1.0), &Tolerances::default()).same());
        let frf_like = |s: f64| {
            Artefact::new(ArtefactKind::Frf).with_table(
                "shapes",
                Table::new().with("phi_1", Column::F64(vec![s])),
                Storage::Ipc,
            )
        };
        assert!(!compare(&frf_like(1.0), &frf_like(-1.0), &Tolerances::default()).same());
    }

    #[test]
    fn dependent_dofs_compare_as_rows_and_their_shapes_up_to_sign() {
        let model = |coefficient: f64| {
            Artefact::new(ArtefactKind::Matrices)
                .with_table(
                    "K",
                    Table::new()
                        .with("row", Column::I64(vec![0]))
                        .with("col", Column::I64(vec![0]))
                        .with("value", Column::F64(vec![2.0])),
                    Storage::Ipc,
                )
                .with_table(
                    "dependent",
                    Table::new()
                        .with("dof", Column::Str(vec!["2:ux".into()]))
                        .with("independent", Column::Str(vec!["1:ux".into()]))
                        .with("coefficient", Column::F64(vec![coefficient]))
                        .with("origin", Column::Str(vec!["RBE2 9".into()])),
                    Storage::Parquet,
                )
        };
        let t = Tolerances::default();
        assert!(compare(&model(1.0), &model(1.0), &t).same());
        let c = compare(&model(0.5), &model(1.0), &t);
        assert_eq!(c.differences[0].location, "dependent.coefficient row 0");
        let modes = |s: f64| {
            Artefact::new(ArtefactKind::Modes).with_table(
                "dependent_shapes",
                Table::new()
                    .with("dof", Column::Str(vec!["2:ux".into(), "2:uy".into()]))
                    .with("phi_1", Column::F64(vec![s, 3.0 * s])),
                Storage::Ipc,
            )
        };
        assert!(compare(&modes(1.0), &modes(-1.0), &t).same());
        assert!(!compare(&modes(1.0), &modes(1.1), &t).same());
    }
}
