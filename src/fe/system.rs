//! System matrices `K`, `M` and optional damping `C` (viscous) and `D` (structural) of
//! `M ẍ + C ẋ + (K + iD) x = f` (docs/theory.md §1), sparse column-major, with their DOF labels.

use crate::core::DofId;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, MatRef};
use std::collections::HashMap;

/// A sparse real matrix in compressed sparse column form.
pub type SparseMatrix = SparseColMat<usize, f64>;

/// Assembled `K`, `M` and optional `C`, `D` over a list of DOFs.
#[derive(Clone, Debug)]
pub struct SystemMatrices {
    /// Row/column labels.
    pub dofs: Vec<DofId>,
    /// Stiffness, N/m.
    pub k: SparseMatrix,
    /// Mass, kg.
    pub m: SparseMatrix,
    /// Viscous damping, N·s/m.
    pub c: Option<SparseMatrix>,
    /// Structural damping, N/m (enters as `iD`).
    pub d: Option<SparseMatrix>,
}

/// Why matrices could not be built or are inconsistent.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SystemMatricesError {
    /// A matrix has the wrong shape.
    #[error("matrix {name} is {rows}x{cols}, expected {n}x{n} (one row per DOF)")]
    Shape {
        /// `K`, `M`, `C` or `D`.
        name: &'static str,
        /// Rows found.
        rows: usize,
        /// Columns found.
        cols: usize,
        /// DOF count.
        n: usize,
    },
    /// A triplet index is out of range.
    #[error("matrix {name}: entry ({row}, {col}) is outside a {n}x{n} matrix")]
    IndexOutOfRange {
        /// Matrix name.
        name: &'static str,
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// DOF count.
        n: usize,
    },
    /// A matrix is not symmetric.
    #[error(
        "matrix {name} is not symmetric: entry ({row_dof}, {col_dof}) = {a:e} but its transpose is {b:e}"
    )]
    NotSymmetric {
        /// Matrix name.
        name: &'static str,
        /// Row DOF.
        row_dof: DofId,
        /// Column DOF.
        col_dof: DofId,
        /// The entry.
        a: f64,
        /// Its mirror.
        b: f64,
    },
    /// A value is NaN or infinite.
    #[error("matrix {name}: entry ({row_dof}, {col_dof}) is {value}, not a finite number")]
    NotFinite {
        /// Matrix name.
        name: &'static str,
        /// Row DOF.
        row_dof: DofId,
        /// Column DOF.
        col_dof: DofId,
        /// The value.
        value: f64,
    },
}

/// Builds an `n × n` sparse matrix from `(row, col, value)` triplets, summing duplicates.
pub fn sparse_from_triplets(
    name: &'static str,
    n: usize,
    triplets: &[(usize, usize, f64)],
) -> Result<SparseMatrix, SystemMatricesError> {
    let mut entries = Vec::with_capacity(triplets.len());
    for &(row, col, val) in triplets {
        if row >= n || col >= n {
            return Err(SystemMatricesError::IndexOutOfRange { name, row, col, n });
        }
        entries.push(Triplet::new(row, col, val));
    }
    SparseColMat::try_new_from_triplets(n, n, &entries).map_err(|_| {
        SystemMatricesError::IndexOutOfRange {
            name,
            row: n,
            col: n,
            n,
        }
    })
}

/// The lower triangle of `α A + β B` for square matrices of one size, merged column by column
/// (no triplet sort: memory and time linear in the non-zeros). Entries of one row in one column
/// are summed. The columns are merged on all threads, since at a million DOFs the merge is not
/// negligible: once to count each column's entries, once to write them where the counts put
/// them.
pub fn lower_combination(
    alpha: f64,
    a: &SparseMatrix,
    beta: f64,
    b: &SparseMatrix,
) -> SparseMatrix {
    use rayon::prelude::*;
    let n = a.ncols();
    assert!(a.nrows() == n && b.nrows() == n && b.ncols() == n);
    let merge = |j: usize, out: &mut Vec<(usize, f64)>| {
        merged_lower_column(
            j,
            [
                (a.row_idx_of_col_raw(j), a.val_of_col(j), alpha),
                (b.row_idx_of_col_raw(j), b.val_of_col(j), beta),
            ],
            out,
        );
    };
    let counts: Vec<usize> = (0..n)
        .into_par_iter()
        .with_min_len(COMBINATION_COLUMNS_PER_TASK)
        .map_init(Vec::new, |column, j| {
            merge(j, column);
            column.len()
        })
        .collect();
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0);
    for c in counts {
        col_ptr.push(col_ptr.last().copied().unwrap_or(0) + c);
    }
    let nnz = col_ptr[n];
    // Storage for at most the two lower triangles, zeroed by the allocator: pages beyond
    // `nnz` are never touched. (Sized exactly, the blocks left other holes in the heap, which
    // raised the peak memory of the eigensolver's later steps.)
    let bound = (a.compute_nnz() + b.compute_nnz()) / 2 + n;
    let (mut rows, mut vals) = (vec![0usize; bound.max(nnz)], vec![0.0f64; bound.max(nnz)]);
    rows.truncate(nnz);
    vals.truncate(nnz);
    // Disjoint runs of columns, each with the part of `rows` and `vals` its columns fill.
    let mut tasks = Vec::new();
    let (mut rows_rest, mut vals_rest) = (rows.as_mut_slice(), vals.as_mut_slice());
    for first in (0..n).step_by(COMBINATION_COLUMNS_PER_TASK) {
        let end = (first + COMBINATION_COLUMNS_PER_TASK).min(n);
        let len = col_ptr[end] - col_ptr[first];
        let (r, rr) = std::mem::take(&mut rows_rest).split_at_mut(len);
        let (v, vr) = std::mem::take(&mut vals_rest).split_at_mut(len);
        (rows_rest, vals_rest) = (rr, vr);
        tasks.push((first..end, r, v));
    }
    tasks.into_par_iter().for_each(|(columns, rows, vals)| {
        let mut column = Vec::new();
        let mut at = 0;
        for j in columns {
            merge(j, &mut column);
            for (k, &(i, v)) in column.iter().enumerate() {
                rows[at + k] = i;
                vals[at + k] = v;
            }
            at += column.len();
        }
    });
    let symbolic = faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
    SparseColMat::new(symbolic, vals)
}

/// Columns per task of [`lower_combination`].
const COMBINATION_COLUMNS_PER_TASK: usize = 4096;

/// Column `j`'s entries on or below the diagonal of `Σ f M` over `parts` `(rows, values, f)`,
/// sorted by row, entries of one row summed: a merge when every part's rows are sorted, else
/// a sort.
fn merged_lower_column(j: usize, parts: [(&[usize], &[f64], f64); 2], out: &mut Vec<(usize, f64)>) {
    out.clear();
    let push = |out: &mut Vec<(usize, f64)>, (i, v): (usize, f64)| match out.last_mut() {
        Some(last) if last.0 == i => last.1 += v,
        _ => out.push((i, v)),
    };
    if parts.iter().all(|(rows, _, _)| rows.is_sorted()) {
        let [(ra, va, fa), (rb, vb, fb)] = parts;
        let (mut p, mut q) = (
            ra.partition_point(|&i| i < j),
            rb.partition_point(|&i| i < j),
        );
        while p < ra.len() || q < rb.len() {
            if q == rb.len() || (p < ra.len() && ra[p] <= rb[q]) {
                push(out, (ra[p], fa * va[p]));
                p += 1;
            } else {
                push(out, (rb[q], fb * vb[q]));
                q += 1;
            }
        }
        return;
    }
    let mut entries: Vec<(usize, f64)> = parts
        .iter()
        .flat_map(|&(rows, vals, f)| {
            rows.iter()
                .zip(vals)
                .filter(|(i, _)| **i >= j)
                .map(move |(&i, &v)| (i, f * v))
        })
        .collect();
    entries.sort_by_key(|e| e.0);
    for e in entries {
        push(out, e);
    }
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

impl SystemMatrices {
    /// Number of DOFs.
    pub fn n(&self) -> usize {
        self.dofs.len()
    }

    /// Map from DOF to row index.
    pub fn dof_index(&self) -> HashMap<DofId, usize> {
        self.dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect()
    }

    /// The matrices with their names, absent ones skipped.
    pub fn named(&self) -> Vec<(&'static str, &SparseMatrix)> {
        let mut v = vec![("K", &self.k), ("M", &self.m)];
        if let Some(c) = &self.c {
            v.push(("C", c));
        }
        if let Some(d) = &self.d {
            v.push(("D", d));
        }
        v
    }

    /// Checks shapes, finiteness and symmetry (relative tolerance `1e-10` of the largest entry).
    pub fn validate(&self) -> Result<(), SystemMatricesError> {
        let n = self.n();
        for (name, a) in self.named() {
            if a.nrows() != n || a.ncols() != n {
                return Err(SystemMatricesError::Shape {
                    name,
                    rows: a.nrows(),
                    cols: a.ncols(),
                    n,
                });
            }
            let trip = sparse_triplets(a);
            let scale = trip.iter().fold(0.0f64, |s, t| s.max(t.2.abs()));
            let mut map: HashMap<(usize, usize), f64> = HashMap::with_capacity(trip.len());
            for &(i, j, v) in &trip {
                if !v.is_finite() {
                    return Err(SystemMatricesError::NotFinite {
                        name,
                        row_dof: self.dofs[i],
                        col_dof: self.dofs[j],
                        value: v,
                    });
                }
                *map.entry((i, j)).or_default() += v;
            }
            let mut keys: Vec<_> = map.keys().copied().collect();
            keys.sort_unstable();
            for (i, j) in keys {
                let a = map[&(i, j)];
                let b = map.get(&(j, i)).copied().unwrap_or(0.0);
                if (a - b).abs() > 1e-10 * scale {
                    return Err(SystemMatricesError::NotSymmetric {
                        name,
                        row_dof: self.dofs[i],
                        col_dof: self.dofs[j],
                        a,
                        b,
                    });
                }
            }
        }
        Ok(())
    }

    /// Dense `K` (for small models and tests).
    pub fn k_dense(&self) -> Mat<f64> {
        sparse_to_dense(&self.k)
    }

    /// Dense `M` (for small models and tests).
    pub fn m_dense(&self) -> Mat<f64> {
        sparse_to_dense(&self.m)
    }
}

/// Largest absolute entry of a dense matrix.
pub fn max_abs(a: MatRef<'_, f64>) -> f64 {
    let mut s = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            s = s.max(a[(i, j)].abs());
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `α A + β B`'s lower triangle equals the dense sum, for columns of different patterns,
    /// with `B` stored sorted and unsorted.
    #[test]
    fn lower_combination_matches_the_dense_sum() {
        let n = 7;
        let entry = |i: usize, j: usize, salt: usize| ((i * 3 + j * 5 + salt) % 7) as f64 - 2.5;
        let mut ta = Vec::new();
        let mut tb = Vec::new();
        for j in 0..n {
            for i in 0..n {
                if (i + j) % 3 != 1 {
                    ta.push((i, j, entry(i.max(j), i.min(j), 1)));
                }
                if (i * j) % 4 != 2 {
                    tb.push((i, j, entry(i.max(j), i.min(j), 2)));
                }
            }
        }
        let a = sparse_from_triplets("A", n, &ta).unwrap();
        let b = sparse_from_triplets("B", n, &tb).unwrap();
        // B again with every column's rows reversed: unsorted storage.
        let (mut ptr, mut rows, mut vals) = (vec![0usize], Vec::new(), Vec::new());
        for j in 0..n {
            let r = b.row_idx_of_col_raw(j);
            let v = b.val_of_col(j);
            rows.extend(r.iter().rev());
            vals.extend(v.iter().rev());
            ptr.push(rows.len());
        }
        let unsorted = SparseColMat::new(
            faer::sparse::SymbolicSparseColMat::new_unsorted_checked(n, n, ptr, None, rows),
            vals,
        );
        let (da, db) = (sparse_to_dense(&a), sparse_to_dense(&b));
        for second in [&b, &unsorted] {
            let c = sparse_to_dense(&lower_combination(2.0, &a, -0.5, second));
            for j in 0..n {
                for i in 0..n {
                    let want = if i >= j {
                        2.0 * da[(i, j)] - 0.5 * db[(i, j)]
                    } else {
                        0.0
                    };
                    assert_eq!(c[(i, j)], want, "({i}, {j})");
                }
            }
        }
        // Wide enough for several tasks of columns, one column unsorted.
        let n = 2 * COMBINATION_COLUMNS_PER_TASK + 37;
        let (mut ta, mut tb) = (Vec::new(), Vec::new());
        for j in 0..n {
            for d in 0..4.min(n - j) {
                let v = entry(j + d, j, 3);
                ta.push((j + d, j, v));
                ta.push((j, j + d, v));
                if d % 2 == 0 {
                    let w = entry(j + d, j, 5) + 0.25;
                    tb.push((j + d, j, w));
                    tb.push((j, j + d, w));
                }
            }
        }
        let a = sparse_from_triplets("A", n, &ta).unwrap();
        let b = sparse_from_triplets("B", n, &tb).unwrap();
        let (mut ptr, mut rows, mut vals) = (vec![0usize], Vec::new(), Vec::new());
        for j in 0..n {
            let (r, v) = (b.row_idx_of_col_raw(j), b.val_of_col(j));
            if j == COMBINATION_COLUMNS_PER_TASK + 5 {
                rows.extend(r.iter().rev());
                vals.extend(v.iter().rev());
            } else {
                rows.extend(r);
                vals.extend(v);
            }
            ptr.push(rows.len());
        }
        let unsorted = SparseColMat::new(
            faer::sparse::SymbolicSparseColMat::new_unsorted_checked(n, n, ptr, None, rows),
            vals,
        );
        // Column by column: the stored sums, sorted.
        for second in [&b, &unsorted] {
            let c = lower_combination(2.0, &a, -0.5, second);
            for j in 0..n {
                let mut want = std::collections::BTreeMap::new();
                for (m, f) in [(&a, 2.0), (second, -0.5)] {
                    for (&i, &v) in m.row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
                        if i >= j {
                            *want.entry(i).or_insert(0.0) += f * v;
                        }
                    }
                }
                let got: Vec<(usize, f64)> = c
                    .row_idx_of_col_raw(j)
                    .iter()
                    .copied()
                    .zip(c.val_of_col(j).iter().copied())
                    .collect();
                assert_eq!(got, want.into_iter().collect::<Vec<_>>(), "column {j}");
            }
        }
    }
}
