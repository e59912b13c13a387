//! Scalar masses and dampers, the general 6×6 mass, the viscous rod damper and the bush in its
//! element system (docs/theory.md §2; Nastran QRG CMASSi, CDAMPi, CONM1, CVISC, CBUSH).
//!
//! **Scalar mass / damper** (CMASS1–4, CDAMP1–4) of value `v` between two DOFs:
//! `v [[1, −1], [−1, 1]]` (the QRG's "mass between two points": the kinetic energy
//! `½ m (u̇₁ − u̇₂)²`), or `[v]` to ground. Both are linear in `v`: `∂M/∂m = M/m`.
//!
//! **General mass** (CONM1): the symmetric 6×6 matrix `M` of the card, already in the basic
//! system (the importer rotates a CID system's matrix by `T M Tᵀ`, `T = diag(Dᵀ, Dᵀ)`).
//!
//! **Viscous damper** (CVISC) between grids `a`, `b` with unit axis `e` from `a` to `b`:
//! `C = [[B, −B], [−B, B]]` with `B = diag(c_a e eᵀ, c_t e eᵀ)`: axial damping `c_a` on the
//! translations along `e` and torsional `c_t` on the rotations about it.
//!
//! **Bush in its element system** (CBUSH with CID, orientation vector or G0): with `R` the 3×3
//! matrix whose rows are the element axes in basic (`u_elem = R u_basic`), each 3×3 block of
//! `D = diag(k)` becomes `Rᵀ D R`, so `K = [[Kb, −Kb], [−Kb, Kb]]` with `Kb = diag(Rᵀ D_t R, Rᵀ D_r R)`;
//! the damping `B` line likewise. `∂K/∂k_c` is the same with a unit `k_c`.

use super::element::{ElementDerivative, ElementError, ElementMatrices, positive};
use super::lumped_elements::SpringEnds;
use crate::core::Component;
use faer::Mat;

/// The 2×2 (or 1×1 to ground) pattern `v [[1, −1], [−1, 1]]`.
pub fn two_point(v: f64, ends: SpringEnds) -> Mat<f64> {
    match ends {
        SpringEnds::Ground => Mat::from_fn(1, 1, |_, _| v),
        SpringEnds::TwoNodes => Mat::from_fn(2, 2, |i, j| if i == j { v } else { -v }),
    }
}

/// Mass matrix (and zero stiffness) of a scalar mass `m ≥ 0`, 2×2 or 1×1 to ground.
pub fn scalar_mass(m: f64, ends: SpringEnds) -> Result<ElementMatrices, ElementError> {
    positive("m", m, true)?;
    let mm = two_point(m, ends);
    Ok(ElementMatrices {
        k: Mat::zeros(mm.nrows(), mm.ncols()),
        m: mm,
    })
}

/// `∂M/∂m` of [`scalar_mass`] (`∂K = 0`).
pub fn scalar_mass_derivative(ends: SpringEnds) -> ElementDerivative {
    let dm = two_point(1.0, ends);
    ElementDerivative {
        dk: Mat::zeros(dm.nrows(), dm.ncols()),
        dm,
    }
}

/// Damping matrix of a scalar damper `c ≥ 0`, 2×2 or 1×1 to ground.
pub fn scalar_damper(c: f64, ends: SpringEnds) -> Result<Mat<f64>, ElementError> {
    positive("c", c, true)?;
    Ok(two_point(c, ends))
}

/// The 6×6 matrix of a general mass from its lower triangle `M11, M21, M22, …, M66` (row by
/// row); the entries must be finite and the diagonal `≥ 0`.
pub fn general_mass(lower: &[f64; 21]) -> Result<ElementMatrices, ElementError> {
    let mut m = Mat::zeros(6, 6);
    let mut k = 0;
    for i in 0..6 {
        for j in 0..=i {
            let v = lower[k];
            if !v.is_finite() {
                return Err(ElementError::BadValue {
                    field: "M",
                    value: v,
                    hint: "a finite number",
                });
            }
            m[(i, j)] = v;
            m[(j, i)] = v;
            k += 1;
        }
    }
    for i in 0..6 {
        positive("Mii", m[(i, i)], true)?;
    }
    Ok(ElementMatrices {
        k: Mat::zeros(6, 6),
        m,
    })
}

/// Damping of a viscous damper between points `a` and `b` (12×12, basic): axial `c_a`,
/// torsional `c_t`; the points must differ.
pub fn viscous(
    a: [f64; 3],
    b: [f64; 3],
    axial: f64,
    torsional: f64,
) -> Result<Mat<f64>, ElementError> {
    positive("axial damping", axial, true)?;
    positive("torsional damping", torsional, true)?;
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if len == 0.0 || !len.is_finite() {
        return Err(ElementError::Degenerate(
            "the two grids of a viscous damper coincide, so it has no axis".into(),
        ));
    }
    let e = d.map(|x| x / len);
    Ok(Mat::from_fn(12, 12, |i, j| {
        let (bi, bj) = (i / 6, j / 6);
        let (ri, rj) = (i % 6, j % 6);
        if (ri < 3) != (rj < 3) {
            return 0.0;
        }
        let c = if ri < 3 { axial } else { torsional };
        let v = c * e[ri % 3] * e[rj % 3];
        if bi == bj { v } else { -v }
    }))
}

/// `Rᵀ diag(d) R` for each 3×3 half of `d` (translations, rotations), as a 6×6 block.
fn rotated_block(d: &[f64; 6], axes: &[[f64; 3]; 3]) -> [[f64; 6]; 6] {
    let mut out = [[0.0; 6]; 6];
    for half in 0..2 {
        for r in 0..3 {
            for c in 0..3 {
                out[3 * half + r][3 * half + c] = (0..3)
                    .map(|k| axes[k][r] * d[3 * half + k] * axes[k][c])
                    .sum();
            }
        }
    }
    out
}

/// The spring/damper pattern of a 6×6 block `b` over one node or between two.
fn block_pattern(b: &[[f64; 6]; 6], ends: SpringEnds) -> Mat<f64> {
    let n = match ends {
        SpringEnds::Ground => 6,
        SpringEnds::TwoNodes => 12,
    };
    Mat::from_fn(n, n, |i, j| {
        let v = b[i % 6][j % 6];
        if i / 6 == j / 6 { v } else { -v }
    })
}

/// The axes checked: finite, unit and orthogonal to 1e-9.
fn check_axes(axes: &[[f64; 3]; 3]) -> Result<(), ElementError> {
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| axes[i][k] * axes[j][k]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            if !dot.is_finite() || (dot - want).abs() > 1e-9 {
                return Err(ElementError::Degenerate(format!(
                    "the bush's element axes {axes:?} are not orthonormal"
                )));
            }
        }
    }
    Ok(())
}

/// A six-DOF bush's `diag(v)` in its element system `axes` (rows, basic; `None`: basic) as a
/// matrix over the basic DOFs of one node or two.
pub fn bush_matrix(
    v: &[f64; 6],
    axes: Option<&[[f64; 3]; 3]>,
    ends: SpringEnds,
) -> Result<Mat<f64>, ElementError> {
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let axes = axes.unwrap_or(&identity);
    check_axes(axes)?;
    Ok(block_pattern(&rotated_block(v, axes), ends))
}

/// `∂K/∂k_c` of a bush in its element system (direction `c` of the element axes); `None` for
/// the scalar component, which a bush does not have.
pub fn bush_unit(direction: Component) -> Option<[f64; 6]> {
    if direction.is_scalar() {
        return None;
    }
    let mut unit = [0.0; 6];
    unit[direction.slot()] = 1.0;
    Some(unit)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bush whose system is basic turned 90° about z: its x axis is basic y, so `kx` acts
    /// along basic y and `ky` along basic −x (the same stiffness along x). Exact (entries of
    /// the rotation are 0 and ±1).
    #[test]
    fn a_turned_bush_swaps_its_stiffnesses() {
        let k = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let axes = [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let turned = bush_matrix(&k, Some(&axes), SpringEnds::TwoNodes).unwrap();
        let swapped = [2.0, 1.0, 3.0, 5.0, 4.0, 6.0];
        let plain = bush_matrix(&swapped, None, SpringEnds::TwoNodes).unwrap();
        for i in 0..12 {
            for j in 0..12 {
                assert_eq!(turned[(i, j)], plain[(i, j)], "({i}, {j})");
            }
        }
        let skew = [[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(bush_matrix(&k, Some(&skew), SpringEnds::Ground).is_err());
    }

    /// A general bush rotation keeps `K` symmetric and its trace per block (invariants), to
    /// round-off.
    #[test]
    fn a_rotated_bush_keeps_its_invariants() {
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let axes = [
            [c, s, 0.0],
            [-s * 0.6, c * 0.6, 0.8],
            [s * 0.8, -c * 0.8, 0.6],
        ];
        let k = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let m = bush_matrix(&k, Some(&axes), SpringEnds::Ground).unwrap();
        let tr_t: f64 = (0..3).map(|i| m[(i, i)]).sum();
        let tr_r: f64 = (3..6).map(|i| m[(i, i)]).sum();
        assert!((tr_t - 6.0).abs() < 1e-14 && (tr_r - 15.0).abs() < 1e-14);
        for i in 0..6 {
            for j in 0..6 {
                assert!((m[(i, j)] - m[(j, i)]).abs() < 1e-15);
            }
        }
    }

    /// The viscous damper along a skew axis: `uᵀ C u` for a unit relative axial velocity is
    /// `c_a`, for a transverse one 0; torsion likewise.
    #[test]
    fn a_viscous_damper_damps_along_its_axis_only() {
        let c = viscous([0.0; 3], [1.0, 2.0, 2.0], 7.0, 3.0).unwrap();
        let e = [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
        let t = [2.0 / 3.0, -2.0 / 3.0, 1.0 / 3.0];
        let quad = |u: &[f64; 12]| -> f64 {
            (0..12)
                .flat_map(|i| (0..12).map(move |j| (i, j)))
                .map(|(i, j)| u[i] * c[(i, j)] * u[j])
                .sum()
        };
        let mut u = [0.0; 12];
        u[6..9].copy_from_slice(&e);
        assert!((quad(&u) - 7.0).abs() < 1e-13);
        let mut u = [0.0; 12];
        u[9..12].copy_from_slice(&e);
        assert!((quad(&u) - 3.0).abs() < 1e-13);
        let mut u = [0.0; 12];
        u[0..3].copy_from_slice(&t);
        assert!(quad(&u).abs() < 1e-13);
        assert!(viscous([1.0; 3], [1.0; 3], 1.0, 0.0).is_err());
    }

    #[test]
    fn a_general_mass_is_symmetric_and_checked() {
        let mut lower = [0.0; 21];
        for (i, v) in lower.iter_mut().enumerate() {
            *v = i as f64 + 1.0;
        }
        let m = general_mass(&lower).unwrap().m;
        assert_eq!(m[(1, 0)], 2.0);
        assert_eq!(m[(0, 1)], 2.0);
        assert_eq!(m[(5, 5)], 21.0);
        assert_eq!(m[(5, 0)], 16.0);
        lower[0] = -1.0;
        assert!(general_mass(&lower).is_err());
        assert!(scalar_mass(-1.0, SpringEnds::Ground).is_err());
        assert!(scalar_damper(f64::NAN, SpringEnds::Ground).is_err());
    }
}
