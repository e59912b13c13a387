//! Nastran bulk data import: reads a `.bdf`/`.dat` deck into a [`Model`].
//!
//! Field layouts follow the MSC Nastran Quick Reference Guide (QRG). Field numbers in messages
//! are the QRG's: 1–10 on each line of a card, with continuation lines counted from 1.
//!
//! Formats: small field (8 characters), large field (16 characters, `NAME*` and `*`
//! continuation half-lines), free field (commas; `NAME*,` for four fields per line), explicit
//! (`+name`/`*name`) and implicit (blank first field) continuations, `$` comments, `INCLUDE`
//! (quoted or bare, relative to the including file, quoted names may run over several lines,
//! cycles rejected), `BEGIN BULK` (anything before it is skipped when present) and `ENDDATA`
//! (anything after it is ignored), the real number shorthands `1.5-3`, `7.+4`, `.5`, `1+3`,
//! `1.E3` and `1D3`, and blank fields taking the QRG defaults.
//!
//! Cards read: GRID, CORD2R, CQUAD4, CTRIA3, CBAR, CBEAM, PSHELL, PBAR, PBARL (BAR, ROD, TUBE),
//! PBEAM, MAT1, CELAS1 with PELAS, CELAS2, CBUSH with PBUSH, CONM2, SPC, SPC1, SET1. Cards that
//! change neither stiffness, mass nor constraints ([`SKIPPED_CARDS`], PARAMs of
//! [`SKIPPED_PARAMS`], `PARAM,WTMASS,1.0`) are skipped and counted in [`BulkImport::skipped`];
//! every other card is an error naming file, line and card unless the user lists it in
//! [`BulkOptions::ignore_cards`] (then it is counted in [`BulkImport::ignored`]).
//! `PARAM,WTMASS` ≠ 1 is an error. A deck without elements is an error.
//!
//! Files are read through [`crate::core::input`] (regular files only, bounded size, optional
//! confinement). Messages quote at most [`EXCERPT_CHARS`] characters of a line, and nothing of a
//! file in which no Nastran card has been seen.
//!
//! Values femu's elements cannot take are refused at the card, so that `femu validate` finds
//! them: MAT1 E > 0 (given or derived), G ≥ 0, −1 < NU ≤ 0.5 (< 0.5 for shells), RHO ≥ 0;
//! PSHELL T > 0; PBAR/PBEAM A, I1, I2 > 0, J, K1, K2 ≥ 0; NSM ≥ 0; spring stiffnesses ≥ 0; CONM2
//! mass ≥ 0. Every element is then checked as the assembly would check it, naming its card.
//!
//! Deviations from Nastran, each stated where it happens:
//! - GRID: CP must be 0 or a CORD2R id. CD ≠ 0 is ignored with a warning: PS, SPC and spring
//!   components are taken in the basic system. SEID is ignored.
//! - CORD2R: RID must be 0 or another CORD2R (chains are resolved; cycles are errors).
//! - CQUAD4/CTRIA3: ZOFFS ≠ 0 is an error; THETA/MCID is ignored (isotropic material);
//!   corner thicknesses T1–T4 are ignored with a warning (the PSHELL T is used).
//! - CBAR/CBEAM: the orientation is X1–X3 (taken in the basic system, as CD is ignored) or G0;
//!   a blank orientation (BAROR/BEAMOR defaults) is an error. Pin flags PA/PB and offsets
//!   W1A–W3B ≠ 0 are errors; CBEAM warping points SA/SB are ignored with a warning.
//! - PSHELL: MID1 is the material for membrane and bending. MID2 blank (no bending in Nastran)
//!   or different from MID1, MID3 different from MID1, MID4 given or 12I/T³ ≠ 1 give warnings.
//!   T must be given (> 0).
//! - PBAR: I1 (plane 1) is the second moment about the element z axis, I2 about y; K1/K2 blank
//!   or 0 mean no shear flexibility; I12 ≠ 0 is an error; stress points are ignored.
//! - PBARL: GROUP must be blank or MSCBML0; TYPE BAR (DIM1 → `width`, DIM2 → `height`; the QRG
//!   figure puts DIM1 along element z and DIM2 along element y, so I1 = DIM1·DIM2³/12), ROD
//!   (DIM1 radius) and TUBE (DIM1 outer, DIM2 inner radius) only.
//! - PBEAM: end A only; stations must repeat the end-A values (blank or equal) — a tapered beam
//!   is an error. K1/K2 default 1.0 (0 = no shear flexibility). I12 ≠ 0 is an error; NSI, CW and
//!   the M/N offsets are ignored with a warning.
//! - MAT1: a blank E, G or NU is derived from the other two (E = 2(1+NU)G). With only E given,
//!   NU = 0 (Nastran sets G = 0; femu's isotropic material has G = E/2) with a warning. When all
//!   three are given and inconsistent, E and NU are kept and a warning names the G used.
//! - CELAS1/CELAS2/PELAS: grid points only (no scalar points); GE and S are ignored (GE ≠ 0 warns).
//! - CBUSH/PBUSH: only the K line is used (B, GE, RCV, M… ignored with a warning); the element
//!   system (CID ≠ 0, orientation vector or G0) is ignored with a warning — stiffness acts along
//!   the basic axes. The spring location (S, OCID, S1–S3) is ignored with a warning.
//! - CONM2: CID 0 (offset X1–X3) or −1 (X1–X3 are the basic coordinates of the centre of
//!   gravity); any other CID is an error.
//! - SPC: D must be 0. SPC and SPC1 of every SID are merged into one constraint list (there is no
//!   case control to choose one); several SIDs give a warning. THRU ranges cover the grids that
//!   exist. Constraints come back sorted and without repeats.
//! - SET1: element ids (with THRU over existing elements, optional SKIN) → set `set<SID>`, ids
//!   sorted without repeats.
//! - Integers are accepted where a real is expected (Nastran wants a decimal point), except where
//!   the type decides the meaning (CBAR/CBEAM/CBUSH X1 against G0).
//! - Unsorted decks (continuations away from their parent) and replication (`=`) are not
//!   supported; a free-field line may hold at most ten fields.
//! - femu extensions written by the exporter and read back: `$femu-set <sid> <name>` names the
//!   SET1 `<sid>` (or an empty set), `$femu-parameter <json>` holds an updating parameter.
//!
//! After reading, [`Model::add_property_sets`] adds `pid<N>` sets and [`Model::validate`] checks
//! every reference; a failure names the card that holds the dangling reference.

use crate::core::input::{EXCERPT_CHARS, InputError, InputPolicy, excerpt, read_input_with};
use crate::core::{Component, DofId};
use crate::model::structure::{
    BeamProperty, BeamSection, Element, Material, Model, ModelError, Parameter, ShellProperty,
};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Deepest INCLUDE nesting accepted.
const MAX_INCLUDE_DEPTH: usize = 64;

/// Cards femu reads.
pub const READ_CARDS: [&str; 20] = [
    "GRID", "CORD2R", "CQUAD4", "CTRIA3", "CBAR", "CBEAM", "PSHELL", "PBAR", "PBARL", "PBEAM",
    "MAT1", "CELAS1", "CELAS2", "PELAS", "CBUSH", "PBUSH", "CONM2", "SPC", "SPC1", "SET1",
];

/// Cards skipped (counted) because they change neither stiffness, mass nor constraints: static
/// and dynamic loads and their tables, temperatures (femu has no temperature-dependent
/// material, and MATT1 is refused), eigenvalue and frequency-response control, plot elements,
/// and coordinate systems other than CORD2R (a GRID or element that uses one is an error).
pub const SKIPPED_CARDS: [&str; 46] = [
    "FORCE", "FORCE1", "FORCE2", "MOMENT", "MOMENT1", "MOMENT2", "LOAD", "PLOAD", "PLOAD1",
    "PLOAD2", "PLOAD4", "GRAV", "RFORCE", "ACCEL", "ACCEL1", "LSEQ", "DAREA", "DLOAD", "RLOAD1",
    "RLOAD2", "TLOAD1", "TLOAD2", "DPHASE", "DELAY", "TABLED1", "TABLED2", "TABLED3", "TABLED4",
    "TEMP", "TEMPD", "EIGRL", "EIGR", "EIGC", "EIGB", "FREQ", "FREQ1", "FREQ2", "FREQ3", "FREQ4",
    "TSTEP", "PLOTEL", "CORD1R", "CORD1C", "CORD1S", "CORD2C", "CORD2S",
];

/// PARAM names skipped (counted): output and diagnostics only. `PARAM,WTMASS,1.0` is skipped
/// too; any other WTMASS is an error (it scales the mass matrix, which femu does not do).
pub const SKIPPED_PARAMS: [&str; 11] = [
    "POST", "POSTEXT", "PATVER", "PRGPST", "GRDPNT", "MAXRATIO", "BAILOUT", "NOCOMPS", "OGEOM",
    "OUGCORD", "PRTMAXIM",
];

/// Nastran cards femu does not read that change the stiffness, mass, damping or constraints;
/// an error unless listed in [`BulkOptions::ignore_cards`] (the list only decides how messages
/// name them: any other unread card is an error too).
const REFUSED_CARDS: [&str; 83] = [
    "RBE1", "RBE2", "RBE3", "RBAR", "RBAR1", "RROD", "RTRPLT", "RSPLINE", "MPC", "MPCADD",
    "SPCADD", "SPCD", "SUPORT", "SUPORT1", "ASET", "ASET1", "OMIT", "OMIT1", "QSET", "QSET1",
    "BSET", "BSET1", "CSET", "CSET1", "SPOINT", "EPOINT", "GRDSET", "CROD", "CONROD", "CTUBE",
    "PROD", "PTUBE", "CQUAD8", "CQUADR", "CQUAD", "CTRIA6", "CTRIAR", "CSHEAR", "PSHEAR", "CHEXA",
    "CPENTA", "CTETRA", "CPYRAM", "PSOLID", "PCOMP", "PCOMPG", "MAT2", "MAT8", "MAT9", "MAT10",
    "MATT1", "MATS1", "CONM1", "CMASS1", "CMASS2", "CMASS3", "CMASS4", "PMASS", "CDAMP1", "CDAMP2",
    "CDAMP3", "CDAMP4", "CDAMP5", "PDAMP", "CVISC", "PVISC", "CELAS3", "CELAS4", "CBUSH1D",
    "PBUSH1D", "CGAP", "PGAP", "CWELD", "PWELD", "CFAST", "PFAST", "NSM", "NSM1", "NSML", "NSML1",
    "DMIG", "GENEL", "PBEAML",
];

/// Whether `name` is a card name Nastran could have written: a letter, then letters or digits,
/// at most 8 characters.
fn is_card_name(name: &str) -> bool {
    let b = name.as_bytes();
    !b.is_empty()
        && b.len() <= 8
        && b[0].is_ascii_alphabetic()
        && b.iter().all(|c| c.is_ascii_alphanumeric())
}

/// Whether `name` is a card femu knows to be Nastran's (read, skipped or refused).
fn is_known_card(name: &str) -> bool {
    name == "PARAM"
        || READ_CARDS.contains(&name)
        || SKIPPED_CARDS.contains(&name)
        || REFUSED_CARDS.contains(&name)
}

/// A model read from a bulk data deck, with what was skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct BulkImport {
    /// The model (with `pid<N>` sets added, validated).
    pub model: Model,
    /// Cards that are not read, by name (`PARAM,NAME` for PARAM), with how often each occurs:
    /// the union of `skipped` and `ignored`.
    pub unknown: BTreeMap<String, usize>,
    /// Cards skipped because they do not change the stiffness, mass or constraints (loads,
    /// analysis and output control), with their counts.
    pub skipped: BTreeMap<String, usize>,
    /// Cards dropped because the user listed them in [`BulkOptions::ignore_cards`], with counts.
    pub ignored: BTreeMap<String, usize>,
    /// Deviations from Nastran's meaning that did not stop the import, each naming file and line.
    pub warnings: Vec<String>,
}

/// Why a bulk data deck could not be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NastranError {
    /// A file could not be read.
    #[error("cannot read Nastran bulk data file `{path}`: {message}")]
    Io {
        /// The path.
        path: Box<str>,
        /// The operating system's message.
        message: Box<str>,
    },
    /// An INCLUDE statement that cannot be followed.
    #[error("{file} line {line}: INCLUDE {problem}; {valid}")]
    Include {
        /// File holding the INCLUDE.
        file: Box<str>,
        /// Its line.
        line: usize,
        /// What is wrong.
        problem: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// A line that is neither a card, a continuation nor a comment.
    #[error("{file} line {line}: {problem}; {valid}")]
    Syntax {
        /// File.
        file: Box<str>,
        /// Line.
        line: usize,
        /// What is wrong.
        problem: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// A field of a card is malformed, missing, unsupported or refers to nothing.
    #[error(
        "{file} line {line}: {card} field {field} ({label}){}: {problem}; {valid}",
        row_note(.row, .field_line, .line)
    )]
    Field {
        /// File.
        file: Box<str>,
        /// Line of the card's first line.
        line: usize,
        /// Card name.
        card: Box<str>,
        /// Continuation holding the field (0: the card's first line).
        row: usize,
        /// Field number 1–10 on that line, as in the QRG.
        field: usize,
        /// File line holding the field.
        field_line: usize,
        /// The QRG's name for the field.
        label: Box<str>,
        /// What is wrong.
        problem: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// An id defined twice.
    #[error(
        "{file} line {line}: {card} field {field} ({label}): {what} {id} is already defined at {first}; ids must be unique"
    )]
    Duplicate {
        /// File.
        file: Box<str>,
        /// Line of the second definition.
        line: usize,
        /// Card name.
        card: Box<str>,
        /// Field number of the id, as in the QRG.
        field: usize,
        /// The QRG's name for the field.
        label: &'static str,
        /// Kind of id (grid, element, property, …).
        what: &'static str,
        /// The id.
        id: u64,
        /// Where the first definition is (`file line N`).
        first: Box<str>,
    },
    /// An element femu's assembly cannot build from the values of its cards.
    #[error(
        "{file} line {line}: {card} {id}{uses}: {message}; correct the element's grids or the property and material it uses"
    )]
    Element {
        /// File of the element card.
        file: Box<str>,
        /// Its line.
        line: usize,
        /// The element card's name.
        card: Box<str>,
        /// Element id.
        id: u64,
        /// The property and material it uses, with where they are defined.
        uses: Box<str>,
        /// What the element check found.
        message: Box<str>,
    },
    /// The deck defines no element: nothing to assemble.
    #[error("{file}: {problem}; {valid}")]
    Empty {
        /// The top file.
        file: Box<str>,
        /// What was found.
        problem: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// The deck is complete but inconsistent (a reference to something not defined).
    #[error("{file} line {line}: {source}; {valid}")]
    Model {
        /// File of the card holding the reference.
        file: Box<str>,
        /// Its line.
        line: usize,
        /// The model check that failed.
        source: ModelError,
        /// What would be valid.
        valid: Box<str>,
    },
}

fn row_note(row: &usize, field_line: &usize, line: &usize) -> String {
    if *row > 0 {
        format!(" of continuation {row} (line {field_line})")
    } else if field_line != line {
        format!(" (line {field_line})")
    } else {
        String::new()
    }
}

/// Choices of the user that change what an import accepts.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BulkOptions {
    /// Card names (upper case; `PARAM,NAME` for one PARAM) the user accepts to drop although
    /// they may change the stiffness, mass or constraints.
    pub ignore_cards: BTreeSet<String>,
}

/// Reads a bulk data file (and the files it includes) under the process-wide input policy,
/// refusing every card it does not read unless it is known to be harmless.
pub fn read_bulk(path: impl AsRef<Path>) -> Result<BulkImport, NastranError> {
    read_bulk_with(path, &BulkOptions::default())
}

/// [`read_bulk`] with options.
pub fn read_bulk_with(
    path: impl AsRef<Path>,
    options: &BulkOptions,
) -> Result<BulkImport, NastranError> {
    let path = path.as_ref();
    let io = |e: InputError| NastranError::Io {
        path: path.display().to_string().into(),
        message: e.to_string().into(),
    };
    let policy = crate::core::input::policy().map_err(io)?;
    let bytes = read_input_with(path, &policy, policy.max_bytes).map_err(io)?;
    parse_with_policy(
        &String::from_utf8_lossy(&bytes),
        &path.display().to_string(),
        options,
        policy,
        bytes.len() as u64,
    )
}

/// Parses bulk data text; `file_name` names it in messages and anchors relative INCLUDEs
/// (read under the process-wide input policy).
pub fn parse_bulk(text: &str, file_name: &str) -> Result<BulkImport, NastranError> {
    parse_bulk_with(text, file_name, &BulkOptions::default())
}

/// [`parse_bulk`] with options.
pub fn parse_bulk_with(
    text: &str,
    file_name: &str,
    options: &BulkOptions,
) -> Result<BulkImport, NastranError> {
    let policy = crate::core::input::policy().map_err(|e| NastranError::Io {
        path: file_name.into(),
        message: e.to_string().into(),
    })?;
    parse_with_policy(text, file_name, options, policy, text.len() as u64)
}

fn parse_with_policy(
    text: &str,
    file_name: &str,
    options: &BulkOptions,
    policy: InputPolicy,
    used: u64,
) -> Result<BulkImport, NastranError> {
    let path = Path::new(file_name);
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut loader = Loader {
        policy,
        used,
        ..Loader::default()
    };
    loader
        .stack
        .push(std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()));
    loader.load(text, Rc::from(file_name), &dir, true)?;
    let cards = assemble(&loader.lines, &mut loader.warnings)?;
    let mut builder = Builder {
        top_file: Rc::from(file_name),
        warnings: std::mem::take(&mut loader.warnings),
        ignore: options.ignore_cards.clone(),
        ..Builder::default()
    };
    for card in &cards {
        builder.card(card)?;
    }
    builder.finish(loader.set_names, loader.parameters)
}

// ---------------------------------------------------------------------------------------------
// Numbers

/// Parses a Nastran integer field.
fn parse_int(text: &str) -> Option<i64> {
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
fn parse_components(text: &str) -> Option<Vec<Component>> {
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
fn q(s: &str) -> String {
    excerpt(s, EXCERPT_CHARS)
}

fn starts_with_ci(s: &str, prefix: &str) -> bool {
    s.get(..prefix.len())
        .is_some_and(|head| head.eq_ignore_ascii_case(prefix))
}

fn strip_comment(line: &str) -> &str {
    match line.find('$') {
        Some(i) => &line[..i],
        None => line,
    }
}

fn is_begin_bulk(line: &str) -> bool {
    let squeezed: String = strip_comment(line)
        .chars()
        .filter(|c| !c.is_whitespace() && *c != ',')
        .collect();
    starts_with_ci(&squeezed, "BEGINBULK")
}

// ---------------------------------------------------------------------------------------------
// Files and lines

/// One significant line of the deck (comment removed).
struct SrcLine {
    file: Rc<str>,
    line: usize,
    text: String,
}

/// Where a card starts.
#[derive(Clone, Debug)]
struct Loc {
    file: Rc<str>,
    line: usize,
    card: Rc<str>,
}

impl Loc {
    fn err(
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

    fn field_err(
        &self,
        k: usize,
        label: &str,
        problem: impl Into<Box<str>>,
        valid: impl Into<Box<str>>,
    ) -> NastranError {
        self.err(k, self.line, label, problem, valid)
    }

    fn place(&self) -> String {
        format!("{} line {}", self.file, self.line)
    }
}

#[derive(Default)]
struct Loader {
    /// How INCLUDEd files may be read.
    policy: InputPolicy,
    /// Bytes read so far (the deck and its INCLUDEs share the policy's limit).
    used: u64,
    lines: Vec<SrcLine>,
    warnings: Vec<String>,
    stack: Vec<PathBuf>,
    set_names: Vec<(Loc, u64, String)>,
    parameters: Vec<(Loc, Parameter)>,
}

impl Loader {
    /// Reads one file's lines (recursing into INCLUDEs); returns true once ENDDATA is seen.
    fn load(
        &mut self,
        text: &str,
        file: Rc<str>,
        dir: &Path,
        top: bool,
    ) -> Result<bool, NastranError> {
        let raw: Vec<&str> = text.lines().collect();
        let mut i = 0;
        if top {
            if let Some(begin) = raw.iter().position(|l| is_begin_bulk(l)) {
                i = begin + 1;
            }
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
                if self.include(&name, &file, line_no, dir)? {
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
                        "`{}` starts a part superelement or auxiliary model",
                        q(text)
                    ),
                    "only one BEGIN BULK section is supported",
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

    fn femu_comment(
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

    fn include(
        &mut self,
        name: &str,
        file: &Rc<str>,
        line: usize,
        dir: &Path,
    ) -> Result<bool, NastranError> {
        let err = |problem: String, valid: &str| NastranError::Include {
            file: file.to_string().into(),
            line,
            problem: problem.into(),
            valid: valid.into(),
        };
        let target = if Path::new(name).is_absolute() {
            PathBuf::from(name)
        } else {
            dir.join(name)
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
        let stop = self.load(
            &text,
            Rc::from(target.display().to_string()),
            &sub_dir,
            false,
        )?;
        self.stack.pop();
        Ok(stop)
    }
}

/// The file name of an INCLUDE starting at `raw[*i]`; advances `*i` over continued names.
fn include_name(raw: &[&str], i: &mut usize, file: &Rc<str>) -> Result<String, NastranError> {
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

// ---------------------------------------------------------------------------------------------
// Cards

/// Explicit ids and inclusive `THRU` ranges of a list field.
type IdList = (Vec<u64>, Vec<(u64, u64)>);

/// One data field with the file line that holds it.
struct Field {
    text: String,
    line: usize,
}

/// A whole card: its name and its data fields in QRG order (`fields[k - 1]` is data field `k`;
/// field `k` sits on continuation `(k - 1) / 8` at QRG field `(k - 1) % 8 + 2`).
struct Card {
    name: String,
    loc: Loc,
    fields: Vec<Field>,
    /// A large-field first half-line was read and its second half is still to come.
    half_open: bool,
    /// Whether a card femu knows came before this one in its file, so that quoting the file's
    /// text in a message shows Nastran data, not some other file named by mistake.
    nastran_like: bool,
}

/// One physical line split into fields.
struct Split {
    first: String,
    data: Vec<String>,
    cont: String,
    large: bool,
}

fn split_line(
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
    fn push(&mut self, split: Split, line: usize) {
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

    fn text(&self, k: usize) -> &str {
        k.checked_sub(1)
            .and_then(|i| self.fields.get(i))
            .map_or("", |f| f.text.as_str())
    }

    fn blank(&self, k: usize) -> bool {
        self.text(k).is_empty()
    }

    fn word(&self, k: usize) -> String {
        self.text(k).to_ascii_uppercase()
    }

    fn err(
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

    fn int(&self, k: usize, label: &str) -> Result<Option<i64>, NastranError> {
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

    fn id(&self, k: usize, label: &str) -> Result<u64, NastranError> {
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

    fn id_or(&self, k: usize, label: &str, default: u64) -> Result<u64, NastranError> {
        if self.blank(k) {
            Ok(default)
        } else {
            self.id(k, label)
        }
    }

    /// A grid id that may be blank or 0 (ground).
    fn opt_grid(&self, k: usize, label: &str) -> Result<Option<u64>, NastranError> {
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

    fn nonneg(&self, k: usize, label: &str, what: &str) -> Result<u64, NastranError> {
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

    fn real(&self, k: usize, label: &str) -> Result<Option<f64>, NastranError> {
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

    fn real_or(&self, k: usize, label: &str, default: f64) -> Result<f64, NastranError> {
        Ok(self.real(k, label)?.unwrap_or(default))
    }

    fn req_real(&self, k: usize, label: &str) -> Result<f64, NastranError> {
        self.real(k, label)?
            .ok_or_else(|| self.err(k, label, "the field is blank", "a real number is required"))
    }

    fn positive(&self, k: usize, label: &str) -> Result<f64, NastranError> {
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
    fn nonneg_real(&self, k: usize, label: &str, default: f64) -> Result<f64, NastranError> {
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

    fn comps(&self, k: usize, label: &str) -> Result<Vec<Component>, NastranError> {
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

    fn one_comp(&self, k: usize, label: &str) -> Result<Component, NastranError> {
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
    fn zero(&self, k: usize, label: &str, valid: &str) -> Result<(), NastranError> {
        let v = self.real_or(k, label, 0.0)?;
        if v != 0.0 {
            return Err(self.err(k, label, format!("{v} is not supported"), valid));
        }
        Ok(())
    }

    /// Ids with `THRU` ranges from field `k` on: explicit ids and inclusive ranges.
    fn id_list(&self, from: usize, label: &str) -> Result<IdList, NastranError> {
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
fn not_nastran(file: &str, line: usize) -> NastranError {
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
fn assemble(lines: &[SrcLine], warnings: &mut Vec<String>) -> Result<Vec<Card>, NastranError> {
    let mut cards: Vec<Card> = Vec::new();
    let mut last_cont = String::new();
    let mut beyond: BTreeMap<Rc<str>, (usize, usize)> = BTreeMap::new();
    let mut nastran_like: BTreeSet<Rc<str>> = BTreeSet::new();
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
            return Err(syntax(
                "replication (`=`, `==`) is not supported".to_string(),
                "write each card in full",
            ));
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

// ---------------------------------------------------------------------------------------------
// Building the model

struct GridIn {
    loc: Loc,
    cp: u64,
    x: [f64; 3],
    cd: i64,
    ps: Vec<Component>,
}

struct CordIn {
    loc: Loc,
    rid: u64,
    points: [[f64; 3]; 3],
}

enum Orient {
    Vector([f64; 3]),
    G0(u64),
}

enum ElemIn {
    Done(Element),
    Beam {
        nodes: [u64; 2],
        property: u64,
        orient: Orient,
    },
    Celas1 {
        pid: u64,
        dof: DofId,
        other: Option<DofId>,
    },
    Bush {
        pid: u64,
        node: u64,
        other: Option<u64>,
    },
    MassAbsolute {
        node: u64,
        mass: f64,
        inertia: [f64; 6],
        cg: [f64; 3],
    },
}

struct SetIn {
    loc: Loc,
    ids: Vec<u64>,
    ranges: Vec<(u64, u64)>,
}

/// A rectangular frame: origin and unit axes (rows) in the basic system.
#[derive(Clone, Copy)]
struct Frame {
    origin: [f64; 3],
    axes: [[f64; 3]; 3],
}

impl Frame {
    const BASIC: Frame = Frame {
        origin: [0.0; 3],
        axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    fn to_basic(self, p: [f64; 3]) -> [f64; 3] {
        let mut out = self.origin;
        for (i, o) in out.iter_mut().enumerate() {
            *o += p[0] * self.axes[0][i] + p[1] * self.axes[1][i] + p[2] * self.axes[2][i];
        }
        out
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[derive(Default)]
struct Builder {
    top_file: Rc<str>,
    warnings: Vec<String>,
    /// Card names the user accepts to drop.
    ignore: BTreeSet<String>,
    skipped: BTreeMap<String, usize>,
    ignored: BTreeMap<String, usize>,
    grids: BTreeMap<u64, GridIn>,
    cords: BTreeMap<u64, CordIn>,
    materials: BTreeMap<u64, (Loc, Material)>,
    shells: BTreeMap<u64, ShellProperty>,
    beams: BTreeMap<u64, BeamProperty>,
    pelas: BTreeMap<u64, f64>,
    pbush: BTreeMap<u64, [f64; 6]>,
    pids: BTreeMap<u64, Loc>,
    elements: BTreeMap<u64, (Loc, ElemIn)>,
    spcs: Vec<(Loc, DofId)>,
    spc_ranges: Vec<(Loc, Vec<Component>, u64, u64)>,
    spc_sids: BTreeSet<u64>,
    sets: BTreeMap<u64, SetIn>,
}

/// The error for an id (data field `k`, always on the card's first line) defined twice.
fn duplicate(
    card: &Card,
    k: usize,
    label: &'static str,
    what: &'static str,
    id: u64,
    first: &Loc,
) -> NastranError {
    NastranError::Duplicate {
        file: card.loc.file.to_string().into(),
        line: card.loc.line,
        card: card.name.as_str().into(),
        field: k + 1,
        label,
        what,
        id,
        first: first.place().into(),
    }
}

const OFFSET_HELP: &str = "offsets and pin flags are not supported: leave them blank or 0 and place the grid points on the axis";

impl Builder {
    fn warn(&mut self, loc: &Loc, id: u64, text: impl std::fmt::Display) {
        self.warnings.push(format!(
            "{} line {}: {} {id}: {text}",
            loc.file, loc.line, loc.card
        ));
    }

    fn card(&mut self, c: &Card) -> Result<(), NastranError> {
        match c.name.as_str() {
            "GRID" => self.grid(c),
            "CORD2R" => self.cord2r(c),
            "CQUAD4" | "CTRIA3" => self.shell_element(c),
            "CBAR" | "CBEAM" => self.beam_element(c),
            "PSHELL" => self.pshell(c),
            "PBAR" => self.pbar(c),
            "PBARL" => self.pbarl(c),
            "PBEAM" => self.pbeam(c),
            "MAT1" => self.mat1(c),
            "CELAS1" | "CELAS2" => self.celas(c),
            "PELAS" => self.pelas_card(c),
            "CBUSH" => self.cbush(c),
            "PBUSH" => self.pbush_card(c),
            "CONM2" => self.conm2(c),
            "SPC" => self.spc(c),
            "SPC1" => self.spc1(c),
            "SET1" => self.set1(c),
            "PARAM" => self.param(c),
            other if SKIPPED_CARDS.contains(&other) => {
                *self.skipped.entry(other.to_string()).or_insert(0) += 1;
                Ok(())
            }
            other => self.unread(c, other, other),
        }
    }

    /// A card femu does not read: dropped when the user asked for it, else an error.
    fn unread(&mut self, c: &Card, key: &str, name: &str) -> Result<(), NastranError> {
        if self.ignore.contains(key) || self.ignore.contains(name) {
            *self.ignored.entry(key.to_string()).or_insert(0) += 1;
            return Ok(());
        }
        if !(c.nastran_like || is_known_card(name)) {
            return Err(not_nastran(&c.loc.file, c.loc.line));
        }
        Err(NastranError::Syntax {
            file: c.loc.file.to_string().into(),
            line: c.loc.line,
            problem: format!(
                "{} is not read by femu and may change the stiffness, mass or constraints, so the deck cannot be imported as it is",
                q(key)
            )
            .into(),
            valid: format!(
                "femu reads {}; it skips loads, analysis and output cards ({}, …) and PARAM {}; to drop {} knowingly, add it to the stage's `ignore_cards`",
                READ_CARDS.join(", "),
                SKIPPED_CARDS[..6].join(", "),
                SKIPPED_PARAMS.join(", "),
                q(key)
            )
            .into(),
        })
    }

    fn param(&mut self, c: &Card) -> Result<(), NastranError> {
        let name = c.word(1);
        if !is_card_name(&name) {
            return Err(c.err(
                1,
                "N",
                format!("`{}` is not a parameter name", q(&name)),
                "a name of at most 8 letters and digits, starting with a letter",
            ));
        }
        let key = format!("PARAM,{name}");
        if name == "WTMASS" {
            let w = c.real_or(2, "V1", 1.0)?;
            if w != 1.0 {
                return Err(c.err(
                    2,
                    "V1",
                    format!("WTMASS {w} scales the mass matrix, which femu does not implement"),
                    "remove PARAM,WTMASS and write masses and densities in consistent (SI) units, or set it to 1.0",
                ));
            }
        } else if !SKIPPED_PARAMS.contains(&name.as_str()) {
            return self.unread(c, &key, "PARAM");
        }
        *self.skipped.entry(key).or_insert(0) += 1;
        Ok(())
    }

    fn new_element(&mut self, c: &Card, id: u64, e: ElemIn) -> Result<(), NastranError> {
        if let Some((first, _)) = self.elements.get(&id) {
            return Err(duplicate(c, 1, "EID", "element", id, first));
        }
        self.elements.insert(id, (c.loc.clone(), e));
        Ok(())
    }

    fn new_property(
        &mut self,
        c: &Card,
        k: usize,
        label: &'static str,
        id: u64,
    ) -> Result<(), NastranError> {
        if let Some(first) = self.pids.get(&id) {
            return Err(duplicate(c, k, label, "property", id, first));
        }
        self.pids.insert(id, c.loc.clone());
        Ok(())
    }

    fn grid(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "ID")?;
        let cp = c.nonneg(2, "CP", "0 or a coordinate system id")?;
        let x = [
            c.real_or(3, "X1", 0.0)?,
            c.real_or(4, "X2", 0.0)?,
            c.real_or(5, "X3", 0.0)?,
        ];
        let cd = c.int(6, "CD")?.unwrap_or(0);
        let ps = c.comps(7, "PS")?;
        if let Some(first) = self.grids.get(&id) {
            return Err(duplicate(c, 1, "ID", "grid", id, &first.loc));
        }
        self.grids.insert(
            id,
            GridIn {
                loc: c.loc.clone(),
                cp,
                x,
                cd,
                ps,
            },
        );
        Ok(())
    }

    fn cord2r(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "CID")?;
        let rid = c.nonneg(2, "RID", "0 or a CORD2R id")?;
        let labels = ["A1", "A2", "A3", "B1", "B2", "B3", "C1", "C2", "C3"];
        let mut points = [[0.0; 3]; 3];
        for (j, label) in labels.iter().enumerate() {
            points[j / 3][j % 3] = c.real_or(3 + j, label, 0.0)?;
        }
        if let Some(first) = self.cords.get(&id) {
            return Err(duplicate(c, 1, "CID", "coordinate system", id, &first.loc));
        }
        self.cords.insert(
            id,
            CordIn {
                loc: c.loc.clone(),
                rid,
                points,
            },
        );
        Ok(())
    }

    fn shell_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let quad = c.name == "CQUAD4";
        let n = if quad { 4 } else { 3 };
        let id = c.id(1, "EID")?;
        let property = c.id_or(2, "PID", id)?;
        let mut nodes = [0u64; 4];
        for (j, g) in nodes.iter_mut().take(n).enumerate() {
            *g = c.id(3 + j, ["G1", "G2", "G3", "G4"][j])?;
        }
        for j in 0..n {
            for i in 0..j {
                if nodes[i] == nodes[j] {
                    return Err(c.err(
                        3 + j,
                        ["G1", "G2", "G3", "G4"][j],
                        format!("grid {} appears twice", nodes[j]),
                        "the corner grids must be distinct",
                    ));
                }
            }
        }
        let theta_k = 3 + n;
        if !c.blank(theta_k) {
            c.real(theta_k, "THETA/MCID")?;
        }
        c.zero(
            theta_k + 1,
            "ZOFFS",
            "shell offsets are not supported: leave ZOFFS blank or 0",
        )?;
        if (11..11 + n).any(|k| !c.blank(k)) {
            for k in 11..11 + n {
                c.real(k, "Ti")?;
            }
            self.warn(
                &c.loc,
                id,
                "corner thicknesses T1-T4 are ignored; the PSHELL thickness is used",
            );
        }
        let e = if quad {
            Element::Quad4 { nodes, property }
        } else {
            Element::Tria3 {
                nodes: [nodes[0], nodes[1], nodes[2]],
                property,
            }
        };
        self.new_element(c, id, ElemIn::Done(e))
    }

    /// Reads an orientation X1-X3 or G0 starting at field `k`; `None` when all blank.
    fn orientation(c: &Card, k: usize) -> Result<Option<Orient>, NastranError> {
        let t = c.text(k);
        if t.is_empty() {
            if c.blank(k + 1) && c.blank(k + 2) {
                return Ok(None);
            }
            return Ok(Some(Orient::Vector([
                0.0,
                c.real_or(k + 1, "X2", 0.0)?,
                c.real_or(k + 2, "X3", 0.0)?,
            ])));
        }
        if parse_int(t).is_some() {
            let g0 = c.id(k, "G0")?;
            for (j, label) in [(k + 1, "X2"), (k + 2, "X3")] {
                if !c.blank(j) {
                    return Err(c.err(
                        j,
                        label,
                        format!("`{}` given with G0 {g0}", q(c.text(j))),
                        "with an integer G0 in the X1 field, X2 and X3 must be blank",
                    ));
                }
            }
            return Ok(Some(Orient::G0(g0)));
        }
        Ok(Some(Orient::Vector([
            c.req_real(k, "X1")?,
            c.real_or(k + 1, "X2", 0.0)?,
            c.real_or(k + 2, "X3", 0.0)?,
        ])))
    }

    fn beam_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let beam = c.name == "CBEAM";
        let id = c.id(1, "EID")?;
        let property = c.id_or(2, "PID", id)?;
        let ga = c.id(3, "GA")?;
        let gb = c.id(4, "GB")?;
        if ga == gb {
            return Err(c.err(
                4,
                "GB",
                format!("GB is GA ({ga})"),
                "the two end grids must differ",
            ));
        }
        let Some(orient) = Self::orientation(c, 5)? else {
            return Err(c.err(
                5,
                "X1/G0",
                "no orientation vector or G0 is given",
                "give X1-X3 (reals) or a grid id G0; BAROR/BEAMOR defaults are not supported",
            ));
        };
        let offt = c.word(8);
        if !offt.is_empty() {
            let valid_offt = ["GGG", "BGG", "GGO", "BGO", "GOG", "BOG", "GOO", "BOO"];
            if !(valid_offt.contains(&offt.as_str()) || beam && parse_real(&offt).is_some()) {
                return Err(c.err(
                    8,
                    if beam { "OFFT/BIT" } else { "OFFT" },
                    format!("`{}` is not an offset flag", q(&offt)),
                    "one of GGG, BGG, GGO, BGO, GOG, BOG, GOO, BOO (or a real BIT on CBEAM)",
                ));
            }
        }
        for (k, label) in [(9, "PA"), (10, "PB")] {
            if c.nonneg(k, label, "a pin flag")? != 0 {
                return Err(c.err(
                    k,
                    label,
                    format!("pin flag {} is not supported", c.text(k)),
                    OFFSET_HELP,
                ));
            }
        }
        for (j, label) in ["W1A", "W2A", "W3A", "W1B", "W2B", "W3B"]
            .iter()
            .enumerate()
        {
            c.zero(11 + j, label, OFFSET_HELP)?;
        }
        if beam
            && (c.nonneg(17, "SA", "a scalar point id")? != 0
                || c.nonneg(18, "SB", "a scalar point id")? != 0)
        {
            self.warn(&c.loc, id, "warping scalar points SA/SB are ignored");
        }
        self.new_element(
            c,
            id,
            ElemIn::Beam {
                nodes: [ga, gb],
                property,
                orient,
            },
        )
    }

    fn pshell(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let Some(mid1) = c.int(2, "MID1")? else {
            return Err(c.err(
                2,
                "MID1",
                "the field is blank (a shell without membrane material)",
                "femu needs MID1, a MAT1 id used for membrane and bending",
            ));
        };
        if mid1 <= 0 {
            return Err(c.err(
                2,
                "MID1",
                format!("{mid1} is not a material id"),
                "a MAT1 id (integer > 0)",
            ));
        }
        let material = mid1 as u64;
        let thickness = c.positive(3, "T")?;
        let mid2 = c.int(4, "MID2")?;
        let bending = c.real_or(5, "12I/T**3", 1.0)?;
        let mid3 = c.int(6, "MID3")?;
        c.real(7, "TS/T")?;
        let nsm = c.nonneg_real(8, "NSM", 0.0)?;
        let mid4 = c.int(11, "MID4")?;
        self.new_property(c, 1, "PID", id)?;
        match mid2 {
            None => self.warn(
                &c.loc,
                id,
                format!("MID2 is blank (no bending stiffness in Nastran); femu's shell uses MID1 {material} for bending too"),
            ),
            Some(m) if m != mid1 => self.warn(
                &c.loc,
                id,
                format!("MID2 {m} differs from MID1; MID1 {material} is used for bending"),
            ),
            _ => {}
        }
        if let Some(m) = mid3.filter(|m| *m != mid1) {
            self.warn(
                &c.loc,
                id,
                format!("MID3 {m} differs from MID1; MID1 {material} is used for transverse shear"),
            );
        }
        if let Some(m) = mid4 {
            self.warn(
                &c.loc,
                id,
                format!("MID4 {m} (membrane-bending coupling) is ignored"),
            );
        }
        if bending != 1.0 {
            self.warn(
                &c.loc,
                id,
                format!("12I/T**3 = {bending} is ignored; the bending stiffness is that of a solid plate of thickness T"),
            );
        }
        self.shells.insert(
            id,
            ShellProperty {
                material,
                thickness,
                nsm,
            },
        );
        Ok(())
    }

    fn pbar(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let area = c.positive(3, "A")?;
        let i1 = c.positive(4, "I1")?;
        let i2 = c.positive(5, "I2")?;
        let j = c.nonneg_real(6, "J", 0.0)?;
        let nsm = c.nonneg_real(7, "NSM", 0.0)?;
        for (i, label) in ["C1", "C2", "D1", "D2", "E1", "E2", "F1", "F2"]
            .iter()
            .enumerate()
        {
            c.real(9 + i, label)?;
        }
        let k1 = c.nonneg_real(17, "K1", 0.0)?;
        let k2 = c.nonneg_real(18, "K2", 0.0)?;
        c.zero(
            19,
            "I12",
            "a product of inertia is not supported: give I1 and I2 about the principal axes and orient the bar along them",
        )?;
        self.new_property(c, 1, "PID", id)?;
        self.beams.insert(
            id,
            BeamProperty {
                material,
                section: BeamSection::General {
                    area,
                    iy: i2,
                    iz: i1,
                    j,
                    shear_y: k1,
                    shear_z: k2,
                },
                nsm,
            },
        );
        Ok(())
    }

    fn pbarl(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let group = c.word(3);
        if !(group.is_empty() || group == "MSCBML0") {
            return Err(c.err(
                3,
                "GROUP",
                format!("cross-section library `{}` is not supported", q(&group)),
                "leave GROUP blank or MSCBML0",
            ));
        }
        let kind = c.word(4);
        let n = match kind.as_str() {
            "BAR" | "TUBE" => 2,
            "ROD" => 1,
            "" => {
                return Err(c.err(
                    4,
                    "TYPE",
                    "the field is blank",
                    "a section type: BAR, ROD or TUBE",
                ));
            }
            _ => {
                return Err(c.err(
                    4,
                    "TYPE",
                    format!("section type `{}` is not supported", q(&kind)),
                    "BAR, ROD or TUBE (or give the properties on a PBAR)",
                ));
            }
        };
        let dim1 = c.positive(9, "DIM1")?;
        let section = match kind.as_str() {
            "BAR" => BeamSection::Rectangle {
                width: dim1,
                height: c.positive(10, "DIM2")?,
            },
            "ROD" => BeamSection::Circle { radius: dim1 },
            _ => {
                let inner = c.req_real(10, "DIM2")?;
                if !(0.0..dim1).contains(&inner) {
                    return Err(c.err(
                        10,
                        "DIM2",
                        format!("inner radius {inner} is not in [0, outer radius {dim1})"),
                        "0 <= DIM2 < DIM1",
                    ));
                }
                BeamSection::Tube {
                    outer_radius: dim1,
                    inner_radius: inner,
                }
            }
        };
        let nsm = c.nonneg_real(9 + n, "NSM", 0.0)?;
        self.new_property(c, 1, "PID", id)?;
        self.beams.insert(
            id,
            BeamProperty {
                material,
                section,
                nsm,
            },
        );
        Ok(())
    }

    fn pbeam(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let labels = ["A", "I1", "I2", "I12", "J", "NSM"];
        let mut end_a = [0.0; 6];
        for (i, label) in labels.iter().enumerate() {
            end_a[i] = c.real_or(3 + i, &format!("{label}(A)"), 0.0)?;
        }
        for (i, label) in [(0, "A(A)"), (1, "I1(A)"), (2, "I2(A)")] {
            if end_a[i] <= 0.0 {
                return Err(c.err(
                    3 + i,
                    label,
                    if c.blank(3 + i) {
                        "the field is blank".to_string()
                    } else {
                        format!("{} is not positive", end_a[i])
                    },
                    "a real number > 0 (femu's beam needs a positive area and second moments)",
                ));
            }
        }
        for (i, label) in [(4, "J(A)"), (5, "NSM(A)")] {
            c.nonneg_real(3 + i, label, 0.0)?;
        }
        if end_a[3] != 0.0 {
            return Err(c.err(
                6,
                "I12(A)",
                format!("product of inertia {} is not supported", end_a[3]),
                "give I1 and I2 about the principal axes and orient the beam along them",
            ));
        }
        let rows = c.fields.len().div_ceil(8);
        let mut r = 1;
        let mut tail = 0;
        let (mut k1, mut k2) = (1.0, 1.0);
        while r < rows {
            let k0 = 1 + 8 * r;
            let so = c.word(k0);
            let is_station = parse_real(&so).is_none() && !so.is_empty();
            if is_station {
                if !matches!(so.as_str(), "YES" | "YESA" | "NO") {
                    return Err(c.err(
                        k0,
                        "SO",
                        format!("`{}` is not a stress output flag", q(&so)),
                        "YES, YESA or NO",
                    ));
                }
                c.real(k0 + 1, "X/XB")?;
                for (i, label) in labels.iter().enumerate() {
                    let given = c.real(k0 + 2 + i, label)?;
                    if let Some(v) =
                        given.filter(|v| (v - end_a[i]).abs() > 1e-9 * v.abs().max(end_a[i].abs()))
                    {
                        return Err(c.err(
                            k0 + 2 + i,
                            label,
                            format!("{label} = {v} differs from {} at end A (a tapered beam)", end_a[i]),
                            "only constant sections are supported: repeat the end-A values or leave the station fields blank",
                        ));
                    }
                }
                r += if so == "YES" { 2 } else { 1 };
                continue;
            }
            if r == 1 {
                for i in 0..8 {
                    c.real(k0 + i, "stress point")?;
                }
            } else if tail == 0 {
                k1 = c.nonneg_real(k0, "K1", 1.0)?;
                k2 = c.nonneg_real(k0 + 1, "K2", 1.0)?;
                c.real(k0 + 2, "S1")?;
                c.real(k0 + 3, "S2")?;
                let ignored = ["NSI(A)", "NSI(B)", "CW(A)", "CW(B)"];
                let mut any = false;
                for (i, label) in ignored.iter().enumerate() {
                    any |= c.real_or(k0 + 4 + i, label, 0.0)? != 0.0;
                }
                if any {
                    self.warn(
                        &c.loc,
                        id,
                        "NSI (mass moment of inertia) and CW (warping) are ignored",
                    );
                }
                tail = 1;
            } else if tail == 1 {
                let mut any = false;
                for i in 0..8 {
                    any |= c.real_or(k0 + i, "M/N offset", 0.0)? != 0.0;
                }
                if any {
                    self.warn(
                        &c.loc,
                        id,
                        "the NSM centre of gravity and neutral axis offsets (M, N) are ignored",
                    );
                }
                tail = 2;
            } else if (0..8).any(|i| !c.blank(k0 + i)) {
                return Err(c.err(
                    k0,
                    "?",
                    "this continuation follows the K and M lines",
                    "PBEAM ends with the K1 line and the M1(A) line",
                ));
            }
            r += 1;
        }
        self.new_property(c, 1, "PID", id)?;
        self.beams.insert(
            id,
            BeamProperty {
                material,
                section: BeamSection::General {
                    area: end_a[0],
                    iy: end_a[2],
                    iz: end_a[1],
                    j: end_a[4],
                    shear_y: k1,
                    shear_z: k2,
                },
                nsm: end_a[5],
            },
        );
        Ok(())
    }

    fn mat1(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "MID")?;
        let e = c.real(2, "E")?;
        if let Some(v) = e.filter(|v| *v <= 0.0) {
            return Err(c.err(
                2,
                "E",
                format!("E = {v} is not positive"),
                "E > 0 (Nastran allows E = 0 with G given; femu's isotropic elements need E > 0)",
            ));
        }
        let g = c.real(3, "G")?;
        if let Some(v) = g.filter(|v| *v < 0.0) {
            return Err(c.err(3, "G", format!("G = {v} is negative"), "G >= 0 or blank"));
        }
        let nu = c.real(4, "NU")?;
        let rho = c.nonneg_real(5, "RHO", 0.0)?;
        let mut note = None;
        let (e, nu) = match (e, g, nu) {
            (Some(e), Some(g), Some(nu)) => {
                let g_used = e / (2.0 * (1.0 + nu));
                if (g - g_used).abs() > 1e-6 * g.abs().max(g_used.abs()) {
                    note = Some(format!(
                        "G = {g} does not equal E/(2(1+NU)); E and NU are kept, so G = {g_used}"
                    ));
                }
                (e, nu)
            }
            (Some(e), Some(g), None) => {
                if g <= 0.0 {
                    return Err(c.err(
                        3,
                        "G",
                        format!("G = {g} with NU blank"),
                        "G > 0 so that NU = E/(2G) - 1",
                    ));
                }
                (e, e / (2.0 * g) - 1.0)
            }
            (Some(e), None, Some(nu)) => (e, nu),
            (None, Some(g), Some(nu)) => {
                let e = 2.0 * (1.0 + nu) * g;
                if !(e > 0.0 && e.is_finite()) {
                    return Err(c.err(
                        3,
                        "G",
                        format!(
                            "E = 2(1+NU)G = {e} derived from G = {g} and NU = {nu} is not positive"
                        ),
                        "G > 0 and -1 < NU <= 0.5 when E is blank",
                    ));
                }
                (e, nu)
            }
            (Some(e), None, None) => {
                note = Some(
                    "G and NU are blank (Nastran: G = 0); femu's isotropic material needs NU, 0 is used (G = E/2)"
                        .to_string(),
                );
                (e, 0.0)
            }
            (None, Some(_), None) => {
                return Err(c.err(
                    2,
                    "E",
                    "E and NU are blank",
                    "give two of E, G and NU (femu's isotropic material needs E)",
                ));
            }
            (None, None, _) => {
                return Err(c.err(2, "E", "E and G are both blank", "give E (and NU or G)"));
            }
        };
        if !(nu > -1.0 && nu <= 0.5) {
            return Err(c.err(
                4,
                "NU",
                format!("Poisson's ratio {nu} (given or derived) is outside (-1, 0.5]"),
                "-1 < NU <= 0.5 (Nastran Quick Reference, MAT1)",
            ));
        }
        if let Some((first, _)) = self.materials.get(&id) {
            return Err(duplicate(c, 1, "MID", "material", id, first));
        }
        if let Some(text) = note {
            self.warn(&c.loc, id, text);
        }
        self.materials
            .insert(id, (c.loc.clone(), Material { e, nu, rho }));
        Ok(())
    }

    /// The two ends of a scalar spring from G1, C1, G2, C2 at fields `k..k+3`.
    fn spring_ends(c: &Card, k: usize) -> Result<(DofId, Option<DofId>), NastranError> {
        let end =
            |kg: usize, kc: usize, lg: &str, lc: &str| -> Result<Option<DofId>, NastranError> {
                match c.opt_grid(kg, lg)? {
                    None => Ok(None),
                    Some(g) => Ok(Some(DofId::new(g, c.one_comp(kc, lc)?))),
                }
            };
        let a = end(k, k + 1, "G1", "C1")?;
        let b = end(k + 2, k + 3, "G2", "C2")?;
        match (a, b) {
            (Some(a), b) => Ok((a, b)),
            (None, Some(b)) => Ok((b, None)),
            (None, None) => Err(c.err(
                k,
                "G1",
                "neither G1 nor G2 is given",
                "at least one grid id",
            )),
        }
    }

    fn celas(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let (dof, other) = Self::spring_ends(c, 3)?;
        if c.name == "CELAS1" {
            let pid = c.id_or(2, "PID", id)?;
            return self.new_element(c, id, ElemIn::Celas1 { pid, dof, other });
        }
        if c.blank(2) {
            return Err(c.err(2, "K", "the field is blank", "a stiffness >= 0"));
        }
        let k = c.nonneg_real(2, "K", 0.0)?;
        if c.real_or(7, "GE", 0.0)? != 0.0 {
            self.warn(&c.loc, id, "damping GE is ignored");
        }
        c.real(8, "S")?;
        self.new_element(c, id, ElemIn::Done(Element::ScalarSpring { dof, other, k }))
    }

    fn pelas_card(&mut self, c: &Card) -> Result<(), NastranError> {
        for off in [0, 4] {
            if off == 4 && c.blank(5) {
                break;
            }
            let label = if off == 0 { "PID1" } else { "PID2" };
            let id = c.id(1 + off, label)?;
            let label_k = if off == 0 { "K1" } else { "K2" };
            if c.blank(2 + off) {
                return Err(c.err(2 + off, label_k, "the field is blank", "a stiffness >= 0"));
            }
            let k = c.nonneg_real(2 + off, label_k, 0.0)?;
            if c.real_or(3 + off, "GE", 0.0)? != 0.0 {
                self.warn(&c.loc, id, "damping GE is ignored");
            }
            c.real(4 + off, "S")?;
            self.new_property(c, 1 + off, label, id)?;
            self.pelas.insert(id, k);
        }
        Ok(())
    }

    fn cbush(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let pid = c.id_or(2, "PID", id)?;
        let node = c.id(3, "GA")?;
        let other = c.opt_grid(4, "GB")?;
        if other == Some(node) {
            return Err(c.err(
                4,
                "GB",
                format!("GB is GA ({node})"),
                "a different grid, or blank for ground",
            ));
        }
        let orient = Self::orientation(c, 5)?;
        let cid = c.int(8, "CID")?;
        if let Some(v) = cid.filter(|v| *v < -1) {
            return Err(c.err(
                8,
                "CID",
                format!("{v} is not a coordinate system id"),
                "blank, 0 or a system id",
            ));
        }
        if orient.is_some() || cid.is_some_and(|v| v != 0) {
            self.warn(
                &c.loc,
                id,
                "the element system (CID, orientation vector or G0) is ignored; PBUSH K1-K6 act along the basic axes",
            );
        }
        if c.real(9, "S")?.is_some()
            || c.int(10, "OCID")?.is_some()
            || (11..14).any(|k| !c.blank(k))
        {
            for k in 11..14 {
                c.real(k, "Si")?;
            }
            self.warn(
                &c.loc,
                id,
                "the spring location (S, OCID, S1-S3) is ignored",
            );
        }
        self.new_element(c, id, ElemIn::Bush { pid, node, other })
    }

    fn pbush_card(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let rows = c.fields.len().div_ceil(8).max(1);
        let mut k = None;
        let mut ignored = BTreeSet::new();
        for r in 0..rows {
            let kf = 2 + 8 * r;
            let flag = c.word(kf);
            let values: Vec<usize> = (kf + 1..kf + 7).collect();
            if flag.is_empty() {
                if let Some(&j) = values.iter().find(|&&j| !c.blank(j)) {
                    return Err(c.err(
                        j,
                        "value",
                        "a value follows a blank flag field",
                        "each PBUSH line starts with a flag: K, B, GE, RCV or M",
                    ));
                }
                continue;
            }
            if flag == "K" {
                let mut kv = [0.0; 6];
                for (i, &j) in values.iter().enumerate() {
                    kv[i] = c.nonneg_real(j, &format!("K{}", i + 1), 0.0)?;
                }
                k = Some(kv);
            } else if parse_real(&flag).is_some() {
                return Err(c.err(
                    kf,
                    "flag",
                    format!("`{}` is a number", q(&flag)),
                    "a flag: K, B, GE, RCV or M",
                ));
            } else if values.iter().any(|&j| !c.blank(j)) {
                ignored.insert(flag);
            }
        }
        self.new_property(c, 1, "PID", id)?;
        if !ignored.is_empty() {
            let list: Vec<String> = ignored.into_iter().collect();
            self.warn(
                &c.loc,
                id,
                format!(
                    "the {} line(s) are ignored (stiffness K only)",
                    list.join(", ")
                ),
            );
        }
        let k = match k {
            Some(k) => k,
            None => {
                self.warn(&c.loc, id, "no K line: the bush has zero stiffness");
                [0.0; 6]
            }
        };
        self.pbush.insert(id, k);
        Ok(())
    }

    fn conm2(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let node = c.id(2, "G")?;
        let cid = c.int(3, "CID")?.unwrap_or(0);
        let mass = c.nonneg_real(4, "M", 0.0)?;
        let x = [
            c.real_or(5, "X1", 0.0)?,
            c.real_or(6, "X2", 0.0)?,
            c.real_or(7, "X3", 0.0)?,
        ];
        let mut inertia = [0.0; 6];
        for (i, label) in ["I11", "I21", "I22", "I31", "I32", "I33"]
            .iter()
            .enumerate()
        {
            inertia[i] = c.real_or(9 + i, label, 0.0)?;
        }
        let e = match cid {
            0 => ElemIn::Done(Element::Mass {
                node,
                mass,
                inertia,
                offset: x,
            }),
            -1 => ElemIn::MassAbsolute {
                node,
                mass,
                inertia,
                cg: x,
            },
            _ => {
                return Err(c.err(
                    3,
                    "CID",
                    format!("coordinate system {cid} is not supported"),
                    "0 (offset X1-X3 in the basic system) or -1 (X1-X3 are the basic coordinates of the centre of gravity)",
                ));
            }
        };
        self.new_element(c, id, e)
    }

    fn spc(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        self.spc_sids.insert(sid);
        for (j, off) in [0, 3].into_iter().enumerate() {
            let lg = ["G1", "G2"][j];
            let lc = ["C1", "C2"][j];
            let ld = ["D1", "D2"][j];
            if j == 1 && c.blank(5) && c.blank(6) && c.blank(7) {
                break;
            }
            let g = c.id(2 + off, lg)?;
            let comps = c.comps(3 + off, lc)?;
            if comps.is_empty() {
                return Err(c.err(
                    3 + off,
                    lc,
                    "the field is blank",
                    "components such as 123456",
                ));
            }
            c.zero(
                4 + off,
                ld,
                "enforced displacements are not supported: D must be blank or 0",
            )?;
            for comp in comps {
                self.spcs.push((c.loc.clone(), DofId::new(g, comp)));
            }
        }
        Ok(())
    }

    fn spc1(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        self.spc_sids.insert(sid);
        let comps = c.comps(2, "C")?;
        if comps.is_empty() {
            return Err(c.err(2, "C", "the field is blank", "components such as 123456"));
        }
        let (ids, ranges) = c.id_list(3, "Gi")?;
        if ids.is_empty() && ranges.is_empty() {
            return Err(c.err(
                3,
                "G1",
                "no grid is listed",
                "grid ids, optionally with THRU",
            ));
        }
        for g in ids {
            for &comp in &comps {
                self.spcs.push((c.loc.clone(), DofId::new(g, comp)));
            }
        }
        for (lo, hi) in ranges {
            self.spc_ranges.push((c.loc.clone(), comps.clone(), lo, hi));
        }
        Ok(())
    }

    fn set1(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        let from = if c.word(2) == "SKIN" { 3 } else { 2 };
        let (ids, ranges) = c.id_list(from, "IDi")?;
        if let Some(first) = self.sets.get(&sid) {
            return Err(duplicate(c, 1, "SID", "set", sid, &first.loc));
        }
        self.sets.insert(
            sid,
            SetIn {
                loc: c.loc.clone(),
                ids,
                ranges,
            },
        );
        Ok(())
    }

    /// Frames of every CORD2R, resolving RID chains without recursion.
    fn frames(&self) -> Result<BTreeMap<u64, Frame>, NastranError> {
        let mut done: BTreeMap<u64, Frame> = BTreeMap::new();
        for &start in self.cords.keys() {
            let mut chain = vec![start];
            loop {
                let cord = &self.cords[chain.last().unwrap_or(&start)];
                let rid = cord.rid;
                if rid == 0 || done.contains_key(&rid) {
                    break;
                }
                if chain.contains(&rid) {
                    return Err(cord.loc.field_err(
                        2,
                        "RID",
                        format!("RID {rid} closes a cycle of coordinate systems"),
                        "a chain of RIDs must end in 0 (basic)",
                    ));
                }
                if !self.cords.contains_key(&rid) {
                    return Err(cord.loc.field_err(
                        2,
                        "RID",
                        format!("RID {rid} is not a CORD2R"),
                        "0 (basic) or the id of a CORD2R card (other coordinate system cards are not supported)",
                    ));
                }
                chain.push(rid);
            }
            for &cid in chain.iter().rev() {
                if done.contains_key(&cid) {
                    continue;
                }
                let cord = &self.cords[&cid];
                let parent = if cord.rid == 0 {
                    Frame::BASIC
                } else {
                    done[&cord.rid]
                };
                let [a, b, cc] = cord.points.map(|p| parent.to_basic(p));
                let z = sub(b, a);
                let lz = norm(z);
                if lz == 0.0 || !lz.is_finite() {
                    return Err(cord.loc.field_err(
                        6,
                        "B1",
                        "point B coincides with A",
                        "B must lie on the z axis, away from the origin A",
                    ));
                }
                let z = scale(z, 1.0 / lz);
                let t = sub(cc, a);
                let x = sub(t, scale(z, dot(t, z)));
                let lx = norm(x);
                if lx <= 1e-12 * norm(t) || lx == 0.0 {
                    return Err(cord.loc.field_err(
                        9,
                        "C1",
                        "point C lies on the z axis through A and B",
                        "C must lie in the x-z plane, off the z axis",
                    ));
                }
                let x = scale(x, 1.0 / lx);
                let y = cross(z, x);
                done.insert(
                    cid,
                    Frame {
                        origin: a,
                        axes: [x, y, z],
                    },
                );
            }
        }
        Ok(done)
    }

    fn finish(
        mut self,
        set_names: Vec<(Loc, u64, String)>,
        parameters: Vec<(Loc, Parameter)>,
    ) -> Result<BulkImport, NastranError> {
        let frames = self.frames()?;
        let mut model = Model::default();
        let mut cd_grids: Vec<(u64, i64, Loc)> = Vec::new();
        for (&id, g) in &self.grids {
            let x = if g.cp == 0 {
                g.x
            } else if let Some(f) = frames.get(&g.cp) {
                f.to_basic(g.x)
            } else {
                return Err(g.loc.field_err(
                    2,
                    "CP",
                    format!("coordinate system {} is not a CORD2R of the deck", g.cp),
                    "0 (basic) or the id of a CORD2R card (other coordinate system cards are not supported)",
                ));
            };
            model.nodes.insert(id, x);
            if g.cd != 0 {
                cd_grids.push((id, g.cd, g.loc.clone()));
            }
            for &comp in &g.ps {
                self.spcs.push((g.loc.clone(), DofId::new(id, comp)));
            }
        }
        if let Some((id, cd, loc)) = cd_grids.first() {
            self.warnings.push(format!(
                "{} line {}: GRID {id} has CD {cd} ({} grid(s) with CD != 0 in all); CD is ignored: displacements, PS/SPC components and spring directions are taken in the basic system",
                loc.file,
                loc.line,
                cd_grids.len()
            ));
        }
        for (id, m) in &self.materials {
            model.materials.insert(*id, m.1.clone());
        }
        model.shell_properties = std::mem::take(&mut self.shells);
        model.beam_properties = std::mem::take(&mut self.beams);
        let elements = std::mem::take(&mut self.elements);
        let mut element_locs = BTreeMap::new();
        for (id, (loc, e)) in elements {
            let element = match e {
                ElemIn::Done(e) => e,
                ElemIn::Beam {
                    nodes,
                    property,
                    orient,
                } => {
                    let orientation = match orient {
                        Orient::Vector(v) => v,
                        Orient::G0(g0) => {
                            let (Some(a), Some(p)) =
                                (model.nodes.get(&nodes[0]), model.nodes.get(&g0))
                            else {
                                return Err(loc.field_err(
                                    5,
                                    "G0",
                                    format!(
                                        "orientation grid {g0} or end grid {} is not defined",
                                        nodes[0]
                                    ),
                                    "G0 must be a GRID of the deck",
                                ));
                            };
                            sub(*p, *a)
                        }
                    };
                    if let (Some(a), Some(b)) =
                        (model.nodes.get(&nodes[0]), model.nodes.get(&nodes[1]))
                    {
                        let axis = sub(*b, *a);
                        if norm(axis) == 0.0 {
                            return Err(loc.field_err(
                                4,
                                "GB",
                                format!(
                                    "grids {} and {} coincide (zero length)",
                                    nodes[0], nodes[1]
                                ),
                                "a beam needs two grids at different points",
                            ));
                        }
                        if norm(cross(axis, orientation)) <= 1e-9 * norm(axis) * norm(orientation) {
                            return Err(loc.field_err(
                                5,
                                "X1/G0",
                                format!("orientation vector {orientation:?} is zero or parallel to the axis"),
                                "a vector (or G0 direction) that is not parallel to GA->GB",
                            ));
                        }
                    }
                    Element::Beam {
                        nodes,
                        property,
                        orientation,
                    }
                }
                ElemIn::Celas1 { pid, dof, other } => {
                    let Some(&k) = self.pelas.get(&pid) else {
                        return Err(loc.field_err(
                            2,
                            "PID",
                            format!("property {pid} is not a PELAS"),
                            "the id of a PELAS card",
                        ));
                    };
                    Element::ScalarSpring { dof, other, k }
                }
                ElemIn::Bush { pid, node, other } => {
                    let Some(&k) = self.pbush.get(&pid) else {
                        return Err(loc.field_err(
                            2,
                            "PID",
                            format!("property {pid} is not a PBUSH"),
                            "the id of a PBUSH card",
                        ));
                    };
                    Element::Bush { node, other, k }
                }
                ElemIn::MassAbsolute {
                    node,
                    mass,
                    inertia,
                    cg,
                } => {
                    let at = model.nodes.get(&node).copied().unwrap_or([0.0; 3]);
                    Element::Mass {
                        node,
                        mass,
                        inertia,
                        offset: sub(cg, at),
                    }
                }
            };
            model.elements.insert(id, element);
            element_locs.insert(id, loc);
        }
        for (loc, comps, lo, hi) in &self.spc_ranges {
            for &g in model.nodes.range(lo..=hi).map(|(g, _)| g) {
                for &comp in comps {
                    self.spcs.push((loc.clone(), DofId::new(g, comp)));
                }
            }
        }
        if self.spc_sids.len() > 1 {
            let sids: Vec<String> = self.spc_sids.iter().map(u64::to_string).collect();
            self.warnings.push(format!(
                "{}: SPC/SPC1 sets {} are merged into one constraint list (there is no case control to choose one)",
                self.top_file,
                sids.join(", ")
            ));
        }
        let mut spc_locs: BTreeMap<u64, Loc> = BTreeMap::new();
        for (loc, d) in &self.spcs {
            spc_locs.entry(d.node).or_insert_with(|| loc.clone());
        }
        let mut constraints: Vec<DofId> = self.spcs.iter().map(|(_, d)| *d).collect();
        constraints.sort();
        constraints.dedup();
        model.constraints = constraints;

        let mut names: BTreeMap<u64, (Loc, String)> = BTreeMap::new();
        for (loc, sid, name) in set_names {
            if let Some((first, _)) = names.get(&sid) {
                return Err(NastranError::Syntax {
                    file: loc.file.to_string().into(),
                    line: loc.line,
                    problem: format!("set {sid} is named twice (first at {})", first.place())
                        .into(),
                    valid: "one `$femu-set` comment per set id".into(),
                });
            }
            names.insert(sid, (loc, name));
        }
        let mut set_locs: BTreeMap<String, Loc> = BTreeMap::new();
        let sets = std::mem::take(&mut self.sets);
        let mut all_sids: BTreeSet<u64> = sets.keys().copied().collect();
        all_sids.extend(names.keys().copied());
        for sid in all_sids {
            let (loc, mut ids) = match sets.get(&sid) {
                Some(s) => {
                    let mut ids = s.ids.clone();
                    for (lo, hi) in &s.ranges {
                        ids.extend(model.elements.range(lo..=hi).map(|(e, _)| *e));
                    }
                    (s.loc.clone(), ids)
                }
                None => (names[&sid].0.clone(), Vec::new()),
            };
            ids.sort_unstable();
            ids.dedup();
            let name = names
                .get(&sid)
                .map_or_else(|| format!("set{sid}"), |(_, n)| n.clone());
            if let Some(first) = set_locs.get(&name) {
                return Err(NastranError::Syntax {
                    file: loc.file.to_string().into(),
                    line: loc.line,
                    problem: format!("set `{name}` is defined twice (first at {})", first.place())
                        .into(),
                    valid: "set names must be unique".into(),
                });
            }
            set_locs.insert(name.clone(), loc);
            model.sets.insert(name, ids);
        }
        let mut param_locs = Vec::new();
        for (loc, p) in parameters {
            param_locs.push((p.name.clone(), loc));
            model.parameters.push(p);
        }

        model.add_property_sets();
        if let Err(e) = model.validate() {
            let pid_loc = |p: &u64| self.pids.get(p).cloned();
            let (loc, valid) = match &e {
                ModelError::MissingNode { element, node, .. } => (
                    element_locs.get(element).cloned(),
                    format!("add GRID {node} or correct the element's grid ids"),
                ),
                ModelError::MissingProperty { element, .. } => (
                    element_locs.get(element).cloned(),
                    "CQUAD4/CTRIA3 need a PSHELL; CBAR/CBEAM need a PBAR, PBARL or PBEAM"
                        .to_string(),
                ),
                ModelError::MissingMaterial { property, material } => {
                    (pid_loc(property), format!("add MAT1 {material}"))
                }
                ModelError::MissingSetElement { set, element } => (
                    set_locs.get(set).cloned(),
                    format!(
                        "SET1 lists element ids: define element {element} or remove it from the set"
                    ),
                ),
                ModelError::MissingSet { parameter, .. } => (
                    param_locs
                        .iter()
                        .find(|(n, _)| n == parameter)
                        .map(|(_, l)| l.clone()),
                    "name a set defined by SET1 or a `pid<N>` property set".to_string(),
                ),
                ModelError::ConstraintNode(node) => (
                    spc_locs.get(node).cloned(),
                    format!("add GRID {node} or remove it from the SPC/SPC1"),
                ),
            };
            let (file, line) = loc.map_or((self.top_file.to_string(), 0), |l| {
                (l.file.to_string(), l.line)
            });
            return Err(NastranError::Model {
                file: file.into(),
                line,
                source: e,
                valid: valid.into(),
            });
        }
        if model.elements.is_empty() {
            return Err(NastranError::Empty {
                file: self.top_file.to_string().into(),
                problem: format!(
                    "no element was read ({} GRID card(s)), so there is no stiffness or mass to assemble",
                    model.nodes.len()
                )
                .into(),
                valid: format!(
                    "a bulk data deck with elements femu reads (femu reads {})",
                    READ_CARDS.join(", ")
                )
                .into(),
            });
        }
        // Every element as the assembly will build it, so that a value femu cannot use is
        // found when the pipeline is checked, at the card that holds it.
        for (id, e) in &model.elements {
            if let Err(err) = crate::fe::model_assembly::element_matrices(
                &model,
                e,
                crate::fe::element::MassKind::Consistent,
            ) {
                let loc = element_locs.get(id).cloned().unwrap_or(Loc {
                    file: self.top_file.clone(),
                    line: 0,
                    card: Rc::from("element"),
                });
                let uses = match e.property() {
                    Some(p) => {
                        let mid = model
                            .shell_properties
                            .get(&p)
                            .map(|s| s.material)
                            .or_else(|| model.beam_properties.get(&p).map(|b| b.material));
                        let at = |l: Option<&Loc>| {
                            l.map_or(String::new(), |l| format!(" at {}", l.place()))
                        };
                        let mat = mid.map_or(String::new(), |m| {
                            format!(", material {m}{}", at(self.materials.get(&m).map(|x| &x.0)))
                        });
                        format!(" (property {p}{}{mat})", at(self.pids.get(&p)))
                    }
                    None => String::new(),
                };
                return Err(NastranError::Element {
                    file: loc.file.to_string().into(),
                    line: loc.line,
                    card: loc.card.to_string().into(),
                    id: *id,
                    uses: uses.into(),
                    message: err.to_string().into(),
                });
            }
        }
        let mut unknown = self.skipped.clone();
        for (k, n) in &self.ignored {
            *unknown.entry(k.clone()).or_insert(0) += n;
        }
        Ok(BulkImport {
            model,
            unknown,
            skipped: self.skipped,
            ignored: self.ignored,
            warnings: self.warnings,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> BulkImport {
        match parse_bulk(text, "t.bdf") {
            Ok(b) => b,
            Err(e) => panic!("{e}"),
        }
    }

    fn error(text: &str) -> String {
        match parse_bulk(text, "t.bdf") {
            Ok(_) => panic!("the deck should be rejected:\n{text}"),
            Err(e) => e.to_string(),
        }
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12)
    }

    /// A minimal valid plate deck to which the tests add cards.
    const BASE: &str = "\
MAT1,1,2.1+11,,.3,7850.
PSHELL,10,1,.002,1
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
";

    #[test]
    fn nastran_real_shorthands() {
        let cases = [
            ("1.5-3", 1.5e-3),
            ("7.+4", 7.0e4),
            (".5", 0.5),
            ("1+3", 1.0e3),
            ("1.E3", 1.0e3),
            ("1D3", 1.0e3),
            ("1.5d+2", 150.0),
            ("-2.5E-2", -0.025),
            ("+.5", 0.5),
            ("-.25-1", -0.025),
            ("42", 42.0),
            ("3.", 3.0),
            ("2.1+11", 2.1e11),
        ];
        for (text, value) in cases {
            assert_eq!(parse_real(text), Some(value), "{text}");
        }
        for bad in [
            "", ".", "-", "1.5.3", "E3", "1-", "1e", "abc", "--1", "inf", "nan", "1.0e400", "1 2",
        ] {
            assert_eq!(parse_real(bad), None, "{bad}");
        }
        assert_eq!(parse_int("+12"), Some(12));
        assert_eq!(parse_int("1."), None);
        assert_eq!(parse_int("1+3"), None);
    }

    #[test]
    fn small_large_and_free_fields_with_continuations_and_comments() {
        // Ruler:  ------1-------2-------3-------4-------5-------6-------7-------8-------9-------10
        let deck = "\
ID femu,test
SOL 103
CEND
TITLE = SKIPPED $ executive and case control are skipped
INCLUDE 'does-not-exist-and-is-never-read.bdf'
BEGIN BULK
$ a comment line
PARAM,POST,-1
MAT1    1       2.1+11          .3      7850.
PSHELL  10      1       2.-3    1                               .5
GRID    1               0.      0.      0.
GRID    2               1.5-1   0.      0.              123
GRID*   3                               .15             1.+0            +G3
*G3     0.
grid,4,,0.,1.0,0. $ lower case, inline comment
CQUAD4  100     10      1       2       3       4
CTRIA3,101,10,2,3,4
PBARL,20,1,,BAR
,.01,.02
CBAR    200     20      1       2       0.      0.      1.              +B200
+B200                   0.      0.      0.      0.      0.      0.
GRID    5               1.      1.      1.
CBEAM,201,20,3,5,1
EIGRL   1                       6
ENDDATA
GRID    99              this is never read
";
        let b = parse(deck);
        let m = &b.model;
        assert_eq!(m.nodes.len(), 5);
        assert!(close(m.nodes[&2], [0.15, 0.0, 0.0]));
        assert!(close(m.nodes[&3], [0.15, 1.0, 0.0]));
        assert!(close(m.nodes[&4], [0.0, 1.0, 0.0]));
        assert_eq!(
            m.shell_properties[&10],
            ShellProperty {
                material: 1,
                thickness: 0.002,
                nsm: 0.5
            }
        );
        assert_eq!(m.materials[&1].e, 2.1e11);
        assert_eq!(
            m.elements[&100],
            Element::Quad4 {
                nodes: [1, 2, 3, 4],
                property: 10
            }
        );
        assert_eq!(
            m.elements[&101],
            Element::Tria3 {
                nodes: [2, 3, 4],
                property: 10
            }
        );
        assert_eq!(
            m.elements[&200],
            Element::Beam {
                nodes: [1, 2],
                property: 20,
                orientation: [0.0, 0.0, 1.0]
            }
        );
        // G0 = 1: the orientation is x(G0) - x(GA).
        let Element::Beam { orientation, .. } = &m.elements[&201] else {
            panic!("not a beam");
        };
        assert!(close(*orientation, [-0.15, -1.0, 0.0]));
        assert_eq!(
            m.beam_properties[&20].section,
            BeamSection::Rectangle {
                width: 0.01,
                height: 0.02
            }
        );
        // GRID PS on grid 2.
        assert_eq!(
            m.constraints,
            vec![
                DofId::new(2, Component::Ux),
                DofId::new(2, Component::Uy),
                DofId::new(2, Component::Uz)
            ]
        );
        assert_eq!(m.sets["pid10"], vec![100, 101]);
        assert_eq!(m.sets["pid20"], vec![200, 201]);
        let unknown: Vec<(&str, usize)> = b.unknown.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        assert_eq!(unknown, vec![("EIGRL", 1), ("PARAM,POST", 1)]);
        assert!(b.warnings.is_empty(), "{:?}", b.warnings);
    }

    #[test]
    fn cards_that_change_the_model_are_errors_unless_ignored() {
        let extra = "CQUAD4,1,10,1,2,3,4\nPARAM,POST,-1\nEIGRL,1,,,10\nFORCE,1,1,,1.,0.,0.,1.\nCHEXA,2,1,1,2,3,4,5,6\n,7,8\nRBE2,9,1,123456,2\nRBE2,10,1,123456,3\n";
        let deck = format!("{BASE}{extra}");
        // Each card that may change K, M or constraints is an error naming file, line and card.
        let e = error(&deck);
        assert!(
            e.starts_with("t.bdf line 11: CHEXA is not read by femu")
                && e.contains("femu reads GRID, CORD2R")
                && e.contains("`ignore_cards`"),
            "{e}"
        );
        for (card, line) in [
            ("RBE3,1,,2,123,1.,123,3", 8),
            ("MPC,1,2,1,1.,3,1,-1.", 8),
            ("CROD,5,5,1,2", 8),
            ("CONROD,5,1,2,1,.1", 8),
            ("CQUAD8,5,10,1,2,3,4", 8),
            ("CTRIA6,5,10,1,2,3", 8),
            ("CPENTA,5,1,1,2,3,4", 8),
            ("CTETRA,5,1,1,2,3,4", 8),
            ("GRDSET,,,,,,,123456", 8),
            ("PCOMP,20", 8),
            ("CONM1,5,1,1.", 8),
            ("CMASS1,5,5,1,1", 8),
            ("CDAMP1,5,5,1,1", 8),
            ("SPCADD,3,1,2", 8),
            ("SUPORT,1,123456", 8),
            ("RBAR,5,1,2,123456", 8),
            ("PARAM,COUPMASS,1", 8),
        ] {
            let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,4\n{card}\n"));
            let name = card.split(',').next().unwrap();
            let key = if name == "PARAM" {
                "PARAM,COUPMASS"
            } else {
                name
            };
            assert!(
                e.starts_with(&format!("t.bdf line {line}: {key} is not read by femu")),
                "{e}"
            );
        }
        // Accepted when the user lists them; skipped and ignored cards are counted apart.
        let opts = BulkOptions {
            ignore_cards: ["CHEXA", "RBE2"].map(String::from).into(),
        };
        let b = parse_bulk_with(&deck, "t.bdf", &opts).unwrap();
        assert_eq!(
            b.skipped,
            BTreeMap::from([
                ("EIGRL".to_string(), 1),
                ("FORCE".to_string(), 1),
                ("PARAM,POST".to_string(), 1)
            ])
        );
        assert_eq!(
            b.ignored,
            BTreeMap::from([("CHEXA".to_string(), 1), ("RBE2".to_string(), 2)])
        );
        assert_eq!(b.unknown.len(), 5);
        // A PARAM is ignored by its name or as PARAM.
        let opts = BulkOptions {
            ignore_cards: ["PARAM,COUPMASS".to_string()].into(),
        };
        let b = parse_bulk_with(
            &format!("{BASE}CQUAD4,1,10,1,2,3,4\nPARAM,COUPMASS,1\n"),
            "t.bdf",
            &opts,
        )
        .unwrap();
        assert_eq!(b.ignored["PARAM,COUPMASS"], 1);
    }

    #[test]
    fn wtmass_other_than_one_is_an_error() {
        let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,4\nPARAM,WTMASS,.00259\n"));
        assert!(
            e.starts_with(
                "t.bdf line 8: PARAM field 3 (V1): WTMASS 0.00259 scales the mass matrix"
            ),
            "{e}"
        );
        // Even when the user ignores PARAMs: it would silently scale M.
        let opts = BulkOptions {
            ignore_cards: ["PARAM".to_string(), "PARAM,WTMASS".to_string()].into(),
        };
        assert!(
            parse_bulk_with(
                &format!("{BASE}CQUAD4,1,10,1,2,3,4\nPARAM,WTMASS,.00259\n"),
                "t.bdf",
                &opts
            )
            .is_err()
        );
        let b = parse(&format!("{BASE}CQUAD4,1,10,1,2,3,4\nPARAM,WTMASS,1.0\n"));
        assert_eq!(b.skipped["PARAM,WTMASS"], 1);
    }

    #[test]
    fn a_deck_without_elements_or_not_nastran_is_refused_without_quoting_it() {
        let e = error(BASE);
        assert!(
            e.starts_with("t.bdf: no element was read (4 GRID card(s))"),
            "{e}"
        );
        let e = error("$ only a comment\n");
        assert!(e.contains("no element was read (0 GRID card(s))"), "{e}");
        // Words, a password file, a CSV: not quoted, said not to look like Nastran.
        for text in [
            "the quick brown fox\njumps over\n",
            "root:x:0:0:root:/root:/bin/bash\n",
            "secret,hunter2,more\n",
            "Password\n",
            "#!/bin/sh\n",
        ] {
            let e = error(text);
            assert!(e.contains("does not look like Nastran bulk data"), "{e}");
            for word in [
                "quick", "root", "hunter2", "Password", "PASSWORD", "SECRET", "bin",
            ] {
                assert!(!e.contains(word), "{word} quoted: {e}");
            }
        }
        // After a Nastran card, an offending line is quoted, shortened to 40 characters.
        let long = format!("{BASE}#{}\n", "x".repeat(200));
        let e = error(&long);
        assert!(e.contains(&format!("`#{}…`", "x".repeat(39))), "{e}");
        let e = error(&format!("{BASE}GRID,5,,{},0.,0.\n", "y".repeat(300)));
        assert!(
            e.contains(&format!("`{}…` is not a number", "y".repeat(40))),
            "{e}"
        );
    }

    #[test]
    fn material_and_property_values_are_checked_at_the_card() {
        let quad = "CQUAD4,1,10,1,2,3,4\n";
        let grids = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\n";
        let cases = [
            (
                "MAT1,1,0.,,.3,7850.",
                "MAT1 field 3 (E): E = 0 is not positive",
            ),
            (
                "MAT1,1,-2.1+11,,.3,7850.",
                "MAT1 field 3 (E): E = -210000000000 is not positive",
            ),
            (
                "MAT1,1,,,.3,7850.",
                "MAT1 field 3 (E): E and G are both blank",
            ),
            (
                "MAT1,1,2.1+11,-1.,.3,7850.",
                "MAT1 field 4 (G): G = -1 is negative",
            ),
            (
                "MAT1,1,2.1+11,,.6,7850.",
                "MAT1 field 5 (NU): Poisson's ratio 0.6",
            ),
            (
                "MAT1,1,2.1+11,,-1.,7850.",
                "MAT1 field 5 (NU): Poisson's ratio -1",
            ),
            (
                "MAT1,1,2.1+11,1.+10,,7850.",
                "MAT1 field 5 (NU): Poisson's ratio 9.5",
            ),
            (
                "MAT1,1,2.1+11,,.3,-1.",
                "MAT1 field 6 (RHO): -1 is negative",
            ),
        ];
        for (mat, want) in cases {
            let e = error(&format!("{mat}\nPSHELL,10,1,.002,1\n{grids}{quad}"));
            assert!(
                e.starts_with(&format!("t.bdf line 1: {want}")),
                "{mat}: {e}"
            );
        }
        let mat = "MAT1,1,2.1+11,,.3,7850.\n";
        let props = [
            ("PSHELL,10,1,0.,1", "PSHELL field 4 (T): 0 is not positive"),
            (
                "PSHELL,10,1,.002,1,,,,-1.",
                "PSHELL field 9 (NSM): -1 is negative",
            ),
            (
                "PBAR,10,1,0.,1.-8,1.-8,1.-8",
                "PBAR field 4 (A): 0 is not positive",
            ),
            (
                "PBAR,10,1,1.-4,,1.-8,1.-8",
                "PBAR field 5 (I1): the field is blank",
            ),
            (
                "PBAR,10,1,1.-4,1.-8,1.-8,-1.",
                "PBAR field 7 (J): -1 is negative",
            ),
            (
                "PBEAM,10,1,1.-4,1.-8,0.",
                "PBEAM field 6 (I2(A)): 0 is not positive",
            ),
            (
                "PBARL,10,1,,BAR\n,.01,.02,-1.",
                "PBARL field 4 (NSM) of continuation 1",
            ),
            ("PELAS,10,-5.", "PELAS field 3 (K1): -5 is negative"),
            ("PBUSH,10,K,1.,-1.", "PBUSH field 5 (K2): -1 is negative"),
        ];
        for (prop, want) in props {
            let elem = if prop.starts_with("PSHELL") {
                quad.to_string()
            } else if prop.starts_with("PELAS") {
                "CELAS1,1,10,1,1\n".to_string()
            } else if prop.starts_with("PBUSH") {
                "CBUSH,1,10,1,2\n".to_string()
            } else {
                "CBAR,1,10,1,2,0.,0.,1.\n".to_string()
            };
            let e = error(&format!("{mat}{prop}\n{grids}{elem}"));
            assert!(
                e.starts_with(&format!("t.bdf line 2: {want}")),
                "{prop}: {e}"
            );
        }
        let e = error(&format!("{mat}{grids}CONM2,1,1,,-2.\n"));
        assert!(e.contains("CONM2 field 5 (M): -2 is negative"), "{e}");
        // A shell needs NU < 0.5; the MAT1 card allows 0.5: the element names both cards.
        let e = error(&format!(
            "MAT1,1,2.1+11,,.5,7850.\nPSHELL,10,1,.002,1\n{grids}{quad}"
        ));
        assert!(
            e.starts_with("t.bdf line 7: CQUAD4 1 (property 10 at t.bdf line 2, material 1 at t.bdf line 1): nu = 0.5 is out of range"),
            "{e}"
        );
        // Dangling references are named at the card with file and line.
        let e = error(&format!("{mat}PSHELL,10,2,.002,1\n{grids}{quad}"));
        assert!(
            e.starts_with("t.bdf line 2:") && e.contains("MAT1 2"),
            "{e}"
        );
        let e = error(&format!(
            "{mat}PSHELL,10,1,.002,1\n{grids}CQUAD4,1,11,1,2,3,4\n"
        ));
        assert!(e.starts_with("t.bdf line 7:"), "{e}");
        let e = error(&format!(
            "{mat}PSHELL,10,1,.002,1\n{grids}CQUAD4,1,10,1,2,3,9\n"
        ));
        assert!(
            e.starts_with("t.bdf line 7:") && e.contains("GRID 9"),
            "{e}"
        );
    }

    #[test]
    fn cord2r_chains_place_grids() {
        // System 5: origin (1,2,3), z = basic z, x = basic y (so y = -basic x).
        // System 6 in 5: origin (0,0,1)_5 = (1,2,4), z along x_5 = basic y, x along z_5 = basic z,
        // y = z × x = basic x.
        let deck = "\
CORD2R*                6               5              0.              0.
*                     1.              1.              0.              1.
*                     0.              0.              2.
CORD2R,5,,1.,2.,3.,1.,2.,4.
,1.,3.,3.
GRID,1,5,1.,2.,.5
GRID,2,6,2.,3.,4.
GRID,3,0,1.,1.,1.
CONM2,9,3,,1.
";
        let m = parse(deck).model;
        assert!(close(m.nodes[&1], [-1.0, 3.0, 3.5]), "{:?}", m.nodes[&1]);
        assert!(close(m.nodes[&2], [4.0, 6.0, 6.0]), "{:?}", m.nodes[&2]);
        assert!(close(m.nodes[&3], [1.0, 1.0, 1.0]));
    }

    #[test]
    fn include_relative_quoted_and_continued() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("parts");
        std::fs::create_dir(&sub).unwrap();
        std::fs::write(
            sub.join("grids.bdf"),
            "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nINCLUDE 'more.bdf'\n",
        )
        .unwrap();
        std::fs::write(sub.join("more.bdf"), "GRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\n").unwrap();
        let main = dir.path().join("main.bdf");
        std::fs::write(
            &main,
            "SOL 103\nCEND\nBEGIN BULK\nMAT1,1,2.1+11,,.3,7850.\nINCLUDE 'par\n  ts/grids.bdf'\nPSHELL,10,1,.002,1\nCQUAD4,1,10,1,2,3,4\nENDDATA\n",
        )
        .unwrap();
        let b = read_bulk(&main).unwrap();
        assert_eq!(b.model.nodes.len(), 4);
        assert_eq!(b.model.elements.len(), 1);

        // A cycle: grids.bdf includes main.bdf.
        std::fs::write(
            sub.join("more.bdf"),
            "GRID,3,,1.,1.,0.\nINCLUDE '../main.bdf'\n",
        )
        .unwrap();
        let e = read_bulk(&main).unwrap_err().to_string();
        assert!(e.contains("more.bdf line 2: INCLUDE of"), "{e}");
        assert!(e.contains("closes a cycle"), "{e}");

        let e = parse_bulk("INCLUDE 'missing.bdf'\n", &main.display().to_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("main.bdf line 1: INCLUDE of"), "{e}");
        assert!(e.contains("missing.bdf"), "{e}");
        let e = parse_bulk("INCLUDE 'open\n", "x.bdf")
            .unwrap_err()
            .to_string();
        assert!(e.contains("closing quote is missing"), "{e}");
    }

    #[test]
    fn field_errors_name_file_line_card_and_field() {
        let e = error(&format!("{BASE}GRID,5,,0.,abc,0.\n"));
        assert_eq!(
            e,
            "t.bdf line 7: GRID field 5 (X2): `abc` is not a number; write a real number such as 2.1E11, 2.1+11, 0.5 or .5"
        );
        let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3\n"));
        assert_eq!(
            e,
            "t.bdf line 7: CQUAD4 field 7 (G4): the field is blank; an id (integer > 0) is required"
        );
        let e = error(&format!("{BASE}GRID,2,,5.,0.,0.\n"));
        assert_eq!(
            e,
            "t.bdf line 7: GRID field 2 (ID): grid 2 is already defined at t.bdf line 4; ids must be unique"
        );
        let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,4\nCTRIA3,1,10,1,2,3\n"));
        assert!(
            e.contains(
                "t.bdf line 8: CTRIA3 field 2 (EID): element 1 is already defined at t.bdf line 7"
            ),
            "{e}"
        );
        let e = error(&format!(
            "{BASE}PBARL,20,1,,BAR\n,.01,.02\nCBAR,5,20,1,2,0.,0.,1.\n,,,.5\n"
        ));
        assert_eq!(
            e,
            "t.bdf line 9: CBAR field 4 (W1A) of continuation 1 (line 10): 0.5 is not supported; offsets and pin flags are not supported: leave them blank or 0 and place the grid points on the axis"
        );
        let e = error(&format!("{BASE}PBAR,10,1,1.,1.,1.\n"));
        assert_eq!(
            e,
            "t.bdf line 7: PBAR field 2 (PID): property 10 is already defined at t.bdf line 2; ids must be unique"
        );
        let e = error(&format!("{BASE}PELAS,7,1.,,,7,2.\n"));
        assert!(
            e.contains(
                "t.bdf line 7: PELAS field 6 (PID2): property 7 is already defined at t.bdf line 7"
            ),
            "{e}"
        );
        // Large field: X3 sits on the second half-line, still field 6 of the first QRG line.
        let e = error(&format!(
            "{BASE}GRID*   5                               0.              0.\n*       1..5\n"
        ));
        assert_eq!(
            e,
            "t.bdf line 7: GRID field 6 (X3) (line 8): `1..5` is not a number; write a real number such as 2.1E11, 2.1+11, 0.5 or .5"
        );
        let e = error(&format!("{BASE}GRID,5,3,0.,0.,0.\n"));
        assert!(
            e.starts_with("t.bdf line 7: GRID field 3 (CP): coordinate system 3 is not a CORD2R"),
            "{e}"
        );
        let e = error(&format!("{BASE}SPC1,1,127,1\n"));
        assert!(
            e.starts_with("t.bdf line 7: SPC1 field 3 (C): `127` is not a component list"),
            "{e}"
        );
        let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,1.5\n"));
        assert!(
            e.starts_with("t.bdf line 7: CQUAD4 field 7 (G4): `1.5` is not an integer"),
            "{e}"
        );
        let e = error(&format!("{BASE}CBAR,5,20,1,2\n"));
        assert!(
            e.contains("CBAR field 6 (X1/G0): no orientation vector or G0 is given"),
            "{e}"
        );
        let e = error(&format!("{BASE}SPC,1,1,123,.01\n"));
        assert!(
            e.contains("SPC field 5 (D1): 0.01 is not supported; enforced displacements"),
            "{e}"
        );
        let e = error(&format!("{BASE}PBARL,20,1,,I\n,.1,.1,.01,.01,.01,.01\n"));
        assert!(
            e.contains("PBARL field 5 (TYPE): section type `I` is not supported; BAR, ROD or TUBE"),
            "{e}"
        );
        let e = error(&format!("{BASE}CONM2,9,1,2,1.\n"));
        assert!(
            e.contains("CONM2 field 4 (CID): coordinate system 2 is not supported"),
            "{e}"
        );
    }

    #[test]
    fn syntax_errors_name_the_line() {
        let e = error("+C1     1.\nGRID,1,,0.,0.,0.\n");
        assert!(
            e.starts_with("t.bdf line 1: a continuation line comes before any card"),
            "{e}"
        );
        let e = error(&format!(
            "{BASE}CBAR    5       20      1       2       0.      0.      1.              +A\n+B      1\n"
        ));
        assert!(
            e.starts_with("t.bdf line 8: continuation `+B` does not match `+A`"),
            "{e}"
        );
        let e = error(&format!("{BASE}SPC1,1,123,1,2,3,4,5,6,7,8,9\n"));
        assert!(
            e.starts_with("t.bdf line 7: this free-field line has 12 fields"),
            "{e}"
        );
        let e = error(&format!("{BASE}1.0 2.0\n"));
        assert!(
            e.contains("t.bdf line 7: `1.0 2.0` starts neither a card nor a continuation"),
            "{e}"
        );
        let e = error(&format!("{BASE}BEGIN SUPER=1\n"));
        assert!(
            e.contains("t.bdf line 7: `BEGIN SUPER=1` starts a part superelement"),
            "{e}"
        );
    }

    #[test]
    fn model_check_names_the_card_with_the_dangling_reference() {
        let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,9\n"));
        assert_eq!(
            e,
            "t.bdf line 7: element 1 (quad4) refers to node 9, which is not defined; add GRID 9 or correct the element's grid ids"
        );
        let e = error(&format!("{BASE}CQUAD4,1,11,1,2,3,4\n"));
        assert!(
            e.starts_with("t.bdf line 7: element 1 (quad4) refers to property 11"),
            "{e}"
        );
        let e = error(&format!("{BASE}PSHELL,11,2,.001,2\n"));
        assert!(
            e.starts_with(
                "t.bdf line 7: property 11 refers to material 2, which is not defined; add MAT1 2"
            ),
            "{e}"
        );
        let e = error(&format!("{BASE}SPC1,1,123,1,8\n"));
        assert!(
            e.starts_with("t.bdf line 7: a constraint refers to node 8"),
            "{e}"
        );
        let e = error(&format!("{BASE}SET1,3,1,2\n"));
        assert!(
            e.starts_with("t.bdf line 7: set `set3` lists element 1, which is not defined"),
            "{e}"
        );
        let e = error(&format!("{BASE}CELAS1,1,5,1,3\n"));
        assert!(
            e.contains("CELAS1 field 3 (PID): property 5 is not a PELAS"),
            "{e}"
        );
    }

    #[test]
    fn beam_properties_pbar_pbarl_pbeam() {
        let deck = format!(
            "{BASE}\
CBAR,1,21,1,2,0.,0.,1.
PBAR,21,1,1.-4,2.-8,3.-8,4.-8,.1
,,,,,,,,
,.8,.9
PBARL,22,1,MSCBML0,ROD
,.005,.2
PBARL,23,1,,TUBE
,.01,.008
PBEAM,24,1,2.,3.,4.,,5.,.3
,1.,1.
,YES,.5,2.,,4.
,1.,1.
,NO,1.,2.,3.,4.,0.,5.,.3
,.8
PBEAM,25,1,2.,3.,4.,,5.
"
        );
        let m = parse(&deck).model;
        let sec = |id: u64| m.beam_properties[&id].section.clone();
        assert_eq!(
            sec(21),
            BeamSection::General {
                area: 1e-4,
                iy: 3e-8,
                iz: 2e-8,
                j: 4e-8,
                shear_y: 0.8,
                shear_z: 0.9
            }
        );
        assert_eq!(m.beam_properties[&21].nsm, 0.1);
        assert_eq!(sec(22), BeamSection::Circle { radius: 0.005 });
        assert_eq!(m.beam_properties[&22].nsm, 0.2);
        assert_eq!(
            sec(23),
            BeamSection::Tube {
                outer_radius: 0.01,
                inner_radius: 0.008
            }
        );
        assert_eq!(
            sec(24),
            BeamSection::General {
                area: 2.0,
                iy: 4.0,
                iz: 3.0,
                j: 5.0,
                shear_y: 0.8,
                shear_z: 1.0
            }
        );
        assert_eq!(m.beam_properties[&24].nsm, 0.3);
        // PBEAM K1/K2 default to 1.0, PBAR's to 0.0 (no shear flexibility).
        let BeamSection::General {
            shear_y, shear_z, ..
        } = sec(25)
        else {
            panic!("not general");
        };
        assert_eq!((shear_y, shear_z), (1.0, 1.0));

        let e = error(&format!(
            "{BASE}PBEAM,24,1,2.,3.,4.,,5.\n,YES,1.,1.,3.,4.,,5.\n"
        ));
        assert!(e.contains("PBEAM field 4 (A) of continuation 1 (line 8): A = 1 differs from 2 at end A (a tapered beam)"), "{e}");
        let e = error(&format!("{BASE}PBAR,21,1,1.,1.,1.\n,,,,,,,,\n,,,.5\n"));
        assert!(e.contains("PBAR field 4 (I12) of continuation 2"), "{e}");
    }

    #[test]
    fn mat1_derives_the_missing_constant() {
        let deck = "MAT1,1,2.1+11,,.3,7850.\nMAT1,2,2.6+10,1.+10\nMAT1,3,,1.+10,.3\nMAT1,4,1.+9\nMAT1,5,200.,80.,.3\nGRID,1\nCONM2,1,1,,1.\n";
        let b = parse(deck);
        let m = &b.model.materials;
        assert_eq!((m[&1].e, m[&1].nu, m[&1].rho), (2.1e11, 0.3, 7850.0));
        assert!((m[&2].nu - 0.3).abs() < 1e-12);
        assert!((m[&3].e - 2.6e10).abs() < 1e-3);
        assert_eq!(m[&4].nu, 0.0);
        assert_eq!((m[&5].e, m[&5].nu), (200.0, 0.3));
        assert_eq!(b.warnings.len(), 2, "{:?}", b.warnings);
        assert!(b.warnings[0].starts_with("t.bdf line 4: MAT1 4: G and NU are blank"));
        assert!(
            b.warnings[1].starts_with("t.bdf line 5: MAT1 5: G = 80 does not equal E/(2(1+NU))")
        );
        let e = error("MAT1,1,,,.3\n");
        assert!(
            e.contains("MAT1 field 3 (E): E and G are both blank"),
            "{e}"
        );
    }

    #[test]
    fn springs_bushes_masses() {
        let deck = format!(
            "{BASE}\
CELAS1,20,7,1,3,2,3
PELAS,7,1000.,.01,,8,2000.
CELAS1,21,8,3,6
CELAS2,22,500.,,,4,2
CBUSH,30,9,1,2,,,,0
CBUSH,31,9,3,,0.,0.,1.
PBUSH,9,K,1.+6,2.+6,3.+6,,,6.
,,B,10.
CONM2,40,4,,2.5,.1,,.2
,1.,.1,2.,,,3.
CONM2,41,3,-1,1.,1.,1.,.5
"
        );
        let b = parse(&deck);
        let m = &b.model;
        assert_eq!(
            m.elements[&20],
            Element::ScalarSpring {
                dof: DofId::new(1, Component::Uz),
                other: Some(DofId::new(2, Component::Uz)),
                k: 1000.0
            }
        );
        assert_eq!(
            m.elements[&21],
            Element::ScalarSpring {
                dof: DofId::new(3, Component::Rz),
                other: None,
                k: 2000.0
            }
        );
        assert_eq!(
            m.elements[&22],
            Element::ScalarSpring {
                dof: DofId::new(4, Component::Uy),
                other: None,
                k: 500.0
            }
        );
        let k = [1e6, 2e6, 3e6, 0.0, 0.0, 6.0];
        assert_eq!(
            m.elements[&30],
            Element::Bush {
                node: 1,
                other: Some(2),
                k
            }
        );
        assert_eq!(
            m.elements[&31],
            Element::Bush {
                node: 3,
                other: None,
                k
            }
        );
        assert_eq!(
            m.elements[&40],
            Element::Mass {
                node: 4,
                mass: 2.5,
                inertia: [1.0, 0.1, 2.0, 0.0, 0.0, 3.0],
                offset: [0.1, 0.0, 0.2]
            }
        );
        let Element::Mass { offset, .. } = &m.elements[&41] else {
            panic!("not a mass");
        };
        assert!(close(*offset, [0.0, 0.0, 0.5]));
        let w = b.warnings.join("\n");
        assert!(w.contains("PELAS 7: damping GE is ignored"), "{w}");
        assert!(w.contains("CBUSH 31: the element system"), "{w}");
        assert!(w.contains("PBUSH 9: the B line(s) are ignored"), "{w}");
        assert_eq!(b.warnings.len(), 3, "{w}");
    }

    #[test]
    fn spc_spc1_set1_with_thru() {
        let deck = format!(
            "{BASE}\
GRID,7,,2.,2.,0.
CQUAD4,1,10,1,2,3,4
CTRIA3,2,10,1,2,3
CTRIA3,5,10,2,3,4
SPC,1,1,12,,2,3
SPC1,1,6,1,THRU,100
SPC1,2,45,4
SET1,3,1,THRU,4,5
SET1,4,SKIN,2
GRID,8,,3.,3.,3.,,246
"
        );
        let b = parse(&deck);
        let m = &b.model;
        let c = |n, comp| DofId::new(n, comp);
        use Component::*;
        let mut want = vec![
            c(1, Ux),
            c(1, Uy),
            c(2, Uz),
            c(4, Rx),
            c(4, Ry),
            c(8, Uy),
            c(8, Rx),
            c(8, Rz),
        ];
        want.extend([1, 2, 3, 4, 7, 8].map(|n| c(n, Rz)));
        want.sort();
        want.dedup();
        assert_eq!(m.constraints, want);
        assert_eq!(m.sets["set3"], vec![1, 2, 5]);
        assert_eq!(m.sets["set4"], vec![2]);
        assert_eq!(b.warnings.len(), 1);
        assert!(
            b.warnings[0].contains("SPC/SPC1 sets 1, 2 are merged"),
            "{:?}",
            b.warnings
        );
    }

    #[test]
    fn stated_deviations_warn() {
        let deck = format!(
            "{BASE}\
PSHELL,11,1,.001,,2.
PSHELL,12,1,.001,1,,2
GRID,9,,0.,0.,1.,3
CQUAD4,1,10,1,2,3,4
,,,.1,.1,.1,.1
"
        );
        let b = parse(&deck);
        let w = b.warnings.join("\n");
        assert!(w.contains("PSHELL 11: MID2 is blank"), "{w}");
        assert!(w.contains("PSHELL 11: 12I/T**3 = 2 is ignored"), "{w}");
        assert!(w.contains("PSHELL 12: MID3 2 differs from MID1"), "{w}");
        assert!(w.contains("CQUAD4 1: corner thicknesses"), "{w}");
        assert!(w.contains("GRID 9 has CD 3"), "{w}");
        let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,4,,.001\n"));
        assert!(
            e.contains("CQUAD4 field 9 (ZOFFS): 0.001 is not supported"),
            "{e}"
        );
    }

    #[test]
    fn femu_comments_name_sets_and_carry_parameters() {
        let deck = format!(
            "{BASE}\
CQUAD4,1,10,1,2,3,4
$femu-set 2 skin
SET1,2,1
$femu-set 3 nothing
$femu-parameter {{\"name\":\"t\",\"kind\":\"shell_thickness\",\"set\":\"skin\",\"lower\":0.001,\"upper\":0.003}}
"
        );
        let m = parse(&deck).model;
        assert_eq!(m.sets["skin"], vec![1]);
        assert_eq!(m.sets["nothing"], Vec::<u64>::new());
        assert_eq!(m.parameters.len(), 1);
        assert_eq!(m.parameters[0].set, "skin");
        let e = error("$femu-parameter {\"name\":1}\n");
        assert!(
            e.starts_with("t.bdf line 1: the femu parameter comment is not a valid parameter"),
            "{e}"
        );
    }

    #[test]
    fn fixture_plate_with_bar() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/nastran/plate_with_bar.bdf");
        let b = read_bulk(&path).unwrap();
        let m = &b.model;
        assert!(b.warnings.is_empty(), "{:?}", b.warnings);
        assert_eq!(b.unknown.len(), 2);
        assert_eq!((b.skipped["PARAM,POST"], b.skipped["EIGRL"]), (1, 1));
        assert!(b.ignored.is_empty());
        assert_eq!(m.nodes.len(), 25);
        for j in 0..5u64 {
            for i in 0..5u64 {
                let want = [0.1 * i as f64, 0.1 * j as f64, 0.0];
                assert!(
                    close(m.nodes[&(1 + i + 5 * j)], want),
                    "grid {}",
                    1 + i + 5 * j
                );
            }
        }
        assert_eq!(m.elements.len(), 20);
        for j in 0..4u64 {
            for i in 0..4u64 {
                let n = 1 + i + 5 * j;
                assert_eq!(
                    m.elements[&(1 + i + 4 * j)],
                    Element::Quad4 {
                        nodes: [n, n + 1, n + 6, n + 5],
                        property: 1
                    }
                );
            }
        }
        for (e, a) in [(101, 11), (102, 12), (103, 13), (104, 14)] {
            assert_eq!(
                m.elements[&e],
                Element::Beam {
                    nodes: [a, a + 1],
                    property: 2,
                    orientation: [0.0, 0.0, 1.0]
                }
            );
        }
        assert_eq!(
            m.materials[&1],
            Material {
                e: 2.1e11,
                nu: 0.3,
                rho: 7850.0
            }
        );
        assert_eq!(m.shell_properties[&1].thickness, 0.002);
        assert_eq!(
            m.beam_properties[&2],
            BeamProperty {
                material: 1,
                section: BeamSection::Rectangle {
                    width: 0.01,
                    height: 0.02
                },
                nsm: 0.0
            }
        );
        let clamped: Vec<DofId> = [1, 6, 11, 16, 21]
            .into_iter()
            .flat_map(|n| Component::ALL.map(|c| DofId::new(n, c)))
            .collect();
        assert_eq!(m.constraints, clamped);
        assert_eq!(m.sets["set5"], vec![101, 102, 103, 104]);
        assert_eq!(m.sets["pid1"], (1..=16).collect::<Vec<u64>>());
        assert_eq!(m.sets["pid2"], vec![101, 102, 103, 104]);
    }
}
