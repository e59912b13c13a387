//! Writers of model files for other tools: Nastran bulk data, afresh ([`nastran`]) or as the
//! user's own deck with the updated values ([`deck_update`]). (Universal files are written by
//! `frf::io::uff::write`.)

pub mod deck_update;
pub mod nastran;
