//! `mesh.generate`: the case-study geometries of CASES.md with a mesh-density knob.

use crate::artefact::ArtefactKind;
use crate::artefact::mesh::mesh_to_artefact;
use crate::model::generate::scale::{
    muffler, muffler_element_size, three_plate_element_size, three_plate_two_beam,
};
use crate::model::generate::{
    BentPlate, FlatPlate, PlateSupport, ThreeBeam, bent_plate, flat_plate, steel, three_beam,
};
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};

/// The stage.
pub struct MeshGenerate;

/// Which geometry, with its settings.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(tag = "geometry", rename_all = "snake_case", deny_unknown_fields)]
pub enum Params {
    /// C2: two bent plates with a diagonal bar (864 DOFs at `refine: 1`); C3 without the bar.
    BentPlate {
        /// Refinement `n`: `7n × 7n` shells per plate.
        #[serde(default = "one")]
        refine: usize,
        /// Bend angle in degrees (reconstructed default 30).
        #[serde(default = "bend")]
        bend_deg: f64,
        /// Shell thickness, m.
        #[serde(default = "thickness")]
        thickness_m: f64,
        /// Include the bar.
        #[serde(default = "yes")]
        with_bar: bool,
        /// Clamp the free edge of the first plate.
        #[serde(default)]
        clamped: bool,
    },
    /// A flat steel plate of `nx × ny` four-node shells.
    FlatPlate {
        /// Length along x, m.
        a_m: f64,
        /// Width along y, m.
        b_m: f64,
        /// Elements along x.
        nx: usize,
        /// Elements along y.
        ny: usize,
        /// Thickness, m.
        thickness_m: f64,
        /// Support.
        #[serde(default = "free")]
        support: PlateSupport,
    },
    /// C5: three stacked plates held by two beam columns, sized by a DOF target; measurement
    /// points 101–122, 201–222, 301–322 and zone sets `plate_k_zone_1..6` at every size.
    ThreePlateTwoBeam {
        /// About how many DOFs (sets the element size).
        dofs: usize,
    },
    /// C5: a muffler-like closed shell box with baffles and tubes, sized by a DOF target;
    /// measurement points 1–10 and panel sets (`top`, `side_1`, …, `baffle_k`) at every size.
    Muffler {
        /// About how many DOFs (sets the element size).
        dofs: usize,
        /// Internal baffles.
        #[serde(default = "two")]
        baffles: usize,
    },
    /// C4: the clamped three-beam assembly (648 DOFs at 35 elements per beam).
    ThreeBeam {
        /// Elements per beam.
        #[serde(default = "thirty_five")]
        elements_per_beam: usize,
        /// Clamp stiffness `[kx, ky, kz, krx, kry, krz]`.
        #[serde(default = "clamp")]
        clamp: [f64; 6],
        /// Joint stiffness.
        #[serde(default = "joint")]
        joint: [f64; 6],
    },
}

fn one() -> usize {
    1
}
fn bend() -> f64 {
    BentPlate::default().bend_deg
}
fn thickness() -> f64 {
    BentPlate::default().thickness
}
fn yes() -> bool {
    true
}
fn free() -> PlateSupport {
    PlateSupport::Free
}
fn two() -> usize {
    2
}
fn thirty_five() -> usize {
    35
}
fn clamp() -> [f64; 6] {
    ThreeBeam::default().clamp
}
fn joint() -> [f64; 6] {
    ThreeBeam::default().joint
}

/// Largest generated model, in nodes (about 1.2 million DOFs).
const MAX_NODES: usize = 200_000;

impl TypedStage for MeshGenerate {
    type Params = Params;
    const KIND: &'static str = "mesh.generate";
    const SUMMARY: &'static str = "Case-study geometries (bent plate, flat plate, three-beam, three plates and two beams, muffler) with a mesh-density knob";
    /// 2: the C5 generators carry measurement points with fixed ids and zone sets.
    const IMPL_VERSION: u32 = 2;
    const PREFLIGHT: bool = true;

    fn inputs() -> Vec<PortSpec> {
        vec![]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required("mesh", ArtefactKind::Mesh, "the model")]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        let mut positive = |field: &str, v: f64| {
            if !(v.is_finite() && v > 0.0) {
                issues.push(ParamIssue::at(field, format!("{v} must be positive")));
            }
        };
        match p {
            Params::BentPlate {
                refine,
                thickness_m,
                bend_deg,
                ..
            } => {
                positive("thickness_m", *thickness_m);
                if *refine == 0 || 120 * refine.pow(2) > MAX_NODES {
                    issues.push(ParamIssue::at(
                        "refine",
                        format!(
                            "{refine} must be 1 to {}",
                            (MAX_NODES as f64 / 120.0).sqrt() as usize
                        ),
                    ));
                }
                if !(bend_deg.is_finite() && bend_deg.abs() < 180.0) {
                    issues.push(ParamIssue::at("bend_deg", "must lie in (-180, 180)"));
                }
            }
            Params::FlatPlate {
                a_m,
                b_m,
                nx,
                ny,
                thickness_m,
                ..
            } => {
                positive("a_m", *a_m);
                positive("b_m", *b_m);
                positive("thickness_m", *thickness_m);
                if *nx == 0 || *ny == 0 || (*nx + 1) * (*ny + 1) > MAX_NODES {
                    issues.push(ParamIssue::at(
                        "nx",
                        format!("nx, ny must be >= 1 with (nx+1)(ny+1) <= {MAX_NODES}"),
                    ));
                }
            }
            Params::ThreePlateTwoBeam { dofs } | Params::Muffler { dofs, .. } => {
                if *dofs < 1000 || *dofs > 6 * MAX_NODES {
                    issues.push(ParamIssue::at(
                        "dofs",
                        format!("{dofs} must be 1000 to {}", 6 * MAX_NODES),
                    ));
                }
                if let Params::Muffler { baffles, .. } = p
                    && *baffles > 50
                {
                    issues.push(ParamIssue::at("baffles", "at most 50"));
                }
            }
            Params::ThreeBeam {
                elements_per_beam,
                clamp,
                joint,
            } => {
                if *elements_per_beam < 2 || *elements_per_beam > 10_000 {
                    issues.push(ParamIssue::at("elements_per_beam", "must be 2 to 10000"));
                }
                for (name, k) in [("clamp", clamp), ("joint", joint)] {
                    if k.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
                        issues.push(ParamIssue::at(name, "stiffnesses must be finite and >= 0"));
                    }
                }
            }
        }
        issues
    }

    fn run(p: &Params, _: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = match p {
            Params::BentPlate {
                refine,
                bend_deg,
                thickness_m,
                with_bar,
                clamped,
            } => bent_plate(&BentPlate {
                refine: *refine,
                bend_deg: *bend_deg,
                thickness: *thickness_m,
                with_bar: *with_bar,
                clamped: *clamped,
                ..Default::default()
            }),
            Params::FlatPlate {
                a_m,
                b_m,
                nx,
                ny,
                thickness_m,
                support,
            } => flat_plate(&FlatPlate {
                a: *a_m,
                b: *b_m,
                nx: *nx,
                ny: *ny,
                thickness: *thickness_m,
                material: steel(),
                support: *support,
            }),
            Params::ThreeBeam {
                elements_per_beam,
                clamp,
                joint,
            } => three_beam(&ThreeBeam {
                elements_per_beam: *elements_per_beam,
                clamp: *clamp,
                joint: *joint,
                ..Default::default()
            }),
            Params::ThreePlateTwoBeam { dofs } => {
                three_plate_two_beam(three_plate_element_size(*dofs))
            }
            Params::Muffler { dofs, baffles } => {
                muffler(muffler_element_size(*dofs, *baffles), *baffles)
            }
        };
        Ok(StageOutputs::from([(
            "mesh".to_string(),
            mesh_to_artefact(&model),
        )]))
    }
}
