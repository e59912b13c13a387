//! Universal File Format writer: dataset 58 / 58b for FRF sets, dataset 2411 for nodes.
//!
//! Records 1–11 are written in their Fortran field widths (SDRC dataset 58 description), so
//! fixed-column readers such as pyuff read the output, as does [the reader](super).
//! FRF sets are written as function type 4, complex double (ordinate type 6), in SI units with
//! their labels (record 8 `Hz`; record 9 `m`, `m/s`, `m/s^2`, or `rad…` on a rotation; record 10
//! `N`, or `N*m` for a moment), positive directions ±1…±6 → 1…6. Three encodings of the data:
//!
//! - [`UffEncoding::Ascii`]: the standard fields of record 12 (`4E20.12` double, `6E13.5`
//!   single, `E13.5` for an uneven abscissa), each number with as many significant digits as
//!   its field holds while keeping a leading blank: 13–14 in 20 columns (double values
//!   round-trip to about 5e-14 relative), 6–7 in 13 columns (single values, uneven abscissas).
//! - [`UffEncoding::AsciiExact`]: 17 significant digits in 25 columns (`4E25.16`; 9 digits in
//!   16 columns for single data), exact for every value, but not the standard column layout:
//!   readers that split at fixed columns (pyuff) misread it; whitespace-splitting readers and
//!   this crate read it.
//! - [`UffEncoding::Binary`]: 58b, IEEE 754 in the chosen byte order (uneven abscissas as
//!   `f64` for double data), exact; the header's byte count is the data's.
//!
//! The abscissa is written even (record 7 minimum and increment) when the lines are exactly
//! `start + k·step` with `start` and `step` exact in record 7's 13 columns; otherwise each
//! value carries its abscissa (uneven).

use super::{Abscissa, ByteOrder, OrdinateType, Uff58};
use crate::frf::FrfSet;
use std::fmt::Write as _;

/// How record 12 (the data) is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UffEncoding {
    /// ASCII in the standard field widths, readable by fixed-column readers.
    Ascii,
    /// ASCII with 17 significant digits in 25 columns: exact, but not the standard widths.
    AsciiExact,
    /// Binary 58b in the given byte order: exact.
    Binary(ByteOrder),
}

/// Dataset 58 (ASCII, standard widths) or 58b (binary, little endian) for every FRF of `set`.
pub fn write_uff58(set: &FrfSet, binary: bool) -> Vec<u8> {
    let encoding = if binary {
        UffEncoding::Binary(ByteOrder::Little)
    } else {
        UffEncoding::Ascii
    };
    write_uff58_as(set, encoding)
}

/// Dataset 58 / 58b for every FRF of `set` in the given encoding.
pub fn write_uff58_as(set: &FrfSet, encoding: UffEncoding) -> Vec<u8> {
    write_uff58_records(&records_from_set(set), encoding)
}

/// The FRFs of `set` as dataset 58 records (complex double, even abscissa when exact).
pub fn records_from_set(set: &FrfSet) -> Vec<Uff58> {
    let abscissa = match even_spacing(&set.freqs_hz) {
        Some((start_hz, step_hz)) => Abscissa::Even { start_hz, step_hz },
        None => Abscissa::Uneven,
    };
    let lines = set.freqs_hz.len().min(set.values.nrows());
    set.pairs
        .iter()
        .enumerate()
        .filter(|(j, _)| *j < set.values.ncols())
        .map(|(j, p)| Uff58 {
            file: String::new(),
            line: 0,
            binary: None,
            id_lines: [
                format!(
                    "H({}, {}) {}",
                    p.response,
                    p.excitation,
                    set.quantity.name()
                ),
                "femu".to_string(),
                "NONE".to_string(),
                "NONE".to_string(),
                "NONE".to_string(),
            ],
            function_id: j as i64 + 1,
            load_case: 0,
            response: p.response,
            reference: p.excitation,
            response_direction: p.response.comp.nastran() as i8,
            reference_direction: p.excitation.comp.nastran() as i8,
            sign_flipped: false,
            ordinate: OrdinateType::ComplexDouble,
            quantity: set.quantity,
            abscissa,
            freqs_hz: set.freqs_hz[..lines].to_vec(),
            values: (0..lines).map(|i| set.values[(i, j)]).collect(),
            conversions: Vec::new(),
        })
        .collect()
}

/// Dataset 58 / 58b for each record, in its ordinate type; SI labels, positive directions.
/// An even abscissa is written only when the lines allow it exactly (see the module notes).
pub fn write_uff58_records(records: &[Uff58], encoding: UffEncoding) -> Vec<u8> {
    let mut out = Vec::new();
    for rec in records {
        write_record(&mut out, rec, encoding);
    }
    out
}

/// Dataset 2411 (nodes, double precision) with 17 significant digits: exact; coordinates in
/// the global system (definition and displacement system 0).
pub fn write_uff2411(nodes: &[(u64, [f64; 3])]) -> Vec<u8> {
    let framed: Vec<(u64, [f64; 3], u32)> = nodes.iter().map(|&(id, x)| (id, x, 0)).collect();
    write_uff2411_framed(&framed)
}

/// Dataset 2411 as [`write_uff2411`], each node with its displacement coordinate system (its
/// record 1 field 3; 0 global), which a dataset 2420 of the same file must define.
pub fn write_uff2411_framed(nodes: &[(u64, [f64; 3], u32)]) -> Vec<u8> {
    let mut s = String::from("    -1\n  2411\n");
    for (id, xyz, disp) in nodes {
        let _ = writeln!(s, "{id:>10}{:>10}{disp:>10}{:>10}", 0, 11);
        for x in xyz {
            s.push_str(&fmt_e(*x, 25));
        }
        s.push('\n');
    }
    s.push_str("    -1\n");
    s.into_bytes()
}

/// Dataset 164 (units) declaring SI (code 1, metre and newton, temperature in kelvin): what
/// every value femu writes is in, stated so that no reader has to assume it.
pub fn write_uff164_si() -> Vec<u8> {
    let mut s = String::from("    -1\n   164\n");
    let _ = writeln!(s, "{:>10}{:<20}{:>10}", 1, "SI: meter (newton)", 2);
    for x in [1.0, 1.0, 1.0] {
        s.push_str(&fmt_e(x, 25));
    }
    s.push('\n');
    s.push_str(&fmt_e(273.15, 25));
    s.push_str("\n    -1\n");
    s.into_bytes()
}

/// A Cartesian coordinate system for dataset 2420: its label (≥ 1), its axes as unit rows in
/// global components, and its origin in global (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CartesianSystem {
    /// Label, ≥ 1 (0 is the global system, never written).
    pub label: u32,
    /// The local x, y, z axes (rows), in global components.
    pub axes: [[f64; 3]; 3],
    /// Origin in global.
    pub origin: [f64; 3],
}

/// Dataset 2420 (coordinate systems) with Cartesian systems: record 1 the part UID (1),
/// record 2 the part name, then per system Format(3I10) label, type 0, colour 8, its name, and
/// the transformation as four Format(1P3D25.16) rows (the axes, then the origin) with 17
/// significant digits: exact.
pub fn write_uff2420(part: &str, systems: &[CartesianSystem]) -> Vec<u8> {
    let mut s = String::from("    -1\n  2420\n");
    let _ = writeln!(s, "{:>10}", 1);
    let _ = writeln!(s, "{}", id_line(part));
    for sys in systems {
        let _ = writeln!(s, "{:>10}{:>10}{:>10}", sys.label, 0, 8);
        let _ = writeln!(s, "{}", id_line(&format!("CS{}", sys.label)));
        for row in sys.axes.iter().chain(std::iter::once(&sys.origin)) {
            for x in row {
                s.push_str(&fmt_e(*x, 25));
            }
            s.push('\n');
        }
    }
    s.push_str("    -1\n");
    s.into_bytes()
}

/// `(start, step)` when `freqs` are exactly `start + k·step` with both exact in 13 columns.
pub fn even_spacing(freqs: &[f64]) -> Option<(f64, f64)> {
    let (&start, rest) = freqs.split_first()?;
    if !fits_13(start) {
        return None;
    }
    let Some(&last) = rest.last() else {
        return Some((start, 1.0));
    };
    let raw = [rest[0] - start, (last - start) / rest.len() as f64];
    raw.iter()
        .flat_map(|&d| [d, round_13(d)])
        .find(|&step| {
            step > 0.0
                && fits_13(step)
                && freqs
                    .iter()
                    .enumerate()
                    .all(|(k, &f)| f == start + k as f64 * step)
        })
        .map(|step| (start, step))
}

fn round_13(x: f64) -> f64 {
    fmt_e(x, 13).trim().parse().unwrap_or(f64::NAN)
}

fn fits_13(x: f64) -> bool {
    x.is_finite() && round_13(x) == x
}

/// `x` in 1P E-format (`-1.2345E+02`, at least two exponent digits), right-aligned in `width`
/// columns, with as many significant digits as fit while keeping one leading blank.
fn fmt_e(x: f64, width: usize) -> String {
    if !x.is_finite() {
        let s = if x.is_nan() {
            "NaN"
        } else if x > 0.0 {
            "Inf"
        } else {
            "-Inf"
        };
        return format!("{s:>width$}");
    }
    let mut best = sci(x, 0);
    for digits in (0..=16).rev() {
        let s = sci(x, digits);
        if s.len() < width {
            best = s;
            break;
        }
    }
    format!("{best:>width$}")
}

/// `x` with `digits` digits after the point, exponent as `E+dd`.
fn sci(x: f64, digits: usize) -> String {
    let s = format!("{x:.digits$e}");
    match s.split_once('e') {
        Some((mantissa, exp)) => {
            let e: i32 = exp.parse().unwrap_or(0);
            let sign = if e < 0 { '-' } else { '+' };
            format!("{mantissa}E{sign}{:02}", e.unsigned_abs())
        }
        None => s,
    }
}

fn axis_line(specific: u32, length: i32, force: i32, label: &str, unit: &str) -> String {
    format!(
        "{specific:>10}{length:>5}{force:>5}{:>5} {label:<20} {unit:<20}\n",
        0
    )
}

/// An 80-column ID line without line ends; `NONE` when blank.
fn id_line(s: &str) -> String {
    let clean: String = s
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    let clean = clean.trim_end();
    if clean.trim().is_empty() {
        return "NONE".to_string();
    }
    let mut out = String::new();
    for c in clean.chars() {
        if out.len() + c.len_utf8() > 80 {
            break;
        }
        out.push(c);
    }
    out
}

/// One FRF record as dataset 58 / 58b in `encoding`, appended to `out`.
fn write_record(out: &mut Vec<u8>, rec: &Uff58, encoding: UffEncoding) {
    let n = rec.freqs_hz.len().min(rec.values.len());
    let freqs = &rec.freqs_hz[..n];
    let even = match rec.abscissa {
        Abscissa::Even { .. } => even_spacing(freqs),
        Abscissa::Uneven => None,
    };
    let double = rec.ordinate.is_double();
    let values = data_values(rec, n, even.is_none());

    let mut s = String::from("    -1\n");
    match encoding {
        UffEncoding::Binary(order) => {
            let size = if double { 8 } else { 4 };
            let _ = writeln!(
                s,
                "{:>6}b{:>6}{:>6}{:>12}{:>12}{:>6}{:>6}{:>12}{:>12}",
                58,
                order.code(),
                2,
                11,
                values.len() * size,
                0,
                0,
                0,
                0
            );
        }
        UffEncoding::Ascii | UffEncoding::AsciiExact => s.push_str("    58\n"),
    }
    write_records_1_to_11(&mut s, rec, n, even);

    match encoding {
        UffEncoding::Binary(order) => {
            let mut bytes = s.into_bytes();
            // Single-precision data keep an uneven abscissa in single precision too.
            for v in &values {
                match (double, order) {
                    (true, ByteOrder::Little) => bytes.extend_from_slice(&v.to_le_bytes()),
                    (true, ByteOrder::Big) => bytes.extend_from_slice(&v.to_be_bytes()),
                    (false, ByteOrder::Little) => {
                        bytes.extend_from_slice(&(*v as f32).to_le_bytes());
                    }
                    (false, ByteOrder::Big) => bytes.extend_from_slice(&(*v as f32).to_be_bytes()),
                }
            }
            bytes.extend_from_slice(b"    -1\n");
            out.extend_from_slice(&bytes);
        }
        UffEncoding::Ascii | UffEncoding::AsciiExact => {
            let exact = encoding == UffEncoding::AsciiExact;
            let complex = rec.ordinate.is_complex();
            let pattern: Vec<usize> = match (exact, double, even.is_some(), complex) {
                (true, true, false, true) => vec![25; 3],
                (true, true, _, _) => vec![25; 4],
                (true, false, _, _) => vec![16; 6],
                (false, true, true, _) => vec![20; 4],
                (false, true, false, false) => vec![13, 20, 13, 20],
                (false, true, false, true) => vec![13, 20, 20],
                (false, false, _, _) => vec![13; 6],
            };
            write_columns(&mut s, &values, &pattern);
            s.push_str("    -1\n");
            out.extend_from_slice(s.as_bytes());
        }
    }
}

/// The values of record 12 in file order: per line the abscissa (when `with_abscissa`), the
/// real part and, for complex data, the imaginary part; rounded to `f32` for single data.
fn data_values(rec: &Uff58, n: usize, with_abscissa: bool) -> Vec<f64> {
    let double = rec.ordinate.is_double();
    let complex = rec.ordinate.is_complex();
    let single = |v: f64| if double { v } else { f64::from(v as f32) };
    let mut values = Vec::with_capacity(n * 3);
    for (f, v) in rec.freqs_hz[..n].iter().zip(&rec.values) {
        if with_abscissa {
            values.push(single(*f));
        }
        values.push(single(v.re));
        if complex {
            values.push(single(v.im));
        }
    }
    values
}

/// Records 1–11: ID lines, DOF identification, data form (`n` points, `even` start and step),
/// and the axis characteristics in SI units.
fn write_records_1_to_11(s: &mut String, rec: &Uff58, n: usize, even: Option<(f64, f64)>) {
    for id in &rec.id_lines {
        s.push_str(&id_line(id));
        s.push('\n');
    }
    let resp = rec.response;
    let refr = rec.reference;
    let _ = writeln!(
        s,
        "{:>5}{:>10}{:>5}{:>10} {:<10}{:>10}{:>4} {:<10}{:>10}{:>4}",
        4,
        rec.function_id,
        0,
        rec.load_case,
        "NONE",
        resp.node,
        resp.comp.nastran(),
        "NONE",
        refr.node,
        refr.comp.nastran()
    );
    let (start, step) = even.unwrap_or((0.0, 0.0));
    let _ = writeln!(
        s,
        "{:>10}{:>10}{:>10}{}{}{}",
        rec.ordinate.code(),
        n,
        u8::from(even.is_some()),
        fmt_e(start, 13),
        fmt_e(step, 13),
        fmt_e(0.0, 13)
    );
    s.push_str(&axis_line(18, 0, 0, "Frequency", "Hz"));
    let rot_r = resp.comp.is_rotation();
    let base = if rot_r { "rad" } else { "m" };
    let (specific, label, unit) = match rec.quantity {
        crate::frf::Quantity::Receptance => (8, "Displacement", base.to_string()),
        crate::frf::Quantity::Mobility => (11, "Velocity", format!("{base}/s")),
        crate::frf::Quantity::Accelerance => (12, "Acceleration", format!("{base}/s^2")),
    };
    s.push_str(&axis_line(specific, i32::from(!rot_r), 0, label, &unit));
    if refr.comp.is_rotation() {
        s.push_str(&axis_line(13, 1, 1, "Moment", "N*m"));
    } else {
        s.push_str(&axis_line(13, 0, 1, "Force", "N"));
    }
    s.push_str(&axis_line(0, 0, 0, "NONE", "NONE"));
}

/// Values in lines of fields of the widths of `pattern`, a new line after each full pattern.
fn write_columns(s: &mut String, values: &[f64], pattern: &[usize]) {
    for line in values.chunks(pattern.len()) {
        for (v, w) in line.iter().zip(pattern) {
            s.push_str(&fmt_e(*v, *w));
        }
        s.push('\n');
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_fill_their_fields_with_a_leading_blank() {
        assert_eq!(fmt_e(1.0, 13), " 1.000000E+00");
        assert_eq!(fmt_e(-1.0 / 3.0, 13), " -3.33333E-01");
        assert_eq!(fmt_e(-1.0 / 3.0, 20), " -3.333333333333E-01");
        assert_eq!(fmt_e(2.0 / 3.0, 20), " 6.6666666666667E-01");
        assert_eq!(fmt_e(-2e-300, 25), " -2.0000000000000001E-300");
        // Rounding up to a three-digit exponent costs a digit.
        assert_eq!(fmt_e(9.999_999_9e99, 13), " 1.00000E+100");
        assert_eq!(fmt_e(f64::NAN, 13), "          NaN");
        for w in [13, 16, 20, 25] {
            for x in [
                0.0,
                -0.0,
                1.5e-7,
                -123.456,
                6.02e23,
                -1e-100,
                f64::MAX,
                f64::MIN_POSITIVE,
            ] {
                let s = fmt_e(x, w);
                assert_eq!(s.len(), w, "{s}");
                assert!(s.starts_with(' '), "{s}");
            }
        }
        // 17 significant digits in 25 columns: every double comes back exactly.
        for x in [1.0 / 3.0, -1.0 / 7.0, 1e-310, f64::MAX] {
            assert_eq!(
                fmt_e(x, 25).trim().parse::<f64>().unwrap().to_bits(),
                x.to_bits()
            );
        }
    }

    #[test]
    fn even_spacing_needs_exact_start_and_step() {
        let lines: Vec<f64> = (0..801).map(|k| 1.0 + k as f64 * 0.05).collect();
        assert_eq!(even_spacing(&lines), Some((1.0, 0.05)));
        assert_eq!(even_spacing(&[3.0]), Some((3.0, 1.0)));
        assert_eq!(even_spacing(&[]), None);
        // A step that needs more than 7 significant digits is written uneven.
        let fine: Vec<f64> = (0..4).map(|k| k as f64 * 0.123_456_789).collect();
        assert_eq!(even_spacing(&fine), None);
        assert_eq!(even_spacing(&[1.0, 2.0, 3.5]), None);
    }

    #[test]
    fn id_lines_are_single_80_column_lines() {
        assert_eq!(id_line(""), "NONE");
        assert_eq!(id_line("a\nb\r"), "a b");
        assert_eq!(id_line(&"é".repeat(50)).len(), 80);
    }
}

/// One mode for dataset 55: its frequency, modal mass and damping ratio, and its shape.
#[derive(Clone, Copy, Debug)]
pub struct ModeRecord<'a> {
    /// Mode number (record 7 field 4).
    pub mode: usize,
    /// Natural frequency, Hz.
    pub freq_hz: f64,
    /// Modal mass `φᵀMφ` of the shape as written (1 for mass-normalised shapes, 0 unknown).
    pub modal_mass: f64,
    /// Modal viscous damping ratio.
    pub damping_ratio: f64,
    /// The shape, one value per DOF of [`write_uff55`]'s `dofs`.
    pub shape: &'a [f64],
}

/// Modes as dataset 55 (data at nodes, analysis type 2 normal mode, real, displacement), one
/// dataset per mode: `x, y, z` per node (data characteristic 2), or `x, y, z, rx, ry, rz` when
/// any DOF is a rotation (3); components not among `dofs` are written 0 (note 15 of the
/// description). Values in `6E13.5` columns with as many digits as fit (about 7). `title` is
/// ID line 1. Scalar-point DOFs have no place in the dataset and are refused.
pub fn write_uff55(
    dofs: &[crate::core::DofId],
    modes: &[ModeRecord<'_>],
    title: &str,
) -> Result<Vec<u8>, String> {
    use crate::core::Component;
    use std::collections::BTreeMap;
    let mut nodes: BTreeMap<u64, Vec<(usize, usize)>> = BTreeMap::new();
    let mut rotations = false;
    for (row, d) in dofs.iter().enumerate() {
        let Some(k) = Component::ALL.iter().position(|c| *c == d.comp) else {
            return Err(format!(
                "DOF {d} is a scalar point's; dataset 55 holds only grid translations and rotations"
            ));
        };
        rotations |= k >= 3;
        nodes.entry(d.node).or_default().push((k, row));
    }
    let per_node = if rotations { 6 } else { 3 };
    let mut s = String::new();
    for m in modes {
        if m.shape.len() != dofs.len() {
            return Err(format!(
                "mode {} has {} values for {} DOFs",
                m.mode,
                m.shape.len(),
                dofs.len()
            ));
        }
        s.push_str("    -1\n    55\n");
        let _ = writeln!(s, "{}", id_line(title));
        let _ = writeln!(s, "{}", id_line(&format!("mode {}", m.mode)));
        let _ = writeln!(s, "NONE");
        let _ = writeln!(s, "NONE");
        let _ = writeln!(
            s,
            "{}",
            id_line(&format!(
                "MODE {:>10} FREQUENCY {}",
                m.mode,
                fmt_e(m.freq_hz, 13)
            ))
        );
        let _ = writeln!(
            s,
            "{:>10}{:>10}{:>10}{:>10}{:>10}{:>10}",
            1,
            2,
            if rotations { 3 } else { 2 },
            8,
            2,
            per_node
        );
        let _ = writeln!(s, "{:>10}{:>10}{:>10}{:>10}", 2, 4, 1, m.mode);
        for v in [m.freq_hz, m.modal_mass, m.damping_ratio, 0.0] {
            s.push_str(&fmt_e(v, 13));
        }
        s.push('\n');
        for (node, comps) in &nodes {
            let mut vals = vec![0.0; per_node];
            for &(k, row) in comps {
                vals[k] = m.shape[row];
            }
            let _ = writeln!(s, "{node:>10}");
            for chunk in vals.chunks(6) {
                for v in chunk {
                    s.push_str(&fmt_e(*v, 13));
                }
                s.push('\n');
            }
        }
        s.push_str("    -1\n");
    }
    Ok(s.into_bytes())
}
