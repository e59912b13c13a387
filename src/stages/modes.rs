//! `modes`: natural frequencies and mass-normalised mode shapes of a model (docs/theory.md §1):
//! dense shift-invert for small models, sparse shift-invert Lanczos for large ones.

use super::params::{Count, Modes, Positive};
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::modes::dependent_shapes_table;
use crate::artefact::kinds::{modes_to_artefact, pencil_from_matrices};
use crate::eigen::{EigenRequest, ModeSelection, SparseEigenParams, pencil_modes};
use crate::fe::multipoint::recover;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};

/// The stage.
pub struct ModesStage;

/// Largest model for which `all` modes may be asked: the dense path's cost grows as `N³`.
pub const DENSE_LIMIT: usize = 6000;

/// Parameters of `modes`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Keep the lowest `count` modes (default: what the imported deck's METHOD/EIGRL asks for,
    /// else all).
    #[serde(default)]
    pub count: Option<Count>,
    /// Keep the modes up to this frequency in Hz (default: all).
    #[serde(default)]
    pub max_freq_hz: Option<Positive>,
    /// Shift of the sparse solver: it factors `K − σM` with `σ = −(2π shift_hz)²` (default:
    /// automatic). A value near the lowest elastic frequency speeds up a slow convergence.
    #[serde(default)]
    pub shift_hz: Option<f64>,
    /// Relative convergence tolerance of the sparse solver.
    #[serde(default = "tolerance")]
    pub tolerance: f64,
}

impl Params {
    /// The modes kept (default: all).
    fn selection(&self) -> ModeSelection {
        Modes {
            count: self.count,
            max_freq_hz: self.max_freq_hz,
        }
        .selection_or(ModeSelection::All)
    }
}

fn tolerance() -> f64 {
    SparseEigenParams::default().tolerance
}

impl TypedStage for ModesStage {
    type Params = Params;
    const KIND: &'static str = "modes";
    const SUMMARY: &'static str =
        "Natural frequencies and mass-normalised mode shapes (K phi = lambda M phi)";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::optional("model", ArtefactKind::Matrices, "system matrices K and M"),
            PortSpec::optional(
                "reduced",
                ArtefactKind::ReducedModel,
                "a reduced (CMS) model instead of `model`: its modes are expanded to every physical DOF",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "modes",
            ArtefactKind::Modes,
            "frequencies, shapes and residuals",
        )]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if p.count.is_some() && p.max_freq_hz.is_some() {
            issues.push(ParamIssue::at(
                "count",
                "give `count` or `max_freq_hz`, not both",
            ));
        }
        if !(p.tolerance > 0.0 && p.tolerance < 1e-2) {
            issues.push(ParamIssue::at(
                "tolerance",
                format!("{} must lie in (0, 0.01)", p.tolerance),
            ));
        }
        if ctx.is_connected("model") == ctx.is_connected("reduced") {
            issues.push(ParamIssue {
                path: vec![],
                message: "connect exactly one of the inputs `model` (matrices) and `reduced` (a reduced model)".into(),
            });
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        Self::run_owned(p, inputs.clone())
    }

    fn run_owned(p: &Params, mut inputs: StageInputs) -> Result<StageOutputs, StageError> {
        if let Some(r) = inputs.get("reduced") {
            return run_reduced(p, r);
        }
        let matrices = inputs.take("model")?;
        // K and M as lower triangles on one pattern, as the artefact stores them.
        let (pencil, dofs) = pencil_from_matrices(&matrices)?;
        let dependent = crate::artefact::kinds::matrices::dependent_from_matrices(&matrices)?;
        let deck_request: Option<EigenRequest> = match matrices.meta.get("eigenvalue_request") {
            Some(v) if p.count.is_none() && p.max_freq_hz.is_none() => {
                Some(serde_json::from_value(v.clone()).map_err(|e| {
                    StageError::input("", format!("the model's eigenvalue_request: {e}"))
                })?)
            }
            _ => None,
        };
        // The tables are read into the pencil: free them (when this stage holds the run's last
        // reference) before the factor and the Krylov basis are allocated.
        drop(matrices);
        let n = dofs.len();
        if n > DENSE_LIMIT && p.count.is_none() && p.max_freq_hz.is_none() && deck_request.is_none()
        {
            return Err(StageError::input(
                "",
                format!(
                    "the model has {n} DOFs: give `count` or `max_freq_hz` (all modes only up to {DENSE_LIMIT} DOFs)"
                ),
            ));
        }
        let selection = p.selection();
        let params = SparseEigenParams {
            shift: p
                .shift_hz
                .map(|f| -(2.0 * std::f64::consts::PI * f).powi(2)),
            tolerance: p.tolerance,
            dense_limit: if matches!(selection, ModeSelection::All) {
                DENSE_LIMIT
            } else {
                SparseEigenParams::default().dense_limit
            },
            ..Default::default()
        };
        let solve =
            |selection| pencil_modes(&pencil, &dofs, selection, &params).map(|(modes, _)| modes);
        let modes = match &deck_request {
            Some(request) => {
                let modes = request
                    .select(solve)
                    .map_err(StageError::from_numerics(""))?;
                tracing::info!(
                    "modes: {} mode(s), as the deck's METHOD/EIGRL asks ({})",
                    modes.len(),
                    request.describe()
                );
                if modes.is_empty() {
                    return Err(StageError::input(
                        "count",
                        format!(
                            "the deck's EIGRL ({}) selects no mode of this model; give `count` or `max_freq_hz`",
                            request.describe()
                        ),
                    ));
                }
                modes
            }
            None => solve(selection).map_err(StageError::from_numerics(""))?,
        };
        if modes.is_empty() {
            // Say where the first mode lies, so the limit can be set right.
            let (first, _) = pencil_modes(&pencil, &dofs, ModeSelection::Count(1), &params)
                .map_err(StageError::from_numerics(""))?;
            return Err(no_mode_below(p, &first.frequencies_hz()));
        }
        crate::core::memory::drop_in_background(pencil);
        let mut a = modes_to_artefact(&dofs, &modes);
        if !dependent.is_empty() {
            // Shapes at the DOFs rigid elements and MPCs eliminated: u_d = Σ c u.
            let shapes = recover(&dependent, &dofs, modes.shapes.as_ref());
            let dofs: Vec<crate::core::DofId> = dependent.iter().map(|d| d.dof).collect();
            a = a.with_table(
                "dependent_shapes",
                dependent_shapes_table(&dofs, shapes.as_ref()),
                crate::artefact::Storage::Ipc,
            );
        }
        Ok(StageOutputs::from([("modes".to_string(), a)]))
    }
}

/// The error for a frequency limit below the first mode: an empty basis would make every modal
/// FRF downstream zero.
fn no_mode_below(p: &Params, first_hz: &[f64]) -> StageError {
    StageError::input(
        "max_freq_hz",
        format!(
            "no mode lies below {} Hz{}; raise the limit or give `count`",
            p.max_freq_hz.map_or(0.0, Positive::get),
            first_hz
                .first()
                .map(|f| format!(" (the lowest is at {f:.6} Hz)"))
                .unwrap_or_default()
        ),
    )
}

/// Modes of a reduced model (dense, or sparse beyond 2000 coordinates), expanded to every
/// physical DOF of the full model (`x = T_k q`), so downstream stages see full-model modes.
fn run_reduced(p: &Params, a: &crate::artefact::Artefact) -> Result<StageOutputs, StageError> {
    let r = crate::artefact::reduced::reduced_from_artefact(a)?;
    let selection = p.selection();
    let modes = r.modes(selection).map_err(StageError::from_numerics(""))?;
    if modes.is_empty() {
        let first = r
            .modes(ModeSelection::Count(1))
            .map_err(StageError::from_numerics(""))?;
        return Err(no_mode_below(p, &first.frequencies_hz()));
    }
    let (dofs, expanded) = r
        .expand_modes(&modes)
        .map_err(StageError::from_numerics(""))?;
    let (phys, modal) = r.size();
    let a = modes_to_artefact(&dofs, &expanded)
        .with_meta("reduced_coords", r.n().into())
        .with_meta("reduced_physical", phys.into())
        .with_meta("reduced_modal", modal.into());
    Ok(StageOutputs::from([("modes".to_string(), a)]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    #[test]
    fn count_and_max_freq_exclude_each_other() {
        let e = Typed::<ModesStage>::new()
            .check(
                &serde_json::json!({"count": 3, "max_freq_hz": 10.0}),
                &CheckContext::default(),
            )
            .unwrap_err();
        assert!(e[0].message.contains("not both"));
    }

    #[test]
    fn unknown_param_is_rejected() {
        let e = Typed::<ModesStage>::new()
            .check(&serde_json::json!({"cout": 3}), &CheckContext::default())
            .unwrap_err();
        assert!(
            e[0].message.contains("unknown field `cout`"),
            "{}",
            e[0].message
        );
    }
}
