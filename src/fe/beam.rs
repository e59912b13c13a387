//! Two-node 3D Timoshenko beam (Nastran CBAR-like) with exact parameter derivatives.
//!
//! **Frame.** Local `x` runs from node 1 to node 2. The orientation vector `v` fixes the local
//! `x–y` plane as on Nastran's CBAR/CBEAM: `z = x × v / |x × v|`, `y = z × x`. With `R` the
//! rotation whose rows are the local axes in the basic system and `T = diag(R, R, R, R)`, the
//! element matrices in the basic system are `K = Tᵀ K_ℓ T`, `M = Tᵀ M_ℓ T` (DOFs node-major,
//! `ux uy uz rx ry rz`, see [`super::element`]).
//!
//! **Stiffness** (Przemieniecki 1968, *Theory of Matrix Structural Analysis*, §5.6): axial `EA/L`,
//! Saint-Venant torsion `GJ/L` (no warping), and in each bending plane the closed-form
//! shear-deformable matrix
//! `EI/((1+Φ)L³) · [[12, 6L, −12, 6L], [6L, (4+Φ)L², −6L, (2−Φ)L²], [−12, −6L, 12, −6L],
//! [6L, (2−Φ)L², −6L, (4+Φ)L²]]` with `Φ_y = 12 E I_z / (κ_y G A L²)` in the `x–y` plane (DOFs
//! `uy, rz`) and `Φ_z = 12 E I_y / (κ_z G A L²)` in the `x–z` plane (DOFs `uz, ry`; `ry` enters with
//! the opposite sign). It is built from the homogeneous solution of Timoshenko's equations
//! (cubic `w`, quadratic `θ`, constant shear), so it is exact for end loads; `Φ → 0` gives the
//! Euler–Bernoulli matrix. `G = E / (2(1+ν))`, so with `ν` fixed `K` is exactly linear in `E`.
//!
//! **Consistent mass**: translational inertia of `m̄ = ρA + nsm` and rotary inertia `ρI`, both
//! integrated with the same Φ-dependent interpolation that makes the stiffness exact — the
//! Timoshenko-consistent mass (Przemieniecki 1968; Friedman & Kosmatka 1993, *Comput. Struct.* 47),
//! e.g. `M₁₁ = m̄L (13/35 + 7Φ/10 + Φ²/3)/(1+Φ)²` and `ρI/L · 6/(5(1+Φ)²)`; it reduces to the
//! Euler–Bernoulli consistent mass (`m̄L/420 · [156, 22L, 54, −13L, …]` plus the consistent rotary
//! inertia `ρI/(30L) · [36, 3L, …]`) for `Φ = 0`. Axial `m̄L/6 [[2, 1], [1, 2]]`, torsion
//! `ρ I_p L/6 [[2, 1], [1, 2]]` with the polar moment `I_p = I_y + I_z`. Non-structural mass sits on
//! the axis: translational inertia only.
//!
//! **Lumped mass**: `m̄L/2` on each translation, `ρ I_p L/2` on the twist, and on each bending
//! rotation `ρ I L/2` plus the HRZ share (Hinton, Rock & Zienkiewicz 1976, *Earthq. Eng. Struct.
//! Dyn.* 4) of the translational inertia, `m̄L/2 · M₂₂/M₁₁` (`= m̄L³/78` for `Φ = 0`). Diagonal in the
//! local frame; total mass and total rotary inertia are conserved.
//!
//! **Sections** follow Nastran PBARL, whose cross-section figures draw local `y` up and local
//! `z` to the right: `BAR` has `DIM1` = width along local `z` and `DIM2` = height along local `y`,
//! so `I_z = I1 = b h³/12` (bending in plane 1, `x–y`) and `I_y = I2 = h b³/12`; `ROD` has
//! `DIM1` = radius; `TUBE` has `DIM1`, `DIM2` = outer, inner radius. Torsion constant of a solid
//! `a × b` rectangle (`a ≥ b`) by the Saint-Venant series (Timoshenko & Goodier 1970, §109):
//! `J = a b³/3 − (64 b⁴/π⁵) Σ_{n odd} tanh(nπa/2b)/n⁵`, evaluated as
//! `Σ tanh(·)/n⁵ = (31/32) ζ(5) − Σ (1 − tanh(·))/n⁵` whose remainder decays like `e^{−nπ}` — exact
//! to round-off with at most eight terms. Circles and tubes: `J = I_p`. Shear coefficients are
//! Cowper's (1966, *J. Appl. Mech.* 33) from three-dimensional elasticity: rectangle
//! `10(1+ν)/(12+11ν)`, hollow circle with `m = r_i/r_o`
//! `6(1+ν)(1+m²)² / ((7+6ν)(1+m²)² + (20+12ν)m²)` (solid: `6(1+ν)/(7+6ν)`). They reduce to the
//! classical 5/6 and 6/7 at `ν = 0`, keep `Tube(r, 0) ≡ Circle(r)`, give 1/2 (ν = 0) for a thin tube,
//! and with them the Timoshenko closed form reproduces the NAFEMS FV5 reference frequencies to
//! their printed digits (5/6 would put FV5's third flexural pair 0.4 % low).
//! A [`Section::General`] section takes `A`, `I_y`, `I_z`, `J` and the shear coefficients directly
//! (`None` = shear-rigid, Euler–Bernoulli, as a blank K1/K2 on Nastran's PBAR).
//!
//! **Pin flags** (Nastran CBAR/CBEAM PA, PB): released DOFs `p` of the element system at an end
//! are condensed out statically, `K_c = K_rr − K_rp K_pp⁻¹ K_pr` on the retained DOFs `r` (zero
//! rows and columns at `p`): the released DOFs follow the retained ones as `u_p = −X u_r` with
//! `X = K_pp⁻¹ K_pr`, the end forces at `p` vanish. The mass is made consistent with that motion,
//! `M_c = Tᵀ M T` with `T = [I; −X]` (for either mass kind), so the kinetic energy is that of the
//! condensed displacement field. A singular `K_pp` (the releases leave a mechanism inside the
//! element, e.g. torsion released at both ends) or all six DOFs of an end released is an error.
//!
//! **Offsets** (CBAR/CBEAM WA, WB): the element runs between the offset ends
//! `x_e = x_grid + w`, joined rigidly to the grids: `u_e = u_g + θ_g × w`, `θ_e = θ_g`, i.e.
//! `[u_e; θ_e] = [[I, −[w]×], [0, I]] [u_g; θ_g]` per end, and with that `12 × 12` transform `T_w`
//! the grid matrices are `T_wᵀ K T_w`, `T_wᵀ M T_w` (Przemieniecki 1968, §5.8 rigid offsets).
//!
//! **Centroid and NSM away from the shear centre** (CBEAM with PBEAM N/M/NSI, or an unsymmetric
//! PBEAML section): [`beam2_centred`]; the axis is then the shear centre and the matrices above
//! are transformed to it before the pin flags and offsets (see [`super::beam_offset`]).
//!
//! **Derivatives** (docs/theory.md §2): every entry of `K_ℓ`, `M_ℓ` is a rational function of
//! `E, G, ρ, nsm, A, I_y, I_z, J, I_p, 1/κ_y, 1/κ_z`. The local kernel is written once over a scalar
//! type and evaluated either with `f64` or with dual numbers `a + b ε` (`ε² = 0`) seeded with the
//! analytic derivatives of those quantities (the section's closed-form `∂A/∂d`, `∂I/∂d`, `∂J/∂d`,
//! `∂κ/∂d`). That is the chain rule carried out exactly — including the non-linear dependence of
//! the Timoshenko terms on `I` and `A` through `Φ` — not a difference quotient.

use super::beam_offset::{SectionCentres, about_shear_centre};
use super::element::{ElementDerivative, ElementError, ElementMatrices, MassKind, positive};
use faer::Mat;
use std::f64::consts::PI;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// `Σ_{n odd} 1/n⁵ = (31/32) ζ(5)`.
const ODD_ZETA5: f64 = 1.004_523_762_795_139_6;

/// `|x̂ × v̂|` at or below which the orientation vector counts as parallel to the axis.
const PARALLEL_TOL: f64 = 1e-8;

/// A beam cross-section, by its dimensions (Nastran PBARL conventions) or its properties.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Section {
    /// Solid rectangle, PBARL `BAR`: `width` (DIM1) along local `z`, `height` (DIM2) along local `y`.
    Rectangle {
        /// Width along local `z` (DIM1), m.
        width: f64,
        /// Height along local `y` (DIM2), m.
        height: f64,
    },
    /// Solid square, PBARL `BAR` with DIM1 = DIM2.
    Square {
        /// Side length, m.
        side: f64,
    },
    /// Solid circle, PBARL `ROD`.
    Circle {
        /// Radius (DIM1), m.
        radius: f64,
    },
    /// Circular tube, PBARL `TUBE`.
    Tube {
        /// Outer radius (DIM1), m.
        outer_radius: f64,
        /// Inner radius (DIM2), m; `0 ≤ inner < outer`.
        inner_radius: f64,
    },
    /// Properties given directly, as on Nastran's PBAR; torsional inertia uses `I_p = I_y + I_z`.
    General {
        /// Area `A`, m².
        area: f64,
        /// `I_y = ∫ z² dA` (bending in the `x–z` plane, Nastran I2), m⁴.
        iy: f64,
        /// `I_z = ∫ y² dA` (bending in the `x–y` plane, Nastran I1), m⁴.
        iz: f64,
        /// Torsion constant `J`, m⁴.
        j: f64,
        /// Shear coefficient `κ_y` for shear along local `y`; `None` = shear-rigid.
        shear_y: Option<f64>,
        /// Shear coefficient `κ_z` for shear along local `z`; `None` = shear-rigid.
        shear_z: Option<f64>,
    },
}

/// Section properties (or, from [`Section::derivative`], their partial derivatives).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SectionProperties {
    /// Area `A`, m².
    pub area: f64,
    /// `I_y = ∫ z² dA`, m⁴ (Nastran I2).
    pub iy: f64,
    /// `I_z = ∫ y² dA`, m⁴ (Nastran I1).
    pub iz: f64,
    /// Torsion constant `J`, m⁴.
    pub j: f64,
    /// Polar moment `I_p = I_y + I_z` about the centroid, m⁴ (torsional inertia per `ρ` and length).
    pub ip: f64,
    /// Shear coefficient `κ_y` (shear along local `y`); infinite when shear-rigid.
    pub kappa_y: f64,
    /// Shear coefficient `κ_z` (shear along local `z`); infinite when shear-rigid.
    pub kappa_z: f64,
}

/// A parameter a beam matrix can be differentiated by.
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
pub enum BeamParameter {
    /// Young's modulus `E` (with `ν` fixed, so `G` scales with it).
    YoungsModulus,
    /// Density `ρ`.
    Density,
    /// Non-structural mass per length.
    NonStructuralMass,
    /// Rectangle width (DIM1, along local `z`).
    Width,
    /// Rectangle height (DIM2, along local `y`).
    Height,
    /// Square side.
    Side,
    /// Circle radius.
    Radius,
    /// Tube outer radius.
    OuterRadius,
    /// Tube inner radius.
    InnerRadius,
    /// General section: area.
    Area,
    /// General section: `I_y`.
    Iy,
    /// General section: `I_z`.
    Iz,
    /// General section: torsion constant `J`.
    TorsionConstant,
}

impl BeamParameter {
    /// The snake_case name used in messages and specs.
    pub fn name(self) -> &'static str {
        match self {
            BeamParameter::YoungsModulus => "youngs_modulus",
            BeamParameter::Density => "density",
            BeamParameter::NonStructuralMass => "non_structural_mass",
            BeamParameter::Width => "width",
            BeamParameter::Height => "height",
            BeamParameter::Side => "side",
            BeamParameter::Radius => "radius",
            BeamParameter::OuterRadius => "outer_radius",
            BeamParameter::InnerRadius => "inner_radius",
            BeamParameter::Area => "area",
            BeamParameter::Iy => "iy",
            BeamParameter::Iz => "iz",
            BeamParameter::TorsionConstant => "torsion_constant",
        }
    }

    fn is_material(self) -> bool {
        matches!(
            self,
            BeamParameter::YoungsModulus
                | BeamParameter::Density
                | BeamParameter::NonStructuralMass
        )
    }
}

/// Offsets and pin flags of a beam's ends (zero and none by default: the plain beam).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EndConditions {
    /// Offset from node 1 to end A in the basic system, m.
    pub offset_a: [f64; 3],
    /// Offset from node 2 to end B in the basic system, m.
    pub offset_b: [f64; 3],
    /// Element-system DOFs `[ux uy uz rx ry rz]` released at end A.
    pub released_a: [bool; 6],
    /// Released at end B.
    pub released_b: [bool; 6],
}

impl EndConditions {
    pub(super) fn released(&self) -> Vec<usize> {
        (0..12)
            .filter(|&i| {
                if i < 6 {
                    self.released_a[i]
                } else {
                    self.released_b[i - 6]
                }
            })
            .collect()
    }

    fn has_offset(&self) -> bool {
        self.offset_a
            .iter()
            .chain(&self.offset_b)
            .any(|x| *x != 0.0)
    }
}

/// Material, non-structural mass and section of a beam.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct BeamData {
    /// Young's modulus `E`, Pa.
    pub e: f64,
    /// Poisson's ratio `ν`; `G = E / (2(1+ν))`.
    pub nu: f64,
    /// Density `ρ`, kg/m³.
    pub rho: f64,
    /// Non-structural mass per length, kg/m (on the axis: no rotary inertia).
    pub nsm: f64,
    /// Cross-section.
    pub section: Section,
}

/// The beam's local frame: length and local axes (rows) in the basic system.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamFrame {
    /// Length `L`, m.
    pub length: f64,
    /// Rows are the local `x`, `y`, `z` axes in the basic system.
    pub axes: [[f64; 3]; 3],
}

fn bad(field: &'static str, value: f64, hint: &'static str) -> ElementError {
    ElementError::BadValue { field, value, hint }
}

pub(super) fn poisson(nu: f64) -> Result<f64, ElementError> {
    if nu.is_finite() && nu > -1.0 && nu < 0.5 {
        Ok(nu)
    } else {
        Err(bad("nu", nu, "must be finite with -1 < nu < 0.5"))
    }
}

/// Cowper's shear coefficient of a solid rectangle, `10(1+ν)/(12+11ν)`.
fn cowper_rectangle(nu: f64) -> f64 {
    10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)
}

/// Cowper's shear coefficient of a hollow circle with `m = r_i/r_o`, and `dκ/dm`.
fn cowper_tube(nu: f64, m: f64) -> (f64, f64) {
    let c = 6.0 * (1.0 + nu);
    let p = 7.0 + 6.0 * nu;
    let q = 20.0 + 12.0 * nu;
    let m2 = m * m;
    let s = (1.0 + m2) * (1.0 + m2);
    let den = p * s + q * m2;
    let kappa = c * s / den;
    let dkappa = c * q * 2.0 * m * (1.0 + m2) * (m2 - 1.0) / (den * den);
    (kappa, dkappa)
}

/// Saint-Venant torsion constant of a solid `a × b` rectangle with `a ≥ b > 0`, and `∂J/∂a`, `∂J/∂b`.
fn rectangle_torsion(a: f64, b: f64) -> (f64, f64, f64) {
    // s_t = Σ (1 − tanh x_n)/n⁵ and s_s = Σ sech² x_n / n⁴ over odd n, x_n = nπa/(2b) ≥ nπ/2.
    let mut s_t = 0.0;
    let mut s_s = 0.0;
    let mut n = 1.0f64;
    loop {
        let x = n * PI * a / (2.0 * b);
        let q = (-2.0 * x).exp();
        let n4 = n * n * n * n;
        s_t += 2.0 * q / (1.0 + q) / (n4 * n);
        s_s += 4.0 * q / ((1.0 + q) * (1.0 + q)) / n4;
        if q < 1e-18 || n > 99.0 {
            break;
        }
        n += 2.0;
    }
    let pi4 = PI * PI * PI * PI;
    let pi5 = pi4 * PI;
    let b2 = b * b;
    let b3 = b2 * b;
    let tanh_sum = ODD_ZETA5 - s_t;
    let j = a * b3 / 3.0 - 64.0 * b3 * b / pi5 * tanh_sum;
    let dj_da = b3 / 3.0 - 32.0 * b3 / pi4 * s_s;
    let dj_db = a * b2 - 256.0 * b3 / pi5 * tanh_sum + 32.0 * a * b2 / pi4 * s_s;
    (j, dj_da, dj_db)
}

/// Rectangle `b` (along `z`) × `h` (along `y`): properties and their derivatives by `b` and `h`.
fn rectangle(b: f64, h: f64, nu: f64) -> [SectionProperties; 3] {
    let (j, dj_db, dj_dh) = if b >= h {
        rectangle_torsion(b, h)
    } else {
        let (j, dj_dh, dj_db) = rectangle_torsion(h, b);
        (j, dj_db, dj_dh)
    };
    let iz = b * h * h * h / 12.0;
    let iy = h * b * b * b / 12.0;
    let kappa = cowper_rectangle(nu);
    let value = SectionProperties {
        area: b * h,
        iy,
        iz,
        j,
        ip: iy + iz,
        kappa_y: kappa,
        kappa_z: kappa,
    };
    let d_iz_db = h * h * h / 12.0;
    let d_iy_db = h * b * b / 4.0;
    let by_b = SectionProperties {
        area: h,
        iy: d_iy_db,
        iz: d_iz_db,
        j: dj_db,
        ip: d_iy_db + d_iz_db,
        kappa_y: 0.0,
        kappa_z: 0.0,
    };
    let d_iz_dh = b * h * h / 4.0;
    let d_iy_dh = b * b * b / 12.0;
    let by_h = SectionProperties {
        area: b,
        iy: d_iy_dh,
        iz: d_iz_dh,
        j: dj_dh,
        ip: d_iy_dh + d_iz_dh,
        kappa_y: 0.0,
        kappa_z: 0.0,
    };
    [value, by_b, by_h]
}

/// Tube `r_o`, `r_i` (`r_i = 0`: solid circle): properties and their derivatives by `r_o` and `r_i`.
fn tube(ro: f64, ri: f64, nu: f64) -> [SectionProperties; 3] {
    let i = PI * (ro.powi(4) - ri.powi(4)) / 4.0;
    let (kappa, dkappa_dm) = cowper_tube(nu, ri / ro);
    let value = SectionProperties {
        area: PI * (ro * ro - ri * ri),
        iy: i,
        iz: i,
        j: 2.0 * i,
        ip: 2.0 * i,
        kappa_y: kappa,
        kappa_z: kappa,
    };
    let di_dro = PI * ro * ro * ro;
    let dk_dro = dkappa_dm * (-ri / (ro * ro));
    let by_ro = SectionProperties {
        area: 2.0 * PI * ro,
        iy: di_dro,
        iz: di_dro,
        j: 2.0 * di_dro,
        ip: 2.0 * di_dro,
        kappa_y: dk_dro,
        kappa_z: dk_dro,
    };
    let di_dri = -PI * ri * ri * ri;
    let dk_dri = dkappa_dm / ro;
    let by_ri = SectionProperties {
        area: -2.0 * PI * ri,
        iy: di_dri,
        iz: di_dri,
        j: 2.0 * di_dri,
        ip: 2.0 * di_dri,
        kappa_y: dk_dri,
        kappa_z: dk_dri,
    };
    [value, by_ro, by_ri]
}

impl Section {
    /// Short description for messages, with the parameters it can be differentiated by.
    fn describe(&self) -> (&'static str, &'static str) {
        match self {
            Section::Rectangle { .. } => (
                "a beam with a rectangle section",
                "youngs_modulus, density, non_structural_mass, width, height",
            ),
            Section::Square { .. } => (
                "a beam with a square section",
                "youngs_modulus, density, non_structural_mass, side",
            ),
            Section::Circle { .. } => (
                "a beam with a circle section",
                "youngs_modulus, density, non_structural_mass, radius",
            ),
            Section::Tube { .. } => (
                "a beam with a tube section",
                "youngs_modulus, density, non_structural_mass, outer_radius, inner_radius",
            ),
            Section::General { .. } => (
                "a beam with a general section",
                "youngs_modulus, density, non_structural_mass, area, iy, iz, torsion_constant",
            ),
        }
    }

    fn validate(&self) -> Result<(), ElementError> {
        match *self {
            Section::Rectangle { width, height } => {
                positive("width", width, false)?;
                positive("height", height, false)?;
            }
            Section::Square { side } => {
                positive("side", side, false)?;
            }
            Section::Circle { radius } => {
                positive("radius", radius, false)?;
            }
            Section::Tube {
                outer_radius,
                inner_radius,
            } => {
                positive("outer_radius", outer_radius, false)?;
                if !(inner_radius.is_finite() && inner_radius >= 0.0 && inner_radius < outer_radius)
                {
                    return Err(bad(
                        "inner_radius",
                        inner_radius,
                        "must be finite, >= 0 and < outer_radius",
                    ));
                }
            }
            Section::General {
                area,
                iy,
                iz,
                j,
                shear_y,
                shear_z,
            } => {
                positive("area", area, false)?;
                positive("iy", iy, false)?;
                positive("iz", iz, false)?;
                positive("j", j, true)?;
                if let Some(k) = shear_y {
                    positive("shear_y", k, false)?;
                }
                if let Some(k) = shear_z {
                    positive("shear_z", k, false)?;
                }
            }
        }
        Ok(())
    }

    /// Properties and their derivative by `p` (zero for a material parameter).
    pub(super) fn evaluate(
        &self,
        nu: f64,
        p: Option<BeamParameter>,
    ) -> Result<(SectionProperties, SectionProperties), ElementError> {
        poisson(nu)?;
        self.validate()?;
        let zero = SectionProperties::default();
        let unknown = |p: BeamParameter| {
            let (element, valid) = self.describe();
            ElementError::UnknownParameter {
                parameter: p.name(),
                element,
                valid,
            }
        };
        let pick = |p: Option<BeamParameter>,
                    options: &[(BeamParameter, SectionProperties)]|
         -> Result<SectionProperties, ElementError> {
            match p {
                None => Ok(zero),
                Some(p) if p.is_material() => Ok(zero),
                Some(p) => options
                    .iter()
                    .find(|(q, _)| *q == p)
                    .map(|(_, d)| *d)
                    .ok_or_else(|| unknown(p)),
            }
        };
        Ok(match *self {
            Section::Rectangle { width, height } => {
                let [v, db, dh] = rectangle(width, height, nu);
                let d = pick(
                    p,
                    &[(BeamParameter::Width, db), (BeamParameter::Height, dh)],
                )?;
                (v, d)
            }
            Section::Square { side } => {
                let [v, db, dh] = rectangle(side, side, nu);
                let ds = SectionProperties {
                    area: db.area + dh.area,
                    iy: db.iy + dh.iy,
                    iz: db.iz + dh.iz,
                    j: db.j + dh.j,
                    ip: db.ip + dh.ip,
                    kappa_y: 0.0,
                    kappa_z: 0.0,
                };
                (v, pick(p, &[(BeamParameter::Side, ds)])?)
            }
            Section::Circle { radius } => {
                let [v, dr, _] = tube(radius, 0.0, nu);
                (v, pick(p, &[(BeamParameter::Radius, dr)])?)
            }
            Section::Tube {
                outer_radius,
                inner_radius,
            } => {
                let [v, dro, dri] = tube(outer_radius, inner_radius, nu);
                let d = pick(
                    p,
                    &[
                        (BeamParameter::OuterRadius, dro),
                        (BeamParameter::InnerRadius, dri),
                    ],
                )?;
                (v, d)
            }
            Section::General {
                area,
                iy,
                iz,
                j,
                shear_y,
                shear_z,
            } => {
                let v = SectionProperties {
                    area,
                    iy,
                    iz,
                    j,
                    ip: iy + iz,
                    kappa_y: shear_y.unwrap_or(f64::INFINITY),
                    kappa_z: shear_z.unwrap_or(f64::INFINITY),
                };
                let unit = |area, iy, iz, j| SectionProperties {
                    area,
                    iy,
                    iz,
                    j,
                    ip: iy + iz,
                    kappa_y: 0.0,
                    kappa_z: 0.0,
                };
                let d = pick(
                    p,
                    &[
                        (BeamParameter::Area, unit(1.0, 0.0, 0.0, 0.0)),
                        (BeamParameter::Iy, unit(0.0, 1.0, 0.0, 0.0)),
                        (BeamParameter::Iz, unit(0.0, 0.0, 1.0, 0.0)),
                        (BeamParameter::TorsionConstant, unit(0.0, 0.0, 0.0, 1.0)),
                    ],
                )?;
                (v, d)
            }
        })
    }

    /// Area, second moments, torsion constant, polar moment and Cowper shear coefficients for Poisson's ratio `nu`.
    pub fn properties(&self, nu: f64) -> Result<SectionProperties, ElementError> {
        self.evaluate(nu, None).map(|(v, _)| v)
    }

    /// Partial derivatives of every property by a section dimension (all zero for `E`, `ρ`, nsm).
    pub fn derivative(&self, nu: f64, p: BeamParameter) -> Result<SectionProperties, ElementError> {
        self.evaluate(nu, Some(p)).map(|(_, d)| d)
    }
}

impl BeamData {
    /// Shear modulus `G = E / (2(1+ν))`.
    pub fn shear_modulus(&self) -> f64 {
        self.e / (2.0 * (1.0 + self.nu))
    }

    /// Checks every value and returns the section properties.
    pub fn validate(&self) -> Result<SectionProperties, ElementError> {
        positive("e", self.e, false)?;
        positive("rho", self.rho, true)?;
        positive("nsm", self.nsm, true)?;
        self.section.properties(self.nu)
    }

    /// Current value of a parameter.
    pub fn parameter(&self, p: BeamParameter) -> Result<f64, ElementError> {
        let mut copy = *self;
        let slot = copy.slot(p)?;
        Ok(*slot)
    }

    /// A copy with one parameter set to `value` (not validated until used).
    pub fn with_parameter(&self, p: BeamParameter, value: f64) -> Result<BeamData, ElementError> {
        let mut copy = *self;
        *copy.slot(p)? = value;
        Ok(copy)
    }

    fn slot(&mut self, p: BeamParameter) -> Result<&mut f64, ElementError> {
        let (element, valid) = self.section.describe();
        let unknown = ElementError::UnknownParameter {
            parameter: p.name(),
            element,
            valid,
        };
        Ok(match (p, &mut self.section) {
            (BeamParameter::YoungsModulus, _) => &mut self.e,
            (BeamParameter::Density, _) => &mut self.rho,
            (BeamParameter::NonStructuralMass, _) => &mut self.nsm,
            (BeamParameter::Width, Section::Rectangle { width, .. }) => width,
            (BeamParameter::Height, Section::Rectangle { height, .. }) => height,
            (BeamParameter::Side, Section::Square { side }) => side,
            (BeamParameter::Radius, Section::Circle { radius }) => radius,
            (BeamParameter::OuterRadius, Section::Tube { outer_radius, .. }) => outer_radius,
            (BeamParameter::InnerRadius, Section::Tube { inner_radius, .. }) => inner_radius,
            (BeamParameter::Area, Section::General { area, .. }) => area,
            (BeamParameter::Iy, Section::General { iy, .. }) => iy,
            (BeamParameter::Iz, Section::General { iz, .. }) => iz,
            (BeamParameter::TorsionConstant, Section::General { j, .. }) => j,
            _ => return Err(unknown),
        })
    }
}

fn finite3(field: &'static str, x: [f64; 3]) -> Result<(), ElementError> {
    match x.iter().find(|c| !c.is_finite()) {
        Some(c) => Err(bad(field, *c, "every coordinate must be finite")),
        None => Ok(()),
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Length and local axes of a beam from its node coordinates and orientation vector `v`.
pub fn beam_frame(x1: [f64; 3], x2: [f64; 3], v: [f64; 3]) -> Result<BeamFrame, ElementError> {
    finite3("x1", x1)?;
    finite3("x2", x2)?;
    finite3("v", v)?;
    let d = [x2[0] - x1[0], x2[1] - x1[1], x2[2] - x1[2]];
    let length = norm(d);
    let size = norm(x1).max(norm(x2));
    if !(length.is_finite() && length > 1e-12 * size && length > 0.0) {
        return Err(ElementError::Degenerate(format!(
            "beam nodes at {x1:?} and {x2:?} coincide (length {length:e})"
        )));
    }
    let ex = scale(d, 1.0 / length);
    let vn = norm(v);
    let z = if vn > 0.0 && vn.is_finite() {
        cross(ex, scale(v, 1.0 / vn))
    } else {
        [0.0; 3]
    };
    let zn = norm(z);
    if zn.is_nan() || zn <= PARALLEL_TOL {
        return Err(ElementError::Orientation { v, axis: ex });
    }
    let ez = scale(z, 1.0 / zn);
    let ey = cross(ez, ex);
    Ok(BeamFrame {
        length,
        axes: [ex, ey, ez],
    })
}

/// Arithmetic the local kernel needs; implemented by `f64` and by [`Dual`].
pub(super) trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    fn cst(x: f64) -> Self;
}

impl Scalar for f64 {
    fn cst(x: f64) -> f64 {
        x
    }
}

/// Dual number `v + d ε` with `ε² = 0`: forward-mode derivative carried beside the value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Dual {
    pub(super) v: f64,
    pub(super) d: f64,
}

impl Add for Dual {
    type Output = Dual;
    fn add(self, o: Dual) -> Dual {
        Dual {
            v: self.v + o.v,
            d: self.d + o.d,
        }
    }
}

impl Sub for Dual {
    type Output = Dual;
    fn sub(self, o: Dual) -> Dual {
        Dual {
            v: self.v - o.v,
            d: self.d - o.d,
        }
    }
}

impl Mul for Dual {
    type Output = Dual;
    fn mul(self, o: Dual) -> Dual {
        Dual {
            v: self.v * o.v,
            d: self.v * o.d + self.d * o.v,
        }
    }
}

impl Div for Dual {
    type Output = Dual;
    fn div(self, o: Dual) -> Dual {
        let q = self.v / o.v;
        Dual {
            v: q,
            d: (self.d - q * o.d) / o.v,
        }
    }
}

impl Neg for Dual {
    type Output = Dual;
    fn neg(self) -> Dual {
        Dual {
            v: -self.v,
            d: -self.d,
        }
    }
}

impl Scalar for Dual {
    fn cst(x: f64) -> Dual {
        Dual { v: x, d: 0.0 }
    }
}

/// The scalars every local matrix entry is a function of.
#[derive(Clone, Copy, Debug)]
struct Scalars<T> {
    /// `E/G = 2(1+ν)`: Φ depends on E only through this ratio, so it is independent of `E`.
    e_over_g: f64,
    e: T,
    g: T,
    rho: T,
    nsm: T,
    area: T,
    iy: T,
    iz: T,
    j: T,
    ip: T,
    inv_kappa_y: T,
    inv_kappa_z: T,
}

/// Local DOFs of the `x–y` bending plane (`uy1 rz1 uy2 rz2`) and their signs.
pub(super) const XY_DOFS: [usize; 4] = [1, 5, 7, 11];
pub(super) const XY_SIGNS: [f64; 4] = [1.0, 1.0, 1.0, 1.0];
/// Local DOFs of the `x–z` bending plane (`uz1 ry1 uz2 ry2`); `ry = −dw/dx` flips its sign.
pub(super) const XZ_DOFS: [usize; 4] = [2, 4, 8, 10];
pub(super) const XZ_SIGNS: [f64; 4] = [1.0, -1.0, 1.0, -1.0];

pub(super) fn scatter<T: Scalar>(
    target: &mut [[T; 12]; 12],
    block: &[[T; 4]; 4],
    dofs: [usize; 4],
    signs: [f64; 4],
) {
    for (a, row) in block.iter().enumerate() {
        for (b, value) in row.iter().enumerate() {
            let entry = &mut target[dofs[a]][dofs[b]];
            *entry = if signs[a] * signs[b] > 0.0 {
                *entry + *value
            } else {
                *entry - *value
            };
        }
    }
}

pub(super) fn pair<T: Scalar>(target: &mut [[T; 12]; 12], i: usize, j: usize, diag: T, off: T) {
    target[i][i] = target[i][i] + diag;
    target[j][j] = target[j][j] + diag;
    target[i][j] = target[i][j] + off;
    target[j][i] = target[j][i] + off;
}

/// Timoshenko bending stiffness of one plane, DOFs `(w1, θ1, w2, θ2)` with `θ = dw/dx` when `Φ = 0`.
fn plane_stiffness<T: Scalar>(ei: T, phi: T, l: f64) -> [[T; 4]; 4] {
    let one = T::cst(1.0);
    let c = ei / (T::cst(l * l * l) * (one + phi));
    let k12 = T::cst(12.0) * c;
    let k6 = T::cst(6.0 * l) * c;
    let l2 = T::cst(l * l);
    let kd = (T::cst(4.0) + phi) * l2 * c;
    let ko = (T::cst(2.0) - phi) * l2 * c;
    [
        [k12, k6, -k12, k6],
        [k6, kd, -k6, ko],
        [-k12, -k6, k12, -k6],
        [k6, ko, -k6, kd],
    ]
}

/// Timoshenko-consistent mass of one bending plane: translational `m̄` and rotary `ρI` parts.
fn plane_mass<T: Scalar>(mbar: T, rho_i: T, phi: T, l: f64) -> [[T; 4]; 4] {
    let c = T::cst;
    let one = c(1.0);
    let d = (one + phi) * (one + phi);
    let p2 = phi * phi;
    let t = mbar * c(l) / d;
    let m11 = t * (c(13.0 / 35.0) + c(7.0 / 10.0) * phi + c(1.0 / 3.0) * p2);
    let m12 = t * c(l) * (c(11.0 / 210.0) + c(11.0 / 120.0) * phi + c(1.0 / 24.0) * p2);
    let m13 = t * (c(9.0 / 70.0) + c(3.0 / 10.0) * phi + c(1.0 / 6.0) * p2);
    let m14 = -(t * c(l) * (c(13.0 / 420.0) + c(3.0 / 40.0) * phi + c(1.0 / 24.0) * p2));
    let m22 = t * c(l * l) * (c(1.0 / 105.0) + c(1.0 / 60.0) * phi + c(1.0 / 120.0) * p2);
    let m24 = -(t * c(l * l) * (c(1.0 / 140.0) + c(1.0 / 60.0) * phi + c(1.0 / 120.0) * p2));
    let r = rho_i / (c(l) * d);
    let r11 = r * c(6.0 / 5.0);
    let r12 = r * c(l) * (c(1.0 / 10.0) - c(1.0 / 2.0) * phi);
    let r22 = r * c(l * l) * (c(2.0 / 15.0) + c(1.0 / 6.0) * phi + c(1.0 / 3.0) * p2);
    let r24 = r * c(l * l) * (c(-1.0 / 30.0) - c(1.0 / 6.0) * phi + c(1.0 / 6.0) * p2);
    [
        [m11 + r11, m12 + r12, m13 - r11, m14 + r12],
        [m12 + r12, m22 + r22, -m14 - r12, m24 + r24],
        [m13 - r11, -m14 - r12, m11 + r11, -m12 - r12],
        [m14 + r12, m24 + r24, -m12 - r12, m22 + r22],
    ]
}

/// Lumped (HRZ) mass of one bending plane: diagonal `(w1, θ1, w2, θ2)`.
fn plane_lumped<T: Scalar>(mbar: T, rho_i: T, phi: T, l: f64) -> [T; 4] {
    let c = T::cst;
    let p2 = phi * phi;
    let half = mbar * c(0.5 * l);
    let ratio = c(l * l) * (c(1.0 / 105.0) + c(1.0 / 60.0) * phi + c(1.0 / 120.0) * p2)
        / (c(13.0 / 35.0) + c(7.0 / 10.0) * phi + c(1.0 / 3.0) * p2);
    let rot = half * ratio + rho_i * c(0.5 * l);
    [half, rot, half, rot]
}

/// Local stiffness and mass (12 × 12, local frame).
fn local_matrices<T: Scalar>(
    l: f64,
    s: &Scalars<T>,
    kind: MassKind,
) -> ([[T; 12]; 12], [[T; 12]; 12]) {
    let c = T::cst;
    let zero = c(0.0);
    let mut k = [[zero; 12]; 12];
    let mut m = [[zero; 12]; 12];

    let ea = s.e * s.area / c(l);
    pair(&mut k, 0, 6, ea, -ea);
    let gj = s.g * s.j / c(l);
    pair(&mut k, 3, 9, gj, -gj);
    // Φ = 12 E I / (κ G A L²) = 12 (E/G) I (1/κ) / (A L²).
    let al2 = s.area * c(l * l);
    let phi_y = c(12.0 * s.e_over_g) * s.iz * s.inv_kappa_y / al2;
    let phi_z = c(12.0 * s.e_over_g) * s.iy * s.inv_kappa_z / al2;
    scatter(
        &mut k,
        &plane_stiffness(s.e * s.iz, phi_y, l),
        XY_DOFS,
        XY_SIGNS,
    );
    scatter(
        &mut k,
        &plane_stiffness(s.e * s.iy, phi_z, l),
        XZ_DOFS,
        XZ_SIGNS,
    );

    let mbar = s.rho * s.area + s.nsm;
    let rho_ip = s.rho * s.ip;
    match kind {
        MassKind::Consistent => {
            let axial = mbar * c(l / 6.0);
            pair(&mut m, 0, 6, c(2.0) * axial, axial);
            let twist = rho_ip * c(l / 6.0);
            pair(&mut m, 3, 9, c(2.0) * twist, twist);
            scatter(
                &mut m,
                &plane_mass(mbar, s.rho * s.iz, phi_y, l),
                XY_DOFS,
                XY_SIGNS,
            );
            scatter(
                &mut m,
                &plane_mass(mbar, s.rho * s.iy, phi_z, l),
                XZ_DOFS,
                XZ_SIGNS,
            );
        }
        MassKind::Lumped => {
            let half = mbar * c(0.5 * l);
            pair(&mut m, 0, 6, half, zero);
            pair(&mut m, 3, 9, rho_ip * c(0.5 * l), zero);
            for (dofs, diag) in [
                (XY_DOFS, plane_lumped(mbar, s.rho * s.iz, phi_y, l)),
                (XZ_DOFS, plane_lumped(mbar, s.rho * s.iy, phi_z, l)),
            ] {
                for (dof, value) in dofs.into_iter().zip(diag) {
                    m[dof][dof] = m[dof][dof] + value;
                }
            }
        }
    }
    (k, m)
}

/// `Tᵀ A T` for `T = diag(R, R, R, R)`, symmetrised, as a faer matrix.
pub(super) fn to_basic(a: &[[f64; 12]; 12], r: &[[f64; 3]; 3]) -> Result<Mat<f64>, ElementError> {
    let mut out = [[0.0f64; 12]; 12];
    for bi in 0..4 {
        for bj in 0..4 {
            // tmp = A_block · R
            let mut tmp = [[0.0f64; 3]; 3];
            for (p, tmp_row) in tmp.iter_mut().enumerate() {
                for (q, t) in tmp_row.iter_mut().enumerate() {
                    *t = (0..3).map(|s| a[3 * bi + p][3 * bj + s] * r[s][q]).sum();
                }
            }
            for p in 0..3 {
                for q in 0..3 {
                    out[3 * bi + p][3 * bj + q] = (0..3).map(|s| r[s][p] * tmp[s][q]).sum();
                }
            }
        }
    }
    if let Some(v) = out.iter().flatten().find(|v| !v.is_finite()) {
        return Err(bad(
            "beam matrix entry",
            *v,
            "the element's values overflow f64; check units and magnitudes",
        ));
    }
    Ok(Mat::from_fn(12, 12, |i, j| 0.5 * (out[i][j] + out[j][i])))
}

fn scalars_f64(d: &BeamData, p: &SectionProperties) -> Scalars<f64> {
    Scalars {
        e_over_g: 2.0 * (1.0 + d.nu),
        e: d.e,
        g: d.shear_modulus(),
        rho: d.rho,
        nsm: d.nsm,
        area: p.area,
        iy: p.iy,
        iz: p.iz,
        j: p.j,
        ip: p.ip,
        inv_kappa_y: 1.0 / p.kappa_y,
        inv_kappa_z: 1.0 / p.kappa_z,
    }
}

/// A local stiffness and mass pair.
pub(super) type LocalPair<T> = ([[T; 12]; 12], [[T; 12]; 12]);

/// Static condensation of the released local DOFs `p` (see the module doc): `K_c`, `Tᵀ M T`.
/// `K_pp` is symmetric positive definite when the releases leave no mechanism, so elimination
/// without pivoting is stable; a pivot at or below `1e-10` of the largest diagonal entry of the
/// (value of the) stiffness means a mechanism.
pub(super) fn condense<T: Scalar>(
    k: &[[T; 12]; 12],
    m: &[[T; 12]; 12],
    p: &[usize],
    value: impl Fn(T) -> f64,
) -> Result<LocalPair<T>, ElementError> {
    if p.is_empty() {
        return Ok((*k, *m));
    }
    for end in [0..6, 6..12] {
        if end.clone().all(|i| p.contains(&i)) {
            return Err(ElementError::Degenerate(
                "the pin flags release all six DOFs of an end: the element transmits nothing (a mechanism)".into(),
            ));
        }
    }
    let r: Vec<usize> = (0..12).filter(|i| !p.contains(i)).collect();
    let np = p.len();
    let scale = (0..12).map(|i| value(k[i][i]).abs()).fold(0.0, f64::max);
    // Solve K_pp X = K_pr by Gauss elimination on [K_pp | K_pr].
    let zero = T::cst(0.0);
    let mut a: Vec<Vec<T>> = p
        .iter()
        .map(|&i| {
            p.iter()
                .map(|&j| k[i][j])
                .chain(r.iter().map(|&j| k[i][j]))
                .collect()
        })
        .collect();
    let width = np + r.len();
    for c in 0..np {
        let piv = a[c][c];
        if !(value(piv) > 1e-10 * scale) {
            return Err(ElementError::Degenerate(
                "the pin flags release a mechanism inside the element (e.g. the same DOF at both ends); release fewer DOFs".into(),
            ));
        }
        let (top, below) = a.split_at_mut(c + 1);
        let pivot_row = &top[c];
        for row in below.iter_mut() {
            let f = row[c] / piv;
            for (x, t) in row[c..width].iter_mut().zip(&pivot_row[c..width]) {
                *x = *x - f * *t;
            }
        }
    }
    let mut x = vec![vec![zero; r.len()]; np];
    for c in (0..np).rev() {
        for q in 0..r.len() {
            let mut v = a[c][np + q];
            for s in c + 1..np {
                v = v - a[c][s] * x[s][q];
            }
            x[c][q] = v / a[c][c];
        }
    }
    // T (12 × |r|): identity on r, −X on p.
    let mut t = [[zero; 12]; 12];
    for (q, &j) in r.iter().enumerate() {
        t[j][j] = T::cst(1.0);
        for (c, &i) in p.iter().enumerate() {
            t[i][j] = -x[c][q];
        }
    }
    let congruence = |a: &[[T; 12]; 12]| {
        let mut at = [[zero; 12]; 12];
        for i in 0..12 {
            for &j in &r {
                let mut v = zero;
                for s in 0..12 {
                    v = v + a[i][s] * t[s][j];
                }
                at[i][j] = v;
            }
        }
        let mut out = [[zero; 12]; 12];
        for &i in &r {
            for &j in &r {
                let mut v = zero;
                for s in 0..12 {
                    v = v + t[s][i] * at[s][j];
                }
                out[i][j] = v;
            }
        }
        out
    };
    Ok((congruence(k), congruence(m)))
}

/// `T_wᵀ A T_w` for the rigid offsets of the ends (see the module doc); `A` as it is when both
/// offsets are zero.
pub(super) fn offset_grid(a: Mat<f64>, ends: &EndConditions) -> Mat<f64> {
    if !ends.has_offset() {
        return a;
    }
    let mut t = Mat::<f64>::identity(12, 12);
    for (base, w) in [(0, ends.offset_a), (6, ends.offset_b)] {
        // u_e = u_g − [w]× θ_g, [w]× = [[0, −w3, w2], [w3, 0, −w1], [−w2, w1, 0]].
        let wx = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
        for i in 0..3 {
            for j in 0..3 {
                t[(base + i, base + 3 + j)] = -wx[i][j];
            }
        }
    }
    let out = t.transpose() * &a * &t;
    Mat::from_fn(12, 12, |i, j| 0.5 * (out[(i, j)] + out[(j, i)]))
}

pub(super) fn ends_frame(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    ends: &EndConditions,
) -> Result<BeamFrame, ElementError> {
    finite3("offset_a", ends.offset_a)?;
    finite3("offset_b", ends.offset_b)?;
    let add = |x: [f64; 3], w: [f64; 3]| [x[0] + w[0], x[1] + w[1], x[2] + w[2]];
    beam_frame(add(x1, ends.offset_a), add(x2, ends.offset_b), v)
}

/// Stiffness and mass (12 × 12, basic system) of a 2-node Timoshenko beam from node 1 at `x1` to
/// node 2 at `x2`, with orientation vector `v` in the local `x–y` plane.
pub fn beam2(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    d: &BeamData,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    beam2_with_ends(x1, x2, v, d, mass, &EndConditions::default())
}

/// [`beam2`] with offset ends and pin flags (see the module doc).
pub fn beam2_with_ends(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    d: &BeamData,
    mass: MassKind,
    ends: &EndConditions,
) -> Result<ElementMatrices, ElementError> {
    beam2_centred(x1, x2, v, d, mass, ends, &SectionCentres::default())
}

/// The local pair about the shear centre when the centroid or NSM lies away from it
/// ([`super::beam_offset`]); the centroidal pair itself (bit for bit) when `centres` is zero.
fn local_pair<T: Scalar>(
    l: f64,
    s: &Scalars<T>,
    kind: MassKind,
    centres: &SectionCentres,
) -> LocalPair<T> {
    if centres.is_zero() {
        return local_matrices(l, s, kind);
    }
    let zero = T::cst(0.0);
    let rho_a = s.rho * s.area;
    // m̄ = ρA + nsm = 0 exactly: the rotary and torsional inertia alone.
    let (k, m_rotary) = local_matrices(l, &Scalars { nsm: -rho_a, ..*s }, kind);
    let (_, m_structural) = local_matrices(
        l,
        &Scalars {
            rho: zero,
            nsm: rho_a,
            ..*s
        },
        kind,
    );
    let (_, m_nsm) = local_matrices(l, &Scalars { rho: zero, ..*s }, kind);
    about_shear_centre(&k, [&m_rotary, &m_structural, &m_nsm], centres, l, kind)
}

/// [`beam2_with_ends`] whose axis is the shear centre, with the centroid and the NSM at
/// `centres` from it (see [`super::beam_offset`]).
pub fn beam2_centred(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    d: &BeamData,
    mass: MassKind,
    ends: &EndConditions,
    centres: &SectionCentres,
) -> Result<ElementMatrices, ElementError> {
    let frame = ends_frame(x1, x2, v, ends)?;
    let props = d.validate()?;
    centres.validate()?;
    let (k, m) = local_pair(frame.length, &scalars_f64(d, &props), mass, centres);
    let (k, m) = condense(&k, &m, &ends.released(), |x| x)?;
    Ok(ElementMatrices {
        k: offset_grid(to_basic(&k, &frame.axes)?, ends),
        m: offset_grid(to_basic(&m, &frame.axes)?, ends),
    })
}

/// The derivative parts of a matrix in dual numbers.
pub(super) fn tangent(a: &[[Dual; 12]; 12]) -> [[f64; 12]; 12] {
    let mut out = [[0.0f64; 12]; 12];
    for (o, row) in out.iter_mut().zip(a) {
        for (x, y) in o.iter_mut().zip(row) {
            *x = y.d;
        }
    }
    out
}

/// Exact `∂K/∂φ`, `∂M/∂φ` (basic system) of [`beam2`] by one parameter.
pub fn beam2_derivative(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    d: &BeamData,
    mass: MassKind,
    p: BeamParameter,
) -> Result<ElementDerivative, ElementError> {
    beam2_derivative_with_ends(x1, x2, v, d, mass, p, &EndConditions::default())
}

/// Exact `∂K/∂φ`, `∂M/∂φ` of [`beam2_with_ends`]: the condensation is carried out in dual
/// numbers, the offset transform is constant.
pub fn beam2_derivative_with_ends(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    d: &BeamData,
    mass: MassKind,
    p: BeamParameter,
    ends: &EndConditions,
) -> Result<ElementDerivative, ElementError> {
    beam2_derivative_centred(x1, x2, v, d, mass, p, ends, &SectionCentres::default())
}

/// Exact `∂K/∂φ`, `∂M/∂φ` of [`beam2_centred`]: the shear-centre transforms are constant, so
/// they carry the dual numbers through unchanged.
#[allow(clippy::too_many_arguments)]
pub fn beam2_derivative_centred(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    d: &BeamData,
    mass: MassKind,
    p: BeamParameter,
    ends: &EndConditions,
    centres: &SectionCentres,
) -> Result<ElementDerivative, ElementError> {
    let frame = ends_frame(x1, x2, v, ends)?;
    d.validate()?;
    centres.validate()?;
    let (props, dprops) = d.section.evaluate(d.nu, Some(p))?;
    let s = scalars_f64(d, &props);
    let dual = |v: f64, d: f64| Dual { v, d };
    let g_per_e = 1.0 / (2.0 * (1.0 + d.nu));
    let (de, drho, dnsm) = match p {
        BeamParameter::YoungsModulus => (1.0, 0.0, 0.0),
        BeamParameter::Density => (0.0, 1.0, 0.0),
        BeamParameter::NonStructuralMass => (0.0, 0.0, 1.0),
        _ => (0.0, 0.0, 0.0),
    };
    // d(1/κ) = −dκ/κ²; zero for a shear-rigid (infinite κ) General section.
    let inv_kappa = |kappa: f64, dkappa: f64| {
        if dkappa == 0.0 {
            0.0
        } else {
            -dkappa / (kappa * kappa)
        }
    };
    let sd = Scalars {
        e_over_g: s.e_over_g,
        e: dual(s.e, de),
        g: dual(s.g, de * g_per_e),
        rho: dual(s.rho, drho),
        nsm: dual(s.nsm, dnsm),
        area: dual(s.area, dprops.area),
        iy: dual(s.iy, dprops.iy),
        iz: dual(s.iz, dprops.iz),
        j: dual(s.j, dprops.j),
        ip: dual(s.ip, dprops.ip),
        inv_kappa_y: dual(s.inv_kappa_y, inv_kappa(props.kappa_y, dprops.kappa_y)),
        inv_kappa_z: dual(s.inv_kappa_z, inv_kappa(props.kappa_z, dprops.kappa_z)),
    };
    let (k, m) = local_pair(frame.length, &sd, mass, centres);
    let (k, m) = condense(&k, &m, &ends.released(), |x: Dual| x.v)?;
    Ok(ElementDerivative {
        dk: offset_grid(to_basic(&tangent(&k), &frame.axes)?, ends),
        dm: offset_grid(to_basic(&tangent(&m), &frame.axes)?, ends),
    })
}

#[cfg(test)]
#[path = "beam_tests.rs"]
mod tests;
