//! The response function method recovers the chain's masses from complete, noise-free FRFs.

use super::*;
use crate::frf::frequency_lines;
use crate::updating::rfm::{ResponseFunctionMethod, RfmSettings};

/// C1: with complete noise-free data the RFM recovers all four masses at any non-resonant
/// line — the equation is exact for parameters that enter linearly, so the first step lands
/// on the truth and the second confirms it. Tolerance 1e-8 (issue 5).
#[test]
fn rfm_recovers_the_masses_from_complete_data_at_any_line() {
    let freqs = frequency_lines(0.0, 40.0, 0.5);
    let data = measured(0.0, &freqs);
    for line in [5.0, 9.0, 18.0, 25.0, 33.5] {
        let method = ResponseFunctionMethod {
            measured: &data,
            settings: RfmSettings {
                lines_hz: vec![line],
                ..Default::default()
            },
        };
        let h = run(&method, &chain_model(&[1.0, 1.3, 1.0, 1.0]), 10).unwrap();
        for (i, v) in h.final_values.iter().enumerate() {
            assert!((v - 1.0).abs() < 1e-8, "line {line} Hz: m{} = {v}", i + 1);
        }
        assert_eq!(h.stop, StopReason::Converged, "line {line}");
        assert!(
            h.iterations.len() <= 4,
            "line {line}: {}",
            h.iterations.len()
        );
    }
}
