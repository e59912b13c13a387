//! Craig-Bampton reduction of one substructure (thesis §3.4, 3.5–3.13).
//!
//! With the DOFs split into junction `j` and internal `i`:
//! - constraint modes (3.5–3.7): unit displacement at one junction DOF, the others held,
//!   `Φ_c,i = −K_ii⁻¹ K_ij`, solved with a sparse Cholesky factor of `K_ii` (never a dense inverse);
//! - fixed-interface normal modes (3.8, 3.9): the lowest modes of `(K_ii, M_ii)` up to a count or
//!   a cut-off frequency (thesis: twice the top of the band), by [`lowest_modes`];
//! - `x = T [x_j; q]`, `T = [[I, 0], [Φ_c,i, Φ_n,i]]` (3.11–3.13), and the projected `TᵀKT`,
//!   `TᵀMT` that enter the assembly at common junction DOFs (3.14).
//!
//! With every fixed-interface mode kept, `T` is square and invertible and the reduced model
//! reproduces the full one exactly (a change of basis).

use super::linalg::{SparseSpd, sub_block};
use super::{ComponentReduction, ReductionError, ReductionInfo};
use crate::core::DofId;
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::fe::SystemMatrices;
use faer::Mat;
use std::collections::HashSet;

/// Craig-Bampton reduction of substructure `name` with matrices `sys` and junction DOFs
/// `junction` (a subset of `sys.dofs`).
pub fn craig_bampton(
    name: &str,
    sys: &SystemMatrices,
    junction: &[DofId],
    modes: ModeSelection,
    eigen: &SparseEigenParams,
) -> Result<ComponentReduction, ReductionError> {
    let (j_idx, i_idx) = split(sys, junction)?;
    let (nj, ni) = (j_idx.len(), i_idx.len());
    let internal_dofs: Vec<DofId> = i_idx.iter().map(|&i| sys.dofs[i]).collect();
    // Constraint modes Ψ = −K_ii⁻¹ K_ij (3.6).
    let kii = sub_block(&sys.k, &i_idx, &i_idx);
    let mii = sub_block(&sys.m, &i_idx, &i_idx);
    let psi = if nj > 0 && ni > 0 {
        let kij = sub_block(&sys.k, &i_idx, &j_idx);
        let f = SparseSpd::factor(&kii).ok_or_else(|| ReductionError::NotRestrained {
            substructure: name.to_string(),
            junction: nj,
        })?;
        let mut x = f.solve(crate::fe::system::sparse_to_dense(&kij).as_ref());
        x *= faer::Scale(-1.0);
        x
    } else {
        Mat::zeros(ni, nj)
    };
    // Fixed-interface modes (3.8).
    let fixed = if ni > 0 {
        lowest_modes(&kii, &mii, &internal_dofs, modes, eigen)
            .map_err(|source| ReductionError::Eigen {
                substructure: name.to_string(),
                source,
            })?
            .0
    } else {
        crate::eigen::Modes {
            eigenvalues: vec![],
            shapes: Mat::zeros(0, 0),
            residuals: vec![],
            orthogonality_error: 0.0,
            rigid_body_modes: 0,
        }
    };
    let m = fixed.len();
    let mut t = Mat::zeros(sys.n(), nj + m);
    for (c, &r) in j_idx.iter().enumerate() {
        t[(r, c)] = 1.0;
    }
    for (a, &r) in i_idx.iter().enumerate() {
        for c in 0..nj {
            t[(r, c)] = psi[(a, c)];
        }
        for q in 0..m {
            t[(r, nj + q)] = fixed.shapes[(a, q)];
        }
    }
    Ok(ComponentReduction::from_transformation(
        name,
        sys,
        junction,
        &j_idx,
        t,
        fixed.frequencies_hz(),
        ReductionInfo::default(),
    ))
}

/// Row indices of the junction DOFs (in `junction` order) and of the internal DOFs (ascending).
pub(super) fn split(
    sys: &SystemMatrices,
    junction: &[DofId],
) -> Result<(Vec<usize>, Vec<usize>), ReductionError> {
    let index = sys.dof_index();
    let mut j_idx = Vec::with_capacity(junction.len());
    for d in junction {
        j_idx.push(*index.get(d).ok_or(ReductionError::UnknownDof { dof: *d })?);
    }
    let js: HashSet<usize> = j_idx.iter().copied().collect();
    let i_idx = (0..sys.n()).filter(|i| !js.contains(i)).collect();
    Ok((j_idx, i_idx))
}
