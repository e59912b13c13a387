//! PBARL and PBEAML: cross-sections of Nastran's beam library by their dimensions.
//!
//! BAR, ROD, TUBE and TUBE2 become femu's own rectangle, circle and tube sections (so that their
//! dimensions stay updating parameters); every other type becomes a general section with the
//! properties of [`crate::model::sections`]. A section whose product of inertia is not zero (L,
//! Z, BOX1 with unequal walls) is turned to its principal axes: the property holds the principal
//! values and every element using it has its orientation vector turned by the same angle about
//! its axis (the stiffness is that of Nastran's bar with `I12`, which ignores K1/K2 then).
//!
//! A PBEAML's element axis is the section's shear centre (QRG PBEAML remarks 7 and 12): a
//! section that is not doubly or point symmetric (T, T1, T2, L, CHAN, CHAN1, CHAN2, HAT, I with
//! unequal flanges, BOX1 with unequal opposite walls) gets its centroid's offset from the shear
//! centre ([`crate::model::sections::neutral_axis_offset`], turned with the section), as the
//! equivalent PBEAM's N1, N2. A PBARL keeps both on the axis, as Nastran's CBAR does (QRG PBARL
//! remark 8: "the PBARL does not account for offsets between the neutral axis and the shear
//! center").

use super::*;
use crate::model::sections::{self as lib, SectionError, SectionValues};

/// Library types read, with their number of dimensions.
const TYPES: [(&str, usize); 19] = [
    ("BAR", 2),
    ("ROD", 1),
    ("TUBE", 2),
    ("TUBE2", 2),
    ("I", 6),
    ("I1", 4),
    ("T", 4),
    ("T1", 4),
    ("T2", 4),
    ("L", 4),
    ("CHAN", 4),
    ("CHAN1", 4),
    ("CHAN2", 4),
    ("BOX", 4),
    ("BOX1", 6),
    ("H", 4),
    ("CROSS", 4),
    ("Z", 4),
    ("HAT", 4),
];

/// The number of dimensions of a library type femu reads.
pub(super) fn dim_count(kind: &str) -> Option<usize> {
    TYPES.iter().find(|(k, _)| *k == kind).map(|(_, n)| *n)
}

fn type_list() -> String {
    TYPES.iter().map(|(k, _)| *k).collect::<Vec<_>>().join(", ")
}

/// Reads GROUP (field 3) and TYPE (field 4) of a PBARL/PBEAML; the type and its dimension count.
pub(super) fn library_type(c: &Card) -> Result<(String, usize), NastranError> {
    let group = c.word(3);
    if !(group.is_empty() || group == "MSCBML0") {
        return Err(c.err(
            3,
            "GROUP",
            format!("cross-section library `{}` is not supported", q(&group)),
            "leave GROUP blank or MSCBML0",
        ));
    }
    let kind = c.word(4);
    if kind.is_empty() {
        return Err(c.err(
            4,
            "TYPE",
            "the field is blank",
            format!("a section type: {}", type_list()),
        ));
    }
    let Some(n) = dim_count(&kind) else {
        return Err(c.err(
            4,
            "TYPE",
            format!("section type `{}` is not supported", q(&kind)),
            format!("{} (or give the properties on a PBAR/PBEAM)", type_list()),
        ));
    };
    Ok((kind, n))
}

/// The section of library type `kind` with dimensions `d` (data fields `k`, `k+1`, … of `c`),
/// and the angle (rad) by which the elements' orientation turns to the principal axes.
pub(super) fn library_section(
    c: &Card,
    kind: &str,
    k: usize,
    d: &[f64],
) -> Result<(BeamSection, f64), NastranError> {
    let bad = |e: SectionError| {
        c.err(
            k,
            "DIM1",
            format!(
                "the {kind} dimensions {d:?} do not describe the section: {}",
                e.what
            ),
            format!("dimensions of the {kind} section as the QRG's PBARL figure draws them"),
        )
    };
    let values: SectionValues = match kind {
        "BAR" => {
            return Ok((
                BeamSection::Rectangle {
                    width: d[0],
                    height: d[1],
                },
                0.0,
            ));
        }
        "ROD" => return Ok((BeamSection::Circle { radius: d[0] }, 0.0)),
        "TUBE" | "TUBE2" => {
            let inner = if kind == "TUBE" { d[1] } else { d[0] - d[1] };
            if !(0.0..d[0]).contains(&inner) {
                return Err(c.err(
                    k + 1,
                    "DIM2",
                    format!("inner radius {inner} is not in [0, outer radius {})", d[0]),
                    if kind == "TUBE" {
                        "0 <= DIM2 < DIM1"
                    } else {
                        "0 < DIM2 (wall thickness) <= DIM1"
                    },
                ));
            }
            return Ok((
                BeamSection::Tube {
                    outer_radius: d[0],
                    inner_radius: inner,
                },
                0.0,
            ));
        }
        _ => lib::library_values(kind, d).unwrap_or_else(|| {
            Err(SectionError {
                what: format!("type {kind} is not in femu's library"),
            })
        }),
    }
    .map_err(bad)?;
    let (p, theta) = lib::principal(&values);
    Ok((
        BeamSection::General {
            area: p.area,
            iy: p.i2,
            iz: p.i1,
            j: p.j,
            shear_y: p.k1,
            shear_z: p.k2,
        },
        theta,
    ))
}

/// The offset `(y, z)` of a library section's centroid from its shear centre in the element
/// axes after the principal turn `theta` (`y' = cos θ y + sin θ z`, `z' = −sin θ y + cos θ z`,
/// the turn of [`lib::principal`]): where Nastran's CBEAM puts the neutral axis of a PBEAML
/// (its element axis is the shear centre, QRG PBEAML remarks 7 and 12).
pub(super) fn neutral_axis(kind: &str, d: &[f64], theta: f64) -> [f64; 2] {
    let [y, z] = lib::neutral_axis_offset(kind, d);
    if theta == 0.0 {
        return [y, z];
    }
    let (s, c) = theta.sin_cos();
    [c * y + s * z, -s * y + c * z]
}

/// The dimensions and NSM of a PBARL (DIM1 at data field 9, NSM after the last).
fn pbarl_values(c: &Card, n: usize) -> Result<(Vec<f64>, f64), NastranError> {
    let mut d = Vec::with_capacity(n);
    for i in 0..n {
        d.push(c.positive(9 + i, &format!("DIM{}", i + 1))?);
    }
    Ok((d, c.nonneg_real(9 + n, "NSM", 0.0)?))
}

impl Builder {
    pub(super) fn pbarl(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let (kind, n) = library_type(c)?;
        let (d, nsm) = pbarl_values(c, n)?;
        for k in 10 + n..=c.fields.len() {
            if !c.blank(k) {
                return Err(c.err(
                    k,
                    "?",
                    format!("`{}` follows NSM", q(c.text(k))),
                    format!("a {kind} section has {n} dimensions and then NSM"),
                ));
            }
        }
        let (section, theta) = library_section(c, &kind, 9, &d)?;
        self.new_property(c, 1, "PID", id)?;
        if theta != 0.0 {
            self.beam_turns.insert(id, theta);
        }
        self.beams.insert(
            id,
            BeamProperty {
                material,
                section,
                nsm,
                taper: None,
                centres: None,
            },
        );
        Ok(())
    }

    /// PBEAML: the end-A section and the stations (SO, X/XB, DIMi, NSM) after it. The QRG's
    /// reading: X/XB blank is 1.0 (end B), which must be the last station; blank end-B values
    /// are end A's, blank intermediate ones linear between end A and end B. The dimensions vary
    /// linearly between stations (see `crate::fe::beam_tapered`).
    pub(super) fn pbeaml(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let (kind, n) = library_type(c)?;
        let (d, nsm) = pbarl_values(c, n)?;
        // (first field, X/XB, DIMs and NSM as given) per station.
        let mut given: Vec<(usize, f64, Vec<Option<f64>>)> = Vec::new();
        let mut k = 10 + n;
        while k <= c.fields.len() {
            if (k..k + n + 3).all(|j| c.blank(j)) {
                k += n + 3;
                continue;
            }
            let so = c.word(k);
            if !(so.is_empty() || matches!(so.as_str(), "YES" | "YESA" | "NO")) {
                return Err(c.err(
                    k,
                    "SO",
                    format!("`{}` is not a stress output flag", q(&so)),
                    "YES, YESA or NO",
                ));
            }
            let x = c.real_or(k + 1, "X/XB", 1.0)?;
            let mut v = Vec::with_capacity(n + 1);
            for i in 0..=n {
                let label = if i < n {
                    format!("DIM{}", i + 1)
                } else {
                    "NSM".to_string()
                };
                v.push(c.real(k + 2 + i, &label)?);
            }
            given.push((k, x, v));
            k += n + 3;
        }
        let (section, theta) = library_section(c, &kind, 9, &d)?;
        let offset_a = neutral_axis(&kind, &d, theta);
        let end_a: Vec<f64> = d.iter().copied().chain([nsm]).collect();
        let mut stations = vec![BeamStation {
            x: 0.0,
            values: d.clone(),
            nsm,
        }];
        if let Some((kb, xb, vb)) = given.last() {
            if *xb != 1.0 {
                return Err(c.err(
                    kb + 1,
                    "X/XB",
                    format!("the last station is at X/XB = {xb}"),
                    "the last station is end B: X/XB = 1.0 (blank)",
                ));
            }
            let end_b: Vec<f64> = vb
                .iter()
                .zip(&end_a)
                .map(|(v, a)| v.unwrap_or(*a))
                .collect();
            let mut previous = 0.0;
            for (k0, x, v) in &given {
                let x = *x;
                super::properties::next_station(c, *k0, x, &mut previous)?;
                let values: Vec<f64> = (0..=n)
                    .map(|i| super::properties::station_value(v[i], x, end_a[i], end_b[i]))
                    .collect();
                for (i, value) in values.iter().enumerate() {
                    let ok = if i < n { *value > 0.0 } else { *value >= 0.0 };
                    if !(ok && value.is_finite()) {
                        let label = if i < n {
                            format!("DIM{}", i + 1)
                        } else {
                            "NSM".to_string()
                        };
                        return Err(c.err(
                            k0 + 2 + i,
                            &label,
                            format!("{label} = {value} at station X/XB = {x}"),
                            if i < n {
                                "a real number > 0"
                            } else {
                                "a real number >= 0"
                            },
                        ));
                    }
                }
                let dims = &values[..n];
                let (_, theta) = library_section(c, &kind, k0 + 2, dims)?;
                let offset = neutral_axis(&kind, dims, theta);
                let size = dims.iter().fold(0.0f64, |m, v| m.max(*v));
                if (0..2).any(|i| (offset[i] - offset_a[i]).abs() > 1e-9 * size) {
                    return Err(c.err(
                        k0 + 2,
                        "DIM1",
                        format!("the {kind} section at X/XB = {x} (dimensions {dims:?}) has its centroid at {offset:?} from its shear centre, end A's at {offset_a:?}"),
                        "a tapered PBEAML whose centroid keeps its offset from the shear centre (femu's beam holds the offset constant along the element): a doubly symmetric section, or stations that keep the offset",
                    ));
                }
                if theta != 0.0 {
                    return Err(c.err(
                        k0 + 2,
                        "DIM1",
                        format!("the {kind} section at X/XB = {x} has a product of inertia (principal axes turned by {theta} rad)"),
                        "a tapered PBEAML of a section with I12 = 0 (a tapered Z or unequal BOX1 is not supported)",
                    ));
                }
                stations.push(BeamStation {
                    x,
                    values: dims.to_vec(),
                    nsm: values[n],
                });
            }
        }
        let taper = super::properties::uniform_or(stations, Some(kind.clone()));
        self.new_property(c, 1, "PID", id)?;
        if theta != 0.0 && taper.is_some() {
            return Err(c.err(
                9,
                "DIM1",
                format!("the tapered {kind} section at end A has a product of inertia (principal axes turned by {theta} rad)"),
                "a tapered PBEAML of a section with I12 = 0 (a tapered Z or unequal BOX1 is not supported)",
            ));
        }
        if theta != 0.0 {
            self.beam_turns.insert(id, theta);
        }
        self.beams.insert(
            id,
            BeamProperty {
                material,
                section,
                nsm,
                taper,
                centres: BeamCentres {
                    neutral_axis: offset_a,
                    ..BeamCentres::default()
                }
                .nonzero(),
            },
        );
        Ok(())
    }
}

/// The orientation vector of a beam (axis from `axis[0]` to `axis[1]`) whose section was
/// turned by `turn` rad to its principal axes: the element's `y` axis turned about `x` towards
/// `z`, `y' = cos θ y + sin θ z` (with `z = x × v / |x × v|`, `y = z × x`), which lies in the
/// new `x–y` plane; `v` itself when `turn` is 0.
pub(super) fn turned_orientation(axis: [[f64; 3]; 2], v: [f64; 3], turn: f64) -> [f64; 3] {
    if turn == 0.0 {
        return v;
    }
    let x = unit(sub(axis[1], axis[0]));
    let z = unit(cross(x, v));
    let y = cross(z, x);
    let (s, c) = turn.sin_cos();
    [
        c * y[0] + s * z[0],
        c * y[1] + s * z[1],
        c * y[2] + s * z[2],
    ]
}

/// `v / |v|`.
pub(super) fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = norm(v);
    [v[0] / n, v[1] / n, v[2] / n]
}
