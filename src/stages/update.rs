//! `update`: updates a model's parameters from measured data (docs/theory.md §5, §6): the
//! predictor-corrector on `χ_s`, `χ_a` (`pc`), Lin and Ewins's response function method
//! (`rfm`), or inverse eigensensitivity from measured modes (`eigensensitivity`). The model is a
//! mesh (rebuilt from its elements at every iteration: exact for every parameter kind) or a
//! matrices artefact whose parameters enter linearly (`model.lumped`). Writes the history, the
//! diagnostics of `S` and the final values (`result`), and the updated system (`model`); the
//! updated mesh comes from `mesh.parameters` with the result connected.

use super::frf_synthesise::{Damping, PerMode};
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{
    frf_from_artefact, linear_parameters_from_matrices, matrices_from_artefact,
    matrices_to_artefact, modes_from_artefact,
};
use crate::artefact::mesh::mesh_from_artefact;
use crate::artefact::update::{IdentifiedDamping, update_result_to_artefact, with_modal_damping};
use crate::core::DofId;
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::frf::ModalDamping;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::updating::damping::{
    DampingIdentification, DampingKind, DampingParameters, DampingSettings, equivalent_loss_factor,
};
use crate::updating::eigensensitivity::{EigenSettings, InverseEigensensitivity, MeasuredModes};
use crate::updating::pc::{PcSettings, PredictorCorrector};
use crate::updating::rfm::{ResponseFunctionMethod, RfmSettings};
use crate::updating::sensitive_start::sensitive_start;
use crate::updating::{
    FeModel, LinearModel, ParameterWeighting, ParametricModel, ReducedFeModel, UpdateMethod, run,
    run_phases,
};

/// The stage.
pub struct Update;

/// The updating method.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Predictor-corrector on the FRF correlation coefficients (thesis ch. 4).
    Pc,
    /// Response function method (Lin and Ewins), at chosen lines.
    Rfm,
    /// Inverse eigensensitivity from measured natural frequencies (and shapes).
    Eigensensitivity,
    /// Modal damping identification (thesis ch. 6): the `η_r` (structural) or `ζ_r` (viscous)
    /// of chosen elastic modes by the P-C, the spatial model fixed.
    Damping,
}

/// Settings of the P-C (docs/theory.md §5).
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PcParams {
    /// Lines with `(χ_s + χ_a)/2` above this are not used (4.20); 0.9 < κ_f < 1 (default 0.95;
    /// `damping`: 1, every line, since damping acts only near the resonances).
    #[serde(default)]
    pub kappa_f: Option<f64>,
    /// Lines within this many line spacings of a predicted natural frequency are not used
    /// (default 1; `damping`: 0, the resonances carry the damping).
    #[serde(default)]
    pub resonance_lines: Option<f64>,
    /// Stop when the mean of `(χ_s + χ_a)/2` over all lines reaches this (4.23) (default 0.99;
    /// `damping`: 1, so the step tolerance decides: damping moves few lines).
    #[serde(default)]
    pub stop_chi: Option<f64>,
    /// `κ` of the subset selection, `κ_mn = 1 + κ(n/m)²` (5.14); omitted: every parameter
    /// (`damping`: 1e7, which leaves alone the modes the measurements cannot see).
    #[serde(default)]
    pub subset_kappa: Option<f64>,
    /// `γ` of the parameter weighting `W_φ` (see `ParameterWeighting::Variance`); omitted or 0:
    /// plain weighted least squares.
    #[serde(default)]
    pub weighting_gamma: Option<f64>,
    /// Largest relative change of a parameter in one step.
    #[serde(default = "one")]
    pub max_step: f64,
    /// Add the truncated modes' static share to the mode-shape derivatives (Wang's correction:
    /// one sparse Cholesky of K per iteration); `false`: the thesis's truncated sensitivities.
    #[serde(default = "yes")]
    pub static_correction: bool,
    /// Continuation phases before the P-C proper, e.g. `[0.1, 0.03]`: each an added loss
    /// factor `g` by which measured and predicted FRFs are smoothed over frequency (a Poisson
    /// kernel of half-width `g f / 2`: every mode seen with that much more damping). Broadened
    /// peaks overlap when the initial model's resonances lie many half-power bandwidths from the
    /// measured ones, where the unsmoothed correlation no longer tells which way to go. Each
    /// phase runs until its smoothed mean correlation reaches the stop rule or gains less than
    /// 1e-3 per iteration; the phases share `max_iterations` with the final, unsmoothed P-C.
    #[serde(default)]
    pub smoothing: Vec<f64>,
    /// Also try, at every iteration, the Gauss-Newton steps on the stop figure (the mean
    /// correlation) itself: the P-C's equations with weights `1/(1 − χ)` over every line. The
    /// thesis's line choice (4.20) and weights (4.21) can stall where the mean correlation
    /// still rises toward the solution; these steps do not. Off: the thesis's steps alone.
    #[serde(default)]
    pub merit_steps: bool,
}

impl Default for PcParams {
    fn default() -> Self {
        PcParams {
            kappa_f: None,
            resonance_lines: None,
            stop_chi: None,
            subset_kappa: None,
            weighting_gamma: None,
            max_step: 1.0,
            static_correction: true,
            smoothing: Vec::new(),
            merit_steps: false,
        }
    }
}

fn one() -> f64 {
    1.0
}
fn yes() -> bool {
    true
}
fn ten() -> usize {
    10
}
fn min_mac() -> f64 {
    0.6
}

/// Parameters of `update`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// `pc`, `rfm` or `eigensensitivity`.
    pub method: Method,
    /// Names of the parameters to update (default: all the model declares).
    #[serde(default)]
    pub parameters: Vec<String>,
    /// Most iterations.
    #[serde(default = "ten")]
    pub max_iterations: usize,
    /// Mass matrix of a mesh model.
    #[serde(default)]
    pub mass: MassKind,
    /// Damping of the predictions: modal (`pc`), uniform structural (`rfm`).
    #[serde(default)]
    pub damping: Damping,
    /// Modes of the modal basis (`pc`, `eigensensitivity`): a count …
    #[serde(default)]
    pub mode_count: Option<usize>,
    /// … or every mode up to this frequency (default: twice the highest measured line, the
    /// thesis's `2m` modes; for `eigensensitivity`, three times the measured modes' count).
    /// A reduced model (`partition` connected) of up to 2000 DOFs is analysed on its complete
    /// modal basis whatever these say: its component modes already chose the band.
    #[serde(default)]
    pub modes_max_hz: Option<f64>,
    /// P-C settings.
    #[serde(default)]
    pub pc: PcParams,
    /// RFM: the lines in Hz at which the equations are written (measured lines).
    #[serde(default)]
    pub lines_hz: Vec<f64>,
    /// RFM, eigensensitivity and damping: stop when every relative change is below this
    /// (default 1e-8; `damping`: 1e-2 — a 1 % change of a loss factor is below what noisy
    /// FRFs resolve).
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Eigensensitivity: DOFs of the measured shapes used to pair modes by MAC (default: pair
    /// in order of frequency).
    #[serde(default)]
    pub measured_dofs: Vec<DofId>,
    /// Eigensensitivity: how many of the measured (elastic) modes to use (default: all).
    #[serde(default)]
    pub measured_modes: Option<usize>,
    /// Eigensensitivity: smallest MAC of a pair.
    #[serde(default = "min_mac")]
    pub min_mac: f64,
    /// Damping: 1-based numbers of the modes whose damping is identified, counting rigid-body
    /// modes (default: every elastic mode inside the measured band).
    #[serde(default)]
    pub damping_modes: Vec<usize>,
    /// Before updating, move these parameters' starting values into their sensitive regions
    /// (thesis §5.4): lumped springs and masses whose initial estimates no eigenvalue feels.
    #[serde(default)]
    pub sensitive_start: Option<SensitiveStartParams>,
    /// With `partition` connected: the component mode synthesis the mesh is analysed by; only
    /// substructures holding a changed parameter are reduced again at each iteration.
    #[serde(default)]
    pub reduction: Reduction,
}

impl Params {
    fn damping_method(&self) -> bool {
        self.method == Method::Damping
    }
    /// `κ_f`, resolved.
    pub fn kappa_f(&self) -> f64 {
        let d = if self.damping_method() { 1.0 } else { 0.95 };
        self.pc.kappa_f.unwrap_or(d)
    }
    /// Resonance exclusion in line spacings, resolved.
    pub fn resonance_lines(&self) -> f64 {
        let d = if self.damping_method() { 0.0 } else { 1.0 };
        self.pc.resonance_lines.unwrap_or(d)
    }
    /// The stop figure, resolved.
    pub fn stop_chi(&self) -> f64 {
        let d = if self.damping_method() { 1.0 } else { 0.99 };
        self.pc.stop_chi.unwrap_or(d)
    }
    /// `κ` of the subset selection, resolved.
    pub fn subset_kappa(&self) -> Option<f64> {
        match (self.pc.subset_kappa, self.damping_method()) {
            (None, true) => Some(1e7),
            (k, _) => k,
        }
    }
    /// The step tolerance, resolved.
    pub fn tolerance(&self) -> f64 {
        let d = if self.damping_method() { 1e-2 } else { 1e-8 };
        self.tolerance.unwrap_or(d)
    }
}

/// The sensitive-region search (thesis §5.4, 5.12).
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SensitiveStartParams {
    /// Parameters to move (springs, masses: they enter K and M linearly), one after another.
    pub parameters: Vec<String>,
    /// 1-based numbers of the (elastic) modes whose summed unity eigenvalue sensitivity is
    /// maximised, e.g. the dominant modes of the band.
    pub modes: Vec<usize>,
    /// Scan density between the bounds before the root refinement.
    #[serde(default = "four")]
    pub points_per_decade: usize,
}

fn four() -> usize {
    4
}

/// Reduction method of the analysis when a partition is connected.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Reduction {
    /// `craig_bampton` or `free_interface`.
    #[serde(default = "craig_bampton")]
    pub method: ReductionMethod,
    /// Component modes kept per substructure up to this frequency, Hz (thesis: twice the band).
    #[serde(default = "component_hz")]
    pub component_modes_hz: f64,
    /// Replace the junction DOFs by the interface modes up to this frequency, Hz (chosen at the
    /// start and held, like the component transformations). Default: keep the junction DOFs.
    #[serde(default)]
    pub interface_modes_hz: Option<f64>,
}

impl Default for Reduction {
    fn default() -> Self {
        Reduction {
            method: ReductionMethod::CraigBampton,
            component_modes_hz: component_hz(),
            interface_modes_hz: None,
        }
    }
}

/// The reductions an update can re-run substructure by substructure.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum ReductionMethod {
    /// Craig-Bampton (3.5–3.13: (3.5), (3.6), (3.7), (3.8), (3.9), (3.10), (3.11), (3.12), (3.13)).
    CraigBampton,
    /// Free interface, MacNeal/Rubin (3.26–3.39: (3.26), (3.27), (3.28), (3.29), (3.30), (3.31),
    /// (3.32), (3.33), (3.34), (3.35), (3.36), (3.37), (3.38), (3.39)).
    FreeInterface,
}

fn craig_bampton() -> ReductionMethod {
    ReductionMethod::CraigBampton
}
fn component_hz() -> f64 {
    200.0
}

impl TypedStage for Update {
    type Params = Params;
    const KIND: &'static str = "update";
    const SUMMARY: &'static str =
        "Update model parameters from measured FRFs (P-C, RFM) or modes (inverse eigensensitivity)";
    const IMPL_VERSION: u32 = 4;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::optional(
                "mesh",
                ArtefactKind::Mesh,
                "a finite-element model with declared parameters",
            ),
            PortSpec::optional(
                "model",
                ArtefactKind::Matrices,
                "matrices with linear parameters (model.lumped)",
            ),
            PortSpec::optional("measured", ArtefactKind::Frf, "measured FRFs (pc, rfm)"),
            PortSpec::optional(
                "partition",
                ArtefactKind::Partition,
                "substructures: analyse the mesh through `reduction` (pc, eigensensitivity)",
            ),
            PortSpec::optional(
                "measured_modes",
                ArtefactKind::Modes,
                "measured modes (eigensensitivity)",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "result",
                ArtefactKind::UpdateResult,
                "history, diagnostics and final parameter values",
            ),
            PortSpec::required(
                "model",
                ArtefactKind::Matrices,
                "K and M of the updated model",
            ),
        ]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        // Method-specific defaults, resolved here so that `femu explain` and the cache key show
        // the values used.
        p.pc.kappa_f = Some(p.kappa_f());
        p.pc.resonance_lines = Some(p.resonance_lines());
        p.pc.stop_chi = Some(p.stop_chi());
        p.tolerance = Some(p.tolerance());
        p.pc.subset_kappa = p.subset_kappa();
        let (mesh, model) = (ctx.is_connected("mesh"), ctx.is_connected("model"));
        if mesh == model && !ctx.connected.is_empty() {
            issues.push(ParamIssue::at(
                "",
                "connect exactly one of the inputs `mesh` (a finite-element model) and `model` (matrices from model.lumped)",
            ));
        }
        let data_port = match p.method {
            Method::Pc | Method::Rfm | Method::Damping => "measured",
            Method::Eigensensitivity => "measured_modes",
        };
        if !ctx.connected.is_empty() && !ctx.is_connected(data_port) {
            issues.push(ParamIssue::at(
                "method",
                format!("method {:?} needs the input `{data_port}`", p.method).to_lowercase(),
            ));
        }
        if ctx.is_connected("partition") && !mesh {
            issues.push(ParamIssue::at(
                "reduction",
                "a partition reduces a mesh: connect `mesh` (not `model`) with it",
            ));
        }
        if ctx.is_connected("partition") && p.method == Method::Rfm {
            issues.push(ParamIssue::at(
                "method",
                "the RFM works on the full model's receptances: disconnect `partition`",
            ));
        }
        for (i, &g) in p.pc.smoothing.iter().enumerate() {
            if !(g.is_finite() && g > 0.0 && g <= 1.0) {
                issues.push(ParamIssue::at(
                    "pc.smoothing",
                    format!("entry {i}, {g}, must be an added loss factor in (0, 1], e.g. 0.1"),
                ));
            }
        }
        if p.method != Method::Pc && !p.pc.smoothing.is_empty() {
            issues.push(ParamIssue::at(
                "pc.smoothing",
                "only the method `pc` has smoothing phases: remove `pc.smoothing`",
            ));
        }
        if let Some(f) = p.reduction.interface_modes_hz {
            if !(f.is_finite() && f > 0.0) {
                issues.push(ParamIssue::at(
                    "reduction.interface_modes_hz",
                    format!("{f} must be a positive frequency in Hz"),
                ));
            }
        }
        if !(p.reduction.component_modes_hz.is_finite() && p.reduction.component_modes_hz > 0.0) {
            issues.push(ParamIssue::at(
                "reduction.component_modes_hz",
                format!(
                    "{} must be a positive frequency in Hz",
                    p.reduction.component_modes_hz
                ),
            ));
        }
        if p.method == Method::Rfm && p.lines_hz.is_empty() {
            issues.push(ParamIssue::at(
                "lines_hz",
                "the RFM needs the lines (Hz) at which to write its equations, e.g. [9.0, 18.0]",
            ));
        }
        if p.method == Method::Rfm
            && !matches!(
                p.damping,
                Damping::None | Damping::Structural(PerMode::Uniform(_))
            )
        {
            issues.push(ParamIssue::at(
                "damping",
                "the RFM takes no damping or a uniform structural loss factor `{structural: 0.01}`",
            ));
        }
        if p.method == Method::Damping
            && !matches!(p.damping, Damping::Structural(_) | Damping::Viscous(_))
        {
            issues.push(ParamIssue::at(
                "damping",
                "damping identification starts from modal damping: give `{structural: 0.01}` (identifies η_r) or `{viscous: 0.005}` (identifies ζ_r)",
            ));
        }
        if p.method != Method::Damping && p.damping.is_per_mode() {
            issues.push(ParamIssue::at(
                "damping",
                "per-mode damping needs a fixed modal basis: only the method `damping` takes it; give one uniform value",
            ));
        }
        if p.method != Method::Damping && !p.damping_modes.is_empty() {
            issues.push(ParamIssue::at(
                "damping_modes",
                "only the method `damping` identifies modal damping: remove `damping_modes`",
            ));
        }
        if p.damping_modes.contains(&0) {
            issues.push(ParamIssue::at(
                "damping_modes",
                "mode numbers count from 1 (rigid-body modes included)",
            ));
        }
        if p.method == Method::Pc && matches!(p.damping, Damping::Rayleigh { .. }) {
            issues.push(ParamIssue::at(
                "damping",
                "the P-C predicts by modal summation: give `structural` or `viscous` modal damping",
            ));
        }
        let pc = &p.pc;
        let (kappa_f, stop_chi) = (p.kappa_f(), p.stop_chi());
        if !(kappa_f > 0.0 && kappa_f <= 1.0) {
            issues.push(ParamIssue::at(
                "pc.kappa_f",
                format!("{} must lie in (0, 1]; the thesis uses 0.9 to 1", kappa_f),
            ));
        }
        if !(stop_chi > 0.0 && stop_chi <= 1.0) {
            issues.push(ParamIssue::at(
                "pc.stop_chi",
                format!("{stop_chi} must lie in (0, 1]"),
            ));
        }
        if let Some(k) = pc.subset_kappa {
            if !(k.is_finite() && k >= 1.0) {
                issues.push(ParamIssue::at(
                    "pc.subset_kappa",
                    format!("{k} must be at least 1 (the thesis uses 1e7 to 1e10)"),
                ));
            }
        }
        if let Some(g) = pc.weighting_gamma {
            if !(g.is_finite() && g >= 0.0) {
                issues.push(ParamIssue::at(
                    "pc.weighting_gamma",
                    format!("{g} must be >= 0"),
                ));
            }
        }
        if !(pc.max_step > 0.0 && pc.max_step.is_finite()) {
            issues.push(ParamIssue::at(
                "pc.max_step",
                format!("{} must be positive", pc.max_step),
            ));
        }
        let resonance_lines = p.resonance_lines();
        if !(resonance_lines >= 0.0 && resonance_lines.is_finite()) {
            issues.push(ParamIssue::at(
                "pc.resonance_lines",
                format!("{resonance_lines} must be >= 0"),
            ));
        }
        if let Some(ss) = &p.sensitive_start {
            if p.method == Method::Damping {
                issues.push(ParamIssue::at(
                    "sensitive_start",
                    "the method `damping` changes no spatial parameter: remove `sensitive_start`",
                ));
            }
            if ss.parameters.is_empty() {
                issues.push(ParamIssue::at(
                    "sensitive_start.parameters",
                    "name at least one parameter to move",
                ));
            }
            if ss.modes.is_empty() || ss.modes.contains(&0) {
                issues.push(ParamIssue::at(
                    "sensitive_start.modes",
                    "give 1-based mode numbers, e.g. [1, 2]",
                ));
            }
            if ss.points_per_decade == 0 {
                issues.push(ParamIssue::at(
                    "sensitive_start.points_per_decade",
                    "must be at least 1",
                ));
            }
        }
        if p.mode_count.is_some() && p.modes_max_hz.is_some() {
            issues.push(ParamIssue::at(
                "mode_count",
                "give `mode_count` or `modes_max_hz`, not both",
            ));
        }
        if p.mode_count == Some(0) {
            issues.push(ParamIssue::at("mode_count", "must be at least 1"));
        }
        let tolerance = p.tolerance();
        if !(tolerance > 0.0 && tolerance < 1.0) {
            issues.push(ParamIssue::at(
                "tolerance",
                format!("{tolerance} must lie in (0, 1)"),
            ));
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let fixed = p.method == Method::Damping;
        let model: Box<dyn ParametricModel> = match (inputs.get("mesh"), inputs.get("model")) {
            (Some(mesh), None) => {
                let mesh = mesh_from_artefact(mesh)?;
                let fe = if fixed {
                    FeModel::without_parameters(mesh, p.mass)
                } else {
                    FeModel::new(mesh, &p.parameters, p.mass)
                        .map_err(StageError::from_numerics(""))?
                };
                match inputs.get("partition") {
                    Some(part) => {
                        let partition = crate::artefact::reduced::partition_from_artefact(part)?;
                        let modes = ModeSelection::BelowHz(p.reduction.component_modes_hz);
                        let method = match p.reduction.method {
                            ReductionMethod::CraigBampton => {
                                crate::reduction::Method::CraigBampton { modes }
                            }
                            ReductionMethod::FreeInterface => {
                                crate::reduction::Method::FreeInterface { modes }
                            }
                        };
                        if p.mode_count.is_some() || p.modes_max_hz.is_some() {
                            tracing::info!(
                                "mode_count/modes_max_hz apply to reduced models above {} DOFs; smaller ones use their complete modal basis",
                                crate::updating::model::COMPLETE_REDUCED_BASIS
                            );
                        }
                        let reduced = ReducedFeModel::new(fe, partition, method);
                        match p.reduction.interface_modes_hz {
                            Some(f) => {
                                Box::new(reduced.with_interface_modes(ModeSelection::BelowHz(f)))
                            }
                            None => Box::new(reduced),
                        }
                    }
                    None => Box::new(fe),
                }
            }
            (None, Some(m)) => {
                let sys = matrices_from_artefact(m)?;
                let mut params = linear_parameters_from_matrices(m, sys.n())?;
                if fixed {
                    params.clear();
                } else if params.is_empty() {
                    return Err(StageError::input(
                        "parameters",
                        "the `model` input declares no parameters: add `parameters:` to its model.lumped stage",
                    ));
                }
                if !p.parameters.is_empty() {
                    let known: Vec<String> = params.iter().map(|q| q.0.name.clone()).collect();
                    for name in &p.parameters {
                        if !known.contains(name) {
                            return Err(StageError::input(
                                "parameters",
                                format!(
                                    "`{name}` is not a parameter of the model (it has: {})",
                                    known.join(", ")
                                ),
                            ));
                        }
                    }
                    params.retain(|q| p.parameters.contains(&q.0.name));
                }
                Box::new(LinearModel::new(sys, params).map_err(StageError::from_numerics(""))?)
            }
            _ => {
                return Err(StageError::input(
                    "",
                    "connect exactly one of the inputs `mesh` and `model`",
                ));
            }
        };
        let weighting = match p.pc.weighting_gamma {
            Some(g) if g > 0.0 => ParameterWeighting::Variance { gamma: g },
            _ => ParameterWeighting::None,
        };
        let modes = |default_hz: f64| match (p.mode_count, p.modes_max_hz) {
            (Some(c), _) => ModeSelection::Count(c),
            (_, Some(f)) => ModeSelection::BelowHz(f),
            _ => ModeSelection::BelowHz(default_hz),
        };
        let measured = inputs.get("measured").map(frf_from_artefact).transpose()?;
        let measured_modes = match inputs.get("measured_modes") {
            Some(a) => {
                let m = modes_from_artefact(a)?;
                let elastic: Vec<usize> = (0..m.modes.len())
                    .filter(|&r| m.modes.eigenvalues[r] > 0.0)
                    .take(p.measured_modes.unwrap_or(usize::MAX))
                    .collect();
                let shapes = if p.measured_dofs.is_empty() {
                    None
                } else {
                    let index: std::collections::HashMap<DofId, usize> =
                        m.dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
                    let rows: Vec<usize> = p
                        .measured_dofs
                        .iter()
                        .map(|d| {
                            index.get(d).copied().ok_or_else(|| {
                                StageError::input(
                                    "measured_dofs",
                                    format!("{d} is not a DOF of the measured modes"),
                                )
                            })
                        })
                        .collect::<Result<_, _>>()?;
                    Some((
                        p.measured_dofs.clone(),
                        faer::Mat::from_fn(rows.len(), elastic.len(), |i, j| {
                            m.modes.shapes[(rows[i], elastic[j])]
                        }),
                    ))
                };
                Some(MeasuredModes {
                    eigenvalues: elastic.iter().map(|&r| m.modes.eigenvalues[r]).collect(),
                    shapes,
                })
            }
            None => None,
        };
        let missing = |port: &str| {
            StageError::input(
                "",
                format!("the method needs the input `{port}`; connect it"),
            )
        };
        let top_hz = measured
            .as_ref()
            .and_then(|m| m.freqs_hz.last().copied())
            .unwrap_or(0.0);
        // The P-C's smoothing phases (continuation), each its own method.
        let mut phases: Vec<Box<dyn UpdateMethod + '_>> = Vec::new();
        let method: Box<dyn UpdateMethod + '_> = match p.method {
            Method::Pc => {
                let measured = measured.as_ref().ok_or_else(|| missing("measured"))?;
                let settings = |smoothing: f64| PcSettings {
                    kappa_f: p.kappa_f(),
                    resonance_lines: p.resonance_lines(),
                    stop_chi: p.stop_chi(),
                    subset_kappa: p.pc.subset_kappa,
                    weighting,
                    max_step: p.pc.max_step,
                    modes: modes(2.0 * top_hz),
                    damping: p.damping.modal(),
                    static_correction: p.pc.static_correction,
                    smoothing,
                    merit_steps: p.pc.merit_steps,
                };
                for &g in &p.pc.smoothing {
                    phases.push(Box::new(PredictorCorrector::new(measured, settings(g))));
                }
                Box::new(PredictorCorrector::new(measured, settings(0.0)))
            }
            Method::Rfm => Box::new(ResponseFunctionMethod {
                measured: measured.as_ref().ok_or_else(|| missing("measured"))?,
                settings: RfmSettings {
                    lines_hz: p.lines_hz.clone(),
                    eta: p.damping.direct().structural_eta,
                    tolerance: p.tolerance(),
                    rcond: 1e-12,
                },
            }),
            Method::Damping => {
                let measured = measured.as_ref().ok_or_else(|| missing("measured"))?;
                return identify_damping(p, model.as_ref(), measured, modes(2.0 * top_hz));
            }
            Method::Eigensensitivity => {
                let mm = measured_modes
                    .as_ref()
                    .ok_or_else(|| missing("measured_modes"))?;
                let count = 3 * mm.eigenvalues.len() + 6;
                Box::new(InverseEigensensitivity {
                    measured: mm,
                    settings: EigenSettings {
                        modes: match (p.mode_count, p.modes_max_hz) {
                            (Some(c), _) => ModeSelection::Count(c),
                            (_, Some(f)) => ModeSelection::BelowHz(f),
                            _ => ModeSelection::Count(count),
                        },
                        min_mac: p.min_mac,
                        tolerance: p.tolerance(),
                        subset_kappa: p.pc.subset_kappa,
                        weighting,
                    },
                })
            }
        };
        if let (Method::Pc, ModalDamping::None) = (p.method, p.damping.modal()) {
            tracing::info!("P-C with undamped predictions: lines at resonances are excluded");
        }
        let (start, moved) = match &p.sensitive_start {
            Some(ss) => move_to_sensitive_regions(model.as_ref(), ss)?,
            None => (model.initial_values(), Vec::new()),
        };
        phases.push(method);
        let phases: Vec<&dyn UpdateMethod> = phases.iter().map(|m| m.as_ref()).collect();
        let history = run_phases(&phases, model.as_ref(), &start, p.max_iterations)
            .map_err(StageError::from_numerics(""))?;
        let updated = model
            .evaluate(&history.final_values)
            .map_err(StageError::from_numerics(""))?;
        let name = match p.method {
            Method::Pc => "pc",
            Method::Rfm => "rfm",
            Method::Eigensensitivity => "eigensensitivity",
            Method::Damping => "damping",
        };
        Ok(StageOutputs::from([
            (
                "result".to_string(),
                if moved.is_empty() {
                    update_result_to_artefact(&history, name)
                } else {
                    update_result_to_artefact(&history, name)
                        .with_meta("sensitive_start", serde_json::Value::Array(moved))
                },
            ),
            ("model".to_string(), matrices_to_artefact(&updated.system)),
        ]))
    }
}

/// Moves the named parameters into their sensitive regions one after another (each search
/// with the others at their current starts); returns the start values and, per parameter, a
/// record of the move.
fn move_to_sensitive_regions(
    model: &dyn ParametricModel,
    ss: &SensitiveStartParams,
) -> Result<(Vec<f64>, Vec<serde_json::Value>), StageError> {
    let names: Vec<&str> = model.parameters().iter().map(|q| q.name.as_str()).collect();
    let modes: Vec<usize> = ss.modes.iter().map(|m| m - 1).collect();
    let mut start = model.initial_values();
    let mut moved = Vec::new();
    for name in &ss.parameters {
        let i = names.iter().position(|n| n == name).ok_or_else(|| {
            StageError::input(
                "sensitive_start.parameters",
                format!(
                    "`{name}` is not an updated parameter (they are: {})",
                    names.join(", ")
                ),
            )
        })?;
        let found = sensitive_start(model, &start, i, &modes, ss.points_per_decade)
            .map_err(StageError::from_numerics(""))?;
        tracing::info!(
            "sensitive start: {name} {:e} -> {:e} (unity sensitivity {:.3e} -> {:.3e})",
            found.before,
            found.value,
            found.sensitivity_before,
            found.sensitivity
        );
        start[i] = found.value;
        moved.push(serde_json::json!({
            "parameter": name,
            "before": found.before,
            "start": found.value,
            "sensitivity_before": found.sensitivity_before,
            "sensitivity": found.sensitivity,
        }));
    }
    Ok((start, moved))
}

/// The damping identification: one modal analysis of the fixed model, then the P-C on the modal
/// damping of the chosen elastic modes; the result gains the table `modal_damping`.
fn identify_damping(
    p: &Params,
    model: &dyn ParametricModel,
    measured: &crate::frf::FrfSet,
    basis: ModeSelection,
) -> Result<StageOutputs, StageError> {
    let (state, evaluated) = model
        .modal_state(&model.initial_values(), basis)
        .map_err(StageError::from_numerics(""))?;
    let m = state.modes.len();
    let (kind, initial) = match p.damping.modal_for(m) {
        Ok(ModalDamping::Structural(v)) => (DampingKind::Structural, v),
        Ok(ModalDamping::Viscous(v)) => (DampingKind::Viscous, v),
        Ok(ModalDamping::None) => {
            return Err(StageError::input(
                "damping",
                "damping identification needs a starting modal damping in `damping`",
            ));
        }
        Err(e) => {
            return Err(StageError::input(
                "damping",
                format!("(a modal basis of {m} modes): {e}"),
            ));
        }
    };
    let natural = state.modes.frequencies_hz();
    let (lo, hi) = match (measured.freqs_hz.first(), measured.freqs_hz.last()) {
        (Some(&lo), Some(&hi)) => (lo, hi),
        _ => return Err(StageError::input("", "the measured FRFs have no lines")),
    };
    let modes: Vec<usize> = if p.damping_modes.is_empty() {
        (0..m)
            .filter(|&r| state.modes.eigenvalues[r] > 0.0 && natural[r] >= lo && natural[r] <= hi)
            .collect()
    } else {
        p.damping_modes.iter().map(|&r| r - 1).collect()
    };
    let method = DampingIdentification::new(
        measured,
        &state,
        DampingSettings {
            kind,
            initial,
            modes: modes.clone(),
            kappa_f: p.kappa_f(),
            resonance_lines: p.resonance_lines(),
            stop_chi: p.stop_chi(),
            tolerance: p.tolerance(),
            max_step: p.pc.max_step,
            subset_kappa: p.subset_kappa(),
        },
    )
    .map_err(StageError::input_at("damping_modes"))?;
    let system = match evaluated {
        Some(ev) => ev.system,
        None => {
            model
                .evaluate(&model.initial_values())
                .map_err(StageError::from_numerics(""))?
                .system
        }
    };
    let parameters = DampingParameters::new(&method, system);
    let history =
        run(&method, &parameters, p.max_iterations).map_err(StageError::from_numerics(""))?;
    let identified: Vec<IdentifiedDamping> = modes
        .iter()
        .zip(history.parameters.iter().zip(&history.final_values))
        .map(|(&r, (q, &v))| IdentifiedDamping {
            mode: r + 1,
            natural_hz: natural[r],
            initial: q.initial,
            identified: v,
            equivalent_loss_factor: match kind {
                DampingKind::Structural => v,
                DampingKind::Viscous => equivalent_loss_factor(v),
            },
        })
        .collect();
    let kind_name = match kind {
        DampingKind::Structural => "structural",
        DampingKind::Viscous => "viscous",
    };
    let result = with_modal_damping(
        update_result_to_artefact(&history, "damping"),
        kind_name,
        &identified,
    );
    let system = parameters
        .evaluate(&history.final_values)
        .map_err(StageError::from_numerics(""))?
        .system;
    Ok(StageOutputs::from([
        ("result".to_string(), result),
        ("model".to_string(), matrices_to_artefact(&system)),
    ]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    fn check(
        with: serde_json::Value,
        ports: &[&str],
    ) -> Result<serde_json::Value, Vec<ParamIssue>> {
        Typed::<Update>::new().check(&with, &CheckContext::with_ports(ports))
    }

    #[test]
    fn rfm_needs_lines_and_one_model() {
        let e = check(
            serde_json::json!({"method": "rfm"}),
            &["mesh", "model", "measured"],
        )
        .unwrap_err();
        assert!(e.iter().any(|i| i.message.contains("exactly one")));
        assert!(e.iter().any(|i| i.path == vec!["lines_hz"]));
    }

    #[test]
    fn eigensensitivity_needs_measured_modes() {
        let e = check(
            serde_json::json!({"method": "eigensensitivity"}),
            &["mesh", "measured"],
        )
        .unwrap_err();
        assert!(e[0].message.contains("measured_modes"), "{}", e[0].message);
    }

    #[test]
    fn out_of_range_settings_are_named() {
        let e = check(
            serde_json::json!({"method": "pc", "pc": {"kappa_f": 1.5, "subset_kappa": 0.5}}),
            &["mesh", "measured"],
        )
        .unwrap_err();
        assert_eq!(e[0].path, vec!["pc", "kappa_f"]);
        assert_eq!(e[1].path, vec!["pc", "subset_kappa"]);
    }
}
