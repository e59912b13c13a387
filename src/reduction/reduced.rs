//! The reduced model: component reductions, their coupling, synthesis (3.14, 3.51), re-analysis
//! of single substructures, reduced derivatives (3.59) and expansion to physical DOFs.

use super::craig_bampton::{craig_bampton, craig_bampton_on_interface, junction_condensation};
use super::force_coupling::{MasterSelection, couple, force_coupling, second_level};
use super::interface::{interface_basis, interface_basis_from_condensations};
use super::linalg::project;
use super::partition::{Partition, Substructure};
use super::{ReductionError, free_interface::free_interface};
use crate::core::sparse::SparseMatrix;
use crate::core::{Component, DofId};
use crate::eigen::{ModeSelection, Modes, SparseEigenParams, dense_generalized, lowest_modes};
use crate::fe::SystemMatrices;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::{assemble_elements, elements_parameter_derivative};
use crate::model::{Model, Parameter};
use faer::{Mat, MatRef};
use rayon::prelude::*;
use std::collections::{BTreeSet, HashMap};

/// A coordinate of a reduced model (or of one component's local basis).
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Coordinate {
    /// A physical DOF (junction DOF or master DOF).
    Dof(DofId),
    /// Modal coordinate `mode` (from 1) of a substructure's kept component modes.
    Modal {
        /// The substructure.
        substructure: String,
        /// Mode number from 1.
        mode: usize,
    },
    /// The junction force at a DOF (force coupling, local to a component before coupling).
    Force(DofId),
    /// Interface mode `n` (from 1): a mode of the junction's Guyan model, replacing the junction
    /// DOFs after an interface reduction.
    InterfaceMode(usize),
}

impl std::fmt::Display for Coordinate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Coordinate::Dof(d) => write!(f, "{d}"),
            Coordinate::Modal { substructure, mode } => write!(f, "{substructure}:q{mode}"),
            Coordinate::Force(d) => write!(f, "F:{d}"),
            Coordinate::InterfaceMode(n) => write!(f, "interface:m{n}"),
        }
    }
}

impl std::str::FromStr for Coordinate {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if let Some(d) = s.strip_prefix("F:") {
            return d
                .parse::<DofId>()
                .map(Coordinate::Force)
                .map_err(|e| e.to_string());
        }
        if let Some(n) = s.strip_prefix("interface:m").and_then(|n| n.parse().ok()) {
            return Ok(Coordinate::InterfaceMode(n));
        }
        if let Some((sub, q)) = s.rsplit_once(":q")
            && let Ok(mode) = q.parse::<usize>()
        {
            return Ok(Coordinate::Modal {
                substructure: sub.to_string(),
                mode,
            });
        }
        s.parse::<DofId>().map(Coordinate::Dof).map_err(|e| {
            format!("`{s}` is neither a DOF (node:comp), a modal coordinate (<substructure>:q<n>), an interface mode (interface:m<n>) nor a force (F:node:comp): {e}")
        })
    }
}

/// Which method, with its settings.
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// Craig-Bampton: constraint modes + fixed-interface modes (3.5–3.13: (3.5), (3.6), (3.7),
    /// (3.8), (3.9), (3.10), (3.11), (3.12), (3.13)).
    CraigBampton {
        /// Fixed-interface modes kept per substructure.
        modes: ModeSelection,
    },
    /// MacNeal/Rubin free interface with residual flexibility (3.26–3.39: (3.26), (3.27), (3.28),
    /// (3.29), (3.30), (3.31), (3.32), (3.33), (3.34), (3.35), (3.36), (3.37), (3.38), (3.39)).
    FreeInterface {
        /// Free-interface modes kept per substructure.
        modes: ModeSelection,
    },
    /// Free interface with force coupling, Lombard et al. (3.40–3.53: (3.40), (3.41), (3.42),
    /// (3.43), (3.44), (3.45), (3.46), (3.47), (3.48), (3.49), (3.50), (3.51), (3.52), (3.53)).
    ForceCoupling {
        /// Free-interface modes kept per substructure.
        modes: ModeSelection,
        /// How master DOFs are chosen.
        masters: MasterSelection,
        /// Optional second-level condensation.
        second_level: Option<SecondLevel>,
    },
}

impl Method {
    /// Short name: `craig_bampton`, `free_interface`, `force_coupling`.
    pub fn name(&self) -> &'static str {
        match self {
            Method::CraigBampton { .. } => "craig_bampton",
            Method::FreeInterface { .. } => "free_interface",
            Method::ForceCoupling { .. } => "force_coupling",
        }
    }
}

/// Second-level condensation (3.53): keep `keep` of the master DOFs (chosen by Effective
/// Independence on the reduced model's lowest `modes` modes, `required` always kept) and
/// express the others through those modes, `x_m2 = Φ_m2 Φ_m1⁺ x_m1`.
#[derive(Clone, Debug, PartialEq)]
pub struct SecondLevel {
    /// Master DOFs kept.
    pub keep: usize,
    /// Modes of the first-level model used (`keep ≥ modes`).
    pub modes: usize,
    /// DOFs always kept.
    pub required: Vec<DofId>,
}

/// Junction data of a force-coupling component: `x_j = A x_m + B F_j` (3.42, 3.43).
#[derive(Clone, Debug, PartialEq)]
pub struct JunctionFlexibility {
    /// `A = Φ_j Φ_m⁺` (junction × masters).
    pub a: Mat<f64>,
    /// `B = R_jj − Φ_j Φ_m⁺ R_mj` (junction × junction).
    pub b: Mat<f64>,
}

/// One substructure reduced on its own: the local basis `x_k = T_loc q_loc` over its DOFs and
/// the projected matrices.
#[derive(Clone, Debug, PartialEq)]
pub struct ComponentReduction {
    /// The substructure's name.
    pub substructure: String,
    /// Its DOFs (rows of `t`).
    pub dofs: Vec<DofId>,
    /// Its junction DOFs.
    pub junction: Vec<DofId>,
    /// Local basis `T_loc`, `N_k × r_k`.
    pub t: Mat<f64>,
    /// Local coordinates (columns of `t`).
    pub coords: Vec<Coordinate>,
    /// `T_locᵀ K_k T_loc`.
    pub k: Mat<f64>,
    /// `T_locᵀ M_k T_loc`.
    pub m: Mat<f64>,
    /// Natural frequencies of the kept component modes, Hz.
    pub mode_frequencies_hz: Vec<f64>,
    /// Force coupling only: the junction relation.
    pub flexibility: Option<JunctionFlexibility>,
    /// Figures of the reduction.
    pub info: ReductionInfo,
}

/// Figures of one component's reduction.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ReductionInfo {
    /// Rigid-body modes of the free substructure (free-interface methods).
    pub rigid_body_modes: usize,
    /// Master DOFs (force coupling).
    pub masters: usize,
    /// Condition number of `Φ_m` (force coupling).
    pub master_condition: f64,
    /// Seconds spent.
    pub seconds: f64,
}

/// From global reduced coordinates to a component's local coordinates.
#[derive(Clone, Debug, PartialEq)]
pub enum Coupling {
    /// Local coordinate `i` is global coordinate `map[i]` (3.14).
    Boolean(Vec<usize>),
    /// `q_loc = C q` (force coupling, 3.48–3.50: (3.48), (3.49), (3.50)).
    Dense(Mat<f64>),
}

impl Coupling {
    /// `C q` for a block of reduced vectors `q` (`n × p`).
    fn apply(&self, q: MatRef<'_, f64>) -> Mat<f64> {
        match self {
            Coupling::Boolean(map) => Mat::from_fn(map.len(), q.ncols(), |i, j| q[(map[i], j)]),
            Coupling::Dense(c) => c * q,
        }
    }

    /// `Cᵀ A C` accumulated into `out`.
    fn accumulate(&self, a: MatRef<'_, f64>, out: &mut Mat<f64>) {
        match self {
            Coupling::Boolean(map) => {
                for (i, gi) in map.iter().enumerate() {
                    for (j, gj) in map.iter().enumerate() {
                        out[(*gi, *gj)] += a[(i, j)];
                    }
                }
            }
            Coupling::Dense(c) => {
                let p = c.transpose() * (a * c);
                *out += &p;
            }
        }
    }
}

impl ComponentReduction {
    /// A component reduced by `t` (columns: the junction DOFs at rows `j_idx` of `sys`, then the
    /// component modes): `Tᵀ K T`, `Tᵀ M T` and the coordinate labels.
    pub(crate) fn from_transformation(
        name: &str,
        sys: &crate::fe::SystemMatrices,
        junction: &[DofId],
        j_idx: &[usize],
        t: Mat<f64>,
        mode_frequencies_hz: Vec<f64>,
        info: ReductionInfo,
    ) -> ComponentReduction {
        let leading = j_idx
            .iter()
            .map(|&r| Coordinate::Dof(sys.dofs[r]))
            .collect();
        Self::with_leading_coordinates(name, sys, junction, leading, t, mode_frequencies_hz, info)
    }

    /// A component reduced by `t` whose first columns are the coordinates `leading` (junction
    /// DOFs, or interface modes) and the rest its component modes.
    pub(crate) fn with_leading_coordinates(
        name: &str,
        sys: &crate::fe::SystemMatrices,
        junction: &[DofId],
        mut coords: Vec<Coordinate>,
        t: Mat<f64>,
        mode_frequencies_hz: Vec<f64>,
        info: ReductionInfo,
    ) -> ComponentReduction {
        let m = t.ncols() - coords.len();
        coords.extend((1..=m).map(|mode| Coordinate::Modal {
            substructure: name.to_string(),
            mode,
        }));
        ComponentReduction {
            substructure: name.to_string(),
            dofs: sys.dofs.clone(),
            junction: junction.to_vec(),
            k: super::linalg::project(&sys.k, t.as_ref()),
            m: super::linalg::project(&sys.m, t.as_ref()),
            t,
            coords,
            mode_frequencies_hz,
            flexibility: None,
            info,
        }
    }
}

/// The modes of small dense `k`, `m` (a reduced or Ritz-projected model), shifted by
/// `s = 1e-10 max k_ii/m_ii` so that rigid-body modes factor, and unshifted after: eigenvalues
/// within `s/2` of zero are rigid-body modes, more negative ones an error. Dense up to 2,000
/// coordinates, sparse Lanczos above. `labels` only name rows in error messages.
pub fn projected_modes(
    k: &Mat<f64>,
    m: &Mat<f64>,
    labels: &[DofId],
    selection: ModeSelection,
) -> Result<Modes, ReductionError> {
    let n = labels.len();
    let ratio = (0..n)
        .filter(|i| m[(*i, *i)] > 0.0)
        .map(|i| k[(i, i)] / m[(i, i)])
        .fold(0.0f64, f64::max);
    let s = if ratio > 0.0 { 1e-10 * ratio } else { 1e-10 };
    let kp = k + m * faer::Scale(s);
    let selection = match selection {
        ModeSelection::BelowHz(f) => {
            let l = (2.0 * std::f64::consts::PI * f).powi(2) + s;
            ModeSelection::BelowHz(l.sqrt() / (2.0 * std::f64::consts::PI))
        }
        other => other,
    };
    let mut modes = if n <= 2000 {
        dense_generalized(kp.as_ref(), m.as_ref(), labels, selection)
            .map_err(ReductionError::ReducedEigen)?
    } else {
        let sparse = |a: &Mat<f64>| {
            let mut trip = Vec::new();
            for j in 0..a.ncols() {
                for i in 0..a.nrows() {
                    if a[(i, j)] != 0.0 {
                        trip.push((i, j, a[(i, j)]));
                    }
                }
            }
            crate::core::sparse::sparse_from_triplets("reduced", a.nrows(), &trip)
                .map_err(|e| ReductionError::Replace(e.to_string()))
        };
        let (k, m) = (sparse(&kp)?, sparse(m)?);
        lowest_modes(&k, &m, labels, selection, &SparseEigenParams::default())
            .map(|(modes, _)| modes)
            .map_err(ReductionError::ReducedEigen)?
    };
    let largest = modes.eigenvalues.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    for l in modes.eigenvalues.iter_mut() {
        *l -= s;
        if l.abs() <= 0.5 * s {
            *l = 0.0;
        } else if *l < 0.0 {
            return Err(ReductionError::ReducedEigen(
                crate::eigen::EigenError::IndefiniteStiffness { value: *l, largest },
            ));
        }
    }
    modes.rigid_body_modes = modes.eigenvalues.iter().filter(|l| **l == 0.0).count();
    Ok(modes)
}

/// A reduced model: `K_c`, `M_c` over its coordinates, and everything needed to re-analyse one
/// substructure, project derivatives and expand solutions.
#[derive(Clone, Debug, PartialEq)]
pub struct ReducedModel {
    /// The method.
    pub method: Method,
    /// Reduced coordinates.
    pub coords: Vec<Coordinate>,
    /// Components in partition order.
    pub components: Vec<ComponentReduction>,
    /// Coupling of each component.
    pub couplings: Vec<Coupling>,
    /// Junction DOFs of the partition.
    pub junction: Vec<DofId>,
    /// Reduced stiffness.
    pub k: Mat<f64>,
    /// Reduced mass.
    pub m: Mat<f64>,
    /// Interface reduction: the junction DOFs expressed in these interface modes
    /// (`n_J × n_c`), held fixed when a component is replaced.
    pub interface: Option<Mat<f64>>,
}

impl ReducedModel {
    /// Couples components (3.14; 3.46–3.51: (3.46), (3.47), (3.48), (3.49), (3.50), (3.51) for
    /// force coupling) into a reduced model.
    pub fn synthesise(
        method: Method,
        junction: Vec<DofId>,
        components: Vec<ComponentReduction>,
    ) -> Result<ReducedModel, ReductionError> {
        Self::synthesise_with_interface(method, junction, components, None)
    }

    /// [`ReducedModel::synthesise`] with the junction DOFs replaced by interface modes `psi`
    /// (`x_J = Ψ η`; Craig-Bampton and free interface, whose junction DOFs are coordinates).
    pub fn synthesise_with_interface(
        method: Method,
        junction: Vec<DofId>,
        components: Vec<ComponentReduction>,
        interface: Option<Mat<f64>>,
    ) -> Result<ReducedModel, ReductionError> {
        let (coords, couplings) = match (&method, &interface) {
            (Method::CraigBampton { .. } | Method::FreeInterface { .. }, None) => {
                boolean_coupling(&junction, &components)?
            }
            (Method::CraigBampton { .. } | Method::FreeInterface { .. }, Some(psi)) => {
                interface_coupling(&junction, &components, psi.as_ref())?
            }
            (Method::ForceCoupling { .. }, None) => couple(&junction, &components)?,
            (Method::ForceCoupling { .. }, Some(_)) => {
                return Err(ReductionError::Replace(
                    "force coupling has no junction DOFs to reduce: interface modes apply to Craig-Bampton and free interface".into(),
                ));
            }
        };
        let (k, m) = coupled_sum(
            coords.len(),
            components.iter().map(|c| (&c.k, &c.m)).zip(&couplings),
        );
        let mut r = ReducedModel {
            method,
            coords,
            components,
            couplings,
            junction,
            k,
            m,
            interface,
        };
        if let Method::ForceCoupling {
            second_level: Some(sl),
            ..
        } = &r.method
        {
            let sl = sl.clone();
            second_level(&mut r, &sl)?;
        }
        Ok(r)
    }

    /// Replaces one component (re-analysed after a parameter change) and couples again; the
    /// other components are reused as they are.
    pub fn replace(&mut self, component: ComponentReduction) -> Result<(), ReductionError> {
        let Some(at) = self
            .components
            .iter()
            .position(|c| c.substructure == component.substructure)
        else {
            return Err(ReductionError::UnknownSubstructure {
                name: component.substructure.clone(),
                known: self
                    .components
                    .iter()
                    .map(|c| c.substructure.clone())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        };
        if component.dofs != self.components[at].dofs {
            return Err(ReductionError::Replace(format!(
                "substructure `{}`: the replacement has {} DOFs, the reduced model {}; connectivity must not change",
                component.substructure,
                component.dofs.len(),
                self.components[at].dofs.len()
            )));
        }
        let mut components = std::mem::take(&mut self.components);
        components[at] = component;
        *self = ReducedModel::synthesise_with_interface(
            self.method.clone(),
            self.junction.clone(),
            components,
            self.interface.take(),
        )?;
        Ok(())
    }

    /// Interface reduction (characteristic constraint modes, Castanier et al. 2001): the
    /// junction DOFs of a Craig-Bampton or free-interface model are replaced by the lowest modes
    /// of its junction block `(K_JJ, M_JJ)` — for Craig-Bampton the Guyan model of the
    /// interfaces. With `n_J` junction DOFs in the tens of thousands, this is what keeps the
    /// reduced model small; the basis is held when a component is replaced, as the
    /// transformations are (3.59). With every interface mode kept it is a change of basis.
    pub fn with_interface_modes(
        self,
        selection: ModeSelection,
    ) -> Result<ReducedModel, ReductionError> {
        if self.interface.is_some() {
            return Err(ReductionError::Replace(
                "the junction is already expressed in interface modes".into(),
            ));
        }
        let psi = interface_basis(&self.junction, &self.components, selection)?;
        ReducedModel::synthesise_with_interface(self.method, self.junction, self.components, psi)
    }

    /// Number of reduced coordinates.
    pub fn n(&self) -> usize {
        self.coords.len()
    }

    /// Physical (DOF) and modal coordinate counts.
    pub fn size(&self) -> (usize, usize) {
        let phys = self
            .coords
            .iter()
            .filter(|c| matches!(c, Coordinate::Dof(_)))
            .count();
        (phys, self.n() - phys)
    }

    /// Every physical DOF of the model, ascending.
    pub fn dofs(&self) -> Vec<DofId> {
        let s: BTreeSet<DofId> = self
            .components
            .iter()
            .flat_map(|c| c.dofs.iter().copied())
            .collect();
        s.into_iter().collect()
    }

    /// The full transformation `T_k = T_loc C_k` of component `k` (`N_k × n`).
    pub fn transformation(&self, k: usize) -> Mat<f64> {
        let c = &self.components[k];
        match &self.couplings[k] {
            Coupling::Boolean(map) => {
                let mut t = Mat::zeros(c.dofs.len(), self.n());
                for (l, g) in map.iter().enumerate() {
                    for i in 0..c.dofs.len() {
                        t[(i, *g)] += c.t[(i, l)];
                    }
                }
                t
            }
            Coupling::Dense(cm) => &c.t * cm,
        }
    }

    /// `T_kᵀ A T_k` for a matrix `A` over component `k`'s DOFs (e.g. `∂K_k/∂φ`, 3.59).
    pub fn project_component(&self, k: usize, a: &SparseMatrix) -> Mat<f64> {
        let local = project(a, self.components[k].t.as_ref());
        let mut out = Mat::zeros(self.n(), self.n());
        self.couplings[k].accumulate(local.as_ref(), &mut out);
        out
    }

    /// Values of reduced solutions `q` (`n × p`, e.g. reduced mode shapes) at physical DOFs:
    /// `x = T_k q` from the first substructure holding each DOF (all agree at junction DOFs).
    pub fn expand(&self, q: MatRef<'_, f64>, dofs: &[DofId]) -> Result<Mat<f64>, ReductionError> {
        if q.nrows() != self.n() {
            return Err(ReductionError::Shape {
                found: q.nrows(),
                expected: self.n(),
            });
        }
        let mut at: HashMap<DofId, (usize, usize)> = HashMap::new();
        for (k, c) in self.components.iter().enumerate() {
            for (i, d) in c.dofs.iter().enumerate() {
                at.entry(*d).or_insert((k, i));
            }
        }
        let mut by_comp: Vec<Vec<(usize, usize)>> = vec![Vec::new(); self.components.len()];
        for (row, d) in dofs.iter().enumerate() {
            let (k, i) = at
                .get(d)
                .copied()
                .ok_or(ReductionError::UnknownDof { dof: *d })?;
            by_comp[k].push((row, i));
        }
        let mut out = Mat::zeros(dofs.len(), q.ncols());
        for (k, rows) in by_comp.iter().enumerate() {
            if rows.is_empty() {
                continue;
            }
            let local = self.couplings[k].apply(q);
            let t = &self.components[k].t;
            let sub = Mat::from_fn(rows.len(), t.ncols(), |r, j| t[(rows[r].1, j)]);
            let x = &sub * &local;
            for (r, (row, _)) in rows.iter().enumerate() {
                for j in 0..q.ncols() {
                    out[(*row, j)] = x[(r, j)];
                }
            }
        }
        Ok(out)
    }

    /// Modes of the reduced model, mass-normalised in `M_c` (so the expanded shapes are
    /// mass-normalised in the full `M`); dense for up to 2000 coordinates, sparse beyond.
    ///
    /// The rigid-body modes of a free-free reduced model carry the round-off of `TᵀKT` (about
    /// `ε λ_max`, far above the full model's), so the pencil is solved as `(K_c + sM_c, M_c)`
    /// with `s = 10⁻¹⁰ max_i K_ii/M_ii`, and `λ = μ − s`; `|λ| ≤ s/2` is a rigid-body mode.
    pub fn modes(&self, selection: ModeSelection) -> Result<Modes, ReductionError> {
        self.modes_of(&self.k, &self.m, selection)
    }

    /// `K_c`, `M_c` on this model's held bases with the projected matrices of some components
    /// replaced (`(k, T_locᵀ K_k T_loc, T_locᵀ M_k T_loc)`, e.g. from
    /// [`project_on_held_basis`]): the Rayleigh-Ritz re-analysis of a parameter change on the
    /// transformations of the last reduction (3.59 holds them for the derivatives). The
    /// couplings and expansion stay this model's, so [`Self::modes_of`] and [`Self::expand`]
    /// apply. `None` for a second-level force coupling, whose reduced matrices are not the
    /// coupled sum of the components'.
    pub fn held_basis_matrices(
        &self,
        replaced: &[(usize, Mat<f64>, Mat<f64>)],
    ) -> Option<(Mat<f64>, Mat<f64>)> {
        if let Method::ForceCoupling {
            second_level: Some(_),
            ..
        } = &self.method
        {
            return None;
        }
        let parts = self.components.iter().enumerate().map(|(i, c)| {
            match replaced.iter().find(|(at, _, _)| *at == i) {
                Some((_, k, m)) => (k, m),
                None => (&c.k, &c.m),
            }
        });
        Some(coupled_sum(self.n(), parts.zip(&self.couplings)))
    }

    /// [`Self::modes`] of reduced matrices `k`, `m` over this model's coordinates.
    pub fn modes_of(
        &self,
        k: &Mat<f64>,
        m: &Mat<f64>,
        selection: ModeSelection,
    ) -> Result<Modes, ReductionError> {
        // Labels only name DOFs in error messages; modal coordinates (unit modal mass, never
        // massless) carry the placeholder 0:ux.
        let labels: Vec<DofId> = self
            .coords
            .iter()
            .map(|c| match c {
                Coordinate::Dof(d) | Coordinate::Force(d) => *d,
                Coordinate::Modal { .. } | Coordinate::InterfaceMode(_) => {
                    DofId::new(0, Component::Ux)
                }
            })
            .collect();
        projected_modes(k, m, &labels, selection)
    }

    /// Reduced modes expanded to every physical DOF of the model (ascending DOFs).
    pub fn expand_modes(&self, modes: &Modes) -> Result<(Vec<DofId>, Modes), ReductionError> {
        let dofs = self.dofs();
        let shapes = self.expand(modes.shapes.as_ref(), &dofs)?;
        Ok((
            dofs,
            Modes {
                shapes,
                ..modes.clone()
            },
        ))
    }
}

/// `K_c = Σ_k C_kᵀ K_k C_k`, likewise `M_c`, over `n` reduced coordinates from each component's
/// projected matrices and coupling (3.14), symmetrised.
fn coupled_sum<'a>(
    n: usize,
    parts: impl Iterator<Item = ((&'a Mat<f64>, &'a Mat<f64>), &'a Coupling)>,
) -> (Mat<f64>, Mat<f64>) {
    let (mut k, mut m) = (Mat::zeros(n, n), Mat::zeros(n, n));
    for ((ck, cm), cp) in parts {
        cp.accumulate(ck.as_ref(), &mut k);
        cp.accumulate(cm.as_ref(), &mut m);
    }
    (super::linalg::symmetrise(&k), super::linalg::symmetrise(&m))
}

/// Global coordinates of the classical methods: every junction DOF, then each component's
/// modal coordinates in partition order (3.14).
fn boolean_coupling(
    junction: &[DofId],
    components: &[ComponentReduction],
) -> Result<(Vec<Coordinate>, Vec<Coupling>), ReductionError> {
    let index: HashMap<DofId, usize> = junction.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let mut coords: Vec<Coordinate> = junction.iter().map(|d| Coordinate::Dof(*d)).collect();
    let mut couplings = Vec::with_capacity(components.len());
    for c in components {
        let mut map = Vec::with_capacity(c.coords.len());
        for coord in &c.coords {
            match coord {
                Coordinate::Dof(d) => map.push(*index.get(d).ok_or_else(|| {
                    ReductionError::Replace(format!(
                        "substructure `{}`: coordinate {d} is not a junction DOF of the partition",
                        c.substructure
                    ))
                })?),
                _ => {
                    map.push(coords.len());
                    coords.push(coord.clone());
                }
            }
        }
        couplings.push(Coupling::Boolean(map));
    }
    Ok((coords, couplings))
}

/// Global coordinates after an interface reduction: the interface modes, then each component's
/// modal coordinates. A component whose leading coordinates are junction DOFs couples densely
/// (`x_J = Ψ η`, its rows of `Ψ`); one reduced on the interface modes already
/// ([`craig_bampton_on_interface`]) couples by position.
fn interface_coupling(
    junction: &[DofId],
    components: &[ComponentReduction],
    psi: MatRef<'_, f64>,
) -> Result<(Vec<Coordinate>, Vec<Coupling>), ReductionError> {
    let (nj, nc) = (junction.len(), psi.ncols());
    if psi.nrows() != nj {
        return Err(ReductionError::Replace(format!(
            "the interface basis has {} rows for {nj} junction DOFs",
            psi.nrows()
        )));
    }
    let index: HashMap<DofId, usize> = junction.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let mut coords: Vec<Coordinate> = (1..=nc).map(Coordinate::InterfaceMode).collect();
    // Per local coordinate: `Ok(global coordinate)` or `Err(junction row of Ψ)`.
    let mut maps: Vec<Vec<Result<usize, usize>>> = Vec::with_capacity(components.len());
    for c in components {
        let mut map = Vec::with_capacity(c.coords.len());
        for coord in &c.coords {
            map.push(match coord {
                Coordinate::Dof(d) => Err(*index.get(d).ok_or_else(|| {
                    ReductionError::Replace(format!(
                        "substructure `{}`: coordinate {d} is not a junction DOF of the partition",
                        c.substructure
                    ))
                })?),
                Coordinate::InterfaceMode(q) if (1..=nc).contains(q) => Ok(q - 1),
                Coordinate::InterfaceMode(q) => {
                    return Err(ReductionError::Replace(format!(
                        "substructure `{}`: it was reduced on interface mode {q}, but the interface basis holds {nc}",
                        c.substructure
                    )));
                }
                _ => {
                    coords.push(coord.clone());
                    Ok(coords.len() - 1)
                }
            });
        }
        maps.push(map);
    }
    let n = coords.len();
    let couplings = maps
        .into_iter()
        .map(|map| {
            if map.iter().all(|e| e.is_ok()) {
                return Coupling::Boolean(map.into_iter().flatten().collect());
            }
            let mut c = Mat::zeros(map.len(), n);
            for (l, e) in map.iter().enumerate() {
                match *e {
                    Ok(g) => c[(l, g)] = 1.0,
                    Err(row) => {
                        for q in 0..nc {
                            c[(l, q)] = psi[(row, q)];
                        }
                    }
                }
            }
            Coupling::Dense(c)
        })
        .collect();
    Ok((coords, couplings))
}

/// `K`, `M` of one substructure from its elements alone, over exactly its partition DOFs.
pub fn substructure_matrices(
    model: &Model,
    sub: &Substructure,
    mass: MassKind,
) -> Result<SystemMatrices, ReductionError> {
    let (sys, _) = assemble_elements(model, &sub.elements, mass).map_err(|source| {
        ReductionError::Assembly {
            substructure: sub.name.clone(),
            source,
        }
    })?;
    if sys.dofs == sub.dofs {
        return Ok(sys);
    }
    // The assembly drops only DOFs without stiffness and mass; the partition's DOFs must be
    // exactly these (the partition was made for another model otherwise).
    Err(ReductionError::DofMismatch {
        substructure: sub.name.clone(),
        expected: sub.dofs.len(),
        found: sys.dofs.len(),
    })
}

/// Substructure `k`'s matrices from `model` projected on the basis `held` holds:
/// `(T_locᵀ K_k T_loc, T_locᵀ M_k T_loc)` for [`ReducedModel::held_basis_matrices`]. Only the
/// assembly and two products: no eigenproblem and no factorisation, the reduction's costs.
pub fn project_on_held_basis(
    model: &Model,
    partition: &Partition,
    k: usize,
    mass: MassKind,
    held: &ComponentReduction,
) -> Result<(Mat<f64>, Mat<f64>), ReductionError> {
    let sub = &partition.substructures[k];
    let sys = substructure_matrices(model, sub, mass)?;
    if sys.dofs != held.dofs {
        return Err(ReductionError::Replace(format!(
            "substructure `{}`: {} DOFs assembled, its held basis has {}; connectivity must not change",
            sub.name,
            sys.dofs.len(),
            held.dofs.len()
        )));
    }
    Ok((
        project(&sys.k, held.t.as_ref()),
        project(&sys.m, held.t.as_ref()),
    ))
}

/// Eigen settings for component modes: all modes use the dense path whatever the size.
fn eigen_params(selection: ModeSelection) -> SparseEigenParams {
    SparseEigenParams {
        dense_limit: if matches!(selection, ModeSelection::All) {
            usize::MAX
        } else {
            SparseEigenParams::default().dense_limit
        },
        ..Default::default()
    }
}

/// Reduces substructure `k` of `partition` by `method` (the expensive, independent part).
pub fn reduce_substructure(
    model: &Model,
    partition: &Partition,
    k: usize,
    method: &Method,
    mass: MassKind,
) -> Result<ComponentReduction, ReductionError> {
    let t0 = std::time::Instant::now();
    let sub = &partition.substructures[k];
    let sys = substructure_matrices(model, sub, mass)?;
    let mut c = reduce_assembled(sub, &sys, method)?;
    c.info.seconds = t0.elapsed().as_secs_f64();
    Ok(c)
}

/// Reduces substructure `k` with its junction moving in the interface modes `psi` (`n_J × n_c`
/// over the partition's junction): Craig-Bampton by [`craig_bampton_on_interface`]; the other
/// methods as [`reduce_substructure`], coupled to `psi` at synthesis.
pub fn reduce_substructure_on_interface(
    model: &Model,
    partition: &Partition,
    k: usize,
    method: &Method,
    mass: MassKind,
    psi: MatRef<'_, f64>,
) -> Result<ComponentReduction, ReductionError> {
    let t0 = std::time::Instant::now();
    let sub = &partition.substructures[k];
    let sys = substructure_matrices(model, sub, mass)?;
    let rows = interface_rows(&partition.junction, &sub.junction, psi)?;
    let mut c = reduce_assembled_on_interface(sub, &sys, method, rows.as_ref())?;
    c.info.seconds = t0.elapsed().as_secs_f64();
    Ok(c)
}

/// The rows of the interface basis `psi` (over `junction`, the partition's) at a substructure's
/// junction DOFs, in its order.
pub fn interface_rows(
    junction: &[DofId],
    substructure_junction: &[DofId],
    psi: MatRef<'_, f64>,
) -> Result<Mat<f64>, ReductionError> {
    let rows = super::interface::junction_positions(junction, substructure_junction)?;
    Ok(Mat::from_fn(rows.len(), psi.ncols(), |i, j| {
        psi[(rows[i], j)]
    }))
}

/// [`reduce_assembled`] with the junction moving in the interface modes `rows` (the
/// substructure's rows of the basis, from [`interface_rows`]); only Craig-Bampton uses them
/// here, the other methods couple to the basis at synthesis.
pub fn reduce_assembled_on_interface(
    sub: &Substructure,
    sys: &SystemMatrices,
    method: &Method,
    rows: MatRef<'_, f64>,
) -> Result<ComponentReduction, ReductionError> {
    let Method::CraigBampton { modes } = method else {
        return reduce_assembled(sub, sys, method);
    };
    let t0 = std::time::Instant::now();
    let mut c = craig_bampton_on_interface(
        &sub.name,
        sys,
        &sub.junction,
        rows,
        *modes,
        &eigen_params(*modes),
    )?;
    c.info.seconds = t0.elapsed().as_secs_f64();
    Ok(c)
}

/// Reduces one substructure from its assembled matrices `sys` (from [`substructure_matrices`]):
/// the component depends on nothing else, which is what lets a caller cache it by the content
/// of `sys`, the junction and the method.
pub fn reduce_assembled(
    sub: &Substructure,
    sys: &SystemMatrices,
    method: &Method,
) -> Result<ComponentReduction, ReductionError> {
    let t0 = std::time::Instant::now();
    let mut c = match method {
        Method::CraigBampton { modes } => {
            craig_bampton(&sub.name, sys, &sub.junction, *modes, &eigen_params(*modes))
        }
        Method::FreeInterface { modes } => {
            free_interface(&sub.name, sys, &sub.junction, *modes, &eigen_params(*modes))
        }
        Method::ForceCoupling { modes, masters, .. } => force_coupling(
            &sub.name,
            sys,
            &sub.junction,
            &sub.internal,
            *modes,
            masters,
            &eigen_params(*modes),
        ),
    }?;
    c.info.seconds = t0.elapsed().as_secs_f64();
    Ok(c)
}

/// Checks that the DOFs a method names (force coupling's masters) are DOFs of the partition.
pub fn check_method(partition: &Partition, method: &Method) -> Result<(), ReductionError> {
    if let Method::ForceCoupling { masters, .. } = method {
        let all: BTreeSet<DofId> = partition.dofs().into_iter().collect();
        for d in masters
            .required
            .iter()
            .chain(masters.candidates.iter().flatten())
        {
            if !all.contains(d) {
                return Err(ReductionError::UnknownDof { dof: *d });
            }
        }
    }
    Ok(())
}

/// Progress of the substructures' reductions, advanced as each one ends.
pub fn substructures_task(partition: &Partition) -> crate::core::progress::Task {
    let n = partition.substructures.len();
    crate::core::progress::task(|| "substructures reduced (CMS)".into(), n as u64)
}

/// Reduces every substructure in parallel (results in partition order: deterministic) and
/// synthesises the reduced model.
pub fn reduce(
    model: &Model,
    partition: &Partition,
    method: &Method,
    mass: MassKind,
) -> Result<ReducedModel, ReductionError> {
    reduce_with_interface(model, partition, method, mass, None)
}

/// [`reduce`], with the junction expressed in the interface modes of `interface` when given
/// (the plain reduced matrices, `n_J²` each, are never formed).
pub fn reduce_with_interface(
    model: &Model,
    partition: &Partition,
    method: &Method,
    mass: MassKind,
    interface: Option<ModeSelection>,
) -> Result<ReducedModel, ReductionError> {
    check_method(partition, method)?;
    if let (Method::CraigBampton { .. }, Some(selection)) = (method, interface) {
        // Junction condensations first, then constraint modes for the interface modes only:
        // no component ever holds a junction-sized basis.
        let condensations = partition
            .substructures
            .par_iter()
            .map(|sub| {
                let sys = substructure_matrices(model, sub, mass)?;
                junction_condensation(&sub.name, &sys, &sub.junction)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let psi =
            interface_basis_from_condensations(&partition.junction, condensations, selection)?;
        if let Some(psi) = psi {
            let done = substructures_task(partition);
            let components = (0..partition.substructures.len())
                .into_par_iter()
                .map(|k| {
                    let c = reduce_substructure_on_interface(
                        model,
                        partition,
                        k,
                        method,
                        mass,
                        psi.as_ref(),
                    );
                    done.advance(1);
                    c
                })
                .collect::<Result<Vec<_>, _>>()?;
            return ReducedModel::synthesise_with_interface(
                method.clone(),
                partition.junction.clone(),
                components,
                Some(psi),
            );
        }
    }
    let done = substructures_task(partition);
    let components = (0..partition.substructures.len())
        .into_par_iter()
        .map(|k| {
            let c = reduce_substructure(model, partition, k, method, mass);
            done.advance(1);
            c
        })
        .collect::<Result<Vec<_>, _>>()?;
    let psi = match interface {
        Some(selection) => interface_basis(&partition.junction, &components, selection)?,
        None => None,
    };
    ReducedModel::synthesise_with_interface(
        method.clone(),
        partition.junction.clone(),
        components,
        psi,
    )
}

/// A pair of matrices (`∂K`, `∂M`).
type MatPair = (Mat<f64>, Mat<f64>);

/// Reduced `∂K_c/∂φ`, `∂M_c/∂φ` of an updating parameter: `Σ_k T_kᵀ (∂K_k/∂φ) T_k` over the
/// substructures holding elements of its set, the transformations held fixed (3.59).
pub fn reduced_parameter_derivative(
    model: &Model,
    partition: &Partition,
    reduced: &ReducedModel,
    parameter: &Parameter,
    mass: MassKind,
) -> Result<(Mat<f64>, Mat<f64>), ReductionError> {
    let set: BTreeSet<u64> = model
        .sets
        .get(&parameter.set)
        .ok_or_else(|| ReductionError::UnknownSet {
            set: parameter.set.clone(),
            known: model.sets.keys().cloned().collect::<Vec<_>>().join(", "),
        })?
        .iter()
        .copied()
        .collect();
    let n = reduced.n();
    let parts: Vec<Result<Option<MatPair>, ReductionError>> = partition
        .substructures
        .par_iter()
        .enumerate()
        .map(|(k, sub)| {
            let ids: Vec<u64> = sub
                .elements
                .iter()
                .copied()
                .filter(|e| set.contains(e))
                .collect();
            if ids.is_empty() {
                return Ok(None);
            }
            let (dk, dm) = elements_parameter_derivative(model, parameter, &ids, &sub.dofs, mass)
                .map_err(|source| ReductionError::Assembly {
                substructure: sub.name.clone(),
                source,
            })?;
            Ok(Some((
                reduced.project_component(k, &dk),
                reduced.project_component(k, &dm),
            )))
        })
        .collect();
    let (mut dk, mut dm) = (Mat::zeros(n, n), Mat::zeros(n, n));
    for p in parts {
        if let Some((a, b)) = p? {
            dk += &a;
            dm += &b;
        }
    }
    Ok((dk, dm))
}
