//! Model descriptions: what the structure is, before any matrix is built.

pub mod export;
pub mod import;
pub mod lumped;

pub use lumped::{LumpedMass, LumpedModel, LumpedModelError, LumpedSpring};
