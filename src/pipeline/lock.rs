//! Lock files: for every stage of a run, its kind, implementation version, key, wiring and
//! output digests (DVC's `dvc.lock` is the model). Written atomically; no times or hosts, so two
//! identical runs write identical lock files.

use super::executor::RunReport;
use super::plan::Plan;
use crate::cache::{Cache, CacheError, OutputRecord};
use std::collections::BTreeMap;
use std::path::Path;

/// Name of the lock file in an `--out` directory.
pub const OUT_LOCK_FILE: &str = "femu.lock.json";

/// One stage in a lock file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LockStage {
    /// Kind.
    pub kind: String,
    /// Implementation version.
    pub impl_version: u32,
    /// Cache key.
    pub key: String,
    /// Parameters with defaults.
    pub params: serde_json::Value,
    /// Input port → `stage.port`.
    pub inputs: BTreeMap<String, String>,
    /// Outputs.
    pub outputs: BTreeMap<String, OutputRecord>,
    /// Keys of the stage's parts cached on their own (substructure reductions).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parts: Vec<String>,
}

/// A lock file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LockFile {
    /// Pipeline name.
    pub pipeline: String,
    /// femu version.
    pub femu_version: String,
    /// Stages by name.
    pub stages: BTreeMap<String, LockStage>,
}

impl LockFile {
    /// The lock file of a run.
    pub fn from_run(plan: &Plan, report: &RunReport) -> Self {
        let stages = report
            .stages
            .iter()
            .filter_map(|r| {
                let node = &plan.nodes[plan.index(&r.name)?];
                Some((
                    r.name.clone(),
                    LockStage {
                        kind: r.kind.clone(),
                        impl_version: node.stage.impl_version(),
                        key: r.key.clone(),
                        params: node.params.clone(),
                        inputs: node
                            .inputs
                            .iter()
                            .map(|(p, i)| {
                                (p.clone(), format!("{}.{}", plan.nodes[i.node].name, i.port))
                            })
                            .collect(),
                        outputs: r.outputs.clone(),
                        parts: r.parts.keys.clone(),
                    },
                ))
            })
            .collect();
        LockFile {
            pipeline: plan.name.clone(),
            femu_version: env!("CARGO_PKG_VERSION").into(),
            stages,
        }
    }

    /// The lock file's text (pretty JSON and a final newline).
    pub fn to_text(&self) -> std::io::Result<String> {
        Ok(serde_json::to_string_pretty(self).map_err(std::io::Error::other)? + "\n")
    }

    /// Writes the lock file atomically.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        let text = self.to_text()?;
        let tmp = path.with_extension(format!("tmp.{}", std::process::id()));
        std::fs::write(&tmp, text)?;
        std::fs::rename(&tmp, path)
    }

    /// Records the run as `locks/<name>.lock.json` in `cache`, so `femu cache gc` keeps its
    /// entries. A read-only cache is left untouched: the warning to show is returned instead.
    /// A `name` that is not one plain file name is an error, whatever the cache.
    pub fn record_in(&self, cache: &Cache, name: &str) -> Result<Option<String>, CacheError> {
        let path = cache.lock_path(name)?;
        if let Some(reason) = cache.read_only() {
            return Ok(Some(format!(
                "the cache is read-only ({reason}): lock file {} was not written, so `femu cache gc` on this cache does not know this run",
                path.display()
            )));
        }
        let text = self.to_text().map_err(|source| CacheError::Io {
            path: path.clone(),
            source,
        })?;
        cache.write_lock(name, text.as_bytes())?;
        Ok(None)
    }
}
