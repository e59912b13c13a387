//! Sparse Cholesky factors of symmetric positive definite matrices.
//!
//! faer's approximate minimum degree orders the graph of the nodes ([`super::ordering`]: the
//! columns of each node merged into one vertex) and faer finds the supernodal structure; the
//! numeric factorisation is our multifrontal one ([`super::multifrontal`]: one dense Cholesky,
//! solve and rank update per supernode, independent subtrees in parallel), which uses the dense
//! kernels better than faer's left-looking one. When AMD's order leaves the supernodal tree out of
//! postorder (the muffler's does), the columns are renumbered in a postorder of the tree and the
//! structure found again: an equivalent ordering with the same fill in which every subtree is
//! contiguous, as the parallel factorisation and solves need. A nested dissection by breadth-first
//! level structures was tried on the plate and the muffler and gave 25–50 % more fill than AMD, and
//! METIS's multilevel one only 5 % less. The solves are multifrontal too: a triangular solve with a
//! few right-hand sides is bound by reading the factor, so every pass over the factor serves
//! [`SOLVE_COLUMNS`] columns, independent subtrees run on separate threads, and only the large
//! fronts of the top of the tree split their dense kernels. The forward and the backward sweep are
//! also available apart, for the symmetric shift-invert operator `L⁻¹ Pᵀ M P L⁻ᵀ` of the Lanczos
//! process. The ordering and structure depend on the pattern alone ([`FactorStructure`]): an
//! update's later analyses factor on the first one's, skipping AMD and the symbolic analysis.

use super::multifrontal::{self, FrontError};
use super::operator::{SparseSolve, SymmetricFactor};
use crate::core::hashing::StreamHasher;
use crate::core::sparse::SparseMatrix;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::{MatMut, Par, Side};
use std::sync::Arc;
use std::time::Instant;

/// Where a factorisation's time went, and its size.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct FactorInfo {
    /// Seconds in the ordering and the symbolic factorisation (elimination tree, supernodes),
    /// or in checking that an earlier one's pattern is this matrix's.
    pub symbolic_seconds: f64,
    /// Whether the ordering and structure of an earlier factorisation were used
    /// ([`FactorStructure`]).
    pub structure_reused: bool,
    /// Seconds in the numeric factorisation.
    pub numeric_seconds: f64,
    /// Stored entries of the factor (dense supernodal blocks included).
    pub factor_entries: usize,
}

/// Why a factorisation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FactorError {
    /// A pivot was not positive: the matrix is not positive definite.
    NotPositiveDefinite,
    /// The factor did not fit in memory.
    OutOfMemory,
}

/// Columns solved per pass over the factor: a pass is bound by reading the factor until about
/// this many columns share it.
pub const SOLVE_COLUMNS: usize = 16;

fn front_error(e: FrontError) -> FactorError {
    match e {
        FrontError::NotPositiveDefinite => FactorError::NotPositiveDefinite,
        FrontError::OutOfMemory => FactorError::OutOfMemory,
    }
}

/// The ordering of `symbolic` with its supernodes renumbered in a postorder of `tree`
/// (`forward[new] = old`, as faer's permutations): each supernode's columns stay together and
/// in order.
fn postordered_ordering(
    symbolic: &SymbolicCholesky<usize>,
    tree: &multifrontal::Tree,
) -> Vec<usize> {
    let supernodal = supernodes(symbolic);
    let (begin, end) = (supernodal.supernode_begin(), supernodal.supernode_end());
    let forward = symbolic.perm().map(|p| p.arrays().0);
    tree.postorder()
        .into_iter()
        .flat_map(|s| begin[s]..end[s])
        .map(|column| forward.map_or(column, |f| f[column]))
        .collect()
}

/// The ordering and supernodal structure of the lower triangle of `a` (faer's symbolic
/// analysis, forced supernodal, as the multifrontal factorisation needs).
pub(crate) fn supernodal_symbolic(
    a: &SparseMatrix,
    ordering: SymmetricOrdering<'_, usize>,
) -> Result<SymbolicCholesky<usize>, faer::sparse::FaerError> {
    factorize_symbolic_cholesky(
        a.symbolic(),
        Side::Lower,
        ordering,
        CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        },
    )
}

/// The supernodal structure of a symbolic factorisation made with
/// [`SupernodalThreshold::FORCE_SUPERNODAL`].
fn supernodes(
    symbolic: &SymbolicCholesky<usize>,
) -> &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize> {
    let SymbolicCholeskyRaw::Supernodal(supernodal) = symbolic.raw() else {
        unreachable!("the symbolic factorisation is forced supernodal")
    };
    supernodal
}

/// `inverse[forward[i]] = i`.
fn inverse_permutation(forward: &[usize]) -> Vec<usize> {
    let mut inverse = vec![0; forward.len()];
    for (i, &f) in forward.iter().enumerate() {
        inverse[f] = i;
    }
    inverse
}

/// The ordering and supernodal structure of a factorisation, with a fingerprint of the pattern
/// it was found for. A later matrix of the same pattern (an update's `K(φ) − σM(φ)` at new
/// parameter values: the elements and their connections do not change) is factored on it
/// without a second ordering and symbolic analysis, to the same bits, since both depend on the
/// pattern alone.
#[derive(Clone)]
pub struct FactorStructure(Arc<Structure>);

struct Structure {
    symbolic: SymbolicCholesky<usize>,
    tree: multifrontal::Tree,
    pattern: PatternKey,
}

impl std::fmt::Debug for FactorStructure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FactorStructure")
            .field("n", &self.0.pattern.n)
            .field("pattern_entries", &self.0.pattern.entries)
            .field("factor_entries", &self.0.symbolic.len_val())
            .finish()
    }
}

/// A sparse matrix's pattern as a key: its order, its stored entries and a blake3 hash of its
/// column pointers and row indices (and column counts, for storage with gaps).
#[derive(Clone, Debug, PartialEq, Eq)]
struct PatternKey {
    n: usize,
    entries: usize,
    hash: [u8; 32],
}

impl PatternKey {
    fn of(a: &SparseMatrix) -> Self {
        let pattern = a.symbolic();
        let mut hasher = StreamHasher::new();
        // In memory only (never stored): the native-width indices are hashed in place.
        let mut feed = |values: &[usize]| {
            hasher.bytes(&(values.len() as u64).to_le_bytes());
            hasher.le_values(values, usize::to_le_bytes);
        };
        feed(pattern.col_ptr());
        feed(pattern.row_idx());
        if let Some(counts) = pattern.col_nnz() {
            feed(counts);
        }
        PatternKey {
            n: pattern.nrows(),
            entries: pattern.row_idx().len(),
            hash: *hasher.finish().as_bytes(),
        }
    }
}

/// `A = P L Lᵀ Pᵀ` of a sparse symmetric positive definite `A`.
pub struct SpdFactor {
    structure: FactorStructure,
    values: Vec<f64>,
    /// Timings and size.
    pub info: FactorInfo,
}

impl SpdFactor {
    /// Factors `A`, of which the lower triangle is read (full or lower storage), with
    /// parallelism `par`.
    pub fn new(a: &SparseMatrix, par: Par) -> Result<Self, FactorError> {
        Self::factor(a, par, None)
    }

    /// Factors `A` and frees it as soon as its permuted copy is made, before the factor's
    /// storage is allocated, so `A` is not held beside its copy and the factor at the peak.
    pub fn consuming(a: SparseMatrix, par: Par) -> Result<Self, FactorError> {
        Self::factor(a, par, None)
    }

    /// [`SpdFactor::consuming`] on the structure of an earlier factorisation when `a` has the
    /// pattern it was found for (see [`FactorStructure`]); otherwise the structure is found.
    pub fn consuming_on(
        a: SparseMatrix,
        par: Par,
        structure: Option<&FactorStructure>,
    ) -> Result<Self, FactorError> {
        Self::factor(a, par, structure)
    }

    /// The ordering and supernodal structure, for factoring matrices of the same pattern.
    pub fn structure(&self) -> &FactorStructure {
        &self.structure
    }

    /// Factors `a`, borrowed or owned (an owned one is dropped once permuted), on `held` when
    /// its pattern is `a`'s.
    fn factor(
        a: impl std::borrow::Borrow<SparseMatrix>,
        par: Par,
        held: Option<&FactorStructure>,
    ) -> Result<Self, FactorError> {
        let mut info = FactorInfo::default();
        let t = Instant::now();
        let pattern = PatternKey::of(a.borrow());
        let structure = match held.filter(|h| h.0.pattern == pattern) {
            Some(h) => {
                info.structure_reused = true;
                h.clone()
            }
            None => Self::analyse(a.borrow(), pattern)?,
        };
        info.symbolic_seconds = t.elapsed().as_secs_f64();
        let symbolic = &structure.0.symbolic;
        info.factor_entries = symbolic.len_val();
        let t = Instant::now();
        let supernodal = supernodes(symbolic);
        let inverse = symbolic.perm().map(|p| p.arrays().1);
        let lower = multifrontal::PermutedLower::new(a.borrow(), inverse).map_err(front_error)?;
        drop(a);
        let mut values =
            crate::core::memory::zeroed_f64(symbolic.len_val()).ok_or(FactorError::OutOfMemory)?;
        multifrontal::factorize(supernodal, &structure.0.tree, &lower, &mut values, par)
            .map_err(front_error)?;
        info.numeric_seconds = t.elapsed().as_secs_f64();
        Ok(SpdFactor {
            structure,
            values,
            info,
        })
    }

    /// The ordering (AMD on the node graph, in a postorder of the supernodal tree) and the
    /// supernodal structure of `a`, whose pattern is `pattern`.
    fn analyse(a: &SparseMatrix, pattern: PatternKey) -> Result<FactorStructure, FactorError> {
        // The structure for an ordering `forward[new] = old`.
        let analyse = |forward: &[usize]| {
            let inverse = inverse_permutation(forward);
            let ordering = faer::perm::PermRef::new_checked(forward, &inverse, forward.len());
            supernodal_symbolic(a, SymmetricOrdering::Custom(ordering))
                .map_err(|_| FactorError::OutOfMemory)
        };
        let order = super::ordering::node_amd(a).ok_or(FactorError::OutOfMemory)?;
        let mut symbolic = analyse(&order)?;
        drop(order);
        let mut tree = multifrontal::Tree::new(supernodes(&symbolic));
        if !tree.is_postordered() {
            // AMD's elimination order need not number subtrees contiguously, and then the
            // factorisation and solves run on one thread. A postorder of the supernodal tree is
            // an equivalent ordering (the same fill) in which they do.
            symbolic = analyse(&postordered_ordering(&symbolic, &tree))?;
            tree = multifrontal::Tree::new(supernodes(&symbolic));
        }
        Ok(FactorStructure(Arc::new(Structure {
            symbolic,
            tree,
            pattern,
        })))
    }

    /// [`SymmetricFactor::solve_backward_in_place`] with up to `columns` columns per pass.
    pub fn solve_backward_in_place_in_passes(&self, x: MatMut<'_, f64>, columns: usize, par: Par) {
        self.sweeps(x, columns, multifrontal::Sweeps::Backward, par);
    }

    fn sweeps(&self, x: MatMut<'_, f64>, columns: usize, sweeps: multifrontal::Sweeps, par: Par) {
        let Structure { symbolic, tree, .. } = &*self.structure.0;
        let permutation = symbolic.perm().map(|p| p.arrays());
        multifrontal::solve(
            supernodes(symbolic),
            tree,
            permutation,
            &self.values,
            x,
            columns,
            sweeps,
            par,
        );
    }

    /// faer's own supernodal solve, one thread: the reference the tests hold ours to.
    #[cfg(test)]
    fn solve_by_faer(&self, x: MatMut<'_, f64>) {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::sparse::linalg::cholesky::LltRef;
        use faer::{Conj, Par};
        if x.ncols() == 0 {
            return;
        }
        let symbolic = &self.structure.0.symbolic;
        let scratch = symbolic.solve_in_place_scratch::<f64>(x.ncols(), Par::Seq);
        let mut buffer = MemBuffer::new(scratch);
        LltRef::<'_, usize, f64>::new(symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            x,
            Par::Seq,
            MemStack::new(&mut buffer),
        );
    }
}

/// Independent subtrees of the factor on separate threads (unless `par` is one thread), up to
/// [`SOLVE_COLUMNS`] columns per pass over the factor.
impl SparseSolve<f64> for SpdFactor {
    fn n(&self) -> usize {
        self.structure.0.symbolic.nrows()
    }

    fn solve_in_place(&self, x: MatMut<'_, f64>, par: Par) {
        self.sweeps(x, SOLVE_COLUMNS, multifrontal::Sweeps::Both, par);
    }
}

/// `G = L⁻¹ Pᵀ`, so that `G A Gᵀ = I`.
impl SymmetricFactor for SpdFactor {
    fn solve_forward_in_place(&self, x: MatMut<'_, f64>, par: Par) {
        self.sweeps(x, SOLVE_COLUMNS, multifrontal::Sweeps::Forward, par);
    }

    fn solve_backward_in_place(&self, x: MatMut<'_, f64>, par: Par) {
        self.sweeps(x, SOLVE_COLUMNS, multifrontal::Sweeps::Backward, par);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::sparse_from_triplets;
    use faer::Mat;

    /// A 2-D grid Laplacian plus identity (full storage), solved against a dense reference.
    #[test]
    fn solves_match_a_dense_cholesky() {
        let (nx, ny) = (30, 25);
        let node = |i: usize, j: usize| i * ny + j;
        let mut t = Vec::new();
        for i in 0..nx {
            for j in 0..ny {
                t.push((node(i, j), node(i, j), 5.0));
                for (a, b) in [(i + 1, j), (i, j + 1)] {
                    if a < nx && b < ny {
                        t.push((node(i, j), node(a, b), -1.0));
                        t.push((node(a, b), node(i, j), -1.0));
                    }
                }
            }
        }
        let n = nx * ny;
        let a = sparse_from_triplets("A", n, &t).unwrap();
        let f = SpdFactor::new(&a, Par::rayon(0)).unwrap();
        let b = Mat::from_fn(n, 5, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
        let mut x = b.clone();
        f.solve_in_place(x.as_mut(), Par::rayon(0));
        let dense = crate::core::sparse::sparse_to_dense(&a);
        let r = &dense * &x - &b;
        assert!(r.norm_max() < 1e-12 * b.norm_max(), "{}", r.norm_max());
    }

    /// The multifrontal solve against faer's supernodal solve of the same factor, on a 3-D grid
    /// whose tree is split among the threads, with a column count that leaves a partial pass.
    /// Both are backward stable on a matrix of condition ~10: they agree to 1e-13.
    #[test]
    fn tree_parallel_solves_equal_faers_solves() {
        let a = super::multifrontal::grid_laplacian(28);
        let n = a.ncols();
        let f = SpdFactor::new(&a, Par::rayon(0)).unwrap();
        let b = Mat::from_fn(n, SOLVE_COLUMNS + 5, |i, j| {
            ((i * 7 + j * 3) % 11) as f64 - 5.0
        });
        let (mut ours, mut faers) = (b.clone(), b.clone());
        f.solve_in_place(ours.as_mut(), Par::rayon(0));
        f.solve_by_faer(faers.as_mut());
        let scale = faers.norm_max();
        assert!((&ours - &faers).norm_max() < 1e-13 * scale);
        // On one thread (no subtree split, no parallel copies): the same numbers, bit for bit.
        let mut one_thread = b.clone();
        f.solve_in_place(one_thread.as_mut(), Par::Seq);
        assert_eq!(one_thread, ours);
        // And a single column, alone in its pass.
        let mut one = b.subcols(2, 1).to_owned();
        f.solve_in_place(one.as_mut(), Par::rayon(0));
        assert!((&one - faers.subcols(2, 1)).norm_max() < 1e-13 * scale);
    }

    /// A small muffler box (shells, baffles, tubes), whose AMD order does not number the
    /// supernodal tree's subtrees contiguously: the factor is renumbered in a postorder, with
    /// the same number of entries (an equivalent ordering), and its tree-parallel solves equal
    /// faer's solves of the same factor and leave a residual at round-off.
    #[test]
    fn a_non_postordered_amd_tree_is_renumbered_with_the_same_fill() {
        use crate::fe::element::MassKind;
        use crate::fe::model_assembly::assemble_model;
        use crate::model::generate::scale::{muffler, muffler_element_size};
        let model = muffler(muffler_element_size(6_000, 2), 2);
        let (sys, _) = assemble_model(&model, MassKind::Consistent).unwrap();
        // Free-free: shift below zero.
        let a = crate::sparse::lower_combination(1.0, &sys.k, 1e3, &sys.m);
        let order = super::super::ordering::node_amd(&a).unwrap();
        let inverse = inverse_permutation(&order);
        let ordering = faer::perm::PermRef::new_checked(&order, &inverse, order.len());
        let amd = supernodal_symbolic(&a, SymmetricOrdering::Custom(ordering)).unwrap();
        assert!(
            !multifrontal::Tree::new(supernodes(&amd)).is_postordered(),
            "the test needs a matrix whose AMD tree is not postordered"
        );
        let f = SpdFactor::new(&a, Par::rayon(0)).unwrap();
        assert!(f.structure.0.tree.is_postordered());
        assert_eq!(f.info.factor_entries, amd.len_val());
        let n = a.ncols();
        let b = Mat::from_fn(n, SOLVE_COLUMNS + 3, |i, j| {
            ((i * 5 + j * 3) % 13) as f64 - 6.0
        });
        let (mut ours, mut faers) = (b.clone(), b.clone());
        f.solve_in_place(ours.as_mut(), Par::rayon(0));
        f.solve_by_faer(faers.as_mut());
        assert!((&ours - &faers).norm_max() < 1e-12 * faers.norm_max());
        // A = K + 10³ M, applied through the fully stored K and M.
        let (mut kx, mut mx) = (
            Mat::<f64>::zeros(n, b.ncols()),
            Mat::<f64>::zeros(n, b.ncols()),
        );
        crate::sparse::sym_matvec(&sys.k, ours.as_ref(), kx.as_mut(), Par::rayon(0));
        crate::sparse::sym_matvec(&sys.m, ours.as_ref(), mx.as_mut(), Par::rayon(0));
        let residual = (&kx + faer::Scale(1e3) * &mx - &b).norm_max() / b.norm_max();
        assert!(residual < 1e-8, "relative residual {residual:e}");
    }

    /// The two half solves, one after the other, are the full solve; and the forward half
    /// `G = L⁻¹ Pᵀ` whitens `A`: `G A Gᵀ = I`, checked as `Gᵀ` applied by the backward half.
    #[test]
    fn half_solves_compose_to_the_solve_and_whiten_the_matrix() {
        let a = super::multifrontal::grid_laplacian(12);
        let n = a.ncols();
        let f = SpdFactor::new(&a, Par::rayon(0)).unwrap();
        let b = Mat::from_fn(n, 7, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
        let (mut full, mut halves) = (b.clone(), b.clone());
        f.solve_in_place(full.as_mut(), Par::rayon(0));
        f.solve_forward_in_place(halves.as_mut(), Par::rayon(0));
        f.solve_backward_in_place_in_passes(halves.as_mut(), 3, Par::rayon(0));
        assert!((&full - &halves).norm_max() < 1e-13 * full.norm_max());
        // Gᵀ e_j by the backward half; then G A Gᵀ e_j by A and the forward half.
        let mut g_t = Mat::<f64>::identity(n, n);
        f.solve_backward_in_place_in_passes(g_t.as_mut(), SOLVE_COLUMNS, Par::rayon(0));
        let mut whitened = crate::core::sparse::sparse_to_dense(&a) * &g_t;
        f.solve_forward_in_place(whitened.as_mut(), Par::rayon(0));
        let identity = Mat::<f64>::identity(n, n);
        assert!((&whitened - &identity).norm_max() < 1e-12);
    }

    /// A matrix of the same pattern is factored on the held structure, to the bits of its own
    /// factorisation; a matrix of another pattern (one more entry, or the same entries in
    /// lower storage) is analysed afresh, and still solved to round-off.
    #[test]
    fn the_held_structure_serves_a_matrix_of_the_same_pattern_only() {
        let a = super::multifrontal::grid_laplacian(9);
        let n = a.ncols();
        let first = SpdFactor::new(&a, Par::rayon(0)).unwrap();
        assert!(!first.info.structure_reused);
        // The same pattern, other values (as an update's model at new parameter values).
        let mut t = Vec::new();
        for j in 0..n {
            for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
                t.push((i, j, if i == j { v * 1.3 + 0.2 } else { v * 0.9 }));
            }
        }
        let b = sparse_from_triplets("B", n, &t).unwrap();
        let held =
            SpdFactor::consuming_on(b.clone(), Par::rayon(0), Some(first.structure())).unwrap();
        let fresh = SpdFactor::new(&b, Par::rayon(0)).unwrap();
        assert!(held.info.structure_reused && !fresh.info.structure_reused);
        assert_eq!(held.values, fresh.values, "the same bits");
        // One more coupling (and its mirror): another pattern.
        t.push((0, n - 1, -0.01));
        t.push((n - 1, 0, -0.01));
        let c = sparse_from_triplets("C", n, &t).unwrap();
        let other =
            SpdFactor::consuming_on(c.clone(), Par::rayon(0), Some(first.structure())).unwrap();
        assert!(!other.info.structure_reused);
        let rhs = Mat::from_fn(n, 3, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
        let mut x = rhs.clone();
        other.solve_in_place(x.as_mut(), Par::rayon(0));
        let r = crate::core::sparse::sparse_to_dense(&c) * &x - &rhs;
        assert!(r.norm_max() < 1e-12 * rhs.norm_max(), "{}", r.norm_max());
        // The lower triangle alone is another storage of `B`: analysed afresh, the same factor.
        let lower = crate::sparse::lower_combination(1.0, &b, 0.0, &b);
        let relowered =
            SpdFactor::consuming_on(lower, Par::rayon(0), Some(held.structure())).unwrap();
        assert!(!relowered.info.structure_reused);
        assert_eq!(relowered.info.factor_entries, fresh.info.factor_entries);
    }

    #[test]
    fn an_indefinite_matrix_is_refused() {
        let t = vec![(0, 0, 1.0), (1, 1, -1.0), (1, 0, 0.1), (0, 1, 0.1)];
        let a = sparse_from_triplets("A", 2, &t).unwrap();
        assert_eq!(
            SpdFactor::new(&a, Par::rayon(0)).err(),
            Some(FactorError::NotPositiveDefinite)
        );
    }

    /// Factors and solves at the bounds of the multifrontal code and its kernels: a 1 × 1
    /// matrix (one supernode of one column), a diagonal matrix (columns without entries below
    /// the diagonal: supernodes with nothing to hand on), a dense matrix (one supernode holding
    /// every column, the largest front), and a grid. Every column count from 0 to 17 (no pass,
    /// each padded width of the thin kernels, faer's kernels past 16), each sweep, on one
    /// thread and on two: the results are equal bit for bit, and the solves leave round-off.
    #[test]
    fn factors_and_solves_at_the_bounds_do_not_depend_on_the_threads() {
        let diagonal: Vec<_> = (0..9).map(|j| (j, j, 1.0 + j as f64)).collect();
        let n = 40;
        let mut dense = Vec::new();
        for j in 0..n {
            for i in 0..n {
                dense.push((
                    i,
                    j,
                    if i == j {
                        2.0 * n as f64
                    } else {
                        1.0 / (1 + i + j) as f64
                    },
                ));
            }
        }
        let matrices = [
            sparse_from_triplets("A", 1, &[(0, 0, 4.0)]).unwrap(),
            sparse_from_triplets("A", 9, &diagonal).unwrap(),
            sparse_from_triplets("A", n, &dense).unwrap(),
            super::multifrontal::grid_laplacian(7),
        ];
        for a in &matrices {
            let n = a.ncols();
            let factors = [Par::Seq, Par::rayon(2)].map(|par| SpdFactor::new(a, par).unwrap());
            assert_eq!(factors[0].values, factors[1].values);
            assert_eq!(factors[0].n(), n);
            let dense = crate::core::sparse::sparse_to_dense(a);
            for columns in 0..=17 {
                let b = Mat::from_fn(n, columns, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
                let solve = |f: &SpdFactor, par: Par| {
                    let (mut x, mut fw, mut bw) = (b.clone(), b.clone(), b.clone());
                    f.solve_in_place(x.as_mut(), par);
                    f.solve_forward_in_place(fw.as_mut(), par);
                    f.solve_backward_in_place(bw.as_mut(), par);
                    [x, fw, bw]
                };
                let one = solve(&factors[0], Par::Seq);
                let two = solve(&factors[1], Par::rayon(2));
                assert_eq!(one, two, "{n} rows, {columns} columns");
                let r = &dense * &one[0] - &b;
                assert!(
                    r.norm_max() <= 1e-12 * b.norm_max().max(1.0),
                    "{n} rows, {columns}"
                );
            }
        }
    }
}
