//! The linear algebra every updating method shares: parameter subset selection by QR with
//! column pivoting (5.13, 5.14), the extended weighted least-squares step (4.18, 4.19) with the
//! parameter weighting `W_φ` (4.22), and the diagnostics of `S` that expose non-uniqueness
//! (§2.6: singular values, condition number, null-space directions).

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::svd::{ComputeSvdVectors, svd, svd_scratch};
use faer::{Mat, MatRef, Par};

/// Singular values below this fraction of the largest count as zero (null space).
pub const NULL_SPACE_TOLERANCE: f64 = 1e-8;

/// What the SVD of a sensitivity matrix says.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Diagnostics {
    /// Singular values, descending.
    pub singular_values: Vec<f64>,
    /// `σ_max/σ_min`; infinite when the matrix is numerically rank-deficient,
    /// `σ_min ≤ max(m, n)·ε·σ_max` (LAPACK's rank tolerance): a larger ratio is round-off, not a
    /// property of the problem.
    pub condition: f64,
    /// Right singular vectors whose singular value is below [`NULL_SPACE_TOLERANCE`]·`σ_max`
    /// (one per direction, over all parameters): parameter combinations the data cannot see.
    pub null_space: Vec<Vec<f64>>,
    /// The least determined direction (right singular vector of the smallest singular value).
    pub weakest_direction: Vec<f64>,
}

/// SVD diagnostics of `s` (rows: equations, columns: parameters).
pub fn diagnostics(s: MatRef<'_, f64>) -> Diagnostics {
    let n = s.ncols();
    if n == 0 || s.nrows() == 0 {
        return Diagnostics::default();
    }
    // Pad to at least n rows so every right singular vector exists.
    let padded;
    let a = if s.nrows() < n {
        padded = Mat::from_fn(n, n, |i, j| if i < s.nrows() { s[(i, j)] } else { 0.0 });
        padded.as_ref()
    } else {
        s
    };
    let Some(svd) = thin_svd(a) else {
        return Diagnostics {
            singular_values: vec![f64::NAN; n],
            condition: f64::NAN,
            ..Default::default()
        };
    };
    let sv: Vec<f64> = svd.s[..n].to_vec();
    let v = svd.v.as_ref();
    let max = sv.first().copied().unwrap_or(0.0);
    let min = sv.last().copied().unwrap_or(0.0);
    let null_space = (0..n)
        .filter(|&i| sv[i] <= NULL_SPACE_TOLERANCE * max)
        .map(|i| sign_fixed((0..n).map(|r| v[(r, i)]).collect()))
        .collect();
    let rank_tolerance = s.nrows().max(n) as f64 * f64::EPSILON * max;
    Diagnostics {
        condition: if min > rank_tolerance {
            max / min
        } else {
            f64::INFINITY
        },
        weakest_direction: sign_fixed((0..n).map(|r| v[(r, n - 1)]).collect()),
        singular_values: sv,
        null_space,
    }
}

/// A direction with its largest entry positive (singular vectors have no sign of their own).
fn sign_fixed(mut v: Vec<f64>) -> Vec<f64> {
    let big = v
        .iter()
        .copied()
        .fold(0.0_f64, |a, b| if b.abs() > a.abs() { b } else { a });
    if big < 0.0 {
        v.iter_mut().for_each(|x| *x = -*x);
    }
    v
}

/// `κ_mn = 1 + κ (n/m)²` for an `m × n` sensitivity matrix (5.14).
pub fn subset_condition_limit(kappa: f64, rows: usize, cols: usize) -> f64 {
    let ratio = cols as f64 / rows.max(1) as f64;
    1.0 + kappa * ratio * ratio
}

/// Parameter subset selection (5.13, 5.14): columns of `s` in the pivot order of a QR
/// factorisation with column pivoting, taken while the condition number of the chosen columns
/// stays below `limit`. Zero columns are never chosen. Returns the chosen columns, ascending.
pub fn select_subset(s: MatRef<'_, f64>, limit: f64) -> Vec<usize> {
    let n = s.ncols();
    if n == 0 || s.nrows() == 0 {
        return Vec::new();
    }
    let qr = s.col_piv_qr();
    let order: Vec<usize> = qr.P().arrays().0.to_vec();
    let r = qr.R();
    let k_max = n.min(s.nrows());
    let mut chosen = Vec::new();
    for k in 0..k_max {
        if r[(k, k)] == 0.0 || !r[(k, k)].is_finite() {
            break;
        }
        // Condition of the first k+1 pivoted columns: that of R[..=k, ..=k].
        let block = r.submatrix(0, 0, k + 1, k + 1).to_owned();
        let Ok(sv) = block.singular_values() else {
            break;
        };
        let (hi, lo) = (sv[0], sv[sv.len() - 1]);
        if !(lo > 0.0) || hi / lo > limit {
            break;
        }
        chosen.push(order[k]);
    }
    chosen.sort_unstable();
    chosen
}

/// Parameter weighting of the extended weighted least squares.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParameterWeighting {
    /// `W_φ = 0`: plain weighted least squares.
    None,
    /// `W_φ = γ · tr(SᵀW_fS)/n · diag(v_i / max_j v_j)`, `v = diag((SᵀW_fS)⁻¹)` (4.22 in intent):
    /// a parameter whose estimate is poorly determined (large variance `v_i`) is held back with
    /// a weight up to `γ` times the mean diagonal of the normal matrix; well determined ones are
    /// hardly weighted.
    Variance {
        /// `γ`.
        gamma: f64,
    },
}

/// The step `Δ = (SᵀS + W_φ)⁻¹ Sᵀ ε` of an already row-weighted system (`S = W_f^{1/2} S`,
/// `ε = W_f^{1/2} ε`) over the columns `active`; zero for the others. Solved as the stacked
/// least-squares problem `[S; W_φ^{1/2}] Δ = [ε; 0]` by SVD (pseudo-inverse, relative cut
/// 1e-12), which stays accurate when `SᵀS` would square a large condition number.
pub fn weighted_step(
    s: MatRef<'_, f64>,
    eps: &[f64],
    active: &[usize],
    weighting: ParameterWeighting,
) -> Vec<f64> {
    damped_step(s, eps, active, weighting, 0.0)
}

/// [`weighted_step`] with Marquardt damping `μ diag(SᵀS)` added to `W_φ`: as `μ` grows the step
/// shortens and turns from the Gauss-Newton direction toward the scaled gradient `Sᵀε`.
pub fn damped_step(
    s: MatRef<'_, f64>,
    eps: &[f64],
    active: &[usize],
    weighting: ParameterWeighting,
    mu: f64,
) -> Vec<f64> {
    let n = s.ncols();
    let mut delta = vec![0.0; n];
    let na = active.len();
    if na == 0 {
        return delta;
    }
    let m = s.nrows();
    let sa = Mat::from_fn(m, na, |i, j| s[(i, active[j])]);
    let marquardt: Vec<f64> = (0..na)
        .map(|j| mu * (0..m).map(|i| sa[(i, j)] * sa[(i, j)]).sum::<f64>())
        .collect();
    let w_phi: Vec<f64> = match weighting {
        ParameterWeighting::None => vec![0.0; na],
        ParameterWeighting::Variance { gamma } => {
            let normal = sa.transpose() * &sa;
            let trace: f64 = (0..na).map(|i| normal[(i, i)]).sum();
            let var = variances(sa.as_ref());
            let vmax = var.iter().copied().fold(0.0, f64::max);
            var.iter()
                .map(|v| {
                    if vmax > 0.0 && vmax.is_finite() {
                        gamma * trace / na as f64 * v / vmax
                    } else if v.is_infinite() {
                        gamma * trace / na as f64
                    } else {
                        0.0
                    }
                })
                .collect()
        }
    };
    let a = Mat::from_fn(m + na, na, |i, j| {
        if i < m {
            sa[(i, j)]
        } else if i - m == j {
            (w_phi[j] + marquardt[j]).sqrt()
        } else {
            0.0
        }
    });
    let b: Vec<f64> = (0..m + na)
        .map(|i| if i < m { eps[i] } else { 0.0 })
        .collect();
    let x = least_squares(a.as_ref(), &b, 1e-12);
    for (j, &c) in active.iter().enumerate() {
        delta[c] = x[j];
    }
    delta
}

/// `diag((SᵀS)⁻¹)` from the SVD of `S` (infinite where a direction is unseen).
fn variances(s: MatRef<'_, f64>) -> Vec<f64> {
    let n = s.ncols();
    let Some(svd) = thin_svd(s) else {
        return vec![f64::INFINITY; n];
    };
    let smax = if n > 0 { svd.s[0] } else { 0.0 };
    (0..n)
        .map(|i| {
            (0..n.min(s.nrows()))
                .map(|k| {
                    let sk = svd.s[k];
                    if sk > 1e-14 * smax {
                        svd.v[(i, k)].powi(2) / (sk * sk)
                    } else if svd.v[(i, k)] != 0.0 {
                        f64::INFINITY
                    } else {
                        0.0
                    }
                })
                .sum()
        })
        .collect()
}

/// Minimum-norm least-squares solution of `A x = b` by SVD, singular values below
/// `rcond · σ_max` dropped.
pub fn least_squares(a: MatRef<'_, f64>, b: &[f64], rcond: f64) -> Vec<f64> {
    let n = a.ncols();
    if n == 0 || a.nrows() == 0 {
        return vec![0.0; n];
    }
    let padded;
    let a = if a.nrows() < n {
        padded = Mat::from_fn(n, n, |i, j| if i < a.nrows() { a[(i, j)] } else { 0.0 });
        padded.as_ref()
    } else {
        a
    };
    let Some(svd) = thin_svd(a) else {
        return vec![0.0; n];
    };
    let (u, v) = (svd.u.as_ref(), svd.v.as_ref());
    let smax = svd.s[0];
    let mut x = vec![0.0; n];
    for k in 0..n {
        let sk = svd.s[k];
        if !(sk > rcond * smax) {
            continue;
        }
        let coef: f64 = (0..b.len()).map(|i| u[(i, k)] * b[i]).sum::<f64>() / sk;
        for (j, xj) in x.iter_mut().enumerate() {
            *xj += coef * v[(j, k)];
        }
    }
    x
}

/// A thin SVD `A = U diag(s) Vᵀ`, singular values descending.
struct ThinSvd {
    u: Mat<f64>,
    s: Vec<f64>,
    v: Mat<f64>,
}

/// The thin SVD of `a` on one thread, `None` when it does not converge. (faer's `thin_svd` runs
/// on every rayon thread, and for tall matrices, as sensitivity matrices are, its last bits
/// then depend on the thread count; results must not.)
fn thin_svd(a: MatRef<'_, f64>) -> Option<ThinSvd> {
    let (m, n) = a.shape();
    let size = m.min(n);
    let (mut u, mut v, mut s) = (Mat::zeros(m, size), Mat::zeros(n, size), Diag::zeros(size));
    let thin = ComputeSvdVectors::Thin;
    let mut buf = MemBuffer::new(svd_scratch::<f64>(
        m,
        n,
        thin,
        thin,
        Par::Seq,
        Default::default(),
    ));
    svd(
        a,
        s.as_mut(),
        Some(u.as_mut()),
        Some(v.as_mut()),
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .ok()?;
    let s = (0..size).map(|k| s[k]).collect();
    Some(ThinSvd { u, s, v })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tall sensitivity matrix (2000 equations, 9 parameters) gives the same diagnostics and
    /// least-squares step to the last bit on one thread and on seven.
    #[test]
    fn tall_svds_do_not_depend_on_the_thread_count() {
        let s = Mat::from_fn(2000, 9, |i, j| {
            ((i * 7 + j * 13) as f64).sin() / (1.0 + j as f64)
        });
        let b: Vec<f64> = (0..2000).map(|i| (i as f64 * 0.37).cos()).collect();
        let at = |n: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            pool.install(|| {
                let d = diagnostics(s.as_ref());
                let x = least_squares(s.as_ref(), &b, 1e-12);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                (
                    bits(&d.singular_values),
                    bits(&d.weakest_direction),
                    bits(&x),
                )
            })
        };
        assert_eq!(at(1), at(7));
    }

    /// A matrix with a dependent column: the subset leaves one of the dependent pair out, the
    /// diagnostics name the dependency as the null space.
    #[test]
    fn subset_and_null_space_of_a_rank_deficient_matrix() {
        let s = Mat::from_fn(6, 3, |i, j| match j {
            0 => 1.0 + i as f64,
            1 => (i as f64).sin(),
            _ => 2.0 * (1.0 + i as f64),
        });
        let chosen = select_subset(s.as_ref(), 1e6);
        assert_eq!(chosen.len(), 2);
        assert!(chosen.contains(&1));
        let d = diagnostics(s.as_ref());
        assert_eq!(d.null_space.len(), 1);
        let v = &d.null_space[0];
        // 2·col0 − col2 = 0: direction ∝ (2, 0, −1)/√5.
        assert!((v[0].abs() - 2.0 / 5f64.sqrt()).abs() < 1e-10);
        assert!(v[1].abs() < 1e-10);
        assert!(
            d.condition.is_infinite(),
            "an exact dependency is rank deficiency, not a round-off ratio: {}",
            d.condition
        );
        // Full rank but badly scaled: the ratio is reported as it is.
        let scaled = Mat::from_fn(6, 2, |i, j| {
            if j == 0 {
                1.0 + i as f64
            } else {
                1e-9 * (i as f64).sin()
            }
        });
        let c = diagnostics(scaled.as_ref()).condition;
        assert!(c.is_finite() && c > 1e9 && c < 1e11, "{c}");
    }

    /// With full rank and no weighting the step is the least-squares solution; `κ_mn` follows
    /// (5.14).
    #[test]
    fn plain_step_is_least_squares() {
        let s = Mat::from_fn(5, 2, |i, j| if j == 0 { 1.0 } else { i as f64 });
        let eps: Vec<f64> = (0..5).map(|i| 3.0 - 0.5 * i as f64).collect();
        let d = weighted_step(s.as_ref(), &eps, &[0, 1], ParameterWeighting::None);
        assert!((d[0] - 3.0).abs() < 1e-12 && (d[1] + 0.5).abs() < 1e-12);
        assert_eq!(subset_condition_limit(1e7, 20, 10), 1.0 + 1e7 * 0.25);
        // The variance weighting shrinks the step, the weakest parameter most.
        let w = weighted_step(
            s.as_ref(),
            &eps,
            &[0, 1],
            ParameterWeighting::Variance { gamma: 0.1 },
        );
        assert!(w[0].abs() < 3.0 && w[1].abs() <= 0.5);
    }
}
