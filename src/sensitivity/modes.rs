//! Mode-shape sensitivities on a modal basis (docs/theory.md §3; Fox & Kapoor's modal method
//! with Wang's static correction of the truncated modes).
//!
//! With `P^K = Φᵀ(∂K/∂φ)Φ`, `P^M = Φᵀ(∂M/∂φ)Φ` of one parameter, the derivative of the
//! mass-normalised mode `r` on the basis is `∂φ_r = Σ_s c_sr φ_s`,
//! `c_sr = (P^K_sr − λ_r P^M_sr)/(λ_r − λ_s)`, `c_rr = −P^M_rr/2`. Modes of one cluster
//! (coincident eigenvalues: rigid-body modes, symmetric pairs) have no unique derivative inside
//! the cluster; those coefficients are 0 (the cluster's own rotation is left out).

use super::frf::CLUSTER_TOLERANCE;
use super::projection::ProjectedDerivative;
use faer::{Mat, MatRef};

/// Cluster id of each mode: consecutive eigenvalues within [`CLUSTER_TOLERANCE`] share the id
/// of the first.
pub fn clusters(eigenvalues: &[f64]) -> Vec<usize> {
    let mut id = Vec::with_capacity(eigenvalues.len());
    for (r, &l) in eigenvalues.iter().enumerate() {
        let same = r > 0 && {
            let p = eigenvalues[r - 1];
            (l - p).abs() <= CLUSTER_TOLERANCE * l.abs().max(p.abs())
        };
        id.push(if same { id[r - 1] } else { r });
    }
    id
}

/// The expansion coefficients `C = [c_sr]` (`m × m`, column `r` the derivative of mode `r`) of
/// one parameter's projected derivative.
pub fn expansion_coefficients(
    eigenvalues: &[f64],
    cluster: &[usize],
    d: &ProjectedDerivative,
) -> Mat<f64> {
    let m = eigenvalues.len();
    Mat::from_fn(m, m, |s, r| {
        if s == r {
            -0.5 * d.m[(r, r)]
        } else if cluster[s] == cluster[r] {
            0.0
        } else {
            (d.k[(s, r)] - eigenvalues[r] * d.m[(s, r)]) / (eigenvalues[r] - eigenvalues[s])
        }
    })
}

/// `∂φ_r/∂φ_p` at chosen rows for the modes `modes`, one `rows × modes.len()` matrix per
/// parameter: `shapes` are all `m` modes of the basis at those rows, `derivatives` the projected
/// derivatives (scaled as the caller wants them), `corrections` (optional, `rows × m` per
/// parameter) the truncated modes' share of every mode's derivative
/// ([`super::frf::static_shape_correction`]).
pub fn mode_shape_sensitivities(
    eigenvalues: &[f64],
    shapes: MatRef<'_, f64>,
    modes: &[usize],
    derivatives: &[ProjectedDerivative],
    corrections: Option<&[Mat<f64>]>,
) -> Vec<Mat<f64>> {
    let cluster = clusters(eigenvalues);
    derivatives
        .iter()
        .enumerate()
        .map(|(p, d)| {
            let c = expansion_coefficients(eigenvalues, &cluster, d);
            let rho = corrections.and_then(|c| c.get(p));
            Mat::from_fn(shapes.nrows(), modes.len(), |i, k| {
                let r = modes[k];
                let mut v: f64 = (0..eigenvalues.len())
                    .map(|s| shapes[(i, s)] * c[(s, r)])
                    .sum();
                if let Some(rho) = rho {
                    v += rho[(i, r)];
                }
                v
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::{SparseMatrix, sparse_from_triplets};
    use crate::core::{Component, DofId};
    use crate::eigen::{ModeSelection, Modes, dense_generalized};

    fn dense_modes(k: MatRef<'_, f64>, m: MatRef<'_, f64>) -> Modes {
        let labels: Vec<DofId> = (0..5).map(|n| DofId::new(n, Component::Ux)).collect();
        dense_generalized(k, m, &labels, ModeSelection::All).unwrap()
    }

    /// A five-DOF spring-mass chain, fixed at one end, with the stiffness of spring 3 the
    /// parameter.
    fn chain(k3: f64) -> (Mat<f64>, Mat<f64>) {
        let k = [2.0e4, 1.5e4, k3, 1.2e4, 0.8e4];
        let m = [1.0, 1.3, 0.9, 1.1, 0.7];
        let n = 5;
        let mut kk = Mat::<f64>::zeros(n, n);
        for (e, &ke) in k.iter().enumerate() {
            kk[(e, e)] += ke;
            if e > 0 {
                kk[(e - 1, e - 1)] += ke;
                kk[(e - 1, e)] -= ke;
                kk[(e, e - 1)] -= ke;
            }
        }
        let mm = Mat::from_fn(n, n, |i, j| if i == j { m[i] } else { 0.0 });
        (kk, mm)
    }

    fn sparse(a: &Mat<f64>) -> SparseMatrix {
        let mut t = Vec::new();
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                if a[(i, j)] != 0.0 {
                    t.push((i, j, a[(i, j)]));
                }
            }
        }
        sparse_from_triplets("a", a.nrows(), &t).unwrap()
    }

    /// On the complete basis the modal method is exact: against central differences of the
    /// mass-normalised, sign-fixed modes (relative step 1e-5: truncation ~1e-10, eigen round-off
    /// ~1e-16/1e-5), to 1e-7 of the largest shape entry.
    #[test]
    fn mode_shape_derivatives_match_central_differences() {
        let k3 = 1.0e4;
        let (k, m) = chain(k3);
        let modes = dense_modes(k.as_ref(), m.as_ref());
        let (dk, _) = chain(1.0);
        let (dk0, _) = chain(0.0);
        let dk = sparse(&(&dk - &dk0));
        let dm = sparse(&Mat::<f64>::zeros(5, 5));
        let d = ProjectedDerivative::new(&dk, &dm, modes.shapes.as_ref());
        let all: Vec<usize> = (0..5).collect();
        let sens =
            mode_shape_sensitivities(&modes.eigenvalues, modes.shapes.as_ref(), &all, &[d], None);
        let h = 1e-5 * k3;
        let signed = |k3: f64| {
            let (k, m) = chain(k3);
            let mut s = dense_modes(k.as_ref(), m.as_ref()).shapes;
            for r in 0..5 {
                let dot: f64 = (0..5).map(|i| s[(i, r)] * modes.shapes[(i, r)]).sum();
                if dot < 0.0 {
                    for i in 0..5 {
                        s[(i, r)] = -s[(i, r)];
                    }
                }
            }
            s
        };
        let (up, down) = (signed(k3 + h), signed(k3 - h));
        let scale = (0..5)
            .flat_map(|i| (0..5).map(move |r| (i, r)))
            .map(|(i, r)| modes.shapes[(i, r)].abs())
            .fold(0.0, f64::max);
        for r in 0..5 {
            for i in 0..5 {
                let fd = (up[(i, r)] - down[(i, r)]) / (2.0 * h);
                let err = (sens[0][(i, r)] - fd).abs() * k3;
                assert!(
                    err < 1e-7 * scale,
                    "mode {r} row {i}: {} vs {fd}",
                    sens[0][(i, r)]
                );
            }
        }
    }

    #[test]
    fn coincident_eigenvalues_form_one_cluster() {
        assert_eq!(
            clusters(&[0.0, 0.0, 1.0, 1.0 + 1e-9, 2.0]),
            vec![0, 0, 2, 2, 4]
        );
    }
}
