//! Rigid elements and multipoint constraints: RBE2, RBAR, RBE1, RROD, RBE3, MPC and MPCADD, as the
//! MSC Nastran Quick Reference Guide (QRG) defines them, turned into the model's
//! [`MultipointConstraint`]s (`u_dependent = Σ cᵢ uᵢ` over basic DOFs).
//!
//! Every card first gives equations `a · u_g = Σ cⱼ uⱼ`, one per dependent component (given in
//! the displacement system CD of grid `g`; `a` is that component's direction in basic, `u_g` the
//! grid's basic translations or rotations), in small rotations:
//! - RBE2 (GN, CM, GMi): `u_m = u_n + θ_n × (x_m − x_n)`, `θ_m = θ_n` for the CM components of
//!   each GMi.
//! - RBAR (GA, GB, CNA, CNB, CMA, CMB): the rigid motion `q = (u, θ)` at GA is solved from the
//!   six independent components CNA at GA and CNB at GB (they must determine it: a 6×6 system,
//!   else an error); the dependent components CMA, CMB (blank: every component not independent)
//!   follow from `q`.
//! - RBE1 (GNi/CNi, UM, GMi/CMi): RBAR's rule for any grids: the rigid motion `q` about GN1 is
//!   solved from the six independent components (a 6×6 system, else an error) and every
//!   dependent component follows from it.
//! - RROD (GA, GB, CMA or CMB): `e · (u_B − u_A) = 0` along the unit axis `e`; the one dependent
//!   translation must have a component along `e`.
//! - RBE3 (REFGRID, REFC, WTi, Ci, Gi,j): the reference grid moves with the rigid motion `q`
//!   that fits the independent motions in weighted least squares,
//!   `q = (Σ Gᵢᵀ Wᵢ Gᵢ)⁻¹ Σ Gᵢᵀ Wᵢ uᵢ`, with `Gᵢ` the rigid-body map from the reference to grid
//!   `i` (`u_i = u + θ × (x_i − x_ref)`, `θ_i = θ`), `Wᵢ` the weight WTi on each listed
//!   translation and WTi·L² on each listed rotation, `L` the mean distance of the independent
//!   grids from the reference grid (the QRG's remark on weighting rotations by a characteristic
//!   length, which makes the weights independent of the length unit; `L = 1` when every grid
//!   sits at the reference). The weighted components must determine all six rigid motions
//!   (else an error, e.g. collinear grids with translations only). UM fields are an error.
//! - MPC (SID, Gi, Ci, Ai): `Σ Aᵢ u_{Gi,Ci} = 0`, the first term dependent:
//!   `u₁ = −Σᵢ₌₂ (Aᵢ/A₁) uᵢ`; MPCADD unites sets; the case control's `MPC = n` selects one (no
//!   MPC is applied without a selection when the deck has case control, as in Nastran; a deck
//!   without case control applies every set, with a warning when there are several).
//!
//! The equations of each grid's translations (or rotations) are then solved together for basic
//! DOFs: with `A` the rows `a`, the basic components with the largest pivots (Gaussian elimination
//! with complete pivoting) become dependent, the others stay independent; for a CD parallel to
//! basic this is exactly the listed component. A component made dependent twice, a dependent DOF
//! that an SPC also constrains (Nastran's fatal "dependent DOF in SPC set") and a cycle of
//! dependencies are errors naming both cards; chains are left to the assembly, which substitutes
//! them in dependency order. ALPHA (thermal expansion) and TREF are ignored.

use super::*;
use crate::model::MultipointConstraint;

/// One rigid element as read.
pub(super) enum RigidCard {
    Rbe2 {
        gn: u64,
        cm: Vec<Component>,
        gm: Vec<u64>,
    },
    Rbar {
        ga: u64,
        gb: u64,
        cn: [Vec<Component>; 2],
        cm: [Vec<Component>; 2],
    },
    /// RBE1: independent grids with their components (six in all), dependent grids with theirs.
    Rbe1 {
        independent: Vec<(u64, Vec<Component>)>,
        dependent: Vec<(u64, Vec<Component>)>,
    },
    Rrod {
        ga: u64,
        gb: u64,
        /// The dependent grid (0: GA, 1: GB) and its component.
        dependent: (usize, Component),
    },
    Rbe3 {
        reference: u64,
        refc: Vec<Component>,
        groups: Vec<(f64, Vec<Component>, Vec<u64>)>,
    },
}

/// Rigid elements and MPC cards until the model is put together.
#[derive(Default)]
pub(super) struct RigidIn {
    elements: Vec<(Loc, u64, RigidCard)>,
    ids: BTreeMap<u64, Loc>,
    /// MPC equations: set id, card, terms (grid, component, coefficient).
    mpcs: Vec<(u64, Loc, MpcTerms)>,
    mpcadds: BTreeMap<u64, (Loc, Vec<u64>)>,
    /// `MPC = n` selections of the case control.
    pub(super) case_control: Vec<(Loc, u64)>,
    /// Whether the deck has a case control section.
    pub(super) has_case_control: bool,
}

/// The terms of one MPC card: grid, component, coefficient.
type MpcTerms = Vec<(u64, Component, f64)>;

/// Terms over basic DOFs (until [`in_displacement_systems`] turns them into the grids' own).
type Terms = Vec<(DofId, f64)>;

/// One equation `a · u_{node, triple} = Σ rhs` for the dependent component `comp` (in CD).
struct Equation {
    node: u64,
    comp: Component,
    a: [f64; 3],
    rhs: Vec<(DofId, f64)>,
    card: usize,
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Index 0–2 of a component within its triple, and whether it is a rotation.
fn split(c: Component) -> (usize, bool) {
    let n = c.nastran() as usize;
    if n <= 3 {
        (n - 1, false)
    } else {
        (n - 4, true)
    }
}

/// Basic DOF of `node`, triple `rot`, axis `k`.
fn basic(node: u64, rot: bool, k: usize) -> DofId {
    DofId::new(node, Component::ALL[k + if rot { 3 } else { 0 }])
}

/// Terms of `r · u_{node, triple}` over basic DOFs.
fn along(node: u64, rot: bool, r: [f64; 3]) -> Vec<(DofId, f64)> {
    (0..3)
        .filter(|&k| r[k] != 0.0)
        .map(|k| (basic(node, rot, k), r[k]))
        .collect()
}

/// The row of the rigid-body map `q = (u, θ)` at `base` → component along `r` (translation or
/// rotation) at a point `d` away: `r·u + (d × r)·θ`, or `r·θ`.
fn rigid_row(rot: bool, r: [f64; 3], d: [f64; 3]) -> [f64; 6] {
    if rot {
        [0.0, 0.0, 0.0, r[0], r[1], r[2]]
    } else {
        let t = cross(d, r);
        [r[0], r[1], r[2], t[0], t[1], t[2]]
    }
}

/// Inverse of a small square matrix (Gauss-Jordan, partial pivoting); `None` when a pivot is
/// below `1e-10` of the largest entry.
fn inverse(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let scale = a
        .iter()
        .flatten()
        .fold(0.0f64, |s, v| s.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let mut m: Vec<Vec<f64>> = a
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| if i == j { 1.0 } else { 0.0 }));
            r
        })
        .collect();
    for c in 0..n {
        let p = (c..n).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))?;
        if m[p][c].abs() <= 1e-10 * scale {
            return None;
        }
        m.swap(c, p);
        let pivot = m[c][c];
        for v in &mut m[c] {
            *v /= pivot;
        }
        let pivot_row = m[c].clone();
        for (r, row) in m.iter_mut().enumerate() {
            if r != c && row[c] != 0.0 {
                let f = row[c];
                for (x, p) in row.iter_mut().zip(&pivot_row) {
                    *x -= f * p;
                }
            }
        }
    }
    Some(m.into_iter().map(|r| r[n..].to_vec()).collect())
}

/// A finished-model error at a card.
fn at(loc: &Loc, problem: String, valid: &str) -> NastranError {
    NastranError::Syntax {
        file: loc.file.to_string().into(),
        line: loc.line,
        problem: problem.into(),
        valid: valid.into(),
    }
}

impl Builder {
    /// RBE2, RBAR, RROD, RBE3, MPC, MPCADD.
    pub(super) fn rigid_card(&mut self, c: &Card) -> Result<(), NastranError> {
        match c.name.as_str() {
            "MPC" => return self.mpc_card(c),
            "MPCADD" => return self.mpcadd_card(c),
            _ => {}
        }
        let eid = c.id(1, "EID")?;
        if let Some(first) = self.rigid.ids.get(&eid) {
            return Err(duplicate(c, 1, "EID", "rigid element", eid, first));
        }
        let card = match c.name.as_str() {
            "RBE2" => {
                let gn = c.id(2, "GN")?;
                let cm = c.comps(3, "CM")?;
                if cm.is_empty() {
                    return Err(c.err(3, "CM", "the field is blank", "components such as 123456"));
                }
                let mut last = c.fields.len();
                while last > 3 && c.blank(last) {
                    last -= 1;
                }
                // A trailing real is ALPHA (thermal expansion: no effect on modes).
                if last > 4 && c.text(last).contains('.') {
                    last -= 1;
                }
                let mut gm = Vec::new();
                let mut k = 4;
                while k <= last {
                    if c.word(k) == "THRU" {
                        let (Some(lo), Some(hi)) =
                            (gm.pop(), (k + 1..=last).find(|&j| !c.blank(j)))
                        else {
                            return Err(c.err(
                                k,
                                "GMi",
                                "THRU has no id on both sides",
                                "write `id1 THRU id2`",
                            ));
                        };
                        let hi_id = c.id(hi, "GMi")?;
                        gm.extend(lo..=hi_id);
                        k = hi + 1;
                        continue;
                    }
                    if !c.blank(k) {
                        gm.push(c.id(k, "GMi")?);
                    }
                    k += 1;
                }
                if gm.is_empty() {
                    return Err(c.err(
                        4,
                        "GM1",
                        "no dependent grid is listed",
                        "the ids of the dependent grids",
                    ));
                }
                RigidCard::Rbe2 { gn, cm, gm }
            }
            "RBAR" => {
                let (ga, gb) = (c.id(2, "GA")?, c.id(3, "GB")?);
                let cn = [c.comps(4, "CNA")?, c.comps(5, "CNB")?];
                let cm = [c.comps(6, "CMA")?, c.comps(7, "CMB")?];
                if cn[0].len() + cn[1].len() != 6 {
                    return Err(c.err(
                        4,
                        "CNA",
                        format!("CNA and CNB hold {} components", cn[0].len() + cn[1].len()),
                        "six independent components in all (the QRG's rule), e.g. CNA = 123456 and CNB blank",
                    ));
                }
                for (e, label) in [(0, "CMA"), (1, "CMB")] {
                    if let Some(x) = cm[e].iter().find(|x| cn[e].contains(x)) {
                        return Err(c.err(
                            6 + e,
                            label,
                            format!(
                                "component {} is also independent at the same grid",
                                x.nastran()
                            ),
                            "dependent components that are not in CNA (CNB) of the same grid",
                        ));
                    }
                }
                RigidCard::Rbar { ga, gb, cn, cm }
            }
            "RROD" => {
                let (ga, gb) = (c.id(2, "GA")?, c.id(3, "GB")?);
                let (cma, cmb) = (c.comps(4, "CMA")?, c.comps(5, "CMB")?);
                let dependent = match (cma.as_slice(), cmb.as_slice()) {
                    ([x], []) if x.nastran() <= 3 => (0, *x),
                    ([], [x]) if x.nastran() <= 3 => (1, *x),
                    _ => {
                        return Err(c.err(
                            4,
                            "CMA",
                            "RROD needs exactly one dependent translation, in CMA or in CMB",
                            "one of 1, 2 or 3 in CMA or CMB, the other blank",
                        ));
                    }
                };
                RigidCard::Rrod { ga, gb, dependent }
            }
            "RBE3" => self.rbe3_card(c)?,
            "RBE1" => rbe1_card(c)?,
            other => return self.unread(c, other, other),
        };
        self.rigid.ids.insert(eid, c.loc.clone());
        self.rigid.elements.push((c.loc.clone(), eid, card));
        Ok(())
    }

    fn rbe3_card(&mut self, c: &Card) -> Result<RigidCard, NastranError> {
        let reference = c.id(3, "REFGRID")?;
        let refc = c.comps(4, "REFC")?;
        if refc.is_empty() {
            return Err(c.err(4, "REFC", "the field is blank", "components such as 123456"));
        }
        let mut groups: Vec<(f64, Vec<Component>, Vec<u64>)> = Vec::new();
        let mut k = 5;
        let n = c.fields.len();
        while k <= n {
            if c.blank(k) {
                k += 1;
                continue;
            }
            let w = c.word(k);
            if w == "UM" {
                return Err(c.err(
                    k,
                    "UM",
                    "UM (a redefined dependent set) is not supported",
                    "leave out the UM fields: the REFC components of REFGRID are then dependent",
                ));
            }
            if w == "ALPHA" || w == "TREF" {
                break;
            }
            let is_int = parse_int(c.text(k)).is_some();
            match groups.last_mut() {
                Some((_, comps, grids)) if is_int && !comps.is_empty() => {
                    grids.push(c.id(k, "Gi,j")?)
                }
                Some((_, comps, _)) if is_int => {
                    *comps = c.comps(k, "Ci")?;
                }
                _ => {
                    let wt = c.real_or(k, "WTi", 0.0)?;
                    if !(wt > 0.0 && wt.is_finite()) {
                        return Err(c.err(
                            k,
                            "WTi",
                            format!("weight {wt} is not positive"),
                            "a real weight > 0 (e.g. 1.0)",
                        ));
                    }
                    groups.push((wt, Vec::new(), Vec::new()));
                }
            }
            k += 1;
        }
        if groups.is_empty() || groups.iter().any(|g| g.1.is_empty() || g.2.is_empty()) {
            return Err(c.err(
                5,
                "WT1",
                "a weight without components and grids",
                "groups of WTi (real), Ci (components) and the grids Gi,j",
            ));
        }
        Ok(RigidCard::Rbe3 {
            reference,
            refc,
            groups,
        })
    }

    fn mpc_card(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        let mut terms = Vec::new();
        let mut row = 0;
        while 8 * row + 2 <= c.fields.len() {
            for base in [8 * row + 2, 8 * row + 5] {
                if c.blank(base) && c.blank(base + 1) && c.blank(base + 2) {
                    continue;
                }
                let g = c.id(base, "Gi")?;
                let comp = c.comps(base + 1, "Ci")?;
                let [comp] = comp.as_slice() else {
                    return Err(c.err(
                        base + 1,
                        "Ci",
                        "not one grid component",
                        "one component 1-6 (scalar points are not supported)",
                    ));
                };
                let a = c.req_real(base + 2, "Ai")?;
                terms.push((g, *comp, a));
            }
            row += 1;
        }
        if terms.first().is_none_or(|t| t.2 == 0.0) {
            return Err(c.err(
                4,
                "A1",
                "the first coefficient is 0 or missing",
                "a non-zero A1: the first term is the dependent DOF",
            ));
        }
        self.rigid.mpcs.push((sid, c.loc.clone(), terms));
        Ok(())
    }

    fn mpcadd_card(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        let mut members = Vec::new();
        for k in 2..=c.fields.len() {
            if !c.blank(k) {
                members.push(c.id(k, "Si")?);
            }
        }
        if members.is_empty() {
            return Err(c.err(2, "S1", "no set is listed", "the ids of MPC sets"));
        }
        if let Some((first, _)) = self.rigid.mpcadds.get(&sid) {
            return Err(duplicate(c, 1, "SID", "MPCADD set", sid, first));
        }
        self.rigid.mpcadds.insert(sid, (c.loc.clone(), members));
        Ok(())
    }

    /// The MPC set ids in force, or an error for a selection of nothing.
    fn selected_mpc_sets(&mut self) -> Result<BTreeSet<u64>, NastranError> {
        let defined: BTreeSet<u64> = self.rigid.mpcs.iter().map(|m| m.0).collect();
        let Some((loc, sid)) = self.rigid.case_control.first().cloned() else {
            if self.rigid.has_case_control && !defined.is_empty() {
                self.warnings.push(format!(
                    "{}: the case control selects no MPC set (`MPC = n`), so no MPC card applies, as in Nastran",
                    self.top_file
                ));
                return Ok(BTreeSet::new());
            }
            if defined.len() > 1 {
                let list: Vec<String> = defined.iter().map(u64::to_string).collect();
                self.warnings.push(format!(
                    "{}: MPC sets {} are all applied (the deck has no case control `MPC = n` to choose one)",
                    self.top_file,
                    list.join(", ")
                ));
            }
            return Ok(defined);
        };
        match self.rigid.mpcadds.get(&sid) {
            Some((add, members)) => {
                if let Some(m) = members.iter().find(|m| !defined.contains(m)) {
                    return Err(at(
                        add,
                        format!("MPCADD {sid} lists set {m}, which no MPC card defines"),
                        "the set ids of MPC cards of the deck",
                    ));
                }
                Ok(members.iter().copied().collect())
            }
            None if defined.contains(&sid) => Ok(BTreeSet::from([sid])),
            None => Err(at(
                &loc,
                format!(
                    "the case control selects MPC = {sid}, which no MPC or MPCADD card defines"
                ),
                "the set id of an MPC or MPCADD card of the bulk data",
            )),
        }
    }

    /// Every rigid element and selected MPC as the model's multipoint constraints (after the
    /// SPCs are resolved, so that a dependent DOF also constrained is found here).
    pub(super) fn resolve_rigid(
        &mut self,
        model: &mut Model,
        geo: &Geometry,
    ) -> Result<(), NastranError> {
        let chosen = self.selected_mpc_sets()?;
        let rigid = std::mem::take(&mut self.rigid);
        let mut cards: Vec<(Loc, String)> = Vec::new();
        let mut eqs: Vec<Equation> = Vec::new();
        let pos = |loc: &Loc, g: u64| -> Result<[f64; 3], NastranError> {
            model.nodes.get(&g).copied().ok_or_else(|| {
                at(
                    loc,
                    format!("{} refers to grid {g}, which is not defined", loc.card),
                    "add the GRID or correct the grid id",
                )
            })
        };
        let dirs = |g: u64| -> [[f64; 3]; 3] {
            self.grid_directions(geo, g).1.unwrap_or([
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ])
        };
        // The equations of component `c` at `g` given the 6-vector `g_row` on the rigid motion
        // `q = Σ coefficients` (each q_i as terms).
        let from_q = |g: u64, c: Component, row: [f64; 6], q: &[Vec<(DofId, f64)>], card: usize| {
            let (k, rot) = split(c);
            let mut rhs: Vec<(DofId, f64)> = Vec::new();
            for (i, qi) in q.iter().enumerate() {
                if row[i] != 0.0 {
                    rhs.extend(qi.iter().map(|&(d, v)| (d, row[i] * v)));
                }
            }
            let _ = rot;
            Equation {
                node: g,
                comp: c,
                a: dirs(g)[k],
                rhs,
                card,
            }
        };
        for (loc, eid, card) in &rigid.elements {
            let id = cards.len();
            cards.push((loc.clone(), format!("{} {eid}", loc.card)));
            match card {
                RigidCard::Rbe2 { gn, cm, gm } => {
                    let xn = pos(loc, *gn)?;
                    let q: Vec<Vec<(DofId, f64)>> = (0..6)
                        .map(|i| vec![(DofId::new(*gn, Component::ALL[i]), 1.0)])
                        .collect();
                    for &m in gm {
                        let d = sub(pos(loc, m)?, xn);
                        if m == *gn {
                            return Err(at(
                                loc,
                                format!("RBE2 {eid}: grid {m} is both GN and a GMi"),
                                "list the independent grid GN only once, not among the dependent grids",
                            ));
                        }
                        for &c in cm {
                            let (k, rot) = split(c);
                            eqs.push(from_q(m, c, rigid_row(rot, dirs(m)[k], d), &q, id));
                        }
                    }
                }
                RigidCard::Rbar { ga, gb, cn, cm } => {
                    let grids = [*ga, *gb];
                    let x = [pos(loc, *ga)?, pos(loc, *gb)?];
                    let d = [[0.0; 3], sub(x[1], x[0])];
                    let independent: Vec<(u64, [f64; 3], [f64; 3], Component)> = (0..2)
                        .flat_map(|e| {
                            cn[e]
                                .iter()
                                .map(move |&c| (grids[e], d[e], dirs(grids[e])[split(c).0], c))
                        })
                        .collect();
                    let Some(q) = rigid_motion(&independent) else {
                        return Err(at(
                            loc,
                            format!(
                                "RBAR {eid}: the independent components CNA, CNB do not determine the bar's rigid motion"
                            ),
                            "independent components that fix all six rigid motions, e.g. CNA = 123456",
                        ));
                    };
                    for e in 0..2 {
                        let deps: Vec<Component> = if cm[0].is_empty() && cm[1].is_empty() {
                            Component::ALL
                                .iter()
                                .copied()
                                .filter(|c| !cn[e].contains(c))
                                .collect()
                        } else {
                            cm[e].clone()
                        };
                        for c in deps {
                            let (k, rot) = split(c);
                            eqs.push(from_q(
                                grids[e],
                                c,
                                rigid_row(rot, dirs(grids[e])[k], d[e]),
                                &q,
                                id,
                            ));
                        }
                    }
                }
                RigidCard::Rbe1 {
                    independent,
                    dependent,
                } => {
                    let origin = pos(loc, independent[0].0)?;
                    let mut rows: Vec<(u64, [f64; 3], [f64; 3], Component)> = Vec::new();
                    for (g, comps) in independent {
                        let d = sub(pos(loc, *g)?, origin);
                        for &c in comps {
                            rows.push((*g, d, dirs(*g)[split(c).0], c));
                        }
                    }
                    // The rigid motion about the first independent grid.
                    let Some(q) = rigid_motion(&rows) else {
                        return Err(at(
                            loc,
                            format!(
                                "RBE1 {eid}: the independent components CNi do not determine the element's rigid motion"
                            ),
                            "independent components that fix all six rigid motions, e.g. 123456 at one grid, or 123 at one grid, 23 at a second and 3 at a third not on their line",
                        ));
                    };
                    for (g, comps) in dependent {
                        let d = sub(pos(loc, *g)?, origin);
                        for &c in comps {
                            let (k, rot) = split(c);
                            eqs.push(from_q(*g, c, rigid_row(rot, dirs(*g)[k], d), &q, id));
                        }
                    }
                }
                RigidCard::Rrod { ga, gb, dependent } => {
                    let x = [pos(loc, *ga)?, pos(loc, *gb)?];
                    let axis = sub(x[1], x[0]);
                    let len = dot(axis, axis).sqrt();
                    if len == 0.0 {
                        return Err(at(
                            loc,
                            format!("RROD {eid}: GA and GB are at the same place"),
                            "grids at distinct positions",
                        ));
                    }
                    let e = axis.map(|v| v / len);
                    let (side, c) = *dependent;
                    let (g, other) = if side == 0 { (*ga, *gb) } else { (*gb, *ga) };
                    let (k, _) = split(c);
                    if dot(e, dirs(g)[k]).abs() < 1e-6 {
                        return Err(at(
                            loc,
                            format!(
                                "RROD {eid}: dependent component {} at grid {g} is perpendicular to the rod's axis",
                                c.nastran()
                            ),
                            "a dependent translation with a component along the axis from GA to GB",
                        ));
                    }
                    eqs.push(Equation {
                        node: g,
                        comp: c,
                        a: e,
                        rhs: along(other, false, e),
                        card: id,
                    });
                }
                RigidCard::Rbe3 {
                    reference,
                    refc,
                    groups,
                } => {
                    let xr = pos(loc, *reference)?;
                    let mut obs: Vec<([f64; 6], f64, Terms)> = Vec::new();
                    let mut dist = Vec::new();
                    for (_, _, grids) in groups {
                        for &g in grids {
                            if g == *reference {
                                return Err(at(
                                    loc,
                                    format!(
                                        "RBE3 {eid}: the reference grid {g} is also independent"
                                    ),
                                    "independent grids other than REFGRID",
                                ));
                            }
                            dist.push(dot(sub(pos(loc, g)?, xr), sub(pos(loc, g)?, xr)).sqrt());
                        }
                    }
                    let mean = dist.iter().sum::<f64>() / dist.len().max(1) as f64;
                    let l2 = if mean > 0.0 { mean * mean } else { 1.0 };
                    for (wt, comps, grids) in groups {
                        for &g in grids {
                            let d = sub(pos(loc, g)?, xr);
                            for &c in comps {
                                let (k, rot) = split(c);
                                let r = dirs(g)[k];
                                obs.push((
                                    rigid_row(rot, r, d),
                                    if rot { wt * l2 } else { *wt },
                                    along(g, rot, r),
                                ));
                            }
                        }
                    }
                    let mut n = vec![vec![0.0; 6]; 6];
                    for (gr, w, _) in &obs {
                        for i in 0..6 {
                            for j in 0..6 {
                                n[i][j] += w * gr[i] * gr[j];
                            }
                        }
                    }
                    let Some(ni) = inverse(&n) else {
                        return Err(at(
                            loc,
                            format!(
                                "RBE3 {eid}: the weighted components of the independent grids do not determine the reference grid's rigid motion"
                            ),
                            "independent grids and components that fix all six rigid motions (e.g. translations 123 at three or more grids not on one line)",
                        ));
                    };
                    let q: Vec<Vec<(DofId, f64)>> = (0..6)
                        .map(|i| {
                            obs.iter()
                                .flat_map(|(gr, w, terms)| {
                                    let f: f64 = (0..6).map(|j| ni[i][j] * gr[j]).sum::<f64>() * w;
                                    terms.iter().map(move |&(dd, c)| (dd, f * c))
                                })
                                .collect()
                        })
                        .collect();
                    for &c in refc {
                        let (k, rot) = split(c);
                        eqs.push(from_q(
                            *reference,
                            c,
                            rigid_row(rot, dirs(*reference)[k], [0.0; 3]),
                            &q,
                            id,
                        ));
                    }
                }
            }
        }
        for (sid, loc, terms) in rigid.mpcs.iter().filter(|m| chosen.contains(&m.0)) {
            let id = cards.len();
            cards.push((loc.clone(), format!("MPC {sid}")));
            let (g1, c1, a1) = terms[0];
            for &(g, _, _) in terms {
                pos(loc, g)?;
            }
            let (k1, rot1) = split(c1);
            let mut a = dirs(g1)[k1].map(|v| v * a1);
            let mut rhs = Vec::new();
            for &(g, c, ai) in &terms[1..] {
                let (k, rot) = split(c);
                let r = dirs(g)[k];
                if g == g1 && rot == rot1 {
                    for j in 0..3 {
                        a[j] += ai * r[j];
                    }
                } else {
                    rhs.extend(along(g, rot, r).into_iter().map(|(d, v)| (d, -ai * v)));
                }
            }
            if dot(a, dirs(g1)[k1]).abs() < 1e-12 * a1.abs() {
                return Err(at(
                    loc,
                    format!(
                        "MPC {sid}: the equation does not involve its dependent DOF {g1}:{}",
                        c1.nastran()
                    ),
                    "a first term whose coefficient does not cancel",
                ));
            }
            eqs.push(Equation {
                node: g1,
                comp: c1,
                a,
                rhs,
                card: id,
            });
        }
        let eqs = eqs
            .into_iter()
            .map(|e| in_displacement_systems(e, &model.displacement_systems))
            .collect();
        let mpcs = solve_equations(eqs, &cards)?;
        // A dependent DOF also constrained by an SPC: Nastran's fatal error.
        let spc: BTreeSet<DofId> = model.constraints.iter().copied().collect();
        for m in &mpcs {
            if spc.contains(&m.dependent) {
                let spc_loc = self
                    .spcs
                    .iter()
                    .find(|s| s.2.node == m.dependent.node)
                    .map_or_else(
                        || "an SPC".to_string(),
                        |s| format!("the SPC at {}", s.0.place()),
                    );
                let card = cards.iter().find(|c| c.1 == m.origin).map(|c| c.0.clone());
                let loc = card.unwrap_or_else(|| cards[0].0.clone());
                return Err(at(
                    &loc,
                    format!(
                        "{} makes DOF {} dependent, which {spc_loc} also constrains (Nastran's fatal \"dependent DOF in SPC set\")",
                        m.origin, m.dependent
                    ),
                    "remove the component from the SPC or from the rigid element / MPC",
                ));
            }
        }
        if mpcs.is_empty() {
            return Ok(());
        }
        // Cycles (and the other checks of multipoint constraints); any other dangling
        // reference is left to the model check, which names its card.
        let mut check = model.clone();
        check.mpcs = mpcs.clone();
        if let Err(
            e @ (ModelError::MpcCycle { .. }
            | ModelError::MpcNode { .. }
            | ModelError::MpcConstrained { .. }
            | ModelError::MpcDependentTwice { .. }),
        ) = check.validate()
        {
            return Err(at(
                &cards[0].0,
                e.to_string(),
                "correct the rigid elements and MPC cards named",
            ));
        }
        model.mpcs = mpcs;
        Ok(())
    }
}

/// Terms sorted by DOF, those of one DOF summed.
fn merged_terms(mut terms: Terms) -> Terms {
    terms.sort_by_key(|t| t.0);
    let mut merged: Terms = Vec::with_capacity(terms.len());
    for (d, v) in terms {
        match merged.last_mut() {
            Some(last) if last.0 == d => last.1 += v,
            _ => merged.push((d, v)),
        }
    }
    merged
}

/// An equation written over basic components, rewritten over the components of the grids'
/// displacement systems (the model's DOFs): `a · u_b = (R a) · u_local` on the left, and each
/// basic term `c u_b,j = c Σ_k R[k][j] u_local,k` on the right. Terms that cancel to round-off
/// (below 1e-14 of the largest coefficient, from `R Rᵀ = I` in floating point) are dropped, so
/// that a component written along its own axis stays one term.
fn in_displacement_systems(mut e: Equation, systems: &BTreeMap<u64, [[f64; 3]; 3]>) -> Equation {
    if systems.is_empty() {
        return e;
    }
    if let Some(r) = systems.get(&e.node) {
        let a = e.a;
        e.a = r.map(|row| dot(row, a));
        let big = e.a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for v in &mut e.a {
            if v.abs() <= 1e-14 * big {
                *v = 0.0;
            }
        }
    }
    let mut terms: Vec<(DofId, f64)> = Vec::with_capacity(e.rhs.len());
    for (d, c) in e.rhs {
        match systems.get(&d.node) {
            None => terms.push((d, c)),
            Some(r) => {
                let (j, rot) = split(d.comp);
                for (k, row) in r.iter().enumerate() {
                    if row[j] != 0.0 {
                        terms.push((basic(d.node, rot, k), c * row[j]));
                    }
                }
            }
        }
    }
    let mut merged = merged_terms(terms);
    let big = merged.iter().fold(0.0f64, |m, t| m.max(t.1.abs()));
    merged.retain(|t| t.1.abs() > 1e-14 * big);
    e.rhs = merged;
    e
}

/// The equations of each grid's translations (rotations) solved together for dependent
/// DOFs (complete pivoting), in grid order; a component given twice is an error naming both cards.
fn solve_equations(
    eqs: Vec<Equation>,
    cards: &[(Loc, String)],
) -> Result<Vec<MultipointConstraint>, NastranError> {
    let mut groups: BTreeMap<(u64, bool), Vec<Equation>> = BTreeMap::new();
    for e in eqs {
        let rot = split(e.comp).1;
        let list = groups.entry((e.node, rot)).or_default();
        if let Some(first) = list.iter().find(|f| f.comp == e.comp) {
            return Err(at(
                &cards[e.card].0,
                format!(
                    "DOF {}:{} is dependent in both {} ({}) and {}; a DOF may be dependent in one rigid element or MPC only",
                    e.node,
                    e.comp.nastran(),
                    cards[first.card].1,
                    cards[first.card].0.place(),
                    cards[e.card].1
                ),
                "make the DOF dependent in one card only (make it independent in the other)",
            ));
        }
        list.push(e);
    }
    let mut out = Vec::new();
    for ((node, rot), mut list) in groups {
        // Own-triple terms move to the left: a_k · u = rhs_k.
        for e in &mut list {
            let own: Vec<(usize, f64)> = e
                .rhs
                .iter()
                .filter(|(d, _)| d.node == node && (d.comp.nastran() > 3) == rot)
                .map(|(d, c)| (split(d.comp).0, *c))
                .collect();
            for (k, c) in own {
                e.a[k] -= c;
            }
            e.rhs
                .retain(|(d, _)| !(d.node == node && (d.comp.nastran() > 3) == rot));
        }
        let p = list.len();
        // Complete pivoting on the p×3 matrix A: the pivot columns become dependent.
        let mut a: Vec<[f64; 3]> = list.iter().map(|e| e.a).collect();
        let scale = a.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
        let mut pivots: Vec<usize> = Vec::new();
        let mut rows_left: Vec<usize> = (0..p).collect();
        for _ in 0..p {
            let mut best = (0usize, 0usize, 0.0f64);
            for &r in &rows_left {
                for c in (0..3).filter(|c| !pivots.contains(c)) {
                    if a[r][c].abs() > best.2 {
                        best = (r, c, a[r][c].abs());
                    }
                }
            }
            if best.2 <= 1e-10 * scale.max(f64::MIN_POSITIVE) {
                let e = &list[rows_left[0]];
                return Err(at(
                    &cards[e.card].0,
                    format!(
                        "the dependent components at grid {node} ({}) are not independent of each other",
                        cards[e.card].1
                    ),
                    "dependent components that can be solved for",
                ));
            }
            let (r, c, _) = best;
            rows_left.retain(|&x| x != r);
            for &o in &rows_left {
                let f = a[o][c] / a[r][c];
                let pr = a[r];
                for j in 0..3 {
                    a[o][j] -= f * pr[j];
                }
            }
            pivots.push(c);
        }
        let free: Vec<usize> = (0..3).filter(|c| !pivots.contains(c)).collect();
        // u_P = A_P⁻¹ (rhs − A_F u_F) with the original rows.
        let ap: Vec<Vec<f64>> = list
            .iter()
            .map(|e| pivots.iter().map(|&c| e.a[c]).collect())
            .collect();
        let inv = inverse(&ap).ok_or_else(|| {
            at(
                &cards[list[0].card].0,
                format!("the dependent components at grid {node} are singular"),
                "dependent components that can be solved for",
            )
        })?;
        for (i, &c) in pivots.iter().enumerate() {
            let mut terms: Vec<(DofId, f64)> = Vec::new();
            for (k, e) in list.iter().enumerate() {
                let f = inv[i][k];
                if f == 0.0 {
                    continue;
                }
                terms.extend(e.rhs.iter().map(|&(d, v)| (d, f * v)));
                for &fc in &free {
                    if e.a[fc] != 0.0 {
                        terms.push((basic(node, rot, fc), -f * e.a[fc]));
                    }
                }
            }
            let mut merged = merged_terms(terms);
            merged.retain(|t| t.1 != 0.0);
            // The card of the equation with the largest weight on this pivot.
            let card = (0..list.len())
                .max_by(|&x, &y| inv[i][x].abs().total_cmp(&inv[i][y].abs()))
                .unwrap_or(0);
            out.push(MultipointConstraint {
                dependent: basic(node, rot, c),
                terms: merged,
                origin: cards[list[card].card].1.clone(),
            });
        }
    }
    out.sort_by_key(|m| m.dependent);
    Ok(out)
}

/// RBE1 (EID, GNi/CNi pairs, `UM`, GMi/CMi pairs, ALPHA, TREF): the pairs are read in order,
/// blanks skipped (the QRG leaves the first field of each continuation blank); a real after
/// the dependent pairs starts ALPHA and TREF (no effect on modes).
fn rbe1_card(c: &Card) -> Result<RigidCard, NastranError> {
    let (mut independent, mut dependent) = (Vec::new(), Vec::new());
    let mut after_um = false;
    let mut k = 2;
    let n = c.fields.len();
    while k <= n {
        if c.blank(k) {
            k += 1;
            continue;
        }
        if c.word(k) == "UM" {
            if after_um {
                return Err(c.err(
                    k,
                    "UM",
                    "UM is given twice",
                    "one UM before the dependent pairs",
                ));
            }
            after_um = true;
            k += 1;
            continue;
        }
        if after_um && c.text(k).contains('.') {
            break;
        }
        let (grid_field, comp_field) = if after_um {
            ("GMi", "CMi")
        } else {
            ("GNi", "CNi")
        };
        let g = c.id(k, grid_field)?;
        let comps = if k < n {
            c.comps(k + 1, comp_field)?
        } else {
            Vec::new()
        };
        if comps.is_empty() {
            return Err(c.err(
                k + 1,
                comp_field,
                format!("grid {g} has no components"),
                "components such as 123 after each grid",
            ));
        }
        if after_um {
            dependent.push((g, comps));
        } else {
            independent.push((g, comps));
        }
        k += 2;
    }
    let count: usize = independent.iter().map(|(_, cs)| cs.len()).sum();
    if count != 6 {
        return Err(c.err(
            3,
            "CN1",
            format!("the CNi hold {count} components"),
            "six independent components in all (the QRG's rule), e.g. GN1 = 1, CN1 = 123456",
        ));
    }
    if dependent.is_empty() {
        return Err(c.err(
            2,
            "UM",
            "no dependent grid follows UM",
            "`UM` on a continuation, then GM1 CM1 (grid and components) pairs",
        ));
    }
    for (g, cs) in &dependent {
        for (h, ns) in &independent {
            if let Some(x) = cs.iter().find(|x| g == h && ns.contains(x)) {
                return Err(c.err(
                    2,
                    "CMi",
                    format!(
                        "component {} of grid {g} is both independent and dependent",
                        x.nastran()
                    ),
                    "dependent components that are not among the same grid's CNi",
                ));
            }
        }
    }
    Ok(RigidCard::Rbe1 {
        independent,
        dependent,
    })
}

/// The rigid motion `q = S⁻¹ v` (six sums over basic DOFs) that independent components fix:
/// each row is a grid, its offset from the motion's origin, the component's direction in basic
/// and the component; `S` holds their rigid-body rows, `v` their displacements. `None` when
/// they do not determine the motion (`S` singular or not 6×6).
fn rigid_motion(rows: &[(u64, [f64; 3], [f64; 3], Component)]) -> Option<Vec<Terms>> {
    if rows.len() != 6 {
        return None;
    }
    let mut s: Vec<Vec<f64>> = Vec::new();
    let mut v: Vec<Terms> = Vec::new();
    for &(g, d, r, c) in rows {
        let (_, rot) = split(c);
        s.push(rigid_row(rot, r, d).to_vec());
        v.push(along(g, rot, r));
    }
    let si = inverse(&s)?;
    Some(
        (0..6)
            .map(|i| {
                let mut t = Vec::new();
                for (j, vj) in v.iter().enumerate() {
                    t.extend(vj.iter().map(|&(dd, c)| (dd, si[i][j] * c)));
                }
                t
            })
            .collect(),
    )
}
