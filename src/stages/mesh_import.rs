//! `mesh.import`: a model from Nastran bulk data (free, small and large field, continuations,
//! INCLUDE). The file is parsed when the pipeline is checked, so a malformed card, a card femu
//! does not read or a value its elements cannot take is reported with its file and line before
//! anything runs. The cache key holds a digest of the bytes of the deck and of every file it
//! INCLUDEs together with the digest of the imported artefact (model and notes), not the path:
//! editing any of the files, or a note that would name another file, is never served from the
//! cache.
//!
//! Cards femu does not read that may change the model are errors, all listed at once, except
//! loads, analysis and output cards (skipped and counted), the cards listed in `ignore_cards`
//! and, with `on_unsupported: warn`, all of them (dropped and counted). The counts go into the
//! artefact's meta (`skipped_cards`, `ignored_cards`) beside the import's warnings
//! (`import_warnings`); `femu run` prints them once at the end of the run, for a cached
//! stage too (here they are only logged, at `FEMU_LOG=info`).

use crate::artefact::Artefact;
use crate::artefact::ArtefactKind;
use crate::artefact::mesh::mesh_to_artefact;
use crate::fe::element::MassKind;
use crate::fe::mass_properties::mass_properties;
use crate::model::Model;
use crate::model::import::nastran::{BulkOptions, READ_CARDS, Unsupported, read_bulk_with};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use std::collections::BTreeMap;
use std::path::Path;

/// The stage.
pub struct MeshImport;

/// Parameters of `mesh.import`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Bulk data file (`.bdf`, `.dat`, `.nas`, `.blk`), relative to the pipeline file.
    pub path: String,
    /// Cards femu does not read that may be dropped although they may change the stiffness,
    /// mass or constraints (e.g. `CGAP`, `RSPLINE`; `PARAM,NAME` for one PARAM). Without them
    /// such a card is an error.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ignore_cards: Vec<String>,
    /// What to do with cards femu does not read that may change the stiffness, mass or
    /// constraints: `error` (default) lists them all and stops; `warn` drops them, counts them
    /// in the meta and says so on the console.
    #[serde(default, skip_serializing_if = "OnUnsupported::is_error")]
    pub on_unsupported: OnUnsupported,
    /// Digest of the imported model, filled in when the pipeline is checked (not for users).
    #[serde(default)]
    pub content_digest: Option<String>,
}

/// `on_unsupported` of `mesh.import`.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Deserialize,
    serde::Serialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum OnUnsupported {
    /// Refuse the deck, listing every such card with its count and first line.
    #[default]
    Error,
    /// Drop them knowingly, with a warning.
    Warn,
}

impl OnUnsupported {
    fn is_error(&self) -> bool {
        *self == OnUnsupported::Error
    }
}

struct Imported {
    model: Model,
    skipped: BTreeMap<String, usize>,
    ignored: BTreeMap<String, usize>,
    warnings: Vec<String>,
    source_digest: String,
    grdpnt: Option<[f64; 3]>,
    eigen_request: Option<crate::eigen::EigenRequest>,
}

/// The options from `ignore_cards`: names upper-cased, each a card name or `PARAM,NAME`, and
/// none a card femu reads.
fn options(p: &Params) -> Result<BulkOptions, String> {
    let mut out = BulkOptions::default();
    for raw in &p.ignore_cards {
        let name = raw.trim().to_ascii_uppercase();
        let word = |w: &str| {
            let b = w.as_bytes();
            !b.is_empty()
                && b.len() <= 8
                && b[0].is_ascii_alphabetic()
                && b.iter().all(|c| c.is_ascii_alphanumeric())
        };
        let ok = match name.split_once(',') {
            Some(("PARAM", param)) => word(param),
            Some(_) => false,
            None => word(&name),
        };
        if !ok {
            return Err(format!(
                "`{}` is not a card name; write names such as CGAP or RBE1, or PARAM,NAME for one PARAM",
                crate::core::input::excerpt(raw, 40)
            ));
        }
        if READ_CARDS.contains(&name.as_str()) {
            return Err(format!(
                "femu reads {name}, so it cannot be ignored; `ignore_cards` lists cards femu does not read"
            ));
        }
        out.ignore_cards.insert(name);
    }
    out.on_unsupported = match p.on_unsupported {
        OnUnsupported::Error => Unsupported::Error,
        OnUnsupported::Warn => Unsupported::Warn,
    };
    Ok(out)
}

fn import(base: &Path, p: &Params) -> Result<Imported, String> {
    let full = base.join(&p.path);
    let b = read_bulk_with(&full, &options(p)?).map_err(|e| e.to_string())?;
    Ok(Imported {
        model: b.model,
        skipped: b.skipped,
        ignored: b.ignored,
        warnings: b.warnings,
        source_digest: b.source_digest,
        grdpnt: b.grdpnt,
        eigen_request: b.eigen_request,
    })
}

/// The mesh artefact with the import's notes in its meta, and the cache digest: the
/// artefact's digest together with the digest of the files' bytes.
fn artefact(p: &Params, i: &Imported) -> (Artefact, String) {
    let mut a = mesh_to_artefact(&i.model);
    let unused: Vec<&String> = p
        .ignore_cards
        .iter()
        .filter(|c| {
            let c = c.trim().to_ascii_uppercase();
            !i.ignored
                .keys()
                .any(|k| *k == c || k.split(',').next() == Some(c.as_str()))
        })
        .collect();
    let mut warnings = i.warnings.clone();
    if !unused.is_empty() {
        warnings.push(format!(
            "ignore_cards lists {unused:?}, which the deck does not hold"
        ));
    }
    a.meta.insert(
        "skipped_cards".into(),
        serde_json::to_value(&i.skipped).unwrap_or_default(),
    );
    a.meta.insert(
        "ignored_cards".into(),
        serde_json::to_value(&i.ignored).unwrap_or_default(),
    );
    a.meta.insert(
        "ignore_cards".into(),
        serde_json::to_value(&p.ignore_cards).unwrap_or_default(),
    );
    a.meta.insert("import_warnings".into(), warnings.into());
    if let Some(request) = &i.eigen_request {
        a.meta.insert(
            "eigenvalue_request".into(),
            serde_json::to_value(request).unwrap_or_default(),
        );
    }
    if let Some(reference) = i.grdpnt {
        a.meta
            .insert("weight_summary".into(), weight_summary(&i.model, reference));
    }
    let mut h = blake3::Hasher::new();
    h.update(a.digest().as_bytes());
    h.update(i.source_digest.as_bytes());
    let digest = h.finalize().to_hex().to_string();
    (a, digest)
}

/// The rigid-body mass summary PARAM,GRDPNT asks for (lumped mass, Nastran's default), or
/// why it could not be formed.
fn weight_summary(model: &Model, reference: [f64; 3]) -> serde_json::Value {
    match mass_properties(model, MassKind::Lumped, reference) {
        Ok(p) => serde_json::to_value(p).unwrap_or_default(),
        Err(e) => serde_json::json!({ "error": e.to_string() }),
    }
}

/// `NAME ×count` list for the console.
fn counts(m: &BTreeMap<String, usize>) -> String {
    m.iter()
        .map(|(k, n)| format!("{k} ×{n}"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl TypedStage for MeshImport {
    type Params = Params;
    const KIND: &'static str = "mesh.import";
    const SUMMARY: &'static str = "A model from Nastran bulk data (GRID, CQUAD4, CTRIA3, CBAR/CBEAM, springs, CONM2, SPC, SET1, ...)";
    const IMPL_VERSION: u32 = 2;
    const PREFLIGHT: bool = true;

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
        if let Err(e) = options(p) {
            return vec![ParamIssue::at("ignore_cards", e)];
        }
        match import(&ctx.base_dir, p) {
            Ok(i) => {
                p.content_digest = Some(artefact(p, &i).1);
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
        let i = import(&inputs.base_dir, p).map_err(StageError::input_at("path"))?;
        let (a, digest) = artefact(p, &i);
        if p.content_digest.as_deref() != Some(digest.as_str()) {
            return Err(StageError::input(
                "path",
                format!(
                    "{} changed between checking and running the pipeline; run again",
                    p.path
                ),
            ));
        }
        if !i.skipped.is_empty() {
            tracing::info!(
                "mesh.import {}: cards skipped (they change neither stiffness, mass nor constraints): {}",
                p.path,
                counts(&i.skipped)
            );
        }
        if !i.ignored.is_empty() {
            tracing::info!(
                "mesh.import {}: cards dropped as `ignore_cards` or `on_unsupported` asks (the model lacks what they define): {}",
                p.path,
                counts(&i.ignored)
            );
        }
        if let Some(summary) = a.meta.get("weight_summary") {
            let get = |k: &str| summary.get(k).map(|v| v.to_string()).unwrap_or_default();
            tracing::info!(
                "mesh.import {}: weight summary (PARAM,GRDPNT): mass {} kg by direction, centre of gravity {} m, inertia about it {} kg*m^2",
                p.path,
                get("mass"),
                get("centre_of_gravity"),
                get("inertia")
            );
        }
        if let Some(serde_json::Value::Array(notes)) = a.meta.get("import_warnings") {
            for note in notes.iter().filter_map(|n| n.as_str()) {
                tracing::info!("mesh.import {}: {note}", p.path);
            }
        }
        Ok(StageOutputs::from([("mesh".to_string(), a)]))
    }
}
