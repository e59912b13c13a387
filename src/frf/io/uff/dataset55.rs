//! Dataset 55, data at nodes: mode shapes (analysis type 2, normal mode; 3 and 7, complex
//! eigenvalue of first and second order), ASCII.
//!
//! Records 1–5 are ID lines; record 6 (`6I10`) gives model type, analysis type, data
//! characteristic (2: x, y, z; 3: x, y, z, rx, ry, rz), specific data type, data type (2 real,
//! 5 complex) and the values per node (NDV); records 7 (`8I10`: integer count, real count, the
//! type's integers) and 8 (`6E13.5`, the type's reals) depend on the analysis type; records 9
//! (`I10`, node) and 10 (`6E13.5`, NDV values, complex as real then imaginary part) repeat per
//! node. A node left out has all values zero (note 9 of the dataset description).
//!
//! With a dataset 164 before it whose length unit is not the metre, the translational values
//! (displacement, velocity or acceleration: lengths over time) are converted to metres and the
//! rotational ones (radians in every unit system) kept, so that a shape with both is consistent
//! (a MAC over translations in mm and rotations in rad would weight them 1000:1); the
//! conversion is recorded once per file. Modal mass and modal A/B are kept as written.
//!
//! Only shapes of motion are modes: analysis types other than 2, 3 and 7, data characteristics
//! other than 2 and 3, and specific data types other than unknown, general, displacement,
//! velocity and acceleration are skipped, counted and warned about.

use super::block::{Block, Ctx};
use super::lex::{At, fields, parse_real, split_numbers, text};
use super::mesh::length_conversion;
use super::{UffError, UffFile};
use faer::c64;

/// What record 8 says about a mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ModeKind55 {
    /// Analysis type 2: a normal (real) mode.
    Normal {
        /// Frequency, Hz.
        freq_hz: f64,
        /// Modal mass, as written (0 when not given).
        modal_mass: f64,
        /// Modal viscous damping ratio.
        viscous_ratio: f64,
        /// Modal hysteretic damping ratio.
        hysteretic_ratio: f64,
    },
    /// Analysis type 3 (first order) or 7 (second order): a complex mode.
    Complex {
        /// The eigenvalue `λ = −ζω + iω√(1−ζ²)`, rad/s.
        eigenvalue: c64,
        /// Modal A, as written.
        modal_a: c64,
        /// Modal B, as written.
        modal_b: c64,
        /// Analysis type 7.
        second_order: bool,
    },
}

impl ModeKind55 {
    /// Undamped natural frequency (Hz) and viscous damping ratio: `|λ|/2π` and `−Re λ/|λ|` for
    /// a complex mode.
    pub fn frequency_and_damping(&self) -> (f64, f64) {
        match *self {
            ModeKind55::Normal {
                freq_hz,
                viscous_ratio,
                ..
            } => (freq_hz, viscous_ratio),
            ModeKind55::Complex { eigenvalue, .. } => {
                let w = eigenvalue.norm();
                let zeta = if w > 0.0 { -eigenvalue.re / w } else { 0.0 };
                (w / (2.0 * std::f64::consts::PI), zeta)
            }
        }
    }
}

/// One dataset 55 record: a mode shape at nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct Uff55 {
    /// File name, for messages.
    pub file: String,
    /// 1-based line of the dataset number.
    pub line: usize,
    /// Records 1–5, trimmed.
    pub id_lines: [String; 5],
    /// Load case number (record 7 field 3).
    pub load_case: i64,
    /// Mode number (record 7 field 4).
    pub mode: i64,
    /// Frequency, damping and the modal scalars.
    pub kind: ModeKind55,
    /// Specific data type (record 6 field 4): 0, 1, 8 displacement, 11 velocity, 12 acceleration.
    pub specific: i64,
    /// Values per node: 3 (x, y, z) or 6 (x, y, z, rx, ry, rz).
    pub per_node: usize,
    /// Nodes in file order, each with its `per_node` values (real data: zero imaginary parts).
    pub nodes: Vec<(u64, Vec<c64>)>,
    /// Whether the data were complex (record 6 field 5 = 5).
    pub complex: bool,
}

/// The name of a dataset 55 analysis type, for messages.
fn analysis_name(t: i64) -> &'static str {
    match t {
        0 => "unknown",
        1 => "static",
        2 => "normal mode",
        3 => "complex eigenvalue first order",
        4 => "transient",
        5 => "frequency response",
        6 => "buckling",
        7 => "complex eigenvalue second order",
        _ => "not defined",
    }
}

fn at55<'f>(file: &'f str, line: usize, record: &'static str) -> At<'f> {
    At {
        file,
        line,
        dataset: 55,
        record,
    }
}

/// Counts a skipped record with its reason, once per reason in the warnings.
fn skip(ctx: &mut Ctx<'_>, out: &mut UffFile, b: &Block<'_>, reason: String) {
    out.skipped_shapes += 1;
    ctx.warn(format!(
        "{}:{}: dataset 55 skipped: {reason}; only mode shapes (analysis type 2, 3 or 7) of motion at nodes (data characteristic 2 or 3) are read",
        ctx.file, b.header_line
    ));
}

/// Parses one dataset 55 block into `out.shapes`, or skips it with a warning.
pub(super) fn parse_55(
    b: &Block<'_>,
    ctx: &mut Ctx<'_>,
    out: &mut UffFile,
) -> Result<(), UffError> {
    let file = ctx.file;
    let rec = |k: usize, name: &'static str| {
        b.lines.get(k).copied().ok_or_else(|| {
            at55(file, b.end, name).err(
                name,
                "the closing `    -1`",
                "records 1-8 of dataset 55 before the node data",
            )
        })
    };
    let id_lines = std::array::from_fn(|k| {
        b.lines
            .get(k)
            .map_or(String::new(), |(_, r)| text(r).trim().to_string())
    });
    let (l6, r6) = rec(5, "record 6")?;
    let at6 = at55(file, l6, "record 6");
    let f = fields(r6, &[10, 10, 10, 10, 10, 10]);
    let analysis = at6.int_or_zero(&f[1], "field 2 (analysis type)", "0-7")?;
    let characteristic = at6.int_or_zero(&f[2], "field 3 (data characteristic)", "0-5")?;
    let specific = at6.int_or_zero(&f[3], "field 4 (specific data type)", "0-18")?;
    let data_type = at6.int(&f[4], "field 5 (data type)", "2 (real) or 5 (complex)")?;
    let ndv = at6.int(&f[5], "field 6 (values per node)", "a positive count")?;
    if !matches!(analysis, 2 | 3 | 7) {
        skip(
            ctx,
            out,
            b,
            format!("analysis type {analysis} ({})", analysis_name(analysis)),
        );
        return Ok(());
    }
    let per_node = match characteristic {
        2 => 3,
        3 => 6,
        c => {
            skip(
                ctx,
                out,
                b,
                format!(
                    "data characteristic {c} ({})",
                    match c {
                        1 => "scalar, no direction",
                        4 | 5 => "a tensor",
                        _ => "unknown",
                    }
                ),
            );
            return Ok(());
        }
    };
    if !matches!(specific, 0 | 1 | 8 | 11 | 12) {
        skip(
            ctx,
            out,
            b,
            format!("specific data type {specific} (not displacement, velocity or acceleration)"),
        );
        return Ok(());
    }
    let complex = match data_type {
        2 => false,
        5 => true,
        _ => {
            return Err(at6.err("field 5 (data type)", data_type, "2 (real) or 5 (complex)"));
        }
    };
    if ndv != per_node as i64 {
        return Err(at6.err(
            "field 6 (values per node)",
            ndv,
            format!(
                "{per_node} for data characteristic {characteristic} (note 7 of the dataset description)"
            ),
        ));
    }
    // Records 7 and 8.
    let (l7, r7) = rec(6, "record 7")?;
    let at7 = at55(file, l7, "record 7");
    let f7 = fields(r7, &[10, 10, 10, 10]);
    let n_int = at7.int(&f7[0], "field 1 (number of integers)", "2")?;
    let n_real = at7.int(&f7[1], "field 2 (number of reals)", "4 or 6")?;
    let (want_int, want_real) = if analysis == 2 { (2, 4) } else { (2, 6) };
    if n_int != want_int || n_real < want_real {
        return Err(at7.err(
            "fields 1-2 (numbers of integer and real values)",
            format!("{n_int}, {n_real}"),
            format!(
                "{want_int}, {want_real} for analysis type {analysis} ({})",
                analysis_name(analysis)
            ),
        ));
    }
    let load_case = at7.int_or_zero(&f7[2], "field 3 (load case)", "an integer")?;
    let mode = at7.int(&f7[3], "field 4 (mode number)", "an integer")?;
    let mut reals = Vec::new();
    let mut next = 7;
    while reals.len() < n_real as usize {
        let (l8, r8) = rec(next, "record 8")?;
        let at8 = at55(file, l8, "record 8");
        for tok in text(r8).split_whitespace() {
            for part in split_numbers(tok) {
                reals.push(at8.real(part, &format!("field {}", reals.len() + 1))?);
            }
        }
        next += 1;
    }
    let kind = if analysis == 2 {
        ModeKind55::Normal {
            freq_hz: reals[0],
            modal_mass: reals[1],
            viscous_ratio: reals[2],
            hysteretic_ratio: reals[3],
        }
    } else {
        ModeKind55::Complex {
            eigenvalue: c64::new(reals[0], reals[1]),
            modal_a: c64::new(reals[2], reals[3]),
            modal_b: c64::new(reals[4], reals[5]),
            second_order: analysis == 7,
        }
    };
    let mut nodes = node_values(b, file, next, per_node, complex)?;
    if let Some((f, source)) = length_conversion(ctx) {
        // Translations (and their rates) are lengths; rotations are radians in any system.
        for (_, values) in &mut nodes {
            values.iter_mut().take(3).for_each(|v| *v *= f);
        }
        let entry = ctx
            .converted_shapes
            .entry(source)
            .or_insert((f, 0, b.header_line));
        entry.1 += 1;
    }
    out.shapes.push(Uff55 {
        file: file.to_string(),
        line: b.header_line,
        id_lines,
        load_case,
        mode,
        kind,
        specific,
        per_node,
        nodes,
        complex,
    });
    Ok(())
}

/// Records 9 and 10 from line index `start`: a node label, then its values over as many lines
/// as they take.
fn node_values(
    b: &Block<'_>,
    file: &str,
    start: usize,
    per_node: usize,
    complex: bool,
) -> Result<Vec<(u64, Vec<c64>)>, UffError> {
    let parts = if complex { 2 * per_node } else { per_node };
    let mut nodes: Vec<(u64, Vec<c64>)> = Vec::new();
    let mut seen = std::collections::HashMap::new();
    let mut k = start;
    let lines = &b.lines;
    while k < lines.len() {
        let (l9, r9) = lines[k];
        k += 1;
        if r9.trim_ascii().is_empty() {
            continue;
        }
        let at9 = at55(file, l9, "record 9");
        let node = at9.label(text(r9).trim(), "field 1 (node label)")?;
        if let Some(first) = seen.insert(node, l9) {
            return Err(at9.err(
                "field 1 (node label)",
                node,
                format!("each node once per mode (node {node} also at line {first})"),
            ));
        }
        let mut vals: Vec<f64> = Vec::with_capacity(parts);
        while vals.len() < parts {
            let Some(&(l10, r10)) = lines.get(k) else {
                return Err(at55(file, b.end, "record 10").err(
                    format!("values of node {node}"),
                    format!("{} values before the closing `    -1`", vals.len()),
                    format!(
                        "{parts} values ({per_node}{})",
                        if complex { " complex" } else { "" }
                    ),
                ));
            };
            k += 1;
            let at10 = at55(file, l10, "record 10");
            for tok in text(r10).split_whitespace() {
                for part in split_numbers(tok) {
                    let v = parse_real(part).filter(|v| v.is_finite()).ok_or_else(|| {
                        at10.err(
                            format!("value {} of node {node}", vals.len() + 1),
                            part,
                            "a finite real number, e.g. -1.23456E-02",
                        )
                    })?;
                    if vals.len() == parts {
                        return Err(at10.err(
                            format!("values of node {node}"),
                            format!("more than {parts} values"),
                            format!("{parts} values, then the next node's label (record 9)"),
                        ));
                    }
                    vals.push(v);
                }
            }
        }
        let values = if complex {
            vals.chunks(2).map(|c| c64::new(c[0], c[1])).collect()
        } else {
            vals.into_iter().map(|v| c64::new(v, 0.0)).collect()
        };
        nodes.push((node, values));
    }
    Ok(nodes)
}
