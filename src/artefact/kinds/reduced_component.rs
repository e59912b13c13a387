//! The `reduced_component` kind: one substructure's reduction — its basis `T`, `TᵀKT`, `TᵀMT`,
//! its DOFs and local coordinates, and for force coupling the junction flexibility `A`, `B` —
//! the unit the `reduce.*` stages cache (docs/theory.md §9). The component tables are shared
//! with `reduced_model`, which holds them per component under the prefix `c<i>_`.
//!
//! | table (storage) | columns |
//! |---|---|
//! | `dofs`, `junction` (Parquet) | `dof` |
//! | `coords` (Parquet) | `coord` |
//! | `component_modes` (Parquet) | `mode, frequency_hz` |
//! | `T`, `K`, `M`, `A`, `B` (IPC) | `row, col, value` |

use super::{
    Kind, Layout, col, dense_from, dense_triplet_table, dofs_table, expect_kind, meta, strs, table,
    triplet_layout,
};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::reduction::{ComponentReduction, Coordinate, JunctionFlexibility, ReductionInfo};
use faer::Mat;

/// The `reduced_component` kind. Round-trips exactly, except the timing in `info.seconds`,
/// which is not content.
pub struct ReducedComponentKind;

impl Kind for ReducedComponentKind {
    const KIND: ArtefactKind = ArtefactKind::ReducedComponent;
    const NAME: &'static str = "reduced_component";
    /// 2: the matrix tables' indices are 32-bit integers.
    const VERSION: u32 = 2;
    type Value = ComponentReduction;

    fn layout() -> Layout {
        let s = Storage::Parquet;
        let coords = "coords";
        Layout {
            tables: vec![
                table(
                    "dofs",
                    s,
                    true,
                    vec![col(
                        "dof",
                        "string",
                        "",
                        "the substructure's DOFs (rows of T)",
                    )],
                ),
                table(
                    "junction",
                    s,
                    true,
                    vec![col("dof", "string", "", "its junction DOFs")],
                ),
                table(
                    "coords",
                    s,
                    true,
                    vec![col(
                        "coord",
                        "string",
                        "",
                        "local coordinates (columns of T): node:comp, <substructure>:q<n> or a junction force",
                    )],
                ),
                table(
                    "component_modes",
                    s,
                    true,
                    vec![
                        col("mode", "int64", "", "component mode number"),
                        col("frequency_hz", "float64", "Hz", "its natural frequency"),
                    ],
                ),
                triplet_layout("T", true, coords, "", "non-zero entry"),
                triplet_layout("K", true, coords, "N/m", "non-zero entry"),
                triplet_layout("M", true, coords, "kg", "non-zero entry"),
                triplet_layout(
                    "A",
                    false,
                    coords,
                    "",
                    "force coupling: junction flexibility block A, non-zero entry",
                ),
                triplet_layout(
                    "B",
                    false,
                    coords,
                    "",
                    "force coupling: junction flexibility block B, non-zero entry",
                ),
            ],
            meta: vec![
                meta("substructure", "substructure name"),
                meta("rigid_body_modes", "rigid-body modes (free interface)"),
                meta("masters", "master DOFs (force coupling)"),
                meta("master_condition", "condition of the master selection"),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(c: &ComponentReduction) -> Artefact {
        component_to_artefact(c)
    }

    fn from_artefact(a: &Artefact) -> Result<ComponentReduction, ArtefactError> {
        component_from_artefact(a)
    }
}

/// The `coord` column of table `table`.
pub(crate) fn coords_table(a: &Artefact, table: &str) -> Result<Vec<Coordinate>, ArtefactError> {
    a.table(table)?
        .strs(table, "coord")?
        .iter()
        .enumerate()
        .map(|(row, s)| {
            s.parse::<Coordinate>().map_err(|e| {
                ArtefactError::schema(a.kind, format!("table `{table}` row {row}: {e}"))
            })
        })
        .collect()
}

/// A component's own tables (`{prefix}dofs`, `coords`, `T`, `K`, `M` and, for force coupling,
/// `A`, `B`), shared by the `reduced_component` and `reduced_model` layouts.
pub(crate) fn with_component_tables(
    mut a: Artefact,
    prefix: &str,
    c: &ComponentReduction,
) -> Artefact {
    let p = prefix;
    a = a
        .with_table(
            &format!("{p}dofs"),
            Table::new().with("dof", strs(c.dofs.iter().map(|d| d.to_string()))),
            Storage::Parquet,
        )
        .with_table(
            &format!("{p}coords"),
            Table::new().with("coord", strs(c.coords.iter().map(|d| d.to_string()))),
            Storage::Parquet,
        )
        .with_table(&format!("{p}T"), dense_triplet_table(&c.t), Storage::Ipc)
        .with_table(&format!("{p}K"), dense_triplet_table(&c.k), Storage::Ipc)
        .with_table(&format!("{p}M"), dense_triplet_table(&c.m), Storage::Ipc);
    if let Some(f) = &c.flexibility {
        a = a
            .with_table(&format!("{p}A"), dense_triplet_table(&f.a), Storage::Ipc)
            .with_table(&format!("{p}B"), dense_triplet_table(&f.b), Storage::Ipc);
    }
    a
}

/// What [`with_component_tables`] wrote: DOFs, coordinates, `T`, `K`, `M`, flexibility.
pub(crate) type ComponentTables = (
    Vec<DofId>,
    Vec<Coordinate>,
    Mat<f64>,
    Mat<f64>,
    Mat<f64>,
    Option<JunctionFlexibility>,
);

pub(crate) fn component_tables(
    a: &Artefact,
    prefix: &str,
) -> Result<ComponentTables, ArtefactError> {
    let p = prefix;
    let dofs = dofs_table(a, &format!("{p}dofs"))?;
    let coords = coords_table(a, &format!("{p}coords"))?;
    let (n, r) = (dofs.len(), coords.len());
    let flexibility = if a.tables.contains_key(&format!("{p}A")) {
        let forces = coords
            .iter()
            .filter(|c| matches!(c, Coordinate::Force(_)))
            .count();
        Some(JunctionFlexibility {
            a: dense_from(a, &format!("{p}A"), forces, r - forces)?,
            b: dense_from(a, &format!("{p}B"), forces, forces)?,
        })
    } else {
        None
    };
    Ok((
        dofs,
        coords,
        dense_from(a, &format!("{p}T"), n, r)?,
        dense_from(a, &format!("{p}K"), r, r)?,
        dense_from(a, &format!("{p}M"), r, r)?,
        flexibility,
    ))
}

/// One substructure's reduction as its own artefact (`reduced_component`): the unit the
/// `reduce.*` stages cache, so that a change in one substructure reuses the others. Round-trips
/// exactly, except the timing in `info.seconds`, which is not content.
pub fn component_to_artefact(c: &ComponentReduction) -> Artefact {
    let a = Artefact::new(ReducedComponentKind::KIND)
        .with_meta("substructure", c.substructure.clone().into())
        .with_meta("rigid_body_modes", c.info.rigid_body_modes.into())
        .with_meta("masters", c.info.masters.into())
        .with_meta("master_condition", c.info.master_condition.into())
        .with_table(
            "junction",
            Table::new().with("dof", strs(c.junction.iter().map(|d| d.to_string()))),
            Storage::Parquet,
        )
        .with_table(
            "component_modes",
            Table::new()
                .with(
                    "mode",
                    Column::I64((1..=c.mode_frequencies_hz.len() as i64).collect()),
                )
                .with("frequency_hz", Column::F64(c.mode_frequencies_hz.clone())),
            Storage::Parquet,
        );
    with_component_tables(a, "", c)
}

/// A substructure's reduction from its artefact.
pub fn component_from_artefact(a: &Artefact) -> Result<ComponentReduction, ArtefactError> {
    expect_kind(a, ArtefactKind::ReducedComponent)?;
    let meta_usize = |key: &str| a.meta.get(key).and_then(|v| v.as_u64()).unwrap_or(0) as usize;
    let (dofs, coords, t, k, m, flexibility) = component_tables(a, "")?;
    Ok(ComponentReduction {
        substructure: a
            .meta
            .get("substructure")
            .and_then(|v| v.as_str())
            .unwrap_or_default()
            .to_string(),
        junction: dofs_table(a, "junction")?,
        t,
        k,
        m,
        mode_frequencies_hz: a
            .table("component_modes")?
            .f64s("component_modes", "frequency_hz")?
            .to_vec(),
        dofs,
        coords,
        flexibility,
        info: ReductionInfo {
            rigid_body_modes: meta_usize("rigid_body_modes"),
            masters: meta_usize("masters"),
            master_condition: a
                .meta
                .get("master_condition")
                .and_then(|v| v.as_f64())
                .unwrap_or(0.0),
            seconds: 0.0,
        },
    })
}
