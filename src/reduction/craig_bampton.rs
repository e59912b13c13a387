//! Craig-Bampton reduction of one substructure (thesis §3.4, 3.5–3.13: (3.5), (3.6), (3.7), (3.8),
//! (3.9), (3.10), (3.11), (3.12), (3.13)).
//!
//! With the DOFs split into junction `j` and internal `i`:
//! - constraint modes (3.5–3.7: (3.5), (3.6), (3.7)): unit displacement at one junction DOF, the
//!   others held, `Φ_c,i = −K_ii⁻¹ K_ij`, solved with a sparse Cholesky factor of `K_ii` (never a
//!   dense inverse);
//! - fixed-interface normal modes (3.8, 3.9): the lowest modes of `(K_ii, M_ii)` up to a count or
//!   a cut-off frequency (thesis: twice the top of the band), by [`lowest_modes`];
//! - `x = T [x_j; q]`, `T = [[I, 0], [Φ_c,i, Φ_n,i]]` (3.11–3.13: (3.11), (3.12), (3.13)), and the
//!   projected `TᵀKT`, `TᵀMT` that enter the assembly at common junction DOFs (3.14).
//!
//! - [`junction_condensation`] and [`craig_bampton_on_interface`]: the same reduction for
//!   junctions of thousands of DOFs — the junction's Guyan model first (to choose interface
//!   modes), then constraint modes for the interface modes only.
//!
//! With every fixed-interface mode kept, `T` is square and invertible and the reduced model
//! reproduces the full one exactly (a change of basis).

use super::linalg::{
    dense_columns, solve, sparse_times_dense, sparse_transpose_times_dense, spd_factor, sub_block,
    symmetrise,
};
use super::{ComponentReduction, Coordinate, ReductionError, ReductionInfo};
use crate::core::DofId;
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::fe::SystemMatrices;
use faer::{Mat, MatRef, Par};
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
    constrained_reduction(name, sys, junction, None, modes, eigen)
}

/// Craig-Bampton reduction with the junction moving only in the interface modes `basis`
/// (`n_j × n_c`, rows in `junction` order; characteristic constraint modes, Castanier et al.
/// 2001): `T = [[V, 0], [Ψ V, Φ]]` with `Ψ V = −K_ii⁻¹ K_ij V`, so `n_c` solves and an
/// `N_k × (n_c + m)` basis instead of `n_j` solves and `N_k × (n_j + m)`. The component's
/// leading coordinates are the interface modes; it is [`craig_bampton`] followed by the
/// interface coupling, without the junction-sized intermediate.
pub fn craig_bampton_on_interface(
    name: &str,
    sys: &SystemMatrices,
    junction: &[DofId],
    basis: MatRef<'_, f64>,
    modes: ModeSelection,
    eigen: &SparseEigenParams,
) -> Result<ComponentReduction, ReductionError> {
    if basis.nrows() != junction.len() {
        return Err(ReductionError::Replace(format!(
            "substructure `{name}`: the interface basis has {} rows for its {} junction DOFs",
            basis.nrows(),
            junction.len()
        )));
    }
    constrained_reduction(name, sys, junction, Some(basis), modes, eigen)
}

/// Constraint modes for the junction motions `basis` (the identity when `None`) plus the
/// fixed-interface normal modes (3.5–3.13: (3.5), (3.6), (3.7), (3.8), (3.9), (3.10), (3.11),
/// (3.12), (3.13)).
fn constrained_reduction(
    name: &str,
    sys: &SystemMatrices,
    junction: &[DofId],
    basis: Option<MatRef<'_, f64>>,
    modes: ModeSelection,
    eigen: &SparseEigenParams,
) -> Result<ComponentReduction, ReductionError> {
    let (j_idx, i_idx) = split(sys, junction)?;
    let (nj, ni) = (j_idx.len(), i_idx.len());
    let nc = basis.map_or(nj, |b| b.ncols());
    let internal_dofs: Vec<DofId> = i_idx.iter().map(|&i| sys.dofs[i]).collect();
    // Constraint modes Ψ = −K_ii⁻¹ K_ij (3.6), applied to the junction motions.
    let kii = sub_block(&sys.k, &i_idx, &i_idx);
    let mii = sub_block(&sys.m, &i_idx, &i_idx);
    let psi = if nc > 0 && ni > 0 {
        let kij = sub_block(&sys.k, &i_idx, &j_idx);
        let f = spd_factor(&kii, eigen.par).ok_or_else(|| ReductionError::NotRestrained {
            substructure: name.to_string(),
            junction: nj,
        })?;
        let rhs = match basis {
            None => crate::core::sparse::sparse_to_dense(&kij),
            Some(v) => sparse_times_dense(&kij, v),
        };
        let mut x = solve(&f, rhs.as_ref(), eigen.par);
        x *= faer::Scale(-1.0);
        x
    } else {
        Mat::zeros(ni, nc)
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
    let mut t = Mat::zeros(sys.n(), nc + m);
    for (a, &r) in j_idx.iter().enumerate() {
        match basis {
            None => t[(r, a)] = 1.0,
            Some(v) => {
                for c in 0..nc {
                    t[(r, c)] = v[(a, c)];
                }
            }
        }
    }
    for (a, &r) in i_idx.iter().enumerate() {
        for c in 0..nc {
            t[(r, c)] = psi[(a, c)];
        }
        for q in 0..m {
            t[(r, nc + q)] = fixed.shapes[(a, q)];
        }
    }
    let info = ReductionInfo::default();
    Ok(match basis {
        None => ComponentReduction::from_transformation(
            name,
            sys,
            junction,
            &j_idx,
            t,
            fixed.frequencies_hz(),
            info,
        ),
        Some(_) => ComponentReduction::with_leading_coordinates(
            name,
            sys,
            junction,
            (1..=nc).map(Coordinate::InterfaceMode).collect(),
            t,
            fixed.frequencies_hz(),
            info,
        ),
    })
}

/// The junction block of a Craig-Bampton component: its static condensation onto the junction
/// (the substructure's Guyan model, 3.5–3.7: (3.5), (3.6), (3.7), with (3.14)),
/// `K_G = K_jj + K_ji Ψ = K_jj − K_ji K_ii⁻¹ K_ij` and `M_G = [I; Ψ]ᵀ M [I; Ψ]`.
#[derive(Clone, Debug, PartialEq)]
pub struct JunctionCondensation {
    /// The junction DOFs (rows and columns of `k` and `m`).
    pub junction: Vec<DofId>,
    /// `K_G`, `n_j × n_j`.
    pub k: Mat<f64>,
    /// `M_G`, `n_j × n_j`.
    pub m: Mat<f64>,
}

/// Junction columns solved per block in [`junction_condensation`]: the memory for `Ψ` is this
/// many columns of the substructure, never all `n_j`.
const CONDENSATION_BLOCK: usize = 128;

/// [`JunctionCondensation`] of one substructure, computed in blocks of junction columns without
/// holding `Ψ` (`N_k × n_j`, the memory that made whole-model reductions of million-DOF models
/// fail): with `Y = M_ij + M_ii Ψ`, the term `Ψᵀ Y = −K_ji (K_ii⁻¹ Y)` costs a second solve,
/// so memory is `O(n_j² + b N_k)` for two solves per junction DOF. It equals the junction block
/// of [`craig_bampton`]'s `TᵀKT`, `TᵀMT` (tested).
pub fn junction_condensation(
    name: &str,
    sys: &SystemMatrices,
    junction: &[DofId],
) -> Result<JunctionCondensation, ReductionError> {
    let (j_idx, i_idx) = split(sys, junction)?;
    let (nj, ni) = (j_idx.len(), i_idx.len());
    let dense = crate::core::sparse::sparse_to_dense;
    let mut kg = dense(&sub_block(&sys.k, &j_idx, &j_idx));
    let mut mg = dense(&sub_block(&sys.m, &j_idx, &j_idx));
    if nj > 0 && ni > 0 {
        let kii = sub_block(&sys.k, &i_idx, &i_idx);
        let mii = sub_block(&sys.m, &i_idx, &i_idx);
        let kij = sub_block(&sys.k, &i_idx, &j_idx);
        let mij = sub_block(&sys.m, &i_idx, &j_idx);
        // The substructures' condensations run one after another, each on all threads.
        let par = Par::rayon(0);
        let f = spd_factor(&kii, par).ok_or_else(|| ReductionError::NotRestrained {
            substructure: name.to_string(),
            junction: nj,
        })?;
        for start in (0..nj).step_by(CONDENSATION_BLOCK) {
            let cols = start..(start + CONDENSATION_BLOCK).min(nj);
            let mut psi = solve(&f, dense_columns(&kij, cols.clone()).as_ref(), par);
            psi *= faer::Scale(-1.0);
            let k_cols = sparse_transpose_times_dense(&kij, psi.as_ref());
            // `M_ii Ψ` reading each stored entry of `M_ii` once for the whole block.
            let mut y = dense_columns(&mij, cols.clone());
            let mut mpsi = Mat::zeros(ni, psi.ncols());
            crate::sparse::sym_matvec(&mii, psi.as_ref(), mpsi.as_mut(), par);
            y += &mpsi;
            let z = solve(&f, y.as_ref(), par);
            let m_cols = sparse_transpose_times_dense(&mij, psi.as_ref())
                - sparse_transpose_times_dense(&kij, z.as_ref());
            for (c, j) in cols.enumerate() {
                for i in 0..nj {
                    kg[(i, j)] += k_cols[(i, c)];
                    mg[(i, j)] += m_cols[(i, c)];
                }
            }
        }
    }
    Ok(JunctionCondensation {
        junction: junction.to_vec(),
        k: symmetrise(&kg),
        m: symmetrise(&mg),
    })
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
