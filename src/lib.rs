//! femu — finite-element model updating from measured frequency response functions.
//!
//! The method is H. Grafe's (1998) FRF model updating: shape and amplitude correlation
//! coefficients, their sensitivities, the predictor-corrector and the response function method.
//! The crate is a data-pipeline engine: YAML pipelines chain stages that read and write typed,
//! cached artefacts. Numerical modules (`core`, `model`, `fe`, `eigen`, `frf`, `correlation`)
//! never import the engine (`artefact`, `cache`, `pipeline`, `stages`, `cli`).

#![warn(missing_docs)]

pub mod artefact;
pub mod cache;
pub mod cli;
pub mod core;
pub mod correlation;
pub mod eigen;
pub mod fe;
pub mod frf;
pub mod model;
pub mod pipeline;
pub mod report;
pub mod stages;
