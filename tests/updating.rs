//! The shipped updating pipelines reproduce the thesis's findings (CASES.md C1, C2).

mod common;

use common::*;
use femu::artefact::codec::read_dir;
use std::path::Path;

/// C1 (thesis §2.5.3): the RFM with complete noise-free data recovers all four masses to 1e-8
/// at any non-resonant line; incomplete noise-free data with three coordinates (the fourth from
/// the model) still converge to the truth, iterating, while two coordinates at two lines leave
/// the estimate off; noisy data bias the estimates
/// (5 % noise by a few per cent, 10 % by more); the P-C on the noisy data ends better
/// correlated than it began.
#[test]
fn four_dof_rfm_reproduces_c1() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(&pipeline("four-dof-rfm"), &tmp.path().join("cache"), &[]);
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    for stage in [
        "rfm_complete_5hz",
        "rfm_complete_9hz",
        "rfm_complete_10_5hz",
        "rfm_complete_25hz",
        "rfm_three_coordinates",
    ] {
        for (name, v) in results(&out, stage) {
            assert!((v - 1.0).abs() < 1e-8, "{stage}: {name} = {v}");
        }
        assert_eq!(meta(&out, stage, "stop"), "converged", "{stage}");
    }
    let spread = |stage: &str| {
        results(&out, stage)
            .values()
            .map(|v| (v - 1.0).abs())
            .fold(0.0, f64::max)
    };
    assert!(spread("rfm_two_coordinates") > 1e-3);
    for stage in ["rfm_noise_05_before", "rfm_noise_05_after"] {
        let s = spread(stage);
        assert!(s > 1e-4 && s < 0.1, "{stage}: largest error {s}");
    }
    assert!(spread("rfm_noise_10_before") > spread("rfm_noise_05_before"));
    // Truncated measurements: 3 modes nearly right, 2 modes clearly biased.
    assert!(spread("rfm_from_3_modes") < spread("rfm_from_2_modes"));
    assert!(spread("rfm_from_2_modes") > 1e-2);
    // Band-limited α_11 alone (one parameter, one iteration): every estimate moves m2 from 1.3
    // toward 1 but none reaches it, and the estimate changes as modes are dropped.
    let m2: Vec<f64> = [4, 3, 2, 1]
        .iter()
        .map(|m| results(&out, &format!("band_limited_{m}_modes"))["m2"])
        .collect();
    for v in &m2 {
        assert!(*v < 1.3 && *v > 1.0, "{m2:?}");
    }
    assert!((m2[0] - m2[3]).abs() > 1e-3, "{m2:?}");
    // The P-C improves the correlation.
    let pc = read_dir(&out.join("pc_noise_05").join("result")).unwrap();
    let it = pc.table("iterations").unwrap();
    let chi = it.f64s("iterations", "mean_chi").unwrap();
    assert!(chi.last().unwrap() > &chi[0], "{chi:?}");
}

/// C2 §4.6: the P-C with two smoothing phases (added loss factors 0.1, 0.03) and the merit's
/// steps, from three noisy FRFs on the Craig-Bampton and on the full model, meets the stop rule
/// within ten iterations and moves the thin strip (t5, 0.8 mm) toward the true 1.4 mm: above
/// 1.2 mm, with the two strips beside the bend (t5 + t6) within 3 % of their true 2.8 mm. From
/// α_11 alone (`χ_s ≡ 1`) t5 passes 1 mm. The phases are recorded in order, the last
/// unsmoothed. Without noise and with the stop rule at 0.99999 both bend strips end within 5 %
/// of 1.4 mm (the thesis's 1.36 and 1.42 mm). (Without the continuation t5 went the wrong way,
/// to 0.72 mm: see the pipeline.)
#[test]
fn bent_plate_pc_recovers_the_thin_strip() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(&pipeline("bent-plate-pc"), &tmp.path().join("cache"), &[]);
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    for stage in ["pc_three_frfs", "pc_three_frfs_full", "pc_one_frf"] {
        let a = read_dir(&out.join(stage).join("result")).unwrap();
        let it = a.table("iterations").unwrap();
        let chi = it.f64s("iterations", "mean_chi").unwrap();
        assert!(chi.len() <= 11, "{stage}: {} records", chi.len());
        assert!(chi.last().unwrap() - chi[0] > 0.06, "{stage}: {chi:?}");
        let chi_s = it.f64s("iterations", "mean_chi_s").unwrap();
        if stage == "pc_one_frf" {
            assert!(chi_s.iter().all(|c| (c - 1.0).abs() < 1e-12), "{chi_s:?}");
        }
        let phases = it.f64s("iterations", "smoothing").unwrap();
        // (A phase whose smoothed correlation already meets the stop rule takes no step.)
        assert!(phases[0] > 0.0, "{stage}: {phases:?}");
        assert!(phases.windows(2).all(|w| w[1] <= w[0]), "{phases:?}");
        assert_eq!(*phases.last().unwrap(), 0.0, "{stage}: {phases:?}");
        let v = results(&out, stage);
        assert_eq!(v.len(), 9);
        if stage == "pc_one_frf" {
            assert!(v["t5"] > 1.0e-3, "{stage}: t5 = {}", v["t5"]);
        } else {
            assert_eq!(meta(&out, stage, "stop"), "converged", "{stage}");
            assert!(
                v["t5"] > 1.2e-3 && v["t5"] < 1.45e-3,
                "{stage}: t5 = {}",
                v["t5"]
            );
            let pair = v["t5"] + v["t6"];
            assert!(
                (pair / 2.8e-3 - 1.0).abs() < 0.03,
                "{stage}: t5 + t6 = {pair}"
            );
        }
        let sv = a.table("singular_values").unwrap();
        assert_eq!(sv.f64s("singular_values", "value").unwrap().len() % 9, 0);
        // Its convergence figure is drawn.
        let plot = read_dir(&out.join(format!("{stage}_convergence")).join("plot")).unwrap();
        assert!(plot.blobs["convergence.png"].starts_with(b"\x89PNG"));
        assert!(plot.blobs.contains_key("convergence.svg"));
    }
    // Without noise, to a tight stop rule, the thesis's figures: t5 within 5 % of 1.4 mm.
    let v = results(&out, "pc_three_frfs_noise_free");
    let plot = read_dir(
        &out.join("pc_three_frfs_noise_free_convergence")
            .join("plot"),
    )
    .unwrap();
    assert!(plot.blobs["convergence.png"].starts_with(b"\x89PNG"));
    for t in ["t5", "t6"] {
        assert!((v[t] / 1.4e-3 - 1.0).abs() < 0.05, "{t} = {}", v[t]);
    }
    // Before and after, correlated over every line of the three FRFs (not only the P-C's
    // selected lines), by a direct solution of the updated mesh: the update raised mean χ.
    let mean_chi = |stage: &str| {
        let a = read_dir(&out.join(stage).join("correlation")).unwrap();
        a.meta["summary"]["mean_chi"].as_f64().unwrap()
    };
    let (before, after) = (
        mean_chi("initial_correlation"),
        mean_chi("updated_correlation"),
    );
    assert!(before < 0.9 && after > 0.99, "mean chi {before} -> {after}");
    for stage in ["initial_plot", "updated_plot"] {
        let plot = read_dir(&out.join(stage).join("plot")).unwrap();
        assert!(plot.blobs["frf.png"].starts_with(b"\x89PNG"));
    }
    // The updated model's three FRFs also one to a panel (small multiples).
    let plot = read_dir(&out.join("updated_plot").join("plot")).unwrap();
    assert!(plot.blobs["frf_panels.png"].starts_with(b"\x89PNG"));
    // A parameter the result does not hold is named, with the ones it does.
    let run = femu()
        .args(["run", pipeline("bent-plate-pc").to_str().unwrap()])
        .args(["--set", "pc_one_frf_convergence.parameters=[t5, t10]"])
        .env("FEMU_CACHE_DIR", tmp.path().join("cache"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        stderr.contains("field `with.parameters`: names `t10`, which the result does not hold")
            && stderr.contains("t1, t2, t3, t4, t5, t6, t7, t8, t9"),
        "{stderr}"
    );
    // Said once: the stage error's text is not repeated as its cause.
    assert_eq!(
        stderr.matches("which the result does not hold").count(),
        1,
        "{stderr}"
    );
}

/// C2 §2.5.4: the RFM on the bent plate with complete data identifies the stiff strip's E in one
/// step (to 1e-8), the thick strip's thickness after iterating; three DOFs leave it wrong.
#[test]
fn bent_plate_rfm_reproduces_c2() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(&pipeline("bent-plate-rfm"), &tmp.path().join("cache"), &[]);
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    for (name, v) in results(&out, "rfm_e_complete") {
        assert!((v / 210e9 - 1.0).abs() < 1e-8, "{name} = {v}");
    }
    assert_eq!(meta(&out, "rfm_e_complete", "iterations"), 2);
    for (name, v) in results(&out, "rfm_t_complete") {
        assert!((v / 1.4e-3 - 1.0).abs() < 1e-8, "{name} = {v}");
    }
    let e7 = results(&out, "rfm_e_three_dofs")["e7"];
    assert!(e7 / 210e9 - 1.0 > 0.1, "e7 = {e7}");
}

/// C2 §6.5: damping identification on the free-free bent plate (Craig-Bampton predictions, 15 %
/// zero-mean noise). From six FRFs the perturbed loss factors of the first four elastic modes
/// (0.03 … 0.015, truth 0.01) come back within 10 % and the unperturbed ones stay within 10 %,
/// converged in at most 5 iterations; rigid-body modes are never parameters. From α_11 alone
/// the estimates scatter more (this seed: within 19 %; over 20 seeds,
/// `sweeps/bent-plate-damping-seeds.yaml`, 135 of 140 estimates are within 10 %, median 3 %). A viscous model fitted to the
/// structurally damped data gives `2ζ_r` within 10 % of `η_r`. Noise read on `[0, 1]` biases
/// every amplitude up and so every loss factor down.
#[test]
fn bent_plate_damping_reproduces_c2() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(
        &pipeline("bent-plate-damping"),
        &tmp.path().join("cache"),
        &[],
    );
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    let identified = |stage: &str| -> Vec<(i64, f64)> {
        let a = read_dir(&out.join(stage).join("result")).unwrap();
        let t = a.table("modal_damping").unwrap();
        let modes = t.i64s("modal_damping", "mode").unwrap();
        let eq = t.f64s("modal_damping", "equivalent_loss_factor").unwrap();
        modes.iter().copied().zip(eq.iter().copied()).collect()
    };
    let worst = |stage: &str| {
        identified(stage)
            .iter()
            .map(|(_, v)| (v / 0.01 - 1.0).abs())
            .fold(0.0, f64::max)
    };
    let six = identified("eta_six_frfs");
    assert_eq!(
        six.first().map(|m| m.0),
        Some(7),
        "mode 7 is the first elastic mode"
    );
    assert_eq!(six.len(), 7, "the elastic modes in 0-100 Hz");
    assert!(worst("eta_six_frfs") < 0.10, "{six:?}");
    for stage in ["eta_six_frfs", "eta_one_frf", "zeta_from_structural"] {
        assert_eq!(meta(&out, stage, "stop"), "converged", "{stage}");
        assert!(meta(&out, stage, "iterations").as_u64().unwrap() <= 5);
    }
    assert!(
        worst("eta_one_frf") < 0.20,
        "{:?}",
        identified("eta_one_frf")
    );
    assert!(worst("zeta_from_structural") < 0.10);
    assert_eq!(
        meta(&out, "zeta_from_structural", "damping_model"),
        "viscous"
    );
    let biased = identified("eta_six_frfs_biased");
    assert!(biased.iter().all(|(_, v)| *v < 0.0099), "{biased:?}");
    check_golden(
        "bent-plate-damping",
        &out,
        &[
            "eta_six_frfs/result",
            "eta_one_frf/result",
            "zeta_from_structural/result",
            "eta_six_frfs_biased/result",
        ],
    );
}

/// C4 (thesis §7.1): on the two-substructure Craig-Bampton model with subset selection
/// (κ = 5e7) the P-C raises the correlation above 0.95; the out-of-plane clamp stiffnesses,
/// which in-plane measurements cannot see, are never selected; the clamps' y stiffness of
/// beams 1 and 2 falls from 1e7 toward the true 3e6 N/m. The sensitive-region search records
/// a move for each named spring. (The joint and the masses drift: see the pipeline.)
/// The Laplace posterior shows why (issue 28): the out-of-plane parameters are unidentified
/// on their own (no correlation: the data do not see them), and the in-plane ones lie on
/// ridges — a joint or mass parameter correlated beyond ±0.9 with another parameter that
/// compensates it — which the run report names.
#[test]
fn three_beam_reproduces_c4() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (plan, report, cache) = run(&pipeline("three-beam"), &tmp.path().join("cache"), &[]);
    let lock = femu::pipeline::lock::LockFile::from_run(&plan, &report);
    femu::pipeline::executor::materialise_with_lock(&report, &cache, &out, Some(&lock)).unwrap();
    let a = read_dir(&out.join("pc").join("result")).unwrap();
    let chi = a.table("iterations").unwrap();
    let chi = chi.f64s("iterations", "mean_chi").unwrap();
    assert!(chi[0] < 0.85 && *chi.last().unwrap() > 0.95, "{chi:?}");
    let v = results(&out, "pc");
    assert_eq!(v.len(), 30);
    for c in 1..=3 {
        for dir in ["kz", "krx", "kry"] {
            let name = format!("c{c}_{dir}");
            let initial = if dir == "kz" { 1e7 } else { 1e5 };
            assert_eq!(v[&name], initial, "{name}");
        }
    }
    for name in ["c1_ky", "c2_ky"] {
        assert!(v[name] < 5e6 && v[name] > 1e6, "{name} = {}", v[name]);
    }
    let moves = meta(&out, "sensitive_regions", "sensitive_start");
    assert_eq!(moves.as_array().map(|m| m.len()), Some(6), "{moves}");
    let damping = read_dir(&out.join("damping").join("result")).unwrap();
    let t = damping.table("modal_damping").unwrap();
    assert_eq!(*t.i64s("modal_damping", "mode").unwrap(), [1, 2]);
    // The parameters no step selected are named: the out-of-plane stiffnesses of the P-C, and
    // the loss factor of mode 2 (53.5 Hz, out of plane), which the in-plane measurements do
    // not see.
    let unchanged = |stage: &str| -> String {
        let warnings = meta(&out, stage, "update_warnings");
        let warnings = warnings.as_array().cloned().unwrap_or_default();
        let found = warnings.iter().filter_map(|w| w.as_str());
        found.filter(|w| w.contains("never selected")).collect()
    };
    let pc = unchanged("pc");
    assert!(
        pc.starts_with("15 of 30 parameters were never selected in 25 iterations")
            && pc.contains("c1_kz, c1_krx, c1_kry"),
        "{pc}"
    );
    assert!(
        unchanged("damping").starts_with("1 of 2 parameters was never selected")
            && unchanged("damping").contains("keeps its start value: eta_2 "),
        "{}",
        unchanged("damping")
    );

    let view = femu::run_report::collect(&out, &Default::default()).unwrap();
    let post = view
        .posteriors
        .iter()
        .find(|p| p.id == "pc.posterior")
        .unwrap();
    let index = |name: &str| post.parameters.iter().position(|p| p.name == name).unwrap();
    let (kz, ky) = (index("c1_kz"), index("c1_ky"));
    assert!(
        post.correlation[kz][ky].is_none(),
        "{:?}",
        post.correlation[kz]
    );
    let compensating = |n: &str| n.starts_with('j') || n.starts_with('m');
    assert!(
        post.ridges
            .iter()
            .any(|(a, b, r)| (compensating(a) || compensating(b)) && r.abs() > 0.9),
        "{:?}",
        post.ridges
    );
    assert!(post.ridges.iter().all(|(a, b, _)| {
        !["kz", "krx", "kry"]
            .iter()
            .any(|d| a.ends_with(d) && a.starts_with('c') || b.ends_with(d) && b.starts_with('c'))
    }));
}

/// A one-parameter model that the stub method below never evaluates.
struct Untouched(Vec<femu::updating::UpdatingParameter>);

impl femu::updating::ParametricModel for Untouched {
    fn parameters(&self) -> &[femu::updating::UpdatingParameter] {
        &self.0
    }
    fn evaluate(
        &self,
        _: &[f64],
    ) -> Result<femu::updating::Evaluated, femu::updating::UpdatingError> {
        Err(femu::updating::UpdatingError::Settings(
            "the stub model is never evaluated".into(),
        ))
    }
}

/// A method whose every step leads away from its optimum at x = 1: the merit `1/(1 + (x−1)²)`
/// falls at each step, even halved, as the undamped P-C's does when a measured line sits on a
/// resonance.
struct Diverging;

impl femu::updating::UpdateMethod for Diverging {
    fn iterate(
        &self,
        _: &dyn femu::updating::ParametricModel,
        values: &[f64],
        iteration: usize,
    ) -> Result<femu::updating::Step, femu::updating::UpdatingError> {
        let merit = 1.0 / (1.0 + (values[0] - 1.0).powi(2));
        let record = femu::updating::IterationRecord {
            iteration,
            values: values.to_vec(),
            relative_change: vec![0.5],
            active: vec![true],
            lines_used: 1,
            mean_chi_s: merit,
            mean_chi_a: merit,
            residual_norm: 0.0,
            condition_limit: f64::NAN,
            smoothing: 0.0,
            smoothed_mean_chi: f64::NAN,
            diagnostics: Default::default(),
        };
        Ok(femu::updating::Step::new(record, None))
    }
    fn merit(&self, record: &femu::updating::IterationRecord) -> Option<f64> {
        Some(record.mean_chi())
    }
}

/// A method that steps toward x = 1 (10 % of x a step) and stops, converged, at its third
/// analysis.
struct Approaching;

impl femu::updating::UpdateMethod for Approaching {
    fn iterate(
        &self,
        model: &dyn femu::updating::ParametricModel,
        values: &[f64],
        iteration: usize,
    ) -> Result<femu::updating::Step, femu::updating::UpdatingError> {
        let mut step = Diverging.iterate(model, values, iteration)?;
        step.record.relative_change = vec![-0.1];
        if iteration == 2 {
            step.stop = Some(femu::updating::StopReason::Converged);
        }
        Ok(step)
    }
    fn merit(&self, record: &femu::updating::IterationRecord) -> Option<f64> {
        Some(record.mean_chi())
    }
}

/// In a continuation the best iterate returned by a later phase is numbered in the whole
/// update, and the warning says so; an earlier phase's warning is kept, named by its phase.
#[test]
fn phases_number_the_returned_iterate_on_and_keep_every_warning() {
    let model = Untouched(vec![femu::updating::UpdatingParameter {
        name: "x".into(),
        initial: 1.2,
        lower: 0.1,
        upper: 100.0,
    }]);
    // Approaching: analyses 0, 1 and its closing 2 (which gives way to the next phase's 0);
    // Diverging: analyses 2, 3, 4 of the whole update, its best returned.
    let h = femu::updating::run_phases(&[&Approaching, &Diverging], &model, &[1.2], 4).unwrap();
    let numbers: Vec<usize> = h.iterations.iter().map(|r| r.iteration).collect();
    assert_eq!(numbers, [0, 1, 2, 3, 4]);
    let merit = |i: usize| h.iterations[i].mean_chi();
    let best = (2..5)
        .max_by(|&a, &b| merit(a).total_cmp(&merit(b)))
        .unwrap();
    assert!(merit(best) > merit(4));
    assert_eq!(h.returned_iteration, Some(best));
    assert_eq!(h.final_values, h.iterations[best].values);
    assert_eq!(h.warnings.len(), 1, "{:?}", h.warnings);
    assert!(
        h.warnings[0].contains(&format!("at iteration {best},")),
        "{:?}",
        h.warnings
    );
    // Diverging first: its warning is phase 1's; the start is returned to phase 2.
    let h = femu::updating::run_phases(&[&Diverging, &Approaching], &model, &[1.2], 6).unwrap();
    assert!(
        h.warnings.len() == 1 && h.warnings[0].starts_with("phase 1 of 2: the update ended"),
        "{:?}",
        h.warnings
    );
}

#[test]
fn an_update_that_ends_worse_than_it_began_returns_its_best_iterate() {
    let model = Untouched(vec![femu::updating::UpdatingParameter {
        name: "x".into(),
        initial: 1.2,
        lower: 0.1,
        upper: 100.0,
    }]);
    let h = femu::updating::run(&Diverging, &model, 4).unwrap();
    assert_eq!(h.stop, femu::updating::StopReason::MaxIterations);
    let last = h.iterations.last().unwrap();
    assert!(
        last.values[0] > 1.2,
        "the stub must diverge: {:?}",
        last.values
    );
    assert!(last.mean_chi() < h.iterations[0].mean_chi());
    // The start was the best iterate: its values are returned, and the result says so.
    assert_eq!(h.returned_iteration, Some(0));
    assert_eq!(h.final_values, vec![1.2]);
    let a = femu::artefact::update::update_result_to_artefact(&h, "pc");
    assert_eq!(a.meta["returned_iteration"], serde_json::json!(0));
    // The warning is the result's, so that a cached result tells it again.
    assert_eq!(h.warnings.len(), 1, "{:?}", h.warnings);
    assert!(
        h.warnings[0].contains("worse than it began") && h.warnings[0].contains("iteration 0"),
        "{:?}",
        h.warnings
    );
    assert_eq!(
        a.meta["update_warnings"],
        serde_json::json!(h.warnings),
        "{:?}",
        a.meta
    );
    let shown = femu::run_report::record::meta_warnings(&a.meta);
    assert_eq!(shown, h.warnings);
}

/// Old parameter spellings still read, for one release: `femu validate` and `femu run` warn and
/// name the new spelling, and the stage's checked parameters (its cache key) are those of the new
/// spelling, so the shipped pipeline's result is reused as it is.
#[test]
fn old_parameter_spellings_warn_and_mean_the_same() {
    let tmp = tempfile::tempdir().unwrap();
    let shipped = std::fs::read_to_string(pipeline("four-dof-rfm")).unwrap();
    assert!(shipped.contains("      modes: {count: 3}\n"));
    let old = tmp.path().join("old.yaml");
    std::fs::write(
        &old,
        shipped.replacen("      modes: {count: 3}\n", "      mode_count: 3\n", 1),
    )
    .unwrap();
    let warning = "`with.mode_count` is deprecated and will be removed in the next release: write `with.modes.count`";
    let validate = femu()
        .args(["validate", old.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&validate.stderr);
    assert!(validate.status.success(), "{stderr}");
    assert!(
        stderr.contains(warning) && stderr.contains("frf.synthesise"),
        "{stderr}"
    );
    let run = |path: &Path| {
        femu()
            .args(["run", path.to_str().unwrap(), "--only", "from_3_modes"])
            .env("FEMU_CACHE_DIR", tmp.path().join("cache"))
            .output()
            .unwrap()
    };
    let first = run(&pipeline("four-dof-rfm"));
    assert!(first.status.success());
    assert!(!String::from_utf8_lossy(&first.stderr).contains("deprecated"));
    let again = run(&old);
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(again.status.success(), "{stderr}");
    assert!(stderr.contains(warning), "{stderr}");
    assert!(
        stderr.contains("from_3_modes (frf.synthesise): cached"),
        "{stderr}"
    );
}

/// `band_hz` and `exclude_hz` restrict an update to the lines chosen: on the C1 chain the
/// posterior's predictive band (one row per used line and FRF) holds only lines inside the band
/// and outside the excluded one; a band that leaves no measured line is the user's error,
/// naming the field and the lines there are.
#[test]
fn update_uses_only_the_chosen_lines() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let sets = ["pc.band_hz=[2.0, 15.0]", "pc.exclude_hz=[[9.0, 10.5]]"];
    let (_, report, cache) = run(
        &pipeline("four-dof-bayes"),
        &tmp.path().join("cache"),
        &sets,
    );
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    let post = read_dir(&out.join("pc").join("posterior")).unwrap();
    let band = post.table("frf_band").unwrap();
    let f = band.f64s("frf_band", "freq_hz").unwrap();
    assert!(!f.is_empty());
    assert!(
        f.iter()
            .all(|&x| (2.0..=15.0).contains(&x) && !(9.0..=10.5).contains(&x)),
        "{f:?}"
    );
    let full = read_dir(&out.join("pc_estimated").join("posterior")).unwrap();
    let g = full
        .table("frf_band")
        .unwrap()
        .f64s("frf_band", "freq_hz")
        .unwrap()
        .to_vec();
    assert!(
        g.iter().any(|&x| x > 15.0),
        "the other stage keeps every line"
    );

    let plan = load(&pipeline("four-dof-bayes"), &["pc.band_hz=[100.0, 200.0]"]);
    let cache = femu::cache::Cache::open(&tmp.path().join("cache2")).unwrap();
    let opts = femu::pipeline::RunOptions {
        progress: femu::pipeline::ProgressMode::Quiet,
        ..Default::default()
    };
    let e = femu::pipeline::execute(&plan, &cache, &opts).unwrap_err();
    assert!(e.is_input(), "{e}");
    let text = format!("{e:#}");
    assert!(
        text.contains("band_hz") && text.contains("0.5 to 40 Hz"),
        "{text}"
    );
}
