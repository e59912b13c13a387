//! Receptance by modal summation with proportional damping (docs/theory.md §1):
//! structural `α_ij(ω) = Σ_r φ_ir φ_jr / (ω_r² − ω² + i η_r ω_r²)` (6.10) and viscous
//! `α_ij(ω) = Σ_r φ_ir φ_jr / (ω_r² − ω² + 2i ζ_r ω ω_r)` (6.7). Rigid-body modes are not damped.

use super::{FrfPair, FrfSet, Quantity, convert_from_receptance};
use crate::core::DofId;
use crate::eigen::Modes;
use faer::{Mat, c64};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;

/// Modal damping, per mode or uniform.
#[derive(Clone, Debug, PartialEq)]
pub enum ModalDamping {
    /// Undamped.
    None,
    /// Structural loss factors `η_r` (one value for every mode, or one per mode).
    Structural(Vec<f64>),
    /// Viscous ratios `ζ_r` (one value for every mode, or one per mode).
    Viscous(Vec<f64>),
}

impl ModalDamping {
    /// The value for mode `r`: uniform when one value is given.
    fn value(values: &[f64], r: usize) -> f64 {
        if values.len() == 1 {
            values[0]
        } else {
            values[r]
        }
    }

    /// Denominator `d_r(ω)` of mode `r` with eigenvalue `λ_r`.
    pub fn denominator(&self, r: usize, lambda: f64, omega: f64) -> c64 {
        if lambda == 0.0 {
            return c64::new(-omega * omega, 0.0);
        }
        match self {
            ModalDamping::None => c64::new(lambda - omega * omega, 0.0),
            ModalDamping::Structural(eta) => {
                c64::new(lambda - omega * omega, Self::value(eta, r) * lambda)
            }
            ModalDamping::Viscous(zeta) => c64::new(
                lambda - omega * omega,
                2.0 * Self::value(zeta, r) * omega * lambda.sqrt(),
            ),
        }
    }

    /// The damping value of mode `r` (`η_r` or `ζ_r`; 0 when undamped).
    pub fn mode_value(&self, r: usize) -> f64 {
        match self {
            ModalDamping::None => 0.0,
            ModalDamping::Structural(v) | ModalDamping::Viscous(v) => Self::value(v, r),
        }
    }

    /// The imaginary part `γ_r` of `d_r = λ − ω² + iγ_r(λ, ω)` and its slope `∂γ_r/∂λ`:
    /// `(ηλ, η)` structural, `(2ζω√λ, ζω/√λ)` viscous, zero for rigid-body modes.
    pub fn loss(&self, r: usize, lambda: f64, omega: f64) -> (f64, f64) {
        if lambda == 0.0 {
            return (0.0, 0.0);
        }
        match self {
            ModalDamping::None => (0.0, 0.0),
            ModalDamping::Structural(eta) => {
                let e = Self::value(eta, r);
                (e * lambda, e)
            }
            ModalDamping::Viscous(zeta) => {
                let z = Self::value(zeta, r);
                let w = lambda.abs().sqrt();
                (2.0 * z * omega * w, z * omega / w)
            }
        }
    }

    /// Checks the values against the number of modes `m`: one value, or one per mode, each
    /// finite and non-negative.
    pub fn check(&self, m: usize) -> Result<(), ModalError> {
        let values = self.values();
        if values.len() > 1 && values.len() != m {
            return Err(ModalError::DampingCount {
                given: values.len(),
                modes: m,
            });
        }
        if let Some(v) = values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            return Err(ModalError::BadDamping(*v));
        }
        Ok(())
    }

    /// Number of damping values given (1 for a uniform value).
    pub fn len(&self) -> usize {
        self.values().len()
    }

    /// True when undamped.
    pub fn is_empty(&self) -> bool {
        self.values().is_empty()
    }

    fn values(&self) -> &[f64] {
        match self {
            ModalDamping::None => &[],
            ModalDamping::Structural(v) | ModalDamping::Viscous(v) => v,
        }
    }
}

/// Why a modal FRF could not be synthesised.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModalError {
    /// A pair names a DOF the modes do not hold.
    #[error("DOF {0} is not a DOF of the model; its DOFs run {1}")]
    UnknownDof(DofId, String),
    /// Per-mode damping with the wrong count.
    #[error("{given} per-mode damping values for {modes} modes; give one value, or one per mode")]
    DampingCount {
        /// Values given.
        given: usize,
        /// Modes used.
        modes: usize,
    },
    /// A damping value is negative or not finite.
    #[error("damping value {0} must be finite and >= 0")]
    BadDamping(f64),
    /// An undamped (or rigid-body) resonance falls on a line.
    #[error(
        "the response is undefined at {freq_hz} Hz: mode {mode} ({mode_hz:.6} Hz) is undamped there; move the line or add damping"
    )]
    Singular {
        /// Line frequency.
        freq_hz: f64,
        /// 1-based mode number.
        mode: usize,
        /// Natural frequency of the mode.
        mode_hz: f64,
    },
}

impl crate::core::InputFault for ModalError {
    fn is_input(&self) -> bool {
        !matches!(self, ModalError::Singular { .. })
    }
}

/// Receptance (converted to `quantity`) of `pairs` at `freqs_hz` from the first `modes.len()`
/// modes; `dofs` labels the rows of the mode shapes.
pub fn modal_receptance(
    modes: &Modes,
    dofs: &[DofId],
    damping: &ModalDamping,
    pairs: &[FrfPair],
    freqs_hz: &[f64],
    quantity: Quantity,
) -> Result<FrfSet, ModalError> {
    let m = modes.len();
    damping.check(m)?;
    let index: HashMap<DofId, usize> = dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let describe = || {
        let first = dofs.first().map(|d| d.to_string()).unwrap_or_default();
        let last = dofs.last().map(|d| d.to_string()).unwrap_or_default();
        format!("{first} … {last} ({} DOFs)", dofs.len())
    };
    let rows = |d: &DofId| {
        index
            .get(d)
            .copied()
            .ok_or_else(|| ModalError::UnknownDof(*d, describe()))
    };
    // Modal constants φ_ir φ_jr per pair and mode.
    let mut constants = Mat::<f64>::zeros(m, pairs.len());
    for (p, pair) in pairs.iter().enumerate() {
        let (i, j) = (rows(&pair.response)?, rows(&pair.excitation)?);
        for r in 0..m {
            constants[(r, p)] = modes.shapes[(i, r)] * modes.shapes[(j, r)];
        }
    }
    let hz = modes.frequencies_hz();
    // Shown only when long: the update's iterations call this often, and quickly.
    let done = crate::core::progress::task_when(
        freqs_hz.len() * m * pairs.len() > 50_000_000,
        || "FRF lines (modal)".into(),
        freqs_hz.len() as u64,
    );
    let lines: Vec<Result<Vec<c64>, ModalError>> = freqs_hz
        .par_iter()
        .map(|&f| {
            done.advance(1);
            let omega = 2.0 * PI * f;
            let mut inv = Vec::with_capacity(m);
            for (r, &lambda) in modes.eigenvalues.iter().enumerate().take(m) {
                let d = damping.denominator(r, lambda, omega);
                if d.re == 0.0 && d.im == 0.0 {
                    return Err(ModalError::Singular {
                        freq_hz: f,
                        mode: r + 1,
                        mode_hz: hz[r],
                    });
                }
                inv.push(c64::new(1.0, 0.0) / d);
            }
            Ok((0..pairs.len())
                .map(|p| {
                    let mut s = c64::new(0.0, 0.0);
                    for (r, inv_r) in inv.iter().enumerate() {
                        s += *inv_r * constants[(r, p)];
                    }
                    s
                })
                .collect())
        })
        .collect();
    let mut out = Mat::<c64>::zeros(freqs_hz.len(), pairs.len());
    for (k, line) in lines.into_iter().enumerate() {
        for (p, v) in line?.into_iter().enumerate() {
            out[(k, p)] = v;
        }
    }
    let mut set = FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: freqs_hz.to_vec(),
        pairs: pairs.to_vec(),
        values: out,
    };
    convert_from_receptance(&mut set, quantity);
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    fn single_dof(k: f64, m: f64) -> (Modes, Vec<DofId>) {
        let modes = Modes {
            eigenvalues: vec![k / m],
            shapes: Mat::from_fn(1, 1, |_, _| 1.0 / m.sqrt()),
            residuals: vec![0.0],
            orthogonality_error: 0.0,
            rigid_body_modes: 0,
        };
        (modes, vec!["1:ux".parse().unwrap()])
    }

    /// Single DOF: `α = 1 / (k − ω² m + i η k)` and `1 / (k − ω² m + i c ω)` with `c = 2ζ√(km)`.
    #[test]
    fn single_dof_matches_the_closed_form() {
        let (k, m, eta, zeta) = (4.0e4, 2.5, 0.02, 0.03);
        let (modes, dofs) = single_dof(k, m);
        let pair = FrfPair {
            response: dofs[0],
            excitation: dofs[0],
        };
        let freqs = [0.0, 3.0, 20.0, 55.0];
        let s = modal_receptance(
            &modes,
            &dofs,
            &ModalDamping::Structural(vec![eta]),
            &[pair],
            &freqs,
            Quantity::Receptance,
        )
        .unwrap();
        let v = modal_receptance(
            &modes,
            &dofs,
            &ModalDamping::Viscous(vec![zeta]),
            &[pair],
            &freqs,
            Quantity::Accelerance,
        )
        .unwrap();
        for (row, f) in freqs.iter().enumerate() {
            let w = 2.0 * PI * f;
            let exact = c64::new(1.0, 0.0) / c64::new(k - w * w * m, eta * k);
            assert!((s.values[(row, 0)] - exact).norm() <= 1e-14 * exact.norm());
            let c = 2.0 * zeta * (k * m).sqrt();
            let exact_v = c64::new(-w * w, 0.0) / c64::new(k - w * w * m, c * w);
            assert!((v.values[(row, 0)] - exact_v).norm() <= 1e-14 * exact_v.norm().max(1e-300));
        }
    }

    #[test]
    fn undamped_resonance_on_a_line_is_an_error() {
        let (modes, dofs) = single_dof(4.0 * PI * PI, 1.0); // 1 Hz
        let pair = FrfPair {
            response: dofs[0],
            excitation: dofs[0],
        };
        let e = modal_receptance(
            &modes,
            &dofs,
            &ModalDamping::None,
            &[pair],
            &[1.0],
            Quantity::Receptance,
        )
        .unwrap_err();
        assert!(matches!(e, ModalError::Singular { mode: 1, .. }), "{e}");
    }
}
