//! Composite and offset shells in the model (Nastran PCOMP, PCOMPG, MAT2, MAT8, CQUAD4/CTRIA3
//! THETA, MCID and ZOFFS): the data only; the lamination theory is `fe::laminate`.

use super::structure::ShellProperty;

/// An orthotropic or anisotropic shell material (the ids are shared with the isotropic
/// [`super::Material`]s).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ShellMaterial {
    /// Orthotropic in the plane (MAT8), in its own axes 1 (fibre), 2.
    Orthotropic {
        /// `E1`, Pa.
        e1: f64,
        /// `E2`, Pa.
        e2: f64,
        /// `ν12`.
        nu12: f64,
        /// `G12`, Pa.
        g12: f64,
        /// Transverse shear modulus `G1Z`, Pa.
        g1z: f64,
        /// Transverse shear modulus `G2Z`, Pa.
        g2z: f64,
        /// Density, kg/m³.
        rho: f64,
    },
    /// Anisotropic plane stress (MAT2): `G11, G12, G13, G22, G23, G33` (Pa) over
    /// `(ε1, ε2, γ12)`; as a ply or a transverse shear material its transverse shear moduli are
    /// `G33` (MAT2 has none of its own).
    Anisotropic {
        /// `[G11, G12, G13, G22, G23, G33]`, Pa.
        g: [f64; 6],
        /// Density, kg/m³.
        rho: f64,
    },
}

impl ShellMaterial {
    /// Density, kg/m³.
    pub fn rho(&self) -> f64 {
        match self {
            ShellMaterial::Orthotropic { rho, .. } | ShellMaterial::Anisotropic { rho, .. } => *rho,
        }
    }

    /// Mutable density.
    pub fn rho_mut(&mut self) -> &mut f64 {
        match self {
            ShellMaterial::Orthotropic { rho, .. } | ShellMaterial::Anisotropic { rho, .. } => rho,
        }
    }

    /// The modulus a `youngs_modulus` parameter reads: `E1` (MAT8) or `G11` (MAT2).
    pub fn modulus(&self) -> f64 {
        match self {
            ShellMaterial::Orthotropic { e1, .. } => *e1,
            ShellMaterial::Anisotropic { g, .. } => g[0],
        }
    }

    /// Sets [`Self::modulus`] to `value`, scaling every other modulus by the same factor (the
    /// Poisson's ratio kept), so that the stiffness is proportional to the value.
    pub fn set_modulus(&mut self, value: f64) {
        let f = value / self.modulus();
        match self {
            ShellMaterial::Orthotropic {
                e1,
                e2,
                g12,
                g1z,
                g2z,
                ..
            } => {
                *e1 = value;
                for v in [e2, g12, g1z, g2z] {
                    *v *= f;
                }
            }
            ShellMaterial::Anisotropic { g, .. } => {
                for v in g.iter_mut() {
                    *v *= f;
                }
                g[0] = value;
            }
        }
    }
}

/// The plies of a laminate (PCOMP, PCOMPG), bottom to top.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Laminate {
    /// Plies as given (for a symmetric laminate, one half, bottom to middle).
    pub plies: Vec<Ply>,
    /// Bottom surface relative to the reference plane, m (`None`: `−T/2`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z0: Option<f64>,
    /// LAM = SYM: the plies are mirrored about the middle (the full stack is the plies, then
    /// the plies in reverse order).
    #[serde(default, skip_serializing_if = "is_false")]
    pub symmetric: bool,
    /// PCOMPG's global ply ids (empty for PCOMP).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub global_ids: Vec<u64>,
    /// Which stiffness terms the laminate develops (LAM = MEM, BEND, SMEAR).
    #[serde(default, skip_serializing_if = "LaminateTerms::is_all")]
    pub terms: LaminateTerms,
}

/// The stiffness terms a laminate develops (PCOMP's LAM, QRG): all of them, or the derived
/// shell's membrane (MEM) or bending (BEND) terms only, or the smeared ones (SMEAR), or a
/// sandwich of smeared face sheets about a core (SMCORE).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LaminateTerms {
    /// LAM blank or SYM: `A`, `B`, `D` and the transverse shear of the stack.
    #[default]
    All,
    /// LAM = MEM: the membrane stiffness `A` only (a membrane: no bending, coupling or
    /// transverse shear stiffness; the mass as the stack's).
    Membrane,
    /// LAM = BEND: the bending stiffness `D` (about the reference plane) and the transverse
    /// shear only (no membrane stiffness or coupling).
    Bending,
    /// LAM = SMEAR: the stacking sequence ignored — the smeared membrane stiffness `A` and
    /// `D = A T²/12` about the laminate's middle surface (the derived shell's MID2 = MID1, no
    /// MID4), shifted to the reference plane like an offset when `Z0 ≠ −T/2`.
    Smeared,
    /// LAM = SMCORE: a sandwich — the last ply is the core, the plies before it the face
    /// sheets, smeared and split half below and half above the core, symmetric about the core's
    /// middle surface (the reference plane; `B = 0`).
    SmearedCore,
}

impl LaminateTerms {
    fn is_all(&self) -> bool {
        *self == LaminateTerms::All
    }

    /// The LAM word (blank for all terms; SYM is written from [`Laminate::symmetric`]).
    pub fn lam(self) -> &'static str {
        match self {
            LaminateTerms::All => "",
            LaminateTerms::Membrane => "MEM",
            LaminateTerms::Bending => "BEND",
            LaminateTerms::Smeared => "SMEAR",
            LaminateTerms::SmearedCore => "SMCORE",
        }
    }
}

fn is_false(v: &bool) -> bool {
    !*v
}

/// One ply.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Ply {
    /// Material id (MAT1, MAT2 or MAT8).
    pub material: u64,
    /// Thickness, m.
    pub thickness: f64,
    /// Fibre angle from the element's material x axis, degrees.
    pub theta_deg: f64,
}

impl Laminate {
    /// The full stack, bottom to top (a symmetric laminate mirrored).
    pub fn stack(&self) -> Vec<Ply> {
        let mut out = self.plies.clone();
        if self.symmetric {
            out.extend(self.plies.iter().rev().copied());
        }
        out
    }

    /// Total thickness, m.
    pub fn thickness(&self) -> f64 {
        self.stack().iter().map(|p| p.thickness).sum()
    }

    /// The bottom surface relative to the reference plane, m.
    pub fn bottom(&self) -> f64 {
        self.z0.unwrap_or_else(|| -0.5 * self.thickness())
    }
}

/// Material axis and offset of one shell element (CQUAD4/CTRIA3/CQUADR/CTRIAR THETA or MCID,
/// ZOFFS); the default is none (THETA = 0 from G1→G2, no offset).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShellPlacement {
    /// THETA: the material x axis at this angle (degrees) from the G1→G2 edge.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub theta_deg: f64,
    /// MCID resolved: the basic-system direction (the coordinate system's x axis) whose
    /// projection on the element is the material x axis; replaces `theta_deg`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// ZOFFS: the reference plane's offset from the grid plane along the element normal, m.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub offset: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl ShellPlacement {
    /// Whether it is the default (no placement).
    pub fn is_default(&self) -> bool {
        *self == ShellPlacement::default()
    }
}

impl ShellProperty {
    /// Every material id the property names (parts or plies).
    pub fn material_ids(&self) -> Vec<u64> {
        let mut out = vec![self.material];
        match &self.laminate {
            Some(l) => out.extend(l.plies.iter().map(|p| p.material)),
            None => {
                out.extend([self.bending_mid(), self.shear_mid()]);
                out.extend(self.coupling_material);
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Sets the thickness; a laminate's plies (and an explicit `z0`) scale with it, so the
    /// stack keeps its shape.
    pub fn set_thickness(&mut self, value: f64) {
        if let Some(l) = &mut self.laminate {
            let f = value / self.thickness;
            for p in &mut l.plies {
                p.thickness *= f;
            }
            if let Some(z0) = &mut l.z0 {
                *z0 *= f;
            }
        }
        self.thickness = value;
    }
}
