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
    /// Where each stored lower-triangle entry of the analysed pattern goes in the values.
    scatter: Vec<usize>,
    /// Largest `r` of a supernode.
    max_rows: usize,
    /// Largest `r · w` of a supernode.
    max_panel_below: usize,
}

/// A factor's values and the scratch of its factorisation: one per thread.
pub struct LdltWorkspace {
    values: Vec<c64>,
    /// Update matrices handed from children to parents, `r × r` each, and their owners.
    stack: Vec<c64>,
    frames: Vec<(usize, usize)>,
    front: Vec<c64>,
    scaled: Vec<c64>,
}

impl SymbolicLdlt {
    /// Analyses the pattern of the symmetric matrix whose lower triangle (diagonal included)
    /// `lower` stores; values are not read. [`factorize`](Self::factorize) takes the values in
    /// the order of `lower`'s stored entries, column by column.
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
        let (mut max_rows, mut max_panel_below) = (0, 0);
        for s in 0..ns {
            let rows = sn.supernode(s).pattern();
            pattern.extend_from_slice(rows);
            pattern_ptr[s + 1] = pattern.len();
            let (w, r) = (begin[s + 1] - begin[s], rows.len());
            value_ptr[s + 1] = value_ptr[s] + (w + r) * w;
            max_rows = max_rows.max(r);
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
        let mut scatter = Vec::with_capacity(lower.compute_nnz());
        for oj in 0..n {
            for &oi in lower.row_idx_of_col_raw(oj) {
                let (a, b) = (inverse[oi], inverse[oj]);
                let (i, j) = (a.max(b), a.min(b));
                let s = owner[j];
                let m = begin[s + 1] - begin[s] + rows_of(s).len();
                scatter.push(value_ptr[s] + (j - begin[s]) * m + place(s, i));
            }
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
            scatter,
            max_rows,
            max_panel_below,
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
    pub fn workspace(&self) -> LdltWorkspace {
        LdltWorkspace {
            values: vec![c64::ZERO; self.factor_entries()],
            stack: Vec::new(),
            frames: Vec::new(),
            front: vec![c64::ZERO; self.max_rows * self.max_rows],
            scaled: vec![c64::ZERO; self.max_panel_below],
        }
    }

    /// Factors the matrix whose `e`-th stored lower entry (in the analysed pattern's order) is
    /// `value(e)`, into `ws`; `par` splits the dense kernels of large fronts.
    pub fn factorize(
        &self,
        ws: &mut LdltWorkspace,
        value: impl Fn(usize) -> c64,
        par: Par,
    ) -> Result<(), LdltError> {
        let LdltWorkspace {
            values,
            stack,
            frames,
            front,
            scaled,
        } = ws;
        values.fill(c64::ZERO);
        for (e, &slot) in self.scatter.iter().enumerate() {
            values[slot] += value(e);
        }
        stack.clear();
        frames.clear();
        for &s in &self.postorder {
            let (b, w) = (self.begin[s], self.begin[s + 1] - self.begin[s]);
            let r = self.pattern_ptr[s + 1] - self.pattern_ptr[s];
            let m = w + r;
            let panel = &mut values[self.value_ptr[s]..self.value_ptr[s + 1]];
            let front = &mut front[..r * r];
            front.fill(c64::ZERO);
            // Extend-add: the children's update matrices are the last frames on the stack.
            let first_frame = frames.len() - self.children[s];
            let stack_top = frames.get(first_frame).map_or(stack.len(), |f| f.1);
            for &(c, at) in &frames[first_frame..] {
                let rel = &self.relative[self.pattern_ptr[c]..self.pattern_ptr[c + 1]];
                let rc = rel.len();
                let update = &stack[at..at + rc * rc];
                for (jj, &cj) in rel.iter().enumerate() {
                    let column = &update[jj * rc..(jj + 1) * rc];
                    if cj < w {
                        let target = &mut panel[cj * m..(cj + 1) * m];
                        for (&ci, &v) in rel[jj..].iter().zip(&column[jj..]) {
                            target[ci] += v;
                        }
                    } else {
                        let target = &mut front[(cj - w) * r..(cj - w + 1) * r];
                        for (&ci, &v) in rel[jj..].iter().zip(&column[jj..]) {
                            target[ci - w] += v;
                        }
                    }
                }
            }
            frames.truncate(first_frame);
            stack.truncate(stack_top);
            ldlt_panel(panel, m, 0, w, par).map_err(|k| LdltError::ZeroPivot(b + k))?;
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
                    Accum::Add,
                    MatRef::from_column_major_slice_with_stride(&panel[w..], r, w, m),
                    BlockStructure::Rectangular,
                    MatRef::from_column_major_slice(scaled, r, w).transpose(),
                    BlockStructure::Rectangular,
                    c64::new(-1.0, 0.0),
                    par,
                );
                frames.push((s, stack.len()));
                stack.extend_from_slice(front);
            }
        }
        Ok(())
    }

    /// `X ← A⁻¹ X` by the factor in `ws`, for `x` with [`n`](Self::n) rows.
    pub fn solve_in_place(&self, ws: &LdltWorkspace, mut x: MatMut<'_, c64>) {
        let values = &ws.values;
        let ns = self.begin.len() - 1;
        let mut y = vec![c64::ZERO; self.n];
        for k in 0..x.ncols() {
            for (new, &old) in self.forward.iter().enumerate() {
                y[new] = x[(old, k)];
            }
            // L z = P b, then D, then Lᵀ: supernodes in index order are children first.
            for s in 0..ns {
                let (b, w, rows) = self.supernode(s);
                let m = w + rows.len();
                let panel = &values[self.value_ptr[s]..self.value_ptr[s + 1]];
                for j in 0..w {
                    let column = &panel[j * m..(j + 1) * m];
                    let yj = y[b + j];
                    for i in j + 1..w {
                        y[b + i] -= column[i] * yj;
                    }
                    for (&i, &l) in rows.iter().zip(&column[w..]) {
                        y[i] -= l * yj;
                    }
                }
                for j in 0..w {
                    y[b + j] /= panel[j * m + j];
                }
            }
            for s in (0..ns).rev() {
                let (b, w, rows) = self.supernode(s);
                let m = w + rows.len();
                let panel = &values[self.value_ptr[s]..self.value_ptr[s + 1]];
                for j in (0..w).rev() {
                    let column = &panel[j * m..(j + 1) * m];
                    let mut sum = c64::ZERO;
                    for i in j + 1..w {
                        sum += column[i] * y[b + i];
                    }
                    for (&i, &l) in rows.iter().zip(&column[w..]) {
                        sum += l * y[i];
                    }
                    y[b + j] -= sum;
                }
            }
            for (new, &old) in self.forward.iter().enumerate() {
                x[(old, k)] = y[new];
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
fn ldlt_panel(a: &mut [c64], ld: usize, c0: usize, w: usize, par: Par) -> Result<(), usize> {
    let m = ld - c0;
    if w <= BLOCK {
        for k in 0..w {
            let (head, tail) = a.split_at_mut((c0 + k + 1) * ld);
            let column = &mut head[(c0 + k) * ld + c0..];
            let d = column[k];
            if d == c64::ZERO || !(d.re.is_finite() && d.im.is_finite()) {
                return Err(k);
            }
            let inv = c64::new(1.0, 0.0) / d;
            for j in k + 1..w {
                let l = column[j] * inv;
                let target = &mut tail[(j - k - 1) * ld + c0..(j - k) * ld];
                for (t, &v) in target[j..].iter_mut().zip(&column[j..m]) {
                    *t -= v * l;
                }
            }
            for v in &mut column[k + 1..m] {
                *v *= inv;
            }
        }
        return Ok(());
    }
    let w1 = (w / 2).div_ceil(BLOCK) * BLOCK;
    let w2 = w - w1;
    ldlt_panel(a, ld, c0, w1, par)?;
    let (left, right) = a.split_at_mut((c0 + w1) * ld);
    let left = &left[c0 * ld..];
    // L_21 D_1 for the rows of the right half's diagonal block.
    let scaled = faer::Mat::<c64>::from_fn(w2, w1, |i, j| {
        left[j * ld + c0 + w1 + i] * left[j * ld + c0 + j]
    });
    matmul(
        MatMut::from_column_major_slice_with_stride_mut(&mut right[c0 + w1..], m - w1, w2, ld),
        Accum::Add,
        MatRef::from_column_major_slice_with_stride(&left[c0 + w1..], m - w1, w1, ld),
        scaled.transpose(),
        c64::new(-1.0, 0.0),
        par,
    );
    ldlt_panel(a, ld, c0 + w1, w2, par).map_err(|k| k + w1)
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
    /// product to round-off, with one thread and two giving the same numbers bit for bit.
    #[test]
    fn complex_symmetric_solves_leave_round_off() {
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
            let value = |e: usize| {
                let (i, j) = stored[e];
                if i == j {
                    c64::new(3.0 - (i % 5) as f64, 0.3 + 0.01 * (i % 3) as f64)
                } else {
                    c64::new(-0.4 - 0.01 * ((i + j) % 4) as f64, 0.05)
                }
            };
            let mut a = Mat::<c64>::zeros(n, n);
            for (e, &(i, j)) in stored.iter().enumerate() {
                a[(i, j)] = value(e);
                a[(j, i)] = value(e);
            }
            let b = Mat::from_fn(n, 3, |i, k| c64::new((i * 7 + k) as f64 % 5.0, 1.0));
            let mut results = Vec::new();
            for par in [Par::Seq, Par::rayon(2)] {
                let mut ws = sym.workspace();
                sym.factorize(&mut ws, value, par).unwrap();
                let mut x = b.clone();
                sym.solve_in_place(&ws, x.as_mut());
                let r = &a * &x - &b;
                assert!(
                    r.norm_max() < 1e-12 * a.norm_max() * x.norm_max(),
                    "{n}: {}",
                    r.norm_max()
                );
                results.push(x);
            }
            assert_eq!(results[0], results[1]);
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
