//! Beams as Nastran models them: the PBARL/PBEAML library, CBAR/CBEAM offsets (OFFT) and pin
//! flags, each against an independent path (a PBAR with the same values, hand deflections,
//! the composite-section frequency).

use super::tests::{error, parse};
use super::*;
use crate::eigen::{ModeSelection, dense_generalized};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::assemble_model;
use crate::model::export::nastran::{format_real, write_bulk};
use crate::model::sections as lib;
use faer::Mat;
use faer::linalg::solvers::Solve;

const E: f64 = 2.1e11;

fn r(x: f64) -> String {
    format_real(x)
}

/// `K`, `M` (dense) and DOFs of a deck.
fn system(deck: &str) -> (Mat<f64>, Mat<f64>, Vec<DofId>) {
    let m = parse(deck).model;
    let (sys, _) = assemble_model(&m, MassKind::Consistent).unwrap();
    (sys.k.to_dense(), sys.m.to_dense(), sys.dofs)
}

/// Static displacements `K u = f` for unit loads on the named DOFs (dense LU).
fn solve(k: &Mat<f64>, dofs: &[DofId], load: &[(DofId, f64)]) -> Vec<f64> {
    let mut f = Mat::<f64>::zeros(dofs.len(), 1);
    for (d, v) in load {
        f[(dofs.iter().position(|x| x == d).unwrap(), 0)] = *v;
    }
    let u = k.partial_piv_lu().solve(&f);
    (0..dofs.len()).map(|i| u[(i, 0)]).collect()
}

fn at(dofs: &[DofId], u: &[f64], node: u64, c: Component) -> f64 {
    u[dofs.iter().position(|d| *d == DofId::new(node, c)).unwrap()]
}

/// A four-element cantilever along x with orientation `v = y`, its property `pid` given by
/// `prop` (the property cards).
fn cantilever(prop: &str) -> String {
    format!(
        "MAT1,1,2.1+11,,.3,7850.\n{prop}GRID,1,,0.,0.,0.,,123456\nGRID,2,,.5,0.,0.\nGRID,3,,1.,0.,0.\nGRID,4,,1.5,0.,0.\nGRID,5,,2.,0.,0.\n\
         CBAR,1,7,1,2,0.,1.,0.\nCBAR,2,7,2,3,0.,1.,0.\nCBAR,3,7,3,4,0.,1.,0.\nCBAR,4,7,4,5,0.,1.,0.\n"
    )
}

/// A PBARL I beam has exactly the K and M of the same beam given by a PBAR with the library's
/// A, I1, I2, J, K1, K2 (printed so that they read back to the same f64), hence its modes.
#[test]
fn pbarl_i_beam_is_the_pbar_of_its_library_values() {
    let d = [0.3, 0.16, 0.12, 0.01, 0.02, 0.015];
    let s = lib::i_section(d).unwrap();
    let pbarl = format!("PBARL,7,1,,I\n,{},2.5\n", d.map(r).join(","));
    let pbar = format!(
        "PBAR,7,1,{},{},{},{},2.5\n,0.,0.,0.,0.,0.,0.,0.,0.\n,{},{}\n",
        r(s.area),
        r(s.i1),
        r(s.i2),
        r(s.j),
        r(s.k1),
        r(s.k2)
    );
    let a = parse(&cantilever(&pbarl)).model;
    let b = parse(&cantilever(&pbar)).model;
    assert_eq!(a.beam_properties, b.beam_properties);
    assert_eq!(a.beam_properties[&7].nsm, 2.5);
    let (ka, ma, dofs) = system(&cantilever(&pbarl));
    let (kb, mb, _) = system(&cantilever(&pbar));
    assert_eq!((ka.clone(), ma.clone()), (kb, mb));
    let modes =
        dense_generalized(ka.as_ref(), ma.as_ref(), &dofs, ModeSelection::Count(4)).unwrap();
    assert!(modes.eigenvalues[0] > 0.0);
}

/// Every library type reads; BAR, ROD, TUBE and TUBE2 keep femu's own sections, the others
/// carry the library's values; bad dimensions and unknown types name the field.
#[test]
fn every_library_type_reads_with_its_dimension_count() {
    let dims: [(&str, &[f64]); 19] = [
        ("BAR", &[0.02, 0.03]),
        ("ROD", &[0.01]),
        ("TUBE", &[0.02, 0.015]),
        ("TUBE2", &[0.02, 0.005]),
        ("I", &[0.3, 0.16, 0.12, 0.01, 0.02, 0.015]),
        ("I1", &[0.06, 0.008, 0.18, 0.2]),
        ("T", &[0.2, 0.25, 0.02, 0.012]),
        ("T1", &[0.2, 0.1, 0.012, 0.01]),
        ("T2", &[0.2, 0.25, 0.02, 0.012]),
        ("L", &[0.1, 0.15, 0.01, 0.008]),
        ("CHAN", &[0.08, 0.2, 0.009, 0.012]),
        ("CHAN1", &[0.071, 0.009, 0.176, 0.2]),
        ("CHAN2", &[0.01, 0.015, 0.1, 0.2]),
        ("BOX", &[0.2, 0.1, 0.01, 0.02]),
        ("BOX1", &[0.2, 0.1, 0.01, 0.02, 0.005, 0.015]),
        ("H", &[0.15, 0.02, 0.2, 0.01]),
        ("CROSS", &[0.12, 0.02, 0.18, 0.015]),
        ("Z", &[0.06, 0.008, 0.18, 0.2]),
        ("HAT", &[0.1, 0.004, 0.08, 0.03]),
    ];
    for (kind, d) in dims {
        let text: Vec<String> = d.iter().map(|x| r(*x)).collect();
        let deck = cantilever(&format!("PBARL,7,1,,{kind}\n,{},.5\n", text.join(",")));
        let m = parse(&deck).model;
        let p = &m.beam_properties[&7];
        assert_eq!(p.nsm, 0.5, "{kind}");
        match (kind, &p.section) {
            ("BAR", BeamSection::Rectangle { width, height }) => {
                assert_eq!((*width, *height), (d[0], d[1]))
            }
            ("ROD", BeamSection::Circle { radius }) => assert_eq!(*radius, d[0]),
            ("TUBE", BeamSection::Tube { inner_radius, .. }) => assert_eq!(*inner_radius, d[1]),
            ("TUBE2", BeamSection::Tube { inner_radius, .. }) => {
                assert_eq!(*inner_radius, d[0] - d[1])
            }
            (_, BeamSection::General { area, j, .. }) => assert!(*area > 0.0 && *j > 0.0),
            (k, s) => panic!("{k}: {s:?}"),
        }
        assert_eq!(
            parse(&deck).model.elements.len(),
            4,
            "{kind}: the elements read"
        );
    }
    let e = error(&cantilever("PBARL,7,1,,HEXA\n,.1,.2,.1\n"));
    assert!(
        e.contains("field 5 (TYPE)") && e.contains("HEXA") && e.contains("CHAN2"),
        "{e}"
    );
    let e = error(&cantilever("PBARL,7,1,,I\n,.03,.16,.12,.01,.02,.015\n"));
    assert!(e.contains("DIM1") && e.contains("DIM5 + DIM6"), "{e}");
    let e = error(&cantilever("PBARL,7,1,,L\n,.1,.15,.01,.008,.5,3.\n"));
    assert!(e.contains("follows NSM"), "{e}");
}

/// An L section (I12 ≠ 0) turned to principal axes bends as the unsymmetric section: a tip
/// force along element y gives `[u_y, u_z] = L³/(3E) S⁻¹ [P, 0]` with
/// `S = [[I1, I12], [I12, I2]]` (Euler–Bernoulli, as Nastran's bar with I12 ignores K1/K2).
/// One element of length 2 clamped at grid 1; relative agreement 1e-9 (a 6 × 6 solve).
#[test]
fn l_section_turned_to_principal_axes_bends_as_the_unsymmetric_section() {
    let d = [0.1, 0.15, 0.01, 0.008];
    let s = lib::l_section(d).unwrap();
    let deck = format!(
        "MAT1,1,2.1+11,,.3,7850.\nPBARL,7,1,,L\n,{}\nGRID,1,,0.,0.,0.,,123456\nGRID,2,,2.,0.,0.\nCBAR,1,7,1,2,0.,1.,0.\n",
        d.map(r).join(",")
    );
    let m = parse(&deck).model;
    let Element::Beam { orientation, .. } = &m.elements[&1] else {
        panic!()
    };
    assert!(orientation[2].abs() > 0.1, "turned: {orientation:?}");
    let (k, _, dofs) = system(&deck);
    let u = solve(&k, &dofs, &[(DofId::new(2, Component::Uy), 1.0)]);
    let det = s.i1 * s.i2 - s.i12 * s.i12;
    let c = 8.0 / (3.0 * E);
    let want = [c * s.i2 / det, -c * s.i12 / det];
    let got = [
        at(&dofs, &u, 2, Component::Uy),
        at(&dofs, &u, 2, Component::Uz),
    ];
    for i in 0..2 {
        assert!(
            (got[i] - want[i]).abs() < 1e-9 * want[0].abs(),
            "{got:?} vs {want:?}"
        );
    }
    // A pin releasing one bending direction of the turned section is refused.
    let e = error(&deck.replace("CBAR,1,7,1,2,0.,1.,0.", "CBAR,1,7,1,2,0.,1.,0.\n,,6"));
    assert!(e.contains("PB") && e.contains("principal"), "{e}");
}

/// PBEAML: constant stations (repeated or blank) read as the PBARL of end A; a tapered Z or a
/// bad stress flag are errors.
#[test]
fn pbeaml_reads_constant_sections_and_refuses_tapers() {
    let pbarl = "PBARL,7,1,,BOX\n,.2,.1,.01,.02,1.5\n";
    let pbeaml = "PBEAML,7,1,,BOX\n,.2,.1,.01,.02,1.5,YESA,.5,.2\n,,.01,.02,,NO,1.,,\n";
    let a = parse(&cantilever(pbarl)).model;
    let b = parse(&cantilever(pbeaml)).model;
    assert_eq!(a.beam_properties, b.beam_properties);
    // A tapered BOX reads (tests_tapered.rs); a tapered Z (I12 ≠ 0) does not.
    let tapered = "PBEAML,7,1,,BOX\n,.2,.1,.01,.02,1.5,NO,1.,.3\n";
    let m = parse(&cantilever(tapered)).model;
    assert_eq!(
        m.beam_properties[&7].taper.as_ref().unwrap().stations.len(),
        2
    );
    // A T (shear centre off the centroid) reads, with the offset (tests_shear_centre.rs).
    let t = parse(&cantilever("PBEAML,7,1,,T\n,.2,.25,.02,.012\n")).model;
    assert!(t.beam_properties[&7].centres.is_some());
    let e = error(&cantilever("PBEAML,7,1,,ROD\n,.01,,MAYBE\n"));
    assert!(e.contains("SO"), "{e}");
    // A doubly symmetric I and the point-symmetric Z are accepted.
    parse(&cantilever("PBEAML,7,1,,I\n,.3,.15,.15,.01,.02,.02\n"));
    parse(&cantilever("PBEAML,7,1,,Z\n,.06,.008,.18,.2\n"));
}

/// A hinge by pin flag: clamped at 0 and at L, hinged at a with a load P there. Each side is a
/// cantilever loaded at its tip, so `δ = P / (3EI/a³ + 3EI/(L−a)³)` (Euler–Bernoulli, PBAR
/// without K1/K2). The pin may sit on either element's end at the hinge. Relative 1e-10.
#[test]
fn pinned_joint_deflects_as_the_hand_hinge() {
    let (a, l, i) = (0.8, 2.0, 3e-7);
    for pins in [
        "CBAR,1,7,1,2,0.,1.,0.\n,,6\nCBAR,2,7,2,3,0.,1.,0.\n",
        "CBAR,1,7,1,2,0.,1.,0.\nCBAR,2,7,2,3,0.,1.,0.\n,6\n",
    ] {
        let deck = format!(
            "MAT1,1,2.1+11,,.3,7850.\nPBAR,7,1,1.-3,{},{},1.-7\nGRID,1,,0.,0.,0.,,123456\nGRID,2,,{},0.,0.,,345\nGRID,3,,{},0.,0.,,123456\n{pins}",
            r(i),
            r(i),
            r(a),
            r(l)
        );
        let (k, _, dofs) = system(&deck);
        let u = solve(&k, &dofs, &[(DofId::new(2, Component::Uy), 1.0)]);
        let want = 1.0 / (3.0 * E * i / a.powi(3) + 3.0 * E * i / (l - a).powi(3));
        let got = at(&dofs, &u, 2, Component::Uy);
        assert!((got - want).abs() < 1e-10 * want, "{got:e} vs {want:e}");
    }
    // Torsion released at both ends leaves a mechanism; digits outside 1–6 are not DOFs.
    let base = "MAT1,1,2.1+11,,.3,7850.\nPBAR,7,1,1.-3,3.-7,3.-7,1.-7\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\n";
    let e = error(&format!("{base}CBAR,1,7,1,2,0.,1.,0.\n,4,4\n"));
    assert!(e.contains("CBAR 1") && e.contains("mechanism"), "{e}");
    let e = error(&format!("{base}CBAR,1,7,1,2,0.,1.,0.\n,17\n"));
    assert!(e.contains("field 2 (PA)") && e.contains("17"), "{e}");
}

/// Two parallel members on one grid line, the second offset by `e` along y (WA = WB), act as
/// one composite section: first bending frequency of the cantilever
/// `f = 1.87510407²/(2π) √(E I_c / (m̄ L⁴))`, `I_c = I1 + I2 + A1 A2 e²/(A1 + A2)` (parallel-axis
/// theorem about the composite neutral axis; Timoshenko & Gere, *Mechanics of Materials*,
/// composite beams), `m̄ = ρ (A1 + A2)`: the offset raises it by `√(I_c/(I1+I2))` (here 57 %)
/// over the same members without offset. Joined only at the grids, the members slip between
/// them (axial displacement linear, rotation quadratic), so the mesh converges to the
/// composite section as `h²`: the error must fall four-fold from 20 to 40 elements (ratio in
/// [3.5, 4.5]) and be below 4e-4 at 40; without offset (no slip) below 1e-4 at 20 elements
/// (rotary inertia, order `(r/L)²`).
#[test]
fn offset_member_stiffens_the_cantilever_as_the_composite_section() {
    let (l, off) = (2.0, 0.01);
    let (a1, i1, a2, i2, rho) = (2e-4, 2e-9, 1e-4, 1e-9, 7850.0);
    let deck = |n: usize, w: f64| {
        let mut s = format!(
            "MAT1,1,2.1+11,,.3,7850.\nPBAR,1,1,{},{},{},1.-9\nPBAR,2,1,{},{},{},1.-9\n",
            r(a1),
            r(i1),
            r(i1),
            r(a2),
            r(i2),
            r(i2)
        );
        for g in 0..=n {
            let ps = if g == 0 { "123456" } else { "345" };
            s += &format!(
                "GRID,{},,{},0.,0.,,{ps}\n",
                g + 1,
                r(l * g as f64 / n as f64)
            );
        }
        for e in 0..n {
            let (ga, gb) = (e + 1, e + 2);
            s += &format!("CBAR,{},1,{ga},{gb},0.,1.,0.\n", e + 1);
            s += &format!(
                "CBAR,{},2,{ga},{gb},0.,1.,0.\n,,,0.,{},0.,0.,{},0.\n",
                e + 1001,
                r(w),
                r(w)
            );
        }
        s
    };
    let f1 = |n: usize, w: f64| {
        let (k, m, dofs) = system(&deck(n, w));
        let modes =
            dense_generalized(k.as_ref(), m.as_ref(), &dofs, ModeSelection::Count(1)).unwrap();
        modes.eigenvalues[0].sqrt() / (2.0 * std::f64::consts::PI)
    };
    let beta = 1.875_104_068_711_961_f64;
    let hz = |i: f64| {
        beta * beta / (2.0 * std::f64::consts::PI) * (E * i / (rho * (a1 + a2) * l.powi(4))).sqrt()
    };
    let ic = i1 + i2 + a1 * a2 * off * off / (a1 + a2);
    let (e20, e40) = (
        (f1(20, off) / hz(ic) - 1.0).abs(),
        (f1(40, off) / hz(ic) - 1.0).abs(),
    );
    assert!(
        e40 < 4e-4 && (3.5..4.5).contains(&(e20 / e40)),
        "{e20:e} {e40:e}"
    );
    let plain = (f1(20, 0.0) / hz(i1 + i2) - 1.0).abs();
    assert!(plain < 1e-4, "{plain:e}");
    eprintln!(
        "offset composite cantilever: error {e20:e} (20 elements), {e40:e} (40); no offset {plain:e}"
    );
    let m = parse(&deck(2, off)).model;
    let Element::Beam { ends, .. } = &m.elements[&1001] else {
        panic!()
    };
    assert_eq!(
        (ends.offset_a, ends.offset_b),
        ([0.0, off, 0.0], [0.0, off, 0.0])
    );
}

/// OFFT: offsets in the grids' displacement systems (G), or the element system (O); the
/// orientation vector in GA's displacement system (G) or basic (B). Grid 2's CD turns x to y.
#[test]
fn offt_codes_place_offsets_and_orientation() {
    let base = "MAT1,1,2.1+11,,.3,7850.\nPBAR,7,1,1.-3,3.-7,3.-7,1.-7\nCORD2R,5,,0.,0.,0.,0.,0.,1.\n,0.,1.,0.\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.,5\n";
    let ends = |offt: &str, v: &str| {
        let m = parse(&format!(
            "{base}CBAR,1,7,1,2,{v},{offt}\n,,,.1,.2,.3,.4,.5,.6\n"
        ))
        .model;
        let Element::Beam {
            ends, orientation, ..
        } = &m.elements[&1]
        else {
            panic!()
        };
        (ends.offset_a, ends.offset_b, *orientation)
    };
    let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12);
    // GGG: A in basic (grid 1 has CD 0), B in system 5 (x → basic y, y → basic −x).
    let (a, b, _) = ends("", "0.,1.,0.");
    assert!(
        close(a, [0.1, 0.2, 0.3]) && close(b, [-0.5, 0.4, 0.6]),
        "{a:?} {b:?}"
    );
    // GOO with v = y: the element system is basic, so both offsets read as given.
    let (a, b, _) = ends("GOO", "0.,1.,0.");
    assert!(
        close(a, [0.1, 0.2, 0.3]) && close(b, [0.4, 0.5, 0.6]),
        "{a:?} {b:?}"
    );
    // Element system with v = z: element y = basic z, z = −basic y.
    let (_, b, _) = ends("GGO", "0.,0.,1.");
    assert!(close(b, [0.4, -0.6, 0.5]), "{b:?}");
    let e = error(&format!("{base}CBAR,1,7,1,2,0.,1.,0.,XYZ\n"));
    assert!(e.contains("OFFT") && e.contains("BOO"), "{e}");
}

/// Offsets and pins survive export and re-import (as OFFT BGG in basic); a plain beam writes
/// no OFFT. (Their round trip through the mesh artefact is tested in `artefact::kinds`.)
#[test]
fn offsets_and_pins_round_trip_through_export() {
    let deck = "MAT1,1,2.1+11,,.3,7850.\nPBAR,7,1,1.-3,3.-7,3.-7,1.-7\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,2.,0.,0.\n\
                CBAR,1,7,1,2,0.,1.,0.\n,5,46,.1,.2,.3,.4,.5,.6\nCBAR,2,7,2,3,0.,1.,0.\n";
    let m = parse(deck).model;
    let again = parse(&write_bulk(&m)).model;
    assert_eq!(again.elements, m.elements);
    let Element::Beam { ends, .. } = &m.elements[&1] else {
        panic!()
    };
    assert_eq!((ends.pin_a, ends.pin_b), (5, 46));
    let plain = parse(&deck.replace(",5,46,.1,.2,.3,.4,.5,.6\n", "")).model;
    assert!(!write_bulk(&plain).contains("BGG"));
}

/// BAROR and BEAMOR give blank CBAR/CBEAM fields their PID, orientation and OFFT; each applies
/// only to its own element card, a field on the element wins, and a second one is an error.
#[test]
fn baror_and_beamor_fill_blank_fields() {
    let base = "MAT1,1,2.1+11,,.3,7850.\nPBAR,7,1,1.-3,3.-7,3.-7,1.-7\nPBAR,8,1,2.-3,3.-7,3.-7,1.-7\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\n";
    let m = parse(&format!(
        "{base}BAROR,,7,,,0.,0.,1.,GOO\nBEAMOR,,8,,,3\nCBAR,1,,1,2\n,,,0.,.1,0.\nCBAR,2,8,1,2,0.,1.,0.\nCBEAM,3,,1,2\n"
    ))
    .model;
    let beam = |id: u64| match &m.elements[&id] {
        Element::Beam {
            property,
            orientation,
            ends,
            ..
        } => (*property, *orientation, ends.clone()),
        _ => panic!(),
    };
    // Element 1: PID, v and OFFT (element-system offsets: y = basic z) from BAROR.
    let (p, v, ends) = beam(1);
    assert_eq!((p, v), (7, [0.0, 0.0, 1.0]));
    assert_eq!(ends.offset_a, [0.0, 0.0, 0.1]);
    // Element 2: its own PID and v win.
    assert_eq!(beam(2).0, 8);
    assert_eq!(beam(2).1, [0.0, 1.0, 0.0]);
    // Element 3 (CBEAM): BEAMOR's PID and G0 = 3 (v from GA towards grid 3).
    assert_eq!((beam(3).0, beam(3).1), (8, [1.0, 1.0, 0.0]));
    let e = error(&format!("{base}BEAMOR,,8,,,3\nCBAR,1,7,1,2\n"));
    assert!(
        e.contains("CBAR field 6 (X1/G0)") && e.contains("BAROR"),
        "{e}"
    );
    let e = error(&format!(
        "{base}BAROR,,7\nBAROR,,8\nCBAR,1,7,1,2,0.,1.,0.\n"
    ));
    assert!(e.contains("BAROR is given twice"), "{e}");
    // Blank PID without BAROR PID: the element id, as in Nastran.
    let m = parse(&format!("{base}CBAR,7,,1,2,0.,1.,0.\n")).model;
    assert_eq!(m.elements[&7].property(), Some(7));
}
