//! Bounded fuzzing of the importers: arbitrary bytes and structured mutations of real decks and
//! universal files (small, large and free field Nastran with continuations; UFF 58 ASCII and
//! 58b) never make a reader panic, and every error names the file it is about. Each property
//! runs a fixed number of cases (a few seconds in release).

mod common;

use common::root;
use femu::frf::io::uff;
use femu::model::import::nastran;
use proptest::prelude::*;

const DECK_NAME: &str = "fuzz-dir-that-does-not-exist/deck.bdf";
const UFF_NAME: &str = "fuzz.uff";

/// The fixture deck (small field, `+` continuations and comments).
fn small_field() -> String {
    std::fs::read_to_string(root().join("fixtures/nastran/plate_with_bar.bdf")).unwrap()
}

/// A free-field deck with implicit and explicit continuations.
const FREE_FIELD: &str = "\
BEGIN BULK
MAT1,1,2.1+11,,.3,7850.
PSHELL,10,1,.002,1
PBARL,20,1,,BAR,,,,,+PB
+PB,.01,.02
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
CQUAD4,1,10,1,2,3,4
CBAR,2,20,1,2,0.,0.,1.
,,,,,,,
CONM2,3,3,,2.5
CELAS2,4,1.+5,4,3
SPC1,1,123456,1,THRU,2
SET1,5,1,2
ENDDATA
";

/// A large-field deck (`NAME*` and `*` continuation half-lines).
fn large_field() -> String {
    let mut s = String::from("BEGIN BULK\n");
    let f16 = |v: &str| format!("{v:<16}");
    let card = |name: &str, fields: &[&str]| {
        let mut out = format!("{name:<8}");
        for (i, f) in fields.iter().enumerate() {
            if i > 0 && i % 4 == 0 {
                out.push_str("\n*       ");
            }
            out.push_str(&f16(f));
        }
        out.push('\n');
        out
    };
    s.push_str(&card("MAT1*", &["1", "2.1+11", "", ".3", "7850."]));
    s.push_str(&card("PSHELL*", &["10", "1", ".002", "1"]));
    for (id, x, y) in [
        (1, "0.", "0."),
        (2, "1.", "0."),
        (3, "1.", "1."),
        (4, "0.", "1."),
    ] {
        s.push_str(&card("GRID*", &[&id.to_string(), "", x, y, "0."]));
    }
    s.push_str(&card("CQUAD4*", &["1", "10", "1", "2", "3", "4"]));
    s.push_str("ENDDATA\n");
    s
}

/// Fields and words that exercise the readers' edge cases.
const TOKENS: [&str; 26] = [
    "",
    "0",
    "-1",
    "1.5-3",
    ".5",
    "7.+4",
    "1D3",
    "NaN",
    "inf",
    "1e400",
    "THRU",
    "+",
    "*",
    "$",
    ",",
    "=",
    "\t",
    "é",
    "99999999999999999999",
    "INCLUDE 'x.bdf'",
    "BEGIN BULK",
    "ENDDATA",
    "GRID",
    "CQUAD4*",
    "    -1",
    "    58b     1     2          11          10",
];

/// One structured mutation of a line-oriented text.
#[derive(Clone, Debug)]
enum Mutation {
    DeleteLine(usize),
    DuplicateLine(usize),
    SwapLines(usize, usize),
    ReplaceField {
        line: usize,
        field: usize,
        token: usize,
    },
    InsertBytes {
        at: usize,
        bytes: Vec<u8>,
    },
    Truncate(usize),
    FlipByte {
        at: usize,
        bit: u8,
    },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        any::<usize>().prop_map(Mutation::DeleteLine),
        any::<usize>().prop_map(Mutation::DuplicateLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        (any::<usize>(), 0usize..12, 0..TOKENS.len())
            .prop_map(|(line, field, token)| Mutation::ReplaceField { line, field, token }),
        (any::<usize>(), prop::collection::vec(any::<u8>(), 1..12))
            .prop_map(|(at, bytes)| Mutation::InsertBytes { at, bytes }),
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), 0u8..8).prop_map(|(at, bit)| Mutation::FlipByte { at, bit }),
    ]
}

/// Applies mutations to bytes, line-wise where the mutation is about lines; fields are cut at
/// commas when the line has any, else in 8-column slots.
fn mutate(seed: &[u8], ms: &[Mutation]) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    for m in ms {
        let mut lines: Vec<Vec<u8>> = bytes.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
        let n = lines.len().max(1);
        match m {
            Mutation::DeleteLine(i) => {
                if !lines.is_empty() {
                    lines.remove(i % n);
                }
            }
            Mutation::DuplicateLine(i) => {
                if let Some(l) = lines.get(i % n).cloned() {
                    lines.insert(i % n, l);
                }
            }
            Mutation::SwapLines(a, b) => {
                if !lines.is_empty() {
                    lines.swap(a % n, b % n);
                }
            }
            Mutation::ReplaceField { line, field, token } => {
                if let Some(l) = lines.get_mut(line % n) {
                    let tok = TOKENS[*token].as_bytes();
                    if l.contains(&b',') {
                        let mut parts: Vec<Vec<u8>> =
                            l.split(|&b| b == b',').map(<[u8]>::to_vec).collect();
                        let k = field % parts.len();
                        parts[k] = tok.to_vec();
                        *l = parts.join(&b","[..]);
                    } else {
                        let a = (field * 8).min(l.len());
                        let b = (a + 8).min(l.len());
                        let mut slot = tok.to_vec();
                        slot.resize(8.max(tok.len()), b' ');
                        l.splice(a..b, slot);
                    }
                }
            }
            Mutation::InsertBytes { at, bytes: ins } => {
                let at = at % (bytes.len() + 1);
                bytes.splice(at..at, ins.iter().copied());
                continue;
            }
            Mutation::Truncate(at) => {
                bytes.truncate(at % (bytes.len() + 1));
                continue;
            }
            Mutation::FlipByte { at, bit } => {
                if !bytes.is_empty() {
                    let at = at % bytes.len();
                    bytes[at] ^= 1 << bit;
                }
                continue;
            }
        }
        bytes = lines.join(&b"\n"[..]);
    }
    bytes
}

/// Parses a deck; an error must name the file.
fn check_deck(bytes: &[u8]) -> Result<(), TestCaseError> {
    let text = String::from_utf8_lossy(bytes);
    if let Err(e) = nastran::parse_bulk(&text, DECK_NAME) {
        let m = e.to_string();
        prop_assert!(
            m.contains(DECK_NAME),
            "the error does not name the file: {m}"
        );
    }
    Ok(())
}

/// Parses a universal file and groups its FRFs; an error must name the file.
fn check_uff(bytes: &[u8]) -> Result<(), TestCaseError> {
    match uff::parse_uff(bytes, UFF_NAME) {
        Err(e) => {
            let m = e.to_string();
            prop_assert!(
                m.contains(UFF_NAME),
                "the error does not name the file: {m}"
            );
        }
        Ok(f) => {
            if let Err(e) = uff::to_frf_set(&f.frfs) {
                let m = e.to_string();
                prop_assert!(
                    f.frfs.is_empty() || m.contains(UFF_NAME),
                    "the error does not name the file: {m}"
                );
            }
            for rec in &f.frfs {
                prop_assert!(
                    rec.values
                        .iter()
                        .all(|v| v.re.is_finite() && v.im.is_finite()),
                    "a non-finite value was accepted"
                );
            }
        }
    }
    Ok(())
}

fn uff_ascii() -> Vec<u8> {
    std::fs::read(root().join("fixtures/uff/four_dof_receptance.uff")).unwrap()
}

fn uff_binary() -> Vec<u8> {
    let f = uff::read_uff(root().join("fixtures/uff/four_dof_receptance.uff")).unwrap();
    let set = uff::to_frf_set(&f.frfs).unwrap();
    uff::write_uff58(&set, true)
}

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

#[test]
fn the_seeds_are_valid() {
    for deck in [small_field(), FREE_FIELD.to_string(), large_field()] {
        nastran::parse_bulk(&deck, DECK_NAME).unwrap_or_else(|e| panic!("{e}\n{deck}"));
    }
    for file in [uff_ascii(), uff_binary()] {
        let f = uff::parse_uff(&file, UFF_NAME).unwrap();
        assert_eq!(uff::to_frf_set(&f.frfs).unwrap().pairs.len(), 4);
    }
}

proptest! {
    #![proptest_config(config(1500))]

    #[test]
    fn nastran_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..2000)) {
        check_deck(&bytes)?;
    }

    #[test]
    fn nastran_small_field_mutations(ms in prop::collection::vec(mutation(), 1..6)) {
        check_deck(&mutate(small_field().as_bytes(), &ms))?;
    }

    #[test]
    fn nastran_free_field_mutations(ms in prop::collection::vec(mutation(), 1..6)) {
        check_deck(&mutate(FREE_FIELD.as_bytes(), &ms))?;
    }

    #[test]
    fn nastran_large_field_mutations(ms in prop::collection::vec(mutation(), 1..6)) {
        check_deck(&mutate(large_field().as_bytes(), &ms))?;
    }

    #[test]
    fn uff_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..2000)) {
        check_uff(&bytes)?;
    }

    #[test]
    fn uff_ascii_mutations(ms in prop::collection::vec(mutation(), 1..6)) {
        check_uff(&mutate(&uff_ascii(), &ms))?;
    }

    #[test]
    fn uff_binary_mutations(ms in prop::collection::vec(mutation(), 1..6)) {
        check_uff(&mutate(&uff_binary(), &ms))?;
    }
}
