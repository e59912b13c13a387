//! Content-addressed store of stage outputs.
//!
//! An entry is keyed by the blake3 hash of canonical JSON `{salt, kind, impl_version, params,
//! format, inputs}` (inputs: port → artefact digest) — never paths, hosts, times or thread counts.
//! Layout under the root:
//! ```text
//! entries/<key>/manifest.json       key, stage kind, outputs (kind, digest), file hashes
//! entries/<key>/<port>/…            one artefact directory per output port
//! tmp/                              work in progress, committed by one atomic rename
//! locks/<pipeline>.lock.json        the last run's keys and digests (per pipeline)
//! ```
//! A reader verifies every file hash before trusting an entry; a corrupt entry is reported,
//! evicted (renamed away atomically, then deleted) and recomputed. Two processes that compute the
//! same entry at once both succeed: the second rename finds the entry in place and is dropped.

use crate::artefact::codec::{read_dir, write_dir};
use crate::artefact::digest::{canonical_json, hash_bytes};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Format};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Salt of every key: changing it invalidates every cache.
pub const ENGINE_SALT: &str = concat!("femu-cache-v1-", env!("CARGO_PKG_VERSION"));

/// Errors of the store.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    /// File system failure.
    #[error("cache {path}: {source}")]
    Io {
        /// Path involved.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// An artefact could not be written or read.
    #[error(transparent)]
    Artefact(#[from] ArtefactError),
    /// An entry is damaged.
    #[error("cache entry {key} is corrupt: {reason}")]
    Corrupt {
        /// Entry key.
        key: String,
        /// What is wrong.
        reason: String,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> CacheError + '_ {
    move |source| CacheError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// What the manifest says of one output.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OutputRecord {
    /// Artefact kind name.
    pub kind: String,
    /// Content digest.
    pub digest: String,
}

/// The manifest of a committed entry.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Manifest {
    /// Entry key.
    pub key: String,
    /// Stage kind that produced it.
    pub stage_kind: String,
    /// Its implementation version.
    pub impl_version: u32,
    /// Outputs by port.
    pub outputs: BTreeMap<String, OutputRecord>,
    /// blake3 of every file, by path relative to the entry.
    pub files: BTreeMap<String, String>,
    /// Keys of the entry's parts, cached as entries of their own (see `pipeline::memo`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parts: Vec<String>,
}

/// Result of a lookup.
#[derive(Debug)]
pub enum Lookup {
    /// A verified entry.
    Hit(Manifest),
    /// No entry.
    Miss,
    /// An entry that failed verification (already evicted).
    Corrupt(String),
}

/// One entry as listed by `femu cache ls`.
#[derive(Clone, Debug)]
pub struct EntrySummary {
    /// Key.
    pub key: String,
    /// Stage kind.
    pub stage_kind: String,
    /// Output ports and kinds.
    pub outputs: Vec<(String, String)>,
    /// Bytes on disk.
    pub bytes: u64,
    /// Last modification.
    pub modified: Option<std::time::SystemTime>,
}

/// The store.
#[derive(Clone, Debug)]
pub struct Cache {
    root: PathBuf,
}

static TMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Computes a cache key.
pub fn cache_key(
    kind: &str,
    impl_version: u32,
    params: &serde_json::Value,
    format: Format,
    inputs: &BTreeMap<String, String>,
) -> String {
    let doc = serde_json::json!({
        "salt": ENGINE_SALT,
        "kind": kind,
        "impl_version": impl_version,
        "params": params,
        "format": format,
        "inputs": inputs,
    });
    hash_bytes(canonical_json(&doc).as_bytes())
}

impl Cache {
    /// Opens (creating) a store at `root`.
    pub fn open(root: &Path) -> Result<Cache, CacheError> {
        for sub in ["entries", "tmp", "locks"] {
            let p = root.join(sub);
            std::fs::create_dir_all(&p).map_err(io(&p))?;
        }
        Ok(Cache {
            root: root.to_path_buf(),
        })
    }

    /// Root directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    fn entry_dir(&self, key: &str) -> PathBuf {
        self.root.join("entries").join(key)
    }

    /// Directory of one output artefact of an entry.
    pub fn artefact_dir(&self, key: &str, port: &str) -> PathBuf {
        self.entry_dir(key).join(port)
    }

    /// Path of a pipeline's lock file.
    pub fn lock_path(&self, pipeline: &str) -> PathBuf {
        self.root
            .join("locks")
            .join(format!("{pipeline}.lock.json"))
    }

    fn read_manifest(&self, key: &str) -> Result<Manifest, String> {
        let path = self.entry_dir(key).join("manifest.json");
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("manifest unreadable: {e}"))?;
        serde_json::from_str(&text).map_err(|e| format!("manifest is not valid: {e}"))
    }

    fn verify(&self, key: &str) -> Result<Manifest, String> {
        let m = self.read_manifest(key)?;
        if m.key != key {
            return Err(format!("manifest names key {}", m.key));
        }
        let dir = self.entry_dir(key);
        for (rel, want) in &m.files {
            let bytes = std::fs::read(dir.join(rel)).map_err(|e| format!("{rel}: {e}"))?;
            if &hash_bytes(&bytes) != want {
                return Err(format!("{rel}: content does not match its recorded hash"));
            }
        }
        Ok(m)
    }

    /// Looks up and verifies an entry; a corrupt one is evicted and reported.
    pub fn lookup(&self, key: &str) -> Lookup {
        if !self.entry_dir(key).exists() {
            return Lookup::Miss;
        }
        match self.verify(key) {
            Ok(m) => Lookup::Hit(m),
            Err(reason) => {
                let _ = self.evict(key);
                Lookup::Corrupt(reason)
            }
        }
    }

    /// Removes an entry: an atomic rename out of `entries/`, then deletion.
    pub fn evict(&self, key: &str) -> Result<(), CacheError> {
        let dir = self.entry_dir(key);
        let trash = self.tmp_path(&format!("evict-{key}"));
        match std::fs::rename(&dir, &trash) {
            Ok(()) => std::fs::remove_dir_all(&trash).map_err(io(&trash)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(CacheError::Io {
                path: dir,
                source: e,
            }),
        }
    }

    fn tmp_path(&self, stem: &str) -> PathBuf {
        let n = TMP_COUNTER.fetch_add(1, Ordering::Relaxed);
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.subsec_nanos())
            .unwrap_or(0);
        self.root
            .join("tmp")
            .join(format!("{stem}.{}.{n}.{nanos}", std::process::id()))
    }

    /// Writes the outputs of a stage run and commits them under `key` atomically. Returns the
    /// manifest of the committed entry (another process's, if it committed first).
    pub fn commit(
        &self,
        key: &str,
        stage_kind: &str,
        impl_version: u32,
        outputs: &BTreeMap<String, Artefact>,
        format: Format,
    ) -> Result<Manifest, CacheError> {
        self.commit_with_parts(key, stage_kind, impl_version, outputs, format, &[])
    }

    /// [`Cache::commit`] for a stage whose parts are entries of their own (their keys are
    /// recorded in the manifest).
    pub fn commit_with_parts(
        &self,
        key: &str,
        stage_kind: &str,
        impl_version: u32,
        outputs: &BTreeMap<String, Artefact>,
        format: Format,
        parts: &[String],
    ) -> Result<Manifest, CacheError> {
        let tmp = self.tmp_path(key);
        std::fs::create_dir_all(&tmp).map_err(io(&tmp))?;
        let result = self.write_entry(&tmp, key, stage_kind, impl_version, outputs, format, parts);
        let manifest = match result {
            Ok(m) => m,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&tmp);
                return Err(e);
            }
        };
        let dest = self.entry_dir(key);
        match std::fs::rename(&tmp, &dest) {
            Ok(()) => Ok(manifest),
            Err(_) if dest.exists() => {
                // Someone committed the same key first (or a forced re-run): keep a verified
                // existing entry, replace a corrupt one.
                match self.verify(key) {
                    Ok(existing) => {
                        let _ = std::fs::remove_dir_all(&tmp);
                        Ok(existing)
                    }
                    Err(_) => {
                        self.evict(key)?;
                        std::fs::rename(&tmp, &dest).map_err(io(&dest))?;
                        Ok(manifest)
                    }
                }
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&tmp);
                Err(CacheError::Io {
                    path: dest,
                    source: e,
                })
            }
        }
    }

    /// Replaces an entry with freshly computed outputs (`--force`).
    pub fn recommit(
        &self,
        key: &str,
        stage_kind: &str,
        impl_version: u32,
        outputs: &BTreeMap<String, Artefact>,
        format: Format,
        parts: &[String],
    ) -> Result<Manifest, CacheError> {
        self.evict(key)?;
        self.commit_with_parts(key, stage_kind, impl_version, outputs, format, parts)
    }

    #[allow(clippy::too_many_arguments)]
    fn write_entry(
        &self,
        tmp: &Path,
        key: &str,
        stage_kind: &str,
        impl_version: u32,
        outputs: &BTreeMap<String, Artefact>,
        format: Format,
        parts: &[String],
    ) -> Result<Manifest, CacheError> {
        let mut records = BTreeMap::new();
        for (port, a) in outputs {
            let dir = tmp.join(port);
            std::fs::create_dir_all(&dir).map_err(io(&dir))?;
            let producer = serde_json::json!({"stage_kind": stage_kind, "impl_version": impl_version, "key": key, "port": port});
            let digest = write_dir(a, &dir, format, Some(producer))?;
            records.insert(
                port.clone(),
                OutputRecord {
                    kind: a.kind.name().to_string(),
                    digest,
                },
            );
        }
        let mut files = BTreeMap::new();
        hash_tree(tmp, tmp, &mut files)?;
        let manifest = Manifest {
            key: key.to_string(),
            stage_kind: stage_kind.to_string(),
            impl_version,
            outputs: records,
            files,
            parts: parts.to_vec(),
        };
        let path = tmp.join("manifest.json");
        let text = serde_json::to_string_pretty(&manifest).map_err(|e| CacheError::Corrupt {
            key: key.into(),
            reason: e.to_string(),
        })?;
        write_synced(&path, text.as_bytes())?;
        Ok(manifest)
    }

    /// Reads one output artefact of a verified entry.
    pub fn read(&self, key: &str, port: &str, kind: ArtefactKind) -> Result<Artefact, CacheError> {
        let a = read_dir(&self.artefact_dir(key, port))?;
        if a.kind != kind {
            return Err(CacheError::Corrupt {
                key: key.into(),
                reason: format!("port `{port}` holds `{}`, expected `{kind}`", a.kind),
            });
        }
        Ok(a)
    }

    /// Every committed entry.
    pub fn entries(&self) -> Result<Vec<EntrySummary>, CacheError> {
        let dir = self.root.join("entries");
        let mut out = Vec::new();
        for e in std::fs::read_dir(&dir).map_err(io(&dir))? {
            let e = e.map_err(io(&dir))?;
            let key = e.file_name().to_string_lossy().to_string();
            let (stage_kind, outputs) = match self.read_manifest(&key) {
                Ok(m) => (
                    m.stage_kind,
                    m.outputs.into_iter().map(|(p, r)| (p, r.kind)).collect(),
                ),
                Err(_) => ("<corrupt>".to_string(), vec![]),
            };
            out.push(EntrySummary {
                bytes: tree_size(&e.path()),
                modified: e.metadata().ok().and_then(|m| m.modified().ok()),
                key,
                stage_kind,
                outputs,
            });
        }
        out.sort_by(|a, b| a.key.cmp(&b.key));
        Ok(out)
    }

    /// Keys named by any lock file under `locks/`.
    pub fn locked_keys(&self) -> BTreeSet<String> {
        let mut keys = BTreeSet::new();
        let dir = self.root.join("locks");
        for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let Ok(text) = std::fs::read_to_string(e.path()) else {
                continue;
            };
            let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) else {
                continue;
            };
            if let Some(stages) = v.get("stages").and_then(|s| s.as_object()) {
                for s in stages.values() {
                    if let Some(k) = s.get("key").and_then(|k| k.as_str()) {
                        keys.insert(k.to_string());
                    }
                    let parts = s.get("parts").and_then(|p| p.as_array());
                    keys.extend(
                        parts
                            .into_iter()
                            .flatten()
                            .filter_map(|k| k.as_str().map(String::from)),
                    );
                }
            }
        }
        keys
    }

    /// Removes every entry not in `keep` and all leftovers in `tmp/`; returns (entries, bytes) freed.
    pub fn gc(&self, keep: &BTreeSet<String>) -> Result<(usize, u64), CacheError> {
        let (mut n, mut bytes) = (0, 0);
        for e in self.entries()? {
            if !keep.contains(&e.key) {
                self.evict(&e.key)?;
                n += 1;
                bytes += e.bytes;
            }
        }
        let tmp = self.root.join("tmp");
        for e in std::fs::read_dir(&tmp).map_err(io(&tmp))?.flatten() {
            // Only stale work: anything younger than an hour may belong to a running process.
            let old = e
                .metadata()
                .ok()
                .and_then(|m| m.modified().ok())
                .and_then(|t| t.elapsed().ok())
                .is_some_and(|d| d.as_secs() > 3600);
            if old {
                bytes += tree_size(&e.path());
                let _ = std::fs::remove_dir_all(e.path());
            }
        }
        Ok((n, bytes))
    }
}

fn write_synced(path: &Path, bytes: &[u8]) -> Result<(), CacheError> {
    use std::io::Write;
    let mut f = std::fs::File::create(path).map_err(io(path))?;
    f.write_all(bytes).map_err(io(path))?;
    f.sync_all().map_err(io(path))
}

fn hash_tree(
    base: &Path,
    dir: &Path,
    out: &mut BTreeMap<String, String>,
) -> Result<(), CacheError> {
    let mut entries: Vec<_> = std::fs::read_dir(dir).map_err(io(dir))?.flatten().collect();
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let p = e.path();
        if p.is_dir() {
            hash_tree(base, &p, out)?;
        } else {
            let bytes = std::fs::read(&p).map_err(io(&p))?;
            let rel = p
                .strip_prefix(base)
                .unwrap_or(&p)
                .to_string_lossy()
                .replace('\\', "/");
            out.insert(rel, hash_bytes(&bytes));
        }
    }
    Ok(())
}

fn tree_size(p: &Path) -> u64 {
    if p.is_dir() {
        std::fs::read_dir(p)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| tree_size(&e.path()))
            .sum()
    } else {
        p.metadata().map(|m| m.len()).unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::{Column, Storage, Table};

    fn outputs(v: f64) -> BTreeMap<String, Artefact> {
        let a = Artefact::new(ArtefactKind::Frf).with_table(
            "t",
            Table::new().with("x", Column::F64(vec![v])),
            Storage::Parquet,
        );
        BTreeMap::from([("frf".to_string(), a)])
    }

    #[test]
    fn commit_lookup_and_corruption() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        assert!(matches!(cache.lookup("k1"), Lookup::Miss));
        let m = cache
            .commit("k1", "test", 1, &outputs(1.0), Format::Arrow)
            .unwrap();
        assert!(matches!(cache.lookup("k1"), Lookup::Hit(ref h) if *h == m));
        // A second commit of the same key (another process) keeps the first.
        let again = cache
            .commit("k1", "test", 1, &outputs(1.0), Format::Arrow)
            .unwrap();
        assert_eq!(again, m);
        // Flip a byte in the data: detected, evicted.
        let f = cache.artefact_dir("k1", "frf").join("t.parquet");
        let mut bytes = std::fs::read(&f).unwrap();
        let mid = bytes.len() / 2;
        bytes[mid] ^= 0xff;
        std::fs::write(&f, bytes).unwrap();
        assert!(matches!(cache.lookup("k1"), Lookup::Corrupt(_)));
        assert!(matches!(cache.lookup("k1"), Lookup::Miss));
        assert!(
            std::fs::read_dir(dir.path().join("tmp"))
                .unwrap()
                .next()
                .is_none(),
            "nothing left half-written"
        );
    }

    #[test]
    fn keys_ignore_map_order_but_not_values() {
        let p1: serde_json::Value = serde_json::from_str(r#"{"a":1,"b":2}"#).unwrap();
        let p2: serde_json::Value = serde_json::from_str(r#"{"b":2,"a":1}"#).unwrap();
        let p3: serde_json::Value = serde_json::from_str(r#"{"b":2,"a":1.5}"#).unwrap();
        let none = BTreeMap::new();
        assert_eq!(
            cache_key("k", 1, &p1, Format::Arrow, &none),
            cache_key("k", 1, &p2, Format::Arrow, &none)
        );
        assert_ne!(
            cache_key("k", 1, &p1, Format::Arrow, &none),
            cache_key("k", 1, &p3, Format::Arrow, &none)
        );
        assert_ne!(
            cache_key("k", 1, &p1, Format::Arrow, &none),
            cache_key("k", 2, &p1, Format::Arrow, &none)
        );
    }

    #[test]
    fn gc_keeps_what_it_is_told() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        cache
            .commit("a", "t", 1, &outputs(1.0), Format::Arrow)
            .unwrap();
        cache
            .commit("b", "t", 1, &outputs(2.0), Format::Arrow)
            .unwrap();
        let (n, _) = cache.gc(&BTreeSet::from(["a".to_string()])).unwrap();
        assert_eq!(n, 1);
        assert_eq!(cache.entries().unwrap().len(), 1);
    }
}
