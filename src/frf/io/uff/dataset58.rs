//! Dataset 58 / 58b, one FRF record: checks of records 1–11, the data of record 12 (ASCII or
//! binary), frequency lines, ordinate units and sign, non-finite values.

use super::block::{Binary, Block, Ctx};
use super::header58::{
    ORDINATE_VALID, RECORDS, dof_of, parse_axis_record, parse_record_6, parse_record_7,
};
use super::lex::{At, parse_real, split_numbers, text};
use super::units::{abscissa_factor, resolve_ordinate};
use super::{Abscissa, ByteOrder, NonFiniteValue, OrdinateType, Uff58, UffError};
use faer::c64;

pub(super) fn parse_58(b: &Block<'_>, ctx: &mut Ctx<'_>) -> Result<Option<Uff58>, UffError> {
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
pub(super) fn decode_binary(
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

pub(super) struct BinReader<'a> {
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
    pub(super) order: ByteOrder,
}

impl BinReader<'_> {
    pub(super) fn read(&mut self, size: usize) -> Option<f64> {
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
