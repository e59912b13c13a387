//! Checks of the beam about its shear centre: cantilever statics against closed forms, the
//! coupled bending–torsion frequencies of Gere & Lin, rigid-body inertia, the zero-offset
//! identity and the exact derivatives.

use super::*;
use crate::core::{Component, DofId};
use crate::eigen::{ModeSelection, dense_generalized};
use crate::fe::beam::{
    BeamData, BeamParameter, EndConditions, Section, beam2_centred, beam2_derivative_centred,
    beam2_with_ends,
};
use crate::fe::beam_tapered::tests::central;
use crate::fe::beam_tapered::{
    PropertyTaper, TaperedBeam, tapered_beam2, tapered_beam2_centred,
    tapered_beam2_centred_derivative,
};
use crate::fe::element::ElementMatrices;
use crate::model::{BeamProperty, BeamSection, BeamStation, BeamTaper};
use faer::Mat;
use faer::linalg::solvers::Solve;

const E: f64 = 2.1e11;
const NU: f64 = 0.3;
const RHO: f64 = 7850.0;

/// A channel-like general section (m², m⁴).
fn general(shear: bool) -> Section {
    Section::General {
        area: 1.8e-3,
        iy: 2.2e-6,
        iz: 6.5e-6,
        j: 3.0e-8,
        shear_y: shear.then_some(0.45),
        shear_z: shear.then_some(0.5),
    }
}

fn data(section: Section, nsm: f64) -> BeamData {
    BeamData {
        e: E,
        nu: NU,
        rho: RHO,
        nsm,
        section,
    }
}

const CENTRES: SectionCentres = SectionCentres {
    neutral_axis: [0.021, -0.013],
    nsm_cg: [-0.03, 0.045],
    nsi: 0.012,
};

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

/// Dense `K`, `M` of `n` equal elements along x from 0 to `l` (all six DOFs per node, node-major).
fn chain(
    n: usize,
    l: f64,
    element: &dyn Fn([f64; 3], [f64; 3]) -> ElementMatrices,
) -> (Mat<f64>, Mat<f64>) {
    let size = 6 * (n + 1);
    let mut k = Mat::<f64>::zeros(size, size);
    let mut m = Mat::<f64>::zeros(size, size);
    for e in 0..n {
        let x = |i: usize| [l * i as f64 / n as f64, 0.0, 0.0];
        let em = element(x(e), x(e + 1));
        for i in 0..12 {
            for j in 0..12 {
                k[(6 * e + i, 6 * e + j)] += em.k[(i, j)];
                m[(6 * e + i, 6 * e + j)] += em.m[(i, j)];
            }
        }
    }
    (k, m)
}

/// The rows and columns `keep` of `a`.
fn restrict(a: &Mat<f64>, keep: &[usize]) -> Mat<f64> {
    Mat::from_fn(keep.len(), keep.len(), |i, j| a[(keep[i], keep[j])])
}

/// Tip displacements (six DOFs) of a cantilever of `n` elements, clamped at x = 0, under the
/// tip load `f` (six components at the grid).
fn cantilever_tip(n: usize, l: f64, centres: &SectionCentres, f: [f64; 6]) -> [f64; 6] {
    let d = data(general(false), 0.0);
    let (k, _) = chain(n, l, &|a, b| {
        beam2_centred(
            a,
            b,
            [0.0, 1.0, 0.0],
            &d,
            MassKind::Consistent,
            &EndConditions::default(),
            centres,
        )
        .unwrap()
    });
    let keep: Vec<usize> = (6..6 * (n + 1)).collect();
    let kr = restrict(&k, &keep);
    let size = keep.len();
    let rhs = Mat::from_fn(
        size,
        1,
        |i, _| if i >= size - 6 { f[i + 6 - size] } else { 0.0 },
    );
    let u = kr.partial_piv_lu().solve(&rhs);
    std::array::from_fn(|c| u[(size - 6 + c, 0)])
}

/// Statics of a cantilever (L = 2, 8 shear-rigid elements) whose centroid is at `n = (0.021,
/// −0.013)` from the grid line (the shear centre):
/// - an axial tip force `P` at the grid acts at `−n` from the centroid, the moments
///   `M_z = P n_y`, `M_y = −P n_z`, constant along the beam: the closed form tip
///   `u = PL (1/EA + n_z²/EI_y + n_y²/EI_z)`, `v = P n_y L²/(2EI_z)`, `w = P n_z L²/(2EI_y)`,
///   `θ_y = −P n_z L/EI_y`, `θ_z = P n_y L/EI_z`, no twist. The cubic element is exact under
///   constant moment, so the tolerance is round-off: 1e-9 of the largest component (the
///   stiffness spans `EA/L` to `EI/L³`, a condition number ~1e6). A sign error in `T_a`, or a
///   centroidal axial force, changes `v`, `w` or `u` at O(1);
/// - a transverse tip force at the grid (shear centre) twists nothing, and `v, w, θ` are those
///   of the beam without the offset (to 1e-12: the axial rows alone change, so the solution
///   for the other DOFs is the same up to the LU's round-off); the tip's axial motion is the
///   section rotation's lever, `u = n_y θ_z − n_z θ_y`. A full rigid offset in the stiffness
///   would twist the beam (by `n × F`) and fail at O(1).
#[test]
fn cantilever_statics_match_the_closed_forms() {
    let (l, n) = (2.0, 8);
    let [ny, nz] = CENTRES.neutral_axis;
    let centres = SectionCentres {
        neutral_axis: [ny, nz],
        ..SectionCentres::default()
    };
    let Section::General { area, iy, iz, .. } = general(false) else {
        unreachable!()
    };
    let p = 1.0e4;
    let u = cantilever_tip(n, l, &centres, [p, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let want = [
        p * l * (1.0 / (E * area) + nz * nz / (E * iy) + ny * ny / (E * iz)),
        p * ny * l * l / (2.0 * E * iz),
        p * nz * l * l / (2.0 * E * iy),
        0.0,
        -p * nz * l / (E * iy),
        p * ny * l / (E * iz),
    ];
    let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let worst = (0..6).fold(0.0f64, |m, c| m.max((u[c] - want[c]).abs())) / scale;
    eprintln!("axial load: largest error {worst:e} of the largest component");
    for c in 0..6 {
        assert!(
            (u[c] - want[c]).abs() <= 1e-9 * scale,
            "axial load, DOF {c}: {} against {}",
            u[c],
            want[c]
        );
    }
    for f in [[0.0, p, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, p, 0.0, 0.0, 0.0]] {
        let u = cantilever_tip(n, l, &centres, f);
        let u0 = cantilever_tip(n, l, &SectionCentres::default(), f);
        let scale = u0.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(u[3].abs() <= 1e-12 * scale, "twist {} under {f:?}", u[3]);
        for c in 1..6 {
            assert!(
                (u[c] - u0[c]).abs() <= 1e-12 * scale,
                "DOF {c} under {f:?}: {} against {} without the offset",
                u[c],
                u0[c]
            );
        }
        let diff = (1..6).fold(0.0f64, |m, c| m.max((u[c] - u0[c]).abs())) / scale;
        eprintln!(
            "transverse load {f:?}: twist {:e}, largest change against no offset {diff:e}",
            u[3].abs() / scale
        );
        let lever = ny * u[5] - nz * u[4];
        assert!(
            (u[0] - lever).abs() <= 1e-12 * scale,
            "axial {} against the lever {lever}",
            u[0]
        );
    }
}

/// Rigid motions of one element (tilted in space, both mass kinds) carry the exact inertia of
/// the offset sections: a translation `m̄L = (ρA + nsm)L`; a unit spin about the element axis
/// through the shear centre `L (ρ(I_p + A|n|²) + nsm |m|² + NSI)` (the polar inertia about `S`);
/// a unit spin about the element `y` axis through end A the translational part `m̄L³/3` plus
/// the axial lever `(ρA n_z² + nsm m_z²) L` and the rotary `ρI_y L` (consistent mass only: the
/// lumped mass carries rotary inertia through its HRZ share, not exactly). The transforms are
/// exact, so round-off: 1e-12. A wrong sign or a missing term misses by the offset's share
/// (> 1e-3 here).
#[test]
fn rigid_motions_carry_the_offset_inertia() {
    let (x1, x2, v) = ([0.2, -0.1, 0.3], [1.4, 0.5, -0.2], [0.3, 1.0, 0.2]);
    let nsm = 2.5;
    let d = data(general(true), nsm);
    let props = d.section.properties(NU).unwrap();
    let frame = crate::fe::beam::beam_frame(x1, x2, v).unwrap();
    let [ex, ey, _] = frame.axes;
    let l = frame.length;
    let (n, m) = (CENTRES.neutral_axis, CENTRES.nsm_cg);
    let n2 = n[0] * n[0] + n[1] * n[1];
    let m2 = m[0] * m[0] + m[1] * m[1];
    for kind in [MassKind::Consistent, MassKind::Lumped] {
        let mm = beam2_centred(x1, x2, v, &d, kind, &EndConditions::default(), &CENTRES)
            .unwrap()
            .m;
        let energy = |u: &[f64; 12]| {
            let mut s = 0.0;
            for i in 0..12 {
                for j in 0..12 {
                    s += u[i] * mm[(i, j)] * u[j];
                }
            }
            s
        };
        let mut t = [0.0; 12];
        for b in [0, 6] {
            t[b..b + 3].copy_from_slice(&ex);
        }
        let want = (RHO * props.area + nsm) * l;
        assert!(
            ((energy(&t) - want) / want).abs() < 1e-12,
            "{kind:?} translation"
        );
        let mut spin = [0.0; 12];
        for b in [0, 6] {
            spin[b + 3..b + 6].copy_from_slice(&ex);
        }
        let want = l * (RHO * (props.ip + props.area * n2) + nsm * m2 + CENTRES.nsi);
        let got = energy(&spin);
        eprintln!(
            "{kind:?}: translation {:e}, spin {:e}",
            (energy(&t) / ((RHO * props.area + nsm) * l) - 1.0).abs(),
            (got / want - 1.0).abs()
        );
        assert!(
            ((got - want) / want).abs() < 1e-12,
            "{kind:?} spin: {got} against {want}"
        );
        if kind == MassKind::Consistent {
            // Spin ω = e_y about end A: u = ω × (s e_x) = −s e_z at node B.
            let ez = frame.axes[2];
            let mut r = [0.0; 12];
            for b in [0, 6] {
                r[b + 3..b + 6].copy_from_slice(&ey);
            }
            for c in 0..3 {
                r[6 + c] = -l * ez[c];
            }
            let want = (RHO * props.area + nsm) * l.powi(3) / 3.0
                + (RHO * props.area * n[1] * n[1] + nsm * m[1] * m[1]) * l
                + RHO * props.iy * l;
            let got = energy(&r);
            assert!(
                ((got - want) / want).abs() < 1e-12,
                "pitch: {got} against {want}"
            );
        }
    }
}

/// Zero offsets are the plain element bit for bit (the uniform and the tapered beam, both mass
/// kinds, with offsets and a pin): the existing matrices do not move.
#[test]
fn zero_centres_are_the_plain_element() {
    let (x1, x2, v) = ([0.2, -0.1, 0.3], [1.4, 0.5, -0.2], [0.3, 1.0, 0.2]);
    let ends = EndConditions {
        offset_a: [0.01, 0.02, -0.01],
        offset_b: [0.0, -0.03, 0.01],
        released_a: [false; 6],
        released_b: [false, false, false, false, true, false],
    };
    let d = data(general(true), 1.5);
    let prop = tapered_property(None);
    let taper = PropertyTaper::new(&prop, NU).unwrap();
    let b = TaperedBeam {
        e: E,
        nu: NU,
        rho: RHO,
        taper: &taper,
    };
    let zero = SectionCentres::default();
    for kind in [MassKind::Consistent, MassKind::Lumped] {
        let a = beam2_centred(x1, x2, v, &d, kind, &ends, &zero).unwrap();
        let p = beam2_with_ends(x1, x2, v, &d, kind, &ends).unwrap();
        assert!(a.k == p.k && a.m == p.m);
        let a = tapered_beam2_centred(x1, x2, v, &b, kind, &ends, &zero).unwrap();
        let p = tapered_beam2(x1, x2, v, &b, kind, &ends).unwrap();
        assert!(a.k == p.k && a.m == p.m);
        // And any offset changes them (the check above can tell).
        let c = beam2_centred(x1, x2, v, &d, kind, &ends, &CENTRES).unwrap();
        assert!(rel(&c.k, &p.k) > 1e-6 || rel(&c.m, &p.m) > 1e-6);
    }
}

/// A tapered PBEAM-like property (A, I1, I2, J linear from end A to end B, NSM 1.2 → 0.6).
fn tapered_property(library: Option<&str>) -> BeamProperty {
    let a = [1.8e-3, 6.5e-6, 2.2e-6, 3.0e-8];
    let b = [1.2e-3, 4.0e-6, 1.5e-6, 2.0e-8];
    BeamProperty {
        material: 1,
        section: BeamSection::General {
            area: a[0],
            iy: a[2],
            iz: a[1],
            j: a[3],
            shear_y: 0.45,
            shear_z: 0.5,
        },
        nsm: 1.2,
        taper: Some(BeamTaper {
            library: library.map(str::to_string),
            stations: vec![
                BeamStation {
                    x: 0.0,
                    values: a.to_vec(),
                    nsm: 1.2,
                },
                BeamStation {
                    x: 1.0,
                    values: b.to_vec(),
                    nsm: 0.6,
                },
            ],
        }),
        centres: None,
    }
}

/// The exact `E` and `ρ` derivatives with all offsets, NSM and NSI (uniform and tapered, both
/// mass kinds, WA/WB offsets and a pin) match central differences with a step of 1e-5
/// relative: `K` is linear in `E` and `M` in `ρ`, so the differences are exact but for
/// round-off (~1e-16/1e-5 of the entries) and `Φ` is independent of `E` at fixed `ν`: 1e-8 of
/// the largest entry. A derivative that left the NSM in `∂M/∂ρ`, or skipped a transform,
/// misses by the NSM's or the offset's share (> 1e-3).
#[test]
fn derivatives_match_central_differences() {
    let (x1, x2, v) = ([0.2, -0.1, 0.3], [1.4, 0.5, -0.2], [0.3, 1.0, 0.2]);
    let ends = EndConditions {
        offset_a: [0.01, 0.02, -0.01],
        offset_b: [0.0, -0.03, 0.01],
        released_a: [false; 6],
        released_b: [false, false, false, false, true, false],
    };
    let prop = tapered_property(None);
    let taper = PropertyTaper::new(&prop, NU).unwrap();
    for kind in [MassKind::Consistent, MassKind::Lumped] {
        for (p, value) in [
            (BeamParameter::YoungsModulus, E),
            (BeamParameter::Density, RHO),
        ] {
            let material = |dv: f64| match p {
                BeamParameter::YoungsModulus => (E + dv, RHO),
                _ => (E, RHO + dv),
            };
            let uniform = |dv: f64| {
                let (e, rho) = material(dv);
                let d = BeamData {
                    e,
                    rho,
                    ..data(general(true), 1.5)
                };
                beam2_centred(x1, x2, v, &d, kind, &ends, &CENTRES).unwrap()
            };
            let tapered = |dv: f64| {
                let (e, rho) = material(dv);
                let b = TaperedBeam {
                    e,
                    nu: NU,
                    rho,
                    taper: &taper,
                };
                tapered_beam2_centred(x1, x2, v, &b, kind, &ends, &CENTRES).unwrap()
            };
            let exact_uniform = beam2_derivative_centred(
                x1,
                x2,
                v,
                &data(general(true), 1.5),
                kind,
                p,
                &ends,
                &CENTRES,
            )
            .unwrap();
            let b = TaperedBeam {
                e: E,
                nu: NU,
                rho: RHO,
                taper: &taper,
            };
            let exact_tapered =
                tapered_beam2_centred_derivative(x1, x2, v, &b, kind, p, &ends, &CENTRES).unwrap();
            for (name, f, exact) in [
                (
                    "uniform",
                    &uniform as &dyn Fn(f64) -> ElementMatrices,
                    exact_uniform,
                ),
                ("tapered", &tapered, exact_tapered),
            ] {
                let (dk, dm) = central(f, 1e-5 * value);
                let at = f(0.0);
                let (what, e) = if p == BeamParameter::YoungsModulus {
                    ("dK/dE", rel(&exact.dk, &dk))
                } else {
                    ("dM/drho", rel(&exact.dm, &dm))
                };
                eprintln!("{name} {kind:?} {what}: {e:e} of the largest entry");
                if p == BeamParameter::YoungsModulus {
                    let e = rel(&exact.dk, &dk);
                    assert!(e < 1e-8, "{name} {kind:?} dK/dE {e:e}");
                    let z = exact.dm.norm_max() * value / at.m.norm_max();
                    assert!(z < 1e-12, "{name} {kind:?} dM/dE {z:e}");
                } else {
                    let e = rel(&exact.dm, &dm);
                    assert!(e < 1e-8, "{name} {kind:?} dM/drho {e:e}");
                    let z = exact.dk.norm_max() * value / at.k.norm_max();
                    assert!(z < 1e-12, "{name} {kind:?} dK/drho {z:e}");
                }
            }
        }
    }
}

/// Coupled bending–torsion of a simply supported mono-symmetric beam (Gere & Lin 1958, *J.
/// Franklin Inst.* 266; Timoshenko, Young & Weaver, *Vibration Problems in Engineering*, §5.17):
/// with `w = W sin βx`, `θ = Θ sin βx`, `β = kπ/L`, the kinetic energy of the section (centroid
/// at `e` along element `y` from the shear centre) and femu's rotary inertia `ρI_y w'²` give
/// `det([[EI_yβ⁴, 0], [0, GJβ²]] − ω² ρ[[A + I_yβ², Ae], [Ae, I_S]]) = 0`, `I_S = I_y + I_z +
/// Ae²`; without the rotary term (`I_yβ²`) it is Gere & Lin's
/// `r²(ω_b² − ω²)(ω_t² − ω²) = ω⁴e²` (`ω_b² = EI_yβ⁴/ρA`, `ω_t² = GJβ²/ρI_S`, `r² = I_S/A`).
/// femu's consistent mass has the rotary inertia, so the reference keeps it (it moves the
/// frequencies by less than 1e-3 here, checked) and the analytic model is the FE's limit:
/// shear-rigid section (no Timoshenko shear), warping ignored on both sides.
///
/// Section: a CHAN2 (a U open along +y, so its symmetry axis is element y and the offset `e`
/// is along y; bending in the `x–z` plane couples with twist), 150 × 100 mm, walls 4 mm, from
/// femu's library and thin-walled shear centre; L = 6 m, steel. Only the DOFs of the coupled
/// family (`u_z, θ_x, θ_y`) are kept — with `n = (e, 0)` the transforms leave them uncoupled
/// from `u_x, u_y, θ_z` — simply supported with fork ends (`u_z = θ_x = 0` at both ends).
///
/// Measured: the four lowest frequencies (the k = 1 pair, 37.96 and 128.2 rad/s, and the
/// lower roots of k = 2 and 3) converge to the reference at second order — largest relative
/// error 1.1e-2, 2.8e-3, 6.9e-4, 1.7e-4 at 16, 32, 64, 128 consistent elements (rate 2.00;
/// lumped 1.4e-2 … 2.2e-4, rate 2.00), as the linear twist interpolation predicts
/// (`(βh)²/24` ≈ 2e-4 for the k = 3 twist at 128 elements). Checked as: error at 128 elements
/// below 3e-4 (consistent) and 4e-4 (lumped), and an error ratio from 64 to 128 elements above
/// 3.5 (rate > 1.8). Without the offset (e = 0) the first frequency moves by 47 %; moving the
/// rotary inertia with the centroid too left a 2.6e-3 error that grew under refinement — both
/// fail this check.
#[test]
fn coupled_bending_torsion_frequencies_converge_to_gere_lin() {
    let d = [0.004, 0.004, 0.1, 0.15];
    let s = crate::model::sections::chan2_section(d).unwrap();
    let [e_off, zero] = crate::model::sections::neutral_axis_offset("CHAN2", &d);
    assert_eq!(zero, 0.0);
    assert!(e_off.abs() > 0.02, "{e_off}");
    let section = Section::General {
        area: s.area,
        iy: s.i2,
        iz: s.i1,
        j: s.j,
        shear_y: None,
        shear_z: None,
    };
    let g = E / (2.0 * (1.0 + NU));
    let l = 6.0;
    let is = s.i1 + s.i2 + s.area * e_off * e_off;
    // Reference: the lowest roots over k = 1..20.
    let reference = |e: f64, rotary: f64| {
        let is = s.i1 + s.i2 + s.area * e * e;
        let mut out = Vec::new();
        for k in 1..=20 {
            let beta = k as f64 * std::f64::consts::PI / l;
            let k1 = E * s.i2 * beta.powi(4);
            let k2 = g * s.j * beta * beta;
            let m11 = RHO * (s.area + rotary * s.i2 * beta * beta);
            let (m12, m22) = (RHO * s.area * e, RHO * is);
            let a = m11 * m22 - m12 * m12;
            let b = -(k1 * m22 + k2 * m11);
            let c = k1 * k2;
            let disc = (b * b - 4.0 * a * c).sqrt();
            out.push(((-b - disc) / (2.0 * a)).sqrt());
            out.push(((-b + disc) / (2.0 * a)).sqrt());
        }
        out.sort_by(f64::total_cmp);
        out.truncate(4);
        out
    };
    let want = reference(e_off, 1.0);
    let uncoupled = reference(0.0, 1.0);
    assert!(
        (uncoupled[0] - want[0]).abs() > 0.05 * want[0],
        "{uncoupled:?} {want:?}"
    );
    // Gere & Lin's equation proper (no rotary inertia): its roots satisfy
    // r²(ω_b² − ω²)(ω_t² − ω²) = ω⁴e² (to round-off), and differ from the reference's by the
    // rotary inertia alone (below 1e-3 here).
    let gere_lin = reference(e_off, 0.0);
    let beta = std::f64::consts::PI / l;
    let wb2 = E * s.i2 * beta.powi(4) / (RHO * s.area);
    let wt2 = g * s.j * beta * beta / (RHO * is);
    let r2 = is / s.area;
    let w2 = gere_lin[0] * gere_lin[0];
    let residual = r2 * (wb2 - w2) * (wt2 - w2) - w2 * w2 * e_off * e_off;
    assert!(residual.abs() < 1e-9 * r2 * wb2 * wt2, "{residual}");
    for (a, b) in gere_lin.iter().zip(&want) {
        assert!(((a - b) / b).abs() < 1e-3, "{gere_lin:?} {want:?}");
    }
    eprintln!(
        "reference {want:?}, Gere-Lin without rotary inertia {gere_lin:?}, uncoupled {uncoupled:?}"
    );
    let centres = SectionCentres {
        neutral_axis: [e_off, 0.0],
        ..SectionCentres::default()
    };
    for (kind, tol) in [(MassKind::Consistent, 3e-4), (MassKind::Lumped, 4e-4)] {
        let bd = data(section, 0.0);
        let error = |n: usize| {
            let (k, m) = chain(n, l, &|a, b| {
                beam2_centred(
                    a,
                    b,
                    [0.0, 1.0, 0.0],
                    &bd,
                    kind,
                    &EndConditions::default(),
                    &centres,
                )
                .unwrap()
            });
            let keep: Vec<usize> = (0..=n)
                .flat_map(|i| {
                    let end = i == 0 || i == n;
                    [2usize, 3, 4]
                        .into_iter()
                        .filter(move |c| !(end && (*c == 2 || *c == 3)))
                        .map(move |c| 6 * i + c)
                })
                .collect();
            let (kr, mr) = (restrict(&k, &keep), restrict(&m, &keep));
            let dofs: Vec<DofId> = (0..keep.len())
                .map(|i| DofId::new(1 + i as u64 / 6, Component::ALL[i % 6]))
                .collect();
            let modes = dense_generalized(kr.as_ref(), mr.as_ref(), &dofs, ModeSelection::Count(4))
                .unwrap();
            let got: Vec<f64> = modes.eigenvalues.iter().map(|x| x.sqrt()).collect();
            got.iter()
                .zip(&want)
                .map(|(g, w)| ((g - w) / w).abs())
                .fold(0.0f64, f64::max)
        };
        let errors: Vec<f64> = [16, 32, 64, 128].map(error).to_vec();
        let rate = (errors[2] / errors[3]).log2();
        eprintln!("{kind:?}: errors at 16, 32, 64, 128 elements {errors:?}, rate {rate:.2}");
        assert!(errors[3] < tol, "{kind:?} {errors:?}");
        assert!(
            errors[2] / errors[3] > 3.0,
            "{kind:?} rate {rate} {errors:?}"
        );
    }
}
