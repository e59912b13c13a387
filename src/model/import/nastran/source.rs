//! Files and lines: reading the deck and its INCLUDEs under the input policy, comments,
//! `BEGIN BULK`/`ENDDATA`, and the femu comments (`$femu-set`, `$femu-parameter`).

use super::*;

/// One significant line of the deck (comment removed).
pub(super) struct SrcLine {
    pub(super) file: Rc<str>,
    pub(super) line: usize,
    pub(super) text: String,
}

/// Where a card starts.
#[derive(Clone, Debug)]
pub(super) struct Loc {
    pub(super) file: Rc<str>,
    pub(super) line: usize,
    pub(super) card: Rc<str>,
}

impl Loc {
    pub(super) fn err(
        &self,
        k: usize,
        field_line: usize,
        label: &str,
        problem: impl Into<Box<str>>,
        valid: impl Into<Box<str>>,
    ) -> NastranError {
        let k = k.max(1);
        NastranError::Field {
            file: self.file.to_string().into(),
            line: self.line,
            card: self.card.to_string().into(),
            row: (k - 1) / 8,
            field: (k - 1) % 8 + 2,
            field_line,
            label: label.to_string().into(),
            problem: problem.into(),
            valid: valid.into(),
        }
    }

    pub(super) fn field_err(
        &self,
        k: usize,
        label: &str,
        problem: impl Into<Box<str>>,
        valid: impl Into<Box<str>>,
    ) -> NastranError {
        self.err(k, self.line, label, problem, valid)
    }

    pub(super) fn place(&self) -> String {
        format!("{} line {}", self.file, self.line)
    }
}

#[derive(Default)]
pub(super) struct Loader {
    /// How INCLUDEd files may be read.
    pub(super) policy: InputPolicy,
    /// Bytes read so far (the deck and its INCLUDEs share the policy's limit).
    pub(super) used: u64,
    pub(super) lines: Vec<SrcLine>,
    pub(super) warnings: Vec<String>,
    pub(super) stack: Vec<PathBuf>,
    pub(super) set_names: Vec<(Loc, u64, String)>,
    pub(super) parameters: Vec<(Loc, Parameter)>,
    /// `SPC = n` selections of the case control, in order (global first, then by subcase).
    pub(super) case_control: Vec<(Loc, u64)>,
    /// `MPC = n` selections of the case control, likewise.
    pub(super) case_control_mpc: Vec<(Loc, u64)>,
    /// `METHOD = n` (or `METH = n`) selections, likewise.
    pub(super) case_control_method: Vec<(Loc, u64)>,
    /// Whether the top file has a case control section (a CEND before BEGIN BULK).
    pub(super) has_case_control: bool,
    /// The top file's folder: INCLUDEs not found beside the including file are looked up here.
    pub(super) job_dir: PathBuf,
    /// Hash of the bytes of every file read, in reading order.
    pub(super) source: blake3::Hasher,
    /// Keep every file's bytes and INCLUDE statements ([`super::deck::read_deck`]).
    pub(super) keep: bool,
    /// Each INCLUDEd file's name (as in messages) and bytes, in reading order, when `keep`.
    pub(super) files: Vec<(Rc<str>, Vec<u8>)>,
    /// Each INCLUDE statement when `keep`: the including file, its first and last line, and
    /// the included file's name.
    pub(super) includes: Vec<(Rc<str>, usize, usize, Rc<str>)>,
}

/// The `SPC = n` selections of the case control section (the lines before `BEGIN BULK`, after
/// `CEND` when present), each with its line.
pub(super) fn case_control_spcs(lines: &[&str], file: &Rc<str>) -> Vec<(Loc, u64)> {
    case_control_selections(lines, file, "SPC")
}

/// The `<key> = n` selections of the case control section (as [`case_control_spcs`]).
pub(super) fn case_control_selections(
    lines: &[&str],
    file: &Rc<str>,
    key_name: &str,
) -> Vec<(Loc, u64)> {
    let start = lines
        .iter()
        .position(|l| starts_with_ci(strip_comment(l).trim(), "CEND"))
        .map_or(0, |p| p + 1);
    let mut out = Vec::new();
    for (i, raw) in lines.iter().enumerate().skip(start) {
        let text = strip_comment(raw).trim();
        let Some((key, value)) = text.split_once('=') else {
            continue;
        };
        if !key.trim().eq_ignore_ascii_case(key_name) {
            continue;
        }
        if let Some(sid) = parse_int(value.trim()).filter(|v| *v > 0) {
            out.push((
                Loc {
                    file: file.clone(),
                    line: i + 1,
                    card: Rc::from(format!("{key_name} =")),
                },
                sid as u64,
            ));
        }
    }
    out
}

impl Loader {
    /// Adds one file's bytes to the source digest (length-prefixed, so that the split between
    /// files counts too).
    pub(super) fn digest_source(&mut self, bytes: &[u8]) {
        self.source.update(&(bytes.len() as u64).to_le_bytes());
        self.source.update(bytes);
    }

    /// Reads one file's lines (recursing into INCLUDEs); returns true once ENDDATA is seen.
    pub(super) fn load(
        &mut self,
        text: &str,
        file: Rc<str>,
        dir: &Path,
        top: bool,
    ) -> Result<bool, NastranError> {
        let raw: Vec<&str> = text.lines().collect();
        let mut i = 0;
        if top && let Some(begin) = raw.iter().position(|l| is_begin_bulk(l)) {
            self.case_control = case_control_spcs(&raw[..begin], &file);
            self.case_control_mpc = case_control_selections(&raw[..begin], &file, "MPC");
            let mut method = case_control_selections(&raw[..begin], &file, "METHOD");
            method.extend(case_control_selections(&raw[..begin], &file, "METH"));
            method.sort_by_key(|(loc, _)| loc.line);
            self.case_control_method = method;
            self.has_case_control = raw[..begin]
                .iter()
                .any(|l| starts_with_ci(strip_comment(l).trim(), "CEND"));
            i = begin + 1;
        }
        while i < raw.len() {
            let line_no = i + 1;
            let full = raw[i];
            let trimmed = full.trim_start();
            if starts_with_ci(trimmed, "$femu-") {
                self.femu_comment(trimmed, &file, line_no)?;
                i += 1;
                continue;
            }
            let text = strip_comment(full).trim_end();
            if text.trim().is_empty() {
                i += 1;
                continue;
            }
            let syntax = |problem: String, valid: &str| NastranError::Syntax {
                file: file.to_string().into(),
                line: line_no,
                problem: problem.into(),
                valid: valid.into(),
            };
            if starts_with_ci(text, "INCLUDE")
                && text[7..]
                    .chars()
                    .next()
                    .is_none_or(|c| c.is_whitespace() || c == '\'' || c == '"')
            {
                let name = include_name(&raw, &mut i, &file)?;
                if self.include(&name, &file, (line_no, i + 1), dir)? {
                    return Ok(true);
                }
                i += 1;
                continue;
            }
            if starts_with_ci(text, "ENDDATA") {
                return Ok(true);
            }
            if starts_with_ci(text, "BEGIN") {
                if is_begin_bulk(text) {
                    i += 1;
                    continue;
                }
                return Err(syntax(
                    format!(
                        "`{}` starts a part superelement or auxiliary model; this file has {}",
                        q(text),
                        part_sections(&raw[i..], line_no)
                    ),
                    "femu reads one BEGIN BULK section (the residual structure): merge the parts' bulk data into it (renumbering ids that repeat) and partition the model with `model.partition` for femu's own component mode synthesis",
                ));
            }
            self.lines.push(SrcLine {
                file: file.clone(),
                line: line_no,
                text: text.to_string(),
            });
            i += 1;
        }
        Ok(false)
    }

    pub(super) fn femu_comment(
        &mut self,
        line: &str,
        file: &Rc<str>,
        line_no: usize,
    ) -> Result<(), NastranError> {
        let loc = Loc {
            file: file.clone(),
            line: line_no,
            card: Rc::from("$femu"),
        };
        let bad = |problem: String, valid: &str| NastranError::Syntax {
            file: file.to_string().into(),
            line: line_no,
            problem: problem.into(),
            valid: valid.into(),
        };
        let rest = &line[6..];
        if let Some(body) = rest.strip_prefix("set ") {
            let body = body.trim();
            let (sid, name) = body.split_once(' ').unwrap_or((body, ""));
            let sid = parse_int(sid).filter(|v| *v > 0).ok_or_else(|| {
                bad(
                    format!("`{}` has no set id", q(line)),
                    "write `$femu-set <sid> <name>`",
                )
            })?;
            let name = name.trim();
            if name.is_empty() {
                return Err(bad(
                    format!("`{}` has no set name", q(line)),
                    "write `$femu-set <sid> <name>`",
                ));
            }
            self.set_names.push((loc, sid as u64, name.to_string()));
        } else if let Some(body) = rest.strip_prefix("parameter ") {
            let p: Parameter = serde_json::from_str(body.trim()).map_err(|e| {
                bad(
                    format!(
                        "the femu parameter comment is not a valid parameter: {}",
                        excerpt(&e.to_string(), 100)
                    ),
                    "write `$femu-parameter` followed by the parameter as one line of JSON",
                )
            })?;
            self.parameters.push((loc, p));
        }
        Ok(())
    }

    pub(super) fn include(
        &mut self,
        name: &str,
        file: &Rc<str>,
        (line, last_line): (usize, usize),
        dir: &Path,
    ) -> Result<bool, NastranError> {
        let err = |problem: String, valid: &str| NastranError::Include {
            file: file.to_string().into(),
            line,
            problem: problem.into(),
            valid: valid.into(),
        };
        // Relative to the including file, as Nastran does; failing that, to the job's folder
        // (the top file's), where Nastran runs and so also looks.
        let target = if Path::new(name).is_absolute() {
            PathBuf::from(name)
        } else {
            let beside = dir.join(name);
            let in_job = self.job_dir.join(name);
            if !beside.exists() && in_job.exists() {
                in_job
            } else {
                beside
            }
        };
        let budget = self.policy.max_bytes.saturating_sub(self.used);
        let bytes = read_input_with(&target, &self.policy, budget).map_err(|e| {
            let valid = match e {
                InputError::TooLarge { .. } => {
                    "the deck and all its INCLUDEs together must fit in the input limit"
                }
                _ => "relative paths are taken from the folder of the including file",
            };
            err(format!("of `{}` failed: {e}", q(name)), valid)
        })?;
        self.used += bytes.len() as u64;
        self.digest_source(&bytes);
        let canonical = std::fs::canonicalize(&target).unwrap_or_else(|_| target.clone());
        if self.stack.contains(&canonical) {
            let chain: Vec<String> = self
                .stack
                .iter()
                .chain(std::iter::once(&canonical))
                .map(|p| p.display().to_string())
                .collect();
            return Err(err(
                format!(
                    "of `{}` closes a cycle: {}",
                    target.display(),
                    chain.join(" -> ")
                ),
                "a file may not include itself, directly or through other files",
            ));
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(err(
                format!(
                    "of `{}` nests deeper than {MAX_INCLUDE_DEPTH} files",
                    target.display()
                ),
                "flatten the include tree",
            ));
        }
        let sub_dir = target.parent().map(Path::to_path_buf).unwrap_or_default();
        self.stack.push(canonical);
        let text = String::from_utf8_lossy(&bytes).into_owned();
        let name: Rc<str> = Rc::from(target.display().to_string());
        if self.keep {
            self.includes
                .push((file.clone(), line, last_line, name.clone()));
            self.files.push((name.clone(), bytes));
        }
        let stop = self.load(&text, name, &sub_dir, false)?;
        self.stack.pop();
        Ok(stop)
    }
}

/// The file name of an INCLUDE starting at `raw[*i]`; advances `*i` over continued names.
pub(super) fn include_name(
    raw: &[&str],
    i: &mut usize,
    file: &Rc<str>,
) -> Result<String, NastranError> {
    let start = *i + 1;
    let err = |problem: &str| NastranError::Include {
        file: file.to_string().into(),
        line: start,
        problem: problem.into(),
        valid: "write INCLUDE 'path/to/file.bdf' (the quoted name may run over several lines)"
            .into(),
    };
    let rest = strip_comment(raw[*i])[7..].trim();
    let Some(quote) = rest.chars().next().filter(|c| *c == '\'' || *c == '"') else {
        return rest
            .split_whitespace()
            .next()
            .map(str::to_string)
            .ok_or_else(|| err("has no file name"));
    };
    let body = &rest[1..];
    if let Some(end) = body.find(quote) {
        return Ok(body[..end].to_string());
    }
    let mut name = body.trim_end().to_string();
    loop {
        *i += 1;
        let Some(line) = raw.get(*i) else {
            return Err(err("has a file name whose closing quote is missing"));
        };
        let piece = strip_comment(line).trim();
        if let Some(end) = piece.find(quote) {
            name.push_str(&piece[..end]);
            return Ok(name);
        }
        name.push_str(piece);
    }
}

/// The `BEGIN` sections from `rest` on (the first at line `first`): each with its line and the
/// number of bulk data lines in it (comments and blank lines not counted), for the message
/// that refuses part superelements, so the user sees the whole of what is not read.
fn part_sections(rest: &[&str], first: usize) -> String {
    let mut sections: Vec<(String, usize, usize)> = Vec::new();
    for (k, l) in rest.iter().enumerate() {
        let text = strip_comment(l).trim();
        if starts_with_ci(text, "ENDDATA") {
            break;
        }
        if starts_with_ci(text, "BEGIN") {
            sections.push((text.to_string(), first + k, 0));
        } else if !text.is_empty()
            && let Some(s) = sections.last_mut()
        {
            s.2 += 1;
        }
    }
    let listed: Vec<String> = sections
        .iter()
        .map(|(t, line, n)| format!("`{}` at line {line} ({n} lines)", q(t)))
        .collect();
    format!("{} such section(s): {}", sections.len(), listed.join(", "))
}
