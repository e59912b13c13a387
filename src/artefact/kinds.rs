//! Typed views of artefacts: conversions between numerical types and [`Artefact`] tables.
//!
//! | kind | tables (storage) | columns |
//! |---|---|---|
//! | `matrices` | `dofs` (Parquet); `K`, `M`, `C`, `D` (IPC) | `index, dof, node, comp`; `row, col, value` |
//! | `modes` | `frequencies` (Parquet); `shapes` (IPC) | `mode, freq_hz, eigenvalue_rad2_s2, residual`; `dof, phi_1 … phi_m` |
//! | `frf` | `frf` (Parquet) | `freq_hz, response, excitation, re, im` |
//! | `correlation` | `lines`, `frac` (Parquet) | `freq_hz, chi_s, chi_a`; `response, excitation, frac` |
//! | `plot` | blobs `*.png`, `*.svg` | |

use super::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::core::sparse::{sparse_from_triplets, sparse_triplets};
use crate::correlation::FrfCorrelation;
use crate::eigen::Modes;
use crate::fe::SystemMatrices;
use crate::frf::{FrfPair, FrfSet, Quantity};
use faer::{Mat, c64};

/// Digest of a DOF list: artefacts that refer to the same DOFs record the same value.
pub fn dof_index_digest(dofs: &[DofId]) -> String {
    let text: Vec<String> = dofs.iter().map(|d| d.to_string()).collect();
    super::digest::hash_bytes(text.join("\n").as_bytes())
}

fn dof_table(dofs: &[DofId]) -> Table {
    Table::new()
        .with("index", Column::I64((0..dofs.len() as i64).collect()))
        .with(
            "dof",
            Column::Str(dofs.iter().map(|d| d.to_string()).collect()),
        )
        .with(
            "node",
            Column::I64(dofs.iter().map(|d| d.node as i64).collect()),
        )
        .with(
            "comp",
            Column::Str(dofs.iter().map(|d| d.comp.name().to_string()).collect()),
        )
}

fn parse_dofs(
    kind: ArtefactKind,
    table: &str,
    labels: &[String],
) -> Result<Vec<DofId>, ArtefactError> {
    labels
        .iter()
        .enumerate()
        .map(|(row, s)| {
            s.parse::<DofId>()
                .map_err(|e| ArtefactError::schema(kind, format!("table `{table}` row {row}: {e}")))
        })
        .collect()
}

/// Checks an artefact's kind before reading it as `kind`.
pub(crate) fn expect_kind(a: &Artefact, kind: ArtefactKind) -> Result<(), ArtefactError> {
    if a.kind == kind {
        Ok(())
    } else {
        Err(ArtefactError::schema(
            kind,
            format!("got a `{}` artefact", a.kind),
        ))
    }
}

/// System matrices as an artefact.
pub fn matrices_to_artefact(sys: &SystemMatrices) -> Artefact {
    let mut a = Artefact::new(ArtefactKind::Matrices)
        .with_meta("n_dofs", sys.n().into())
        .with_meta("dof_index", dof_index_digest(&sys.dofs).into())
        .with_meta(
            "units",
            serde_json::json!({"K": "N/m", "M": "kg", "C": "N*s/m", "D": "N/m"}),
        )
        .with_table("dofs", dof_table(&sys.dofs), Storage::Parquet);
    for (name, mat) in sys.named() {
        a = a.with_table(name, triplet_table(mat), Storage::Ipc);
    }
    a
}

/// A sparse matrix as a `row, col, value` table (the layout of every matrix table).
pub fn triplet_table(mat: &crate::core::sparse::SparseMatrix) -> Table {
    let t = sparse_triplets(mat);
    Table::new()
        .with("row", Column::I64(t.iter().map(|e| e.0 as i64).collect()))
        .with("col", Column::I64(t.iter().map(|e| e.1 as i64).collect()))
        .with("value", Column::F64(t.iter().map(|e| e.2).collect()))
}

/// System matrices from an artefact.
pub fn matrices_from_artefact(a: &Artefact) -> Result<SystemMatrices, ArtefactError> {
    let kind = ArtefactKind::Matrices;
    expect_kind(a, kind)?;
    let dofs = parse_dofs(kind, "dofs", a.table("dofs")?.strs("dofs", "dof")?)?;
    let n = dofs.len();
    let read = |name: &str| read_matrix(a, name, n);
    let sys = SystemMatrices {
        k: read("K")?.ok_or_else(|| ArtefactError::schema(kind, "no stiffness table `K`"))?,
        m: read("M")?.ok_or_else(|| ArtefactError::schema(kind, "no mass table `M`"))?,
        c: read("C")?,
        d: read("D")?,
        dofs,
    };
    sys.validate()
        .map_err(|e| ArtefactError::schema(kind, e.to_string()))?;
    Ok(sys)
}

/// The matrix table `name` of a matrices artefact with `n` DOFs, if present.
fn read_matrix(
    a: &Artefact,
    name: &str,
    n: usize,
) -> Result<Option<crate::core::sparse::SparseMatrix>, ArtefactError> {
    let Some((t, _)) = a.tables.get(name) else {
        return Ok(None);
    };
    let (r, c, v) = (
        t.i64s(name, "row")?,
        t.i64s(name, "col")?,
        t.f64s(name, "value")?,
    );
    let trip: Vec<(usize, usize, f64)> = r
        .iter()
        .zip(c)
        .zip(v)
        .map(|((r, c), v)| {
            (
                usize::try_from(*r).unwrap_or(usize::MAX),
                usize::try_from(*c).unwrap_or(usize::MAX),
                *v,
            )
        })
        .collect();
    sparse_from_triplets("matrix", n, &trip)
        .map(Some)
        .map_err(|e| ArtefactError::schema(ArtefactKind::Matrices, format!("table `{name}`: {e}")))
}

/// Parameters that enter a matrices artefact linearly (meta `parameters` with `linear: true`,
/// as `model.lumped` writes them) with their `dK__<name>`, `dM__<name>` tables.
#[allow(clippy::type_complexity)]
pub fn linear_parameters_from_matrices(
    a: &Artefact,
    n: usize,
) -> Result<
    Vec<(
        crate::updating::UpdatingParameter,
        crate::core::sparse::SparseMatrix,
        crate::core::sparse::SparseMatrix,
    )>,
    ArtefactError,
> {
    let kind = ArtefactKind::Matrices;
    let Some(list) = a.meta.get("parameters") else {
        return Ok(Vec::new());
    };
    let list: Vec<serde_json::Value> = serde_json::from_value(list.clone())
        .map_err(|e| ArtefactError::schema(kind, format!("meta `parameters`: {e}")))?;
    let mut out = Vec::new();
    for v in list {
        #[derive(serde::Deserialize)]
        struct Entry {
            name: String,
            value: f64,
            lower: f64,
            upper: f64,
            linear: bool,
        }
        let e: Entry = serde_json::from_value(v)
            .map_err(|e| ArtefactError::schema(kind, format!("meta `parameters`: {e}")))?;
        if !e.linear {
            return Err(ArtefactError::schema(
                kind,
                format!(
                    "parameter `{}` does not enter the matrices linearly: update the model it came from (the mesh) instead",
                    e.name
                ),
            ));
        }
        let zero = || {
            sparse_from_triplets("zero", n, &[])
                .map_err(|x| ArtefactError::schema(kind, x.to_string()))
        };
        let dk = match read_matrix(a, &format!("dK__{}", e.name), n)? {
            Some(m) => m,
            None => zero()?,
        };
        let dm = match read_matrix(a, &format!("dM__{}", e.name), n)? {
            Some(m) => m,
            None => zero()?,
        };
        out.push((
            crate::updating::UpdatingParameter {
                name: e.name,
                initial: e.value,
                lower: e.lower,
                upper: e.upper,
            },
            dk,
            dm,
        ));
    }
    Ok(out)
}

/// Modes with their DOF labels.
#[derive(Clone, Debug)]
pub struct ModesArtefact {
    /// Row labels of the shapes.
    pub dofs: Vec<DofId>,
    /// The modes.
    pub modes: Modes,
}

/// Modes as an artefact.
pub fn modes_to_artefact(dofs: &[DofId], modes: &Modes) -> Artefact {
    let m = modes.len();
    let freqs = Table::new()
        .with("mode", Column::I64((1..=m as i64).collect()))
        .with("freq_hz", Column::F64(modes.frequencies_hz()))
        .with("eigenvalue_rad2_s2", Column::F64(modes.eigenvalues.clone()))
        .with("residual", Column::F64(modes.residuals.clone()));
    let mut shapes = Table::new().with(
        "dof",
        Column::Str(dofs.iter().map(|d| d.to_string()).collect()),
    );
    for r in 0..m {
        shapes = shapes.with(
            format!("phi_{}", r + 1),
            Column::F64((0..dofs.len()).map(|i| modes.shapes[(i, r)]).collect()),
        );
    }
    Artefact::new(ArtefactKind::Modes)
        .with_meta("n_modes", m.into())
        .with_meta("n_dofs", dofs.len().into())
        .with_meta("rigid_body_modes", modes.rigid_body_modes.into())
        .with_meta("orthogonality_error", modes.orthogonality_error.into())
        .with_meta("dof_index", dof_index_digest(dofs).into())
        .with_meta("normalisation", "mass".into())
        .with_meta("units", serde_json::json!({"freq_hz": "Hz", "eigenvalue_rad2_s2": "rad^2/s^2", "phi": "1/sqrt(kg)"}))
        .with_table("frequencies", freqs, Storage::Parquet)
        .with_table("shapes", shapes, Storage::Ipc)
}

/// Modes from an artefact.
pub fn modes_from_artefact(a: &Artefact) -> Result<ModesArtefact, ArtefactError> {
    let kind = ArtefactKind::Modes;
    expect_kind(a, kind)?;
    let f = a.table("frequencies")?;
    let lambdas = f.f64s("frequencies", "eigenvalue_rad2_s2")?.to_vec();
    let residuals = f.f64s("frequencies", "residual")?.to_vec();
    let s = a.table("shapes")?;
    let dofs = parse_dofs(kind, "shapes", s.strs("shapes", "dof")?)?;
    let mut shapes = Mat::<f64>::zeros(dofs.len(), lambdas.len());
    for r in 0..lambdas.len() {
        let col = s.f64s("shapes", &format!("phi_{}", r + 1))?;
        for (i, v) in col.iter().enumerate() {
            shapes[(i, r)] = *v;
        }
    }
    Ok(ModesArtefact {
        dofs,
        modes: Modes {
            rigid_body_modes: lambdas.iter().filter(|l| **l == 0.0).count(),
            orthogonality_error: a
                .meta
                .get("orthogonality_error")
                .and_then(|v| v.as_f64())
                .unwrap_or(0.0),
            eigenvalues: lambdas,
            shapes,
            residuals,
        },
    })
}

/// FRFs as an artefact (long table: one row per line and pair, pair-major).
pub fn frf_to_artefact(set: &FrfSet) -> Artefact {
    let (nl, np) = (set.freqs_hz.len(), set.pairs.len());
    let mut freq = Vec::with_capacity(nl * np);
    let (mut resp, mut exc) = (Vec::with_capacity(nl * np), Vec::with_capacity(nl * np));
    let (mut re, mut im) = (Vec::with_capacity(nl * np), Vec::with_capacity(nl * np));
    for (p, pair) in set.pairs.iter().enumerate() {
        let (r, e) = (pair.response.to_string(), pair.excitation.to_string());
        for (k, f) in set.freqs_hz.iter().enumerate() {
            freq.push(*f);
            resp.push(r.clone());
            exc.push(e.clone());
            re.push(set.values[(k, p)].re);
            im.push(set.values[(k, p)].im);
        }
    }
    let table = Table::new()
        .with("freq_hz", Column::F64(freq))
        .with("response", Column::Str(resp))
        .with("excitation", Column::Str(exc))
        .with("re", Column::F64(re))
        .with("im", Column::F64(im));
    Artefact::new(ArtefactKind::Frf)
        .with_meta("quantity", set.quantity.name().into())
        .with_meta("units", serde_json::json!({"freq_hz": "Hz", "re": set.quantity.unit(), "im": set.quantity.unit()}))
        .with_meta("n_lines", nl.into())
        .with_meta("n_frfs", np.into())
        .with_table("frf", table, Storage::Parquet)
}

/// FRFs from an artefact: rows grouped by (response, excitation) in order of first appearance,
/// every FRF on the same ascending lines.
pub fn frf_from_artefact(a: &Artefact) -> Result<FrfSet, ArtefactError> {
    let kind = ArtefactKind::Frf;
    expect_kind(a, kind)?;
    let q = a.meta_str("quantity")?;
    let quantity = Quantity::from_name(q).ok_or_else(|| {
        ArtefactError::schema(
            kind,
            format!("quantity `{q}` is not one of receptance, mobility, accelerance"),
        )
    })?;
    let t = a.table("frf")?;
    let f = t.f64s("frf", "freq_hz")?;
    let r = t.strs("frf", "response")?;
    let e = t.strs("frf", "excitation")?;
    let (re, im) = (t.f64s("frf", "re")?, t.f64s("frf", "im")?);
    let mut pairs: Vec<FrfPair> = Vec::new();
    let mut rows: Vec<Vec<usize>> = Vec::new();
    let mut last: Option<(&String, &String, usize)> = None;
    for row in 0..f.len() {
        let slot = match last {
            Some((lr, le, s)) if lr == &r[row] && le == &e[row] => s,
            _ => {
                let parse = |s: &String, col: &str| {
                    s.parse::<DofId>().map_err(|err| {
                        ArtefactError::schema(
                            kind,
                            format!("table `frf` row {row} column `{col}`: {err}"),
                        )
                    })
                };
                let pair = FrfPair {
                    response: parse(&r[row], "response")?,
                    excitation: parse(&e[row], "excitation")?,
                };
                match pairs.iter().position(|p| *p == pair) {
                    Some(s) => s,
                    None => {
                        pairs.push(pair);
                        rows.push(Vec::new());
                        pairs.len() - 1
                    }
                }
            }
        };
        rows[slot].push(row);
        last = Some((&r[row], &e[row], slot));
    }
    let Some(first) = rows.first() else {
        return Err(ArtefactError::schema(kind, "table `frf` has no rows"));
    };
    let freqs: Vec<f64> = first.iter().map(|&i| f[i]).collect();
    if freqs
        .windows(2)
        .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
    {
        return Err(ArtefactError::schema(
            kind,
            format!(
                "FRF {}/{}: frequencies must strictly increase",
                pairs[0].response, pairs[0].excitation
            ),
        ));
    }
    let mut values = Mat::<c64>::zeros(freqs.len(), pairs.len());
    for (p, idx) in rows.iter().enumerate() {
        let same = idx.len() == freqs.len()
            && idx
                .iter()
                .zip(&freqs)
                .all(|(&i, fr)| (f[i] - fr).abs() <= 1e-9 * fr.abs().max(1.0));
        if !same {
            return Err(ArtefactError::schema(
                kind,
                format!(
                    "FRF {}/{} has {} lines that differ from the first FRF's {} lines; every FRF must share one set of lines",
                    pairs[p].response,
                    pairs[p].excitation,
                    idx.len(),
                    freqs.len()
                ),
            ));
        }
        for (k, &i) in idx.iter().enumerate() {
            values[(k, p)] = c64::new(re[i], im[i]);
        }
    }
    Ok(FrfSet {
        quantity,
        freqs_hz: freqs,
        pairs,
        values,
    })
}

/// A correlation as an artefact.
pub fn correlation_to_artefact(c: &FrfCorrelation) -> Artefact {
    let lines = Table::new()
        .with("freq_hz", Column::F64(c.freqs_hz.clone()))
        .with("chi_s", Column::F64(c.chi_s.clone()))
        .with("chi_a", Column::F64(c.chi_a.clone()));
    let frac = Table::new()
        .with(
            "response",
            Column::Str(c.pairs.iter().map(|p| p.response.to_string()).collect()),
        )
        .with(
            "excitation",
            Column::Str(c.pairs.iter().map(|p| p.excitation.to_string()).collect()),
        )
        .with("frac", Column::F64(c.frac.clone()));
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    Artefact::new(ArtefactKind::Correlation)
        .with_meta(
            "summary",
            serde_json::json!({
                "mean_chi_s": c.mean_chi_s(),
                "mean_chi_a": c.mean_chi_a(),
                "mean_chi": c.mean_chi(),
                "min_chi_s": min(&c.chi_s),
                "min_chi_a": min(&c.chi_a),
                "mean_frac": if c.frac.is_empty() { 0.0 } else { c.frac.iter().sum::<f64>() / c.frac.len() as f64 },
                "n_lines": c.freqs_hz.len(),
                "n_frfs": c.pairs.len(),
            }),
        )
        .with_table("lines", lines, Storage::Parquet)
        .with_table("frac", frac, Storage::Parquet)
}

/// A correlation from an artefact.
pub fn correlation_from_artefact(a: &Artefact) -> Result<FrfCorrelation, ArtefactError> {
    let kind = ArtefactKind::Correlation;
    expect_kind(a, kind)?;
    let l = a.table("lines")?;
    let fr = a.table("frac")?;
    let resp = parse_dofs(kind, "frac", fr.strs("frac", "response")?)?;
    let exc = parse_dofs(kind, "frac", fr.strs("frac", "excitation")?)?;
    Ok(FrfCorrelation {
        freqs_hz: l.f64s("lines", "freq_hz")?.to_vec(),
        chi_s: l.f64s("lines", "chi_s")?.to_vec(),
        chi_a: l.f64s("lines", "chi_a")?.to_vec(),
        pairs: resp
            .into_iter()
            .zip(exc)
            .map(|(response, excitation)| FrfPair {
                response,
                excitation,
            })
            .collect(),
        frac: fr.f64s("frac", "frac")?.to_vec(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::lumped::assemble_lumped;
    use crate::model::LumpedModel;

    #[test]
    fn matrices_round_trip() {
        let sys = assemble_lumped(&LumpedModel::chain(&[1.0, 1.3, 1.0], 10.0)).unwrap();
        let back = matrices_from_artefact(&matrices_to_artefact(&sys)).unwrap();
        assert_eq!(back.dofs, sys.dofs);
        assert_eq!(back.k_dense(), sys.k_dense());
        assert_eq!(back.m_dense(), sys.m_dense());
    }

    #[test]
    fn frf_round_trip_and_line_mismatch_is_reported() {
        let dofs: Vec<DofId> = vec!["1:ux".parse().unwrap(), "2:uz".parse().unwrap()];
        let set = FrfSet {
            quantity: Quantity::Mobility,
            freqs_hz: vec![1.0, 2.0, 3.0],
            pairs: FrfSet::all_pairs(&dofs, &dofs[..1]),
            values: Mat::from_fn(3, 2, |k, p| c64::new(k as f64, p as f64 - 0.5)),
        };
        let a = frf_to_artefact(&set);
        let back = frf_from_artefact(&a).unwrap();
        assert_eq!(back.values, set.values);
        assert_eq!(back.pairs, set.pairs);
        assert_eq!(back.quantity, Quantity::Mobility);
        let mut broken = a.clone();
        if let Some((t, _)) = broken.tables.get_mut("frf") {
            if let Column::F64(f) = &mut t.columns[0].1 {
                f[4] = 2.5;
            }
        }
        let e = frf_from_artefact(&broken).unwrap_err().to_string();
        assert!(e.contains("2:uz/1:ux"), "{e}");
    }
}

/// One column of a table layout.
#[derive(Clone, Debug)]
pub struct ColumnLayout {
    /// Column name (`phi_{r}` stands for `phi_1 … phi_m`).
    pub name: &'static str,
    /// `float64`, `int64` or `string`.
    pub dtype: &'static str,
    /// SI unit, or empty.
    pub unit: &'static str,
    /// What it holds.
    pub doc: &'static str,
}

/// One table of a kind's layout.
#[derive(Clone, Debug)]
pub struct TableLayout {
    /// Table name.
    pub name: &'static str,
    /// `parquet` or `arrow_ipc`.
    pub storage: &'static str,
    /// Whether every artefact of the kind has it.
    pub required: bool,
    /// Columns in order.
    pub columns: Vec<ColumnLayout>,
}

pub(crate) const fn col(
    name: &'static str,
    dtype: &'static str,
    unit: &'static str,
    doc: &'static str,
) -> ColumnLayout {
    ColumnLayout {
        name,
        dtype,
        unit,
        doc,
    }
}

/// The tables and columns every artefact of `kind` has (the published schema).
pub fn layout(kind: ArtefactKind) -> Vec<TableLayout> {
    let t = |name, storage, required, columns| TableLayout {
        name,
        storage,
        required,
        columns,
    };
    let triplets = |name: &'static str, unit: &'static str, required| {
        t(
            name,
            "arrow_ipc",
            required,
            vec![
                col("row", "int64", "", "row index into `dofs`"),
                col("col", "int64", "", "column index into `dofs`"),
                col("value", "float64", unit, "entry; duplicates sum"),
            ],
        )
    };
    match kind {
        ArtefactKind::Matrices => vec![
            t(
                "dofs",
                "parquet",
                true,
                vec![
                    col("index", "int64", "", "row/column index"),
                    col("dof", "string", "", "DOF label node:comp"),
                    col("node", "int64", "", "node id"),
                    col("comp", "string", "", "component ux uy uz rx ry rz"),
                ],
            ),
            triplets("K", "N/m", true),
            triplets("M", "kg", true),
            triplets("C", "N*s/m", false),
            triplets("D", "N/m", false),
        ],
        ArtefactKind::Modes => vec![
            t(
                "frequencies",
                "parquet",
                true,
                vec![
                    col("mode", "int64", "", "mode number from 1"),
                    col("freq_hz", "float64", "Hz", "natural frequency"),
                    col(
                        "eigenvalue_rad2_s2",
                        "float64",
                        "rad^2/s^2",
                        "eigenvalue omega^2",
                    ),
                    col(
                        "residual",
                        "float64",
                        "",
                        "relative residual |K phi - lambda M phi| / |K phi|",
                    ),
                ],
            ),
            t(
                "shapes",
                "arrow_ipc",
                true,
                vec![
                    col("dof", "string", "", "DOF label node:comp"),
                    col(
                        "phi_{r}",
                        "float64",
                        "1/sqrt(kg)",
                        "mass-normalised shape of mode r, one column per mode",
                    ),
                ],
            ),
        ],
        ArtefactKind::Frf => vec![t(
            "frf",
            "parquet",
            true,
            vec![
                col("freq_hz", "float64", "Hz", "frequency line"),
                col("response", "string", "", "response DOF node:comp"),
                col("excitation", "string", "", "excitation DOF node:comp"),
                col("re", "float64", "meta.units.re", "real part"),
                col("im", "float64", "meta.units.im", "imaginary part"),
            ],
        )],
        ArtefactKind::Correlation => vec![
            t(
                "lines",
                "parquet",
                true,
                vec![
                    col("freq_hz", "float64", "Hz", "frequency line"),
                    col(
                        "chi_s",
                        "float64",
                        "",
                        "shape correlation coefficient (4.8)",
                    ),
                    col(
                        "chi_a",
                        "float64",
                        "",
                        "amplitude correlation coefficient (4.9)",
                    ),
                ],
            ),
            t(
                "frac",
                "parquet",
                true,
                vec![
                    col("response", "string", "", "response DOF"),
                    col("excitation", "string", "", "excitation DOF"),
                    col(
                        "frac",
                        "float64",
                        "",
                        "FRF assurance criterion over all lines (1.19)",
                    ),
                ],
            ),
        ],
        ArtefactKind::Plot => vec![],
        ArtefactKind::Partition | ArtefactKind::ReducedModel | ArtefactKind::ReducedComponent => {
            super::reduced::layout(kind)
        }
        ArtefactKind::ModalCorrelation => super::modal_correlation::layout(),
        ArtefactKind::Leverage | ArtefactKind::EigenvalueSensitivity => {
            super::leverage::layout(kind)
        }
        ArtefactKind::Mesh => vec![
            t(
                "nodes",
                "parquet",
                true,
                vec![
                    col("node", "int64", "", "grid id"),
                    col("x_m", "float64", "m", "basic x"),
                    col("y_m", "float64", "m", "basic y"),
                    col("z_m", "float64", "m", "basic z"),
                ],
            ),
            t(
                "elements",
                "parquet",
                true,
                vec![
                    col("element", "int64", "", "element id"),
                    col("type", "string", "", "quad4, tria3 or beam"),
                    col("property", "int64", "", "property id"),
                    col("n1", "int64", "", "first node"),
                    col("n2", "int64", "", "second node"),
                    col("n3", "int64", "", "third node or -1"),
                    col("n4", "int64", "", "fourth node or -1"),
                    col(
                        "v_x",
                        "float64",
                        "",
                        "beam orientation vector, NaN otherwise",
                    ),
                    col("v_y", "float64", "", "beam orientation vector"),
                    col("v_z", "float64", "", "beam orientation vector"),
                ],
            ),
            t(
                "lumped",
                "parquet",
                true,
                vec![
                    col("element", "int64", "", "element id"),
                    col("type", "string", "", "bush, scalar_spring or mass"),
                ],
            ),
            t(
                "constraints",
                "parquet",
                true,
                vec![col("dof", "string", "", "constrained DOF node:comp")],
            ),
            t(
                "sets",
                "parquet",
                true,
                vec![
                    col("set", "string", "", "set name"),
                    col("element", "int64", "", "element id"),
                ],
            ),
        ],
        ArtefactKind::UpdateResult => vec![
            t(
                "parameters",
                "parquet",
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
            t(
                "iterations",
                "parquet",
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
            ),
            t(
                "history",
                "parquet",
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
            t(
                "singular_values",
                "parquet",
                true,
                vec![
                    col("iteration", "int64", "", "iteration"),
                    col("index", "int64", "", "from 1, descending values"),
                    col("value", "float64", "", "singular value of weighted S"),
                ],
            ),
            t(
                "directions",
                "parquet",
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
            t(
                "modal_damping",
                "parquet",
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
        ],
    }
}

/// Checks an artefact against its kind's layout: required tables present, columns in order with
/// their types.
pub fn check_layout(a: &Artefact) -> Result<(), ArtefactError> {
    for tl in layout(a.kind) {
        let Some((table, _)) = a.tables.get(tl.name) else {
            if tl.required {
                return Err(ArtefactError::schema(
                    a.kind,
                    format!("missing table `{}`", tl.name),
                ));
            }
            continue;
        };
        let mut cols = table.columns.iter();
        for cl in &tl.columns {
            let repeated = cl.name.ends_with("_{r}");
            let stem = cl.name.trim_end_matches("{r}");
            loop {
                let Some((name, c)) = cols.next() else {
                    if repeated {
                        break;
                    }
                    return Err(ArtefactError::schema(
                        a.kind,
                        format!("table `{}` lacks column `{}`", tl.name, cl.name),
                    ));
                };
                let name_ok = if repeated {
                    name.starts_with(stem)
                } else {
                    name == cl.name
                };
                if !name_ok || c.type_name() != cl.dtype {
                    return Err(ArtefactError::schema(
                        a.kind,
                        format!(
                            "table `{}`: column `{name}` ({}) where `{}` ({}) belongs",
                            tl.name,
                            c.type_name(),
                            cl.name,
                            cl.dtype
                        ),
                    ));
                }
                if !repeated {
                    break;
                }
            }
        }
    }
    Ok(())
}

/// A plot artefact holding `<name>.png` and `<name>.svg`.
pub fn plot_artefact(name: &str, title: &str, fig: crate::report::frf_plot::Figure) -> Artefact {
    let mut a = Artefact::new(ArtefactKind::Plot).with_meta("title", title.into());
    a.blobs.insert(format!("{name}.png"), fig.png);
    a.blobs.insert(format!("{name}.svg"), fig.svg.into_bytes());
    a
}
