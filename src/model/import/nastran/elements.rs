//! Shell and beam element cards: CQUAD4, CTRIA3, CBAR, CBEAM and their orientation.

use super::*;

impl Builder {
    pub(super) fn shell_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let quad = c.name == "CQUAD4";
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
        let theta_k = 3 + n;
        if !c.blank(theta_k) {
            c.real(theta_k, "THETA/MCID")?;
        }
        c.zero(
            theta_k + 1,
            "ZOFFS",
            "shell offsets are not supported: leave ZOFFS blank or 0",
        )?;
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

    pub(super) fn beam_element(&mut self, c: &Card) -> Result<(), NastranError> {
        let beam = c.name == "CBEAM";
        let id = c.id(1, "EID")?;
        let property = c.id_or(2, "PID", id)?;
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
        let Some(orient) = Self::orientation(c, 5)? else {
            return Err(c.err(
                5,
                "X1/G0",
                "no orientation vector or G0 is given",
                "give X1-X3 (reals) or a grid id G0; BAROR/BEAMOR defaults are not supported",
            ));
        };
        let offt = c.word(8);
        if !offt.is_empty() {
            let valid_offt = ["GGG", "BGG", "GGO", "BGO", "GOG", "BOG", "GOO", "BOO"];
            if !(valid_offt.contains(&offt.as_str()) || beam && parse_real(&offt).is_some()) {
                return Err(c.err(
                    8,
                    if beam { "OFFT/BIT" } else { "OFFT" },
                    format!("`{}` is not an offset flag", q(&offt)),
                    "one of GGG, BGG, GGO, BGO, GOG, BOG, GOO, BOO (or a real BIT on CBEAM)",
                ));
            }
        }
        for (k, label) in [(9, "PA"), (10, "PB")] {
            if c.nonneg(k, label, "a pin flag")? != 0 {
                return Err(c.err(
                    k,
                    label,
                    format!("pin flag {} is not supported", c.text(k)),
                    OFFSET_HELP,
                ));
            }
        }
        for (j, label) in ["W1A", "W2A", "W3A", "W1B", "W2B", "W3B"]
            .iter()
            .enumerate()
        {
            c.zero(11 + j, label, OFFSET_HELP)?;
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
                nodes: [ga, gb],
                property,
                orient,
            },
        )
    }
}
