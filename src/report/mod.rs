//! Reports: figures rendered from FRF sets and their correlation, in memory (PNG and SVG).
//!
//! Rendering needs no system fonts: the DejaVu Sans faces embedded in the binary are used, so
//! figures come out the same on any machine, byte for byte.

pub mod band_plot;
pub mod bar_plot;
pub mod box_plot;
pub mod figure;
pub mod frf_plot;
pub mod line_plot;
pub mod mac_plot;
pub mod mesh_plot;
pub mod pairing_plot;
pub mod posterior_plot;
