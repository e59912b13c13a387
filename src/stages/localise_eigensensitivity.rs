//! `localise.eigensensitivity`: the classical error indicator (thesis 5.1–5.3: (5.1), (5.2), (5.3);
//! docs/theory.md §7), the unity-based eigenvalue sensitivity
//! `φ_i ∂λ_r/∂φ_i = φ_i φ_rᵀ(∂K/∂φ_i − λ_r ∂M/∂φ_i)φ_r` of every candidate for chosen modes,
//! normalised per mode. Purely analytical: it ignores the measurements, which is the thesis's
//! argument for the leverage. Writes the table, a mesh panel per mode and a bar panel per mode.

use super::localise_leverage::{Candidates, PlotParams, element_values};
use super::params::Band;
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::plot_artefact;
use crate::artefact::leverage::eigen_map_to_artefact;
use crate::artefact::mesh::mesh_from_artefact;
use crate::fe::element::MassKind;
use crate::localisation::{ModeChoice, eigenvalue_map};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::report::bar_plot::{BarPlot, bar_plot};
use crate::report::mesh_plot::{MeshPanel, MeshPlot, mesh_plot};

/// The stage.
pub struct LocaliseEigensensitivity;

/// Parameters of `localise.eigensensitivity`; give exactly one of `modes`, `elastic_modes`,
/// `band_hz`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// `parameters` (the model's declared ones) or `{every_element: {kind, set}}`.
    #[serde(default)]
    pub candidates: Candidates,
    /// Mode numbers, 1-based over all modes (rigid-body modes first), e.g. `[7, 8, 9]`.
    #[serde(default)]
    pub modes: Option<Vec<usize>>,
    /// The lowest this many elastic modes.
    #[serde(default)]
    pub elastic_modes: Option<usize>,
    /// Every elastic mode in `[lo, hi]` Hz.
    #[serde(default)]
    pub band_hz: Option<Band>,
    /// Mass matrix.
    #[serde(default)]
    pub mass: MassKind,
    /// Mesh panels per row.
    #[serde(default = "three")]
    pub columns: usize,
    /// Figures.
    #[serde(default)]
    pub plot: PlotParams,
}

fn three() -> usize {
    3
}

/// Most modes one map covers.
const MAX_MODES: usize = 48;

impl TypedStage for LocaliseEigensensitivity {
    type Params = Params;
    const KIND: &'static str = "localise.eigensensitivity";
    const SUMMARY: &'static str =
        "Error localisation: eigenvalue sensitivities (5.3) of candidate parameters per mode";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "mesh",
            ArtefactKind::Mesh,
            "the finite-element model (with declared parameters for `candidates: parameters`)",
        )]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "sensitivity",
                ArtefactKind::EigenvalueSensitivity,
                "sensitivity per candidate and mode, raw and normalised per mode",
            ),
            PortSpec::required(
                "maps",
                ArtefactKind::Plot,
                "maps.png/svg: the mesh coloured by the normalised sensitivity, one panel per mode",
            ),
            PortSpec::required(
                "bars",
                ArtefactKind::Plot,
                "bars.png/svg: normalised sensitivity per candidate, one panel per mode",
            ),
        ]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        let given = [
            p.modes.is_some(),
            p.elastic_modes.is_some(),
            p.band_hz.is_some(),
        ]
        .iter()
        .filter(|g| **g)
        .count();
        if given != 1 {
            issues.push(ParamIssue::at(
                "modes",
                "give exactly one of `modes: [7, 8, ...]` (1-based), `elastic_modes: 6` or `band_hz: [lo, hi]`",
            ));
        }
        if let Some(m) = &p.modes {
            if m.is_empty() || m.len() > MAX_MODES || m.contains(&0) {
                issues.push(ParamIssue::at(
                    "modes",
                    format!("list 1 to {MAX_MODES} mode numbers, each at least 1 (1-based)"),
                ));
            }
            let mut seen = std::collections::BTreeSet::new();
            if m.iter().any(|x| !seen.insert(*x)) {
                issues.push(ParamIssue::at("modes", "a mode is listed twice"));
            }
        }
        if let Some(n) = p.elastic_modes
            && !(1..=MAX_MODES).contains(&n)
        {
            issues.push(ParamIssue::at(
                "elastic_modes",
                format!("{n} must be 1 to {MAX_MODES}"),
            ));
        }
        if !(1..=8).contains(&p.columns) {
            issues.push(ParamIssue::at(
                "columns",
                format!("{} must be 1 to 8", p.columns),
            ));
        }
        issues.extend(p.plot.issues());
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = mesh_from_artefact(inputs.require("mesh")?)?;
        let highlight = p.plot.highlighted(&model)?;
        let candidates = p.candidates.resolve(&model)?;
        let choice = match (&p.modes, p.elastic_modes, p.band_hz) {
            (Some(m), _, _) => ModeChoice::Numbers(m.clone()),
            (_, Some(n), _) => ModeChoice::Elastic(n),
            (_, _, Some(b)) => ModeChoice::Band(b.into()),
            _ => {
                return Err(StageError::input(
                    "modes",
                    "give one of `modes`, `elastic_modes`, `band_hz`",
                ));
            }
        };
        let map = eigenvalue_map(&model, candidates, &choice, p.mass)
            .map_err(StageError::from_numerics(""))?;
        if map.modes.len() > MAX_MODES {
            return Err(StageError::input(
                "band_hz",
                format!(
                    "{} modes lie in the band; narrow it to at most {MAX_MODES}",
                    map.modes.len()
                ),
            ));
        }
        let title = p.plot.title.clone().unwrap_or_else(|| {
            "Eigenvalue sensitivity phi_i d(lambda_r)/d(phi_i) / max per mode".to_string()
        });
        let panel_title = |k: usize| format!("mode {} ({:.1} Hz)", map.modes[k], map.freqs_hz[k]);
        let column = |k: usize| -> Vec<f64> { map.normalised.iter().map(|v| v[k]).collect() };
        let maps = mesh_plot(&MeshPlot {
            title: title.clone(),
            model: &model,
            panels: (0..map.modes.len())
                .map(|k| MeshPanel {
                    title: panel_title(k),
                    values: element_values(&map.candidates, &column(k)),
                })
                .collect(),
            columns: p.columns,
            view: p.plot.view(),
            highlight: highlight.clone(),
            colour_label: "sens. / max".into(),
        })
        .map_err(StageError::failed)?;
        let bars = bar_plot(&BarPlot {
            title: title.clone(),
            y_label: "sensitivity / max".into(),
            panels: (0..map.modes.len())
                .map(|k| {
                    p.plot
                        .bars(panel_title(k), &map.candidates, &column(k), &highlight)
                })
                .collect(),
            columns: p.columns.min(2),
            marked_label: p.plot.highlight_set.clone().unwrap_or_default(),
        })
        .map_err(StageError::failed)?;
        Ok(StageOutputs::from([
            ("sensitivity".to_string(), eigen_map_to_artefact(&map)),
            ("maps".to_string(), plot_artefact("maps", &title, maps)),
            ("bars".to_string(), plot_artefact("bars", &title, bars)),
        ]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::mesh::mesh_to_artefact;
    use crate::pipeline::{Stage, Typed};

    fn check(with: serde_json::Value) -> Result<serde_json::Value, Vec<ParamIssue>> {
        Typed::<LocaliseEigensensitivity>::new().check(&with, &CheckContext::with_ports(&["mesh"]))
    }

    #[test]
    fn exactly_one_mode_choice() {
        let e = check(serde_json::json!({})).unwrap_err();
        assert_eq!(e[0].path, vec!["modes"]);
        let e = check(serde_json::json!({"modes": [7], "elastic_modes": 2})).unwrap_err();
        assert!(e[0].message.contains("exactly one"));
        let e = check(serde_json::json!({"modes": [0, 7, 7]})).unwrap_err();
        assert_eq!(e.len(), 2, "{e:?}");
        let e = check(serde_json::json!({"band_hz": [50, 10]})).unwrap_err();
        assert_eq!(e[0].path, vec!["band_hz"]);
        assert!(
            e[0].message.contains("0 <= start <= stop"),
            "{}",
            e[0].message
        );
        let e = check(serde_json::json!({"band_hz": [10, 50], "columns": 0})).unwrap_err();
        assert_eq!(e[0].path, vec!["columns"]);
        assert!(check(serde_json::json!({"elastic_modes": 6})).is_ok());
    }

    fn run(with: serde_json::Value) -> Result<StageOutputs, String> {
        let p: Params = serde_json::from_value(check(with).unwrap()).unwrap();
        let model =
            crate::model::generate::bent_plate(&crate::model::generate::BentPlate::default());
        let mut i = StageInputs::default();
        i.artefacts
            .insert("mesh".into(), std::sync::Arc::new(mesh_to_artefact(&model)));
        LocaliseEigensensitivity::run(&p, &i).map_err(|e| e.to_string())
    }

    fn fails(with: serde_json::Value) -> String {
        match run(with) {
            Ok(_) => panic!("the stage ran"),
            Err(e) => e,
        }
    }

    /// Modes that do not exist, an empty band and an unknown set are named; a good run writes
    /// one panel per mode.
    #[test]
    fn bad_inputs_are_explained() {
        let every = serde_json::json!({"every_element": {"kind": "youngs_modulus"}});
        let e = fails(serde_json::json!({"candidates": every, "modes": [7, 5000]}));
        assert!(e.starts_with("modes: mode 5000"), "{e}");
        let e = fails(serde_json::json!({"candidates": every, "band_hz": [1, 2]}));
        assert!(e.starts_with("band_hz"), "{e}");
        let e = fails(
            serde_json::json!({"candidates": {"every_element": {"kind": "density", "set": "x"}}, "elastic_modes": 1}),
        );
        assert!(e.contains("`x` is not a set"), "{e}");
        let out = run(serde_json::json!({"candidates": every, "elastic_modes": 2,
            "plot": {"highlight_set": "strip_7"}}))
        .unwrap();
        let t = out["sensitivity"].table("modes").unwrap();
        assert_eq!(*t.i64s("modes", "mode").unwrap(), [7, 8]);
        assert!(out["maps"].blobs["maps.png"].starts_with(b"\x89PNG"));
    }
}
