//! CBEAM sections whose centroid is off the shear centre: PBEAML's unsymmetric library
//! sections (offset by the thin-walled shear centre) and PBEAM's N, M and NSI, applied with
//! Nastran's meaning, checked against the kernel given the same numbers, and written back.

use super::tests::{error, parse};
use super::*;
use crate::fe::beam::{BeamData, EndConditions, Section, beam2_centred};
use crate::fe::beam_offset::SectionCentres;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::element_matrices;
use crate::model::export::nastran::write_bulk;
use crate::model::sections as lib;

/// A two-element CBEAM cantilever along x (v = y) of property 7 given by `prop`.
fn deck(prop: &str) -> String {
    format!(
        "MAT1,1,2.1+11,,.3,7850.\n{prop}GRID,1,,0.,0.,0.,,123456\nGRID,2,,.5,0.,0.\nGRID,3,,1.,0.,0.\n\
         CBEAM,1,7,1,2,0.,1.,0.\nCBEAM,2,7,2,3,0.,1.,0.\n"
    )
}

/// PBEAML T, L, CHAN, HAT (and T1, T2, CHAN1, CHAN2, an unequal I and BOX1) import on CBEAM,
/// no longer refused, with the centroid's offset from the shear centre of
/// [`lib::neutral_axis_offset`] (checked against closed forms in `model::sections`), turned
/// with the section for L and BOX1 (whose principal axes are turned): the turned offset keeps
/// its length and is the figure's offset in the new axes `y' = c y + s z`, `z' = −s y + c z`.
/// The same dimensions on a PBARL keep both on the axis (QRG PBARL remark 8).
#[test]
fn pbeaml_unsymmetric_sections_import_with_their_offsets() {
    let cases: [(&str, &[f64]); 10] = [
        ("T", &[0.2, 0.25, 0.02, 0.012]),
        ("L", &[0.1, 0.15, 0.01, 0.008]),
        ("CHAN", &[0.08, 0.2, 0.009, 0.012]),
        ("HAT", &[0.1, 0.004, 0.08, 0.03]),
        ("T1", &[0.2, 0.1, 0.012, 0.01]),
        ("T2", &[0.2, 0.25, 0.02, 0.012]),
        ("CHAN1", &[0.06, 0.008, 0.18, 0.2]),
        ("CHAN2", &[0.01, 0.015, 0.1, 0.2]),
        ("I", &[0.3, 0.16, 0.12, 0.01, 0.02, 0.015]),
        ("BOX1", &[0.2, 0.1, 0.01, 0.02, 0.005, 0.015]),
    ];
    for (kind, d) in cases {
        let dims: Vec<String> = d.iter().map(|x| x.to_string()).collect();
        let m = parse(&deck(&format!("PBEAML,7,1,,{kind}\n,{}\n", dims.join(",")))).model;
        let p = &m.beam_properties[&7];
        let c = p
            .centres
            .as_ref()
            .unwrap_or_else(|| panic!("{kind}: no offset"));
        let figure = lib::neutral_axis_offset(kind, d);
        let (_, theta) = lib::principal(&lib::library_values(kind, d).unwrap().unwrap());
        let (s, co) = theta.sin_cos();
        let want = [
            co * figure[0] + s * figure[1],
            -s * figure[0] + co * figure[1],
        ];
        assert_eq!(c.neutral_axis, want, "{kind}");
        assert!(
            figure[0].hypot(figure[1]) > 1e-3,
            "{kind}: offset {figure:?} is not a real offset"
        );
        assert!(
            (c.neutral_axis[0].hypot(c.neutral_axis[1]) - figure[0].hypot(figure[1])).abs() < 1e-15
        );
        assert_eq!((c.nsm_cg, c.nsi), ([0.0; 2], 0.0), "{kind}");
        if matches!(kind, "L" | "BOX1") {
            assert!(theta != 0.0 && c.neutral_axis != figure, "{kind}");
        }
        let bar = parse(&deck(&format!("PBARL,7,1,,{kind}\n,{}\n", dims.join(",")))).model;
        assert_eq!(bar.beam_properties[&7].centres, None, "{kind}");
    }
}

/// PBEAM N1/N2, M1/M2 and NSI are applied, not warned about: the property holds them, and the
/// imported element's matrices are the kernel's about the shear centre for the same numbers
/// (to 1e-15 of the largest entry: the same arithmetic, up to the basic-system rotation the
/// assembly adds), which differ from the plain beam's. CW still draws its warning.
#[test]
fn pbeam_offsets_and_nsi_are_applied() {
    let pbeam = "PBEAM,7,1,1.8-3,6.5-6,2.2-6,,3.-8,2.5\n,,,,,,,,\n,.8,.9,,,.012,,1.-9,\n,-.03,.045,,,.021,-.013\n";
    let b = parse(&deck(pbeam));
    let p = &b.model.beam_properties[&7];
    let c = p.centres.clone().unwrap();
    assert_eq!(
        c,
        BeamCentres {
            neutral_axis: [0.021, -0.013],
            nsm_cg: [-0.03, 0.045],
            nsi: 0.012,
        }
    );
    assert!(
        !b.warnings
            .iter()
            .any(|w| w.contains("NSI") || w.contains("offsets")),
        "{:?}",
        b.warnings
    );
    assert!(
        b.warnings.iter().any(|w| w.contains("CW")),
        "{:?}",
        b.warnings
    );
    let d = BeamData {
        e: 2.1e11,
        nu: 0.3,
        rho: 7850.0,
        nsm: 2.5,
        section: Section::General {
            area: 1.8e-3,
            iy: 2.2e-6,
            iz: 6.5e-6,
            j: 3e-8,
            shear_y: Some(0.8),
            shear_z: Some(0.9),
        },
    };
    let centres = SectionCentres {
        neutral_axis: [0.021, -0.013],
        nsm_cg: [-0.03, 0.045],
        nsi: 0.012,
    };
    for kind in [MassKind::Consistent, MassKind::Lumped] {
        let got = element_matrices(&b.model, &b.model.elements[&1], kind).unwrap();
        let want = beam2_centred(
            [0.0; 3],
            [0.5, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            &d,
            kind,
            &EndConditions::default(),
            &centres,
        )
        .unwrap();
        let plain = beam2_centred(
            [0.0; 3],
            [0.5, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            &d,
            kind,
            &EndConditions::default(),
            &SectionCentres::default(),
        )
        .unwrap();
        for (g, w, p) in [(&got.k, &want.k, &plain.k), (&got.m, &want.m, &plain.m)] {
            assert!((g - w).norm_max() <= 1e-15 * w.norm_max(), "{kind:?}");
            assert!((g - p).norm_max() > 1e-6 * p.norm_max(), "{kind:?}");
        }
    }
    // Blank end-B values are end A's; equal ones are accepted.
    let same = "PBEAM,7,1,1.8-3,6.5-6,2.2-6,,3.-8,2.5\n,,,,,,,,\n,.8,.9,,,.012,.012\n,-.03,.045,-.03,.045,.021,-.013,.021,-.013\n";
    assert_eq!(
        parse(&deck(same)).model.beam_properties[&7].centres,
        Some(c)
    );
}

/// End-B offsets or NSI other than end A's are refused, naming the file, line and field (femu
/// holds them constant); a negative NSI too.
#[test]
fn pbeam_differing_end_b_offsets_are_errors() {
    let head = "PBEAM,7,1,1.8-3,6.5-6,2.2-6,,3.-8,2.5\n,,,,,,,,\n";
    // The M line is continuation 3, on line 5 of the deck (MAT1, PBEAM and two continuations
    // before it); N1(B) is its seventh value, field 8.
    let e = error(&deck(&format!(
        "{head},.8,.9\n,-.03,.045,,,.021,-.013,.03\n"
    )));
    assert!(
        e.contains("t.bdf")
            && e.contains("PBEAM field 8 (N1(B)) of continuation 3 (line 5)")
            && e.contains("differs from N1(A)"),
        "{e}"
    );
    let e = error(&deck(&format!("{head},.8,.9\n,-.03,.045,,.05\n")));
    assert!(
        e.contains("field 5 (M2(B)) of continuation 3 (line 5)"),
        "{e}"
    );
    let e = error(&deck(&format!("{head},.8,.9,,,.012,.02\n")));
    assert!(
        e.contains("field 7 (NSI(B)) of continuation 2 (line 4)"),
        "{e}"
    );
    let e = error(&deck(&format!("{head},.8,.9,,,-.012\n")));
    assert!(e.contains("NSI(A)") && e.contains("negative"), "{e}");
}

/// A tapered PBEAML must keep the offset at every station: a T whose dimensions change is
/// refused naming the station; one whose NSM alone varies reads with the offset. A tapered
/// PBEAM with N1/N2 reads with them.
#[test]
fn tapered_sections_keep_their_offset() {
    let e = error(&deck("PBEAML,7,1,,T\n,.2,.25,.02,.012,,NO,1.,.15\n"));
    assert!(
        e.contains("DIM1") && e.contains("X/XB = 1") && e.contains("shear centre"),
        "{e}"
    );
    let m = parse(&deck("PBEAML,7,1,,T\n,.2,.25,.02,.012,1.,NO,1.,\n,,,,.5\n")).model;
    let p = &m.beam_properties[&7];
    assert!(p.taper.is_some());
    assert_eq!(
        p.centres.as_ref().unwrap().neutral_axis,
        lib::neutral_axis_offset("T", &[0.2, 0.25, 0.02, 0.012])
    );
    let m = parse(&deck(
        "PBEAM,7,1,2.-3,4.-6,6.-6,,2.-6,1.5\n,NO,1.,1.-3,2.-6,3.-6,,1.-6,.5\n,,\n,,,,,.01,.02\n",
    ))
    .model;
    let p = &m.beam_properties[&7];
    assert!(p.taper.is_some());
    assert_eq!(p.centres.as_ref().unwrap().neutral_axis, [0.01, 0.02]);
    // Its matrices assemble (the tapered kernel about the shear centre).
    crate::fe::model_assembly::assemble_model(&m, MassKind::Consistent).unwrap();
}

/// `write_bulk` writes the offsets back (a PBEAM with N, M, NSI on CBEAM, the CHAN's PBEAML as
/// the equivalent PBEAM, a tapered PBEAM with its M line), and the re-import is the same model
/// property for property.
#[test]
fn offsets_round_trip_through_the_export() {
    let props = "PBEAM,7,1,1.8-3,6.5-6,2.2-6,,3.-8,2.5\n,,,,,,,,\n,.8,.9,,,.012\n,-.03,.045,,,.021,-.013\n\
                 PBEAML,8,1,,CHAN\n,.08,.2,.009,.012,1.5\n\
                 PBEAML,9,1,,L\n,.1,.15,.01,.008\n\
                 PBEAM,10,1,2.-3,4.-6,6.-6,,2.-6,1.5\n,NO,1.,1.-3,2.-6,3.-6,,1.-6,.5\n,,\n,,,,,.01,.02\n";
    let text = format!(
        "{}CBEAM,3,8,1,2,0.,1.,0.\nCBEAM,4,9,2,3,0.,1.,0.\nCBEAM,5,10,2,3,0.,1.,0.\n",
        deck(props)
    );
    let a = parse(&text).model;
    for id in [7, 8, 9, 10] {
        assert!(a.beam_properties[&id].centres.is_some(), "{id}");
    }
    let out = write_bulk(&a);
    assert!(!out.contains("CBAR"), "{out}");
    let b = parse(&out).model;
    assert_eq!(a.beam_properties[&7], b.beam_properties[&7]);
    assert_eq!(a.beam_properties[&10], b.beam_properties[&10]);
    for id in [8, 9] {
        let (p, q) = (&a.beam_properties[&id], &b.beam_properties[&id]);
        assert_eq!(
            (&p.section, &p.centres, p.nsm),
            (&q.section, &q.centres, q.nsm),
            "{id}"
        );
    }
}

/// Through the model: the `E` and `ρ` derivatives of an imported PBEAM with N, M and NSI (both
/// mass kinds) match central differences of the assembled matrices (steps 1e-5 relative; `K`
/// is linear in `E` and `M` in `ρ`, so round-off only: 1e-8 of the largest entry), and a
/// dimension of a tapered section whose centroid is off its shear centre is refused, by name.
#[test]
fn model_derivatives_with_offsets() {
    use crate::fe::model_assembly::{assemble_model, parameter_derivative};
    use crate::model::{Parameter, ParameterKind};
    let pbeam =
        "PBEAM,7,1,1.8-3,6.5-6,2.2-6,,3.-8,2.5\n,,,,,,,,\n,.8,.9,,,.012\n,-.03,.045,,,.021,-.013\n";
    let model = parse(&deck(pbeam)).model;
    let param = |kind: ParameterKind| Parameter {
        name: "p".into(),
        kind,
        set: "pid7".into(),
        lower: 1e-12,
        upper: 1e15,
    };
    for kind in [MassKind::Consistent, MassKind::Lumped] {
        for (p, value) in [
            (param(ParameterKind::YoungsModulus), 2.1e11),
            (param(ParameterKind::Density), 7850.0),
        ] {
            let (sys, _) = assemble_model(&model, kind).unwrap();
            let (dk, dm) = parameter_derivative(&model, &p, &sys.dofs, kind).unwrap();
            let at = |dv: f64| {
                let mut m = model.clone();
                m.set_parameter_value(&p, value + dv).unwrap();
                let (s, _) = assemble_model(&m, kind).unwrap();
                assert_eq!(s.dofs, sys.dofs);
                (s.k.to_dense(), s.m.to_dense())
            };
            let h = 1e-5 * value;
            let ((kp, mp), (km, mm)) = (at(h), at(-h));
            for (exact, plus, minus) in [(dk.to_dense(), kp, km), (dm.to_dense(), mp, mm)] {
                let fd = (&plus - &minus) * faer::Scale(1.0 / (2.0 * h));
                let scale = fd.norm_max().max(exact.norm_max());
                if scale > 0.0 {
                    let e = (&exact - &fd).norm_max() / scale;
                    eprintln!("model {kind:?} {:?}: {e:e}", p.kind);
                    assert!(e < 1e-8, "{kind:?} {:?}: {e:e}", p.kind);
                }
            }
        }
    }
    let tapered = parse(&deck("PBEAML,7,1,,T\n,.2,.25,.02,.012,1.,NO,1.,\n,,,,.5\n")).model;
    let (sys, _) = assemble_model(&tapered, MassKind::Consistent).unwrap();
    let e = parameter_derivative(
        &tapered,
        &param(ParameterKind::BeamWidth),
        &sys.dofs,
        MassKind::Consistent,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("width") && e.contains("shear centre"), "{e}");
}
