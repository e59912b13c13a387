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

/// The largest pipeline file read: pipelines are a few kilobytes; megabytes of YAML are a mistake
/// (and would take minutes to scan).
pub const MAX_PIPELINE_BYTES: u64 = 4 << 20;

/// Reads a pipeline file: a regular file of at most [`MAX_PIPELINE_BYTES`] in UTF-8.
pub fn read_pipeline(path: &Path) -> Result<SourcedSpec, Diagnostics> {
    let file = path.display().to_string();
    let fail = |m: String| Diagnostics(vec![Diagnostic::new(&file, m)]);
    let text = read_bounded_text(path, MAX_PIPELINE_BYTES)
        .map_err(|e| fail(format!("cannot read the pipeline file: {e}")))?;
    parse_pipeline(&file, &text)
}

/// Reads a small text file: only a regular file (not a device, FIFO or directory), at most
/// `limit` bytes, valid UTF-8.
pub fn read_bounded_text(path: &Path, limit: u64) -> Result<String, String> {
    use std::io::Read;
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a regular file".into());
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_end(&mut bytes))
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > limit {
        return Err(format!("larger than the limit of {limit} bytes"));
    }
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "not UTF-8 text (invalid byte at offset {})",
            e.utf8_error().valid_up_to()
        )
    })
}

/// Parses pipeline text; `file` names it in messages. A leading UTF-8 byte-order mark is
/// allowed, as in any YAML file.
pub fn parse_pipeline(file: &str, text: &str) -> Result<SourcedSpec, Diagnostics> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if text.len() as u64 > MAX_PIPELINE_BYTES {
        return Err(Diagnostics(vec![Diagnostic::new(
            file,
            format!(
                "the pipeline is {} bytes, above the limit of {MAX_PIPELINE_BYTES}",
                text.len()
            ),
        )]));
    }
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
    // Parameters are kept as JSON values, where `.nan` and `.inf` would silently become `null`
    // (and then a default): find them first.
    if let Ok(tree) = serde_yaml::from_str::<serde_yaml::Value>(text) {
        let mut found = Vec::new();
        non_finite_numbers(&tree, &mut Vec::new(), &mut found);
        if !found.is_empty() {
            return Err(Diagnostics(
                found
                    .into_iter()
                    .map(|(path, v)| {
                        let keys: Vec<&str> = path.iter().map(String::as_str).collect();
                        Diagnostic::new(file, format!("{v} is not a finite number"))
                            .at(locator.value(&keys))
                            .field(path.join("."))
                            .help("give a finite number")
                    })
                    .collect(),
            ));
        }
    }
    let spec: PipelineSpec = serde_yaml::from_str(text).map_err(|e| {
        let mut pos = e.location().map(|l| Pos { line: l.line(), col: l.column() });
        let mut msg = e.to_string();
        if let Some(i) = msg.find(" at line ") {
            msg.truncate(i);
        }
        let mut help = if msg.contains("unknown field") {
            Some("remove the key or fix its spelling; a pipeline has `name`, `description`, `stages`, and a stage has `kind`, `description`, `inputs`, `with`, `format`")
        } else {
            None
        };
        if pos.is_none() && msg.contains("repetition limit") {
            // Aliases that expand exponentially ("billion laughs"): the parser gives no
            // position, so point at the first alias.
            pos = first_alias(text);
            help = Some("a pipeline needs no YAML aliases that expand to millions of nodes; write the values out");
        }
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

/// The position of the first YAML alias (`*name` after a space, `[`, `,`, `:` or at a line's
/// start), if any.
fn first_alias(text: &str) -> Option<Pos> {
    text.lines().enumerate().find_map(|(i, line)| {
        let b = line.as_bytes();
        (0..b.len()).find_map(|j| {
            let after_gap = j == 0 || b" [,:{-".contains(&b[j - 1]);
            let named = b
                .get(j + 1)
                .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_');
            (b[j] == b'*' && after_gap && named).then_some(Pos {
                line: i + 1,
                col: j + 1,
            })
        })
    })
}

/// The paths (keys and sequence indices) and values of the NaN and infinite numbers in `v`.
fn non_finite_numbers(
    v: &serde_yaml::Value,
    path: &mut Vec<String>,
    found: &mut Vec<(Vec<String>, f64)>,
) {
    match v {
        serde_yaml::Value::Number(n) => {
            if let Some(x) = n.as_f64().filter(|x| !x.is_finite()) {
                found.push((path.clone(), x));
            }
        }
        serde_yaml::Value::Sequence(items) => {
            for (i, item) in items.iter().enumerate() {
                path.push(i.to_string());
                non_finite_numbers(item, path, found);
                path.pop();
            }
        }
        serde_yaml::Value::Mapping(map) => {
            for (k, item) in map {
                let key = match k {
                    serde_yaml::Value::String(s) => s.clone(),
                    other => serde_yaml::to_string(other)
                        .unwrap_or_default()
                        .trim()
                        .to_string(),
                };
                path.push(key);
                non_finite_numbers(item, path, found);
                path.pop();
            }
        }
        serde_yaml::Value::Tagged(t) => non_finite_numbers(&t.value, path, found),
        _ => {}
    }
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
            if let Ok(tree) = serde_yaml::from_str::<serde_yaml::Value>(value) {
                let mut found = Vec::new();
                non_finite_numbers(&tree, &mut Vec::new(), &mut found);
                if let Some((_, v)) = found.first() {
                    diags.push(d(format!("value `{value}` holds {v}, not a finite number")));
                    continue;
                }
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
