//! The viscous damping matrix `C` of a model's damping elements (CDAMP1–4, CVISC, the CBUSH
//! B line) over the free DOFs of its assembled `K`, `M` (docs/theory.md §1:
//! `M ẍ + C ẋ + K x = f`). Each element's `C` (see [`super::scalar_elements`]) is scattered
//! like a parameter derivative: a dependent DOF of a multipoint constraint enters through its
//! independent DOFs (`C̃ = Tᵀ C T`), a constrained DOF or one no element stiffens or masses is
//! dropped. Like `K` and `M`, it is over the components of the grids' displacement systems.

use super::lumped_elements::SpringEnds;
use super::model_assembly::{
    DofIndex, ModelAssemblyError, block_nodes, dependents_of, expand_scalar, row_map,
};
use super::scalar_elements::{bush_matrix, scalar_damper, viscous};
use crate::core::DofId;
use crate::core::sparse::SparseMatrix;
use crate::model::{Element, Model};
use faer::Mat;

/// Whether the model has any element that adds viscous damping.
pub fn has_dampers(model: &Model) -> bool {
    model.elements.values().any(Element::has_damping)
}

/// The damping matrix of element `e` in its block order (6 rows per distinct point), or `None`
/// when it adds no damping.
pub fn element_damping(
    model: &Model,
    e: &Element,
) -> Result<Option<Mat<f64>>, super::element::ElementError> {
    let ends = |two: bool| {
        if two {
            SpringEnds::TwoNodes
        } else {
            SpringEnds::Ground
        }
    };
    Ok(match e {
        Element::ScalarDamper { dof, other, c } => {
            let small = scalar_damper(*c, ends(other.is_some()))?;
            Some(expand_scalar(dof, other, &small))
        }
        Element::Viscous {
            nodes,
            axial,
            torsional,
        } => Some(viscous(
            model.nodes[&nodes[0]],
            model.nodes[&nodes[1]],
            *axial,
            *torsional,
        )?),
        Element::Bush { other, axes, b, .. } if e.has_damping() => {
            for (i, v) in b.iter().enumerate() {
                super::element::positive(["bx", "by", "bz", "brx", "bry", "brz"][i], *v, true)?;
            }
            Some(bush_matrix(b, axes.as_ref(), ends(other.is_some()))?)
        }
        _ => None,
    })
}

/// `C` over the free DOFs `dofs` of the model's assembled system; `None` when the model has
/// no damping element.
pub fn damping_matrix(
    model: &Model,
    dofs: &[DofId],
) -> Result<Option<SparseMatrix>, ModelAssemblyError> {
    if !has_dampers(model) {
        return Ok(None);
    }
    let index: DofIndex = dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let dependents = dependents_of(model)?;
    let mut triplets = Vec::new();
    for (&id, e) in &model.elements {
        let c = element_damping(model, e).map_err(|source| ModelAssemblyError::Element {
            element: id,
            kind: e.type_name(),
            source,
        })?;
        let Some(mut c) = c else {
            continue;
        };
        super::model_assembly::to_displacement_systems(model, e, &mut c);
        debug_assert_eq!(c.nrows(), 6 * block_nodes(e).len());
        let map = row_map(model, e, &index, &dependents);
        for (a, ra) in map.iter().enumerate() {
            for (b, rb) in map.iter().enumerate() {
                let v = c[(a, b)];
                if v == 0.0 {
                    continue;
                }
                for &(i, ci) in ra {
                    for &(j, cj) in rb {
                        triplets.push((i, j, ci * cj * v));
                    }
                }
            }
        }
    }
    let c = crate::core::sparse::sparse_from_triplets("C", dofs.len(), &triplets).map_err(|e| {
        ModelAssemblyError::Element {
            element: 0,
            kind: "assembly",
            source: super::element::ElementError::Degenerate(e.to_string()),
        }
    })?;
    Ok(Some(c))
}
