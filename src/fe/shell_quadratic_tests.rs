//! Tests of the quadratic shells against independent references: rigid-body motions, exact
//! areas, patch tests, Kirchhoff plate frequencies, the flat quad4 on a refined mesh, and
//! central differences.

use super::*;
use crate::fe::shell::{LayerMaterial, ShellLayers, quad4};
use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Par, Side};
use std::f64::consts::PI;

const STEEL: ShellSection = ShellSection {
    thickness: 0.05,
    e: 210e9,
    nu: 0.3,
    rho: 7850.0,
    nsm: 3.0,
    layers: None,
};

/// A general straight-edged quad (no two sides parallel), midside nodes at the edge midpoints.
fn quad8_flat() -> [[f64; 3]; 8] {
    let c = [
        [0.0, 0.0, 0.0],
        [1.2, 0.1, 0.0],
        [1.0, 0.9, 0.0],
        [0.1, 0.8, 0.0],
    ];
    with_midpoints(&c)
}

fn with_midpoints<const C: usize, const N: usize>(c: &[[f64; 3]; C]) -> [[f64; 3]; N] {
    let mut out = [[0.0; 3]; N];
    for i in 0..C {
        out[i] = c[i];
        let j = (i + 1) % C;
        out[C + i] = [
            0.5 * (c[i][0] + c[j][0]),
            0.5 * (c[i][1] + c[j][1]),
            0.5 * (c[i][2] + c[j][2]),
        ];
    }
    out
}

fn tria6_flat() -> [[f64; 3]; 6] {
    with_midpoints(&[[0.0, 0.0, 0.0], [1.1, 0.2, 0.0], [0.3, 0.9, 0.0]])
}

/// A point of the cylinder of radius `r` about the x axis at angle `phi`, axial position `x`.
fn cyl(r: f64, x: f64, phi: f64) -> [f64; 3] {
    [x, r * phi.sin(), r * phi.cos()]
}

/// A curved quad8 on a cylinder (radius 1, 50° by 0.8), slightly irregular.
fn quad8_curved() -> [[f64; 3]; 8] {
    let a = 50f64.to_radians();
    [
        cyl(1.0, 0.0, 0.0),
        cyl(1.0, 0.8, 0.05),
        cyl(1.0, 0.75, a),
        cyl(1.0, 0.05, a - 0.03),
        cyl(1.0, 0.4, 0.02),
        cyl(1.0, 0.78, 0.5 * a),
        cyl(1.0, 0.42, a - 0.01),
        cyl(1.0, 0.02, 0.5 * a - 0.02),
    ]
}

fn tria6_curved() -> [[f64; 3]; 6] {
    let a = 50f64.to_radians();
    [
        cyl(1.0, 0.0, 0.0),
        cyl(1.0, 0.8, 0.05),
        cyl(1.0, 0.3, a),
        cyl(1.0, 0.4, 0.02),
        cyl(1.0, 0.55, 0.5 * a + 0.03),
        cyl(1.0, 0.15, 0.5 * a),
    ]
}

fn element(xyz: &[[f64; 3]], present: &[bool], s: &ShellSection, m: MassKind) -> ElementMatrices {
    match xyz.len() {
        8 => quad8(xyz.try_into().unwrap(), present.try_into().unwrap(), s, m).unwrap(),
        6 => tria6(xyz.try_into().unwrap(), present.try_into().unwrap(), s, m).unwrap(),
        n => panic!("{n} nodes"),
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

/// The coordinates of the element's DOF nodes (corners, then present midsides).
fn dof_nodes(xyz: &[[f64; 3]], present: &[bool]) -> Vec<[f64; 3]> {
    let c = present.len();
    let mut out = xyz[..c].to_vec();
    for k in 0..c {
        if present[k] {
            out.push(xyz[c + k]);
        }
    }
    out
}

fn rigid_modes(xyz: &[[f64; 3]]) -> Vec<Vec<f64>> {
    let n = 6 * xyz.len();
    let mut out = Vec::new();
    for k in 0..3 {
        out.push((0..n).map(|i| if i % 6 == k { 1.0 } else { 0.0 }).collect());
    }
    for k in 0..3 {
        let mut th = [0.0; 3];
        th[k] = 1.0;
        out.push(
            (0..n)
                .map(|i| {
                    let (node, c) = (i / 6, i % 6);
                    if c < 3 {
                        cross(&th, &xyz[node])[c]
                    } else {
                        th[c - 3]
                    }
                })
                .collect(),
        );
    }
    out
}

fn eigenvalues(m: &Mat<f64>) -> Vec<f64> {
    m.self_adjoint_eigenvalues(Side::Lower).unwrap()
}

fn rotate(xyz: &[[f64; 3]], shift: [f64; 3]) -> Vec<[f64; 3]> {
    // A fixed general rotation (axis (1, 2, 3)/√14, angle 0.7).
    let k = unit(&[1.0, 2.0, 3.0]);
    let (s, c) = (0.7f64.sin(), 0.7f64.cos());
    xyz.iter()
        .map(|p| {
            let kxp = cross(&k, p);
            let kp = dot(&k, p);
            let mut q = [0.0; 3];
            for i in 0..3 {
                q[i] = p[i] * c + kxp[i] * s + k[i] * kp * (1.0 - c) + shift[i];
            }
            q
        })
        .collect()
}

/// `K r = 0` for the six rigid-body motions (relative 1e-10 of `|K| |r|`: round-off of sums of
/// ~50 terms); exactly six eigenvalues below 1e-10 λ_max and the seventh above 1e-9 λ_max (the
/// smallest elastic one is the drilling penalty, ~1e-5 λ_max here); `M` positive definite. Flat
/// distorted and curved (cylindrical) elements, rotated and moved, with and without omitted
/// midside nodes, both mass kinds.
#[test]
fn six_rigid_body_modes_and_positive_definite_mass() {
    let q = [true; 4];
    let q2 = [true, false, true, false];
    let t = [true; 3];
    let t2 = [false, true, true];
    let q8f = quad8_flat();
    let q8c = quad8_curved();
    let t6f = tria6_flat();
    let t6c = tria6_curved();
    type Case<'a> = (&'a str, &'a [[f64; 3]], &'a [bool]);
    let cases: Vec<Case> = vec![
        ("quad8 flat", &q8f, &q),
        ("quad8 curved", &q8c, &q),
        ("quad8 curved, two midsides omitted", &q8c, &q2),
        ("tria6 flat", &t6f, &t),
        ("tria6 curved", &t6c, &t),
        ("tria6 curved, one midside omitted", &t6c, &t2),
    ];
    for (name, base, present) in cases {
        let xyz = rotate(base, [3.0, -2.0, 1.0]);
        for kind in [MassKind::Consistent, MassKind::Lumped] {
            let em = element(&xyz, present, &STEEL, kind);
            let nodes = dof_nodes(&xyz, present);
            let kmax = max_abs(&em.k);
            for (i, r) in rigid_modes(&nodes).iter().enumerate() {
                let rn = r.iter().map(|v| v * v).sum::<f64>().sqrt();
                for row in 0..em.k.nrows() {
                    let f: f64 = (0..em.k.ncols()).map(|c| em.k[(row, c)] * r[c]).sum();
                    assert!(
                        f.abs() < 1e-10 * kmax * rn,
                        "{name}: rigid mode {i} gives force {f:e} (|K| {kmax:e})"
                    );
                }
            }
            let lam = eigenvalues(&em.k);
            let lmax = *lam.last().unwrap();
            let zero = lam.iter().filter(|l| l.abs() < 1e-10 * lmax).count();
            assert_eq!(zero, 6, "{name}: zero-energy modes {:?}", &lam[..8]);
            assert!(
                lam[6] > 1e-9 * lmax,
                "{name}: seventh eigenvalue {:e}",
                lam[6]
            );
            let mu = eigenvalues(&em.m);
            assert!(mu[0] > 0.0, "{name} {kind:?}: mass eigenvalue {:e}", mu[0]);
        }
    }
}

/// The translational mass along each axis is `(ρ t + nsm) A` with the exact area: 0.845 for the
/// flat quad (shoelace), 0.465 for the triangle (to 1e-12: both integration rules are exact for
/// the polynomial integrands of a straight-edged element); `A` on the cylinder is `R × ∫ dφ dx`
/// of the mapped element, compared to 1e-4 (the quadratic geometry approximates the circle to
/// ~(Δφ)⁴/… there). Every lumped diagonal entry is positive; lumped and consistent have the same
/// total.
#[test]
fn total_mass_is_exact_and_lumped_masses_positive() {
    let mu = STEEL.rho * STEEL.thickness + STEEL.nsm;
    for (xyz, present, area) in [
        (&quad8_flat()[..], &[true; 4][..], 0.845),
        (&quad8_flat()[..], &[false, true, false, false][..], 0.845),
        (&tria6_flat()[..], &[true; 3][..], 0.465),
    ] {
        for kind in [MassKind::Consistent, MassKind::Lumped] {
            let em = element(xyz, present, &STEEL, kind);
            let n = em.m.nrows();
            for c in 0..3 {
                let total: f64 = (0..n)
                    .filter(|i| i % 6 == c)
                    .flat_map(|i| (0..n).filter(|j| j % 6 == c).map(move |j| (i, j)))
                    .map(|(i, j)| em.m[(i, j)])
                    .sum();
                assert!(
                    (total - mu * area).abs() < 1e-12 * mu * area,
                    "{} nodes {kind:?}: mass {total} vs {}",
                    xyz.len(),
                    mu * area
                );
            }
            if kind == MassKind::Lumped {
                for i in 0..n {
                    for j in 0..n {
                        if i != j && (i / 6 != j / 6 || i % 6 < 3 || j % 6 < 3) {
                            assert_eq!(em.m[(i, j)], 0.0, "lumped mass off-diagonal {i} {j}");
                        }
                    }
                    assert!(em.m[(i, i)] > 0.0, "lumped mass {i}: {}", em.m[(i, i)]);
                }
            }
        }
    }
    // HRZ on a square quad8: ∫N_c² = 2/15, ∫N_m² = 32/45 on [−1, 1]² (exact rational
    // integration), so the corner share is 3/76 and the midside share 16/76 of the area.
    let sq = with_midpoints(&[
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [2.0, 2.0, 0.0],
        [0.0, 2.0, 0.0],
    ]);
    let em = quad8(&sq, [true; 4], &STEEL, MassKind::Lumped).unwrap();
    let a = 4.0 * mu;
    assert!((em.m[(0, 0)] - a * 3.0 / 76.0).abs() < 1e-12 * a);
    assert!((em.m[(24, 24)] - a * 16.0 / 76.0).abs() < 1e-12 * a);
}

// ---------------------------------------------------------------------------------------------
// Meshes.

/// A mesh of quad8 or tria6 elements: element node lists index `nodes` (corners, then midsides).
struct Mesh {
    nodes: Vec<[f64; 3]>,
    elements: Vec<Vec<usize>>,
}

impl Mesh {
    /// `nx × ny` cells on the map `f(u, v)`, `u, v ∈ [0, 1]`, as quad8 (or tria6, two per cell,
    /// the diagonal alternating) with the midside nodes on the map.
    fn grid(nx: usize, ny: usize, tria: bool, f: &dyn Fn(f64, f64) -> [f64; 3]) -> Mesh {
        let (mx, my) = (2 * nx + 1, 2 * ny + 1);
        let nodes = (0..my)
            .flat_map(|j| (0..mx).map(move |i| (i, j)))
            .map(|(i, j)| f(i as f64 / (mx - 1) as f64, j as f64 / (my - 1) as f64))
            .collect();
        let id = |i: usize, j: usize| j * mx + i;
        let mut elements = Vec::new();
        for cj in 0..ny {
            for ci in 0..nx {
                let (i, j) = (2 * ci, 2 * cj);
                let c = [id(i, j), id(i + 2, j), id(i + 2, j + 2), id(i, j + 2)];
                if !tria {
                    elements.push(vec![
                        c[0],
                        c[1],
                        c[2],
                        c[3],
                        id(i + 1, j),
                        id(i + 2, j + 1),
                        id(i + 1, j + 2),
                        id(i, j + 1),
                    ]);
                } else if (ci + cj) % 2 == 0 {
                    let m = id(i + 1, j + 1);
                    elements.push(vec![c[0], c[1], c[2], id(i + 1, j), id(i + 2, j + 1), m]);
                    elements.push(vec![c[0], c[2], c[3], m, id(i + 1, j + 2), id(i, j + 1)]);
                } else {
                    let m = id(i + 1, j + 1);
                    elements.push(vec![c[0], c[1], c[3], id(i + 1, j), m, id(i, j + 1)]);
                    elements.push(vec![
                        c[1],
                        c[2],
                        c[3],
                        id(i + 2, j + 1),
                        id(i + 1, j + 2),
                        m,
                    ]);
                }
            }
        }
        Mesh { nodes, elements }
    }

    fn ndof(&self) -> usize {
        6 * self.nodes.len()
    }

    fn assemble(&self, s: &ShellSection, kind: MassKind) -> (Mat<f64>, Mat<f64>) {
        let n = self.ndof();
        let mut k = Mat::zeros(n, n);
        let mut m = Mat::zeros(n, n);
        for e in &self.elements {
            let xyz: Vec<[f64; 3]> = e.iter().map(|i| self.nodes[*i]).collect();
            let present = vec![true; e.len() / 2];
            let em = element(&xyz, &present, s, kind);
            for (a, na) in e.iter().enumerate() {
                for (b, nb) in e.iter().enumerate() {
                    for r in 0..6 {
                        for c in 0..6 {
                            k[(6 * na + r, 6 * nb + c)] += em.k[(6 * a + r, 6 * b + c)];
                            m[(6 * na + r, 6 * nb + c)] += em.m[(6 * a + r, 6 * b + c)];
                        }
                    }
                }
            }
        }
        (k, m)
    }

    /// Nodes used by some element.
    fn used(&self) -> Vec<bool> {
        let mut u = vec![false; self.nodes.len()];
        for e in &self.elements {
            for i in e {
                u[*i] = true;
            }
        }
        u
    }
}

fn restrict(a: &Mat<f64>, rows: &[usize], cols: &[usize]) -> Mat<f64> {
    Mat::from_fn(rows.len(), cols.len(), |i, j| a[(rows[i], cols[j])])
}

/// Solves `K u = 0` with the `prescribed` DOFs held (dense LU); unused nodes are left out.
fn solve_static(k: &Mat<f64>, prescribed: &[(usize, f64)], skip: &[usize]) -> Vec<f64> {
    let n = k.nrows();
    let fixed: Vec<usize> = prescribed.iter().map(|p| p.0).collect();
    let free: Vec<usize> = (0..n)
        .filter(|d| !fixed.contains(d) && !skip.contains(d))
        .collect();
    let kff = restrict(k, &free, &free);
    let kfb = restrict(k, &free, &fixed);
    let ub = Mat::from_fn(fixed.len(), 1, |i, _| prescribed[i].1);
    let rhs = -(&kfb * &ub);
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

/// Eigenvalues `λ = ω²` of `K x = λ M x` on the `free` DOFs (Cholesky of `M`, symmetric
/// eigenvalues of `L⁻¹ K L⁻ᵀ`).
fn omega2(k: &Mat<f64>, m: &Mat<f64>, free: &[usize]) -> Vec<f64> {
    let (kf, mf) = (restrict(k, free, free), restrict(m, free, free));
    let llt = mf.llt(Side::Lower).unwrap();
    let l = llt.L();
    let mut x = kf.clone();
    solve_lower_triangular_in_place(l, x.as_mut(), Par::Seq);
    let mut a = x.transpose().to_owned();
    solve_lower_triangular_in_place(l, a.as_mut(), Par::Seq);
    let a = Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    eigenvalues(&a)
}

/// Patch tests (MacNeal & Harder 1985): the boundary nodes of a patch of distorted,
/// straight-edged elements are held at (a) a constant membrane strain with a rigid in-plane
/// rotation (and the matching θz) and (b) a constant curvature (w quadratic, θ its slopes: zero
/// transverse shear); the interior nodes must take the exact field, to 1e-7 of its scale
/// 1e-4 (round-off of a K whose condition number is ~1e9 here: bending ∝ t³, t = 0.001, beside
/// membrane ∝ t). The quad8 patches are of parallelograms (an affine map: the serendipity
/// space then holds every quadratic) and of general quads; on a general quad the serendipity
/// interpolant of `w` is not the quadratic, but the tied shear (edge values and the interior
/// moment `∫ ∂w/∂ξ dξ`) depends only on `w` along the straight edges, where it is exact, so the
/// patch passes there too. The tria6 patch is of general triangles for both.
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
    let omega = 2e-4;
    let membrane = |p: &[f64; 3]| {
        let (x, y) = (p[0], p[1]);
        [
            1e-3 * (x + 0.5 * y) - omega * y,
            1e-3 * (y + 0.5 * x) + omega * x,
            0.0,
            0.0,
            0.0,
            omega,
        ]
    };
    let bending = |p: &[f64; 3]| {
        let (x, y) = (p[0], p[1]);
        // w = ½ (x² + x y + y²) 1e-3: θx = ∂w/∂y, θy = −∂w/∂x.
        [
            0.0,
            0.0,
            1e-3 * 0.5 * (x * x + x * y + y * y),
            1e-3 * (0.5 * x + y),
            -1e-3 * (x + 0.5 * y),
            0.0,
        ]
    };
    // General distortion: moves interior grid points off the straight grid (edges stay straight:
    // the mapping is applied to the corners and the midside nodes are put at the midpoints).
    let general = |u: f64, v: f64| {
        let bump = 16.0 * u * (1.0 - u) * v * (1.0 - v);
        [
            0.24 * u + 0.03 * bump * (v - 0.3),
            0.12 * v + 0.02 * bump * (0.6 - u),
            0.0,
        ]
    };
    let parallelogram = |u: f64, v: f64| [0.24 * u + 0.08 * v, 0.12 * v + 0.02 * u, 0.0];
    let straight = |mesh: &mut Mesh, tria: bool| {
        // Midside positions from the corners (each midside belongs to one edge).
        let mut nodes = mesh.nodes.clone();
        for e in &mesh.elements {
            let c = if tria { 3 } else { 4 };
            for k in 0..c {
                let (a, b) = (mesh.nodes[e[k]], mesh.nodes[e[(k + 1) % c]]);
                nodes[e[c + k]] = [
                    0.5 * (a[0] + b[0]),
                    0.5 * (a[1] + b[1]),
                    0.5 * (a[2] + b[2]),
                ];
            }
        }
        mesh.nodes = nodes;
    };
    type Field<'a> = &'a dyn Fn(&[f64; 3]) -> [f64; 6];
    type Map<'a> = &'a dyn Fn(f64, f64) -> [f64; 3];
    let cases: Vec<(&str, bool, Map, Field)> = vec![
        ("quad8 general, membrane", false, &general, &membrane),
        (
            "quad8 parallelograms, bending",
            false,
            &parallelogram,
            &bending,
        ),
        ("quad8 general, bending", false, &general, &bending),
        ("tria6 general, membrane", true, &general, &membrane),
        ("tria6 general, bending", true, &general, &bending),
    ];
    for (name, tria, map, field) in cases {
        let mut mesh = Mesh::grid(3, 3, tria, map);
        straight(&mut mesh, tria);
        let (k, _) = mesh.assemble(&s, MassKind::Consistent);
        let used = mesh.used();
        let mx = 7;
        let boundary = |i: usize| {
            let (a, b) = (i % mx, i / mx);
            a == 0 || b == 0 || a == mx - 1 || b == mx - 1
        };
        let mut prescribed = Vec::new();
        let mut skip = Vec::new();
        for i in 0..mesh.nodes.len() {
            if !used[i] {
                skip.extend(6 * i..6 * i + 6);
            } else if boundary(i) {
                let f = field(&mesh.nodes[i]);
                prescribed.extend((0..6).map(|c| (6 * i + c, f[c])));
            }
        }
        let u = solve_static(&k, &prescribed, &skip);
        let mut worst = 0.0f64;
        for i in 0..mesh.nodes.len() {
            if used[i] && !boundary(i) {
                let f = field(&mesh.nodes[i]);
                for c in 0..6 {
                    worst = worst.max((u[6 * i + c] - f[c]).abs());
                }
            }
        }
        eprintln!("{name}: largest interior error {worst:e} (scale 1e-4)");
        assert!(worst < 1e-7 * 1e-4, "{name}: interior error {worst:e}");
    }
}

/// Plate DOFs (`uz`, `θx`, `θy`) of the used nodes of a flat plate in the x-y plane, less the
/// hard simply supported edges of `[0, a]²` (`w = 0`, and the rotation about the edge's
/// direction: `θx` on `x = 0, a`, `θy` on `y = 0, a`); in-plane DOFs and θz are held (membrane
/// and drilling are uncoupled from bending in a flat plate).
fn simply_supported(mesh: &Mesh, a: f64) -> Vec<usize> {
    let used = mesh.used();
    let mut free = Vec::new();
    for (i, p) in mesh.nodes.iter().enumerate() {
        if !used[i] {
            continue;
        }
        let on_x = p[0].abs() < 1e-12 || (p[0] - a).abs() < 1e-12;
        let on_y = p[1].abs() < 1e-12 || (p[1] - a).abs() < 1e-12;
        if !(on_x || on_y) {
            free.push(6 * i + 2);
        }
        if !on_x {
            free.push(6 * i + 3);
        }
        if !on_y {
            free.push(6 * i + 4);
        }
    }
    free
}

/// Simply supported square plate, `a = 1`, thin (`t/a = 0.01` and `0.001`): the frequencies
/// against Kirchhoff's `ω_mn = π² (m² + n²)/a² √(D/ρt)` (Leissa 1969, NASA SP-160, §4.1): modes
/// (1,1), (1,2), (2,1), (2,2). The Mindlin value is below Kirchhoff's by
/// `~(π²/6κ(1−ν))·2 (t/a)² ≈ 5e-4` at `t/a = 0.01` and 5e-6 at 0.001; the discretisation error
/// of the MITC quadratics converges from above. Measured (ω/ω_K, t/a = 0.001): quad8 4 × 4
/// 1.0033, 8 × 8 1.0002; tria6 (two per cell) 3 × 3 1.0155, 6 × 6 1.0012, 12 × 12 1.0001 (the
/// fourth mode 1.015 at 6 × 6). Asserted: the first mode within 2 % on the coarse mesh and 0.3 %
/// on the fine one, the first four within 2 % on the fine one, and the two thicknesses within
/// 0.5 % of each other (a locking element is far too stiff at `t/a = 0.001`: the MITC9 field on
/// the 8-node element gave 2.2 at 4 × 4).
#[test]
fn simply_supported_thin_plate_matches_kirchhoff_without_locking() {
    let a = 1.0;
    for tria in [false, true] {
        for (cells, tol) in [(4, 0.02), (8, 0.003)] {
            let cells = if tria { cells * 3 / 4 } else { cells };
            let mut ratios = Vec::new();
            for ta in [0.01, 0.001] {
                let s = ShellSection {
                    thickness: ta * a,
                    e: 2.1e11,
                    nu: 0.3,
                    rho: 7800.0,
                    nsm: 0.0,
                    layers: None,
                };
                let mesh = Mesh::grid(cells, cells, tria, &|u, v| [a * u, a * v, 0.0]);
                let (k, m) = mesh.assemble(&s, MassKind::Consistent);
                let lam = omega2(&k, &m, &simply_supported(&mesh, a));
                let d = s.e * s.thickness.powi(3) / (12.0 * (1.0 - s.nu * s.nu));
                let w0 = PI * PI / (a * a) * (d / (s.rho * s.thickness)).sqrt();
                let modes: Vec<f64> = [2.0, 5.0, 5.0, 8.0]
                    .iter()
                    .enumerate()
                    .map(|(i, f)| lam[i].sqrt() / (w0 * f))
                    .collect();
                eprintln!("tria {tria} {cells}x{cells} t/a {ta}: ω/ω_K = {modes:?}");
                if tol < 0.01 {
                    for (i, r) in modes.iter().enumerate() {
                        assert!((r - 1.0).abs() < 0.02, "tria {tria} t/a {ta} mode {i}: {r}");
                    }
                }
                ratios.push(modes[0]);
            }
            for r in &ratios {
                assert!(
                    (r - 1.0).abs() < tol,
                    "tria {tria} {cells} cells: {ratios:?}"
                );
            }
            assert!(
                (ratios[0] - ratios[1]).abs() < 0.005,
                "locking: ratios {ratios:?}"
            );
        }
    }
}

/// No spurious zero-energy modes in free-free meshes: 3 × 3 cells of general distorted quad8 and
/// tria6 (the patch-test map, midside nodes on the map), flat and mapped onto a cylinder, thin
/// (`t = 0.005` on a 0.24 × 0.12 patch, bending far below membrane): exactly six eigenvalues of
/// `K` (used DOFs) below `1e-10 λ_max`, the seventh above it by orders of magnitude.
#[test]
fn free_free_distorted_meshes_have_exactly_six_zero_energy_modes() {
    let s = ShellSection {
        thickness: 0.005,
        ..STEEL
    };
    let general = |u: f64, v: f64| {
        let bump = 16.0 * u * (1.0 - u) * v * (1.0 - v);
        [
            0.24 * u + 0.03 * bump * (v - 0.3),
            0.12 * v + 0.02 * bump * (0.6 - u),
            0.0,
        ]
    };
    let curved = |u: f64, v: f64| {
        let p = general(u, v);
        cyl(0.3, p[0], p[1] / 0.3)
    };
    type Map<'a> = &'a dyn Fn(f64, f64) -> [f64; 3];
    for (name, map) in [("flat", &general as Map), ("cylinder", &curved)] {
        for tria in [false, true] {
            let mesh = Mesh::grid(3, 3, tria, map);
            let (k, _) = mesh.assemble(&s, MassKind::Consistent);
            let used = mesh.used();
            let dofs: Vec<usize> = (0..mesh.ndof()).filter(|d| used[d / 6]).collect();
            let lam = eigenvalues(&restrict(&k, &dofs, &dofs));
            let lmax = *lam.last().unwrap();
            let zero = lam.iter().filter(|l| l.abs() < 1e-10 * lmax).count();
            eprintln!(
                "{name} tria {tria}: λ/λ_max {:?}",
                lam[..8].iter().map(|l| l / lmax).collect::<Vec<_>>()
            );
            assert_eq!(zero, 6, "{name} tria {tria}: {:?}", &lam[..8]);
        }
    }
}

/// Assembles a quad4 mesh of the corner grid `f(u, v)` (`n × n` cells) with the flat shell.
fn quad4_mesh(
    n: usize,
    s: &ShellSection,
    f: &dyn Fn(f64, f64) -> [f64; 3],
) -> (Vec<[f64; 3]>, Mat<f64>, Mat<f64>) {
    let nodes: Vec<[f64; 3]> = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| (i, j)))
        .map(|(i, j)| f(i as f64 / n as f64, j as f64 / n as f64))
        .collect();
    let dof = 6 * nodes.len();
    let mut k = Mat::zeros(dof, dof);
    let mut m = Mat::zeros(dof, dof);
    for cj in 0..n {
        for ci in 0..n {
            let a = cj * (n + 1) + ci;
            let e = [a, a + 1, a + n + 2, a + n + 1];
            let em = quad4(&e.map(|i| nodes[i]), s, MassKind::Consistent).unwrap();
            for (x, nx) in e.iter().enumerate() {
                for (y, ny) in e.iter().enumerate() {
                    for r in 0..6 {
                        for c in 0..6 {
                            k[(6 * nx + r, 6 * ny + c)] += em.k[(6 * x + r, 6 * y + c)];
                            m[(6 * nx + r, 6 * ny + c)] += em.m[(6 * x + r, 6 * y + c)];
                        }
                    }
                }
            }
        }
    }
    (nodes, k, m)
}

/// All DOFs of the used nodes not on the clamped edges `u = 0` and `u = 1` (`x` at the ends).
fn clamped_ends(nodes: &[[f64; 3]], used: &[bool], len: f64) -> Vec<usize> {
    let mut free = Vec::new();
    for (i, p) in nodes.iter().enumerate() {
        if used[i] && p[0].abs() > 1e-9 && (p[0] - len).abs() > 1e-9 {
            free.extend(6 * i..6 * i + 6);
        }
    }
    free
}

/// Second path: the first three frequencies of a cylindrical panel (R = 1, 60°, length 1,
/// `t = 0.02`, clamped on both curved ends) and of the square plate clamped on two opposite
/// edges (`t/a = 0.05`), with 10 × 10 quad8 and 10 × 10 cells of tria6, against flat quad4
/// meshes of 16 × 16 and 24 × 24. The quad4 converges as O(h²) (its 16 → 24 change is 0.6–1.3 %,
/// so 24 × 24 alone is still ~0.5–1 % stiff); the reference is the Richardson extrapolation
/// `ω₂₄ + (ω₂₄ − ω₁₆)·16²/(24² − 16²)`. Plate: quad8 and tria6 within 0.3 % of it (measured
/// +0.05 … +0.22 %: the quadratics converge as O(h⁴), quad8 5 → 10 cells changes 0.2 %, and
/// the extrapolation's own O(h⁴) remainder is below that). Panel: within 1.5 % (flat facets add
/// an O(h²) geometric error of their own, and the coarse curved quadratics carry untreated
/// membrane locking, from above); tria6 against quad8 within the same tolerances.
#[test]
fn cylindrical_panel_and_plate_against_refined_quad4() {
    let s = ShellSection {
        thickness: 0.02,
        e: 2.1e11,
        nu: 0.3,
        rho: 7800.0,
        nsm: 0.0,
        layers: None,
    };
    let angle = 60f64.to_radians();
    let panel = move |u: f64, v: f64| cyl(1.0, u, angle * (v - 0.5));
    let plate = |u: f64, v: f64| [u, v, 0.0];
    let thick = ShellSection {
        thickness: 0.05,
        ..s
    };
    for (name, map, sec, tol) in [
        ("panel", &panel as &dyn Fn(f64, f64) -> [f64; 3], &s, 0.015),
        ("plate", &plate, &thick, 0.003),
    ] {
        let quad4_omega = |n: usize| {
            let (nodes, k, m) = quad4_mesh(n, sec, map);
            let used = vec![true; nodes.len()];
            let lam = omega2(&k, &m, &clamped_ends(&nodes, &used, 1.0));
            (0..3).map(|i| lam[i].sqrt()).collect::<Vec<f64>>()
        };
        let (fine, coarse) = (quad4_omega(24), quad4_omega(16));
        let reference: Vec<f64> = (0..3)
            .map(|i| fine[i] + (fine[i] - coarse[i]) * 256.0 / (576.0 - 256.0))
            .collect();
        let mut quadratic = Vec::new();
        for tria in [false, true] {
            let mesh = Mesh::grid(10, 10, tria, map);
            let (k, m) = mesh.assemble(sec, MassKind::Consistent);
            let lam = omega2(&k, &m, &clamped_ends(&mesh.nodes, &mesh.used(), 1.0));
            let omega: Vec<f64> = (0..3).map(|i| lam[i].sqrt()).collect();
            let ratios: Vec<f64> = (0..3).map(|i| omega[i] / reference[i]).collect();
            eprintln!(
                "{name} tria {tria}: ratios to extrapolated quad4 {ratios:?} (quad4 16, 24: {coarse:?} {fine:?})"
            );
            quadratic.push(omega);
        }
        for (q, omega) in quadratic.iter().enumerate() {
            for i in 0..3 {
                let r = omega[i] / reference[i];
                assert!((r - 1.0).abs() < tol, "{name} mesh {q} mode {i}: {r}");
            }
        }
        for i in 0..3 {
            let r = quadratic[1][i] / quadratic[0][i];
            assert!((r - 1.0).abs() < tol, "{name}: tria6 / quad8 mode {i}: {r}");
        }
    }
}

/// Sections covering every PSHELL part combination.
fn sections() -> Vec<(&'static str, ShellSection)> {
    let other = LayerMaterial::Other {
        e: 7.0e10,
        nu: 0.33,
    };
    let with = |membrane, bending, shear, br, sr| ShellSection {
        layers: Some(ShellLayers {
            membrane,
            bending,
            shear,
            bending_ratio: br,
            shear_ratio: sr,
        }),
        ..STEEL
    };
    vec![
        ("homogeneous", STEEL),
        (
            "membrane only",
            with(true, None, LayerMaterial::Own, 1.0, 0.8),
        ),
        (
            "bending only",
            with(false, Some(LayerMaterial::Own), other, 1.0, 0.8),
        ),
        ("other bending", with(true, Some(other), other, 0.7, 0.9)),
        (
            "ratios",
            with(true, Some(LayerMaterial::Own), LayerMaterial::Own, 1.3, 0.6),
        ),
    ]
}

/// Every analytic derivative equals a central difference with relative step 1e-6, to 1e-6 of the
/// derivative's scale `max(|∂K/∂φ|, |K|/φ)` (truncation ~h² = 1e-12, round-off ~1e-10). Curved
/// elements, both mass kinds, one omitted midside node, every section variant.
#[test]
fn derivatives_match_central_differences() {
    let q8 = quad8_curved();
    let t6 = tria6_curved();
    for (xyz, present) in [
        (&q8[..], &[true, true, false, true][..]),
        (&t6[..], &[true; 3][..]),
    ] {
        for (name, s) in sections() {
            for kind in [MassKind::Consistent, MassKind::Lumped] {
                let em = element(xyz, present, &s, kind);
                let (em2, ds) = if xyz.len() == 8 {
                    quad8_with_derivatives(
                        xyz.try_into().unwrap(),
                        present.try_into().unwrap(),
                        &s,
                        kind,
                        &ShellParameter::ALL,
                    )
                } else {
                    tria6_with_derivatives(
                        xyz.try_into().unwrap(),
                        present.try_into().unwrap(),
                        &s,
                        kind,
                        &ShellParameter::ALL,
                    )
                }
                .unwrap();
                assert_eq!(em, em2);
                for (p, d) in ShellParameter::ALL.iter().zip(ds) {
                    let v = s.parameter(*p);
                    let h = 1e-6 * v;
                    let plus = element(xyz, present, &s.with_parameter(*p, v + h), kind);
                    let minus = element(xyz, present, &s.with_parameter(*p, v - h), kind);
                    let fd_k = (&plus.k - &minus.k) * (1.0 / (2.0 * h));
                    let fd_m = (&plus.m - &minus.m) * (1.0 / (2.0 * h));
                    let sk = max_abs(&d.dk).max(max_abs(&em.k) / v);
                    let sm = max_abs(&d.dm).max(max_abs(&em.m) / v);
                    let ek = max_abs(&(&fd_k - &d.dk)) / sk;
                    let emm = max_abs(&(&fd_m - &d.dm)) / sm;
                    assert!(
                        ek < 1e-6,
                        "{} nodes {name} {kind:?} {p:?}: dK {ek:e}",
                        xyz.len()
                    );
                    assert!(
                        emm < 1e-6,
                        "{} nodes {name} {kind:?} {p:?}: dM {emm:e}",
                        xyz.len()
                    );
                }
            }
        }
    }
}

/// Membrane-only: no rotational stiffness or mass at all; bending-only: no in-plane stiffness of
/// a flat element (a pure in-plane stretch is free), no mass on the rotation about the normal;
/// homogeneous: the parts add up (membrane + bending-only differ from it only by the drilling).
#[test]
fn membrane_only_and_bending_only_have_only_their_parts() {
    let xyz = quad8_flat();
    let all = sections();
    let mem = element(&xyz, &[true; 4], &all[1].1, MassKind::Consistent);
    for i in 0..48 {
        for j in 0..48 {
            if i % 6 >= 3 || j % 6 >= 3 {
                assert_eq!(mem.k[(i, j)], 0.0);
                assert_eq!(mem.m[(i, j)], 0.0);
            }
        }
    }
    let bend = element(&xyz, &[true; 4], &all[2].1, MassKind::Lumped);
    let stretch: Vec<f64> = (0..48)
        .map(|i| if i % 6 == 0 { xyz[i / 6][0] } else { 0.0 })
        .collect();
    let e: f64 = (0..48)
        .flat_map(|i| (0..48).map(move |j| (i, j)))
        .map(|(i, j)| stretch[i] * bend.k[(i, j)] * stretch[j])
        .sum();
    assert!(e.abs() < 1e-12 * max_abs(&bend.k));
    for i in 0..8 {
        assert_eq!(bend.m[(6 * i + 5, 6 * i + 5)], 0.0);
        assert!(bend.m[(6 * i + 3, 6 * i + 3)] > 0.0);
    }
}

/// Condensing each node's rotation about the normal out of one flat element leaves the same
/// matrix whatever the drilling factor (the penalty only ties each `θz` to the membrane's own
/// rotation): compared through `K − K_{·z} K_zz⁻¹ K_{z·}` for the homogeneous section, to 1e-9.
#[test]
fn drilling_penalty_condenses_out_of_one_element() {
    let xyz = quad8_flat();
    let em = element(&xyz, &[true; 4], &STEEL, MassKind::Consistent);
    let z: Vec<usize> = (0..8).map(|i| 6 * i + 5).collect();
    let o: Vec<usize> = (0..48).filter(|i| i % 6 != 5).collect();
    let kzz = restrict(&em.k, &z, &z);
    let koz = restrict(&em.k, &o, &z);
    let koo = restrict(&em.k, &o, &o);
    let cond = &koo - &koz * kzz.partial_piv_lu().solve(koz.transpose().to_owned());
    // Without the drilling penalty the θz rows are zero: the condensed matrix is the stiffness
    // with k_m minus the drilling part; compare with the membrane + bending + shear energy of
    // a state with θz = ω: the condensed energy of in-plane fields equals the plane-stress energy.
    let field: Vec<f64> = (0..48)
        .filter(|i| i % 6 != 5)
        .map(|i| {
            let p = xyz[i / 6];
            match i % 6 {
                0 => 1e-3 * p[0] + 2e-3 * p[1],
                1 => -1e-3 * p[0] + 0.5e-3 * p[1],
                _ => 0.0,
            }
        })
        .collect();
    let energy: f64 = (0..40)
        .flat_map(|i| (0..40).map(move |j| (i, j)))
        .map(|(i, j)| field[i] * cond[(i, j)] * field[j])
        .sum();
    // ε = (1e-3, 0.5e-3, 1e-3), U·2 = t A εᵀ C ε with A = 0.845.
    let c = STEEL.e / (1.0 - STEEL.nu * STEEL.nu);
    let (ex, ey, g) = (1e-3, 0.5e-3, 1e-3);
    let exact = STEEL.thickness
        * 0.845
        * c
        * (ex * ex + ey * ey + 2.0 * STEEL.nu * ex * ey + 0.5 * (1.0 - STEEL.nu) * g * g);
    assert!(
        ((energy - exact) / exact).abs() < 1e-9,
        "{energy} vs {exact}"
    );
}

fn message(r: Result<ElementMatrices, ElementError>) -> String {
    r.err().map(|e| e.to_string()).unwrap_or_default()
}

/// Bad geometry and values are errors that say what is wrong; nothing panics.
#[test]
fn bad_geometry_and_values_are_errors() {
    let mut xyz = quad8_flat();
    xyz[4] = [0.6, 0.6, 0.0];
    assert!(
        message(quad8(&xyz, [true; 4], &STEEL, MassKind::Consistent)).contains("midside node 5")
    );
    let mut xyz = quad8_flat();
    xyz[2] = xyz[1];
    assert!(message(quad8(&xyz, [true; 4], &STEEL, MassKind::Consistent)).contains("coincide"));
    // Reversed numbering of one corner: folded.
    let mut xyz = quad8_flat();
    xyz.swap(1, 3);
    let xyz: [[f64; 3]; 8] = with_midpoints(&[xyz[0], xyz[1], xyz[2], xyz[3]]);
    let bowtie = [
        xyz[0], xyz[2], xyz[1], xyz[3], xyz[4], xyz[5], xyz[6], xyz[7],
    ];
    let m = message(quad8(&bowtie, [true; 4], &STEEL, MassKind::Consistent));
    assert!(m.contains("degenerate"), "{m}");
    let bad = ShellSection { nu: 0.5, ..STEEL };
    assert!(message(tria6(&tria6_flat(), [true; 3], &bad, MassKind::Lumped)).contains("nu"));
    let mut nan = tria6_flat();
    nan[1][0] = f64::NAN;
    assert!(message(tria6(&nan, [true; 3], &STEEL, MassKind::Lumped)).contains("non-finite"));
    // An omitted midside node's coordinate is ignored, even when not finite.
    let mut nan = tria6_flat();
    nan[4] = [f64::NAN; 3];
    assert!(tria6(&nan, [true, false, true], &STEEL, MassKind::Lumped).is_ok());
}

/// An element with every midside node omitted is the straight-sided element with linear
/// interpolation: it passes the constant-strain membrane state exactly (forces only at the
/// corners balance, energy = `t A εᵀ C ε`).
#[test]
fn all_midsides_omitted_is_the_linear_element() {
    let xyz = quad8_flat();
    let em = element(&xyz, &[false; 4], &STEEL, MassKind::Consistent);
    assert_eq!(em.k.nrows(), 24);
    let field: Vec<f64> = (0..24)
        .map(|i| {
            let p = xyz[i / 6];
            match i % 6 {
                0 => 1e-3 * p[0] + 2e-3 * p[1],
                1 => -1e-3 * p[0] + 0.5e-3 * p[1],
                5 => 0.5 * (-1e-3 - 2e-3),
                _ => 0.0,
            }
        })
        .collect();
    let energy: f64 = (0..24)
        .flat_map(|i| (0..24).map(move |j| (i, j)))
        .map(|(i, j)| field[i] * em.k[(i, j)] * field[j])
        .sum();
    let c = STEEL.e / (1.0 - STEEL.nu * STEEL.nu);
    let (ex, ey, g) = (1e-3, 0.5e-3, 1e-3);
    let exact = STEEL.thickness
        * 0.845
        * c
        * (ex * ex + ey * ey + 2.0 * STEEL.nu * ex * ey + 0.5 * (1.0 - STEEL.nu) * g * g);
    assert!(
        ((energy - exact) / exact).abs() < 1e-10,
        "{energy} vs {exact}"
    );
}
