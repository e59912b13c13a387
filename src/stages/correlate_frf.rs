//! `correlate.frf`: the shape and amplitude correlation coefficients `χ_s(ω)`, `χ_a(ω)` per line
//! (4.8, 4.9), FRAC per measured FRF (1.19), and their summary (docs/theory.md §4).

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{correlation_to_artefact, frf_from_artefact};
use crate::correlation::correlate;
use crate::pipeline::{PortSpec, StageError, StageInputs, StageOutputs, TypedStage};
use crate::stages::params::{Band, select_lines};

/// The stage.
pub struct CorrelateFrf;

/// Parameters of `correlate.frf`.
#[derive(Clone, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Only measured lines in `[lo, hi]` Hz are correlated (default: all).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band_hz: Option<Band>,
    /// Lines inside any of these bands are left out, e.g. `[[0, 0]]` for the static line or
    /// `[[49, 51]]` for mains hum (default: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exclude_hz: Vec<Band>,
}

impl TypedStage for CorrelateFrf {
    type Params = Params;
    const KIND: &'static str = "correlate.frf";
    const SUMMARY: &'static str =
        "Shape and amplitude correlation chi_s, chi_a per line and FRAC per FRF";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required("measured", ArtefactKind::Frf, "measured (reference) FRFs"),
            PortSpec::required(
                "predicted",
                ArtefactKind::Frf,
                "predicted FRFs on the same lines, holding every measured pair",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "correlation",
            ArtefactKind::Correlation,
            "chi_s, chi_a per line; FRAC per FRF",
        )]
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let mut measured = frf_from_artefact(inputs.require("measured")?)?;
        let mut predicted = frf_from_artefact(inputs.require("predicted")?)?;
        if p.band_hz.is_some() || !p.exclude_hz.is_empty() {
            measured = select_lines(&measured, p.band_hz, &p.exclude_hz)?;
            predicted = select_lines(&predicted, p.band_hz, &p.exclude_hz)?;
        }
        let c = correlate(&measured, &predicted).map_err(StageError::from_numerics(""))?;
        Ok(StageOutputs::from([(
            "correlation".to_string(),
            correlation_to_artefact(&c),
        )]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::kinds::frf_to_artefact;
    use crate::frf::{FrfPair, FrfSet, Quantity};
    use faer::{Mat, c64};
    use std::sync::Arc;

    /// Two FRFs on lines 0, 10, …, 100 Hz; the predicted one is the measured one scaled by
    /// `scale` on lines at or above 50 Hz, so a band below 50 Hz correlates perfectly.
    fn inputs(scale: f64) -> StageInputs {
        let pairs = ["1:uz", "2:uz"]
            .map(|r| FrfPair {
                response: r.parse().unwrap(),
                excitation: "1:uz".parse().unwrap(),
            })
            .to_vec();
        let freqs_hz: Vec<f64> = (0..=10).map(|k| 10.0 * k as f64).collect();
        let measured = FrfSet {
            quantity: Quantity::Receptance,
            freqs_hz: freqs_hz.clone(),
            pairs: pairs.clone(),
            values: Mat::from_fn(11, 2, |k, j| c64::new(1.0 + k as f64, j as f64 - 0.5)),
        };
        let mut predicted = measured.clone();
        for k in 5..11 {
            predicted.values[(k, 1)] *= scale;
        }
        let mut i = StageInputs::default();
        i.artefacts
            .insert("measured".into(), Arc::new(frf_to_artefact(&measured)));
        i.artefacts
            .insert("predicted".into(), Arc::new(frf_to_artefact(&predicted)));
        i
    }

    fn run(with: serde_json::Value, scale: f64) -> Result<Vec<(f64, f64)>, StageError> {
        let p: Params = serde_json::from_value(with).unwrap();
        let out = CorrelateFrf::run(&p, &inputs(scale))?;
        let c = crate::artefact::kinds::correlation_from_artefact(&out["correlation"]).unwrap();
        Ok(c.freqs_hz
            .iter()
            .copied()
            .zip(c.chi_s.iter().copied())
            .collect())
    }

    /// The band and the excluded bands keep exactly the lines inside `[lo, hi]` and outside
    /// every excluded band (ends included), and only those lines are correlated.
    #[test]
    fn band_and_exclusions_select_the_lines() {
        let all = run(serde_json::json!({}), 3.0).unwrap();
        assert_eq!(all.len(), 11);
        assert!(all[7].1 < 0.99, "scaled lines correlate worse: {all:?}");
        let lines = run(
            serde_json::json!({"band_hz": [0, 40], "exclude_hz": [[0, 0], [15, 25]]}),
            3.0,
        )
        .unwrap();
        let f: Vec<f64> = lines.iter().map(|l| l.0).collect();
        assert_eq!(f, [10.0, 30.0, 40.0]);
        assert!(lines.iter().all(|l| (l.1 - 1.0).abs() < 1e-14), "{lines:?}");
        // With no options the artefact is what it was before the options existed.
        let p = Params::default();
        assert_eq!(serde_json::to_value(&p).unwrap(), serde_json::json!({}));
    }

    /// A selection that leaves nothing names the field and the lines there are.
    #[test]
    fn an_empty_selection_names_the_lines() {
        let e = run(serde_json::json!({"band_hz": [200, 300]}), 1.0).unwrap_err();
        assert!(e.is_input(), "{e}");
        assert!(
            e.to_string().contains("band_hz") && e.to_string().contains("0 to 100 Hz"),
            "{e}"
        );
        let e = run(serde_json::json!({"exclude_hz": [[0, 100]]}), 1.0).unwrap_err();
        assert!(e.to_string().contains("exclude_hz"), "{e}");
        let bad: Result<Params, _> = serde_json::from_value(serde_json::json!({"band_hz": [5, 1]}));
        assert!(bad.unwrap_err().to_string().contains("start <= stop"));
    }
}
