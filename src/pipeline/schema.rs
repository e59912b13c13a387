//! JSON Schemas generated from the code: the pipeline file (one variant per stage kind, with its
//! ports and typed parameters) and every artefact kind's `meta.json` and tables. The files in
//! `schemas/` are these, written by `femu schema`; a test keeps them in step with the code.

use super::plan::Registry;
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::layout;
use serde_json::{Map, Value, json};

/// Rewrites `#/$defs/X` references to `#/$defs/<prefix>X`.
fn prefix_refs(v: &mut Value, prefix: &str) {
    match v {
        Value::Object(map) => {
            if let Some(Value::String(r)) = map.get_mut("$ref")
                && let Some(name) = r.strip_prefix("#/$defs/")
            {
                *r = format!("#/$defs/{prefix}{name}");
            }
            for x in map.values_mut() {
                prefix_refs(x, prefix);
            }
        }
        Value::Array(items) => items.iter_mut().for_each(|x| prefix_refs(x, prefix)),
        _ => {}
    }
}

/// The JSON Schema of a pipeline file for the stages in `registry`.
pub fn pipeline_schema(registry: &Registry) -> Value {
    let mut defs = Map::new();
    let mut variants = Vec::new();
    for stage in registry.all() {
        let kind = stage.kind();
        let prefix = format!("{}.", kind);
        let mut params = stage.params_schema().to_value();
        prefix_refs(&mut params, &prefix);
        if let Value::Object(map) = &mut params {
            map.remove("$schema");
            if let Some(Value::Object(d)) = map.remove("$defs") {
                for (k, v) in d {
                    defs.insert(format!("{prefix}{k}"), v);
                }
            }
            map.remove("title");
        }
        let mut ports = Map::new();
        for p in stage.inputs() {
            ports.insert(p.name.into(), json!({"type": "string", "description": format!("`{}` artefact from `stage` or `stage.port`: {}", p.kind, p.doc)}));
        }
        let required: Vec<&str> = stage
            .inputs()
            .iter()
            .filter(|p| p.required)
            .map(|p| p.name)
            .collect();
        variants.push(json!({
            "type": "object",
            "description": stage.summary(),
            "additionalProperties": false,
            "required": if required.is_empty() { json!(["kind"]) } else { json!(["kind", "inputs"]) },
            "properties": {
                "kind": {"const": kind},
                "description": {"type": "string"},
                "inputs": {"type": "object", "additionalProperties": false, "properties": ports, "required": required},
                "with": params,
                "format": {"enum": ["arrow", "hdf5"], "description": "storage of the outputs"},
            }
        }));
    }
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://femu.dev/schemas/pipeline.schema.json",
        "title": "femu pipeline",
        "type": "object",
        "additionalProperties": false,
        "required": ["name", "stages"],
        "properties": {
            "name": {"type": "string"},
            "description": {"type": "string"},
            "stages": {
                "type": "object",
                "propertyNames": {"pattern": "^[A-Za-z0-9_-]+$"},
                "additionalProperties": {"oneOf": variants},
            }
        },
        "$defs": defs,
    })
}

/// The JSON Schema of an artefact directory's `meta.json`, with the table layout.
pub fn artefact_schema(kind: ArtefactKind) -> Value {
    let tables: Map<String, Value> = layout(kind)
        .into_iter()
        .map(|t| {
            let cols: Vec<Value> = t.columns.iter().map(|c| json!({"name": c.name, "type": c.dtype, "unit": c.unit, "description": c.doc})).collect();
            (t.name.to_string(), json!({"storage": t.storage, "required": t.required, "columns": cols}))
        })
        .collect();
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": format!("https://femu.dev/schemas/artefacts/{}.schema.json", kind.name()),
        "title": format!("femu `{}` artefact, schema version {}", kind.name(), kind.schema_version()),
        "type": "object",
        "required": ["femu_artefact", "schema_version", "format", "digest", "meta", "tables"],
        "properties": {
            "femu_artefact": {"const": kind.name()},
            "schema_version": {"const": kind.schema_version()},
            "format": {"enum": ["arrow", "hdf5"]},
            "digest": {"type": "string", "pattern": "^[0-9a-f]{64}$"},
            "meta": {"type": "object"},
            "tables": {"type": "object"},
            "blobs": {"type": "array", "items": {"type": "string"}},
            "producer": {"type": "object"},
        },
        "x-femu-tables": tables,
    })
}
