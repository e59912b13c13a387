//! File formats of FRFs written by other tools: the Universal File Format (datasets 58 / 58b,
//! with the nodes, elements and units a test system writes beside them), and long-format tables
//! (CSV, or Parquet read by the caller).

pub mod table;
pub mod uff;
