//! Sparse real matrices in compressed sparse column form, shared by every numerical module:
//! built from triplets, read back as triplets or as a dense copy.

use crate::core::memory::split_at_offsets;
use faer::Mat;
use faer::sparse::{SparseColMat, Triplet};
use rayon::prelude::*;

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

/// Most rows or columns that triplets index with 32-bit integers (indices up to `i32::MAX`);
/// larger matrices get 64-bit ones.
pub const INT32_INDEXED: usize = 1 << 31;

/// Row or column indices of triplets: 32-bit for matrices of at most [`INT32_INDEXED`] rows
/// and columns, else 64-bit.
#[derive(Clone, Debug, PartialEq)]
pub enum TripletIndices {
    /// 32-bit indices.
    I32(Vec<i32>),
    /// 64-bit indices.
    I64(Vec<i64>),
}

/// A symmetric matrix's lower triangle (`row ≥ col`, diagonal included) as triplets in
/// column-major order, rows ascending within each column: half the entries of the full matrix,
/// the layout the matrices artefact stores.
#[derive(Clone, Debug, PartialEq)]
pub struct LowerTriplets {
    /// Row of each entry.
    pub rows: TripletIndices,
    /// Column of each entry.
    pub cols: TripletIndices,
    /// The entries.
    pub values: Vec<f64>,
}

impl LowerTriplets {
    /// The lower triangle of the symmetric `mat` (its entries above the diagonal are not
    /// read), gathered on all threads.
    pub fn of(mat: &SparseMatrix) -> Self {
        let symbolic = mat.symbolic();
        let entries = |j: usize| {
            let rows = symbolic.row_idx_of_col_raw(j).iter();
            rows.zip(symbolic.col_range(j))
                .filter(move |(i, _)| **i >= j)
                .map(|(&i, p)| (i, p))
        };
        let n = mat.nrows().max(mat.ncols());
        if n <= INT32_INDEXED {
            let (rows, cols, [values]) =
                gather_triplets(mat.ncols(), entries, |i| i as i32, [mat.val()]);
            let (rows, cols) = (TripletIndices::I32(rows), TripletIndices::I32(cols));
            Self { rows, cols, values }
        } else {
            let (rows, cols, [values]) =
                gather_triplets(mat.ncols(), entries, |i| i as i64, [mat.val()]);
            let (rows, cols) = (TripletIndices::I64(rows), TripletIndices::I64(cols));
            Self { rows, cols, values }
        }
    }
}

/// Column-major triplets of a matrix with `columns` columns, gathered on all threads a block
/// of columns at a time: column `j` holds the `(row, position)` pairs that `entries(j)` gives
/// (rows ascending), written as `index(row)`, `index(j)` and, for each slice of `values`, its
/// value at `position`. `entries` is walked twice, to count and to fill.
pub fn gather_triplets<I, E, const V: usize>(
    columns: usize,
    entries: impl Fn(usize) -> E + Sync,
    index: impl Fn(usize) -> I + Sync,
    values: [&[f64]; V],
) -> (Vec<I>, Vec<I>, [Vec<f64>; V])
where
    I: Copy + Default + Send + Sync,
    E: Iterator<Item = (usize, usize)>,
{
    /// Columns per parallel task.
    const COLUMNS: usize = 4096;
    let block = |b: usize| b * COLUMNS..((b + 1) * COLUMNS).min(columns);
    // Entries before each block of columns, so that the blocks fill their parts side by side.
    let counts: Vec<usize> = (0..columns.div_ceil(COLUMNS))
        .into_par_iter()
        .map(|b| block(b).map(|j| entries(j).count()).sum())
        .collect();
    let mut offsets = Vec::with_capacity(counts.len() + 1);
    offsets.push(0);
    for c in &counts {
        offsets.push(offsets[offsets.len() - 1] + c);
    }
    let nnz = offsets[counts.len()];
    let (mut row, mut col) = (vec![I::default(); nnz], vec![I::default(); nnz]);
    let mut out: [Vec<f64>; V] = std::array::from_fn(|_| vec![0.0; nnz]);
    let mut parts: Vec<Vec<&mut [f64]>> =
        (0..counts.len()).map(|_| Vec::with_capacity(V)).collect();
    for v in &mut out {
        for (b, part) in split_at_offsets(v, &offsets).into_iter().enumerate() {
            parts[b].push(part);
        }
    }
    split_at_offsets(&mut row, &offsets)
        .into_par_iter()
        .zip(split_at_offsets(&mut col, &offsets))
        .zip(parts)
        .enumerate()
        .for_each(|(b, ((row, col), mut parts))| {
            let mut k = 0;
            for j in block(b) {
                for (i, p) in entries(j) {
                    (row[k], col[k]) = (index(i), index(j));
                    for (part, source) in parts.iter_mut().zip(&values) {
                        part[k] = source[p];
                    }
                    k += 1;
                }
            }
        });
    (row, col, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lower triangle gathered by blocks of columns is a plain column-by-column scan of the
    /// entries on or below the diagonal: on a matrix of 10,000 columns (three blocks), with
    /// empty columns, entries far from the diagonal and entries above it that must be left out.
    #[test]
    fn the_lower_triangle_is_a_scan_of_the_entries_on_and_below_the_diagonal() {
        let n: usize = 10_000;
        let mut triplets = Vec::new();
        for j in 0..n {
            if j % 7 == 3 {
                continue;
            }
            for i in [j, (j * 31 + 5) % n, (j + 4_500) % n, j.saturating_sub(2)] {
                triplets.push((i, j, (i * n + j) as f64 * 0.5 - 1.0));
            }
        }
        let a = sparse_from_triplets("A", n, &triplets).unwrap();
        let want: Vec<(usize, usize, f64)> = sparse_triplets(&a)
            .into_iter()
            .filter(|(i, j, _)| i >= j)
            .collect();
        assert!(want.len() > n && want.len() < a.compute_nnz());
        let got = LowerTriplets::of(&a);
        let TripletIndices::I32(rows) = &got.rows else {
            panic!("32-bit indices expected for {n} columns");
        };
        let TripletIndices::I32(cols) = &got.cols else {
            panic!("32-bit indices expected for {n} columns");
        };
        let got: Vec<(usize, usize, f64)> = (0..rows.len())
            .map(|k| (rows[k] as usize, cols[k] as usize, got.values[k]))
            .collect();
        assert_eq!(got, want);
    }
}
