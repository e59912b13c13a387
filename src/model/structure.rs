//! A finite-element model as engineers describe it: grid points, elements referring to
//! properties and materials, lumped springs and masses, single-point constraints, named element
//! sets and updating parameters (docs/theory.md §2). Ids are the user's (Nastran) ids; nothing here
//! is a matrix row number.

use crate::core::{Component, DofId};
use rayon::prelude::*;
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
    /// Membrane–bending coupling material (PSHELL MID4): `B = T² G4`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coupling_material: Option<u64>,
    /// The plies of a laminate (PCOMP, PCOMPG); then `material` is the first ply's, `thickness`
    /// the laminate's total and the PSHELL parts above are unused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub laminate: Option<crate::model::laminates::Laminate>,
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
            coupling_material: None,
            laminate: None,
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
            && self.coupling_material.is_none()
            && self.laminate.is_none()
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
    /// A tapered tube (PTUBE with OD2 ≠ OD): `area`, `j` and `nsm` are then end A's values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub taper: Option<TubeTaper>,
}

/// A tapered PTUBE: the outer diameter varies linearly from `od_a` at end A to `od_b` at end B,
/// the wall thickness `t` is constant (0: a solid rod).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TubeTaper {
    /// Outer diameter at end A (OD), m.
    pub od_a: f64,
    /// Outer diameter at end B (OD2), m.
    pub od_b: f64,
    /// Wall thickness (T), m; 0 for a solid rod.
    pub t: f64,
}

impl TubeTaper {
    /// Area and polar moment of a tube of outer diameter `od` and wall `t` as Nastran's PTUBE:
    /// `A = π (OD − T) T` (solid, `T = 0`: `π OD²/4`), `J = π (OD⁴ − ID⁴)/32`, `ID = OD − 2T`.
    pub fn section(od: f64, t: f64) -> (f64, f64) {
        let id = if t == 0.0 { 0.0 } else { od - 2.0 * t };
        let area = if t == 0.0 {
            std::f64::consts::PI * od * od / 4.0
        } else {
            std::f64::consts::PI * (od - t) * t
        };
        let j = std::f64::consts::PI * (od.powi(4) - id.powi(4)) / 32.0;
        (area, j)
    }

    /// Area and polar moment at `xi` (0: end A, 1: end B).
    pub fn at(&self, xi: f64) -> (f64, f64) {
        TubeTaper::section(self.od_a + xi * (self.od_b - self.od_a), self.t)
    }
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

/// A general anisotropic material for solids (Nastran MAT9): the 6×6 symmetric elasticity
/// matrix in the material system, Voigt order `[xx, yy, zz, xy, yz, zx]` with engineering shear
/// strains, given by its upper triangle row by row (`G11 G12 … G16 G22 … G66`, 21 values).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AnisotropicMaterial {
    /// `G_ij` (i ≤ j), row by row, Pa.
    pub g: Vec<f64>,
    /// Density, kg/m³.
    pub rho: f64,
}

impl AnisotropicMaterial {
    /// The full symmetric 6×6 matrix.
    pub fn matrix(&self) -> [[f64; 6]; 6] {
        let mut d = [[0.0; 6]; 6];
        let upper = (0..6).flat_map(|i| (i..6).map(move |j| (i, j)));
        for (k, (i, j)) in upper.enumerate() {
            let v = self.g.get(k).copied().unwrap_or(0.0);
            d[i][j] = v;
            d[j][i] = v;
        }
        d
    }
}

/// The isoparametric solid element shapes (Nastran CHEXA, CPENTA, CTETRA, CPYRAM), by node
/// count; nodes in the QRG's order, corners first, then midside nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolidKind {
    /// 8-node hexahedron.
    Hexa8,
    /// 20-node serendipity hexahedron.
    Hexa20,
    /// 6-node pentahedron (wedge).
    Penta6,
    /// 15-node pentahedron.
    Penta15,
    /// 4-node tetrahedron.
    Tetra4,
    /// 10-node tetrahedron.
    Tetra10,
    /// 5-node pyramid.
    Pyram5,
    /// 13-node pyramid (CPYRAM with G6–G13).
    Pyram13,
    /// A variable-node element of `family` with only some of its midside nodes (Nastran's
    /// partial set of G9–G20, G7–G15, G5–G10 or G6–G13): bit `k` of `midside` set when the
    /// midside node of edge `k` (the `k`-th midside field of the card) is present. Nodes: the
    /// corners, then the present midside nodes in field order; an edge without its midside node
    /// is straight and its displacement linear.
    Variable {
        /// The shape.
        family: SolidFamily,
        /// Present midside nodes, bit `k` for edge `k`.
        midside: u16,
    },
}

/// The four solid shapes, whatever their nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolidFamily {
    /// Hexahedron (CHEXA): 8 corners, 12 edges.
    Hexa,
    /// Pentahedron (CPENTA): 6 corners, 9 edges.
    Penta,
    /// Tetrahedron (CTETRA): 4 corners, 6 edges.
    Tetra,
    /// Pyramid (CPYRAM): 5 corners, 8 edges.
    Pyram,
}

impl SolidFamily {
    /// Number of corners.
    pub fn corners(self) -> usize {
        match self {
            SolidFamily::Hexa => 8,
            SolidFamily::Penta => 6,
            SolidFamily::Tetra => 4,
            SolidFamily::Pyram => 5,
        }
    }

    /// Number of edges (possible midside nodes).
    pub fn edges(self) -> usize {
        match self {
            SolidFamily::Hexa => 12,
            SolidFamily::Penta => 9,
            SolidFamily::Tetra => 6,
            SolidFamily::Pyram => 8,
        }
    }

    /// The element without midside nodes.
    pub fn linear(self) -> SolidKind {
        match self {
            SolidFamily::Hexa => SolidKind::Hexa8,
            SolidFamily::Penta => SolidKind::Penta6,
            SolidFamily::Tetra => SolidKind::Tetra4,
            SolidFamily::Pyram => SolidKind::Pyram5,
        }
    }

    /// The element with every midside node.
    pub fn quadratic(self) -> SolidKind {
        match self {
            SolidFamily::Hexa => SolidKind::Hexa20,
            SolidFamily::Penta => SolidKind::Penta15,
            SolidFamily::Tetra => SolidKind::Tetra10,
            SolidFamily::Pyram => SolidKind::Pyram13,
        }
    }

    /// The element with the midside nodes of `midside` (bit `k`: edge `k`): the linear one
    /// when none, the quadratic one when all, else [`SolidKind::Variable`].
    pub fn with_midside(self, midside: u16) -> SolidKind {
        let all = (1u16 << self.edges()) - 1;
        match midside & all {
            0 => self.linear(),
            m if m == all => self.quadratic(),
            m => SolidKind::Variable {
                family: self,
                midside: m,
            },
        }
    }
}

impl SolidKind {
    /// Its shape.
    pub fn family(self) -> SolidFamily {
        match self {
            SolidKind::Hexa8 | SolidKind::Hexa20 => SolidFamily::Hexa,
            SolidKind::Penta6 | SolidKind::Penta15 => SolidFamily::Penta,
            SolidKind::Tetra4 | SolidKind::Tetra10 => SolidFamily::Tetra,
            SolidKind::Pyram5 | SolidKind::Pyram13 => SolidFamily::Pyram,
            SolidKind::Variable { family, .. } => family,
        }
    }

    /// The present midside nodes, bit `k` for edge `k` (0 for a linear element).
    pub fn midside(self) -> u16 {
        let family = self.family();
        match self {
            SolidKind::Hexa8 | SolidKind::Penta6 | SolidKind::Tetra4 | SolidKind::Pyram5 => 0,
            SolidKind::Variable { midside, .. } => midside & ((1u16 << family.edges()) - 1),
            _ => (1u16 << family.edges()) - 1,
        }
    }

    /// Number of nodes.
    pub fn n_nodes(self) -> usize {
        self.family().corners() + self.midside().count_ones() as usize
    }

    /// The faces of the element as lists of corner positions (0-based, into its nodes), each
    /// ordered round the face.
    pub fn corner_faces(self) -> &'static [&'static [usize]] {
        match self.family() {
            SolidFamily::Hexa => &[
                &[0, 1, 2, 3],
                &[4, 5, 6, 7],
                &[0, 1, 5, 4],
                &[1, 2, 6, 5],
                &[2, 3, 7, 6],
                &[3, 0, 4, 7],
            ],
            SolidFamily::Penta => &[
                &[0, 1, 2],
                &[3, 4, 5],
                &[0, 1, 4, 3],
                &[1, 2, 5, 4],
                &[2, 0, 3, 5],
            ],
            SolidFamily::Tetra => &[&[0, 1, 2], &[0, 1, 3], &[1, 2, 3], &[2, 0, 3]],
            SolidFamily::Pyram => &[
                &[0, 1, 2, 3],
                &[0, 1, 4],
                &[1, 2, 4],
                &[2, 3, 4],
                &[3, 0, 4],
            ],
        }
    }

    /// Short type name (`hexa8`, …; a variable-node element `hexa8-20`, …).
    pub fn name(self) -> &'static str {
        match self {
            SolidKind::Hexa8 => "hexa8",
            SolidKind::Hexa20 => "hexa20",
            SolidKind::Penta6 => "penta6",
            SolidKind::Penta15 => "penta15",
            SolidKind::Tetra4 => "tetra4",
            SolidKind::Tetra10 => "tetra10",
            SolidKind::Pyram5 => "pyram5",
            SolidKind::Pyram13 => "pyram13",
            SolidKind::Variable { family, .. } => match family {
                SolidFamily::Hexa => "hexa8-20",
                SolidFamily::Penta => "penta6-15",
                SolidFamily::Tetra => "tetra4-10",
                SolidFamily::Pyram => "pyram5-13",
            },
        }
    }
}

/// A solid property (Nastran PSOLID): the material (a MAT1 of `materials` or a MAT9 of
/// `anisotropic_materials`) and, for an anisotropic one, its material axes.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolidProperty {
    /// Material id.
    pub material: u64,
    /// Material axes in the basic system (rows: the material x, y, z directions), for a MAT9
    /// given in a rectangular CORDM; `None`: the basic axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axes: Option<[[f64; 3]; 3]>,
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
    /// A tapered beam's stations (PBEAM, PBEAML); `None`: the section is constant. `section`
    /// and `nsm` then hold end A's values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub taper: Option<BeamTaper>,
    /// Where the centroid and the non-structural mass lie relative to the beam's axis, which is
    /// then the section's shear centre (Nastran CBEAM: PBEAM N, M, NSI; a PBEAML section whose
    /// shear centre is off its centroid); `None`: both on the axis. Constant along a taper.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centres: Option<BeamCentres>,
}

/// The centroid and non-structural mass of a beam section relative to its shear centre, in
/// element `y`, `z` (Nastran PBEAM; see `crate::fe::beam_offset` for the mechanics).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BeamCentres {
    /// Centroid (neutral axis) from the shear centre, `(y, z)`, m (PBEAM N1, N2).
    #[serde(default)]
    pub neutral_axis: [f64; 2],
    /// Centre of gravity of the non-structural mass from the shear centre, `(y, z)`, m (PBEAM
    /// M1, M2).
    #[serde(default)]
    pub nsm_cg: [f64; 2],
    /// Non-structural mass moment of inertia per length about its centre of gravity, kg·m
    /// (PBEAM NSI).
    #[serde(default)]
    pub nsi: f64,
}

impl BeamCentres {
    /// `Some` unless every value is zero.
    pub fn nonzero(self) -> Option<BeamCentres> {
        (self != BeamCentres::default()).then_some(self)
    }
}

/// The stations of a tapered beam, from end A (`x = 0`) to end B (`x = 1`), with what varies
/// linearly between them (Nastran PBEAM, PBEAML).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BeamTaper {
    /// PBEAML: the library type whose dimensions vary linearly (the properties follow from
    /// them at each point); `None`: PBEAM, whose `A, I1, I2, J` vary linearly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub library: Option<String>,
    /// Stations by increasing `x`, the first at 0 (end A) and the last at 1 (end B).
    pub stations: Vec<BeamStation>,
}

/// One station of a tapered beam.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BeamStation {
    /// Distance from end A over the length (Nastran X/XB), in `[0, 1]`.
    pub x: f64,
    /// PBEAML: DIM1, DIM2, …; PBEAM: `A, I1, I2, J` (m², m⁴).
    pub values: Vec<f64>,
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
    /// Isoparametric solid (CHEXA, CPENTA, CTETRA, CPYRAM): three translations per node.
    Solid {
        /// Its shape.
        kind: SolidKind,
        /// Nodes in the QRG's order.
        nodes: Vec<u64>,
        /// Solid property id.
        property: u64,
    },
    /// Six-DOF lumped spring (CBUSH; or a spring to ground when `nodes[1]` is `None`),
    /// stiffness (and viscous damping) per direction of its element system: the basic axes, or
    /// `axes` when given (`K = Rᵀ diag(k) R` per node block with `R` the rows of `axes`).
    Bush {
        /// First node.
        node: u64,
        /// Second node, or ground.
        other: Option<u64>,
        /// Stiffness `[kx, ky, kz, krx, kry, krz]` (N/m, N·m/rad).
        k: [f64; 6],
        /// The element system's unit axes x, y, z in the basic system (rows); `None`: basic.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        axes: Option<[[f64; 3]; 3]>,
        /// Viscous damping `[bx, by, bz, brx, bry, brz]` (N·s/m, N·m·s/rad; PBUSH B).
        #[serde(default, skip_serializing_if = "is_zero6")]
        b: [f64; 6],
    },
    /// Scalar spring between two DOFs, or one DOF and ground (CELAS1–4); a DOF may be a
    /// scalar point's.
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
    /// Scalar mass between two DOFs (`m [[1, −1], [−1, 1]]`), or on one DOF (CMASS1–4).
    ScalarMass {
        /// First DOF.
        dof: DofId,
        /// Second DOF, or ground.
        other: Option<DofId>,
        /// Mass, kg (or kg·m² on rotations).
        m: f64,
    },
    /// A symmetric 6×6 mass matrix at a node in the basic system (CONM1), lower triangle by
    /// rows: `M11, M21, M22, M31, …, M66`.
    GeneralMass {
        /// The node.
        node: u64,
        /// The 21 entries of the lower triangle, row by row.
        m: [f64; 21],
    },
    /// Scalar viscous damper between two DOFs, or one DOF and ground (CDAMP1–4).
    ScalarDamper {
        /// First DOF.
        dof: DofId,
        /// Second DOF, or ground.
        other: Option<DofId>,
        /// Damping, N·s/m (or N·m·s/rad).
        c: f64,
    },
    /// Viscous damper between two grids (CVISC): axial along the line between them and
    /// torsional about it.
    Viscous {
        /// The two grids.
        nodes: [u64; 2],
        /// Axial damping, N·s/m.
        axial: f64,
        /// Torsional damping, N·m·s/rad.
        torsional: f64,
    },
}

fn is_zero6(v: &[f64; 6]) -> bool {
    v.iter().all(|x| *x == 0.0)
}

impl Element {
    /// Whether the element only damps (no stiffness, no mass).
    pub fn is_damper(&self) -> bool {
        matches!(self, Element::ScalarDamper { .. } | Element::Viscous { .. })
    }

    /// Whether the element adds viscous damping `C` (dampers, bushes with B).
    pub fn has_damping(&self) -> bool {
        match self {
            Element::Bush { b, .. } => !is_zero6(b),
            e => e.is_damper(),
        }
    }

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
            Element::Solid { nodes, .. } => nodes.clone(),
            Element::Bush { node, other, .. } => std::iter::once(*node).chain(*other).collect(),
            Element::ScalarSpring { dof, other, .. } => std::iter::once(dof.node)
                .chain(other.map(|d| d.node))
                .collect(),
            Element::Mass { node, .. } | Element::GeneralMass { node, .. } => vec![*node],
            Element::ScalarMass { dof, other, .. } | Element::ScalarDamper { dof, other, .. } => {
                std::iter::once(dof.node)
                    .chain(other.map(|d| d.node))
                    .collect()
            }
            Element::Viscous { nodes, .. } => nodes.to_vec(),
        }
    }

    /// The DOFs of a scalar element (spring, mass, damper): its first DOF and the other one.
    pub fn scalar_dofs(&self) -> Option<(DofId, Option<DofId>)> {
        match self {
            Element::ScalarSpring { dof, other, .. }
            | Element::ScalarMass { dof, other, .. }
            | Element::ScalarDamper { dof, other, .. } => Some((*dof, *other)),
            _ => None,
        }
    }

    /// Property id, for elements that have one.
    pub fn property(&self) -> Option<u64> {
        match self {
            Element::Quad4 { property, .. }
            | Element::Tria3 { property, .. }
            | Element::Quad8 { property, .. }
            | Element::Tria6 { property, .. }
            | Element::Beam { property, .. }
            | Element::Solid { property, .. } => Some(*property),
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
            Element::Solid { kind, .. } => kind.name(),
            Element::Bush { .. } => "bush",
            Element::ScalarSpring { .. } => "scalar_spring",
            Element::Mass { .. } => "mass",
            Element::ScalarMass { .. } => "scalar_mass",
            Element::GeneralMass { .. } => "general_mass",
            Element::ScalarDamper { .. } => "scalar_damper",
            Element::Viscous { .. } => "viscous",
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

/// A linear multipoint constraint over the model's DOFs (rigid elements, MPC cards):
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
    /// Solid properties by id (PSOLID).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub solid_properties: BTreeMap<u64, SolidProperty>,
    /// Anisotropic solid materials by id (MAT9); ids share one space with `materials`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub anisotropic_materials: BTreeMap<u64, AnisotropicMaterial>,
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
    /// Scalar points (Nastran SPOINT, EPOINT): one DOF each (`id:s`), no position; ids distinct
    /// from the grids'.
    #[serde(default, skip_serializing_if = "std::collections::BTreeSet::is_empty")]
    pub scalar_points: std::collections::BTreeSet<u64>,
    /// Orthotropic and anisotropic shell materials by id (MAT8, MAT2), beside the isotropic
    /// `materials` (ids are shared: one id is in one of the two).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub shell_materials: BTreeMap<u64, crate::model::laminates::ShellMaterial>,
    /// Material axis and offset of the shell elements that have them, by element id.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub shell_placements: BTreeMap<u64, crate::model::laminates::ShellPlacement>,
    /// Displacement systems of the grid points whose DOFs are not along the basic axes
    /// (Nastran GRID CD): per grid, the rows are the unit vectors (in basic) of its components
    /// 1–3, which also carry the rotations 4–6. Every DOF of such a grid — constraints,
    /// springs, multipoint constraints, mode shapes, responses — is a component along these
    /// axes, `u_local = R u_basic`; the assembly turns element matrices into them
    /// (`K_local = R K_basic Rᵀ` per 3 × 3 block). Grids not listed are in basic.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub displacement_systems: BTreeMap<u64, [[f64; 3]; 3]>,
}

/// Whether the rows of `r` are orthonormal and right-handed, to 1e-9.
fn is_rotation(r: &[[f64; 3]; 3]) -> bool {
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let orthonormal = (0..3).all(|i| {
        (0..3).all(|j| {
            let want = if i == j { 1.0 } else { 0.0 };
            (dot(&r[i], &r[j]) - want).abs() <= 1e-9
        })
    });
    let [a, b, c] = r;
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    orthonormal && r.iter().flatten().all(|v| v.is_finite()) && dot(&cross, c) > 0.0
}

/// Why a model is inconsistent.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// A displacement system names no node or is not a rotation.
    #[error("the displacement system of node {node} is invalid: {problem}")]
    BadDisplacementSystem {
        /// Node id.
        node: u64,
        /// What is wrong.
        problem: String,
    },
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
    /// An id is both a grid's and a scalar point's.
    #[error(
        "id {0} is both a grid point and a scalar point; grid and scalar point ids must be unique"
    )]
    ScalarPointIsGrid(u64),
    /// A DOF whose component does not fit its point: a grid component (1–6) of a scalar
    /// point, or the scalar component (0) of a grid.
    #[error("{origin} names DOF {dof}, but {problem}")]
    ComponentMismatch {
        /// Where (`element 12`, `a constraint`).
        origin: String,
        /// The DOF.
        dof: DofId,
        /// What is wrong and what would be valid.
        problem: &'static str,
    },
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
        if let Some(&g) = self
            .scalar_points
            .iter()
            .find(|s| self.nodes.contains_key(s))
        {
            return Err(ModelError::ScalarPointIsGrid(g));
        }
        for (&node, r) in &self.displacement_systems {
            if !self.nodes.contains_key(&node) {
                return Err(ModelError::BadDisplacementSystem {
                    node,
                    problem: "the node is not defined".into(),
                });
            }
            if !is_rotation(r) {
                return Err(ModelError::BadDisplacementSystem {
                    node,
                    problem: format!(
                        "its axes {r:?} are not orthonormal and right-handed (rows must be unit vectors, mutually perpendicular, with row 3 = row 1 × row 2, to 1e-9)"
                    ),
                });
            }
        }
        for (&id, p) in &self.shell_properties {
            for material in p.material_ids() {
                if !self.materials.contains_key(&material)
                    && !self.shell_materials.contains_key(&material)
                {
                    return Err(ModelError::MissingMaterial {
                        property: id,
                        material,
                    });
                }
            }
        }
        for (&id, p) in &self.solid_properties {
            if !self.materials.contains_key(&p.material)
                && !self.anisotropic_materials.contains_key(&p.material)
            {
                return Err(ModelError::MissingMaterial {
                    property: id,
                    material: p.material,
                });
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
        for (&id, p) in &self.beam_properties {
            if !self.materials.contains_key(&p.material) {
                return Err(ModelError::MissingMaterial {
                    property: id,
                    material: p.material,
                });
            }
        }
        // Every element, on all threads; the first fault in id order.
        let grid: Vec<u64> = self.nodes.keys().copied().collect();
        let elements: Vec<(&u64, &Element)> = self.elements.iter().collect();
        if let Some(fault) = elements
            .par_iter()
            .find_map_first(|&(&id, e)| self.element_fault(&grid, id, e))
        {
            return Err(fault);
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
            if !self.has_point(d.node) {
                return Err(ModelError::ConstraintNode(d.node));
            }
            self.check_component(*d, || "a constraint".to_string())?;
        }
        self.validate_mpcs()
    }

    /// What is wrong with element `id`: a point it names that is not defined (`grid` holds the
    /// grid points' ids, ascending), a property or material of its kind that is not, a
    /// quadratic shell on a section it cannot take, or a scalar point where it takes a grid
    /// point or the other way round; `None` when nothing is.
    fn element_fault(&self, grid: &[u64], id: u64, e: &Element) -> Option<ModelError> {
        let is_point = |n: u64| grid.binary_search(&n).is_ok() || self.scalar_points.contains(&n);
        let nodes = e.nodes();
        for &n in &nodes {
            if !is_point(n) {
                return Some(ModelError::MissingNode {
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
            Element::Beam { property, .. } => (self.beam_properties.contains_key(property), "beam"),
            Element::Rod {
                section: RodSection::Property(p),
                ..
            } => (self.rod_properties.contains_key(p), "rod"),
            Element::Solid { property, .. } => {
                (self.solid_properties.contains_key(property), "solid")
            }
            _ => (true, ""),
        };
        if !ok {
            return Some(ModelError::MissingProperty {
                element: id,
                kind: e.type_name(),
                property: e.property().unwrap_or(0),
                wanted,
            });
        }

        if let Element::Quad8 { property, .. } | Element::Tria6 { property, .. } = e {
            let p = &self.shell_properties[property];
            let isotropic = p.laminate.is_none()
                && p.coupling_material.is_none()
                && p.material_ids()
                    .iter()
                    .all(|m| self.materials.contains_key(m));
            if !isotropic {
                return Some(ModelError::MissingProperty {
                    element: id,
                    kind: e.type_name(),
                    property: *property,
                    wanted: "homogeneous-material (PSHELL with MAT1, no MID4) shell",
                });
            }
        }
        if let Element::Rod {
            section: RodSection::Own(p),
            ..
        } = e
            && !self.materials.contains_key(&p.material)
        {
            return Some(ModelError::MissingElementMaterial {
                element: id,
                material: p.material,
            });
        }
        if let Some((a, b)) = e.scalar_dofs() {
            for d in std::iter::once(a).chain(b) {
                if let Err(fault) =
                    self.check_component(d, || format!("element {id} ({})", e.type_name()))
                {
                    return Some(fault);
                }
            }
        } else if !self.scalar_points.is_empty()
            && let Some(&n) = nodes.iter().find(|&&n| self.is_scalar_point(n))
        {
            return Some(ModelError::ComponentMismatch {
                origin: format!("element {id} ({})", e.type_name()),
                dof: DofId::new(n, Component::Scalar),
                problem: "only scalar elements (springs, masses, dampers) connect scalar points",
            });
        }
        None
    }

    /// Whether `id` is a grid point or a scalar point of the model.
    pub fn has_point(&self, id: u64) -> bool {
        self.nodes.contains_key(&id) || self.scalar_points.contains(&id)
    }

    /// Whether `id` is a scalar point.
    pub fn is_scalar_point(&self, id: u64) -> bool {
        self.scalar_points.contains(&id)
    }

    /// A DOF's component fits its point: `s` on a scalar point, `ux`…`rz` on a grid.
    fn check_component(&self, d: DofId, origin: impl Fn() -> String) -> Result<(), ModelError> {
        let problem = match (self.is_scalar_point(d.node), d.comp.is_scalar()) {
            (true, false) => {
                "it is a scalar point, whose one DOF is component s (Nastran 0 or blank)"
            }
            (false, true) => {
                "it is a grid point, whose components are ux uy uz rx ry rz (Nastran 1-6)"
            }
            _ => return Ok(()),
        };
        Err(ModelError::ComponentMismatch {
            origin: origin(),
            dof: d,
            problem,
        })
    }

    /// Multipoint constraints: nodes exist, each dependent DOF once, none constrained, no cycle.
    fn validate_mpcs(&self) -> Result<(), ModelError> {
        if self.mpcs.is_empty() {
            return Ok(());
        }
        let mut by_dep: BTreeMap<DofId, usize> = BTreeMap::new();
        for (i, c) in self.mpcs.iter().enumerate() {
            for d in std::iter::once(&c.dependent).chain(c.terms.iter().map(|t| &t.0)) {
                if !self.has_point(d.node) {
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

    /// Total count of DOFs before constraints: six per node, one per scalar point.
    pub fn n_dofs(&self) -> usize {
        6 * self.nodes.len() + self.scalar_points.len()
    }
}
