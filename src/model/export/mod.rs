//! Exporters: Nastran bulk data.

pub mod nastran;
