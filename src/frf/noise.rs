//! Simulated measurement noise (docs/theory.md §10).
//!
//! - Thesis noise (2.29): `H̃ = H (1 + p ε)`, `ε` uniform on `[a, b]`, drawn independently for
//!   every FRF value. The thesis text lost the interval's lower bound; `[0, 1]` is the default
//!   reading (docs/theory.md §10), `[-1, 1]` the zero-mean alternative.
//! - Complex Gaussian noise at a signal-to-noise ratio: per FRF, `σ² = mean_k |H_k|² / 10^(SNR/10)`,
//!   `H̃ = H + σ (g₁ + i g₂)/√2`, `g` standard normal.
//!
//! Every FRF draws from its own ChaCha8 stream (`seed`, stream = FRF index), so the numbers do not
//! depend on thread count or on which other FRFs are in the set.

use super::FrfSet;
use faer::c64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

/// A noise model.
#[derive(Clone, Debug, PartialEq)]
pub enum NoiseModel {
    /// `H (1 + p ε)`, `ε ~ U[lower, upper]` (2.29).
    Multiplicative {
        /// Level `p` (0.05 for 5 %).
        level: f64,
        /// Lower end of the interval of `ε`.
        lower: f64,
        /// Upper end of the interval of `ε`.
        upper: f64,
    },
    /// Additive complex Gaussian noise at a per-FRF signal-to-noise ratio in dB.
    Gaussian {
        /// SNR in dB.
        snr_db: f64,
    },
}

/// Adds noise to every value of `set` in place, reproducibly from `seed`.
pub fn add_noise(set: &mut FrfSet, model: &NoiseModel, seed: u64) {
    let lines = set.freqs_hz.len();
    let columns: Vec<Vec<c64>> = (0..set.pairs.len())
        .into_par_iter()
        .map(|p| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(p as u64);
            let column: Vec<c64> = (0..lines).map(|k| set.values[(k, p)]).collect();
            match *model {
                NoiseModel::Multiplicative {
                    level,
                    lower,
                    upper,
                } => column
                    .iter()
                    .map(|h| {
                        let eps = lower + (upper - lower) * rng.random::<f64>();
                        *h * (1.0 + level * eps)
                    })
                    .collect(),
                NoiseModel::Gaussian { snr_db } => {
                    let power =
                        column.iter().map(|h| h.norm_sqr()).sum::<f64>() / lines.max(1) as f64;
                    let sigma =
                        (power / 10f64.powf(snr_db / 10.0)).sqrt() / std::f64::consts::SQRT_2;
                    column
                        .iter()
                        .map(|h| {
                            let g1: f64 = StandardNormal.sample(&mut rng);
                            let g2: f64 = StandardNormal.sample(&mut rng);
                            *h + c64::new(sigma * g1, sigma * g2)
                        })
                        .collect()
                }
            }
        })
        .collect();
    for (p, column) in columns.into_iter().enumerate() {
        for (k, v) in column.into_iter().enumerate() {
            set.values[(k, p)] = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::{FrfPair, Quantity};
    use faer::Mat;

    fn constant_set(lines: usize, pairs: usize) -> FrfSet {
        let dof = "1:ux".parse().unwrap();
        FrfSet {
            quantity: Quantity::Receptance,
            freqs_hz: (0..lines).map(|k| k as f64).collect(),
            pairs: vec![
                FrfPair {
                    response: dof,
                    excitation: dof
                };
                pairs
            ],
            values: Mat::from_fn(lines, pairs, |_, _| c64::new(2.0, -1.0)),
        }
    }

    #[test]
    fn multiplicative_noise_stays_in_its_interval_and_keeps_phase() {
        let mut s = constant_set(2000, 2);
        add_noise(
            &mut s,
            &NoiseModel::Multiplicative {
                level: 0.1,
                lower: 0.0,
                upper: 1.0,
            },
            7,
        );
        let mut mean = 0.0;
        for k in 0..2000 {
            let ratio = s.values[(k, 0)] / c64::new(2.0, -1.0);
            assert!(ratio.im.abs() < 1e-15 && (1.0..=1.1).contains(&ratio.re));
            mean += (ratio.re - 1.0) / 0.1;
        }
        // Mean of U[0, 1] is 1/2; with 2000 draws its standard error is 0.0065.
        assert!((mean / 2000.0 - 0.5).abs() < 0.03);
    }

    #[test]
    fn same_seed_same_draws_other_seed_other_draws() {
        let model = NoiseModel::Gaussian { snr_db: 20.0 };
        let (mut a, mut b, mut c) = (
            constant_set(50, 3),
            constant_set(50, 3),
            constant_set(50, 3),
        );
        add_noise(&mut a, &model, 1);
        add_noise(&mut b, &model, 1);
        add_noise(&mut c, &model, 2);
        assert_eq!(a.values, b.values);
        assert_ne!(a.values, c.values);
        // FRF columns draw from independent streams.
        assert_ne!(a.values[(0, 0)], a.values[(0, 1)]);
    }

    #[test]
    fn gaussian_noise_has_the_requested_snr() {
        let mut s = constant_set(20000, 1);
        add_noise(&mut s, &NoiseModel::Gaussian { snr_db: 10.0 }, 3);
        let noise_power: f64 = (0..20000)
            .map(|k| (s.values[(k, 0)] - c64::new(2.0, -1.0)).norm_sqr())
            .sum::<f64>()
            / 20000.0;
        let snr = 10.0 * (5.0 / noise_power).log10();
        assert!((snr - 10.0).abs() < 0.1, "{snr}");
    }
}
