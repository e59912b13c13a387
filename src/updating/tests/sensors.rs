//! Measured FRFs through sensor maps: multi-term sensors, relabelling, interpolation weights.

use super::*;
use crate::frf::frequency_lines;
use crate::updating::damping::{
    DampingIdentification, DampingKind, DampingParameters, DampingSettings,
};
use crate::updating::pc::{PcSettings, PredictorCorrector};
use crate::updating::rfm::{ResponseFunctionMethod, RfmSettings};

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
