//! Modal projections of derivative matrices, `Φᵀ (∂K/∂φ) Φ` and `Φᵀ (∂M/∂φ) Φ` (4.5), and the
//! eigenvalue sensitivity `∂λ_r/∂φ = φ_rᵀ (∂K/∂φ − λ_r ∂M/∂φ) φ_r` (5.3) that is their diagonal.
//!
//! A parameter's derivative matrix is non-zero only on the DOFs of its elements, so the product
//! gathers those rows of `Φ` and never touches the rest of the model: the cost is
//! `nnz(∂K/∂φ)·m + |support|·m²`, independent of the model size.

use crate::core::sparse::SparseMatrix;
#[cfg(target_arch = "x86_64")]
use crate::sparse::{Isa, Level};
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
    let (rows, ar) = SUPPORT_SLOTS.with_borrow_mut(|slots| {
        let slot = slots.clean(a.nrows());
        let mut columns = Vec::new();
        let mut rows: Vec<usize> = Vec::new();
        for j in 0..a.ncols() {
            if col_ptr[j] == col_ptr[j + 1] {
                continue;
            }
            columns.push(j);
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                if slot[i] == u32::MAX {
                    slot[i] = rows.len() as u32;
                    rows.push(i);
                }
            }
        }
        // The rows of `R` at the stored columns, row-major: every stored entry of `A` is then
        // one axpy over `m` contiguous values, its indices read once (not once per column).
        let mut right_rows = vec![0.0; columns.len() * m];
        for c in 0..m {
            let rc = right.col(c);
            for (jj, &j) in columns.iter().enumerate() {
                right_rows[jj * m + c] = rc[j];
            }
        }
        let mut ar = vec![0.0; rows.len() * m];
        let entries = Entries {
            columns: &columns,
            col_ptr,
            row_idx,
            values,
            slot,
        };
        entries.accumulate(&right_rows, &mut ar, m);
        // Back to empty for the next call on this thread: only the support's slots.
        for &i in &rows {
            slot[i] = u32::MAX;
        }
        slots.dirty = false;
        (rows, ar)
    });
    if rows.is_empty() {
        return out;
    }
    let ar = MatRef::from_row_major_slice(&ar, rows.len(), m);
    let l = Mat::from_fn(rows.len(), n, |r, c| left[(rows[r], c)]);
    out += l.transpose() * ar;
    out
}

/// `Lᵀ A R` for a symmetric `A` (as every derivative `∂K/∂φ`, `∂M/∂φ` is): by
/// [`project_between`] as `(Rᵀ A L)ᵀ` when `L` has fewer columns than `R`, so the sparse
/// product is formed with the narrower side (the static correction's `Xᵀ A Φ` takes `A X`,
/// a column per measured DOF, not `A Φ`, a column per mode).
pub fn project_between_symmetric(
    a: &SparseMatrix,
    left: MatRef<'_, f64>,
    right: MatRef<'_, f64>,
) -> Mat<f64> {
    if left.ncols() < right.ncols() {
        project_between(a, right, left).transpose().to_owned()
    } else {
        project_between(a, left, right)
    }
}

thread_local! {
    /// Each row's place in the support of the matrix being projected, kept empty between
    /// calls: a call then costs its support, not a fresh array of `N` entries (4–8 MB at a
    /// million DOFs, for each of a hundred derivatives).
    static SUPPORT_SLOTS: std::cell::RefCell<SupportSlots> =
        const { std::cell::RefCell::new(SupportSlots { slot: Vec::new(), dirty: false }) };
}

/// Rows' places in a support (`u32::MAX`: not in it).
struct SupportSlots {
    slot: Vec<u32>,
    /// Set while a call uses the slots: a call that did not finish left them unknown.
    dirty: bool,
}

impl SupportSlots {
    /// At least `n` empty slots, marked in use.
    fn clean(&mut self, n: usize) -> &mut [u32] {
        if self.dirty {
            self.slot.fill(u32::MAX);
        }
        if self.slot.len() < n {
            self.slot.resize(n, u32::MAX);
        }
        self.dirty = true;
        &mut self.slot
    }
}

/// The stored entries of a sparse matrix's columns `columns`, each row at its `slot`.
struct Entries<'a> {
    columns: &'a [usize],
    col_ptr: &'a [usize],
    row_idx: &'a [usize],
    values: &'a [f64],
    slot: &'a [u32],
}

impl Entries<'_> {
    /// `AR[slot(i)] += a_ij R[jj]` for every stored entry, `m` values a row (row-major `AR` and
    /// `R`, `R`'s rows in the order of `columns`): on AVX-512 or AVX2 where the machine has them,
    /// the same multiplications and additions (no fused ones) in the same order, so the same
    /// bits as the plain loop. The set is the one the sparse kernels detected
    /// (`sparse::Isa`).
    fn accumulate(&self, right_rows: &[f64], ar: &mut [f64], m: usize) {
        #[cfg(target_arch = "x86_64")]
        match Isa::detected().level() {
            // SAFETY: `Isa::detected` found AVX-512F on this machine.
            Level::Avx512 => return unsafe { self.accumulate_avx512(right_rows, ar, m) },
            // SAFETY: `Isa::detected` found AVX2 on this machine.
            Level::Avx2 => return unsafe { self.accumulate_avx2(right_rows, ar, m) },
            Level::Plain => {}
        }
        self.accumulate_plain(right_rows, ar, m)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn accumulate_avx512(&self, right_rows: &[f64], ar: &mut [f64], m: usize) {
        self.accumulate_plain(right_rows, ar, m)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn accumulate_avx2(&self, right_rows: &[f64], ar: &mut [f64], m: usize) {
        self.accumulate_plain(right_rows, ar, m)
    }

    #[inline(always)]
    fn accumulate_plain(&self, right_rows: &[f64], ar: &mut [f64], m: usize) {
        for (jj, &j) in self.columns.iter().enumerate() {
            let rj = &right_rows[jj * m..(jj + 1) * m];
            for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                let v = self.values[k];
                let at = self.slot[self.row_idx[k]] as usize * m;
                for (o, r) in ar[at..at + m].iter_mut().zip(rj) {
                    *o += v * r;
                }
            }
        }
    }
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

    /// A symmetric `A` on a few rows of a larger model, and two dense blocks.
    fn symmetric_case(n: usize, first: usize) -> (SparseMatrix, Mat<f64>, Mat<f64>) {
        let mut t = Vec::new();
        for i in first..first + 9 {
            for j in first..=i {
                let v = ((i * 7 + j * 3) % 11) as f64 - 5.0 + if i == j { 20.0 } else { 0.0 };
                t.push((i, j, v));
                if i != j {
                    t.push((j, i, v));
                }
            }
        }
        let a = sparse_from_triplets("A", n, &t).unwrap();
        let wide = Mat::from_fn(n, 7, |i, j| ((i * 13 + j * 29) % 17) as f64 / 17.0 - 0.4);
        let narrow = Mat::from_fn(n, 2, |i, j| ((i * 5 + j * 11) % 7) as f64 / 7.0 - 0.3);
        (a, wide, narrow)
    }

    /// The symmetric form takes the narrower side for the sparse product and gives the same
    /// `Lᵀ A R` as the general one, either side narrower, to round-off; the dense product is
    /// the reference (1e-13 of its largest entry: sums of a few dozen terms of order 10).
    #[test]
    fn symmetric_projection_matches_the_general_one_either_way() {
        let (a, wide, narrow) = symmetric_case(30, 12);
        let dense = sparse_to_dense(&a);
        for (left, right) in [(&narrow, &wide), (&wide, &narrow), (&wide, &wide)] {
            let want = left.transpose() * &dense * right;
            let scale = want.norm_max();
            for got in [
                project_between(&a, left.as_ref(), right.as_ref()),
                project_between_symmetric(&a, left.as_ref(), right.as_ref()),
            ] {
                assert_eq!((got.nrows(), got.ncols()), (left.ncols(), right.ncols()));
                assert!((&got - &want).norm_max() <= 1e-13 * scale);
            }
        }
    }

    /// The support slots a thread keeps are empty after each call, whatever the sizes of the
    /// models in turn, and slots left in use by a call that did not finish are cleared.
    #[test]
    fn support_slots_are_left_empty_between_calls() {
        let (big, big_wide, _) = symmetric_case(60, 40);
        let (small, small_wide, _) = symmetric_case(20, 3);
        let want_big = project_between(&big, big_wide.as_ref(), big_wide.as_ref());
        let want_small = project_between(&small, small_wide.as_ref(), small_wide.as_ref());
        for _ in 0..2 {
            let got = project_between(&big, big_wide.as_ref(), big_wide.as_ref());
            assert_eq!(got, want_big);
            let got = project_between(&small, small_wide.as_ref(), small_wide.as_ref());
            assert_eq!(got, want_small);
        }
        SUPPORT_SLOTS.with_borrow_mut(|s| {
            assert!(s.slot.iter().all(|&p| p == u32::MAX) && !s.dirty);
            // As if a call had stopped half way.
            s.slot[5] = 0;
            s.dirty = true;
        });
        let got = project_between(&small, small_wide.as_ref(), small_wide.as_ref());
        assert_eq!(got, want_small);
        SUPPORT_SLOTS.with_borrow(|s| assert!(s.slot.iter().all(|&p| p == u32::MAX)));
    }
}
