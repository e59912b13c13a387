//! Typed views of the substructuring artefacts (docs/theory.md §9).
//!
//! | kind | tables (storage) | columns |
//! |---|---|---|
//! | `partition` | `substructures`, `dofs`, `boundaries` (Parquet) | `substructure, element`; `substructure, dof, role`; `boundary, substructures, dof` |
//! | `reduced_model` | `coords`, `components`, `junction` (Parquet); `K`, `M` (IPC) | `index, coord, kind`; per component figures; `dof`; `row, col, value` |
//!
//! A reduced model also holds, per component `i` (in `components` order), `c<i>_dofs` and
//! `c<i>_coords` (Parquet) and the matrices `c<i>_T` (local basis `T_loc`, rows = its DOFs,
//! columns = its local coordinates), `c<i>_K`, `c<i>_M` (projected), `c<i>_C` (coupling from the
//! reduced coordinates), and for force coupling `c<i>_A`, `c<i>_B` (IPC, `row, col, value`); the
//! full transformation is `T_k = T_loc C_k`. `dK__<p>`, `dM__<p>` are the reduced derivatives
//! `Σ T_kᵀ ∂K_k/∂φ T_k` of every model parameter `p` (3.59).

use super::kinds::{ColumnLayout, TableLayout, col, expect_kind};
use super::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::eigen::ModeSelection;
use crate::reduction::force_coupling::MasterSelection;
use crate::reduction::{
    Boundary, ComponentReduction, Coordinate, Coupling, JunctionFlexibility, Method, Partition,
    ReducedModel, ReductionInfo, SecondLevel, Substructure,
};
use faer::Mat;
use std::collections::BTreeMap;

fn strs(v: impl IntoIterator<Item = String>) -> Column {
    Column::Str(v.into_iter().collect())
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
    Artefact::new(ArtefactKind::Partition)
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

/// The `dof` column of table `table`.
fn dofs_table(a: &Artefact, table: &str) -> Result<Vec<DofId>, ArtefactError> {
    a.table(table)?
        .strs(table, "dof")?
        .iter()
        .enumerate()
        .map(|(row, s)| dof(a.kind, table, row, s))
        .collect()
}

/// The `coord` column of table `table`.
fn coords_table(a: &Artefact, table: &str) -> Result<Vec<Coordinate>, ArtefactError> {
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
fn with_component_tables(mut a: Artefact, prefix: &str, c: &ComponentReduction) -> Artefact {
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
type ComponentTables = (
    Vec<DofId>,
    Vec<Coordinate>,
    Mat<f64>,
    Mat<f64>,
    Mat<f64>,
    Option<JunctionFlexibility>,
);

fn component_tables(a: &Artefact, prefix: &str) -> Result<ComponentTables, ArtefactError> {
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
    for (name, e) in names.iter().zip(elems) {
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

/// A dense matrix as a `row, col, value` table of its non-zero entries.
pub fn dense_triplet_table(m: &Mat<f64>) -> Table {
    let (mut r, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            if m[(i, j)] != 0.0 {
                r.push(i as i64);
                c.push(j as i64);
                v.push(m[(i, j)]);
            }
        }
    }
    Table::new()
        .with("row", Column::I64(r))
        .with("col", Column::I64(c))
        .with("value", Column::F64(v))
}

fn dense_from(
    a: &Artefact,
    name: &str,
    rows: usize,
    cols: usize,
) -> Result<Mat<f64>, ArtefactError> {
    let kind = a.kind;
    let t = a.table(name)?;
    let (r, c, v) = (
        t.i64s(name, "row")?,
        t.i64s(name, "col")?,
        t.f64s(name, "value")?,
    );
    let mut m = Mat::zeros(rows, cols);
    for k in 0..r.len() {
        let (i, j) = (r[k], c[k]);
        if i < 0 || j < 0 || i as usize >= rows || j as usize >= cols {
            return Err(ArtefactError::schema(
                kind,
                format!("table `{name}` row {k}: entry ({i}, {j}) outside {rows}x{cols}"),
            ));
        }
        m[(i as usize, j as usize)] += v[k];
    }
    Ok(m)
}

fn selection_json(s: &ModeSelection) -> serde_json::Value {
    match s {
        ModeSelection::All => serde_json::json!("all"),
        ModeSelection::Count(c) => serde_json::json!({"count": c}),
        ModeSelection::BelowHz(f) => serde_json::json!({"max_freq_hz": f}),
    }
}

fn selection_from(v: &serde_json::Value) -> ModeSelection {
    if let Some(c) = v.get("count").and_then(|c| c.as_u64()) {
        ModeSelection::Count(c as usize)
    } else if let Some(f) = v.get("max_freq_hz").and_then(|f| f.as_f64()) {
        ModeSelection::BelowHz(f)
    } else {
        ModeSelection::All
    }
}

/// The method as JSON (reduced-model metadata, and part of a cached component's key).
pub fn method_json(m: &Method) -> serde_json::Value {
    match m {
        Method::CraigBampton { modes } | Method::FreeInterface { modes } => {
            serde_json::json!({"name": m.name(), "modes": selection_json(modes)})
        }
        Method::ForceCoupling {
            modes,
            masters,
            second_level,
        } => serde_json::json!({
            "name": m.name(),
            "modes": selection_json(modes),
            "candidates": masters.candidates.as_ref().map(|c| c.iter().map(|d| d.to_string()).collect::<Vec<_>>()),
            "required": masters.required.iter().map(|d| d.to_string()).collect::<Vec<_>>(),
            "per_mode": masters.per_mode,
            "second_level": second_level.as_ref().map(|s| serde_json::json!({
                "keep": s.keep, "modes": s.modes,
                "required": s.required.iter().map(|d| d.to_string()).collect::<Vec<_>>()})),
        }),
    }
}

fn method_from(v: &serde_json::Value) -> Result<Method, ArtefactError> {
    let kind = ArtefactKind::ReducedModel;
    let modes = selection_from(v.get("modes").unwrap_or(&serde_json::Value::Null));
    let dofs = |v: Option<&serde_json::Value>| -> Result<Vec<DofId>, ArtefactError> {
        v.and_then(|x| x.as_array())
            .map(|a| {
                a.iter()
                    .map(|s| {
                        s.as_str().unwrap_or("").parse::<DofId>().map_err(|e| {
                            ArtefactError::schema(kind, format!("metadata `method`: {e}"))
                        })
                    })
                    .collect()
            })
            .unwrap_or(Ok(vec![]))
    };
    match v.get("name").and_then(|n| n.as_str()) {
        Some("craig_bampton") => Ok(Method::CraigBampton { modes }),
        Some("free_interface") => Ok(Method::FreeInterface { modes }),
        Some("force_coupling") => Ok(Method::ForceCoupling {
            modes,
            masters: MasterSelection {
                candidates: match v.get("candidates") {
                    Some(c) if c.is_array() => Some(dofs(Some(c))?),
                    _ => None,
                },
                required: dofs(v.get("required"))?,
                per_mode: v.get("per_mode").and_then(|x| x.as_f64()).unwrap_or(1.0),
            },
            second_level: match v.get("second_level") {
                Some(s) if s.is_object() => Some(SecondLevel {
                    keep: s.get("keep").and_then(|x| x.as_u64()).unwrap_or(0) as usize,
                    modes: s.get("modes").and_then(|x| x.as_u64()).unwrap_or(0) as usize,
                    required: dofs(s.get("required"))?,
                }),
                _ => None,
            },
        }),
        other => Err(ArtefactError::schema(
            kind,
            format!(
                "metadata `method.name` is {other:?}, not craig_bampton, free_interface or force_coupling"
            ),
        )),
    }
}

/// A reduced model as an artefact; `derivatives` are the reduced `(name, ∂K_c, ∂M_c)` of the
/// model's parameters.
pub fn reduced_to_artefact(
    r: &ReducedModel,
    derivatives: &[(String, Mat<f64>, Mat<f64>)],
) -> Artefact {
    let (phys, modal) = r.size();
    let coords = Table::new()
        .with("index", Column::I64((0..r.n() as i64).collect()))
        .with("coord", strs(r.coords.iter().map(|c| c.to_string())))
        .with(
            "kind",
            strs(r.coords.iter().map(|c| {
                match c {
                    Coordinate::Dof(_) => "dof",
                    Coordinate::Modal { .. } => "modal",
                    Coordinate::Force(_) => "force",
                    Coordinate::InterfaceMode(_) => "interface",
                }
                .to_string()
            })),
        );
    let comps = &r.components;
    let components = Table::new()
        .with(
            "substructure",
            strs(comps.iter().map(|c| c.substructure.clone())),
        )
        .with(
            "n_dofs",
            Column::I64(comps.iter().map(|c| c.dofs.len() as i64).collect()),
        )
        .with(
            "n_junction",
            Column::I64(comps.iter().map(|c| c.junction.len() as i64).collect()),
        )
        .with(
            "n_local",
            Column::I64(comps.iter().map(|c| c.coords.len() as i64).collect()),
        )
        .with(
            "n_modes",
            Column::I64(
                comps
                    .iter()
                    .map(|c| c.mode_frequencies_hz.len() as i64)
                    .collect(),
            ),
        )
        .with(
            "highest_mode_hz",
            Column::F64(
                comps
                    .iter()
                    .map(|c| c.mode_frequencies_hz.last().copied().unwrap_or(0.0))
                    .collect(),
            ),
        )
        .with(
            "rigid_body_modes",
            Column::I64(
                comps
                    .iter()
                    .map(|c| c.info.rigid_body_modes as i64)
                    .collect(),
            ),
        )
        .with(
            "masters",
            Column::I64(comps.iter().map(|c| c.info.masters as i64).collect()),
        );
    let mut a = Artefact::new(ArtefactKind::ReducedModel)
        .with_meta("method", method_json(&r.method))
        .with_meta("n_coords", r.n().into())
        .with_meta("n_physical", phys.into())
        .with_meta("n_modal", modal.into())
        .with_meta("n_full_dofs", r.dofs().len().into())
        .with_meta(
            "units",
            serde_json::json!({"K": "N/m (physical), rad^2/s^2*kg (modal)", "M": "kg"}),
        )
        .with_table("coords", coords, Storage::Parquet)
        .with_table("components", components, Storage::Parquet)
        .with_table(
            "junction",
            Table::new().with("dof", strs(r.junction.iter().map(|d| d.to_string()))),
            Storage::Parquet,
        )
        .with_table("K", dense_triplet_table(&r.k), Storage::Ipc)
        .with_table("M", dense_triplet_table(&r.m), Storage::Ipc);
    for (i, (c, cp)) in r.components.iter().zip(&r.couplings).enumerate() {
        let p = format!("c{i}_");
        a = with_component_tables(a, &p, c);
        let cm = match cp {
            Coupling::Boolean(map) => {
                let mut m = Mat::zeros(map.len(), r.n());
                for (l, g) in map.iter().enumerate() {
                    m[(l, *g)] = 1.0;
                }
                m
            }
            Coupling::Dense(m) => m.clone(),
        };
        a = a.with_table(&format!("{p}C"), dense_triplet_table(&cm), Storage::Ipc);
    }
    if let Some(psi) = &r.interface {
        a = a.with_table("interface", dense_triplet_table(psi), Storage::Ipc);
    }
    for (name, dk, dm) in derivatives {
        a = a
            .with_table(
                &format!("dK__{name}"),
                dense_triplet_table(dk),
                Storage::Ipc,
            )
            .with_table(
                &format!("dM__{name}"),
                dense_triplet_table(dm),
                Storage::Ipc,
            );
    }
    a
}

/// One substructure's reduction as its own artefact (`reduced_component`): the unit the
/// `reduce.*` stages cache, so that a change in one substructure reuses the others. Round-trips
/// exactly, except the timing in `info.seconds`, which is not content.
pub fn component_to_artefact(c: &ComponentReduction) -> Artefact {
    let a = Artefact::new(ArtefactKind::ReducedComponent)
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

/// A reduced model from an artefact.
pub fn reduced_from_artefact(a: &Artefact) -> Result<ReducedModel, ArtefactError> {
    expect_kind(a, ArtefactKind::ReducedModel)?;
    let method = method_from(a.meta.get("method").unwrap_or(&serde_json::Value::Null))?;
    let coords = coords_table(a, "coords")?;
    let n = coords.len();
    let junction = dofs_table(a, "junction")?;
    let ct = a.table("components")?;
    let names = ct.strs("components", "substructure")?;
    let rigid = ct.i64s("components", "rigid_body_modes")?;
    let masters = ct.i64s("components", "masters")?;
    let mut components = Vec::with_capacity(names.len());
    let mut couplings = Vec::with_capacity(names.len());
    for (i, name) in names.iter().enumerate() {
        let p = format!("c{i}_");
        let (dofs, local, t, k, m, flexibility) = component_tables(a, &p)?;
        let rk = local.len();
        let cm = dense_from(a, &format!("{p}C"), rk, n)?;
        let boolean = (0..rk).all(|l| {
            let nz: Vec<usize> = (0..n).filter(|g| cm[(l, *g)] != 0.0).collect();
            nz.len() == 1 && cm[(l, nz[0])] == 1.0
        }) && !matches!(method, Method::ForceCoupling { .. });
        couplings.push(if boolean {
            Coupling::Boolean(
                (0..rk)
                    .map(|l| (0..n).find(|g| cm[(l, *g)] != 0.0).unwrap_or(0))
                    .collect(),
            )
        } else {
            Coupling::Dense(cm)
        });
        let junction_k: Vec<DofId> = dofs
            .iter()
            .copied()
            .filter(|d| junction.binary_search(d).is_ok())
            .collect();
        components.push(ComponentReduction {
            substructure: name.clone(),
            t,
            k,
            m,
            dofs,
            junction: junction_k,
            coords: local,
            mode_frequencies_hz: vec![],
            flexibility,
            info: ReductionInfo {
                rigid_body_modes: rigid.get(i).copied().unwrap_or(0).max(0) as usize,
                masters: masters.get(i).copied().unwrap_or(0).max(0) as usize,
                ..Default::default()
            },
        });
    }
    let interface_modes = coords
        .iter()
        .filter(|c| matches!(c, Coordinate::InterfaceMode(_)))
        .count();
    let interface = if a.tables.contains_key("interface") {
        Some(dense_from(a, "interface", junction.len(), interface_modes)?)
    } else {
        None
    };
    Ok(ReducedModel {
        interface,
        method,
        k: dense_from(a, "K", n, n)?,
        m: dense_from(a, "M", n, n)?,
        coords,
        components,
        couplings,
        junction,
    })
}

/// Published layouts of `partition`, `reduced_model` and `reduced_component`.
pub fn layout(kind: ArtefactKind) -> Vec<TableLayout> {
    let t = |name, storage, columns: Vec<ColumnLayout>| TableLayout {
        name,
        storage,
        required: true,
        columns,
    };
    let triplets = |name: &'static str, unit: &'static str| {
        t(
            name,
            "arrow_ipc",
            vec![
                col("row", "int64", "", "row index into `coords`"),
                col("col", "int64", "", "column index into `coords`"),
                col("value", "float64", unit, "non-zero entry"),
            ],
        )
    };
    match kind {
        ArtefactKind::Partition => vec![
            t(
                "substructures",
                "parquet",
                vec![
                    col("substructure", "string", "", "substructure name"),
                    col("element", "int64", "", "element id"),
                ],
            ),
            t(
                "dofs",
                "parquet",
                vec![
                    col("substructure", "string", "", "substructure name"),
                    col("dof", "string", "", "DOF node:comp"),
                    col("role", "string", "", "junction (shared) or internal"),
                ],
            ),
            t(
                "boundaries",
                "parquet",
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
        ArtefactKind::ReducedModel => vec![
            t(
                "coords",
                "parquet",
                vec![
                    col("index", "int64", "", "row/column of K and M"),
                    col(
                        "coord",
                        "string",
                        "",
                        "node:comp, or <substructure>:q<n> for a modal coordinate",
                    ),
                    col(
                        "kind",
                        "string",
                        "",
                        "dof, modal or interface (an interface mode)",
                    ),
                ],
            ),
            t(
                "components",
                "parquet",
                vec![
                    col("substructure", "string", "", "substructure name"),
                    col("n_dofs", "int64", "", "its physical DOFs"),
                    col("n_junction", "int64", "", "its junction DOFs"),
                    col("n_local", "int64", "", "its local reduced coordinates"),
                    col("n_modes", "int64", "", "component modes kept"),
                    col(
                        "highest_mode_hz",
                        "float64",
                        "Hz",
                        "highest component mode kept",
                    ),
                    col(
                        "rigid_body_modes",
                        "int64",
                        "",
                        "rigid-body modes (free interface)",
                    ),
                    col("masters", "int64", "", "master DOFs (force coupling)"),
                ],
            ),
            t(
                "junction",
                "parquet",
                vec![col("dof", "string", "", "junction DOF")],
            ),
            triplets("K", "N/m"),
            triplets("M", "kg"),
        ],
        ArtefactKind::ReducedComponent => vec![
            t(
                "dofs",
                "parquet",
                vec![col(
                    "dof",
                    "string",
                    "",
                    "the substructure's DOFs (rows of T)",
                )],
            ),
            t(
                "junction",
                "parquet",
                vec![col("dof", "string", "", "its junction DOFs")],
            ),
            t(
                "coords",
                "parquet",
                vec![col(
                    "coord",
                    "string",
                    "",
                    "local coordinates (columns of T): node:comp, <substructure>:q<n> or a junction force",
                )],
            ),
            t(
                "component_modes",
                "parquet",
                vec![
                    col("mode", "int64", "", "component mode number"),
                    col("frequency_hz", "float64", "Hz", "its natural frequency"),
                ],
            ),
            triplets("T", ""),
            triplets("K", "N/m"),
            triplets("M", "kg"),
        ],
        _ => vec![],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::element::MassKind;
    use crate::model::generate::{BentPlate, bent_plate};
    use crate::reduction::reduce;

    /// Partition and reduced model survive the round trip (reduced K, M, coordinates,
    /// transformations exactly; `check_layout` passes).
    #[test]
    fn round_trips() {
        let model = bent_plate(&BentPlate {
            with_bar: false,
            ..Default::default()
        });
        let p = Partition::from_sets(
            &model,
            &["plate_1".into(), "plate_2".into()],
            MassKind::Consistent,
        )
        .unwrap();
        let pa = partition_to_artefact(&p);
        super::super::kinds::check_layout(&pa).unwrap();
        assert_eq!(partition_from_artefact(&pa).unwrap(), p);
        for method in [
            Method::CraigBampton {
                modes: ModeSelection::BelowHz(200.0),
            },
            Method::ForceCoupling {
                modes: ModeSelection::BelowHz(200.0),
                masters: MasterSelection::default(),
                second_level: None,
            },
        ] {
            let r = reduce(&model, &p, &method, MassKind::Consistent).unwrap();
            let a = reduced_to_artefact(&r, &[]);
            super::super::kinds::check_layout(&a).unwrap();
            let back = reduced_from_artefact(&a).unwrap();
            assert_eq!(back.k, r.k);
            assert_eq!(back.coords, r.coords);
            assert_eq!(back.method, r.method);
            for k in 0..r.components.len() {
                assert_eq!(back.transformation(k), r.transformation(k));
                let ca = component_to_artefact(&r.components[k]);
                super::super::kinds::check_layout(&ca).unwrap();
                let c = component_from_artefact(&ca).unwrap();
                let want = ComponentReduction {
                    info: ReductionInfo {
                        seconds: 0.0,
                        ..r.components[k].info.clone()
                    },
                    ..r.components[k].clone()
                };
                assert_eq!(c, want, "{} component {k}", method.name());
            }
        }
    }
}
