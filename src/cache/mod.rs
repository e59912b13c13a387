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
//! A reader verifies every file hash, and that each output's `meta.json` names this entry, port
//! and kind as its producer, before trusting an entry; a corrupt entry is reported, evicted
//! (renamed away atomically, then deleted) and recomputed. Two processes that compute the same
//! entry at once both succeed: the second rename finds the entry in place and is dropped.
//!
//! Names from users or from disk (pipeline, port, file names) are joined to the root only when
//! they are one plain path component ([`names`]). Temporaries carry their process and host
//! ([`owner`]); opening a cache removes those of dead processes. A cache that cannot be written
//! (read-only file system, no permission) still serves hits: [`Cache::read_only`] says why.

pub mod names;
pub mod owner;

use crate::artefact::codec::{read_dir, read_meta, write_dir_digested, write_dir_hashed};
use crate::artefact::digest::{canonical_json, hash_bytes, hash_file};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Format};
use rayon::prelude::*;
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
    /// A name that would become a path is not one plain path component.
    #[error("{what} `{name}` cannot name a file under {root}: {reason}; a valid name is {valid}", valid = names::VALID_NAME)]
    UnsafeName {
        /// What the name names (pipeline, port, key).
        what: &'static str,
        /// The name.
        name: String,
        /// The directory it would be joined to.
        root: PathBuf,
        /// Why it is refused.
        reason: &'static str,
    },
    /// The cache cannot be written.
    #[error(
        "cache {root} is read-only ({reason}); cached results can be read but nothing can be stored: use a writable --cache-dir to compute"
    )]
    ReadOnly {
        /// Cache root.
        root: PathBuf,
        /// Why it is read-only.
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

/// An entry being written: its key, producer, format, parts and outputs.
struct NewEntry<'a> {
    key: &'a str,
    stage_kind: &'a str,
    impl_version: u32,
    format: Format,
    parts: &'a [String],
    outputs: Vec<EntryOutput<'a>>,
}

/// One output of an entry being written: its port, the artefact and, when known, its digest.
#[derive(Clone, Copy)]
struct EntryOutput<'a> {
    port: &'a str,
    artefact: &'a Artefact,
    digest: Option<&'a str>,
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
    /// Why the store cannot be written, when it cannot.
    read_only: Option<String>,
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
    /// Opens (creating) a store at `root`, and removes the temporaries of dead processes. A store
    /// whose `entries/` exists but that cannot be written (the first write fails) opens
    /// read-only: hits are served, commits fail with [`CacheError::ReadOnly`].
    pub fn open(root: &Path) -> Result<Cache, CacheError> {
        let mut cache = Cache {
            root: root.to_path_buf(),
            read_only: None,
        };
        match cache.prepare() {
            Ok(()) => {
                cache.remove_stale_temporaries();
                Ok(cache)
            }
            Err(e) if root.join("entries").is_dir() => {
                cache.read_only = Some(e.to_string());
                Ok(cache)
            }
            Err(e) => Err(e),
        }
    }

    /// Opens an existing store without ever writing to it (a shared, read-only cache).
    pub fn open_read_only(root: &Path) -> Result<Cache, CacheError> {
        let entries = root.join("entries");
        if !entries.is_dir() {
            return Err(CacheError::Io {
                path: entries,
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "no cache here (a read-only cache must already hold `entries/`)",
                ),
            });
        }
        Ok(Cache {
            root: root.to_path_buf(),
            read_only: Some("opened read-only".into()),
        })
    }

    /// Creates the layout and proves that `tmp/` takes a new file.
    fn prepare(&self) -> Result<(), CacheError> {
        for sub in ["entries", "tmp", "locks"] {
            let p = self.root.join(sub);
            std::fs::create_dir_all(&p).map_err(io(&p))?;
        }
        let probe = self.tmp_path("probe");
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&probe)
            .map_err(io(&probe))?;
        std::fs::remove_file(&probe).map_err(io(&probe))
    }

    /// Root directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Why the store cannot be written, or `None` when it can.
    pub fn read_only(&self) -> Option<&str> {
        self.read_only.as_deref()
    }

    /// Whether entries can be committed: [`CacheError::ReadOnly`] says why not.
    pub fn writable(&self) -> Result<(), CacheError> {
        match &self.read_only {
            None => Ok(()),
            Some(reason) => Err(CacheError::ReadOnly {
                root: self.root.clone(),
                reason: reason.clone(),
            }),
        }
    }

    /// `base/name` when `name` is one plain path component, else an error naming both.
    fn join_checked(base: &Path, what: &'static str, name: &str) -> Result<PathBuf, CacheError> {
        match names::unsafe_reason(name) {
            None => Ok(base.join(name)),
            Some(reason) => Err(CacheError::UnsafeName {
                what,
                name: name.to_string(),
                root: base.to_path_buf(),
                reason,
            }),
        }
    }

    fn entry_dir(&self, key: &str) -> Result<PathBuf, CacheError> {
        Self::join_checked(&self.root.join("entries"), "cache key", key)
    }

    /// Directory of one output artefact of an entry; an error if the key or port is not a
    /// plain name.
    pub fn artefact_dir(&self, key: &str, port: &str) -> Result<PathBuf, CacheError> {
        Self::join_checked(&self.entry_dir(key)?, "output port", port)
    }

    /// Path of a pipeline's lock file; an error if `pipeline` is not a plain name (it must not
    /// reach outside `locks/`).
    pub fn lock_path(&self, pipeline: &str) -> Result<PathBuf, CacheError> {
        let locks = self.root.join("locks");
        Self::join_checked(&locks, "pipeline name", pipeline)?;
        Ok(locks.join(format!("{pipeline}.lock.json")))
    }

    /// Writes `text` as the lock file of `pipeline`: into `tmp/` (so a killed writer's leftover
    /// is found by [`Cache::remove_stale_temporaries`]), then renamed into `locks/`.
    pub fn write_lock(&self, pipeline: &str, text: &[u8]) -> Result<PathBuf, CacheError> {
        let path = self.lock_path(pipeline)?;
        self.writable()?;
        let tmp = self.tmp_path("lock");
        if let Err(e) = write_synced(&tmp, text) {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        std::fs::rename(&tmp, &path).map_err(|source| {
            let _ = std::fs::remove_file(&tmp);
            CacheError::Io {
                path: path.clone(),
                source,
            }
        })?;
        Ok(path)
    }

    fn read_manifest(&self, key: &str) -> Result<Manifest, String> {
        let path = self
            .entry_dir(key)
            .map_err(|e| e.to_string())?
            .join("manifest.json");
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("manifest unreadable: {e}"))?;
        serde_json::from_str(&text).map_err(|e| format!("manifest is not valid: {e}"))
    }

    fn verify(&self, key: &str) -> Result<Manifest, String> {
        let m = self.read_manifest(key)?;
        if m.key != key {
            return Err(format!("manifest names key {}", m.key));
        }
        let dir = self.entry_dir(key).map_err(|e| e.to_string())?;
        for rel in m.files.keys() {
            if let Some(why) = names::unsafe_relative_reason(rel) {
                return Err(format!("manifest lists file `{rel}`: {why}"));
            }
        }
        // Every file checked in parallel; the first failure in the manifest's order is reported.
        let failures: Vec<String> = m
            .files
            .par_iter()
            .filter_map(|(rel, want)| {
                let path = dir.join(rel);
                let check = || -> Result<(), String> {
                    let meta =
                        std::fs::symlink_metadata(&path).map_err(|e| format!("{rel}: {e}"))?;
                    if !meta.is_file() {
                        return Err(format!("{rel}: not a regular file"));
                    }
                    if &hash_file(&path).map_err(|e| format!("{rel}: {e}"))? != want {
                        return Err(format!("{rel}: content does not match its recorded hash"));
                    }
                    Ok(())
                };
                check().err()
            })
            .collect();
        if let Some(first) = failures.into_iter().next() {
            return Err(first);
        }
        for (port, record) in &m.outputs {
            self.check_producer(key, &m.stage_kind, port, &record.kind, Some(&record.digest))?;
        }
        Ok(m)
    }

    /// Checks that the `meta.json` of output `port` names this entry as its producer: its key,
    /// stage kind and port, its artefact kind and (when known) its digest. Files copied from
    /// another entry, even with consistent hashes, fail here.
    fn check_producer(
        &self,
        key: &str,
        stage_kind: &str,
        port: &str,
        kind: &str,
        digest: Option<&str>,
    ) -> Result<(), String> {
        let dir = self.artefact_dir(key, port).map_err(|e| e.to_string())?;
        let meta = read_meta(&dir).map_err(|e| e.to_string())?;
        if meta.kind.name() != kind {
            return Err(format!(
                "port `{port}` holds a `{}` artefact, the manifest says `{kind}`",
                meta.kind
            ));
        }
        if let Some(d) = digest.filter(|d| **d != meta.digest) {
            return Err(format!(
                "port `{port}`: meta.json records digest {}, the manifest {d}",
                meta.digest
            ));
        }
        let producer = meta.raw.get("producer");
        let field = |name: &str| producer.and_then(|p| p.get(name)).and_then(|v| v.as_str());
        for (name, want) in [("key", key), ("port", port), ("stage_kind", stage_kind)] {
            match field(name) {
                Some(got) if got == want => {}
                got => {
                    return Err(format!(
                        "port `{port}`: meta.json names producer {name} {}, not this entry's {want}",
                        got.unwrap_or("<none>")
                    ));
                }
            }
        }
        Ok(())
    }

    /// Looks up and verifies an entry; a corrupt one is evicted and reported.
    pub fn lookup(&self, key: &str) -> Lookup {
        match self.entry_dir(key) {
            Ok(dir) if !dir.exists() => return Lookup::Miss,
            Ok(_) => {}
            Err(e) => return Lookup::Corrupt(e.to_string()),
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
        self.writable()?;
        let dir = self.entry_dir(key)?;
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

    /// A fresh name in `tmp/`: `<stem>.<n>.<nanos>.<pid>@<host>` (see [`owner`]).
    fn tmp_path(&self, stem: &str) -> PathBuf {
        let n = TMP_COUNTER.fetch_add(1, Ordering::Relaxed);
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.subsec_nanos())
            .unwrap_or(0);
        let owner = owner::owner_suffix(std::process::id());
        self.root
            .join("tmp")
            .join(format!("{stem}.{n}.{nanos}.{owner}"))
    }

    /// Removes the temporaries in `tmp/` of processes of this host that have died (killed in
    /// the middle of a commit or an eviction); returns the bytes freed. Live processes' work and
    /// other hosts' work are left alone; failures are ignored (the next open or `gc` retries).
    pub fn remove_stale_temporaries(&self) -> u64 {
        if self.read_only.is_some() {
            return 0;
        }
        let tmp = self.root.join("tmp");
        let mut freed = 0;
        for e in std::fs::read_dir(&tmp).into_iter().flatten().flatten() {
            if !owner::is_stale(&e.file_name().to_string_lossy()) {
                continue;
            }
            let size = tree_size(&e.path());
            if remove_any(&e.path()).is_ok() {
                freed += size;
            }
        }
        freed
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
        self.commit_entry(&NewEntry {
            key,
            stage_kind,
            impl_version,
            format,
            parts,
            outputs: outputs
                .iter()
                .map(|(port, artefact)| EntryOutput {
                    port,
                    artefact,
                    digest: None,
                })
                .collect(),
        })
    }

    /// [`Cache::commit_with_parts`] for outputs whose content digests are already known (the
    /// pipeline computes them first, for the keys of the stages downstream, and commits in the
    /// background): each `(port, artefact, digest)` is written with its digest recorded, not
    /// computed again.
    pub fn commit_digested(
        &self,
        key: &str,
        stage_kind: &str,
        impl_version: u32,
        outputs: &[(&str, &Artefact, &str)],
        format: Format,
        parts: &[String],
    ) -> Result<Manifest, CacheError> {
        self.commit_entry(&NewEntry {
            key,
            stage_kind,
            impl_version,
            format,
            parts,
            outputs: outputs
                .iter()
                .map(|&(port, artefact, digest)| EntryOutput {
                    port,
                    artefact,
                    digest: Some(digest),
                })
                .collect(),
        })
    }

    /// Writes `entry` into a temporary directory and renames it to the entry of its key.
    fn commit_entry(&self, entry: &NewEntry<'_>) -> Result<Manifest, CacheError> {
        let key = entry.key;
        self.writable()?;
        let dest = self.entry_dir(key)?;
        let tmp = self.tmp_path(key);
        std::fs::create_dir_all(&tmp).map_err(io(&tmp))?;
        let result = self.write_entry(&tmp, entry);
        let manifest = match result {
            Ok(m) => m,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&tmp);
                return Err(e);
            }
        };
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

    fn write_entry(&self, tmp: &Path, entry: &NewEntry<'_>) -> Result<Manifest, CacheError> {
        let NewEntry {
            key,
            stage_kind,
            impl_version,
            format,
            parts,
            ref outputs,
        } = *entry;
        let mut records = BTreeMap::new();
        // Files hashed as they were written, by path relative to the entry.
        let mut written = BTreeMap::new();
        for &EntryOutput {
            port,
            artefact: a,
            digest,
        } in outputs
        {
            let dir = Self::join_checked(tmp, "output port", port)?;
            std::fs::create_dir_all(&dir).map_err(io(&dir))?;
            let producer = serde_json::json!({"stage_kind": stage_kind, "impl_version": impl_version, "key": key, "port": port});
            let (digest, hashes) = match digest {
                Some(d) => write_dir_digested(a, &dir, format, Some(producer), d)?,
                None => write_dir_hashed(a, &dir, format, Some(producer))?,
            };
            written.extend(
                hashes
                    .into_iter()
                    .map(|(file, hash)| (format!("{port}/{file}"), hash)),
            );
            records.insert(
                port.to_string(),
                OutputRecord {
                    kind: a.kind.name().to_string(),
                    digest,
                },
            );
        }
        let mut files = BTreeMap::new();
        hash_tree_reusing(tmp, tmp, &written, &mut files)?;
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

    /// Reads one output artefact of a verified entry. An output whose `meta.json` names
    /// another producer, or of another kind, is corrupt: the entry is evicted.
    pub fn read(&self, key: &str, port: &str, kind: ArtefactKind) -> Result<Artefact, CacheError> {
        let a = read_dir(&self.artefact_dir(key, port)?)?;
        let check = if a.kind != kind {
            Err(format!(
                "port `{port}` holds `{}`, expected `{kind}`",
                a.kind
            ))
        } else {
            self.read_manifest(key).and_then(|m| {
                let digest = m.outputs.get(port).map(|r| r.digest.as_str());
                self.check_producer(key, &m.stage_kind, port, kind.name(), digest)
            })
        };
        match check {
            Ok(()) => Ok(a),
            Err(reason) => {
                if self.read_only.is_none() {
                    let _ = self.evict(key);
                }
                Err(CacheError::Corrupt {
                    key: key.into(),
                    reason,
                })
            }
        }
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
        self.writable()?;
        let (mut n, mut bytes) = (0, 0);
        for e in self.entries()? {
            if !keep.contains(&e.key) {
                self.evict(&e.key)?;
                n += 1;
                bytes += e.bytes;
            }
        }
        bytes += self.remove_stale_temporaries();
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
                let _ = remove_any(&e.path());
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

/// The hash of every file under `dir`, keyed by its path relative to `base`, read and hashed
/// in parallel (an entry's matrices are hundreds of megabytes at 10⁵–10⁶ DOFs), except that a
/// file listed in `known` (by relative path: hashed as it was written) is not read back. The
/// listing still decides which files there are, so a file written by other means is hashed,
/// not left out of the manifest.
fn hash_tree_reusing(
    base: &Path,
    dir: &Path,
    known: &BTreeMap<String, String>,
    out: &mut BTreeMap<String, String>,
) -> Result<(), CacheError> {
    let mut files = Vec::new();
    list_files(dir, &mut files)?;
    let hashed: Vec<(String, String)> = files
        .par_iter()
        .map(|p| {
            let rel = p
                .strip_prefix(base)
                .unwrap_or(p)
                .to_string_lossy()
                .replace('\\', "/");
            let hash = match known.get(&rel) {
                Some(hash) => hash.clone(),
                None => hash_file(p).map_err(io(p))?,
            };
            Ok((rel, hash))
        })
        .collect::<Result<_, CacheError>>()?;
    out.extend(hashed);
    Ok(())
}

fn list_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), CacheError> {
    let mut entries: Vec<_> = std::fs::read_dir(dir).map_err(io(dir))?.flatten().collect();
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let p = e.path();
        if p.is_dir() {
            list_files(&p, out)?;
        } else {
            out.push(p);
        }
    }
    Ok(())
}

/// Removes a file, a link (never its target) or a directory tree.
fn remove_any(p: &Path) -> std::io::Result<()> {
    if std::fs::symlink_metadata(p)?.is_dir() {
        std::fs::remove_dir_all(p)
    } else {
        std::fs::remove_file(p)
    }
}

fn tree_size(p: &Path) -> u64 {
    if std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir()) {
        std::fs::read_dir(p)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| tree_size(&e.path()))
            .sum()
    } else {
        std::fs::symlink_metadata(p).map(|m| m.len()).unwrap_or(0)
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
        let f = cache.artefact_dir("k1", "frf").unwrap().join("t.parquet");
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

    /// Copies `from`'s output over `to`'s with every hash made consistent.
    fn forge(cache: &Cache, from: &str, to: &str) {
        let (src, dst) = (
            cache.artefact_dir(from, "frf").unwrap(),
            cache.artefact_dir(to, "frf").unwrap(),
        );
        std::fs::remove_dir_all(&dst).unwrap();
        std::fs::create_dir(&dst).unwrap();
        for f in std::fs::read_dir(&src).unwrap().flatten() {
            std::fs::copy(f.path(), dst.join(f.file_name())).unwrap();
        }
        let donor = cache.read_manifest(from).unwrap();
        let mut m = cache.read_manifest(to).unwrap();
        m.outputs = donor.outputs.clone();
        m.files.clear();
        let dir = cache.entry_dir(to).unwrap();
        hash_tree_reusing(&dir, &dir, &BTreeMap::new(), &mut m.files).unwrap();
        m.files.remove("manifest.json");
        std::fs::write(
            dir.join("manifest.json"),
            serde_json::to_string_pretty(&m).unwrap(),
        )
        .unwrap();
    }

    #[test]
    fn an_entry_copied_from_another_with_consistent_hashes_is_corrupt() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        cache
            .commit("ka", "t", 1, &outputs(1.0), Format::Arrow)
            .unwrap();
        cache
            .commit("kb", "t", 1, &outputs(2.0), Format::Arrow)
            .unwrap();
        forge(&cache, "kb", "ka");
        match cache.lookup("ka") {
            Lookup::Corrupt(reason) => {
                assert!(reason.contains("producer key kb"), "{reason}")
            }
            other => panic!("a forged entry was accepted: {other:?}"),
        }
        assert!(matches!(cache.lookup("ka"), Lookup::Miss), "evicted");
        // Forged after a verified lookup: the read itself refuses and evicts.
        cache
            .commit("ka", "t", 1, &outputs(1.0), Format::Arrow)
            .unwrap();
        assert!(matches!(cache.lookup("ka"), Lookup::Hit(_)));
        forge(&cache, "kb", "ka");
        let e = cache.read("ka", "frf", ArtefactKind::Frf).unwrap_err();
        assert!(matches!(e, CacheError::Corrupt { .. }), "{e}");
        assert!(matches!(cache.lookup("ka"), Lookup::Miss), "evicted");
        // The untouched donor is fine.
        assert!(cache.read("kb", "frf", ArtefactKind::Frf).is_ok());
    }

    #[test]
    fn names_from_disk_or_users_never_leave_the_root() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        for bad in ["../x", "/etc", "a/b", ".."] {
            assert!(cache.lock_path(bad).is_err(), "{bad}");
            assert!(cache.artefact_dir(bad, "frf").is_err(), "{bad}");
            assert!(cache.artefact_dir("k", bad).is_err(), "{bad}");
        }
        // A manifest that lists a file outside its entry is corrupt, and nothing is read there.
        let m = cache
            .commit("k", "t", 1, &outputs(1.0), Format::Arrow)
            .unwrap();
        let mut forged = m.clone();
        forged
            .files
            .insert("../../outside".into(), hash_bytes(b"secret"));
        std::fs::write(dir.path().join("outside"), b"secret").unwrap();
        std::fs::write(
            cache.entry_dir("k").unwrap().join("manifest.json"),
            serde_json::to_string(&forged).unwrap(),
        )
        .unwrap();
        assert!(matches!(cache.lookup("k"), Lookup::Corrupt(ref r) if r.contains("../../outside")),);
    }

    #[test]
    fn a_cache_that_cannot_be_written_opens_read_only() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        assert_eq!(cache.read_only(), None);
        cache
            .commit("k", "t", 1, &outputs(1.0), Format::Arrow)
            .unwrap();
        // `tmp` a file: the first write fails (whatever the user's privileges).
        std::fs::remove_dir_all(dir.path().join("tmp")).unwrap();
        std::fs::write(dir.path().join("tmp"), b"").unwrap();
        let ro = Cache::open(dir.path()).unwrap();
        assert!(ro.read_only().is_some_and(|r| r.contains("tmp")), "{ro:?}");
        assert!(matches!(ro.lookup("k"), Lookup::Hit(_)));
        assert!(ro.read("k", "frf", ArtefactKind::Frf).is_ok());
        let e = ro
            .commit("k2", "t", 1, &outputs(2.0), Format::Arrow)
            .unwrap_err();
        assert!(matches!(e, CacheError::ReadOnly { .. }), "{e}");
        assert!(matches!(ro.evict("k"), Err(CacheError::ReadOnly { .. })));
        assert!(ro.gc(&BTreeSet::new()).is_err());
        assert!(matches!(ro.lookup("k"), Lookup::Hit(_)), "still there");
        // No cache at all is an error, not an empty read-only one.
        let none = tempfile::tempdir().unwrap();
        assert!(Cache::open_read_only(none.path()).is_err());
    }

    #[test]
    fn open_removes_dead_processes_temporaries_only() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        let dead = owner::exited_child_pid();
        let tmp = dir.path().join("tmp");
        let dead_dir = tmp.join(format!("k.0.0.{}", owner::owner_suffix(dead)));
        let dead_file = tmp.join(format!("probe.0.0.{}", owner::owner_suffix(dead)));
        std::fs::create_dir_all(dead_dir.join("frf")).unwrap();
        std::fs::write(dead_dir.join("frf/x"), vec![1u8; 1000]).unwrap();
        std::fs::write(&dead_file, b"").unwrap();
        let live = cache.tmp_path("k");
        std::fs::create_dir_all(&live).unwrap();
        assert!(cache.remove_stale_temporaries() >= 1000);
        assert!(!dead_dir.exists() && !dead_file.exists());
        assert!(live.exists());
    }
}
