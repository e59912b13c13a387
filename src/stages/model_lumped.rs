//! `model.lumped`: a lumped-parameter model (point masses, springs with optional dampers) from
//! the YAML itself, assembled into system matrices.

use crate::artefact::ArtefactKind;
use crate::artefact::Storage;
use crate::artefact::kinds::{lower_triplet_table, matrices_to_artefact};
use crate::core::DofId;
use crate::fe::lumped::{LumpedTarget, assemble_lumped, lumped_derivative};
use crate::model::{LumpedMass, LumpedModel, LumpedSpring};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use std::collections::BTreeSet;

/// The stage.
pub struct ModelLumped;

/// A point mass.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MassSpec {
    /// DOF carrying the mass.
    pub dof: DofId,
    /// Mass in kg (kg·m² on a rotation).
    pub m: f64,
}

/// A spring, to ground when `to` is omitted.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SpringSpec {
    /// First end.
    pub from: DofId,
    /// Second end; omitted for a spring to ground.
    #[serde(default)]
    pub to: Option<DofId>,
    /// Stiffness in N/m (N·m/rad on rotations).
    pub k: f64,
    /// Viscous damping in N·s/m.
    #[serde(default)]
    pub c: f64,
    /// Structural damping in N/m (enters as i·d).
    #[serde(default)]
    pub d: f64,
}

/// An updating parameter of a lumped model: the value of one mass or one spring's stiffness.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    /// Name (letters, digits, `_`, `-`), unique.
    pub name: String,
    /// The mass at this DOF.
    #[serde(default)]
    pub mass: Option<DofId>,
    /// The spring at this position in `springs` (from 1).
    #[serde(default)]
    pub spring: Option<usize>,
    /// Lowest allowed value (default: a thousandth of the initial value).
    #[serde(default)]
    pub lower: Option<f64>,
    /// Highest allowed value (default: a thousand times the initial value).
    #[serde(default)]
    pub upper: Option<f64>,
}

/// Parameters of `model.lumped`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Point masses; their order fixes the DOF order (spring-only DOFs follow).
    pub masses: Vec<MassSpec>,
    /// Springs between DOFs or to ground.
    #[serde(default)]
    pub springs: Vec<SpringSpec>,
    /// Updating parameters; each writes its `dK__<name>`, `dM__<name>` (they enter linearly).
    #[serde(default)]
    pub parameters: Vec<ParameterSpec>,
}

impl ParameterSpec {
    fn target(&self, p: &Params) -> Option<(LumpedTarget, f64)> {
        match (self.mass, self.spring) {
            (Some(d), None) => p
                .masses
                .iter()
                .position(|m| m.dof == d)
                .map(|i| (LumpedTarget::Mass(i), p.masses[i].m)),
            (None, Some(s)) if s >= 1 && s <= p.springs.len() => {
                Some((LumpedTarget::Spring(s - 1), p.springs[s - 1].k))
            }
            _ => None,
        }
    }
}

impl Params {
    fn model(&self) -> LumpedModel {
        let mut dofs: Vec<DofId> = Vec::new();
        let mut push = |d: DofId| {
            if !dofs.contains(&d) {
                dofs.push(d);
            }
        };
        self.masses.iter().for_each(|m| push(m.dof));
        for s in &self.springs {
            push(s.from);
            if let Some(t) = s.to {
                push(t);
            }
        }
        LumpedModel {
            dofs,
            masses: self
                .masses
                .iter()
                .map(|m| LumpedMass {
                    dof: m.dof,
                    value: m.m,
                })
                .collect(),
            springs: self
                .springs
                .iter()
                .map(|s| LumpedSpring {
                    from: s.from,
                    to: s.to,
                    stiffness: s.k,
                    viscous: s.c,
                    structural: s.d,
                })
                .collect(),
        }
    }
}

impl TypedStage for ModelLumped {
    type Params = Params;
    const KIND: &'static str = "model.lumped";
    const SUMMARY: &'static str =
        "Lumped masses and springs (with optional dampers) assembled into K, M, C, D";
    const IMPL_VERSION: u32 = 3;
    const PREFLIGHT: bool = true;

    fn inputs() -> Vec<PortSpec> {
        vec![]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "model",
            ArtefactKind::Matrices,
            "assembled system matrices",
        )]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        let check = |issues: &mut Vec<ParamIssue>, path: String, v: f64| {
            if !(v.is_finite() && v >= 0.0) {
                issues.push(ParamIssue::at(
                    &path,
                    format!("{v} must be a finite number >= 0"),
                ));
            }
        };
        if p.masses.is_empty() {
            issues.push(ParamIssue::at(
                "masses",
                "give at least one mass: `- {dof: \"1:ux\", m: 1.0}`",
            ));
        }
        let mut seen = BTreeSet::new();
        for (i, m) in p.masses.iter().enumerate() {
            check(&mut issues, format!("masses.{i}.m"), m.m);
            if !seen.insert(m.dof) {
                issues.push(ParamIssue::at(
                    &format!("masses.{i}.dof"),
                    format!("DOF {} has a mass already; give each DOF one mass", m.dof),
                ));
            }
        }
        let mut names = BTreeSet::new();
        for (i, q) in p.parameters.iter().enumerate() {
            if q.name.is_empty()
                || !q
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                issues.push(ParamIssue::at(
                    &format!("parameters.{i}.name"),
                    format!("`{}`: use letters, digits, `_` and `-`", q.name),
                ));
            }
            if !names.insert(q.name.clone()) {
                issues.push(ParamIssue::at(
                    &format!("parameters.{i}.name"),
                    format!("`{}` is used twice", q.name),
                ));
            }
            match (q.mass, q.spring) {
                (Some(_), Some(_)) | (None, None) => issues.push(ParamIssue::at(
                    &format!("parameters.{i}"),
                    "give `mass: <dof>` or `spring: <position from 1>`, one of them",
                )),
                _ => match q.target(p) {
                    None if q.mass.is_some() => issues.push(ParamIssue::at(
                        &format!("parameters.{i}.mass"),
                        format!(
                            "no mass at {}; masses are at {}",
                            q.mass.map(|d| d.to_string()).unwrap_or_default(),
                            p.masses
                                .iter()
                                .map(|m| m.dof.to_string())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    )),
                    None => issues.push(ParamIssue::at(
                        &format!("parameters.{i}.spring"),
                        format!(
                            "{} is not a spring position: 1 to {}",
                            q.spring.unwrap_or(0),
                            p.springs.len()
                        ),
                    )),
                    Some((_, v)) => {
                        let (lo, hi) = (q.lower.unwrap_or(v * 1e-3), q.upper.unwrap_or(v * 1e3));
                        if !(v > 0.0 && lo > 0.0 && lo <= v && v <= hi && hi.is_finite()) {
                            issues.push(ParamIssue::at(
                                &format!("parameters.{i}"),
                                format!(
                                    "the value {v} must be positive and lie within 0 < lower {lo} <= value <= upper {hi}"
                                ),
                            ));
                        }
                    }
                },
            }
        }
        for (i, s) in p.springs.iter().enumerate() {
            check(&mut issues, format!("springs.{i}.k"), s.k);
            check(&mut issues, format!("springs.{i}.c"), s.c);
            check(&mut issues, format!("springs.{i}.d"), s.d);
            if s.to == Some(s.from) {
                issues.push(ParamIssue::at(
                    &format!("springs.{i}.to"),
                    format!(
                        "the spring connects {} to itself; omit `to` for a spring to ground",
                        s.from
                    ),
                ));
            }
        }
        issues
    }

    fn run(p: &Params, _: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = p.model();
        let sys = assemble_lumped(&model).map_err(StageError::input_at(""))?;
        let mut a = matrices_to_artefact(&sys);
        let mut meta = Vec::new();
        for q in &p.parameters {
            let Some((target, value)) = q.target(p) else {
                return Err(StageError::input(
                    "parameters",
                    format!("parameter `{}` names no mass or spring", q.name),
                ));
            };
            let (dk, dm) =
                lumped_derivative(&model, target).map_err(StageError::input_at("parameters"))?;
            a = a
                .with_table(
                    &format!("dK__{}", q.name),
                    lower_triplet_table(&dk),
                    Storage::Ipc,
                )
                .with_table(
                    &format!("dM__{}", q.name),
                    lower_triplet_table(&dm),
                    Storage::Ipc,
                );
            meta.push(serde_json::json!({
                "name": q.name,
                "value": value,
                "lower": q.lower.unwrap_or(value * 1e-3),
                "upper": q.upper.unwrap_or(value * 1e3),
                "linear": true,
            }));
        }
        if !meta.is_empty() {
            a = a.with_meta("parameters", meta.into());
        }
        Ok(StageOutputs::from([("model".to_string(), a)]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    fn check(with: serde_json::Value) -> Result<serde_json::Value, Vec<ParamIssue>> {
        Typed::<ModelLumped>::new().check(&with, &CheckContext::default())
    }

    #[test]
    fn negative_stiffness_names_the_field() {
        let e = check(serde_json::json!({"masses": [{"dof": "1:ux", "m": 1.0}], "springs": [{"from": "1:ux", "k": -5.0}]})).unwrap_err();
        assert_eq!(e[0].path, vec!["springs", "0", "k"]);
    }

    #[test]
    fn bad_dof_label_names_the_field() {
        let e = check(serde_json::json!({"masses": [{"dof": "1:uw", "m": 1.0}]})).unwrap_err();
        assert_eq!(e[0].path, vec!["masses", "0", "dof"]);
        assert!(e[0].message.contains("ux uy uz"), "{}", e[0].message);
    }

    #[test]
    fn defaults_are_filled() {
        let v = check(serde_json::json!({"masses": [{"dof": "1:ux", "m": 1.0}], "springs": [{"from": "1:ux", "k": 5.0}]})).unwrap();
        assert_eq!(v["springs"][0]["c"], serde_json::json!(0.0));
        assert_eq!(v["springs"][0]["to"], serde_json::Value::Null);
    }
}
