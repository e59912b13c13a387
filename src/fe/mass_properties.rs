//! Rigid-body mass properties of a model, as Nastran's grid point weight generator
//! (`PARAM,GRDPNT`) reports them: the 6 × 6 rigid-body mass matrix about a reference point,
//! the mass in each direction, the centre of gravity and the inertia tensor about it.
//!
//! With `D` the rigid-body modes about the reference point `r₀` (at a grid at `x`, a
//! translation `t` and rotation `θ` move it by `u = t + θ × (x − r₀)`, `φ = θ`), the rigid-body
//! mass matrix is `M₀ = Dᵀ M D` over every DOF the elements reach, constraints ignored. Its
//! translation–rotation block is `−m [c]ₓ` for the centre of gravity `c` (relative to `r₀`),
//! so `c_x = M₀(t_y, θ_z)/m_y`, `c_y = M₀(t_z, θ_x)/m_z`, `c_z = M₀(t_x, θ_y)/m_x`, and the
//! inertia about `c` is `J₀ − m (|c|² I − c cᵀ)` (parallel axes, `m` the x mass).

use super::element::MassKind;
use super::model_assembly::{ModelAssemblyError, assemble_model};
use crate::core::Component;
use crate::core::sparse::sparse_triplets;
use crate::model::Model;

/// A model's rigid-body mass properties.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MassProperties {
    /// The reference point, basic coordinates.
    pub reference: [f64; 3],
    /// `M₀ = Dᵀ M D` about the reference point (`tx ty tz rx ry rz`).
    pub rigid_body_mass: [[f64; 6]; 6],
    /// Mass moving with a translation along x, y, z.
    pub mass: [f64; 3],
    /// Centre of gravity, basic coordinates.
    pub centre_of_gravity: [f64; 3],
    /// Inertia tensor about the centre of gravity, along the basic axes.
    pub inertia: [[f64; 3]; 3],
}

/// The mass properties of `model` about `reference` (basic coordinates), with its constraints
/// ignored (Nastran's weight generator uses the unconstrained mass).
pub fn mass_properties(
    model: &Model,
    mass: MassKind,
    reference: [f64; 3],
) -> Result<MassProperties, ModelAssemblyError> {
    let mut free = model.clone();
    free.constraints.clear();
    let (sys, _) = assemble_model(&free, mass)?;
    // D: one row per DOF, six rigid-body columns.
    let rows: Vec<[f64; 6]> = sys
        .dofs
        .iter()
        .map(|d| {
            let x = model.nodes.get(&d.node).copied().unwrap_or(reference);
            let r = [
                x[0] - reference[0],
                x[1] - reference[1],
                x[2] - reference[2],
            ];
            // u = t + θ × r: ∂u/∂θ = −[r]ₓ.
            let basic = |c: Component| match c {
                Component::Ux => [1.0, 0.0, 0.0, 0.0, r[2], -r[1]],
                Component::Uy => [0.0, 1.0, 0.0, -r[2], 0.0, r[0]],
                Component::Uz => [0.0, 0.0, 1.0, r[1], -r[0], 0.0],
                Component::Rx => [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
                Component::Ry => [0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
                Component::Rz => [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
                // A scalar point has no position: no rigid-body motion moves it (Nastran's
                // weight generator covers grid points only).
                Component::Scalar => [0.0; 6],
            };
            // A component of a displacement system is `Σ_j R[k][j]` times the basic ones.
            let system = model.displacement_systems.get(&d.node);
            let Some(rot) = system.filter(|_| d.comp != Component::Scalar) else {
                return basic(d.comp);
            };
            let k = d.comp as usize;
            let (row, first) = (rot[k % 3], if k < 3 { 0 } else { 3 });
            let mut out = [0.0; 6];
            for (j, w) in row.iter().enumerate() {
                let b = basic(Component::ALL[first + j]);
                for (o, v) in out.iter_mut().zip(b) {
                    *o += w * v;
                }
            }
            out
        })
        .collect();
    let mut m0 = [[0.0; 6]; 6];
    for (i, j, v) in sparse_triplets(&sys.m) {
        for a in 0..6 {
            if rows[i][a] == 0.0 {
                continue;
            }
            for b in 0..6 {
                m0[a][b] += rows[i][a] * v * rows[j][b];
            }
        }
    }
    let mass = [m0[0][0], m0[1][1], m0[2][2]];
    let ratio = |num: f64, den: f64| if den != 0.0 { num / den } else { 0.0 };
    let c = [
        ratio(m0[1][5], mass[1]),
        ratio(m0[2][3], mass[2]),
        ratio(m0[0][4], mass[0]),
    ];
    let c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    let mut inertia = [[0.0; 3]; 3];
    for a in 0..3 {
        for b in 0..3 {
            let delta = if a == b { c2 } else { 0.0 };
            inertia[a][b] = m0[3 + a][3 + b] - mass[0] * (delta - c[a] * c[b]);
        }
    }
    Ok(MassProperties {
        reference,
        rigid_body_mass: m0,
        mass,
        centre_of_gravity: [
            reference[0] + c[0],
            reference[1] + c[1],
            reference[2] + c[2],
        ],
        inertia,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::structure::{Element, Material, ShellProperty};

    /// One CONM2 with an offset and a full inertia tensor: the mass, the centre of gravity at
    /// node + offset, and the inertia about it are the card's, exactly; about another
    /// reference point the rigid-body matrix has the parallel-axis terms.
    #[test]
    fn a_point_mass_gives_its_own_values() {
        let mut m = Model::default();
        m.nodes.insert(1, [1.0, 2.0, 3.0]);
        m.nodes.insert(2, [0.0, 0.0, 0.0]);
        let inertia = [2.0, -0.1, 3.0, 0.2, -0.3, 4.0];
        m.elements.insert(
            1,
            Element::Mass {
                node: 1,
                mass: 5.0,
                inertia,
                offset: [0.5, -0.25, 0.125],
            },
        );
        m.elements.insert(
            2,
            Element::Bush {
                node: 1,
                other: Some(2),
                k: [1.0; 6],
                axes: None,
                b: [0.0; 6],
            },
        );
        let p = mass_properties(&m, MassKind::Consistent, [0.0; 3]).unwrap();
        assert_eq!(p.mass, [5.0; 3]);
        let want = [1.5, 1.75, 3.125];
        for (got, want) in p.centre_of_gravity.iter().zip(want) {
            assert!((got - want).abs() < 1e-14);
        }
        // The CONM2 inertia [I11, I21, I22, I31, I32, I33] with Nastran's sign convention:
        // the tensor's off-diagonal terms are −I21, −I31, −I32.
        let tensor = [[2.0, 0.1, -0.2], [0.1, 3.0, 0.3], [-0.2, 0.3, 4.0]];
        for (got, want) in p.inertia.iter().flatten().zip(tensor.iter().flatten()) {
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
        // About the origin: J₀ = J_c + m (|c|² I − c cᵀ).
        let c = want;
        let c2 = c.iter().map(|x| x * x).sum::<f64>();
        for a in 0..3 {
            for b in 0..3 {
                let d = if a == b { c2 } else { 0.0 };
                let j0 = tensor[a][b] + 5.0 * (d - c[a] * c[b]);
                assert!((p.rigid_body_mass[3 + a][3 + b] - j0).abs() < 1e-11);
            }
        }
    }

    /// A uniform rectangular plate a × b (4 × 3 CQUAD4): mass ρ t a b, centre at its middle,
    /// and I_zz = m (a² + b²)/12 plus the shell's rotary inertia (ρ t³/12 per area on θz),
    /// exactly for the consistent mass (bilinear fields integrate x² exactly), and for the
    /// lumped mass with the trapezoidal rule's known excess.
    #[test]
    fn a_uniform_plate_matches_the_analytic_values() {
        let (a, b, t, rho) = (0.8, 0.6, 0.01, 2700.0);
        let (nx, ny) = (4, 3);
        let mut m = Model::default();
        for j in 0..=ny {
            for i in 0..=nx {
                let id = (1 + i + (nx + 1) * j) as u64;
                m.nodes.insert(
                    id,
                    [a * i as f64 / nx as f64, b * j as f64 / ny as f64, 0.0],
                );
            }
        }
        m.materials.insert(
            1,
            Material {
                e: 7e10,
                nu: 0.3,
                rho,
            },
        );
        m.shell_properties
            .insert(1, ShellProperty::homogeneous(1, t, 0.0));
        let mut eid = 1;
        for j in 0..ny {
            for i in 0..nx {
                let n = |i: usize, j: usize| (1 + i + (nx + 1) * j) as u64;
                m.elements.insert(
                    eid,
                    Element::Quad4 {
                        nodes: [n(i, j), n(i + 1, j), n(i + 1, j + 1), n(i, j + 1)],
                        property: 1,
                    },
                );
                eid += 1;
            }
        }
        let mass = rho * t * a * b;
        let izz = mass * (a * a + b * b) / 12.0 + rho * t.powi(3) / 12.0 * a * b;
        let p = mass_properties(&m, MassKind::Consistent, [0.0; 3]).unwrap();
        for d in 0..3 {
            assert!((p.mass[d] - mass).abs() < 1e-12 * mass);
        }
        let cg = p.centre_of_gravity;
        assert!((cg[0] - a / 2.0).abs() < 1e-12 && (cg[1] - b / 2.0).abs() < 1e-12);
        assert!(
            (p.inertia[2][2] - izz).abs() < 1e-12 * izz,
            "{}",
            p.inertia[2][2]
        );
        let lumped = mass_properties(&m, MassKind::Lumped, [0.0; 3]).unwrap();
        assert!((lumped.mass[2] - mass).abs() < 1e-12 * mass);
        // Nodal lumping (the trapezoidal rule) overestimates ∫ x² dm by m h²/6 per direction
        // (h the element size): over [x₀, x₀ + h], h (x₀² + x₁²)/2 − h (x₀² + x₀x₁ + x₁²)/3 = h³/6.
        let (hx, hy) = (a / nx as f64, b / ny as f64);
        let excess = mass * (hx * hx + hy * hy) / 6.0;
        assert!(
            (lumped.inertia[2][2] - izz - excess).abs() < 1e-9 * izz,
            "{} vs {}",
            lumped.inertia[2][2],
            izz + excess
        );
    }
}
