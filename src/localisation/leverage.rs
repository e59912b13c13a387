//! The leverage of a candidate parameter (thesis 5.4–5.9: (5.4), (5.5), (5.6), (5.7), (5.8), (5.9);
//! docs/theory.md §7).
//!
//! With one parameter `i` alone the P-C's equations (4.16) over the updating lines read
//! `ε = S_i Δφ_i` (5.5), `ε` stacking `1 − χ_s(ω_k)`, `1 − χ_a(ω_k)` and `S_i` their
//! unity-based gradients. Its least-squares change is `Δφ_i = S_iᵀε / S_iᵀS_i` (5.6) and the
//! residual left, `‖ε − S_iΔφ_i‖² = εᵀε − (S_iᵀε)²/(S_iᵀS_i)` (5.7, 5.8), is smallest for the
//! largest leverage `L_i = (S_iᵀε)² / (S_iᵀS_i)` (5.9). Every `L_i` needs only its own column,
//! so the columns are formed and reduced chunk by chunk and `S` is never held whole.

use super::LocalisationError;
use crate::core::DofId;
use crate::frf::FrfSet;
use crate::sensitivity::frf::pair_rows;
use crate::sensitivity::{ModalFrfModel, ProjectedDerivative, frf_sensitivities};
use crate::updating::pc::correlation_equations;
use faer::{Mat, MatRef, c64};
use rayon::prelude::*;
use std::ops::Range;

/// What one column of `S` says about its parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColumnFit {
    /// `L_i = (S_iᵀε)²/(S_iᵀS_i)` (5.9); 0 for a zero column.
    pub leverage: f64,
    /// `Δφ_i/φ_i = S_iᵀε/(S_iᵀS_i)` (5.6): the relative change parameter `i` alone would make.
    pub change: f64,
    /// `S_iᵀS_i`.
    pub norm2: f64,
}

/// Leverage and one-parameter change of `column` against the residual `eps`.
pub fn column_fit(column: &[f64], eps: &[f64]) -> ColumnFit {
    let (mut se, mut ss) = (0.0, 0.0);
    for (s, e) in column.iter().zip(eps) {
        se += s * e;
        ss += s * s;
    }
    if ss > 0.0 {
        ColumnFit {
            leverage: se * se / ss,
            change: se / ss,
            norm2: ss,
        }
    } else {
        ColumnFit {
            leverage: 0.0,
            change: 0.0,
            norm2: 0.0,
        }
    }
}

/// [`column_fit`] of every column of `s`.
pub fn column_fits(s: MatRef<'_, f64>, eps: &[f64]) -> Vec<ColumnFit> {
    (0..s.ncols())
        .map(|j| {
            let col: Vec<f64> = (0..s.nrows()).map(|i| s[(i, j)]).collect();
            column_fit(&col, eps)
        })
        .collect()
}

/// The P-C's equations at chosen lines for a fixed prediction (4.16): builds `ε` once and the
/// columns of `S` for any candidates' projected derivatives.
pub struct Equations<'a> {
    /// Measured FRFs.
    pub measured: &'a FrfSet,
    /// The prediction at the measured pairs and lines.
    pub predicted: &'a FrfSet,
    /// Updating lines (indices into the measured lines).
    pub chosen: &'a [usize],
    /// Modes with their shapes at the measured DOFs.
    pub modal: ModalFrfModel<'a>,
    /// Rows weighted by `√χ` (4.21); the thesis's leverage (5.4) is unweighted.
    pub weighted: bool,
}

impl Equations<'_> {
    /// `ε`: `1 − χ_s`, `1 − χ_a` per line (only `1 − χ_a` with one FRF).
    pub fn residual(&self) -> Vec<f64> {
        correlation_equations(
            self.measured,
            self.predicted,
            self.chosen,
            &[],
            self.weighted,
        )
        .1
    }

    /// Columns of `S` for a chunk of candidates.
    pub fn columns(&self, terms: &ChunkTerms) -> Result<Mat<f64>, LocalisationError> {
        let freqs: Vec<f64> = self
            .chosen
            .iter()
            .map(|&k| self.measured.freqs_hz[k])
            .collect();
        let mut sens = frf_sensitivities(
            &self.modal,
            &self.measured.pairs,
            &freqs,
            self.measured.quantity,
            &terms.projected,
            terms.shape_corrections.as_deref(),
        )?;
        if let Some(flex) = &terms.flexibility {
            let rows = pair_rows(self.modal.dofs, &self.measured.pairs)?;
            for (s, dr) in sens.iter_mut().zip(flex) {
                add_static_receptance(s, &freqs, self.measured.quantity, &rows, dr.as_ref());
            }
        }
        Ok(correlation_equations(
            self.measured,
            self.predicted,
            self.chosen,
            &sens,
            self.weighted,
        )
        .0)
    }
}

/// Adds a frequency-independent receptance `r` (rows and columns over `dofs`) to every FRF of
/// `set`, converted to its quantity.
pub fn add_receptance(
    set: &mut FrfSet,
    r: MatRef<'_, f64>,
    dofs: &[DofId],
) -> Result<(), LocalisationError> {
    let rows = pair_rows(dofs, &set.pairs)?;
    add_static_receptance(&mut set.values, &set.freqs_hz, set.quantity, &rows, r);
    Ok(())
}

/// Adds a frequency-independent receptance `r` to `values` (lines × pairs, at `freqs_hz`),
/// converted to `quantity`; `rows` are each pair's (response, excitation) rows of `r`.
pub fn add_static_receptance(
    values: &mut Mat<c64>,
    freqs_hz: &[f64],
    quantity: crate::frf::Quantity,
    rows: &[(usize, usize)],
    r: MatRef<'_, f64>,
) {
    for (k, &f) in freqs_hz.iter().enumerate() {
        let factor = quantity.factor(2.0 * std::f64::consts::PI * f);
        for (q, &(i, j)) in rows.iter().enumerate() {
            values[(k, q)] += factor * r[(i, j)];
        }
    }
}

/// What a chunk of candidates contributes to `S`: their unity-scaled projected derivatives
/// and, with the static share, Wang's corrections of the mode-shape derivatives and the
/// derivatives of the residual flexibility at the measured DOFs (see [`super::residual`]).
#[derive(Clone, Debug, Default)]
pub struct ChunkTerms {
    /// `φ Φᵀ∂KΦ`, `φ Φᵀ∂MΦ` per candidate.
    pub projected: Vec<ProjectedDerivative>,
    /// `ρ` per candidate (measured DOFs × modes).
    pub shape_corrections: Option<Vec<Mat<f64>>>,
    /// `∂R` per candidate (measured DOFs × measured DOFs).
    pub flexibility: Option<Vec<Mat<f64>>>,
}

/// Fits of `n` candidates, `chunk` at a time: `produce(range)` forms the terms of the
/// candidates in `range`, their columns of `S` are built and reduced to [`ColumnFit`]s, and
/// the chunk is dropped. Chunks run in parallel; the result is in candidate order.
pub fn chunked_fits<F>(
    equations: &Equations<'_>,
    n: usize,
    chunk: usize,
    produce: F,
) -> Result<Vec<ColumnFit>, LocalisationError>
where
    F: Fn(Range<usize>) -> Result<ChunkTerms, LocalisationError> + Sync,
{
    let eps = equations.residual();
    let chunk = chunk.max(1);
    let ranges: Vec<Range<usize>> = (0..n.div_ceil(chunk))
        .map(|c| c * chunk..((c + 1) * chunk).min(n))
        .collect();
    let done = crate::core::progress::task(
        || format!("leverage chunks ({n} candidates)"),
        ranges.len() as u64,
    );
    let parts = ranges
        .into_par_iter()
        .map(|r| {
            let s = equations.columns(&produce(r)?)?;
            done.advance(1);
            Ok(column_fits(s.as_ref(), &eps))
        })
        .collect::<Result<Vec<_>, LocalisationError>>()?;
    Ok(parts.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Leverage by its definition (5.7, 5.8): `‖ε‖² − min_x ‖ε − S_i x‖²`, the minimum found
    /// by a QR least-squares solve independent of the formula, and no other `x` doing better.
    #[test]
    fn leverage_is_the_residual_reduction() {
        use faer::linalg::solvers::SolveLstsq;
        let m = 17;
        let eps: Vec<f64> = (0..m).map(|i| ((i * 7 % 5) as f64 - 1.7) * 0.3).collect();
        let s = Mat::from_fn(m, 3, |i, j| {
            ((i * (j + 3) + 2 * j) % 11) as f64 / 11.0 - 0.4
        });
        let e2: f64 = eps.iter().map(|e| e * e).sum();
        let fits = column_fits(s.as_ref(), &eps);
        for (j, fit) in fits.iter().enumerate() {
            let col = s.subcols(j, 1).to_owned();
            let rhs = Mat::from_fn(m, 1, |i, _| eps[i]);
            let x = col.qr().solve_lstsq(&rhs)[(0, 0)];
            let left = |x: f64| {
                (0..m)
                    .map(|i| (eps[i] - s[(i, j)] * x).powi(2))
                    .sum::<f64>()
            };
            assert!(
                (e2 - left(x) - fit.leverage).abs() <= 1e-12 * e2,
                "column {j}"
            );
            assert!((x - fit.change).abs() <= 1e-12 * x.abs().max(1.0));
            for dx in [-1e-3, 1e-3] {
                assert!(left(x + dx) > left(x));
            }
        }
        assert_eq!(column_fit(&[0.0; 3], &[1.0, 2.0, 3.0]).leverage, 0.0);
    }
}
