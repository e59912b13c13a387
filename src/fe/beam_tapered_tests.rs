//! Checks of the tapered beam and rod against the uniform element, closed forms, a finely
//! subdivided uniform model and central differences.

use super::*;
use crate::core::{Component, DofId};
use crate::eigen::{ModeSelection, dense_generalized};
use crate::fe::beam::{BeamData, Section, beam2_with_ends};
use crate::fe::rod::RodParameter;
use crate::model::BeamStation;
use faer::linalg::solvers::Solve;

const E: f64 = 2.1e11;
const NU: f64 = 0.3;
const RHO: f64 = 7850.0;
const X1: [f64; 3] = [0.2, -0.1, 0.3];
const X2: [f64; 3] = [1.4, 0.5, -0.2];
const V: [f64; 3] = [0.3, 1.0, 0.2];

/// A model property with stations (`values` per station, NSM), library type `library`.
fn property(library: Option<&str>, stations: &[(f64, &[f64], f64)], shear: f64) -> BeamProperty {
    let a = stations[0].1;
    let section = match library {
        Some("BAR") => BeamSection::Rectangle {
            width: a[0],
            height: a[1],
        },
        _ => BeamSection::General {
            area: a[0],
            iy: a[2],
            iz: a[1],
            j: a[3],
            shear_y: shear,
            shear_z: 0.9 * shear,
        },
    };
    BeamProperty {
        material: 1,
        section,
        nsm: stations[0].2,
        taper: Some(BeamTaper {
            library: library.map(str::to_string),
            stations: stations
                .iter()
                .map(|(x, v, nsm)| BeamStation {
                    x: *x,
                    values: v.to_vec(),
                    nsm: *nsm,
                })
                .collect(),
        }),
        centres: None,
    }
}

fn beam(t: &dyn Taper) -> TaperedBeam<'_> {
    TaperedBeam {
        e: E,
        nu: NU,
        rho: RHO,
        taper: t,
    }
}

/// `max |a − b| / max |b|`.
fn rel(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    let mut d = 0.0f64;
    let mut s = 0.0f64;
    for i in 0..a.nrows() {
        for j in 0..a.ncols() {
            d = d.max((a[(i, j)] - b[(i, j)]).abs());
            s = s.max(b[(i, j)].abs());
        }
    }
    d / s
}

fn pinned() -> EndConditions {
    EndConditions {
        offset_a: [0.01, 0.02, -0.01],
        offset_b: [0.0, -0.03, 0.01],
        released_a: [false; 6],
        released_b: [false, false, false, false, true, false],
    }
}

/// Equal stations give the uniform element of `super::beam` to round-off (1e-12 of the largest
/// entry: the flexibility route inverts a 2 × 2 and sums 16 Gauss terms, the uniform one is
/// closed form), for a PBEAM-like general section with shear flexibility and for a BAR,
/// both mass kinds, plain and with offsets and a pin. A wrong shape function, sign or lumping
/// share breaks it at O(1).
#[test]
fn equal_stations_are_the_uniform_element() {
    let v = [3.0e-3, 2.0e-6, 4.5e-6, 1.5e-6];
    let general = property(None, &[(0.0, &v, 1.2), (0.4, &v, 1.2), (1.0, &v, 1.2)], 0.8);
    let bar = property(
        Some("BAR"),
        &[(0.0, &[0.05, 0.08], 0.7), (1.0, &[0.05, 0.08], 0.7)],
        0.0,
    );
    let uniform = [
        Section::General {
            area: v[0],
            iy: v[2],
            iz: v[1],
            j: v[3],
            shear_y: Some(0.8),
            shear_z: Some(0.72),
        },
        Section::Rectangle {
            width: 0.05,
            height: 0.08,
        },
    ];
    for ((p, section), nsm) in [&general, &bar].into_iter().zip(uniform).zip([1.2, 0.7]) {
        let t = PropertyTaper::new(p, NU).unwrap();
        let d = BeamData {
            e: E,
            nu: NU,
            rho: RHO,
            nsm,
            section,
        };
        for kind in [MassKind::Consistent, MassKind::Lumped] {
            for ends in [EndConditions::default(), pinned()] {
                let a = tapered_beam2(X1, X2, V, &beam(&t), kind, &ends).unwrap();
                let b = beam2_with_ends(X1, X2, V, &d, kind, &ends).unwrap();
                assert!(rel(&a.k, &b.k) < 1e-12, "K {}", rel(&a.k, &b.k));
                assert!(rel(&a.m, &b.m) < 1e-12, "M {kind:?} {}", rel(&a.m, &b.m));
            }
        }
    }
}

/// A rod whose area is linear from `A1` to `A2` has `k = E (A2 − A1) / (L ln(A2/A1))` exactly;
/// the bisected Gauss rule reaches it to 1e-13 even for A2/A1 = 200 (a pole of `1/A` close to
/// end A), where a single 8-point rule is off by about 1 %.
#[test]
fn linear_area_rod_has_the_logarithmic_stiffness() {
    let l = 2.0;
    for (a1, a2) in [(1e-4, 3e-4), (2e-3, 1e-5), (1e-5, 2e-3)] {
        let at = |xi: f64| (a1 + xi * (a2 - a1), 0.0, 0.0);
        let r = TaperedRod {
            e: E,
            nu: NU,
            rho: RHO,
            at: &at,
        };
        let m = tapered_rod2([0.0; 3], [l, 0.0, 0.0], &r, MassKind::Lumped).unwrap();
        let exact = E * (a2 - a1) / (l * (a2 / a1).ln());
        assert!(((m.k[(0, 0)] - exact) / exact).abs() < 1e-13, "{a1} {a2}");
        assert_eq!(m.k[(3, 3)], 0.0);
        // Lumped: total ρ(A1+A2)L/2, centre of mass at L(A1 + 2A2)/(3(A1 + A2)).
        let total = RHO * 0.5 * (a1 + a2) * l;
        let centre = l * (a1 + 2.0 * a2) / (3.0 * (a1 + a2));
        let (ma, mb) = (m.m[(0, 0)], m.m[(6, 6)]);
        assert!(((ma + mb) - total).abs() < 1e-13 * total);
        assert!((mb * l / (ma + mb) - centre).abs() < 1e-13 * l);
    }
}

/// A shear-rigid cantilever with `I` linear from `I1` at the clamp to `I2` at the tip deflects
/// under a tip load `P` by `δ = P/(E b³) [I2² ln(I2/I1) − 2 I2 (I2 − I1) + (I2² − I1²)/2]`,
/// `b = (I2 − I1)/L` (`∫ (L−s)²/EI(s) ds`), and turns by `P/(E b²) [I2 ln(I2/I1) − (I2 − I1)]`.
/// One element gives both to 1e-10 (the closed form loses a few digits to cancellation).
#[test]
fn linear_inertia_cantilever_has_the_closed_form_deflection() {
    let l = 1.5;
    let (i1, i2) = (6e-6, 2e-6);
    let p = property(
        None,
        &[
            (0.0, &[2e-3, i1, 3.0 * i1, 1e-6], 0.0),
            (1.0, &[2e-3, i2, 3.0 * i2, 1e-6], 0.0),
        ],
        0.0,
    );
    let t = PropertyTaper::new(&p, NU).unwrap();
    let m = tapered_beam2(
        [0.0; 3],
        [l, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        &beam(&t),
        MassKind::Consistent,
        &EndConditions::default(),
    )
    .unwrap();
    // Free DOFs of node 2 in the x–y plane: uy (7), rz (11).
    let kbb = Mat::from_fn(2, 2, |i, j| m.k[([7, 11][i], [7, 11][j])]);
    let f = Mat::from_fn(2, 1, |i, _| if i == 0 { 1.0 } else { 0.0 });
    let u = kbb.partial_piv_lu().solve(&f);
    let b = (i2 - i1) / l;
    let delta = (i2 * i2 * (i2 / i1).ln() - 2.0 * i2 * (i2 - i1) + 0.5 * (i2 * i2 - i1 * i1))
        / (E * b * b * b);
    let turn = (i2 * (i2 / i1).ln() - (i2 - i1)) / (E * b * b);
    assert!(
        ((u[(0, 0)] - delta) / delta).abs() < 1e-10,
        "{} {delta}",
        u[(0, 0)]
    );
    assert!(
        ((u[(1, 0)] - turn) / turn).abs() < 1e-10,
        "{} {turn}",
        u[(1, 0)]
    );
}

/// Dense `K`, `M` of a chain of beams along x (nodes at `xs`), clamped at x = 0.
fn chain(
    xs: &[f64],
    element: &dyn Fn(usize, [f64; 3], [f64; 3]) -> ElementMatrices,
) -> (Mat<f64>, Mat<f64>) {
    let n = 6 * (xs.len() - 1);
    let mut k = Mat::<f64>::zeros(n, n);
    let mut m = Mat::<f64>::zeros(n, n);
    for e in 0..xs.len() - 1 {
        let em = element(e, [xs[e], 0.0, 0.0], [xs[e + 1], 0.0, 0.0]);
        for i in 0..12 {
            for j in 0..12 {
                // Global free DOF of local i: node e (i < 6) or e + 1, minus the clamped node 0.
                let gi = (6 * e + i).checked_sub(6);
                let gj = (6 * e + j).checked_sub(6);
                if let (Some(gi), Some(gj)) = (gi, gj) {
                    k[(gi, gj)] += em.k[(i, j)];
                    m[(gi, gj)] += em.m[(i, j)];
                }
            }
        }
    }
    (k, m)
}

/// Tip flexibilities (axial, two bending planes, torsion) of a clamped chain.
fn tip_flexibility(k: &Mat<f64>) -> [f64; 4] {
    let n = k.nrows();
    let lu = k.partial_piv_lu();
    [0, 1, 2, 3].map(|c| {
        let f = Mat::from_fn(n, 1, |i, _| if i == n - 6 + c { 1.0 } else { 0.0 });
        lu.solve(&f)[(n - 6 + c, 0)]
    })
}

fn frequencies(k: &Mat<f64>, m: &Mat<f64>, count: usize) -> Vec<f64> {
    let dofs: Vec<DofId> = (0..k.nrows())
        .map(|i| DofId::new(2 + i as u64 / 6, Component::ALL[i % 6]))
        .collect();
    let modes =
        dense_generalized(k.as_ref(), m.as_ref(), &dofs, ModeSelection::Count(count)).unwrap();
    modes.eigenvalues.iter().map(|l| l.sqrt()).collect()
}

/// A BAR cantilever (PBEAML) whose height falls linearly from 0.12 to 0.04 and width from 0.06
/// to 0.05, Timoshenko shear (L = 1.2, so shear matters at the root), against the same beam cut
/// into N uniform elements with the dimensions at their midpoints:
/// - statics: the one tapered element is exact, the stepped model's error falls as N⁻² (the
///   midpoint rule): below 5e-5 at N = 256 and at least 10 times smaller than at N = 64;
/// - the first six frequencies of 64 tapered elements against 256 stepped ones agree to 2e-4.
///   The tapered mesh's error is dominated by its linear axial and twist interpolation,
///   `(βh)²/12` ≈ 5e-5 for the first axial mode at 64 elements (at 16 it was 5e-4 on the
///   fifth and sixth modes, as that estimate says); the stepped mesh's N⁻² error is ~1e-5.
///   A mass or stiffness integrated with end A's section (or the wrong shape functions)
///   misses by 10–50 %.
#[test]
fn one_tapered_element_is_the_limit_of_fine_uniform_ones() {
    let l = 1.2;
    let dims = |xi: f64| [0.06 - 0.01 * xi, 0.12 - 0.08 * xi];
    let tapered = |a: f64, b: f64| {
        let (da, db) = (dims(a), dims(b));
        property(Some("BAR"), &[(0.0, &da, 0.5), (1.0, &db, 0.5)], 0.0)
    };
    let tapered_chain = |n: usize| {
        let xs: Vec<f64> = (0..=n).map(|i| l * i as f64 / n as f64).collect();
        let props: Vec<BeamProperty> = (0..n)
            .map(|e| tapered(e as f64 / n as f64, (e + 1) as f64 / n as f64))
            .collect();
        chain(&xs, &|e, a, b| {
            let t = PropertyTaper::new(&props[e], NU).unwrap();
            tapered_beam2(
                a,
                b,
                [0.0, 1.0, 0.0],
                &beam(&t),
                MassKind::Consistent,
                &EndConditions::default(),
            )
            .unwrap()
        })
    };
    let stepped_chain = |n: usize| {
        let xs: Vec<f64> = (0..=n).map(|i| l * i as f64 / n as f64).collect();
        chain(&xs, &|e, a, b| {
            let d = dims((e as f64 + 0.5) / n as f64);
            let data = BeamData {
                e: E,
                nu: NU,
                rho: RHO,
                nsm: 0.5,
                section: Section::Rectangle {
                    width: d[0],
                    height: d[1],
                },
            };
            beam2_with_ends(
                a,
                b,
                [0.0, 1.0, 0.0],
                &data,
                MassKind::Consistent,
                &EndConditions::default(),
            )
            .unwrap()
        })
    };
    let exact = tip_flexibility(&tapered_chain(1).0);
    let err = |n: usize| {
        let f = tip_flexibility(&stepped_chain(n).0);
        (0..4)
            .map(|c| ((f[c] - exact[c]) / exact[c]).abs())
            .fold(0.0, f64::max)
    };
    let (e64, e256) = (err(64), err(256));
    assert!(e256 < 5e-5, "stepped N = 256 off by {e256}");
    assert!(e64 > 10.0 * e256, "no N^-2 convergence: {e64} then {e256}");
    // Four tapered elements already give the same statics (each is exact).
    let four = tip_flexibility(&tapered_chain(4).0);
    for c in 0..4 {
        assert!(((four[c] - exact[c]) / exact[c]).abs() < 1e-11);
    }
    let (k, m) = tapered_chain(64);
    let (ks, ms) = stepped_chain(256);
    let (a, b) = (frequencies(&k, &m, 6), frequencies(&ks, &ms, 6));
    for (x, y) in a.iter().zip(&b) {
        assert!(((x - y) / y).abs() < 2e-4, "{a:?} against {b:?}");
    }
}

/// Central differences of the matrices by `h`: `(A(φ + h) − A(φ − h)) / 2h`.
pub(crate) fn central(f: &dyn Fn(f64) -> ElementMatrices, h: f64) -> (Mat<f64>, Mat<f64>) {
    let (p, m) = (f(h), f(-h));
    let s = 1.0 / (2.0 * h);
    (
        Mat::from_fn(12, 12, |i, j| s * (p.k[(i, j)] - m.k[(i, j)])),
        Mat::from_fn(12, 12, |i, j| s * (p.m[(i, j)] - m.m[(i, j)])),
    )
}

/// The exact derivatives by E, ρ, and a tapered BAR's width and height (scaled at every
/// station) match central differences with steps of 1e-5 relative: truncation O(h²) ≈ 1e-10
/// and round-off ≈ 1e-16/1e-5, so 1e-7 of the largest entry (a derivative that forgets the
/// chain factor d(ξ)/d_A, or the Φ dependence, is off by 1e-2 or more); with offsets, a pin
/// and both mass kinds.
#[test]
fn derivatives_match_central_differences() {
    let stations = |w: f64, h: f64| {
        property(
            Some("BAR"),
            &[
                (0.0, &[w, h], 0.4),
                (0.3, &[0.9 * w, 0.7 * h], 0.2),
                (1.0, &[0.6 * w, 0.5 * h], 0.1),
            ],
            0.0,
        )
    };
    let (w0, h0) = (0.05, 0.09);
    for kind in [MassKind::Consistent, MassKind::Lumped] {
        let ends = pinned();
        let cases: [(BeamParameter, f64); 4] = [
            (BeamParameter::YoungsModulus, E),
            (BeamParameter::Density, RHO),
            (BeamParameter::Width, w0),
            (BeamParameter::Height, h0),
        ];
        for (p, value) in cases {
            let at = |dv: f64| {
                let (mut e, mut rho, mut w, mut h) = (E, RHO, w0, h0);
                match p {
                    BeamParameter::YoungsModulus => e += dv,
                    BeamParameter::Density => rho += dv,
                    BeamParameter::Width => w += dv,
                    _ => h += dv,
                }
                let prop = stations(w, h);
                let t = PropertyTaper::new(&prop, NU).unwrap();
                let b = TaperedBeam {
                    e,
                    nu: NU,
                    rho,
                    taper: &t,
                };
                tapered_beam2(X1, X2, V, &b, kind, &ends).unwrap()
            };
            let (dk, dm) = central(&at, 1e-5 * value);
            let prop = stations(w0, h0);
            let t = PropertyTaper::new(&prop, NU).unwrap();
            let d = tapered_beam2_derivative(X1, X2, V, &beam(&t), kind, p, &ends).unwrap();
            if p != BeamParameter::Density {
                assert!(
                    rel(&d.dk, &dk) < 1e-7,
                    "{p:?} {kind:?} dK {}",
                    rel(&d.dk, &dk)
                );
            }
            if p != BeamParameter::YoungsModulus {
                assert!(
                    rel(&d.dm, &dm) < 1e-7,
                    "{p:?} {kind:?} dM {}",
                    rel(&d.dm, &dm)
                );
            }
        }
    }
    // A PBEAM taper has no dimensions: a width is refused, by name.
    let v = [3.0e-3, 2.0e-6, 4.5e-6, 1.5e-6];
    let w = [2.0e-3, 1.0e-6, 2.5e-6, 1.0e-6];
    let p = property(None, &[(0.0, &v, 0.0), (1.0, &w, 0.0)], 0.0);
    let t = PropertyTaper::new(&p, NU).unwrap();
    let e = tapered_beam2_derivative(
        X1,
        X2,
        V,
        &beam(&t),
        MassKind::Consistent,
        BeamParameter::Width,
        &EndConditions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("width") && e.contains("PBEAM"), "{e}");
}

/// The tapered rod's derivatives by E and ρ are exact (K linear in E, M in ρ): central
/// differences agree to 1e-9 (round-off only).
#[test]
fn rod_derivatives_match_central_differences() {
    let at = |xi: f64| (3e-4 - 2e-4 * xi, 2e-8 - 1e-8 * xi, 0.3);
    for kind in [MassKind::Consistent, MassKind::Lumped] {
        for (p, value) in [
            (RodParameter::YoungsModulus, E),
            (RodParameter::Density, RHO),
        ] {
            let f = |dv: f64| {
                let (e, rho) = match p {
                    RodParameter::YoungsModulus => (E + dv, RHO),
                    RodParameter::Density => (E, RHO + dv),
                };
                let r = TaperedRod {
                    e,
                    nu: NU,
                    rho,
                    at: &at,
                };
                tapered_rod2(X1, X2, &r, kind).unwrap()
            };
            let (dk, dm) = central(&f, 1e-4 * value);
            let r = TaperedRod {
                e: E,
                nu: NU,
                rho: RHO,
                at: &at,
            };
            let d = tapered_rod2_derivative(X1, X2, &r, kind, p).unwrap();
            match p {
                RodParameter::YoungsModulus => assert!(rel(&d.dk, &dk) < 1e-9),
                RodParameter::Density => assert!(rel(&d.dm, &dm) < 1e-9),
            }
        }
    }
}

/// Stations out of order, J vanishing at some stations only, and a non-positive area are
/// errors that say what is wrong.
#[test]
fn bad_stations_are_errors() {
    let v = [3.0e-3, 2.0e-6, 4.5e-6, 1.5e-6];
    let no_j = [3.0e-3, 2.0e-6, 4.5e-6, 0.0];
    let p = property(None, &[(0.0, &v, 0.0), (1.0, &no_j, 0.0)], 0.0);
    let t = PropertyTaper::new(&p, NU).unwrap();
    let e = tapered_beam2(
        X1,
        X2,
        V,
        &beam(&t),
        MassKind::Lumped,
        &EndConditions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("torsion constant"), "{e}");
    let p = property(None, &[(0.0, &v, 0.0), (0.7, &v, 0.0)], 0.0);
    let t = PropertyTaper::new(&p, NU).unwrap();
    let e = tapered_beam2(
        X1,
        X2,
        V,
        &beam(&t),
        MassKind::Lumped,
        &EndConditions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("from 0 (end A) to 1 (end B)"), "{e}");
}
