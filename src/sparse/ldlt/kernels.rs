//! The vector kernels the `LDLᵀ` sweeps are written in, and the instruction sets they run on.
//!
//! The sweeps ([`unblocked_ldlt`](super::unblocked_ldlt), [`SymbolicLdlt::extend_add`] and
//! [`SymbolicLdlt::solve_with`]) are generic over a [`Kernels`] implementation. Each scalar has
//! an entry point per instruction set, compiled with that set's target features, into which its
//! kernels inline: the complex ones written with AVX2 or AVX-512 intrinsics (two or four
//! complex numbers to a register), the real ones the plain loops, which the compiler vectorises
//! for the set. [`Isa::detected`] picks the best the machine runs, once per process.
//!
//! The AVX2 and AVX-512 kernels do the same operations on each entry in the same order (the
//! AVX2 kernels' last odd entry in half a register, the AVX-512 dot products by the AVX2
//! kernel), so a result is the same to the bit on every machine with AVX2 and FMA, whichever
//! of the two it runs; the plain loops differ from them in the last bits.

use super::SymbolicLdlt;
use super::{LdltScalar, unblocked_ldlt};

/// The instruction set the kernels run on: one this machine has (a value exists only by
/// [`Isa::detected`], possibly lowered by [`Isa::at_most`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Isa(Level);

/// The instruction sets of the kernels, in increasing order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Plain loops (any machine).
    Plain,
    /// x86-64 with AVX2 and FMA.
    Avx2,
    /// x86-64 with AVX-512F (and AVX2, FMA).
    Avx512,
}

impl Isa {
    /// The best set this machine runs.
    pub fn detected() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::sync::OnceLock;
            static DETECTED: OnceLock<Level> = OnceLock::new();
            Isa(*DETECTED.get_or_init(|| {
                // AVX2 and FMA as the Cholesky's thin kernels ask for them.
                match (
                    crate::sparse::thin::available(),
                    std::arch::is_x86_feature_detected!("avx512f"),
                ) {
                    (true, true) => Level::Avx512,
                    (true, false) => Level::Avx2,
                    _ => Level::Plain,
                }
            }))
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Isa(Level::Plain)
        }
    }

    /// This set, or `level` if that is lower (a machine with a set has the lower ones).
    pub fn at_most(self, level: Level) -> Self {
        Isa(self.0.min(level))
    }

    /// Which set.
    pub fn level(self) -> Level {
        self.0
    }
}

/// The operations the sweeps are made of, on slices of one scalar, each over the common
/// length of its arguments.
pub trait Kernels<T> {
    /// `t ← t + v`.
    fn add(&self, t: &mut [T], v: &[T]);
    /// `t ← t − v l`.
    fn sub_scaled(&self, t: &mut [T], v: &[T], l: T);
    /// `t ← t − Σ_k v_k l_k`, `t` read and written once for the four.
    fn sub_scaled4(&self, t: &mut [T], v: [&[T]; 4], l: [T; 4]);
    /// `t ← t − V l` for the column-major `V` of `l.len()` columns (leading dimension `ld`,
    /// column `k` at `v[k ld..]`, `t.len()` rows), `t` read and written once.
    fn sub_product(&self, t: &mut [T], v: &[T], ld: usize, l: &[T]);
    /// `Σ aᵢ bᵢ` (no conjugation).
    fn dot(&self, a: &[T], b: &[T]) -> T;
    /// `Σ a_kᵢ bᵢ` for each of the four `a_k`, `b` read once for the four.
    fn dot4(&self, a: [&[T]; 4], b: &[T]) -> [T; 4];
}

/// The kernels as plain loops, for every scalar.
pub struct Plain;

impl<T: LdltScalar> Kernels<T> for Plain {
    #[inline(always)]
    fn add(&self, t: &mut [T], v: &[T]) {
        for (t, &v) in t.iter_mut().zip(v) {
            *t += v;
        }
    }

    #[inline(always)]
    fn sub_scaled(&self, t: &mut [T], v: &[T], l: T) {
        for (t, &v) in t.iter_mut().zip(v) {
            *t -= v * l;
        }
    }

    #[inline(always)]
    fn sub_scaled4(&self, t: &mut [T], v: [&[T]; 4], l: [T; 4]) {
        let n = v.iter().fold(t.len(), |n, v| n.min(v.len()));
        let [v0, v1, v2, v3] = v.map(|v| &v[..n]);
        for (i, t) in t[..n].iter_mut().enumerate() {
            *t -= (v0[i] * l[0] + v1[i] * l[1]) + (v2[i] * l[2] + v3[i] * l[3]);
        }
    }

    #[inline(always)]
    fn sub_product(&self, t: &mut [T], v: &[T], ld: usize, l: &[T]) {
        let n = t.len();
        for (k, &l) in l.iter().enumerate() {
            self.sub_scaled(t, &v[k * ld..k * ld + n], l);
        }
    }

    /// In four partial sums, which a vector unit holds side by side.
    #[inline(always)]
    fn dot(&self, a: &[T], b: &[T]) -> T {
        let n = a.len().min(b.len());
        let (a, b) = (a[..n].chunks_exact(4), b[..n].chunks_exact(4));
        let tail: T = a
            .remainder()
            .iter()
            .zip(b.remainder())
            .map(|(&x, &y)| x * y)
            .sum();
        let mut partial = [T::NIL; 4];
        for (x, y) in a.zip(b) {
            for l in 0..4 {
                partial[l] += x[l] * y[l];
            }
        }
        (partial[0] + partial[1]) + (partial[2] + partial[3]) + tail
    }

    #[inline(always)]
    fn dot4(&self, a: [&[T]; 4], b: &[T]) -> [T; 4] {
        let n = a.iter().fold(b.len(), |n, a| n.min(a.len()));
        let mut sums = [T::NIL; 4];
        for (i, &y) in b[..n].iter().enumerate() {
            for k in 0..4 {
                sums[k] += a[k][i] * y;
            }
        }
        sums
    }
}

/// A scalar's entry points for one instruction set, in a module `$name`: the sweeps with the
/// kernels `$kernels` (an expression), compiled with `$features`.
macro_rules! entry_points {
    ($name:ident, $features:literal, $scalar:ty, $kernels:expr) => {
        #[cfg(target_arch = "x86_64")]
        pub mod $name {
            #[allow(unused_imports)]
            use super::*;

            /// [`unblocked_ldlt`](super::super::unblocked_ldlt) on this set.
            ///
            /// # Safety
            /// The machine must have the set.
            #[target_feature(enable = $features)]
            pub unsafe fn unblocked_ldlt(
                a: &mut [$scalar],
                ld: usize,
                c0: usize,
                w: usize,
            ) -> Result<(), usize> {
                super::unblocked_ldlt(a, ld, c0, w, &$kernels)
            }

            /// [`SymbolicLdlt::extend_add`] on this set.
            ///
            /// # Safety
            /// The machine must have the set.
            #[target_feature(enable = $features)]
            pub unsafe fn extend_add(
                sym: &SymbolicLdlt,
                c: usize,
                update: &[$scalar],
                w: usize,
                panel: &mut [$scalar],
                front: &mut [$scalar],
                into_front: bool,
            ) {
                sym.extend_add(c, update, w, panel, front, into_front, &$kernels)
            }

            /// [`SymbolicLdlt::solve_with`] on this set.
            ///
            /// # Safety
            /// The machine must have the set.
            #[target_feature(enable = $features)]
            pub unsafe fn solve(
                sym: &SymbolicLdlt,
                values: &[$scalar],
                y: &mut [$scalar],
                scratch: &mut [$scalar],
            ) {
                sym.solve_with(values, y, scratch, &$kernels)
            }
        }
    };
}

// SAFETY (of the tokens below): each entry point is compiled for its set and is `unsafe`
// to call on a machine without it; its kernels' token is made only inside it.
entry_points!(complex_avx2, "avx2,fma", faer::c64, avx2::Avx2(()));
entry_points!(
    complex_avx512,
    "avx512f,avx2,fma",
    faer::c64,
    avx512::Avx512(())
);
entry_points!(real_avx2, "avx2,fma", f64, Plain);
entry_points!(real_avx512, "avx512f,avx2,fma", f64, Plain);

/// The three sweeps of [`LdltScalar`] for a scalar, by the entry points of each set.
macro_rules! dispatch {
    ($avx2:ident, $avx512:ident) => {
        fn unblocked(
            isa: Isa,
            a: &mut [Self],
            ld: usize,
            c0: usize,
            w: usize,
        ) -> Result<(), usize> {
            match isa.level() {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Isa` names only a set the machine has.
                Level::Avx512 => unsafe { kernels::$avx512::unblocked_ldlt(a, ld, c0, w) },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: as above.
                Level::Avx2 => unsafe { kernels::$avx2::unblocked_ldlt(a, ld, c0, w) },
                _ => unblocked_ldlt(a, ld, c0, w, &kernels::Plain),
            }
        }

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
        ) {
            let (p, f) = (panel, front);
            match isa.level() {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Isa` names only a set the machine has.
                Level::Avx512 => unsafe {
                    kernels::$avx512::extend_add(sym, c, update, w, p, f, into_front)
                },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: as above.
                Level::Avx2 => unsafe {
                    kernels::$avx2::extend_add(sym, c, update, w, p, f, into_front)
                },
                _ => sym.extend_add(c, update, w, p, f, into_front, &kernels::Plain),
            }
        }

        fn solve(
            isa: Isa,
            sym: &SymbolicLdlt,
            values: &[Self],
            y: &mut [Self],
            scratch: &mut [Self],
        ) {
            match isa.level() {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Isa` names only a set the machine has.
                Level::Avx512 => unsafe { kernels::$avx512::solve(sym, values, y, scratch) },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: as above.
                Level::Avx2 => unsafe { kernels::$avx2::solve(sym, values, y, scratch) },
                _ => sym.solve_with(values, y, scratch, &kernels::Plain),
            }
        }
    };
}
pub(super) use dispatch;

/// Pointer to the doubles of a complex slice (`c64` is `#[repr(C)]` `{re, im}`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn doubles(v: &[faer::c64]) -> *const f64 {
    v.as_ptr().cast()
}

/// The complex kernels in AVX2 and FMA: two complex numbers to a register. A product
/// `x l` is `(xʳlʳ, xⁱlʳ)` and `(xⁱlⁱ, xʳlⁱ)` (the swapped `x` times `lⁱ`) combined by one
/// `fmaddsub`; sums of products keep the two halves apart and combine them once.
#[cfg(target_arch = "x86_64")]
pub mod avx2 {
    use super::{Kernels, doubles};
    use faer::c64;
    use std::arch::x86_64::*;

    /// The AVX2 kernels' token: made only inside entry points compiled for AVX2 and FMA.
    pub struct Avx2(pub(super) ());

    impl Kernels<c64> for Avx2 {
        #[inline(always)]
        fn add(&self, t: &mut [c64], v: &[c64]) {
            let n = t.len().min(v.len());
            let (tp, vp) = (t.as_mut_ptr().cast::<f64>(), doubles(v));
            // SAFETY: the token proves AVX2; complex entries `2p` and `2p + 1` of both slices
            // are the four doubles at `4p`, inside their first `n` entries.
            unsafe {
                for p in 0..n / 2 {
                    let x = _mm256_loadu_pd(vp.add(4 * p));
                    let y = _mm256_loadu_pd(tp.add(4 * p));
                    _mm256_storeu_pd(tp.add(4 * p), _mm256_add_pd(y, x));
                }
            }
            if n % 2 == 1 {
                t[n - 1] += v[n - 1];
            }
        }

        #[inline(always)]
        fn sub_scaled(&self, t: &mut [c64], v: &[c64], l: c64) {
            let n = t.len().min(v.len());
            let (tp, vp) = (t.as_mut_ptr().cast::<f64>(), doubles(v));
            // SAFETY: as in `add`; the token proves FMA too.
            unsafe {
                let (re, im) = (_mm256_set1_pd(l.re), _mm256_set1_pd(l.im));
                for p in 0..n / 2 {
                    let x = _mm256_loadu_pd(vp.add(4 * p));
                    let swapped = _mm256_permute_pd::<0b0101>(x);
                    let product = _mm256_fmaddsub_pd(x, re, _mm256_mul_pd(swapped, im));
                    let y = _mm256_loadu_pd(tp.add(4 * p));
                    _mm256_storeu_pd(tp.add(4 * p), _mm256_sub_pd(y, product));
                }
                if n % 2 == 1 {
                    // The last entry by the same operations in half a register.
                    let at = 2 * (n - 1);
                    let x = _mm_loadu_pd(vp.add(at));
                    let swapped = _mm_permute_pd::<0b01>(x);
                    let im = _mm_mul_pd(swapped, _mm_set1_pd(l.im));
                    let product = _mm_fmaddsub_pd(x, _mm_set1_pd(l.re), im);
                    _mm_storeu_pd(tp.add(at), _mm_sub_pd(_mm_loadu_pd(tp.add(at)), product));
                }
            }
        }

        #[inline(always)]
        fn sub_scaled4(&self, t: &mut [c64], v: [&[c64]; 4], l: [c64; 4]) {
            let n = v.iter().fold(t.len(), |n, v| n.min(v.len()));
            let (tp, vp) = (t.as_mut_ptr().cast::<f64>(), v.map(doubles));
            // SAFETY: as in `sub_scaled`, for every slice.
            unsafe {
                let re = l.map(|l| _mm256_set1_pd(l.re));
                let im = l.map(|l| _mm256_set1_pd(l.im));
                for p in 0..n / 2 {
                    let x = _mm256_loadu_pd(vp[0].add(4 * p));
                    let mut same = _mm256_mul_pd(x, re[0]);
                    let mut crossed = _mm256_mul_pd(_mm256_permute_pd::<0b0101>(x), im[0]);
                    for k in 1..4 {
                        let x = _mm256_loadu_pd(vp[k].add(4 * p));
                        same = _mm256_fmadd_pd(x, re[k], same);
                        crossed = _mm256_fmadd_pd(_mm256_permute_pd::<0b0101>(x), im[k], crossed);
                    }
                    let y = _mm256_loadu_pd(tp.add(4 * p));
                    let product = _mm256_addsub_pd(same, crossed);
                    _mm256_storeu_pd(tp.add(4 * p), _mm256_sub_pd(y, product));
                }
                if n % 2 == 1 {
                    // The last entry by the same operations in half a register.
                    let at = 2 * (n - 1);
                    let x = _mm_loadu_pd(vp[0].add(at));
                    let mut same = _mm_mul_pd(x, _mm_set1_pd(l[0].re));
                    let mut crossed = _mm_mul_pd(_mm_permute_pd::<0b01>(x), _mm_set1_pd(l[0].im));
                    for k in 1..4 {
                        let x = _mm_loadu_pd(vp[k].add(at));
                        same = _mm_fmadd_pd(x, _mm_set1_pd(l[k].re), same);
                        let swapped = _mm_permute_pd::<0b01>(x);
                        crossed = _mm_fmadd_pd(swapped, _mm_set1_pd(l[k].im), crossed);
                    }
                    let y = _mm_loadu_pd(tp.add(at));
                    _mm_storeu_pd(tp.add(at), _mm_sub_pd(y, _mm_addsub_pd(same, crossed)));
                }
            }
        }

        #[inline(always)]
        fn sub_product(&self, t: &mut [c64], v: &[c64], ld: usize, l: &[c64]) {
            let n = t.len();
            assert!(l.is_empty() || v.len() >= (l.len() - 1) * ld + n);
            let (tp, vp) = (t.as_mut_ptr().cast::<f64>(), doubles(v));
            let lp = doubles(l);
            // SAFETY: the token proves AVX2 and FMA; column `k`'s entries `2p`, `2p + 1` are
            // the four doubles at `2 (k ld) + 4p`, inside `v` (asserted), and `l`'s parts
            // are at `2k`, `2k + 1`.
            unsafe {
                for p in 0..n / 2 {
                    let (mut same, mut crossed) = (_mm256_setzero_pd(), _mm256_setzero_pd());
                    for k in 0..l.len() {
                        let x = _mm256_loadu_pd(vp.add(2 * k * ld + 4 * p));
                        same = _mm256_fmadd_pd(x, _mm256_broadcast_sd(&*lp.add(2 * k)), same);
                        let swapped = _mm256_permute_pd::<0b0101>(x);
                        let im = _mm256_broadcast_sd(&*lp.add(2 * k + 1));
                        crossed = _mm256_fmadd_pd(swapped, im, crossed);
                    }
                    let y = _mm256_loadu_pd(tp.add(4 * p));
                    let product = _mm256_addsub_pd(same, crossed);
                    _mm256_storeu_pd(tp.add(4 * p), _mm256_sub_pd(y, product));
                }
                if n % 2 == 1 {
                    // The last entry by the same operations in half a register.
                    let at = 2 * (n - 1);
                    let (mut same, mut crossed) = (_mm_setzero_pd(), _mm_setzero_pd());
                    for k in 0..l.len() {
                        let x = _mm_loadu_pd(vp.add(2 * k * ld + at));
                        same = _mm_fmadd_pd(x, _mm_set1_pd(*lp.add(2 * k)), same);
                        let swapped = _mm_permute_pd::<0b01>(x);
                        crossed = _mm_fmadd_pd(swapped, _mm_set1_pd(*lp.add(2 * k + 1)), crossed);
                    }
                    let y = _mm_loadu_pd(tp.add(at));
                    _mm_storeu_pd(tp.add(at), _mm_sub_pd(y, _mm_addsub_pd(same, crossed)));
                }
            }
        }

        #[inline(always)]
        fn dot(&self, a: &[c64], b: &[c64]) -> c64 {
            // SAFETY: the token proves AVX2 and FMA.
            let [sum] = unsafe { dots([a], b) };
            sum
        }

        #[inline(always)]
        fn dot4(&self, a: [&[c64]; 4], b: &[c64]) -> [c64; 4] {
            // SAFETY: as in `dot`.
            unsafe { dots(a, b) }
        }
    }

    /// `Σ a_kᵢ bᵢ` for each `a_k`: `(aʳbʳ, aⁱbⁱ)` and `(aʳbⁱ, aⁱbʳ)` summed in two registers
    /// per sum, combined at the end. The AVX-512 kernels take their dot products from here
    /// too, so both sets give the same bits.
    ///
    /// # Safety
    /// AVX2 and FMA (inlined into a function that enables them).
    #[inline(always)]
    pub(super) unsafe fn dots<const K: usize>(a: [&[c64]; K], b: &[c64]) -> [c64; K] {
        let n = a.iter().fold(b.len(), |n, a| n.min(a.len()));
        let (ap, bp) = (a.map(doubles), doubles(b));
        let mut sums = [c64::ZERO; K];
        // SAFETY: the caller guarantees AVX2 and FMA; complex entries `2p` and `2p + 1`
        // of every slice are the four doubles at `4p`, inside their first `n` entries.
        unsafe {
            let mut same = [_mm256_setzero_pd(); K];
            let mut crossed = [_mm256_setzero_pd(); K];
            for p in 0..n / 2 {
                let y = _mm256_loadu_pd(bp.add(4 * p));
                let swapped = _mm256_permute_pd::<0b0101>(y);
                for k in 0..K {
                    let x = _mm256_loadu_pd(ap[k].add(4 * p));
                    same[k] = _mm256_fmadd_pd(x, y, same[k]);
                    crossed[k] = _mm256_fmadd_pd(x, swapped, crossed[k]);
                }
            }
            for k in 0..K {
                let (mut s, mut c) = ([0.0; 4], [0.0; 4]);
                _mm256_storeu_pd(s.as_mut_ptr(), same[k]);
                _mm256_storeu_pd(c.as_mut_ptr(), crossed[k]);
                sums[k] = c64::new((s[0] - s[1]) + (s[2] - s[3]), (c[0] + c[1]) + (c[2] + c[3]));
            }
        }
        if n % 2 == 1 {
            for k in 0..K {
                sums[k] += a[k][n - 1] * b[n - 1];
            }
        }
        sums
    }
}

/// The complex kernels in AVX-512F: four complex numbers to a register, the same products as
/// [`avx2`]'s; a tail of one to three entries by masked loads and stores.
#[cfg(target_arch = "x86_64")]
pub mod avx512 {
    use super::{Kernels, doubles};
    use faer::c64;
    use std::arch::x86_64::*;

    /// The AVX-512 kernels' token: made only inside entry points compiled for AVX-512F.
    pub struct Avx512(pub(super) ());

    /// The register-sized steps over `n` complex entries (the last one possibly partial).
    #[inline(always)]
    fn steps(n: usize) -> std::ops::Range<usize> {
        0..n.div_ceil(4)
    }

    /// Step `p`'s first double and the mask of its doubles that belong to the first `n`
    /// complex entries (all eight but in a last partial step). The loops use masked loads and
    /// stores throughout, so each kernel is one loop with no closure (a closure's body would
    /// not inherit the entry point's target features).
    #[inline(always)]
    fn step(p: usize, n: usize) -> (usize, __mmask8) {
        let left = (n - 4 * p).min(4);
        (8 * p, ((1u32 << (2 * left)) - 1) as __mmask8)
    }

    /// The swap of each complex entry's parts.
    #[inline(always)]
    unsafe fn swap(x: __m512d) -> __m512d {
        // SAFETY: the caller's token proves AVX-512F.
        unsafe { _mm512_permute_pd::<0b0101_0101>(x) }
    }

    impl Kernels<c64> for Avx512 {
        #[inline(always)]
        fn add(&self, t: &mut [c64], v: &[c64]) {
            let n = t.len().min(v.len());
            let (tp, vp) = (t.as_mut_ptr().cast::<f64>(), doubles(v));
            // SAFETY: the token proves AVX-512F; a step's doubles `at..at + 8` under `mask`
            // are inside both slices' first `n` entries.
            unsafe {
                for p in steps(n) {
                    let (at, mask) = step(p, n);
                    let x = _mm512_maskz_loadu_pd(mask, vp.add(at));
                    let y = _mm512_maskz_loadu_pd(mask, tp.add(at));
                    _mm512_mask_storeu_pd(tp.add(at), mask, _mm512_add_pd(y, x));
                }
            }
        }

        #[inline(always)]
        fn sub_scaled(&self, t: &mut [c64], v: &[c64], l: c64) {
            let n = t.len().min(v.len());
            let (tp, vp) = (t.as_mut_ptr().cast::<f64>(), doubles(v));
            // SAFETY: as in `add`.
            unsafe {
                let (re, im) = (_mm512_set1_pd(l.re), _mm512_set1_pd(l.im));
                for p in steps(n) {
                    let (at, mask) = step(p, n);
                    let x = _mm512_maskz_loadu_pd(mask, vp.add(at));
                    let product = _mm512_fmaddsub_pd(x, re, _mm512_mul_pd(swap(x), im));
                    let y = _mm512_maskz_loadu_pd(mask, tp.add(at));
                    _mm512_mask_storeu_pd(tp.add(at), mask, _mm512_sub_pd(y, product));
                }
            }
        }

        #[inline(always)]
        fn sub_scaled4(&self, t: &mut [c64], v: [&[c64]; 4], l: [c64; 4]) {
            let n = v.iter().fold(t.len(), |n, v| n.min(v.len()));
            let (tp, vp) = (t.as_mut_ptr().cast::<f64>(), v.map(doubles));
            // SAFETY: as in `add`, for every slice.
            unsafe {
                let re = l.map(|l| _mm512_set1_pd(l.re));
                let im = l.map(|l| _mm512_set1_pd(l.im));
                let ones = _mm512_set1_pd(1.0);
                for p in steps(n) {
                    let (at, mask) = step(p, n);
                    let x = _mm512_maskz_loadu_pd(mask, vp[0].add(at));
                    let mut same = _mm512_mul_pd(x, re[0]);
                    let mut crossed = _mm512_mul_pd(swap(x), im[0]);
                    for k in 1..4 {
                        let x = _mm512_maskz_loadu_pd(mask, vp[k].add(at));
                        same = _mm512_fmadd_pd(x, re[k], same);
                        crossed = _mm512_fmadd_pd(swap(x), im[k], crossed);
                    }
                    // (same − crossed, same + crossed) in the real and imaginary places.
                    let product = _mm512_fmaddsub_pd(same, ones, crossed);
                    let y = _mm512_maskz_loadu_pd(mask, tp.add(at));
                    _mm512_mask_storeu_pd(tp.add(at), mask, _mm512_sub_pd(y, product));
                }
            }
        }

        #[inline(always)]
        fn sub_product(&self, t: &mut [c64], v: &[c64], ld: usize, l: &[c64]) {
            let n = t.len();
            assert!(l.is_empty() || v.len() >= (l.len() - 1) * ld + n);
            let (tp, vp) = (t.as_mut_ptr().cast::<f64>(), doubles(v));
            let lp = doubles(l);
            // SAFETY: the token proves AVX-512F; column `k`'s doubles of a step under its
            // mask are inside `v` (asserted), and `l`'s parts are at `2k`, `2k + 1`.
            unsafe {
                let ones = _mm512_set1_pd(1.0);
                for p in steps(n) {
                    let (at, mask) = step(p, n);
                    let (mut same, mut crossed) = (_mm512_setzero_pd(), _mm512_setzero_pd());
                    for k in 0..l.len() {
                        let x = _mm512_maskz_loadu_pd(mask, vp.add(2 * k * ld + at));
                        same = _mm512_fmadd_pd(x, _mm512_set1_pd(*lp.add(2 * k)), same);
                        let im = _mm512_set1_pd(*lp.add(2 * k + 1));
                        crossed = _mm512_fmadd_pd(swap(x), im, crossed);
                    }
                    let product = _mm512_fmaddsub_pd(same, ones, crossed);
                    let y = _mm512_maskz_loadu_pd(mask, tp.add(at));
                    _mm512_mask_storeu_pd(tp.add(at), mask, _mm512_sub_pd(y, product));
                }
            }
        }

        /// By the AVX2 kernel: a dot product is read-bound, and the same summation order on
        /// both sets keeps their results equal to the bit.
        #[inline(always)]
        fn dot(&self, a: &[c64], b: &[c64]) -> c64 {
            // SAFETY: the token proves AVX-512F, whose machines have AVX2 and FMA.
            let [sum] = unsafe { super::avx2::dots([a], b) };
            sum
        }

        #[inline(always)]
        fn dot4(&self, a: [&[c64]; 4], b: &[c64]) -> [c64; 4] {
            // SAFETY: as in `dot`.
            unsafe { super::avx2::dots(a, b) }
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use faer::c64;

    /// The test's operands: four columns `v` (also as one column-major matrix of leading
    /// dimension `n + 3`), four multipliers `l` and a target `t`.
    struct Operands {
        v: [Vec<c64>; 4],
        matrix: Vec<c64>,
        l: [c64; 4],
        t: Vec<c64>,
    }

    /// What each kernel gives on the operands.
    struct Results {
        add: Vec<c64>,
        sub: Vec<c64>,
        sub4: Vec<c64>,
        product: Vec<c64>,
        dot: c64,
        dot4: [c64; 4],
    }

    #[inline(always)]
    fn results(k: &impl Kernels<c64>, o: &Operands) -> Results {
        let v4 = [&o.v[0][..], &o.v[1][..], &o.v[2][..], &o.v[3][..]];
        let n = o.t.len();
        let (mut add, mut sub, mut sub4, mut product) =
            (o.t.clone(), o.t.clone(), o.t.clone(), o.t.clone());
        k.add(&mut add, &o.v[0]);
        k.sub_scaled(&mut sub, &o.v[0], o.l[0]);
        k.sub_scaled4(&mut sub4, v4, o.l);
        k.sub_product(&mut product, &o.matrix, n + 3, &o.l);
        Results {
            add,
            sub,
            sub4,
            product,
            dot: k.dot(&o.v[0], &o.t),
            dot4: k.dot4(v4, &o.t),
        }
    }

    /// [`results`] by the AVX2 kernels.
    ///
    /// # Safety
    /// The machine must have AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    unsafe fn results_avx2(o: &Operands) -> Results {
        results(&avx2::Avx2(()), o)
    }

    /// [`results`] by the AVX-512 kernels.
    ///
    /// # Safety
    /// The machine must have AVX-512F.
    #[target_feature(enable = "avx512f,avx2,fma")]
    unsafe fn results_avx512(o: &Operands) -> Results {
        results(&avx512::Avx512(()), o)
    }

    /// Every set's complex kernels agree with the plain loops to the rounding of their
    /// operation orders (sums of a few unit-size products: a few ulps; `add` bit for bit), at
    /// every length up to past two AVX-512 registers, so every masked tail is run; a wrong
    /// pairing of real and imaginary parts would miss by order one.
    #[test]
    fn vector_kernels_match_the_plain_ones() {
        let isa = Isa::detected();
        let entry =
            |i: usize, s: f64| c64::new((i as f64 * 0.37 + s).sin(), (i as f64 * 0.91 - s).cos());
        for n in 0..12 {
            let v: [Vec<c64>; 4] =
                [0, 1, 2, 3].map(|k| (0..n).map(|i| entry(i, 0.2 + k as f64)).collect());
            let mut matrix = vec![c64::new(f64::NAN, 0.0); 4 * (n + 3)];
            for (k, column) in v.iter().enumerate() {
                matrix[k * (n + 3)..k * (n + 3) + n].copy_from_slice(column);
            }
            let o = Operands {
                v,
                matrix,
                l: [0.6, -0.2, 1.1, 0.3].map(|s| c64::new(s, 1.0 - 2.0 * s)),
                t: (0..n).map(|i| entry(i, 1.7)).collect(),
            };
            let plain = results(&Plain, &o);
            let mut vector: Vec<Results> = Vec::new();
            for level in [Level::Avx2, Level::Avx512] {
                if isa.level() < level {
                    continue;
                }
                let fast = match level {
                    // SAFETY: the machine has AVX2 and FMA (its detected set is at least that).
                    Level::Avx2 => unsafe { results_avx2(&o) },
                    // SAFETY: the machine has AVX-512F, likewise.
                    _ => unsafe { results_avx512(&o) },
                };
                let close = |a: c64, b: c64, tol: f64| (a - b).norm() < tol;
                for i in 0..n {
                    assert_eq!(plain.add[i], fast.add[i], "{level:?} add {n} {i}");
                    assert!(
                        close(plain.sub[i], fast.sub[i], 1e-15),
                        "{level:?} sub {n} {i}"
                    );
                    assert!(
                        close(plain.sub4[i], fast.sub4[i], 4e-15),
                        "{level:?} sub4 {n}"
                    );
                    assert!(
                        close(plain.product[i], fast.product[i], 4e-15),
                        "{level:?} {n}"
                    );
                }
                let tol = 1e-14 * (1.0 + n as f64);
                assert!(close(plain.dot, fast.dot, tol), "{level:?} dot {n}");
                for k in 0..4 {
                    assert!(
                        close(plain.dot4[k], fast.dot4[k], tol),
                        "{level:?} dot4 {n}"
                    );
                }
                vector.push(fast);
            }
            if let [avx2, avx512] = &vector[..] {
                // The two sets agree to the bit.
                assert_eq!(avx2.add, avx512.add, "{n}");
                assert_eq!(avx2.sub, avx512.sub, "{n}");
                assert_eq!(avx2.sub4, avx512.sub4, "{n}");
                assert_eq!(avx2.product, avx512.product, "{n}");
                assert_eq!((avx2.dot, avx2.dot4), (avx512.dot, avx512.dot4), "{n}");
            }
            if n > 0 {
                // The kernels changed the target, by order one.
                assert!((plain.sub[0] - o.t[0]).norm() > 0.1);
                assert!((plain.product[n - 1] - o.t[n - 1]).norm() > 0.1);
            }
        }
    }
}
