//! Writers of files for other tools.

pub mod uff;
