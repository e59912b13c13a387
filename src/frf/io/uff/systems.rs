//! Coordinate systems: datasets 18 (origin, a point on +x, a point in the +xz plane, in a
//! reference system) and 2420 (a 4×3 transformation: rows 1–3 the local axes, row 4 the origin,
//! in global components), and node coordinates in their definition system brought to global.
//!
//! A point `p` given in system `S` (origin `o`, axes `e₁ e₂ e₃` as rows) is, in global,
//! `o + Σᵢ cᵢ eᵢ` with `c = p` for a Cartesian system, `c = (r cos θ, r sin θ, z)` for a
//! cylindrical one `(r, θ, z)`, and `c = (r sin θ cos φ, r sin θ sin φ, r cos θ)` for a
//! spherical one `(r, θ, φ)` (θ from the local z axis, φ about it from the local x axis);
//! angles in degrees, as I-DEAS writes them.

use super::block::{Block, Ctx};
use super::lex::{At, fields, text};
use super::mesh::length_conversion;
use super::types::{CoordKind, UffCoordSystem};
use super::{UffError, UffFile};

/// A dataset 18 system before its reference system is known: the three points as written.
pub(super) struct Pending18 {
    pub(super) id: u32,
    pub(super) kind: CoordKind,
    pub(super) reference: u32,
    pub(super) name: String,
    pub(super) points: [[f64; 3]; 3],
    pub(super) line: usize,
    /// Line of record 3 (the origin and the +x point).
    pub(super) points_line: usize,
}

fn kind_of(at: &At<'_>, s: &str, field: &str) -> Result<CoordKind, UffError> {
    match at.small(s, field)? {
        0 => Ok(CoordKind::Cartesian),
        1 => Ok(CoordKind::Cylindrical),
        2 => Ok(CoordKind::Spherical),
        k => Err(at.err(field, k, "0 (Cartesian), 1 (cylindrical) or 2 (spherical)")),
    }
}

/// Non-blank lines of a dataset.
fn lines_of<'a>(b: &Block<'a>) -> Vec<(usize, &'a [u8])> {
    b.lines
        .iter()
        .copied()
        .filter(|(_, raw)| !raw.trim_ascii().is_empty())
        .collect()
}

fn take<'a>(
    lines: &[(usize, &'a [u8])],
    i: &mut usize,
    at: &At<'_>,
    what: &str,
    end: usize,
) -> Result<(usize, &'a [u8]), UffError> {
    let l = lines.get(*i).copied().ok_or_else(|| {
        At { line: end, ..*at }.err(
            what.to_string(),
            "the closing `    -1`",
            "the rest of the coordinate system",
        )
    })?;
    *i += 1;
    Ok(l)
}

fn reals(at: &At<'_>, raw: &[u8], widths: &[usize], first: usize) -> Result<Vec<f64>, UffError> {
    fields(raw, widths)
        .iter()
        .enumerate()
        .map(|(k, s)| at.real_or_zero(s, &format!("field {}", first + k)))
        .collect()
}

/// Dataset 18: per system Format(5I10) (label, type, reference system, colour, method),
/// Format(20A2) (name), Format(1P6E13.5) (origin, point on +x), Format(1P3E13.5) (point in
/// the +xz plane), all in the reference system; lengths converted by dataset 164.
pub(super) fn parse_18(
    b: &Block<'_>,
    ctx: &mut Ctx<'_>,
    pending: &mut Vec<Pending18>,
) -> Result<(), UffError> {
    let lines = lines_of(b);
    let scale = length_conversion(ctx).map_or(1.0, |(f, _)| f);
    let mut i = 0;
    while i < lines.len() {
        let (no, raw) = lines[i];
        i += 1;
        let at1 = At {
            file: ctx.file,
            line: no,
            dataset: 18,
            record: "record 1",
        };
        let f = fields(raw, &[10; 5]);
        let id = at1.small(&f[0], "field 1 (coordinate system label)")?;
        let kind = kind_of(&at1, &f[1], "field 2 (coordinate system type)")?;
        let reference = at1.small(&f[2], "field 3 (reference coordinate system)")?;
        let method = at1.small(&f[4], "field 5 (method of definition)")?;
        if method > 1 {
            return Err(at1.err(
                "field 5 (method of definition)",
                method,
                "1 (origin, point on +x axis, point in the +xz plane)",
            ));
        }
        let (_, name_raw) = take(&lines, &mut i, &at1, "record 2 (name)", b.end)?;
        let (l3, r3) = take(
            &lines,
            &mut i,
            &at1,
            "record 3 (origin and +x point)",
            b.end,
        )?;
        let at3 = At {
            line: l3,
            record: "record 3",
            ..at1
        };
        let v3 = reals(&at3, r3, &[13; 6], 1)?;
        let (l4, r4) = take(&lines, &mut i, &at1, "record 4 (+xz plane point)", b.end)?;
        let at4 = At {
            line: l4,
            record: "record 4",
            ..at1
        };
        let v4 = reals(&at4, r4, &[13; 3], 1)?;
        let s = |p: [f64; 3]| p.map(|x| x * scale);
        pending.push(Pending18 {
            id,
            kind,
            reference,
            name: text(name_raw).trim().to_string(),
            points: [
                s([v3[0], v3[1], v3[2]]),
                s([v3[3], v3[4], v3[5]]),
                s([v4[0], v4[1], v4[2]]),
            ],
            line: no,
            points_line: l3,
        });
    }
    Ok(())
}

/// Dataset 2420: Format(I10) part UID, Format(40A2) part name, then per system Format(3I10)
/// (label, type, colour), Format(40A2) (name) and four Format(1P3D25.16) rows of the
/// transformation (axes, then origin), in global components.
pub(super) fn parse_2420(
    b: &Block<'_>,
    ctx: &mut Ctx<'_>,
    out: &mut UffFile,
) -> Result<(), UffError> {
    let lines = lines_of(b);
    let scale = length_conversion(ctx).map_or(1.0, |(f, _)| f);
    let at0 = At {
        file: ctx.file,
        line: b.header_line,
        dataset: 2420,
        record: "record 1",
    };
    let mut i = 0;
    take(&lines, &mut i, &at0, "record 1 (part UID)", b.end)?;
    // The part name may be blank, and then it was skipped with the blank lines.
    if lines.get(i).is_some_and(|(_, r)| {
        fields(r, &[10, 10, 10])
            .iter()
            .any(|s| s.trim().parse::<u32>().is_err())
    }) {
        i += 1;
    }
    while i < lines.len() {
        let (no, raw) = lines[i];
        i += 1;
        let at3 = At {
            line: no,
            record: "record 3",
            ..at0
        };
        let f = fields(raw, &[10, 10, 10]);
        let id = at3.small(&f[0], "field 1 (coordinate system label)")?;
        let kind = kind_of(&at3, &f[1], "field 2 (coordinate system type)")?;
        let (_, name_raw) = take(&lines, &mut i, &at3, "record 4 (name)", b.end)?;
        let mut rows = [[0.0; 3]; 4];
        for (k, row) in rows.iter_mut().enumerate() {
            const REC: [&str; 4] = ["record 5", "record 6", "record 7", "record 8"];
            let (l, r) = take(&lines, &mut i, &at3, REC[k], b.end)?;
            let at = At {
                line: l,
                record: REC[k],
                ..at0
            };
            let v = reals(&at, r, &[25; 3], 1)?;
            *row = [v[0], v[1], v[2]];
        }
        let axes = [rows[0], rows[1], rows[2]];
        check_axes(&At { line: no, ..at3 }, &axes)?;
        let sys = UffCoordSystem {
            id,
            kind,
            name: text(name_raw).trim().to_string(),
            axes,
            origin: rows[3].map(|x| x * scale),
            dataset: 2420,
            line: no,
        };
        add_system(ctx, out, sys)?;
    }
    Ok(())
}

fn add_system(ctx: &Ctx<'_>, out: &mut UffFile, sys: UffCoordSystem) -> Result<(), UffError> {
    if sys.id == 0 {
        return Err(At {
            file: ctx.file,
            line: sys.line,
            dataset: sys.dataset,
            record: if sys.dataset == 18 {
                "record 1"
            } else {
                "record 3"
            },
        }
        .err(
            "field 1 (coordinate system label)",
            0,
            "a label >= 1 (0 is the global system)",
        ));
    }
    if let Some(first) = out.coordinate_systems.iter().find(|c| c.id == sys.id) {
        return Err(At {
            file: ctx.file,
            line: sys.line,
            dataset: sys.dataset,
            record: "record 1",
        }
        .err(
            "field 1 (coordinate system label)",
            sys.id,
            format!("a label not defined before (it is at line {})", first.line),
        ));
    }
    out.coordinate_systems.push(sys);
    Ok(())
}

/// Refuses axes that are not orthonormal (to 1e-6).
fn check_axes(at: &At<'_>, axes: &[[f64; 3]; 3]) -> Result<(), UffError> {
    for a in 0..3 {
        for b in 0..3 {
            let d: f64 = (0..3).map(|k| axes[a][k] * axes[b][k]).sum();
            let want = if a == b { 1.0 } else { 0.0 };
            if (d - want).abs() > 1e-6 {
                return Err(at.err(
                    "records 5-7 (transformation rows)",
                    format!("{axes:?}"),
                    "orthonormal rows (the local axes in global components)",
                ));
            }
        }
    }
    Ok(())
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (n > 0.0 && n.is_finite()).then(|| a.map(|x| x / n))
}

impl UffCoordSystem {
    /// A point given in this system, in global coordinates.
    pub fn to_global(&self, p: [f64; 3]) -> [f64; 3] {
        let (d, r) = (std::f64::consts::PI / 180.0, p[0]);
        let c = match self.kind {
            CoordKind::Cartesian => p,
            CoordKind::Cylindrical => [r * (p[1] * d).cos(), r * (p[1] * d).sin(), p[2]],
            CoordKind::Spherical => {
                let (t, f) = (p[1] * d, p[2] * d);
                [r * t.sin() * f.cos(), r * t.sin() * f.sin(), r * t.cos()]
            }
        };
        let mut g = self.origin;
        for (i, e) in self.axes.iter().enumerate() {
            for k in 0..3 {
                g[k] += c[i] * e[k];
            }
        }
        g
    }
}

/// Resolves the dataset 18 systems (each against its reference, in any order).
pub(super) fn resolve_18(
    ctx: &Ctx<'_>,
    out: &mut UffFile,
    mut pending: Vec<Pending18>,
) -> Result<(), UffError> {
    while !pending.is_empty() {
        let before = pending.len();
        let mut k = 0;
        while k < pending.len() {
            let p = &pending[k];
            let reference = if p.reference == 0 {
                None
            } else {
                match out.coordinate_systems.iter().find(|c| c.id == p.reference) {
                    Some(c) => Some(c.clone()),
                    None => {
                        k += 1;
                        continue;
                    }
                }
            };
            let g = |q: [f64; 3]| reference.as_ref().map_or(q, |c| c.to_global(q));
            let [o, a, b] = p.points.map(g);
            let at = At {
                file: ctx.file,
                line: p.points_line,
                dataset: 18,
                record: "record 3",
            };
            let ex = unit(sub(a, o));
            let ey = ex.and_then(|ex| unit(cross(sub(b, o), ex)));
            let (Some(ex), Some(ey)) = (ex, ey) else {
                return Err(at.err(
                    "fields 1-6 and record 4",
                    format!("origin {o:?}, +x point {a:?}, +xz point {b:?}"),
                    "three points that are not on one line",
                ));
            };
            let sys = UffCoordSystem {
                id: p.id,
                kind: p.kind,
                name: p.name.clone(),
                axes: [ex, ey, cross(ex, ey)],
                origin: o,
                dataset: 18,
                line: p.line,
            };
            add_system(ctx, out, sys)?;
            pending.remove(k);
        }
        if pending.len() == before {
            let p = &pending[0];
            return Err(At { file: ctx.file, line: p.line, dataset: 18, record: "record 1" }.err(
                "field 3 (reference coordinate system)",
                p.reference,
                "0 (global) or a coordinate system defined in the file (datasets 18, 2420), without cycles",
            ));
        }
    }
    Ok(())
}

/// Brings the node coordinates given in a definition system (other than 0) to global, and
/// records what was done; each node keeps its displacement system in `node_systems`.
pub(super) fn nodes_to_global(ctx: &mut Ctx<'_>, out: &mut UffFile) -> Result<(), UffError> {
    use std::collections::BTreeMap;
    let mut moved: BTreeMap<u32, usize> = BTreeMap::new();
    // Systems named by nodes but not defined: (definition or displacement, system) → count.
    let mut undefined: BTreeMap<(&str, u32), usize> = BTreeMap::new();
    for (k, (_, xyz)) in out.nodes.iter_mut().enumerate() {
        let [def, disp, _] = out.node_systems[k];
        let find = |s: u32| out.coordinate_systems.iter().find(|c| c.id == s);
        if disp != 0 && find(disp).is_none() {
            *undefined.entry(("displacement", disp)).or_default() += 1;
        }
        if def == 0 {
            continue;
        }
        let Some(sys) = find(def) else {
            *undefined.entry(("definition", def)).or_default() += 1;
            continue;
        };
        let mut p = *xyz;
        if sys.kind != CoordKind::Cartesian {
            // Angles are not lengths: undo the dataset 164 length factor applied on reading.
            let f = ctx.node_scale.get(k).copied().unwrap_or(1.0);
            p[1] /= f;
            if sys.kind == CoordKind::Spherical {
                p[2] /= f;
            }
        }
        *xyz = sys.to_global(p);
        *moved.entry(def).or_default() += 1;
    }
    for ((which, s), count) in undefined {
        ctx.warn(format!(
            "{}: {count} node(s) name {which} coordinate system {s}, which no dataset 18 or 2420 of the file defines: taken as the global system",
            ctx.file
        ));
    }
    for (s, count) in moved {
        let sys = out.coordinate_systems.iter().find(|c| c.id == s);
        let (kind, line, dataset) = sys.map_or((CoordKind::Cartesian, 0, 0), |c| {
            (c.kind, c.line, c.dataset)
        });
        out.conversions.push(format!(
            "{}: coordinates of {count} node(s) in definition system {s} ({}, dataset {dataset} at line {line}) transformed to global{}",
            ctx.file,
            kind.name(),
            if kind == CoordKind::Cartesian { "" } else { " (angles in degrees)" }
        ));
    }
    // One warning for every node off the global axes, naming the nodes by system.
    let mut nodes_by_system: std::collections::BTreeMap<u32, Vec<u64>> = Default::default();
    for ((id, _), systems) in out.nodes.iter().zip(&out.node_systems) {
        let s = systems[1];
        if s != 0 && out.coordinate_systems.iter().any(|c| c.id == s) {
            nodes_by_system.entry(s).or_default().push(*id);
        }
    }
    let by_system: Vec<String> = nodes_by_system
        .iter()
        .map(|(s, nodes)| {
            let noun = if nodes.len() == 1 { "node" } else { "nodes" };
            format!(
                "system {s}: {noun} {}",
                crate::core::first_of(nodes.iter(), 5)
            )
        })
        .collect();
    if !by_system.is_empty() {
        ctx.warn(format!(
            "{}: nodes measure in displacement systems other than the global one ({}): the directions of their DOFs (in datasets 58 and 55) are those systems' axes, not global; see coordinate_systems",
            ctx.file,
            by_system.join("; ")
        ));
    }
    Ok(())
}

impl UffCoordSystem {
    /// The unit directions (rows, in global components) that DOFs 1–3 of a node at global
    /// position `p` measure along when this is its displacement system: the system's axes for a
    /// Cartesian one; radial, tangential, axial at `p` for a cylindrical one; `e_r`, `e_θ`,
    /// `e_φ` at `p` for a spherical one (at the origin, or on the axis, the directions of
    /// `θ = 0`, `φ = 0` where undefined).
    pub fn directions_at(&self, p: [f64; 3]) -> [[f64; 3]; 3] {
        let q = sub(p, self.origin);
        let c: Vec<f64> = self
            .axes
            .iter()
            .map(|e| e[0] * q[0] + e[1] * q[1] + e[2] * q[2])
            .collect();
        let local: [[f64; 3]; 3] = match self.kind {
            CoordKind::Cartesian => return self.axes,
            CoordKind::Cylindrical => {
                let t = c[1].atan2(c[0]);
                let (s, k) = t.sin_cos();
                [[k, s, 0.0], [-s, k, 0.0], [0.0, 0.0, 1.0]]
            }
            CoordKind::Spherical => {
                let t = (c[0] * c[0] + c[1] * c[1]).sqrt().atan2(c[2]);
                let f = c[1].atan2(c[0]);
                let ((st, ct), (sf, cf)) = (t.sin_cos(), f.sin_cos());
                [
                    [st * cf, st * sf, ct],
                    [ct * cf, ct * sf, -st],
                    [-sf, cf, 0.0],
                ]
            }
        };
        local.map(|l| {
            let mut g = [0.0; 3];
            for (i, e) in self.axes.iter().enumerate() {
                for k in 0..3 {
                    g[k] += l[i] * e[k];
                }
            }
            g
        })
    }
}

#[cfg(test)]
mod direction_tests {
    use super::*;

    /// A cylindrical system about global z shifted to (1, 0, 0): at (1, 2, 5) the radial
    /// direction is +y, the tangential −x.
    #[test]
    fn directions_follow_the_point() {
        let sys = UffCoordSystem {
            id: 3,
            kind: CoordKind::Cylindrical,
            name: String::new(),
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            origin: [1.0, 0.0, 0.0],
            dataset: 2420,
            line: 1,
        };
        let d = sys.directions_at([1.0, 2.0, 5.0]);
        let near = |a: [f64; 3], b: [f64; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-15);
        assert!(
            near(d[0], [0.0, 1.0, 0.0]) && near(d[1], [-1.0, 0.0, 0.0]),
            "{d:?}"
        );
        let sph = UffCoordSystem {
            kind: CoordKind::Spherical,
            origin: [0.0; 3],
            ..sys.clone()
        };
        let d = sph.directions_at([0.0, 0.0, 2.0]);
        assert!(
            near(d[0], [0.0, 0.0, 1.0]) && near(d[1], [1.0, 0.0, 0.0]),
            "{d:?}"
        );
        let cart = UffCoordSystem {
            kind: CoordKind::Cartesian,
            ..sys
        };
        assert_eq!(cart.directions_at([9.0, 9.0, 9.0]), cart.axes);
    }
}
