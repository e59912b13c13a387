//! Candidate parameters of an error localisation and their derivatives (docs/theory.md §2, §7).
//!
//! A candidate is one property (`E`, `ρ`, shell thickness, …) of a group of elements: a declared
//! updating parameter, or a single element. Its derivative `(∂K/∂φ, ∂M/∂φ)` is formed over the
//! free DOFs of its own elements only ([`LocalDerivative`]), so thousands of one-element
//! candidates never touch an `N × N` matrix: projecting one onto `m` modes costs
//! `nnz(∂K/∂φ)·m + n_e·m²` (4.5), independent of the model size.

use super::LocalisationError;
use crate::core::sparse::{SparseMatrix, sparse_from_triplets, sparse_triplets};
use crate::core::{Component, DofId};
use crate::fe::element::MassKind;
use crate::fe::model_assembly::elements_parameter_derivative;
use crate::model::{Element, Model, Parameter, ParameterKind};
use crate::sensitivity::{ProjectedDerivative, project};
use faer::{Mat, MatRef};
use std::collections::HashMap;

/// One candidate: a property of a group of elements at its current value.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// Name (a declared parameter's name, or `e<id>` for one element).
    pub name: String,
    /// What it changes.
    pub kind: ParameterKind,
    /// Name of the group: the parameter's set, or `element <id>`.
    pub set: String,
    /// Element ids, ascending.
    pub elements: Vec<u64>,
    /// Current value `φ` (SI), the scale of the unity-based derivative `φ ∂/∂φ` (2.16).
    pub value: f64,
}

impl Candidate {
    /// The candidate as a model parameter (for the element kernels' derivative).
    fn parameter(&self) -> Parameter {
        Parameter {
            name: self.name.clone(),
            kind: self.kind.clone(),
            set: self.set.clone(),
            lower: 0.0,
            upper: f64::INFINITY,
        }
    }
}

/// The model's declared updating parameters as candidates, with their current values.
pub fn declared_candidates(model: &Model) -> Result<Vec<Candidate>, LocalisationError> {
    if model.parameters.is_empty() {
        return Err(LocalisationError::Settings(
            "candidates: the model declares no parameter; declare them with a `mesh.parameters` stage or use `candidates: {every_element: {kind: youngs_modulus}}`".into(),
        ));
    }
    model
        .parameters
        .iter()
        .map(|p| {
            let value = model.parameter_value(p)?;
            let elements = model.sets.get(&p.set).cloned().unwrap_or_default();
            Ok(Candidate {
                name: p.name.clone(),
                kind: p.kind.clone(),
                set: p.set.clone(),
                elements,
                value,
            })
        })
        .collect()
}

/// The value of property `kind` on element `id`, or `None` where the element does not carry it.
/// Only the per-element kinds (`youngs_modulus`, `density`, `shell_thickness`) are known.
pub fn element_value(model: &Model, id: u64, kind: &ParameterKind) -> Option<f64> {
    let e = model.elements.get(&id)?;
    let material = |mid: u64| model.materials.get(&mid);
    match (e, kind) {
        (
            Element::Quad4 { property, .. }
            | Element::Tria3 { property, .. }
            | Element::Quad8 { property, .. }
            | Element::Tria6 { property, .. },
            k,
        ) => {
            let p = model.shell_properties.get(property)?;
            match k {
                ParameterKind::ShellThickness => Some(p.thickness),
                ParameterKind::YoungsModulus => material(p.material).map(|m| m.e),
                ParameterKind::Density => material(p.material).map(|m| m.rho),
                _ => None,
            }
        }
        (Element::Beam { property, .. }, k) => {
            let p = model.beam_properties.get(property)?;
            match k {
                ParameterKind::YoungsModulus => material(p.material).map(|m| m.e),
                ParameterKind::Density => material(p.material).map(|m| m.rho),
                _ => None,
            }
        }
        (Element::Solid { property, .. }, k) => {
            let mid = model.solid_properties.get(property)?.material;
            match (k, model.anisotropic_materials.get(&mid)) {
                (ParameterKind::Density, Some(m)) => Some(m.rho),
                (_, Some(_)) => None,
                (ParameterKind::YoungsModulus, None) => material(mid).map(|m| m.e),
                (ParameterKind::Density, None) => material(mid).map(|m| m.rho),
                _ => None,
            }
        }
        _ => None,
    }
}

/// Every element of `sets` (or of the model, when empty) as its own candidate of `kind`, in
/// ascending id. Without sets, elements that do not carry the property (beams for a thickness,
/// springs, masses) are left out; elements of named sets must all carry it.
pub fn element_candidates(
    model: &Model,
    kind: &ParameterKind,
    sets: &[String],
) -> Result<Vec<Candidate>, LocalisationError> {
    if !matches!(
        kind,
        ParameterKind::YoungsModulus | ParameterKind::Density | ParameterKind::ShellThickness
    ) {
        return Err(LocalisationError::Settings(format!(
            "candidates.every_element.kind: {kind:?} is not a per-element property; use youngs_modulus, density or shell_thickness"
        )));
    }
    let mut ids: Vec<(u64, Option<&str>)> = Vec::new();
    if sets.is_empty() {
        ids.extend(model.elements.keys().map(|id| (*id, None)));
    }
    for s in sets {
        let members = model.sets.get(s).ok_or_else(|| {
            LocalisationError::Settings(format!(
                "candidates.every_element.set: `{s}` is not a set of the model (sets: {})",
                model.sets.keys().cloned().collect::<Vec<_>>().join(", ")
            ))
        })?;
        ids.extend(members.iter().map(|id| (*id, Some(s.as_str()))));
    }
    ids.sort_by_key(|x| x.0);
    ids.dedup_by_key(|x| x.0);
    let mut out = Vec::with_capacity(ids.len());
    for (id, set) in ids {
        match (element_value(model, id, kind), set) {
            (Some(value), _) => out.push(Candidate {
                name: format!("e{id}"),
                kind: kind.clone(),
                set: format!("element {id}"),
                elements: vec![id],
                value,
            }),
            (None, None) => {}
            (None, Some(set)) => {
                let what = model
                    .elements
                    .get(&id)
                    .map(|e| e.type_name())
                    .unwrap_or("missing");
                return Err(LocalisationError::Settings(format!(
                    "candidates.every_element: element {id} ({what}) of set `{set}` has no {kind:?}; choose sets of shells (and beams for youngs_modulus or density)"
                )));
            }
        }
    }
    if out.is_empty() {
        return Err(LocalisationError::Settings(format!(
            "candidates.every_element: no element carries {kind:?}"
        )));
    }
    Ok(out)
}

/// A candidate's `(∂K/∂φ, ∂M/∂φ)` over the free DOFs of its elements (absolute, not scaled).
#[derive(Clone, Debug)]
pub struct LocalDerivative {
    /// Global row (free-DOF index) of every local row, ascending.
    pub rows: Vec<usize>,
    /// `∂K/∂φ` on the local rows.
    pub dk: SparseMatrix,
    /// `∂M/∂φ` on the local rows.
    pub dm: SparseMatrix,
}

impl LocalDerivative {
    /// The derivative of `candidate`; `dofs` are the model's free DOFs with their `index`.
    pub fn new(
        model: &Model,
        candidate: &Candidate,
        dofs: &[DofId],
        index: &HashMap<DofId, usize>,
        mass: MassKind,
    ) -> Result<Self, LocalisationError> {
        let mut rows: Vec<usize> = Vec::new();
        for id in &candidate.elements {
            let e = model.elements.get(id).ok_or_else(|| {
                LocalisationError::Model(format!(
                    "candidate `{}`: element {id} is not in the model",
                    candidate.name
                ))
            })?;
            for node in e.nodes() {
                // A scalar point's one DOF is `node:s`.
                for c in Component::ALL.into_iter().chain([Component::Scalar]) {
                    if let Some(&r) = index.get(&DofId::new(node, c)) {
                        rows.push(r);
                    }
                }
            }
        }
        rows.sort_unstable();
        rows.dedup();
        let local: Vec<DofId> = rows.iter().map(|&r| dofs[r]).collect();
        let (dk, dm) = elements_parameter_derivative(
            model,
            &candidate.parameter(),
            &candidate.elements,
            &local,
            mass,
        )?;
        Ok(LocalDerivative { rows, dk, dm })
    }

    /// A derivative given on all free DOFs (a parameter's `∂K/∂φ`, `∂M/∂φ`), restricted to the
    /// rows where either has an entry.
    pub fn from_global(dk: &SparseMatrix, dm: &SparseMatrix) -> Result<Self, LocalisationError> {
        let (tk, tm) = (sparse_triplets(dk), sparse_triplets(dm));
        let mut rows: Vec<usize> = tk.iter().chain(&tm).flat_map(|t| [t.0, t.1]).collect();
        rows.sort_unstable();
        rows.dedup();
        let local = |t: Vec<(usize, usize, f64)>| {
            let at = |g: usize| rows.binary_search(&g).unwrap_or_default();
            let t: Vec<(usize, usize, f64)> =
                t.into_iter().map(|(i, j, v)| (at(i), at(j), v)).collect();
            sparse_from_triplets("derivative", rows.len(), &t)
                .map_err(|e| LocalisationError::Model(e.to_string()))
        };
        let (dk, dm) = (local(tk)?, local(tm)?);
        Ok(LocalDerivative { rows, dk, dm })
    }

    /// The rows of `a` (`N × c`) at the local DOFs.
    pub fn gather(&self, a: MatRef<'_, f64>) -> Mat<f64> {
        Mat::from_fn(self.rows.len(), a.ncols(), |i, c| a[(self.rows[i], c)])
    }

    /// `φ Φᵀ(∂K/∂φ)Φ`, `φ Φᵀ(∂M/∂φ)Φ` (2.16, 4.5) for the modes `phi` over all free DOFs.
    pub fn projected(&self, phi: MatRef<'_, f64>, value: f64) -> ProjectedDerivative {
        let local = self.gather(phi);
        ProjectedDerivative {
            k: project(&self.dk, local.as_ref()),
            m: project(&self.dm, local.as_ref()),
        }
        .scaled(value)
    }

    /// The same derivative scattered onto all `n` free DOFs.
    pub fn to_global(&self, n: usize) -> Result<(SparseMatrix, SparseMatrix), LocalisationError> {
        let scatter = |a: &SparseMatrix| {
            let t: Vec<(usize, usize, f64)> = sparse_triplets(a)
                .into_iter()
                .map(|(i, j, v)| (self.rows[i], self.rows[j], v))
                .collect();
            sparse_from_triplets("derivative", n, &t)
                .map_err(|e| LocalisationError::Model(e.to_string()))
        };
        Ok((scatter(&self.dk)?, scatter(&self.dm)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::sparse::sparse_to_dense;
    use crate::fe::model_assembly::{assemble_model, parameter_derivative};
    use crate::model::generate::{BentPlate, bent_plate};

    /// The one-element derivatives of a strip's elements, summed, are the strip's derivative
    /// (the derivative is additive over elements, 2.16).
    #[test]
    fn element_derivatives_sum_to_the_strip_derivative() {
        let model = bent_plate(&BentPlate::default());
        let (sys, _) = assemble_model(&model, MassKind::Consistent).unwrap();
        let index = sys.dof_index();
        let n = sys.n();
        for kind in [ParameterKind::YoungsModulus, ParameterKind::ShellThickness] {
            let strip = Parameter {
                name: "s7".into(),
                kind: kind.clone(),
                set: "strip_7".into(),
                lower: 0.0,
                upper: 1.0,
            };
            let (sk, sm) =
                parameter_derivative(&model, &strip, &sys.dofs, MassKind::Consistent).unwrap();
            let (sk, sm) = (sparse_to_dense(&sk), sparse_to_dense(&sm));
            let cands = element_candidates(&model, &kind, &["strip_7".into()]).unwrap();
            assert_eq!(cands.len(), 7);
            let mut k = Mat::<f64>::zeros(n, n);
            let mut m = Mat::<f64>::zeros(n, n);
            for c in &cands {
                let d = LocalDerivative::new(&model, c, &sys.dofs, &index, MassKind::Consistent)
                    .unwrap();
                let (gk, gm) = d.to_global(n).unwrap();
                k += sparse_to_dense(&gk);
                m += sparse_to_dense(&gm);
            }
            let scale = sk.norm_max().max(sm.norm_max());
            assert!((&k - &sk).norm_max() <= 1e-12 * scale, "{kind:?}");
            assert!((&m - &sm).norm_max() <= 1e-12 * scale.max(1.0), "{kind:?}");
        }
    }

    /// A set with an element that lacks the property is an error naming it; without a set,
    /// such elements (the bar for a thickness) are skipped.
    #[test]
    fn inapplicable_elements() {
        let model = bent_plate(&BentPlate::default());
        let t = ParameterKind::ShellThickness;
        assert_eq!(element_candidates(&model, &t, &[]).unwrap().len(), 98);
        let e = element_candidates(&model, &t, &["bar".into()]).unwrap_err();
        assert!(e.to_string().contains("beam"), "{e}");
        let e = element_candidates(&model, &t, &["nope".into()]).unwrap_err();
        assert!(e.to_string().contains("strip_1"), "{e}");
        let all_e = element_candidates(&model, &ParameterKind::YoungsModulus, &[]).unwrap();
        assert_eq!(all_e.len(), 123);
    }
}
