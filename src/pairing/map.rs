//! Pairing test points to the model and the measured-to-model DOF map (docs/theory.md §14,
//! (14.4)–(14.6)).

use super::align::{FitReport, RigidTransform, mat_vec};
use super::shape::{Shape, locate};
use super::{PairingError, TestPoint, abbreviate};
use crate::core::{Component, DofId};
use crate::model::{Element, Model, SolidKind};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

/// How a test point is paired.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairMethod {
    /// The nearest grid.
    Nearest,
    /// The enclosing (or nearest, projected) element's shape functions.
    Interpolate,
    /// The nearest grid when within `snap` (m), else as `Interpolate`.
    Auto {
        /// Snap distance, m.
        snap: f64,
    },
}

impl PairMethod {
    /// Its name in artefacts.
    pub fn name(self) -> &'static str {
        match self {
            PairMethod::Nearest => "nearest",
            PairMethod::Interpolate => "interpolate",
            PairMethod::Auto { .. } => "auto",
        }
    }
}

/// What to do with points beyond the tolerance.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum OnBeyond {
    /// Refuse them, naming each.
    Error,
    /// Pair them anyway and warn.
    Warn,
}

/// Pairing settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairParams {
    /// How to pair.
    pub method: PairMethod,
    /// Largest accepted pairing distance, m.
    pub tolerance: f64,
    /// Points beyond it.
    pub beyond: OnBeyond,
}

/// What a point was paired to.
#[derive(Clone, Debug, PartialEq)]
pub enum PairedBy {
    /// A grid.
    Node(u64),
    /// An element, at natural coordinates.
    Element {
        /// Element id.
        id: u64,
        /// Its shape.
        shape: Shape,
        /// Natural coordinates of the (projected, clamped) point.
        natural: [f64; 3],
    },
}

/// One test point's pairing.
#[derive(Clone, Debug, PartialEq)]
pub struct PointPairing {
    /// Test node label.
    pub test_node: u64,
    /// Position after alignment, in model coordinates, m.
    pub xyz: [f64; 3],
    /// What it is paired to.
    pub paired_by: PairedBy,
    /// Weights on model grids (shape functions; 1 on a grid), non-zero only.
    pub nodes: Vec<(u64, f64)>,
    /// Distance to the grid, or to the element (out of plane for shells), m.
    pub distance: f64,
    /// The nearest grid and its distance, m.
    pub nearest_node: (u64, f64),
    /// Whether `distance` is within the tolerance.
    pub within_tolerance: bool,
}

/// A point beyond the tolerance, for messages.
#[derive(Clone, Debug, PartialEq)]
pub struct BeyondTolerance {
    /// Test node label.
    pub test_node: u64,
    /// Its pairing distance, m.
    pub distance: f64,
    /// The nearest grid and its distance, m.
    pub nearest_node: (u64, f64),
    /// Its aligned position, m.
    pub xyz: [f64; 3],
}

impl fmt::Display for BeyondTolerance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "test node {} at ({:.4}, {:.4}, {:.4}) m is {:.4e} m from the model (nearest grid {} at {:.4e} m)",
            self.test_node,
            self.xyz[0],
            self.xyz[1],
            self.xyz[2],
            self.distance,
            self.nearest_node.0,
            self.nearest_node.1
        )
    }
}

/// One term of the map: measured DOF `test_dof` receives `weight × fe_dof`.
#[derive(Clone, Debug, PartialEq)]
pub struct MapRow {
    /// Measured DOF.
    pub test_dof: DofId,
    /// Model DOF.
    pub fe_dof: DofId,
    /// Weight (shape function × direction cosine).
    pub weight: f64,
}

/// The test-to-model map with how it was made.
#[derive(Clone, Debug, PartialEq)]
pub struct TestMap {
    /// The alignment applied.
    pub transform: RigidTransform,
    /// The fit that gave it, when fitted.
    pub fit: Option<FitReport>,
    /// Pairing method name.
    pub method: String,
    /// Tolerance, m.
    pub tolerance: f64,
    /// Per test point, in the geometry's order.
    pub points: Vec<PointPairing>,
    /// The map, grouped by measured DOF in the order requested.
    pub rows: Vec<MapRow>,
    /// Warnings (points paired beyond tolerance).
    pub warnings: Vec<String>,
}

impl TestMap {
    /// Vectors at the model's `dofs` (one column each, e.g. mode shapes) at the measured DOFs:
    /// `φ_t = Σ w φ` over each measured DOF's terms (14.7), rows in the map's order. A model DOF
    /// the vectors lack is an error naming it.
    pub fn shapes_at_test_dofs(
        &self,
        dofs: &[DofId],
        shapes: faer::MatRef<'_, f64>,
    ) -> Result<(Vec<DofId>, faer::Mat<f64>), String> {
        let row: std::collections::HashMap<DofId, usize> =
            dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
        let combos = self.combinations();
        let mut out = faer::Mat::<f64>::zeros(combos.len(), shapes.ncols());
        for (t, (test_dof, terms)) in combos.iter().enumerate() {
            for (fe, w) in terms {
                let Some(&i) = row.get(fe) else {
                    return Err(format!(
                        "the map's measured DOF {test_dof} uses model DOF {fe}, which the modes do not hold (a constrained or dependent DOF, or modes of another model)"
                    ));
                };
                for c in 0..shapes.ncols() {
                    out[(t, c)] += w * shapes[(i, c)];
                }
            }
        }
        Ok((combos.into_iter().map(|(d, _)| d).collect(), out))
    }

    /// The weighted model DOFs of each measured DOF, in the order of first appearance.
    pub fn combinations(&self) -> Vec<(DofId, Vec<(DofId, f64)>)> {
        let mut out: Vec<(DofId, Vec<(DofId, f64)>)> = Vec::new();
        for r in &self.rows {
            match out.iter_mut().find(|(t, _)| *t == r.test_dof) {
                Some((_, terms)) => terms.push((r.fe_dof, r.weight)),
                None => out.push((r.test_dof, vec![(r.fe_dof, r.weight)])),
            }
        }
        out
    }
}

struct Candidate {
    id: u64,
    shape: Shape,
    /// The element's nodes in its shape's order (an omitted midside node's entry unused).
    nodes: Vec<u64>,
    /// Their coordinates (an omitted midside node at its edge's midpoint).
    xyz: Vec<[f64; 3]>,
    /// Omitted midside nodes `(index, corner, corner)`: their edge is straight, and their
    /// shape function's value goes half to each corner (the linear edge's interpolation).
    omitted: Vec<(usize, usize, usize)>,
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Candidate {
    /// The weight of each node, an omitted midside node's given to its edge's corners.
    fn node_weights(&self, weights: &[f64]) -> Vec<(u64, f64)> {
        let mut w = weights.to_vec();
        for &(k, a, b) in &self.omitted {
            let half = 0.5 * w[k];
            w[a] += half;
            w[b] += half;
            w[k] = 0.0;
        }
        self.nodes
            .iter()
            .zip(w)
            .filter(|(_, w)| w.abs() > 1e-12)
            .map(|(n, w)| (*n, w))
            .collect()
    }
}

/// An element's shape, its nodes in that shape's order (`None`: an omitted midside node) and
/// the corners of each midside node's edge.
type Interpolable = (Shape, Vec<Option<u64>>, Vec<[usize; 2]>);

/// [`Interpolable`] of `e`, if it has one.
fn shape_of(e: &Element) -> Option<Interpolable> {
    let all = |nodes: &[u64]| nodes.iter().map(|n| Some(*n)).collect::<Vec<_>>();
    let curved = |corners: &[u64], midside: &[Option<u64>]| {
        let c = corners.len();
        let nodes = all(corners)
            .into_iter()
            .chain(midside.iter().copied())
            .collect();
        (nodes, (0..c).map(|k| [k, (k + 1) % c]).collect())
    };
    match e {
        Element::Quad4 { nodes, .. } => Some((Shape::Quad4, all(nodes), vec![])),
        Element::Tria3 { nodes, .. } => Some((Shape::Tria3, all(nodes), vec![])),
        Element::Quad8 {
            corners, midside, ..
        } => {
            let (nodes, edges) = curved(corners, midside);
            Some((Shape::Quad8, nodes, edges))
        }
        Element::Tria6 {
            corners, midside, ..
        } => {
            let (nodes, edges) = curved(corners, midside);
            Some((Shape::Tria6, nodes, edges))
        }
        Element::Solid { kind, nodes, .. } => {
            let shape = match kind {
                SolidKind::Hexa8 => Shape::Hexa8,
                SolidKind::Tetra4 => Shape::Tetra4,
                SolidKind::Variable { family, .. } => {
                    // The quadratic shape with the omitted midside nodes at their edges'
                    // midpoints: the variable-node element's interpolation exactly.
                    let corners = family.corners();
                    let mut present = nodes[corners.min(nodes.len())..].iter();
                    let edges = crate::fe::solid::shape::edges(*family);
                    let listed = all(&nodes[..corners.min(nodes.len())])
                        .into_iter()
                        .chain((0..edges.len()).map(|k| {
                            if kind.midside() >> k & 1 == 1 {
                                present.next().copied()
                            } else {
                                None
                            }
                        }))
                        .collect();
                    let edges = edges.to_vec();
                    return Some((Shape::Solid(family.quadratic()), listed, edges));
                }
                other => Shape::Solid(*other),
            };
            Some((shape, all(nodes), vec![]))
        }
        _ => None,
    }
}

fn candidates(model: &Model) -> Vec<Candidate> {
    let mut out = Vec::new();
    for (&id, e) in &model.elements {
        let Some((shape, listed, edges)) = shape_of(e) else {
            continue;
        };
        let corners = listed.len() - edges.len();
        let Some(mut xyz) = listed
            .iter()
            .map(|n| match n {
                Some(n) => model.nodes.get(n).copied(),
                None => Some([f64::NAN; 3]),
            })
            .collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let mut omitted = Vec::new();
        for (m, [a, b]) in edges.iter().enumerate() {
            let k = corners + m;
            if listed[k].is_none() {
                xyz[k] = [0, 1, 2].map(|c| 0.5 * (xyz[*a][c] + xyz[*b][c]));
                omitted.push((k, *a, *b));
            }
        }
        let nodes: Vec<u64> = listed.iter().map(|n| n.unwrap_or(0)).collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in &xyz {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        out.push(Candidate {
            id,
            shape,
            nodes,
            xyz,
            omitted,
            lo,
            hi,
        });
    }
    out
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Pairs every test point (14.4)–(14.5): aligned by `transform`, then to the nearest grid, or
/// by the shape functions of the element whose (projected) image of it is nearest — preferring
/// one that encloses it, then the lowest id. Grids considered are those of the elements (all
/// grids when the model has none). A point with no interpolable element within the tolerance
/// is paired to its nearest grid. Points beyond `tolerance` are refused together, naming each
/// with its nearest grid, or (with [`OnBeyond::Warn`]) paired and returned with a warning.
pub fn pair_points(
    model: &Model,
    geometry: &[TestPoint],
    transform: &RigidTransform,
    params: &PairParams,
) -> Result<(Vec<PointPairing>, Vec<String>), PairingError> {
    let mut seen = BTreeSet::new();
    for p in geometry {
        if !seen.insert(p.node) {
            return Err(PairingError::DuplicateTestNode { node: p.node });
        }
        if !p.xyz.iter().all(|v| v.is_finite()) {
            return Err(PairingError::BadTestPoint {
                node: p.node,
                problem: format!("coordinates {:?} are not finite", p.xyz),
            });
        }
    }
    let used: BTreeSet<u64> = model.elements.values().flat_map(|e| e.nodes()).collect();
    let grids: Vec<(u64, [f64; 3])> = model
        .nodes
        .iter()
        .filter(|(n, _)| used.is_empty() || used.contains(n))
        .map(|(n, x)| (*n, *x))
        .collect();
    if grids.is_empty() {
        return Err(PairingError::EmptyModel {
            what: "grids".into(),
        });
    }
    let elements = candidates(model);
    if params.method == PairMethod::Interpolate && elements.is_empty() {
        return Err(PairingError::EmptyModel {
            what: "elements that can be interpolated (shells and solids); use `method: nearest`"
                .into(),
        });
    }
    let tol = params.tolerance;
    let mut out = Vec::with_capacity(geometry.len());
    let mut beyond = Vec::new();
    for p in geometry {
        let x = transform.apply(p.xyz);
        let mut nearest = (grids[0].0, f64::INFINITY);
        for &(n, g) in &grids {
            let d = dist(x, g);
            if d < nearest.1 {
                nearest = (n, d);
            }
        }
        let at_node = PointPairing {
            test_node: p.node,
            xyz: x,
            paired_by: PairedBy::Node(nearest.0),
            nodes: vec![(nearest.0, 1.0)],
            distance: nearest.1,
            nearest_node: nearest,
            within_tolerance: nearest.1 <= tol,
        };
        let interpolate = match params.method {
            PairMethod::Nearest => false,
            PairMethod::Interpolate => true,
            PairMethod::Auto { snap } => nearest.1 > snap,
        };
        let mut pairing = at_node.clone();
        if interpolate {
            // (distance, not inside, id) ordering, with distances equal to rounding.
            let mut best: Option<(f64, bool, &Candidate, super::Location)> = None;
            for c in &elements {
                let reach = tol.max(nearest.1);
                if (0..3).any(|k| x[k] < c.lo[k] - reach || x[k] > c.hi[k] + reach) {
                    continue;
                }
                let Some(l) = locate(c.shape, &c.xyz, x) else {
                    continue;
                };
                let better = match &best {
                    None => true,
                    Some((d, inside, _, _)) => {
                        let eps = 1e-12 * (1.0 + d.abs());
                        l.distance < d - eps || (l.distance <= d + eps && l.inside && !inside)
                    }
                };
                if better {
                    best = Some((l.distance, l.inside, c, l));
                }
            }
            if let Some((d, _, c, l)) = best
                && (d <= tol || d < nearest.1)
            {
                let nodes = c.node_weights(&l.weights);
                pairing = PointPairing {
                    paired_by: PairedBy::Element {
                        id: c.id,
                        shape: c.shape,
                        natural: l.natural,
                    },
                    nodes,
                    distance: d,
                    within_tolerance: d <= tol,
                    ..at_node
                };
            }
        }
        if !pairing.within_tolerance {
            beyond.push(BeyondTolerance {
                test_node: p.node,
                distance: pairing.distance,
                nearest_node: nearest,
                xyz: x,
            });
        }
        out.push(pairing);
    }
    if beyond.is_empty() {
        return Ok((out, Vec::new()));
    }
    match params.beyond {
        OnBeyond::Error => Err(PairingError::BeyondTolerance {
            tolerance: tol,
            points: beyond,
        }),
        OnBeyond::Warn => {
            let warnings = beyond
                .iter()
                .map(|b| format!("{b}: beyond the tolerance of {tol} m, paired anyway"))
                .collect();
            Ok((out, warnings))
        }
    }
}

/// The model DOF weights of a sensor at `point` along `direction`, a unit vector in the
/// point's displacement frame (14.6): `N_k (T_k R Σᵢ dᵢ aᵢ)_j` on `k:u_j` (`k:r_j` when
/// `rotational`); weights below 1e-12 in size are dropped.
pub fn sensor_weights(
    model: &Model,
    point: &TestPoint,
    pairing: &PointPairing,
    transform: &RigidTransform,
    direction: [f64; 3],
    rotational: bool,
) -> Result<Vec<(DofId, f64)>, PairingError> {
    let len = direction.iter().map(|d| d * d).sum::<f64>().sqrt();
    if !((len - 1.0).abs() <= 1e-6) {
        return Err(PairingError::BadTestPoint {
            node: point.node,
            problem: format!(
                "sensor direction {direction:?} has length {len}; give a unit vector in the point's displacement frame"
            ),
        });
    }
    for (i, a) in point.axes.iter().enumerate() {
        let l = a.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !((l - 1.0).abs() <= 1e-6) {
            return Err(PairingError::BadTestPoint {
                node: point.node,
                problem: format!(
                    "axis {} of its displacement frame, {a:?}, has length {l}; give unit axes",
                    i + 1
                ),
            });
        }
    }
    let mut d_test = [0.0; 3];
    for (i, a) in point.axes.iter().enumerate() {
        for k in 0..3 {
            d_test[k] += direction[i] * a[k];
        }
    }
    let d = transform.turn(d_test);
    let comps = if rotational {
        [Component::Rx, Component::Ry, Component::Rz]
    } else {
        [Component::Ux, Component::Uy, Component::Uz]
    };
    let mut out = Vec::new();
    for &(node, n) in &pairing.nodes {
        let local = match model.displacement_systems.get(&node) {
            Some(t) => mat_vec(t, d),
            None => d,
        };
        for j in 0..3 {
            let w = n * local[j];
            if w.abs() > 1e-12 {
                out.push((DofId::new(node, comps[j]), w));
            }
        }
    }
    Ok(out)
}

/// The map of the measured DOFs `test_dofs` (each `node:comp`, a direction of the node's
/// displacement frame), in their order, repeated DOFs once. `directions` gives the sensor
/// direction (a unit vector in the point's displacement frame) of DOFs whose sensor is not
/// along the frame's axis `comp`.
pub fn map_dofs(
    model: &Model,
    geometry: &[TestPoint],
    pairings: &[PointPairing],
    transform: &RigidTransform,
    test_dofs: &[DofId],
    directions: &BTreeMap<DofId, [f64; 3]>,
) -> Result<Vec<MapRow>, PairingError> {
    let points: BTreeMap<u64, (&TestPoint, &PointPairing)> = geometry
        .iter()
        .zip(pairings)
        .map(|(g, p)| (g.node, (g, p)))
        .collect();
    let mut done = BTreeSet::new();
    let mut rows = Vec::new();
    for &dof in test_dofs {
        if !done.insert(dof) {
            continue;
        }
        let Some((g, p)) = points.get(&dof.node) else {
            return Err(PairingError::UnknownTestNode {
                node: dof.node,
                context: format!("measured DOF {dof}"),
                known: abbreviate(geometry.iter().map(|g| g.node), 12),
            });
        };
        if dof.comp.is_scalar() {
            return Err(PairingError::BadTestDof {
                dof: dof.to_string(),
                problem: "a scalar point's DOF has no direction; measured DOFs are ux uy uz rx ry rz of a test point".into(),
            });
        }
        let mut e = [0.0; 3];
        e[dof.comp.slot() % 3] = 1.0;
        let e = directions.get(&dof).copied().unwrap_or(e);
        let terms = sensor_weights(model, g, p, transform, e, dof.comp.is_rotation())?;
        if terms.is_empty() {
            return Err(PairingError::BadTestDof {
                dof: dof.to_string(),
                problem: "it maps to no model DOF (all weights vanish)".into(),
            });
        }
        rows.extend(terms.into_iter().map(|(fe_dof, weight)| MapRow {
            test_dof: dof,
            fe_dof,
            weight,
        }));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::generate::{FlatPlate, PlateSupport, flat_plate, steel};
    use crate::pairing::{Rotation, TestPoint};

    /// 0.4 × 0.3 m plate, 4 × 3 elements of 0.1 m: nodes `1 + i + 5 j` at `(0.1 i, 0.1 j)`.
    fn plate() -> Model {
        flat_plate(&FlatPlate {
            a: 0.4,
            b: 0.3,
            nx: 4,
            ny: 3,
            thickness: 0.002,
            material: steel(),
            support: PlateSupport::Free,
        })
    }

    fn params(method: PairMethod) -> PairParams {
        PairParams {
            method,
            tolerance: 0.005,
            beyond: OnBeyond::Error,
        }
    }

    fn dof(s: &str) -> DofId {
        s.parse().unwrap()
    }

    /// An off-node point gets the bilinear weights of its element; a point on a grid snaps.
    #[test]
    fn interior_point_gets_bilinear_weights() {
        let m = plate();
        // In element 6 (nodes 7, 8, 13, 12: x 0.1–0.2, y 0.1–0.2) at ξ = 0.5, η = −0.5, 2 mm up.
        let geo = [
            TestPoint::global(1, [0.175, 0.125, 0.002]),
            TestPoint::global(2, [0.3, 0.2, 0.0]),
        ];
        let (p, w) = pair_points(
            &m,
            &geo,
            &RigidTransform::identity(),
            &params(PairMethod::Auto { snap: 1e-3 }),
        )
        .unwrap();
        assert!(w.is_empty());
        let PairedBy::Element { id, shape, .. } = p[0].paired_by else {
            panic!("{:?}", p[0]);
        };
        assert_eq!((id, shape), (6, Shape::Quad4));
        let want = [
            (7, 0.25 * 0.5 * 1.5),
            (8, 0.25 * 1.5 * 1.5),
            (13, 0.25 * 1.5 * 0.5),
            (12, 0.25 * 0.5 * 0.5),
        ];
        for ((n, w), (wn, ww)) in p[0].nodes.iter().zip(want) {
            assert_eq!(*n, wn);
            assert!((w - ww).abs() < 1e-14, "{:?}", p[0].nodes);
        }
        assert!((p[0].distance - 0.002).abs() < 1e-15);
        assert_eq!(p[1].paired_by, PairedBy::Node(14));
        // The map: uz of the point takes the shape weights on the grids' uz.
        let rows = map_dofs(
            &m,
            &geo,
            &p,
            &RigidTransform::identity(),
            &[dof("1:uz")],
            &BTreeMap::new(),
        )
        .unwrap();
        assert_eq!(rows.len(), 4);
        assert!(rows.iter().all(|r| r.fe_dof.comp == Component::Uz));
        assert!((rows.iter().map(|r| r.weight).sum::<f64>() - 1.0).abs() < 1e-14);
    }

    /// A CQUAD8 with a midside node omitted pairs like the plate's quad4 there: its straight
    /// edge's omitted node gives its weight to the two corners, the weights reproduce the point
    /// and sum to one, and no weight falls on an absent node.
    #[test]
    fn quad8_with_an_omitted_midside_node() {
        let mut m = plate();
        // Element 6 (corners 7, 8, 13, 12) as a CQUAD8 with midside nodes on three edges.
        let mut next = 100;
        let mut midside = [None; 4];
        let corners = [7, 8, 13, 12];
        for (k, slot) in midside.iter_mut().enumerate() {
            if k == 1 {
                continue;
            }
            let (a, b) = (m.nodes[&corners[k]], m.nodes[&corners[(k + 1) % 4]]);
            m.nodes.insert(next, [0, 1, 2].map(|c| 0.5 * (a[c] + b[c])));
            *slot = Some(next);
            next += 1;
        }
        let property = match m.elements[&6] {
            Element::Quad4 { property, .. } => property,
            _ => unreachable!(),
        };
        m.elements.insert(
            6,
            Element::Quad8 {
                corners,
                midside,
                property,
            },
        );
        let geo = [TestPoint::global(1, [0.175, 0.125, 0.0])];
        let (p, _) = pair_points(
            &m,
            &geo,
            &RigidTransform::identity(),
            &params(PairMethod::Interpolate),
        )
        .unwrap();
        let PairedBy::Element { id, shape, .. } = p[0].paired_by else {
            panic!("{:?}", p[0]);
        };
        assert_eq!((id, shape), (6, Shape::Quad8));
        assert!(p[0].distance < 1e-14);
        assert!((p[0].nodes.iter().map(|n| n.1).sum::<f64>() - 1.0).abs() < 1e-13);
        let mut image = [0.0; 3];
        for (n, w) in &p[0].nodes {
            assert!(m.nodes.contains_key(n), "weight on absent node {n}");
            for (x, g) in image.iter_mut().zip(m.nodes[n]) {
                *x += w * g;
            }
        }
        for (x, want) in image.iter().zip(geo[0].xyz) {
            assert!((x - want).abs() < 1e-14, "{image:?}");
        }
    }

    /// A point in a tetrahedron with one curved midside node (a variable-node CTETRA, G5 only)
    /// pairs in the quadratic shape with the omitted midside nodes given to their corners: the
    /// weights are the variable-node element's shape functions at the located point (1e-12)
    /// and reproduce the point (1e-12).
    #[test]
    fn a_partial_midside_solid_interpolates_with_its_own_functions() {
        use crate::model::{SolidFamily, SolidKind};
        let mut m = Model::default();
        let xyz = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.5, -0.06, 0.02],
        ];
        for (i, p) in xyz.iter().enumerate() {
            m.nodes.insert(i as u64 + 1, *p);
        }
        let kind = SolidKind::Variable {
            family: SolidFamily::Tetra,
            midside: 0b1,
        };
        m.elements.insert(
            1,
            Element::Solid {
                kind,
                nodes: vec![1, 2, 3, 4, 5],
                property: 1,
            },
        );
        let geo = [TestPoint::global(1, [0.3, 0.05, 0.2])];
        let (p, _) = pair_points(
            &m,
            &geo,
            &RigidTransform::identity(),
            &params(PairMethod::Interpolate),
        )
        .unwrap();
        let PairedBy::Element {
            id, shape, natural, ..
        } = p[0].paired_by
        else {
            panic!("{:?}", p[0]);
        };
        assert_eq!((id, shape), (1, Shape::Solid(SolidKind::Tetra10)));
        let (n, _) = crate::fe::solid::shape::shape(kind, natural);
        let mut image = [0.0; 3];
        for (node, w) in &p[0].nodes {
            let i = (*node - 1) as usize;
            assert!((w - n[i]).abs() < 1e-12, "node {node}: {w} vs {}", n[i]);
            for (x, g) in image.iter_mut().zip(xyz[i]) {
                *x += w * g;
            }
        }
        for (x, want) in image.iter().zip(geo[0].xyz) {
            assert!((x - want).abs() < 1e-12, "{image:?}");
        }
    }

    /// A skewed sensor's weights are its direction cosines; a sensor along −z gets −1; a model
    /// grid in a displacement system receives the direction in that system.
    #[test]
    fn directions_become_cosines() {
        let mut m = plate();
        let geo = [TestPoint::global(5, [0.2, 0.1, 0.0])];
        let t = RigidTransform::identity();
        let (p, _) = pair_points(&m, &geo, &t, &params(PairMethod::Nearest)).unwrap();
        assert_eq!(p[0].paired_by, PairedBy::Node(8));
        let d = [0.48, 0.6, 0.64];
        let w = sensor_weights(&m, &geo[0], &p[0], &t, d, false).unwrap();
        assert_eq!(
            w,
            vec![(dof("8:ux"), 0.48), (dof("8:uy"), 0.6), (dof("8:uz"), 0.64)]
        );
        let w = sensor_weights(&m, &geo[0], &p[0], &t, [0.0, 0.0, -1.0], false).unwrap();
        assert_eq!(w, vec![(dof("8:uz"), -1.0)]);
        // A test point whose frame is skewed: its x axis is the skew direction.
        let c = std::f64::consts::FRAC_1_SQRT_2;
        let skew = TestPoint {
            axes: [[c, 0.0, c], [0.0, 1.0, 0.0], [-c, 0.0, c]],
            ..geo[0].clone()
        };
        let rows = map_dofs(
            &m,
            std::slice::from_ref(&skew),
            &p,
            &t,
            &[dof("5:ux")],
            &BTreeMap::new(),
        )
        .unwrap();
        let got: Vec<(String, f64)> = rows
            .iter()
            .map(|r| (r.fe_dof.to_string(), r.weight))
            .collect();
        assert_eq!(got, vec![("8:ux".into(), c), ("8:uz".into(), c)]);
        // Model grid 8 measured in a system turned 90° about z: global x is its −y.
        m.displacement_systems
            .insert(8, [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);
        let w = sensor_weights(&m, &geo[0], &p[0], &t, [1.0, 0.0, 0.0], false).unwrap();
        assert_eq!(w, vec![(dof("8:uy"), -1.0)]);
        // A rotation by the alignment turns the direction too.
        let r = RigidTransform::new(
            &Rotation::AxisAngle {
                axis: [0.0, 0.0, 1.0],
                angle_deg: 90.0,
            },
            [0.0; 3],
        )
        .unwrap();
        m.displacement_systems.clear();
        let w = sensor_weights(&m, &geo[0], &p[0], &r, [1.0, 0.0, 0.0], true).unwrap();
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].0, dof("8:ry"));
        assert!((w[0].1 - 1.0).abs() < 1e-15);
        assert!(sensor_weights(&m, &geo[0], &p[0], &t, [1.0, 1.0, 0.0], false).is_err());
    }

    /// Points beyond the tolerance are named with their nearest grid, or paired with a warning.
    #[test]
    fn beyond_tolerance_is_refused_or_warned() {
        let m = plate();
        let geo = [
            TestPoint::global(1, [0.1, 0.1, 0.0]),
            TestPoint::global(77, [0.15, 0.15, 0.02]),
        ];
        let t = RigidTransform::identity();
        let e = pair_points(&m, &geo, &t, &params(PairMethod::Interpolate))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("test node 77") && e.contains("tolerance_m") && !e.contains("test node 1 "),
            "{e}"
        );
        let mut warn = params(PairMethod::Interpolate);
        warn.beyond = OnBeyond::Warn;
        let (p, w) = pair_points(&m, &geo, &t, &warn).unwrap();
        assert_eq!(w.len(), 1);
        assert!(!p[1].within_tolerance && (p[1].distance - 0.02).abs() < 1e-15);
        let e = map_dofs(&m, &geo, &p, &t, &[dof("9001:uz")], &BTreeMap::new())
            .unwrap_err()
            .to_string();
        assert!(e.contains("test node 9001") && e.contains("1, 77"), "{e}");
    }
}
