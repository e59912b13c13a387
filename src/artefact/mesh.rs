//! The `mesh` artefact: a [`Model`] as tables a user can open with pandas.
//!
//! | table | columns |
//! |---|---|
//! | `nodes` | `node, x_m, y_m, z_m` |
//! | `elements` | `element, type, property, n1, n2, n3, n4, v_x, v_y, v_z` (−1 / NaN when absent) |
//! | `lumped` | `element, type, node, comp, other, other_comp, k_1 … k_6, mass_kg, i11, i21, i22, i31, i32, i33, off_x, off_y, off_z` |
//! | `constraints` | `dof` |
//! | `sets` | `set, element` |
//!
//! Materials, properties and parameters are small and go into `meta` as JSON.

use super::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::model::{Element, Model};

const K: ArtefactKind = ArtefactKind::Mesh;

/// A model as an artefact.
pub fn mesh_to_artefact(m: &Model) -> Artefact {
    let nodes = Table::new()
        .with(
            "node",
            Column::I64(m.nodes.keys().map(|&n| n as i64).collect()),
        )
        .with("x_m", Column::F64(m.nodes.values().map(|x| x[0]).collect()))
        .with("y_m", Column::F64(m.nodes.values().map(|x| x[1]).collect()))
        .with("z_m", Column::F64(m.nodes.values().map(|x| x[2]).collect()));
    let (mut eid, mut ty, mut prop) = (Vec::new(), Vec::new(), Vec::new());
    let mut ns: [Vec<i64>; 4] = Default::default();
    let mut vs: [Vec<f64>; 3] = Default::default();
    let mut l_id = Vec::new();
    let mut l_ty = Vec::new();
    let (mut l_node, mut l_comp, mut l_other, mut l_ocomp) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut l_k: [Vec<f64>; 6] = Default::default();
    let mut l_mass = Vec::new();
    let mut l_i: [Vec<f64>; 6] = Default::default();
    let mut l_off: [Vec<f64>; 3] = Default::default();
    for (&id, e) in &m.elements {
        let shell_or_beam = |nodes: &[u64],
                             v: Option<[f64; 3]>,
                             p: u64,
                             eid: &mut Vec<i64>,
                             ty: &mut Vec<String>,
                             prop: &mut Vec<i64>,
                             ns: &mut [Vec<i64>; 4],
                             vs: &mut [Vec<f64>; 3]| {
            eid.push(id as i64);
            ty.push(e.type_name().to_string());
            prop.push(p as i64);
            for (k, col) in ns.iter_mut().enumerate() {
                col.push(nodes.get(k).map(|n| *n as i64).unwrap_or(-1));
            }
            for (k, col) in vs.iter_mut().enumerate() {
                col.push(v.map(|v| v[k]).unwrap_or(f64::NAN));
            }
        };
        match e {
            Element::Quad4 { nodes, property } => shell_or_beam(
                nodes, None, *property, &mut eid, &mut ty, &mut prop, &mut ns, &mut vs,
            ),
            Element::Tria3 { nodes, property } => shell_or_beam(
                nodes, None, *property, &mut eid, &mut ty, &mut prop, &mut ns, &mut vs,
            ),
            Element::Beam {
                nodes,
                property,
                orientation,
            } => shell_or_beam(
                nodes,
                Some(*orientation),
                *property,
                &mut eid,
                &mut ty,
                &mut prop,
                &mut ns,
                &mut vs,
            ),
            _ => {
                l_id.push(id as i64);
                l_ty.push(e.type_name().to_string());
                let (node, comp, other, ocomp, k, mass, inertia, off) = match e {
                    Element::Bush { node, other, k } => (
                        *node,
                        String::new(),
                        other.map(|o| o as i64).unwrap_or(-1),
                        String::new(),
                        *k,
                        0.0,
                        [0.0; 6],
                        [0.0; 3],
                    ),
                    Element::ScalarSpring { dof, other, k } => (
                        dof.node,
                        dof.comp.name().to_string(),
                        other.map(|o| o.node as i64).unwrap_or(-1),
                        other.map(|o| o.comp.name().to_string()).unwrap_or_default(),
                        [*k, 0.0, 0.0, 0.0, 0.0, 0.0],
                        0.0,
                        [0.0; 6],
                        [0.0; 3],
                    ),
                    Element::Mass {
                        node,
                        mass,
                        inertia,
                        offset,
                    } => (
                        *node,
                        String::new(),
                        -1,
                        String::new(),
                        [0.0; 6],
                        *mass,
                        *inertia,
                        *offset,
                    ),
                    _ => unreachable!("shells and beams are handled above"),
                };
                l_node.push(node as i64);
                l_comp.push(comp);
                l_other.push(other);
                l_ocomp.push(ocomp);
                for i in 0..6 {
                    l_k[i].push(k[i]);
                    l_i[i].push(inertia[i]);
                }
                l_mass.push(mass);
                for i in 0..3 {
                    l_off[i].push(off[i]);
                }
            }
        }
    }
    let [n1, n2, n3, n4] = ns;
    let [vx, vy, vz] = vs;
    let elements = Table::new()
        .with("element", Column::I64(eid))
        .with("type", Column::Str(ty))
        .with("property", Column::I64(prop))
        .with("n1", Column::I64(n1))
        .with("n2", Column::I64(n2))
        .with("n3", Column::I64(n3))
        .with("n4", Column::I64(n4))
        .with("v_x", Column::F64(vx))
        .with("v_y", Column::F64(vy))
        .with("v_z", Column::F64(vz));
    let mut lumped = Table::new()
        .with("element", Column::I64(l_id))
        .with("type", Column::Str(l_ty))
        .with("node", Column::I64(l_node))
        .with("comp", Column::Str(l_comp))
        .with("other", Column::I64(l_other))
        .with("other_comp", Column::Str(l_ocomp));
    for (i, c) in l_k.into_iter().enumerate() {
        lumped = lumped.with(format!("k_{}", i + 1), Column::F64(c));
    }
    lumped = lumped.with("mass_kg", Column::F64(l_mass));
    for (name, c) in ["i11", "i21", "i22", "i31", "i32", "i33"]
        .into_iter()
        .zip(l_i)
    {
        lumped = lumped.with(name, Column::F64(c));
    }
    for (name, c) in ["off_x", "off_y", "off_z"].into_iter().zip(l_off) {
        lumped = lumped.with(name, Column::F64(c));
    }
    let constraints = Table::new().with(
        "dof",
        Column::Str(m.constraints.iter().map(|d| d.to_string()).collect()),
    );
    let (mut s_name, mut s_el) = (Vec::new(), Vec::new());
    for (name, ids) in &m.sets {
        for e in ids {
            s_name.push(name.clone());
            s_el.push(*e as i64);
        }
    }
    let sets = Table::new()
        .with("set", Column::Str(s_name))
        .with("element", Column::I64(s_el));
    Artefact::new(K)
        .with_meta("n_nodes", m.nodes.len().into())
        .with_meta("n_elements", m.elements.len().into())
        .with_meta("n_dofs", m.n_dofs().into())
        .with_meta("materials", to_json(&m.materials))
        .with_meta("shell_properties", to_json(&m.shell_properties))
        .with_meta("beam_properties", to_json(&m.beam_properties))
        .with_meta("parameters", to_json(&m.parameters))
        .with_meta("units", serde_json::json!({"x_m": "m", "k_1": "N/m", "k_4": "N*m/rad", "mass_kg": "kg", "i11": "kg*m^2"}))
        .with_table("nodes", nodes, Storage::Parquet)
        .with_table("elements", elements, Storage::Parquet)
        .with_table("lumped", lumped, Storage::Parquet)
        .with_table("constraints", constraints, Storage::Parquet)
        .with_table("sets", sets, Storage::Parquet)
}

/// JSON of a small model part (id-keyed maps become objects).
fn to_json<T: serde::Serialize>(v: &T) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or(serde_json::Value::Null)
}

fn bad(msg: String) -> ArtefactError {
    ArtefactError::schema(K, msg)
}

fn meta<T: serde::de::DeserializeOwned>(a: &Artefact, key: &str) -> Result<T, ArtefactError> {
    let v = a.meta.get(key).cloned().unwrap_or(serde_json::Value::Null);
    serde_json::from_value(v).map_err(|e| bad(format!("metadata `{key}`: {e}")))
}

fn id(v: i64, what: &str, row: usize) -> Result<u64, ArtefactError> {
    u64::try_from(v).map_err(|_| bad(format!("{what} row {row}: id {v} must be >= 0")))
}

/// A model from an artefact; the result is validated.
pub fn mesh_from_artefact(a: &Artefact) -> Result<Model, ArtefactError> {
    if a.kind != K {
        return Err(bad(format!("got a `{}` artefact", a.kind)));
    }
    let mut m = Model {
        materials: meta(a, "materials")?,
        shell_properties: meta(a, "shell_properties")?,
        beam_properties: meta(a, "beam_properties")?,
        parameters: meta(a, "parameters")?,
        ..Default::default()
    };
    let t = a.table("nodes")?;
    let (ids, x, y, z) = (
        t.i64s("nodes", "node")?,
        t.f64s("nodes", "x_m")?,
        t.f64s("nodes", "y_m")?,
        t.f64s("nodes", "z_m")?,
    );
    for r in 0..ids.len() {
        m.nodes.insert(id(ids[r], "nodes", r)?, [x[r], y[r], z[r]]);
    }
    let t = a.table("elements")?;
    let (eid, ty, prop) = (
        t.i64s("elements", "element")?,
        t.strs("elements", "type")?,
        t.i64s("elements", "property")?,
    );
    let ns = [
        t.i64s("elements", "n1")?,
        t.i64s("elements", "n2")?,
        t.i64s("elements", "n3")?,
        t.i64s("elements", "n4")?,
    ];
    let vs = [
        t.f64s("elements", "v_x")?,
        t.f64s("elements", "v_y")?,
        t.f64s("elements", "v_z")?,
    ];
    for r in 0..eid.len() {
        let node = |k: usize| id(ns[k][r], "elements", r);
        let p = id(prop[r], "elements", r)?;
        let e = match ty[r].as_str() {
            "quad4" => Element::Quad4 {
                nodes: [node(0)?, node(1)?, node(2)?, node(3)?],
                property: p,
            },
            "tria3" => Element::Tria3 {
                nodes: [node(0)?, node(1)?, node(2)?],
                property: p,
            },
            "beam" => Element::Beam {
                nodes: [node(0)?, node(1)?],
                property: p,
                orientation: [vs[0][r], vs[1][r], vs[2][r]],
            },
            other => {
                return Err(bad(format!(
                    "elements row {r}: type `{other}` is not quad4, tria3 or beam"
                )));
            }
        };
        m.elements.insert(id(eid[r], "elements", r)?, e);
    }
    let t = a.table("lumped")?;
    let n = "lumped";
    let (lid, lty, lnode, lcomp, lother, locomp) = (
        t.i64s(n, "element")?,
        t.strs(n, "type")?,
        t.i64s(n, "node")?,
        t.strs(n, "comp")?,
        t.i64s(n, "other")?,
        t.strs(n, "other_comp")?,
    );
    let mut k: Vec<&[f64]> = Vec::new();
    for i in 1..=6 {
        k.push(t.f64s(n, &format!("k_{i}"))?);
    }
    let mass = t.f64s(n, "mass_kg")?;
    let mut inertia: Vec<&[f64]> = Vec::new();
    for c in ["i11", "i21", "i22", "i31", "i32", "i33"] {
        inertia.push(t.f64s(n, c)?);
    }
    let off = [
        t.f64s(n, "off_x")?,
        t.f64s(n, "off_y")?,
        t.f64s(n, "off_z")?,
    ];
    for r in 0..lid.len() {
        let node = id(lnode[r], n, r)?;
        let other = if lother[r] < 0 {
            None
        } else {
            Some(id(lother[r], n, r)?)
        };
        let dof = |nd: u64, c: &str| -> Result<DofId, ArtefactError> {
            format!("{nd}:{c}")
                .parse()
                .map_err(|e| bad(format!("lumped row {r}: {e}")))
        };
        let e = match lty[r].as_str() {
            "bush" => Element::Bush {
                node,
                other,
                k: std::array::from_fn(|i| k[i][r]),
            },
            "scalar_spring" => Element::ScalarSpring {
                dof: dof(node, &lcomp[r])?,
                other: other.map(|o| dof(o, &locomp[r])).transpose()?,
                k: k[0][r],
            },
            "mass" => Element::Mass {
                node,
                mass: mass[r],
                inertia: std::array::from_fn(|i| inertia[i][r]),
                offset: std::array::from_fn(|i| off[i][r]),
            },
            other => {
                return Err(bad(format!(
                    "lumped row {r}: type `{other}` is not bush, scalar_spring or mass"
                )));
            }
        };
        m.elements.insert(id(lid[r], n, r)?, e);
    }
    let t = a.table("constraints")?;
    for (r, d) in t.strs("constraints", "dof")?.iter().enumerate() {
        m.constraints.push(
            d.parse()
                .map_err(|e| bad(format!("constraints row {r}: {e}")))?,
        );
    }
    let t = a.table("sets")?;
    let (sn, se) = (t.strs("sets", "set")?, t.i64s("sets", "element")?);
    for r in 0..sn.len() {
        m.sets
            .entry(sn[r].clone())
            .or_default()
            .push(id(se[r], "sets", r)?);
    }
    m.validate().map_err(|e| bad(e.to_string()))?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::generate::{ThreeBeam, bent_plate, three_beam};

    #[test]
    fn models_round_trip() {
        for m in [
            bent_plate(&Default::default()),
            three_beam(&ThreeBeam::default()),
        ] {
            let back = mesh_from_artefact(&mesh_to_artefact(&m)).unwrap();
            assert_eq!(back, m);
        }
    }
}
