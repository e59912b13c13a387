//! A deck as written: its files' bytes, its cards with the physical lines that hold them, and
//! its INCLUDE statements — what [`crate::model::export::deck_update`] needs to change a few
//! cards of a user's deck and leave every other byte as it was.

use super::*;

/// One file of a deck: its name as in messages (the path it was opened by) and its bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct DeckFile {
    /// Path as opened (relative INCLUDEs joined to the including file's folder).
    pub name: String,
    /// The bytes read.
    pub bytes: Vec<u8>,
}

/// One data field of a card: its text (trimmed) and the file line that holds it (1-based).
#[derive(Clone, Debug, PartialEq)]
pub struct DeckField {
    /// The field's text, trimmed; empty when blank.
    pub text: String,
    /// Line in the card's file.
    pub line: usize,
}

/// One card: name, file, first line and data fields in QRG order (`fields[k - 1]` is field `k`).
#[derive(Clone, Debug, PartialEq)]
pub struct DeckCard {
    /// Card name, upper case, without the large-field `*`.
    pub name: String,
    /// Index into [`Deck::files`].
    pub file: usize,
    /// Line of the card's first line.
    pub line: usize,
    /// Data fields.
    pub fields: Vec<DeckField>,
}

impl DeckCard {
    /// Field `k` (1-based QRG numbering), blank when beyond the card.
    pub fn field(&self, k: usize) -> &str {
        k.checked_sub(1)
            .and_then(|i| self.fields.get(i))
            .map_or("", |f| f.text.as_str())
    }

    /// The physical lines that hold the card, ascending.
    pub fn lines(&self) -> Vec<usize> {
        let mut lines: Vec<usize> = std::iter::once(self.line)
            .chain(self.fields.iter().map(|f| f.line))
            .collect();
        lines.sort_unstable();
        lines.dedup();
        lines
    }
}

/// An INCLUDE statement: where it is and which file it reads.
#[derive(Clone, Debug, PartialEq)]
pub struct DeckInclude {
    /// Index into [`Deck::files`] of the including file.
    pub file: usize,
    /// First line of the statement.
    pub first_line: usize,
    /// Last line (a quoted name may run over several lines).
    pub last_line: usize,
    /// Index into [`Deck::files`] of the included file.
    pub target: usize,
}

/// A deck's files, cards and INCLUDEs; `files[0]` is the top file.
#[derive(Clone, Debug, PartialEq)]
pub struct Deck {
    /// The files, the top file first, then INCLUDEs in reading order (each once).
    pub files: Vec<DeckFile>,
    /// Bulk data cards in reading order.
    pub cards: Vec<DeckCard>,
    /// INCLUDE statements.
    pub includes: Vec<DeckInclude>,
    /// blake3 of the bytes of every file, as [`BulkImport::source_digest`].
    pub source_digest: String,
}

/// Reads a deck's files and cards under the process-wide input policy, with the same lexing as
/// [`read_bulk`] (so the same files, lines and syntax errors), without building a model.
pub fn read_deck(path: impl AsRef<Path>) -> Result<Deck, NastranError> {
    let path = path.as_ref();
    let io = |e: InputError| NastranError::Io {
        path: path.display().to_string().into(),
        message: e.to_string().into(),
    };
    let policy = crate::core::input::policy().map_err(io)?;
    let bytes = read_input_with(path, &policy, policy.max_bytes).map_err(io)?;
    let file_name = path.display().to_string();
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut loader = Loader {
        policy,
        used: bytes.len() as u64,
        job_dir: dir.clone(),
        keep: true,
        ..Loader::default()
    };
    loader.digest_source(&bytes);
    loader
        .stack
        .push(std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()));
    let text = String::from_utf8_lossy(&bytes).into_owned();
    let top: Rc<str> = Rc::from(file_name.as_str());
    loader.load(&text, top.clone(), &dir, true)?;
    let cards = assemble(&loader.lines, &mut loader.warnings)?;

    let mut files = vec![DeckFile {
        name: file_name,
        bytes,
    }];
    let mut index: BTreeMap<Rc<str>, usize> = BTreeMap::from([(top, 0)]);
    for (name, bytes) in std::mem::take(&mut loader.files) {
        if !index.contains_key(&name) {
            index.insert(name.clone(), files.len());
            files.push(DeckFile {
                name: name.to_string(),
                bytes,
            });
        }
    }
    let includes = loader
        .includes
        .iter()
        .map(|(from, first_line, last_line, target)| DeckInclude {
            file: index[from],
            first_line: *first_line,
            last_line: *last_line,
            target: index[target],
        })
        .collect();
    let cards = cards
        .into_iter()
        .map(|c| DeckCard {
            file: index[&c.loc.file],
            line: c.loc.line,
            name: c.name,
            fields: c
                .fields
                .into_iter()
                .map(|f| DeckField {
                    text: f.text,
                    line: f.line,
                })
                .collect(),
        })
        .collect();
    Ok(Deck {
        files,
        cards,
        includes,
        source_digest: loader.source.finalize().to_hex().to_string(),
    })
}
