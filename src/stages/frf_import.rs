//! `frf.import`: measured FRFs from a Universal File (dataset 58, ASCII or binary 58b),
//! converted to SI with every conversion recorded. The file is read when the pipeline is checked
//! (through [`crate::core::input`]: regular files only, bounded size), so a malformed record or a
//! NaN or infinite measured value is reported then; the cache key holds the digest of the FRFs,
//! not the path.

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::frf_to_artefact;
use crate::frf::FrfSet;
use crate::frf::io::uff::{UffError, read_uff, to_frf_set};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use std::path::Path;

/// The stage.
pub struct FrfImport;

/// Parameters of `frf.import`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Universal File (`.uff`, `.unv`), relative to the pipeline file.
    pub path: String,
    /// Digest of the imported FRFs, filled in when the pipeline is checked (not for users).
    #[serde(default)]
    pub content_digest: Option<String>,
}

fn import(base: &Path, path: &str) -> Result<(FrfSet, Vec<String>), String> {
    let full = base.join(path);
    let file = read_uff(&full).map_err(|e| e.to_string())?;
    let set = to_frf_set(&file.frfs).map_err(|e| match e {
        UffError::NoFrfs => format!("{}: {e}", full.display()),
        e => e.to_string(),
    })?;
    let mut notes = file.conversions.clone();
    notes.extend(file.warnings.iter().cloned());
    Ok((set, notes))
}

impl TypedStage for FrfImport {
    type Params = Params;
    const KIND: &'static str = "frf.import";
    const SUMMARY: &'static str =
        "Measured FRFs from a Universal File (dataset 58/58b), converted to SI";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "frf",
            ArtefactKind::Frf,
            "the measured FRFs",
        )]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        match import(&ctx.base_dir, &p.path) {
            Ok((set, _)) => {
                p.content_digest = Some(frf_to_artefact(&set).digest());
                Vec::new()
            }
            Err(e) => vec![ParamIssue::at("path", e)],
        }
    }

    fn key_params(params: &serde_json::Value) -> serde_json::Value {
        crate::pipeline::stage::without_path(params)
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        // Normally found when checking; here only when the file changed since.
        let (set, notes) =
            import(&inputs.base_dir, &p.path).map_err(StageError::input_at("path"))?;
        let a = frf_to_artefact(&set);
        if p.content_digest.as_deref() != Some(a.digest().as_str()) {
            return Err(StageError::input(
                "path",
                format!(
                    "{} changed between checking and running the pipeline; run again",
                    p.path
                ),
            ));
        }
        let a = a.with_meta("import_notes", notes.into());
        Ok(StageOutputs::from([("frf".to_string(), a)]))
    }
}
