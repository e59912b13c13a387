//! Tests of the sparse eigensolver: its block orthogonalisation and shift-inverted operator,
//! analytic chain spectra, repeated eigenvalues, frequency limits against the dense solution,
//! rigid-body modes, a reused factor structure, and errors naming the DOF.

use super::*;
use crate::core::sparse::{sparse_from_triplets, sparse_to_dense};
use crate::sparse::LowerPencil;

/// A free-free chain of `n` masses: one rigid mode, `λ_r = (4k/m) sin²(rπ/(2n))`.
fn free_chain(n: usize, k: f64, m: f64) -> (SparseMatrix, SparseMatrix, Vec<DofId>) {
    let mut kt = Vec::new();
    for i in 0..n - 1 {
        kt.extend([(i, i, k), (i + 1, i + 1, k), (i, i + 1, -k), (i + 1, i, -k)]);
    }
    let mt: Vec<_> = (0..n).map(|i| (i, i, m)).collect();
    let dofs = (0..n as u64)
        .map(|i| DofId::new(i + 1, crate::core::Component::Ux))
        .collect();
    (
        sparse_from_triplets("K", n, &kt).unwrap(),
        sparse_from_triplets("M", n, &mt).unwrap(),
        dofs,
    )
}

/// A tridiagonal (non-diagonal) positive definite mass matrix.
fn banded_mass(n: usize, diagonal: impl Fn(usize) -> f64, off: f64) -> SparseMatrix {
    let mut t = Vec::new();
    for j in 0..n {
        t.push((j, j, diagonal(j)));
        if j + 1 < n {
            t.extend([(j, j + 1, off), (j + 1, j, off)]);
        }
    }
    sparse_from_triplets("M", n, &t).unwrap()
}

/// Cholesky QR on a block whose columns are nearly parallel (`κ ≈ 10⁴`: one pass leaves
/// `ε κ² ≈ 10⁻⁸`, so the second must run), over more rows than one tile: `Q R` rebuilds
/// the block and `QᵀQ = I`.
#[test]
fn cholesky_qr_orthonormalises_an_ill_conditioned_block() {
    let n = 10_000;
    let base = Mat::from_fn(n, 1, |i, _| ((i * 37) % 101) as f64 / 101.0 - 0.5);
    let w = Mat::from_fn(n, 6, |i, j| {
        base[(i, 0)] + 1e-4 * (((i + 1) * (j + 3) * 7919) % 1009) as f64 / 1009.0
    });
    let (q, r) = cholesky_qr(w.clone()).unwrap();
    assert!((&q * &r - &w).norm_max() < 1e-12 * w.norm_max());
    let gram = q.transpose() * &q;
    assert!((gram - Mat::<f64>::identity(6, 6)).norm_max() < 1e-12);
    // The tiled transform's Gram matrix equals the whole product's.
    let mut q2 = w.clone();
    let tr = Mat::from_fn(6, 6, |i, j| if i <= j { 1.0 + (i + j) as f64 } else { 0.0 });
    let g = transform_rows_with_gram(q2.as_mut(), tr.as_ref());
    let wt = &w * &tr;
    assert!((&q2 - &wt).norm_max() < 1e-13 * wt.norm_max());
    assert!((g - wt.transpose() * &wt).norm_max() < 1e-12 * (wt.transpose() * &wt).norm_max());
}

/// The third pass keeps `w = V c + Q R` and leaves `Q` orthonormal and orthogonal to `V`,
/// from a block that was never projected (every column mostly along `V`).
#[test]
fn a_third_pass_keeps_the_block_and_orthogonalises_it() {
    let n = 60;
    let raw = Mat::from_fn(n, 10, |i, j| {
        ((i * 7 + j * 13) % 11) as f64 - 5.0 + 0.1 * j as f64
    });
    let (v, _) = cholesky_qr(raw).unwrap();
    // Mostly along V, with a small part outside.
    let x = Mat::from_fn(10, 3, |i, j| 1.0 + (i + 2 * j) as f64);
    let w = &v * &x
        + Mat::from_fn(n, 3, |i, j| {
            1e-3 * ((i * j) % 5) as f64 + 1e-3 * (i == j) as u8 as f64
        });
    let (q, r) = cholesky_qr(w.clone()).unwrap();
    let mut c = Mat::<f64>::zeros(10, 3);
    let (q2, r2) = reorthogonalise(v.as_ref(), (q, r), &mut c).unwrap();
    let rebuilt = &v * &c + &q2 * &r2;
    assert!((&rebuilt - &w).norm_max() < 1e-12 * w.norm_max());
    assert!((q2.transpose() * &q2 - Mat::<f64>::identity(3, 3)).norm_max() < 1e-12);
    // One pass over a block cancelled by ~10⁴ leaves about ε 10⁴ along V.
    assert!((v.transpose() * &q2).norm_max() < 1e-10);
    // The pass removed most of w: the criterion asks for it.
    assert!(cancellation(c.as_ref(), r2.as_ref()) > 1.0);
}

/// The operator `C = L⁻¹ Pᵀ M P L⁻ᵀ` is symmetric and has the eigenvalues `1/(λ − σ)`
/// of the pencil: against the dense generalised solution of a chain with a banded mass,
/// to 1e-10 relative (both are backward stable on matrices of condition ~10³).
#[test]
fn the_symmetric_operator_has_the_shift_inverted_eigenvalues() {
    let n = 40;
    let (k, _, dofs) = free_chain(n, 1000.0, 1.0);
    let m = banded_mass(n, |j| 2.0 + (j % 3) as f64, 0.5);
    let shift = -10.0;
    let a = crate::sparse::lower_combination(1.0, &k, -shift, &m);
    let llt = SpdFactor::new(&a, Par::rayon(0)).unwrap();
    let mut info = SparseEigenInfo::default();
    let pencil = LowerPencil::from_full(&k, &m).unwrap();
    let c = apply_operator(
        &llt,
        &pencil,
        Mat::<f64>::identity(n, n),
        Par::rayon(0),
        &mut info,
    );
    assert!((&c - c.transpose()).norm_max() < 1e-13 * c.norm_max());
    let mut nu: Vec<f64> = c
        .self_adjoint_eigenvalues(Side::Lower)
        .unwrap()
        .into_iter()
        .collect();
    nu.sort_by(|a, b| b.total_cmp(a));
    let exact = dense_generalized(
        sparse_to_dense(&k).as_ref(),
        sparse_to_dense(&m).as_ref(),
        &dofs,
        ModeSelection::All,
    )
    .unwrap();
    for (nu, lambda) in nu.iter().zip(&exact.eigenvalues) {
        let expected = 1.0 / (lambda - shift);
        assert!((nu - expected).abs() < 1e-10 * expected, "{nu} {expected}");
    }
}

#[test]
fn columns_are_permuted_in_place_along_cycles() {
    let a = Mat::from_fn(3, 6, |i, j| (10 * j + i) as f64);
    let order = [2, 0, 1, 3, 5, 4];
    let mut b = a.clone();
    permute_columns(&mut b, &order);
    assert_eq!(b, Mat::from_fn(3, 6, |i, j| a[(i, order[j])]));
}

/// `λ_r = (4k/m) sin²(rπ/(2n))`, to 1e-8 (the Lanczos tolerance is 1e-10 on `ν`; the
/// refined Rayleigh quotients are far better), with residuals below 1e-8, for a request
/// that runs blocks of 8 (12 modes) and one that runs blocks of 16 (110 modes).
#[test]
fn free_chain_lowest_modes_match_the_analytic_values() {
    for count in [12, 110] {
        free_chain_modes_match(count);
    }
}

/// An analysis on the factor structure of an earlier one (another chain of the same
/// pattern, as an update's model at new values) gives the modes of its own analysis to the
/// bit; a chain of another length is analysed afresh.
#[test]
fn an_earlier_analysis_structure_gives_the_same_modes() {
    let selection = ModeSelection::Count(8);
    let params = SparseEigenParams::default();
    let (k, m, dofs) = free_chain(1500, 1e6, 0.5);
    let (_, info, factor) = lowest_modes_keeping_factor(&k, &m, &dofs, selection, &params).unwrap();
    assert!(!info.dense && !info.factor.structure_reused);
    let held = SparseEigenParams {
        structure: factor.map(|f| f.factor.structure().clone()),
        ..params.clone()
    };
    let (k2, m2, _) = free_chain(1500, 2e6, 0.7);
    let (on_held, info) = lowest_modes(&k2, &m2, &dofs, selection, &held).unwrap();
    assert!(info.factor.structure_reused);
    let (fresh, info) = lowest_modes(&k2, &m2, &dofs, selection, &params).unwrap();
    assert!(!info.factor.structure_reused);
    assert_eq!(on_held.eigenvalues, fresh.eigenvalues);
    assert_eq!(on_held.shapes, fresh.shapes);
    let (k3, m3, dofs3) = free_chain(1600, 1e6, 0.5);
    let (_, info) = lowest_modes(&k3, &m3, &dofs3, selection, &held).unwrap();
    assert!(!info.factor.structure_reused);
}

fn free_chain_modes_match(count: usize) {
    let (n, k, m) = (3000, 1e6, 0.5);
    let (kk, mm, dofs) = free_chain(n, k, m);
    let (modes, info) = lowest_modes(
        &kk,
        &mm,
        &dofs,
        ModeSelection::Count(count),
        &SparseEigenParams::default(),
    )
    .unwrap();
    assert!(!info.dense);
    assert_eq!(modes.len(), count);
    assert_eq!(modes.rigid_body_modes, 1);
    for r in 0..count {
        let s = (r as f64 * std::f64::consts::PI / (2.0 * n as f64)).sin();
        let exact = 4.0 * k / m * s * s;
        let got = modes.eigenvalues[r];
        let err = if r == 0 {
            got.abs()
        } else {
            ((got - exact) / exact).abs()
        };
        assert!(err < 1e-8, "mode {r}: {got} vs {exact}");
        assert!(
            modes.residuals[r] < 1e-8,
            "mode {r} residual {}",
            modes.residuals[r]
        );
    }
    assert!(
        modes.orthogonality_error < 1e-10,
        "{}",
        modes.orthogonality_error
    );
}

#[test]
fn repeated_eigenvalues_are_all_found() {
    // Two identical, uncoupled chains: every eigenvalue is double.
    let (n, k, m) = (1200, 1e4, 1.0);
    let (k1, m1, _) = free_chain(n, k, m);
    let mut kt = Vec::new();
    let mut mt = Vec::new();
    for (off, (a, b)) in [(0, (&k1, &m1)), (n, (&k1, &m1))] {
        for j in 0..n {
            for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
                kt.push((i + off, j + off, v));
            }
            for (&i, &v) in b.row_idx_of_col_raw(j).iter().zip(b.val_of_col(j)) {
                mt.push((i + off, j + off, v));
            }
        }
    }
    // Ground both chains at one end so there is no rigid mode.
    kt.push((0, 0, k));
    kt.push((n, n, k));
    let kk = sparse_from_triplets("K", 2 * n, &kt).unwrap();
    let mm = sparse_from_triplets("M", 2 * n, &mt).unwrap();
    let dofs: Vec<DofId> = (0..2 * n as u64)
        .map(|i| DofId::new(i + 1, crate::core::Component::Ux))
        .collect();
    let (modes, _) = lowest_modes(
        &kk,
        &mm,
        &dofs,
        ModeSelection::Count(8),
        &SparseEigenParams::default(),
    )
    .unwrap();
    for r in (0..8).step_by(2) {
        let (a, b) = (modes.eigenvalues[r], modes.eigenvalues[r + 1]);
        assert!(((a - b) / a).abs() < 1e-9, "pair {r}: {a} vs {b}");
    }
    assert!(modes.orthogonality_error < 1e-10);
}

/// The 45 modes of the chain below 10 Hz, whatever the first Lanczos run asks for: the
/// default 20 (doubled twice), one (doubled six times), just enough, and far more.
#[test]
fn modes_below_a_frequency_match_the_dense_solution() {
    let (kk, mm, dofs) = free_chain(1000, 2e5, 1.0);
    let dense = dense_generalized(
        sparse_to_dense(&kk).as_ref(),
        sparse_to_dense(&mm).as_ref(),
        &dofs,
        ModeSelection::BelowHz(10.0),
    )
    .unwrap();
    assert_eq!(dense.len(), 45);
    for first_count in [None, Some(1), Some(46), Some(200)] {
        let params = SparseEigenParams {
            first_count,
            ..SparseEigenParams::default()
        };
        let (sparse, _) =
            lowest_modes(&kk, &mm, &dofs, ModeSelection::BelowHz(10.0), &params).unwrap();
        assert_eq!(sparse.len(), dense.len(), "first count {first_count:?}");
        for r in 1..dense.len() {
            let (a, b) = (sparse.eigenvalues[r], dense.eigenvalues[r]);
            assert!(
                ((a - b) / b).abs() < 1e-9,
                "{first_count:?}, mode {r}: {a} vs {b}"
            );
        }
    }
}

/// A frequency limit below the first elastic mode of a free structure returns its rigid-body
/// modes only (no "indefinite stiffness" from their round-off).
#[test]
fn a_limit_below_the_first_elastic_mode_gives_the_rigid_modes() {
    let (kk, mm, dofs) = free_chain(2000, 2e5, 1.0);
    let first_elastic_hz = {
        let s = (std::f64::consts::PI / 4000.0).sin();
        (4.0 * 2e5 * s * s).sqrt() / (2.0 * std::f64::consts::PI)
    };
    let (modes, _) = lowest_modes(
        &kk,
        &mm,
        &dofs,
        ModeSelection::BelowHz(0.5 * first_elastic_hz),
        &SparseEigenParams::default(),
    )
    .unwrap();
    assert_eq!(modes.len(), 1);
    assert_eq!(modes.rigid_body_modes, 1);
    assert_eq!(modes.eigenvalues[0], 0.0);
}

/// The same on the free-free bent plate of shells and beams, whose rigid-body Rayleigh
/// quotients carry shell round-off (~1e-5 rad²/s²) far above the tiny shift of a 0.5 Hz
/// limit: six rigid modes, no "indefinite stiffness".
#[test]
fn a_low_limit_on_a_free_shell_model_gives_its_six_rigid_modes() {
    use crate::fe::element::MassKind;
    use crate::fe::model_assembly::assemble_model;
    use crate::model::generate::{BentPlate, bent_plate};
    let (sys, _) =
        assemble_model(&bent_plate(&BentPlate::default()), MassKind::Consistent).unwrap();
    let (modes, _) = lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::BelowHz(0.5),
        &SparseEigenParams::default(),
    )
    .unwrap();
    assert_eq!((modes.len(), modes.rigid_body_modes), (6, 6));
}

#[test]
fn dof_without_stiffness_or_mass_is_named() {
    let (kk, _, dofs) = free_chain(900, 1.0, 1.0);
    let mt: Vec<_> = (0..899).map(|i| (i, i, 1.0)).collect();
    let mm = sparse_from_triplets("M", 900, &mt).unwrap();
    let mut kt = crate::core::sparse::sparse_triplets(&kk);
    kt.retain(|t| t.0 != 899 && t.1 != 899);
    let kk = sparse_from_triplets("K", 900, &kt).unwrap();
    let e = lowest_modes(
        &kk,
        &mm,
        &dofs,
        ModeSelection::Count(3),
        &SparseEigenParams::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("900:ux"), "{e}");
}
