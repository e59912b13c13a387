//! Nastran numbers: integer and real fields (with the QRG shorthands) and component lists.

use super::*;

/// Parses a Nastran integer field.
pub(super) fn parse_int(text: &str) -> Option<i64> {
    let digits = text.strip_prefix(['+', '-']).unwrap_or(text);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    text.parse().ok()
}

/// Parses a Nastran real field, including the shorthands `1.5-3`, `7.+4`, `.5`, `1+3`, `1.E3`
/// and `1D3`; integers are accepted too. Returns `None` for anything else or an overflow.
pub(crate) fn parse_real(text: &str) -> Option<f64> {
    let b = text.as_bytes();
    let mut i = 0;
    let mut sign = "";
    if let Some(&c) = b.first().filter(|c| **c == b'+' || **c == b'-') {
        if c == b'-' {
            sign = "-";
        }
        i = 1;
    }
    let int_start = i;
    while i < b.len() && b[i].is_ascii_digit() {
        i += 1;
    }
    let int_part = &text[int_start..i];
    let mut frac_part = "";
    if i < b.len() && b[i] == b'.' {
        i += 1;
        let frac_start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        frac_part = &text[frac_start..i];
    }
    if int_part.is_empty() && frac_part.is_empty() {
        return None;
    }
    let mut exponent = "0";
    if i < b.len() {
        if matches!(b[i], b'e' | b'E' | b'd' | b'D') {
            i += 1;
        } else if !matches!(b[i], b'+' | b'-') {
            return None;
        }
        let exp_start = i;
        if i < b.len() && matches!(b[i], b'+' | b'-') {
            i += 1;
        }
        let digits_start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        if i != b.len() || i == digits_start {
            return None;
        }
        exponent = &text[exp_start..];
    }
    let int_part = if int_part.is_empty() { "0" } else { int_part };
    let frac_part = if frac_part.is_empty() { "0" } else { frac_part };
    let value: f64 = format!("{sign}{int_part}.{frac_part}e{exponent}")
        .parse()
        .ok()?;
    value.is_finite().then_some(value)
}

/// Parses a component list such as `123456` (digits 1–6, no repeats).
pub(super) fn parse_components(text: &str) -> Option<Vec<Component>> {
    if text.is_empty() {
        return None;
    }
    let mut out = Vec::new();
    for ch in text.chars() {
        let c = Component::from_nastran(ch.to_digit(10)? as u8)?;
        if out.contains(&c) {
            return None;
        }
        out.push(c);
    }
    Some(out)
}

/// A field or line quoted in a message: at most [`EXCERPT_CHARS`] characters.
pub(super) fn q(s: &str) -> String {
    excerpt(s, EXCERPT_CHARS)
}

pub(super) fn starts_with_ci(s: &str, prefix: &str) -> bool {
    s.get(..prefix.len())
        .is_some_and(|head| head.eq_ignore_ascii_case(prefix))
}

pub(super) fn strip_comment(line: &str) -> &str {
    match line.find('$') {
        Some(i) => &line[..i],
        None => line,
    }
}

pub(super) fn is_begin_bulk(line: &str) -> bool {
    let squeezed: String = strip_comment(line)
        .chars()
        .filter(|c| !c.is_whitespace() && *c != ',')
        .collect();
    starts_with_ci(&squeezed, "BEGINBULK")
}
