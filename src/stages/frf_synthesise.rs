//! `frf.synthesise`: receptance, mobility or accelerance at chosen DOFs over a band, by modal
//! summation (structural `η_r` or viscous `ζ_r`, uniform or per mode, optionally truncated), by
//! direct solution of `Z(ω)`, or by a Krylov reduced-order sweep checked at every line by its
//! load residual (docs/theory.md §1).
//!
//! With a measured FRF artefact on `template`, the prediction follows the test: its lines, its
//! response/excitation pairs and its quantity, nothing retyped. With a `test.pair` map on `map`
//! too, each measured DOF is the map's weighted sum of model DOFs, and
//! `H_t(i, j) = Σ_a Σ_b w_ia w_jb H(a, b)` (docs/theory.md §14, (14.7)).

use super::params::{
    Band, Count, Damping, Deprecation, Modes, NonNegative, Positive, migrate_mode_fields,
    warn_deprecated,
};
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::test_map::test_map_from_artefact;
use crate::artefact::kinds::{
    frf_from_artefact, frf_to_artefact, matrices_from_artefact, modes_from_artefact,
};
use crate::core::DofId;
use crate::frf::{
    FrfPair, FrfSet, KrylovOptions, KrylovReport, Quantity, add_residual, convert_from_receptance,
    direct_receptance, frequency_line_count, frequency_lines, krylov_receptance, modal_receptance,
    static_residual,
};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use faer::{Mat, c64};
use std::collections::{BTreeMap, BTreeSet};

/// The stage.
pub struct FrfSynthesise;

/// How the FRFs are computed.
#[derive(
    Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Modal summation over the `modes` input.
    Modal,
    /// `α = Z(ω)⁻¹` from the `model` input.
    Direct,
    /// A Krylov reduced-order model of the `model` input, refined until every line's relative
    /// load residual meets `krylov.tolerance`: for many lines on large models.
    Krylov,
}

/// A correction for the modes a modal sum leaves out.
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
pub enum Residual {
    /// The modes given, nothing more.
    #[default]
    None,
    /// Their static flexibility `K⁻¹ − Σ φφᵀ/λ` added (docs/theory.md (13.4)); needs `model`
    /// (constrained: no rigid-body modes).
    Static,
}

/// Settings of `method: krylov`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct KrylovParams {
    /// Largest relative load residual `‖Z(ω)x − f‖/‖f‖` accepted at any line (default 1e-6).
    #[serde(default = "krylov_tolerance")]
    pub tolerance: Positive,
    /// Krylov blocks per expansion point, one vector per excitation each (default 8).
    #[serde(default = "krylov_blocks")]
    pub blocks_per_point: Count,
    /// Most expansion points before the stage fails (default 40).
    #[serde(default = "krylov_points")]
    pub max_points: Count,
}

impl Default for KrylovParams {
    fn default() -> Self {
        KrylovParams {
            tolerance: krylov_tolerance(),
            blocks_per_point: krylov_blocks(),
            max_points: krylov_points(),
        }
    }
}

fn krylov_tolerance() -> Positive {
    Positive::new(KrylovOptions::default().tolerance).expect("a positive default")
}

fn krylov_blocks() -> Count {
    Count::new(KrylovOptions::default().blocks_per_point).expect("a positive default")
}

fn krylov_points() -> Count {
    Count::new(KrylovOptions::default().max_points).expect("a positive default")
}

impl KrylovParams {
    fn options(&self) -> KrylovOptions {
        KrylovOptions {
            tolerance: self.tolerance.get(),
            blocks_per_point: self.blocks_per_point.get(),
            max_points: self.max_points.get(),
        }
    }
}

/// Parameters of `frf.synthesise`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// `modal` (needs `modes`), `direct` or `krylov` (need `model`); default: modal when
    /// `modes` is connected, else direct.
    #[serde(default)]
    pub method: Option<Method>,
    /// Settings of `method: krylov`.
    #[serde(default)]
    pub krylov: KrylovParams,
    /// `static`: a modal sum gets the static flexibility of the modes it leaves out (needs the
    /// `model` input too); default `none`.
    #[serde(default)]
    pub residual: Residual,
    /// receptance (m/N), mobility (m/s/N) or accelerance (m/s²/N); with `template`, the
    /// template's.
    #[serde(default = "receptance")]
    pub quantity: Quantity,
    /// Response DOFs.
    #[serde(default)]
    pub responses: Vec<DofId>,
    /// Every free DOF of the model with one of these components is a response too (e.g.
    /// `[ux, uy, uz, rx, ry, rz]` for complete data, `[ux]` for x-direction DOFs only).
    #[serde(default)]
    pub response_components: Vec<crate::core::Component>,
    /// Excitation DOFs; every response/excitation pair is synthesised (not with `template`).
    #[serde(default)]
    pub excitations: Vec<DofId>,
    /// Band `[start, stop]` in Hz, with `step_hz`.
    #[serde(default)]
    pub band_hz: Option<Band>,
    /// Line spacing in Hz, with `band_hz`.
    #[serde(default)]
    pub step_hz: Option<Positive>,
    /// Explicit lines in Hz, instead of `band_hz`/`step_hz`.
    #[serde(default)]
    pub lines_hz: Option<Vec<NonNegative>>,
    /// Damping model.
    #[serde(default)]
    pub damping: Damping,
    /// Use only the lowest modes given, `{count: N}` or `{max_freq_hz: F}` (modal only;
    /// default: all modes given).
    #[serde(default)]
    pub modes: Modes,
    /// Deprecated spelling of `modes.count`.
    #[serde(default, skip_serializing)]
    #[schemars(extend("deprecated" = true))]
    pub mode_count: Option<Count>,
}

fn receptance() -> Quantity {
    Quantity::Receptance
}

/// Most lines one stage synthesises.
const MAX_LINES: usize = 1_000_000;

impl Params {
    /// How many of the given modes (with these natural frequencies) are kept, if not all.
    fn kept_modes(&self, natural_hz: &[f64]) -> Result<Option<usize>, StageError> {
        let n = natural_hz.len();
        match (self.modes.count.map(Count::get), self.modes.max_freq_hz) {
            (Some(c), _) if c > n => Err(StageError::input(
                "modes.count",
                format!("{c} exceeds the {n} modes given; compute more modes upstream"),
            )),
            (Some(c), _) => Ok(Some(c)),
            (None, Some(f)) => match natural_hz.iter().filter(|&&h| h <= f.get()).count() {
                0 => Err(StageError::input(
                    "modes.max_freq_hz",
                    format!("no mode given lies below {} Hz", f.get()),
                )),
                c => Ok(Some(c)),
            },
            (None, None) => Ok(None),
        }
    }

    fn lines(&self) -> Vec<f64> {
        match (&self.lines_hz, self.band_hz, self.step_hz) {
            (Some(l), _, _) => l.iter().map(|f| f.get()).collect(),
            (None, Some(b), Some(s)) => frequency_lines(b.lo, b.hi, s.get()),
            _ => Vec::new(),
        }
    }
}

/// The checks of the responses, excitations and lines (when no template gives them).
/// `earlier`: whether other checks found issues already (the line count is then not checked).
fn pair_and_line_issues(p: &Params, earlier: bool) -> Vec<ParamIssue> {
    let mut issues = Vec::new();
    if p.responses.is_empty() && p.response_components.is_empty() {
        issues.push(ParamIssue::at(
            "responses",
            "give at least one response DOF, e.g. [\"1:ux\"], or `response_components`",
        ));
    }
    if p.excitations.is_empty() {
        issues.push(ParamIssue::at(
            "excitations",
            "give at least one excitation DOF, e.g. [\"1:ux\"]",
        ));
    }
    match (&p.lines_hz, p.band_hz, p.step_hz) {
        (Some(_), None, None) | (None, Some(_), Some(_)) => {}
        _ => issues.push(ParamIssue::at(
            "band_hz",
            "give `band_hz: [start, stop]` with `step_hz`, or `lines_hz: [...]`",
        )),
    }
    if let Some(l) = &p.lines_hz
        && (l.is_empty() || l.windows(2).any(|w| w[1] <= w[0]))
    {
        issues.push(ParamIssue::at(
            "lines_hz",
            "lines must be non-negative and strictly increasing",
        ));
    }
    if let (true, Some(Band { lo: a, hi: b }), Some(step)) = (
        !earlier && issues.is_empty(),
        p.band_hz,
        p.step_hz.map(Positive::get),
    ) {
        // Counted before anything is allocated: a step of 1e-3 Hz over 1 MHz is 1e9 lines.
        match frequency_line_count(a, b, step) {
            None => issues.push(ParamIssue::at(
                "step_hz",
                format!(
                    "{step} Hz is too small to separate lines near {b} Hz in double precision; widen the step"
                ),
            )),
            Some(n) if n > MAX_LINES as f64 => issues.push(ParamIssue::at(
                "step_hz",
                format!(
                    "[{a}, {b}] Hz at {step} Hz is {n:.3e} lines, above the limit of {MAX_LINES}; widen the step or narrow the band"
                ),
            )),
            Some(_) => {}
        }
    }
    if let Some(l) = &p.lines_hz
        && l.len() > MAX_LINES
    {
        issues.push(ParamIssue::at(
            "lines_hz",
            format!("{} lines exceed the limit of {MAX_LINES}", l.len()),
        ));
    }
    issues
}

impl TypedStage for FrfSynthesise {
    type Params = Params;
    const KIND: &'static str = "frf.synthesise";
    const SUMMARY: &'static str =
        "FRFs (receptance, mobility, accelerance) by modal summation or direct solution of Z(w)";
    /// 2: the map's missing model DOFs recorded as `synthesis_warnings`.
    const IMPL_VERSION: u32 = 2;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::optional(
                "model",
                ArtefactKind::Matrices,
                "system matrices, for `method: direct`",
            ),
            PortSpec::optional("modes", ArtefactKind::Modes, "modes, for `method: modal`"),
            PortSpec::optional(
                "template",
                ArtefactKind::Frf,
                "measured FRFs whose lines, pairs and quantity the prediction takes",
            ),
            PortSpec::optional(
                "map",
                ArtefactKind::TestMap,
                "with `template`: measured DOFs as weighted model DOFs (test.pair)",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "frf",
            ArtefactKind::Frf,
            "the synthesised FRFs",
        )]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        let mut found: Vec<Deprecation> = Vec::new();
        let mut issues = migrate_mode_fields(&mut p.modes, p.mode_count.take(), None, &mut found);
        warn_deprecated(Self::KIND, &found);
        issues.extend(p.modes.issues("modes"));
        let method = *p.method.get_or_insert(if ctx.is_connected("modes") {
            Method::Modal
        } else {
            Method::Direct
        });
        match method {
            Method::Modal if !ctx.is_connected("modes") => issues.push(ParamIssue::at(
                "method",
                "`modal` needs the `modes` input connected (or use `method: direct` with `model`)",
            )),
            Method::Direct | Method::Krylov if !ctx.is_connected("model") => {
                issues.push(ParamIssue::at(
                    "method",
                    "`direct` and `krylov` need the `model` input connected (or use `method: modal` with `modes`)",
                ))
            }
            _ => {}
        }
        if ctx.is_connected("map") && !ctx.is_connected("template") {
            issues.push(ParamIssue {
                path: vec![],
                message: "the `map` input needs the measured FRFs on `template` (their pairs are what the map's DOFs combine into)".into(),
            });
        }
        if ctx.is_connected("template") {
            let given = [
                ("responses", !p.responses.is_empty()),
                ("response_components", !p.response_components.is_empty()),
                ("excitations", !p.excitations.is_empty()),
                ("band_hz", p.band_hz.is_some()),
                ("step_hz", p.step_hz.is_some()),
                ("lines_hz", p.lines_hz.is_some()),
            ];
            for (field, _) in given.iter().filter(|g| g.1) {
                issues.push(ParamIssue::at(
                    field,
                    "with `template` connected the lines, pairs and quantity are the measured FRFs'; remove it",
                ));
            }
        } else {
            let earlier = !issues.is_empty();
            issues.extend(pair_and_line_issues(p, earlier));
        }
        let values = match &p.damping {
            Damping::Structural(v) | Damping::Viscous(v) => v.values(),
            Damping::Rayleigh { alpha, beta } => vec![*alpha, *beta],
            Damping::None => vec![],
        };
        if values.is_empty() && !matches!(p.damping, Damping::None) {
            issues.push(ParamIssue::at("damping", "give at least one damping value"));
        }
        if values.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            issues.push(ParamIssue::at(
                "damping",
                "damping values must be finite and >= 0",
            ));
        }
        let physical = matches!(method, Method::Direct | Method::Krylov);
        match (method, &p.damping) {
            (_, Damping::Viscous(_)) if physical => issues.push(ParamIssue::at("damping", "modal viscous ratios need `method: modal`; for `direct` and `krylov` use `rayleigh: {alpha, beta}` or the model's own C")),
            (_, d) if physical && d.is_per_mode() => issues.push(ParamIssue::at("damping", "per-mode loss factors need `method: modal`; `direct` and `krylov` take one uniform value")),
            (Method::Modal, Damping::Rayleigh { .. }) => issues.push(ParamIssue::at("damping", "Rayleigh damping needs `method: direct` or `krylov`; for `modal` give `viscous` ratios per mode")),
            _ => {}
        }
        if p.residual == Residual::Static {
            if physical {
                issues.push(ParamIssue::at(
                    "residual",
                    "the static correction is for `method: modal`; `direct` and `krylov` are complete",
                ));
            } else if !ctx.is_connected("model") {
                issues.push(ParamIssue::at(
                    "residual",
                    "`residual: static` needs the `model` input connected (its K gives the static flexibility)",
                ));
            }
        }
        if physical && p.modes.is_given() {
            issues.push(ParamIssue::at(
                "modes",
                "mode truncation applies to `method: modal` only",
            ));
        }
        issues
    }

    /// The Krylov settings enter the key only when the Krylov sweep runs, the residual only
    /// when asked for.
    fn key_params(params: &serde_json::Value) -> serde_json::Value {
        let mut key = params.clone();
        let method = key.get("method").and_then(|m| m.as_str()) == Some("krylov");
        let residual = key.get("residual").and_then(|m| m.as_str()) != Some("none");
        if let Some(o) = key.as_object_mut() {
            if !method {
                o.remove("krylov");
            }
            if !residual {
                o.remove("residual");
            }
        }
        key
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        if let Some(t) = inputs.get("template") {
            let template = frf_from_artefact(t)?;
            let (set, report, warnings) = match inputs.get("map") {
                Some(m) => through_map(p, inputs, &template, &test_map_from_artefact(m)?)?,
                None => {
                    let (set, report) = synthesise(
                        p,
                        inputs,
                        |_| template.pairs.clone(),
                        &template.freqs_hz,
                        template.quantity,
                    )?;
                    (set, report, Vec::new())
                }
            };
            return Ok(frf_output(&set, report, &warnings, p));
        }
        let lines = p.lines();
        // Responses: the listed DOFs, then every model DOF of the listed components.
        let with_components = |dofs: &[DofId]| {
            let mut out = p.responses.clone();
            let mut seen: std::collections::HashSet<DofId> = out.iter().copied().collect();
            for d in dofs {
                if p.response_components.contains(&d.comp) && seen.insert(*d) {
                    out.push(*d);
                }
            }
            out
        };
        let (set, report) = synthesise(
            p,
            inputs,
            |dofs| FrfSet::all_pairs(&with_components(dofs), &p.excitations),
            &lines,
            p.quantity,
        )?;
        Ok(frf_output(&set, report, &[], p))
    }
}

/// The FRFs at `lines` by the method of `p`, of the pairs `pairs_of` makes from the model's
/// DOFs (the modes' or the matrices').
fn synthesise(
    p: &Params,
    inputs: &StageInputs,
    pairs_of: impl FnOnce(&[DofId]) -> Vec<FrfPair>,
    lines: &[f64],
    quantity: Quantity,
) -> Result<(FrfSet, Option<KrylovReport>), StageError> {
    match p.method {
        Some(Method::Modal) => {
            if let Some(model) = inputs.get("model")
                && matrices_from_artefact(model)?.c.is_some()
            {
                return Err(StageError::input(
                    "",
                    "the model has element dampers (its matrices hold a viscous C from CDAMP, CVISC or CBUSH B), which are not proportional and are not in the modal damping; use `method: direct` to include them, or remove the dampers",
                ));
            }
            let m = modes_from_artefact(inputs.require("modes")?)?;
            let pairs = pairs_of(&m.dofs);
            let mut modes = m.modes;
            if modes.is_empty() {
                return Err(StageError::input(
                    "",
                    "the `modes` input holds no mode, so every modal FRF would be zero; compute modes upstream (raise `max_freq_hz` or give `count`)",
                ));
            }
            if let Some(c) = p.kept_modes(&modes.frequencies_hz())? {
                modes.eigenvalues.truncate(c);
                modes.residuals.truncate(c);
                modes.shapes = modes.shapes.subcols(0, c).to_owned();
            }
            let damping = p
                .damping
                .modal_for(modes.len())
                .map_err(StageError::input_at("damping"))?;
            if p.residual == Residual::None {
                return modal_receptance(&modes, &m.dofs, &damping, &pairs, lines, quantity)
                    .map(|set| (set, None))
                    .map_err(StageError::from_numerics(""));
            }
            let sys = matrices_from_artefact(inputs.require("model")?)?;
            let residual = static_residual(&sys, &modes, &m.dofs, &pairs)
                .map_err(StageError::from_numerics("residual"))?;
            let mut set = modal_receptance(
                &modes,
                &m.dofs,
                &damping,
                &pairs,
                lines,
                Quantity::Receptance,
            )
            .map_err(StageError::from_numerics(""))?;
            add_residual(&mut set, &residual, &damping);
            convert_from_receptance(&mut set, quantity);
            Ok((set, None))
        }
        Some(Method::Krylov) => {
            let sys = matrices_from_artefact(inputs.require("model")?)?;
            let pairs = pairs_of(&sys.dofs);
            let options = p.krylov.options();
            krylov_receptance(&sys, &p.damping.direct(), &pairs, lines, quantity, &options)
                .map(|(set, report)| (set, Some(report)))
                .map_err(StageError::from_numerics(""))
        }
        _ => {
            let sys = matrices_from_artefact(inputs.require("model")?)?;
            let pairs = pairs_of(&sys.dofs);
            direct_receptance(&sys, &p.damping.direct(), &pairs, lines, quantity)
                .map(|set| (set, None))
                .map_err(StageError::from_numerics(""))
        }
    }
}

/// The model's DOFs (free DOFs of the matrices, or the DOFs of the modes).
fn model_dofs(inputs: &StageInputs, method: Option<Method>) -> Result<Vec<DofId>, StageError> {
    Ok(match method {
        Some(Method::Modal) => modes_from_artefact(inputs.require("modes")?)?.dofs,
        _ => matrices_from_artefact(inputs.require("model")?)?.dofs,
    })
}

/// The template's FRFs predicted through the map (14.7): the model FRFs between every pair of
/// model DOFs the map names for a measured pair, combined with the weights. Model DOFs the map
/// names that the model does not have (constrained ones) contribute zero, with a warning; a
/// measured DOF with none of its model DOFs left is refused.
fn through_map(
    p: &Params,
    inputs: &StageInputs,
    template: &FrfSet,
    map: &crate::pairing::TestMap,
) -> Result<(FrfSet, Option<KrylovReport>, Vec<String>), StageError> {
    let free: BTreeSet<DofId> = model_dofs(inputs, p.method)?.into_iter().collect();
    let combos: BTreeMap<DofId, Vec<(DofId, f64)>> = map.combinations().into_iter().collect();
    let mut dropped: BTreeSet<DofId> = BTreeSet::new();
    let mut terms_of = |d: DofId| -> Result<Vec<(DofId, f64)>, StageError> {
        let Some(all) = combos.get(&d) else {
            return Err(StageError::input(
                "",
                format!(
                    "measured DOF {d} is not in the map; the map holds {} (pair the FRFs it was made from)",
                    crate::core::first_of(combos.keys(), 12)
                ),
            ));
        };
        let kept: Vec<(DofId, f64)> = all
            .iter()
            .filter(|(a, _)| free.contains(a))
            .copied()
            .collect();
        dropped.extend(
            all.iter()
                .filter(|(a, _)| !free.contains(a))
                .map(|(a, _)| *a),
        );
        if kept.is_empty() {
            return Err(StageError::input(
                "",
                format!(
                    "measured DOF {d} maps only to {}, none of them a free DOF of the model (constrained?)",
                    all.iter()
                        .map(|(a, _)| a.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        Ok(kept)
    };
    let mut combos_of_pairs = Vec::with_capacity(template.pairs.len());
    let mut needed: Vec<FrfPair> = Vec::new();
    let mut index: BTreeMap<FrfPair, usize> = BTreeMap::new();
    for pair in &template.pairs {
        let (ri, ej) = (terms_of(pair.response)?, terms_of(pair.excitation)?);
        let mut terms = Vec::with_capacity(ri.len() * ej.len());
        for &(a, wa) in &ri {
            for &(b, wb) in &ej {
                let fe = FrfPair {
                    response: a,
                    excitation: b,
                };
                let k = *index.entry(fe).or_insert_with(|| {
                    needed.push(fe);
                    needed.len() - 1
                });
                terms.push((k, wa * wb));
            }
        }
        combos_of_pairs.push(terms);
    }
    let mut warnings = Vec::new();
    if !dropped.is_empty() {
        warnings.push(format!(
            "the map names model DOFs the model does not have (constrained?), taken as zero: {}",
            crate::core::first_of(dropped.iter(), 12)
        ));
    }
    let (fe, report) = synthesise(
        p,
        inputs,
        |_| needed.clone(),
        &template.freqs_hz,
        template.quantity,
    )?;
    let column: Vec<usize> = needed
        .iter()
        .map(|q| {
            fe.pair_index(q).ok_or_else(|| {
                StageError::Failed(format!(
                    "internal error: the model FRF {q:?} was not synthesised"
                ))
            })
        })
        .collect::<Result<_, _>>()?;
    let lines = template.freqs_hz.len();
    let values = Mat::from_fn(lines, template.pairs.len(), |l, j| {
        combos_of_pairs[j]
            .iter()
            .fold(c64::new(0.0, 0.0), |acc, &(k, w)| {
                acc + fe.values[(l, column[k])] * w
            })
    });
    let set = FrfSet {
        quantity: template.quantity,
        freqs_hz: template.freqs_hz.clone(),
        pairs: template.pairs.clone(),
        values,
    };
    Ok((set, report, warnings))
}

/// The FRF artefact, with the Krylov sweep's expansion points, basis size and estimates in
/// its meta when it made the values, and the synthesis's `warnings` when there are any.
fn frf_output(
    set: &FrfSet,
    report: Option<KrylovReport>,
    warnings: &[String],
    p: &Params,
) -> StageOutputs {
    let mut a = frf_to_artefact(set);
    if !warnings.is_empty() {
        a.meta
            .insert("synthesis_warnings".into(), warnings.to_vec().into());
    }
    if let Some(r) = report {
        let worst = r.estimates.iter().copied().fold(0.0, f64::max);
        a.meta.insert(
            "krylov".into(),
            serde_json::json!({
                "expansion_hz": r.expansion_hz,
                "basis_size": r.basis_size,
                "tolerance": p.krylov.tolerance.get(),
                "worst_estimate": worst,
            }),
        );
    }
    StageOutputs::from([("frf".to_string(), a)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    fn check(
        with: serde_json::Value,
        ports: &[&str],
    ) -> Result<serde_json::Value, Vec<ParamIssue>> {
        Typed::<FrfSynthesise>::new().check(&with, &CheckContext::with_ports(ports))
    }

    /// A map term on a model DOF the model lacks (a constrained one) contributes zero, and the
    /// FRF artefact records the warning that names it, so that it is shown again when cached.
    #[test]
    fn map_dofs_the_model_lacks_are_zero_with_a_recorded_warning() {
        use crate::pairing::{MapRow, RigidTransform, TestMap};
        let dof = |s: &str| -> DofId { s.parse().unwrap() };
        // Two masses of 1 kg on springs of 1e4 N/m: ground–1–2.
        let k = crate::core::sparse::sparse_from_triplets(
            "K",
            2,
            &[(0, 0, 2e4), (1, 0, -1e4), (0, 1, -1e4), (1, 1, 1e4)],
        )
        .unwrap();
        let m =
            crate::core::sparse::sparse_from_triplets("M", 2, &[(0, 0, 1.0), (1, 1, 1.0)]).unwrap();
        let sys = crate::fe::SystemMatrices {
            dofs: vec![dof("1:ux"), dof("2:ux")],
            k,
            m,
            c: None,
            d: None,
        };
        let pair = |r: &str, e: &str| crate::frf::FrfPair {
            response: dof(r),
            excitation: dof(e),
        };
        let template = FrfSet {
            quantity: Quantity::Receptance,
            freqs_hz: vec![5.0, 10.0, 30.0],
            pairs: vec![pair("101:ux", "102:ux")],
            values: Mat::zeros(3, 1),
        };
        let row = |t: &str, f: &str, weight: f64| MapRow {
            test_dof: dof(t),
            fe_dof: dof(f),
            weight,
        };
        let map = TestMap {
            transform: RigidTransform::identity(),
            fit: None,
            method: "stated".into(),
            tolerance: 1e-3,
            points: Vec::new(),
            rows: vec![
                row("101:ux", "1:ux", 0.5),
                row("101:ux", "3:ux", 0.5),
                row("102:ux", "2:ux", 1.0),
            ],
            warnings: Vec::new(),
        };
        let mut inputs = StageInputs::default();
        inputs.artefacts.insert(
            "model".into(),
            std::sync::Arc::new(crate::artefact::kinds::matrices_to_artefact(&sys)),
        );
        let p: Params = serde_json::from_value(serde_json::json!({
            "method": "direct", "damping": {"structural": 0.01}
        }))
        .unwrap();
        let (set, report, warnings) = through_map(&p, &inputs, &template, &map).unwrap();
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0].ends_with("taken as zero: 3:ux"), "{warnings:?}");
        // The measured 101 is half of model DOF 1: H(101, 102) = 0.5 H(1:ux, 2:ux), from
        // Z(ω) = K(1 + iη) − ω²M inverted by hand.
        for (l, f) in template.freqs_hz.iter().enumerate() {
            let w2 = (2.0 * std::f64::consts::PI * f).powi(2);
            let s = c64::new(1.0, 0.01);
            let (a, b, d) = (s * 2e4 - w2, s * -1e4, s * 1e4 - w2);
            let h12 = -b / (a * d - b * b);
            let got = set.values[(l, 0)];
            assert!(
                (got - h12 * 0.5).norm() <= 1e-12 * h12.norm(),
                "{f} Hz: {got}"
            );
        }
        let out = frf_output(&set, report, &warnings, &p);
        crate::artefact::kinds::check_layout(&out["frf"]).unwrap();
        let shown = crate::run_report::record::meta_warnings(&out["frf"].meta);
        assert_eq!(shown, warnings);
    }

    #[test]
    fn method_defaults_from_the_wiring() {
        let base = serde_json::json!({"responses": ["1:ux"], "excitations": ["1:ux"], "band_hz": [0, 10], "step_hz": 1});
        assert_eq!(check(base.clone(), &["modes"]).unwrap()["method"], "modal");
        assert_eq!(check(base, &["model"]).unwrap()["method"], "direct");
    }

    #[test]
    fn inconsistent_damping_is_explained() {
        let with = serde_json::json!({"method": "direct", "responses": ["1:ux"], "excitations": ["1:ux"], "band_hz": [0, 10], "step_hz": 1, "damping": {"viscous": 0.01}});
        let e = check(with, &["model"]).unwrap_err();
        assert_eq!(e[0].path, vec!["damping"]);
        assert!(e[0].message.contains("rayleigh"));
    }

    #[test]
    fn missing_lines_and_bad_band() {
        let e = check(
            serde_json::json!({"responses": ["1:ux"], "excitations": ["1:ux"]}),
            &["modes"],
        )
        .unwrap_err();
        assert!(e[0].message.contains("band_hz"));
        let e = check(serde_json::json!({"responses": ["1:ux"], "excitations": ["1:ux"], "band_hz": [10, 0], "step_hz": 1}), &["modes"]).unwrap_err();
        assert_eq!(e[0].path, vec!["band_hz"]);
        assert!(e[0].message.contains("start <= stop"));
    }

    #[test]
    fn mode_count_is_read_as_modes_count_with_a_deprecation() {
        let base = serde_json::json!({"responses": ["1:ux"], "excitations": ["1:ux"], "band_hz": [0, 10], "step_hz": 1});
        let mut old = base.clone();
        old["mode_count"] = 3.into();
        let mut new = base;
        new["modes"] = serde_json::json!({"count": 3});
        let checked = check(old.clone(), &["modes"]).unwrap();
        assert_eq!(checked["modes"]["count"], 3);
        assert!(checked.get("mode_count").is_none());
        assert_eq!(checked, check(new, &["modes"]).unwrap());
        let mut p: Params = crate::pipeline::stage::parse_params(&old).unwrap();
        let mut found = Vec::new();
        migrate_mode_fields(&mut p.modes, p.mode_count.take(), None, &mut found);
        assert_eq!((found[0].old, found[0].new), ("mode_count", "modes.count"));
        let mut zero = old;
        zero["mode_count"] = 0.into();
        let e = check(zero, &["modes"]).unwrap_err();
        assert_eq!(e[0].path, vec!["mode_count"]);
        assert!(e[0].message.contains(">= 1"), "{}", e[0].message);
    }
}
