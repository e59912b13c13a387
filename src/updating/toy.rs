//! A linear-Gaussian likelihood for the samplers' and the posterior's unit tests.

use super::model::UpdatingError;
use super::posterior::{Likelihood, Prediction};
use faer::Mat;

/// `f(φ) = A φ`, one noise group: under a flat prior the posterior is Gaussian with mean
/// `(AᵀA)⁻¹Aᵀy` and covariance `σ²(AᵀA)⁻¹`; the Jacobian in unity coordinates is `A diag(φ)`.
pub(crate) struct Linear {
    /// `A`.
    pub a: Mat<f64>,
    /// `y`.
    pub y: Vec<f64>,
    /// Noise group of every row.
    pub groups: Vec<usize>,
}

impl Likelihood for Linear {
    fn measured(&self) -> &[f64] {
        &self.y
    }
    fn groups(&self) -> &[usize] {
        &self.groups
    }
    fn group_names(&self) -> Vec<String> {
        vec!["all".into()]
    }
    fn pooled(&self) -> bool {
        true
    }
    fn scale(&self) -> Vec<f64> {
        vec![1.0; self.y.len()]
    }
    fn predict(&self, values: &[f64], jacobian: bool) -> Result<Prediction, UpdatingError> {
        let (m, n) = self.a.shape();
        Ok(Prediction {
            values: (0..m)
                .map(|i| (0..n).map(|j| self.a[(i, j)] * values[j]).sum())
                .collect(),
            jacobian: jacobian.then(|| Mat::from_fn(m, n, |i, j| self.a[(i, j)] * values[j])),
        })
    }
}
