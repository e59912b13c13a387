//! Free-interface component modes with residual flexibility, MacNeal (1971) / Rubin (1975)
//! (thesis §3.5, 3.15–3.39: (3.15), (3.16), (3.17), (3.18), (3.19), (3.20), (3.21), (3.22), (3.23),
//! (3.24), (3.25), (3.26), (3.27), (3.28), (3.29), (3.30), (3.31), (3.32), (3.33), (3.34), (3.35),
//! (3.36), (3.37), (3.38), (3.39); Appendix A.1).
//!
//! Free modes `Φ` of `(K, M)` of the whole substructure (3.32, 3.33), rigid-body modes `Φ_r`
//! included. Attachment modes are columns of the flexibility `G = K⁻¹` (3.17); for a floating
//! substructure `K` is singular and the elastic flexibility is used instead (3.22–3.25: (3.22),
//! (3.23), (3.24), (3.25)): hold `r` DOFs temporarily (`r` = rigid-body modes), invert the rest
//! (`G` with zero rows and columns at the held DOFs), and filter with the inertia-relief projector
//! `P = I − M Φ_r Φ_rᵀ`: `G_e = Pᵀ G P`. `P` removes the rigid-body resultant of a load, `Pᵀ` the
//! rigid-body part of a displacement, so `G_e = Σ_elastic φ φᵀ/λ` whatever DOFs were held (the
//! Appendix A demonstration; tested). The held DOFs are chosen by pivoted Gram–Schmidt on the rows
//! of `Φ_r`, so `Φ_r` restricted to them is well conditioned and the remaining stiffness is
//! non-singular.
//!
//! Residual flexibility (3.29–3.31: (3.29), (3.30), (3.31)): `R = G_e − Φ_el Λ_el⁻¹ Φ_elᵀ` (kept
//! elastic modes); only its junction columns `R_{:,j}` are formed (a sparse solve per junction
//! DOF). Eliminating the junction forces with the junction rows (3.36) gives the transformation
//! (3.37–3.39: (3.37), (3.38), (3.39)) `x_j = x_j`,
//! `x_i = R_ij R_jj⁻¹ x_j + (Φ_i − R_ij R_jj⁻¹ Φ_j) q`.
//!
//! Complete limit: with every free mode kept the residual flexibility is zero and `R_jj⁻¹`
//! does not exist; compatibility is then imposed on the modes themselves (`n_j` carrier modes
//! replaced by the junction displacements, see `complete_free_interface`), `T` is square and the
//! reduced model reproduces the full one (tested). Between the two, MacNeal's `T` needs `R_jj`
//! invertible; with close to `N_k − n_j` modes kept it can be singular to working precision, and
//! the reduction says so (`SingularResidual`).

use super::craig_bampton::split;
use super::linalg::{solve, sparse_times_dense, spd_factor, sub_block, symmetrise};
use super::{ComponentReduction, ReductionError, ReductionInfo};
use crate::core::DofId;
use crate::eigen::{ModeSelection, Modes, SparseEigenParams, lowest_modes};
use crate::fe::SystemMatrices;
use faer::{Mat, MatRef, Par, Side};

/// Free modes of a substructure, checked to hold some elastic mode.
pub fn free_modes(
    name: &str,
    sys: &SystemMatrices,
    modes: ModeSelection,
    eigen: &SparseEigenParams,
) -> Result<Modes, ReductionError> {
    let (m, _) = lowest_modes(&sys.k, &sys.m, &sys.dofs, modes, eigen).map_err(|source| {
        ReductionError::Eigen {
            substructure: name.to_string(),
            source,
        }
    })?;
    let rigid = m.eigenvalues.iter().filter(|l| **l == 0.0).count();
    if rigid == m.len() && m.len() < sys.n() {
        return Err(ReductionError::OnlyRigidModes {
            substructure: name.to_string(),
            kept: m.len(),
        });
    }
    Ok(m)
}

/// `r` row indices of `Φ_r` (`N × r`) chosen among `candidates` by pivoted Gram–Schmidt: each
/// step takes the row with the largest part orthogonal to the rows already taken (ties: lowest
/// index), so `Φ_r[held, :]` is as well conditioned as the candidates allow.
pub fn choose_held_dofs(phi_r: MatRef<'_, f64>, candidates: &[usize]) -> Vec<usize> {
    let r = phi_r.ncols();
    let mut w: Vec<Vec<f64>> = candidates
        .iter()
        .map(|&i| (0..r).map(|c| phi_r[(i, c)]).collect())
        .collect();
    let mut held = Vec::with_capacity(r);
    for _ in 0..r {
        let (mut best, mut best_norm) = (usize::MAX, 0.0f64);
        for (a, row) in w.iter().enumerate() {
            let nrm: f64 = row.iter().map(|v| v * v).sum();
            if nrm > best_norm * (1.0 + 1e-12) {
                best = a;
                best_norm = nrm;
            }
        }
        if best == usize::MAX || best_norm == 0.0 {
            break;
        }
        held.push(candidates[best]);
        let v: Vec<f64> = w[best].iter().map(|x| x / best_norm.sqrt()).collect();
        for row in w.iter_mut() {
            let d: f64 = row.iter().zip(&v).map(|(a, b)| a * b).sum();
            for (x, vv) in row.iter_mut().zip(&v) {
                *x -= d * vv;
            }
        }
    }
    held.sort_unstable();
    held
}

/// `G_e B = Pᵀ G P B` (3.22–3.24: (3.22), (3.23), (3.24)) for a block of loads `B` (`N × p`): `Φ_r`
/// the mass-normalised rigid-body modes (`N × r`, possibly `r = 0`, then `G = K⁻¹`), `held` the
/// temporarily held DOFs (`r` of them). Errors when the stiffness with `held` removed is singular.
pub fn elastic_flexibility(
    k: &crate::core::sparse::SparseMatrix,
    m: &crate::core::sparse::SparseMatrix,
    phi_r: MatRef<'_, f64>,
    held: &[usize],
    b: MatRef<'_, f64>,
    par: Par,
) -> Result<Mat<f64>, String> {
    let n = k.nrows();
    let r = phi_r.ncols();
    // P B = B − M Φ_r (Φ_rᵀ B).
    let mut y = b.to_owned();
    if r > 0 {
        let c = phi_r.transpose() * b;
        let mc = sparse_times_dense(m, (phi_r * &c).as_ref());
        y -= &mc;
    }
    // G (P B): solve on the DOFs not held, zero at the held ones.
    let mut keep_mask = vec![true; n];
    for &h in held {
        keep_mask[h] = false;
    }
    let free: Vec<usize> = (0..n).filter(|i| keep_mask[*i]).collect();
    let kf = sub_block(k, &free, &free);
    let f = spd_factor(&kf, par).ok_or_else(|| {
        format!(
            "the stiffness with {} DOFs held is not positive definite",
            held.len()
        )
    })?;
    let yf = Mat::from_fn(free.len(), y.ncols(), |i, j| y[(free[i], j)]);
    let zf = solve(&f, yf.as_ref(), par);
    let mut z = Mat::zeros(n, y.ncols());
    for (a, &i) in free.iter().enumerate() {
        for j in 0..y.ncols() {
            z[(i, j)] = zf[(a, j)];
        }
    }
    // Pᵀ Z = Z − Φ_r (Φ_rᵀ M Z).
    if r > 0 {
        let mz = sparse_times_dense(m, z.as_ref());
        let c = phi_r.transpose() * &mz;
        z -= phi_r * &c;
    }
    Ok(z)
}

/// Columns `cols` of the residual flexibility `R = G_e − Φ_el Λ_el⁻¹ Φ_elᵀ` (3.29–3.31: (3.29),
/// (3.30), (3.31)) of a substructure whose kept free modes are `modes` (all rigid-body modes among
/// them).
pub fn residual_flexibility(
    name: &str,
    sys: &SystemMatrices,
    modes: &Modes,
    cols: &[usize],
    par: Par,
) -> Result<Mat<f64>, ReductionError> {
    let n = sys.n();
    let rigid: Vec<usize> = (0..modes.len())
        .filter(|r| modes.eigenvalues[*r] == 0.0)
        .collect();
    let elastic: Vec<usize> = (0..modes.len())
        .filter(|r| modes.eigenvalues[*r] != 0.0)
        .collect();
    let phi_r = Mat::from_fn(n, rigid.len(), |i, c| modes.shapes[(i, rigid[c])]);
    let held = choose_held_dofs(phi_r.as_ref(), &(0..n).collect::<Vec<_>>());
    let mut e = Mat::zeros(n, cols.len());
    for (c, &i) in cols.iter().enumerate() {
        e[(i, c)] = 1.0;
    }
    let mut rr = elastic_flexibility(&sys.k, &sys.m, phi_r.as_ref(), &held, e.as_ref(), par)
        .map_err(|reason| ReductionError::Mechanism {
            substructure: name.to_string(),
            held: held.len(),
            reason,
        })?;
    for &r in &elastic {
        let inv = 1.0 / modes.eigenvalues[r];
        for (c, &col) in cols.iter().enumerate() {
            let w = modes.shapes[(col, r)] * inv;
            for i in 0..n {
                rr[(i, c)] -= modes.shapes[(i, r)] * w;
            }
        }
    }
    Ok(rr)
}

/// Inverse of the symmetric junction block `R_jj` of the residual flexibility, rejecting it when
/// its smallest eigenvalue is below `1e-11` of the largest (round-off of `G_e − ΦΛ⁻¹Φᵀ`).
pub(super) fn residual_inverse(
    name: &str,
    rjj: &Mat<f64>,
    internal: usize,
) -> Result<Mat<f64>, ReductionError> {
    let nj = rjj.nrows();
    let sym = symmetrise(rjj);
    let bad = |detail: String| ReductionError::SingularResidual {
        substructure: name.to_string(),
        junction: nj,
        internal,
        detail,
    };
    let evd = sym
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| bad("its eigen decomposition failed".into()))?;
    let s = evd.S();
    let (mut smin, mut smax) = (f64::INFINITY, 0.0f64);
    for i in 0..nj {
        smin = smin.min(s[i]);
        smax = smax.max(s[i].abs());
    }
    if !(smin > 1e-11 * smax) {
        return Err(bad(format!("eigenvalues from {smin:e} to {smax:e} m/N")));
    }
    let u = evd.U();
    Ok(Mat::from_fn(nj, nj, |a, b| {
        (0..nj).map(|c| u[(a, c)] * u[(b, c)] / s[c]).sum()
    }))
}

/// MacNeal/Rubin free-interface reduction of substructure `name` (3.32–3.39: (3.32), (3.33),
/// (3.34), (3.35), (3.36), (3.37), (3.38), (3.39)).
pub fn free_interface(
    name: &str,
    sys: &SystemMatrices,
    junction: &[DofId],
    modes: ModeSelection,
    eigen: &SparseEigenParams,
) -> Result<ComponentReduction, ReductionError> {
    let (j_idx, i_idx) = split(sys, junction)?;
    let (n, nj) = (sys.n(), j_idx.len());
    let free = free_modes(name, sys, modes, eigen)?;
    let m = free.len();
    let rigid = free.eigenvalues.iter().filter(|l| **l == 0.0).count();
    if nj > 0 && m == n {
        return complete_free_interface(name, sys, junction, &j_idx, &free, rigid);
    }
    let mut t = Mat::zeros(n, nj + m);
    if nj > 0 {
        let rj = residual_flexibility(name, sys, &free, &j_idx, eigen.par)?; // R_{:,j}, N × n_j
        let rjj = Mat::from_fn(nj, nj, |a, b| rj[(j_idx[a], b)]);
        let rjj_inv = residual_inverse(name, &rjj, i_idx.len())?;
        let a = &rj * &rjj_inv; // R_{:j} R_jj⁻¹
        let phij = Mat::from_fn(nj, m, |a, q| free.shapes[(j_idx[a], q)]);
        let b = &free.shapes - &a * &phij; // Φ − R_{:j} R_jj⁻¹ Φ_j
        t = junction_transformation(a.as_ref(), b.as_ref(), &j_idx);
    } else {
        for i in 0..n {
            for q in 0..m {
                t[(i, q)] = free.shapes[(i, q)];
            }
        }
    }
    Ok(ComponentReduction::from_transformation(
        name,
        sys,
        junction,
        &j_idx,
        t,
        free.frequencies_hz(),
        ReductionInfo {
            rigid_body_modes: rigid,
            ..Default::default()
        },
    ))
}

/// The complete limit: every free mode kept, so the residual flexibility is zero and MacNeal's
/// `R_jj⁻¹` does not exist. Compatibility is then imposed on the modes themselves: `n_j` carrier
/// modes `a` (chosen by pivoted Gram–Schmidt on the junction rows, so `Φ_ja` is as well
/// conditioned as the modes allow) give way to the junction displacements,
/// `q_a = Φ_ja⁻¹ (x_j − Φ_jb q_b)`, so `x = Φ_a Φ_ja⁻¹ x_j + (Φ_b − Φ_a Φ_ja⁻¹ Φ_jb) q_b`. This is
/// MacNeal's transformation (3.37–3.39: (3.37), (3.38), (3.39)) with exactly the carriers omitted
/// (then `R_ij R_jj⁻¹ = Φ_ia Φ_ja⁻¹`); `T` is square and invertible, so the synthesis is exact.
fn complete_free_interface(
    name: &str,
    sys: &SystemMatrices,
    junction: &[DofId],
    j_idx: &[usize],
    free: &Modes,
    rigid: usize,
) -> Result<ComponentReduction, ReductionError> {
    let (n, nj) = (sys.n(), j_idx.len());
    let phi = &free.shapes;
    // Modes as rows, junction DOFs as columns: choose the carrier rows.
    let phi_jt = Mat::from_fn(n, nj, |q, a| phi[(j_idx[a], q)]);
    let carriers = choose_held_dofs(phi_jt.as_ref(), &(0..n).rev().collect::<Vec<_>>());
    let singular = |detail: String| ReductionError::SingularResidual {
        substructure: name.to_string(),
        junction: nj,
        internal: n - nj,
        detail,
    };
    if carriers.len() < nj {
        return Err(singular(format!(
            "with every mode kept, the junction rows of the modes have rank {} < {nj}",
            carriers.len()
        )));
    }
    let is_carrier: std::collections::BTreeSet<usize> = carriers.iter().copied().collect();
    let kept: Vec<usize> = (0..n).filter(|q| !is_carrier.contains(q)).collect();
    let phi_ja = Mat::from_fn(nj, nj, |a, c| phi[(j_idx[a], carriers[c])]);
    let inv = super::linalg::inverse(&phi_ja)
        .ok_or_else(|| singular("the carrier modes' junction block is singular".into()))?;
    let phi_a = Mat::from_fn(n, nj, |i, c| phi[(i, carriers[c])]);
    let phi_b = Mat::from_fn(n, kept.len(), |i, c| phi[(i, kept[c])]);
    let phi_jb = Mat::from_fn(nj, kept.len(), |a, c| phi[(j_idx[a], kept[c])]);
    let a = &phi_a * &inv;
    let b = &phi_b - &a * &phi_jb;
    let t = junction_transformation(a.as_ref(), b.as_ref(), j_idx);
    let hz = free.frequencies_hz();
    Ok(ComponentReduction::from_transformation(
        name,
        sys,
        junction,
        j_idx,
        t,
        kept.iter().map(|q| hz[*q]).collect(),
        ReductionInfo {
            rigid_body_modes: rigid,
            ..Default::default()
        },
    ))
}

/// `T = [A, B]` (junction columns, then modal columns) with the junction rows set exactly to
/// `[I, 0]`, which they are by construction (3.37–3.39: (3.37), (3.38), (3.39)).
fn junction_transformation(a: MatRef<'_, f64>, b: MatRef<'_, f64>, j_idx: &[usize]) -> Mat<f64> {
    let nj = a.ncols();
    let mut t = Mat::from_fn(a.nrows(), nj + b.ncols(), |i, c| {
        if c < nj { a[(i, c)] } else { b[(i, c - nj)] }
    });
    for (a_, &r) in j_idx.iter().enumerate() {
        for c in 0..t.ncols() {
            t[(r, c)] = if c == a_ { 1.0 } else { 0.0 };
        }
    }
    t
}
