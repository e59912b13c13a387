//! Sparse `A = P L D Lᵀ Pᵀ` of a complex symmetric (not Hermitian) matrix, without pivoting and
//! without conjugation, for the dynamic stiffness `Z(ω) = K + iD + iωC − ω²M` of the direct FRF
//! (docs/theory.md (1.14)).
//!
//! The ordering (node-graph AMD, [`super::ordering`]) and the supernodal structure (faer's
//! symbolic Cholesky) are those of the eigensolver's factor, computed once for a pattern
//! ([`SymbolicLdlt`]); so are the map of every stored entry of `A` into the factor's storage and
//! the map of every supernode's update rows into its parent's front. A numeric factorisation
//! ([`SymbolicLdlt::factorize`]) then only scatters the values and runs the multifrontal sweep:
//! per supernode in a postorder of the tree, the children's update matrices are added into the
//! front, the panel `[F_11; F_21]` is factored as `F_11 = L_11 D L_11ᵀ`,
//! `L_21 = F_21 L_11⁻ᵀ D⁻¹` (a recursive blocked `LDLᵀ` whose bulk is a complex matrix product),
//! and `U = F_22 − L_21 D L_21ᵀ` goes to the parent. Each caller owns an [`LdltWorkspace`], so many
//! matrices of one pattern (frequency lines) factor on separate threads.
//!
//! Without pivoting the factorisation is backward stable only where the pivots stay away from
//! zero relative to the entries they eliminate; a zero or non-finite pivot is reported, and the
//! caller checks the residual of its solutions (the direct FRF falls back to a pivoted LU).

use crate::core::sparse::SparseMatrix;
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::sparse::linalg::cholesky::{SymbolicCholeskyRaw, SymmetricOrdering};
use faer::{Accum, MatMut, MatRef, Par, c64};
use kernels::Kernels;
pub(crate) use kernels::{Isa, Level};

mod kernels;

/// Columns factored by the unblocked kernel; wider panels split in two.
const BLOCK: usize = 16;

/// Why a numeric factorisation or the analysis failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LdltError {
    /// A pivot was zero or not finite (in the factor's order).
    #[error("zero or non-finite pivot at column {0} of the factor")]
    ZeroPivot(usize),
    /// The ordering or the symbolic analysis ran out of memory.
    #[error("out of memory in the symbolic analysis")]
    OutOfMemory,
}

/// The ordering, supernodal structure and assembly maps of one symmetric pattern.
pub struct SymbolicLdlt {
    n: usize,
    /// `forward[new] = old`.
    forward: Vec<usize>,
    /// Supernode `s` holds the factor's columns `begin[s]..begin[s + 1]`.
    begin: Vec<usize>,
    /// Rows below supernode `s`'s diagonal block (factor order, ascending):
    /// `pattern[pattern_ptr[s]..pattern_ptr[s + 1]]`.
    pattern_ptr: Vec<usize>,
    pattern: Vec<usize>,
    /// For each of those rows, its place in the parent's front (the parent's columns first,
    /// then its pattern).
    relative: Vec<usize>,
    /// Supernode `s`'s panel, `(w + r) × w` column-major, starts at `value_ptr[s]`.
    value_ptr: Vec<usize>,
    /// Supernodes in a postorder of the tree, and each one's number of children.
    postorder: Vec<usize>,
    children: Vec<usize>,
    /// The place in its supernode's panel of the `k`-th entry in the factor's order, and
    /// that entry's place among the stored lower-triangle entries of the analysed pattern.
    /// Supernode `s` takes entries `scatter_ptr[s]..scatter_ptr[s + 1]`.
    slots: Vec<u32>,
    entry_order: Vec<usize>,
    scatter_ptr: Vec<usize>,
    /// Where each run of consecutive places in `relative` starts (relative to the supernode's
    /// first row): supernode `s`'s runs are `runs[run_ptr[s]..run_ptr[s + 1]]`.
    runs: Vec<usize>,
    run_ptr: Vec<usize>,
    /// Largest `r` of a supernode.
    max_rows: usize,
    /// Largest `w` of a supernode.
    max_width: usize,
    /// Largest `r · w` of a supernode.
    max_panel_below: usize,
    /// Whether each supernode's depth in the tree (roots at 0) is odd.
    odd_depth: Vec<bool>,
}

/// A factor's values and the scratch of its factorisation: one per thread.
pub struct LdltWorkspace<T: LdltScalar> {
    values: Vec<T>,
    /// Update matrices handed from children to parents, `r × r` each, and their owners and
    /// places: those of supernodes at even depth of the tree on the first stack, odd on the
    /// second, so that a front is built in place on its stack while its children's updates,
    /// one depth below, sit on top of the other. A stack's buffer keeps the length it has
    /// grown to and `tops` says where its frames end, so that a new front is zeroed in its
    /// lower triangle only (the upper one is never read).
    stacks: [Vec<T>; 2],
    tops: [usize; 2],
    frames: [Vec<(usize, usize)>; 2],
    scaled: Vec<T>,
}

/// A scalar the factorisation runs in, with its vector kernels: `c64` for the complex
/// symmetric dynamic stiffness of a direct FRF line, `f64` for the real `K − ω²M` of a Krylov
/// sweep's expansion point (a quarter of the complex arithmetic and half the storage).
pub trait LdltScalar:
    faer::traits::ComplexField
    + Copy
    + PartialEq
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::AddAssign
    + std::ops::SubAssign
    + std::ops::MulAssign
    + std::ops::DivAssign
    + std::iter::Sum
    + Send
    + Sync
{
    /// `0`.
    const NIL: Self;
    /// `1`.
    const UNIT: Self;
    /// Whether both parts are finite.
    fn finite(self) -> bool;
    /// [`unblocked_ldlt`] by the kernels of `isa`.
    fn unblocked(isa: Isa, a: &mut [Self], ld: usize, c0: usize, w: usize) -> Result<(), usize>;
    /// [`SymbolicLdlt::extend_add`] likewise.
    #[allow(clippy::too_many_arguments)]
    fn extend_add(
        isa: Isa,
        sym: &SymbolicLdlt,
        c: usize,
        update: &[Self],
        w: usize,
        panel: &mut [Self],
        front: &mut [Self],
        into_front: bool,
    );
    /// [`SymbolicLdlt::solve_with`] likewise.
    fn solve(isa: Isa, sym: &SymbolicLdlt, values: &[Self], y: &mut [Self], scratch: &mut [Self]);
}

impl LdltScalar for c64 {
    const NIL: Self = c64::ZERO;
    const UNIT: Self = c64::ONE;
    fn finite(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
    kernels::dispatch!(complex_avx2, complex_avx512);
}

impl LdltScalar for f64 {
    const NIL: Self = 0.0;
    const UNIT: Self = 1.0;
    fn finite(self) -> bool {
        self.is_finite()
    }
    kernels::dispatch!(real_avx2, real_avx512);
}

/// The second of `pair` and the first, if `second`; else the first and the second.
fn own_and_other<T>(pair: &mut [T; 2], second: bool) -> (&mut T, &mut T) {
    let [first, other] = pair;
    if second {
        (other, first)
    } else {
        (first, other)
    }
}

impl SymbolicLdlt {
    /// Analyses the pattern of the symmetric matrix whose lower triangle (diagonal included)
    /// `lower` stores; values are not read. [`factorize`](Self::factorize) takes the values in
    /// the factor's order, to which [`in_factor_order`](Self::in_factor_order) maps `lower`'s.
    pub fn new(lower: &SparseMatrix) -> Result<Self, LdltError> {
        let n = lower.ncols();
        let forward = super::ordering::node_amd(lower).ok_or(LdltError::OutOfMemory)?;
        let mut inverse = vec![0; n];
        for (new, &old) in forward.iter().enumerate() {
            inverse[old] = new;
        }
        let ordering = faer::perm::PermRef::new_checked(&forward, &inverse, n);
        let symbolic =
            super::factor::supernodal_symbolic(lower, SymmetricOrdering::Custom(ordering))
                .map_err(|_| LdltError::OutOfMemory)?;
        let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
            unreachable!("the symbolic factorisation is forced supernodal")
        };
        let ns = sn.n_supernodes();
        let begin: Vec<usize> = sn.supernode_begin().iter().copied().chain([n]).collect();
        let mut owner = vec![0usize; n];
        for s in 0..ns {
            owner[begin[s]..begin[s + 1]].fill(s);
        }
        let mut pattern_ptr = vec![0usize; ns + 1];
        let mut pattern = Vec::new();
        let mut value_ptr = vec![0usize; ns + 1];
        let (mut max_rows, mut max_width, mut max_panel_below) = (0, 0, 0);
        for s in 0..ns {
            let rows = sn.supernode(s).pattern();
            pattern.extend_from_slice(rows);
            pattern_ptr[s + 1] = pattern.len();
            let (w, r) = (begin[s + 1] - begin[s], rows.len());
            value_ptr[s + 1] = value_ptr[s] + (w + r) * w;
            max_rows = max_rows.max(r);
            max_width = max_width.max(w);
            max_panel_below = max_panel_below.max(r * w);
        }
        let rows_of = |s: usize| &pattern[pattern_ptr[s]..pattern_ptr[s + 1]];
        // The place of factor row `i` in supernode `s`'s front.
        let place = |s: usize, i: usize| {
            if i < begin[s + 1] {
                i - begin[s]
            } else {
                let below = rows_of(s)
                    .binary_search(&i)
                    .expect("the symbolic structure holds every row of the front");
                begin[s + 1] - begin[s] + below
            }
        };
        let parent: Vec<Option<usize>> = (0..ns)
            .map(|s| rows_of(s).first().map(|&i| owner[i]))
            .collect();
        let mut relative = Vec::with_capacity(pattern.len());
        for (s, p) in parent.iter().enumerate() {
            if let Some(p) = *p {
                relative.extend(rows_of(s).iter().map(|&i| place(p, i)));
            }
        }
        // Children lists (ascending) and a postorder by depth-first search from the roots.
        let mut child_ptr = vec![0usize; ns + 1];
        for p in parent.iter().flatten() {
            child_ptr[p + 1] += 1;
        }
        for s in 0..ns {
            child_ptr[s + 1] += child_ptr[s];
        }
        let children: Vec<usize> = (0..ns).map(|s| child_ptr[s + 1] - child_ptr[s]).collect();
        let mut child_idx = vec![0usize; child_ptr[ns]];
        let mut next = child_ptr.clone();
        for (s, p) in parent.iter().enumerate() {
            if let Some(p) = *p {
                child_idx[next[p]] = s;
                next[p] += 1;
            }
        }
        let mut postorder = Vec::with_capacity(ns);
        let mut stack: Vec<(usize, usize)> = (0..ns)
            .rev()
            .filter(|&s| parent[s].is_none())
            .map(|s| (s, 0))
            .collect();
        while let Some((s, visited)) = stack.pop() {
            if visited < children[s] {
                stack.push((s, visited + 1));
                stack.push((child_idx[child_ptr[s] + visited], 0));
            } else {
                postorder.push(s);
            }
        }
        let mut scatter: Vec<(usize, usize)> = Vec::with_capacity(lower.compute_nnz());
        for oj in 0..n {
            for &oi in lower.row_idx_of_col_raw(oj) {
                let (a, b) = (inverse[oi], inverse[oj]);
                let (i, j) = (a.max(b), a.min(b));
                let s = owner[j];
                let m = begin[s + 1] - begin[s] + rows_of(s).len();
                scatter.push((
                    value_ptr[s] + (j - begin[s]) * m + place(s, i),
                    scatter.len(),
                ));
            }
        }
        // By supernode, so that each panel is filled just before it is factored.
        scatter.sort_unstable();
        let (slots, entry_order): (Vec<usize>, Vec<usize>) = scatter.into_iter().unzip();
        let mut scatter_ptr = vec![0usize; ns + 1];
        for s in 0..ns {
            scatter_ptr[s + 1] = slots.partition_point(|&slot| slot < value_ptr[s + 1]);
        }
        // Within its panel: four bytes an entry to stream at every factorisation.
        let mut local = Vec::with_capacity(slots.len());
        for s in 0..ns {
            for &slot in &slots[scatter_ptr[s]..scatter_ptr[s + 1]] {
                local.push(u32::try_from(slot - value_ptr[s]).map_err(|_| LdltError::OutOfMemory)?);
            }
        }
        let slots = local;
        // A parent's index is above its children's.
        let mut odd_depth = vec![false; ns];
        for s in (0..ns).rev() {
            odd_depth[s] = parent[s].is_some_and(|p| !odd_depth[p]);
        }
        // Runs of consecutive places in each supernode's relative map.
        let mut run_ptr = vec![0usize; ns + 1];
        let mut runs = Vec::new();
        for s in 0..ns {
            let rel = &relative[pattern_ptr[s]..pattern_ptr[s + 1]];
            runs.extend((0..rel.len()).filter(|&k| k == 0 || rel[k] != rel[k - 1] + 1));
            run_ptr[s + 1] = runs.len();
        }
        Ok(SymbolicLdlt {
            n,
            forward,
            begin,
            pattern_ptr,
            pattern,
            relative,
            value_ptr,
            postorder,
            children,
            slots,
            entry_order,
            scatter_ptr,
            runs,
            run_ptr,
            max_rows,
            max_width,
            max_panel_below,
            odd_depth,
        })
    }

    /// Order of the matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Stored entries of the factor (dense supernodal panels).
    pub fn factor_entries(&self) -> usize {
        self.value_ptr[self.value_ptr.len() - 1]
    }

    /// Supernodes and the real floating-point operations of one numeric factorisation: each
    /// factor column with `c` entries below its diagonal costs `c (c + 1) / 2` complex
    /// multiply-adds (8 real operations each) for its update of the trailing lower triangle.
    pub fn shape(&self) -> (usize, f64) {
        let ns = self.begin.len() - 1;
        let mut macs = 0.0;
        for s in 0..ns {
            let (_, w, rows) = self.supernode(s);
            let m = w + rows.len();
            for j in 0..w {
                let c = (m - j - 1) as f64;
                macs += c * (c + 1.0) / 2.0;
            }
        }
        (ns, 8.0 * macs)
    }

    /// The storage of one factor and its scratch.
    pub fn workspace<T: LdltScalar>(&self) -> LdltWorkspace<T> {
        LdltWorkspace {
            values: vec![T::NIL; self.factor_entries()],
            stacks: [Vec::new(), Vec::new()],
            tops: [0; 2],
            frames: [Vec::new(), Vec::new()],
            scaled: vec![T::NIL; self.max_panel_below],
        }
    }

    /// Per-entry data of the analysed pattern (one item per stored lower entry, in its stored
    /// order) in the factor's order, the order in which [`factorize`](Self::factorize) asks for
    /// the values.
    pub fn in_factor_order<T: Copy>(&self, stored: &[T]) -> Vec<T> {
        assert_eq!(
            stored.len(),
            self.entry_order.len(),
            "one item per stored entry"
        );
        self.entry_order.iter().map(|&e| stored[e]).collect()
    }

    /// Factors the matrix whose `k`-th entry in the factor's order is `value(k)`
    /// ([`in_factor_order`](Self::in_factor_order) maps stored entries to it: filling a panel
    /// then reads its values in sequence), into `ws`; `par` splits the dense kernels of large
    /// fronts.
    pub fn factorize<T: LdltScalar>(
        &self,
        ws: &mut LdltWorkspace<T>,
        value: impl Fn(usize) -> T,
        par: Par,
    ) -> Result<(), LdltError> {
        self.factorize_on(Isa::detected(), ws, value, par)
    }

    /// [`factorize`](Self::factorize) by the kernels of `isa`.
    fn factorize_on<T: LdltScalar>(
        &self,
        isa: Isa,
        ws: &mut LdltWorkspace<T>,
        value: impl Fn(usize) -> T,
        par: Par,
    ) -> Result<(), LdltError> {
        let LdltWorkspace {
            values,
            stacks,
            tops,
            frames,
            scaled,
        } = ws;
        *tops = [0; 2];
        frames.iter_mut().for_each(Vec::clear);
        for &s in &self.postorder {
            let (b, w) = (self.begin[s], self.begin[s + 1] - self.begin[s]);
            let r = self.pattern_ptr[s + 1] - self.pattern_ptr[s];
            let m = w + r;
            let panel = &mut values[self.value_ptr[s]..self.value_ptr[s + 1]];
            panel.fill(T::NIL);
            for k in self.scatter_ptr[s]..self.scatter_ptr[s + 1] {
                panel[self.slots[k] as usize] += value(k);
            }
            let (own_stack, child_stack) = own_and_other(stacks, self.odd_depth[s]);
            let (own_frames, child_frames) = own_and_other(frames, self.odd_depth[s]);
            let (own_top, child_top) = own_and_other(tops, self.odd_depth[s]);
            let at = *own_top;
            if own_stack.len() < at + r * r {
                own_stack.resize(at + r * r, T::NIL);
            }
            *own_top = at + r * r;
            let front = &mut own_stack[at..at + r * r];
            // Extend-add: the children's update matrices are the last frames of the other
            // stack. Their columns in the panel go in before it is factored; those in the
            // front after the front is written (not added to) by the panel's update, so the
            // front is never zeroed, and is in cache for them.
            let first_frame = child_frames.len() - self.children[s];
            let stack_top = child_frames.get(first_frame).map_or(*child_top, |f| f.1);
            let children = &child_frames[first_frame..];
            let extend_add = |into_front: bool, panel: &mut [T], front: &mut [T]| {
                for &(c, at) in children {
                    let rc = self.pattern_ptr[c + 1] - self.pattern_ptr[c];
                    let update = &child_stack[at..at + rc * rc];
                    T::extend_add(isa, self, c, update, w, panel, front, into_front);
                }
            };
            extend_add(false, panel, front);
            ldlt_panel(isa, panel, m, 0, w, par).map_err(|k| LdltError::ZeroPivot(b + k))?;
            if r > 0 {
                // U = F_22 − L_21 D L_21ᵀ, lower triangle.
                let scaled = &mut scaled[..r * w];
                for j in 0..w {
                    let d = panel[j * m + j];
                    for (t, &l) in scaled[j * r..(j + 1) * r]
                        .iter_mut()
                        .zip(&panel[j * m + w..(j + 1) * m])
                    {
                        *t = l * d;
                    }
                }
                triangular::matmul(
                    MatMut::from_column_major_slice_mut(front, r, r),
                    BlockStructure::TriangularLower,
                    Accum::Replace,
                    MatRef::from_column_major_slice_with_stride(&panel[w..], r, w, m),
                    BlockStructure::Rectangular,
                    MatRef::from_column_major_slice(scaled, r, w).transpose(),
                    BlockStructure::Rectangular,
                    T::NIL - T::UNIT,
                    par,
                );
                extend_add(true, panel, front);
                own_frames.push((s, at));
            }
            child_frames.truncate(first_frame);
            *child_top = stack_top;
        }
        Ok(())
    }

    /// Adds child `c`'s update matrix (`rc × rc`, its lower triangle read) into its parent's
    /// panel (`m × w`), or, `into_front`, into its front (`r × r`, rows and columns after the
    /// panel's): the update's columns that land there, a run of consecutive places at a time
    /// by the kernels' `add`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn extend_add<T: LdltScalar>(
        &self,
        c: usize,
        update: &[T],
        w: usize,
        panel: &mut [T],
        front: &mut [T],
        into_front: bool,
        kernels: &impl Kernels<T>,
    ) {
        let rel = &self.relative[self.pattern_ptr[c]..self.pattern_ptr[c + 1]];
        let runs = &self.runs[self.run_ptr[c]..self.run_ptr[c + 1]];
        let rc = rel.len();
        let m = panel.len() / w.max(1);
        let r = m - w;
        // The update's columns in the panel come first (`rel` ascends).
        let in_panel = rel.partition_point(|&cj| cj < w);
        let columns = if into_front {
            in_panel..rc
        } else {
            0..in_panel
        };
        let mut run = 0;
        for (jj, &cj) in rel.iter().enumerate().take(columns.end).skip(columns.start) {
            while run + 1 < runs.len() && runs[run + 1] <= jj {
                run += 1;
            }
            let column = &update[jj * rc..(jj + 1) * rc];
            let (target, shift) = if cj < w {
                (&mut panel[cj * m..(cj + 1) * m], 0)
            } else {
                (&mut front[(cj - w) * r..(cj - w + 1) * r], w)
            };
            for k in run..runs.len() {
                let start = runs[k].max(jj);
                let end = runs.get(k + 1).copied().unwrap_or(rc);
                let place = rel[start] - shift;
                kernels.add(&mut target[place..place + end - start], &column[start..end]);
            }
        }
    }

    /// `X ← A⁻¹ X` by the factor in `ws`, for `x` with [`n`](Self::n) rows.
    pub fn solve_in_place<T: LdltScalar>(&self, ws: &LdltWorkspace<T>, x: MatMut<'_, T>) {
        self.solve_in_place_on(Isa::detected(), ws, x)
    }

    /// [`solve_in_place`](Self::solve_in_place) by the kernels of `isa`.
    fn solve_in_place_on<T: LdltScalar>(
        &self,
        isa: Isa,
        ws: &LdltWorkspace<T>,
        mut x: MatMut<'_, T>,
    ) {
        let n = self.n;
        let mut y = vec![T::NIL; n * x.ncols()];
        let mut scratch = vec![T::NIL; self.max_rows + self.max_width];
        for (k, y) in y.chunks_exact_mut(n.max(1)).enumerate() {
            for (new, &old) in self.forward.iter().enumerate() {
                y[new] = x[(old, k)];
            }
        }
        T::solve(isa, self, &ws.values, &mut y, &mut scratch);
        for (k, y) in y.chunks_exact(n.max(1)).enumerate() {
            for (new, &old) in self.forward.iter().enumerate() {
                x[(old, k)] = y[new];
            }
        }
    }

    /// `Y ← (L D Lᵀ)⁻¹ Y` in the factor's order, for the columns of `y` (`n` entries each, one
    /// after another), with `scratch` of `max_rows + max_width` entries. Per
    /// supernode, each column's entries at its rows below the diagonal block are gathered; on
    /// the way down the diagonal block is solved and the gathered rows take the panel's
    /// columns' updates four at a time (`sub_scaled4`), on the way up the panel's columns'
    /// dot products with them are taken four at a time (`dot4`) before the diagonal block is
    /// solved. The columns take their turns within a supernode, so its panel is read from
    /// memory once.
    #[inline(always)]
    fn solve_with<T: LdltScalar>(
        &self,
        values: &[T],
        y: &mut [T],
        scratch: &mut [T],
        kernels: &impl Kernels<T>,
    ) {
        let ns = self.begin.len() - 1;
        let n = self.n.max(1);
        let (gathered, sums) = scratch.split_at_mut(self.max_rows);
        // L z = P b, then D: supernodes in index order are children first. A column whose
        // entries at a supernode are all zero is not changed by it: a right-hand side with one
        // nonzero (an FRF's excitation) reads only the supernodes on its path to the root.
        for s in 0..ns {
            let (b, w, rows) = self.supernode(s);
            let m = w + rows.len();
            let panel = &values[self.value_ptr[s]..self.value_ptr[s + 1]];
            let column = |j: usize| &panel[j * m..(j + 1) * m];
            for y in y.chunks_exact_mut(n) {
                if y[b..b + w].iter().all(|v| *v == T::NIL) {
                    continue;
                }
                let below = &mut gathered[..rows.len()];
                for (t, &i) in below.iter_mut().zip(rows) {
                    *t = y[i];
                }
                for j in 0..w {
                    let (solved, rest) = y[b..b + w].split_at_mut(j + 1);
                    kernels.sub_scaled(rest, &column(j)[j + 1..w], solved[j]);
                }
                let quads = w / 4 * 4;
                for j in (0..quads).step_by(4) {
                    let v = [j, j + 1, j + 2, j + 3].map(|j| &column(j)[w..]);
                    kernels.sub_scaled4(below, v, [0, 1, 2, 3].map(|k| y[b + j + k]));
                }
                for j in quads..w {
                    kernels.sub_scaled(below, &column(j)[w..], y[b + j]);
                }
                for (&t, &i) in below.iter().zip(rows) {
                    y[i] = t;
                }
                for j in 0..w {
                    y[b + j] /= panel[j * m + j];
                }
            }
        }
        // Then Lᵀ, parents first.
        for s in (0..ns).rev() {
            let (b, w, rows) = self.supernode(s);
            let m = w + rows.len();
            let panel = &values[self.value_ptr[s]..self.value_ptr[s + 1]];
            let column = |j: usize| &panel[j * m..(j + 1) * m];
            for y in y.chunks_exact_mut(n) {
                let below = &mut gathered[..rows.len()];
                for (t, &i) in below.iter_mut().zip(rows) {
                    *t = y[i];
                }
                let sums = &mut sums[..w];
                let quads = w / 4 * 4;
                for j in (0..quads).step_by(4) {
                    let v = [j, j + 1, j + 2, j + 3].map(|j| &column(j)[w..]);
                    sums[j..j + 4].copy_from_slice(&kernels.dot4(v, below));
                }
                for (j, sum) in sums.iter_mut().enumerate().skip(quads) {
                    *sum = kernels.dot(&column(j)[w..], below);
                }
                for j in (0..w).rev() {
                    let (open, solved) = y[b..b + w].split_at_mut(j + 1);
                    open[j] -= sums[j] + kernels.dot(&column(j)[j + 1..w], solved);
                }
            }
        }
    }

    /// First column, width and rows below the diagonal block of supernode `s`.
    fn supernode(&self, s: usize) -> (usize, usize, &[usize]) {
        (
            self.begin[s],
            self.begin[s + 1] - self.begin[s],
            &self.pattern[self.pattern_ptr[s]..self.pattern_ptr[s + 1]],
        )
    }
}

/// `LDLᵀ` in place of columns `c0..c0 + w` of the column-major panel `a` (leading dimension
/// `ld`), rows `c0..ld`: the diagonal block's lower triangle becomes `L` (unit diagonal, not
/// stored) with `D` on the diagonal, the rows below become `L_21`. Columns past `BLOCK` are
/// split in two: the right half is updated by one matrix product with the left half's factor
/// (`A_22 −= L_21 D_1 L_21ᵀ`, full columns below), then factored. Returns the offending column
/// (relative to `c0`) on a zero or non-finite pivot.
fn ldlt_panel<T: LdltScalar>(
    isa: Isa,
    a: &mut [T],
    ld: usize,
    c0: usize,
    w: usize,
    par: Par,
) -> Result<(), usize> {
    if w <= BLOCK {
        return T::unblocked(isa, a, ld, c0, w);
    }
    let m = ld - c0;
    let w1 = (w / 2).div_ceil(BLOCK) * BLOCK;
    let w2 = w - w1;
    ldlt_panel(isa, a, ld, c0, w1, par)?;
    let (left, right) = a.split_at_mut((c0 + w1) * ld);
    let left = &left[c0 * ld..];
    // L_21 D_1 for the rows of the right half's diagonal block.
    let scaled = faer::Mat::<T>::from_fn(w2, w1, |i, j| {
        left[j * ld + c0 + w1 + i] * left[j * ld + c0 + j]
    });
    matmul(
        MatMut::from_column_major_slice_with_stride_mut(&mut right[c0 + w1..], m - w1, w2, ld),
        Accum::Add,
        MatRef::from_column_major_slice_with_stride(&left[c0 + w1..], m - w1, w1, ld),
        scaled.transpose(),
        T::NIL - T::UNIT,
        par,
    );
    ldlt_panel(isa, a, ld, c0 + w1, w2, par).map_err(|k| k + w1)
}

/// The unblocked left-looking `LDLᵀ` of [`ldlt_panel`]'s columns `c0..c0 + w` (at most
/// [`BLOCK`]): each column, every row below included, first takes the updates of the panel's
/// factored columns before it, `a_j −= Σ_k L_k (d_k L_jk)` (the kernels' `sub_product`: `a_j`
/// is read and written once), then is divided by its pivot.
#[inline(always)]
fn unblocked_ldlt<T: LdltScalar>(
    a: &mut [T],
    ld: usize,
    c0: usize,
    w: usize,
    kernels: &impl Kernels<T>,
) -> Result<(), usize> {
    let mut scalars = [T::NIL; BLOCK];
    for j in 0..w {
        let (done, rest) = a.split_at_mut((c0 + j) * ld);
        let target = &mut rest[c0 + j..ld];
        // `d_k L_jk` of the columns before, and their rows `c0 + j..` (leading dimension `ld`).
        for (k, l) in scalars[..j].iter_mut().enumerate() {
            let column = (c0 + k) * ld + c0;
            *l = done[column + j] * done[column + k];
        }
        if j > 0 {
            kernels.sub_product(target, &done[c0 * ld + c0 + j..], ld, &scalars[..j]);
        }
        let d = target[0];
        if d == T::NIL || !d.finite() {
            return Err(j);
        }
        let inv = T::UNIT / d;
        for v in &mut target[1..] {
            *v *= inv;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// The lower triangle of a complex symmetric `A` in two real parts, as the scatter takes it.
    fn lower_pattern(n: usize, entries: &[(usize, usize)]) -> SparseMatrix {
        let t: Vec<(usize, usize, f64)> = entries.iter().map(|&(i, j)| (i, j, 1.0)).collect();
        crate::core::sparse::sparse_from_triplets("A", n, &t).unwrap()
    }

    /// `A = L D Lᵀ` of complex symmetric matrices — a 3-D grid with complex indefinite
    /// diagonal (wide supernodes at the top of the tree, split by the blocked kernel), a dense
    /// matrix (one supernode) and a diagonal one (no updates) — solves against the dense
    /// product to round-off, on every instruction set the machine has (the plain loops, AVX2,
    /// AVX-512), with one thread and two giving the same numbers bit for bit.
    #[test]
    fn complex_symmetric_solves_leave_round_off() {
        solves_leave_round_off(
            |i, j| {
                if i == j {
                    c64::new(3.0 - (i % 5) as f64, 0.3 + 0.01 * (i % 3) as f64)
                } else {
                    c64::new(-0.4 - 0.01 * ((i + j) % 4) as f64, 0.05)
                }
            },
            |i, k| c64::new((i * 7 + k) as f64 % 5.0, 1.0),
        );
    }

    /// The same in real arithmetic (the Krylov sweep's expansion points): a symmetric
    /// indefinite matrix, no pivoting.
    #[test]
    fn real_symmetric_solves_leave_round_off() {
        solves_leave_round_off(
            |i, j| {
                if i == j {
                    3.3 - (i % 5) as f64
                } else {
                    -0.4 - 0.01 * ((i + j) % 4) as f64
                }
            },
            |i, k| (i * 7 + k) as f64 % 5.0 - 2.0,
        );
    }

    /// The solves of [`complex_symmetric_solves_leave_round_off`] with entries `entry(i, j)`
    /// and right-hand sides `rhs(i, k)`.
    fn solves_leave_round_off<T>(entry: impl Fn(usize, usize) -> T, rhs: impl Fn(usize, usize) -> T)
    where
        T: LdltScalar + faer::traits::ComplexField<Real = f64> + std::fmt::Debug,
    {
        let g = 9;
        let node = |i: usize, j: usize, k: usize| (i * g + j) * g + k;
        let mut grid = Vec::new();
        for i in 0..g {
            for j in 0..g {
                for k in 0..g {
                    grid.push((node(i, j, k), node(i, j, k)));
                    for (a, b, c) in [(i + 1, j, k), (i, j + 1, k), (i, j, k + 1)] {
                        if a < g && b < g && c < g {
                            grid.push((node(a, b, c), node(i, j, k)));
                        }
                    }
                }
            }
        }
        let dense: Vec<(usize, usize)> =
            (0..60).flat_map(|j| (j..60).map(move |i| (i, j))).collect();
        let diagonal: Vec<(usize, usize)> = (0..7).map(|j| (j, j)).collect();
        for (n, entries) in [(g * g * g, grid), (60, dense), (7, diagonal)] {
            let lower = lower_pattern(n, &entries);
            let sym = SymbolicLdlt::new(&lower).unwrap();
            // Values in the stored order of `lower`.
            let mut stored = Vec::new();
            for j in 0..n {
                for &i in lower.row_idx_of_col_raw(j) {
                    stored.push((i, j));
                }
            }
            let value = |e: usize| entry(stored[e].0, stored[e].1);
            let mut a = Mat::<T>::zeros(n, n);
            for (e, &(i, j)) in stored.iter().enumerate() {
                a[(i, j)] = value(e);
                a[(j, i)] = value(e);
            }
            let b = Mat::from_fn(n, 3, &rhs);
            let ordered = sym.in_factor_order(&(0..stored.len()).collect::<Vec<_>>());
            // Every instruction set this machine has, the plain loops included.
            for level in [Level::Plain, Level::Avx2, Level::Avx512] {
                let isa = Isa::detected().at_most(level);
                let mut results = Vec::new();
                for par in [Par::Seq, Par::rayon(2)] {
                    let mut ws = sym.workspace();
                    sym.factorize_on(isa, &mut ws, |k| value(ordered[k]), par)
                        .unwrap();
                    let mut x = b.clone();
                    sym.solve_in_place_on(isa, &ws, x.as_mut());
                    let r = &a * &x - &b;
                    assert!(
                        r.norm_max() < 1e-12 * a.norm_max() * x.norm_max(),
                        "{n} {isa:?}: {}",
                        r.norm_max()
                    );
                    results.push(x);
                }
                assert_eq!(results[0], results[1]);
            }
        }
    }

    /// A zero pivot is reported, not divided by.
    #[test]
    fn a_zero_pivot_is_reported() {
        let lower = lower_pattern(2, &[(0, 0), (1, 0), (1, 1)]);
        let sym = SymbolicLdlt::new(&lower).unwrap();
        let mut ws = sym.workspace();
        let e = sym.factorize(&mut ws, |_| c64::ZERO, Par::Seq).unwrap_err();
        assert!(matches!(e, LdltError::ZeroPivot(_)));
    }
}
