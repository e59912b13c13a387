//! System matrices `K`, `M` and optional damping `C` (viscous) and `D` (structural) of
//! `M ẍ + C ẋ + (K + iD) x = f` (docs/theory.md §1), sparse column-major, with their DOF labels.

use crate::core::DofId;
use crate::core::sparse::{SparseError, SparseMatrix, sparse_to_dense, sparse_triplets};
use faer::Mat;
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
