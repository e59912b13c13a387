//! Writers of model files for other tools: Nastran bulk data. (Universal files are written by
//! `frf::io::uff::write`.)

pub mod nastran;
