//! Rigid alignment of test geometry to the model (docs/theory.md §14): a stated transform
//! `x_model = R x_test + t` (14.1), or the least-squares fit of `R`, `t` to named point
//! correspondences by the SVD of their cross-covariance (Kabsch 1976, Horn 1987; (14.2)–(14.3)).

use super::PairingError;
use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::svd::{ComputeSvdVectors, svd, svd_scratch};
use faer::{Mat, Par};

/// A rigid motion `x_model = R x_test + t` (14.1); directions turn by `R` alone.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RigidTransform {
    /// Rotation `R`, rows: `R[i][j]` multiplies test component `j` to give model component `i`.
    pub rotation: [[f64; 3]; 3],
    /// Translation `t`, m.
    pub translation: [f64; 3],
}

impl Default for RigidTransform {
    fn default() -> Self {
        RigidTransform::identity()
    }
}

/// How a rotation is stated.
#[derive(Clone, Debug, PartialEq)]
pub enum Rotation {
    /// The matrix itself, by rows (`x_model = R x_test`).
    Matrix([[f64; 3]; 3]),
    /// A right-handed rotation by `angle_deg` about `axis` (any non-zero length).
    AxisAngle {
        /// The axis, in model (= test) components.
        axis: [f64; 3],
        /// The angle, degrees.
        angle_deg: f64,
    },
    /// Rotations about the fixed x, then y, then z axes: `R = R_z(γ) R_y(β) R_x(α)`, degrees
    /// `[α, β, γ]`.
    EulerXyz([f64; 3]),
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

/// The determinant of a 3×3 matrix.
pub(super) fn det3(a: &[[f64; 3]; 3]) -> f64 {
    a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
}

/// `a v`.
pub(super) fn mat_vec(a: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

impl Rotation {
    /// The rotation matrix; refuses a matrix that is not orthonormal with determinant +1 (to
    /// 1e-6), a zero axis and non-finite values.
    pub fn matrix(&self) -> Result<[[f64; 3]; 3], PairingError> {
        let bad = |problem: String| PairingError::NotARotation { problem };
        match self {
            Rotation::Matrix(r) => {
                if !r.iter().flatten().all(|v| v.is_finite()) {
                    return Err(bad("it holds a value that is not finite".into()));
                }
                for i in 0..3 {
                    for j in 0..3 {
                        let d: f64 = (0..3).map(|k| r[i][k] * r[j][k]).sum();
                        let want = if i == j { 1.0 } else { 0.0 };
                        if (d - want).abs() > 1e-6 {
                            return Err(bad(format!(
                                "rows {} and {} have dot product {d:.6}, not {want}; give orthonormal rows",
                                i + 1,
                                j + 1
                            )));
                        }
                    }
                }
                let d = det3(r);
                if d < 0.0 {
                    return Err(bad(format!(
                        "its determinant is {d:.6}: a reflection; give a right-handed rotation (determinant +1)"
                    )));
                }
                Ok(*r)
            }
            Rotation::AxisAngle { axis, angle_deg } => {
                let n = axis.iter().map(|a| a * a).sum::<f64>().sqrt();
                if !(n > 0.0) || !n.is_finite() || !angle_deg.is_finite() {
                    return Err(bad(format!(
                        "axis {axis:?} and angle {angle_deg} deg: give a non-zero finite axis and a finite angle"
                    )));
                }
                let [x, y, z] = axis.map(|a| a / n);
                let (s, c) = angle_deg.to_radians().sin_cos();
                let v = 1.0 - c;
                // Rodrigues' formula: R = c I + s [k]ₓ + (1 − c) k kᵀ.
                Ok([
                    [c + x * x * v, x * y * v - z * s, x * z * v + y * s],
                    [y * x * v + z * s, c + y * y * v, y * z * v - x * s],
                    [z * x * v - y * s, z * y * v + x * s, c + z * z * v],
                ])
            }
            Rotation::EulerXyz(angles) => {
                if !angles.iter().all(|a| a.is_finite()) {
                    return Err(bad(format!("angles {angles:?}: give finite angles")));
                }
                let about = |axis: [f64; 3], a: f64| Rotation::AxisAngle { axis, angle_deg: a };
                let rx = about([1.0, 0.0, 0.0], angles[0]).matrix()?;
                let ry = about([0.0, 1.0, 0.0], angles[1]).matrix()?;
                let rz = about([0.0, 0.0, 1.0], angles[2]).matrix()?;
                Ok(mat_mul(&rz, &mat_mul(&ry, &rx)))
            }
        }
    }
}

impl RigidTransform {
    /// No motion.
    pub fn identity() -> Self {
        RigidTransform {
            rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            translation: [0.0; 3],
        }
    }

    /// A stated rotation and translation.
    pub fn new(rotation: &Rotation, translation: [f64; 3]) -> Result<Self, PairingError> {
        if !translation.iter().all(|t| t.is_finite()) {
            return Err(PairingError::NotARotation {
                problem: format!("translation {translation:?} is not finite"),
            });
        }
        Ok(RigidTransform {
            rotation: rotation.matrix()?,
            translation,
        })
    }

    /// A test point in model coordinates (14.1).
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let r = mat_vec(&self.rotation, p);
        [0, 1, 2].map(|i| r[i] + self.translation[i])
    }

    /// A test direction in model components.
    pub fn turn(&self, d: [f64; 3]) -> [f64; 3] {
        mat_vec(&self.rotation, d)
    }
}

/// One named correspondence: a test point and the model node it should coincide with.
#[derive(Clone, Debug, PartialEq)]
pub struct Correspondence {
    /// Test node label.
    pub test_node: u64,
    /// Its coordinates in the test system, m.
    pub test_xyz: [f64; 3],
    /// Model node id.
    pub fe_node: u64,
    /// Its coordinates, m.
    pub fe_xyz: [f64; 3],
}

/// The result of a fit: the transform and how well each correspondence is met.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitReport {
    /// The least-squares transform.
    pub transform: RigidTransform,
    /// Per correspondence `(test node, FE node, |R p + t − q|)`, m, in the order given.
    pub residuals: Vec<(u64, u64, f64)>,
    /// Root mean square of the residuals, m.
    pub rms: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn centroid(ps: impl Iterator<Item = [f64; 3]> + Clone) -> [f64; 3] {
    let n = ps.clone().count().max(1) as f64;
    let mut c = [0.0; 3];
    for p in ps {
        for k in 0..3 {
            c[k] += p[k];
        }
    }
    c.map(|v| v / n)
}

/// The SVD `A = U diag(s) Vᵀ` of a 3×3 matrix on one thread (bit-reproducible).
fn svd3(a: &[[f64; 3]; 3]) -> Option<(Mat<f64>, [f64; 3], Mat<f64>)> {
    let m = Mat::from_fn(3, 3, |i, j| a[i][j]);
    let (mut u, mut v, mut s) = (Mat::zeros(3, 3), Mat::zeros(3, 3), Diag::zeros(3));
    let full = ComputeSvdVectors::Full;
    let mut buf = MemBuffer::new(svd_scratch::<f64>(
        3,
        3,
        full,
        full,
        Par::Seq,
        Default::default(),
    ));
    svd(
        m.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        Some(v.as_mut()),
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .ok()?;
    Some((u, [s[0], s[1], s[2]], v))
}

/// Describes the correspondences for messages: `test 101 → FE 1, …`.
fn describe(pairs: &[Correspondence]) -> String {
    pairs
        .iter()
        .map(|c| format!("test {} → FE {}", c.test_node, c.fe_node))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The rigid transform minimising `Σ |R pᵢ + t − qᵢ|²` over three or more correspondences
/// (14.2)–(14.3): `H = Σ (pᵢ − p̄)(qᵢ − q̄)ᵀ = U S Vᵀ`, `R = V diag(1, 1, det(V Uᵀ)) Uᵀ`,
/// `t = q̄ − R p̄`. Refuses fewer than three, repeated test nodes, and points on one line
/// (in either set), naming them.
pub fn fit_rigid(pairs: &[Correspondence]) -> Result<FitReport, PairingError> {
    if pairs.len() < 3 {
        return Err(PairingError::TooFewCorrespondences {
            given: describe(pairs),
        });
    }
    for (k, c) in pairs.iter().enumerate() {
        if !c.test_xyz.iter().chain(&c.fe_xyz).all(|v| v.is_finite()) {
            return Err(PairingError::DegenerateCorrespondences {
                pairs: describe(&pairs[k..=k]),
                problem: "a coordinate is not finite".into(),
            });
        }
        if let Some(first) = pairs[..k].iter().find(|d| d.test_node == c.test_node) {
            return Err(PairingError::DegenerateCorrespondences {
                pairs: describe(&[first.clone(), c.clone()]),
                problem: format!("test node {} is named twice", c.test_node),
            });
        }
    }
    let pc = centroid(pairs.iter().map(|c| c.test_xyz));
    let qc = centroid(pairs.iter().map(|c| c.fe_xyz));
    // Collinearity of each set: the second singular value of its centred scatter.
    for (which, pick) in [("test", 0usize), ("model", 1)] {
        let mut s = [[0.0; 3]; 3];
        let c0 = if pick == 0 { pc } else { qc };
        for c in pairs {
            let d = sub(if pick == 0 { c.test_xyz } else { c.fe_xyz }, c0);
            for i in 0..3 {
                for j in 0..3 {
                    s[i][j] += d[i] * d[j];
                }
            }
        }
        let (_, sv, _) = svd3(&s).ok_or(PairingError::FitFailed)?;
        // `s` holds squared lengths: the spread across the best line, relative to along it.
        if !(sv[1] > 1e-12 * sv[0]) {
            return Err(PairingError::DegenerateCorrespondences {
                pairs: describe(pairs),
                problem: format!(
                    "the {which} points lie on one line (or coincide), so a rotation about it is undetermined"
                ),
            });
        }
    }
    let mut h = [[0.0; 3]; 3];
    for c in pairs {
        let (p, q) = (sub(c.test_xyz, pc), sub(c.fe_xyz, qc));
        for i in 0..3 {
            for j in 0..3 {
                h[i][j] += p[i] * q[j];
            }
        }
    }
    let (u, _, v) = svd3(&h).ok_or(PairingError::FitFailed)?;
    let vut = |d: f64| {
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = v[(i, 0)] * u[(j, 0)] + v[(i, 1)] * u[(j, 1)] + d * v[(i, 2)] * u[(j, 2)];
            }
        }
        r
    };
    let d = det3(&vut(1.0)).signum();
    let rotation = vut(d);
    let rp = mat_vec(&rotation, pc);
    let transform = RigidTransform {
        rotation,
        translation: [qc[0] - rp[0], qc[1] - rp[1], qc[2] - rp[2]],
    };
    let residuals: Vec<(u64, u64, f64)> = pairs
        .iter()
        .map(|c| {
            let r = norm(sub(transform.apply(c.test_xyz), c.fe_xyz));
            (c.test_node, c.fe_node, r)
        })
        .collect();
    let rms = (residuals.iter().map(|r| r.2 * r.2).sum::<f64>() / residuals.len() as f64).sqrt();
    Ok(FitReport {
        transform,
        residuals,
        rms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points() -> Vec<[f64; 3]> {
        vec![
            [0.0, 0.0, 0.0],
            [0.4, 0.0, 0.0],
            [0.4, 0.3, 0.0],
            [0.0, 0.3, 0.05],
            [0.21, 0.17, -0.02],
        ]
    }

    /// A rotated and translated copy is recovered to 1e-12, with zero residuals.
    #[test]
    fn fit_recovers_a_rotated_translated_copy() {
        let truth = RigidTransform::new(
            &Rotation::AxisAngle {
                axis: [0.3, -0.5, 0.8],
                angle_deg: 137.0,
            },
            [1.5, -0.25, 3.0],
        )
        .unwrap();
        let pairs: Vec<Correspondence> = points()
            .into_iter()
            .enumerate()
            .map(|(k, p)| Correspondence {
                test_node: 100 + k as u64,
                test_xyz: p,
                fe_node: k as u64 + 1,
                fe_xyz: truth.apply(p),
            })
            .collect();
        let fit = fit_rigid(&pairs).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                assert!((fit.transform.rotation[i][j] - truth.rotation[i][j]).abs() < 1e-12);
            }
            assert!((fit.transform.translation[i] - truth.translation[i]).abs() < 1e-12);
        }
        assert!(fit.rms < 1e-12 && fit.residuals.iter().all(|r| r.2 < 1e-12));
        assert_eq!(fit.residuals[2].0, 102);
        // Three points suffice, planar sets included (no reflection is returned).
        let three = fit_rigid(&pairs[..3]).unwrap();
        assert!((det3(&three.transform.rotation) - 1.0).abs() < 1e-12);
        assert!(three.rms < 1e-12);
    }

    /// Noise gives residuals whose RMS matches their definition.
    #[test]
    fn residuals_are_reported_per_point() {
        let mut pairs: Vec<Correspondence> = points()
            .into_iter()
            .enumerate()
            .map(|(k, p)| Correspondence {
                test_node: k as u64 + 1,
                test_xyz: p,
                fe_node: k as u64 + 1,
                fe_xyz: p,
            })
            .collect();
        pairs[4].fe_xyz[2] += 0.001;
        let fit = fit_rigid(&pairs).unwrap();
        let rms = (fit.residuals.iter().map(|r| r.2 * r.2).sum::<f64>() / 5.0).sqrt();
        assert!((fit.rms - rms).abs() < 1e-15 && fit.rms > 1e-4);
        assert!(fit.residuals[4].2 > fit.residuals[0].2);
    }

    #[test]
    fn collinear_and_too_few_correspondences_are_refused_by_name() {
        let line: Vec<Correspondence> = (0..4)
            .map(|k| Correspondence {
                test_node: 10 + k,
                test_xyz: [k as f64, 2.0 * k as f64, 0.0],
                fe_node: k + 1,
                fe_xyz: [k as f64, 0.0, 0.0],
            })
            .collect();
        let e = fit_rigid(&line).unwrap_err().to_string();
        assert!(
            e.contains("test 10 → FE 1") && e.contains("one line"),
            "{e}"
        );
        let e = fit_rigid(&line[..2]).unwrap_err().to_string();
        assert!(e.contains("at least three"), "{e}");
    }

    #[test]
    fn stated_rotations_agree() {
        let e = Rotation::EulerXyz([0.0, 0.0, 90.0]).matrix().unwrap();
        let a = Rotation::AxisAngle {
            axis: [0.0, 0.0, 2.0],
            angle_deg: 90.0,
        }
        .matrix()
        .unwrap();
        let x = mat_vec(&e, [1.0, 0.0, 0.0]);
        assert!((x[1] - 1.0).abs() < 1e-15 && x[0].abs() < 1e-15);
        assert_eq!(e, a);
        // x then y: a point on x goes to -z under R_y(90) after R_x leaves it.
        let r = Rotation::EulerXyz([90.0, 90.0, 0.0]).matrix().unwrap();
        let y = mat_vec(&r, [0.0, 1.0, 0.0]);
        assert!((y[0] - 1.0).abs() < 1e-15, "{y:?}");
        assert!(
            Rotation::Matrix([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
                .matrix()
                .unwrap_err()
                .to_string()
                .contains("reflection")
        );
        assert!(
            Rotation::Matrix([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
                .matrix()
                .is_err()
        );
    }
}
