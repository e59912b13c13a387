//! Dense generalised symmetric eigenproblem `K φ = λ M φ` for small models
//! (docs/theory.md §1, 1.7–1.12: (1.7), (1.8), (1.9), (1.10), (1.11), (1.12)).
//!
//! With a shift `σ = −10⁻⁶ median(K_jj/M_jj)` below every eigenvalue, `K − σM = L Lᵀ`
//! (Cholesky) and the pencil becomes the standard symmetric problem `(L⁻¹ M L⁻ᵀ) y = ν y`,
//! `ν = 1/(λ − σ)`, solved by faer's self-adjoint eigendecomposition; `φ = L⁻ᵀ y / √ν`.
//! Working with the inverse keeps the lowest modes accurate to round-off relative to
//! themselves, not to the stiffest mode. The shapes come out mass-normalised, `Φᵀ M Φ = I`,
//! `Φᵀ K Φ = Λ`. Rigid-body modes (`|λ| ≤ 10⁻⁶ |σ|`) are kept and set to `λ = 0`. Each shape's sign is fixed so that its
//! largest-magnitude entry is positive, which makes results reproducible run to run.
//!
//! Massless DOFs (zero row and column of `M` with stiffness, e.g. rotations under lumped mass or
//! the independent grid of a rigid element) are condensed out statically, as Nastran does:
//! with `0` the massless and `m` the other DOFs, `K̂ = K_mm − K_m0 K_00⁻¹ K_0m` (exact for the
//! eigenproblem since `M_0· = 0`: the massless rows read `K_0m φ_m + K_00 φ_0 = 0`), the reduced
//! pencil `(K̂, M_mm)` is solved, and `φ_0 = −K_00⁻¹ K_0m φ_m` completes each shape. The
//! infinite eigenvalues of the singular pencil are thereby left out.

use crate::core::DofId;
use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Mat, MatRef, Par, Side};

/// Which modes to keep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ModeSelection {
    /// Every mode.
    All,
    /// The lowest `n` modes.
    Count(usize),
    /// Every mode whose natural frequency is at most this many Hz.
    BelowHz(f64),
}

/// Mass-normalised modes with their accuracy figures.
#[derive(Clone, Debug)]
pub struct Modes {
    /// Eigenvalues `λ_r = ω_r²` in rad²/s², ascending.
    pub eigenvalues: Vec<f64>,
    /// Shapes, one column per mode, one row per DOF.
    pub shapes: Mat<f64>,
    /// Relative residual `‖Kφ − λMφ‖ / ‖Kφ‖` per mode (denominator `‖K‖·‖φ‖` for rigid modes).
    pub residuals: Vec<f64>,
    /// `max |ΦᵀMΦ − I|`.
    pub orthogonality_error: f64,
    /// Number of rigid-body modes found.
    pub rigid_body_modes: usize,
}

impl Modes {
    /// Natural frequencies in Hz.
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.eigenvalues
            .iter()
            .map(|l| l.max(0.0).sqrt() / (2.0 * std::f64::consts::PI))
            .collect()
    }

    /// Number of modes.
    pub fn len(&self) -> usize {
        self.eigenvalues.len()
    }

    /// True when no mode was kept.
    pub fn is_empty(&self) -> bool {
        self.eigenvalues.is_empty()
    }
}

/// Why the eigenproblem could not be solved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EigenError {
    /// A DOF has no mass (zero or negative diagonal).
    #[error(
        "the mass matrix is not positive definite: DOF {dof} has diagonal mass {value:e}; give every DOF a mass (or condense massless DOFs out)"
    )]
    MasslessDof {
        /// The DOF.
        dof: DofId,
        /// Its diagonal mass.
        value: f64,
    },
    /// The mass matrix is indefinite although its diagonal is positive.
    #[error(
        "the mass matrix is not positive definite (Cholesky failed); check for negative masses or inconsistent mass couplings"
    )]
    IndefiniteMass,
    /// The stiffness matrix has a clearly negative eigenvalue.
    #[error(
        "the stiffness matrix is indefinite: eigenvalue {value:e} rad²/s² is negative beyond round-off (largest {largest:e}); check for negative stiffnesses"
    )]
    IndefiniteStiffness {
        /// The negative eigenvalue.
        value: f64,
        /// The largest eigenvalue.
        largest: f64,
    },
    /// Shapes of `K` and `M` disagree.
    #[error("K is {k}x{k} but M is {m}x{m} and there are {dofs} DOFs")]
    Shape {
        /// K dimension.
        k: usize,
        /// M dimension.
        m: usize,
        /// DOF count.
        dofs: usize,
    },
    /// The dense eigensolver did not converge.
    #[error("the eigensolver did not converge")]
    NoConvergence,
    /// A DOF has neither stiffness nor mass.
    #[error(
        "DOF {dof} has neither stiffness nor mass, so the problem is singular there; constrain it (SPC) or connect it (e.g. a drilling stiffness for shell rotations)"
    )]
    Unsupported {
        /// The DOF.
        dof: DofId,
    },
    /// `K − σM` could not be factored.
    #[error(
        "K - sigma M is not positive definite at the shift sigma = {shift:e} rad^2/s^2: the stiffness has an eigenvalue below the shift (negative stiffness) or the mass matrix is indefinite"
    )]
    NotPositiveDefinite {
        /// The shift.
        shift: f64,
    },
    /// The factor of `K − σM` did not fit in memory.
    #[error(
        "the Cholesky factor of K - sigma M ({n} DOFs) does not fit in memory; reduce the model (CMS) or use a machine with more memory"
    )]
    FactorTooLarge {
        /// DOF count.
        n: usize,
    },
    /// `K` and `M` hold more entries than the eigensolver's 32-bit indices address.
    #[error("{0}; reduce the model (CMS)")]
    PencilTooLarge(crate::sparse::PencilError),
    /// Not every wanted mode converged.
    #[error(
        "only {converged} of {wanted} modes converged after {restarts} restarts; loosen the tolerance, ask for fewer modes, or give a shift near the wanted frequencies"
    )]
    NotConverged {
        /// Converged count.
        converged: usize,
        /// Wanted count.
        wanted: usize,
        /// Restarts done.
        restarts: usize,
    },
    /// Massless DOFs that cannot be condensed: they form a mechanism among themselves.
    #[error(
        "DOF {dof} has no mass and the massless DOFs have no stiffness of their own to condense them out (K_00 is singular there); give it a mass or support it"
    )]
    MasslessMechanism {
        /// A DOF of the singular massless block.
        dof: DofId,
    },
    /// "All modes" of a large model.
    #[error("all {n} modes of a sparse model were asked for; give a count or a frequency limit")]
    AllModesOfLargeModel {
        /// DOF count.
        n: usize,
    },
}

impl crate::core::InputFault for EigenError {
    fn is_input(&self) -> bool {
        matches!(
            self,
            EigenError::MasslessDof { .. }
                | EigenError::MasslessMechanism { .. }
                | EigenError::IndefiniteMass
                | EigenError::AllModesOfLargeModel { .. }
        )
    }
}

/// All (or the selected) modes of a small model, mass-normalised.
pub fn dense_generalized(
    k: MatRef<'_, f64>,
    m: MatRef<'_, f64>,
    dofs: &[DofId],
    selection: ModeSelection,
) -> Result<Modes, EigenError> {
    let n = dofs.len();
    if k.nrows() != n || k.ncols() != n || m.nrows() != n || m.ncols() != n {
        return Err(EigenError::Shape {
            k: k.nrows(),
            m: m.nrows(),
            dofs: n,
        });
    }
    let mut massless = Vec::new();
    for (i, dof) in dofs.iter().enumerate() {
        let row_zero = (0..n).all(|j| m[(i, j)] == 0.0 && m[(j, i)] == 0.0);
        if m[(i, i)] == 0.0 && row_zero && k[(i, i)] > 0.0 {
            massless.push(i);
            continue;
        }
        if m[(i, i)].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(EigenError::MasslessDof {
                dof: *dof,
                value: m[(i, i)],
            });
        }
    }
    if !massless.is_empty() {
        return condensed(k, m, dofs, selection, &massless);
    }
    // Shift-invert: with σ < 0 below every eigenvalue, A = K − σM = L Lᵀ and the symmetric
    // C = L⁻¹ M L⁻ᵀ has eigenvalues ν = 1/(λ − σ), largest for the lowest modes. Its
    // eigenvectors are accurate relative to ν_max, so the low modes keep full accuracy even
    // when λ_max/λ_1 is 1e9 or more (thin shells), where the direct form L_M⁻¹ K L_M⁻ᵀ loses
    // them in the round-off of the stiff modes.
    let shift = -1e-6 * diagonal_scale(k, m);
    let a = Mat::from_fn(n, n, |i, j| k[(i, j)] - shift * m[(i, j)]);
    let llt = a
        .llt(Side::Lower)
        .map_err(|_| EigenError::NotPositiveDefinite { shift })?;
    let l = llt.L();
    let mut x = m.to_owned();
    solve_lower_triangular_in_place(l, x.as_mut(), Par::Seq);
    let mut c = x.transpose().to_owned();
    solve_lower_triangular_in_place(l, c.as_mut(), Par::Seq);
    let sym = Mat::from_fn(n, n, |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    let evd = sym
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| EigenError::NoConvergence)?;
    // Largest ν first = lowest λ first.
    let s = evd.S();
    let nu: Vec<f64> = (0..n).rev().map(|i| s[i]).collect();
    let nu_max = nu.first().copied().unwrap_or(0.0);
    if !(nu_max > 0.0) || nu.iter().any(|v| *v <= 1e-14 * nu_max) {
        return Err(EigenError::IndefiniteMass);
    }
    let u = evd.U();
    let mut shapes = Mat::from_fn(n, n, |i, j| u[(i, n - 1 - j)]);
    solve_upper_triangular_in_place(l.transpose(), shapes.as_mut(), Par::Seq);
    // φᵀMφ = ν for yᵀy = 1: scale to unit modal mass.
    for (j, v) in nu.iter().enumerate() {
        let f = 1.0 / v.sqrt();
        for i in 0..n {
            shapes[(i, j)] *= f;
        }
    }
    let mut lambdas: Vec<f64> = nu.iter().map(|v| shift + 1.0 / v).collect();
    let largest = lambdas.iter().fold(0.0f64, |acc, v| acc.max(v.abs()));
    // Round-off in λ = σ + 1/ν is a few ε|σ| for the low modes: anything within 1e-6 |σ| of
    // zero is a rigid-body mode.
    let rigid_tol = 1e-6 * shift.abs();
    let mut rigid = 0;
    for lam in lambdas.iter_mut() {
        if lam.abs() <= rigid_tol {
            *lam = 0.0;
            rigid += 1;
        } else if *lam < 0.0 {
            return Err(EigenError::IndefiniteStiffness {
                value: *lam,
                largest,
            });
        }
    }

    let keep = match selection {
        ModeSelection::All => n,
        ModeSelection::Count(c) => c.min(n),
        ModeSelection::BelowHz(f) => {
            let limit = (2.0 * std::f64::consts::PI * f).powi(2);
            lambdas.iter().take_while(|l| **l <= limit).count()
        }
    };
    lambdas.truncate(keep);
    let mut shapes = shapes.subcols(0, keep).to_owned();
    for j in 0..keep {
        fix_sign(shapes.as_mut().col_mut(j));
    }
    let rigid_body_modes = lambdas.iter().filter(|l| **l == 0.0).count().min(rigid);

    let kphi = k * &shapes;
    let mphi = m * &shapes;
    // Rayleigh quotients: second-order accurate in the shape, so the high modes (small ν) get
    // their eigenvalues to round-off too.
    for (j, lam) in lambdas.iter_mut().enumerate() {
        if *lam != 0.0 {
            let (mut pkp, mut pmp) = (0.0, 0.0);
            for i in 0..n {
                pkp += shapes[(i, j)] * kphi[(i, j)];
                pmp += shapes[(i, j)] * mphi[(i, j)];
            }
            *lam = pkp / pmp;
        }
    }
    let k_norm = crate::core::dense::max_abs(k) * (n as f64).sqrt();
    let residuals = (0..keep)
        .map(|j| {
            let mut r2 = 0.0;
            let mut k2 = 0.0;
            let mut p2 = 0.0;
            for i in 0..n {
                let r = kphi[(i, j)] - lambdas[j] * mphi[(i, j)];
                r2 += r * r;
                k2 += kphi[(i, j)] * kphi[(i, j)];
                p2 += shapes[(i, j)] * shapes[(i, j)];
            }
            let denom = if lambdas[j] == 0.0 {
                k_norm * p2.sqrt()
            } else {
                k2.sqrt()
            };
            if denom > 0.0 { r2.sqrt() / denom } else { 0.0 }
        })
        .collect();
    let gram = shapes.transpose() * &mphi;
    let mut orthogonality_error = 0.0f64;
    for i in 0..keep {
        for j in 0..keep {
            let target = if i == j { 1.0 } else { 0.0 };
            orthogonality_error = orthogonality_error.max((gram[(i, j)] - target).abs());
        }
    }
    Ok(Modes {
        eigenvalues: lambdas,
        shapes,
        residuals,
        orthogonality_error,
        rigid_body_modes,
    })
}

/// [`dense_generalized`] with the `massless` DOFs condensed out statically (module doc): the
/// reduced pencil's modes, completed at the massless DOFs, with residuals and orthogonality of
/// the full problem.
fn condensed(
    k: MatRef<'_, f64>,
    m: MatRef<'_, f64>,
    dofs: &[DofId],
    selection: ModeSelection,
    massless: &[usize],
) -> Result<Modes, EigenError> {
    let n = dofs.len();
    let mut is_zero = vec![false; n];
    for &i in massless {
        is_zero[i] = true;
    }
    let kept: Vec<usize> = (0..n).filter(|&i| !is_zero[i]).collect();
    let (nz, nk) = (massless.len(), kept.len());
    let k00 = Mat::from_fn(nz, nz, |i, j| k[(massless[i], massless[j])]);
    let k0m = Mat::from_fn(nz, nk, |i, j| k[(massless[i], kept[j])]);
    let llt = k00
        .llt(Side::Lower)
        .map_err(|_| EigenError::MasslessMechanism {
            dof: dofs[massless[0]],
        })?;
    // G = K_00⁻¹ K_0m, so φ_0 = −G φ_m and K̂ = K_mm − K_m0 G.
    let g = llt.solve(&k0m);
    let kh = Mat::from_fn(nk, nk, |i, j| {
        let mut v = k[(kept[i], kept[j])];
        for p in 0..nz {
            v -= k0m[(p, i)] * g[(p, j)];
        }
        v
    });
    let kh = Mat::from_fn(nk, nk, |i, j| 0.5 * (kh[(i, j)] + kh[(j, i)]));
    let mm = Mat::from_fn(nk, nk, |i, j| m[(kept[i], kept[j])]);
    let kept_dofs: Vec<DofId> = kept.iter().map(|&i| dofs[i]).collect();
    let reduced = dense_generalized(kh.as_ref(), mm.as_ref(), &kept_dofs, selection)?;
    let c = reduced.len();
    let full_from = g * &reduced.shapes;
    let mut shapes = Mat::zeros(n, c);
    for j in 0..c {
        for (r, &i) in kept.iter().enumerate() {
            shapes[(i, j)] = reduced.shapes[(r, j)];
        }
        for (p, &i) in massless.iter().enumerate() {
            shapes[(i, j)] = -full_from[(p, j)];
        }
        fix_sign(shapes.as_mut().col_mut(j));
    }
    let kphi = k * &shapes;
    let mphi = m * &shapes;
    let k_norm = crate::core::dense::max_abs(k) * (n as f64).sqrt();
    let residuals = (0..c)
        .map(|j| {
            let lam = reduced.eigenvalues[j];
            let (mut r2, mut k2, mut p2) = (0.0, 0.0, 0.0);
            for i in 0..n {
                let r = kphi[(i, j)] - lam * mphi[(i, j)];
                r2 += r * r;
                k2 += kphi[(i, j)] * kphi[(i, j)];
                p2 += shapes[(i, j)] * shapes[(i, j)];
            }
            let denom = if lam == 0.0 {
                k_norm * p2.sqrt()
            } else {
                k2.sqrt()
            };
            if denom > 0.0 { r2.sqrt() / denom } else { 0.0 }
        })
        .collect();
    Ok(Modes {
        eigenvalues: reduced.eigenvalues,
        shapes,
        residuals,
        orthogonality_error: reduced.orthogonality_error,
        rigid_body_modes: reduced.rigid_body_modes,
    })
}

/// Median of `K_jj / M_jj` over DOFs with mass and stiffness: the scale of the eigenvalues.
pub fn diagonal_scale(k: MatRef<'_, f64>, m: MatRef<'_, f64>) -> f64 {
    median_ratio((0..k.nrows()).map(|j| (k[(j, j)], m[(j, j)])))
}

/// Median of `k / m` over pairs with both positive (1 when there is none).
pub fn median_ratio(pairs: impl Iterator<Item = (f64, f64)>) -> f64 {
    let mut r: Vec<f64> = pairs
        .filter(|(k, m)| *k > 0.0 && *m > 0.0)
        .map(|(k, m)| k / m)
        .collect();
    if r.is_empty() {
        return 1.0;
    }
    let mid = r.len() / 2;
    r.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    r[mid]
}

/// Flips a shape so that its largest-magnitude entry (the first, on ties) is positive; returns
/// whether it flipped.
pub fn fix_sign(mut col: faer::ColMut<'_, f64>) -> bool {
    let mut best = 0usize;
    for i in 0..col.nrows() {
        if col[i].abs() > col[best].abs() * (1.0 + 1e-12) {
            best = i;
        }
    }
    let flip = col.nrows() > 0 && col[best] < 0.0;
    if flip {
        for i in 0..col.nrows() {
            col[i] = -col[i];
        }
    }
    flip
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::lumped::assemble_lumped;
    use crate::model::LumpedModel;

    fn chain_modes(masses: &[f64], k: f64) -> Modes {
        let sys = assemble_lumped(&LumpedModel::chain(masses, k)).unwrap();
        dense_generalized(
            sys.k_dense().as_ref(),
            sys.m_dense().as_ref(),
            &sys.dofs,
            ModeSelection::All,
        )
        .unwrap()
    }

    /// A uniform chain of `n` equal masses `m` between two grounds has
    /// `ω_r² = (4k/m) sin²(rπ / (2(n+1)))` (analytic reference).
    #[test]
    fn uniform_chain_matches_the_analytic_frequencies() {
        let (n, k, m) = (4usize, 1e4, 1.0);
        let modes = chain_modes(&vec![m; n], k);
        for r in 1..=n {
            let theta = r as f64 * std::f64::consts::PI / (2.0 * (n as f64 + 1.0));
            let expected = 4.0 * k / m * theta.sin().powi(2);
            let got = modes.eigenvalues[r - 1];
            assert!(
                ((got - expected) / expected).abs() < 1e-12,
                "mode {r}: {got} vs {expected}"
            );
        }
        assert!(modes.orthogonality_error < 1e-12);
        assert!(modes.residuals.iter().all(|r| *r < 1e-12));
        // The reconstructed C1 stiffness puts the first two resonances near 9.8 and 18.7 Hz.
        let f = modes.frequencies_hz();
        assert!(
            (f[0] - 9.836).abs() < 0.01 && (f[1] - 18.71).abs() < 0.01,
            "{f:?}"
        );
    }

    #[test]
    fn free_free_pair_keeps_its_rigid_body_mode() {
        let dofs: Vec<DofId> = vec!["1:ux".parse().unwrap(), "2:ux".parse().unwrap()];
        let k = Mat::from_fn(2, 2, |i, j| if i == j { 100.0 } else { -100.0 });
        let m = Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { 0.0 });
        let modes = dense_generalized(k.as_ref(), m.as_ref(), &dofs, ModeSelection::All).unwrap();
        assert_eq!(modes.eigenvalues[0], 0.0);
        assert_eq!(modes.rigid_body_modes, 1);
        assert!((modes.eigenvalues[1] - 100.0).abs() < 1e-10);
    }

    #[test]
    fn massless_dof_is_named() {
        let dofs: Vec<DofId> = vec!["1:ux".parse().unwrap(), "7:rz".parse().unwrap()];
        // Without stiffness it cannot be condensed; with a negative mass it is no mass at all.
        let k = Mat::from_fn(2, 2, |i, j| if i == j && i == 0 { 1.0 } else { 0.0 });
        let m = Mat::from_fn(2, 2, |i, j| if i == j && i == 0 { 1.0 } else { 0.0 });
        let e = dense_generalized(k.as_ref(), m.as_ref(), &dofs, ModeSelection::All).unwrap_err();
        assert!(e.to_string().contains("7:rz"), "{e}");
        let m = Mat::from_fn(2, 2, |i, j| if i == j { 1.0 - 2.0 * i as f64 } else { 0.0 });
        let k = Mat::<f64>::identity(2, 2);
        let e = dense_generalized(k.as_ref(), m.as_ref(), &dofs, ModeSelection::All).unwrap_err();
        assert!(e.to_string().contains("7:rz"), "{e}");
    }

    /// A chain of springs whose every second DOF is massless: `(K, M, DOFs)` and the chain of
    /// the massive DOFs joined by the series springs `k₁k₂/(k₁+k₂)`, condensed by hand.
    #[allow(clippy::type_complexity)]
    fn half_massless_chain(
        nm: usize,
        k1: f64,
        k2: f64,
    ) -> (
        crate::core::sparse::SparseMatrix,
        crate::core::sparse::SparseMatrix,
        Vec<DofId>,
        Mat<f64>,
        Mat<f64>,
    ) {
        use crate::core::sparse::sparse_from_triplets;
        let masses: Vec<f64> = (0..nm).map(|i| 1.0 + 0.5 * (i as f64).sin()).collect();
        // ground –k1– m0 –k1– b0 –k2– m1 –k1– b1 –k2– m2 … –k1– ground.
        let n = 2 * nm - 1;
        let mut kt = Vec::new();
        let mut spring = |a: Option<usize>, b: Option<usize>, s: f64| {
            for (x, y, v) in [(a, a, s), (b, b, s), (a, b, -s), (b, a, -s)] {
                if let (Some(x), Some(y)) = (x, y) {
                    kt.push((x, y, v));
                }
            }
        };
        spring(None, Some(0), k1);
        for i in 0..nm - 1 {
            spring(Some(2 * i), Some(2 * i + 1), k1);
            spring(Some(2 * i + 1), Some(2 * i + 2), k2);
        }
        spring(Some(n - 1), None, k1);
        let mt: Vec<(usize, usize, f64)> = (0..nm).map(|i| (2 * i, 2 * i, masses[i])).collect();
        let k = sparse_from_triplets("K", n, &kt).unwrap();
        let m = sparse_from_triplets("M", n, &mt).unwrap();
        let dofs: Vec<DofId> = (0..n)
            .map(|i| DofId::new(i as u64 + 1, crate::core::Component::Ux))
            .collect();
        let ks = k1 * k2 / (k1 + k2);
        let kh = Mat::from_fn(nm, nm, |i, j| {
            if i == j {
                (if i == 0 { k1 } else { ks }) + (if i == nm - 1 { k1 } else { ks })
            } else if i.abs_diff(j) == 1 {
                -ks
            } else {
                0.0
            }
        });
        let mh = Mat::from_fn(nm, nm, |i, j| if i == j { masses[i] } else { 0.0 });
        (k, m, dofs, kh, mh)
    }

    /// Massless DOFs condensed out: the same eigenvalues (1e-12 relative) as the chain condensed
    /// by hand, on the dense path (static condensation), the sparse path's pencil on the few
    /// massive DOFs (10 of 19) and its shift-invert Lanczos (1100 of 2199: singular `M`, the
    /// infinite eigenvalues, `ν = 0` of the operator, are never wanted);
    /// the shapes at the massless DOFs are the static interpolation
    /// `φ_b = (k₁ φ_a + k₂ φ_c)/(k₁ + k₂)`, and every residual is at round-off.
    #[test]
    fn massless_dofs_are_condensed_exactly() {
        use crate::eigen::{SparseEigenParams, lowest_modes};
        let (k1, k2) = (1.0e4, 3.0e4);
        for (nm, sparse_path) in [(10, false), (10, true), (1100, true)] {
            let (k, m, dofs, kh, mh) = half_massless_chain(nm, k1, k2);
            let hand = dense_generalized(kh.as_ref(), mh.as_ref(), &dofs[..nm], ModeSelection::All)
                .unwrap();
            let (modes, count) = if sparse_path {
                let params = SparseEigenParams {
                    dense_limit: 0,
                    ..Default::default()
                };
                let (modes, info) =
                    lowest_modes(&k, &m, &dofs, ModeSelection::Count(4), &params).unwrap();
                assert!(!info.dense);
                (modes, 4)
            } else {
                let modes = dense_generalized(
                    crate::core::sparse::sparse_to_dense(&k).as_ref(),
                    crate::core::sparse::sparse_to_dense(&m).as_ref(),
                    &dofs,
                    ModeSelection::All,
                )
                .unwrap();
                (modes, nm)
            };
            assert_eq!(modes.len(), count);
            for r in 0..count {
                let (a, b) = (modes.eigenvalues[r], hand.eigenvalues[r]);
                // 1e-12 relative, 1e-9 for the long chain (λ_max/λ_1 ≈ 10⁶ costs that much
                // round-off in the hand reference's dense solve and in the Lanczos path).
                let tol = if nm > 100 { 1e-9 } else { 1e-12 };
                assert!(((a - b) / b).abs() < tol, "{nm}: mode {r}: {a} vs {b}");
            }
            // The long chain's residuals carry its conditioning (λ_max/λ_1 ≈ 10⁶): 1e-9.
            let rtol = if nm > 100 { 1e-9 } else { 1e-10 };
            assert!(
                modes.residuals.iter().all(|r| *r < rtol),
                "{:?}",
                modes.residuals
            );
            for r in 0..count {
                let s = modes.shapes.col(r);
                for i in 0..nm - 1 {
                    let interp = (k1 * s[2 * i] + k2 * s[2 * i + 2]) / (k1 + k2);
                    assert!(
                        (s[2 * i + 1] - interp).abs() < 1e-10 * s.norm_max(),
                        "{nm}: mode {r}"
                    );
                }
            }
        }
    }

    #[test]
    fn selection_by_frequency_and_count() {
        let modes = chain_modes(&[1.0; 4], 1e4);
        assert_eq!(modes.len(), 4);
        let sys = assemble_lumped(&LumpedModel::chain(&[1.0; 4], 1e4)).unwrap();
        let (k, m) = (sys.k_dense(), sys.m_dense());
        let below = dense_generalized(
            k.as_ref(),
            m.as_ref(),
            &sys.dofs,
            ModeSelection::BelowHz(20.0),
        )
        .unwrap();
        assert_eq!(below.len(), 2);
        let two =
            dense_generalized(k.as_ref(), m.as_ref(), &sys.dofs, ModeSelection::Count(3)).unwrap();
        assert_eq!(two.len(), 3);
        assert_eq!(two.shapes.ncols(), 3);
    }
}
