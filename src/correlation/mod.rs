//! Correlation of measured and predicted FRFs: the shape and amplitude correlation coefficients
//! `χ_s(ω)`, `χ_a(ω)` (4.8, 4.9) and the FRF assurance criterion FRAC (1.19); of modes: MAC,
//! COMAC, pairing by MAC, eigenvalue error (3.54), FDAC.

pub mod frf;
pub mod modal;

pub use frf::{
    CorrelationError, FrfCorrelation, amplitude_correlation, correlate, frac, match_pairs,
    shape_correlation,
};
pub use modal::{
    ModeCorrelation, ModePair, Pairing, comac, correlate_modes, eigenvalue_error, fdac, mac,
    mac_matrix, pair_by_mac,
};
