//! Linear combinations of sparse matrices.

use crate::core::sparse::SparseMatrix;
use faer::sparse::SparseColMat;

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
    let merge = |j: usize, out: &mut Vec<(usize, f64, f64)>| merge_lower_column(j, a, b, out);
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
            for (k, &(i, x, y)) in column.iter().enumerate() {
                rows[at + k] = i;
                vals[at + k] = alpha * x + beta * y;
            }
            at += column.len();
        }
    });
    let symbolic = faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
    SparseColMat::new(symbolic, vals)
}

/// Columns per task of [`lower_combination`].
const COMBINATION_COLUMNS_PER_TASK: usize = 4096;

/// Column `j`'s entries on or below the diagonal of two matrices `K` and `M`, `(row, k, m)`
/// (an entry one of them lacks is zero there), sorted by row, entries of one row summed: a merge when both columns' rows are sorted, else a sort.
pub(super) fn merge_lower_column(
    j: usize,
    k: &SparseMatrix,
    m: &SparseMatrix,
    out: &mut Vec<(usize, f64, f64)>,
) {
    out.clear();
    let push = |out: &mut Vec<(usize, f64, f64)>, (i, a, b): (usize, f64, f64)| match out.last_mut()
    {
        Some(last) if last.0 == i => {
            last.1 += a;
            last.2 += b;
        }
        _ => out.push((i, a, b)),
    };
    let (rk, vk) = (k.row_idx_of_col_raw(j), k.val_of_col(j));
    let (rm, vm) = (m.row_idx_of_col_raw(j), m.val_of_col(j));
    if rk.is_sorted() && rm.is_sorted() {
        let (mut p, mut q) = (
            rk.partition_point(|&i| i < j),
            rm.partition_point(|&i| i < j),
        );
        while p < rk.len() || q < rm.len() {
            if q == rm.len() || (p < rk.len() && rk[p] < rm[q]) {
                push(out, (rk[p], vk[p], 0.0));
                p += 1;
            } else if p == rk.len() || rm[q] < rk[p] {
                push(out, (rm[q], 0.0, vm[q]));
                q += 1;
            } else {
                push(out, (rk[p], vk[p], vm[q]));
                (p, q) = (p + 1, q + 1);
            }
        }
        return;
    }
    let mut entries: Vec<(usize, f64, f64)> = rk
        .iter()
        .zip(vk)
        .map(|(&i, &v)| (i, v, 0.0))
        .chain(rm.iter().zip(vm).map(|(&i, &v)| (i, 0.0, v)))
        .filter(|e| e.0 >= j)
        .collect();
    entries.sort_by_key(|e| e.0);
    for e in entries {
        push(out, e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::{sparse_from_triplets, sparse_to_dense};

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
