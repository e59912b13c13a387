//! Displacement systems (GRID CD): the model's DOFs at a grid with a CD are components along its
//! axes, as in Nastran. Each check has a second path written without CD: the same constraint as
//! an MPC over basic components, the same spring as a rod along the local axis, the same
//! structure with every grid in basic.

use super::tests::parse;
use crate::core::{Component, DofId};
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::fe::element::MassKind;
use crate::fe::mass_properties::mass_properties;
use crate::fe::model_assembly::{assemble_model, parameter_derivative};
use crate::model::Model;

/// Lowest `n` frequencies (Hz).
fn frequencies(m: &Model, n: usize) -> Vec<f64> {
    let (sys, _) = assemble_model(m, MassKind::Consistent).unwrap();
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(n),
        &SparseEigenParams::default(),
    )
    .unwrap();
    modes.frequencies_hz()
}

fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(1e-3))
        .fold(0.0, f64::max)
}

/// A 3 × 2 plate of CQUAD4 in the xy plane, clamped along x = 0 (grids 1, 5, 9), with `cd` in
/// the CD field of every other grid.
fn plate(cd: &str) -> String {
    let mut s = String::from("MAT1,1,7.+10,,.3,2700.\nPSHELL,1,1,.004,1,,1\n");
    for j in 0..3 {
        for i in 0..4 {
            let id = 1 + i + 4 * j;
            let field = if i == 0 { "" } else { cd };
            s.push_str(&format!(
                "GRID,{id},,{:.3},{:.3},0.,{field}\n",
                i as f64 * 0.1,
                j as f64 * 0.1
            ));
        }
    }
    for j in 0..2 {
        for i in 0..3 {
            let g = 1 + i + 4 * j;
            s.push_str(&format!(
                "CQUAD4,{},1,{g},{},{},{}\n",
                1 + i + 3 * j,
                g + 1,
                g + 5,
                g + 4
            ));
        }
    }
    s.push_str("SPC1,1,123456,1,5,9\n");
    s
}

/// System 6: rectangular, turned 30° about z and then tilted, so that no axis is a basic one.
/// System 7: cylindrical about basic z.
const SYSTEMS: &str = "CORD2R,6,0,0.,0.,0.,.1,.2,1.,+A\n+A,1.,.57735,.1\nCORD2C,7,0,0.,0.,0.,0.,0.,1.,+B\n+B,1.,0.,0.\n";

/// With every free grid in a skewed or a cylindrical system the structure is the same: the
/// frequencies and the weight summary equal those of the basic model to 1e-10 (the rotation is
/// exact up to round-off; the eigensolver's own tolerance is far below), and the DOFs keep their
/// names while their directions change.
#[test]
fn a_structure_in_displacement_systems_has_the_same_modes_and_mass() {
    let basic = parse(&plate("")).model;
    let f0 = frequencies(&basic, 8);
    let p0 = mass_properties(&basic, MassKind::Consistent, [0.0; 3]).unwrap();
    for cd in ["6", "7"] {
        let m = parse(&format!("{SYSTEMS}{}", plate(cd))).model;
        // Grids on the x axis have the cylindrical axes (e_R, e_θ, e_z) = basic: not listed.
        let listed = if cd == "7" { 6 } else { 9 };
        assert_eq!(m.displacement_systems.len(), listed, "CD {cd}");
        let f = frequencies(&m, 8);
        assert!(max_rel_diff(&f, &f0) < 1e-10, "CD {cd}: {f:?} vs {f0:?}");
        let p = mass_properties(&m, MassKind::Consistent, [0.0; 3]).unwrap();
        for (a, b) in p
            .rigid_body_mass
            .iter()
            .flatten()
            .zip(p0.rigid_body_mass.iter().flatten())
        {
            assert!((a - b).abs() < 1e-12 * p0.mass[0], "CD {cd}: {a} vs {b}");
        }
        // Grid 6 at (0.1, 0.1): e_R and e_θ at 45°.
        if cd == "7" {
            let r = m.displacement_systems[&6]; // at (0.1, 0.1): θ = 45°
            let s = std::f64::consts::FRAC_1_SQRT_2;
            assert!((r[0][0] - s).abs() < 1e-15 && (r[0][1] - s).abs() < 1e-15);
            assert!((r[1][0] + s).abs() < 1e-15 && (r[1][1] - s).abs() < 1e-15);
        }
    }
}

/// A single skewed component constrained in a cylindrical CD (the radial translation of grids
/// on a 45° line and elsewhere, something no basic DOF expresses) equals the same constraint
/// written as an MPC over basic components, `cos θ u_x + sin θ u_y = 0`: the same frequencies
/// to 1e-9 (two different eliminations of one constraint, each exact).
#[test]
fn a_skewed_single_point_constraint_equals_the_mpc_over_basic_components() {
    let free_grids = [4u64, 8, 12, 11];
    let spc: String = free_grids
        .iter()
        .map(|g| format!("SPC1,1,1,{g}\n"))
        .collect();
    let local = parse(&format!("{SYSTEMS}{}{spc}", plate("7"))).model;
    for g in free_grids {
        assert!(local.constraints.contains(&DofId::new(g, Component::Ux)));
    }
    let mut mpc = String::from("SPC=1\nMPC=2\nBEGIN BULK\n");
    mpc.push_str(&plate(""));
    let base = parse(&plate("")).model;
    for g in free_grids {
        let x = base.nodes[&g];
        let r = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let (c, s) = (x[0] / r, x[1] / r);
        mpc.push_str(&format!("MPC,2,{g},1,{c:.17},{g},2,{s:.17}\n"));
    }
    let basic = parse(&mpc).model;
    assert_eq!(basic.mpcs.len(), free_grids.len());
    let (f, g) = (frequencies(&local, 8), frequencies(&basic, 8));
    assert!(max_rel_diff(&f, &g) < 1e-9, "{f:?} vs {g:?}");
}

/// A CELAS2 on component 3 of a grid whose CD is skewed acts along that axis: the same as a
/// massless rod of axial stiffness `EA/L = k` from the grid along the axis to a clamped grid
/// (its torsion is `J = 0`), to 1e-9.
#[test]
fn a_spring_on_a_local_component_equals_a_rod_along_that_axis() {
    let k = 3.0e4;
    let with_spring = parse(&format!("{SYSTEMS}{}CELAS2,50,{k},12,3\n", plate("6"))).model;
    let base = parse(&format!("{SYSTEMS}{}", plate("6"))).model;
    let axis = base.displacement_systems[&12][2];
    let x = base.nodes[&12];
    let (e, len) = (2.0e11, 0.5);
    let area = k * len / e;
    let end = [0, 1, 2].map(|i| x[i] + len * axis[i]);
    let rod = format!(
        "{SYSTEMS}{}GRID,99,,{:.17},{:.17},{:.17}\nSPC1,1,123456,99\nCROD,50,50,12,99\nPROD,50,2,{area:.17}\nMAT1,2,{e},,.3,0.\n",
        plate("6"),
        end[0],
        end[1],
        end[2]
    );
    let with_rod = parse(&rod).model;
    let (f, g) = (frequencies(&with_spring, 8), frequencies(&with_rod, 8));
    assert!(max_rel_diff(&f, &g) < 1e-9, "{f:?} vs {g:?}");
    assert!(
        max_rel_diff(&f, &frequencies(&base, 8)) > 1e-4,
        "the spring matters"
    );
}

/// A rigid element is geometric: an RBE2 tying a grid in a skewed system to one in a
/// cylindrical system gives the frequencies of the same deck in basic (1e-10), and its
/// dependent DOFs are components of the dependent grid's own system.
#[test]
fn rigid_elements_between_grids_in_displacement_systems_are_unchanged() {
    let extra = "GRID,20,,.4,.25,.02,7\nCONM2,21,20,,.5\nRBE2,22,12,123456,20\n";
    let basic_extra = "GRID,20,,.4,.25,.02\nCONM2,21,20,,.5\nRBE2,22,12,123456,20\n";
    let local = parse(&format!("{SYSTEMS}{}{extra}", plate("6"))).model;
    let basic = parse(&format!("{}{basic_extra}", plate(""))).model;
    let deps: Vec<DofId> = local.mpcs.iter().map(|c| c.dependent).collect();
    assert_eq!(deps.len(), 6);
    assert!(deps.iter().all(|d| d.node == 20));
    let (f, g) = (frequencies(&local, 8), frequencies(&basic, 8));
    assert!(max_rel_diff(&f, &g) < 1e-10, "{f:?} vs {g:?}");
}

/// The derivative of `K` with respect to a thickness, in displacement systems, against a central
/// difference of the assembled `K` (step 1e-6 relative: truncation O(h²) and round-off
/// ~1e-16/h keep the error near 1e-9 of the largest entry; the test allows 1e-6).
#[test]
fn derivatives_in_displacement_systems_match_finite_differences() {
    let deck = format!(
        "{SYSTEMS}{}$femu-parameter {{\"name\":\"t\",\"set\":\"pid1\",\"kind\":\"shell_thickness\",\"lower\":0.001,\"upper\":0.01}}\n",
        plate("7")
    );
    let m = parse(&deck).model;
    let (sys, _) = assemble_model(&m, MassKind::Consistent).unwrap();
    let (dk, dm) =
        parameter_derivative(&m, &m.parameters[0], &sys.dofs, MassKind::Consistent).unwrap();
    let h = 0.004e-6;
    let at = |t: f64| {
        let mut m2 = m.clone();
        m2.shell_properties.get_mut(&1).unwrap().thickness = t;
        assemble_model(&m2, MassKind::Consistent).unwrap().0
    };
    let (plus, minus) = (at(0.004 + h), at(0.004 - h));
    for (d, p, q) in [
        (&dk, plus.k_dense(), minus.k_dense()),
        (&dm, plus.m_dense(), minus.m_dense()),
    ] {
        let d = crate::core::sparse::sparse_to_dense(d);
        let (mut err, mut scale) = (0.0f64, 0.0f64);
        for j in 0..d.ncols() {
            for i in 0..d.nrows() {
                let fd = (p[(i, j)] - q[(i, j)]) / (2.0 * h);
                err = err.max((fd - d[(i, j)]).abs());
                scale = scale.max(d[(i, j)].abs());
            }
        }
        assert!(err < 1e-6 * scale, "{err:e} vs {scale:e}");
    }
}

/// The written deck carries the displacement systems: it reads back to the same model to
/// round-off (a CORD2R is re-derived from three points). The mesh artefact's exact round trip is
/// tested in `artefact::kinds::mesh`.
#[test]
fn displacement_systems_survive_the_written_deck() {
    let m = parse(&format!("{SYSTEMS}{}", plate("7"))).model;
    let text = crate::model::export::nastran::write_bulk(&m);
    let again = parse(&text).model;
    assert_eq!(again.nodes, m.nodes);
    assert_eq!(again.constraints, m.constraints);
    for (g, r) in &m.displacement_systems {
        let s = again.displacement_systems[g];
        assert!(
            r.iter()
                .flatten()
                .zip(s.iter().flatten())
                .all(|(a, b)| (a - b).abs() < 1e-15),
            "{g}"
        );
    }
    let (f, g) = (frequencies(&m, 6), frequencies(&again, 6));
    assert!(max_rel_diff(&f, &g) < 1e-12);
}
