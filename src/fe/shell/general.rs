//! The flat shells of [`super`] under a general constitutive law ([`quad4_general`],
//! [`tria3_general`]): laminates, MAT2/MAT8 parts, MID4 coupling, THETA/MCID, offsets.
//!
//! The same elements with the resultants `N = A ε0 + B κ`, `M = B ε0 + D κ`, `Q = G_s γ` of a
//! [`ShellLaw`] (`super::super::laminate`), given in the material axes and rotated into the
//! element's by `φ = ψ + THETA` (`ψ` the angle of the projected G1→G2 edge from `e1`, which for
//! quad4 is `∂x/∂ξ`, not G1→G2) or by the projection of an MCID axis; an offset `z0` (ZOFFS)
//! enters as `B + z0 A`, `D + 2 z0 B + z0² A` (tested against the element on rigid links).
//! quad4 condenses its incompatible modes from the coupled membrane–bending system; the
//! drilling penalty is `α_d Ā66 A_e` with the rotation-invariant
//! `Ā66 = (A11 + A22 − 2 A12 + 4 A33)/8` (`G t` for an isotropic shell); tria3's shear
//! stabilisation uses the total thickness. The mass is `μ + nsm` on translations, `S` coupling
//! `u–θy` (and `−S` `v–θx`), `I` on the rotations (θz with bending and membrane). Derivatives
//! take the law's derivative ([`quad4_general_derivative`]): exact, the condensation's
//! included. The homogeneous kernel of [`super`] stays the one for PSHELLs without offset or
//! MAT2/MAT8/MID4 (its bits unchanged).

// Index loops follow the index notation of the formulas.
#![allow(clippy::needless_range_loop)]

use super::super::element::{ElementDerivative, ElementError, ElementMatrices, MassKind};
use super::super::laminate::{M2, ShellLaw};
use super::{
    DRILLING_FACTOR, Frame, GAUSS2, TRIA_SHEAR_STABILISATION, add_btdb, add_drilling, cartesian,
    check_nodes, cholesky_solve, covariant_shear4, cross, dot, edge_shear3, jacobian4, norm,
    quad_frame, scaled, shape4, sub, transform,
};
use faer::Mat;

/// The material x axis of a general shell element (Nastran CQUAD4/CTRIA3 THETA or MCID).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialAxis {
    /// At angle THETA (rad) from the G1→G2 edge (projected on the element plane), about the
    /// element normal.
    Theta(f64),
    /// Along a basic-system direction projected on the element plane (the x axis of MCID).
    Direction([f64; 3]),
}

/// Where a general law lies on its element: its material axis and the offset `z0` (m) of its
/// reference plane above the grid plane along the element normal (ZOFFS).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellOrientation {
    /// The material x axis.
    pub axis: MaterialAxis,
    /// ZOFFS, m.
    pub offset: f64,
}

impl Default for ShellOrientation {
    fn default() -> Self {
        ShellOrientation {
            axis: MaterialAxis::Theta(0.0),
            offset: 0.0,
        }
    }
}

/// Angle (rad) of the material x axis from the element's `e1`.
fn material_angle<const N: usize>(
    frame: &Frame<N>,
    xyz: &[[f64; 3]; N],
    axis: MaterialAxis,
) -> Result<f64, ElementError> {
    let (e1, e2) = (&frame.t[0], &frame.t[1]);
    match axis {
        MaterialAxis::Theta(theta) => {
            let d = sub(&xyz[1], &xyz[0]);
            Ok(dot(&d, e2).atan2(dot(&d, e1)) + theta)
        }
        MaterialAxis::Direction(v) => {
            let (vx, vy) = (dot(&v, e1), dot(&v, e2));
            let n = norm(&v);
            if !(n.is_finite() && vx.hypot(vy) > 1e-8 * n) {
                return Err(ElementError::Degenerate(format!(
                    "the material axis {v:?} (MCID's x axis, or r axis at the centre) is normal to the element (or zero), so it has no projection on the element plane; give THETA or another MCID"
                )));
            }
            Ok(vy.atan2(vx))
        }
    }
}

/// The law in the element's axes about the grid plane.
fn element_law(law: &ShellLaw, phi: f64, o: &ShellOrientation) -> ShellLaw {
    law.rotated(phi).offset(o.offset)
}

/// `[[A, B], [Bᵀ, D]]` over `(ε, κ)`.
fn law6(l: &ShellLaw) -> [[f64; 6]; 6] {
    let mut c = [[0.0; 6]; 6];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = l.a[i][j];
            c[i][3 + j] = l.b[i][j];
            c[3 + i][j] = l.b[j][i];
            c[3 + i][3 + j] = l.d[i][j];
        }
    }
    c
}

/// `k += w Bᵀ C E` for strain matrices `B` (R × I) and `E` (R × J).
fn add_btce<const R: usize, const I: usize, const J: usize>(
    k: &mut [[f64; J]; I],
    b: &[[f64; I]; R],
    c: &[[f64; R]; R],
    e: &[[f64; J]; R],
    w: f64,
) {
    let mut ce = [[0.0; J]; R];
    for r in 0..R {
        for j in 0..J {
            let mut s = 0.0;
            for q in 0..R {
                s += c[r][q] * e[q][j];
            }
            ce[r][j] = s * w;
        }
    }
    for i in 0..I {
        for j in 0..J {
            let mut s = 0.0;
            for r in 0..R {
                s += b[r][i] * ce[r][j];
            }
            k[i][j] += s;
        }
    }
}

/// Local index of compatible DOF `a` of a general element with `m` membrane DOFs (`u, v` per
/// node) followed by the plate DOFs (`w, θx, θy` per node).
fn general_index(a: usize, m: usize) -> usize {
    if a < m {
        6 * (a / 2) + a % 2
    } else {
        let p = a - m;
        6 * (p / 3) + 2 + p % 3
    }
}

/// Mass of a general law (element axes, about the grid plane) in the local frame, rotated:
/// `μ + nsm` on translations, `S` coupling `u–θy` and `−S` coupling `v–θx`, `I` on θx, θy (with
/// bending) and θz (with bending and membrane).
pub(super) fn law_mass<const N: usize, const D: usize>(
    frame: &Frame<N>,
    area: f64,
    m_geo: &[[f64; N]; N],
    l: &ShellLaw,
    kind: MassKind,
) -> Mat<f64> {
    let mut blk = [[0.0; 6]; 6];
    for a in 0..3 {
        blk[a][a] = l.mu + l.nsm;
    }
    if l.bending {
        blk[3][3] = l.inertia;
        blk[4][4] = l.inertia;
        blk[0][4] = l.first_moment;
        blk[4][0] = l.first_moment;
        blk[1][3] = -l.first_moment;
        blk[3][1] = -l.first_moment;
        if l.membrane {
            blk[5][5] = l.inertia;
        }
    }
    let mut ml = [[0.0; D]; D];
    for i in 0..N {
        for j in 0..N {
            let f = match kind {
                MassKind::Consistent => m_geo[i][j],
                MassKind::Lumped if i == j => area / N as f64,
                MassKind::Lumped => continue,
            };
            for a in 0..6 {
                for b in 0..6 {
                    ml[6 * i + a][6 * j + b] = f * blk[a][b];
                }
            }
        }
    }
    match kind {
        // As the homogeneous kernel: the lumped mass is not carried through the warping links.
        MassKind::Lumped => transform(&ml, &frame.t, &[0.0; N]),
        MassKind::Consistent => transform(&ml, &frame.t, &frame.z),
    }
}

/// Local stiffness (24 × 24) of a general quad4 for law `l` (element axes) and, with `dl`, its
/// exact derivative for the law derivative `dl`: the incompatible modes are condensed from the
/// coupled membrane–bending system, `K = K_cc − K_ca K_aa⁻¹ K_ac`, whose derivative is
/// `dK_cc − dK_ca X − Xᵀ dK_ac + Xᵀ dK_aa X` with `X = K_aa⁻¹ K_ac`.
#[allow(clippy::type_complexity)]
pub(super) fn quad4_law_local(
    frame: &Frame<4>,
    l: &ShellLaw,
    dl: Option<&ShellLaw>,
    drill: f64,
) -> Result<([[f64; 24]; 24], Option<[[f64; 24]; 24]>, f64, [[f64; 4]; 4]), ElementError> {
    let (x, y) = (&frame.x, &frame.y);
    let (_, dxi0, deta0) = shape4(0.0, 0.0);
    let (j0, det0) = jacobian4(x, y, &dxi0, &deta0);
    let ga = covariant_shear4(x, y, 0.0, 1.0, true);
    let gc = covariant_shear4(x, y, 0.0, -1.0, true);
    let gd = covariant_shear4(x, y, 1.0, 0.0, false);
    let gb = covariant_shear4(x, y, -1.0, 0.0, false);
    let c6 = law6(l);
    let dc6 = dl.map(law6);
    let mut kcc = [[0.0; 20]; 20];
    let mut kca = [[0.0; 4]; 20];
    let mut kaa = [[0.0; 4]; 4];
    let mut dkcc = [[0.0; 20]; 20];
    let mut dkca = [[0.0; 4]; 20];
    let mut dkaa = [[0.0; 4]; 4];
    let mut m_geo = [[0.0; 4]; 4];
    let mut area = 0.0;
    for (xi, eta) in [
        (-GAUSS2, -GAUSS2),
        (GAUSS2, -GAUSS2),
        (GAUSS2, GAUSS2),
        (-GAUSS2, GAUSS2),
    ] {
        let (n, dxi, deta) = shape4(xi, eta);
        let (j, det) = jacobian4(x, y, &dxi, &deta);
        if det.is_nan() || det <= 0.0 {
            return Err(ElementError::Degenerate(format!(
                "non-positive Jacobian {det:e} inside the quad"
            )));
        }
        let w = det;
        area += w;
        let mut nx = [0.0; 4];
        let mut ny = [0.0; 4];
        for i in 0..4 {
            (nx[i], ny[i]) = cartesian(&j, det, dxi[i], deta[i]);
        }
        // Generalised strains (ε; κ) over the 20 compatible DOFs.
        let mut e = [[0.0; 20]; 6];
        for i in 0..4 {
            e[0][2 * i] = nx[i];
            e[1][2 * i + 1] = ny[i];
            e[2][2 * i] = ny[i];
            e[2][2 * i + 1] = nx[i];
            e[3][8 + 3 * i + 2] = nx[i];
            e[4][8 + 3 * i + 1] = -ny[i];
            e[5][8 + 3 * i + 2] = ny[i];
            e[5][8 + 3 * i + 1] = -nx[i];
        }
        let scale = det0 / det;
        let (p1x, p1y) = cartesian(&j0, det0, -2.0 * xi, 0.0);
        let (p2x, p2y) = cartesian(&j0, det0, 0.0, -2.0 * eta);
        let (p1x, p1y, p2x, p2y) = (p1x * scale, p1y * scale, p2x * scale, p2y * scale);
        let ea = [
            [p1x, p2x, 0.0, 0.0],
            [0.0, 0.0, p1y, p2y],
            [p1y, p2y, p1x, p2x],
            [0.0; 4],
            [0.0; 4],
            [0.0; 4],
        ];
        let mut bs = [[0.0; 20]; 2];
        for c in 0..12 {
            let g_xi = 0.5 * (1.0 + eta) * ga[c] + 0.5 * (1.0 - eta) * gc[c];
            let g_eta = 0.5 * (1.0 + xi) * gd[c] + 0.5 * (1.0 - xi) * gb[c];
            (bs[0][8 + c], bs[1][8 + c]) = cartesian(&j, det, g_xi, g_eta);
        }
        add_btdb(&mut kcc, &e, &c6, w);
        add_btce(&mut kca, &e, &c6, &ea, w);
        add_btdb(&mut kaa, &ea, &c6, w);
        add_btdb(&mut kcc, &bs, &l.g, w);
        if let (Some(dc6), Some(dl)) = (&dc6, dl) {
            add_btdb(&mut dkcc, &e, dc6, w);
            add_btce(&mut dkca, &e, dc6, &ea, w);
            add_btdb(&mut dkaa, &ea, dc6, w);
            add_btdb(&mut dkcc, &bs, &dl.g, w);
        }
        for a in 0..4 {
            for b in 0..4 {
                m_geo[a][b] += n[a] * n[b] * w;
            }
        }
    }
    if l.membrane {
        let mut kac = [[0.0; 20]; 4];
        for a in 0..20 {
            for b in 0..4 {
                kac[b][a] = kca[a][b];
            }
        }
        let xm = cholesky_solve(kaa, kac).ok_or_else(|| {
            ElementError::Degenerate(
                "the incompatible-mode stiffness is singular (distorted quad or a membrane stiffness A that is not positive definite)".into(),
            )
        })?;
        // dK_ca X and Xᵀ dK_aa X first (they use the undisturbed K_cc).
        if dl.is_some() {
            let mut dkx = [[0.0; 20]; 20];
            let mut xdx = [[0.0; 20]; 20];
            let mut dkaa_x = [[0.0; 20]; 4];
            for c in 0..4 {
                for b in 0..20 {
                    dkaa_x[c][b] = (0..4).map(|q| dkaa[c][q] * xm[q][b]).sum();
                }
            }
            for a in 0..20 {
                for b in 0..20 {
                    dkx[a][b] = (0..4).map(|c| dkca[a][c] * xm[c][b]).sum();
                    xdx[a][b] = (0..4).map(|c| xm[c][a] * dkaa_x[c][b]).sum();
                }
            }
            for a in 0..20 {
                for b in 0..20 {
                    dkcc[a][b] += -dkx[a][b] - dkx[b][a] + xdx[a][b];
                }
            }
        }
        for a in 0..20 {
            for b in 0..20 {
                let acc: f64 = (0..4).map(|c| kca[a][c] * xm[c][b]).sum();
                kcc[a][b] -= acc;
            }
        }
    }
    let mut nx0 = [0.0; 4];
    let mut ny0 = [0.0; 4];
    for i in 0..4 {
        (nx0[i], ny0[i]) = cartesian(&j0, det0, dxi0[i], deta0[i]);
    }
    let scatter = |k20: &[[f64; 20]; 20], law: &ShellLaw| {
        let mut k = [[0.0; 24]; 24];
        for a in 0..20 {
            for b in 0..20 {
                k[general_index(a, 8)][general_index(b, 8)] += k20[a][b];
            }
        }
        if l.membrane && l.bending {
            add_drilling(&mut k, &nx0, &ny0, drill * law.drilling_rigidity() * area);
        }
        k
    };
    let k = scatter(&kcc, l);
    let dk = dl.map(|dl| scatter(&dkcc, dl));
    Ok((k, dk, area, m_geo))
}

/// Local stiffness (18 × 18) of a general tria3 (CST membrane, constant curvature, MITC3 shear
/// with the stabilisation `T²/(T² + α h²)` of the total thickness) for law `l` and, with `dl`,
/// its exact derivative (linear in the law but for the stabilisation, whose `T`-derivative
/// enters with `dl.thickness`).
#[allow(clippy::type_complexity)]
fn tria3_law_local(
    frame: &Frame<3>,
    l: &ShellLaw,
    dl: Option<&ShellLaw>,
    drill: f64,
) -> ([[f64; 18]; 18], Option<[[f64; 18]; 18]>, f64) {
    let (x, y) = (frame.x, frame.y);
    let two_a = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
    let area = 0.5 * two_a;
    let mut nx = [0.0; 3];
    let mut ny = [0.0; 3];
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        nx[i] = (y[j] - y[k]) / two_a;
        ny[i] = (x[k] - x[j]) / two_a;
    }
    let mut e = [[0.0; 15]; 6];
    for i in 0..3 {
        e[0][2 * i] = nx[i];
        e[1][2 * i + 1] = ny[i];
        e[2][2 * i] = ny[i];
        e[2][2 * i + 1] = nx[i];
        e[3][6 + 3 * i + 2] = nx[i];
        e[4][6 + 3 * i + 1] = -ny[i];
        e[5][6 + 3 * i + 2] = ny[i];
        e[5][6 + 3 * i + 1] = -nx[i];
    }
    let h2 = (0..3)
        .map(|i| {
            let j = (i + 1) % 3;
            (x[j] - x[i]).powi(2) + (y[j] - y[i]).powi(2)
        })
        .fold(0.0f64, f64::max);
    let alpha_h2 = TRIA_SHEAR_STABILISATION * h2;
    let t = l.thickness;
    let stab = t * t / (t * t + alpha_h2);
    let dstab_dt = 2.0 * t * alpha_h2 / (t * t + alpha_h2).powi(2);
    let t12 = edge_shear3(&x, &y, 0, 1);
    let t13 = edge_shear3(&x, &y, 0, 2);
    let t23 = edge_shear3(&x, &y, 1, 2);
    let mut cvec = [0.0; 9];
    for c in 0..9 {
        cvec[c] = t13[c] - t12[c] - t23[c];
    }
    let jm = [x[1] - x[0], y[1] - y[0], x[2] - x[0], y[2] - y[0]];
    let local = |law: &ShellLaw, g: &M2| {
        let mut k15 = [[0.0; 15]; 15];
        add_btdb(&mut k15, &e, &law6(law), area);
        for (r, s_) in [
            (1.0 / 6.0, 1.0 / 6.0),
            (2.0 / 3.0, 1.0 / 6.0),
            (1.0 / 6.0, 2.0 / 3.0),
        ] {
            let mut bs = [[0.0; 15]; 2];
            for c in 0..9 {
                let g_r = t12[c] + s_ * cvec[c];
                let g_s = t13[c] - r * cvec[c];
                (bs[0][6 + c], bs[1][6 + c]) = cartesian(&jm, two_a, g_r, g_s);
            }
            add_btdb(&mut k15, &bs, g, area / 3.0);
        }
        let mut k = [[0.0; 18]; 18];
        for a in 0..15 {
            for b in 0..15 {
                k[general_index(a, 6)][general_index(b, 6)] += k15[a][b];
            }
        }
        if l.membrane && l.bending {
            add_drilling(&mut k, &nx, &ny, drill * law.drilling_rigidity() * area);
        }
        k
    };
    let scaled2 = |g: &M2, f: f64| [[g[0][0] * f, g[0][1] * f], [g[1][0] * f, g[1][1] * f]];
    let k = local(l, &scaled2(&l.g, stab));
    let dk = dl.map(|dl| {
        let mut g = scaled2(&dl.g, stab);
        let extra = scaled2(&l.g, dstab_dt * dl.thickness);
        for i in 0..2 {
            for j in 0..2 {
                g[i][j] += extra[i][j];
            }
        }
        local(dl, &g)
    });
    (k, dk, area)
}

/// The projected flat frame of a tria3 (as [`tria3`] forms it).
fn tria_frame(xyz: &[[f64; 3]; 3]) -> Result<Frame<3>, ElementError> {
    let lmax = check_nodes(xyz)?;
    let r12 = sub(&xyz[1], &xyz[0]);
    let r13 = sub(&xyz[2], &xyz[0]);
    let nvec = cross(&r12, &r13);
    let nn = norm(&nvec);
    let area = 0.5 * nn;
    if area.is_nan() || area <= 1e-10 * lmax * lmax {
        return Err(ElementError::Degenerate(format!(
            "the triangle has (near) zero area {area:e} m² (collinear nodes)"
        )));
    }
    let e1 = scaled(&r12, 1.0 / norm(&r12));
    let e3 = scaled(&nvec, 1.0 / nn);
    let e2 = cross(&e3, &e1);
    let centre = scaled(
        &[
            xyz[0][0] + xyz[1][0] + xyz[2][0],
            xyz[0][1] + xyz[1][1] + xyz[2][1],
            xyz[0][2] + xyz[1][2] + xyz[2][2],
        ],
        1.0 / 3.0,
    );
    let mut frame = Frame {
        t: [e1, e2, e3],
        x: [0.0; 3],
        y: [0.0; 3],
        z: [0.0; 3],
    };
    for i in 0..3 {
        let r = sub(&xyz[i], &centre);
        frame.x[i] = dot(&r, &e1);
        frame.y[i] = dot(&r, &e2);
    }
    Ok(frame)
}

fn finite_local<const D: usize>(k: &[[f64; D]; D]) -> Result<(), ElementError> {
    if k.iter().flatten().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(ElementError::Degenerate(
            "the element matrices overflow (non-finite entries); check the magnitudes of the coordinates and the section".into(),
        ))
    }
}

/// Stiffness and mass of a 4-node flat shell with a general law `law` (material axes) placed by
/// `o` (material axis, ZOFFS): the same element as [`quad4`] with `[[A, B], [Bᵀ, D]]`, `G_s` in
/// place of the homogeneous parts and the drilling penalty `α_d Ā66 A_e`,
/// `Ā66 = (A11 + A22 − 2 A12 + 4 A33)/8` ([`ShellLaw::drilling_rigidity`]).
pub fn quad4_general(
    xyz: &[[f64; 3]; 4],
    law: &ShellLaw,
    o: &ShellOrientation,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    law.validate()?;
    let (frame, _) = quad_frame(xyz)?;
    let l = element_law(law, material_angle(&frame, xyz, o.axis)?, o);
    let (k, _, area, m_geo) = quad4_law_local(&frame, &l, None, DRILLING_FACTOR)?;
    finite_local(&k)?;
    Ok(ElementMatrices {
        k: transform(&k, &frame.t, &frame.z),
        m: law_mass::<4, 24>(&frame, area, &m_geo, &l, mass),
    })
}

/// Exact derivative of [`quad4_general`] for the law derivative `dlaw` (`∂A/∂φ`, …, with
/// `dlaw.thickness = ∂T/∂φ`; `dlaw.membrane`, `dlaw.bending` unused).
pub fn quad4_general_derivative(
    xyz: &[[f64; 3]; 4],
    law: &ShellLaw,
    dlaw: &ShellLaw,
    o: &ShellOrientation,
    mass: MassKind,
) -> Result<ElementDerivative, ElementError> {
    law.validate()?;
    let (frame, _) = quad_frame(xyz)?;
    let phi = material_angle(&frame, xyz, o.axis)?;
    let l = element_law(law, phi, o);
    let dl = ShellLaw {
        membrane: law.membrane,
        bending: law.bending,
        ..element_law(dlaw, phi, o)
    };
    let (_, dk, area, m_geo) = quad4_law_local(&frame, &l, Some(&dl), DRILLING_FACTOR)?;
    let dk = dk.unwrap_or([[0.0; 24]; 24]);
    finite_local(&dk)?;
    Ok(ElementDerivative {
        dk: transform(&dk, &frame.t, &frame.z),
        dm: law_mass::<4, 24>(&frame, area, &m_geo, &dl, mass),
    })
}

/// Stiffness and mass of a 3-node flat shell with a general law (see [`quad4_general`]).
pub fn tria3_general(
    xyz: &[[f64; 3]; 3],
    law: &ShellLaw,
    o: &ShellOrientation,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    law.validate()?;
    let frame = tria_frame(xyz)?;
    let l = element_law(law, material_angle(&frame, xyz, o.axis)?, o);
    let (k, _, area) = tria3_law_local(&frame, &l, None, DRILLING_FACTOR);
    finite_local(&k)?;
    Ok(ElementMatrices {
        k: transform(&k, &frame.t, &frame.z),
        m: law_mass::<3, 18>(&frame, area, &tria_m_geo(area), &l, mass),
    })
}

/// Exact derivative of [`tria3_general`] (see [`quad4_general_derivative`]).
pub fn tria3_general_derivative(
    xyz: &[[f64; 3]; 3],
    law: &ShellLaw,
    dlaw: &ShellLaw,
    o: &ShellOrientation,
    mass: MassKind,
) -> Result<ElementDerivative, ElementError> {
    law.validate()?;
    let frame = tria_frame(xyz)?;
    let phi = material_angle(&frame, xyz, o.axis)?;
    let l = element_law(law, phi, o);
    let dl = ShellLaw {
        membrane: law.membrane,
        bending: law.bending,
        ..element_law(dlaw, phi, o)
    };
    let (_, dk, area) = tria3_law_local(&frame, &l, Some(&dl), DRILLING_FACTOR);
    let dk = dk.unwrap_or([[0.0; 18]; 18]);
    finite_local(&dk)?;
    Ok(ElementDerivative {
        dk: transform(&dk, &frame.t, &frame.z),
        dm: law_mass::<3, 18>(&frame, area, &tria_m_geo(area), &dl, mass),
    })
}

/// `∫ Nᵢ Nⱼ dA` of a linear triangle.
fn tria_m_geo(area: f64) -> [[f64; 3]; 3] {
    let mut m = [[area / 12.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = area / 6.0;
    }
    m
}
