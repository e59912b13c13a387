//! The model builder: what each card contributes before the model is put together, and
//! the dispatch of cards to their readers.

use super::*;

pub(super) struct GridIn {
    pub(super) loc: Loc,
    pub(super) cp: u64,
    pub(super) x: [f64; 3],
    pub(super) cd: i64,
    pub(super) ps: Vec<Component>,
}

pub(super) struct CordIn {
    pub(super) loc: Loc,
    pub(super) rid: u64,
    pub(super) points: [[f64; 3]; 3],
}

pub(super) enum Orient {
    Vector([f64; 3]),
    G0(u64),
}

pub(super) enum ElemIn {
    Done(Element),
    Beam {
        nodes: [u64; 2],
        property: u64,
        orient: Orient,
    },
    Celas1 {
        pid: u64,
        dof: DofId,
        other: Option<DofId>,
    },
    Bush {
        pid: u64,
        node: u64,
        other: Option<u64>,
    },
    MassAbsolute {
        node: u64,
        mass: f64,
        inertia: [f64; 6],
        cg: [f64; 3],
    },
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
    pub(super) materials: BTreeMap<u64, (Loc, Material)>,
    pub(super) shells: BTreeMap<u64, ShellProperty>,
    pub(super) beams: BTreeMap<u64, BeamProperty>,
    pub(super) pelas: BTreeMap<u64, f64>,
    pub(super) pbush: BTreeMap<u64, [f64; 6]>,
    pub(super) pids: BTreeMap<u64, Loc>,
    pub(super) elements: BTreeMap<u64, (Loc, ElemIn)>,
    pub(super) spcs: Vec<(Loc, DofId)>,
    pub(super) spc_ranges: Vec<(Loc, Vec<Component>, u64, u64)>,
    pub(super) spc_sids: BTreeSet<u64>,
    pub(super) sets: BTreeMap<u64, SetIn>,
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

pub(super) const OFFSET_HELP: &str = "offsets and pin flags are not supported: leave them blank or 0 and place the grid points on the axis";

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
            "CORD2R" => self.cord2r(c),
            "CQUAD4" | "CTRIA3" => self.shell_element(c),
            "CBAR" | "CBEAM" => self.beam_element(c),
            "PSHELL" => self.pshell(c),
            "PBAR" => self.pbar(c),
            "PBARL" => self.pbarl(c),
            "PBEAM" => self.pbeam(c),
            "MAT1" => self.mat1(c),
            "CELAS1" | "CELAS2" => self.celas(c),
            "PELAS" => self.pelas_card(c),
            "CBUSH" => self.cbush(c),
            "PBUSH" => self.pbush_card(c),
            "CONM2" => self.conm2(c),
            "SPC" => self.spc(c),
            "SPC1" => self.spc1(c),
            "SET1" => self.set1(c),
            "PARAM" => self.param(c),
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
        Err(NastranError::Syntax {
            file: c.loc.file.to_string().into(),
            line: c.loc.line,
            problem: format!(
                "{} is not read by femu and may change the stiffness, mass or constraints, so the deck cannot be imported as it is",
                q(key)
            )
            .into(),
            valid: format!(
                "femu reads {}; it skips loads, analysis and output cards ({}, …) and PARAM {}; to drop {} knowingly, add it to the stage's `ignore_cards`",
                READ_CARDS.join(", "),
                SKIPPED_CARDS[..6].join(", "),
                SKIPPED_PARAMS.join(", "),
                q(key)
            )
            .into(),
        })
    }

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
        if name == "WTMASS" {
            let w = c.real_or(2, "V1", 1.0)?;
            if w != 1.0 {
                return Err(c.err(
                    2,
                    "V1",
                    format!("WTMASS {w} scales the mass matrix, which femu does not implement"),
                    "remove PARAM,WTMASS and write masses and densities in consistent (SI) units, or set it to 1.0",
                ));
            }
        } else if !SKIPPED_PARAMS.contains(&name.as_str()) {
            return self.unread(c, &key, "PARAM");
        }
        *self.skipped.entry(key).or_insert(0) += 1;
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
