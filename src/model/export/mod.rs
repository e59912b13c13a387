//! Writers of files for other tools: Nastran bulk data, UFF.

pub mod nastran;
pub mod uff;
