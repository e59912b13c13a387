//! Error localisation (thesis ch. 5, docs/theory.md §7): which candidate parameters can best
//! explain the discrepancy between measured and predicted FRFs.
//!
//! - [`leverage_map`]: the correlation-based leverage `L_i = (S_iᵀε)²/(S_iᵀS_i)` (5.9) of every
//!   candidate over the updating lines (4.20; by default every line but those at predicted
//!   resonances), `S` and `ε` as in the P-C (4.16) with the thesis's unweighted equations
//!   (5.4) by default; candidates are processed in chunks, so every element of a large model
//!   can be one.
//! - [`eigenvalue_map`]: the classical eigenvalue sensitivity `φ_i ∂λ_r/∂φ_i` (5.3) of chosen
//!   modes, normalised per mode.
//!
//! The analysis is of the full finite-element model at its current parameter values, on its
//! modes to twice the band plus the static share of the higher modes ([`residual`]), which
//! stands in for the constraint modes of the thesis's Craig-Bampton model.

pub mod candidates;
pub mod eigen_maps;
pub mod leverage;
pub mod residual;

pub use candidates::{Candidate, LocalDerivative, declared_candidates, element_candidates};
pub use leverage::{ChunkTerms, ColumnFit, Equations, chunked_fits, column_fit, column_fits};
pub use residual::StaticShare;

use crate::core::DofId;
use crate::eigen::{ModeSelection, Modes, SparseEigenParams, lowest_modes};
use crate::fe::SystemMatrices;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::assemble_model;
use crate::frf::{FrfSet, ModalDamping};
use crate::model::Model;
use crate::sensitivity::ModalFrfModel;
use crate::updating::ModalState;
use crate::updating::pc::{LineCorrelation, predict, select_lines};
use rayon::prelude::*;
use std::collections::HashMap;

/// Why a localisation could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum LocalisationError {
    /// Settings that do not fit the model or the data; the message names the field.
    #[error("{0}")]
    Settings(String),
    /// The model could not be assembled or differentiated.
    #[error("the model: {0}")]
    Model(String),
    /// The model could not be assembled or differentiated.
    #[error("the model: {0}")]
    Assembly(#[from] crate::fe::model_assembly::ModelAssemblyError),
    /// A parameter's value could not be read.
    #[error("the model: {0}")]
    Parameter(#[from] crate::model::parameters::ParameterValueError),
    /// The eigen solution failed.
    #[error("modal analysis: {0}")]
    Eigen(#[from] crate::eigen::EigenError),
    /// An FRF or its sensitivity could not be formed.
    #[error(transparent)]
    Modal(#[from] crate::frf::ModalError),
    /// The prediction at the measured DOFs failed.
    #[error(transparent)]
    Updating(#[from] crate::updating::UpdatingError),
}

impl crate::core::InputFault for LocalisationError {
    fn is_input(&self) -> bool {
        match self {
            LocalisationError::Settings(_) => true,
            LocalisationError::Model(_) => false,
            LocalisationError::Assembly(e) => e.is_input(),
            LocalisationError::Parameter(e) => e.is_input(),
            LocalisationError::Eigen(e) => e.is_input(),
            LocalisationError::Modal(e) => e.is_input(),
            LocalisationError::Updating(e) => e.is_input(),
        }
    }
}

/// Settings of [`leverage_map`].
#[derive(Clone, Debug)]
pub struct LeverageSettings {
    /// Only measured lines in `[lo, hi]` Hz are candidates for the updating lines.
    pub band_hz: Option<[f64; 2]>,
    /// Lines with `(χ_s + χ_a)/2 > κ_f` are left out (4.20); 1 keeps every line.
    pub kappa_f: f64,
    /// Lines within this many line spacings of a predicted natural frequency are left out.
    pub resonance_lines: f64,
    /// Modes of the basis (the thesis: twice the band).
    pub modes: ModeSelection,
    /// Modal damping of the prediction.
    pub damping: ModalDamping,
    /// Mass matrix.
    pub mass: MassKind,
    /// The static share of the truncated modes in the prediction and its derivatives.
    pub static_correction: bool,
    /// Rows weighted by `√χ` (4.21); the thesis's leverage (5.4) is unweighted.
    pub weighted: bool,
    /// Candidates per chunk.
    pub chunk: usize,
    /// The test map the measured DOFs are read through (14.7); `None`: they are model DOFs.
    pub sensors: Option<std::sync::Arc<crate::sensitivity::SensorMap>>,
}

impl Default for LeverageSettings {
    fn default() -> Self {
        LeverageSettings {
            band_hz: None,
            kappa_f: 1.0,
            resonance_lines: 1.0,
            modes: ModeSelection::All,
            damping: ModalDamping::None,
            mass: MassKind::Consistent,
            static_correction: true,
            weighted: false,
            chunk: 256,
            sensors: None,
        }
    }
}

/// The leverage of every candidate with what it was computed from.
#[derive(Clone, Debug)]
pub struct LeverageMap {
    /// The candidates, in input order.
    pub candidates: Vec<Candidate>,
    /// Their fits, in the same order.
    pub fits: Vec<ColumnFit>,
    /// The measured lines, Hz.
    pub freqs_hz: Vec<f64>,
    /// `χ_s`, `χ_a` of the prediction at every measured line.
    pub lines: LineCorrelation,
    /// The updating lines (indices into the measured lines).
    pub chosen: Vec<usize>,
    /// `εᵀε` over the updating lines.
    pub residual_norm2: f64,
    /// Natural frequencies of the modal basis, Hz.
    pub natural_hz: Vec<f64>,
}

/// Largest model analysed on its complete modal basis (`ModeSelection::All`), in DOFs.
pub const COMPLETE_BASIS_LIMIT: usize = 3000;

/// `K`, `M` of the model over its free DOFs.
fn assemble(model: &Model, mass: MassKind) -> Result<SystemMatrices, LocalisationError> {
    assemble_model(model, mass)
        .map(|(sys, _)| sys)
        .map_err(LocalisationError::from)
}

/// The selected modes of `sys`.
fn solve(sys: &SystemMatrices, selection: ModeSelection) -> Result<Modes, LocalisationError> {
    // Every mode of a model of moderate size comes from the dense solver.
    let params = match selection {
        ModeSelection::All => SparseEigenParams {
            dense_limit: COMPLETE_BASIS_LIMIT,
            ..Default::default()
        },
        _ => SparseEigenParams::default(),
    };
    let (modes, _) = lowest_modes(&sys.k, &sys.m, &sys.dofs, selection, &params)?;
    if modes.is_empty() {
        return Err(LocalisationError::Settings(
            "modes: the modal basis is empty; raise the mode count or frequency limit".into(),
        ));
    }
    Ok(modes)
}

/// Modes of the model's free DOFs with their labels.
fn analyse(
    model: &Model,
    mass: MassKind,
    selection: ModeSelection,
) -> Result<(SystemMatrices, Modes), LocalisationError> {
    let sys = assemble(model, mass)?;
    let modes = solve(&sys, selection)?;
    Ok((sys, modes))
}

/// Leverage (5.9) of every candidate against `measured`, from the model at its current values.
pub fn leverage_map(
    model: &Model,
    candidates: Vec<Candidate>,
    measured: &FrfSet,
    s: &LeverageSettings,
) -> Result<LeverageMap, LocalisationError> {
    if candidates.is_empty() {
        return Err(LocalisationError::Settings(
            "candidates: there is no candidate".into(),
        ));
    }
    let f = &measured.freqs_hz;
    let in_band = |k: usize| s.band_hz.is_none_or(|[lo, hi]| f[k] >= lo && f[k] <= hi);
    let band_lines = (0..f.len()).filter(|&k| in_band(k)).count();
    if band_lines == 0 {
        let [lo, hi] = s.band_hz.unwrap_or([0.0, 0.0]);
        return Err(LocalisationError::Settings(format!(
            "band_hz: [{lo}, {hi}] holds none of the {} measured lines ({} to {} Hz)",
            f.len(),
            f.first().copied().unwrap_or(f64::NAN),
            f.last().copied().unwrap_or(f64::NAN)
        )));
    }
    let (sys, modes) = analyse(model, s.mass, s.modes)?;
    let state = ModalState {
        modes,
        dofs: sys.dofs.clone(),
        projected: Vec::new(),
        reduced: None,
        factor: None,
        sensors: s.sensors.clone(),
    };
    let mdofs = measured.dofs();
    // Through a test map everything is read at the model DOFs it names (`udofs`) and combined
    // with `W`: shapes `W Φ`, corrections `W ρ`, flexibilities `W R Wᵀ` (14.7)–(14.9).
    let through = state.sensor_rows(&mdofs)?;
    let udofs = through.as_ref().map_or(&mdofs, |(u, _)| u);
    let weights = through.as_ref().map(|(_, w)| w);
    let ushapes = state.model_shapes_at(udofs)?;
    let shapes = match weights {
        Some(w) => w.rows(ushapes.as_ref()),
        None => ushapes.clone(),
    };
    let phi = state.modes.shapes.as_ref();
    let eigenvalues = &state.modes.eigenvalues;
    let share = if s.static_correction {
        Some(StaticShare::new(&sys, &state.modes, udofs)?)
    } else {
        None
    };
    let mut predicted = predict(&state, measured, &s.damping)?;
    if let Some(share) = &share {
        let r = share.flexibility(eigenvalues, ushapes.as_ref());
        let r = match weights {
            Some(w) => w.both_sides(r.as_ref()),
            None => r,
        };
        leverage::add_receptance(&mut predicted, r.as_ref(), &mdofs)?;
    }
    let lines = LineCorrelation::new(measured, &predicted);
    let natural_hz = state.modes.frequencies_hz();
    let chosen: Vec<usize> = select_lines(f, &lines, &natural_hz, s.kappa_f, s.resonance_lines)
        .into_iter()
        .filter(|&k| in_band(k))
        .collect();
    if chosen.is_empty() {
        return Err(LocalisationError::Settings(format!(
            "kappa_f: no updating line is left in the band: each of its {} lines is correlated above kappa_f = {} or lies at a predicted resonance; raise kappa_f or lower resonance_lines",
            band_lines, s.kappa_f
        )));
    }
    let equations = Equations {
        measured,
        predicted: &predicted,
        chosen: &chosen,
        modal: ModalFrfModel {
            eigenvalues,
            shapes: shapes.as_ref(),
            dofs: &mdofs,
            damping: &s.damping,
        },
        weighted: s.weighted,
    };
    let index: HashMap<DofId, usize> = sys.dof_index();
    let fits = chunked_fits(&equations, candidates.len(), s.chunk, |range| {
        let parts = candidates[range]
            .par_iter()
            .map(|c| {
                let d = LocalDerivative::new(model, c, &sys.dofs, &index, s.mass)?;
                let p = d.projected(phi, c.value);
                let extra = share.as_ref().map(|sh| {
                    let (rho, dr) =
                        sh.candidate_terms(&d, c.value, eigenvalues, phi, ushapes.as_ref(), &p);
                    match weights {
                        Some(w) => (w.rows(rho.as_ref()), w.both_sides(dr.as_ref())),
                        None => (rho, dr),
                    }
                });
                Ok((p, extra))
            })
            .collect::<Result<Vec<_>, LocalisationError>>()?;
        let mut terms = ChunkTerms::default();
        let (mut rho, mut flex) = (Vec::new(), Vec::new());
        for (p, extra) in parts {
            terms.projected.push(p);
            if let Some((r, f)) = extra {
                rho.push(r);
                flex.push(f);
            }
        }
        if share.is_some() {
            terms.shape_corrections = Some(rho);
            terms.flexibility = Some(flex);
        }
        Ok(terms)
    })?;
    let residual_norm2 = equations.residual().iter().map(|e| e * e).sum();
    Ok(LeverageMap {
        candidates,
        fits,
        freqs_hz: f.clone(),
        lines,
        chosen,
        residual_norm2,
        natural_hz,
    })
}

/// Which modes an eigenvalue map covers.
#[derive(Clone, Debug, PartialEq)]
pub enum ModeChoice {
    /// These modes, 1-based in the order of all modes (rigid-body modes included).
    Numbers(Vec<usize>),
    /// The lowest `n` elastic modes.
    Elastic(usize),
    /// Every elastic mode with its natural frequency in `[lo, hi]` Hz.
    Band([f64; 2]),
}

/// Eigenvalue sensitivities of candidates for chosen modes.
#[derive(Clone, Debug)]
pub struct EigenMap {
    /// The candidates, in input order.
    pub candidates: Vec<Candidate>,
    /// The modes, 1-based over all modes.
    pub modes: Vec<usize>,
    /// Their natural frequencies, Hz.
    pub freqs_hz: Vec<f64>,
    /// `φ_i ∂λ_r/∂φ_i` in rad²/s², one row per candidate, one entry per mode (5.3).
    pub values: Vec<Vec<f64>>,
    /// The same, each mode divided by its largest magnitude over the candidates.
    pub normalised: Vec<Vec<f64>>,
}

/// Eigenvalue sensitivities (5.3) of every candidate for the chosen modes of the model.
pub fn eigenvalue_map(
    model: &Model,
    candidates: Vec<Candidate>,
    choice: &ModeChoice,
    mass: MassKind,
) -> Result<EigenMap, LocalisationError> {
    if candidates.is_empty() {
        return Err(LocalisationError::Settings(
            "candidates: there is no candidate".into(),
        ));
    }
    let selection = match choice {
        ModeChoice::Numbers(v) => ModeSelection::Count(v.iter().copied().max().unwrap_or(1)),
        // Six rigid-body modes at most in a free model, and a margin for mechanisms.
        ModeChoice::Elastic(n) => ModeSelection::Count(n + 12),
        ModeChoice::Band([_, hi]) => ModeSelection::BelowHz(*hi),
    };
    let sys = assemble(model, mass)?;
    if let ModeChoice::Numbers(v) = choice
        && let Some(n) = v.iter().find(|n| **n == 0 || **n > sys.n())
    {
        return Err(LocalisationError::Settings(format!(
            "modes: mode {n} does not exist; the model has {} free DOFs, so modes 1 to {} (1-based, rigid-body modes first)",
            sys.n(),
            sys.n()
        )));
    }
    if let ModeChoice::Band([lo, hi]) = choice {
        // A frequency limit below the first elastic mode of a free model leaves only
        // rigid-body modes, which the solver cannot scale: look at the lowest modes first.
        let lowest = solve(&sys, ModeSelection::Count(13.min(sys.n())))?;
        let first = lowest
            .eigenvalues
            .iter()
            .position(|l| *l > 0.0)
            .map(|r| lowest.frequencies_hz()[r]);
        if first.is_none_or(|f| f > *hi) {
            return Err(LocalisationError::Settings(format!(
                "band_hz: no elastic mode lies in [{lo}, {hi}] Hz (the first is at {})",
                first.map_or("none of the lowest 13 modes".to_string(), |f| format!(
                    "{f:.2} Hz"
                ))
            )));
        }
    }
    let modes = solve(&sys, selection)?;
    let freqs = modes.frequencies_hz();
    let elastic = |r: &usize| modes.eigenvalues[*r] > 0.0;
    let chosen: Vec<usize> = match choice {
        ModeChoice::Numbers(v) => {
            let mut out = Vec::with_capacity(v.len());
            for &n in v {
                if n == 0 || n > modes.len() {
                    return Err(LocalisationError::Settings(format!(
                        "modes: mode {n} does not exist; the model has modes 1 to {} (1-based, rigid-body modes first)",
                        modes.len()
                    )));
                }
                out.push(n - 1);
            }
            out
        }
        ModeChoice::Elastic(n) => {
            let out: Vec<usize> = (0..modes.len()).filter(elastic).take(*n).collect();
            if out.len() < *n {
                return Err(LocalisationError::Settings(format!(
                    "elastic_modes: only {} elastic modes were found among the lowest {}",
                    out.len(),
                    modes.len()
                )));
            }
            out
        }
        ModeChoice::Band([lo, hi]) => {
            let out: Vec<usize> = (0..modes.len())
                .filter(elastic)
                .filter(|&r| freqs[r] >= *lo && freqs[r] <= *hi)
                .collect();
            if out.is_empty() {
                return Err(LocalisationError::Settings(format!(
                    "band_hz: no elastic mode lies in [{lo}, {hi}] Hz (modes found up to {:.2} Hz)",
                    freqs.last().copied().unwrap_or(0.0)
                )));
            }
            out
        }
    };
    let index: HashMap<DofId, usize> = sys.dof_index();
    let values = candidates
        .par_iter()
        .map(|c| {
            let d = LocalDerivative::new(model, c, &sys.dofs, &index, mass)?;
            Ok(eigen_maps::eigenvalue_sensitivities(
                &d,
                c.value,
                &modes.eigenvalues,
                modes.shapes.as_ref(),
                &chosen,
            ))
        })
        .collect::<Result<Vec<_>, LocalisationError>>()?;
    let normalised = eigen_maps::normalise_columns(&values);
    Ok(EigenMap {
        candidates,
        modes: chosen.iter().map(|r| r + 1).collect(),
        freqs_hz: chosen.iter().map(|&r| freqs[r]).collect(),
        values,
        normalised,
    })
}

#[cfg(test)]
mod tests;
