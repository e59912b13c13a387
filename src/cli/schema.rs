//! `femu schema`: the JSON Schemas of pipelines, sweeps and artefacts.

use super::Failure;
use crate::artefact::ArtefactKind;
use crate::pipeline::schema::{artefact_schema, pipeline_schema};
use crate::stages::registry;
use std::path::Path;

/// `femu schema`.
pub(super) fn run(out: &Path) -> Result<u8, Failure> {
    write_schemas(out)?;
    println!("schemas written to {}", out.display());
    Ok(0)
}

/// Writes `pipeline.schema.json`, `sweep.schema.json` and `artefacts/<kind>.schema.json` under `out`.
pub fn write_schemas(out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out.join("artefacts"))?;
    let text = serde_json::to_string_pretty(&pipeline_schema(&registry()))? + "\n";
    std::fs::write(out.join("pipeline.schema.json"), text)?;
    let text = serde_json::to_string_pretty(&crate::sweep::schema::sweep_schema())? + "\n";
    std::fs::write(out.join("sweep.schema.json"), text)?;
    for kind in ArtefactKind::ALL {
        let text = serde_json::to_string_pretty(&artefact_schema(kind))? + "\n";
        std::fs::write(
            out.join("artefacts")
                .join(format!("{}.schema.json", kind.name())),
            text,
        )?;
    }
    Ok(())
}
