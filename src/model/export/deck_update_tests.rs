//! Tests of writing an updated model back into its Nastran deck: re-import gives the updated
//! model, an unchanged model gives the deck back, and what cannot be written is refused.

use super::*;
use crate::core::Component;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::assemble_model;
use crate::model::import::nastran::{read_bulk, read_deck};
use crate::model::{Parameter, ParameterKind};
use std::path::Path;

/// A small-field line from its fields (8 columns each).
fn small(fields: &[&str]) -> String {
    fields
        .iter()
        .map(|f| format!("{f:<8}"))
        .collect::<String>()
        .trim_end()
        .to_string()
}

/// A plate of four CQUAD4 in two properties sharing MAT1 1, a CONM2, a CBUSH to ground
/// and a CELAS2, with WTMASS 0.5; properties in an INCLUDE. Mixed small, large and free
/// field, comments, CRLF in the include.
fn write_deck(dir: &Path, t2: &str) {
    let mut main = String::from(
        "SOL 103\nCEND\nBEGIN BULK\n$ the plate\nPARAM,WTMASS,0.5\nINCLUDE 'props.bdf'\n",
    );
    let mut id = 1;
    for j in 0..3 {
        for i in 0..3 {
            let (x, y) = (format!("{}.", i), format!("{}.", j));
            main.push_str(&small(&["GRID", &id.to_string(), "", &x, &y, "0."]));
            main.push('\n');
            id += 1;
        }
    }
    let quads = [
        (1, 1, [1, 2, 5, 4]),
        (2, 1, [2, 3, 6, 5]),
        (3, 2, [4, 5, 8, 7]),
    ];
    for (eid, pid, n) in quads {
        main.push_str(&format!(
            "CQUAD4,{eid},{pid},{},{},{},{}\n",
            n[0], n[1], n[2], n[3]
        ));
    }
    main.push_str(
        "CQUAD4*  4               2               5               6\n*       9               8\n",
    );
    main.push_str("SPC1,1,123456,1,4,7\n");
    main.push_str(&small(&["CONM2", "10", "9", "", "2.0"]));
    main.push('\n');
    main.push_str(&small(&["CBUSH", "11", "21", "7", "", "", "", "", "0"]));
    main.push('\n');
    main.push_str("CELAS2,12,1.+4,8,3\nPROD,20,1,1.-4,0.\nCROD,21,20,2,3\nCONROD,22,5,6,1,2.-4,0.\nSET1,5,10\nSET1,6,11\nSET1,7,12\nSET1,8,1\nSET1,9,22\nENDDATA\n");
    std::fs::write(dir.join("main.bdf"), main).unwrap();
    let props = format!(
        "{}\r\n{}\r\n$ steel\r\nMAT1,1,2.1+11,,.3,7850.\r\n{}\r\n",
        small(&["PSHELL", "1", "1", ".002", "1"]),
        small(&["PSHELL", "2", "1", t2, "1"]),
        small(&["PBUSH", "21", "K", "1.+5", "2.+5", "3.+5"])
    );
    std::fs::write(dir.join("props.bdf"), props).unwrap();
}

fn param(name: &str, kind: ParameterKind, set: &str) -> Parameter {
    Parameter {
        name: name.into(),
        kind,
        set: set.into(),
        lower: 1e-12,
        upper: 1e15,
    }
}

/// The deck's model with new values: element 1's thickness (a copy of PSHELL 1, which the
/// model numbers 21 after PROD 20, but 21 is the PBUSH's in the deck, so 22), pid2's thickness and modulus (MAT1 1 is shared
/// with pid1, so a copy), the CONM2's mass, the bush's y stiffness and the CELAS2's k.
fn updated(model: &Model) -> Model {
    let mut m = model.clone();
    let values = [
        (param("t1", ParameterKind::ShellThickness, "set8"), 0.0015),
        (param("t2", ParameterKind::ShellThickness, "pid2"), 0.0031),
        (
            param("e_conrod", ParameterKind::YoungsModulus, "set9"),
            7e10,
        ),
        (param("e2", ParameterKind::YoungsModulus, "pid2"), 1.9e11),
        (param("rho2", ParameterKind::Density, "pid2"), 7700.0),
        (
            param("m", ParameterKind::LumpedMass(Component::Ux), "set5"),
            1.25,
        ),
        (
            param("ky", ParameterKind::SpringStiffness(Component::Uy), "set6"),
            2.5e5,
        ),
        (
            param("ks", ParameterKind::SpringStiffness(Component::Uz), "set7"),
            1.0 / 3.0 * 1e4,
        ),
    ];
    for (p, v) in values {
        m.set_parameter_value(&p, v).unwrap();
    }
    m
}

fn written(dir: &Path, out: &UpdatedDeck) -> std::path::PathBuf {
    let out_dir = dir.join("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    for (name, bytes) in &out.files {
        std::fs::write(out_dir.join(name), bytes).unwrap();
    }
    out_dir.join(&out.files[0].0)
}

/// Updated scalar masses go back into CMASS2 `M` and into the PMASS `M2` of a CMASS1 (the
/// only user of that property), divided by WTMASS; re-imported they are the updated ones
/// exactly. A PMASS whose users were updated apart is an error naming it.
#[test]
fn scalar_masses_are_written_back() {
    let dir = tempfile::tempdir().unwrap();
    let top = dir.path().join("main.bdf");
    let text = "PARAM,WTMASS,.5\nSPOINT,1,2\nCELAS4,1,1.+4,1,2\nCMASS2,2,4.,1\nCMASS1,3,8,2\nCMASS1,4,7,2\nPMASS,7,1.,8,6.\nENDDATA\n";
    std::fs::write(&top, text).unwrap();
    let model = read_bulk(&top).unwrap().model;
    let mut new = model.clone();
    for (id, v) in [(2, 2.5), (3, 1.25)] {
        if let Some(Element::ScalarMass { m, .. }) = new.elements.get_mut(&id) {
            *m = v;
        }
    }
    let deck = read_deck(&top).unwrap();
    let out = update_deck(&deck, &model, &new, &["test".to_string()]).unwrap();
    let back = read_bulk(written(dir.path(), &out)).unwrap().model;
    assert_eq!(back, new);
    let written_text = String::from_utf8_lossy(&out.files[0].1).to_string();
    assert!(written_text.contains("CMASS2*"), "{written_text}");
    assert!(written_text.contains("5."), "{written_text}");
    // Elements 3 and 4 share nothing, but two users of one PMASS updated apart are refused.
    let shared = "SPOINT,1,2\nCMASS1,3,8,1\nCMASS1,4,8,2\nPMASS,8,6.\nENDDATA\n";
    std::fs::write(&top, shared).unwrap();
    let model = read_bulk(&top).unwrap().model;
    let mut new = model.clone();
    if let Some(Element::ScalarMass { m, .. }) = new.elements.get_mut(&3) {
        *m = 1.0;
    }
    let deck = read_deck(&top).unwrap();
    let e = update_deck(&deck, &model, &new, &["test".to_string()])
        .unwrap_err()
        .to_string();
    assert!(e.contains("PMASS 8") && e.contains("own PMASS"), "{e}");
}

/// Re-importing the written deck gives the updated model's K and M: the exactly written
/// values to the last bit, the rounded ones (1/3·10⁴ in 16 characters) to 1e-10; every line
/// of an unchanged card is the original's byte for byte.
#[test]
fn written_deck_reimports_to_the_updated_model() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), ".002");
    let top = dir.path().join("main.bdf");
    let model = read_bulk(&top).unwrap().model;
    let new = updated(&model);
    let deck = read_deck(&top).unwrap();
    let out = update_deck(&deck, &model, &new, &["test".to_string()]).unwrap();
    let back = read_bulk(written(dir.path(), &out)).unwrap().model;

    let (a, _) = assemble_model(&new, MassKind::Consistent).unwrap();
    let (b, _) = assemble_model(&back, MassKind::Consistent).unwrap();
    assert_eq!(a.dofs, b.dofs);
    for (x, y) in [(a.k_dense(), b.k_dense()), (a.m_dense(), b.m_dense())] {
        let scale = (0..x.nrows()).map(|i| x[(i, i)].abs()).fold(0.0, f64::max);
        for i in 0..x.nrows() {
            for j in 0..x.ncols() {
                assert!(
                    (x[(i, j)] - y[(i, j)]).abs() <= 1e-10 * scale,
                    "({i}, {j}): {} vs {}",
                    x[(i, j)],
                    y[(i, j)]
                );
            }
        }
    }
    // The shell, material and mass values are exact.
    let p2 = back.elements[&3].property().unwrap();
    let q2 = &back.shell_properties[&p2];
    assert_eq!(q2.thickness, 0.0031);
    assert_eq!(back.materials[&q2.material].e, 1.9e11);
    assert_eq!(back.materials[&q2.material].rho, 7700.0);
    assert_eq!(back.materials[&1].e, 2.1e11, "pid1 keeps its material");
    assert_eq!(back.elements[&1].property(), Some(22));
    assert_eq!(back.shell_properties[&22].thickness, 0.0015);
    assert_eq!(back.shell_properties[&1].thickness, 0.002);
    let Element::Rod {
        section: RodSection::Own(conrod),
        ..
    } = &back.elements[&22]
    else {
        panic!("{:?}", back.elements[&22])
    };
    assert_eq!(back.materials[&conrod.material].e, 7e10);
    let Element::Mass { mass, .. } = back.elements[&10] else {
        panic!()
    };
    assert_eq!(mass, 1.25, "CONM2 M written as 2.5 under WTMASS 0.5");

    // Unchanged cards keep their bytes; the changed ones are listed.
    let main_in = std::fs::read_to_string(&top).unwrap();
    let main_out = String::from_utf8(out.files[0].1.clone()).unwrap();
    for line in main_in.lines() {
        let changed = [
            "CONM2",
            "CBUSH",
            "CELAS2",
            "CQUAD4",
            "CONROD",
            "*       9",
            "INCLUDE",
        ]
        .iter()
        .any(|c| line.starts_with(c));
        if !changed {
            assert!(main_out.lines().any(|l| l == line), "`{line}` lost");
        }
    }
    assert!(
        main_out.contains("CQUAD4,2,1,2,3,6,5"),
        "an unchanged element was rewritten"
    );
    assert!(main_out.contains("INCLUDE 'props.bdf'"));
    let props_out = String::from_utf8(out.files[1].1.clone()).unwrap();
    assert!(props_out.contains("PSHELL  1       1       .002    1\r\n"));
    assert!(props_out.contains("$ steel\r\n"));
    let fields: BTreeSet<String> = out
        .changes
        .iter()
        .map(|c| format!("{} {}", c.card, c.field))
        .collect();
    for want in [
        "PSHELL 2 T",
        "CONM2 10 M",
        "CELAS2 12 K",
        "PBUSH 21 K2",
        "PSHELL 2 MID1",
        "PSHELL 2 MID2",
        "MAT1 2 new card",
        "PSHELL 22 new card",
        "CQUAD4 1 PID",
        "CONROD 22 MID",
    ] {
        assert!(fields.contains(want), "{want} missing from {fields:?}");
    }
    assert!(main_out.starts_with("$ test\n"));
}

/// Writing the same values again changes nothing: no card is rewritten, every byte kept.
#[test]
fn unchanged_model_gives_the_deck_back() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), ".002");
    let top = dir.path().join("main.bdf");
    let model = read_bulk(&top).unwrap().model;
    let deck = read_deck(&top).unwrap();
    let out = update_deck(&deck, &model, &model, &[]).unwrap();
    assert!(out.changes.is_empty());
    assert_eq!(out.files[0].1, deck.files[0].bytes);
    assert_eq!(out.files[1].1, deck.files[1].bytes);
}

/// A deck that does not hold the values the update started from is refused, naming the
/// card, file and line; so is a model with other elements.
#[test]
fn another_deck_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), ".002");
    let model = read_bulk(dir.path().join("main.bdf")).unwrap().model;
    let new = updated(&model);
    let other = tempfile::tempdir().unwrap();
    write_deck(other.path(), ".0025");
    let deck = read_deck(other.path().join("main.bdf")).unwrap();
    let e = update_deck(&deck, &model, &new, &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("props.bdf line 2: PSHELL 2 T is .0025 in the deck but 0.002"),
        "{e}"
    );
    let mut fewer = new.clone();
    fewer.elements.remove(&12);
    let e = update_deck(&deck, &model, &fewer, &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("only in the deck: [12]"), "{e}");
}

/// Reals fit a large field: exact when the shortest form fits, else rounded to 16 characters.
#[test]
fn reals_fit_sixteen_characters() {
    assert_eq!(real16(2.1e11), "2.1+11");
    assert_eq!(real16(0.0031), ".0031");
    for x in [1.0 / 3.0, -2.0 / 3.0 * 1e-7, std::f64::consts::PI * 1e200] {
        let s = real16(x);
        assert!(s.len() <= 16, "{s}");
        let back = parse_real(&s).unwrap();
        assert!((back - x).abs() <= 1e-10 * x.abs(), "{x} -> {s}");
    }
}
/// A tapered PBEAML BAR: a width parameter scales every station's DIM1 (end A's is the
/// value), which the write-back refuses, naming the card; a density update of the same
/// beam is written (to the MAT1) and reads back.
#[test]
fn tapered_beams_are_not_corrupted() {
    let dir = tempfile::tempdir().unwrap();
    let top = dir.path().join("main.bdf");
    let text = "MAT1,1,2.1+11,,.3,7850.\nGRID,1,,0.,0.,0.,,123456\nGRID,2,,1.,0.,0.\nPBEAML,7,1,,BAR\n,.05,.1,.5,NO,.5,.045,.08,.4\n,YES,,.04,.06,.3\nCBEAM,1,7,1,2,0.,1.,0.\nENDDATA\n";
    std::fs::write(&top, text).unwrap();
    let model = read_bulk(&top).unwrap().model;
    let deck = read_deck(&top).unwrap();
    let mut new = model.clone();
    new.set_parameter_value(&param("w", ParameterKind::BeamWidth, "pid7"), 0.06)
        .unwrap();
    let st = &new.beam_properties[&7].taper.as_ref().unwrap().stations;
    let dim1: Vec<f64> = st.iter().map(|s| s.values[0]).collect();
    assert_eq!(dim1[0], 0.06);
    assert!((dim1[1] - 0.054).abs() < 1e-15 && (dim1[2] - 0.048).abs() < 1e-15);
    let e = update_deck(&deck, &model, &new, &["test".to_string()])
        .unwrap_err()
        .to_string();
    assert!(e.contains("PBEAML 7") && e.contains("tapered"), "{e}");
    let mut new = model.clone();
    new.set_parameter_value(&param("rho", ParameterKind::Density, "pid7"), 7000.0)
        .unwrap();
    let out = update_deck(&deck, &model, &new, &["test".to_string()]).unwrap();
    let back = read_bulk(written(dir.path(), &out)).unwrap().model;
    assert_eq!(back, new);
}

/// A PBEAM with neutral-axis and NSM offsets and NSI: a modulus update is written (to the
/// MAT1) and the card keeps its M/N line, so the read-back equals the updated model (the
/// offsets are not lost); a model whose offsets changed is refused, naming the card.
#[test]
fn beam_offsets_are_kept_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let top = dir.path().join("main.bdf");
    let text = "MAT1,1,2.1+11,,.3,7850.\nGRID,1,,0.,0.,0.,,123456\nGRID,2,,1.,0.,0.\nPBEAM,7,1,1.8-3,6.5-6,2.2-6,,3.-8,2.5\n,,,,,,,,\n,.8,.9,,,.012\n,-.03,.045,,,.021,-.013\nCBEAM,1,7,1,2,0.,1.,0.\nENDDATA\n";
    std::fs::write(&top, text).unwrap();
    let model = read_bulk(&top).unwrap().model;
    assert!(model.beam_properties[&7].centres.is_some());
    let deck = read_deck(&top).unwrap();
    let mut new = model.clone();
    new.set_parameter_value(&param("e", ParameterKind::YoungsModulus, "pid7"), 2.0e11)
        .unwrap();
    let out = update_deck(&deck, &model, &new, &["test".to_string()]).unwrap();
    let back = read_bulk(written(dir.path(), &out)).unwrap().model;
    assert_eq!(back, new);
    let mut moved = model.clone();
    if let Some(c) = &mut moved.beam_properties.get_mut(&7).unwrap().centres {
        c.neutral_axis[0] = 0.03;
    }
    let e = update_deck(&deck, &model, &moved, &["test".to_string()])
        .unwrap_err()
        .to_string();
    assert!(e.contains("PBEAM 7") && e.contains("neutral axis"), "{e}");
}
