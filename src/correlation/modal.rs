//! Correlation of mode shapes and frequencies (thesis §1.4): the modal assurance criterion MAC
//! (1.18), the coordinate MAC (COMAC), pairing of modes by MAC, the relative eigenvalue error
//! (3.54) used to judge reduced models, and the frequency domain assurance criterion FDAC
//! between FRF sets, whose diagonal is `χ_s` (4.8).

use faer::{Mat, MatRef, c64};

/// `MAC(a, b) = (aᵀb)² / (aᵀa · bᵀb)`, in [0, 1], blind to scale (1.18); 0 when a vector is zero.
pub fn mac(a: &[f64], b: &[f64]) -> f64 {
    let ab: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let aa: f64 = a.iter().map(|x| x * x).sum();
    let bb: f64 = b.iter().map(|x| x * x).sum();
    if aa * bb > 0.0 {
        ab * ab / (aa * bb)
    } else {
        0.0
    }
}

/// MAC of every mode of `a` (rows) with every mode of `b` (columns); shapes share their rows.
pub fn mac_matrix(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let col =
        |m: MatRef<'_, f64>, j: usize| -> Vec<f64> { (0..m.nrows()).map(|i| m[(i, j)]).collect() };
    Mat::from_fn(a.ncols(), b.ncols(), |i, j| mac(&col(a, i), &col(b, j)))
}

/// Pairs each mode of `a` with the mode of `b` of highest MAC not yet taken, in the order of
/// `a`; `None` where no MAC reaches `min_mac`.
pub fn pair_by_mac(
    a: MatRef<'_, f64>,
    b: MatRef<'_, f64>,
    min_mac: f64,
) -> Vec<Option<(usize, f64)>> {
    let m = mac_matrix(a, b);
    let mut taken = vec![false; b.ncols()];
    (0..a.ncols())
        .map(|i| {
            let best = (0..b.ncols())
                .filter(|&j| !taken[j])
                .map(|j| (j, m[(i, j)]))
                .fold(None, |best: Option<(usize, f64)>, c| match best {
                    Some(x) if x.1 >= c.1 => Some(x),
                    _ => Some(c),
                });
            match best {
                Some((j, v)) if v >= min_mac => {
                    taken[j] = true;
                    Some((j, v))
                }
                _ => None,
            }
        })
        .collect()
}

/// COMAC per DOF (row) over paired modes `(i, j)` of `a` and `b`:
/// `(Σ |a_ri b_rj|)² / (Σ a_ri² · Σ b_rj²)`.
pub fn comac(a: MatRef<'_, f64>, b: MatRef<'_, f64>, pairs: &[(usize, usize)]) -> Vec<f64> {
    (0..a.nrows())
        .map(|r| {
            let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
            for &(i, j) in pairs {
                ab += (a[(r, i)] * b[(r, j)]).abs();
                aa += a[(r, i)] * a[(r, i)];
                bb += b[(r, j)] * b[(r, j)];
            }
            if aa * bb > 0.0 {
                ab * ab / (aa * bb)
            } else {
                0.0
            }
        })
        .collect()
}

/// Relative eigenvalue error `(λ − λ_ref)/λ_ref` (3.54); 0 for two rigid-body modes, infinite
/// for an elastic mode against a rigid reference.
pub fn eigenvalue_error(reference: f64, lambda: f64) -> f64 {
    if reference == 0.0 {
        if lambda == 0.0 { 0.0 } else { f64::INFINITY }
    } else {
        (lambda - reference) / reference
    }
}

/// FDAC between the lines of two FRF sets (rows: lines, columns: the same pairs):
/// `FDAC(k, l) = |x_kᴴ a_l|² / (x_kᴴx_k · a_lᴴa_l)`; its diagonal is `χ_s(ω_k)`.
pub fn fdac(x: MatRef<'_, c64>, a: MatRef<'_, c64>) -> Mat<f64> {
    let row =
        |m: MatRef<'_, c64>, k: usize| -> Vec<c64> { (0..m.ncols()).map(|q| m[(k, q)]).collect() };
    Mat::from_fn(x.nrows(), a.nrows(), |k, l| {
        super::frf::shape_correlation(&row(x, k), &row(a, l))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mac_is_one_for_scaled_copies_and_pairs_swapped_modes() {
        let a = Mat::from_fn(5, 3, |i, j| {
            ((i + 1) as f64).powi(j as i32 + 1) * if j == 1 { -1.0 } else { 1.0 }
        });
        // b: the modes of a in another order and scale.
        let b = Mat::from_fn(5, 3, |i, j| match j {
            0 => -2.0 * a[(i, 2)],
            1 => 0.5 * a[(i, 0)],
            _ => 3.0 * a[(i, 1)],
        });
        let pairs = pair_by_mac(a.as_ref(), b.as_ref(), 0.9);
        assert_eq!(
            pairs.iter().map(|p| p.unwrap().0).collect::<Vec<_>>(),
            vec![1, 2, 0]
        );
        for p in &pairs {
            assert!((p.unwrap().1 - 1.0).abs() < 1e-14);
        }
        let c = comac(a.as_ref(), b.as_ref(), &[(0, 1), (1, 2), (2, 0)]);
        // Rows scale differently per mode (0.5, 3, 2): COMAC < 1 unless modes share a scale.
        assert!(c.iter().all(|v| *v > 0.0 && *v <= 1.0 + 1e-15));
        let same = comac(a.as_ref(), a.as_ref(), &[(0, 0), (1, 1), (2, 2)]);
        assert!(same.iter().all(|v| (v - 1.0).abs() < 1e-14));
        assert_eq!(eigenvalue_error(100.0, 101.0), 0.01);
        assert_eq!(eigenvalue_error(0.0, 0.0), 0.0);
    }

    #[test]
    fn fdac_diagonal_is_the_shape_correlation() {
        let x = Mat::from_fn(4, 3, |k, q| {
            c64::new(1.0 + k as f64 + q as f64, 0.3 * q as f64)
        });
        let a = Mat::from_fn(4, 3, |k, q| c64::new(1.2 + k as f64 - 0.1 * q as f64, -0.2));
        let f = fdac(x.as_ref(), a.as_ref());
        for k in 0..4 {
            let xs: Vec<c64> = (0..3).map(|q| x[(k, q)]).collect();
            let as_: Vec<c64> = (0..3).map(|q| a[(k, q)]).collect();
            assert!((f[(k, k)] - super::super::frf::shape_correlation(&xs, &as_)).abs() < 1e-15);
        }
    }
}
