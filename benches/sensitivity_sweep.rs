//! The P-C's sensitivity sweep (docs/theory.md §3): `∂H/∂φ` for every parameter, measured pair and
//! frequency line from a modal basis, the size by default — 100 modes (`2m`), 50
//! parameters, 10 FRFs, 1000 lines (`cargo bench --bench sensitivity_sweep [modes params
//! frfs lines]`). Prints the time, the rate of the flops actually done, and the rate a direct
//! evaluation of the thesis's double sum (4.5) would need for the same answer in the same time.

use faer::Mat;
use femu::core::{Component, DofId};
use femu::frf::{FrfSet, ModalDamping, Quantity};
use femu::sensitivity::{ModalFrfModel, ProjectedDerivative, frf_sensitivities};

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let arg = |i: usize, d: usize| args.get(i).copied().unwrap_or(d);
    let (m, np, nq, nf) = (arg(0, 100), arg(1, 50), arg(2, 10), arg(3, 1000));
    // Deterministic pseudo-random data: eigenvalues spread over 1..400 Hz.
    let lambda: Vec<f64> = (0..m)
        .map(|r| (2.0 * std::f64::consts::PI * (1.0 + 4.0 * r as f64)).powi(2))
        .collect();
    let dofs: Vec<DofId> = (1..=nq as u64)
        .map(|n| DofId::new(n, Component::Uz))
        .collect();
    let shapes = Mat::from_fn(nq, m, |i, r| {
        (((i * 31 + r * 17) % 23) as f64 - 11.0) / 11.0
    });
    let derivatives: Vec<ProjectedDerivative> = (0..np)
        .map(|p| {
            let sym = |i: usize, j: usize, s: usize| {
                (((i.min(j) * 13 + i.max(j) * 7 + p * s) % 29) as f64 - 14.0) / 14.0
            };
            ProjectedDerivative {
                k: Mat::from_fn(m, m, |i, j| sym(i, j, 3) * lambda[i.max(j)]),
                m: Mat::from_fn(m, m, |i, j| sym(i, j, 5)),
            }
        })
        .collect();
    let damping = ModalDamping::Structural(vec![0.01]);
    let model = ModalFrfModel {
        eigenvalues: &lambda,
        shapes: shapes.as_ref(),
        dofs: &dofs,
        damping: &damping,
    };
    let pairs = FrfSet::all_pairs(&dofs, &dofs[..1]);
    let pairs: Vec<_> = pairs.into_iter().take(nq).collect();
    // Lines between the resonances (never on one: the model is lightly damped anyway).
    let freqs: Vec<f64> = (0..nf).map(|k| 0.5 + 0.4 * k as f64 + 0.013).collect();
    let t0 = std::time::Instant::now();
    let s = frf_sensitivities(
        &model,
        &pairs,
        &freqs,
        Quantity::Receptance,
        &derivatives,
        None,
    )
    .expect("the synthetic model is well formed");
    let secs = t0.elapsed().as_secs_f64();
    std::hint::black_box(&s);
    let (m_, np_, nq_, nf_) = (m as f64, np as f64, nq as f64, nf as f64);
    // Done: the ω-independent coefficients (np·nq·m·m·2 for Cᵀφ) and the real×complex GEMM.
    let done = np_ * nq_ * m_ * m_ * 4.0 + 2.0 * 2.0 * (np_ * nq_) * (2.0 * m_) * nf_;
    // Direct double sum per line, parameter and pair: m² complex multiply-adds (8 flops).
    let naive = nf_ * np_ * nq_ * m_ * m_ * 8.0;
    println!(
        "modes {m}, parameters {np}, FRFs {nq}, lines {nf}: {secs:.3} s, {:.1} GFLOP/s done, {:.1} GFLOP/s equivalent of the direct double sum",
        done / secs / 1e9,
        naive / secs / 1e9
    );
}
