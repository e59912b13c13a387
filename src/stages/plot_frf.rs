//! `plot.frf`: FRF overlays (amplitude in dB and phase) of measured and predicted FRFs with the
//! `χ_s`/`χ_a` curves, as PNG and SVG.

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{correlation_from_artefact, frf_from_artefact, plot_artefact};
use crate::core::DofId;
use crate::frf::FrfPair;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::report::frf_plot::{FrfPlotOptions, MAX_FRFS, MAX_SIDE_PX, MIN_SIDE_PX, frf_overlay};

/// The stage.
pub struct PlotFrf;

/// Parameters of `plot.frf`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Figure title.
    #[serde(default = "title")]
    pub title: String,
    /// FRFs to draw as `response/excitation` labels (default: the first `max_frfs` measured).
    #[serde(default)]
    pub frfs: Option<Vec<String>>,
    /// Most FRFs drawn (1–8).
    #[serde(default = "four")]
    pub max_frfs: usize,
    /// Width in pixels.
    #[serde(default = "width")]
    pub width_px: u32,
    /// Height in pixels.
    #[serde(default = "height")]
    pub height_px: u32,
}

fn title() -> String {
    "FRF overlay".into()
}
fn four() -> usize {
    4
}
fn width() -> u32 {
    1200
}
fn height() -> u32 {
    900
}

fn parse_pair(s: &str) -> Result<FrfPair, String> {
    let (r, e) = s
        .split_once('/')
        .ok_or_else(|| format!("`{s}` is not `response/excitation`, e.g. `2:ux/1:ux`"))?;
    let response: DofId = r
        .parse()
        .map_err(|e: crate::core::DofParseError| e.to_string())?;
    let excitation: DofId = e
        .parse()
        .map_err(|e: crate::core::DofParseError| e.to_string())?;
    Ok(FrfPair {
        response,
        excitation,
    })
}

impl TypedStage for PlotFrf {
    type Params = Params;
    const KIND: &'static str = "plot.frf";
    const SUMMARY: &'static str =
        "FRF overlay figure (dB amplitude, phase, chi_s and chi_a) as PNG and SVG";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "measured",
                ArtefactKind::Frf,
                "measured FRFs (drawn as dots)",
            ),
            PortSpec::optional(
                "predicted",
                ArtefactKind::Frf,
                "predicted FRFs (drawn as lines)",
            ),
            PortSpec::optional(
                "correlation",
                ArtefactKind::Correlation,
                "chi_s and chi_a curves",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "plot",
            ArtefactKind::Plot,
            "frf.png and frf.svg",
        )]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if p.max_frfs == 0 || p.max_frfs > MAX_FRFS {
            issues.push(ParamIssue::at(
                "max_frfs",
                format!("{} must be 1 to {MAX_FRFS}", p.max_frfs),
            ));
        }
        for (name, v) in [("width_px", p.width_px), ("height_px", p.height_px)] {
            if !(MIN_SIDE_PX..=MAX_SIDE_PX).contains(&v) {
                issues.push(ParamIssue::at(
                    name,
                    format!("{v} must be {MIN_SIDE_PX} to {MAX_SIDE_PX}"),
                ));
            }
        }
        for (i, s) in p.frfs.iter().flatten().enumerate() {
            if let Err(e) = parse_pair(s) {
                issues.push(ParamIssue {
                    path: vec!["frfs".into(), i.to_string()],
                    message: e,
                });
            }
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let measured = frf_from_artefact(inputs.require("measured")?)?;
        let predicted = inputs.get("predicted").map(frf_from_artefact).transpose()?;
        let correlation = inputs
            .get("correlation")
            .map(correlation_from_artefact)
            .transpose()?;
        let pairs = p
            .frfs
            .as_ref()
            .map(|l| {
                l.iter()
                    .map(|s| parse_pair(s))
                    .collect::<Result<Vec<_>, _>>()
            })
            .transpose()
            .map_err(StageError::input_at("pairs"))?;
        let opts = FrfPlotOptions {
            title: p.title.clone(),
            width_px: p.width_px,
            height_px: p.height_px,
            max_frfs: p.max_frfs,
            pairs,
        };
        let fig = frf_overlay(&measured, predicted.as_ref(), correlation.as_ref(), &opts)
            .map_err(StageError::failed)?;
        Ok(StageOutputs::from([(
            "plot".to_string(),
            plot_artefact("frf", &p.title, fig),
        )]))
    }
}
