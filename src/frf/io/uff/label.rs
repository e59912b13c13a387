//! Unit labels written as expressions, as lab software spells them: `(1/N)*(m/s²)`,
//! `m/(s^2 N)`, `(m/s2)/N`, `m·s⁻²/N`, `μm/N`. A label is read into a factor to SI and the
//! exponents of length, angle, time and force, then into the motion over force (or moment) an
//! FRF ordinate needs. Used when the plain labels of `units` (`m/s^2/N`, `g/lbf`) do not match.

use super::units::{ForceUnit, Motion, MotionUnit, POUND_FORCE, STANDARD_GRAVITY};
use std::f64::consts::PI;

/// Exponents of length, angle, time and force.
type Dims = [i32; 4];
const L: usize = 0;
const A: usize = 1;
const T: usize = 2;
const F: usize = 3;

/// A unit word: SI per unit and dimensions.
fn atom(word: &str) -> Option<(f64, Dims)> {
    let len = |f: f64| (f, [1, 0, 0, 0]);
    let ang = |f: f64| (f, [0, 1, 0, 0]);
    let time = |f: f64| (f, [0, 0, 1, 0]);
    let force = |f: f64| (f, [0, 0, 0, 1]);
    Some(match word {
        "m" => len(1.0),
        "mm" => len(1e-3),
        "cm" => len(1e-2),
        "um" | "micron" => len(1e-6),
        "nm" => len(1e-9),
        "in" | "inch" => len(0.0254),
        "ft" => len(0.3048),
        "mil" => len(2.54e-5),
        "rad" => ang(1.0),
        "mrad" => ang(1e-3),
        "deg" | "°" => ang(PI / 180.0),
        "s" | "sec" => time(1.0),
        "ms" => time(1e-3),
        "min" => time(60.0),
        "g" | "gn" => (STANDARD_GRAVITY, [1, 0, -2, 0]),
        "n" => force(1.0),
        "kn" => force(1e3),
        "lbf" | "lb" | "lbs" => force(POUND_FORCE),
        "kgf" => force(STANDARD_GRAVITY),
        _ => return None,
    })
}

/// A unit expression read: SI factor, dimensions, and the factors of its force atoms and of the
/// lengths in its denominator (a moment's arm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UnitExpr {
    /// SI per file unit of the whole expression.
    pub(super) factor: f64,
    dims: Dims,
    force_factor: f64,
    arm_factor: f64,
}

/// Unit words with their net exponents.
type Atoms = Vec<(f64, Dims, i32)>;

struct Parser<'a> {
    toks: Vec<Tok<'a>>,
    pos: usize,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Tok<'a> {
    Word(&'a str),
    Num(i32),
    Mul,
    Div,
    Pow,
    Open,
    Close,
}

/// Lower-cases and spells out the symbols (`²` → `^2`, `·` → `*`, `μ` → `u`, `**` → `^`).
fn canonical(s: &str) -> String {
    let mut out = String::new();
    for c in s.trim().chars() {
        match c {
            '²' => out.push_str("^2"),
            '³' => out.push_str("^3"),
            '⁻' => out.push_str("^-"),
            '¹' => out.push('1'),
            '·' | '⋅' | '×' | '∙' => out.push('*'),
            'µ' | 'μ' => out.push('u'),
            c => out.extend(c.to_lowercase()),
        }
    }
    out.replace("**", "^").replace("^-^", "^-")
}

fn tokens(s: &str) -> Option<Vec<Tok<'_>>> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        match c {
            b' ' | b'\t' => {}
            b'*' | b'.' => out.push(Tok::Mul),
            b'/' => out.push(Tok::Div),
            b'^' => out.push(Tok::Pow),
            b'(' | b'[' => out.push(Tok::Open),
            b')' | b']' => out.push(Tok::Close),
            b'-' | b'+' | b'0'..=b'9' => {
                let start = i;
                i += 1;
                while i < b.len() && b[i].is_ascii_digit() {
                    i += 1;
                }
                out.push(Tok::Num(s[start..i].parse().ok()?));
                continue;
            }
            _ if c.is_ascii_alphabetic() || c >= 0x80 => {
                let start = i;
                while i < b.len() && (b[i].is_ascii_alphabetic() || b[i] >= 0x80) {
                    i += 1;
                }
                out.push(Tok::Word(&s[start..i]));
                continue;
            }
            _ => return None,
        }
        i += 1;
    }
    Some(out)
}

impl<'a> Parser<'a> {
    fn peek(&self) -> Option<Tok<'a>> {
        self.toks.get(self.pos).copied()
    }

    /// product := power (('*' | '/' | juxtaposition) power)*
    fn product(&mut self) -> Option<Atoms> {
        let mut acc = self.power()?;
        loop {
            let e = match self.peek() {
                Some(Tok::Mul) => {
                    self.pos += 1;
                    1
                }
                Some(Tok::Div) => {
                    self.pos += 1;
                    -1
                }
                Some(Tok::Word(_) | Tok::Open) => 1,
                _ => return Some(acc),
            };
            acc.extend(self.power()?.into_iter().map(|(f, d, x)| (f, d, x * e)));
        }
    }

    /// power := base ('^'? integer)?   (`s2` and `s^-2` alike)
    fn power(&mut self) -> Option<Atoms> {
        let base = match self.peek()? {
            Tok::Open => {
                self.pos += 1;
                let inner = self.product()?;
                (self.peek() == Some(Tok::Close)).then_some(())?;
                self.pos += 1;
                inner
            }
            Tok::Word(w) => {
                self.pos += 1;
                let (f, d) = atom(w)?;
                vec![(f, d, 1)]
            }
            Tok::Num(1) => {
                self.pos += 1;
                Vec::new()
            }
            _ => return None,
        };
        let e = match (self.peek(), self.toks.get(self.pos + 1).copied()) {
            (Some(Tok::Pow), Some(Tok::Num(n))) => {
                self.pos += 2;
                n
            }
            (Some(Tok::Num(n)), _) => {
                self.pos += 1;
                n
            }
            _ => 1,
        };
        if !(-4..=4).contains(&e) {
            return None;
        }
        Some(base.into_iter().map(|(f, d, x)| (f, d, x * e)).collect())
    }
}

/// Reads a unit expression; `None` when it is not one.
pub(super) fn parse_expr(label: &str) -> Option<UnitExpr> {
    let c = canonical(label);
    let toks = tokens(&c)?;
    if toks.is_empty() {
        return None;
    }
    let mut p = Parser { toks, pos: 0 };
    let atoms = p.product()?;
    if p.pos != p.toks.len() {
        return None;
    }
    let mut e = UnitExpr {
        factor: 1.0,
        dims: [0; 4],
        force_factor: 1.0,
        arm_factor: 1.0,
    };
    for (f, d, x) in atoms {
        e.factor *= f.powi(x);
        for (acc, dk) in e.dims.iter_mut().zip(d) {
            *acc += dk * x;
        }
        if d[F] != 0 {
            e.force_factor *= f.powi(-x);
        } else if d == [1, 0, 0, 0] && x < 0 {
            e.arm_factor *= f.powi(-x);
        }
    }
    Some(e)
}

impl UnitExpr {
    /// The motion (`m`, `rad/s`, `g`) over force or moment the expression is, if it is one.
    pub(super) fn as_frf(&self) -> Option<(MotionUnit, Option<ForceUnit>)> {
        let d = self.dims;
        let kind = match d[T] {
            0 => Motion::Displacement,
            -1 => Motion::Velocity,
            -2 => Motion::Acceleration,
            _ => return None,
        };
        let (rotational, force) = match (d[A], d[L], d[F]) {
            (1, 0, 0) => (true, None),
            (0, 1, 0) => (false, None),
            (1, 0, -1) => (true, Some(false)),
            (1, -1, -1) => (true, Some(true)),
            (0, 1, -1) => (false, Some(false)),
            (0, 0, -1) => (false, Some(true)),
            _ => return None,
        };
        // SI per file unit of the denominator: its force, times the arm of a moment.
        let ff = match force {
            None => 1.0,
            Some(false) => self.force_factor,
            Some(true) => self.force_factor * self.arm_factor,
        };
        let motion = MotionUnit {
            kind,
            rotational,
            factor: self.factor * ff,
        };
        Some((motion, force.map(|moment| ForceUnit { moment, factor: ff })))
    }

    /// The force or moment the expression is, if it is one.
    pub(super) fn as_force(&self) -> Option<ForceUnit> {
        match self.dims {
            [0, 0, 0, 1] => Some(ForceUnit {
                moment: false,
                factor: self.factor,
            }),
            [1, 0, 0, 1] => Some(ForceUnit {
                moment: true,
                factor: self.factor,
            }),
            _ => None,
        }
    }

    /// The expression in SI words, e.g. `m/s^2/N`, for the record of what was read.
    pub(super) fn describe(&self) -> String {
        if let Some((m, f)) = self.as_frf() {
            let base = if m.rotational { "rad" } else { "m" };
            let num = match m.kind {
                Motion::Displacement => base.to_string(),
                Motion::Velocity => format!("{base}/s"),
                Motion::Acceleration => format!("{base}/s^2"),
            };
            return match f {
                None => num,
                Some(f) if f.moment => format!("{num}/(N*m)"),
                Some(_) => format!("{num}/N"),
            };
        }
        match self.as_force() {
            Some(f) if f.moment => "N*m".into(),
            Some(_) => "N".into(),
            None => "not a motion or force unit".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frf(label: &str) -> (Motion, bool, f64, Option<(bool, f64)>) {
        let e = parse_expr(label).unwrap_or_else(|| panic!("{label}"));
        let (m, f) = e.as_frf().unwrap_or_else(|| panic!("{label}: {e:?}"));
        (
            m.kind,
            m.rotational,
            m.factor,
            f.map(|f| (f.moment, f.factor)),
        )
    }

    #[test]
    fn lab_spellings_of_accelerance_read_alike() {
        for l in [
            "(1/N)*(m/s²)",
            "m/s^2/N",
            "(m/s2)/N",
            "m/(s^2 N)",
            "m/(s^2*N)",
            "m·s⁻²/N",
            "m s^-2 N^-1",
            "(m/s**2)/N",
            "m/(N s²)",
        ] {
            assert_eq!(
                frf(l),
                (Motion::Acceleration, false, 1.0, Some((false, 1.0))),
                "{l}"
            );
        }
        let (k, rot, f, force) = frf("g/N");
        assert_eq!(
            (k, rot, force),
            (Motion::Acceleration, false, Some((false, 1.0)))
        );
        assert!((f - STANDARD_GRAVITY).abs() < 1e-15);
        let (k, _, f, force) = frf("μm/(lbf)");
        assert_eq!(k, Motion::Displacement);
        assert!((f - 1e-6).abs() < 1e-21);
        assert!((force.unwrap().1 - POUND_FORCE).abs() < 1e-12);
        let (k, rot, _, force) = frf("rad/s/(N·m)");
        assert_eq!((k, rot, force), (Motion::Velocity, true, Some((true, 1.0))));
        let (k, _, f, force) = frf("(mm/s)/(N*mm)");
        assert_eq!(k, Motion::Velocity);
        assert!((f - 1e-3).abs() < 1e-18);
        assert_eq!(force, Some((true, 1e-3)));
    }

    #[test]
    fn forces_and_nonsense() {
        assert_eq!(
            parse_expr("kN").unwrap().as_force().map(|f| f.factor),
            Some(1e3)
        );
        assert!(parse_expr("N·m").unwrap().as_force().unwrap().moment);
        for bad in ["", "m/s^2/", "furlong/N", "m/s^9/N", "(m/s", "m/s^2/N)"] {
            assert!(parse_expr(bad).and_then(|e| e.as_frf()).is_none(), "{bad}");
        }
        assert!(parse_expr("m/s^3/N").unwrap().as_frf().is_none());
    }
}
