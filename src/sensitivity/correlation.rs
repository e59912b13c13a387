//! Sensitivities of the FRF correlation coefficients (docs/theory.md §4; thesis 4.8–4.15: (4.8),
//! (4.9), (4.10), (4.11), (4.12), (4.13), (4.14), (4.15)).
//!
//! At one line, with measured `x`, predicted `a`, `c = xᴴa`, `X = xᴴx`, `A = aᴴa` and a
//! prediction derivative `s = ∂a/∂φ`:
//! `∂|c|²/∂φ = 2 Re(c̄ xᴴs)`, `∂A/∂φ = 2 Re(aᴴs)`, `∂|c|/∂φ = Re(c̄ xᴴs)/|c|`,
//! `∂χ_s = ∂|c|²/(XA) − |c|² ∂A/(XA²)`, `∂χ_a = 2∂|c|/(X + A) − 2|c| ∂A/(X + A)²`.

use faer::c64;

/// `χ_s`, `χ_a` and their derivatives at one line.
#[derive(Clone, Debug, PartialEq)]
pub struct ChiSensitivity {
    /// Shape correlation `χ_s` (4.8).
    pub chi_s: f64,
    /// Amplitude correlation `χ_a` (4.9).
    pub chi_a: f64,
    /// `∂χ_s/∂φ_p` per parameter.
    pub d_chi_s: Vec<f64>,
    /// `∂χ_a/∂φ_p` per parameter.
    pub d_chi_a: Vec<f64>,
}

fn dot(x: &[c64], y: &[c64]) -> c64 {
    x.iter()
        .zip(y)
        .fold(c64::new(0.0, 0.0), |s, (a, b)| s + a.conj() * b)
}

/// `χ_s`, `χ_a` of `x` (measured) against `a` (predicted) and their derivatives for each
/// column `s[p]` of `∂a/∂φ_p`. Where a coefficient is undefined (`X A = 0`, or `c = 0` for the
/// derivative of `|c|`) its value and derivatives are 0: nothing can be learnt at that line.
pub fn chi_sensitivity(x: &[c64], a: &[c64], s: &[&[c64]]) -> ChiSensitivity {
    let c = dot(x, a);
    let (xx, aa) = (dot(x, x).re, dot(a, a).re);
    let c2 = c.norm_sqr();
    let cn = c2.sqrt();
    let defined_s = xx * aa > 0.0;
    let defined_a = xx + aa > 0.0;
    let chi_s = if defined_s { c2 / (xx * aa) } else { 0.0 };
    let chi_a = if defined_a { 2.0 * cn / (xx + aa) } else { 0.0 };
    let mut d_chi_s = Vec::with_capacity(s.len());
    let mut d_chi_a = Vec::with_capacity(s.len());
    for sp in s {
        let xs = dot(x, sp);
        let dc2 = 2.0 * (c.conj() * xs).re;
        let da = 2.0 * dot(a, sp).re;
        let dcn = if cn > 0.0 {
            (c.conj() * xs).re / cn
        } else {
            0.0
        };
        d_chi_s.push(if defined_s {
            dc2 / (xx * aa) - c2 * da / (xx * aa * aa)
        } else {
            0.0
        });
        d_chi_a.push(if defined_a {
            2.0 * dcn / (xx + aa) - 2.0 * cn * da / ((xx + aa) * (xx + aa))
        } else {
            0.0
        });
    }
    ChiSensitivity {
        chi_s,
        chi_a,
        d_chi_s,
        d_chi_a,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::correlation::frf::{amplitude_correlation, shape_correlation};

    /// Against central differences along `a + t s` (step 1e-6 of a unit-size vector: truncation
    /// ~1e-12, round-off ~1e-10), and the values against the correlation module.
    #[test]
    fn chi_derivatives_match_central_differences() {
        let x: Vec<c64> = (0..4)
            .map(|i| c64::new(1.0 + i as f64, 0.5 - 0.3 * i as f64))
            .collect();
        let a: Vec<c64> = (0..4)
            .map(|i| c64::new(0.8 + 1.1 * i as f64, 0.2 - 0.4 * i as f64))
            .collect();
        let s1: Vec<c64> = (0..4).map(|i| c64::new(0.3 * i as f64, -0.2)).collect();
        let s2: Vec<c64> = (0..4).map(|i| c64::new(-0.1, 0.05 * i as f64)).collect();
        let r = chi_sensitivity(&x, &a, &[&s1, &s2]);
        assert!((r.chi_s - shape_correlation(&x, &a)).abs() < 1e-15);
        assert!((r.chi_a - amplitude_correlation(&x, &a)).abs() < 1e-15);
        for (p, s) in [&s1, &s2].iter().enumerate() {
            let h = 1e-6;
            let shifted = |t: f64| -> Vec<c64> {
                a.iter().zip(s.iter()).map(|(ai, si)| ai + si * t).collect()
            };
            let (ap, am) = (shifted(h), shifted(-h));
            let fs = (shape_correlation(&x, &ap) - shape_correlation(&x, &am)) / (2.0 * h);
            let fa = (amplitude_correlation(&x, &ap) - amplitude_correlation(&x, &am)) / (2.0 * h);
            assert!(
                (r.d_chi_s[p] - fs).abs() < 1e-8,
                "{p}: {} vs {fs}",
                r.d_chi_s[p]
            );
            assert!(
                (r.d_chi_a[p] - fa).abs() < 1e-8,
                "{p}: {} vs {fa}",
                r.d_chi_a[p]
            );
        }
    }

    /// One FRF: `χ_s ≡ 1`, so its derivative vanishes.
    #[test]
    fn single_frf_has_no_shape_sensitivity() {
        let r = chi_sensitivity(
            &[c64::new(1.0, 2.0)],
            &[c64::new(0.5, 1.0)],
            &[&[c64::new(0.3, 0.1)]],
        );
        assert!((r.chi_s - 1.0).abs() < 1e-15);
        assert!(r.d_chi_s[0].abs() < 1e-15);
        assert!(r.d_chi_a[0] != 0.0);
    }
}
