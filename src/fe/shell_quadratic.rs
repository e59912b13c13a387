//! Curved quadratic shells with six DOFs per node: the 8-node serendipity `quad8` (CQUAD8) and
//! the 6-node `tria6` (CTRIA6). DOFs are node-major, `ux uy uz rx ry rz` in the basic system
//! (as [`super::shell`]); corners first, then the midside nodes that are present.
//!
//! **Geometry.** A degenerated (Ahmad) shell (Ahmad, Irons & Zienkiewicz 1970, *IJNME* 2): the
//! mid-surface is `x(ξ, η) = Σ Nᵢ xᵢ` and the material point at distance `z` along the director
//! is `X = x + z d(ξ, η)`, `d = Σ Nᵢ dᵢ`, where the nodal director `dᵢ` is the unit normal of the
//! interpolated surface at node `i` (`x,ξ × x,η` there). Displacements `u = Σ Nᵢ (uᵢ + z θᵢ × dᵢ)`.
//!
//! **Strains (first order in z).** With the covariant base `J(z) = J₀ + z J₁` (rows `x,ξ`, `x,η`,
//! `d`, and `d,ξ`, `d,η`, 0), the displacement gradient `∂u/∂X = J⁻¹ ∂u/∂(ξ, η, z)` is expanded
//! to first order in `z`, `J⁻¹ ≈ J₀⁻¹ − z J₀⁻¹ J₁ J₀⁻¹`: `L = L₀ + z L₁`. This keeps rigid-body
//! motions strain-free on a curved surface exactly (`Σ X,ₖ ⊗ gᵏ = 1` holds order by order) and
//! splits the energy into parts of fixed thickness dependence. In the lamina frame of each
//! integration point (`e3` the surface normal, `e1` along `x,ξ`): membrane `ε = sym L₀` (in
//! plane), curvature `κ = sym L₁` (in plane), transverse shear `γ = 2 sym L₀` (`13`, `23`); the
//! `O(z²)` terms and the variation of the area through the thickness (`O(t/R)` coupling of
//! membrane and bending) are neglected, the usual thin-shell approximation. Energy per area:
//! `½ (εᵀ t C₁ ε + κᵀ (12I/T³) t³/12 C₂ κ + γᵀ (TS/T) G₃ t γ)` (PSHELL MID1, MID2, MID3; for a
//! homogeneous shell `C₁ = C₂ = C`, `TS/T = κ = 5/6`).
//!
//! **No shear locking: MITC** (Bathe & Dvorkin 1986, *IJNME* 22). The covariant transverse shear
//! strains `e_ξz`, `e_ηz` are not taken from the displacements at the integration points but from
//! an assumed field tied to the displacement-based strains; the local shear strains are then
//! formed from the assumed covariant components by the tensor transformation. Both elements tie
//! the tangential covariant shear at the two Gauss points `±1/√3` of each edge (the edge moments
//! against linears: exact, as the tangential strain is quadratic along an edge) and the two
//! interior moments `∫∫ e_ξz dξ dη`, `∫∫ e_ηz dξ dη` over the natural domain.
//! `quad8` (MITC8: Bathe & Dvorkin 1986; the plate space of Bathe, Bucalem & Brezzi 1990, *Eng.
//! Comput.* 7): `e_ξz ∈ span{1, ξ, η, ξη, η²}`, tied at `ξ = ±1/√3` on `η = ±1` and by its
//! interior moment, so `e_ξz = A(η) + ξ B(η)` with `B` linear between the edges' slopes and `A`
//! quadratic through the edges' means, its bubble `1 − η²` fixed by the moment; `e_ηz` likewise
//! with `ξ`, `η` swapped (10 tying conditions). The MITC9 field (12 conditions, the interior ones
//! at `η = 0` from the displacements) locks on the 8-node element: 2.2 × Kirchhoff's frequency
//! at `t/a = 0.001`, and a curvature patch of general quads fails by 1.6e-2 of the field. With
//! the moments in the natural domain, `∫ e_ξz dξ` of the displacements depends only on the edge
//! values (`∫ ∂w/∂ξ dξ`), so the constant-curvature patch passes on general straight-edged quads.
//! `tria6`: the rotated second-order Raviart–Thomas field of Lee & Bathe's MITC6 (2004,
//! *Comput. Struct.* 82), `e_rz = a₁ + b₁ r + c₁ s + s (d r + e s)`, `e_sz = a₂ + b₂ r + c₂ s −
//! r (d r + e s)` (8 coefficients), tied on the edges as there; the two interior conditions are
//! the moments (as the interior degrees of freedom of the Raviart–Thomas space, Brezzi, Bathe &
//! Fortin 1989, *IJNME* 28), not Lee & Bathe's values at the centroid: with those, the clamped
//! thick-plate frequency converged from below and slowly (5, 10, 20 cells: −3.0 %, −1.0 %,
//! −0.3 % from the converged value), with the moments from above (+0.25 % at 5, +0.01 % at 10).
//! Membrane and bending strains come from the displacements, full integration (3 × 3 Gauss;
//! 6-point degree-4 rule on triangles); membrane locking of strongly curved, coarse meshes is not
//! treated (curved meshes converge from above).
//!
//! **Drilling.** As the flat shells ([`super::shell::DRILLING_FACTOR`]): each node's rotation
//! about its director, `θᵢ · dᵢ`, is tied by a penalty to the in-plane rotation of the membrane at
//! that node, `ωᵢ = ½ (e2 · L₀ e1 − e1 · L₀ e2)` in the node's lamina frame:
//! `U = ½ (k_d / n) Σᵢ (θᵢ · dᵢ − ωᵢ)²`, `k_d = α_d G₁ t A`. Rigid rotations give zero energy,
//! and each `θᵢ · dᵢ` appears in one term only, so condensing them out of one element gives the
//! drilling-free element (tested).
//!
//! **Mass.** Consistent: `∫ Nᵢ Nⱼ dA` times `μ = ρ t + nsm` on the translations and `I = ρ t³/12`
//! on the rotations. Lumped: HRZ diagonal scaling (Hinton, Rock & Zienkiewicz 1976, *Earthquake
//! Eng. Struct. Dyn.* 4): node `i` gets the share `A ∫Nᵢ² dA / Σⱼ ∫Nⱼ² dA` of the area — the
//! row-sum lumping of the serendipity element gives negative corner masses; HRZ gives all
//! positive (corner : midside = 3 : 16 on a square quad8 and on a straight-sided triangle) and exact total
//! mass. Rotary inertia as the flat shells: on all three rotations when the shell has membrane
//! and bending, only on the tangential ones (`1 − e3 e3ᵀ`) without membrane (no drilling
//! stiffness), none without bending.
//!
//! **Omitted midside nodes** (blank G5–G8 of CQUAD8, G4–G6 of CTRIA6: a straight edge, QRG). The
//! element is formed with that midside node at the edge midpoint and its six DOFs slaved to the
//! corners, `u_m = (u_a + u_b)/2`: `K = Tᵀ K_full T`; the consistent mass likewise; the lumped
//! mass is the row sum of `Tᵀ M_full T` (half the omitted node's share to each corner, diagonal,
//! positive). The omitted node carries no drilling penalty.
//!
//! **Derivatives** (docs/theory.md §2, thesis (2.13)–(2.16)): the stiffness is kept in parts,
//! membrane + drilling `K_m ∝ t`, shear `K_s ∝ t`, bending `K_b ∝ t³`, so
//! `∂K/∂t = K_m/t + K_s/t + 3 K_b/t`, `∂K/∂E = K/E` over the parts of the section's own
//! material; the mass is `μ M_tr + I M_rot` with `∂μ/∂t = ρ`, `∂I/∂t = ρ t²/4`, `∂μ/∂ρ = t`, `∂I/∂ρ = t³/12`, `∂μ/∂nsm = 1`. Exact.

// Index loops follow the index notation of the formulas.
#![allow(clippy::needless_range_loop)]

use super::element::{ElementDerivative, ElementError, ElementMatrices, MassKind};
use super::shell::{
    DRILLING_FACTOR, LayerMaterial, SHEAR_CORRECTION, ShellParameter, ShellSection, V3, cross, dot,
    norm, sub,
};
use faer::Mat;

/// Smallest accepted cosine between a nodal director and the element's mean normal.
pub const MIN_DIRECTOR_COSINE: f64 = 0.5;

/// `N`, `∂N/∂ξ`, `∂N/∂η` of the eight-node serendipity quadrilateral (CQUAD8, `ξ, η ∈ [−1, 1]`,
/// corners then midside nodes G5–G8 on edges 1–2, 2–3, 3–4, 4–1) at `(ξ, η)`.
pub fn quad8_shape(xi: f64, eta: f64) -> [Vec<f64>; 3] {
    Shape::Quad8.eval(xi, eta)
}

/// `N`, `∂N/∂r`, `∂N/∂s` of the six-node quadratic triangle (CTRIA6, area coordinates
/// `L = (1 − r − s, r, s)`, midside nodes G4–G6 on edges 1–2, 2–3, 3–1) at `(r, s)`.
pub fn tria6_shape(r: f64, s: f64) -> [Vec<f64>; 3] {
    Shape::Tria6.eval(r, s)
}

/// Which element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Quad8,
    Tria6,
}

impl Shape {
    fn corners(self) -> usize {
        match self {
            Shape::Quad8 => 4,
            Shape::Tria6 => 3,
        }
    }

    fn nodes(self) -> usize {
        2 * self.corners()
    }

    /// Natural coordinates of node `i`.
    fn node(self, i: usize) -> [f64; 2] {
        match self {
            Shape::Quad8 => [
                [-1.0, -1.0],
                [1.0, -1.0],
                [1.0, 1.0],
                [-1.0, 1.0],
                [0.0, -1.0],
                [1.0, 0.0],
                [0.0, 1.0],
                [-1.0, 0.0],
            ][i],
            Shape::Tria6 => [
                [0.0, 0.0],
                [1.0, 0.0],
                [0.0, 1.0],
                [0.5, 0.0],
                [0.5, 0.5],
                [0.0, 0.5],
            ][i],
        }
    }

    /// `N`, `∂N/∂ξ`, `∂N/∂η` at `(r, s)`.
    fn eval(self, r: f64, s: f64) -> [Vec<f64>; 3] {
        match self {
            Shape::Quad8 => {
                let mut n = vec![0.0; 8];
                let mut dr = vec![0.0; 8];
                let mut ds = vec![0.0; 8];
                for i in 0..4 {
                    let [a, b] = self.node(i);
                    let (p, q) = (1.0 + a * r, 1.0 + b * s);
                    n[i] = 0.25 * p * q * (a * r + b * s - 1.0);
                    dr[i] = 0.25 * a * q * (2.0 * a * r + b * s);
                    ds[i] = 0.25 * b * p * (a * r + 2.0 * b * s);
                }
                for i in 4..8 {
                    let [a, b] = self.node(i);
                    if a == 0.0 {
                        n[i] = 0.5 * (1.0 - r * r) * (1.0 + b * s);
                        dr[i] = -r * (1.0 + b * s);
                        ds[i] = 0.5 * b * (1.0 - r * r);
                    } else {
                        n[i] = 0.5 * (1.0 + a * r) * (1.0 - s * s);
                        dr[i] = 0.5 * a * (1.0 - s * s);
                        ds[i] = -s * (1.0 + a * r);
                    }
                }
                [n, dr, ds]
            }
            Shape::Tria6 => {
                let l = [1.0 - r - s, r, s];
                let dl = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
                let mut n = vec![0.0; 6];
                let mut dr = vec![0.0; 6];
                let mut ds = vec![0.0; 6];
                for i in 0..3 {
                    n[i] = l[i] * (2.0 * l[i] - 1.0);
                    dr[i] = (4.0 * l[i] - 1.0) * dl[i][0];
                    ds[i] = (4.0 * l[i] - 1.0) * dl[i][1];
                }
                for (k, (a, b)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
                    n[3 + k] = 4.0 * l[a] * l[b];
                    dr[3 + k] = 4.0 * (dl[a][0] * l[b] + l[a] * dl[b][0]);
                    ds[3 + k] = 4.0 * (dl[a][1] * l[b] + l[a] * dl[b][1]);
                }
                [n, dr, ds]
            }
        }
    }

    /// Integration points `(ξ, η, weight)`.
    fn gauss(self) -> Vec<(f64, f64, f64)> {
        match self {
            Shape::Quad8 => {
                let a = (0.6f64).sqrt();
                let p = [(-a, 5.0 / 9.0), (0.0, 8.0 / 9.0), (a, 5.0 / 9.0)];
                let mut out = Vec::with_capacity(9);
                for (x, wx) in p {
                    for (y, wy) in p {
                        out.push((x, y, wx * wy));
                    }
                }
                out
            }
            Shape::Tria6 => {
                // Strang & Fix 6-point rule, degree 4 (weights sum to ½, the reference area).
                let (a1, b1, w1) = (
                    0.445_948_490_915_965,
                    0.108_103_018_168_070,
                    0.111_690_794_839_005_5,
                );
                let (a2, b2, w2) = (
                    0.091_576_213_509_771,
                    0.816_847_572_980_459,
                    0.054_975_871_827_660_9,
                );
                vec![
                    (a1, a1, w1),
                    (b1, a1, w1),
                    (a1, b1, w1),
                    (a2, a2, w2),
                    (b2, a2, w2),
                    (a2, b2, w2),
                ]
            }
        }
    }

    /// Edge `k`: its corners and its midside node.
    fn edge(self, k: usize) -> (usize, usize, usize) {
        let c = self.corners();
        (k, (k + 1) % c, c + k)
    }
}

fn unit(a: &V3) -> V3 {
    let n = norm(a);
    [a[0] / n, a[1] / n, a[2] / n]
}

fn inverse3(m: &[V3; 3]) -> Option<[V3; 3]> {
    let det = dot(&m[0], &cross(&m[1], &m[2]));
    if !(det.is_finite() && det.abs() > 0.0) {
        return None;
    }
    // Columns of the inverse are the reciprocal base vectors.
    let c0 = cross(&m[1], &m[2]);
    let c1 = cross(&m[2], &m[0]);
    let c2 = cross(&m[0], &m[1]);
    let mut inv = [[0.0; 3]; 3];
    for r in 0..3 {
        inv[r] = [c0[r] / det, c1[r] / det, c2[r] / det];
    }
    Some(inv)
}

/// A vector-valued linear function of the element DOFs: three rows of length `6n`.
type Op = [Vec<f64>; 3];

fn op_zero(d: usize) -> Op {
    [vec![0.0; d], vec![0.0; d], vec![0.0; d]]
}

/// `Σᵢ wᵢ uᵢ` (translations).
fn op_translation(w: &[f64], d: usize) -> Op {
    let mut o = op_zero(d);
    for (i, wi) in w.iter().enumerate() {
        for c in 0..3 {
            o[c][6 * i + c] = *wi;
        }
    }
    o
}

/// `Σᵢ wᵢ θᵢ × dᵢ`.
fn op_rotation(w: &[f64], dirs: &[V3], d: usize) -> Op {
    let mut o = op_zero(d);
    for (i, wi) in w.iter().enumerate() {
        let v = dirs[i];
        // θ × v = [[0, v_z, −v_y], [−v_z, 0, v_x], [v_y, −v_x, 0]] θ.
        let m = [[0.0, v[2], -v[1]], [-v[2], 0.0, v[0]], [v[1], -v[0], 0.0]];
        for r in 0..3 {
            for c in 0..3 {
                o[r][6 * i + 3 + c] = wi * m[r][c];
            }
        }
    }
    o
}

/// `e · op` (a row).
fn project(e: &V3, op: &Op) -> Vec<f64> {
    (0..op[0].len())
        .map(|k| e[0] * op[0][k] + e[1] * op[1][k] + e[2] * op[2][k])
        .collect()
}

fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// `K += w Bᵀ C B` for rows `b` and a symmetric `C`.
fn add_btcb(k: &mut Mat<f64>, b: &[Vec<f64>], c: &[Vec<f64>], w: f64) {
    let d = k.nrows();
    let nb = b.len();
    let mut cb = vec![vec![0.0; d]; nb];
    for r in 0..nb {
        for q in 0..nb {
            if c[r][q] != 0.0 {
                axpy(&mut cb[r], w * c[r][q], &b[q]);
            }
        }
    }
    for i in 0..d {
        for r in 0..nb {
            let bi = b[r][i];
            if bi == 0.0 {
                continue;
            }
            for j in 0..d {
                k[(i, j)] += bi * cb[r][j];
            }
        }
    }
}

fn plane_stress(e: f64, nu: f64) -> Vec<Vec<f64>> {
    let c = e / (1.0 - nu * nu);
    vec![
        vec![c, c * nu, 0.0],
        vec![c * nu, c, 0.0],
        vec![0.0, 0.0, c * 0.5 * (1.0 - nu)],
    ]
}

/// The parts of a section: per part `(E, ν, own material)`.
struct Resolved {
    membrane: Option<(f64, f64, bool)>,
    bending: Option<(f64, f64, bool)>,
    shear: (f64, f64, bool),
    bending_ratio: f64,
    shear_ratio: f64,
}

fn resolve(s: &ShellSection) -> Resolved {
    let own = (s.e, s.nu, true);
    let of = |m: LayerMaterial| match m {
        LayerMaterial::Own => own,
        LayerMaterial::Other { e, nu } => (e, nu, false),
    };
    match s.layers {
        None => Resolved {
            membrane: Some(own),
            bending: Some(own),
            shear: own,
            bending_ratio: 1.0,
            shear_ratio: SHEAR_CORRECTION,
        },
        Some(l) => Resolved {
            membrane: l.membrane.then_some(own),
            bending: l.bending.map(of),
            shear: of(l.shear),
            bending_ratio: l.bending_ratio,
            shear_ratio: l.shear_ratio,
        },
    }
}

/// Geometry of one element at a point: frames and the strain operators.
struct Point {
    /// Lamina frame `e1 e2 e3`.
    e: [V3; 3],
    /// Area element `|x,ξ × x,η|`.
    da: f64,
    /// `∂u/∂X_j` at `z = 0` (`l0[j]`) and its first-order coefficient (`l1[j]`).
    l0: [Op; 3],
    l1: [Op; 3],
    /// Contravariant base `gᵏ` (columns of `J₀⁻¹`).
    gc: [V3; 3],
    /// Covariant strain rows `e_kl` at `z = 0` (symmetric; `ek[k][l]`).
    ek: [[Vec<f64>; 3]; 3],
    n: Vec<f64>,
}

struct Element {
    shape: Shape,
    x: Vec<V3>,
    dirs: Vec<V3>,
    present: Vec<bool>,
    d: usize,
}

impl Element {
    fn new(shape: Shape, xyz: &[V3], present: &[bool]) -> Result<Element, ElementError> {
        let n = shape.nodes();
        let c = shape.corners();
        for (i, p) in xyz.iter().enumerate() {
            if !p.iter().all(|v| v.is_finite()) && (i < c || present[i - c]) {
                return Err(ElementError::Degenerate(format!(
                    "node {} has a non-finite coordinate {p:?}",
                    i + 1
                )));
            }
        }
        let mut x = xyz.to_vec();
        let mut pres = vec![true; n];
        for k in 0..c {
            let (a, b, m) = shape.edge(k);
            pres[m] = present[k];
            if !present[k] {
                x[m] = [
                    0.5 * (x[a][0] + x[b][0]),
                    0.5 * (x[a][1] + x[b][1]),
                    0.5 * (x[a][2] + x[b][2]),
                ];
            }
        }
        let size = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| norm(&sub(&x[i], &x[j])))
            .fold(0.0, f64::max);
        for i in 0..n {
            for j in 0..i {
                if norm(&sub(&x[i], &x[j])) <= 1e-9 * size {
                    return Err(ElementError::Degenerate(format!(
                        "nodes {} and {} coincide",
                        j + 1,
                        i + 1
                    )));
                }
            }
        }
        for k in 0..c {
            let (a, b, m) = shape.edge(k);
            let half = norm(&sub(&x[b], &x[a])) * 0.5;
            let mid = [
                0.5 * (x[a][0] + x[b][0]),
                0.5 * (x[a][1] + x[b][1]),
                0.5 * (x[a][2] + x[b][2]),
            ];
            if norm(&sub(&x[m], &mid)) > 0.5 * half {
                return Err(ElementError::Degenerate(format!(
                    "midside node {} is {:.3e} from the midpoint of its edge {}-{} (half length {:.3e}); a midside node must lie near the middle of its edge",
                    m + 1,
                    norm(&sub(&x[m], &mid)),
                    a + 1,
                    b + 1,
                    half
                )));
            }
        }
        // Directors: the surface normal at each node.
        let mut dirs = Vec::with_capacity(n);
        let mut mean = [0.0; 3];
        for i in 0..n {
            let [r, s] = shape.node(i);
            let [_, dr, ds] = shape.eval(r, s);
            let mut g1 = [0.0; 3];
            let mut g2 = [0.0; 3];
            for j in 0..n {
                for q in 0..3 {
                    g1[q] += dr[j] * x[j][q];
                    g2[q] += ds[j] * x[j][q];
                }
            }
            let nn = cross(&g1, &g2);
            if !(norm(&nn) > 1e-12 * size * size) {
                return Err(ElementError::Degenerate(format!(
                    "the surface has no normal at node {} (zero Jacobian: collinear or folded nodes)",
                    i + 1
                )));
            }
            let u = unit(&nn);
            for q in 0..3 {
                mean[q] += u[q];
            }
            dirs.push(u);
        }
        let mean = unit(&mean);
        for (i, d) in dirs.iter().enumerate() {
            if !(dot(d, &mean) >= MIN_DIRECTOR_COSINE) {
                return Err(ElementError::Degenerate(format!(
                    "the surface normal at node {} is {:.0}° from the element's mean normal (at most 60° accepted): the element is folded, wrongly numbered or too curved",
                    i + 1,
                    dot(d, &mean).clamp(-1.0, 1.0).acos().to_degrees()
                )));
            }
        }
        Ok(Element {
            shape,
            x,
            dirs,
            present: pres,
            d: 6 * n,
        })
    }

    fn point(&self, r: f64, s: f64) -> Result<Point, ElementError> {
        let n = self.shape.nodes();
        let d = self.d;
        let [nv, dr, ds] = self.shape.eval(r, s);
        let mut g = [[0.0; 3]; 3];
        let mut h = [[0.0; 3]; 3];
        for i in 0..n {
            for q in 0..3 {
                g[0][q] += dr[i] * self.x[i][q];
                g[1][q] += ds[i] * self.x[i][q];
                g[2][q] += nv[i] * self.dirs[i][q];
                h[0][q] += dr[i] * self.dirs[i][q];
                h[1][q] += ds[i] * self.dirs[i][q];
            }
        }
        let normal = cross(&g[0], &g[1]);
        let da = norm(&normal);
        let e3 = unit(&normal);
        if !(da > 0.0) || dot(&e3, &g[2]) <= 0.0 {
            return Err(ElementError::Degenerate(format!(
                "the Jacobian is not positive at (ξ, η) = ({r:.3}, {s:.3}): distorted or folded element"
            )));
        }
        let e1 = unit(&g[0]);
        let e2 = cross(&e3, &e1);
        let inv = inverse3(&g).ok_or_else(|| {
            ElementError::Degenerate("singular Jacobian: distorted element".into())
        })?;
        // J₁ J₀⁻¹ and J₀⁻¹ J₁ J₀⁻¹ (J₁ rows h).
        let mut inv1 = [[0.0; 3]; 3];
        for j in 0..3 {
            for k in 0..3 {
                let mut acc = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        acc += inv[j][a] * h[a][b] * inv[b][k];
                    }
                }
                inv1[j][k] = -acc;
            }
        }
        let du0 = [
            op_translation(&dr, d),
            op_translation(&ds, d),
            op_rotation(&nv, &self.dirs, d),
        ];
        let du1 = [
            op_rotation(&dr, &self.dirs, d),
            op_rotation(&ds, &self.dirs, d),
            op_zero(d),
        ];
        let mut l0 = [op_zero(d), op_zero(d), op_zero(d)];
        let mut l1 = [op_zero(d), op_zero(d), op_zero(d)];
        for j in 0..3 {
            for k in 0..3 {
                for c in 0..3 {
                    axpy(&mut l0[j][c], inv[j][k], &du0[k][c]);
                    axpy(&mut l1[j][c], inv[j][k], &du1[k][c]);
                    axpy(&mut l1[j][c], inv1[j][k], &du0[k][c]);
                }
            }
        }
        let gc = [
            [inv[0][0], inv[1][0], inv[2][0]],
            [inv[0][1], inv[1][1], inv[2][1]],
            [inv[0][2], inv[1][2], inv[2][2]],
        ];
        let mut ek: [[Vec<f64>; 3]; 3] = Default::default();
        for k in 0..3 {
            for l in 0..3 {
                let mut row = project(&g[k], &du0[l]);
                axpy(&mut row, 1.0, &project(&g[l], &du0[k]));
                row.iter_mut().for_each(|v| *v *= 0.5);
                ek[k][l] = row;
            }
        }
        Ok(Point {
            e: [e1, e2, e3],
            da,
            l0,
            l1,
            gc,
            ek,
            n: nv,
        })
    }
}

/// `e_a · (∂u/∂e_b)` from a gradient `l` (`l[j]` = `∂u/∂X_j`).
fn grad(l: &[Op; 3], ea: &V3, eb: &V3) -> Vec<f64> {
    let mut du = op_zero(l[0][0].len());
    for j in 0..3 {
        for c in 0..3 {
            axpy(&mut du[c], eb[j], &l[j][c]);
        }
    }
    project(ea, &du)
}

/// In-plane strain rows `[ε11, ε22, γ12]` of a gradient.
fn in_plane(l: &[Op; 3], e: &[V3; 3]) -> Vec<Vec<f64>> {
    let g11 = grad(l, &e[0], &e[0]);
    let g22 = grad(l, &e[1], &e[1]);
    let mut g12 = grad(l, &e[0], &e[1]);
    axpy(&mut g12, 1.0, &grad(l, &e[1], &e[0]));
    vec![g11, g22, g12]
}

/// The element's parts, in reduced DOFs (omitted midside nodes eliminated).
struct Parts {
    /// Membrane + drilling per unit thickness.
    k_m: Mat<f64>,
    /// Shear per unit thickness.
    k_s: Mat<f64>,
    /// Bending per unit t³.
    k_b: Mat<f64>,
    /// Translational mass per unit μ.
    m_tr: Mat<f64>,
    /// Rotational mass per unit I.
    m_rot: Mat<f64>,
    own: [bool; 3],
}

fn parts(
    shape: Shape,
    xyz: &[V3],
    present: &[bool],
    s: &ShellSection,
    kind: MassKind,
) -> Result<Parts, ElementError> {
    s.validate()?;
    let el = Element::new(shape, xyz, present)?;
    let res = resolve(s);
    let n = shape.nodes();
    let d = el.d;
    let mut k_m = Mat::zeros(d, d);
    let mut k_s = Mat::zeros(d, d);
    let mut k_b = Mat::zeros(d, d);
    let mut m_tr = Mat::zeros(d, d);
    let mut m_rot = Mat::zeros(d, d);
    let tying = Tying::new(shape);
    let tied = tying.tied(&el)?;
    let cm = res.membrane.map(|(e, nu, _)| plane_stress(e, nu));
    let cb = res.bending.map(|(e, nu, _)| {
        let mut c = plane_stress(e, nu);
        c.iter_mut()
            .flatten()
            .for_each(|v| *v *= res.bending_ratio / 12.0);
        c
    });
    let gs = res.shear.0 / (2.0 * (1.0 + res.shear.1)) * res.shear_ratio;
    let cs = vec![vec![gs, 0.0], vec![0.0, gs]];
    let mut area = 0.0;
    let mut nn = vec![0.0; n];
    for (r, s_, w) in shape.gauss() {
        let p = el.point(r, s_)?;
        let wa = w * p.da;
        area += wa;
        if let Some(c) = &cm {
            add_btcb(&mut k_m, &in_plane(&p.l0, &p.e), c, wa);
        }
        if let Some(c) = &cb {
            add_btcb(&mut k_b, &in_plane(&p.l1, &p.e), c, wa);
            // Assumed covariant shear, then the local shear strains.
            let [a13, a23] = tying.assumed(r, s_, &tied);
            let ca = |a: usize, k: usize| dot(&p.e[a], &p.gc[k]);
            let mut rows = Vec::with_capacity(2);
            for a in 0..2 {
                let mut row = vec![0.0; d];
                axpy(
                    &mut row,
                    2.0 * (ca(a, 0) * ca(2, 2) + ca(a, 2) * ca(2, 0)),
                    &a13,
                );
                axpy(
                    &mut row,
                    2.0 * (ca(a, 1) * ca(2, 2) + ca(a, 2) * ca(2, 1)),
                    &a23,
                );
                for (k, l) in [(0, 0), (1, 1), (2, 2)] {
                    axpy(&mut row, 2.0 * ca(a, k) * ca(2, l), &p.ek[k][l]);
                }
                axpy(
                    &mut row,
                    2.0 * (ca(a, 0) * ca(2, 1) + ca(a, 1) * ca(2, 0)),
                    &p.ek[0][1],
                );
                rows.push(row);
            }
            add_btcb(&mut k_s, &rows, &cs, wa);
        }
        // Mass.
        let proj = |a: usize, b: usize| -> f64 {
            let id = if a == b { 1.0 } else { 0.0 };
            if res.membrane.is_some() {
                id
            } else {
                id - p.e[2][a] * p.e[2][b]
            }
        };
        for i in 0..n {
            nn[i] += wa * p.n[i] * p.n[i];
            for j in 0..n {
                let v = wa * p.n[i] * p.n[j];
                for c in 0..3 {
                    m_tr[(6 * i + c, 6 * j + c)] += v;
                }
                if res.bending.is_some() {
                    for a in 0..3 {
                        for b in 0..3 {
                            m_rot[(6 * i + 3 + a, 6 * j + 3 + b)] += v * proj(a, b);
                        }
                    }
                }
            }
        }
    }
    // Drilling penalty at the present nodes.
    if let Some((e, nu, _)) = res.membrane
        && res.bending.is_some()
    {
        let count = el.present.iter().filter(|p| **p).count() as f64;
        let kd = DRILLING_FACTOR * e / (2.0 * (1.0 + nu)) * area / count;
        for i in 0..n {
            if !el.present[i] {
                continue;
            }
            let [r, s_] = shape.node(i);
            let p = el.point(r, s_)?;
            let e3 = el.dirs[i];
            let e1 = {
                let t = sub(&p.e[0], &scale(&e3, dot(&p.e[0], &e3)));
                unit(&t)
            };
            let e2 = cross(&e3, &e1);
            let mut row = grad(&p.l0, &e2, &e1);
            row.iter_mut().for_each(|v| *v *= 0.5);
            axpy(&mut row, -0.5, &grad(&p.l0, &e1, &e2));
            for c in 0..3 {
                row[6 * i + 3 + c] -= e3[c];
            }
            add_btcb(&mut k_m, &[row], &[vec![kd]], 1.0);
        }
    }
    if kind == MassKind::Lumped {
        let total: f64 = nn.iter().sum();
        let mut lt = Mat::zeros(d, d);
        let mut lr = Mat::zeros(d, d);
        for i in 0..n {
            let share = area * nn[i] / total;
            for c in 0..3 {
                lt[(6 * i + c, 6 * i + c)] = share;
            }
            if res.bending.is_some() {
                let di = el.dirs[i];
                for a in 0..3 {
                    for b in 0..3 {
                        let id = if a == b { 1.0 } else { 0.0 };
                        let v = if res.membrane.is_some() {
                            id
                        } else {
                            id - di[a] * di[b]
                        };
                        lr[(6 * i + 3 + a, 6 * i + 3 + b)] = share * v;
                    }
                }
            }
        }
        m_tr = lt;
        m_rot = lr;
    }
    // Eliminate omitted midside nodes.
    let t = slave(shape, &el.present);
    let reduce = |m: &Mat<f64>| -> Mat<f64> {
        let r: Mat<f64> = t.transpose() * m * &t;
        Mat::from_fn(r.nrows(), r.ncols(), |i, j| 0.5 * (r[(i, j)] + r[(j, i)]))
    };
    let lumped_reduce = |m: &Mat<f64>| -> Mat<f64> {
        // Row sums of Tᵀ M T, node block by node block (keeps a nodal 3 × 3 rotational block).
        let r: Mat<f64> = t.transpose() * m * &t;
        let nr = r.nrows() / 6;
        let mut out = Mat::<f64>::zeros(r.nrows(), r.ncols());
        for i in 0..nr {
            for j in 0..nr {
                for a in 0..6 {
                    for b in 0..6 {
                        out[(6 * i + a, 6 * i + b)] += r[(6 * i + a, 6 * j + b)];
                    }
                }
            }
        }
        Mat::from_fn(out.nrows(), out.ncols(), |i, j| {
            0.5 * (out[(i, j)] + out[(j, i)])
        })
    };
    let all = el.present.iter().all(|p| *p);
    let (m_tr, m_rot) = if all {
        (m_tr, m_rot)
    } else if kind == MassKind::Lumped {
        (lumped_reduce(&m_tr), lumped_reduce(&m_rot))
    } else {
        (reduce(&m_tr), reduce(&m_rot))
    };
    let sym =
        |m: Mat<f64>| Mat::from_fn(m.nrows(), m.ncols(), |i, j| 0.5 * (m[(i, j)] + m[(j, i)]));
    let out = Parts {
        k_m: if all { sym(k_m) } else { reduce(&k_m) },
        k_s: if all { sym(k_s) } else { reduce(&k_s) },
        k_b: if all { sym(k_b) } else { reduce(&k_b) },
        m_tr,
        m_rot,
        own: [
            res.membrane.is_some_and(|m| m.2),
            res.shear.2,
            res.bending.is_some_and(|b| b.2),
        ],
    };
    let finite =
        |m: &Mat<f64>| (0..m.nrows()).all(|i| (0..m.ncols()).all(|j| m[(i, j)].is_finite()));
    if [&out.k_m, &out.k_s, &out.k_b, &out.m_tr, &out.m_rot]
        .iter()
        .all(|m| finite(m))
    {
        Ok(out)
    } else {
        Err(ElementError::Degenerate(
            "the element matrices overflow (non-finite entries); check the magnitudes of the coordinates, thickness and modulus".into(),
        ))
    }
}

fn scale(a: &V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `u_full = T u_reduced`: the DOFs of an omitted midside node are the mean of its corners'.
fn slave(shape: Shape, present: &[bool]) -> Mat<f64> {
    let n = shape.nodes();
    let c = shape.corners();
    // Reduced node index of each full node.
    let mut index = vec![usize::MAX; n];
    let mut next = 0;
    for i in 0..n {
        if present[i] {
            index[i] = next;
            next += 1;
        }
    }
    let mut t = Mat::zeros(6 * n, 6 * next);
    for i in 0..n {
        for a in 0..6 {
            if present[i] {
                t[(6 * i + a, 6 * index[i] + a)] = 1.0;
            } else {
                let (ca, cb, _) = shape.edge(i - c);
                t[(6 * i + a, 6 * index[ca] + a)] = 0.5;
                t[(6 * i + a, 6 * index[cb] + a)] = 0.5;
            }
        }
    }
    t
}

/// The MITC tying scheme of an element: edge tying points `(ξ, η, direction)` measuring
/// `dir₀ e_ξz + dir₁ e_ηz`, the two interior moments, and the assumed field built from them.
struct Tying {
    shape: Shape,
    points: Vec<(f64, f64, [f64; 2])>,
    /// Tria6: the inverse of the 8 × 8 matrix of basis values at the tying functionals.
    inverse: Vec<Vec<f64>>,
}

const TIE: f64 = 0.577_350_269_189_625_8;

impl Tying {
    fn new(shape: Shape) -> Tying {
        match shape {
            Shape::Quad8 => {
                // e_ξz on the edges η = ∓1 at ξ = ∓1/√3, e_ηz on ξ = ∓1 at η = ∓1/√3.
                let mut points = Vec::with_capacity(8);
                for s in [-1.0, 1.0] {
                    for r in [-TIE, TIE] {
                        points.push((r, s, [1.0, 0.0]));
                    }
                }
                for r in [-1.0, 1.0] {
                    for s in [-TIE, TIE] {
                        points.push((r, s, [0.0, 1.0]));
                    }
                }
                Tying {
                    shape,
                    points,
                    inverse: Vec::new(),
                }
            }
            Shape::Tria6 => {
                let (a, b) = (0.5 - 0.5 * TIE, 0.5 + 0.5 * TIE);
                let points = vec![
                    (a, 0.0, [1.0, 0.0]),
                    (b, 0.0, [1.0, 0.0]),
                    (b, a, [-1.0, 1.0]),
                    (a, b, [-1.0, 1.0]),
                    (0.0, b, [0.0, 1.0]),
                    (0.0, a, [0.0, 1.0]),
                ];
                let mut m = vec![vec![0.0; 8]; 8];
                for (row, (r, s, dir)) in points.iter().enumerate() {
                    let basis = tria_basis(*r, *s);
                    for (k, [fr, fs]) in basis.iter().enumerate() {
                        m[row][k] = dir[0] * fr + dir[1] * fs;
                    }
                }
                // The interior moments ∫∫ e_rz dr ds, ∫∫ e_sz dr ds of the basis (the rule is
                // exact for its quadratics).
                for (r, s, w) in shape.gauss() {
                    for (k, [fr, fs]) in tria_basis(r, s).iter().enumerate() {
                        m[6][k] += w * fr;
                        m[7][k] += w * fs;
                    }
                }
                Tying {
                    shape,
                    points,
                    inverse: invert(m),
                }
            }
        }
    }

    /// The tied rows of element `el`: the covariant shear at the tying points, then the
    /// interior moments `∫∫ e_ξz dξ dη`, `∫∫ e_ηz dξ dη` of the displacement-based strains over
    /// the natural domain (the element's own rule: 3 × 3 Gauss, the 6-point triangle rule).
    fn tied(&self, el: &Element) -> Result<Vec<Vec<f64>>, ElementError> {
        let mut tied = Vec::with_capacity(self.points.len() + 2);
        for (r, s, dir) in &self.points {
            let p = el.point(*r, *s)?;
            let mut row = vec![0.0; el.d];
            axpy(&mut row, dir[0], &p.ek[0][2]);
            axpy(&mut row, dir[1], &p.ek[1][2]);
            tied.push(row);
        }
        {
            let mut moments = [vec![0.0; el.d], vec![0.0; el.d]];
            for (r, s, w) in self.shape.gauss() {
                let p = el.point(r, s)?;
                axpy(&mut moments[0], w, &p.ek[0][2]);
                axpy(&mut moments[1], w, &p.ek[1][2]);
            }
            tied.extend(moments);
        }
        Ok(tied)
    }

    /// Assumed `[e_ξz, e_ηz]` rows at `(r, s)` from the tied rows.
    fn assumed(&self, r: f64, s: f64, tied: &[Vec<f64>]) -> [Vec<f64>; 2] {
        let d = tied[0].len();
        let mut out = [vec![0.0; d], vec![0.0; d]];
        match self.shape {
            Shape::Quad8 => {
                // e_ξz = A(η) + ξ B(η): B linear between the edges' slopes, A quadratic through
                // the edges' means with the bubble 1 − η² fixed by the interior moment.
                let weights = |along: f64, across: f64| -> [f64; 5] {
                    let (lo, hi) = (0.5 * (1.0 - across), 0.5 * (1.0 + across));
                    let bubble = 0.375 * (1.0 - across * across);
                    let slope = along / (2.0 * TIE);
                    [
                        0.5 * lo - bubble - slope * lo,
                        0.5 * lo - bubble + slope * lo,
                        0.5 * hi - bubble - slope * hi,
                        0.5 * hi - bubble + slope * hi,
                        bubble,
                    ]
                };
                let (wr, ws) = (weights(r, s), weights(s, r));
                for k in 0..4 {
                    axpy(&mut out[0], wr[k], &tied[k]);
                    axpy(&mut out[1], ws[k], &tied[4 + k]);
                }
                axpy(&mut out[0], wr[4], &tied[8]);
                axpy(&mut out[1], ws[4], &tied[9]);
            }
            Shape::Tria6 => {
                let basis = tria_basis(r, s);
                for (k, [fr, fs]) in basis.iter().enumerate() {
                    for (p, row) in tied.iter().enumerate() {
                        let c = self.inverse[k][p];
                        if c != 0.0 {
                            axpy(&mut out[0], fr * c, row);
                            axpy(&mut out[1], fs * c, row);
                        }
                    }
                }
            }
        }
        out
    }
}

/// The rotated second-order Raviart–Thomas basis `(e_rz, e_sz)`.
fn tria_basis(r: f64, s: f64) -> [[f64; 2]; 8] {
    [
        [1.0, 0.0],
        [r, 0.0],
        [s, 0.0],
        [0.0, 1.0],
        [0.0, r],
        [0.0, s],
        [s * r, -r * r],
        [s * s, -r * s],
    ]
}

/// Gauss–Jordan inverse of a small well-conditioned matrix (partial pivoting).
fn invert(mut a: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let n = a.len();
    let mut inv: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    for c in 0..n {
        let p = (c..n)
            .max_by(|x, y| a[*x][c].abs().total_cmp(&a[*y][c].abs()))
            .unwrap_or(c);
        a.swap(c, p);
        inv.swap(c, p);
        let piv = a[c][c];
        for j in 0..n {
            a[c][j] /= piv;
            inv[c][j] /= piv;
        }
        for r in 0..n {
            if r != c {
                let f = a[r][c];
                if f != 0.0 {
                    for j in 0..n {
                        a[r][j] -= f * a[c][j];
                        inv[r][j] -= f * inv[c][j];
                    }
                }
            }
        }
    }
    inv
}

impl Parts {
    fn stiffness(&self, cm: f64, cs: f64, cb: f64) -> Mat<f64> {
        Mat::from_fn(self.k_m.nrows(), self.k_m.ncols(), |i, j| {
            cm * self.k_m[(i, j)] + cs * self.k_s[(i, j)] + cb * self.k_b[(i, j)]
        })
    }

    fn mass(&self, mu: f64, inertia: f64) -> Mat<f64> {
        Mat::from_fn(self.m_tr.nrows(), self.m_tr.ncols(), |i, j| {
            mu * self.m_tr[(i, j)] + inertia * self.m_rot[(i, j)]
        })
    }

    fn matrices(&self, s: &ShellSection) -> ElementMatrices {
        let t = s.thickness;
        ElementMatrices {
            k: self.stiffness(t, t, t * t * t),
            m: self.mass(s.rho * t + s.nsm, s.rho * t * t * t / 12.0),
        }
    }

    fn derivative(&self, s: &ShellSection, p: ShellParameter) -> ElementDerivative {
        let t = s.thickness;
        let d = self.k_m.nrows();
        match p {
            ShellParameter::Thickness => ElementDerivative {
                dk: self.stiffness(1.0, 1.0, 3.0 * t * t),
                dm: self.mass(s.rho, s.rho * t * t / 4.0),
            },
            ShellParameter::YoungsModulus => {
                let c = |own: bool, f: f64| if own { f / s.e } else { 0.0 };
                ElementDerivative {
                    dk: self.stiffness(
                        c(self.own[0], t),
                        c(self.own[1], t),
                        c(self.own[2], t * t * t),
                    ),
                    dm: Mat::zeros(d, d),
                }
            }
            ShellParameter::Density => ElementDerivative {
                dk: Mat::zeros(d, d),
                dm: self.mass(t, t * t * t / 12.0),
            },
            ShellParameter::NonStructuralMass => ElementDerivative {
                dk: Mat::zeros(d, d),
                dm: self.mass(1.0, 0.0),
            },
        }
    }
}

/// The node coordinates a kernel takes from the corners and the midside nodes that are present:
/// `(corners, midsides)` with an omitted midside node at its edge's midpoint, and the mask.
pub fn quadratic_geometry<const C: usize, const N: usize>(
    corners: &[[f64; 3]; C],
    midside: &[Option<[f64; 3]>; C],
) -> ([[f64; 3]; N], [bool; C]) {
    let mut xyz = [[0.0; 3]; N];
    for k in 0..C {
        xyz[k] = corners[k];
        let (a, b) = (corners[k], corners[(k + 1) % C]);
        xyz[C + k] = midside[k].unwrap_or([
            0.5 * (a[0] + b[0]),
            0.5 * (a[1] + b[1]),
            0.5 * (a[2] + b[2]),
        ]);
    }
    (xyz, midside.map(|m| m.is_some()))
}

/// Stiffness and mass of an 8-node curved shell (CQUAD8). `xyz`: G1–G4 then G5–G8; `midside[k]`
/// false for an omitted midside node (its coordinate is ignored). The matrices are over the
/// corners and the present midside nodes, in that order.
pub fn quad8(
    xyz: &[[f64; 3]; 8],
    midside: [bool; 4],
    s: &ShellSection,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    Ok(parts(Shape::Quad8, xyz, &midside, s, mass)?.matrices(s))
}

/// Quad8 matrices and the derivatives for `params` (in that order) from one evaluation.
pub fn quad8_with_derivatives(
    xyz: &[[f64; 3]; 8],
    midside: [bool; 4],
    s: &ShellSection,
    mass: MassKind,
    params: &[ShellParameter],
) -> Result<(ElementMatrices, Vec<ElementDerivative>), ElementError> {
    let p = parts(Shape::Quad8, xyz, &midside, s, mass)?;
    let d = params.iter().map(|q| p.derivative(s, *q)).collect();
    Ok((p.matrices(s), d))
}

/// Stiffness and mass of a 6-node curved shell (CTRIA6). `xyz`: G1–G3 then G4–G6 (G4 on edge
/// 1–2, G5 on 2–3, G6 on 3–1); `midside[k]` false for an omitted midside node.
pub fn tria6(
    xyz: &[[f64; 3]; 6],
    midside: [bool; 3],
    s: &ShellSection,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    Ok(parts(Shape::Tria6, xyz, &midside, s, mass)?.matrices(s))
}

/// Tria6 matrices and the derivatives for `params` (in that order) from one evaluation.
pub fn tria6_with_derivatives(
    xyz: &[[f64; 3]; 6],
    midside: [bool; 3],
    s: &ShellSection,
    mass: MassKind,
    params: &[ShellParameter],
) -> Result<(ElementMatrices, Vec<ElementDerivative>), ElementError> {
    let p = parts(Shape::Tria6, xyz, &midside, s, mass)?;
    let d = params.iter().map(|q| p.derivative(s, *q)).collect();
    Ok((p.matrices(s), d))
}

#[cfg(test)]
#[path = "shell_quadratic_tests.rs"]
mod tests;
