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

/// How each reference mode finds its partner among the predicted modes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pairing {
    /// Highest MAC not yet taken, in the reference's order; unpaired below `min_mac`.
    Mac {
        /// Lowest MAC accepted as a pair.
        min_mac: f64,
    },
    /// The `i`-th elastic mode with the `i`-th elastic mode.
    Order,
}

/// One reference mode and its partner. Mode indices are 0-based over all modes, rigid-body
/// modes included.
#[derive(Clone, Debug, PartialEq)]
pub struct ModePair {
    /// Reference mode.
    pub reference: usize,
    /// Predicted mode.
    pub predicted: usize,
    /// Their MAC (1.18).
    pub mac: f64,
    /// `(λ − λ_ref)/λ_ref` (3.54).
    pub eigenvalue_error: f64,
    /// `(f − f_ref)/f_ref = sqrt(1 + ε_λ) − 1`.
    pub frequency_error: f64,
}

/// The elastic modes of two sets compared: pairs, the reference modes left unpaired, the MAC
/// matrix (elastic reference × elastic predicted) and the COMAC per row over the pairs.
#[derive(Clone, Debug, PartialEq)]
pub struct ModeCorrelation {
    /// Pairs, in the reference's order.
    pub pairs: Vec<ModePair>,
    /// Reference modes without a partner (0-based over all modes).
    pub unpaired: Vec<usize>,
    /// MAC of elastic reference mode `i` (row) with elastic predicted mode `j` (column).
    pub mac: Mat<f64>,
    /// COMAC per shape row over the pairs.
    pub comac: Vec<f64>,
}

/// Compares the elastic modes of `reference` and `predicted` (eigenvalues and shapes over the
/// same rows; the first `*_rigid` modes of each are rigid-body modes and are left out: their
/// eigenvalue error means nothing). This is the thesis's check of a reduced model against the
/// full one (3.54), with the MAC to make sure each error is taken against the right mode.
pub fn correlate_modes(
    reference: (&[f64], MatRef<'_, f64>, usize),
    predicted: (&[f64], MatRef<'_, f64>, usize),
    pairing: Pairing,
) -> ModeCorrelation {
    let (ref_lambda, ref_shapes, ref_rigid) = reference;
    let (pred_lambda, pred_shapes, pred_rigid) = predicted;
    let ref_rigid = ref_rigid.min(ref_lambda.len());
    let pred_rigid = pred_rigid.min(pred_lambda.len());
    let a = ref_shapes.subcols(ref_rigid, ref_lambda.len() - ref_rigid);
    let b = pred_shapes.subcols(pred_rigid, pred_lambda.len() - pred_rigid);
    let mac = mac_matrix(a, b);
    let partners: Vec<Option<(usize, f64)>> = match pairing {
        Pairing::Mac { min_mac } => pair_by_mac(a, b, min_mac),
        Pairing::Order => (0..a.ncols())
            .map(|i| (i < b.ncols()).then(|| (i, mac[(i, i)])))
            .collect(),
    };
    let (mut pairs, mut unpaired, mut local) = (Vec::new(), Vec::new(), Vec::new());
    for (i, p) in partners.into_iter().enumerate() {
        let r = i + ref_rigid;
        match p {
            Some((j, m)) => {
                let e = eigenvalue_error(ref_lambda[r], pred_lambda[j + pred_rigid]);
                pairs.push(ModePair {
                    reference: r,
                    predicted: j + pred_rigid,
                    mac: m,
                    eigenvalue_error: e,
                    frequency_error: (1.0 + e).sqrt() - 1.0,
                });
                local.push((i, j));
            }
            None => unpaired.push(r),
        }
    }
    ModeCorrelation {
        comac: comac(a, b, &local),
        pairs,
        unpaired,
        mac,
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

    /// Two modes swapped in order, one shape with flipped sign, eigenvalues 1 % high:
    /// MAC pairing finds the swap and the 1 % (3.54); order pairing pairs the wrong shapes.
    #[test]
    fn correlate_modes_pairs_by_mac_and_skips_rigid_modes() {
        // Reference: one rigid mode and three elastic modes over four rows.
        let ref_shapes = Mat::from_fn(4, 4, |i, j| if i == j { 1.0 } else { 0.1 * (i + j) as f64 });
        let ref_lambda = [0.0, 100.0, 400.0, 900.0];
        // Predicted: rigid mode, then elastic modes 2 and 1 swapped, mode 3 with its sign flipped
        // (COMAC, unlike MAC, assumes consistently scaled shapes).
        let order = [0usize, 2, 1, 3];
        let pred_shapes = Mat::from_fn(4, 4, |i, j| {
            let s = if j == 3 { -1.0 } else { 1.0 };
            s * ref_shapes[(i, order[j])]
        });
        let pred_lambda = [0.0, 404.0, 101.0, 909.0];
        let c = correlate_modes(
            (&ref_lambda, ref_shapes.as_ref(), 1),
            (&pred_lambda, pred_shapes.as_ref(), 1),
            Pairing::Mac { min_mac: 0.9 },
        );
        assert!(c.unpaired.is_empty());
        let got: Vec<(usize, usize)> = c.pairs.iter().map(|p| (p.reference, p.predicted)).collect();
        assert_eq!(got, vec![(1, 2), (2, 1), (3, 3)]);
        for p in &c.pairs {
            assert!((p.eigenvalue_error - 0.01).abs() < 1e-12, "{p:?}");
            assert!((p.frequency_error - (1.01f64.sqrt() - 1.0)).abs() < 1e-12);
            assert!((p.mac - 1.0).abs() < 1e-12);
        }
        assert!(c.comac.iter().all(|v| (v - 1.0).abs() < 1e-12));
        let by_order = correlate_modes(
            (&ref_lambda, ref_shapes.as_ref(), 1),
            (&pred_lambda, pred_shapes.as_ref(), 1),
            Pairing::Order,
        );
        assert_eq!(by_order.pairs[0].predicted, 1);
        assert!(by_order.pairs[0].mac < 0.9);
        assert!((by_order.pairs[0].eigenvalue_error - 3.04).abs() < 1e-12);
        // A stricter threshold leaves modes unpaired rather than pairing them badly.
        let strict = correlate_modes(
            (&ref_lambda, ref_shapes.as_ref(), 1),
            (&pred_lambda[..3], pred_shapes.as_ref().subcols(0, 3), 1),
            Pairing::Mac { min_mac: 0.9 },
        );
        assert_eq!(strict.unpaired, vec![3]);
    }

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
