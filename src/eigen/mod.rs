//! Eigensolvers for `K φ = λ M φ`.

pub mod dense;
pub mod sparse;

pub use dense::{EigenError, ModeSelection, Modes, dense_generalized};
pub use sparse::{SparseEigenInfo, SparseEigenParams, lowest_modes};
