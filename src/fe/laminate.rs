//! Classical lamination theory (docs/theory.md §2, shell element): the general shell law
//! [`ShellLaw`] — membrane `A`, coupling `B`, bending `D`, transverse shear `G_s`, mass per area,
//! its first and second moments — of a Nastran PCOMP/PCOMPG laminate or of a PSHELL whose parts
//! are MAT2/MAT8 materials or have a membrane–bending coupling (MID4).
//!
//! **Ply.** In its own axes (1 along the fibre, 2 across, in the plane) a ply has the plane-stress
//! reduced stiffness `Q`: MAT8 `Q11 = E1/(1 − ν12 ν21)`, `Q22 = E2/(1 − ν12 ν21)`,
//! `Q12 = ν12 E2/(1 − ν12 ν21)`, `Q66 = G12` with `ν21 = ν12 E2/E1`; MAT2 `Q = [G_ij]` as given;
//! MAT1 the isotropic `E/(1 − ν²)[[1, ν, 0], [ν, 1, 0], [0, 0, (1 − ν)/2]]`. A ply at angle `θ`
//! (from the laminate's material x axis towards y) has `Q̄ = T_εᵀ Q T_ε` with the engineering
//! strain rotation `T_ε = [[c², s², cs], [s², c², −cs], [−2cs, 2cs, c² − s²]]`, exact also for a
//! fully anisotropic MAT2. Its transverse shear moduli `diag(G1Z, G2Z)` (over `γ1z`, `γ2z`)
//! rotate as `Ḡ = Rᵀ G R`, `R = [[c, s], [−s, c]]`.
//!
//! **Laminate.** Plies stacked from the bottom surface `z = Z0` upwards along the element normal,
//! ply `k` from `z_k` to `z_k + t_k`, mid-height `z̄_k`:
//! `A = Σ Q̄_k t_k`, `B = Σ Q̄_k t_k z̄_k`, `D = Σ Q̄_k (t_k z̄_k² + t_k³/12)` (Jones, *Mechanics of
//! Composite Materials*, 1999, §4.2; the same as `∫ Q̄ (1, z, z²) dz`). The strains at height `z`
//! are `ε0 + z κ` in femu's plate convention (`u = u0 + z θy`, `v = v0 − z θx`), so the
//! resultants are `N = A ε0 + B κ`, `M = B ε0 + D κ`.
//!
//! **Transverse shear** (a deviation from Nastran, stated): `G_s = κ Σ Ḡ_k t_k` with the
//! homogeneous-plate factor `κ = 5/6` (first-order shear deformation theory, Whitney & Pagano 1970,
//! *J. Appl. Mech.* 37). Nastran derives a laminate's shear stiffness from the transverse shear
//! stress distribution that equilibrates bending in the ply stack; both agree for a homogeneous
//! section (a single ply equals PSHELL with TS/T = 5/6 exactly) and differ by a few per cent for
//! strongly heterogeneous stacks, which changes thin-laminate frequencies by `O((T/λ)²)`.
//!
//! **Mass.** `μ = Σ ρ_k t_k`, first moment `S = Σ ρ_k t_k z̄_k`, rotary inertia
//! `I = Σ ρ_k (t_k z̄_k² + t_k³/12)` about the reference plane; the kinetic energy is
//! `½ ∫ [μ (u̇0² + v̇0² + ẇ²) + 2 S (u̇0 θ̇y − v̇0 θ̇x) + I (θ̇x² + θ̇y²)] dA` (plus `I θ̇z²`, femu's
//! drilling inertia convention, see [`super::shell`]). `μ I ≥ S²` (Cauchy–Schwarz), so the mass
//! is positive semi-definite.
//!
//! **Offset** ([`ShellLaw::offset`]; Nastran ZOFFS): the reference plane at `z0` above the grid
//! plane, strains `ε_ref = ε_grid + z0 κ`, so `B' = B + z0 A`, `D' = D + 2 z0 B + z0² A`,
//! `S' = S + z0 μ`, `I' = I + 2 z0 S + z0² μ` (the parallel-axis terms; rotary inertia is about
//! the grid plane, on θx, θy and, by femu's convention, θz).

// Index loops follow the index notation of the formulas (Q, A, B, D over strain components).
#![allow(clippy::needless_range_loop)]

use super::element::ElementError;

/// The material of one ply (or of one PSHELL part), in its own axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PlyMaterial {
    /// Isotropic (MAT1).
    Isotropic {
        /// Young's modulus, Pa.
        e: f64,
        /// Poisson's ratio.
        nu: f64,
    },
    /// Orthotropic in the plane (MAT8).
    Orthotropic {
        /// Modulus along the fibre, Pa.
        e1: f64,
        /// Modulus across the fibre, Pa.
        e2: f64,
        /// Major Poisson's ratio `ν12`.
        nu12: f64,
        /// In-plane shear modulus, Pa.
        g12: f64,
        /// Transverse shear modulus in the 1–z plane, Pa.
        g1z: f64,
        /// Transverse shear modulus in the 2–z plane, Pa.
        g2z: f64,
    },
    /// Anisotropic plane stress (MAT2): `[[G11, G12, G13], [G12, G22, G23], [G13, G23, G33]]`
    /// over `(ε1, ε2, γ12)`, with the transverse shear moduli `(G1Z, G2Z)` it is given.
    Anisotropic {
        /// The plane-stress matrix, Pa.
        g: [[f64; 3]; 3],
        /// Transverse shear moduli, Pa.
        shear: [f64; 2],
    },
}

/// 3 × 3 matrix.
pub type M3 = [[f64; 3]; 3];
/// 2 × 2 matrix.
pub type M2 = [[f64; 2]; 2];

impl PlyMaterial {
    /// Checks the values: moduli positive, `Q` positive definite.
    pub fn validate(&self) -> Result<(), ElementError> {
        let bad = |field: &'static str, value: f64, hint: &'static str| {
            Err(ElementError::BadValue { field, value, hint })
        };
        let shear = self.shear();
        for v in [shear[0][0], shear[1][1]] {
            if !(v.is_finite() && v > 0.0) {
                return bad(
                    "g1z/g2z",
                    v,
                    "transverse shear moduli must be finite and > 0",
                );
            }
        }
        let q = self.q();
        let det2 = q[0][0] * q[1][1] - q[0][1] * q[1][0];
        let det3 = q[0][0] * (q[1][1] * q[2][2] - q[1][2] * q[2][1])
            - q[0][1] * (q[1][0] * q[2][2] - q[1][2] * q[2][0])
            + q[0][2] * (q[1][0] * q[2][1] - q[1][1] * q[2][0]);
        if !(q.iter().flatten().all(|v| v.is_finite()) && q[0][0] > 0.0 && det2 > 0.0 && det3 > 0.0)
        {
            return bad(
                "q",
                det3,
                "the ply's plane-stress stiffness must be positive definite (E1, E2, G12 > 0 and nu12^2 < E1/E2 for MAT8; a positive definite G for MAT2)",
            );
        }
        Ok(())
    }

    /// Plane-stress reduced stiffness `Q` in the material's own axes.
    pub fn q(&self) -> M3 {
        match *self {
            PlyMaterial::Isotropic { e, nu } => {
                let c = e / (1.0 - nu * nu);
                [
                    [c, c * nu, 0.0],
                    [c * nu, c, 0.0],
                    [0.0, 0.0, c * 0.5 * (1.0 - nu)],
                ]
            }
            PlyMaterial::Orthotropic {
                e1, e2, nu12, g12, ..
            } => {
                let nu21 = nu12 * e2 / e1;
                let den = 1.0 - nu12 * nu21;
                [
                    [e1 / den, nu12 * e2 / den, 0.0],
                    [nu12 * e2 / den, e2 / den, 0.0],
                    [0.0, 0.0, g12],
                ]
            }
            PlyMaterial::Anisotropic { g, .. } => g,
        }
    }

    /// Transverse shear moduli `diag(G1Z, G2Z)` in the material's own axes.
    pub fn shear(&self) -> M2 {
        match *self {
            PlyMaterial::Isotropic { e, nu } => {
                let g = e / (2.0 * (1.0 + nu));
                [[g, 0.0], [0.0, g]]
            }
            PlyMaterial::Orthotropic { g1z, g2z, .. } => [[g1z, 0.0], [0.0, g2z]],
            PlyMaterial::Anisotropic { shear, .. } => [[shear[0], 0.0], [0.0, shear[1]]],
        }
    }
}

/// `Q̄ = T_εᵀ Q T_ε`: a plane-stress stiffness given in axes at angle `theta` (rad) from x,
/// expressed in the x–y axes.
pub fn rotate_plane(q: &M3, theta: f64) -> M3 {
    let (s, c) = theta.sin_cos();
    let t = [
        [c * c, s * s, c * s],
        [s * s, c * c, -c * s],
        [-2.0 * c * s, 2.0 * c * s, c * c - s * s],
    ];
    let mut qt = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            qt[i][j] = (0..3).map(|k| q[i][k] * t[k][j]).sum();
        }
    }
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            out[i][j] = (0..3).map(|k| t[k][i] * qt[k][j]).sum();
        }
    }
    // Exactly symmetric.
    for i in 0..3 {
        for j in i + 1..3 {
            let v = 0.5 * (out[i][j] + out[j][i]);
            out[i][j] = v;
            out[j][i] = v;
        }
    }
    out
}

/// `Ḡ = Rᵀ G R`: transverse shear moduli given in axes at angle `theta` (rad) from x, over
/// `(γxz, γyz)`.
pub fn rotate_shear(g: &M2, theta: f64) -> M2 {
    let (s, c) = theta.sin_cos();
    let r = [[c, s], [-s, c]];
    let mut out = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            let mut v = 0.0;
            for a in 0..2 {
                for b in 0..2 {
                    v += r[a][i] * g[a][b] * r[b][j];
                }
            }
            out[i][j] = v;
        }
    }
    let v = 0.5 * (out[0][1] + out[1][0]);
    out[0][1] = v;
    out[1][0] = v;
    out
}

/// One ply of a laminate, bottom to top.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ply {
    /// Its material.
    pub material: PlyMaterial,
    /// Thickness, m (> 0).
    pub thickness: f64,
    /// Fibre angle from the laminate's material x axis, rad.
    pub theta: f64,
    /// Density, kg/m³ (≥ 0).
    pub rho: f64,
}

/// The general law of a shell section in its material axes (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellLaw {
    /// Membrane stiffness `A` (N/m) over `(εx, εy, γxy)`.
    pub a: M3,
    /// Membrane–bending coupling `B` (N).
    pub b: M3,
    /// Bending stiffness `D` (N·m) over `(κx, κy, κxy)`.
    pub d: M3,
    /// Transverse shear stiffness `G_s` (N/m) over `(γxz, γyz)`.
    pub g: M2,
    /// Total thickness (m), for the tria3 shear stabilisation.
    pub thickness: f64,
    /// Structural mass per area `μ` (kg/m²).
    pub mu: f64,
    /// First moment of mass `S` about the reference plane (kg/m).
    pub first_moment: f64,
    /// Rotary inertia `I` about the reference plane (kg).
    pub inertia: f64,
    /// Non-structural mass per area (kg/m²), translational only, at the grid plane.
    pub nsm: f64,
    /// Membrane (and drilling) stiffness present.
    pub membrane: bool,
    /// Bending and transverse shear stiffness (and rotary inertia) present.
    pub bending: bool,
}

/// `x + f y` for 3 × 3 matrices.
fn axpy3(x: &M3, f: f64, y: &M3) -> M3 {
    let mut o = *x;
    for i in 0..3 {
        for j in 0..3 {
            o[i][j] += f * y[i][j];
        }
    }
    o
}

impl ShellLaw {
    /// A law with every stiffness and mass zero (a derivative's start).
    pub fn zero(membrane: bool, bending: bool) -> ShellLaw {
        ShellLaw {
            a: [[0.0; 3]; 3],
            b: [[0.0; 3]; 3],
            d: [[0.0; 3]; 3],
            g: [[0.0; 2]; 2],
            thickness: 0.0,
            mu: 0.0,
            first_moment: 0.0,
            inertia: 0.0,
            nsm: 0.0,
            membrane,
            bending,
        }
    }

    /// The law with its material axes at angle `phi` (rad) from the element's x axis, in the
    /// element's axes. Linear in the law.
    pub fn rotated(&self, phi: f64) -> ShellLaw {
        if phi == 0.0 {
            return *self;
        }
        ShellLaw {
            a: rotate_plane(&self.a, phi),
            b: rotate_plane(&self.b, phi),
            d: rotate_plane(&self.d, phi),
            g: rotate_shear(&self.g, phi),
            ..*self
        }
    }

    /// The law about the grid plane of a section whose reference plane lies `z0` above it
    /// (ZOFFS): `B' = B + z0 A`, `D' = D + 2 z0 B + z0² A`, `S' = S + z0 μ`,
    /// `I' = I + 2 z0 S + z0² μ`. Linear in the law.
    pub fn offset(&self, z0: f64) -> ShellLaw {
        if z0 == 0.0 {
            return *self;
        }
        ShellLaw {
            b: axpy3(&self.b, z0, &self.a),
            d: axpy3(&axpy3(&self.d, 2.0 * z0, &self.b), z0 * z0, &self.a),
            first_moment: self.first_moment + z0 * self.mu,
            inertia: self.inertia + 2.0 * z0 * self.first_moment + z0 * z0 * self.mu,
            ..*self
        }
    }

    /// The in-plane shear rigidity invariant `(A11 + A22 − 2 A12 + 4 A33)/8` (the mean of `A33`
    /// over all in-plane rotations; `G t` for an isotropic shell), which scales the drilling
    /// penalty so that it does not depend on the material axes.
    pub fn drilling_rigidity(&self) -> f64 {
        let a = &self.a;
        (a[0][0] + a[1][1] - 2.0 * a[0][1] + 4.0 * a[2][2]) / 8.0
    }

    /// Checks the values are finite, the parts present are positive definite where they must
    /// be, and the mass is non-negative.
    pub fn validate(&self) -> Result<(), ElementError> {
        let finite = self
            .a
            .iter()
            .chain(&self.b)
            .chain(&self.d)
            .flatten()
            .chain(self.g.iter().flatten())
            .chain([
                &self.thickness,
                &self.mu,
                &self.first_moment,
                &self.inertia,
                &self.nsm,
            ])
            .all(|v| v.is_finite());
        if !finite {
            return Err(ElementError::BadValue {
                field: "shell law",
                value: f64::NAN,
                hint: "every stiffness and mass of the section must be finite",
            });
        }
        if !self.membrane && !self.bending {
            return Err(ElementError::BadValue {
                field: "layers",
                value: 0.0,
                hint: "a shell needs membrane or bending stiffness",
            });
        }
        if !(self.thickness > 0.0) {
            return Err(ElementError::BadValue {
                field: "thickness",
                value: self.thickness,
                hint: "must be > 0",
            });
        }
        if self.mu < 0.0 || self.nsm < 0.0 || self.inertia < 0.0 {
            return Err(ElementError::BadValue {
                field: "mass",
                value: self.mu.min(self.nsm).min(self.inertia),
                hint: "mass per area, non-structural mass and rotary inertia must be >= 0",
            });
        }
        Ok(())
    }
}

/// Shear correction factor of the laminate's transverse shear (see the module doc).
pub const LAMINATE_SHEAR_CORRECTION: f64 = 5.0 / 6.0;

/// The law of plies stacked upwards from `z0` (the bottom surface relative to the reference
/// plane), with non-structural mass `nsm`.
pub fn laminate(plies: &[Ply], z0: f64, nsm: f64) -> Result<ShellLaw, ElementError> {
    if plies.is_empty() {
        return Err(ElementError::BadValue {
            field: "plies",
            value: 0.0,
            hint: "a laminate needs at least one ply",
        });
    }
    let mut law = ShellLaw::zero(true, true);
    law.nsm = nsm;
    let mut z = z0;
    for p in plies {
        p.material.validate()?;
        if !(p.thickness.is_finite() && p.thickness > 0.0) {
            return Err(ElementError::BadValue {
                field: "ply thickness",
                value: p.thickness,
                hint: "must be finite and > 0",
            });
        }
        if !(p.rho.is_finite() && p.rho >= 0.0 && p.theta.is_finite()) {
            return Err(ElementError::BadValue {
                field: "ply density/angle",
                value: p.rho,
                hint: "density must be finite and >= 0, the angle finite",
            });
        }
        let t = p.thickness;
        let zbar = z + 0.5 * t;
        let q = rotate_plane(&p.material.q(), p.theta);
        let g = rotate_shear(&p.material.shear(), p.theta);
        law.a = axpy3(&law.a, t, &q);
        law.b = axpy3(&law.b, t * zbar, &q);
        law.d = axpy3(&law.d, t * zbar * zbar + t * t * t / 12.0, &q);
        for i in 0..2 {
            for j in 0..2 {
                law.g[i][j] += LAMINATE_SHEAR_CORRECTION * t * g[i][j];
            }
        }
        law.thickness += t;
        law.mu += p.rho * t;
        law.first_moment += p.rho * t * zbar;
        law.inertia += p.rho * (t * zbar * zbar + t * t * t / 12.0);
        z += t;
    }
    Ok(law)
}

// ---------------------------------------------------------------------------------------------
// From the model.

use crate::model::laminates::{LaminateTerms, ShellMaterial};
use crate::model::{Model, ShellProperty};

/// Whether a shell property needs the general law: a laminate, a membrane–bending coupling
/// (MID4) or a MAT2/MAT8 part.
pub fn is_general(model: &Model, p: &ShellProperty) -> bool {
    p.laminate.is_some()
        || p.coupling_material.is_some()
        || p.material_ids()
            .iter()
            .any(|m| model.shell_materials.contains_key(m))
}

/// The kernel material and density of material `mid` (MAT1, MAT8 or MAT2).
fn ply_material(model: &Model, mid: u64) -> Result<(PlyMaterial, f64), ElementError> {
    if let Some(m) = model.materials.get(&mid) {
        return Ok((PlyMaterial::Isotropic { e: m.e, nu: m.nu }, m.rho));
    }
    match model.shell_materials.get(&mid) {
        Some(&ShellMaterial::Orthotropic {
            e1,
            e2,
            nu12,
            g12,
            g1z,
            g2z,
            rho,
        }) => Ok((
            PlyMaterial::Orthotropic {
                e1,
                e2,
                nu12,
                g12,
                g1z,
                g2z,
            },
            rho,
        )),
        Some(&ShellMaterial::Anisotropic { g, rho }) => Ok((
            PlyMaterial::Anisotropic {
                g: [[g[0], g[1], g[2]], [g[1], g[3], g[4]], [g[2], g[4], g[5]]],
                shear: [g[5], g[5]],
            },
            rho,
        )),
        None => Err(ElementError::BadValue {
            field: "material",
            value: mid as f64,
            hint: "the shell names a material that is neither MAT1, MAT2 nor MAT8",
        }),
    }
}

/// The modulus a `youngs_modulus` parameter of material `mid` reads (MAT1 `E`, MAT8 `E1`, MAT2
/// `G11`); every modulus of the material is proportional to it.
pub fn material_modulus(model: &Model, mid: u64) -> Option<f64> {
    model
        .materials
        .get(&mid)
        .map(|m| m.e)
        .or_else(|| model.shell_materials.get(&mid).map(|m| m.modulus()))
}

/// What a law is formed of: the section's value, or the part proportional to one material's
/// moduli (over that modulus) or density (per unit density), or to the non-structural mass.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Part {
    Value,
    Modulus(u64),
    Density(u64),
    Nsm,
}

fn scaled3(q: &M3, f: f64) -> M3 {
    q.map(|r| r.map(|v| v * f))
}

fn scaled2(g: &M2, f: f64) -> M2 {
    g.map(|r| r.map(|v| v * f))
}

/// The law of shell property `p` (or one part of it, see [`Part`]).
fn law_of(model: &Model, p: &ShellProperty, part: Part) -> Result<ShellLaw, ElementError> {
    let stiff = |mid: u64| -> Result<f64, ElementError> {
        Ok(match part {
            Part::Value => 1.0,
            Part::Modulus(own) if own == mid => {
                1.0 / material_modulus(model, mid).unwrap_or(f64::NAN)
            }
            _ => 0.0,
        })
    };
    let dens = |mid: u64, rho: f64| match part {
        Part::Value => rho,
        Part::Density(own) if own == mid => 1.0,
        _ => 0.0,
    };
    let nsm = match part {
        Part::Value => p.nsm,
        Part::Nsm => 1.0,
        _ => 0.0,
    };
    if let Some(lam) = &p.laminate {
        let stack = lam.stack();
        let mut plies = Vec::with_capacity(stack.len());
        let mut weights = Vec::with_capacity(stack.len());
        for ply in &stack {
            let (material, rho) = ply_material(model, ply.material)?;
            plies.push(Ply {
                material,
                thickness: ply.thickness,
                theta: ply.theta_deg.to_radians(),
                rho: dens(ply.material, rho),
            });
            weights.push(stiff(ply.material)?);
        }
        if lam.terms == LaminateTerms::SmearedCore {
            return sandwich(&plies, &weights, nsm);
        }
        let law = laminate_weighted(&plies, &weights, lam.bottom(), nsm)?;
        return Ok(with_terms(law, lam.terms, lam.bottom()));
    }
    let t = p.thickness;
    let mut law = ShellLaw::zero(p.membrane, p.bending);
    law.thickness = t;
    law.nsm = nsm;
    if p.membrane {
        let (m, _) = ply_material(model, p.material)?;
        m.validate()?;
        law.a = scaled3(&m.q(), t * stiff(p.material)?);
    }
    if p.bending {
        let mid2 = p.bending_mid();
        let (m, _) = ply_material(model, mid2)?;
        m.validate()?;
        law.d = scaled3(&m.q(), p.bending_ratio * t * t * t / 12.0 * stiff(mid2)?);
        let mid3 = p.shear_mid();
        let (m, _) = ply_material(model, mid3)?;
        m.validate()?;
        law.g = scaled2(&m.shear(), p.shear_ratio * t * stiff(mid3)?);
    }
    if let Some(mid4) = p.coupling_material {
        let (m, _) = ply_material(model, mid4)?;
        law.b = scaled3(&m.q(), t * t * stiff(mid4)?);
    }
    let (_, rho) = ply_material(model, p.material)?;
    let rho = dens(p.material, rho);
    law.mu = rho * t;
    law.inertia = rho * t * t * t / 12.0;
    Ok(law)
}

/// The terms of a laminate's law that its LAM option keeps ([`LaminateTerms`]), for a stack
/// whose bottom lies at `z0`. Linear in the law, so it applies to derivatives alike.
fn with_terms(mut law: ShellLaw, terms: LaminateTerms, z0: f64) -> ShellLaw {
    const ZERO3: M3 = [[0.0; 3]; 3];
    match terms {
        LaminateTerms::All | LaminateTerms::SmearedCore => {}
        LaminateTerms::Membrane => {
            (law.b, law.d, law.g, law.bending) = (ZERO3, ZERO3, [[0.0; 2]; 2], false);
        }
        LaminateTerms::Bending => {
            (law.a, law.b, law.membrane) = (ZERO3, ZERO3, false);
        }
        LaminateTerms::Smeared => {
            // The smeared section about its middle surface (B = 0, D = A T²/12, density
            // uniform through the thickness), then moved to the reference plane.
            let t = law.thickness;
            let middle = ShellLaw {
                b: ZERO3,
                d: scaled3(&law.a, t * t / 12.0),
                first_moment: 0.0,
                inertia: law.mu * t * t / 12.0,
                ..law
            };
            law = middle.offset(z0 + 0.5 * t);
        }
    }
    law
}

/// LAM = SMCORE (QRG PCOMP): the last ply is the core, the plies before it the face sheets,
/// smeared (their stacking ignored) and split in half, one half below the core and one above,
/// about the core's middle surface, which is the reference plane. With the faces' smeared
/// membrane stiffness `A_f` and mass `μ_f` over their total thickness `t_f`, and `h = t_c/2`:
/// `A = A_f + A_c`, `B = 0`, `D = D_c + (A_f/t_f) I_f`, `I = I_c + (μ_f/t_f) I_f`, where
/// `I_f = ⅔((h + t_f/2)³ − h³)` is `∫z²` over both faces. The transverse shear is the plies'
/// sum, as for any laminate. Weights as in [`laminate_weighted`].
fn sandwich(plies: &[Ply], weights: &[f64], nsm: f64) -> Result<ShellLaw, ElementError> {
    let n = plies.len();
    if n < 2 {
        return Err(ElementError::Degenerate(
            "LAM = SMCORE needs at least one face sheet ply before the core ply".into(),
        ));
    }
    let (faces, core) = plies.split_at(n - 1);
    let (face_weights, core_weight) = weights.split_at(n - 1);
    let tf: f64 = faces.iter().map(|p| p.thickness).sum();
    let tc = core[0].thickness;
    let face = laminate_weighted(faces, face_weights, -0.5 * tf, 0.0)?;
    let mut law = laminate_weighted(core, core_weight, -0.5 * tc, nsm)?;
    let h = 0.5 * tc;
    let i_faces = 2.0 / 3.0 * ((h + 0.5 * tf).powi(3) - h.powi(3));
    law.a = axpy3(&law.a, 1.0, &face.a);
    law.d = axpy3(&law.d, i_faces / tf, &face.a);
    for (gi, fi) in law.g.iter_mut().zip(&face.g) {
        for (g, f) in gi.iter_mut().zip(fi) {
            *g += f;
        }
    }
    law.thickness = tf + tc;
    law.inertia += face.mu / tf * i_faces;
    law.mu += face.mu;
    Ok(law)
}

/// [`laminate`] with ply `k`'s stiffness times `weights[k]` (the mass as the plies' densities
/// give it).
fn laminate_weighted(
    plies: &[Ply],
    weights: &[f64],
    z0: f64,
    nsm: f64,
) -> Result<ShellLaw, ElementError> {
    if weights.iter().all(|w| *w == 1.0) {
        return laminate(plies, z0, nsm);
    }
    let mut law = laminate(plies, z0, nsm)?;
    let mut z = z0;
    (law.a, law.b, law.d, law.g) = ([[0.0; 3]; 3], [[0.0; 3]; 3], [[0.0; 3]; 3], [[0.0; 2]; 2]);
    for (p, w) in plies.iter().zip(weights) {
        let t = p.thickness;
        let zbar = z + 0.5 * t;
        z += t;
        if *w == 0.0 {
            continue;
        }
        let q = scaled3(&rotate_plane(&p.material.q(), p.theta), *w);
        let g = rotate_shear(&p.material.shear(), p.theta);
        law.a = axpy3(&law.a, t, &q);
        law.b = axpy3(&law.b, t * zbar, &q);
        law.d = axpy3(&law.d, t * zbar * zbar + t * t * t / 12.0, &q);
        for i in 0..2 {
            for j in 0..2 {
                law.g[i][j] += LAMINATE_SHEAR_CORRECTION * t * g[i][j] * w;
            }
        }
    }
    Ok(law)
}

/// The general law of shell property `p` in its material axes.
pub fn property_law(model: &Model, p: &ShellProperty) -> Result<ShellLaw, ElementError> {
    law_of(model, p, Part::Value)
}

/// `∂law/∂φ` of shell property `p` for one parameter, exact: the thickness by homogeneity (`A`,
/// `G_s`, `μ` ∝ T, `B`, `S` ∝ T², `D`, `I` ∝ T³, the plies and Z0 scaling with T), the modulus of
/// `p.material` (every modulus of it in proportion), its density, the non-structural mass.
pub fn property_law_derivative(
    model: &Model,
    p: &ShellProperty,
    parameter: super::shell::ShellParameter,
) -> Result<ShellLaw, ElementError> {
    use super::shell::ShellParameter as P;
    let mut d = match parameter {
        P::Thickness => {
            let l = law_of(model, p, Part::Value)?;
            let t = l.thickness;
            ShellLaw {
                a: scaled3(&l.a, 1.0 / t),
                b: scaled3(&l.b, 2.0 / t),
                d: scaled3(&l.d, 3.0 / t),
                g: scaled2(&l.g, 1.0 / t),
                thickness: 1.0,
                mu: l.mu / t,
                first_moment: 2.0 * l.first_moment / t,
                inertia: 3.0 * l.inertia / t,
                nsm: 0.0,
                ..l
            }
        }
        P::YoungsModulus => law_of(model, p, Part::Modulus(p.material))?,
        P::Density => law_of(model, p, Part::Density(p.material))?,
        P::NonStructuralMass => law_of(model, p, Part::Nsm)?,
    };
    if parameter != P::Thickness {
        d.thickness = 0.0;
    }
    Ok(d)
}

/// The kernel orientation of element `id` (its THETA/MCID and ZOFFS; none by default).
pub fn element_orientation(model: &Model, id: u64) -> super::shell::ShellOrientation {
    use super::shell::{MaterialAxis, ShellOrientation};
    match model.shell_placements.get(&id) {
        None => ShellOrientation::default(),
        Some(pl) => ShellOrientation {
            axis: match pl.axis {
                Some(v) => MaterialAxis::Direction(v),
                None => MaterialAxis::Theta(pl.theta_deg.to_radians()),
            },
            offset: pl.offset,
        },
    }
}

/// Whether shell element `id` of property `p` is formed with the general law: a general
/// property or an offset (a THETA/MCID alone leaves an isotropic PSHELL unchanged, so it keeps
/// the homogeneous kernel and its bits).
pub fn uses_general(model: &Model, id: Option<u64>, p: &ShellProperty) -> bool {
    is_general(model, p)
        || id
            .and_then(|id| model.shell_placements.get(&id))
            .is_some_and(|pl| pl.offset != 0.0)
}

/// Matrices of shell element `id` (`nodes`, property `pid`) with the general law.
pub fn general_shell_matrices(
    model: &Model,
    id: Option<u64>,
    xyz: &[[f64; 3]],
    pid: u64,
    mass: super::element::MassKind,
) -> Result<super::element::ElementMatrices, ElementError> {
    let p = &model.shell_properties[&pid];
    let law = property_law(model, p)?;
    let o = id.map_or_else(Default::default, |id| element_orientation(model, id));
    match xyz.len() {
        4 => super::shell::quad4_general(&[xyz[0], xyz[1], xyz[2], xyz[3]], &law, &o, mass),
        _ => super::shell::tria3_general(&[xyz[0], xyz[1], xyz[2]], &law, &o, mass),
    }
}

/// The exact derivative of [`general_shell_matrices`] for one shell parameter.
pub fn general_shell_derivative(
    model: &Model,
    id: u64,
    xyz: &[[f64; 3]],
    pid: u64,
    mass: super::element::MassKind,
    parameter: super::shell::ShellParameter,
) -> Result<super::element::ElementDerivative, ElementError> {
    let p = &model.shell_properties[&pid];
    let law = property_law(model, p)?;
    let dlaw = property_law_derivative(model, p, parameter)?;
    let o = element_orientation(model, id);
    match xyz.len() {
        4 => super::shell::quad4_general_derivative(
            &[xyz[0], xyz[1], xyz[2], xyz[3]],
            &law,
            &dlaw,
            &o,
            mass,
        ),
        _ => {
            super::shell::tria3_general_derivative(&[xyz[0], xyz[1], xyz[2]], &law, &dlaw, &o, mass)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const E: f64 = 70e9;
    const NU: f64 = 0.3;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    fn carbon() -> PlyMaterial {
        PlyMaterial::Orthotropic {
            e1: 140e9,
            e2: 10e9,
            nu12: 0.3,
            g12: 5e9,
            g1z: 5e9,
            g2z: 3.5e9,
        }
    }

    #[test]
    fn isotropic_single_ply_is_the_homogeneous_plate() {
        let t = 0.004;
        let iso = PlyMaterial::Orthotropic {
            e1: E,
            e2: E,
            nu12: NU,
            g12: E / (2.0 * (1.0 + NU)),
            g1z: E / (2.0 * (1.0 + NU)),
            g2z: E / (2.0 * (1.0 + NU)),
        };
        let ply = Ply {
            material: iso,
            thickness: t,
            theta: 0.7,
            rho: 2700.0,
        };
        let law = laminate(&[ply], -t / 2.0, 0.5).unwrap();
        let c = E / (1.0 - NU * NU);
        // Rotation leaves an isotropic Q unchanged (to round-off, 1e-12 relative).
        let want = [
            [c, c * NU, 0.0],
            [c * NU, c, 0.0],
            [0.0, 0.0, c * (1.0 - NU) / 2.0],
        ];
        for i in 0..3 {
            for j in 0..3 {
                assert!((law.a[i][j] - want[i][j] * t).abs() <= 1e-12 * c * t);
                assert!(law.b[i][j].abs() <= 1e-12 * c * t * t);
                assert!(
                    (law.d[i][j] - want[i][j] * t * t * t / 12.0).abs() <= 1e-12 * c * t.powi(3)
                );
            }
        }
        let g = E / (2.0 * (1.0 + NU));
        assert!(close(law.g[0][0], 5.0 / 6.0 * g * t, 1e-12));
        assert!(law.g[0][1].abs() <= 1e-12 * g * t);
        assert!(close(law.mu, 2700.0 * t, 1e-14));
        assert!(law.first_moment.abs() <= 1e-15);
        assert!(close(law.inertia, 2700.0 * t.powi(3) / 12.0, 1e-12));
        assert!(close(law.drilling_rigidity(), g * t, 1e-12));
    }

    /// A carbon ply (1,600 kg/m³) of thickness `t` at `deg` degrees.
    fn carbon_ply(deg: f64, t: f64) -> Ply {
        Ply {
            material: carbon(),
            thickness: t,
            theta: deg.to_radians(),
            rho: 1600.0,
        }
    }

    /// Hand values for the carbon ply: ν21 = 0.3·10/140, 1 − ν12 ν21 = 0.993571…,
    /// Q11 = 140e9/0.993571, Q22 = 10e9/0.993571, Q12 = 3e9/0.993571, Q66 = 5e9.
    fn q_hand() -> (f64, f64, f64, f64) {
        let den = 1.0 - 0.3 * 0.3 * 10.0 / 140.0;
        (140e9 / den, 10e9 / den, 3e9 / den, 5e9)
    }

    #[test]
    fn symmetric_cross_ply_has_no_coupling_and_the_hand_values() {
        // [0/90]s, plies 0.25 mm: A = 2t(Q11 + Q22) on 11 and 22, D from the z-integrals.
        let t = 0.25e-3;
        let ply = |deg: f64| carbon_ply(deg, t);
        let plies = [ply(0.0), ply(90.0), ply(90.0), ply(0.0)];
        let law = laminate(&plies, -2.0 * t, 0.0).unwrap();
        let (q11, q22, q12, q66) = q_hand();
        assert!(close(law.a[0][0], 2.0 * t * (q11 + q22), 1e-12));
        assert!(close(law.a[1][1], 2.0 * t * (q11 + q22), 1e-12));
        assert!(close(law.a[0][1], 4.0 * t * q12, 1e-12));
        assert!(close(law.a[2][2], 4.0 * t * q66, 1e-12));
        assert!(law.a[0][2].abs() <= 1e-9 * q11 * t);
        for row in &law.b {
            for v in row {
                assert!(v.abs() <= 1e-12 * q11 * t * t, "B = {:?}", law.b);
            }
        }
        // Outer plies from t to 2t: ∫z² = (8 − 1)t³/3 each side; inner from 0 to t: t³/3 each.
        let outer = 2.0 * 7.0 * t.powi(3) / 3.0;
        let inner = 2.0 * t.powi(3) / 3.0;
        assert!(close(law.d[0][0], q11 * outer + q22 * inner, 1e-12));
        assert!(close(law.d[1][1], q22 * outer + q11 * inner, 1e-12));
        assert!(close(law.d[0][1], q12 * (outer + inner), 1e-12));
        assert!(close(law.d[2][2], q66 * (outer + inner), 1e-12));
        // Shear: 5/6 Σ t Ḡ: each of 1z/2z appears in two plies along x and two along y.
        assert!(close(
            law.g[0][0],
            5.0 / 6.0 * 2.0 * t * (5e9 + 3.5e9),
            1e-12
        ));
        assert!(close(law.g[1][1], law.g[0][0], 1e-12));
    }

    /// LAM = MEM, BEND, SMEAR on the unsymmetric [0/90] of two 0.5 mm carbon plies: MEM keeps
    /// the stack's `A` and nothing of bending; BEND its `D` and transverse shear and no
    /// membrane; SMEAR ignores the sequence, `B = 0` and `D = A T²/12` — for this cross-ply
    /// `D11 = (Q11 + Q22) t T²/12` by hand, where the stacked `D11` is also `(Q11 + Q22) T³/24`
    /// (the same, the plies being of equal thickness) but `B11 = (Q22 − Q11) t²/2 ≠ 0` — and,
    /// the stack moved up by `e` (Z0 = −T/2 + e), `B = e A` as for an offset shell.
    #[test]
    fn lam_options_keep_their_terms() {
        let t = 0.5e-3;
        let ply = |deg: f64| carbon_ply(deg, t);
        let plies = [ply(0.0), ply(90.0)];
        let full = laminate(&plies, -t, 0.0).unwrap();
        let (q11, q22, _, _) = q_hand();
        let membrane = with_terms(full, LaminateTerms::Membrane, -t);
        assert_eq!(membrane.a, full.a);
        assert!(!membrane.bending && membrane.membrane);
        assert!(membrane.b == [[0.0; 3]; 3] && membrane.d == [[0.0; 3]; 3]);
        assert!(membrane.g == [[0.0; 2]; 2]);
        assert_eq!(membrane.mu, full.mu);
        let bending = with_terms(full, LaminateTerms::Bending, -t);
        assert!(bending.bending && !bending.membrane);
        assert_eq!((bending.d, bending.g), (full.d, full.g));
        assert!(bending.a == [[0.0; 3]; 3] && bending.b == [[0.0; 3]; 3]);
        let smeared = with_terms(full, LaminateTerms::Smeared, -t);
        let big_t = 2.0 * t;
        assert_eq!(smeared.a, full.a);
        assert!(smeared.b.iter().flatten().all(|v| *v == 0.0));
        assert!(close(
            smeared.d[0][0],
            (q11 + q22) * t * big_t * big_t / 12.0,
            1e-12
        ));
        assert!(close(smeared.d[1][1], smeared.d[0][0], 1e-12));
        assert!(close(smeared.inertia, 1600.0 * big_t.powi(3) / 12.0, 1e-12));
        let e = 0.2e-3;
        let raised = laminate(&plies, -t + e, 0.0).unwrap();
        let moved = with_terms(raised, LaminateTerms::Smeared, -t + e);
        assert!(close(moved.b[0][0], e * full.a[0][0], 1e-12));
        assert!(close(
            moved.d[0][0],
            smeared.d[0][0] + e * e * full.a[0][0],
            1e-12
        ));
        assert!(close(moved.first_moment, e * full.mu, 1e-12));
    }

    #[test]
    fn unsymmetric_cross_ply_has_the_textbook_coupling() {
        // [0/90] of two plies of t about the mid-plane: B11 = (Q22 − Q11) t²/2 = −B22
        // (Jones 1999, §4.3.2: B11 = −B22 = (Q11 − Q22)(−t²/2)), the other entries zero.
        let t = 0.5e-3;
        let ply = |deg: f64| carbon_ply(deg, t);
        let law = laminate(&[ply(0.0), ply(90.0)], -t, 0.0).unwrap();
        let (q11, q22, _, _) = q_hand();
        let b11 = (q22 - q11) * t * t / 2.0;
        assert!(close(law.b[0][0], b11, 1e-12), "{} vs {b11}", law.b[0][0]);
        assert!(close(law.b[1][1], -b11, 1e-12));
        for (i, j) in [(0, 1), (0, 2), (1, 2), (2, 2)] {
            assert!(
                law.b[i][j].abs() <= 1e-9 * b11.abs(),
                "B{i}{j} = {}",
                law.b[i][j]
            );
        }
        // Mass moments: symmetric density, so S = 0.
        assert!(law.first_moment.abs() <= 1e-15);
    }

    #[test]
    fn rotating_a_ply_by_90_degrees_swaps_e1_and_e2() {
        let turned = rotate_plane(&carbon().q(), std::f64::consts::FRAC_PI_2);
        let swapped = PlyMaterial::Orthotropic {
            e1: 10e9,
            e2: 140e9,
            nu12: 0.3 * 10.0 / 140.0,
            g12: 5e9,
            g1z: 3.5e9,
            g2z: 5e9,
        };
        let q = swapped.q();
        for i in 0..3 {
            for j in 0..3 {
                assert!((turned[i][j] - q[i][j]).abs() <= 1e-12 * 140e9, "{i}{j}");
            }
        }
        let gs = rotate_shear(&carbon().shear(), std::f64::consts::FRAC_PI_2);
        let gw = swapped.shear();
        for i in 0..2 {
            for j in 0..2 {
                assert!((gs[i][j] - gw[i][j]).abs() <= 1e-12 * 5e9);
            }
        }
    }

    #[test]
    fn rotation_matches_the_textbook_q_bar_at_45_degrees() {
        // Jones (1999) eq. 2.85 at θ = 45°: c⁴ = s⁴ = c²s² = 1/4.
        let (q11, q22, q12, q66) = q_hand();
        let r = rotate_plane(&carbon().q(), std::f64::consts::FRAC_PI_4);
        let qb11 = 0.25 * (q11 + 2.0 * (q12 + 2.0 * q66) + q22);
        let qb12 = 0.25 * (q11 + q22 - 4.0 * q66) + 0.5 * q12;
        let qb16 = 0.25 * (q11 - q12 - 2.0 * q66) - 0.25 * (q22 - q12 - 2.0 * q66);
        let qb66 = 0.25 * (q11 + q22 - 2.0 * q12 - 2.0 * q66) + 0.5 * q66;
        assert!(close(r[0][0], qb11, 1e-12));
        assert!(close(r[0][1], qb12, 1e-12));
        assert!(close(r[0][2], qb16, 1e-12));
        assert!(close(r[2][2], qb66, 1e-12));
    }

    #[test]
    fn offset_equals_moving_the_stack() {
        let t = 0.3e-3;
        let plies: Vec<Ply> = [0.0, 45.0, -45.0, 90.0, 30.0]
            .iter()
            .map(|d: &f64| Ply {
                material: carbon(),
                thickness: t,
                theta: d.to_radians(),
                rho: 1500.0 + *d,
            })
            .collect();
        let z0 = 0.7e-3;
        let a = laminate(&plies, -1.0e-3, 0.0).unwrap().offset(z0);
        let b = laminate(&plies, -1.0e-3 + z0, 0.0).unwrap();
        let scale = 140e9 * 1.5e-3;
        for i in 0..3 {
            for j in 0..3 {
                assert!((a.a[i][j] - b.a[i][j]).abs() <= 1e-12 * scale);
                assert!((a.b[i][j] - b.b[i][j]).abs() <= 1e-12 * scale * 1e-3);
                assert!((a.d[i][j] - b.d[i][j]).abs() <= 1e-12 * scale * 1e-6);
            }
        }
        assert!((a.first_moment - b.first_moment).abs() <= 1e-12 * 1500.0 * 1.5e-6);
        assert!((a.inertia - b.inertia).abs() <= 1e-12 * 1500.0 * 1.5e-9);
    }

    #[test]
    fn bad_plies_are_errors() {
        assert!(laminate(&[], 0.0, 0.0).is_err());
        let mut p = Ply {
            material: carbon(),
            thickness: 0.0,
            theta: 0.0,
            rho: 1.0,
        };
        assert!(laminate(&[p], 0.0, 0.0).is_err());
        p.thickness = 1e-3;
        p.material = PlyMaterial::Orthotropic {
            e1: 1e9,
            e2: 100e9,
            nu12: 0.5,
            g12: 1e9,
            g1z: 1e9,
            g2z: 1e9,
        };
        let e = laminate(&[p], 0.0, 0.0).unwrap_err().to_string();
        assert!(e.contains("positive definite"), "{e}");
    }
}
