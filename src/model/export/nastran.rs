//! Nastran bulk data export: writes a [`Model`] as a deck that
//! [`crate::model::import::nastran::parse_bulk`] reads back to the same model.
//!
//! Cards written, in this order, each group by ascending id: MAT1, MAT9, PSHELL, PBAR (general
//! sections) and PBARL (BAR, ROD, TUBE), or for a tapered property PBEAM (general) or PBEAML
//! (library type) with every station (SO = NO), PROD (PTUBE for a tapered tube), PSOLID (each with material axes preceded by a
//! CORD2R of a fresh id holding them, named in CORDM), PBUSH (one per bush, ids above every
//! property id; a B line when the bush damps), PVISC (one per viscous damper, ids after the
//! PBUSHes), CORD2R (one per bush with an element system), CORD2R (one per distinct
//! displacement system), GRID (basic coordinates, CD), SPOINT (scalar points), CQUAD4, CTRIA3,
//! CHEXA, CPENTA, CTETRA, CPYRAM, CBAR (orientation X1–X3; CBEAM, same fields, for a tapered
//! property), CROD (a rod with a property; CTUBE for a tapered tube) or CONROD (a rod with its own section), CBUSH (CID 0, or its CORD2R), CELAS2,
//! CMASS2, CDAMP2, CVISC, CONM1 (CID 0), CONM2 (CID 0), SPC1
//! (SID 1, one card per component list), MPC (SID 1, one card per multipoint constraint
//! `u_d = Σ cᵢ uᵢ` as `1·u_d − Σ cᵢ uᵢ = 0`, preceded by a comment naming the card it came
//! from; re-read, its origin becomes `MPC 1`), SET1, between `BEGIN BULK` and `ENDDATA`.
//!
//! PSHELL: MID1 blank for a shell without membrane, MID2 and MID3 blank for one without
//! bending, else MID2 and MID3 written out (MID3 blank would mean no transverse shear
//! flexibility to Nastran); 12I/T³ and TS/T only when not the defaults 1 and 5/6.
//!
//! Cards are in large-field format. A real is written in the shortest form that reads back to
//! the same `f64` (`2.1+11`, `.3`, `-1.5-3`); when one field of a card needs more than 16
//! characters, that card is written in free-field format instead, with full-length fields.
//! Nastran itself reads at most 16 characters per field and may round such values.
//!
//! Deviations and femu extensions:
//! - A set named `set<N>` becomes SET1 `N`; a `pid<N>` set equal to the one
//!   [`Model::add_property_sets`] would make is left out (the reader adds it again). Any other
//!   set is a SET1 with a fresh id preceded by a `$femu-set <sid> <name>` comment; an empty set
//!   is only the comment (Nastran has no empty SET1).
//! - Each updating parameter is a `$femu-parameter <json>` comment.
//! - Constraints are written grouped by node and come back sorted without repeats; a model
//!   round-trips exactly when its constraints are sorted and unique and its `pid<N>` sets are
//!   present, as for every imported model.
//! - Non-finite values are written as `NaN`/`inf`, which the reader rejects.

use crate::core::Component;
use crate::model::structure::{BeamProperty, BeamSection, BeamTaper, Element, Model, RodSection};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;

/// One field to write.
enum F {
    Blank,
    Int(u64),
    Real(f64),
    Text(String),
}

/// Formats a real in the shortest Nastran form that parses back to exactly `x`; it always
/// has a decimal point, so it never reads as an integer.
pub fn format_real(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return if x.is_sign_negative() { "-0." } else { "0." }.to_string();
    }
    let sci = format!("{x:e}");
    let Some((mantissa, exponent)) = sci.split_once('e') else {
        return sci;
    };
    let Ok(exp) = exponent.parse::<i32>() else {
        return sci;
    };
    let sign = if mantissa.starts_with('-') { "-" } else { "" };
    let digits: String = mantissa.chars().filter(char::is_ascii_digit).collect();
    let n = digits.len() as i32;
    let (lead, rest) = digits.split_at(1);
    let exp_form = if exp == 0 {
        format!("{sign}{lead}.{rest}")
    } else {
        format!("{sign}{lead}.{rest}{exp:+}")
    };
    let positional = if exp >= n - 1 {
        format!("{sign}{digits}{}.", "0".repeat((exp + 1 - n) as usize))
    } else if exp >= 0 {
        let (a, b) = digits.split_at(exp as usize + 1);
        format!("{sign}{a}.{b}")
    } else {
        format!("{sign}.{}{digits}", "0".repeat((-exp - 1) as usize))
    };
    if positional.len() <= exp_form.len() {
        positional
    } else {
        exp_form
    }
}

fn text_of(f: &F) -> String {
    match f {
        F::Blank => String::new(),
        F::Int(v) => v.to_string(),
        F::Real(v) => format_real(*v),
        F::Text(s) => s.clone(),
    }
}

/// Appends one card: large field when every field fits 16 characters, else free field.
fn card(out: &mut String, name: &str, fields: Vec<F>) {
    let texts: Vec<String> = fields.iter().map(text_of).collect();
    card_texts(out, name, texts);
}

/// Appends one card from its field texts (trailing blanks dropped): large field when every
/// field fits 16 characters, else free field.
pub(crate) fn card_texts(out: &mut String, name: &str, mut texts: Vec<String>) {
    while texts.last().is_some_and(String::is_empty) {
        texts.pop();
    }
    if texts.iter().all(|t| t.len() <= 16) {
        for (i, chunk) in texts.chunks(4).enumerate() {
            let mut line = if i == 0 {
                format!("{:<8}", format!("{name}*"))
            } else {
                "*       ".to_string()
            };
            for t in chunk {
                let _ = write!(line, "{t:<16}");
            }
            out.push_str(line.trim_end());
            out.push('\n');
        }
        if texts.is_empty() {
            out.push_str(&format!("{name}*\n"));
        }
    } else {
        for (i, chunk) in texts.chunks(8).enumerate() {
            out.push_str(if i == 0 { name } else { "" });
            for t in chunk {
                out.push(',');
                out.push_str(t);
            }
            out.push('\n');
        }
    }
}

fn comps_text(comps: &BTreeSet<Component>) -> String {
    comps.iter().map(|c| c.nastran().to_string()).collect()
}

/// Writes the model as bulk data (large-field cards, free field where a value needs it).
pub fn write_bulk(model: &Model) -> String {
    let mut out = String::new();
    out.push_str("$ Nastran bulk data written by femu\nBEGIN BULK\n");
    write_materials_and_properties(&mut out, model);
    // Coordinate system ids: the solids' material axes first (1…), then the bushes' element
    // systems, the displacement systems, and the shells' material axes.
    let solid_axes = model
        .solid_properties
        .values()
        .filter(|p| p.axes.is_some())
        .count() as u64;
    let bush_pid = write_bush_properties(&mut out, model, solid_axes);
    let bush_axes = bush_pid.values().filter(|(_, cid)| *cid != 0).count() as u64;
    let first = solid_axes + bush_axes + 1;
    let systems = write_displacement_systems(&mut out, model, first);
    let first = first + systems.values().collect::<BTreeSet<_>>().len() as u64;
    let axes = write_material_axes(&mut out, model, first);
    for (&id, x) in &model.nodes {
        let mut fields = vec![
            F::Int(id),
            F::Blank,
            F::Real(x[0]),
            F::Real(x[1]),
            F::Real(x[2]),
        ];
        if let Some(cd) = systems.get(&id) {
            fields.push(F::Int(*cd));
        }
        card(&mut out, "GRID", fields);
    }
    if !model.scalar_points.is_empty() {
        let ids: Vec<u64> = model.scalar_points.iter().copied().collect();
        for chunk in ids.chunks(8) {
            card(
                &mut out,
                "SPOINT",
                chunk.iter().map(|i| F::Int(*i)).collect(),
            );
        }
    }
    for (&id, e) in &model.elements {
        match model.shell_placements.get(&id) {
            Some(pl) => write_placed_shell(&mut out, id, e, pl, &axes),
            None => write_element(&mut out, model, id, e, &bush_pid),
        }
    }
    write_constraints(&mut out, model);
    write_mpcs(&mut out, model);
    write_sets(&mut out, model);
    for p in &model.parameters {
        if let Ok(json) = serde_json::to_string(p) {
            let _ = writeln!(out, "$femu-parameter {json}");
        }
    }
    out.push_str("ENDDATA\n");
    out
}

/// One CORD2R per distinct displacement system (ids from `first`, in order of first use by grid id:
/// origin at the basic origin, `B` on its z axis, `C` on its x axis), and the CD of each grid
/// that has one.
fn write_displacement_systems(out: &mut String, model: &Model, first: u64) -> BTreeMap<u64, u64> {
    let mut ids: BTreeMap<[u64; 9], u64> = BTreeMap::new();
    let mut cd = BTreeMap::new();
    for (&node, r) in &model.displacement_systems {
        let key: [u64; 9] = std::array::from_fn(|k| r[k / 3][k % 3].to_bits());
        let next = ids.len() as u64 + first;
        let id = *ids.entry(key).or_insert_with(|| {
            card(
                out,
                "CORD2R",
                vec![
                    F::Int(next),
                    F::Int(0),
                    F::Real(0.0),
                    F::Real(0.0),
                    F::Real(0.0),
                    F::Real(r[2][0]),
                    F::Real(r[2][1]),
                    F::Real(r[2][2]),
                    F::Real(r[0][0]),
                    F::Real(r[0][1]),
                    F::Real(r[0][2]),
                ],
            );
            next
        });
        cd.insert(node, id);
    }
    cd
}

/// MAT1, PSHELL, and PBAR or PBARL cards, each group by ascending id.
fn write_materials_and_properties(out: &mut String, model: &Model) {
    for (&id, m) in &model.materials {
        card(
            out,
            "MAT1",
            vec![
                F::Int(id),
                F::Real(m.e),
                F::Blank,
                F::Real(m.nu),
                F::Real(m.rho),
            ],
        );
    }
    for (&id, m) in &model.anisotropic_materials {
        let mut f = vec![F::Int(id)];
        f.extend(m.g.iter().map(|v| F::Real(*v)));
        f.push(F::Real(m.rho));
        card(out, "MAT9", f);
    }
    write_shell_materials(out, model);
    for (&id, p) in &model.shell_properties {
        if let Some(l) = &p.laminate {
            write_laminate(out, id, p, l);
            continue;
        }
        let mid = |on: bool, m: u64| if on { F::Int(m) } else { F::Blank };
        let ratio = |v: f64, default: f64| {
            if v == default { F::Blank } else { F::Real(v) }
        };
        card(
            out,
            "PSHELL",
            vec![
                F::Int(id),
                mid(p.membrane, p.material),
                F::Real(p.thickness),
                mid(p.bending, p.bending_mid()),
                ratio(p.bending_ratio, 1.0),
                mid(p.bending, p.shear_mid()),
                ratio(p.shear_ratio, crate::model::structure::five_sixths()),
                F::Real(p.nsm),
            ]
            .into_iter()
            .chain(
                p.coupling_material
                    .map(|m| [F::Blank, F::Blank, F::Int(m)])
                    .into_iter()
                    .flatten(),
            )
            .collect(),
        );
    }
    for (&id, p) in &model.beam_properties {
        let nu = model.materials.get(&p.material).map(|m| m.nu);
        write_beam_property(out, id, p, nu);
    }
    for (&id, p) in &model.rod_properties {
        if let Some(t) = p.taper {
            card(
                out,
                "PTUBE",
                vec![
                    F::Int(id),
                    F::Int(p.material),
                    F::Real(t.od_a),
                    F::Real(t.t),
                    F::Real(p.nsm),
                    F::Real(t.od_b),
                ],
            );
            continue;
        }
        card(
            out,
            "PROD",
            vec![
                F::Int(id),
                F::Int(p.material),
                F::Real(p.area),
                F::Real(p.j),
                F::Real(p.c),
                F::Real(p.nsm),
            ],
        );
    }
    let mut cid = 0;
    for (&id, p) in &model.solid_properties {
        let cordm = match &p.axes {
            Some(axes) => {
                // CORD2R: origin A = 0, B on the z axis, C in the x-z plane (on x).
                cid += 1;
                let mut f = vec![F::Int(cid), F::Int(0), F::Real(0.0), F::Real(0.0)];
                f.push(F::Real(0.0));
                f.extend(axes[2].iter().chain(&axes[0]).map(|v| F::Real(*v)));
                card(out, "CORD2R", f);
                F::Int(cid)
            }
            None => F::Blank,
        };
        card(out, "PSOLID", vec![F::Int(id), F::Int(p.material), cordm]);
    }
}

/// MAT8 and MAT2 cards by ascending id.
fn write_shell_materials(out: &mut String, model: &Model) {
    use crate::model::laminates::ShellMaterial;
    for (&id, m) in &model.shell_materials {
        match m {
            ShellMaterial::Orthotropic {
                e1,
                e2,
                nu12,
                g12,
                g1z,
                g2z,
                rho,
            } => card(
                out,
                "MAT8",
                [*e1, *e2, *nu12, *g12, *g1z, *g2z, *rho]
                    .into_iter()
                    .map(F::Real)
                    .fold(vec![F::Int(id)], |mut v, f| {
                        v.push(f);
                        v
                    }),
            ),
            ShellMaterial::Anisotropic { g, rho } => {
                let mut f = vec![F::Int(id)];
                f.extend(g.iter().map(|v| F::Real(*v)));
                f.push(F::Real(*rho));
                card(out, "MAT2", f);
            }
        }
    }
}

/// A PCOMP (or PCOMPG with its global ply ids) with every ply's MID, T and THETA given.
fn write_laminate(
    out: &mut String,
    id: u64,
    p: &crate::model::ShellProperty,
    l: &crate::model::laminates::Laminate,
) {
    let global = !l.global_ids.is_empty();
    let mut f = vec![
        F::Int(id),
        l.z0.map_or(F::Blank, F::Real),
        F::Real(p.nsm),
        F::Blank,
        F::Blank,
        F::Blank,
        F::Blank,
        if l.symmetric {
            F::Text("SYM".into())
        } else if l.terms.lam().is_empty() {
            F::Blank
        } else {
            F::Text(l.terms.lam().into())
        },
    ];
    for (j, ply) in l.plies.iter().enumerate() {
        if global {
            f.push(F::Int(l.global_ids[j]));
        }
        f.extend([
            F::Int(ply.material),
            F::Real(ply.thickness),
            F::Real(ply.theta_deg),
            F::Blank,
        ]);
        if global {
            f.extend([F::Blank, F::Blank, F::Blank]);
        }
    }
    card(out, if global { "PCOMPG" } else { "PCOMP" }, f);
}

/// One CORD2R per distinct MCID axis of the shell placements (ids from `first`, in first-use
/// order: the model holds every position in basic, so no other system is written); returns
/// each axis' id by its bits.
fn write_material_axes(out: &mut String, model: &Model, first: u64) -> BTreeMap<[u64; 3], u64> {
    let mut ids = BTreeMap::new();
    for pl in model.shell_placements.values() {
        let Some(v) = pl.axis else { continue };
        let key = v.map(f64::to_bits);
        if ids.contains_key(&key) {
            continue;
        }
        let id = ids.len() as u64 + first;
        ids.insert(key, id);
        // z normal to v: v × (the basic axis least along v); x in the plane of z and C = v.
        let k = (0..3)
            .min_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()))
            .unwrap_or(0);
        let mut w = [0.0; 3];
        w[k] = 1.0;
        let z = [
            v[1] * w[2] - v[2] * w[1],
            v[2] * w[0] - v[0] * w[2],
            v[0] * w[1] - v[1] * w[0],
        ];
        let mut f = vec![
            F::Int(id),
            F::Blank,
            F::Real(0.0),
            F::Real(0.0),
            F::Real(0.0),
        ];
        f.extend(z.iter().map(|c| F::Real(*c)));
        f.extend(v.iter().map(|c| F::Real(*c)));
        card(out, "CORD2R", f);
    }
    ids
}

/// A CQUAD4/CTRIA3 with its THETA (or MCID) and ZOFFS.
fn write_placed_shell(
    out: &mut String,
    id: u64,
    e: &Element,
    pl: &crate::model::laminates::ShellPlacement,
    axes: &BTreeMap<[u64; 3], u64>,
) {
    let (name, nodes, property) = match e {
        Element::Quad4 { nodes, property } => ("CQUAD4", nodes.to_vec(), property),
        Element::Tria3 { nodes, property } => ("CTRIA3", nodes.to_vec(), property),
        _ => return,
    };
    let mut f = vec![F::Int(id), F::Int(*property)];
    f.extend(nodes.iter().map(|n| F::Int(*n)));
    f.push(match pl.axis {
        Some(v) => F::Int(axes[&v.map(f64::to_bits)]),
        None => F::Real(pl.theta_deg),
    });
    f.push(F::Real(pl.offset));
    card(out, name, f);
}

/// A tapered beam property: PBEAML (dimensions) or PBEAM (properties, K1/K2 from the
/// section, and the N/M/NSI offsets) with every station after end A, SO = NO. A PBEAML has no
/// offset fields: its neutral axis offset is recomputed from the dimensions on reading (NSM
/// offsets of a tapered library section, which no import produces, are not written).
fn write_tapered_beam_property(out: &mut String, id: u64, p: &BeamProperty, t: &BeamTaper) {
    let Some(a) = t.stations.first() else {
        return;
    };
    let rest = &t.stations[1..];
    if let Some(kind) = &t.library {
        let mut f = vec![
            F::Int(id),
            F::Int(p.material),
            F::Blank,
            F::Text(kind.clone()),
            F::Blank,
            F::Blank,
            F::Blank,
            F::Blank,
        ];
        f.extend(a.values.iter().map(|v| F::Real(*v)));
        f.push(F::Real(a.nsm));
        for s in rest {
            f.extend([F::Text("NO".into()), F::Real(s.x)]);
            f.extend(s.values.iter().map(|v| F::Real(*v)));
            f.push(F::Real(s.nsm));
        }
        card(out, "PBEAML", f);
        return;
    }
    let (k1, k2) = match p.section {
        BeamSection::General {
            shear_y, shear_z, ..
        } => (shear_y, shear_z),
        _ => (0.0, 0.0),
    };
    // A I1 I2 I12 J NSM from the stored A I1 I2 J.
    let props = |s: &crate::model::BeamStation| -> Vec<F> {
        let v = |i: usize| F::Real(s.values.get(i).copied().unwrap_or(0.0));
        vec![v(0), v(1), v(2), F::Real(0.0), v(3), F::Real(s.nsm)]
    };
    let mut f = vec![F::Int(id), F::Int(p.material)];
    f.extend(props(a));
    f.extend((0..8).map(|_| F::Blank));
    for s in rest {
        f.extend([F::Text("NO".into()), F::Real(s.x)]);
        f.extend(props(s));
    }
    f.extend(pbeam_tail(p, k1, k2));
    card(out, "PBEAM", f);
}

/// The last two PBEAM continuations: `K1 K2 S1 S2 NSI(A) NSI(B) CW(A) CW(B)` and, when the
/// property has its centroid or NSM off the axis, `M1(A) M2(A) M1(B) M2(B) N1(A) N2(A) N1(B)
/// N2(B)` (end B blank: end A's). Trailing blanks are dropped by the card writer.
fn pbeam_tail(p: &BeamProperty, k1: f64, k2: f64) -> Vec<F> {
    let mut f = vec![F::Real(k1), F::Real(k2)];
    if let Some(c) = &p.centres {
        f.extend([F::Blank, F::Blank, F::Real(c.nsi)]);
        f.extend((0..3).map(|_| F::Blank));
        f.extend([
            F::Real(c.nsm_cg[0]),
            F::Real(c.nsm_cg[1]),
            F::Blank,
            F::Blank,
        ]);
        f.extend([F::Real(c.neutral_axis[0]), F::Real(c.neutral_axis[1])]);
    }
    f
}

/// A beam whose centroid or NSM is off its axis: a PBEAM (the only card with N/M/NSI) with the
/// section's properties. A BAR, ROD or TUBE section (which no import produces with offsets)
/// is written with the properties femu's kernel gives it for the material's `ν` (J by the
/// Saint-Venant series, Cowper's shear factors), so it reads back as a general section of the
/// same stiffness and mass.
fn write_centred_beam_property(out: &mut String, id: u64, p: &BeamProperty, nu: Option<f64>) {
    let (area, iy, iz, j, k1, k2) = match p.section {
        BeamSection::General {
            area,
            iy,
            iz,
            j,
            shear_y,
            shear_z,
        } => (area, iy, iz, j, shear_y, shear_z),
        ref s => {
            let nu = nu.unwrap_or(0.3);
            match crate::fe::model_assembly::kernel_section(s).properties(nu) {
                Ok(q) => (q.area, q.iy, q.iz, q.j, q.kappa_y, q.kappa_z),
                Err(_) => (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
            }
        }
    };
    let mut f = vec![
        F::Int(id),
        F::Int(p.material),
        F::Real(area),
        F::Real(iz),
        F::Real(iy),
        F::Real(0.0),
        F::Real(j),
        F::Real(p.nsm),
    ];
    f.extend((0..8).map(|_| F::Blank));
    f.extend(pbeam_tail(p, k1, k2));
    card(out, "PBEAM", f);
}

/// A beam property: PBARL for the BAR, ROD and TUBE sections, PBAR for a general one; PBEAM
/// (with its N, M, NSI) when the centroid or NSM is off the axis; a tapered one as
/// [`write_tapered_beam_property`] says (`nu`: the material's Poisson's ratio).
fn write_beam_property(out: &mut String, id: u64, p: &BeamProperty, nu: Option<f64>) {
    if let Some(t) = &p.taper {
        write_tapered_beam_property(out, id, p, t);
        return;
    }
    if p.centres.is_some() {
        write_centred_beam_property(out, id, p, nu);
        return;
    }
    let head = |kind: &str| {
        vec![
            F::Int(id),
            F::Int(p.material),
            F::Blank,
            F::Text(kind.to_string()),
            F::Blank,
            F::Blank,
            F::Blank,
            F::Blank,
        ]
    };
    match &p.section {
        BeamSection::Rectangle { width, height } => {
            let mut f = head("BAR");
            f.extend([F::Real(*width), F::Real(*height), F::Real(p.nsm)]);
            card(out, "PBARL", f);
        }
        BeamSection::Circle { radius } => {
            let mut f = head("ROD");
            f.extend([F::Real(*radius), F::Real(p.nsm)]);
            card(out, "PBARL", f);
        }
        BeamSection::Tube {
            outer_radius,
            inner_radius,
        } => {
            let mut f = head("TUBE");
            f.extend([
                F::Real(*outer_radius),
                F::Real(*inner_radius),
                F::Real(p.nsm),
            ]);
            card(out, "PBARL", f);
        }
        BeamSection::General {
            area,
            iy,
            iz,
            j,
            shear_y,
            shear_z,
        } => {
            let mut f = vec![
                F::Int(id),
                F::Int(p.material),
                F::Real(*area),
                F::Real(*iz),
                F::Real(*iy),
                F::Real(*j),
                F::Real(p.nsm),
                F::Blank,
            ];
            f.extend((0..8).map(|_| F::Blank));
            f.extend([F::Real(*shear_y), F::Real(*shear_z)]);
            card(out, "PBAR", f);
        }
    }
}

/// One PBUSH per bush element, with ids above every property id; returns each bush's property
/// id by element id.
fn write_bush_properties(
    out: &mut String,
    model: &Model,
    cids_before: u64,
) -> BTreeMap<u64, (u64, u64)> {
    let max_pid = model
        .shell_properties
        .keys()
        .chain(model.beam_properties.keys())
        .chain(model.rod_properties.keys())
        .chain(model.solid_properties.keys())
        .max()
        .copied()
        .unwrap_or(0);
    let mut bush_pid = BTreeMap::new();
    let mut cid = cids_before;
    for (&id, e) in &model.elements {
        if let Element::Bush { k, b, axes, .. } = e {
            let pid = max_pid + 1 + bush_pid.len() as u64;
            let mut f = vec![F::Int(pid), F::Text("K".to_string())];
            f.extend(k.iter().map(|v| F::Real(*v)));
            if b.iter().any(|v| *v != 0.0) {
                // The continuation: a blank field 2, then the B flag and B1–B6.
                f.extend([F::Blank, F::Text("B".to_string())]);
                f.extend(b.iter().map(|v| F::Real(*v)));
            }
            card(out, "PBUSH", f);
            // The element system as a CORD2R: origin at basic 0, A the origin, B on z, C on x.
            let system = axes.map(|a| {
                cid += 1;
                let mut f = vec![
                    F::Int(cid),
                    F::Int(0),
                    F::Real(0.0),
                    F::Real(0.0),
                    F::Real(0.0),
                ];
                f.extend(a[2].iter().map(|v| F::Real(*v)));
                f.extend(a[0].iter().map(|v| F::Real(*v)));
                card(out, "CORD2R", f);
                cid
            });
            bush_pid.insert(id, (pid, system.unwrap_or(0)));
        }
    }
    let mut next = max_pid + 1 + bush_pid.len() as u64;
    for (&id, e) in &model.elements {
        if let Element::Viscous {
            axial, torsional, ..
        } = e
        {
            let pid = next;
            next += 1;
            bush_pid.insert(id, (pid, 0));
            card(
                out,
                "PVISC",
                vec![F::Int(pid), F::Real(*axial), F::Real(*torsional)],
            );
        }
    }
    bush_pid
}

/// One element card; a bush refers to its PBUSH id and CORD2R id in `bush_pid` (a viscous
/// damper to its PVISC id).
fn write_element(
    out: &mut String,
    model: &Model,
    id: u64,
    e: &Element,
    bush_pid: &BTreeMap<u64, (u64, u64)>,
) {
    match e {
        Element::Quad4 { nodes, property } => {
            let mut f = vec![F::Int(id), F::Int(*property)];
            f.extend(nodes.iter().map(|n| F::Int(*n)));
            card(out, "CQUAD4", f);
        }
        Element::Tria3 { nodes, property } => {
            let mut f = vec![F::Int(id), F::Int(*property)];
            f.extend(nodes.iter().map(|n| F::Int(*n)));
            card(out, "CTRIA3", f);
        }
        // CQUAD8/CTRIA6: corners, then the midside nodes (blank where omitted); THETA, ZOFFS and
        // T1–T4 blank (the PSHELL thickness).
        Element::Quad8 {
            corners,
            midside,
            property,
        } => card(
            out,
            "CQUAD8",
            quadratic_fields(id, *property, corners, midside),
        ),
        Element::Tria6 {
            corners,
            midside,
            property,
        } => card(
            out,
            "CTRIA6",
            quadratic_fields(id, *property, corners, midside),
        ),
        Element::Beam {
            nodes,
            property,
            orientation,
            ends,
        } => {
            let mut f = vec![
                F::Int(id),
                F::Int(*property),
                F::Int(nodes[0]),
                F::Int(nodes[1]),
            ];
            f.extend(orientation.iter().map(|v| F::Real(*v)));
            if !ends.is_plain() {
                // OFFT BGG: orientation and offsets in the basic system, as the model holds them.
                f.push(F::Text("BGG".into()));
                for pin in [ends.pin_a, ends.pin_b] {
                    f.push(if pin == 0 {
                        F::Blank
                    } else {
                        F::Int(pin as u64)
                    });
                }
                f.extend(
                    ends.offset_a
                        .iter()
                        .chain(&ends.offset_b)
                        .map(|v| F::Real(*v)),
                );
            }
            // A tapered property, or one with its centroid or NSM off the axis, is a
            // PBEAM/PBEAML, which CBEAM names (same fields as CBAR).
            let tapered = model
                .beam_properties
                .get(property)
                .is_some_and(|p| p.taper.is_some() || p.centres.is_some());
            card(out, if tapered { "CBEAM" } else { "CBAR" }, f);
        }
        Element::Rod { nodes, section } => match section {
            RodSection::Property(pid) => card(
                out,
                if model
                    .rod_properties
                    .get(pid)
                    .is_some_and(|p| p.taper.is_some())
                {
                    "CTUBE"
                } else {
                    "CROD"
                },
                vec![F::Int(id), F::Int(*pid), F::Int(nodes[0]), F::Int(nodes[1])],
            ),
            RodSection::Own(p) => card(
                out,
                "CONROD",
                vec![
                    F::Int(id),
                    F::Int(nodes[0]),
                    F::Int(nodes[1]),
                    F::Int(p.material),
                    F::Real(p.area),
                    F::Real(p.j),
                    F::Real(p.c),
                    F::Real(p.nsm),
                ],
            ),
        },
        Element::Solid {
            kind,
            nodes,
            property,
        } => {
            use crate::model::SolidFamily as S;
            let name = match kind.family() {
                S::Hexa => "CHEXA",
                S::Penta => "CPENTA",
                S::Tetra => "CTETRA",
                S::Pyram => "CPYRAM",
            };
            let mut f = vec![F::Int(id), F::Int(*property)];
            let corners = kind.family().corners();
            f.extend(nodes.iter().take(corners).map(|n| F::Int(*n)));
            // Midside grids in their fields, an absent one blank (a variable-node element).
            let mut midside = nodes.iter().skip(corners);
            if kind.midside() != 0 {
                for k in 0..kind.family().edges() {
                    f.push(if kind.midside() >> k & 1 == 1 {
                        midside.next().map_or(F::Blank, |n| F::Int(*n))
                    } else {
                        F::Blank
                    });
                }
            }
            card(out, name, f);
        }
        Element::Bush { node, other, .. } => {
            let (pid, cid) = bush_pid.get(&id).copied().unwrap_or((0, 0));
            card(
                out,
                "CBUSH",
                vec![
                    F::Int(id),
                    F::Int(pid),
                    F::Int(*node),
                    other.map_or(F::Blank, F::Int),
                    F::Blank,
                    F::Blank,
                    F::Blank,
                    F::Int(cid),
                ],
            );
        }
        Element::ScalarMass { dof, other, m } => {
            card(out, "CMASS2", scalar_fields(id, *m, dof, other));
        }
        Element::ScalarDamper { dof, other, c } => {
            card(out, "CDAMP2", scalar_fields(id, *c, dof, other));
        }
        Element::Viscous { nodes, .. } => {
            let (pid, _) = bush_pid.get(&id).copied().unwrap_or((0, 0));
            card(
                out,
                "CVISC",
                vec![F::Int(id), F::Int(pid), F::Int(nodes[0]), F::Int(nodes[1])],
            );
        }
        Element::GeneralMass { node, m } => {
            let mut f = vec![F::Int(id), F::Int(*node), F::Int(0)];
            f.extend(m.iter().map(|v| F::Real(*v)));
            card(out, "CONM1", f);
        }
        Element::ScalarSpring { dof, other, k } => {
            let mut f = vec![
                F::Int(id),
                F::Real(*k),
                F::Int(dof.node),
                F::Int(u64::from(dof.comp.nastran())),
            ];
            if let Some(o) = other {
                f.extend([F::Int(o.node), F::Int(u64::from(o.comp.nastran()))]);
            }
            card(out, "CELAS2", f);
        }
        Element::Mass {
            node,
            mass,
            inertia,
            offset,
        } => {
            let mut f = vec![F::Int(id), F::Int(*node), F::Int(0), F::Real(*mass)];
            f.extend(offset.iter().map(|v| F::Real(*v)));
            f.push(F::Blank);
            f.extend(inertia.iter().map(|v| F::Real(*v)));
            card(out, "CONM2", f);
        }
    }
}

/// The fields of a CELAS2/CMASS2/CDAMP2: EID, value, G1, C1 and G2, C2 when not to ground.
fn scalar_fields(
    id: u64,
    v: f64,
    dof: &crate::core::DofId,
    other: &Option<crate::core::DofId>,
) -> Vec<F> {
    let mut f = vec![
        F::Int(id),
        F::Real(v),
        F::Int(dof.node),
        F::Int(u64::from(dof.comp.nastran())),
    ];
    if let Some(o) = other {
        f.extend([F::Int(o.node), F::Int(u64::from(o.comp.nastran()))]);
    }
    f
}

/// SPC1 cards (SID 1), one per component list, the nodes grouped by their constrained components.
fn write_constraints(out: &mut String, model: &Model) {
    let mut by_node: BTreeMap<u64, BTreeSet<Component>> = BTreeMap::new();
    for d in &model.constraints {
        by_node.entry(d.node).or_default().insert(d.comp);
    }
    let mut by_comps: BTreeMap<String, Vec<u64>> = BTreeMap::new();
    for (node, comps) in by_node {
        by_comps.entry(comps_text(&comps)).or_default().push(node);
    }
    for (comps, nodes) in by_comps {
        let mut f = vec![F::Int(1), F::Text(comps)];
        f.extend(nodes.into_iter().map(F::Int));
        card(out, "SPC1", f);
    }
}

/// MPC cards (SID 1): `G1 C1 1.0` for the dependent DOF, then `Gi Ci −cᵢ`, two terms per line
/// after the first (fields 3–8 and, on continuations, 3–8 after a blank field 2).
fn write_mpcs(out: &mut String, model: &Model) {
    for c in &model.mpcs {
        let _ = writeln!(out, "$ {}", c.origin.replace('\n', " "));
        let mut f = vec![F::Int(1)];
        let terms =
            std::iter::once((c.dependent, 1.0)).chain(c.terms.iter().map(|&(d, v)| (d, -v)));
        for (i, (d, v)) in terms.enumerate() {
            // Fields per line: SID + two triples + blank; continuations: blank + two triples + blank.
            if i >= 2 && i % 2 == 0 {
                f.push(F::Blank);
                f.push(F::Blank);
            }
            f.push(F::Int(d.node));
            f.push(F::Int(d.comp.nastran() as u64));
            f.push(F::Real(v));
        }
        card(out, "MPC", f);
    }
}

/// The SID a set name stands for (`set<N>`, `N` > 0 written without leading zeros).
fn numbered(name: &str) -> Option<u64> {
    let n: u64 = name.strip_prefix("set")?.parse().ok()?;
    (n > 0 && format!("set{n}") == name).then_some(n)
}

fn write_sets(out: &mut String, model: &Model) {
    let mut by_pid: BTreeMap<u64, Vec<u64>> = BTreeMap::new();
    for (&id, e) in &model.elements {
        if let Some(p) = e.property() {
            by_pid.entry(p).or_default().push(id);
        }
    }
    let generated = |name: &str, ids: &[u64]| {
        name.strip_prefix("pid")
            .and_then(|n| n.parse::<u64>().ok())
            .is_some_and(|p| format!("pid{p}") == name && by_pid.get(&p).is_some_and(|v| v == ids))
    };
    let mut next = model
        .sets
        .keys()
        .filter_map(|n| numbered(n))
        .max()
        .unwrap_or(0)
        + 1;
    for (name, ids) in &model.sets {
        if generated(name, ids) {
            continue;
        }
        let sid = match numbered(name) {
            Some(n) => n,
            None => {
                let sid = next;
                next += 1;
                let _ = writeln!(out, "$femu-set {sid} {name}");
                sid
            }
        };
        if !ids.is_empty() {
            let mut f = vec![F::Int(sid)];
            f.extend(ids.iter().map(|e| F::Int(*e)));
            card(out, "SET1", f);
        }
    }
}

/// The fields of a CQUAD8/CTRIA6: id, property, corners, then the midside nodes (blank where
/// omitted).
fn quadratic_fields(id: u64, property: u64, corners: &[u64], midside: &[Option<u64>]) -> Vec<F> {
    let mut f = vec![F::Int(id), F::Int(property)];
    f.extend(corners.iter().map(|n| F::Int(*n)));
    f.extend(midside.iter().map(|n| n.map_or(F::Blank, F::Int)));
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::DofId;
    use crate::model::import::nastran::{parse_bulk, parse_real};
    use crate::model::structure::{
        BeamProperty, Material, Parameter, ParameterKind, RodProperty, ShellProperty,
    };
    use proptest::prelude::*;

    #[test]
    fn reals_are_short_and_have_a_point() {
        assert_eq!(format_real(2.1e11), "2.1+11");
        assert_eq!(format_real(0.3), ".3");
        assert_eq!(format_real(-1.5e-3), "-.0015");
        assert_eq!(format_real(7850.0), "7850.");
        assert_eq!(format_real(1.0), "1.");
        assert_eq!(format_real(-2.5e-12), "-2.5-12");
        assert_eq!(format_real(0.0), "0.");
        assert_eq!(format_real(1e300), "1.+300");
        assert_eq!(format_real(0.1 + 0.2), ".30000000000000004");
    }

    proptest! {
        #[test]
        fn every_finite_real_reads_back_exactly(x in any::<f64>().prop_filter("finite", |x| x.is_finite())) {
            let text = format_real(x);
            prop_assert!(text.contains('.'));
            prop_assert_eq!(parse_real(&text).map(f64::to_bits), Some(x.to_bits()));
        }
    }

    /// A model with every element type and section, property sets, named sets and parameters.
    fn full_model() -> Model {
        let mut m = Model::default();
        let coords = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.5, 0.0],
            [0.1 + 0.2, 1.0 / 3.0, -2.5e-7],
            [3.0, 0.0, 1e-3],
        ];
        for (i, x) in coords.iter().enumerate() {
            m.nodes.insert(i as u64 + 1, *x);
        }
        m.materials.insert(
            1,
            Material {
                e: 2.1e11,
                nu: 0.3,
                rho: 7850.0,
            },
        );
        m.materials.insert(
            2,
            Material {
                e: 7.0e10,
                nu: 1.0 / 3.0,
                rho: 2700.0,
            },
        );
        m.shell_properties
            .insert(10, ShellProperty::homogeneous(1, 0.002, 0.5));
        let sections = [
            BeamSection::Rectangle {
                width: 0.01,
                height: 0.02,
            },
            BeamSection::Circle { radius: 0.005 },
            BeamSection::Tube {
                outer_radius: 0.01,
                inner_radius: 0.008,
            },
            BeamSection::General {
                area: 1.2e-4,
                iy: 3.4e-9,
                iz: 5.6e-9,
                j: 7.8e-9,
                shear_y: 0.0,
                shear_z: 5.0 / 6.0,
            },
        ];
        for (i, s) in sections.into_iter().enumerate() {
            m.beam_properties.insert(
                20 + i as u64,
                BeamProperty {
                    material: 2,
                    section: s,
                    nsm: 0.1 * i as f64,
                    taper: None,
                    centres: None,
                },
            );
        }
        m.elements.insert(
            1,
            Element::Quad4 {
                nodes: [1, 2, 3, 4],
                property: 10,
            },
        );
        m.elements.insert(
            2,
            Element::Tria3 {
                nodes: [2, 5, 3],
                property: 10,
            },
        );
        for i in 0..4u64 {
            m.elements.insert(
                3 + i,
                Element::Beam {
                    nodes: [5, 6 + i % 2],
                    property: 20 + i,
                    orientation: [0.0, 0.0, 1.0 + i as f64],
                    ends: Default::default(),
                },
            );
        }
        // Rods: a PROD shared by id and a CONROD with its own section.
        m.rod_properties.insert(
            14,
            RodProperty {
                material: 2,
                area: 3.0e-5,
                j: 1.0e-9,
                c: 0.004,
                nsm: 0.02,
                taper: None,
            },
        );
        m.elements.insert(
            15,
            Element::Rod {
                nodes: [5, 7],
                section: RodSection::Property(14),
            },
        );
        m.elements.insert(
            16,
            Element::Rod {
                nodes: [6, 7],
                section: RodSection::Own(RodProperty {
                    material: 1,
                    area: 1.0 / 3.0 * 1e-4,
                    j: 0.0,
                    c: 0.0,
                    nsm: 0.0,
                    taper: None,
                }),
            },
        );
        // PSHELL variants: membrane only, bending only, other MID2/MID3 with 12I/T³ and TS/T.
        let mut membrane = ShellProperty::homogeneous(1, 0.003, 0.0);
        membrane.bending = false;
        let mut bending = ShellProperty::homogeneous(2, 0.004, 0.1);
        bending.membrane = false;
        let mut layered = ShellProperty::homogeneous(1, 0.005, 0.0);
        layered.bending_material = Some(2);
        layered.shear_material = Some(1);
        layered.bending_ratio = 2.5;
        layered.shear_ratio = 0.7;
        for (pid, p) in [(11, membrane), (12, bending), (13, layered)] {
            m.shell_properties.insert(pid, p);
        }
        for (eid, pid) in [(17, 11), (18, 12), (19, 13)] {
            m.elements.insert(
                eid,
                Element::Tria3 {
                    nodes: [1, 2, 3],
                    property: pid,
                },
            );
        }
        m.elements.insert(
            10,
            Element::Bush {
                node: 4,
                other: Some(6),
                k: [1e6, 2e6, 3e6, 10.0, 20.0, 30.5],
                axes: Some([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
                b: [0.5, 0.0, 0.0, 0.0, 0.0, 0.25],
            },
        );
        // Scalar points and the scalar family (SPOINT, CMASS2, CDAMP2, CONM1, CVISC).
        m.scalar_points.extend([100, 101]);
        m.elements.insert(
            30,
            Element::ScalarMass {
                dof: DofId::new(100, Component::Scalar),
                other: Some(DofId::new(101, Component::Scalar)),
                m: 0.75,
            },
        );
        m.elements.insert(
            31,
            Element::ScalarDamper {
                dof: DofId::new(100, Component::Scalar),
                other: None,
                c: 3.5,
            },
        );
        m.elements.insert(
            32,
            Element::GeneralMass {
                node: 5,
                m: std::array::from_fn(|i| {
                    if [0, 2, 5, 9, 14, 20].contains(&i) {
                        1.0 + i as f64
                    } else {
                        0.01 * i as f64
                    }
                }),
            },
        );
        m.elements.insert(
            33,
            Element::Viscous {
                nodes: [4, 6],
                axial: 2.0,
                torsional: 0.5,
            },
        );
        m.elements.insert(
            34,
            Element::ScalarSpring {
                dof: DofId::new(3, Component::Uy),
                other: Some(DofId::new(100, Component::Scalar)),
                k: 9.0,
            },
        );
        m.constraints.push(DofId::new(101, Component::Scalar));
        m.elements.insert(
            11,
            Element::Bush {
                node: 7,
                other: None,
                k: [1e5, 0.0, 1e5, 0.0, 0.0, 0.0],
                axes: None,
                b: [0.0; 6],
            },
        );
        m.elements.insert(
            12,
            Element::ScalarSpring {
                dof: DofId::new(6, Component::Uz),
                other: Some(DofId::new(7, Component::Rx)),
                k: 1234.5,
            },
        );
        m.elements.insert(
            13,
            Element::ScalarSpring {
                dof: DofId::new(3, Component::Uy),
                other: None,
                k: 1.0 / 7.0,
            },
        );
        m.elements.insert(
            14,
            Element::Mass {
                node: 5,
                mass: 2.5,
                inertia: [0.1, -0.01, 0.2, 0.0, 0.02, 0.3],
                offset: [0.0, 0.05, -0.1],
            },
        );
        for node in [1, 4] {
            for comp in Component::ALL {
                m.constraints.push(DofId::new(node, comp));
            }
        }
        m.constraints.push(DofId::new(7, Component::Uz));
        m.constraints.sort();
        m.add_property_sets();
        m.sets.insert("set7".to_string(), vec![1, 2]);
        m.sets.insert("flange".to_string(), vec![3, 4, 5]);
        m.sets.insert("springs".to_string(), vec![10, 11, 12, 13]);
        m.sets.insert("empty".to_string(), vec![]);
        m.sets.insert("pid21".to_string(), vec![3, 4]);
        m.parameters.push(Parameter {
            name: "t_plate".to_string(),
            kind: ParameterKind::ShellThickness,
            set: "pid10".to_string(),
            lower: 0.001,
            upper: 0.004,
        });
        m.parameters.push(Parameter {
            name: "k_mount".to_string(),
            kind: ParameterKind::SpringStiffness(Component::Uz),
            set: "springs".to_string(),
            lower: 0.0,
            upper: 1e7,
        });
        m.validate().unwrap();
        m
    }

    #[test]
    fn write_then_read_gives_the_same_model() {
        let m = full_model();
        let text = write_bulk(&m);
        let back = parse_bulk(&text, "roundtrip.bdf").unwrap();
        assert!(back.unknown.is_empty(), "{:?}", back.unknown);
        assert!(back.warnings.is_empty(), "{:?}", back.warnings);
        assert_eq!(back.model, m, "{text}");
        // Deterministic, and a fixed point.
        assert_eq!(write_bulk(&back.model), text);
    }

    #[test]
    fn output_is_large_field_with_free_field_only_where_needed() {
        let text = write_bulk(&full_model());
        assert!(text.starts_with("$ Nastran bulk data written by femu\nBEGIN BULK\n"));
        assert!(text.ends_with("ENDDATA\n"));
        assert!(
            text.contains(
                "MAT1*   1               2.1+11                          .3\n*       7850.\n"
            ),
            "{text}"
        );
        assert!(
            text.contains("PBUSH*  24              K               1.+6            2.+6\n"),
            "{text}"
        );
        assert!(
            text.contains("$femu-set 10 pid21\nSET1*   10              3               4\n"),
            "{text}"
        );
        // Grid 6 has 0.30000000000000004: free field for that card only.
        assert!(
            text.contains("GRID,6,,.30000000000000004,.3333333333333333,-2.5-7\n"),
            "{text}"
        );
        assert!(
            text.contains(
                "GRID*   7                               3.              0.\n*       .001\n"
            ),
            "{text}"
        );
        for line in text
            .lines()
            .filter(|l| !l.contains(',') && !l.starts_with('$'))
        {
            assert!(line.len() <= 72, "{line}");
        }
        assert!(text.contains("$femu-set "));
        assert!(text.contains("$femu-parameter {\"name\":\"t_plate\""));
    }
}
