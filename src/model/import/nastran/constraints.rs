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
            // 0 or blank: a scalar point's DOF (checked against the point in finish).
            let comps = Self::spc_comps(c, 3 + off, lc)?;
            let value = c.real_or(4 + off, ld, 0.0)?;
            if value != 0.0 {
                self.warn(
                    &c.loc,
                    sid,
                    format!("{ld} = {value} at grid {g} is taken as 0: an enforced displacement does not change the modes (femu models no static load case)"),
                );
            }
            for comp in comps {
                self.spcs
                    .push((c.loc.clone(), Some(sid), DofId::new(g, comp)));
            }
        }
        Ok(())
    }

    pub(super) fn spc1(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        self.spc_sids.insert(sid);
        let comps = Self::spc_comps(c, 2, "C")?;
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
                self.spcs
                    .push((c.loc.clone(), Some(sid), DofId::new(g, comp)));
            }
        }
        for (lo, hi) in ranges {
            self.spc_ranges
                .push((c.loc.clone(), sid, comps.clone(), lo, hi));
        }
        Ok(())
    }

    /// SPCADD: a set id uniting SPC/SPC1 sets (selected by the case control's `SPC = n`).
    pub(super) fn spcadd(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        let mut members = Vec::new();
        let mut k = 2;
        while k <= c.fields.len() {
            if !c.blank(k) {
                members.push(c.id(k, &format!("S{}", members.len() + 1))?);
            }
            k += 1;
        }
        if members.is_empty() {
            return Err(c.err(2, "S1", "no set is listed", "the ids of SPC or SPC1 sets"));
        }
        if let Some((first, _)) = self.spcadds.get(&sid) {
            return Err(duplicate(c, 1, "SID", "SPCADD set", sid, first));
        }
        self.spcadds.insert(sid, (c.loc.clone(), members));
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

#[cfg(test)]
mod tests {
    use super::super::tests::{error, parse};

    const PLATE: &str = "\
CQUAD4,1,1,1,2,3,4
PSHELL,1,1,.01
MAT1,1,7.e10,,.3,2700.
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
SPC1,1,123,1
SPC1,2,456,2
SPC,3,3,3
SPCADD,10,1,3
";

    fn constrained(deck: &str) -> Vec<String> {
        let b = parse(deck);
        b.model
            .constraints
            .iter()
            .map(|d| format!("{}:{}", d.node, d.comp.name()))
            .collect()
    }

    #[test]
    fn the_case_control_selects_the_constraint_set() {
        let head = "SOL 103\nCEND\nTITLE = plate\nSPCFORCES = ALL\n";
        let with = |spc: &str| format!("{head}{spc}BEGIN BULK\n{PLATE}ENDDATA\n");
        assert_eq!(constrained(&with("SPC = 2\n")), ["2:rx", "2:ry", "2:rz"]);
        assert_eq!(
            constrained(&with("SUBCASE 1\n  SPC=10 $ both\n")),
            ["1:ux", "1:uy", "1:uz", "3:uz"]
        );
        // Subcases selecting different sets: the first is used, with a warning.
        let b = parse(&with("SUBCASE 1\nSPC = 1\nSUBCASE 2\nSPC = 2\n"));
        assert_eq!(b.model.constraints.len(), 3);
        assert!(
            b.warnings
                .iter()
                .any(|w| w.contains("selects SPC sets 1, 2")),
            "{:?}",
            b.warnings
        );
        // Without case control every set is merged, with a warning.
        let b = parse(PLATE);
        assert_eq!(b.model.constraints.len(), 7);
        assert!(
            b.warnings
                .iter()
                .any(|w| w.contains("sets 1, 2, 3 are merged")),
            "{:?}",
            b.warnings
        );
        let e = error(&with("SPC = 7\n"));
        assert!(
            e.starts_with("t.bdf line 5: the case control selects SPC = 7, which no SPC"),
            "{e}"
        );
        let e = error(&format!(
            "{head}SPC = 11\nBEGIN BULK\n{PLATE}SPCADD,11,1,4\n"
        ));
        assert!(
            e.contains("SPCADD 11 lists set 4, which no SPC or SPC1 card defines"),
            "{e}"
        );
    }
}
