//! System matrices `K`, `M` and optional damping `C` (viscous) and `D` (structural) of
//! `M ẍ + C ẋ + (K + iD) x = f` (docs/theory.md §1), sparse column-major, with their DOF labels.

use crate::core::DofId;
use crate::core::sparse::{LowerTriplets, SparseError, SparseMatrix, sparse_to_dense};
use faer::Mat;
use rayon::prelude::*;
use std::borrow::Cow;
use std::collections::HashMap;

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

/// Symmetric `K` and `M` over a list of DOFs as their lower triangles (column-major triplets):
/// what the matrices artefact stores, assembled without building the full matrices.
#[derive(Clone, Debug, PartialEq)]
pub struct LowerSystem {
    /// Row/column labels.
    pub dofs: Vec<DofId>,
    /// Stiffness, N/m.
    pub k: LowerTriplets,
    /// Mass, kg.
    pub m: LowerTriplets,
}

impl LowerSystem {
    /// The lower triangles of `sys`'s `K` and `M`.
    pub fn of(sys: &SystemMatrices) -> Self {
        let (k, m) = rayon::join(|| LowerTriplets::of(&sys.k), || LowerTriplets::of(&sys.m));
        Self {
            dofs: sys.dofs.clone(),
            k,
            m,
        }
    }
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
    #[error(transparent)]
    Triplets(#[from] SparseError),
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
    ///
    /// `O(nnz log d)` and parallel over columns: each entry `(i, j)` is compared with `(j, i)`,
    /// found by binary search in column `i`. The first offending entry is reported as a serial
    /// scan would find it (non-finite: column-major order; asymmetric: row-major order).
    pub fn validate(&self) -> Result<(), SystemMatricesError> {
        self.validate_entries(true)
    }

    /// [`SystemMatrices::validate`] without the symmetry check, for matrices symmetric by
    /// construction (mirrored from a stored lower triangle).
    pub fn validate_shapes_and_values(&self) -> Result<(), SystemMatricesError> {
        self.validate_entries(false)
    }

    fn validate_entries(&self, symmetry: bool) -> Result<(), SystemMatricesError> {
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
            if let Some((i, j, value)) = first_non_finite(a) {
                return Err(SystemMatricesError::NotFinite {
                    name,
                    row_dof: self.dofs[i],
                    col_dof: self.dofs[j],
                    value,
                });
            }
            if !symmetry {
                continue;
            }
            if let Some((i, j, a, b)) = first_asymmetric(&CanonicalColumns::of(a), 1e-10) {
                return Err(SystemMatricesError::NotSymmetric {
                    name,
                    row_dof: self.dofs[i],
                    col_dof: self.dofs[j],
                    a,
                    b,
                });
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

/// The first entry of `a` that is NaN or infinite, in column-major storage order.
fn first_non_finite(a: &SparseMatrix) -> Option<(usize, usize, f64)> {
    let j = (0..a.ncols())
        .into_par_iter()
        .find_first(|&j| a.val_of_col(j).iter().any(|v| !v.is_finite()))?;
    let (rows, vals) = (a.row_idx_of_col_raw(j), a.val_of_col(j));
    let k = vals.iter().position(|v| !v.is_finite())?;
    Some((rows[k], j, vals[k]))
}

/// The columns of a square sparse matrix with their rows ascending and duplicates summed:
/// borrowed when the matrix is stored that way (as every matrix femu builds is), else a copy.
struct CanonicalColumns<'a> {
    col_ptr: Cow<'a, [usize]>,
    rows: Cow<'a, [usize]>,
    vals: Cow<'a, [f64]>,
    /// Largest `|value|` stored, before duplicates are summed.
    scale: f64,
}

impl<'a> CanonicalColumns<'a> {
    fn of(a: &'a SparseMatrix) -> Self {
        let scale = a
            .val()
            .par_iter()
            .fold(|| 0.0f64, |s, v| s.max(v.abs()))
            .reduce(|| 0.0, f64::max);
        let canonical = a.col_ptr().len() == a.ncols() + 1
            && a.col_nnz().is_none()
            && (0..a.ncols())
                .into_par_iter()
                .all(|j| a.row_idx_of_col_raw(j).windows(2).all(|w| w[0] < w[1]));
        if canonical {
            let nnz = a.col_ptr()[a.ncols()];
            return Self {
                col_ptr: Cow::Borrowed(a.col_ptr()),
                rows: Cow::Borrowed(&a.row_idx()[..nnz]),
                vals: Cow::Borrowed(&a.val()[..nnz]),
                scale,
            };
        }
        let (mut col_ptr, mut rows, mut vals) = (vec![0], Vec::new(), Vec::new());
        let mut column: Vec<(usize, f64)> = Vec::new();
        for j in 0..a.ncols() {
            column.clear();
            column.extend(
                a.row_idx_of_col_raw(j)
                    .iter()
                    .copied()
                    .zip(a.val_of_col(j).iter().copied()),
            );
            column.sort_by_key(|&(i, _)| i);
            for &(i, v) in &column {
                if rows.len() > col_ptr[j] && rows.last() == Some(&i) {
                    *vals.last_mut().expect("a value per row") += v;
                } else {
                    rows.push(i);
                    vals.push(v);
                }
            }
            col_ptr.push(rows.len());
        }
        Self {
            col_ptr: Cow::Owned(col_ptr),
            rows: Cow::Owned(rows),
            vals: Cow::Owned(vals),
            scale,
        }
    }

    fn column(&self, j: usize) -> (&[usize], &[f64]) {
        let r = self.col_ptr[j]..self.col_ptr[j + 1];
        (&self.rows[r.clone()], &self.vals[r])
    }

    /// Entry `(i, j)`, zero where none is stored.
    fn get(&self, i: usize, j: usize) -> f64 {
        let (rows, vals) = self.column(j);
        rows.binary_search(&i).map_or(0.0, |k| vals[k])
    }
}

/// The first entry `(i, j, a_ij, a_ji)` in row-major order with
/// `|a_ij − a_ji| > tolerance · max|a|`.
fn first_asymmetric(a: &CanonicalColumns<'_>, tolerance: f64) -> Option<(usize, usize, f64, f64)> {
    let limit = tolerance * a.scale;
    let n = a.col_ptr.len() - 1;
    (0..n)
        .into_par_iter()
        .filter_map(|j| {
            let (rows, vals) = a.column(j);
            rows.iter().zip(vals).find_map(|(&i, &v)| {
                let mirror = if i == j { v } else { a.get(j, i) };
                ((v - mirror).abs() > limit).then_some((i, j, v, mirror))
            })
        })
        .min_by_key(|&(i, j, _, _)| (i, j))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::sparse_from_triplets;
    use crate::core::{Component, DofId};
    use faer::sparse::{SparseColMat, SymbolicSparseColMat};

    fn dofs(n: usize) -> Vec<DofId> {
        (1..=n as u64)
            .map(|node| DofId::new(node, Component::Ux))
            .collect()
    }

    fn system(k: SparseMatrix) -> SystemMatrices {
        let n = k.nrows();
        let m =
            sparse_from_triplets("M", n, &(0..n).map(|i| (i, i, 1.0)).collect::<Vec<_>>()).unwrap();
        SystemMatrices {
            dofs: dofs(n),
            k,
            m,
            c: None,
            d: None,
        }
    }

    #[test]
    fn a_symmetric_matrix_passes_and_the_first_asymmetric_entry_is_named_in_row_order() {
        let sym = [
            (0, 0, 2.0),
            (1, 0, -1.0),
            (0, 1, -1.0),
            (1, 1, 2.0),
            (2, 2, 1.0),
        ];
        let k = sparse_from_triplets("K", 3, &sym).unwrap();
        system(k).validate().unwrap();
        // (2, 0) has no mirror and (0, 2) differs from (2, 0): row-major first is (0, 2).
        let asym = [
            (0, 0, 2.0),
            (2, 0, 0.5),
            (0, 2, 0.25),
            (1, 2, 1e-3),
            (2, 2, 1.0),
            (1, 1, 1.0),
        ];
        let e = system(sparse_from_triplets("K", 3, &asym).unwrap())
            .validate()
            .unwrap_err();
        let SystemMatricesError::NotSymmetric {
            row_dof,
            col_dof,
            a,
            b,
            ..
        } = e
        else {
            panic!("{e}")
        };
        assert_eq!((row_dof.node, col_dof.node, a, b), (1, 3, 0.25, 0.5));
    }

    #[test]
    fn asymmetry_within_the_tolerance_passes() {
        let t = [(0, 0, 1.0), (1, 0, 0.5), (0, 1, 0.5 + 5e-11), (1, 1, 1.0)];
        system(sparse_from_triplets("K", 2, &t).unwrap())
            .validate()
            .unwrap();
        let t = [(0, 0, 1.0), (1, 0, 0.5), (0, 1, 0.5 + 5e-10), (1, 1, 1.0)];
        assert!(
            system(sparse_from_triplets("K", 2, &t).unwrap())
                .validate()
                .is_err()
        );
    }

    #[test]
    fn unsorted_columns_with_duplicates_are_summed_before_the_symmetry_check() {
        // Column 0 holds rows 1, 0, 1 (0.25 + 0.25 at (1, 0)); column 1 holds (0, 1) = 0.5.
        let symbolic = SymbolicSparseColMat::new_unsorted_checked(
            2,
            2,
            vec![0usize, 3, 5],
            None,
            vec![1usize, 0, 1, 0, 1],
        );
        let k = SparseColMat::new(symbolic, vec![0.25, 1.0, 0.25, 0.5, 1.0]);
        system(k.clone()).validate().unwrap();
        let mut vals = vec![0.25, 1.0, 0.25, 0.5, 1.0];
        vals[2] = 0.3;
        let k = SparseColMat::new(k.symbolic().to_owned().unwrap(), vals);
        let e = system(k).validate().unwrap_err();
        assert!(
            matches!(e, SystemMatricesError::NotSymmetric { a, b, .. } if a == 0.5 && b == 0.55),
            "{e}"
        );
    }

    #[test]
    fn the_first_non_finite_entry_is_named_in_column_order() {
        let t = [
            (0, 0, 1.0),
            (1, 1, f64::NAN),
            (0, 2, f64::INFINITY),
            (2, 0, f64::INFINITY),
            (2, 2, 1.0),
        ];
        let e = system(sparse_from_triplets("K", 3, &t).unwrap())
            .validate()
            .unwrap_err();
        let SystemMatricesError::NotFinite {
            row_dof,
            col_dof,
            value,
            ..
        } = e
        else {
            panic!("{e}")
        };
        assert_eq!((row_dof.node, col_dof.node), (3, 1));
        assert!(value.is_infinite());
    }
}
