//! Lines, fields and Fortran reals of a universal file, and where a field is for messages.

use super::UffError;
use super::block::Ctx;
use crate::core::input::{EXCERPT_CHARS, excerpt};
use std::borrow::Cow;
use std::fmt;

/// A position in the file, line by line, with raw byte runs for binary data.
pub(super) struct Cursor<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) pos: usize,
    /// 1-based number of the next line.
    pub(super) line: usize,
}

impl<'a> Cursor<'a> {
    pub(super) fn new(bytes: &'a [u8]) -> Self {
        Cursor {
            bytes,
            pos: 0,
            line: 1,
        }
    }

    /// The next line without its line end, with its 1-based number.
    pub(super) fn next_line(&mut self) -> Option<(usize, &'a [u8])> {
        let rest = self.bytes.get(self.pos..).filter(|r| !r.is_empty())?;
        let (body, used) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        let body = body.strip_suffix(b"\r").unwrap_or(body);
        let no = self.line;
        self.line += 1;
        self.pos += used;
        Some((no, body))
    }

    /// Number of the last line read (the file's last line at its end).
    pub(super) fn last_line(&self) -> usize {
        self.line.saturating_sub(1).max(1)
    }

    pub(super) fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    /// Whether a delimiter line follows `n` bytes from here, after at most one line end.
    pub(super) fn delimiter_after(&self, n: usize) -> bool {
        let Some(rest) = self.pos.checked_add(n).and_then(|s| self.bytes.get(s..)) else {
            return false;
        };
        let rest = skip_line_end(rest);
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        is_delimiter(&rest[..end])
    }

    /// Takes `n` raw bytes, then the line end that may follow them.
    pub(super) fn take_binary(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let chunk = self.bytes.get(self.pos..end)?;
        self.line += chunk.iter().filter(|&&b| b == b'\n').count();
        self.pos = end;
        let rest = self.bytes.get(end..).unwrap_or_default();
        let skipped = rest.len() - skip_line_end(rest).len();
        if skipped > 0 {
            self.pos += skipped;
            self.line += 1;
        }
        Some(chunk)
    }
}

pub(super) fn skip_line_end(b: &[u8]) -> &[u8] {
    b.strip_prefix(b"\r\n")
        .or_else(|| b.strip_prefix(b"\n"))
        .unwrap_or(b)
}

pub(super) fn is_delimiter(line: &[u8]) -> bool {
    line.trim_ascii() == b"-1"
}

pub(super) fn text(raw: &[u8]) -> Cow<'_, str> {
    String::from_utf8_lossy(raw)
}

/// A text shortened for a message: at most [`EXCERPT_CHARS`] characters.
pub(super) fn shown(s: &str) -> String {
    let s = s.trim();
    if s.is_empty() {
        return "(blank)".to_string();
    }
    excerpt(s, EXCERPT_CHARS)
}

/// A line quoted in a structural error: an excerpt once the file has shown itself to be a
/// universal file (a dataset was read), else a note that the text is not quoted.
pub(super) fn quoted_line(ctx: &Ctx<'_>, raw: &[u8]) -> String {
    if ctx.datasets > 0 {
        format!("`{}`", shown(&text(raw)))
    } else {
        "a line that is not quoted: nothing before it is a universal file dataset, so the file does not look like a universal file".to_string()
    }
}

/// Columns `a..b` (0-based, byte columns) of a line, empty past its end.
pub(super) fn col(raw: &[u8], a: usize, b: usize) -> String {
    let n = raw.len();
    text(&raw[a.min(n)..b.min(n)]).into_owned()
}

/// The fields of a numeric record: its whitespace-separated values when there are exactly as
/// many as `widths`, else its fixed Fortran columns.
pub(super) fn fields(raw: &[u8], widths: &[usize]) -> Vec<String> {
    let t = text(raw);
    let toks: Vec<&str> = t.split_whitespace().collect();
    if toks.len() == widths.len() {
        return toks.into_iter().map(str::to_string).collect();
    }
    let mut a = 0;
    widths
        .iter()
        .map(|w| {
            let f = col(raw, a, a + w).trim().to_string();
            a += w;
            f
        })
        .collect()
}

/// A real in Fortran notation: `1.5E+02`, `1.5D+02`, `0.15+003`, `NaN`.
pub(super) fn parse_real(s: &str) -> Option<f64> {
    let s = s.trim();
    if s.is_empty() {
        return None;
    }
    if let Ok(v) = s.parse::<f64>() {
        return Some(v);
    }
    let mut t: String = s
        .chars()
        .map(|c| if c == 'd' || c == 'D' { 'E' } else { c })
        .collect();
    if !t.contains(['e', 'E']) {
        let sign = t
            .char_indices()
            .skip(1)
            .find(|(_, c)| *c == '+' || *c == '-')
            .map(|(i, _)| i);
        if let Some(i) = sign {
            t.insert(i, 'E');
        }
    }
    t.parse().ok()
}

/// Splits a whitespace-free token into the numbers of touching fixed-width fields:
/// `1.0E+00-2.0E+00` → `1.0E+00`, `-2.0E+00`. A sign followed only by digits after a mantissa
/// without exponent is a letter-less Fortran exponent (`0.12+100`) and stays.
pub(super) fn split_numbers(token: &str) -> Vec<&str> {
    let b = token.as_bytes();
    let mut parts = Vec::new();
    let mut start = 0;
    let mut i = 1;
    while i < b.len() {
        if (b[i] == b'+' || b[i] == b'-') && !matches!(b[i - 1], b'e' | b'E' | b'd' | b'D') {
            let current = &b[start..i];
            let has_exponent = current
                .iter()
                .any(|c| matches!(c, b'e' | b'E' | b'd' | b'D'));
            let mut j = i + 1;
            while j < b.len() && b[j].is_ascii_digit() {
                j += 1;
            }
            let digits_only = j > i + 1 && (j == b.len() || b[j] == b'+' || b[j] == b'-');
            if !has_exponent && current.contains(&b'.') && digits_only {
                i = j;
                continue;
            }
            parts.push(&token[start..i]);
            start = i;
        }
        i += 1;
    }
    parts.push(&token[start..]);
    parts
}

/// Where a field is, for error messages.
#[derive(Clone, Copy)]
pub(super) struct At<'f> {
    pub(super) file: &'f str,
    pub(super) line: usize,
    pub(super) dataset: u32,
    pub(super) record: &'static str,
}

impl At<'_> {
    pub(super) fn err(
        &self,
        field: impl Into<String>,
        found: impl fmt::Display,
        valid: impl Into<String>,
    ) -> UffError {
        UffError::Field {
            file: self.file.to_string(),
            line: self.line,
            dataset: self.dataset,
            record: self.record,
            field: field.into(),
            found: shown(&found.to_string()),
            valid: valid.into(),
        }
    }

    pub(super) fn int(&self, s: &str, field: &str, valid: &str) -> Result<i64, UffError> {
        s.trim()
            .parse::<i64>()
            .map_err(|_| self.err(field, s, valid))
    }

    pub(super) fn int_or_zero(&self, s: &str, field: &str, valid: &str) -> Result<i64, UffError> {
        if s.trim().is_empty() {
            Ok(0)
        } else {
            self.int(s, field, valid)
        }
    }

    pub(super) fn label(&self, s: &str, field: &str) -> Result<u64, UffError> {
        s.trim()
            .parse::<u64>()
            .map_err(|_| self.err(field, s, "a non-negative integer label"))
    }

    pub(super) fn small(&self, s: &str, field: &str) -> Result<u32, UffError> {
        if s.trim().is_empty() {
            return Ok(0);
        }
        s.trim()
            .parse::<u32>()
            .map_err(|_| self.err(field, s, "a non-negative integer"))
    }

    pub(super) fn real(&self, s: &str, field: &str) -> Result<f64, UffError> {
        parse_real(s)
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err(field, s, "a finite real number, e.g. 1.25000E+02"))
    }

    pub(super) fn real_or_zero(&self, s: &str, field: &str) -> Result<f64, UffError> {
        if s.trim().is_empty() {
            Ok(0.0)
        } else {
            self.real(s, field)
        }
    }
}
