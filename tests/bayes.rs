//! The Laplace posterior of an update (docs/theory.md §12, issue 28): its credible intervals
//! cover the truth as often as they claim on the C1 four-DOF chain with known noise, and the
//! shipped pipeline `four-dof-bayes` writes the `posterior` artefact.

mod common;

use common::*;
use femu::artefact::codec::read_dir;
use femu::artefact::kinds::check_layout;
use femu::eigen::ModeSelection;
use femu::fe::lumped::{LumpedTarget, assemble_lumped, lumped_derivative};
use femu::frf::{
    DirectDamping, FrfSet, ModalDamping, NoiseModel, Quantity, add_noise, direct_receptance,
    frequency_lines,
};
use femu::model::LumpedModel;
use femu::stages::update::snr_sigmas;
use femu::updating::pc::{PcSettings, PredictorCorrector};
use femu::updating::posterior::{ModalFrfLikelihood, Noise, PosteriorSettings, laplace};
use femu::updating::{LinearModel, ParametricModel, UpdateMethod, UpdatingParameter};
use rayon::prelude::*;

const ETA: f64 = 0.02;
const SNR_DB: f64 = 30.0;

fn chain(masses: &[f64]) -> LinearModel {
    let lumped = LumpedModel::chain(masses, 1e4);
    let sys = assemble_lumped(&lumped).unwrap();
    let params = (0..masses.len())
        .map(|i| {
            let (dk, dm) = lumped_derivative(&lumped, LumpedTarget::Mass(i)).unwrap();
            let p = UpdatingParameter {
                name: format!("m{}", i + 1),
                initial: masses[i],
                lower: 0.01,
                upper: 100.0,
            };
            (p, dk, dm)
        })
        .collect();
    LinearModel::new(sys, params).unwrap()
}

fn clean(freqs: &[f64]) -> FrfSet {
    let sys = assemble_lumped(&LumpedModel::chain(&[1.0; 4], 1e4)).unwrap();
    let pairs = FrfSet::all_pairs(&sys.dofs, &sys.dofs[..1]);
    let damping = DirectDamping {
        structural_eta: ETA,
        rayleigh: None,
    };
    direct_receptance(&sys, &damping, &pairs, freqs, Quantity::Receptance).unwrap()
}

/// Coverage (issue 28, reduced size): the C1 chain, truth all masses 1 kg, analytical model
/// m2 = 1.3 kg, the four masses updated by the P-C from four receptances (excitation at mass 1)
/// on 0.5–40 Hz every 0.5 Hz (80 lines, 640 data) with a loss factor of 0.02 and complex
/// Gaussian noise at 30 dB SNR (`noise.add`'s model, σ known per FRF). Over 400 noise seeds the
/// 90 % credible interval of every mass contains the truth 90 ± 5 % of the time, and so do the
/// four masses pooled to ±4 % (the masses share their seeds, so the 1600 intervals are not
/// independent; this run gives 0.887, 0.882, 0.885, 0.865, pooled 0.880). The mean standard deviation is also checked
/// against the spread of the posterior means across seeds (the frequentist error) to 15 %.
#[test]
fn credible_intervals_of_the_masses_cover_the_truth() {
    let freqs = frequency_lines(0.5, 40.0, 0.5);
    let x0 = clean(&freqs);
    let sigma = snr_sigmas(&x0, SNR_DB);
    let model = chain(&[1.0, 1.3, 1.0, 1.0]);
    let seeds: Vec<u64> = (0..400).collect();
    let per_seed: Vec<(Vec<bool>, Vec<f64>, Vec<f64>)> = seeds
        .par_iter()
        .map(|&seed| {
            let mut x = x0.clone();
            add_noise(&mut x, &NoiseModel::Gaussian { snr_db: SNR_DB }, seed);
            let settings = PcSettings {
                damping: ModalDamping::Structural(vec![ETA; 4]),
                merit_steps: true,
                ..Default::default()
            };
            let pc = PredictorCorrector::new(&x, settings);
            let phases: [&dyn UpdateMethod; 1] = [&pc];
            let h =
                femu::updating::run_phases(&phases, &model, &model.initial_values(), 20).unwrap();
            let lik = ModalFrfLikelihood::new(
                &model,
                &x,
                (0..freqs.len()).collect(),
                ModeSelection::All,
                ModalDamping::Structural(vec![ETA; 4]),
            );
            let post = laplace(
                &lik,
                model.parameters(),
                &h.final_values,
                &PosteriorSettings {
                    noise: Noise::Absolute(sigma.clone()),
                    refine_iterations: 10,
                    samples: 0,
                    predictive_samples: 0,
                    ..Default::default()
                },
                None,
            )
            .unwrap();
            assert!(
                post.refinement.converged,
                "seed {seed}: {:?}",
                post.refinement
            );
            let m = &post.marginals;
            (
                m.iter().map(|m| m.lower <= 1.0 && 1.0 <= m.upper).collect(),
                m.iter().map(|m| m.mean).collect(),
                m.iter().map(|m| m.sd).collect(),
            )
        })
        .collect();
    let n = per_seed.len() as f64;
    let mut pooled = 0.0;
    for j in 0..4 {
        let hits = per_seed.iter().filter(|s| s.0[j]).count() as f64;
        pooled += hits;
        let coverage = hits / n;
        assert!(
            (coverage - 0.9).abs() <= 0.05,
            "m{}: coverage {coverage}",
            j + 1
        );
        let mean = per_seed.iter().map(|s| s.1[j]).sum::<f64>() / n;
        let spread = (per_seed
            .iter()
            .map(|s| (s.1[j] - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0))
            .sqrt();
        let sd = per_seed.iter().map(|s| s.2[j]).sum::<f64>() / n;
        assert!(
            (sd / spread - 1.0).abs() < 0.15,
            "m{}: posterior sd {sd:e} against the spread of the means {spread:e}",
            j + 1
        );
        eprintln!(
            "m{}: coverage {coverage:.3}, mean {mean:.5}, sd {sd:.3e}, spread {spread:.3e}",
            j + 1
        );
    }
    let pooled = pooled / (4.0 * n);
    assert!((pooled - 0.9).abs() <= 0.04, "pooled coverage {pooled}");
}

/// The shipped pipeline `four-dof-bayes`: the update writes a `posterior` artefact that fits
/// its layout, with a mean within four standard deviations of the truth for every mass, a
/// symmetric correlation matrix with unit diagonal, four directions, 1000 samples per mass,
/// the natural-frequency bands of the four modes (first order and sampled agreeing to 25 %)
/// and the |H| band at every line; the posterior with estimated noise finds σ within 15 % of
/// the known one.
#[test]
fn four_dof_bayes_pipeline_writes_the_posterior() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(&pipeline("four-dof-bayes"), &tmp.path().join("cache"), &[]);
    femu::pipeline::materialise(&report, &cache, &out).unwrap();
    let a = read_dir(&out.join("pc").join("posterior")).unwrap();
    check_layout(&a).unwrap();
    let t = a.table("parameters").unwrap();
    let (mean, sd) = (
        t.f64s("parameters", "mean").unwrap(),
        t.f64s("parameters", "sd").unwrap(),
    );
    assert_eq!(mean.len(), 4);
    for j in 0..4 {
        assert!(sd[j] > 0.0 && sd[j] < 0.05, "m{}: sd {}", j + 1, sd[j]);
        assert!(
            (mean[j] - 1.0).abs() < 4.0 * sd[j],
            "m{}: {}",
            j + 1,
            mean[j]
        );
    }
    let c = a.table("covariance").unwrap();
    let rho = c.f64s("covariance", "correlation").unwrap();
    for i in 0..4 {
        assert!((rho[i * 4 + i] - 1.0).abs() < 1e-12);
        for j in 0..4 {
            assert!((rho[i * 4 + j] - rho[j * 4 + i]).abs() < 1e-12);
            assert!(rho[i * 4 + j].abs() <= 1.0 + 1e-12);
        }
    }
    let d = a.table("directions").unwrap();
    assert_eq!(d.i64s("directions", "direction").unwrap().len(), 16);
    let s = a.table("samples").unwrap();
    assert_eq!(s.f64s("samples", "value").unwrap().len(), 4000);
    let nf = a.table("natural_frequencies").unwrap();
    let (lin, smp) = (
        nf.f64s("natural_frequencies", "sd_linear_hz").unwrap(),
        nf.f64s("natural_frequencies", "sd_sampled_hz").unwrap(),
    );
    assert_eq!(lin.len(), 4);
    for r in 0..4 {
        assert!(
            (smp[r] / lin[r] - 1.0).abs() < 0.25,
            "mode {}: {} vs {}",
            r + 1,
            smp[r],
            lin[r]
        );
    }
    let band = a.table("frf_band").unwrap();
    assert_eq!(band.f64s("frf_band", "abs").unwrap().len(), 4 * 159);
    assert_eq!(a.meta["predictive_samples"], 200);

    // Estimated noise against the known: σ per FRF as noise.add made it.
    let known = read_dir(&out.join("pc").join("posterior")).unwrap();
    let known = known
        .table("noise")
        .unwrap()
        .f64s("noise", "sigma")
        .unwrap()
        .to_vec();
    let e = read_dir(&out.join("pc_estimated").join("posterior")).unwrap();
    assert_eq!(e.meta["sigma_estimated"], true);
    let est = e
        .table("noise")
        .unwrap()
        .f64s("noise", "sigma")
        .unwrap()
        .to_vec();
    for (k, s) in known.iter().zip(&est) {
        assert!((s / k - 1.0).abs() < 0.15, "{s:e} vs {k:e}");
    }
}
