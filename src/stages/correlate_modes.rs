//! `correlate.modes`: two sets of modes compared, the thesis's check of a reduced model against
//! the full one (3.54) and the usual test–analysis modal correlation: elastic modes paired by
//! MAC (1.18), the relative eigenvalue and frequency errors of each pair, the MAC matrix and
//! the COMAC, as a table, a bar chart of the errors and MACs per mode and the MAC matrix as a
//! heat map with the pairs outlined.

use super::params::Positive;
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{modes_from_artefact, plot_artefact};
use crate::artefact::modal_correlation::{ModalCorrelationContext, modal_correlation_to_artefact};
use crate::correlation::{Pairing, correlate_modes};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::report::bar_plot::{BarPanel, BarPlot, bar_plot};
use crate::report::mac_plot::{MacPlot, mac_plot};
use faer::Mat;
use std::collections::HashMap;

/// The stage.
pub struct CorrelateModes;

/// How reference modes find their partners.
#[derive(
    Clone, Copy, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum PairingKind {
    /// Highest MAC not yet taken (reference order); below `min_mac` a mode stays unpaired.
    #[default]
    Mac,
    /// The i-th elastic mode with the i-th elastic mode.
    Order,
}

/// Parameters of `correlate.modes`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// `mac` (default) or `order`.
    #[serde(default)]
    pub pairing: PairingKind,
    /// Lowest MAC accepted as a pair (MAC pairing).
    #[serde(default = "half")]
    pub min_mac: f64,
    /// Compare only reference modes up to this frequency, Hz (default: all).
    #[serde(default)]
    pub max_freq_hz: Option<Positive>,
    /// Top of the validity band, Hz: pairs above it are flagged `in_band = 0`, drawn in the
    /// second colour and left out of the summary (thesis C3: 100 Hz).
    #[serde(default)]
    pub band_hz: Option<Positive>,
    /// Figure title.
    #[serde(default = "default_title")]
    pub title: String,
}

fn half() -> f64 {
    0.5
}

fn default_title() -> String {
    "Modal correlation: relative eigenvalue error (3.54) and MAC per reference mode".into()
}

impl TypedStage for CorrelateModes {
    type Params = Params;
    const KIND: &'static str = "correlate.modes";
    const SUMMARY: &'static str =
        "Modes against reference modes: MAC pairing, relative eigenvalue error (3.54), COMAC";
    const IMPL_VERSION: u32 = 2;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "reference",
                ArtefactKind::Modes,
                "reference modes (full model, or test)",
            ),
            PortSpec::required(
                "predicted",
                ArtefactKind::Modes,
                "modes to judge (reduced or updated model), sharing DOFs with the reference",
            ),
            PortSpec::optional(
                "map",
                ArtefactKind::TestMap,
                "test.pair's map: the predicted (model) modes are taken at the reference's measured DOFs, φ_t = Σ w φ",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "correlation",
                ArtefactKind::ModalCorrelation,
                "pairs with eigenvalue error and MAC, the MAC matrix and COMAC",
            ),
            PortSpec::required(
                "plot",
                ArtefactKind::Plot,
                "errors.png/svg: |eigenvalue error| (log axis) and MAC per reference mode",
            ),
            PortSpec::required(
                "mac",
                ArtefactKind::Plot,
                "mac.png/svg: the MAC matrix (1.18) of the elastic modes as a heat map, pairs outlined",
            ),
        ]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        if !(0.0..=1.0).contains(&p.min_mac) {
            v.push(ParamIssue::at(
                "min_mac",
                format!("{} is not a MAC: give a value in [0, 1]", p.min_mac),
            ));
        }
        v
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let reference = modes_from_artefact(inputs.require("reference")?)?;
        let mut predicted = modes_from_artefact(inputs.require("predicted")?)?;
        if let Some(m) = inputs.get("map") {
            let map = crate::artefact::kinds::test_map::test_map_from_artefact(m)?;
            let (dofs, shapes) = map
                .shapes_at_test_dofs(&predicted.dofs, predicted.modes.shapes.as_ref())
                .map_err(|e| StageError::input("map", e))?;
            predicted.dofs = dofs;
            predicted.modes.shapes = shapes;
        }
        // Rows of the reference that the prediction also has, in the reference's order.
        let at: HashMap<_, usize> = predicted
            .dofs
            .iter()
            .enumerate()
            .map(|(i, d)| (*d, i))
            .collect();
        let rows: Vec<(usize, usize)> = reference
            .dofs
            .iter()
            .enumerate()
            .filter_map(|(i, d)| at.get(d).map(|j| (i, *j)))
            .collect();
        if rows.is_empty() {
            return Err(StageError::input(
                "",
                format!(
                    "the two mode sets share no DOF: reference has {} (first {}), predicted {} (first {}); \
                 expand a reduced model's modes to physical DOFs or take both from the same mesh",
                    reference.dofs.len(),
                    reference
                        .dofs
                        .first()
                        .map(|d| d.to_string())
                        .unwrap_or_default(),
                    predicted.dofs.len(),
                    predicted
                        .dofs
                        .first()
                        .map(|d| d.to_string())
                        .unwrap_or_default(),
                ),
            ));
        }
        let ref_hz = reference.modes.frequencies_hz();
        let pred_hz = predicted.modes.frequencies_hz();
        let (max_freq_hz, band_hz) = (
            p.max_freq_hz.map(Positive::get),
            p.band_hz.map(Positive::get),
        );
        let kept = match max_freq_hz {
            Some(f) => ref_hz.iter().filter(|h| **h <= f).count(),
            None => ref_hz.len(),
        };
        let ref_rigid = reference.modes.rigid_body_modes.min(kept);
        if kept == ref_rigid {
            return Err(StageError::input(
                "max_freq_hz",
                format!(
                    "no elastic reference mode to compare{}: the reference has {} modes, {} of them rigid-body modes",
                    max_freq_hz
                        .map(|f| format!(" below max_freq_hz = {f} Hz"))
                        .unwrap_or_default(),
                    ref_hz.len(),
                    reference.modes.rigid_body_modes
                ),
            ));
        }
        let a = Mat::from_fn(rows.len(), kept, |r, j| {
            reference.modes.shapes[(rows[r].0, j)]
        });
        let b = Mat::from_fn(rows.len(), pred_hz.len(), |r, j| {
            predicted.modes.shapes[(rows[r].1, j)]
        });
        let pairing = match p.pairing {
            PairingKind::Mac => Pairing::Mac { min_mac: p.min_mac },
            PairingKind::Order => Pairing::Order,
        };
        let pred_rigid = predicted.modes.rigid_body_modes;
        let c = correlate_modes(
            (&reference.modes.eigenvalues[..kept], a.as_ref(), ref_rigid),
            (&predicted.modes.eigenvalues, b.as_ref(), pred_rigid),
            pairing,
        );
        let dofs: Vec<_> = rows.iter().map(|(i, _)| reference.dofs[*i]).collect();
        let name = match p.pairing {
            PairingKind::Mac => "mac",
            PairingKind::Order => "order",
        };
        let artefact = modal_correlation_to_artefact(
            &c,
            &ModalCorrelationContext {
                reference_hz: &ref_hz,
                predicted_hz: &pred_hz,
                rigid_body_modes: (ref_rigid, pred_rigid),
                dofs: &dofs,
                band_hz,
                pairing: (name, p.min_mac),
            },
        );
        let labels: Vec<String> = c
            .pairs
            .iter()
            .map(|x| (x.reference + 1).to_string())
            .collect();
        let marked: Vec<bool> = c
            .pairs
            .iter()
            .map(|x| band_hz.is_some_and(|b| ref_hz[x.reference] > b))
            .collect();
        let panel = |title: &str, values: Vec<f64>, log: bool| BarPanel {
            title: title.into(),
            labels: labels.clone(),
            values,
            marked: marked.clone(),
            log,
        };
        let fig = bar_plot(&BarPlot {
            title: p.title.clone(),
            y_label: "per reference mode".into(),
            panels: vec![
                panel(
                    "|relative eigenvalue error| (3.54)",
                    c.pairs.iter().map(|x| x.eigenvalue_error).collect(),
                    true,
                ),
                panel("MAC", c.pairs.iter().map(|x| x.mac).collect(), false),
            ],
            columns: 2,
            marked_label: p
                .band_hz
                .map(|b| format!("above the validity band ({b} Hz)"))
                .unwrap_or_default(),
        })
        .map_err(StageError::failed)?;
        let mac_title = "MAC matrix (1.18)";
        let mac_fig = mac_plot(&MacPlot {
            title: mac_title.into(),
            mac: c.mac.as_ref(),
            reference: (0..c.mac.nrows())
                .map(|i| (ref_rigid + i + 1).to_string())
                .collect(),
            predicted: (0..c.mac.ncols())
                .map(|j| (pred_rigid + j + 1).to_string())
                .collect(),
            pairs: c
                .pairs
                .iter()
                .map(|x| (x.reference - ref_rigid, x.predicted - pred_rigid))
                .collect(),
            reference_label: "reference mode no.".into(),
            predicted_label: "predicted mode no.".into(),
        })
        .map_err(StageError::failed)?;
        Ok(StageOutputs::from([
            ("correlation".to_string(), artefact),
            ("plot".to_string(), plot_artefact("errors", &p.title, fig)),
            ("mac".to_string(), plot_artefact("mac", mac_title, mac_fig)),
        ]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::kinds::modes_to_artefact;
    use crate::core::DofId;
    use crate::eigen::Modes;
    use std::sync::Arc;

    fn modes(node: u64) -> crate::artefact::Artefact {
        let dofs: Vec<DofId> = (0..3)
            .map(|i| format!("{}:u{}", node + i, "x").parse().unwrap())
            .collect();
        let m = Modes {
            eigenvalues: vec![100.0, 400.0],
            shapes: Mat::from_fn(3, 2, |i, j| if i == j { 1.0 } else { 0.0 }),
            residuals: vec![0.0; 2],
            orthogonality_error: 0.0,
            rigid_body_modes: 0,
        };
        modes_to_artefact(&dofs, &m)
    }

    fn inputs(a: u64, b: u64) -> StageInputs {
        let mut i = StageInputs::default();
        i.artefacts.insert("reference".into(), Arc::new(modes(a)));
        i.artefacts.insert("predicted".into(), Arc::new(modes(b)));
        i
    }

    fn params() -> Params {
        serde_json::from_value(serde_json::json!({})).unwrap()
    }

    /// Shapes over disjoint DOFs are refused with both sets named; overlapping DOFs are matched
    /// by label, not by row.
    #[test]
    fn rows_are_matched_by_dof() {
        let e = CorrelateModes::run(&params(), &inputs(1, 10)).unwrap_err();
        assert!(e.to_string().contains("share no DOF"), "{e}");
        let out = CorrelateModes::run(&params(), &inputs(1, 1)).unwrap();
        let c = &out["correlation"];
        assert_eq!(c.meta["n_dofs"], 3);
        assert_eq!(c.meta["n_pairs"], 2);
        assert_eq!(c.meta["max_abs_eigenvalue_error_in_band"], 0.0);
        // The heat map: one cell per pair of elastic modes, both pairs outlined.
        let svg = String::from_utf8(out["mac"].blobs["mac.svg"].clone()).unwrap();
        let cells = crate::report::mac_plot::check::svg_elements(&svg).unwrap();
        assert_eq!(cells["polygon"], 2 * 2);
        assert_eq!(
            crate::report::mac_plot::check::count_with(&svg, "rect", "stroke=\"#DC141E\""),
            2 + 1
        );
        assert!(out["mac"].blobs["mac.png"].starts_with(b"\x89PNG"));
        // Shifted by one node, two rows are shared and the shapes no longer match one to one.
        let shifted = CorrelateModes::run(&params(), &inputs(1, 2)).unwrap();
        assert_eq!(shifted["correlation"].meta["n_dofs"], 2);
        let mut bad = params();
        bad.min_mac = 1.5;
        assert_eq!(
            CorrelateModes::validate(&mut bad, &CheckContext::default()).len(),
            1
        );
    }
}
