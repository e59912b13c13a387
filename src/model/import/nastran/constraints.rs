//! Constraints and sets: SPC, SPC1, SET1.

use super::*;

impl Builder {
    pub(super) fn spc(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        self.spc_sids.insert(sid);
        for (j, off) in [0, 3].into_iter().enumerate() {
            let lg = ["G1", "G2"][j];
            let lc = ["C1", "C2"][j];
            let ld = ["D1", "D2"][j];
            if j == 1 && c.blank(5) && c.blank(6) && c.blank(7) {
                break;
            }
            let g = c.id(2 + off, lg)?;
            let comps = c.comps(3 + off, lc)?;
            if comps.is_empty() {
                return Err(c.err(
                    3 + off,
                    lc,
                    "the field is blank",
                    "components such as 123456",
                ));
            }
            c.zero(
                4 + off,
                ld,
                "enforced displacements are not supported: D must be blank or 0",
            )?;
            for comp in comps {
                self.spcs.push((c.loc.clone(), DofId::new(g, comp)));
            }
        }
        Ok(())
    }

    pub(super) fn spc1(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        self.spc_sids.insert(sid);
        let comps = c.comps(2, "C")?;
        if comps.is_empty() {
            return Err(c.err(2, "C", "the field is blank", "components such as 123456"));
        }
        let (ids, ranges) = c.id_list(3, "Gi")?;
        if ids.is_empty() && ranges.is_empty() {
            return Err(c.err(
                3,
                "G1",
                "no grid is listed",
                "grid ids, optionally with THRU",
            ));
        }
        for g in ids {
            for &comp in &comps {
                self.spcs.push((c.loc.clone(), DofId::new(g, comp)));
            }
        }
        for (lo, hi) in ranges {
            self.spc_ranges.push((c.loc.clone(), comps.clone(), lo, hi));
        }
        Ok(())
    }

    pub(super) fn set1(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        let from = if c.word(2) == "SKIN" { 3 } else { 2 };
        let (ids, ranges) = c.id_list(from, "IDi")?;
        if let Some(first) = self.sets.get(&sid) {
            return Err(duplicate(c, 1, "SID", "set", sid, &first.loc));
        }
        self.sets.insert(
            sid,
            SetIn {
                loc: c.loc.clone(),
                ids,
                ranges,
            },
        );
        Ok(())
    }
}
