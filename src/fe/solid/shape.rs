//! Shape functions and integration rules of the isoparametric solids (docs/theory.md §1).
//!
//! Natural coordinates: hexahedra `ξ, η, ζ ∈ [−1, 1]`; tetrahedra the volume coordinates
//! `(r, s, t)` with `L₁ = 1 − r − s − t`; pentahedra the triangle coordinates `(r, s)` times
//! `ζ ∈ [−1, 1]` (G1–G3 at `ζ = −1`); the pyramid the hexahedron's cube with its top face
//! collapsed onto the apex G5 (`N_i = (1 + ξ_iξ)(1 + η_iη)(1 − ζ)/8`, `N₅ = (1 + ζ)/2`: linear
//! complete, bilinear on the base, linear on the triangular faces, so conforming with HEXA8
//! and TETRA4 neighbours). Node order as the QRG (corners, then midside nodes edge by edge).
//!
//! **PYRAM13** (CPYRAM with G6–G13): Bedrosian's rational 13-node pyramid (G. Bedrosian 1992,
//! "Shape functions and integration formulas for three-dimensional finite element analysis",
//! *IJNME* 35, 95–108). With `t = (1 − ζ)/2` (1 on the base, 0 at the apex) and the reference
//! pyramid `x = ξt, y = ηt, z = 1 − t`, its space is the complete quadratics in `(x, y, z)` plus
//! `xy/(1 − z)`, `x²y/(1 − z)`, `xy²/(1 − z)`; on the cube these are the polynomials
//! `1, t, ξt, ηt, ξηt, t², ξt², ηt², ξ²t², η²t², ξηt², ξ²ηt², ξη²t²`. Its traces are the
//! 8-node serendipity quadrilateral on the base and the 6-node triangle on each triangular
//! face, so it is conforming with HEXA20, PENTA15 and TETRA10 neighbours. Nodal basis: base
//! edge `t²(1 − ξ²)(1 + η_m η)/2` (and with ξ, η swapped), apex edge `t(1 − t)(1 + ξ_i ξ)(1 +
//! η_i η)` (in `x, y, z`: Bedrosian's `z(1 − z + ξ_i x)(1 − z + η_i y)/(1 − z)`), corners as below.
//!
//! **Variable-node elements** (any subset of midside nodes, Bathe, *Finite Element Procedures*
//! 1996, §5.3, the 4-to-20-node construction carried to each family): the present midside
//! functions are those of the quadratic element, and each corner function is the linear
//! element's minus one half of each present midside function of its edges. An absent midside
//! function is dropped: the edge stays straight (geometry) and the displacement along it
//! linear. The quadratic elements are the case "all present" (their corner functions satisfy
//! the same identity), which is how PYRAM13's corners are formed.

use crate::model::{SolidFamily, SolidKind};

/// One integration point: natural coordinates and weight.
pub(super) type Point = ([f64; 3], f64);

/// Corner signs of the hexahedron (QRG CHEXA: G1–G4 one face, G5–G8 the opposite one).
pub(super) const HEX: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// HEXA20 midside nodes G9–G20 as the corner pairs of their edges (0-based).
pub const HEX_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [1, 2],
    [2, 3],
    [3, 0],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
    [4, 5],
    [5, 6],
    [6, 7],
    [7, 4],
];

/// PENTA15 midside nodes G7–G15 as corner pairs.
pub const PENTA_EDGES: [[usize; 2]; 9] = [
    [0, 1],
    [1, 2],
    [2, 0],
    [0, 3],
    [1, 4],
    [2, 5],
    [3, 4],
    [4, 5],
    [5, 3],
];

/// TETRA10 midside nodes G5–G10 as corner pairs.
pub const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]];

/// PYRAM13 midside nodes G6–G13 as corner pairs: the base edges, then G1–G4 to the apex G5.
pub const PYR_EDGES: [[usize; 2]; 8] = [
    [0, 1],
    [1, 2],
    [2, 3],
    [3, 0],
    [0, 4],
    [1, 4],
    [2, 4],
    [3, 4],
];

/// The edges of a family as corner pairs, in the order of its midside fields.
pub fn edges(family: SolidFamily) -> &'static [[usize; 2]] {
    match family {
        SolidFamily::Hexa => &HEX_EDGES,
        SolidFamily::Penta => &PENTA_EDGES,
        SolidFamily::Tetra => &TET_EDGES,
        SolidFamily::Pyram => &PYR_EDGES,
    }
}

/// The midside nodes present in `kind`, as indices into [`edges`].
pub fn present_edges(kind: SolidKind) -> impl Iterator<Item = usize> {
    let mask = kind.midside();
    (0..kind.family().edges()).filter(move |k| mask >> k & 1 == 1)
}

/// Natural coordinates of the nodes of `kind` (for the Kronecker-property test and the
/// midside positions). The pyramid's apex-edge midside nodes are at `(ξ_i, η_i, 0)`: the cube's
/// top face is collapsed onto the apex, so the midpoint of G_i–G5 is at the corner's `ξ, η`.
pub fn node_coordinates(kind: SolidKind) -> Vec<[f64; 3]> {
    let family = kind.family();
    let corners: Vec<[f64; 3]> = match family {
        SolidFamily::Hexa => HEX.to_vec(),
        SolidFamily::Penta => vec![
            [0.0, 0.0, -1.0],
            [1.0, 0.0, -1.0],
            [0.0, 1.0, -1.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
        ],
        SolidFamily::Tetra => vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        SolidFamily::Pyram => {
            let mut v: Vec<[f64; 3]> = HEX[..4].to_vec();
            v.push([0.0, 0.0, 1.0]);
            v
        }
    };
    let mut v = corners.clone();
    for k in present_edges(kind) {
        let [a, b] = edges(family)[k];
        v.push(if family == SolidFamily::Pyram && b == 4 {
            [HEX[a][0], HEX[a][1], 0.0]
        } else {
            [0, 1, 2].map(|r| 0.5 * (corners[a][r] + corners[b][r]))
        });
    }
    v
}

/// The nodes of the straight-edged reference element of `kind` in space: the natural
/// coordinates, except for the pyramid, whose cube is mapped to the pyramid with base
/// `[−1, 1]²` at `z = −1` and apex `(0, 0, 1)` by `x = ξ(1 − ζ)/2, y = η(1 − ζ)/2, z = ζ`.
pub fn reference_nodes(kind: SolidKind) -> Vec<[f64; 3]> {
    let v = node_coordinates(kind);
    if kind.family() != SolidFamily::Pyram {
        return v;
    }
    v.into_iter()
        .map(|[x, y, z]| [x * (1.0 - z) / 2.0, y * (1.0 - z) / 2.0, z])
        .collect()
}

/// Shape functions `N` and their natural derivatives `∂N/∂(ξ, η, ζ)` at `p`.
pub fn shape(kind: SolidKind, p: [f64; 3]) -> (Vec<f64>, Vec<[f64; 3]>) {
    let [x, y, z] = p;
    match kind {
        SolidKind::Pyram13 | SolidKind::Variable { .. } => variable(kind, p),
        SolidKind::Hexa8 => HEX
            .iter()
            .map(|c| {
                let (a, b, d) = (1.0 + c[0] * x, 1.0 + c[1] * y, 1.0 + c[2] * z);
                (
                    a * b * d / 8.0,
                    [c[0] * b * d / 8.0, a * c[1] * d / 8.0, a * b * c[2] / 8.0],
                )
            })
            .unzip(),
        SolidKind::Hexa20 => {
            let mut n = Vec::with_capacity(20);
            let mut dn = Vec::with_capacity(20);
            for c in HEX {
                let (a, b, d) = (1.0 + c[0] * x, 1.0 + c[1] * y, 1.0 + c[2] * z);
                let s = c[0] * x + c[1] * y + c[2] * z - 2.0;
                n.push(a * b * d * s / 8.0);
                dn.push([
                    c[0] * b * d * (s + a) / 8.0,
                    c[1] * a * d * (s + b) / 8.0,
                    c[2] * a * b * (s + d) / 8.0,
                ]);
            }
            for k in 0..HEX_EDGES.len() {
                let (v, d) = midside(SolidFamily::Hexa, k, p);
                n.push(v);
                dn.push(d);
            }
            (n, dn)
        }
        SolidKind::Penta6 | SolidKind::Penta15 => {
            let l = [1.0 - x - y, x, y];
            let dl = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
            let h = [(1.0 - z) / 2.0, (1.0 + z) / 2.0];
            let dh = [-0.5, 0.5];
            let mut n = Vec::new();
            let mut dn = Vec::new();
            if kind == SolidKind::Penta6 {
                for (hk, dhk) in h.iter().zip(dh) {
                    for (li, dli) in l.iter().zip(dl) {
                        n.push(li * hk);
                        dn.push([dli[0] * hk, dli[1] * hk, li * dhk]);
                    }
                }
                return (n, dn);
            }
            // Corners: L(2L − 1)·h − L(1 − ζ²)/2; triangle edges 4 LᵢLⱼ·h; verticals L(1 − ζ²).
            for k in 0..2 {
                for i in 0..3 {
                    let (li, dli) = (l[i], dl[i]);
                    let q = 1.0 - z * z;
                    n.push(li * (2.0 * li - 1.0) * h[k] - 0.5 * li * q);
                    let dldr = (4.0 * li - 1.0) * h[k] - 0.5 * q;
                    dn.push([
                        dldr * dli[0],
                        dldr * dli[1],
                        li * (2.0 * li - 1.0) * dh[k] + li * z,
                    ]);
                }
            }
            for [a, b] in PENTA_EDGES {
                let (ia, ib) = (a % 3, b % 3);
                if a < 3 && b < 3 || a >= 3 && b >= 3 {
                    let k = a / 3;
                    let (la, lb) = (l[ia], l[ib]);
                    n.push(4.0 * la * lb * h[k]);
                    dn.push([
                        4.0 * (dl[ia][0] * lb + la * dl[ib][0]) * h[k],
                        4.0 * (dl[ia][1] * lb + la * dl[ib][1]) * h[k],
                        4.0 * la * lb * dh[k],
                    ]);
                } else {
                    let q = 1.0 - z * z;
                    n.push(l[ia] * q);
                    dn.push([dl[ia][0] * q, dl[ia][1] * q, -2.0 * z * l[ia]]);
                }
            }
            (n, dn)
        }
        SolidKind::Tetra4 | SolidKind::Tetra10 => {
            let l = [1.0 - x - y - z, x, y, z];
            let dl = [
                [-1.0, -1.0, -1.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ];
            if kind == SolidKind::Tetra4 {
                return (l.to_vec(), dl.to_vec());
            }
            let mut n: Vec<f64> = l.iter().map(|li| li * (2.0 * li - 1.0)).collect();
            let mut dn: Vec<[f64; 3]> = (0..4)
                .map(|i| dl[i].map(|d| (4.0 * l[i] - 1.0) * d))
                .collect();
            for [a, b] in TET_EDGES {
                n.push(4.0 * l[a] * l[b]);
                dn.push([0, 1, 2].map(|k| 4.0 * (dl[a][k] * l[b] + l[a] * dl[b][k])));
            }
            (n, dn)
        }
        SolidKind::Pyram5 => {
            let mut n = Vec::with_capacity(5);
            let mut dn = Vec::with_capacity(5);
            for c in &HEX[..4] {
                let (a, b, d) = (1.0 + c[0] * x, 1.0 + c[1] * y, 1.0 - z);
                n.push(a * b * d / 8.0);
                dn.push([c[0] * b * d / 8.0, a * c[1] * d / 8.0, -a * b / 8.0]);
            }
            n.push((1.0 + z) / 2.0);
            dn.push([0.0, 0.0, 0.5]);
            (n, dn)
        }
    }
}

/// The midside function of edge `k` of the quadratic element of `family` and its natural
/// derivatives (HEXA20, PENTA15, TETRA10, PYRAM13).
fn midside(family: SolidFamily, k: usize, p: [f64; 3]) -> (f64, [f64; 3]) {
    let [x, y, z] = p;
    match family {
        SolidFamily::Hexa => {
            let [i, j] = HEX_EDGES[k];
            let m = [0, 1, 2].map(|r| 0.5 * (HEX[i][r] + HEX[j][r]));
            // The edge runs along the coordinate whose midpoint value is 0.
            let axis = (0..3).find(|&r| m[r] == 0.0).unwrap_or(0);
            let f = |r: usize| {
                if r == axis {
                    (1.0 - p[r] * p[r], -2.0 * p[r])
                } else {
                    (1.0 + m[r] * p[r], m[r])
                }
            };
            let (f0, f1, f2) = (f(0), f(1), f(2));
            (
                f0.0 * f1.0 * f2.0 / 4.0,
                [
                    f0.1 * f1.0 * f2.0 / 4.0,
                    f0.0 * f1.1 * f2.0 / 4.0,
                    f0.0 * f1.0 * f2.1 / 4.0,
                ],
            )
        }
        SolidFamily::Penta => {
            let l = [1.0 - x - y, x, y];
            let dl = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
            let [a, b] = PENTA_EDGES[k];
            let (ia, ib) = (a % 3, b % 3);
            if a / 3 == b / 3 {
                // A triangle edge: 4 LᵢLⱼ h.
                let (h, dh) = if a < 3 {
                    ((1.0 - z) / 2.0, -0.5)
                } else {
                    ((1.0 + z) / 2.0, 0.5)
                };
                let (la, lb) = (l[ia], l[ib]);
                (
                    4.0 * la * lb * h,
                    [
                        4.0 * (dl[ia][0] * lb + la * dl[ib][0]) * h,
                        4.0 * (dl[ia][1] * lb + la * dl[ib][1]) * h,
                        4.0 * la * lb * dh,
                    ],
                )
            } else {
                // A vertical edge: L(1 − ζ²).
                let q = 1.0 - z * z;
                (l[ia] * q, [dl[ia][0] * q, dl[ia][1] * q, -2.0 * z * l[ia]])
            }
        }
        SolidFamily::Tetra => {
            let l = [1.0 - x - y - z, x, y, z];
            let dl = [
                [-1.0, -1.0, -1.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ];
            let [a, b] = TET_EDGES[k];
            (
                4.0 * l[a] * l[b],
                [0, 1, 2].map(|r| 4.0 * (dl[a][r] * l[b] + l[a] * dl[b][r])),
            )
        }
        SolidFamily::Pyram => {
            // t = (1 − ζ)/2, dt/dζ = −1/2.
            let t = (1.0 - z) / 2.0;
            let [a, b] = PYR_EDGES[k];
            if b == 4 {
                // G_a to the apex: t(1 − t)(1 + ξ_a ξ)(1 + η_a η).
                let (xa, ya) = (HEX[a][0], HEX[a][1]);
                let (g, dg) = (t * (1.0 - t), -0.5 * (1.0 - 2.0 * t));
                let (u, v) = (1.0 + xa * x, 1.0 + ya * y);
                (g * u * v, [g * xa * v, g * u * ya, dg * u * v])
            } else if HEX[a][1] == HEX[b][1] {
                // A base edge along ξ at η = η_m: t²(1 − ξ²)(1 + η_m η)/2.
                let ym = HEX[a][1];
                let (u, v) = (1.0 - x * x, 1.0 + ym * y);
                (
                    t * t * u * v / 2.0,
                    [-t * t * x * v, t * t * u * ym / 2.0, -t * u * v / 2.0],
                )
            } else {
                // A base edge along η at ξ = ξ_m: t²(1 − η²)(1 + ξ_m ξ)/2.
                let xm = HEX[a][0];
                let (u, v) = (1.0 - y * y, 1.0 + xm * x);
                (
                    t * t * u * v / 2.0,
                    [t * t * u * xm / 2.0, -t * t * y * v, -t * u * v / 2.0],
                )
            }
        }
    }
}

/// The variable-node element (module doc): the linear element's functions, each present
/// midside function appended and half of it taken from the two corners of its edge.
fn variable(kind: SolidKind, p: [f64; 3]) -> (Vec<f64>, Vec<[f64; 3]>) {
    let family = kind.family();
    let (mut n, mut dn) = shape(family.linear(), p);
    for k in present_edges(kind) {
        let (v, d) = midside(family, k, p);
        for c in edges(family)[k] {
            n[c] -= 0.5 * v;
            for r in 0..3 {
                dn[c][r] -= 0.5 * d[r];
            }
        }
        n.push(v);
        dn.push(d);
    }
    (n, dn)
}

/// Gauss–Legendre points and weights on `[−1, 1]`, `n` = 1…4.
fn gauss(n: usize) -> Vec<(f64, f64)> {
    match n {
        1 => vec![(0.0, 2.0)],
        2 => {
            let a = 1.0 / 3f64.sqrt();
            vec![(-a, 1.0), (a, 1.0)]
        }
        3 => {
            let a = (0.6f64).sqrt();
            vec![(-a, 5.0 / 9.0), (0.0, 8.0 / 9.0), (a, 5.0 / 9.0)]
        }
        _ => {
            let (a, b) = (0.339_981_043_584_856_3, 0.861_136_311_594_052_6);
            let (wa, wb) = (0.652_145_154_862_546_1, 0.347_854_845_137_453_9);
            vec![(-b, wb), (-a, wa), (a, wa), (b, wb)]
        }
    }
}

/// `n × n × n` Gauss points on the cube.
fn cube(n: usize) -> Vec<Point> {
    let g = gauss(n);
    let mut out = Vec::with_capacity(n * n * n);
    for &(z, wz) in &g {
        for &(y, wy) in &g {
            for &(x, wx) in &g {
                out.push(([x, y, z], wx * wy * wz));
            }
        }
    }
    out
}

/// Collapsed (Duffy) Gauss rule on the triangle `r, s ≥ 0, r + s ≤ 1`: `r = a`,
/// `s = b(1 − a)`, weight `(1 − a)`; exact for total degree `2n − 2`.
fn triangle(n: usize) -> Vec<([f64; 2], f64)> {
    let g = gauss(n);
    let mut out = Vec::new();
    for &(u, wu) in &g {
        for &(v, wv) in &g {
            let (a, b) = ((1.0 + u) / 2.0, (1.0 + v) / 2.0);
            out.push(([a, b * (1.0 - a)], wu * wv / 4.0 * (1.0 - a)));
        }
    }
    out
}

/// Collapsed Gauss rule on the unit tetrahedron, exact for total degree `2n − 3`.
fn tetra(n: usize) -> Vec<Point> {
    let g = gauss(n);
    let mut out = Vec::new();
    for &(u, wu) in &g {
        for &(v, wv) in &g {
            for &(w, ww) in &g {
                let (a, b, c) = ((1.0 + u) / 2.0, (1.0 + v) / 2.0, (1.0 + w) / 2.0);
                out.push((
                    [a, b * (1.0 - a), c * (1.0 - a) * (1.0 - b)],
                    wu * wv * ww / 8.0 * (1.0 - a) * (1.0 - a) * (1.0 - b),
                ));
            }
        }
    }
    out
}

/// Triangle rule times Gauss in `ζ`.
fn prism(tri: Vec<([f64; 2], f64)>, n: usize) -> Vec<Point> {
    let g = gauss(n);
    let mut out = Vec::new();
    for &(z, wz) in &g {
        for &(p, w) in &tri {
            out.push(([p[0], p[1], z], w * wz));
        }
    }
    out
}

/// The stiffness rule (full integration): HEXA8 2×2×2 (with incompatible
/// modes), HEXA20 3×3×3, PENTA6 3-point triangle × 2, PENTA15 9-point triangle × 3, TETRA4 the
/// centroid, TETRA10 the 4-point degree-2 rule, PYRAM5 and PYRAM13 3×3×3 on the collapsed
/// cube; a variable-node element its quadratic element's rule. For PYRAM13 on a straight-edged
/// pyramid the physical gradients of its functions are polynomials on the cube of degree ≤ 2 in
/// ξ and η and ≤ 1 in `t`, and `det J ∝ t²`: the integrand has degree ≤ 4 in each
/// coordinate, which 3 Gauss points integrate exactly (degree 5).
pub fn stiffness_rule(kind: SolidKind) -> Vec<Point> {
    match kind {
        SolidKind::Pyram13 => cube(3),
        SolidKind::Variable { family, .. } => stiffness_rule(family.quadratic()),
        SolidKind::Hexa8 => cube(2),
        SolidKind::Hexa20 | SolidKind::Pyram5 => cube(3),
        SolidKind::Penta6 => prism(
            vec![
                ([1.0 / 6.0, 1.0 / 6.0], 1.0 / 6.0),
                ([2.0 / 3.0, 1.0 / 6.0], 1.0 / 6.0),
                ([1.0 / 6.0, 2.0 / 3.0], 1.0 / 6.0),
            ],
            2,
        ),
        SolidKind::Penta15 => prism(triangle(3), 3),
        SolidKind::Tetra4 => vec![([0.25, 0.25, 0.25], 1.0 / 6.0)],
        SolidKind::Tetra10 => {
            let (a, b) = (0.585_410_196_624_968_5, 0.138_196_601_125_010_5);
            vec![
                ([b, b, b], 1.0 / 24.0),
                ([a, b, b], 1.0 / 24.0),
                ([b, a, b], 1.0 / 24.0),
                ([b, b, a], 1.0 / 24.0),
            ]
        }
    }
}

/// The mass rule: exact for `ρ NᵀN` on elements with straight edges (HEXA8 3×3×3 also for a
/// distorted trilinear map). PYRAM13: `NᵢNⱼ det J` has degree 6 in `t`, so 4 points (degree 7);
/// a variable-node element takes its quadratic element's rule.
pub fn mass_rule(kind: SolidKind) -> Vec<Point> {
    match kind {
        SolidKind::Pyram13 => cube(4),
        SolidKind::Variable { family, .. } => mass_rule(family.quadratic()),
        SolidKind::Hexa8 | SolidKind::Hexa20 | SolidKind::Pyram5 => cube(3),
        SolidKind::Penta6 => prism(triangle(2), 2),
        SolidKind::Penta15 => prism(triangle(3), 3),
        SolidKind::Tetra4 => tetra(3),
        SolidKind::Tetra10 => tetra(4),
    }
}
