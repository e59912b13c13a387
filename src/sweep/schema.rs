//! The JSON Schema of sweep files, generated from [`SweepSpec`]; `femu schema` writes it to
//! `schemas/sweep.schema.json` and a test keeps the committed file in step.

use super::spec::SweepSpec;
use serde_json::Value;

/// The JSON Schema of a sweep file.
pub fn sweep_schema() -> Value {
    let mut v = schemars::schema_for!(SweepSpec).to_value();
    if let Value::Object(map) = &mut v {
        map.insert(
            "$id".into(),
            Value::String("https://femu.dev/schemas/sweep.schema.json".into()),
        );
        map.insert(
            "description".into(),
            Value::String(
                "A parameter sweep over one femu pipeline: `femu sweep FILE --backend local|slurm`."
                    .into(),
            ),
        );
    }
    v
}
