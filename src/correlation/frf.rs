//! FRF correlation coefficients (docs/theory.md §4).
//!
//! At a line `ω_k`, `x` stacks the measured FRFs and `a` the predicted ones. With `c = xᴴa`,
//! `X = xᴴx`, `A = aᴴa`:
//! - shape `χ_s = |c|² / (X A)` (4.8): 1 when `a ∥ x`, blind to scale;
//! - amplitude `χ_a = 2|c| / (X + A)` (4.9): 1 only when `a = x`.
//!
//! FRAC of one FRF over the lines (1.19): `|Σ_k x̄_k a_k|² / (Σ|x_k|² Σ|a_k|²)`.
//! Where both vectors vanish the coefficients are 1 (identical); where only one does, 0.

use crate::frf::{FrfPair, FrfSet};
use faer::c64;

/// `χ_s` of two vectors (4.8).
pub fn shape_correlation(x: &[c64], a: &[c64]) -> f64 {
    let (c, xx, aa) = products(x, a);
    match (xx > 0.0, aa > 0.0) {
        (true, true) => (c.norm_sqr() / (xx * aa)).min(1.0),
        (false, false) => 1.0,
        _ => 0.0,
    }
}

/// `χ_a` of two vectors (4.9).
pub fn amplitude_correlation(x: &[c64], a: &[c64]) -> f64 {
    let (c, xx, aa) = products(x, a);
    if xx + aa > 0.0 {
        (2.0 * c.norm() / (xx + aa)).min(1.0)
    } else {
        1.0
    }
}

/// FRAC of one measured and one predicted FRF over their lines (1.19).
pub fn frac(x: &[c64], a: &[c64]) -> f64 {
    shape_correlation(x, a)
}

/// `(c, X, A) = (xᴴa, xᴴx, aᴴa)`.
fn products(x: &[c64], a: &[c64]) -> (c64, f64, f64) {
    let mut c = c64::new(0.0, 0.0);
    let (mut xx, mut aa) = (0.0, 0.0);
    for (xi, ai) in x.iter().zip(a) {
        c += xi.conj() * ai;
        xx += xi.norm_sqr();
        aa += ai.norm_sqr();
    }
    (c, xx, aa)
}

/// Why two FRF sets cannot be correlated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CorrelationError {
    /// A measured FRF has no predicted counterpart.
    #[error(
        "the measured FRF {response}/{excitation} (response/excitation) has no predicted counterpart; predicted pairs are {known}"
    )]
    MissingPair {
        /// Response DOF.
        response: String,
        /// Excitation DOF.
        excitation: String,
        /// Pairs the prediction holds.
        known: String,
    },
    /// Frequency lines differ.
    #[error(
        "frequency lines differ: {}; synthesise the prediction on the measured lines",
        describe_lines(*index, *measured, *predicted, *n_measured, *n_predicted)
    )]
    Lines {
        /// First differing index (0-based).
        index: usize,
        /// Measured frequency at `index`, if the measured set has that line.
        measured: Option<f64>,
        /// Predicted frequency at `index`, if the predicted set has that line.
        predicted: Option<f64>,
        /// Measured line count.
        n_measured: usize,
        /// Predicted line count.
        n_predicted: usize,
    },
    /// The two sets hold different quantities.
    #[error("measured FRFs are {0} but predicted FRFs are {1}; synthesise the same quantity")]
    Quantity(&'static str, &'static str),
    /// Nothing to correlate.
    #[error("the measured set holds no FRF")]
    Empty,
}

/// The first difference of two line sets, in words: a line count mismatch names the last line
/// both share and the first one only one of them has.
fn describe_lines(
    index: usize,
    measured: Option<f64>,
    predicted: Option<f64>,
    n_measured: usize,
    n_predicted: usize,
) -> String {
    let line = index + 1;
    match (measured, predicted) {
        (Some(m), Some(p)) => format!(
            "line {line} is {m} Hz measured but {p} Hz predicted ({n_measured} measured lines, {n_predicted} predicted)"
        ),
        (Some(m), None) => format!(
            "{n_measured} measured lines but {n_predicted} predicted; measured line {line} ({m} Hz) has no predicted counterpart"
        ),
        (None, Some(p)) => format!(
            "{n_measured} measured lines but {n_predicted} predicted; predicted line {line} ({p} Hz) has no measured counterpart"
        ),
        (None, None) => format!("{n_measured} measured lines, {n_predicted} predicted"),
    }
}

impl crate::core::InputFault for CorrelationError {
    fn is_input(&self) -> bool {
        // Measured and predicted sets that do not match are the pipeline's to fix.
        true
    }
}

/// Column index in `predicted` for each measured pair, in measured order.
pub fn match_pairs(measured: &FrfSet, predicted: &FrfSet) -> Result<Vec<usize>, CorrelationError> {
    if measured.pairs.is_empty() {
        return Err(CorrelationError::Empty);
    }
    if measured.quantity != predicted.quantity {
        return Err(CorrelationError::Quantity(
            measured.quantity.name(),
            predicted.quantity.name(),
        ));
    }
    let (nm, np) = (measured.freqs_hz.len(), predicted.freqs_hz.len());
    for k in 0..nm.max(np) {
        let (fm, fp) = (measured.freqs_hz.get(k), predicted.freqs_hz.get(k));
        let same =
            matches!((fm, fp), (Some(a), Some(b)) if (a - b).abs() <= 1e-9 * a.abs().max(1.0));
        if !same {
            return Err(CorrelationError::Lines {
                index: k,
                measured: fm.copied(),
                predicted: fp.copied(),
                n_measured: nm,
                n_predicted: np,
            });
        }
    }
    measured
        .pairs
        .iter()
        .map(|p: &FrfPair| {
            predicted
                .pair_index(p)
                .ok_or_else(|| CorrelationError::MissingPair {
                    response: p.response.to_string(),
                    excitation: p.excitation.to_string(),
                    known: predicted
                        .pairs
                        .iter()
                        .map(|q| format!("{}/{}", q.response, q.excitation))
                        .collect::<Vec<_>>()
                        .join(", "),
                })
        })
        .collect()
}

/// `χ_s`, `χ_a` per line and FRAC per measured FRF.
#[derive(Clone, Debug, PartialEq)]
pub struct FrfCorrelation {
    /// Lines in Hz.
    pub freqs_hz: Vec<f64>,
    /// `χ_s(ω_k)`.
    pub chi_s: Vec<f64>,
    /// `χ_a(ω_k)`.
    pub chi_a: Vec<f64>,
    /// Measured pairs, in the order of `frac`.
    pub pairs: Vec<FrfPair>,
    /// FRAC per measured FRF.
    pub frac: Vec<f64>,
}

impl FrfCorrelation {
    /// Mean of `χ_s` over all lines.
    pub fn mean_chi_s(&self) -> f64 {
        mean(&self.chi_s)
    }

    /// Mean of `χ_a` over all lines.
    pub fn mean_chi_a(&self) -> f64 {
        mean(&self.chi_a)
    }

    /// Mean of `(χ_s + χ_a)/2` over all lines: the P-C stop figure (4.23).
    pub fn mean_chi(&self) -> f64 {
        0.5 * (self.mean_chi_s() + self.mean_chi_a())
    }
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Correlates a measured set with a prediction holding at least the measured pairs.
pub fn correlate(
    measured: &FrfSet,
    predicted: &FrfSet,
) -> Result<FrfCorrelation, CorrelationError> {
    let cols = match_pairs(measured, predicted)?;
    let lines = measured.freqs_hz.len();
    let (mut chi_s, mut chi_a) = (Vec::with_capacity(lines), Vec::with_capacity(lines));
    let mut x = vec![c64::new(0.0, 0.0); cols.len()];
    let mut a = x.clone();
    for k in 0..lines {
        for (p, &q) in cols.iter().enumerate() {
            x[p] = measured.values[(k, p)];
            a[p] = predicted.values[(k, q)];
        }
        chi_s.push(shape_correlation(&x, &a));
        chi_a.push(amplitude_correlation(&x, &a));
    }
    let frac = cols
        .iter()
        .enumerate()
        .map(|(p, &q)| {
            let xs: Vec<c64> = (0..lines).map(|k| measured.values[(k, p)]).collect();
            let as_: Vec<c64> = (0..lines).map(|k| predicted.values[(k, q)]).collect();
            frac(&xs, &as_)
        })
        .collect();
    Ok(FrfCorrelation {
        freqs_hz: measured.freqs_hz.clone(),
        chi_s,
        chi_a,
        pairs: measured.pairs.clone(),
        frac,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cvec(v: &[(f64, f64)]) -> Vec<c64> {
        v.iter().map(|(r, i)| c64::new(*r, *i)).collect()
    }

    #[test]
    fn equal_vectors_correlate_perfectly() {
        let x = cvec(&[(1.0, 2.0), (-3.0, 0.5), (0.0, -1.0)]);
        assert!((shape_correlation(&x, &x) - 1.0).abs() < 1e-15);
        assert!((amplitude_correlation(&x, &x) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn scaled_vector_keeps_shape_but_loses_amplitude() {
        let x = cvec(&[(1.0, 2.0), (-3.0, 0.5)]);
        let a: Vec<c64> = x.iter().map(|v| *v * c64::new(0.0, 2.0)).collect();
        assert!((shape_correlation(&x, &a) - 1.0).abs() < 1e-15);
        // χ_a = 2|s| X / (X + |s|² X) = 2·2/(1+4) = 0.8 for a = s x, |s| = 2.
        assert!((amplitude_correlation(&x, &a) - 0.8).abs() < 1e-15);
    }

    #[test]
    fn orthogonal_vectors_do_not_correlate() {
        let x = cvec(&[(1.0, 0.0), (0.0, 0.0)]);
        let a = cvec(&[(0.0, 0.0), (0.0, 1.0)]);
        assert_eq!(shape_correlation(&x, &a), 0.0);
        assert_eq!(amplitude_correlation(&x, &a), 0.0);
    }

    fn arb_vec(n: usize) -> impl Strategy<Value = Vec<c64>> {
        prop::collection::vec((-1e3f64..1e3, -1e3f64..1e3), n)
            .prop_map(|v| v.into_iter().map(|(r, i)| c64::new(r, i)).collect())
    }

    proptest! {
        #[test]
        fn coefficients_lie_in_unit_interval((x, a) in (1usize..8).prop_flat_map(|n| (arb_vec(n), arb_vec(n)))) {
            let s = shape_correlation(&x, &a);
            let am = amplitude_correlation(&x, &a);
            prop_assert!((0.0..=1.0).contains(&s));
            prop_assert!((0.0..=1.0).contains(&am));
            // χ_a ≤ √χ_s·(2√(XA)/(X+A)) ≤ √χ_s: amplitude agreement implies shape agreement.
            prop_assert!(am <= s.sqrt() + 1e-12);
        }

        #[test]
        fn shape_is_scale_invariant(x in arb_vec(5), re in 0.01f64..100.0, im in -100.0f64..100.0) {
            let s = c64::new(re, im);
            let a: Vec<c64> = x.iter().map(|v| *v * s).collect();
            let xx: f64 = x.iter().map(|v| v.norm_sqr()).sum();
            prop_assume!(xx > 1e-6);
            prop_assert!((shape_correlation(&x, &a) - 1.0).abs() < 1e-12);
            let b: Vec<c64> = x.iter().map(|v| *v * 3.0).collect();
            prop_assert!((shape_correlation(&b, &a) - 1.0).abs() < 1e-12);
        }

        #[test]
        fn amplitude_is_one_only_for_equal_vectors(x in arb_vec(4), d in arb_vec(4)) {
            let dd: f64 = d.iter().map(|v| v.norm_sqr()).sum();
            prop_assume!(dd > 1e-3);
            let a: Vec<c64> = x.iter().zip(&d).map(|(u, v)| *u + *v).collect();
            prop_assert!(amplitude_correlation(&x, &a) < 1.0);
            prop_assert_eq!(amplitude_correlation(&x, &x), 1.0);
        }
    }
}
