//! Products of sparse symmetric matrices, stored in full, with blocks of vectors: `Y = A X`,
//! and `K X`, `M X` together when the two share a pattern.
//!
//! Row `j` of a symmetric `A` is its column `j`, read contiguously, so the rows of `Y` are
//! independent and shared among the threads. `X` is copied row-major first, so every stored
//! entry gathers one contiguous row of `X` and serves all its columns. On a machine with AVX2
//! and FMA ([`super::thin::available`]) the rows are padded to a multiple of four and each
//! entry is a fixed sequence of fused multiply-adds into registers, in two interleaved sums
//! (even and odd entries) so that consecutive entries do not wait on each other; elsewhere a
//! portable loop runs. When `K` and `M` share their pattern (the assembly stores both on the
//! union pattern), one pass reads the row indices and gathers `X` once for both products.
//! `par` shares the rows among the threads; [`Par::Seq`] keeps them on the calling thread. Every
//! row is summed in the same order either way.
//!
//! The kernels read a row through [`SymmetricRows`]: matrices stored in full give column `j`
//! in place; a [`super::LowerPencil`] gives the entries left of the diagonal through its index,
//! then its column `j`. Both runs are summed as one sequence, so equal rows give equal bits.

use super::layout::to_row_major;
use crate::core::sparse::SparseMatrix;
use faer::{MatMut, MatRef, Par};

/// Most columns per pass over the matrix: with rows padded to a multiple of four, the
/// accumulators of two products fit in the sixteen vector registers.
const PRODUCT_COLUMNS: usize = 16;

/// Output rows per parallel task.
const MIN_ROWS_PER_TASK: usize = 1024;

/// `Y = A X` for a sparse symmetric `A` stored in full.
pub fn sym_matvec(a: &SparseMatrix, x: MatRef<'_, f64>, y: MatMut<'_, f64>, par: Par) {
    assert_eq!(
        (a.nrows(), a.ncols(), y.nrows(), y.ncols()),
        (x.nrows(), x.nrows(), x.nrows(), x.ncols()),
        "Y = A X needs a square A and X, Y of its rows and of equal width"
    );
    let source = FullRows {
        pattern: a,
        values: [a.val()],
    };
    in_passes(&source, x, [y], par);
}

/// `KX = K X` and `MX = M X`, in one pass over the pattern when `K` and `M` share it.
pub fn sym_matvec_pair(
    k: &SparseMatrix,
    m: &SparseMatrix,
    x: MatRef<'_, f64>,
    mut kx: MatMut<'_, f64>,
    mut mx: MatMut<'_, f64>,
    par: Par,
) {
    if !same_pattern(k, m) || !super::thin::available() {
        sym_matvec(k, x, kx, par);
        sym_matvec(m, x, mx, par);
        return;
    }
    assert_eq!(
        (
            k.nrows(),
            k.ncols(),
            kx.ncols(),
            mx.ncols(),
            kx.nrows(),
            mx.nrows()
        ),
        (
            x.nrows(),
            x.nrows(),
            x.ncols(),
            x.ncols(),
            x.nrows(),
            x.nrows()
        ),
        "K X, M X need square K, M and X, KX, MX of their rows and of equal width"
    );
    let source = FullRows {
        pattern: k,
        values: [k.val(), m.val()],
    };
    in_passes(&source, x, [kx.as_mut(), mx.as_mut()], par);
}

/// A run of a row's entries: column indices and the `N` matrices' values, entry `t` of
/// `len()`. A row is two runs, read one after the other.
pub(super) trait Entries<const N: usize> {
    /// Entries in the run.
    fn len(&self) -> usize;
    /// Column index of entry `t`.
    fn index(&self, t: usize) -> usize;
    /// Matrix `q`'s value of entry `t`.
    fn value(&self, q: usize, t: usize) -> f64;
}

/// Entries stored contiguously: `indices[t]`, `values[q][t]`.
pub(super) struct Contiguous<'a, I, const N: usize> {
    pub indices: &'a [I],
    pub values: [&'a [f64]; N],
}

impl<I: RowIndex, const N: usize> Entries<N> for Contiguous<'_, I, N> {
    #[inline(always)]
    fn len(&self) -> usize {
        self.indices.len()
    }
    #[inline(always)]
    fn index(&self, t: usize) -> usize {
        self.indices[t].get()
    }
    #[inline(always)]
    fn value(&self, q: usize, t: usize) -> f64 {
        self.values[q][t]
    }
}

/// A row index of a sparse pattern: `usize` in faer's matrices, `u32` in
/// [`super::LowerPencil`].
pub(super) trait RowIndex: Copy {
    /// The index.
    fn get(self) -> usize;
}

impl RowIndex for usize {
    #[inline(always)]
    fn get(self) -> usize {
        self
    }
}

impl RowIndex for u32 {
    #[inline(always)]
    fn get(self) -> usize {
        self as usize
    }
}

/// Entries whose values lie elsewhere: `indices[t]`, `values[q][positions[t]]`.
pub(super) struct Gathered<'a, const N: usize> {
    pub indices: &'a [u32],
    pub positions: &'a [u32],
    pub values: [&'a [f64]; N],
}

impl<const N: usize> Entries<N> for Gathered<'_, N> {
    #[inline(always)]
    fn len(&self) -> usize {
        self.indices.len()
    }
    #[inline(always)]
    fn index(&self, t: usize) -> usize {
        self.indices[t] as usize
    }
    #[inline(always)]
    fn value(&self, q: usize, t: usize) -> f64 {
        self.values[q][self.positions[t] as usize]
    }
}

/// The rows of `N` symmetric matrices on one pattern, as the products read them: row `j` as
/// two runs of entries whose column indices ascend from the first run's start to the second
/// run's end, with each matrix's values. (The order fixes the round-off: equal rows give
/// equal bits whichever storage they come from.)
pub(super) trait SymmetricRows<const N: usize>: Sync {
    /// The first run's type.
    type First<'s>: Entries<N>
    where
        Self: 's;
    /// The second run's type.
    type Second<'s>: Entries<N>
    where
        Self: 's;
    /// Row `j`.
    fn row(&self, j: usize) -> (Self::First<'_>, Self::Second<'_>);
}

/// Symmetric matrices stored in full on `pattern`: row `j` is column `j`, read in place (the
/// second run is empty).
struct FullRows<'a, const N: usize> {
    pattern: &'a SparseMatrix,
    values: [&'a [f64]; N],
}

impl<const N: usize> SymmetricRows<N> for FullRows<'_, N> {
    type First<'s>
        = Contiguous<'s, usize, N>
    where
        Self: 's;
    type Second<'s>
        = Contiguous<'s, usize, N>
    where
        Self: 's;

    fn row(&self, j: usize) -> (Self::First<'_>, Self::Second<'_>) {
        let indices = self.pattern.row_idx_of_col_raw(j);
        let start = self.pattern.symbolic().col_ptr()[j];
        let first = Contiguous {
            indices,
            values: self.values.map(|v| &v[start..start + indices.len()]),
        };
        let second = Contiguous {
            indices: &[],
            values: [&[][..]; N],
        };
        (first, second)
    }
}

/// Whether `a` and `b` store the same entries.
fn same_pattern(a: &SparseMatrix, b: &SparseMatrix) -> bool {
    let (a, b) = (a.symbolic(), b.symbolic());
    a.nrows() == b.nrows()
        && a.ncols() == b.ncols()
        && a.col_ptr() == b.col_ptr()
        && a.col_nnz() == b.col_nnz()
        && a.row_idx() == b.row_idx()
}

/// [`products`] over the columns of `x` (and alike of every `y`) in passes of equal width, at
/// most [`PRODUCT_COLUMNS`] wide (50 columns: four passes of 13 and 12, not three of 16 and
/// one of 2).
pub(super) fn in_passes<const N: usize>(
    source: &impl SymmetricRows<N>,
    x: MatRef<'_, f64>,
    mut ys: [MatMut<'_, f64>; N],
    par: Par,
) {
    let b = x.ncols();
    if b == 0 || x.nrows() == 0 {
        return;
    }
    let passes = b.div_ceil(PRODUCT_COLUMNS);
    let width = b.div_ceil(passes);
    for c0 in (0..b).step_by(width) {
        let w = width.min(b - c0);
        let parts = ys.each_mut().map(|y| y.as_mut().subcols_mut(c0, w));
        products(source, x.subcols(c0, w), parts, par);
    }
}

/// `Y_q = A_q X` for the matrices of `pattern`'s pattern with values `values[q]`, `X` at
/// most [`PRODUCT_COLUMNS`] wide.
fn products<const N: usize, S: SymmetricRows<N>>(
    source: &S,
    x: MatRef<'_, f64>,
    ys: [MatMut<'_, f64>; N],
    par: Par,
) {
    let (n, b) = (x.nrows(), x.ncols());
    let fast = super::thin::available();
    let s = if fast { b.next_multiple_of(4) } else { b };
    let mut xt = vec![0.0; n * s];
    to_row_major(x, &mut xt, par);
    let ctx = RowProducts {
        source,
        xt: &xt,
        s,
        fast,
        parallel: par.degree() > 1,
    };
    ctx.rows(0, ys);
}

/// What every block of output rows of [`products`] reads.
struct RowProducts<'a, const N: usize, S> {
    source: &'a S,
    /// `X` by rows of `s` values.
    xt: &'a [f64],
    s: usize,
    /// Whether the AVX2 and FMA kernel runs.
    fast: bool,
    /// Whether blocks of rows may run on separate threads.
    parallel: bool,
}

impl<const N: usize, S: SymmetricRows<N>> RowProducts<'_, N, S> {
    /// Rows `first..` of every `Y_q` (`ys`), halved among the threads down to blocks of
    /// [`MIN_ROWS_PER_TASK`]; each row is written straight into the column-major results, so
    /// no row-major result is held beside them.
    fn rows(&self, first: usize, ys: [MatMut<'_, f64>; N]) {
        let rows = ys[0].nrows();
        if rows > MIN_ROWS_PER_TASK && self.parallel {
            let half = rows / 2;
            let mut top: [Option<MatMut<'_, f64>>; N] = [const { None }; N];
            let mut bottom: [Option<MatMut<'_, f64>>; N] = [const { None }; N];
            for (q, y) in ys.into_iter().enumerate() {
                let (t, b) = y.split_at_row_mut(half);
                (top[q], bottom[q]) = (Some(t), Some(b));
            }
            let (top, bottom) = (top.map(Option::unwrap), bottom.map(Option::unwrap));
            rayon::join(|| self.rows(first, top), || self.rows(first + half, bottom));
            return;
        }
        let s = self.s;
        let mut ys = ys;
        let mut out = [0.0f64; 2 * PRODUCT_COLUMNS];
        let out = &mut out[..N * s];
        for r in 0..rows {
            let (head, tail) = self.source.row(first + r);
            self.row(&head, &tail, out);
            for (q, y) in ys.iter_mut().enumerate() {
                for c in 0..y.ncols() {
                    y[(r, c)] = out[q * s + c];
                }
            }
        }
    }

    /// One output row of every product into `out` (`N s` values): the entries of `head`,
    /// then of `tail`.
    fn row(&self, head: &impl Entries<N>, tail: &impl Entries<N>, out: &mut [f64]) {
        let s = self.s;
        if self.fast {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `fast` is `thin::available()`: the machine has AVX2 and FMA, which is
            // all `fma::row` needs beyond its arguments' lengths (it reads and writes through
            // bounds-checked slices of them). `s` is 4, 8, 12 or 16: `b` is 1 to
            // PRODUCT_COLUMNS (`in_passes`), rounded up to a multiple of four; `out` is `N s`
            // long; and every row index is below `n`, the rows of `xt`.
            unsafe {
                fma::row(head, tail, self.xt, out, s)
            };
        } else {
            for q in 0..N {
                portable_row(head, tail, q, self.xt, &mut out[q * s..(q + 1) * s]);
            }
        }
    }
}

/// One output row of matrix `q`, `out = Σ_t v_t x_{i_t}` over the entries of `head` then
/// `tail` and the rows of `xt` (`out.len()` wide).
fn portable_row<const N: usize>(
    head: &impl Entries<N>,
    tail: &impl Entries<N>,
    q: usize,
    xt: &[f64],
    out: &mut [f64],
) {
    let s = out.len();
    out.fill(0.0);
    let mut add = |i: usize, v: f64| {
        for (o, x) in out.iter_mut().zip(&xt[i * s..i * s + s]) {
            *o += v * x;
        }
    };
    for t in 0..head.len() {
        add(head.index(t), head.value(q, t));
    }
    for t in 0..tail.len() {
        add(tail.index(t), tail.value(q, t));
    }
}

#[cfg(target_arch = "x86_64")]
mod fma {
    use super::Entries;
    use std::arch::x86_64::*;

    /// The output rows of the `N` products for one pattern row (the entries of `head`, then of
    /// `tail`), side by side in `out`.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA. For the right result, `s ∈ {4, 8, 12, 16}`, `out`
    /// holds `N s` values, `xt` rows of `s`, and every index of the entries is a row of `xt`;
    /// the accesses themselves are bounds-checked, so other lengths panic.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn row<const N: usize>(
        head: &impl Entries<N>,
        tail: &impl Entries<N>,
        xt: &[f64],
        out: &mut [f64],
        s: usize,
    ) {
        // SAFETY: `row_v` needs AVX2 and FMA, which this function's target features enable
        // and its caller guarantees.
        unsafe {
            match s {
                4 => row_v::<1, N>(head, tail, xt, out),
                8 => row_v::<2, N>(head, tail, xt, out),
                12 => row_v::<3, N>(head, tail, xt, out),
                16 => row_v::<4, N>(head, tail, xt, out),
                _ => unreachable!("rows of 4, 8, 12 or 16 values"),
            }
        }
    }

    /// [`row`] for rows of `4 V` values: the row's even and odd entries (counted across both
    /// runs) summed apart, then added.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA (inlined into [`row`], which enables them).
    #[inline(always)]
    unsafe fn row_v<const V: usize, const N: usize>(
        head: &impl Entries<N>,
        tail: &impl Entries<N>,
        xt: &[f64],
        out: &mut [f64],
    ) {
        let s = 4 * V;
        debug_assert_eq!(out.len(), N * s);
        // SAFETY: AVX2, as the caller guarantees.
        let zero = unsafe { _mm256_setzero_pd() };
        let mut sums = [[[zero; V]; N]; 2];
        // SAFETY: AVX2 and FMA, as the caller guarantees.
        let odd = unsafe { add_run(&mut sums, head, false, xt) };
        // SAFETY: as above.
        unsafe { add_run(&mut sums, tail, odd, xt) };
        let [even, odd] = sums;
        for q in 0..N {
            let o: &mut [f64] = &mut out[q * s..(q + 1) * s];
            for c in 0..V {
                // SAFETY: AVX2, as the caller guarantees; `o` is a slice of `4 V` values (the
                // range above is bounds-checked), so the store at `4 c` for `c < V` stays in it.
                unsafe {
                    _mm256_storeu_pd(
                        o.as_mut_ptr().add(4 * c),
                        _mm256_add_pd(even[q][c], odd[q][c]),
                    )
                };
            }
        }
    }

    /// Adds a run's entries into the even and odd sums, alternately, starting with the odd
    /// sums when `odd`; returns whether the next entry is odd.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA.
    #[inline(always)]
    unsafe fn add_run<const V: usize, const N: usize>(
        sums: &mut [[[__m256d; V]; N]; 2],
        run: &impl Entries<N>,
        odd: bool,
        xt: &[f64],
    ) -> bool {
        let len = run.len();
        let mut t = 0;
        let [even_sums, odd_sums] = sums;
        if odd && len > 0 {
            // SAFETY: AVX2 and FMA, as the caller guarantees; `t < len`.
            unsafe { add_entry(odd_sums, run, xt, 0) };
            t = 1;
        }
        while t + 1 < len {
            // SAFETY: AVX2 and FMA, as the caller guarantees; `t + 1 < len`.
            unsafe {
                add_entry(even_sums, run, xt, t);
                add_entry(odd_sums, run, xt, t + 1);
            }
            t += 2;
        }
        if t < len {
            // SAFETY: AVX2 and FMA, as the caller guarantees; the run's last entry.
            unsafe { add_entry(even_sums, run, xt, t) };
            return true;
        }
        odd && len == 0
    }

    /// `acc_q += value_q(t) · xt[index(t)]` for every product `q`.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA. `t`, the entry's index and the row's range of `xt`
    /// are bounds-checked.
    #[inline(always)]
    unsafe fn add_entry<const V: usize, const N: usize>(
        acc: &mut [[__m256d; V]; N],
        run: &impl Entries<N>,
        xt: &[f64],
        t: usize,
    ) {
        let s = 4 * V;
        let i = run.index(t);
        let xi = &xt[i * s..i * s + s];
        for (q, acc_q) in acc.iter_mut().enumerate() {
            // SAFETY: AVX2 and FMA, as the caller guarantees; `xi` is a bounds-checked slice of
            // `4 V` values, so the loads at `4 c` for `c < V` stay in it.
            unsafe {
                let v = _mm256_set1_pd(run.value(q, t));
                for (c, a) in acc_q.iter_mut().enumerate() {
                    *a = _mm256_fmadd_pd(v, _mm256_loadu_pd(xi.as_ptr().add(4 * c)), *a);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::{sparse_from_triplets, sparse_to_dense};
    use faer::Mat;

    /// A symmetric banded matrix stored in full, with `bands` off-diagonals and values
    /// depending on `seed`.
    fn banded(n: usize, bands: usize, seed: f64) -> SparseMatrix {
        let mut t = Vec::new();
        for j in 0..n {
            for d in 0..=bands.min(n - 1 - j) {
                let v = (seed + (j * 7 + d * 3) as f64).sin() + if d == 0 { 4.0 } else { 0.0 };
                t.push((j + d, j, v));
                if d > 0 {
                    t.push((j, j + d, v));
                }
            }
        }
        sparse_from_triplets("A", n, &t).unwrap()
    }

    /// Both products, for widths of one to four passes (1, 4, 5, 13, 16, 17, 50 columns),
    /// against dense products: 1e-13 relative (round-off of sums of at most 13 terms).
    #[test]
    fn products_match_dense_algebra_for_every_width() {
        let n = 3 * MIN_ROWS_PER_TASK + 11;
        let (k, m) = (banded(n, 6, 0.3), banded(n, 6, 1.7));
        let other = banded(n, 2, 0.9);
        let (kd, md) = (sparse_to_dense(&k), sparse_to_dense(&m));
        let od = sparse_to_dense(&other);
        for (b, par) in [1, 4, 5, 13, 16, 17, 50]
            .into_iter()
            .flat_map(|b| [(b, Par::Seq), (b, Par::rayon(2))])
        {
            let x = Mat::from_fn(n, b, |i, c| ((i * 31 + c * 17) % 97) as f64 / 97.0 - 0.5);
            let (mut kx, mut mx) = (Mat::zeros(n, b), Mat::zeros(n, b));
            sym_matvec_pair(&k, &m, x.as_ref(), kx.as_mut(), mx.as_mut(), par);
            let close = |got: &Mat<f64>, want: Mat<f64>| {
                let err = (got - &want).norm_max() / want.norm_max();
                assert!(err < 1e-13, "{b} columns: {err:e}");
            };
            close(&kx, &kd * &x);
            close(&mx, &md * &x);
            // Another pattern: the products are made one after the other.
            sym_matvec_pair(&other, &m, x.as_ref(), kx.as_mut(), mx.as_mut(), par);
            close(&kx, &od * &x);
            close(&mx, &md * &x);
            let mut y = Mat::zeros(n, b);
            sym_matvec(&m, x.as_ref(), y.as_mut(), par);
            close(&y, &md * &x);
        }
    }

    /// The kernel's bounds: a 1 × 1 matrix, a matrix with an empty column (a row with no
    /// entries), rows with one entry (an odd count: the last entry alone) and two, and the
    /// last row of `X` gathered. Every width from 1 to 16 (each padded row width `4 V`), on
    /// one thread and on two, bit for bit equal and equal to the dense product.
    #[test]
    fn products_at_the_kernel_bounds() {
        let one = sparse_from_triplets("A", 1, &[(0, 0, 2.5)]).unwrap();
        // Column 1 empty; column 0 holds one entry, column 2 two, the last row n − 1 is
        // reached from column 0's mirror.
        let n = 5;
        let t = [
            (0, 0, 1.5),
            (4, 0, -0.5),
            (0, 4, -0.5),
            (2, 2, 3.0),
            (3, 2, 0.25),
            (2, 3, 0.25),
            (4, 4, 2.0),
        ];
        let holes = sparse_from_triplets("A", n, &t).unwrap();
        for a in [&one, &holes] {
            let n = a.nrows();
            let dense = sparse_to_dense(a);
            for b in 1..=PRODUCT_COLUMNS {
                let x = Mat::from_fn(n, b, |i, c| 1.0 + (i * 3 + c) as f64);
                let mut results = Vec::new();
                for par in [Par::Seq, Par::rayon(2)] {
                    let mut y = Mat::from_fn(n, b, |_, _| f64::NAN);
                    sym_matvec(a, x.as_ref(), y.as_mut(), par);
                    assert_eq!(y, &dense * &x, "{n} rows, {b} columns");
                    let (mut kx, mut mx) = (Mat::zeros(n, b), Mat::zeros(n, b));
                    sym_matvec_pair(a, a, x.as_ref(), kx.as_mut(), mx.as_mut(), par);
                    assert_eq!((&kx, &mx), (&y, &y));
                    results.push(y);
                }
                assert_eq!(results[0], results[1]);
            }
        }
    }
}
