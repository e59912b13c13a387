//! What a universal file holds once read: nodes, elements, units and FRF records.

use crate::core::DofId;
use crate::frf::{FrfPair, Quantity};
use faer::c64;
use std::fmt;

/// Everything read from a universal file.
#[derive(Clone, Debug, Default)]
pub struct UffFile {
    /// Nodes of datasets 15 and 2411: label and global coordinates (SI when dataset 164 gives
    /// units; brought from their definition coordinate system to global).
    pub nodes: Vec<(u64, [f64; 3])>,
    /// Per node, in the order of `nodes`: definition coordinate system, displacement coordinate
    /// system and colour.
    pub node_systems: Vec<[u32; 3]>,
    /// Elements of dataset 2412.
    pub elements: Vec<UffElement>,
    /// Coordinate systems of datasets 18 and 2420, axes and origins in global (SI lengths).
    pub coordinate_systems: Vec<UffCoordSystem>,
    /// Trace lines of dataset 82, kept for display.
    pub trace_lines: Vec<UffTraceLine>,
    /// The header of dataset 151.
    pub header: Option<UffHeader>,
    /// FRF records of datasets 58 and 58b, in file order.
    pub frfs: Vec<Uff58>,
    /// Mode shape records of dataset 55, in file order.
    pub shapes: Vec<super::Uff55>,
    /// Dataset 55 records skipped as not mode shapes (each reason warned about).
    pub skipped_shapes: usize,
    /// The last units dataset (164) read.
    pub units: Option<UffUnits>,
    /// Every conversion done (units, abscissa, sign flips), naming the record it applies to.
    pub conversions: Vec<String>,
    /// Assumptions made and records skipped, each stated once.
    pub warnings: Vec<String>,
    /// Datasets not read, `(dataset number, count)`, ascending by number.
    pub skipped: Vec<(u32, usize)>,
}

/// The type of a coordinate system (dataset 18 field 2, dataset 2420 record 3 field 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoordKind {
    /// 0: `(x, y, z)`.
    Cartesian,
    /// 1: `(r, θ, z)`, θ in degrees.
    Cylindrical,
    /// 2: `(r, θ, φ)`, θ from the z axis and φ about it, in degrees.
    Spherical,
}

impl CoordKind {
    /// The name, for messages.
    pub fn name(self) -> &'static str {
        match self {
            CoordKind::Cartesian => "Cartesian",
            CoordKind::Cylindrical => "cylindrical",
            CoordKind::Spherical => "spherical",
        }
    }
}

/// A coordinate system of dataset 18 or 2420, in global.
#[derive(Clone, Debug, PartialEq)]
pub struct UffCoordSystem {
    /// Label.
    pub id: u32,
    /// Type.
    pub kind: CoordKind,
    /// Name as written.
    pub name: String,
    /// The local x, y, z axes as unit vectors in global components (rows).
    pub axes: [[f64; 3]; 3],
    /// Origin in global, m (when dataset 164 gives units).
    pub origin: [f64; 3],
    /// 18 or 2420.
    pub dataset: u32,
    /// 1-based line of the system's first record.
    pub line: usize,
}

/// A trace line of dataset 82: nodes joined for display, 0 lifting the pen.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UffTraceLine {
    /// Trace line number.
    pub id: u64,
    /// Colour.
    pub color: u32,
    /// ID line.
    pub name: String,
    /// Node labels; 0 moves to the next node without drawing.
    pub nodes: Vec<u64>,
    /// 1-based line of record 1.
    pub line: usize,
}

/// The header of dataset 151, as written.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct UffHeader {
    /// Record 1: model file name.
    pub model: String,
    /// Record 2: model file description.
    pub description: String,
    /// Record 3: program that created the database.
    pub database_program: String,
    /// Record 4: date and time the database was created.
    pub database_created: String,
    /// Record 5: date and time the database was last saved.
    pub database_saved: String,
    /// Record 6: program that wrote the universal file.
    pub program: String,
    /// Record 7: date and time the universal file was written.
    pub written: String,
    /// 1-based line of the dataset number.
    pub line: usize,
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
    pub(super) fn is_si(&self) -> bool {
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
