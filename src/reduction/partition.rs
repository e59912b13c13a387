//! Substructures of a model (docs/theory.md §9, thesis §3.3, fig. 3.1): groups of elements, the
//! DOFs each group holds, junction DOFs `j` shared by two or more substructures, internal DOFs `i`
//! (the rest), and the boundaries — the sets of junction DOFs shared by the same substructures.
//!
//! Groups come from named element sets, from property ids, or from an automatic `k`-way
//! partition of the element connectivity for large models. The automatic partition is
//! **recursive coordinate bisection** of the element centroids (split the part along its longest
//! extent at the weighted median, `k` split as `⌊k/2⌋ : ⌈k/2⌉` in proportion), followed by a
//! **greedy boundary refinement**: elements whose node-sharing neighbours mostly lie in another
//! part move there when that keeps both parts within the balance tolerance, a few sweeps in
//! element-id order (deterministic). Coordinate bisection gives compact, balanced parts with
//! small planar cuts on shell and solid meshes; the refinement removes the jagged single
//! elements the median cut leaves on curved or bent surfaces.
//!
//! A DOF belongs to a substructure when one of its elements gives it stiffness or mass (the
//! same rule by which the full assembly keeps a DOF free), and it is not constrained.

use super::ReductionError;
use crate::core::DofId;
use crate::fe::element::MassKind;
use crate::fe::model_assembly::element_dofs;
use crate::model::Model;
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// One substructure.
#[derive(Clone, Debug, PartialEq)]
pub struct Substructure {
    /// Name (the set name, `pid<N>`, or `part_<n>`).
    pub name: String,
    /// Its element ids, ascending.
    pub elements: Vec<u64>,
    /// Its DOFs, ascending (node, component): the rows of its matrices.
    pub dofs: Vec<DofId>,
    /// Its junction DOFs (shared with another substructure), ascending.
    pub junction: Vec<DofId>,
    /// Its internal DOFs, ascending.
    pub internal: Vec<DofId>,
}

/// Junction DOFs shared by the same set of substructures (thesis fig. 3.1: a boundary `l`).
#[derive(Clone, Debug, PartialEq)]
pub struct Boundary {
    /// Indices of the substructures sharing it, ascending.
    pub substructures: Vec<usize>,
    /// Its DOFs, ascending.
    pub dofs: Vec<DofId>,
}

/// A model split into substructures.
#[derive(Clone, Debug, PartialEq)]
pub struct Partition {
    /// The substructures.
    pub substructures: Vec<Substructure>,
    /// Every junction DOF, ascending.
    pub junction: Vec<DofId>,
    /// The boundaries.
    pub boundaries: Vec<Boundary>,
}

impl Partition {
    /// Index of a substructure by name.
    pub fn index_of(&self, name: &str) -> Result<usize, ReductionError> {
        self.substructures
            .iter()
            .position(|s| s.name == name)
            .ok_or_else(|| ReductionError::UnknownSubstructure {
                name: name.to_string(),
                known: self.names().join(", "),
            })
    }

    /// Substructure names in order.
    pub fn names(&self) -> Vec<String> {
        self.substructures.iter().map(|s| s.name.clone()).collect()
    }

    /// Every physical DOF of the partitioned model, ascending (the full model's free DOFs).
    pub fn dofs(&self) -> Vec<DofId> {
        let set: BTreeSet<DofId> = self
            .substructures
            .iter()
            .flat_map(|s| s.dofs.iter().copied())
            .collect();
        set.into_iter().collect()
    }

    /// Indices of the substructures holding elements of `elements` (e.g. a parameter's set).
    pub fn substructures_of(&self, elements: &[u64]) -> Vec<usize> {
        let set: BTreeSet<u64> = elements.iter().copied().collect();
        self.substructures
            .iter()
            .enumerate()
            .filter(|(_, s)| s.elements.iter().any(|e| set.contains(e)))
            .map(|(i, _)| i)
            .collect()
    }

    /// Builds the partition of `model` from named element groups (each element in exactly one
    /// group; every element of the model in some group).
    pub fn from_groups(
        model: &Model,
        groups: Vec<(String, Vec<u64>)>,
        mass: MassKind,
    ) -> Result<Partition, ReductionError> {
        model.validate()?;
        if groups.is_empty() {
            return Err(ReductionError::NoSubstructures);
        }
        let mut owner: HashMap<u64, usize> = HashMap::new();
        for (g, (name, ids)) in groups.iter().enumerate() {
            if ids.is_empty() {
                return Err(ReductionError::EmptySubstructure { name: name.clone() });
            }
            if groups[..g].iter().any(|(n, _)| n == name) {
                return Err(ReductionError::DuplicateName { name: name.clone() });
            }
            for id in ids {
                if !model.elements.contains_key(id) {
                    return Err(ReductionError::UnknownElement {
                        substructure: name.clone(),
                        element: *id,
                    });
                }
                if let Some(prev) = owner.insert(*id, g)
                    && prev != g
                {
                    return Err(ReductionError::Overlap {
                        element: *id,
                        first: groups[prev].0.clone(),
                        second: name.clone(),
                    });
                }
            }
        }
        if let Some(id) = model.elements.keys().find(|id| !owner.contains_key(id)) {
            return Err(ReductionError::Unassigned {
                element: *id,
                count: model.elements.len() - owner.len(),
            });
        }
        let constrained: BTreeSet<DofId> = model.constraints.iter().copied().collect();
        let per_group: Vec<Result<Group, ReductionError>> = groups
            .into_par_iter()
            .map(|(name, mut ids)| {
                ids.sort_unstable();
                ids.dedup();
                let mut dofs = BTreeSet::new();
                for id in &ids {
                    let e = &model.elements[id];
                    let d = element_dofs(model, *id, e, mass).map_err(|source| {
                        ReductionError::Assembly {
                            substructure: String::new(),
                            source,
                        }
                    })?;
                    dofs.extend(d.into_iter().filter(|d| !constrained.contains(d)));
                }
                Ok((name, ids, dofs.into_iter().collect()))
            })
            .collect();
        let mut subs = Vec::with_capacity(per_group.len());
        for r in per_group {
            subs.push(r?);
        }
        // Which substructures hold each DOF.
        let mut holders: BTreeMap<DofId, Vec<usize>> = BTreeMap::new();
        for (k, (_, _, dofs)) in subs.iter().enumerate() {
            for d in dofs {
                holders.entry(*d).or_default().push(k);
            }
        }
        let junction: Vec<DofId> = holders
            .iter()
            .filter(|(_, h)| h.len() >= 2)
            .map(|(d, _)| *d)
            .collect();
        let mut by_set: BTreeMap<Vec<usize>, Vec<DofId>> = BTreeMap::new();
        for (d, h) in &holders {
            if h.len() >= 2 {
                by_set.entry(h.clone()).or_default().push(*d);
            }
        }
        let boundaries = by_set
            .into_iter()
            .map(|(substructures, dofs)| Boundary {
                substructures,
                dofs,
            })
            .collect();
        let substructures = subs
            .into_iter()
            .map(|(name, elements, dofs)| {
                let (junction, internal): (Vec<DofId>, Vec<DofId>) =
                    dofs.iter().partition(|d| holders[*d].len() >= 2);
                Substructure {
                    name,
                    elements,
                    dofs,
                    junction,
                    internal,
                }
            })
            .collect();
        Ok(Partition {
            substructures,
            junction,
            boundaries,
        })
    }

    /// One substructure per named element set of the model.
    pub fn from_sets(
        model: &Model,
        sets: &[String],
        mass: MassKind,
    ) -> Result<Partition, ReductionError> {
        let groups: Vec<Vec<String>> = sets.iter().map(|s| vec![s.clone()]).collect();
        Self::from_set_unions(model, &groups, mass)
    }

    /// One substructure per union of named element sets (named by its sets joined with `+`).
    pub fn from_set_unions(
        model: &Model,
        unions: &[Vec<String>],
        mass: MassKind,
    ) -> Result<Partition, ReductionError> {
        let mut groups = Vec::with_capacity(unions.len());
        for union in unions {
            let mut ids = Vec::new();
            for s in union {
                let set = model
                    .sets
                    .get(s)
                    .ok_or_else(|| ReductionError::UnknownSet {
                        set: s.clone(),
                        known: model.sets.keys().cloned().collect::<Vec<_>>().join(", "),
                    })?;
                ids.extend_from_slice(set);
            }
            groups.push((union.join("+"), ids));
        }
        Self::from_groups(model, groups, mass)
    }

    /// One substructure per property id (`pid<N>`); elements without a property (springs,
    /// masses) join the substructure of the lowest property id among the elements sharing
    /// a node with them, or the first substructure.
    pub fn from_properties(model: &Model, mass: MassKind) -> Result<Partition, ReductionError> {
        let mut groups: BTreeMap<u64, Vec<u64>> = BTreeMap::new();
        let mut node_pid: HashMap<u64, u64> = HashMap::new();
        for (&id, e) in &model.elements {
            if let Some(p) = e.property() {
                groups.entry(p).or_default().push(id);
                for n in e.nodes() {
                    let slot = node_pid.entry(n).or_insert(p);
                    *slot = (*slot).min(p);
                }
            }
        }
        let Some(&first) = groups.keys().next() else {
            return Err(ReductionError::NoSubstructures);
        };
        for (&id, e) in &model.elements {
            if e.property().is_none() {
                let p = e
                    .nodes()
                    .iter()
                    .filter_map(|n| node_pid.get(n).copied())
                    .min()
                    .unwrap_or(first);
                groups.entry(p).or_default().push(id);
            }
        }
        Self::from_groups(
            model,
            groups
                .into_iter()
                .map(|(p, ids)| (format!("pid{p}"), ids))
                .collect(),
            mass,
        )
    }

    /// Automatic `k`-way partition (recursive coordinate bisection + greedy boundary
    /// refinement, see the module documentation); parts are named `part_1 … part_k`.
    pub fn automatic(
        model: &Model,
        parts: usize,
        mass: MassKind,
    ) -> Result<Partition, ReductionError> {
        let groups = automatic_groups(model, parts)?;
        Self::from_groups(model, groups, mass)
    }

    /// Junction node count (a size measure of the interfaces).
    pub fn junction_nodes(&self) -> usize {
        self.junction
            .iter()
            .map(|d| d.node)
            .collect::<BTreeSet<_>>()
            .len()
    }
}

/// A named group of elements with its DOFs.
type Group = (String, Vec<u64>, Vec<DofId>);

/// Balance tolerance of the refinement: no part grows above `(1 + tol)` or shrinks below
/// `(1 − tol)` times its target size.
const BALANCE_TOLERANCE: f64 = 0.05;

/// The element groups of the automatic partition.
pub fn automatic_groups(
    model: &Model,
    parts: usize,
) -> Result<Vec<(String, Vec<u64>)>, ReductionError> {
    model.validate()?;
    let n = model.elements.len();
    if parts == 0 || parts > n {
        return Err(ReductionError::PartCount { parts, elements: n });
    }
    let ids: Vec<u64> = model.elements.keys().copied().collect();
    let centroids: Vec<[f64; 3]> = model
        .elements
        .values()
        .map(|e| {
            // Scalar points have no position: the centroid of the element's grids (the origin
            // for an element on scalar points only).
            let xs: Vec<[f64; 3]> = e
                .nodes()
                .iter()
                .filter_map(|nd| model.nodes.get(nd).copied())
                .collect();
            let mut c = [0.0; 3];
            for x in &xs {
                for a in 0..3 {
                    c[a] += x[a] / xs.len() as f64;
                }
            }
            c
        })
        .collect();
    let mut part = vec![0usize; n];
    let all: Vec<usize> = (0..n).collect();
    bisect(&centroids, all, 0, parts, &mut part);
    refine(model, &ids, parts, &mut part);
    let mut groups: Vec<Vec<u64>> = vec![Vec::new(); parts];
    for (e, p) in part.iter().enumerate() {
        groups[*p].push(ids[e]);
    }
    Ok(groups
        .into_iter()
        .enumerate()
        .map(|(p, g)| (format!("part_{}", p + 1), g))
        .collect())
}

/// Assigns parts `first .. first + parts` to `elems` by recursive coordinate bisection.
fn bisect(c: &[[f64; 3]], mut elems: Vec<usize>, first: usize, parts: usize, out: &mut [usize]) {
    if parts <= 1 || elems.len() <= 1 {
        for e in elems {
            out[e] = first;
        }
        return;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for &e in &elems {
        for a in 0..3 {
            lo[a] = lo[a].min(c[e][a]);
            hi[a] = hi[a].max(c[e][a]);
        }
    }
    let axis = (0..3)
        .max_by(|a, b| (hi[*a] - lo[*a]).total_cmp(&(hi[*b] - lo[*b])))
        .unwrap_or(0);
    // Ties broken by element index: deterministic.
    elems.sort_by(|a, b| c[*a][axis].total_cmp(&c[*b][axis]).then(a.cmp(b)));
    let left_parts = parts / 2;
    let split = (elems.len() * left_parts + parts / 2) / parts;
    let split = split.clamp(left_parts.min(elems.len()), elems.len() - 1);
    let right = elems.split_off(split);
    bisect(c, elems, first, left_parts, out);
    bisect(c, right, first + left_parts, parts - left_parts, out);
}

/// Greedy boundary refinement (see the module documentation).
fn refine(model: &Model, ids: &[u64], parts: usize, part: &mut [usize]) {
    let n = ids.len();
    let index: HashMap<u64, usize> = ids.iter().enumerate().map(|(i, id)| (*id, i)).collect();
    let mut node_elems: HashMap<u64, Vec<usize>> = HashMap::new();
    for (id, e) in &model.elements {
        for nd in e.nodes() {
            node_elems.entry(nd).or_default().push(index[id]);
        }
    }
    let neighbours: Vec<Vec<usize>> = ids
        .iter()
        .enumerate()
        .map(|(i, id)| {
            let mut v: Vec<usize> = model.elements[id]
                .nodes()
                .iter()
                .flat_map(|nd| node_elems[nd].iter().copied())
                .filter(|j| *j != i)
                .collect();
            v.sort_unstable();
            v.dedup();
            v
        })
        .collect();
    let target = n as f64 / parts as f64;
    let (max_size, min_size) = (
        ((1.0 + BALANCE_TOLERANCE) * target).floor().max(1.0) as usize,
        ((1.0 - BALANCE_TOLERANCE) * target).ceil().max(1.0) as usize,
    );
    let mut size = vec![0usize; parts];
    for p in part.iter() {
        size[*p] += 1;
    }
    for _sweep in 0..4 {
        let mut moved = 0;
        for e in 0..n {
            let own = part[e];
            let mut count: BTreeMap<usize, usize> = BTreeMap::new();
            for &j in &neighbours[e] {
                *count.entry(part[j]).or_default() += 1;
            }
            let own_count = count.get(&own).copied().unwrap_or(0);
            let best = count
                .iter()
                .filter(|(p, _)| **p != own)
                .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)));
            if let Some((&p, &c)) = best
                && c > own_count
                && size[p] < max_size
                && size[own] > min_size
            {
                part[e] = p;
                size[p] += 1;
                size[own] -= 1;
                moved += 1;
            }
        }
        if moved == 0 {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::generate::{BentPlate, bent_plate};

    /// The C3 two-plate model split by its sets: the junction is the bend line (8 nodes), every
    /// DOF is internal to one plate or shared by both, and the union is the full model's DOFs.
    #[test]
    fn two_plates_share_the_bend_line() {
        let model = bent_plate(&BentPlate {
            with_bar: false,
            ..Default::default()
        });
        let p = Partition::from_sets(
            &model,
            &["plate_1".into(), "plate_2".into()],
            MassKind::Consistent,
        )
        .unwrap();
        assert_eq!(p.substructures.len(), 2);
        assert_eq!(p.junction_nodes(), 8);
        assert_eq!(p.boundaries.len(), 1);
        let (sys, _) =
            crate::fe::model_assembly::assemble_model(&model, MassKind::Consistent).unwrap();
        assert_eq!(p.dofs(), sys.dofs);
        for s in &p.substructures {
            assert_eq!(s.junction.len() + s.internal.len(), s.dofs.len());
        }
        assert_eq!(p.junction.len(), 48);
    }

    #[test]
    fn bad_groups_are_named() {
        let model = bent_plate(&BentPlate::default());
        let e = Partition::from_sets(&model, &["plate_1".into()], MassKind::Consistent)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not in any substructure"), "{e}");
        let e = Partition::from_sets(&model, &["plate_9".into()], MassKind::Consistent)
            .unwrap_err()
            .to_string();
        assert!(e.contains("plate_9") && e.contains("plate_1"), "{e}");
        let e = Partition::from_groups(
            &model,
            vec![
                ("a".into(), model.sets["strip_1"].clone()),
                ("b".into(), model.sets["plate_1"].clone()),
            ],
            MassKind::Consistent,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("`a`") && e.contains("`b`"), "{e}");
        let e = Partition::automatic(&model, 0, MassKind::Consistent)
            .unwrap_err()
            .to_string();
        assert!(e.contains("between 1 and 123"), "{e}");
    }

    /// Automatic partition of a refined bent plate: balanced within the tolerance, and the
    /// refinement never enlarges the interface of the plain bisection.
    #[test]
    fn automatic_partition_is_balanced_with_small_interfaces() {
        let model = bent_plate(&BentPlate {
            refine: 2,
            ..Default::default()
        });
        for k in [2, 3, 4, 8] {
            let p = Partition::automatic(&model, k, MassKind::Consistent).unwrap();
            let n = model.elements.len() as f64;
            for s in &p.substructures {
                let r = s.elements.len() as f64 / (n / k as f64);
                assert!((0.9..=1.1).contains(&r), "k={k}: {} has ratio {r}", s.name);
            }
            // Unrefined bisection for comparison.
            let ids: Vec<u64> = model.elements.keys().copied().collect();
            let c: Vec<[f64; 3]> = model
                .elements
                .values()
                .map(|e| {
                    let ns = e.nodes();
                    let mut c = [0.0; 3];
                    for nd in &ns {
                        for (ca, xa) in c.iter_mut().zip(model.nodes[nd]) {
                            *ca += xa / ns.len() as f64;
                        }
                    }
                    c
                })
                .collect();
            let mut part = vec![0; ids.len()];
            bisect(&c, (0..ids.len()).collect(), 0, k, &mut part);
            let mut groups = vec![Vec::new(); k];
            for (e, q) in part.iter().enumerate() {
                groups[*q].push(ids[e]);
            }
            let plain = Partition::from_groups(
                &model,
                groups
                    .into_iter()
                    .enumerate()
                    .map(|(i, g)| (format!("p{i}"), g))
                    .collect(),
                MassKind::Consistent,
            )
            .unwrap();
            assert!(
                p.junction_nodes() <= plain.junction_nodes(),
                "k={k}: refined {} vs plain {}",
                p.junction_nodes(),
                plain.junction_nodes()
            );
            // Same groups twice: deterministic.
            assert_eq!(
                p,
                Partition::automatic(&model, k, MassKind::Consistent).unwrap()
            );
        }
    }
}
