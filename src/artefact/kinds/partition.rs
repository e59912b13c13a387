//! The `partition` kind: the substructures of a model, their elements, junction and internal
//! DOFs, and the boundaries between them (docs/theory.md §9).
//!
//! | table (Parquet) | columns |
//! |---|---|
//! | `substructures` | `substructure, element` |
//! | `dofs` | `substructure, dof, role` |
//! | `boundaries` | `boundary, substructures, dof` |

use super::{Kind, Layout, col, meta, strs, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::reduction::{Boundary, Partition, Substructure};
use std::collections::BTreeMap;

/// The `partition` kind.
pub struct PartitionKind;

impl Kind for PartitionKind {
    const KIND: ArtefactKind = ArtefactKind::Partition;
    const NAME: &'static str = "partition";
    type Value = Partition;

    fn layout() -> Layout {
        let s = Storage::Parquet;
        Layout {
            tables: vec![
                table(
                    "substructures",
                    s,
                    true,
                    vec![
                        col("substructure", "string", "", "substructure name"),
                        col("element", "int64", "", "element id"),
                    ],
                ),
                table(
                    "dofs",
                    s,
                    true,
                    vec![
                        col("substructure", "string", "", "substructure name"),
                        col("dof", "string", "", "DOF node:comp"),
                        col("role", "string", "", "junction (shared) or internal"),
                    ],
                ),
                table(
                    "boundaries",
                    s,
                    true,
                    vec![
                        col("boundary", "int64", "", "boundary number from 1"),
                        col(
                            "substructures",
                            "string",
                            "",
                            "substructures sharing it, comma-separated",
                        ),
                        col("dof", "string", "", "junction DOF node:comp"),
                    ],
                ),
            ],
            meta: vec![
                meta("n_substructures", "number of substructures"),
                meta("n_junction_dofs", "DOFs shared by substructures"),
                meta("n_junction_nodes", "nodes shared by substructures"),
                meta("n_boundaries", "number of boundaries"),
                meta(
                    "substructures",
                    "per substructure: name, elements, DOFs, junction and internal DOFs",
                ),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(p: &Partition) -> Artefact {
        partition_to_artefact(p)
    }

    fn from_artefact(a: &Artefact) -> Result<Partition, ArtefactError> {
        partition_from_artefact(a)
    }
}

/// A partition as an artefact.
pub fn partition_to_artefact(p: &Partition) -> Artefact {
    let (mut s_name, mut s_elem) = (Vec::new(), Vec::new());
    let (mut d_name, mut d_dof, mut d_role) = (Vec::new(), Vec::new(), Vec::new());
    for s in &p.substructures {
        for e in &s.elements {
            s_name.push(s.name.clone());
            s_elem.push(*e as i64);
        }
        for d in &s.dofs {
            d_name.push(s.name.clone());
            d_dof.push(d.to_string());
            d_role.push(if s.junction.binary_search(d).is_ok() {
                "junction".to_string()
            } else {
                "internal".to_string()
            });
        }
    }
    let (mut b_id, mut b_subs, mut b_dof) = (Vec::new(), Vec::new(), Vec::new());
    for (i, b) in p.boundaries.iter().enumerate() {
        let names: Vec<String> = b
            .substructures
            .iter()
            .map(|k| p.substructures[*k].name.clone())
            .collect();
        for d in &b.dofs {
            b_id.push(i as i64 + 1);
            b_subs.push(names.join(","));
            b_dof.push(d.to_string());
        }
    }
    Artefact::new(PartitionKind::KIND)
        .with_meta("n_substructures", p.substructures.len().into())
        .with_meta("n_junction_dofs", p.junction.len().into())
        .with_meta("n_junction_nodes", p.junction_nodes().into())
        .with_meta("n_boundaries", p.boundaries.len().into())
        .with_meta(
            "substructures",
            serde_json::Value::Array(
                p.substructures
                    .iter()
                    .map(|s| {
                        serde_json::json!({"name": s.name, "elements": s.elements.len(),
                            "dofs": s.dofs.len(), "junction": s.junction.len(), "internal": s.internal.len()})
                    })
                    .collect(),
            ),
        )
        .with_table(
            "substructures",
            Table::new()
                .with("substructure", strs(s_name))
                .with("element", Column::I64(s_elem)),
            Storage::Parquet,
        )
        .with_table(
            "dofs",
            Table::new()
                .with("substructure", strs(d_name))
                .with("dof", strs(d_dof))
                .with("role", strs(d_role)),
            Storage::Parquet,
        )
        .with_table(
            "boundaries",
            Table::new()
                .with("boundary", Column::I64(b_id))
                .with("substructures", strs(b_subs))
                .with("dof", strs(b_dof)),
            Storage::Parquet,
        )
}

fn dof(kind: ArtefactKind, table: &str, row: usize, s: &str) -> Result<DofId, ArtefactError> {
    s.parse()
        .map_err(|e| ArtefactError::schema(kind, format!("table `{table}` row {row}: {e}")))
}

/// A partition from an artefact.
pub fn partition_from_artefact(a: &Artefact) -> Result<Partition, ArtefactError> {
    let kind = ArtefactKind::Partition;
    if a.kind != kind {
        return Err(ArtefactError::schema(
            kind,
            format!("got a `{}` artefact", a.kind),
        ));
    }
    let t = a.table("substructures")?;
    let names = t.strs("substructures", "substructure")?;
    let elems = t.i64s("substructures", "element")?;
    let mut order: Vec<String> = Vec::new();
    let mut subs: BTreeMap<String, Substructure> = BTreeMap::new();
    for (name, e) in names.iter().zip(elems.iter()) {
        let s = subs.entry(name.clone()).or_insert_with(|| {
            order.push(name.clone());
            Substructure {
                name: name.clone(),
                elements: vec![],
                dofs: vec![],
                junction: vec![],
                internal: vec![],
            }
        });
        s.elements.push(u64::try_from(*e).map_err(|_| {
            ArtefactError::schema(kind, format!("element id {e} of `{name}` is negative"))
        })?);
    }
    let t = a.table("dofs")?;
    let (dn, dd, dr) = (
        t.strs("dofs", "substructure")?,
        t.strs("dofs", "dof")?,
        t.strs("dofs", "role")?,
    );
    for row in 0..dn.len() {
        let s = subs.get_mut(&dn[row]).ok_or_else(|| {
            ArtefactError::schema(
                kind,
                format!("table `dofs` row {row}: unknown substructure `{}`", dn[row]),
            )
        })?;
        let d = dof(kind, "dofs", row, &dd[row])?;
        s.dofs.push(d);
        match dr[row].as_str() {
            "junction" => s.junction.push(d),
            "internal" => s.internal.push(d),
            other => {
                return Err(ArtefactError::schema(
                    kind,
                    format!("table `dofs` row {row}: role `{other}` is not junction or internal"),
                ));
            }
        }
    }
    let substructures: Vec<Substructure> = order.iter().filter_map(|n| subs.remove(n)).collect();
    let index: BTreeMap<&str, usize> = substructures
        .iter()
        .enumerate()
        .map(|(i, s)| (s.name.as_str(), i))
        .collect();
    let t = a.table("boundaries")?;
    let (bi, bs, bd) = (
        t.i64s("boundaries", "boundary")?,
        t.strs("boundaries", "substructures")?,
        t.strs("boundaries", "dof")?,
    );
    let mut boundaries: BTreeMap<i64, Boundary> = BTreeMap::new();
    for row in 0..bi.len() {
        let b = boundaries.entry(bi[row]).or_insert_with(|| Boundary {
            substructures: vec![],
            dofs: vec![],
        });
        if b.substructures.is_empty() {
            for n in bs[row].split(',') {
                b.substructures.push(*index.get(n).ok_or_else(|| {
                    ArtefactError::schema(
                        kind,
                        format!("table `boundaries` row {row}: unknown substructure `{n}`"),
                    )
                })?);
            }
        }
        b.dofs.push(dof(kind, "boundaries", row, &bd[row])?);
    }
    let mut junction: Vec<DofId> = substructures
        .iter()
        .flat_map(|s| s.junction.iter().copied())
        .collect();
    junction.sort_unstable();
    junction.dedup();
    Ok(Partition {
        substructures,
        junction,
        boundaries: boundaries.into_values().collect(),
    })
}
