//! Where a point lies in an element: its natural coordinates by inverting the isoparametric
//! map, the element's shape functions there as weights on its nodes, and its distance from the
//! element (docs/theory.md §14, (14.4)). Shells (four-node bilinear, three-node linear, and the
//! curved eight- and six-node ones) are surfaces: a point off them is projected along the
//! normal, and the distance is the out-of-plane one. Solids (every isoparametric solid of
//! `fe::solid`, linear and quadratic) enclose the point or not. A point beyond an element's
//! edges is taken to a point of the element: the nearest one for the linear triangle and
//! tetrahedron, the one whose natural coordinates are the clamped ones (the parent domain's
//! nearest point) for the others, so the distance is then to that point.

use crate::model::{SolidFamily, SolidKind};

/// The element shapes interpolated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Four-node bilinear quadrilateral (CQUAD4), corners `(∓1, ∓1)` counter-clockwise.
    Quad4,
    /// Three-node linear triangle (CTRIA3).
    Tria3,
    /// Eight-node trilinear hexahedron (CHEXA8): corners 1–4 at `ζ = −1`, 5–8 at `ζ = +1`.
    Hexa8,
    /// Four-node linear tetrahedron (CTETRA4).
    Tetra4,
    /// Eight-node serendipity quadrilateral (CQUAD8): corners, then midside nodes on edges
    /// 1–2, 2–3, 3–4, 4–1.
    Quad8,
    /// Six-node quadratic triangle (CTRIA6): corners, then midside nodes on 1–2, 2–3, 3–1.
    Tria6,
    /// Another isoparametric solid (`hexa20`, `penta6`, `penta15`, `tetra10`, `pyram5`,
    /// `pyram13`), by the
    /// shape functions of `fe::solid::shape` in the QRG's node order.
    Solid(SolidKind),
}

impl Shape {
    /// Every shape, in the order of their names.
    pub const ALL: [Shape; 12] = [
        Shape::Quad4,
        Shape::Tria3,
        Shape::Hexa8,
        Shape::Tetra4,
        Shape::Quad8,
        Shape::Tria6,
        Shape::Solid(SolidKind::Hexa20),
        Shape::Solid(SolidKind::Penta6),
        Shape::Solid(SolidKind::Penta15),
        Shape::Solid(SolidKind::Tetra10),
        Shape::Solid(SolidKind::Pyram5),
        Shape::Solid(SolidKind::Pyram13),
    ];

    /// Its name in artefacts and messages.
    pub fn name(self) -> &'static str {
        match self {
            Shape::Quad4 => "quad4",
            Shape::Tria3 => "tria3",
            Shape::Hexa8 => "hexa8",
            Shape::Tetra4 => "tetra4",
            Shape::Quad8 => "quad8",
            Shape::Tria6 => "tria6",
            Shape::Solid(kind) => kind.name(),
        }
    }

    /// The shape named `name` ([`Self::name`]).
    pub fn from_name(name: &str) -> Option<Shape> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// The parent domain of a shape's natural coordinates, for the clamping of a point beyond it.
#[derive(Clone, Copy)]
enum Domain {
    /// `[−1, 1]` in the first `dims` coordinates.
    Cube(usize),
    /// `r, s ≥ 0`, `r + s ≤ 1` (triangles).
    Triangle,
    /// `r, s, t ≥ 0`, `r + s + t ≤ 1` (tetrahedra).
    Tetrahedron,
    /// A triangle in `r, s` times `ζ ∈ [−1, 1]` (pentahedra).
    Wedge,
}

impl Domain {
    /// Where Gauss-Newton starts: the domain's centre.
    fn centre(self) -> [f64; 3] {
        match self {
            Domain::Cube(_) => [0.0; 3],
            Domain::Triangle | Domain::Wedge => [1.0 / 3.0, 1.0 / 3.0, 0.0],
            Domain::Tetrahedron => [0.25; 3],
        }
    }

    /// Whether `x` lies in the domain (to [`INSIDE`]).
    fn contains(self, x: [f64; 3]) -> bool {
        let simplex =
            |v: &[f64]| v.iter().all(|c| *c >= -INSIDE) && v.iter().sum::<f64>() <= 1.0 + INSIDE;
        match self {
            Domain::Cube(d) => x[..d].iter().all(|v| v.abs() <= 1.0 + INSIDE),
            Domain::Triangle => simplex(&x[..2]),
            Domain::Tetrahedron => simplex(&x),
            Domain::Wedge => simplex(&x[..2]) && x[2].abs() <= 1.0 + INSIDE,
        }
    }

    /// The point of the domain nearest to `x` (Euclidean in natural coordinates).
    fn clamp(self, x: [f64; 3]) -> [f64; 3] {
        match self {
            Domain::Cube(d) => {
                let mut c = x;
                for v in &mut c[..d] {
                    *v = v.clamp(-1.0, 1.0);
                }
                c
            }
            Domain::Triangle => {
                let [r, s] = simplex_projection([x[0], x[1]]);
                [r, s, 0.0]
            }
            Domain::Tetrahedron => simplex_projection(x),
            Domain::Wedge => {
                let [r, s] = simplex_projection([x[0], x[1]]);
                [r, s, x[2].clamp(-1.0, 1.0)]
            }
        }
    }
}

/// The Euclidean projection of `v` onto `{v ≥ 0, Σ v ≤ 1}`.
fn simplex_projection<const N: usize>(v: [f64; N]) -> [f64; N] {
    let clipped = v.map(|c| c.max(0.0));
    if clipped.iter().sum::<f64>() <= 1.0 {
        return clipped;
    }
    // Onto the face Σ v = 1, v ≥ 0: v − τ clipped at zero, τ from the sorted values.
    let mut sorted = v;
    sorted.sort_by(|a, b| b.total_cmp(a));
    let mut tau = 0.0;
    let mut sum = 0.0;
    for (k, u) in sorted.iter().enumerate() {
        sum += u;
        let t = (sum - 1.0) / (k + 1) as f64;
        if u - t > 0.0 {
            tau = t;
        }
    }
    v.map(|c| (c - tau).max(0.0))
}

/// A point located in one element.
#[derive(Clone, Debug, PartialEq)]
pub struct Location {
    /// Natural coordinates (`ξ, η, ζ`; barycentric `s, t, u` for triangles and tetrahedra),
    /// clamped to the element.
    pub natural: [f64; 3],
    /// Shape function values at `natural`, one per element node, summing to 1.
    pub weights: Vec<f64>,
    /// Distance from the point to its image `Σ Nᵢ xᵢ`, m.
    pub distance: f64,
    /// Whether the point's projection falls within the element (to 1e-9 in natural
    /// coordinates) before clamping.
    pub inside: bool,
}

const INSIDE: f64 = 1e-9;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn combine(x: &[[f64; 3]], w: &[f64]) -> [f64; 3] {
    let mut p = [0.0; 3];
    for (xi, wi) in x.iter().zip(w) {
        for k in 0..3 {
            p[k] += wi * xi[k];
        }
    }
    p
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    dot(sub(a, b), sub(a, b)).sqrt()
}

/// Bilinear shape functions and their `ξ`, `η` derivatives (14.4).
fn quad4_n(xi: f64, eta: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    const C: [(f64, f64); 4] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    let n = C.map(|(a, b)| 0.25 * (1.0 + a * xi) * (1.0 + b * eta));
    let dxi = C.map(|(a, b)| 0.25 * a * (1.0 + b * eta));
    let deta = C.map(|(a, b)| 0.25 * b * (1.0 + a * xi));
    (n, dxi, deta)
}

/// Trilinear shape functions and their derivatives.
fn hexa8_n(x: [f64; 3]) -> ([f64; 8], [[f64; 8]; 3]) {
    const C: [[f64; 3]; 8] = [
        [-1.0, -1.0, -1.0],
        [1.0, -1.0, -1.0],
        [1.0, 1.0, -1.0],
        [-1.0, 1.0, -1.0],
        [-1.0, -1.0, 1.0],
        [1.0, -1.0, 1.0],
        [1.0, 1.0, 1.0],
        [-1.0, 1.0, 1.0],
    ];
    let f = |c: &[f64; 3], k: usize| 1.0 + c[k] * x[k];
    let n = C.map(|c| 0.125 * f(&c, 0) * f(&c, 1) * f(&c, 2));
    let d = [
        C.map(|c| 0.125 * c[0] * f(&c, 1) * f(&c, 2)),
        C.map(|c| 0.125 * c[1] * f(&c, 0) * f(&c, 2)),
        C.map(|c| 0.125 * c[2] * f(&c, 0) * f(&c, 1)),
    ];
    (n, d)
}

/// Solves the `n × n` system `a x = b` (n ≤ 3) by Gaussian elimination with partial pivoting;
/// `None` when singular relative to the matrix's size.
fn solve(mut a: [[f64; 3]; 3], mut b: [f64; 3], n: usize) -> Option<[f64; 3]> {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(scale > 0.0) {
        return None;
    }
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if !(a[p][c].abs() > 1e-13 * scale) {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            let pivot = a[c];
            for (x, pv) in a[r][c..n].iter_mut().zip(&pivot[c..n]) {
                *x -= f * pv;
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0; 3];
    for c in (0..n).rev() {
        let s: f64 = (c + 1..n).map(|k| a[c][k] * x[k]).sum();
        x[c] = (b[c] - s) / a[c][c];
    }
    Some(x)
}

/// Gauss–Newton on `min |x(ξ) − p|²` over `dims` natural coordinates from `start`;
/// `eval` gives the shape functions and their derivatives. Stops when the step is below 1e-14
/// or after 50 steps.
fn invert(
    x: &[[f64; 3]],
    p: [f64; 3],
    dims: usize,
    start: [f64; 3],
    eval: impl Fn([f64; 3]) -> (Vec<f64>, Vec<Vec<f64>>),
) -> Option<[f64; 3]> {
    let mut xi = start;
    for _ in 0..50 {
        let (n, d) = eval(xi);
        let r = sub(p, combine(x, &n));
        let tangents: Vec<[f64; 3]> = (0..dims).map(|k| combine(x, &d[k])).collect();
        let mut jtj = [[0.0; 3]; 3];
        let mut jtr = [0.0; 3];
        for a in 0..dims {
            for b in 0..dims {
                jtj[a][b] = dot(tangents[a], tangents[b]);
            }
            jtr[a] = dot(tangents[a], r);
        }
        let step = solve(jtj, jtr, dims)?;
        for k in 0..dims {
            xi[k] += step[k];
        }
        if !xi.iter().all(|v| v.is_finite() && v.abs() < 1e6) {
            return None;
        }
        if step.iter().map(|s| s.abs()).fold(0.0, f64::max) < 1e-14 {
            break;
        }
    }
    Some(xi)
}

/// The point `p` in the element of `shape` with corner coordinates `x` (in its node order);
/// `None` for a degenerate element or a projection that does not converge.
pub fn locate(shape: Shape, x: &[[f64; 3]], p: [f64; 3]) -> Option<Location> {
    match shape {
        Shape::Quad8 => locate_isoparametric(x, p, 2, Domain::Cube(2), |v| {
            let [n, a, b] = crate::fe::shell_quadratic::quad8_shape(v[0], v[1]);
            (n, vec![a, b])
        }),
        Shape::Tria6 => locate_isoparametric(x, p, 2, Domain::Triangle, |v| {
            let [n, a, b] = crate::fe::shell_quadratic::tria6_shape(v[0], v[1]);
            (n, vec![a, b])
        }),
        Shape::Solid(kind) => {
            let domain = match kind.family() {
                SolidFamily::Tetra => Domain::Tetrahedron,
                SolidFamily::Penta => Domain::Wedge,
                SolidFamily::Hexa | SolidFamily::Pyram => Domain::Cube(3),
            };
            locate_isoparametric(x, p, 3, domain, |v| {
                let (n, d) = crate::fe::solid::shape::shape(kind, v);
                let d = (0..3).map(|k| d.iter().map(|g| g[k]).collect()).collect();
                (n, d)
            })
        }
        Shape::Quad4 => {
            let eval = |v: [f64; 3]| {
                let (n, a, b) = quad4_n(v[0], v[1]);
                (n.to_vec(), vec![a.to_vec(), b.to_vec()])
            };
            let xi = invert(x, p, 2, [0.0; 3], eval)?;
            let inside = xi[0].abs() <= 1.0 + INSIDE && xi[1].abs() <= 1.0 + INSIDE;
            let c = [xi[0].clamp(-1.0, 1.0), xi[1].clamp(-1.0, 1.0), 0.0];
            let (n, _, _) = quad4_n(c[0], c[1]);
            Some(Location {
                natural: c,
                weights: n.to_vec(),
                distance: dist(p, combine(x, &n)),
                inside,
            })
        }
        Shape::Hexa8 => {
            let eval = |v: [f64; 3]| {
                let (n, d) = hexa8_n(v);
                (n.to_vec(), d.iter().map(|r| r.to_vec()).collect())
            };
            let xi = invert(x, p, 3, [0.0; 3], eval)?;
            let inside = xi.iter().all(|v| v.abs() <= 1.0 + INSIDE);
            let c = xi.map(|v| v.clamp(-1.0, 1.0));
            let (n, _) = hexa8_n(c);
            Some(Location {
                natural: c,
                weights: n.to_vec(),
                distance: dist(p, combine(x, &n)),
                inside,
            })
        }
        Shape::Tria3 => {
            let (e1, e2, r) = (sub(x[1], x[0]), sub(x[2], x[0]), sub(p, x[0]));
            let a = [
                [dot(e1, e1), dot(e1, e2), 0.0],
                [dot(e2, e1), dot(e2, e2), 0.0],
                [0.0; 3],
            ];
            let st = solve(a, [dot(e1, r), dot(e2, r), 0.0], 2)?;
            let bary = [1.0 - st[0] - st[1], st[0], st[1]];
            let inside = bary.iter().all(|b| *b >= -INSIDE);
            let w = if inside {
                bary
            } else {
                nearest_on_triangle(x, p)
            };
            Some(Location {
                natural: [w[1], w[2], 0.0],
                weights: w.to_vec(),
                distance: dist(p, combine(x, &w)),
                inside,
            })
        }
        Shape::Tetra4 => {
            let (e1, e2, e3, r) = (
                sub(x[1], x[0]),
                sub(x[2], x[0]),
                sub(x[3], x[0]),
                sub(p, x[0]),
            );
            let a = [
                [e1[0], e2[0], e3[0]],
                [e1[1], e2[1], e3[1]],
                [e1[2], e2[2], e3[2]],
            ];
            let s = solve(a, r, 3)?;
            let bary = [1.0 - s[0] - s[1] - s[2], s[0], s[1], s[2]];
            let inside = bary.iter().all(|b| *b >= -INSIDE);
            let w = if inside {
                bary
            } else {
                // The nearest point on the tetrahedron is on one of its faces.
                let faces = [[0, 1, 2], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
                let mut best = ([0.0; 4], f64::INFINITY);
                for f in faces {
                    let fx = f.map(|k| x[k]);
                    let fw = nearest_on_triangle(&fx, p);
                    let d = dist(p, combine(&fx, &fw));
                    if d < best.1 {
                        let mut w = [0.0; 4];
                        for (k, &node) in f.iter().enumerate() {
                            w[node] = fw[k];
                        }
                        best = (w, d);
                    }
                }
                best.0
            };
            Some(Location {
                natural: [w[1], w[2], w[3]],
                weights: w.to_vec(),
                distance: dist(p, combine(x, &w)),
                inside,
            })
        }
    }
}

/// [`locate`] for the shapes located by Gauss-Newton in their parent `domain` of `dims`
/// coordinates, with the shape functions `eval`.
fn locate_isoparametric(
    x: &[[f64; 3]],
    p: [f64; 3],
    dims: usize,
    domain: Domain,
    eval: impl Fn([f64; 3]) -> (Vec<f64>, Vec<Vec<f64>>),
) -> Option<Location> {
    let xi = invert(x, p, dims, domain.centre(), &eval)?;
    let inside = domain.contains(xi);
    let c = domain.clamp(xi);
    let (n, _) = eval(c);
    Some(Location {
        natural: c,
        distance: dist(p, combine(x, &n)),
        weights: n,
        inside,
    })
}

/// Barycentric weights of the point of triangle `x` nearest to `p` (inside, on an edge or at a
/// corner).
fn nearest_on_triangle(x: &[[f64; 3]], p: [f64; 3]) -> [f64; 3] {
    let (e1, e2, r) = (sub(x[1], x[0]), sub(x[2], x[0]), sub(p, x[0]));
    let a = [
        [dot(e1, e1), dot(e1, e2), 0.0],
        [dot(e2, e1), dot(e2, e2), 0.0],
        [0.0; 3],
    ];
    if let Some(st) = solve(a, [dot(e1, r), dot(e2, r), 0.0], 2) {
        let w = [1.0 - st[0] - st[1], st[0], st[1]];
        if w.iter().all(|b| *b >= 0.0) {
            return w;
        }
    }
    // On an edge: the best of the three segments.
    let mut best = ([1.0, 0.0, 0.0], f64::INFINITY);
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        let e = sub(x[j], x[i]);
        let ee = dot(e, e);
        let t = if ee > 0.0 {
            (dot(sub(p, x[i]), e) / ee).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let mut w = [0.0; 3];
        w[i] = 1.0 - t;
        w[j] += t;
        let d = dist(p, combine(x, &w));
        if d < best.1 {
            best = (w, d);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point inside a flat rectangle has the bilinear weights of its natural coordinates,
    /// and a point above it is projected with its height as distance.
    #[test]
    fn bilinear_weights_at_a_known_point() {
        let x = [
            [0.0, 0.0, 0.0],
            [0.2, 0.0, 0.0],
            [0.2, 0.1, 0.0],
            [0.0, 0.1, 0.0],
        ];
        // x = 0.05 → ξ = −0.5; y = 0.075 → η = 0.5.
        let l = locate(Shape::Quad4, &x, [0.05, 0.075, 0.003]).unwrap();
        let want = [
            0.25 * 1.5 * 0.5,
            0.25 * 0.5 * 0.5,
            0.25 * 0.5 * 1.5,
            0.25 * 1.5 * 1.5,
        ];
        for (w, want) in l.weights.iter().zip(want) {
            assert!((w - want).abs() < 1e-14, "{:?}", l.weights);
        }
        assert!((l.natural[0] + 0.5).abs() < 1e-14 && (l.natural[1] - 0.5).abs() < 1e-14);
        assert!((l.distance - 0.003).abs() < 1e-15 && l.inside);
        // Beyond the edge x = 0.2: clamped to it, the distance to the edge point.
        let l = locate(Shape::Quad4, &x, [0.23, 0.05, 0.0]).unwrap();
        assert!(!l.inside && (l.distance - 0.03).abs() < 1e-14);
        assert!((l.weights[1] - 0.5).abs() < 1e-14 && (l.weights[2] - 0.5).abs() < 1e-14);
    }

    /// A warped, distorted quadrilateral: the weights reproduce the projected point and the
    /// residual is normal to the surface there.
    #[test]
    fn distorted_quad_reproduces_the_point() {
        let x = [
            [0.0, 0.0, 0.0],
            [1.0, 0.1, 0.02],
            [1.2, 0.9, -0.01],
            [-0.1, 1.0, 0.03],
        ];
        let p = [0.4, 0.55, 0.2];
        let l = locate(Shape::Quad4, &x, p).unwrap();
        let q = combine(&x, &l.weights);
        let (_, a, b) = quad4_n(l.natural[0], l.natural[1]);
        let r = sub(p, q);
        assert!(dot(r, combine(&x, &a)).abs() < 1e-12);
        assert!(dot(r, combine(&x, &b)).abs() < 1e-12);
        assert!((l.weights.iter().sum::<f64>() - 1.0).abs() < 1e-14);
    }

    /// The serendipity quadrilateral's weights on a flat rectangle with straight edges, at a
    /// point of known natural coordinates, against the shape functions written out by hand
    /// (corner `¼(1+ξᵢξ)(1+ηᵢη)(ξᵢξ+ηᵢη−1)`, midside `½(1−ξ²)(1+ηᵢη)` and `½(1+ξᵢξ)(1−η²)`).
    #[test]
    fn quad8_weights_at_a_known_point() {
        let c = [[0.0, 0.0], [0.2, 0.0], [0.2, 0.1], [0.0, 0.1]];
        let mut x: Vec<[f64; 3]> = c.iter().map(|p| [p[0], p[1], 0.0]).collect();
        for k in 0..4 {
            let (a, b) = (c[k], c[(k + 1) % 4]);
            x.push([0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.0]);
        }
        let l = locate(Shape::Quad8, &x, [0.05, 0.075, -0.004]).unwrap();
        let (xi, eta) = (-0.5, 0.5);
        let corner =
            |a: f64, b: f64| 0.25 * (1.0 + a * xi) * (1.0 + b * eta) * (a * xi + b * eta - 1.0);
        let want = [
            corner(-1.0, -1.0),
            corner(1.0, -1.0),
            corner(1.0, 1.0),
            corner(-1.0, 1.0),
            0.5 * (1.0 - xi * xi) * (1.0 - eta),
            0.5 * (1.0 + xi) * (1.0 - eta * eta),
            0.5 * (1.0 - xi * xi) * (1.0 + eta),
            0.5 * (1.0 - xi) * (1.0 - eta * eta),
        ];
        for (w, want) in l.weights.iter().zip(want) {
            assert!((w - want).abs() < 1e-13, "{:?} vs {want:?}", l.weights);
        }
        assert!(l.inside && (l.distance - 0.004).abs() < 1e-14);
    }

    /// Curved quadratic elements: a point made by the element's own map at chosen natural
    /// coordinates (and, for the surfaces, moved along the normal) is found there again, with
    /// the shape functions there as weights (1e-10), inside, at the distance it was moved; a
    /// point beyond a quadratic tetrahedron is clamped onto its parent domain.
    #[test]
    fn curved_quadratic_elements_invert_their_own_map() {
        // Midside nodes pushed off the straight edges: curved edges and faces.
        let bulge = |x: &mut Vec<[f64; 3]>, from: usize, amount: f64| {
            for (k, p) in x.iter_mut().enumerate().skip(from) {
                p[2] += amount * (1.0 + 0.3 * k as f64);
                p[0] += 0.4 * amount;
            }
        };
        // CQUAD8 on a saddle.
        let mut q: Vec<[f64; 3]> = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.8, 0.0],
            [0.0, 0.8, 0.0],
            [0.5, 0.0, 0.0],
            [1.0, 0.4, 0.0],
            [0.5, 0.8, 0.0],
            [0.0, 0.4, 0.0],
        ];
        bulge(&mut q, 4, 0.05);
        let at = [0.3, -0.6, 0.0];
        let [n, _, _] = crate::fe::shell_quadratic::quad8_shape(at[0], at[1]);
        let on = combine(&q, &n);
        let l = locate(Shape::Quad8, &q, on).unwrap();
        assert!(l.inside && l.distance < 1e-12, "{l:?}");
        for (w, want) in l.weights.iter().zip(&n) {
            assert!((w - want).abs() < 1e-10, "{:?} vs {n:?}", l.weights);
        }
        // CTRIA6, curved.
        let mut t: Vec<[f64; 3]> = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.0, 0.5, 0.0],
        ];
        bulge(&mut t, 3, 0.04);
        let [n, _, _] = crate::fe::shell_quadratic::tria6_shape(0.2, 0.5);
        let l = locate(Shape::Tria6, &t, combine(&t, &n)).unwrap();
        assert!(l.inside && l.distance < 1e-12);
        assert!((l.natural[0] - 0.2).abs() < 1e-10 && (l.natural[1] - 0.5).abs() < 1e-10);
        // The solids of fe::solid, midside nodes moved inwards and outwards.
        for (kind, at) in [
            (SolidKind::Hexa20, [0.3, -0.2, 0.7]),
            (SolidKind::Tetra10, [0.2, 0.3, 0.1]),
            (SolidKind::Penta6, [0.2, 0.5, -0.4]),
            (SolidKind::Penta15, [0.6, 0.1, 0.3]),
            (SolidKind::Pyram5, [0.2, -0.3, 0.1]),
            (SolidKind::Pyram13, [0.2, -0.3, 0.1]),
        ] {
            let mut x: Vec<[f64; 3]> = crate::fe::solid::shape::reference_nodes(kind)
                .iter()
                .map(|c| [0.1 * c[0] + 1.0, 0.2 * c[1], 0.05 * c[2] + 0.02 * c[0]])
                .collect();
            let corners = match kind {
                SolidKind::Hexa20 => 8,
                SolidKind::Tetra10 => 4,
                SolidKind::Penta15 => 6,
                SolidKind::Pyram13 => 5,
                _ => x.len(),
            };
            for (k, p) in x.iter_mut().enumerate().skip(corners) {
                p[2] += if k % 2 == 0 { 0.004 } else { -0.003 };
            }
            let (n, _) = crate::fe::solid::shape::shape(kind, at);
            let l = locate(Shape::Solid(kind), &x, combine(&x, &n)).unwrap();
            assert!(l.inside && l.distance < 1e-12, "{kind:?}: {l:?}");
            for (a, b) in l.natural.iter().zip(at) {
                assert!((a - b).abs() < 1e-10, "{kind:?}: {:?} vs {at:?}", l.natural);
            }
        }
        let tet: Vec<[f64; 3]> = crate::fe::solid::shape::node_coordinates(SolidKind::Tetra10);
        let l = locate(Shape::Solid(SolidKind::Tetra10), &tet, [0.8, 0.6, -0.1]).unwrap();
        assert!(!l.inside);
        let [r, s, t] = l.natural;
        assert!(
            r >= 0.0 && s >= 0.0 && t >= 0.0 && r + s + t <= 1.0 + 1e-15,
            "{l:?}"
        );
        assert!((l.weights.iter().sum::<f64>() - 1.0).abs() < 1e-13);
    }

    /// The projection onto the simplex: inside unchanged, a negative coordinate to zero, beyond
    /// the face `Σ = 1` onto it along its normal.
    #[test]
    fn simplex_projection_is_the_nearest_point() {
        assert_eq!(simplex_projection([0.2, 0.3]), [0.2, 0.3]);
        assert_eq!(simplex_projection([-0.2, 0.5]), [0.0, 0.5]);
        let [a, b] = simplex_projection([0.8, 0.6]);
        assert!((a - 0.6).abs() < 1e-15 && (b - 0.4).abs() < 1e-15);
        let [a, b, c] = simplex_projection([1.5, -0.5, 0.2]);
        assert!((a - 1.0).abs() < 1e-15 && b == 0.0 && c == 0.0);
    }

    #[test]
    fn triangles_and_solids() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let l = locate(Shape::Tria3, &t, [0.2, 0.3, -0.1]).unwrap();
        assert!((l.weights[0] - 0.5).abs() < 1e-15 && (l.weights[2] - 0.3).abs() < 1e-15);
        assert!((l.distance - 0.1).abs() < 1e-15);
        let l = locate(Shape::Tria3, &t, [1.0, 1.0, 0.0]).unwrap();
        assert!(!l.inside && (l.weights[1] - 0.5).abs() < 1e-15);
        let h: Vec<[f64; 3]> = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]
        .iter()
        .chain(&[
            [0.0, 0.0, 1.0],
            [2.0, 0.0, 1.0],
            [2.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ])
        .copied()
        .collect();
        let l = locate(Shape::Hexa8, &h, [1.5, 0.25, 0.5]).unwrap();
        // ξ = 0.5, η = −0.5, ζ = 0.
        assert!(l.inside && l.distance < 1e-15);
        assert!((l.weights[1] - 0.125 * 1.5 * 1.5).abs() < 1e-14);
        let tet = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let l = locate(Shape::Tetra4, &tet, [0.1, 0.2, 0.3]).unwrap();
        assert!((l.weights[0] - 0.4).abs() < 1e-15 && l.inside);
        let l = locate(Shape::Tetra4, &tet, [0.2, 0.2, -0.5]).unwrap();
        assert!(!l.inside && (l.distance - 0.5).abs() < 1e-15);
    }
}
