//! Rod cards: CROD with PROD, CTUBE with PTUBE, and CONROD (a rod with its section inline).
//!
//! QRG meaning: a rod has axial stiffness `E A / L` and torsional stiffness `G J / L` only; `C`
//! is the torsional stress coefficient (stress recovery, no effect on `K` or `M`) and `NSM` a
//! mass per length. PTUBE gives the outer diameter `OD` and wall thickness `T` of a circular
//! tube (T blank or 0: a solid rod), converted as Nastran does to `A = π (OD − T) T` and the
//! polar moment `J = π (OD⁴ − ID⁴) / 32`, `ID = OD − 2T`. A tapered tube (OD2 ≠ OD) has OD
//! linear from end A to end B at constant T, its `A(x)`, `J(x)` from the same formulas
//! (`crate::fe::beam_tapered::tapered_rod2`); `area`/`j` hold end A's.
//! CROD must name a PROD and CTUBE a PTUBE (checked once every card is read); PID defaults to
//! EID on both. CONROD has no property id: its section stays with the element (it is in no
//! `pid<N>` set; updating parameters reach it through a SET1 of element ids, as Nastran's
//! DVPREL on a CONROD addresses the element).

use super::*;
use crate::model::structure::{RodProperty, RodSection, TubeTaper};

/// What a valid PTUBE T is.
const PTUBE_T: &str = "0 <= T <= OD/2 (blank or 0: a solid rod)";

impl Builder {
    /// CROD and CTUBE: `EID PID G1 G2`.
    pub(super) fn rod_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let property = c.id_or(2, "PID", id)?;
        let [g1, g2] = rod_grids(c, 3)?;
        self.new_element(
            c,
            id,
            ElemIn::Done(Element::Rod {
                nodes: [g1, g2],
                section: RodSection::Property(property),
            }),
        )
    }

    /// CONROD: `EID G1 G2 MID A J C NSM`.
    pub(super) fn conrod(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "EID")?;
        let [g1, g2] = rod_grids(c, 2)?;
        let section = rod_section(c, 4)?;
        self.new_element(
            c,
            id,
            ElemIn::Done(Element::Rod {
                nodes: [g1, g2],
                section: RodSection::Own(section),
            }),
        )
    }

    /// PROD: `PID MID A J C NSM`.
    pub(super) fn prod(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let p = rod_section(c, 2)?;
        self.new_property(c, 1, "PID", id)?;
        self.rods.insert(id, p);
        Ok(())
    }

    /// PTUBE: `PID MID OD T NSM OD2`.
    pub(super) fn ptube(&mut self, c: &Card) -> Result<(), NastranError> {
        let id = c.id(1, "PID")?;
        let material = c.id(2, "MID")?;
        let od = c.positive(3, "OD")?;
        let t = c.real_or(4, "T", 0.0)?;
        if !(0.0..=0.5 * od).contains(&t) {
            return Err(c.err(
                4,
                "T",
                format!("wall thickness {t} is not in [0, OD/2 = {}]", 0.5 * od),
                PTUBE_T,
            ));
        }
        let nsm = c.nonneg_real(5, "NSM", 0.0)?;
        // OD2 blank (or 0, as some writers leave it) is OD: a uniform tube.
        let od2 = c.real_or(6, "OD2", od)?;
        let od2 = if od2 == 0.0 { od } else { od2 };
        if od2 < 0.0 || !(0.0..=0.5 * od2).contains(&t) {
            return Err(c.err(
                6,
                "OD2",
                format!("OD2 = {od2} with wall thickness T = {t}"),
                "OD2 > 0 with T <= OD2/2 (blank: OD)",
            ));
        }
        let taper = (od2 != od).then_some(TubeTaper {
            od_a: od,
            od_b: od2,
            t,
        });
        let (area, j) = tube_section(od, t);
        self.new_property(c, 1, "PID", id)?;
        self.rods.insert(
            id,
            RodProperty {
                material,
                area,
                j,
                c: 0.0,
                nsm,
                taper,
            },
        );
        self.tube_pids.insert(id);
        Ok(())
    }

    /// Every CROD names a PROD and every CTUBE a PTUBE of the deck (before the model is built).
    pub(super) fn check_rod_properties(&self) -> Result<(), NastranError> {
        for (loc, e) in self.elements.values() {
            let ElemIn::Done(Element::Rod {
                section: RodSection::Property(pid),
                ..
            }) = e
            else {
                continue;
            };
            let tube = &*loc.card == "CTUBE";
            let (wanted, other) = if tube {
                ("PTUBE", "PROD")
            } else {
                ("PROD", "PTUBE")
            };
            let problem = if !self.rods.contains_key(pid) {
                format!("property {pid} is not a {wanted} of the deck")
            } else if self.tube_pids.contains(pid) != tube {
                format!("property {pid} is a {other}, not a {wanted}")
            } else {
                continue;
            };
            return Err(loc.field_err(
                2,
                "PID",
                problem,
                format!("the id of a {wanted} card (blank: the element id)"),
            ));
        }
        Ok(())
    }
}

/// The two distinct end grids at fields `k`, `k + 1`.
fn rod_grids(c: &Card, k: usize) -> Result<[u64; 2], NastranError> {
    let g1 = c.id(k, "G1")?;
    let g2 = c.id(k + 1, "G2")?;
    if g1 == g2 {
        return Err(c.err(
            k + 1,
            "G2",
            format!("G2 is G1 ({g1})"),
            "the two end grids must differ",
        ));
    }
    Ok([g1, g2])
}

/// `MID A J C NSM` from field `k` (PROD, CONROD).
fn rod_section(c: &Card, k: usize) -> Result<RodProperty, NastranError> {
    Ok(RodProperty {
        material: c.id(k, "MID")?,
        area: c.positive(k + 1, "A")?,
        j: c.nonneg_real(k + 2, "J", 0.0)?,
        c: c.real_or(k + 3, "C", 0.0)?,
        nsm: c.nonneg_real(k + 4, "NSM", 0.0)?,
        taper: None,
    })
}

/// Area and polar moment of a circular tube of outer diameter `od` and wall `t` (0: solid).
pub(super) fn tube_section(od: f64, t: f64) -> (f64, f64) {
    TubeTaper::section(od, t)
}
