//! Modal damping identification (docs/theory.md §8; thesis ch. 6).
//!
//! The spatial model is fixed; the parameters are the modal loss factors `η_r` (structural) or
//! damping ratios `ζ_r` (viscous) of chosen elastic modes. The equations are the P-C's
//! (4.16–4.21: (4.16), (4.17), (4.18), (4.19), (4.20), (4.21)) with the exact damping sensitivities
//! (6.8, 6.11) as the columns of `S`, unity based: `η_r ∂H/∂η_r`. Each `η_r` acts near its own
//! resonance, so the columns are nearly orthogonal and every parameter is updated (no subset
//! selection). Rigid-body modes have no damping and are never parameters.
//!
//! A viscous model fitted to structurally damped measurements matches them only near each
//! resonance, where `η_r ≈ 2ζ_r` ([`equivalent_loss_factor`]).

use super::model::{Evaluated, ModalState, ParametricModel, UpdatingError, UpdatingParameter};
use super::pc::{close_iteration, correlation_equations, open_iteration, predict};
use super::solve::ParameterWeighting;
use super::{IterationRecord, Step, UpdateMethod};
use crate::fe::SystemMatrices;
use crate::frf::{FrfSet, ModalDamping};
use crate::sensitivity::{ModalFrfModel, damping_sensitivities};
use faer::{Mat, c64};

/// Which modal damping model is identified.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DampingKind {
    /// Structural loss factors `η_r`.
    Structural,
    /// Viscous damping ratios `ζ_r`.
    Viscous,
}

impl DampingKind {
    /// Parameter name of 1-based mode number `mode`: `eta_7`, `zeta_7`.
    pub fn parameter_name(self, mode: usize) -> String {
        match self {
            DampingKind::Structural => format!("eta_{mode}"),
            DampingKind::Viscous => format!("zeta_{mode}"),
        }
    }
}

/// The structural loss factor a viscous ratio is equivalent to at resonance: `η = 2ζ`.
pub fn equivalent_loss_factor(zeta: f64) -> f64 {
    2.0 * zeta
}

/// Settings of the damping identification.
#[derive(Clone, Debug)]
pub struct DampingSettings {
    /// The damping model identified.
    pub kind: DampingKind,
    /// Damping of every mode of the basis at the start (`η_r` or `ζ_r`, one per mode).
    pub initial: Vec<f64>,
    /// Indices (0-based, into the basis) of the modes whose damping is identified.
    pub modes: Vec<usize>,
    /// Lines with `(χ_s + χ_a)/2 > κ_f` are left out (4.20).
    pub kappa_f: f64,
    /// Lines within this many line spacings of a predicted natural frequency are left out.
    pub resonance_lines: f64,
    /// Stop when the mean of `(χ_s + χ_a)/2` over all lines reaches this (4.23).
    pub stop_chi: f64,
    /// Stop when every relative change is below this, or the objective improves by less than a
    /// tenth of it.
    pub tolerance: f64,
    /// Largest relative change of one parameter in one step.
    pub max_step: f64,
    /// `κ` of the subset selection `κ_mn = 1 + κ(n/m)²` (5.14); `None` updates every mode.
    /// Modes whose damping the measurements barely see (outside the band, or at a node of
    /// every measured DOF) give near-zero columns that least squares would fill with noise;
    /// the selection leaves them alone.
    pub subset_kappa: Option<f64>,
}

impl Default for DampingSettings {
    /// The thesis's damping identification (ch. 6): every line (`κ_f = 1`, no resonance
    /// exclusion: damping acts near the resonances), the step tolerance as the stop rule (a 1 %
    /// change of a loss factor is below what noisy FRFs resolve), and `κ = 1e7`, which leaves
    /// alone the modes the measurements cannot see.
    fn default() -> Self {
        DampingSettings {
            kind: DampingKind::Structural,
            initial: Vec::new(),
            modes: Vec::new(),
            kappa_f: 1.0,
            resonance_lines: 0.0,
            stop_chi: 1.0,
            tolerance: 1e-2,
            max_step: 1.0,
            subset_kappa: Some(1e7),
        }
    }
}

/// The damping identification against one measured FRF set, on a fixed modal state.
pub struct DampingIdentification<'a> {
    measured: &'a FrfSet,
    state: &'a ModalState,
    /// Mode shapes at the measured DOFs.
    shapes: Mat<f64>,
    settings: DampingSettings,
}

impl<'a> DampingIdentification<'a> {
    /// Checks the settings against the modal state: one initial value per mode, identified
    /// modes inside the basis, elastic, and listed once.
    pub fn new(
        measured: &'a FrfSet,
        state: &'a ModalState,
        settings: DampingSettings,
    ) -> Result<Self, UpdatingError> {
        let m = state.modes.len();
        if settings.initial.len() != m {
            return Err(UpdatingError::Settings(format!(
                "{} initial damping values for {m} modes",
                settings.initial.len()
            )));
        }
        let mut seen = vec![false; m];
        for &r in &settings.modes {
            if r >= m {
                return Err(UpdatingError::Settings(format!(
                    "mode {} is not in the modal basis (modes 1 to {m})",
                    r + 1
                )));
            }
            if state.modes.eigenvalues[r] == 0.0 {
                return Err(UpdatingError::Settings(format!(
                    "mode {} is a rigid-body mode: it has no damping to identify",
                    r + 1
                )));
            }
            if std::mem::replace(&mut seen[r], true) {
                return Err(UpdatingError::Settings(format!(
                    "mode {} is listed twice",
                    r + 1
                )));
            }
            if !(settings.initial[r] > 0.0 && settings.initial[r].is_finite()) {
                return Err(UpdatingError::Settings(format!(
                    "mode {} starts with damping {}: identification needs a positive value",
                    r + 1,
                    settings.initial[r]
                )));
            }
        }
        if settings.modes.is_empty() {
            return Err(UpdatingError::Settings(
                "no elastic mode to identify the damping of".into(),
            ));
        }
        let shapes = state.shapes_at(&measured.dofs())?;
        Ok(DampingIdentification {
            measured,
            state,
            shapes,
            settings,
        })
    }

    /// The parameters: one per identified mode, named by its 1-based number, between
    /// `10⁻⁶` times and `100` times the initial value (and below 1 for `ζ`).
    pub fn parameters(&self) -> Vec<UpdatingParameter> {
        let s = &self.settings;
        s.modes
            .iter()
            .map(|&r| {
                let v = s.initial[r];
                let cap = match s.kind {
                    DampingKind::Structural => 100.0 * v,
                    DampingKind::Viscous => (100.0 * v).min(1.0),
                };
                UpdatingParameter {
                    name: s.kind.parameter_name(r + 1),
                    initial: v,
                    lower: 1e-6 * v,
                    upper: cap.max(v),
                }
            })
            .collect()
    }

    /// The modal damping of every mode of the basis at `values`.
    pub fn damping(&self, values: &[f64]) -> ModalDamping {
        let mut all = self.settings.initial.clone();
        for (&r, &v) in self.settings.modes.iter().zip(values) {
            all[r] = v;
        }
        match self.settings.kind {
            DampingKind::Structural => ModalDamping::Structural(all),
            DampingKind::Viscous => ModalDamping::Viscous(all),
        }
    }
}

/// Unity-based columns `v_r ∂H/∂v_r` of the identified `modes` (one per damping value) from
/// every mode's `∂H/∂v_r` (`per_mode`).
pub(super) fn unity_columns(
    per_mode: &[Mat<c64>],
    modes: &[usize],
    values: &[f64],
) -> Vec<Mat<c64>> {
    modes
        .iter()
        .zip(values)
        .map(|(&r, &v)| {
            let d = &per_mode[r];
            Mat::from_fn(d.nrows(), d.ncols(), |i, j| d[(i, j)] * v)
        })
        .collect()
}

impl UpdateMethod for DampingIdentification<'_> {
    fn iterate(
        &self,
        _model: &dyn ParametricModel,
        values: &[f64],
        iteration: usize,
    ) -> Result<Step, UpdatingError> {
        let s = &self.settings;
        let damping = self.damping(values);
        let predicted = predict(self.state, self.measured, &damping)?;
        let (record, stop, chosen) = open_iteration(
            self.measured,
            &predicted,
            &self.state.modes.frequencies_hz(),
            values,
            iteration,
            s.kappa_f,
            s.resonance_lines,
            s.stop_chi,
        );
        if stop.is_some() {
            return Ok(Step::new(record, stop));
        }
        let dofs = self.measured.dofs();
        let modal = ModalFrfModel {
            eigenvalues: &self.state.modes.eigenvalues,
            shapes: self.shapes.as_ref(),
            dofs: &dofs,
            damping: &damping,
        };
        let freqs: Vec<f64> = chosen.iter().map(|&k| self.measured.freqs_hz[k]).collect();
        let per_mode =
            damping_sensitivities(&modal, &self.measured.pairs, &freqs, self.measured.quantity)?;
        let columns = unity_columns(&per_mode, &s.modes, values);
        let (sw, ew) = correlation_equations(self.measured, &predicted, &chosen, &columns, true);
        Ok(close_iteration(
            record,
            sw.as_ref(),
            &ew,
            s.subset_kappa,
            ParameterWeighting::None,
            s.max_step,
            None,
        ))
    }

    fn converged_by_step(&self, applied: &[f64]) -> bool {
        applied.iter().all(|d| d.abs() < self.settings.tolerance)
    }

    /// Also converged when the objective `‖W_f^{1/2} ε‖` improved by less than a tenth of the
    /// tolerance, relatively: with noisy data the optimum has a residual, and weakly seen modes
    /// can creep on long after the fit stopped improving.
    fn converged_by_merit(&self, before: &IterationRecord, after: &IterationRecord) -> bool {
        let (b, a) = (before.residual_norm, after.residual_norm);
        b > 0.0 && (b - a) / b < 0.1 * self.settings.tolerance
    }

    /// The least-squares objective itself, `−‖W_f^{1/2} ε‖` (over every line with the default
    /// `κ_f = 1`): with noisy data the best `χ` stays below 1, and a merit other than the
    /// objective the steps minimise (such as the mean `χ`) would keep the candidate search
    /// hopping between the two optima instead of converging.
    fn merit(&self, record: &IterationRecord) -> Option<f64> {
        Some(-record.residual_norm)
    }
}

/// The damping parameters as a model for [`super::run`]: the spatial system does not change.
pub struct DampingParameters {
    parameters: Vec<UpdatingParameter>,
    system: SystemMatrices,
}

impl DampingParameters {
    /// The parameters of `method` on the fixed `system`.
    pub fn new(method: &DampingIdentification<'_>, system: SystemMatrices) -> Self {
        DampingParameters {
            parameters: method.parameters(),
            system,
        }
    }
}

impl ParametricModel for DampingParameters {
    fn parameters(&self) -> &[UpdatingParameter] {
        &self.parameters
    }

    fn evaluate(&self, _values: &[f64]) -> Result<Evaluated, UpdatingError> {
        Ok(Evaluated {
            system: self.system.clone(),
            derivatives: Vec::new(),
        })
    }
}
