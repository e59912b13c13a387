//! Replication (MSC Nastran QRG, "Bulk Data Entry Replication"): a line whose first field is
//! `=` repeats the preceding entry with its fields given as
//! - `=`: the preceding entry's field, unchanged;
//! - `==`: this and every following field of the preceding entry, unchanged;
//! - `*x` or `*(x)`: the preceding entry's field plus `x` (integers stay integers);
//! - anything else (blank included): that value;
//!
//! and a line whose first field is `=n` or `=(n)` generates `n` more entries, each the one
//! before with the same increments applied again. Only single-line entries are replicated
//! (an entry with continuations would need its continuations replicated too): anything else is
//! an error that asks for the entries in full.

use super::*;

/// What a replicated field does, remembered for `=n`.
#[derive(Clone, Debug)]
pub(super) enum Rule {
    /// The preceding entry's value.
    Same,
    /// The preceding entry's value plus this increment (its text).
    Increment(String),
    /// This value.
    Value(String),
}

/// The rules of the last replicated entry, for `=n`.
#[derive(Clone, Debug, Default)]
pub(super) struct Replication {
    rules: Vec<Rule>,
}

fn syntax(l: &SrcLine, problem: String, valid: &str) -> NastranError {
    NastranError::Syntax {
        file: l.file.to_string().into(),
        line: l.line,
        problem: problem.into(),
        valid: valid.into(),
    }
}

/// The data fields of a replication line (8 of them) and its first field.
fn fields_of(l: &SrcLine) -> Result<(String, Vec<String>), NastranError> {
    let mut over = 0;
    let split = split_line(&l.text, &l.file, l.line, &mut over)?;
    if split.large {
        return Err(syntax(
            l,
            "a replication line in large-field format".into(),
            "write replication lines in small or free field",
        ));
    }
    if !split.cont.is_empty() {
        return Err(syntax(
            l,
            "a replication line with a continuation field".into(),
            "replication is supported for single-line entries only; write the entry in full",
        ));
    }
    Ok((split.first, split.data))
}

/// `field` plus increment `inc`, both as written.
fn increment(prev: &str, inc: &str) -> Option<String> {
    if let (Some(a), Some(b)) = (parse_int(prev), parse_int(inc)) {
        return a.checked_add(b).map(|v| v.to_string());
    }
    let (a, b) = (parse_real(prev)?, parse_real(inc)?);
    Some(crate::model::export::nastran::format_real(a + b))
}

impl Replication {
    /// Applies one replication line `l` to the preceding entry `prev`, giving the new entries.
    pub(super) fn apply(&mut self, l: &SrcLine, prev: &Card) -> Result<Vec<Card>, NastranError> {
        let (first, data) = fields_of(l)?;
        if prev.fields.len() > 8 && prev.fields[8..].iter().any(|f| !f.text.is_empty()) {
            return Err(syntax(
                l,
                format!(
                    "replication of {} (line {}), an entry with continuations",
                    prev.name, prev.loc.line
                ),
                "replication is supported for single-line entries only; write the entries in full",
            ));
        }
        let count = first.trim_start_matches('=');
        if !count.is_empty() {
            let n = count
                .trim_start_matches('(')
                .trim_end_matches(')')
                .parse::<usize>()
                .ok()
                .filter(|n| (1..=1_000_000).contains(n))
                .ok_or_else(|| {
                    syntax(
                        l,
                        format!("`{}` is not a replication count", q(&first)),
                        "`=n` or `=(n)` with n from 1 to 1000000",
                    )
                })?;
            if self.rules.is_empty() {
                return Err(syntax(
                    l,
                    "`=n` follows no replicated entry".into(),
                    "`=n` repeats the increments of the replicated entry (a line starting with `=`) just before it",
                ));
            }
            let mut out: Vec<Card> = Vec::with_capacity(n);
            for _ in 0..n {
                let base = out.last().unwrap_or(prev);
                out.push(self.generate(l, base)?);
            }
            return Ok(out);
        }
        self.rules.clear();
        let mut rest_same = false;
        for text in data {
            let t = text.trim();
            let rule = if rest_same || t == "==" {
                rest_same = true;
                Rule::Same
            } else if t == "=" {
                Rule::Same
            } else if let Some(inc) = t.strip_prefix('*') {
                Rule::Increment(
                    inc.trim_start_matches('(')
                        .trim_end_matches(')')
                        .to_string(),
                )
            } else {
                Rule::Value(t.to_string())
            };
            self.rules.push(rule);
        }
        Ok(vec![self.generate(l, prev)?])
    }

    /// One entry from `base` by the current rules.
    fn generate(&self, l: &SrcLine, base: &Card) -> Result<Card, NastranError> {
        let mut fields = Vec::with_capacity(8);
        for (j, rule) in self.rules.iter().enumerate() {
            let prev = base.fields.get(j).map_or("", |f| f.text.as_str());
            let text = match rule {
                Rule::Same => prev.to_string(),
                Rule::Value(v) => v.clone(),
                Rule::Increment(inc) => increment(prev, inc).ok_or_else(|| {
                    syntax(
                        l,
                        format!(
                            "field {} of {}: `*{}` cannot increment `{}`",
                            j + 2,
                            base.name,
                            q(inc),
                            q(prev)
                        ),
                        "increment a number by a number (`*1`, `*(0.5)`)",
                    )
                })?,
            };
            fields.push(Field { text, line: l.line });
        }
        Ok(Card {
            name: base.name.clone(),
            loc: Loc {
                file: l.file.clone(),
                line: l.line,
                card: base.loc.card.clone(),
            },
            fields,
            half_open: false,
            nastran_like: true,
        })
    }
}
