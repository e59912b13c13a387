//! Eigensolvers for `K φ = λ M φ`: dense for small models, block Lanczos on the shift-invert
//! operator of a sparse Cholesky factor ([`crate::sparse::SymmetricFactor`]) for large ones.

pub mod dense;
pub mod request;
pub mod sparse;

pub use dense::{EigenError, ModeSelection, Modes, dense_generalized};
pub use request::EigenRequest;
pub use sparse::{
    ShiftedFactor, SparseEigenInfo, SparseEigenParams, lowest_modes, lowest_modes_keeping_factor,
    pencil_modes, pencil_modes_keeping_factor,
};
