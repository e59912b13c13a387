//! The two-node rod (Nastran CROD, CONROD, CTUBE): tension–compression and torsion, nothing else.
//!
//! **Stiffness.** With the unit axis `e = (x₂ − x₁)/L`, the axial stiffness `k_a = E A / L` acts on
//! the translations along `e` and the torsional stiffness `k_t = G J / L` (`G = E/(2(1 + ν))`) on
//! the rotations about `e`: `K = k_a [[P, −P], [−P, P]]` on the translations plus
//! `k_t [[P, −P], [−P, P]]` on the rotations, `P = e eᵀ`, in the basic system. A rod gives no
//! lateral or bending stiffness, so a grid held only by rods has its lateral translations and
//! its rotations free (or dropped when nothing gives them mass either, as Nastran's AUTOSPC does).
//!
//! **Mass** (mass per length `μ = ρ A + nsm`, element mass `m = μ L`). Lumped (Nastran's default,
//! `COUPMASS` off): `m/2` on each end's three translations. Consistent (Nastran's coupled rod
//! mass): `m/6 [[2, 1], [1, 2]]` on each of the three translations, so the rod carries its mass
//! laterally as well as along its axis (the same linear interpolation in every direction, hence
//! isotropic blocks that need no rotation). Neither includes torsional inertia: Nastran's rod mass
//! is translational only (its element mass tables list no polar inertia for CROD), and femu
//! follows it, so a rotation about the axis of a rod alone has stiffness without mass.
//!
//! **Derivatives** (docs/theory.md §2, (2.13)–(2.16)): `K` is linear in `E` at fixed `ν`, so
//! `∂K/∂E = K/E`, `∂M/∂E = 0`; `M` is linear in `ρ`: `∂M/∂ρ = M(μ = A)`, `∂K/∂ρ = 0`. Both exact.

use super::element::{ElementDerivative, ElementError, ElementMatrices, MassKind, positive};
use faer::Mat;

/// Material and section of a rod.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RodData {
    /// Young's modulus `E` (Pa), > 0.
    pub e: f64,
    /// Poisson's ratio `ν` (for `G`), −1 < ν ≤ 0.5.
    pub nu: f64,
    /// Density `ρ` (kg/m³), ≥ 0.
    pub rho: f64,
    /// Area `A` (m²), > 0.
    pub area: f64,
    /// Torsion constant `J` (m⁴), ≥ 0.
    pub j: f64,
    /// Non-structural mass per length (kg/m), ≥ 0.
    pub nsm: f64,
}

impl RodData {
    /// Checks every value is finite and in range.
    pub fn validate(&self) -> Result<(), ElementError> {
        positive("e", self.e, false)?;
        if !(self.nu.is_finite() && self.nu > -1.0 && self.nu <= 0.5) {
            return Err(ElementError::BadValue {
                field: "nu",
                value: self.nu,
                hint: "must be finite with -1 < nu <= 0.5",
            });
        }
        positive("rho", self.rho, true)?;
        positive("area", self.area, false)?;
        positive("j", self.j, true)?;
        positive("nsm", self.nsm, true)?;
        Ok(())
    }
}

/// A rod parameter with an analytic derivative.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RodParameter {
    /// Young's modulus `E` (ν fixed).
    YoungsModulus,
    /// Density `ρ`.
    Density,
}

/// The unit axis and length of a rod; an error for coincident or non-finite ends.
pub(super) fn axis(x1: [f64; 3], x2: [f64; 3]) -> Result<([f64; 3], f64), ElementError> {
    let d = [x2[0] - x1[0], x2[1] - x1[1], x2[2] - x1[2]];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let scale = x1.iter().chain(&x2).fold(0.0f64, |a, v| a.max(v.abs()));
    if !l.is_finite() || l <= 1e-12 * scale.max(f64::MIN_POSITIVE) || l == 0.0 {
        return Err(ElementError::Degenerate(format!(
            "the rod's end nodes coincide or are not finite (length {l:e} m)"
        )));
    }
    Ok(([d[0] / l, d[1] / l, d[2] / l], l))
}

/// `ka [[P, −P], [−P, P]]` on the translations plus the same with `kt` on the rotations.
pub(super) fn stiffness(e: [f64; 3], ka: f64, kt: f64) -> Mat<f64> {
    Mat::from_fn(12, 12, |r, c| {
        let (a, b) = (r % 6, c % 6);
        if (a < 3) != (b < 3) {
            return 0.0;
        }
        let k = if a < 3 { ka } else { kt };
        let sign = if r / 6 == c / 6 { 1.0 } else { -1.0 };
        sign * k * e[a % 3] * e[b % 3]
    })
}

/// Mass of a rod of element mass `m` on the translations.
fn mass(m: f64, kind: MassKind) -> Mat<f64> {
    Mat::from_fn(12, 12, |r, c| {
        if r % 6 >= 3 || r % 6 != c % 6 {
            return 0.0;
        }
        match kind {
            MassKind::Lumped if r == c => 0.5 * m,
            MassKind::Lumped => 0.0,
            MassKind::Consistent if r == c => m / 3.0,
            MassKind::Consistent => m / 6.0,
        }
    })
}

/// Stiffness and mass of a rod from `x1` to `x2` (basic system, DOFs `ux uy uz rx ry rz` per node).
pub fn rod2(
    x1: [f64; 3],
    x2: [f64; 3],
    d: &RodData,
    kind: MassKind,
) -> Result<ElementMatrices, ElementError> {
    d.validate()?;
    let (e, l) = axis(x1, x2)?;
    let g = d.e / (2.0 * (1.0 + d.nu));
    Ok(ElementMatrices {
        k: stiffness(e, d.e * d.area / l, g * d.j / l),
        m: mass((d.rho * d.area + d.nsm) * l, kind),
    })
}

/// Exact derivative of the rod matrices with respect to one parameter.
pub fn rod2_derivative(
    x1: [f64; 3],
    x2: [f64; 3],
    d: &RodData,
    kind: MassKind,
    p: RodParameter,
) -> Result<ElementDerivative, ElementError> {
    d.validate()?;
    let (e, l) = axis(x1, x2)?;
    Ok(match p {
        RodParameter::YoungsModulus => ElementDerivative {
            dk: stiffness(e, d.area / l, d.j / (2.0 * (1.0 + d.nu) * l)),
            dm: Mat::zeros(12, 12),
        },
        RodParameter::Density => ElementDerivative {
            dk: Mat::zeros(12, 12),
            dm: mass(d.area * l, kind),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data() -> RodData {
        RodData {
            e: 7.0e10,
            nu: 0.33,
            rho: 2700.0,
            area: 3.0e-4,
            j: 2.0e-8,
            nsm: 0.4,
        }
    }

    const X1: [f64; 3] = [0.1, -0.2, 0.3];
    const X2: [f64; 3] = [0.9, 0.4, -0.1];

    fn length() -> f64 {
        ((0.8f64).powi(2) + 0.6f64.powi(2) + 0.4f64.powi(2)).sqrt()
    }

    fn apply(m: &Mat<f64>, u: &[f64; 12]) -> [f64; 12] {
        std::array::from_fn(|r| (0..12).map(|c| m[(r, c)] * u[c]).sum())
    }

    /// Axial stretch by hand: ends pulled apart by δ along the axis need force E A δ / L; a twist
    /// θ about the axis needs moment G J θ / L. Rigid motions (three translations, three
    /// rotations about the first node, with the second node's translation `ω × (x₂ − x₁)`) give
    /// zero force. Tolerance 1e-12 relative (a few products).
    #[test]
    fn axial_and_torsional_stiffness_by_hand() {
        let d = data();
        let m = rod2(X1, X2, &d, MassKind::Consistent).unwrap();
        let l = length();
        let e: [f64; 3] = std::array::from_fn(|i| (X2[i] - X1[i]) / l);
        let mut u = [0.0; 12];
        for i in 0..3 {
            u[6 + i] = 1e-3 * e[i];
        }
        let f = apply(&m.k, &u);
        let fa = d.e * d.area / l * 1e-3;
        for i in 0..3 {
            assert!((f[6 + i] - fa * e[i]).abs() < 1e-12 * fa);
            assert!((f[i] + fa * e[i]).abs() < 1e-12 * fa);
        }
        let mut u = [0.0; 12];
        for i in 0..3 {
            u[9 + i] = 0.01 * e[i];
        }
        let f = apply(&m.k, &u);
        let mt = d.e / (2.0 * 1.33) * d.j / l * 0.01;
        for i in 0..3 {
            assert!((f[9 + i] - mt * e[i]).abs() < 1e-12 * mt);
        }
        let r: [f64; 3] = std::array::from_fn(|i| X2[i] - X1[i]);
        for k in 0..6 {
            let mut u = [0.0; 12];
            if k < 3 {
                u[k] = 1.0;
                u[6 + k] = 1.0;
            } else {
                let mut w = [0.0; 3];
                w[k - 3] = 1.0;
                u[k] = 1.0;
                u[6 + k] = 1.0;
                let wxr = [
                    w[1] * r[2] - w[2] * r[1],
                    w[2] * r[0] - w[0] * r[2],
                    w[0] * r[1] - w[1] * r[0],
                ];
                u[6..9].copy_from_slice(&wxr);
            }
            let f = apply(&m.k, &u);
            assert!(f.iter().all(|v| v.abs() < 1e-9 * fa / 1e-3), "{k}: {f:?}");
        }
    }

    /// Total mass `(ρA + nsm) L` in every direction for both mass kinds, lumped diagonal with
    /// halves at the ends, consistent `m/6 [[2, 1], [1, 2]]`, no rotary inertia.
    #[test]
    fn mass_is_nastrans_rod_mass() {
        let d = data();
        let total = (d.rho * d.area + d.nsm) * length();
        for kind in [MassKind::Lumped, MassKind::Consistent] {
            let m = rod2(X1, X2, &d, kind).unwrap().m;
            for dir in 0..3 {
                let mut u = [0.0; 12];
                u[dir] = 1.0;
                u[6 + dir] = 1.0;
                let mu = apply(&m, &u);
                let s: f64 = (0..12).map(|i| u[i] * mu[i]).sum();
                assert!((s - total).abs() < 1e-13 * total);
            }
            for r in 0..12 {
                for c in 0..12 {
                    if r % 6 >= 3 || c % 6 >= 3 {
                        assert_eq!(m[(r, c)], 0.0);
                    }
                }
            }
            if kind == MassKind::Lumped {
                assert_eq!(m[(0, 0)], 0.5 * total);
                assert_eq!(m[(0, 6)], 0.0);
            } else {
                assert!((m[(0, 0)] - total / 3.0).abs() < 1e-15 * total);
                assert!((m[(1, 7)] - total / 6.0).abs() < 1e-15 * total);
            }
        }
    }

    /// `∂K/∂E` and `∂M/∂ρ` against central differences (relative step 1e-6; the matrices are
    /// linear in the parameter, so only round-off remains: tolerance 1e-8 of the largest entry).
    #[test]
    fn derivatives_match_central_differences() {
        let d = data();
        for kind in [MassKind::Lumped, MassKind::Consistent] {
            for p in [RodParameter::YoungsModulus, RodParameter::Density] {
                let an = rod2_derivative(X1, X2, &d, kind, p).unwrap();
                let (v, set): (f64, fn(&mut RodData, f64)) = match p {
                    RodParameter::YoungsModulus => (d.e, |d, v| d.e = v),
                    RodParameter::Density => (d.rho, |d, v| d.rho = v),
                };
                let h = 1e-6 * v;
                let (mut dp, mut dm) = (d, d);
                set(&mut dp, v + h);
                set(&mut dm, v - h);
                let (a, b) = (
                    rod2(X1, X2, &dp, kind).unwrap(),
                    rod2(X1, X2, &dm, kind).unwrap(),
                );
                for (analytic, fp, fm) in [(&an.dk, &a.k, &b.k), (&an.dm, &a.m, &b.m)] {
                    let scale = (0..144)
                        .map(|i| analytic[(i / 12, i % 12)].abs())
                        .fold(0.0, f64::max);
                    for r in 0..12 {
                        for c in 0..12 {
                            let fd = (fp[(r, c)] - fm[(r, c)]) / (2.0 * h);
                            assert!(
                                (analytic[(r, c)] - fd).abs() <= 1e-8 * scale.max(1e-300),
                                "{p:?} {kind:?} ({r},{c}): {} vs {fd}",
                                analytic[(r, c)]
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn bad_input_is_named() {
        let mut d = data();
        assert!(
            rod2(X1, X1, &d, MassKind::Lumped)
                .unwrap_err()
                .to_string()
                .contains("coincide")
        );
        d.area = 0.0;
        assert!(
            rod2(X1, X2, &d, MassKind::Lumped)
                .unwrap_err()
                .to_string()
                .contains("area")
        );
    }
}
