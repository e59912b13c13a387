//! Scalar points and scalar elements: SPOINT, EPOINT, CELAS1–4 (with PELAS), CMASS1–4 (with
//! PMASS), CDAMP1–4 (with PDAMP), CVISC (with PVISC), CONM1, and the CBUSH element system (CID,
//! orientation vector or G0) with the PBUSH B line (QRG meanings).
//!
//! A scalar point is one DOF without position (`id:s`); its component on a card is 0 or blank.
//! EPOINT (extra points) only matter to transfer functions and direct-response equations,
//! which femu does not read: they are taken as scalar points, which no element connects unless
//! the deck says so, so they are dropped like unconnected DOFs. A scalar element's ends are
//! checked once every point is known: a grid takes components 1–6, a scalar point 0 or blank.

use super::*;
use crate::model::structure::Element;

/// What the scalar cards contribute before the model is put together.
#[derive(Default)]
pub(super) struct ScalarsIn {
    /// Scalar point id → its first card.
    pub(super) points: BTreeMap<u64, Loc>,
    pub(super) pmass: BTreeMap<u64, f64>,
    pub(super) pdamp: BTreeMap<u64, f64>,
    pub(super) pvisc: BTreeMap<u64, (f64, f64)>,
    /// PBUSH B lines by property id.
    pub(super) pbush_b: BTreeMap<u64, [f64; 6]>,
}

/// The three scalar element families.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum ScalarKind {
    Spring,
    Mass,
    Damper,
}

/// A value given on the element (CELAS2, CMASS2, …) or through a property (CELAS1, …).
pub(super) enum Value {
    Given(f64),
    Property(u64),
}

/// One end of a scalar element: the point, its component (`Scalar` for 0 or blank) and the
/// field number of the point on the card.
#[derive(Clone, Copy)]
pub(super) struct End {
    pub(super) dof: DofId,
    pub(super) field: usize,
    /// Whether the card has a component field after the point (CxxxS1/2 do, 3/4 do not).
    pub(super) has_comp: bool,
}

/// How a CBUSH's element system is given.
pub(super) enum BushSystem {
    /// CID ≥ 0.
    Cid(u64),
    /// CID blank, an orientation vector or G0.
    Orient(Orient),
    /// CID blank and no orientation.
    None,
}

/// A scalar-family element as read.
pub(super) enum ScalarIn {
    Scalar {
        kind: ScalarKind,
        value: Value,
        a: End,
        b: Option<End>,
    },
    Conm1 {
        node: u64,
        cid: u64,
        m: [f64; 21],
    },
    Cvisc {
        pid: u64,
        nodes: [u64; 2],
    },
    Bush {
        pid: u64,
        node: u64,
        other: Option<u64>,
        system: BushSystem,
    },
}

impl Builder {
    /// SPOINT/EPOINT: ids, with `THRU` ranges.
    pub(super) fn spoint(&mut self, c: &Card) -> Result<(), NastranError> {
        let (ids, ranges) = c.id_list(1, "IDi")?;
        if ids.is_empty() && ranges.is_empty() {
            return Err(c.err(
                1,
                "ID1",
                "no point is listed",
                "scalar point ids, optionally with THRU",
            ));
        }
        if let Some((lo, hi)) = ranges.iter().find(|(lo, hi)| hi - lo > 10_000_000) {
            return Err(c.err(
                1,
                "IDi",
                format!("{lo} THRU {hi} defines more than 10^7 scalar points"),
                "a range of at most 10^7 ids",
            ));
        }
        let all = ids
            .into_iter()
            .chain(ranges.into_iter().flat_map(|(lo, hi)| lo..=hi));
        for id in all {
            self.scalars
                .points
                .entry(id)
                .or_insert_with(|| c.loc.clone());
        }
        Ok(())
    }

    /// One end `(G, C)` at fields `kg`, `kg + 1` (`scalar_only`: CELAS3/4, CMASS3/4, CDAMP3/4
    /// name scalar points and have no C field); `None` for a blank or 0 point (ground).
    fn scalar_end(
        c: &Card,
        kg: usize,
        lg: &str,
        lc: &str,
        scalar_only: bool,
    ) -> Result<Option<End>, NastranError> {
        let Some(g) = c.opt_grid(kg, lg)? else {
            return Ok(None);
        };
        let comp = if scalar_only || c.blank(kg + 1) || c.text(kg + 1) == "0" {
            Component::Scalar
        } else {
            c.one_comp(kg + 1, lc)?
        };
        Ok(Some(End {
            dof: DofId::new(g, comp),
            field: kg,
            has_comp: !scalar_only,
        }))
    }

    /// SPC/SPC1 components: digits 1–6 for grids, 0 or blank for a scalar point.
    pub(super) fn spc_comps(
        c: &Card,
        k: usize,
        label: &str,
    ) -> Result<Vec<Component>, NastranError> {
        if c.blank(k) || c.text(k) == "0" {
            return Ok(vec![Component::Scalar]);
        }
        c.comps(k, label)
    }

    /// CELASi, CMASSi, CDAMPi (i = 1–4).
    pub(super) fn scalar_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let name = c.name.as_str();
        let id = c.id(1, "EID")?;
        let kind = match &name[..5] {
            "CELAS" => ScalarKind::Spring,
            "CMASS" => ScalarKind::Mass,
            _ => ScalarKind::Damper,
        };
        let form = name.as_bytes()[name.len() - 1] - b'0';
        let (label, what) = match kind {
            ScalarKind::Spring => ("K", "a stiffness >= 0"),
            ScalarKind::Mass => ("M", "a mass >= 0"),
            ScalarKind::Damper => ("B", "a damping >= 0"),
        };
        let value = if form % 2 == 1 {
            Value::Property(c.id_or(2, "PID", id)?)
        } else {
            if kind == ScalarKind::Spring && c.blank(2) {
                return Err(c.err(2, label, "the field is blank", what));
            }
            Value::Given(c.nonneg_real(2, label, 0.0)?)
        };
        let scalar_only = form >= 3;
        let (a, b) = if scalar_only {
            (
                Self::scalar_end(c, 3, "S1", "", true)?,
                Self::scalar_end(c, 4, "S2", "", true)?,
            )
        } else {
            (
                Self::scalar_end(c, 3, "G1", "C1", false)?,
                Self::scalar_end(c, 5, "G2", "C2", false)?,
            )
        };
        let (a, b) = match (a, b) {
            (Some(a), b) => (a, b),
            (None, Some(b)) => (b, None),
            (None, None) => {
                return Err(c.err(
                    3,
                    if scalar_only { "S1" } else { "G1" },
                    "neither point is given",
                    "at least one grid or scalar point id",
                ));
            }
        };
        if let Some(b) = b
            && b.dof == a.dof
        {
            return Err(c.err(
                b.field,
                if scalar_only { "S2" } else { "G2" },
                format!("both ends are DOF {}", a.dof),
                "two different DOFs, or one and blank for ground",
            ));
        }
        if kind == ScalarKind::Spring && form == 2 {
            if c.real_or(7, "GE", 0.0)? != 0.0 {
                self.warn(&c.loc, id, "damping GE is ignored");
            }
            c.real(8, "S")?;
        }
        self.new_element(
            c,
            id,
            ElemIn::Scalar(ScalarIn::Scalar { kind, value, a, b }),
        )
    }

    /// PMASS and PDAMP: up to four `(PID, value)` pairs.
    pub(super) fn pmass_pdamp(&mut self, c: &Card) -> Result<(), NastranError> {
        let mass = c.name == "PMASS";
        let (vl, what) = if mass {
            ("M", "a mass >= 0")
        } else {
            ("B", "a damping >= 0")
        };
        for i in 0..4 {
            let k = 1 + 2 * i;
            if i > 0 && c.blank(k) && c.blank(k + 1) {
                continue;
            }
            let labels = ["PID1", "PID2", "PID3", "PID4"];
            let id = c.id(k, labels[i])?;
            let vlabel = format!("{vl}{}", i + 1);
            if c.blank(k + 1) {
                return Err(c.err(k + 1, &vlabel, "the field is blank", what));
            }
            let v = c.nonneg_real(k + 1, &vlabel, 0.0)?;
            self.new_property(c, k, labels[i], id)?;
            if mass {
                self.scalars.pmass.insert(id, v);
            } else {
                self.scalars.pdamp.insert(id, v);
            }
        }
        Ok(())
    }

    /// PVISC: up to two `(PID, CE, CR)` triples.
    pub(super) fn pvisc(&mut self, c: &Card) -> Result<(), NastranError> {
        for (i, k) in [1usize, 5].into_iter().enumerate() {
            if i > 0 && (k..k + 3).all(|j| c.blank(j)) {
                continue;
            }
            let label = ["PID1", "PID2"][i];
            let id = c.id(k, label)?;
            let ce = c.nonneg_real(k + 1, "CE", 0.0)?;
            let cr = c.nonneg_real(k + 2, "CR", 0.0)?;
            self.new_property(c, k, label, id)?;
            self.scalars.pvisc.insert(id, (ce, cr));
        }
        Ok(())
    }

    /// CVISC: EID, PID, G1, G2.
    pub(super) fn cvisc(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let pid = c.id_or(2, "PID", id)?;
        let g1 = c.id(3, "G1")?;
        let g2 = c.id(4, "G2")?;
        if g1 == g2 {
            return Err(c.err(4, "G2", format!("G2 is G1 ({g1})"), "a different grid"));
        }
        self.new_element(
            c,
            id,
            ElemIn::Scalar(ScalarIn::Cvisc {
                pid,
                nodes: [g1, g2],
            }),
        )
    }

    /// CDAMP5 (heat transfer) and other cards femu refuses with a reason.
    pub(super) fn cdamp5(&mut self, c: &Card) -> Result<(), NastranError> {
        Err(c.err(
            1,
            "EID",
            "CDAMP5 is a heat-transfer (thermal capacitance) element",
            "a structural damper: CDAMP1-4 or CVISC",
        ))
    }

    /// CONM1: EID, G, CID, then M11, M21, M22, …, M66 (lower triangle by rows).
    pub(super) fn conm1(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let node = c.id(2, "G")?;
        let cid = c.nonneg(3, "CID", "a coordinate system id, 0 or blank for basic")?;
        let mut m = [0.0; 21];
        let mut k = 0;
        for i in 1..=6 {
            for j in 1..=i {
                m[k] = c.real_or(4 + k, &format!("M{i}{j}"), 0.0)?;
                if i == j && m[k] < 0.0 {
                    return Err(c.err(
                        4 + k,
                        &format!("M{i}{j}"),
                        format!("{} is negative", m[k]),
                        "a diagonal mass or inertia >= 0",
                    ));
                }
                k += 1;
            }
        }
        self.new_element(c, id, ElemIn::Scalar(ScalarIn::Conm1 { node, cid, m }))
    }

    /// The element as the model holds it, its points checked and its systems resolved.
    pub(super) fn resolve_scalar(
        &self,
        model: &Model,
        geo: &Geometry,
        loc: &Loc,
        e: ScalarIn,
    ) -> Result<Element, NastranError> {
        match e {
            ScalarIn::Scalar { kind, value, a, b } => {
                for end in std::iter::once(a).chain(b) {
                    self.check_end(loc, end)?;
                }
                let v = match value {
                    Value::Given(v) => v,
                    Value::Property(pid) => {
                        let (map, card) = match kind {
                            ScalarKind::Spring => (&self.pelas, "PELAS"),
                            ScalarKind::Mass => (&self.scalars.pmass, "PMASS"),
                            ScalarKind::Damper => (&self.scalars.pdamp, "PDAMP"),
                        };
                        *map.get(&pid).ok_or_else(|| {
                            loc.field_err(
                                2,
                                "PID",
                                format!("property {pid} is not a {card}"),
                                format!("the id of a {card} card"),
                            )
                        })?
                    }
                };
                // Components of the grids' displacement systems, as the model's DOFs are.
                let (dof, other) = (a.dof, b.map(|b| b.dof));
                Ok(match kind {
                    ScalarKind::Spring => Element::ScalarSpring { dof, other, k: v },
                    ScalarKind::Mass => Element::ScalarMass { dof, other, m: v },
                    ScalarKind::Damper => Element::ScalarDamper { dof, other, c: v },
                })
            }
            ScalarIn::Cvisc { pid, nodes } => {
                let &(axial, torsional) = self.scalars.pvisc.get(&pid).ok_or_else(|| {
                    loc.field_err(
                        2,
                        "PID",
                        format!("property {pid} is not a PVISC"),
                        "the id of a PVISC card",
                    )
                })?;
                Ok(Element::Viscous {
                    nodes,
                    axial,
                    torsional,
                })
            }
            ScalarIn::Conm1 { node, cid, m } => {
                if cid == 0 {
                    return Ok(Element::GeneralMass { node, m });
                }
                let (Some(frame), Some(at)) = (geo.frames.get(&cid), model.nodes.get(&node)) else {
                    return Err(loc.field_err(
                        3,
                        "CID",
                        format!("coordinate system {cid} is not defined in the deck"),
                        "0 or blank (basic) or the id of a CORD1R/C/S or CORD2R/C/S card",
                    ));
                };
                Ok(Element::GeneralMass {
                    node,
                    m: rotate_general_mass(&frame.directions_at(*at), &m),
                })
            }
            ScalarIn::Bush {
                pid,
                node,
                other,
                system,
            } => {
                let Some(&k) = self.pbush.get(&pid) else {
                    return Err(loc.field_err(
                        2,
                        "PID",
                        format!("property {pid} is not a PBUSH"),
                        "the id of a PBUSH card",
                    ));
                };
                let b = self.scalars.pbush_b.get(&pid).copied().unwrap_or([0.0; 6]);
                let axes = self.bush_axes(model, geo, loc, node, other, system)?;
                Ok(Element::Bush {
                    node,
                    other,
                    k,
                    axes,
                    b,
                })
            }
        }
    }

    /// An end's point exists as a grid or scalar point and its component fits it.
    fn check_end(&self, loc: &Loc, end: End) -> Result<(), NastranError> {
        let id = end.dof.node;
        let scalar = self.scalars.points.contains_key(&id);
        let grid = self.grids.contains_key(&id);
        let (cf, cl) = if end.has_comp {
            (end.field + 1, "C")
        } else {
            (end.field, "S")
        };
        match (grid, scalar, end.dof.comp.is_scalar()) {
            (false, false, _) => Err(loc.field_err(
                end.field,
                "G",
                format!("point {id} is neither a GRID nor a scalar point (SPOINT/EPOINT)"),
                "the id of a GRID, SPOINT or EPOINT of the deck",
            )),
            (true, _, true) => Err(loc.field_err(
                cf,
                cl,
                format!("grid {id} is given component 0 or blank, or is named where the card takes scalar points only"),
                "a grid takes one component 1-6 (CELAS3/4, CMASS3/4 and CDAMP3/4 connect scalar points only: use CELAS1/2, CMASS1/2, CDAMP1/2 for grids)",
            )),
            (false, true, false) => Err(loc.field_err(
                cf,
                cl,
                format!("scalar point {id} is given component {}", end.dof.comp.nastran()),
                "0 or blank for a scalar point",
            )),
            _ => Ok(()),
        }
    }

    /// The element axes of a CBUSH (QRG): CID's axes (a curvilinear CID evaluated at GA); else
    /// x from GA to GB and y in the plane of x and the orientation vector; `None` for the basic
    /// axes (CID 0, or CID and orientation blank with a warning).
    fn bush_axes(
        &self,
        model: &Model,
        geo: &Geometry,
        loc: &Loc,
        node: u64,
        other: Option<u64>,
        system: BushSystem,
    ) -> Result<Option<[[f64; 3]; 3]>, NastranError> {
        let at = |g: u64| model.nodes.get(&g).copied();
        let coincide = match (at(node), other.and_then(at)) {
            (Some(a), Some(b)) => norm(sub(b, a)) < 1e-4,
            _ => true,
        };
        match system {
            BushSystem::Cid(0) => Ok(None),
            BushSystem::Cid(cid) => {
                let (Some(frame), Some(x)) = (geo.frames.get(&cid), at(node)) else {
                    return Err(loc.field_err(
                        8,
                        "CID",
                        format!("coordinate system {cid} is not defined in the deck"),
                        "blank, 0 (basic) or the id of a CORD1R/C/S or CORD2R/C/S card",
                    ));
                };
                Ok(Some(frame.directions_at(x)))
            }
            BushSystem::None | BushSystem::Orient(_) if coincide => Err(loc.field_err(
                8,
                "CID",
                "CID is blank, but GB is blank or within 1e-4 of GA, so GA-GB gives no element x axis",
                "a coordinate system id (0 for basic) in CID, as Nastran requires for a grounded or zero-length bush",
            )),
            BushSystem::None => Ok(None),
            BushSystem::Orient(o) => {
                let (Some(a), Some(b)) = (at(node), other.and_then(at)) else {
                    return Ok(None);
                };
                let v = match self.orient_in_basic(geo, node, o) {
                    Orient::Vector(v) => v,
                    Orient::G0(g0) => {
                        let p = at(g0).ok_or_else(|| {
                            loc.field_err(
                                5,
                                "G0",
                                format!("orientation grid {g0} is not defined"),
                                "G0 must be a GRID of the deck",
                            )
                        })?;
                        sub(p, a)
                    }
                };
                let x = sub(b, a);
                let z = cross(x, v);
                if norm(z) <= 1e-9 * norm(x) * norm(v) {
                    return Err(loc.field_err(
                        5,
                        "X1/G0",
                        format!("orientation vector {v:?} is zero or parallel to GA->GB"),
                        "a vector (or G0 direction) not parallel to GA->GB, or a CID",
                    ));
                }
                let y = cross(z, x);
                let unit = |w: [f64; 3]| {
                    let n = norm(w);
                    [w[0] / n, w[1] / n, w[2] / n]
                };
                Ok(Some([unit(x), unit(y), unit(z)]))
            }
        }
    }

    /// SPC/SPC1 on scalar points: THRU ranges given component 0 or blank expanded over the
    /// scalar points, and every constraint's component checked against its point.
    pub(super) fn scalar_constraints(&mut self) -> Result<(), NastranError> {
        let mut kept = Vec::new();
        for (loc, sid, comps, lo, hi) in std::mem::take(&mut self.spc_ranges) {
            if comps == [Component::Scalar] {
                for (&p, _) in self.scalars.points.range(lo..=hi) {
                    self.spcs
                        .push((loc.clone(), Some(sid), DofId::new(p, Component::Scalar)));
                }
            } else {
                kept.push((loc, sid, comps, lo, hi));
            }
        }
        self.spc_ranges = kept;
        for (loc, _, d) in &self.spcs {
            let scalar = self.scalars.points.contains_key(&d.node);
            let problem = match (scalar, d.comp.is_scalar()) {
                (true, false) => format!(
                    "scalar point {} is constrained in component {}",
                    d.node,
                    d.comp.nastran()
                ),
                (false, true) if self.grids.contains_key(&d.node) => {
                    format!("grid {} is constrained with component 0 or blank", d.node)
                }
                _ => continue,
            };
            let k = if &*loc.card == "SPC1" { 2 } else { 3 };
            return Err(loc.field_err(
                k,
                "C",
                problem,
                "components 1-6 for a grid, 0 or blank for a scalar point (SPOINT/EPOINT)",
            ));
        }
        Ok(())
    }

    /// The scalar points into the model; an id that is also a GRID is an error at the SPOINT.
    pub(super) fn place_scalar_points(&self, model: &mut Model) -> Result<(), NastranError> {
        for (&id, loc) in &self.scalars.points {
            if let Some(g) = self.grids.get(&id) {
                return Err(loc.field_err(
                    1,
                    "ID",
                    format!("{id} is also a GRID (at {})", g.loc.place()),
                    "grid and scalar point ids must be unique (Nastran's rule)",
                ));
            }
            model.scalar_points.insert(id);
        }
        Ok(())
    }
}

/// PARAM,WTMASS on the scalar-family masses.
pub(super) fn wtmass_scalars(e: &mut Element, w: f64) {
    match e {
        Element::ScalarMass { m, .. } => *m *= w,
        Element::GeneralMass { m, .. } => {
            for v in m.iter_mut() {
                *v *= w;
            }
        }
        _ => {}
    }
}

/// A CONM1 matrix given along local directions `d` (rows, basic) at the grid, in basic:
/// `M_b = Tᵀ M T` with `T = diag(D, D)` (`u_local = D u_basic`).
#[allow(clippy::needless_range_loop)] // index arithmetic over the lower triangle
fn rotate_general_mass(d: &[[f64; 3]; 3], lower: &[f64; 21]) -> [f64; 21] {
    let mut m = [[0.0; 6]; 6];
    let mut k = 0;
    for i in 0..6 {
        for j in 0..=i {
            m[i][j] = lower[k];
            m[j][i] = lower[k];
            k += 1;
        }
    }
    let t = |r: usize, c: usize| {
        if r / 3 == c / 3 { d[r % 3][c % 3] } else { 0.0 }
    };
    let mut out = [0.0; 21];
    let mut k = 0;
    for i in 0..6 {
        for j in 0..=i {
            let mut s = 0.0;
            for a in 0..6 {
                for b in 0..6 {
                    s += t(a, i) * m[a][b] * t(b, j);
                }
            }
            out[k] = s;
            k += 1;
        }
    }
    out
}
