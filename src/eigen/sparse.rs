//! Lowest modes of large sparse models by shift-invert Lanczos (docs/theory.md §1, 1.7–1.12: (1.7),
//! (1.8), (1.9), (1.10), (1.11), (1.12)).
//!
//! With a shift `σ` below the wanted eigenvalues, `A = K − σM` is factored once by sparse
//! Cholesky ([`SpdFactor`]: `A = P L Lᵀ Pᵀ`, faer's AMD ordering and supernodal structure, our
//! multifrontal numeric factorisation and solves, subtrees in parallel). The operator
//! `C = L⁻¹ Pᵀ M P L⁻ᵀ` is symmetric, and its largest eigenvalues `ν = 1/(λ − σ)` belong to the
//! lowest `λ`, with eigenvectors `y = Lᵀ Pᵀ φ`. A thick-restart block Lanczos process builds an
//! orthonormal basis `V` with full re-orthogonalisation (a local and a global block
//! Gram–Schmidt pass), and the projected matrix `H = VᵀCV` is formed explicitly from the same
//! projections, so it is exact in floating point rather than assumed tridiagonal. Working
//! with `C` rather than with `A⁻¹M` in the `M`-inner product, no `M V` is stored beside the
//! basis. Ritz pairs whose Lanczos residual `‖f‖ |y_last|` falls below `tol · ν` are accepted;
//! the others seed the next cycle. The restarts combine the basis in place, by blocks of rows,
//! so no second basis is ever held.
//!
//! Free-free structures need `σ < 0`: the automatic shift is `−10⁻⁸` times the median ratio of
//! the diagonals of `K` and `M` (the scale of the model's element-level eigenvalues), or, for a
//! frequency limit, `−1 %` of its eigenvalue — far enough from zero for a stable factorisation
//! (rigid-body pivots stay eight orders above round-off), close enough that the lowest modes
//! stay well separated. The median ratio grows as the mesh is refined (as `h⁻⁴` for bending):
//! at `−10⁻⁶` of it the 1M-DOF muffler's shift sat at `−0.85 λ₁₀₀`, which slowed the
//! convergence and made the shift useless to the static correction. The final eigenvalues are
//! Rayleigh quotients `φᵀKφ` (`φᵀMφ = 1`), and every mode reports its relative residual. "All modes
//! below f" enlarges the request until a mode above `f` is found.
//!
//! Massless DOFs (stiffness, no mass) make `M` singular; `C` then has the eigenvalue `ν = 0` (the
//! infinite `λ`) on them, which is never wanted, and the start block `C X` and the refinement
//! `A⁻¹ M Φ` keep the basis in the range of `M` (purification). When few DOFs carry mass
//! (at most [`FEW_MASSIVE`], fewer than all), the Krylov space would be exhausted; the pencil is
//! then solved exactly on those DOFs `m` instead: with `G = (A⁻¹)_mm` (one solve per massive
//! DOF with the same factor) and `M_mm = L_m L_mᵀ`, the symmetric `L_mᵀ G L_m y = ν y` holds
//! every finite eigenvalue, and `φ = A⁻¹ E_m L_m y / ν` (`φᵀMφ = yᵀy = 1`).

use super::dense::{EigenError, ModeSelection, Modes, dense_generalized, fix_sign, median_ratio};
use crate::core::DofId;
use crate::core::memory::{Columns, parallel_zeros};
use crate::core::sparse::SparseMatrix;
use crate::sparse::{
    FactorError, FactorInfo, FactorStructure, FullPencil, SparseSolve, SpdFactor, SymmetricFactor,
    SymmetricPencil,
};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, MatMut, MatRef, Par, Side};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::time::Instant;

/// Settings of the sparse eigensolver.
#[derive(Clone, Debug)]
pub struct SparseEigenParams {
    /// Shift `σ` in rad²/s²; automatic when `None`.
    pub shift: Option<f64>,
    /// Relative tolerance on the operator's eigenvalues.
    pub tolerance: f64,
    /// Most restarts of the Lanczos process.
    pub max_restarts: usize,
    /// Models with at most this many DOFs use the dense path.
    pub dense_limit: usize,
    /// Seed of the start vector.
    pub seed: u64,
    /// Parallelism of the factorisation, the solves and the sparse products (the results do
    /// not depend on it).
    pub par: Par,
    /// For a frequency limit, the modes asked of the first Lanczos run (then doubled until one
    /// lies above the limit): the count an analysis of a similar model found, with a margin,
    /// spares the runs that doubling from 20 would make. `None`: 20.
    pub first_count: Option<usize>,
    /// The factor structure (ordering, supernodes) of an earlier analysis: used, without a new
    /// ordering and symbolic analysis, when `K − σM` has the pattern it was found for (an
    /// update's model at new parameter values), with the same results to the bit.
    pub structure: Option<FactorStructure>,
}

impl Default for SparseEigenParams {
    fn default() -> Self {
        SparseEigenParams {
            shift: None,
            tolerance: 1e-10,
            max_restarts: 300,
            dense_limit: 800,
            seed: 1,
            par: Par::rayon(0),
            first_count: None,
            structure: None,
        }
    }
}

/// Where the time went.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SparseEigenInfo {
    /// Shift used.
    pub shift: f64,
    /// Whether the dense path was taken.
    pub dense: bool,
    /// Seconds in the Cholesky factorisation (forming `K − σM`, symbolic and numeric).
    pub factor_seconds: f64,
    /// The factorisation's own breakdown and size.
    pub factor: FactorInfo,
    /// Seconds in triangular solves (a Lanczos step makes one backward and one forward sweep).
    pub solve_seconds: f64,
    /// Seconds in re-orthogonalisation and restarts (dense products).
    pub orthogonalisation_seconds: f64,
    /// Seconds in `M` products.
    pub mass_product_seconds: f64,
    /// Seconds in the final inverse-iteration and Rayleigh–Ritz step, residuals included.
    pub refinement_seconds: f64,
    /// Operator applications.
    pub solves: usize,
    /// Lanczos restarts.
    pub restarts: usize,
    /// Blocks that needed a third Gram–Schmidt pass (the second cancelled most of them).
    pub third_passes: usize,
}

/// The median of `K_jj / M_jj` over DOFs with mass: the scale of the model's eigenvalues.
fn eigenvalue_scale(pencil: &dyn SymmetricPencil) -> f64 {
    median_ratio((0..pencil.n()).map(|j| (pencil.k_diagonal(j), pencil.m_diagonal(j))))
}

/// The Cholesky factor of `K − σM` the modes were found with, kept for static solutions
/// (the shift is below every eigenvalue, so the matrix is positive definite).
pub struct ShiftedFactor {
    /// `K − σM = P L Lᵀ Pᵀ`.
    pub factor: SpdFactor,
    /// `σ`, rad²/s².
    pub shift: f64,
}

impl std::fmt::Debug for ShiftedFactor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShiftedFactor")
            .field("n", &self.factor.n())
            .field("shift", &self.shift)
            .field("factor_entries", &self.factor.info.factor_entries)
            .finish()
    }
}

/// Most DOFs with mass for which the eigenproblem is solved on them (module doc), rather than by
/// Lanczos, when other DOFs are massless.
pub const FEW_MASSIVE: usize = 1000;

/// The modes of `K φ = λ M φ` when only the `massive` DOFs carry mass: the dense pencil on them
/// through the factor of `A = K − σM` (module doc), in the order and count `selection` asks.
fn few_massive_modes(
    llt: &SpdFactor,
    pencil: &dyn SymmetricPencil,
    massive: &[usize],
    selection: ModeSelection,
    shift: f64,
    par: Par,
) -> Result<RefinedModes, EigenError> {
    let n = pencil.n();
    let nm = massive.len();
    let solve = |mut x: Mat<f64>| {
        llt.solve_forward_in_place(x.as_mut(), par);
        llt.solve_backward_in_place(x.as_mut(), par);
        x
    };
    // G = E_mᵀ A⁻¹ E_m, by blocks of unit columns.
    let mut g = Mat::<f64>::zeros(nm, nm);
    let width = crate::sparse::SOLVE_COLUMNS;
    for start in (0..nm).step_by(width) {
        let w = width.min(nm - start);
        let mut e = Mat::<f64>::zeros(n, w);
        for c in 0..w {
            e[(massive[start + c], c)] = 1.0;
        }
        let x = solve(e);
        for c in 0..w {
            for (r, &i) in massive.iter().enumerate() {
                g[(r, start + c)] = x[(i, c)];
            }
        }
    }
    // M_mm from the lower triangle (a massive DOF's entries with a massless one are zero).
    let mut mm = Mat::<f64>::zeros(nm, nm);
    for (c, &j) in massive.iter().enumerate() {
        for (i, v) in pencil.m_lower_entries(j) {
            if let Ok(r) = massive.binary_search(&i) {
                mm[(r, c)] += v;
                if r != c {
                    mm[(c, r)] += v;
                }
            }
        }
    }
    let lm = mm
        .llt(Side::Lower)
        .map_err(|_| EigenError::IndefiniteMass)?;
    let l = lm.L().to_owned();
    let s = l.transpose() * &g * &l;
    let s = Mat::from_fn(nm, nm, |i, j| 0.5 * (s[(i, j)] + s[(j, i)]));
    let evd = s
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| EigenError::NoConvergence)?;
    // Largest ν first = lowest λ first; ν ≤ 0 beyond round-off: no finite eigenvalue left.
    let nu: Vec<f64> = (0..nm).rev().map(|i| evd.S()[i]).collect();
    let nu_max = nu.first().copied().unwrap_or(0.0);
    let finite = nu.iter().take_while(|v| **v > 1e-12 * nu_max).count();
    let lambdas_all: Vec<f64> = nu[..finite].iter().map(|v| shift + 1.0 / v).collect();
    let keep = match selection {
        ModeSelection::All => finite,
        ModeSelection::Count(c) => c.min(finite),
        ModeSelection::BelowHz(f) => {
            let limit = (2.0 * std::f64::consts::PI * f).powi(2);
            lambdas_all.iter().take_while(|l| **l <= limit).count()
        }
    };
    let mut rhs = Mat::<f64>::zeros(n, keep);
    for j in 0..keep {
        let col = nm - 1 - j;
        for (r, &i) in massive.iter().enumerate() {
            // (L_m y)_r, L_m lower triangular.
            let mut lv = 0.0;
            for c in 0..=r {
                lv += l[(r, c)] * evd.U()[(c, col)];
            }
            rhs[(i, j)] = lv / nu[j];
        }
    }
    let mut shapes = Columns::from_mat(solve(rhs).as_ref());
    shapes.reserve_spare(keep);
    let mut mphi = Mat::<f64>::zeros(n, keep);
    let (phi, kphi) = shapes.split_spare();
    pencil.products(phi.as_ref(), kphi.subcols_mut(0, keep), mphi.as_mut(), par);
    Ok((lambdas_all[..keep].to_vec(), shapes, mphi))
}

/// Lowest modes of `K φ = λ M φ` for `K` and `M` stored in full; `dofs` labels the rows.
pub fn lowest_modes(
    k: &SparseMatrix,
    m: &SparseMatrix,
    dofs: &[DofId],
    selection: ModeSelection,
    params: &SparseEigenParams,
) -> Result<(Modes, SparseEigenInfo), EigenError> {
    let pencil = full_pencil(k, m, dofs.len())?;
    pencil_modes(&pencil, dofs, selection, params)
}

/// The pencil of `K` and `M` stored in full, over `n` DOFs: the matrices borrowed, not copied.
fn full_pencil<'a>(
    k: &'a SparseMatrix,
    m: &'a SparseMatrix,
    n: usize,
) -> Result<FullPencil<'a>, EigenError> {
    if k.nrows() != n || k.ncols() != n || m.nrows() != n || m.ncols() != n {
        return Err(EigenError::Shape {
            k: k.nrows(),
            m: m.nrows(),
            dofs: n,
        });
    }
    FullPencil::new(k, m).map_err(EigenError::PencilTooLarge)
}

/// [`lowest_modes`], handing back the factor of `K − σM` as well (`None` on the dense path), so
/// that static solutions at the same shift need no second factorisation.
pub fn lowest_modes_keeping_factor(
    k: &SparseMatrix,
    m: &SparseMatrix,
    dofs: &[DofId],
    selection: ModeSelection,
    params: &SparseEigenParams,
) -> Result<(Modes, SparseEigenInfo, Option<ShiftedFactor>), EigenError> {
    let pencil = full_pencil(k, m, dofs.len())?;
    pencil_modes_keeping_factor(&pencil, dofs, selection, params)
}

/// [`lowest_modes`] of a pencil: held as lower triangles ([`crate::sparse::LowerPencil`], what
/// the `modes` stage reads from a matrices artefact: no full matrices are built), or as full
/// matrices borrowed ([`FullPencil`], what [`lowest_modes`] passes). The factor is freed as soon as the last
/// solve is made, before the refinement's products are allocated (at a million DOFs the
/// solver's peak is then the Lanczos process's).
pub fn pencil_modes(
    pencil: &dyn SymmetricPencil,
    dofs: &[DofId],
    selection: ModeSelection,
    params: &SparseEigenParams,
) -> Result<(Modes, SparseEigenInfo), EigenError> {
    solve_pencil(pencil, dofs, selection, params, false).map(|(modes, info, _)| (modes, info))
}

/// [`lowest_modes_keeping_factor`] of a pencil (see [`pencil_modes`]).
pub fn pencil_modes_keeping_factor(
    pencil: &dyn SymmetricPencil,
    dofs: &[DofId],
    selection: ModeSelection,
    params: &SparseEigenParams,
) -> Result<(Modes, SparseEigenInfo, Option<ShiftedFactor>), EigenError> {
    solve_pencil(pencil, dofs, selection, params, true)
}

/// The lowest modes of the pencil, with the factor of `K − σM` when `keep_factor` (and a
/// sparse path was taken).
fn solve_pencil(
    pencil: &dyn SymmetricPencil,
    dofs: &[DofId],
    selection: ModeSelection,
    params: &SparseEigenParams,
    keep_factor: bool,
) -> Result<(Modes, SparseEigenInfo, Option<ShiftedFactor>), EigenError> {
    let n = dofs.len();
    if pencil.n() != n {
        return Err(EigenError::Shape {
            k: pencil.n(),
            m: pencil.n(),
            dofs: n,
        });
    }
    for (j, dof) in dofs.iter().enumerate() {
        let (kj, mj) = (pencil.k_diagonal(j), pencil.m_diagonal(j));
        if !(mj >= 0.0) {
            return Err(EigenError::MasslessDof {
                dof: *dof,
                value: mj,
            });
        }
        if kj == 0.0 && mj == 0.0 {
            return Err(EigenError::Unsupported { dof: *dof });
        }
    }
    if n <= params.dense_limit {
        let modes = dense_generalized(
            pencil.k_dense().as_ref(),
            pencil.m_dense().as_ref(),
            dofs,
            selection,
        )?;
        return Ok((
            modes,
            SparseEigenInfo {
                dense: true,
                ..Default::default()
            },
            None,
        ));
    }
    let scale = eigenvalue_scale(pencil);
    let shift = params.shift.unwrap_or(match selection {
        ModeSelection::BelowHz(f) => {
            -0.01 * (2.0 * std::f64::consts::PI * f).powi(2).max(1e-12 * scale)
        }
        _ => -1e-8 * scale,
    });
    let mut info = SparseEigenInfo {
        shift,
        ..Default::default()
    };
    let t0 = Instant::now();
    // A = K − σM over the union pattern, lower triangle.
    let a = pencil.lower_combination(1.0, -shift);
    let llt =
        SpdFactor::consuming_on(a, params.par, params.structure.as_ref()).map_err(|e| match e {
            FactorError::NotPositiveDefinite => EigenError::NotPositiveDefinite { shift },
            FactorError::OutOfMemory => EigenError::FactorTooLarge { n },
        })?;
    // The factorisation's work arrays are freed; hand their pages back before the Krylov
    // basis is allocated, so the two peaks do not add up.
    crate::core::memory::release_freed_memory();
    info.factor = llt.info;
    info.factor_seconds = t0.elapsed().as_secs_f64();
    crate::core::progress::step(
        || {
            format!(
                "modes: K − σM factorised ({n} DOFs, {:.1} s)",
                info.factor_seconds
            )
        },
        0,
        0,
    );
    let massive: Vec<usize> = (0..n).filter(|&j| pencil.has_mass(j)).collect();
    if massive.len() < n && massive.len() <= FEW_MASSIVE {
        let t = Instant::now();
        let (lambdas, vecs, mphi) =
            few_massive_modes(&llt, pencil, &massive, selection, shift, params.par)?;
        info.solves += massive.len() + lambdas.len();
        let modes = finish(pencil, lambdas, vecs, mphi, shift, scale)?;
        info.refinement_seconds = t.elapsed().as_secs_f64();
        let factor = ShiftedFactor { factor: llt, shift };
        return Ok((modes, info, Some(factor)));
    }

    let (mut lambdas, mut ritz_images, counted) = match selection {
        ModeSelection::All => return Err(EigenError::AllModesOfLargeModel { n }),
        ModeSelection::Count(c) => {
            let (l, v) = lanczos(&llt, pencil, n, c.min(n / 2), shift, params, &mut info)?;
            (l, v, c.min(n / 2))
        }
        ModeSelection::BelowHz(f) => {
            let limit = (2.0 * std::f64::consts::PI * f).powi(2);
            let mut count = match params.first_count {
                Some(c) => c.clamp(1, (n / 2).max(1)),
                None => 20.min(n),
            };
            loop {
                let (l, v) = lanczos(&llt, pencil, n, count, shift, params, &mut info)?;
                if l.last().is_some_and(|x| *x > limit) || count >= n / 2 {
                    let keep = l.iter().take_while(|x| **x <= limit).count();
                    break (l, v, keep);
                }
                count = (count * 2).min(n / 2);
            }
        }
    };
    lambdas.truncate(counted);
    ritz_images.keep_leading(counted, counted);
    let (mut vecs, mut mphi) = (Columns::zeros(n, 0), Mat::zeros(n, 0));
    let t = Instant::now();
    // X = A⁻¹ M Φ = P L⁻ᵀ (C Y) for the Ritz vectors (see `refine`): the last solve.
    if counted > 0 {
        llt.solve_backward_in_place(ritz_images.as_mut(), params.par);
    }
    let factor = keep_factor.then_some(ShiftedFactor { factor: llt, shift });
    if counted > 0 {
        (lambdas, vecs, mphi) = refine(pencil, ritz_images, params.par)?;
        info.solves += counted;
    }
    let modes = finish(pencil, lambdas, vecs, mphi, shift, scale)?;
    info.refinement_seconds = t.elapsed().as_secs_f64();
    Ok((modes, info, factor))
}

/// Eigenvalues, shapes `Φ` with `KΦ` in their spare columns, and `MΦ`.
type RefinedModes = (Vec<f64>, Columns, Mat<f64>);

/// One block inverse-iteration step and a Rayleigh–Ritz projection: `X = A⁻¹ M Φ` for the
/// Ritz vectors `Φ = P L⁻ᵀ Y`, which the caller forms as `P L⁻ᵀ (C Y)` from the `C Y` that
/// [`lanczos`] hands over (one backward sweep), then the small pencil `(XᵀKX, XᵀMX)`. The
/// Lanczos residual bounds the error of `Y` in the metric of `C`, where the stiff modes weigh
/// little; this step divides their share by `ν_high/ν_low`, so the residuals
/// `‖Kφ − λMφ‖ / ‖Kφ‖` reach round-off level.
fn refine(pencil: &dyn SymmetricPencil, x: Columns, par: Par) -> Result<RefinedModes, EigenError> {
    let (n, c) = (x.nrows(), x.ncols());
    let mut x = x;
    // `K X` where the basis's next columns were (spare), `M X` fresh.
    x.reserve_spare(c);
    let mut mx = parallel_zeros(n, c);
    let (mut x_cols, kx) = x.split_spare();
    let mut kx = kx.subcols_mut(0, c);
    pencil.products(x_cols.as_ref(), kx.as_mut(), mx.as_mut(), par);
    let kr = x_cols.as_ref().transpose() * kx.as_ref();
    let mr = x_cols.as_ref().transpose() * &mx;
    let kr = Mat::from_fn(c, c, |i, j| 0.5 * (kr[(i, j)] + kr[(j, i)]));
    let mr = Mat::from_fn(c, c, |i, j| 0.5 * (mr[(i, j)] + mr[(j, i)]));
    // XᵀMX is well conditioned (X is nearly M-orthogonal): reduce by its Cholesky factor.
    // Rigid-body and sign decisions are left to `finish`, which knows the full problem's scale.
    let llt_m = mr.llt(Side::Lower).map_err(|_| EigenError::NoConvergence)?;
    let l = llt_m.L();
    let mut a = kr.clone();
    solve_lower_triangular_in_place(l, a.as_mut(), Par::Seq);
    let mut a = a.transpose().to_owned();
    solve_lower_triangular_in_place(l, a.as_mut(), Par::Seq);
    let a = Mat::from_fn(c, c, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let evd = a
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| EigenError::NoConvergence)?;
    let lambdas: Vec<f64> = (0..c).map(|i| evd.S()[i]).collect();
    let mut y = evd.U().to_owned();
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(
        l.transpose(),
        y.as_mut(),
        Par::Seq,
    );
    // Φ = X y, and KΦ, MΦ from the products already formed, each in place.
    for z in [x_cols.as_mut(), kx.as_mut(), mx.as_mut()] {
        combine_in_place(z, y.as_ref());
    }
    Ok((lambdas, x, mx))
}

/// Rayleigh quotients, residuals, orthogonality and sign convention for computed pairs.
/// `KΦ` (in the spare columns of `shapes`) and `mphi` = `MΦ` are handed on by [`refine`] so
/// no sparse product is repeated.
fn finish(
    pencil: &dyn SymmetricPencil,
    mut lambdas: Vec<f64>,
    mut shapes: Columns,
    mut mphi: Mat<f64>,
    shift: f64,
    scale: f64,
) -> Result<Modes, EigenError> {
    let (n, c) = (shapes.nrows(), shapes.ncols());
    let largest = lambdas.iter().fold(0.0f64, |s, l| s.max(l.abs()));
    let k_norm = (0..n)
        .map(|j| pencil.k_diagonal(j).abs())
        .fold(0.0f64, f64::max);
    // Each mode on its own (in parallel over the modes, each sum in row order as on one
    // thread): `(λ, residual, rigid)`, or the first indefinite mode's error.
    let (phis, kphi) = shapes.split_spare();
    let per_mode: Vec<Result<(f64, f64, bool), EigenError>> = phis
        .par_col_iter_mut()
        .zip(kphi.subcols_mut(0, c).par_col_iter_mut())
        .zip(mphi.as_mut().par_col_iter_mut())
        .map(|((mut phi, mut kp), mut mp)| {
            let (mut pkp, mut pmp) = (0.0, 0.0);
            for i in 0..n {
                pkp += phi[i] * kp[i];
                pmp += phi[i] * mp[i];
            }
            let mut lam = pkp / pmp;
            // Rigid-body modes carry round-off of the stiff modes, ~ε·λ_max: 10⁻¹² of the
            // model's eigenvalue scale (the median `K_jj/M_jj`) bounds it, as in the dense
            // path, whatever the shift (a frequency limit under the first elastic mode gives a
            // tiny one).
            let rigid = lam.abs()
                <= (1e-10 * largest)
                    .max(1e-6 * shift.abs())
                    .max(1e-12 * scale)
                    .max(f64::MIN_POSITIVE);
            if rigid {
                lam = 0.0;
            } else if lam < 0.0 {
                return Err(EigenError::IndefiniteStiffness {
                    value: lam,
                    largest,
                });
            }
            let s = 1.0 / pmp.sqrt();
            let (mut r2, mut k2, mut p2) = (0.0, 0.0, 0.0);
            for i in 0..n {
                phi[i] *= s;
                let (kv, mv) = (kp[i] * s, mp[i] * s);
                kp[i] = kv;
                mp[i] = mv;
                let res = kv - lam * mv;
                r2 += res * res;
                k2 += kv * kv;
                p2 += phi[i] * phi[i];
            }
            let denom = if lam == 0.0 {
                k_norm * p2.sqrt()
            } else {
                k2.sqrt()
            };
            let residual = if denom > 0.0 { r2.sqrt() / denom } else { 0.0 };
            if fix_sign(phi.as_mut()) {
                for i in 0..n {
                    mp[i] = -mp[i];
                }
            }
            Ok((lam, residual, rigid))
        })
        .collect();
    let mut residuals = Vec::with_capacity(c);
    let mut rigid = 0;
    for (r, mode) in per_mode.into_iter().enumerate() {
        let (lam, residual, is_rigid) = mode?;
        lambdas[r] = lam;
        residuals.push(residual);
        rigid += usize::from(is_rigid);
    }
    // ΦᵀMΦ − I before the re-sort, which permutes its rows and columns alike.
    let gram = shapes.as_ref().transpose() * &mphi;
    // The shapes' storage was the Krylov basis's: the modes keep a matrix of their own, the
    // one `MΦ` (no longer needed, of the same shape) was in, rather than fresh memory.
    let mut owned = mphi;
    owned.copy_from(shapes.as_ref());
    drop(shapes);
    let mut shapes = owned;
    // Re-sort: Rayleigh quotients may swap nearly repeated pairs.
    let mut order: Vec<usize> = (0..c).collect();
    order.sort_by(|a, b| lambdas[*a].total_cmp(&lambdas[*b]));
    permute_columns(&mut shapes, &order);
    let lambdas: Vec<f64> = order.iter().map(|&j| lambdas[j]).collect();
    let residuals: Vec<f64> = order.iter().map(|&j| residuals[j]).collect();
    let mut orthogonality_error = 0.0f64;
    for i in 0..c {
        for j in 0..c {
            let t = if i == j { 1.0 } else { 0.0 };
            orthogonality_error = orthogonality_error.max((gram[(i, j)] - t).abs());
        }
    }
    Ok(Modes {
        eigenvalues: lambdas,
        shapes,
        residuals,
        orthogonality_error,
        rigid_body_modes: rigid,
    })
}

/// Column `j` of `a` becomes its column `order[j]`, following the permutation's cycles with one
/// column held aside (no second copy of `a`).
fn permute_columns(a: &mut Mat<f64>, order: &[usize]) {
    let mut placed = vec![false; order.len()];
    for start in 0..order.len() {
        if placed[start] || order[start] == start {
            continue;
        }
        let held = a.col(start).to_owned();
        let mut j = start;
        while order[j] != start {
            let source = a.col(order[j]).to_owned();
            a.col_mut(j).copy_from(&source);
            placed[j] = true;
            j = order[j];
        }
        a.col_mut(j).copy_from(&held);
        placed[j] = true;
    }
}

/// One block Gram–Schmidt pass, `w ← w − basis · (basisᵀ w)`; returns the coefficients.
fn project_once(basis: MatRef<'_, f64>, w: MatMut<'_, f64>) -> Mat<f64> {
    let mut c = Mat::<f64>::zeros(basis.ncols(), w.ncols());
    project_once_into(basis, w, c.as_mut());
    c
}

/// [`project_once`], writing the coefficients into `c`. Both products run by tiles of rows
/// shared among the threads: `basisᵀ w` as a sum of the tiles' products in row order (so the
/// result does not depend on the threads), then `w ← w − basis c` tile by tile. (faer's
/// products split the `p × b` result among the threads, and it is too small to share.)
fn project_once_into(basis: MatRef<'_, f64>, w: MatMut<'_, f64>, mut c: MatMut<'_, f64>) {
    let mut tiles = Vec::new();
    tile_inner_products(basis, w.as_ref(), &mut tiles);
    c.fill(0.0);
    for tile in &tiles {
        c += tile;
    }
    subtract_product_by_tiles(basis, c.as_ref(), w);
}

/// Rows per tile of the dense products with the Krylov basis.
const PRODUCT_ROWS: usize = 4096;

/// Where `rows` rows split in two at a tile boundary, or `None` for one tile: the split
/// depends on the row count alone, so sums over the tiles in row order do not depend on the
/// threads.
fn tile_split(rows: usize) -> Option<usize> {
    (rows > PRODUCT_ROWS).then(|| (rows / 2).div_ceil(PRODUCT_ROWS) * PRODUCT_ROWS)
}

/// The tiles' `basis_tᵀ w_t`, in row order; the rows halved recursively at tile boundaries
/// (a split that depends on the row count alone).
fn tile_inner_products(basis: MatRef<'_, f64>, w: MatRef<'_, f64>, tiles: &mut Vec<Mat<f64>>) {
    if let Some(half) = tile_split(w.nrows()) {
        let (b_top, b_bottom) = basis.split_at_row(half);
        let (w_top, w_bottom) = w.split_at_row(half);
        let (mut above, mut below) = (Vec::new(), Vec::new());
        rayon::join(
            || tile_inner_products(b_top, w_top, &mut above),
            || tile_inner_products(b_bottom, w_bottom, &mut below),
        );
        tiles.append(&mut above);
        tiles.append(&mut below);
    } else {
        tiles.push(basis.transpose() * w);
    }
}

/// `w ← w − basis c`, by tiles of rows.
fn subtract_product_by_tiles(basis: MatRef<'_, f64>, c: MatRef<'_, f64>, w: MatMut<'_, f64>) {
    if let Some(half) = tile_split(w.nrows()) {
        let (b_top, b_bottom) = basis.split_at_row(half);
        let (w_top, w_bottom) = w.split_at_row_mut(half);
        rayon::join(
            || subtract_product_by_tiles(b_top, c, w_top),
            || subtract_product_by_tiles(b_bottom, c, w_bottom),
        );
    } else {
        faer::linalg::matmul::matmul(w, faer::Accum::Add, basis, c, -1.0, Par::Seq);
    }
}

/// `w ← w − basis · (basisᵀ · w)` twice (classical Gram–Schmidt with one
/// re-orthogonalisation); returns the summed projection coefficients.
fn project_out(basis: MatRef<'_, f64>, mut w: MatMut<'_, f64>) -> Mat<f64> {
    let mut c = project_once(basis, w.as_mut());
    c += project_once(basis, w);
    c
}

/// Departure of an orthonormalised block's Gram matrix from the identity below which a
/// second Cholesky QR pass is skipped (the second pass would leave round-off of this order).
const GRAM_TOLERANCE: f64 = 1e-13;

/// Orthonormalises the block `q` in place by Cholesky QR: `q ← q L⁻ᵀ` for `qᵀq = L Lᵀ`, the
/// Gram matrix of the result formed in the same pass over the rows. A second pass runs only
/// when that Gram matrix is not the identity to [`GRAM_TOLERANCE`] (CholeskyQR2's reason: one
/// pass leaves an error of order `ε κ(q)²`). Returns `(Q, R)` with `q = Q R`, or `None` when
/// the block is rank-deficient.
fn cholesky_qr(mut q: Mat<f64>) -> Option<(Mat<f64>, Mat<f64>)> {
    let b = q.ncols();
    let mut r_total = Mat::<f64>::identity(b, b);
    let mut g = q.transpose() * &q;
    for _ in 0..2 {
        let g_sym = Mat::from_fn(b, b, |i, j| 0.5 * (g[(i, j)] + g[(j, i)]));
        let llt = g_sym.llt(Side::Lower).ok()?;
        let l = llt.L();
        let diag_min = (0..b).map(|i| l[(i, i)]).fold(f64::INFINITY, f64::min);
        let diag_max = (0..b).map(|i| l[(i, i)]).fold(0.0f64, f64::max);
        if !(diag_min > 1e-10 * diag_max) {
            return None;
        }
        // R = Lᵀ; q ← q R⁻¹ = q L⁻ᵀ, as one product with the small inverse.
        let mut l_inv = Mat::<f64>::identity(b, b);
        solve_lower_triangular_in_place(l, l_inv.as_mut(), Par::Seq);
        g = transform_rows_with_gram(q.as_mut(), l_inv.transpose());
        r_total = l.transpose() * &r_total;
        if (&g - Mat::<f64>::identity(b, b)).norm_max() <= GRAM_TOLERANCE {
            break;
        }
    }
    Some((q, r_total))
}

/// `q ← q t` in place for a small square `t`, returning `qᵀ q` of the result: one parallel
/// pass over the rows, each tile transformed while it is in cache. The tiles' Gram matrices
/// are summed in tile order, so the result does not depend on the threads.
fn transform_rows_with_gram(q: MatMut<'_, f64>, t: MatRef<'_, f64>) -> Mat<f64> {
    let b = q.ncols();
    let mut grams = Vec::new();
    tile_grams(q, t, &mut grams);
    let mut g = Mat::<f64>::zeros(b, b);
    for tile in &grams {
        g += tile;
    }
    g
}

/// The tiles of [`transform_rows_with_gram`], halved recursively at tile boundaries (a split
/// that depends on the row count alone), their Gram matrices appended in row order.
fn tile_grams(mut q: MatMut<'_, f64>, t: MatRef<'_, f64>, grams: &mut Vec<Mat<f64>>) {
    if let Some(half) = tile_split(q.nrows()) {
        let (top, bottom) = q.split_at_row_mut(half);
        let (mut above, mut below) = (Vec::new(), Vec::new());
        rayon::join(
            || tile_grams(top, t, &mut above),
            || tile_grams(bottom, t, &mut below),
        );
        grams.append(&mut above);
        grams.append(&mut below);
    } else {
        let qt = q.as_ref() * t;
        q.copy_from(&qt);
        grams.push(qt.transpose() * &qt);
    }
}

/// One more Gram–Schmidt pass on an orthonormalised block `w = V c + Q R` whose last pass
/// cancelled most of it: `Q = V c₃ + Q₂ R₂`, so that `w = V (c + c₃ R) + Q₂ (R₂ R)`. Updates
/// `c`; returns `(Q₂, R₂ R)`, or `None` when `Q₂` is rank-deficient.
fn reorthogonalise(
    basis: MatRef<'_, f64>,
    (mut q, r): (Mat<f64>, Mat<f64>),
    c: &mut Mat<f64>,
) -> Option<(Mat<f64>, Mat<f64>)> {
    let c3 = project_once(basis, q.as_mut());
    let (q2, r2) = cholesky_qr(q)?;
    *c += &c3 * &r;
    Some((q2, &r2 * &r))
}

/// The largest ratio, over the columns of a block, of what a re-orthogonalisation pass removed
/// (`c`, coefficients on an orthonormal basis) to the norm of what it left (`R`'s column, the
/// block being `Q R`). Above 1 the pass cancelled most of the vector, so its result carries
/// the first pass's round-off at full size and needs one more pass (Daniel, Gragg, Kaufman
/// and Stewart's criterion, `‖w_after‖ < ‖w_before‖/√2`).
fn cancellation(c: MatRef<'_, f64>, r: MatRef<'_, f64>) -> f64 {
    (0..c.ncols())
        .map(|j| c.col(j).norm_l2() / r.col(j).norm_l2())
        .fold(0.0, f64::max)
}

/// `C X = L⁻¹ Pᵀ M P L⁻ᵀ X` (1.9 through the factor `A = P L Lᵀ Pᵀ`): the backward sweep, a
/// product with `M`, the forward sweep. `C` is symmetric and its eigenvalues are those of
/// `A⁻¹ M`, `ν = 1/(λ − σ)`, with eigenvectors `y = Lᵀ Pᵀ φ`.
fn apply_operator(
    llt: &impl SymmetricFactor,
    pencil: &dyn SymmetricPencil,
    mut x: Mat<f64>,
    par: Par,
    info: &mut SparseEigenInfo,
) -> Mat<f64> {
    let t = Instant::now();
    llt.solve_backward_in_place(x.as_mut(), par);
    info.solve_seconds += t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut y = Mat::<f64>::zeros(x.nrows(), x.ncols());
    pencil.mass_product(x.as_ref(), y.as_mut(), par);
    drop(x);
    info.mass_product_seconds += t.elapsed().as_secs_f64();
    let t = Instant::now();
    llt.solve_forward_in_place(y.as_mut(), par);
    info.solve_seconds += t.elapsed().as_secs_f64();
    info.solves += y.ncols();
    y
}

/// Ritz values `ν` (largest first), their vectors `Y` in the basis, and how many of the
/// leading ones converged.
type RitzPairs = (Vec<f64>, Mat<f64>, usize);

/// Block thick-restart Lanczos on the symmetric `C = L⁻¹ Pᵀ M P L⁻ᵀ` ([`apply_operator`]),
/// with blocks of `b` vectors so that every pass over the Cholesky factor serves `b`
/// right-hand sides (the solves are memory-bound). The basis is orthonormal in the plain inner
/// product, so no `M V` is stored beside it (one array the size of the basis less). Returns
/// the `nev` lowest `λ` (ascending) and `C Y` for their Ritz vectors `Y` (what [`refine`]
/// starts from: `P L⁻ᵀ C Y = A⁻¹ M Φ` for the modes `Φ = P L⁻ᵀ Y`).
fn lanczos(
    llt: &impl SymmetricFactor,
    pencil: &dyn SymmetricPencil,
    n: usize,
    nev: usize,
    shift: f64,
    params: &SparseEigenParams,
    info: &mut SparseEigenInfo,
) -> Result<(Vec<f64>, Columns), EigenError> {
    let mut process = Lanczos::start(llt, pencil, n, nev, params, info)?;
    let mut kept = 0usize;
    for restart in 0..=params.max_restarts {
        info.restarts = restart;
        let (filled, early) = process.fill(kept, nev, info)?;
        // Rayleigh–Ritz on H, as far as the basis was filled.
        let t = Instant::now();
        let (theta, y, converged) = match early {
            Some(pairs) => pairs,
            None => ritz(
                process.h.as_ref(),
                filled,
                process.r_last.as_ref(),
                nev,
                params,
            )?,
        };
        crate::core::progress::step(|| "modes converged".into(), converged as u64, nev as u64);
        if converged >= nev || restart == params.max_restarts {
            if converged < nev {
                return Err(EigenError::NotConverged {
                    converged,
                    wanted: nev,
                    restarts: restart,
                });
            }
            let images = process.into_ritz_images(&theta[..nev], y.subcols(0, nev), filled);
            info.orthogonalisation_seconds += t.elapsed().as_secs_f64();
            let lambdas: Vec<f64> = theta[..nev].iter().map(|nu| shift + 1.0 / nu).collect();
            return Ok((lambdas, images));
        }
        kept = process.thick_restart(&theta, y.as_ref(), nev, converged)?;
        info.orthogonalisation_seconds += t.elapsed().as_secs_f64();
    }
    Err(EigenError::NoConvergence)
}

/// The state of [`lanczos`]: the basis `V` (`n × p`, blocks of `b`), the projected matrix
/// `H = VᵀCV`, and the block `F` after the basis with its coupling `R` (`C V = V H + F R E`,
/// `E` selecting the last block).
struct Lanczos<'a, F> {
    llt: &'a F,
    pencil: &'a dyn SymmetricPencil,
    params: &'a SparseEigenParams,
    b: usize,
    p: usize,
    v: Columns,
    h: Mat<f64>,
    /// `F` and `R`: set by every block before they are read.
    f: Mat<f64>,
    r_last: Mat<f64>,
    rng: rand_chacha::ChaCha8Rng,
}

impl<'a, F: SymmetricFactor> Lanczos<'a, F> {
    /// Sizes the block and the basis for `nev` pairs and sets the first block.
    fn start(
        llt: &'a F,
        pencil: &'a dyn SymmetricPencil,
        n: usize,
        nev: usize,
        params: &'a SparseEigenParams,
        info: &mut SparseEigenInfo,
    ) -> Result<Self, EigenError> {
        let b = block_size(nev).min(nev.max(1));
        // A basis of 2.5 nev rather than 2 nev: the extra vectors save a restart cycle, so the
        // modes converge with about as many Lanczos vectors as they would without any restart.
        let want = (5 * nev / 2).max(nev + 3 * b);
        let p = (want.div_ceil(b) * b).min((n - b) / b * b).max(2 * b);
        if p <= nev {
            return Err(EigenError::NoConvergence);
        }
        let mut process = Lanczos {
            llt,
            pencil,
            params,
            b,
            p,
            // A gigabyte at 10⁶ DOFs: first touched by all threads.
            v: Columns::zeros(n, p),
            h: Mat::zeros(p, p),
            f: Mat::new(),
            r_last: Mat::new(),
            rng: rand_chacha::ChaCha8Rng::seed_from_u64(params.seed),
        };
        let start = process.random_block(info);
        let (q, _) = cholesky_qr(start).ok_or(EigenError::NoConvergence)?;
        process.v.as_mut().subcols_mut(0, b).copy_from(&q);
        Ok(process)
    }

    /// A random block mapped by the operator: it starts inside the operator's range (which
    /// kills components along massless DOFs).
    fn random_block(&mut self, info: &mut SparseEigenInfo) -> Mat<f64> {
        let (n, b) = (self.v.nrows(), self.b);
        let x: Mat<f64> = Mat::from_fn(n, b, |_, _| self.rng.random::<f64>() - 0.5);
        apply_operator(self.llt, self.pencil, x, self.params.par, info)
    }

    /// Fills the basis block by block from column `kept`. Past `nev + b` vectors the wanted
    /// Ritz pairs may have converged before the basis is full: the check costs an
    /// eigensolution of `H` (about a millisecond), a block's solves far more. Returns the
    /// columns filled and the Ritz pairs of a check that found them converged.
    fn fill(
        &mut self,
        kept: usize,
        nev: usize,
        info: &mut SparseEigenInfo,
    ) -> Result<(usize, Option<RitzPairs>), EigenError> {
        let mut s0 = kept;
        while s0 < self.p {
            self.extend(s0, kept, info)?;
            s0 += self.b;
            crate::core::progress::step(
                || "modes: Lanczos vectors".into(),
                s0 as u64,
                self.p as u64,
            );
            if s0 < self.p && s0 >= nev + self.b {
                let t = Instant::now();
                let pairs = ritz(self.h.as_ref(), s0, self.r_last.as_ref(), nev, self.params)?;
                info.orthogonalisation_seconds += t.elapsed().as_secs_f64();
                if pairs.2 >= nev {
                    return Ok((s0, Some(pairs)));
                }
            }
        }
        Ok((s0, None))
    }

    /// One Lanczos step: `C` applied to the block at `s0`, orthogonalised against the basis
    /// so far; its coefficients enter `H`, and the orthonormal result becomes the next block
    /// (or `F`, past the basis's end).
    fn extend(
        &mut self,
        s0: usize,
        kept: usize,
        info: &mut SparseEigenInfo,
    ) -> Result<(), EigenError> {
        let b = self.b;
        let x = self.v.as_ref().subcols(s0, b).to_owned();
        let mut w = apply_operator(self.llt, self.pencil, x, self.params.par, info);
        let t = Instant::now();
        let upto = s0 + b;
        // In exact arithmetic the new block couples only to the current and the previous
        // block, and, first after a thick restart, to every kept Ritz vector (the arrowhead).
        // One pass against those removes the bulk; one pass against the whole basis then
        // removes what round-off left along the rest: the basis is read twice instead of four
        // times (classical Gram–Schmidt, twice, over everything).
        let local = if s0 > kept { s0 - b } else { 0 };
        let basis = self.v.as_ref().subcols(0, upto);
        let mut c = Mat::<f64>::zeros(upto, b);
        project_once_into(
            basis.subcols(local, upto - local),
            w.as_mut(),
            c.as_mut().subrows_mut(local, upto - local),
        );
        let full = project_once(basis, w.as_mut());
        c += &full;
        let orthonormal = cholesky_qr(w).and_then(|(q, r)| {
            if cancellation(full.as_ref(), r.as_ref()) <= 1.0 {
                return Some((q, r));
            }
            info.third_passes += 1;
            reorthogonalise(basis, (q, r), &mut c)
        });
        for jj in 0..b {
            for i in 0..upto {
                self.h[(i, s0 + jj)] = c[(i, jj)];
                self.h[(s0 + jj, i)] = c[(i, jj)];
            }
        }
        info.orthogonalisation_seconds += t.elapsed().as_secs_f64();
        let next = match orthonormal {
            Some(x) => x,
            None => {
                // (Near-)invariant subspace: continue with fresh directions, uncoupled.
                let mut fresh = self.random_block(info);
                project_out(self.v.as_ref().subcols(0, upto), fresh.as_mut());
                let (q, _) = cholesky_qr(fresh).ok_or(EigenError::NoConvergence)?;
                (q, Mat::zeros(b, b))
            }
        };
        if upto < self.p {
            self.v.as_mut().subcols_mut(upto, b).copy_from(&next.0);
        }
        (self.f, self.r_last) = next;
        Ok(())
    }

    /// `C V Y = V (H Y) + F R Y_last = V Y Θ + F R Y_last` (the Lanczos relation) for the Ritz
    /// vectors `Y` with values `theta`, over the `filled` columns of the basis: formed in one
    /// parallel pass over the basis's rows, in place of its leading columns, whose storage is
    /// then all that is kept (the images are never held beside the basis, and the
    /// refinement's work fits where the rest of it was).
    fn into_ritz_images(self, theta: &[f64], y: MatRef<'_, f64>, filled: usize) -> Columns {
        let b = self.b;
        let coupling = &self.r_last * y.subrows(filled - b, b);
        let mut v = self.v;
        ritz_images_in_place(
            v.as_mut(),
            filled,
            y,
            theta,
            self.f.as_ref(),
            coupling.as_ref(),
        );
        // The columns after the images stay as spare, for the refinement's `K X`.
        v.keep_leading(y.ncols(), y.ncols());
        v
    }

    /// Thick restart: the basis becomes the leading Ritz vectors (at least one more than
    /// converged, about half the basis), `H` their values, then the residual block `F`;
    /// blocks must tile up to `p`. Returns the number kept.
    fn thick_restart(
        &mut self,
        theta: &[f64],
        y: MatRef<'_, f64>,
        nev: usize,
        converged: usize,
    ) -> Result<usize, EigenError> {
        let (p, b) = (self.p, self.b);
        let shrink = ((p - nev) / 2 / b).max(1) * b;
        let keep = (p - shrink).max(converged + 1).min(p - b);
        let keep = (p - (p - keep).div_ceil(b) * b).max(1);
        if keep + b > p {
            return Err(EigenError::NoConvergence);
        }
        combine_in_place(self.v.as_mut(), y.subcols(0, keep));
        self.h.fill(0.0);
        for (c, &nu) in theta.iter().take(keep).enumerate() {
            self.h[(c, c)] = nu;
        }
        self.v.as_mut().subcols_mut(keep, b).copy_from(&self.f);
        Ok(keep)
    }
}

/// Ritz pairs of the leading `size × size` block of `H`, largest `ν` first: `(ν, Y, converged)`,
/// where `converged` counts the leading pairs among the first `nev` whose Lanczos residual
/// `‖R y_last‖` (`R` coupling the basis to the next block, `y_last` the vector's last `b`
/// entries) is at most `tol · ν`.
fn ritz(
    h: MatRef<'_, f64>,
    size: usize,
    r_last: MatRef<'_, f64>,
    nev: usize,
    params: &SparseEigenParams,
) -> Result<(Vec<f64>, Mat<f64>, usize), EigenError> {
    let b = r_last.ncols();
    let evd = h
        .submatrix(0, 0, size, size)
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| EigenError::NoConvergence)?;
    // faer orders the eigenvalues ascending: reverse.
    let theta: Vec<f64> = (0..size).rev().map(|i| evd.S()[i]).collect();
    let y = Mat::from_fn(size, size, |i, c| evd.U()[(i, size - 1 - c)]);
    let last = r_last * y.subrows(size - b, b);
    let converged = (0..nev.min(size))
        .take_while(|&c| last.col(c).norm_l2() <= params.tolerance * theta[c].abs())
        .count();
    Ok((theta, y, converged))
}

/// Lanczos block size: the number of right-hand sides per pass over the factor. A pass with
/// 16 columns costs little more than one with 8 (the solves are memory-bound), but a larger
/// block converges more slowly per vector: 16 pays off once the basis (`2·nev`) holds a dozen
/// blocks of 16. With a smaller basis the slower convergence costs more restarts than the
/// wider passes save.
fn block_size(nev: usize) -> usize {
    if 2 * nev >= 12 * 16 { 16 } else { 8 }
}

/// `V[:, ..k] ← V[:, ..filled] Y Θ + F G` for `Y` of `k` columns (the Ritz vectors' images
/// `C V Y` by the Lanczos relation, `G = R Y_last`) by tiles of rows in parallel, each formed
/// while its rows of `V` and `F` are in cache: one read of the basis. A tile's rows depend on
/// its own rows alone, so each is written back over the basis once formed.
fn ritz_images_in_place(
    v: MatMut<'_, f64>,
    filled: usize,
    y: MatRef<'_, f64>,
    theta: &[f64],
    f: MatRef<'_, f64>,
    g: MatRef<'_, f64>,
) {
    if let Some(half) = tile_split(v.nrows()) {
        let (v_top, v_bottom) = v.split_at_row_mut(half);
        let (f_top, f_bottom) = f.split_at_row(half);
        rayon::join(
            || ritz_images_in_place(v_top, filled, y, theta, f_top, g),
            || ritz_images_in_place(v_bottom, filled, y, theta, f_bottom, g),
        );
    } else {
        let mut out = Mat::<f64>::zeros(v.nrows(), y.ncols());
        let basis = v.as_ref().subcols(0, filled);
        faer::linalg::matmul::matmul(out.as_mut(), faer::Accum::Replace, basis, y, 1.0, Par::Seq);
        for (c, &nu) in theta.iter().enumerate() {
            faer::zip!(out.as_mut().col_mut(c)).for_each(|faer::unzip!(x)| *x *= nu);
        }
        faer::linalg::matmul::matmul(out.as_mut(), faer::Accum::Add, f, g, 1.0, Par::Seq);
        v.subcols_mut(0, y.ncols()).copy_from(&out);
    }
}

/// `V[:, ..k] ← V Y` for `Y` of `k` columns, by blocks of rows in parallel: no second basis
/// is held (at 1M DOFs that would be another gigabyte).
fn combine_in_place(v: MatMut<'_, f64>, y: MatRef<'_, f64>) {
    const ROWS: usize = 2048;
    let rows = v.nrows();
    if rows > ROWS {
        let (top, bottom) = v.split_at_row_mut(rows / 2);
        rayon::join(|| combine_in_place(top, y), || combine_in_place(bottom, y));
    } else {
        let combined = v.as_ref() * y;
        v.subcols_mut(0, y.ncols()).copy_from(&combined);
    }
}

#[cfg(test)]
#[path = "sparse_tests.rs"]
mod tests;
