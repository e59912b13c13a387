//! From a [`Model`] to `K` and `M`: each element's kernel (shell, beam, rod, spring, mass)
//! evaluated in parallel and scattered by [`assemble`](super::assembly::assemble).

use super::assembly::{AssemblyInfo, Contribution, Scattered, node_index, scatter};
use super::beam::{BeamData, EndConditions, Section, beam2_centred};
use super::beam_offset::SectionCentres;
use super::beam_tapered::{
    PropertyTaper, TaperedBeam, TaperedRod, tapered_beam2_centred, tapered_rod2,
};
use super::element::{ElementError, ElementMatrices, MassKind};
use super::lumped_elements::{LumpedMass, SpringEnds, conm2, scalar_spring, spring6};
use super::multipoint::{DependentDof, MultipointError, eliminate, independent_dofs, resolve};
use super::shell::{ShellSection, quad4, tria3};
use super::shell_quadratic::{quad8, quadratic_geometry, tria6};
use super::system::{LowerSystem, SystemMatrices};
use crate::core::sparse::SparseMatrix;
use crate::model::{BeamEnds, BeamProperty, BeamSection, Element, Model, ModelError};
use faer::Mat;
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet};

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
    /// Multipoint constraints could not be eliminated.
    #[error(transparent)]
    Multipoint(#[from] MultipointError),
    /// Every DOF that an element reaches is constrained.
    #[error(
        "the model has no free DOFs: its {constrained} constrained DOFs include every DOF its elements reach; remove constraints (SPC, `constraints:`) so that something can move"
    )]
    NoFreeDofs {
        /// The constrained DOFs the elements reach.
        constrained: usize,
    },
    /// A parameter's set holds an element the parameter cannot act on.
    #[error(
        "parameter `{parameter}` ({what}) cannot act on element {element} ({kind}) of its set; remove the element from the set or choose another parameter kind"
    )]
    NotApplicable {
        /// Parameter name.
        parameter: String,
        /// What the parameter changes.
        what: String,
        /// Element id.
        element: u64,
        /// Element type.
        kind: &'static str,
    },
}

impl crate::core::InputFault for ModelAssemblyError {
    fn is_input(&self) -> bool {
        true
    }
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

/// The kernel's centroid and NSM offsets from the shear centre of a model beam property (zero
/// when it has none).
pub fn kernel_centres(p: &BeamProperty) -> SectionCentres {
    p.centres
        .as_ref()
        .map_or_else(SectionCentres::default, |c| SectionCentres {
            neutral_axis: c.neutral_axis,
            nsm_cg: c.nsm_cg,
            nsi: c.nsi,
        })
}

/// The kernel's end conditions of a model beam's ends (pin codes such as 456 → released DOFs).
pub fn kernel_ends(e: &BeamEnds) -> Result<EndConditions, ElementError> {
    let pins = |code: u32| {
        BeamEnds::released(code).ok_or(ElementError::BadValue {
            field: "pin flag",
            value: code as f64,
            hint: "digits 1-6, each at most once",
        })
    };
    Ok(EndConditions {
        offset_a: e.offset_a,
        offset_b: e.offset_b,
        released_a: pins(e.pin_a)?,
        released_b: pins(e.pin_b)?,
    })
}

/// The kernel section of shell property `property` (references already validated).
fn shell_section(model: &Model, property: u64) -> ShellSection {
    use super::shell::{LayerMaterial, ShellLayers};
    let p = &model.shell_properties[&property];
    let mat = &model.materials[&p.material];
    let layer = |mid: u64| {
        if mid == p.material {
            LayerMaterial::Own
        } else {
            let m = &model.materials[&mid];
            LayerMaterial::Other { e: m.e, nu: m.nu }
        }
    };
    ShellSection {
        thickness: p.thickness,
        e: mat.e,
        nu: mat.nu,
        rho: mat.rho,
        nsm: p.nsm,
        layers: (!p.is_homogeneous()).then(|| ShellLayers {
            membrane: p.membrane,
            bending: p.bending.then(|| layer(p.bending_mid())),
            shear: layer(p.shear_mid()),
            bending_ratio: p.bending_ratio,
            shear_ratio: p.shear_ratio,
        }),
    }
}

/// The kernel data of a rod of `model` (references already validated).
fn rod_data(model: &Model, section: &crate::model::RodSection) -> super::rod::RodData {
    let p = match section {
        crate::model::RodSection::Property(id) => &model.rod_properties[id],
        crate::model::RodSection::Own(p) => p,
    };
    let mat = &model.materials[&p.material];
    super::rod::RodData {
        e: mat.e,
        nu: mat.nu,
        rho: mat.rho,
        area: p.area,
        j: p.j,
        nsm: p.nsm,
    }
}

/// `f` of a tapered tube (PTUBE with OD2 ≠ OD) as the kernel reads it; `None` for a uniform rod.
fn with_tapered_rod<R>(
    model: &Model,
    section: &crate::model::RodSection,
    f: impl FnOnce(&TaperedRod) -> R,
) -> Option<R> {
    let p = match section {
        crate::model::RodSection::Property(id) => &model.rod_properties[id],
        crate::model::RodSection::Own(p) => p,
    };
    let taper = p.taper?;
    let d = rod_data(model, section);
    let at = |xi: f64| {
        let (area, j) = taper.at(xi);
        (area, j, p.nsm)
    };
    Some(f(&TaperedRod {
        e: d.e,
        nu: d.nu,
        rho: d.rho,
        at: &at,
    }))
}

/// The kernel material of solid property `property` (references already validated): a MAT1's
/// isotropic `D`, or a MAT9's `G` turned from the property's material axes to basic.
pub fn solid_material(
    model: &Model,
    property: u64,
) -> Result<super::solid::SolidMaterial, ElementError> {
    let p = &model.solid_properties[&property];
    if let Some(m) = model.materials.get(&p.material) {
        return Ok(super::solid::SolidMaterial {
            d: super::solid::isotropic(m.e, m.nu)?,
            rho: m.rho,
        });
    }
    let m = &model.anisotropic_materials[&p.material];
    let g = m.matrix();
    Ok(super::solid::SolidMaterial {
        d: match &p.axes {
            Some(axes) => super::solid::rotate_to_basic(&g, axes),
            None => g,
        },
        rho: m.rho,
    })
}

/// Element matrices of element `id` of `model` (references already validated), with its
/// shell placement (THETA/MCID, ZOFFS) if it has one, over the DOFs of its nodes' displacement
/// systems.
pub fn element_matrices_with_id(
    model: &Model,
    id: u64,
    e: &Element,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    element_matrices_at(model, Some(id), e, mass)
}

/// [`element_matrices_with_id`], its error naming the element and its kind.
pub fn named_element_matrices(
    model: &Model,
    id: u64,
    e: &Element,
    mass: MassKind,
) -> Result<ElementMatrices, ModelAssemblyError> {
    element_matrices_with_id(model, id, e, mass).map_err(|source| ModelAssemblyError::Element {
        element: id,
        kind: e.type_name(),
        source,
    })
}

/// Element matrices of one element of `model` (references already validated), over the DOFs of
/// its nodes' displacement systems. A shell of a model with shell placements needs its id:
/// [`element_matrices_with_id`].
pub fn element_matrices(
    model: &Model,
    e: &Element,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    element_matrices_at(model, None, e, mass)
}

fn element_matrices_at(
    model: &Model,
    id: Option<u64>,
    e: &Element,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    let mut m = basic_element_matrices(model, id, e, mass)?;
    to_displacement_systems(model, e, &mut m.k);
    to_displacement_systems(model, e, &mut m.m);
    Ok(m)
}

/// Whether an element's matrix is already over the DOFs it names (a scalar element joins
/// components of the grids' displacement systems, as Nastran's CELAS do), rather than over
/// basic components at its nodes.
fn acts_on_named_dofs(e: &Element) -> bool {
    matches!(
        e,
        Element::ScalarSpring { .. } | Element::ScalarMass { .. } | Element::ScalarDamper { .. }
    )
}

/// Turns an element matrix over basic components at its nodes into one over the components of
/// the nodes' displacement systems: `A ← T A Tᵀ` with `T` block-diagonal, `R` (rows: the local
/// axes in basic) on the translations and on the rotations of each node that has a system
/// (`u_local = R u_basic`), the identity elsewhere. Symmetric in, symmetric out (the two
/// triangles are averaged so that round-off keeps no asymmetry).
pub(crate) fn to_displacement_systems(model: &Model, e: &Element, a: &mut Mat<f64>) {
    if model.displacement_systems.is_empty() || acts_on_named_dofs(e) {
        return;
    }
    let systems: Vec<(usize, &[[f64; 3]; 3])> = block_nodes(e)
        .iter()
        .enumerate()
        .filter_map(|(b, n)| model.displacement_systems.get(n).map(|r| (b, r)))
        .collect();
    if systems.is_empty() {
        return;
    }
    let n = a.nrows();
    for &(b, r) in &systems {
        for start in [6 * b, 6 * b + 3] {
            if start + 3 > n {
                continue;
            }
            // Rows: A[start..start+3, :] ← R A[start..start+3, :].
            for j in 0..n {
                let v = [a[(start, j)], a[(start + 1, j)], a[(start + 2, j)]];
                for (i, row) in r.iter().enumerate() {
                    a[(start + i, j)] = row[0] * v[0] + row[1] * v[1] + row[2] * v[2];
                }
            }
            // Columns: A[:, start..start+3] ← A[:, start..start+3] Rᵀ.
            for i in 0..n {
                let v = [a[(i, start)], a[(i, start + 1)], a[(i, start + 2)]];
                for (j, row) in r.iter().enumerate() {
                    a[(i, start + j)] = row[0] * v[0] + row[1] * v[1] + row[2] * v[2];
                }
            }
        }
    }
    for i in 0..n {
        for j in 0..i {
            let s = 0.5 * (a[(i, j)] + a[(j, i)]);
            a[(i, j)] = s;
            a[(j, i)] = s;
        }
    }
}

/// [`element_matrices`] over basic components at the element's nodes.
fn basic_element_matrices(
    model: &Model,
    id: Option<u64>,
    e: &Element,
    mass: MassKind,
) -> Result<ElementMatrices, ElementError> {
    let xyz = |n: &u64| model.nodes[n];
    if let Element::Quad4 { property, .. } | Element::Tria3 { property, .. } = e {
        if id.is_none() && !model.shell_placements.is_empty() {
            return Err(ElementError::Degenerate(
                "internal: a shell of a model with THETA/MCID/ZOFFS placements is formed without its element id (use element_matrices_with_id)".into(),
            ));
        }
        let p = &model.shell_properties[property];
        if super::laminate::uses_general(model, id, p) {
            let xyz: Vec<[f64; 3]> = e.nodes().iter().map(xyz).collect();
            return super::laminate::general_shell_matrices(model, id, &xyz, *property, mass);
        }
    }
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
        Element::Quad8 {
            corners,
            midside,
            property,
        } => {
            let (x, present) = quadratic_geometry(
                &corners.each_ref().map(xyz),
                &midside.map(|m| m.map(|n| xyz(&n))),
            );
            quad8(&x, present, &shell_section(model, *property), mass)
        }
        Element::Tria6 {
            corners,
            midside,
            property,
        } => {
            let (x, present) = quadratic_geometry(
                &corners.each_ref().map(xyz),
                &midside.map(|m| m.map(|n| xyz(&n))),
            );
            tria6(&x, present, &shell_section(model, *property), mass)
        }
        Element::Beam {
            nodes,
            property,
            orientation,
            ends,
        } => {
            let p = &model.beam_properties[property];
            let mat = &model.materials[&p.material];
            if let Some(taper) = PropertyTaper::new(p, mat.nu) {
                let b = TaperedBeam {
                    e: mat.e,
                    nu: mat.nu,
                    rho: mat.rho,
                    taper: &taper,
                };
                return tapered_beam2_centred(
                    xyz(&nodes[0]),
                    xyz(&nodes[1]),
                    *orientation,
                    &b,
                    mass,
                    &kernel_ends(ends)?,
                    &kernel_centres(p),
                );
            }
            let d = BeamData {
                e: mat.e,
                nu: mat.nu,
                rho: mat.rho,
                nsm: p.nsm,
                section: kernel_section(&p.section),
            };
            beam2_centred(
                xyz(&nodes[0]),
                xyz(&nodes[1]),
                *orientation,
                &d,
                mass,
                &kernel_ends(ends)?,
                &kernel_centres(p),
            )
        }
        Element::Rod { nodes, section } => with_tapered_rod(model, section, |r| {
            tapered_rod2(xyz(&nodes[0]), xyz(&nodes[1]), r, mass)
        })
        .unwrap_or_else(|| {
            super::rod::rod2(
                xyz(&nodes[0]),
                xyz(&nodes[1]),
                &rod_data(model, section),
                mass,
            )
        }),
        Element::Solid {
            kind,
            nodes,
            property,
        } => {
            let xyz: Vec<[f64; 3]> = nodes.iter().map(xyz).collect();
            super::solid::solid(*kind, &xyz, &solid_material(model, *property)?, mass)
        }
        Element::Bush { other, k, axes, .. } => {
            let ends = if other.is_some() {
                SpringEnds::TwoNodes
            } else {
                SpringEnds::Ground
            };
            match axes {
                None => spring6(k, ends),
                Some(axes) => {
                    spring6(k, ends)?;
                    let kk = super::scalar_elements::bush_matrix(k, Some(axes), ends)?;
                    Ok(ElementMatrices {
                        m: Mat::zeros(kk.nrows(), kk.ncols()),
                        k: kk,
                    })
                }
            }
        }
        Element::ScalarSpring { dof, other, k } => {
            let small = scalar_spring(*k, scalar_ends(other))?;
            let kk = expand_scalar(dof, other, &small.k);
            Ok(ElementMatrices {
                m: Mat::zeros(kk.nrows(), kk.ncols()),
                k: kk,
            })
        }
        Element::ScalarMass { dof, other, m } => {
            let small = super::scalar_elements::scalar_mass(*m, scalar_ends(other))?;
            let mm = expand_scalar(dof, other, &small.m);
            Ok(ElementMatrices {
                k: Mat::zeros(mm.nrows(), mm.ncols()),
                m: mm,
            })
        }
        Element::ScalarDamper { other, c, .. } => {
            // No stiffness or mass: the damping is assembled by `fe::damping`.
            super::scalar_elements::scalar_damper(*c, scalar_ends(other))?;
            let n = 6 * block_nodes(e).len();
            Ok(ElementMatrices {
                k: Mat::zeros(n, n),
                m: Mat::zeros(n, n),
            })
        }
        Element::Viscous {
            nodes,
            axial,
            torsional,
        } => {
            super::scalar_elements::viscous(xyz(&nodes[0]), xyz(&nodes[1]), *axial, *torsional)?;
            Ok(ElementMatrices {
                k: Mat::zeros(12, 12),
                m: Mat::zeros(12, 12),
            })
        }
        Element::GeneralMass { m, .. } => super::scalar_elements::general_mass(m),
        Element::Mass {
            mass: m,
            inertia,
            offset,
            ..
        } => conm2(&LumpedMass::from_nastran(*m, *offset, *inertia)),
    }
}

/// Two DOFs or one to ground.
fn scalar_ends(other: &Option<crate::core::DofId>) -> SpringEnds {
    if other.is_some() {
        SpringEnds::TwoNodes
    } else {
        SpringEnds::Ground
    }
}

/// A scalar element's 2×2 (or 1×1) DOF matrix expanded onto the 6-DOF blocks of its distinct
/// points (a scalar point's DOF is slot 0 of its block).
pub(crate) fn expand_scalar(
    dof: &crate::core::DofId,
    other: &Option<crate::core::DofId>,
    small: &Mat<f64>,
) -> Mat<f64> {
    let comps: Vec<(usize, usize)> = match other {
        Some(o) if o.node == dof.node => vec![(0, dof.comp.slot()), (0, o.comp.slot())],
        Some(o) => vec![(0, dof.comp.slot()), (1, o.comp.slot())],
        None => vec![(0, dof.comp.slot())],
    };
    let nn = if matches!(other, Some(o) if o.node != dof.node) {
        2
    } else {
        1
    };
    let mut out = Mat::zeros(6 * nn, 6 * nn);
    for (a, (na, ca)) in comps.iter().enumerate() {
        for (b, (nb, cb)) in comps.iter().enumerate() {
            out[(6 * na + ca, 6 * nb + cb)] += small[(a, b)];
        }
    }
    out
}

/// The distinct nodes of an element in the order of its matrix blocks.
pub(crate) fn block_nodes(e: &Element) -> Vec<u64> {
    let mut nodes = e.nodes();
    if let Some((dof, Some(o))) = e.scalar_dofs()
        && o.node == dof.node
    {
        nodes.truncate(1);
    }
    nodes
}

/// The DOF of each row of an element's matrices (6 per block; `None` for the five unused slots
/// of a scalar point's block).
pub(crate) fn block_dofs(model: &Model, e: &Element) -> Vec<Option<crate::core::DofId>> {
    use crate::core::{Component, DofId};
    block_nodes(e)
        .into_iter()
        .flat_map(|n| {
            let scalar = model.is_scalar_point(n);
            (0..6).map(move |i| match (scalar, i) {
                (true, 0) => Some(DofId::new(n, Component::Scalar)),
                (true, _) => None,
                (false, i) => Some(DofId::new(n, Component::ALL[i])),
            })
        })
        .collect()
}

/// Grid and scalar point ids, sorted: the blocks of an assembly.
fn point_ids(model: &Model) -> Vec<u64> {
    if model.scalar_points.is_empty() {
        return model.nodes.keys().copied().collect();
    }
    let mut ids: Vec<u64> = model
        .nodes
        .keys()
        .chain(model.scalar_points.iter())
        .copied()
        .collect();
    ids.sort_unstable();
    ids
}

/// Assembles `K` and `M` of a model over its free DOFs.
pub fn assemble_model(
    model: &Model,
    mass: MassKind,
) -> Result<(SystemMatrices, AssemblyInfo), ModelAssemblyError> {
    let p = Prepared::of(model)?;
    let (sys, info) = p.without_dependent(p.scatter(mass)?.full())?;
    p.some_free(&sys.dofs)?;
    Ok((sys, info))
}

/// [`assemble_model`]'s `K` and `M` as lower triangles (what the matrices artefact stores):
/// gathered straight from the scatter, or, when multipoint constraints eliminate DOFs, from
/// the full matrices the elimination works on.
pub fn assemble_model_lower(
    model: &Model,
    mass: MassKind,
) -> Result<(LowerSystem, AssemblyInfo), ModelAssemblyError> {
    let p = Prepared::of(model)?;
    let scattered = p.scatter(mass)?;
    let (sys, info) = if p.dependents.is_empty() {
        scattered.lower()
    } else {
        let (sys, info) = p.without_dependent(scattered.full())?;
        (LowerSystem::of(&sys), info)
    };
    p.some_free(&sys.dofs)?;
    Ok((sys, info))
}

/// What an assembly of a model's elements (all of them, or a substructure's) needs before the
/// scatter: the points, each element's blocks, the constraints at those points and the
/// multipoint constraints resolved.
struct Prepared<'m> {
    /// The model.
    model: &'m Model,
    /// Grid and scalar point ids, sorted.
    node_ids: Vec<u64>,
    /// The elements, in id order.
    elements: Vec<(u64, &'m Element)>,
    /// Each element's blocks, as indices into `node_ids`.
    lists: Vec<Vec<usize>>,
    /// Single-point constraints at the points.
    constraints: BTreeSet<crate::core::DofId>,
    /// The dependent DOFs of multipoint constraints.
    dependents: BTreeMap<crate::core::DofId, DependentDof>,
    /// DOFs kept even without stiffness or mass (independent DOFs of multipoint constraints).
    keep: BTreeSet<crate::core::DofId>,
}

impl<'m> Prepared<'m> {
    /// The whole model, checked.
    fn of(model: &'m Model) -> Result<Self, ModelAssemblyError> {
        model.validate()?;
        if model.elements.is_empty() {
            return Err(ModelAssemblyError::Empty);
        }
        let elements = model.elements.iter().map(|(id, e)| (*id, e)).collect();
        Self::on_points(model, elements, point_ids(model))
    }

    /// `elements` of `model` on the points `node_ids` (sorted, every element's points among
    /// them), with the model's constraints at those points.
    fn on_points(
        model: &'m Model,
        elements: Vec<(u64, &'m Element)>,
        node_ids: Vec<u64>,
    ) -> Result<Self, ModelAssemblyError> {
        let index = node_index(&node_ids);
        let lists: Vec<Vec<usize>> = elements
            .par_iter()
            .map(|(_, e)| block_nodes(e).iter().map(|n| index[n]).collect())
            .collect();
        // Multipoint constraints are resolved against all the model's constraints.
        let all_constraints: BTreeSet<_> = model.constraints.iter().copied().collect();
        let dependents = resolve(&model.mpcs, &all_constraints)?;
        let keep = independent_dofs(&dependents);
        let constraints = all_constraints
            .into_iter()
            .filter(|d| index.contains_key(&d.node))
            .collect();
        Ok(Self {
            model,
            node_ids,
            elements,
            lists,
            constraints,
            dependents,
            keep,
        })
    }

    /// Every element's matrices scattered, the free DOFs chosen.
    fn scatter(&self, mass: MassKind) -> Result<Scattered, ModelAssemblyError> {
        let contribution = |i: usize| {
            let (id, e) = self.elements[i];
            Ok(Contribution {
                nodes: self.lists[i].clone(),
                matrices: named_element_matrices(self.model, id, e, mass)?,
            })
        };
        scatter(
            &self.node_ids,
            &self.model.scalar_points,
            &self.lists,
            &self.constraints,
            &self.keep,
            contribution,
        )
    }

    /// The assembled `(system, info)` with the multipoint constraints' dependent DOFs
    /// eliminated ([`without_dependent`]).
    fn without_dependent(
        &self,
        (sys, info): (SystemMatrices, AssemblyInfo),
    ) -> Result<(SystemMatrices, AssemblyInfo), ModelAssemblyError> {
        without_dependent(sys, info, &self.dependents, &self.node_ids)
    }

    /// An error when no DOF is left free.
    fn some_free(&self, dofs: &[crate::core::DofId]) -> Result<(), ModelAssemblyError> {
        if dofs.is_empty() {
            return Err(ModelAssemblyError::NoFreeDofs {
                constrained: self.constraints.len(),
            });
        }
        Ok(())
    }
}

/// The assembled system with the dependent DOFs of multipoint constraints eliminated
/// ([`eliminate`], `K̃ = Tᵀ K T`), the expansion of the dependent DOFs of `nodes` recorded in the
/// info; unchanged without constraints.
fn without_dependent(
    sys: SystemMatrices,
    mut info: AssemblyInfo,
    dependents: &BTreeMap<crate::core::DofId, DependentDof>,
    node_ids: &[u64],
) -> Result<(SystemMatrices, AssemblyInfo), ModelAssemblyError> {
    if dependents.is_empty() {
        return Ok((sys, info));
    }
    let nodes: BTreeSet<u64> = node_ids.iter().copied().collect();
    let e = eliminate(&sys, dependents, &nodes)?;
    info.auto_constrained.extend(e.dropped);
    info.auto_constrained.sort();
    info.free_dofs = e.system.n();
    info.nnz = e.system.k.compute_nnz();
    info.dependent = e.dependent;
    Ok((e.system, info))
}

/// The DOFs to which element `e` gives stiffness or mass (non-zero diagonal), unconstrained or
/// not: exactly the DOFs it adds to an assembly's free set.
pub fn element_dofs(
    model: &Model,
    id: u64,
    e: &Element,
    mass: MassKind,
) -> Result<Vec<crate::core::DofId>, ModelAssemblyError> {
    let m = named_element_matrices(model, id, e, mass)?;
    let mut out = Vec::new();
    for (i, d) in block_dofs(model, e).into_iter().enumerate() {
        if let Some(d) = d
            && i < m.k.nrows()
            && (m.k[(i, i)] != 0.0 || m.m[(i, i)] != 0.0)
        {
            out.push(d);
        }
    }
    Ok(out)
}

/// Assembles `K` and `M` of only the elements `ids` of `model` over the DOFs of their nodes
/// (a substructure, docs/theory.md §9): constraints of the model apply, DOFs without stiffness and
/// mass in these elements are dropped. Element ids absent from the model are an error.
pub fn assemble_elements(
    model: &Model,
    ids: &[u64],
    mass: MassKind,
) -> Result<(SystemMatrices, AssemblyInfo), ModelAssemblyError> {
    model.validate()?;
    if ids.is_empty() {
        return Err(ModelAssemblyError::Empty);
    }
    let mut elements: Vec<(u64, &Element)> = Vec::with_capacity(ids.len());
    for id in ids {
        let e = model.elements.get(id).ok_or_else(|| {
            ModelAssemblyError::Model(ModelError::MissingSetElement {
                set: "substructure".into(),
                element: *id,
            })
        })?;
        elements.push((*id, e));
    }
    let node_ids: Vec<u64> = elements
        .iter()
        .flat_map(|(_, e)| e.nodes())
        .collect::<BTreeSet<u64>>()
        .into_iter()
        .collect();
    let p = Prepared::on_points(model, elements, node_ids)?;
    p.without_dependent(p.scatter(mass)?.full())
}

/// `∂K/∂φ` and `∂M/∂φ` of one updating parameter over the free DOFs `dofs` of an assembled
/// system (docs/theory.md §2, 2.13–2.16: (2.13), (2.14), (2.15), (2.16)): only the elements of the
/// parameter's set are evaluated, each by its kernel's exact derivative, so no part of the model is
/// assembled again. For a CONM2 mass a translational direction is the (isotropic) mass `m`, a
/// rotation its diagonal inertia.
pub fn parameter_derivative(
    model: &Model,
    parameter: &crate::model::Parameter,
    dofs: &[crate::core::DofId],
    mass: MassKind,
) -> Result<(SparseMatrix, SparseMatrix), ModelAssemblyError> {
    let index: DofIndex = dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let dependents = model_dependents(model)?;
    set_derivative(model, parameter, &index, &dependents, mass)
}

/// The model's dependent DOFs over independent ones (empty without multipoint constraints).
fn model_dependents(
    model: &Model,
) -> Result<BTreeMap<crate::core::DofId, DependentDof>, ModelAssemblyError> {
    let spc: BTreeSet<_> = model.constraints.iter().copied().collect();
    Ok(resolve(&model.mpcs, &spc)?)
}

/// The derivative over all elements of the parameter's set, or an error naming the known sets.
fn set_derivative(
    model: &Model,
    parameter: &crate::model::Parameter,
    index: &DofIndex,
    dependents: &BTreeMap<crate::core::DofId, DependentDof>,
    mass: MassKind,
) -> Result<(SparseMatrix, SparseMatrix), ModelAssemblyError> {
    let ids = model.sets.get(&parameter.set).ok_or_else(|| {
        ModelAssemblyError::Model(ModelError::MissingSet {
            parameter: parameter.name.clone(),
            set: parameter.set.clone(),
            known: model.sets.keys().cloned().collect::<Vec<_>>().join(", "),
        })
    })?;
    indexed_derivative(model, parameter, ids, index, dependents, mass)
}

/// Row of each free DOF of an assembled system.
pub type DofIndex = std::collections::HashMap<crate::core::DofId, usize>;

/// [`parameter_derivative`] of every parameter, in parallel, over one index of the free DOFs
/// `dofs` (at 1M DOFs, building it per parameter cost more than the derivatives of a small set).
pub fn parameter_derivatives(
    model: &Model,
    parameters: &[crate::model::Parameter],
    dofs: &[crate::core::DofId],
    mass: MassKind,
) -> Result<Vec<(SparseMatrix, SparseMatrix)>, ModelAssemblyError> {
    use rayon::prelude::*;
    if parameters.is_empty() {
        // Nothing to index the DOFs for (a million-entry map at 10⁶ DOFs).
        return Ok(Vec::new());
    }
    let index: DofIndex = dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let dependents = model_dependents(model)?;
    parameters
        .par_iter()
        .map(|parameter| set_derivative(model, parameter, &index, &dependents, mass))
        .collect::<Vec<_>>()
        .into_iter()
        // The first failing parameter's error in declaration order, whatever the threads did.
        .collect()
}

/// [`parameter_derivative`] restricted to the elements `ids` of the parameter's set (for a
/// substructure: the set's elements that lie in it), over the DOFs `dofs`.
pub fn elements_parameter_derivative(
    model: &Model,
    parameter: &crate::model::Parameter,
    ids: &[u64],
    dofs: &[crate::core::DofId],
    mass: MassKind,
) -> Result<(SparseMatrix, SparseMatrix), ModelAssemblyError> {
    let index: DofIndex = dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let dependents = model_dependents(model)?;
    indexed_derivative(model, parameter, ids, &index, &dependents, mass)
}

/// [`elements_parameter_derivative`] over the DOFs of `index` (its rows `0..index.len()`): an
/// element DOF that is dependent enters through its independent DOFs, `∂K̃/∂φ = Tᵀ (∂K/∂φ) T`.
fn indexed_derivative(
    model: &Model,
    parameter: &crate::model::Parameter,
    ids: &[u64],
    index: &DofIndex,
    dependents: &BTreeMap<crate::core::DofId, DependentDof>,
    mass: MassKind,
) -> Result<(SparseMatrix, SparseMatrix), ModelAssemblyError> {
    let (mut kt, mut mt) = (Vec::new(), Vec::new());
    for id in ids {
        let Some(e) = model.elements.get(id) else {
            return Err(ModelAssemblyError::Model(ModelError::MissingSetElement {
                set: parameter.set.clone(),
                element: *id,
            }));
        };
        let mut d = element_derivative(model, parameter, *id, e, mass)?;
        to_displacement_systems(model, e, &mut d.dk);
        to_displacement_systems(model, e, &mut d.dm);
        let map = row_map(model, e, index, dependents);
        for (a, ra) in map.iter().enumerate() {
            for (b, rb) in map.iter().enumerate() {
                let (k, m) = (d.dk[(a, b)], d.dm[(a, b)]);
                if k == 0.0 && m == 0.0 {
                    continue;
                }
                for &(i, ci) in ra {
                    for &(j, cj) in rb {
                        if k != 0.0 {
                            kt.push((i, j, ci * cj * k));
                        }
                        if m != 0.0 {
                            mt.push((i, j, ci * cj * m));
                        }
                    }
                }
            }
        }
    }
    let n = index.len();
    let build = |name, t: &[(usize, usize, f64)]| {
        crate::core::sparse::sparse_from_triplets(name, n, t).map_err(|e| {
            ModelAssemblyError::Element {
                element: 0,
                kind: "assembly",
                source: ElementError::Degenerate(e.to_string()),
            }
        })
    };
    Ok((build("dK", &kt)?, build("dM", &mt)?))
}

/// Where each row of element `e`'s matrices goes among the rows of `index`: its own row, or the
/// rows of the independent DOFs of a dependent DOF with their coefficients, or nowhere.
pub(crate) fn row_map(
    model: &Model,
    e: &Element,
    index: &DofIndex,
    dependents: &BTreeMap<crate::core::DofId, DependentDof>,
) -> Vec<Vec<(usize, f64)>> {
    block_dofs(model, e)
        .into_iter()
        .map(|d| {
            let Some(d) = d else {
                return Vec::new();
            };
            match (index.get(&d), dependents.get(&d)) {
                (Some(&i), _) => vec![(i, 1.0)],
                (None, Some(dep)) => dep
                    .terms
                    .iter()
                    .filter_map(|(t, c)| index.get(t).map(|&i| (i, *c)))
                    .collect(),
                (None, None) => Vec::new(),
            }
        })
        .collect()
}

/// The model's dependent DOFs (for [`row_map`]).
pub(crate) fn dependents_of(
    model: &Model,
) -> Result<BTreeMap<crate::core::DofId, DependentDof>, ModelAssemblyError> {
    model_dependents(model)
}

/// The derivative of element `id`'s stiffness and mass with respect to `parameter`, in the
/// element's own DOF order; an error when the parameter does not apply to the element.
fn element_derivative(
    model: &Model,
    parameter: &crate::model::Parameter,
    id: u64,
    e: &Element,
    mass: MassKind,
) -> Result<super::element::ElementDerivative, ModelAssemblyError> {
    use super::beam::{BeamParameter, beam2_derivative_centred};
    use super::lumped_elements::{MassParameter, conm2_derivative, spring6_derivative};
    use super::shell::{ShellParameter, quad4_derivative, tria3_derivative};
    use crate::core::Component;
    use crate::model::ParameterKind as P;
    let not_applicable = || ModelAssemblyError::NotApplicable {
        parameter: parameter.name.clone(),
        what: format!("{:?}", parameter.kind),
        element: id,
        kind: e.type_name(),
    };
    let xyz = |n: &u64| model.nodes[n];
    let err = |source| ModelAssemblyError::Element {
        element: id,
        kind: e.type_name(),
        source,
    };
    let shell = |kind: &P| match kind {
        P::ShellThickness => Some(ShellParameter::Thickness),
        P::YoungsModulus => Some(ShellParameter::YoungsModulus),
        P::Density => Some(ShellParameter::Density),
        _ => None,
    };
    if let Element::Quad4 { property, .. } | Element::Tria3 { property, .. } = e {
        let sp = &model.shell_properties[property];
        if super::laminate::uses_general(model, Some(id), sp) {
            let p = shell(&parameter.kind).ok_or_else(not_applicable)?;
            let xyz: Vec<[f64; 3]> = e.nodes().iter().map(xyz).collect();
            return super::laminate::general_shell_derivative(model, id, &xyz, *property, mass, p)
                .map_err(err);
        }
    }
    Ok(match e {
        Element::Quad4 { nodes, property } => {
            let p = shell(&parameter.kind).ok_or_else(not_applicable)?;
            quad4_derivative(
                &nodes.each_ref().map(xyz),
                &shell_section(model, *property),
                mass,
                p,
            )
            .map_err(err)?
        }
        Element::Tria3 { nodes, property } => {
            let p = shell(&parameter.kind).ok_or_else(not_applicable)?;
            tria3_derivative(
                &nodes.each_ref().map(xyz),
                &shell_section(model, *property),
                mass,
                p,
            )
            .map_err(err)?
        }
        Element::Quad8 {
            corners,
            midside,
            property,
        } => {
            let p = shell(&parameter.kind).ok_or_else(not_applicable)?;
            let (x, present) = quadratic_geometry(
                &corners.each_ref().map(xyz),
                &midside.map(|m| m.map(|n| xyz(&n))),
            );
            let s = shell_section(model, *property);
            let (_, mut d) =
                super::shell_quadratic::quad8_with_derivatives(&x, present, &s, mass, &[p])
                    .map_err(err)?;
            d.remove(0)
        }
        Element::Tria6 {
            corners,
            midside,
            property,
        } => {
            let p = shell(&parameter.kind).ok_or_else(not_applicable)?;
            let (x, present) = quadratic_geometry(
                &corners.each_ref().map(xyz),
                &midside.map(|m| m.map(|n| xyz(&n))),
            );
            let s = shell_section(model, *property);
            let (_, mut d) =
                super::shell_quadratic::tria6_with_derivatives(&x, present, &s, mass, &[p])
                    .map_err(err)?;
            d.remove(0)
        }
        Element::Beam {
            nodes,
            property,
            orientation,
            ends,
        } => {
            let bp = &model.beam_properties[property];
            let mat = &model.materials[&bp.material];
            if let Some(taper) = PropertyTaper::new(bp, mat.nu) {
                let p = match parameter.kind {
                    P::YoungsModulus => BeamParameter::YoungsModulus,
                    P::Density => BeamParameter::Density,
                    P::BeamWidth => BeamParameter::Width,
                    P::BeamHeight => BeamParameter::Height,
                    _ => return Err(not_applicable()),
                };
                let centres = kernel_centres(bp);
                // A library section's shear centre moves with its dimensions; the offsets are
                // held constant here, so a dimension derivative would miss that part.
                if matches!(p, BeamParameter::Width | BeamParameter::Height)
                    && centres.neutral_axis != [0.0; 2]
                {
                    return Err(err(ElementError::Degenerate(format!(
                        "the {} of a tapered beam section whose centroid is off its shear centre (offset {:?}) cannot be differentiated: the offset depends on the dimensions",
                        p.name(),
                        centres.neutral_axis
                    ))));
                }
                let b = TaperedBeam {
                    e: mat.e,
                    nu: mat.nu,
                    rho: mat.rho,
                    taper: &taper,
                };
                return super::beam_tapered::tapered_beam2_centred_derivative(
                    xyz(&nodes[0]),
                    xyz(&nodes[1]),
                    *orientation,
                    &b,
                    mass,
                    p,
                    &kernel_ends(ends).map_err(err)?,
                    &centres,
                )
                .map_err(err);
            }
            // A width or height parameter moves that dimension alone (`set_parameter_value`),
            // so a square section is differentiated as the rectangle it becomes, not by its side.
            let section = match (&parameter.kind, kernel_section(&bp.section)) {
                (P::BeamWidth | P::BeamHeight, Section::Square { side }) => Section::Rectangle {
                    width: side,
                    height: side,
                },
                (_, section) => section,
            };
            let p = match (&parameter.kind, &section) {
                (P::YoungsModulus, _) => BeamParameter::YoungsModulus,
                (P::Density, _) => BeamParameter::Density,
                (P::BeamWidth, _) => BeamParameter::Width,
                (P::BeamHeight, _) => BeamParameter::Height,
                _ => return Err(not_applicable()),
            };
            let d = BeamData {
                e: mat.e,
                nu: mat.nu,
                rho: mat.rho,
                nsm: bp.nsm,
                section,
            };
            beam2_derivative_centred(
                xyz(&nodes[0]),
                xyz(&nodes[1]),
                *orientation,
                &d,
                mass,
                p,
                &kernel_ends(ends).map_err(err)?,
                &kernel_centres(bp),
            )
            .map_err(err)?
        }
        Element::Rod { nodes, section } => {
            use super::rod::RodParameter;
            let p = match parameter.kind {
                P::YoungsModulus => RodParameter::YoungsModulus,
                P::Density => RodParameter::Density,
                _ => return Err(not_applicable()),
            };
            with_tapered_rod(model, section, |r| {
                super::beam_tapered::tapered_rod2_derivative(
                    xyz(&nodes[0]),
                    xyz(&nodes[1]),
                    r,
                    mass,
                    p,
                )
            })
            .unwrap_or_else(|| {
                super::rod::rod2_derivative(
                    xyz(&nodes[0]),
                    xyz(&nodes[1]),
                    &rod_data(model, section),
                    mass,
                    p,
                )
            })
            .map_err(err)?
        }
        Element::Solid {
            kind,
            nodes,
            property,
        } => {
            use super::solid::SolidParameter;
            let mid = model.solid_properties[property].material;
            let p = match (&parameter.kind, model.materials.get(&mid)) {
                (P::YoungsModulus, Some(m)) => SolidParameter::YoungsModulus { e: m.e },
                (P::Density, _) => SolidParameter::Density,
                _ => return Err(not_applicable()),
            };
            let xyz: Vec<[f64; 3]> = nodes.iter().map(xyz).collect();
            let mat = solid_material(model, *property).map_err(err)?;
            super::solid::solid_derivative(*kind, &xyz, &mat, mass, p).map_err(err)?
        }
        Element::Bush { other, k, axes, .. } => {
            let P::SpringStiffness(c) = parameter.kind else {
                return Err(not_applicable());
            };
            let Some(unit) = super::scalar_elements::bush_unit(c) else {
                return Err(not_applicable());
            };
            let ends = scalar_ends(&other.map(|o| crate::core::DofId::new(o, c)));
            match axes {
                None => spring6_derivative(k, ends, c).map_err(err)?,
                Some(axes) => {
                    spring6(k, ends).map_err(err)?;
                    let dk = super::scalar_elements::bush_matrix(&unit, Some(axes), ends)
                        .map_err(err)?;
                    super::element::ElementDerivative {
                        dm: Mat::zeros(dk.nrows(), dk.ncols()),
                        dk,
                    }
                }
            }
        }
        Element::ScalarMass { dof, other, m } => {
            let P::LumpedMass(_) = parameter.kind else {
                return Err(not_applicable());
            };
            super::scalar_elements::scalar_mass(*m, scalar_ends(other)).map_err(err)?;
            let unit = super::scalar_elements::scalar_mass_derivative(scalar_ends(other));
            let dm = expand_scalar(dof, other, &unit.dm);
            super::element::ElementDerivative {
                dk: Mat::zeros(dm.nrows(), dm.ncols()),
                dm,
            }
        }
        Element::GeneralMass { .. } | Element::ScalarDamper { .. } | Element::Viscous { .. } => {
            return Err(not_applicable());
        }
        Element::ScalarSpring { dof, other, .. } => {
            let P::SpringStiffness(_) = parameter.kind else {
                return Err(not_applicable());
            };
            // K is linear in k: the derivative is the unit spring, expanded like the stiffness.
            let unit = Element::ScalarSpring {
                dof: *dof,
                other: *other,
                k: 1.0,
            };
            let m = element_matrices(model, &unit, mass).map_err(err)?;
            super::element::ElementDerivative { dk: m.k, dm: m.m }
        }
        Element::Mass {
            mass: m,
            inertia,
            offset,
            ..
        } => {
            let P::LumpedMass(c) = parameter.kind else {
                return Err(not_applicable());
            };
            let p = match c {
                Component::Ux | Component::Uy | Component::Uz => MassParameter::Mass,
                Component::Rx => MassParameter::Ixx,
                Component::Ry => MassParameter::Iyy,
                Component::Rz => MassParameter::Izz,
                Component::Scalar => return Err(not_applicable()),
            };
            conm2_derivative(&LumpedMass::from_nastran(*m, *offset, *inertia), p).map_err(err)?
        }
    })
}

#[cfg(test)]
#[path = "model_assembly_tests.rs"]
mod tests;
