//! Readers of model and measurement files written by other tools.

pub mod uff;
