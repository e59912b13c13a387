//! Units: unit labels of records 8–10, dataset 164, and the quantity and SI factor of an FRF
//! record's abscissa and ordinate.

use super::block::{Block, Ctx};
use super::header58::{AxisRecord, RECORDS, specific_type_name};
use super::label::parse_expr;
use super::lex::{At, col, fields, text};
use super::{UffError, UffUnits};
use crate::frf::Quantity;
use std::f64::consts::PI;

/// Standard gravity in m/s², the value of one `g`.
pub(super) const STANDARD_GRAVITY: f64 = 9.806_65;
/// One pound-force in newtons.
pub(super) const POUND_FORCE: f64 = 4.448_221_615_260_5;

/// A unit label made comparable: no blanks, lower case, `²` → `^2`, `sec` → `s`, `µ` → `u`.
/// `None` for a blank label or `NONE`.
pub(super) fn normalise_unit(s: &str) -> Option<String> {
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

pub(super) fn strip_parens(s: &str) -> &str {
    s.strip_prefix('(')
        .and_then(|x| x.strip_suffix(')'))
        .unwrap_or(s)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Motion {
    Displacement,
    Velocity,
    Acceleration,
}

impl Motion {
    pub(super) fn name(self) -> &'static str {
        match self {
            Motion::Displacement => "displacement",
            Motion::Velocity => "velocity",
            Motion::Acceleration => "acceleration",
        }
    }

    pub(super) fn quantity(self) -> Quantity {
        match self {
            Motion::Displacement => Quantity::Receptance,
            Motion::Velocity => Quantity::Mobility,
            Motion::Acceleration => Quantity::Accelerance,
        }
    }
}

#[derive(Clone, Copy, Debug)]
pub(super) struct MotionUnit {
    pub(super) kind: Motion,
    pub(super) rotational: bool,
    /// SI per file unit.
    pub(super) factor: f64,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct ForceUnit {
    pub(super) moment: bool,
    /// SI per file unit.
    pub(super) factor: f64,
}

pub(super) fn length_unit(s: &str) -> Option<(f64, bool)> {
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

pub(super) fn motion_unit(s: &str) -> Option<MotionUnit> {
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

pub(super) fn force_unit(s: &str) -> Option<ForceUnit> {
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
pub(super) fn frf_label(raw: &str) -> Result<Option<(MotionUnit, Option<ForceUnit>)>, ()> {
    let Some(n) = normalise_unit(raw) else {
        return Ok(None);
    };
    if let Some(plain) = plain_frf_label(&n) {
        return Ok(Some(plain));
    }
    parse_expr(raw).and_then(|e| e.as_frf()).map(Some).ok_or(())
}

/// The plain spellings: a motion unit, or one over a force (`m/s^2/N`, `g/lbf`).
fn plain_frf_label(n: &str) -> Option<(MotionUnit, Option<ForceUnit>)> {
    if let Some(m) = motion_unit(n) {
        return Some((m, None));
    }
    n.rmatch_indices('/')
        .find_map(|(i, _)| Some((motion_unit(&n[..i])?, Some(force_unit(&n[i + 1..])?))))
}

/// A force or moment label: the plain spellings, else a unit expression (`kN`, `N·mm`).
fn force_label(raw: &str, n: &str) -> Option<ForceUnit> {
    force_unit(n).or_else(|| parse_expr(raw).and_then(|e| e.as_force()))
}

/// How a label outside the plain spellings was read, e.g. ``record 9 label `(1/N)*(m/s²)` read
/// as m/s^2/N``; `None` for a plain or blank label.
fn reading(record: &str, raw: &str, force: bool) -> Option<String> {
    let n = normalise_unit(raw)?;
    let plain = if force {
        force_unit(&n).is_some()
    } else {
        plain_frf_label(&n).is_some()
    };
    if plain {
        return None;
    }
    let e = parse_expr(raw)?;
    Some(format!(
        "{record} label `{}` read as {}",
        raw.trim(),
        e.describe()
    ))
}

pub(super) const MOTION_LABELS: &str = "a motion unit such as m, mm, um, in, m/s, mm/s, in/s, m/s^2, mm/s^2, g, rad, rad/s, rad/s^2, optionally over a force (m/s^2/N, g/lbf, m/N, (1/N)*(m/s²), m/(s^2 N)); or NONE";
pub(super) const FORCE_LABELS: &str =
    "a force unit N, kN, mN, lbf, kgf, or a moment unit N*m, kN*m, N*mm, lbf*in, lbf*ft; or NONE";

pub(super) fn si_unit(kind: Motion, rot_response: bool, rot_reference: bool) -> String {
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
pub(super) fn units_factor(units: &UffUnits, len: i64, force: i64) -> f64 {
    let e = |x: i64| i32::try_from(x.clamp(-64, 64)).unwrap_or(0);
    units.length_factor.powi(-e(len)) * units.force_factor.powi(-e(force))
}

/// Quantity and SI factor of the ordinate from records 9 (numerator) and 10 (denominator),
/// with a description of the conversion when the factor is not one.
pub(super) fn resolve_ordinate(
    ctx: &mut Ctx<'_>,
    num: &AxisRecord,
    den: &AxisRecord,
    at9: &At<'_>,
    at10: &At<'_>,
    rot_response: bool,
    rot_reference: bool,
) -> Result<(Quantity, f64, Option<String>), UffError> {
    let o = Ordinate {
        num,
        den,
        at9,
        at10,
        rot_response,
        rot_reference,
    };
    let (kind, num_label, den_label) = o.kind()?;
    o.check_senses(num_label, den_label)?;
    let units = ctx.units.clone().filter(|u| !u.is_si());
    let mut sources: Vec<String> = Vec::new();
    let num_factor = o.numerator_factor(num_label, units.as_ref(), &mut sources);
    let label_force = num_label.and_then(|(_, f)| f);
    let den_factor = o.denominator_factor(label_force, den_label, units.as_ref(), &mut sources)?;
    if num_factor.is_none() || den_factor.is_none() {
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
    let factor = num_factor.unwrap_or(1.0) / den_factor.unwrap_or(1.0);
    if !(factor.is_finite() && factor > 0.0) {
        return Err(at9.err(
            "fields 2-3 (units exponents)",
            format!("{} and {}", num.length_exponent, num.force_exponent),
            "exponents that give a finite conversion factor",
        ));
    }
    let mut notes: Vec<String> = [
        reading("record 9", &num.unit, false),
        reading("record 10", &den.unit, true),
    ]
    .into_iter()
    .flatten()
    .collect();
    if factor != 1.0 {
        notes.push(format!(
            "ordinate converted to SI {} from {}: ×{factor:e}",
            si_unit(kind, rot_response, rot_reference),
            sources.join(" and ")
        ));
    }
    let note = (!notes.is_empty()).then(|| notes.join("; "));
    Ok((kind.quantity(), factor, note))
}

/// The ordinate's numerator label: its motion unit and the force it may be over.
type NumLabel = Option<(MotionUnit, Option<ForceUnit>)>;

/// Records 9 and 10 of one FRF record, with where they are and the senses of its DOFs.
struct Ordinate<'r> {
    num: &'r AxisRecord,
    den: &'r AxisRecord,
    at9: &'r At<'r>,
    at10: &'r At<'r>,
    /// The response direction is a rotation.
    rot_response: bool,
    /// The reference direction is a rotation (the excitation a moment).
    rot_reference: bool,
}

impl Ordinate<'_> {
    /// The motion the numerator measures, from its specific data type or its label (which must
    /// agree when both tell), and the labels of numerator and denominator.
    fn kind(&self) -> Result<(Motion, NumLabel, Option<ForceUnit>), UffError> {
        let (num, den, at9, at10) = (self.num, self.den, self.at9, self.at10);
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
                force_label(&den.unit, &n)
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
        Ok((kind, num_label, den_label))
    }

    /// Refuses labels whose sense (translation or rotation, force or moment) is not the
    /// directions' of record 6.
    fn check_senses(
        &self,
        num_label: NumLabel,
        den_label: Option<ForceUnit>,
    ) -> Result<(), UffError> {
        let (num, den, at9, at10) = (self.num, self.den, self.at9, self.at10);
        let (rot_response, rot_reference) = (self.rot_response, self.rot_reference);
        let sense = |rot: bool| if rot { "rotation" } else { "translation" };
        let force = |rot: bool| if rot { "moment" } else { "force" };
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
            if let Some(f) = f
                && f.moment != rot_reference
            {
                return Err(at9.err(
                    "field 6 (units label)",
                    &num.unit,
                    format!(
                        "a label over a {}, as the reference direction is a {}",
                        force(rot_reference),
                        sense(rot_reference)
                    ),
                ));
            }
        }
        if let Some(f) = den_label
            && f.moment != rot_reference
        {
            return Err(at10.err(
                "field 6 (units label)",
                &den.unit,
                format!(
                    "a {} unit, as the reference direction is a {}",
                    force(rot_reference),
                    sense(rot_reference)
                ),
            ));
        }
        Ok(())
    }

    /// SI per file unit of the numerator, from its label, else from dataset 164 (`units`, not
    /// SI) with the record's exponents; `None` when neither tells (SI assumed).
    fn numerator_factor(
        &self,
        num_label: NumLabel,
        units: Option<&UffUnits>,
        sources: &mut Vec<String>,
    ) -> Option<f64> {
        let num = self.num;
        match (num_label, units) {
            (Some((m, _)), _) => {
                sources.push(format!("record 9 label `{}`", num.unit.trim()));
                Some(m.factor)
            }
            (None, Some(u)) => {
                let (l, f) = if num.specific_type == 1 {
                    (num.length_exponent, num.force_exponent)
                } else if self.rot_response {
                    (0, 0)
                } else {
                    (1, 0)
                };
                sources.push(format!(
                    "dataset 164 units `{}` (line {}) with numerator exponents length {l}, force {f}",
                    u.description, u.line
                ));
                Some(units_factor(u, l, f))
            }
            (None, None) => None,
        }
    }

    /// SI per file unit of the denominator, from the force of the numerator's label or record
    /// 10's label (which must agree), else from dataset 164; `None` when nothing tells.
    fn denominator_factor(
        &self,
        label_force: Option<ForceUnit>,
        den_label: Option<ForceUnit>,
        units: Option<&UffUnits>,
        sources: &mut Vec<String>,
    ) -> Result<Option<f64>, UffError> {
        let (num, den) = (self.num, self.den);
        Ok(match (label_force, den_label, units) {
            (Some(a), Some(b), _) => {
                if (a.factor - b.factor).abs() > 1e-12 * a.factor.abs() {
                    return Err(self.at10.err(
                        "field 6 (units label)",
                        &den.unit,
                        format!(
                            "the force unit of record 9's label `{}`, or NONE",
                            num.unit.trim()
                        ),
                    ));
                }
                Some(a.factor)
            }
            (Some(a), None, _) => Some(a.factor),
            (None, Some(b), _) => {
                sources.push(format!("record 10 label `{}`", den.unit.trim()));
                Some(b.factor)
            }
            (None, None, Some(u)) => {
                let (l, f) = if den.specific_type == 1 {
                    (den.length_exponent, den.force_exponent)
                } else if self.rot_reference {
                    (1, 1)
                } else {
                    (0, 1)
                };
                sources.push(format!(
                    "dataset 164 units `{}` with denominator exponents length {l}, force {f}",
                    u.description
                ));
                Some(units_factor(u, l, f))
            }
            (None, None, None) => None,
        })
    }
}

/// Factor from the file's abscissa unit to Hz (record 8), with a note when not one.
pub(super) fn abscissa_factor(
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

/// Dataset 164, units: Format(I10,20A1,I10), then Format(3D25.17), then the temperature offset.
pub(super) fn parse_units_164(b: &Block<'_>, file: &str) -> Result<UffUnits, UffError> {
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
