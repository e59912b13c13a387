//! `mesh.import`: a model from Nastran bulk data (free, small and large field, continuations,
//! INCLUDE). The file is parsed when the pipeline is checked, so a malformed card is reported
//! with its file and line before anything runs; the cache key holds the digest of the imported
//! model, not the path, so moving or renaming the file reuses the cache and editing it does not.

use crate::artefact::ArtefactKind;
use crate::artefact::mesh::mesh_to_artefact;
use crate::model::Model;
use crate::model::import::nastran::read_bulk;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use std::path::Path;

/// The stage.
pub struct MeshImport;

/// Parameters of `mesh.import`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Bulk data file (`.bdf`, `.dat`, `.nas`, `.blk`), relative to the pipeline file.
    pub path: String,
    /// Digest of the imported model, filled in when the pipeline is checked (not for users).
    #[serde(default)]
    pub content_digest: Option<String>,
}

struct Imported {
    model: Model,
    unknown: std::collections::BTreeMap<String, usize>,
    warnings: Vec<String>,
}

fn import(base: &Path, path: &str) -> Result<Imported, String> {
    let full = base.join(path);
    let b = read_bulk(&full).map_err(|e| e.to_string())?;
    Ok(Imported {
        model: b.model,
        unknown: b.unknown,
        warnings: b.warnings,
    })
}

impl TypedStage for MeshImport {
    type Params = Params;
    const KIND: &'static str = "mesh.import";
    const SUMMARY: &'static str = "A model from Nastran bulk data (GRID, CQUAD4, CTRIA3, CBAR/CBEAM, springs, CONM2, SPC, SET1, ...)";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "mesh",
            ArtefactKind::Mesh,
            "the imported model, with one set per property id",
        )]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        match import(&ctx.base_dir, &p.path) {
            Ok(i) => {
                p.content_digest = Some(mesh_to_artefact(&i.model).digest());
                Vec::new()
            }
            Err(e) => vec![ParamIssue::at("path", e)],
        }
    }

    fn key_params(params: &serde_json::Value) -> serde_json::Value {
        crate::pipeline::stage::without_path(params)
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let i = import(&inputs.base_dir, &p.path).map_err(StageError::Failed)?;
        let mut a = mesh_to_artefact(&i.model);
        if p.content_digest.as_deref() != Some(a.digest().as_str()) {
            return Err(StageError::Failed(format!(
                "{} changed between checking and running the pipeline; run again",
                p.path
            )));
        }
        a.meta.insert(
            "unknown_cards".into(),
            serde_json::to_value(&i.unknown).unwrap_or_default(),
        );
        a.meta.insert("import_warnings".into(), i.warnings.into());
        Ok(StageOutputs::from([("mesh".to_string(), a)]))
    }
}
