//! The stage abstraction: one object per YAML `kind:`, with typed parameters, declared ports,
//! an implementation version that enters the cache key, and a `run` that maps input artefacts to
//! output artefacts. Stages never touch the cache or the file system of the engine.

use crate::artefact::{Artefact, ArtefactError, ArtefactKind};
use crate::core::InputFault;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::collections::{BTreeMap, BTreeSet};
use std::marker::PhantomData;
use std::path::PathBuf;

/// A named input or output port.
#[derive(Clone, Debug, PartialEq)]
pub struct PortSpec {
    /// Port name.
    pub name: &'static str,
    /// Artefact kind it carries.
    pub kind: ArtefactKind,
    /// Whether an input must be connected (outputs are always produced).
    pub required: bool,
    /// One line saying what it is.
    pub doc: &'static str,
}

impl PortSpec {
    /// A required port.
    pub const fn required(name: &'static str, kind: ArtefactKind, doc: &'static str) -> Self {
        PortSpec {
            name,
            kind,
            required: true,
            doc,
        }
    }

    /// An optional input port.
    pub const fn optional(name: &'static str, kind: ArtefactKind, doc: &'static str) -> Self {
        PortSpec {
            name,
            kind,
            required: false,
            doc,
        }
    }
}

/// A problem with one parameter: its path below `with` and what would be valid.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamIssue {
    /// Path below `with` (`["springs", "2", "k"]`); empty for the whole block.
    pub path: Vec<String>,
    /// What is wrong and what would be valid.
    pub message: String,
}

impl ParamIssue {
    /// An issue at a single field.
    pub fn at(field: &str, message: impl Into<String>) -> Self {
        ParamIssue {
            path: field.split('.').map(str::to_string).collect(),
            message: message.into(),
        }
    }
}

/// Why a stage failed while running. The kind decides the exit code: [`StageError::Input`] is
/// the user's to fix (exit 2), the others are failures (exit 1).
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    /// An input artefact could not be interpreted.
    #[error(transparent)]
    Artefact(#[from] ArtefactError),
    /// A parameter, a file it names, or the content of an input does not fit what the stage
    /// needs: the message says what would be valid. Found only at run time because it depends on
    /// upstream results (a parameter naming a mode the model does not have, say).
    #[error("{}{message}", if field.is_empty() { String::new() } else { format!("with.{field}: ") })]
    Input {
        /// Parameter path below `with` (`parameters`, `modes.count`), or empty for the inputs.
        field: String,
        /// What is wrong and what would be valid.
        message: String,
        /// The numerics' error that found it, when one did.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// A computation failed; the numerical error is kept as the source.
    #[error("{context}")]
    Numerical {
        /// What was being computed, with the cause's message.
        context: String,
        /// The numerics' own error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// Any other failure (an engine invariant, a figure that could not be drawn).
    #[error("{0}")]
    Failed(String),
}

impl StageError {
    /// A failure from any error, its text kept (prefer [`StageError::numerical`] for numerics'
    /// errors, which keeps the error itself).
    pub fn failed(e: impl std::fmt::Display) -> Self {
        StageError::Failed(e.to_string())
    }

    /// A numerical failure keeping its source error.
    pub fn numerical(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        StageError::Numerical {
            context: e.to_string(),
            source: Box::new(e),
        }
    }

    /// `map_err` adapter: a numerical failure while doing `what`, keeping its source error.
    pub fn numerical_in<E: std::error::Error + Send + Sync + 'static>(
        what: impl std::fmt::Display,
    ) -> impl FnOnce(E) -> Self {
        move |e| StageError::Numerical {
            context: format!("{what}: {e}"),
            source: Box::new(e),
        }
    }

    /// Bad input at parameter `field` (empty: the inputs as a whole).
    pub fn input(field: &str, message: impl std::fmt::Display) -> Self {
        StageError::Input {
            field: field.to_string(),
            message: message.to_string(),
            source: None,
        }
    }

    /// `map_err` adapter for the numerics' errors: bad input at parameter `field` when the error
    /// says the input is at fault ([`InputFault`]), a numerical failure otherwise; the error is
    /// kept as the source either way.
    pub fn from_numerics<E: InputFault + Send + Sync + 'static>(
        field: &str,
    ) -> impl FnOnce(E) -> Self + '_ {
        move |e| {
            if e.is_input() {
                // The numerics often name the field themselves (`modes: mode 5000 …`).
                let text = e.to_string();
                let message = match text.strip_prefix(field).and_then(|m| m.strip_prefix(": ")) {
                    Some(rest) if !field.is_empty() => rest.to_string(),
                    _ => text,
                };
                StageError::Input {
                    field: field.to_string(),
                    message,
                    source: Some(Box::new(e)),
                }
            } else {
                StageError::numerical(e)
            }
        }
    }

    /// `map_err` adapter: an error that means parameter `field` is wrong.
    pub fn input_at<E: std::fmt::Display>(field: &str) -> impl FnOnce(E) -> Self + '_ {
        move |e| StageError::input(field, e)
    }

    /// Whether the user's input is at fault (exit code 2).
    pub fn is_input(&self) -> bool {
        matches!(self, StageError::Input { .. })
    }
}

/// What a stage may know while checking its parameters.
#[derive(Clone, Debug, Default)]
pub struct CheckContext {
    /// Names of the connected input ports.
    pub connected: BTreeSet<String>,
    /// Directory of the pipeline file: relative file paths in parameters resolve against it.
    pub base_dir: PathBuf,
}

impl CheckContext {
    /// A context with these ports connected and the current directory as base.
    pub fn with_ports(ports: &[&str]) -> Self {
        CheckContext {
            connected: ports.iter().map(|s| s.to_string()).collect(),
            base_dir: PathBuf::from("."),
        }
    }

    /// Whether an input port is connected.
    pub fn is_connected(&self, port: &str) -> bool {
        self.connected.contains(port)
    }
}

/// The input artefacts of one run, by port, and the pipeline's directory.
#[derive(Clone, Debug, Default)]
pub struct StageInputs {
    /// Connected inputs.
    pub artefacts: BTreeMap<String, std::sync::Arc<Artefact>>,
    /// Directory of the pipeline file.
    pub base_dir: PathBuf,
    /// The cache for parts of the stage kept on their own (none outside a pipeline run).
    pub parts: Option<std::sync::Arc<super::memo::PartCache>>,
    /// The content digest of each connected input, by port (empty outside a pipeline run):
    /// what a part's key names its inputs by.
    pub digests: BTreeMap<String, String>,
}

impl StageInputs {
    /// An optional input.
    pub fn get(&self, port: &str) -> Option<&Artefact> {
        self.artefacts.get(port).map(|a| a.as_ref())
    }

    /// A part of the run cached on its own: read from the run's cache or computed and committed
    /// (see [`super::memo::PartCache::get_or_compute`]); computed directly outside a pipeline run.
    pub fn part(
        &self,
        part_kind: &str,
        impl_version: u32,
        key: &serde_json::Value,
        kind: crate::artefact::ArtefactKind,
        compute: impl FnOnce() -> Result<Artefact, StageError>,
    ) -> Result<Artefact, StageError> {
        match &self.parts {
            Some(p) => p.get_or_compute(part_kind, impl_version, key, kind, compute),
            None => compute(),
        }
    }

    /// A required input (connection is checked when planning, so absence is an engine bug
    /// reported as an error, never a panic).
    pub fn require(&self, port: &str) -> Result<&Artefact, StageError> {
        self.get(port)
            .ok_or_else(|| StageError::Failed(format!("input port `{port}` is not connected")))
    }

    /// A required input, taken out of the inputs: dropping it frees the artefact once no other
    /// holder is left.
    pub fn take(&mut self, port: &str) -> Result<std::sync::Arc<Artefact>, StageError> {
        self.artefacts
            .remove(port)
            .ok_or_else(|| StageError::Failed(format!("input port `{port}` is not connected")))
    }
}

/// Output artefacts by port.
pub type StageOutputs = BTreeMap<String, Artefact>;

/// A stage kind as the engine sees it.
pub trait Stage: Send + Sync {
    /// The YAML `kind:`.
    fn kind(&self) -> &'static str;
    /// One line saying what it does.
    fn summary(&self) -> &'static str;
    /// Bumped on any change of meaning of the outputs; part of the cache key.
    fn impl_version(&self) -> u32;
    /// Input ports.
    fn inputs(&self) -> Vec<PortSpec>;
    /// Output ports.
    fn outputs(&self) -> Vec<PortSpec>;
    /// JSON Schema of the `with:` block.
    fn params_schema(&self) -> schemars::Schema;
    /// Parses and checks `with`, given which inputs are connected; returns the parameters with
    /// every default filled in (the form that enters the cache key).
    fn check(
        &self,
        with: &serde_json::Value,
        ctx: &CheckContext,
    ) -> Result<serde_json::Value, Vec<ParamIssue>>;
    /// The part of the checked parameters that enters the cache key (default: all). Stages that
    /// read files drop the path and key on the content digest they recorded instead.
    fn key_params(&self, params: &serde_json::Value) -> serde_json::Value {
        params.clone()
    }
    /// Runs on checked parameters.
    fn run(
        &self,
        params: &serde_json::Value,
        inputs: &StageInputs,
    ) -> Result<StageOutputs, StageError>;
    /// [`Stage::run`], handed the inputs, so that a stage may drop an input it has converted
    /// before its heavy work (the executor runs stages so).
    fn run_owned(
        &self,
        params: &serde_json::Value,
        inputs: StageInputs,
    ) -> Result<StageOutputs, StageError> {
        self.run(params, &inputs)
    }
    /// Whether `femu validate` runs the stage to check the stages downstream against its
    /// outputs (see [`TypedStage::PREFLIGHT`]).
    fn runs_in_preflight(&self) -> bool {
        false
    }
    /// Checks of checked parameters against the inputs, before anything runs (see
    /// [`TypedStage::preflight`]).
    fn preflight(&self, _params: &serde_json::Value, _inputs: &StageInputs) -> Vec<ParamIssue> {
        Vec::new()
    }
}

/// A stage with typed parameters; [`Typed`] adapts it to [`Stage`].
pub trait TypedStage: Send + Sync + 'static {
    /// The `with:` block.
    type Params: DeserializeOwned + Serialize + schemars::JsonSchema;
    /// The YAML `kind:`.
    const KIND: &'static str;
    /// One line saying what it does.
    const SUMMARY: &'static str;
    /// Implementation version.
    const IMPL_VERSION: u32;
    /// Input ports.
    fn inputs() -> Vec<PortSpec>;
    /// Output ports.
    fn outputs() -> Vec<PortSpec>;
    /// Range and consistency checks beyond types; may fill defaults that depend on the wiring.
    fn validate(_params: &mut Self::Params, _ctx: &CheckContext) -> Vec<ParamIssue> {
        Vec::new()
    }
    /// The computation.
    fn run(params: &Self::Params, inputs: &StageInputs) -> Result<StageOutputs, StageError>;
    /// [`TypedStage::run`], handed the inputs (default: `run` on them). A stage whose input is
    /// large beside its working memory (the `modes` stage's matrices) converts it and drops it
    /// here before the heavy work.
    fn run_owned(params: &Self::Params, inputs: StageInputs) -> Result<StageOutputs, StageError> {
        Self::run(params, &inputs)
    }
    /// Parameters that enter the cache key (default: all).
    fn key_params(params: &serde_json::Value) -> serde_json::Value {
        params.clone()
    }
    /// Whether the stage only reads files or builds a model from its parameters, cheaply and
    /// without side effects, so that `femu validate` may run it and check the stages
    /// downstream against what it gives ([`crate::pipeline::preflight`]).
    const PREFLIGHT: bool = false;
    /// What can be checked against the inputs before anything runs (DOFs of the test against
    /// the model, set names, parameter kinds), so that `femu validate` reports it at the field
    /// instead of the run failing later. Called only when every connected input is available
    /// at check time.
    fn preflight(_params: &Self::Params, _inputs: &StageInputs) -> Vec<ParamIssue> {
        Vec::new()
    }
}

/// Adapter from [`TypedStage`] to [`Stage`].
pub struct Typed<T>(PhantomData<T>);

impl<T> Typed<T> {
    /// The adapter.
    pub const fn new() -> Self {
        Typed(PhantomData)
    }
}

impl<T> Default for Typed<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// Checked parameters without their `path` field: the key of a stage that reads a file holds the
/// content digest it recorded, not where the file was.
pub fn without_path(params: &serde_json::Value) -> serde_json::Value {
    let mut v = params.clone();
    if let Some(map) = v.as_object_mut() {
        map.remove("path");
    }
    v
}

/// Deserialises typed parameters, reporting the path of the first bad field.
pub fn parse_params<P: DeserializeOwned>(with: &serde_json::Value) -> Result<P, ParamIssue> {
    let value = if with.is_null() {
        serde_json::Value::Object(Default::default())
    } else {
        with.clone()
    };
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path: Vec<String> = e
            .path()
            .iter()
            .filter_map(|seg| match seg {
                serde_path_to_error::Segment::Seq { index } => Some(index.to_string()),
                serde_path_to_error::Segment::Map { key } => Some(key.clone()),
                serde_path_to_error::Segment::Enum { variant } => Some(variant.clone()),
                serde_path_to_error::Segment::Unknown => None,
            })
            .collect();
        ParamIssue {
            path,
            message: e.into_inner().to_string(),
        }
    })
}

impl<T: TypedStage> Stage for Typed<T> {
    fn kind(&self) -> &'static str {
        T::KIND
    }
    fn summary(&self) -> &'static str {
        T::SUMMARY
    }
    fn impl_version(&self) -> u32 {
        T::IMPL_VERSION
    }
    fn inputs(&self) -> Vec<PortSpec> {
        T::inputs()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        T::outputs()
    }
    fn params_schema(&self) -> schemars::Schema {
        schemars::schema_for!(T::Params)
    }
    fn check(
        &self,
        with: &serde_json::Value,
        ctx: &CheckContext,
    ) -> Result<serde_json::Value, Vec<ParamIssue>> {
        let mut params: T::Params = parse_params(with).map_err(|e| vec![e])?;
        let issues = T::validate(&mut params, ctx);
        if !issues.is_empty() {
            return Err(issues);
        }
        serde_json::to_value(&params).map_err(|e| {
            vec![ParamIssue {
                path: vec![],
                message: e.to_string(),
            }]
        })
    }
    fn key_params(&self, params: &serde_json::Value) -> serde_json::Value {
        T::key_params(params)
    }
    fn run(
        &self,
        params: &serde_json::Value,
        inputs: &StageInputs,
    ) -> Result<StageOutputs, StageError> {
        let params: T::Params = parse_params(params).map_err(|e| StageError::Failed(e.message))?;
        T::run(&params, inputs)
    }
    fn run_owned(
        &self,
        params: &serde_json::Value,
        inputs: StageInputs,
    ) -> Result<StageOutputs, StageError> {
        let params: T::Params = parse_params(params).map_err(|e| StageError::Failed(e.message))?;
        T::run_owned(&params, inputs)
    }
    fn runs_in_preflight(&self) -> bool {
        T::PREFLIGHT
    }
    fn preflight(&self, params: &serde_json::Value, inputs: &StageInputs) -> Vec<ParamIssue> {
        match parse_params::<T::Params>(params) {
            Ok(p) => T::preflight(&p, inputs),
            Err(e) => vec![e],
        }
    }
}
