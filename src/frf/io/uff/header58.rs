//! Dataset 58, records 1–11: DOF identification (6), data form (7), axis characteristics
//! (8–11), read and checked into a [`Header58`]; the names of function and specific data type
//! codes.

use super::block::{Block, Ctx};
use super::lex::{At, col, fields, text};
use super::{OrdinateType, UffError};
use crate::core::{Component, DofId};

pub(super) const RECORDS: [&str; 13] = [
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
pub(super) struct DofRecord {
    pub(super) function_type: i64,
    pub(super) function_id: i64,
    pub(super) load_case: i64,
    pub(super) response_node: i64,
    pub(super) response_direction: i64,
    pub(super) reference_node: i64,
    pub(super) reference_direction: i64,
}

pub(super) fn parse_record_6(at: &At<'_>, raw: &[u8]) -> Result<DofRecord, UffError> {
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
            if toks.len() == 10
                && let (Some(a), Some(b), Some(_), Some(c), Some(d), Some(e2), Some(f), Some(g)) = (
                    num(0),
                    num(1),
                    num(2),
                    num(3),
                    num(5),
                    num(6),
                    num(8),
                    num(9),
                )
            {
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
            Err(e)
        }
    }
}

/// Record 7, data form: Format(3I10,3E13.5).
pub(super) struct FormRecord {
    pub(super) ordinate: i64,
    pub(super) points: i64,
    pub(super) spacing: i64,
    pub(super) start: f64,
    pub(super) step: f64,
}

pub(super) fn parse_record_7(at: &At<'_>, raw: &[u8]) -> Result<FormRecord, UffError> {
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

pub(super) const ORDINATE_VALID: &str =
    "2 (real single), 4 (real double), 5 (complex single) or 6 (complex double)";

/// Records 8–11, axis data characteristics: Format(I10,3I5,2(1X,20A1)).
pub(super) struct AxisRecord {
    pub(super) at_line: usize,
    pub(super) specific_type: i64,
    pub(super) length_exponent: i64,
    pub(super) force_exponent: i64,
    pub(super) unit: String,
}

pub(super) fn parse_axis_record(at: &At<'_>, raw: &[u8]) -> Result<AxisRecord, UffError> {
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
pub(super) fn binary_sizes_58(lines: &[(usize, &[u8])]) -> Vec<usize> {
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

pub(super) fn function_name(t: i64) -> &'static str {
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

pub(super) fn specific_type_name(t: i64) -> &'static str {
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
pub(super) fn dof_of(
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

/// Where record `k` of dataset 58 is, for messages.
pub(super) fn at58(file: &str, k: usize, line: usize) -> At<'_> {
    At {
        file,
        line,
        dataset: 58,
        record: RECORDS[k],
    }
}

/// Records 1–11 of an FRF record (function type 4), checked.
pub(super) struct Header58 {
    /// How DOFs missing from record 6 were read from the ID lines.
    pub(super) dof_note: Option<String>,
    /// Records 1–5, trailing blanks removed.
    pub(super) id_lines: [String; 5],
    /// Record 6: function identification number and load case.
    pub(super) function_id: i64,
    pub(super) load_case: i64,
    /// Record 6: response and reference DOFs with their directions as written.
    pub(super) response: (DofId, i8),
    pub(super) reference: (DofId, i8),
    /// Record 7 and its line.
    pub(super) form: FormRecord,
    pub(super) form_line: usize,
    pub(super) ordinate: OrdinateType,
    /// Even abscissa (record 7 field 3 = 1).
    pub(super) even: bool,
    /// Number of points, at least one.
    pub(super) n: usize,
    /// Records 8–11: abscissa, ordinate numerator and denominator, z axis.
    pub(super) axes: Vec<AxisRecord>,
}

/// Reads records 1–11 of a dataset 58; `None` for a function type other than 4 (an FRF), which
/// is counted in the file's skipped function types.
pub(super) fn read_header(b: &Block<'_>, ctx: &mut Ctx<'_>) -> Result<Option<Header58>, UffError> {
    let file = ctx.file;
    let record = |k: usize| {
        b.lines.get(k - 1).copied().ok_or_else(|| {
            at58(file, k, b.end).err(
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
    let at6 = at58(file, 6, l6);
    let dofs = parse_record_6(&at6, r6)?;
    let (form_line, r7) = record(7)?;
    let form = parse_record_7(&at58(file, 7, form_line), r7)?;
    let mut axes = Vec::with_capacity(4);
    for k in 8..=11 {
        let (l, r) = record(k)?;
        axes.push(parse_axis_record(&at58(file, k, l), r)?);
    }
    if dofs.function_type != 4 {
        let e = ctx
            .skipped_functions
            .entry(dofs.function_type)
            .or_insert((0, b.header_line));
        e.0 += 1;
        return Ok(None);
    }
    let (ordinate, even, n) = check_form(&at58(file, 7, form_line), &form)?;
    let mut dofs = dofs;
    let id_numbers: Vec<usize> = (1..=5).map(|k| b.lines[k - 1].0).collect();
    let dof_note = dofs_from_id_lines(&at6, &id_lines, &id_numbers, &mut dofs)?;
    let response = dof_of(
        &at6,
        dofs.response_node,
        dofs.response_direction,
        "field 6 (response node)",
        "field 7 (response direction)",
    )?;
    let reference = dof_of(
        &at6,
        dofs.reference_node,
        dofs.reference_direction,
        "field 9 (reference node)",
        "field 10 (reference direction)",
    )?;
    Ok(Some(Header58 {
        dof_note,
        id_lines,
        function_id: dofs.function_id,
        load_case: dofs.load_case,
        response,
        reference,
        form,
        form_line,
        ordinate,
        even,
        n,
        axes,
    }))
}

/// Record 7 checked: the ordinate type, whether the abscissa is even, and the number of points.
fn check_form(at7: &At<'_>, form: &FormRecord) -> Result<(OrdinateType, bool, usize), UffError> {
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
    Ok((ordinate, even, n))
}

/// The DOFs an ID line names, in order, as (node, signed direction code): `12:+Z` and `Pt12:+Z`
/// (Test.Lab style), `12.Z-` and `Pt 12.Z-` (sign after the axis), `12:-RX` rotations, `12:TZ`
/// for a translation. A node is a run of digits, followed by at most three of ` :._` and the
/// direction: an optional sign, `R` or `T`, the axis `X`/`Y`/`Z`, an optional sign, and then no
/// letter or digit. Without a sign the separator must hold `:` or `.` (a bare `12 Z` is not
/// read); without a sign the direction is positive.
pub(super) fn id_line_dofs(line: &str) -> Vec<(u64, i8)> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if !b[i].is_ascii_digit() || (i > 0 && b[i - 1].is_ascii_digit()) {
            i += 1;
            continue;
        }
        let start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        let Ok(node) = line[start..i].parse::<u64>() else {
            continue;
        };
        let mut j = i;
        let mut marked = false;
        while j < b.len() && j - i < 3 && matches!(b[j], b' ' | b':' | b'.' | b'_') {
            marked |= matches!(b[j], b':' | b'.');
            j += 1;
        }
        let sign = |c: Option<&u8>| match c {
            Some(b'+') => Some(1i8),
            Some(b'-') => Some(-1i8),
            _ => None,
        };
        let before = sign(b.get(j));
        if before.is_some() {
            j += 1;
        }
        let rotation = match b.get(j).map(|c| c.to_ascii_uppercase()) {
            Some(b'R') => {
                j += 1;
                true
            }
            Some(b'T') => {
                j += 1;
                false
            }
            _ => false,
        };
        let axis = match b.get(j).map(|c| c.to_ascii_uppercase()) {
            Some(b'X') => 1i8,
            Some(b'Y') => 2,
            Some(b'Z') => 3,
            _ => continue,
        };
        j += 1;
        let after = sign(b.get(j));
        if after.is_some() {
            j += 1;
        }
        let boundary = b.get(j).is_none_or(|c| !c.is_ascii_alphanumeric());
        let s = match (before, after) {
            (Some(_), Some(_)) => continue,
            (Some(s), None) | (None, Some(s)) => s,
            (None, None) if marked => 1,
            (None, None) => continue,
        };
        if boundary {
            out.push((node, s * (axis + if rotation { 3 } else { 0 })));
            i = j;
        }
    }
    out
}

/// Fills record 6's zero directions (and zero nodes) from the DOFs the ID lines name
/// ([`id_line_dofs`]): the first named DOF is the response, the second the reference (the
/// only one, when only the reference is missing). A node record 6 gives must agree. Returns a
/// note of what was read, `None` when record 6 names both directions.
fn dofs_from_id_lines(
    at6: &At<'_>,
    id_lines: &[String; 5],
    id_numbers: &[usize],
    dofs: &mut DofRecord,
) -> Result<Option<String>, UffError> {
    let (need_resp, need_ref) = (dofs.response_direction == 0, dofs.reference_direction == 0);
    if !need_resp && !need_ref {
        return Ok(None);
    }
    let named: Vec<(usize, u64, i8)> = id_lines
        .iter()
        .enumerate()
        .flat_map(|(k, l)| id_line_dofs(l).into_iter().map(move |(n, d)| (k, n, d)))
        .collect();
    let (field, wanted) = if need_resp {
        ("field 7 (response direction)", usize::from(need_ref) + 1)
    } else {
        ("field 10 (reference direction)", 1)
    };
    if named.len() < wanted {
        return Err(at6.err(
            field,
            0,
            format!(
                "±1..±6; 0 (scalar) has no DOF unless the response and reference are named in the ID lines (records 1-5), e.g. `12:+Z / 1:+Z` or `Pt12.Z- Pt1.Z+`, and they name {}",
                named.len()
            ),
        ));
    }
    let mut notes = Vec::new();
    let mut take = |which: &str, node: &mut i64, dir: &mut i64, pick: (usize, u64, i8)| {
        let (k, n, d) = pick;
        let at = At {
            line: id_numbers[k],
            record: RECORDS[k + 1],
            ..*at6
        };
        if *node != 0 && u64::try_from(*node).ok() != Some(n) {
            return Err(at.err(
                "field 1 (ID line)",
                &id_lines[k],
                format!("the {which} node {node} of record 6"),
            ));
        }
        *node = n as i64;
        *dir = i64::from(d);
        notes.push(format!(
            "{which} node {n} direction {d:+} read from ID line {} (line {}) `{}`",
            k + 1,
            id_numbers[k],
            id_lines[k]
        ));
        Ok(())
    };
    if need_resp {
        take(
            "response",
            &mut dofs.response_node,
            &mut dofs.response_direction,
            named[0],
        )?;
    }
    if need_ref {
        let pick = if named.len() >= 2 { named[1] } else { named[0] };
        take(
            "reference",
            &mut dofs.reference_node,
            &mut dofs.reference_direction,
            pick,
        )?;
    }
    Ok(Some(format!(
        "record 6 gives direction 0; {}",
        notes.join(", ")
    )))
}
