//! Dataset 58 / 58b, one FRF record: the data of record 12 (ASCII or binary), frequency lines,
//! ordinate units and sign, non-finite values. Records 1–11 are read in `header58`.

use super::block::{Binary, Block, Ctx};
use super::header58::{Header58, at58, read_header};
use super::lex::{At, parse_real, split_numbers, text};
use super::units::{abscissa_factor, resolve_ordinate};
use super::{Abscissa, ByteOrder, NonFiniteValue, OrdinateType, Uff58, UffError};
use faer::c64;

/// Reads one dataset 58 / 58b; `None` for a function other than an FRF (skipped and counted).
pub(super) fn parse_58(b: &Block<'_>, ctx: &mut Ctx<'_>) -> Result<Option<Uff58>, UffError> {
    let file = ctx.file;
    ctx.frf_records += 1;
    let index = ctx.frf_records;
    let Some(h) = read_header(b, ctx)? else {
        return Ok(None);
    };
    let layout = Layout::of(&h, file)?;
    let data = match &b.binary {
        None => ascii_data(b, file, &layout)?,
        Some(bin) => binary_data(bin, b, file, &h, &layout)?,
    };
    if let Some((line, count)) = data.padding {
        ctx.warn(format!(
            "{file}:{line}: dataset 58 (header at line {}): {count} zero value(s) after the {} values record 7 declares ({}) taken as padding and ignored",
            b.header_line, layout.total, layout.text
        ));
    }
    let (response, response_direction) = h.response;
    let (reference, reference_direction) = h.reference;
    let mut conversions = Vec::new();
    let loc = format!("{file}:{} H({response}, {reference})", b.header_line);
    if let Some(note) = &h.dof_note {
        conversions.push(format!("{loc}: {note}"));
    }
    let (freqs_hz, abscissa) = frequency_lines(ctx, b, &h, &data.xs, &loc, &mut conversions)?;
    let (quantity, factor, unit_note) = resolve_ordinate(
        ctx,
        &h.axes[1],
        &h.axes[2],
        &at58(file, 9, h.axes[1].at_line),
        &at58(file, 10, h.axes[2].at_line),
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
    let record = Uff58 {
        file: file.to_string(),
        line: b.header_line,
        binary: b.binary.as_ref().map(|bin| bin.order),
        id_lines: h.id_lines,
        function_id: h.function_id,
        load_case: h.load_case,
        response,
        reference,
        response_direction,
        reference_direction,
        sign_flipped,
        ordinate: h.ordinate,
        quantity,
        abscissa,
        freqs_hz,
        values: ordinate_values(h.ordinate, &data.ys, scale),
        conversions,
    };
    check_finite(&record, index, &layout, &data, scale)?;
    Ok(Some(record))
}

/// How record 12 holds its values.
struct Layout {
    /// Number of points.
    n: usize,
    /// Ordinate values per point: 2 complex, 1 real.
    ky: usize,
    even: bool,
    /// Values per point, the abscissa included when uneven.
    per_point: usize,
    /// Number of values in all.
    total: usize,
    /// The layout in words, for messages.
    text: String,
}

impl Layout {
    fn of(h: &Header58, file: &str) -> Result<Layout, UffError> {
        let (n, even, ordinate) = (h.n, h.even, h.ordinate);
        let ky = if ordinate.is_complex() { 2 } else { 1 };
        let per_point = ky + usize::from(!even);
        let text = format!(
            "{n} points of {ordinate}{}",
            if even {
                ", even abscissa"
            } else {
                ", each with its abscissa"
            }
        );
        let total = n.checked_mul(per_point).ok_or_else(|| {
            at58(file, 7, h.form_line).err(
                "field 2 (number of points)",
                n,
                "a count that fits in memory",
            )
        })?;
        Ok(Layout {
            n,
            ky,
            even,
            per_point,
            total,
            text,
        })
    }
}

/// The values of record 12: abscissas (uneven only), ordinate parts, and the first value that
/// is not finite as its index among the data values and its line, and any zero padding.
struct Data {
    xs: Vec<f64>,
    ys: Vec<f64>,
    first_bad: Option<(usize, usize)>,
    /// Zeros after the declared values: the line of the first and their count.
    padding: Option<(usize, usize)>,
}

/// Record 12 in ASCII: every number of the lines after record 11, split into abscissas and
/// ordinate parts.
fn ascii_data(b: &Block<'_>, file: &str, layout: &Layout) -> Result<Data, UffError> {
    let total = layout.total;
    let mut first_bad = None;
    let mut padding: Option<(usize, usize)> = None;
    let mut vals: Vec<f64> = Vec::new();
    for &(no, raw) in b.lines.get(11..).unwrap_or_default() {
        let t = text(raw);
        for tok in t.split_whitespace() {
            for part in split_numbers(tok) {
                let v = parse_real(part).ok_or_else(|| {
                    at58(file, 12, no).err(
                        format!("data value {}", vals.len() + 1),
                        part,
                        "a real number, e.g. -1.23456E-02",
                    )
                })?;
                if vals.len() == total {
                    // Zeros after the declared values pad the last line or block (some
                    // exporters write whole blocks); they are dropped and warned about.
                    if v == 0.0 {
                        padding.get_or_insert((no, 0)).1 += 1;
                        continue;
                    }
                    return Err(at58(file, 12, no).err(
                        "data values",
                        format!(
                            "more than {total} values, value {} being {part} (not zero padding)",
                            total + padding.map_or(0, |p| p.1) + 1
                        ),
                        format!("{total} values: {} (record 7)", layout.text),
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
        return Err(at58(file, 12, b.end).err(
            "data values",
            format!("{} values before the closing `    -1`", vals.len()),
            format!("{total} values: {} (record 7)", layout.text),
        ));
    }
    if layout.even {
        return Ok(Data {
            xs: Vec::new(),
            ys: vals,
            first_bad,
            padding,
        });
    }
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for chunk in vals.chunks(layout.per_point) {
        xs.push(chunk[0]);
        ys.extend_from_slice(&chunk[1..]);
    }
    Ok(Data {
        xs,
        ys,
        first_bad,
        padding,
    })
}

/// Record 12 in binary (58b), with the first value that is not finite indexed as in ASCII.
fn binary_data(
    bin: &Binary<'_>,
    b: &Block<'_>,
    file: &str,
    h: &Header58,
    layout: &Layout,
) -> Result<Data, UffError> {
    let (n, ky, even) = (layout.n, layout.ky, layout.even);
    let at12 = at58(file, 12, b.header_line);
    let (xs, ys) = decode_binary(bin, n, ky, even, h.ordinate, &layout.text, &at12)?;
    // As the ASCII index: abscissa first when uneven, then the ordinate parts.
    let first_bad = (0..n).find_map(|k| {
        let x = if even { None } else { Some(xs[k]) };
        let parts = x
            .into_iter()
            .chain(ys[k * ky..(k + 1) * ky].iter().copied());
        parts
            .enumerate()
            .find(|(_, v)| !v.is_finite())
            .map(|(r, _)| (k * layout.per_point + r, b.header_line))
    });
    Ok(Data {
        xs,
        ys,
        first_bad,
        padding: None,
    })
}

/// The frequency lines in Hz (record 8's unit converted, the conversion noted) and the spacing.
fn frequency_lines(
    ctx: &mut Ctx<'_>,
    b: &Block<'_>,
    h: &Header58,
    xs: &[f64],
    loc: &str,
    conversions: &mut Vec<String>,
) -> Result<(Vec<f64>, Abscissa), UffError> {
    let file = ctx.file;
    let form = &h.form;
    let (af, abscissa_note) = abscissa_factor(ctx, &h.axes[0], &at58(file, 8, h.axes[0].at_line))?;
    if let Some(note) = abscissa_note {
        conversions.push(format!("{loc}: {note}"));
    }
    let freqs_hz: Vec<f64> = if h.even {
        (0..h.n)
            .map(|k| (form.start + k as f64 * form.step) * af)
            .collect()
    } else {
        for (k, x) in xs.iter().enumerate() {
            if !x.is_finite() {
                return Err(at58(file, 12, b.header_line).err(
                    format!("abscissa of point {}", k + 1),
                    x,
                    "a finite frequency",
                ));
            }
        }
        xs.iter().map(|x| x * af).collect()
    };
    if freqs_hz.iter().any(|f| !f.is_finite()) {
        return Err(at58(file, 7, h.form_line).err(
            "fields 4-5 (abscissa minimum and increment)",
            format!("{} + k·{}", form.start, form.step),
            "values whose lines stay finite",
        ));
    }
    let abscissa = if h.even {
        Abscissa::Even {
            start_hz: form.start * af,
            step_hz: form.step * af,
        }
    } else {
        Abscissa::Uneven
    };
    Ok((freqs_hz, abscissa))
}

/// The ordinate parts as complex values, times `scale` (SI factor and sign).
fn ordinate_values(ordinate: OrdinateType, ys: &[f64], scale: f64) -> Vec<c64> {
    let values: Vec<c64> = if ordinate.is_complex() {
        ys.chunks(2)
            .map(|c| c64::new(c[0], c.get(1).copied().unwrap_or(0.0)))
            .collect()
    } else {
        ys.iter().map(|&y| c64::new(y, 0.0)).collect()
    };
    if scale == 1.0 {
        values
    } else {
        values.into_iter().map(|v| v * scale).collect()
    }
}

/// Refuses a record with a value that is NaN or infinite as read, or infinite once converted to
/// SI, naming the first such value.
fn check_finite(
    rec: &Uff58,
    index: usize,
    layout: &Layout,
    data: &Data,
    scale: f64,
) -> Result<(), UffError> {
    let non_finite = |point: usize, line: usize, found: String| {
        UffError::NonFinite(Box::new(NonFiniteValue {
            file: rec.file.clone(),
            line,
            binary: if rec.binary.is_some() { "b" } else { "" },
            index,
            header: rec.line,
            response: rec.response,
            reference: rec.reference,
            point: point + 1,
            freq_hz: rec.freqs_hz.get(point).copied().unwrap_or(f64::NAN),
            found,
        }))
    };
    if let Some((i, line)) = data.first_bad {
        let (point, r) = (i / layout.per_point, i % layout.per_point);
        let found = match r.checked_sub(usize::from(!layout.even)) {
            None => format!(
                "{} in the abscissa",
                data.xs.get(point).copied().unwrap_or(f64::NAN)
            ),
            Some(part) => {
                let v = data
                    .ys
                    .get(point * layout.ky + part)
                    .copied()
                    .unwrap_or(f64::NAN);
                let which = match (rec.ordinate.is_complex(), part) {
                    (false, _) => "",
                    (true, 0) => " in the real part",
                    (true, _) => " in the imaginary part",
                };
                format!("{v}{which}")
            }
        };
        return Err(non_finite(point, line, found));
    }
    if let Some(k) = rec
        .values
        .iter()
        .position(|v| !(v.re.is_finite() && v.im.is_finite()))
    {
        return Err(non_finite(
            k,
            rec.line,
            format!("infinite after conversion to SI (factor {scale:e})"),
        ));
    }
    Ok(())
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
