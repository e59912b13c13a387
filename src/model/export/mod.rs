//! Writers of model files for other tools: Nastran bulk data. (Universal files are written by
//! [`crate::frf::io::uff::write`].)

pub mod nastran;
