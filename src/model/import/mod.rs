//! Readers of model files written by other tools: Nastran bulk data. (Universal files, which
//! hold measured FRFs, are read by `frf::io::uff`.)

pub mod nastran;
