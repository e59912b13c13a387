//! The pipeline file: `name`, `description`, and an ordered map of stages, each with `kind`,
//! `inputs` (port → `stage` or `stage.port`), `with` (typed parameters) and optional `format`.
//! Unknown keys anywhere are errors.

use super::diagnostic::{Diagnostic, Diagnostics};
use super::locate::{Locator, Pos};
use crate::artefact::Format;
use indexmap::IndexMap;
use std::path::Path;

/// A pipeline as written.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    /// Pipeline name (used for lock files).
    pub name: String,
    /// What the pipeline shows.
    #[serde(default)]
    pub description: String,
    /// Stages by name, in file order.
    pub stages: IndexMap<String, StageSpec>,
}

/// One stage as written.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    /// Stage kind, e.g. `frf.synthesise`.
    pub kind: String,
    /// What this stage is for.
    #[serde(default)]
    pub description: String,
    /// Input port → upstream `stage` or `stage.port`.
    #[serde(default)]
    pub inputs: IndexMap<String, String>,
    /// Parameters of the kind.
    #[serde(default)]
    pub with: serde_json::Value,
    /// Storage of the outputs: `arrow` (Parquet + Arrow IPC, default) or `hdf5`.
    #[serde(default)]
    pub format: Format,
}

/// A parsed pipeline file with the positions of its nodes.
#[derive(Clone, Debug)]
pub struct SourcedSpec {
    /// File name for messages.
    pub file: String,
    /// The spec (with `--set` overrides applied).
    pub spec: PipelineSpec,
    /// Node positions.
    pub locator: Locator,
}

/// Reads a pipeline file.
pub fn read_pipeline(path: &Path) -> Result<SourcedSpec, Diagnostics> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| {
        Diagnostics(vec![Diagnostic::new(
            &file,
            format!("cannot read the pipeline file: {e}"),
        )])
    })?;
    parse_pipeline(&file, &text)
}

/// Parses pipeline text; `file` names it in messages.
pub fn parse_pipeline(file: &str, text: &str) -> Result<SourcedSpec, Diagnostics> {
    let locator = Locator::scan(text).map_err(|(pos, msg)| {
        Diagnostics(vec![
            Diagnostic::new(file, format!("YAML syntax error: {msg}")).at(Some(pos)),
        ])
    })?;
    if !locator.duplicates.is_empty() {
        return Err(Diagnostics(
            locator
                .duplicates
                .iter()
                .map(|(path, first, second)| {
                    Diagnostic::new(
                        file,
                        format!(
                            "key `{}` appears twice in one mapping (first at line {})",
                            path.last().map(String::as_str).unwrap_or(""),
                            first.line
                        ),
                    )
                    .at(Some(*second))
                    .help("every key of a mapping, and every stage name, must be unique")
                })
                .collect(),
        ));
    }
    let spec: PipelineSpec = serde_yaml::from_str(text).map_err(|e| {
        let pos = e.location().map(|l| Pos { line: l.line(), col: l.column() });
        let mut msg = e.to_string();
        if let Some(i) = msg.find(" at line ") {
            msg.truncate(i);
        }
        let help = if msg.contains("unknown field") {
            Some("remove the key or fix its spelling; a pipeline has `name`, `description`, `stages`, and a stage has `kind`, `description`, `inputs`, `with`, `format`")
        } else {
            None
        };
        let mut d = Diagnostic::new(file, msg).at(pos);
        if let Some(h) = help {
            d = d.help(h);
        }
        Diagnostics(vec![d])
    })?;
    Ok(SourcedSpec {
        file: file.to_string(),
        spec,
        locator,
    })
}

impl SourcedSpec {
    /// Applies `--set stage.param[.sub…]=value` overrides; `value` is read as YAML.
    pub fn apply_overrides(&mut self, sets: &[String]) -> Result<(), Diagnostics> {
        let mut diags = Vec::new();
        for s in sets {
            let d = |m: String| {
                Diagnostic::new("--set", m).help("write --set STAGE.PARAM=VALUE, e.g. --set noise.level=0.1 or --set noise.seed=3")
            };
            let Some((path, value)) = s.split_once('=') else {
                diags.push(d(format!("`{s}` has no `=`")));
                continue;
            };
            let parts: Vec<&str> = path.trim().split('.').collect();
            if parts.len() < 2 || parts.iter().any(|p| p.is_empty()) {
                diags.push(d(format!("`{path}` must name a stage and a parameter")));
                continue;
            }
            let value: serde_json::Value = match serde_yaml::from_str(value) {
                Ok(v) => v,
                Err(e) => {
                    diags.push(d(format!("value `{value}` is not valid YAML: {e}")));
                    continue;
                }
            };
            let Some(stage) = self.spec.stages.get_mut(parts[0]) else {
                let names: Vec<&str> = self.spec.stages.keys().map(String::as_str).collect();
                let mut diag = d(format!("no stage `{}` in this pipeline", parts[0]));
                diag.help = Some(format!("stages are: {}", names.join(", ")));
                diags.push(diag);
                continue;
            };
            if stage.with.is_null() {
                stage.with = serde_json::Value::Object(Default::default());
            }
            let mut node = &mut stage.with;
            for (i, key) in parts[1..].iter().enumerate() {
                let Some(map) = node.as_object_mut() else {
                    diags.push(d(format!(
                        "`{}` is not a mapping, so `{key}` cannot be set in it",
                        parts[..=i].join(".")
                    )));
                    break;
                };
                if i + 2 == parts.len() {
                    map.insert(key.to_string(), value.clone());
                    break;
                }
                node = map
                    .entry(key.to_string())
                    .or_insert_with(|| serde_json::Value::Object(Default::default()));
            }
        }
        if diags.is_empty() {
            Ok(())
        } else {
            Err(Diagnostics(diags))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_top_level_key_is_located() {
        let e = parse_pipeline("p.yaml", "name: x\nstage:\n  a: {kind: modes}\n").unwrap_err();
        let d = &e.0[0];
        assert!(d.message.contains("unknown field `stage`"), "{d}");
        assert_eq!(d.pos.map(|p| p.line), Some(2));
    }

    #[test]
    fn overrides_reach_nested_params() {
        let mut s = parse_pipeline(
            "p.yaml",
            "name: x\nstages:\n  n:\n    kind: noise.add\n    with: {level: 0.05}\n",
        )
        .unwrap();
        s.apply_overrides(&["n.level=0.1".into(), "n.sub.deep=[1, 2]".into()])
            .unwrap();
        assert_eq!(s.spec.stages["n"].with["level"], serde_json::json!(0.1));
        assert_eq!(
            s.spec.stages["n"].with["sub"]["deep"],
            serde_json::json!([1, 2])
        );
        let e = s.apply_overrides(&["m.level=1".into()]).unwrap_err();
        assert!(e.to_string().contains("no stage `m`"));
    }
}
