//! The `nastran_deck` kind: a Nastran bulk data deck as files (the top file and every file it
//! INCLUDEs, side by side under plain names), with the record of what was changed.

use super::{Kind, Layout, expect_kind, meta};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind};
use crate::model::export::deck_update::DeckChange;

/// A written deck.
#[derive(Clone, Debug, PartialEq)]
pub struct NastranDeck {
    /// The files, top file first: plain name and bytes.
    pub files: Vec<(String, Vec<u8>)>,
    /// What was changed relative to the user's deck (empty for a deck written afresh).
    pub changes: Vec<DeckChange>,
    /// Where the values came from (e.g. the update result's digest), for the record.
    pub source: String,
}

/// The `nastran_deck` kind.
pub struct NastranDeckKind;

impl Kind for NastranDeckKind {
    const KIND: ArtefactKind = ArtefactKind::NastranDeck;
    const NAME: &'static str = "nastran_deck";
    type Value = NastranDeck;

    fn layout() -> Layout {
        Layout {
            tables: vec![],
            meta: vec![
                meta("files", "the deck's files in order, the top file first"),
                meta(
                    "changes",
                    "each changed field or added card: file, line, card, field, old and new text",
                ),
                meta("source", "what the written values come from"),
            ],
            blobs: vec!["{file}"],
        }
    }

    fn to_artefact(d: &NastranDeck) -> Artefact {
        let names: Vec<&str> = d.files.iter().map(|(n, _)| n.as_str()).collect();
        let mut a = Artefact::new(Self::KIND)
            .with_meta("files", serde_json::to_value(names).unwrap_or_default())
            .with_meta(
                "changes",
                serde_json::to_value(&d.changes).unwrap_or_default(),
            )
            .with_meta("source", d.source.as_str().into());
        for (name, bytes) in &d.files {
            a.blobs.insert(name.clone(), bytes.clone());
        }
        a
    }

    fn from_artefact(a: &Artefact) -> Result<NastranDeck, ArtefactError> {
        expect_kind(a, Self::KIND)?;
        let bad = |m: String| ArtefactError::schema(Self::KIND, m);
        let names: Vec<String> = serde_json::from_value(
            a.meta
                .get("files")
                .cloned()
                .ok_or_else(|| bad("no `files` in the metadata".into()))?,
        )
        .map_err(|e| bad(format!("`files`: {e}")))?;
        let changes: Vec<DeckChange> = serde_json::from_value(
            a.meta
                .get("changes")
                .cloned()
                .ok_or_else(|| bad("no `changes` in the metadata".into()))?,
        )
        .map_err(|e| bad(format!("`changes`: {e}")))?;
        let files = names
            .into_iter()
            .map(|n| {
                let bytes = a
                    .blobs
                    .get(&n)
                    .cloned()
                    .ok_or_else(|| bad(format!("file `{n}` is listed but not stored")))?;
                Ok((n, bytes))
            })
            .collect::<Result<_, ArtefactError>>()?;
        Ok(NastranDeck {
            files,
            changes,
            source: a.meta_str("source")?.to_string(),
        })
    }
}
