//! `modes.import`: test modes from a Universal File (dataset 55: normal or complex modes, 3 or
//! 6 values per node), for `correlate.modes` and `update` (`eigensensitivity`) against the
//! test. Complex shapes are made real by their best rotation, with the phase collinearity kept
//! ([`crate::frf::io::uff::to_test_modes`]); shapes keep their measured scale. Values are in
//! each node's displacement frame, as `frf.import` reads FRF directions, so `test.pair` maps
//! them to the model the same way. The file's nodes leave as `geometry`, for `test.pair`.
//! Translations in a dataset 164's length unit are converted to metres (rotations kept), and
//! the conversion is one of the notes printed and recorded.
//!
//! The file is read when the pipeline is checked, so a malformed record is reported then; the
//! cache key holds the digests of the modes and the geometry, not the path.

use super::frf_import::geometry_of;
use crate::artefact::ArtefactKind;
use crate::artefact::kinds::modes::test_modes_to_artefact;
use crate::artefact::kinds::test_geometry::test_geometry_to_artefact;
use crate::frf::io::uff::{TestModes, read_uff, to_test_modes};
use crate::pairing::TestGeometry;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use std::path::Path;

/// The stage.
pub struct ModesImport;

/// Parameters of `modes.import`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Universal File (`.uff`, `.unv`) with dataset 55 mode shapes, relative to the pipeline
    /// file.
    pub path: String,
    /// Keep only the modes whose natural frequency is in `[low, high]` Hz.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band_hz: Option<[f64; 2]>,
    /// Digest of the imported modes, filled in when the pipeline is checked (not for users).
    #[serde(default)]
    pub content_digest: Option<String>,
    /// Digest of the imported test geometry, filled in when the pipeline is checked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geometry_digest: Option<String>,
}

/// The modes in the band (all without one), the geometry and the notes.
fn import(base: &Path, p: &Params) -> Result<(TestModes, TestGeometry), String> {
    let full = base.join(&p.path);
    let file = read_uff(&full).map_err(|e| e.to_string())?;
    let mut modes = to_test_modes(&file).map_err(|e| format!("{}: {e}", full.display()))?;
    modes.notes.extend(file.conversions.iter().cloned());
    modes.notes.extend(file.warnings.iter().cloned());
    if let Some([lo, hi]) = p.band_hz {
        let keep: Vec<usize> = (0..modes.freqs_hz.len())
            .filter(|&c| (lo..=hi).contains(&modes.freqs_hz[c]))
            .collect();
        if keep.is_empty() {
            return Err(format!(
                "{}: no mode in {lo}-{hi} Hz; the file's modes are at {} Hz",
                p.path,
                modes
                    .freqs_hz
                    .iter()
                    .map(|f| format!("{f:.4}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        let pick = |v: &[f64]| keep.iter().map(|&c| v[c]).collect::<Vec<f64>>();
        modes = TestModes {
            shapes: faer::Mat::from_fn(modes.dofs.len(), keep.len(), |i, j| {
                modes.shapes[(i, keep[j])]
            }),
            freqs_hz: pick(&modes.freqs_hz),
            damping_ratios: pick(&modes.damping_ratios),
            collinearity: pick(&modes.collinearity),
            modal_mass: pick(&modes.modal_mass),
            source_mode: keep.iter().map(|&c| modes.source_mode[c]).collect(),
            source_line: keep.iter().map(|&c| modes.source_line[c]).collect(),
            dofs: modes.dofs,
            notes: modes.notes,
        };
    }
    Ok((modes, geometry_of(&file)))
}

impl TypedStage for ModesImport {
    type Params = Params;
    const KIND: &'static str = "modes.import";
    const SUMMARY: &'static str =
        "Test modes from a Universal File (dataset 55), complex shapes made real";
    /// 3: nodes in local displacement systems are named in one warning.
    const IMPL_VERSION: u32 = 3;
    const PREFLIGHT: bool = true;

    fn inputs() -> Vec<PortSpec> {
        vec![]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "modes",
                ArtefactKind::Modes,
                "the test modes at the measured DOFs, in ascending frequency, as measured (not mass-normalised)",
            ),
            PortSpec::required(
                "geometry",
                ArtefactKind::TestGeometry,
                "the test points of datasets 15/2411 with their displacement frames",
            ),
        ]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        if let Some([lo, hi]) = p.band_hz
            && !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi)
        {
            return vec![ParamIssue::at(
                "band_hz",
                format!("[{lo}, {hi}] is not a band; give [low, high] with 0 <= low < high"),
            )];
        }
        match import(&ctx.base_dir, p) {
            Ok((modes, geometry)) => {
                p.content_digest = Some(test_modes_to_artefact(&modes).digest());
                p.geometry_digest = Some(test_geometry_to_artefact(&geometry).digest());
                Vec::new()
            }
            Err(e) => vec![ParamIssue::at("path", e)],
        }
    }

    fn key_params(params: &serde_json::Value) -> serde_json::Value {
        crate::pipeline::stage::without_path(params)
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let (modes, geometry) =
            import(&inputs.base_dir, p).map_err(StageError::input_at("path"))?;
        let a = test_modes_to_artefact(&modes);
        let g = test_geometry_to_artefact(&geometry);
        if p.content_digest.as_deref() != Some(a.digest().as_str())
            || p.geometry_digest.as_deref() != Some(g.digest().as_str())
        {
            return Err(StageError::input(
                "path",
                format!(
                    "{} changed between checking and running the pipeline; run again",
                    p.path
                ),
            ));
        }
        for note in &modes.notes {
            tracing::info!("modes.import: {note}");
        }
        Ok(StageOutputs::from([
            ("modes".to_string(), a),
            ("geometry".to_string(), g),
        ]))
    }
}
