//! EIGRL cards and the case control's `METHOD = n`: the band and number of modes the deck asks
//! of a real eigenvalue analysis ([`EigenRequest`]), recorded with the import so that the
//! `modes` stage can compute what Nastran would (Quick Reference Guide, EIGRL and METHOD).

use super::NastranError;
use super::builder::{Builder, duplicate};
use super::card::Card;
use super::source::Loc;
use crate::eigen::EigenRequest;
use std::collections::BTreeMap;

/// EIGRL cards by set id: the card, the request, and whether it asks for `NORM = MAX`.
pub(super) type Eigrls = BTreeMap<u64, (Loc, EigenRequest, bool)>;

impl Builder {
    /// `EIGRL, SID, V1, V2, ND, MSGLVL, MAXSET, SHFSCL, NORM`; the continuation's options
    /// (frequency segments, `ALPH`, `NUMS`) tune Nastran's solver only and are noted.
    pub(super) fn eigrl(&mut self, c: &Card) -> Result<(), NastranError> {
        let sid = c.id(1, "SID")?;
        if let Some((first, _, _)) = self.eigrls.get(&sid) {
            return Err(duplicate(c, 1, "SID", "EIGRL", sid, first));
        }
        let (v1, v2) = (c.real(2, "V1")?, c.real(3, "V2")?);
        if let (Some(a), Some(b)) = (v1, v2)
            && a >= b
        {
            return Err(c.err(
                3,
                "V2",
                format!("V2 = {b} is not above V1 = {a}"),
                "a frequency range V1 < V2 in Hz, or blank",
            ));
        }
        if let Some(b) = v2.filter(|b| *b <= 0.0) {
            return Err(c.err(
                3,
                "V2",
                format!("V2 = {b} Hz leaves no mode of a vibration analysis"),
                "an upper frequency > 0 Hz, or blank",
            ));
        }
        let count = match c.int(4, "ND")? {
            None => None,
            Some(n) if n > 0 => Some(n as usize),
            Some(n) => {
                return Err(c.err(
                    4,
                    "ND",
                    format!("ND = {n}"),
                    "a number of roots > 0, or blank",
                ));
            }
        };
        let norm_max = match c.word(8).as_str() {
            "" | "MASS" => false,
            "MAX" => true,
            other => {
                return Err(c.err(
                    8,
                    "NORM",
                    format!("`{other}`"),
                    "MASS or MAX (or blank: MASS)",
                ));
            }
        };
        if (9..=16).any(|k| !c.blank(k)) {
            self.warn(
                &c.loc,
                sid,
                "the continuation's options (frequency segments, ALPH, NUMS) tune Nastran's Lanczos solver; femu's solver ignores them",
            );
        }
        let request = EigenRequest {
            min_hz: v1,
            max_hz: v2,
            count,
        };
        self.eigrls.insert(sid, (c.loc.clone(), request, norm_max));
        Ok(())
    }

    /// The request the case control's first `METHOD = n` selects; with case control and no
    /// METHOD, none (Nastran runs no eigenvalue analysis then). A deck without case control (a
    /// bulk data file alone) has its only EIGRL taken, with a warning. A METHOD naming no
    /// EIGRL (e.g. an EIGR, which femu skips) leaves the choice to the `modes` stage, with a
    /// warning.
    pub(super) fn eigen_request(&mut self) -> Result<Option<EigenRequest>, NastranError> {
        let Some((loc, sid)) = self.case_control_method.first().cloned() else {
            if self.rigid.has_case_control {
                return Ok(None);
            }
            if self.eigrls.len() == 1 {
                let (sid, (loc, request, _)) = self.eigrls.iter().next().expect("one EIGRL");
                let (sid, loc, request) = (*sid, loc.clone(), request.clone());
                self.warn(
                    &loc,
                    sid,
                    format!(
                        "no case control `METHOD = {sid}` selects it; as the deck's only EIGRL it is taken as the modes asked for ({})",
                        request.describe()
                    ),
                );
                return Ok(Some(request));
            }
            if self.eigrls.len() > 1 {
                let sids: Vec<String> = self.eigrls.keys().map(u64::to_string).collect();
                self.warnings.push(format!(
                    "{}: EIGRL {} are not used: the deck has no case control `METHOD = n` to choose one, so the `modes` stage's count or max_freq_hz decide",
                    self.top_file,
                    sids.join(", ")
                ));
            }
            return Ok(None);
        };
        let others: Vec<u64> = self.case_control_method.iter().map(|(_, s)| *s).collect();
        if others.iter().any(|s| *s != sid) {
            self.warnings.push(format!(
                "{} line {}: the case control selects METHOD {others:?}; femu uses the first, METHOD = {sid}",
                loc.file, loc.line
            ));
        }
        let Some((eloc, request, norm_max)) = self.eigrls.get(&sid).cloned() else {
            self.warnings.push(format!(
                "{} line {}: METHOD = {sid} selects no EIGRL card (femu reads EIGRL; EIGR and EIGB are skipped), so the `modes` stage's count or max_freq_hz decide",
                loc.file, loc.line
            ));
            return Ok(None);
        };
        if norm_max {
            self.warn(
                &eloc,
                sid,
                "NORM = MAX: femu normalises every mode shape to unit modal mass (what its modal FRFs and sensitivities need); frequencies are unchanged, shapes differ from Nastran's by a scale per mode",
            );
        }
        Ok(Some(request))
    }
}

#[cfg(test)]
mod tests {
    use super::super::{BulkOptions, parse_bulk, parse_bulk_with};
    use crate::eigen::EigenRequest;

    const BULK: &str = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nCROD,1,1,1,2\nPROD,1,1,1e-4\nMAT1,1,2.1e11,,0.3,7800.\n";

    fn request(deck: &str) -> (Option<EigenRequest>, Vec<String>) {
        let b = parse_bulk(deck, "e.bdf").unwrap();
        (b.eigen_request, b.warnings)
    }

    #[test]
    fn method_selects_its_eigrl() {
        let deck = format!(
            "SOL 103\nCEND\nMETHOD = 2\nBEGIN BULK\n{BULK}EIGRL,1,,,10\nEIGRL,2,5.,200.,,,,,MASS\nENDDATA\n"
        );
        let (r, w) = request(&deck);
        assert_eq!(
            r,
            Some(EigenRequest {
                min_hz: Some(5.0),
                max_hz: Some(200.0),
                count: None
            })
        );
        assert!(w.is_empty(), "{w:?}");
    }

    #[test]
    fn the_only_eigrl_of_a_deck_without_case_control_is_taken_with_a_warning() {
        let (r, w) = request(&format!("{BULK}EIGRL,7,,,12\n"));
        assert_eq!(r.and_then(|r| r.count), Some(12));
        assert!(
            w[0].contains("EIGRL 7: no case control `METHOD = 7`"),
            "{w:?}"
        );
        let (r, w) = request(&format!("{BULK}EIGRL,7,,,12\nEIGRL,8,,,3\n"));
        assert_eq!(r, None);
        assert!(w[0].contains("EIGRL 7, 8 are not used"), "{w:?}");
        // With case control and no METHOD, Nastran uses none.
        let (r, w) = request(&format!("SOL 101\nCEND\nBEGIN BULK\n{BULK}EIGRL,7,,,12\n"));
        assert_eq!((r, w.len()), (None, 0));
    }

    #[test]
    fn a_method_without_its_eigrl_and_norm_max_are_warnings() {
        let deck = format!("CEND\nMETHOD = 3\nBEGIN BULK\n{BULK}EIGR,3,LAN,,100.\n");
        let (r, w) = request(&deck);
        assert_eq!(r, None);
        assert!(
            w[0].contains("line 2: METHOD = 3 selects no EIGRL card"),
            "{w:?}"
        );
        let deck = format!("CEND\nMETHOD = 3\nBEGIN BULK\n{BULK}EIGRL,3,,,4,,,,MAX\n");
        let (r, w) = request(&deck);
        assert_eq!(r.and_then(|r| r.count), Some(4));
        assert!(w[0].contains("NORM = MAX"), "{w:?}");
    }

    #[test]
    fn bad_fields_are_errors_naming_line_and_field() {
        let bad = |card: &str| {
            parse_bulk_with(&format!("{BULK}{card}\n"), "e.bdf", &BulkOptions::default())
                .unwrap_err()
                .to_string()
        };
        let e = bad("EIGRL,1,100.,10.");
        assert!(
            e.contains("e.bdf line 6") && e.contains("V2 = 10 is not above V1 = 100"),
            "{e}"
        );
        let e = bad("EIGRL,1,,,-2");
        assert!(
            e.contains("ND = -2") && e.contains("a number of roots > 0"),
            "{e}"
        );
        let e = bad("EIGRL,1,,,2,,,,UNIT");
        assert!(e.contains("`UNIT`") && e.contains("MASS or MAX"), "{e}");
        let e = bad("EIGRL,1,,,2\nEIGRL,1,,,3");
        assert!(e.contains("line 7") && e.contains("line 6"), "{e}");
    }
}
