//! Frequency smoothing of FRFs by the Poisson (Cauchy) kernel: the continuation that lets a
//! correlation-based update start from a model whose resonances lie many half-power bandwidths
//! from the measured ones.
//!
//! Near resonance `r` a lightly damped FRF is `≈ c_r / (f_r − f + i b_r)` with half-width
//! `b_r = η_r f_r / 2`. Convolving such a function (analytic on one side of the real axis) with
//! the Poisson kernel `P_γ(x) = (γ/π) / (x² + γ²)` gives `c_r / (f_r − f + i (b_r + γ))`: the
//! same mode with its half-width widened by `γ`. Smoothing the measured and the predicted FRFs
//! by one kernel thus compares both as if every mode carried `γ` more damping, whatever the
//! damping of the structure: the resonance peaks broaden, a predicted peak a few bandwidths off
//! the measured one still overlaps it, and the correlation becomes a smooth function of the
//! frequency shift. The half-width here grows with frequency, `γ_k = g f_k / 2`, as structural
//! damping's does, so `g` reads as an added loss factor.
//!
//! On discrete lines over a finite band the kernel is sampled at the measured lines within 50
//! half-widths and each row normalised to unit sum (what lies outside is missing on both sides
//! alike): storage and work per line grow with the lines inside its window, not with the band.

use faer::{Mat, MatRef, c64};

/// Kernel weights beyond this many half-widths from a line are dropped (the Cauchy tail
/// beyond `x` holds `2γ/(πx)` of the mass: 1.3 % here), which keeps the operator banded.
const WINDOW_HALF_WIDTHS: f64 = 50.0;

/// A linear smoothing operator over the lines of one frequency axis, stored by rows as a band.
#[derive(Clone, Debug)]
pub struct FrequencySmoothing {
    /// Per line `k`: the first line its kernel reaches and the normalised weights from there.
    rows: Vec<(usize, Vec<f64>)>,
}

impl FrequencySmoothing {
    /// The Poisson kernel with half-width `g f_k / 2` at line `k` (`g`: the added loss factor,
    /// positive) over the ascending lines `freqs_hz`.
    pub fn new(freqs_hz: &[f64], g: f64) -> Self {
        let rows = freqs_hz
            .iter()
            .map(|&fk| {
                let gamma = (0.5 * g * fk.abs()).max(f64::MIN_POSITIVE);
                let reach = WINDOW_HALF_WIDTHS * gamma;
                let first = freqs_hz.partition_point(|&f| f < fk - reach);
                let last = freqs_hz.partition_point(|&f| f <= fk + reach);
                let mut w: Vec<f64> = freqs_hz[first..last]
                    .iter()
                    .map(|&fj| gamma / ((fj - fk).powi(2) + gamma * gamma))
                    .collect();
                let sum: f64 = w.iter().sum();
                w.iter_mut().for_each(|x| *x /= sum);
                (first, w)
            })
            .collect();
        FrequencySmoothing { rows }
    }

    /// Number of lines.
    pub fn lines(&self) -> usize {
        self.rows.len()
    }

    /// The smoothed columns of `values` (one row per line).
    ///
    /// # Panics
    /// If `values` has another number of rows than there are lines.
    pub fn apply(&self, values: MatRef<'_, c64>) -> Mat<c64> {
        assert_eq!(values.nrows(), self.lines(), "one row per line");
        Mat::from_fn(values.nrows(), values.ncols(), |k, c| {
            let (first, w) = &self.rows[k];
            w.iter()
                .enumerate()
                .fold(c64::new(0.0, 0.0), |acc, (i, &wi)| {
                    acc + values[(first + i, c)] * wi
                })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One mode `1 / (f_r − f + i b)` smoothed over a fine, wide axis is the mode with
    /// half-width `b + γ_k` at every line `k` (the Poisson integral of a function analytic in
    /// a half-plane is its value `γ_k` inside it). Tolerance 2e-2 relative to the peak: the
    /// sampled kernel misses its tails beyond the 80 Hz band (about `2γ/(π·40 Hz)` of its mass).
    #[test]
    fn smoothing_a_mode_widens_its_half_power_band_by_the_kernel_width() {
        let (fr, b, g) = (50.0, 0.25, 0.04);
        let freqs: Vec<f64> = (0..1600).map(|k| 10.0 + 0.05 * k as f64).collect();
        let mode =
            |f: f64, width: f64| c64::new(fr - f, -width) / ((fr - f).powi(2) + width * width);
        let values = Mat::from_fn(freqs.len(), 1, |k, _| mode(freqs[k], b));
        let smoothed = FrequencySmoothing::new(&freqs, g).apply(values.as_ref());
        let peak = 1.0 / (b + 0.5 * g * fr);
        for (k, &f) in freqs.iter().enumerate() {
            if (f - fr).abs() < 5.0 {
                let expected = mode(f, b + 0.5 * g * f);
                let err = (smoothed[(k, 0)] - expected).norm() / peak;
                assert!(err < 2e-2, "at {f} Hz: {err}");
            }
        }
        // Far from any smoothing, a constant stays itself.
        let ones = Mat::from_fn(freqs.len(), 1, |_, _| c64::new(1.0, 0.0));
        let s = FrequencySmoothing::new(&freqs, g).apply(ones.as_ref());
        assert!((0..freqs.len()).all(|k| (s[(k, 0)] - c64::new(1.0, 0.0)).norm() < 1e-12));
    }
}
