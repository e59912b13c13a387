//! Planning: a parsed pipeline becomes a checked DAG before any stage runs. Names are resolved,
//! ports and artefact kinds matched, parameters typed and range-checked with defaults filled in,
//! and cycles rejected. Every problem found is reported, not only the first.

use super::diagnostic::{Diagnostic, Diagnostics, nearest};
use super::spec::{SourcedSpec, StageSpec};
use super::stage::{CheckContext, PortSpec, Stage};
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

/// Upstream wiring of each stage: input port -> (upstream stage, its output port).
type Edges<'a> = BTreeMap<&'a str, BTreeMap<String, (String, String)>>;

/// Builds the plan, or every problem found: the names, the stage kinds, each stage's inputs,
/// required ports and parameters (all reported together), then the topological order.
pub fn plan(src: &SourcedSpec, registry: &Registry) -> Result<Plan, Diagnostics> {
    let spec = &src.spec;
    let base_dir = base_dir(&src.file);
    let mut p = Planning::new(src);
    p.check_names();
    let kinds = p.resolve_kinds(registry);
    let mut edges: Edges = BTreeMap::new();
    let mut params: BTreeMap<&str, serde_json::Value> = BTreeMap::new();
    for (name, st) in &spec.stages {
        let Some(stage) = kinds.get(name.as_str()).copied() else {
            continue;
        };
        let wired = p.wire_inputs(name, st, stage, &kinds);
        p.check_required(name, st, stage);
        if let Some(v) = p.check_params(name, st, stage, &base_dir) {
            params.insert(name, v);
        }
        edges.insert(name, wired);
    }
    if !p.diags.is_empty() {
        return Err(Diagnostics(p.diags));
    }
    let order = p.topological_order(&edges)?;
    Ok(Plan {
        name: spec.name.clone(),
        description: spec.description.clone(),
        nodes: nodes(spec, &order, &kinds, &params, &edges),
        base_dir,
    })
}

/// The directory of the pipeline file, `.` for a bare file name.
fn base_dir(file: &str) -> std::path::PathBuf {
    std::path::Path::new(file)
        .parent()
        .map(|p| {
            if p.as_os_str().is_empty() {
                std::path::Path::new(".")
            } else {
                p
            }
        })
        .unwrap_or(std::path::Path::new("."))
        .to_path_buf()
}

/// The pipeline being planned and the problems found so far.
struct Planning<'a> {
    file: &'a str,
    loc: &'a super::locate::Locator,
    spec: &'a super::spec::PipelineSpec,
    /// Stage names in file order.
    names: Vec<&'a str>,
    diags: Vec<Diagnostic>,
}

impl<'a> Planning<'a> {
    fn new(src: &'a SourcedSpec) -> Self {
        Planning {
            file: src.file.as_str(),
            loc: &src.locator,
            spec: &src.spec,
            names: src.spec.stages.keys().map(String::as_str).collect(),
            diags: Vec::new(),
        }
    }

    /// The pipeline's name (it names the lock file) and that it has stages.
    fn check_names(&mut self) {
        let (file, loc, spec) = (self.file, self.loc, self.spec);
        if !valid_pipeline_name(&spec.name) {
            self.diags.push(
                Diagnostic::new(
                    file,
                    format!("`{}` is not a valid pipeline name", spec.name.escape_debug()),
                )
                .at(loc.value(&["name"]))
                .field("name")
                .help("the name names the lock file: use 1 to 128 letters, digits, `_`, `-` and `.`, not starting with `.`"),
            );
        }
        if self.names.is_empty() {
            self.diags
                .push(Diagnostic::new(file, "the pipeline has no stages").at(loc.key(&["stages"])));
        }
    }

    /// Each stage's kind in the registry, and that its name is valid.
    fn resolve_kinds(&mut self, registry: &Registry) -> BTreeMap<&'a str, &'static dyn Stage> {
        let (file, loc) = (self.file, self.loc);
        let mut kinds = BTreeMap::new();
        for (name, st) in &self.spec.stages {
            if !valid_name(name) {
                self.diags.push(
                    Diagnostic::new(file, format!("`{name}` is not a valid stage name"))
                        .at(loc.key(&["stages", name]))
                        .help(
                            "use letters, digits, `_` and `-` (no dots: `stage.port` refers to a port)",
                        ),
                );
            }
            match registry.get(&st.kind) {
                Some(s) => {
                    kinds.insert(name.as_str(), s);
                }
                None => {
                    let all: Vec<&str> = registry.all().iter().map(|s| s.kind()).collect();
                    let help = match nearest(&st.kind, all.iter().copied()) {
                        Some(n) => format!("did you mean `{n}`? (`femu list` shows every kind)"),
                        None => format!("known kinds: {}", all.join(", ")),
                    };
                    self.diags.push(
                        Diagnostic::new(file, format!("unknown stage kind `{}`", st.kind))
                            .at(loc.value(&["stages", name, "kind"]))
                            .stage(name)
                            .field("kind")
                            .help(help),
                    );
                }
            }
        }
        kinds
    }

    /// A stage's inputs matched to upstream output ports of the same artefact kind.
    fn wire_inputs(
        &mut self,
        name: &str,
        st: &StageSpec,
        stage: &'static dyn Stage,
        kinds: &BTreeMap<&str, &'static dyn Stage>,
    ) -> BTreeMap<String, (String, String)> {
        let ports = stage.inputs();
        let mut wired = BTreeMap::new();
        for (port, source) in &st.inputs {
            let Some(pspec) = ports.iter().find(|p| p.name == port) else {
                let help = if ports.is_empty() {
                    format!("`{}` takes no inputs", st.kind)
                } else {
                    format!("inputs of `{}`: {}", st.kind, port_list(&ports))
                };
                self.diags.push(
                    Diagnostic::new(
                        self.file,
                        format!("`{}` has no input port `{port}`", st.kind),
                    )
                    .at(self.loc.key(&["stages", name, "inputs", port]))
                    .stage(name)
                    .field(format!("inputs.{port}"))
                    .help(help),
                );
                continue;
            };
            if let Some(w) = self.wire_input(name, port, source, pspec, kinds) {
                wired.insert(port.clone(), w);
            }
        }
        wired
    }

    /// The upstream `(stage, output port)` that input `port` reads from `source`
    /// (`stage.port`, or `stage` with one output), or `None` with the problem reported.
    fn wire_input(
        &mut self,
        name: &str,
        port: &str,
        source: &str,
        pspec: &PortSpec,
        kinds: &BTreeMap<&str, &'static dyn Stage>,
    ) -> Option<(String, String)> {
        let at = self.loc.value(&["stages", name, "inputs", port]);
        let field = format!("inputs.{port}");
        let report = |msg: String| {
            Diagnostic::new(self.file, msg)
                .at(at)
                .stage(name)
                .field(&field)
        };
        let (up, up_port) = match source.split_once('.') {
            Some((s, p)) => (s, Some(p)),
            None => (source, None),
        };
        if up == name {
            let d = report("a stage cannot read its own output".into());
            self.diags.push(d);
            return None;
        }
        let Some(up_spec) = self.spec.stages.get(up) else {
            let help = match nearest(up, self.names.iter().copied()) {
                Some(n) => format!("did you mean `{n}`?"),
                None => format!("stages are: {}", self.names.join(", ")),
            };
            let d = report(format!("no stage `{up}` in this pipeline")).help(help);
            self.diags.push(d);
            return None;
        };
        let up_stage = kinds.get(up).copied()?;
        let outs = up_stage.outputs();
        let out = match up_port {
            Some(p) => outs.iter().find(|o| o.name == p),
            None if outs.len() == 1 => outs.first(),
            // Several outputs: the one of the kind the input takes, when it is the only one.
            None => {
                let mut same = outs.iter().filter(|o| o.kind == pspec.kind);
                match (same.next(), same.next()) {
                    (Some(o), None) => Some(o),
                    _ => None,
                }
            }
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
            let d = report(msg).help(format!("outputs: {list}"));
            self.diags.push(d);
            return None;
        };
        if out.kind != pspec.kind {
            let d = report(format!(
                "input `{port}` takes a `{}` artefact but `{up}.{}` is `{}`",
                pspec.kind, out.name, out.kind
            ))
            .help(format!("connect an output of kind `{}`", pspec.kind));
            self.diags.push(d);
            return None;
        }
        Some((up.to_string(), out.name.to_string()))
    }

    /// Every required input port of a stage is connected.
    fn check_required(&mut self, name: &str, st: &StageSpec, stage: &'static dyn Stage) {
        let loc = self.loc;
        for p in stage.inputs().iter().filter(|p| p.required) {
            if !st.inputs.contains_key(p.name) {
                self.diags.push(
                    Diagnostic::new(
                        self.file,
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
    }

    /// A stage's parameters, typed and range-checked with defaults filled in by the stage.
    fn check_params(
        &mut self,
        name: &str,
        st: &StageSpec,
        stage: &'static dyn Stage,
        base_dir: &std::path::Path,
    ) -> Option<serde_json::Value> {
        let ctx = CheckContext {
            connected: st.inputs.keys().cloned().collect(),
            base_dir: base_dir.to_path_buf(),
        };
        let issues = match stage.check(&st.with, &ctx) {
            Ok(v) => return Some(v),
            Err(issues) => issues,
        };
        for issue in issues {
            let mut path = vec!["stages", name, "with"];
            path.extend(issue.path.iter().map(String::as_str));
            let field = std::iter::once("with")
                .chain(issue.path.iter().map(String::as_str))
                .collect::<Vec<_>>()
                .join(".");
            self.diags.push(
                Diagnostic::new(self.file, issue.message.clone())
                    .at(self.loc.value(&path))
                    .stage(name)
                    .field(field)
                    .help(format!("`femu list {}` shows its parameters", st.kind)),
            );
        }
        None
    }

    /// Topological order, file order among ready stages (Kahn), or the cycle that prevents it.
    fn topological_order(&self, edges: &Edges<'a>) -> Result<Vec<&'a str>, Diagnostics> {
        let names = &self.names;
        let mut order: Vec<&str> = Vec::new();
        let mut done: BTreeSet<&str> = BTreeSet::new();
        while order.len() < names.len() {
            let next = names.iter().copied().find(|n| {
                !done.contains(n) && edges[n].values().all(|(up, _)| done.contains(up.as_str()))
            });
            let Some(n) = next else {
                let stuck: Vec<&str> = names
                    .iter()
                    .copied()
                    .filter(|n| !done.contains(n))
                    .collect();
                let cycle = find_cycle(&stuck, edges);
                return Err(Diagnostics(vec![
                    Diagnostic::new(
                        self.file,
                        format!("the stages form a cycle: {}", cycle.join(" -> ")),
                    )
                    .at(self.loc.key(&["stages", cycle[0]]))
                    .stage(cycle[0])
                    .help("a pipeline is a DAG: break the cycle by removing one of these inputs"),
                ]));
            };
            done.insert(n);
            order.push(n);
        }
        Ok(order)
    }
}

/// An input port list for help texts: `name (kind, required), …`.
fn port_list(ports: &[PortSpec]) -> String {
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
}

/// The plan's nodes in `order`, inputs referring to upstream nodes by index.
fn nodes(
    spec: &super::spec::PipelineSpec,
    order: &[&str],
    kinds: &BTreeMap<&str, &'static dyn Stage>,
    params: &BTreeMap<&str, serde_json::Value>,
    edges: &Edges,
) -> Vec<PlanNode> {
    let index: BTreeMap<&str, usize> = order.iter().enumerate().map(|(i, n)| (*n, i)).collect();
    order
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
        .collect()
}

/// A cycle among `stuck` stages, as a closed path of names.
fn find_cycle<'a>(stuck: &[&'a str], edges: &Edges<'a>) -> Vec<&'a str> {
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
