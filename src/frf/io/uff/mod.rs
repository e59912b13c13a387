//! Universal File Format (UFF) reader and writer: nodes, elements and measured FRFs.
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
//!     no change); [`Uff58::sign_flipped`] records it. Exports that leave record 6's directions
//!     0 and name the DOFs only in the ID lines (`Pt12:+Z / Pt1:+Z`, `Pt 12.Z-`) are read from
//!     there, with the reading recorded as a conversion.
//!   - Zeros after the values record 7 declares are padding: dropped, with a warning; any other
//!     extra value is an error.
//!   - Record 7: ordinate data type 2/4 (real single/double) or 5/6 (complex single/double);
//!     even abscissa (minimum, increment) or uneven (`x` stored with every value; in 58b as
//!     `f64` for double data, `f32` accepted too, `f32` for single data).
//!   - Quantity from the ordinate numerator's specific data type (record 9 field 1): 8
//!     displacement → receptance, 11 velocity → mobility, 12 acceleration → accelerance. The
//!     denominator (record 10 field 1) is 13 excitation force or 9 reaction force. With type 0
//!     (unknown) or 1 (general) the unit label decides.
//!   - Units to SI: the unit labels of records 9/10 (e.g. `g`, `mm`, `in/s`, `m/s^2/N`, `lbf`,
//!     `N*m`, and expressions such as `(1/N)*(m/s²)`, `m/(s^2 N)`, `μm/N`, recorded as read),
//!     else dataset 164 with the unit exponents (the addendum A table, or the record's
//!     own exponents for type 1), else SI is assumed and warned about. The abscissa is in Hz
//!     unless record 8 says `rad/s`, `kHz` or `rpm`. Every conversion is listed in
//!     [`Uff58::conversions`] and [`UffFile::conversions`].
//! - **55** data at nodes: mode shapes (analysis type 2 normal, 3/7 complex), 3 or 6 values
//!   per node, real or complex; other analysis types and data characteristics are skipped,
//!   counted and warned about. [`to_test_modes`] makes them one set of real test modes.
//! - Every other dataset is skipped and counted in [`UffFile::skipped`].
//!
//! [`to_frf_set`] groups FRF records into one [`FrfSet`] after checking they share quantity and
//! frequency lines. Errors name the file, the 1-based line, the dataset, record and field, what
//! was found and what is valid; no input makes the reader panic.

//!
//! The writer is [`write`] (datasets 58 / 58b and 2411). Files of the reader, by concern:
//! `lex` (lines, fields, Fortran reals), `block` (datasets between delimiters, the 58b header),
//! `header58` and `dataset58` (records 1–11 and the data of dataset 58), `units` and `label` (unit labels,
//! dataset 164, the ordinate's quantity and SI factor), `mesh` (datasets 15, 2411, 2412),
//! `set` (records to one [`FrfSet`](crate::frf::FrfSet)), `types` and `error`.

mod block;
mod dataset55;
mod dataset58;
mod error;
mod header58;
mod info;
mod label;
mod lex;
mod mesh;
mod notes;
mod set;
mod shapes;
mod systems;
mod types;
mod units;
pub mod write;

pub use dataset55::{ModeKind55, Uff55};
pub use error::{NonFiniteValue, UffError};
pub use notes::grouped_conversions;
pub use set::{LINE_TOLERANCE, to_frf_set};
pub use shapes::{TestModes, realisation, to_test_modes};
pub use types::{
    Abscissa, ByteOrder, CoordKind, OrdinateType, Uff58, UffBeam, UffCoordSystem, UffElement,
    UffFile, UffHeader, UffTraceLine, UffUnits,
};
pub use write::{
    CartesianSystem, UffEncoding, even_spacing, records_from_set, write_uff58, write_uff58_as,
    write_uff58_records, write_uff164_si, write_uff2411, write_uff2411_framed, write_uff2420,
};

use block::{Ctx, next_block};
use dataset58::parse_58;
use header58::function_name;
use lex::Cursor;
use mesh::{parse_elements_2412, parse_nodes_15, parse_nodes_2411};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;
use units::parse_units_164;

/// The quantity and SI factor of an FRF unit label (`m/s^2/N`, `g/N`, `(1/N)*(m/s²)`, `mm/N`):
/// a translational motion over a force; `None` for anything else.
pub fn frf_unit_si(label: &str) -> Option<(crate::frf::Quantity, f64)> {
    let (m, f) = units::frf_label(label).ok()??;
    let f = f?;
    (!m.rotational && !f.moment).then(|| (m.kind.quantity(), m.factor / f.factor))
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
        node_scale: Vec::new(),
        warned: HashSet::new(),
        skipped_functions: BTreeMap::new(),
        datasets: 0,
        frf_records: 0,
        converted_shapes: BTreeMap::new(),
    };
    let mut out = UffFile::default();
    let mut skipped: BTreeMap<u32, usize> = BTreeMap::new();
    let mut pending18 = Vec::new();
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
            (55, false) => dataset55::parse_55(&block, &mut ctx, &mut out)?,
            (15, false) => parse_nodes_15(&block, &mut ctx, &mut out)?,
            (2411, false) => parse_nodes_2411(&block, &mut ctx, &mut out)?,
            (2412, false) => parse_elements_2412(&block, &ctx, &mut out)?,
            (164, false) => ctx.units = Some(parse_units_164(&block, ctx.file)?),
            (18, false) => systems::parse_18(&block, &mut ctx, &mut pending18)?,
            (2420, false) => systems::parse_2420(&block, &mut ctx, &mut out)?,
            (151, false) => info::parse_151(&block, &mut ctx, &mut out),
            (82, false) => info::parse_82(&block, &ctx, &mut out)?,
            (n, _) => *skipped.entry(n).or_default() += 1,
        }
    }
    for (ty, (count, line)) in &ctx.skipped_functions {
        ctx.warnings.push(format!(
            "{file_name}: {count} dataset 58 record(s) of function type {ty} ({}) skipped, the first at line {line}; only type 4 (frequency response function) is read",
            function_name(*ty)
        ));
    }
    for (source, (f, count, line)) in &ctx.converted_shapes {
        out.conversions.push(format!(
            "{file_name}:{line}: translations of {count} dataset 55 mode shape(s) converted to m from {source}: ×{f:e} (rotations in rad unchanged; modal masses as written)"
        ));
    }
    systems::resolve_18(&ctx, &mut out, pending18)?;
    systems::nodes_to_global(&mut ctx, &mut out)?;
    out.units = ctx.units;
    out.warnings = ctx.warnings;
    out.skipped = skipped.into_iter().collect();
    Ok(out)
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests55;
