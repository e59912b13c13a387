//! The `universal_file` kind: a Universal File written for a lab's own software (test points,
//! predicted FRFs, modes at the test DOFs), with the count of each dataset in it.

use super::{Kind, Layout, expect_kind, meta};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind};

/// A written Universal File.
#[derive(Clone, Debug, PartialEq)]
pub struct UniversalFile {
    /// Plain file name.
    pub name: String,
    /// Its bytes.
    pub bytes: Vec<u8>,
    /// `(dataset number, records)` in the order written.
    pub datasets: Vec<(u32, usize)>,
    /// What the values come from.
    pub source: String,
}

/// The `universal_file` kind.
pub struct UniversalFileKind;

impl Kind for UniversalFileKind {
    const KIND: ArtefactKind = ArtefactKind::UniversalFile;
    const NAME: &'static str = "universal_file";
    type Value = UniversalFile;

    fn layout() -> Layout {
        Layout {
            tables: vec![],
            meta: vec![
                meta("file", "the file's plain name"),
                meta("datasets", "[dataset number, records] in the order written"),
                meta("source", "what the written values come from"),
            ],
            blobs: vec!["{file}"],
        }
    }

    fn to_artefact(f: &UniversalFile) -> Artefact {
        let mut a = Artefact::new(Self::KIND)
            .with_meta("file", f.name.as_str().into())
            .with_meta(
                "datasets",
                serde_json::to_value(&f.datasets).unwrap_or_default(),
            )
            .with_meta("source", f.source.as_str().into());
        a.blobs.insert(f.name.clone(), f.bytes.clone());
        a
    }

    fn from_artefact(a: &Artefact) -> Result<UniversalFile, ArtefactError> {
        expect_kind(a, Self::KIND)?;
        let bad = |m: String| ArtefactError::schema(Self::KIND, m);
        let name = a.meta_str("file")?.to_string();
        let datasets: Vec<(u32, usize)> = serde_json::from_value(
            a.meta
                .get("datasets")
                .cloned()
                .ok_or_else(|| bad("no `datasets` in the metadata".into()))?,
        )
        .map_err(|e| bad(format!("`datasets`: {e}")))?;
        let bytes = a
            .blobs
            .get(&name)
            .cloned()
            .ok_or_else(|| bad(format!("file `{name}` is listed but not stored")))?;
        Ok(UniversalFile {
            name,
            bytes,
            datasets,
            source: a.meta_str("source")?.to_string(),
        })
    }
}
