//! Moving a lumped parameter's starting value into its sensitive region (thesis §5.4, 5.10–5.12:
//! (5.10), (5.11), (5.12)).
//!
//! A boundary or joint spring whose initial estimate is far too stiff or too soft hardly moves
//! any eigenvalue, so no sensitivity-based method sees it. Measured against the unity-based
//! sensitivity `s_r(φ) = (φ/λ_r) ∂λ_r/∂φ` of the modes that matter, a stiffness has a sensitive
//! region: `s_r` rises from 0 (spring too soft to matter) to a peak and falls back to 0 (spring
//! as good as rigid). The peak is a root of
//! `ds_r/d ln φ = s_r + (φ²/λ_r) ∂²λ_r/∂φ² − s_r²`, which needs the second-order eigenvalue
//! sensitivity (5.12). For a parameter entering `K` and `M` linearly (5.11: springs, masses),
//! on a complete modal basis,
//! `∂²λ_r/∂φ² = 2 Σ_{s≠r} (φ_sᵀ(K' − λ_r M')φ_r)² / (λ_r − λ_s) − 2 (∂λ_r/∂φ) φ_rᵀM'φ_r`.
//!
//! The search scans `ln φ` between the bounds, keeps the grid point where `Σ_r s_r` is largest,
//! and refines the root of its derivative by bisection.

use super::model::{ParametricModel, UpdatingError};
use crate::eigen::ModeSelection;
use crate::sensitivity::ProjectedDerivative;

/// Unity-based first and second eigenvalue sensitivities of mode `r`, from projections already
/// scaled by the parameter value (`φ Φᵀ K' Φ`, `φ Φᵀ M' Φ`) on a complete basis:
/// `(φ ∂λ_r/∂φ, φ² ∂²λ_r/∂φ²)`. Pairs of modes closer than `1e-9 λ_r` (repeated
/// eigenvalues) are skipped: the expansion has no limit there.
pub fn eigenvalue_sensitivities_1_2(
    eigenvalues: &[f64],
    scaled: &ProjectedDerivative,
    r: usize,
) -> (f64, f64) {
    let lr = eigenvalues[r];
    let first = scaled.k[(r, r)] - lr * scaled.m[(r, r)];
    let mut second = -2.0 * first * scaled.m[(r, r)];
    for (s, &ls) in eigenvalues.iter().enumerate() {
        if s == r || (lr - ls).abs() <= 1e-9 * lr.abs().max(ls.abs()) {
            continue;
        }
        let a = scaled.k[(s, r)] - lr * scaled.m[(s, r)];
        second += 2.0 * a * a / (lr - ls);
    }
    (first, second)
}

/// Where one parameter's sensitive region lies.
#[derive(Clone, Debug, PartialEq)]
pub struct SensitiveStart {
    /// Index of the parameter.
    pub parameter: usize,
    /// Its value before.
    pub before: f64,
    /// The value where `Σ_r s_r` peaks (within the bounds).
    pub value: f64,
    /// `Σ_r s_r` there.
    pub sensitivity: f64,
    /// `Σ_r s_r` at the value before.
    pub sensitivity_before: f64,
}

/// `Σ_r s_r` and its derivative in `ln φ` for parameter `p` at `values`.
fn unity_sensitivity(
    model: &dyn ParametricModel,
    values: &[f64],
    p: usize,
    modes: &[usize],
) -> Result<(f64, f64), UpdatingError> {
    let (state, _) = model.modal_state(values, ModeSelection::All)?;
    let lambdas = &state.modes.eigenvalues;
    let mut s = 0.0;
    let mut ds = 0.0;
    for &r in modes {
        let Some(&lr) = lambdas.get(r) else {
            return Err(UpdatingError::Settings(format!(
                "sensitive_start: mode {} is not among the model's {} modes",
                r + 1,
                lambdas.len()
            )));
        };
        if lr <= 0.0 {
            return Err(UpdatingError::Settings(format!(
                "sensitive_start: mode {} is a rigid-body mode; name elastic modes",
                r + 1
            )));
        }
        let (first, second) = eigenvalue_sensitivities_1_2(lambdas, &state.projected[p], r);
        let sr = first / lr;
        s += sr;
        ds += sr + second / lr - sr * sr;
    }
    Ok((s, ds))
}

/// Moves parameter `p` (all others at `values`) to the peak of the summed unity eigenvalue
/// sensitivity of `modes` (0-based) within its bounds: a scan of `points_per_decade` points
/// per decade of `ln φ`, then bisection on the derivative (5.12) to a relative `1e-4`.
/// Needs a model whose complete modal basis is affordable (a small or a reduced model).
pub fn sensitive_start(
    model: &dyn ParametricModel,
    values: &[f64],
    p: usize,
    modes: &[usize],
    points_per_decade: usize,
) -> Result<SensitiveStart, UpdatingError> {
    let info = &model.parameters()[p];
    if !(info.lower > 0.0 && info.upper > info.lower && info.upper.is_finite()) {
        return Err(UpdatingError::Settings(format!(
            "sensitive_start: parameter `{}` needs finite positive bounds (it has [{:e}, {:e}])",
            info.name, info.lower, info.upper
        )));
    }
    let at = |v: f64| {
        let mut x = values.to_vec();
        x[p] = v;
        x
    };
    let (lo, hi) = (info.lower.ln(), info.upper.ln());
    let n =
        (((hi - lo) / std::f64::consts::LN_10) * points_per_decade.max(1) as f64).ceil() as usize;
    let grid: Vec<f64> = (0..=n.max(2))
        .map(|k| lo + (hi - lo) * k as f64 / n.max(2) as f64)
        .collect();
    let mut table = Vec::with_capacity(grid.len());
    for &u in &grid {
        table.push(unity_sensitivity(model, &at(u.exp()), p, modes)?);
    }
    let (best, _) =
        table
            .iter()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |(bi, bs), (i, &(s, _))| {
                if s > bs { (i, s) } else { (bi, bs) }
            });
    // Bracket the root of ds/du around the best grid point: + on the left, − on the right.
    let mut u = grid[best];
    let mut s_best = table[best].0;
    let left = (best > 0 && table[best - 1].1 > 0.0 && table[best].1 < 0.0).then(|| best - 1);
    let right =
        (best + 1 < grid.len() && table[best].1 > 0.0 && table[best + 1].1 < 0.0).then_some(best);
    if let Some(i) = left.or(right) {
        let (mut a, mut b) = (grid[i], grid[i + 1]);
        while (b - a) > 1e-4 {
            let m = 0.5 * (a + b);
            let (s, ds) = unity_sensitivity(model, &at(m.exp()), p, modes)?;
            if ds > 0.0 {
                a = m;
            } else {
                b = m;
            }
            if s > s_best {
                (u, s_best) = (m, s);
            }
        }
    }
    let before = values[p];
    Ok(SensitiveStart {
        parameter: p,
        before,
        value: u.exp().clamp(info.lower, info.upper),
        sensitivity: s_best,
        sensitivity_before: unity_sensitivity(model, values, p, modes)?.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::lumped::{LumpedTarget, assemble_lumped, lumped_derivative};
    use crate::model::LumpedModel;
    use crate::updating::{LinearModel, UpdatingParameter};

    /// The four-mass chain with its left grounding spring (1e4 N/m) as the parameter.
    fn chain_with_ground_spring(k: f64) -> LinearModel {
        let mut lumped = LumpedModel::chain(&[1.0; 4], 1e4);
        lumped.springs[0].stiffness = k;
        let sys = assemble_lumped(&lumped).unwrap();
        let (dk, dm) = lumped_derivative(&lumped, LumpedTarget::Spring(0)).unwrap();
        LinearModel::new(
            sys,
            vec![(
                UpdatingParameter {
                    name: "k0".into(),
                    initial: k,
                    lower: 1.0,
                    upper: 1e9,
                },
                dk,
                dm,
            )],
        )
        .unwrap()
    }

    fn eigenvalue(k: f64, r: usize) -> f64 {
        let m = chain_with_ground_spring(k);
        let (state, _) = m.modal_state(&[k], ModeSelection::All).unwrap();
        state.modes.eigenvalues[r]
    }

    /// (5.12) against central differences of the eigenvalue, for every mode: the first
    /// derivative to 1e-6, the second to 1e-4 (step 1e-3 k: truncation ~1e-6, round-off
    /// ~1e-16 λ / h² ≈ 1e-6 relative).
    #[test]
    fn second_order_eigenvalue_sensitivity_matches_central_differences() {
        let k = 2e4;
        let model = chain_with_ground_spring(k);
        let (state, _) = model.modal_state(&[k], ModeSelection::All).unwrap();
        let h = 1e-3 * k;
        for r in 0..4 {
            let (first, second) =
                eigenvalue_sensitivities_1_2(&state.modes.eigenvalues, &state.projected[0], r);
            let (lm, l0, lp) = (eigenvalue(k - h, r), eigenvalue(k, r), eigenvalue(k + h, r));
            let fd1 = k * (lp - lm) / (2.0 * h);
            let fd2 = k * k * (lp - 2.0 * l0 + lm) / (h * h);
            assert!(
                (first - fd1).abs() < 1e-6 * fd1.abs(),
                "mode {r}: {first} vs {fd1}"
            );
            assert!(
                (second - fd2).abs() < 1e-4 * fd2.abs(),
                "mode {r}: {second} vs {fd2}"
            );
        }
    }

    /// The peak of the first mode's unity sensitivity to the grounding spring: the search's
    /// value is a stationary point of `s(ln k)` (checked by finite differences of `s` itself),
    /// and higher than the sensitivity at a spring 1000× too stiff.
    #[test]
    fn the_search_lands_on_the_peak_of_the_unity_sensitivity() {
        let stiff = 1e7;
        let model = chain_with_ground_spring(stiff);
        let found = sensitive_start(&model, &[stiff], 0, &[0], 4).unwrap();
        assert!(
            found.sensitivity > 10.0 * found.sensitivity_before,
            "{found:?}"
        );
        let s = |k: f64| unity_sensitivity(&model, &[k], 0, &[0]).unwrap().0;
        let (v, e) = (found.value, 1e-2);
        assert!(
            s(v) >= s(v * (1.0 + e)) && s(v) >= s(v / (1.0 + e)),
            "{found:?}"
        );
        assert!(found.value > 1e3 && found.value < 1e6, "{found:?}");
    }
}
