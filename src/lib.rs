//! femu — finite-element model updating from measured frequency response functions.
//!
//! The method is H. Grafe's (1998) FRF model updating: shape and amplitude correlation
//! coefficients, their sensitivities, the predictor-corrector and the response function method.
//! The crate is a data-pipeline engine: YAML pipelines chain stages that read and write typed,
//! cached artefacts. Numerical modules (`core`, `model`, `fe`, `sparse`, `eigen`, `frf`,
//! `pairing`, `correlation`, `sensitivity`, `reduction`, `localisation`, `updating`, `report`) never import
//! the engine (`artefact`, `cache`, `pipeline`, `stages`, `cli`, `sweep`); `stages` is the glue. The layers,
//! the error flow and the caching are described in `docs/architecture.md`, the mathematics in
//! `docs/theory.md`.

#![warn(missing_docs)]
// Every `unsafe` block states the invariant that makes it sound.
#![warn(clippy::undocumented_unsafe_blocks)]
// `!(x > 0.0)` is used on purpose: it rejects NaN together with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod artefact;
pub mod bench;
pub mod cache;
pub mod cli;
pub mod core;
pub mod correlation;
pub mod eigen;
pub mod fe;
pub mod frf;
pub mod localisation;
pub mod model;
pub mod pairing;
pub mod pipeline;
pub mod reduction;
pub mod report;
pub mod run_report;
pub mod sensitivity;
pub mod sparse;
pub mod stages;
pub mod sweep;
pub mod updating;
