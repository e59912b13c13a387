//! Solid cards: CHEXA, CPENTA, CTETRA, CPYRAM with PSOLID, and the anisotropic MAT9.
//!
//! QRG meaning: CHEXA `EID PID G1 … G20` (G1–G4 one face, G5–G8 the opposite one, G9–G20 the
//! optional midside nodes), CPENTA `EID PID G1 … G15` (G7–G15 optional), CTETRA
//! `EID PID G1 … G10` (G5–G10 optional), CPYRAM `EID PID G1 … G13` (G6–G13 optional); PID blank
//! is the EID. Midside grids: any subset (QRG), blank or 0 meaning none: all blank is the
//! linear element, all given the quadratic one (CPYRAM: Bedrosian's 13-node pyramid), a
//! partial set Bathe's variable-node element (an edge without its grid straight, the
//! displacement linear along it; `src/fe/solid/shape.rs`); a grid repeated in one element is
//! an error (Nastran writes wedges as CPENTA, not as a CHEXA with repeated grids). PSOLID `PID MID CORDM IN STRESS ISOP FCTN`: MID a MAT1 or
//! MAT9; CORDM the material system (0/blank basic, −1 the element system, or a CORDi id) —
//! used for a MAT9 only, which must be in basic or a rectangular CORD1R/CORD2R (the element
//! system and curvilinear systems are errors); IN and ISOP choose Nastran's integration
//! network: femu has one formulation per shape (`src/fe/solid/`), so blank is read silently and
//! the documented values (IN 2, 3, TWO, THREE, BUBBLE; ISOP 0, 1, REDUCED, FULL) with a
//! warning, others are errors; STRESS (output location) is ignored; FCTN must be blank or SMECH
//! (PFLUID, FFLUID and the others are fluid elements: an error). MAT9 `MID G11 … G66 RHO A1 …
//! A6 TREF GE`: the 21 `G_ij` (blank 0) must form a positive definite matrix; the thermal
//! fields and GE do not change the modes (GE ≠ 0 warns).

use super::*;
use crate::model::structure::{AnisotropicMaterial, SolidFamily, SolidProperty};

/// A PSOLID as read, its CORDM not yet resolved.
pub(super) struct SolidIn {
    pub(super) loc: Loc,
    pub(super) material: u64,
    pub(super) cordm: i64,
}

/// Field names of the element grids.
fn g_label(i: usize) -> String {
    format!("G{i}")
}

impl Builder {
    /// CHEXA, CPENTA, CTETRA, CPYRAM.
    pub(super) fn solid_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let family = match c.name.as_str() {
            "CHEXA" => SolidFamily::Hexa,
            "CPENTA" => SolidFamily::Penta,
            "CTETRA" => SolidFamily::Tetra,
            _ => SolidFamily::Pyram,
        };
        let (corners, all) = (family.corners(), family.corners() + family.edges());
        let id = c.id(1, "EID")?;
        let property = c.id_or(2, "PID", id)?;
        let mut nodes = Vec::with_capacity(all);
        for i in 1..=corners {
            nodes.push(c.id(2 + i, &g_label(i))?);
        }
        // Midside grids: blank or 0 is no grid (a straight edge), any subset (QRG).
        let mut midside = 0u16;
        for (k, i) in (corners + 1..=all).enumerate() {
            match c.int(2 + i, &g_label(i))? {
                None | Some(0) => {}
                Some(v) if v > 0 => {
                    midside |= 1 << k;
                    nodes.push(v as u64);
                }
                Some(v) => {
                    return Err(c.err(
                        2 + i,
                        &g_label(i),
                        format!("{v} is not a grid id"),
                        "a grid id (integer > 0), or blank or 0 for no midside grid (a straight edge)",
                    ));
                }
            }
        }
        let kind = family.with_midside(midside);
        for k in 3 + all..=3 + all + 8 {
            if !c.blank(k) {
                return Err(c.err(
                    k,
                    "(beyond the grids)",
                    format!("field holds `{}`", q(c.text(k))),
                    format!(
                        "{} has at most {all} grids; leave the fields after G{all} blank",
                        c.name
                    ),
                ));
            }
        }
        // The field (1-based G number) of each node.
        let field: Vec<usize> = (1..=corners)
            .chain(
                (0..family.edges())
                    .filter(|k| midside >> k & 1 == 1)
                    .map(|k| corners + 1 + k),
            )
            .collect();
        for j in 0..nodes.len() {
            if let Some(i) = (0..j).find(|&i| nodes[i] == nodes[j]) {
                return Err(c.err(
                    2 + field[j],
                    &g_label(field[j]),
                    format!("grid {} appears twice (also G{})", nodes[j], field[i]),
                    "the grids of a solid must be distinct: a wedge is a CPENTA and a pyramid a CPYRAM, not a CHEXA with repeated grids",
                ));
            }
        }
        self.new_element(
            c,
            id,
            ElemIn::Done(Element::Solid {
                kind,
                nodes,
                property,
            }),
        )
    }

    /// PSOLID: `PID MID CORDM IN STRESS ISOP FCTN`.
    pub(super) fn psolid(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let cordm = c.int(3, "CORDM")?.unwrap_or(0);
        if cordm < -1 {
            return Err(c.err(
                3,
                "CORDM",
                format!("{cordm} is not a coordinate system"),
                "0 or blank (basic), -1 (element system) or a coordinate system id",
            ));
        }
        let mut noted = Vec::new();
        let word = c.word(4);
        match word.as_str() {
            "" => {}
            "2" | "3" | "TWO" | "THREE" | "BUBBLE" => noted.push(format!("IN = {word}")),
            other => {
                return Err(c.err(
                    4,
                    "IN",
                    format!("`{}` is not an integration network", q(other)),
                    "blank, 2, 3, TWO, THREE or BUBBLE",
                ));
            }
        }
        let word = c.word(6);
        match word.as_str() {
            "" => {}
            "0" | "1" | "REDUCED" | "FULL" => noted.push(format!("ISOP = {word}")),
            other => {
                return Err(c.err(
                    6,
                    "ISOP",
                    format!("`{}` is not an integration scheme femu knows", q(other)),
                    "blank, 0, 1, REDUCED or FULL",
                ));
            }
        }
        let fctn = c.word(7);
        if !(fctn.is_empty() || fctn == "SMECH") {
            return Err(c.err(
                7,
                "FCTN",
                format!("FCTN = {} makes the elements fluid elements", q(&fctn)),
                "blank or SMECH (structural solids); femu has no fluid elements",
            ));
        }
        self.new_property(c, 1, "PID", id)?;
        if !noted.is_empty() {
            self.warn(
                &c.loc,
                id,
                format!(
                    "{} is read as femu's own formulation for each shape: HEXA8 2x2x2 Gauss with incompatible modes, the other shapes fully integrated (src/fe/solid)",
                    noted.join(", ")
                ),
            );
        }
        self.solids.insert(
            id,
            SolidIn {
                loc: c.loc.clone(),
                material,
                cordm,
            },
        );
        Ok(())
    }

    /// MAT9: `MID G11 … G66 RHO A1 … A6 TREF GE`.
    pub(super) fn mat9(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "MID")?;
        let mut g = Vec::with_capacity(21);
        let mut labels = Vec::with_capacity(21);
        for i in 1..=6 {
            for j in i..=6 {
                labels.push(format!("G{i}{j}"));
            }
        }
        for (k, label) in labels.iter().enumerate() {
            g.push(c.real_or(2 + k, label, 0.0)?);
        }
        let rho = c.nonneg_real(23, "RHO", 0.0)?;
        for (k, label) in ["A1", "A2", "A3", "A4", "A5", "A6", "TREF"]
            .into_iter()
            .enumerate()
        {
            c.real(24 + k, label)?;
        }
        if c.real_or(31, "GE", 0.0)? != 0.0 {
            self.warn(
                &c.loc,
                id,
                "GE (structural damping) does not change the modes and is ignored",
            );
        }
        let m = AnisotropicMaterial { g, rho };
        if let Some(pivot) = not_positive_definite(&m.matrix()) {
            return Err(c.err(
                2,
                "G11",
                format!(
                    "the matrix G is not positive definite (pivot {} of its Cholesky factorisation is {:e})",
                    pivot.0 + 1,
                    pivot.1
                ),
                "a positive definite elasticity matrix (every strain must store energy)",
            ));
        }
        if let Some(first) = self
            .materials
            .get(&id)
            .map(|m| &m.0)
            .or_else(|| self.mat9s.get(&id).map(|m| &m.0))
        {
            return Err(duplicate(c, 1, "MID", "material", id, first));
        }
        self.mat9s.insert(id, (c.loc.clone(), m));
        Ok(())
    }

    /// The solid properties of the model: each PSOLID's material checked against the MAT1 and
    /// MAT9 cards, a MAT9's CORDM resolved to axes in basic.
    pub(super) fn resolve_solid_properties(
        &mut self,
        geo: &Geometry,
    ) -> Result<BTreeMap<u64, SolidProperty>, NastranError> {
        let mut out = BTreeMap::new();
        for (&id, p) in &self.solids {
            let err = |k: usize, label: &str, problem: String, valid: &str| {
                p.loc.field_err(k, label, problem, valid.to_string())
            };
            let anisotropic = self.mat9s.contains_key(&p.material);
            if !anisotropic && !self.materials.contains_key(&p.material) {
                return Err(err(
                    2,
                    "MID",
                    format!("material {} is not a MAT1 or MAT9 of the deck", p.material),
                    "the id of a MAT1 or MAT9 card",
                ));
            }
            let axes = match (anisotropic, p.cordm) {
                (false, _) | (true, 0) => None,
                (true, -1) => {
                    return Err(err(
                        3,
                        "CORDM",
                        format!(
                            "CORDM = -1 (the element coordinate system) with the anisotropic MAT9 {}",
                            p.material
                        ),
                        "0 or blank (basic) or a rectangular CORD1R/CORD2R: femu does not form Nastran's element material systems",
                    ));
                }
                (true, cid) => {
                    let Some(frame) = geo.frames.get(&(cid as u64)) else {
                        return Err(err(
                            3,
                            "CORDM",
                            format!("coordinate system {cid} is not defined in the deck"),
                            "0 or blank (basic) or the id of a CORD1R or CORD2R card",
                        ));
                    };
                    if frame.kind != CordKind::Rectangular {
                        return Err(err(
                            3,
                            "CORDM",
                            format!(
                                "coordinate system {cid} is cylindrical or spherical: the material axes of MAT9 {} would vary over the mesh",
                                p.material
                            ),
                            "a rectangular CORD1R or CORD2R",
                        ));
                    }
                    (frame.axes != Frame::BASIC.axes).then_some(frame.axes)
                }
            };
            out.insert(
                id,
                SolidProperty {
                    material: p.material,
                    axes,
                },
            );
        }
        Ok(out)
    }
}

/// The first non-positive pivot (index, value) of the Cholesky factorisation of `a`, if any.
fn not_positive_definite(a: &[[f64; 6]; 6]) -> Option<(usize, f64)> {
    let scale = (0..6).map(|i| a[i][i].abs()).fold(0.0, f64::max);
    let mut l = [[0.0; 6]; 6];
    for j in 0..6 {
        let d = a[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        if !(d > 1e-12 * scale) {
            return Some((j, d));
        }
        l[j][j] = d.sqrt();
        for i in j + 1..6 {
            l[i][j] = (a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / l[j][j];
        }
    }
    None
}
