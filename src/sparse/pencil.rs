//! The stiffness and mass of a symmetric pencil `(K, M)` as lower triangles on one pattern:
//! what the eigensolver holds of a model.
//!
//! Two full matrices in faer's storage cost 16 bytes per entry each, both triangles. Here one
//! pattern of 32-bit row indices serves both matrices and only the lower triangle is kept: at
//! a million shell DOFs 0.76 GB instead of 1.72 GB. The products `K X`, `M X` need every row
//! of the full matrix; row `j`'s entries left of the diagonal lie in the columns before `j`,
//! and an index of them (column and position, 8 bytes per entry) lets each row be gathered
//! in the same order as column `j` of the full matrix: the products are bit for bit those of
//! [`super::sym_matvec_pair`] on the mirrored matrices.

use super::combination::merge_lower_column;
use super::product::{Contiguous, Gathered, SymmetricRows, in_passes};
use crate::core::memory::split_at_offsets;
use crate::core::sparse::SparseMatrix;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use faer::{Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// Why a pencil could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PencilError {
    /// `K` and `M` are not square matrices of one order.
    #[error(
        "K is {k_rows}x{k_cols} and M is {m_rows}x{m_cols}: the pencil needs two square matrices of one order"
    )]
    Shape {
        /// Rows of `K`.
        k_rows: usize,
        /// Columns of `K`.
        k_cols: usize,
        /// Rows of `M`.
        m_rows: usize,
        /// Columns of `M`.
        m_cols: usize,
    },
    /// More entries or DOFs than a 32-bit index addresses.
    #[error(
        "the lower triangles of K and M hold {entries} entries on {n} DOFs; at most {max} of each fit the eigensolver's 32-bit indices"
    )]
    TooLarge {
        /// Stored entries.
        entries: usize,
        /// Order.
        n: usize,
        /// Most of either.
        max: usize,
    },
}

/// `K` and `M` as lower triangles (diagonal included) in compressed columns on one pattern,
/// rows ascending in each column, with the index of every row's entries left of the diagonal.
#[derive(Clone, Debug)]
pub struct LowerPencil {
    /// Column `j`'s entries are `col_ptr[j]..col_ptr[j + 1]`.
    col_ptr: Vec<usize>,
    rows: Vec<u32>,
    k: Vec<f64>,
    m: Vec<f64>,
    /// Row `j`'s entries `(j, i)`, `i < j`, are `upper_ptr[j]..upper_ptr[j + 1]` of
    /// `upper_cols` (`i`, ascending) and `upper_pos` (where the entry lies in `rows`, `k`, `m`).
    upper_ptr: Vec<usize>,
    upper_cols: Vec<u32>,
    upper_pos: Vec<u32>,
}

/// Whether two slices are equal, compared on all threads.
fn same<T: PartialEq + Sync>(a: &[T], b: &[T]) -> bool {
    const CHUNK: usize = 1 << 16;
    a.len() == b.len()
        && a.par_chunks(CHUNK)
            .zip(b.par_chunks(CHUNK))
            .all(|(x, y)| x == y)
}

/// Columns per task when columns are merged in parallel.
const COLUMNS_PER_TASK: usize = 4096;

/// The common order of `K` and `M`, or the error naming both shapes.
fn square_order(k: &SparseMatrix, m: &SparseMatrix) -> Result<usize, PencilError> {
    let n = k.nrows();
    if k.ncols() != n || m.nrows() != n || m.ncols() != n {
        return Err(PencilError::Shape {
            k_rows: k.nrows(),
            k_cols: k.ncols(),
            m_rows: m.nrows(),
            m_cols: m.ncols(),
        });
    }
    Ok(n)
}

/// A row or column index given as a signed integer, 32-bit or 64-bit (as lists of triplets
/// store them).
pub trait IntegerIndex: Copy + Into<i64> + PartialEq + Send + Sync {}

impl IntegerIndex for i32 {}
impl IntegerIndex for i64 {}

impl LowerPencil {
    /// The pencil of `K` and `M` stored in full (or as lower triangles; entries above the
    /// diagonal are not read), on the union of their lower patterns. Entries of one row in one
    /// column are summed.
    pub fn from_full(k: &SparseMatrix, m: &SparseMatrix) -> Result<Self, PencilError> {
        let n = square_order(k, m)?;
        check_size(n, (k.compute_nnz() + m.compute_nnz()) / 2 + n)?;
        // Each column merged twice on all threads: once to count its entries, once to write
        // them where the counts put them (no intermediate arrays).
        let counts: Vec<usize> = (0..n)
            .into_par_iter()
            .with_min_len(COLUMNS_PER_TASK)
            .map_init(Vec::new, |column, j| {
                merge_lower_column(j, k, m, column);
                column.len()
            })
            .collect();
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        for c in counts {
            col_ptr.push(col_ptr[col_ptr.len() - 1] + c);
        }
        let nnz = col_ptr[n];
        let (mut rows, mut kv, mut mv) = (vec![0u32; nnz], vec![0.0; nnz], vec![0.0; nnz]);
        let firsts: Vec<usize> = (0..n).step_by(COLUMNS_PER_TASK).collect();
        let offsets: Vec<usize> = firsts.iter().map(|&j| col_ptr[j]).chain([nnz]).collect();
        let parts = split_at_offsets(&mut rows, &offsets)
            .into_iter()
            .zip(split_at_offsets(&mut kv, &offsets))
            .zip(split_at_offsets(&mut mv, &offsets))
            .zip(firsts);
        parts
            .collect::<Vec<_>>()
            .into_par_iter()
            .for_each(|(((rows, kv), mv), first)| {
                let mut column = Vec::new();
                let mut at = 0;
                for j in first..(first + COLUMNS_PER_TASK).min(n) {
                    merge_lower_column(j, k, m, &mut column);
                    for (t, &(i, a, b)) in column.iter().enumerate() {
                        (rows[at + t], kv[at + t], mv[at + t]) = (i as u32, a, b);
                    }
                    at += column.len();
                }
            });
        Ok(Self::with_upper_index(col_ptr, rows, kv, mv))
    }

    /// The pencil of two lower triangles given as `(rows, cols, values)` in column-major
    /// order with rows strictly ascending in each column (as femu's matrices artefacts store
    /// them), merged without sorting; an entry only one of them stores is zero in the other.
    /// `None` when a list is out of that order, holds an entry above the diagonal or an index
    /// outside `0..n`, or when the pencil is too large for its indices: the caller then reads
    /// the matrices through the general path, which names the fault. The indices are 32-bit or
    /// 64-bit integers (`I`), as the tables hold them.
    pub fn from_sorted_lower<I: IntegerIndex>(
        n: usize,
        k: (&[I], &[I], &[f64]),
        m: (&[I], &[I], &[f64]),
    ) -> Option<Self> {
        let (kr, kc, kv) = k;
        let (mr, mc, mv) = m;
        if kr.len() != kc.len() || kr.len() != kv.len() {
            return None;
        }
        if mr.len() != mc.len() || mr.len() != mv.len() {
            return None;
        }
        check_size(n, kr.len().max(mr.len())).ok()?;
        let key = |r: I, c: I| -> Option<(usize, usize)> {
            let (r, c) = (
                usize::try_from(r.into()).ok()?,
                usize::try_from(c.into()).ok()?,
            );
            (r < n && c <= r).then_some((c, r))
        };
        if same(kr, mr) && same(kc, mc) {
            return Self::from_one_sorted_pattern(n, (kr, kc), kv, mv, key);
        }
        let (mut p, mut q) = (0, 0);
        let mut previous: Option<(usize, usize)> = None;
        let mut col_ptr = vec![0usize; n + 1];
        let capacity = kr.len().max(mr.len());
        let (mut rows, mut ks, mut ms) = (
            Vec::with_capacity(capacity),
            Vec::with_capacity(capacity),
            Vec::with_capacity(capacity),
        );
        while p < kr.len() || q < mr.len() {
            let a = if p < kr.len() {
                Some(key(kr[p], kc[p])?)
            } else {
                None
            };
            let b = if q < mr.len() {
                Some(key(mr[q], mc[q])?)
            } else {
                None
            };
            // The smaller head is taken; equal heads are one entry of both.
            let (take_k, take_m) = match (a, b) {
                (Some(a), Some(b)) => (a <= b, b <= a),
                (a, b) => (a.is_some(), b.is_some()),
            };
            let (mut at, mut kval, mut mval) = ((0, 0), 0.0, 0.0);
            if take_k {
                (at, kval) = (a?, kv[p]);
                p += 1;
            }
            if take_m {
                (at, mval) = (b?, mv[q]);
                q += 1;
            }
            if previous.is_some_and(|prev| at <= prev) {
                return None;
            }
            previous = Some(at);
            col_ptr[at.0 + 1] += 1;
            rows.push(at.1 as u32);
            ks.push(kval);
            ms.push(mval);
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        Some(Self::with_upper_index(col_ptr, rows, ks, ms))
    }

    /// [`Self::from_sorted_lower`] when `K` and `M` store the same entries (as the assembly
    /// writes them, on the union of their patterns): the order is checked and the arrays
    /// converted on all threads, with no merge.
    fn from_one_sorted_pattern<I: IntegerIndex>(
        n: usize,
        (rows, cols): (&[I], &[I]),
        k: &[f64],
        m: &[f64],
        key: impl Fn(I, I) -> Option<(usize, usize)> + Sync,
    ) -> Option<Self> {
        const CHUNK: usize = 1 << 16;
        let ordered = rows
            .par_chunks(CHUNK)
            .zip(cols.par_chunks(CHUNK))
            .enumerate()
            .all(|(c, (r, cc))| {
                // The entry before the chunk; its own chunk checks that it is valid.
                let mut previous = (c > 0).then(|| key(rows[c * CHUNK - 1], cols[c * CHUNK - 1]));
                for (&r, &cc) in r.iter().zip(cc) {
                    let Some(at) = key(r, cc) else {
                        return false;
                    };
                    if previous.is_some_and(|p| p.is_some_and(|p| at <= p)) {
                        return false;
                    }
                    previous = Some(Some(at));
                }
                true
            });
        if !ordered {
            return None;
        }
        let mut col_ptr = vec![0usize; n + 1];
        // Every index was checked above: 0 ≤ col ≤ row < n.
        for &c in cols {
            col_ptr[c.into() as usize + 1] += 1;
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let rows: Vec<u32> = rows.par_iter().map(|&r| r.into() as u32).collect();
        let (k, m) = rayon::join(|| k.to_vec(), || m.to_vec());
        Some(Self::with_upper_index(col_ptr, rows, k, m))
    }

    /// The pencil of the lower columns given (rows strictly ascending in each), with its row
    /// index built.
    ///
    /// The rows are cut into blocks, each indexed by one task: it finds its rows in each column
    /// by bisection (a column whose last row lies above the block is passed over at once) and
    /// writes its own part of the index, so the blocks need no merge. Each row's list comes out
    /// in ascending column order.
    fn with_upper_index(col_ptr: Vec<usize>, rows: Vec<u32>, k: Vec<f64>, m: Vec<f64>) -> Self {
        let n = col_ptr.len() - 1;
        let blocks = (4 * rayon::current_num_threads()).clamp(1, n.max(1));
        let bounds: Vec<usize> = (0..=blocks).map(|b| b * n / blocks).collect();
        // Positions in `rows` of column `j`'s entries in rows `first..end`, below the diagonal.
        let entries_in = |j: usize, first: usize, end: usize| {
            let column = &rows[col_ptr[j]..col_ptr[j + 1]];
            if column.last().is_none_or(|&i| (i as usize) < first) {
                return 0..0;
            }
            let from = column.partition_point(|&i| (i as usize) < first.max(j + 1));
            let to = column.partition_point(|&i| (i as usize) < end);
            col_ptr[j] + from..col_ptr[j] + to.max(from)
        };
        // Entries left of the diagonal in each row, block by block.
        let counts: Vec<Vec<usize>> = bounds
            .par_windows(2)
            .map(|b| {
                let (first, end) = (b[0], b[1]);
                let mut count = vec![0usize; end - first];
                for j in 0..end {
                    for &i in &rows[entries_in(j, first, end)] {
                        count[i as usize - first] += 1;
                    }
                }
                count
            })
            .collect();
        let mut upper_ptr = Vec::with_capacity(n + 1);
        upper_ptr.push(0);
        for c in counts.iter().flatten() {
            upper_ptr.push(upper_ptr[upper_ptr.len() - 1] + c);
        }
        let entries = upper_ptr[n];
        let (mut upper_cols, mut upper_pos) = (vec![0u32; entries], vec![0u32; entries]);
        let offsets: Vec<usize> = bounds.iter().map(|&r| upper_ptr[r]).collect();
        split_at_offsets(&mut upper_cols, &offsets)
            .into_par_iter()
            .zip(split_at_offsets(&mut upper_pos, &offsets))
            .zip(bounds.par_windows(2))
            .for_each(|((cols, pos), b)| {
                let (first, end) = (b[0], b[1]);
                let base = upper_ptr[first];
                let mut next: Vec<usize> = upper_ptr[first..end].iter().map(|p| p - base).collect();
                for j in 0..end {
                    for p in entries_in(j, first, end) {
                        let slot = &mut next[rows[p] as usize - first];
                        (cols[*slot], pos[*slot]) = (j as u32, p as u32);
                        *slot += 1;
                    }
                }
            });
        LowerPencil {
            col_ptr,
            rows,
            k,
            m,
            upper_ptr,
            upper_cols,
            upper_pos,
        }
    }

    /// Entries stored (lower triangle, diagonal included).
    pub fn lower_entries(&self) -> usize {
        self.rows.len()
    }

    fn diagonal(&self, values: &[f64], j: usize) -> f64 {
        let start = self.col_ptr[j];
        match self.rows.get(start) {
            Some(&i) if start < self.col_ptr[j + 1] && i as usize == j => values[start],
            _ => 0.0,
        }
    }

    fn dense(&self, values: &[f64]) -> Mat<f64> {
        let n = self.n();
        let mut a = Mat::zeros(n, n);
        for j in 0..n {
            let range = self.col_ptr[j]..self.col_ptr[j + 1];
            for (&i, &v) in self.rows[range.clone()].iter().zip(&values[range]) {
                a[(i as usize, j)] = v;
                a[(j, i as usize)] = v;
            }
        }
        a
    }

    fn check_shapes(&self, x: MatRef<'_, f64>, y: MatRef<'_, f64>, name: &str) {
        assert_eq!(
            (x.nrows(), y.nrows(), y.ncols()),
            (self.n(), self.n(), x.ncols()),
            "{name} = (K or M) X needs X and {name} of the pencil's rows and of equal width"
        );
    }
}

/// Fails when `entries` or `n` exceed the 32-bit indices.
fn check_size(n: usize, entries: usize) -> Result<(), PencilError> {
    let max = u32::MAX as usize;
    if entries > max || n > max {
        return Err(PencilError::TooLarge { entries, n, max });
    }
    Ok(())
}

/// A pencil's rows for the products: row `j`'s entries left of the diagonal, through the
/// index, then column `j`'s own entries in place.
struct PencilRows<'a, const N: usize> {
    pencil: &'a LowerPencil,
    values: [&'a [f64]; N],
}

impl<const N: usize> SymmetricRows<N> for PencilRows<'_, N> {
    type First<'s>
        = Gathered<'s, N>
    where
        Self: 's;
    type Second<'s>
        = Contiguous<'s, u32, N>
    where
        Self: 's;

    fn row(&self, j: usize) -> (Gathered<'_, N>, Contiguous<'_, u32, N>) {
        let p = self.pencil;
        let upper = p.upper_ptr[j]..p.upper_ptr[j + 1];
        let lower = p.col_ptr[j]..p.col_ptr[j + 1];
        let left = Gathered {
            indices: &p.upper_cols[upper.clone()],
            positions: &p.upper_pos[upper],
            values: self.values,
        };
        let own = Contiguous {
            indices: &p.rows[lower.clone()],
            values: self.values.map(|v| &v[lower.clone()]),
        };
        (left, own)
    }
}

/// A symmetric pencil `(K, M)` as the eigensolver reads it: held as lower triangles on one
/// pattern ([`LowerPencil`], what the `modes` stage reads from an artefact), or as two full
/// matrices that their owner holds anyway ([`FullPencil`], an update's model).
pub trait SymmetricPencil: Sync {
    /// Order of `K` and `M`.
    fn n(&self) -> usize;
    /// `K_jj`.
    fn k_diagonal(&self, j: usize) -> f64;
    /// `M_jj`.
    fn m_diagonal(&self, j: usize) -> f64;
    /// Whether row (and column) `j` of `M` holds a non-zero.
    fn has_mass(&self, j: usize) -> bool;
    /// Column `j`'s entries of `M` on and below the diagonal: `(row, value)`, rows ascending.
    fn m_lower_entries(&self, j: usize) -> Vec<(usize, f64)>;
    /// Dense `K` (small models: the dense eigensolver).
    fn k_dense(&self) -> Mat<f64>;
    /// Dense `M`.
    fn m_dense(&self) -> Mat<f64>;
    /// The lower triangle of `α K + β M` on the union of the patterns, in faer's storage.
    fn lower_combination(&self, alpha: f64, beta: f64) -> SparseMatrix;
    /// `KX = K X` and `MX = M X`.
    fn products(&self, x: MatRef<'_, f64>, kx: MatMut<'_, f64>, mx: MatMut<'_, f64>, par: Par);
    /// `Y = M X`.
    fn mass_product(&self, x: MatRef<'_, f64>, y: MatMut<'_, f64>, par: Par);
}

impl SymmetricPencil for LowerPencil {
    fn n(&self) -> usize {
        self.col_ptr.len() - 1
    }

    fn k_diagonal(&self, j: usize) -> f64 {
        self.diagonal(&self.k, j)
    }

    fn m_diagonal(&self, j: usize) -> f64 {
        self.diagonal(&self.m, j)
    }

    fn has_mass(&self, j: usize) -> bool {
        let lower = self.m[self.col_ptr[j]..self.col_ptr[j + 1]].iter();
        let upper = self.upper_pos[self.upper_ptr[j]..self.upper_ptr[j + 1]]
            .iter()
            .map(|&p| &self.m[p as usize]);
        lower.chain(upper).any(|v| *v != 0.0)
    }

    fn m_lower_entries(&self, j: usize) -> Vec<(usize, f64)> {
        let range = self.col_ptr[j]..self.col_ptr[j + 1];
        let rows = self.rows[range.clone()].iter().map(|&i| i as usize);
        rows.zip(self.m[range].iter().copied()).collect()
    }

    fn k_dense(&self) -> Mat<f64> {
        self.dense(&self.k)
    }

    fn m_dense(&self) -> Mat<f64> {
        self.dense(&self.m)
    }

    /// Every stored entry is `α k + β m`, an entry absent from one matrix counting as zero:
    /// bit for bit [`super::lower_combination`] of the full matrices (the same merge and sum).
    fn lower_combination(&self, alpha: f64, beta: f64) -> SparseMatrix {
        let nnz = self.rows.len();
        let mut rows = vec![0usize; nnz];
        let mut vals = vec![0.0f64; nnz];
        const CHUNK: usize = 1 << 16;
        rows.par_chunks_mut(CHUNK)
            .zip(vals.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (r, v))| {
                let start = c * CHUNK;
                for (t, (r, v)) in r.iter_mut().zip(v).enumerate() {
                    let p = start + t;
                    *r = self.rows[p] as usize;
                    *v = alpha * self.k[p] + beta * self.m[p];
                }
            });
        let n = self.n();
        let symbolic = SymbolicSparseColMat::new_checked(n, n, self.col_ptr.clone(), None, rows);
        SparseColMat::new(symbolic, vals)
    }

    /// In one pass over the pattern, as [`super::sym_matvec_pair`], whose sums it repeats in
    /// order: the results are the same bits.
    fn products(
        &self,
        x: MatRef<'_, f64>,
        mut kx: MatMut<'_, f64>,
        mut mx: MatMut<'_, f64>,
        par: Par,
    ) {
        self.check_shapes(x, kx.as_ref(), "KX");
        self.check_shapes(x, mx.as_ref(), "MX");
        let source = PencilRows {
            pencil: self,
            values: [&self.k, &self.m],
        };
        in_passes(&source, x, [kx.as_mut(), mx.as_mut()], par);
    }

    /// As [`super::sym_matvec`] of the full `M`.
    fn mass_product(&self, x: MatRef<'_, f64>, mut y: MatMut<'_, f64>, par: Par) {
        self.check_shapes(x, y.as_ref(), "MX");
        let source = PencilRows {
            pencil: self,
            values: [&self.m],
        };
        in_passes(&source, x, [y.as_mut()], par);
    }
}

/// `K` and `M` stored in full (both triangles), borrowed from
/// their owner: no copy is made (an update's model holds them for its derivatives anyway,
/// 0.9 GB of pencil at a million DOFs), and the products read the contiguous columns
/// ([`super::sym_matvec_pair`]). With one pattern, every product and combination is the same
/// bits as the [`LowerPencil`] of the same matrices.
pub struct FullPencil<'a> {
    k: &'a SparseMatrix,
    m: &'a SparseMatrix,
    k_diagonal: Vec<f64>,
    m_diagonal: Vec<f64>,
}

impl<'a> FullPencil<'a> {
    /// The pencil of `k` and `m`, which must be square of one order.
    pub fn new(k: &'a SparseMatrix, m: &'a SparseMatrix) -> Result<Self, PencilError> {
        let n = square_order(k, m)?;
        let diagonal = |a: &SparseMatrix| -> Vec<f64> {
            (0..n)
                .into_par_iter()
                .map(|j| {
                    // Duplicates summed, in whatever order the column stores its rows.
                    let rows = a.row_idx_of_col_raw(j).iter();
                    rows.zip(a.val_of_col(j))
                        .filter(|(i, _)| **i == j)
                        .map(|(_, v)| *v)
                        .sum()
                })
                .collect()
        };
        let (k_diagonal, m_diagonal) = rayon::join(|| diagonal(k), || diagonal(m));
        Ok(FullPencil {
            k,
            m,
            k_diagonal,
            m_diagonal,
        })
    }
}

/// The dense symmetric matrix of `a`'s lower triangle (as [`LowerPencil`]'s dense copies).
fn mirrored_lower(a: &SparseMatrix) -> Mat<f64> {
    let n = a.ncols();
    let mut d = Mat::zeros(n, n);
    for j in 0..n {
        let rows = a.row_idx_of_col_raw(j).iter();
        for (&i, &v) in rows.zip(a.val_of_col(j)).filter(|(i, _)| **i >= j) {
            d[(i, j)] = v;
            d[(j, i)] = v;
        }
    }
    d
}

impl SymmetricPencil for FullPencil<'_> {
    fn n(&self) -> usize {
        self.k.nrows()
    }
    fn k_diagonal(&self, j: usize) -> f64 {
        self.k_diagonal[j]
    }
    fn m_diagonal(&self, j: usize) -> f64 {
        self.m_diagonal[j]
    }
    fn has_mass(&self, j: usize) -> bool {
        self.m.val_of_col(j).iter().any(|v| *v != 0.0)
    }
    fn m_lower_entries(&self, j: usize) -> Vec<(usize, f64)> {
        let rows = self.m.row_idx_of_col_raw(j).iter().copied();
        rows.zip(self.m.val_of_col(j).iter().copied())
            .filter(|(i, _)| *i >= j)
            .collect()
    }
    fn k_dense(&self) -> Mat<f64> {
        mirrored_lower(self.k)
    }
    fn m_dense(&self) -> Mat<f64> {
        mirrored_lower(self.m)
    }
    fn lower_combination(&self, alpha: f64, beta: f64) -> SparseMatrix {
        super::lower_combination(alpha, self.k, beta, self.m)
    }
    fn products(&self, x: MatRef<'_, f64>, kx: MatMut<'_, f64>, mx: MatMut<'_, f64>, par: Par) {
        super::sym_matvec_pair(self.k, self.m, x, kx, mx, par)
    }
    fn mass_product(&self, x: MatRef<'_, f64>, y: MatMut<'_, f64>, par: Par) {
        super::sym_matvec(self.m, x, y, par)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::{sparse_from_triplets, sparse_to_dense};
    use crate::sparse::{lower_combination, sym_matvec, sym_matvec_pair};

    /// A symmetric matrix stored in full: a band of `bands` off-diagonals plus entries that
    /// couple rows far apart (as an unordered mesh's numbering does), values from `seed`;
    /// `skip` leaves every `skip`-th off-diagonal entry out, so two matrices differ in pattern.
    fn symmetric(n: usize, bands: usize, seed: f64, skip: usize) -> SparseMatrix {
        let mut t = Vec::new();
        let mut put = |i: usize, j: usize, v: f64| {
            t.push((i, j, v));
            if i != j {
                t.push((j, i, v));
            }
        };
        for j in 0..n {
            for d in 0..=bands.min(n - 1 - j) {
                if d > 0 && (j + d) % skip == 0 {
                    continue;
                }
                let v = (seed + (j * 7 + d * 3) as f64).sin() + if d == 0 { 4.0 } else { 0.0 };
                put(j + d, j, v);
            }
            if j % 5 == 0 && j + n / 2 < n {
                put(j + n / 2, j, 0.01 * (seed + j as f64).cos());
            }
        }
        sparse_from_triplets("A", n, &t).unwrap()
    }

    /// The lower triangle of a full matrix as `(rows, cols, values)` in column-major order.
    fn lower_triplets(a: &SparseMatrix) -> (Vec<i64>, Vec<i64>, Vec<f64>) {
        let (mut r, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..a.ncols() {
            for (&i, &x) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
                if i >= j {
                    r.push(i as i64);
                    c.push(j as i64);
                    v.push(x);
                }
            }
        }
        (r, c, v)
    }

    /// From full matrices and from lower triplets alike: the products are bit for bit those
    /// of the full matrices on the same pattern (same sums in the same order), on one thread
    /// and on two, for widths of one to four passes, and the dense products to round-off; the
    /// combination equals `lower_combination`'s; the diagonals, the dense copies and the mass
    /// test agree with the full matrices.
    #[test]
    fn the_pencil_repeats_the_full_matrices_bit_for_bit() {
        let n = 3 * 1024 + 37;
        // Different patterns (K lacks every 7th band entry, M every 5th: the merge), and one
        // pattern (both lack every 7th: the lists are converted as they are).
        for m_skip in [5, 7] {
            let (k, m) = (symmetric(n, 9, 0.3, 7), symmetric(n, 9, 1.7, m_skip));
            pencil_matches(&k, &m);
        }
    }

    fn pencil_matches(k: &SparseMatrix, m: &SparseMatrix) {
        let (k, m) = (k.clone(), m.clone());
        let n = k.nrows();
        let (kt, mt) = (lower_triplets(&k), lower_triplets(&m));
        let pencils = [
            LowerPencil::from_full(&k, &m).unwrap(),
            LowerPencil::from_sorted_lower(n, (&kt.0, &kt.1, &kt.2), (&mt.0, &mt.1, &mt.2))
                .unwrap(),
        ];
        let want_a = lower_combination(1.0, &k, 0.25, &m);
        // The full matrices on the pencil's (union) pattern, with explicit zeros: the full
        // storage's products of these are the reference, bit for bit.
        let on_union = |a: &SparseMatrix, other: &SparseMatrix| {
            let mut t = crate::core::sparse::sparse_triplets(a);
            t.extend(
                crate::core::sparse::sparse_triplets(other)
                    .into_iter()
                    .map(|(i, j, _)| (i, j, 0.0)),
            );
            sparse_from_triplets("A", n, &t).unwrap()
        };
        let (ku, mu) = (on_union(&k, &m), on_union(&m, &k));
        let (kd, md) = (sparse_to_dense(&k), sparse_to_dense(&m));
        for pencil in &pencils {
            let a = pencil.lower_combination(1.0, 0.25);
            assert_eq!(a.symbolic().col_ptr(), want_a.symbolic().col_ptr());
            assert_eq!(a.symbolic().row_idx(), want_a.symbolic().row_idx());
            assert_eq!(a.val(), want_a.val());
            for b in [1, 5, 16, 17, 50] {
                let x = Mat::from_fn(n, b, |i, c| ((i * 31 + c * 17) % 97) as f64 / 97.0 - 0.5);
                let (mut kx0, mut mx0) = (Mat::zeros(n, b), Mat::zeros(n, b));
                sym_matvec_pair(&ku, &mu, x.as_ref(), kx0.as_mut(), mx0.as_mut(), Par::Seq);
                let mut m0 = Mat::zeros(n, b);
                sym_matvec(&mu, x.as_ref(), m0.as_mut(), Par::Seq);
                // And the dense algebra, to round-off (sums of at most 21 terms).
                for (got, want) in [(&kx0, &kd * &x), (&mx0, &md * &x)] {
                    assert!((got - &want).norm_max() < 1e-13 * want.norm_max());
                }
                for par in [Par::Seq, Par::rayon(2)] {
                    let (mut kx, mut mx) = (Mat::zeros(n, b), Mat::zeros(n, b));
                    pencil.products(x.as_ref(), kx.as_mut(), mx.as_mut(), par);
                    assert_eq!((&kx, &mx), (&kx0, &mx0), "{b} columns");
                    let mut y = Mat::zeros(n, b);
                    pencil.mass_product(x.as_ref(), y.as_mut(), par);
                    assert_eq!(y, m0, "{b} columns");
                }
            }
            assert_eq!(pencil.k_dense(), kd);
            assert_eq!(pencil.m_dense(), md);
            for j in 0..n {
                assert_eq!(pencil.k_diagonal(j), k[(j, j)]);
                assert_eq!(pencil.m_diagonal(j), m[(j, j)]);
                let massive = (0..n).any(|i| md[(i, j)] != 0.0);
                assert_eq!(pencil.has_mass(j), massive, "DOF {j}");
            }
        }
    }

    /// The full matrices borrowed read as their lower pencil: the same combination (bits),
    /// diagonals, mass test, dense copies and lower mass columns; with one pattern the same
    /// products bit for bit, with two the products of the full storage (to round-off of the
    /// dense algebra: sums of at most 21 terms).
    #[test]
    fn the_full_pencil_reads_as_the_lower_one() {
        let n = 1024 + 37;
        for m_skip in [5, 7] {
            let (k, m) = (symmetric(n, 9, 0.3, 7), symmetric(n, 9, 1.7, m_skip));
            let lower = LowerPencil::from_full(&k, &m).unwrap();
            let full = FullPencil::new(&k, &m).unwrap();
            let (lower, full): (&dyn SymmetricPencil, &dyn SymmetricPencil) = (&lower, &full);
            assert_eq!(full.n(), n);
            let (a, b) = (
                lower.lower_combination(1.0, 0.25),
                full.lower_combination(1.0, 0.25),
            );
            assert_eq!(a.symbolic().row_idx(), b.symbolic().row_idx());
            assert_eq!(a.val(), b.val());
            assert_eq!(full.k_dense(), lower.k_dense());
            assert_eq!(full.m_dense(), lower.m_dense());
            for j in 0..n {
                assert_eq!(full.k_diagonal(j), lower.k_diagonal(j));
                assert_eq!(full.m_diagonal(j), lower.m_diagonal(j));
                assert_eq!(full.has_mass(j), lower.has_mass(j));
                // The lower pencil stores the union pattern: its explicit zeros aside.
                let nonzero = |e: Vec<(usize, f64)>| -> Vec<(usize, f64)> {
                    e.into_iter().filter(|(_, v)| *v != 0.0).collect()
                };
                assert_eq!(
                    nonzero(full.m_lower_entries(j)),
                    nonzero(lower.m_lower_entries(j))
                );
            }
            let x = Mat::from_fn(n, 16, |i, c| ((i * 31 + c * 17) % 97) as f64 / 97.0 - 0.5);
            let products = |p: &dyn SymmetricPencil| {
                let (mut kx, mut mx, mut y) =
                    (Mat::zeros(n, 16), Mat::zeros(n, 16), Mat::zeros(n, 16));
                p.products(x.as_ref(), kx.as_mut(), mx.as_mut(), Par::rayon(2));
                p.mass_product(x.as_ref(), y.as_mut(), Par::rayon(2));
                (kx, mx, y)
            };
            let (got, want) = (products(full), products(lower));
            if m_skip == 7 {
                assert_eq!(got, want, "one pattern");
            }
            let (kd, md) = (sparse_to_dense(&k), sparse_to_dense(&m));
            for (g, w) in [(&got.0, &kd * &x), (&got.1, &md * &x), (&got.2, &md * &x)] {
                assert!((g - &w).norm_max() < 1e-13 * w.norm_max());
            }
        }
        let square = symmetric(8, 2, 0.1, 7);
        let one_mass = sparse_from_triplets("M", 8, &[(0, 0, 1.0)]).unwrap();
        assert!(FullPencil::new(&square, &one_mass).is_ok());
        let other = symmetric(9, 2, 0.1, 7);
        assert!(matches!(
            FullPencil::new(&square, &other),
            Err(PencilError::Shape { .. })
        ));
    }

    /// Over several tasks of columns (the merge of `from_full` writes each run of columns
    /// where the counts put it): both constructors give the combination of the full matrices
    /// and the same products.
    #[test]
    fn pencils_over_many_column_runs_agree() {
        let n = 2 * COLUMNS_PER_TASK + 37;
        let (k, m) = (symmetric(n, 4, 0.3, 7), symmetric(n, 4, 1.7, 5));
        let (kt, mt) = (lower_triplets(&k), lower_triplets(&m));
        let full = LowerPencil::from_full(&k, &m).unwrap();
        let sorted =
            LowerPencil::from_sorted_lower(n, (&kt.0, &kt.1, &kt.2), (&mt.0, &mt.1, &mt.2))
                .unwrap();
        let want = lower_combination(1.0, &k, 0.5, &m);
        for p in [&full, &sorted] {
            let a = p.lower_combination(1.0, 0.5);
            assert_eq!(a.symbolic().col_ptr(), want.symbolic().col_ptr());
            assert_eq!(a.symbolic().row_idx(), want.symbolic().row_idx());
            assert_eq!(a.val(), want.val());
        }
        let x = Mat::from_fn(n, 5, |i, c| ((i * 13 + c * 7) % 31) as f64 - 15.0);
        let products = |p: &LowerPencil| {
            let (mut kx, mut mx) = (Mat::zeros(n, 5), Mat::zeros(n, 5));
            p.products(x.as_ref(), kx.as_mut(), mx.as_mut(), Par::rayon(2));
            (kx, mx)
        };
        assert_eq!(products(&full), products(&sorted));
    }

    /// The row index lists, for every row, the entries left of the diagonal in ascending
    /// column order with their positions, however the rows are cut into blocks (four on one
    /// thread, twelve on three), with entries far from the diagonal crossing blocks.
    #[test]
    fn the_row_index_lists_every_entry_left_of_the_diagonal() {
        let n = 1000 + 37;
        let (k, m) = (symmetric(n, 4, 0.3, 7), symmetric(n, 4, 1.7, 5));
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let p = pool.install(|| LowerPencil::from_full(&k, &m).unwrap());
            let mut want = vec![Vec::new(); n];
            for j in 0..n {
                for at in p.col_ptr[j]..p.col_ptr[j + 1] {
                    let i = p.rows[at] as usize;
                    if i != j {
                        want[i].push((j as u32, at as u32));
                    }
                }
            }
            assert!(want.iter().any(|w| w.len() > 4), "entries far off the band");
            for (i, want) in want.iter().enumerate() {
                let r = p.upper_ptr[i]..p.upper_ptr[i + 1];
                let got: Vec<(u32, u32)> = p.upper_cols[r.clone()]
                    .iter()
                    .copied()
                    .zip(p.upper_pos[r].iter().copied())
                    .collect();
                assert_eq!(&got, want, "row {i} on {threads} thread(s)");
            }
        }
    }

    /// Matrices of different sizes are refused; lists out of order, above the diagonal or out
    /// of range are not read (the general path then names the entry).
    #[test]
    fn malformed_input_is_refused() {
        let a = symmetric(10, 2, 0.1, 3);
        let b = symmetric(11, 2, 0.1, 3);
        assert!(matches!(
            LowerPencil::from_full(&a, &b),
            Err(PencilError::Shape { .. })
        ));
        let ok = (&[0i64, 1][..], &[0i64, 0][..], &[1.0, 2.0][..]);
        assert!(LowerPencil::from_sorted_lower(2, ok, ok).is_some());
        // Out of order, above the diagonal, out of range, a value missing; each against a
        // valid list (the merge) and against itself (one pattern).
        for bad in [
            (&[1i64, 0][..], &[0i64, 0][..], &[1.0, 2.0][..]),
            (&[0i64, 0][..], &[0i64, 1][..], &[1.0, 2.0][..]),
            (&[0i64, 2][..], &[0i64, 0][..], &[1.0, 2.0][..]),
            (&[0i64, -1][..], &[0i64, 0][..], &[1.0, 2.0][..]),
            (&[0i64, 1][..], &[0i64, 0][..], &[1.0][..]),
            (&[1i64, 1][..], &[0i64, 0][..], &[1.0, 2.0][..]),
        ] {
            assert!(LowerPencil::from_sorted_lower(2, bad, ok).is_none());
            assert!(LowerPencil::from_sorted_lower(2, ok, bad).is_none());
            assert!(LowerPencil::from_sorted_lower(2, bad, bad).is_none());
        }
        // An order broken across the one-pattern check's chunks of 2¹⁶ entries.
        let len = (1 << 16) + 5;
        let rows: Vec<i64> = (0..len as i64)
            .map(|i| if i == 1 << 16 { 0 } else { i })
            .collect();
        let cols = vec![0i64; len];
        let vals = vec![1.0; len];
        let broken = (&rows[..], &cols[..], &vals[..]);
        assert!(LowerPencil::from_sorted_lower(len, broken, broken).is_none());
    }

    /// A DOF whose only mass is off the diagonal, in a column before it, has mass; a pencil
    /// of order zero is empty.
    #[test]
    fn mass_off_the_diagonal_counts() {
        let k = sparse_from_triplets("K", 3, &[(0, 0, 1.0), (1, 1, 1.0), (2, 2, 1.0)]).unwrap();
        let m = sparse_from_triplets("M", 3, &[(0, 0, 1.0), (2, 0, 0.5), (0, 2, 0.5)]).unwrap();
        let p = LowerPencil::from_full(&k, &m).unwrap();
        assert_eq!(
            (0..3).map(|j| p.has_mass(j)).collect::<Vec<_>>(),
            [true, false, true]
        );
        assert_eq!(p.m_diagonal(2), 0.0);
        let empty = sparse_from_triplets("K", 0, &[]).unwrap();
        let p = LowerPencil::from_full(&empty, &empty).unwrap();
        assert_eq!((p.n(), p.lower_entries()), (0, 0));
    }
}
