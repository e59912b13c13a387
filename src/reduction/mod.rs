//! Substructuring and component mode synthesis (docs/theory.md §9, thesis chapter 3).
//!
//! A model is split into substructures `k` ([`partition`]); each is reduced on its own, in
//! parallel, by a frequency-independent transformation `x_k = T_k q_k` (3.3, 3.13, 3.39, 3.50),
//! and the reduced components are assembled into `K_c = Σ_k T_kᵀ K_k T_k`, `M_c = Σ_k T_kᵀ M_k T_k`
//! (3.14 at common junction coordinates; 3.51 as a plain sum for force coupling).
//!
//! - [`craig_bampton`]: constraint modes `Ψ = −K_ii⁻¹ K_ij` (sparse Cholesky) and
//!   fixed-interface normal modes of `(K_ii, M_ii)` (3.5–3.13: (3.5), (3.6), (3.7), (3.8), (3.9),
//!   (3.10), (3.11), (3.12), (3.13)).
//! - [`free_interface`]: MacNeal/Rubin free modes plus residual flexibility `R = G − Φ Λ⁻¹ Φᵀ`,
//!   or `G_e = Pᵀ G P` with the inertia-relief projector for floating substructures
//!   (3.15–3.39: (3.15), (3.16), (3.17), (3.18), (3.19), (3.20), (3.21), (3.22), (3.23), (3.24),
//!   (3.25), (3.26), (3.27), (3.28), (3.29), (3.30), (3.31), (3.32), (3.33), (3.34), (3.35),
//!   (3.36), (3.37), (3.38), (3.39); Appendix A.1).
//! - [`force_coupling`]: Lombard et al. (1997): free modes and residual flexibility, physical
//!   master DOFs chosen by Effective Independence (Kammer 1991), junction forces eliminated by
//!   compatibility and equilibrium at every junction DOF (3.40–3.51: (3.40), (3.41), (3.42),
//!   (3.43), (3.44), (3.45), (3.46), (3.47), (3.48), (3.49), (3.50), (3.51)), optional second-level
//!   condensation (3.53).
//!
//! Every method produces per substructure a [`ComponentReduction`] — a local basis `T_k^loc`
//! over the substructure's DOFs with its projected `K`, `M` — and a coupling `C_k` from the
//! global reduced coordinates to the local ones, so `T_k = T_k^loc C_k`. For the classical
//! methods `C_k` is Boolean (junction DOFs shared, modal coordinates private); for force coupling
//! it is dense and depends on every component's interface flexibility. Only the component
//! analysis is expensive; the coupling is cheap, so after a parameter change only the changed
//! substructures are re-analysed ([`ReducedModel::replace`]) and the coupling is redone.
//! Reduced derivatives are `T_kᵀ (∂K_k/∂φ) T_k` with the transformation held fixed (3.59).

pub mod craig_bampton;
pub mod force_coupling;
pub mod free_interface;
pub mod interface;
pub mod linalg;
pub mod partition;
mod reduced;

pub use craig_bampton::JunctionCondensation;
pub use interface::{interface_basis, interface_basis_from_condensations};
pub use partition::{Boundary, Partition, Substructure};
pub use reduced::{
    ComponentReduction, Coordinate, Coupling, JunctionFlexibility, Method, ReducedModel,
    ReductionInfo, SecondLevel, check_method, interface_rows, project_on_held_basis,
    projected_modes, reduce, reduce_assembled, reduce_assembled_on_interface, reduce_substructure,
    reduce_substructure_on_interface, reduce_with_interface, reduced_parameter_derivative,
    substructure_matrices, substructures_task,
};

use crate::core::DofId;

/// Why a model could not be partitioned, reduced or expanded.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ReductionError {
    /// The model is inconsistent or an element could not be formed.
    #[error("{0}")]
    Model(String),
    /// The model's references are broken.
    #[error(transparent)]
    Definition(#[from] crate::model::ModelError),
    /// A substructure (or the whole model, `substructure` empty) could not be assembled.
    #[error("{}{source}", if substructure.is_empty() { String::new() } else { format!("substructure `{substructure}`: ") })]
    Assembly {
        /// The substructure's name, or empty.
        substructure: String,
        /// The assembly's reason.
        source: crate::fe::model_assembly::ModelAssemblyError,
    },
    /// No substructure was given.
    #[error("no substructures: give element sets, property ids, or a part count")]
    NoSubstructures,
    /// A substructure has no element.
    #[error("substructure `{name}` has no elements")]
    EmptySubstructure {
        /// Its name.
        name: String,
    },
    /// Two substructures share a name.
    #[error("substructure name `{name}` is used twice; names must be unique")]
    DuplicateName {
        /// The name.
        name: String,
    },
    /// A set named as a substructure does not exist.
    #[error("element set `{set}` is not defined (sets: {known})")]
    UnknownSet {
        /// The set.
        set: String,
        /// Sets of the model.
        known: String,
    },
    /// A substructure lists an element the model does not have.
    #[error("substructure `{substructure}` lists element {element}, which is not defined")]
    UnknownElement {
        /// The substructure.
        substructure: String,
        /// The element.
        element: u64,
    },
    /// An element is in two substructures.
    #[error(
        "element {element} is in both substructures `{first}` and `{second}`; every element must belong to exactly one"
    )]
    Overlap {
        /// The element.
        element: u64,
        /// First substructure.
        first: String,
        /// Second substructure.
        second: String,
    },
    /// Some elements are in no substructure.
    #[error(
        "element {element} (and {count} elements in all) is not in any substructure; every element must belong to exactly one"
    )]
    Unassigned {
        /// The first such element.
        element: u64,
        /// How many.
        count: usize,
    },
    /// A bad part count for the automatic partition.
    #[error(
        "{parts} parts asked for a model of {elements} elements: give between 1 and {elements}"
    )]
    PartCount {
        /// Parts asked.
        parts: usize,
        /// Elements of the model.
        elements: usize,
    },
    /// A substructure name is unknown.
    #[error("no substructure `{name}` (substructures: {known})")]
    UnknownSubstructure {
        /// The name.
        name: String,
        /// Known names.
        known: String,
    },
    /// The assembled substructure does not hold the DOFs the partition says.
    #[error(
        "substructure `{substructure}`: the partition lists {expected} DOFs but its elements assemble to {found}; re-run the partition on this model"
    )]
    DofMismatch {
        /// The substructure.
        substructure: String,
        /// DOFs in the partition.
        expected: usize,
        /// DOFs assembled.
        found: usize,
    },
    /// `K_ii` is singular: holding the junction does not restrain the substructure.
    #[error(
        "substructure `{substructure}`: K_ii is not positive definite, so its internal DOFs move freely when its {junction} junction DOFs are held (a mechanism, or a part that touches no other substructure and is not supported); merge it with a neighbour or support it"
    )]
    NotRestrained {
        /// The substructure.
        substructure: String,
        /// Its junction DOF count.
        junction: usize,
    },
    /// The stiffness with the temporary supports is singular.
    #[error(
        "substructure `{substructure}`: its stiffness is singular even with {held} rigid-body DOFs held ({reason}); it has a mechanism that the rigid-body modes do not describe"
    )]
    Mechanism {
        /// The substructure.
        substructure: String,
        /// DOFs held.
        held: usize,
        /// Detail.
        reason: String,
    },
    /// The eigensolver failed on a substructure.
    #[error("substructure `{substructure}`: {source}")]
    Eigen {
        /// The substructure.
        substructure: String,
        /// The solver's reason.
        source: crate::eigen::EigenError,
    },
    /// The residual flexibility at the interface is singular.
    #[error(
        "substructure `{substructure}`: the residual flexibility at its {junction} junction DOFs is singular ({detail}); keep fewer component modes — at most its internal DOF count {internal} — or more, so that the modes left out still flex the interface"
    )]
    SingularResidual {
        /// The substructure.
        substructure: String,
        /// Junction DOFs.
        junction: usize,
        /// Internal DOFs.
        internal: usize,
        /// Detail.
        detail: String,
    },
    /// Too few component modes to hold every rigid-body mode.
    #[error(
        "substructure `{substructure}`: all {kept} kept modes are rigid-body modes, so its elastic behaviour is missing; raise the cut-off or the mode count"
    )]
    OnlyRigidModes {
        /// The substructure.
        substructure: String,
        /// Modes kept.
        kept: usize,
    },
    /// Master DOF selection impossible.
    #[error(
        "substructure `{substructure}`: {candidates} candidate master DOFs cannot resolve its {modes} component modes ({detail}); add candidates or keep fewer modes"
    )]
    Masters {
        /// The substructure.
        substructure: String,
        /// Candidate count.
        candidates: usize,
        /// Mode count.
        modes: usize,
        /// Detail.
        detail: String,
    },
    /// A named DOF is not a DOF of the model.
    #[error(
        "DOF {dof} is not a free DOF of any substructure (constrained, not in the model, or without stiffness and mass)"
    )]
    UnknownDof {
        /// The DOF.
        dof: DofId,
    },
    /// The coupled junction flexibility is singular.
    #[error(
        "force coupling: the interface flexibility summed over the substructures is singular at the junction ({detail}); keep more master DOFs or fewer modes"
    )]
    SingularCoupling {
        /// Detail.
        detail: String,
    },
    /// A replacement does not fit.
    #[error("{0}")]
    Replace(String),
    /// A reduced vector has the wrong length.
    #[error("a reduced solution has {found} rows but the reduced model has {expected} coordinates")]
    Shape {
        /// Rows found.
        found: usize,
        /// Coordinates.
        expected: usize,
    },
    /// The reduced model's eigenproblem failed.
    #[error("reduced model: {0}")]
    ReducedEigen(crate::eigen::EigenError),
}

impl crate::core::InputFault for ReductionError {
    fn is_input(&self) -> bool {
        match self {
            ReductionError::Definition(_) => true,
            ReductionError::Assembly { source, .. } => source.is_input(),
            ReductionError::Eigen { source, .. } | ReductionError::ReducedEigen(source) => {
                source.is_input()
            }
            ReductionError::Model(_)
            | ReductionError::SingularResidual { .. }
            | ReductionError::SingularCoupling { .. }
            | ReductionError::Shape { .. } => false,
            _ => true,
        }
    }
}

#[cfg(test)]
mod tests;
