//! `reduce.force_coupling`: free interface with force coupling (Lombard et al. 1997, thesis
//! 3.40–3.51: (3.40), (3.41), (3.42), (3.43), (3.44), (3.45), (3.46), (3.47), (3.48), (3.49),
//! (3.50), (3.51)): physical master DOFs only, chosen by Effective Independence (Kammer 1991) from
//! the candidates, junction forces eliminated by compatibility and equilibrium, optional
//! second-level condensation (3.53).

use super::params::{Count, Positive};
use super::reduce_common::{self, ComponentModes};
use crate::core::DofId;
use crate::fe::element::MassKind;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::reduction::force_coupling::MasterSelection;
use crate::reduction::{Method, SecondLevel};

/// The stage.
pub struct ReduceForceCoupling;

/// Second-level condensation settings.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SecondLevelParams {
    /// Master DOFs kept.
    pub keep: usize,
    /// Modes of the first-level model used (at most `keep`).
    pub modes: usize,
}

/// Parameters.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Keep component modes up to this frequency, Hz (default 200 Hz when `count` is absent).
    #[serde(default)]
    pub max_freq_hz: Option<Positive>,
    /// Keep this many component modes per substructure.
    #[serde(default)]
    pub count: Option<Count>,
    /// Candidate master DOFs (default: every internal translational DOF).
    #[serde(default)]
    pub candidates: Option<Vec<DofId>>,
    /// DOFs always kept as masters (e.g. the measured DOFs); internal DOFs only.
    #[serde(default)]
    pub required: Vec<DofId>,
    /// Masters per kept component mode (at least 1).
    #[serde(default = "one")]
    pub masters_per_mode: f64,
    /// Optional second-level condensation (3.53).
    #[serde(default)]
    pub second_level: Option<SecondLevelParams>,
    /// Mass matrix kind.
    #[serde(default)]
    pub mass: MassKind,
}

fn one() -> f64 {
    1.0
}

impl TypedStage for ReduceForceCoupling {
    type Params = Params;
    const KIND: &'static str = "reduce.force_coupling";
    const SUMMARY: &'static str = "Free interface with force coupling (Lombard): physical master DOFs only, chosen by Effective Independence";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        reduce_common::inputs()
    }

    fn outputs() -> Vec<PortSpec> {
        reduce_common::outputs()
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut v = modes(p).issues();
        if !(p.masters_per_mode >= 1.0 && p.masters_per_mode.is_finite()) {
            v.push(ParamIssue::at(
                "masters_per_mode",
                format!(
                    "{} must be at least 1 (Φ_m needs full column rank)",
                    p.masters_per_mode
                ),
            ));
        }
        if let Some(s) = &p.second_level
            && (s.modes == 0 || s.keep < s.modes)
        {
            v.push(ParamIssue::at(
                "second_level",
                format!(
                    "need 1 <= modes <= keep; got modes {} and keep {}",
                    s.modes, s.keep
                ),
            ));
        }
        v
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let method = Method::ForceCoupling {
            modes: modes(p).selection(),
            masters: MasterSelection {
                candidates: p.candidates.clone(),
                required: p.required.clone(),
                per_mode: p.masters_per_mode,
            },
            second_level: p.second_level.as_ref().map(|s| SecondLevel {
                keep: s.keep,
                modes: s.modes,
                required: p.required.clone(),
            }),
        };
        reduce_common::run(method, p.mass, None, inputs)
    }
}

fn modes(p: &Params) -> ComponentModes {
    ComponentModes {
        max_freq_hz: p.max_freq_hz,
        count: p.count,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    #[test]
    fn bad_params_are_named() {
        let e = Typed::<ReduceForceCoupling>::new()
            .check(
                &serde_json::json!({"masters_per_mode": 0.5, "second_level": {"keep": 3, "modes": 5}}),
                &CheckContext::default(),
            )
            .unwrap_err();
        assert!(e.iter().any(|i| i.message.contains("at least 1")));
        assert!(e.iter().any(|i| i.message.contains("modes <= keep")));
    }
}
