//! Writes an updated model back into the user's own Nastran deck: only the cards whose values
//! changed are rewritten, every other line of every file keeps its bytes.
//!
//! What changes, by the parameter kinds of docs/theory.md §2:
//! - shell thickness → PSHELL `T`; Young's modulus and density (of shells, beams, rods, solids)
//!   → MAT1 `E` and `RHO`, density of a solid's MAT9 → MAT9 `RHO` (with `G`
//!   kept consistent, `E = 2(1 + ν)G`, when the card gives it; `RHO` divided by `PARAM,WTMASS`);
//!   beam width and height → PBARL/PBEAML `BAR` `DIM1`/`DIM2` (not of a tapered beam: a
//!   changed section of a PBEAM/PBEAML with stations, or of a tapered PTUBE, is an error
//!   naming the card, which is left as it was);
//! - bush stiffness → PBUSH `K1`–`K6`, scalar spring stiffness → CELAS2 `K` or PELAS `K1`/`K2`;
//! - lumped mass → CONM2 `M` and `I11`/`I22`/`I33` (divided by WTMASS);
//! - laminates: shell thickness → every ply's `Ti` (and an explicit `Z0`) of the PCOMP/PCOMPG,
//!   scaled together; Young's modulus and density of a MAT8/MAT2 → `E1`, `E2`, `G12`, `G1Z`,
//!   `G2Z` (blank ones stay blank) or `G11`–`G33` in proportion, and `RHO`.
//! - lumped mass → CONM2 `M` and `I11`/`I22`/`I33` (divided by WTMASS); scalar mass → CMASS2/
//!   CMASS4 `M`, or the PMASS `Mi` of a CMASS1/CMASS3 when every element using it changed
//!   alike (divided by WTMASS; else an error: a PMASS copy is not written).
//!
//! When an update gave part of a shared property (or material, PBUSH, PELAS) its own value, the
//! model holds a copy under a new id: the deck gets a copy of the original card, placed right
//! after it, under an id no card of its kind uses, and the elements of the set (or the
//! properties) name it. Every rewritten or added card is in large-field format; a value is
//! written in the shortest form that reads back to the same `f64` when that fits 16
//! characters, else rounded to the most significant digits that fit (at least 10), which is
//! what Nastran reads. INCLUDE statements are kept but point at the written files, which are all
//! given plain names side by side (see [`UpdatedDeck::files`]).
//!
//! Before a field is changed its current value is compared with the model the update started
//! from; a deck that does not hold the model's value (another deck, or one edited since) is an
//! error naming the card, file and line.

use crate::model::export::nastran::format_real;
use crate::model::import::nastran::{Deck, DeckCard, parse_real};
use crate::model::laminates::{Laminate, ShellMaterial};
use crate::model::structure::{BeamSection, Element, Material, Model, RodSection, ShellProperty};
use std::collections::{BTreeMap, BTreeSet};

/// One field changed (or one card added), for the comment block and the stage's record.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DeckChange {
    /// File (as opened) and line of the card in the original deck.
    pub file: String,
    /// Line of the card's first line.
    pub line: usize,
    /// Card name and id, e.g. `PSHELL 3`.
    pub card: String,
    /// Field label, or `new card` for a copy.
    pub field: String,
    /// The text before.
    pub old: String,
    /// The text written.
    pub new: String,
}

/// The written deck.
#[derive(Clone, Debug, PartialEq)]
pub struct UpdatedDeck {
    /// Each file of the deck under a plain name (the top file first): the original file name,
    /// made unique by a numeric prefix when two files share one.
    pub files: Vec<(String, Vec<u8>)>,
    /// Every change, in deck order.
    pub changes: Vec<DeckChange>,
}

/// Why a deck could not be updated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DeckUpdateError {
    /// The model names something the deck has no card for.
    #[error(
        "the deck has no {what} {id}, which the model holds; give the deck the mesh was imported from"
    )]
    Missing {
        /// `MAT1`, `property`, `element`.
        what: &'static str,
        /// Its id.
        id: u64,
    },
    /// The model is not the deck's.
    #[error(
        "the model does not come from this deck: its {what} differ ({detail}); give the deck the mesh was imported from"
    )]
    OtherModel {
        /// `grids` or `elements`.
        what: &'static str,
        /// The first ids that differ.
        detail: String,
    },
    /// A card's value differs from the model the update started from.
    #[error(
        "{file} line {line}: {card} {field} is {found} in the deck but {expected} in the model the update started from; give the deck the mesh was imported from (unedited)"
    )]
    Mismatch {
        /// File.
        file: String,
        /// Line.
        line: usize,
        /// Card name and id.
        card: String,
        /// Field label.
        field: String,
        /// The deck's text.
        found: String,
        /// The model's value.
        expected: f64,
    },
    /// A change femu cannot express on this card.
    #[error("{file} line {line}: {card}: {problem}")]
    Unsupported {
        /// File.
        file: String,
        /// Line.
        line: usize,
        /// Card name and id.
        card: String,
        /// What cannot be written.
        problem: String,
    },
}

/// Relative agreement required between a deck value and the model's (the import's own
/// arithmetic, e.g. WTMASS scaling, is exact to a few ulps).
const AGREE: f64 = 1e-9;

/// Material cards sharing Nastran's material id space.
fn is_material(name: &str) -> bool {
    matches!(
        name,
        "MAT1" | "MAT2" | "MAT3" | "MAT8" | "MAT9" | "MAT10" | "MAT11"
    )
}

/// Property cards sharing Nastran's property id space (PELAS holds two).
fn is_property(name: &str) -> bool {
    matches!(
        name,
        "PSHELL"
            | "PCOMP"
            | "PCOMPG"
            | "PBAR"
            | "PBARL"
            | "PBEAM"
            | "PBEAML"
            | "PROD"
            | "PTUBE"
            | "PBUSH"
            | "PBUSH1D"
            | "PELAS"
            | "PDAMP"
            | "PMASS"
            | "PVISC"
            | "PGAP"
            | "PSOLID"
            | "PSHEAR"
            | "PWELD"
            | "PFAST"
    )
}

/// Element cards sharing Nastran's element id space.
fn is_element(name: &str) -> bool {
    name.starts_with('C') && !name.starts_with("CORD") && !matches!(name, "CONV" | "CONVM")
}

/// A real of at most 16 characters: the shortest exact form when it fits, else rounded.
pub fn real16(x: f64) -> String {
    let exact = format_real(x);
    if exact.len() <= 16 {
        return exact;
    }
    for digits in (1..16).rev() {
        let rounded: f64 = format!("{x:.*e}", digits - 1).parse().unwrap_or(x);
        let s = format_real(rounded);
        if s.len() <= 16 {
            return s;
        }
    }
    exact
}

/// Elements whose stiffness lives on a property card: id, old and new stiffness.
type SpringUsers = Vec<(u64, [f64; 6], [f64; 6])>;
/// Field texts by QRG field number.
type FieldTexts = BTreeMap<usize, String>;
/// Per file: the first line of each rewritten card → the card and its changed fields.
type Rewrites = BTreeMap<usize, (usize, FieldTexts)>;
/// Per file: a line → copies of cards to insert after it.
type Insertions = BTreeMap<usize, Vec<(usize, FieldTexts)>>;

/// Pending edits of one card: new field texts by QRG field number, and an optional new id.
#[derive(Clone, Debug, Default)]
struct Edit {
    fields: BTreeMap<usize, (String, String)>,
}

/// A copy of a card to insert after it.
#[derive(Clone, Debug)]
struct CardCopy {
    source: usize,
    fields: BTreeMap<usize, String>,
    why: String,
}

struct Writer<'a> {
    deck: &'a Deck,
    wtmass: f64,
    materials: BTreeMap<u64, usize>,
    properties: BTreeMap<u64, usize>,
    elements: BTreeMap<u64, usize>,
    edits: BTreeMap<usize, Edit>,
    copies: Vec<CardCopy>,
    used_materials: BTreeSet<u64>,
    used_properties: BTreeSet<u64>,
}

fn card_id(c: &DeckCard, k: usize) -> Option<u64> {
    c.field(k)
        .parse::<i64>()
        .ok()
        .filter(|v| *v > 0)
        .map(|v| v as u64)
}

impl<'a> Writer<'a> {
    fn new(deck: &'a Deck) -> Self {
        let mut w = Writer {
            deck,
            wtmass: 1.0,
            materials: BTreeMap::new(),
            properties: BTreeMap::new(),
            elements: BTreeMap::new(),
            edits: BTreeMap::new(),
            copies: Vec::new(),
            used_materials: BTreeSet::new(),
            used_properties: BTreeSet::new(),
        };
        for (i, c) in deck.cards.iter().enumerate() {
            let name = c.name.as_str();
            if name == "PARAM" && c.field(1).eq_ignore_ascii_case("WTMASS") {
                w.wtmass = parse_real(c.field(2)).unwrap_or(1.0);
            } else if is_material(name) {
                if let Some(id) = card_id(c, 1) {
                    w.materials.insert(id, i);
                    w.used_materials.insert(id);
                }
            } else if is_property(name) {
                let ks: &[usize] = match name {
                    "PELAS" => &[1, 5],
                    "PMASS" | "PDAMP" => &[1, 3, 5, 7],
                    _ => &[1],
                };
                for &k in ks {
                    if let Some(id) = card_id(c, k) {
                        w.properties.insert(id, i);
                        w.used_properties.insert(id);
                    }
                }
            } else if is_element(name)
                && let Some(id) = card_id(c, 1)
            {
                w.elements.insert(id, i);
            }
        }
        w
    }

    fn card(&self, i: usize) -> &DeckCard {
        &self.deck.cards[i]
    }

    fn label(&self, i: usize) -> String {
        let c = self.card(i);
        format!("{} {}", c.name, c.field(1))
    }

    fn place(&self, i: usize) -> (String, usize) {
        let c = self.card(i);
        (self.deck.files[c.file].name.clone(), c.line)
    }

    fn unsupported(&self, i: usize, problem: impl Into<String>) -> DeckUpdateError {
        let (file, line) = self.place(i);
        DeckUpdateError::Unsupported {
            file,
            line,
            card: self.label(i),
            problem: problem.into(),
        }
    }

    /// Checks that field `k` of card `i` reads `expected` (× `scale`; blank reads `blank`).
    fn check(
        &self,
        i: usize,
        k: usize,
        label: &str,
        expected: f64,
        scale: f64,
        blank: f64,
    ) -> Result<(), DeckUpdateError> {
        let text = self.card(i).field(k);
        let found = if text.is_empty() {
            Some(blank)
        } else {
            parse_real(text)
        };
        let agrees = found.is_some_and(|v| {
            let v = v * scale;
            (v - expected).abs() <= AGREE * expected.abs().max(v.abs())
        });
        if agrees {
            return Ok(());
        }
        let (file, line) = self.place(i);
        Err(DeckUpdateError::Mismatch {
            file,
            line,
            card: self.label(i),
            field: label.to_string(),
            found: if text.is_empty() {
                "blank".into()
            } else {
                text.to_string()
            },
            expected,
        })
    }

    fn set(&mut self, i: usize, k: usize, label: &str, text: String) {
        self.edits
            .entry(i)
            .or_default()
            .fields
            .insert(k, (label.to_string(), text));
    }

    /// Sets a real field after checking it holds the original value (deck value × `scale`).
    #[allow(clippy::too_many_arguments)]
    fn set_real(
        &mut self,
        i: usize,
        k: usize,
        label: &str,
        old: f64,
        new: f64,
        scale: f64,
        blank: f64,
    ) -> Result<(), DeckUpdateError> {
        if old == new {
            return Ok(());
        }
        self.check(i, k, label, old, scale, blank)?;
        self.set(i, k, label, real16(new / scale));
        Ok(())
    }

    fn fresh(used: &mut BTreeSet<u64>, wanted: u64) -> u64 {
        let id = if used.contains(&wanted) {
            used.last().copied().unwrap_or(0) + 1
        } else {
            wanted
        };
        used.insert(id);
        id
    }

    /// MAT1 `i`'s fields from `old` to `new`.
    fn material(
        &mut self,
        i: usize,
        old: &Material,
        new: &Material,
    ) -> Result<(), DeckUpdateError> {
        let name = self.card(i).name.clone();
        if name != "MAT1" {
            return Err(self.unsupported(i, format!("{name} values cannot be written back")));
        }
        if old.nu != new.nu {
            return Err(self.unsupported(i, "a changed Poisson's ratio cannot be written back"));
        }
        if old.e != new.e {
            let e_blank = self.card(i).field(2).is_empty();
            if e_blank {
                // E was derived from G and NU: give E and let G follow from it.
                self.check(i, 3, "G", old.g(), 1.0, f64::NAN)?;
                self.set(i, 2, "E", real16(new.e));
                self.set(i, 3, "G", String::new());
            } else {
                self.set_real(i, 2, "E", old.e, new.e, 1.0, f64::NAN)?;
                if !self.card(i).field(3).is_empty() {
                    self.set(i, 3, "G", real16(new.g()));
                }
            }
        }
        let w = self.wtmass;
        self.set_real(i, 5, "RHO", old.rho, new.rho, w, 0.0)
    }

    /// MAT8 `E1`, `E2`, `G12`, `G1Z`, `G2Z` (blank ones stay blank: they read as `G12`, which
    /// scales with them), MAT2 `G11`–`G33`, and `RHO` (divided by WTMASS).
    fn shell_material(
        &mut self,
        i: usize,
        old: &ShellMaterial,
        new: &ShellMaterial,
    ) -> Result<(), DeckUpdateError> {
        let name = self.card(i).name.clone();
        let w = self.wtmass;
        match (old, new) {
            (
                ShellMaterial::Orthotropic {
                    e1: a1,
                    e2: a2,
                    nu12: n0,
                    g12: s0,
                    g1z: x0,
                    g2z: y0,
                    rho: r0,
                },
                ShellMaterial::Orthotropic {
                    e1,
                    e2,
                    nu12,
                    g12,
                    g1z,
                    g2z,
                    rho,
                },
            ) if name == "MAT8" => {
                if n0 != nu12 {
                    return Err(self.unsupported(i, "a changed NU12 cannot be written back"));
                }
                for (k, label, o, n) in [
                    (2, "E1", a1, e1),
                    (3, "E2", a2, e2),
                    (5, "G12", s0, g12),
                    (6, "G1Z", x0, g1z),
                    (7, "G2Z", y0, g2z),
                ] {
                    if k >= 6 && self.card(i).field(k).is_empty() {
                        continue;
                    }
                    self.set_real(i, k, label, *o, *n, 1.0, f64::NAN)?;
                }
                self.set_real(i, 8, "RHO", *r0, *rho, w, 0.0)
            }
            (
                ShellMaterial::Anisotropic { g: g0, rho: r0 },
                ShellMaterial::Anisotropic { g, rho },
            ) if name == "MAT2" => {
                let labels = ["G11", "G12", "G13", "G22", "G23", "G33"];
                for (j, label) in labels.iter().enumerate() {
                    self.set_real(i, 2 + j, label, g0[j], g[j], 1.0, 0.0)?;
                }
                self.set_real(i, 8, "RHO", *r0, *rho, w, 0.0)
            }
            _ => Err(self.unsupported(i, format!("{name} values cannot be written back"))),
        }
    }

    /// Starts a copy of card `i`: its own pending edits are set aside, so that the edits made
    /// next describe the copy ([`Writer::finish_copy`]).
    fn begin_copy(&mut self, i: usize) -> Option<Edit> {
        self.edits.remove(&i)
    }

    /// Moves the edits made on card `i` since [`Writer::begin_copy`] to a copy with id `id`,
    /// and gives `i` its own edits back.
    fn finish_copy(&mut self, i: usize, own: Option<Edit>, id: u64, why: String) {
        let mut fields: FieldTexts = self
            .edits
            .remove(&i)
            .map(|e| e.fields.into_iter().map(|(k, (_, t))| (k, t)).collect())
            .unwrap_or_default();
        if let Some(e) = own {
            self.edits.insert(i, e);
        }
        fields.insert(1, id.to_string());
        self.copy(i, fields, why);
    }

    fn copy(&mut self, source: usize, fields: BTreeMap<usize, String>, why: String) {
        self.copies.push(CardCopy {
            source,
            fields,
            why,
        });
    }
}

/// The deck with `updated`'s values where they differ from `original` (the model the deck was
/// imported to, or that model with updating parameters declared); `header` lines open the top
/// file as `$` comments.
pub fn update_deck(
    deck: &Deck,
    original: &Model,
    updated: &Model,
    header: &[String],
) -> Result<UpdatedDeck, DeckUpdateError> {
    same_structure(original, updated)?;
    let mut w = Writer::new(deck);
    let mut new_material_ids = materials(&mut w, original, updated)?;
    new_material_ids.extend(anisotropic_materials(&mut w, original, updated)?);
    let new_property_ids = properties(&mut w, original, updated, &new_material_ids)?;
    elements(
        &mut w,
        original,
        updated,
        (&new_material_ids, &new_property_ids),
    )?;
    render(&w, header)
}

/// The updated model must be the deck's: the same grids and elements (values may differ).
fn same_structure(original: &Model, updated: &Model) -> Result<(), DeckUpdateError> {
    let differ = |what: &'static str, a: Vec<u64>, b: Vec<u64>| {
        let only_a: Vec<String> = a
            .iter()
            .filter(|x| b.binary_search(x).is_err())
            .take(5)
            .map(u64::to_string)
            .collect();
        let only_b: Vec<String> = b
            .iter()
            .filter(|x| a.binary_search(x).is_err())
            .take(5)
            .map(u64::to_string)
            .collect();
        DeckUpdateError::OtherModel {
            what,
            detail: format!(
                "only in the deck: [{}]; only in the model: [{}]",
                only_a.join(", "),
                only_b.join(", ")
            ),
        }
    };
    let (a, b): (Vec<u64>, Vec<u64>) = (
        original.nodes.keys().copied().collect(),
        updated.nodes.keys().copied().collect(),
    );
    if a != b {
        return Err(differ("grids", a, b));
    }
    let (a, b): (Vec<u64>, Vec<u64>) = (
        original.elements.keys().copied().collect(),
        updated.elements.keys().copied().collect(),
    );
    if a != b {
        return Err(differ("elements", a, b));
    }
    Ok(())
}

/// MAT1 changes; returns the deck id given to each material id new in `updated`.
fn materials(
    w: &mut Writer,
    original: &Model,
    updated: &Model,
) -> Result<BTreeMap<u64, u64>, DeckUpdateError> {
    // A new material is a copy of the one its element used in the original model.
    let mut source_of: BTreeMap<u64, u64> = BTreeMap::new();
    for (eid, e) in &updated.elements {
        let Some(e0) = original.elements.get(eid) else {
            continue;
        };
        if let (Some(mid), Some(mid0)) =
            (element_material(updated, e), element_material(original, e0))
            && !original.materials.contains_key(&mid)
        {
            source_of.insert(mid, mid0);
        }
    }
    let mut ids = BTreeMap::new();
    for (mid, m) in &updated.shell_materials {
        if let Some(m0) = original.shell_materials.get(mid) {
            if m0 != m {
                let i = *w.materials.get(mid).ok_or(DeckUpdateError::Missing {
                    what: "material",
                    id: *mid,
                })?;
                w.shell_material(i, m0, m)?;
            }
            continue;
        }
        let Some(m0) = source_of
            .get(mid)
            .and_then(|mid0| original.shell_materials.get(mid0).map(|m0| (*mid0, m0)))
        else {
            continue;
        };
        let (mid0, m0) = m0;
        let i = *w.materials.get(&mid0).ok_or(DeckUpdateError::Missing {
            what: "material",
            id: mid0,
        })?;
        let id = Writer::fresh(&mut w.used_materials, *mid);
        ids.insert(*mid, id);
        let own = w.begin_copy(i);
        w.shell_material(i, m0, m)?;
        let why = format!("copy of {} {mid0} for the updated elements", w.card(i).name);
        w.finish_copy(i, own, id, why);
    }
    for (mid, m) in &updated.materials {
        if let Some(m0) = original.materials.get(mid) {
            if m0 != m {
                let i = *w.materials.get(mid).ok_or(DeckUpdateError::Missing {
                    what: "material",
                    id: *mid,
                })?;
                w.material(i, m0, m)?;
            }
            continue;
        }
        let Some(mid0) = source_of.get(mid) else {
            // A material no element uses: nothing in the deck refers to it.
            continue;
        };
        let i = *w.materials.get(mid0).ok_or(DeckUpdateError::Missing {
            what: "material",
            id: *mid0,
        })?;
        let id = Writer::fresh(&mut w.used_materials, *mid);
        ids.insert(*mid, id);
        let own = w.begin_copy(i);
        w.material(i, &original.materials[mid0], m)?;
        let why = format!("copy of MAT1 {mid0} for the updated elements");
        w.finish_copy(i, own, id, why);
    }
    Ok(ids)
}

/// MAT9 changes (density only); returns the deck id given to each MAT9 id new in `updated`.
fn anisotropic_materials(
    w: &mut Writer,
    original: &Model,
    updated: &Model,
) -> Result<BTreeMap<u64, u64>, DeckUpdateError> {
    let mut source_of: BTreeMap<u64, u64> = BTreeMap::new();
    for (eid, e) in &updated.elements {
        let Some(e0) = original.elements.get(eid) else {
            continue;
        };
        if let (Some(mid), Some(mid0)) =
            (element_material(updated, e), element_material(original, e0))
            && !original.anisotropic_materials.contains_key(&mid)
        {
            source_of.insert(mid, mid0);
        }
    }
    let mut ids = BTreeMap::new();
    for (mid, m) in &updated.anisotropic_materials {
        let (mid0, is_new) = match original.anisotropic_materials.get(mid) {
            Some(_) => (*mid, false),
            None => match source_of.get(mid) {
                Some(m0) => (*m0, true),
                None => continue,
            },
        };
        let m0 = &original.anisotropic_materials[&mid0];
        if !is_new && m0 == m {
            continue;
        }
        let i = *w.materials.get(&mid0).ok_or(DeckUpdateError::Missing {
            what: "material",
            id: mid0,
        })?;
        if m.g != m0.g {
            return Err(w.unsupported(i, "MAT9 stiffness values cannot be written back"));
        }
        let own = if is_new { w.begin_copy(i) } else { None };
        let scale = w.wtmass;
        w.set_real(i, 23, "RHO", m0.rho, m.rho, scale, 0.0)?;
        if is_new {
            let id = Writer::fresh(&mut w.used_materials, *mid);
            ids.insert(*mid, id);
            w.finish_copy(
                i,
                own,
                id,
                format!("copy of MAT9 {mid0} for the updated elements"),
            );
        }
    }
    Ok(ids)
}

/// The material an element's stiffness comes from (shell, beam and rod properties, CONROD).
fn element_material(m: &Model, e: &Element) -> Option<u64> {
    if let Element::Rod {
        section: RodSection::Own(p),
        ..
    } = e
    {
        return Some(p.material);
    }
    let pid = e.property()?;
    m.shell_properties
        .get(&pid)
        .map(|p| p.material)
        .or_else(|| m.beam_properties.get(&pid).map(|p| p.material))
        .or_else(|| m.rod_properties.get(&pid).map(|p| p.material))
        .or_else(|| m.solid_properties.get(&pid).map(|p| p.material))
}

/// Property changes; returns the deck id given to each property id new in `updated`.
fn properties(
    w: &mut Writer,
    original: &Model,
    updated: &Model,
    new_materials: &BTreeMap<u64, u64>,
) -> Result<BTreeMap<u64, u64>, DeckUpdateError> {
    let mut source_of: BTreeMap<u64, u64> = BTreeMap::new();
    for (eid, e) in &updated.elements {
        if let (Some(pid), Some(pid0)) = (
            e.property(),
            original.elements.get(eid).and_then(Element::property),
        ) && pid != pid0
        {
            source_of.insert(pid, pid0);
        }
    }
    let mid_text = |mid: u64| new_materials.get(&mid).copied().unwrap_or(mid).to_string();
    let mut ids = BTreeMap::new();
    let pids: BTreeSet<u64> = updated
        .shell_properties
        .keys()
        .chain(updated.beam_properties.keys())
        .chain(updated.rod_properties.keys())
        .chain(updated.solid_properties.keys())
        .copied()
        .collect();
    for pid in pids {
        let (pid0, is_new) = match source_of.get(&pid) {
            Some(p0)
                if !original.shell_properties.contains_key(&pid)
                    && !original.beam_properties.contains_key(&pid)
                    && !original.solid_properties.contains_key(&pid) =>
            {
                (*p0, true)
            }
            _ => (pid, false),
        };
        let i = *w.properties.get(&pid0).ok_or(DeckUpdateError::Missing {
            what: "property",
            id: pid0,
        })?;
        let own = if is_new { w.begin_copy(i) } else { None };
        if let (Some(p), Some(p0)) = (
            updated.shell_properties.get(&pid),
            original.shell_properties.get(&pid0),
        ) {
            if let (Some(l), Some(l0)) = (&p.laminate, &p0.laminate) {
                laminate(w, i, (p0, l0), (p, l), &mid_text)?;
            } else if w.card(i).name != "PSHELL" || p.laminate.is_some() {
                return Err(w.unsupported(i, "shell properties are written to PSHELL only"));
            } else {
                w.set_real(i, 3, "T", p0.thickness, p.thickness, 1.0, f64::NAN)?;
                if p.material != p0.material {
                    // Every MID field that named the old material names the new one.
                    for (k, label) in [(2, "MID1"), (4, "MID2"), (6, "MID3"), (11, "MID4")] {
                        if card_id(w.card(i), k) == Some(p0.material) {
                            w.set(i, k, label, mid_text(p.material));
                        }
                    }
                }
            }
        } else if let (Some(p), Some(p0)) = (
            updated.beam_properties.get(&pid),
            original.beam_properties.get(&pid0),
        ) {
            if p.material != p0.material {
                w.set(i, 2, "MID", mid_text(p.material));
            }
            if p0.taper.is_some() && (p.section != p0.section || p.taper != p0.taper) {
                return Err(w.unsupported(
                    i,
                    "the section of a tapered beam (PBEAM/PBEAML with stations) changed; its stations cannot be written back (only its material can), so the card is left as it is",
                ));
            }
            if p.centres != p0.centres {
                return Err(w.unsupported(
                    i,
                    "the neutral axis or NSM offsets (PBEAM N, M, NSI) of a beam changed; they cannot be written back, so the card is left as it is",
                ));
            }
            if p.section != p0.section {
                beam_section(w, i, &p0.section, &p.section)?;
            }
        } else if let (Some(p), Some(p0)) = (
            updated.rod_properties.get(&pid),
            original.rod_properties.get(&pid0),
        ) {
            if p.material != p0.material {
                w.set(i, 2, "MID", mid_text(p.material));
            }
            if (p.area, p.j, p.nsm, p.taper) != (p0.area, p0.j, p0.nsm, p0.taper) {
                return Err(w.unsupported(i, "rod sections cannot be written back"));
            }
        } else if let (Some(p), Some(p0)) = (
            updated.solid_properties.get(&pid),
            original.solid_properties.get(&pid0),
        ) {
            if p.material != p0.material {
                w.set(i, 2, "MID", mid_text(p.material));
            }
            if p.axes != p0.axes {
                return Err(w.unsupported(i, "solid material axes cannot be written back"));
            }
        }
        if is_new {
            let id = Writer::fresh(&mut w.used_properties, pid);
            ids.insert(pid, id);
            let why = format!("copy of {} {pid0} for the updated elements", w.card(i).name);
            w.finish_copy(i, own, id, why);
        }
    }
    Ok(ids)
}

/// The MID field of each ply of a PCOMP/PCOMPG card, bottom to top (as the importer reads it).
fn ply_fields(c: &DeckCard) -> Vec<usize> {
    let global = c.name == "PCOMPG";
    let step = if global { 8 } else { 4 };
    let mut out = Vec::new();
    let mut k0 = 9;
    while k0 <= c.fields.len() {
        let k = if global { k0 + 1 } else { k0 };
        if (k0..k + 4).any(|j| !c.field(j).is_empty()) {
            out.push(k);
        }
        k0 += step;
    }
    out
}

/// A laminate's changes on its PCOMP/PCOMPG: ply thicknesses (every ply's `Ti` written, so a
/// blank one no longer repeats the one before), an explicit `Z0`, `NSM`, and ply materials
/// renamed by a material copy. Other changes are errors.
fn laminate(
    w: &mut Writer,
    i: usize,
    (p0, l0): (&ShellProperty, &Laminate),
    (p, l): (&ShellProperty, &Laminate),
    mid_text: &dyn Fn(u64) -> String,
) -> Result<(), DeckUpdateError> {
    if !matches!(w.card(i).name.as_str(), "PCOMP" | "PCOMPG") {
        return Err(w.unsupported(i, "a laminate is written to PCOMP/PCOMPG only"));
    }
    let fields = ply_fields(w.card(i));
    let same_shape = fields.len() == l0.plies.len()
        && l.plies.len() == l0.plies.len()
        && l.symmetric == l0.symmetric
        && l.terms == l0.terms
        && l.global_ids == l0.global_ids
        && l.z0.is_some() == l0.z0.is_some()
        && l.plies
            .iter()
            .zip(&l0.plies)
            .all(|(a, b)| a.theta_deg == b.theta_deg);
    if !same_shape {
        return Err(w.unsupported(
            i,
            "only ply thicknesses, Z0, NSM and ply materials of a laminate can be written back",
        ));
    }
    if let (Some(z0), Some(z)) = (l0.z0, l.z0) {
        w.set_real(i, 2, "Z0", z0, z, 1.0, f64::NAN)?;
    }
    w.set_real(i, 3, "NSM", p0.nsm, p.nsm, w.wtmass, 0.0)?;
    for ((k, ply), ply0) in fields.into_iter().zip(&l.plies).zip(&l0.plies) {
        if ply.thickness != ply0.thickness {
            // A blank Ti reads as the previous ply's, which the model holds.
            w.set_real(
                i,
                k + 1,
                "Ti",
                ply0.thickness,
                ply.thickness,
                1.0,
                ply0.thickness,
            )?;
        }
        if ply.material != ply0.material {
            w.set(i, k, "MIDi", mid_text(ply.material));
        }
    }
    Ok(())
}

/// PBARL/PBEAML BAR dimensions.
fn beam_section(
    w: &mut Writer,
    i: usize,
    old: &BeamSection,
    new: &BeamSection,
) -> Result<(), DeckUpdateError> {
    let name = w.card(i).name.clone();
    let bar = matches!(name.as_str(), "PBARL" | "PBEAML") && w.card(i).field(4) == "BAR";
    match (old, new, bar) {
        (
            BeamSection::Rectangle {
                width: w0,
                height: h0,
            },
            BeamSection::Rectangle { width, height },
            true,
        ) => {
            if name == "PBEAML" && w.card(i).fields.len() > 16 {
                return Err(w.unsupported(
                    i,
                    "a PBEAML with stations beyond end A cannot be written back",
                ));
            }
            w.set_real(i, 9, "DIM1", *w0, *width, 1.0, f64::NAN)?;
            w.set_real(i, 10, "DIM2", *h0, *height, 1.0, f64::NAN)
        }
        _ => Err(w.unsupported(
            i,
            "only the BAR dimensions of a PBARL/PBEAML can be written back",
        )),
    }
}

/// Element changes: property ids, springs, masses.
fn elements(
    w: &mut Writer,
    original: &Model,
    updated: &Model,
    (new_materials, new_properties): (&BTreeMap<u64, u64>, &BTreeMap<u64, u64>),
) -> Result<(), DeckUpdateError> {
    // Springs whose property card holds the stiffness: (property card, field of K) → users' k.
    let mut spring_groups: BTreeMap<(usize, usize), SpringUsers> = BTreeMap::new();
    let mut mass_groups: BTreeMap<u64, Vec<(u64, f64, f64)>> = BTreeMap::new();
    for (eid, e) in &updated.elements {
        let Some(e0) = original.elements.get(eid) else {
            continue;
        };
        if e == e0 {
            continue;
        }
        let i = *w.elements.get(eid).ok_or(DeckUpdateError::Missing {
            what: "element",
            id: *eid,
        })?;
        if let (Some(p), Some(p0)) = (e.property(), e0.property())
            && p != p0
        {
            let text = new_properties.get(&p).copied().unwrap_or(p).to_string();
            w.set(i, 2, "PID", text);
        }
        match (e, e0) {
            (
                Element::Rod {
                    section: RodSection::Own(p),
                    ..
                },
                Element::Rod {
                    section: RodSection::Own(p0),
                    ..
                },
            ) if p != p0 => {
                if (p.area, p.j, p.nsm, p.taper) != (p0.area, p0.j, p0.nsm, p0.taper) {
                    return Err(w.unsupported(i, "rod sections cannot be written back"));
                }
                let text = new_materials
                    .get(&p.material)
                    .copied()
                    .unwrap_or(p.material)
                    .to_string();
                w.set(i, 4, "MID", text);
            }
            (Element::Bush { k, .. }, Element::Bush { k: k0, .. }) if k != k0 => {
                let pid = card_id(w.card(i), 2).unwrap_or(*eid);
                let pi = *w.properties.get(&pid).ok_or(DeckUpdateError::Missing {
                    what: "property",
                    id: pid,
                })?;
                spring_groups
                    .entry((pi, 0))
                    .or_default()
                    .push((*eid, *k0, *k));
            }
            (Element::ScalarSpring { k, .. }, Element::ScalarSpring { k: k0, .. }) if k != k0 => {
                if w.card(i).name == "CELAS2" {
                    w.set_real(i, 2, "K", *k0, *k, 1.0, f64::NAN)?;
                } else {
                    let pid = card_id(w.card(i), 2).unwrap_or(*eid);
                    let pi = *w.properties.get(&pid).ok_or(DeckUpdateError::Missing {
                        what: "property",
                        id: pid,
                    })?;
                    let k_field = if card_id(w.card(pi), 1) == Some(pid) {
                        2
                    } else {
                        6
                    };
                    let mut a = [0.0; 6];
                    let mut b = [0.0; 6];
                    a[0] = *k0;
                    b[0] = *k;
                    spring_groups
                        .entry((pi, k_field))
                        .or_default()
                        .push((*eid, a, b));
                }
            }
            (
                Element::Mass { mass, inertia, .. },
                Element::Mass {
                    mass: m0,
                    inertia: i0,
                    ..
                },
            ) => {
                let wt = w.wtmass;
                w.set_real(i, 4, "M", *m0, *mass, wt, 0.0)?;
                if inertia != i0 {
                    let cid = w.card(i).field(3).parse::<i64>().unwrap_or(0);
                    if cid > 0 {
                        return Err(w.unsupported(
                            i,
                            "the inertia of a CONM2 given in a coordinate system (CID > 0) cannot be written back",
                        ));
                    }
                    for (c, label) in ["I11", "I21", "I22", "I31", "I32", "I33"]
                        .iter()
                        .enumerate()
                    {
                        w.set_real(i, 9 + c, label, i0[c], inertia[c], wt, 0.0)?;
                    }
                }
            }
            (Element::ScalarMass { m, .. }, Element::ScalarMass { m: m0, .. }) if m != m0 => {
                let wt = w.wtmass;
                if matches!(w.card(i).name.as_str(), "CMASS2" | "CMASS4") {
                    w.set_real(i, 2, "M", *m0, *m, wt, 0.0)?;
                } else {
                    let pid = card_id(w.card(i), 2).unwrap_or(*eid);
                    mass_groups.entry(pid).or_default().push((*eid, *m0, *m));
                }
            }
            _ => {}
        }
    }
    scalar_masses(w, mass_groups)?;
    springs(w, spring_groups)
}

/// PMASS masses of CMASS1/CMASS3 elements: the property's field when every element using it
/// changed to one value, else an error naming the card.
fn scalar_masses(
    w: &mut Writer,
    groups: BTreeMap<u64, Vec<(u64, f64, f64)>>,
) -> Result<(), DeckUpdateError> {
    for (pid, users) in groups {
        let pi = *w.properties.get(&pid).ok_or(DeckUpdateError::Missing {
            what: "property",
            id: pid,
        })?;
        let all_users = w
            .elements
            .iter()
            .filter(|(eid, ci)| {
                let c = w.card(**ci);
                matches!(c.name.as_str(), "CMASS1" | "CMASS3")
                    && card_id(c, 2).unwrap_or(**eid) == pid
            })
            .count();
        let (m0, m) = (users[0].1, users[0].2);
        if users.len() != all_users || users.iter().any(|u| u.2.to_bits() != m.to_bits()) {
            return Err(w.unsupported(
                pi,
                format!("the elements using PMASS {pid} were updated to different masses; give them their own PMASS (a PMASS copy is not written)"),
            ));
        }
        let Some(k) = [1, 3, 5, 7]
            .into_iter()
            .find(|&k| card_id(w.card(pi), k) == Some(pid))
        else {
            continue;
        };
        let wt = w.wtmass;
        w.set_real(pi, k + 1, "M", m0, m, wt, 0.0)?;
    }
    Ok(())
}

/// PBUSH/PELAS stiffnesses: the card itself when every element using it changed alike, else a
/// copy for each group of elements with one new stiffness.
fn springs(
    w: &mut Writer,
    groups: BTreeMap<(usize, usize), SpringUsers>,
) -> Result<(), DeckUpdateError> {
    for ((pi, k_field), users) in groups {
        let pid = if k_field == 6 {
            card_id(w.card(pi), 5)
        } else {
            card_id(w.card(pi), 1)
        }
        .unwrap_or(0);
        let all_users: BTreeSet<u64> = w
            .elements
            .iter()
            .filter(|(eid, ci)| {
                let c = w.card(**ci);
                matches!(c.name.as_str(), "CBUSH" | "CELAS1")
                    && card_id(c, 2).unwrap_or(**eid) == pid
            })
            .map(|(eid, _)| *eid)
            .collect();
        let mut by_value: BTreeMap<Vec<u64>, Vec<u64>> = BTreeMap::new();
        for (eid, _, k) in &users {
            by_value
                .entry(k.iter().map(|v| v.to_bits()).collect())
                .or_default()
                .push(*eid);
        }
        let k0 = users[0].1;
        let whole = by_value.len() == 1 && users.len() == all_users.len();
        for (bits, eids) in by_value {
            let k: Vec<f64> = bits.iter().map(|b| f64::from_bits(*b)).collect();
            let fields = spring_fields(w, pi, k_field, &k0, &k)?;
            if whole {
                for (kf, label, text) in fields {
                    w.set(pi, kf, &label, text);
                }
                continue;
            }
            let id = Writer::fresh(&mut w.used_properties, pid);
            let mut copy: BTreeMap<usize, String> =
                fields.into_iter().map(|(kf, _, t)| (kf, t)).collect();
            if w.card(pi).name == "PELAS" {
                // The copy holds only this property, as its first one.
                let off = if k_field == 6 { 4 } else { 0 };
                let mut single = BTreeMap::new();
                for k in 1..=4 {
                    let t = copy
                        .remove(&(k + off))
                        .unwrap_or_else(|| w.card(pi).field(k + off).to_string());
                    single.insert(k, t);
                }
                for k in 5..=8 {
                    single.insert(k, String::new());
                }
                copy = single;
            }
            copy.insert(1, id.to_string());
            let why = format!(
                "copy of {} {pid} for elements {}",
                w.card(pi).name,
                eids.iter()
                    .map(u64::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            w.copy(pi, copy, why);
            for eid in eids {
                let ei = w.elements[&eid];
                w.set(ei, 2, "PID", id.to_string());
            }
        }
    }
    Ok(())
}

/// The fields of spring property card `pi` that carry `k` (checked against `k0`).
fn spring_fields(
    w: &Writer,
    pi: usize,
    k_field: usize,
    k0: &[f64; 6],
    k: &[f64],
) -> Result<Vec<(usize, String, String)>, DeckUpdateError> {
    let c = w.card(pi);
    let mut out = Vec::new();
    if c.name == "PELAS" {
        let label = if k_field == 6 { "K2" } else { "K1" };
        w.check(pi, k_field, label, k0[0], 1.0, f64::NAN)?;
        out.push((k_field, label.to_string(), real16(k[0])));
        return Ok(out);
    }
    let rows = c.fields.len().div_ceil(8).max(1);
    let row = (0..rows)
        .find(|r| c.field(2 + 8 * r).eq_ignore_ascii_case("K"))
        .ok_or_else(|| w.unsupported(pi, "the PBUSH has no K line to write the stiffness to"))?;
    for (j, (old, new)) in k0.iter().zip(k).enumerate() {
        let kf = 3 + 8 * row + j;
        let label = format!("K{}", j + 1);
        if old != new {
            w.check(pi, kf, &label, *old, 1.0, 0.0)?;
            out.push((kf, label, real16(*new)));
        }
    }
    Ok(out)
}

/// A card in large-field format (its texts are at most 16 characters, see [`card_texts`]) with
/// the file's line ending.
fn large_card(name: &str, texts: Vec<String>, eol: &str) -> String {
    let mut out = String::new();
    crate::model::export::nastran::card_texts(&mut out, name, texts);
    if eol == "\n" {
        out
    } else {
        out.replace('\n', eol)
    }
}

/// The field texts of card `i` with `changes`, each at most 16 characters.
fn card_texts(
    w: &Writer,
    i: usize,
    changes: &BTreeMap<usize, String>,
) -> Result<Vec<String>, DeckUpdateError> {
    let c = w.card(i);
    let n = c
        .fields
        .len()
        .max(changes.keys().max().copied().unwrap_or(0));
    (1..=n)
        .map(|k| {
            let text = changes
                .get(&k)
                .cloned()
                .unwrap_or_else(|| c.field(k).to_string());
            if text.len() <= 16 {
                return Ok(text);
            }
            match parse_real(&text) {
                Some(v) if text.contains(['.', 'e', 'E', 'd', 'D']) => Ok(real16(v)),
                _ => Err(w.unsupported(
                    i,
                    format!("field {k} `{text}` is longer than a large field holds"),
                )),
            }
        })
        .collect()
}

/// Splits bytes into lines, each with its ending.
fn lines_of(bytes: &[u8]) -> Vec<&[u8]> {
    bytes.split_inclusive(|b| *b == b'\n').collect()
}

/// Plain, unique output names for the deck's files.
fn output_names(deck: &Deck) -> Vec<String> {
    let mut seen = BTreeSet::new();
    deck.files
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let base = std::path::Path::new(&f.name)
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .filter(|n| !n.is_empty() && n != "." && n != "..")
                .unwrap_or_else(|| format!("include{i}.bdf"));
            let mut name = base.clone();
            let mut n = 1;
            while !seen.insert(name.to_ascii_lowercase()) {
                n += 1;
                name = format!("{n}_{base}");
            }
            name
        })
        .collect()
}

fn render(w: &Writer, header: &[String]) -> Result<UpdatedDeck, DeckUpdateError> {
    let deck = w.deck;
    let names = output_names(deck);
    let mut changes = Vec::new();
    // Per file: first line of a rewritten card → its text; lines to drop; insertions after a
    // line; INCLUDE statements to rewrite.
    let mut replace: Vec<Rewrites> = vec![BTreeMap::new(); deck.files.len()];
    let mut drop: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); deck.files.len()];
    let mut after: Vec<Insertions> = vec![BTreeMap::new(); deck.files.len()];
    for (&i, edit) in &w.edits {
        let c = w.card(i);
        for (&k, (label, new)) in &edit.fields {
            changes.push(DeckChange {
                file: deck.files[c.file].name.clone(),
                line: c.line,
                card: w.label(i),
                field: label.clone(),
                old: c.field(k).to_string(),
                new: new.clone(),
            });
        }
        let lines = c.lines();
        let fields = edit
            .fields
            .iter()
            .map(|(k, (_, t))| (*k, t.clone()))
            .collect();
        replace[c.file].insert(lines[0], (i, fields));
        drop[c.file].extend(lines[1..].iter().copied());
    }
    for copy in &w.copies {
        let c = w.card(copy.source);
        let last = *c.lines().last().unwrap_or(&c.line);
        changes.push(DeckChange {
            file: deck.files[c.file].name.clone(),
            line: c.line,
            card: format!(
                "{} {}",
                c.name,
                copy.fields.get(&1).cloned().unwrap_or_default()
            ),
            field: "new card".into(),
            old: String::new(),
            new: copy.why.clone(),
        });
        after[c.file]
            .entry(last)
            .or_default()
            .push((copy.source, copy.fields.clone()));
    }
    changes.sort_by(|a, b| (&a.file, a.line).cmp(&(&b.file, b.line)));
    let mut includes: Vec<BTreeMap<usize, (usize, usize)>> =
        vec![BTreeMap::new(); deck.files.len()];
    for inc in &deck.includes {
        includes[inc.file].insert(inc.first_line, (inc.last_line, inc.target));
    }

    let mut files = Vec::with_capacity(deck.files.len());
    for (f, file) in deck.files.iter().enumerate() {
        let lines = lines_of(&file.bytes);
        let eol = if lines.first().is_some_and(|l| l.ends_with(b"\r\n")) {
            "\r\n"
        } else {
            "\n"
        };
        let mut out: Vec<u8> = Vec::with_capacity(file.bytes.len() + 256);
        if f == 0 && (!header.is_empty() || !changes.is_empty()) {
            for h in header {
                out.extend_from_slice(format!("$ {h}{eol}").as_bytes());
            }
            for c in &changes {
                out.extend_from_slice(
                    format!(
                        "$   {} line {}: {} {}: {} -> {}{eol}",
                        c.file,
                        c.line,
                        c.card,
                        c.field,
                        if c.old.is_empty() { "blank" } else { &c.old },
                        c.new
                    )
                    .as_bytes(),
                );
            }
        }
        let mut skip_to = 0;
        for (n0, line) in lines.iter().enumerate() {
            let n = n0 + 1;
            if n <= skip_to {
                continue;
            }
            if let Some((last, target)) = includes[f].get(&n) {
                out.extend_from_slice(format!("INCLUDE '{}'{eol}", names[*target]).as_bytes());
                skip_to = *last;
                continue;
            }
            if let Some((i, fields)) = replace[f].get(&n) {
                let texts = card_texts(w, *i, fields)?;
                out.extend_from_slice(large_card(&w.card(*i).name, texts, eol).as_bytes());
            } else if !drop[f].contains(&n) {
                out.extend_from_slice(line);
                if !line.ends_with(b"\n") && after[f].contains_key(&n) {
                    out.extend_from_slice(eol.as_bytes());
                }
            }
            for (source, fields) in after[f].get(&n).into_iter().flatten() {
                let texts = card_texts(w, *source, fields)?;
                out.extend_from_slice(large_card(&w.card(*source).name, texts, eol).as_bytes());
            }
        }
        files.push((names[f].clone(), out));
    }
    Ok(UpdatedDeck { files, changes })
}

#[cfg(test)]
#[path = "deck_update_tests.rs"]
mod tests;
