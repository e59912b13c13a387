//! `mesh.export`: a model as Nastran bulk data. With `path`, the user's own deck is written
//! back with only the cards whose values differ from it changed (PSHELL `T`, MAT1 `E`/`RHO`,
//! PBARL `BAR` dimensions, PBUSH/PELAS/CELAS2 `K`, CONM2 `M` and inertia; copies of shared
//! cards where an update split them), every other line byte for byte, INCLUDEs kept, and a
//! comment block at the top saying what changed and where the values came from
//! ([`crate::model::export::deck_update`]). Without `path`, the model is written afresh
//! ([`crate::model::export::nastran::write_bulk`]).
//!
//! The values written are those of `mesh`, with the final values of `result` (an `update`
//! run) applied to its parameters when connected. The deck's bytes (and its INCLUDEs') are
//! digested when the pipeline is checked and are part of the cache key, not the path.

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::Kind;
use crate::artefact::kinds::nastran_deck::{NastranDeck, NastranDeckKind};
use crate::artefact::mesh::mesh_from_artefact;
use crate::artefact::update::final_values;
use crate::model::Model;
use crate::model::export::deck_update::update_deck;
use crate::model::export::nastran::write_bulk;
use crate::model::import::nastran::{BulkOptions, Unsupported, read_bulk_with, read_deck};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use std::path::Path;

/// The stage.
pub struct MeshExport;

/// Parameters of `mesh.export`.
#[derive(Clone, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// The user's deck (`.bdf`, `.dat`, …, relative to the pipeline file) to write the values
    /// into; the deck the mesh was imported from. Without it the model is written afresh.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<String>,
    /// File name of a deck written afresh (default `model.bdf`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file_name: Option<String>,
    /// Digest of the deck's files, filled in when the pipeline is checked (not for users).
    #[serde(default)]
    pub source_digest: Option<String>,
}

/// A plain file name: no folder, not empty, not `.`/`..`.
fn plain_name(name: &str) -> bool {
    !name.is_empty()
        && name != "."
        && name != ".."
        && !name.contains(['/', '\\', '\0'])
        && name.len() <= 255
}

/// The model to write: `mesh`, with `result`'s final values on its parameters.
fn updated_model(inputs: &StageInputs) -> Result<(Model, String), StageError> {
    let mut model = mesh_from_artefact(inputs.require("mesh")?)?;
    let Some(result) = inputs.get("result") else {
        return Ok((model, "the input mesh".into()));
    };
    for (name, value) in final_values(result)? {
        let p = model
            .parameters
            .iter()
            .find(|q| q.name == name)
            .cloned()
            .ok_or_else(|| {
                StageError::input(
                    "",
                    format!(
                        "the update result's parameter `{name}` is not a parameter of the mesh; connect the mesh the update started from"
                    ),
                )
            })?;
        model
            .set_parameter_value(&p, value)
            .map_err(|e| StageError::input("", format!("`{name}`: {e}")))?;
    }
    Ok((model, format!("update result {}", &result.digest()[..16])))
}

impl TypedStage for MeshExport {
    type Params = Params;
    const KIND: &'static str = "mesh.export";
    const SUMMARY: &'static str =
        "A model as Nastran bulk data: the user's deck with the updated cards changed, or afresh";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required("mesh", ArtefactKind::Mesh, "the model to write"),
            PortSpec::optional(
                "result",
                ArtefactKind::UpdateResult,
                "an update run whose final values are written",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "deck",
            ArtefactKind::NastranDeck,
            "the deck's files, the top file first",
        )]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        if let Some(name) = &p.file_name {
            if p.path.is_some() {
                return vec![ParamIssue::at(
                    "file_name",
                    "a deck written into `path` keeps its own file names; leave `file_name` out",
                )];
            }
            if !plain_name(name) {
                return vec![ParamIssue::at(
                    "file_name",
                    format!("`{name}` is not a plain file name (no folders)"),
                )];
            }
        }
        if let Some(path) = &p.path {
            match read_deck(ctx.base_dir.join(path)) {
                Ok(deck) => p.source_digest = Some(deck.source_digest),
                Err(e) => return vec![ParamIssue::at("path", e.to_string())],
            }
        }
        Vec::new()
    }

    fn key_params(params: &serde_json::Value) -> serde_json::Value {
        crate::pipeline::stage::without_path(params)
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let (model, source) = updated_model(inputs)?;
        let deck = match &p.path {
            None => NastranDeck {
                files: vec![(
                    p.file_name.clone().unwrap_or_else(|| "model.bdf".into()),
                    write_bulk(&model).into_bytes(),
                )],
                changes: Vec::new(),
                source,
            },
            Some(path) => write_into(&inputs.base_dir, path, p, &model, source)?,
        };
        Ok(StageOutputs::from([(
            "deck".to_string(),
            NastranDeckKind::to_artefact(&deck),
        )]))
    }
}

/// The user's deck at `path` with `model`'s values.
fn write_into(
    base: &Path,
    path: &str,
    p: &Params,
    model: &Model,
    source: String,
) -> Result<NastranDeck, StageError> {
    let full = base.join(path);
    let deck = read_deck(&full).map_err(StageError::input_at("path"))?;
    if p.source_digest.as_deref() != Some(deck.source_digest.as_str()) {
        return Err(StageError::input(
            "path",
            format!("{path} changed between checking and running the pipeline; run again"),
        ));
    }
    // The deck's own values: cards femu does not read play no part in the comparison.
    let options = BulkOptions {
        on_unsupported: Unsupported::Warn,
        ..BulkOptions::default()
    };
    let original = read_bulk_with(&full, &options)
        .map_err(StageError::input_at("path"))?
        .model;
    let header = vec![
        format!(
            "femu {} mesh.export: values from {source}",
            env!("CARGO_PKG_VERSION")
        ),
        "changed fields (file line: card field: old -> new):".to_string(),
    ];
    let updated =
        update_deck(&deck, &original, model, &header).map_err(StageError::input_at("path"))?;
    for c in &updated.changes {
        tracing::info!(
            "mesh.export: {} line {}: {} {}: {} -> {}",
            c.file,
            c.line,
            c.card,
            c.field,
            c.old,
            c.new
        );
    }
    Ok(NastranDeck {
        files: updated.files,
        changes: updated.changes,
        source,
    })
}
