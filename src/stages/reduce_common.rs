//! Glue shared by the `reduce.*` stages (not a stage kind): component-mode selection, reading
//! mesh and partition, reducing, and the reduced derivatives of every model parameter.

use super::params::{Count, Modes, Positive};
use crate::artefact::mesh::mesh_from_artefact;
use crate::artefact::reduced::{
    component_from_artefact, component_to_artefact, method_json, partition_from_artefact,
    reduced_to_artefact,
};
use crate::artefact::{Artefact, ArtefactKind};
use crate::eigen::ModeSelection;
use crate::fe::SystemMatrices;
use crate::fe::element::MassKind;
use crate::pipeline::{ParamIssue, PortSpec, StageError, StageInputs, StageOutputs};
use crate::reduction::craig_bampton::junction_condensation;
use crate::reduction::{
    Method, ReducedModel, ReductionError, Substructure, check_method, interface_basis,
    interface_basis_from_condensations, interface_rows, reduce_assembled,
    reduce_assembled_on_interface, reduced_parameter_derivative, substructure_matrices,
};
use rayon::prelude::*;

/// Component modes kept per substructure: `max_freq_hz` (default 200 Hz, the thesis's C3
/// cut-off) or `count`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ComponentModes {
    /// Keep component modes up to this frequency, Hz (thesis: twice the top of the band).
    #[serde(default)]
    pub max_freq_hz: Option<Positive>,
    /// Keep this many component modes per substructure.
    #[serde(default)]
    pub count: Option<Count>,
}

impl ComponentModes {
    /// Checks the pair.
    pub fn issues(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        if self.max_freq_hz.is_some() && self.count.is_some() {
            v.push(ParamIssue::at(
                "max_freq_hz",
                "give `max_freq_hz` or `count`, not both",
            ));
        }
        v
    }

    /// The selection (default: modes to 200 Hz).
    pub fn selection(&self) -> ModeSelection {
        Modes {
            count: self.count,
            max_freq_hz: self.max_freq_hz,
        }
        .selection_or(ModeSelection::BelowHz(200.0))
    }
}

/// Parameters of the reductions that need only component modes and the mass kind
/// (`reduce.craig_bampton`, `reduce.free_interface`).
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ModalReductionParams {
    /// Keep component modes up to this frequency, Hz (default 200 Hz when `count` is absent;
    /// the thesis kept twice the top of the band).
    #[serde(default)]
    pub max_freq_hz: Option<Positive>,
    /// Keep this many component modes per substructure.
    #[serde(default)]
    pub count: Option<Count>,
    /// Mass matrix kind.
    #[serde(default)]
    pub mass: MassKind,
    /// Interface reduction: replace the junction DOFs by the lowest modes of the junction's
    /// Guyan model, `{max_freq_hz: F}` or `{count: N}` (characteristic constraint modes; keeps
    /// the reduced model small when the interfaces have thousands of DOFs). Craig-Bampton then
    /// reduces each substructure on the interface modes alone, never holding a junction-sized
    /// basis; junctions above 5000 DOFs get their interface modes in two levels (local modes
    /// per boundary to 8× the cut-off, then their global combinations). Default: none.
    #[serde(default)]
    pub interface: Option<ComponentModes>,
}

impl ModalReductionParams {
    /// Problems with the parameters.
    pub fn issues(&self) -> Vec<ParamIssue> {
        let mut v = self.modes().issues();
        if let Some(i) = &self.interface {
            v.extend(i.issues().into_iter().map(|mut issue| {
                issue.path.insert(0, "interface".into());
                issue
            }));
            if i.max_freq_hz.is_none() && i.count.is_none() {
                v.push(ParamIssue::at(
                    "interface",
                    "give `max_freq_hz` or `count` of the interface modes to keep",
                ));
            }
        }
        v
    }

    /// The interface-mode choice, if any.
    pub fn interface_selection(&self) -> Option<ModeSelection> {
        self.interface.as_ref().map(ComponentModes::selection)
    }

    /// The component-mode choice.
    pub fn modes(&self) -> ComponentModes {
        ComponentModes {
            max_freq_hz: self.max_freq_hz,
            count: self.count,
        }
    }
}

/// Input ports of every `reduce.*` stage.
pub fn inputs() -> Vec<PortSpec> {
    vec![
        PortSpec::required("mesh", ArtefactKind::Mesh, "the model"),
        PortSpec::required("partition", ArtefactKind::Partition, "its substructures"),
    ]
}

/// Output ports of every `reduce.*` stage.
pub fn outputs() -> Vec<PortSpec> {
    vec![PortSpec::required(
        "reduced",
        ArtefactKind::ReducedModel,
        "reduced K, M, transformations and reduced parameter derivatives",
    )]
}

/// Producer name and version of a cached substructure reduction; the version changes whenever
/// what a component holds or how it is computed changes.
const COMPONENT_PART: &str = "reduce/component";
const COMPONENT_VERSION: u32 = 1;

/// Reduces and writes the artefact with the reduced derivatives of every model parameter. Each
/// substructure's reduction is a cached part keyed by the content of its assembled `K`, `M`,
/// its junction and the method: when one substructure changes, the others are read back.
pub fn run(
    method: Method,
    mass: MassKind,
    interface: Option<ModeSelection>,
    inputs: &StageInputs,
) -> Result<StageOutputs, StageError> {
    let model = mesh_from_artefact(inputs.require("mesh")?)?;
    let part = partition_from_artefact(inputs.require("partition")?)?;
    check_method(&part, &method).map_err(StageError::from_numerics(""))?;
    let matrices = |sub: &Substructure| -> Result<SystemMatrices, StageError> {
        substructure_matrices(&model, sub, mass).map_err(StageError::from_numerics(""))
    };
    let interface_failed = |e: ReductionError| StageError::numerical_in("interface modes")(e);
    // Craig-Bampton on interface modes: the junction condensations choose the modes, then each
    // component is reduced on them alone (its part key holds its rows of the basis), so no
    // component ever holds a junction-sized basis.
    let lean_interface = match (&method, interface) {
        (Method::CraigBampton { .. }, Some(selection)) => {
            let carried = crate::core::progress::carry();
            let condensations = part
                .substructures
                .par_iter()
                .map(|sub| {
                    carried.run(|| {
                        junction_condensation(&sub.name, &matrices(sub)?, &sub.junction)
                            .map_err(StageError::from_numerics(""))
                    })
                })
                .collect::<Result<Vec<_>, StageError>>()?;
            interface_basis_from_condensations(&part.junction, condensations, selection)
                .map_err(interface_failed)?
        }
        _ => None,
    };
    let done = crate::reduction::substructures_task(&part);
    // The eigensolves of each substructure report to this stage from the rayon workers.
    let carried = crate::core::progress::carry();
    let components = part
        .substructures
        .par_iter()
        .map(|sub| {
            carried.run(|| {
                let sys = matrices(sub)?;
                let rows = match &lean_interface {
                    Some(psi) => Some(
                        interface_rows(&part.junction, &sub.junction, psi.as_ref())
                            .map_err(StageError::from_numerics(""))?,
                    ),
                    None => None,
                };
                let mut key = serde_json::json!({
                    "method": method_json(&method),
                    "substructure": sub.name,
                    "junction": sub.junction.iter().map(|d| d.to_string()).collect::<Vec<_>>(),
                    "matrices": matrices_digest(&sys),
                });
                if let Some(rows) = &rows {
                    key["interface_rows"] = dense_digest(rows).into();
                }
                // A component computed here is used as it is; only one read from the cache is
                // decoded (the round trip is exact, tested in `artefact::reduced`).
                let mut computed = None;
                let a = inputs.part(
                    COMPONENT_PART,
                    COMPONENT_VERSION,
                    &key,
                    ArtefactKind::ReducedComponent,
                    || {
                        let c = match &rows {
                            Some(rows) => {
                                reduce_assembled_on_interface(sub, &sys, &method, rows.as_ref())
                            }
                            None => reduce_assembled(sub, &sys, &method),
                        }
                        .map_err(StageError::from_numerics(""))?;
                        let a = component_to_artefact(&c);
                        computed = Some(c);
                        Ok(a)
                    },
                )?;
                done.advance(1);
                match computed {
                    Some(c) => Ok(c),
                    None => Ok(component_from_artefact(&a)?),
                }
            })
        })
        .collect::<Result<Vec<_>, StageError>>()?;
    let psi = match (lean_interface, interface) {
        (Some(psi), _) => Some(psi),
        (None, Some(selection)) => {
            interface_basis(&part.junction, &components, selection).map_err(interface_failed)?
        }
        (None, None) => None,
    };
    let r = ReducedModel::synthesise_with_interface(method, part.junction.clone(), components, psi)
        .map_err(StageError::from_numerics(""))?;
    let mut derivs = Vec::new();
    for param in &model.parameters {
        let (dk, dm) = reduced_parameter_derivative(&model, &part, &r, param, mass)
            .map_err(StageError::from_numerics("parameters"))?;
        derivs.push((param.name.clone(), dk, dm));
    }
    let a: Artefact = reduced_to_artefact(&r, &derivs);
    Ok(StageOutputs::from([("reduced".to_string(), a)]))
}

/// blake3 of a dense matrix's shape and exact bits.
fn dense_digest(a: &faer::Mat<f64>) -> String {
    let mut h = blake3::Hasher::new();
    h.update(&(a.nrows() as u64).to_le_bytes());
    h.update(&(a.ncols() as u64).to_le_bytes());
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            h.update(&a[(i, j)].to_bits().to_le_bytes());
        }
    }
    h.finalize().to_hex().to_string()
}

/// blake3 of a substructure's DOF labels and the exact bits of its sparse `K` and `M`.
fn matrices_digest(sys: &SystemMatrices) -> String {
    let mut h = blake3::Hasher::new();
    for d in &sys.dofs {
        h.update(d.to_string().as_bytes());
        h.update(b";");
    }
    for a in [&sys.k, &sys.m] {
        let s = a.symbolic();
        h.update(&(s.nrows() as u64).to_le_bytes());
        for &p in s.col_ptr() {
            h.update(&(p as u64).to_le_bytes());
        }
        for &i in s.row_idx() {
            h.update(&(i as u64).to_le_bytes());
        }
        for v in a.val() {
            h.update(&v.to_bits().to_le_bytes());
        }
    }
    h.finalize().to_hex().to_string()
}
