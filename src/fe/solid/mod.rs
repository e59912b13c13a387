//! Isoparametric solid elements (Nastran CHEXA, CPENTA, CTETRA, CPYRAM): HEXA8, HEXA20,
//! PENTA6, PENTA15, TETRA4, TETRA10, PYRAM5 and PYRAM13, and the variable-node elements of each
//! shape (any subset of midside nodes, [`shape`]), with three translations per node
//! (docs/theory.md §1; derivatives §2, (2.13)–(2.16)).
//!
//! **Stiffness.** `K = ∫ Bᵀ D B dV` with the strain `ε = [εxx, εyy, εzz, γxy, γyz, γzx] = B u`
//! (engineering shear, the MAT9 order) and `D` the elasticity matrix in the basic system: the
//! isotropic `D(E, ν)` of a MAT1, or a MAT9's `G` turned from its material axes `R` by
//! `D = Tᵀ G T`, `T` the Voigt strain rotation (`ε' = R ε Rᵀ`). Integration as
//! [`shape::stiffness_rule`] (full integration for every shape). HEXA8 adds the nine
//! incompatible modes `1 − ξ²`, `1 − η²`, `1 − ζ²` per displacement (Wilson's element with
//! Taylor's correction, the 3-D form of femu's QM6 shell membrane; Taylor, Beresford & Wilson
//! 1976, *IJNME* 10): their derivatives are taken with the centre Jacobian `J₀` and scaled by
//! `det J₀ / det J`, so that `∫ B_I dV = 0` and the patch test is passed; they are condensed
//! statically (HEXA8 only: a variable-node hexahedron, partial midside set, is plain
//! isoparametric). Plain trilinear HEXA8 locks in bending; the incompatible modes remove that, as
//! the "bubble" of MSC Nastran's default CHEXA does (MSC's own formulation is not published, so
//! femu's HEXA8 agrees with it to discretisation accuracy, not digit for digit).
//!
//! **Mass.** Consistent `M = ∫ ρ NᵀN dV` on each translation ([`shape::mass_rule`], exact for
//! straight-edged elements; PYRAM13 4×4×4 on the collapsed cube). Lumped: the HRZ diagonal (Hinton, Rock & Zienkiewicz 1976): each
//! node's consistent diagonal `∫ρNᵢ²dV` scaled so that the sum is the element mass `ρV` — for
//! every shape, so that quadratic elements never get a zero or negative corner mass (row sums
//! of HEXA20/TETRA10 are negative at corners). Both conserve `ρV` exactly; both are positive
//! semi-definite.
//!
//! **Checks.** A zero or negative `det J` at any integration point is an error naming the node
//! order the QRG asks for (Nastran refuses such elements too).
//!
//! **Derivatives.** `K` is linear in `D` and `M` in `ρ`, so `∂K/∂E = K/E` (MAT1) and
//! `∂M/∂ρ = M/ρ` exactly; [`solid_derivative`] forms them with `E = 1`, `ρ = 1`.
//!
//! The 6-DOF node blocks of [`super::element`] carry zeros on the rotations: a solid gives
//! rotations neither stiffness nor mass, so a solid-only mesh loses them in the assembly (as
//! Nastran's AUTOSPC) and a solid joined to shells adds nothing to their rotations.

pub mod shape;
#[cfg(test)]
mod tests;

use super::element::{ElementDerivative, ElementError, ElementMatrices, MassKind, positive};
use crate::model::{SolidFamily, SolidKind};
use faer::Mat;
use faer::linalg::solvers::Solve;

/// A 6×6 elasticity matrix, Voigt order `[xx, yy, zz, xy, yz, zx]`, engineering shear.
pub type Elasticity = [[f64; 6]; 6];

/// Material of a solid element: elasticity in the basic system and density.
#[derive(Clone, Debug, PartialEq)]
pub struct SolidMaterial {
    /// `D` in the basic system.
    pub d: Elasticity,
    /// Density, kg/m³.
    pub rho: f64,
}

/// Which parameter a derivative is taken for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SolidParameter {
    /// Young's modulus of an isotropic material whose value is `e` (`∂K/∂E = K/E`).
    YoungsModulus {
        /// The current modulus.
        e: f64,
    },
    /// Density (`∂M/∂ρ = M/ρ`).
    Density,
}

/// The isotropic elasticity `D(E, ν)`: `λ = Eν/((1 + ν)(1 − 2ν))`, `μ = E/(2(1 + ν))`.
pub fn isotropic(e: f64, nu: f64) -> Result<Elasticity, ElementError> {
    positive("E", e, false)?;
    if !(nu > -1.0 && nu < 0.5) {
        return Err(ElementError::BadValue {
            field: "NU",
            value: nu,
            hint: "a solid needs -1 < NU < 0.5 (0.5 is incompressible)",
        });
    }
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let mut d = [[0.0; 6]; 6];
    for i in 0..3 {
        d[i][..3].fill(lambda);
        d[i][i] = lambda + 2.0 * mu;
        d[i + 3][i + 3] = mu;
    }
    Ok(d)
}

/// A strain vector as a symmetric tensor (engineering shear halved).
fn tensor(v: &[f64; 6]) -> [[f64; 3]; 3] {
    [
        [v[0], 0.5 * v[3], 0.5 * v[5]],
        [0.5 * v[3], v[1], 0.5 * v[4]],
        [0.5 * v[5], 0.5 * v[4], v[2]],
    ]
}

/// `D = Tᵀ G T`: an elasticity `g` given along material axes `axes` (rows: the material
/// directions in basic) as the elasticity in the basic system.
pub fn rotate_to_basic(g: &Elasticity, axes: &[[f64; 3]; 3]) -> Elasticity {
    // Column j of T: the material-axes strain of the j-th unit basic strain.
    let mut t = [[0.0; 6]; 6];
    for j in 0..6 {
        let mut unit = [0.0; 6];
        unit[j] = 1.0;
        let e = tensor(&unit);
        let mut r = [[0.0; 3]; 3];
        for (a, row) in r.iter_mut().enumerate() {
            for (b, v) in row.iter_mut().enumerate() {
                *v = (0..3)
                    .flat_map(|k| (0..3).map(move |l| (k, l)))
                    .map(|(k, l)| axes[a][k] * e[k][l] * axes[b][l])
                    .sum();
            }
        }
        let voigt = [
            r[0][0],
            r[1][1],
            r[2][2],
            2.0 * r[0][1],
            2.0 * r[1][2],
            2.0 * r[2][0],
        ];
        for i in 0..6 {
            t[i][j] = voigt[i];
        }
    }
    let mut d = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            d[i][j] = (0..6)
                .flat_map(|k| (0..6).map(move |l| (k, l)))
                .map(|(k, l)| t[k][i] * g[k][l] * t[l][j])
                .sum();
        }
    }
    d
}

/// The node order the QRG asks of `kind`, for the bad-Jacobian message.
fn order_hint(kind: SolidKind) -> &'static str {
    match kind.family() {
        SolidFamily::Hexa => {
            "nodes G1-G4 must go round one face counter-clockwise seen from the opposite face (right-handed about the direction towards it), G5-G8 round the opposite face with G5 opposite G1, G6 opposite G2, and any midside nodes G9-G20 on their edges in the QRG's order"
        }
        SolidFamily::Penta => {
            "nodes G1-G3 must go round one triangular face counter-clockwise seen from the opposite face, G4-G6 the opposite face with G4 opposite G1, and any midside nodes G7-G15 on their edges in the QRG's order"
        }
        SolidFamily::Tetra => {
            "nodes G1-G3 must go counter-clockwise seen from G4 (right-handed about the direction towards G4), and any midside nodes G5-G10 on their edges in the QRG's order"
        }
        SolidFamily::Pyram => {
            "nodes G1-G4 must go round the base counter-clockwise seen from the apex G5, and any midside nodes G6-G13 on their edges in the QRG's order (G6-G9 on G1-G2, G2-G3, G3-G4, G4-G1, G10-G13 on G1-G5 ... G4-G5)"
        }
    }
}

/// Jacobian `J[i][j] = ∂x_j/∂ξ_i`, its determinant, and `∂N/∂x = J⁻¹ ∂N/∂ξ`.
struct Map {
    det: f64,
    inv: [[f64; 3]; 3],
}

fn jacobian(xyz: &[[f64; 3]], dn: &[[f64; 3]]) -> Map {
    let mut j = [[0.0; 3]; 3];
    for (x, d) in xyz.iter().zip(dn) {
        for a in 0..3 {
            for b in 0..3 {
                j[a][b] += d[a] * x[b];
            }
        }
    }
    let det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1])
        - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
        + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
    let c = |a: usize, b: usize| {
        let (a1, a2) = ((a + 1) % 3, (a + 2) % 3);
        let (b1, b2) = ((b + 1) % 3, (b + 2) % 3);
        j[a1][b1] * j[a2][b2] - j[a1][b2] * j[a2][b1]
    };
    let mut inv = [[0.0; 3]; 3];
    for (a, row) in inv.iter_mut().enumerate() {
        for (b, v) in row.iter_mut().enumerate() {
            *v = c(b, a) / det;
        }
    }
    Map { det, inv }
}

fn grad(map: &Map, d: &[f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|a| (0..3).map(|b| map.inv[a][b] * d[b]).sum())
}

/// Adds the strain rows of one node's gradient `g` at columns `3c..3c+3` of the 6×m `b`.
fn strain_rows(b: &mut [Vec<f64>; 6], c: usize, g: [f64; 3], scale: f64) {
    let g = g.map(|v| v * scale);
    b[0][3 * c] = g[0];
    b[1][3 * c + 1] = g[1];
    b[2][3 * c + 2] = g[2];
    b[3][3 * c] = g[1];
    b[3][3 * c + 1] = g[0];
    b[4][3 * c + 1] = g[2];
    b[4][3 * c + 2] = g[1];
    b[5][3 * c] = g[2];
    b[5][3 * c + 2] = g[0];
}

/// `k += w Bᵢᵀ D Bⱼ`.
fn add_btdb(k: &mut Mat<f64>, bi: &[Vec<f64>; 6], d: &Elasticity, bj: &[Vec<f64>; 6], w: f64) {
    let (ni, nj) = (bi[0].len(), bj[0].len());
    let mut db = vec![[0.0; 6]; nj];
    for (c, col) in db.iter_mut().enumerate() {
        for (r, v) in col.iter_mut().enumerate() {
            *v = (0..6).map(|s| d[r][s] * bj[s][c]).sum();
        }
    }
    for r in 0..ni {
        for (c, col) in db.iter().enumerate() {
            let v: f64 = (0..6).map(|s| bi[s][r] * col[s]).sum();
            k[(r, c)] += w * v;
        }
    }
}

fn check_nodes(kind: SolidKind, xyz: &[[f64; 3]]) -> Result<(), ElementError> {
    if xyz.len() != kind.n_nodes() {
        return Err(ElementError::Degenerate(format!(
            "a {} element needs {} nodes, got {}",
            kind.name(),
            kind.n_nodes(),
            xyz.len()
        )));
    }
    Ok(())
}

fn bad_jacobian(kind: SolidKind, det: f64, p: [f64; 3]) -> ElementError {
    ElementError::Degenerate(format!(
        "the Jacobian determinant is {det:e} (not positive) at the integration point {p:?} of the {}; {}",
        kind.name(),
        order_hint(kind)
    ))
}

/// Stiffness and mass over the element's `3n` translations (node-major `ux uy uz`).
pub fn solid3(
    kind: SolidKind,
    xyz: &[[f64; 3]],
    mat: &SolidMaterial,
    mass: MassKind,
) -> Result<(Mat<f64>, Mat<f64>), ElementError> {
    check_nodes(kind, xyz)?;
    positive("RHO", mat.rho, true)?;
    let n = kind.n_nodes();
    let m3 = mass_matrix(kind, xyz, mat.rho, mass)?;
    let mut k = Mat::<f64>::zeros(3 * n, 3 * n);
    let incompatible = kind == SolidKind::Hexa8;
    let centre = if incompatible {
        let (_, dn0) = shape::shape(kind, [0.0; 3]);
        Some(jacobian(xyz, &dn0))
    } else {
        None
    };
    let ni = if incompatible { 9 } else { 0 };
    let mut kci = Mat::<f64>::zeros(3 * n, ni);
    let mut kii = Mat::<f64>::zeros(ni, ni);
    for (p, w) in shape::stiffness_rule(kind) {
        let (_, dn) = shape::shape(kind, p);
        let map = jacobian(xyz, &dn);
        if map.det <= 0.0 || !map.det.is_finite() {
            return Err(bad_jacobian(kind, map.det, p));
        }
        let mut b: [Vec<f64>; 6] = std::array::from_fn(|_| vec![0.0; 3 * n]);
        for (a, d) in dn.iter().enumerate() {
            strain_rows(&mut b, a, grad(&map, d), 1.0);
        }
        let wd = w * map.det;
        add_btdb(&mut k, &b, &mat.d, &b, wd);
        if let Some(j0) = &centre {
            let mut bi: [Vec<f64>; 6] = std::array::from_fn(|_| vec![0.0; 9]);
            for m in 0..3 {
                let mut d = [0.0; 3];
                d[m] = -2.0 * p[m];
                let g = grad(j0, &d);
                for c in 0..3 {
                    // Mode m of component c: only the strains of that component.
                    let mut full: [Vec<f64>; 6] = std::array::from_fn(|_| vec![0.0; 3]);
                    strain_rows(&mut full, 0, g, j0.det / map.det);
                    for s in 0..6 {
                        bi[s][3 * m + c] = full[s][c];
                    }
                }
            }
            add_btdb(&mut kci, &b, &mat.d, &bi, wd);
            add_btdb(&mut kii, &bi, &mat.d, &bi, wd);
        }
    }
    if incompatible && kii.norm_max() > 0.0 {
        let x = kii.partial_piv_lu().solve(kci.transpose().to_owned());
        k -= &kci * &x;
    }
    let k = Mat::from_fn(3 * n, 3 * n, |i, j| 0.5 * (k[(i, j)] + k[(j, i)]));
    Ok((k, m3))
}

/// The consistent or HRZ-lumped mass over `3n` translations.
fn mass_matrix(
    kind: SolidKind,
    xyz: &[[f64; 3]],
    rho: f64,
    mass: MassKind,
) -> Result<Mat<f64>, ElementError> {
    let n = kind.n_nodes();
    let mut s = Mat::<f64>::zeros(n, n);
    let mut volume = 0.0;
    for (p, w) in shape::mass_rule(kind) {
        let (nn, dn) = shape::shape(kind, p);
        let map = jacobian(xyz, &dn);
        if map.det <= 0.0 || !map.det.is_finite() {
            return Err(bad_jacobian(kind, map.det, p));
        }
        let wd = w * map.det;
        volume += wd;
        for a in 0..n {
            for b in 0..n {
                s[(a, b)] += wd * nn[a] * nn[b];
            }
        }
    }
    let mut m = Mat::<f64>::zeros(3 * n, 3 * n);
    match mass {
        MassKind::Consistent => {
            for a in 0..n {
                for b in 0..n {
                    let v = rho * 0.5 * (s[(a, b)] + s[(b, a)]);
                    for c in 0..3 {
                        m[(3 * a + c, 3 * b + c)] = v;
                    }
                }
            }
        }
        MassKind::Lumped => {
            let diag: f64 = (0..n).map(|a| s[(a, a)]).sum();
            for a in 0..n {
                let v = rho * volume * s[(a, a)] / diag;
                for c in 0..3 {
                    m[(3 * a + c, 3 * a + c)] = v;
                }
            }
        }
    }
    Ok(m)
}

/// The `3n` matrix on the element's 6-DOF node blocks (rotations zero).
fn expand(small: &Mat<f64>) -> Mat<f64> {
    let n = small.nrows() / 3;
    let mut out = Mat::<f64>::zeros(6 * n, 6 * n);
    for a in 0..n {
        for b in 0..n {
            for i in 0..3 {
                for j in 0..3 {
                    out[(6 * a + i, 6 * b + j)] = small[(3 * a + i, 3 * b + j)];
                }
            }
        }
    }
    out
}

/// Stiffness and mass of a solid on six DOFs per node (rotations without stiffness and mass).
pub fn solid(
    kind: SolidKind,
    xyz: &[[f64; 3]],
    mat: &SolidMaterial,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    let (k, m) = solid3(kind, xyz, mat, mass)?;
    Ok(ElementMatrices {
        k: expand(&k),
        m: expand(&m),
    })
}

/// `∂K/∂φ`, `∂M/∂φ` of a solid on six DOFs per node: `K/E` for the modulus of an isotropic
/// material, `M/ρ` (formed with `ρ = 1`) for the density.
pub fn solid_derivative(
    kind: SolidKind,
    xyz: &[[f64; 3]],
    mat: &SolidMaterial,
    mass: MassKind,
    p: SolidParameter,
) -> Result<ElementDerivative, ElementError> {
    let n6 = 6 * kind.n_nodes();
    Ok(match p {
        SolidParameter::YoungsModulus { e } => {
            positive("E", e, false)?;
            let unit = SolidMaterial {
                d: mat.d.map(|row| row.map(|v| v / e)),
                rho: 0.0,
            };
            let (k, _) = solid3(kind, xyz, &unit, mass)?;
            ElementDerivative {
                dk: expand(&k),
                dm: Mat::zeros(n6, n6),
            }
        }
        SolidParameter::Density => {
            let unit = SolidMaterial { d: mat.d, rho: 1.0 };
            check_nodes(kind, xyz)?;
            let m = mass_matrix(kind, xyz, unit.rho, mass)?;
            ElementDerivative {
                dk: Mat::zeros(n6, n6),
                dm: expand(&m),
            }
        }
    })
}
