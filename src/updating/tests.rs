//! The updating methods on the four-DOF chain of C1 (thesis §2.5.3): truth all masses 1 kg,
//! analytical model `m2 = 1.3 kg`, five springs `1e4 N/m`, the four masses as parameters.

use super::damping::{
    DampingIdentification, DampingKind, DampingParameters, DampingSettings, equivalent_loss_factor,
};
use super::eigensensitivity::{EigenSettings, InverseEigensensitivity, MeasuredModes};
use super::pc::{PcSettings, PredictorCorrector};
use super::rfm::{ResponseFunctionMethod, RfmSettings};
use super::*;
use crate::eigen::{ModeSelection, dense_generalized};
use crate::fe::lumped::{LumpedTarget, assemble_lumped, lumped_derivative};
use crate::frf::{
    DirectDamping, FrfSet, ModalDamping, Quantity, direct_receptance, frequency_lines,
};
use crate::model::LumpedModel;

fn chain_model(masses: &[f64]) -> LinearModel {
    let lumped = LumpedModel::chain(masses, 1e4);
    let sys = assemble_lumped(&lumped).unwrap();
    let params = (0..masses.len())
        .map(|i| {
            let (dk, dm) = lumped_derivative(&lumped, LumpedTarget::Mass(i)).unwrap();
            (
                UpdatingParameter {
                    name: format!("m{}", i + 1),
                    initial: masses[i],
                    lower: 0.01,
                    upper: 100.0,
                },
                dk,
                dm,
            )
        })
        .collect();
    LinearModel::new(sys, params).unwrap()
}

fn measured(eta: f64, freqs: &[f64]) -> FrfSet {
    let sys = assemble_lumped(&LumpedModel::chain(&[1.0; 4], 1e4)).unwrap();
    let pairs = FrfSet::all_pairs(&sys.dofs, &sys.dofs[..1]);
    direct_receptance(
        &sys,
        &DirectDamping {
            structural_eta: eta,
            rayleigh: None,
        },
        &pairs,
        freqs,
        Quantity::Receptance,
    )
    .unwrap()
}

/// The clamped bent plate without its bar, thickness parameters on strips 1, 4 and 9: the
/// model of the FRF sensitivity checks.
pub(super) fn clamped_plate_three_strips() -> crate::model::Model {
    bent_plate_with_strip_thicknesses(
        crate::model::generate::BentPlate {
            clamped: true,
            with_bar: false,
            ..Default::default()
        },
        &[1, 4, 9],
    )
}

/// Its three measured DOFs, uz at the free corner (the excitation) and two more.
pub(super) fn three_measured_dofs() -> Vec<crate::core::DofId> {
    ["113:uz", "56:uz", "110:uz"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect()
}

/// The C2 bent plate of `geometry` with the thicknesses of `strips` as parameters (bounds
/// 0.1–10 mm), named `t<strip>`.
fn bent_plate_with_strip_thicknesses(
    geometry: crate::model::generate::BentPlate,
    strips: &[usize],
) -> crate::model::Model {
    use crate::model::{Parameter, ParameterKind};
    let mut model = crate::model::generate::bent_plate(&geometry);
    for s in strips {
        model.parameters.push(Parameter {
            name: format!("t{s}"),
            kind: ParameterKind::ShellThickness,
            set: format!("strip_{s}"),
            lower: 1e-4,
            upper: 1e-2,
        });
    }
    model
}

/// C1: with complete noise-free data the RFM recovers all four masses at any non-resonant
/// line — the equation is exact for parameters that enter linearly, so the first step lands
/// on the truth and the second confirms it. Tolerance 1e-8 (issue 5).
#[test]
fn rfm_recovers_the_masses_from_complete_data_at_any_line() {
    let freqs = frequency_lines(0.0, 40.0, 0.5);
    let data = measured(0.0, &freqs);
    for line in [5.0, 9.0, 18.0, 25.0, 33.5] {
        let method = ResponseFunctionMethod {
            measured: &data,
            settings: RfmSettings {
                lines_hz: vec![line],
                ..Default::default()
            },
        };
        let h = run(&method, &chain_model(&[1.0, 1.3, 1.0, 1.0]), 10).unwrap();
        for (i, v) in h.final_values.iter().enumerate() {
            assert!((v - 1.0).abs() < 1e-8, "line {line} Hz: m{} = {v}", i + 1);
        }
        assert_eq!(h.stop, StopReason::Converged, "line {line}");
        assert!(
            h.iterations.len() <= 4,
            "line {line}: {}",
            h.iterations.len()
        );
    }
}

/// The C1 chain measured through sensors that combine several masses' motions (an
/// interpolated, a flipped and a skewed sensor): `H_t = W H W_eᵀ` (14.7) from the true chain,
/// excitation through the first (a combination too), at `lines`.
fn measured_through_sensors(
    sensors: &[(crate::core::DofId, Vec<(crate::core::DofId, f64)>)],
    responses: usize,
    freqs: &[f64],
) -> FrfSet {
    use crate::frf::FrfPair;
    let sys = assemble_lumped(&LumpedModel::chain(&[1.0; 4], 1e4)).unwrap();
    let all = FrfSet::all_pairs(&sys.dofs, &sys.dofs);
    let truth = direct_receptance(
        &sys,
        &DirectDamping::default(),
        &all,
        freqs,
        Quantity::Receptance,
    )
    .unwrap();
    let (exc, we) = &sensors[0];
    let pairs: Vec<FrfPair> = sensors[..responses]
        .iter()
        .map(|(t, _)| FrfPair {
            response: *t,
            excitation: *exc,
        })
        .collect();
    let values = faer::Mat::from_fn(freqs.len(), responses, |k, q| {
        let mut v = faer::c64::new(0.0, 0.0);
        for (a, wa) in &sensors[q].1 {
            for (b, wb) in we {
                let p = truth
                    .pair_index(&FrfPair {
                        response: *a,
                        excitation: *b,
                    })
                    .unwrap();
                v += truth.values[(k, p)] * (wa * wb);
            }
        }
        v
    });
    FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: freqs.to_vec(),
        values,
        pairs,
    }
}

/// Through sensors that combine several model DOFs the RFM puts the measured values into the
/// analytical column as its least change (14.11) and recovers the masses: from four
/// independent sensors (complete data: the column is then the true one and, as for the
/// plain RFM, the first step is exact) to 1e-8 in at most 4 iterations; from three (incomplete
/// data, several lines) by iterating to the truth, to 1e-7.
#[test]
fn rfm_through_multi_term_sensors_recovers_the_masses() {
    use super::model::ThroughMap;
    use crate::core::DofId;
    let chain = assemble_lumped(&LumpedModel::chain(&[1.0; 4], 1e4)).unwrap();
    let x = chain.dofs.clone();
    let t = |n: u64| DofId::new(n, x[0].comp);
    let sensors = vec![
        (t(901), vec![(x[0], 0.6), (x[1], 0.8)]),
        (t(902), vec![(x[1], -1.0)]),
        (t(903), vec![(x[2], 0.5), (x[3], 0.5)]),
        (t(904), vec![(x[3], 1.0), (x[0], -0.3)]),
    ];
    let map = crate::sensitivity::SensorMap::new(sensors.clone());
    let freqs = frequency_lines(0.0, 40.0, 0.5);
    for (responses, lines, tol, max_iter) in [
        (4, vec![9.0], 1e-8, 4),
        (3, vec![5.0, 9.0, 18.0, 25.0, 33.5], 1e-7, 30),
    ] {
        let data = measured_through_sensors(&sensors, responses, &freqs);
        let method = ResponseFunctionMethod {
            measured: &data,
            settings: RfmSettings {
                lines_hz: lines,
                tolerance: 1e-10,
                ..Default::default()
            },
        };
        let model = ThroughMap::new(Box::new(chain_model(&[1.0, 1.3, 1.0, 1.0])), map.clone());
        let h = run(&method, &model, 40).unwrap();
        assert_eq!(h.stop, StopReason::Converged, "{responses} sensors");
        assert!(
            h.iterations.len() <= max_iter,
            "{responses} sensors: {} iterations",
            h.iterations.len()
        );
        for (i, v) in h.final_values.iter().enumerate() {
            assert!(
                (v - 1.0).abs() < tol,
                "{responses} sensors: m{} = {v}",
                i + 1
            );
        }
    }
}

/// The P-C on the same system (η = 0.01 in test and model) converges to the truth. With the
/// thesis's settings (`κ_f = 0.95`, stop at 0.99) it stops within 5 % of it (`1 − χ` is
/// quadratic in the error, so 0.99 tolerates a few per cent); with `κ_f` and the
/// stop figure tightened to 1 − 1e-6 it keeps updating to within 1e-3 (`1 − χ` is
/// quadratic in the error).
#[test]
fn pc_recovers_the_mass_error() {
    let freqs = frequency_lines(0.5, 40.0, 0.1);
    let data = measured(0.01, &freqs);
    let method = PredictorCorrector::new(
        &data,
        PcSettings {
            damping: ModalDamping::Structural(vec![0.01]),
            ..Default::default()
        },
    );
    let h = run(&method, &chain_model(&[1.0, 1.3, 1.0, 1.0]), 15).unwrap();
    // The thesis's rule (mean χ ≥ 0.99) is loose: one doubled step meets it, 5 % off in m4.
    assert_eq!(h.stop, StopReason::Converged, "{:#?}", h.iterations.last());
    assert!(h.iterations.len() <= 3, "{} iterations", h.iterations.len());
    assert!(h.iterations.last().unwrap().mean_chi() >= 0.99);
    for (i, v) in h.final_values.iter().enumerate() {
        assert!((v - 1.0).abs() < 6e-2, "m{} = {v}", i + 1);
    }
    let tight = PredictorCorrector::new(
        &data,
        PcSettings {
            damping: ModalDamping::Structural(vec![0.01]),
            kappa_f: 0.999999,
            stop_chi: 0.999999,
            ..Default::default()
        },
    );
    let h = run(&tight, &chain_model(&[1.0, 1.3, 1.0, 1.0]), 30).unwrap();
    assert_eq!(h.stop, StopReason::Converged, "{:#?}", h.iterations.last());
    assert!(h.iterations.len() <= 8, "{} iterations", h.iterations.len());
    for (i, v) in h.final_values.iter().enumerate() {
        assert!((v - 1.0).abs() < 1e-3, "m{} = {v}", i + 1);
    }
    let first = &h.iterations[0];
    let last = h.iterations.last().unwrap();
    assert!(last.mean_chi() > first.mean_chi());
    assert!(first.lines_used > 0 && first.diagnostics.singular_values.len() == 4);
}

/// Inverse eigensensitivity from the four measured natural frequencies and shapes (MAC
/// pairing): four equations, four unknowns, Newton iterations on an analytic function: the
/// masses to 1e-8. The truth is not mirror-symmetric: for the symmetric chain (all masses
/// equal) the frequencies are stationary under antisymmetric mass changes, the Jacobian is
/// singular at the truth and convergence only linear — the non-uniqueness of §2.6.
#[test]
fn eigensensitivity_recovers_the_masses_from_four_frequencies() {
    let truth_masses = [1.0, 1.1, 0.9, 1.2];
    let truth = assemble_lumped(&LumpedModel::chain(&truth_masses, 1e4)).unwrap();
    let modes = dense_generalized(
        truth.k_dense().as_ref(),
        truth.m_dense().as_ref(),
        &truth.dofs,
        ModeSelection::All,
    )
    .unwrap();
    let measured = MeasuredModes {
        eigenvalues: modes.eigenvalues.clone(),
        shapes: Some((truth.dofs.clone(), modes.shapes.clone())),
    };
    let method = InverseEigensensitivity {
        measured: &measured,
        settings: EigenSettings {
            modes: ModeSelection::All,
            min_mac: 0.5,
            tolerance: 1e-12,
            subset_kappa: None,
            weighting: ParameterWeighting::None,
        },
    };
    let h = run(&method, &chain_model(&[1.0, 1.3, 1.0, 1.0]), 30).unwrap();
    assert_eq!(h.stop, StopReason::Converged);
    for (i, v) in h.final_values.iter().enumerate() {
        assert!((v - truth_masses[i]).abs() < 1e-8, "m{} = {v}", i + 1);
    }
    assert!(h.iterations.len() < 12, "{} iterations", h.iterations.len());
}

/// The P-C's rows `∂χ_s/∂φ`, `∂χ_a/∂φ` of an FE model (bent plate, shell thicknesses, unity
/// based) against central differences of `χ` with the model rebuilt and re-analysed. On the
/// complete modal basis the FRF sensitivity is exact, so they agree to the difference's own
/// error (relative step 1e-4: truncation ~1e-8, eigen noise ~1e-11/1e-4) at 1e-5. On the
/// thesis's truncated basis (modes to twice the band) the mode-shape derivatives miss the
/// truncated modes' share — without correction a row can even change sign (seen at 61 Hz) —
/// and the static correction restores them to 10 % of the row's scale: what remains is the
/// `λ_r/λ_s` the static form neglects for the modes just above 200 Hz (up to 1/4 at 100 Hz).
#[test]
fn chi_sensitivities_of_an_fe_model_match_central_differences() {
    use crate::correlation::frf::{amplitude_correlation, shape_correlation};
    use crate::fe::element::MassKind;
    use crate::sensitivity::{ModalFrfModel, chi_sensitivity, frf_sensitivities};
    use faer::c64;
    let model = clamped_plate_three_strips();
    let truth = FeModel::new(model.clone(), &[], MassKind::Consistent).unwrap();
    let mut wrong = model.clone();
    wrong
        .set_parameter_value(&model.parameters[1], 0.8e-3)
        .unwrap();
    let fe = FeModel::new(wrong, &[], MassKind::Consistent).unwrap();
    let values = fe.initial_values();
    let dofs = three_measured_dofs();
    let pairs = FrfSet::all_pairs(&dofs, &dofs[..1]);
    let freqs = [13.0, 37.5, 61.0, 88.0];
    let damping = ModalDamping::Structural(vec![0.01]);
    let measured = {
        let st = ModalState::new(
            &truth.evaluate(&truth.initial_values()).unwrap(),
            &truth.initial_values(),
            ModeSelection::BelowHz(400.0),
        )
        .unwrap();
        crate::frf::modal_receptance(
            &st.modes,
            &st.dofs,
            &damping,
            &pairs,
            &freqs,
            Quantity::Receptance,
        )
        .unwrap()
    };
    let chi_at = |v: &[f64], sel: ModeSelection| -> Vec<(f64, f64)> {
        let st = ModalState::new(&fe.evaluate(v).unwrap(), v, sel).unwrap();
        let h = crate::frf::modal_receptance(
            &st.modes,
            &st.dofs,
            &damping,
            &pairs,
            &freqs,
            Quantity::Receptance,
        )
        .unwrap();
        (0..freqs.len())
            .map(|k| {
                let x: Vec<c64> = (0..3).map(|q| measured.values[(k, q)]).collect();
                let a: Vec<c64> = (0..3).map(|q| h.values[(k, q)]).collect();
                (shape_correlation(&x, &a), amplitude_correlation(&x, &a))
            })
            .collect()
    };
    for (sel, tol) in [
        (ModeSelection::All, 1e-5),
        (ModeSelection::BelowHz(200.0), 0.1),
    ] {
        let st = ModalState::new(&fe.evaluate(&values).unwrap(), &values, sel).unwrap();
        let shapes = st.shapes_at(&dofs).unwrap();
        let modal = ModalFrfModel {
            eigenvalues: &st.modes.eigenvalues,
            shapes: shapes.as_ref(),
            dofs: &dofs,
            damping: &damping,
        };
        let h = crate::frf::modal_receptance(
            &st.modes,
            &st.dofs,
            &damping,
            &pairs,
            &freqs,
            Quantity::Receptance,
        )
        .unwrap();
        // The static correction completes a truncated basis; on the complete one it is zero.
        let corr = (sel != ModeSelection::All).then(|| {
            st.shape_corrections(&fe.evaluate(&values).unwrap(), &values, &dofs)
                .unwrap()
        });
        let sens = frf_sensitivities(
            &modal,
            &pairs,
            &freqs,
            Quantity::Receptance,
            &st.projected,
            corr.as_deref(),
        )
        .unwrap();
        for p in 0..3 {
            let step = 1e-4;
            let mut up = values.clone();
            let mut down = values.clone();
            up[p] *= 1.0 + step;
            down[p] *= 1.0 - step;
            let (cu, cd) = (chi_at(&up, sel), chi_at(&down, sel));
            let rows: Vec<(f64, f64, f64, f64)> = (0..freqs.len())
                .map(|k| {
                    let x: Vec<c64> = (0..3).map(|q| measured.values[(k, q)]).collect();
                    let a: Vec<c64> = (0..3).map(|q| h.values[(k, q)]).collect();
                    let s: Vec<c64> = (0..3).map(|q| sens[p][(k, q)]).collect();
                    let c = chi_sensitivity(&x, &a, &[&s]);
                    let fs = (cu[k].0 - cd[k].0) / (2.0 * step);
                    let fa = (cu[k].1 - cd[k].1) / (2.0 * step);
                    (c.d_chi_s[0], fs, c.d_chi_a[0], fa)
                })
                .collect();
            // Scale: the parameter's largest row over the lines.
            let scale = rows
                .iter()
                .map(|r| r.1.abs().max(r.3.abs()))
                .fold(1e-6, f64::max);
            for (k, (s_an, s_fd, a_an, a_fd)) in rows.iter().enumerate() {
                assert!(
                    (s_an - s_fd).abs() <= tol * scale && (a_an - a_fd).abs() <= tol * scale,
                    "{sel:?} t{p} line {}: chi_s {s_an} vs {s_fd}, chi_a {a_an} vs {a_fd} (scale {scale})",
                    freqs[k]
                );
            }
        }
    }
}

/// The C2 bent plate with strips 6 and 10 as thickness parameters, on a Craig-Bampton model of
/// its two plates and the bar (component modes to 200 Hz).
fn bent_plate_craig_bampton() -> super::ReducedFeModel {
    use crate::fe::element::MassKind;
    use crate::model::generate::BentPlate;
    use crate::reduction::{Method, Partition};
    let model = bent_plate_with_strip_thicknesses(BentPlate::default(), &[6, 10]);
    let names: Vec<String> = ["plate_1", "plate_2", "bar"].map(String::from).to_vec();
    let partition = Partition::from_sets(&model, &names, MassKind::Consistent).unwrap();
    let fe = FeModel::new(model, &[], MassKind::Consistent).unwrap();
    super::ReducedFeModel::new(
        fe,
        partition,
        Method::CraigBampton {
            modes: ModeSelection::BelowHz(200.0),
        },
    )
}

/// Updating through Craig-Bampton (two plates and the bar of C2, component modes to 200 Hz):
/// a parameter change re-reduces only the substructures holding the parameter's elements, and
/// the FRF sensitivities of the reduced model (on its complete modal basis, transformations
/// held, 3.59) agree with central differences of the re-reduced model's FRFs to 10 % of each
/// parameter's largest value below 90 Hz. The difference (8 % seen for a strip of plate 1) is
/// the fixed-interface modes' own dependence on the thickness, which 3.59 drops by design.
#[test]
fn reduced_model_reanalyses_only_changed_substructures() {
    use crate::sensitivity::{ModalFrfModel, frf_sensitivities};
    let reduced = bent_plate_craig_bampton();
    let values = reduced.initial_values();
    let selection = ModeSelection::BelowHz(200.0);
    let (state, physical) = reduced.modal_state(&values, selection).unwrap();
    assert!(physical.is_none());
    assert_eq!(reduced.reductions(), 3);
    // t6 lies in plate 1 only: one reduction more.
    let mut moved = values.clone();
    moved[0] *= 1.01;
    reduced.modal_state(&moved, selection).unwrap();
    assert_eq!(reduced.reductions(), 4);

    let dofs: Vec<crate::core::DofId> = ["120:uz", "56:uz", "1:uz"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
    let pairs = FrfSet::all_pairs(&dofs, &dofs[..1]);
    let freqs: Vec<f64> = (1..=18).map(|k| 5.0 * k as f64 - 2.5).collect();
    let damping = ModalDamping::Structural(vec![0.02]);
    let data = FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: freqs.clone(),
        pairs: pairs.clone(),
        values: faer::Mat::zeros(freqs.len(), pairs.len()),
    };
    let shapes = state.shapes_at(&dofs).unwrap();
    let modal = ModalFrfModel {
        eigenvalues: &state.modes.eigenvalues,
        shapes: shapes.as_ref(),
        dofs: &dofs,
        damping: &damping,
    };
    let sens = frf_sensitivities(
        &modal,
        &pairs,
        &freqs,
        Quantity::Receptance,
        &state.projected,
        None,
    )
    .unwrap();
    for p in 0..2 {
        let h = 1e-4;
        let at = |sign: f64| {
            let mut v = values.clone();
            v[p] *= 1.0 + sign * h;
            let (st, _) = reduced.modal_state(&v, selection).unwrap();
            super::pc::predict(&st, &data, &damping).unwrap().values
        };
        let fd = (at(1.0) - at(-1.0)) * faer::Scale(faer::c64::new(0.5 / h, 0.0));
        let err = (&sens[p] - &fd).norm_max();
        assert!(
            err <= 0.1 * fd.norm_max(),
            "t{p}: {err:e} of {:e}",
            fd.norm_max()
        );
    }
}

/// The trial analysis of a reduced model (candidate steps ranked on the held bases) is the
/// Rayleigh-Ritz analysis of the full model on the last analysis's global transformation:
/// checked against `Tᵀ K T`, `Tᵀ M T` formed from the whole model's matrices at the moved
/// values (the trial projects only the changed substructure and couples; agreement to 1e-9
/// relative, rounding of two different summation orders). Its eigenvalues bound the full
/// model's from above (a Ritz model), and at the last analysis's own values it reproduces
/// that analysis. No reduction is computed for a trial.
#[test]
fn trial_state_is_rayleigh_ritz_on_the_held_bases() {
    let reduced = bent_plate_craig_bampton();
    let selection = ModeSelection::BelowHz(100.0);
    let values = reduced.initial_values();
    assert!(
        reduced
            .trial_modal_state(&values, selection)
            .unwrap()
            .is_none()
    );
    let (state, _) = reduced.modal_state(&values, selection).unwrap();
    let same = reduced
        .trial_modal_state(&values, selection)
        .unwrap()
        .unwrap();
    for (a, b) in same.modes.eigenvalues.iter().zip(&state.modes.eigenvalues) {
        assert!((a - b).abs() <= 1e-10 * b.abs().max(1.0), "{a} vs {b}");
    }

    let mut moved = values.clone();
    moved[0] *= 1.15;
    let trial = reduced
        .trial_modal_state(&moved, selection)
        .unwrap()
        .unwrap();
    assert!(trial.projected.is_empty());
    assert_eq!(reduced.reductions(), 3, "a trial reduces nothing");
    let held = trial.reduced.as_ref().unwrap();
    let full = reduced.evaluate(&moved).unwrap().system;
    let n = held.n();
    let t = held
        .expand(faer::Mat::<f64>::identity(n, n).as_ref(), &full.dofs)
        .unwrap();
    let kc = crate::reduction::linalg::project(&full.k, t.as_ref());
    let mc = crate::reduction::linalg::project(&full.m, t.as_ref());
    let labels = vec![crate::core::DofId::new(0, crate::core::Component::Ux); n];
    let ritz = dense_generalized(kc.as_ref(), mc.as_ref(), &labels, ModeSelection::All).unwrap();
    let exact = dense_generalized(
        full.k.to_dense().as_ref(),
        full.m.to_dense().as_ref(),
        &full.dofs,
        ModeSelection::Count(12),
    )
    .unwrap();
    for (i, l) in exact.eigenvalues.iter().enumerate() {
        let (a, b) = (trial.modes.eigenvalues[i], ritz.eigenvalues[i]);
        assert!(
            (a - b).abs() <= 1e-9 * b,
            "mode {i}: trial {a} vs Tᵀ K T {b}"
        );
        assert!(
            a >= l * (1.0 - 1e-9),
            "mode {i}: trial {a} below the full model's {l}"
        );
    }
}

/// A full model's trial state is Rayleigh-Ritz on the mode shapes of its last full analysis:
/// none before one; at that analysis's values it reproduces it (1e-8 relative, the Lanczos
/// modes' own convergence: the Rayleigh quotients of converged Ritz vectors); after a 15 % thickness change its eigenvalues bound the full
/// analysis's from above and lie within 2 % of them (reached 1.3 %: eight modes are a small
/// basis, and the change of the shapes they miss enters the eigenvalues to second order), its shapes are `M(φ)`-orthonormal
/// to 1e-9, and it carries no projected derivatives and no factor.
#[test]
fn full_model_trial_state_is_rayleigh_ritz_on_the_last_modes() {
    use crate::fe::element::MassKind;
    let fe = FeModel::new(clamped_plate_three_strips(), &[], MassKind::Consistent).unwrap();
    let selection = ModeSelection::Count(8);
    let values = fe.initial_values();
    assert!(fe.trial_modal_state(&values, selection).unwrap().is_none());
    let (state, _) = fe.modal_state(&values, selection).unwrap();
    let same = fe.trial_modal_state(&values, selection).unwrap().unwrap();
    for (a, b) in same.modes.eigenvalues.iter().zip(&state.modes.eigenvalues) {
        assert!((a - b).abs() <= 1e-8 * b, "{a} vs {b}");
    }
    let mut moved = values.clone();
    moved[1] *= 1.15;
    let trial = fe.trial_modal_state(&moved, selection).unwrap().unwrap();
    assert!(trial.projected.is_empty() && trial.factor.is_none());
    let (exact, evaluated) = fe.modal_state(&moved, selection).unwrap();
    let mut worst = 0.0f64;
    for (a, l) in trial.modes.eigenvalues.iter().zip(&exact.modes.eigenvalues) {
        assert!(
            *a >= l * (1.0 - 1e-9),
            "trial {a} below the full model's {l}"
        );
        worst = worst.max(a / l - 1.0);
    }
    assert!(
        worst < 0.02 && worst > 0.0,
        "largest eigenvalue error {worst}"
    );
    let m = evaluated.unwrap().system.m;
    let phi = trial.modes.shapes.as_ref();
    let mass = crate::reduction::linalg::project(&m, phi);
    for i in 0..mass.nrows() {
        for j in 0..mass.ncols() {
            let want = if i == j { 1.0 } else { 0.0 };
            assert!(
                (mass[(i, j)] - want).abs() < 1e-9,
                "({i}, {j}): {}",
                mass[(i, j)]
            );
        }
    }
}

/// On a free-free model the trial keeps the rigid-body modes rigid: their projected stiffness
/// is round-off of `‖K‖ε` and is taken as zero. The free bent plate's six rigid-body modes come
/// out with eigenvalue 0 after a 15 % thickness change, and its elastic ones still bound the
/// full analysis's. (The round-off that made the Ritz solve call a rigid-body mode negative
/// appeared on the 1M-DOF muffler only, −5.5e-4 rad²/s² against a kept band of 1e7: that
/// failure was measured there, not reproduced at this size.)
#[test]
fn full_model_trial_keeps_rigid_body_modes_rigid() {
    use crate::fe::element::MassKind;
    let free = bent_plate_with_strip_thicknesses(
        crate::model::generate::BentPlate {
            clamped: false,
            with_bar: false,
            ..Default::default()
        },
        &[1, 4, 9],
    );
    let fe = FeModel::new(free, &[], MassKind::Consistent).unwrap();
    let selection = ModeSelection::Count(12);
    let values = fe.initial_values();
    let (state, _) = fe.modal_state(&values, selection).unwrap();
    assert_eq!(state.modes.rigid_body_modes, 6);
    let mut moved = values.clone();
    moved[2] *= 1.15;
    let trial = fe.trial_modal_state(&moved, selection).unwrap().unwrap();
    assert_eq!(trial.modes.rigid_body_modes, 6);
    assert!(trial.modes.eigenvalues[..6].iter().all(|l| *l == 0.0));
    let (exact, _) = fe.modal_state(&moved, selection).unwrap();
    for (a, l) in trial.modes.eigenvalues[6..]
        .iter()
        .zip(&exact.modes.eigenvalues[6..])
    {
        assert!(
            *a >= l * (1.0 - 1e-9),
            "trial {a} below the full model's {l}"
        );
    }
}

/// The trial merits [`TrialMethod`] offers.
#[derive(Clone, Copy, Debug)]
enum Trials {
    /// None: every candidate is analysed.
    Exact,
    /// Within half the promised gain of the truth, but ranking φ = 1.5 above φ = 2.
    Biased,
    /// The reverse of the truth: φ = 0.5 first.
    Misleading,
}

/// An update method with chosen trial merits, for the trust-region search.
struct TrialMethod {
    /// Analyses in full so far.
    full: std::cell::Cell<usize>,
    trials: Trials,
}

impl UpdateMethod for TrialMethod {
    /// Full merit `−(φ − 2)²`; from φ = 1 the step to 1.5 and fallbacks to 2.0 and 0.5.
    fn iterate(
        &self,
        _model: &dyn ParametricModel,
        values: &[f64],
        iteration: usize,
    ) -> Result<Step, UpdatingError> {
        self.full.set(self.full.get() + 1);
        let v = values[0];
        let chi = -(v - 2.0).powi(2);
        let record = IterationRecord {
            iteration,
            values: values.to_vec(),
            relative_change: vec![0.5],
            active: vec![true],
            lines_used: 1,
            mean_chi_s: chi,
            mean_chi_a: chi,
            residual_norm: 0.0,
            condition_limit: f64::NAN,
            smoothing: 0.0,
            smoothed_mean_chi: f64::NAN,
            diagnostics: Default::default(),
        };
        let stop = (iteration > 0).then_some(StopReason::Converged);
        Ok(Step {
            record,
            stop,
            fallbacks: vec![vec![1.0], vec![-0.5]],
        })
    }

    fn merit(&self, record: &IterationRecord) -> Option<f64> {
        Some(record.mean_chi())
    }

    fn trial_merit(
        &self,
        _model: &dyn ParametricModel,
        values: &[f64],
    ) -> Result<Option<f64>, UpdatingError> {
        let v = values[0];
        Ok(match self.trials {
            Trials::Exact => None,
            Trials::Biased => Some(-(v - 2.0).powi(2) + if v == 1.5 { 0.05 } else { -0.3 }),
            Trials::Misleading => Some(-(v - 0.5).powi(2)),
        })
    }
}

/// The trust-region search from φ = 1 (merit −1) over φ = 1.5, 2, 0.5 (merits −0.25, 0,
/// −2.25). Exact merits: all three analysed, the best (2) taken. Trial merits within
/// [`TRIAL_ACCURACY`] of the gain they promise are trusted: only the trial-best (1.5) is
/// analysed, confirmed, and no other is ranked above it — taken after one analysis where
/// the exhaustive search takes three. Misleading trials: the trial-best (0.5) analyses to a
/// loss, so every candidate is analysed and the best (2) taken.
#[test]
fn trust_region_confirms_trial_merits_by_full_analyses() {
    let model = chain_model(&[1.0]);
    for (trials, expected, analyses) in [
        (Trials::Exact, 2.0, 4),
        (Trials::Biased, 1.5, 2),
        (Trials::Misleading, 2.0, 4),
    ] {
        let method = TrialMethod {
            full: std::cell::Cell::new(0),
            trials,
        };
        let h = run(&method, &model, 5).unwrap();
        assert_eq!(h.final_values, vec![expected], "{trials:?}");
        assert_eq!(method.full.get(), analyses, "{trials:?}");
    }
}

/// Modal receptances of the true chain (all masses 1 kg) with per-mode `damping`.
fn measured_with_modal_damping(damping: &ModalDamping, freqs: &[f64]) -> FrfSet {
    let sys = assemble_lumped(&LumpedModel::chain(&[1.0; 4], 1e4)).unwrap();
    let (modes, _) = crate::eigen::lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::All,
        &Default::default(),
    )
    .unwrap();
    let pairs = FrfSet::all_pairs(&sys.dofs, &sys.dofs[..1]);
    crate::frf::modal_receptance(
        &modes,
        &sys.dofs,
        damping,
        &pairs,
        freqs,
        Quantity::Receptance,
    )
    .unwrap()
}

fn identify(
    data: &FrfSet,
    kind: DampingKind,
    initial: f64,
    pairs: usize,
) -> (UpdateHistory, Vec<UpdatingParameter>) {
    let data = FrfSet {
        pairs: data.pairs[..pairs].to_vec(),
        values: faer::Mat::from_fn(data.freqs_hz.len(), pairs, |k, q| data.values[(k, q)]),
        ..data.clone()
    };
    let model = chain_model(&[1.0; 4]);
    let (state, _) = model
        .modal_state(&model.initial_values(), ModeSelection::All)
        .unwrap();
    let method = DampingIdentification::new(
        &data,
        &state,
        DampingSettings {
            kind,
            initial: vec![initial; 4],
            modes: vec![0, 1, 2, 3],
            kappa_f: 1.0,
            resonance_lines: 0.0,
            stop_chi: 1.0,
            tolerance: 1e-9,
            max_step: 1.0,
            subset_kappa: None,
        },
    )
    .unwrap();
    let params = DampingParameters::new(&method, model.evaluate(&[1.0; 4]).unwrap().system);
    let h = run(&method, &params, 30).unwrap();
    (h, method.parameters())
}

/// Noise-free FRFs from a model with per-mode loss factors: the four `η_r` are recovered to
/// 1e-6 from the column of FRFs and from the point FRF alone (the model is exact, so the
/// equations are consistent and Gauss-Newton converges to the truth).
#[test]
fn damping_identification_recovers_per_mode_loss_factors() {
    let truth = [0.02, 0.005, 0.01, 0.03];
    let freqs = frequency_lines(0.5, 40.0, 0.1);
    let data = measured_with_modal_damping(&ModalDamping::Structural(truth.to_vec()), &freqs);
    for pairs in [4, 1] {
        let (h, params) = identify(&data, DampingKind::Structural, 0.01, pairs);
        assert_eq!(params[0].name, "eta_1");
        assert_eq!(h.stop, StopReason::Converged);
        assert!(h.iterations.len() <= 8, "{} iterations", h.iterations.len());
        for (v, t) in h.final_values.iter().zip(truth) {
            assert!(
                (v / t - 1.0).abs() < 1e-6,
                "{pairs} FRFs: η = {v}, truth {t}"
            );
        }
    }
}

/// A viscous model fitted to structurally damped FRFs: near resonance `c ω = η k` gives
/// `ζ_r = η_r/2` exactly at `ω_r`; away from it the two models differ, so the fit lands close
/// to, not on, `η_r/2` (within 2 % here, where each peak dominates its band).
#[test]
fn viscous_fit_to_structural_measurements_gives_equivalent_ratios() {
    let truth = [0.02, 0.005, 0.01, 0.03];
    let freqs = frequency_lines(0.5, 40.0, 0.05);
    let data = measured_with_modal_damping(&ModalDamping::Structural(truth.to_vec()), &freqs);
    let (h, params) = identify(&data, DampingKind::Viscous, 0.005, 4);
    assert_eq!(params[3].name, "zeta_4");
    for (v, t) in h.final_values.iter().zip(truth) {
        let eta = equivalent_loss_factor(*v);
        assert!((eta / t - 1.0).abs() < 2e-2, "2ζ = {eta}, η = {t}");
    }
}

/// Rigid-body and out-of-basis modes are refused with the mode named.
#[test]
fn damping_of_a_rigid_body_mode_is_refused() {
    // Free-free: the chain without its two grounding springs has one rigid-body mode.
    let mut lumped = LumpedModel::chain(&[1.0; 4], 1e4);
    lumped.springs.retain(|s| s.to.is_some());
    let free = LinearModel::new(assemble_lumped(&lumped).unwrap(), Vec::new()).unwrap();
    let (state, _) = free.modal_state(&[], ModeSelection::All).unwrap();
    let data = measured(0.01, &[5.0, 6.0]);
    let settings = |modes: Vec<usize>| DampingSettings {
        kind: DampingKind::Structural,
        initial: vec![0.01; state.modes.len()],
        modes,
        kappa_f: 0.95,
        resonance_lines: 1.0,
        stop_chi: 0.99,
        tolerance: 1e-6,
        max_step: 1.0,
        subset_kappa: None,
    };
    assert_eq!(state.modes.rigid_body_modes, 1);
    let e = DampingIdentification::new(&data, &state, settings(vec![1, 0]))
        .err()
        .unwrap();
    assert!(e.to_string().contains("mode 1 is a rigid-body mode"), "{e}");
    let e = DampingIdentification::new(&data, &state, settings(vec![7]))
        .err()
        .unwrap();
    assert!(
        e.to_string().contains("mode 8 is not in the modal basis"),
        "{e}"
    );
}

/// Updating through Craig-Bampton with interface modes to 400 Hz (C2's two plates and bar): the
/// modes below 100 Hz stay within 1 % of the plain Craig-Bampton model's, the interface basis
/// is chosen once, and a parameter change still re-reduces only its substructure.
#[test]
fn reduced_model_with_interface_modes_holds_its_basis() {
    use crate::fe::element::MassKind;
    use crate::model::generate::{BentPlate, bent_plate};
    use crate::model::{Parameter, ParameterKind};
    use crate::reduction::{Method, Partition};
    let mut model = bent_plate(&BentPlate::default());
    model.parameters.push(Parameter {
        name: "t6".into(),
        kind: ParameterKind::ShellThickness,
        set: "strip_6".into(),
        lower: 1e-4,
        upper: 1e-2,
    });
    let names: Vec<String> = ["plate_1", "plate_2", "bar"].map(String::from).to_vec();
    let partition = Partition::from_sets(&model, &names, MassKind::Consistent).unwrap();
    let method = Method::CraigBampton {
        modes: ModeSelection::BelowHz(200.0),
    };
    let fe = || FeModel::new(model.clone(), &[], MassKind::Consistent).unwrap();
    let plain = super::ReducedFeModel::new(fe(), partition.clone(), method.clone());
    let reduced = super::ReducedFeModel::new(fe(), partition, method)
        .with_interface_modes(ModeSelection::BelowHz(400.0));
    let values = reduced.initial_values();
    let selection = ModeSelection::BelowHz(100.0);
    let (a, _) = plain.modal_state(&values, selection).unwrap();
    let (b, _) = reduced.modal_state(&values, selection).unwrap();
    // Both are analysed on their complete reduced bases: compare the modes below 100 Hz.
    let limit = (2.0 * std::f64::consts::PI * 100.0f64).powi(2);
    let band = a.modes.eigenvalues.iter().filter(|l| **l <= limit).count();
    assert!(band >= 12 && b.modes.eigenvalues.len() >= band);
    assert!(b.modes.eigenvalues.len() < a.modes.eigenvalues.len());
    for (la, lb) in a.modes.eigenvalues[..band].iter().zip(&b.modes.eigenvalues) {
        if *la > 0.0 {
            assert!((lb / la - 1.0).abs() < 0.01, "{lb} vs {la}");
            assert!(
                lb >= &(la * (1.0 - 1e-9)),
                "a Ritz model on a smaller basis"
            );
        }
    }
    assert_eq!(reduced.reductions(), 3);
    let mut moved = values.clone();
    moved[0] *= 1.05;
    reduced.modal_state(&moved, selection).unwrap();
    assert_eq!(reduced.reductions(), 4);
}

/// The merit equations of the P-C ([`super::pc::merit_equations`]) are Gauss-Newton's for the
/// stop figure: their gradient `S_mᵀ ε_m` is twice the gradient of `Σ_k (χ_s + χ_a)` over the
/// lines, checked against a central difference of the correlation coefficients themselves on a
/// prediction linear in one parameter. Tolerance 1e-6 relative: the difference's truncation
/// error at step 1e-5.
#[test]
fn merit_equations_follow_the_gradient_of_the_mean_correlation() {
    use super::pc::{correlation_equations, merit_equations};
    use crate::correlation::frf::{amplitude_correlation, shape_correlation};
    use faer::{Mat, c64};
    let freqs = frequency_lines(1.0, 6.0, 1.0);
    let x = measured(0.02, &freqs);
    let (nf, nq) = (freqs.len(), x.pairs.len());
    let slope = Mat::from_fn(nf, nq, |k, q| {
        c64::new(0.3 * (k as f64 + 1.0), -0.2 * (q as f64 + 0.5)) * 1e-4
    });
    let at = |phi: f64| FrfSet {
        values: Mat::from_fn(nf, nq, |k, q| {
            x.values[(k, q)] * c64::new(1.1, 0.05 * q as f64) + slope[(k, q)] * phi
        }),
        ..x.clone()
    };
    let total = |phi: f64| {
        let a = at(phi);
        (0..nf)
            .map(|k| {
                let xv: Vec<c64> = (0..nq).map(|q| x.values[(k, q)]).collect();
                let av: Vec<c64> = (0..nq).map(|q| a.values[(k, q)]).collect();
                shape_correlation(&xv, &av) + amplitude_correlation(&xv, &av)
            })
            .sum::<f64>()
    };
    let lines: Vec<usize> = (0..nf).collect();
    let (mut s, mut eps) =
        correlation_equations(&x, &at(0.0), &lines, std::slice::from_ref(&slope), false);
    merit_equations(&mut s, &mut eps);
    let gradient: f64 = (0..s.nrows()).map(|i| s[(i, 0)] * eps[i]).sum();
    let h = 1e-5;
    let fd = (total(h) - total(-h)) / (2.0 * h);
    assert!(
        (gradient - 2.0 * fd).abs() < 1e-6 * fd.abs(),
        "{gradient} against {}",
        2.0 * fd
    );
}

/// A continuation ([`run_phases`]): a smoothed P-C phase, then the P-C proper, share the
/// iteration budget, number their iterations on, record their smoothing in order, and end
/// where the unsmoothed phase's stop rule does — from a 30 % mass error on the four-DOF chain.
#[test]
fn phases_share_the_budget_and_number_their_iterations_on() {
    let freqs = frequency_lines(0.5, 40.0, 0.1);
    let data = measured(0.01, &freqs);
    let settings = |smoothing: f64| PcSettings {
        damping: ModalDamping::Structural(vec![0.01]),
        smoothing,
        merit_steps: true,
        ..Default::default()
    };
    let smoothed = PredictorCorrector::new(&data, settings(0.05));
    let proper = PredictorCorrector::new(&data, settings(0.0));
    let model = chain_model(&[1.0, 1.3, 1.0, 1.0]);
    let h = run_phases(&[&smoothed, &proper], &model, &model.initial_values(), 12).unwrap();
    assert_eq!(h.stop, StopReason::Converged);
    let numbers: Vec<usize> = h.iterations.iter().map(|r| r.iteration).collect();
    assert_eq!(numbers, (0..h.iterations.len()).collect::<Vec<_>>());
    assert!(h.iterations.len() <= 13);
    let phases: Vec<f64> = h.iterations.iter().map(|r| r.smoothing).collect();
    assert_eq!(phases[0], 0.05, "{phases:?}");
    assert_eq!(*phases.last().unwrap(), 0.0, "{phases:?}");
    assert!(phases.windows(2).all(|w| w[1] <= w[0]), "{phases:?}");
    // The smoothed merit is recorded where it was used, the FRFs' own correlation everywhere.
    for r in &h.iterations {
        assert_eq!(r.smoothed_mean_chi.is_nan(), r.smoothing == 0.0);
        assert!(r.mean_chi() > 0.0 && r.mean_chi() <= 1.0);
    }
    assert!(h.iterations.last().unwrap().mean_chi() >= 0.99);
    for (i, v) in h.final_values.iter().enumerate() {
        assert!((v - 1.0).abs() < 0.05, "m{} = {v}", i + 1);
    }
}

/// The static solutions from the eigensolver's factor, its shift moved to the static one by
/// fixed-point steps, against a second factorisation at that shift and against the complete
/// dense eigen-decomposition (`Σ_truncated φ_s φ_sᵀ e_j/(λ_s − σ)`, an independent second
/// method): the free-free bent plate with its bar (864 DOFs, the sparse path, six rigid-body
/// modes), modes to 200 Hz. The truncated part of the moved solutions matches the dense sum to
/// 1e-6 of its largest entry (seen 7e-8; the dense sum over 830 modes is itself good to about
/// that), that of the second factorisation to 1e-5 (seen 8e-7: its solution carries the
/// rigid-body part, 100/λ₁, whose round-off the subtraction leaves). The shape corrections built
/// from either agree to 5e-5 of their largest entry (seen 1.5e-5, the second factorisation's
/// error).
#[test]
fn static_solutions_from_the_eigen_factor_match_a_second_factorisation() {
    use crate::core::sparse::sparse_to_dense;
    use crate::fe::element::MassKind;
    use crate::model::generate::BentPlate;
    use crate::sensitivity::frf::{EigenFactor, shift_steps, shifted_static_solutions};
    use faer::Mat;
    let model = bent_plate_with_strip_thicknesses(BentPlate::default(), &[5, 12]);
    let fe = FeModel::new(model, &[], MassKind::Consistent).unwrap();
    let values = fe.initial_values();
    let evaluated = fe.evaluate(&values).unwrap();
    let state = ModalState::new(&evaluated, &values, ModeSelection::BelowHz(200.0)).unwrap();
    assert_eq!(state.modes.rigid_body_modes, 6);
    let factor = state
        .factor
        .as_deref()
        .expect("864 DOFs take the sparse path, which keeps its factor");
    let eigen_factor = EigenFactor {
        factor,
        shapes: state.modes.shapes.as_ref(),
    };
    let dofs: Vec<crate::core::DofId> = ["113:uz", "56:uz", "110:uz", "120:ux"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
    let index = state.index();
    let rows: Vec<usize> = dofs.iter().map(|d| index[d]).collect();
    let (k, m) = (&evaluated.system.k, &evaluated.system.m);
    let (n, eigenvalues) = (k.nrows(), &state.modes.eigenvalues);
    let moved = shifted_static_solutions(k, m, eigenvalues, &rows, Some(eigen_factor)).unwrap();
    let own = shifted_static_solutions(k, m, eigenvalues, &rows, None).unwrap();
    assert_eq!(moved.shift, own.shift);
    let sigma = own.shift;
    let steps = shift_steps(eigen_factor, eigenvalues, sigma, n).unwrap();
    assert!(
        (1..=crate::sensitivity::frf::MAX_SHIFT_STEPS).contains(&steps),
        "{steps} steps: the test must exercise the moved shift"
    );
    let largest = |a: &Mat<f64>| {
        (0..a.ncols())
            .flat_map(|c| (0..a.nrows()).map(move |i| (i, c)))
            .fold(0.0f64, |s, (i, c)| s.max(a[(i, c)].abs()))
    };
    let all = crate::eigen::dense_generalized(
        sparse_to_dense(k).as_ref(),
        sparse_to_dense(m).as_ref(),
        &evaluated.system.dofs,
        ModeSelection::All,
    )
    .unwrap();
    let kept = eigenvalues.len();
    let truth = Mat::from_fn(n, rows.len(), |i, c| {
        (kept..n)
            .map(|s| all.shapes[(i, s)] * all.shapes[(rows[c], s)] / (all.eigenvalues[s] - sigma))
            .sum::<f64>()
    });
    let phi = state.modes.shapes.as_ref();
    let truncated = |x: &Mat<f64>| {
        Mat::from_fn(n, rows.len(), |i, c| {
            x[(i, c)]
                - (0..kept)
                    .map(|s| phi[(i, s)] * phi[(rows[c], s)] / (eigenvalues[s] - sigma))
                    .sum::<f64>()
        })
    };
    let scale = largest(&truth);
    let moved_error = largest(&(&truncated(&moved.x) - &truth)) / scale;
    let own_error = largest(&(&truncated(&own.x) - &truth)) / scale;
    assert!(
        moved_error <= 1e-6 && own_error <= 1e-5,
        "truncated parts off the dense sum by {moved_error:e} (moved), {own_error:e} (refactored)"
    );
    let with_factor = state.shape_corrections(&evaluated, &values, &dofs).unwrap();
    let mut refactored = state.clone();
    refactored.factor = None;
    let without = refactored
        .shape_corrections(&evaluated, &values, &dofs)
        .unwrap();
    for (p, (a, b)) in with_factor.iter().zip(&without).enumerate() {
        let gap = largest(&(a - b));
        assert!(
            gap <= 5e-5 * largest(b),
            "parameter {p}: corrections differ by {gap:e} of {:e}",
            largest(b)
        );
    }
}

/// `set` with every DOF relabelled `node + 100` and the map taking each relabelled DOF back
/// to its model DOF with weight 1: an identity relabelling.
fn relabelled(set: &FrfSet) -> (FrfSet, crate::sensitivity::SensorMap) {
    use crate::core::DofId;
    let moved = |d: DofId| DofId::new(d.node + 100, d.comp);
    let map = crate::sensitivity::SensorMap::new(
        set.dofs().into_iter().map(|d| (moved(d), vec![(d, 1.0)])),
    );
    let pairs = set
        .pairs
        .iter()
        .map(|p| crate::frf::FrfPair {
            response: moved(p.response),
            excitation: moved(p.excitation),
        })
        .collect();
    (
        FrfSet {
            pairs,
            ..set.clone()
        },
        map,
    )
}

/// Through a map that only renames the measured DOFs (weight 1 on the model DOF of the old
/// name), the P-C, the RFM, the damping identification and the direct likelihood give exactly
/// the plain results: the unit-weight case reads the same rows, bit for bit.
#[test]
fn an_identity_relabelling_map_changes_nothing() {
    use super::model::ThroughMap;
    use super::posterior::{DirectFrfLikelihood, Likelihood, ModalFrfLikelihood};
    let freqs = frequency_lines(0.5, 40.0, 0.1);
    let data = measured(0.01, &freqs);
    let (renamed, map) = relabelled(&data);
    let start = [1.0, 1.3, 1.0, 1.0];
    let through = ThroughMap::new(Box::new(chain_model(&start)), map.clone());
    let pc = |set| {
        PredictorCorrector::new(
            set,
            PcSettings {
                damping: ModalDamping::Structural(vec![0.01]),
                merit_steps: true,
                ..Default::default()
            },
        )
    };
    // Compared as text: the records hold NaN (no subset limit), which is never equal to itself.
    let same =
        |a: &UpdateHistory, b: &UpdateHistory| assert_eq!(format!("{a:?}"), format!("{b:?}"));
    let plain = run(&pc(&data), &chain_model(&start), 15).unwrap();
    let mapped = run(&pc(&renamed), &through, 15).unwrap();
    same(&plain, &mapped);

    let rfm = |set| ResponseFunctionMethod {
        measured: set,
        settings: RfmSettings {
            lines_hz: vec![9.0, 25.0],
            eta: 0.01,
            ..Default::default()
        },
    };
    let plain = run(&rfm(&data), &chain_model(&start), 10).unwrap();
    let mapped = run(&rfm(&renamed), &through, 10).unwrap();
    same(&plain, &mapped);

    let damped = measured_with_modal_damping(&ModalDamping::Structural(vec![0.02; 4]), &freqs);
    let (damped_renamed, _) = relabelled(&damped);
    let settings = DampingSettings {
        kind: DampingKind::Structural,
        initial: vec![0.01; 4],
        modes: vec![0, 1, 2, 3],
        kappa_f: 1.0,
        resonance_lines: 0.0,
        stop_chi: 1.0,
        tolerance: 1e-9,
        max_step: 1.0,
        subset_kappa: None,
    };
    let truth = chain_model(&[1.0; 4]);
    let through_truth = ThroughMap::new(Box::new(chain_model(&[1.0; 4])), map);
    let mut histories = Vec::new();
    for (set, model) in [
        (&damped, &truth as &dyn ParametricModel),
        (&damped_renamed, &through_truth),
    ] {
        let (state, _) = model.modal_state(&[1.0; 4], ModeSelection::All).unwrap();
        let method = DampingIdentification::new(set, &state, settings.clone()).unwrap();
        let params = DampingParameters::new(&method, model.evaluate(&[1.0; 4]).unwrap().system);
        histories.push(run(&method, &params, 30).unwrap());
    }
    same(&histories[0], &histories[1]);

    let lines: Vec<usize> = (0..freqs.len()).step_by(37).collect();
    let plain_model = chain_model(&start);
    let a = DirectFrfLikelihood::new(&plain_model, &data, lines.clone(), 0.01)
        .predict(&start, true)
        .unwrap();
    let b = DirectFrfLikelihood::new(&through, &renamed, lines.clone(), 0.01)
        .predict(&start, true)
        .unwrap();
    assert_eq!(a.values, b.values);
    assert_eq!(a.jacobian, b.jacobian);
    let damping = ModalDamping::Structural(vec![0.01]);
    let a = ModalFrfLikelihood::new(
        &plain_model,
        &data,
        lines.clone(),
        ModeSelection::All,
        damping.clone(),
    )
    .predict(&start, true)
    .unwrap();
    let b = ModalFrfLikelihood::new(&through, &renamed, lines, ModeSelection::All, damping)
        .predict(&start, true)
        .unwrap();
    assert_eq!(a.values, b.values);
    assert_eq!(a.jacobian, b.jacobian);
}

/// Through a map with interpolation weights, a flipped and a skewed sensor on the clamped bent
/// plate, every predicted FRF is `W_r H W_eᵀ` of the model FRFs between the model DOFs the map
/// names (14.7), and every sensitivity the same combination of the model's (14.8), for the
/// modal prediction (on a complete and on a truncated, statically corrected basis) and the
/// direct one; and the sensitivities through the map equal central differences of the
/// predictions through the map (complete basis and direct: exact derivatives, to 1e-4 of the
/// largest, the differences' own error at a relative step of 1e-5).
#[test]
fn predictions_and_sensitivities_through_interpolation_weights() {
    use super::model::ThroughMap;
    use super::posterior::{DirectFrfLikelihood, Likelihood, ModalFrfLikelihood, Prediction};
    use crate::core::DofId;
    use crate::fe::element::MassKind;
    use crate::frf::FrfPair;
    let model = clamped_plate_three_strips();
    let d = |s: &str| -> DofId { s.parse().unwrap() };
    let combos: Vec<(DofId, Vec<(DofId, f64)>)> = vec![
        (d("9001:uz"), vec![(d("113:uz"), 0.25), (d("56:uz"), 0.75)]),
        (d("9002:uz"), vec![(d("110:uz"), -1.0)]),
        (d("9003:uz"), vec![(d("56:uz"), 0.6), (d("110:ux"), 0.8)]),
    ];
    let map = crate::sensitivity::SensorMap::new(combos.clone());
    let test: Vec<DofId> = combos.iter().map(|c| c.0).collect();
    let union = [d("113:uz"), d("56:uz"), d("110:uz"), d("110:ux")];
    let freqs = vec![13.0, 37.5, 61.0, 88.0];
    let set = |dofs: &[DofId], exc: &[DofId]| {
        let pairs = FrfSet::all_pairs(dofs, exc);
        FrfSet {
            quantity: Quantity::Receptance,
            freqs_hz: freqs.clone(),
            values: faer::Mat::zeros(freqs.len(), pairs.len()),
            pairs,
        }
    };
    // Measured pairs: every test DOF against the excitation at 9003 (skewed) and 9002.
    let measured = set(&test, &test[1..]);
    let on_model = set(&union, &union);
    let lines: Vec<usize> = (0..freqs.len()).collect();
    let fe = || FeModel::new(model.clone(), &[], MassKind::Consistent).unwrap();
    let plain = fe();
    let through = ThroughMap::new(Box::new(fe()), map);
    let values = plain.initial_values();
    let weights = |t: DofId| combos.iter().find(|c| c.0 == t).unwrap().1.clone();
    // W_r X W_eᵀ of a prediction on all model pairs, in the measured layout (re, im per pair
    // per line), for the values and each Jacobian column.
    let combine = |p: &Prediction, column: Option<usize>| -> Vec<f64> {
        let get = |k: usize, q: usize, part: usize| {
            let i = 2 * (k * on_model.pairs.len() + q) + part;
            match column {
                None => p.values[i],
                Some(c) => p.jacobian.as_ref().unwrap()[(i, c)],
            }
        };
        let mut out = Vec::new();
        for k in 0..freqs.len() {
            for pair in &measured.pairs {
                for part in 0..2 {
                    let mut v = 0.0;
                    for (a, wa) in weights(pair.response) {
                        for (b, wb) in weights(pair.excitation) {
                            let q = on_model
                                .pair_index(&FrfPair {
                                    response: a,
                                    excitation: b,
                                })
                                .unwrap();
                            v += wa * wb * get(k, q, part);
                        }
                    }
                    out.push(v);
                }
            }
        }
        out
    };
    let close = |a: &[f64], b: &[f64], tol: f64, what: &str| {
        let scale = b.iter().fold(1e-300_f64, |m, x| m.max(x.abs()));
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                (x - y).abs() <= tol * scale,
                "{what} [{i}]: {x} vs {y} (scale {scale:e})"
            );
        }
        assert_eq!(a.len(), b.len(), "{what}");
    };
    let damping = ModalDamping::Structural(vec![0.01]);
    type Predict<'a> = Box<dyn Fn(&dyn ParametricModel, &FrfSet, &[f64], bool) -> Prediction + 'a>;
    let routes: Vec<(&str, Predict, Option<f64>)> = vec![
        (
            "modal, complete basis",
            Box::new(|m, s, v, j| {
                ModalFrfLikelihood::new(m, s, lines.clone(), ModeSelection::All, damping.clone())
                    .predict(v, j)
                    .unwrap()
            }),
            Some(1e-4),
        ),
        (
            "modal, 200 Hz basis with the static correction",
            Box::new(|m, s, v, j| {
                ModalFrfLikelihood::new(
                    m,
                    s,
                    lines.clone(),
                    ModeSelection::BelowHz(200.0),
                    damping.clone(),
                )
                .predict(v, j)
                .unwrap()
            }),
            None,
        ),
        (
            "direct",
            Box::new(|m, s, v, j| {
                DirectFrfLikelihood::new(m, s, lines.clone(), 0.01)
                    .predict(v, j)
                    .unwrap()
            }),
            Some(1e-4),
        ),
    ];
    for (name, predict, fd_tol) in routes {
        let mapped = predict(&through, &measured, &values, true);
        let model_pairs = predict(&plain, &on_model, &values, true);
        close(&mapped.values, &combine(&model_pairs, None), 1e-12, name);
        for p in 0..values.len() {
            let column: Vec<f64> = (0..mapped.values.len())
                .map(|i| mapped.jacobian.as_ref().unwrap()[(i, p)])
                .collect();
            close(&column, &combine(&model_pairs, Some(p)), 1e-10, name);
            let Some(tol) = fd_tol else { continue };
            let step = 1e-5;
            let (mut up, mut down) = (values.clone(), values.clone());
            up[p] *= 1.0 + step;
            down[p] *= 1.0 - step;
            let (hu, hd) = (
                predict(&through, &measured, &up, false).values,
                predict(&through, &measured, &down, false).values,
            );
            let fd: Vec<f64> = hu
                .iter()
                .zip(&hd)
                .map(|(a, b)| (a - b) / (2.0 * step))
                .collect();
            close(
                &column,
                &fd,
                tol,
                &format!("{name}: t{p} against differences"),
            );
        }
    }
}

/// Lab-like data: the lines of a band where the measurement concentrates around the
/// resonances (every 0.1 Hz within a window of each natural frequency of the truth), and a
/// small mass error: every line off the predicted resonances correlates above the default
/// `κ_f = 0.95` while the mean over all lines (the resonances' neighbours included) stays below
/// the stop figure 0.99 — the case where the P-C used to stop with `nothing_to_update`. The
/// first window and error of `m2` of a scan that reproduce that opening are updated with the
/// defaults: the P-C now takes the worst-correlated lines, one per parameter, and reaches its
/// own stop rule.
#[test]
fn pc_defaults_reach_their_stop_rule_when_no_line_passes_kappa_f() {
    use super::pc::{LineCorrelation, off_resonance_lines, predict};
    let settings = PcSettings {
        damping: ModalDamping::Structural(vec![0.01]),
        ..Default::default()
    };
    let defaults = PcSettings::default();
    let truth = chain_model(&[1.0; 4]);
    let natural = truth
        .modal_state(&[1.0; 4], ModeSelection::All)
        .unwrap()
        .0
        .modes
        .frequencies_hz();
    let data = |window: f64| {
        let freqs: Vec<f64> = frequency_lines(0.5, 40.0, 0.1)
            .into_iter()
            .filter(|f| natural.iter().any(|n| (f - n).abs() <= window))
            .collect();
        measured(0.01, &freqs)
    };
    // (worst off-resonance line, mean) of the model with `m2` against `data`.
    let opening = |data: &FrfSet, m2: f64| {
        let model = chain_model(&[1.0, m2, 1.0, 1.0]);
        let (state, _) = model
            .modal_state(&model.initial_values(), ModeSelection::All)
            .unwrap();
        let predicted = predict(&state, data, &settings.damping).unwrap();
        let lines = LineCorrelation::new(data, &predicted);
        let off = off_resonance_lines(
            &data.freqs_hz,
            &state.modes.frequencies_hz(),
            defaults.resonance_lines,
        );
        let worst = off
            .iter()
            .map(|&k| 0.5 * (lines.chi_s[k] + lines.chi_a[k]))
            .fold(1.0_f64, f64::min);
        (worst, lines.mean_chi())
    };
    let mut seen = Vec::new();
    let mut case = None;
    'scan: for window in [0.3, 0.5, 0.8, 1.2, 2.0] {
        let data = data(window);
        for m2 in (1..=40).map(|i| 1.0 + 0.0025 * i as f64) {
            let (worst, mean) = opening(&data, m2);
            seen.push(format!(
                "window {window} Hz, m2 {m2:.4}: worst {worst:.4}, mean {mean:.4}"
            ));
            if worst > defaults.kappa_f && mean < defaults.stop_chi {
                case = Some((data, m2));
                break 'scan;
            }
        }
    }
    let (data, m2) =
        case.unwrap_or_else(|| panic!("no case reproduces the stop:\n{}", seen.join("\n")));
    let method = PredictorCorrector::new(&data, settings);
    let h = run(&method, &chain_model(&[1.0, m2, 1.0, 1.0]), 15).unwrap();
    let last = seen.last().unwrap();
    assert_eq!(h.iterations[0].lines_used, 4, "{last}");
    assert_eq!(h.stop, StopReason::Converged, "{last}: {:#?}", h.iterations);
    assert!(h.iterations.last().unwrap().mean_chi() >= defaults.stop_chi);
    assert!(
        (h.final_values[1] - 1.0).abs() < (m2 - 1.0),
        "{last}: {:?}",
        h.final_values
    );
}

/// Every full analysis of an update after the first factors `K − σM` on the last one's
/// structure (the parameters change thicknesses, not which elements connect), and finds the
/// modes a fresh analysis at the same values finds, to the bit: the free-free bent plate with its
/// bar (864 DOFs, the sparse path), modes to 200 Hz, at the initial values and 10 % thicker
/// strips.
#[test]
fn analyses_after_the_first_reuse_the_factor_structure() {
    use crate::fe::element::MassKind;
    use crate::model::generate::BentPlate;
    let model = bent_plate_with_strip_thicknesses(BentPlate::default(), &[5, 12]);
    let fe = FeModel::new(model, &[], MassKind::Consistent).unwrap();
    let selection = ModeSelection::BelowHz(200.0);
    let initial = fe.initial_values();
    let reused = |state: &ModalState| {
        let factor = state
            .factor
            .as_deref()
            .expect("the sparse path keeps its factor");
        factor.factor.info.structure_reused
    };
    let (first, _) = fe.modal_state(&initial, selection).unwrap();
    assert!(!reused(&first));
    let moved: Vec<f64> = initial.iter().map(|v| v * 1.1).collect();
    let (second, evaluated) = fe.modal_state(&moved, selection).unwrap();
    assert!(reused(&second));
    // With the first Lanczos run sized as `modal_state` sizes it after an analysis.
    let first_count = Some(super::model::first_count_after(first.modes.len()));
    let params = super::model::update_eigen_params(first_count, None);
    let fresh = ModalState::with_params(&evaluated.unwrap(), &moved, selection, &params).unwrap();
    assert!(!reused(&fresh));
    assert_eq!(second.modes.eigenvalues, fresh.modes.eigenvalues);
    assert_eq!(second.modes.shapes, fresh.modes.shapes);
}
