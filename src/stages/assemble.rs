//! `assemble`: a model's stiffness and mass matrices over its free DOFs (sparse, parallel,
//! deterministic), with constrained and unsupported DOFs removed, and for every updating
//! parameter of the model its assembled `∂K/∂φ`, `∂M/∂φ` (tables `dK__<name>`, `dM__<name>`).

use crate::artefact::ArtefactKind;
use crate::artefact::Storage;
use crate::artefact::kinds::{lower_matrices_to_artefact, lower_triplet_table};
use crate::artefact::mesh::mesh_from_artefact;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::{assemble_model_lower, parameter_derivatives};
use crate::pipeline::{PortSpec, StageError, StageInputs, StageOutputs, TypedStage};

/// The stage.
pub struct Assemble;

/// Parameters of `assemble`.
#[derive(Clone, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// `consistent` (default) or `lumped` mass.
    #[serde(default)]
    pub mass: MassKind,
}

impl TypedStage for Assemble {
    type Params = Params;
    const KIND: &'static str = "assemble";
    const SUMMARY: &'static str =
        "Sparse K and M of a model over its free DOFs (shells, beams, springs, masses)";
    const IMPL_VERSION: u32 = 3;

    fn inputs() -> Vec<PortSpec> {
        vec![PortSpec::required("mesh", ArtefactKind::Mesh, "the model")]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "model",
            ArtefactKind::Matrices,
            "K and M over the free DOFs",
        )]
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let mesh = inputs.require("mesh")?;
        let model = mesh_from_artefact(mesh)?;
        for param in &model.parameters {
            if !param
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(StageError::input(
                    "",
                    format!(
                        "parameter name `{}` must use letters, digits, `_` and `-`",
                        param.name
                    ),
                ));
            }
        }
        // K and M straight as the lower triangles the artefact stores.
        let (sys, info) =
            assemble_model_lower(&model, p.mass).map_err(StageError::from_numerics(""))?;
        // The dampers' viscous C (CDAMP, CVISC, CBUSH B), only when the model has any, so other
        // models' matrices keep their bytes.
        let c = crate::fe::damping::damping_matrix(&model, &sys.dofs)
            .map_err(StageError::from_numerics(""))?;
        // Per updating parameter, the assembled derivatives `dK__<name>`, `dM__<name>` (2.13).
        let derivatives = parameter_derivatives(&model, &model.parameters, &sys.dofs, p.mass)
            .map_err(StageError::from_numerics(""))?;
        let mut a = lower_matrices_to_artefact(sys, c.as_ref());
        for (param, (dk, dm)) in model.parameters.iter().zip(&derivatives) {
            for (prefix, mat) in [("dK", dk), ("dM", dm)] {
                a = a.with_table(
                    &format!("{prefix}__{}", param.name),
                    lower_triplet_table(mat),
                    Storage::Ipc,
                );
            }
        }
        if !info.dependent.is_empty() {
            // How each DOF a rigid element or MPC eliminated follows from the free DOFs.
            a = a.with_table(
                "dependent",
                crate::artefact::kinds::matrices::dependent_table(&info.dependent),
                Storage::Parquet,
            );
        }
        a.meta.insert("total_dofs".into(), info.total_dofs.into());
        if let Some(request) = mesh.meta.get("eigenvalue_request") {
            // The deck's METHOD/EIGRL, for the `modes` stage.
            a.meta.insert("eigenvalue_request".into(), request.clone());
        }
        a.meta.insert(
            "auto_constrained".into(),
            info.auto_constrained
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .into(),
        );
        Ok(StageOutputs::from([("model".to_string(), a)]))
    }
}
