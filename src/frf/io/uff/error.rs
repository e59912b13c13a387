//! Why a universal file, or a group of its FRF records, cannot be used.

use crate::core::DofId;

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
    /// No mode shape record to form modes from.
    #[error(
        "no mode shapes (dataset 55 of analysis type 2, 3 or 7 with motion at nodes) to form modes from{}",
        if *skipped > 0 { format!("; {skipped} other dataset 55 record(s) were skipped (see the warnings)") } else { String::new() }
    )]
    NoShapes {
        /// Dataset 55 records skipped as not mode shapes.
        skipped: usize,
    },
    /// Two mode shape records contradict each other.
    #[error("{file}:{line}: {what} (first at line {first})")]
    ShapeConflict {
        /// The file.
        file: String,
        /// Line of the second record's dataset number.
        line: usize,
        /// What is wrong.
        what: String,
        /// Line of the first record.
        first: usize,
    },
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
