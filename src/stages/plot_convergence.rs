//! `plot.convergence`: the convergence history of an `update` run as PNG and SVG: every
//! parameter's value per iteration (relative to its initial value, or in its own unit), with
//! the true values dashed when they are known, and the mean `χ_s`, `χ_a` per iteration.

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::plot_artefact;
use crate::artefact::update::convergence_from_artefact;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::report::line_plot::{Line, LinePanel, LinePlot, line_plot};
use indexmap::IndexMap;

/// The stage.
pub struct PlotConvergence;

/// Most parameters drawn in one panel (the palette's distinct colours).
const MAX_PARAMETERS: usize = 12;

/// Parameters of `plot.convergence`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Figure title.
    #[serde(default = "title")]
    pub title: String,
    /// Parameters to draw, by name (default: all, at most 12).
    #[serde(default)]
    pub parameters: Option<Vec<String>>,
    /// Draw each value divided by its initial value (default), or in its own unit.
    #[serde(default = "yes")]
    pub relative: bool,
    /// Known true values by parameter name, drawn as dashed lines (simulated studies).
    #[serde(default)]
    pub truth: IndexMap<String, f64>,
}

fn title() -> String {
    "Convergence".into()
}
fn yes() -> bool {
    true
}

impl TypedStage for PlotConvergence {
    type Params = Params;
    const KIND: &'static str = "plot.convergence";
    const SUMMARY: &'static str = "Convergence history of an update: parameters and mean chi_s, chi_a per iteration (PNG, SVG)";
    const IMPL_VERSION: u32 = 2;

    fn inputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "result",
            ArtefactKind::UpdateResult,
            "the result of an `update` stage",
        )]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "plot",
            ArtefactKind::Plot,
            "convergence.png and convergence.svg",
        )]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if let Some(list) = &p.parameters {
            if list.is_empty() {
                issues.push(ParamIssue::at(
                    "parameters",
                    "is empty; leave it out to draw every parameter, or name at least one",
                ));
            }
            if list.len() > MAX_PARAMETERS {
                issues.push(ParamIssue::at(
                    "parameters",
                    format!(
                        "names {} parameters; at most {MAX_PARAMETERS} can be told apart in one panel",
                        list.len()
                    ),
                ));
            }
        }
        for (name, v) in &p.truth {
            if !v.is_finite() || (p.relative && *v == 0.0) {
                issues.push(ParamIssue {
                    path: vec!["truth".into(), name.clone()],
                    message: format!("{v} must be a finite value (non-zero when relative)"),
                });
            }
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let c = convergence_from_artefact(inputs.require("result")?)?;
        let known = || c.parameters.join(", ");
        let unknown = |name: &str, field: &str| {
            StageError::input(
                field,
                format!(
                    "names `{name}`, which the result does not hold; its parameters are {}",
                    known()
                ),
            )
        };
        let chosen: Vec<usize> = match &p.parameters {
            Some(list) => list
                .iter()
                .map(|n| {
                    c.parameters
                        .iter()
                        .position(|q| q == n)
                        .ok_or_else(|| unknown(n, "parameters"))
                })
                .collect::<Result<_, _>>()?,
            None if c.parameters.len() > MAX_PARAMETERS => {
                return Err(StageError::input(
                    "parameters",
                    format!(
                        "the result holds {} parameters; name at most {MAX_PARAMETERS} in `parameters` ({})",
                        c.parameters.len(),
                        known()
                    ),
                ));
            }
            None => (0..c.parameters.len()).collect(),
        };
        if let Some(name) = p.truth.keys().find(|n| !c.parameters.contains(n)) {
            return Err(unknown(name, "truth"));
        }
        let series = chosen
            .iter()
            .map(|&q| {
                let scale = if p.relative { c.initial[q] } else { 1.0 };
                if scale == 0.0 {
                    return Err(StageError::input("relative", format!(
                        "parameter `{}` starts at 0, so it cannot be drawn relative to its initial value; set `relative: false`",
                        c.parameters[q]
                    )));
                }
                Ok(Line {
                    label: c.parameters[q].clone(),
                    values: c.values[q].iter().map(|v| v / scale).collect(),
                    reference: p.truth.get(&c.parameters[q]).map(|t| t / scale),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut panels = vec![LinePanel {
            title: "Parameters".into(),
            y_label: if p.relative {
                "value / initial value".into()
            } else {
                "value".into()
            },
            series,
        }];
        let correlation: Vec<Line> = [("mean chi_s", &c.mean_chi_s), ("mean chi_a", &c.mean_chi_a)]
            .into_iter()
            .filter(|(_, v)| v.iter().any(|x| x.is_finite()))
            .map(|(label, v)| Line {
                label: label.into(),
                values: v.clone(),
                reference: None,
            })
            .collect();
        if !correlation.is_empty() {
            panels.push(LinePanel {
                title: "Mean correlation over every measured line".into(),
                y_label: "mean".into(),
                series: correlation,
            });
        }
        let plot = LinePlot {
            title: format!("{} ({})", p.title, c.method),
            x_label: "iteration".into(),
            panels,
        };
        let fig = line_plot(&plot).map_err(StageError::failed)?;
        Ok(StageOutputs::from([(
            "plot".to_string(),
            plot_artefact("convergence", &p.title, fig),
        )]))
    }
}
