//! Flat shell elements with six DOFs per node: the 4-node `quad4` and the 3-node `tria3`.
//!
//! Both are flat facet shells: a membrane and a Mindlin–Reissner plate, uncoupled in the element's
//! local plane, plus a drilling penalty, rotated to the basic system. DOFs are node-major,
//! `ux uy uz rx ry rz` at each node (see [`super::element`]).
//!
//! **Local system.** `quad4`: the normal `e3` is along `(x3 − x1) × (x4 − x2)` (the normal of the
//! bilinear surface at its centre), `e1` along `∂x/∂ξ` at the centre projected on the plane, and
//! the plane passes through the mean of the four nodes (the mean plane). A warped quad has its
//! corners at heights `z_i = ±h` off that plane; the element is formed on the projected flat quad
//! and joined to the real nodes by rigid offsets (`u_P = u_X − z_i θ × e3`), the rigid-link warping
//! correction (MacNeal 1978, *Comput. Struct.* 8). Rigid-body motions of the real nodes are
//! rigid-body motions of the projected ones, so a warped element keeps exactly six zero-energy
//! modes, and the matrices are continuous in `h` (the flat element is `h = 0`). A warp ratio `h/√A`
//! above [`MAX_WARP_RATIO`] is rejected. `tria3`: `e1` along edge 1–2, `e3` along
//! `(x2 − x1) × (x3 − x1)`.
//!
//! **Membrane.** `quad4`: bilinear isoparametric with the two incompatible modes `1 − ξ²`, `1 − η²`
//! per displacement (QM6, Taylor, Beresford & Wilson 1976, *IJNME* 10), whose derivatives are taken
//! with the centre Jacobian and scaled by `det J₀ / det J` so that the patch test is passed; the
//! four internal DOFs are condensed statically. 2 × 2 Gauss. `tria3`: constant strain (CST). Plane
//! stress `C = E/(1 − ν²) [[1, ν, 0], [ν, 1, 0], [0, 0, (1 − ν)/2]]`, membrane `t C`.
//!
//! **Plate.** Displacements `u = z θy`, `v = −z θx`; curvatures `κx = ∂θy/∂x`, `κy = −∂θx/∂y`,
//! `κxy = ∂θy/∂y − ∂θx/∂x`, bending `t³/12 C`; transverse shear `γxz = ∂w/∂x + θy`,
//! `γyz = ∂w/∂y − θx` with `κ G t`, `κ = 5/6`. No shear locking: `quad4` is MITC4 (Bathe & Dvorkin
//! 1986, *IJNME* 22; Dvorkin & Bathe 1984, *Eng. Comput.* 1): the covariant shear strains `γ_ξ`,
//! `γ_η` are tied at the edge midpoints (`γ_ξ` at `(0, ±1)`, `γ_η` at `(±1, 0)`) and interpolated
//! linearly across, 2 × 2 Gauss. `tria3` is MITC3 (Lee & Bathe 2004, *Comput. Struct.* 82): the
//! assumed covariant shear field `γ̃_r = γ_r⁽¹⁾ + c s`, `γ̃_s = γ_s⁽²⁾ − c r` ties the tangential
//! shear strain at the three edge midpoints (a rotated Raviart–Thomas field, isotropic, independent
//! of node numbering), 3-point rule, with the shear stabilisation of Lyly, Stenberg & Vihinen
//! (1993, *Comput. Methods Appl. Mech. Eng.* 110): the shear rigidity is `κ G t · t²/(t² + α h²)`
//! with `α =` [`TRIA_SHEAR_STABILISATION`] and `h` the longest edge. That factor removes the
//! residual stiffness of MITC3 in thin plates; it is not ∝ t, and its `t`-derivative is included
//! exactly.
//!
//! **Drilling.** Each node's `θz` is tied by a penalty to the in-plane rotation of the membrane at
//! the element centre, `ω₀ = ½(∂v/∂x − ∂u/∂y)`: `U = ½ (k_d / n) Σ_i (θz_i − ω₀)²`,
//! `k_d = α_d G t A`, `α_d =` [`DRILLING_FACTOR`] `= 10⁻³`. Rigid-body rotations give zero energy;
//! condensing the `θz` out of one element gives back the drilling-free element exactly (tested), so
//! the penalty stiffens nothing inside an element; in a mesh it only adds `O(α_d)` where
//! neighbouring elements rotate differently (tested to be < 0.1 % on an in-plane bending strip),
//! and in a flat plate it is uncoupled from bending.
//!
//! **Mass.** Consistent: `∫ Nᵢ Nⱼ dA` times `μ = ρ t + nsm` on the three translations and
//! `I = ρ t³/12` on the three rotations (the same rotary inertia on `θz` as on `θx`, `θy`, so the
//! block is isotropic and `M` is positive definite when `ρ > 0`); for a warped quad it goes through
//! the same rigid offsets. Lumped: diagonal, `μ A / n` on each translation and `I A / n` on each
//! rotation of every node (frame independent, hence also diagonal in the basic system). `A` is the
//! area of the (projected) flat element. Non-structural mass carries no rotary inertia.
//!
//! **Parts of a Nastran PSHELL** ([`ShellLayers`]; `None` is the homogeneous shell above). The
//! membrane is of the section's `E`, `ν` (MID1); bending of its own `(E_b, ν_b)` (MID2) with
//! `D = (12I/T³) t³/12 C(E_b, ν_b)`; transverse shear `(TS/T) G_s t` (MID3; TS/T replaces
//! `κ`). Without membrane (MID1 blank) there is no membrane and no drilling stiffness; without
//! bending (MID2 blank) no bending, no transverse shear, no drilling stiffness and no rotary
//! inertia, so the rotations of a membrane-only mesh get neither stiffness nor mass and the
//! assembly drops them (as Nastran's AUTOSPC). θz carries rotary inertia only when the element
//! has drilling stiffness (membrane and bending). The rotary inertia stays `ρ t³/12`, not
//! scaled by 12I/T³ (Nastran derives no rotary inertia from 12I/T³ either; it is an O(t²) term).
//! The mass is always `ρ t + nsm` of the section's density (MID1's, or MID2's when MID1 is blank).
//!
//! **Derivatives** (docs/theory.md §2, thesis 2.13–2.16: (2.13), (2.14), (2.15), (2.16); analytic
//! where the element allows, so assembled `∂K/∂φ`, `∂M/∂φ` need no rebuild). The local stiffness is
//! kept in three parts: membrane + drilling `K_m ∝ E t`, shear `K_s ∝ E t` (× the tria3
//! stabilisation factor), bending `K_b ∝ E t³`, so `∂K/∂t = K_m/t + (∂ ln K_s/∂t) K_s + 3 K_b/t`,
//! `∂K/∂E = K/E` (the parts of the section's own material only), `∂K/∂ρ = 0`; the mass is `M = μ M_tr + I M_rot` with `∂μ/∂t = ρ`,
//! `∂I/∂t = ρ t²/4`, `∂μ/∂ρ = t`, `∂I/∂ρ = t³/12`, `∂μ/∂nsm = 1`. All are exact;
//! [`quad4_with_derivatives`] returns the matrices and any number of derivatives from one
//! evaluation of the local parts.
//!
//! **General law** (laminates, MAT2/MAT8 parts, MID4, offsets): [`general`].
//!
//! **Cost.** Everything is on the stack (`[[f64; 24]; 24]`) until the final conversion to
//! [`faer::Mat`]; no heap allocation in the integration loops.

// Index loops follow the index notation of the formulas (B, D, K over DOF numbers).
#![allow(clippy::needless_range_loop)]

use super::element::{ElementDerivative, ElementError, ElementMatrices, MassKind, positive};
use faer::Mat;

/// Transverse shear correction factor `κ` of the Mindlin–Reissner plate.
pub const SHEAR_CORRECTION: f64 = 5.0 / 6.0;
/// Drilling penalty factor `α_d`: an element's total drilling stiffness is `α_d G t A`.
pub const DRILLING_FACTOR: f64 = 1e-3;
/// Largest accepted warp ratio `h / √A` of a quad (corner offset from the mean plane over √area).
pub const MAX_WARP_RATIO: f64 = 0.2;
/// Shear stabilisation `α` of tria3: shear rigidity `κ G t · t²/(t² + α h²)`.
pub const TRIA_SHEAR_STABILISATION: f64 = 0.1;

/// Section and material of a homogeneous isotropic shell.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct ShellSection {
    /// Thickness `t` (m), > 0.
    pub thickness: f64,
    /// Young's modulus `E` (Pa), > 0.
    pub e: f64,
    /// Poisson's ratio `ν`, with −1 < ν < 0.5.
    pub nu: f64,
    /// Density `ρ` (kg/m³), ≥ 0.
    pub rho: f64,
    /// Non-structural mass per unit area (kg/m²), ≥ 0, translational only.
    #[serde(default)]
    pub nsm: f64,
    /// The parts of a shell that is not homogeneous (Nastran PSHELL with MID1 or MID2 blank,
    /// other MID2/MID3 materials, 12I/T³ or TS/T); `None` is the homogeneous shell of `e`, `nu`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layers: Option<ShellLayers>,
}

/// Which stiffness parts a shell has and of which material (Nastran PSHELL MID1, MID2, MID3,
/// 12I/T³, TS/T). The membrane is always of the section's own `e`, `nu`.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct ShellLayers {
    /// Membrane and drilling stiffness present (MID1 given).
    pub membrane: bool,
    /// Bending material, or `None`: no bending, no transverse shear, no rotary inertia (MID2
    /// blank).
    pub bending: Option<LayerMaterial>,
    /// Transverse shear material (MID3; used only with bending).
    pub shear: LayerMaterial,
    /// Bending stiffness ratio `12I/T³` (> 0): `D = (12I/T³) t³/12 C_b`.
    pub bending_ratio: f64,
    /// Transverse shear thickness ratio `TS/T` (> 0), the shear correction factor.
    pub shear_ratio: f64,
}

/// The material of one stiffness part.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum LayerMaterial {
    /// The section's own `e`, `nu` (it follows a Young's modulus parameter).
    Own,
    /// Another isotropic material.
    Other {
        /// Young's modulus (Pa), > 0.
        e: f64,
        /// Poisson's ratio, −1 < ν < 0.5.
        nu: f64,
    },
}

/// What a kernel forms of one section: per part its `(E, ν)`, whether it is the section's own
/// material, and the factors of the bending and shear rigidities.
struct Resolved {
    membrane: bool,
    bending: Option<(f64, f64, bool)>,
    shear: (f64, f64, bool),
    bending_ratio: f64,
    shear_ratio: f64,
}

impl ShellSection {
    fn resolved(&self) -> Resolved {
        let own = (self.e, self.nu, true);
        let of = |m: LayerMaterial| match m {
            LayerMaterial::Own => own,
            LayerMaterial::Other { e, nu } => (e, nu, false),
        };
        match self.layers {
            None => Resolved {
                membrane: true,
                bending: Some(own),
                shear: own,
                bending_ratio: 1.0,
                shear_ratio: SHEAR_CORRECTION,
            },
            Some(l) => Resolved {
                membrane: l.membrane,
                bending: l.bending.map(of),
                shear: of(l.shear),
                bending_ratio: l.bending_ratio,
                shear_ratio: l.shear_ratio,
            },
        }
    }
}

impl ShellSection {
    /// Checks every value is finite and in range.
    pub fn validate(&self) -> Result<(), ElementError> {
        positive("thickness", self.thickness, false)?;
        positive("e", self.e, false)?;
        if !(self.nu.is_finite() && self.nu > -1.0 && self.nu < 0.5) {
            return Err(ElementError::BadValue {
                field: "nu",
                value: self.nu,
                hint: "must be finite with -1 < nu < 0.5",
            });
        }
        positive("rho", self.rho, true)?;
        positive("nsm", self.nsm, true)?;
        if let Some(l) = &self.layers {
            if !l.membrane && l.bending.is_none() {
                return Err(ElementError::BadValue {
                    field: "layers",
                    value: 0.0,
                    hint: "a shell needs membrane or bending stiffness (MID1 or MID2)",
                });
            }
            positive("bending_ratio", l.bending_ratio, false)?;
            positive("shear_ratio", l.shear_ratio, false)?;
            for m in l.bending.iter().chain([&l.shear]) {
                if let LayerMaterial::Other { e, nu } = *m {
                    positive("e", e, false)?;
                    if !(nu.is_finite() && nu > -1.0 && nu < 0.5) {
                        return Err(ElementError::BadValue {
                            field: "nu",
                            value: nu,
                            hint: "must be finite with -1 < nu < 0.5",
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Shear modulus `G = E / (2(1 + ν))`.
    pub fn shear_modulus(&self) -> f64 {
        self.e / (2.0 * (1.0 + self.nu))
    }

    /// Current value of a parameter.
    pub fn parameter(&self, p: ShellParameter) -> f64 {
        match p {
            ShellParameter::Thickness => self.thickness,
            ShellParameter::YoungsModulus => self.e,
            ShellParameter::Density => self.rho,
            ShellParameter::NonStructuralMass => self.nsm,
        }
    }

    /// A copy with one parameter set to `value` (not validated until used).
    pub fn with_parameter(&self, p: ShellParameter, value: f64) -> ShellSection {
        let mut s = *self;
        match p {
            ShellParameter::Thickness => s.thickness = value,
            ShellParameter::YoungsModulus => s.e = value,
            ShellParameter::Density => s.rho = value,
            ShellParameter::NonStructuralMass => s.nsm = value,
        }
        s
    }
}

/// A shell parameter with an analytic derivative.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum ShellParameter {
    /// Thickness `t`.
    Thickness,
    /// Young's modulus `E`.
    YoungsModulus,
    /// Density `ρ`.
    Density,
    /// Non-structural mass per area.
    NonStructuralMass,
}

impl ShellParameter {
    /// Every shell parameter.
    pub const ALL: [ShellParameter; 4] = [
        ShellParameter::Thickness,
        ShellParameter::YoungsModulus,
        ShellParameter::Density,
        ShellParameter::NonStructuralMass,
    ];

    /// The snake_case name used in messages and specs.
    pub fn name(self) -> &'static str {
        match self {
            ShellParameter::Thickness => "thickness",
            ShellParameter::YoungsModulus => "youngs_modulus",
            ShellParameter::Density => "density",
            ShellParameter::NonStructuralMass => "non_structural_mass",
        }
    }
}

/// Stiffness and mass of a 4-node flat shell (MITC4 plate, QM6 membrane, drilling penalty).
pub fn quad4(
    xyz: &[[f64; 3]; 4],
    s: &ShellSection,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    Ok(quad4_parts(xyz, s, DRILLING_FACTOR)?.matrices(s, mass))
}

/// Exact derivative of the quad4 matrices with respect to one parameter.
pub fn quad4_derivative(
    xyz: &[[f64; 3]; 4],
    s: &ShellSection,
    mass: MassKind,
    p: ShellParameter,
) -> Result<ElementDerivative, ElementError> {
    Ok(quad4_parts(xyz, s, DRILLING_FACTOR)?.derivative(s, mass, p))
}

/// Quad4 matrices and the derivatives for `params` (in that order) from one evaluation.
pub fn quad4_with_derivatives(
    xyz: &[[f64; 3]; 4],
    s: &ShellSection,
    mass: MassKind,
    params: &[ShellParameter],
) -> Result<(ElementMatrices, Vec<ElementDerivative>), ElementError> {
    let parts = quad4_parts(xyz, s, DRILLING_FACTOR)?;
    let d = params
        .iter()
        .map(|p| parts.derivative(s, mass, *p))
        .collect();
    Ok((parts.matrices(s, mass), d))
}

/// Stiffness and mass of a 3-node flat shell (MITC3 plate, CST membrane, drilling penalty).
pub fn tria3(
    xyz: &[[f64; 3]; 3],
    s: &ShellSection,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    Ok(tria3_parts(xyz, s, DRILLING_FACTOR)?.matrices(s, mass))
}

/// Exact derivative of the tria3 matrices with respect to one parameter.
pub fn tria3_derivative(
    xyz: &[[f64; 3]; 3],
    s: &ShellSection,
    mass: MassKind,
    p: ShellParameter,
) -> Result<ElementDerivative, ElementError> {
    Ok(tria3_parts(xyz, s, DRILLING_FACTOR)?.derivative(s, mass, p))
}

/// Tria3 matrices and the derivatives for `params` (in that order) from one evaluation.
pub fn tria3_with_derivatives(
    xyz: &[[f64; 3]; 3],
    s: &ShellSection,
    mass: MassKind,
    params: &[ShellParameter],
) -> Result<(ElementMatrices, Vec<ElementDerivative>), ElementError> {
    let parts = tria3_parts(xyz, s, DRILLING_FACTOR)?;
    let d = params
        .iter()
        .map(|p| parts.derivative(s, mass, *p))
        .collect();
    Ok((parts.matrices(s, mass), d))
}

// ---------------------------------------------------------------------------------------------
// Internals.

/// A 3-vector; the vector helpers below serve the quadratic shells too.
pub(super) type V3 = [f64; 3];

pub(super) fn sub(a: &V3, b: &V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn dot(a: &V3, b: &V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(super) fn cross(a: &V3, b: &V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(super) fn norm(a: &V3) -> f64 {
    dot(a, a).sqrt()
}

fn scaled(a: &V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Local frame of a flat (projected) element: rows of `t` are `e1 e2 e3` in the basic system.
struct Frame<const N: usize> {
    t: [[f64; 3]; 3],
    x: [f64; N],
    y: [f64; N],
    /// Offsets of the real nodes from the flat element along `e3` (zero for tria3).
    z: [f64; N],
}

/// An element's local parts, enough to form `K`, `M` and every derivative.
struct Parts<const N: usize, const D: usize> {
    frame: Frame<N>,
    area: f64,
    /// Membrane and drilling, ∝ E t.
    k_m: [[f64; D]; D],
    /// Transverse shear, ∝ E t (× stabilisation).
    k_s: [[f64; D]; D],
    /// `∂ ln K_s / ∂t`.
    dln_ks_dt: f64,
    /// Bending, ∝ E t³.
    k_b: [[f64; D]; D],
    /// `∫ Nᵢ Nⱼ dA`.
    m_geo: [[f64; N]; N],
    /// Whether membrane, shear and bending are of the section's own `E` (for `∂K/∂E`).
    own: [bool; 3],
    /// Rotary inertia on θx, θy (bending present) and on θz (bending and membrane present: θz has
    /// stiffness only through the drilling penalty, which a shell has only with both).
    rotary: [bool; 2],
}

impl<const N: usize, const D: usize> Parts<N, D> {
    fn matrices(&self, s: &ShellSection, kind: MassKind) -> ElementMatrices {
        let t = s.thickness;
        ElementMatrices {
            k: self.stiffness(1.0, 1.0, 1.0),
            m: self.mass(s.rho * t + s.nsm, s.rho * t * t * t / 12.0, kind),
        }
    }

    fn derivative(&self, s: &ShellSection, kind: MassKind, p: ShellParameter) -> ElementDerivative {
        let t = s.thickness;
        let zero = || Mat::zeros(D, D);
        match p {
            ShellParameter::Thickness => ElementDerivative {
                dk: self.stiffness(1.0 / t, self.dln_ks_dt, 3.0 / t),
                dm: self.mass(s.rho, s.rho * t * t / 4.0, kind),
            },
            ShellParameter::YoungsModulus => {
                let c = |own: bool| if own { 1.0 / s.e } else { 0.0 };
                ElementDerivative {
                    dk: self.stiffness(c(self.own[0]), c(self.own[1]), c(self.own[2])),
                    dm: zero(),
                }
            }
            ShellParameter::Density => ElementDerivative {
                dk: zero(),
                dm: self.mass(t, t * t * t / 12.0, kind),
            },
            ShellParameter::NonStructuralMass => ElementDerivative {
                dk: zero(),
                dm: self.mass(1.0, 0.0, kind),
            },
        }
    }

    /// `cm K_m + cs K_s + cb K_b`, rotated to the basic system.
    fn stiffness(&self, cm: f64, cs: f64, cb: f64) -> Mat<f64> {
        let mut kl = [[0.0; D]; D];
        for (i, row) in kl.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = cm * self.k_m[i][j] + cs * self.k_s[i][j] + cb * self.k_b[i][j];
            }
        }
        transform(&kl, &self.frame.t, &self.frame.z)
    }

    /// Mass with `mu` per area on translations and `inertia` per area on rotations (those of
    /// them the shell has, see `rotary`).
    fn mass(&self, mu: f64, inertia: f64, kind: MassKind) -> Mat<f64> {
        if self.rotary != [true, true] {
            return self.mass_in_local(mu, inertia, kind);
        }
        match kind {
            MassKind::Lumped => {
                let share = self.area / N as f64;
                Mat::from_fn(D, D, |r, c| {
                    if r != c {
                        0.0
                    } else if r % 6 < 3 {
                        share * mu
                    } else {
                        share * inertia
                    }
                })
            }
            MassKind::Consistent => {
                let mut ml = [[0.0; D]; D];
                for i in 0..N {
                    for j in 0..N {
                        for a in 0..6 {
                            let f = if a < 3 { mu } else { inertia };
                            ml[6 * i + a][6 * j + a] = self.m_geo[i][j] * f;
                        }
                    }
                }
                if self.frame.z.iter().all(|z| *z == 0.0) {
                    // The blocks are isotropic, so the rotation leaves them unchanged.
                    to_mat(&ml)
                } else {
                    transform(&ml, &self.frame.t, &self.frame.z)
                }
            }
        }
    }

    /// Mass formed in the local frame with rotary inertia only where the shell has it, then
    /// rotated (the rotational block is not isotropic then, so it is not frame independent).
    fn mass_in_local(&self, mu: f64, inertia: f64, kind: MassKind) -> Mat<f64> {
        let factor = |a: usize| match a {
            0..=2 => mu,
            3 | 4 if self.rotary[0] => inertia,
            5 if self.rotary[1] => inertia,
            _ => 0.0,
        };
        let mut ml = [[0.0; D]; D];
        for i in 0..N {
            for a in 0..6 {
                let f = factor(a);
                if f == 0.0 {
                    continue;
                }
                match kind {
                    MassKind::Lumped => ml[6 * i + a][6 * i + a] = self.area / N as f64 * f,
                    MassKind::Consistent => {
                        for j in 0..N {
                            ml[6 * i + a][6 * j + a] = self.m_geo[i][j] * f;
                        }
                    }
                }
            }
        }
        transform(&ml, &self.frame.t, &self.frame.z)
    }

    fn check_finite(&self) -> Result<(), ElementError> {
        let finite = |a: &[[f64; D]; D]| a.iter().flatten().all(|v| v.is_finite());
        let ok = finite(&self.k_m)
            && finite(&self.k_s)
            && finite(&self.k_b)
            && self.dln_ks_dt.is_finite()
            && self.area.is_finite()
            && self.m_geo.iter().flatten().all(|v| v.is_finite());
        if ok {
            Ok(())
        } else {
            Err(ElementError::Degenerate(
                "the element matrices overflow (non-finite entries); check the magnitudes of the coordinates, thickness and modulus".into(),
            ))
        }
    }
}

/// `Gᵀ K G` for `G = diag(G_1 … G_N)`, `G_i = [[T, Z_i], [0, T]]` (rotation `T`, rigid offset
/// `Z_i = z_i [−e2; e1; 0]`), written straight into an exactly symmetric `Mat`. Works on 3 × 3
/// blocks, skips the offset terms of flat nodes and forms only the upper node blocks.
fn transform<const N: usize, const D: usize>(
    kl: &[[f64; D]; D],
    t: &[[f64; 3]; 3],
    z: &[f64; N],
) -> Mat<f64> {
    type B3 = [[f64; 3]; 3];
    // X Y and Xᵀ Y for 3 × 3 blocks.
    fn mul(x: &B3, y: &B3) -> B3 {
        let mut o = [[0.0; 3]; 3];
        for (r, orow) in o.iter_mut().enumerate() {
            for (c, v) in orow.iter_mut().enumerate() {
                *v = x[r][0] * y[0][c] + x[r][1] * y[1][c] + x[r][2] * y[2][c];
            }
        }
        o
    }
    fn tmul(x: &B3, y: &B3) -> B3 {
        let mut o = [[0.0; 3]; 3];
        for (r, orow) in o.iter_mut().enumerate() {
            for (c, v) in orow.iter_mut().enumerate() {
                *v = x[0][r] * y[0][c] + x[1][r] * y[1][c] + x[2][r] * y[2][c];
            }
        }
        o
    }
    fn add(x: &mut B3, y: &B3) {
        for r in 0..3 {
            for c in 0..3 {
                x[r][c] += y[r][c];
            }
        }
    }
    let offset = |zi: f64| -> B3 {
        [
            [-zi * t[1][0], -zi * t[1][1], -zi * t[1][2]],
            [zi * t[0][0], zi * t[0][1], zi * t[0][2]],
            [0.0; 3],
        ]
    };
    let mut out = [[0.0; D]; D];
    for i in 0..N {
        for j in i..N {
            let blk = |r0: usize, c0: usize| -> B3 {
                let mut o = [[0.0; 3]; 3];
                for (r, orow) in o.iter_mut().enumerate() {
                    orow.copy_from_slice(&kl[6 * i + r0 + r][6 * j + c0..6 * j + c0 + 3]);
                }
                o
            };
            let (a, b, c, d) = (blk(0, 0), blk(0, 3), blk(3, 0), blk(3, 3));
            // K_ij G_j = [[A T, A Z_j + B T], [C T, C Z_j + D T]].
            let p = mul(&a, t);
            let r = mul(&c, t);
            let mut q = mul(&b, t);
            let mut u = mul(&d, t);
            if z[j] != 0.0 {
                let zj = offset(z[j]);
                add(&mut q, &mul(&a, &zj));
                add(&mut u, &mul(&c, &zj));
            }
            // G_iᵀ (K_ij G_j) = [[Tᵀ P, Tᵀ Q], [Z_iᵀ P + Tᵀ R, Z_iᵀ Q + Tᵀ U]].
            let o11 = tmul(t, &p);
            let o12 = tmul(t, &q);
            let mut o21 = tmul(t, &r);
            let mut o22 = tmul(t, &u);
            if z[i] != 0.0 {
                let zi = offset(z[i]);
                add(&mut o21, &tmul(&zi, &p));
                add(&mut o22, &tmul(&zi, &q));
            }
            for (r0, c0, o) in [(0, 0, &o11), (0, 3, &o12), (3, 0, &o21), (3, 3, &o22)] {
                for (rr, orow) in o.iter().enumerate() {
                    for (cc, v) in orow.iter().enumerate() {
                        out[6 * i + r0 + rr][6 * j + c0 + cc] = *v;
                    }
                }
            }
        }
    }
    // The lower node blocks are the transposes of the upper ones; the diagonal node blocks are
    // symmetrised.
    Mat::from_fn(D, D, |r, c| {
        if r / 6 == c / 6 {
            0.5 * (out[r][c] + out[c][r])
        } else if r < c {
            out[r][c]
        } else {
            out[c][r]
        }
    })
}

/// Exactly symmetric `Mat` from a (numerically) symmetric array.
fn to_mat<const D: usize>(a: &[[f64; D]; D]) -> Mat<f64> {
    Mat::from_fn(D, D, |i, j| 0.5 * (a[i][j] + a[j][i]))
}

/// `k += w Bᵀ Dm B` for an `R × C` strain matrix.
fn add_btdb<const R: usize, const C: usize>(
    k: &mut [[f64; C]; C],
    b: &[[f64; C]; R],
    dm: &[[f64; R]; R],
    w: f64,
) {
    let mut db = [[0.0; C]; R];
    for r in 0..R {
        for c in 0..C {
            let mut s = 0.0;
            for q in 0..R {
                s += dm[r][q] * b[q][c];
            }
            db[r][c] = s * w;
        }
    }
    for i in 0..C {
        for j in 0..C {
            let mut s = 0.0;
            for r in 0..R {
                s += b[r][i] * db[r][j];
            }
            k[i][j] += s;
        }
    }
}

fn plane_stress(e: f64, nu: f64, factor: f64) -> [[f64; 3]; 3] {
    let c = factor * e / (1.0 - nu * nu);
    [
        [c, c * nu, 0.0],
        [c * nu, c, 0.0],
        [0.0, 0.0, c * 0.5 * (1.0 - nu)],
    ]
}

/// Checks coordinates are finite and distinct; returns the largest node distance.
fn check_nodes<const N: usize>(xyz: &[[f64; 3]; N]) -> Result<f64, ElementError> {
    for (i, p) in xyz.iter().enumerate() {
        if !p.iter().all(|v| v.is_finite()) {
            return Err(ElementError::Degenerate(format!(
                "node {} has a non-finite coordinate {p:?}",
                i + 1
            )));
        }
    }
    let mut lmax = 0.0f64;
    for i in 0..N {
        for j in i + 1..N {
            lmax = lmax.max(norm(&sub(&xyz[j], &xyz[i])));
        }
    }
    if !(lmax.is_finite() && (lmax * lmax).is_finite()) {
        return Err(ElementError::Degenerate(
            "the node coordinates are too large (their distances overflow)".into(),
        ));
    }
    if lmax == 0.0 {
        return Err(ElementError::Degenerate(format!(
            "all {N} nodes coincide at {:?}",
            xyz[0]
        )));
    }
    for i in 0..N {
        for j in i + 1..N {
            let d = norm(&sub(&xyz[j], &xyz[i]));
            if d <= 1e-8 * lmax {
                return Err(ElementError::Degenerate(format!(
                    "nodes {} and {} coincide (distance {d:e} m for an element of size {lmax:e} m)",
                    i + 1,
                    j + 1
                )));
            }
        }
    }
    Ok(lmax)
}

const GAUSS2: f64 = 0.577_350_269_189_625_8;

/// Bilinear shape functions and their natural derivatives.
fn shape4(xi: f64, eta: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    const XI: [f64; 4] = [-1.0, 1.0, 1.0, -1.0];
    const ETA: [f64; 4] = [-1.0, -1.0, 1.0, 1.0];
    let mut n = [0.0; 4];
    let mut dxi = [0.0; 4];
    let mut deta = [0.0; 4];
    for i in 0..4 {
        n[i] = 0.25 * (1.0 + XI[i] * xi) * (1.0 + ETA[i] * eta);
        dxi[i] = 0.25 * XI[i] * (1.0 + ETA[i] * eta);
        deta[i] = 0.25 * ETA[i] * (1.0 + XI[i] * xi);
    }
    (n, dxi, deta)
}

/// `[x_ξ, y_ξ, x_η, y_η]` and `det J`.
fn jacobian4(x: &[f64; 4], y: &[f64; 4], dxi: &[f64; 4], deta: &[f64; 4]) -> ([f64; 4], f64) {
    let mut j = [0.0; 4];
    for i in 0..4 {
        j[0] += dxi[i] * x[i];
        j[1] += dxi[i] * y[i];
        j[2] += deta[i] * x[i];
        j[3] += deta[i] * y[i];
    }
    (j, j[0] * j[3] - j[1] * j[2])
}

/// Cartesian derivatives from natural ones: `[∂/∂x; ∂/∂y] = J⁻¹ [∂/∂ξ; ∂/∂η]`.
fn cartesian(j: &[f64; 4], det: f64, d_xi: f64, d_eta: f64) -> (f64, f64) {
    (
        (j[3] * d_xi - j[1] * d_eta) / det,
        (-j[2] * d_xi + j[0] * d_eta) / det,
    )
}

/// Covariant transverse shear strain along ξ (`along_xi`) or η at a point, over the 12 plate DOFs
/// `(w, θx, θy)` per node: `γ_ξ = ∂w/∂ξ + θy x_ξ − θx y_ξ`.
fn covariant_shear4(x: &[f64; 4], y: &[f64; 4], xi: f64, eta: f64, along_xi: bool) -> [f64; 12] {
    let (n, dxi, deta) = shape4(xi, eta);
    let d = if along_xi { dxi } else { deta };
    let (mut tx, mut ty) = (0.0, 0.0);
    for i in 0..4 {
        tx += d[i] * x[i];
        ty += d[i] * y[i];
    }
    let mut g = [0.0; 12];
    for i in 0..4 {
        g[3 * i] = d[i];
        g[3 * i + 1] = -n[i] * ty;
        g[3 * i + 2] = n[i] * tx;
    }
    g
}

fn quad_frame(xyz: &[[f64; 3]; 4]) -> Result<(Frame<4>, f64), ElementError> {
    let lmax = check_nodes(xyz)?;
    let centre = scaled(
        &[
            xyz[0][0] + xyz[1][0] + xyz[2][0] + xyz[3][0],
            xyz[0][1] + xyz[1][1] + xyz[2][1] + xyz[3][1],
            xyz[0][2] + xyz[1][2] + xyz[2][2] + xyz[3][2],
        ],
        0.25,
    );
    let d1 = sub(&xyz[2], &xyz[0]);
    let d2 = sub(&xyz[3], &xyz[1]);
    let nvec = cross(&d1, &d2);
    let nn = norm(&nvec);
    // Area of the projection on the mean plane.
    let area = 0.5 * nn;
    if area.is_nan() || area <= 1e-10 * lmax * lmax {
        return Err(ElementError::Degenerate(format!(
            "the quad has (near) zero area {area:e} m² (its diagonals are parallel: collinear or folded nodes)"
        )));
    }
    let e3 = scaled(&nvec, 1.0 / nn);
    let mut gxi = [0.0; 3];
    for (k, v) in gxi.iter_mut().enumerate() {
        *v = 0.25 * (-xyz[0][k] + xyz[1][k] + xyz[2][k] - xyz[3][k]);
    }
    let gxi = sub(&gxi, &scaled(&e3, dot(&gxi, &e3)));
    let ng = norm(&gxi);
    if ng.is_nan() || ng <= 1e-8 * lmax {
        return Err(ElementError::Degenerate(
            "the quad has no extent along its first parametric direction (nodes 1-2 and 4-3 fold back)"
                .into(),
        ));
    }
    let e1 = scaled(&gxi, 1.0 / ng);
    let e2 = cross(&e3, &e1);
    let mut frame = Frame {
        t: [e1, e2, e3],
        x: [0.0; 4],
        y: [0.0; 4],
        z: [0.0; 4],
    };
    for i in 0..4 {
        let r = sub(&xyz[i], &centre);
        frame.x[i] = dot(&r, &e1);
        frame.y[i] = dot(&r, &e2);
        frame.z[i] = dot(&r, &e3);
    }
    let warp = frame.z.iter().fold(0.0f64, |a, z| a.max(z.abs())) / area.sqrt();
    if warp > MAX_WARP_RATIO {
        return Err(ElementError::Degenerate(format!(
            "the quad is warped too much: corner offset / sqrt(area) = {warp:.3} > {MAX_WARP_RATIO}; split it into two tria3"
        )));
    }
    // Corner Jacobians of the projected quad: all positive for a convex quad (det J is affine in
    // ξ and η, so then it is positive everywhere).
    for i in 0..4 {
        let (ip, im) = ((i + 1) % 4, (i + 3) % 4);
        let (ax, ay) = (frame.x[ip] - frame.x[i], frame.y[ip] - frame.y[i]);
        let (bx, by) = (frame.x[im] - frame.x[i], frame.y[im] - frame.y[i]);
        let c = ax * by - ay * bx;
        if c.is_nan() || c <= 1e-6 * area {
            return Err(ElementError::Degenerate(format!(
                "the Jacobian at corner node {} is {} ({c:e}): the quad is concave, crossed (bow-tie) or has three collinear nodes; give a convex quad or use tria3",
                i + 1,
                if c > 0.0 { "near zero" } else { "negative" }
            )));
        }
    }
    Ok((frame, area))
}

/// Local parts of a quad4 with drilling factor `drill`.
fn quad4_parts(
    xyz: &[[f64; 3]; 4],
    s: &ShellSection,
    drill: f64,
) -> Result<Parts<4, 24>, ElementError> {
    s.validate()?;
    let (frame, _) = quad_frame(xyz)?;
    let (x, y) = (&frame.x, &frame.y);
    let t = s.thickness;
    let r = s.resolved();
    let g_mod = s.shear_modulus();
    let dm = plane_stress(s.e, s.nu, t);
    let (e_b, nu_b, own_b) = r.bending.unwrap_or((s.e, s.nu, true));
    let db = plane_stress(e_b, nu_b, t * t * t / 12.0 * r.bending_ratio);
    let (e_s, nu_s, own_s) = r.shear;
    let ks_coef = r.shear_ratio * (e_s / (2.0 * (1.0 + nu_s))) * t;
    let ds = [[ks_coef, 0.0], [0.0, ks_coef]];

    // Centre Jacobian for the incompatible modes and the drilling rotation.
    let (_, dxi0, deta0) = shape4(0.0, 0.0);
    let (j0, det0) = jacobian4(x, y, &dxi0, &deta0);
    // MITC4 tying points: γ_ξ at A (0, 1) and C (0, −1); γ_η at D (1, 0) and B (−1, 0).
    let ga = covariant_shear4(x, y, 0.0, 1.0, true);
    let gc = covariant_shear4(x, y, 0.0, -1.0, true);
    let gd = covariant_shear4(x, y, 1.0, 0.0, false);
    let gb = covariant_shear4(x, y, -1.0, 0.0, false);

    let mut kuu = [[0.0; 8]; 8];
    let mut kua = [[0.0; 4]; 8];
    let mut kaa = [[0.0; 4]; 4];
    let mut kbend = [[0.0; 12]; 12];
    let mut kshear = [[0.0; 12]; 12];
    let mut m_geo = [[0.0; 4]; 4];
    let mut area = 0.0;
    for (xi, eta) in [
        (-GAUSS2, -GAUSS2),
        (GAUSS2, -GAUSS2),
        (GAUSS2, GAUSS2),
        (-GAUSS2, GAUSS2),
    ] {
        let (n, dxi, deta) = shape4(xi, eta);
        let (j, det) = jacobian4(x, y, &dxi, &deta);
        if det.is_nan() || det <= 0.0 {
            return Err(ElementError::Degenerate(format!(
                "non-positive Jacobian {det:e} inside the quad"
            )));
        }
        let w = det;
        area += w;
        let mut nx = [0.0; 4];
        let mut ny = [0.0; 4];
        for i in 0..4 {
            (nx[i], ny[i]) = cartesian(&j, det, dxi[i], deta[i]);
        }
        // Membrane, compatible part over (u, v) per node.
        let mut bu = [[0.0; 8]; 3];
        for i in 0..4 {
            bu[0][2 * i] = nx[i];
            bu[1][2 * i + 1] = ny[i];
            bu[2][2 * i] = ny[i];
            bu[2][2 * i + 1] = nx[i];
        }
        // Incompatible modes P1 = 1 − ξ², P2 = 1 − η² (Taylor's centre-Jacobian form).
        let scale = det0 / det;
        let (p1x, p1y) = cartesian(&j0, det0, -2.0 * xi, 0.0);
        let (p2x, p2y) = cartesian(&j0, det0, 0.0, -2.0 * eta);
        let (p1x, p1y, p2x, p2y) = (p1x * scale, p1y * scale, p2x * scale, p2y * scale);
        let ba = [
            [p1x, p2x, 0.0, 0.0],
            [0.0, 0.0, p1y, p2y],
            [p1y, p2y, p1x, p2x],
        ];
        add_btdb(&mut kuu, &bu, &dm, w);
        add_btdb(&mut kaa, &ba, &dm, w);
        for a in 0..8 {
            for b in 0..4 {
                let mut acc = 0.0;
                for r in 0..3 {
                    for q in 0..3 {
                        acc += bu[r][a] * dm[r][q] * ba[q][b];
                    }
                }
                kua[a][b] += acc * w;
            }
        }
        // Bending over (w, θx, θy) per node.
        let mut bb = [[0.0; 12]; 3];
        for i in 0..4 {
            bb[0][3 * i + 2] = nx[i];
            bb[1][3 * i + 1] = -ny[i];
            bb[2][3 * i + 2] = ny[i];
            bb[2][3 * i + 1] = -nx[i];
        }
        add_btdb(&mut kbend, &bb, &db, w);
        // MITC4 assumed shear strains.
        let mut bs = [[0.0; 12]; 2];
        for c in 0..12 {
            let g_xi = 0.5 * (1.0 + eta) * ga[c] + 0.5 * (1.0 - eta) * gc[c];
            let g_eta = 0.5 * (1.0 + xi) * gd[c] + 0.5 * (1.0 - xi) * gb[c];
            (bs[0][c], bs[1][c]) = cartesian(&j, det, g_xi, g_eta);
        }
        add_btdb(&mut kshear, &bs, &ds, w);
        for a in 0..4 {
            for b in 0..4 {
                m_geo[a][b] += n[a] * n[b] * w;
            }
        }
    }
    // Condense the incompatible modes: K = Kuu − Kua Kaa⁻¹ Kau.
    let x_aa = cholesky_solve(kaa, transpose84(&kua)).ok_or_else(|| {
        ElementError::Degenerate(
            "the incompatible-mode stiffness is singular (distorted quad)".into(),
        )
    })?;
    for a in 0..8 {
        for b in 0..8 {
            let mut acc = 0.0;
            for c in 0..4 {
                acc += kua[a][c] * x_aa[c][b];
            }
            kuu[a][b] -= acc;
        }
    }

    let mut parts = Parts {
        frame,
        area,
        k_m: [[0.0; 24]; 24],
        k_s: [[0.0; 24]; 24],
        dln_ks_dt: 1.0 / t,
        k_b: [[0.0; 24]; 24],
        m_geo,
        own: [true, own_s, own_b],
        rotary: [r.bending.is_some(), r.bending.is_some() && r.membrane],
    };
    if r.bending.is_some() {
        scatter_plate(&mut parts.k_b, &kbend);
        scatter_plate(&mut parts.k_s, &kshear);
    }
    if r.membrane {
        scatter_membrane(&mut parts.k_m, &kuu);
        let mut nx0 = [0.0; 4];
        let mut ny0 = [0.0; 4];
        for i in 0..4 {
            (nx0[i], ny0[i]) = cartesian(&j0, det0, dxi0[i], deta0[i]);
        }
        if r.bending.is_some() {
            add_drilling(&mut parts.k_m, &nx0, &ny0, drill * g_mod * t * area);
        }
    }
    parts.check_finite()?;
    Ok(parts)
}

fn transpose84(a: &[[f64; 4]; 8]) -> [[f64; 8]; 4] {
    let mut t = [[0.0; 8]; 4];
    for i in 0..8 {
        for j in 0..4 {
            t[j][i] = a[i][j];
        }
    }
    t
}

/// Solves `A X = B` for symmetric positive definite `A` (Cholesky); `None` if not SPD.
fn cholesky_solve<const N: usize, const M: usize>(
    a: [[f64; N]; N],
    mut b: [[f64; M]; N],
) -> Option<[[f64; M]; N]> {
    let mut l = [[0.0; N]; N];
    for i in 0..N {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s.is_nan() || s <= 0.0 {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    for c in 0..M {
        for i in 0..N {
            let mut s = b[i][c];
            for k in 0..i {
                s -= l[i][k] * b[k][c];
            }
            b[i][c] = s / l[i][i];
        }
        for i in (0..N).rev() {
            let mut s = b[i][c];
            for k in i + 1..N {
                s -= l[k][i] * b[k][c];
            }
            b[i][c] = s / l[i][i];
        }
    }
    Some(b)
}

/// Adds a `(u, v)`-per-node membrane matrix into the 6-per-node local matrix.
fn scatter_membrane<const D: usize, const M: usize>(k: &mut [[f64; D]; D], km: &[[f64; M]; M]) {
    for a in 0..M {
        for b in 0..M {
            k[6 * (a / 2) + a % 2][6 * (b / 2) + b % 2] += km[a][b];
        }
    }
}

/// Adds a `(w, θx, θy)`-per-node plate matrix into the 6-per-node local matrix.
fn scatter_plate<const D: usize, const P: usize>(k: &mut [[f64; D]; D], kp: &[[f64; P]; P]) {
    for a in 0..P {
        for b in 0..P {
            k[6 * (a / 3) + 2 + a % 3][6 * (b / 3) + 2 + b % 3] += kp[a][b];
        }
    }
}

/// Drilling penalty `½ (kd/n) Σ (θz_i − ω₀)²` with `ω₀ = ½(∂v/∂x − ∂u/∂y)` from the centre
/// derivatives `nx`, `ny` of the shape functions.
fn add_drilling<const D: usize, const N: usize>(
    k: &mut [[f64; D]; D],
    nx: &[f64; N],
    ny: &[f64; N],
    kd: f64,
) {
    let mut g = [0.0; D];
    for i in 0..N {
        g[6 * i] = -0.5 * ny[i];
        g[6 * i + 1] = 0.5 * nx[i];
    }
    let w = kd / N as f64;
    for i in 0..N {
        let mut c = g.map(|v| -v);
        c[6 * i + 5] += 1.0;
        for a in 0..D {
            if c[a] == 0.0 {
                continue;
            }
            for b in 0..D {
                k[a][b] += w * c[a] * c[b];
            }
        }
    }
}

/// Tangential shear strain of edge `i → j` tied at its midpoint, over the 9 plate DOFs:
/// `(w_j − w_i) + ½(β_i + β_j)·(x_j − x_i)` with `β = (θy, −θx)`.
fn edge_shear3(x: &[f64; 3], y: &[f64; 3], i: usize, j: usize) -> [f64; 9] {
    let (dx, dy) = (x[j] - x[i], y[j] - y[i]);
    let mut g = [0.0; 9];
    g[3 * i] -= 1.0;
    g[3 * j] += 1.0;
    for k in [i, j] {
        g[3 * k + 1] -= 0.5 * dy;
        g[3 * k + 2] += 0.5 * dx;
    }
    g
}

/// Local parts of a tria3 with drilling factor `drill`.
fn tria3_parts(
    xyz: &[[f64; 3]; 3],
    s: &ShellSection,
    drill: f64,
) -> Result<Parts<3, 18>, ElementError> {
    s.validate()?;
    let lmax = check_nodes(xyz)?;
    let r12 = sub(&xyz[1], &xyz[0]);
    let r13 = sub(&xyz[2], &xyz[0]);
    let nvec = cross(&r12, &r13);
    let nn = norm(&nvec);
    let area = 0.5 * nn;
    if area.is_nan() || area <= 1e-10 * lmax * lmax {
        return Err(ElementError::Degenerate(format!(
            "the triangle has (near) zero area {area:e} m² (collinear nodes)"
        )));
    }
    let e1 = scaled(&r12, 1.0 / norm(&r12));
    let e3 = scaled(&nvec, 1.0 / nn);
    let e2 = cross(&e3, &e1);
    let centre = scaled(
        &[
            xyz[0][0] + xyz[1][0] + xyz[2][0],
            xyz[0][1] + xyz[1][1] + xyz[2][1],
            xyz[0][2] + xyz[1][2] + xyz[2][2],
        ],
        1.0 / 3.0,
    );
    let mut frame = Frame {
        t: [e1, e2, e3],
        x: [0.0; 3],
        y: [0.0; 3],
        z: [0.0; 3],
    };
    for i in 0..3 {
        let r = sub(&xyz[i], &centre);
        frame.x[i] = dot(&r, &e1);
        frame.y[i] = dot(&r, &e2);
    }
    let (x, y) = (frame.x, frame.y);
    let t = s.thickness;
    let r = s.resolved();
    let g_mod = s.shear_modulus();
    let dm = plane_stress(s.e, s.nu, t);
    let (e_b, nu_b, own_b) = r.bending.unwrap_or((s.e, s.nu, true));
    let db = plane_stress(e_b, nu_b, t * t * t / 12.0 * r.bending_ratio);
    // Shape function derivatives (constant).
    let two_a = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
    let mut nx = [0.0; 3];
    let mut ny = [0.0; 3];
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        nx[i] = (y[j] - y[k]) / two_a;
        ny[i] = (x[k] - x[j]) / two_a;
    }
    // CST membrane.
    let mut bm = [[0.0; 6]; 3];
    for i in 0..3 {
        bm[0][2 * i] = nx[i];
        bm[1][2 * i + 1] = ny[i];
        bm[2][2 * i] = ny[i];
        bm[2][2 * i + 1] = nx[i];
    }
    let mut kmem = [[0.0; 6]; 6];
    add_btdb(&mut kmem, &bm, &dm, area);
    // Constant-curvature bending.
    let mut bb = [[0.0; 9]; 3];
    for i in 0..3 {
        bb[0][3 * i + 2] = nx[i];
        bb[1][3 * i + 1] = -ny[i];
        bb[2][3 * i + 2] = ny[i];
        bb[2][3 * i + 1] = -nx[i];
    }
    let mut kbend = [[0.0; 9]; 9];
    add_btdb(&mut kbend, &bb, &db, area);
    // MITC3 shear with the Lyly–Stenberg–Vihinen factor.
    let h2 = (0..3)
        .map(|i| {
            let j = (i + 1) % 3;
            (x[j] - x[i]).powi(2) + (y[j] - y[i]).powi(2)
        })
        .fold(0.0f64, f64::max);
    let alpha_h2 = TRIA_SHEAR_STABILISATION * h2;
    let stab = t * t / (t * t + alpha_h2);
    let dln_ks_dt = 3.0 / t - 2.0 * t / (t * t + alpha_h2);
    let (e_s, nu_s, own_s) = r.shear;
    let ks_coef = r.shear_ratio * (e_s / (2.0 * (1.0 + nu_s))) * t * stab;
    let ds = [[ks_coef, 0.0], [0.0, ks_coef]];
    let t12 = edge_shear3(&x, &y, 0, 1);
    let t13 = edge_shear3(&x, &y, 0, 2);
    let t23 = edge_shear3(&x, &y, 1, 2);
    let mut cvec = [0.0; 9];
    for c in 0..9 {
        cvec[c] = t13[c] - t12[c] - t23[c];
    }
    // J = [[x_r, y_r], [x_s, y_s]] with r along 1→2 and s along 1→3.
    let jm = [x[1] - x[0], y[1] - y[0], x[2] - x[0], y[2] - y[0]];
    let mut kshear = [[0.0; 9]; 9];
    for (r, s_) in [
        (1.0 / 6.0, 1.0 / 6.0),
        (2.0 / 3.0, 1.0 / 6.0),
        (1.0 / 6.0, 2.0 / 3.0),
    ] {
        let mut bs = [[0.0; 9]; 2];
        for c in 0..9 {
            let g_r = t12[c] + s_ * cvec[c];
            let g_s = t13[c] - r * cvec[c];
            (bs[0][c], bs[1][c]) = cartesian(&jm, two_a, g_r, g_s);
        }
        add_btdb(&mut kshear, &bs, &ds, area / 3.0);
    }
    let mut m_geo = [[area / 12.0; 3]; 3];
    for (i, row) in m_geo.iter_mut().enumerate() {
        row[i] = area / 6.0;
    }
    let mut parts = Parts {
        frame,
        area,
        k_m: [[0.0; 18]; 18],
        k_s: [[0.0; 18]; 18],
        dln_ks_dt,
        k_b: [[0.0; 18]; 18],
        m_geo,
        own: [true, own_s, own_b],
        rotary: [r.bending.is_some(), r.bending.is_some() && r.membrane],
    };
    if r.bending.is_some() {
        scatter_plate(&mut parts.k_b, &kbend);
        scatter_plate(&mut parts.k_s, &kshear);
    }
    if r.membrane {
        scatter_membrane(&mut parts.k_m, &kmem);
        if r.bending.is_some() {
            add_drilling(&mut parts.k_m, &nx, &ny, drill * g_mod * t * area);
        }
    }
    parts.check_finite()?;
    Ok(parts)
}

mod general;
pub use general::{
    MaterialAxis, ShellOrientation, quad4_general, quad4_general_derivative, tria3_general,
    tria3_general_derivative,
};

#[cfg(test)]
mod tests;
