//! What an import tells its user about a file: the conversions of its FRF records, a note that
//! many records share (a unit conversion, a sign rule) said once with the records it applies
//! to. A lab export of 300 FRFs in `g/N` gave 300 equal lines.

use super::UffFile;
use std::collections::HashMap;

/// Records listed by name in a shared note; the rest are counted.
const SHOWN: usize = 3;

/// The file's conversions for its user: each FRF record's own note as it is, a note two or
/// more records share once (`file: note, in N FRF records: H(r, e) (line L), …`), in the order
/// of the first record that has it, then the file's other conversions (coordinates, shapes).
pub fn grouped_conversions(file: &UffFile) -> Vec<String> {
    // (file, note) → the first record's note as written and the records it applies to, as
    // "H(r, e) (line L)", in first-seen order.
    let mut groups: Vec<(&str, &str, &str, Vec<String>)> = Vec::new();
    let mut index: HashMap<(&str, &str), usize> = HashMap::new();
    let mut of_records: std::collections::HashSet<&str> = std::collections::HashSet::new();
    let mut unmatched = Vec::new();
    for rec in &file.frfs {
        let prefix = format!(
            "{}:{} H({}, {}): ",
            rec.file, rec.line, rec.response, rec.reference
        );
        for c in &rec.conversions {
            of_records.insert(c.as_str());
            let Some(note) = c.strip_prefix(&prefix) else {
                unmatched.push(c.clone());
                continue;
            };
            let at = format!("H({}, {}) (line {})", rec.response, rec.reference, rec.line);
            let k = *index.entry((rec.file.as_str(), note)).or_insert_with(|| {
                groups.push((rec.file.as_str(), note, c.as_str(), Vec::new()));
                groups.len() - 1
            });
            groups[k].3.push(at);
        }
    }
    let mut out: Vec<String> = groups
        .into_iter()
        .map(|(file, note, written, records)| match records.len() {
            1 => written.to_string(),
            _ => format!(
                "{file}: {note}, in {} FRF records: {}",
                records.len(),
                crate::core::first_of(records.iter(), SHOWN)
            ),
        })
        .collect();
    out.extend(unmatched);
    out.extend(
        file.conversions
            .iter()
            .filter(|c| !of_records.contains(c.as_str()))
            .cloned(),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lab plate (a Simcenter Testlab export, 12 FRFs in g/N, one response measured in
    /// the negative direction): the unit conversion once for all twelve records, the sign rule
    /// as its record wrote it, and nothing lost.
    #[test]
    fn a_note_shared_by_records_is_said_once() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/lab/plate.uff");
        let file = super::super::read_uff(&path).unwrap();
        let each = file.conversions.clone();
        let grouped = grouped_conversions(&file);
        let shared: Vec<&String> = grouped
            .iter()
            .filter(|n| n.contains("ordinate converted to SI"))
            .collect();
        let records = each
            .iter()
            .filter(|n| n.contains("ordinate converted to SI"))
            .count();
        assert!(records >= 2, "{each:?}");
        assert_eq!(shared.len(), 1, "{grouped:?}");
        assert!(
            shared[0].contains(&format!(
                ": ordinate converted to SI m/s^2/N from record 9 label `g` and record 10 label `N`: ×9.80665e0, in {records} FRF records: H(101:uz, 110:uz) (line 56), H(102:uz, 110:uz) (line 187), H(103:uz, 110:uz) (line 318), and {} more",
                records - 3
            )),
            "{}",
            shared[0]
        );
        // A note of one record alone reads as before, and every other conversion is kept.
        let single: Vec<&String> = each
            .iter()
            .filter(|n| !n.contains("ordinate converted to SI"))
            .collect();
        for n in &single {
            assert!(grouped.contains(n), "{n} lost from {grouped:?}");
        }
        assert_eq!(grouped.len(), single.len() + 1);
    }
}
