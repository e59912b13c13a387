//! Lumped elements: six-DOF springs, scalar springs and concentrated (CONM2-like) masses, with
//! their exact parameter derivatives (docs/theory.md §2: linear in every parameter).
//!
//! **Six-DOF spring** (like a CBUSH between coincident nodes, in the basic system): stiffness
//! `k_c` in each direction `c ∈ {x, y, z, θx, θy, θz}`. Between nodes `a` and `b` DOF `c` of each gets
//! `k_c [[1, −1], [−1, 1]]`, so `K` is `[[D, −D], [−D, D]]` with `D = diag(k)` (12 × 12); to ground it
//! is `D` (6 × 6). The two nodes are meant to coincide: no lever arm between them is modelled.
//! `∂K/∂k_c` is the same pattern with a 1 in direction `c`.
//!
//! **Scalar spring** (like CELAS2) of stiffness `k` between two arbitrary DOFs: `k [[1, −1], [−1, 1]]`
//! (rows: the two DOFs), or `[k]` to ground.
//!
//! **Concentrated mass** (like CONM2 in the basic system): mass `m` at the centre of gravity,
//! offset `e` from the node, with inertia tensor `J` about the centre of gravity. The centre of
//! gravity moves with `u + ω × e` for nodal translation `u` and rotation `ω`, so the kinetic energy
//! `½ m |u̇ + ω̇ × e|² + ½ ω̇ᵀ J ω̇` gives (with `E = [e]ₓ`, `E a = e × a`)
//! `M = [[m I, −m E], [m E, J − m E²]]` where `−m E² = m (|e|² I − e eᵀ)` is the parallel-axis term.
//! `J` is the tensor `[[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]]` with products
//! `Ixy = −∫ x y dm`; Nastran's CONM2 fields `I21, I31, I32` are `+∫ x y dm` etc., so
//! [`LumpedMass::from_nastran`] negates them. `∂M/∂m = [[I, −E], [E, −E²]]` and `∂M/∂J_ij` has
//! ones at `(i, j)` and `(j, i)` of the rotational block.

use super::element::{ElementDerivative, ElementError, ElementMatrices, positive};
use crate::core::Component;
use faer::Mat;

/// How a spring is connected.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum SpringEnds {
    /// Between two nodes (or two DOFs): matrices over both ends.
    TwoNodes,
    /// From one node (or DOF) to ground: matrices over that end only.
    Ground,
}

/// Stiffness per direction `[kx, ky, kz, krx, kry, krz]` (N/m, N·m/rad) of a six-DOF spring.
pub type SpringStiffness = [f64; 6];

fn check_stiffness(k: &SpringStiffness) -> Result<(), ElementError> {
    const NAMES: [&str; 6] = ["kx", "ky", "kz", "krx", "kry", "krz"];
    for (name, value) in NAMES.iter().zip(k) {
        positive(name, *value, true)?;
    }
    Ok(())
}

/// Spring matrix with diagonal `d` per direction, over one or two nodes.
fn spring_pattern(d: &[f64; 6], ends: SpringEnds) -> Mat<f64> {
    match ends {
        SpringEnds::Ground => Mat::from_fn(6, 6, |i, j| if i == j { d[i] } else { 0.0 }),
        SpringEnds::TwoNodes => Mat::from_fn(12, 12, |i, j| {
            if i % 6 != j % 6 {
                0.0
            } else if i == j {
                d[i % 6]
            } else {
                -d[i % 6]
            }
        }),
    }
}

fn zeros_like(a: &Mat<f64>) -> Mat<f64> {
    Mat::zeros(a.nrows(), a.ncols())
}

/// Stiffness (and zero mass) of a six-DOF spring in the basic system, 12 × 12 or 6 × 6 to ground.
pub fn spring6(k: &SpringStiffness, ends: SpringEnds) -> Result<ElementMatrices, ElementError> {
    check_stiffness(k)?;
    let k = spring_pattern(k, ends);
    let m = zeros_like(&k);
    Ok(ElementMatrices { k, m })
}

/// `∂K/∂k_c` of [`spring6`] for the stiffness in `direction` (`∂M = 0`).
pub fn spring6_derivative(
    k: &SpringStiffness,
    ends: SpringEnds,
    direction: Component,
) -> Result<ElementDerivative, ElementError> {
    check_stiffness(k)?;
    let mut unit = [0.0; 6];
    unit[direction as usize] = 1.0;
    let dk = spring_pattern(&unit, ends);
    let dm = zeros_like(&dk);
    Ok(ElementDerivative { dk, dm })
}

/// Stiffness (and zero mass) of a scalar spring between two DOFs (2 × 2) or to ground (1 × 1).
pub fn scalar_spring(k: f64, ends: SpringEnds) -> Result<ElementMatrices, ElementError> {
    positive("k", k, true)?;
    let kk = scalar_pattern(k, ends);
    let m = zeros_like(&kk);
    Ok(ElementMatrices { k: kk, m })
}

/// `∂K/∂k` of [`scalar_spring`].
pub fn scalar_spring_derivative(ends: SpringEnds) -> ElementDerivative {
    let dk = scalar_pattern(1.0, ends);
    let dm = zeros_like(&dk);
    ElementDerivative { dk, dm }
}

fn scalar_pattern(k: f64, ends: SpringEnds) -> Mat<f64> {
    match ends {
        SpringEnds::Ground => Mat::from_fn(1, 1, |_, _| k),
        SpringEnds::TwoNodes => Mat::from_fn(2, 2, |i, j| if i == j { k } else { -k }),
    }
}

/// A concentrated mass with rotary inertia and an offset (CONM2-like, basic system).
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct LumpedMass {
    /// Mass `m`, kg.
    pub mass: f64,
    /// Inertia tensor about the centre of gravity `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`, kg·m²; products are `−∫ x y dm` etc.
    pub inertia: [f64; 6],
    /// Offset `e` from the node to the centre of gravity, m.
    pub offset: [f64; 3],
}

/// A parameter of a [`LumpedMass`].
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum MassParameter {
    /// The mass `m`.
    Mass,
    /// `Ixx`.
    Ixx,
    /// `Iyy`.
    Iyy,
    /// `Izz`.
    Izz,
    /// Tensor product `Ixy` (= −Nastran `I21`).
    Ixy,
    /// Tensor product `Ixz` (= −Nastran `I31`).
    Ixz,
    /// Tensor product `Iyz` (= −Nastran `I32`).
    Iyz,
}

impl LumpedMass {
    /// A point mass at the node with no rotary inertia.
    pub fn point(mass: f64) -> Self {
        LumpedMass {
            mass,
            inertia: [0.0; 6],
            offset: [0.0; 3],
        }
    }

    /// From Nastran CONM2 fields (CID 0): `M`, `X1..X3`, `I11, I21, I22, I31, I32, I33`.
    pub fn from_nastran(mass: f64, offset: [f64; 3], i: [f64; 6]) -> Self {
        let [i11, i21, i22, i31, i32, i33] = i;
        LumpedMass {
            mass,
            inertia: [i11, i22, i33, -i21, -i31, -i32],
            offset,
        }
    }

    /// The inertia tensor `J` about the centre of gravity as a symmetric 3 × 3 array.
    pub fn inertia_tensor(&self) -> [[f64; 3]; 3] {
        let [xx, yy, zz, xy, xz, yz] = self.inertia;
        [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]
    }

    /// Current value of a parameter.
    pub fn parameter(&self, p: MassParameter) -> f64 {
        match p {
            MassParameter::Mass => self.mass,
            _ => self.inertia[p as usize - 1],
        }
    }

    /// A copy with one parameter set to `value` (not validated until used).
    pub fn with_parameter(&self, p: MassParameter, value: f64) -> Self {
        let mut copy = *self;
        match p {
            MassParameter::Mass => copy.mass = value,
            _ => copy.inertia[p as usize - 1] = value,
        }
        copy
    }

    /// Checks the mass is non-negative and the inertia tensor symmetric positive semi-definite.
    pub fn validate(&self) -> Result<(), ElementError> {
        positive("mass", self.mass, true)?;
        const NAMES: [&str; 6] = ["ixx", "iyy", "izz", "ixy", "ixz", "iyz"];
        for (name, value) in NAMES.iter().zip(&self.inertia) {
            if !value.is_finite() {
                return Err(ElementError::BadValue {
                    field: name,
                    value: *value,
                    hint: "must be finite",
                });
            }
        }
        for value in &self.offset {
            if !value.is_finite() {
                return Err(ElementError::BadValue {
                    field: "offset",
                    value: *value,
                    hint: "the offset must be finite",
                });
            }
        }
        // Positive semi-definite ⇔ every principal minor ≥ 0 (round-off allowed).
        let [xx, yy, zz, xy, xz, yz] = self.inertia;
        let scale = xx.abs().max(yy.abs()).max(zz.abs());
        let tol = 1e-12 * scale;
        for (name, d) in [("ixx", xx), ("iyy", yy), ("izz", zz)] {
            if d < -tol {
                return Err(ElementError::BadValue {
                    field: name,
                    value: d,
                    hint: "a moment of inertia must be >= 0",
                });
            }
        }
        let minors = [
            ("ixy", xy, xx * yy - xy * xy),
            ("ixz", xz, xx * zz - xz * xz),
            ("iyz", yz, yy * zz - yz * yz),
        ];
        for (name, value, minor) in minors {
            if minor < -tol * scale {
                return Err(ElementError::BadValue {
                    field: name,
                    value,
                    hint: "the inertia tensor must be positive semi-definite (|Ixy| <= sqrt(Ixx Iyy) etc.)",
                });
            }
        }
        let det = xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz);
        if det < -tol * scale * scale {
            return Err(ElementError::BadValue {
                field: "inertia",
                value: det,
                hint: "the inertia tensor must be positive semi-definite (its determinant is negative)",
            });
        }
        Ok(())
    }
}

/// `m`-part and `J`-part of the 6 × 6 rigid-body mass pattern.
fn mass_pattern(m: f64, j: &[[f64; 3]; 3], e: [f64; 3]) -> Mat<f64> {
    // E = [e]ₓ with E a = e × a.
    let ex = [[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]];
    let e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    Mat::from_fn(6, 6, |r, c| match (r < 3, c < 3) {
        (true, true) => {
            if r == c {
                m
            } else {
                0.0
            }
        }
        (true, false) => -m * ex[r][c - 3],
        (false, true) => m * ex[r - 3][c],
        (false, false) => {
            let (p, q) = (r - 3, c - 3);
            let delta = if p == q { 1.0 } else { 0.0 };
            j[p][q] + m * (e2 * delta - e[p] * e[q])
        }
    })
}

/// Mass (6 × 6, basic system, zero stiffness) of a concentrated mass at one node.
pub fn conm2(mass: &LumpedMass) -> Result<ElementMatrices, ElementError> {
    mass.validate()?;
    let m = mass_pattern(mass.mass, &mass.inertia_tensor(), mass.offset);
    let k = zeros_like(&m);
    Ok(ElementMatrices { k, m })
}

/// `∂M/∂φ` of [`conm2`] for one parameter (`∂K = 0`).
pub fn conm2_derivative(
    mass: &LumpedMass,
    p: MassParameter,
) -> Result<ElementDerivative, ElementError> {
    mass.validate()?;
    let dm = match p {
        MassParameter::Mass => mass_pattern(1.0, &[[0.0; 3]; 3], mass.offset),
        _ => {
            let unit = LumpedMass {
                mass: 0.0,
                inertia: [0.0; 6],
                offset: [0.0; 3],
            }
            .with_parameter(p, 1.0);
            mass_pattern(0.0, &unit.inertia_tensor(), [0.0; 3])
        }
    };
    let dk = zeros_like(&dm);
    Ok(ElementDerivative { dk, dm })
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::{MatRef, Side};

    fn max_abs(a: MatRef<'_, f64>) -> f64 {
        let mut m = 0.0f64;
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                m = m.max(a[(i, j)].abs());
            }
        }
        m
    }

    fn quad(a: &Mat<f64>, x: &[f64]) -> f64 {
        let mut s = 0.0;
        for i in 0..x.len() {
            for j in 0..x.len() {
                s += x[i] * a[(i, j)] * x[j];
            }
        }
        s
    }

    fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    const K6: SpringStiffness = [1e5, 3e6, 1e1, 1e3, 2e2, 1.4e4];

    #[test]
    fn six_dof_spring_patterns() {
        let two = spring6(&K6, SpringEnds::TwoNodes).unwrap();
        assert_eq!((two.k.nrows(), two.m.nrows()), (12, 12));
        assert_eq!(max_abs(two.m.as_ref()), 0.0);
        for (c, kc) in K6.iter().enumerate() {
            assert_eq!(two.k[(c, c)], *kc);
            assert_eq!(two.k[(c + 6, c + 6)], *kc);
            assert_eq!(two.k[(c, c + 6)], -kc);
            assert_eq!(two.k[(c + 6, c)], -kc);
        }
        // Symmetric, and a common motion of both (coincident) nodes stores no energy.
        for i in 0..12 {
            for j in 0..12 {
                assert_eq!(two.k[(i, j)], two.k[(j, i)]);
            }
            let common: f64 = (0..12)
                .map(|j| two.k[(i, j)] * [0.3, -1.0, 2.0, 0.1, 0.5, -0.7][j % 6])
                .sum();
            assert_eq!(common, 0.0);
        }
        let ground = spring6(&K6, SpringEnds::Ground).unwrap();
        assert_eq!(ground.k.nrows(), 6);
        for (i, ki) in K6.iter().enumerate() {
            for j in 0..6 {
                assert_eq!(ground.k[(i, j)], if i == j { *ki } else { 0.0 });
            }
        }
    }

    /// K is linear in each stiffness, so the central difference equals the derivative to round-off
    /// (tolerance 1e-9 relative to the derivative's unit entries).
    #[test]
    fn spring_derivatives_match_central_differences() {
        for ends in [SpringEnds::TwoNodes, SpringEnds::Ground] {
            for comp in Component::ALL {
                let c = comp as usize;
                let h = 1e-6 * K6[c];
                let (mut plus, mut minus) = (K6, K6);
                plus[c] += h;
                minus[c] -= h;
                let fd = (&spring6(&plus, ends).unwrap().k - &spring6(&minus, ends).unwrap().k)
                    * faer::Scale(1.0 / (2.0 * h));
                let d = spring6_derivative(&K6, ends, comp).unwrap();
                assert!(max_abs((&fd - &d.dk).as_ref()) < 1e-9, "{comp:?} {ends:?}");
                assert_eq!(max_abs(d.dm.as_ref()), 0.0);
                assert_eq!(max_abs(d.dk.as_ref()), 1.0);
            }
            let s = scalar_spring(250.0, ends).unwrap();
            let d = scalar_spring_derivative(ends);
            let err = max_abs((&d.dk * faer::Scale(250.0) - &s.k).as_ref());
            assert_eq!(err, 0.0);
        }
        let s = scalar_spring(7.0, SpringEnds::TwoNodes).unwrap();
        assert_eq!(
            (s.k[(0, 0)], s.k[(0, 1)], s.k[(1, 0)], s.k[(1, 1)]),
            (7.0, -7.0, -7.0, 7.0)
        );
        assert_eq!(
            scalar_spring(7.0, SpringEnds::Ground).unwrap().k[(0, 0)],
            7.0
        );
    }

    fn sample_mass() -> LumpedMass {
        LumpedMass {
            mass: 0.03,
            inertia: [2e-5, 3e-5, 4e-5, -1e-6, 2e-6, -5e-7],
            offset: [0.01, -0.02, 0.015],
        }
    }

    /// Rigid motion `u̇ = v`, `ω` at the node: the kinetic energy `qᵀ M q` equals
    /// `m |v + ω × e|² + ωᵀ J ω` (the centre of gravity moves with `v + ω × e`); for a pure
    /// rotation `m |e × ω|² + ωᵀ J ω`; for a translation `m |v|²`. Tolerance 1e-14 relative.
    #[test]
    fn offset_mass_has_the_rigid_body_kinetic_energy() {
        let lm = sample_mass();
        let m = conm2(&lm).unwrap().m;
        let j = lm.inertia_tensor();
        let e = lm.offset;
        for (v, w) in [
            ([1.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
            ([0.0, -2.0, 0.5], [0.0, 0.0, 0.0]),
            ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            ([0.0, 0.0, 0.0], [0.3, -0.8, 0.5]),
            ([0.2, 0.1, -0.4], [-1.1, 0.6, 0.9]),
        ] {
            let q = [v[0], v[1], v[2], w[0], w[1], w[2]];
            let got = quad(&m, &q);
            let we = cross(w, e);
            let vc = [v[0] + we[0], v[1] + we[1], v[2] + we[2]];
            let mut jw = 0.0;
            for a in 0..3 {
                for b in 0..3 {
                    jw += w[a] * j[a][b] * w[b];
                }
            }
            let expected = lm.mass * (vc[0] * vc[0] + vc[1] * vc[1] + vc[2] * vc[2]) + jw;
            eprintln!(
                "conm2 kinetic energy v {v:?} w {w:?}: {:e}",
                (got - expected).abs() / expected
            );
            assert!(
                (got - expected).abs() <= 1e-14 * expected,
                "v {v:?} w {w:?}: {got} vs {expected}"
            );
        }
        // Total mass: a unit translation in each direction carries m.
        for d in 0..3 {
            let mut q = [0.0; 6];
            q[d] = 1.0;
            assert!((quad(&m, &q) - lm.mass).abs() < 1e-17);
        }
        // Symmetric and positive semi-definite.
        for a in 0..6 {
            for b in 0..6 {
                assert_eq!(m[(a, b)], m[(b, a)]);
            }
        }
        let ev = m.self_adjoint_eigenvalues(Side::Lower).unwrap();
        assert!(ev[0] > 0.0, "{ev:?}");
        assert_eq!(max_abs(conm2(&lm).unwrap().k.as_ref()), 0.0);
    }

    /// Nastran's products of inertia enter the tensor negated; with no offset the rotational
    /// block is the tensor itself.
    #[test]
    fn nastran_fields_map_to_the_tensor() {
        let lm = LumpedMass::from_nastran(2.0, [0.0; 3], [1.0, 0.1, 2.0, 0.2, 0.3, 3.0]);
        let m = conm2(&lm).unwrap().m;
        let expected = [[1.0, -0.1, -0.2], [-0.1, 2.0, -0.3], [-0.2, -0.3, 3.0]];
        for a in 0..3 {
            for b in 0..3 {
                assert_eq!(m[(3 + a, 3 + b)], expected[a][b]);
                assert_eq!(m[(a, 3 + b)], 0.0);
            }
            assert_eq!(m[(a, a)], 2.0);
        }
        // With an offset the coupling follows Nastran's CONM2: M[ux, ry] = m X3, M[ux, rz] = −m X2.
        let lm = LumpedMass::from_nastran(2.0, [0.1, 0.2, 0.3], [0.0; 6]);
        let m = conm2(&lm).unwrap().m;
        assert!((m[(0, 4)] - 0.6).abs() < 1e-15 && (m[(0, 5)] + 0.4).abs() < 1e-15);
        assert!((m[(1, 3)] + 0.6).abs() < 1e-15 && (m[(1, 5)] - 0.2).abs() < 1e-15);
    }

    /// M is linear in m and in every inertia component: central differences equal the
    /// derivative to round-off (tolerance 1e-9 relative to the derivative).
    #[test]
    fn mass_derivatives_match_central_differences() {
        let lm = sample_mass();
        for p in [
            MassParameter::Mass,
            MassParameter::Ixx,
            MassParameter::Iyy,
            MassParameter::Izz,
            MassParameter::Ixy,
            MassParameter::Ixz,
            MassParameter::Iyz,
        ] {
            let x = lm.parameter(p);
            let h = 1e-6 * x.abs();
            let plus = conm2(&lm.with_parameter(p, x + h)).unwrap().m;
            let minus = conm2(&lm.with_parameter(p, x - h)).unwrap().m;
            let fd = (&plus - &minus) * faer::Scale(1.0 / (2.0 * h));
            let d = conm2_derivative(&lm, p).unwrap();
            let scale = max_abs(d.dm.as_ref());
            assert!(scale > 0.0);
            let err = max_abs((&fd - &d.dm).as_ref()) / scale;
            eprintln!("conm2 derivative {p:?} vs central difference: {err:e}");
            assert!(err < 1e-9, "{p:?}: {err:e}");
            assert_eq!(max_abs(d.dk.as_ref()), 0.0);
        }
    }

    #[test]
    fn bad_values_are_rejected() {
        let mut k = K6;
        k[4] = -1.0;
        assert!(matches!(
            spring6(&k, SpringEnds::Ground),
            Err(ElementError::BadValue { field: "kry", .. })
        ));
        k[4] = f64::NAN;
        assert!(spring6_derivative(&k, SpringEnds::TwoNodes, Component::Rx).is_err());
        assert!(scalar_spring(f64::INFINITY, SpringEnds::Ground).is_err());
        let mut lm = sample_mass();
        lm.mass = -1.0;
        assert!(conm2(&lm).is_err());
        lm = sample_mass();
        lm.inertia[3] = 1.0; // |Ixy| > sqrt(Ixx Iyy)
        assert!(matches!(
            conm2(&lm),
            Err(ElementError::BadValue { field: "ixy", .. })
        ));
        lm = sample_mass();
        lm.offset[1] = f64::NAN;
        assert!(conm2_derivative(&lm, MassParameter::Mass).is_err());
        assert!(conm2(&LumpedMass::point(1.0)).is_ok());
    }
}
