//! Assembly of system matrices from model descriptions.

pub mod lumped;
pub mod system;

pub use system::{SystemMatrices, SystemMatricesError};
