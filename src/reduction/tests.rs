//! The reduction methods against the full model: C3 (the two-plate assembly, thesis §3.6),
//! complete-basis exactness, derivatives, expansion, re-analysis and Appendix A.

use super::force_coupling::MasterSelection;
use super::free_interface::{choose_held_dofs, elastic_flexibility, free_modes};
use super::reduced::Coupling;
use super::*;
use crate::eigen::{ModeSelection, Modes, SparseEigenParams, dense_generalized};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::assemble_model;
use crate::model::generate::{BentPlate, bent_plate};
use crate::model::{Element, Model, Parameter, ParameterKind};
use faer::Mat;

const MASS: MassKind = MassKind::Consistent;

fn c3() -> Model {
    bent_plate(&BentPlate {
        with_bar: false,
        ..Default::default()
    })
}

/// C3 with 30 mm plates: `λ_max/λ_1` about 1e5 instead of 1e9, so quantities formed as small
/// differences of flexibilities (the residual flexibility of a nearly complete basis) keep
/// enough digits to test exactness.
fn thick_c3() -> Model {
    bent_plate(&BentPlate {
        with_bar: false,
        thickness: 0.03,
        ..Default::default()
    })
}

fn two_plates(model: &Model) -> Partition {
    Partition::from_sets(model, &["plate_1".into(), "plate_2".into()], MASS).unwrap()
}

fn full_modes(model: &Model) -> (Vec<crate::core::DofId>, Modes) {
    let (sys, _) = assemble_model(model, MASS).unwrap();
    let modes = dense_generalized(
        sys.k_dense().as_ref(),
        sys.m_dense().as_ref(),
        &sys.dofs,
        ModeSelection::All,
    )
    .unwrap();
    (sys.dofs, modes)
}

/// Relative eigenvalue error (3.54) of the elastic modes below `f_hz`; rigid-body modes
/// (λ = 0 in both) are skipped. Returns (worst error, elastic modes compared).
fn eigen_error(full: &Modes, reduced: &Modes, f_hz: f64) -> (f64, usize) {
    let limit = (2.0 * std::f64::consts::PI * f_hz).powi(2);
    let mut worst = 0.0f64;
    let mut count = 0;
    for (r, lf) in full.eigenvalues.iter().enumerate() {
        if *lf == 0.0 || *lf > limit {
            continue;
        }
        let lc = reduced.eigenvalues[r];
        worst = worst.max((lc - lf).abs() / lf);
        count += 1;
    }
    (worst, count)
}

fn fc_method(modes: ModeSelection) -> Method {
    Method::ForceCoupling {
        modes,
        masters: MasterSelection::default(),
        second_level: None,
    }
}

/// With a complete component basis Craig-Bampton is a change of basis (`T` square and
/// invertible), so the reduced eigenvalues equal the full model's. Tolerance 1e-7 relative on
/// the 40 lowest elastic modes (measured 1.6e-11): both sides are dense shift-invert solutions
/// accurate to ~1e-12 of themselves, plus round-off amplified by the condition of `T`.
///
/// Force coupling has no such limit: its masters are internal DOFs only, so `Φ_m` cannot have
/// full column rank with every mode kept, and the junction is condensed through the static
/// residual flexibility, a frequency-independent relation; its reduced model has
/// `Σ n_m < N` coordinates. It is checked for convergence with the cut-off instead
/// (`free_interface_methods_converge_with_the_cut_off`).
#[test]
fn complete_craig_bampton_reproduces_the_full_model() {
    complete_reduction_reproduces_the_full_model(Method::CraigBampton {
        modes: ModeSelection::All,
    });
}

/// MacNeal's free interface with every free mode kept: the residual flexibility vanishes, the
/// junction displacements replace `n_j` carrier modes, `T` is square, and the reduced model
/// reproduces the full one like Craig-Bampton's (same tolerance and reason; measured 7e-11).
/// Keeping all but `n_j` modes instead would need `R_jj` invertible, and on these shells the
/// highest free modes barely move the bend line, so it is singular to working precision.
#[test]
fn complete_free_interface_reproduces_the_full_model() {
    complete_reduction_reproduces_the_full_model(Method::FreeInterface {
        modes: ModeSelection::All,
    });
}

fn complete_reduction_reproduces_the_full_model(method: Method) {
    let model = c3();
    let p = two_plates(&model);
    let (_, full) = full_modes(&model);
    let r = reduce(&model, &p, &method, MASS).unwrap();
    assert_eq!(r.n(), full.len(), "square T");
    let red = r.modes(ModeSelection::All).unwrap();
    assert_eq!(red.rigid_body_modes, 6);
    let mut worst = 0.0f64;
    for k in 6..46 {
        worst = worst.max((red.eigenvalues[k] - full.eigenvalues[k]).abs() / full.eigenvalues[k]);
    }
    assert!(
        worst < 1e-7,
        "{}: worst relative error {worst:e}",
        method.name()
    );
}

/// C3 (thesis §3.6, fig. 3.3): component modes to 200 Hz, every method's eigenvalue error
/// (3.54) below 1 % for the elastic modes below 100 Hz (the thesis's validity band). The
/// classical methods are Rayleigh–Ritz models, so their errors are also non-negative.
#[test]
fn c3_all_methods_within_one_percent_below_100_hz() {
    let model = c3();
    let p = two_plates(&model);
    let (_, full) = full_modes(&model);
    let cut = ModeSelection::BelowHz(200.0);
    for method in [
        Method::CraigBampton { modes: cut },
        Method::FreeInterface { modes: cut },
        fc_method(cut),
    ] {
        let r = reduce(&model, &p, &method, MASS).unwrap();
        let red = r.modes(ModeSelection::All).unwrap();
        let (worst, count) = eigen_error(&full, &red, 100.0);
        assert!(count >= 5, "{}: {count} modes in band", method.name());
        assert!(
            worst < 0.01,
            "{}: eigenvalue error {worst:e} (size {:?})",
            method.name(),
            r.size()
        );
        if !matches!(method, Method::ForceCoupling { .. }) {
            for k in 6..6 + count {
                assert!(red.eigenvalues[k] >= full.eigenvalues[k] * (1.0 - 1e-9));
            }
        }
    }
}

/// The free-interface methods converge as the component cut-off rises (MacNeal's exact limit is
/// `complete_free_interface_reproduces_the_full_model`; force coupling has none): the
/// worst error below 100 Hz with modes to 800 Hz is below a tenth of that with modes to 200 Hz
/// (measured: MacNeal 2.1e-4 → 5.2e-8, force coupling 2.5e-4 → 4.3e-7).
#[test]
fn free_interface_methods_converge_with_the_cut_off() {
    let model = c3();
    let p = two_plates(&model);
    let (_, full) = full_modes(&model);
    let err = |m: Method| {
        let r = reduce(&model, &p, &m, MASS).unwrap();
        eigen_error(&full, &r.modes(ModeSelection::All).unwrap(), 100.0).0
    };
    let fi = |f: f64| Method::FreeInterface {
        modes: ModeSelection::BelowHz(f),
    };
    let (a, b) = (err(fi(200.0)), err(fi(800.0)));
    assert!(b < 0.1 * a, "free interface: 200 Hz {a:e}, 800 Hz {b:e}");
    let fc = |f: f64| fc_method(ModeSelection::BelowHz(f));
    let (a, b) = (err(fc(200.0)), err(fc(800.0)));
    assert!(b < 0.1 * a, "force coupling: 200 Hz {a:e}, 800 Hz {b:e}");
}

/// Second-level condensation (3.53) keeps the required DOF and the number asked, and the
/// lowest elastic modes stay within 1 % (the kept masters resolve the modes used).
#[test]
fn second_level_condensation_keeps_the_band() {
    let model = c3();
    let p = two_plates(&model);
    let (_, full) = full_modes(&model);
    let measured: crate::core::DofId = "1:uz".parse().unwrap();
    let method = Method::ForceCoupling {
        modes: ModeSelection::BelowHz(200.0),
        masters: MasterSelection {
            required: vec![measured],
            ..Default::default()
        },
        second_level: Some(SecondLevel {
            keep: 16,
            modes: 16,
            required: vec![measured],
        }),
    };
    let r = reduce(&model, &p, &method, MASS).unwrap();
    assert_eq!(r.n(), 16);
    assert!(r.coords.contains(&Coordinate::Dof(measured)));
    let (worst, _) = eigen_error(&full, &r.modes(ModeSelection::All).unwrap(), 60.0);
    assert!(worst < 0.01, "{worst:e}");
}

/// A thickness parameter on elements of both plates (strips 7 and 8, given their own property):
/// the reduced derivative `Σ T_kᵀ ∂K_k/∂t T_k` equals the central difference of
/// `Σ T_kᵀ K_k(t) T_k` with the transformations held fixed (3.59). Tolerance 1e-6 of the largest
/// entry: relative step 1e-6, second-order difference, as for the assembled derivatives.
#[test]
fn reduced_derivative_matches_finite_difference() {
    let mut model = c3();
    let mut ids = model.sets["strip_7"].clone();
    ids.extend(model.sets["strip_8"].iter().copied());
    let mut prop = model.shell_properties[&1].clone();
    prop.thickness = 1.4e-3;
    model.shell_properties.insert(9, prop);
    for e in &ids {
        if let Some(Element::Quad4 { property, .. }) = model.elements.get_mut(e) {
            *property = 9;
        }
    }
    model.sets.insert("joint".into(), ids);
    let param = Parameter {
        name: "t_joint".into(),
        kind: ParameterKind::ShellThickness,
        set: "joint".into(),
        lower: 0.0,
        upper: 1.0,
    };
    let p = two_plates(&model);
    let r = reduce(
        &model,
        &p,
        &Method::CraigBampton {
            modes: ModeSelection::BelowHz(200.0),
        },
        MASS,
    )
    .unwrap();
    let (dk, dm) = reduced_parameter_derivative(&model, &p, &r, &param, MASS).unwrap();
    let t = 1.4e-3;
    let h = 1e-6 * t;
    let reduced_at = |value: f64| {
        let mut m2 = model.clone();
        m2.shell_properties.get_mut(&9).unwrap().thickness = value;
        let n = r.n();
        let (mut k, mut m) = (Mat::zeros(n, n), Mat::zeros(n, n));
        for (i, sub) in p.substructures.iter().enumerate() {
            let sys = substructure_matrices(&m2, sub, MASS).unwrap();
            k += r.project_component(i, &sys.k);
            m += r.project_component(i, &sys.m);
        }
        (k, m)
    };
    let (kp, mp) = reduced_at(t + h);
    let (km, mm) = reduced_at(t - h);
    for (analytic, plus, minus, what) in [(&dk, &kp, &km, "K"), (&dm, &mp, &mm, "M")] {
        let scale = crate::core::dense::max_abs(analytic.as_ref());
        assert!(scale > 0.0);
        let fd = (plus - minus) * faer::Scale(1.0 / (2.0 * h));
        let worst = linalg::max_diff(analytic.as_ref(), fd.as_ref());
        assert!(worst <= 1e-6 * scale, "{what}: {worst:e} vs {scale:e}");
    }
}

/// Reduced modes expanded to every physical DOF match the full model's modes in band
/// (MAC > 0.99 below 100 Hz, every method), and come out mass-normalised in the full `M`
/// (`ΦᵀMΦ = I` to 1e-9: `M_c = Tᵀ M T` exactly up to round-off).
#[test]
fn expanded_modes_match_the_full_model() {
    let model = c3();
    let p = two_plates(&model);
    let (sys, _) = assemble_model(&model, MASS).unwrap();
    let (dofs, full) = full_modes(&model);
    let limit = (2.0 * std::f64::consts::PI * 100.0f64).powi(2);
    let cut = ModeSelection::BelowHz(200.0);
    for method in [
        Method::CraigBampton { modes: cut },
        Method::FreeInterface { modes: cut },
        fc_method(cut),
    ] {
        let r = reduce(&model, &p, &method, MASS).unwrap();
        let red = r.modes(ModeSelection::Count(20)).unwrap();
        let (edofs, expanded) = r.expand_modes(&red).unwrap();
        assert_eq!(edofs, dofs);
        let mphi = crate::reduction::linalg::sparse_times_dense(&sys.m, expanded.shapes.as_ref());
        let gram = expanded.shapes.transpose() * &mphi;
        let ortho = linalg::max_diff(gram.as_ref(), Mat::<f64>::identity(20, 20).as_ref());
        assert!(ortho < 1e-9, "{}: {ortho:e}", method.name());
        for k in 6..20 {
            if full.eigenvalues[k] > limit {
                break;
            }
            let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
            for i in 0..dofs.len() {
                let (a, b) = (full.shapes[(i, k)], expanded.shapes[(i, k)]);
                ab += a * b;
                aa += a * a;
                bb += b * b;
            }
            let mac = ab * ab / (aa * bb);
            assert!(mac > 0.99, "{} mode {}: MAC {mac}", method.name(), k + 1);
        }
    }
}

/// Re-analysing only the changed substructure and coupling again gives the same reduced model
/// as reducing everything from scratch (bitwise: same inputs, same fixed-order arithmetic);
/// the unchanged component is reused untouched.
#[test]
fn replacing_one_component_equals_a_full_reduction() {
    let model = c3();
    let p = two_plates(&model);
    for method in [
        Method::CraigBampton {
            modes: ModeSelection::BelowHz(200.0),
        },
        fc_method(ModeSelection::BelowHz(200.0)),
    ] {
        let mut r = reduce(&model, &p, &method, MASS).unwrap();
        let mut changed = model.clone();
        let mut prop = changed.shell_properties[&1].clone();
        prop.thickness = 0.8e-3;
        changed.shell_properties.insert(5, prop);
        for e in &changed.sets["strip_3"].clone() {
            if let Some(Element::Quad4 { property, .. }) = changed.elements.get_mut(e) {
                *property = 5;
            }
        }
        let k = p.index_of("plate_1").unwrap();
        let untouched = r.components[1].clone();
        let comp = reduce_substructure(&changed, &p, k, &method, MASS).unwrap();
        r.replace(comp).unwrap();
        let fresh = reduce(&changed, &p, &method, MASS).unwrap();
        assert_eq!(r.k, fresh.k, "{}", method.name());
        assert_eq!(r.m, fresh.m, "{}", method.name());
        assert_eq!(r.components[1].t, untouched.t);
        assert_ne!(r.k, reduce(&model, &p, &method, MASS).unwrap().k);
    }
}

/// Thesis Appendix A (3.22–3.25: (3.22), (3.23), (3.24), (3.25)): the elastic flexibility
/// `G_e = Pᵀ G P` of a floating substructure (plate 1 alone, free-free, 6 rigid-body modes) does
/// not depend on which DOFs are held temporarily: two disjoint held sets give the same `G_e`, equal
/// to the elastic modal sum `Σ φφᵀ/λ` over every elastic mode. Tolerance 1e-8 of the largest entry
/// between held sets (two Cholesky solves of a shell with λ_max/λ_1 ~ 1e9), 1e-7 against the modal
/// sum (a full dense eigensolution, on the 30 mm plate).
#[test]
fn appendix_a_elastic_flexibility_is_independent_of_the_held_dofs() {
    let model = c3();
    let p = two_plates(&model);
    let sys = substructure_matrices(&model, &p.substructures[0], MASS).unwrap();
    let n = sys.n();
    let all = free_modes(
        "plate_1",
        &sys,
        ModeSelection::All,
        &SparseEigenParams {
            dense_limit: usize::MAX,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(all.rigid_body_modes, 6);
    let phi_r = all.shapes.subcols(0, 6).to_owned();
    let first: Vec<usize> = (0..n / 2).collect();
    let second: Vec<usize> = (n / 2..n).collect();
    let held_a = choose_held_dofs(phi_r.as_ref(), &first);
    let held_b = choose_held_dofs(phi_r.as_ref(), &second);
    assert_eq!(held_a.len(), 6);
    assert!(held_a.iter().all(|h| !held_b.contains(h)));
    let eye = Mat::<f64>::identity(n, n);
    let ga = elastic_flexibility(
        &sys.k,
        &sys.m,
        phi_r.as_ref(),
        &held_a,
        eye.as_ref(),
        faer::Par::rayon(0),
    )
    .unwrap();
    let gb = elastic_flexibility(
        &sys.k,
        &sys.m,
        phi_r.as_ref(),
        &held_b,
        eye.as_ref(),
        faer::Par::rayon(0),
    )
    .unwrap();
    let scale = crate::core::dense::max_abs(ga.as_ref());
    let d = linalg::max_diff(ga.as_ref(), gb.as_ref());
    assert!(d < 1e-8 * scale, "held sets disagree: {d:e} of {scale:e}");
    // The modal sum of a 1.4 mm shell loses ~1e-5 to the round-off of its stiff modes;
    // compare it on the 30 mm plate, where the dense eigensolution is accurate to ~1e-10.
    let thick = thick_c3();
    let pt = two_plates(&thick);
    let st = substructure_matrices(&thick, &pt.substructures[0], MASS).unwrap();
    let all_t = free_modes(
        "plate_1",
        &st,
        ModeSelection::All,
        &SparseEigenParams {
            dense_limit: usize::MAX,
            ..Default::default()
        },
    )
    .unwrap();
    let phi_t = all_t.shapes.subcols(0, 6).to_owned();
    let held_t = choose_held_dofs(phi_t.as_ref(), &(0..n).collect::<Vec<_>>());
    let gt = elastic_flexibility(
        &st.k,
        &st.m,
        phi_t.as_ref(),
        &held_t,
        eye.as_ref(),
        faer::Par::rayon(0),
    )
    .unwrap();
    let modal = Mat::from_fn(n, n, |i, j| {
        (6..all_t.len())
            .map(|r| all_t.shapes[(i, r)] * all_t.shapes[(j, r)] / all_t.eigenvalues[r])
            .sum::<f64>()
    });
    let scale_t = crate::core::dense::max_abs(gt.as_ref());
    let d = linalg::max_diff(gt.as_ref(), modal.as_ref());
    assert!(d < 1e-7 * scale_t, "G_e vs modal sum: {d:e} of {scale_t:e}");
    // Without the projector the two held sets give different flexibilities.
    let none = Mat::<f64>::zeros(n, 0);
    let raw_a = elastic_flexibility(
        &sys.k,
        &sys.m,
        none.as_ref(),
        &held_a,
        eye.as_ref(),
        faer::Par::rayon(0),
    )
    .unwrap();
    let raw_b = elastic_flexibility(
        &sys.k,
        &sys.m,
        none.as_ref(),
        &held_b,
        eye.as_ref(),
        faer::Par::rayon(0),
    )
    .unwrap();
    assert!(linalg::max_diff(raw_a.as_ref(), raw_b.as_ref()) > 1e-3 * scale);
}

/// Same inputs, same reduced model bit for bit (parallel over substructures, fixed order).
#[test]
fn reduction_is_deterministic() {
    let model = c3();
    let p = Partition::automatic(&model, 3, MASS).unwrap();
    let m = Method::CraigBampton {
        modes: ModeSelection::BelowHz(300.0),
    };
    let a = reduce(&model, &p, &m, MASS).unwrap();
    let b = reduce(&model, &p, &m, MASS).unwrap();
    assert_eq!(a.k, b.k);
    assert_eq!(a.m, b.m);
    assert_eq!(a.coords, b.coords);
    for k in 0..a.components.len() {
        assert_eq!(a.transformation(k), b.transformation(k));
    }
}

/// Bad requests are named: an unknown master DOF, a substructure that is not restrained.
#[test]
fn bad_requests_are_named() {
    let model = c3();
    let p = two_plates(&model);
    let bad = Method::ForceCoupling {
        modes: ModeSelection::BelowHz(200.0),
        masters: MasterSelection {
            required: vec!["99999:uz".parse().unwrap()],
            ..Default::default()
        },
        second_level: None,
    };
    let e = reduce(&model, &p, &bad, MASS).unwrap_err().to_string();
    assert!(e.contains("99999:uz"), "{e}");
    // One substructure only: no junction, free-free: Craig-Bampton is plain modal truncation.
    let one = Partition::from_groups(
        &model,
        vec![("all".into(), model.elements.keys().copied().collect())],
        MASS,
    )
    .unwrap();
    let r = reduce(
        &model,
        &one,
        &Method::CraigBampton {
            modes: ModeSelection::Count(10),
        },
        MASS,
    )
    .unwrap();
    assert_eq!(r.size(), (0, 10));
    let e = r
        .expand(Mat::<f64>::zeros(3, 1).as_ref(), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("3 rows") && e.contains("10 coordinates"), "{e}");
}

/// Interface reduction on C3 (Craig-Bampton, component modes to 200 Hz): with every interface
/// mode kept it is a change of basis (eigenvalues equal the plain model's to 1e-9 relative);
/// with the 12 lowest the model shrinks and the band below 100 Hz stays within 1 % of the full
/// model, its expanded modes mass-orthonormal; a replaced component keeps the basis and gives
/// what coupling from scratch with that basis gives.
#[test]
fn interface_modes_reduce_the_junction() {
    let model = c3();
    let p = two_plates(&model);
    let (_, full) = full_modes(&model);
    let method = Method::CraigBampton {
        modes: ModeSelection::BelowHz(200.0),
    };
    let plain = reduce(&model, &p, &method, MASS).unwrap();
    let nj = plain.junction.len();
    let plain_modes = plain.modes(ModeSelection::Count(20)).unwrap();
    let all = plain
        .clone()
        .with_interface_modes(ModeSelection::All)
        .unwrap();
    assert_eq!(all.n(), plain.n());
    let all_modes = all.modes(ModeSelection::Count(20)).unwrap();
    for k in 6..20 {
        let e = (all_modes.eigenvalues[k] / plain_modes.eigenvalues[k] - 1.0).abs();
        assert!(e < 1e-9, "mode {}: {e:e}", k + 1);
    }
    let few = plain
        .clone()
        .with_interface_modes(ModeSelection::Count(12))
        .unwrap();
    assert_eq!(few.n(), plain.n() - nj + 12);
    let red = few.modes(ModeSelection::All).unwrap();
    let (worst, count) = eigen_error(&full, &red, 100.0);
    assert!(count >= 5 && worst < 0.01, "{worst:e} over {count} modes");
    let (sys, _) = assemble_model(&model, MASS).unwrap();
    let lowest = few.modes(ModeSelection::Count(12)).unwrap();
    let (_, expanded) = few.expand_modes(&lowest).unwrap();
    let mphi = linalg::sparse_times_dense(&sys.m, expanded.shapes.as_ref());
    let gram = expanded.shapes.transpose() * &mphi;
    let ortho = linalg::max_diff(gram.as_ref(), Mat::<f64>::identity(12, 12).as_ref());
    assert!(ortho < 1e-9, "{ortho:e}");

    let mut replaced = few.clone();
    let k = p.index_of("plate_2").unwrap();
    let mut changed = model.clone();
    for prop in changed.shell_properties.values_mut() {
        prop.thickness *= 1.1;
    }
    let comp = reduce_substructure(&changed, &p, k, &method, MASS).unwrap();
    replaced.replace(comp.clone()).unwrap();
    let mut comps = few.components.clone();
    comps[k] = comp;
    let fresh = ReducedModel::synthesise_with_interface(
        method.clone(),
        few.junction.clone(),
        comps,
        few.interface.clone(),
    )
    .unwrap();
    assert_eq!(replaced.k, fresh.k);
    assert_eq!(replaced.interface, few.interface);
}

/// The memory-lean interface reduction against the coupled one on C3: each substructure's
/// junction condensation equals the junction block of its Craig-Bampton `TᵀKT`, `TᵀMT`
/// (two independent routes: `n_j` solves with `Ψ` held, and blocked solves with `Ψᵀ Y` by a
/// second solve; 1e-9 of the block's largest entry, the round-off of `K_ii⁻¹` at
/// `λ_max/λ_1 ≈ 1e9`); components reduced on the interface modes alone give the reduced
/// matrices that the junction-sized components coupled through the same basis give; and a
/// replaced component keeps the basis.
#[test]
fn lean_interface_reduction_equals_the_coupled_one() {
    let model = c3();
    let p = two_plates(&model);
    let method = Method::CraigBampton {
        modes: ModeSelection::BelowHz(200.0),
    };
    let plain = reduce(&model, &p, &method, MASS).unwrap();
    let relative = |a: &Mat<f64>, b: &Mat<f64>| {
        let scale = (0..b.ncols())
            .flat_map(|j| (0..b.nrows()).map(move |i| (i, j)))
            .fold(0.0f64, |s, (i, j)| s.max(b[(i, j)].abs()));
        linalg::max_diff(a.as_ref(), b.as_ref()) / scale
    };
    let mut condensations = Vec::new();
    for (k, sub) in p.substructures.iter().enumerate() {
        let sys = substructure_matrices(&model, sub, MASS).unwrap();
        let c = craig_bampton::junction_condensation(&sub.name, &sys, &sub.junction).unwrap();
        let comp = &plain.components[k];
        let nj = sub.junction.len();
        assert!(
            comp.coords[..nj]
                .iter()
                .zip(&sub.junction)
                .all(|(c, d)| *c == Coordinate::Dof(*d))
        );
        let block = |a: &Mat<f64>| Mat::from_fn(nj, nj, |i, j| a[(i, j)]);
        let (ek, em) = (
            relative(&c.k, &block(&comp.k)),
            relative(&c.m, &block(&comp.m)),
        );
        assert!(ek < 1e-9 && em < 1e-9, "{}: K {ek:e}, M {em:e}", sub.name);
        condensations.push(c);
    }
    let selection = ModeSelection::Count(12);
    let coupled = plain.clone().with_interface_modes(selection).unwrap();
    let psi = coupled.interface.clone().unwrap();
    let from_condensations =
        interface_basis_from_condensations(&p.junction, condensations, selection)
            .unwrap()
            .unwrap();
    // The same elastic interface modes up to sign (the six rigid-body ones of the free-free
    // assembly are any basis of their subspace).
    for q in 6..12 {
        let dot: f64 = (0..psi.nrows())
            .map(|i| psi[(i, q)] * from_condensations[(i, q)])
            .sum();
        let norm: f64 = (0..psi.nrows()).map(|i| psi[(i, q)].powi(2)).sum();
        assert!(
            (dot.abs() / norm - 1.0).abs() < 1e-8,
            "interface mode {}",
            q + 1
        );
    }
    let lean_components: Vec<ComponentReduction> = (0..p.substructures.len())
        .map(|k| reduce_substructure_on_interface(&model, &p, k, &method, MASS, psi.as_ref()))
        .collect::<Result<_, _>>()
        .unwrap();
    for (c, plain_c) in lean_components.iter().zip(&plain.components) {
        assert_eq!(c.t.ncols(), 12 + plain_c.mode_frequencies_hz.len());
    }
    let lean = ReducedModel::synthesise_with_interface(
        method.clone(),
        p.junction.clone(),
        lean_components,
        Some(psi.clone()),
    )
    .unwrap();
    assert!(
        lean.couplings
            .iter()
            .all(|c| matches!(c, Coupling::Boolean(_)))
    );
    assert_eq!(lean.coords, coupled.coords);
    let (ek, em) = (relative(&lean.k, &coupled.k), relative(&lean.m, &coupled.m));
    assert!(ek < 1e-9 && em < 1e-9, "K {ek:e}, M {em:e}");
    // The whole-model entry point takes the lean route and finds the same model.
    let direct = reduce_with_interface(&model, &p, &method, MASS, Some(selection)).unwrap();
    let (a, b) = (
        direct.modes(ModeSelection::Count(20)).unwrap(),
        coupled.modes(ModeSelection::Count(20)).unwrap(),
    );
    for k in 6..20 {
        let e = (a.eigenvalues[k] / b.eigenvalues[k] - 1.0).abs();
        assert!(e < 1e-9, "mode {}: {e:e}", k + 1);
    }
    // Re-analysis of one substructure on the held basis.
    let k = p.index_of("plate_2").unwrap();
    let mut changed = model.clone();
    for prop in changed.shell_properties.values_mut() {
        prop.thickness *= 1.1;
    }
    let mut replaced = lean.clone();
    let comp =
        reduce_substructure_on_interface(&changed, &p, k, &method, MASS, psi.as_ref()).unwrap();
    replaced.replace(comp).unwrap();
    let mut reference = coupled.clone();
    reference
        .replace(reduce_substructure(&changed, &p, k, &method, MASS).unwrap())
        .unwrap();
    let (ek, em) = (
        relative(&replaced.k, &reference.k),
        relative(&replaced.m, &reference.m),
    );
    assert!(ek < 1e-9 && em < 1e-9, "replaced: K {ek:e}, M {em:e}");
}
