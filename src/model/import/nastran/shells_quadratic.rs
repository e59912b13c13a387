//! Quadratic shell cards: CQUAD8 and CTRIA6 (QRG layouts).
//!
//! CQUAD8: `EID PID G1 G2 G3 G4 G5 G6 / G7 G8 T1 T2 T3 T4 THETA/MCID ZOFFS / TFLAG`;
//! CTRIA6: `EID PID G1 G2 G3 G4 G5 G6 / THETA/MCID ZOFFS T1 T2 T3 TFLAG`. The corners are
//! required and distinct; a midside grid (G5–G8, G4–G6) may be blank, meaning a straight edge
//! (QRG remark), or 0 (the same). THETA/MCID is read and ignored (isotropic material); ZOFFS ≠ 0
//! is an error; corner thicknesses (and TFLAG) are ignored with a warning: the PSHELL T is used.
//! The property must be a PSHELL of MAT1 materials without MID4 (the model check refuses a
//! laminate or MAT2/MAT8 part, naming the element).

use super::*;

impl Builder {
    pub(super) fn quadratic_shell(&mut self, c: &Card) -> Result<(), NastranError> {
        let quad = c.name == "CQUAD8";
        let corners = if quad { 4 } else { 3 };
        const LABELS: [&str; 8] = ["G1", "G2", "G3", "G4", "G5", "G6", "G7", "G8"];
        let id = c.id(1, "EID")?;
        let property = c.id_or(2, "PID", id)?;
        // Grid fields: 3..=8 on the first line, 9 and 10 (G7, G8) on the second for CQUAD8.
        let mut grids: Vec<Option<u64>> = Vec::with_capacity(2 * corners);
        for (j, label) in LABELS.iter().enumerate().take(2 * corners) {
            if j < corners {
                grids.push(Some(c.id(3 + j, label)?));
            } else {
                grids.push(c.opt_grid(3 + j, label)?);
            }
        }
        for j in 0..grids.len() {
            for i in 0..j {
                if let (Some(a), Some(b)) = (grids[i], grids[j])
                    && a == b
                {
                    return Err(c.err(
                        3 + j,
                        LABELS[j],
                        format!("grid {b} appears twice (also {})", LABELS[i]),
                        "the corner and midside grids must be distinct",
                    ));
                }
            }
        }
        let (theta, zoffs, t_first, tflag) = if quad {
            (15, 16, 11, 17)
        } else {
            (9, 10, 11, 14)
        };
        if !c.blank(theta) {
            c.real(theta, "THETA/MCID")?;
        }
        c.zero(
            zoffs,
            "ZOFFS",
            "shell offsets are not supported: leave ZOFFS blank or 0",
        )?;
        let t_fields = t_first..t_first + corners;
        if t_fields.clone().any(|k| !c.blank(k)) || !c.blank(tflag) {
            for k in t_fields {
                c.real(k, "Ti")?;
            }
            c.int(tflag, "TFLAG")?;
            self.warn(
                &c.loc,
                id,
                "corner thicknesses T1-T4 (and TFLAG) are ignored; the PSHELL thickness is used",
            );
        }
        let corner = |j: usize| grids[j].unwrap_or_default();
        let e = if quad {
            Element::Quad8 {
                corners: [corner(0), corner(1), corner(2), corner(3)],
                midside: [grids[4], grids[5], grids[6], grids[7]],
                property,
            }
        } else {
            Element::Tria6 {
                corners: [corner(0), corner(1), corner(2)],
                midside: [grids[3], grids[4], grids[5]],
                property,
            }
        };
        self.new_element(c, id, ElemIn::Done(e))
    }
}
