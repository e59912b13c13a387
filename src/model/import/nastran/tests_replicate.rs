//! Replication against the same deck written in full.

use super::*;

fn nodes(text: &str) -> BTreeMap<u64, [f64; 3]> {
    parse_bulk(text, "r.bdf").unwrap().model.nodes
}

const ELEMENTS: &str = "MAT1,1,2.1+11,,.3,7850.\nPSHELL,1,1,.002,1\nCQUAD4,1,1,101,102,106,105\nCQUAD4,2,1,102,103,107,106\nCQUAD4,3,1,103,104,108,107\n";

/// The QRG's example pattern: `=`, `*x`, `==`, then `=n` repeating the increments, in free and
/// small field, equals the grids written out.
#[test]
fn replicated_grids_equal_the_grids_in_full() {
    let replicated = format!(
        "GRID,101,,0.,0.,0.\n=,*1,=,*0.5,==\n=2\nGRID    105             0.      1.      0.\n=       *1              *(.5)   =       =\n=(2)\n{ELEMENTS}"
    );
    let mut full = String::new();
    for i in 0..4 {
        full.push_str(&format!("GRID,{},,{},0.,0.\n", 101 + i, 0.5 * i as f64));
        full.push_str(&format!("GRID,{},,{},1.,0.\n", 105 + i, 0.5 * i as f64));
    }
    full.push_str(ELEMENTS);
    assert_eq!(nodes(&replicated), nodes(&full));
    assert_eq!(nodes(&replicated)[&108], [1.5, 1.0, 0.0]);
}

/// Replication that cannot be read is an error at its line saying what is valid.
#[test]
fn unreadable_replication_is_an_error_at_its_line() {
    for (bad, want) in [
        (
            "=,*1\nGRID,1,,0.,0.,0.\n",
            "line 1: a replication line comes before any card",
        ),
        (
            "GRID,1,,0.,0.,0.\n=3\n",
            "line 2: `=n` follows no replicated entry",
        ),
        ("GRID,1,,0.,0.,0.\n=,*1,,*a\n", "`*a` cannot increment `0.`"),
        ("GRID,1,,0.,0.,0.\n=0\n", "`=0` is not a replication count"),
        (
            "CBAR,1,1,1,2,0.,0.,1.\n,,,0.,0.,.1\n=,*1,==\n",
            "line 3: replication of CBAR (line 1), an entry with continuations",
        ),
    ] {
        let e = parse_bulk(&format!("{bad}{ELEMENTS}"), "r.bdf")
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{bad:?}: {e}");
    }
}

/// PARAM,GRDPNT names the weight summary's reference point: a grid's position, the origin for
/// 0, nothing for −1; an undefined grid is an error at the card.
#[test]
fn grdpnt_gives_the_reference_point() {
    let deck = |v: &str| {
        format!(
            "PARAM,GRDPNT,{v}\nGRID,101,,0.,0.,0.\nGRID,102,,1.,0.,0.\nGRID,103,,2.,0.,0.\nGRID,104,,3.,0.,0.\nGRID,105,,0.,1.,0.\nGRID,106,,1.,1.,0.\nGRID,107,,2.,1.,0.\nGRID,108,,3.,1.,5.\n{ELEMENTS}"
        )
    };
    let at = |v: &str| parse_bulk(&deck(v), "g.bdf").map(|b| b.grdpnt);
    assert_eq!(at("108").unwrap(), Some([3.0, 1.0, 5.0]));
    assert_eq!(at("0").unwrap(), Some([0.0; 3]));
    assert_eq!(at("-1").unwrap(), None);
    let e = at("99").unwrap_err().to_string();
    assert!(e.contains("grid 99 is not defined"), "{e}");
}
