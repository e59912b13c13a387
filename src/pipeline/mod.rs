//! The pipeline engine: YAML spec, node positions for error messages, stage abstraction,
//! planning into a checked DAG, execution against the cache, and lock files.

pub mod diagnostic;
pub mod executor;
pub mod locate;
pub mod lock;
pub mod memo;
pub mod plan;
pub mod preflight;
pub mod schema;
pub mod spec;
pub mod stage;

pub use diagnostic::{Diagnostic, Diagnostics};
pub use executor::{ProgressMode, RunOptions, RunReport, Status, execute, materialise};
pub use plan::{Plan, Registry, plan};
pub use preflight::preflight;
pub use spec::{SourcedSpec, parse_pipeline, read_pipeline};
pub use stage::{
    CheckContext, ParamIssue, PortSpec, Stage, StageError, StageInputs, StageOutputs, Typed,
    TypedStage,
};
