//! Sparse real matrices in compressed sparse column form, shared by every numerical module:
//! built from triplets, read back as triplets or as a dense copy.

use faer::Mat;
use faer::sparse::{SparseColMat, Triplet};

/// A sparse real matrix in compressed sparse column form.
pub type SparseMatrix = SparseColMat<usize, f64>;

/// Why a sparse matrix could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SparseError {
    /// A triplet index is out of range.
    #[error("matrix {name}: entry ({row}, {col}) is outside a {n}x{n} matrix")]
    IndexOutOfRange {
        /// Matrix name.
        name: &'static str,
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// Order of the matrix.
        n: usize,
    },
}

/// Builds an `n × n` sparse matrix from `(row, col, value)` triplets, summing duplicates.
pub fn sparse_from_triplets(
    name: &'static str,
    n: usize,
    triplets: &[(usize, usize, f64)],
) -> Result<SparseMatrix, SparseError> {
    let mut entries = Vec::with_capacity(triplets.len());
    for &(row, col, val) in triplets {
        if row >= n || col >= n {
            return Err(SparseError::IndexOutOfRange { name, row, col, n });
        }
        entries.push(Triplet::new(row, col, val));
    }
    SparseColMat::try_new_from_triplets(n, n, &entries).map_err(|_| SparseError::IndexOutOfRange {
        name,
        row: n,
        col: n,
        n,
    })
}

/// The stored entries of a sparse matrix as `(row, col, value)`, column-major order.
pub fn sparse_triplets(a: &SparseMatrix) -> Vec<(usize, usize, f64)> {
    let mut out = Vec::with_capacity(a.compute_nnz());
    for j in 0..a.ncols() {
        let rows = a.row_idx_of_col_raw(j);
        let vals = a.val_of_col(j);
        for (&i, &v) in rows.iter().zip(vals) {
            out.push((i, j, v));
        }
    }
    out
}

/// A dense copy of a sparse matrix.
pub fn sparse_to_dense(a: &SparseMatrix) -> Mat<f64> {
    let mut d = Mat::zeros(a.nrows(), a.ncols());
    for (i, j, v) in sparse_triplets(a) {
        d[(i, j)] += v;
    }
    d
}
