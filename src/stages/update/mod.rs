//! `update`: updates a model's parameters from measured data (docs/theory.md §5, §6): the
//! predictor-corrector on `χ_s`, `χ_a` (`pc`), Lin and Ewins's response function method
//! (`rfm`), inverse eigensensitivity from measured modes (`eigensensitivity`), or the modal
//! damping identification (`damping`). The model is a mesh (rebuilt from its elements at every
//! iteration: exact for every parameter kind) or a matrices artefact whose parameters enter
//! linearly (`model.lumped`). Writes the history, the diagnostics of `S` and the final values
//! (`result`), the updated system (`model`) and the Laplace posterior of the parameters
//! (`posterior`, docs/theory.md §12); the updated mesh comes from `mesh.parameters` with the
//! result connected.
//!
//! The parameters are one variant per method, selected by `method:` (one file each); the
//! fields every method shares are here.

mod damping;
mod eigensensitivity;
mod pc;
mod posterior;
mod rfm;

pub use damping::{DampingMethod, DampingPcParams};
pub use eigensensitivity::{EigensensitivityMethod, LegacyEigenPc};
pub use pc::{PcMethod, PcParams};
pub use posterior::{NoiseParams, OneOrMany, PosteriorParams, PriorParams, snr_sigmas};
pub use rfm::RfmMethod;

use super::params::{Count, Deprecation, Positive, warn_deprecated};
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{linear_parameters_from_matrices, matrices_from_artefact};
use crate::artefact::kinds::{matrices_to_artefact, modes_from_artefact};
use crate::artefact::mesh::mesh_from_artefact;
use crate::artefact::update::update_result_to_artefact;
use crate::core::DofId;
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::updating::eigensensitivity::MeasuredModes;
use crate::updating::sensitive_start::sensitive_start;
use crate::updating::{
    FeModel, LinearModel, ParametricModel, ReducedFeModel, UpdateHistory, UpdateMethod,
};
use serde::de::{DeserializeOwned, Error as _};

/// The stage.
pub struct Update;

/// The updating method: the value of `method:`.
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

impl Method {
    /// The name written in the result.
    pub fn name(self) -> &'static str {
        match self {
            Method::Pc => "pc",
            Method::Rfm => "rfm",
            Method::Eigensensitivity => "eigensensitivity",
            Method::Damping => "damping",
        }
    }
}

/// Parameters of `update`: the method's own, selected by `method:`.
#[derive(Clone, Debug, serde::Serialize, schemars::JsonSchema)]
#[serde(tag = "method", rename_all = "snake_case")]
pub enum Params {
    /// Predictor-corrector on `χ_s`, `χ_a` (docs/theory.md §5).
    Pc(PcMethod),
    /// Response function method at chosen lines.
    Rfm(RfmMethod),
    /// Inverse eigensensitivity from measured modes.
    Eigensensitivity(EigensensitivityMethod),
    /// Modal damping identification (thesis ch. 6).
    Damping(DampingMethod),
}

/// Reads the variant `method:` names. (Serde's internally tagged enums buffer the block and lose
/// the path of a bad field; this keeps it in the message.)
impl<'de> serde::Deserialize<'de> for Params {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut map = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let method = map
            .remove("method")
            .ok_or_else(|| D::Error::missing_field("method"))?;
        let method: Method =
            serde_json::from_value(method).map_err(|e| D::Error::custom(format!("method: {e}")))?;
        let rest = serde_json::Value::Object(map);
        Ok(match method {
            Method::Pc => Params::Pc(variant(rest)?),
            Method::Rfm => Params::Rfm(variant(rest)?),
            Method::Eigensensitivity => Params::Eigensensitivity(variant(rest)?),
            Method::Damping => Params::Damping(variant(rest)?),
        })
    }
}

/// One method's fields, a bad one named in the message.
fn variant<T: DeserializeOwned, E: serde::de::Error>(v: serde_json::Value) -> Result<T, E> {
    serde_path_to_error::deserialize(v).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        if path == "." {
            E::custom(inner)
        } else {
            E::custom(format!("{path}: {inner}"))
        }
    })
}

impl Params {
    /// The method.
    pub fn method(&self) -> Method {
        match self {
            Params::Pc(_) => Method::Pc,
            Params::Rfm(_) => Method::Rfm,
            Params::Eigensensitivity(_) => Method::Eigensensitivity,
            Params::Damping(_) => Method::Damping,
        }
    }

    /// The posterior settings.
    pub fn posterior(&self) -> &PosteriorParams {
        match self {
            Params::Pc(p) => &p.posterior,
            Params::Rfm(p) => &p.posterior,
            Params::Eigensensitivity(p) => &p.posterior,
            Params::Damping(p) => &p.posterior,
        }
    }

    /// Moves old spellings to their new places: the problems, and the deprecations met.
    pub fn migrate(&mut self) -> (Vec<ParamIssue>, Vec<Deprecation>) {
        let mut found = Vec::new();
        let issues = match self {
            Params::Pc(p) => p.migrate(&mut found),
            Params::Rfm(_) => Vec::new(),
            Params::Eigensensitivity(p) => p.migrate(&mut found),
            Params::Damping(p) => p.migrate(&mut found),
        };
        (issues, found)
    }
}

/// Default of `max_iterations`.
fn max_iterations() -> usize {
    10
}

/// The sensitive-region search (thesis §5.4, 5.12).
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SensitiveStartParams {
    /// Parameters to move (springs, masses: they enter K and M linearly), one after another.
    pub parameters: Vec<String>,
    /// 1-based numbers of the (elastic) modes whose summed unity eigenvalue sensitivity is
    /// maximised, e.g. the dominant modes of the band.
    pub modes: Vec<Count>,
    /// Scan density between the bounds before the root refinement.
    #[serde(default = "four")]
    pub points_per_decade: Count,
}

fn four() -> Count {
    Count::of_default(4)
}

impl SensitiveStartParams {
    fn issues(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if self.parameters.is_empty() {
            issues.push(ParamIssue::at(
                "sensitive_start.parameters",
                "name at least one parameter to move",
            ));
        }
        if self.modes.is_empty() {
            issues.push(ParamIssue::at(
                "sensitive_start.modes",
                "give 1-based mode numbers, e.g. [1, 2]",
            ));
        }
        issues
    }
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
    pub component_modes_hz: Positive,
    /// Replace the junction DOFs by the interface modes up to this frequency, Hz (chosen at the
    /// start and held, like the component transformations). Default: keep the junction DOFs.
    #[serde(default)]
    pub interface_modes_hz: Option<Positive>,
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
fn component_hz() -> Positive {
    Positive::of_default(200.0)
}

impl TypedStage for Update {
    type Params = Params;
    const KIND: &'static str = "update";
    const SUMMARY: &'static str =
        "Update model parameters from measured FRFs (P-C, RFM) or modes (inverse eigensensitivity)";
    /// 6: the result records the component mode synthesis reuse (`cms`); 8: the RFM reads
    /// measured DOFs through multi-term test maps (14.11); 9: trial states from the parametric
    /// projection, the posterior started from the update's last analysis, and each analysis's
    /// first Lanczos run sized by the last (results move in round-off); 10: warnings recorded
    /// in the result and the posterior (`update_warnings`, `posterior_warnings`), a best iterate
    /// not returned for a gain at round-off, and numbered in the whole continuation; 11:
    /// warnings name the parameters no step selected and the Laplace intervals that reach past
    /// their parameters' bounds.
    const IMPL_VERSION: u32 = 11;

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
            PortSpec::optional(
                "map",
                ArtefactKind::TestMap,
                "test.pair's map: every measured DOF is its weighted sum of model DOFs (14.7)",
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
            PortSpec::required(
                "posterior",
                ArtefactKind::Posterior,
                "Laplace posterior of the parameters: marginals, correlation, directions, samples, predictive bands",
            ),
        ]
    }

    /// What the types cannot say: the wiring, and the combinations within a method.
    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        let (mut issues, found) = p.migrate();
        warn_deprecated(Self::KIND, &found);
        issues.extend(wiring_issues(p.method(), ctx));
        issues.extend(match p {
            Params::Pc(p) => p.issues(),
            Params::Rfm(p) => p.issues(),
            Params::Eigensensitivity(p) => p.issues(),
            Params::Damping(p) => p.issues(),
        });
        issues.extend(p.posterior().issues());
        issues
    }

    /// The measured DOFs against the model, unless a map relates them.
    fn preflight(_p: &Params, inputs: &StageInputs) -> Vec<ParamIssue> {
        if inputs.get("map").is_some() {
            return Vec::new();
        }
        let (Some(mesh), Some(measured)) = (inputs.get("mesh"), inputs.get("measured")) else {
            return Vec::new();
        };
        let (Ok(model), Ok(set)) = (
            crate::artefact::mesh::mesh_from_artefact(mesh),
            crate::artefact::kinds::frf_from_artefact(measured),
        ) else {
            return Vec::new();
        };
        super::params::measured_dofs_issue(&model, &set, "measured")
            .into_iter()
            .collect()
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        match p {
            Params::Pc(p) => p.run(inputs),
            Params::Rfm(p) => p.run(inputs),
            Params::Eigensensitivity(p) => p.run(inputs),
            Params::Damping(p) => p.run(inputs),
        }
    }
}

/// Which inputs the method needs connected.
fn wiring_issues(method: Method, ctx: &CheckContext) -> Vec<ParamIssue> {
    let mut issues = Vec::new();
    if ctx.connected.is_empty() {
        return issues;
    }
    let (mesh, model) = (ctx.is_connected("mesh"), ctx.is_connected("model"));
    if mesh == model {
        issues.push(ParamIssue::at(
            "",
            "connect exactly one of the inputs `mesh` (a finite-element model) and `model` (matrices from model.lumped)",
        ));
    }
    let data_port = match method {
        Method::Pc | Method::Rfm | Method::Damping => "measured",
        Method::Eigensensitivity => "measured_modes",
    };
    if !ctx.is_connected(data_port) {
        issues.push(ParamIssue::at(
            "method",
            format!("method {} needs the input `{data_port}`", method.name()),
        ));
    }
    if ctx.is_connected("partition") && !mesh {
        issues.push(ParamIssue::at(
            "reduction",
            "a partition reduces a mesh: connect `mesh` (not `model`) with it",
        ));
    }
    if ctx.is_connected("map") && !mesh {
        issues.push(ParamIssue::at(
            "",
            "a test map names grids of a mesh: connect `mesh` (not `model`) with `map`",
        ));
    }
    if ctx.is_connected("partition") && method == Method::Rfm {
        issues.push(ParamIssue::at(
            "method",
            "the RFM works on the full model's receptances: disconnect `partition`",
        ));
    }
    issues
}

/// The model updated: a mesh (through the partition's reduction when one is connected) or
/// linear matrices. `parameters`: the names to update (empty: all); `None`: none (a fixed
/// model, for the damping identification). `modes_given`: whether the user chose the basis.
/// With a test map on `map`, the measured DOFs are read through it (14.7).
pub(crate) fn build_model(
    inputs: &StageInputs,
    parameters: Option<&[String]>,
    mass: MassKind,
    reduction: &Reduction,
    modes_given: bool,
) -> Result<Box<dyn ParametricModel>, StageError> {
    let model = model_of(inputs, parameters, mass, reduction, modes_given)?;
    Ok(match sensor_map(inputs)? {
        Some(map) => Box::new(crate::updating::model::ThroughMap::new(model, map)),
        None => model,
    })
}

/// The test map on the input `map`, as measured DOF → weighted model DOFs (14.6).
pub(crate) fn sensor_map(
    inputs: &StageInputs,
) -> Result<Option<crate::sensitivity::SensorMap>, StageError> {
    let Some(a) = inputs.get("map") else {
        return Ok(None);
    };
    let map = crate::artefact::kinds::test_map::test_map_from_artefact(a)?;
    Ok(Some(crate::sensitivity::SensorMap::new(map.combinations())))
}

/// [`build_model`] without the map.
fn model_of(
    inputs: &StageInputs,
    parameters: Option<&[String]>,
    mass: MassKind,
    reduction: &Reduction,
    modes_given: bool,
) -> Result<Box<dyn ParametricModel>, StageError> {
    match (inputs.get("mesh"), inputs.get("model")) {
        (Some(mesh), None) => {
            let mesh = mesh_from_artefact(mesh)?;
            let fe = match parameters {
                None => FeModel::without_parameters(mesh, mass),
                Some(names) => {
                    FeModel::new(mesh, names, mass).map_err(StageError::from_numerics(""))?
                }
            };
            let Some(part) = inputs.get("partition") else {
                return Ok(Box::new(fe));
            };
            let partition = crate::artefact::reduced::partition_from_artefact(part)?;
            let modes = ModeSelection::BelowHz(reduction.component_modes_hz.get());
            let method = match reduction.method {
                ReductionMethod::CraigBampton => crate::reduction::Method::CraigBampton { modes },
                ReductionMethod::FreeInterface => crate::reduction::Method::FreeInterface { modes },
            };
            if modes_given {
                tracing::info!(
                    "`modes` applies to reduced models above {} DOFs; smaller ones use their complete modal basis",
                    crate::updating::model::COMPLETE_REDUCED_BASIS
                );
            }
            let reduced = ReducedFeModel::new(fe, partition, method);
            Ok(match reduction.interface_modes_hz {
                Some(f) => Box::new(reduced.with_interface_modes(ModeSelection::BelowHz(f.get()))),
                None => Box::new(reduced),
            })
        }
        (None, Some(m)) => linear_model(m, parameters),
        _ => Err(StageError::input(
            "",
            "connect exactly one of the inputs `mesh` and `model`",
        )),
    }
}

/// Matrices with linear parameters (`model.lumped`), restricted to the named ones.
fn linear_model(
    m: &crate::artefact::Artefact,
    parameters: Option<&[String]>,
) -> Result<Box<dyn ParametricModel>, StageError> {
    let sys = matrices_from_artefact(m)?;
    let mut params = linear_parameters_from_matrices(m, sys.n())?;
    match parameters {
        None => params.clear(),
        Some(_) if params.is_empty() => {
            return Err(StageError::input(
                "parameters",
                "the `model` input declares no parameters: add `parameters:` to its model.lumped stage",
            ));
        }
        Some([]) => {}
        Some(names) => {
            let known: Vec<String> = params.iter().map(|q| q.0.name.clone()).collect();
            if let Some(name) = names.iter().find(|n| !known.contains(n)) {
                return Err(StageError::input(
                    "parameters",
                    format!(
                        "`{name}` is not a parameter of the model (it has: {})",
                        known.join(", ")
                    ),
                ));
            }
            params.retain(|q| names.contains(&q.0.name));
        }
    }
    Ok(Box::new(
        LinearModel::new(sys, params).map_err(StageError::from_numerics(""))?,
    ))
}

/// The measured FRFs, required by the FRF methods: the lines in `band` and outside `exclude`.
pub(crate) fn measured_frf(
    inputs: &StageInputs,
    band: Option<crate::stages::params::Band>,
    exclude: &[crate::stages::params::Band],
) -> Result<crate::frf::FrfSet, StageError> {
    let a = inputs.get("measured").ok_or_else(|| missing("measured"))?;
    let set = crate::artefact::kinds::frf_from_artefact(a)?;
    if band.is_none() && exclude.is_empty() {
        return Ok(set);
    }
    crate::stages::params::select_lines(&set, band, exclude)
}

/// The measured modes, required by inverse eigensensitivity.
pub(crate) fn measured_modes(
    inputs: &StageInputs,
) -> Result<crate::artefact::kinds::ModesArtefact, StageError> {
    let a = inputs
        .get("measured_modes")
        .ok_or_else(|| missing("measured_modes"))?;
    Ok(modes_from_artefact(a)?)
}

/// The first `count` (default: all) elastic modes of the input `measured_modes`, with their
/// shapes at `dofs` when any are given (an unknown DOF is an error of the field
/// `measured_dofs`).
pub(crate) fn elastic_measured_modes(
    inputs: &StageInputs,
    count: Option<usize>,
    dofs: &[DofId],
) -> Result<MeasuredModes, StageError> {
    let m = measured_modes(inputs)?;
    let elastic: Vec<usize> = (0..m.modes.len())
        .filter(|&r| m.modes.eigenvalues[r] > 0.0)
        .take(count.unwrap_or(usize::MAX))
        .collect();
    let shapes = if dofs.is_empty() {
        None
    } else {
        let index: std::collections::HashMap<DofId, usize> =
            m.dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
        let rows: Vec<usize> = dofs
            .iter()
            .map(|d| {
                index.get(d).copied().ok_or_else(|| {
                    StageError::input(
                        "measured_dofs",
                        format!(
                            "{d} is not a DOF of the measured modes ({} DOFs, e.g. {})",
                            m.dofs.len(),
                            m.dofs
                                .iter()
                                .take(3)
                                .map(|d| d.to_string())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        Some((
            dofs.to_vec(),
            faer::Mat::from_fn(rows.len(), elastic.len(), |i, j| {
                m.modes.shapes[(rows[i], elastic[j])]
            }),
        ))
    };
    Ok(MeasuredModes {
        eigenvalues: elastic.iter().map(|&r| m.modes.eigenvalues[r]).collect(),
        shapes,
    })
}

fn missing(port: &str) -> StageError {
    StageError::input(
        "",
        format!("the method needs the input `{port}`; connect it"),
    )
}

/// The posterior artefact of an update, from its history.
type PosteriorOf<'a> = &'a dyn Fn(&UpdateHistory) -> Result<crate::artefact::Artefact, StageError>;

/// The common end of the spatial methods: the sensitive-region search, the phases run in turn
/// from its start, the posterior, and the outputs.
fn run_and_write(
    model: &dyn ParametricModel,
    phases: &[&dyn UpdateMethod],
    sensitive: Option<&SensitiveStartParams>,
    max_iterations: usize,
    method: Method,
    posterior: PosteriorOf<'_>,
) -> Result<StageOutputs, StageError> {
    let (start, moved) = match sensitive {
        Some(ss) => move_to_sensitive_regions(model, ss)?,
        None => (model.initial_values(), Vec::new()),
    };
    let history = crate::updating::run_phases(phases, model, &start, max_iterations)
        .map_err(StageError::from_numerics(""))?;
    let updated = model
        .evaluate(&history.final_values)
        .map_err(StageError::from_numerics(""))?;
    let mut result = update_result_to_artefact(&history, method.name());
    if !moved.is_empty() {
        result = result.with_meta("sensitive_start", serde_json::Value::Array(moved));
    }
    if let Some(cms) = model.reanalysis() {
        tracing::info!(
            "component mode synthesis: {} substructure reductions for {} analyses of {} substructures ({} reused); {} candidate steps ranked on held bases",
            cms.reductions,
            cms.analyses,
            cms.substructures,
            cms.reused(),
            cms.trials
        );
        result = result.with_meta(
            "cms",
            serde_json::json!({
                "substructures": cms.substructures,
                "analyses": cms.analyses,
                "reductions": cms.reductions,
                "reused": cms.reused(),
                "trials": cms.trials,
            }),
        );
    }
    let posterior = posterior(&history)?;
    Ok(StageOutputs::from([
        ("result".to_string(), result),
        ("model".to_string(), matrices_to_artefact(&updated.system)),
        ("posterior".to_string(), posterior),
    ]))
}

/// Moves the named parameters into their sensitive regions one after another (each search
/// with the others at their current starts); returns the start values and, per parameter, a
/// record of the move.
fn move_to_sensitive_regions(
    model: &dyn ParametricModel,
    ss: &SensitiveStartParams,
) -> Result<(Vec<f64>, Vec<serde_json::Value>), StageError> {
    let names: Vec<&str> = model.parameters().iter().map(|q| q.name.as_str()).collect();
    let modes: Vec<usize> = ss.modes.iter().map(|m| m.get() - 1).collect();
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
        let found = sensitive_start(model, &start, i, &modes, ss.points_per_decade.get())
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

#[cfg(test)]
mod tests;
