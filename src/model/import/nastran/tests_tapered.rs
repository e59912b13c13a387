//! Tapered beams and tubes as Nastran gives them: PBEAM stations, PBEAML station dimensions,
//! PTUBE OD2; the export writes them back; the write-back of an update refuses to touch them.

use super::tests::{error, parse};
use super::*;
use crate::fe::beam::EndConditions;
use crate::fe::beam_tapered::{PropertyTaper, TaperedBeam, tapered_beam2};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::assemble_model;
use crate::model::export::nastran::write_bulk;

const HEAD: &str = "MAT1,1,2.1+11,,.3,7850.\nGRID,1,,0.,0.,0.,,123456\nGRID,2,,1.2,0.,0.\n";

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-14 * a.abs().max(b.abs())
}

/// The assembled K and M of the deck's only beam equal the tapered kernel's for the model's
/// property (the element reaches the tapered kernel), to round-off.
fn assembles_as_tapered(m: &Model) {
    let (sys, _) = assemble_model(m, MassKind::Consistent).unwrap();
    let p = &m.beam_properties[&7];
    let t = PropertyTaper::new(p, 0.3).unwrap();
    let b = TaperedBeam {
        e: 2.1e11,
        nu: 0.3,
        rho: 7850.0,
        taper: &t,
    };
    let e = tapered_beam2(
        [0.0; 3],
        [1.2, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        &b,
        MassKind::Consistent,
        &EndConditions::default(),
    )
    .unwrap();
    let (k, mm) = (sys.k.to_dense(), sys.m.to_dense());
    // Node 2's six DOFs are the free ones (node 1 is clamped).
    for (i, di) in sys.dofs.iter().enumerate() {
        for (j, dj) in sys.dofs.iter().enumerate() {
            let (a, b) = (6 + di.comp.slot(), 6 + dj.comp.slot());
            assert!((k[(i, j)] - e.k[(a, b)]).abs() <= 1e-12 * e.k[(a, a)].abs().max(1.0));
            assert!((mm[(i, j)] - e.m[(a, b)]).abs() <= 1e-12 * e.m[(a, a)].abs().max(1e-30));
        }
    }
}

/// PBEAM with an intermediate station whose I1, I2, J, NSM are blank (interpolated between
/// end A and end B at its X/XB) and an end B; the element is the tapered one. Stations equal to
/// end A give no taper (the uniform element, as before).
#[test]
fn pbeam_stations_are_read() {
    let deck = format!(
        "{HEAD}PBEAM,7,1,2.-3,4.-6,6.-6,,2.-6,1.5\n,NO,.4,1.6-3\n,YESA,1.,1.-3,2.-6,3.-6,,1.-6,.5\n,.9,.8\nCBEAM,1,7,1,2,0.,1.,0.\n"
    );
    let m = parse(&deck).model;
    let p = &m.beam_properties[&7];
    let t = p.taper.as_ref().unwrap();
    assert_eq!(t.library, None);
    let want = [
        (0.0, [2e-3, 4e-6, 6e-6, 2e-6], 1.5),
        (0.4, [1.6e-3, 3.2e-6, 4.8e-6, 1.6e-6], 1.1),
        (1.0, [1e-3, 2e-6, 3e-6, 1e-6], 0.5),
    ];
    assert_eq!(t.stations.len(), 3);
    for (s, (x, v, nsm)) in t.stations.iter().zip(want) {
        assert_eq!(s.x, x);
        assert!(s.values.iter().zip(v).all(|(a, b)| close(*a, b)), "{s:?}");
        assert!(close(s.nsm, nsm));
    }
    let BeamSection::General {
        area,
        shear_y,
        shear_z,
        ..
    } = p.section
    else {
        panic!("not general");
    };
    assert_eq!((area, shear_y, shear_z), (2e-3, 0.9, 0.8));
    assembles_as_tapered(&m);

    let uniform = format!(
        "{HEAD}PBEAM,7,1,2.-3,4.-6,6.-6,,2.-6,1.5\n,NO,.4\n,YESA,1.,2.-3,4.-6,6.-6,,2.-6,1.5\nCBEAM,1,7,1,2,0.,1.,0.\n"
    );
    assert_eq!(parse(&uniform).model.beam_properties[&7].taper, None);
}

/// PBEAML BAR with an intermediate station and end B: the dimensions are the stations',
/// the property's section is end A's; a blank X/XB is end B.
#[test]
fn pbeaml_stations_are_read() {
    let deck = format!(
        "{HEAD}PBEAML,7,1,,BAR\n,.05,.1,.5,NO,.5,.045,.08,.4\n,YES,,.04,.06,.3\nCBEAM,1,7,1,2,0.,1.,0.\n"
    );
    let m = parse(&deck).model;
    let p = &m.beam_properties[&7];
    assert_eq!(
        p.section,
        BeamSection::Rectangle {
            width: 0.05,
            height: 0.1
        }
    );
    let t = p.taper.as_ref().unwrap();
    assert_eq!(t.library.as_deref(), Some("BAR"));
    let got: Vec<(f64, Vec<f64>, f64)> = t
        .stations
        .iter()
        .map(|s| (s.x, s.values.clone(), s.nsm))
        .collect();
    assert_eq!(
        got,
        vec![
            (0.0, vec![0.05, 0.1], 0.5),
            (0.5, vec![0.045, 0.08], 0.4),
            (1.0, vec![0.04, 0.06], 0.3)
        ]
    );
    assembles_as_tapered(&m);
    // A tapered I (doubly symmetric at every station) reads too.
    let i = format!(
        "{HEAD}PBEAML,7,1,,I\n,.3,.15,.15,.01,.02,.02,,NO\n,1.,.2,.1,.1,.008,.015,.015\nCBEAM,1,7,1,2,0.,1.,0.\n"
    );
    assembles_as_tapered(&parse(&i).model);
}

/// PTUBE with OD2: a solid tube (T = 0) of linear diameter has the axial stiffness
/// `E π d_A d_B / (4L)` (`∫ ds/d² = L/(d_A d_B)`) and the torsional stiffness
/// `3 G π d_A³ d_B³ / (32 L (d_A² + d_A d_B + d_B²))`; to 1e-12 relative.
#[test]
fn ptube_od2_is_a_tapered_rod() {
    let deck = format!("{HEAD}PTUBE,3,1,.05,,.2,.03\nCTUBE,1,3,1,2\n");
    let m = parse(&deck).model;
    let p = &m.rod_properties[&3];
    let t = p.taper.unwrap();
    assert_eq!((t.od_a, t.od_b, t.t), (0.05, 0.03, 0.0));
    let (sys, _) = assemble_model(&m, MassKind::Lumped).unwrap();
    let k = sys.k.to_dense();
    let at = |c: Component| sys.dofs.iter().position(|d| d.comp == c).unwrap();
    let (e, g, l, da, db) = (2.1e11, 2.1e11 / 2.6, 1.2, 0.05, 0.03);
    let pi = std::f64::consts::PI;
    let ka = e * pi * da * db / (4.0 * l);
    let kt = 3.0 * g * pi * da.powi(3) * db.powi(3) / (32.0 * l * (da * da + da * db + db * db));
    let (kx, krx) = (
        k[(at(Component::Ux), at(Component::Ux))],
        k[(at(Component::Rx), at(Component::Rx))],
    );
    assert!((kx - ka).abs() < 1e-12 * ka, "{kx} {ka}");
    assert!((krx - kt).abs() < 1e-12 * kt, "{krx} {kt}");
    // OD2 equal to OD (or blank) is the uniform tube, as before.
    let same = format!("{HEAD}PTUBE,3,1,.05,.01,.2,.05\nCTUBE,1,3,1,2\n");
    assert_eq!(parse(&same).model.rod_properties[&3].taper, None);
}

/// What stays unsupported is an error naming the card, field and line.
#[test]
fn unsupported_tapers_are_named() {
    // A tapered Z: its principal axes turn along the beam.
    let z = format!("{HEAD}PBEAML,7,1,,Z\n,.06,.008,.18,.2,,NO,1.,.05\nCBEAM,1,7,1,2,0.,1.,0.\n");
    let e = error(&z);
    assert!(
        e.contains("PBEAML field 9 (DIM1) of continuation 1 (line 5)")
            && e.contains("product of inertia"),
        "{e}"
    );
    // I12 at a station.
    let i12 = format!(
        "{HEAD}PBEAM,7,1,2.-3,4.-6,6.-6,,2.-6\n,NO,1.,1.-3,2.-6,3.-6,1.-7\nCBEAM,1,7,1,2,0.,1.,0.\n"
    );
    let e = error(&i12);
    assert!(
        e.contains("PBEAM field 7 (I12) of continuation 1 (line 5)"),
        "{e}"
    );
    // J blank at end A but given at end B.
    let j = format!(
        "{HEAD}PBEAM,7,1,2.-3,4.-6,6.-6\n,NO,1.,1.-3,2.-6,3.-6,,1.-6\nCBEAM,1,7,1,2,0.,1.,0.\n"
    );
    let e = error(&j);
    assert!(
        e.contains("PBEAM field 8 (J) of continuation 1") && e.contains("J > 0 at every station"),
        "{e}"
    );
    // Stations out of order.
    let order = format!(
        "{HEAD}PBEAM,7,1,2.-3,4.-6,6.-6,,2.-6\n,NO,.6,1.5-3\n,NO,.3,1.4-3\n,NO,1.,1.-3\nCBEAM,1,7,1,2,0.,1.,0.\n"
    );
    let e = error(&order);
    assert!(
        e.contains("PBEAM field 3 (X/XB) of continuation 2 (line 6)")
            && e.contains("does not follow"),
        "{e}"
    );
}

/// The export writes a tapered PBEAM, PBEAML and PTUBE (with CBEAM, CTUBE) that read back to
/// the same properties and elements.
#[test]
fn tapered_properties_round_trip_through_the_export() {
    let deck = format!(
        "{HEAD}GRID,3,,2.,0.,0.\nGRID,4,,3.,0.,0.\n\
         PBEAM,7,1,2.-3,4.-6,6.-6,,2.-6,1.5\n,NO,.4,1.6-3\n,YESA,1.,1.-3,2.-6,3.-6,,1.-6,.5\n,.9,.8\n\
         PBEAML,8,1,,BAR\n,.05,.1,.5,NO,.5,.045,.08,.4\n,YES,,.04,.06,.3\n\
         PTUBE,3,1,.05,.01,.2,.03\n\
         CBEAM,1,7,1,2,0.,1.,0.\nCBEAM,2,8,2,3,0.,1.,0.\nCTUBE,3,3,3,4\n"
    );
    let m = parse(&deck).model;
    let back = parse(&write_bulk(&m)).model;
    assert_eq!(back.beam_properties, m.beam_properties);
    assert_eq!(back.rod_properties, m.rod_properties);
    assert_eq!(back.elements, m.elements);
}
