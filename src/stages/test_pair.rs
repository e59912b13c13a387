//! `test.pair`: pairs the test geometry of `frf.import` to the model and writes the map from
//! measured DOFs to weighted model DOFs (docs/theory.md §14): alignment as given, by a stated
//! rigid transform, or by a least-squares fit to named node correspondences; each test point to
//! its nearest grid or interpolated in its element; each measured direction, skewed or not,
//! as direction cosines on the model's translations (rotations). The figure shows the test
//! points over the mesh with their pairing distances.

use crate::artefact::ArtefactKind;
use crate::artefact::kinds::frf_from_artefact;
use crate::artefact::kinds::plot_artefact;
use crate::artefact::kinds::test_geometry::test_geometry_from_artefact;
use crate::artefact::kinds::test_map::test_map_to_artefact;
use crate::artefact::mesh::mesh_from_artefact;
use crate::core::{Component, DofId};
use crate::pairing::{
    Correspondence, OnBeyond, PairMethod, PairParams, RigidTransform, Rotation, TestMap, TestPoint,
    fit_rigid, map_dofs, pair_points,
};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::report::mesh_plot::View;
use crate::report::pairing_plot::{PairingPlot, PlotPoint, pairing_plot};
use std::collections::{BTreeMap, BTreeSet};

/// The stage.
pub struct TestPair;

/// A stated rotation of the test geometry (`x_model = R x_test + t`).
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum RotationSpec {
    /// The matrix `R` by rows: row `i` gives model component `i` from the test components.
    Matrix([[f64; 3]; 3]),
    /// A right-handed rotation by `angle_deg` about `axis` (model components, any length).
    AxisAngle {
        /// The axis.
        axis: [f64; 3],
        /// The angle, degrees.
        angle_deg: f64,
    },
    /// `[α, β, γ]` degrees about the fixed x, then y, then z axes: `R = R_z(γ) R_y(β) R_x(α)`.
    EulerXyzDeg([f64; 3]),
}

impl RotationSpec {
    fn rotation(&self) -> Rotation {
        match self {
            RotationSpec::Matrix(m) => Rotation::Matrix(*m),
            RotationSpec::AxisAngle { axis, angle_deg } => Rotation::AxisAngle {
                axis: *axis,
                angle_deg: *angle_deg,
            },
            RotationSpec::EulerXyzDeg(a) => Rotation::EulerXyz(*a),
        }
    }
}

/// A named correspondence for the fit.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NodePair {
    /// Test node label.
    pub test: u64,
    /// Model grid id it should coincide with.
    pub fe: u64,
}

/// How test coordinates become model coordinates.
#[derive(
    Clone, Debug, Default, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Alignment {
    /// The test coordinates are model coordinates.
    #[default]
    AsGiven,
    /// A stated rigid motion `x_model = R x_test + t`.
    Transform {
        /// `R`.
        rotation: RotationSpec,
        /// `t`, m.
        #[serde(default)]
        translation_m: [f64; 3],
    },
    /// The least-squares rigid motion bringing three or more test nodes (not on one line) onto
    /// the named grids; the residuals are reported.
    Fit(Vec<NodePair>),
}

/// How each test point is paired.
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
pub enum Method {
    /// The nearest grid within `snap_m`, else interpolation.
    #[default]
    Auto,
    /// The nearest grid.
    Nearest,
    /// The shape functions of the enclosing (or nearest, projected) shell or solid element,
    /// linear or quadratic.
    Interpolate,
}

/// A sensor not along an axis of its point's displacement frame.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Sensor {
    /// The measured DOF (`node:comp`) the sensor's data are named by.
    pub dof: DofId,
    /// Its direction, a unit vector in the point's displacement frame.
    pub direction: [f64; 3],
}

/// Parameters of `test.pair`.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Largest accepted distance between a test point and the model (to the grid, or to the
    /// element: out of plane for shells), m.
    pub tolerance_m: f64,
    /// How test coordinates become model coordinates: `as_given`, `{transform: {rotation:
    /// {axis_angle: {axis: [0, 0, 1], angle_deg: 90}}, translation_m: [..]}}` or `{fit: [{test:
    /// 101, fe: 1}, …]}`.
    #[serde(default)]
    pub alignment: Alignment,
    /// Factor on the test coordinates before alignment (e.g. 0.001 for a file in mm that has
    /// no units dataset 164).
    #[serde(default = "one")]
    pub scale: f64,
    /// `auto` (nearest grid within `snap_m`, else interpolation), `nearest` or `interpolate`.
    #[serde(default)]
    pub method: Method,
    /// `auto`: a test point this close to a grid is paired to it, m.
    #[serde(default = "snap")]
    pub snap_m: f64,
    /// Points beyond `tolerance_m`: `error` (refuse, naming each) or `warn` (pair anyway).
    #[serde(default = "refuse")]
    pub beyond_tolerance: OnBeyond,
    /// Sensors whose direction is not an axis of their point's displacement frame.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sensors: Vec<Sensor>,
    /// Figure title.
    #[serde(default = "title")]
    pub title: String,
}

fn one() -> f64 {
    1.0
}
fn snap() -> f64 {
    1e-3
}
fn refuse() -> OnBeyond {
    OnBeyond::Error
}
fn title() -> String {
    "Test points over the model".into()
}

fn positive(issues: &mut Vec<ParamIssue>, field: &str, v: f64, zero_ok: bool) {
    if !v.is_finite() || v < 0.0 || (!zero_ok && v == 0.0) {
        let want = if zero_ok {
            "finite and >= 0"
        } else {
            "finite and > 0"
        };
        issues.push(ParamIssue::at(field, format!("{v} must be {want}")));
    }
}

impl TypedStage for TestPair {
    type Params = Params;
    const KIND: &'static str = "test.pair";
    const SUMMARY: &'static str = "Pairs test points to the model (alignment, nearest grid or shape-function interpolation) and maps measured DOFs to weighted model DOFs";
    const IMPL_VERSION: u32 = 1;
    const PREFLIGHT: bool = true;

    fn inputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required("mesh", ArtefactKind::Mesh, "the model"),
            PortSpec::required(
                "geometry",
                ArtefactKind::TestGeometry,
                "the test points (frf.import's `geometry`)",
            ),
            PortSpec::optional(
                "frf",
                ArtefactKind::Frf,
                "the measured FRFs: their DOFs are mapped (without it: ux, uy, uz of every point)",
            ),
        ]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![
            PortSpec::required(
                "map",
                ArtefactKind::TestMap,
                "measured DOFs as weighted model DOFs, and each point's pairing",
            ),
            PortSpec::required(
                "plot",
                ArtefactKind::Plot,
                "pairing.png and pairing.svg: the test points over the mesh",
            ),
        ]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        positive(&mut issues, "tolerance_m", p.tolerance_m, false);
        positive(&mut issues, "snap_m", p.snap_m, true);
        positive(&mut issues, "scale", p.scale, false);
        if p.snap_m.is_finite() && p.tolerance_m.is_finite() && p.snap_m > p.tolerance_m {
            issues.push(ParamIssue::at(
                "snap_m",
                format!(
                    "{} exceeds tolerance_m {}; give a snap distance within the tolerance",
                    p.snap_m, p.tolerance_m
                ),
            ));
        }
        match &p.alignment {
            Alignment::AsGiven => {}
            Alignment::Transform {
                rotation,
                translation_m,
            } => {
                if let Err(e) = RigidTransform::new(&rotation.rotation(), *translation_m) {
                    issues.push(ParamIssue::at("alignment.transform", e.to_string()));
                }
            }
            Alignment::Fit(pairs) => {
                if pairs.len() < 3 {
                    issues.push(ParamIssue::at(
                        "alignment.fit",
                        format!(
                            "{} correspondence(s) given; a rigid fit needs at least three test nodes, not on one line, each with the grid it should meet",
                            pairs.len()
                        ),
                    ));
                }
                let mut seen = BTreeSet::new();
                for (i, np) in pairs.iter().enumerate() {
                    if !seen.insert(np.test) {
                        issues.push(ParamIssue {
                            path: vec!["alignment".into(), "fit".into(), i.to_string()],
                            message: format!(
                                "test node {} is named twice; name each once",
                                np.test
                            ),
                        });
                    }
                }
            }
        }
        for (i, s) in p.sensors.iter().enumerate() {
            let len = s.direction.iter().map(|d| d * d).sum::<f64>().sqrt();
            if !((len - 1.0).abs() <= 1e-6) {
                issues.push(ParamIssue {
                    path: vec!["sensors".into(), i.to_string(), "direction".into()],
                    message: format!(
                        "{:?} has length {len}; give a unit vector in the point's displacement frame",
                        s.direction
                    ),
                });
            }
            if s.dof.comp.is_scalar() {
                issues.push(ParamIssue {
                    path: vec!["sensors".into(), i.to_string(), "dof".into()],
                    message: format!("{} is a scalar point's DOF; give node:ux … node:rz", s.dof),
                });
            }
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = mesh_from_artefact(inputs.require("mesh")?)?;
        let geometry = test_geometry_from_artefact(inputs.require("geometry")?)?;
        if geometry.points.is_empty() {
            return Err(StageError::input(
                "",
                "the test geometry holds no points: the measured file has no nodes (Universal File datasets 15 or 2411); export the geometry with the FRFs",
            ));
        }
        let points: Vec<TestPoint> = geometry
            .points
            .iter()
            .map(|t| TestPoint {
                xyz: t.xyz.map(|v| v * p.scale),
                ..t.clone()
            })
            .collect();
        let (transform, fit) = align(p, &points, &model)?;
        let method = match p.method {
            Method::Auto => PairMethod::Auto { snap: p.snap_m },
            Method::Nearest => PairMethod::Nearest,
            Method::Interpolate => PairMethod::Interpolate,
        };
        let params = PairParams {
            method,
            tolerance: p.tolerance_m,
            beyond: p.beyond_tolerance,
        };
        let (pairings, warnings) = pair_points(&model, &points, &transform, &params)
            .map_err(StageError::from_numerics("tolerance_m"))?;
        for w in &warnings {
            tracing::warn!("test.pair: {w}");
        }
        let test_dofs: Vec<DofId> = match inputs.get("frf") {
            Some(a) => frf_from_artefact(a)?.dofs(),
            None => points
                .iter()
                .flat_map(|t| {
                    [Component::Ux, Component::Uy, Component::Uz].map(|c| DofId::new(t.node, c))
                })
                .collect(),
        };
        let directions: BTreeMap<DofId, [f64; 3]> =
            p.sensors.iter().map(|s| (s.dof, s.direction)).collect();
        for s in &p.sensors {
            if !test_dofs.contains(&s.dof) {
                return Err(StageError::input(
                    "sensors",
                    format!(
                        "{} is not a measured DOF; the measured DOFs are {}",
                        s.dof,
                        abbreviate_dofs(&test_dofs)
                    ),
                ));
            }
        }
        let rows = map_dofs(
            &model,
            &points,
            &pairings,
            &transform,
            &test_dofs,
            &directions,
        )
        .map_err(StageError::from_numerics(""))?;
        let map = TestMap {
            transform,
            fit,
            method: match p.method {
                Method::Auto => "auto",
                Method::Nearest => "nearest",
                Method::Interpolate => "interpolate",
            }
            .into(),
            tolerance: p.tolerance_m,
            points: pairings,
            rows,
            warnings,
        };
        let figure = pairing_plot(&PairingPlot {
            title: p.title.clone(),
            model: &model,
            points: map
                .points
                .iter()
                .map(|q| PlotPoint {
                    node: q.test_node,
                    xyz: q.xyz,
                    distance: q.distance,
                    within: q.within_tolerance,
                })
                .collect(),
            tolerance: p.tolerance_m,
            view: View::default(),
        })
        .map_err(StageError::failed)?;
        Ok(StageOutputs::from([
            ("map".to_string(), test_map_to_artefact(&map)),
            (
                "plot".to_string(),
                plot_artefact("pairing", &p.title, figure),
            ),
        ]))
    }
}

fn abbreviate_dofs(dofs: &[DofId]) -> String {
    let mut s: Vec<String> = dofs.iter().take(12).map(|d| d.to_string()).collect();
    if dofs.len() > 12 {
        s.push(format!("… ({} in all)", dofs.len()));
    }
    s.join(", ")
}

/// The alignment the parameters state, or the fit to their correspondences.
fn align(
    p: &Params,
    points: &[TestPoint],
    model: &crate::model::Model,
) -> Result<(RigidTransform, Option<crate::pairing::FitReport>), StageError> {
    match &p.alignment {
        Alignment::AsGiven => Ok((RigidTransform::identity(), None)),
        Alignment::Transform {
            rotation,
            translation_m,
        } => {
            let t = RigidTransform::new(&rotation.rotation(), *translation_m)
                .map_err(StageError::from_numerics("alignment.transform"))?;
            Ok((t, None))
        }
        Alignment::Fit(pairs) => {
            let mut c = Vec::with_capacity(pairs.len());
            for np in pairs {
                let Some(t) = points.iter().find(|t| t.node == np.test) else {
                    return Err(StageError::input(
                        "alignment.fit",
                        format!(
                            "test node {} is not in the test geometry; its nodes are {}",
                            np.test,
                            crate::pairing::abbreviate(points.iter().map(|t| t.node), 12)
                        ),
                    ));
                };
                let Some(q) = model.nodes.get(&np.fe) else {
                    return Err(StageError::input(
                        "alignment.fit",
                        format!(
                            "FE node {} (for test node {}) is not a grid of the model; its grids are {}",
                            np.fe,
                            np.test,
                            crate::pairing::abbreviate(model.nodes.keys().copied(), 12)
                        ),
                    ));
                };
                c.push(Correspondence {
                    test_node: np.test,
                    test_xyz: t.xyz,
                    fe_node: np.fe,
                    fe_xyz: *q,
                });
            }
            let fit = fit_rigid(&c).map_err(StageError::from_numerics("alignment.fit"))?;
            tracing::info!(
                "test.pair: rigid fit to {} correspondences, RMS residual {:.3e} m",
                c.len(),
                fit.rms
            );
            Ok((fit.transform, Some(fit)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(with: serde_json::Value) -> Vec<ParamIssue> {
        let mut p: Params = serde_json::from_value(with).unwrap();
        TestPair::validate(&mut p, &CheckContext::default())
    }

    #[test]
    fn bad_parameters_are_named() {
        let i = check(serde_json::json!({"tolerance_m": 0.0}));
        assert_eq!(i[0].path, vec!["tolerance_m"]);
        let i = check(serde_json::json!({"tolerance_m": 0.01, "snap_m": 0.02}));
        assert!(i[0].message.contains("within the tolerance"), "{i:?}");
        let i = check(serde_json::json!({"tolerance_m": 0.01,
            "alignment": {"fit": [{"test": 1, "fe": 2}, {"test": 1, "fe": 3}]}}));
        assert!(
            i.iter().any(|x| x.message.contains("at least three")),
            "{i:?}"
        );
        assert!(
            i.iter().any(|x| x.path == vec!["alignment", "fit", "1"]),
            "{i:?}"
        );
        let i = check(serde_json::json!({"tolerance_m": 0.01,
            "alignment": {"transform": {"rotation": {"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}}}}));
        assert!(i[0].message.contains("reflection"), "{i:?}");
        let i = check(serde_json::json!({"tolerance_m": 0.01,
            "sensors": [{"dof": "3:ux", "direction": [1.0, 1.0, 0.0]}]}));
        assert_eq!(i[0].path, vec!["sensors", "0", "direction"]);
        assert!(check(serde_json::json!({"tolerance_m": 0.01,
            "alignment": {"transform": {"rotation": {"euler_xyz_deg": [0, 0, 90]}, "translation_m": [1, 0, 0]}}}))
        .is_empty());
        let e = serde_json::from_value::<Params>(
            serde_json::json!({"tolerance_m": 0.01, "methd": "auto"}),
        );
        assert!(e.is_err());
    }
}
