//! Tests of the flat shells against independent references: rigid-body modes in any
//! orientation, exact masses, patch tests, layered and offset sections against the homogeneous
//! element, drilling, warping, locking, central differences for every derivative, and errors.

use super::super::laminate::ShellLaw;
use super::general::{law_mass, quad4_law_local};
use super::*;
use crate::core::{Component, DofId};
use crate::eigen::{ModeSelection, dense_generalized};
use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Par, Side};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const STEEL: ShellSection = ShellSection {
    thickness: 0.1,
    e: 210e9,
    nu: 0.3,
    rho: 7850.0,
    nsm: 3.0,
    layers: None,
};
/// A general convex flat quad (no two sides parallel).
const QUAD: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.2, 0.1, 0.0],
    [1.0, 0.9, 0.0],
    [0.1, 0.8, 0.0],
];
/// A warped, tilted quad: warp ratio about 0.03.
const WARPED: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.05],
    [1.2, 0.1, -0.01],
    [1.0, 0.9, 0.12],
    [0.1, 0.8, 0.02],
];
/// A general triangle.
const TRIA: [[f64; 3]; 3] = [[0.0, 0.0, 0.0], [1.1, 0.2, 0.0], [0.3, 0.9, 0.0]];

fn element(
    xyz: &[[f64; 3]],
    s: &ShellSection,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    element_drill(xyz, s, mass, DRILLING_FACTOR)
}

fn element_drill(
    xyz: &[[f64; 3]],
    s: &ShellSection,
    mass: MassKind,
    drill: f64,
) -> Result<ElementMatrices, ElementError> {
    match xyz.len() {
        4 => Ok(quad4_parts(xyz.try_into().unwrap(), s, drill)?.matrices(s, mass)),
        3 => Ok(tria3_parts(xyz.try_into().unwrap(), s, drill)?.matrices(s, mass)),
        n => panic!("{n} nodes"),
    }
}

fn derivative(
    xyz: &[[f64; 3]],
    s: &ShellSection,
    mass: MassKind,
    p: ShellParameter,
) -> ElementDerivative {
    match xyz.len() {
        4 => quad4_derivative(xyz.try_into().unwrap(), s, mass, p).unwrap(),
        _ => tria3_derivative(xyz.try_into().unwrap(), s, mass, p).unwrap(),
    }
}

fn max_abs(m: &Mat<f64>) -> f64 {
    let mut a = 0.0f64;
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            a = a.max(m[(i, j)].abs());
        }
    }
    a
}

fn max_diff(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    max_abs(&(a - b))
}

fn random_rotation(rng: &mut ChaCha8Rng) -> [[f64; 3]; 3] {
    let mut q = [0.0; 4];
    loop {
        for v in q.iter_mut() {
            *v = 2.0 * rng.random::<f64>() - 1.0;
        }
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if n > 0.1 && n <= 1.0 {
            q.iter_mut().for_each(|v| *v /= n);
            break;
        }
    }
    let [w, x, y, z] = q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

fn apply(r: &[[f64; 3]; 3], p: &[f64; 3]) -> [f64; 3] {
    [dot(&r[0], p), dot(&r[1], p), dot(&r[2], p)]
}

fn moved(xyz: &[[f64; 3]], r: &[[f64; 3]; 3], shift: [f64; 3]) -> Vec<[f64; 3]> {
    xyz.iter()
        .map(|p| {
            let q = apply(r, p);
            [q[0] + shift[0], q[1] + shift[1], q[2] + shift[2]]
        })
        .collect()
}

/// The six rigid-body motions (three translations, three rotations about the origin).
fn rigid_modes(xyz: &[[f64; 3]]) -> Vec<Mat<f64>> {
    let n = 6 * xyz.len();
    let mut out = Vec::new();
    for k in 0..3 {
        out.push(Mat::from_fn(
            n,
            1,
            |i, _| if i % 6 == k { 1.0 } else { 0.0 },
        ));
    }
    for k in 0..3 {
        let mut th = [0.0; 3];
        th[k] = 1.0;
        out.push(Mat::from_fn(n, 1, |i, _| {
            let (node, c) = (i / 6, i % 6);
            if c < 3 {
                cross(&th, &xyz[node])[c]
            } else {
                th[c - 3]
            }
        }));
    }
    out
}

fn eigenvalues(m: &Mat<f64>) -> Vec<f64> {
    m.self_adjoint_eigenvalues(Side::Lower).unwrap()
}

/// Symmetric K and M; K r = 0 for the six rigid-body motions (relative 1e-10: round-off of a
/// sum of 24 terms is ~1e-15); exactly six eigenvalues below 1e-10 λ_max and the seventh above
/// 1e-8 λ_max (the smallest elastic one, drilling/bending, is ~1e-6 λ_max here); M positive
/// definite (Cholesky and a positive smallest eigenvalue). Three random orientations and
/// positions each for a flat quad, a warped quad and a triangle.
/// The isotropic law of `STEEL` (thickness, E, ν, ρ, nsm) as a general law.
fn steel_law() -> ShellLaw {
    let s = STEEL;
    let ply = crate::fe::laminate::Ply {
        material: crate::fe::laminate::PlyMaterial::Isotropic { e: s.e, nu: s.nu },
        thickness: s.thickness,
        theta: 0.0,
        rho: s.rho,
    };
    crate::fe::laminate::laminate(&[ply], -0.5 * s.thickness, s.nsm).unwrap()
}

/// The general kernel with the homogeneous isotropic law is the homogeneous kernel (1e-12
/// of the largest entry: only the order of the arithmetic differs), warped quads included,
/// for any material axis.
#[test]
fn general_law_of_an_isotropic_plate_is_the_homogeneous_element() {
    let law = steel_law();
    for axis in [
        MaterialAxis::Theta(0.0),
        MaterialAxis::Theta(1.1),
        MaterialAxis::Direction([0.3, -1.0, 0.2]),
    ] {
        let o = ShellOrientation { axis, offset: 0.0 };
        for mass in [MassKind::Consistent, MassKind::Lumped] {
            for xyz in [&QUAD, &WARPED] {
                let a = quad4(xyz, &STEEL, mass).unwrap();
                let b = quad4_general(xyz, &law, &o, mass).unwrap();
                let (dk, dm) = (max_diff(&a.k, &b.k), max_diff(&a.m, &b.m));
                let msg = format!(
                    "{axis:?} {mass:?} {xyz:?}: dK {dk:e} of {:e}, dM {dm:e} of {:e}",
                    max_abs(&a.k),
                    max_abs(&a.m)
                );
                assert!(dk <= 1e-12 * max_abs(&a.k), "{msg}");
                assert!(dm <= 1e-12 * max_abs(&a.m), "{msg}");
            }
            let a = tria3(&TRIA, &STEEL, mass).unwrap();
            let b = tria3_general(&TRIA, &law, &o, mass).unwrap();
            assert!(max_diff(&a.k, &b.k) <= 1e-12 * max_abs(&a.k));
            assert!(max_diff(&a.m, &b.m) <= 1e-12 * max_abs(&a.m));
        }
    }
}

/// ZOFFS as a constitutive offset (`B' = B + z0 A`, `D' = D + 2 z0 B + z0² A`, mass
/// moments likewise) equals the element formed on its reference plane and joined to the
/// grids by rigid links (the warping offsets of `transform`), for an unsymmetric laminate:
/// exactly the same energy, so 1e-12, without the drilling penalty (which ties θz to the
/// membrane rotation of the grid plane in the first and of the reference plane in the
/// second). The mass agrees but for the θz inertia, which femu takes about the grid plane.
#[test]
fn zoffs_is_the_element_on_rigid_links() {
    use crate::fe::laminate::{Ply, PlyMaterial, laminate};
    let carbon = PlyMaterial::Orthotropic {
        e1: 140e9,
        e2: 10e9,
        nu12: 0.3,
        g12: 5e9,
        g1z: 5e9,
        g2z: 3.5e9,
    };
    let ply = |deg: f64, rho: f64| Ply {
        material: carbon,
        thickness: 0.5e-3,
        theta: deg.to_radians(),
        rho,
    };
    let law = laminate(&[ply(0.0, 1500.0), ply(60.0, 1800.0)], -0.4e-3, 0.0).unwrap();
    let z0 = 2.0e-3;
    let (frame, _) = quad_frame(&QUAD).unwrap();
    let l = law.rotated(0.3);
    let (k_off, _, area, m_geo) = quad4_law_local(&frame, &l.offset(z0), None, 0.0).unwrap();
    let k1 = transform(&k_off, &frame.t, &frame.z);
    let (k_ref, _, _, _) = quad4_law_local(&frame, &l, None, 0.0).unwrap();
    let k2 = transform(&k_ref, &frame.t, &[-z0; 4]);
    assert!(
        max_diff(&k1, &k2) <= 1e-12 * max_abs(&k1),
        "{:e}",
        max_diff(&k1, &k2)
    );
    // (The lumped mass has the same node blocks; it is not carried through warping links.)
    for mass in [MassKind::Consistent] {
        let m1 = law_mass::<4, 24>(&frame, area, &m_geo, &l.offset(z0), mass);
        let ref_frame = Frame {
            z: [-z0; 4],
            ..frame
        };
        let m2 = law_mass::<4, 24>(&ref_frame, area, &m_geo, &l, mass);
        let big = max_abs(&m1);
        for r in 0..24 {
            for c in 0..24 {
                if r % 6 == 5 && c % 6 == 5 {
                    continue;
                }
                assert!(
                    (m1[(r, c)] - m2[(r, c)]).abs() <= 1e-12 * big,
                    "{mass:?} {r} {c}"
                );
            }
        }
    }
    // With the drilling penalty the two differ only at O(α_d).
    let (kd, _, _, _) = quad4_law_local(&frame, &l.offset(z0), None, DRILLING_FACTOR).unwrap();
    let kd = transform(&kd, &frame.t, &frame.z);
    assert!(max_diff(&kd, &k1) <= 1e-2 * max_abs(&k1));
}

/// Rotating the material axis by 90° is swapping E1 and E2 (element level, quad and tria).
#[test]
fn a_quarter_turn_of_the_material_axis_swaps_e1_and_e2() {
    use crate::fe::laminate::{Ply, PlyMaterial, laminate};
    let ply = |e1: f64, e2: f64, nu12: f64, g1z: f64, g2z: f64| Ply {
        material: PlyMaterial::Orthotropic {
            e1,
            e2,
            nu12,
            g12: 5e9,
            g1z,
            g2z,
        },
        thickness: 1e-3,
        theta: 0.2,
        rho: 1600.0,
    };
    let a = laminate(&[ply(140e9, 10e9, 0.3, 5e9, 3.5e9)], -0.3e-3, 0.0).unwrap();
    let mut pb = ply(10e9, 140e9, 0.3 * 10.0 / 140.0, 3.5e9, 5e9);
    pb.theta = 0.2;
    let b = laminate(&[pb], -0.3e-3, 0.0).unwrap();
    let turned = ShellOrientation {
        axis: MaterialAxis::Theta(std::f64::consts::FRAC_PI_2),
        offset: 0.001,
    };
    let plain = ShellOrientation {
        offset: 0.001,
        ..Default::default()
    };
    let ka = quad4_general(&QUAD, &a, &turned, MassKind::Consistent)
        .unwrap()
        .k;
    let kb = quad4_general(&QUAD, &b, &plain, MassKind::Consistent)
        .unwrap()
        .k;
    assert!(max_diff(&ka, &kb) <= 1e-12 * max_abs(&ka));
    let ka = tria3_general(&TRIA, &a, &turned, MassKind::Consistent)
        .unwrap()
        .k;
    let kb = tria3_general(&TRIA, &b, &plain, MassKind::Consistent)
        .unwrap()
        .k;
    assert!(max_diff(&ka, &kb) <= 1e-12 * max_abs(&ka));
}

#[test]
fn six_rigid_body_modes_in_any_orientation_and_positive_definite_mass() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for base in [&QUAD[..], &WARPED[..], &TRIA[..]] {
        for _ in 0..3 {
            let r = random_rotation(&mut rng);
            let shift = [10.0 * rng.random::<f64>(), -5.0 * rng.random::<f64>(), 3.0];
            let xyz = moved(base, &r, shift);
            for mass in [MassKind::Consistent, MassKind::Lumped] {
                let em = element(&xyz, &STEEL, mass).unwrap();
                assert_eq!(max_diff(&em.k, &em.k.transpose().to_owned()), 0.0);
                assert_eq!(max_diff(&em.m, &em.m.transpose().to_owned()), 0.0);
                let kmax = max_abs(&em.k);
                for (i, rb) in rigid_modes(&xyz).iter().enumerate() {
                    let res = max_abs(&(&em.k * rb)) / (kmax * max_abs(rb));
                    assert!(res < 1e-10, "rigid mode {i}: relative residual {res:e}");
                }
                let lam = eigenvalues(&em.k);
                let lmax = lam.last().copied().unwrap();
                let zero = lam.iter().filter(|l| l.abs() <= 1e-10 * lmax).count();
                assert_eq!(zero, 6, "{} nodes: eigenvalues {lam:?}", xyz.len());
                assert!(lam[6] > 1e-8 * lmax, "{lam:?}");
                assert!(em.m.llt(Side::Lower).is_ok());
                let mu = eigenvalues(&em.m);
                assert!(mu[0] > 0.0, "{mass:?}: smallest mass eigenvalue {}", mu[0]);
            }
        }
    }
}

/// `rᵀ M r = (ρ t + nsm) A` for a unit translation `r` in x, y and z, consistent and lumped
/// (relative 1e-12: exact integration, round-off only). A is the area of the projected quad,
/// ½ |d1 × d2|. Lumped mass is diagonal.
#[test]
fn total_translational_mass_is_rho_t_plus_nsm_times_area() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let r = random_rotation(&mut rng);
    for base in [&QUAD[..], &WARPED[..], &TRIA[..]] {
        let xyz = moved(base, &r, [1.0, 2.0, 3.0]);
        let area = if xyz.len() == 4 {
            0.5 * norm(&cross(&sub(&xyz[2], &xyz[0]), &sub(&xyz[3], &xyz[1])))
        } else {
            0.5 * norm(&cross(&sub(&xyz[1], &xyz[0]), &sub(&xyz[2], &xyz[0])))
        };
        let expected = (STEEL.rho * STEEL.thickness + STEEL.nsm) * area;
        for mass in [MassKind::Consistent, MassKind::Lumped] {
            let m = element(&xyz, &STEEL, mass).unwrap().m;
            for rb in rigid_modes(&xyz).iter().take(3) {
                let total = (rb.transpose() * &m * rb)[(0, 0)];
                assert!(
                    ((total - expected) / expected).abs() < 1e-12,
                    "{mass:?}: {total} vs {expected}"
                );
            }
            if mass == MassKind::Lumped {
                for i in 0..m.nrows() {
                    for j in 0..m.ncols() {
                        assert!(i == j || m[(i, j)] == 0.0);
                    }
                }
            }
        }
    }
}

/// K(R x) = Q K(x) Qᵀ with Q = diag(R, …, R), and the eigenvalues agree (relative 1e-10 of
/// max |K|: the local frame is built from the geometry, so only round-off differs).
#[test]
fn rotated_element_has_the_same_matrices_and_eigenvalues() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for base in [&QUAD[..], &WARPED[..], &TRIA[..]] {
        let em0 = element(base, &STEEL, MassKind::Consistent).unwrap();
        let lam0 = eigenvalues(&em0.k);
        for _ in 0..3 {
            let r = random_rotation(&mut rng);
            let xyz = moved(base, &r, [0.0; 3]);
            let em = element(&xyz, &STEEL, MassKind::Consistent).unwrap();
            let n = em.k.nrows();
            let q = Mat::from_fn(
                n,
                n,
                |i, j| {
                    if i / 3 == j / 3 { r[i % 3][j % 3] } else { 0.0 }
                },
            );
            let k_expected = &q * &em0.k * q.transpose();
            let m_expected = &q * &em0.m * q.transpose();
            assert!(max_diff(&em.k, &k_expected) < 1e-10 * max_abs(&em0.k));
            assert!(max_diff(&em.m, &m_expected) < 1e-10 * max_abs(&em0.m));
            let lam = eigenvalues(&em.k);
            let lmax = lam0.last().unwrap();
            for (a, b) in lam.iter().zip(lam0.iter()) {
                assert!((a - b).abs() < 1e-10 * lmax, "{a} vs {b}");
            }
        }
    }
}

// ------------------------------------------------------------------------------------------
// Small dense meshes.

struct Mesh {
    nodes: Vec<[f64; 3]>,
    quads: Vec<[usize; 4]>,
    trias: Vec<[usize; 3]>,
}

impl Mesh {
    /// `nx × ny` quads on `[0, lx] × [0, ly]`, node `j (nx + 1) + i`.
    fn grid(lx: f64, ly: f64, nx: usize, ny: usize) -> Mesh {
        let mut nodes = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                nodes.push([lx * i as f64 / nx as f64, ly * j as f64 / ny as f64, 0.0]);
            }
        }
        let mut quads = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let a = j * (nx + 1) + i;
                quads.push([a, a + 1, a + nx + 2, a + nx + 1]);
            }
        }
        Mesh {
            nodes,
            quads,
            trias: Vec::new(),
        }
    }

    /// Each quad split in two triangles, the diagonal alternating in a chequerboard.
    fn split(&self, nx: usize) -> Mesh {
        let mut trias = Vec::new();
        for (e, q) in self.quads.iter().enumerate() {
            if (e % nx + e / nx).is_multiple_of(2) {
                trias.push([q[0], q[1], q[2]]);
                trias.push([q[0], q[2], q[3]]);
            } else {
                trias.push([q[0], q[1], q[3]]);
                trias.push([q[1], q[2], q[3]]);
            }
        }
        Mesh {
            nodes: self.nodes.clone(),
            quads: Vec::new(),
            trias,
        }
    }

    fn ndof(&self) -> usize {
        6 * self.nodes.len()
    }

    fn assemble(&self, s: &ShellSection, mass: MassKind, drill: f64) -> (Mat<f64>, Mat<f64>) {
        let n = self.ndof();
        let mut k = Mat::<f64>::zeros(n, n);
        let mut m = Mat::<f64>::zeros(n, n);
        let elements = self
            .quads
            .iter()
            .map(|q| q.to_vec())
            .chain(self.trias.iter().map(|t| t.to_vec()));
        for conn in elements {
            let xyz: Vec<[f64; 3]> = conn.iter().map(|&i| self.nodes[i]).collect();
            let em = element_drill(&xyz, s, mass, drill).unwrap();
            for (a, &na) in conn.iter().enumerate() {
                for (b, &nb) in conn.iter().enumerate() {
                    for i in 0..6 {
                        for j in 0..6 {
                            k[(6 * na + i, 6 * nb + j)] += em.k[(6 * a + i, 6 * b + j)];
                            m[(6 * na + i, 6 * nb + j)] += em.m[(6 * a + i, 6 * b + j)];
                        }
                    }
                }
            }
        }
        (k, m)
    }
}

fn restrict(a: &Mat<f64>, rows: &[usize], cols: &[usize]) -> Mat<f64> {
    Mat::from_fn(rows.len(), cols.len(), |i, j| a[(rows[i], cols[j])])
}

fn free_dofs(n: usize, fixed: &[usize]) -> Vec<usize> {
    (0..n).filter(|d| !fixed.contains(d)).collect()
}

/// Solves `K u = f` on the free DOFs with the others held at `u_fixed` (dense LU).
fn solve_static(k: &Mat<f64>, f: &[f64], prescribed: &[(usize, f64)]) -> Vec<f64> {
    let n = k.nrows();
    let fixed: Vec<usize> = prescribed.iter().map(|p| p.0).collect();
    let free = free_dofs(n, &fixed);
    let kff = restrict(k, &free, &free);
    let kfb = restrict(k, &free, &fixed);
    let ub = Mat::from_fn(fixed.len(), 1, |i, _| prescribed[i].1);
    let rhs = Mat::from_fn(free.len(), 1, |i, _| f[free[i]]) - &kfb * &ub;
    let uf = kff.partial_piv_lu().solve(&rhs);
    let mut u = vec![0.0; n];
    for (i, &d) in free.iter().enumerate() {
        u[d] = uf[(i, 0)];
    }
    for &(d, v) in prescribed {
        u[d] = v;
    }
    u
}

/// Natural frequencies (Hz) of the lowest `count` modes with `fixed` DOFs removed, and the
/// number of rigid-body modes, from `crate::eigen::dense_generalized` (shift-invert with
/// Rayleigh quotients), cross-checked against the eigenvalues alone of the Cholesky-reduced
/// matrix (accurate to ~1e-16 λ_max): they must agree to 1e-6 on every elastic mode.
fn frequencies(k: &Mat<f64>, m: &Mat<f64>, fixed: &[usize], count: usize) -> (Vec<f64>, usize) {
    let free = free_dofs(k.nrows(), fixed);
    let dofs: Vec<DofId> = free
        .iter()
        .map(|&d| DofId::new((d / 6 + 1) as u64, Component::ALL[d % 6]))
        .collect();
    let (kf, mf) = (restrict(k, &free, &free), restrict(m, &free, &free));
    let (exact, rigid) = frequencies_values_only(&kf, &mf, count);
    let modes =
        dense_generalized(kf.as_ref(), mf.as_ref(), &dofs, ModeSelection::Count(count)).unwrap();
    assert_eq!(rigid, modes.rigid_body_modes, "rigid-body mode count");
    let got = modes.frequencies_hz();
    for (i, (f, e)) in got.iter().zip(&exact).enumerate() {
        if i >= rigid {
            assert!(
                ((f - e) / e).abs() < 1e-6,
                "mode {i}: dense_generalized {f} Hz vs values-only {e} Hz"
            );
        }
    }
    (got, rigid)
}

/// Frequencies (Hz) of the lowest `count` modes and the number of rigid-body modes
/// (`|λ| ≤ 1e-10 λ_max`) from the eigenvalues alone of `L⁻¹ K L⁻ᵀ`, `M = L Lᵀ`.
fn frequencies_values_only(kf: &Mat<f64>, mf: &Mat<f64>, count: usize) -> (Vec<f64>, usize) {
    let llt = mf.llt(Side::Lower).unwrap();
    let l = llt.L();
    let mut x = kf.clone();
    solve_lower_triangular_in_place(l, x.as_mut(), Par::Seq);
    let mut a = x.transpose().to_owned();
    solve_lower_triangular_in_place(l, a.as_mut(), Par::Seq);
    let a = Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let lambda = eigenvalues(&a);
    let lmax = *lambda.last().unwrap();
    let rigid = lambda.iter().filter(|l| l.abs() <= 1e-10 * lmax).count();
    let f = lambda[..count]
        .iter()
        .map(|l| l.max(0.0).sqrt() / (2.0 * std::f64::consts::PI))
        .collect();
    (f, rigid)
}

/// MacNeal–Harder patch: 0.24 × 0.12 with four interior nodes, five distorted quads.
fn patch() -> Mesh {
    let nodes = vec![
        [0.0, 0.0, 0.0],
        [0.24, 0.0, 0.0],
        [0.24, 0.12, 0.0],
        [0.0, 0.12, 0.0],
        [0.04, 0.02, 0.0],
        [0.18, 0.03, 0.0],
        [0.16, 0.08, 0.0],
        [0.08, 0.08, 0.0],
    ];
    let quads = vec![
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
        [4, 5, 6, 7],
    ];
    Mesh {
        nodes,
        quads,
        trias: Vec::new(),
    }
}

/// Linear membrane field with a rigid rotation, and a constant-curvature plate field.
fn patch_field(p: &[f64; 3]) -> [f64; 6] {
    let (x, y) = (p[0], p[1]);
    let omega = 2e-4;
    [
        1e-3 * (x + 0.5 * y) - omega * y,
        1e-3 * (y + 0.5 * x) + omega * x,
        1e-3 * 0.5 * (x * x + x * y + y * y),
        1e-3 * (0.5 * x + y),
        -1e-3 * (x + 0.5 * y),
        omega,
    ]
}

/// Patch tests (MacNeal & Harder 1985): boundary nodes held at a constant-membrane-strain
/// field (with a rigid in-plane rotation and matching θz) and a constant-curvature plate
/// field (w quadratic, θ = its slopes, so zero transverse shear); the four interior nodes must
/// take the exact field. Tolerance 1e-9 of the largest value: an exactly reproduced field
/// leaves only round-off of a K with entries spanning ~1e8.
#[test]
fn patch_tests_constant_membrane_strain_and_constant_curvature() {
    let s = ShellSection {
        thickness: 0.001,
        e: 1e6,
        nu: 0.25,
        rho: 1.0,
        nsm: 0.0,
        layers: None,
    };
    let quads = patch();
    let trias = quads.split(1);
    for mesh in [&quads, &trias] {
        let (k, _) = mesh.assemble(&s, MassKind::Consistent, DRILLING_FACTOR);
        let mut prescribed = Vec::new();
        for node in 0..4 {
            let f = patch_field(&mesh.nodes[node]);
            for (c, v) in f.iter().enumerate() {
                prescribed.push((6 * node + c, *v));
            }
        }
        let u = solve_static(&k, &vec![0.0; mesh.ndof()], &prescribed);
        for node in 4..8 {
            let f = patch_field(&mesh.nodes[node]);
            for c in 0..6 {
                let err = (u[6 * node + c] - f[c]).abs();
                assert!(
                    err < 1e-9 * 1e-3,
                    "{} elements, node {node} comp {c}: {} vs {}",
                    mesh.quads.len() + mesh.trias.len(),
                    u[6 * node + c],
                    f[c]
                );
            }
        }
    }
}

// ------------------------------------------------------------------------------------------
// Derivatives.

const PARAMS: [ShellParameter; 4] = ShellParameter::ALL;

/// Every analytic derivative equals a central difference with relative step 1e-6, to 1e-7 of
/// the derivative's scale `max(|∂K/∂φ|, |K|/φ)`: the truncation error is ~h² ≈ 1e-12 and the
/// round-off ~1e-16/1e-6 = 1e-10. Warped quad and general triangle, randomly oriented, both
/// mass kinds, and the combined call equals the single ones.
#[test]
fn derivatives_match_central_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let r = random_rotation(&mut rng);
    for base in [&WARPED[..], &TRIA[..]] {
        let xyz = moved(base, &r, [0.5, -1.0, 2.0]);
        for mass in [MassKind::Consistent, MassKind::Lumped] {
            let em = element(&xyz, &STEEL, mass).unwrap();
            for p in PARAMS {
                let d = derivative(&xyz, &STEEL, mass, p);
                let v = STEEL.parameter(p);
                let h = 1e-6 * v;
                let plus = element(&xyz, &STEEL.with_parameter(p, v + h), mass).unwrap();
                let minus = element(&xyz, &STEEL.with_parameter(p, v - h), mass).unwrap();
                let fd_k = (&plus.k - &minus.k) * (1.0 / (2.0 * h));
                let fd_m = (&plus.m - &minus.m) * (1.0 / (2.0 * h));
                let sk = max_abs(&d.dk).max(max_abs(&em.k) / v);
                let sm = max_abs(&d.dm).max(max_abs(&em.m) / v);
                let ek = max_diff(&fd_k, &d.dk) / sk;
                let emm = max_diff(&fd_m, &d.dm) / sm;
                assert!(
                    ek < 1e-7,
                    "{} nodes {mass:?} {p:?}: dK error {ek:e}",
                    xyz.len()
                );
                assert!(
                    emm < 1e-7,
                    "{} nodes {mass:?} {p:?}: dM error {emm:e}",
                    xyz.len()
                );
            }
            let (em2, ds) = if xyz.len() == 4 {
                quad4_with_derivatives(xyz[..].try_into().unwrap(), &STEEL, mass, &PARAMS)
            } else {
                tria3_with_derivatives(xyz[..].try_into().unwrap(), &STEEL, mass, &PARAMS)
            }
            .unwrap();
            assert_eq!(em2, em);
            for (p, d) in PARAMS.iter().zip(ds) {
                assert_eq!(d, derivative(&xyz, &STEEL, mass, *p));
            }
        }
    }
}

/// Non-homogeneous sections (Nastran PSHELL variants) to test every combination with.
fn layered() -> Vec<(&'static str, ShellSection)> {
    let other = LayerMaterial::Other {
        e: 7.0e10,
        nu: 0.33,
    };
    let with = |l: ShellLayers| ShellSection {
        layers: Some(l),
        ..STEEL
    };
    let full = ShellLayers {
        membrane: true,
        bending: Some(LayerMaterial::Own),
        shear: LayerMaterial::Own,
        bending_ratio: 1.0,
        shear_ratio: SHEAR_CORRECTION,
    };
    vec![
        (
            "membrane only",
            with(ShellLayers {
                bending: None,
                ..full
            }),
        ),
        (
            "bending only",
            with(ShellLayers {
                membrane: false,
                ..full
            }),
        ),
        (
            "other bending material, 12I/T3 = 2.5",
            with(ShellLayers {
                bending: Some(other),
                bending_ratio: 2.5,
                ..full
            }),
        ),
        (
            "other shear material, TS/T = 0.6",
            with(ShellLayers {
                shear: other,
                shear_ratio: 0.6,
                ..full
            }),
        ),
        (
            "bending only of another material",
            with(ShellLayers {
                membrane: false,
                bending: Some(other),
                shear: other,
                ..full
            }),
        ),
    ]
}

/// Every parameter derivative of every PSHELL variant against central differences (as
/// `derivatives_match_central_differences`: relative step 1e-6, tolerance 1e-7 of the
/// derivative's scale), quad (warped, rotated) and triangle, both mass kinds. The Young's
/// modulus is the section's own: parts of another material do not follow it.
#[test]
fn layered_derivatives_match_central_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let r = random_rotation(&mut rng);
    for (name, s) in layered() {
        for base in [&WARPED[..], &TRIA[..]] {
            let xyz = moved(base, &r, [0.5, -1.0, 2.0]);
            for mass in [MassKind::Consistent, MassKind::Lumped] {
                let em = element(&xyz, &s, mass).unwrap();
                for p in PARAMS {
                    let d = derivative(&xyz, &s, mass, p);
                    let v = s.parameter(p);
                    let h = 1e-6 * v;
                    let plus = element(&xyz, &s.with_parameter(p, v + h), mass).unwrap();
                    let minus = element(&xyz, &s.with_parameter(p, v - h), mass).unwrap();
                    let fd_k = (&plus.k - &minus.k) * (1.0 / (2.0 * h));
                    let fd_m = (&plus.m - &minus.m) * (1.0 / (2.0 * h));
                    let sk = max_abs(&d.dk).max(max_abs(&em.k) / v);
                    let sm = max_abs(&d.dm).max(max_abs(&em.m) / v);
                    let ek = max_diff(&fd_k, &d.dk) / sk;
                    let emm = max_diff(&fd_m, &d.dm) / sm;
                    assert!(
                        ek < 1e-7,
                        "{name} {} nodes {mass:?} {p:?}: dK {ek:e}",
                        xyz.len()
                    );
                    assert!(
                        emm < 1e-7,
                        "{name} {} nodes {mass:?} {p:?}: dM {emm:e}",
                        xyz.len()
                    );
                }
            }
        }
    }
}

/// A PSHELL whose parts all have their defaults gives bit-identical matrices to the
/// homogeneous section (so existing meshes keep their digests).
#[test]
fn default_layers_are_the_homogeneous_shell_bit_for_bit() {
    let s = ShellSection {
        layers: Some(ShellLayers {
            membrane: true,
            bending: Some(LayerMaterial::Own),
            shear: LayerMaterial::Own,
            bending_ratio: 1.0,
            shear_ratio: SHEAR_CORRECTION,
        }),
        ..STEEL
    };
    for xyz in [&WARPED[..], &TRIA[..]] {
        for mass in [MassKind::Consistent, MassKind::Lumped] {
            assert_eq!(element(xyz, &s, mass), element(xyz, &STEEL, mass));
        }
    }
}

/// Membrane only: no stiffness on w, θx, θy, θz and no rotary inertia (the assembly drops
/// the rotations); bending only: no stiffness on u, v, θz and no θz inertia, translational
/// mass on all three translations. The flat quad lies in the basic x-y plane.
#[test]
fn membrane_only_and_bending_only_have_only_their_parts() {
    let [mem, bend, ..] = &layered()[..] else {
        unreachable!()
    };
    for mass in [MassKind::Consistent, MassKind::Lumped] {
        for (s, no_k, no_m) in [
            (&mem.1, vec![2, 3, 4, 5], vec![3, 4, 5]),
            (&bend.1, vec![0, 1, 5], vec![5]),
        ] {
            for xyz in [&QUAD[..], &TRIA[..]] {
                let em = element(xyz, s, mass).unwrap();
                let n = em.k.nrows();
                for r in 0..n {
                    for c in 0..n {
                        if no_k.contains(&(r % 6)) || no_k.contains(&(c % 6)) {
                            assert_eq!(em.k[(r, c)], 0.0, "K ({r},{c})");
                        }
                        if no_m.contains(&(r % 6)) || no_m.contains(&(c % 6)) {
                            assert!(em.m[(r, c)].abs() < 1e-18, "M ({r},{c})");
                        }
                    }
                    if r % 6 < 3 {
                        assert!(em.m[(r, r)] > 0.0);
                    }
                    if !no_k.contains(&(r % 6)) {
                        assert!(em.k[(r, r)] > 0.0, "{r}");
                    }
                }
            }
        }
    }
}

/// With ρ = 0 (a massless stiffness element) the density derivative is still defined.
#[test]
fn density_derivative_at_zero_density() {
    let s = ShellSection { rho: 0.0, ..STEEL };
    let d = quad4_derivative(&QUAD, &s, MassKind::Consistent, ShellParameter::Density).unwrap();
    assert!(max_abs(&d.dm) > 0.0 && max_abs(&d.dk) == 0.0);
}

// ------------------------------------------------------------------------------------------
// Drilling and warping.

/// Condensing θz out of one flat element gives the drilling-free element exactly (relative
/// 1e-10 of max |K|: round-off of a Schur complement), so the penalty stiffens neither
/// membrane nor bending inside an element.
#[test]
fn drilling_penalty_condenses_out_of_one_element() {
    for base in [&QUAD[..], &TRIA[..]] {
        let k = element_drill(base, &STEEL, MassKind::Consistent, DRILLING_FACTOR)
            .unwrap()
            .k;
        let k0 = element_drill(base, &STEEL, MassKind::Consistent, 0.0)
            .unwrap()
            .k;
        let n = k.nrows();
        let rz: Vec<usize> = (0..n).filter(|i| i % 6 == 5).collect();
        let other = free_dofs(n, &rz);
        let krr = restrict(&k, &rz, &rz);
        let kro = restrict(&k, &rz, &other);
        let schur =
            restrict(&k, &other, &other) - kro.transpose() * krr.partial_piv_lu().solve(&kro);
        let err = max_diff(&schur, &restrict(&k0, &other, &other)) / max_abs(&k0);
        assert!(err < 1e-10, "{} nodes: {err:e}", base.len());
    }
}

/// In a flat plate the drilling penalty is uncoupled from bending: in a free 6 × 6 plate the
/// bending block (uz, rx, ry) of K is bit-identical for α_d = 1e-3 and 1e-1 and its coupling to
/// (ux, uy, rz) is exactly zero, so the first 15 elastic (bending) frequencies agree (relative
/// 1e-7: eigensolver round-off). In-plane, a 10 × 2 membrane cantilever under an end couple
/// (ν = 0, whose exact solution QM6 reproduces on rectangles) matches M L²/(2EI) within 0.2 %
/// and moves by less than 0.1 % between α_d = 1e-3 and 1e-6: the O(α_d) mesh effect.
#[test]
fn drilling_penalty_leaves_bending_and_membrane_modes_alone() {
    let s = ShellSection {
        thickness: 0.05,
        e: 200e9,
        nu: 0.3,
        rho: 8000.0,
        nsm: 0.0,
        layers: None,
    };
    let mesh = Mesh::grid(10.0, 10.0, 6, 6);
    let (k1, m1) = mesh.assemble(&s, MassKind::Consistent, 1e-3);
    let (k2, m2) = mesh.assemble(&s, MassKind::Consistent, 1e-1);
    let n = k1.nrows();
    let bending: Vec<usize> = (0..n).filter(|i| [2, 3, 4].contains(&(i % 6))).collect();
    let membrane = free_dofs(n, &bending);
    assert_eq!(
        max_diff(
            &restrict(&k1, &bending, &bending),
            &restrict(&k2, &bending, &bending)
        ),
        0.0
    );
    assert_eq!(max_abs(&restrict(&k1, &bending, &membrane)), 0.0);
    let (f1, _) = frequencies(&k1, &m1, &[], 21);
    let (f2, _) = frequencies(&k2, &m2, &[], 21);
    for i in 6..21 {
        assert!(
            ((f1[i] - f2[i]) / f1[i]).abs() < 1e-7,
            "mode {i}: {} vs {}",
            f1[i],
            f2[i]
        );
    }

    let (l, h, t) = (1.0, 0.2, 0.01);
    let s = ShellSection {
        thickness: t,
        e: 200e9,
        nu: 0.0,
        rho: 8000.0,
        nsm: 0.0,
        layers: None,
    };
    let mesh = Mesh::grid(l, h, 10, 2);
    let couple = 1000.0;
    let tip = |drill: f64| {
        let (k, _) = mesh.assemble(&s, MassKind::Consistent, drill);
        let mut f = vec![0.0; mesh.ndof()];
        // Tip nodes 10 (y = 0), 21 (y = h/2), 32 (y = h): linear stress → forces ∓F, 0, ±F
        // with moment F h.
        let force = couple / h;
        f[6 * 10] += force;
        f[6 * 32] -= force;
        let fixed: Vec<(usize, f64)> = (0..3)
            .flat_map(|j| (0..6).map(move |c| (6 * (11 * j) + c, 0.0)))
            .collect();
        let u = solve_static(&k, &f, &fixed);
        u[6 * 21 + 1]
    };
    let inertia = t * h * h * h / 12.0;
    let exact = couple * l * l / (2.0 * s.e * inertia);
    let v1 = tip(1e-3);
    let v2 = tip(1e-6);
    eprintln!("in-plane couple: tip v {v1:e} (α 1e-3), {v2:e} (α 1e-6), exact {exact:e}");
    assert!(((v1 - exact) / exact).abs() < 2e-3, "{v1} vs {exact}");
    assert!(((v1 - v2) / v2).abs() < 1e-3, "{v1} vs {v2}");
}

/// A slightly warped quad is continuous with the flat one: with corner offsets ±h the change
/// of K and M relative to the flat element is below 10 h/L (first order in h) and goes to
/// zero with h.
#[test]
fn slightly_warped_quad_is_continuous_with_the_flat_one() {
    let flat = quad4(&QUAD, &STEEL, MassKind::Consistent).unwrap();
    let mut last = f64::INFINITY;
    for h in [1e-2, 1e-4, 1e-6] {
        let mut xyz = QUAD;
        for (i, p) in xyz.iter_mut().enumerate() {
            p[2] = if i % 2 == 0 { h } else { -h };
        }
        let w = quad4(&xyz, &STEEL, MassKind::Consistent).unwrap();
        let dk = max_diff(&w.k, &flat.k) / max_abs(&flat.k);
        let dm = max_diff(&w.m, &flat.m) / max_abs(&flat.m);
        eprintln!("warp {h:e}: dK {dk:e}, dM {dm:e}");
        assert!(dk < 10.0 * h && dm < 10.0 * h, "h {h}: {dk:e} {dm:e}");
        assert!(dk < last);
        last = dk;
    }
}

// ------------------------------------------------------------------------------------------
// Cantilever strips: no shear locking.

/// Tip deflection of a strip `L × b` of `nx × 1` elements clamped at x = 0 under a tip load
/// P = 1 N shared by the two tip nodes (ν = 0, so the plate strip is a Timoshenko beam).
fn strip_tip(t: f64, tria: bool) -> (f64, f64, f64) {
    let (l, b, nx) = (1.0, 0.1, 10);
    let s = ShellSection {
        thickness: t,
        e: 200e9,
        nu: 0.0,
        rho: 8000.0,
        nsm: 0.0,
        layers: None,
    };
    let quads = Mesh::grid(l, b, nx, 1);
    let mesh = if tria { quads.split(nx) } else { quads };
    let (k, _) = mesh.assemble(&s, MassKind::Consistent, DRILLING_FACTOR);
    let mut f = vec![0.0; mesh.ndof()];
    f[6 * nx + 2] = 0.5;
    f[6 * (2 * nx + 1) + 2] = 0.5;
    let fixed: Vec<(usize, f64)> = [0, nx + 1]
        .iter()
        .flat_map(|n| (0..6).map(move |c| (6 * n + c, 0.0)))
        .collect();
    let u = solve_static(&k, &f, &fixed);
    let tip = 0.5 * (u[6 * nx + 2] + u[6 * (2 * nx + 1) + 2]);
    let i = b * t * t * t / 12.0;
    let euler = l * l * l / (3.0 * s.e * i);
    let timoshenko = euler + l / (SHEAR_CORRECTION * s.shear_modulus() * b * t);
    (tip, euler, timoshenko)
}

/// Thin strip (t/L = 1e-3): within 2 % of Euler–Bernoulli PL³/(3EI) with 10 quads and with
/// 20 triangles (a locking element would be orders of magnitude stiffer). Thick strip
/// (t/L = 0.25, shear adds 3.75 %): within 1 % of Timoshenko PL³/(3EI) + PL/(κGA).
#[test]
fn cantilever_strips_do_not_lock() {
    for tria in [false, true] {
        let (tip, euler, _) = strip_tip(1e-3, tria);
        let err = (tip - euler) / euler;
        eprintln!("thin strip (tria {tria}): tip {tip:e}, Euler {euler:e}, error {err:+.4e}");
        assert!(err.abs() < 0.02, "tria {tria}: {tip} vs {euler}");
        let (tip, euler, timo) = strip_tip(0.25, tria);
        let err = (tip - timo) / timo;
        eprintln!(
            "thick strip (tria {tria}): tip {tip:e}, Timoshenko {timo:e}, Euler {euler:e}, error {err:+.4e}"
        );
        assert!(err.abs() < 0.01, "tria {tria}: {tip} vs {timo}");
    }
}

// ------------------------------------------------------------------------------------------
// NAFEMS free-vibration benchmarks (NAFEMS R0015, "Selected Benchmarks for Natural Frequency
// Analysis", 1987): 10 m × 10 m × 0.05 m steel plate, E = 200 GPa, ν = 0.3, ρ = 8000 kg/m³.
// Reference values as tabulated from R0015 in Altair's OptiStruct verification problems
// OS-V 0420 (FV12) and OS-V 0430 (FV16).

const FV_SECTION: ShellSection = ShellSection {
    thickness: 0.05,
    e: 200e9,
    nu: 0.3,
    rho: 8000.0,
    nsm: 0.0,
    layers: None,
};
/// FV12 free plate, elastic modes 4–9 of the three-rigid-mode model (Hz).
const FV12: [f64; 6] = [1.622, 2.360, 2.922, 4.233, 4.233, 7.416];
/// FV16 cantilevered plate, modes 1–6 (Hz).
const FV16: [f64; 6] = [0.421, 1.029, 2.582, 3.306, 3.753, 6.555];

fn fv12(tria: bool, mass: MassKind, n: usize, bending_only: bool) -> (Vec<f64>, usize) {
    let quads = Mesh::grid(10.0, 10.0, n, n);
    let mesh = if tria { quads.split(n) } else { quads };
    let (k, m) = mesh.assemble(&FV_SECTION, mass, DRILLING_FACTOR);
    // In a flat plate K and M are exactly block-diagonal between (uz, rx, ry) and
    // (ux, uy, rz) (see the drilling test), so the bending modes of the bending block are
    // those of the whole model.
    if bending_only {
        let bending: Vec<usize> = (0..mesh.ndof())
            .filter(|d| [2, 3, 4].contains(&(d % 6)))
            .collect();
        let kb = restrict(&k, &bending, &bending);
        let mb = restrict(&m, &bending, &bending);
        frequencies(&kb, &mb, &[], 13)
    } else {
        frequencies(&k, &m, &[], 13)
    }
}

fn fv16(tria: bool, mass: MassKind, n: usize) -> Vec<f64> {
    let quads = Mesh::grid(10.0, 10.0, n, n);
    let mesh = if tria { quads.split(n) } else { quads };
    let (k, m) = mesh.assemble(&FV_SECTION, mass, DRILLING_FACTOR);
    // Clamped along the y axis (x = 0) as NAFEMS states: ux, uy, uz and ry fixed.
    let fixed: Vec<usize> = (0..=n)
        .flat_map(|j| [0, 1, 2, 4].map(|c| 6 * j * (n + 1) + c))
        .collect();
    frequencies(&k, &m, &fixed, 6).0
}

fn check(name: &str, got: &[f64], reference: &[f64], tol: f64) {
    let errs: Vec<f64> = got
        .iter()
        .zip(reference)
        .map(|(g, r)| (g - r) / r)
        .collect();
    eprintln!("{name}:");
    for ((g, r), e) in got.iter().zip(reference).zip(&errs) {
        eprintln!("  {g:8.4} Hz  ref {r:6.3}  {:+6.2} %", 100.0 * e);
    }
    for (i, e) in errs.iter().enumerate() {
        assert!(
            e.abs() < tol,
            "{name} mode {}: error {:+.2} %",
            i + 1,
            100.0 * e
        );
    }
}

/// FV12. The free 6-DOF model of 10 × 10 quads (726 DOFs) has exactly six rigid-body
/// modes; its elastic modes 4–8 are within 2.5 % and mode 9 (the most wavy, converging
/// slowest) within 5.5 % (commercial QUAD4 elements on 8 × 8 give +5.2 % there). The bending
/// block of a 16 × 16 mesh (867 DOFs, three rigid-body modes) has all six within 2.5 %,
/// consistent or lumped mass. The 10 × 10 and 16 × 16 meshes split into triangles: within
/// 5 % and 3 %.
#[test]
fn nafems_fv12_free_thin_square_plate() {
    let (f, rigid) = fv12(false, MassKind::Consistent, 10, false);
    assert_eq!(rigid, 6, "{f:?}");
    assert!(f[6] > 1.0);
    check(
        "FV12 quad4 consistent 10x10 (6 DOF)",
        &f[6..11],
        &FV12[..5],
        0.025,
    );
    check(
        "FV12 quad4 consistent 10x10 (6 DOF)",
        &f[11..12],
        &FV12[5..],
        0.055,
    );
    let (f, rigid) = fv12(true, MassKind::Consistent, 10, false);
    assert_eq!(rigid, 6, "{f:?}");
    check(
        "FV12 tria3 consistent 10x10x2 (6 DOF)",
        &f[6..12],
        &FV12,
        0.05,
    );
    for (tria, mass, tol) in [
        (false, MassKind::Consistent, 0.025),
        (false, MassKind::Lumped, 0.025),
        (true, MassKind::Consistent, 0.03),
    ] {
        let (f, rigid) = fv12(tria, mass, 16, true);
        assert_eq!(rigid, 3, "{f:?}");
        let name = format!(
            "FV12 {} {mass:?} 16x16 (bending block)",
            if tria { "tria3" } else { "quad4" }
        );
        check(&name, &f[3..9], &FV12, tol);
    }
}

/// FV16 cantilevered plate, 10 × 10 quads (660 free DOFs): the six reference frequencies
/// within 2.5 % with consistent mass (worst measured +2.0 %) and 5 % with lumped mass (worst
/// −4.0 %: lumping lowers the frequencies, O(h²)); split into triangles within 5 % (worst
/// +3.5 %). The clamp follows NAFEMS (ux, uy, uz, ry fixed along x = 0).
#[test]
fn nafems_fv16_cantilevered_thin_square_plate() {
    check(
        "FV16 quad4 consistent 10x10",
        &fv16(false, MassKind::Consistent, 10),
        &FV16,
        0.025,
    );
    check(
        "FV16 quad4 lumped 10x10",
        &fv16(false, MassKind::Lumped, 10),
        &FV16,
        0.05,
    );
    check(
        "FV16 tria3 consistent 10x10x2",
        &fv16(true, MassKind::Consistent, 10),
        &FV16,
        0.05,
    );
}

// ------------------------------------------------------------------------------------------
// Errors.

fn message(r: Result<ElementMatrices, ElementError>) -> String {
    r.unwrap_err().to_string()
}

#[test]
fn bad_geometry_and_values_are_errors_that_say_what_is_wrong() {
    let c = MassKind::Consistent;
    let mut nan = QUAD;
    nan[2][1] = f64::NAN;
    assert!(message(quad4(&nan, &STEEL, c)).contains("node 3 has a non-finite"));
    let mut same = QUAD;
    same[3] = same[1];
    assert!(message(quad4(&same, &STEEL, c)).contains("nodes 2 and 4 coincide"));
    assert!(message(quad4(&[[1.0; 3]; 4], &STEEL, c)).contains("all 4 nodes coincide"));
    let line = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]];
    assert!(message(tria3(&line, &STEEL, c)).contains("zero area"));
    let concave = [
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.0, 2.0, 0.0],
    ];
    let e = message(quad4(&concave, &STEEL, c));
    assert!(e.contains("corner node 3") && e.contains("negative"), "{e}");
    let bowtie = [
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    assert!(message(quad4(&bowtie, &STEEL, c)).contains("zero area"));
    let bowtie2 = [
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [0.5, 1.0, 0.0],
        [1.5, 1.2, 0.0],
    ];
    let e = message(quad4(&bowtie2, &STEEL, c));
    assert!(e.contains("Jacobian"), "{e}");
    let collinear = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    let e = message(quad4(&collinear, &STEEL, c));
    assert!(
        e.contains("corner node 2") && e.contains("collinear"),
        "{e}"
    );
    let mut warped = QUAD;
    warped[0][2] = 0.5;
    warped[2][2] = 0.5;
    assert!(message(quad4(&warped, &STEEL, c)).contains("warped"));
    let huge = [[0.0, 0.0, 0.0], [1e300, 0.0, 0.0], [0.0, 1e300, 0.0]];
    assert!(message(tria3(&huge, &STEEL, c)).contains("too large"));
    let overflow = ShellSection {
        e: 1e300,
        thickness: 1e200,
        ..STEEL
    };
    assert!(message(tria3(&TRIA, &overflow, c)).contains("overflow"));
    for (s, field) in [
        (
            ShellSection {
                thickness: 0.0,
                ..STEEL
            },
            "thickness",
        ),
        (
            ShellSection {
                e: f64::NAN,
                ..STEEL
            },
            "e =",
        ),
        (ShellSection { nu: 0.5, ..STEEL }, "nu"),
        (ShellSection { nu: -1.0, ..STEEL }, "nu"),
        (ShellSection { rho: -1.0, ..STEEL }, "rho"),
        (
            ShellSection {
                nsm: f64::INFINITY,
                ..STEEL
            },
            "nsm",
        ),
    ] {
        let e = message(quad4(&QUAD, &s, c));
        assert!(e.starts_with(field), "{e}");
        let e = message(tria3(&TRIA, &s, c));
        assert!(e.starts_with(field), "{e}");
    }
}

/// No input panics: 2000 random elements whose coordinates and section values are drawn from
/// ordinary numbers, zero, ±inf, NaN, 1e±300; every result is an error or finite matrices.
#[test]
fn no_input_panics() {
    let specials = [
        0.0,
        1.0,
        -1.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e300,
        1e-300,
        0.3,
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let pick = |rng: &mut ChaCha8Rng| {
        if rng.random::<f64>() < 0.7 {
            2.0 * rng.random::<f64>() - 1.0
        } else {
            specials[rng.random_range(0..specials.len())]
        }
    };
    let finite = |em: &ElementMatrices| {
        (0..em.k.nrows()).all(|i| {
            (0..em.k.ncols()).all(|j| em.k[(i, j)].is_finite() && em.m[(i, j)].is_finite())
        })
    };
    for _ in 0..2000 {
        let mut q = [[0.0; 3]; 4];
        q.iter_mut().flatten().for_each(|v| *v = pick(&mut rng));
        let s = ShellSection {
            thickness: pick(&mut rng).abs(),
            e: pick(&mut rng).abs() * 1e9,
            nu: pick(&mut rng) * 0.4,
            rho: pick(&mut rng).abs(),
            nsm: pick(&mut rng).abs(),
            layers: None,
        };
        for mass in [MassKind::Consistent, MassKind::Lumped] {
            if let Ok(em) = quad4(&q, &s, mass) {
                assert!(finite(&em), "{q:?} {s:?}");
            }
            let t = [q[0], q[1], q[2]];
            if let Ok(em) = tria3(&t, &s, mass) {
                assert!(finite(&em), "{t:?} {s:?}");
            }
            for p in PARAMS {
                let _ = quad4_derivative(&q, &s, mass, p);
                let _ = tria3_derivative(&t, &s, mass, p);
            }
        }
    }
}
