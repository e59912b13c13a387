//! Small sparse/dense helpers shared by the reduction methods: sub-blocks of a sparse matrix,
//! sparse × dense products, sparse Cholesky solves and a rank-checked pseudo-inverse.

use crate::core::sparse::SparseMatrix;
use crate::sparse::{SparseSolve, SpdFactor};
use faer::linalg::solvers::DenseSolveCore;
use faer::sparse::Triplet;
use faer::{Mat, MatRef, Par};
use rayon::prelude::*;

/// The block `A[rows, cols]` of a sparse matrix (`rows`, `cols` index lists into `A`).
pub fn sub_block(a: &SparseMatrix, rows: &[usize], cols: &[usize]) -> SparseMatrix {
    let mut map = vec![usize::MAX; a.nrows()];
    for (local, &g) in rows.iter().enumerate() {
        map[g] = local;
    }
    let mut trip = Vec::new();
    for (lc, &gc) in cols.iter().enumerate() {
        for (&i, &v) in a.row_idx_of_col_raw(gc).iter().zip(a.val_of_col(gc)) {
            if map[i] != usize::MAX {
                trip.push(Triplet::new(map[i], lc, v));
            }
        }
    }
    // Indices are in range by construction, so building cannot fail.
    SparseMatrix::try_new_from_triplets(rows.len(), cols.len(), &trip)
        .expect("sub-block indices are in range by construction")
}

/// `Y = A X` for a sparse `A` of any shape and a dense `X`, parallel over the columns of `X`
/// (each column summed in a fixed order: deterministic whatever the thread count).
pub fn sparse_times_dense(a: &SparseMatrix, x: MatRef<'_, f64>) -> Mat<f64> {
    let (n, c) = (a.nrows(), x.ncols());
    let cols: Vec<Vec<f64>> = (0..c)
        .into_par_iter()
        .map(|col| {
            let mut y = vec![0.0; n];
            for j in 0..a.ncols() {
                let xj = x[(j, col)];
                if xj != 0.0 {
                    for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
                        y[i] += v * xj;
                    }
                }
            }
            y
        })
        .collect();
    Mat::from_fn(n, c, |i, j| cols[j][i])
}

/// `Y = Aᵀ X` for a sparse `A` (`r × c`) and a dense `X` (`r × p`): each entry is one stored
/// column of `A` dotted with a column of `X`, in storage order (deterministic).
pub fn sparse_transpose_times_dense(a: &SparseMatrix, x: MatRef<'_, f64>) -> Mat<f64> {
    let cols: Vec<Vec<f64>> = (0..x.ncols())
        .into_par_iter()
        .map(|col| {
            (0..a.ncols())
                .map(|j| {
                    let mut s = 0.0;
                    for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
                        s += v * x[(i, col)];
                    }
                    s
                })
                .collect()
        })
        .collect();
    Mat::from_fn(a.ncols(), x.ncols(), |i, j| cols[j][i])
}

/// Columns `cols` of a sparse matrix as a dense block.
pub fn dense_columns(a: &SparseMatrix, cols: std::ops::Range<usize>) -> Mat<f64> {
    let mut d = Mat::zeros(a.nrows(), cols.len());
    for (c, j) in cols.enumerate() {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            d[(i, c)] += v;
        }
    }
    d
}

/// Sums dense symmetric blocks into one sparse `n × n` matrix pair: block `b` adds `K_b`, `M_b`
/// at the global indices `rows_b` (3.14's assembly at shared coordinates). Built column by
/// column straight into compressed storage, so memory is the result's non-zeros plus one
/// column (no triplet list, which would be three times the size of the blocks).
pub fn assemble_dense_blocks(
    n: usize,
    blocks: &[(&[usize], MatRef<'_, f64>, MatRef<'_, f64>)],
) -> (SparseMatrix, SparseMatrix) {
    // Which blocks hold each global column, and at which local index.
    let mut holders: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
    for (b, (rows, _, _)) in blocks.iter().enumerate() {
        for (l, &g) in rows.iter().enumerate() {
            holders[g].push((b, l));
        }
    }
    let mut col_ptr = Vec::with_capacity(n + 1);
    let (mut row_idx, mut kv, mut mv) = (Vec::new(), Vec::new(), Vec::new());
    let mut column: Vec<(usize, f64, f64)> = Vec::new();
    col_ptr.push(0);
    for held in &holders {
        column.clear();
        for &(b, l) in held {
            let (rows, k, m) = &blocks[b];
            for (r, &g) in rows.iter().enumerate() {
                column.push((g, k[(r, l)], m[(r, l)]));
            }
        }
        column.sort_unstable_by_key(|e| e.0);
        let start = row_idx.len();
        for &(g, k, m) in &column {
            if row_idx.len() > start && row_idx.last() == Some(&g) {
                *kv.last_mut().expect("a row was pushed with its value") += k;
                *mv.last_mut().expect("a row was pushed with its value") += m;
            } else {
                row_idx.push(g);
                kv.push(k);
                mv.push(m);
            }
        }
        col_ptr.push(row_idx.len());
    }
    let symbolic = faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
    (
        SparseMatrix::new(symbolic.clone(), kv),
        SparseMatrix::new(symbolic, mv),
    )
}

/// `Tᵀ A T` for a sparse symmetric `A` and dense `T`, symmetrised.
pub fn project(a: &SparseMatrix, t: MatRef<'_, f64>) -> Mat<f64> {
    let at = sparse_times_dense(a, t);
    let p = t.transpose() * &at;
    symmetrise(&p)
}

/// `(A + Aᵀ)/2`.
pub fn symmetrise(a: &Mat<f64>) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * (a[(i, j)] + a[(j, i)]))
}

/// The sparse Cholesky factor of a symmetric positive definite `A` (full symmetric storage;
/// only the lower triangle is read), made with parallelism `par`; `None` when `A` is not
/// positive definite.
pub fn spd_factor(a: &SparseMatrix, par: Par) -> Option<SpdFactor> {
    SpdFactor::new(a, par).ok()
}

/// `A⁻¹ B` by a factor of `A`, solved with parallelism `par`.
pub fn solve(a: &impl SparseSolve<f64>, b: MatRef<'_, f64>, par: Par) -> Mat<f64> {
    let mut x = b.to_owned();
    a.solve_in_place(x.as_mut(), par);
    x
}

/// Moore–Penrose pseudo-inverse of a matrix of full column rank, with its 2-norm condition
/// number; `None` when the smallest singular value is below `1e-12` of the largest (rank
/// deficient) or the SVD fails.
pub fn pinv_full_column_rank(a: MatRef<'_, f64>) -> Option<(Mat<f64>, f64)> {
    if a.ncols() == 0 {
        return Some((Mat::zeros(0, a.nrows()), 1.0));
    }
    if a.nrows() < a.ncols() {
        return None;
    }
    let svd = a.thin_svd().ok()?;
    let s = svd.S();
    let k = a.ncols();
    let (mut smax, mut smin) = (0.0f64, f64::INFINITY);
    for i in 0..k {
        smax = smax.max(s[i]);
        smin = smin.min(s[i]);
    }
    if !(smin > 1e-12 * smax) {
        return None;
    }
    Some((svd.pseudoinverse(), smax / smin))
}

/// Inverse of a small square matrix by LU with partial pivoting; `None` when it is singular to
/// working precision (a non-finite entry or a reciprocal condition estimate below `1e-14`).
pub fn inverse(a: &Mat<f64>) -> Option<Mat<f64>> {
    let n = a.nrows();
    if n == 0 {
        return Some(Mat::zeros(0, 0));
    }
    let inv = a.partial_piv_lu().inverse();
    let norm = |m: &Mat<f64>| {
        (0..m.nrows())
            .map(|i| (0..m.ncols()).map(|j| m[(i, j)].abs()).sum::<f64>())
            .fold(0.0f64, f64::max)
    };
    let (na, ni) = (norm(a), norm(&inv));
    if !(na > 0.0 && na.is_finite() && ni.is_finite() && 1.0 / (na * ni) > 1e-14) {
        return None;
    }
    Some(inv)
}

/// `max |A − B|` over all entries.
pub fn max_diff(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> f64 {
    let mut s = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            s = s.max((a[(i, j)] - b[(i, j)]).abs());
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Products and blocks checked against their dense definitions (exact arithmetic on small
    /// integers, so equality is exact).
    #[test]
    fn blocks_and_products_match_dense() {
        let trip: Vec<(usize, usize, f64)> = vec![
            (0, 0, 4.0),
            (1, 1, 5.0),
            (2, 2, 6.0),
            (0, 1, 1.0),
            (1, 0, 1.0),
            (1, 2, 2.0),
            (2, 1, 2.0),
        ];
        let a = crate::core::sparse::sparse_from_triplets("A", 3, &trip).unwrap();
        let d = crate::core::sparse::sparse_to_dense(&a);
        let b = sub_block(&a, &[2, 0], &[1]);
        assert_eq!(crate::core::sparse::sparse_to_dense(&b)[(0, 0)], 2.0);
        assert_eq!(crate::core::sparse::sparse_to_dense(&b)[(1, 0)], 1.0);
        let x = Mat::from_fn(3, 2, |i, j| (i + 2 * j) as f64);
        let y = sparse_times_dense(&a, x.as_ref());
        assert_eq!(max_diff(y.as_ref(), (&d * &x).as_ref()), 0.0);
        let f = spd_factor(&a, Par::Seq).unwrap();
        let z = solve(&f, y.as_ref(), Par::Seq);
        assert!(max_diff(z.as_ref(), x.as_ref()) < 1e-13);
        let inv = inverse(&d).unwrap();
        assert!(max_diff((&inv * &d).as_ref(), Mat::<f64>::identity(3, 3).as_ref()) < 1e-14);
        assert!(inverse(&Mat::<f64>::zeros(2, 2)).is_none());
        let (p, cond) = pinv_full_column_rank(x.as_ref()).unwrap();
        assert!(cond >= 1.0);
        assert!(max_diff((&p * &x).as_ref(), Mat::<f64>::identity(2, 2).as_ref()) < 1e-13);
    }
}
