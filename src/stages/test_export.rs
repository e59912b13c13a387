//! `test.export`: predictions written as a Universal File for the lab's own software: the
//! test points (dataset 2411) with their displacement frames (dataset 2420: a skewed or
//! upside-down sensor's directions), FRFs (dataset 58, or 58b), and modes (dataset 55), after
//! a dataset 164 stating SI units.
//!
//! FRFs are written at their own DOFs: a prediction made with `frf.synthesise`'s `template`
//! and `map` is already at the measured DOFs, in the test's quantity. Modes are written at
//! their DOFs too, or, with a `test.pair` map connected, at the measured DOFs: each is the
//! map's weighted sum of model DOFs (14.7), so an updated model's modes reach the lab's
//! points and directions. Mass-normalised modes carry modal mass 1, test modes 0 (unknown).

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::test_geometry::test_geometry_from_artefact;
use crate::artefact::kinds::test_map::test_map_from_artefact;
use crate::artefact::kinds::universal_file::{UniversalFile, UniversalFileKind};
use crate::artefact::kinds::{Kind, frf_from_artefact, modes_from_artefact};
use crate::frf::io::uff::write::{
    CartesianSystem, ModeRecord, UffEncoding, write_uff55, write_uff164_si, write_uff2411_framed,
    write_uff2420,
};
use crate::frf::io::uff::write_uff58_as;
use crate::pairing::TestPoint;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};

/// The stage.
pub struct TestExport;

/// How dataset 58 data are encoded.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Deserialize,
    serde::Serialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Encoding {
    /// The standard `4E20.12` columns (about 13 digits), readable by fixed-column readers.
    #[default]
    Ascii,
    /// 17 digits in 25 columns: exact, for whitespace-splitting readers.
    AsciiExact,
    /// Binary 58b, little-endian IEEE 754: exact and compact.
    Binary,
}

/// Parameters of `test.export`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// File name of the Universal File (default `femu.uff`).
    #[serde(default = "default_name")]
    pub file_name: String,
    /// Encoding of the FRF data (default `ascii`).
    #[serde(default)]
    pub encoding: Encoding,
    /// ID line 1 of the mode datasets.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
}

fn default_name() -> String {
    "femu.uff".into()
}

/// A test point for dataset 2411: label, position (m) and displacement system label.
type FramedNode = (u64, [f64; 3], u32);

/// The displacement frames of `points` as Cartesian systems (dataset 2420), one per distinct
/// frame in order of first use, labelled from 1, and each point with its system's label (0 for
/// the global frame). A point read in a cylindrical or spherical system carries that system's
/// directions at the point, so it gets a Cartesian system of its own: the directions its DOFs
/// measure along are what a reader needs, and they are kept exactly.
fn frames_of(points: &[TestPoint]) -> (Vec<CartesianSystem>, Vec<FramedNode>) {
    const GLOBAL: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut systems: Vec<CartesianSystem> = Vec::new();
    let nodes = points
        .iter()
        .map(|pt| {
            if pt.axes == GLOBAL {
                return (pt.node, pt.xyz, 0);
            }
            let label = match systems.iter().find(|s| s.axes == pt.axes) {
                Some(s) => s.label,
                None => {
                    let label = systems.len() as u32 + 1;
                    systems.push(CartesianSystem {
                        label,
                        axes: pt.axes,
                        origin: [0.0; 3],
                    });
                    label
                }
            };
            (pt.node, pt.xyz, label)
        })
        .collect();
    (systems, nodes)
}

/// A plain file name: no folder, not empty, not `.`/`..`.
fn plain_name(name: &str) -> bool {
    !name.is_empty()
        && name != "."
        && name != ".."
        && !name.contains(['/', '\\', '\0'])
        && name.len() <= 255
}

impl TypedStage for TestExport {
    type Params = Params;
    const KIND: &'static str = "test.export";
    const SUMMARY: &'static str = "Test points, FRFs and modes as a Universal File (datasets 2420, 2411, 58/58b, 55) for the lab";
    const IMPL_VERSION: u32 = 2;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::optional(
                "geometry",
                ArtefactKind::TestGeometry,
                "test points, written as dataset 2411, their displacement frames as dataset 2420",
            ),
            PortSpec::optional("frf", ArtefactKind::Frf, "FRFs, written as dataset 58"),
            PortSpec::optional("modes", ArtefactKind::Modes, "modes, written as dataset 55"),
            PortSpec::optional(
                "map",
                ArtefactKind::TestMap,
                "with `modes`: the modes are written at the map's measured DOFs",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "file",
            ArtefactKind::UniversalFile,
            "the Universal File",
        )]
    }

    fn validate(p: &mut Params, ctx: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if !plain_name(&p.file_name) {
            issues.push(ParamIssue::at(
                "file_name",
                format!("`{}` is not a plain file name (no folders)", p.file_name),
            ));
        }
        if !["geometry", "frf", "modes"]
            .iter()
            .any(|port| ctx.is_connected(port))
        {
            issues.push(ParamIssue::at(
                "",
                "nothing to write: connect `geometry`, `frf` or `modes`",
            ));
        }
        if ctx.is_connected("map") && !ctx.is_connected("modes") {
            issues.push(ParamIssue::at(
                "",
                "the `map` input maps `modes` to the measured DOFs; connect `modes` too, or remove `map`",
            ));
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        // Everything below is in SI; the file says so first.
        let mut bytes = write_uff164_si();
        let mut datasets = vec![(164, 1)];
        let mut source = Vec::new();
        if let Some(g) = inputs.get("geometry") {
            let geometry = test_geometry_from_artefact(g)?;
            let (systems, nodes) = frames_of(&geometry.points);
            if !systems.is_empty() {
                bytes.extend(write_uff2420("femu test geometry", &systems));
                datasets.push((2420, systems.len()));
            }
            bytes.extend(write_uff2411_framed(&nodes));
            datasets.push((2411, nodes.len()));
            source.push(format!("geometry {}", &g.digest()[..16]));
        }
        if let Some(f) = inputs.get("frf") {
            let set = frf_from_artefact(f)?;
            let encoding = match p.encoding {
                Encoding::Ascii => UffEncoding::Ascii,
                Encoding::AsciiExact => UffEncoding::AsciiExact,
                Encoding::Binary => UffEncoding::Binary(crate::frf::io::uff::ByteOrder::Little),
            };
            bytes.extend(write_uff58_as(&set, encoding));
            datasets.push((58, set.pairs.len()));
            source.push(format!("frf {}", &f.digest()[..16]));
        }
        if let Some(m) = inputs.get("modes") {
            let modes = modes_from_artefact(m)?;
            let (dofs, shapes) = match inputs.get("map") {
                Some(a) => {
                    let map = test_map_from_artefact(a)?;
                    map.shapes_at_test_dofs(&modes.dofs, modes.modes.shapes.as_ref())
                        .map_err(|e| StageError::input("map", e))?
                }
                None => (modes.dofs.clone(), modes.modes.shapes.clone()),
            };
            let modal_mass = match m.meta.get("normalisation").and_then(|v| v.as_str()) {
                Some("mass") => 1.0,
                _ => 0.0,
            };
            let freqs = modes.modes.frequencies_hz();
            let columns: Vec<Vec<f64>> = (0..shapes.ncols())
                .map(|c| (0..shapes.nrows()).map(|i| shapes[(i, c)]).collect())
                .collect();
            let records: Vec<ModeRecord<'_>> = columns
                .iter()
                .enumerate()
                .map(|(c, shape)| ModeRecord {
                    mode: c + 1,
                    freq_hz: freqs[c],
                    modal_mass,
                    damping_ratio: 0.0,
                    shape,
                })
                .collect();
            let title = p.title.clone().unwrap_or_else(|| "femu modes".into());
            bytes.extend(
                write_uff55(&dofs, &records, &title).map_err(|e| StageError::input("modes", e))?,
            );
            datasets.push((55, records.len()));
            source.push(format!("modes {}", &m.digest()[..16]));
        }
        let file = UniversalFile {
            name: p.file_name.clone(),
            bytes,
            datasets,
            source: source.join(", "),
        };
        Ok(StageOutputs::from([(
            "file".to_string(),
            UniversalFileKind::to_artefact(&file),
        )]))
    }
}
