//! Readers of model and measurement files written by other tools: Nastran bulk data, UFF.

pub mod nastran;
pub mod uff;
