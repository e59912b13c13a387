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
    /// A further absolute tolerance as a fraction of the largest magnitude in the column (or
    /// matrix): entries that are round-off next to the column's scale — a mode shape's entries
    /// near a nodal line, a cancellation near zero — are no change.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub scaled: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Tol {
    /// Whether `a` and `b` agree.
    pub fn accepts(&self, a: f64, b: f64) -> bool {
        self.accepts_in(a, b, 0.0)
    }

    /// Whether `a` and `b` agree in a column whose largest magnitude is `scale` (see
    /// [`Tol::scaled`]).
    pub fn accepts_in(&self, a: f64, b: f64, scale: f64) -> bool {
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
            && (a - b).abs() <= self.atol + self.rtol * a.abs().max(b.abs()) + self.scaled * scale
    }

    /// The rule in words, e.g. `|Δ| ≤ 1e-9·max(|a|, |b|) + 1e-12·(column's largest |value|)`.
    pub fn describe(&self) -> String {
        if let Some(m) = self.max {
            return format!("same while both |values| ≤ {m:e}");
        }
        let mut terms = Vec::new();
        if self.atol > 0.0 {
            terms.push(format!("{:e}", self.atol));
        }
        if self.rtol > 0.0 {
            terms.push(format!("{:e}·max(|a|, |b|)", self.rtol));
        }
        if self.scaled > 0.0 {
            terms.push(format!("{:e}·(largest |value| in the column)", self.scaled));
        }
        if terms.is_empty() {
            "exactly equal".into()
        } else {
            format!("|a − b| ≤ {}", terms.join(" + "))
        }
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
                ("scaled", t.scaled),
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
        ..Default::default()
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
    /// `femu diff`'s tolerances for an artefact of `kind` when the user chooses none: round-off
    /// is no change. Every number: `1e-9` relative, plus `1e-12` of its column's largest
    /// magnitude (a cancellation near zero); mode shapes (compared up to sign, repeated modes
    /// as a subspace) to `1e-7` of the shape's largest entry, since an iterative eigensolver's
    /// shapes move by ~1e-9 with the operation order; figures that are round-off by nature
    /// (eigen residuals, orthogonality errors) are the same while both stay below `1e-6`.
    pub fn defaults_for(kind: ArtefactKind) -> Tolerances {
        let mut t = Tolerances {
            default: Tol {
                rtol: 1e-9,
                scaled: 1e-12,
                ..Default::default()
            },
            ..Default::default()
        };
        let shapes = Tol {
            rtol: 0.0,
            scaled: 1e-7,
            ..Default::default()
        };
        let roundoff = Tol {
            max: Some(1e-6),
            ..Default::default()
        };
        let columns: Vec<(&str, Tol)> = match kind {
            ArtefactKind::Modes => vec![
                ("shapes.phi_*", shapes),
                ("dependent_shapes.phi_*", shapes),
                ("frequencies.residual", roundoff),
                ("meta.orthogonality_error", roundoff),
            ],
            ArtefactKind::ReducedComponent | ArtefactKind::ReducedModel => {
                vec![("meta.orthogonality_error", roundoff)]
            }
            _ => Vec::new(),
        };
        t.columns = columns
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect();
        t
    }

    /// The rules in words, one line each: the default, then each column's own.
    pub fn describe(&self) -> Vec<String> {
        let mut out = vec![format!("every number: {}", self.default.describe())];
        for (c, t) in &self.columns {
            let what = if c.ends_with("phi_*") {
                format!("{c} (up to sign, repeated modes as a subspace)")
            } else {
                c.clone()
            };
            out.push(format!("{what}: {}", t.describe()));
        }
        if self.skip_blobs {
            out.push("files (figures) not compared".into());
        }
        out
    }

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

/// The differences of one column (or matrix, or meta entry), for a summary.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColumnDifferences {
    /// Differing values.
    pub count: usize,
    /// Largest absolute difference among them (NaN for text and kinds of change).
    pub worst_abs: f64,
    /// Its relative size, `|a − b| / max(|a|, |b|)` (NaN when not numeric).
    pub worst_rel: f64,
    /// Where the largest difference is (the row named by its key columns).
    pub worst_at: String,
}

/// The outcome of a comparison.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Comparison {
    /// Differences, at most [`MAX_LISTED`] listed per table or column (or as many as
    /// [`compare_listing`] was asked for).
    pub differences: Vec<Difference>,
    /// Total count of differing values.
    pub count: usize,
    /// Largest absolute difference per `table.column`.
    pub max_abs: BTreeMap<String, f64>,
    /// Per `table.column` (or `meta.key`, or table) that differs: how many values and the
    /// largest difference.
    pub columns: BTreeMap<String, ColumnDifferences>,
    /// How many differences to list per column (`None`: [`MAX_LISTED`]; `Some(usize::MAX)`
    /// lists all).
    limit: Option<usize>,
}

/// How many differences are listed per column before counting only.
pub const MAX_LISTED: usize = 5;

impl Comparison {
    /// True when nothing differs.
    pub fn same(&self) -> bool {
        self.count == 0
    }

    /// A difference that has no size (text, a missing key, a changed layout).
    fn push(&mut self, listed_in_column: &mut usize, location: String, detail: String) {
        self.push_num(listed_in_column, location, detail, f64::NAN, f64::NAN);
    }

    /// A numeric difference of absolute size `abs` and relative size `rel`, counted in the
    /// summary of its column (the location up to ` row ` or ` (`).
    fn push_num(
        &mut self,
        listed_in_column: &mut usize,
        location: String,
        detail: String,
        abs: f64,
        rel: f64,
    ) {
        self.count += 1;
        let column = location
            .split(" row ")
            .next()
            .and_then(|c| c.split(" (").next())
            .unwrap_or(&location)
            .to_string();
        let c = self.columns.entry(column).or_default();
        c.count += 1;
        if c.count == 1 || abs > c.worst_abs || (c.worst_abs.is_nan() && !abs.is_nan()) {
            c.worst_abs = abs;
            c.worst_rel = rel;
            c.worst_at = location.clone();
        }
        if *listed_in_column < self.limit.unwrap_or(MAX_LISTED) {
            self.differences.push(Difference { location, detail });
        }
        *listed_in_column += 1;
    }
}

/// Names a table's rows by its key columns (the parameter, the DOF, the mode, the frequency
/// line) rather than by number alone.
struct RowNames<'t> {
    keys: Vec<(&'t str, &'t Column)>,
}

impl<'t> RowNames<'t> {
    fn new(kind: ArtefactKind, table: &str, t: &'t Table) -> Self {
        let names = key_columns(kind, table);
        let keys = names
            .iter()
            .filter_map(|n| t.column(n).map(|c| (*n, c)))
            .collect();
        RowNames { keys }
    }

    /// `row 12 (response 1:ux, excitation 1:ux, freq_hz 0.6)`; `row 12` without key columns.
    fn name(&self, row: usize) -> String {
        if self.keys.is_empty() {
            return format!("row {row}");
        }
        let parts: Vec<String> = self
            .keys
            .iter()
            .filter(|(_, c)| row < c.len())
            .map(|(n, c)| {
                let v = match c {
                    // 12 significant digits: `0.15`, not `0.15000000000000002`.
                    Column::F64(v) => {
                        let rounded: f64 = format!("{:.11e}", v[row]).parse().unwrap_or(v[row]);
                        format!("{rounded}")
                    }
                    Column::I64(v) => v[row].to_string(),
                    Column::I32(v) => v[row].to_string(),
                    Column::Str(v) => v[row].clone(),
                };
                format!("{n} {v}")
            })
            .collect();
        format!("row {row} ({})", parts.join(", "))
    }
}

/// The columns that name a row of `table` in an artefact of `kind`.
pub fn key_columns(kind: ArtefactKind, table: &str) -> &'static [&'static str] {
    use ArtefactKind as K;
    match (kind, table) {
        (K::Frf, "frf") => &["response", "excitation", "freq_hz"],
        (K::Correlation | K::Leverage, "lines") => &["freq_hz"],
        (K::Correlation, "frac") => &["response", "excitation"],
        (K::Modes, "frequencies") => &["mode"],
        (K::Modes, _) => &["dof"],
        (K::ModalCorrelation, "pairs" | "mac") => &["reference_mode", "predicted_mode"],
        (K::ModalCorrelation, "comac") => &["dof"],
        (K::UpdateResult, "parameters") => &["parameter"],
        (K::UpdateResult, "history") => &["iteration", "parameter"],
        (K::UpdateResult, "iterations") => &["iteration"],
        (K::UpdateResult, "singular_values") => &["iteration", "index"],
        (K::UpdateResult, "directions") => &["iteration", "direction", "parameter"],
        (K::UpdateResult, "modal_damping") => &["mode"],
        (K::Leverage, "candidates") => &["candidate"],
        (K::Leverage | K::EigenvalueSensitivity, "members") => &["candidate", "element"],
        (K::EigenvalueSensitivity, "modes") => &["mode"],
        (K::EigenvalueSensitivity, "sensitivities") => &["candidate", "mode"],
        (K::Matrices, "dependent") => &["dof"],
        (K::Matrices, "dofs") => &["index"],
        (K::Mesh, "nodes" | "displacement_systems") => &["node"],
        (K::Mesh, "elements" | "lumped") => &["element"],
        (K::Mesh, "sets") => &["set", "element"],
        (K::Mesh, "constraints") => &["dof"],
        (K::Mesh, "mpcs") => &["dependent", "independent"],
        (K::Partition, "dofs") => &["substructure", "dof"],
        (K::Partition, "substructures") => &["substructure", "element"],
        (K::Partition, "boundaries") => &["boundary", "dof"],
        (K::ReducedModel, "components") => &["substructure"],
        (K::ReducedModel, "coords") => &["index"],
        (K::ReducedComponent, "component_modes") => &["mode"],
        _ => &[],
    }
}

/// Compares `a` (new) against `b` (reference), listing at most [`MAX_LISTED`] differences a
/// column.
pub fn compare(a: &Artefact, b: &Artefact, tol: &Tolerances) -> Comparison {
    compare_listing(a, b, tol, MAX_LISTED)
}

/// [`compare`], listing at most `listed` differences a column (`usize::MAX`: every one).
pub fn compare_listing(a: &Artefact, b: &Artefact, tol: &Tolerances, listed: usize) -> Comparison {
    let mut out = Comparison {
        limit: Some(listed),
        ..Default::default()
    };
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
    let labels = index_labels(b);
    let names: std::collections::BTreeSet<&String> =
        a.tables.keys().chain(b.tables.keys()).collect();
    for name in names {
        let mut n = 0;
        match (a.tables.get(name), b.tables.get(name)) {
            (Some((ta, _)), Some((tb, _))) => match (a.kind, name.as_str()) {
                // Every matrices table but the DOF list and the rigid elements' equations is a
                // sparse matrix.
                (ArtefactKind::Matrices, t) if t != "dofs" && t != "dependent" => {
                    compare_sparse(name, ta, tb, tol, labels.as_ref(), &mut out)
                }
                // Shapes at the free and at the dependent DOFs, both up to sign.
                (ArtefactKind::Modes, "shapes" | "dependent_shapes") => {
                    compare_shapes(name, a, ta, tb, tol, &mut out)
                }
                _ => compare_table(name, ta, tb, tol, false, a.kind, &mut out),
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
                let d = (u - v).abs();
                out.push_num(
                    &mut n,
                    path.to_string(),
                    format!("{u:e} vs {v:e}"),
                    d,
                    d / u.abs().max(v.abs()),
                );
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
    kind: ArtefactKind,
    out: &mut Comparison,
) {
    let mut n = 0;
    let rows = RowNames::new(kind, name, b);
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
                let scale = if t.scaled > 0.0 {
                    x.iter()
                        .chain(y)
                        .filter(|v| v.is_finite())
                        .fold(0.0f64, |m, v| m.max(v.abs()))
                } else {
                    0.0
                };
                let mut worst = 0.0f64;
                for (row, (u, v)) in x.iter().zip(y).enumerate() {
                    let u = sign * u;
                    let d = (u - v).abs();
                    worst = worst.max(d);
                    if !t.accepts_in(u, *v, scale) {
                        out.push_num(
                            &mut listed,
                            format!("{loc} {}", rows.name(row)),
                            format!("{u:e} vs {v:e}"),
                            d,
                            d / u.abs().max(v.abs()),
                        );
                    }
                }
                out.max_abs.insert(loc, worst);
            }
            (Column::I64(_) | Column::I32(_), Column::I64(_) | Column::I32(_)) => {
                let (Some(x), Some(y)) = (x.integers(), y.integers()) else {
                    unreachable!("both columns are integers")
                };
                for row in 0..x.len().min(y.len()) {
                    let (u, v) = (x.get(row), y.get(row));
                    if u != v {
                        out.push(
                            &mut listed,
                            format!("{loc} {}", rows.name(row)),
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
                            format!("{loc} {}", rows.name(row)),
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
        return compare_table(name, ta, tb, tol, true, a.kind, out);
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
    compare_table(name, &sa, &sb, tol, true, a.kind, out);
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
            if rel > t.rtol.max(t.scaled).max(1e-12) {
                out.push_num(&mut listed, format!("{name}.phi_{}", g[c] + 1), format!("lies {rel:e} (relative) outside the reference span of the repeated modes {}..{}", g[0] + 1, g[k - 1] + 1), rel, rel);
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
        t.indices(name, "row").ok()?,
        t.indices(name, "col").ok()?,
        t.f64s(name, "value").ok()?,
    );
    let mut m = BTreeMap::new();
    for (k, v) in v.iter().enumerate().take(r.len().min(c.len())) {
        *m.entry((r.get(k), c.get(k))).or_insert(0.0) += v;
    }
    Some(m)
}

/// Labels of a matrix's rows and columns by index: the DOFs of `matrices`.
fn index_labels(x: &Artefact) -> Option<BTreeMap<i64, String>> {
    let (table, column) = match x.kind {
        ArtefactKind::Matrices => ("dofs", "dof"),
        _ => return None,
    };
    let t = x.table(table).ok()?;
    let index = t.i64s(table, "index").ok()?;
    let labels = t.strs(table, column).ok()?;
    Some(index.iter().copied().zip(labels.iter().cloned()).collect())
}

fn compare_sparse(
    name: &str,
    a: &Table,
    b: &Table,
    tol: &Tolerances,
    labels: Option<&BTreeMap<i64, String>>,
    out: &mut Comparison,
) {
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
        if !t.accepts_in(u, v, scale) && (u - v).abs() > t.rtol * scale {
            let at = match labels.map(|l| (l.get(&k.0), l.get(&k.1))) {
                Some((Some(r), Some(c))) => format!("{name} ({}, {}: {r}, {c})", k.0, k.1),
                _ => format!("{name} ({}, {})", k.0, k.1),
            };
            let d = (u - v).abs();
            out.push_num(
                &mut n,
                at,
                format!("{u:e} vs {v:e}"),
                d,
                d / u.abs().max(v.abs()),
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
                ..Default::default()
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
        assert_eq!(
            c.differences[0].location,
            "dependent.coefficient row 0 (dof 2:ux)"
        );
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

    #[test]
    fn rows_are_named_by_their_key_columns_and_summarised_by_column() {
        let params = |v: &[f64]| {
            Artefact::new(ArtefactKind::UpdateResult).with_table(
                "parameters",
                Table::new()
                    .with(
                        "parameter",
                        Column::Str(v.iter().enumerate().map(|(i, _)| format!("t{i}")).collect()),
                    )
                    .with("final", Column::F64(v.to_vec())),
                Storage::Parquet,
            )
        };
        let base: Vec<f64> = (1..=8).map(f64::from).collect();
        let mut changed = base.clone();
        for (i, x) in changed.iter_mut().enumerate().skip(1) {
            *x *= 1.0 + 0.01 * i as f64;
        }
        let t = Tolerances::default();
        let c = compare(&params(&changed), &params(&base), &t);
        assert_eq!(c.count, 7);
        assert_eq!(c.differences.len(), MAX_LISTED);
        assert_eq!(
            c.differences[0].location,
            "parameters.final row 1 (parameter t1)"
        );
        let col = &c.columns["parameters.final"];
        assert_eq!(col.count, 7);
        assert_eq!(col.worst_at, "parameters.final row 7 (parameter t7)");
        assert!((col.worst_rel - 0.56 / 1.07 * 0.125).abs() < 1e-2);
        let all = compare_listing(&params(&changed), &params(&base), &t, usize::MAX);
        assert_eq!(all.differences.len(), 7);
        assert_eq!(all.count, c.count);
    }

    #[test]
    fn diff_defaults_ignore_round_off_but_not_changes() {
        let modes = |phi: Vec<f64>, ortho: f64| {
            Artefact::new(ArtefactKind::Modes)
                .with_meta("orthogonality_error", ortho.into())
                .with_table(
                    "shapes",
                    Table::new()
                        .with(
                            "dof",
                            Column::Str(vec!["1:ux".into(), "2:ux".into(), "3:ux".into()]),
                        )
                        .with("phi_1", Column::F64(phi)),
                    Storage::Ipc,
                )
        };
        let reference = modes(vec![0.5, 1e-19, -1.0], 1.1e-15);
        // Sign flipped, a node's entry at round-off, a different round-off orthogonality error.
        let noisy = modes(vec![-0.5, 3e-19, 1.0 + 1e-12], 2.3e-15);
        let strict = Tolerances::default();
        assert!(
            !compare(&noisy, &reference, &strict).same(),
            "1e-19 noise fails rtol alone"
        );
        let d = Tolerances::defaults_for(ArtefactKind::Modes);
        assert!(compare(&noisy, &reference, &d).same());
        let moved = modes(vec![-0.5, 1e-3, 1.0], 1.1e-15);
        let c = compare(&moved, &reference, &d);
        assert_eq!(c.count, 1);
        assert_eq!(c.differences[0].location, "shapes.phi_1 row 1 (dof 2:ux)");
        // Elsewhere the relative tolerance holds, plus round-off of the column's scale.
        let frf = |v: f64| {
            Artefact::new(ArtefactKind::Frf).with_table(
                "frf",
                Table::new()
                    .with("response", Column::Str(vec!["1:ux".into(), "1:ux".into()]))
                    .with(
                        "excitation",
                        Column::Str(vec!["1:ux".into(), "1:ux".into()]),
                    )
                    .with("freq_hz", Column::F64(vec![0.0, 0.5]))
                    .with("re", Column::F64(vec![1.0, v])),
                Storage::Parquet,
            )
        };
        let d = Tolerances::defaults_for(ArtefactKind::Frf);
        assert!(compare(&frf(1e-20), &frf(-1e-20), &d).same());
        let c = compare(&frf(2e-6), &frf(1e-6), &d);
        assert_eq!(
            c.differences[0].location,
            "frf.re row 1 (response 1:ux, excitation 1:ux, freq_hz 0.5)"
        );
        assert!(d.describe()[0].contains("1e-9·max(|a|, |b|)"));
        assert!(
            Tolerances::defaults_for(ArtefactKind::Modes)
                .describe()
                .iter()
                .any(|l| l.starts_with("shapes.phi_* (up to sign"))
        );
    }
}
