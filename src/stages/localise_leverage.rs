//! `localise.leverage`: correlation-based error localisation (thesis 5.4–5.9: (5.4), (5.5), (5.6),
//! (5.7), (5.8), (5.9); docs/theory.md §7). The leverage `L_i = (S_iᵀε)²/(S_iᵀS_i)` of every
//! candidate parameter over the P-C's updating lines says how much of the residual `ε` (`1 − χ_s`,
//! `1 − χ_a`) that parameter alone can remove. Candidates are the model's declared parameters or
//! every element on its own (processed in chunks). Writes the table, a mesh coloured by the
//! normalised leverage and a bar chart.

use super::params::{
    Band, Count, Damping, Deprecation, Fraction, Modes, NonNegative, Positive, migrate_mode_fields,
    select_lines, warn_deprecated,
};
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::{frf_from_artefact, plot_artefact};
use crate::artefact::leverage::{leverage_to_artefact, ranks};
use crate::artefact::mesh::mesh_from_artefact;
use crate::eigen::ModeSelection;
use crate::fe::element::MassKind;
use crate::localisation::{
    Candidate, LeverageSettings, declared_candidates, element_candidates, leverage_map,
};
use crate::model::{Model, ParameterKind};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::report::bar_plot::{BarPanel, BarPlot, bar_plot};
use crate::report::mesh_plot::{MeshPanel, MeshPlot, View, mesh_plot};
use std::collections::{BTreeMap, BTreeSet};

/// The stage.
pub struct LocaliseLeverage;

/// A property every element carries on its own.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum ElementProperty {
    /// Young's modulus (shells and beams).
    YoungsModulus,
    /// Shell thickness (shells).
    #[serde(alias = "shell_thickness")]
    Thickness,
    /// Density (shells and beams).
    Density,
}

impl ElementProperty {
    fn kind(self) -> ParameterKind {
        match self {
            ElementProperty::YoungsModulus => ParameterKind::YoungsModulus,
            ElementProperty::Thickness => ParameterKind::ShellThickness,
            ElementProperty::Density => ParameterKind::Density,
        }
    }
}

/// Which parameters are candidates.
#[derive(
    Clone, Debug, Default, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Candidates {
    /// The model's declared updating parameters (`mesh.parameters`).
    #[default]
    Parameters,
    /// Every element (of `set`, or of the model) a candidate of its own.
    EveryElement {
        /// `youngs_modulus`, `thickness` or `density`.
        kind: ElementProperty,
        /// Only the elements of this set or these sets (default: every element that carries
        /// `kind`).
        #[serde(default)]
        set: Option<SetNames>,
    },
}

/// One set name or several.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum SetNames {
    /// One set.
    One(String),
    /// Several sets (their union).
    Many(Vec<String>),
}

impl SetNames {
    fn names(&self) -> Vec<String> {
        match self {
            SetNames::One(s) => vec![s.clone()],
            SetNames::Many(v) => v.clone(),
        }
    }
}

impl Candidates {
    /// The candidates in `model`.
    pub fn resolve(&self, model: &Model) -> Result<Vec<Candidate>, StageError> {
        match self {
            Candidates::Parameters => declared_candidates(model),
            Candidates::EveryElement { kind, set } => {
                let sets = set.as_ref().map(SetNames::names).unwrap_or_default();
                element_candidates(model, &kind.kind(), &sets)
            }
        }
        .map_err(StageError::from_numerics("candidates"))
    }

    fn describe(&self) -> String {
        match self {
            Candidates::Parameters => "declared parameters".into(),
            Candidates::EveryElement { kind, set } => format!(
                "every element{} ({})",
                set.as_ref()
                    .map(|s| format!(" of {}", s.names().join(" + ")))
                    .unwrap_or_default(),
                serde_json::to_value(kind)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_default()
            ),
        }
    }
}

/// Order of the bars.
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
pub enum BarOrder {
    /// Largest first.
    #[default]
    Ranked,
    /// As the candidates are listed.
    Candidates,
}

/// Viewing direction of the mesh figures.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ViewParams {
    /// Rotation about z from +x toward +y, degrees.
    #[serde(default = "azimuth")]
    pub azimuth_deg: f64,
    /// Angle above the xy plane, degrees.
    #[serde(default = "elevation")]
    pub elevation_deg: f64,
}

impl Default for ViewParams {
    fn default() -> Self {
        ViewParams {
            azimuth_deg: azimuth(),
            elevation_deg: elevation(),
        }
    }
}

fn azimuth() -> f64 {
    View::default().azimuth_deg
}
fn elevation() -> f64 {
    View::default().elevation_deg
}

/// Figure settings.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlotParams {
    /// Figure title (default: what was computed).
    #[serde(default)]
    pub title: Option<String>,
    /// Viewing direction of the mesh.
    #[serde(default)]
    pub view: ViewParams,
    /// Elements of this set get red edges on the mesh and their candidates red bars (e.g.
    /// the known error of a simulated study).
    #[serde(default)]
    pub highlight_set: Option<String>,
    /// `ranked` (largest first) or `candidates` (listed order).
    #[serde(default)]
    pub bar_order: BarOrder,
    /// Most bars per panel (1–500).
    #[serde(default = "max_bars")]
    pub max_bars: usize,
}

impl Default for PlotParams {
    fn default() -> Self {
        PlotParams {
            title: None,
            view: ViewParams::default(),
            highlight_set: None,
            bar_order: BarOrder::Ranked,
            max_bars: max_bars(),
        }
    }
}

fn max_bars() -> usize {
    100
}

impl PlotParams {
    /// Problems with the figure settings.
    pub fn issues(&self) -> Vec<ParamIssue> {
        let mut out = Vec::new();
        for (f, v) in [
            ("plot.view.azimuth_deg", self.view.azimuth_deg),
            ("plot.view.elevation_deg", self.view.elevation_deg),
        ] {
            if !(v.is_finite() && v.abs() <= 360.0) {
                out.push(ParamIssue::at(
                    f,
                    format!("{v} must be an angle in [-360, 360] degrees"),
                ));
            }
        }
        if !(1..=500).contains(&self.max_bars) {
            out.push(ParamIssue::at(
                "plot.max_bars",
                format!("{} must be 1 to 500", self.max_bars),
            ));
        }
        out
    }

    /// The elements of `highlight_set`.
    pub fn highlighted(&self, model: &Model) -> Result<BTreeSet<u64>, StageError> {
        match &self.highlight_set {
            None => Ok(BTreeSet::new()),
            Some(s) => model
                .sets
                .get(s)
                .map(|ids| ids.iter().copied().collect())
                .ok_or_else(|| {
                    StageError::input(
                        "plot.highlight_set",
                        format!(
                            "`{s}` is not a set of the model (sets: {})",
                            model.sets.keys().cloned().collect::<Vec<_>>().join(", ")
                        ),
                    )
                }),
        }
    }

    /// The view.
    pub fn view(&self) -> View {
        View {
            azimuth_deg: self.view.azimuth_deg,
            elevation_deg: self.view.elevation_deg,
        }
    }

    /// Bars of one series: the order, capped at `max_bars`, marked where a candidate touches
    /// `highlight`.
    pub fn bars(
        &self,
        title: String,
        candidates: &[Candidate],
        values: &[f64],
        highlight: &BTreeSet<u64>,
    ) -> BarPanel {
        let order: Vec<usize> = match self.bar_order {
            BarOrder::Candidates => (0..values.len()).collect(),
            BarOrder::Ranked => {
                let mag: Vec<f64> = values.iter().map(|v| v.abs()).collect();
                let r = ranks(&mag);
                let mut o: Vec<usize> = (0..values.len()).collect();
                o.sort_by_key(|&i| r[i]);
                o
            }
        };
        let order = &order[..order.len().min(self.max_bars)];
        BarPanel {
            title,
            labels: order.iter().map(|&i| candidates[i].name.clone()).collect(),
            values: order.iter().map(|&i| values[i]).collect(),
            marked: order
                .iter()
                .map(|&i| candidates[i].elements.iter().any(|e| highlight.contains(e)))
                .collect(),
            log: false,
        }
    }
}

/// A value per element from a value per candidate (the largest magnitude where groups overlap).
pub fn element_values(candidates: &[Candidate], values: &[f64]) -> BTreeMap<u64, f64> {
    let mut out: BTreeMap<u64, f64> = BTreeMap::new();
    for (c, v) in candidates.iter().zip(values) {
        for e in &c.elements {
            let slot = out.entry(*e).or_insert(*v);
            if v.abs() > slot.abs() {
                *slot = *v;
            }
        }
    }
    out
}

/// Problems with a damping given for a modal prediction.
pub fn damping_issues(d: &Damping) -> Vec<ParamIssue> {
    if matches!(d, Damping::Rayleigh { .. }) {
        return vec![ParamIssue::at(
            "damping",
            "the prediction is a modal sum: give `structural` or `viscous` modal damping, e.g. {structural: 0.01}",
        )];
    }
    let modal = d.modal();
    let given = !matches!(d, Damping::None);
    if given && (modal.is_empty() || modal.check(modal.len()).is_err()) {
        vec![ParamIssue::at(
            "damping",
            "give finite damping values >= 0 (one, or one per mode of the basis)",
        )]
    } else {
        Vec::new()
    }
}

/// Parameters of `localise.leverage`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// `parameters` (the model's declared ones) or `{every_element: {kind, set}}`.
    #[serde(default)]
    pub candidates: Candidates,
    /// Only measured lines in `[lo, hi]` Hz are used (default: all).
    #[serde(default)]
    pub band_hz: Option<Band>,
    /// Measured lines inside any of these bands are left out, e.g. `[[0, 0]]` for the static
    /// line or `[[49, 51]]` for mains hum (default: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exclude_hz: Vec<Band>,
    /// Lines with `(χ_s + χ_a)/2` above this are not used (4.20). Default 1: every line but
    /// those at predicted resonances, since well-correlated lines count against a candidate
    /// that would spoil them (through `S_iᵀS_i`); the P-C's 0.95 keeps only the poor lines.
    #[serde(default = "kappa_f")]
    pub kappa_f: Fraction,
    /// Lines within this many line spacings of a predicted natural frequency are not used.
    #[serde(default = "one")]
    pub resonance_lines: NonNegative,
    /// Modes of the basis, `{count: N}` or `{max_freq_hz: F}` (default: every mode up to twice
    /// the highest line used).
    #[serde(default)]
    pub modes: Modes,
    /// Deprecated spelling of `modes.count`.
    #[serde(default, skip_serializing)]
    #[schemars(extend("deprecated" = true))]
    pub mode_count: Option<Count>,
    /// Deprecated spelling of `modes.max_freq_hz`.
    #[serde(default, skip_serializing)]
    #[schemars(extend("deprecated" = true))]
    pub modes_max_hz: Option<Positive>,
    /// Modal damping of the prediction (as in `frf.synthesise` and `update`).
    #[serde(default)]
    pub damping: Damping,
    /// Mass matrix.
    #[serde(default)]
    pub mass: MassKind,
    /// Add the truncated modes' static share: their residual flexibility to the prediction and
    /// its derivative, and Wang's correction to the mode-shape derivatives (see
    /// `localisation::residual`); `false`: the truncated modal sums alone.
    #[serde(default = "yes")]
    pub static_correction: bool,
    /// Weight the equations by `√χ` (4.21); the thesis's leverage (5.4) is unweighted.
    #[serde(default)]
    pub weighted: bool,
    /// Candidates per chunk (memory holds one chunk's sensitivities per thread).
    #[serde(default = "chunk")]
    pub chunk: usize,
    /// Figures.
    #[serde(default)]
    pub plot: PlotParams,
}

fn kappa_f() -> Fraction {
    Fraction::of_default(1.0)
}
fn one() -> NonNegative {
    NonNegative::of_default(1.0)
}
fn yes() -> bool {
    true
}
fn chunk() -> usize {
    256
}

impl TypedStage for LocaliseLeverage {
    type Params = Params;
    const KIND: &'static str = "localise.leverage";
    const SUMMARY: &'static str = "Error localisation: leverage (5.9) of candidate parameters (or every element) over the P-C's lines";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "mesh",
                ArtefactKind::Mesh,
                "the finite-element model (with declared parameters for `candidates: parameters`)",
            ),
            PortSpec::required("measured", ArtefactKind::Frf, "measured FRFs"),
            PortSpec::optional(
                "map",
                ArtefactKind::TestMap,
                "test.pair's map: every measured DOF is its weighted sum of model DOFs (14.7)",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "leverage",
                ArtefactKind::Leverage,
                "leverage, rank and one-parameter change per candidate; the lines used",
            ),
            PortSpec::required(
                "map",
                ArtefactKind::Plot,
                "map.png/svg: the mesh coloured by the normalised leverage",
            ),
            PortSpec::required(
                "bars",
                ArtefactKind::Plot,
                "bars.png/svg: normalised leverage per candidate",
            ),
        ]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        let mut found: Vec<Deprecation> = Vec::new();
        let (count, hz) = (p.mode_count.take(), p.modes_max_hz.take());
        issues.extend(migrate_mode_fields(&mut p.modes, count, hz, &mut found));
        warn_deprecated(Self::KIND, &found);
        issues.extend(p.modes.issues("modes"));
        if !(1..=1_000_000).contains(&p.chunk) {
            issues.push(ParamIssue::at(
                "chunk",
                format!("{} must be 1 to 1000000", p.chunk),
            ));
        }
        issues.extend(damping_issues(&p.damping));
        issues.extend(p.plot.issues());
        issues
    }

    /// The measured DOFs against the model, unless a map relates them.
    fn preflight(_p: &Params, inputs: &StageInputs) -> Vec<ParamIssue> {
        if inputs.get("map").is_some() {
            return Vec::new();
        }
        let (Some(mesh), Some(measured)) = (inputs.get("mesh"), inputs.get("measured")) else {
            return Vec::new();
        };
        let (Ok(model), Ok(set)) = (
            crate::artefact::mesh::mesh_from_artefact(mesh),
            crate::artefact::kinds::frf_from_artefact(measured),
        ) else {
            return Vec::new();
        };
        super::params::measured_dofs_issue(&model, &set, "measured")
            .into_iter()
            .collect()
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = mesh_from_artefact(inputs.require("mesh")?)?;
        let mut measured = frf_from_artefact(inputs.require("measured")?)?;
        if !p.exclude_hz.is_empty() {
            measured = select_lines(&measured, None, &p.exclude_hz)?;
        }
        let highlight = p.plot.highlighted(&model)?;
        let candidates = p.candidates.resolve(&model)?;
        let f = &measured.freqs_hz;
        let top_hz = f
            .iter()
            .copied()
            .filter(|x| p.band_hz.is_none_or(|b| *x >= b.lo && *x <= b.hi))
            .fold(0.0_f64, f64::max);
        let modes =
            (p.modes).selection_or(ModeSelection::BelowHz(2.0 * top_hz.max(f64::MIN_POSITIVE)));
        let band_hz = p.band_hz.map(<[f64; 2]>::from);
        let settings = LeverageSettings {
            band_hz,
            kappa_f: p.kappa_f.get(),
            resonance_lines: p.resonance_lines.get(),
            modes,
            damping: p.damping.modal(),
            mass: p.mass,
            static_correction: p.static_correction,
            weighted: p.weighted,
            chunk: p.chunk,
            sensors: crate::stages::update::sensor_map(inputs)?.map(std::sync::Arc::new),
        };
        let n = candidates.len();
        let start = std::time::Instant::now();
        let map = leverage_map(&model, candidates, &measured, &settings)
            .map_err(StageError::from_numerics(""))?;
        tracing::info!(
            "leverage of {n} candidates over {} lines in {:.2} s",
            map.chosen.len(),
            start.elapsed().as_secs_f64()
        );
        let artefact = leverage_to_artefact(&map, band_hz);
        let lev: Vec<f64> = map.fits.iter().map(|f| f.leverage).collect();
        let top = lev.iter().copied().fold(0.0_f64, f64::max);
        let norm: Vec<f64> = lev
            .iter()
            .map(|l| if top > 0.0 { l / top } else { 0.0 })
            .collect();
        let used: Vec<f64> = map.chosen.iter().map(|&k| f[k]).collect();
        let span = format!(
            "{:.1}-{:.1} Hz, {} lines",
            used.first().copied().unwrap_or(0.0),
            used.last().copied().unwrap_or(0.0),
            used.len()
        );
        let title = p
            .plot
            .title
            .clone()
            .unwrap_or_else(|| format!("Leverage L_i / max L ({span})"));
        let map_fig = mesh_plot(&MeshPlot {
            title: title.clone(),
            model: &model,
            panels: vec![MeshPanel {
                title: format!("candidates: {}", p.candidates.describe()),
                values: element_values(&map.candidates, &norm),
            }],
            columns: 1,
            view: p.plot.view(),
            highlight: highlight.clone(),
            colour_label: "L / max L".into(),
        })
        .map_err(StageError::failed)?;
        let bars_fig = bar_plot(&BarPlot {
            title: title.clone(),
            y_label: "L / max L".into(),
            panels: vec![p.plot.bars(
                format!("candidates: {}", p.candidates.describe()),
                &map.candidates,
                &norm,
                &highlight,
            )],
            columns: 1,
            marked_label: p.plot.highlight_set.clone().unwrap_or_default(),
        })
        .map_err(StageError::failed)?;
        Ok(StageOutputs::from([
            ("leverage".to_string(), artefact),
            ("map".to_string(), plot_artefact("map", &title, map_fig)),
            ("bars".to_string(), plot_artefact("bars", &title, bars_fig)),
        ]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::kinds::frf_to_artefact;
    use crate::artefact::mesh::mesh_to_artefact;
    use crate::pipeline::{Stage, Typed};

    fn check(with: serde_json::Value) -> Result<serde_json::Value, Vec<ParamIssue>> {
        Typed::<LocaliseLeverage>::new()
            .check(&with, &CheckContext::with_ports(&["mesh", "measured"]))
    }

    #[test]
    fn defaults_fill_in() {
        let v = check(serde_json::json!({})).unwrap();
        assert_eq!(v["candidates"], "parameters");
        assert_eq!(v["kappa_f"], 1.0);
        assert_eq!(v["weighted"], false);
        let v = check(
            serde_json::json!({"candidates": {"every_element": {"kind": "shell_thickness"}}}),
        )
        .unwrap();
        assert_eq!(v["candidates"]["every_element"]["kind"], "thickness");
    }

    #[test]
    fn bad_settings_are_named() {
        // Out of their types' ranges: refused as read, the range named.
        for (with, field, range) in [
            (
                serde_json::json!({"band_hz": [100, 10]}),
                "band_hz",
                "start <= stop",
            ),
            (serde_json::json!({"kappa_f": 1.5}), "kappa_f", "(0, 1]"),
            (
                serde_json::json!({"resonance_lines": -1}),
                "resonance_lines",
                "[0, ∞)",
            ),
        ] {
            let e = check(with).unwrap_err();
            assert_eq!(e[0].path, vec![field]);
            assert!(e[0].message.contains(range), "{}", e[0].message);
        }
        let e = check(serde_json::json!({"chunk": 0,
            "damping": {"rayleigh": {"alpha": 1, "beta": 0}}, "plot": {"max_bars": 0}}))
        .unwrap_err();
        let paths: Vec<String> = e.iter().map(|i| i.path.join(".")).collect();
        assert_eq!(paths, ["chunk", "damping", "plot.max_bars"], "{e:?}");
        let e = check(serde_json::json!({"candidates": {"every_element": {"kind": "beam_width"}}}))
            .unwrap_err();
        assert!(e[0].message.contains("unknown variant"), "{}", e[0].message);
        let e = check(serde_json::json!({"modes": {"count": 10, "max_freq_hz": 100}})).unwrap_err();
        assert_eq!(e[0].path, vec!["modes", "count"]);
        let e = check(serde_json::json!({"mode_count": 10, "modes": {"count": 10}})).unwrap_err();
        assert_eq!(e[0].path, vec!["modes"]);
        for bad in [serde_json::json!(-0.01), serde_json::json!([])] {
            let e = check(serde_json::json!({"damping": {"structural": bad}})).unwrap_err();
            assert_eq!(e[0].path, vec!["damping"], "{bad}");
        }
    }

    #[test]
    fn old_mode_spellings_are_read_as_modes() {
        let old = check(serde_json::json!({"mode_count": 10})).unwrap();
        let new = check(serde_json::json!({"modes": {"count": 10}})).unwrap();
        assert_eq!(old, new);
        assert!(old.get("mode_count").is_none());
        let old = check(serde_json::json!({"modes_max_hz": 300.0})).unwrap();
        assert_eq!(old["modes"]["max_freq_hz"], 300.0);
    }

    fn inputs(with_params: bool) -> StageInputs {
        let mut model =
            crate::model::generate::bent_plate(&crate::model::generate::BentPlate::default());
        if with_params {
            model.parameters.push(crate::model::Parameter {
                name: "e7".into(),
                kind: ParameterKind::YoungsModulus,
                set: "strip_7".into(),
                lower: 1.0,
                upper: 1e12,
            });
        }
        let dof: crate::core::DofId = "120:uz".parse().unwrap();
        let frf = crate::frf::FrfSet {
            quantity: crate::frf::Quantity::Receptance,
            freqs_hz: vec![10.0, 20.0],
            pairs: vec![crate::frf::FrfPair {
                response: dof,
                excitation: dof,
            }],
            values: faer::Mat::from_fn(2, 1, |_, _| faer::c64::new(1e-4, 0.0)),
        };
        let mut i = StageInputs::default();
        i.artefacts
            .insert("mesh".into(), std::sync::Arc::new(mesh_to_artefact(&model)));
        i.artefacts.insert(
            "measured".into(),
            std::sync::Arc::new(frf_to_artefact(&frf)),
        );
        i
    }

    fn run(with: serde_json::Value, with_params: bool) -> String {
        let p: Params = serde_json::from_value(check(with).unwrap()).unwrap();
        match LocaliseLeverage::run(&p, &inputs(with_params)) {
            Ok(_) => String::new(),
            Err(e) => e.to_string(),
        }
    }

    /// Errors that depend on the data name the field and what would be valid.
    #[test]
    fn bad_inputs_are_explained() {
        let e = run(serde_json::json!({}), false);
        assert!(
            e.starts_with("with.candidates:") && e.contains("mesh.parameters"),
            "{e}"
        );
        let e = run(
            serde_json::json!({"candidates": {"every_element": {"kind": "youngs_modulus", "set": "strip_99"}}}),
            false,
        );
        assert!(e.contains("strip_99") && e.contains("strip_1"), "{e}");
        let e = run(serde_json::json!({"band_hz": [200, 300]}), true);
        assert!(e.starts_with("band_hz") && e.contains("10 to 20 Hz"), "{e}");
        let e = run(serde_json::json!({"exclude_hz": [[0, 1000]]}), true);
        assert!(
            e.starts_with("with.exclude_hz") && e.contains("10 to 20 Hz"),
            "{e}"
        );
        let e = run(serde_json::json!({"plot": {"highlight_set": "nope"}}), true);
        assert!(e.starts_with("with.plot.highlight_set"), "{e}");
        let e = run(
            serde_json::json!({"candidates": {"every_element": {"kind": "thickness", "set": "bar"}}}),
            false,
        );
        assert!(e.contains("beam"), "{e}");
    }
}
