//! What a run leaves beside its artefacts for its readers (`femu show`, the run report): the run
//! record (statuses, times, warnings, command) and the warnings stages record in their
//! artefacts' meta.

use serde_json::{Map, Value};
use std::collections::BTreeMap;

/// Name of the run record in an `--out` directory: statuses, times and warnings of the run
/// that wrote it (not in the lock file, which holds no times so that identical runs write
/// identical locks; never part of an artefact).
pub const RUN_RECORD_FILE: &str = "femu.run.json";

/// One stage in the run record.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct RunRecordStage {
    /// Stage name.
    pub name: String,
    /// Kind.
    pub kind: String,
    /// `ran`, `cached` or `recomputed`.
    pub status: String,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// The run record: how the run that wrote an `--out` directory went.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct RunRecord {
    /// Pipeline name.
    pub pipeline: String,
    /// femu version.
    pub femu_version: String,
    /// The command line.
    pub command: Vec<String>,
    /// Stages in the order they were planned.
    pub stages: Vec<RunRecordStage>,
    /// Warnings by stage.
    pub warnings: BTreeMap<String, Vec<String>>,
}

/// The warnings an artefact's meta records: every `warnings`, `…_warnings`, `notes` or
/// `…_notes` entry (a string or a list of strings; `frf.import`'s unit conversions and sign
/// flips, `mesh.import`'s warnings, …), and the deck cards `mesh.import` skipped or dropped.
pub fn meta_warnings(meta: &Map<String, Value>) -> Vec<String> {
    let mut out = Vec::new();
    for (key, value) in meta {
        let is_warning = key == "warnings"
            || key.ends_with("_warnings")
            || key == "notes"
            || key.ends_with("_notes");
        if is_warning {
            match value {
                Value::String(s) => out.push(s.clone()),
                Value::Array(items) => out.extend(items.iter().map(|v| match v {
                    Value::String(s) => s.clone(),
                    other => other.to_string(),
                })),
                _ => {}
            }
        }
    }
    for (key, what) in [
        (
            "skipped_cards",
            "cards skipped (they change neither stiffness, mass nor constraints)",
        ),
        (
            "ignored_cards",
            "cards dropped as `ignore_cards` or `on_unsupported` asks (the model lacks what they define)",
        ),
    ] {
        if let Some(Value::Object(cards)) = meta.get(key)
            && !cards.is_empty()
        {
            let counts: Vec<String> = cards
                .iter()
                .map(|(card, n)| format!("{card} ×{n}"))
                .collect();
            out.push(format!("{what}: {}", counts.join(", ")));
        }
    }
    out
}

/// The warnings of one stage's outputs, each once, in port order.
pub fn stage_warnings<'a>(metas: impl IntoIterator<Item = &'a Map<String, Value>>) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for meta in metas {
        for w in meta_warnings(meta) {
            if !out.contains(&w) {
                out.push(w);
            }
        }
    }
    out
}
