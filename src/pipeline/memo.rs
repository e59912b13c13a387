//! Parts of a stage cached on their own. A stage whose work splits into independent units (the
//! substructures of a `reduce.*` stage) keys each unit by its content and keeps it as a cache
//! entry of its own: when the stage has to run again because one unit changed, the others come
//! from the cache. The stage's own entry lists its parts, so lock files (and `cache gc`) keep
//! them alive with it.

use super::stage::StageError;
use crate::artefact::{Artefact, ArtefactKind, Format};
use crate::cache::{Cache, Lookup, cache_key};
use std::collections::BTreeMap;
use std::sync::Mutex;

/// The name of the single output of a part's cache entry.
const PART_PORT: &str = "part";

/// How a stage's parts were obtained.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PartCounts {
    /// Taken from the cache.
    pub reused: usize,
    /// Computed (and committed).
    pub computed: usize,
    /// Cache keys of every part, sorted.
    pub keys: Vec<String>,
}

/// A stage's handle on the cache for its parts.
#[derive(Debug)]
pub struct PartCache {
    cache: Cache,
    format: Format,
    force: bool,
    record: Mutex<PartCounts>,
}

impl PartCache {
    /// Parts of one stage run, stored in `cache` as `format`; `force` recomputes every part.
    pub fn new(cache: Cache, format: Format, force: bool) -> Self {
        PartCache {
            cache,
            format,
            force,
            record: Mutex::new(PartCounts::default()),
        }
    }

    /// The part keyed by `(part_kind, impl_version, key)`, read from the cache or computed by
    /// `compute` and committed. `key` must hold everything the part depends on (content digests,
    /// settings); `part_kind` names the producer, e.g. `reduce.craig_bampton/component`.
    pub fn get_or_compute(
        &self,
        part_kind: &str,
        impl_version: u32,
        key: &serde_json::Value,
        kind: ArtefactKind,
        compute: impl FnOnce() -> Result<Artefact, StageError>,
    ) -> Result<Artefact, StageError> {
        let k = cache_key(part_kind, impl_version, key, self.format, &BTreeMap::new());
        let cache_err = |e: crate::cache::CacheError| {
            StageError::Failed(format!("cached part {part_kind} {k}: {e}"))
        };
        if !self.force
            && let Lookup::Hit(_) = self.cache.lookup(&k)
        {
            // A verified entry that fails to decode is evicted and recomputed like a corrupt one.
            match self.cache.read(&k, PART_PORT, kind) {
                Ok(a) => {
                    self.note(&k, true);
                    return Ok(a);
                }
                Err(_) => self.cache.evict(&k).map_err(cache_err)?,
            }
        }
        let a = compute()?;
        let outputs = BTreeMap::from([(PART_PORT.to_string(), a)]);
        if self.force {
            self.cache
                .recommit(&k, part_kind, impl_version, &outputs, self.format, &[])
        } else {
            self.cache
                .commit(&k, part_kind, impl_version, &outputs, self.format)
        }
        .map_err(cache_err)?;
        self.note(&k, false);
        outputs
            .into_values()
            .next()
            .ok_or_else(|| StageError::Failed("internal error: a part has one output".into()))
    }

    fn note(&self, key: &str, reused: bool) {
        if let Ok(mut r) = self.record.lock() {
            if reused {
                r.reused += 1;
            } else {
                r.computed += 1;
            }
            r.keys.push(key.to_string());
        }
    }

    /// What happened so far (keys sorted, each once).
    pub fn counts(&self) -> PartCounts {
        let mut c = self.record.lock().map(|r| r.clone()).unwrap_or_default();
        c.keys.sort();
        c.keys.dedup();
        c
    }
}
