//! Residual (static) correction of a truncated modal FRF (docs/theory.md §13, (13.4)).
//!
//! Well below their natural frequencies the modes left out of a modal sum respond
//! quasi-statically, with the flexibility `R = K⁻¹ − Σ_{r kept} φ_r φ_rᵀ / λ_r`. Adding `R_ij` to
//! the truncated sum makes the FRF exact at 0 Hz and removes most of the truncation error below
//! the first mode left out. With one uniform structural loss factor `η` the residual is damped
//! like the modes, `R / (1 + iη)` (the limit of the left-out modes' terms at ω → 0); with
//! viscous or per-mode damping it stays real.

use super::{FrfPair, FrfSet, ModalDamping, Quantity};
use crate::core::DofId;
use crate::eigen::Modes;
use crate::fe::SystemMatrices;
use crate::sparse::{SparseSolve, SpdFactor};
use faer::{Mat, Par, c64};
use std::collections::HashMap;

/// Why the residual could not be formed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ResidualError {
    /// The model has rigid-body modes (or mechanisms): `K⁻¹` does not exist.
    #[error(
        "the static correction needs a model without rigid-body modes (K positive definite), but {0}; constrain the model (SPC) or drop `residual`"
    )]
    NotPositiveDefinite(String),
    /// A pair names a DOF the matrices or the modes do not hold.
    #[error("DOF {0} is not a free DOF of the {1}")]
    UnknownDof(DofId, &'static str),
}

impl crate::core::InputFault for ResidualError {
    fn is_input(&self) -> bool {
        true
    }
}

/// `R_ij = (K⁻¹)_ij − Σ_r φ_ir φ_jr / λ_r` for every pair, over the modes of `modes` (rows
/// labelled by `mode_dofs`); `K⁻¹` from one sparse Cholesky factorisation and one solve per
/// excitation.
pub fn static_residual(
    sys: &SystemMatrices,
    modes: &Modes,
    mode_dofs: &[DofId],
    pairs: &[FrfPair],
) -> Result<Vec<f64>, ResidualError> {
    if let Some(r) = modes.eigenvalues.iter().position(|&l| l <= 0.0) {
        return Err(ResidualError::NotPositiveDefinite(format!(
            "mode {} has eigenvalue {:e}",
            r + 1,
            modes.eigenvalues[r]
        )));
    }
    let matrix_row = sys.dof_index();
    let mode_row: HashMap<DofId, usize> =
        mode_dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let mut excitations: Vec<usize> = Vec::new();
    let mut slot: HashMap<usize, usize> = HashMap::new();
    let mut rows = Vec::with_capacity(pairs.len());
    for p in pairs {
        let find = |d: &DofId| {
            let i = *matrix_row
                .get(d)
                .ok_or(ResidualError::UnknownDof(*d, "matrices"))?;
            let r = *mode_row
                .get(d)
                .ok_or(ResidualError::UnknownDof(*d, "modes"))?;
            Ok::<_, ResidualError>((i, r))
        };
        let ((i, ri), (j, rj)) = (find(&p.response)?, find(&p.excitation)?);
        let s = *slot.entry(j).or_insert_with(|| {
            excitations.push(j);
            excitations.len() - 1
        });
        rows.push((i, s, ri, rj));
    }
    let factor = SpdFactor::new(&sys.k, Par::rayon(0)).map_err(|e| {
        ResidualError::NotPositiveDefinite(format!(
            "the Cholesky factorisation of K failed ({e:?})"
        ))
    })?;
    let mut flexibility = Mat::<f64>::zeros(sys.n(), excitations.len());
    for (s, &j) in excitations.iter().enumerate() {
        flexibility[(j, s)] = 1.0;
    }
    factor.solve_in_place(flexibility.as_mut(), Par::rayon(0));
    Ok(rows
        .into_iter()
        .map(|(i, s, ri, rj)| {
            let kept: f64 = modes
                .eigenvalues
                .iter()
                .enumerate()
                .map(|(r, &l)| modes.shapes[(ri, r)] * modes.shapes[(rj, r)] / l)
                .sum();
            flexibility[(i, s)] - kept
        })
        .collect())
}

/// Adds the residual (13.4) to a receptance `set`, damped as the modes are where one uniform
/// structural loss factor is given (one value, or the same value for every mode).
pub fn add_residual(set: &mut FrfSet, residual: &[f64], damping: &ModalDamping) {
    debug_assert_eq!(set.quantity, Quantity::Receptance);
    let scale = match damping {
        ModalDamping::Structural(eta) if !eta.is_empty() && eta.iter().all(|&e| e == eta[0]) => {
            c64::new(1.0, 0.0) / c64::new(1.0, eta[0])
        }
        _ => c64::new(1.0, 0.0),
    };
    for (p, &r) in residual.iter().enumerate() {
        for k in 0..set.freqs_hz.len() {
            set.values[(k, p)] += scale * r;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eigen::{ModeSelection, dense_generalized};
    use crate::frf::direct::{DirectDamping, direct_receptance};
    use crate::frf::modal_receptance;

    /// The clamped 8 × 8 plate (294 DOFs), all its modes, three `uz` pairs.
    fn plate() -> (SystemMatrices, Modes, Vec<FrfPair>) {
        let sys = crate::frf::krylov::tests::clamped_plate();
        let modes = dense_generalized(
            sys.k_dense().as_ref(),
            sys.m_dense().as_ref(),
            &sys.dofs,
            ModeSelection::All,
        )
        .unwrap();
        let uz: Vec<DofId> = sys
            .dofs
            .iter()
            .filter(|d| d.comp == crate::core::Component::Uz)
            .copied()
            .collect();
        let pairs = FrfSet::all_pairs(&[uz[4], uz[20], uz[31]], &[uz[20]]);
        (sys, modes, pairs)
    }

    fn truncated(modes: &Modes, m: usize) -> Modes {
        Modes {
            eigenvalues: modes.eigenvalues[..m].to_vec(),
            shapes: modes.shapes.subcols(0, m).to_owned(),
            residuals: modes.residuals[..m].to_vec(),
            ..modes.clone()
        }
    }

    /// With every mode kept the residual vanishes (to the round-off of `K⁻¹`, 1e-9 of it).
    #[test]
    fn the_residual_of_all_modes_is_zero() {
        let (sys, modes, pairs) = plate();
        let all = static_residual(&sys, &modes, &sys.dofs, &pairs).unwrap();
        let none = static_residual(&sys, &truncated(&modes, 0), &sys.dofs, &pairs).unwrap();
        for (r, flex) in all.iter().zip(&none) {
            assert!(r.abs() <= 1e-9 * flex.abs(), "{r:e} of {flex:e}");
        }
    }

    /// Ten of 294 modes with the residual against the direct solution, η = 0.02: exact at
    /// 0 Hz (1e-9, the round-off of two solutions), and up to half the eleventh mode's
    /// frequency every line's error at most `(f/f_11)²` of the plain truncated sum's — the
    /// factor by which the correction shrinks each left-out mode's term
    /// `c_r/(λ_r(1 + iη) − ω²)` to `c_r ω²/(λ_r(1 + iη)(λ_r(1 + iη) − ω²))` (0.63 of it measured
    /// at worst; modes of opposite sign could cancel in the plain error, not here).
    #[test]
    fn the_residual_corrects_a_truncated_sum() {
        let (sys, modes, pairs) = plate();
        let kept = truncated(&modes, 10);
        let f11 = modes.frequencies_hz()[10];
        let top = 0.5 * f11;
        let freqs = crate::frf::frequency_lines(0.0, top, top / 200.0);
        let damping = ModalDamping::Structural(vec![0.02]);
        let direct = direct_receptance(
            &sys,
            &DirectDamping {
                structural_eta: 0.02,
                rayleigh: None,
            },
            &pairs,
            &freqs,
            Quantity::Receptance,
        )
        .unwrap();
        let plain = modal_receptance(
            &kept,
            &sys.dofs,
            &damping,
            &pairs,
            &freqs,
            Quantity::Receptance,
        )
        .unwrap();
        let mut corrected = plain.clone();
        let r = static_residual(&sys, &kept, &sys.dofs, &pairs).unwrap();
        add_residual(&mut corrected, &r, &damping);
        for p in 0..pairs.len() {
            let at0 = (corrected.values[(0, p)] - direct.values[(0, p)]).norm();
            assert!(
                at0 <= 1e-9 * direct.values[(0, p)].norm(),
                "pair {p}: {at0:e}"
            );
            let (mut worst_plain, mut worst_corrected) = (0.0f64, 0.0f64);
            for (k, f) in freqs.iter().enumerate() {
                let e_plain = (plain.values[(k, p)] - direct.values[(k, p)]).norm();
                let e_corr = (corrected.values[(k, p)] - direct.values[(k, p)]).norm();
                worst_plain = worst_plain.max(e_plain);
                worst_corrected = worst_corrected.max(e_corr);
                // Each left-out mode's error shrinks by (ω/ω_r)² ≤ (ω/ω_11)² (13.4).
                let bound = (f / f11).powi(2) * e_plain;
                assert!(
                    e_corr <= bound + 1e-9 * direct.values[(k, p)].norm(),
                    "pair {p} at {f} Hz: {e_corr:e} vs {e_plain:e}"
                );
            }
            assert!(worst_corrected <= 0.25 * worst_plain, "pair {p}");
        }
    }

    /// A free model has no static flexibility: refused with what to do.
    #[test]
    fn rigid_body_modes_are_refused() {
        let (sys, modes, pairs) = plate();
        let mut free = modes.clone();
        free.eigenvalues[0] = 0.0;
        let e = static_residual(&sys, &free, &sys.dofs, &pairs).unwrap_err();
        assert!(e.to_string().contains("rigid-body"), "{e}");
    }
}
