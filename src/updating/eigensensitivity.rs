//! Classical inverse eigensensitivity updating from measured natural frequencies (and, when
//! measured shapes are given, modes paired by MAC) — the method of FEMtools and SOL 200, here
//! for comparison with the FRF-based methods.
//!
//! For each paired mode `r`: `(λ_X,r − λ_A,r)/λ_A,r = Σ_j (φ_j ∂λ_r/∂φ_j / λ_A,r) Δφ_j/φ_j`
//! with `∂λ_r/∂φ = φ_rᵀ(∂K/∂φ − λ_r ∂M/∂φ)φ_r` (5.3), solved by (subset-selected) least
//! squares and iterated.

use super::model::{ModalState, ParametricModel, UpdatingError};
use super::solve::{
    ParameterWeighting, diagnostics, select_subset, subset_condition_limit, weighted_step,
};
use super::{IterationRecord, Step, UpdateMethod};
use crate::core::DofId;
use crate::correlation::mac;
use crate::eigen::ModeSelection;
use crate::sensitivity::eigenvalue_sensitivity;
use faer::{Mat, MatRef};

/// Measured modes: eigenvalues and, optionally, shapes at measured DOFs.
#[derive(Clone, Debug)]
pub struct MeasuredModes {
    /// `λ_X = ω²` of the measured elastic modes (rad²/s²), ascending.
    pub eigenvalues: Vec<f64>,
    /// Shapes at `dofs` (rows) per measured mode (columns), for MAC pairing.
    pub shapes: Option<(Vec<DofId>, Mat<f64>)>,
}

/// Settings of inverse eigensensitivity.
#[derive(Clone, Debug)]
pub struct EigenSettings {
    /// Modes of the model's basis (enough to pair every measured mode).
    pub modes: ModeSelection,
    /// Smallest MAC accepted for a pair.
    pub min_mac: f64,
    /// Stop when every relative change is below this.
    pub tolerance: f64,
    /// Subset selection `κ`, or every parameter.
    pub subset_kappa: Option<f64>,
    /// `W_φ`.
    pub weighting: ParameterWeighting,
}

impl Default for EigenSettings {
    fn default() -> Self {
        EigenSettings {
            modes: ModeSelection::All,
            min_mac: 0.6,
            tolerance: 1e-8,
            subset_kappa: None,
            weighting: ParameterWeighting::None,
        }
    }
}

/// The method against measured modes.
pub struct InverseEigensensitivity<'a> {
    /// Measured modes.
    pub measured: &'a MeasuredModes,
    /// Settings.
    pub settings: EigenSettings,
}

impl InverseEigensensitivity<'_> {
    /// Analytical mode paired with each measured mode (`None` when no MAC reaches `min_mac`).
    pub fn pairs(&self, state: &ModalState) -> Result<Vec<Option<usize>>, UpdatingError> {
        let elastic: Vec<usize> = (0..state.modes.len())
            .filter(|&r| state.modes.eigenvalues[r] > 0.0)
            .collect();
        let nx = self.measured.eigenvalues.len();
        match &self.measured.shapes {
            None => {
                if elastic.len() < nx {
                    return Err(UpdatingError::Settings(format!(
                        "{nx} measured modes but only {} elastic modes in the model's basis: raise the mode count",
                        elastic.len()
                    )));
                }
                Ok(elastic.into_iter().take(nx).map(Some).collect())
            }
            Some((dofs, shapes)) => {
                let a = state.shapes_at(dofs)?;
                let pairs = mac_pairs(shapes.as_ref(), a.as_ref(), &elastic, self.settings.min_mac);
                Ok(pairs.into_iter().map(|p| p.map(|(r, _)| r)).collect())
            }
        }
    }
}

/// Greedy MAC pairing: each measured shape (column of `measured`), in order, takes the
/// candidate model mode (column of `model`, same rows) of highest MAC not taken before, with
/// that MAC, when it reaches `min_mac`; `None` when none does (that mode stays free).
pub fn mac_pairs(
    measured: MatRef<'_, f64>,
    model: MatRef<'_, f64>,
    candidates: &[usize],
    min_mac: f64,
) -> Vec<Option<(usize, f64)>> {
    let column =
        |a: MatRef<'_, f64>, j: usize| -> Vec<f64> { (0..a.nrows()).map(|i| a[(i, j)]).collect() };
    let mut used = vec![false; model.ncols()];
    (0..measured.ncols())
        .map(|x| {
            let xs = column(measured, x);
            let best = candidates
                .iter()
                .filter(|&&r| !used[r])
                .map(|&r| (r, mac(&xs, &column(model, r))))
                .fold(None, |best: Option<(usize, f64)>, c| match best {
                    Some(b) if b.1 >= c.1 => Some(b),
                    _ => Some(c),
                })
                .filter(|&(_, m)| m >= min_mac);
            if let Some((r, _)) = best {
                used[r] = true;
            }
            best
        })
        .collect()
}

impl UpdateMethod for InverseEigensensitivity<'_> {
    fn equations_from(&self) -> &'static str {
        "modes"
    }

    fn iterate(
        &self,
        model: &dyn ParametricModel,
        values: &[f64],
        iteration: usize,
    ) -> Result<Step, UpdatingError> {
        let n = values.len();
        let (state, _) = model.modal_state(values, self.settings.modes)?;
        let pairs = self.pairs(&state)?;
        let used: Vec<(usize, usize)> = pairs
            .iter()
            .enumerate()
            .filter_map(|(x, a)| a.map(|a| (x, a)))
            .collect();
        if used.is_empty() {
            return Err(UpdatingError::Data(format!(
                "no measured mode pairs with a model mode at MAC >= {}",
                self.settings.min_mac
            )));
        }
        let dl: Vec<Vec<f64>> = state
            .projected
            .iter()
            .map(|d| eigenvalue_sensitivity(&state.modes.eigenvalues, d))
            .collect();
        let m = used.len();
        let s = Mat::from_fn(m, n, |i, j| {
            let (_, a) = used[i];
            dl[j][a] / state.modes.eigenvalues[a]
        });
        let eps: Vec<f64> = used
            .iter()
            .map(|&(x, a)| {
                let la = state.modes.eigenvalues[a];
                (self.measured.eigenvalues[x] - la) / la
            })
            .collect();
        let mut record = IterationRecord {
            iteration,
            values: values.to_vec(),
            relative_change: vec![0.0; n],
            active: vec![false; n],
            lines_used: m,
            mean_chi_s: f64::NAN,
            mean_chi_a: f64::NAN,
            residual_norm: eps.iter().map(|e| e * e).sum::<f64>().sqrt(),
            condition_limit: f64::NAN,
            smoothing: 0.0,
            smoothed_mean_chi: f64::NAN,
            diagnostics: diagnostics(s.as_ref()),
        };
        let active: Vec<usize> = match self.settings.subset_kappa {
            Some(kappa) => {
                let limit = subset_condition_limit(kappa, m, n);
                record.condition_limit = limit;
                select_subset(s.as_ref(), limit)
            }
            None => (0..n).collect(),
        };
        for &a in &active {
            record.active[a] = true;
        }
        record.relative_change = weighted_step(s.as_ref(), &eps, &active, self.settings.weighting);
        Ok(Step::new(record, None))
    }

    fn converged_by_step(&self, relative_change: &[f64]) -> bool {
        relative_change
            .iter()
            .all(|d| d.abs() < self.settings.tolerance)
    }
}
