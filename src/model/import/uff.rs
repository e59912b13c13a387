//! Universal File Format (UFF) reader: nodes, elements and measured FRFs.
//!
//! Layouts follow the SDRC (I-DEAS) universal dataset descriptions as published by UC-SDRL
//! (`58.asc`, `164.asc`, the Binary 58 note), cross-checked against the readers and writers of
//! pyuff and UFFFiles.jl. The supported subset:
//!
//! - Datasets between `    -1` delimiter lines, LF or CRLF line ends. ASCII records are read
//!   field by field: as whitespace-separated values when a line holds exactly as many as the
//!   record has fields, else in the fixed Fortran columns. Reals may use `E`, `D` or the
//!   letter-less Fortran exponent (`0.1234+100`).
//! - **15** nodes (`4I10,1P3E13.5`) and **2411** nodes in double precision (`4I10` then
//!   `1P3D25.16`): label, definition and displacement coordinate systems, colour, coordinates
//!   as written (coordinate systems are kept, not applied).
//! - **2412** elements (`6I10`, then node labels `8I10` per line; rods and beams, descriptors 11
//!   and 21–24, carry the extra `3I10` orientation record), kept for display.
//! - **164** units: the length and force factors (`SI = file value / factor`) convert coordinates
//!   and any FRF whose unit labels are absent.
//! - **58** function at nodal DOF, ASCII and binary **58b** (byte ordering 1 little / 2 big
//!   endian, floating-point format 2 IEEE 754). Only function type 4 (frequency response
//!   function) is read; other function types are skipped, counted and warned about.
//!   - Record 6 directions ±1…±6 map to `ux uy uz rx ry rz`. A negative response or reference
//!     direction negates the data so that they refer to the positive directions (both negative:
//!     no change); [`Uff58::sign_flipped`] records it.
//!   - Record 7: ordinate data type 2/4 (real single/double) or 5/6 (complex single/double);
//!     even abscissa (minimum, increment) or uneven (`x` stored with every value; in 58b as
//!     `f64` for double data, `f32` accepted too, `f32` for single data).
//!   - Quantity from the ordinate numerator's specific data type (record 9 field 1): 8
//!     displacement → receptance, 11 velocity → mobility, 12 acceleration → accelerance. The
//!     denominator (record 10 field 1) is 13 excitation force or 9 reaction force. With type 0
//!     (unknown) or 1 (general) the unit label decides.
//!   - Units to SI: the unit labels of records 9/10 (e.g. `g`, `mm`, `in/s`, `m/s^2/N`, `lbf`,
//!     `N*m`), else dataset 164 with the unit exponents (the addendum A table, or the record's
//!     own exponents for type 1), else SI is assumed and warned about. The abscissa is in Hz
//!     unless record 8 says `rad/s`, `kHz` or `rpm`. Every conversion is listed in
//!     [`Uff58::conversions`] and [`UffFile::conversions`].
//! - Every other dataset is skipped and counted in [`UffFile::skipped`].
//!
//! [`to_frf_set`] groups FRF records into one [`FrfSet`] after checking they share quantity and
//! frequency lines. Errors name the file, the 1-based line, the dataset, record and field, what
//! was found and what is valid; no input makes the reader panic.

use crate::core::input::{EXCERPT_CHARS, excerpt};
use crate::core::{Component, DofId};
use crate::frf::{FrfPair, FrfSet, Quantity};
use faer::{Mat, c64};
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::f64::consts::PI;
use std::fmt;
use std::path::Path;

/// Standard gravity in m/s², the value of one `g`.
const STANDARD_GRAVITY: f64 = 9.806_65;
/// One pound-force in newtons.
const POUND_FORCE: f64 = 4.448_221_615_260_5;
/// Relative tolerance within which two records' frequency lines are the same line.
pub const LINE_TOLERANCE: f64 = 1e-9;

/// Everything read from a universal file.
#[derive(Clone, Debug, Default)]
pub struct UffFile {
    /// Nodes of datasets 15 and 2411: label and coordinates (SI when dataset 164 gives units).
    pub nodes: Vec<(u64, [f64; 3])>,
    /// Per node, in the order of `nodes`: definition coordinate system, displacement coordinate
    /// system and colour.
    pub node_systems: Vec<[u32; 3]>,
    /// Elements of dataset 2412.
    pub elements: Vec<UffElement>,
    /// FRF records of datasets 58 and 58b, in file order.
    pub frfs: Vec<Uff58>,
    /// The last units dataset (164) read.
    pub units: Option<UffUnits>,
    /// Every conversion done (units, abscissa, sign flips), naming the record it applies to.
    pub conversions: Vec<String>,
    /// Assumptions made and records skipped, each stated once.
    pub warnings: Vec<String>,
    /// Datasets not read, `(dataset number, count)`, ascending by number.
    pub skipped: Vec<(u32, usize)>,
}

/// One element of dataset 2412.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UffElement {
    /// Element label.
    pub id: u64,
    /// FE descriptor id (e.g. 21 linear beam, 44 plane stress quadrilateral, 94 thin shell).
    pub descriptor: u32,
    /// Physical property table number.
    pub physical_property: u32,
    /// Material property table number.
    pub material_property: u32,
    /// Colour.
    pub color: u32,
    /// Node labels, in the element's order.
    pub nodes: Vec<u64>,
    /// The orientation record of rods and beams.
    pub beam: Option<UffBeam>,
    /// 1-based line of the element's first record.
    pub line: usize,
}

/// The extra record of a rod or beam element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UffBeam {
    /// Beam orientation node.
    pub orientation_node: u64,
    /// Fore-end cross-section number.
    pub fore_section: u32,
    /// Aft-end cross-section number.
    pub aft_section: u32,
}

/// The units of dataset 164.
#[derive(Clone, Debug, PartialEq)]
pub struct UffUnits {
    /// Units code (1 SI, 2 BG, 3 MG, 4 BA, 5 MM, 6 CM, 7 IN, 8 GM, 9 user, 10 MN).
    pub code: u32,
    /// Units description as written.
    pub description: String,
    /// File length units per metre (`SI = file value / factor`).
    pub length_factor: f64,
    /// File force units per newton.
    pub force_factor: f64,
    /// 1-based line of the dataset's number line.
    pub line: usize,
}

impl UffUnits {
    fn is_si(&self) -> bool {
        self.length_factor == 1.0 && self.force_factor == 1.0
    }
}

/// Ordinate data type of dataset 58 record 7 field 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OrdinateType {
    /// Code 2: real, single precision.
    RealSingle,
    /// Code 4: real, double precision.
    RealDouble,
    /// Code 5: complex, single precision.
    ComplexSingle,
    /// Code 6: complex, double precision.
    ComplexDouble,
}

impl OrdinateType {
    /// The code in record 7 field 1.
    pub fn code(self) -> u32 {
        match self {
            OrdinateType::RealSingle => 2,
            OrdinateType::RealDouble => 4,
            OrdinateType::ComplexSingle => 5,
            OrdinateType::ComplexDouble => 6,
        }
    }

    /// The type of a record 7 code.
    pub fn from_code(code: i64) -> Option<Self> {
        match code {
            2 => Some(OrdinateType::RealSingle),
            4 => Some(OrdinateType::RealDouble),
            5 => Some(OrdinateType::ComplexSingle),
            6 => Some(OrdinateType::ComplexDouble),
            _ => None,
        }
    }

    /// True for the complex types.
    pub fn is_complex(self) -> bool {
        matches!(
            self,
            OrdinateType::ComplexSingle | OrdinateType::ComplexDouble
        )
    }

    /// True for the double-precision types.
    pub fn is_double(self) -> bool {
        matches!(self, OrdinateType::RealDouble | OrdinateType::ComplexDouble)
    }
}

impl fmt::Display for OrdinateType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            OrdinateType::RealSingle => "real single precision",
            OrdinateType::RealDouble => "real double precision",
            OrdinateType::ComplexSingle => "complex single precision",
            OrdinateType::ComplexDouble => "complex double precision",
        };
        write!(f, "{name} ({})", self.code())
    }
}

/// Byte order of binary 58b data (header field 3: 1 little, 2 big endian).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ByteOrder {
    /// Code 1, least significant byte first.
    Little,
    /// Code 2, most significant byte first.
    Big,
}

impl ByteOrder {
    /// The code in the 58b header.
    pub fn code(self) -> u32 {
        match self {
            ByteOrder::Little => 1,
            ByteOrder::Big => 2,
        }
    }
}

/// Abscissa spacing of an FRF record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Abscissa {
    /// Record 7 spacing 1: lines `start + k step`, only the ordinates stored.
    Even {
        /// First line, Hz.
        start_hz: f64,
        /// Line increment, Hz.
        step_hz: f64,
    },
    /// Record 7 spacing 0: every value stored with its abscissa.
    Uneven,
}

/// One FRF record of dataset 58 or 58b, in SI units and referred to positive directions.
#[derive(Clone, Debug, PartialEq)]
pub struct Uff58 {
    /// File the record was read from (empty for records made in memory).
    pub file: String,
    /// 1-based line of the dataset's number line (`    58`), 0 for records made in memory.
    pub line: usize,
    /// Byte order of binary (58b) data, `None` for ASCII.
    pub binary: Option<ByteOrder>,
    /// ID lines 1–5 (records 1–5), trailing blanks removed.
    pub id_lines: [String; 5],
    /// Function identification number (record 6 field 2).
    pub function_id: i64,
    /// Load case identification number (record 6 field 4).
    pub load_case: i64,
    /// Response DOF (record 6 fields 6–7).
    pub response: DofId,
    /// Reference (excitation) DOF (record 6 fields 9–10).
    pub reference: DofId,
    /// Response direction code as written, ±1…±6.
    pub response_direction: i8,
    /// Reference direction code as written, ±1…±6.
    pub reference_direction: i8,
    /// True when exactly one of the two directions is negative, so the data were negated.
    pub sign_flipped: bool,
    /// Ordinate data type as written (record 7 field 1).
    pub ordinate: OrdinateType,
    /// Response quantity (record 9 field 1 or its unit label).
    pub quantity: Quantity,
    /// Abscissa spacing (record 7 fields 3–5, converted to Hz).
    pub abscissa: Abscissa,
    /// Frequency lines in Hz.
    pub freqs_hz: Vec<f64>,
    /// Values in SI units (m, m/s, m/s², rad…, per N or N·m), one per line.
    pub values: Vec<c64>,
    /// Every conversion done on this record.
    pub conversions: Vec<String>,
}

impl Uff58 {
    /// The response/excitation pair the record holds.
    pub fn pair(&self) -> FrfPair {
        FrfPair {
            response: self.response,
            excitation: self.reference,
        }
    }
}

/// Why a universal file, or a group of its FRF records, cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum UffError {
    /// The file could not be read.
    #[error("cannot read `{file}`: {source}")]
    Io {
        /// The file.
        file: String,
        /// The system error.
        #[source]
        source: std::io::Error,
    },
    /// A line outside any dataset is not the delimiter.
    #[error(
        "{file}:{line}: expected the dataset delimiter `    -1` (-1 right-justified in columns 1-6), found {found}"
    )]
    Delimiter {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// An excerpt of the line in backquotes, or, before the file's first dataset, a note
        /// that it is not quoted.
        found: String,
    },
    /// The line after a delimiter does not hold a dataset number.
    #[error(
        "{file}:{line}: expected a dataset number after `    -1` (I6, e.g. `    58`, or `    58b` for binary data), found {found}"
    )]
    DatasetNumber {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// An excerpt of the line in backquotes, or, before the file's first dataset, a note
        /// that it is not quoted.
        found: String,
    },
    /// The file ends inside a dataset.
    #[error("{file}:{line}: the file ends inside {} that starts at line {start}; expected {expected}", dataset_name(*dataset))]
    Truncated {
        /// The file.
        file: String,
        /// 1-based number of the last line of the file.
        line: usize,
        /// The dataset number, when it was read.
        dataset: Option<u32>,
        /// 1-based line of the dataset's opening `    -1`.
        start: usize,
        /// What was still expected.
        expected: String,
    },
    /// A field holds a value that is not valid.
    #[error("{file}:{line}: dataset {dataset}, {record}, {field}: found `{found}`; valid: {valid}")]
    Field {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// Dataset number.
        dataset: u32,
        /// Record, e.g. `record 7`.
        record: &'static str,
        /// Field, e.g. `field 1 (ordinate data type)`.
        field: String,
        /// The text or value found.
        found: String,
        /// What would be valid.
        valid: String,
    },
    /// A node label is defined twice.
    #[error("{file}: node {node} is defined twice, at lines {first} and {second}")]
    DuplicateNode {
        /// The file.
        file: String,
        /// Node label.
        node: u64,
        /// Line of the first definition.
        first: usize,
        /// Line of the second definition.
        second: usize,
    },
    /// Two FRF records cannot form one set.
    #[error(
        "the FRF records at {first_file}:{first_line} and {second_file}:{second_line} cannot form one FRF set: {reason}"
    )]
    Inconsistent {
        /// File of the first record.
        first_file: String,
        /// Line of the first record's dataset number.
        first_line: usize,
        /// File of the second record.
        second_file: String,
        /// Line of the second record's dataset number.
        second_line: usize,
        /// What differs.
        reason: String,
    },
    /// The frequency lines of a record are not strictly ascending.
    #[error(
        "{file}:{line}: the frequency lines of this FRF record are not strictly ascending (line {index}: {previous} Hz, then {next} Hz); an FRF set needs ascending lines"
    )]
    NotAscending {
        /// The file.
        file: String,
        /// Line of the record's dataset number.
        line: usize,
        /// Zero-based index of the offending line.
        index: usize,
        /// Frequency before it, Hz.
        previous: f64,
        /// Its frequency, Hz.
        next: f64,
    },
    /// A measured value is NaN or infinite.
    #[error(transparent)]
    NonFinite(Box<NonFiniteValue>),
    /// No FRF record to group.
    #[error("no FRF records (dataset 58, function type 4) to form an FRF set from")]
    NoFrfs,
}

/// A measured value that is NaN or infinite, and where it is.
#[derive(Debug, thiserror::Error)]
#[error(
    "{file}:{line}: dataset 58{binary} (FRF record {index} of the file, header at line {header}), H({response}, {reference}): the value of spectral line {point} ({freq_hz} Hz) is {found}; measured values must be finite (a NaN or infinite value makes every correlation over the record meaningless); remove or repair the record"
)]
pub struct NonFiniteValue {
    /// The file.
    pub file: String,
    /// 1-based line holding the value (ASCII), or the dataset number's line (58b).
    pub line: usize,
    /// `b` for binary data, else empty.
    pub binary: &'static str,
    /// 1-based index of the FRF record among the file's dataset 58 records.
    pub index: usize,
    /// Line of the record's dataset number.
    pub header: usize,
    /// Response DOF.
    pub response: DofId,
    /// Reference DOF.
    pub reference: DofId,
    /// 1-based spectral line.
    pub point: usize,
    /// Its frequency, Hz.
    pub freq_hz: f64,
    /// What was found (e.g. `NaN in the real part`).
    pub found: String,
}

fn dataset_name(d: Option<u32>) -> String {
    match d {
        Some(n) => format!("dataset {n}"),
        None => "the dataset".to_string(),
    }
}

/// Reads and parses a universal file, read under the process-wide input policy
/// ([`crate::core::input`]: regular files only, bounded size, optional confinement).
pub fn read_uff(path: impl AsRef<Path>) -> Result<UffFile, UffError> {
    let path = path.as_ref();
    let file = path.display().to_string();
    let bytes = crate::core::input::read_input(path).map_err(|e| UffError::Io {
        file: file.clone(),
        source: std::io::Error::other(e),
    })?;
    parse_uff(&bytes, &file)
}

/// Parses the bytes of a universal file; `file_name` is used in messages.
pub fn parse_uff(bytes: &[u8], file_name: &str) -> Result<UffFile, UffError> {
    let mut cur = Cursor::new(bytes);
    let mut ctx = Ctx {
        file: file_name,
        units: None,
        warnings: Vec::new(),
        node_lines: HashMap::new(),
        warned: HashSet::new(),
        skipped_functions: BTreeMap::new(),
        datasets: 0,
        frf_records: 0,
    };
    let mut out = UffFile::default();
    let mut skipped: BTreeMap<u32, usize> = BTreeMap::new();
    while let Some(block) = next_block(&mut cur, &mut ctx)? {
        ctx.datasets += 1;
        match (block.number, block.binary.is_some()) {
            (58, _) => match parse_58(&block, &mut ctx)? {
                Some(rec) => {
                    out.conversions.extend(rec.conversions.iter().cloned());
                    out.frfs.push(rec);
                }
                None => *skipped.entry(58).or_default() += 1,
            },
            (15, false) => parse_nodes_15(&block, &mut ctx, &mut out)?,
            (2411, false) => parse_nodes_2411(&block, &mut ctx, &mut out)?,
            (2412, false) => parse_elements_2412(&block, &ctx, &mut out)?,
            (164, false) => ctx.units = Some(parse_units_164(&block, ctx.file)?),
            (n, _) => *skipped.entry(n).or_default() += 1,
        }
    }
    for (ty, (count, line)) in &ctx.skipped_functions {
        ctx.warnings.push(format!(
            "{file_name}: {count} dataset 58 record(s) of function type {ty} ({}) skipped, the first at line {line}; only type 4 (frequency response function) is read",
            function_name(*ty)
        ));
    }
    out.units = ctx.units;
    out.warnings = ctx.warnings;
    out.skipped = skipped.into_iter().collect();
    Ok(out)
}

/// Groups FRF records into one set: same quantity, same lines (within [`LINE_TOLERANCE`]
/// relative), strictly ascending lines, no pair twice. The lines are the first record's.
pub fn to_frf_set(frfs: &[Uff58]) -> Result<FrfSet, UffError> {
    let first = frfs.first().ok_or(UffError::NoFrfs)?;
    for (k, w) in first.freqs_hz.windows(2).enumerate() {
        if w[1] <= w[0] || w[1].is_nan() || w[0].is_nan() {
            return Err(UffError::NotAscending {
                file: first.file.clone(),
                line: first.line,
                index: k + 1,
                previous: w[0],
                next: w[1],
            });
        }
    }
    let inconsistent = |a: &Uff58, b: &Uff58, reason: String| UffError::Inconsistent {
        first_file: a.file.clone(),
        first_line: a.line,
        second_file: b.file.clone(),
        second_line: b.line,
        reason,
    };
    let mut seen: HashMap<FrfPair, &Uff58> = HashMap::new();
    for rec in frfs {
        if rec.quantity != first.quantity {
            return Err(inconsistent(
                first,
                rec,
                format!(
                    "the first holds {}, the second {}",
                    first.quantity.name(),
                    rec.quantity.name()
                ),
            ));
        }
        if rec.freqs_hz.len() != first.freqs_hz.len() {
            return Err(inconsistent(
                first,
                rec,
                format!(
                    "the first has {} frequency lines, the second {}",
                    first.freqs_hz.len(),
                    rec.freqs_hz.len()
                ),
            ));
        }
        for (k, (a, b)) in first.freqs_hz.iter().zip(&rec.freqs_hz).enumerate() {
            let gap = (a - b).abs();
            if gap > LINE_TOLERANCE * a.abs().max(b.abs()) || gap.is_nan() {
                return Err(inconsistent(
                    first,
                    rec,
                    format!(
                        "line {k} is {a} Hz in the first and {b} Hz in the second (more than {LINE_TOLERANCE:e} relative apart)"
                    ),
                ));
            }
        }
        if rec.values.len() != first.freqs_hz.len() {
            return Err(inconsistent(
                first,
                rec,
                format!(
                    "the second has {} values for {} lines",
                    rec.values.len(),
                    first.freqs_hz.len()
                ),
            ));
        }
        if let Some(prev) = seen.insert(rec.pair(), rec) {
            return Err(inconsistent(
                prev,
                rec,
                format!("both hold H({}, {})", rec.response, rec.reference),
            ));
        }
    }
    Ok(FrfSet {
        quantity: first.quantity,
        freqs_hz: first.freqs_hz.clone(),
        pairs: frfs.iter().map(Uff58::pair).collect(),
        values: Mat::from_fn(first.freqs_hz.len(), frfs.len(), |i, j| frfs[j].values[i]),
    })
}

// ---------------------------------------------------------------------------------------------
// Lines, blocks and fields.

/// A position in the file, line by line, with raw byte runs for binary data.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// 1-based number of the next line.
    line: usize,
}

impl<'a> Cursor<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Cursor {
            bytes,
            pos: 0,
            line: 1,
        }
    }

    /// The next line without its line end, with its 1-based number.
    fn next_line(&mut self) -> Option<(usize, &'a [u8])> {
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
    fn last_line(&self) -> usize {
        self.line.saturating_sub(1).max(1)
    }

    fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    /// Whether a delimiter line follows `n` bytes from here, after at most one line end.
    fn delimiter_after(&self, n: usize) -> bool {
        let Some(rest) = self.pos.checked_add(n).and_then(|s| self.bytes.get(s..)) else {
            return false;
        };
        let rest = skip_line_end(rest);
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        is_delimiter(&rest[..end])
    }

    /// Takes `n` raw bytes, then the line end that may follow them.
    fn take_binary(&mut self, n: usize) -> Option<&'a [u8]> {
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

fn skip_line_end(b: &[u8]) -> &[u8] {
    b.strip_prefix(b"\r\n")
        .or_else(|| b.strip_prefix(b"\n"))
        .unwrap_or(b)
}

fn is_delimiter(line: &[u8]) -> bool {
    line.trim_ascii() == b"-1"
}

fn text(raw: &[u8]) -> Cow<'_, str> {
    String::from_utf8_lossy(raw)
}

/// A text shortened for a message: at most [`EXCERPT_CHARS`] characters.
fn shown(s: &str) -> String {
    let s = s.trim();
    if s.is_empty() {
        return "(blank)".to_string();
    }
    excerpt(s, EXCERPT_CHARS)
}

/// A line quoted in a structural error: an excerpt once the file has shown itself to be a
/// universal file (a dataset was read), else a note that the text is not quoted.
fn quoted_line(ctx: &Ctx<'_>, raw: &[u8]) -> String {
    if ctx.datasets > 0 {
        format!("`{}`", shown(&text(raw)))
    } else {
        "a line that is not quoted: nothing before it is a universal file dataset, so the file does not look like a universal file".to_string()
    }
}

/// Columns `a..b` (0-based, byte columns) of a line, empty past its end.
fn col(raw: &[u8], a: usize, b: usize) -> String {
    let n = raw.len();
    text(&raw[a.min(n)..b.min(n)]).into_owned()
}

/// The fields of a numeric record: its whitespace-separated values when there are exactly as
/// many as `widths`, else its fixed Fortran columns.
fn fields(raw: &[u8], widths: &[usize]) -> Vec<String> {
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
fn parse_real(s: &str) -> Option<f64> {
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
fn split_numbers(token: &str) -> Vec<&str> {
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
struct At<'f> {
    file: &'f str,
    line: usize,
    dataset: u32,
    record: &'static str,
}

impl At<'_> {
    fn err(
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

    fn int(&self, s: &str, field: &str, valid: &str) -> Result<i64, UffError> {
        s.trim()
            .parse::<i64>()
            .map_err(|_| self.err(field, s, valid))
    }

    fn int_or_zero(&self, s: &str, field: &str, valid: &str) -> Result<i64, UffError> {
        if s.trim().is_empty() {
            Ok(0)
        } else {
            self.int(s, field, valid)
        }
    }

    fn label(&self, s: &str, field: &str) -> Result<u64, UffError> {
        s.trim()
            .parse::<u64>()
            .map_err(|_| self.err(field, s, "a non-negative integer label"))
    }

    fn small(&self, s: &str, field: &str) -> Result<u32, UffError> {
        if s.trim().is_empty() {
            return Ok(0);
        }
        s.trim()
            .parse::<u32>()
            .map_err(|_| self.err(field, s, "a non-negative integer"))
    }

    fn real(&self, s: &str, field: &str) -> Result<f64, UffError> {
        parse_real(s)
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err(field, s, "a finite real number, e.g. 1.25000E+02"))
    }

    fn real_or_zero(&self, s: &str, field: &str) -> Result<f64, UffError> {
        if s.trim().is_empty() {
            Ok(0.0)
        } else {
            self.real(s, field)
        }
    }
}

/// A dataset: its number, lines and binary data.
struct Block<'a> {
    number: u32,
    /// Line of the dataset number.
    header_line: usize,
    /// ASCII lines between the number line and the closing delimiter (for 58b: the ASCII
    /// records announced by the header).
    lines: Vec<(usize, &'a [u8])>,
    binary: Option<Binary<'a>>,
    /// Line of the closing `    -1`.
    end: usize,
}

struct Binary<'a> {
    order: ByteOrder,
    data: &'a [u8],
}

/// Reading state shared by the datasets of one file.
struct Ctx<'f> {
    file: &'f str,
    units: Option<UffUnits>,
    warnings: Vec<String>,
    node_lines: HashMap<u64, usize>,
    /// Keys of the warnings given once per file.
    warned: HashSet<&'static str>,
    /// Skipped dataset 58 function types: count and first line.
    skipped_functions: BTreeMap<i64, (usize, usize)>,
    /// Datasets read so far (before the first, the file's text is not quoted in messages).
    datasets: usize,
    /// Dataset 58 records met so far.
    frf_records: usize,
}

impl Ctx<'_> {
    fn warn(&mut self, w: String) {
        if !self.warnings.contains(&w) {
            self.warnings.push(w);
        }
    }

    /// A warning given once per file, at its first occurrence.
    fn warn_once(&mut self, key: &'static str, w: String) {
        if self.warned.insert(key) {
            self.warnings.push(w);
        }
    }
}

/// Reads the next dataset, `None` at the end of the file.
fn next_block<'a>(cur: &mut Cursor<'a>, ctx: &mut Ctx<'_>) -> Result<Option<Block<'a>>, UffError> {
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
    let Some((header_line, hraw)) = cur.next_line() else {
        return Err(UffError::Truncated {
            file: file.to_string(),
            line: cur.last_line(),
            dataset: None,
            start,
            expected: "a dataset number after the opening `    -1`".to_string(),
        });
    };
    let htext = text(hraw);
    let mut toks = htext.split_whitespace();
    let first = toks.next().unwrap_or("");
    let (number_text, is_binary) = match first.strip_suffix(['b', 'B']) {
        Some(n) => (n, true),
        None => (first, false),
    };
    let number: u32 = number_text.parse().map_err(|_| UffError::DatasetNumber {
        file: file.to_string(),
        line: header_line,
        found: quoted_line(ctx, hraw),
    })?;
    let truncated = |cur: &Cursor<'_>, expected: String| UffError::Truncated {
        file: file.to_string(),
        line: cur.last_line(),
        dataset: Some(number),
        start,
        expected,
    };
    let mut lines = Vec::new();
    if !is_binary {
        let end = loop {
            match cur.next_line() {
                None => {
                    return Err(truncated(
                        cur,
                        "more records and the closing `    -1`".to_string(),
                    ));
                }
                Some((no, raw)) if is_delimiter(raw) => break no,
                Some(l) => lines.push(l),
            }
        };
        return Ok(Some(Block {
            number,
            header_line,
            lines,
            binary: None,
            end,
        }));
    }

    // Binary header: Format(I6,1A1,I6,I6,I12,I12,I6,I6,I12,I12).
    let at = At {
        file,
        line: header_line,
        dataset: number,
        record: "binary header",
    };
    let rest: Vec<&str> = toks.collect();
    let get = |i: usize, a: usize, b: usize, field: &str| -> Result<i64, UffError> {
        let s = if rest.len() >= 4 {
            rest[i].to_string()
        } else {
            col(hraw, a, b)
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
    for k in 0..n_ascii {
        match cur.next_line() {
            Some(l) => lines.push(l),
            None => {
                return Err(truncated(
                    cur,
                    format!("{n_ascii} ASCII lines after the binary header (field 5), found {k}"),
                ));
            }
        }
    }
    let mut candidates = vec![n_bytes];
    if number == 58 {
        for s in binary_sizes_58(&lines) {
            if !candidates.contains(&s) {
                candidates.push(s);
            }
        }
    }
    let Some(size) = candidates.iter().copied().find(|&c| cur.delimiter_after(c)) else {
        if cur.remaining() < n_bytes {
            return Err(truncated(
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
        return Err(at.err(
            "field 6 (number of bytes)",
            n_bytes,
            format!(
                "the count of binary data bytes, after which `    -1` closes the dataset{implied}"
            ),
        ));
    };
    if size != n_bytes {
        ctx.warn(format!(
            "{file}:{header_line}: dataset 58b declares {n_bytes} bytes of binary data, but the closing `    -1` follows after {size} bytes, as record 7 implies; {size} bytes read"
        ));
    }
    let data = cur
        .take_binary(size)
        .ok_or_else(|| truncated(cur, format!("{size} bytes of binary data")))?;
    let end = match cur.next_line() {
        Some((no, raw)) if is_delimiter(raw) => no,
        _ => {
            return Err(truncated(
                cur,
                "the closing `    -1` after the binary data".to_string(),
            ));
        }
    };
    Ok(Some(Block {
        number,
        header_line,
        lines,
        binary: Some(Binary { order, data }),
        end,
    }))
}

// ---------------------------------------------------------------------------------------------
// Dataset 58.

const RECORDS: [&str; 13] = [
    "record 0",
    "record 1",
    "record 2",
    "record 3",
    "record 4",
    "record 5",
    "record 6",
    "record 7",
    "record 8",
    "record 9",
    "record 10",
    "record 11",
    "record 12",
];

/// Record 6, DOF identification: Format(2(I5,I10),2(1X,10A1,I10,I4)).
struct DofRecord {
    function_type: i64,
    function_id: i64,
    load_case: i64,
    response_node: i64,
    response_direction: i64,
    reference_node: i64,
    reference_direction: i64,
}

fn parse_record_6(at: &At<'_>, raw: &[u8]) -> Result<DofRecord, UffError> {
    const DIR: &str = "±1..±6";
    let fixed = || -> Result<DofRecord, UffError> {
        Ok(DofRecord {
            function_type: at.int(
                &col(raw, 0, 5),
                "field 1 (function type)",
                "an integer, 4 for an FRF",
            )?,
            function_id: at.int_or_zero(
                &col(raw, 5, 15),
                "field 2 (function identification number)",
                "an integer",
            )?,
            load_case: at.int_or_zero(&col(raw, 20, 30), "field 4 (load case)", "an integer")?,
            response_node: at.int(&col(raw, 41, 51), "field 6 (response node)", "a node label")?,
            response_direction: at.int(&col(raw, 51, 55), "field 7 (response direction)", DIR)?,
            reference_node: at.int(
                &col(raw, 66, 76),
                "field 9 (reference node)",
                "a node label",
            )?,
            reference_direction: at.int(
                &col(raw, 76, 80),
                "field 10 (reference direction)",
                DIR,
            )?,
        })
    };
    // Entity names may hold blanks, so the fixed columns come first; they are trusted only
    // when the line keeps the layout (80 columns, blank 1X separators), which a label wider
    // than its field breaks.
    let t = text(raw);
    let keeps_layout = t.trim_end().len() <= 80
        && [30, 55]
            .iter()
            .all(|&c| raw.get(c).is_none_or(|b| *b == b' '));
    match fixed().and_then(|r| {
        if keeps_layout {
            Ok(r)
        } else {
            Err(at.err(
                "the whole record",
                t.trim_end(),
                "Format(2(I5,I10),2(1X,10A1,I10,I4)): 80 columns, blanks in columns 31 and 56",
            ))
        }
    }) {
        Ok(r) => Ok(r),
        Err(e) => {
            let toks: Vec<&str> = t.split_whitespace().collect();
            let num = |i: usize| toks.get(i).and_then(|s| s.parse::<i64>().ok());
            if toks.len() == 10 {
                if let (Some(a), Some(b), Some(_), Some(c), Some(d), Some(e2), Some(f), Some(g)) = (
                    num(0),
                    num(1),
                    num(2),
                    num(3),
                    num(5),
                    num(6),
                    num(8),
                    num(9),
                ) {
                    return Ok(DofRecord {
                        function_type: a,
                        function_id: b,
                        load_case: c,
                        response_node: d,
                        response_direction: e2,
                        reference_node: f,
                        reference_direction: g,
                    });
                }
            }
            Err(e)
        }
    }
}

/// Record 7, data form: Format(3I10,3E13.5).
struct FormRecord {
    ordinate: i64,
    points: i64,
    spacing: i64,
    start: f64,
    step: f64,
}

fn parse_record_7(at: &At<'_>, raw: &[u8]) -> Result<FormRecord, UffError> {
    let f = fields(raw, &[10, 10, 10, 13, 13, 13]);
    Ok(FormRecord {
        ordinate: at.int(&f[0], "field 1 (ordinate data type)", ORDINATE_VALID)?,
        points: at.int(&f[1], "field 2 (number of points)", "an integer >= 1")?,
        spacing: at.int(
            &f[2],
            "field 3 (abscissa spacing)",
            "0 (uneven) or 1 (even)",
        )?,
        start: at.real_or_zero(&f[3], "field 4 (abscissa minimum)")?,
        step: at.real_or_zero(&f[4], "field 5 (abscissa increment)")?,
    })
}

const ORDINATE_VALID: &str =
    "2 (real single), 4 (real double), 5 (complex single) or 6 (complex double)";

/// Records 8–11, axis data characteristics: Format(I10,3I5,2(1X,20A1)).
struct AxisRecord {
    at_line: usize,
    specific_type: i64,
    length_exponent: i64,
    force_exponent: i64,
    unit: String,
}

fn parse_axis_record(at: &At<'_>, raw: &[u8]) -> Result<AxisRecord, UffError> {
    let fixed = || -> Result<(i64, i64, i64), UffError> {
        Ok((
            at.int_or_zero(
                &col(raw, 0, 10),
                "field 1 (specific data type)",
                "an integer code",
            )?,
            at.int_or_zero(
                &col(raw, 10, 15),
                "field 2 (length units exponent)",
                "an integer",
            )?,
            at.int_or_zero(
                &col(raw, 15, 20),
                "field 3 (force units exponent)",
                "an integer",
            )?,
        ))
    };
    let (ints, unit) = match fixed() {
        Ok(ints) => (ints, col(raw, 47, usize::MAX).trim().to_string()),
        Err(e) => {
            let t = text(raw);
            let toks: Vec<&str> = t.split_whitespace().collect();
            let num = |i: usize| toks.get(i).and_then(|s| s.parse::<i64>().ok());
            match (num(0), num(1), num(2), num(3)) {
                (Some(a), Some(b), Some(c), Some(_)) => (
                    (a, b, c),
                    toks.get(5).map_or(String::new(), |s| s.to_string()),
                ),
                _ => return Err(e),
            }
        }
    };
    Ok(AxisRecord {
        at_line: at.line,
        specific_type: ints.0,
        length_exponent: ints.1,
        force_exponent: ints.2,
        unit,
    })
}

/// Possible byte counts of 58b data from record 7, for headers that miscount.
fn binary_sizes_58(lines: &[(usize, &[u8])]) -> Vec<usize> {
    let Some((_, raw)) = lines.get(6) else {
        return Vec::new();
    };
    let f = fields(raw, &[10, 10, 10, 13, 13, 13]);
    let (Ok(ord), Ok(n), Ok(spacing)) = (
        f[0].parse::<i64>(),
        f[1].parse::<usize>(),
        f[2].parse::<i64>(),
    ) else {
        return Vec::new();
    };
    let Some(ord) = OrdinateType::from_code(ord) else {
        return Vec::new();
    };
    let s = if ord.is_double() { 8 } else { 4 };
    let ky = if ord.is_complex() { 2 } else { 1 };
    let per = |x: usize| n.checked_mul(ky * s + x);
    let sizes = if spacing == 1 {
        vec![per(0)]
    } else if s == 8 {
        vec![per(8), per(4)]
    } else {
        vec![per(4)]
    };
    sizes.into_iter().flatten().collect()
}

fn function_name(t: i64) -> &'static str {
    const NAMES: [&str; 29] = [
        "general or unknown",
        "time response",
        "auto spectrum",
        "cross spectrum",
        "frequency response function",
        "transmissibility",
        "coherence",
        "auto correlation",
        "cross correlation",
        "power spectral density",
        "energy spectral density",
        "probability density function",
        "spectrum",
        "cumulative frequency distribution",
        "peaks valley",
        "stress/cycles",
        "strain/cycles",
        "orbit",
        "mode indicator function",
        "force pattern",
        "partial power",
        "partial coherence",
        "eigenvalue",
        "eigenvector",
        "shock response spectrum",
        "finite impulse response filter",
        "multiple coherence",
        "order function",
        "phase compensation",
    ];
    usize::try_from(t)
        .ok()
        .and_then(|i| NAMES.get(i))
        .copied()
        .unwrap_or("unknown type")
}

fn specific_type_name(t: i64) -> &'static str {
    match t {
        0 => "unknown",
        1 => "general",
        2 => "stress",
        3 => "strain",
        5 => "temperature",
        6 => "heat flux",
        8 => "displacement",
        9 => "reaction force",
        11 => "velocity",
        12 => "acceleration",
        13 => "excitation force",
        15 => "pressure",
        16 => "mass",
        17 => "time",
        18 => "frequency",
        19 => "rpm",
        20 => "order",
        _ => "not a specific data type code",
    }
}

/// A DOF from a node field and a direction field of record 6.
fn dof_of(
    at: &At<'_>,
    node: i64,
    dir: i64,
    node_field: &str,
    dir_field: &str,
) -> Result<(DofId, i8), UffError> {
    let node =
        u64::try_from(node).map_err(|_| at.err(node_field, node, "a non-negative node label"))?;
    let comp = u8::try_from(dir.unsigned_abs())
        .ok()
        .filter(|_| dir != 0)
        .and_then(Component::from_nastran)
        .ok_or_else(|| {
            at.err(
                dir_field,
                dir,
                "±1..±6 (1-3 X/Y/Z translation, 4-6 X/Y/Z rotation, negative for the opposite sense); 0 (scalar) has no DOF",
            )
        })?;
    // |dir| <= 6 here.
    Ok((DofId::new(node, comp), dir as i8))
}

fn parse_58(b: &Block<'_>, ctx: &mut Ctx<'_>) -> Result<Option<Uff58>, UffError> {
    let file = ctx.file;
    ctx.frf_records += 1;
    let index = ctx.frf_records;
    let at = |k: usize, line: usize| At {
        file,
        line,
        dataset: 58,
        record: RECORDS[k],
    };
    let record = |k: usize| {
        b.lines.get(k - 1).copied().ok_or_else(|| {
            at(k, b.end).err(
                "the whole record",
                "the closing `    -1`",
                "records 1-11 (ID lines, DOF identification, data form, axis characteristics) before the data",
            )
        })
    };
    if b.binary.is_some() && b.lines.len() != 11 {
        return Err(At {
            file,
            line: b.header_line,
            dataset: 58,
            record: "binary header",
        }
        .err(
            "field 5 (number of ASCII lines)",
            b.lines.len(),
            "11 for dataset 58 (records 1-11)",
        ));
    }
    let mut id_lines: [String; 5] = Default::default();
    for (k, id) in id_lines.iter_mut().enumerate() {
        *id = text(record(k + 1)?.1).trim_end().to_string();
    }
    let (l6, r6) = record(6)?;
    let at6 = at(6, l6);
    let dofs = parse_record_6(&at6, r6)?;
    let (l7, r7) = record(7)?;
    let at7 = at(7, l7);
    let form = parse_record_7(&at7, r7)?;
    let mut axes = Vec::with_capacity(4);
    for k in 8..=11 {
        let (l, r) = record(k)?;
        axes.push(parse_axis_record(&at(k, l), r)?);
    }
    if dofs.function_type != 4 {
        let e = ctx
            .skipped_functions
            .entry(dofs.function_type)
            .or_insert((0, b.header_line));
        e.0 += 1;
        return Ok(None);
    }

    let ordinate = OrdinateType::from_code(form.ordinate).ok_or_else(|| {
        at7.err(
            "field 1 (ordinate data type)",
            form.ordinate,
            ORDINATE_VALID,
        )
    })?;
    let even = match form.spacing {
        1 => true,
        0 => false,
        s => return Err(at7.err("field 3 (abscissa spacing)", s, "0 (uneven) or 1 (even)")),
    };
    let n = usize::try_from(form.points)
        .ok()
        .filter(|&n| n >= 1)
        .ok_or_else(|| at7.err("field 2 (number of points)", form.points, "an integer >= 1"))?;
    if even && form.step <= 0.0 {
        return Err(at7.err(
            "field 5 (abscissa increment)",
            form.step,
            "an increment > 0 for even spacing",
        ));
    }
    let (response, response_direction) = dof_of(
        &at6,
        dofs.response_node,
        dofs.response_direction,
        "field 6 (response node)",
        "field 7 (response direction)",
    )?;
    let (reference, reference_direction) = dof_of(
        &at6,
        dofs.reference_node,
        dofs.reference_direction,
        "field 9 (reference node)",
        "field 10 (reference direction)",
    )?;

    // Record 12: the data.
    let ky = if ordinate.is_complex() { 2 } else { 1 };
    let per_point = ky + usize::from(!even);
    let layout = format!(
        "{n} points of {ordinate}{}",
        if even {
            ", even abscissa"
        } else {
            ", each with its abscissa"
        }
    );
    let total = n.checked_mul(per_point).ok_or_else(|| {
        at7.err(
            "field 2 (number of points)",
            n,
            "a count that fits in memory",
        )
    })?;
    // The first value that is not finite: its index among the data values and its line.
    let mut first_bad: Option<(usize, usize)> = None;
    let (xs, ys) = match &b.binary {
        None => {
            let mut vals: Vec<f64> = Vec::new();
            for &(no, raw) in b.lines.get(11..).unwrap_or_default() {
                let t = text(raw);
                for tok in t.split_whitespace() {
                    for part in split_numbers(tok) {
                        let v = parse_real(part).ok_or_else(|| {
                            at(12, no).err(
                                format!("data value {}", vals.len() + 1),
                                part,
                                "a real number, e.g. -1.23456E-02",
                            )
                        })?;
                        if vals.len() == total {
                            return Err(at(12, no).err(
                                "data values",
                                format!("more than {total} values"),
                                format!("{total} values: {layout} (record 7)"),
                            ));
                        }
                        if !v.is_finite() && first_bad.is_none() {
                            first_bad = Some((vals.len(), no));
                        }
                        vals.push(v);
                    }
                }
            }
            if vals.len() < total {
                return Err(at(12, b.end).err(
                    "data values",
                    format!("{} values before the closing `    -1`", vals.len()),
                    format!("{total} values: {layout} (record 7)"),
                ));
            }
            if even {
                (Vec::new(), vals)
            } else {
                let mut xs = Vec::new();
                let mut ys = Vec::new();
                for chunk in vals.chunks(per_point) {
                    xs.push(chunk[0]);
                    ys.extend_from_slice(&chunk[1..]);
                }
                (xs, ys)
            }
        }
        Some(bin) => {
            let (xs, ys) =
                decode_binary(bin, n, ky, even, ordinate, &layout, &at(12, b.header_line))?;
            // As the ASCII index: abscissa first when uneven, then the ordinate parts.
            first_bad = (0..n).find_map(|k| {
                let x = if even { None } else { Some(xs[k]) };
                let parts = x
                    .into_iter()
                    .chain(ys[k * ky..(k + 1) * ky].iter().copied());
                parts
                    .enumerate()
                    .find(|(_, v)| !v.is_finite())
                    .map(|(r, _)| (k * per_point + r, b.header_line))
            });
            (xs, ys)
        }
    };

    // Abscissa.
    let (af, abscissa_note) = abscissa_factor(ctx, &axes[0], &at(8, axes[0].at_line))?;
    let mut conversions = Vec::new();
    let loc = format!("{file}:{} H({response}, {reference})", b.header_line);
    if let Some(note) = abscissa_note {
        conversions.push(format!("{loc}: {note}"));
    }
    let freqs_hz: Vec<f64> = if even {
        (0..n)
            .map(|k| (form.start + k as f64 * form.step) * af)
            .collect()
    } else {
        for (k, x) in xs.iter().enumerate() {
            if !x.is_finite() {
                return Err(at(12, b.header_line).err(
                    format!("abscissa of point {}", k + 1),
                    x,
                    "a finite frequency",
                ));
            }
        }
        xs.iter().map(|x| x * af).collect()
    };
    if freqs_hz.iter().any(|f| !f.is_finite()) {
        return Err(at7.err(
            "fields 4-5 (abscissa minimum and increment)",
            format!("{} + k·{}", form.start, form.step),
            "values whose lines stay finite",
        ));
    }
    let abscissa = if even {
        Abscissa::Even {
            start_hz: form.start * af,
            step_hz: form.step * af,
        }
    } else {
        Abscissa::Uneven
    };

    // Ordinate: quantity, units, sign.
    let (quantity, factor, unit_note) = resolve_ordinate(
        ctx,
        &axes[1],
        &axes[2],
        &at(9, axes[1].at_line),
        &at(10, axes[2].at_line),
        response.comp.is_rotation(),
        reference.comp.is_rotation(),
    )?;
    if let Some(note) = unit_note {
        conversions.push(format!("{loc}: {note}"));
    }
    let sign_flipped = (response_direction < 0) != (reference_direction < 0);
    if sign_flipped {
        conversions.push(format!(
            "{loc}: response direction {response_direction:+} and reference direction {reference_direction:+}: data negated to refer to the positive directions"
        ));
    }
    let scale = if sign_flipped { -factor } else { factor };
    let values: Vec<c64> = if ordinate.is_complex() {
        ys.chunks(2)
            .map(|c| c64::new(c[0], c.get(1).copied().unwrap_or(0.0)))
            .collect()
    } else {
        ys.iter().map(|&y| c64::new(y, 0.0)).collect()
    };
    let values: Vec<c64> = if scale == 1.0 {
        values
    } else {
        values.into_iter().map(|v| v * scale).collect()
    };
    let non_finite = |point: usize, line: usize, found: String| {
        UffError::NonFinite(Box::new(NonFiniteValue {
            file: file.to_string(),
            line,
            binary: if b.binary.is_some() { "b" } else { "" },
            index,
            header: b.header_line,
            response,
            reference,
            point: point + 1,
            freq_hz: freqs_hz.get(point).copied().unwrap_or(f64::NAN),
            found,
        }))
    };
    if let Some((i, line)) = first_bad {
        let (point, r) = (i / per_point, i % per_point);
        let found = match r.checked_sub(usize::from(!even)) {
            None => format!(
                "{} in the abscissa",
                xs.get(point).copied().unwrap_or(f64::NAN)
            ),
            Some(part) => {
                let v = ys.get(point * ky + part).copied().unwrap_or(f64::NAN);
                let which = match (ordinate.is_complex(), part) {
                    (false, _) => "",
                    (true, 0) => " in the real part",
                    (true, _) => " in the imaginary part",
                };
                format!("{v}{which}")
            }
        };
        return Err(non_finite(point, line, found));
    }
    if let Some(k) = values
        .iter()
        .position(|v| !(v.re.is_finite() && v.im.is_finite()))
    {
        return Err(non_finite(
            k,
            b.header_line,
            format!("infinite after conversion to SI (factor {scale:e})"),
        ));
    }
    Ok(Some(Uff58 {
        file: file.to_string(),
        line: b.header_line,
        binary: b.binary.as_ref().map(|bin| bin.order),
        id_lines,
        function_id: dofs.function_id,
        load_case: dofs.load_case,
        response,
        reference,
        response_direction,
        reference_direction,
        sign_flipped,
        ordinate,
        quantity,
        abscissa,
        freqs_hz,
        values,
        conversions,
    }))
}

/// Reads the abscissa and ordinate values of 58b data.
fn decode_binary(
    bin: &Binary<'_>,
    n: usize,
    ky: usize,
    even: bool,
    ordinate: OrdinateType,
    layout: &str,
    at: &At<'_>,
) -> Result<(Vec<f64>, Vec<f64>), UffError> {
    let s = if ordinate.is_double() { 8 } else { 4 };
    let mut layouts: Vec<usize> = Vec::new(); // abscissa sizes, 0 for even
    if even {
        layouts.push(0);
    } else {
        layouts.push(s);
        if s == 8 {
            layouts.push(4);
        }
    }
    let size = |xs: usize| n.checked_mul(ky * s + xs);
    let Some(xsize) = layouts
        .iter()
        .copied()
        .find(|&xs| size(xs) == Some(bin.data.len()))
    else {
        let expected: Vec<String> = layouts
            .iter()
            .filter_map(|&xs| size(xs).map(|v| v.to_string()))
            .collect();
        return Err(at.err(
            "binary data length",
            format!("{} bytes", bin.data.len()),
            format!("{} bytes for {layout}", expected.join(" or ")),
        ));
    };
    let mut rd = BinReader {
        data: bin.data,
        pos: 0,
        order: bin.order,
    };
    let mut xs = Vec::with_capacity(if even { 0 } else { n });
    let mut ys = Vec::with_capacity(n * ky);
    let short = || at.err("binary data length", "too few bytes", layout.to_string());
    for _ in 0..n {
        if xsize > 0 {
            xs.push(rd.read(xsize).ok_or_else(short)?);
        }
        for _ in 0..ky {
            ys.push(rd.read(s).ok_or_else(short)?);
        }
    }
    Ok((xs, ys))
}

struct BinReader<'a> {
    data: &'a [u8],
    pos: usize,
    order: ByteOrder,
}

impl BinReader<'_> {
    fn read(&mut self, size: usize) -> Option<f64> {
        let bytes = self.data.get(self.pos..self.pos.checked_add(size)?)?;
        self.pos += size;
        Some(match (size, self.order) {
            (4, ByteOrder::Little) => f64::from(f32::from_le_bytes(bytes.try_into().ok()?)),
            (4, ByteOrder::Big) => f64::from(f32::from_be_bytes(bytes.try_into().ok()?)),
            (8, ByteOrder::Little) => f64::from_le_bytes(bytes.try_into().ok()?),
            (8, ByteOrder::Big) => f64::from_be_bytes(bytes.try_into().ok()?),
            _ => return None,
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Units.

/// A unit label made comparable: no blanks, lower case, `²` → `^2`, `sec` → `s`, `µ` → `u`.
/// `None` for a blank label or `NONE`.
fn normalise_unit(s: &str) -> Option<String> {
    let t: String = s.chars().filter(|c| !c.is_whitespace()).collect();
    let t = t
        .replace('²', "^2")
        .replace("**", "^")
        .replace(['µ', 'μ'], "u")
        .replace('·', "*")
        .to_lowercase()
        .replace("sec", "s");
    if t.is_empty() || t == "none" {
        None
    } else {
        Some(t)
    }
}

fn strip_parens(s: &str) -> &str {
    s.strip_prefix('(')
        .and_then(|x| x.strip_suffix(')'))
        .unwrap_or(s)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Motion {
    Displacement,
    Velocity,
    Acceleration,
}

impl Motion {
    fn name(self) -> &'static str {
        match self {
            Motion::Displacement => "displacement",
            Motion::Velocity => "velocity",
            Motion::Acceleration => "acceleration",
        }
    }

    fn quantity(self) -> Quantity {
        match self {
            Motion::Displacement => Quantity::Receptance,
            Motion::Velocity => Quantity::Mobility,
            Motion::Acceleration => Quantity::Accelerance,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct MotionUnit {
    kind: Motion,
    rotational: bool,
    /// SI per file unit.
    factor: f64,
}

#[derive(Clone, Copy, Debug)]
struct ForceUnit {
    moment: bool,
    /// SI per file unit.
    factor: f64,
}

fn length_unit(s: &str) -> Option<(f64, bool)> {
    Some(match strip_parens(s) {
        "m" => (1.0, false),
        "mm" => (1e-3, false),
        "cm" => (1e-2, false),
        "um" | "micron" => (1e-6, false),
        "nm" => (1e-9, false),
        "in" | "inch" => (0.0254, false),
        "ft" => (0.3048, false),
        "mil" => (2.54e-5, false),
        "rad" => (1.0, true),
        "mrad" => (1e-3, true),
        "deg" | "°" => (PI / 180.0, true),
        _ => return None,
    })
}

fn motion_unit(s: &str) -> Option<MotionUnit> {
    let s = strip_parens(s);
    if s == "g" || s == "gn" {
        return Some(MotionUnit {
            kind: Motion::Acceleration,
            rotational: false,
            factor: STANDARD_GRAVITY,
        });
    }
    for suffix in ["/s^2", "/s2", "/s/s"] {
        if let Some(base) = s.strip_suffix(suffix) {
            let (factor, rotational) = length_unit(base)?;
            return Some(MotionUnit {
                kind: Motion::Acceleration,
                rotational,
                factor,
            });
        }
    }
    if let Some(base) = s.strip_suffix("/s") {
        let (factor, rotational) = length_unit(base)?;
        return Some(MotionUnit {
            kind: Motion::Velocity,
            rotational,
            factor,
        });
    }
    let (factor, rotational) = length_unit(s)?;
    Some(MotionUnit {
        kind: Motion::Displacement,
        rotational,
        factor,
    })
}

fn force_unit(s: &str) -> Option<ForceUnit> {
    const LBF_IN: f64 = POUND_FORCE * 0.0254;
    const LBF_FT: f64 = POUND_FORCE * 0.3048;
    let (factor, moment) = match strip_parens(s) {
        "n" => (1.0, false),
        "kn" => (1e3, false),
        "mn" => (1e-3, false),
        "lbf" | "lb" | "lbs" => (POUND_FORCE, false),
        "kgf" => (STANDARD_GRAVITY, false),
        "nm" | "n*m" | "n.m" | "n-m" | "m*n" => (1.0, true),
        "knm" | "kn*m" | "kn.m" | "kn-m" => (1e3, true),
        "nmm" | "n*mm" | "n.mm" | "n-mm" => (1e-3, true),
        "lbf*in" | "lbf.in" | "lbf-in" | "lbfin" | "in*lbf" | "in.lbf" | "in-lbf" | "inlbf" => {
            (LBF_IN, true)
        }
        "lbf*ft" | "lbf.ft" | "lbf-ft" | "lbfft" | "ft*lbf" | "ft.lbf" | "ft-lbf" | "ftlbf" => {
            (LBF_FT, true)
        }
        _ => return None,
    };
    Some(ForceUnit { moment, factor })
}

/// An ordinate numerator label, possibly with its force denominator (`m/s^2/N`, `g/lbf`).
/// `Ok(None)` for no label, `Err(())` for one not understood.
fn frf_label(raw: &str) -> Result<Option<(MotionUnit, Option<ForceUnit>)>, ()> {
    let Some(n) = normalise_unit(raw) else {
        return Ok(None);
    };
    if let Some(m) = motion_unit(&n) {
        return Ok(Some((m, None)));
    }
    for (i, _) in n.rmatch_indices('/') {
        if let (Some(m), Some(f)) = (motion_unit(&n[..i]), force_unit(&n[i + 1..])) {
            return Ok(Some((m, Some(f))));
        }
    }
    Err(())
}

const MOTION_LABELS: &str = "a motion unit such as m, mm, um, in, m/s, mm/s, in/s, m/s^2, mm/s^2, g, rad, rad/s, rad/s^2, optionally over a force (m/s^2/N, g/lbf, m/N); or NONE";
const FORCE_LABELS: &str =
    "a force unit N, kN, mN, lbf, kgf, or a moment unit N*m, kN*m, N*mm, lbf*in, lbf*ft; or NONE";

fn si_unit(kind: Motion, rot_response: bool, rot_reference: bool) -> String {
    let base = if rot_response { "rad" } else { "m" };
    let num = match kind {
        Motion::Displacement => base.to_string(),
        Motion::Velocity => format!("{base}/s"),
        Motion::Acceleration => format!("{base}/s^2"),
    };
    if rot_reference {
        format!("{num}/(N*m)")
    } else {
        format!("{num}/N")
    }
}

/// Units factor (SI per file unit) from dataset 164 for a quantity of dimension
/// length^`len` · force^`force`.
fn units_factor(units: &UffUnits, len: i64, force: i64) -> f64 {
    let e = |x: i64| i32::try_from(x.clamp(-64, 64)).unwrap_or(0);
    units.length_factor.powi(-e(len)) * units.force_factor.powi(-e(force))
}

/// Quantity and SI factor of the ordinate from records 9 (numerator) and 10 (denominator),
/// with a description of the conversion when the factor is not one.
fn resolve_ordinate(
    ctx: &mut Ctx<'_>,
    num: &AxisRecord,
    den: &AxisRecord,
    at9: &At<'_>,
    at10: &At<'_>,
    rot_response: bool,
    rot_reference: bool,
) -> Result<(Quantity, f64, Option<String>), UffError> {
    let type_kind = match num.specific_type {
        8 => Some(Motion::Displacement),
        11 => Some(Motion::Velocity),
        12 => Some(Motion::Acceleration),
        0 | 1 => None,
        t => {
            return Err(at9.err(
                "field 1 (specific data type)",
                format!("{t} ({})", specific_type_name(t)),
                "8 (displacement), 11 (velocity) or 12 (acceleration) over force; 0 or 1 with a unit label",
            ));
        }
    };
    match den.specific_type {
        13 | 9 | 0 | 1 => {}
        t => {
            return Err(at10.err(
                "field 1 (specific data type)",
                format!("{t} ({})", specific_type_name(t)),
                "13 (excitation force) or 9 (reaction force); 0 or 1 with a force unit label",
            ));
        }
    }
    let num_label = frf_label(&num.unit)
        .map_err(|()| at9.err("field 6 (units label)", &num.unit, MOTION_LABELS))?;
    let den_label = match normalise_unit(&den.unit) {
        None => None,
        Some(n) => Some(
            force_unit(&n)
                .ok_or_else(|| at10.err("field 6 (units label)", &den.unit, FORCE_LABELS))?,
        ),
    };
    let kind = match (type_kind, num_label.map(|(m, _)| m.kind)) {
        (Some(t), Some(l)) if t != l => {
            return Err(at9.err(
                "field 6 (units label)",
                format!("{} (a {} unit)", num.unit, l.name()),
                format!(
                    "a {} unit, as field 1 gives specific data type {} ({})",
                    t.name(),
                    num.specific_type,
                    t.name()
                ),
            ));
        }
        (Some(t), _) => t,
        (None, Some(l)) => l,
        (None, None) => {
            return Err(at9.err(
                "field 1 (specific data type)",
                format!(
                    "{} ({}) with units label `{}`",
                    num.specific_type,
                    specific_type_name(num.specific_type),
                    num.unit.trim()
                ),
                "8 (displacement), 11 (velocity) or 12 (acceleration), or a units label in field 6 that tells which",
            ));
        }
    };
    let sense = |rot: bool| if rot { "rotation" } else { "translation" };
    if let Some((m, f)) = num_label {
        if m.rotational != rot_response {
            return Err(at9.err(
                "field 6 (units label)",
                format!("{} (a {} unit)", num.unit, sense(m.rotational)),
                format!(
                    "a {} unit, as the response direction is a {}",
                    sense(rot_response),
                    sense(rot_response)
                ),
            ));
        }
        if let Some(f) = f {
            if f.moment != rot_reference {
                return Err(at9.err(
                    "field 6 (units label)",
                    &num.unit,
                    format!(
                        "a label over a {}, as the reference direction is a {}",
                        if rot_reference { "moment" } else { "force" },
                        sense(rot_reference)
                    ),
                ));
            }
        }
    }
    if let Some(f) = den_label {
        if f.moment != rot_reference {
            return Err(at10.err(
                "field 6 (units label)",
                &den.unit,
                format!(
                    "a {} unit, as the reference direction is a {}",
                    if rot_reference { "moment" } else { "force" },
                    sense(rot_reference)
                ),
            ));
        }
    }

    let units = ctx.units.clone().filter(|u| !u.is_si());
    let mut sources: Vec<String> = Vec::new();
    let mut unlabelled = false;
    let num_factor = match (num_label, &units) {
        (Some((m, _)), _) => {
            sources.push(format!("record 9 label `{}`", num.unit.trim()));
            m.factor
        }
        (None, Some(u)) => {
            let (l, f) = if num.specific_type == 1 {
                (num.length_exponent, num.force_exponent)
            } else if rot_response {
                (0, 0)
            } else {
                (1, 0)
            };
            sources.push(format!(
                "dataset 164 units `{}` (line {}) with numerator exponents length {l}, force {f}",
                u.description, u.line
            ));
            units_factor(u, l, f)
        }
        (None, None) => {
            unlabelled = true;
            1.0
        }
    };
    let label_force = num_label.and_then(|(_, f)| f);
    let den_factor = match (label_force, den_label, &units) {
        (Some(a), Some(b), _) => {
            if (a.factor - b.factor).abs() > 1e-12 * a.factor.abs() {
                return Err(at10.err(
                    "field 6 (units label)",
                    &den.unit,
                    format!(
                        "the force unit of record 9's label `{}`, or NONE",
                        num.unit.trim()
                    ),
                ));
            }
            a.factor
        }
        (Some(a), None, _) => a.factor,
        (None, Some(b), _) => {
            sources.push(format!("record 10 label `{}`", den.unit.trim()));
            b.factor
        }
        (None, None, Some(u)) => {
            let (l, f) = if den.specific_type == 1 {
                (den.length_exponent, den.force_exponent)
            } else if rot_reference {
                (1, 1)
            } else {
                (0, 1)
            };
            sources.push(format!(
                "dataset 164 units `{}` with denominator exponents length {l}, force {f}",
                u.description
            ));
            units_factor(u, l, f)
        }
        (None, None, None) => {
            unlabelled = true;
            1.0
        }
    };
    if unlabelled {
        ctx.warn_once("unlabelled", format!(
            "{}: dataset 58 records without unit labels in records 9/10 (first at line {}), and no dataset 164 before them: their values are taken as SI",
            ctx.file, at9.line
        ));
    }
    if den.specific_type == 0 && den_label.is_none() && label_force.is_none() {
        ctx.warn_once("denominator", format!(
            "{}: dataset 58 records with an unknown ordinate denominator (record 10 field 1 = 0, first at line {}) are taken as over excitation force",
            ctx.file, at10.line
        ));
    }
    let factor = num_factor / den_factor;
    if !(factor.is_finite() && factor > 0.0) {
        return Err(at9.err(
            "fields 2-3 (units exponents)",
            format!("{} and {}", num.length_exponent, num.force_exponent),
            "exponents that give a finite conversion factor",
        ));
    }
    let note = (factor != 1.0).then(|| {
        format!(
            "ordinate converted to SI {} from {}: ×{factor:e}",
            si_unit(kind, rot_response, rot_reference),
            sources.join(" and ")
        )
    });
    Ok((kind.quantity(), factor, note))
}

/// Factor from the file's abscissa unit to Hz (record 8), with a note when not one.
fn abscissa_factor(
    ctx: &mut Ctx<'_>,
    axis: &AxisRecord,
    at8: &At<'_>,
) -> Result<(f64, Option<String>), UffError> {
    match axis.specific_type {
        18 | 0 | 1 => {}
        t => {
            return Err(at8.err(
                "field 1 (specific data type)",
                format!("{t} ({})", specific_type_name(t)),
                "18 (frequency), or 0/1 with a units label Hz, rad/s, kHz or rpm; an FRF needs a frequency abscissa",
            ));
        }
    }
    let Some(unit) = normalise_unit(&axis.unit) else {
        if axis.specific_type != 18 {
            ctx.warn_once("abscissa", format!(
                "{}: dataset 58 abscissas without the frequency type (record 8 field 1 = 18) or a units label (first at line {}) are taken as Hz",
                ctx.file, at8.line
            ));
        }
        return Ok((1.0, None));
    };
    let factor = match unit.as_str() {
        "hz" | "1/s" | "cps" | "cycles/s" | "s^-1" => return Ok((1.0, None)),
        "khz" => 1e3,
        "rad/s" => 1.0 / (2.0 * PI),
        "rpm" | "rev/min" | "1/min" | "cpm" => 1.0 / 60.0,
        _ => {
            return Err(at8.err(
                "field 6 (units label)",
                &axis.unit,
                "Hz, rad/s, kHz, rpm, or NONE (Hz)",
            ));
        }
    };
    Ok((
        factor,
        Some(format!(
            "abscissa in {} converted to Hz: ×{factor:e}",
            axis.unit.trim()
        )),
    ))
}

// ---------------------------------------------------------------------------------------------
// Datasets 15, 2411, 2412, 164.

fn length_conversion(ctx: &Ctx<'_>) -> Option<(f64, String)> {
    let u = ctx.units.as_ref().filter(|u| u.length_factor != 1.0)?;
    Some((
        1.0 / u.length_factor,
        format!("dataset 164 units `{}` (line {})", u.description, u.line),
    ))
}

fn add_node(
    ctx: &mut Ctx<'_>,
    out: &mut UffFile,
    id: u64,
    xyz: [f64; 3],
    systems: [u32; 3],
    line: usize,
) -> Result<(), UffError> {
    if let Some(first) = ctx.node_lines.insert(id, line) {
        return Err(UffError::DuplicateNode {
            file: ctx.file.to_string(),
            node: id,
            first,
            second: line,
        });
    }
    let xyz = match length_conversion(ctx) {
        Some((f, _)) => xyz.map(|x| x * f),
        None => xyz,
    };
    out.nodes.push((id, xyz));
    out.node_systems.push(systems);
    Ok(())
}

fn note_node_conversion(ctx: &Ctx<'_>, out: &mut UffFile, b: &Block<'_>, count: usize) {
    if let Some((f, source)) = length_conversion(ctx) {
        if count > 0 {
            out.conversions.push(format!(
                "{}:{}: dataset {} coordinates of {count} nodes converted to m from {source}: ×{f:e}",
                ctx.file, b.header_line, b.number
            ));
        }
    }
}

/// Dataset 15, nodes: Format(4I10,1P3E13.5) per node.
fn parse_nodes_15(b: &Block<'_>, ctx: &mut Ctx<'_>, out: &mut UffFile) -> Result<(), UffError> {
    let mut count = 0;
    for &(no, raw) in &b.lines {
        if raw.trim_ascii().is_empty() {
            continue;
        }
        let at = At {
            file: ctx.file,
            line: no,
            dataset: 15,
            record: "record 1",
        };
        let f = fields(raw, &[10, 10, 10, 10, 13, 13, 13]);
        let id = at.label(&f[0], "field 1 (node label)")?;
        let systems = [
            at.small(&f[1], "field 2 (definition coordinate system)")?,
            at.small(&f[2], "field 3 (displacement coordinate system)")?,
            at.small(&f[3], "field 4 (colour)")?,
        ];
        let xyz = [
            at.real(&f[4], "field 5 (x)")?,
            at.real(&f[5], "field 6 (y)")?,
            at.real(&f[6], "field 7 (z)")?,
        ];
        add_node(ctx, out, id, xyz, systems, no)?;
        count += 1;
    }
    note_node_conversion(ctx, out, b, count);
    Ok(())
}

/// Dataset 2411, nodes in double precision: Format(4I10) then Format(1P3D25.16) per node.
fn parse_nodes_2411(b: &Block<'_>, ctx: &mut Ctx<'_>, out: &mut UffFile) -> Result<(), UffError> {
    let lines: Vec<(usize, &[u8])> = b
        .lines
        .iter()
        .copied()
        .filter(|(_, raw)| !raw.trim_ascii().is_empty())
        .collect();
    let mut count = 0;
    for pair in lines.chunks(2) {
        let (no, raw) = pair[0];
        let at1 = At {
            file: ctx.file,
            line: no,
            dataset: 2411,
            record: "record 1",
        };
        let f = fields(raw, &[10, 10, 10, 10]);
        let id = at1.label(&f[0], "field 1 (node label)")?;
        let systems = [
            at1.small(&f[1], "field 2 (export coordinate system)")?,
            at1.small(&f[2], "field 3 (displacement coordinate system)")?,
            at1.small(&f[3], "field 4 (colour)")?,
        ];
        let Some(&(no2, raw2)) = pair.get(1) else {
            return Err(At {
                record: "record 2",
                line: b.end,
                ..at1
            }
            .err(
                "node coordinates",
                "the closing `    -1`",
                format!("the coordinates of node {id} (1P3D25.16)"),
            ));
        };
        let at2 = At {
            line: no2,
            record: "record 2",
            ..at1
        };
        let c = fields(raw2, &[25, 25, 25]);
        let xyz = [
            at2.real(&c[0], "field 1 (x)")?,
            at2.real(&c[1], "field 2 (y)")?,
            at2.real(&c[2], "field 3 (z)")?,
        ];
        add_node(ctx, out, id, xyz, systems, no)?;
        count += 1;
    }
    note_node_conversion(ctx, out, b, count);
    Ok(())
}

/// FE descriptors whose elements carry the beam record (rods and beams).
const BEAM_DESCRIPTORS: [u32; 5] = [11, 21, 22, 23, 24];

/// Dataset 2412, elements.
fn parse_elements_2412(b: &Block<'_>, ctx: &Ctx<'_>, out: &mut UffFile) -> Result<(), UffError> {
    let lines: Vec<(usize, &[u8])> = b
        .lines
        .iter()
        .copied()
        .filter(|(_, raw)| !raw.trim_ascii().is_empty())
        .collect();
    let mut i = 0;
    while i < lines.len() {
        let (no, raw) = lines[i];
        i += 1;
        let at1 = At {
            file: ctx.file,
            line: no,
            dataset: 2412,
            record: "record 1",
        };
        let f = fields(raw, &[10; 6]);
        let id = at1.label(&f[0], "field 1 (element label)")?;
        let descriptor = at1.small(&f[1], "field 2 (FE descriptor id)")?;
        let physical_property = at1.small(&f[2], "field 3 (physical property table)")?;
        let material_property = at1.small(&f[3], "field 4 (material property table)")?;
        let color = at1.small(&f[4], "field 5 (colour)")?;
        let count = at1.small(&f[5], "field 6 (number of nodes)")?;
        if count == 0 {
            return Err(at1.err("field 6 (number of nodes)", 0, "at least 1 node"));
        }
        let count = count as usize;
        let rest_of = |what: &str| {
            At {
                line: b.end,
                record: "record 2",
                ..at1
            }
            .err(
                what.to_string(),
                "the closing `    -1`",
                format!("the rest of element {id}"),
            )
        };
        let beam = if BEAM_DESCRIPTORS.contains(&descriptor) {
            let (no2, raw2) = take(&lines, &mut i).ok_or_else(|| rest_of("beam record"))?;
            let at2 = At {
                line: no2,
                record: "record 2 (beam)",
                ..at1
            };
            let g = fields(raw2, &[10, 10, 10]);
            Some(UffBeam {
                orientation_node: at2.label(&g[0], "field 1 (beam orientation node)")?,
                fore_section: at2.small(&g[1], "field 2 (fore-end cross section)")?,
                aft_section: at2.small(&g[2], "field 3 (aft-end cross section)")?,
            })
        } else {
            None
        };
        let mut nodes = Vec::new();
        while nodes.len() < count {
            let (nl, nraw) = take(&lines, &mut i).ok_or_else(|| rest_of("node labels"))?;
            let at3 = At {
                line: nl,
                record: if beam.is_some() {
                    "record 3"
                } else {
                    "record 2"
                },
                ..at1
            };
            let want = (count - nodes.len()).min(8);
            let t = text(nraw);
            let toks: Vec<&str> = t.split_whitespace().collect();
            let parsed = |v: &[String]| -> Option<Vec<u64>> {
                v.iter().map(|s| s.parse::<u64>().ok()).collect()
            };
            let as_tokens: Vec<String> = toks.iter().map(|s| s.to_string()).collect();
            let got = if toks.len() == want {
                parsed(&as_tokens)
            } else {
                None
            }
            .or_else(|| parsed(&fields(nraw, &vec![10; want])).filter(|v| v.len() == want))
            .or_else(|| {
                parsed(&as_tokens).filter(|v| !v.is_empty() && v.len() <= count - nodes.len())
            });
            match got {
                Some(v) => nodes.extend(v),
                None => {
                    return Err(at3.err(
                        "node labels",
                        t.trim(),
                        format!(
                            "{want} node labels (8I10 per line) of element {id}, which has {count} nodes"
                        ),
                    ));
                }
            }
        }
        out.elements.push(UffElement {
            id,
            descriptor,
            physical_property,
            material_property,
            color,
            nodes,
            beam,
            line: no,
        });
    }
    Ok(())
}

fn take<'a>(lines: &[(usize, &'a [u8])], i: &mut usize) -> Option<(usize, &'a [u8])> {
    let l = lines.get(*i).copied()?;
    *i += 1;
    Some(l)
}

/// Dataset 164, units: Format(I10,20A1,I10), then Format(3D25.17), then the temperature offset.
fn parse_units_164(b: &Block<'_>, file: &str) -> Result<UffUnits, UffError> {
    let at = |k: usize, line: usize| At {
        file,
        line,
        dataset: 164,
        record: RECORDS[k],
    };
    let record = |k: usize| {
        b.lines.get(k - 1).copied().ok_or_else(|| {
            at(k, b.end).err(
                "the whole record",
                "the closing `    -1`",
                "record 1 (units code, description, temperature mode) and record 2 (length, force, temperature factors)",
            )
        })
    };
    let (l1, r1) = record(1)?;
    let code_text = col(r1, 0, 10);
    let code_text = if code_text.trim().parse::<u32>().is_ok() {
        code_text
    } else {
        text(r1).split_whitespace().next().unwrap_or("").to_string()
    };
    let code = at(1, l1).small(&code_text, "field 1 (units code)")?;
    let description = col(r1, 10, 30).trim().to_string();
    let (l2, r2) = record(2)?;
    let f = fields(r2, &[25, 25, 25]);
    let at2 = at(2, l2);
    let positive = |s: &str, field: &str| -> Result<f64, UffError> {
        let v = at2.real(s, field)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(at2.err(field, s, "a factor > 0 (file units per SI unit)"))
        }
    };
    Ok(UffUnits {
        code,
        description,
        length_factor: positive(&f[0], "field 1 (length factor)")?,
        force_factor: positive(&f[1], "field 2 (force factor)")?,
        line: b.header_line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::frequency_lines;
    use crate::model::export::uff::{
        UffEncoding, even_spacing, records_from_set, write_uff58, write_uff58_records,
        write_uff2411,
    };
    use proptest::prelude::*;

    /// A dataset 58 in the published layout: FRF (type 4), response 3:+Z, reference 1:+Z,
    /// complex double, even abscissa from 10 Hz by 0.5 Hz, acceleration over force in m/s²/N.
    const HAND_58: &str = concat!(
        "    -1\n",
        "    58\n",
        "H 3:uz / 1:uz accelerance\n",
        "NONE\n",
        "18-Apr-16 13:49:58\n",
        "NONE\n",
        "NONE\n",
        "    4         1    0         0 NONE               3   3 NONE               1   3\n",
        "         6         3         1  1.00000E+01  5.00000E-01  0.00000E+00\n",
        "        18    0    0    0 Frequency            Hz                  \n",
        "        12    1    0    0 Acceleration         m/s^2               \n",
        "        13    0    1    0 Force                N                   \n",
        "         0    0    0    0 NONE                 NONE                \n",
        "   1.00000000000E+00  -2.00000000000E+00   3.50000000000E-01   4.00000000000E+00\n",
        "  -5.00000000000E-01   6.25000000000E-02\n",
        "    -1\n",
    );
    const HAND_VALUES: [(f64, f64); 3] = [(1.0, -2.0), (0.35, 4.0), (-0.5, 0.0625)];
    const R6: &str =
        "    4         1    0         0 NONE               3   3 NONE               1   3";
    const R9: &str = "        12    1    0    0 Acceleration         m/s^2               ";

    fn parse(s: &str) -> Result<UffFile, UffError> {
        parse_uff(s.as_bytes(), "test.uff")
    }

    fn field_error(e: &UffError) -> (usize, u32, &'static str, String) {
        match e {
            UffError::Field {
                line,
                dataset,
                record,
                field,
                ..
            } => (*line, *dataset, *record, field.clone()),
            other => panic!("expected a field error, got {other}"),
        }
    }

    #[test]
    fn fortran_reals_and_touching_fields_are_read() {
        assert_eq!(parse_real(" 1.5E+02 "), Some(150.0));
        assert_eq!(parse_real("1.5D+02"), Some(150.0));
        assert_eq!(parse_real("0.15+003"), Some(150.0));
        assert_eq!(parse_real("-0.15-002"), Some(-0.0015));
        assert_eq!(parse_real("1."), Some(1.0));
        assert!(parse_real("NaN").is_some_and(f64::is_nan));
        assert_eq!(parse_real("-Inf"), Some(f64::NEG_INFINITY));
        assert_eq!(parse_real("1.0x"), None);
        assert_eq!(parse_real("é-1"), None);
        assert_eq!(
            split_numbers("1.0E+00-2.0E+00+3.5E-01"),
            vec!["1.0E+00", "-2.0E+00", "+3.5E-01"]
        );
        assert_eq!(
            split_numbers("0.123+100-0.5E+00"),
            vec!["0.123+100", "-0.5E+00"]
        );
        assert_eq!(split_numbers("-1.5"), vec!["-1.5"]);
    }

    #[test]
    fn hand_written_dataset_58_reads_to_known_values() {
        let f = parse(HAND_58).unwrap();
        assert_eq!(f.frfs.len(), 1);
        let r = &f.frfs[0];
        assert_eq!(r.line, 2);
        assert_eq!(r.id_lines[0], "H 3:uz / 1:uz accelerance");
        assert_eq!(r.id_lines[2], "18-Apr-16 13:49:58");
        assert_eq!(r.response, "3:uz".parse().unwrap());
        assert_eq!(r.reference, "1:uz".parse().unwrap());
        assert_eq!((r.response_direction, r.reference_direction), (3, 3));
        assert!(!r.sign_flipped);
        assert_eq!(r.function_id, 1);
        assert_eq!(r.ordinate, OrdinateType::ComplexDouble);
        assert_eq!(r.quantity, Quantity::Accelerance);
        assert_eq!(
            r.abscissa,
            Abscissa::Even {
                start_hz: 10.0,
                step_hz: 0.5
            }
        );
        assert_eq!(r.freqs_hz, vec![10.0, 10.5, 11.0]);
        let want: Vec<c64> = HAND_VALUES.iter().map(|&(a, b)| c64::new(a, b)).collect();
        assert_eq!(r.values, want);
        assert!(r.conversions.is_empty(), "{:?}", r.conversions);
        assert!(
            f.conversions.is_empty() && f.warnings.is_empty(),
            "{:?}",
            f.warnings
        );
        let set = to_frf_set(&f.frfs).unwrap();
        assert_eq!(set.values[(1, 0)], c64::new(0.35, 4.0));
    }

    #[test]
    fn crlf_line_ends_and_free_format_fields_read_alike() {
        let crlf = HAND_58.replace('\n', "\r\n");
        assert_eq!(parse(&crlf).unwrap().frfs, parse(HAND_58).unwrap().frfs);
        // Record 7 and the data written free-format, the data with touching fields.
        let free = HAND_58
            .replace(
                "         6         3         1  1.00000E+01  5.00000E-01  0.00000E+00",
                "6 3 1 10.0 0.5 0.0",
            )
            .replace(
                "   1.00000000000E+00  -2.00000000000E+00   3.50000000000E-01   4.00000000000E+00",
                "1.0E+00-2.0E+00 0.35 4.0D0",
            );
        assert_eq!(
            parse(&free).unwrap().frfs[0].values,
            parse(HAND_58).unwrap().frfs[0].values
        );
    }

    #[test]
    fn a_negative_direction_flips_the_sign_and_says_so() {
        let neg = HAND_58.replace(
            R6,
            "    4         1    0         0 NONE               3  -3 NONE               1   3",
        );
        let f = parse(&neg).unwrap();
        let r = &f.frfs[0];
        assert_eq!(r.response, "3:uz".parse().unwrap());
        assert_eq!(r.response_direction, -3);
        assert!(r.sign_flipped);
        for (v, (a, b)) in r.values.iter().zip(HAND_VALUES) {
            assert_eq!(*v, c64::new(-a, -b));
        }
        assert!(
            f.conversions
                .iter()
                .any(|c| c.contains("negated") && c.contains("test.uff:2")),
            "{:?}",
            f.conversions
        );
        // Both negative: the sense of both is reversed, the FRF is unchanged.
        let both = HAND_58.replace(
            R6,
            "    4         1    0         0 NONE               3  -3 NONE               1  -3",
        );
        let r = &parse(&both).unwrap().frfs[0];
        assert!(!r.sign_flipped);
        assert_eq!(r.values[0], c64::new(1.0, -2.0));
    }

    #[test]
    fn unit_labels_convert_to_si_and_are_recorded() {
        // mm/N displacement → m/N receptance.
        let mm = HAND_58.replace(
            R9,
            "         8    1    0    0 Displacement         mm                  ",
        );
        let f = parse(&mm).unwrap();
        let r = &f.frfs[0];
        assert_eq!(r.quantity, Quantity::Receptance);
        assert!((r.values[0] - c64::new(1e-3, -2e-3)).norm() < 1e-18);
        assert!(
            r.conversions
                .iter()
                .any(|c| c.contains("m/N") && c.contains("`mm`") && c.contains("1e-3")),
            "{:?}",
            r.conversions
        );
        assert_eq!(f.conversions, r.conversions);
        // g/lbf in one label, with a rad/s abscissa.
        let g = HAND_58
            .replace(
                R9,
                "        12    1    0    0 Acceleration         g/lbf               ",
            )
            .replace(
                "        13    0    1    0 Force                N                   ",
                "        13    0    1    0 Force                NONE                ",
            )
            .replace(
                "        18    0    0    0 Frequency            Hz                  ",
                "        18    0    0    0 Frequency            rad/s               ",
            );
        let r = &parse(&g).unwrap().frfs[0];
        let k = STANDARD_GRAVITY / POUND_FORCE;
        assert!((r.values[0].re - k).abs() < 1e-15 && (r.values[0].im + 2.0 * k).abs() < 1e-15);
        assert!((r.freqs_hz[0] - 10.0 / (2.0 * PI)).abs() < 1e-14);
        assert_eq!(r.conversions.len(), 2, "{:?}", r.conversions);
        // Velocity in mm/s with the type unknown (0): the label decides.
        let v = HAND_58.replace(
            R9,
            "         0    0    0    0 NONE                 mm/s                ",
        );
        let r = &parse(&v).unwrap().frfs[0];
        assert_eq!(r.quantity, Quantity::Mobility);
        assert!((r.values[2].re + 0.5e-3).abs() < 1e-18);
    }

    #[test]
    fn dataset_164_converts_unlabelled_data_and_nodes() {
        let units = concat!(
            "    -1\n",
            "   164\n",
            "         5mm (milli newton)               2\n",
            "  1.00000000000000000D+03  1.00000000000000000D+03  1.00000000000000000D+00\n",
            "  2.73150000000000000D+02\n",
            "    -1\n",
            "    -1\n",
            "    15\n",
            "         7         0         0         8  1.00000E+00  2.00000E+00 -3.50000E+00\n",
            "    -1\n",
        );
        let unlabelled = HAND_58
            .replace(
                R9,
                "        12    1    0    0 NONE                 NONE                ",
            )
            .replace(
                "        13    0    1    0 Force                N                   ",
                "        13    0    1    0 NONE                 NONE                ",
            );
        let f = parse(&format!("{units}{unlabelled}")).unwrap();
        assert_eq!(f.units.as_ref().map(|u| u.code), Some(5));
        assert_eq!(f.nodes, vec![(7, [1e-3, 2e-3, -3.5e-3])]);
        assert_eq!(f.node_systems, vec![[0, 0, 8]]);
        // mm/s² per mN = 1e-3 m/s² per 1e-3 N: a factor of one, nothing to convert.
        let r = &f.frfs[0];
        assert_eq!(r.values[0], c64::new(1.0, -2.0));
        assert!(r.conversions.is_empty(), "{:?}", r.conversions);
        assert!(
            f.conversions.iter().any(|c| c.contains("coordinates")),
            "{:?}",
            f.conversions
        );
        // Without labels and without 164: SI, with one warning for all such records.
        let other = unlabelled.replace(
            R6,
            "    4         1    0         0 NONE               2   3 NONE               1   3",
        );
        let f = parse(&format!("{unlabelled}{other}")).unwrap();
        assert_eq!(f.frfs[1].values[0], c64::new(1.0, -2.0));
        assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
        assert!(f.warnings[0].contains("taken as SI"), "{:?}", f.warnings);
    }

    #[test]
    fn dataset_2411_15_and_2412_are_read() {
        let text = concat!(
            "    -1\n",
            "  2411\n",
            "       101         1         1        11\n",
            "   1.5000000000000000E+00  -2.5000000000000000E-01   1.0000000000000000E-03\n",
            "       102         1         1        11\n",
            "   0.1234567890123456D+01   0.0000000000000000D+00  -7.0000000000000000D+02\n",
            "    -1\n",
            "    -1\n",
            "    15\n",
            "         7         0         0         8  1.00000E+00  2.00000E+00 -3.50000E+00\n",
            "    -1\n",
            "    -1\n",
            "  2412\n",
            "         1        94         1         1         7         4\n",
            "       101       102         7       101\n",
            "         2        21         2         1         7         2\n",
            "         0         1         1\n",
            "       101       102\n",
            "         3       116         1         1         7         9\n",
            "         1         2         3         4         5         6         7         8\n",
            "         9\n",
            "    -1\n",
            "    -1\n",
            "   151\n",
            "a header we do not read\n",
            "    -1\n",
        );
        let f = parse(text).unwrap();
        assert_eq!(
            f.nodes,
            vec![
                (101, [1.5, -0.25, 1e-3]),
                (102, [1.234567890123456, 0.0, -700.0]),
                (7, [1.0, 2.0, -3.5])
            ]
        );
        assert_eq!(f.node_systems[0], [1, 1, 11]);
        assert_eq!(f.elements.len(), 3);
        assert_eq!(f.elements[0].nodes, vec![101, 102, 7, 101]);
        assert_eq!(f.elements[0].beam, None);
        assert_eq!(f.elements[1].descriptor, 21);
        assert_eq!(
            f.elements[1].beam,
            Some(UffBeam {
                orientation_node: 0,
                fore_section: 1,
                aft_section: 1
            })
        );
        assert_eq!(f.elements[1].nodes, vec![101, 102]);
        assert_eq!(f.elements[2].nodes, (1..=9).collect::<Vec<u64>>());
        assert_eq!(f.elements[2].line, 19);
        assert_eq!(f.skipped, vec![(151, 1)]);
        // Written nodes read back exactly.
        let nodes = vec![(5, [0.1, -1.0 / 3.0, 2e-300]), (6, [1e5, PI, -0.0])];
        let back = parse_uff(&write_uff2411(&nodes), "n.uff").unwrap();
        assert_eq!(back.nodes, nodes);
        // A node defined twice is an error naming both lines.
        let twice = format!(
            "{}{}",
            &text[..text.find("    -1\n  2412").unwrap()],
            "    -1\n    15\n       101         0         0         8  1.00000E+00  2.00000E+00 -3.50000E+00\n    -1\n"
        );
        let e = parse(&twice).unwrap_err();
        assert!(
            matches!(
                e,
                UffError::DuplicateNode {
                    node: 101,
                    first: 3,
                    second: 14,
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn node_labels_wider_than_their_field_are_not_misread() {
        let wide = HAND_58.replace(
            R6,
            "    4         1    0         0 NONE      12345678901   3 NONE               1   3",
        );
        assert_eq!(
            parse(&wide).unwrap().frfs[0].response,
            DofId::new(12_345_678_901, Component::Uz)
        );
        let set = FrfSet {
            quantity: Quantity::Receptance,
            freqs_hz: vec![1.0, 2.0],
            pairs: vec![FrfPair {
                response: DofId::new(98_765_432_101, Component::Rx),
                excitation: DofId::new(12_345_678_901, Component::Uy),
            }],
            values: Mat::from_fn(2, 1, |i, _| c64::new(i as f64, 1.0)),
        };
        let back =
            to_frf_set(&parse_uff(&write_uff58(&set, false), "w.uff").unwrap().frfs).unwrap();
        assert_eq!(back.pairs, set.pairs);
        // The pyuff sample layout: an entity name with a blank.
        let named = HAND_58.replace(
            R6,
            "    4         0    0         0 Mic 01             3   3 NONE               1   3",
        );
        assert_eq!(
            parse(&named).unwrap().frfs[0].response,
            DofId::new(3, Component::Uz)
        );
    }

    #[test]
    fn other_function_types_are_skipped_with_a_warning() {
        let coh = HAND_58.replace(
            R6,
            "    6         1    0         0 NONE               3   3 NONE               1   3",
        );
        let f = parse(&format!("{coh}{HAND_58}")).unwrap();
        assert_eq!(f.frfs.len(), 1);
        assert_eq!(f.frfs[0].line, 18);
        assert_eq!(f.skipped, vec![(58, 1)]);
        assert!(
            f.warnings.iter().any(|w| w.contains("type 6 (coherence)")),
            "{:?}",
            f.warnings
        );
    }

    #[test]
    fn bad_fields_are_named_with_line_record_and_valid_values() {
        let bad = HAND_58.replace(
            "         6         3         1  1.00000E+01",
            "         3         3         1  1.00000E+01",
        );
        let e = parse(&bad).unwrap_err();
        assert_eq!(
            field_error(&e),
            (9, 58, "record 7", "field 1 (ordinate data type)".into())
        );
        let msg = e.to_string();
        assert!(
            msg.starts_with("test.uff:9:") && msg.contains("6 (complex double)"),
            "{msg}"
        );

        let scalar = HAND_58.replace(
            R6,
            "    4         1    0         0 NONE               3   0 NONE               1   3",
        );
        let e = parse(&scalar).unwrap_err();
        assert_eq!(field_error(&e).2, "record 6");
        assert!(e.to_string().contains("0 (scalar) has no DOF"), "{e}");

        let stress = HAND_58.replace(
            R9,
            "         2    0    0    0 Stress               NONE                ",
        );
        let e = parse(&stress).unwrap_err();
        assert_eq!(
            field_error(&e),
            (11, 58, "record 9", "field 1 (specific data type)".into())
        );

        let clash = HAND_58.replace(
            R9,
            "        12    1    0    0 Acceleration         mm/s                ",
        );
        assert!(
            parse(&clash)
                .unwrap_err()
                .to_string()
                .contains("velocity unit")
        );

        let unknown = HAND_58.replace(
            R9,
            "        12    1    0    0 Acceleration         furlong             ",
        );
        assert_eq!(
            field_error(&parse(&unknown).unwrap_err()).3,
            "field 6 (units label)"
        );

        let time = HAND_58.replace(
            "        18    0    0    0 Frequency            Hz",
            "        17    0    0    0 Time                 s ",
        );
        assert!(
            parse(&time)
                .unwrap_err()
                .to_string()
                .contains("frequency abscissa")
        );

        let garbage = HAND_58.replace("  -5.00000000000E-01", "  -5.0000000zz00E-01");
        let e = parse(&garbage).unwrap_err();
        assert_eq!(
            field_error(&e),
            (15, 58, "record 12", "data value 5".into())
        );

        let extra = HAND_58.replace("   6.25000000000E-02\n", "   6.25000000000E-02   1.0\n");
        assert!(
            parse(&extra)
                .unwrap_err()
                .to_string()
                .contains("more than 6 values")
        );

        let e = parse("    -1\n    58\nNONE\n    -1\n").unwrap_err();
        assert_eq!(field_error(&e).0, 4);

        let e = parse("hello\n").unwrap_err();
        assert!(matches!(e, UffError::Delimiter { line: 1, .. }), "{e}");
        let e = parse("    -1\n  58x\n    -1\n").unwrap_err();
        assert!(matches!(e, UffError::DatasetNumber { line: 2, .. }), "{e}");
    }

    #[test]
    fn truncated_files_name_the_last_line_and_the_dataset() {
        // Cut inside the data: lines 1-14 remain.
        let cut = &HAND_58[..HAND_58.find("  -5.0000").unwrap()];
        let e = parse(cut).unwrap_err();
        match &e {
            UffError::Truncated {
                line,
                dataset,
                start,
                ..
            } => assert_eq!((*line, *dataset, *start), (14, Some(58), 1)),
            other => panic!("{other}"),
        }
        assert!(
            e.to_string()
                .starts_with("test.uff:14: the file ends inside dataset 58"),
            "{e}"
        );
        assert!(matches!(
            parse("\n\n    -1\n").unwrap_err(),
            UffError::Truncated {
                line: 3,
                dataset: None,
                start: 3,
                ..
            }
        ));

        // Binary data cut short.
        let set = sample_set(Quantity::Mobility, &frequency_lines(1.0, 3.0, 0.5));
        let bin = write_uff58(&set, true);
        let cut = &bin[..bin.len() - 20];
        let e = parse_uff(cut, "b.uff").unwrap_err();
        assert!(
            matches!(
                e,
                UffError::Truncated {
                    dataset: Some(58),
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("bytes of binary data"), "{e}");
    }

    #[test]
    fn mixed_lines_quantities_and_pairs_are_refused_naming_both_records() {
        const R6_NODE_2: &str =
            "    4         1    0         0 NONE               2   3 NONE               1   3";
        let other_pair = HAND_58.replace(R6, R6_NODE_2);
        // Increment 0.51 Hz instead of 0.5 Hz.
        let shifted =
            other_pair.replace("  1.00000E+01  5.00000E-01", "  1.00000E+01  5.10000E-01");
        let f = parse(&format!("{HAND_58}{shifted}")).unwrap();
        let e = to_frf_set(&f.frfs).unwrap_err();
        match &e {
            UffError::Inconsistent {
                first_line,
                second_line,
                reason,
                ..
            } => {
                assert_eq!((*first_line, *second_line), (2, 18));
                assert!(
                    reason.contains("line 1 is 10.5 Hz in the first and 10.51 Hz"),
                    "{reason}"
                );
            }
            other => panic!("{other}"),
        }
        assert!(e.to_string().contains("test.uff:2 and test.uff:18"), "{e}");

        let velocity = other_pair.replace(
            R9,
            "        11    1    0    0 Velocity             m/s                 ",
        );
        let f = parse(&format!("{HAND_58}{velocity}")).unwrap();
        let e = to_frf_set(&f.frfs).unwrap_err();
        assert!(
            e.to_string().contains("accelerance, the second mobility"),
            "{e}"
        );

        let f = parse(&format!("{HAND_58}{HAND_58}")).unwrap();
        let e = to_frf_set(&f.frfs).unwrap_err();
        assert!(e.to_string().contains("both hold H(3:uz, 1:uz)"), "{e}");
        assert!(matches!(to_frf_set(&[]), Err(UffError::NoFrfs)));

        // Lines within 1e-9 relative are the same lines; the first record's are kept.
        let a = f.frfs[0].clone();
        let mut b = a.clone();
        b.response = "4:uz".parse().unwrap();
        b.freqs_hz[2] *= 1.0 + 1e-12;
        let set = to_frf_set(&[a, b]).unwrap();
        assert_eq!(set.freqs_hz, vec![10.0, 10.5, 11.0]);
    }

    /// Values with mixed signs and magnitudes, none a short decimal.
    fn sample_set(quantity: Quantity, freqs: &[f64]) -> FrfSet {
        let pairs = FrfSet::all_pairs(
            &[
                "1:ux".parse().unwrap(),
                "2:rz".parse().unwrap(),
                "30000:uy".parse().unwrap(),
            ],
            &["1:ux".parse().unwrap(), "5:rx".parse().unwrap()],
        );
        let values = Mat::from_fn(freqs.len(), pairs.len(), |i, j| {
            let t = (i * 7 + j * 3) as f64 + 0.123_456_789;
            c64::new(
                t.sin() * 10f64.powi(j as i32 - 4) / 3.0,
                -t.cos() * 10f64.powi(2 - j as i32) / 7.0,
            )
        });
        FrfSet {
            quantity,
            freqs_hz: freqs.to_vec(),
            pairs,
            values,
        }
    }

    /// `a` equals `b` exactly (`rel` = 0), as single-precision numbers (`rel` < 0), or within
    /// `rel` relative.
    fn same(a: f64, b: f64, rel: f64) -> bool {
        if rel == 0.0 {
            a.to_bits() == b.to_bits()
        } else if rel < 0.0 {
            (a as f32).to_bits() == (b as f32).to_bits()
        } else {
            (a - b).abs() <= rel * b.abs()
        }
    }

    #[test]
    fn round_trips_in_every_encoding_type_spacing_and_quantity() {
        let even = frequency_lines(2.0, 6.5, 0.5);
        let uneven = [
            1.0,
            1.3,
            std::f64::consts::E,
            PI,
            10.0 / 3.0,
            100.123_456_789,
            2000.5,
        ];
        let encodings = [
            UffEncoding::Ascii,
            UffEncoding::AsciiExact,
            UffEncoding::Binary(ByteOrder::Little),
            UffEncoding::Binary(ByteOrder::Big),
        ];
        let types = [
            OrdinateType::RealSingle,
            OrdinateType::RealDouble,
            OrdinateType::ComplexSingle,
            OrdinateType::ComplexDouble,
        ];
        let mut cases = 0;
        for quantity in [
            Quantity::Receptance,
            Quantity::Mobility,
            Quantity::Accelerance,
        ] {
            for freqs in [&even[..], &uneven[..]] {
                let set = sample_set(quantity, freqs);
                for force_uneven in [false, true] {
                    for ord in types {
                        for enc in encodings {
                            let mut recs = records_from_set(&set);
                            for r in &mut recs {
                                r.ordinate = ord;
                                if force_uneven {
                                    r.abscissa = Abscissa::Uneven;
                                }
                            }
                            let bytes = write_uff58_records(&recs, enc);
                            let back = parse_uff(&bytes, "rt.uff")
                                .unwrap_or_else(|e| panic!("{enc:?} {ord}: {e}"))
                                .frfs;
                            assert_eq!(back.len(), recs.len());
                            let ascii = enc == UffEncoding::Ascii;
                            let double = ord.is_double();
                            let is_even = !force_uneven && std::ptr::eq(freqs, &even[..]);
                            let exact_text = enc == UffEncoding::AsciiExact;
                            // ASCII single data are read as the nearest double of their text.
                            let value_tol = match (ascii, double) {
                                (true, true) => 1e-12,
                                (true, false) => 1e-5,
                                (false, false) if exact_text => -1.0,
                                (false, _) => 0.0,
                            };
                            let freq_tol = match (is_even, ascii, double) {
                                (true, _, _) => 0.0,
                                (false, true, _) => 1e-6,
                                (false, false, false) if exact_text => -1.0,
                                (false, false, _) => 0.0,
                            };
                            let cast = |v: f64| if double { v } else { f64::from(v as f32) };
                            for (r, w) in back.iter().zip(&recs) {
                                assert_eq!((r.response, r.reference), (w.response, w.reference));
                                assert_eq!((r.quantity, r.ordinate), (quantity, ord));
                                assert_eq!(
                                    r.binary.is_some(),
                                    matches!(enc, UffEncoding::Binary(_))
                                );
                                assert_eq!(matches!(r.abscissa, Abscissa::Even { .. }), is_even);
                                assert!(r.conversions.is_empty(), "{:?}", r.conversions);
                                for (a, b) in r.freqs_hz.iter().zip(&w.freqs_hz) {
                                    let b = if is_even { *b } else { cast(*b) };
                                    assert!(same(*a, b, freq_tol), "{enc:?} {ord}: {a} vs {b}");
                                }
                                for (a, b) in r.values.iter().zip(&w.values) {
                                    let im = if ord.is_complex() { cast(b.im) } else { 0.0 };
                                    assert!(
                                        same(a.re, cast(b.re), value_tol)
                                            && same(a.im, im, value_tol),
                                        "{enc:?} {ord} {quantity:?}: {a} vs {b}"
                                    );
                                }
                            }
                            if ord == OrdinateType::ComplexDouble && !ascii {
                                let got = to_frf_set(&back).unwrap();
                                assert_eq!(got.pairs, set.pairs);
                                assert_eq!(got.freqs_hz, set.freqs_hz);
                                assert!(got.values == set.values);
                            }
                            cases += 1;
                        }
                    }
                }
            }
        }
        assert_eq!(cases, 3 * 2 * 2 * 4 * 4);
    }

    #[test]
    fn uneven_double_58b_with_single_precision_abscissa_and_miscounted_header_is_read() {
        let set = sample_set(Quantity::Receptance, &[1.0, 2.5, 4.0]);
        let mut recs = records_from_set(&set);
        recs.truncate(1);
        recs[0].abscissa = Abscissa::Uneven;
        let bytes = write_uff58_records(&recs, UffEncoding::Binary(ByteOrder::Little));
        // The 13 ASCII lines (delimiter, header, records 1-11), then 3 × 24 bytes of data.
        let text_end = bytes
            .iter()
            .enumerate()
            .filter(|(_, b)| **b == b'\n')
            .nth(12)
            .map(|(k, _)| k + 1)
            .unwrap();
        let head = String::from_utf8(bytes[..text_end].to_vec()).unwrap();
        assert!(head.contains("          11          72"), "{head}");
        // Re-encode the abscissa as f32 (20 bytes per point), and declare a wrong byte count
        // as some writers do.
        let mut file = head
            .replacen("          11          72", "          11          24", 1)
            .into_bytes();
        for p in bytes[text_end..bytes.len() - 7].chunks(24) {
            let x = f64::from_le_bytes(p[..8].try_into().unwrap());
            file.extend_from_slice(&(x as f32).to_le_bytes());
            file.extend_from_slice(&p[8..]);
        }
        file.extend_from_slice(b"    -1\n");
        let f = parse_uff(&file, "w.uff").unwrap();
        assert_eq!(f.frfs[0].freqs_hz, vec![1.0, 2.5, 4.0]);
        assert_eq!(f.frfs[0].values, recs[0].values);
        assert!(
            f.warnings
                .iter()
                .any(|w| w.contains("declares 24 bytes") && w.contains("60 bytes read")),
            "{:?}",
            f.warnings
        );
    }

    #[test]
    fn standard_ascii_keeps_the_fixed_columns_of_the_layout() {
        let set = sample_set(Quantity::Accelerance, &frequency_lines(0.0, 40.0, 0.05));
        assert_eq!(even_spacing(&set.freqs_hz), Some((0.0, 0.05)));
        assert_eq!(
            even_spacing(&frequency_lines(1.0, 10.0, 0.05)),
            Some((1.0, 0.05))
        );
        assert_eq!(even_spacing(&[1.0, 2.0, 3.5]), None);
        let text = String::from_utf8(write_uff58(&set, false)).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[7].len(), 80, "record 6: {}", lines[7]);
        assert_eq!(lines[8].len(), 69, "record 7: {}", lines[8]);
        // Record 7 holds 7 significant digits per 13-column field (E13.5 holds 6).
        assert!(
            lines[8].ends_with(" 0.000000E+00 5.000000E-02 0.000000E+00"),
            "{}",
            lines[8]
        );
        // A fixed-column reader (20 columns per value) gets every value.
        let first = lines[13];
        assert_eq!(first.len(), 80);
        for k in 0..4 {
            let v: f64 = first[20 * k..20 * (k + 1)].trim().parse().unwrap();
            let want = set.values[(k / 2, 0)];
            let want = if k % 2 == 0 { want.re } else { want.im };
            assert!((v - want).abs() <= 1e-12 * want.abs(), "{v} vs {want}");
        }
    }

    fn fixture_set() -> FrfSet {
        // Two-mode modal receptance of a four-DOF chain driven at 1:ux:
        // H_i1 = Σ_r φ_ir φ_1r / (ω_r² − ω² + 2iζω_rω).
        let phi = [[0.30, 0.55], [0.50, 0.35], [0.55, -0.30], [0.60, -0.60]];
        let omega_r = [2.0 * PI * 12.0, 2.0 * PI * 31.0];
        let zeta = 0.02;
        let freqs = frequency_lines(5.0, 50.0, 5.0);
        let pairs: Vec<FrfPair> = (1..=4)
            .map(|i| FrfPair {
                response: DofId::new(i, Component::Ux),
                excitation: DofId::new(1, Component::Ux),
            })
            .collect();
        let values = Mat::from_fn(freqs.len(), 4, |k, i| {
            let w = 2.0 * PI * freqs[k];
            (0..2)
                .map(|r| {
                    let d = c64::new(omega_r[r] * omega_r[r] - w * w, 2.0 * zeta * omega_r[r] * w);
                    c64::new(phi[i][r] * phi[0][r], 0.0) / d
                })
                .fold(c64::new(0.0, 0.0), |a, b| a + b)
        });
        FrfSet {
            quantity: Quantity::Receptance,
            freqs_hz: freqs,
            pairs,
            values,
        }
    }

    #[test]
    fn the_four_dof_fixture_reads_back_as_the_synthetic_set() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/uff/four_dof_receptance.uff"
        );
        let set = fixture_set();
        let written = write_uff58(&set, false);
        if std::env::var_os("FEMU_BLESS").is_some() {
            std::fs::create_dir_all(Path::new(path).parent().unwrap()).unwrap();
            std::fs::write(path, &written).unwrap();
        }
        let file = read_uff(path).unwrap();
        assert!(
            file.warnings.is_empty() && file.conversions.is_empty(),
            "{:?}",
            file.warnings
        );
        let got = to_frf_set(&file.frfs).unwrap();
        assert_eq!(got.quantity, Quantity::Receptance);
        assert_eq!(got.pairs, set.pairs);
        assert_eq!(got.freqs_hz, set.freqs_hz);
        assert_eq!((got.values.nrows(), got.values.ncols()), (10, 4));
        for i in 0..10 {
            for j in 0..4 {
                let (a, b) = (got.values[(i, j)], set.values[(i, j)]);
                assert!((a - b).norm() <= 1e-12 * b.norm(), "({i}, {j}): {a} vs {b}");
            }
        }
        assert!(
            std::fs::read(path).unwrap() == written,
            "fixtures/uff/four_dof_receptance.uff is not what the writer makes now; bless on purpose with FEMU_BLESS=1"
        );
    }

    fn damaged_sample(binary: bool) -> Vec<u8> {
        let set = sample_set(Quantity::Mobility, &[1.0, 2.0, 3.5]);
        let mut bytes = write_uff2411(&[(1, [0.0, 1.0, 2.0])]);
        bytes.extend(write_uff58(&set, binary));
        bytes.extend_from_slice(HAND_58.as_bytes());
        bytes
    }

    proptest! {
        #[test]
        fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..3000)) {
            let _ = parse_uff(&bytes, "random.uff");
        }

        #[test]
        fn random_text_after_a_58_header_never_panics(body in "[ -~\n]{0,600}", binary in any::<bool>(), n in 0usize..2000) {
            let head = if binary {
                format!("    -1\n    58b     1     2          11{n:>12}     0     0           0           0\n")
            } else {
                "    -1\n    58\n".to_string()
            };
            let _ = parse_uff(format!("{head}{body}").as_bytes(), "text.uff");
        }

        #[test]
        fn damaged_files_never_panic(
            binary in any::<bool>(),
            cut in 0usize..8000,
            flips in prop::collection::vec((0usize..8000, any::<u8>()), 0..6),
        ) {
            let mut bytes = damaged_sample(binary);
            for (i, b) in flips {
                let k = i % bytes.len();
                bytes[k] = b;
            }
            bytes.truncate(cut);
            let _ = parse_uff(&bytes, "damaged.uff");
        }
    }
}
