//! Identifiers shared by every layer: degrees of freedom and their labels.

mod dof;
pub mod input;
pub mod memory;

pub use dof::{Component, DofId, DofParseError};
