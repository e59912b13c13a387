//! Eigensolvers for `K φ = λ M φ`.

pub mod dense;

pub use dense::{EigenError, ModeSelection, Modes, dense_generalized};
