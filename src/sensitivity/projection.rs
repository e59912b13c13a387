//! Modal projections of derivative matrices, `Φᵀ (∂K/∂φ) Φ` and `Φᵀ (∂M/∂φ) Φ` (4.5), and the
//! eigenvalue sensitivity `∂λ_r/∂φ = φ_rᵀ (∂K/∂φ − λ_r ∂M/∂φ) φ_r` (5.3) that is their diagonal.
//!
//! A parameter's derivative matrix is non-zero only on the DOFs of its elements, so the product
//! gathers those rows of `Φ` and never touches the rest of the model: the cost is
//! `nnz(∂K/∂φ)·m + |support|·m²`, independent of the model size.

use crate::core::sparse::SparseMatrix;
use faer::{Mat, MatRef};

/// `Φᵀ (∂K/∂φ) Φ` and `Φᵀ (∂M/∂φ) Φ` of one parameter (`m × m`, symmetric).
#[derive(Clone, Debug, PartialEq)]
pub struct ProjectedDerivative {
    /// `Φᵀ (∂K/∂φ) Φ`.
    pub k: Mat<f64>,
    /// `Φᵀ (∂M/∂φ) Φ`.
    pub m: Mat<f64>,
}

impl ProjectedDerivative {
    /// Both projections of a parameter's `(∂K/∂φ, ∂M/∂φ)` on the modes `phi` (`N × m`).
    pub fn new(dk: &SparseMatrix, dm: &SparseMatrix, phi: MatRef<'_, f64>) -> Self {
        ProjectedDerivative {
            k: project(dk, phi),
            m: project(dm, phi),
        }
    }

    /// Scales both by `s` (unity-based parameters use `φ ∂Z/∂φ`, 2.16).
    pub fn scaled(mut self, s: f64) -> Self {
        self.k *= faer::Scale(s);
        self.m *= faer::Scale(s);
        self
    }

    /// Number of modes.
    pub fn modes(&self) -> usize {
        self.k.nrows()
    }
}

/// `Φᵀ A Φ` for a sparse `A` (`N × N`) and dense `Φ` (`N × m`), over the support of `A` only,
/// symmetrised to remove the round-off of the two-sided product.
pub fn project(a: &SparseMatrix, phi: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = project_between(a, phi, phi);
    let m = out.nrows();
    for r in 0..m {
        for c in 0..r {
            let v = 0.5 * (out[(r, c)] + out[(c, r)]);
            out[(r, c)] = v;
            out[(c, r)] = v;
        }
    }
    out
}

/// `Lᵀ A R` for a sparse `A` (`N × N`) and dense `L` (`N × n`), `R` (`N × m`), over the support
/// of `A` only (the cross projection of the static shape-derivative correction).
pub fn project_between(
    a: &SparseMatrix,
    left: MatRef<'_, f64>,
    right: MatRef<'_, f64>,
) -> Mat<f64> {
    let (n, m) = (left.ncols(), right.ncols());
    let col_ptr = a.symbolic().col_ptr();
    let row_idx = a.symbolic().row_idx();
    let values = a.val();
    let mut out = Mat::<f64>::zeros(n, m);
    // (A R) row by row of the support, accumulated column by column of A, then Lᵀ on the left.
    // Only the stored columns are visited: a parameter's derivative touches a few elements of a
    // model of up to millions of DOFs, and reading a row of `R` costs a cache miss per column.
    let mut slot = vec![usize::MAX; a.nrows()];
    let mut rows = Vec::new();
    let mut columns = Vec::new();
    for j in 0..a.ncols() {
        if col_ptr[j] == col_ptr[j + 1] {
            continue;
        }
        columns.push(j);
        for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
            if slot[i] == usize::MAX {
                slot[i] = rows.len();
                rows.push(i);
            }
        }
    }
    if rows.is_empty() {
        return out;
    }
    // The rows of `R` at the stored columns, row-major: every stored entry of `A` is then one
    // axpy over `m` contiguous values, its indices read once (not once per column of `R`).
    let mut right_rows = vec![0.0; columns.len() * m];
    for c in 0..m {
        let rc = right.col(c);
        for (jj, &j) in columns.iter().enumerate() {
            right_rows[jj * m + c] = rc[j];
        }
    }
    let mut ar = vec![0.0; rows.len() * m];
    for (jj, &j) in columns.iter().enumerate() {
        let rj = &right_rows[jj * m..(jj + 1) * m];
        for k in col_ptr[j]..col_ptr[j + 1] {
            let v = values[k];
            let at = slot[row_idx[k]] * m;
            for (o, r) in ar[at..at + m].iter_mut().zip(rj) {
                *o += v * r;
            }
        }
    }
    let ar = MatRef::from_row_major_slice(&ar, rows.len(), m);
    let l = Mat::from_fn(rows.len(), n, |r, c| left[(rows[r], c)]);
    out += l.transpose() * ar;
    out
}

/// `∂λ_r/∂φ = [Φᵀ ∂K Φ]_rr − λ_r [Φᵀ ∂M Φ]_rr` for every mode (5.3).
pub fn eigenvalue_sensitivity(eigenvalues: &[f64], d: &ProjectedDerivative) -> Vec<f64> {
    eigenvalues
        .iter()
        .enumerate()
        .map(|(r, &l)| d.k[(r, r)] - l * d.m[(r, r)])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::{sparse_from_triplets, sparse_to_dense};

    /// The support-gathered product equals the dense `Φᵀ A Φ` to round-off.
    #[test]
    fn projection_matches_the_dense_product() {
        let n = 40;
        let mut t = Vec::new();
        for i in 10..18 {
            for j in 10..18 {
                let v = ((i * 7 + j * 3) % 11) as f64 - 5.0;
                t.push((i, j, v + if i == j { 20.0 } else { 0.0 }));
                t.push((j, i, v));
            }
        }
        let a = sparse_from_triplets("A", n, &t).unwrap();
        let phi = Mat::from_fn(n, 6, |i, j| ((i * 13 + j * 29) % 17) as f64 / 17.0 - 0.4);
        let p = project(&a, phi.as_ref());
        let dense = phi.transpose() * sparse_to_dense(&a) * &phi;
        let scale = dense.norm_max();
        for r in 0..6 {
            for c in 0..6 {
                let sym = 0.5 * (dense[(r, c)] + dense[(c, r)]);
                assert!((p[(r, c)] - sym).abs() <= 1e-13 * scale);
            }
        }
    }
}
