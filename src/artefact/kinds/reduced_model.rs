//! The `reduced_model` kind: a component-mode-synthesis model — reduced `K`, `M` over its
//! coordinates, per component its basis and coupling, and the reduced derivatives of the
//! model's parameters (docs/theory.md §9).
//!
//! | table (storage) | columns |
//! |---|---|
//! | `coords`, `components`, `junction` (Parquet) | `index, coord, kind`; per component figures; `dof` |
//! | `K`, `M` (IPC) | `row, col, value` |
//!
//! It also holds, per component `i` (in `components` order), `c<i>_dofs` and `c<i>_coords`
//! (Parquet) and the matrices `c<i>_T` (local basis `T_loc`, rows = its DOFs, columns = its
//! local coordinates), `c<i>_K`, `c<i>_M` (projected), `c<i>_C` (coupling from the reduced
//! coordinates), and for force coupling `c<i>_A`, `c<i>_B` (IPC, `row, col, value`); the full
//! transformation is `T_k = T_loc C_k`. `dK__<p>`, `dM__<p>` are the reduced derivatives
//! `Σ T_kᵀ ∂K_k/∂φ T_k` of every model parameter `p` (3.59); `interface` the interface modes
//! `Ψ` when the junction is reduced.

use super::reduced_component::{component_tables, coords_table, with_component_tables};
use super::{
    ColumnLayout, Kind, Layout, TableLayout, col, dense_from, dense_triplet_table, dofs_table,
    expect_kind, meta, strs, table, triplet_layout,
};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::eigen::ModeSelection;
use crate::reduction::force_coupling::MasterSelection;
use crate::reduction::{
    ComponentReduction, Coordinate, Coupling, Method, ReducedModel, ReductionInfo, SecondLevel,
};
use faer::Mat;

/// A reduced model as stored: the model, the reduced derivatives of its parameters, and the
/// component modes it kept (the components' mode frequencies are not stored, only their count
/// and the highest).
#[derive(Clone, Debug, PartialEq)]
pub struct ReducedModelArtefact {
    /// The model; its components' `mode_frequencies_hz` are empty when read back.
    pub model: ReducedModel,
    /// `(name, ∂K_c, ∂M_c)` per model parameter (3.59).
    pub derivatives: Vec<(String, Mat<f64>, Mat<f64>)>,
    /// Per component: modes kept and the highest of them, Hz (0 when none).
    pub component_modes: Vec<(usize, f64)>,
}

/// The `reduced_model` kind.
pub struct ReducedModelKind;

impl Kind for ReducedModelKind {
    const KIND: ArtefactKind = ArtefactKind::ReducedModel;
    const NAME: &'static str = "reduced_model";
    /// 2: the matrix tables' indices are 32-bit integers.
    const VERSION: u32 = 2;
    type Value = ReducedModelArtefact;

    fn layout() -> Layout {
        Layout {
            tables: table_layouts(),
            meta: vec![
                meta("method", "reduction method and its settings"),
                meta("n_coords", "reduced coordinates"),
                meta("n_physical", "physical (junction) coordinates"),
                meta("n_modal", "modal coordinates"),
                meta("n_full_dofs", "DOFs of the full model"),
                meta("units", "units of K and M"),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(v: &ReducedModelArtefact) -> Artefact {
        write(&v.model, &v.derivatives, &v.component_modes)
    }

    fn from_artefact(a: &Artefact) -> Result<ReducedModelArtefact, ArtefactError> {
        let model = reduced_from_artefact(a)?;
        let ct = a.table("components")?;
        let count = ct.i64s("components", "n_modes")?;
        let highest = ct.f64s("components", "highest_mode_hz")?;
        let n = model.n();
        let mut derivatives = Vec::new();
        for name in a.tables.keys() {
            if let Some(p) = name.strip_prefix("dK__") {
                derivatives.push((
                    p.to_string(),
                    dense_from(a, name, n, n)?,
                    dense_from(a, &format!("dM__{p}"), n, n)?,
                ));
            }
        }
        Ok(ReducedModelArtefact {
            model,
            derivatives,
            component_modes: count
                .iter()
                .zip(highest)
                .map(|(c, h)| ((*c).max(0) as usize, *h))
                .collect(),
        })
    }
}

fn table_layouts() -> Vec<TableLayout> {
    let s = Storage::Parquet;
    let coord = |name, doc| triplet_layout(name, false, "coords", "", doc);
    vec![
        table(
            "coords",
            s,
            true,
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
        table("components", s, true, component_columns()),
        table(
            "junction",
            s,
            true,
            vec![col("dof", "string", "", "junction DOF")],
        ),
        triplet_layout("K", true, "coords", "N/m", "non-zero entry"),
        triplet_layout("M", true, "coords", "kg", "non-zero entry"),
        coord("interface", "interface modes Psi (rows: junction DOFs)"),
        table(
            "c{i}_dofs",
            s,
            false,
            vec![col(
                "dof",
                "string",
                "",
                "component i's DOFs (rows of its T)",
            )],
        ),
        table(
            "c{i}_coords",
            s,
            false,
            vec![col(
                "coord",
                "string",
                "",
                "component i's local coordinates",
            )],
        ),
        coord("c{i}_T", "component i's local basis T_loc"),
        coord("c{i}_K", "component i's projected stiffness"),
        coord("c{i}_M", "component i's projected mass"),
        coord(
            "c{i}_C",
            "component i's coupling from the reduced coordinates",
        ),
        coord(
            "c{i}_A",
            "force coupling: component i's flexibility block A",
        ),
        coord(
            "c{i}_B",
            "force coupling: component i's flexibility block B",
        ),
        coord("dK__{p}", "reduced dK/dp of model parameter p (3.59)"),
        coord("dM__{p}", "reduced dM/dp of model parameter p (3.59)"),
    ]
}

fn component_columns() -> Vec<ColumnLayout> {
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
    ]
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
    let modes: Vec<(usize, f64)> = r
        .components
        .iter()
        .map(|c| {
            let f = &c.mode_frequencies_hz;
            (f.len(), f.last().copied().unwrap_or(0.0))
        })
        .collect();
    write(r, derivatives, &modes)
}

fn write(
    r: &ReducedModel,
    derivatives: &[(String, Mat<f64>, Mat<f64>)],
    component_modes: &[(usize, f64)],
) -> Artefact {
    let (phys, modal) = r.size();
    let mut a = Artefact::new(ReducedModelKind::KIND)
        .with_meta("method", method_json(&r.method))
        .with_meta("n_coords", r.n().into())
        .with_meta("n_physical", phys.into())
        .with_meta("n_modal", modal.into())
        .with_meta("n_full_dofs", r.dofs().len().into())
        .with_meta(
            "units",
            serde_json::json!({"K": "N/m (physical), rad^2/s^2*kg (modal)", "M": "kg"}),
        )
        .with_table("coords", coords_table_of(r), Storage::Parquet)
        .with_table(
            "components",
            components_table(&r.components, component_modes),
            Storage::Parquet,
        )
        .with_table(
            "junction",
            Table::new().with("dof", super::dof_strs(&r.junction)),
            Storage::Parquet,
        )
        .with_table("K", dense_triplet_table(&r.k), Storage::Ipc)
        .with_table("M", dense_triplet_table(&r.m), Storage::Ipc);
    for (i, (c, cp)) in r.components.iter().zip(&r.couplings).enumerate() {
        let p = format!("c{i}_");
        a = with_component_tables(a, &p, c);
        let cm = coupling_matrix(cp, r.n());
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

/// The reduced coordinates with their kinds.
fn coords_table_of(r: &ReducedModel) -> Table {
    Table::new()
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
        )
}

/// Per component its sizes, the modes it kept and the highest, rigid-body modes and masters.
fn components_table(comps: &[ComponentReduction], modes: &[(usize, f64)]) -> Table {
    let i = |f: fn(&ComponentReduction) -> usize| {
        Column::I64(comps.iter().map(|c| f(c) as i64).collect())
    };
    Table::new()
        .with(
            "substructure",
            strs(comps.iter().map(|c| c.substructure.clone())),
        )
        .with("n_dofs", i(|c| c.dofs.len()))
        .with("n_junction", i(|c| c.junction.len()))
        .with("n_local", i(|c| c.coords.len()))
        .with(
            "n_modes",
            Column::I64(modes.iter().map(|m| m.0 as i64).collect()),
        )
        .with(
            "highest_mode_hz",
            Column::F64(modes.iter().map(|m| m.1).collect()),
        )
        .with("rigid_body_modes", i(|c| c.info.rigid_body_modes))
        .with("masters", i(|c| c.info.masters))
}

/// A component's coupling as a dense `local × n` matrix.
fn coupling_matrix(cp: &Coupling, n: usize) -> Mat<f64> {
    match cp {
        Coupling::Boolean(map) => {
            let mut m = Mat::zeros(map.len(), n);
            for (l, g) in map.iter().enumerate() {
                m[(l, *g)] = 1.0;
            }
            m
        }
        Coupling::Dense(m) => m.clone(),
    }
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
