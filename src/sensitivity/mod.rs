//! Sensitivities (docs/theory.md §3, §4, §7): modal projections of derivative matrices, eigenvalue
//! sensitivities, FRF, mode-shape and damping sensitivities on a modal basis, and the sensitivities of the
//! correlation coefficients `χ_s`, `χ_a`; all of them at measured DOFs that a test map combines
//! from model DOFs (`sensors`).

pub mod correlation;
pub mod frf;
pub mod modes;
pub mod projection;
pub mod sensors;

pub use correlation::{ChiSensitivity, chi_sensitivity};
pub use frf::{ModalFrfModel, damping_sensitivities, frf_sensitivities, log_magnitude_sensitivity};
pub use modes::mode_shape_sensitivities;
pub use projection::{
    ProjectedDerivative, eigenvalue_sensitivity, project, project_between,
    project_between_symmetric,
};
pub use sensors::{RowWeights, SensorMap};
