//! Models whose matrices depend on updating parameters (docs/theory.md §2).
//!
//! [`ParametricModel`] is what every updating method needs: the matrices at given parameter
//! values and their derivatives `∂K/∂φ`, `∂M/∂φ` there. Two kinds exist:
//! [`FeModel`] rebuilds a finite-element model from its elements (exact for every parameter,
//! thickness and section sizes included) and [`LinearModel`] holds `K(φ) = K₀ + Σ (φ_i − φ_i⁰)
//! ∂K/∂φ_i` (exact for parameters that enter linearly: lumped masses and springs, `E`, `ρ`).

use super::trial_projection::ParametricProjection;
use crate::core::DofId;
use crate::core::sparse::SparseMatrix;
use crate::eigen::{
    ModeSelection, Modes, ShiftedFactor, SparseEigenParams, lowest_modes_keeping_factor,
};
use crate::fe::SystemMatrices;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::{assemble_model, parameter_derivatives};
use crate::model::{Model, Parameter};
use crate::reduction::{Method, Partition, ReducedModel};
use crate::sensitivity::ProjectedDerivative;
use crate::sensitivity::{RowWeights, SensorMap};
use crate::sparse::FactorStructure;
use faer::{Mat, MatRef};
use rayon::prelude::*;
use std::collections::HashMap;

/// The Lanczos tolerance of an update's modal analyses, looser than the eigensolver's default
/// (`1e-10`). The modes are refined after the Lanczos run (one inverse iteration and a
/// Rayleigh–Ritz step), and the refinement sets their accuracy: on the 100k-DOF muffler, `1e-8`
/// gave the same eigenvalues to `2e-12` (relative), the same residuals after refinement
/// (`1e-8`), shapes in the `1e-10` run's span to `4e-10`, and 6–9 % less time in the
/// eigensolver, which is most of an iteration on a large model.
pub const UPDATE_LANCZOS_TOLERANCE: f64 = 1e-8;

/// The eigensolver's settings for an update's modal analyses: [`UPDATE_LANCZOS_TOLERANCE`],
/// `first_count` for a frequency limit (see [`SparseEigenParams::first_count`]) and the factor
/// structure of the last analysis (see [`SparseEigenParams::structure`]).
pub fn update_eigen_params(
    first_count: Option<usize>,
    structure: Option<FactorStructure>,
) -> SparseEigenParams {
    SparseEigenParams {
        tolerance: UPDATE_LANCZOS_TOLERANCE,
        first_count,
        structure,
        ..SparseEigenParams::default()
    }
}

/// The modes the first Lanczos run of an analysis asks for below a frequency limit, when the
/// last analysis found `found` there: a margin for the modes the parameters' change brings
/// under the limit.
pub(crate) fn first_count_after(found: usize) -> usize {
    found + (found / 10).max(4)
}

/// An updating parameter as the methods see it: name, initial value and bounds (SI).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UpdatingParameter {
    /// Name.
    pub name: String,
    /// Value in the initial model.
    pub initial: f64,
    /// Lowest allowed value.
    pub lower: f64,
    /// Highest allowed value.
    pub upper: f64,
}

/// Why a model could not be evaluated or updated.
#[derive(Debug, thiserror::Error)]
pub enum UpdatingError {
    /// The model could not be rebuilt at some parameter values.
    #[error("the model at the current parameter values: {0}")]
    Model(String),
    /// A parameter's value could not be read or set.
    #[error("the model at the current parameter values: {0}")]
    Parameter(#[from] crate::model::parameters::ParameterValueError),
    /// The model could not be assembled or differentiated.
    #[error("the model at the current parameter values: {0}")]
    Assembly(#[from] crate::fe::model_assembly::ModelAssemblyError),
    /// A substructure could not be reduced again.
    #[error("the reduced model at the current parameter values: {0}")]
    Reduction(#[from] Box<crate::reduction::ReductionError>),
    /// The eigen solution failed.
    #[error("modal analysis: {0}")]
    Eigen(#[from] crate::eigen::EigenError),
    /// An FRF could not be formed.
    #[error(transparent)]
    Modal(#[from] crate::frf::ModalError),
    /// A direct solution failed.
    #[error(transparent)]
    Direct(#[from] crate::frf::DirectError),
    /// The measured data do not fit the model or the method.
    #[error("{0}")]
    Data(String),
    /// The method's settings are inconsistent.
    #[error("{0}")]
    Settings(String),
}

impl From<crate::reduction::ReductionError> for UpdatingError {
    fn from(e: crate::reduction::ReductionError) -> Self {
        UpdatingError::Reduction(Box::new(e))
    }
}

impl crate::core::InputFault for UpdatingError {
    fn is_input(&self) -> bool {
        match self {
            UpdatingError::Model(_) => false,
            UpdatingError::Parameter(e) => e.is_input(),
            UpdatingError::Assembly(e) => e.is_input(),
            UpdatingError::Reduction(e) => e.is_input(),
            UpdatingError::Eigen(e) => e.is_input(),
            UpdatingError::Modal(e) => e.is_input(),
            UpdatingError::Direct(e) => e.is_input(),
            UpdatingError::Data(_) | UpdatingError::Settings(_) => true,
        }
    }
}

/// A model evaluated at parameter values.
#[derive(Clone, Debug)]
pub struct Evaluated {
    /// `K`, `M` (and `C`, `D`) over the free DOFs.
    pub system: SystemMatrices,
    /// `(∂K/∂φ_i, ∂M/∂φ_i)` per parameter (absolute, not yet scaled by `φ_i`).
    pub derivatives: Vec<(SparseMatrix, SparseMatrix)>,
}

/// A model whose matrices depend on named parameters.
pub trait ParametricModel: Sync {
    /// The parameters, in the order of every value vector.
    fn parameters(&self) -> &[UpdatingParameter];
    /// Matrices and derivatives at `values`.
    fn evaluate(&self, values: &[f64]) -> Result<Evaluated, UpdatingError>;
    /// Initial values.
    fn initial_values(&self) -> Vec<f64> {
        self.parameters().iter().map(|p| p.initial).collect()
    }
    /// Modes at `values` with the projected, unity-scaled derivatives; with the physical
    /// matrices when the model has them (a reduced model answers from its reduced coordinates).
    fn modal_state(
        &self,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<(ModalState, Option<Evaluated>), UpdatingError> {
        let evaluated = self.evaluate(values)?;
        let state = ModalState::new(&evaluated, values, selection)?;
        Ok((state, Some(evaluated)))
    }
    /// The test map measured DOFs are read through ([`ThroughMap`]); `None`: they are model DOFs.
    fn sensors(&self) -> Option<&SensorMap> {
        None
    }
    /// For a model analysed by component mode synthesis, how much of its re-analyses reused
    /// substructures reduced before; `None` for other models.
    fn reanalysis(&self) -> Option<Reanalysis> {
        None
    }
    /// Modes at `values` from an analysis cheaper than [`Self::modal_state`], good enough to
    /// rank candidate steps by their merit, without projected derivatives (`projected` is
    /// empty); `None` when the model has none (the candidates are then analysed fully). A
    /// reduced model answers on the bases of its last analysis ([`ReducedFeModel`]).
    fn trial_modal_state(
        &self,
        _values: &[f64],
        _selection: ModeSelection,
    ) -> Result<Option<ModalState>, UpdatingError> {
        Ok(None)
    }
}

/// Modes at `values` for a point that only needs a prediction (a trial step, a posterior
/// sample): the model's trial state ([`ParametricModel::trial_modal_state`]) where it has
/// one, else its full analysis.
pub fn sample_state(
    model: &dyn ParametricModel,
    values: &[f64],
    selection: ModeSelection,
) -> Result<ModalState, UpdatingError> {
    match model.trial_modal_state(values, selection)? {
        Some(state) => Ok(state),
        None => Ok(model.modal_state(values, selection)?.0),
    }
}

/// The component mode synthesis work of an update (see [`ReducedFeModel`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Reanalysis {
    /// Substructures of the partition.
    pub substructures: usize,
    /// Reduced models analysed (parameter points).
    pub analyses: usize,
    /// Substructure reductions computed; `analyses · substructures` without the reuse.
    pub reductions: usize,
    /// Candidate steps ranked on the held bases of the last analysis
    /// ([`ParametricModel::trial_modal_state`]), each without any reduction.
    pub trials: usize,
}

impl Reanalysis {
    /// Substructure reductions taken from an earlier analysis instead of computed.
    pub fn reused(&self) -> usize {
        (self.analyses * self.substructures).saturating_sub(self.reductions)
    }
}

/// A model whose measured DOFs are read through a test map (14.7): its modal states carry the
/// map, so every prediction and sensitivity the methods read at measured DOFs follows it.
pub struct ThroughMap {
    inner: Box<dyn ParametricModel>,
    sensors: std::sync::Arc<SensorMap>,
}

impl ThroughMap {
    /// `inner` read through `sensors`.
    pub fn new(inner: Box<dyn ParametricModel>, sensors: SensorMap) -> Self {
        ThroughMap {
            inner,
            sensors: std::sync::Arc::new(sensors),
        }
    }
}

impl ParametricModel for ThroughMap {
    fn parameters(&self) -> &[UpdatingParameter] {
        self.inner.parameters()
    }

    fn evaluate(&self, values: &[f64]) -> Result<Evaluated, UpdatingError> {
        self.inner.evaluate(values)
    }

    fn initial_values(&self) -> Vec<f64> {
        self.inner.initial_values()
    }

    fn modal_state(
        &self,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<(ModalState, Option<Evaluated>), UpdatingError> {
        let (mut state, evaluated) = self.inner.modal_state(values, selection)?;
        state.sensors = Some(self.sensors.clone());
        Ok((state, evaluated))
    }

    fn sensors(&self) -> Option<&SensorMap> {
        Some(&self.sensors)
    }

    fn trial_modal_state(
        &self,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<Option<ModalState>, UpdatingError> {
        let mut state = self.inner.trial_modal_state(values, selection)?;
        if let Some(state) = &mut state {
            state.sensors = Some(self.sensors.clone());
        }
        Ok(state)
    }

    fn reanalysis(&self) -> Option<Reanalysis> {
        self.inner.reanalysis()
    }
}

/// A finite-element model rebuilt from its elements at each evaluation.
#[derive(Clone, Debug)]
pub struct FeModel {
    model: Model,
    parameters: Vec<Parameter>,
    info: Vec<UpdatingParameter>,
    mass: MassKind,
    held: HeldModes,
}

/// The values and mode shapes of a full model's last modal analysis: the Ritz basis of its
/// trial states ([`FeModel`]'s [`ParametricModel::trial_modal_state`]). A clone starts empty.
#[derive(Debug, Default)]
struct HeldModes(std::sync::Mutex<Option<std::sync::Arc<Held>>>);

/// An analysis's values, mode shapes (rows: `dofs`), how many of them are rigid-body modes,
/// and the model's projection on them once a trial has asked for it.
#[derive(Debug)]
struct Held {
    values: Vec<f64>,
    shapes: Mat<f64>,
    dofs: Vec<DofId>,
    rigid: usize,
    projection: std::sync::Mutex<Projection>,
    /// The analysis's factor structure, for the next analysis (sparse path only).
    structure: Option<FactorStructure>,
}

/// Where the held basis's [`ParametricProjection`] stands.
#[derive(Clone, Default)]
enum Projection {
    /// Not asked for yet.
    #[default]
    Absent,
    /// Being formed by one trial; others meanwhile project the assembled model (no thread
    /// waits for another, which rayon's work stealing could turn into a deadlock).
    Forming,
    /// Ready.
    Ready(std::sync::Arc<ParametricProjection>),
    /// Forming it failed: trials project the assembled model.
    Failed,
}

impl std::fmt::Debug for Projection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Projection::Absent => "Absent",
            Projection::Forming => "Forming",
            Projection::Ready(_) => "Ready",
            Projection::Failed => "Failed",
        })
    }
}

impl Clone for HeldModes {
    fn clone(&self) -> Self {
        HeldModes::default()
    }
}

impl HeldModes {
    fn get(&self) -> Option<std::sync::Arc<Held>> {
        self.0.lock().ok()?.clone()
    }

    fn set(
        &self,
        values: &[f64],
        modes: &Modes,
        dofs: &[DofId],
        structure: Option<FactorStructure>,
    ) {
        if let Ok(mut held) = self.0.lock() {
            // The old basis goes first, so that two are never held at once.
            *held = None;
            *held = Some(std::sync::Arc::new(Held {
                values: values.to_vec(),
                shapes: modes.shapes.clone(),
                dofs: dofs.to_vec(),
                rigid: modes.rigid_body_modes,
                projection: std::sync::Mutex::new(Projection::Absent),
                structure,
            }));
        }
    }
}

impl FeModel {
    /// The model's updating parameters (all, or those named in `names`), their initial values
    /// read from the model.
    pub fn new(model: Model, names: &[String], mass: MassKind) -> Result<Self, UpdatingError> {
        let parameters: Vec<Parameter> = if names.is_empty() {
            model.parameters.clone()
        } else {
            names
                .iter()
                .map(|n| {
                    model
                        .parameters
                        .iter()
                        .find(|p| &p.name == n)
                        .cloned()
                        .ok_or_else(|| {
                            UpdatingError::Settings(format!(
                                "parameter `{n}` is not a parameter of the model (it has: {})",
                                model
                                    .parameters
                                    .iter()
                                    .map(|p| p.name.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ))
                        })
                })
                .collect::<Result<_, _>>()?
        };
        if parameters.is_empty() {
            return Err(UpdatingError::Settings(
                "the model declares no updating parameter; declare them with a `mesh.parameters` stage"
                    .into(),
            ));
        }
        let info = parameters
            .iter()
            .map(|p| {
                Ok(UpdatingParameter {
                    name: p.name.clone(),
                    initial: model.parameter_value(p).map_err(UpdatingError::from)?,
                    lower: p.lower,
                    upper: p.upper,
                })
            })
            .collect::<Result<_, UpdatingError>>()?;
        Ok(FeModel {
            model,
            parameters,
            info,
            mass,
            held: HeldModes::default(),
        })
    }

    /// The model as it is, with no updating parameter (for analyses that change no property,
    /// such as damping identification).
    pub fn without_parameters(model: Model, mass: MassKind) -> Self {
        FeModel {
            model,
            parameters: Vec::new(),
            info: Vec::new(),
            mass,
            held: HeldModes::default(),
        }
    }

    /// The model with `values` written into it.
    pub fn model_at(&self, values: &[f64]) -> Result<Model, UpdatingError> {
        super::trial_projection::model_with(&self.model, &self.parameters, values)
    }
}

impl ParametricModel for FeModel {
    fn parameters(&self) -> &[UpdatingParameter] {
        &self.info
    }

    fn evaluate(&self, values: &[f64]) -> Result<Evaluated, UpdatingError> {
        let model = self.model_at(values)?;
        let (system, _) = assemble_model(&model, self.mass).map_err(UpdatingError::from)?;
        let derivatives = parameter_derivatives(&model, &self.parameters, &system.dofs, self.mass)
            .map_err(UpdatingError::from)?;
        Ok(Evaluated {
            system,
            derivatives,
        })
    }

    /// The full analysis; its mode shapes are held as the basis of later trial states.
    fn modal_state(
        &self,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<(ModalState, Option<Evaluated>), UpdatingError> {
        let evaluated = self.evaluate(values)?;
        // From the last analysis: below a frequency limit, the count it found sizes the first
        // Lanczos run (doubling from 20 would repeat the run two or three times on a large
        // model); its factor structure serves when the pattern is the same (it is, unless a
        // parameter changes which elements connect).
        let held = self.held.get();
        let first_count = held
            .as_ref()
            .map(|held| first_count_after(held.shapes.ncols()));
        let structure = held.and_then(|held| held.structure.clone());
        let params = update_eigen_params(first_count, structure);
        let state = ModalState::with_params(&evaluated, values, selection, &params)?;
        let structure = state.factor.as_ref().map(|f| f.factor.structure().clone());
        self.held.set(values, &state.modes, &state.dofs, structure);
        Ok((state, Some(evaluated)))
    }

    /// Rayleigh-Ritz on the mode shapes `Φ` of the last full analysis, `ΦᵀKΦ q = λ ΦᵀMΦ q`,
    /// shapes `Φq` — no factorisation, no eigensolver iterations. The eigenvalues bound the
    /// full model's from above and err to second order in the change of the mode shapes: enough
    /// to rank trial steps, after which the chosen step is analysed in full. `ΦᵀK(φ)Φ` and
    /// `ΦᵀM(φ)Φ` come from the model's [`ParametricProjection`] on `Φ`, formed by the first
    /// trial on a basis (`O(m²)` per cluster of parameters after that); while another trial is
    /// forming it, or where it could not be formed, the model is assembled at `values` and
    /// projected.
    fn trial_modal_state(
        &self,
        values: &[f64],
        _selection: ModeSelection,
    ) -> Result<Option<ModalState>, UpdatingError> {
        let Some(held) = self.held.get() else {
            return Ok(None);
        };
        if held.values.len() != values.len() {
            return Ok(None);
        }
        let basis = held.shapes.as_ref();
        let (mut k, m) = match self.projection(&held) {
            Some(projection) => projection.at(&self.model, &self.parameters, values, basis)?,
            None => {
                let model = self.model_at(values)?;
                let (system, _) = assemble_model(&model, self.mass).map_err(UpdatingError::from)?;
                if system.dofs != held.dofs {
                    return Ok(None);
                }
                rayon::join(
                    || crate::reduction::linalg::project(&system.k, basis),
                    || crate::reduction::linalg::project(&system.m, basis),
                )
            }
        };
        // Rigid-body motion stays in the null space of K whatever the parameters: the projected
        // stiffness of the rigid-body modes is round-off of ‖K‖ε (at 1M DOFs, 1e-4 of the kept
        // band's eigenvalues: more than the Ritz solve takes for zero), so it is zero.
        for r in 0..held.rigid.min(k.nrows()) {
            for j in 0..k.ncols() {
                k[(r, j)] = 0.0;
                k[(j, r)] = 0.0;
            }
        }
        // Ritz coordinates carry no DOF: the labels only name rows in error messages.
        let labels = vec![DofId::new(0, crate::core::Component::Ux); basis.ncols()];
        let ritz = crate::reduction::projected_modes(&k, &m, &labels, ModeSelection::All)?;
        let shapes = basis * &ritz.shapes;
        Ok(Some(ModalState {
            modes: Modes { shapes, ..ritz },
            dofs: held.dofs.clone(),
            projected: Vec::new(),
            reduced: None,
            factor: None,
            sensors: None,
        }))
    }
}

impl FeModel {
    /// The projection of the model on the held basis: formed here when no trial has asked for
    /// it yet; `None` while another trial forms it or when forming it failed.
    fn projection(&self, held: &Held) -> Option<std::sync::Arc<ParametricProjection>> {
        {
            let mut state = held.projection.lock().ok()?;
            match &*state {
                Projection::Ready(p) => return Some(p.clone()),
                Projection::Forming | Projection::Failed => return None,
                Projection::Absent => *state = Projection::Forming,
            }
        }
        let formed = ParametricProjection::new(
            &self.model,
            &self.parameters,
            &held.values,
            held.shapes.as_ref(),
            &held.dofs,
            held.rigid,
            self.mass,
        );
        let mut state = held.projection.lock().ok()?;
        match formed {
            Ok(p) => {
                let p = std::sync::Arc::new(p);
                *state = Projection::Ready(p.clone());
                Some(p)
            }
            Err(e) => {
                tracing::debug!("trial projection not formed ({e}): trials assemble the model");
                *state = Projection::Failed;
                None
            }
        }
    }
}

/// Matrices linear in the parameters: `K(φ) = K₀ + Σ (φ_i − φ_i⁰) ∂K/∂φ_i`, likewise `M`.
#[derive(Clone, Debug)]
pub struct LinearModel {
    base: SystemMatrices,
    info: Vec<UpdatingParameter>,
    derivatives: Vec<(SparseMatrix, SparseMatrix)>,
}

impl LinearModel {
    /// From the initial matrices and each parameter with its constant derivatives.
    pub fn new(
        base: SystemMatrices,
        parameters: Vec<(UpdatingParameter, SparseMatrix, SparseMatrix)>,
    ) -> Result<Self, UpdatingError> {
        let n = base.n();
        let mut info = Vec::new();
        let mut derivatives = Vec::new();
        for (p, dk, dm) in parameters {
            if dk.nrows() != n || dm.nrows() != n {
                return Err(UpdatingError::Model(format!(
                    "the derivatives of `{}` are {}×{} and {}×{}, the model has {n} DOFs",
                    p.name,
                    dk.nrows(),
                    dk.ncols(),
                    dm.nrows(),
                    dm.ncols()
                )));
            }
            info.push(p);
            derivatives.push((dk, dm));
        }
        Ok(LinearModel {
            base,
            info,
            derivatives,
        })
    }
}

/// `a + s b` for sparse matrices of one size.
fn add_scaled(a: &SparseMatrix, b: &SparseMatrix, s: f64) -> SparseMatrix {
    let mut t = crate::core::sparse::sparse_triplets(a);
    t.extend(
        crate::core::sparse::sparse_triplets(b)
            .into_iter()
            .map(|(i, j, v)| (i, j, s * v)),
    );
    // Same size and finite values: building cannot fail.
    crate::core::sparse::sparse_from_triplets("sum", a.nrows(), &t).unwrap_or_else(|_| a.clone())
}

impl ParametricModel for LinearModel {
    fn parameters(&self) -> &[UpdatingParameter] {
        &self.info
    }

    fn evaluate(&self, values: &[f64]) -> Result<Evaluated, UpdatingError> {
        let mut system = self.base.clone();
        for ((p, (dk, dm)), &v) in self.info.iter().zip(&self.derivatives).zip(values) {
            let delta = v - p.initial;
            if delta != 0.0 {
                system.k = add_scaled(&system.k, dk, delta);
                system.m = add_scaled(&system.m, dm, delta);
            }
        }
        Ok(Evaluated {
            system,
            derivatives: self.derivatives.clone(),
        })
    }
}

/// Each parameter's unity-scaled projected derivatives `φ_i Φᵀ(∂K/∂φ_i)Φ`, `φ_i Φᵀ(∂M/∂φ_i)Φ`
/// (2.16), parameters in parallel.
pub fn project_derivatives(
    derivatives: &[(SparseMatrix, SparseMatrix)],
    values: &[f64],
    shapes: MatRef<'_, f64>,
) -> Vec<ProjectedDerivative> {
    derivatives
        .par_iter()
        .zip(values.par_iter())
        .map(|((dk, dm), &v)| ProjectedDerivative::new(dk, dm, shapes).scaled(v))
        .collect()
}

/// Modes of an evaluated model with their shapes at chosen DOFs and each parameter's projected,
/// unity-scaled derivative `φ_i Φᵀ(∂K/∂φ_i)Φ`, `φ_i Φᵀ(∂M/∂φ_i)Φ` (2.16).
#[derive(Clone, Debug)]
pub struct ModalState {
    /// All modes over all DOFs.
    pub modes: Modes,
    /// DOF labels of the rows of `modes.shapes`.
    pub dofs: Vec<DofId>,
    /// Projected derivatives, one per parameter, scaled by the parameter value.
    pub projected: Vec<ProjectedDerivative>,
    /// The reduced model the modes live on (their rows are its coordinates then, and shapes
    /// at physical DOFs come from its expansion).
    pub reduced: Option<std::sync::Arc<ReducedModel>>,
    /// The eigensolver's factor of `K − σM`, which the static correction reuses instead of
    /// paying for a second factorisation; `None` on the dense path and for reduced models.
    pub factor: Option<std::sync::Arc<ShiftedFactor>>,
    /// The test map through which measured DOFs are read (14.7); `None`: measured DOFs are
    /// model DOFs.
    pub sensors: Option<std::sync::Arc<SensorMap>>,
}

impl ModalState {
    /// Modes of a reduced model: their rows are its coordinates (labelled `0:ux`; shapes at
    /// physical DOFs come from its expansion).
    fn on_reduced(
        modes: Modes,
        reduced: std::sync::Arc<ReducedModel>,
        projected: Vec<ProjectedDerivative>,
    ) -> Self {
        ModalState {
            dofs: vec![DofId::new(0, crate::core::Component::Ux); reduced.n()],
            modes,
            projected,
            reduced: Some(reduced),
            factor: None,
            sensors: None,
        }
    }

    /// Solves for the modes and projects the derivatives, with [`update_eigen_params`].
    pub fn new(
        evaluated: &Evaluated,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<Self, UpdatingError> {
        Self::with_params(
            evaluated,
            values,
            selection,
            &update_eigen_params(None, None),
        )
    }

    /// [`ModalState::new`] with the eigensolver's settings given.
    pub fn with_params(
        evaluated: &Evaluated,
        values: &[f64],
        selection: ModeSelection,
        params: &SparseEigenParams,
    ) -> Result<Self, UpdatingError> {
        let sys = &evaluated.system;
        let (modes, _, factor) =
            lowest_modes_keeping_factor(&sys.k, &sys.m, &sys.dofs, selection, params)?;
        if modes.is_empty() {
            return Err(UpdatingError::Settings(
                "the modal basis is empty: raise the number of modes or their frequency limit"
                    .into(),
            ));
        }
        let projected = project_derivatives(&evaluated.derivatives, values, modes.shapes.as_ref());
        Ok(ModalState {
            modes,
            dofs: sys.dofs.clone(),
            projected,
            reduced: None,
            factor: factor.map(std::sync::Arc::new),
            sensors: None,
        })
    }

    /// Row index of every DOF.
    pub fn index(&self) -> HashMap<DofId, usize> {
        self.dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect()
    }

    /// Through the test map, the model DOFs the measured `dofs` read and their weights `W`
    /// (model DOFs that are not free taken as zero); `None` without a map.
    pub fn sensor_rows(
        &self,
        dofs: &[DofId],
    ) -> Result<Option<(Vec<DofId>, RowWeights)>, UpdatingError> {
        let Some(map) = &self.sensors else {
            return Ok(None);
        };
        let resolved = match &self.reduced {
            Some(_) => map.resolve(dofs, |_| true),
            None => {
                let index = self.index();
                map.resolve(dofs, |d| index.contains_key(d))
            }
        };
        resolved
            .map(Some)
            .map_err(|e| UpdatingError::Data(e.to_string()))
    }

    /// Mode shapes at the measured `dofs` (rows in that order): the model's rows, or through
    /// the test map `W Φ` (14.7); an error names the first DOF the model (or map) lacks.
    pub fn shapes_at(&self, dofs: &[DofId]) -> Result<Mat<f64>, UpdatingError> {
        match self.sensor_rows(dofs)? {
            None => self.model_shapes_at(dofs),
            Some((model, w)) => Ok(w.rows(self.model_shapes_at(&model)?.as_ref())),
        }
    }

    /// Mode shapes at model DOFs `dofs` (rows in that order), the test map not applied.
    pub fn model_shapes_at(&self, dofs: &[DofId]) -> Result<Mat<f64>, UpdatingError> {
        if let Some(r) = &self.reduced {
            return r
                .expand(self.modes.shapes.as_ref(), dofs)
                .map_err(|e| UpdatingError::Reduction(Box::new(e)));
        }
        let index = self.index();
        let rows: Vec<usize> = dofs
            .iter()
            .map(|d| {
                index.get(d).copied().ok_or_else(|| {
                    UpdatingError::Data(format!(
                        "DOF {d} is not a free DOF of the model ({} DOFs)",
                        self.dofs.len()
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Mat::from_fn(rows.len(), self.modes.len(), |i, r| {
            self.modes.shapes[(rows[i], r)]
        }))
    }

    /// The static correction `ρ` of every mode-shape derivative at the measured `dofs` (through
    /// the test map `W ρ`, (14.8)), per parameter
    /// (see [`crate::sensitivity::frf::static_shape_correction`]): one solve per DOF with the
    /// eigensolver's factor of `K − σM`, or, without one, a factorisation with `σ` a hundredth
    /// of the first elastic eigenvalue below zero (free-free models factor too). `evaluated`
    /// must be the model the state was computed from.
    pub fn shape_corrections(
        &self,
        evaluated: &Evaluated,
        values: &[f64],
        dofs: &[DofId],
    ) -> Result<Vec<Mat<f64>>, UpdatingError> {
        match self.sensor_rows(dofs)? {
            None => self.model_shape_corrections(evaluated, values, dofs),
            Some((model, w)) => Ok(self
                .model_shape_corrections(evaluated, values, &model)?
                .iter()
                .map(|rho| w.rows(rho.as_ref()))
                .collect()),
        }
    }

    /// [`Self::shape_corrections`] at model DOFs `dofs`, the test map not applied.
    pub fn model_shape_corrections(
        &self,
        evaluated: &Evaluated,
        values: &[f64],
        dofs: &[DofId],
    ) -> Result<Vec<Mat<f64>>, UpdatingError> {
        use crate::sensitivity::frf::{ShiftedStaticError, shifted_static_solutions};
        let sys = &evaluated.system;
        let index = self.index();
        let rows: Vec<usize> = dofs
            .iter()
            .map(|d| {
                index.get(d).copied().ok_or_else(|| {
                    UpdatingError::Data(format!("DOF {d} is not a free DOF of the model"))
                })
            })
            .collect::<Result<_, _>>()?;
        let solved = shifted_static_solutions(
            &sys.k,
            &sys.m,
            &self.modes.eigenvalues,
            &rows,
            self.factor
                .as_deref()
                .map(|factor| crate::sensitivity::frf::EigenFactor {
                    factor,
                    shapes: self.modes.shapes.as_ref(),
                }),
        )
            .map_err(|e| match e {
                ShiftedStaticError::NotPositiveDefinite => UpdatingError::Model(
                    "K - sigma M is not positive definite: the static correction needs a model without mechanisms"
                        .into(),
                ),
                e => UpdatingError::Model(e.to_string()),
            })?;
        let (x, shift) = (solved.x, solved.shift);
        let shapes = self.model_shapes_at(dofs)?;
        let phi = self.modes.shapes.as_ref();
        Ok(evaluated
            .derivatives
            .par_iter()
            .zip(values.par_iter())
            .zip(self.projected.par_iter())
            .map(|(((dk, dm), &v), d)| {
                // `Xᵀ ∂K Φ` through `∂K X`: a column per measured DOF rather than per mode.
                let project = |a| {
                    crate::sensitivity::project_between_symmetric(a, x.as_ref(), phi)
                        * faer::Scale(v)
                };
                let (ck, cm) = (project(dk), project(dm));
                crate::sensitivity::frf::static_shape_correction(
                    &self.modes.eigenvalues,
                    shift,
                    shapes.as_ref(),
                    ck.as_ref(),
                    cm.as_ref(),
                    d,
                )
            })
            .collect())
    }
}

/// The values of a reduced model's last analysis and the reduced model there.
type LastAnalysis = (Vec<f64>, std::sync::Arc<ReducedModel>);

/// Reduced models up to this size are analysed on their complete modal basis.
pub const COMPLETE_REDUCED_BASIS: usize = 2000;

/// A finite-element model analysed through component mode synthesis (thesis ch. 3, 3.59): the
/// modes come from the reduced model, the derivatives are `T_kᵀ(∂K_k/∂φ)T_k` with the
/// transformations held, and after a parameter change only the substructures holding that
/// parameter's elements are reduced again; the others are reused from the last analysis.
pub struct ReducedFeModel {
    fe: FeModel,
    partition: Partition,
    method: Method,
    interface: Option<ModeSelection>,
    last: std::sync::Mutex<Option<LastAnalysis>>,
    reductions: std::sync::atomic::AtomicUsize,
    analyses: std::sync::atomic::AtomicUsize,
    trials: std::sync::atomic::AtomicUsize,
}

impl ReducedFeModel {
    /// The reduced view of `fe` over `partition` by `method`.
    pub fn new(fe: FeModel, partition: Partition, method: Method) -> Self {
        ReducedFeModel {
            fe,
            partition,
            method,
            interface: None,
            last: std::sync::Mutex::new(None),
            reductions: std::sync::atomic::AtomicUsize::new(0),
            analyses: std::sync::atomic::AtomicUsize::new(0),
            trials: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    /// With the junction expressed in interface modes (chosen at the first analysis and held
    /// afterwards, like the transformations): see [`ReducedModel::with_interface_modes`].
    pub fn with_interface_modes(mut self, selection: ModeSelection) -> Self {
        self.interface = Some(selection);
        self
    }

    /// How many substructure reductions were computed so far.
    pub fn reductions(&self) -> usize {
        self.reductions.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Substructures holding elements of parameter `i`.
    fn substructures_of(&self, i: usize) -> Vec<usize> {
        let set = &self.fe.parameters[i].set;
        let ids = self.fe.model.sets.get(set).cloned().unwrap_or_default();
        self.partition.substructures_of(&ids)
    }

    /// The last analysis's values and reduced model.
    fn last(&self) -> Result<Option<LastAnalysis>, UpdatingError> {
        Ok(self
            .last
            .lock()
            .map_err(|_| UpdatingError::Model("a reduction panicked".into()))?
            .clone())
    }

    /// Substructures holding a parameter whose value differs between `old` and `values`.
    fn changed_substructures(&self, old: &[f64], values: &[f64]) -> Vec<usize> {
        let mut changed: Vec<usize> = (0..values.len())
            .filter(|&i| old[i] != values[i])
            .flat_map(|i| self.substructures_of(i))
            .collect();
        changed.sort_unstable();
        changed.dedup();
        changed
    }

    /// A small reduced model uses its complete modal basis: cheap, and then the mode-shape
    /// derivatives within the reduced space are exact (no truncation, no static correction).
    fn selection_for(reduced: &ReducedModel, selection: ModeSelection) -> ModeSelection {
        if reduced.n() <= COMPLETE_REDUCED_BASIS {
            ModeSelection::All
        } else {
            selection
        }
    }

    fn reduced_at(
        &self,
        model: &Model,
        values: &[f64],
    ) -> Result<std::sync::Arc<ReducedModel>, UpdatingError> {
        use std::sync::atomic::Ordering;
        let err = |e: crate::reduction::ReductionError| UpdatingError::Reduction(Box::new(e));
        self.analyses.fetch_add(1, Ordering::Relaxed);
        let reduced = match self.last()? {
            Some((old, reduced)) if old.len() == values.len() => {
                let changed = self.changed_substructures(&old, values);
                if changed.is_empty() {
                    reduced
                } else {
                    let comps: Vec<_> = changed
                        .par_iter()
                        .map(|&k| match &reduced.interface {
                            // The interface basis is held, like the transformations (3.59).
                            Some(psi) => crate::reduction::reduce_substructure_on_interface(
                                model,
                                &self.partition,
                                k,
                                &self.method,
                                self.fe.mass,
                                psi.as_ref(),
                            ),
                            None => crate::reduction::reduce_substructure(
                                model,
                                &self.partition,
                                k,
                                &self.method,
                                self.fe.mass,
                            ),
                        })
                        .collect::<Result<_, _>>()
                        .map_err(err)?;
                    self.reductions.fetch_add(comps.len(), Ordering::Relaxed);
                    let mut r = (*reduced).clone();
                    for c in comps {
                        r.replace(c).map_err(err)?;
                    }
                    std::sync::Arc::new(r)
                }
            }
            _ => {
                let r = crate::reduction::reduce_with_interface(
                    model,
                    &self.partition,
                    &self.method,
                    self.fe.mass,
                    self.interface,
                )
                .map_err(err)?;
                self.reductions
                    .fetch_add(self.partition.substructures.len(), Ordering::Relaxed);
                std::sync::Arc::new(r)
            }
        };
        if let Ok(mut last) = self.last.lock() {
            *last = Some((values.to_vec(), reduced.clone()));
        }
        Ok(reduced)
    }
}

impl ParametricModel for ReducedFeModel {
    fn parameters(&self) -> &[UpdatingParameter] {
        self.fe.parameters()
    }

    fn reanalysis(&self) -> Option<Reanalysis> {
        use std::sync::atomic::Ordering;
        Some(Reanalysis {
            substructures: self.partition.substructures.len(),
            analyses: self.analyses.load(Ordering::Relaxed),
            reductions: self.reductions(),
            trials: self.trials.load(Ordering::Relaxed),
        })
    }

    /// Rayleigh-Ritz on the bases of the last analysis: the changed substructures' matrices
    /// assembled at `values` and projected on their held transformations, coupled, solved —
    /// no component eigenproblem, no factorisation. The eigenvalues are upper bounds that err
    /// to second order in the change of the component modes, enough to rank trial steps; the
    /// chosen step is then analysed in full.
    fn trial_modal_state(
        &self,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<Option<ModalState>, UpdatingError> {
        let Some((old, reduced)) = self.last()? else {
            return Ok(None);
        };
        if old.len() != values.len() {
            return Ok(None);
        }
        let model = self.fe.model_at(values)?;
        let replaced = self
            .changed_substructures(&old, values)
            .par_iter()
            .map(|&k| {
                let (pk, pm) = crate::reduction::project_on_held_basis(
                    &model,
                    &self.partition,
                    k,
                    self.fe.mass,
                    &reduced.components[k],
                )?;
                Ok((k, pk, pm))
            })
            .collect::<Result<Vec<_>, crate::reduction::ReductionError>>()?;
        let Some((k, m)) = reduced.held_basis_matrices(&replaced) else {
            return Ok(None);
        };
        let modes = reduced.modes_of(&k, &m, Self::selection_for(&reduced, selection))?;
        if modes.is_empty() {
            return Ok(None);
        }
        self.trials
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Ok(Some(ModalState::on_reduced(modes, reduced, Vec::new())))
    }

    /// The full model (for methods that need physical matrices, and for the updated output).
    fn evaluate(&self, values: &[f64]) -> Result<Evaluated, UpdatingError> {
        self.fe.evaluate(values)
    }

    fn modal_state(
        &self,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<(ModalState, Option<Evaluated>), UpdatingError> {
        let model = self.fe.model_at(values)?;
        let reduced = self.reduced_at(&model, values)?;
        let modes = reduced
            .modes(Self::selection_for(&reduced, selection))
            .map_err(UpdatingError::from)?;
        if modes.is_empty() {
            return Err(UpdatingError::Settings(
                "the reduced model has no mode in the basis: raise the mode count or limit".into(),
            ));
        }
        let projected = self
            .fe
            .parameters
            .par_iter()
            .zip(values.par_iter())
            .map(|(p, &v)| {
                let (dk, dm) = crate::reduction::reduced_parameter_derivative(
                    &model,
                    &self.partition,
                    &reduced,
                    p,
                    self.fe.mass,
                )
                .map_err(UpdatingError::from)?;
                let phi = modes.shapes.as_ref();
                let pk = phi.transpose() * &dk * phi;
                let pm = phi.transpose() * &dm * phi;
                Ok(ProjectedDerivative { k: pk, m: pm }.scaled(v))
            })
            .collect::<Result<_, UpdatingError>>()?;
        Ok((ModalState::on_reduced(modes, reduced, projected), None))
    }
}
