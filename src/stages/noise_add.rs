//! `noise.add`: simulated measurement noise on FRFs — the thesis's multiplicative uniform noise
//! (2.29) or complex Gaussian noise at an SNR — reproducible from a seed (docs/theory.md §10).

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{frf_from_artefact, frf_to_artefact};
use crate::frf::{NoiseModel, add_noise};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};

/// The stage.
pub struct NoiseAdd;

/// Which noise.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    serde::Deserialize,
    serde::Serialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// `H (1 + p ε)`, `ε ~ U[interval]` (2.29).
    #[default]
    Thesis,
    /// `H + n`, complex Gaussian at `snr_db` per FRF.
    Gaussian,
}

/// Parameters of `noise.add`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// `thesis` (multiplicative uniform) or `gaussian`.
    #[serde(default)]
    pub noise: Kind,
    /// Level `p` of thesis noise (0.05 = 5 %).
    #[serde(default)]
    pub level: Option<f64>,
    /// Interval of `ε` for thesis noise; the thesis's lower bound was lost in extraction: `[0, 1]` (default) or `[-1, 1]`.
    #[serde(default)]
    pub interval: Option<[f64; 2]>,
    /// Signal-to-noise ratio in dB for Gaussian noise.
    #[serde(default)]
    pub snr_db: Option<f64>,
    /// Seed of the random streams.
    #[serde(default)]
    pub seed: u64,
}

impl TypedStage for NoiseAdd {
    type Params = Params;
    const KIND: &'static str = "noise.add";
    const SUMMARY: &'static str = "Seeded measurement noise: thesis multiplicative uniform (2.29) or complex Gaussian at an SNR";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![PortSpec::required("frf", ArtefactKind::Frf, "clean FRFs")]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required("frf", ArtefactKind::Frf, "noisy FRFs")]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        match p.noise {
            Kind::Thesis => {
                match p.level {
                    Some(l) if l.is_finite() && l >= 0.0 => {}
                    Some(l) => issues.push(ParamIssue::at(
                        "level",
                        format!("{l} must be >= 0 (0.05 for 5 %)"),
                    )),
                    None => issues.push(ParamIssue::at(
                        "level",
                        "thesis noise needs `level`, e.g. 0.05 for 5 %",
                    )),
                }
                let [a, b] = *p.interval.get_or_insert([0.0, 1.0]);
                if !(a.is_finite() && b.is_finite() && a <= b) {
                    issues.push(ParamIssue::at(
                        "interval",
                        format!("[{a}, {b}] must be ordered"),
                    ));
                }
                if p.snr_db.is_some() {
                    issues.push(ParamIssue::at(
                        "snr_db",
                        "`snr_db` belongs to `noise: gaussian`",
                    ));
                }
            }
            Kind::Gaussian => {
                match p.snr_db {
                    Some(s) if s.is_finite() => {}
                    _ => issues.push(ParamIssue::at(
                        "snr_db",
                        "gaussian noise needs a finite `snr_db`, e.g. 30",
                    )),
                }
                if p.level.is_some() || p.interval.is_some() {
                    issues.push(ParamIssue::at(
                        "level",
                        "`level` and `interval` belong to `noise: thesis`",
                    ));
                }
            }
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let mut set = frf_from_artefact(inputs.require("frf")?)?;
        let model = match p.noise {
            Kind::Thesis => {
                let [lower, upper] = p.interval.unwrap_or([0.0, 1.0]);
                NoiseModel::Multiplicative {
                    level: p.level.unwrap_or(0.0),
                    lower,
                    upper,
                }
            }
            Kind::Gaussian => NoiseModel::Gaussian {
                snr_db: p.snr_db.unwrap_or(f64::INFINITY),
            },
        };
        add_noise(&mut set, &model, p.seed);
        Ok(StageOutputs::from([(
            "frf".to_string(),
            frf_to_artefact(&set),
        )]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    #[test]
    fn negative_level_and_missing_snr() {
        let s = Typed::<NoiseAdd>::new();
        let e = s
            .check(
                &serde_json::json!({"level": -0.1}),
                &CheckContext::default(),
            )
            .unwrap_err();
        assert_eq!(e[0].path, vec!["level"]);
        let e = s
            .check(
                &serde_json::json!({"noise": "gaussian"}),
                &CheckContext::default(),
            )
            .unwrap_err();
        assert_eq!(e[0].path, vec!["snr_db"]);
        let v = s
            .check(
                &serde_json::json!({"level": 0.05, "seed": 3}),
                &CheckContext::default(),
            )
            .unwrap();
        assert_eq!(v["interval"], serde_json::json!([0.0, 1.0]));
    }
}
