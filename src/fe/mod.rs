//! Assembly of system matrices from model descriptions.

pub mod assembly;
pub mod element;
pub mod lumped;
pub mod system;

pub use system::{SystemMatrices, SystemMatricesError};
