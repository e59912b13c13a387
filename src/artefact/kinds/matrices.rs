//! The `matrices` kind: system matrices `K`, `M`, optional `C`, `D`, with their DOF labels, and
//! (written by `assemble` and `model.lumped`) the derivatives `dK__<p>`, `dM__<p>` of updating
//! parameters.
//!
//! | table (storage) | columns |
//! |---|---|
//! | `dofs` (Parquet) | `index, dof, node, comp` |
//! | `K`, `M`, `C`, `D`, `dK__<p>`, `dM__<p>` (IPC) | `row, col, value`: with meta `triangle: lower` (as femu writes them) the lower triangle `row ≥ col` of the symmetric matrix; without it, every entry |
//! | `dependent` (Parquet; written by `assemble` for a model with rigid elements or MPCs) | `dof, independent, coefficient, origin`: each DOF eliminated by a multipoint constraint as `Σ coefficient · u_independent` over DOFs of `dofs`, one row per term (none: one row with an empty `independent`) |

use super::{
    Kind, Layout, col, expect_kind, lower_table, lower_triplet_table, meta, meta_opt, mirror_lower,
    mirror_sorted_lower, parse_dofs, read_sparse, table, triplet_layout,
};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Indices, Storage, Table};
use crate::core::DofId;
use crate::core::sparse::{SparseMatrix, sparse_from_triplets};
use crate::fe::SystemMatrices;
use crate::fe::multipoint::DependentDof;
use crate::fe::system::LowerSystem;
use crate::sparse::LowerPencil;
use rayon::prelude::*;

/// The `matrices` kind.
pub struct MatricesKind;

impl Kind for MatricesKind {
    const KIND: ArtefactKind = ArtefactKind::Matrices;
    const NAME: &'static str = "matrices";
    /// 2: the matrix tables hold lower triangles (meta `triangle`); 3: their indices are
    /// 32-bit integers (a third fewer bytes to write, hash and read).
    const VERSION: u32 = 3;
    type Value = SystemMatrices;

    fn layout() -> Layout {
        Layout {
            tables: vec![
                table(
                    "dofs",
                    Storage::Parquet,
                    true,
                    vec![
                        col("index", "int64", "", "row/column index"),
                        col("dof", "string", "", "DOF label node:comp"),
                        col("node", "int64", "", "node id"),
                        col("comp", "string", "", "component ux uy uz rx ry rz"),
                    ],
                ),
                triplet_layout("K", true, "dofs", "N/m", "entry; duplicates sum"),
                triplet_layout("M", true, "dofs", "kg", "entry; duplicates sum"),
                triplet_layout("C", false, "dofs", "N*s/m", "entry; duplicates sum"),
                triplet_layout("D", false, "dofs", "N/m", "entry; duplicates sum"),
                triplet_layout(
                    "dK__{p}",
                    false,
                    "dofs",
                    "",
                    "dK/dp of updating parameter p (2.13); duplicates sum",
                ),
                triplet_layout(
                    "dM__{p}",
                    false,
                    "dofs",
                    "",
                    "dM/dp of updating parameter p (2.13); duplicates sum",
                ),
                table(
                    "dependent",
                    Storage::Parquet,
                    false,
                    vec![
                        col(
                            "dof",
                            "string",
                            "",
                            "DOF eliminated by a rigid element or MPC",
                        ),
                        col(
                            "independent",
                            "string",
                            "",
                            "a DOF of `dofs` it depends on (empty: none)",
                        ),
                        col("coefficient", "float64", "", "its coefficient"),
                        col("origin", "string", "", "the card, e.g. RBE2 12"),
                    ],
                ),
            ],
            meta: vec![
                meta("n_dofs", "number of DOFs"),
                meta("dof_index", "digest of the DOF list"),
                meta("units", "unit of each matrix"),
                meta_opt(
                    "parameters",
                    "updating parameters with value, bounds and whether they enter linearly",
                ),
                meta_opt(
                    TRIANGLE,
                    "`lower`: each matrix table holds the lower triangle (row >= col) of its symmetric matrix; absent: every entry",
                ),
                meta_opt("total_dofs", "DOFs before constraints (assemble)"),
                meta_opt(
                    "eigenvalue_request",
                    "the modes the imported deck's METHOD/EIGRL asks for (from the mesh)",
                ),
                meta_opt(
                    "auto_constrained",
                    "DOFs without stiffness that assemble constrained",
                ),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(sys: &SystemMatrices) -> Artefact {
        // The matrices' tables (each hundreds of megabytes at 10⁶ DOFs) and the DOFs' labels
        // built side by side.
        let (dofs, tables) = rayon::join(
            || DofTables::of(&sys.dofs),
            || {
                sys.named()
                    .into_par_iter()
                    .map(|(name, mat)| (name, lower_triplet_table(mat)))
                    .collect::<Vec<(&str, Table)>>()
            },
        );
        dofs.with_matrices(tables)
    }

    fn from_artefact(a: &Artefact) -> Result<SystemMatrices, ArtefactError> {
        let kind = Self::KIND;
        expect_kind(a, kind)?;
        let dofs = parse_dofs(kind, "dofs", a.table("dofs")?.strs("dofs", "dof")?)?;
        let n = dofs.len();
        let lower = stores_lower(a)?;
        // The four matrices read side by side.
        let read = |name: &str| read_symmetric(a, name, n, lower);
        let ((k, m), (c, d)) = rayon::join(
            || rayon::join(|| read("K"), || read("M")),
            || rayon::join(|| read("C"), || read("D")),
        );
        let sys = SystemMatrices {
            k: k?.ok_or_else(|| ArtefactError::schema(kind, "no stiffness table `K`"))?,
            m: m?.ok_or_else(|| ArtefactError::schema(kind, "no mass table `M`"))?,
            c: c?,
            d: d?,
            dofs,
        };
        // Mirrored from lower triangles, the matrices are symmetric by construction.
        let checked = if lower {
            sys.validate_shapes_and_values()
        } else {
            sys.validate()
        };
        checked.map_err(|e| ArtefactError::schema(kind, e.to_string()))?;
        Ok(sys)
    }
}

/// The DOFs' part of a matrices artefact: their labels' digest and table.
struct DofTables {
    n: usize,
    dof_index: String,
    table: Table,
}

impl DofTables {
    /// The digest and the table, built side by side.
    fn of(dofs: &[DofId]) -> Self {
        let (dof_index, table) = rayon::join(|| super::dof_index_digest(dofs), || dof_table(dofs));
        Self {
            n: dofs.len(),
            dof_index,
            table,
        }
    }

    /// The artefact of these DOFs and the lower triangles `tables` of their matrices.
    fn with_matrices(self, tables: Vec<(&str, Table)>) -> Artefact {
        let mut a = Artefact::new(MatricesKind::KIND)
            .with_meta("n_dofs", self.n.into())
            .with_meta("dof_index", self.dof_index.into())
            .with_meta(
                "units",
                serde_json::json!({"K": "N/m", "M": "kg", "C": "N*s/m", "D": "N/m"}),
            )
            .with_meta(TRIANGLE, LOWER.into())
            .with_table("dofs", self.table, Storage::Parquet);
        for (name, table) in tables {
            a = a.with_table(name, table, Storage::Ipc);
        }
        a
    }
}

/// Meta key: how the matrix tables are stored.
pub const TRIANGLE: &str = "triangle";
/// [`TRIANGLE`]'s value for lower triangles of symmetric matrices.
pub const LOWER: &str = "lower";

/// Whether a matrices artefact stores lower triangles (meta `triangle: lower`); absent: full
/// matrices (artefacts written by hand or by other tools).
fn stores_lower(a: &Artefact) -> Result<bool, ArtefactError> {
    match a.meta.get(TRIANGLE) {
        None => Ok(false),
        Some(v) if v.as_str() == Some(LOWER) => Ok(true),
        Some(v) => Err(ArtefactError::schema(
            a.kind,
            format!(
                "meta `{TRIANGLE}` is {v}; valid: \"{LOWER}\", or no `{TRIANGLE}` for full matrices"
            ),
        )),
    }
}

/// Symmetric matrix table `name` over `n` DOFs, if present: mirrored from its lower triangle
/// when the artefact stores lower triangles (`lower`, from [`stores_lower`]; an entry above the
/// diagonal is then an error), else read whole.
fn read_symmetric(
    a: &Artefact,
    name: &str,
    n: usize,
    lower: bool,
) -> Result<Option<SparseMatrix>, ArtefactError> {
    if !lower {
        return read_sparse(a, name, n);
    }
    if let Some((t, _)) = a.tables.get(name) {
        let (rows, cols) = (t.indices(name, "row")?, t.indices(name, "col")?);
        let values = t.f64s(name, "value")?;
        let mirrored = match (rows, cols) {
            (Indices::I32(r), Indices::I32(c)) => mirror_sorted_lower(n, r, c, values),
            (r, c) => mirror_sorted_lower(n, &r.to_i64(), &c.to_i64(), values),
        };
        if mirrored.is_some() {
            return Ok(mirrored);
        }
        let entries = rows.len().min(cols.len());
        if let Some(k) = (0..entries).find(|&k| rows.get(k) < cols.get(k)) {
            return Err(ArtefactError::schema(
                a.kind,
                format!(
                    "table `{name}` row {k}: entry ({}, {}) lies above the diagonal, but meta `{TRIANGLE}: {LOWER}` says the table holds a lower triangle",
                    rows.get(k),
                    cols.get(k)
                ),
            ));
        }
    }
    Ok(read_sparse(a, name, n)?.map(|l| mirror_lower(&l)))
}

fn dof_table(dofs: &[DofId]) -> Table {
    let (labels, comps) = rayon::join(
        || super::dof_strs(dofs),
        || Column::Str(dofs.par_iter().map(|d| d.comp.name().to_string()).collect()),
    );
    Table::new()
        .with("index", Column::I64((0..dofs.len() as i64).collect()))
        .with("dof", labels)
        .with(
            "node",
            Column::I64(dofs.iter().map(|d| d.node as i64).collect()),
        )
        .with("comp", comps)
}

/// The `dependent` table: each dependent DOF's terms, one row per term.
pub fn dependent_table(dependent: &[DependentDof]) -> Table {
    let (mut dof, mut ind, mut coef, mut origin) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for d in dependent {
        let rows: Vec<(String, f64)> = if d.terms.is_empty() {
            vec![(String::new(), 0.0)]
        } else {
            d.terms.iter().map(|(t, c)| (t.to_string(), *c)).collect()
        };
        for (t, c) in rows {
            dof.push(d.dof.to_string());
            ind.push(t);
            coef.push(c);
            origin.push(d.origin.clone());
        }
    }
    Table::new()
        .with("dof", Column::Str(dof))
        .with("independent", Column::Str(ind))
        .with("coefficient", Column::F64(coef))
        .with("origin", Column::Str(origin))
}

/// The dependent DOFs a matrices artefact records (none without a `dependent` table).
pub fn dependent_from_matrices(a: &Artefact) -> Result<Vec<DependentDof>, ArtefactError> {
    let kind = ArtefactKind::Matrices;
    let n = "dependent";
    if !a.tables.contains_key(n) {
        return Ok(Vec::new());
    }
    let t = a.table(n)?;
    let (dof, ind, coef, origin) = (
        t.strs(n, "dof")?,
        t.strs(n, "independent")?,
        t.f64s(n, "coefficient")?,
        t.strs(n, "origin")?,
    );
    let parse = |s: &str, r: usize| -> Result<DofId, ArtefactError> {
        s.parse()
            .map_err(|e| ArtefactError::schema(kind, format!("dependent row {r}: {e}")))
    };
    let mut out: Vec<DependentDof> = Vec::new();
    for r in 0..dof.len() {
        if r == 0 || dof[r] != dof[r - 1] {
            out.push(DependentDof {
                dof: parse(&dof[r], r)?,
                terms: Vec::new(),
                origin: origin[r].clone(),
            });
        }
        if !ind[r].is_empty() {
            let term = parse(&ind[r], r)?;
            if let Some(d) = out.last_mut() {
                d.terms.push((term, coef[r]));
            }
        }
    }
    Ok(out)
}

/// System matrices as an artefact.
pub fn matrices_to_artefact(sys: &SystemMatrices) -> Artefact {
    MatricesKind::to_artefact(sys)
}

/// System matrices as an artefact, from `K` and `M` already as lower triangles (from
/// [`crate::fe::model_assembly::assemble_model_lower`]) and the viscous damping `c`, if any:
/// the triangles' columns become the tables as they are.
pub fn lower_matrices_to_artefact(sys: LowerSystem, c: Option<&SparseMatrix>) -> Artefact {
    let LowerSystem { dofs, k, m } = sys;
    let (dofs, c) = rayon::join(|| DofTables::of(&dofs), || c.map(lower_triplet_table));
    let mut tables = vec![("K", lower_table(k)), ("M", lower_table(m))];
    tables.extend(c.map(|c| ("C", c)));
    dofs.with_matrices(tables)
}

/// System matrices from an artefact.
pub fn matrices_from_artefact(a: &Artefact) -> Result<SystemMatrices, ArtefactError> {
    MatricesKind::from_artefact(a)
}

/// The stiffness and mass of a matrices artefact as a [`LowerPencil`], with the DOFs: straight
/// from the lower-triangle tables femu writes, without building the full matrices or reading
/// `C` and `D` (what the `modes` stage needs at a million DOFs: 0.76 GB where the full `K`
/// and `M` took 1.72 GB). Other artefacts go through [`matrices_from_artefact`], whose errors
/// name the faulty entry.
pub fn pencil_from_matrices(a: &Artefact) -> Result<(LowerPencil, Vec<DofId>), ArtefactError> {
    let kind = MatricesKind::KIND;
    expect_kind(a, kind)?;
    if stores_lower(a)?
        && let (Some((k, _)), Some((m, _))) = (a.tables.get("K"), a.tables.get("M"))
    {
        let dofs = parse_dofs(kind, "dofs", a.table("dofs")?.strs("dofs", "dof")?)?;
        type Triplets<'t> = (Indices<'t>, Indices<'t>, &'t [f64]);
        fn triplets<'t>(name: &str, t: &'t Table) -> Result<Triplets<'t>, ArtefactError> {
            Ok((
                t.indices(name, "row")?,
                t.indices(name, "col")?,
                t.f64s(name, "value")?,
            ))
        }
        let (kt, mt) = (triplets("K", k)?, triplets("M", m)?);
        let n = dofs.len();
        let pencil = match (kt, mt) {
            (
                (Indices::I32(kr), Indices::I32(kc), kv),
                (Indices::I32(mr), Indices::I32(mc), mv),
            ) => LowerPencil::from_sorted_lower(n, (kr, kc, kv), (mr, mc, mv)),
            ((kr, kc, kv), (mr, mc, mv)) => LowerPencil::from_sorted_lower(
                n,
                (&kr.to_i64(), &kc.to_i64(), kv),
                (&mr.to_i64(), &mc.to_i64(), mv),
            ),
        };
        if let Some(pencil) = pencil {
            // The indices were checked above; a value that is not finite is named.
            for (name, (rows, cols, values)) in [("K", kt), ("M", mt)] {
                if let Some(t) = values.par_iter().position_first(|v| !v.is_finite()) {
                    let e = crate::fe::SystemMatricesError::NotFinite {
                        name,
                        row_dof: dofs[rows.get(t) as usize],
                        col_dof: dofs[cols.get(t) as usize],
                        value: values[t],
                    };
                    return Err(ArtefactError::schema(kind, e.to_string()));
                }
            }
            return Ok((pencil, dofs));
        }
    }
    let sys = matrices_from_artefact(a)?;
    let pencil = LowerPencil::from_full(&sys.k, &sys.m)
        .map_err(|e| ArtefactError::schema(kind, e.to_string()))?;
    Ok((pencil, sys.dofs))
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
        SparseMatrix,
        SparseMatrix,
    )>,
    ArtefactError,
> {
    let kind = ArtefactKind::Matrices;
    let Some(list) = a.meta.get("parameters") else {
        return Ok(Vec::new());
    };
    let list: Vec<serde_json::Value> = serde_json::from_value(list.clone())
        .map_err(|e| ArtefactError::schema(kind, format!("meta `parameters`: {e}")))?;
    let lower = stores_lower(a)?;
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
        let dk = match read_symmetric(a, &format!("dK__{}", e.name), n, lower)? {
            Some(m) => m,
            None => zero()?,
        };
        let dm = match read_symmetric(a, &format!("dM__{}", e.name), n, lower)? {
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
