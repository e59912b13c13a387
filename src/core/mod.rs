//! What every layer shares: degrees of freedom and their labels, the sparse-matrix type and
//! its conversions, small dense helpers, the input-fault trait and the allocator settings.

pub mod dense;
mod dof;
mod fault;
pub mod hashing;
pub mod input;
pub mod memory;
pub mod progress;
pub mod sparse;

pub use dof::{Component, DofId, DofParseError};
pub use fault::InputFault;
