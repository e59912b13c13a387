//! Eigensolvers for `K φ = λ M φ`, and the sparse Cholesky factors they shift and invert.

pub mod dense;
pub mod factor;
mod layout;
mod multifrontal;
mod ordering;
mod product;
pub mod sparse;
mod thin;

pub use dense::{EigenError, ModeSelection, Modes, dense_generalized};
pub use factor::{FactorError, FactorInfo, SpdFactor};
pub use sparse::{
    ShiftedFactor, SparseEigenInfo, SparseEigenParams, lowest_modes, lowest_modes_keeping_factor,
};
