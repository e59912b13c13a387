//! Artefacts: typed, versioned values that stages read and write.
//!
//! In memory an artefact is a kind, a JSON metadata object, named [`Table`]s and named binary
//! blobs (images). On disk it is a directory holding `meta.json` and one file per table —
//! Parquet for row tables, Arrow IPC for matrices and mode shapes — or, with the `hdf5` feature
//! and `format: hdf5`, a single `data.h5`. Its digest is a blake3 hash of a canonical encoding of
//! the content, independent of the file format, so downstream cache keys do not change when only
//! the storage does. Each kind is a type in [`kinds`]: its layout, writer and reader in one file.

pub mod codec;
pub mod compare;
pub mod digest;
#[cfg(feature = "hdf5")]
mod hdf5_codec;
pub mod kinds;
mod table;

/// The `mesh` kind's writer and reader (the path stages use).
pub mod mesh {
    pub use super::kinds::mesh::*;
}

/// The `update_result` kind's writer and readers.
pub mod update {
    pub use super::kinds::update_result::*;
}

/// The substructuring kinds: `partition`, `reduced_model`, `reduced_component`.
pub mod reduced {
    pub use super::kinds::partition::*;
    pub use super::kinds::reduced_component::*;
    pub use super::kinds::reduced_model::*;
    pub use super::kinds::{dense_triplet_table, dof_index_digest};
}

/// The error-localisation kinds: `leverage`, `eigenvalue_sensitivity`.
pub mod leverage {
    pub use super::kinds::eigenvalue_sensitivity::*;
    pub use super::kinds::leverage::*;
}

/// The `modal_correlation` kind.
pub mod modal_correlation {
    pub use super::kinds::modal_correlation::*;
}

pub use table::{Column, Indices, Storage, Table, TableError};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Every artefact kind (its name, version, layout, writer and reader: [`kinds::Kind`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ArtefactKind {
    /// System matrices `K`, `M`, optional `C`, `D`, with their DOF labels.
    Matrices,
    /// Natural frequencies and mass-normalised mode shapes.
    Modes,
    /// Frequency response functions.
    Frf,
    /// FRF correlation: `χ_s`, `χ_a` per line, FRAC per FRF.
    Correlation,
    /// A figure as PNG and SVG.
    Plot,
    /// A finite-element model: nodes, elements, properties, constraints, sets, parameters.
    Mesh,
    /// An updating run: parameter history, correlation, diagnostics of `S`, final values.
    UpdateResult,
    /// Substructures of a model: their elements, junction and internal DOFs, boundaries.
    Partition,
    /// A component-mode-synthesis model: reduced `K`, `M`, transformations, derivatives.
    ReducedModel,
    /// One substructure's reduction: its basis `T`, `TᵀKT`, `TᵀMT` and coordinates.
    ReducedComponent,
    /// Two sets of modes compared: pairs by MAC, relative eigenvalue errors (3.54), COMAC.
    ModalCorrelation,
    /// Error localisation: the leverage (5.9) of every candidate parameter.
    Leverage,
    /// Eigenvalue sensitivities (5.3) of candidate parameters for chosen modes.
    EigenvalueSensitivity,
    /// A Nastran bulk data deck (its files) with the record of what was changed.
    NastranDeck,
    /// The Laplace posterior of an update's parameters: marginals, correlation, directions,
    /// samples, predictive bands.
    Posterior,
    /// Test points with their displacement frames and trace lines.
    TestGeometry,
    /// Measured DOFs as weighted sums of model DOFs, with the pairing of each test point.
    TestMap,
    /// A Universal File written for a lab's software: test points, FRFs, modes.
    UniversalFile,
    /// The samples of one TMCMC tempering stage, kept so that a stopped run resumes.
    TmcmcPopulation,
}

impl ArtefactKind {
    /// The name used in files and port declarations.
    pub fn name(self) -> &'static str {
        kinds::name_of(self)
    }

    /// Kind from its name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }

    /// Current schema version; bumped on any change of layout or meaning.
    pub fn schema_version(self) -> u32 {
        kinds::version_of(self)
    }
}

impl std::fmt::Display for ArtefactKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// File format of an artefact on disk.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Parquet for tables, Arrow IPC for matrices and shapes.
    #[default]
    Arrow,
    /// One HDF5 file (`hdf5` cargo feature).
    Hdf5,
}

/// An artefact in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Artefact {
    /// Its kind.
    pub kind: ArtefactKind,
    /// Metadata: units, quantity, summaries (a JSON object). Part of the digest.
    pub meta: serde_json::Map<String, serde_json::Value>,
    /// Named tables with their preferred storage.
    pub tables: BTreeMap<String, (Table, Storage)>,
    /// Named binary files (images).
    pub blobs: BTreeMap<String, Vec<u8>>,
}

/// Why an artefact could not be read, written or interpreted.
#[derive(Debug, thiserror::Error)]
pub enum ArtefactError {
    /// File system failure.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A file could not be decoded.
    #[error("{path}: {message}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The artefact is of another kind than expected.
    #[error("{path}: artefact is `{found}`, expected `{expected}`")]
    WrongKind {
        /// Its directory.
        path: PathBuf,
        /// Kind found.
        found: String,
        /// Kind wanted.
        expected: ArtefactKind,
    },
    /// The content does not fit the kind's schema.
    #[error("{kind} artefact: {message}")]
    Schema {
        /// The kind.
        kind: ArtefactKind,
        /// What is wrong, naming table, column, row or DOF.
        message: String,
    },
    /// The HDF5 format was chosen but femu was built without it.
    #[error(
        "`format: hdf5` needs femu built with the `hdf5` feature (cargo build --features hdf5; apt-get install -y libhdf5-dev)"
    )]
    Hdf5Unavailable,
}

impl ArtefactError {
    /// A schema error for `kind`.
    pub fn schema(kind: ArtefactKind, message: impl Into<String>) -> Self {
        ArtefactError::Schema {
            kind,
            message: message.into(),
        }
    }

    /// An I/O error at `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        ArtefactError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

impl From<TableError> for ArtefactError {
    fn from(e: TableError) -> Self {
        ArtefactError::Decode {
            path: PathBuf::from(&e.table),
            message: e.problem,
        }
    }
}

impl Artefact {
    /// An empty artefact of `kind`.
    pub fn new(kind: ArtefactKind) -> Self {
        Artefact {
            kind,
            meta: serde_json::Map::new(),
            tables: BTreeMap::new(),
            blobs: BTreeMap::new(),
        }
    }

    /// Adds a table.
    pub fn with_table(mut self, name: &str, table: Table, storage: Storage) -> Self {
        self.tables.insert(name.to_string(), (table, storage));
        self
    }

    /// Sets a metadata entry.
    pub fn with_meta(mut self, key: &str, value: serde_json::Value) -> Self {
        self.meta.insert(key.to_string(), value);
        self
    }

    /// A table by name, or a schema error naming what is there.
    pub fn table(&self, name: &str) -> Result<&Table, ArtefactError> {
        self.tables.get(name).map(|t| &t.0).ok_or_else(|| {
            ArtefactError::schema(
                self.kind,
                format!(
                    "no table `{name}` (tables: {})",
                    self.tables.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })
    }

    /// A metadata string.
    pub fn meta_str(&self, key: &str) -> Result<&str, ArtefactError> {
        self.meta.get(key).and_then(|v| v.as_str()).ok_or_else(|| {
            ArtefactError::schema(self.kind, format!("metadata `{key}` missing or not text"))
        })
    }

    /// Canonical content digest (hex).
    pub fn digest(&self) -> String {
        digest::artefact_digest(self)
    }
}
