use super::*;

pub(super) fn parse(text: &str) -> BulkImport {
    match parse_bulk(text, "t.bdf") {
        Ok(b) => b,
        Err(e) => panic!("{e}"),
    }
}

pub(super) fn error(text: &str) -> String {
    match parse_bulk(text, "t.bdf") {
        Ok(_) => panic!("the deck should be rejected:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12)
}

/// A minimal valid plate deck to which the tests add cards.
const BASE: &str = "\
MAT1,1,2.1+11,,.3,7850.
PSHELL,10,1,.002,1,,1
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
";

#[test]
fn nastran_real_shorthands() {
    let cases = [
        ("1.5-3", 1.5e-3),
        ("7.+4", 7.0e4),
        (".5", 0.5),
        ("1+3", 1.0e3),
        ("1.E3", 1.0e3),
        ("1D3", 1.0e3),
        ("1.5d+2", 150.0),
        ("-2.5E-2", -0.025),
        ("+.5", 0.5),
        ("-.25-1", -0.025),
        ("42", 42.0),
        ("3.", 3.0),
        ("2.1+11", 2.1e11),
    ];
    for (text, value) in cases {
        assert_eq!(parse_real(text), Some(value), "{text}");
    }
    for bad in [
        "", ".", "-", "1.5.3", "E3", "1-", "1e", "abc", "--1", "inf", "nan", "1.0e400", "1 2",
    ] {
        assert_eq!(parse_real(bad), None, "{bad}");
    }
    assert_eq!(parse_int("+12"), Some(12));
    assert_eq!(parse_int("1."), None);
    assert_eq!(parse_int("1+3"), None);
}

#[test]
fn small_large_and_free_fields_with_continuations_and_comments() {
    // Ruler:  ------1-------2-------3-------4-------5-------6-------7-------8-------9-------10
    let deck = "\
ID femu,test
SOL 103
CEND
TITLE = SKIPPED $ executive and case control are skipped
INCLUDE 'does-not-exist-and-is-never-read.bdf'
BEGIN BULK
$ a comment line
PARAM,POST,-1
MAT1    1       2.1+11          .3      7850.
PSHELL  10      1       2.-3    1               1               .5
GRID    1               0.      0.      0.
GRID    2               1.5-1   0.      0.              123
GRID*   3                               .15             1.+0            +G3
*G3     0.
grid,4,,0.,1.0,0. $ lower case, inline comment
CQUAD4  100     10      1       2       3       4
CTRIA3,101,10,2,3,4
PBARL,20,1,,BAR
,.01,.02
CBAR    200     20      1       2       0.      0.      1.              +B200
+B200                   0.      0.      0.      0.      0.      0.
GRID    5               1.      1.      1.
CBEAM,201,20,3,5,1
EIGRL   1                       6
ENDDATA
GRID    99              this is never read
";
    let b = parse(deck);
    let m = &b.model;
    assert_eq!(m.nodes.len(), 5);
    assert!(close(m.nodes[&2], [0.15, 0.0, 0.0]));
    assert!(close(m.nodes[&3], [0.15, 1.0, 0.0]));
    assert!(close(m.nodes[&4], [0.0, 1.0, 0.0]));
    assert_eq!(
        m.shell_properties[&10],
        ShellProperty::homogeneous(1, 0.002, 0.5)
    );
    assert_eq!(m.materials[&1].e, 2.1e11);
    assert_eq!(
        m.elements[&100],
        Element::Quad4 {
            nodes: [1, 2, 3, 4],
            property: 10
        }
    );
    assert_eq!(
        m.elements[&101],
        Element::Tria3 {
            nodes: [2, 3, 4],
            property: 10
        }
    );
    assert_eq!(
        m.elements[&200],
        Element::Beam {
            nodes: [1, 2],
            property: 20,
            orientation: [0.0, 0.0, 1.0],
            ends: Default::default(),
        }
    );
    // G0 = 1: the orientation is x(G0) - x(GA).
    let Element::Beam { orientation, .. } = &m.elements[&201] else {
        panic!("not a beam");
    };
    assert!(close(*orientation, [-0.15, -1.0, 0.0]));
    assert_eq!(
        m.beam_properties[&20].section,
        BeamSection::Rectangle {
            width: 0.01,
            height: 0.02
        }
    );
    // GRID PS on grid 2.
    assert_eq!(
        m.constraints,
        vec![
            DofId::new(2, Component::Ux),
            DofId::new(2, Component::Uy),
            DofId::new(2, Component::Uz)
        ]
    );
    assert_eq!(m.sets["pid10"], vec![100, 101]);
    assert_eq!(m.sets["pid20"], vec![200, 201]);
    let unknown: Vec<(&str, usize)> = b.unknown.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    assert_eq!(unknown, vec![("PARAM,POST", 1)]);
    assert_eq!(b.eigen_request, None, "case control without METHOD");
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);
}

#[test]
fn cards_that_change_the_model_are_errors_unless_ignored() {
    let extra = "CQUAD4,1,10,1,2,3,4\nPARAM,POST,-1\nEIGRL,1,,,10\nFORCE,1,1,,1.,0.,0.,1.\nCGAP,2,1,1,2,3,4,5,6\n,7,8\nRSPLINE,9,1,123456,2\nRSPLINE,10,1,123456,3\n";
    let deck = format!("{BASE}{extra}");
    // Every card that may change K, M or constraints is listed at once, with counts and the
    // first place of each.
    let e = error(&deck);
    assert!(
        e.starts_with(
            "t.bdf: 3 card(s) femu does not read may change the stiffness, mass or constraints"
        ) && e.contains("CGAP ×1 (first at t.bdf line 11), RSPLINE ×2 (first at t.bdf line 13)")
            && e.contains("femu reads GRID, GRDSET")
            && e.contains("`ignore_cards`")
            && e.contains("`on_unsupported: warn`"),
        "{e}"
    );
    for card in [
        "RSPLINE,1,.1,2,3",
        "CSHEAR,5,10,1,2,3,4",
        "CFAST,5,1",
        "CWELD,5,1",
        "CQUAD,5,10,1,2,3,4",
        "CBUSH1D,5,5,1,2",
        "CGAP,5,5,1,2",
        "SUPORT,1,123456",
        "RBAR1,5,1,2,123456",
        "PARAM,SNORM,20.",
    ] {
        let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,4\n{card}\n"));
        let name = card.split(',').next().unwrap();
        let key = if name == "PARAM" { "PARAM,SNORM" } else { name };
        assert!(
            e.starts_with("t.bdf: 1 card(s) femu does not read")
                && e.contains(&format!(": {key} ×1 (first at t.bdf line 8)")),
            "{e}"
        );
    }
    // Accepted when the user lists them; skipped and ignored cards are counted apart.
    let opts = BulkOptions {
        ignore_cards: ["CGAP", "RSPLINE"].map(String::from).into(),
        ..BulkOptions::default()
    };
    let b = parse_bulk_with(&deck, "t.bdf", &opts).unwrap();
    assert_eq!(
        b.skipped,
        BTreeMap::from([("FORCE".to_string(), 1), ("PARAM,POST".to_string(), 1)])
    );
    assert_eq!(
        b.ignored,
        BTreeMap::from([("CGAP".to_string(), 1), ("RSPLINE".to_string(), 2)])
    );
    assert_eq!(b.unknown.len(), 4);
    // Or all of them, knowingly, with one warning that lists them.
    let opts = BulkOptions {
        on_unsupported: Unsupported::Warn,
        ..BulkOptions::default()
    };
    let b = parse_bulk_with(&deck, "t.bdf", &opts).unwrap();
    assert_eq!(
        b.ignored,
        BTreeMap::from([("CGAP".to_string(), 1), ("RSPLINE".to_string(), 2)])
    );
    assert!(
        b.warnings
            .iter()
            .any(|w| w.contains("3 card(s) femu does not read were dropped")
                && w.contains("RSPLINE ×2 (first at t.bdf line 13)")),
        "{:?}",
        b.warnings
    );
    // A PARAM is ignored by its name or as PARAM.
    let opts = BulkOptions {
        ignore_cards: ["PARAM,SNORM".to_string()].into(),
        ..BulkOptions::default()
    };
    let b = parse_bulk_with(
        &format!("{BASE}CQUAD4,1,10,1,2,3,4\nPARAM,SNORM,20.\n"),
        "t.bdf",
        &opts,
    )
    .unwrap();
    assert_eq!(b.ignored["PARAM,SNORM"], 1);
}

#[test]
fn wtmass_scales_every_mass_input() {
    // The same model written in "weight" units with WTMASS 0.5, and in mass units.
    let body = |rho: f64, nsm: f64, m: f64, i: f64| {
        format!(
            "MAT1,1,2.1+11,,.3,{rho}\nPSHELL,10,1,.002,1,,,,{nsm}\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\nCQUAD4,1,10,1,2,3,4\nPBAR,20,1,1.-4,1.-8,1.-8,1.-8,{nsm}\nCBAR,2,20,1,2,0.,0.,1.\nCONM2,3,3,0,{m},,,,,+M\n+M,{i},0.,{i},0.,0.,{i}\n"
        )
    };
    let weighted = parse(&format!(
        "PARAM,WTMASS,.5\n{}",
        body(7850.0, 0.4, 3.0, 0.02)
    ));
    let massed = parse(&body(3925.0, 0.2, 1.5, 0.01));
    assert_eq!(weighted.model, massed.model);
    assert!(
        weighted
            .warnings
            .iter()
            .any(|w| w.contains("PARAM,WTMASS,0.5 is applied")),
        "{:?}",
        weighted.warnings
    );
    // Applied, so not among the skipped cards.
    assert!(!weighted.skipped.contains_key("PARAM,WTMASS"));
    for (v, problem) in [
        ("0.", "WTMASS 0 is not a positive factor"),
        ("-2.", "WTMASS -2 is not"),
    ] {
        let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,4\nPARAM,WTMASS,{v}\n"));
        assert!(
            e.starts_with("t.bdf line 8: PARAM field 3 (V1): ") && e.contains(problem),
            "{e}"
        );
    }
    let e = error(&format!(
        "{BASE}CQUAD4,1,10,1,2,3,4\nPARAM,WTMASS,.5\nPARAM,WTMASS,.5\n"
    ));
    assert!(
        e.contains("WTMASS is given twice (first at t.bdf line 8)"),
        "{e}"
    );
}

#[test]
fn params_femu_replaces_warn_and_spc_values_are_zero_in_a_modal_model() {
    let b = parse(&format!(
        "{BASE}CQUAD4,1,10,1,2,3,4\nPARAM,COUPMASS,1\nPARAM,K6ROT,100.\nPARAM,AUTOSPC,NO\nPARAM,G,.02\nSPC,1,1,123,.5\n"
    ));
    for text in [
        "line 8: PARAM,COUPMASS,1: Nastran would use coupled (consistent) mass",
        "line 9: PARAM,K6ROT,100",
        "line 10: PARAM,AUTOSPC,NO",
        "line 11: PARAM,G,0.02 (structural damping)",
        "line 12: SPC 1: D1 = 0.5 at grid 1 is taken as 0",
    ] {
        assert!(
            b.warnings.iter().any(|w| w.contains(text)),
            "{text}: {:?}",
            b.warnings
        );
    }
    assert_eq!(b.model.constraints.len(), 3);
}

#[test]
fn a_deck_without_elements_or_not_nastran_is_refused_without_quoting_it() {
    let e = error(BASE);
    assert!(
        e.starts_with("t.bdf: no element was read (4 GRID card(s))"),
        "{e}"
    );
    let e = error("$ only a comment\n");
    assert!(e.contains("no element was read (0 GRID card(s))"), "{e}");
    // Words, a password file, a CSV: not quoted, said not to look like Nastran.
    for text in [
        "the quick brown fox\njumps over\n",
        "root:x:0:0:root:/root:/bin/bash\n",
        "secret,hunter2,more\n",
        "Password\n",
        "#!/bin/sh\n",
    ] {
        let e = error(text);
        assert!(e.contains("does not look like Nastran bulk data"), "{e}");
        for word in [
            "quick", "root", "hunter2", "Password", "PASSWORD", "SECRET", "bin",
        ] {
            assert!(!e.contains(word), "{word} quoted: {e}");
        }
    }
    // After a Nastran card, an offending line is quoted, shortened to 40 characters.
    let long = format!("{BASE}#{}\n", "x".repeat(200));
    let e = error(&long);
    assert!(e.contains(&format!("`#{}…`", "x".repeat(39))), "{e}");
    let e = error(&format!("{BASE}GRID,5,,{},0.,0.\n", "y".repeat(300)));
    assert!(
        e.contains(&format!("`{}…` is not a number", "y".repeat(40))),
        "{e}"
    );
}

#[test]
fn material_and_property_values_are_checked_at_the_card() {
    let quad = "CQUAD4,1,10,1,2,3,4\n";
    let grids = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\n";
    let cases = [
        (
            "MAT1,1,0.,,.3,7850.",
            "MAT1 field 3 (E): E = 0 is not positive",
        ),
        (
            "MAT1,1,-2.1+11,,.3,7850.",
            "MAT1 field 3 (E): E = -210000000000 is not positive",
        ),
        (
            "MAT1,1,,,.3,7850.",
            "MAT1 field 3 (E): E and G are both blank",
        ),
        (
            "MAT1,1,2.1+11,-1.,.3,7850.",
            "MAT1 field 4 (G): G = -1 is negative",
        ),
        (
            "MAT1,1,2.1+11,,.6,7850.",
            "MAT1 field 5 (NU): Poisson's ratio 0.6",
        ),
        (
            "MAT1,1,2.1+11,,-1.,7850.",
            "MAT1 field 5 (NU): Poisson's ratio -1",
        ),
        (
            "MAT1,1,2.1+11,1.+10,,7850.",
            "MAT1 field 5 (NU): Poisson's ratio 9.5",
        ),
        (
            "MAT1,1,2.1+11,,.3,-1.",
            "MAT1 field 6 (RHO): -1 is negative",
        ),
    ];
    for (mat, want) in cases {
        let e = error(&format!("{mat}\nPSHELL,10,1,.002,1\n{grids}{quad}"));
        assert!(
            e.starts_with(&format!("t.bdf line 1: {want}")),
            "{mat}: {e}"
        );
    }
    let mat = "MAT1,1,2.1+11,,.3,7850.\n";
    let props = [
        ("PSHELL,10,1,0.,1", "PSHELL field 4 (T): 0 is not positive"),
        (
            "PSHELL,10,1,.002,1,,,,-1.",
            "PSHELL field 9 (NSM): -1 is negative",
        ),
        (
            "PBAR,10,1,0.,1.-8,1.-8,1.-8",
            "PBAR field 4 (A): 0 is not positive",
        ),
        (
            "PBAR,10,1,1.-4,,1.-8,1.-8",
            "PBAR field 5 (I1): the field is blank",
        ),
        (
            "PBAR,10,1,1.-4,1.-8,1.-8,-1.",
            "PBAR field 7 (J): -1 is negative",
        ),
        (
            "PBEAM,10,1,1.-4,1.-8,0.",
            "PBEAM field 6 (I2(A)): 0 is not positive",
        ),
        (
            "PBARL,10,1,,BAR\n,.01,.02,-1.",
            "PBARL field 4 (NSM) of continuation 1",
        ),
        ("PELAS,10,-5.", "PELAS field 3 (K1): -5 is negative"),
        ("PBUSH,10,K,1.,-1.", "PBUSH field 5 (K2): -1 is negative"),
    ];
    for (prop, want) in props {
        let elem = if prop.starts_with("PSHELL") {
            quad.to_string()
        } else if prop.starts_with("PELAS") {
            "CELAS1,1,10,1,1\n".to_string()
        } else if prop.starts_with("PBUSH") {
            "CBUSH,1,10,1,2\n".to_string()
        } else {
            "CBAR,1,10,1,2,0.,0.,1.\n".to_string()
        };
        let e = error(&format!("{mat}{prop}\n{grids}{elem}"));
        assert!(
            e.starts_with(&format!("t.bdf line 2: {want}")),
            "{prop}: {e}"
        );
    }
    let e = error(&format!("{mat}{grids}CONM2,1,1,,-2.\n"));
    assert!(e.contains("CONM2 field 5 (M): -2 is negative"), "{e}");
    // A shell needs NU < 0.5; the MAT1 card allows 0.5: the element names both cards.
    let e = error(&format!(
        "MAT1,1,2.1+11,,.5,7850.\nPSHELL,10,1,.002,1\n{grids}{quad}"
    ));
    assert!(
        e.starts_with("t.bdf line 7: CQUAD4 1 (property 10 at t.bdf line 2, material 1 at t.bdf line 1): nu = 0.5 is out of range"),
        "{e}"
    );
    // Dangling references are named at the card with file and line.
    let e = error(&format!("{mat}PSHELL,10,2,.002,1\n{grids}{quad}"));
    assert!(
        e.starts_with("t.bdf line 2:") && e.contains("MAT1 2"),
        "{e}"
    );
    let e = error(&format!(
        "{mat}PSHELL,10,1,.002,1\n{grids}CQUAD4,1,11,1,2,3,4\n"
    ));
    assert!(e.starts_with("t.bdf line 7:"), "{e}");
    let e = error(&format!(
        "{mat}PSHELL,10,1,.002,1\n{grids}CQUAD4,1,10,1,2,3,9\n"
    ));
    assert!(
        e.starts_with("t.bdf line 7:") && e.contains("GRID 9"),
        "{e}"
    );
}

#[test]
fn cord2r_chains_place_grids() {
    // System 5: origin (1,2,3), z = basic z, x = basic y (so y = -basic x).
    // System 6 in 5: origin (0,0,1)_5 = (1,2,4), z along x_5 = basic y, x along z_5 = basic z,
    // y = z × x = basic x.
    let deck = "\
CORD2R*                6               5              0.              0.
*                     1.              1.              0.              1.
*                     0.              0.              2.
CORD2R,5,,1.,2.,3.,1.,2.,4.
,1.,3.,3.
GRID,1,5,1.,2.,.5
GRID,2,6,2.,3.,4.
GRID,3,0,1.,1.,1.
CONM2,9,3,,1.
";
    let m = parse(deck).model;
    assert!(close(m.nodes[&1], [-1.0, 3.0, 3.5]), "{:?}", m.nodes[&1]);
    assert!(close(m.nodes[&2], [4.0, 6.0, 6.0]), "{:?}", m.nodes[&2]);
    assert!(close(m.nodes[&3], [1.0, 1.0, 1.0]));
}

#[test]
fn include_relative_quoted_and_continued() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("parts");
    std::fs::create_dir(&sub).unwrap();
    std::fs::write(
        sub.join("grids.bdf"),
        "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nINCLUDE 'more.bdf'\n",
    )
    .unwrap();
    std::fs::write(sub.join("more.bdf"), "GRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\n").unwrap();
    let main = dir.path().join("main.bdf");
    std::fs::write(
        &main,
        "SOL 103\nCEND\nBEGIN BULK\nMAT1,1,2.1+11,,.3,7850.\nINCLUDE 'par\n  ts/grids.bdf'\nPSHELL,10,1,.002,1\nCQUAD4,1,10,1,2,3,4\nENDDATA\n",
    )
    .unwrap();
    let b = read_bulk(&main).unwrap();
    assert_eq!(b.model.nodes.len(), 4);
    assert_eq!(b.model.elements.len(), 1);

    // A cycle: grids.bdf includes main.bdf.
    std::fs::write(
        sub.join("more.bdf"),
        "GRID,3,,1.,1.,0.\nINCLUDE '../main.bdf'\n",
    )
    .unwrap();
    let e = read_bulk(&main).unwrap_err().to_string();
    assert!(e.contains("more.bdf line 2: INCLUDE of"), "{e}");
    assert!(e.contains("closes a cycle"), "{e}");

    let e = parse_bulk("INCLUDE 'missing.bdf'\n", &main.display().to_string())
        .unwrap_err()
        .to_string();
    assert!(e.contains("main.bdf line 1: INCLUDE of"), "{e}");
    assert!(e.contains("missing.bdf"), "{e}");
    let e = parse_bulk("INCLUDE 'open\n", "x.bdf")
        .unwrap_err()
        .to_string();
    assert!(e.contains("closing quote is missing"), "{e}");
}

#[test]
fn field_errors_name_file_line_card_and_field() {
    let e = error(&format!("{BASE}GRID,5,,0.,abc,0.\n"));
    assert_eq!(
        e,
        "t.bdf line 7: GRID field 5 (X2): `abc` is not a number; write a real number such as 2.1E11, 2.1+11, 0.5 or .5"
    );
    let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3\n"));
    assert_eq!(
        e,
        "t.bdf line 7: CQUAD4 field 7 (G4): the field is blank; an id (integer > 0) is required"
    );
    let e = error(&format!("{BASE}GRID,2,,5.,0.,0.\n"));
    assert_eq!(
        e,
        "t.bdf line 7: GRID field 2 (ID): grid 2 is already defined at t.bdf line 4; ids must be unique"
    );
    let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,4\nCTRIA3,1,10,1,2,3\n"));
    assert!(
        e.contains(
            "t.bdf line 8: CTRIA3 field 2 (EID): element 1 is already defined at t.bdf line 7"
        ),
        "{e}"
    );
    let e = error(&format!(
        "{BASE}PBARL,20,1,,BAR\n,.01,.02\nCBAR,5,20,1,2,0.,0.,1.\n,7\n"
    ));
    assert_eq!(
        e,
        "t.bdf line 9: CBAR field 2 (PA) of continuation 1 (line 10): pin flag 7 is not a set of DOFs; up to five distinct digits 1-6 (DOFs of the element system released at that end)"
    );
    let e = error(&format!("{BASE}PBAR,10,1,1.,1.,1.\n"));
    assert_eq!(
        e,
        "t.bdf line 7: PBAR field 2 (PID): property 10 is already defined at t.bdf line 2; ids must be unique"
    );
    let e = error(&format!("{BASE}PELAS,7,1.,,,7,2.\n"));
    assert!(
        e.contains(
            "t.bdf line 7: PELAS field 6 (PID2): property 7 is already defined at t.bdf line 7"
        ),
        "{e}"
    );
    // Large field: X3 sits on the second half-line, still field 6 of the first QRG line.
    let e = error(&format!(
        "{BASE}GRID*   5                               0.              0.\n*       1..5\n"
    ));
    assert_eq!(
        e,
        "t.bdf line 7: GRID field 6 (X3) (line 8): `1..5` is not a number; write a real number such as 2.1E11, 2.1+11, 0.5 or .5"
    );
    let e = error(&format!("{BASE}GRID,5,3,0.,0.,0.\n"));
    assert!(
        e.starts_with(
            "t.bdf line 7: GRID field 3 (CP): coordinate system 3 is not defined in the deck"
        ),
        "{e}"
    );
    let e = error(&format!("{BASE}SPC1,1,127,1\n"));
    assert!(
        e.starts_with("t.bdf line 7: SPC1 field 3 (C): `127` is not a component list"),
        "{e}"
    );
    let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,1.5\n"));
    assert!(
        e.starts_with("t.bdf line 7: CQUAD4 field 7 (G4): `1.5` is not an integer"),
        "{e}"
    );
    let e = error(&format!("{BASE}CBAR,5,20,1,2\n"));
    assert!(
        e.contains("CBAR field 6 (X1/G0): no orientation vector or G0 is given"),
        "{e}"
    );
    let e = error(&format!("{BASE}PBARL,20,1,,HEXA\n,.1,.1,.01\n"));
    assert!(
        e.contains("PBARL field 5 (TYPE): section type `HEXA` is not supported; BAR, ROD, TUBE"),
        "{e}"
    );
    let e = error(&format!("{BASE}CONM2,9,1,2,1.\n"));
    assert!(e.contains("line 7: CONM2 field 4 (CID)"), "{e}");
    assert!(
        e.contains("CONM2 field 4 (CID): coordinate system 2 is not defined in the deck"),
        "{e}"
    );
}

#[test]
fn syntax_errors_name_the_line() {
    let e = error("+C1     1.\nGRID,1,,0.,0.,0.\n");
    assert!(
        e.starts_with("t.bdf line 1: a continuation line comes before any card"),
        "{e}"
    );
    let e = error(&format!(
        "{BASE}CBAR    5       20      1       2       0.      0.      1.              +A\n+B      1\n"
    ));
    assert!(
        e.starts_with("t.bdf line 8: continuation `+B` does not match `+A`"),
        "{e}"
    );
    let e = error(&format!("{BASE}SPC1,1,123,1,2,3,4,5,6,7,8,9\n"));
    assert!(
        e.starts_with("t.bdf line 7: this free-field line has 12 fields"),
        "{e}"
    );
    let e = error(&format!("{BASE}1.0 2.0\n"));
    assert!(
        e.contains("t.bdf line 7: `1.0 2.0` starts neither a card nor a continuation"),
        "{e}"
    );
    let e = error(&format!(
        "{BASE}BEGIN SUPER=1\nGRID,101,,0.,0.,0.\n$ a comment\nGRID,102,,1.,0.,0.\nBEGIN SUPER = 2\nGRID,201,,0.,0.,0.\nENDDATA\n"
    ));
    assert!(
        e.contains("t.bdf line 7: `BEGIN SUPER=1` starts a part superelement")
            && e.contains(
                "2 such section(s): `BEGIN SUPER=1` at line 7 (2 lines), `BEGIN SUPER = 2` at line 11 (1 lines)"
            ),
        "{e}"
    );
}

#[test]
fn model_check_names_the_card_with_the_dangling_reference() {
    let e = error(&format!("{BASE}CQUAD4,1,10,1,2,3,9\n"));
    assert_eq!(
        e,
        "t.bdf line 7: element 1 (quad4) refers to node 9, which is not defined; add GRID 9 or correct the element's grid ids"
    );
    let e = error(&format!("{BASE}CQUAD4,1,11,1,2,3,4\n"));
    assert!(
        e.starts_with("t.bdf line 7: element 1 (quad4) refers to property 11"),
        "{e}"
    );
    let e = error(&format!("{BASE}PSHELL,11,2,.001,2\n"));
    assert!(
        e.starts_with(
            "t.bdf line 7: property 11 refers to material 2, which is not defined; add MAT1 2"
        ),
        "{e}"
    );
    let e = error(&format!("{BASE}SPC1,1,123,1,8\n"));
    assert!(
        e.starts_with("t.bdf line 7: a constraint refers to node 8"),
        "{e}"
    );
    let e = error(&format!("{BASE}SET1,3,1,2\n"));
    assert!(
        e.starts_with("t.bdf line 7: set `set3` lists element 1, which is not defined"),
        "{e}"
    );
    let e = error(&format!("{BASE}CELAS1,1,5,1,3\n"));
    assert!(
        e.contains("CELAS1 field 3 (PID): property 5 is not a PELAS"),
        "{e}"
    );
}

#[test]
fn beam_properties_pbar_pbarl_pbeam() {
    let deck = format!(
        "{BASE}\
CBAR,1,21,1,2,0.,0.,1.
PBAR,21,1,1.-4,2.-8,3.-8,4.-8,.1
,,,,,,,,
,.8,.9
PBARL,22,1,MSCBML0,ROD
,.005,.2
PBARL,23,1,,TUBE
,.01,.008
PBEAM,24,1,2.,3.,4.,,5.,.3
,1.,1.
,YES,.5,2.,,4.
,1.,1.
,NO,1.,2.,3.,4.,0.,5.,.3
,.8
PBEAM,25,1,2.,3.,4.,,5.
"
    );
    let m = parse(&deck).model;
    let sec = |id: u64| m.beam_properties[&id].section.clone();
    assert_eq!(
        sec(21),
        BeamSection::General {
            area: 1e-4,
            iy: 3e-8,
            iz: 2e-8,
            j: 4e-8,
            shear_y: 0.8,
            shear_z: 0.9
        }
    );
    assert_eq!(m.beam_properties[&21].nsm, 0.1);
    assert_eq!(sec(22), BeamSection::Circle { radius: 0.005 });
    assert_eq!(m.beam_properties[&22].nsm, 0.2);
    assert_eq!(
        sec(23),
        BeamSection::Tube {
            outer_radius: 0.01,
            inner_radius: 0.008
        }
    );
    assert_eq!(
        sec(24),
        BeamSection::General {
            area: 2.0,
            iy: 4.0,
            iz: 3.0,
            j: 5.0,
            shear_y: 0.8,
            shear_z: 1.0
        }
    );
    assert_eq!(m.beam_properties[&24].nsm, 0.3);
    // PBEAM K1/K2 default to 1.0, PBAR's to 0.0 (no shear flexibility).
    let BeamSection::General {
        shear_y, shear_z, ..
    } = sec(25)
    else {
        panic!("not general");
    };
    assert_eq!((shear_y, shear_z), (1.0, 1.0));

    let e = error(&format!(
        "{BASE}PBEAM,24,1,2.,3.,4.,,5.\n,YES,.5,1.,3.,4.,,5.\n"
    ));
    assert!(
        e.contains(
            "PBEAM field 3 (X/XB) of continuation 1 (line 8): the last station is at X/XB = 0.5"
        ),
        "{e}"
    );
    let e = error(&format!("{BASE}PBAR,21,1,1.,1.,1.\n,,,,,,,,\n,,,.5\n"));
    assert!(e.contains("PBAR field 4 (I12) of continuation 2"), "{e}");
}

#[test]
fn mat1_derives_the_missing_constant() {
    let deck = "MAT1,1,2.1+11,,.3,7850.\nMAT1,2,2.6+10,1.+10\nMAT1,3,,1.+10,.3\nMAT1,4,1.+9\nMAT1,5,200.,80.,.3\nGRID,1\nCONM2,1,1,,1.\n";
    let b = parse(deck);
    let m = &b.model.materials;
    assert_eq!((m[&1].e, m[&1].nu, m[&1].rho), (2.1e11, 0.3, 7850.0));
    assert!((m[&2].nu - 0.3).abs() < 1e-12);
    assert!((m[&3].e - 2.6e10).abs() < 1e-3);
    assert_eq!(m[&4].nu, 0.0);
    assert_eq!((m[&5].e, m[&5].nu), (200.0, 0.3));
    assert_eq!(b.warnings.len(), 2, "{:?}", b.warnings);
    assert!(b.warnings[0].starts_with("t.bdf line 4: MAT1 4: G and NU are blank"));
    assert!(b.warnings[1].starts_with("t.bdf line 5: MAT1 5: G = 80 does not equal E/(2(1+NU))"));
    let e = error("MAT1,1,,,.3\n");
    assert!(
        e.contains("MAT1 field 3 (E): E and G are both blank"),
        "{e}"
    );
}

#[test]
fn springs_bushes_masses() {
    let deck = format!(
        "{BASE}\
CELAS1,20,7,1,3,2,3
PELAS,7,1000.,.01,,8,2000.
CELAS1,21,8,3,6
CELAS2,22,500.,,,4,2
CBUSH,30,9,1,2,,,,0
CBUSH,31,9,3,,,,,0
PBUSH,9,K,1.+6,2.+6,3.+6,,,6.
,,B,10.
CONM2,40,4,,2.5,.1,,.2
,1.,.1,2.,,,3.
CONM2,41,3,-1,1.,1.,1.,.5
"
    );
    let b = parse(&deck);
    let m = &b.model;
    assert_eq!(
        m.elements[&20],
        Element::ScalarSpring {
            dof: DofId::new(1, Component::Uz),
            other: Some(DofId::new(2, Component::Uz)),
            k: 1000.0
        }
    );
    assert_eq!(
        m.elements[&21],
        Element::ScalarSpring {
            dof: DofId::new(3, Component::Rz),
            other: None,
            k: 2000.0
        }
    );
    assert_eq!(
        m.elements[&22],
        Element::ScalarSpring {
            dof: DofId::new(4, Component::Uy),
            other: None,
            k: 500.0
        }
    );
    let k = [1e6, 2e6, 3e6, 0.0, 0.0, 6.0];
    assert_eq!(
        m.elements[&30],
        Element::Bush {
            node: 1,
            other: Some(2),
            k,
            axes: None,
            b: [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        }
    );
    assert_eq!(
        m.elements[&31],
        Element::Bush {
            node: 3,
            other: None,
            k,
            axes: None,
            b: [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        }
    );
    assert_eq!(
        m.elements[&40],
        Element::Mass {
            node: 4,
            mass: 2.5,
            inertia: [1.0, 0.1, 2.0, 0.0, 0.0, 3.0],
            offset: [0.1, 0.0, 0.2]
        }
    );
    let Element::Mass { offset, .. } = &m.elements[&41] else {
        panic!("not a mass");
    };
    assert!(close(*offset, [0.0, 0.0, 0.5]));
    let w = b.warnings.join("\n");
    assert!(w.contains("PELAS 7: damping GE is ignored"), "{w}");
    assert_eq!(b.warnings.len(), 1, "{w}");
}

#[test]
fn spc_spc1_set1_with_thru() {
    let deck = format!(
        "{BASE}\
GRID,7,,2.,2.,0.
CQUAD4,1,10,1,2,3,4
CTRIA3,2,10,1,2,3
CTRIA3,5,10,2,3,4
SPC,1,1,12,,2,3
SPC1,1,6,1,THRU,100
SPC1,2,45,4
SET1,3,1,THRU,4,5
SET1,4,SKIN,2
GRID,8,,3.,3.,3.,,246
"
    );
    let b = parse(&deck);
    let m = &b.model;
    let c = |n, comp| DofId::new(n, comp);
    use Component::*;
    let mut want = vec![
        c(1, Ux),
        c(1, Uy),
        c(2, Uz),
        c(4, Rx),
        c(4, Ry),
        c(8, Uy),
        c(8, Rx),
        c(8, Rz),
    ];
    want.extend([1, 2, 3, 4, 7, 8].map(|n| c(n, Rz)));
    want.sort();
    want.dedup();
    assert_eq!(m.constraints, want);
    assert_eq!(m.sets["set3"], vec![1, 2, 5]);
    assert_eq!(m.sets["set4"], vec![2]);
    assert_eq!(b.warnings.len(), 1);
    assert!(
        b.warnings[0].contains("SPC/SPC1 sets 1, 2 are merged"),
        "{:?}",
        b.warnings
    );
}

#[test]
fn stated_deviations_warn() {
    // PSHELL MID1/MID2/MID3, 12I/T³ and TS/T have their Nastran meaning (tests_rods.rs);
    // MID3 blank is a stated deviation (Mindlin shear kept).
    let deck = format!(
        "{BASE}\
PSHELL,11,1,.001,1
CQUAD4,1,10,1,2,3,4
,,,.1,.1,.1,.1
"
    );
    let b = parse(&deck);
    let w = b.warnings.join("\n");
    assert!(w.contains("PSHELL 11: MID3 is blank"), "{w}");
    assert!(w.contains("CQUAD4 1: corner thicknesses"), "{w}");
    // ZOFFS is read (tests_laminates.rs): the element's offset, no warning.
    let b = parse(&format!("{BASE}CQUAD4,1,10,1,2,3,4,,.001\n"));
    assert_eq!(b.model.shell_placements[&1].offset, 0.001);
}

#[test]
fn femu_comments_name_sets_and_carry_parameters() {
    let deck = format!(
        "{BASE}\
CQUAD4,1,10,1,2,3,4
$femu-set 2 skin
SET1,2,1
$femu-set 3 nothing
$femu-parameter {{\"name\":\"t\",\"kind\":\"shell_thickness\",\"set\":\"skin\",\"lower\":0.001,\"upper\":0.003}}
"
    );
    let m = parse(&deck).model;
    assert_eq!(m.sets["skin"], vec![1]);
    assert_eq!(m.sets["nothing"], Vec::<u64>::new());
    assert_eq!(m.parameters.len(), 1);
    assert_eq!(m.parameters[0].set, "skin");
    let e = error("$femu-parameter {\"name\":1}\n");
    assert!(
        e.starts_with("t.bdf line 1: the femu parameter comment is not a valid parameter"),
        "{e}"
    );
}

#[test]
fn fixture_plate_with_bar() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/nastran/plate_with_bar.bdf");
    let b = read_bulk(&path).unwrap();
    let m = &b.model;
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);
    assert_eq!(b.unknown.len(), 1);
    assert_eq!(b.skipped["PARAM,POST"], 1);
    let asked = crate::eigen::EigenRequest {
        count: Some(10),
        ..Default::default()
    };
    assert_eq!(b.eigen_request, Some(asked), "METHOD = 1 selects EIGRL 1");
    assert!(b.ignored.is_empty());
    assert_eq!(m.nodes.len(), 25);
    for j in 0..5u64 {
        for i in 0..5u64 {
            let want = [0.1 * i as f64, 0.1 * j as f64, 0.0];
            assert!(
                close(m.nodes[&(1 + i + 5 * j)], want),
                "grid {}",
                1 + i + 5 * j
            );
        }
    }
    assert_eq!(m.elements.len(), 20);
    for j in 0..4u64 {
        for i in 0..4u64 {
            let n = 1 + i + 5 * j;
            assert_eq!(
                m.elements[&(1 + i + 4 * j)],
                Element::Quad4 {
                    nodes: [n, n + 1, n + 6, n + 5],
                    property: 1
                }
            );
        }
    }
    for (e, a) in [(101, 11), (102, 12), (103, 13), (104, 14)] {
        assert_eq!(
            m.elements[&e],
            Element::Beam {
                nodes: [a, a + 1],
                property: 2,
                orientation: [0.0, 0.0, 1.0],
                ends: Default::default(),
            }
        );
    }
    assert_eq!(
        m.materials[&1],
        Material {
            e: 2.1e11,
            nu: 0.3,
            rho: 7850.0
        }
    );
    assert_eq!(m.shell_properties[&1].thickness, 0.002);
    assert_eq!(
        m.beam_properties[&2],
        BeamProperty {
            material: 1,
            section: BeamSection::Rectangle {
                width: 0.01,
                height: 0.02
            },
            nsm: 0.0,
            taper: None,
            centres: None,
        }
    );
    let clamped: Vec<DofId> = [1, 6, 11, 16, 21]
        .into_iter()
        .flat_map(|n| Component::ALL.map(|c| DofId::new(n, c)))
        .collect();
    assert_eq!(m.constraints, clamped);
    assert_eq!(m.sets["set5"], vec![101, 102, 103, 104]);
    assert_eq!(m.sets["pid1"], (1..=16).collect::<Vec<u64>>());
    assert_eq!(m.sets["pid2"], vec![101, 102, 103, 104]);
}
