//! Planning: a parsed pipeline becomes a checked DAG before any stage runs. Names are resolved,
//! ports and artefact kinds matched, parameters typed and range-checked with defaults filled in,
//! and cycles rejected. Every problem found is reported, not only the first.

use super::diagnostic::{Diagnostic, Diagnostics, nearest};
use super::spec::SourcedSpec;
use super::stage::{CheckContext, Stage};
use crate::artefact::Format;
use std::collections::{BTreeMap, BTreeSet};

/// The stage kinds known to the engine.
pub struct Registry {
    stages: Vec<&'static dyn Stage>,
}

impl Registry {
    /// A registry of the given stages.
    pub fn new(stages: Vec<&'static dyn Stage>) -> Self {
        Registry { stages }
    }

    /// A stage by kind.
    pub fn get(&self, kind: &str) -> Option<&'static dyn Stage> {
        self.stages.iter().copied().find(|s| s.kind() == kind)
    }

    /// All stages in registration order.
    pub fn all(&self) -> &[&'static dyn Stage] {
        &self.stages
    }
}

/// Where an input comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputRef {
    /// Index of the upstream node in [`Plan::nodes`].
    pub node: usize,
    /// Its output port.
    pub port: String,
}

/// One resolved stage.
#[derive(Clone)]
pub struct PlanNode {
    /// Stage name.
    pub name: String,
    /// Its kind.
    pub stage: &'static dyn Stage,
    /// Checked parameters with defaults.
    pub params: serde_json::Value,
    /// Output format.
    pub format: Format,
    /// Inputs by port.
    pub inputs: BTreeMap<String, InputRef>,
    /// Description from the file.
    pub description: String,
}

/// A checked pipeline in topological order (file order where the DAG allows).
#[derive(Clone)]
pub struct Plan {
    /// Pipeline name.
    pub name: String,
    /// Description.
    pub description: String,
    /// Stages, upstream before downstream.
    pub nodes: Vec<PlanNode>,
    /// Directory of the pipeline file.
    pub base_dir: std::path::PathBuf,
}

impl Plan {
    /// Index of a stage by name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    /// `targets` and everything upstream of them, as node indices.
    pub fn upstream_closure(&self, targets: &[usize]) -> BTreeSet<usize> {
        let mut keep = BTreeSet::new();
        let mut todo: Vec<usize> = targets.to_vec();
        while let Some(i) = todo.pop() {
            if keep.insert(i) {
                todo.extend(self.nodes[i].inputs.values().map(|r| r.node));
            }
        }
        keep
    }
}

fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// Whether a pipeline name is safe as a file name: it names the lock file, so it must be one
/// path component of letters, digits, `_`, `-` and `.`, not starting with `.`.
pub fn valid_pipeline_name(name: &str) -> bool {
    (1..=128).contains(&name.len())
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c))
}

/// Builds the plan, or every problem found.
pub fn plan(src: &SourcedSpec, registry: &Registry) -> Result<Plan, Diagnostics> {
    let file = src.file.as_str();
    let loc = &src.locator;
    let spec = &src.spec;
    let base_dir = std::path::Path::new(file)
        .parent()
        .map(|p| {
            if p.as_os_str().is_empty() {
                std::path::Path::new(".")
            } else {
                p
            }
        })
        .unwrap_or(std::path::Path::new("."))
        .to_path_buf();
    let mut diags = Vec::new();
    if !valid_pipeline_name(&spec.name) {
        diags.push(
            Diagnostic::new(
                file,
                format!("`{}` is not a valid pipeline name", spec.name.escape_debug()),
            )
            .at(loc.value(&["name"]))
            .field("name")
            .help("the name names the lock file: use 1 to 128 letters, digits, `_`, `-` and `.`, not starting with `.`"),
        );
    }
    let names: Vec<&str> = spec.stages.keys().map(String::as_str).collect();
    if names.is_empty() {
        diags.push(Diagnostic::new(file, "the pipeline has no stages").at(loc.key(&["stages"])));
    }
    // Kinds.
    let mut kinds: BTreeMap<&str, &'static dyn Stage> = BTreeMap::new();
    for (name, st) in &spec.stages {
        if !valid_name(name) {
            diags.push(
                Diagnostic::new(file, format!("`{name}` is not a valid stage name"))
                    .at(loc.key(&["stages", name]))
                    .help(
                        "use letters, digits, `_` and `-` (no dots: `stage.port` refers to a port)",
                    ),
            );
        }
        match registry.get(&st.kind) {
            Some(s) => {
                kinds.insert(name, s);
            }
            None => {
                let all: Vec<&str> = registry.all().iter().map(|s| s.kind()).collect();
                let help = match nearest(&st.kind, all.iter().copied()) {
                    Some(n) => format!("did you mean `{n}`? (`femu list` shows every kind)"),
                    None => format!("known kinds: {}", all.join(", ")),
                };
                diags.push(
                    Diagnostic::new(file, format!("unknown stage kind `{}`", st.kind))
                        .at(loc.value(&["stages", name, "kind"]))
                        .stage(name)
                        .field("kind")
                        .help(help),
                );
            }
        }
    }
    // Inputs and parameters.
    let mut edges: BTreeMap<&str, BTreeMap<String, (String, String)>> = BTreeMap::new();
    let mut params: BTreeMap<&str, serde_json::Value> = BTreeMap::new();
    for (name, st) in &spec.stages {
        let Some(stage) = kinds.get(name.as_str()).copied() else {
            continue;
        };
        let ports = stage.inputs();
        let port_list = || {
            ports
                .iter()
                .map(|p| {
                    format!(
                        "{} ({}{})",
                        p.name,
                        p.kind,
                        if p.required { ", required" } else { "" }
                    )
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let mut wired = BTreeMap::new();
        for (port, source) in &st.inputs {
            let at = loc.value(&["stages", name, "inputs", port]);
            let field = format!("inputs.{port}");
            let Some(pspec) = ports.iter().find(|p| p.name == port) else {
                let help = if ports.is_empty() {
                    format!("`{}` takes no inputs", st.kind)
                } else {
                    format!("inputs of `{}`: {}", st.kind, port_list())
                };
                diags.push(
                    Diagnostic::new(file, format!("`{}` has no input port `{port}`", st.kind))
                        .at(loc.key(&["stages", name, "inputs", port]))
                        .stage(name)
                        .field(&field)
                        .help(help),
                );
                continue;
            };
            let (up, up_port) = match source.split_once('.') {
                Some((s, p)) => (s, Some(p)),
                None => (source.as_str(), None),
            };
            if up == name {
                diags.push(
                    Diagnostic::new(file, "a stage cannot read its own output")
                        .at(at)
                        .stage(name)
                        .field(&field),
                );
                continue;
            }
            let Some(up_spec) = spec.stages.get(up) else {
                let help = match nearest(up, names.iter().copied()) {
                    Some(n) => format!("did you mean `{n}`?"),
                    None => format!("stages are: {}", names.join(", ")),
                };
                diags.push(
                    Diagnostic::new(file, format!("no stage `{up}` in this pipeline"))
                        .at(at)
                        .stage(name)
                        .field(&field)
                        .help(help),
                );
                continue;
            };
            let Some(up_stage) = kinds.get(up).copied() else {
                continue;
            };
            let outs = up_stage.outputs();
            let out = match up_port {
                Some(p) => outs.iter().find(|o| o.name == p),
                None if outs.len() == 1 => outs.first(),
                None => None,
            };
            let Some(out) = out else {
                let list = outs
                    .iter()
                    .map(|o| format!("{up}.{} ({})", o.name, o.kind))
                    .collect::<Vec<_>>()
                    .join(", ");
                let msg = match up_port {
                    Some(p) => format!("`{up}` ({}) has no output port `{p}`", up_spec.kind),
                    None => format!("`{up}` ({}) has several outputs; name one", up_spec.kind),
                };
                diags.push(
                    Diagnostic::new(file, msg)
                        .at(at)
                        .stage(name)
                        .field(&field)
                        .help(format!("outputs: {list}")),
                );
                continue;
            };
            if out.kind != pspec.kind {
                diags.push(
                    Diagnostic::new(
                        file,
                        format!(
                            "input `{port}` takes a `{}` artefact but `{up}.{}` is `{}`",
                            pspec.kind, out.name, out.kind
                        ),
                    )
                    .at(at)
                    .stage(name)
                    .field(&field)
                    .help(format!("connect an output of kind `{}`", pspec.kind)),
                );
                continue;
            }
            wired.insert(port.clone(), (up.to_string(), out.name.to_string()));
        }
        for p in ports.iter().filter(|p| p.required) {
            if !st.inputs.contains_key(p.name) {
                diags.push(
                    Diagnostic::new(
                        file,
                        format!("required input `{}` ({}) is not connected", p.name, p.kind),
                    )
                    .at(loc
                        .key(&["stages", name, "inputs"])
                        .or(loc.key(&["stages", name])))
                    .stage(name)
                    .field("inputs")
                    .help(format!("add `inputs: {{{}: <stage>}}`: {}", p.name, p.doc)),
                );
            }
        }
        let ctx = CheckContext {
            connected: st.inputs.keys().cloned().collect(),
            base_dir: base_dir.clone(),
        };
        match stage.check(&st.with, &ctx) {
            Ok(v) => {
                params.insert(name, v);
            }
            Err(issues) => {
                for issue in issues {
                    let mut path = vec!["stages", name.as_str(), "with"];
                    path.extend(issue.path.iter().map(String::as_str));
                    let field = std::iter::once("with")
                        .chain(issue.path.iter().map(String::as_str))
                        .collect::<Vec<_>>()
                        .join(".");
                    diags.push(
                        Diagnostic::new(file, issue.message.clone())
                            .at(loc.value(&path))
                            .stage(name)
                            .field(field)
                            .help(format!("`femu list {}` shows its parameters", st.kind)),
                    );
                }
            }
        }
        edges.insert(name, wired);
    }
    if !diags.is_empty() {
        return Err(Diagnostics(diags));
    }
    // Topological order, file order among ready stages (Kahn).
    let mut order: Vec<&str> = Vec::new();
    let mut done: BTreeSet<&str> = BTreeSet::new();
    while order.len() < names.len() {
        let next = names.iter().copied().find(|n| {
            !done.contains(n) && edges[n].values().all(|(up, _)| done.contains(up.as_str()))
        });
        match next {
            Some(n) => {
                done.insert(n);
                order.push(n);
            }
            None => {
                let stuck: Vec<&str> = names
                    .iter()
                    .copied()
                    .filter(|n| !done.contains(n))
                    .collect();
                let cycle = find_cycle(&stuck, &edges);
                return Err(Diagnostics(vec![
                    Diagnostic::new(
                        file,
                        format!("the stages form a cycle: {}", cycle.join(" -> ")),
                    )
                    .at(loc.key(&["stages", cycle[0]]))
                    .stage(cycle[0])
                    .help("a pipeline is a DAG: break the cycle by removing one of these inputs"),
                ]));
            }
        }
    }
    let index: BTreeMap<&str, usize> = order.iter().enumerate().map(|(i, n)| (*n, i)).collect();
    let nodes = order
        .iter()
        .map(|n| {
            let st = &spec.stages[*n];
            PlanNode {
                name: n.to_string(),
                stage: kinds[n],
                params: params[n].clone(),
                format: st.format,
                inputs: edges[n]
                    .iter()
                    .map(|(port, (up, up_port))| {
                        (
                            port.clone(),
                            InputRef {
                                node: index[up.as_str()],
                                port: up_port.clone(),
                            },
                        )
                    })
                    .collect(),
                description: st.description.clone(),
            }
        })
        .collect();
    Ok(Plan {
        name: spec.name.clone(),
        description: spec.description.clone(),
        nodes,
        base_dir,
    })
}

/// A cycle among `stuck` stages, as a closed path of names.
fn find_cycle<'a>(
    stuck: &[&'a str],
    edges: &BTreeMap<&'a str, BTreeMap<String, (String, String)>>,
) -> Vec<&'a str> {
    let mut path = vec![stuck[0]];
    loop {
        let cur = *path.last().unwrap_or(&stuck[0]);
        let next = edges[cur]
            .values()
            .filter_map(|(up, _)| stuck.iter().copied().find(|s| *s == up.as_str()))
            .next();
        let Some(next) = next else { return path };
        if let Some(i) = path.iter().position(|p| *p == next) {
            let mut cycle: Vec<&str> = path[i..].to_vec();
            cycle.reverse();
            cycle.push(cycle[0]);
            return cycle;
        }
        path.push(next);
    }
}
