//! Correlation of measured and predicted FRFs: the shape and amplitude correlation coefficients
//! `χ_s(ω)`, `χ_a(ω)` (4.8, 4.9) and the FRF assurance criterion FRAC (1.19).

pub mod frf;

pub use frf::{
    CorrelationError, FrfCorrelation, amplitude_correlation, correlate, frac, match_pairs,
    shape_correlation,
};
