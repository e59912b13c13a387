//! Datasets between `    -1` delimiters: the dataset number, the ASCII lines, and for 58b the
//! binary header and data; the reading state shared by a file's datasets.

use super::header58::binary_sizes_58;
use super::lex::{At, Cursor, col, is_delimiter, quoted_line, text};
use super::{ByteOrder, UffError, UffUnits};
use std::collections::{BTreeMap, HashMap, HashSet};

/// A dataset: its number, lines and binary data.
pub(super) struct Block<'a> {
    pub(super) number: u32,
    /// Line of the dataset number.
    pub(super) header_line: usize,
    /// ASCII lines between the number line and the closing delimiter (for 58b: the ASCII
    /// records announced by the header).
    pub(super) lines: Vec<(usize, &'a [u8])>,
    pub(super) binary: Option<Binary<'a>>,
    /// Line of the closing `    -1`.
    pub(super) end: usize,
}

pub(super) struct Binary<'a> {
    pub(super) order: ByteOrder,
    pub(super) data: &'a [u8],
}

/// Reading state shared by the datasets of one file.
pub(super) struct Ctx<'f> {
    pub(super) file: &'f str,
    pub(super) units: Option<UffUnits>,
    pub(super) warnings: Vec<String>,
    pub(super) node_lines: HashMap<u64, usize>,
    /// Per node read: the dataset 164 length factor applied.
    pub(super) node_scale: Vec<f64>,
    /// Keys of the warnings given once per file.
    pub(super) warned: HashSet<&'static str>,
    /// Skipped dataset 58 function types: count and first line.
    pub(super) skipped_functions: BTreeMap<i64, (usize, usize)>,
    /// Datasets read so far (before the first, the file's text is not quoted in messages).
    pub(super) datasets: usize,
    /// Dataset 58 records met so far.
    pub(super) frf_records: usize,
    /// Dataset 55 shapes whose translations were converted to m, by the units' source: factor,
    /// count and the first's line.
    pub(super) converted_shapes: BTreeMap<String, (f64, usize, usize)>,
}

impl Ctx<'_> {
    pub(super) fn warn(&mut self, w: String) {
        if !self.warnings.contains(&w) {
            self.warnings.push(w);
        }
    }

    /// A warning given once per file, at its first occurrence.
    pub(super) fn warn_once(&mut self, key: &'static str, w: String) {
        if self.warned.insert(key) {
            self.warnings.push(w);
        }
    }
}

/// Reads the next dataset, `None` at the end of the file.
pub(super) fn next_block<'a>(
    cur: &mut Cursor<'a>,
    ctx: &mut Ctx<'_>,
) -> Result<Option<Block<'a>>, UffError> {
    let Some(open) = opening(cur, ctx)? else {
        return Ok(None);
    };
    if open.binary {
        binary_block(cur, ctx, &open).map(Some)
    } else {
        ascii_block(cur, ctx.file, &open).map(Some)
    }
}

/// The start of a dataset: the opening delimiter and the number line after it.
struct Opening<'a> {
    /// Line of the opening `    -1`.
    start: usize,
    /// Line of the dataset number.
    header_line: usize,
    /// The number line as read (for 58b, also the binary header).
    raw: &'a [u8],
    number: u32,
    /// True for a number with the `b` suffix (binary data follow).
    binary: bool,
}

impl Opening<'_> {
    /// The file ends inside this dataset while `expected` was still to come.
    fn truncated(&self, file: &str, cur: &Cursor<'_>, expected: String) -> UffError {
        UffError::Truncated {
            file: file.to_string(),
            line: cur.last_line(),
            dataset: Some(self.number),
            start: self.start,
            expected,
        }
    }
}

/// Skips blank lines to the opening delimiter and reads the dataset number after it; `None` at
/// the end of the file.
fn opening<'a>(cur: &mut Cursor<'a>, ctx: &Ctx<'_>) -> Result<Option<Opening<'a>>, UffError> {
    let file = ctx.file;
    let start = loop {
        let Some((no, raw)) = cur.next_line() else {
            return Ok(None);
        };
        if raw.trim_ascii().is_empty() {
            continue;
        }
        if is_delimiter(raw) {
            break no;
        }
        return Err(UffError::Delimiter {
            file: file.to_string(),
            line: no,
            found: quoted_line(ctx, raw),
        });
    };
    let Some((header_line, raw)) = cur.next_line() else {
        return Err(UffError::Truncated {
            file: file.to_string(),
            line: cur.last_line(),
            dataset: None,
            start,
            expected: "a dataset number after the opening `    -1`".to_string(),
        });
    };
    let htext = text(raw);
    let first = htext.split_whitespace().next().unwrap_or("");
    let (number_text, binary) = match first.strip_suffix(['b', 'B']) {
        Some(n) => (n, true),
        None => (first, false),
    };
    let number: u32 = number_text.parse().map_err(|_| UffError::DatasetNumber {
        file: file.to_string(),
        line: header_line,
        found: quoted_line(ctx, raw),
    })?;
    Ok(Some(Opening {
        start,
        header_line,
        raw,
        number,
        binary,
    }))
}

/// An ASCII dataset: its lines up to the closing delimiter.
fn ascii_block<'a>(
    cur: &mut Cursor<'a>,
    file: &str,
    open: &Opening<'_>,
) -> Result<Block<'a>, UffError> {
    let mut lines = Vec::new();
    let end = loop {
        match cur.next_line() {
            None => {
                return Err(open.truncated(
                    file,
                    cur,
                    "more records and the closing `    -1`".to_string(),
                ));
            }
            Some((no, raw)) if is_delimiter(raw) => break no,
            Some(l) => lines.push(l),
        }
    };
    Ok(Block {
        number: open.number,
        header_line: open.header_line,
        lines,
        binary: None,
        end,
    })
}

/// Fields 3–6 of the binary header, Format(I6,1A1,I6,I6,I12,I12,I6,I6,I12,I12): the byte
/// order, the floating-point format (IEEE 754 only), the count of ASCII lines and of data bytes.
fn binary_header(at: &At<'_>, raw: &[u8]) -> Result<(ByteOrder, usize, usize), UffError> {
    let htext = text(raw);
    let rest: Vec<&str> = htext.split_whitespace().skip(1).collect();
    let get = |i: usize, a: usize, b: usize, field: &str| -> Result<i64, UffError> {
        let s = if rest.len() >= 4 {
            rest[i].to_string()
        } else {
            col(raw, a, b)
        };
        at.int(&s, field, "an integer")
    };
    let order = match get(0, 7, 13, "field 3 (byte ordering method)")? {
        1 => ByteOrder::Little,
        2 => ByteOrder::Big,
        o => {
            return Err(at.err(
                "field 3 (byte ordering method)",
                o,
                "1 (little endian) or 2 (big endian)",
            ));
        }
    };
    let fp = get(1, 13, 19, "field 4 (floating-point format)")?;
    if fp != 2 {
        return Err(at.err(
            "field 4 (floating-point format)",
            fp,
            "2 (IEEE 754); 1 (DEC VMS) and 3 (IBM 5/370) are not supported",
        ));
    }
    let n_ascii = get(2, 19, 31, "field 5 (number of ASCII lines)")?;
    let n_ascii = usize::try_from(n_ascii).map_err(|_| {
        at.err(
            "field 5 (number of ASCII lines)",
            n_ascii,
            "a non-negative count (11 for dataset 58)",
        )
    })?;
    let n_bytes = get(3, 31, 43, "field 6 (number of bytes)")?;
    let n_bytes = usize::try_from(n_bytes).map_err(|_| {
        at.err(
            "field 6 (number of bytes)",
            n_bytes,
            "a non-negative byte count",
        )
    })?;
    Ok((order, n_ascii, n_bytes))
}

/// A binary (58b) dataset: the header, the ASCII records it announces, the binary data and the
/// closing delimiter.
fn binary_block<'a>(
    cur: &mut Cursor<'a>,
    ctx: &mut Ctx<'_>,
    open: &Opening<'_>,
) -> Result<Block<'a>, UffError> {
    let file = ctx.file;
    let at = At {
        file,
        line: open.header_line,
        dataset: open.number,
        record: "binary header",
    };
    let (order, n_ascii, n_bytes) = binary_header(&at, open.raw)?;
    let mut lines = Vec::new();
    for k in 0..n_ascii {
        match cur.next_line() {
            Some(l) => lines.push(l),
            None => {
                return Err(open.truncated(
                    file,
                    cur,
                    format!("{n_ascii} ASCII lines after the binary header (field 5), found {k}"),
                ));
            }
        }
    }
    let size = binary_size(cur, open, &at, &lines, n_bytes)?;
    if size != n_bytes {
        ctx.warn(format!(
            "{file}:{}: dataset 58b declares {n_bytes} bytes of binary data, but the closing `    -1` follows after {size} bytes, as record 7 implies; {size} bytes read",
            open.header_line
        ));
    }
    let data = cur
        .take_binary(size)
        .ok_or_else(|| open.truncated(file, cur, format!("{size} bytes of binary data")))?;
    let end = match cur.next_line() {
        Some((no, raw)) if is_delimiter(raw) => no,
        _ => {
            return Err(open.truncated(
                file,
                cur,
                "the closing `    -1` after the binary data".to_string(),
            ));
        }
    };
    Ok(Block {
        number: open.number,
        header_line: open.header_line,
        lines,
        binary: Some(Binary { order, data }),
        end,
    })
}

/// The count of binary data bytes: the header's (field 6), or for dataset 58 the count record 7
/// implies, whichever the closing delimiter follows.
fn binary_size(
    cur: &Cursor<'_>,
    open: &Opening<'_>,
    at: &At<'_>,
    lines: &[(usize, &[u8])],
    n_bytes: usize,
) -> Result<usize, UffError> {
    let mut candidates = vec![n_bytes];
    if open.number == 58 {
        for s in binary_sizes_58(lines) {
            if !candidates.contains(&s) {
                candidates.push(s);
            }
        }
    }
    if let Some(size) = candidates.iter().copied().find(|&c| cur.delimiter_after(c)) {
        return Ok(size);
    }
    if cur.remaining() < n_bytes {
        return Err(open.truncated(
            at.file,
            cur,
            format!(
                "{n_bytes} bytes of binary data (binary header field 6) and the closing `    -1`; only {} bytes remain",
                cur.remaining()
            ),
        ));
    }
    let implied = if candidates.len() > 1 {
        format!(
            " (record 7 implies {} bytes)",
            candidates[1..]
                .iter()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(" or ")
        )
    } else {
        String::new()
    };
    Err(at.err(
        "field 6 (number of bytes)",
        n_bytes,
        format!("the count of binary data bytes, after which `    -1` closes the dataset{implied}"),
    ))
}
