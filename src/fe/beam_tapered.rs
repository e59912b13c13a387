//! Tapered two-node beams (Nastran PBEAM/PBEAML with stations) and tapered rods (PTUBE with
//! OD2), with exact parameter derivatives.
//!
//! **What varies.** A [`Taper`] gives the section properties and non-structural mass at any
//! point `ξ = s/L ∈ [0, 1]` and the stations between which they are smooth: PBEAM interpolates
//! `A, I1, I2, J, NSM` linearly between stations; PBEAML interpolates the dimensions (and NSM)
//! linearly and computes the properties from them at every point (so `I` of a BAR whose height
//! varies linearly is cubic). The frame, offsets and pin flags are those of [`super::beam`].
//!
//! **Stiffness: the flexibility method** (Przemieniecki 1968, *Theory of Matrix Structural
//! Analysis*, §5.7). Clamped at end A and loaded at end B, the beam's tip flexibility is exact
//! for end loads whatever the variation of the section: axial `f = ∫ ds/EA`, torsion
//! `∫ ds/GJ`, and in each bending plane, with `r = L − s` the lever arm of the tip load,
//! `F = [[∫ r²/EI ds + ∫ ds/(κGA), ∫ r/EI ds], [∫ r/EI ds, ∫ ds/EI]]` on the tip deflection and
//! section rotation (Timoshenko: the shear term is the complementary energy of the shear
//! force; `κ = ∞` drops it). Then `K_BB = F⁻¹`, and equilibrium (the stiffness annihilates the
//! rigid motions `u_B = Γ u_A`, `Γ = [[1, L], [0, 1]]`) completes
//! `K = Hᵀ K_BB H`, `H = [−Γ, I]`. For a uniform section this is the closed-form matrix of
//! [`super::beam`]. The integrals are taken by 8-point Gauss–Legendre quadrature on each
//! interval between stations, bisected until halving changes no flexibility by more than
//! `1e-14` of itself (the integrands `1/EI(ξ)` are rational, with poles outside the interval
//! that come near it for strong tapers; bisection keeps the rule converged).
//!
//! **Mass** (consistent): the interpolation of the uniform element (Timoshenko cubic `w` and
//! quadratic `θ` with shear parameter `Φ`, linear axial and twist) integrated against the
//! varying `m̄ = ρA + NSM`, rotary `ρI_y`, `ρI_z` and torsional `ρI_p`, with the element's
//! equivalent `Φ = 12 ∫ds/(κGA) / (L² ∫ds/EI)` (the uniform `12EI/(κGAL²)`). The integrands are
//! polynomials of degree at most 8 for the sections femu reads (linear `A`, `I`; or dimensions
//! linear, properties polynomial in them of degree ≤ 4), which the 8-point rule integrates
//! exactly on each interval. **Lumped**: each end takes the share of the total mass given by
//! the first moment of the mass distribution, `m_A = ∫ m̄ (1 − ξ) ds`, `m_B = ∫ m̄ ξ ds`, so
//! the total and the centre of mass are exact (Nastran puts half at each end of a uniform
//! beam, which this is then); the twist inertia and the rotary inertia are split alike, and the
//! bending rotations add the HRZ share `m_A M₂₂/M₁₁` (`m_B M₄₄/M₃₃`) of the consistent
//! translational mass, as the uniform beam does.
//!
//! **Derivatives.** The local kernel runs over the same scalar type as the uniform beam's, with
//! dual numbers seeded by `∂E`, `∂ρ` or the section's exact derivatives at every quadrature
//! point (the subdivision is fixed by the values): the chain rule carried out exactly,
//! inversion of `F` included.
//!
//! **Rods** ([`tapered_rod2`]): axial `1/∫ds/EA`, torsional `1/∫ds/GJ`, mass `∫ m̄ NᵢNⱼ ds`
//! with the linear `Nᵢ` on each translation (consistent) or the first-moment split (lumped),
//! no torsional inertia, as [`super::rod`].
//!
//! **Shear centre** ([`tapered_beam2_centred`]): the centroid and NSM at constant offsets from
//! the axis, transformed as for the uniform beam ([`super::beam_offset`]).

use super::beam::Section;
use super::beam::{
    BeamParameter, Dual, EndConditions, LocalPair, Scalar, SectionProperties, XY_DOFS, XY_SIGNS,
    XZ_DOFS, XZ_SIGNS, condense, ends_frame, offset_grid, pair, poisson, scatter, tangent,
    to_basic,
};
use super::beam_offset::{SectionCentres, about_shear_centre};
use super::element::{ElementDerivative, ElementError, ElementMatrices, MassKind, positive};
use crate::model::{BeamProperty, BeamSection, BeamTaper};
use faer::Mat;
use std::sync::OnceLock;

/// Gauss–Legendre points per interval.
const GAUSS_POINTS: usize = 8;

/// Relative change of a flexibility under bisection at which an interval is accepted.
const QUADRATURE_TOL: f64 = 1e-14;

/// Bisection depth limit (an interval of `2⁻²⁴` of a station interval).
const MAX_DEPTH: u32 = 24;

/// What varies along a tapered beam.
pub trait Taper {
    /// Station positions `ξ` from 0 to 1, increasing; the properties are smooth between them.
    fn breaks(&self) -> &[f64];

    /// Section properties and non-structural mass at `ξ` and their derivatives by `p` (zero
    /// when `p` is `None` or does not change the section); an error when `p` has no meaning
    /// for this beam or the section at `ξ` is not valid.
    fn at(
        &self,
        xi: f64,
        p: Option<BeamParameter>,
    ) -> Result<(SectionProperties, f64, SectionProperties, f64), ElementError>;
}

/// Material and variation of a tapered beam.
pub struct TaperedBeam<'a> {
    /// Young's modulus `E`, Pa.
    pub e: f64,
    /// Poisson's ratio `ν`; `G = E / (2(1+ν))`.
    pub nu: f64,
    /// Density `ρ`, kg/m³.
    pub rho: f64,
    /// Sections along the beam.
    pub taper: &'a dyn Taper,
}

/// Gauss–Legendre nodes and weights on `[−1, 1]` (Newton on `P_n`, Golub–Welsch-free).
fn gauss() -> &'static [(f64, f64); GAUSS_POINTS] {
    static RULE: OnceLock<[(f64, f64); GAUSS_POINTS]> = OnceLock::new();
    RULE.get_or_init(|| {
        let n = GAUSS_POINTS;
        let mut out = [(0.0, 0.0); GAUSS_POINTS];
        for (i, o) in out.iter_mut().enumerate() {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                // P_n(x) and P_n'(x) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let kf = k as f64;
                    let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            *o = (x, 2.0 / ((1.0 - x * x) * dp * dp));
        }
        out
    })
}

/// One quadrature point: position, weight (including `L`) and the varying quantities.
#[derive(Clone, Copy)]
struct Point<T> {
    xi: f64,
    w: f64,
    area: T,
    iy: T,
    iz: T,
    j: T,
    ip: T,
    inv_kappa_y: T,
    inv_kappa_z: T,
    nsm: T,
}

/// The value of a quadrature point's NSM (of an `f64` or dual point).
trait NsmValue {
    fn nsm_value(&self) -> f64;
}

impl NsmValue for Point<f64> {
    fn nsm_value(&self) -> f64 {
        self.nsm
    }
}

impl NsmValue for Point<Dual> {
    fn nsm_value(&self) -> f64 {
        self.nsm.v
    }
}

/// `1/κ`, zero for a shear-rigid (infinite) `κ`.
fn inverse(kappa: f64) -> f64 {
    if kappa.is_infinite() {
        0.0
    } else {
        1.0 / kappa
    }
}

/// The flexibility integrands per `1/E` (with `G = E/r`, `r = E/G`): `1/A`, `1/J` (or 0),
/// and per plane `1/I · (1, ρ, ρ²)` and `r/(κA)`.
fn integrands(p: &SectionProperties, xi: f64, r: f64, torsion: bool) -> [f64; 10] {
    let a = 1.0 - xi;
    [
        1.0 / p.area,
        if torsion { r / p.j } else { 0.0 },
        1.0 / p.iz,
        a / p.iz,
        a * a / p.iz,
        r * inverse(p.kappa_y) / p.area,
        1.0 / p.iy,
        a / p.iy,
        a * a / p.iy,
        r * inverse(p.kappa_z) / p.area,
    ]
}

/// Gauss sums of [`integrands`] over `[a, b]` (in `ξ`).
fn interval_sum(
    taper: &dyn Taper,
    (a, b): (f64, f64),
    r: f64,
    torsion: bool,
) -> Result<[f64; 10], ElementError> {
    let mut s = [0.0; 10];
    let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
    for &(x, w) in gauss() {
        let xi = mid + half * x;
        let (p, _, _, _) = taper.at(xi, None)?;
        for (si, v) in s.iter_mut().zip(integrands(&p, xi, r, torsion)) {
            *si += w * half * v;
        }
    }
    Ok(s)
}

/// Intervals of `ξ` on which the Gauss rule has converged (bisecting each station interval
/// until halving changes no flexibility by more than [`QUADRATURE_TOL`] of itself).
fn intervals(taper: &dyn Taper, r: f64, torsion: bool) -> Result<Vec<(f64, f64)>, ElementError> {
    let mut out = Vec::new();
    for seg in taper.breaks().windows(2) {
        if seg[1] <= seg[0] {
            continue;
        }
        let mut stack = vec![(
            (seg[0], seg[1]),
            interval_sum(taper, (seg[0], seg[1]), r, torsion)?,
            0,
        )];
        while let Some(((a, b), whole, depth)) = stack.pop() {
            let m = 0.5 * (a + b);
            let left = interval_sum(taper, (a, m), r, torsion)?;
            let right = interval_sum(taper, (m, b), r, torsion)?;
            let converged = (0..10).all(|i| {
                let halves = left[i] + right[i];
                (halves - whole[i]).abs() <= QUADRATURE_TOL * halves.abs()
            });
            if converged || depth >= MAX_DEPTH {
                out.push((a, m));
                out.push((m, b));
            } else {
                stack.push(((m, b), right, depth + 1));
                stack.push(((a, m), left, depth + 1));
            }
        }
    }
    out.sort_by(|x, y| x.0.total_cmp(&y.0));
    Ok(out)
}

/// The quadrature points of a tapered beam of length `l`, as values and as duals seeded with
/// the derivatives by `p`.
fn points(
    taper: &dyn Taper,
    nu: f64,
    l: f64,
    p: Option<BeamParameter>,
) -> Result<(Vec<Point<Dual>>, bool), ElementError> {
    poisson(nu)?;
    let breaks = taper.breaks();
    let well_formed = breaks.len() >= 2
        && breaks[0] == 0.0
        && breaks[breaks.len() - 1] == 1.0
        && breaks.windows(2).all(|w| w[0] <= w[1]);
    if !well_formed {
        return Err(ElementError::Degenerate(format!(
            "the stations of a tapered beam must run from 0 (end A) to 1 (end B) in order; got {breaks:?}"
        )));
    }
    // Torsion: J > 0 at every station, or 0 at all (no torsional stiffness, as the uniform beam).
    let mut js = Vec::with_capacity(breaks.len());
    for &x in breaks {
        let (s, nsm, _, _) = taper.at(x, None)?;
        for (field, v, zero) in [
            ("area", s.area, false),
            ("iy", s.iy, false),
            ("iz", s.iz, false),
            ("j", s.j, true),
            ("nsm", nsm, true),
        ] {
            positive(field, v, zero)?;
        }
        js.push(s.j);
    }
    let torsion = js.iter().any(|j| *j > 0.0);
    if torsion && js.contains(&0.0) {
        return Err(ElementError::Degenerate(format!(
            "the torsion constant J of a tapered beam is 0 at some stations and not at others ({js:?}); give J > 0 at every station or 0 at all"
        )));
    }
    let r = 2.0 * (1.0 + nu);
    let mut out = Vec::new();
    for (a, b) in intervals(taper, r, torsion)? {
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for &(x, w) in gauss() {
            let xi = mid + half * x;
            let (s, nsm, ds, dnsm) = taper.at(xi, p)?;
            let dual = |v: f64, d: f64| Dual { v, d };
            // d(1/κ) = −dκ/κ²; zero for a shear-rigid section.
            let inv =
                |k: f64, dk: f64| dual(inverse(k), if dk == 0.0 { 0.0 } else { -dk / (k * k) });
            out.push(Point {
                xi,
                w: w * half * l,
                area: dual(s.area, ds.area),
                iy: dual(s.iy, ds.iy),
                iz: dual(s.iz, ds.iz),
                j: dual(s.j, ds.j),
                ip: dual(s.ip, ds.ip),
                inv_kappa_y: inv(s.kappa_y, ds.kappa_y),
                inv_kappa_z: inv(s.kappa_z, ds.kappa_z),
                nsm: dual(nsm, dnsm),
            });
        }
    }
    Ok((out, torsion))
}

/// Inverse of a symmetric 2 × 2 matrix `[[a, b], [b, d]]`.
fn inverse2<T: Scalar>(a: T, b: T, d: T) -> [[T; 2]; 2] {
    let det = a * d - b * b;
    [[d / det, -(b / det)], [-(b / det), a / det]]
}

/// Bending stiffness of one plane (`w1, θ1, w2, θ2`) from its flexibility: `Hᵀ F⁻¹ H`.
fn plane_stiffness<T: Scalar>(f11: T, f12: T, f22: T, l: f64) -> [[T; 4]; 4] {
    let kbb = inverse2(f11, f12, f22);
    let c = T::cst;
    let h = [
        [c(-1.0), c(-l), c(1.0), c(0.0)],
        [c(0.0), c(-1.0), c(0.0), c(1.0)],
    ];
    let mut k = [[c(0.0); 4]; 4];
    for (a, row) in k.iter_mut().enumerate() {
        for (b, v) in row.iter_mut().enumerate() {
            let mut s = c(0.0);
            for p in 0..2 {
                for q in 0..2 {
                    s = s + h[p][a] * kbb[p][q] * h[q][b];
                }
            }
            *v = s;
        }
    }
    k
}

/// Timoshenko interpolation of the uniform element at `ξ`: `w` (`N`) and `θ` (`G`) per DOF
/// `(w1, θ1, w2, θ2)` for shear parameter `Φ` (Przemieniecki 1968; Friedman & Kosmatka 1993).
fn shapes<T: Scalar>(xi: f64, phi: T, l: f64) -> ([T; 4], [T; 4]) {
    let c = T::cst;
    let d = c(1.0) / (c(1.0) + phi);
    let (x2, x3) = (xi * xi, xi * xi * xi);
    let n = [
        (c(1.0 - 3.0 * x2 + 2.0 * x3) + phi * c(1.0 - xi)) * d,
        (c(l * (xi - 2.0 * x2 + x3)) + phi * c(0.5 * l * (xi - x2))) * d,
        (c(3.0 * x2 - 2.0 * x3) + phi * c(xi)) * d,
        (c(l * (x3 - x2)) - phi * c(0.5 * l * (xi - x2))) * d,
    ];
    let g = [
        c(6.0 * (x2 - xi) / l) * d,
        (c(1.0 - 4.0 * xi + 3.0 * x2) + phi * c(1.0 - xi)) * d,
        c(-6.0 * (x2 - xi) / l) * d,
        (c(3.0 * x2 - 2.0 * xi) + phi * c(xi)) * d,
    ];
    (n, g)
}

/// One bending plane's consistent translational (`m̄ N Nᵀ`) and rotary (`ρI G Gᵀ`) mass.
fn plane_mass<T: Scalar>(
    pts: &[Point<T>],
    mbar: &[T],
    rho_i: &[T],
    phi: T,
    l: f64,
) -> ([[T; 4]; 4], [[T; 4]; 4]) {
    let zero = T::cst(0.0);
    let mut mt = [[zero; 4]; 4];
    let mut mr = [[zero; 4]; 4];
    for ((p, m), ri) in pts.iter().zip(mbar).zip(rho_i) {
        let (n, g) = shapes(p.xi, phi, l);
        let (wm, wr) = (*m * T::cst(p.w), *ri * T::cst(p.w));
        for a in 0..4 {
            for b in 0..4 {
                mt[a][b] = mt[a][b] + wm * n[a] * n[b];
                mr[a][b] = mr[a][b] + wr * g[a] * g[b];
            }
        }
    }
    (mt, mr)
}

/// `(∫ f (1 − ξ), ∫ f ξ)`: the first-moment split of `∫ f` to the ends.
fn split<T: Scalar>(pts: &[Point<T>], f: &[T]) -> (T, T) {
    let zero = T::cst(0.0);
    pts.iter().zip(f).fold((zero, zero), |(a, b), (p, v)| {
        (
            a + *v * T::cst(p.w * (1.0 - p.xi)),
            b + *v * T::cst(p.w * p.xi),
        )
    })
}

/// Local stiffness and mass of a tapered beam (12 × 12, local frame).
fn local_matrices<T: Scalar>(
    l: f64,
    pts: &[Point<T>],
    torsion: bool,
    (e, g, rho): (T, T, T),
    kind: MassKind,
) -> LocalPair<T> {
    let c = T::cst;
    let zero = c(0.0);
    let mut k = [[zero; 12]; 12];
    let mut m = [[zero; 12]; 12];
    let sum = |f: &dyn Fn(&Point<T>) -> T| pts.iter().fold(zero, |s, p| s + f(p) * c(p.w));

    let ea = c(1.0) / sum(&|p| c(1.0) / (e * p.area));
    pair(&mut k, 0, 6, ea, -ea);
    if torsion {
        let gj = c(1.0) / sum(&|p| c(1.0) / (g * p.j));
        pair(&mut k, 3, 9, gj, -gj);
    }
    let mut phis = [zero; 2];
    for (plane, (dofs, signs)) in [(XY_DOFS, XY_SIGNS), (XZ_DOFS, XZ_SIGNS)]
        .into_iter()
        .enumerate()
    {
        let i = |p: &Point<T>| if plane == 0 { p.iz } else { p.iy };
        let inv_kappa = |p: &Point<T>| {
            if plane == 0 {
                p.inv_kappa_y
            } else {
                p.inv_kappa_z
            }
        };
        let f22 = sum(&|p| c(1.0) / (e * i(p)));
        let f12 = sum(&|p| c(l * (1.0 - p.xi)) / (e * i(p)));
        let shear = sum(&|p| inv_kappa(p) / (g * p.area));
        let f11 = sum(&|p| c((l * (1.0 - p.xi)).powi(2)) / (e * i(p))) + shear;
        scatter(&mut k, &plane_stiffness(f11, f12, f22, l), dofs, signs);
        phis[plane] = c(12.0 / (l * l)) * shear / f22;
    }

    let mbar: Vec<T> = pts.iter().map(|p| rho * p.area + p.nsm).collect();
    let rho_ip: Vec<T> = pts.iter().map(|p| rho * p.ip).collect();
    let rho_iz: Vec<T> = pts.iter().map(|p| rho * p.iz).collect();
    let rho_iy: Vec<T> = pts.iter().map(|p| rho * p.iy).collect();
    let planes = [
        (XY_DOFS, XY_SIGNS, &rho_iz, phis[0]),
        (XZ_DOFS, XZ_SIGNS, &rho_iy, phis[1]),
    ];
    match kind {
        MassKind::Consistent => {
            let lin = |f: &[T]| {
                let mut s = [zero; 3];
                for (p, v) in pts.iter().zip(f) {
                    let w = *v * c(p.w);
                    s[0] = s[0] + w * c((1.0 - p.xi) * (1.0 - p.xi));
                    s[1] = s[1] + w * c((1.0 - p.xi) * p.xi);
                    s[2] = s[2] + w * c(p.xi * p.xi);
                }
                s
            };
            for (a, b, f) in [(0, 6, &mbar), (3, 9, &rho_ip)] {
                let s = lin(f);
                m[a][a] = m[a][a] + s[0];
                m[b][b] = m[b][b] + s[2];
                m[a][b] = m[a][b] + s[1];
                m[b][a] = m[b][a] + s[1];
            }
            for (dofs, signs, rho_i, phi) in planes {
                let (mt, mr) = plane_mass(pts, &mbar, rho_i, phi, l);
                let mut sum4 = [[zero; 4]; 4];
                for a in 0..4 {
                    for b in 0..4 {
                        sum4[a][b] = mt[a][b] + mr[a][b];
                    }
                }
                scatter(&mut m, &sum4, dofs, signs);
            }
        }
        MassKind::Lumped => {
            let (ma, mb) = split(pts, &mbar);
            let (ta, tb) = split(pts, &rho_ip);
            m[0][0] = ma;
            m[6][6] = mb;
            m[3][3] = ta;
            m[9][9] = tb;
            for (dofs, _, rho_i, phi) in planes {
                let (mt, _) = plane_mass(pts, &mbar, rho_i, phi, l);
                let (ra, rb) = split(pts, rho_i);
                let diag = [
                    ma,
                    ma * mt[1][1] / mt[0][0] + ra,
                    mb,
                    mb * mt[3][3] / mt[2][2] + rb,
                ];
                for (dof, v) in dofs.into_iter().zip(diag) {
                    m[dof][dof] = m[dof][dof] + v;
                }
            }
        }
    }
    (k, m)
}

/// Checks the material of a tapered element.
fn material(e: f64, nu: f64, rho: f64) -> Result<(), ElementError> {
    positive("e", e, false)?;
    positive("rho", rho, true)?;
    poisson(nu)?;
    Ok(())
}

/// The material scalars as duals seeded by `p`.
fn material_duals(b: &TaperedBeam, p: Option<BeamParameter>) -> (Dual, Dual, Dual) {
    let g = b.e / (2.0 * (1.0 + b.nu));
    let (de, drho) = match p {
        Some(BeamParameter::YoungsModulus) => (1.0, 0.0),
        Some(BeamParameter::Density) => (0.0, 1.0),
        _ => (0.0, 0.0),
    };
    (
        Dual { v: b.e, d: de },
        Dual {
            v: g,
            d: de * g / b.e,
        },
        Dual { v: b.rho, d: drho },
    )
}

/// Stiffness and mass (12 × 12, basic system) of a tapered beam from node 1 at `x1` (end A) to
/// node 2 at `x2` (end B), orientation vector `v`, offsets and pin flags `ends`.
pub fn tapered_beam2(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    b: &TaperedBeam,
    mass: MassKind,
    ends: &EndConditions,
) -> Result<ElementMatrices, ElementError> {
    tapered_beam2_centred(x1, x2, v, b, mass, ends, &SectionCentres::default())
}

/// The local pair about the shear centre ([`super::beam_offset`]); the centroidal pair itself
/// when `centres` is zero. The structural mass is `ρ` times that of unit density (the mass is
/// linear in `ρ`; the lumped HRZ share divides by the translational mass, which is then never
/// zero): its translational part is that of the area taken as an NSM, its rotary and
/// torsional part the rest; the non-structural one is left out when the NSM is zero
/// everywhere.
fn local_pair<T: Scalar>(
    l: f64,
    pts: &[Point<T>],
    torsion: bool,
    (e, g, rho): (T, T, T),
    kind: MassKind,
    centres: &SectionCentres,
) -> LocalPair<T>
where
    Point<T>: NsmValue,
{
    if centres.is_zero() {
        return local_matrices(l, pts, torsion, (e, g, rho), kind);
    }
    let zero = T::cst(0.0);
    // Unit density: all of it, and its translational part alone (the area as an NSM).
    let bare: Vec<Point<T>> = pts.iter().map(|p| Point { nsm: zero, ..*p }).collect();
    let (k, unit) = local_matrices(l, &bare, torsion, (e, g, T::cst(1.0)), kind);
    let areas: Vec<Point<T>> = pts.iter().map(|p| Point { nsm: p.area, ..*p }).collect();
    let (_, unit_translation) = local_matrices(l, &areas, torsion, (e, g, zero), kind);
    let m_structural = unit_translation.map(|row| row.map(|x| rho * x));
    let mut m_rotary = unit;
    for (row, t) in m_rotary.iter_mut().zip(&unit_translation) {
        for (x, y) in row.iter_mut().zip(t) {
            *x = rho * (*x - *y);
        }
    }
    let m_nsm = if pts.iter().any(|p| p.nsm_value() != 0.0) {
        local_matrices(l, pts, torsion, (e, g, zero), kind).1
    } else {
        [[zero; 12]; 12]
    };
    about_shear_centre(&k, [&m_rotary, &m_structural, &m_nsm], centres, l, kind)
}

/// [`tapered_beam2`] whose axis is the shear centre, with the centroid and NSM at the constant
/// offsets `centres` from it (see [`super::beam_offset`]).
pub fn tapered_beam2_centred(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    b: &TaperedBeam,
    mass: MassKind,
    ends: &EndConditions,
    centres: &SectionCentres,
) -> Result<ElementMatrices, ElementError> {
    let frame = ends_frame(x1, x2, v, ends)?;
    material(b.e, b.nu, b.rho)?;
    centres.validate()?;
    let (pts, torsion) = points(b.taper, b.nu, frame.length, None)?;
    let pts: Vec<Point<f64>> = pts.iter().map(value_point).collect();
    let g = b.e / (2.0 * (1.0 + b.nu));
    let (k, m) = local_pair(frame.length, &pts, torsion, (b.e, g, b.rho), mass, centres);
    let (k, m) = condense(&k, &m, &ends.released(), |x| x)?;
    Ok(ElementMatrices {
        k: offset_grid(to_basic(&k, &frame.axes)?, ends),
        m: offset_grid(to_basic(&m, &frame.axes)?, ends),
    })
}

fn value_point(p: &Point<Dual>) -> Point<f64> {
    Point {
        xi: p.xi,
        w: p.w,
        area: p.area.v,
        iy: p.iy.v,
        iz: p.iz.v,
        j: p.j.v,
        ip: p.ip.v,
        inv_kappa_y: p.inv_kappa_y.v,
        inv_kappa_z: p.inv_kappa_z.v,
        nsm: p.nsm.v,
    }
}

/// Exact `∂K/∂φ`, `∂M/∂φ` (basic system) of [`tapered_beam2`] by one parameter: `E`, `ρ`, or
/// whatever the [`Taper`] differentiates.
pub fn tapered_beam2_derivative(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    b: &TaperedBeam,
    mass: MassKind,
    p: BeamParameter,
    ends: &EndConditions,
) -> Result<ElementDerivative, ElementError> {
    tapered_beam2_centred_derivative(x1, x2, v, b, mass, p, ends, &SectionCentres::default())
}

/// Exact `∂K/∂φ`, `∂M/∂φ` of [`tapered_beam2_centred`]: the shear-centre transforms are
/// constant. The offsets must not depend on the parameter (the caller refuses a section
/// dimension of a library section whose shear centre is off its centroid).
#[allow(clippy::too_many_arguments)]
pub fn tapered_beam2_centred_derivative(
    x1: [f64; 3],
    x2: [f64; 3],
    v: [f64; 3],
    b: &TaperedBeam,
    mass: MassKind,
    p: BeamParameter,
    ends: &EndConditions,
    centres: &SectionCentres,
) -> Result<ElementDerivative, ElementError> {
    let frame = ends_frame(x1, x2, v, ends)?;
    material(b.e, b.nu, b.rho)?;
    centres.validate()?;
    let section_p =
        (!matches!(p, BeamParameter::YoungsModulus | BeamParameter::Density)).then_some(p);
    let (pts, torsion) = points(b.taper, b.nu, frame.length, section_p)?;
    let (k, m) = local_pair(
        frame.length,
        &pts,
        torsion,
        material_duals(b, Some(p)),
        mass,
        centres,
    );
    let (k, m) = condense(&k, &m, &ends.released(), |x: Dual| x.v)?;
    Ok(ElementDerivative {
        dk: offset_grid(to_basic(&tangent(&k), &frame.axes)?, ends),
        dm: offset_grid(to_basic(&tangent(&m), &frame.axes)?, ends),
    })
}

/// Material and variation of a tapered rod: properties `(A, J, NSM)` at `ξ`.
pub struct TaperedRod<'a> {
    /// Young's modulus `E`, Pa.
    pub e: f64,
    /// Poisson's ratio `ν`.
    pub nu: f64,
    /// Density `ρ`, kg/m³.
    pub rho: f64,
    /// `(A, J, NSM)` at `ξ ∈ [0, 1]`, smooth over the whole length.
    pub at: &'a dyn Fn(f64) -> (f64, f64, f64),
}

/// A tapered rod's quadrature point: `ξ`, weight (with `L`), `[A, J, NSM]`.
type RodPoint = (f64, f64, [f64; 3]);

/// The Gauss points of a tapered rod, with `(A, J, NSM)`; the subdivision as for beams.
fn rod_points(r: &TaperedRod, l: f64) -> Result<(Vec<RodPoint>, bool), ElementError> {
    positive("e", r.e, false)?;
    positive("rho", r.rho, true)?;
    if !(r.nu.is_finite() && r.nu > -1.0 && r.nu <= 0.5) {
        return Err(ElementError::BadValue {
            field: "nu",
            value: r.nu,
            hint: "must be finite with -1 < nu <= 0.5",
        });
    }
    let (a0, j0, n0) = (r.at)(0.0);
    let (a1, j1, n1) = (r.at)(1.0);
    for (field, v, zero) in [
        ("area", a0, false),
        ("area", a1, false),
        ("j", j0, true),
        ("j", j1, true),
        ("nsm", n0, true),
        ("nsm", n1, true),
    ] {
        positive(field, v, zero)?;
    }
    let torsion = j0 > 0.0 || j1 > 0.0;
    if torsion && (j0 == 0.0 || j1 == 0.0) {
        return Err(ElementError::Degenerate(format!(
            "the torsion constant of a tapered rod is 0 at one end and {} at the other",
            j0.max(j1)
        )));
    }
    struct Rod<'b>(&'b TaperedRod<'b>, [f64; 2]);
    impl Taper for Rod<'_> {
        fn breaks(&self) -> &[f64] {
            &self.1
        }
        fn at(
            &self,
            xi: f64,
            _: Option<BeamParameter>,
        ) -> Result<(SectionProperties, f64, SectionProperties, f64), ElementError> {
            let (area, j, nsm) = (self.0.at)(xi);
            let s = SectionProperties {
                area,
                iy: 1.0,
                iz: 1.0,
                j,
                ip: 0.0,
                kappa_y: f64::INFINITY,
                kappa_z: f64::INFINITY,
            };
            Ok((s, nsm, SectionProperties::default(), 0.0))
        }
    }
    let rod = Rod(r, [0.0, 1.0]);
    let mut out = Vec::new();
    for (a, b) in intervals(&rod, 2.0 * (1.0 + r.nu), torsion)? {
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for &(x, w) in gauss() {
            let xi = mid + half * x;
            let (area, j, nsm) = (r.at)(xi);
            out.push((xi, w * half * l, [area, j, nsm]));
        }
    }
    Ok((out, torsion))
}

/// The rod's 2 × 2 mass `[[∫m̄(1−ξ)², ∫m̄ξ(1−ξ)], [·, ∫m̄ξ²]]` (consistent) or the first-moment
/// split (lumped), on each translation, for mass per length `m̄ = ρ A + NSM · with_nsm`.
fn rod_mass(pts: &[RodPoint], rho: f64, with_nsm: f64, kind: MassKind) -> Mat<f64> {
    let mut s = [0.0; 3];
    for (xi, w, [area, _, nsm]) in pts {
        let mw = (rho * area + with_nsm * nsm) * w;
        s[0] += mw * (1.0 - xi) * (1.0 - xi);
        s[1] += mw * (1.0 - xi) * xi;
        s[2] += mw * xi * xi;
    }
    let m = match kind {
        MassKind::Consistent => [[s[0], s[1]], [s[1], s[2]]],
        MassKind::Lumped => [[s[0] + s[1], 0.0], [0.0, s[1] + s[2]]],
    };
    Mat::from_fn(12, 12, |r, c| {
        if r % 6 >= 3 || r % 6 != c % 6 {
            0.0
        } else {
            m[r / 6][c / 6]
        }
    })
}

/// Axial and torsional stiffness `(1/∫ds/EA, 1/∫ds/GJ)` per unit `E`.
fn rod_stiffness(pts: &[RodPoint], nu: f64, torsion: bool) -> (f64, f64) {
    let fa: f64 = pts.iter().map(|(_, w, [a, _, _])| w / a).sum();
    let ft: f64 = pts.iter().map(|(_, w, [_, j, _])| w / j).sum();
    let g = 1.0 / (2.0 * (1.0 + nu));
    (1.0 / fa, if torsion { g / ft } else { 0.0 })
}

/// Stiffness and mass of a tapered rod from `x1` (end A) to `x2` (end B), basic system.
pub fn tapered_rod2(
    x1: [f64; 3],
    x2: [f64; 3],
    r: &TaperedRod,
    kind: MassKind,
) -> Result<ElementMatrices, ElementError> {
    let (axis, l) = super::rod::axis(x1, x2)?;
    let (pts, torsion) = rod_points(r, l)?;
    let (ka, kt) = rod_stiffness(&pts, r.nu, torsion);
    Ok(ElementMatrices {
        k: super::rod::stiffness(axis, r.e * ka, r.e * kt),
        m: rod_mass(&pts, r.rho, 1.0, kind),
    })
}

/// Exact derivative of [`tapered_rod2`]: `K` is linear in `E` (`ν` fixed) and `M` in `ρ`, so
/// `∂K/∂E = K/E` and `∂M/∂ρ = M(ρ = 1, NSM = 0)` (the first-moment split is linear too).
pub fn tapered_rod2_derivative(
    x1: [f64; 3],
    x2: [f64; 3],
    r: &TaperedRod,
    kind: MassKind,
    p: super::rod::RodParameter,
) -> Result<ElementDerivative, ElementError> {
    let (axis, l) = super::rod::axis(x1, x2)?;
    let (pts, torsion) = rod_points(r, l)?;
    Ok(match p {
        super::rod::RodParameter::YoungsModulus => {
            let (ka, kt) = rod_stiffness(&pts, r.nu, torsion);
            ElementDerivative {
                dk: super::rod::stiffness(axis, ka, kt),
                dm: Mat::zeros(12, 12),
            }
        }
        super::rod::RodParameter::Density => ElementDerivative {
            dk: Mat::zeros(12, 12),
            dm: rod_mass(&pts, 1.0, 0.0, kind),
        },
    })
}

/// The [`Taper`] of a model beam property with stations (see [`BeamTaper`]): PBEAM's
/// `A, I1, I2, J, NSM` or PBEAML's dimensions and NSM linear between stations.
///
/// Dimension parameters (PBEAML `BAR`: `width` = DIM1, `height` = DIM2) scale that dimension
/// at every station in proportion, the parameter's value being end A's: at `ξ` the dimension
/// is `d(ξ) = φ d̂(ξ)` with `d̂` the stations' shape, so `∂d(ξ)/∂φ = d(ξ)/d_A`.
pub struct PropertyTaper<'a> {
    taper: &'a BeamTaper,
    /// Shear factors of a PBEAM (`K1`, `K2`; 0 = shear-rigid).
    shear: (f64, f64),
    nu: f64,
    breaks: Vec<f64>,
}

impl<'a> PropertyTaper<'a> {
    /// The taper of `property` for Poisson's ratio `nu`; `None` when it has no stations.
    pub fn new(property: &'a BeamProperty, nu: f64) -> Option<PropertyTaper<'a>> {
        let taper = property.taper.as_ref()?;
        let shear = match property.section {
            BeamSection::General {
                shear_y, shear_z, ..
            } => (shear_y, shear_z),
            _ => (0.0, 0.0),
        };
        Some(PropertyTaper {
            taper,
            shear,
            nu,
            breaks: taper.stations.iter().map(|s| s.x).collect(),
        })
    }

    /// Values and NSM linearly interpolated at `xi`.
    fn values(&self, xi: f64) -> (Vec<f64>, f64) {
        let st = &self.taper.stations;
        let i = st
            .windows(2)
            .position(|w| xi <= w[1].x && w[1].x > w[0].x)
            .unwrap_or(st.len().saturating_sub(2));
        let (a, b) = (&st[i], &st[(i + 1).min(st.len() - 1)]);
        let t = if b.x > a.x {
            ((xi - a.x) / (b.x - a.x)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let lerp = |u: f64, v: f64| u + t * (v - u);
        let values = a
            .values
            .iter()
            .zip(&b.values)
            .map(|(u, v)| lerp(*u, *v))
            .collect();
        (values, lerp(a.nsm, b.nsm))
    }

    fn unknown(&self, p: BeamParameter) -> ElementError {
        let (element, valid) = match self.taper.library.as_deref() {
            None => ("a tapered beam (PBEAM stations)", "youngs_modulus, density"),
            Some("BAR") => (
                "a tapered BAR beam (PBEAML stations)",
                "youngs_modulus, density, width, height",
            ),
            Some(_) => (
                "a tapered library beam (PBEAML stations)",
                "youngs_modulus, density",
            ),
        };
        ElementError::UnknownParameter {
            parameter: p.name(),
            element,
            valid,
        }
    }
}

impl Taper for PropertyTaper<'_> {
    fn breaks(&self) -> &[f64] {
        &self.breaks
    }

    fn at(
        &self,
        xi: f64,
        p: Option<BeamParameter>,
    ) -> Result<(SectionProperties, f64, SectionProperties, f64), ElementError> {
        let (d, nsm) = self.values(xi);
        let zero = SectionProperties::default();
        let kappa = |k: f64| if k > 0.0 { k } else { f64::INFINITY };
        let short = || {
            ElementError::Degenerate(format!(
                "a tapered beam station has {} values, fewer than its section needs",
                d.len()
            ))
        };
        let Some(kind) = self.taper.library.as_deref() else {
            if let Some(p) = p {
                return Err(self.unknown(p));
            }
            let [area, i1, i2, j] = d[..] else {
                return Err(short());
            };
            let s = SectionProperties {
                area,
                iy: i2,
                iz: i1,
                j,
                ip: i1 + i2,
                kappa_y: kappa(self.shear.0),
                kappa_z: kappa(self.shear.1),
            };
            return Ok((s, nsm, zero, 0.0));
        };
        let own = match (kind, &d[..]) {
            ("BAR", [w, h, ..]) => Some((
                Section::Rectangle {
                    width: *w,
                    height: *h,
                },
                [*w, *h],
            )),
            ("ROD", [r, ..]) => Some((Section::Circle { radius: *r }, [*r, 0.0])),
            ("TUBE", [ro, ri, ..]) => Some((
                Section::Tube {
                    outer_radius: *ro,
                    inner_radius: *ri,
                },
                [*ro, *ri],
            )),
            ("TUBE2", [ro, t, ..]) => Some((
                Section::Tube {
                    outer_radius: *ro,
                    inner_radius: ro - t,
                },
                [*ro, ro - t],
            )),
            ("BAR" | "ROD" | "TUBE" | "TUBE2", _) => return Err(short()),
            _ => None,
        };
        if let Some((section, _)) = own {
            let q = match (kind, p) {
                (_, None) => None,
                ("BAR", Some(BeamParameter::Width | BeamParameter::Height)) => p,
                (_, Some(p)) => return Err(self.unknown(p)),
            };
            let (s, ds) = section.evaluate(self.nu, q)?;
            // d(ξ)/d_A: the chain factor of a dimension scaled at every station.
            let factor = match q {
                Some(BeamParameter::Width) => d[0] / self.taper.stations[0].values[0],
                Some(BeamParameter::Height) => d[1] / self.taper.stations[0].values[1],
                _ => 0.0,
            };
            let ds = SectionProperties {
                area: ds.area * factor,
                iy: ds.iy * factor,
                iz: ds.iz * factor,
                j: ds.j * factor,
                ip: ds.ip * factor,
                kappa_y: ds.kappa_y * factor,
                kappa_z: ds.kappa_z * factor,
            };
            return Ok((s, nsm, ds, 0.0));
        }
        if let Some(p) = p {
            return Err(self.unknown(p));
        }
        let values = crate::model::sections::library_values(kind, &d)
            .unwrap_or_else(|| {
                Err(crate::model::sections::SectionError {
                    what: format!("type {kind} is not in femu's library"),
                })
            })
            .map_err(|e| {
                ElementError::Degenerate(format!(
                    "the tapered {kind} section at x/L = {xi} (dimensions {d:?}) is not valid: {}",
                    e.what
                ))
            })?;
        let (v, _) = crate::model::sections::principal(&values);
        let s = SectionProperties {
            area: v.area,
            iy: v.i2,
            iz: v.i1,
            j: v.j,
            ip: v.i1 + v.i2,
            kappa_y: kappa(v.k1),
            kappa_z: kappa(v.k2),
        };
        Ok((s, nsm, zero, 0.0))
    }
}

#[cfg(test)]
#[path = "beam_tapered_tests.rs"]
pub(crate) mod tests;
