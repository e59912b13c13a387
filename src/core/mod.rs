//! Identifiers shared by every layer: degrees of freedom and their labels.

mod dof;
mod fault;
pub mod input;
pub mod memory;

pub use dof::{Component, DofId, DofParseError};
pub use fault::InputFault;
