//! Scalar points, scalar elements, CONM1, dampers and the CBUSH element system (scalars.rs).

use super::tests::{error, parse};
use super::*;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::{assemble_model, parameter_derivative};
use crate::model::structure::Element;

fn eigenvalues(model: &Model) -> Vec<f64> {
    let (sys, _) = assemble_model(model, MassKind::Consistent).unwrap();
    let (modes, _) = crate::eigen::lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        crate::eigen::ModeSelection::Count(sys.n()),
        &crate::eigen::SparseEigenParams::default(),
    )
    .unwrap();
    modes.eigenvalues.clone()
}

/// `m₁ m₂ λ² − (m₁ k₂ + m₂ (k₁ + k₂)) λ + k₁ k₂ = 0` of the chain ground–k₁–m₁–k₂–m₂.
fn two_dof(k1: f64, k2: f64, m1: f64, m2: f64) -> [f64; 2] {
    let (a, b, c) = (m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2);
    let r = (b * b - 4.0 * a * c).sqrt();
    [(-b - r) / (2.0 * a), (-b + r) / (2.0 * a)]
}

/// The two-DOF chain on scalar points (CELAS4, CMASS4, CELAS3 with PELAS, CMASS3 with PMASS,
/// k₁ to a third scalar point held by SPC1 component 0) against the closed form, to 1e-12
/// relative (a 2×2 problem solved densely: round-off only); the same chain on grid components
/// (CELAS2, CMASS2, CELAS1, CMASS1, the other DOFs having nothing and dropped) gives the same
/// eigenvalues to 1e-12.
#[test]
fn a_two_dof_chain_on_scalar_points_is_analytic() {
    let (k1, k2, m1, m2) = (3.0e4, 1.0e4, 2.0, 1.0);
    let deck = "\
SPOINT,1,THRU,3
EPOINT,50
CELAS4,10,3.+4,1,3
CELAS3,11,7,1,2
PELAS,7,1.+4
CMASS4,20,2.,1
CMASS3,21,8,2,0
PMASS,8,1.
SPC1,1,0,3
";
    let b = parse(deck);
    assert_eq!(
        b.model.scalar_points,
        [1, 2, 3, 50].into_iter().collect::<BTreeSet<u64>>()
    );
    assert_eq!(
        b.model.elements[&11],
        Element::ScalarSpring {
            dof: DofId::new(1, Component::Scalar),
            other: Some(DofId::new(2, Component::Scalar)),
            k: k2
        }
    );
    assert_eq!(b.model.constraints, [DofId::new(3, Component::Scalar)]);
    let want = two_dof(k1, k2, m1, m2);
    let got = eigenvalues(&b.model);
    assert_eq!(got.len(), 2, "the unconnected EPOINT is dropped");
    for (g, w) in got.iter().zip(want) {
        assert!(((g - w) / w).abs() < 1e-12, "{g} vs {w}");
    }
    let grids = "\
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.
CELAS2,10,3.+4,1,1
CELAS1,11,7,1,1,2,1
PELAS,7,1.+4
CMASS2,20,2.,1,1
CMASS1,21,8,2,1
PMASS,8,1.
";
    let g = eigenvalues(&parse(grids).model);
    for (a, b) in g.iter().zip(&got) {
        assert!(((a - b) / b).abs() < 1e-12, "{a} vs {b}");
    }
    // A spring from a grid to a scalar point is not a syntax error.
    let mixed = "GRID,1,,0.,0.,0.\nSPOINT,5\nCELAS2,1,10.,1,3,5\nCMASS2,2,1.,5\n";
    let m = parse(mixed).model;
    assert_eq!(
        m.elements[&1],
        Element::ScalarSpring {
            dof: DofId::new(1, Component::Uz),
            other: Some(DofId::new(5, Component::Scalar)),
            k: 10.0
        }
    );
    let (sys, _) = assemble_model(&m, MassKind::Consistent).unwrap();
    assert_eq!(
        sys.dofs,
        [
            DofId::new(1, Component::Uz),
            DofId::new(5, Component::Scalar)
        ]
    );
}

/// CONM1 holding the CONM2 matrix `[[m I, −m E], [m E, J − m E²]]` of the same mass, inertia
/// and offset gives the same assembled `M` (1e-13 of its largest entry: both are sums of a few
/// products); likewise when both cards are given in a rotated CORD2R (CONM2's CID rotation is
/// femu's existing path, CONM1's `Tᵀ M T` the new one).
#[test]
fn conm1_equals_the_conm2_it_writes_out() {
    let (mass, x, i) = (2.5, [0.1, -0.2, 0.3], [1.0, 0.1, 2.0, -0.2, 0.05, 3.0]);
    let lm = crate::fe::lumped_elements::LumpedMass::from_nastran(mass, x, i);
    let mm = crate::fe::lumped_elements::conm2(&lm).unwrap().m;
    let mut fields = Vec::new();
    for r in 0..6 {
        for c in 0..=r {
            fields.push(format!("{:e}", mm[(r, c)]));
        }
    }
    let f = |a: usize, b: usize| fields[a..b].join(",");
    for cid in [0, 5] {
        let cord = "CORD2R,5,,0.,0.,0.,.3,.4,.866025403784\n,1.,0.,0.\n";
        let conm1 = format!(
            "GRID,1,,1.,2.,3.\n{cord}CONM1,1,1,{cid},{}\n,{}\n,{}\n",
            f(0, 5),
            f(5, 13),
            f(13, 21)
        );
        let conm2 = format!(
            "GRID,1,,1.,2.,3.\n{cord}CONM2,1,1,{cid},2.5,.1,-.2,.3\n,1.,.1,2.,-.2,.05,3.\n"
        );
        let (m1, m2) = (parse(&conm1).model, parse(&conm2).model);
        let (a, _) = assemble_model(&m1, MassKind::Consistent).unwrap();
        let (b, _) = assemble_model(&m2, MassKind::Consistent).unwrap();
        // The GRDPNT weight summary counts the CONM1 as the CONM2.
        let mp = |m: &Model| {
            crate::fe::mass_properties::mass_properties(m, MassKind::Consistent, [0.0; 3]).unwrap()
        };
        let (p1, p2) = (mp(&m1), mp(&m2));
        for (x, y) in p1
            .rigid_body_mass
            .iter()
            .flatten()
            .zip(p2.rigid_body_mass.iter().flatten())
        {
            assert!((x - y).abs() < 1e-12 * 30.0, "{x} vs {y}");
        }
        assert_eq!(a.dofs, b.dofs);
        let (ma, mb) = (a.m_dense(), b.m_dense());
        let scale = crate::core::dense::max_abs(mb.as_ref());
        for r in 0..6 {
            for c in 0..6 {
                assert!(
                    (ma[(r, c)] - mb[(r, c)]).abs() < 1e-13 * scale,
                    "CID {cid} ({r}, {c}): {} vs {}",
                    ma[(r, c)],
                    mb[(r, c)]
                );
            }
        }
    }
}

/// A CBUSH whose CID is basic turned 90° about z equals the bush in basic with kx, ky (and
/// krx, kry) swapped, exactly; an orientation vector gives x from GA to GB.
#[test]
fn a_bush_in_a_turned_system_swaps_its_stiffnesses() {
    let head = "GRID,1,,0.,0.,0.\nGRID,2,,0.,0.,0.\nCONM2,9,2,,1.\n";
    let turned = format!(
        "{head}CORD2R,3,,0.,0.,0.,0.,0.,1.\n,0.,1.,0.\nCBUSH,1,4,2,1,,,,3\nPBUSH,4,K,1.,2.,3.,4.,5.,6.\n"
    );
    let plain = format!("{head}CBUSH,1,4,2,1,,,,0\nPBUSH,4,K,2.,1.,3.,5.,4.,6.\n");
    let (a, _) = assemble_model(&parse(&turned).model, MassKind::Consistent).unwrap();
    let (b, _) = assemble_model(&parse(&plain).model, MassKind::Consistent).unwrap();
    assert_eq!(a.dofs, b.dofs);
    let (ka, kb) = (a.k_dense(), b.k_dense());
    for r in 0..ka.nrows() {
        for c in 0..ka.ncols() {
            assert!((ka[(r, c)] - kb[(r, c)]).abs() < 1e-15, "({r}, {c})");
        }
    }
    // Orientation vector: x along GA->GB (basic y), v along basic z: element y is basic z.
    let deck = "GRID,1,,0.,0.,0.\nGRID,2,,0.,2.,0.\nCBUSH,1,4,1,2,0.,0.,1.\nPBUSH,4,K,1.,2.,3.\n";
    let Element::Bush { axes, .. } = &parse(deck).model.elements[&1] else {
        panic!("not a bush");
    };
    assert_eq!(
        *axes,
        Some([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    );
    let e = error("GRID,1,,0.,0.,0.\nCBUSH,1,4,1,,0.,0.,1.\nPBUSH,4,K,1.\n");
    assert!(
        e.contains("t.bdf line 2: CBUSH field 9 (CID)") && e.contains("CID is blank"),
        "{e}"
    );
}

/// The direct FRF of a single-DOF oscillator (CELAS2, CMASS2, CDAMP2 on one grid component)
/// equals `1/(k − ω²m + iωc)` to 1e-12 relative (one complex division per line); a CVISC along
/// x damps like a CDAMP2 pair between the grids' x components (equal `C`, exactly).
#[test]
fn dampers_enter_the_direct_frf() {
    let deck = "\
GRID,1,,0.,0.,0.
CELAS2,1,4.+4,1,1
CMASS2,2,1.5,1,1
CDAMP2,3,12.,1,1
";
    let model = parse(deck).model;
    let (mut sys, _) = assemble_model(&model, MassKind::Consistent).unwrap();
    sys.c = crate::fe::damping::damping_matrix(&model, &sys.dofs).unwrap();
    assert!(sys.c.is_some());
    let d = DofId::new(1, Component::Ux);
    let pairs = crate::frf::FrfSet::all_pairs(&[d], &[d]);
    let lines = [1.0, 20.0, 26.0, 80.0];
    let set = crate::frf::direct::direct_receptance(
        &sys,
        &crate::frf::direct::DirectDamping::default(),
        &pairs,
        &lines,
        crate::frf::Quantity::Receptance,
    )
    .unwrap();
    for (r, f) in lines.iter().enumerate() {
        let w = 2.0 * std::f64::consts::PI * f;
        let want = faer::c64::new(1.0, 0.0) / faer::c64::new(4e4 - w * w * 1.5, w * 12.0);
        let got = set.values[(r, 0)];
        assert!(
            (got - want).norm() < 1e-12 * want.norm(),
            "{f} Hz: {got} vs {want}"
        );
    }
    let grids = "GRID,1,,0.,0.,0.\nGRID,2,,2.,0.,0.\nCMASS2,9,1.,1,1\nCMASS2,10,1.,2,1\n";
    let visc = format!("{grids}CVISC,1,5,1,2\nPVISC,5,7.,0.\n");
    let pair = format!("{grids}CDAMP2,1,7.,1,1,2,1\n");
    let c_of = |deck: &str| {
        let m = parse(deck).model;
        let (s, _) = assemble_model(&m, MassKind::Consistent).unwrap();
        let c = crate::fe::damping::damping_matrix(&m, &s.dofs)
            .unwrap()
            .unwrap();
        (s.dofs, crate::core::sparse::sparse_to_dense(&c))
    };
    let (da, ca) = c_of(&visc);
    let (db, cb) = c_of(&pair);
    assert_eq!(da, db);
    assert_eq!(ca, cb);
    // A model without dampers has no C.
    let m = parse(grids).model;
    let (s, _) = assemble_model(&m, MassKind::Consistent).unwrap();
    assert!(
        crate::fe::damping::damping_matrix(&m, &s.dofs)
            .unwrap()
            .is_none()
    );
}

/// `∂M/∂m` of a CMASS set equals the central difference of the assembled `M` (M is linear in
/// m: the difference is exact up to round-off, 1e-9 of the entry for a step of 1e-3 m);
/// PARAM,WTMASS multiplies CMASS and CONM1 masses.
#[test]
fn scalar_mass_derivatives_and_wtmass() {
    let deck = "\
SPOINT,1,2
CELAS4,10,3.+4,1
CELAS4,11,1.+4,1,2
CMASS4,20,2.,1,2
CMASS4,21,1.,2
SET1,5,20
$femu-set 5 cm
";
    let mut model = parse(deck).model;
    model.parameters.push(crate::model::Parameter {
        name: "m".into(),
        kind: crate::model::ParameterKind::LumpedMass(Component::Scalar),
        set: "cm".into(),
        lower: 0.0,
        upper: 10.0,
    });
    assert_eq!(model.parameter_value(&model.parameters[0]).unwrap(), 2.0);
    let (sys, _) = assemble_model(&model, MassKind::Consistent).unwrap();
    let (dk, dm) = parameter_derivative(
        &model,
        &model.parameters[0],
        &sys.dofs,
        MassKind::Consistent,
    )
    .unwrap();
    assert_eq!(dk.compute_nnz(), 0);
    let h = 1e-3;
    let at = |v: f64| {
        let mut m = model.clone();
        let p = m.parameters[0].clone();
        m.set_parameter_value(&p, v).unwrap();
        assemble_model(&m, MassKind::Consistent)
            .unwrap()
            .0
            .m_dense()
    };
    let (mp, mm) = (at(2.0 + h), at(2.0 - h));
    let d = crate::core::sparse::sparse_to_dense(&dm);
    for r in 0..2 {
        for c in 0..2 {
            let fd = (mp[(r, c)] - mm[(r, c)]) / (2.0 * h);
            assert!(
                (d[(r, c)] - fd).abs() < 1e-9,
                "({r}, {c}): {} vs {fd}",
                d[(r, c)]
            );
        }
    }
    assert_eq!(d[(0, 1)], -1.0);
    let b = parse("PARAM,WTMASS,.5\nGRID,1,,0.,0.,0.\nCMASS2,1,4.,1,1\nCONM1,2,1,,2.\n");
    assert_eq!(
        b.model.elements[&1],
        Element::ScalarMass {
            dof: DofId::new(1, Component::Ux),
            other: None,
            m: 2.0
        }
    );
    let Element::GeneralMass { m, .. } = &b.model.elements[&2] else {
        panic!("not a general mass");
    };
    assert_eq!(m[0], 1.0);
}

#[test]
fn bad_scalar_cards_are_named() {
    let cases = [
        (
            "GRID,1,,0.,0.,0.\nCELAS4,1,1.,1\n",
            "t.bdf line 2: CELAS4 field 4 (S): grid 1",
        ),
        (
            "SPOINT,1\nCELAS2,1,1.,1,3\n",
            "t.bdf line 2: CELAS2 field 5 (C): scalar point 1 is given component 3",
        ),
        (
            "GRID,1,,0.,0.,0.\nSPOINT,1\nCELAS2,1,1.,1,3\n",
            "t.bdf line 2: SPOINT field 2 (ID): 1 is also a GRID",
        ),
        (
            "SPOINT,1\nCELAS4,1,1.,1\nSPC,1,1,3\n",
            "t.bdf line 3: SPC field 4 (C): scalar point 1 is constrained in component 3",
        ),
        (
            "GRID,1,,0.,0.,0.\nCDAMP5,1,2,1\n",
            "t.bdf line 2: CDAMP5 field 2 (EID): CDAMP5 is a heat-transfer",
        ),
        (
            "SPOINT,1\nCMASS1,1,4,1\n",
            "t.bdf line 2: CMASS1 field 3 (PID): property 4 is not a PMASS",
        ),
        (
            "SPOINT,1\nCELAS4,1,1.,1,9\n",
            "t.bdf line 2: CELAS4 field 5 (G): point 9 is neither",
        ),
    ];
    for (deck, want) in cases {
        let e = error(deck);
        assert!(e.starts_with(want), "{e}\nwanted: {want}");
    }
}
