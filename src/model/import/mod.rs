//! Importers: Nastran bulk data.

pub mod nastran;
