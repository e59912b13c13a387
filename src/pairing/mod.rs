//! Test geometry against the model: rigid alignment of the test points (a stated transform or
//! a least-squares fit to named correspondences), pairing of each point to the model (the
//! nearest node, or the enclosing element's shape functions), and the map from measured DOFs to
//! weighted combinations of model DOFs (docs/theory.md §14, (14.1)–(14.6)).
//!
//! A measured DOF `n:c` is the motion of test point `n` along axis `c` of its displacement
//! frame. With the frame's axes `aᵢ` (unit rows in test components), the alignment's rotation
//! `R`, the paired element's shape functions `N_k` and model node `k`'s displacement frame
//! `T_k` (`u_local = T_k u_basic`, Nastran GRID CD), the measured motion is
//! `u_test = Σ_k N_k (T_k R a_c) · u_k` (14.6): weights `N_k (T_k R a_c)_j` on model DOFs
//! `k:u_j`, so a skewed sensor gets its direction cosines and a sensor along −z gets −1.

pub mod align;
pub mod map;
pub mod shape;

pub use align::{Correspondence, FitReport, RigidTransform, Rotation, fit_rigid};
pub use map::{
    BeyondTolerance, MapRow, OnBeyond, PairMethod, PairParams, PairedBy, PointPairing, TestMap,
    map_dofs, pair_points, sensor_weights,
};
pub use shape::{Location, Shape, locate};

/// One test point: its label, position and displacement frame.
#[derive(Clone, Debug, PartialEq)]
pub struct TestPoint {
    /// Test node label.
    pub node: u64,
    /// Position in the test system, m.
    pub xyz: [f64; 3],
    /// Displacement frame: rows are the unit vectors (in test components) of the point's
    /// directions 1–3 (and of the rotations about them).
    pub axes: [[f64; 3]; 3],
}

impl TestPoint {
    /// A point whose directions are the test system's axes.
    pub fn global(node: u64, xyz: [f64; 3]) -> Self {
        TestPoint {
            node,
            xyz,
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }
}

/// Test geometry as read from a test system's file: points with their frames, the coordinate
/// systems they were written in, and the trace lines drawn between them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TestGeometry {
    /// The points, in file order.
    pub points: Vec<TestPoint>,
    /// Per point, in the order of `points`: its definition and displacement coordinate system
    /// labels as written (0: global).
    pub systems: Vec<[u32; 2]>,
    /// Trace lines: number and node labels, 0 lifting the pen.
    pub trace_lines: Vec<(u64, Vec<u64>)>,
}

/// Why test geometry cannot be aligned, paired or mapped.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PairingError {
    /// Fewer than three correspondences for a fit.
    #[error(
        "a rigid fit needs at least three correspondences (test node → FE node) not on one line; got {}",
        if given.is_empty() { "none" } else { given.as_str() }
    )]
    TooFewCorrespondences {
        /// The correspondences given.
        given: String,
    },
    /// Correspondences that do not determine a rotation.
    #[error("the correspondences {pairs} cannot be fitted: {problem}")]
    DegenerateCorrespondences {
        /// The correspondences concerned.
        pairs: String,
        /// What is wrong.
        problem: String,
    },
    /// The SVD did not converge (not expected for finite 3×3 input).
    #[error("the SVD of the correspondences' cross-covariance did not converge")]
    FitFailed,
    /// A stated rotation that is not one.
    #[error("the stated transform is not a rigid motion: {problem}")]
    NotARotation {
        /// What is wrong.
        problem: String,
    },
    /// A test node the geometry does not hold.
    #[error("test node {node} is not in the test geometry ({context}); its nodes are {known}")]
    UnknownTestNode {
        /// The label.
        node: u64,
        /// Where it was named.
        context: String,
        /// The geometry's labels (abbreviated).
        known: String,
    },
    /// A model node that does not exist.
    #[error("FE node {node} is not a grid of the model ({context}); its grids are {known}")]
    UnknownFeNode {
        /// The id.
        node: u64,
        /// Where it was named.
        context: String,
        /// The model's grid ids (abbreviated).
        known: String,
    },
    /// A test label given twice.
    #[error("test node {node} appears twice in the test geometry; give each point once")]
    DuplicateTestNode {
        /// The label.
        node: u64,
    },
    /// A test point whose data are unusable.
    #[error("test node {node}: {problem}")]
    BadTestPoint {
        /// The label.
        node: u64,
        /// What is wrong and what would be valid.
        problem: String,
    },
    /// A measured DOF that cannot be mapped.
    #[error("measured DOF {dof}: {problem}")]
    BadTestDof {
        /// The DOF.
        dof: String,
        /// What is wrong and what would be valid.
        problem: String,
    },
    /// The model has nothing a point could be paired to.
    #[error("the model has no {what} to pair test points to")]
    EmptyModel {
        /// Grids, or elements that can be interpolated.
        what: String,
    },
    /// Test points beyond the tolerance.
    #[error("{} test point(s) lie beyond the tolerance of {tolerance} m: {}; raise `tolerance_m`, check the alignment, or set `beyond_tolerance: warn` to pair them anyway", points.len(), points.iter().map(|p| p.to_string()).collect::<Vec<_>>().join("; "))]
    BeyondTolerance {
        /// The tolerance, m.
        tolerance: f64,
        /// The points beyond it.
        points: Vec<BeyondTolerance>,
    },
}

impl crate::core::InputFault for PairingError {
    fn is_input(&self) -> bool {
        !matches!(self, PairingError::FitFailed)
    }
}

/// At most `n` labels, then a count.
pub(crate) fn abbreviate(ids: impl Iterator<Item = u64>, n: usize) -> String {
    let all: Vec<u64> = ids.collect();
    let mut s: Vec<String> = all.iter().take(n).map(|i| i.to_string()).collect();
    if all.len() > n {
        s.push(format!("… ({} in all)", all.len()));
    }
    if s.is_empty() {
        "none".into()
    } else {
        s.join(", ")
    }
}
