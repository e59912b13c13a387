//! `plot.frf`: FRF overlays (amplitude in dB and phase) of measured and predicted FRFs with the
//! `χ_s`/`χ_a` curves, as PNG and SVG; optionally also one small panel per FRF (`|H|` on log
//! axes, measured against predicted, FRAC (4.10) per panel).

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{correlation_from_artefact, frf_from_artefact, plot_artefact};
use crate::core::DofId;
use crate::frf::FrfPair;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::report::frf_plot::{
    FrfPlotOptions, MAX_FRFS, MAX_SIDE_PX, MIN_SIDE_PX, SmallMultiplesOptions, frf_overlay,
    frf_small_multiples,
};

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
    /// Also draw `frf_panels.png`/`.svg`: one small panel per FRF (`frfs`, or every measured
    /// FRF up to 64) with `|H|` on log axes, measured against predicted, and the FRAC.
    #[serde(default, skip_serializing_if = "is_false")]
    pub small_multiples: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
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
            "frf.png and frf.svg; frf_panels.png and .svg with `small_multiples`",
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
            pairs: pairs.clone(),
        };
        let fig = frf_overlay(&measured, predicted.as_ref(), correlation.as_ref(), &opts)
            .map_err(StageError::failed)?;
        let mut plot = plot_artefact("frf", &p.title, fig);
        if p.small_multiples {
            let panels = frf_small_multiples(
                &measured,
                predicted.as_ref(),
                correlation.as_ref(),
                &SmallMultiplesOptions {
                    title: p.title.clone(),
                    pairs,
                },
            )
            .map_err(StageError::failed)?;
            plot.blobs.insert("frf_panels.png".into(), panels.png);
            plot.blobs
                .insert("frf_panels.svg".into(), panels.svg.into_bytes());
        }
        Ok(StageOutputs::from([("plot".to_string(), plot)]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::kinds::frf_to_artefact;
    use crate::frf::{FrfSet, Quantity};
    use faer::{Mat, c64};
    use std::sync::Arc;

    fn set() -> FrfSet {
        let pairs: Vec<FrfPair> = ["1:ux/1:ux", "2:ux/1:ux", "3:ux/1:ux"]
            .iter()
            .map(|s| parse_pair(s).unwrap())
            .collect();
        let freqs_hz: Vec<f64> = (1..=50).map(|k| 2.0 * k as f64).collect();
        let values = Mat::from_fn(freqs_hz.len(), pairs.len(), |k, j| {
            let w = freqs_hz[k] / 30.0;
            c64::new(1e-3 / (1.0 - w * w + 0.05 * (j + 1) as f64), 1e-5)
        });
        FrfSet {
            quantity: Quantity::Receptance,
            freqs_hz,
            pairs,
            values,
        }
    }

    /// `small_multiples` adds one panel per FRF to the plot artefact; without it the artefact
    /// holds the overlay only, and the option leaves the key's params unchanged when off.
    #[test]
    fn small_multiples_add_one_panel_per_frf() {
        let mut inputs = StageInputs::default();
        inputs
            .artefacts
            .insert("measured".into(), Arc::new(frf_to_artefact(&set())));
        let mut p: Params = serde_json::from_value(serde_json::json!({})).unwrap();
        assert!(
            !serde_json::to_value(&p)
                .unwrap()
                .as_object()
                .unwrap()
                .contains_key("small_multiples")
        );
        let plain = PlotFrf::run(&p, &inputs).unwrap();
        assert_eq!(plain["plot"].blobs.len(), 2);
        p.small_multiples = true;
        let out = PlotFrf::run(&p, &inputs).unwrap();
        let svg = String::from_utf8(out["plot"].blobs["frf_panels.svg"].clone()).unwrap();
        crate::report::mac_plot::check::svg_elements(&svg).unwrap();
        assert_eq!(
            crate::report::mac_plot::check::count_with(&svg, "rect", "stroke=\"#1E1E1E\""),
            3
        );
        assert!(out["plot"].blobs["frf_panels.png"].starts_with(b"\x89PNG"));
    }
}
