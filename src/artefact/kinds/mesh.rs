//! The `mesh` kind: a [`Model`] as tables a user can open with pandas.
//!
//! | table | columns |
//! |---|---|
//! | `nodes` | `node, x_m, y_m, z_m` |
//! | `elements` | `element, type, property, n1, n2, n3, n4, v_x, v_y, v_z` (−1 / NaN when absent) |
//! | `lumped` | `element, type, node, comp, other, other_comp, k_1 … k_6, mass_kg, i11, i21, i22, i31, i32, i33, off_x, off_y, off_z` |
//! | `constraints` | `dof` |
//! | `sets` | `set, element` |
//! | `displacement_systems` (only when some grid has one) | `node, r11, r12, r13, r21, …, r33`: the rows of `R`, the unit vectors (basic) of the grid's components 1–3 (4–6); its DOFs are along them |
//! | `mpcs` (only when the model has multipoint constraints) | `dependent, independent, coefficient, origin`: one row per term of `u_dependent = Σ coefficient · u_independent` (a constraint without terms: one row with an empty `independent`) |
//!
//! Materials, properties and parameters are small and go into `meta` as JSON. Rods (`type`
//! `rod`) name their rod property in `property`, or hold −1 there when the element has its own
//! section (a CONROD), which is then in `meta.rod_sections` under the element id; both rod
//! metadata keys are written only when the model has rods, so meshes without them keep their
//! bytes. The offsets and pin flags of the beams that have them are in `beam_ends` (element
//! id → ends; absent when no beam has any). Solid elements (up to 20 nodes) are in
//! `solid_elements` (element id → `{type: solid, kind, nodes, property}`), with
//! `solid_properties` and the MAT9 `anisotropic_materials`; all three are absent without solids.
//! MAT8/MAT2 materials are in `shell_materials` and
//! the shell elements' THETA/MCID/ZOFFS in `shell_placements` (element id → placement), each
//! only when the model has any; laminates (PCOMP) are shell properties with `laminate` plies. //! Scalar points are in `scalar_points`, the
//! element systems and damping of the bushes that have them in `bush_systems` (element id →
//! `{axes, b}`), and scalar masses, general (CONM1) masses and dampers in `lumped_extra`
//! (element id → element, JSON); each key is written only when the model has such things.
//! Quadratic shells (`quad8`, `tria6`) have their corners in `n1 …` and their midside nodes in
//! `midside_nodes` (element id → list, `null` for an omitted one; absent when the model has none).

use super::{ColumnLayout, Kind, Layout, col, meta, meta_opt, meta_value, optional_meta, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::model::{BeamEnds, Element, Model, RodProperty, RodSection};
use std::collections::BTreeMap;

const K: ArtefactKind = ArtefactKind::Mesh;

/// Names of the inertia columns of `lumped`.
const INERTIA: [&str; 6] = ["i11", "i21", "i22", "i31", "i32", "i33"];
/// Names of the columns of `displacement_systems`: `R` row by row.
const R_COLUMNS: [&str; 9] = [
    "r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33",
];
/// Names of the offset columns of `lumped`.
const OFFSET: [&str; 3] = ["off_x", "off_y", "off_z"];
/// Names of the stiffness columns of `lumped`.
const STIFFNESS: [&str; 6] = ["k_1", "k_2", "k_3", "k_4", "k_5", "k_6"];

/// The `mesh` kind.
pub struct MeshKind;

impl Kind for MeshKind {
    const KIND: ArtefactKind = K;
    const NAME: &'static str = "mesh";
    type Value = Model;

    fn layout() -> Layout {
        let s = Storage::Parquet;
        Layout {
            tables: vec![
                table(
                    "nodes",
                    s,
                    true,
                    vec![
                        col("node", "int64", "", "grid id"),
                        col("x_m", "float64", "m", "basic x"),
                        col("y_m", "float64", "m", "basic y"),
                        col("z_m", "float64", "m", "basic z"),
                    ],
                ),
                table("elements", s, true, element_columns()),
                table("lumped", s, true, lumped_columns()),
                table(
                    "constraints",
                    s,
                    true,
                    vec![col("dof", "string", "", "constrained DOF node:comp")],
                ),
                table(
                    "sets",
                    s,
                    true,
                    vec![
                        col("set", "string", "", "set name"),
                        col("element", "int64", "", "element id"),
                    ],
                ),
                table(
                    "displacement_systems",
                    s,
                    false,
                    std::iter::once(col("node", "int64", "", "grid id"))
                        .chain(R_COLUMNS.iter().map(|c| {
                            col(
                                c,
                                "float64",
                                "",
                                "component of R (row: local axis, column: basic)",
                            )
                        }))
                        .collect(),
                ),
                table(
                    "mpcs",
                    s,
                    false,
                    vec![
                        col("dependent", "string", "", "dependent DOF node:comp"),
                        col(
                            "independent",
                            "string",
                            "",
                            "independent DOF node:comp, empty for a constraint without terms",
                        ),
                        col("coefficient", "float64", "", "its coefficient"),
                        col("origin", "string", "", "the card, e.g. RBE2 12"),
                    ],
                ),
            ],
            meta: vec![
                meta("n_nodes", "number of nodes"),
                meta("n_elements", "number of elements, lumped ones included"),
                meta("n_dofs", "unconstrained DOFs"),
                meta("materials", "materials by id"),
                meta("shell_properties", "shell properties by id"),
                meta("beam_properties", "beam properties by id"),
                meta("parameters", "updating parameters of the model"),
                meta("units", "unit of the columns that have one"),
                meta_opt("rod_properties", "rod properties by id (only with rods)"),
                meta_opt(
                    "shell_materials",
                    "MAT8/MAT2 shell materials by id (only when the model has them)",
                ),
                meta_opt(
                    "shell_placements",
                    "shell material axes (THETA/MCID) and offsets (ZOFFS) by element id (only when some element has one)",
                ),
                meta_opt(
                    "rod_sections",
                    "sections of rods without a property (CONROD), by element id",
                ),
                meta_opt("skipped_cards", "deck cards mesh.import did not read"),
                meta_opt("ignored_cards", "deck cards left out on request"),
                meta_opt("ignore_cards", "the cards requested to be left out"),
                meta_opt("import_warnings", "what mesh.import warned about"),
                meta_opt(
                    "eigenvalue_request",
                    "the modes the deck's METHOD/EIGRL asks for: min_hz (V1), max_hz (V2), count (ND)",
                ),
                meta_opt(
                    "weight_summary",
                    "rigid-body mass, centre of gravity and inertia (PARAM,GRDPNT)",
                ),
                meta_opt(
                    "midside_nodes",
                    "midside nodes of the quad8 and tria6 elements (null where omitted), by element id",
                ),
                meta_opt(
                    "solid_elements",
                    "solid elements by id: kind, nodes (QRG order), property (only with solids)",
                ),
                meta_opt(
                    "solid_properties",
                    "solid properties by id (only with solids)",
                ),
                meta_opt(
                    "anisotropic_materials",
                    "MAT9 anisotropic materials by id (only when the model has them)",
                ),
                meta_opt(
                    "beam_ends",
                    "offsets (basic, m) and pin flags of the beams that have them, by element id",
                ),
                meta_opt("scalar_points", "scalar point ids (SPOINT, EPOINT)"),
                meta_opt(
                    "bush_systems",
                    "element axes (rows, basic) and damping b_1..b_6 of the bushes that have them, by element id",
                ),
                meta_opt(
                    "lumped_extra",
                    "scalar masses, general masses (CONM1) and dampers, by element id",
                ),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(m: &Model) -> Artefact {
        mesh_to_artefact(m)
    }

    fn from_artefact(a: &Artefact) -> Result<Model, ArtefactError> {
        mesh_from_artefact(a)
    }
}

fn element_columns() -> Vec<ColumnLayout> {
    vec![
        col("element", "int64", "", "element id"),
        col("type", "string", "", "quad4, tria3, beam or rod"),
        col(
            "property",
            "int64",
            "",
            "property id (-1: a rod with its own section)",
        ),
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
    ]
}

fn lumped_columns() -> Vec<ColumnLayout> {
    let mut c = vec![
        col("element", "int64", "", "element id"),
        col("type", "string", "", "bush, scalar_spring or mass"),
        col("node", "int64", "", "its node"),
        col("comp", "string", "", "scalar spring: its component"),
        col("other", "int64", "", "second node, or -1 when grounded"),
        col(
            "other_comp",
            "string",
            "",
            "scalar spring: second component",
        ),
    ];
    let k_doc = "bush stiffness per component (k_1 for a scalar spring), 0 otherwise";
    for (i, name) in STIFFNESS.into_iter().enumerate() {
        c.push(col(
            name,
            "float64",
            if i < 3 { "N/m" } else { "N*m/rad" },
            k_doc,
        ));
    }
    c.push(col("mass_kg", "float64", "kg", "point mass, 0 otherwise"));
    for name in INERTIA {
        c.push(col(name, "float64", "kg*m^2", "mass: inertia tensor entry"));
    }
    for name in OFFSET {
        c.push(col(name, "float64", "m", "mass: offset from the node"));
    }
    c
}

/// A model as an artefact.
pub fn mesh_to_artefact(m: &Model) -> Artefact {
    let mut elements = ElementColumns::default();
    let mut lumped = LumpedColumns::default();
    let mut rod_sections = std::collections::BTreeMap::new();
    let mut beam_ends = std::collections::BTreeMap::new();
    let mut midside_nodes: BTreeMap<u64, Vec<Option<u64>>> = BTreeMap::new();
    let mut solids = std::collections::BTreeMap::new();
    let mut bush_systems = std::collections::BTreeMap::new();
    let mut lumped_extra = std::collections::BTreeMap::new();
    for (&id, e) in &m.elements {
        match e {
            Element::Solid { .. } => {
                solids.insert(id, e.clone());
            }
            Element::Bush { axes, b, .. } if axes.is_some() || b.iter().any(|v| *v != 0.0) => {
                bush_systems.insert(id, serde_json::json!({"axes": axes, "b": b}));
                lumped.push(id, e);
            }
            Element::ScalarMass { .. }
            | Element::GeneralMass { .. }
            | Element::ScalarDamper { .. }
            | Element::Viscous { .. } => {
                lumped_extra.insert(id, e.clone());
            }
            Element::Quad4 { nodes, property } => elements.push(id, e, nodes, *property, None),
            Element::Quad8 {
                corners,
                midside,
                property,
            } => {
                midside_nodes.insert(id, midside.to_vec());
                elements.push(id, e, corners, *property, None)
            }
            Element::Tria6 {
                corners,
                midside,
                property,
            } => {
                midside_nodes.insert(id, midside.to_vec());
                elements.push(id, e, corners, *property, None)
            }
            Element::Tria3 { nodes, property } => elements.push(id, e, nodes, *property, None),
            Element::Beam {
                nodes,
                property,
                orientation,
                ends,
            } => {
                if !ends.is_plain() {
                    beam_ends.insert(id, ends.clone());
                }
                elements.push(id, e, nodes, *property, Some(*orientation))
            }
            Element::Rod { nodes, section } => {
                let pid = match section {
                    RodSection::Property(p) => *p as i64,
                    RodSection::Own(p) => {
                        rod_sections.insert(id, p.clone());
                        -1
                    }
                };
                elements.push_row(id, e, nodes, pid, None);
            }
            _ => lumped.push(id, e),
        }
    }
    let a = Artefact::new(K);
    let a = if beam_ends.is_empty() {
        a
    } else {
        a.with_meta("beam_ends", to_json(&beam_ends))
    };
    let mut a = a
        .with_meta("n_nodes", m.nodes.len().into())
        .with_meta("n_elements", m.elements.len().into())
        .with_meta("n_dofs", m.n_dofs().into())
        .with_meta("materials", to_json(&m.materials))
        .with_meta("shell_properties", to_json(&m.shell_properties))
        .with_meta("beam_properties", to_json(&m.beam_properties))
        .with_meta("parameters", to_json(&m.parameters))
        .with_meta("units", serde_json::json!({"x_m": "m", "k_1": "N/m", "k_4": "N*m/rad", "mass_kg": "kg", "i11": "kg*m^2"}))
        .with_table("nodes", nodes_table(m), Storage::Parquet)
        .with_table("elements", elements.into_table(), Storage::Parquet)
        .with_table("lumped", lumped.into_table(), Storage::Parquet)
        .with_table("constraints", constraints_table(m), Storage::Parquet)
        .with_table("sets", sets_table(m), Storage::Parquet);
    if !m.rod_properties.is_empty() {
        a = a.with_meta("rod_properties", to_json(&m.rod_properties));
    }
    if !m.shell_materials.is_empty() {
        a = a.with_meta("shell_materials", to_json(&m.shell_materials));
    }
    if !m.shell_placements.is_empty() {
        a = a.with_meta("shell_placements", to_json(&m.shell_placements));
    }
    if !rod_sections.is_empty() {
        a = a.with_meta("rod_sections", to_json(&rod_sections));
    }
    if !midside_nodes.is_empty() {
        a = a.with_meta("midside_nodes", to_json(&midside_nodes));
    }
    if !m.displacement_systems.is_empty() {
        a = a.with_table(
            "displacement_systems",
            displacement_systems_table(m),
            Storage::Parquet,
        );
    }
    if !solids.is_empty() {
        a = a.with_meta("solid_elements", to_json(&solids));
    }
    if !m.solid_properties.is_empty() {
        a = a.with_meta("solid_properties", to_json(&m.solid_properties));
    }
    if !m.anisotropic_materials.is_empty() {
        a = a.with_meta("anisotropic_materials", to_json(&m.anisotropic_materials));
    }
    if !m.scalar_points.is_empty() {
        a = a.with_meta("scalar_points", to_json(&m.scalar_points));
    }
    if !bush_systems.is_empty() {
        a = a.with_meta("bush_systems", to_json(&bush_systems));
    }
    if !lumped_extra.is_empty() {
        a = a.with_meta("lumped_extra", to_json(&lumped_extra));
    }
    if m.mpcs.is_empty() {
        a
    } else {
        a.with_table("mpcs", mpcs_table(m), Storage::Parquet)
    }
}

fn displacement_systems_table(m: &Model) -> Table {
    let s = &m.displacement_systems;
    let mut t = Table::new().with("node", Column::I64(s.keys().map(|&n| n as i64).collect()));
    for (k, name) in R_COLUMNS.iter().enumerate() {
        t = t.with(
            *name,
            Column::F64(s.values().map(|r| r[k / 3][k % 3]).collect()),
        );
    }
    t
}

/// The `displacement_systems` table, when present.
fn read_displacement_systems(a: &Artefact, m: &mut Model) -> Result<(), ArtefactError> {
    let n = "displacement_systems";
    if !a.tables.contains_key(n) {
        return Ok(());
    }
    let t = a.table(n)?;
    let nodes = t.i64s(n, "node")?;
    let cols = R_COLUMNS
        .iter()
        .map(|c| t.f64s(n, c))
        .collect::<Result<Vec<_>, _>>()?;
    for (r, node) in nodes.iter().enumerate() {
        let mut rot = [[0.0; 3]; 3];
        for (k, c) in cols.iter().enumerate() {
            rot[k / 3][k % 3] = c[r];
        }
        m.displacement_systems.insert(id(*node, n, r)?, rot);
    }
    Ok(())
}

fn mpcs_table(m: &Model) -> Table {
    let (mut dep, mut ind, mut coef, mut origin) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for c in &m.mpcs {
        let rows: Vec<(String, f64)> = if c.terms.is_empty() {
            vec![(String::new(), 0.0)]
        } else {
            c.terms.iter().map(|(d, v)| (d.to_string(), *v)).collect()
        };
        for (d, v) in rows {
            dep.push(c.dependent.to_string());
            ind.push(d);
            coef.push(v);
            origin.push(c.origin.clone());
        }
    }
    Table::new()
        .with("dependent", Column::Str(dep))
        .with("independent", Column::Str(ind))
        .with("coefficient", Column::F64(coef))
        .with("origin", Column::Str(origin))
}

/// The `mpcs` table's constraints: consecutive rows of one dependent DOF form one constraint.
fn read_mpcs(a: &Artefact, m: &mut Model) -> Result<(), ArtefactError> {
    let n = "mpcs";
    let Ok(t) = a.table(n) else {
        return Ok(());
    };
    let (dep, ind, coef, origin) = (
        t.strs(n, "dependent")?,
        t.strs(n, "independent")?,
        t.f64s(n, "coefficient")?,
        t.strs(n, "origin")?,
    );
    let parse = |s: &str, r: usize| -> Result<DofId, ArtefactError> {
        s.parse().map_err(|e| bad(format!("mpcs row {r}: {e}")))
    };
    for r in 0..dep.len() {
        let d = parse(&dep[r], r)?;
        let same = m
            .mpcs
            .last()
            .is_some_and(|c| c.dependent == d && r > 0 && dep[r - 1] == dep[r]);
        if !same {
            m.mpcs.push(crate::model::MultipointConstraint {
                dependent: d,
                terms: Vec::new(),
                origin: origin[r].clone(),
            });
        }
        if !ind[r].is_empty() {
            let term = parse(&ind[r], r)?;
            if let Some(c) = m.mpcs.last_mut() {
                c.terms.push((term, coef[r]));
            }
        }
    }
    Ok(())
}

fn nodes_table(m: &Model) -> Table {
    Table::new()
        .with(
            "node",
            Column::I64(m.nodes.keys().map(|&n| n as i64).collect()),
        )
        .with("x_m", Column::F64(m.nodes.values().map(|x| x[0]).collect()))
        .with("y_m", Column::F64(m.nodes.values().map(|x| x[1]).collect()))
        .with("z_m", Column::F64(m.nodes.values().map(|x| x[2]).collect()))
}

fn constraints_table(m: &Model) -> Table {
    Table::new().with("dof", super::dof_strs(&m.constraints))
}

fn sets_table(m: &Model) -> Table {
    let (mut s_name, mut s_el) = (Vec::new(), Vec::new());
    for (name, ids) in &m.sets {
        for e in ids {
            s_name.push(name.clone());
            s_el.push(*e as i64);
        }
    }
    Table::new()
        .with("set", Column::Str(s_name))
        .with("element", Column::I64(s_el))
}

/// The columns of `elements` (shells and beams) as they fill.
#[derive(Default)]
struct ElementColumns {
    id: Vec<i64>,
    ty: Vec<String>,
    property: Vec<i64>,
    nodes: [Vec<i64>; 4],
    orientation: [Vec<f64>; 3],
}

impl ElementColumns {
    fn push(&mut self, id: u64, e: &Element, nodes: &[u64], property: u64, v: Option<[f64; 3]>) {
        self.push_row(id, e, nodes, property as i64, v);
    }

    fn push_row(
        &mut self,
        id: u64,
        e: &Element,
        nodes: &[u64],
        property: i64,
        v: Option<[f64; 3]>,
    ) {
        self.id.push(id as i64);
        self.ty.push(e.type_name().to_string());
        self.property.push(property);
        for (k, col) in self.nodes.iter_mut().enumerate() {
            col.push(nodes.get(k).map(|n| *n as i64).unwrap_or(-1));
        }
        for (k, col) in self.orientation.iter_mut().enumerate() {
            col.push(v.map(|v| v[k]).unwrap_or(f64::NAN));
        }
    }

    fn into_table(self) -> Table {
        let [n1, n2, n3, n4] = self.nodes;
        let [vx, vy, vz] = self.orientation;
        Table::new()
            .with("element", Column::I64(self.id))
            .with("type", Column::Str(self.ty))
            .with("property", Column::I64(self.property))
            .with("n1", Column::I64(n1))
            .with("n2", Column::I64(n2))
            .with("n3", Column::I64(n3))
            .with("n4", Column::I64(n4))
            .with("v_x", Column::F64(vx))
            .with("v_y", Column::F64(vy))
            .with("v_z", Column::F64(vz))
    }
}

/// One lumped element as a row of `lumped`: zero (or empty, or −1) where it has no such field.
struct LumpedRow {
    node: u64,
    comp: String,
    other: i64,
    other_comp: String,
    k: [f64; 6],
    mass: f64,
    inertia: [f64; 6],
    offset: [f64; 3],
}

impl LumpedRow {
    /// The row of a bush, scalar spring or mass; `None` for shells and beams.
    fn of(e: &Element) -> Option<LumpedRow> {
        let empty = |node| LumpedRow {
            node,
            comp: String::new(),
            other: -1,
            other_comp: String::new(),
            k: [0.0; 6],
            mass: 0.0,
            inertia: [0.0; 6],
            offset: [0.0; 3],
        };
        Some(match e {
            Element::Bush { node, other, k, .. } => LumpedRow {
                other: other.map(|o| o as i64).unwrap_or(-1),
                k: *k,
                ..empty(*node)
            },
            Element::ScalarSpring { dof, other, k } => LumpedRow {
                comp: dof.comp.name().to_string(),
                other: other.map(|o| o.node as i64).unwrap_or(-1),
                other_comp: other.map(|o| o.comp.name().to_string()).unwrap_or_default(),
                k: [*k, 0.0, 0.0, 0.0, 0.0, 0.0],
                ..empty(dof.node)
            },
            Element::Mass {
                node,
                mass,
                inertia,
                offset,
            } => LumpedRow {
                mass: *mass,
                inertia: *inertia,
                offset: *offset,
                ..empty(*node)
            },
            Element::Quad4 { .. }
            | Element::Tria3 { .. }
            | Element::Quad8 { .. }
            | Element::Tria6 { .. }
            | Element::Beam { .. }
            | Element::Rod { .. }
            | Element::Solid { .. }
            | Element::ScalarMass { .. }
            | Element::GeneralMass { .. }
            | Element::ScalarDamper { .. }
            | Element::Viscous { .. } => return None,
        })
    }
}

/// The columns of `lumped` as they fill.
#[derive(Default)]
struct LumpedColumns {
    id: Vec<i64>,
    ty: Vec<String>,
    node: Vec<i64>,
    comp: Vec<String>,
    other: Vec<i64>,
    other_comp: Vec<String>,
    k: [Vec<f64>; 6],
    mass: Vec<f64>,
    inertia: [Vec<f64>; 6],
    offset: [Vec<f64>; 3],
}

impl LumpedColumns {
    /// Adds a lumped element; shells and beams are not lumped and are skipped.
    fn push(&mut self, id: u64, e: &Element) {
        let Some(r) = LumpedRow::of(e) else {
            return;
        };
        self.id.push(id as i64);
        self.ty.push(e.type_name().to_string());
        self.node.push(r.node as i64);
        self.comp.push(r.comp);
        self.other.push(r.other);
        self.other_comp.push(r.other_comp);
        for i in 0..6 {
            self.k[i].push(r.k[i]);
            self.inertia[i].push(r.inertia[i]);
        }
        self.mass.push(r.mass);
        for i in 0..3 {
            self.offset[i].push(r.offset[i]);
        }
    }

    fn into_table(self) -> Table {
        let mut t = Table::new()
            .with("element", Column::I64(self.id))
            .with("type", Column::Str(self.ty))
            .with("node", Column::I64(self.node))
            .with("comp", Column::Str(self.comp))
            .with("other", Column::I64(self.other))
            .with("other_comp", Column::Str(self.other_comp));
        for (name, c) in STIFFNESS.into_iter().zip(self.k) {
            t = t.with(name, Column::F64(c));
        }
        t = t.with("mass_kg", Column::F64(self.mass));
        for (name, c) in INERTIA.into_iter().zip(self.inertia) {
            t = t.with(name, Column::F64(c));
        }
        for (name, c) in OFFSET.into_iter().zip(self.offset) {
            t = t.with(name, Column::F64(c));
        }
        t
    }
}

/// JSON of a small model part (id-keyed maps become objects).
fn to_json<T: serde::Serialize>(v: &T) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or(serde_json::Value::Null)
}

fn bad(msg: String) -> ArtefactError {
    ArtefactError::schema(K, msg)
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
        materials: meta_value(a, "materials")?,
        shell_properties: meta_value(a, "shell_properties")?,
        beam_properties: meta_value(a, "beam_properties")?,
        parameters: meta_value(a, "parameters")?,
        rod_properties: optional_meta(a, "rod_properties")?,
        solid_properties: optional_meta(a, "solid_properties")?,
        anisotropic_materials: optional_meta(a, "anisotropic_materials")?,
        shell_materials: optional_meta(a, "shell_materials")?,
        shell_placements: optional_meta(a, "shell_placements")?,
        ..Default::default()
    };
    read_nodes(a, &mut m)?;
    read_elements(a, &mut m)?;
    let ends: Option<BTreeMap<u64, BeamEnds>> = meta_value(a, "beam_ends")?;
    for (eid, e) in ends.unwrap_or_default() {
        match m.elements.get_mut(&eid) {
            Some(Element::Beam { ends, .. }) => *ends = e,
            _ => {
                return Err(bad(format!(
                    "beam_ends names element {eid}, which is not a beam of the elements table"
                )));
            }
        }
    }
    let solids: BTreeMap<u64, Element> = optional_meta(a, "solid_elements")?;
    for (eid, e) in solids {
        if !matches!(e, Element::Solid { .. }) || m.elements.contains_key(&eid) {
            return Err(bad(format!(
                "solid_elements names element {eid}, which is not a solid or is also in the elements table"
            )));
        }
        m.elements.insert(eid, e);
    }
    read_lumped(a, &mut m)?;
    read_lumped_extras(a, &mut m)?;
    read_mpcs(a, &mut m)?;
    read_displacement_systems(a, &mut m)?;
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

fn read_nodes(a: &Artefact, m: &mut Model) -> Result<(), ArtefactError> {
    let t = a.table("nodes")?;
    let (ids, x, y, z) = (
        t.i64s("nodes", "node")?,
        t.f64s("nodes", "x_m")?,
        t.f64s("nodes", "y_m")?,
        t.f64s("nodes", "z_m")?,
    );
    let mut nodes = Vec::with_capacity(ids.len());
    for r in 0..ids.len() {
        nodes.push((id(ids[r], "nodes", r)?, r, [x[r], y[r], z[r]]));
    }
    m.nodes = by_id(nodes, "nodes", "node")?;
    Ok(())
}

fn read_elements(a: &Artefact, m: &mut Model) -> Result<(), ArtefactError> {
    let mut rod_sections: std::collections::BTreeMap<u64, RodProperty> =
        optional_meta(a, "rod_sections")?;
    let mut midside_nodes: BTreeMap<u64, Vec<Option<u64>>> = optional_meta(a, "midside_nodes")?;
    let n = "elements";
    let t = a.table(n)?;
    let (eid, ty, prop) = (
        t.i64s(n, "element")?,
        t.strs(n, "type")?,
        t.i64s(n, "property")?,
    );
    let ns = [
        t.i64s(n, "n1")?,
        t.i64s(n, "n2")?,
        t.i64s(n, "n3")?,
        t.i64s(n, "n4")?,
    ];
    let vs = [t.f64s(n, "v_x")?, t.f64s(n, "v_y")?, t.f64s(n, "v_z")?];
    let mut elements = Vec::with_capacity(eid.len());
    for r in 0..eid.len() {
        let node = |k: usize| id(ns[k][r], n, r);
        let eid = id(eid[r], n, r)?;
        if ty[r] == "rod" {
            let section = if prop[r] == -1 {
                RodSection::Own(rod_sections.remove(&eid).ok_or_else(|| {
                    bad(format!(
                        "elements row {r}: rod {eid} has property -1 but no entry in metadata `rod_sections`"
                    ))
                })?)
            } else {
                RodSection::Property(id(prop[r], n, r)?)
            };
            elements.push((
                eid,
                r,
                Element::Rod {
                    nodes: [node(0)?, node(1)?],
                    section,
                },
            ));
            continue;
        }
        let p = id(prop[r], n, r)?;
        let e = match ty[r].as_str() {
            "quad4" => Element::Quad4 {
                nodes: [node(0)?, node(1)?, node(2)?, node(3)?],
                property: p,
            },
            "tria3" => Element::Tria3 {
                nodes: [node(0)?, node(1)?, node(2)?],
                property: p,
            },
            "quad8" | "tria6" => {
                let mid = midside_nodes.remove(&eid).unwrap_or_default();
                let wrong = || {
                    bad(format!(
                        "elements row {r}: {} {eid} needs {} entries in metadata `midside_nodes`",
                        ty[r],
                        if ty[r] == "quad8" { 4 } else { 3 }
                    ))
                };
                if ty[r] == "quad8" {
                    Element::Quad8 {
                        corners: [node(0)?, node(1)?, node(2)?, node(3)?],
                        midside: mid.try_into().map_err(|_| wrong())?,
                        property: p,
                    }
                } else {
                    Element::Tria6 {
                        corners: [node(0)?, node(1)?, node(2)?],
                        midside: mid.try_into().map_err(|_| wrong())?,
                        property: p,
                    }
                }
            }
            "beam" => Element::Beam {
                nodes: [node(0)?, node(1)?],
                property: p,
                orientation: [vs[0][r], vs[1][r], vs[2][r]],
                ends: BeamEnds::default(),
            },
            other => {
                return Err(bad(format!(
                    "elements row {r}: type `{other}` is not quad4, tria3, quad8, tria6, beam or rod"
                )));
            }
        };
        elements.push((eid, r, e));
    }
    m.elements = by_id(elements, "elements", "element")?;
    Ok(())
}

/// The `(id, row, value)` rows of table `table` as a map by id, built at once from the ids in
/// ascending order (as femu writes them; other writers' rows may come in any order); an id on
/// two rows is an error naming both.
fn by_id<T>(
    mut rows: Vec<(u64, usize, T)>,
    table: &str,
    what: &str,
) -> Result<BTreeMap<u64, T>, ArtefactError> {
    if !rows.is_sorted_by_key(|(id, r, _)| (*id, *r)) {
        rows.sort_unstable_by_key(|(id, r, _)| (*id, *r));
    }
    if let Some(w) = rows.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(bad(format!(
            "{table} rows {} and {}: {what} {} is defined twice",
            w[0].1, w[1].1, w[0].0
        )));
    }
    Ok(BTreeMap::from_iter(
        rows.into_iter().map(|(id, _, value)| (id, value)),
    ))
}

/// Scalar points, bush systems and the lumped elements kept as JSON.
fn read_lumped_extras(a: &Artefact, m: &mut Model) -> Result<(), ArtefactError> {
    m.scalar_points = optional_meta(a, "scalar_points")?;
    #[derive(serde::Deserialize)]
    struct BushSystem {
        axes: Option<[[f64; 3]; 3]>,
        b: [f64; 6],
    }
    let systems: BTreeMap<u64, BushSystem> = optional_meta(a, "bush_systems")?;
    for (eid, s) in systems {
        match m.elements.get_mut(&eid) {
            Some(Element::Bush { axes, b, .. }) => {
                *axes = s.axes;
                *b = s.b;
            }
            _ => {
                return Err(bad(format!(
                    "bush_systems names element {eid}, which is not a bush of the lumped table"
                )));
            }
        }
    }
    let extra: BTreeMap<u64, Element> = optional_meta(a, "lumped_extra")?;
    for (eid, e) in extra {
        if m.elements.insert(eid, e).is_some() {
            return Err(bad(format!(
                "lumped_extra defines element {eid}, which another table defines too"
            )));
        }
    }
    Ok(())
}

fn read_lumped(a: &Artefact, m: &mut Model) -> Result<(), ArtefactError> {
    let n = "lumped";
    let t = a.table(n)?;
    let (lid, lty, lnode, lcomp, lother, locomp) = (
        t.i64s(n, "element")?,
        t.strs(n, "type")?,
        t.i64s(n, "node")?,
        t.strs(n, "comp")?,
        t.i64s(n, "other")?,
        t.strs(n, "other_comp")?,
    );
    let floats = |names: &[&str]| -> Result<Vec<&[f64]>, ArtefactError> {
        names.iter().map(|c| Ok(t.f64s(n, c)?)).collect()
    };
    let (k, inertia, off) = (floats(&STIFFNESS)?, floats(&INERTIA)?, floats(&OFFSET)?);
    let mass = t.f64s(n, "mass_kg")?;
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
                axes: None,
                b: [0.0; 6],
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
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Material, ShellProperty};

    fn rod_model() -> Model {
        let mut m = Model::default();
        for (i, x) in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]
            .iter()
            .enumerate()
        {
            m.nodes.insert(i as u64 + 1, *x);
        }
        m.materials.insert(
            1,
            Material {
                e: 7e10,
                nu: 0.33,
                rho: 2700.0,
            },
        );
        let mut membrane = ShellProperty::homogeneous(1, 0.002, 0.0);
        membrane.bending = false;
        m.shell_properties.insert(2, membrane);
        m.elements.insert(
            1,
            Element::Tria3 {
                nodes: [1, 2, 3],
                property: 2,
            },
        );
        let section = RodProperty {
            material: 1,
            area: 1e-4,
            j: 2e-9,
            c: 0.01,
            nsm: 0.3,
            taper: None,
        };
        m.rod_properties.insert(5, section.clone());
        m.elements.insert(
            2,
            Element::Rod {
                nodes: [1, 2],
                section: RodSection::Property(5),
            },
        );
        m.elements.insert(
            3,
            Element::Rod {
                nodes: [2, 3],
                section: RodSection::Own(section),
            },
        );
        m.add_property_sets();
        m
    }

    /// Scalar points, a bush with an element system and damping, and the scalar family come
    /// back exactly; a model without them writes none of their keys.
    #[test]
    fn scalar_points_and_dampers_round_trip() {
        use crate::core::Component;
        let mut m = rod_model();
        let plain = mesh_to_artefact(&m);
        for key in ["scalar_points", "bush_systems", "lumped_extra"] {
            assert!(!plain.meta.contains_key(key), "{key}");
        }
        m.scalar_points.extend([7, 8]);
        let s = |n| DofId::new(n, Component::Scalar);
        m.elements.insert(
            10,
            Element::Bush {
                node: 1,
                other: Some(2),
                k: [1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
                axes: Some([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
                b: [0.5, 0.0, 0.0, 0.0, 0.0, 0.0],
            },
        );
        m.elements.insert(
            11,
            Element::ScalarMass {
                dof: s(7),
                other: Some(s(8)),
                m: 2.0,
            },
        );
        m.elements.insert(
            12,
            Element::ScalarDamper {
                dof: s(7),
                other: None,
                c: 3.0,
            },
        );
        m.elements.insert(
            13,
            Element::ScalarSpring {
                dof: s(8),
                other: Some(DofId::new(3, Component::Uz)),
                k: 4.0,
            },
        );
        m.elements.insert(
            14,
            Element::GeneralMass {
                node: 3,
                m: [1.0; 21],
            },
        );
        m.elements.insert(
            15,
            Element::Viscous {
                nodes: [1, 3],
                axial: 1.0,
                torsional: 0.5,
            },
        );
        m.constraints.push(s(8));
        let back = mesh_from_artefact(&mesh_to_artefact(&m)).unwrap();
        assert_eq!(back, m);
    }

    /// Rods (by property and with their own section) and a membrane-only shell come back
    /// exactly; a model without rods writes no rod metadata and a homogeneous shell property
    /// serialises as before the optional PSHELL parts existed (digests unchanged).
    /// A grid in a cylindrical CD keeps its displacement system through the artefact, exactly.
    #[test]
    fn displacement_systems_round_trip() {
        let deck = "CORD2C,7,0,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\nMAT1,1,7.+10,,.3,2700.\n\
PSHELL,1,1,.004,1,,1\nGRID,1,,0.,0.,0.\nGRID,2,,.1,0.,0.,7\nGRID,3,,.1,.1,0.,7\n\
GRID,4,,0.,.1,0.,7\nCQUAD4,1,1,1,2,3,4\nSPC1,1,123456,1\n";
        let m = crate::model::import::nastran::parse_bulk(deck, "cd.bdf")
            .unwrap()
            .model;
        assert_eq!(m.displacement_systems.len(), 2);
        let back = mesh_from_artefact(&mesh_to_artefact(&m)).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn rods_and_shell_parts_round_trip_and_leave_other_meshes_alone() {
        let m = rod_model();
        let a = mesh_to_artefact(&m);
        assert_eq!(mesh_from_artefact(&a).unwrap(), m);
        assert_eq!(a.meta["rod_sections"]["3"]["area"], 1e-4);
        let t = a.table("elements").unwrap();
        assert_eq!(*t.i64s("elements", "property").unwrap(), [2, 5, -1]);
        let mut plain = m.clone();
        plain.elements.retain(|_, e| e.type_name() != "rod");
        plain.rod_properties.clear();
        plain
            .shell_properties
            .insert(2, ShellProperty::homogeneous(1, 0.002, 0.0));
        plain.sets.clear();
        let a = mesh_to_artefact(&plain);
        assert!(!a.meta.contains_key("rod_properties") && !a.meta.contains_key("rod_sections"));
        assert_eq!(
            a.meta["shell_properties"],
            serde_json::json!({"2": {"material": 1, "thickness": 0.002, "nsm": 0.0}})
        );
        assert_eq!(mesh_from_artefact(&a).unwrap(), plain);
        assert!(!a.meta.contains_key("midside_nodes"));
    }

    #[test]
    fn quadratic_shells_round_trip_with_omitted_midside_nodes() {
        let mut m = rod_model();
        m.elements.insert(
            7,
            Element::Tria6 {
                corners: [1, 2, 3],
                midside: [Some(4), None, Some(5)],
                property: 2,
            },
        );
        m.elements.insert(
            8,
            Element::Quad8 {
                corners: [1, 2, 3, 4],
                midside: [None, Some(6), None, Some(5)],
                property: 2,
            },
        );
        for n in 4..=6 {
            m.nodes.insert(n, [n as f64, 0.5, 0.0]);
        }
        let a = mesh_to_artefact(&m);
        assert_eq!(
            a.meta["midside_nodes"]["7"],
            serde_json::json!([4, null, 5])
        );
        assert_eq!(mesh_from_artefact(&a).unwrap(), m);
    }
}
