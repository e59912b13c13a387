//! The operator boundary of the sparse direct solvers: what a factored matrix offers the
//! methods built on it.

use faer::{MatMut, Par};

/// A factored square matrix `A` of order [`n`](SparseSolve::n) that solves `A X = B` for a
/// block of right-hand sides in place.
///
/// `par` is the parallelism of the call: [`Par::Seq`] keeps it on the calling thread (for
/// callers that already run one solve per thread), `Par::Rayon(n)` shares it among the
/// current rayon pool. Results do not depend on it.
pub trait SparseSolve<T> {
    /// Order of `A`.
    fn n(&self) -> usize;

    /// `X ← A⁻¹ X`; `x` has [`n`](SparseSolve::n) rows and any number of columns.
    fn solve_in_place(&self, x: MatMut<'_, T>, par: Par);
}

/// A symmetric positive definite `A = G⁻¹ G⁻ᵀ` whose two half solves are available apart:
/// with `G = L⁻¹ Pᵀ` for `A = P L Lᵀ Pᵀ`, the operator `G M Gᵀ` is symmetric and has the
/// eigenvalues of `A⁻¹ M` (docs/theory.md (1.9)), which is what shift-invert Lanczos needs.
pub trait SymmetricFactor: SparseSolve<f64> {
    /// `X ← G X = L⁻¹ Pᵀ X`: the result is in the factor's order.
    fn solve_forward_in_place(&self, x: MatMut<'_, f64>, par: Par);

    /// `X ← Gᵀ X = P L⁻ᵀ X`, for `X` in the factor's order.
    fn solve_backward_in_place(&self, x: MatMut<'_, f64>, par: Par);
}
