//! Rigid elements and multipoint constraints: importer fixtures, checked against a second path
//! (the same structure with merged grids, an offset CONM2, hand values) through the assembly.

use super::tests::{error, parse};
use crate::core::sparse::sparse_to_dense;
use crate::core::{Component, DofId};
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::{assemble_model, parameter_derivative};
use crate::model::Model;

const BEAM_PROPS: &str = "MAT1,1,2.1+11,,.3,7850.\nPBAR,1,1,1.-4,2.-9,3.-9,1.-9\n";

/// Lowest `n` frequencies (Hz) and the count of rigid-body modes.
fn modes(m: &Model, n: usize) -> (Vec<f64>, usize) {
    let (sys, _) = assemble_model(m, MassKind::Consistent).unwrap();
    sys.validate().unwrap();
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(n),
        &SparseEigenParams::default(),
    )
    .unwrap();
    (modes.frequencies_hz(), modes.rigid_body_modes)
}

/// Largest `|a − b|` entry and largest `|b|` entry of two dense matrices of one shape.
fn diff_and_scale(a: &faer::Mat<f64>, b: &faer::Mat<f64>) -> (f64, f64) {
    let (mut d, mut s) = (0.0f64, 0.0f64);
    for j in 0..b.ncols() {
        for i in 0..b.nrows() {
            d = d.max((a[(i, j)] - b[(i, j)]).abs());
            s = s.max(b[(i, j)].abs());
        }
    }
    (d, s)
}

fn max_rel_diff(a: &[f64], b: &[f64], floor: f64) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(floor))
        .fold(0.0, f64::max)
}

/// Two free beams along x, 1-2-3 and 4-5-6, grids 3 and 4 at the same place, joined by `join`.
fn two_beams(join: &str) -> String {
    format!(
        "{BEAM_PROPS}GRID,1,,0.,0.,0.\nGRID,2,,.5,0.,0.\nGRID,3,,1.,0.,0.\nGRID,4,,1.,0.,0.\nGRID,5,,1.5,.1,0.\nGRID,6,,2.,.3,0.\nCBAR,1,1,1,2,0.,0.,1.\nCBAR,2,1,2,3,0.,0.,1.\nCBAR,3,1,4,5,0.,0.,1.\nCBAR,4,1,5,6,0.,0.,1.\n{join}"
    )
}

const MERGED: &str = "GRID,1,,0.,0.,0.\nGRID,2,,.5,0.,0.\nGRID,3,,1.,0.,0.\nGRID,5,,1.5,.1,0.\nGRID,6,,2.,.3,0.\nCBAR,1,1,1,2,0.,0.,1.\nCBAR,2,1,2,3,0.,0.,1.\nCBAR,3,1,3,5,0.,0.,1.\nCBAR,4,1,5,6,0.,0.,1.\n";

/// An RBE2 (and an MPC per component) joining coincident grids gives exactly the merged mesh:
/// the same K and M over the same DOFs (to round-off, 1e-12 of the largest entry: only the
/// order of summation differs) and so the same modes, six of them rigid.
#[test]
fn rbe2_and_mpc_joining_coincident_grids_equal_the_merged_mesh() {
    let merged = parse(&format!("{BEAM_PROPS}{MERGED}")).model;
    let (ms, _) = assemble_model(&merged, MassKind::Consistent).unwrap();
    let mpc: String = (1..=6)
        .map(|c| format!("MPC,9,4,{c},1.,3,{c},-1.\n"))
        .collect();
    for join in ["RBE2,10,3,123456,4\n".to_string(), mpc] {
        let m = parse(&two_beams(&join)).model;
        assert_eq!(m.mpcs.len(), 6, "{join}");
        let (s, info) = assemble_model(&m, MassKind::Consistent).unwrap();
        assert_eq!(s.dofs, ms.dofs, "{join}");
        assert_eq!(info.dependent.len(), 6);
        for (a, b) in [(s.k_dense(), ms.k_dense()), (s.m_dense(), ms.m_dense())] {
            let (diff, scale) = diff_and_scale(&a, &b);
            assert!(diff <= 1e-12 * scale, "{join}: {diff:e} vs {scale:e}");
        }
        let (f, rigid) = modes(&m, 10);
        let (g, _) = modes(&merged, 10);
        assert_eq!(rigid, 6, "{join}");
        assert!(
            max_rel_diff(&f[6..], &g[6..], 1e-6) < 1e-9,
            "{f:?} vs {g:?}"
        );
    }
}

/// A rigid spider: an RBE2 from an offset grid 10 (independent, holding a CONM2) to the tip of a
/// cantilever equals the same mass given to the tip as a CONM2 with that offset (a rigid offset
/// is exactly what CONM2's offset means). Also through chains (10 → 11 → tip) and with the
/// roles reversed (tip independent). Tolerance 1e-9 relative: two eigen solves of equal
/// matrices assembled in different orders.
#[test]
fn rbe2_spider_with_a_mass_equals_an_offset_conm2() {
    let beam = format!(
        "{BEAM_PROPS}GRID,1,,0.,0.,0.\nGRID,2,,.5,0.,0.\nGRID,3,,1.,0.,0.\nCBAR,1,1,1,2,0.,0.,1.\nCBAR,2,1,2,3,0.,0.,1.\nSPC1,1,123456,1\n"
    );
    let inertia = "+M,.01,0.,.02,0.,0.,.03\n";
    let offset = parse(&format!("{beam}CONM2,5,3,0,2.,.2,.3,-.1,,+M\n{inertia}")).model;
    let spider = parse(&format!(
        "{beam}GRID,10,,1.2,.3,-.1\nRBE2,7,10,123456,3\nCONM2,5,10,0,2.,,,,,+M\n{inertia}"
    ))
    .model;
    let chain = parse(&format!(
        "{beam}GRID,10,,1.2,.3,-.1\nGRID,11,,1.1,0.,.2\nRBE2,7,10,123456,11\nRBE2,8,11,123456,3\nCONM2,5,10,0,2.,,,,,+M\n{inertia}"
    ))
    .model;
    let reversed = parse(&format!(
        "{beam}GRID,10,,1.2,.3,-.1\nRBE2,7,3,123456,10\nCONM2,5,10,0,2.,,,,,+M\n{inertia}"
    ))
    .model;
    let (g, _) = modes(&offset, 8);
    for (name, m) in [
        ("spider", &spider),
        ("chain", &chain),
        ("reversed", &reversed),
    ] {
        let (f, rigid) = modes(m, 8);
        assert_eq!(rigid, 0);
        assert!(max_rel_diff(&f, &g, 1e-6) < 1e-9, "{name}: {f:?} vs {g:?}");
    }
}

/// RBE3 with translations at the four corners of a square around the reference grid, equal
/// weights: the reference translation is the mean of the corner translations and its rotations
/// the least-squares slopes, by hand: for `u_z = (z₁, z₂, z₃, z₄)` at `(1,1), (−1,1), (−1,−1),
/// (1,−1)`: `u_z,ref = Σz/4`, `θ_x = (z₁ + z₂ − z₃ − z₄)/4`, `θ_y = −(z₁ − z₂ − z₃ + z₄)/4`.
/// A rigid field (translation plus rotation, with weighted rotations in the fit) is reproduced
/// exactly for any weights.
#[test]
fn rbe3_reference_is_the_weighted_least_squares_motion() {
    let grids = "GRID,1,,1.,1.,0.\nGRID,2,,-1.,1.,0.\nGRID,3,,-1.,-1.,0.\nGRID,4,,1.,-1.,0.\nGRID,100,,0.,0.,0.\n";
    let plate = "MAT1,1,7.+10,,.3,2700.\nPSHELL,1,1,.01\nCQUAD4,1,1,1,2,3,4\n";
    let m = parse(&format!(
        "{plate}{grids}RBE3,9,,100,123456,1.,123,1,2,+R\n+R,3,4\n"
    ))
    .model;
    let value = |dof: DofId, field: &dyn Fn(DofId) -> f64| -> f64 {
        let c = m.mpcs.iter().find(|c| c.dependent == dof).unwrap();
        c.terms.iter().map(|(d, v)| v * field(*d)).sum()
    };
    let z = [1.0, 2.0, 4.0, 8.0];
    let field = |d: DofId| {
        if d.comp == Component::Uz {
            z[(d.node - 1) as usize]
        } else {
            0.0
        }
    };
    let hand = [
        (Component::Uz, z.iter().sum::<f64>() / 4.0),
        (Component::Rx, (z[0] + z[1] - z[2] - z[3]) / 4.0),
        (Component::Ry, -(z[0] - z[1] - z[2] + z[3]) / 4.0),
        (Component::Ux, 0.0),
        (Component::Rz, 0.0),
    ];
    for (c, h) in hand {
        let v = value(DofId::new(100, c), &field);
        assert!((v - h).abs() < 1e-12, "{c:?}: {v} vs {h}");
    }
    assert_eq!(m.mpcs[0].origin, "RBE3 9");
    // A rigid motion a + θ × x (and θ at every grid) with unequal weights and rotations.
    let w = parse(&format!(
        "{plate}{grids}RBE3,9,,100,123456,1.,123456,1,2,+R\n+R,3,2.5,123,4\n"
    ))
    .model;
    let (a, th) = ([0.3, -0.2, 0.5], [0.01, 0.02, -0.03]);
    let rigid = |d: DofId| -> f64 {
        let x = w.nodes[&d.node];
        let k = d.comp.nastran() as usize;
        if k > 3 {
            return th[k - 4];
        }
        let t = [
            th[1] * x[2] - th[2] * x[1],
            th[2] * x[0] - th[0] * x[2],
            th[0] * x[1] - th[1] * x[0],
        ];
        a[k - 1] + t[k - 1]
    };
    for c in &w.mpcs {
        let v: f64 = c.terms.iter().map(|(d, x)| x * rigid(*d)).sum();
        assert!((v - rigid(c.dependent)).abs() < 1e-12, "{}", c.dependent);
    }
}

/// RBAR with CNA = 123456 is an RBE2 from GA to GB; RROD keeps the axial distance: along a
/// rod on x with CMB = 1, `u_x,B = u_x,A`.
#[test]
fn rbar_and_rrod_give_their_rigid_equations() {
    let grids = "GRID,1,,0.,0.,0.\nGRID,2,,1.,2.,3.\n";
    let stiff = "CELAS2,1,1.,1,1\n";
    let a = parse(&format!("{grids}{stiff}RBAR,5,1,2,123456,,,123456\n")).model;
    let b = parse(&format!("{grids}{stiff}RBE2,5,1,123456,2\n")).model;
    assert_eq!(a.mpcs.len(), 6);
    for (x, y) in a.mpcs.iter().zip(&b.mpcs) {
        assert_eq!(x.dependent, y.dependent);
        assert_eq!(x.terms.len(), y.terms.len());
        for (s, t) in x.terms.iter().zip(&y.terms) {
            assert_eq!(s.0, t.0);
            assert!((s.1 - t.1).abs() < 1e-12);
        }
    }
    let r = parse("GRID,1,,0.,0.,0.\nGRID,2,,2.,0.,0.\nCELAS2,1,1.,1,1\nRROD,5,1,2,,1\n").model;
    assert_eq!(r.mpcs.len(), 1);
    assert_eq!(r.mpcs[0].dependent, DofId::new(2, Component::Ux));
    assert_eq!(r.mpcs[0].terms, vec![(DofId::new(1, Component::Ux), 1.0)]);
    // An RBAR whose independent components leave a rigid motion free is refused.
    let e = error(&format!("{grids}{stiff}RBAR,5,1,2,123,123,456,456\n"));
    assert!(e.contains("do not determine the bar's rigid motion"), "{e}");
}

/// RBE1 with all six independent components at GN1 is RBAR's (and RBE2's) equations; with the
/// six spread over three grids (123 at 1, 23 at 2, 3 at 3, the QRG's classic choice), every
/// dependent component reproduces an arbitrary rigid motion exactly; independent components
/// that leave a motion free, a grid without components and a component both independent and
/// dependent are errors naming the card.
#[test]
fn rbe1_gives_the_rigid_motion_of_its_independent_components() {
    let grids = "GRID,1,,0.,0.,0.\nGRID,2,,1.,2.,3.\n";
    let stiff = "CELAS2,1,1.,1,1\n";
    let a = parse(&format!("{grids}{stiff}RBE1,5,1,123456\n,UM,2,123456\n")).model;
    let b = parse(&format!("{grids}{stiff}RBAR,5,1,2,123456,,,123456\n")).model;
    assert_eq!(a.mpcs.len(), 6);
    for (x, y) in a.mpcs.iter().zip(&b.mpcs) {
        assert_eq!(x.dependent, y.dependent);
        for (s, t) in x.terms.iter().zip(&y.terms) {
            assert_eq!(s.0, t.0);
            assert!((s.1 - t.1).abs() < 1e-12);
        }
    }
    assert_eq!(a.mpcs[0].origin, "RBE1 5");
    // Three independent grids not on a line, two dependent ones; the QRG's continuation layout
    // (first field of each continuation blank, ALPHA at the end).
    let deck = "GRID,1,,0.,0.,0.\nGRID,2,,2.,0.,0.\nGRID,3,,0.,3.,0.\nGRID,4,,1.,1.,1.\nGRID,5,,-1.,2.,.5\nCELAS2,1,1.,1,1\nRBE1,7,1,123,2,23,3,3\n,\n,UM,4,123456,5,135,1.-5\n";
    let w = parse(deck).model;
    assert_eq!(w.mpcs.len(), 9);
    let (u0, th) = ([0.3, -0.2, 0.5], [0.01, 0.02, -0.03]);
    let rigid = |d: DofId| -> f64 {
        let x = w.nodes[&d.node];
        let k = d.comp.nastran() as usize;
        if k > 3 {
            return th[k - 4];
        }
        let t = [
            th[1] * x[2] - th[2] * x[1],
            th[2] * x[0] - th[0] * x[2],
            th[0] * x[1] - th[1] * x[0],
        ];
        u0[k - 1] + t[k - 1]
    };
    for c in &w.mpcs {
        assert!(c.dependent.node >= 4, "{}", c.dependent);
        let v: f64 = c.terms.iter().map(|(d, x)| x * rigid(*d)).sum();
        assert!((v - rigid(c.dependent)).abs() < 1e-12, "{}", c.dependent);
    }
    // Three grids on a line cannot fix the rotation about it.
    let line =
        "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,2.,0.,0.\nGRID,4,,0.,1.,0.\nCELAS2,1,1.,1,1\n";
    let e = error(&format!("{line}RBE1,7,1,123,2,12,3,2\n,UM,4,1\n"));
    assert!(
        e.contains("RBE1 7") && e.contains("do not determine"),
        "{e}"
    );
    let e = error(&format!("{line}RBE1,7,1,123,2,12\n,UM,4,1\n"));
    assert!(e.contains("CNi hold 5 components"), "{e}");
    let e = error(&format!("{line}RBE1,7,1,123456\n,UM,1,1\n"));
    assert!(e.contains("both independent and dependent"), "{e}");
    let e = error(&format!("{line}RBE1,7,1,123456\n"));
    assert!(e.contains("no dependent grid follows UM"), "{e}");
}

/// Nastran's fatal cases, each naming the cards.
#[test]
fn conflicting_constraints_are_errors_naming_the_cards() {
    let base = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,2.,0.,0.\nCELAS2,1,1.,1,1\n";
    let e = error(&format!("{base}RBE2,5,1,123,2\nRBE2,6,3,1,2\n"));
    assert!(
        e.contains("DOF 2:1 is dependent in both RBE2 5") && e.contains("and RBE2 6"),
        "{e}"
    );
    let e = error(&format!("{base}RBE2,5,1,123,2\nSPC1,1,1,2\n"));
    assert!(
        e.contains("RBE2 5 makes DOF 2:ux dependent") && e.contains("SPC at t.bdf line"),
        "{e}"
    );
    let e = error(&format!("{base}RBE2,5,1,1,2\nRBE2,6,2,1,1\n"));
    assert!(e.contains("cycle"), "{e}");
    let e = error(&format!("{base}RBE3,5,,1,123,1.,123,2,3,+R\n+R,UM,1,1\n"));
    assert!(e.contains("UM"), "{e}");
    let e = error(&format!("{base}RBE2,5,1,123,9\n"));
    assert!(e.contains("grid 9, which is not defined"), "{e}");
}

/// The case control's `MPC = n` selects a set (directly or through MPCADD); without a selection
/// in a deck with case control no MPC applies.
#[test]
fn the_case_control_selects_the_mpc_set() {
    let bulk = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nCELAS2,1,1.,1,1\nCELAS2,2,1.,2,1\nMPC,1,2,1,1.,1,1,-1.\nMPC,2,2,2,1.,1,2,-1.\nMPCADD,3,1,2\n";
    let with = |cc: &str| format!("SOL 103\nCEND\n{cc}BEGIN BULK\n{bulk}ENDDATA\n");
    assert_eq!(parse(&with("MPC = 1\n")).model.mpcs.len(), 1);
    assert_eq!(parse(&with("MPC = 3\n")).model.mpcs.len(), 2);
    let b = parse(&with(""));
    assert!(b.model.mpcs.is_empty());
    assert!(b.warnings.iter().any(|w| w.contains("selects no MPC set")));
    assert_eq!(parse(bulk).model.mpcs.len(), 2);
    let e = error(&with("MPC = 7\n"));
    assert!(e.contains("MPC = 7, which no MPC"), "{e}");
}

/// `∂K̃/∂E` and `∂M̃/∂ρ` of the beams of a model with an RBE2 spider equal central differences
/// of the whole reduced assembly (K̃ is linear in E and M̃ in ρ, so the difference is exact to
/// round-off: tolerance 1e-7 of the largest entry).
#[test]
fn reduced_derivatives_match_central_differences() {
    use crate::model::{Parameter, ParameterKind};
    let mut m = parse(&two_beams(
        "RBE2,10,3,123456,4\nGRID,20,,1.,.5,0.\nRBE2,11,20,123,6\nCONM2,30,20,,1.\n",
    ))
    .model;
    for (kind, name) in [
        (ParameterKind::YoungsModulus, "e"),
        (ParameterKind::Density, "rho"),
    ] {
        m.parameters = vec![Parameter {
            name: name.into(),
            kind: kind.clone(),
            set: "pid1".into(),
            lower: 0.0,
            upper: 1e12,
        }];
        let (sys, _) = assemble_model(&m, MassKind::Consistent).unwrap();
        let (dk, dm) =
            parameter_derivative(&m, &m.parameters[0], &sys.dofs, MassKind::Consistent).unwrap();
        let set = |v: f64| {
            let mut x = m.clone();
            let mat = x.materials.get_mut(&1).unwrap();
            if name == "e" {
                mat.e = v;
            } else {
                mat.rho = v;
            }
            assemble_model(&x, MassKind::Consistent).unwrap().0
        };
        let v0 = if name == "e" {
            m.materials[&1].e
        } else {
            m.materials[&1].rho
        };
        let h = 1e-3 * v0;
        let (p, q) = (set(v0 + h), set(v0 - h));
        assert_eq!(p.dofs, sys.dofs);
        for (analytic, fp, fq) in [
            (sparse_to_dense(&dk), p.k_dense(), q.k_dense()),
            (sparse_to_dense(&dm), p.m_dense(), q.m_dense()),
        ] {
            let fd = faer::Mat::from_fn(fp.nrows(), fp.ncols(), |i, j| {
                (fp[(i, j)] - fq[(i, j)]) / (2.0 * h)
            });
            let (diff, scale) = diff_and_scale(&analytic, &fd);
            // Zero where the parameter does not act (∂K/∂ρ): then both are exactly zero.
            assert!(diff <= 1e-7 * scale, "{name}: {diff:e} vs {scale:e}");
        }
    }
}

/// Export writes MPC cards that read back to the same constraints (origins become `MPC 1`).
#[test]
fn mpcs_round_trip_through_the_exporter() {
    let m = parse(&two_beams(
        "RBE2,10,3,123456,4\nGRID,20,,1.,.5,0.\nRBE3,11,,20,123456,1.,123,1,2,+R\n+R,5,6\n",
    ))
    .model;
    let text = crate::model::export::nastran::write_bulk(&m);
    assert!(text.contains("$ RBE2 10\nMPC*"), "{text}");
    let back = super::parse_bulk(&text, "x.bdf").unwrap().model;
    assert_eq!(back.mpcs.len(), m.mpcs.len());
    for (a, b) in back.mpcs.iter().zip(&m.mpcs) {
        assert_eq!(a.dependent, b.dependent);
        assert_eq!(a.terms, b.terms);
        assert_eq!(a.origin, "MPC 1");
    }
}
