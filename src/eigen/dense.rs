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

use crate::core::DofId;
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
    for (i, dof) in dofs.iter().enumerate() {
        if m[(i, i)].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(EigenError::MasslessDof {
                dof: *dof,
                value: m[(i, i)],
            });
        }
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
        let k = Mat::<f64>::identity(2, 2);
        let m = Mat::from_fn(2, 2, |i, j| if i == j && i == 0 { 1.0 } else { 0.0 });
        let e = dense_generalized(k.as_ref(), m.as_ref(), &dofs, ModeSelection::All).unwrap_err();
        assert!(e.to_string().contains("7:rz"), "{e}");
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
