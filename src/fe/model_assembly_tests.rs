//! Tests of the whole-model assembly: NAFEMS FV16 through the sparse path, free and
//! clamped structures, the lower-triangle assembly against the full one, assembled parameter
//! derivatives against central differences, and errors.

use super::*;
use crate::core::sparse::sparse_to_dense;
use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
use crate::model::generate::{
    BentPlate, FlatPlate, PlateSupport, ThreeBeam, bent_plate, flat_plate, three_beam,
};

/// NAFEMS FV16 (cantilevered thin square plate, 10 m, t = 0.05 m, E = 200 GPa, ν = 0.3,
/// ρ = 8000) through the whole chain: generator, sparse assembly, sparse eigensolver.
/// A 24×24 mesh (3750 free DOFs) is within 1 % of every reference frequency.
#[test]
fn fv16_through_the_sparse_path() {
    let model = flat_plate(&FlatPlate {
        a: 10.0,
        b: 10.0,
        nx: 24,
        ny: 24,
        thickness: 0.05,
        material: crate::model::Material {
            e: 200e9,
            nu: 0.3,
            rho: 8000.0,
        },
        support: PlateSupport::ClampedEdge,
    });
    let (sys, info) = assemble_model(&model, MassKind::Consistent).unwrap();
    assert_eq!(info.free_dofs, 6 * 25 * 24);
    sys.validate().unwrap();
    let (modes, einfo) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(6),
        &SparseEigenParams::default(),
    )
    .unwrap();
    assert!(!einfo.dense);
    let reference = [0.421, 1.029, 2.582, 3.306, 3.753, 6.555];
    for (f, r) in modes.frequencies_hz().iter().zip(reference) {
        assert!(((f - r) / r).abs() < 0.01, "{f} vs {r}");
    }
    assert!(
        modes.residuals.iter().all(|r| *r < 1e-8),
        "{:?}",
        modes.residuals
    );
    assert!(modes.orthogonality_error < 1e-10);
}

#[test]
fn free_bent_plate_has_six_rigid_modes_and_conserves_mass() {
    let model = bent_plate(&BentPlate::default());
    let (sys, info) = assemble_model(&model, MassKind::Consistent).unwrap();
    assert_eq!(info.free_dofs, 864);
    sys.validate().unwrap();
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(12),
        &SparseEigenParams::default(),
    )
    .unwrap();
    assert_eq!(modes.rigid_body_modes, 6);
    // Total mass: u_xᵀ M u_x for a unit translation = plates + bar.
    let ux: Vec<f64> = sys
        .dofs
        .iter()
        .map(|d| {
            if d.comp == crate::core::Component::Ux {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    let md = sys.m_dense();
    let total: f64 = (0..ux.len())
        .flat_map(|i| (0..ux.len()).map(move |j| (i, j)))
        .map(|(i, j)| ux[i] * md[(i, j)] * ux[j])
        .sum();
    let bar_len = {
        let (a, b) = (model.nodes[&1], model.nodes[&(15 * 8)]);
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let expected = 7850.0 * (2.0 * 0.3125 * 0.3 * 1.4e-3 + 5.5e-3 * 5.5e-3 * bar_len);
    assert!(
        ((total - expected) / expected).abs() < 1e-12,
        "{total} vs {expected}"
    );
}

/// The lower triangles gathered straight from the scatter are, entry for entry and in the
/// same order, the full assembly's lower triangles: on a clamped plate (constrained DOFs,
/// drilling DOFs auto-constrained), on beams with springs and masses, on scalar points, and
/// on a deck with RBE2 and RBE3 (through the elimination).
#[test]
fn the_lower_assembly_is_the_full_assemblys_lower_triangle() {
    use crate::model::import::nastran::read_bulk;
    let dir = tempfile::tempdir().unwrap();
    let scalar = dir.path().join("scalar.bdf");
    std::fs::write(
        &scalar,
        "SPOINT,1,2\nCELAS4,1,1.+4,1,2\nCELAS4,5,3.+3,2\nCMASS2,2,4.,1\nCMASS2,3,2.,2\nENDDATA\n",
    )
    .unwrap();
    let panel = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/pipelines/decks/stiffened-panel.bdf"
    );
    let models = [
        flat_plate(&FlatPlate {
            a: 1.0,
            b: 0.5,
            nx: 7,
            ny: 5,
            thickness: 0.01,
            material: crate::model::generate::steel(),
            support: PlateSupport::ClampedEdge,
        }),
        three_beam(&ThreeBeam::default()),
        read_bulk(&scalar).unwrap().model,
        read_bulk(panel).unwrap().model,
    ];
    for (which, model) in models.iter().enumerate() {
        for mass in [MassKind::Consistent, MassKind::Lumped] {
            let (full, full_info) = assemble_model(model, mass).unwrap();
            let (lower, lower_info) = assemble_model_lower(model, mass).unwrap();
            assert_eq!(lower, LowerSystem::of(&full), "model {which}, {mass:?}");
            assert_eq!(lower_info.nnz, full_info.nnz, "model {which}");
            assert_eq!(lower_info.total_dofs, full_info.total_dofs);
            assert_eq!(lower_info.auto_constrained, full_info.auto_constrained);
            assert_eq!(lower_info.dependent, full_info.dependent);
        }
    }
    // The deck's rigid elements do eliminate DOFs: the second branch was taken.
    let (_, info) = assemble_model_lower(&models[3], MassKind::Consistent).unwrap();
    assert!(!info.dependent.is_empty());
}

#[test]
fn three_beam_assembles_with_springs_and_masses() {
    let (sys, _) =
        assemble_model(&three_beam(&ThreeBeam::default()), MassKind::Consistent).unwrap();
    assert_eq!(sys.n(), 648);
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::Count(5),
        &SparseEigenParams::default(),
    )
    .unwrap();
    assert_eq!(modes.rigid_body_modes, 0, "clamp springs hold the assembly");
    assert!(modes.frequencies_hz()[0] > 1.0);
}

/// Assembled `∂K/∂t` and `∂M/∂t` of one strip's thickness equal a central difference of the
/// whole assembly (the strip given its own property so only it changes); likewise a beam
/// width and a clamp spring. Tolerance: 1e-6 of the derivative's largest entry (relative
/// step 1e-6, second-order difference on smooth functions of t).
#[test]
fn parameter_derivatives_match_central_differences() {
    use crate::core::Component;
    use crate::model::{Parameter, ParameterKind};
    let mut model = bent_plate(&BentPlate::default());
    let strip = model.sets["strip_3"].clone();
    let mut p2 = model.shell_properties[&1].clone();
    p2.thickness = 1.4e-3;
    model.shell_properties.insert(7, p2);
    for e in &strip {
        if let Some(Element::Quad4 { property, .. }) = model.elements.get_mut(e) {
            *property = 7;
        }
    }
    let (sys, _) = assemble_model(&model, MassKind::Consistent).unwrap();
    type Setter = Box<dyn Fn(&mut Model, f64)>;
    let cases: Vec<(Parameter, Setter, f64)> = vec![
        (
            Parameter {
                name: "t3".into(),
                kind: ParameterKind::ShellThickness,
                set: "strip_3".into(),
                lower: 0.0,
                upper: 1.0,
            },
            Box::new(|m: &mut Model, v: f64| m.shell_properties.get_mut(&7).unwrap().thickness = v),
            1.4e-3,
        ),
        (
            Parameter {
                name: "bar".into(),
                kind: ParameterKind::BeamWidth,
                set: "bar".into(),
                lower: 0.0,
                upper: 1.0,
            },
            // The bar is square: the width parameter moves the width alone, through the
            // same setter the updating uses.
            Box::new(|m: &mut Model, v: f64| {
                let bar = Parameter {
                    name: "bar".into(),
                    kind: ParameterKind::BeamWidth,
                    set: "bar".into(),
                    lower: 0.0,
                    upper: 1.0,
                };
                m.set_parameter_value(&bar, v).unwrap();
            }),
            5.5e-3,
        ),
    ];
    for (param, set, value) in cases {
        let (dk, dm) =
            parameter_derivative(&model, &param, &sys.dofs, MassKind::Consistent).unwrap();
        let h = 1e-6 * value;
        let mut plus = model.clone();
        set(&mut plus, value + h);
        let mut minus = model.clone();
        set(&mut minus, value - h);
        let (sp, _) = assemble_model(&plus, MassKind::Consistent).unwrap();
        let (sm, _) = assemble_model(&minus, MassKind::Consistent).unwrap();
        for (analytic, fp, fm) in [
            (sparse_to_dense(&dk), sp.k_dense(), sm.k_dense()),
            (sparse_to_dense(&dm), sp.m_dense(), sm.m_dense()),
        ] {
            let scale = crate::core::dense::max_abs(analytic.as_ref());
            assert!(scale > 0.0, "{}: zero derivative", param.name);
            let mut worst = 0.0f64;
            for i in 0..analytic.nrows() {
                for j in 0..analytic.ncols() {
                    worst =
                        worst.max((analytic[(i, j)] - (fp[(i, j)] - fm[(i, j)]) / (2.0 * h)).abs());
                }
            }
            assert!(
                worst <= 1e-6 * scale,
                "{}: {worst:e} vs scale {scale:e}",
                param.name
            );
        }
    }
    // A clamp spring of the three-beam assembly: K is linear in k, so dK = (K(k+1) − K(k)).
    let beams = three_beam(&ThreeBeam::default());
    let (bsys, _) = assemble_model(&beams, MassKind::Consistent).unwrap();
    let param = Parameter {
        name: "ky".into(),
        kind: ParameterKind::SpringStiffness(Component::Uy),
        set: "clamp_1".into(),
        lower: 0.0,
        upper: 1e9,
    };
    let (dk, dm) = parameter_derivative(&beams, &param, &bsys.dofs, MassKind::Consistent).unwrap();
    assert_eq!(dm.compute_nnz(), 0);
    let d = sparse_to_dense(&dk);
    let ix = bsys.dof_index();
    let at = ix[&crate::core::DofId::new(1000, Component::Uy)];
    assert_eq!(d[(at, at)], 1.0);
    assert_eq!(crate::core::dense::max_abs(d.as_ref()), 1.0);
    // A parameter on elements it cannot act on is named.
    let wrong = Parameter {
        name: "t".into(),
        kind: ParameterKind::ShellThickness,
        set: "clamp_1".into(),
        lower: 0.0,
        upper: 1.0,
    };
    let e = parameter_derivative(&beams, &wrong, &bsys.dofs, MassKind::Consistent)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("element 9001 (bush)") && e.contains("`t`"),
        "{e}"
    );
}

#[test]
fn a_bad_element_is_named() {
    let mut model = flat_plate(&FlatPlate {
        a: 1.0,
        b: 1.0,
        nx: 2,
        ny: 2,
        thickness: 0.01,
        material: crate::model::generate::steel(),
        support: PlateSupport::Free,
    });
    model.nodes.insert(5, model.nodes[&1]);
    let e = assemble_model(&model, MassKind::Consistent)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("element 1 (quad4)") || e.contains("element"),
        "{e}"
    );
}
