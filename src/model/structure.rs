//! A finite-element model as engineers describe it: grid points, elements referring to
//! properties and materials, lumped springs and masses, single-point constraints, named element
//! sets and updating parameters (docs/theory.md §2). Ids are the user's (Nastran) ids; nothing here
//! is a matrix row number.

use crate::core::{Component, DofId};
use std::collections::BTreeMap;

/// An isotropic linear-elastic material (Nastran MAT1).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Material {
    /// Young's modulus, Pa.
    pub e: f64,
    /// Poisson's ratio.
    pub nu: f64,
    /// Density, kg/m³.
    pub rho: f64,
}

impl Material {
    /// Shear modulus `E / (2(1 + ν))`.
    pub fn g(&self) -> f64 {
        self.e / (2.0 * (1.0 + self.nu))
    }
}

/// A shell property (Nastran PSHELL): membrane, bending and transverse shear, by default all of
/// one material. The optional parts follow the PSHELL fields (MID1 blank: no membrane; MID2
/// blank: membrane only; MID2, MID3 other materials; 12I/T³; TS/T); their defaults are the
/// homogeneous shell, and they are not serialised when default, so existing meshes keep their
/// bytes.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShellProperty {
    /// Material id: the membrane's (MID1) and the one whose density gives the mass; for a
    /// bending-only shell (MID1 blank) the bending material.
    pub material: u64,
    /// Thickness, m.
    pub thickness: f64,
    /// Non-structural mass per area, kg/m².
    pub nsm: f64,
    /// Whether the shell has membrane stiffness (Nastran: MID1 given).
    #[serde(default = "yes", skip_serializing_if = "is_yes")]
    pub membrane: bool,
    /// Whether the shell has bending and transverse shear stiffness and rotary inertia
    /// (Nastran: MID2 given).
    #[serde(default = "yes", skip_serializing_if = "is_yes")]
    pub bending: bool,
    /// Bending material (MID2) when it is not `material`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bending_material: Option<u64>,
    /// Transverse shear material (MID3) when it is not the bending material.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear_material: Option<u64>,
    /// Bending stiffness ratio `12I/T³` (1: a solid plate).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub bending_ratio: f64,
    /// Transverse shear thickness ratio `TS/T` (the shear correction factor, 5/6 by default).
    #[serde(default = "five_sixths", skip_serializing_if = "is_five_sixths")]
    pub shear_ratio: f64,
}

impl ShellProperty {
    /// A homogeneous shell of one material (membrane, bending and shear), Nastran's default PSHELL.
    pub fn homogeneous(material: u64, thickness: f64, nsm: f64) -> ShellProperty {
        ShellProperty {
            material,
            thickness,
            nsm,
            membrane: true,
            bending: true,
            bending_material: None,
            shear_material: None,
            bending_ratio: 1.0,
            shear_ratio: five_sixths(),
        }
    }

    /// The bending material id (MID2).
    pub fn bending_mid(&self) -> u64 {
        self.bending_material.unwrap_or(self.material)
    }

    /// The transverse shear material id (MID3).
    pub fn shear_mid(&self) -> u64 {
        self.shear_material.unwrap_or_else(|| self.bending_mid())
    }

    /// Whether every optional part has its default (a homogeneous shell).
    pub fn is_homogeneous(&self) -> bool {
        self.membrane
            && self.bending
            && self.bending_material.is_none()
            && self.shear_material.is_none()
            && is_one(&self.bending_ratio)
            && is_five_sixths(&self.shear_ratio)
    }
}

fn yes() -> bool {
    true
}

fn is_yes(v: &bool) -> bool {
    *v
}

fn one() -> f64 {
    1.0
}

fn is_one(v: &f64) -> bool {
    *v == 1.0
}

/// The shear correction factor 5/6 of a homogeneous plate (Nastran's TS/T default 0.833333).
pub fn five_sixths() -> f64 {
    5.0 / 6.0
}

fn is_five_sixths(v: &f64) -> bool {
    *v == five_sixths()
}

/// A rod property (Nastran PROD, or PTUBE converted to area and torsion constant; CONROD holds
/// one inline): axial and torsional stiffness only.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RodProperty {
    /// Material id.
    pub material: u64,
    /// Cross-section area, m².
    pub area: f64,
    /// Torsion constant, m⁴ (0: no torsional stiffness).
    pub j: f64,
    /// Torsional stress coefficient `C` (stress recovery only; kept for write-back).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub c: f64,
    /// Non-structural mass per length, kg/m.
    pub nsm: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Where a rod's section is: a property shared by id (CROD, CTUBE), or the element's own (CONROD,
/// which has no property id, so it belongs to no `pid<N>` set).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RodSection {
    /// A rod property of the model by id.
    Property(u64),
    /// The element's own section (CONROD).
    Own(RodProperty),
}

/// A beam cross-section.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case")]
pub enum BeamSection {
    /// Solid rectangle (PBARL BAR): `width` (DIM1) along the element's local z, `height` (DIM2) along local y.
    Rectangle {
        /// Width, m.
        width: f64,
        /// Height, m.
        height: f64,
    },
    /// Solid circle (PBARL ROD).
    Circle {
        /// Radius, m.
        radius: f64,
    },
    /// Circular tube (PBARL TUBE).
    Tube {
        /// Outer radius, m.
        outer_radius: f64,
        /// Inner radius, m.
        inner_radius: f64,
    },
    /// Properties given directly (PBAR, PBEAM).
    General {
        /// Area, m².
        area: f64,
        /// Second moment about local y, m⁴.
        iy: f64,
        /// Second moment about local z, m⁴.
        iz: f64,
        /// Torsion constant, m⁴.
        j: f64,
        /// Shear factor in y (0: no shear flexibility).
        shear_y: f64,
        /// Shear factor in z.
        shear_z: f64,
    },
}

/// A beam property (PBAR, PBARL, PBEAM).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BeamProperty {
    /// Material id.
    pub material: u64,
    /// Cross-section.
    pub section: BeamSection,
    /// Non-structural mass per length, kg/m.
    pub nsm: f64,
}

/// Offsets and pin flags of a beam's two ends (Nastran CBAR/CBEAM WA, WB, PA, PB).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BeamEnds {
    /// Offset from node A to end A in the basic system, m: the element runs between the offset
    /// ends, joined rigidly to the nodes.
    #[serde(default, skip_serializing_if = "is_zero3")]
    pub offset_a: [f64; 3],
    /// Offset from node B to end B in the basic system, m.
    #[serde(default, skip_serializing_if = "is_zero3")]
    pub offset_b: [f64; 3],
    /// DOFs released at end A, in the element system, as Nastran's PA digits (e.g. 456); 0: none.
    #[serde(default, skip_serializing_if = "is_zero_u32")]
    pub pin_a: u32,
    /// DOFs released at end B (Nastran PB); 0: none.
    #[serde(default, skip_serializing_if = "is_zero_u32")]
    pub pin_b: u32,
}

fn is_zero3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| *x == 0.0)
}

fn is_zero_u32(v: &u32) -> bool {
    *v == 0
}

impl BeamEnds {
    /// No offset and no pin: the plain beam between its nodes.
    pub fn is_plain(&self) -> bool {
        *self == BeamEnds::default()
    }

    /// The released element-system DOFs (0-based, `[ux uy uz rx ry rz]`) of a pin code such as
    /// 456; `None` when the code holds a digit outside 1–6 or a repeated one.
    pub fn released(code: u32) -> Option<[bool; 6]> {
        let mut out = [false; 6];
        let mut c = code;
        while c > 0 {
            let d = (c % 10) as usize;
            if !(1..=6).contains(&d) || out[d - 1] {
                return None;
            }
            out[d - 1] = true;
            c /= 10;
        }
        Some(out)
    }
}

/// One element.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Element {
    /// Four-node shell (CQUAD4).
    Quad4 {
        /// Corner nodes, counter-clockwise.
        nodes: [u64; 4],
        /// Shell property id.
        property: u64,
    },
    /// Three-node shell (CTRIA3).
    Tria3 {
        /// Corner nodes.
        nodes: [u64; 3],
        /// Shell property id.
        property: u64,
    },
    /// Eight-node curved shell (CQUAD8).
    Quad8 {
        /// Corner nodes G1–G4, counter-clockwise.
        corners: [u64; 4],
        /// Midside nodes G5–G8 (G5 on edge 1–2, …, G8 on 4–1); `None` where omitted (that edge
        /// is straight and interpolated linearly).
        midside: [Option<u64>; 4],
        /// Shell property id.
        property: u64,
    },
    /// Six-node curved shell (CTRIA6).
    Tria6 {
        /// Corner nodes G1–G3.
        corners: [u64; 3],
        /// Midside nodes G4–G6 (G4 on edge 1–2, G5 on 2–3, G6 on 3–1); `None` where omitted.
        midside: [Option<u64>; 3],
        /// Shell property id.
        property: u64,
    },
    /// Two-node beam (CBAR, CBEAM).
    Beam {
        /// End nodes.
        nodes: [u64; 2],
        /// Beam property id.
        property: u64,
        /// Orientation vector `v` in the basic system: local y lies in the plane of the axis and `v`.
        orientation: [f64; 3],
        /// Offsets and pin flags of the ends (none by default; absent from the serialised form
        /// when none).
        #[serde(default, skip_serializing_if = "BeamEnds::is_plain")]
        ends: BeamEnds,
    },
    /// Two-node rod (CROD, CONROD, CTUBE): axial and torsional stiffness only.
    Rod {
        /// End nodes.
        nodes: [u64; 2],
        /// Its section: a rod property id, or its own (CONROD).
        section: RodSection,
    },
    /// Six-DOF lumped spring (CBUSH; or a spring to ground when `nodes[1]` is `None`),
    /// stiffness per basic direction.
    Bush {
        /// First node.
        node: u64,
        /// Second node, or ground.
        other: Option<u64>,
        /// Stiffness `[kx, ky, kz, krx, kry, krz]` (N/m, N·m/rad).
        k: [f64; 6],
    },
    /// Scalar spring between two DOFs, or one DOF and ground (CELAS1/2).
    ScalarSpring {
        /// First DOF.
        dof: DofId,
        /// Second DOF, or ground.
        other: Option<DofId>,
        /// Stiffness.
        k: f64,
    },
    /// Six-DOF lumped mass (CONM2): mass, inertia tensor about the centre of gravity, offset.
    Mass {
        /// The node.
        node: u64,
        /// Mass, kg.
        mass: f64,
        /// Inertia `[I11, I21, I22, I31, I32, I33]` about the centre of gravity, kg·m².
        inertia: [f64; 6],
        /// Centre of gravity relative to the node, m.
        offset: [f64; 3],
    },
}

impl Element {
    /// Grid points the element connects.
    pub fn nodes(&self) -> Vec<u64> {
        match self {
            Element::Quad4 { nodes, .. } => nodes.to_vec(),
            Element::Tria3 { nodes, .. } => nodes.to_vec(),
            Element::Quad8 {
                corners, midside, ..
            } => corners
                .iter()
                .copied()
                .chain(midside.iter().flatten().copied())
                .collect(),
            Element::Tria6 {
                corners, midside, ..
            } => corners
                .iter()
                .copied()
                .chain(midside.iter().flatten().copied())
                .collect(),
            Element::Beam { nodes, .. } => nodes.to_vec(),
            Element::Rod { nodes, .. } => nodes.to_vec(),
            Element::Bush { node, other, .. } => std::iter::once(*node).chain(*other).collect(),
            Element::ScalarSpring { dof, other, .. } => std::iter::once(dof.node)
                .chain(other.map(|d| d.node))
                .collect(),
            Element::Mass { node, .. } => vec![*node],
        }
    }

    /// Property id, for elements that have one.
    pub fn property(&self) -> Option<u64> {
        match self {
            Element::Quad4 { property, .. }
            | Element::Tria3 { property, .. }
            | Element::Quad8 { property, .. }
            | Element::Tria6 { property, .. }
            | Element::Beam { property, .. } => Some(*property),
            Element::Rod {
                section: RodSection::Property(p),
                ..
            } => Some(*p),
            _ => None,
        }
    }

    /// Short type name.
    pub fn type_name(&self) -> &'static str {
        match self {
            Element::Quad4 { .. } => "quad4",
            Element::Tria3 { .. } => "tria3",
            Element::Quad8 { .. } => "quad8",
            Element::Tria6 { .. } => "tria6",
            Element::Beam { .. } => "beam",
            Element::Rod { .. } => "rod",
            Element::Bush { .. } => "bush",
            Element::ScalarSpring { .. } => "scalar_spring",
            Element::Mass { .. } => "mass",
        }
    }
}

/// What an updating parameter changes (docs/theory.md §2).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ParameterKind {
    /// Shell thickness of the set's shell elements.
    ShellThickness,
    /// Young's modulus of the set's elements.
    YoungsModulus,
    /// Density of the set's elements.
    Density,
    /// Beam section width.
    BeamWidth,
    /// Beam section height.
    BeamHeight,
    /// Stiffness of the set's lumped springs in one direction.
    SpringStiffness(Component),
    /// Lumped mass of the set's mass elements (translations: `mass`; rotations: inertia).
    LumpedMass(Component),
}

/// A named updating parameter: a property of a set of elements, with bounds on its value.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Parameter {
    /// Name (unique in the model).
    pub name: String,
    /// What it changes.
    pub kind: ParameterKind,
    /// Name of the element set it acts on.
    pub set: String,
    /// Lowest allowed value (SI).
    pub lower: f64,
    /// Highest allowed value (SI).
    pub upper: f64,
}

/// A linear multipoint constraint in the basic system (rigid elements, MPC cards):
/// `u_dependent = Σ cᵢ uᵢ` over the `terms` `(uᵢ, cᵢ)` (docs/theory.md §2). A term may itself be
/// a dependent DOF of another constraint (a chain); the assembly substitutes in dependency order.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MultipointConstraint {
    /// The DOF the constraint eliminates.
    pub dependent: DofId,
    /// Independent DOFs and their coefficients.
    pub terms: Vec<(DofId, f64)>,
    /// The card it comes from (`RBE2 12`, `MPC 3`), for messages.
    pub origin: String,
}

/// A whole model.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Model {
    /// Grid points by id: coordinates in the basic system, m.
    pub nodes: BTreeMap<u64, [f64; 3]>,
    /// Materials by id.
    pub materials: BTreeMap<u64, Material>,
    /// Shell properties by id.
    pub shell_properties: BTreeMap<u64, ShellProperty>,
    /// Beam properties by id.
    pub beam_properties: BTreeMap<u64, BeamProperty>,
    /// Rod properties by id (PROD, PTUBE).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub rod_properties: BTreeMap<u64, RodProperty>,
    /// Elements by id.
    pub elements: BTreeMap<u64, Element>,
    /// Constrained (zero) DOFs.
    pub constraints: Vec<DofId>,
    /// Named element sets (element ids, ascending).
    pub sets: BTreeMap<String, Vec<u64>>,
    /// Updating parameters.
    pub parameters: Vec<Parameter>,
    /// Multipoint constraints (rigid elements, MPC), each eliminating one dependent DOF.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub mpcs: Vec<MultipointConstraint>,
}

/// Why a model is inconsistent.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// An element names a node that does not exist.
    #[error("element {element} ({kind}) refers to node {node}, which is not defined")]
    MissingNode {
        /// Element id.
        element: u64,
        /// Element type.
        kind: &'static str,
        /// Node id.
        node: u64,
    },
    /// An element names a property that does not exist (or of the wrong type).
    #[error(
        "element {element} ({kind}) refers to property {property}, which is not a {wanted} property of the model"
    )]
    MissingProperty {
        /// Element id.
        element: u64,
        /// Element type.
        kind: &'static str,
        /// Property id.
        property: u64,
        /// Kind of property needed.
        wanted: &'static str,
    },
    /// A property names a material that does not exist.
    #[error("property {property} refers to material {material}, which is not defined")]
    MissingMaterial {
        /// Property id.
        property: u64,
        /// Material id.
        material: u64,
    },
    /// An element holding its own section (CONROD) names a material that does not exist.
    #[error("element {element} refers to material {material}, which is not defined")]
    MissingElementMaterial {
        /// Element id.
        element: u64,
        /// Material id.
        material: u64,
    },
    /// A set names an element that does not exist.
    #[error("set `{set}` lists element {element}, which is not defined")]
    MissingSetElement {
        /// Set name.
        set: String,
        /// Element id.
        element: u64,
    },
    /// A parameter names a set that does not exist.
    #[error("parameter `{parameter}` acts on set `{set}`, which is not defined (sets: {known})")]
    MissingSet {
        /// Parameter.
        parameter: String,
        /// Set name.
        set: String,
        /// Known sets.
        known: String,
    },
    /// A constraint names a node that does not exist.
    #[error("a constraint refers to node {0}, which is not defined")]
    ConstraintNode(u64),
    /// A multipoint constraint names a node that does not exist.
    #[error("{origin} refers to node {node}, which is not defined")]
    MpcNode {
        /// The constraint's card.
        origin: String,
        /// Node id.
        node: u64,
    },
    /// A DOF is the dependent DOF of two multipoint constraints.
    #[error(
        "DOF {dof} is dependent in both {first} and {second}; a DOF may be dependent in one rigid element or MPC only"
    )]
    MpcDependentTwice {
        /// The DOF.
        dof: DofId,
        /// The first constraint's card.
        first: String,
        /// The second.
        second: String,
    },
    /// A dependent DOF is also constrained to zero (Nastran's fatal "dependent DOF in SPC set").
    #[error(
        "DOF {dof} is dependent in {origin} and also constrained by an SPC; remove it from one of them"
    )]
    MpcConstrained {
        /// The DOF.
        dof: DofId,
        /// The constraint's card.
        origin: String,
    },
    /// Multipoint constraints depend on each other in a cycle.
    #[error(
        "multipoint constraints form a cycle: {cycle}; a dependent DOF cannot depend on itself"
    )]
    MpcCycle {
        /// The chain, `DOF (card) -> …`.
        cycle: String,
    },
}

impl crate::core::InputFault for ModelError {
    fn is_input(&self) -> bool {
        true
    }
}

impl Model {
    /// Checks every reference.
    pub fn validate(&self) -> Result<(), ModelError> {
        for (&id, e) in &self.elements {
            for n in e.nodes() {
                if !self.nodes.contains_key(&n) {
                    return Err(ModelError::MissingNode {
                        element: id,
                        kind: e.type_name(),
                        node: n,
                    });
                }
            }
            let (ok, wanted) = match e {
                Element::Quad4 { property, .. }
                | Element::Tria3 { property, .. }
                | Element::Quad8 { property, .. }
                | Element::Tria6 { property, .. } => {
                    (self.shell_properties.contains_key(property), "shell")
                }
                Element::Beam { property, .. } => {
                    (self.beam_properties.contains_key(property), "beam")
                }
                Element::Rod {
                    section: RodSection::Property(p),
                    ..
                } => (self.rod_properties.contains_key(p), "rod"),
                _ => (true, ""),
            };
            if !ok {
                return Err(ModelError::MissingProperty {
                    element: id,
                    kind: e.type_name(),
                    property: e.property().unwrap_or(0),
                    wanted,
                });
            }
        }
        for (&id, p) in &self.shell_properties {
            for material in [p.material, p.bending_mid(), p.shear_mid()] {
                if !self.materials.contains_key(&material) {
                    return Err(ModelError::MissingMaterial {
                        property: id,
                        material,
                    });
                }
            }
        }
        for (&id, p) in &self.rod_properties {
            if !self.materials.contains_key(&p.material) {
                return Err(ModelError::MissingMaterial {
                    property: id,
                    material: p.material,
                });
            }
        }
        for (&id, e) in &self.elements {
            if let Element::Rod {
                section: RodSection::Own(p),
                ..
            } = e
            {
                if !self.materials.contains_key(&p.material) {
                    return Err(ModelError::MissingElementMaterial {
                        element: id,
                        material: p.material,
                    });
                }
            }
        }
        for (&id, p) in &self.beam_properties {
            if !self.materials.contains_key(&p.material) {
                return Err(ModelError::MissingMaterial {
                    property: id,
                    material: p.material,
                });
            }
        }
        for (name, ids) in &self.sets {
            for e in ids {
                if !self.elements.contains_key(e) {
                    return Err(ModelError::MissingSetElement {
                        set: name.clone(),
                        element: *e,
                    });
                }
            }
        }
        for p in &self.parameters {
            if !self.sets.contains_key(&p.set) {
                return Err(ModelError::MissingSet {
                    parameter: p.name.clone(),
                    set: p.set.clone(),
                    known: self.sets.keys().cloned().collect::<Vec<_>>().join(", "),
                });
            }
        }
        for d in &self.constraints {
            if !self.nodes.contains_key(&d.node) {
                return Err(ModelError::ConstraintNode(d.node));
            }
        }
        self.validate_mpcs()
    }

    /// Multipoint constraints: nodes exist, each dependent DOF once, none constrained, no cycle.
    fn validate_mpcs(&self) -> Result<(), ModelError> {
        if self.mpcs.is_empty() {
            return Ok(());
        }
        let mut by_dep: BTreeMap<DofId, usize> = BTreeMap::new();
        for (i, c) in self.mpcs.iter().enumerate() {
            for d in std::iter::once(&c.dependent).chain(c.terms.iter().map(|t| &t.0)) {
                if !self.nodes.contains_key(&d.node) {
                    return Err(ModelError::MpcNode {
                        origin: c.origin.clone(),
                        node: d.node,
                    });
                }
            }
            if let Some(&j) = by_dep.get(&c.dependent) {
                return Err(ModelError::MpcDependentTwice {
                    dof: c.dependent,
                    first: self.mpcs[j].origin.clone(),
                    second: c.origin.clone(),
                });
            }
            by_dep.insert(c.dependent, i);
        }
        let spc: std::collections::BTreeSet<DofId> = self.constraints.iter().copied().collect();
        for c in &self.mpcs {
            if spc.contains(&c.dependent) {
                return Err(ModelError::MpcConstrained {
                    dof: c.dependent,
                    origin: c.origin.clone(),
                });
            }
        }
        // Depth-first search over dependent → dependent terms (0 new, 1 on the path, 2 done).
        let mut state = vec![0u8; self.mpcs.len()];
        for start in 0..self.mpcs.len() {
            if state[start] != 0 {
                continue;
            }
            let mut path: Vec<(usize, usize)> = vec![(start, 0)];
            state[start] = 1;
            while let Some(&mut (i, ref mut next)) = path.last_mut() {
                let terms = &self.mpcs[i].terms;
                let child = terms[*next..]
                    .iter()
                    .position(|t| by_dep.contains_key(&t.0))
                    .map(|p| *next + p);
                match child {
                    Some(k) => {
                        *next = k + 1;
                        let j = by_dep[&terms[k].0];
                        match state[j] {
                            0 => {
                                state[j] = 1;
                                path.push((j, 0));
                            }
                            1 => {
                                let from = path.iter().position(|p| p.0 == j).unwrap_or(0);
                                let mut names: Vec<String> = path[from..]
                                    .iter()
                                    .map(|p| {
                                        let c = &self.mpcs[p.0];
                                        format!("{} ({})", c.dependent, c.origin)
                                    })
                                    .collect();
                                names.push(self.mpcs[j].dependent.to_string());
                                return Err(ModelError::MpcCycle {
                                    cycle: names.join(" -> "),
                                });
                            }
                            _ => {}
                        }
                    }
                    None => {
                        state[i] = 2;
                        path.pop();
                    }
                }
            }
        }
        Ok(())
    }

    /// Adds one set per property id (`pid<N>`), the usual grouping of imported models.
    pub fn add_property_sets(&mut self) {
        let mut by_pid: BTreeMap<u64, Vec<u64>> = BTreeMap::new();
        for (&id, e) in &self.elements {
            if let Some(p) = e.property() {
                by_pid.entry(p).or_default().push(id);
            }
        }
        for (pid, ids) in by_pid {
            self.sets.entry(format!("pid{pid}")).or_insert(ids);
        }
    }

    /// Total count of DOFs before constraints: six per node.
    pub fn n_dofs(&self) -> usize {
        6 * self.nodes.len()
    }
}
