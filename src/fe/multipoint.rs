//! Exact elimination of linear multipoint constraints (rigid elements, MPC cards) from assembled
//! matrices (docs/theory.md §1).
//!
//! Each constraint makes one DOF dependent, `u_d = Σ cᵢ uᵢ`. Chains (a term that is itself
//! dependent) are substituted in dependency order, so every dependent DOF becomes a combination
//! of independent DOFs only; terms on constrained (SPC) DOFs vanish. With `T` the sparse map from
//! the independent DOFs `ũ` to all DOFs, `u = T ũ` (identity rows for independent DOFs, the
//! coefficients for dependent ones), the reduced matrices are
//!
//! `K̃ = Tᵀ K T`, `M̃ = Tᵀ M T` (likewise `C`, `D`), and `∂K̃/∂φ = Tᵀ (∂K/∂φ) T`,
//!
//! exact for every parameter value since `T` depends on geometry only. `K̃` is formed column by
//! column: column `b` of `Tᵀ K T` sums `c_j c_i K_ij` over the rows `j` with a term on `b` and the
//! rows `i` of column `j`, in a fixed order (deterministic whatever the thread count). The
//! recovered dependent DOFs (for reporting mode shapes at every physical DOF) are `u_d = T_d ũ`.

use super::system::SystemMatrices;
use crate::core::DofId;
use crate::core::sparse::SparseMatrix;
use crate::model::MultipointConstraint;
use faer::sparse::SymbolicSparseColMat;
use faer::{Mat, MatRef};
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// A dependent DOF as a combination of independent DOFs, with the card that made it dependent.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DependentDof {
    /// The dependent DOF.
    pub dof: DofId,
    /// Independent DOFs and coefficients: `u_dof = Σ c u`.
    pub terms: Vec<(DofId, f64)>,
    /// The card (`RBE2 12`).
    pub origin: String,
}

/// Why constraints could not be eliminated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MultipointError {
    /// The constraints depend on each other in a cycle.
    #[error(
        "multipoint constraints form a cycle through {dof} ({origin}); a dependent DOF cannot depend on itself"
    )]
    Cycle {
        /// A DOF on the cycle.
        dof: DofId,
        /// Its card.
        origin: String,
    },
    /// A DOF is dependent in two constraints.
    #[error("DOF {dof} is dependent in both {first} and {second}")]
    Twice {
        /// The DOF.
        dof: DofId,
        /// First card.
        first: String,
        /// Second card.
        second: String,
    },
    /// A dependent DOF's independent DOF is outside the assembled DOFs (another substructure).
    #[error(
        "DOF {dof} is dependent ({origin}) on {term}, which is not among the DOFs assembled here; a rigid element or MPC may not join two substructures: put its grids into one substructure"
    )]
    Outside {
        /// The dependent DOF.
        dof: DofId,
        /// The independent DOF not found.
        term: DofId,
        /// The card.
        origin: String,
    },
}

/// Every dependent DOF of `mpcs` as a combination of independent DOFs (chains substituted,
/// terms on `spc` DOFs dropped, equal DOFs summed, sorted by DOF).
pub fn resolve(
    mpcs: &[MultipointConstraint],
    spc: &BTreeSet<DofId>,
) -> Result<BTreeMap<DofId, DependentDof>, MultipointError> {
    let mut index: HashMap<DofId, usize> = HashMap::with_capacity(mpcs.len());
    for (i, c) in mpcs.iter().enumerate() {
        if let Some(&j) = index.get(&c.dependent) {
            return Err(MultipointError::Twice {
                dof: c.dependent,
                first: mpcs[j].origin.clone(),
                second: c.origin.clone(),
            });
        }
        index.insert(c.dependent, i);
    }
    let mut done: Vec<Option<Vec<(DofId, f64)>>> = vec![None; mpcs.len()];
    let mut on_stack = vec![false; mpcs.len()];
    for start in 0..mpcs.len() {
        let mut stack = vec![start];
        while let Some(&i) = stack.last() {
            if done[i].is_some() {
                stack.pop();
                continue;
            }
            on_stack[i] = true;
            let pending = mpcs[i]
                .terms
                .iter()
                .filter_map(|t| index.get(&t.0).copied())
                .find(|&j| done[j].is_none());
            if let Some(j) = pending {
                if on_stack[j] {
                    return Err(MultipointError::Cycle {
                        dof: mpcs[j].dependent,
                        origin: mpcs[j].origin.clone(),
                    });
                }
                stack.push(j);
                continue;
            }
            let mut terms: Vec<(DofId, f64)> = Vec::new();
            for &(d, c) in &mpcs[i].terms {
                match index.get(&d) {
                    Some(&j) => terms.extend(
                        done[j]
                            .as_ref()
                            .into_iter()
                            .flatten()
                            .map(|&(e, v)| (e, c * v)),
                    ),
                    None => terms.push((d, c)),
                }
            }
            terms.retain(|t| !spc.contains(&t.0));
            terms.sort_by_key(|t| t.0);
            let mut merged: Vec<(DofId, f64)> = Vec::with_capacity(terms.len());
            for (d, c) in terms {
                match merged.last_mut() {
                    Some(last) if last.0 == d => last.1 += c,
                    _ => merged.push((d, c)),
                }
            }
            merged.retain(|t| t.1 != 0.0);
            done[i] = Some(merged);
            on_stack[i] = false;
            stack.pop();
        }
    }
    Ok(mpcs
        .iter()
        .zip(done)
        .map(|(c, t)| {
            (
                c.dependent,
                DependentDof {
                    dof: c.dependent,
                    terms: t.unwrap_or_default(),
                    origin: c.origin.clone(),
                },
            )
        })
        .collect())
}

/// The independent DOFs every dependent DOF of `dependents` refers to: they must stay in an
/// assembly even when no element reaches them (the constraint gives them stiffness and mass).
pub fn independent_dofs(dependents: &BTreeMap<DofId, DependentDof>) -> BTreeSet<DofId> {
    dependents
        .values()
        .flat_map(|d| d.terms.iter().map(|t| t.0))
        .collect()
}

/// An assembled system with its dependent DOFs eliminated.
#[derive(Clone, Debug)]
pub struct Eliminated {
    /// `Tᵀ K T`, `Tᵀ M T` (and `C`, `D`) over the independent DOFs that keep stiffness or mass.
    pub system: SystemMatrices,
    /// Independent DOFs left without stiffness and mass, removed (as the assembly's AUTOSPC).
    pub dropped: Vec<DofId>,
    /// Each dependent DOF of the system's nodes over the system's DOFs (terms on dropped DOFs,
    /// which are zero, left out).
    pub dependent: Vec<DependentDof>,
}

/// Eliminates the dependent DOFs from `sys` (whose DOFs must hold every independent DOF a
/// dependent DOF of `sys` refers to, unless it is constrained): `K̃ = Tᵀ K T` and likewise for
/// every matrix; dependent DOFs of `nodes` that `sys` does not hold are reported too.
pub fn eliminate(
    sys: &SystemMatrices,
    dependents: &BTreeMap<DofId, DependentDof>,
    nodes: &BTreeSet<u64>,
) -> Result<Eliminated, MultipointError> {
    let kept: Vec<DofId> = sys
        .dofs
        .iter()
        .copied()
        .filter(|d| !dependents.contains_key(d))
        .collect();
    let col: HashMap<DofId, usize> = kept.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let expand = |d: &DependentDof| -> Result<Vec<(usize, f64)>, MultipointError> {
        d.terms
            .iter()
            .map(|(t, c)| {
                col.get(t)
                    .map(|&j| (j, *c))
                    .ok_or_else(|| MultipointError::Outside {
                        dof: d.dof,
                        term: *t,
                        origin: d.origin.clone(),
                    })
            })
            .collect()
    };
    let mut map: Vec<Vec<(usize, f64)>> = Vec::with_capacity(sys.n());
    for d in &sys.dofs {
        map.push(match dependents.get(d) {
            Some(dep) => expand(dep)?,
            None => vec![(col[d], 1.0)],
        });
    }
    let n = kept.len();
    let named: Vec<SparseMatrix> = sys
        .named()
        .iter()
        .map(|(_, a)| congruence(a, &map, n))
        .collect();
    // Independent DOFs without stiffness or mass after the transformation are removed.
    let diag = |a: &SparseMatrix, j: usize| -> f64 {
        let rows = a.row_idx_of_col_raw(j);
        rows.binary_search(&j).map_or(0.0, |p| a.val_of_col(j)[p])
    };
    let keep: Vec<bool> = (0..n)
        .map(|j| diag(&named[0], j) != 0.0 || diag(&named[1], j) != 0.0)
        .collect();
    let dropped: Vec<DofId> = (0..n).filter(|&j| !keep[j]).map(|j| kept[j]).collect();
    let named: Vec<SparseMatrix> = if dropped.is_empty() {
        named
    } else {
        named.iter().map(|a| restrict(a, &keep)).collect()
    };
    let dofs: Vec<DofId> = (0..n).filter(|&j| keep[j]).map(|j| kept[j]).collect();
    let final_set: BTreeSet<DofId> = dofs.iter().copied().collect();
    let dependent: Vec<DependentDof> = dependents
        .values()
        .filter(|d| nodes.contains(&d.dof.node))
        .map(|d| DependentDof {
            dof: d.dof,
            terms: d
                .terms
                .iter()
                .copied()
                .filter(|t| final_set.contains(&t.0))
                .collect(),
            origin: d.origin.clone(),
        })
        .collect();
    let mut it = named.into_iter();
    let (k, m) = (it.next(), it.next());
    let (Some(k), Some(m)) = (k, m) else {
        unreachable!("named() always holds K and M")
    };
    let c = sys.c.as_ref().and_then(|_| it.next());
    let d = sys.d.as_ref().and_then(|_| it.next());
    Ok(Eliminated {
        system: SystemMatrices { dofs, k, m, c, d },
        dropped,
        dependent,
    })
}

/// `Tᵀ A T` where row `i` of `T` is `map[i]` (pairs of column and coefficient), `T` with `n`
/// columns; entries summed in a fixed order per column.
pub fn congruence(a: &SparseMatrix, map: &[Vec<(usize, f64)>], n: usize) -> SparseMatrix {
    // For each new column b: the old columns j with their coefficient T_jb.
    let mut inv: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for (j, row) in map.iter().enumerate() {
        for &(b, c) in row {
            inv[b].push((j, c));
        }
    }
    let columns: Vec<Vec<(usize, f64)>> = inv
        .par_iter()
        .with_min_len(256)
        .map(|sources| {
            let mut acc: Vec<(usize, f64)> = Vec::new();
            for &(j, cj) in sources {
                for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
                    for &(r, ci) in &map[i] {
                        acc.push((r, ci * cj * v));
                    }
                }
            }
            acc.sort_by_key(|e| e.0);
            let mut out: Vec<(usize, f64)> = Vec::with_capacity(acc.len());
            for (r, v) in acc {
                match out.last_mut() {
                    Some(last) if last.0 == r => last.1 += v,
                    _ => out.push((r, v)),
                }
            }
            out
        })
        .collect();
    from_columns(n, columns)
}

/// The rows and columns of `a` whose `keep` flag is set.
fn restrict(a: &SparseMatrix, keep: &[bool]) -> SparseMatrix {
    let mut new = vec![usize::MAX; keep.len()];
    let mut next = 0;
    for (j, &k) in keep.iter().enumerate() {
        if k {
            new[j] = next;
            next += 1;
        }
    }
    let columns: Vec<Vec<(usize, f64)>> = (0..keep.len())
        .filter(|&j| keep[j])
        .map(|j| {
            a.row_idx_of_col_raw(j)
                .iter()
                .zip(a.val_of_col(j))
                .filter(|(i, _)| keep[**i])
                .map(|(&i, &v)| (new[i], v))
                .collect()
        })
        .collect();
    from_columns(next, columns)
}

/// A square sparse matrix from its columns (rows sorted and unique in each).
fn from_columns(n: usize, columns: Vec<Vec<(usize, f64)>>) -> SparseMatrix {
    let mut ptr = Vec::with_capacity(n + 1);
    ptr.push(0usize);
    let mut rows = Vec::new();
    let mut vals = Vec::new();
    for c in columns {
        for (r, v) in c {
            rows.push(r);
            vals.push(v);
        }
        ptr.push(rows.len());
    }
    SparseMatrix::new(
        SymbolicSparseColMat::new_checked(n, n, ptr, None, rows),
        vals,
    )
}

/// The dependent DOFs' values from vectors over `dofs` (columns of `x`): row `k` of the result is
/// `Σ c x[term]` of `dependent[k]`.
pub fn recover(dependent: &[DependentDof], dofs: &[DofId], x: MatRef<'_, f64>) -> Mat<f64> {
    let index: HashMap<DofId, usize> = dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let mut out = Mat::zeros(dependent.len(), x.ncols());
    for (k, d) in dependent.iter().enumerate() {
        for &(t, c) in &d.terms {
            if let Some(&i) = index.get(&t) {
                for j in 0..x.ncols() {
                    out[(k, j)] += c * x[(i, j)];
                }
            }
        }
    }
    out
}
