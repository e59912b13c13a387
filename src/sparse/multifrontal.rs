//! Numeric sparse Cholesky and its triangular solves by the multifrontal method, on faer's
//! supernodal structure.
//!
//! faer's own numeric factorisation is left-looking: every supernode gathers one scattered
//! product per descendant that updates it, with inner dimensions as narrow as a descendant's
//! width, and walks the supernodes one after another. On shell models that reaches only a
//! fraction of the machine's dense speed. Here each supernode instead forms its frontal matrix
//! once:
//!
//! 1. its columns of `P A Pᵀ` and its children's update matrices, as far as they fall in its
//!    columns, are added into the panel `[L_11; L_21]` (which is the factor's own storage);
//! 2. `L_11 L_11ᵀ = F_11`, `L_21 = F_21 L_11⁻ᵀ`, and `U = −L_21 L_21ᵀ` — one dense Cholesky, one
//!    triangular solve and one symmetric rank-`w` product as wide as the supernode;
//! 3. the rest of the children's update matrices is added into `U`, which is handed to the
//!    parent.
//!
//! Independent subtrees of the elimination tree run in parallel, and fronts large enough for it
//! also split their dense kernels over the threads. The values land in faer's supernodal layout
//! (faer's own solve reads them in the tests). The solves also run multifrontal, so each entry
//! of the factor is read once per pass over the right-hand sides rather than once per thread.

use super::layout::{from_row_major, to_row_major};
use super::thin;
use crate::core::sparse::SparseMatrix;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::matmul::triangular::{BlockStructure, matmul};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, MatMut, Par};
use rayon::prelude::*;

/// Why a numeric factorisation stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrontError {
    /// A pivot was not positive.
    NotPositiveDefinite,
    /// A frontal matrix could not be allocated.
    OutOfMemory,
}

/// A subtree is split among the threads only above this many flops (about 20 ms of work).
const PARALLEL_SUBTREE_FLOPS: f64 = 2e8;
/// A front's dense kernels are split among the threads above this many flops.
const PARALLEL_FRONT_FLOPS: f64 = 5e7;
/// Tree parallelism stops this many levels down; deeper subtrees run one after another.
const MAX_PARALLEL_DEPTH: usize = 256;
/// A large front's panel is zeroed by all threads above this many entries.
const PARALLEL_FILL_ENTRIES: usize = 1 << 18;

/// The lower triangle of `P A Pᵀ` in compressed columns, rows sorted: the entries a supernode
/// adds to its front.
pub struct PermutedLower {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
}

impl PermutedLower {
    /// `inverse[old] = new`. Entries of `a` above its diagonal are not read.
    pub fn new(a: &SparseMatrix, inverse: Option<&[usize]>) -> Result<Self, FrontError> {
        let n = a.ncols();
        let new = |i: usize| inverse.map_or(i, |p| p[i]);
        let mut counts = vec![0usize; n + 1];
        for oj in 0..n {
            for &oi in a.row_idx_of_col_raw(oj) {
                if oi >= oj {
                    counts[new(oi).min(new(oj)) + 1] += 1;
                }
            }
        }
        for j in 0..n {
            counts[j + 1] += counts[j];
        }
        let nnz = counts[n];
        let mut row_idx = Vec::new();
        let mut values = Vec::new();
        row_idx
            .try_reserve_exact(nnz)
            .map_err(|_| FrontError::OutOfMemory)?;
        values
            .try_reserve_exact(nnz)
            .map_err(|_| FrontError::OutOfMemory)?;
        row_idx.resize(nnz, 0);
        values.resize(nnz, 0.0);
        let mut next = counts.clone();
        for oj in 0..n {
            for (&oi, &v) in a.row_idx_of_col_raw(oj).iter().zip(a.val_of_col(oj)) {
                if oi >= oj {
                    let (i, j) = (new(oi), new(oj));
                    let (row, col) = (i.max(j), i.min(j));
                    row_idx[next[col]] = row;
                    values[next[col]] = v;
                    next[col] += 1;
                }
            }
        }
        let mut pairs = Vec::new();
        for j in 0..n {
            let range = counts[j]..counts[j + 1];
            if row_idx[range.clone()].is_sorted() {
                continue;
            }
            pairs.clear();
            pairs.extend(
                row_idx[range.clone()]
                    .iter()
                    .copied()
                    .zip(values[range.clone()].iter().copied()),
            );
            pairs.sort_unstable_by_key(|p| p.0);
            for (k, (i, v)) in range.zip(&pairs) {
                row_idx[k] = *i;
                values[k] = *v;
            }
        }
        Ok(PermutedLower {
            col_ptr: counts,
            row_idx,
            values,
        })
    }
}

/// The supernodal elimination tree and what each subtree costs.
pub struct Tree {
    /// Children of supernode `s`: `child_idx[child_ptr[s]..child_ptr[s + 1]]`, ascending.
    child_ptr: Vec<usize>,
    child_idx: Vec<usize>,
    /// First supernode of the subtree rooted at `s`.
    first: Vec<usize>,
    /// Flops of the subtree rooted at `s`.
    subtree_flops: Vec<f64>,
    /// Stored entries of the factor in the subtree rooted at `s` (the work of a solve).
    subtree_entries: Vec<f64>,
    /// Supernodes without a parent, ascending.
    roots: Vec<usize>,
    /// Whether every subtree is the contiguous range `first[s]..=s` (a postorder).
    postordered: bool,
}

impl Tree {
    /// The tree of `symbolic`'s supernodes.
    pub fn new(symbolic: &SymbolicSupernodalCholesky<usize>) -> Self {
        let ns = symbolic.n_supernodes();
        let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
        let mut column_owner = vec![0usize; symbolic.nrows()];
        for s in 0..ns {
            column_owner[begin[s]..end[s]].fill(s);
        }
        // A supernode's parent owns the first row below its diagonal block.
        let parent: Vec<Option<usize>> = (0..ns)
            .map(|s| {
                symbolic
                    .supernode(s)
                    .pattern()
                    .first()
                    .map(|&i| column_owner[i])
            })
            .collect();
        let mut child_ptr = vec![0usize; ns + 1];
        for p in parent.iter().flatten() {
            child_ptr[p + 1] += 1;
        }
        for s in 0..ns {
            child_ptr[s + 1] += child_ptr[s];
        }
        let mut child_idx = vec![0usize; child_ptr[ns]];
        let mut next = child_ptr.clone();
        for (s, p) in parent.iter().enumerate() {
            if let Some(p) = *p {
                child_idx[next[p]] = s;
                next[p] += 1;
            }
        }
        let mut first: Vec<usize> = (0..ns).collect();
        let mut size = vec![1usize; ns];
        let mut subtree_flops: Vec<f64> = (0..ns).map(|s| front_flops(symbolic, s)).collect();
        let col_ptr_val = symbolic.col_ptr_for_val();
        let mut subtree_entries: Vec<f64> = (0..ns)
            .map(|s| (col_ptr_val[s + 1] - col_ptr_val[s]) as f64)
            .collect();
        // Children precede parents, so one ascending sweep completes every subtree.
        for s in 0..ns {
            if let Some(p) = parent[s] {
                first[p] = first[p].min(first[s]);
                size[p] += size[s];
                subtree_flops[p] += subtree_flops[s];
                subtree_entries[p] += subtree_entries[s];
            }
        }
        let postordered = (0..ns).all(|s| s + 1 - first[s] == size[s]);
        let roots = (0..ns).filter(|&s| parent[s].is_none()).collect();
        Tree {
            child_ptr,
            child_idx,
            first,
            subtree_flops,
            subtree_entries,
            roots,
            postordered,
        }
    }

    /// Whether every subtree's supernodes are numbered contiguously, ending at its root (the
    /// parallel factorisation and solves need it).
    pub fn is_postordered(&self) -> bool {
        self.postordered
    }

    /// The supernodes in a postorder: each subtree contiguous, children in their order, then
    /// the root.
    pub fn postorder(&self) -> Vec<usize> {
        let mut order = Vec::with_capacity(self.first.len());
        // (supernode, children visited so far)
        let mut stack: Vec<(usize, usize)> = self.roots.iter().rev().map(|&r| (r, 0)).collect();
        while let Some((s, visited)) = stack.pop() {
            let children = self.children(s);
            if visited < children.len() {
                stack.push((s, visited + 1));
                stack.push((children[visited], 0));
            } else {
                order.push(s);
            }
        }
        order
    }

    fn children(&self, s: usize) -> &[usize] {
        &self.child_idx[self.child_ptr[s]..self.child_ptr[s + 1]]
    }

    /// The subtrees of `s`'s children, with their shares of `items` (one per supernode of
    /// `first[s]..s`, in order).
    fn split_children<'s, T>(&self, s: usize, items: &'s mut [T]) -> Vec<(usize, &'s mut [T])> {
        let mut parts = Vec::with_capacity(self.children(s).len());
        let mut remaining = items;
        for &c in self.children(s) {
            let (head, tail) = remaining.split_at_mut(c + 1 - self.first[c]);
            parts.push((c, head));
            remaining = tail;
        }
        parts
    }

    /// The roots' subtrees with their shares of `items` (one per supernode, in order).
    fn split_roots<'s, T>(&self, items: &'s mut [T]) -> Vec<(usize, &'s mut [T])> {
        let mut parts = Vec::with_capacity(self.roots.len());
        let mut remaining = items;
        for &root in &self.roots {
            let (head, tail) = remaining.split_at_mut(root + 1 - self.first[root]);
            parts.push((root, head));
            remaining = tail;
        }
        parts
    }
}

/// Positions in the front of supernode `s` (its columns, then its pattern) of `rows`, rows of
/// a child's pattern (both sorted, and every row present).
fn local_positions(
    symbolic: &SymbolicSupernodalCholesky<usize>,
    s: usize,
    rows: &[usize],
    local: &mut Vec<usize>,
) {
    let (b, e) = (symbolic.supernode_begin()[s], symbolic.supernode_end()[s]);
    let pattern = symbolic.supernode(s).pattern();
    let w = e - b;
    local.clear();
    let mut p = 0;
    for &i in rows {
        local.push(if i < e {
            i - b
        } else {
            while pattern[p] < i {
                p += 1;
            }
            w + p
        });
    }
}

/// Flops of one front: Cholesky of the `w × w` block, the `r × w` triangular solve and the
/// rank-`w` update of the `r × r` triangle.
fn front_flops(symbolic: &SymbolicSupernodalCholesky<usize>, s: usize) -> f64 {
    let w = (symbolic.supernode_end()[s] - symbolic.supernode_begin()[s]) as f64;
    let r = symbolic.supernode(s).pattern().len() as f64;
    w * w * w / 3.0 + w * w * r + w * r * r
}

/// Fills `values` (faer's supernodal layout for `symbolic`) with the Cholesky factor of
/// `P A Pᵀ`, given as `lower`. With `par` of one thread every front is factored on this
/// thread; otherwise independent subtrees share the pool and large fronts split `par` ways.
pub fn factorize(
    symbolic: &SymbolicSupernodalCholesky<usize>,
    tree: &Tree,
    lower: &PermutedLower,
    values: &mut [f64],
    par: Par,
) -> Result<(), FrontError> {
    let ns = symbolic.n_supernodes();
    let col_ptr_val = symbolic.col_ptr_for_val();
    let mut slots: Vec<&mut [f64]> = Vec::with_capacity(ns);
    let mut rest = values;
    for s in 0..ns {
        let (head, tail) = rest.split_at_mut(col_ptr_val[s + 1] - col_ptr_val[s]);
        slots.push(head);
        rest = tail;
    }
    let ctx = Context {
        symbolic,
        tree,
        lower,
        par,
    };
    if !tree.postordered {
        ctx.range(0, ns, &mut slots)?;
        return Ok(());
    }
    let roots = tree.split_roots(&mut slots);
    let root = |(root, slots): (usize, &mut [&mut [f64]])| ctx.subtree(root, slots, 0).map(drop);
    if par.degree() > 1 {
        roots.into_par_iter().try_for_each(root)
    } else {
        roots.into_iter().try_for_each(root)
    }
}

struct Context<'a> {
    symbolic: &'a SymbolicSupernodalCholesky<usize>,
    tree: &'a Tree,
    lower: &'a PermutedLower,
    /// The parallelism of the whole factorisation.
    par: Par,
}

/// The update matrix a supernode hands to its parent: `r × r`, column-major, lower triangle.
type Update = Vec<f64>;

impl Context<'_> {
    /// Factors the subtree rooted at `s`; `slots` are the panels of `first[s]..=s`.
    fn subtree(
        &self,
        s: usize,
        slots: &mut [&mut [f64]],
        depth: usize,
    ) -> Result<Update, FrontError> {
        let tree = self.tree;
        if depth >= MAX_PARALLEL_DEPTH || tree.subtree_flops[s] < PARALLEL_SUBTREE_FLOPS {
            return self.range(tree.first[s], s + 1, slots);
        }
        let (own, below) = slots.split_last_mut().expect("a subtree holds its root");
        let parts = tree.split_children(s, below);
        let heavy = tree
            .children(s)
            .iter()
            .filter(|&&c| tree.subtree_flops[c] >= PARALLEL_SUBTREE_FLOPS)
            .count();
        let child = |(c, slots): (usize, &mut [&mut [f64]])| {
            self.subtree(c, slots, depth + 1).map(|u| (c, u))
        };
        // Light children go straight to `range`; one heavy child continues the descent.
        let updates: Vec<(usize, Update)> = if heavy >= 2 && self.par.degree() > 1 {
            parts.into_par_iter().map(child).collect::<Result<_, _>>()?
        } else {
            parts.into_iter().map(child).collect::<Result<_, _>>()?
        };
        self.front(s, own, updates)
    }

    /// Factors supernodes `lo..hi` in order (children before parents); `slots` are their panels.
    /// Returns the update matrix of the last one, the range's root.
    fn range(&self, lo: usize, hi: usize, slots: &mut [&mut [f64]]) -> Result<Update, FrontError> {
        let mut pending: Vec<Option<Update>> = vec![None; hi - lo];
        for (k, s) in (lo..hi).enumerate() {
            let updates = self
                .tree
                .children(s)
                .iter()
                .filter(|&&c| c >= lo)
                .map(|&c| {
                    let update = pending[c - lo].take();
                    (
                        c,
                        update.expect("children are factored before their parent"),
                    )
                })
                .collect();
            pending[k] = Some(self.front(s, slots[k], updates)?);
        }
        Ok(pending.pop().flatten().unwrap_or_default())
    }

    /// Assembles, factors and condenses the front of supernode `s` into its panel; returns its
    /// update matrix.
    fn front(
        &self,
        s: usize,
        panel: &mut [f64],
        children: Vec<(usize, Update)>,
    ) -> Result<Update, FrontError> {
        let symbolic = self.symbolic;
        let (b, e) = (symbolic.supernode_begin()[s], symbolic.supernode_end()[s]);
        let pattern = symbolic.supernode(s).pattern();
        let (w, r) = (e - b, pattern.len());
        let nr = w + r;
        let par = if front_flops(symbolic, s) >= PARALLEL_FRONT_FLOPS {
            self.par
        } else {
            Par::Seq
        };
        // A large front's panel is zeroed by all threads: its pages are first touched here,
        // and that costs more than the zeroing itself, too much for one thread on large
        // models.
        if par == Par::Seq || panel.len() < PARALLEL_FILL_ENTRIES {
            panel.fill(0.0);
        } else {
            panel
                .par_chunks_mut(PARALLEL_FILL_ENTRIES / 4)
                .for_each(|chunk| chunk.fill(0.0));
        }
        // Columns of P A Pᵀ: rows inside the block, then below it (both sorted).
        let lower = self.lower;
        for j in b..e {
            let column = &mut panel[(j - b) * nr..(j - b + 1) * nr];
            let mut p = 0;
            let range = lower.col_ptr[j]..lower.col_ptr[j + 1];
            for (&i, &v) in lower.row_idx[range.clone()]
                .iter()
                .zip(&lower.values[range])
            {
                let local = if i < e {
                    i - b
                } else {
                    while pattern[p] < i {
                        p += 1;
                    }
                    w + p
                };
                column[local] += v;
            }
        }
        // The children's update matrices: first the columns that fall in the panel; the rest
        // are added to the update matrix once it holds `−L_21 L_21ᵀ`.
        let children: Vec<(Update, Vec<usize>)> = children
            .into_iter()
            .map(|(c, child)| {
                let mut local = Vec::new();
                local_positions(symbolic, s, symbolic.supernode(c).pattern(), &mut local);
                (child, local)
            })
            .collect();
        for (child, local) in &children {
            let rc = local.len();
            for (jj, &t) in local.iter().enumerate().take_while(|(_, t)| **t < w) {
                let source = &child[jj * rc + jj..(jj + 1) * rc];
                let column = &mut panel[t * nr..(t + 1) * nr];
                for (&li, &v) in local[jj..].iter().zip(source) {
                    column[li] += v;
                }
            }
        }
        let ls = MatMut::from_column_major_slice_mut(panel, nr, w);
        let (mut top, mut bottom) = ls.split_at_row_mut(w);
        let mut buffer =
            MemBuffer::try_new(cholesky_in_place_scratch::<f64>(w, par, Default::default()))
                .map_err(|_| FrontError::OutOfMemory)?;
        cholesky_in_place(
            top.as_mut(),
            Default::default(),
            par,
            MemStack::new(&mut buffer),
            Default::default(),
        )
        .map_err(|_| FrontError::NotPositiveDefinite)?;
        if r == 0 {
            return Ok(Update::new());
        }
        solve_lower_triangular_in_place(top.as_ref(), bottom.as_mut().transpose_mut(), par);
        // `U = −L_21 L_21ᵀ`, written (not added) into zeroed storage: fresh pages are first
        // touched by the product's threads, and those of the strict upper triangle, which is
        // never written, not at all.
        let mut update = crate::core::memory::zeroed_f64(r * r).ok_or(FrontError::OutOfMemory)?;
        matmul(
            MatMut::from_column_major_slice_mut(&mut update, r, r),
            BlockStructure::TriangularLower,
            Accum::Replace,
            bottom.as_ref(),
            BlockStructure::Rectangular,
            bottom.as_ref().transpose(),
            BlockStructure::Rectangular,
            -1.0,
            par,
        );
        for (child, local) in &children {
            let rc = local.len();
            for (jj, &t) in local.iter().enumerate().skip_while(|(_, t)| **t < w) {
                let source = &child[jj * rc + jj..(jj + 1) * rc];
                let column = &mut update[(t - w) * r..(t - w + 1) * r];
                for (&li, &v) in local[jj..].iter().zip(source) {
                    column[li - w] += v;
                }
            }
        }
        Ok(update)
    }
}

/// A subtree's triangular solves run on their own thread above this many factor entries
/// (16 MB of factor, a few milliseconds of reading).
const PARALLEL_SOLVE_ENTRIES: f64 = 2e6;

/// A front with this many entries (`w (w + r)`) splits its solve kernels over the threads,
/// when no sibling subtree holds them: 8 MB of factor, a millisecond of work per pass, far
/// above the cost of a split.
const PARALLEL_FRONT_SOLVE_ENTRIES: usize = 1 << 20;

/// The parallelism of one front's solve kernels: `par` for a large front, else one thread.
fn front_par(w: usize, r: usize, par: Par) -> Par {
    if w * (w + r) >= PARALLEL_FRONT_SOLVE_ENTRIES {
        par
    } else {
        Par::Seq
    }
}

/// Which triangular sweeps a solve makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sweeps {
    /// `X ← (P L Lᵀ Pᵀ)⁻¹ X`.
    Both,
    /// `X ← L⁻¹ Pᵀ X`: the result in the factor's order.
    Forward,
    /// `X ← P L⁻ᵀ X`: `X` given in the factor's order.
    Backward,
}

/// `X ← (P L Lᵀ Pᵀ)⁻¹ X` for the factor in `values`, or one of its two sweeps (`sweeps`);
/// `permutation` is the ordering as `(forward, inverse)`, `forward[new] = old`.
///
/// The solves are multifrontal too, so independent subtrees run on separate threads and each
/// entry of the factor is read once per pass for all columns. Forward, a supernode solves
/// `L_11 y = b` for its own rows and hands `−L_21 y` to its parent; backward, it receives
/// `x` at its pattern's rows from its parent, solves `L_11ᵀ x = y − L_21ᵀ x_pattern`, and hands
/// each child the rows of its own pattern. Columns are taken at most `k` at a time, in passes
/// of equal width (50 columns with `k = 16`: four of 13, not three of 16 and one of 2), in a
/// row-major work array, so a row's values are contiguous for the gathers and scatters. Up to
/// 16 columns, the fronts use [`thin`]'s kernels, which read each panel column once, front to
/// back (rows padded to a multiple of four); wider passes use faer's. With `par` of one
/// thread the whole solve runs on this thread.
#[allow(clippy::too_many_arguments)]
pub fn solve(
    symbolic: &SymbolicSupernodalCholesky<usize>,
    tree: &Tree,
    permutation: Option<(&[usize], &[usize])>,
    values: &[f64],
    x: MatMut<'_, f64>,
    k: usize,
    sweeps: Sweeps,
    par: Par,
) {
    let parallel = par.degree() > 1;
    let (n, ns) = (symbolic.nrows(), symbolic.n_supernodes());
    let col_ptr_val = symbolic.col_ptr_for_val();
    let panels: Vec<&[f64]> = (0..ns)
        .map(|s| &values[col_ptr_val[s]..col_ptr_val[s + 1]])
        .collect();
    let begin = symbolic.supernode_begin();
    let mut x = x;
    let (mut work, mut natural) = (Vec::new(), Vec::new());
    let passes = x.ncols().div_ceil(k.max(1));
    let width = x.ncols().div_ceil(passes.max(1));
    for c0 in (0..x.ncols()).step_by(width.max(1)) {
        let columns = width.min(x.ncols() - c0);
        // The thin kernels take rows of 4, 8, 12 or 16 values: the rows are padded with
        // zero columns, which stay zero.
        let thin = columns <= thin::MAX_COLUMNS && thin::available();
        let kc = if thin {
            columns.next_multiple_of(4)
        } else {
            columns
        };
        // Rows in the factor's order: row `i` of the work is row `forward[i]` of `X`. A
        // second array is held only while rows are permuted.
        work.clear();
        work.resize(n * kc, 0.0);
        match permutation.filter(|_| sweeps != Sweeps::Backward) {
            Some((forward, _)) => {
                natural.clear();
                natural.resize(n * kc, 0.0);
                to_row_major(x.as_ref().subcols(c0, columns), &mut natural, par);
                permute_rows(&mut work, &natural, forward, kc, parallel);
            }
            None => to_row_major(x.as_ref().subcols(c0, columns), &mut work, par),
        }
        let mut rows: Vec<&mut [f64]> = Vec::with_capacity(ns);
        let mut rest = work.as_mut_slice();
        for (b, e) in begin.iter().zip(symbolic.supernode_end()) {
            let (head, tail) = rest.split_at_mut((e - b) * kc);
            rows.push(head);
            rest = tail;
        }
        let ctx = SolveContext {
            symbolic,
            tree,
            panels: &panels,
            k: kc,
            thin,
            parallel,
        };
        ctx.sweep(&mut rows, sweeps, par);
        drop(rows);
        match permutation.filter(|_| sweeps != Sweeps::Forward) {
            Some((_, inverse)) => {
                natural.clear();
                natural.resize(n * kc, 0.0);
                permute_rows(&mut natural, &work, inverse, kc, parallel);
                from_row_major(&natural, x.as_mut().subcols_mut(c0, columns), par);
            }
            None => from_row_major(&work, x.as_mut().subcols_mut(c0, columns), par),
        }
    }
}

/// `out`'s row `i` becomes `from`'s row `order[i]`, rows of `k` values; on the pool's threads
/// when `parallel`.
fn permute_rows(out: &mut [f64], from: &[f64], order: &[usize], k: usize, parallel: bool) {
    let copy = |(row, &i): (&mut [f64], &usize)| row.copy_from_slice(&from[i * k..(i + 1) * k]);
    if parallel {
        out.par_chunks_exact_mut(k)
            .zip(order.par_iter())
            .with_min_len(4096)
            .for_each(copy);
    } else {
        out.chunks_exact_mut(k).zip(order).for_each(copy);
    }
}

struct SolveContext<'a> {
    symbolic: &'a SymbolicSupernodalCholesky<usize>,
    tree: &'a Tree,
    panels: &'a [&'a [f64]],
    k: usize,
    /// Whether the fronts use [`thin`]'s kernels (this machine has them, `k` is small enough).
    thin: bool,
    /// Whether independent subtrees may run on separate threads.
    parallel: bool,
}

/// What one supernode hands to another during a solve: `r × k`, row-major.
type Rows = Vec<f64>;

impl SolveContext<'_> {
    /// The forward and/or backward sweep over every supernode; `rows` holds each one's rows
    /// of the work array. Independent root subtrees run on separate threads when `parallel`;
    /// a lone root chain has the threads to itself, and its large fronts split their dense
    /// kernels `par` ways.
    fn sweep(&self, rows: &mut [&mut [f64]], sweeps: Sweeps, par: Par) {
        let tree = self.tree;
        let par = if tree.roots.len() == 1 || !tree.postordered {
            par
        } else {
            Par::Seq
        };
        let (forward, backward) = (sweeps != Sweeps::Backward, sweeps != Sweeps::Forward);
        if !tree.postordered {
            let ns = rows.len();
            if forward {
                self.forward_range(0, ns, rows, par);
            }
            if backward {
                let roots = tree.roots.iter().map(|&r| (r, Vec::new()));
                self.backward_range(0, ns, rows, roots.collect(), par);
            }
            return;
        }
        if forward {
            let root = |(root, rows): (usize, &mut [&mut [f64]])| {
                self.forward_subtree(root, rows, 0, par);
            };
            let roots = tree.split_roots(rows);
            if self.parallel {
                roots.into_par_iter().for_each(root);
            } else {
                roots.into_iter().for_each(root);
            }
        }
        if backward {
            let root = |(root, rows): (usize, &mut [&mut [f64]])| {
                self.backward_subtree(root, rows, Vec::new(), 0, par);
            };
            let roots = tree.split_roots(rows);
            if self.parallel {
                roots.into_par_iter().for_each(root);
            } else {
                roots.into_iter().for_each(root);
            }
        }
    }

    /// `[L_11; L_21]` of supernode `s` and its width.
    fn panel(&self, s: usize) -> (faer::MatRef<'_, f64>, faer::MatRef<'_, f64>) {
        let w = self.symbolic.supernode_end()[s] - self.symbolic.supernode_begin()[s];
        let r = self.symbolic.supernode(s).pattern().len();
        faer::MatRef::from_column_major_slice(self.panels[s], w + r, w).split_at_row(w)
    }

    /// Solves the subtree rooted at `s` forward; `par` is what its fronts may use (the
    /// threads when no sibling subtree runs beside it).
    fn forward_subtree(&self, s: usize, rows: &mut [&mut [f64]], depth: usize, par: Par) -> Rows {
        let tree = self.tree;
        if depth >= MAX_PARALLEL_DEPTH || tree.subtree_entries[s] < PARALLEL_SOLVE_ENTRIES {
            return self.forward_range(tree.first[s], s + 1, rows, par);
        }
        let (own, below) = rows.split_last_mut().expect("a subtree holds its root");
        let parts = tree.split_children(s, below);
        let heavy = tree
            .children(s)
            .iter()
            .filter(|&&c| tree.subtree_entries[c] >= PARALLEL_SOLVE_ENTRIES)
            .count();
        let child = |par| {
            move |(c, rows): (usize, &mut [&mut [f64]])| {
                (c, self.forward_subtree(c, rows, depth + 1, par))
            }
        };
        let updates: Vec<(usize, Rows)> = if heavy >= 2 && self.parallel {
            parts.into_par_iter().map(child(Par::Seq)).collect()
        } else {
            parts.into_iter().map(child(par)).collect()
        };
        self.forward_front(s, own, updates, par)
    }

    fn forward_range(&self, lo: usize, hi: usize, rows: &mut [&mut [f64]], par: Par) -> Rows {
        let mut pending: Vec<Option<Rows>> = vec![None; hi - lo];
        for (j, s) in (lo..hi).enumerate() {
            let updates = self
                .tree
                .children(s)
                .iter()
                .map(|&c| {
                    let update = pending[c - lo].take();
                    (c, update.expect("children are solved before their parent"))
                })
                .collect();
            pending[j] = Some(self.forward_front(s, rows[j], updates, par));
        }
        pending.pop().flatten().unwrap_or_default()
    }

    /// `y_s = L_11⁻¹ (b_s − Σ children)`; returns `−L_21 y_s` for the parent.
    fn forward_front(
        &self,
        s: usize,
        own: &mut [f64],
        children: Vec<(usize, Rows)>,
        par: Par,
    ) -> Rows {
        let k = self.k;
        let w = own.len() / k;
        let r = self.symbolic.supernode(s).pattern().len();
        let par = front_par(w, r, par);
        let mut update = vec![0.0; r * k];
        let mut local = Vec::new();
        for (c, rows) in children {
            local_positions(
                self.symbolic,
                s,
                self.symbolic.supernode(c).pattern(),
                &mut local,
            );
            for (&t, source) in local.iter().zip(rows.chunks_exact(k)) {
                let target = if t < w {
                    &mut own[t * k..(t + 1) * k]
                } else {
                    &mut update[(t - w) * k..(t - w + 1) * k]
                };
                for (y, v) in target.iter_mut().zip(source) {
                    *y += v;
                }
            }
        }
        if self.thin {
            let panel = thin::Panel::new(self.panels[s], w, r);
            thin::forward(panel, own, &mut update, k, par);
            return update;
        }
        let (top, bottom) = self.panel(s);
        let mut y = MatMut::from_row_major_slice_mut(own, w, k);
        solve_lower_triangular_in_place(top, y.as_mut(), par);
        if r > 0 {
            faer::linalg::matmul::matmul(
                MatMut::from_row_major_slice_mut(&mut update, r, k),
                Accum::Add,
                bottom,
                y.as_ref(),
                -1.0,
                par,
            );
        }
        update
    }

    /// Solves the subtree rooted at `s` backward; `above` is `x` at `s`'s pattern rows.
    fn backward_subtree(
        &self,
        s: usize,
        rows: &mut [&mut [f64]],
        above: Rows,
        depth: usize,
        par: Par,
    ) {
        let tree = self.tree;
        if depth >= MAX_PARALLEL_DEPTH || tree.subtree_entries[s] < PARALLEL_SOLVE_ENTRIES {
            return self.backward_range(tree.first[s], s + 1, rows, vec![(s, above)], par);
        }
        let (own, below) = rows.split_last_mut().expect("a subtree holds its root");
        let handed = self.backward_front(s, own, &above, par);
        let parts: Vec<_> = tree
            .split_children(s, below)
            .into_iter()
            .zip(handed)
            .collect();
        let heavy = tree
            .children(s)
            .iter()
            .filter(|&&c| tree.subtree_entries[c] >= PARALLEL_SOLVE_ENTRIES)
            .count();
        let child = |par| {
            move |((c, rows), above): ((usize, &mut [&mut [f64]]), Rows)| {
                self.backward_subtree(c, rows, above, depth + 1, par)
            }
        };
        if heavy >= 2 && self.parallel {
            parts.into_par_iter().for_each(child(Par::Seq));
        } else {
            parts.into_iter().for_each(child(par));
        }
    }

    /// Solves supernodes `hi − 1` down to `lo`; `given` holds `x` at the pattern rows of the
    /// range's roots.
    fn backward_range(
        &self,
        lo: usize,
        hi: usize,
        rows: &mut [&mut [f64]],
        given: Vec<(usize, Rows)>,
        par: Par,
    ) {
        let mut pending: Vec<Option<Rows>> = vec![None; hi - lo];
        for (s, above) in given {
            pending[s - lo] = Some(above);
        }
        for s in (lo..hi).rev() {
            let above = pending[s - lo]
                .take()
                .expect("parents are solved before their children");
            let handed = self.backward_front(s, rows[s - lo], &above, par);
            for (&c, rows) in self.tree.children(s).iter().zip(handed) {
                pending[c - lo] = Some(rows);
            }
        }
    }

    /// The backward step of [`Self::backward_front`] with faer's kernels.
    fn backward_front_by_faer(&self, s: usize, own: &mut [f64], above: &[f64], par: Par) {
        let k = self.k;
        let (w, r) = (own.len() / k, above.len() / k);
        let (top, bottom) = self.panel(s);
        let mut x = MatMut::from_row_major_slice_mut(own, w, k);
        if r > 0 {
            faer::linalg::matmul::matmul(
                x.as_mut(),
                Accum::Add,
                bottom.transpose(),
                faer::MatRef::from_row_major_slice(above, r, k),
                -1.0,
                par,
            );
        }
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            top.transpose(),
            x.as_mut(),
            par,
        );
    }

    /// `x_s = L_11⁻ᵀ (y_s − L_21ᵀ x_pattern)`; returns, per child, `x` at the child's pattern.
    fn backward_front(&self, s: usize, own: &mut [f64], above: &[f64], par: Par) -> Vec<Rows> {
        let k = self.k;
        let w = own.len() / k;
        let r = self.symbolic.supernode(s).pattern().len();
        let par = front_par(w, r, par);
        if self.thin {
            thin::backward(thin::Panel::new(self.panels[s], w, r), own, above, k, par);
        } else {
            self.backward_front_by_faer(s, own, above, par);
        }
        let mut local = Vec::new();
        self.tree
            .children(s)
            .iter()
            .map(|&c| {
                local_positions(
                    self.symbolic,
                    s,
                    self.symbolic.supernode(c).pattern(),
                    &mut local,
                );
                let mut rows = Vec::with_capacity(local.len() * k);
                for &t in &local {
                    rows.extend_from_slice(if t < w {
                        &own[t * k..(t + 1) * k]
                    } else {
                        &above[(t - w) * k..(t - w + 1) * k]
                    });
                }
                rows
            })
            .collect()
    }
}

#[cfg(test)]
/// A 3-D grid Laplacian with a diagonal shift, full storage: its elimination tree has
/// separators wide enough for the parallel subtrees and the split dense kernels. Diagonal
/// `6.5 + 0.1 (a mod 7)`, so its condition number is about 10.
pub(crate) fn grid_laplacian(side: usize) -> SparseMatrix {
    let node = |i: usize, j: usize, k: usize| (i * side + j) * side + k;
    let mut t = Vec::new();
    for i in 0..side {
        for j in 0..side {
            for k in 0..side {
                let a = node(i, j, k);
                t.push((a, a, 6.5 + (a % 7) as f64 * 0.1));
                for (x, y, z) in [(i + 1, j, k), (i, j + 1, k), (i, j, k + 1)] {
                    if x < side && y < side && z < side {
                        let b = node(x, y, z);
                        t.push((a, b, -1.0));
                        t.push((b, a, -1.0));
                    }
                }
            }
        }
    }
    crate::core::sparse::sparse_from_triplets("A", side * side * side, &t).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::sparse_from_triplets;
    use faer::Side;
    use faer::dyn_stack::MemBuffer;
    use faer::sparse::linalg::cholesky::{
        SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    };

    fn symbolic(a: &SparseMatrix) -> SymbolicCholesky<usize> {
        super::super::factor::supernodal_symbolic(a, SymmetricOrdering::Amd).unwrap()
    }

    /// faer's left-looking supernodal factorisation of the same structure: an independent
    /// computation of the same numbers, so they agree to round-off (1e-12 of the largest entry;
    /// the two orders of summation differ by a few ulps per update).
    #[test]
    fn values_equal_faers_left_looking_factor() {
        let a = grid_laplacian(30);
        let sym = symbolic(&a);
        let mut reference = vec![0.0; sym.len_val()];
        let par = Par::Seq;
        let mut buffer =
            MemBuffer::new(sym.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
        sym.factorize_numeric_llt::<f64>(
            &mut reference,
            a.as_ref(),
            Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut buffer),
            Default::default(),
        )
        .unwrap();
        let SymbolicCholeskyRaw::Supernodal(supernodal) = sym.raw() else {
            panic!("forced supernodal")
        };
        let inverse = sym.perm().map(|p| p.arrays().1);
        let tree = Tree::new(supernodal);
        assert!(tree.postordered);
        let split = (0..supernodal.n_supernodes()).any(|s| {
            let heavy = tree.children(s).iter();
            heavy
                .filter(|&&c| tree.subtree_flops[c] >= PARALLEL_SUBTREE_FLOPS)
                .count()
                >= 2
        });
        assert!(split, "the test must reach the parallel subtrees");
        let largest = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let check = |values: &[f64], route: &str| {
            let worst = values
                .iter()
                .zip(&reference)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(
                worst <= 1e-12 * largest,
                "{route}: {worst:e} of {largest:e}"
            );
        };
        let mut values = vec![f64::NAN; sym.len_val()];
        let lower = PermutedLower::new(&a, inverse).unwrap();
        factorize(supernodal, &tree, &lower, &mut values, Par::rayon(2)).unwrap();
        check(&values, "parallel tree");
        // On one thread: the same numbers, bit for bit.
        let mut one_thread = vec![f64::NAN; sym.len_val()];
        factorize(supernodal, &tree, &lower, &mut one_thread, Par::Seq).unwrap();
        assert!(
            values
                .iter()
                .zip(&one_thread)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        // The sequential route (taken when supernodes are not in postorder).
        let ctx = Context {
            symbolic: supernodal,
            tree: &tree,
            lower: &lower,
            par: Par::rayon(0),
        };
        let mut values = vec![f64::NAN; sym.len_val()];
        let ptr = supernodal.col_ptr_for_val();
        let mut slots: Vec<&mut [f64]> = Vec::new();
        let mut rest = values.as_mut_slice();
        for s in 0..supernodal.n_supernodes() {
            let (head, tail) = rest.split_at_mut(ptr[s + 1] - ptr[s]);
            slots.push(head);
            rest = tail;
        }
        ctx.range(0, supernodal.n_supernodes(), &mut slots).unwrap();
        check(&values, "sequential");
    }

    #[test]
    fn an_indefinite_matrix_stops_with_its_error() {
        let mut a = crate::core::sparse::sparse_triplets(&grid_laplacian(6));
        for t in a.iter_mut().filter(|t| t.0 == t.1 && t.0 == 100) {
            t.2 = -50.0;
        }
        let a = sparse_from_triplets("A", 216, &a).unwrap();
        let sym = symbolic(&a);
        let SymbolicCholeskyRaw::Supernodal(supernodal) = sym.raw() else {
            panic!("forced supernodal")
        };
        let mut values = vec![0.0; sym.len_val()];
        let inverse = sym.perm().map(|p| p.arrays().1);
        assert_eq!(
            factorize(
                supernodal,
                &Tree::new(supernodal),
                &PermutedLower::new(&a, inverse).unwrap(),
                &mut values,
                Par::Seq,
            ),
            Err(FrontError::NotPositiveDefinite)
        );
    }
}
