//! Where a point lies in an element: its natural coordinates by inverting the isoparametric
//! map, the element's shape functions there as weights on its nodes, and its distance from the
//! element (docs/theory.md §14, (14.4)). Shells (four-node bilinear, three-node linear) are
//! surfaces: a point off them is projected along the normal, and the distance is the
//! out-of-plane one. Solids (eight-node trilinear, four-node linear) enclose the point or not.
//! A point beyond an element's edges is taken to the nearest point of the element (natural
//! coordinates clamped to it), so the distance is then to that point.

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
}

impl Shape {
    /// Its name in artefacts and messages.
    pub fn name(self) -> &'static str {
        match self {
            Shape::Quad4 => "quad4",
            Shape::Tria3 => "tria3",
            Shape::Hexa8 => "hexa8",
            Shape::Tetra4 => "tetra4",
        }
    }
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

/// Gauss–Newton on `min |x(ξ) − p|²` over `dims` natural coordinates from the centre;
/// `eval` gives the shape functions and their derivatives. Stops when the step is below 1e-14
/// or after 50 steps.
fn invert(
    x: &[[f64; 3]],
    p: [f64; 3],
    dims: usize,
    eval: impl Fn([f64; 3]) -> (Vec<f64>, Vec<Vec<f64>>),
) -> Option<[f64; 3]> {
    let mut xi = [0.0; 3];
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
        Shape::Quad4 => {
            let eval = |v: [f64; 3]| {
                let (n, a, b) = quad4_n(v[0], v[1]);
                (n.to_vec(), vec![a.to_vec(), b.to_vec()])
            };
            let xi = invert(x, p, 2, eval)?;
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
            let xi = invert(x, p, 3, eval)?;
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
