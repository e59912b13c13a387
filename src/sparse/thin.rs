//! Dense kernels of the multifrontal triangular solves: one supernode's panel `[L₁₁; L₂₁]`
//! (column-major) against at most [`MAX_COLUMNS`] right-hand sides stored by rows.
//!
//! A solve with a few right-hand sides is bound by reading the factor: every entry serves one
//! multiply-add per right-hand side. faer's general kernels, handed right-hand sides by rows,
//! walk the panel across its columns a few rows at a time, one page further at every step, and
//! read the factor well below the memory bandwidth. Here every panel column is read front to
//! back, four columns at a time, while the right-hand-side rows of those four columns stay in
//! registers.
//!
//! Each result is a fixed sequence of fused multiply-adds, the same on every machine that has
//! AVX2 and FMA (the kernels are compiled for them and chosen at run time, [`available`]);
//! elsewhere the solve keeps faer's kernels.

use faer::Par;

/// Most right-hand sides the kernels take: their rows then fit in a few registers.
pub const MAX_COLUMNS: usize = 16;

/// Panel columns handled together: their right-hand-side rows stay in registers.
const J: usize = 4;

/// A parallel kernel splits its rows (or columns) no finer than this.
const SPLIT_ROWS: usize = 512;

/// Whether this machine runs the kernels (x86-64 with AVX2 and FMA).
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// A supernode's panel: `w` columns of `w + r` rows, column-major, `L₁₁` on top of `L₂₁`.
#[derive(Clone, Copy)]
pub struct Panel<'a> {
    values: &'a [f64],
    w: usize,
    r: usize,
}

impl<'a> Panel<'a> {
    /// The panel stored in `values` (`(w + r) w` of them).
    pub fn new(values: &'a [f64], w: usize, r: usize) -> Self {
        assert_eq!(values.len(), w * (w + r), "a panel holds (w + r) w values");
        Panel { values, w, r }
    }

    /// Rows `rows` of column `j`.
    #[inline(always)]
    fn col(&self, j: usize, rows: std::ops::Range<usize>) -> &'a [f64] {
        let start = j * (self.w + self.r);
        &self.values[start + rows.start..start + rows.end]
    }

    /// Rows `rows` of columns `j0..j0 + J'`.
    #[inline(always)]
    fn cols<const JB: usize>(&self, j0: usize, rows: std::ops::Range<usize>) -> [&'a [f64]; JB] {
        std::array::from_fn(|t| self.col(j0 + t, rows.clone()))
    }
}

/// Forward step of a front: `y ← L₁₁⁻¹ y`, then `u ← u − L₂₁ y`; `y` is `w × k`, `u` is
/// `r × k`, both by rows. `par` splits the rows of `u` among the threads. The caller checks
/// [`available`]; `k` is a multiple of 4 up to [`MAX_COLUMNS`].
pub fn forward(panel: Panel<'_>, y: &mut [f64], u: &mut [f64], k: usize, par: Par) {
    check(panel, y, k);
    assert_eq!(u.len(), panel.r * k);
    if par.degree() > 1 {
        // SAFETY: `check` asserted AVX2 and FMA, `k ∈ {4, 8, 12, 16}` and `y.len() = w k`.
        unsafe { fma::lower_solve(panel, y, &mut [], k) };
        update_rows(panel, y, u, 0, k, par);
    } else {
        // One sweep down the panel: each block of columns updates `u` right after `y`.
        // SAFETY: `check` asserted AVX2 and FMA, `k ∈ {4, 8, 12, 16}` and `y.len() = w k`;
        // `u.len() = r k` is asserted above.
        unsafe { fma::lower_solve(panel, y, u, k) };
    }
}

/// Backward step of a front: `x ← L₁₁⁻ᵀ (x − L₂₁ᵀ a)`; `x` is `w × k`, `a` is `r × k`, both by
/// rows. `par` splits the columns of `L₂₁` among the threads. The caller checks [`available`]
/// and that `k` is a multiple of 4 up to [`MAX_COLUMNS`].
pub fn backward(panel: Panel<'_>, x: &mut [f64], a: &[f64], k: usize, par: Par) {
    check(panel, x, k);
    assert_eq!(a.len(), panel.r * k);
    if par.degree() > 1 {
        update_columns(panel, x, a, 0, k, par);
        // SAFETY: `check` asserted AVX2 and FMA, `k ∈ {4, 8, 12, 16}` and `x.len() = w k`.
        unsafe { fma::lower_transposed_solve(panel, x, &[], k) };
    } else {
        // One sweep up the panel: each block of columns takes its products with `a` right
        // after those with the rows of `x` below it.
        // SAFETY: `check` asserted AVX2 and FMA, `k ∈ {4, 8, 12, 16}` and `x.len() = w k`;
        // `a.len() = r k` is asserted above.
        unsafe { fma::lower_transposed_solve(panel, x, a, k) };
    }
}

fn check(panel: Panel<'_>, own: &[f64], k: usize) {
    assert!(available(), "the thin kernels need AVX2 and FMA");
    assert!(
        k.is_multiple_of(4) && (4..=MAX_COLUMNS).contains(&k),
        "rows of 4 to {MAX_COLUMNS} right-hand sides, a multiple of 4 (pad with zeros)"
    );
    assert_eq!(own.len(), panel.w * k);
}

/// `u ← u − L₂₁[first.., :] y`, where `u` holds rows `first..` of `L₂₁`'s product. Called by
/// [`forward`] only, after its checks, with `u` a part of its `r × k` rows starting at `first`.
fn update_rows(panel: Panel<'_>, y: &[f64], u: &mut [f64], first: usize, k: usize, par: Par) {
    let rows = u.len() / k;
    if par.degree() > 1 && rows >= 2 * SPLIT_ROWS {
        let half = rows / 2;
        let (top, bottom) = u.split_at_mut(half * k);
        rayon::join(
            || update_rows(panel, y, top, first, k, par),
            || update_rows(panel, y, bottom, first + half, k, par),
        );
    } else {
        // SAFETY: `forward` asserted AVX2 and FMA, `k ∈ {4, 8, 12, 16}` and `y.len() = w k`;
        // the halving above keeps `u` inside rows `first..r` of the product.
        unsafe { fma::sub_product(panel, y, u, first, k) };
    }
}

/// `x ← x − L₂₁[:, first..]ᵀ a`, where `x` holds rows `first..` of `L₂₁ᵀ a`. Called by
/// [`backward`] only, after its checks, with `x` a part of its `w × k` rows starting at `first`.
fn update_columns(panel: Panel<'_>, x: &mut [f64], a: &[f64], first: usize, k: usize, par: Par) {
    let cols = x.len() / k;
    if par.degree() > 1 && cols >= 2 * SPLIT_ROWS.div_ceil(J) && panel.r >= SPLIT_ROWS {
        let half = cols / 2 / J * J;
        let (top, bottom) = x.split_at_mut(half * k);
        rayon::join(
            || update_columns(panel, top, a, first, k, par),
            || update_columns(panel, bottom, a, first + half, k, par),
        );
    } else {
        // SAFETY: `backward` asserted AVX2 and FMA, `k ∈ {4, 8, 12, 16}` and `a.len() = r k`;
        // the halving above keeps `x` inside rows `first..w`.
        unsafe { fma::sub_transposed_product(panel, x, a, first, k) };
    }
}

/// The kernels, compiled for AVX2 and FMA: one instance per width `k = 4 V` of the
/// right-hand-side rows.
#[cfg(target_arch = "x86_64")]
mod fma {
    use super::{J, Panel};
    use std::arch::x86_64::*;

    /// `$kernel::<V>` for `k = 4 V`.
    macro_rules! by_width {
        ($k:expr, $kernel:ident($($arg:expr),*)) => {
            match $k {
                4 => $kernel::<1>($($arg),*),
                8 => $kernel::<2>($($arg),*),
                12 => $kernel::<3>($($arg),*),
                16 => $kernel::<4>($($arg),*),
                _ => unreachable!("the public kernels check the width"),
            }
        };
    }

    /// `$kernel::<V, jb>` on panel columns `j0..j0 + jb` (`jb ≤ J`), rows `rows`.
    macro_rules! by_block {
        ($jb:expr, $kernel:ident::<$v:ident>, $panel:expr, $j0:expr, $rows:expr, $src:expr, $dst:expr) => {
            match $jb {
                4 => $kernel::<$v, 4>($panel.cols::<4>($j0, $rows), $src, $dst),
                3 => $kernel::<$v, 3>($panel.cols::<3>($j0, $rows), $src, $dst),
                2 => $kernel::<$v, 2>($panel.cols::<2>($j0, $rows), $src, $dst),
                _ => $kernel::<$v, 1>($panel.cols::<1>($j0, $rows), $src, $dst),
            }
        };
    }

    /// `y ← L₁₁⁻¹ y`, and `u ← u − L₂₁ y` unless `u` is empty.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA; `y` is `w × k` with `k ∈ {4, 8, 12, 16}`, `u`
    /// empty or `r × k`.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn lower_solve(panel: Panel<'_>, y: &mut [f64], u: &mut [f64], k: usize) {
        // SAFETY: the kernel needs AVX2 and FMA (this function's target features, which the
        // caller guarantees), `y` of `w` rows and `u` empty or of `r` rows of `k = 4 V`.
        unsafe { by_width!(k, lower_solve_v(panel, y, u)) }
    }

    /// `x ← L₁₁⁻ᵀ (x − L₂₁ᵀ a)`, or `x ← L₁₁⁻ᵀ x` for an empty `a`.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA; `x` is `w × k` with `k ∈ {4, 8, 12, 16}`, `a`
    /// empty or `r × k`.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn lower_transposed_solve(panel: Panel<'_>, x: &mut [f64], a: &[f64], k: usize) {
        // SAFETY: the kernel needs AVX2 and FMA (this function's target features, which the
        // caller guarantees), `x` of `w` rows and `a` empty or of `r` rows of `k = 4 V`.
        unsafe { by_width!(k, lower_transposed_solve_v(panel, x, a)) }
    }

    /// `u ← u − L₂₁[first.., :] y`.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA; `y` is `w × k` with `k ∈ {4, 8, 12, 16}`, `u`
    /// holds at most `r − first` rows of `k`.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn sub_product(panel: Panel<'_>, y: &[f64], u: &mut [f64], first: usize, k: usize) {
        // SAFETY: the kernel needs AVX2 and FMA (this function's target features, which the
        // caller guarantees), `y` of `w` rows and `u` of at most `r − first` rows of `k = 4 V`.
        unsafe { by_width!(k, sub_product_v(panel, y, u, first)) }
    }

    /// `x ← x − L₂₁[:, first..]ᵀ a`.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA; `a` is `r × k` with `k ∈ {4, 8, 12, 16}`, `x`
    /// holds at most `w − first` rows of `k`.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn sub_transposed_product(
        panel: Panel<'_>,
        x: &mut [f64],
        a: &[f64],
        first: usize,
        k: usize,
    ) {
        // SAFETY: the kernel needs AVX2 and FMA (this function's target features, which the
        // caller guarantees), `a` of `r` rows and `x` of at most `w − first` rows of `k = 4 V`.
        unsafe { by_width!(k, sub_transposed_product_v(panel, x, a, first)) }
    }

    /// Blocks of `J` columns, each solving its own small triangle and then updating the rows
    /// below it, those of `y` and then those of `u` (when given): the columns are read once,
    /// from the diagonal down.
    ///
    /// # Safety
    /// AVX2 and FMA; `y` holds `w` rows of `4 V`, `u` none or `r`.
    #[inline(always)]
    unsafe fn lower_solve_v<const V: usize>(panel: Panel<'_>, y: &mut [f64], u: &mut [f64]) {
        let (w, r, k) = (panel.w, panel.r, 4 * V);
        let mut j0 = 0;
        while j0 < w {
            let jb = (w - j0).min(J);
            let (head, below) = y.split_at_mut((j0 + jb) * k);
            let block = &mut head[j0 * k..];
            for t in 0..jb {
                let col = panel.col(j0 + t, j0..j0 + jb);
                let (done, rest) = block.split_at_mut((t + 1) * k);
                let pivot = &mut done[t * k..];
                for v in pivot.iter_mut() {
                    *v /= col[t];
                }
                for (s, row) in rest.chunks_exact_mut(k).enumerate() {
                    let l = -col[t + 1 + s];
                    for (v, p) in row.iter_mut().zip(pivot.iter()) {
                        *v = l.mul_add(*p, *v);
                    }
                }
            }
            // SAFETY: AVX2 and FMA, as the caller guarantees. `block` is a bounds-checked slice
            // of `jb` rows; the columns' slices `j0 + jb..w` and `w..w + r` (bounds-checked)
            // have as many entries as `below` (the `w − j0 − jb` rows of `y` after the block)
            // and `u` (`r` rows, as the caller guarantees) have rows.
            unsafe {
                by_block!(jb, sub_outer::<V>, panel, j0, j0 + jb..w, block, below);
                if !u.is_empty() {
                    by_block!(jb, sub_outer::<V>, panel, j0, w..w + r, block, &mut *u);
                }
            }
            j0 += jb;
        }
    }

    /// Blocks of `J` columns from the last, each first less its products with the rows
    /// already solved below it and then with those of `a` (when given), then solving its own
    /// small triangle: the columns are read once, from the diagonal down.
    ///
    /// # Safety
    /// AVX2 and FMA; `x` holds `w` rows of `4 V`, `a` none or `r`.
    #[inline(always)]
    unsafe fn lower_transposed_solve_v<const V: usize>(panel: Panel<'_>, x: &mut [f64], a: &[f64]) {
        let (w, r, k) = (panel.w, panel.r, 4 * V);
        let mut end = w;
        while end > 0 {
            let jb = end.min(J);
            let j0 = end - jb;
            let (head, solved) = x.split_at_mut(end * k);
            let block = &mut head[j0 * k..];
            // SAFETY: AVX2 and FMA, as the caller guarantees. `block` is a bounds-checked slice
            // of `jb` rows; the columns' slices `end..w` and `w..w + r` (bounds-checked) have
            // as many entries as `solved` (the `w − end` rows of `x` after the block) and `a`
            // (`r` rows, as the caller guarantees) have rows.
            unsafe {
                by_block!(jb, sub_inner::<V>, panel, j0, end..w, solved, &mut *block);
                if !a.is_empty() {
                    by_block!(jb, sub_inner::<V>, panel, j0, w..w + r, a, &mut *block);
                }
            }
            for t in (0..jb).rev() {
                let col = panel.col(j0 + t, j0..end);
                let (own, rest) = block.split_at_mut((t + 1) * k);
                let own = &mut own[t * k..];
                for (s, row) in rest.chunks_exact(k).enumerate() {
                    let l = -col[t + 1 + s];
                    for (v, p) in own.iter_mut().zip(row) {
                        *v = l.mul_add(*p, *v);
                    }
                }
                for v in own.iter_mut() {
                    *v /= col[t];
                }
            }
            end = j0;
        }
    }

    /// Blocks of `J` columns in order.
    ///
    /// # Safety
    /// AVX2 and FMA; `y` holds `w` rows of `4 V`, `u` at most `r − first`.
    #[inline(always)]
    unsafe fn sub_product_v<const V: usize>(
        panel: Panel<'_>,
        y: &[f64],
        u: &mut [f64],
        first: usize,
    ) {
        let (w, k) = (panel.w, 4 * V);
        let lo = w + first;
        let rows = lo..lo + u.len() / k;
        for j0 in (0..w).step_by(J) {
            let jb = (w - j0).min(J);
            let src = &y[j0 * k..(j0 + jb) * k];
            // SAFETY: AVX2 and FMA, as the caller guarantees; `src` is a bounds-checked slice of
            // `jb` rows, and the columns' bounds-checked slices have as many entries as `u`
            // has rows (`rows` is `u`'s row count, and inside the panel as `u` is).
            unsafe { by_block!(jb, sub_outer::<V>, panel, j0, rows.clone(), src, &mut *u) };
        }
    }

    /// Blocks of `J` columns in order.
    ///
    /// # Safety
    /// AVX2 and FMA; `a` holds `r` rows of `4 V`, `x` at most `w − first`.
    #[inline(always)]
    unsafe fn sub_transposed_product_v<const V: usize>(
        panel: Panel<'_>,
        x: &mut [f64],
        a: &[f64],
        first: usize,
    ) {
        let (w, r, k) = (panel.w, panel.r, 4 * V);
        let cols = x.len() / k;
        for j0 in (0..cols).step_by(J) {
            let jb = (cols - j0).min(J);
            let dst = &mut x[j0 * k..(j0 + jb) * k];
            // SAFETY: AVX2 and FMA, as the caller guarantees; `dst` is a bounds-checked slice of
            // `jb` rows, and the columns' bounds-checked slices (rows `w..w + r`) have as many
            // entries as `a` has rows.
            unsafe { by_block!(jb, sub_inner::<V>, panel, first + j0, w..w + r, a, dst) };
        }
    }

    /// `dst ← dst − Σ_t cols[t] ⊗ src[t]`: rows of `dst` (`K` wide) less the outer products of
    /// `JB` panel columns with `JB` rows of `src`, one fused multiply-add per entry and
    /// right-hand side, columns in order.
    ///
    /// # Safety
    /// AVX2 and FMA; `K = 4 V`; `src` holds `JB` rows, and every column at least as many entries
    /// as `dst` has rows.
    #[inline(always)]
    unsafe fn sub_outer<const V: usize, const JB: usize>(
        cols: [&[f64]; JB],
        src: &[f64],
        dst: &mut [f64],
    ) {
        let k = 4 * V;
        let rows = dst.len() / k;
        debug_assert!(src.len() >= JB * k && cols.iter().all(|c| c.len() >= rows));
        // SAFETY: AVX2 and FMA, as the caller guarantees. Loads from `src` are at `t k + 4 v + 3
        // < JB k` (the caller's `JB` rows); loads and stores of `dst` at `i k + 4 v + 3 < rows
        // k ≤ dst.len()`; column loads at `i < rows`, within each column (the caller's bound).
        unsafe {
            let zero = _mm256_setzero_pd();
            let negated: [[__m256d; V]; JB] = std::array::from_fn(|t| {
                std::array::from_fn(|v| {
                    _mm256_sub_pd(zero, _mm256_loadu_pd(src.as_ptr().add(t * k + 4 * v)))
                })
            });
            let (out, cols) = (dst.as_mut_ptr(), cols.map(<[f64]>::as_ptr));
            for i in 0..rows {
                let row = out.add(i * k);
                let mut acc: [__m256d; V] =
                    std::array::from_fn(|v| _mm256_loadu_pd(row.add(4 * v)));
                for (col, y) in cols.iter().zip(&negated) {
                    let l = _mm256_broadcast_sd(&*col.add(i));
                    for (a, y) in acc.iter_mut().zip(y) {
                        *a = _mm256_fmadd_pd(l, *y, *a);
                    }
                }
                for (v, a) in acc.iter().enumerate() {
                    _mm256_storeu_pd(row.add(4 * v), *a);
                }
            }
        }
    }

    /// `dst ← dst − Σ_i cols[·][i] src[i]`: `JB` rows of `dst` (`K` wide) less the products of
    /// `JB` panel columns with the rows of `src`, each summed over `i` in order.
    ///
    /// # Safety
    /// AVX2 and FMA; `K = 4 V`; `dst` holds `JB` rows, and every column at least as many entries
    /// as `src` has rows.
    #[inline(always)]
    unsafe fn sub_inner<const V: usize, const JB: usize>(
        cols: [&[f64]; JB],
        src: &[f64],
        dst: &mut [f64],
    ) {
        let k = 4 * V;
        let rows = src.len() / k;
        debug_assert!(dst.len() >= JB * k && cols.iter().all(|c| c.len() >= rows));
        // SAFETY: AVX2 and FMA, as the caller guarantees. Loads from `src` are at `i k + 4 v + 3
        // < rows k ≤ src.len()`; column loads at `i < rows`, within each column (the caller's
        // bound); loads and stores of `dst` at `t k + 4 v + 3 < JB k` (the caller's `JB` rows).
        unsafe {
            let mut acc = [[_mm256_setzero_pd(); V]; JB];
            let (input, cols) = (src.as_ptr(), cols.map(<[f64]>::as_ptr));
            for i in 0..rows {
                let row: [__m256d; V] =
                    std::array::from_fn(|v| _mm256_loadu_pd(input.add(i * k + 4 * v)));
                for (col, acc) in cols.iter().zip(acc.iter_mut()) {
                    let l = _mm256_broadcast_sd(&*col.add(i));
                    for (a, x) in acc.iter_mut().zip(&row) {
                        *a = _mm256_fmadd_pd(l, *x, *a);
                    }
                }
            }
            for (t, acc) in acc.iter().enumerate() {
                for (v, a) in acc.iter().enumerate() {
                    let out = dst.as_mut_ptr().add(t * k + 4 * v);
                    _mm256_storeu_pd(out, _mm256_sub_pd(_mm256_loadu_pd(out), *a));
                }
            }
        }
    }
}

/// Off x86-64 [`available`] is false and no kernel is called.
#[cfg(not(target_arch = "x86_64"))]
mod fma {
    use super::Panel;

    pub unsafe fn lower_solve(_: Panel<'_>, _: &mut [f64], _: &mut [f64], _: usize) {
        unreachable!("the thin kernels are not available off x86-64")
    }
    pub unsafe fn lower_transposed_solve(_: Panel<'_>, _: &mut [f64], _: &[f64], _: usize) {
        unreachable!("the thin kernels are not available off x86-64")
    }
    pub unsafe fn sub_product(_: Panel<'_>, _: &[f64], _: &mut [f64], _: usize, _: usize) {
        unreachable!("the thin kernels are not available off x86-64")
    }
    pub unsafe fn sub_transposed_product(
        _: Panel<'_>,
        _: &mut [f64],
        _: &[f64],
        _: usize,
        _: usize,
    ) {
        unreachable!("the thin kernels are not available off x86-64")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// A panel with a well-conditioned lower-triangular top, and random-ish entries below.
    fn panel_values(w: usize, r: usize) -> Vec<f64> {
        let mut values = vec![0.0; w * (w + r)];
        for j in 0..w {
            for i in j..w + r {
                values[j * (w + r) + i] = if i == j {
                    2.0 + (j % 5) as f64 * 0.25
                } else {
                    (((i * 31 + j * 17) % 23) as f64 - 11.0) / (23.0 * (w as f64).sqrt())
                };
            }
        }
        values
    }

    fn rows_of(m: &Mat<f64>) -> Vec<f64> {
        (0..m.nrows())
            .flat_map(|i| (0..m.ncols()).map(move |c| (i, c)))
            .map(|(i, c)| m[(i, c)])
            .collect()
    }

    /// Both steps against dense products and triangular solves with faer, for every width,
    /// panel widths that leave partial column blocks (partial column blocks) and both split settings. Condition of
    /// `L₁₁` about 10: agreement to 1e-13 relative.
    #[test]
    fn forward_and_backward_steps_match_dense_algebra() {
        if !available() {
            return;
        }
        // The smallest panel (one column, nothing below), column blocks exactly full (4, 8)
        // and one column into a new block (5), partial blocks, and panels tall enough for
        // the parallel split of both updates.
        for (w, r) in [
            (1, 0),
            (1, 1),
            (3, 5),
            (4, 0),
            (5, 1),
            (8, 3),
            (7, 1200),
            (37, 2100),
            (64, 0),
        ] {
            let values = panel_values(w, r);
            let full = Mat::from_fn(w + r, w, |i, j| values[j * (w + r) + i]);
            let (l11, l21) = (full.subrows(0, w), full.subrows(w, r));
            for k in (4..=MAX_COLUMNS).step_by(4) {
                let y0 = Mat::from_fn(w, k, |i, c| ((i * 7 + c * 3) % 11) as f64 - 5.0);
                let u0 = Mat::from_fn(r, k, |i, c| ((i * 5 + c) % 13) as f64 - 6.0);
                // Dense reference: y = L₁₁⁻¹ y0, u = u0 − L₂₁ y; x = L₁₁⁻ᵀ (y0 − L₂₁ᵀ u0).
                let mut y_ref = y0.clone();
                faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                    l11,
                    y_ref.as_mut(),
                    Par::Seq,
                );
                let u_ref = &u0 - l21 * &y_ref;
                let mut x_ref = &y0 - l21.transpose() * &u0;
                faer::linalg::triangular_solve::solve_upper_triangular_in_place(
                    l11.transpose(),
                    x_ref.as_mut(),
                    Par::Seq,
                );
                for par in [Par::Seq, Par::rayon(2)] {
                    let panel = Panel::new(&values, w, r);
                    let (mut y, mut u) = (rows_of(&y0), rows_of(&u0));
                    forward(panel, &mut y, &mut u, k, par);
                    let mut x = rows_of(&y0);
                    backward(panel, &mut x, &rows_of(&u0), k, par);
                    for (ours, reference) in [(&y, &y_ref), (&u, &u_ref), (&x, &x_ref)] {
                        let reference = rows_of(reference);
                        let scale = reference.iter().fold(1.0f64, |s, v| s.max(v.abs()));
                        for (a, b) in ours.iter().zip(&reference) {
                            assert!((a - b).abs() <= 1e-13 * scale, "w {w} r {r} k {k}: {a} {b}");
                        }
                    }
                }
            }
        }
    }

    /// The checks that the kernels' `unsafe` calls rely on refuse what they must: widths
    /// that are not 4, 8, 12 or 16, and work arrays of the wrong length.
    #[test]
    fn the_kernels_refuse_what_their_safety_needs() {
        if !available() {
            return;
        }
        let (w, r) = (3, 2);
        let values = panel_values(w, r);
        let refused = |k: usize, own: usize, other: usize, forward_step: bool| {
            std::panic::catch_unwind(|| {
                let panel = Panel::new(&values, w, r);
                let (mut y, mut u) = (vec![1.0; own], vec![0.0; other]);
                if forward_step {
                    forward(panel, &mut y, &mut u, k, Par::Seq);
                } else {
                    backward(panel, &mut y, &u, k, Par::Seq);
                }
            })
            .is_err()
        };
        for forward_step in [true, false] {
            assert!(!refused(4, w * 4, r * 4, forward_step));
            for k in [0, 2, 6, 20] {
                assert!(refused(k, w * k, r * k, forward_step), "k = {k}");
            }
            assert!(refused(4, w * 4 - 1, r * 4, forward_step));
            assert!(refused(4, w * 4, r * 4 + 4, forward_step));
            assert!(refused(4, w * 4, 0, forward_step));
        }
        assert!(std::panic::catch_unwind(|| Panel::new(&values[1..], w, r)).is_err());
    }
}
