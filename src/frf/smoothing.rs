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
//! On discrete lines over a finite band the kernel is sampled at the measured lines and each
//! row normalised to unit sum (the lines outside the band are missing on both sides alike).

use faer::{Mat, MatRef, c64};

/// A linear smoothing operator over the lines of one frequency axis.
#[derive(Clone, Debug)]
pub struct FrequencySmoothing {
    /// Row `k` holds the normalised kernel weights of line `k` over all lines.
    weights: Mat<f64>,
}

impl FrequencySmoothing {
    /// The Poisson kernel with half-width `g f_k / 2` at line `k` (`g`: the added loss factor,
    /// positive) over the lines `freqs_hz`.
    pub fn new(freqs_hz: &[f64], g: f64) -> Self {
        let n = freqs_hz.len();
        let mut weights = Mat::<f64>::zeros(n, n);
        for (k, &fk) in freqs_hz.iter().enumerate() {
            let gamma = (0.5 * g * fk.abs()).max(f64::MIN_POSITIVE);
            let mut sum = 0.0;
            for (j, &fj) in freqs_hz.iter().enumerate() {
                let d = fj - fk;
                let w = gamma / (d * d + gamma * gamma);
                weights[(k, j)] = w;
                sum += w;
            }
            for j in 0..n {
                weights[(k, j)] /= sum;
            }
        }
        FrequencySmoothing { weights }
    }

    /// Number of lines.
    pub fn lines(&self) -> usize {
        self.weights.nrows()
    }

    /// The smoothed columns of `values` (one row per line).
    ///
    /// # Panics
    /// If `values` has another number of rows than there are lines.
    pub fn apply(&self, values: MatRef<'_, c64>) -> Mat<c64> {
        assert_eq!(values.nrows(), self.lines(), "one row per line");
        let (n, q) = (values.nrows(), values.ncols());
        Mat::from_fn(n, q, |k, c| {
            let mut acc = c64::new(0.0, 0.0);
            for j in 0..n {
                acc += values[(j, c)] * self.weights[(k, j)];
            }
            acc
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
