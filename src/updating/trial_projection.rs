//! Rayleigh-Ritz matrices `ΦᵀK(φ)Φ`, `ΦᵀM(φ)Φ` of a full model at any parameter values on a
//! held basis `Φ`, without assembling the model: the trial states of
//! [`super::model::FeModel`] (docs/theory.md §9).
//!
//! A parameter changes the elements of its set only, so the projected matrices are a sum over
//! the elements no parameter reaches and over *clusters*: the parameters that share elements,
//! with the elements they reach. Within a cluster the element matrices are polynomials in the
//! parameters for the kinds whose kernels make them so — linear in `E`, `ρ`, a spring's
//! stiffness or a lumped mass; cubic in a shell's thickness (membrane and transverse shear
//! `∝ t`, bending and rotary inertia `∝ t³`, offsets and non-structural mass fixed) — and so is
//! the cluster's projection. It is then the tensor-product Lagrange interpolant of its
//! projections at `Π (dᵢ + 1)` grid points: exact to rounding, not an approximation, and a trial
//! costs `O(m²)` per grid point. Every such claim is checked once, at a point off the grid,
//! against a direct projection ([`CHECK_TOLERANCE`] in the scale of the whole projected matrix). A
//! cluster
//! that fails the check, or whose kinds are not polynomial (beam section sizes: a rectangle's
//! torsion constant is not), is projected directly at every trial, from its elements alone.
//!
//! A projection is formed element by element, `Σ_e (T_eΦ)ᵀ K_e (T_eΦ)`, with each element's rows
//! found as the assembly finds them (constrained DOFs dropped, dependent DOFs of multipoint
//! constraints through their independent ones, displacement systems applied by the element
//! matrices), in chunks of elements whose rows of `Φ` are gathered once: `K_e T_eΦ` is added into
//! the chunk's rows, and the chunk contributes `Φ_rᵀ (K Φ)_r`.

use crate::core::DofId;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::{
    DofIndex, ModelAssemblyError, dependents_of, named_element_matrices, row_map,
};
use crate::fe::multipoint::DependentDof;
use crate::model::{Element, Model, ModelError, Parameter, ParameterKind};
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;
use std::collections::BTreeMap;

use super::model::UpdatingError;

/// Largest difference between a polynomial cluster's interpolant and its direct projection at
/// the check point, relative to the scale of the whole projected matrix (see [`worst_excess`]): the
/// interpolant is exact, so only rounding separates them.
pub const CHECK_TOLERANCE: f64 = 1e-9;

/// The absolute part of the check, as a share of the largest diagonal of the whole projected
/// matrix: rounding of sums that cancel (a stiff part that moves almost rigidly in the kept
/// modes; the rigid-body modes' own stiffness rows are not checked at all).
pub const CHECK_FLOOR: f64 = 1e-11;

/// Most grid points of a polynomial cluster; a larger cluster is projected at every trial.
const MAX_GRID: usize = 16;

/// Elements per chunk of [`project_elements`]: their rows of `Φ` are gathered once.
const CHUNK: usize = 512;

/// Where a grid point or the check point lies, as a multiple of half the parameter's value
/// from it (`φ⁰ (1 + c/2)`): inside `[φ⁰/2, 3φ⁰/2]`, positive, and the check point off every
/// node of degree at most three.
const CHECK_OFFSET: f64 = 0.29;

/// The degree of an element's matrices as polynomials in a parameter of this kind, where the
/// element kernel makes them polynomial (each claim is checked on the model, see the module):
/// `None` for section sizes, and for the thickness of a tria3, whose transverse shear carries
/// the stabilisation `t²/(t² + α h²)`.
fn polynomial_degree(kind: &ParameterKind, element: &Element) -> Option<usize> {
    match kind {
        ParameterKind::ShellThickness => (!matches!(element, Element::Tria3 { .. })).then_some(3),
        ParameterKind::YoungsModulus
        | ParameterKind::Density
        | ParameterKind::SpringStiffness(_)
        | ParameterKind::LumpedMass(_) => Some(1),
        ParameterKind::BeamWidth | ParameterKind::BeamHeight => None,
    }
}

/// The rows of an assembled system: where an element's rows go.
struct Rows {
    index: DofIndex,
    dependents: BTreeMap<DofId, DependentDof>,
}

/// A cluster's projections at the points of its grid.
struct Grid {
    /// Node values per parameter of the cluster.
    nodes: Vec<Vec<f64>>,
    /// `ΦᵀKΦ`, `ΦᵀMΦ` of the cluster's elements at each grid point (the first parameter's
    /// node varying slowest).
    projections: Vec<(Mat<f64>, Mat<f64>)>,
}

/// Parameters that share elements, and the elements they change.
struct Cluster {
    /// Indices into the parameter list.
    parameters: Vec<usize>,
    /// Element ids.
    elements: Vec<u64>,
    /// The polynomial form; `None`: projected at every trial.
    grid: Option<Grid>,
}

/// The projected matrices of a model on one basis, ready for any parameter values.
pub struct ParametricProjection {
    rows: Rows,
    mass: MassKind,
    /// `ΦᵀKΦ`, `ΦᵀMΦ` of the elements no parameter changes.
    fixed: (Mat<f64>, Mat<f64>),
    clusters: Vec<Cluster>,
}

/// `model` with `values` written into its `parameters`.
pub fn model_with(
    model: &Model,
    parameters: &[Parameter],
    values: &[f64],
) -> Result<Model, UpdatingError> {
    let mut model = model.clone();
    for (p, &v) in parameters.iter().zip(values) {
        model.set_parameter_value(p, v)?;
    }
    Ok(model)
}

impl ParametricProjection {
    /// Clusters, grids and checks for `model` (its parameter values `values`) on `basis`, whose
    /// rows are the DOFs `dofs` and whose first `rigid` columns are rigid-body modes: their
    /// projected stiffness is round-off of `‖K‖ε` (which the trials set to zero), so the checks
    /// leave their rows and columns of `K` out — on a fine mesh that round-off alone exceeds
    /// what the check allows.
    pub fn new(
        model: &Model,
        parameters: &[Parameter],
        values: &[f64],
        basis: MatRef<'_, f64>,
        dofs: &[DofId],
        rigid: usize,
        mass: MassKind,
    ) -> Result<Self, UpdatingError> {
        let rows = Rows {
            index: dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect(),
            dependents: dependents_of(model)?,
        };
        let (fixed_ids, mut clusters) = clusters_of(model, parameters)?;
        let fixed = project_elements(model, &fixed_ids, &rows, basis, mass)?;
        // Grid nodes per parameter: `φ⁰ (1 + c/2)` at `d + 1` equispaced `c` in [−1, 1], `d`
        // the largest degree over the cluster's elements.
        let nodes_of = |p: usize, elements: &[u64]| -> Option<Vec<f64>> {
            let mut d = 0;
            for id in elements {
                let e = model.elements.get(id)?;
                d = d.max(polynomial_degree(&parameters[p].kind, e)?);
            }
            Some(
                (0..=d)
                    .map(|k| {
                        let c = if d == 0 {
                            0.0
                        } else {
                            -1.0 + 2.0 * k as f64 / d as f64
                        };
                        values[p] * (1.0 + 0.5 * c)
                    })
                    .collect(),
            )
        };
        let mut grids: Vec<Option<Vec<Vec<f64>>>> = clusters
            .iter()
            .map(|c| {
                let nodes: Option<Vec<Vec<f64>>> = c
                    .parameters
                    .iter()
                    .map(|&p| nodes_of(p, &c.elements))
                    .collect();
                nodes.filter(|n| n.iter().map(Vec::len).product::<usize>() <= MAX_GRID)
            })
            .collect();
        // The k-th evaluation puts every polynomial cluster at its k-th grid point.
        let evaluations = grids
            .iter()
            .flatten()
            .map(|n| n.iter().map(Vec::len).product::<usize>())
            .max()
            .unwrap_or(0);
        let mut projections: Vec<Vec<(Mat<f64>, Mat<f64>)>> = vec![Vec::new(); clusters.len()];
        for point in 0..evaluations {
            let mut at = values.to_vec();
            let mut due = Vec::new();
            for (c, cluster) in clusters.iter().enumerate() {
                let Some(nodes) = &grids[c] else { continue };
                if point >= nodes.iter().map(Vec::len).product::<usize>() {
                    continue;
                }
                for (&p, v) in cluster.parameters.iter().zip(grid_point(nodes, point)) {
                    at[p] = v;
                }
                due.push(c);
            }
            let moved = model_with(model, parameters, &at)?;
            for c in due {
                let pair = project_elements(&moved, &clusters[c].elements, &rows, basis, mass)?;
                projections[c].push(pair);
            }
        }
        // The check point: every polynomial cluster off its grid.
        let mut at = values.to_vec();
        for (c, cluster) in clusters.iter().enumerate() {
            if grids[c].is_some() {
                for &p in &cluster.parameters {
                    at[p] = values[p] * (1.0 + 0.5 * CHECK_OFFSET);
                }
            }
        }
        if grids.iter().any(Option::is_some) {
            let moved = model_with(model, parameters, &at)?;
            let mut checks = Vec::new();
            let (mut total_k, mut total_m) = fixed.clone();
            for (c, cluster) in clusters.iter().enumerate() {
                if grids[c].is_some() {
                    let direct = project_elements(&moved, &cluster.elements, &rows, basis, mass)?;
                    total_k += &direct.0;
                    total_m += &direct.1;
                    checks.push((c, direct));
                }
            }
            for (c, (direct_k, direct_m)) in checks {
                let cluster = &mut clusters[c];
                let grid = Grid {
                    nodes: grids[c].take().unwrap_or_default(),
                    projections: std::mem::take(&mut projections[c]),
                };
                let local: Vec<f64> = cluster.parameters.iter().map(|&p| at[p]).collect();
                let (k, m) = grid.interpolate(&local);
                let excess = worst_excess(&k, &direct_k, &total_k, rigid)
                    .map(|w| ("K", w))
                    .or_else(|| worst_excess(&m, &direct_m, &total_m, 0).map(|w| ("M", w)));
                match excess {
                    None => cluster.grid = Some(grid),
                    Some((matrix, (i, j, difference, allowed))) => tracing::debug!(
                        "trial projection: the parameters {:?} are not polynomial of the assumed degree on their elements (projected {matrix}, entry ({i}, {j}): off by {difference:.3e} where {allowed:.3e} is allowed); projected at every trial",
                        cluster
                            .parameters
                            .iter()
                            .map(|&p| parameters[p].name.as_str())
                            .collect::<Vec<_>>()
                    ),
                }
            }
        }
        Ok(ParametricProjection {
            rows,
            mass,
            fixed,
            clusters,
        })
    }

    /// `ΦᵀK(φ)Φ` and `ΦᵀM(φ)Φ` at `values` (symmetric); `model` and `parameters` as given to
    /// [`Self::new`], for the clusters projected at every trial.
    pub fn at(
        &self,
        model: &Model,
        parameters: &[Parameter],
        values: &[f64],
        basis: MatRef<'_, f64>,
    ) -> Result<(Mat<f64>, Mat<f64>), UpdatingError> {
        let (mut k, mut m) = (self.fixed.0.clone(), self.fixed.1.clone());
        let mut moved: Option<Model> = None;
        for cluster in &self.clusters {
            let (ck, cm) = match &cluster.grid {
                Some(grid) => {
                    let local: Vec<f64> = cluster.parameters.iter().map(|&p| values[p]).collect();
                    grid.interpolate(&local)
                }
                None => {
                    if moved.is_none() {
                        moved = Some(model_with(model, parameters, values)?);
                    }
                    let moved = moved.as_ref().unwrap_or(model);
                    project_elements(moved, &cluster.elements, &self.rows, basis, self.mass)?
                }
            };
            k += &ck;
            m += &cm;
        }
        Ok((symmetrised(k), symmetrised(m)))
    }

    /// Clusters whose projections are interpolated, and all clusters (for reports and tests).
    pub fn polynomial_clusters(&self) -> (usize, usize) {
        let polynomial = self.clusters.iter().filter(|c| c.grid.is_some()).count();
        (polynomial, self.clusters.len())
    }
}

impl Grid {
    /// The tensor-product Lagrange interpolant of the projections at `values` (one per
    /// parameter of the cluster).
    fn interpolate(&self, values: &[f64]) -> (Mat<f64>, Mat<f64>) {
        let weights: Vec<Vec<f64>> = self
            .nodes
            .iter()
            .zip(values)
            .map(|(nodes, &x)| lagrange_weights(nodes, x))
            .collect();
        let (r, c) = (self.projections[0].0.nrows(), self.projections[0].0.ncols());
        let (mut k, mut m) = (Mat::<f64>::zeros(r, c), Mat::<f64>::zeros(r, c));
        for (point, (pk, pm)) in self.projections.iter().enumerate() {
            let mut w = 1.0;
            let mut rest = point;
            for (dim, nodes) in self.nodes.iter().enumerate().rev() {
                w *= weights[dim][rest % nodes.len()];
                rest /= nodes.len();
            }
            if w != 0.0 {
                k += faer::Scale(w) * pk;
                m += faer::Scale(w) * pm;
            }
        }
        (k, m)
    }
}

/// The values of the parameters at grid point `point` (the first parameter's node varying
/// slowest).
fn grid_point(nodes: &[Vec<f64>], point: usize) -> Vec<f64> {
    let mut out = vec![0.0; nodes.len()];
    let mut rest = point;
    for (dim, n) in nodes.iter().enumerate().rev() {
        out[dim] = n[rest % n.len()];
        rest /= n.len();
    }
    out
}

/// `ℓ_k(x) = Π_{j≠k} (x − x_j)/(x_k − x_j)` for every node `k`.
fn lagrange_weights(nodes: &[f64], x: f64) -> Vec<f64> {
    (0..nodes.len())
        .map(|k| {
            nodes
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != k)
                .map(|(_, xj)| (x - xj) / (nodes[k] - xj))
                .product()
        })
        .collect()
}

/// Whether a cluster's interpolant `a` matches its direct projection `b` in the scale of the
/// whole projected matrix `total` (PSD): entry `(i, j)` within [`CHECK_TOLERANCE`] of
/// `√(Tᵢᵢ Tⱼⱼ)`, the bound of any entry of `T`, plus [`CHECK_FLOOR`] of its largest diagonal.
/// A cluster's entries can be far below its elements' terms (a stiff part moving almost
/// rigidly in the kept modes; on the rigid-body modes they cancel to nothing), so neither its
/// own entries nor `Tᵢᵢ` alone scale the rounding of both sides.
///
/// Rows and columns before `skip` are not compared. Returns the entry where they differ most
/// beyond what is allowed, as `(i, j, difference, allowed)`; `None` when they agree.
fn worst_excess(
    a: &Mat<f64>,
    b: &Mat<f64>,
    total: &Mat<f64>,
    skip: usize,
) -> Option<(usize, usize, f64, f64)> {
    let n = total.nrows();
    let diagonal: Vec<f64> = (0..n).map(|i| total[(i, i)].abs()).collect();
    let floor = CHECK_FLOOR * diagonal.iter().fold(0.0f64, |m, d| m.max(*d));
    let mut worst: Option<(usize, usize, f64, f64)> = None;
    for j in skip..n {
        for i in skip..n {
            let allowed = CHECK_TOLERANCE * (diagonal[i] * diagonal[j]).sqrt() + floor;
            let difference = (a[(i, j)] - b[(i, j)]).abs();
            if difference > allowed
                && worst.is_none_or(|(_, _, d, al)| difference / allowed > d / al)
            {
                worst = Some((i, j, difference, allowed));
            }
        }
    }
    worst
}

fn symmetrised(a: Mat<f64>) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * (a[(i, j)] + a[(j, i)]))
}

/// The elements no parameter reaches, and the clusters of parameters that share elements
/// (connected through common elements), each with its elements, in parameter order.
fn clusters_of(
    model: &Model,
    parameters: &[Parameter],
) -> Result<(Vec<u64>, Vec<Cluster>), UpdatingError> {
    // Union-find over the parameters, joined through the elements they share.
    let mut parent: Vec<usize> = (0..parameters.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut owner: BTreeMap<u64, usize> = BTreeMap::new();
    for (p, parameter) in parameters.iter().enumerate() {
        let ids = model.sets.get(&parameter.set).ok_or_else(|| {
            UpdatingError::Assembly(ModelAssemblyError::Model(ModelError::MissingSet {
                parameter: parameter.name.clone(),
                set: parameter.set.clone(),
                known: model.sets.keys().cloned().collect::<Vec<_>>().join(", "),
            }))
        })?;
        for &id in ids {
            if let Some(&q) = owner.get(&id) {
                let (a, b) = (root(&mut parent, p), root(&mut parent, q));
                parent[a.max(b)] = a.min(b);
            } else {
                owner.insert(id, p);
            }
        }
    }
    let mut by_root: BTreeMap<usize, Cluster> = BTreeMap::new();
    for p in 0..parameters.len() {
        let r = root(&mut parent, p);
        by_root
            .entry(r)
            .or_insert_with(|| Cluster {
                parameters: Vec::new(),
                elements: Vec::new(),
                grid: None,
            })
            .parameters
            .push(p);
    }
    let mut fixed = Vec::new();
    for &id in model.elements.keys() {
        match owner.get(&id) {
            Some(&p) => {
                let r = root(&mut parent, p);
                if let Some(c) = by_root.get_mut(&r) {
                    c.elements.push(id);
                }
            }
            None => fixed.push(id),
        }
    }
    Ok((fixed, by_root.into_values().collect()))
}

/// `Σ_e (T_eΦ)ᵀ K_e (T_eΦ)` and the same with `M_e`, over the elements `ids` of `model`, in
/// chunks of [`CHUNK`] elements in parallel, summed in chunk order (the same on every run).
fn project_elements(
    model: &Model,
    ids: &[u64],
    rows: &Rows,
    basis: MatRef<'_, f64>,
    mass: MassKind,
) -> Result<(Mat<f64>, Mat<f64>), UpdatingError> {
    let m = basis.ncols();
    let parts = ids
        .par_chunks(CHUNK)
        .map(|chunk| project_chunk(model, chunk, rows, basis, mass))
        .collect::<Vec<_>>();
    let (mut k, mut mm) = (Mat::<f64>::zeros(m, m), Mat::<f64>::zeros(m, m));
    for part in parts {
        let (pk, pm) = part?;
        k += &pk;
        mm += &pm;
    }
    Ok((k, mm))
}

/// One chunk of [`project_elements`].
fn project_chunk(
    model: &Model,
    ids: &[u64],
    rows: &Rows,
    basis: MatRef<'_, f64>,
    mass: MassKind,
) -> Result<(Mat<f64>, Mat<f64>), UpdatingError> {
    let m = basis.ncols();
    let mut elements = Vec::with_capacity(ids.len());
    for &id in ids {
        let e = model.elements.get(&id).ok_or_else(|| {
            UpdatingError::Assembly(ModelAssemblyError::Model(ModelError::MissingSetElement {
                set: "parameter".into(),
                element: id,
            }))
        })?;
        let map = row_map(model, e, &rows.index, &rows.dependents);
        if map.iter().all(Vec::is_empty) {
            continue;
        }
        let matrices = named_element_matrices(model, id, e, mass)?;
        elements.push((matrices, map));
    }
    let mut touched: Vec<usize> = elements
        .iter()
        .flat_map(|(_, map)| map.iter().flatten().map(|(i, _)| *i))
        .collect();
    touched.sort_unstable();
    touched.dedup();
    let local = |i: usize| touched.binary_search(&i).unwrap_or(0);
    let (mut yk, mut ym) = (
        Mat::<f64>::zeros(touched.len(), m),
        Mat::<f64>::zeros(touched.len(), m),
    );
    let mut phi_e = Mat::<f64>::zeros(0, m);
    let mut product = Mat::<f64>::zeros(0, m);
    for (matrices, map) in &elements {
        let n = matrices.k.nrows().min(map.len());
        phi_e.resize_with(n, m, |_, _| 0.0);
        product.resize_with(n, m, |_, _| 0.0);
        for (a, targets) in map.iter().take(n).enumerate() {
            for j in 0..m {
                phi_e[(a, j)] = targets.iter().map(|&(i, c)| c * basis[(i, j)]).sum();
            }
        }
        for (element, y) in [(&matrices.k, &mut yk), (&matrices.m, &mut ym)] {
            faer::linalg::matmul::matmul(
                product.as_mut(),
                Accum::Replace,
                element.as_ref().submatrix(0, 0, n, n),
                phi_e.as_ref(),
                1.0,
                Par::Seq,
            );
            scatter(y.as_mut(), product.as_ref(), map, &local);
        }
    }
    let phi_r = Mat::from_fn(touched.len(), m, |r, j| basis[(touched[r], j)]);
    Ok((phi_r.transpose() * &yk, phi_r.transpose() * &ym))
}

/// `y[rows of a] += c · p[a]` for every element row `a` and each of its targets `(i, c)`.
fn scatter(
    mut y: MatMut<'_, f64>,
    p: MatRef<'_, f64>,
    map: &[Vec<(usize, f64)>],
    local: &impl Fn(usize) -> usize,
) {
    for (a, targets) in map.iter().take(p.nrows()).enumerate() {
        for &(i, c) in targets {
            let r = local(i);
            for j in 0..p.ncols() {
                y[(r, j)] += c * p[(a, j)];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::Component;
    use crate::fe::model_assembly::assemble_model;
    use crate::model::MultipointConstraint;
    use crate::model::generate::{BentPlate, ThreeBeam, bent_plate, three_beam};
    use crate::reduction::linalg::project;

    fn parameter(name: &str, kind: ParameterKind, set: &str) -> Parameter {
        Parameter {
            name: name.into(),
            kind,
            set: set.into(),
            lower: 1e-12,
            upper: 1e12,
        }
    }

    /// A basis that is no model's modes: any `Φ` projects alike.
    fn basis(n: usize, m: usize) -> Mat<f64> {
        Mat::from_fn(n, m, |i, j| ((i * 7 + j * 13) as f64 * 0.37).sin() + 0.1)
    }

    /// The projection at each of `moves` (factors on the initial values) against the model
    /// assembled there and projected (`project`, the trial's former path): agreement to 1e-10 of
    /// the largest entry, which is rounding of two summation orders (assembled sparse rows
    /// against element by element). Returns the polynomial and all clusters.
    fn matches_assembly(
        mut model: Model,
        parameters: Vec<Parameter>,
        moves: &[Vec<f64>],
        mass: MassKind,
        modes: Option<usize>,
    ) -> (usize, usize) {
        model.parameters = parameters.clone();
        let values: Vec<f64> = parameters
            .iter()
            .map(|p| model.parameter_value(p).unwrap())
            .collect();
        let (system, _) = assemble_model(&model, mass).unwrap();
        let (phi, rigid) = match modes {
            // Lowest modes: the rigid-body ones and smooth shapes, in which stiff parts of
            // the model nearly cancel.
            Some(count) => {
                let modes = crate::eigen::lowest_modes(
                    &system.k,
                    &system.m,
                    &system.dofs,
                    crate::eigen::ModeSelection::Count(count),
                    &Default::default(),
                )
                .unwrap()
                .0;
                (modes.shapes, modes.rigid_body_modes)
            }
            None => (basis(system.n(), 9), 0),
        };
        let projection = ParametricProjection::new(
            &model,
            &parameters,
            &values,
            phi.as_ref(),
            &system.dofs,
            rigid,
            mass,
        )
        .unwrap();
        for factors in std::iter::once(&vec![1.0; values.len()]).chain(moves) {
            let at: Vec<f64> = values.iter().zip(factors).map(|(v, f)| v * f).collect();
            let (k, m) = projection
                .at(&model, &parameters, &at, phi.as_ref())
                .unwrap();
            let moved = model_with(&model, &parameters, &at).unwrap();
            let (assembled, _) = assemble_model(&moved, mass).unwrap();
            assert_eq!(assembled.dofs, system.dofs);
            for (ours, theirs, what) in [
                (&k, project(&assembled.k, phi.as_ref()), "K"),
                (&m, project(&assembled.m, phi.as_ref()), "M"),
            ] {
                let err = (ours - &theirs).norm_max();
                assert!(
                    err <= 1e-10 * theirs.norm_max(),
                    "{what} at {factors:?}: {err:e} of {:e}",
                    theirs.norm_max()
                );
            }
        }
        projection.polynomial_clusters()
    }

    /// Shell thicknesses on three strips of the clamped bent plate, with a multipoint
    /// constraint and a displacement system in the model: each strip is a cubic cluster, and
    /// the interpolants hold inside their grid (±50 %) and outside it (×2, ×0.3).
    #[test]
    fn shell_thickness_clusters_are_cubic() {
        let mut model = bent_plate(&BentPlate {
            clamped: true,
            with_bar: false,
            ..Default::default()
        });
        // Node 56's uz follows two neighbours; node 57 has a rotated displacement system.
        model.mpcs.push(MultipointConstraint {
            dependent: "56:uz".parse().unwrap(),
            terms: vec![
                ("55:uz".parse().unwrap(), 0.5),
                ("57:uz".parse().unwrap(), 0.5),
            ],
            origin: "MPC 1".into(),
        });
        let (c, s) = (0.6f64.cos(), 0.6f64.sin());
        model
            .displacement_systems
            .insert(57, [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]);
        let parameters: Vec<Parameter> = [1, 4, 9]
            .iter()
            .map(|s| {
                parameter(
                    &format!("t{s}"),
                    ParameterKind::ShellThickness,
                    &format!("strip_{s}"),
                )
            })
            .collect();
        let moves = [
            vec![1.15, 0.7, 1.4],
            vec![2.0, 0.3, 1.0],
            vec![1.0, 1.0, 1.01],
        ];
        for mass in [MassKind::Consistent, MassKind::Lumped] {
            assert_eq!(
                matches_assembly(model.clone(), parameters.clone(), &moves, mass, None),
                (3, 3)
            );
        }
    }

    /// Parameters sharing elements form one cluster on a tensor grid (thickness and `E` of the
    /// first plate's strip: 4 × 2 points), `ρ` of the second plate a linear one, and the bar's
    /// width with its `E` one projected at every trial (a section size is not polynomial).
    #[test]
    fn shared_elements_join_clusters_and_section_sizes_are_direct() {
        let model = bent_plate(&BentPlate::default());
        let parameters = vec![
            parameter("t1", ParameterKind::ShellThickness, "plate_1"),
            parameter("e1", ParameterKind::YoungsModulus, "strip_1"),
            parameter("rho2", ParameterKind::Density, "plate_2"),
            parameter("bar_w", ParameterKind::BeamWidth, "bar"),
            parameter("bar_e", ParameterKind::YoungsModulus, "bar"),
        ];
        let moves = [vec![1.2, 0.8, 1.3, 1.1, 0.9], vec![0.6, 1.7, 0.5, 0.8, 1.2]];
        assert_eq!(
            matches_assembly(model, parameters, &moves, MassKind::Consistent, None),
            (2, 3)
        );
    }

    /// Springs (a clamp's stiffness in one direction), lumped masses and a beam's `E` are
    /// linear; a beam height is projected at every trial.
    #[test]
    fn springs_masses_and_moduli_are_linear() {
        let model = three_beam(&ThreeBeam::default());
        let parameters = vec![
            parameter(
                "k1",
                ParameterKind::SpringStiffness(Component::Uz),
                "clamp_1",
            ),
            parameter("m1", ParameterKind::LumpedMass(Component::Ux), "mass_1"),
            parameter("e1", ParameterKind::YoungsModulus, "beam_1"),
            parameter("h2", ParameterKind::BeamHeight, "beam_2"),
        ];
        let moves = [vec![3.0, 0.4, 1.25, 1.1], vec![0.2, 2.5, 0.7, 0.9]];
        assert_eq!(
            matches_assembly(model, parameters, &moves, MassKind::Consistent, None),
            (3, 4)
        );
    }

    /// On the muffler's lowest 30 modes (six rigid), the thicknesses of its top panel and of
    /// its stiff small tubes are cubic clusters: the tubes move almost rigidly, so their
    /// projected stiffness is far below their elements' terms, and the check measures the
    /// rounding in the scale of the whole projected matrix, not in the tubes' own.
    #[test]
    fn muffler_panels_and_tubes_are_cubic_on_its_modes() {
        use crate::model::generate::scale::{muffler, muffler_element_size};
        let model = muffler(muffler_element_size(3000, 2), 2);
        let parameters = vec![
            parameter("t_top", ParameterKind::ShellThickness, "top"),
            parameter("t_tubes", ParameterKind::ShellThickness, "tubes"),
        ];
        let moves = [vec![0.9, 1.3], vec![1.6, 0.4]];
        assert_eq!(
            matches_assembly(model, parameters, &moves, MassKind::Consistent, Some(30)),
            (2, 2)
        );
    }

    /// A tria3's transverse shear stabilisation `t²/(t² + α h²)` is not polynomial in the
    /// thickness: a strip of the bent plate split into tria3 pairs is projected at every trial,
    /// and its trial matrices still match the assembled model's.
    #[test]
    fn tria3_thickness_is_projected_directly() {
        let mut model = bent_plate(&BentPlate {
            clamped: true,
            with_bar: false,
            ..Default::default()
        });
        for id in model.sets["strip_1"].clone() {
            let Some(Element::Quad4 {
                nodes: [a, b, c, d],
                property,
            }) = model.elements.get(&id).cloned()
            else {
                continue;
            };
            let twin = id + 1_000_000;
            model.elements.insert(
                id,
                Element::Tria3 {
                    nodes: [a, b, c],
                    property,
                },
            );
            model.elements.insert(
                twin,
                Element::Tria3 {
                    nodes: [a, c, d],
                    property,
                },
            );
            for members in model.sets.values_mut() {
                if members.contains(&id) {
                    members.push(twin);
                    members.sort_unstable();
                }
            }
        }
        let parameters = vec![
            parameter("t1", ParameterKind::ShellThickness, "strip_1"),
            parameter("t4", ParameterKind::ShellThickness, "strip_4"),
        ];
        let moves = [vec![1.3, 0.8], vec![0.5, 1.5]];
        assert_eq!(
            matches_assembly(model, parameters, &moves, MassKind::Consistent, Some(12)),
            (1, 2)
        );
    }

    /// The check allows `CHECK_TOLERANCE √(TᵢᵢTⱼⱼ)` plus `CHECK_FLOOR` of the largest diagonal,
    /// names the worst entry, and leaves out the rows and columns it is told to skip (the
    /// rigid-body modes' stiffness, round-off that a 300k-DOF muffler's panels exceeded the
    /// floor with, entry (5, 5), and so lost their interpolants).
    #[test]
    fn the_check_scales_by_the_whole_matrix_and_skips_the_rigid_rows() {
        let total = Mat::from_fn(
            3,
            3,
            |i, j| if i == j { [1e-6, 1e4, 1e6][i] } else { 0.0f64 },
        );
        let a = Mat::<f64>::zeros(3, 3);
        let allowed = |i: usize, j: usize| {
            CHECK_TOLERANCE * (total[(i, i)] * total[(j, j)]).sqrt() + CHECK_FLOOR * 1e6
        };
        // Just inside at (2, 1), just outside at (0, 0) and, further outside, at (1, 2).
        let mut b = Mat::<f64>::zeros(3, 3);
        b[(2, 1)] = 0.99 * allowed(2, 1);
        assert_eq!(worst_excess(&a, &b, &total, 0), None);
        b[(0, 0)] = 1.01 * allowed(0, 0);
        b[(1, 2)] = 2.0 * allowed(1, 2);
        let (i, j, difference, limit) = worst_excess(&a, &b, &total, 0).unwrap();
        assert_eq!((i, j), (1, 2));
        assert!((difference / limit - 2.0).abs() < 1e-12);
        assert_eq!(
            worst_excess(&a, &b, &total, 1).map(|w| (w.0, w.1)),
            Some((1, 2))
        );
        b[(1, 2)] = 0.0;
        assert_eq!(
            worst_excess(&a, &b, &total, 0).map(|w| (w.0, w.1)),
            Some((0, 0))
        );
        assert_eq!(worst_excess(&a, &b, &total, 1), None);
    }

    /// Lagrange weights reproduce a cubic exactly, at and between the nodes and beyond them.
    #[test]
    fn lagrange_weights_reproduce_cubics() {
        let nodes = [0.5, 5.0 / 6.0, 7.0 / 6.0, 1.5];
        let f = |x: f64| 2.0 - x + 0.5 * x * x - 3.0 * x * x * x;
        for x in [0.5, 0.9, 1.0, 2.0, 3.0, -1.0] {
            let w = lagrange_weights(&nodes, x);
            let y: f64 = w.iter().zip(nodes).map(|(w, n)| w * f(n)).sum();
            assert!((y - f(x)).abs() <= 1e-12 * f(x).abs().max(1.0), "{x}: {y}");
        }
        assert_eq!(
            grid_point(&[vec![1.0, 2.0], vec![3.0, 4.0, 5.0]], 4),
            vec![2.0, 4.0]
        );
    }
}
