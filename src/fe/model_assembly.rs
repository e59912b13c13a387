//! From a [`Model`] to `K` and `M`: each element's kernel (shell, beam, spring, mass) evaluated
//! in parallel and scattered by [`assemble`](super::assembly::assemble).

use super::assembly::{AssemblyInfo, Contribution, assemble, node_index};
use super::beam::{BeamData, Section, beam2};
use super::element::{ElementError, ElementMatrices, MassKind};
use super::lumped_elements::{LumpedMass, SpringEnds, conm2, scalar_spring, spring6};
use super::shell::{ShellSection, quad4, tria3};
use super::system::SystemMatrices;
use crate::model::{BeamSection, Element, Model, ModelError};
use faer::Mat;
use std::collections::BTreeSet;

/// Why a model could not be assembled.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelAssemblyError {
    /// A reference in the model is broken.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// An element could not be formed.
    #[error("element {element} ({kind}): {source}")]
    Element {
        /// Element id.
        element: u64,
        /// Element type.
        kind: &'static str,
        /// The kernel's reason.
        source: ElementError,
    },
    /// The model has no element.
    #[error("the model has no elements")]
    Empty,
}

/// The kernel section of a model beam section (shear factor 0 in a general section: shear-rigid).
pub fn kernel_section(s: &BeamSection) -> Section {
    match *s {
        BeamSection::Rectangle { width, height } if width == height => {
            Section::Square { side: width }
        }
        BeamSection::Rectangle { width, height } => Section::Rectangle { width, height },
        BeamSection::Circle { radius } => Section::Circle { radius },
        BeamSection::Tube {
            outer_radius,
            inner_radius,
        } => Section::Tube {
            outer_radius,
            inner_radius,
        },
        BeamSection::General {
            area,
            iy,
            iz,
            j,
            shear_y,
            shear_z,
        } => Section::General {
            area,
            iy,
            iz,
            j,
            shear_y: (shear_y > 0.0).then_some(shear_y),
            shear_z: (shear_z > 0.0).then_some(shear_z),
        },
    }
}

/// The kernel section of shell property `property` (references already validated).
fn shell_section(model: &Model, property: u64) -> ShellSection {
    let p = &model.shell_properties[&property];
    let mat = &model.materials[&p.material];
    ShellSection {
        thickness: p.thickness,
        e: mat.e,
        nu: mat.nu,
        rho: mat.rho,
        nsm: p.nsm,
    }
}

/// Element matrices of one element of `model` (references already validated).
pub fn element_matrices(
    model: &Model,
    e: &Element,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    let xyz = |n: &u64| model.nodes[n];
    match e {
        Element::Quad4 { nodes, property } => quad4(
            &nodes.each_ref().map(xyz),
            &shell_section(model, *property),
            mass,
        ),
        Element::Tria3 { nodes, property } => tria3(
            &nodes.each_ref().map(xyz),
            &shell_section(model, *property),
            mass,
        ),
        Element::Beam {
            nodes,
            property,
            orientation,
        } => {
            let p = &model.beam_properties[property];
            let mat = &model.materials[&p.material];
            let d = BeamData {
                e: mat.e,
                nu: mat.nu,
                rho: mat.rho,
                nsm: p.nsm,
                section: kernel_section(&p.section),
            };
            beam2(xyz(&nodes[0]), xyz(&nodes[1]), *orientation, &d, mass)
        }
        Element::Bush { other, k, .. } => spring6(
            k,
            if other.is_some() {
                SpringEnds::TwoNodes
            } else {
                SpringEnds::Ground
            },
        ),
        Element::ScalarSpring { dof, other, k } => {
            let ends = if other.is_some() {
                SpringEnds::TwoNodes
            } else {
                SpringEnds::Ground
            };
            let small = scalar_spring(*k, ends)?;
            // Expand the 2×2 (or 1×1) DOF matrix onto the node blocks of `Element::nodes`.
            let comps: Vec<(usize, usize)> = match other {
                Some(o) if o.node == dof.node => vec![(0, dof.comp as usize), (0, o.comp as usize)],
                Some(o) => vec![(0, dof.comp as usize), (1, o.comp as usize)],
                None => vec![(0, dof.comp as usize)],
            };
            let nn = if matches!(other, Some(o) if o.node != dof.node) {
                2
            } else {
                1
            };
            let mut kk = Mat::zeros(6 * nn, 6 * nn);
            for (a, (na, ca)) in comps.iter().enumerate() {
                for (b, (nb, cb)) in comps.iter().enumerate() {
                    kk[(6 * na + ca, 6 * nb + cb)] += small.k[(a, b)];
                }
            }
            Ok(ElementMatrices {
                m: Mat::zeros(6 * nn, 6 * nn),
                k: kk,
            })
        }
        Element::Mass {
            mass: m,
            inertia,
            offset,
            ..
        } => conm2(&LumpedMass::from_nastran(*m, *offset, *inertia)),
    }
}

/// The distinct nodes of an element in the order of its matrix blocks.
fn block_nodes(e: &Element) -> Vec<u64> {
    let mut nodes = e.nodes();
    if let Element::ScalarSpring {
        dof,
        other: Some(o),
        ..
    } = e
    {
        if o.node == dof.node {
            nodes.truncate(1);
        }
    }
    nodes
}

/// Assembles `K` and `M` of a model over its free DOFs.
pub fn assemble_model(
    model: &Model,
    mass: MassKind,
) -> Result<(SystemMatrices, AssemblyInfo), ModelAssemblyError> {
    model.validate()?;
    if model.elements.is_empty() {
        return Err(ModelAssemblyError::Empty);
    }
    let node_ids: Vec<u64> = model.nodes.keys().copied().collect();
    let index = node_index(&node_ids);
    let elements: Vec<(u64, &Element)> = model.elements.iter().map(|(id, e)| (*id, e)).collect();
    let lists: Vec<Vec<usize>> = elements
        .iter()
        .map(|(_, e)| block_nodes(e).iter().map(|n| index[n]).collect())
        .collect();
    let constraints: BTreeSet<_> = model.constraints.iter().copied().collect();
    assemble(&node_ids, &lists, &constraints, |i| {
        let (id, e) = elements[i];
        let matrices =
            element_matrices(model, e, mass).map_err(|source| ModelAssemblyError::Element {
                element: id,
                kind: e.type_name(),
                source,
            })?;
        Ok(Contribution {
            nodes: lists[i].clone(),
            matrices,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
    use crate::model::generate::{
        BentPlate, FlatPlate, PlateSupport, ThreeBeam, bent_plate, flat_plate, three_beam,
    };

    /// NAFEMS FV16 (cantilevered thin square plate, 10 m, t = 0.05 m, E = 200 GPa, ν = 0.3,
    /// ρ = 8000) through the whole chain: generator, sparse assembly, sparse eigensolver.
    /// A 24×24 mesh (3750 free DOFs) is within 1 % of every reference frequency.
    #[test]
    fn fv16_through_the_sparse_path() {
        let model = flat_plate(&FlatPlate {
            a: 10.0,
            b: 10.0,
            nx: 24,
            ny: 24,
            thickness: 0.05,
            material: crate::model::Material {
                e: 200e9,
                nu: 0.3,
                rho: 8000.0,
            },
            support: PlateSupport::ClampedEdge,
        });
        let (sys, info) = assemble_model(&model, MassKind::Consistent).unwrap();
        assert_eq!(info.free_dofs, 6 * 25 * 24);
        sys.validate().unwrap();
        let (modes, einfo) = lowest_modes(
            &sys.k,
            &sys.m,
            &sys.dofs,
            ModeSelection::Count(6),
            &SparseEigenParams::default(),
        )
        .unwrap();
        assert!(!einfo.dense);
        let reference = [0.421, 1.029, 2.582, 3.306, 3.753, 6.555];
        for (f, r) in modes.frequencies_hz().iter().zip(reference) {
            assert!(((f - r) / r).abs() < 0.01, "{f} vs {r}");
        }
        assert!(
            modes.residuals.iter().all(|r| *r < 1e-8),
            "{:?}",
            modes.residuals
        );
        assert!(modes.orthogonality_error < 1e-10);
    }

    #[test]
    fn free_bent_plate_has_six_rigid_modes_and_conserves_mass() {
        let model = bent_plate(&BentPlate::default());
        let (sys, info) = assemble_model(&model, MassKind::Consistent).unwrap();
        assert_eq!(info.free_dofs, 864);
        sys.validate().unwrap();
        let (modes, _) = lowest_modes(
            &sys.k,
            &sys.m,
            &sys.dofs,
            ModeSelection::Count(12),
            &SparseEigenParams::default(),
        )
        .unwrap();
        assert_eq!(modes.rigid_body_modes, 6);
        // Total mass: u_xᵀ M u_x for a unit translation = plates + bar.
        let ux: Vec<f64> = sys
            .dofs
            .iter()
            .map(|d| {
                if d.comp == crate::core::Component::Ux {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let md = sys.m_dense();
        let total: f64 = (0..ux.len())
            .flat_map(|i| (0..ux.len()).map(move |j| (i, j)))
            .map(|(i, j)| ux[i] * md[(i, j)] * ux[j])
            .sum();
        let bar_len = {
            let (a, b) = (model.nodes[&1], model.nodes[&(15 * 8)]);
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        };
        let expected = 7850.0 * (2.0 * 0.3125 * 0.3 * 1.4e-3 + 5.5e-3 * 5.5e-3 * bar_len);
        assert!(
            ((total - expected) / expected).abs() < 1e-12,
            "{total} vs {expected}"
        );
    }

    #[test]
    fn three_beam_assembles_with_springs_and_masses() {
        let (sys, _) =
            assemble_model(&three_beam(&ThreeBeam::default()), MassKind::Consistent).unwrap();
        assert_eq!(sys.n(), 648);
        let (modes, _) = lowest_modes(
            &sys.k,
            &sys.m,
            &sys.dofs,
            ModeSelection::Count(5),
            &SparseEigenParams::default(),
        )
        .unwrap();
        assert_eq!(modes.rigid_body_modes, 0, "clamp springs hold the assembly");
        assert!(modes.frequencies_hz()[0] > 1.0);
    }

    #[test]
    fn a_bad_element_is_named() {
        let mut model = flat_plate(&FlatPlate {
            a: 1.0,
            b: 1.0,
            nx: 2,
            ny: 2,
            thickness: 0.01,
            material: crate::model::generate::steel(),
            support: PlateSupport::Free,
        });
        model.nodes.insert(5, model.nodes[&1]);
        let e = assemble_model(&model, MassKind::Consistent)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("element 1 (quad4)") || e.contains("element"),
            "{e}"
        );
    }
}
