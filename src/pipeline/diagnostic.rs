//! Errors in pipeline files, each with its file, line, column, stage and field.

use super::locate::Pos;
use std::fmt;

/// One problem found while reading or planning a pipeline.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// File name as given.
    pub file: String,
    /// Position, when known.
    pub pos: Option<Pos>,
    /// Stage name, when the problem is in a stage.
    pub stage: Option<String>,
    /// Field path (`with.level`, `inputs.measured`), when known.
    pub field: Option<String>,
    /// What is wrong.
    pub message: String,
    /// What would be valid.
    pub help: Option<String>,
}

impl Diagnostic {
    /// A diagnostic for `file` with a message.
    pub fn new(file: &str, message: impl Into<String>) -> Self {
        Diagnostic {
            file: file.to_string(),
            pos: None,
            stage: None,
            field: None,
            message: message.into(),
            help: None,
        }
    }

    /// Sets the position.
    pub fn at(mut self, pos: Option<Pos>) -> Self {
        self.pos = pos;
        self
    }

    /// Sets the stage.
    pub fn stage(mut self, stage: &str) -> Self {
        self.stage = Some(stage.to_string());
        self
    }

    /// Sets the field.
    pub fn field(mut self, field: impl Into<String>) -> Self {
        self.field = Some(field.into());
        self
    }

    /// Sets the help text.
    pub fn help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(p) = self.pos {
            write!(f, ":{}:{}", p.line, p.col)?;
        }
        write!(f, ":")?;
        if let Some(s) = &self.stage {
            write!(f, " stage `{s}`")?;
            if self.field.is_some() {
                write!(f, ",")?;
            }
        }
        if let Some(fl) = &self.field {
            write!(f, " field `{fl}`")?;
        }
        if self.stage.is_some() || self.field.is_some() {
            write!(f, ":")?;
        }
        write!(f, " {}", self.message)?;
        if let Some(h) = &self.help {
            write!(f, "\n  help: {h}")?;
        }
        Ok(())
    }
}

/// All problems found in one pipeline; displayed one per line.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostics(pub Vec<Diagnostic>);

/// Most problems reported at once; the rest are counted in a last line (a file of junk must not
/// print millions of lines).
pub const MAX_REPORTED: usize = 50;

impl Diagnostics {
    /// Keeps the first [`MAX_REPORTED`] problems and counts the rest in a last one, for `file`.
    pub fn capped(file: &str, mut diags: Vec<Diagnostic>) -> Diagnostics {
        if diags.len() > MAX_REPORTED {
            let more = diags.len() - MAX_REPORTED;
            diags.truncate(MAX_REPORTED);
            diags.push(
                Diagnostic::new(file, format!("… and {more} more problems")).help(format!(
                    "only the first {MAX_REPORTED} are shown; fix these and run again"
                )),
            );
        }
        Diagnostics(diags)
    }
}

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "error: {d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}

/// The candidate closest to `word` by edit distance, if it is close enough to be a likely typo.
pub fn nearest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (edit_distance(word, c), c))
        .filter(|(d, c)| *d <= 2.max(c.len() / 3))
        .min()
        .map(|(_, c)| c)
}

fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for i in 1..=a.len() {
        let mut cur = vec![i; b.len() + 1];
        for j in 1..=b.len() {
            let sub = prev[j - 1] + usize::from(a[i - 1] != b[j - 1]);
            cur[j] = sub.min(prev[j] + 1).min(cur[j - 1] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_finds_typos_only() {
        let kinds = ["frf.synthesise", "noise.add", "modes"];
        assert_eq!(nearest("frf.synthesize", kinds), Some("frf.synthesise"));
        assert_eq!(nearest("mode", kinds), Some("modes"));
        assert_eq!(nearest("update.pc", kinds), None);
    }
}
