//! `mesh.parameters`: declares updating parameters on a model (docs/theory.md §2: a property of a
//! named element set, with bounds), sets parameter values (to build an erroneous initial model, or
//! a "true" structure for simulated measurements), and writes the final values of an `update` run
//! back into the model (input `result`), so the updated model is a mesh every stage reads.

use crate::artefact::ArtefactKind;
use crate::artefact::mesh::{mesh_from_artefact, mesh_to_artefact};
use crate::artefact::update::final_values;
use crate::model::{Parameter, ParameterKind};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use std::collections::BTreeMap;

/// The stage.
pub struct MeshParameters;

/// One parameter to declare.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    /// Name (letters, digits, `_`, `-`), unique in the model.
    pub name: String,
    /// What it changes: `shell_thickness`, `youngs_modulus`, `density`, `beam_width`,
    /// `beam_height`, `{spring_stiffness: uy}`, `{lumped_mass: ux}`.
    pub kind: ParameterKind,
    /// The element set it acts on (defaults to `name`).
    #[serde(default)]
    pub set: Option<String>,
    /// Lowest allowed value, SI (default: a tenth of the value).
    #[serde(default)]
    pub lower: Option<f64>,
    /// Highest allowed value, SI (default: ten times the value).
    #[serde(default)]
    pub upper: Option<f64>,
}

/// Parameters of `mesh.parameters`.
#[derive(Clone, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Parameters to declare (added to those the model already has; a name declared again is
    /// replaced).
    #[serde(default)]
    pub declare: Vec<ParameterSpec>,
    /// Values to set, SI, by parameter name (declared here or before).
    #[serde(default)]
    pub values: BTreeMap<String, f64>,
    /// Values to set as factors of the current value, by parameter name.
    #[serde(default)]
    pub scale: BTreeMap<String, f64>,
    /// Keep only the declared parameters of this stage (drop the model's others).
    #[serde(default)]
    pub replace: bool,
}

fn valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

impl TypedStage for MeshParameters {
    type Params = Params;
    const KIND: &'static str = "mesh.parameters";
    const SUMMARY: &'static str =
        "Declare updating parameters on element sets, set their values, or apply an update result";
    const IMPL_VERSION: u32 = 1;
    const PREFLIGHT: bool = true;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required("mesh", ArtefactKind::Mesh, "the model"),
            PortSpec::optional(
                "result",
                ArtefactKind::UpdateResult,
                "an update run whose final values are written into the model",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "mesh",
            ArtefactKind::Mesh,
            "the model with its parameters and values",
        )]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        let mut seen = std::collections::BTreeSet::new();
        for (i, d) in p.declare.iter().enumerate() {
            if !valid_name(&d.name) {
                issues.push(ParamIssue::at(
                    &format!("declare.{i}.name"),
                    format!("`{}`: use letters, digits, `_` and `-`", d.name),
                ));
            }
            if !seen.insert(d.name.clone()) {
                issues.push(ParamIssue::at(
                    &format!("declare.{i}.name"),
                    format!("`{}` is declared twice", d.name),
                ));
            }
            for (field, v) in [("lower", d.lower), ("upper", d.upper)] {
                if let Some(v) = v
                    && !(v.is_finite() && v > 0.0)
                {
                    issues.push(ParamIssue::at(
                        &format!("declare.{i}.{field}"),
                        format!("{v} must be a positive finite number"),
                    ));
                }
            }
        }
        for (field, map) in [("values", &p.values), ("scale", &p.scale)] {
            for (name, v) in map {
                if !(v.is_finite() && *v > 0.0) {
                    issues.push(ParamIssue::at(
                        &format!("{field}.{name}"),
                        format!("{v} must be a positive finite number"),
                    ));
                }
            }
        }
        issues
    }

    /// Each declaration against the model: its set exists and its kind acts on the set's
    /// elements; the names given values exist.
    fn preflight(p: &Params, inputs: &StageInputs) -> Vec<ParamIssue> {
        use crate::model::ParameterValueError as E;
        let Some(Ok(mut model)) = inputs.get("mesh").map(mesh_from_artefact) else {
            return Vec::new();
        };
        if p.replace {
            model.parameters.clear();
        }
        let mut issues = Vec::new();
        for (i, d) in p.declare.iter().enumerate() {
            let param = Parameter {
                name: d.name.clone(),
                kind: d.kind.clone(),
                set: d.set.clone().unwrap_or_else(|| d.name.clone()),
                lower: 0.0,
                upper: f64::INFINITY,
            };
            match model.parameter_value(&param) {
                Ok(_) => {
                    model.parameters.retain(|q| q.name != param.name);
                    model.parameters.push(param);
                }
                Err(e) => {
                    let field = match (&e, &d.set) {
                        (E::MissingSet { .. }, Some(_)) => "set",
                        (E::MissingSet { .. }, None) => "name",
                        _ => "kind",
                    };
                    let mut message = e.to_string();
                    if let E::MissingSet { set, .. } = &e
                        && let Some(near) = crate::pipeline::diagnostic::nearest(
                            set,
                            model.sets.keys().map(String::as_str),
                        )
                    {
                        message.push_str(&format!("; did you mean `{near}`?"));
                    }
                    issues.push(ParamIssue {
                        path: vec!["declare".into(), i.to_string(), field.into()],
                        message,
                    });
                }
            }
        }
        let declared: Vec<&str> = model.parameters.iter().map(|q| q.name.as_str()).collect();
        for (field, names) in [("values", &p.values), ("scale", &p.scale)] {
            for name in names.keys() {
                if !declared.contains(&name.as_str()) {
                    issues.push(ParamIssue {
                        path: vec![field.into(), name.clone()],
                        message: format!(
                            "`{name}` is not a parameter of the model; declared: {}",
                            declared.join(", ")
                        ),
                    });
                }
            }
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let mesh = inputs.require("mesh")?;
        let mut model = mesh_from_artefact(mesh)?;
        if p.replace {
            model.parameters.clear();
        }
        for d in &p.declare {
            let mut param = Parameter {
                name: d.name.clone(),
                kind: d.kind.clone(),
                set: d.set.clone().unwrap_or_else(|| d.name.clone()),
                lower: 0.0,
                upper: f64::INFINITY,
            };
            let value = model
                .parameter_value(&param)
                .map_err(|e| StageError::input("declare", format!("`{}`: {e}", d.name)))?;
            param.lower = d.lower.unwrap_or(0.1 * value);
            param.upper = d.upper.unwrap_or(10.0 * value);
            if !(param.lower <= param.upper) {
                return Err(StageError::input(
                    "declare",
                    format!(
                        "`{}`: lower bound {:e} above upper bound {:e}",
                        d.name, param.lower, param.upper
                    ),
                ));
            }
            model.parameters.retain(|q| q.name != param.name);
            model.parameters.push(param);
        }
        let find = |name: &str, model: &crate::model::Model| {
            model
                .parameters
                .iter()
                .find(|q| q.name == name)
                .cloned()
                .ok_or_else(|| {
                    StageError::input(
                        "",
                        format!(
                            "`{name}` is not a parameter of the model; declared: {}",
                            model
                                .parameters
                                .iter()
                                .map(|q| q.name.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    )
                })
        };
        let set = |name: &str, value: f64, model: &mut crate::model::Model| {
            let param = find(name, model)?;
            model
                .set_parameter_value(&param, value)
                .map_err(|e| StageError::input("", format!("`{name}`: {e}")))
        };
        for (name, v) in &p.values {
            set(name, *v, &mut model)?;
        }
        for (name, f) in &p.scale {
            let param = find(name, &model)?;
            let v = model
                .parameter_value(&param)
                .map_err(|e| StageError::input("", format!("`{name}`: {e}")))?;
            set(name, v * f, &mut model)?;
        }
        if let Some(result) = inputs.get("result") {
            for (name, v) in final_values(result)? {
                set(&name, v, &mut model)?;
            }
        }
        let mut out = mesh_to_artefact(&model);
        if let Some(request) = mesh.meta.get("eigenvalue_request") {
            // The imported deck's METHOD/EIGRL still asks for the same modes.
            out.meta
                .insert("eigenvalue_request".into(), request.clone());
        }
        Ok(StageOutputs::from([("mesh".to_string(), out)]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    #[test]
    fn bad_names_and_values_are_named() {
        let e = Typed::<MeshParameters>::new()
            .check(
                &serde_json::json!({
                    "declare": [{"name": "strip 1", "kind": "shell_thickness", "set": "strip_1"}],
                    "values": {"t1": -1.0}
                }),
                &CheckContext::default(),
            )
            .unwrap_err();
        assert_eq!(e[0].path, vec!["declare", "0", "name"]);
        assert_eq!(e[1].path, vec!["values", "t1"]);
    }

    #[test]
    fn unknown_kind_lists_the_valid_ones() {
        let e = Typed::<MeshParameters>::new()
            .check(
                &serde_json::json!({"declare": [{"name": "t1", "kind": "thickness"}]}),
                &CheckContext::default(),
            )
            .unwrap_err();
        assert!(e[0].message.contains("shell_thickness"), "{}", e[0].message);
    }
}
