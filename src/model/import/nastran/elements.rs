//! Shell and beam element cards: CQUAD4, CTRIA3, CBAR, CBEAM with their orientation, offsets
//! (OFFT, WA, WB) and pin flags (PA, PB).

use super::finish::beam_orientation;
use super::sections::{turned_orientation, unit};
use super::*;

impl Builder {
    pub(super) fn shell_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let quad = matches!(c.name.as_str(), "CQUAD4" | "CQUADR");
        let n = if quad { 4 } else { 3 };
        let id = c.id(1, "EID")?;
        let property = c.id_or(2, "PID", id)?;
        let mut nodes = [0u64; 4];
        for (j, g) in nodes.iter_mut().take(n).enumerate() {
            *g = c.id(3 + j, ["G1", "G2", "G3", "G4"][j])?;
        }
        for j in 0..n {
            for i in 0..j {
                if nodes[i] == nodes[j] {
                    return Err(c.err(
                        3 + j,
                        ["G1", "G2", "G3", "G4"][j],
                        format!("grid {} appears twice", nodes[j]),
                        "the corner grids must be distinct",
                    ));
                }
            }
        }
        self.shell_placement(c, id, 3 + n)?;
        if (11..11 + n).any(|k| !c.blank(k)) {
            for k in 11..11 + n {
                c.real(k, "Ti")?;
            }
            self.warn(
                &c.loc,
                id,
                "corner thicknesses T1-T4 are ignored; the PSHELL thickness is used",
            );
        }
        let e = if quad {
            Element::Quad4 { nodes, property }
        } else {
            Element::Tria3 {
                nodes: [nodes[0], nodes[1], nodes[2]],
                property,
            }
        };
        self.new_element(c, id, ElemIn::Done(e))
    }

    /// Reads an orientation X1-X3 or G0 starting at field `k`; `None` when all blank.
    pub(super) fn orientation(c: &Card, k: usize) -> Result<Option<Orient>, NastranError> {
        let t = c.text(k);
        if t.is_empty() {
            if c.blank(k + 1) && c.blank(k + 2) {
                return Ok(None);
            }
            return Ok(Some(Orient::Vector([
                0.0,
                c.real_or(k + 1, "X2", 0.0)?,
                c.real_or(k + 2, "X3", 0.0)?,
            ])));
        }
        if parse_int(t).is_some() {
            let g0 = c.id(k, "G0")?;
            for (j, label) in [(k + 1, "X2"), (k + 2, "X3")] {
                if !c.blank(j) {
                    return Err(c.err(
                        j,
                        label,
                        format!("`{}` given with G0 {g0}", q(c.text(j))),
                        "with an integer G0 in the X1 field, X2 and X3 must be blank",
                    ));
                }
            }
            return Ok(Some(Orient::G0(g0)));
        }
        Ok(Some(Orient::Vector([
            c.req_real(k, "X1")?,
            c.real_or(k + 1, "X2", 0.0)?,
            c.real_or(k + 2, "X3", 0.0)?,
        ])))
    }

    /// OFFT (field 8) of a CBAR/CBEAM/BAROR/BEAMOR; `None` when blank, and on CBEAM/BEAMOR when
    /// it holds a real BIT (built-in twist, p-elements only).
    fn offt(c: &Card, beam: bool) -> Result<Option<[u8; 3]>, NastranError> {
        let offt = c.word(8);
        if offt.is_empty() || beam && parse_real(&offt).is_some() {
            return Ok(None);
        }
        let valid = ["GGG", "BGG", "GGO", "BGO", "GOG", "BOG", "GOO", "BOO"];
        match valid.iter().find(|v| **v == offt) {
            Some(v) => Ok(Some(v.as_bytes().try_into().unwrap_or(*b"GGG"))),
            None => Err(c.err(
                8,
                if beam { "OFFT/BIT" } else { "OFFT" },
                format!("`{}` is not an offset flag", q(&offt)),
                "one of GGG, BGG, GGO, BGO, GOG, BOG, GOO, BOO (or a real BIT on CBEAM)",
            )),
        }
    }

    /// BAROR/BEAMOR: the PID, orientation (X1–X3 or G0) and OFFT that CBAR/CBEAM cards with
    /// those fields blank take (QRG BAROR, BEAMOR); one of each per deck.
    pub(super) fn beam_defaults(&mut self, c: &Card) -> Result<(), NastranError> {
        let beam = c.name == "BEAMOR";
        let pid = if c.blank(2) {
            None
        } else {
            Some(c.id(2, "PID")?)
        };
        let d = BeamDefaults {
            loc: c.loc.clone(),
            pid,
            orient: Self::orientation(c, 5)?,
            offt: Self::offt(c, beam)?,
        };
        let slot = if beam {
            &mut self.beamor
        } else {
            &mut self.baror
        };
        if let Some(first) = slot {
            return Err(c.err(
                1,
                &c.name,
                format!("{} is given twice (first at {})", c.name, first.loc.place()),
                format!("one {} per deck", c.name),
            ));
        }
        *slot = Some(d);
        Ok(())
    }

    pub(super) fn beam_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let beam = c.name == "CBEAM";
        let id = c.id(1, "EID")?;
        let property = if c.blank(2) {
            None
        } else {
            Some(c.id(2, "PID")?)
        };
        let ga = c.id(3, "GA")?;
        let gb = c.id(4, "GB")?;
        if ga == gb {
            return Err(c.err(
                4,
                "GB",
                format!("GB is GA ({ga})"),
                "the two end grids must differ",
            ));
        }
        let orient = Self::orientation(c, 5)?;
        let offt = Self::offt(c, beam)?;
        let mut pins = [0u32; 2];
        for (j, (k, label)) in [(9, "PA"), (10, "PB")].into_iter().enumerate() {
            let code = c.nonneg(k, label, "a pin flag")?;
            if code > 0 && (code > 654_321 || BeamEnds::released(code as u32).is_none()) {
                return Err(c.err(
                    k,
                    label,
                    format!("pin flag {code} is not a set of DOFs"),
                    "up to five distinct digits 1-6 (DOFs of the element system released at that end)",
                ));
            }
            pins[j] = code as u32;
        }
        let mut w = [0.0; 6];
        for (j, label) in ["W1A", "W2A", "W3A", "W1B", "W2B", "W3B"]
            .iter()
            .enumerate()
        {
            w[j] = c.real_or(11 + j, label, 0.0)?;
        }
        if beam
            && (c.nonneg(17, "SA", "a scalar point id")? != 0
                || c.nonneg(18, "SB", "a scalar point id")? != 0)
        {
            self.warn(&c.loc, id, "warping scalar points SA/SB are ignored");
        }
        self.new_element(
            c,
            id,
            ElemIn::Beam {
                eid: id,
                beam,
                nodes: [ga, gb],
                property,
                orient,
                ends: BeamEndsIn {
                    offt,
                    wa: [w[0], w[1], w[2]],
                    wb: [w[3], w[4], w[5]],
                    pins,
                },
            },
        )
    }
}

impl Builder {
    /// A CBAR/CBEAM in the model's terms: orientation vector and offsets in the basic system
    /// (OFFT: first letter, `v` in GA's displacement system `G` or basic `B`; second and third,
    /// WA and WB in the displacement system of GA/GB `G` or the element system `O`, whose `x`
    /// runs from GA to GB and whose `y` lies in the plane of `x` and `v`), the section's turn to
    /// principal axes applied to `v`, and the pin codes.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn beam_in_basic(
        &self,
        model: &Model,
        geo: &Geometry,
        loc: &Loc,
        nodes: [u64; 2],
        (eid, beam): (u64, bool),
        property: Option<u64>,
        orient: Option<Orient>,
        ends: BeamEndsIn,
    ) -> Result<Element, NastranError> {
        let defaults = if beam { &self.beamor } else { &self.baror };
        let property = property
            .or_else(|| defaults.as_ref().and_then(|d| d.pid))
            .unwrap_or(eid);
        let Some(orient) = orient.or_else(|| defaults.as_ref().and_then(|d| d.orient)) else {
            let name = if beam { "BEAMOR" } else { "BAROR" };
            return Err(loc.field_err(
                5,
                "X1/G0",
                format!("no orientation vector or G0 is given, on the card or a {name}"),
                format!("give X1-X3 (reals) or a grid id G0 here or on a {name} card"),
            ));
        };
        let offt = ends
            .offt
            .or_else(|| defaults.as_ref().and_then(|d| d.offt))
            .unwrap_or(*b"GGG");
        let orient = match (offt[0], orient) {
            (b'B', Orient::Vector(v)) => Orient::Vector(v),
            (_, o) => self.orient_in_basic(geo, nodes[0], o),
        };
        let v = beam_orientation(model, loc, nodes, orient)?;
        // An undefined grid is reported by the model check that follows; place nothing here.
        let (Some(&xa), Some(&xb)) = (model.nodes.get(&nodes[0]), model.nodes.get(&nodes[1]))
        else {
            return Ok(Element::Beam {
                nodes,
                property,
                orientation: v,
                ends: BeamEnds::default(),
            });
        };
        let ex = unit(sub(xb, xa));
        let ez = unit(cross(ex, v));
        let element = [ex, cross(ez, ex), ez];
        let place = |code: u8, g: u64, w: [f64; 3]| {
            if w == [0.0; 3] {
                return w;
            }
            if code == b'O' {
                return combine(&element, w);
            }
            match self.grid_directions(geo, g).1 {
                Some(d) => combine(&d, w),
                None => w,
            }
        };
        let ends = BeamEnds {
            offset_a: place(offt[1], nodes[0], ends.wa),
            offset_b: place(offt[2], nodes[1], ends.wb),
            pin_a: ends.pins[0],
            pin_b: ends.pins[1],
        };
        let turn = self.beam_turns.get(&property).copied().unwrap_or(0.0);
        if turn != 0.0 {
            for (code, label) in [(ends.pin_a, 9), (ends.pin_b, 10)] {
                let r = BeamEnds::released(code).unwrap_or_default();
                if r[1] != r[2] || r[4] != r[5] {
                    return Err(loc.field_err(
                        label,
                        ["PA", "PB"][label - 9],
                        format!("pin flag {code} releases one bending direction of a section femu turned by {:.6} rad to its principal axes (I12 ≠ 0)", turn),
                        "release both or neither of 2 and 3 (and of 5 and 6) for an unsymmetric section",
                    ));
                }
            }
        }
        let axis = [add(xa, ends.offset_a), add(xb, ends.offset_b)];
        Ok(Element::Beam {
            nodes,
            property,
            orientation: turned_orientation(axis, v, turn),
            ends,
        })
    }
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
