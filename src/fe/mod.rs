//! Element kernels and the assembly of system matrices from model descriptions.

pub mod assembly;
pub mod beam;
pub mod beam_offset;
pub mod beam_tapered;
pub mod damping;
pub mod element;
pub mod laminate;
pub mod lumped;
pub mod lumped_elements;
pub mod mass_properties;
pub mod model_assembly;
pub mod multipoint;
pub mod rod;
pub mod scalar_elements;
pub mod shell;
pub mod shell_quadratic;
pub mod solid;
pub mod system;

pub use system::{SystemMatrices, SystemMatricesError};
