//! Cards: splitting lines into small, large and free fields, joining continuations, and
//! typed access to a card's fields with messages that name file, line and QRG field.

use super::*;

/// Explicit ids and inclusive `THRU` ranges of a list field.
pub(super) type IdList = (Vec<u64>, Vec<(u64, u64)>);

/// One data field with the file line that holds it.
pub(super) struct Field {
    pub(super) text: String,
    pub(super) line: usize,
}

/// A whole card: its name and its data fields in QRG order (`fields[k - 1]` is data field `k`;
/// field `k` sits on continuation `(k - 1) / 8` at QRG field `(k - 1) % 8 + 2`).
pub(super) struct Card {
    pub(super) name: String,
    pub(super) loc: Loc,
    pub(super) fields: Vec<Field>,
    /// A large-field first half-line was read and its second half is still to come.
    pub(super) half_open: bool,
    /// Whether a card femu knows came before this one in its file, so that quoting the file's
    /// text in a message shows Nastran data, not some other file named by mistake.
    pub(super) nastran_like: bool,
}

/// One physical line split into fields.
pub(super) struct Split {
    pub(super) first: String,
    pub(super) data: Vec<String>,
    pub(super) cont: String,
    pub(super) large: bool,
}

pub(super) fn split_line(
    text: &str,
    file: &str,
    line: usize,
    beyond_80: &mut usize,
) -> Result<Split, NastranError> {
    if text.contains(',') {
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        let first = parts[0].to_string();
        let large = first.ends_with('*') || first.starts_with('*');
        let n = if large { 4 } else { 8 };
        if parts.len() > n + 2 {
            return Err(NastranError::Syntax {
                file: file.to_string().into(),
                line,
                problem: format!(
                    "this free-field line has {} fields, more than the {} a line holds",
                    parts.len(),
                    n + 2
                )
                .into(),
                valid: format!(
                    "put at most {n} data fields after the card name or continuation field and continue on a line starting with a comma"
                )
                .into(),
            });
        }
        let mut data: Vec<String> = parts[1..parts.len().min(n + 1)]
            .iter()
            .map(|s| s.to_string())
            .collect();
        data.resize(n, String::new());
        let cont = parts.get(n + 1).map(|s| s.to_string()).unwrap_or_default();
        return Ok(Split {
            first,
            data,
            cont,
            large,
        });
    }
    let mut chars: Vec<char> = Vec::with_capacity(80);
    for ch in text.chars() {
        if ch == '\t' {
            let next = (chars.len() / 8 + 1) * 8;
            chars.resize(next, ' ');
        } else {
            chars.push(ch);
        }
    }
    if chars.iter().skip(80).any(|c| !c.is_whitespace()) {
        *beyond_80 += 1;
    }
    chars.truncate(80);
    let get = |a: usize, b: usize| -> String {
        let a = a.min(chars.len());
        let b = b.min(chars.len());
        chars[a..b].iter().collect::<String>().trim().to_string()
    };
    let first = get(0, 8);
    let large = first.ends_with('*') || first.starts_with('*');
    let (n, w) = if large { (4, 16) } else { (8, 8) };
    let data = (0..n).map(|j| get(8 + j * w, 8 + (j + 1) * w)).collect();
    Ok(Split {
        first,
        data,
        cont: get(72, 80),
        large,
    })
}

impl Card {
    pub(super) fn push(&mut self, split: Split, line: usize) {
        if split.large {
            self.half_open = !self.half_open;
        } else if self.half_open {
            self.fields.extend((0..4).map(|_| Field {
                text: String::new(),
                line,
            }));
            self.half_open = false;
        }
        self.fields
            .extend(split.data.into_iter().map(|text| Field { text, line }));
    }

    pub(super) fn text(&self, k: usize) -> &str {
        k.checked_sub(1)
            .and_then(|i| self.fields.get(i))
            .map_or("", |f| f.text.as_str())
    }

    pub(super) fn blank(&self, k: usize) -> bool {
        self.text(k).is_empty()
    }

    pub(super) fn word(&self, k: usize) -> String {
        self.text(k).to_ascii_uppercase()
    }

    pub(super) fn err(
        &self,
        k: usize,
        label: &str,
        problem: impl Into<Box<str>>,
        valid: impl Into<Box<str>>,
    ) -> NastranError {
        let line = k
            .checked_sub(1)
            .and_then(|i| self.fields.get(i))
            .map_or(self.loc.line, |f| f.line);
        self.loc.err(k, line, label, problem, valid)
    }

    pub(super) fn int(&self, k: usize, label: &str) -> Result<Option<i64>, NastranError> {
        let t = self.text(k);
        if t.is_empty() {
            return Ok(None);
        }
        parse_int(t).map(Some).ok_or_else(|| {
            self.err(
                k,
                label,
                format!("`{}` is not an integer", q(t)),
                "write a whole number without a decimal point",
            )
        })
    }

    pub(super) fn id(&self, k: usize, label: &str) -> Result<u64, NastranError> {
        match self.int(k, label)? {
            None => Err(self.err(
                k,
                label,
                "the field is blank",
                "an id (integer > 0) is required",
            )),
            Some(v) if v > 0 => Ok(v as u64),
            Some(v) => Err(self.err(
                k,
                label,
                format!("{v} is not an id"),
                "ids are integers > 0",
            )),
        }
    }

    pub(super) fn id_or(&self, k: usize, label: &str, default: u64) -> Result<u64, NastranError> {
        if self.blank(k) {
            Ok(default)
        } else {
            self.id(k, label)
        }
    }

    /// A grid id that may be blank or 0 (ground).
    pub(super) fn opt_grid(&self, k: usize, label: &str) -> Result<Option<u64>, NastranError> {
        match self.int(k, label)? {
            None | Some(0) => Ok(None),
            Some(v) if v > 0 => Ok(Some(v as u64)),
            Some(v) => Err(self.err(
                k,
                label,
                format!("{v} is not a grid id"),
                "a grid id (integer > 0), or blank or 0 for ground",
            )),
        }
    }

    pub(super) fn nonneg(&self, k: usize, label: &str, what: &str) -> Result<u64, NastranError> {
        match self.int(k, label)? {
            None => Ok(0),
            Some(v) if v >= 0 => Ok(v as u64),
            Some(v) => Err(self.err(
                k,
                label,
                format!("{v} is negative"),
                format!("{what} (integer ≥ 0)"),
            )),
        }
    }

    pub(super) fn real(&self, k: usize, label: &str) -> Result<Option<f64>, NastranError> {
        let t = self.text(k);
        if t.is_empty() {
            return Ok(None);
        }
        parse_real(t).map(Some).ok_or_else(|| {
            self.err(
                k,
                label,
                format!("`{}` is not a number", q(t)),
                "write a real number such as 2.1E11, 2.1+11, 0.5 or .5",
            )
        })
    }

    pub(super) fn real_or(&self, k: usize, label: &str, default: f64) -> Result<f64, NastranError> {
        Ok(self.real(k, label)?.unwrap_or(default))
    }

    pub(super) fn req_real(&self, k: usize, label: &str) -> Result<f64, NastranError> {
        self.real(k, label)?
            .ok_or_else(|| self.err(k, label, "the field is blank", "a real number is required"))
    }

    pub(super) fn positive(&self, k: usize, label: &str) -> Result<f64, NastranError> {
        let v = self.req_real(k, label)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(
                k,
                label,
                format!("{v} is not positive"),
                "a real number > 0 is required",
            ))
        }
    }

    /// A real ≥ 0 (blank: `default`); femu's elements refuse negative values of it.
    pub(super) fn nonneg_real(
        &self,
        k: usize,
        label: &str,
        default: f64,
    ) -> Result<f64, NastranError> {
        let v = self.real_or(k, label, default)?;
        if v < 0.0 {
            return Err(self.err(
                k,
                label,
                format!("{v} is negative"),
                "a real number >= 0 (femu's elements do not accept negative values here)",
            ));
        }
        Ok(v)
    }

    pub(super) fn comps(&self, k: usize, label: &str) -> Result<Vec<Component>, NastranError> {
        let t = self.text(k);
        if t.is_empty() {
            return Ok(Vec::new());
        }
        parse_components(t).ok_or_else(|| {
            self.err(
                k,
                label,
                format!("`{}` is not a component list", q(t)),
                "write distinct digits 1-6 without blanks, e.g. 123 or 123456",
            )
        })
    }

    pub(super) fn one_comp(&self, k: usize, label: &str) -> Result<Component, NastranError> {
        let c = self.comps(k, label)?;
        match c.as_slice() {
            [one] => Ok(*one),
            _ => Err(self.err(
                k,
                label,
                format!("`{}` is not one grid component", q(self.text(k))),
                "a single component 1-6 (scalar points are not supported)",
            )),
        }
    }

    /// Rejects a nonzero real field that femu cannot represent.
    pub(super) fn zero(&self, k: usize, label: &str, valid: &str) -> Result<(), NastranError> {
        let v = self.real_or(k, label, 0.0)?;
        if v != 0.0 {
            return Err(self.err(k, label, format!("{v} is not supported"), valid));
        }
        Ok(())
    }

    /// Ids with `THRU` ranges from field `k` on: explicit ids and inclusive ranges.
    pub(super) fn id_list(&self, from: usize, label: &str) -> Result<IdList, NastranError> {
        let mut ids = Vec::new();
        let mut ranges = Vec::new();
        let mut k = from;
        while k <= self.fields.len() {
            if self.blank(k) {
                k += 1;
                continue;
            }
            if self.word(k) == "THRU" {
                let (Some(lo), Some(next)) = (
                    ids.pop(),
                    (k + 1..=self.fields.len()).find(|&j| !self.blank(j)),
                ) else {
                    return Err(self.err(
                        k,
                        label,
                        "THRU has no id on both sides",
                        "write `id1 THRU id2`",
                    ));
                };
                let hi = self.id(next, label)?;
                if hi < lo {
                    return Err(self.err(
                        next,
                        label,
                        format!("{lo} THRU {hi} runs backwards"),
                        "the id after THRU must not be smaller than the one before",
                    ));
                }
                ranges.push((lo, hi));
                k = next + 1;
                continue;
            }
            ids.push(self.id(k, label)?);
            k += 1;
        }
        Ok((ids, ranges))
    }
}

/// The error for a line of a file in which no Nastran card has been seen yet: its text is not
/// quoted, as the file may be anything a path named by mistake.
pub(super) fn not_nastran(file: &str, line: usize) -> NastranError {
    NastranError::Syntax {
        file: file.into(),
        line,
        problem: "this line does not start a Nastran card femu knows, and no card came before it in this file, so the file does not look like Nastran bulk data (its text is not quoted)".into(),
        valid: format!(
            "name a bulk data deck: cards such as {} in small, large or free field format",
            READ_CARDS.join(", ")
        )
        .into(),
    }
}

/// Groups lines into cards.
pub(super) fn assemble(
    lines: &[SrcLine],
    warnings: &mut Vec<String>,
) -> Result<Vec<Card>, NastranError> {
    let mut cards: Vec<Card> = Vec::new();
    let mut last_cont = String::new();
    let mut beyond: BTreeMap<Rc<str>, (usize, usize)> = BTreeMap::new();
    let mut nastran_like: BTreeSet<Rc<str>> = BTreeSet::new();
    let mut replication = super::replicate::Replication::default();
    for l in lines {
        let like = nastran_like.contains(&l.file);
        let syntax = |problem: String, valid: &str| NastranError::Syntax {
            file: l.file.to_string().into(),
            line: l.line,
            problem: problem.into(),
            valid: valid.into(),
        };
        let first_char = l.text.chars().next().unwrap_or(' ');
        let mut over = 0;
        let split = split_line(&l.text, &l.file, l.line, &mut over)?;
        if over > 0 {
            let entry = beyond.entry(l.file.clone()).or_insert((l.line, 0));
            entry.1 += 1;
        }
        if first_char.is_ascii_alphabetic() {
            let name = split
                .first
                .trim_end_matches('*')
                .trim()
                .to_ascii_uppercase();
            if !is_card_name(&name) {
                return Err(if like {
                    syntax(
                        format!("`{}` is not a card name", q(&split.first)),
                        "a card name is a letter followed by letters or digits, at most 8 characters",
                    )
                } else {
                    not_nastran(&l.file, l.line)
                });
            }
            if is_known_card(&name) {
                nastran_like.insert(l.file.clone());
            }
            let mut card = Card {
                name: name.clone(),
                loc: Loc {
                    file: l.file.clone(),
                    line: l.line,
                    card: Rc::from(name.as_str()),
                },
                fields: Vec::new(),
                half_open: false,
                nastran_like: like,
            };
            last_cont = split.cont.clone();
            card.push(split, l.line);
            cards.push(card);
        } else if matches!(first_char, '+' | '*' | ',' | ' ' | '\t') {
            let Some(card) = cards.last_mut() else {
                return Err(syntax(
                    "a continuation line comes before any card".to_string(),
                    "continuation lines must follow the card they continue",
                ));
            };
            let marker = split.first.trim_start_matches(['+', '*']);
            let expected = last_cont.trim_start_matches(['+', '*']);
            if !marker.is_empty() && !expected.is_empty() && marker != expected {
                return Err(syntax(
                    format!(
                        "continuation `{}` does not match `{}` at the end of the previous line of {} (line {})",
                        q(&split.first),
                        q(&last_cont),
                        card.name,
                        card.loc.line
                    ),
                    "continuation lines must follow their parent in order (unsorted decks are not supported)",
                ));
            }
            last_cont = split.cont.clone();
            card.push(split, l.line);
        } else if first_char == '=' {
            let Some(prev) = cards.last() else {
                return Err(syntax(
                    "a replication line comes before any card".to_string(),
                    "`=` repeats the entry just before it",
                ));
            };
            let made = replication.apply(l, prev)?;
            last_cont.clear();
            cards.extend(made);
        } else if like {
            return Err(syntax(
                format!("`{}` starts neither a card nor a continuation", q(&l.text)),
                "a card name starts in column 1 with a letter; a continuation starts with `+`, `*`, `,` or a blank",
            ));
        } else {
            return Err(not_nastran(&l.file, l.line));
        }
    }
    for (file, (line, count)) in beyond {
        warnings.push(format!(
            "{file} line {line}: {count} fixed-format line(s) have text beyond column 80, which is ignored as in Nastran"
        ));
    }
    Ok(cards)
}
