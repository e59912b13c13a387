//! The model builder: what each card contributes before the model is put together, and
//! the dispatch of cards to their readers.

use super::*;

#[derive(Clone, Copy)]
pub(super) enum Orient {
    Vector([f64; 3]),
    G0(u64),
}

pub(super) enum ElemIn {
    Done(Element),
    /// CBAR/CBEAM; a blank PID, orientation or OFFT takes the BAROR/BEAMOR default.
    Beam {
        eid: u64,
        beam: bool,
        nodes: [u64; 2],
        property: Option<u64>,
        orient: Option<Orient>,
        ends: BeamEndsIn,
    },
    /// Scalar elements, CONM1, CVISC and CBUSH (scalars.rs).
    Scalar(super::scalars::ScalarIn),
    /// CONM2 with CID > 0: offset and inertia along the system's directions at the grid.
    MassInSystem {
        node: u64,
        mass: f64,
        inertia: [f64; 6],
        offset: [f64; 3],
        cid: u64,
    },
    MassAbsolute {
        node: u64,
        mass: f64,
        inertia: [f64; 6],
        cg: [f64; 3],
    },
}

/// CBAR/CBEAM offsets and pins as the card gives them: OFFT (`None` when blank), WA, WB in
/// the systems OFFT names, PA/PB digit codes.
pub(super) struct BeamEndsIn {
    pub(super) offt: Option<[u8; 3]>,
    pub(super) wa: [f64; 3],
    pub(super) wb: [f64; 3],
    pub(super) pins: [u32; 2],
}

/// BAROR/BEAMOR: defaults for blank CBAR/CBEAM PID, orientation and OFFT.
pub(super) struct BeamDefaults {
    pub(super) loc: Loc,
    pub(super) pid: Option<u64>,
    pub(super) orient: Option<Orient>,
    pub(super) offt: Option<[u8; 3]>,
}

pub(super) struct SetIn {
    pub(super) loc: Loc,
    pub(super) ids: Vec<u64>,
    pub(super) ranges: Vec<(u64, u64)>,
}

#[derive(Default)]
pub(super) struct Builder {
    pub(super) top_file: Rc<str>,
    pub(super) warnings: Vec<String>,
    /// Card names the user accepts to drop.
    pub(super) ignore: BTreeSet<String>,
    pub(super) skipped: BTreeMap<String, usize>,
    pub(super) ignored: BTreeMap<String, usize>,
    pub(super) grids: BTreeMap<u64, GridIn>,
    pub(super) cords: BTreeMap<u64, CordIn>,
    pub(super) grdset: Option<GridDefaults>,
    /// PARAM,WTMASS: where, and the factor applied to every mass.
    pub(super) wtmass: Option<(Loc, f64)>,
    /// PARAM,GRDPNT: where, and the reference grid (0: the basic origin).
    pub(super) grdpnt: Option<(Loc, u64)>,
    /// Cards femu does not read that may change the model: count and first place, by name.
    pub(super) unsupported: BTreeMap<String, (usize, Loc)>,
    /// What to do with them.
    pub(super) on_unsupported: Unsupported,
    pub(super) materials: BTreeMap<u64, (Loc, Material)>,
    pub(super) shells: BTreeMap<u64, ShellProperty>,
    pub(super) beams: BTreeMap<u64, BeamProperty>,
    /// PROD and PTUBE properties; the ids of the PTUBEs.
    pub(super) rods: BTreeMap<u64, crate::model::structure::RodProperty>,
    pub(super) tube_pids: BTreeSet<u64>,
    /// PSOLID cards and MAT9 materials (solids.rs).
    pub(super) solids: BTreeMap<u64, super::solids::SolidIn>,
    pub(super) mat9s: BTreeMap<u64, (Loc, crate::model::structure::AnisotropicMaterial)>,
    /// Whether the PSHELL MID3-blank deviation has been stated (once per deck).
    pub(super) mid3_blank_warned: bool,
    /// PBARL/PBEAML turned to principal axes: property id → angle (rad) of the elements' turn.
    pub(super) beam_turns: BTreeMap<u64, f64>,
    /// BAROR and BEAMOR defaults.
    pub(super) baror: Option<BeamDefaults>,
    pub(super) beamor: Option<BeamDefaults>,
    pub(super) pelas: BTreeMap<u64, f64>,
    pub(super) pbush: BTreeMap<u64, [f64; 6]>,
    pub(super) pids: BTreeMap<u64, Loc>,
    pub(super) elements: BTreeMap<u64, (Loc, ElemIn)>,
    /// Single-point constraints with their set id (`None`: a GRID's PS, always applied).
    pub(super) spcs: Vec<(Loc, Option<u64>, DofId)>,
    pub(super) spc_ranges: Vec<(Loc, u64, Vec<Component>, u64, u64)>,
    pub(super) spc_sids: BTreeSet<u64>,
    /// SPCADD: set id → (card, the SPC/SPC1 set ids it unites).
    pub(super) spcadds: BTreeMap<u64, (Loc, Vec<u64>)>,
    /// `SPC = n` selections of the case control.
    pub(super) case_control: Vec<(Loc, u64)>,
    /// `METHOD = n` selections of the case control, and the EIGRL cards (eigrl.rs).
    pub(super) case_control_method: Vec<(Loc, u64)>,
    pub(super) eigrls: super::eigrl::Eigrls,
    pub(super) sets: BTreeMap<u64, SetIn>,
    /// Rigid elements and MPC cards (rigid.rs).
    pub(super) rigid: super::rigid::RigidIn,
    /// MAT2/MAT8 and shell placements (laminates.rs).
    pub(super) laminates: super::laminates::LaminatesIn,
    /// Scalar points and the properties of scalar elements (scalars.rs).
    pub(super) scalars: super::scalars::ScalarsIn,
}

/// The error for an id (data field `k`, always on the card's first line) defined twice.
pub(super) fn duplicate(
    card: &Card,
    k: usize,
    label: &'static str,
    what: &'static str,
    id: u64,
    first: &Loc,
) -> NastranError {
    NastranError::Duplicate {
        file: card.loc.file.to_string().into(),
        line: card.loc.line,
        card: card.name.as_str().into(),
        field: k + 1,
        label,
        what,
        id,
        first: first.place().into(),
    }
}

impl Builder {
    pub(super) fn warn(&mut self, loc: &Loc, id: u64, text: impl std::fmt::Display) {
        self.warnings.push(format!(
            "{} line {}: {} {id}: {text}",
            loc.file, loc.line, loc.card
        ));
    }

    pub(super) fn card(&mut self, c: &Card) -> Result<(), NastranError> {
        match c.name.as_str() {
            "GRID" => self.grid(c),
            "CORD2R" | "CORD2C" | "CORD2S" => self.cord2(c),
            "CORD1R" | "CORD1C" | "CORD1S" => self.cord1(c),
            "GRDSET" => self.grdset(c),
            "CQUAD4" | "CTRIA3" | "CQUADR" | "CTRIAR" => self.shell_element(c),
            "PCOMP" | "PCOMPG" => self.pcomp(c),
            "MAT2" => self.mat2(c),
            "MAT8" => self.mat8(c),
            "CQUAD8" | "CTRIA6" => self.quadratic_shell(c),
            "CBAR" | "CBEAM" => self.beam_element(c),
            "BAROR" | "BEAMOR" => self.beam_defaults(c),
            "PSHELL" => self.pshell(c),
            "PBAR" => self.pbar(c),
            "PBARL" => self.pbarl(c),
            "PBEAM" => self.pbeam(c),
            "CROD" | "CTUBE" => self.rod_element(c),
            "CONROD" => self.conrod(c),
            "PROD" => self.prod(c),
            "PTUBE" => self.ptube(c),
            "PBEAML" => self.pbeaml(c),
            "CHEXA" | "CPENTA" | "CTETRA" | "CPYRAM" => self.solid_element(c),
            "PSOLID" => self.psolid(c),
            "MAT9" => self.mat9(c),
            "MAT1" => self.mat1(c),
            "CELAS1" | "CELAS2" | "CELAS3" | "CELAS4" | "CMASS1" | "CMASS2" | "CMASS3"
            | "CMASS4" | "CDAMP1" | "CDAMP2" | "CDAMP3" | "CDAMP4" => self.scalar_element(c),
            "SPOINT" | "EPOINT" => self.spoint(c),
            "PMASS" | "PDAMP" => self.pmass_pdamp(c),
            "PVISC" => self.pvisc(c),
            "CVISC" => self.cvisc(c),
            "CONM1" => self.conm1(c),
            "CDAMP5" => self.cdamp5(c),
            "PELAS" => self.pelas_card(c),
            "CBUSH" => self.cbush(c),
            "PBUSH" => self.pbush_card(c),
            "CONM2" => self.conm2(c),
            "SPC" => self.spc(c),
            "SPC1" => self.spc1(c),
            "SPCADD" => self.spcadd(c),
            "SET1" => self.set1(c),
            "RBE2" | "RBAR" | "RBE1" | "RROD" | "RBE3" | "MPC" | "MPCADD" => self.rigid_card(c),
            "PARAM" => self.param(c),
            "EIGRL" => self.eigrl(c),
            other if SKIPPED_CARDS.contains(&other) => {
                *self.skipped.entry(other.to_string()).or_insert(0) += 1;
                Ok(())
            }
            other => self.unread(c, other, other),
        }
    }

    /// A card femu does not read: dropped when the user asked for it, else an error.
    pub(super) fn unread(&mut self, c: &Card, key: &str, name: &str) -> Result<(), NastranError> {
        if self.ignore.contains(key) || self.ignore.contains(name) {
            *self.ignored.entry(key.to_string()).or_insert(0) += 1;
            return Ok(());
        }
        if !(c.nastran_like || is_known_card(name)) {
            return Err(not_nastran(&c.loc.file, c.loc.line));
        }
        let entry = self
            .unsupported
            .entry(key.to_string())
            .or_insert_with(|| (0, c.loc.clone()));
        entry.0 += 1;
        Ok(())
    }

    /// After every card is read: the cards femu does not read that may change the stiffness,
    /// mass or constraints, all listed with their counts and first lines, as one error; or, when
    /// the user chose to proceed ([`Unsupported::Warn`]), dropped with one warning.
    pub(super) fn check_unsupported(&mut self) -> Result<(), NastranError> {
        if self.unsupported.is_empty() {
            return Ok(());
        }
        let total: usize = self.unsupported.values().map(|(n, _)| n).sum();
        let list: Vec<String> = self
            .unsupported
            .iter()
            .map(|(k, (n, loc))| format!("{} ×{n} (first at {})", q(k), loc.place()))
            .collect();
        if self.on_unsupported == Unsupported::Warn {
            for (k, (n, _)) in std::mem::take(&mut self.unsupported) {
                *self.ignored.entry(k).or_insert(0) += n;
            }
            self.warnings.push(format!(
                "{}: {total} card(s) femu does not read were dropped as `on_unsupported: warn` asks; the model lacks what they define: {}",
                self.top_file,
                list.join(", ")
            ));
            return Ok(());
        }
        Err(NastranError::Unsupported {
            file: self.top_file.to_string().into(),
            count: total,
            cards: list.join(", ").into(),
            valid: format!(
                "femu reads {}; it skips loads, analysis and output cards ({}, …) and PARAM {}; to drop cards knowingly, list them in the stage's `ignore_cards` or set `on_unsupported: warn`",
                READ_CARDS.join(", "),
                SKIPPED_CARDS[..6].join(", "),
                SKIPPED_PARAMS.join(", "),
            )
            .into(),
        })
    }

    /// PARAM: WTMASS is applied, GRDPNT read, parameters whose effect femu reproduces or
    /// replaces are accepted with a warning saying how, output-only ones are skipped (and only
    /// they are counted in `skipped_cards`), any other is unread.
    pub(super) fn param(&mut self, c: &Card) -> Result<(), NastranError> {
        let name = c.word(1);
        if !is_card_name(&name) {
            return Err(c.err(
                1,
                "N",
                format!("`{}` is not a parameter name", q(&name)),
                "a name of at most 8 letters and digits, starting with a letter",
            ));
        }
        let key = format!("PARAM,{name}");
        match name.as_str() {
            "WTMASS" => {
                let w = c.real_or(2, "V1", 1.0)?;
                if !(w > 0.0 && w.is_finite()) {
                    return Err(c.err(
                        2,
                        "V1",
                        format!("WTMASS {w} is not a positive factor"),
                        "a real number > 0 (the factor from the deck's mass units to consistent mass units)",
                    ));
                }
                if let Some((first, _)) = &self.wtmass {
                    return Err(c.err(
                        1,
                        "N",
                        format!("WTMASS is given twice (first at {})", first.place()),
                        "one PARAM,WTMASS per deck",
                    ));
                }
                if w != 1.0 {
                    self.warnings.push(format!(
                        "{} line {}: PARAM,WTMASS,{w} is applied: every density, non-structural mass and CONM2 mass and inertia is multiplied by it",
                        c.loc.file, c.loc.line
                    ));
                }
                self.wtmass = Some((c.loc.clone(), w));
            }
            "GRDPNT" => {
                let v = c.int(2, "V1")?.unwrap_or(-1);
                if v >= 0 {
                    self.grdpnt = Some((c.loc.clone(), v as u64));
                }
            }
            "COUPMASS" => {
                let v = c.int(2, "V1")?.unwrap_or(-1);
                let nastran = if v > 0 {
                    "coupled (consistent)"
                } else {
                    "lumped"
                };
                self.warnings.push(format!(
                    "{} line {}: PARAM,COUPMASS,{v}: Nastran would use {nastran} mass; femu uses the mass formulation named by the assembling stage's `mass` parameter (`consistent` or `lumped`)",
                    c.loc.file, c.loc.line
                ));
            }
            "AUTOSPC" => {
                if c.word(2) == "NO" {
                    self.warnings.push(format!(
                        "{} line {}: PARAM,AUTOSPC,NO: femu always constrains DOFs that no element stiffens (as AUTOSPC,YES does)",
                        c.loc.file, c.loc.line
                    ));
                }
            }
            "K6ROT" => {
                let v = c.real_or(2, "V1", 100.0)?;
                self.warnings.push(format!(
                    "{} line {}: PARAM,K6ROT,{v}: femu's shells tie the normal rotation by their own drilling penalty (docs/theory.md, shell element), not by K6ROT",
                    c.loc.file, c.loc.line
                ));
            }
            "G" => {
                let v = c.real_or(2, "V1", 0.0)?;
                if v != 0.0 {
                    self.warnings.push(format!(
                        "{} line {}: PARAM,G,{v} (structural damping) does not change the modes; for frequency responses set the synthesis stage's `damping` (e.g. a structural loss factor)",
                        c.loc.file, c.loc.line
                    ));
                }
            }
            // Output only: counted as skipped.
            _ if SKIPPED_PARAMS.contains(&name.as_str()) => {
                *self.skipped.entry(key).or_insert(0) += 1;
            }
            _ => return self.unread(c, &key, "PARAM"),
        }
        Ok(())
    }

    pub(super) fn new_element(&mut self, c: &Card, id: u64, e: ElemIn) -> Result<(), NastranError> {
        if let Some((first, _)) = self.elements.get(&id) {
            return Err(duplicate(c, 1, "EID", "element", id, first));
        }
        self.elements.insert(id, (c.loc.clone(), e));
        Ok(())
    }

    pub(super) fn new_property(
        &mut self,
        c: &Card,
        k: usize,
        label: &'static str,
        id: u64,
    ) -> Result<(), NastranError> {
        if let Some(first) = self.pids.get(&id) {
            return Err(duplicate(c, k, label, "property", id, first));
        }
        self.pids.insert(id, c.loc.clone());
        Ok(())
    }
}
