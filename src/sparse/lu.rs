//! LU factors of general sparse matrices (faer's supernodal LU with partial pivoting), the
//! symbolic analysis shared by every matrix of one pattern, e.g. the dynamic stiffness
//! `Z(ω)` at every frequency line (docs/theory.md (1.14)).

use super::operator::SparseSolve;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::lu::{NumericLu, factorize_symbolic_lu};
use faer::sparse::{FaerError, SparseColMatRef, SymbolicSparseColMatRef};
use faer::traits::ComplexField;
use faer::{Conj, MatMut, Par};

/// The symbolic LU analysis (fill-reducing column ordering, supernodal structure) of one
/// sparsity pattern.
pub struct SymbolicLu(faer::sparse::linalg::lu::SymbolicLu<usize>);

impl SymbolicLu {
    /// Analyses the pattern of a square matrix.
    pub fn new(pattern: SymbolicSparseColMatRef<'_, usize>) -> Result<Self, FaerError> {
        factorize_symbolic_lu(pattern, Default::default()).map(SymbolicLu)
    }
}

/// `A = Pᵣᵀ L U P꜀` of a square sparse matrix, on a [`SymbolicLu`] of its pattern.
pub struct Lu<'a, T: ComplexField> {
    symbolic: &'a SymbolicLu,
    numeric: NumericLu<usize, T>,
}

impl<'a, T: ComplexField> Lu<'a, T> {
    /// Factors `a`, whose pattern `symbolic` analysed; `par` is the parallelism of the
    /// numeric factorisation.
    pub fn new(
        symbolic: &'a SymbolicLu,
        a: SparseColMatRef<'_, usize, T>,
        par: Par,
    ) -> Result<Self, LuError> {
        let mut numeric = NumericLu::new();
        let scratch = symbolic
            .0
            .factorize_numeric_lu_scratch::<T>(par, Default::default());
        let mut buffer = MemBuffer::try_new(scratch).map_err(|_| FaerError::OutOfMemory)?;
        symbolic.0.factorize_numeric_lu(
            &mut numeric,
            a,
            par,
            MemStack::new(&mut buffer),
            Default::default(),
        )?;
        Ok(Lu { symbolic, numeric })
    }
}

impl<T: ComplexField> SparseSolve<T> for Lu<'_, T> {
    fn n(&self) -> usize {
        self.symbolic.0.nrows()
    }

    fn solve_in_place(&self, x: MatMut<'_, T>, par: Par) {
        let symbolic = &self.symbolic.0;
        let mut buffer = MemBuffer::new(symbolic.solve_in_place_scratch::<T>(x.ncols(), par));
        // `new_unchecked` only asks that the numeric factor was made on this symbolic one,
        // which `Lu::new` ensures.
        faer::sparse::linalg::lu::LuRef::new_unchecked(symbolic, &self.numeric)
            .solve_in_place_with_conj(Conj::No, x, par, MemStack::new(&mut buffer));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, Triplet};
    use faer::{Mat, c64};

    /// A complex symmetric tridiagonal matrix, solved in place with one and with several
    /// threads: the residual is at round-off and both results are identical.
    #[test]
    fn complex_solves_leave_round_off_and_do_not_depend_on_the_threads() {
        let n = 300;
        let mut t = Vec::new();
        for j in 0..n {
            t.push(Triplet::new(j, j, c64::new(4.0 + (j % 3) as f64, 0.5)));
            if j + 1 < n {
                t.push(Triplet::new(j, j + 1, c64::new(-1.0, 0.1)));
                t.push(Triplet::new(j + 1, j, c64::new(-1.0, 0.1)));
            }
        }
        let a = SparseColMat::<usize, c64>::try_new_from_triplets(n, n, &t).unwrap();
        let symbolic = SymbolicLu::new(a.symbolic()).unwrap();
        let b = Mat::from_fn(n, 3, |i, j| c64::new((i + j) as f64, 1.0));
        let mut results = Vec::new();
        for par in [Par::Seq, Par::rayon(2)] {
            let lu = Lu::new(&symbolic, a.as_ref(), par).unwrap();
            assert_eq!(lu.n(), n);
            let mut x = b.clone();
            lu.solve_in_place(x.as_mut(), par);
            let r = &a * &x - &b;
            assert!(r.norm_max() < 1e-12 * b.norm_max());
            results.push(x);
        }
        assert_eq!(results[0], results[1]);
    }

    /// A structurally singular matrix (an empty column) is refused, not solved.
    #[test]
    fn a_structurally_singular_matrix_is_refused() {
        let t = [
            Triplet::new(0, 0, c64::new(1.0, 0.0)),
            Triplet::new(1, 0, c64::new(1.0, 0.0)),
        ];
        let a = SparseColMat::<usize, c64>::try_new_from_triplets(2, 2, &t).unwrap();
        let symbolic = SymbolicLu::new(a.symbolic()).unwrap();
        assert!(Lu::new(&symbolic, a.as_ref(), Par::Seq).is_err());
    }
}
