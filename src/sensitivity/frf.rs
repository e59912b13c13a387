//! FRF sensitivities on a modal basis (docs/theory.md §3; thesis 4.2–4.7: (4.2), (4.3), (4.4),
//! (4.5), (4.6), (4.7); (6.8), (6.11)).
//!
//! For the modal sum `α_ij = Σ_r φ_ir φ_jr / d_r`, `d_r = λ_r − ω² + iγ_r` with the modal damping
//! held fixed, the derivative with respect to a parameter follows from the eigenvalue derivative
//! `∂λ_r = P^K_rr − λ_r P^M_rr` and the mode-shape derivative on the same basis,
//! `∂φ_r = Σ_s c_sr φ_s`, `c_sr = (P^K_sr − λ_r P^M_sr)/(λ_r − λ_s)`, `c_rr = −P^M_rr/2`, where
//! `P^K = Φᵀ(∂K/∂φ)Φ`, `P^M = Φᵀ(∂M/∂φ)Φ`:
//!
//! `∂α_ij = Σ_r [Σ_s c_sr (φ_is φ_jr + φ_ir φ_js)] / d_r − φ_ir φ_jr (1 + i ∂γ_r/∂λ) ∂λ_r / d_r²`.
//!
//! For a uniform loss factor this equals the thesis's projection form (4.5)
//! `∂α_ij = −Σ_r Σ_s φ_ir φ_js [Φᵀ ∂Z Φ]_rs / (d_r d_s)` term by term, so on a truncated basis it
//! is the thesis's sensitivity; on a complete basis it is the exact derivative of the modal FRF for
//! any modal damping (uniform or per mode, structural or viscous). Its advantage is cost: the
//! bracket does not depend on `ω`, so the sweep over all lines is one real × complex matrix
//! product `[g | f] · [1/d; −(1 + iγ')/d²]` of size `(N_φ·N_pairs) × 2m × N_f`. Modes whose
//! eigenvalues coincide to a relative `1e-6` (rigid-body modes, symmetric pairs) would make
//! `c_sr` ill-conditioned; between them the projection form is used instead, whose limit it is:
//! `−φ_ir φ_js [(1 + iγ')P^K_rs − ω² P^M_rs + iκ P^M_rs]/(d_r d_s)`, `κ = γ − λγ'`.

use super::modes::{clusters, expansion_coefficients};
use super::projection::{ProjectedDerivative, eigenvalue_sensitivity};
use crate::core::DofId;
use crate::frf::{FrfPair, ModalDamping, ModalError, Quantity};
use crate::sparse::SparseSolve;
use faer::{Mat, MatRef, Par, c64};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;

/// The rows in `dofs` of the response and excitation of every pair.
pub fn pair_rows(dofs: &[DofId], pairs: &[FrfPair]) -> Result<Vec<(usize, usize)>, ModalError> {
    let index: HashMap<DofId, usize> = dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let describe = || format!("{} DOFs with shapes", dofs.len());
    let row = |d: &DofId| {
        index
            .get(d)
            .copied()
            .ok_or_else(|| ModalError::UnknownDof(*d, describe()))
    };
    pairs
        .iter()
        .map(|p| Ok((row(&p.response)?, row(&p.excitation)?)))
        .collect()
}

/// Relative gap below which two eigenvalues count as one cluster.
pub const CLUSTER_TOLERANCE: f64 = 1e-6;

/// The modal model an FRF and its sensitivities are built from.
#[derive(Clone, Copy, Debug)]
pub struct ModalFrfModel<'a> {
    /// `λ_r`, ascending, rigid-body modes exactly 0.
    pub eigenvalues: &'a [f64],
    /// Mass-normalised shapes at `dofs` (rows) for every mode (columns).
    pub shapes: MatRef<'a, f64>,
    /// Labels of the rows of `shapes`.
    pub dofs: &'a [DofId],
    /// Modal damping.
    pub damping: &'a ModalDamping,
}

impl ModalFrfModel<'_> {
    fn rows(&self, pairs: &[FrfPair]) -> Result<Vec<(usize, usize)>, ModalError> {
        pair_rows(self.dofs, pairs)
    }

    /// `1/d_r(ω)` for every mode at one line, or the mode that is singular there.
    fn inverse_denominators(&self, f_hz: f64) -> Result<Vec<c64>, ModalError> {
        let omega = 2.0 * PI * f_hz;
        self.eigenvalues
            .iter()
            .enumerate()
            .map(|(r, &l)| {
                let d = self.damping.denominator(r, l, omega);
                if d.re == 0.0 && d.im == 0.0 {
                    Err(ModalError::Singular {
                        freq_hz: f_hz,
                        mode: r + 1,
                        mode_hz: l.max(0.0).sqrt() / (2.0 * PI),
                    })
                } else {
                    Ok(c64::new(1.0, 0.0) / d)
                }
            })
            .collect()
    }
}

/// `∂H/∂φ` per parameter (`N_f × N_pairs` each, in `quantity`) of the modal FRF, from each
/// parameter's projected derivative (scale it by `φ` first for unity-based sensitivities).
///
/// `shape_corrections`, one `rows × m` matrix per parameter over the rows of
/// `model.shapes`, adds the truncated modes' share of each mode-shape derivative
/// (`∂φ_r += ρ_r`, see [`static_shape_correction`]); without it the derivatives are those of
/// the truncated expansion alone (the thesis's form).
pub fn frf_sensitivities(
    model: &ModalFrfModel<'_>,
    pairs: &[FrfPair],
    freqs_hz: &[f64],
    quantity: Quantity,
    derivatives: &[ProjectedDerivative],
    shape_corrections: Option<&[Mat<f64>]>,
) -> Result<Vec<Mat<c64>>, ModalError> {
    let m = model.eigenvalues.len();
    model.damping.check(m)?;
    let rows = model.rows(pairs)?;
    let (nq, np, nf) = (pairs.len(), derivatives.len(), freqs_hz.len());
    let cluster = clusters(model.eigenvalues);
    let lambda = model.eigenvalues;
    let phi = model.shapes;

    // Shown only when long (the P-C calls this every iteration).
    let done = crate::core::progress::task_when(
        np * (nq * m + m * m) * m.max(nf) > 200_000_000,
        || "FRF sensitivities (parameters)".into(),
        np as u64,
    );
    // Frequency-independent coefficients [g | f], one row per (parameter, pair).
    let blocks: Vec<Mat<f64>> = derivatives
        .par_iter()
        .enumerate()
        .map(|(p, d)| {
            done.advance(1);
            let rho = shape_corrections.and_then(|c| c.get(p));
            let dl = eigenvalue_sensitivity(lambda, d);
            // c_sr with s the row, r the column; zero inside a cluster (off the diagonal).
            let c = expansion_coefficients(lambda, &cluster, d);
            // u_i = Cᵀ φ_i for every DOF row a pair uses.
            let mut coef = Mat::<f64>::zeros(nq, 2 * m);
            for (q, &(i, j)) in rows.iter().enumerate() {
                for r in 0..m {
                    let (mut ui, mut uj) = (0.0, 0.0);
                    for s in 0..m {
                        ui += c[(s, r)] * phi[(i, s)];
                        uj += c[(s, r)] * phi[(j, s)];
                    }
                    coef[(q, r)] = ui * phi[(j, r)] + phi[(i, r)] * uj;
                    if let Some(rho) = rho {
                        coef[(q, r)] += rho[(i, r)] * phi[(j, r)] + phi[(i, r)] * rho[(j, r)];
                    }
                    coef[(q, m + r)] = phi[(i, r)] * phi[(j, r)] * dl[r];
                }
            }
            coef
        })
        .collect();
    let coef = Mat::from_fn(np * nq, 2 * m, |row, col| {
        blocks[row / nq.max(1)][(row % nq.max(1), col)]
    });

    // Frequency kernels W = [1/d; −(1 + iγ')/d²] (2m × N_f), real and imaginary parts.
    let inv: Vec<Vec<c64>> = freqs_hz
        .par_iter()
        .map(|&f| model.inverse_denominators(f))
        .collect::<Result<_, _>>()?;
    let mut w_re = Mat::<f64>::zeros(2 * m, nf);
    let mut w_im = Mat::<f64>::zeros(2 * m, nf);
    for (k, &f) in freqs_hz.iter().enumerate() {
        let omega = 2.0 * PI * f;
        for r in 0..m {
            let id = inv[k][r];
            let (_, slope) = model.damping.loss(r, lambda[r], omega);
            let w2 = -(c64::new(1.0, slope) * id * id);
            w_re[(r, k)] = id.re;
            w_im[(r, k)] = id.im;
            w_re[(m + r, k)] = w2.re;
            w_im[(m + r, k)] = w2.im;
        }
    }
    let s_re = &coef * &w_re;
    let s_im = &coef * &w_im;

    // Cluster pairs by the projection form.
    let cluster_pairs: Vec<(usize, usize)> = (0..m)
        .flat_map(|r| (0..m).map(move |s| (r, s)))
        .filter(|&(r, s)| r != s && cluster[r] == cluster[s])
        .collect();

    let out: Vec<Mat<c64>> = (0..np)
        .into_par_iter()
        .map(|p| {
            let d = &derivatives[p];
            Mat::from_fn(nf, nq, |k, q| {
                let row = p * nq + q;
                let mut v = c64::new(s_re[(row, k)], s_im[(row, k)]);
                if !cluster_pairs.is_empty() {
                    let omega = 2.0 * PI * freqs_hz[k];
                    let (i, j) = rows[q];
                    for &(r, s) in &cluster_pairs {
                        let (g_r, sl_r) = model.damping.loss(r, lambda[r], omega);
                        let (g_s, sl_s) = model.damping.loss(s, lambda[s], omega);
                        let (slope, gamma) = (0.5 * (sl_r + sl_s), 0.5 * (g_r + g_s));
                        let kappa = gamma - 0.5 * (lambda[r] + lambda[s]) * slope;
                        let dz = c64::new(1.0, slope) * d.k[(r, s)]
                            + c64::new(-omega * omega, kappa) * d.m[(r, s)];
                        v -= dz * inv[k][r] * inv[k][s] * (phi[(i, r)] * phi[(j, s)]);
                    }
                }
                v * quantity.factor(2.0 * PI * freqs_hz[k])
            })
        })
        .collect();
    Ok(out)
}

/// Static solutions `x_j = (K − σM)⁻¹ e_j` for chosen rows, the input of Wang's static
/// correction and of the residual flexibility: one sparse Cholesky, one solve per row.
#[derive(Clone, Debug)]
pub struct ShiftedStatic {
    /// `x_j` for each chosen row (`N × rows`).
    pub x: Mat<f64>,
    /// `σ`, below every eigenvalue so free-free models factor: the eigensolver's own when its
    /// factor is reused, else a hundredth of the first elastic eigenvalue below zero.
    pub shift: f64,
}

/// Why `K − σM` could not be factored.
#[derive(Debug, thiserror::Error)]
pub enum ShiftedStaticError {
    /// The factor did not fit in memory.
    #[error("the Cholesky factor of K - sigma M ({n} DOFs) does not fit in memory")]
    OutOfMemory {
        /// DOF count.
        n: usize,
    },
    /// A mechanism (or an indefinite matrix) remains after the shift.
    #[error("K - sigma M is not positive definite")]
    NotPositiveDefinite,
}

/// The eigensolver's factor of `K − σ_e M` and the modes it found (all kept, `M`-orthonormal,
/// ascending), from which static solutions at another shift follow without a second
/// factorisation (see [`shifted_static_solutions`]).
#[derive(Clone, Copy)]
pub struct EigenFactor<'a> {
    /// The factor and `σ_e`.
    pub factor: &'a crate::eigen::ShiftedFactor,
    /// The kept mode shapes `Φ` (`N × m`).
    pub shapes: MatRef<'a, f64>,
}

/// Most fixed-point steps [`shifted_static_solutions`] takes to move the eigensolver's shift to
/// the static one; beyond, factoring `K − σM` anew is cheaper (at 1M DOFs a factorisation costs
/// about twenty solves of the ten measured DOFs).
pub const MAX_SHIFT_STEPS: usize = 10;

/// Relative accuracy of the moved solutions in every truncated mode: far below the static
/// correction's own approximation (`λ_r/λ_s` for a kept mode `r` and a truncated `s`), and the
/// Lanczos tolerance of an update's modal analyses. At 1M DOFs each step is a solve with the
/// factor (about 0.45 s); `1e-10` took one step more than this on the muffler.
const SHIFT_TOLERANCE: f64 = 1e-8;

/// Static solutions `x_j = (K − σM)⁻¹ e_j` for unit loads at `rows`, with `σ` a hundredth of the
/// first positive of `eigenvalues`, below zero (free-free models factor too).
///
/// With the eigensolver's factor of `K − σ_e M` (`σ_e < σ`), no second factorisation is needed:
/// the kept modes' part of `x_j` is exact, `Σ_kept φ_s φ_sᵀ e_j/(λ_s − σ)`, and the truncated
/// part `y` solves `y = y₀ + (σ − σ_e) P A_e⁻¹ M y` (`A_e = K − σ_e M`, `y₀ = P A_e⁻¹ e_j`,
/// `P = I − ΦΦᵀM`), a contraction of ratio `q = (σ − σ_e)/(λ_s − σ_e) ≤ (σ − σ_e)/(λ_m − σ_e)`
/// in each truncated mode `s`: its error after `k` steps is `q^(k+1)`. The factor is used when
/// [`MAX_SHIFT_STEPS`] steps reach `10⁻⁸`; otherwise `K − σM` is factored.
pub fn shifted_static_solutions(
    k: &crate::core::sparse::SparseMatrix,
    m: &crate::core::sparse::SparseMatrix,
    eigenvalues: &[f64],
    rows: &[usize],
    eigen_factor: Option<EigenFactor<'_>>,
) -> Result<ShiftedStatic, ShiftedStaticError> {
    let n = k.nrows();
    let shift = static_shift(eigenvalues);
    let mut x = Mat::<f64>::zeros(n, rows.len());
    for (c, &r) in rows.iter().enumerate() {
        x[(r, c)] = 1.0;
    }
    if let Some(ef) = eigen_factor
        && let Some(steps) = shift_steps(ef, eigenvalues, shift, n)
    {
        move_shift(ef, m, eigenvalues, rows, shift, steps, x.as_mut());
        return Ok(ShiftedStatic { x, shift });
    }
    let a = crate::sparse::lower_combination(1.0, k, -shift, m);
    let llt = crate::sparse::SpdFactor::consuming(a, Par::rayon(0)).map_err(|e| match e {
        crate::sparse::FactorError::NotPositiveDefinite => ShiftedStaticError::NotPositiveDefinite,
        crate::sparse::FactorError::OutOfMemory => ShiftedStaticError::OutOfMemory { n },
    })?;
    llt.solve_in_place(x.as_mut(), Par::rayon(0));
    Ok(ShiftedStatic { x, shift })
}

/// The static correction's shift: a hundredth of the first positive of `eigenvalues`, below
/// zero, so free-free models factor too.
pub fn static_shift(eigenvalues: &[f64]) -> f64 {
    let first_elastic = eigenvalues
        .iter()
        .copied()
        .find(|l| *l > 0.0)
        .unwrap_or(1.0);
    -1e-2 * first_elastic
}

/// Fixed-point steps for the eigensolver's factor to give solutions at `shift`, or `None` when
/// it cannot (another size, a shift not below `shift`, or a contraction too slow).
pub fn shift_steps(
    ef: EigenFactor<'_>,
    eigenvalues: &[f64],
    shift: f64,
    n: usize,
) -> Option<usize> {
    let sigma_e = ef.factor.shift;
    let highest = eigenvalues.last().copied()?;
    if ef.factor.factor.n() != n
        || ef.shapes.nrows() != n
        || ef.shapes.ncols() != eigenvalues.len()
        || !(sigma_e <= shift)
        || !(highest > shift)
    {
        return None;
    }
    let q = (shift - sigma_e) / (highest - sigma_e);
    if q == 0.0 {
        return Some(0);
    }
    // q^(k+1) ≤ tolerance.
    let steps = (SHIFT_TOLERANCE.ln() / q.ln()).ceil() as usize;
    (steps <= MAX_SHIFT_STEPS + 1).then(|| steps.saturating_sub(1))
}

/// `x ← (K − σM)⁻¹ x` for unit loads `x` at `rows`, by the eigensolver's factor (see
/// [`shifted_static_solutions`]).
fn move_shift(
    ef: EigenFactor<'_>,
    m: &crate::core::sparse::SparseMatrix,
    eigenvalues: &[f64],
    rows: &[usize],
    shift: f64,
    steps: usize,
    mut x: faer::MatMut<'_, f64>,
) {
    use crate::sparse::sym_matvec;
    let (phi, sigma_e, factor) = (ef.shapes, ef.factor.shift, &ef.factor.factor);
    let (n, r) = (x.nrows(), x.ncols());
    // Φᵀ e_j: the kept modes at the loaded rows.
    let at_rows = Mat::from_fn(eigenvalues.len(), r, |s, c| phi[(rows[c], s)]);
    let scaled = |d: f64| {
        Mat::from_fn(eigenvalues.len(), r, |s, c| {
            at_rows[(s, c)] / (eigenvalues[s] - d)
        })
    };
    // y₀ = P A_e⁻¹ e_j: the kept part of A_e⁻¹ e_j is Φ diag(1/(λ − σ_e)) Φᵀ e_j.
    factor.solve_in_place(x.as_mut(), Par::rayon(0));
    let mut y0 = x.to_owned();
    y0 -= phi * scaled(sigma_e);
    let mut y = y0.clone();
    let mut my = Mat::<f64>::zeros(n, r);
    for _ in 0..steps {
        sym_matvec(m, y.as_ref(), my.as_mut(), Par::rayon(0));
        // ΦᵀM A_e⁻¹ M y = diag(1/(λ − σ_e)) ΦᵀM y: the kept part, removed exactly.
        let mut kept = phi.transpose() * &my;
        for c in 0..r {
            for (s, &l) in eigenvalues.iter().enumerate() {
                kept[(s, c)] /= l - sigma_e;
            }
        }
        factor.solve_in_place(my.as_mut(), Par::rayon(0));
        my -= phi * kept;
        y.copy_from(&y0);
        y += faer::Scale(shift - sigma_e) * &my;
    }
    // The full solution at σ: the truncated part and the kept part at σ.
    x.copy_from(&y);
    x += phi * scaled(shift);
}

/// The truncated modes' share of each mode-shape derivative at chosen DOFs (Wang's static
/// correction of the modal method): for mode `r`,
/// `ρ_r = −[(K − σM)⁻¹ − Σ_s φ_s φ_sᵀ/(λ_s − σ)] (∂K − λ_r ∂M) φ_r`, the sum over the kept
/// modes, since `Σ_{s not kept} φ_s c_sr ≈ −Σ_{s not kept} φ_s φ_sᵀ(∂K − λ_r∂M)φ_r / λ_s` for
/// `λ_s ≫ λ_r`. At DOF row `i`, with `x_i = (K − σM)⁻¹ e_i`:
/// `ρ_ir = −x_iᵀ(∂K − λ_r ∂M)φ_r + Σ_s φ_is (P^K_sr − λ_r P^M_sr)/(λ_s − σ)`.
/// `cross_k`, `cross_m` are `Xᵀ ∂K Φ`, `Xᵀ ∂M Φ` (`rows × m`), `shapes` the kept modes at the
/// same rows; all derivatives scaled alike.
pub fn static_shape_correction(
    eigenvalues: &[f64],
    shift: f64,
    shapes: MatRef<'_, f64>,
    cross_k: MatRef<'_, f64>,
    cross_m: MatRef<'_, f64>,
    d: &ProjectedDerivative,
) -> Mat<f64> {
    let m = eigenvalues.len();
    Mat::from_fn(shapes.nrows(), m, |i, r| {
        let lr = eigenvalues[r];
        let mut v = -(cross_k[(i, r)] - lr * cross_m[(i, r)]);
        for s in 0..m {
            v += shapes[(i, s)] * (d.k[(s, r)] - lr * d.m[(s, r)]) / (eigenvalues[s] - shift);
        }
        v
    })
}

/// Exact damping sensitivities per mode (6.8, 6.11), `N_f × N_pairs` each, in `quantity`:
/// `∂α_ij/∂η_r = −iλ_r φ_ir φ_jr / d_r²` for structural damping (also for an undamped model),
/// `∂α_ij/∂ζ_r = −2iω√λ_r φ_ir φ_jr / d_r²` for viscous. Rigid-body modes give zeros.
pub fn damping_sensitivities(
    model: &ModalFrfModel<'_>,
    pairs: &[FrfPair],
    freqs_hz: &[f64],
    quantity: Quantity,
) -> Result<Vec<Mat<c64>>, ModalError> {
    let m = model.eigenvalues.len();
    model.damping.check(m)?;
    let rows = model.rows(pairs)?;
    let inv: Vec<Vec<c64>> = freqs_hz
        .par_iter()
        .map(|&f| model.inverse_denominators(f))
        .collect::<Result<_, _>>()?;
    let viscous = matches!(model.damping, ModalDamping::Viscous(_));
    Ok((0..m)
        .into_par_iter()
        .map(|r| {
            let l = model.eigenvalues[r];
            Mat::from_fn(freqs_hz.len(), pairs.len(), |k, q| {
                if l == 0.0 {
                    return c64::new(0.0, 0.0);
                }
                let omega = 2.0 * PI * freqs_hz[k];
                let dd = if viscous { 2.0 * omega * l.sqrt() } else { l };
                let (i, j) = rows[q];
                let id = inv[k][r];
                c64::new(0.0, -dd)
                    * id
                    * id
                    * (model.shapes[(i, r)] * model.shapes[(j, r)])
                    * quantity.factor(omega)
            })
        })
        .collect())
}

/// `∂(20 log10|H|)/∂φ = (20/ln 10)(Re H Re ∂H + Im H Im ∂H)/|H|²` (dB per unit of `φ`);
/// zero where `H = 0`.
pub fn log_magnitude_sensitivity(h: c64, dh: c64) -> f64 {
    let n2 = h.re * h.re + h.im * h.im;
    if n2 == 0.0 {
        return 0.0;
    }
    20.0 / std::f64::consts::LN_10 * (h.re * dh.re + h.im * dh.im) / n2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eigen::dense_generalized;
    use crate::eigen::{ModeSelection, Modes};
    use crate::frf::modal_receptance;

    /// A free-free five-mass chain (one rigid-body mode) whose masses and springs are the
    /// parameters; K and M are linear in them.
    fn chain(masses: &[f64], springs: &[f64]) -> (Mat<f64>, Mat<f64>) {
        let n = masses.len();
        let mut k = Mat::<f64>::zeros(n, n);
        for (e, &ke) in springs.iter().enumerate() {
            let (a, b) = (e, e + 1);
            k[(a, a)] += ke;
            k[(b, b)] += ke;
            k[(a, b)] -= ke;
            k[(b, a)] -= ke;
        }
        let m = Mat::from_fn(n, n, |i, j| if i == j { masses[i] } else { 0.0 });
        (k, m)
    }

    fn dofs(n: usize) -> Vec<DofId> {
        (1..=n as u64)
            .map(|i| DofId::new(i, crate::core::Component::Ux))
            .collect()
    }

    fn modes_of(k: &Mat<f64>, m: &Mat<f64>) -> Modes {
        dense_generalized(k.as_ref(), m.as_ref(), &dofs(k.nrows()), ModeSelection::All).unwrap()
    }

    fn frf(
        modes: &Modes,
        damping: &ModalDamping,
        pairs: &[FrfPair],
        f: &[f64],
        q: Quantity,
    ) -> Mat<c64> {
        modal_receptance(modes, &dofs(modes.shapes.nrows()), damping, pairs, f, q)
            .unwrap()
            .values
    }

    fn to_sparse(a: &Mat<f64>) -> crate::core::sparse::SparseMatrix {
        let mut t = Vec::new();
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                if a[(i, j)] != 0.0 {
                    t.push((i, j, a[(i, j)]));
                }
            }
        }
        crate::core::sparse::sparse_from_triplets("A", a.nrows(), &t).unwrap()
    }

    /// On the complete basis the sensitivity is the exact derivative of the modal FRF: it
    /// equals a fourth-order central difference (relative step 1e-3: truncation ~1e-12, the
    /// eigensolver's ~1e-11 relative noise over the step ~1e-8) to 1e-6 of the largest entry, for structural per-mode, viscous per-mode and
    /// uniform damping, in receptance, mobility and accelerance, with a rigid-body mode and a
    /// mass and a spring parameter.
    #[test]
    fn complete_basis_matches_central_differences() {
        let masses = [1.0, 1.3, 0.8, 1.1, 0.9];
        let springs = [2.0e4, 1.5e4, 3.0e4, 1.0e4];
        let pairs = crate::frf::FrfSet::all_pairs(&dofs(5)[..3], &dofs(5)[..1]);
        let freqs = [3.0, 11.5, 17.25, 26.0, 40.0];
        let dampings = [
            ModalDamping::Structural(vec![0.02]),
            ModalDamping::Structural(vec![0.0, 0.01, 0.03, 0.02, 0.05]),
            ModalDamping::Viscous(vec![0.0, 0.02, 0.01, 0.04, 0.03]),
        ];
        let n_dofs = dofs(5);
        for damping in &dampings {
            for quantity in [
                Quantity::Receptance,
                Quantity::Mobility,
                Quantity::Accelerance,
            ] {
                for param in 0..2 {
                    let (k, m) = chain(&masses, &springs);
                    let modes = modes_of(&k, &m);
                    let (dk, dm) = if param == 0 {
                        // ∂/∂m_2
                        (
                            Mat::zeros(5, 5),
                            Mat::from_fn(5, 5, |i, j| (i == 1 && j == 1) as u8 as f64),
                        )
                    } else {
                        // ∂/∂k_3
                        let unit = chain(&[0.0; 5], &[0.0, 0.0, 1.0, 0.0]).0;
                        (unit, Mat::zeros(5, 5))
                    };
                    let d = ProjectedDerivative::new(
                        &to_sparse(&dk),
                        &to_sparse(&dm),
                        modes.shapes.as_ref(),
                    );
                    let model = ModalFrfModel {
                        eigenvalues: &modes.eigenvalues,
                        shapes: modes.shapes.as_ref(),
                        dofs: &n_dofs,
                        damping,
                    };
                    let s =
                        frf_sensitivities(&model, &pairs, &freqs, quantity, &[d], None).unwrap();
                    let h = 1e-3;
                    let eval = |sign: f64| {
                        let (mut ms, mut ks) = (masses, springs);
                        if param == 0 {
                            ms[1] *= 1.0 + sign * h;
                        } else {
                            ks[2] *= 1.0 + sign * h;
                        }
                        let (k, m) = chain(&ms, &ks);
                        frf(&modes_of(&k, &m), damping, &pairs, &freqs, quantity)
                    };
                    let step = if param == 0 {
                        masses[1] * h
                    } else {
                        springs[2] * h
                    };
                    // Fourth-order central difference.
                    let fd = (eval(-2.0) - eval(2.0)
                        + (eval(1.0) - eval(-1.0)) * faer::Scale(c64::new(8.0, 0.0)))
                        * faer::Scale(c64::new(1.0 / (12.0 * step), 0.0));
                    let scale = fd.norm_max();
                    let err = (&s[0] - &fd).norm_max();
                    assert!(
                        err <= 1e-6 * scale,
                        "{damping:?} {quantity:?} param {param}: {err:e} vs {scale:e}"
                    );
                }
            }
        }
    }

    /// For a uniform loss factor the sensitivity is the thesis's projection form (4.5),
    /// `−Σ_rs φ_ir φ_js [(1+iη)P^K − ω²P^M]_rs/(d_r d_s)`, on a truncated basis too.
    #[test]
    fn uniform_loss_factor_equals_the_projection_form() {
        let (k, m) = chain(&[1.0, 1.3, 0.8, 1.1, 0.9], &[2.0e4, 1.5e4, 3.0e4, 1.0e4]);
        let all = modes_of(&k, &m);
        let kept = 3;
        let shapes = all.shapes.subcols(0, kept).to_owned();
        let lambda = all.eigenvalues[..kept].to_vec();
        let unit = chain(&[0.0; 5], &[0.0, 2.0, 0.0, 1.0]).0;
        let mass = Mat::from_fn(5, 5, |i, j| if i == j { 0.1 * i as f64 } else { 0.0 });
        let d = ProjectedDerivative::new(&to_sparse(&unit), &to_sparse(&mass), shapes.as_ref());
        let eta = 0.03;
        let damping = ModalDamping::Structural(vec![eta]);
        let n_dofs = dofs(5);
        let model = ModalFrfModel {
            eigenvalues: &lambda,
            shapes: shapes.as_ref(),
            dofs: &n_dofs,
            damping: &damping,
        };
        let pairs = crate::frf::FrfSet::all_pairs(&n_dofs, &n_dofs[1..2]);
        let freqs = [2.0, 9.0, 21.0];
        let s = frf_sensitivities(
            &model,
            &pairs,
            &freqs,
            Quantity::Receptance,
            std::slice::from_ref(&d),
            None,
        )
        .unwrap();
        for (kk, &f) in freqs.iter().enumerate() {
            let w = 2.0 * PI * f;
            let dn: Vec<c64> = (0..kept)
                .map(|r| damping.denominator(r, lambda[r], w))
                .collect();
            for (q, p) in pairs.iter().enumerate() {
                let (i, j) = (
                    (p.response.node - 1) as usize,
                    (p.excitation.node - 1) as usize,
                );
                let mut v = c64::new(0.0, 0.0);
                for r in 0..kept {
                    for s2 in 0..kept {
                        let dz =
                            c64::new(1.0, eta) * d.k[(r, s2)] - c64::new(w * w, 0.0) * d.m[(r, s2)];
                        v -= dz * shapes[(i, r)] * shapes[(j, s2)] / (dn[r] * dn[s2]);
                    }
                }
                assert!(
                    (s[0][(kk, q)] - v).norm() <= 1e-12 * v.norm().max(1e-30),
                    "{kk} {q}"
                );
            }
        }
    }

    /// The exact damping sensitivities against central differences of the modal FRF.
    #[test]
    fn damping_sensitivities_match_central_differences() {
        let (k, m) = chain(&[1.0, 1.3, 0.8, 1.1, 0.9], &[2.0e4, 1.5e4, 3.0e4, 1.0e4]);
        let modes = modes_of(&k, &m);
        let n_dofs = dofs(5);
        let pairs = crate::frf::FrfSet::all_pairs(&n_dofs[..2], &n_dofs[..1]);
        let freqs = [5.0, 13.0, 29.0];
        for viscous in [false, true] {
            let base = vec![0.0, 0.02, 0.01, 0.04, 0.03];
            let make = |v: Vec<f64>| {
                if viscous {
                    ModalDamping::Viscous(v)
                } else {
                    ModalDamping::Structural(v)
                }
            };
            let damping = make(base.clone());
            let model = ModalFrfModel {
                eigenvalues: &modes.eigenvalues,
                shapes: modes.shapes.as_ref(),
                dofs: &n_dofs,
                damping: &damping,
            };
            let s = damping_sensitivities(&model, &pairs, &freqs, Quantity::Mobility).unwrap();
            assert_eq!(
                s[0].norm_max(),
                0.0,
                "the rigid-body mode has no damping sensitivity"
            );
            for r in 1..5 {
                let h = 1e-6;
                let eval = |sign: f64| {
                    let mut v = base.clone();
                    v[r] += sign * h;
                    frf(&modes, &make(v), &pairs, &freqs, Quantity::Mobility)
                };
                let fd = (eval(1.0) - eval(-1.0)) * faer::Scale(c64::new(0.5 / h, 0.0));
                let err = (&s[r] - &fd).norm_max();
                assert!(err <= 1e-6 * fd.norm_max(), "mode {r}: {err:e}");
            }
        }
    }

    #[test]
    fn log_magnitude_matches_a_difference() {
        let h = c64::new(0.3, -0.7);
        let dh = c64::new(-0.2, 0.5);
        let e = 1e-7;
        let db = |x: c64| 20.0 * x.norm().log10();
        let fd = (db(h + dh * e) - db(h - dh * e)) / (2.0 * e);
        assert!((log_magnitude_sensitivity(h, dh) - fd).abs() < 1e-7);
    }
}
