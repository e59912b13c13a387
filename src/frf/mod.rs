//! Frequency response functions: the FRF set type, synthesis by modal summation and by direct
//! solution of the dynamic stiffness, and simulated measurement noise (docs/theory.md §1, §10).

pub mod direct;
pub mod io;
pub mod krylov;
pub mod modal;
pub mod noise;
pub mod residual;
pub mod smoothing;

use crate::core::DofId;
use faer::{Mat, c64};

pub use direct::{DirectDamping, DirectError, direct_receptance};
pub use krylov::{KrylovError, KrylovOptions, KrylovReport, krylov_receptance};
pub use modal::{ModalDamping, ModalError, modal_receptance};
pub use noise::{NoiseModel, add_noise};
pub use residual::{ResidualError, add_residual, static_residual};
pub use smoothing::FrequencySmoothing;

/// Which response quantity an FRF holds (1.4).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Displacement per force, `α = Z⁻¹`, m/N.
    Receptance,
    /// Velocity per force, `Y = iω α`, m/s/N.
    Mobility,
    /// Acceleration per force, `A = −ω² α`, m/s²/N.
    Accelerance,
}

impl Quantity {
    /// The factor that turns a receptance at `ω` (rad/s) into this quantity.
    pub fn factor(self, omega: f64) -> c64 {
        match self {
            Quantity::Receptance => c64::new(1.0, 0.0),
            Quantity::Mobility => c64::new(0.0, omega),
            Quantity::Accelerance => c64::new(-omega * omega, 0.0),
        }
    }

    /// SI unit of the quantity (translational response per force).
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::Receptance => "m/N",
            Quantity::Mobility => "m/s/N",
            Quantity::Accelerance => "m/s^2/N",
        }
    }

    /// The name used in artefacts.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::Receptance => "receptance",
            Quantity::Mobility => "mobility",
            Quantity::Accelerance => "accelerance",
        }
    }

    /// Quantity from its name.
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "receptance" => Some(Quantity::Receptance),
            "mobility" => Some(Quantity::Mobility),
            "accelerance" => Some(Quantity::Accelerance),
            _ => None,
        }
    }
}

/// A response/excitation DOF pair naming one FRF `H_ij`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FrfPair {
    /// Response DOF `i`.
    pub response: DofId,
    /// Excitation DOF `j`.
    pub excitation: DofId,
}

/// A set of FRFs on common frequency lines: `values[(line, pair)]`.
#[derive(Clone, Debug)]
pub struct FrfSet {
    /// Quantity of every FRF.
    pub quantity: Quantity,
    /// Frequency lines in Hz, ascending.
    pub freqs_hz: Vec<f64>,
    /// The FRFs, one per column of `values`.
    pub pairs: Vec<FrfPair>,
    /// Complex values, one row per line, one column per pair.
    pub values: Mat<c64>,
}

impl FrfSet {
    /// Column index of a pair.
    pub fn pair_index(&self, pair: &FrfPair) -> Option<usize> {
        self.pairs.iter().position(|p| p == pair)
    }

    /// The lines `keep` accepts (by frequency in Hz), every pair kept, in order.
    pub fn select_lines(&self, keep: impl Fn(f64) -> bool) -> FrfSet {
        let rows: Vec<usize> = (0..self.freqs_hz.len())
            .filter(|&k| keep(self.freqs_hz[k]))
            .collect();
        FrfSet {
            quantity: self.quantity,
            freqs_hz: rows.iter().map(|&k| self.freqs_hz[k]).collect(),
            pairs: self.pairs.clone(),
            values: Mat::from_fn(rows.len(), self.pairs.len(), |i, j| {
                self.values[(rows[i], j)]
            }),
        }
    }

    /// The DOFs the pairs touch, in order of first appearance.
    pub fn dofs(&self) -> Vec<DofId> {
        let mut out: Vec<DofId> = Vec::new();
        for p in &self.pairs {
            for d in [p.response, p.excitation] {
                if !out.contains(&d) {
                    out.push(d);
                }
            }
        }
        out
    }

    /// All pairs `(r, e)` for each excitation `e`, then each response `r`.
    pub fn all_pairs(responses: &[DofId], excitations: &[DofId]) -> Vec<FrfPair> {
        excitations
            .iter()
            .flat_map(|e| {
                responses.iter().map(move |r| FrfPair {
                    response: *r,
                    excitation: *e,
                })
            })
            .collect()
    }
}

/// How many lines [`frequency_lines`] makes, counted in floating point so that an absurd step
/// gives a huge count instead of wrapping around; `None` when the band or step is not finite,
/// the band is reversed or the step is not positive, or when the step is too small to separate
/// neighbouring lines at `stop_hz` (they would repeat in `f64`).
pub fn frequency_line_count(start_hz: f64, stop_hz: f64, step_hz: f64) -> Option<f64> {
    let finite = start_hz.is_finite() && stop_hz.is_finite() && step_hz.is_finite();
    if !finite || start_hz < 0.0 || stop_hz < start_hz || !(step_hz > 0.0) {
        return None;
    }
    // Successive lines must differ by many ulps of the largest line.
    if step_hz <= 64.0 * f64::EPSILON * stop_hz.abs() {
        return None;
    }
    Some(((stop_hz - start_hz) / step_hz + 1e-9).floor() + 1.0)
}

/// Frequency lines `start, start + step, …` up to `stop` inclusive (within 1e-9 of a step).
/// Callers bound the count with [`frequency_line_count`] first: the lines are allocated.
pub fn frequency_lines(start_hz: f64, stop_hz: f64, step_hz: f64) -> Vec<f64> {
    let count = frequency_line_count(start_hz, stop_hz, step_hz).unwrap_or(0.0) as usize;
    (0..count).map(|i| start_hz + i as f64 * step_hz).collect()
}

/// Converts receptance values in place into `quantity`.
pub fn convert_from_receptance(set: &mut FrfSet, quantity: Quantity) {
    for (k, f) in set.freqs_hz.iter().enumerate() {
        let factor = quantity.factor(2.0 * std::f64::consts::PI * f);
        for j in 0..set.pairs.len() {
            set.values[(k, j)] *= factor;
        }
    }
    set.quantity = quantity;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_include_the_end_point() {
        let l = frequency_lines(0.0, 40.0, 0.05);
        assert_eq!(l.len(), 801);
        assert!((l[800] - 40.0).abs() < 1e-12);
        assert_eq!(frequency_lines(1.0, 1.0, 0.5), vec![1.0]);
    }
}
