//! Sparse, parallel, deterministic assembly of element matrices into `K` and `M`.
//!
//! The pattern is built once from node adjacency: every pair of nodes that share an element
//! couples through a 6×6 block, so column `(a, c)` holds the rows `(b, 0..6)` of each neighbour
//! `b` of node `a`, sorted. Elements are then greedily coloured (in id order) so that no two
//! elements of one colour share a node; colours are scattered one after the other, the elements
//! of a colour in parallel. Each entry therefore receives its contributions in a fixed order
//! whatever the thread count, and memory stays proportional to the non-zeros (no triplet list).
//! Constrained DOFs are dropped at the end; DOFs with neither stiffness nor mass (e.g. shell
//! drilling rotations at nodes nothing else holds) are reported and dropped too, as Nastran's
//! AUTOSPC does.

use super::element::ElementMatrices;
use super::system::{LowerSystem, SystemMatrices};
use crate::core::memory::split_at_offsets;
use crate::core::sparse::{
    INT32_INDEXED, LowerTriplets, SparseMatrix, TripletIndices, gather_triplets,
};
use crate::core::{Component, DofId};
use faer::sparse::SymbolicSparseColMat;
use rayon::prelude::*;
use std::collections::{BTreeSet, HashMap};

/// One element's contribution: its nodes (indices into the node list) and its matrices in
/// node-major 6-DOF order.
pub struct Contribution {
    /// Node indices, in the order of the matrices' blocks.
    pub nodes: Vec<usize>,
    /// Stiffness and mass, `6n × 6n`.
    pub matrices: ElementMatrices,
}

/// Figures of an assembly.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct AssemblyInfo {
    /// DOFs before constraints.
    pub total_dofs: usize,
    /// Free DOFs.
    pub free_dofs: usize,
    /// Stored non-zeros per matrix (full symmetric storage).
    pub nnz: usize,
    /// Element colours.
    pub colours: usize,
    /// DOFs removed because nothing gives them stiffness or mass.
    pub auto_constrained: Vec<DofId>,
    /// DOFs eliminated by multipoint constraints, each over the free DOFs (recovery of
    /// results at every physical DOF).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub dependent: Vec<super::multipoint::DependentDof>,
}

/// Greedy colouring of elements (given as node lists) in order: no two elements of one colour
/// share a node. Returns the element indices of each colour, ascending.
pub fn colour(elements: &[Vec<usize>], n_nodes: usize) -> Vec<Vec<usize>> {
    let mut colours: Vec<Vec<usize>> = Vec::new();
    // For each node, a bit set of colours already touching it (u64 words).
    let mut used: Vec<Vec<u64>> = vec![Vec::new(); n_nodes];
    for (e, nodes) in elements.iter().enumerate() {
        let mut c = 0;
        loop {
            let (w, b) = (c / 64, c % 64);
            if nodes
                .iter()
                .all(|&n| used[n].get(w).is_none_or(|word| word & (1 << b) == 0))
            {
                break;
            }
            c += 1;
        }
        let (w, b) = (c / 64, c % 64);
        for &n in nodes {
            if used[n].len() <= w {
                used[n].resize(w + 1, 0);
            }
            used[n][w] |= 1 << b;
        }
        if colours.len() <= c {
            colours.resize(c + 1, Vec::new());
        }
        colours[c].push(e);
    }
    colours
}

struct SharedValues(*mut f64);
// SAFETY: elements of one colour share no node, so they write disjoint entries (see `scatter`).
unsafe impl Sync for SharedValues {}
// SAFETY: as for `Sync`: the pointer is only written through by `scatter`, colour by colour.
unsafe impl Send for SharedValues {}

/// Assembles `K` and `M` over `node_ids` (sorted, 6 DOFs each) from `elements` (node-index
/// lists) with `contribution(i)` computing element `i`; then removes `constraints` and DOFs
/// without stiffness and mass.
pub fn assemble<E, F>(
    node_ids: &[u64],
    elements: &[Vec<usize>],
    constraints: &BTreeSet<DofId>,
    contribution: F,
) -> Result<(SystemMatrices, AssemblyInfo), E>
where
    F: Fn(usize) -> Result<Contribution, E> + Sync,
    E: Send,
{
    assemble_keeping(
        node_ids,
        elements,
        constraints,
        &BTreeSet::new(),
        contribution,
    )
}

/// [`assemble`], keeping the unconstrained DOFs of `keep` even when no element gives them
/// stiffness or mass (independent DOFs of multipoint constraints, which receive theirs from the
/// dependent DOFs).
pub fn assemble_keeping<E, F>(
    node_ids: &[u64],
    elements: &[Vec<usize>],
    constraints: &BTreeSet<DofId>,
    keep_dofs: &BTreeSet<DofId>,
    contribution: F,
) -> Result<(SystemMatrices, AssemblyInfo), E>
where
    F: Fn(usize) -> Result<Contribution, E> + Sync,
    E: Send,
{
    let scalar = BTreeSet::new();
    scatter(
        node_ids,
        &scalar,
        elements,
        constraints,
        keep_dofs,
        contribution,
    )
    .map(Scattered::full)
}

/// Element matrices scattered into the pattern of every DOF (`6` per node), with the free
/// DOFs chosen: what is left is to gather the free DOFs' entries, as full matrices
/// ([`Scattered::full`]) or as the lower triangles the matrices artefact stores
/// ([`Scattered::lower`]).
pub struct Scattered {
    /// The pattern over every DOF and which of them are free.
    pattern: FreePattern,
    /// Stiffness and mass on the pattern.
    kv: Vec<f64>,
    mv: Vec<f64>,
    /// The free DOFs' labels.
    dofs: Vec<DofId>,
    /// The figures of the assembly, but for `nnz` (set by the gather).
    info: AssemblyInfo,
}

/// The assembly's pattern over every DOF, with the free DOFs marked.
struct FreePattern {
    /// Column pointers of the pattern.
    col_ptr: Vec<usize>,
    /// Row indices of the pattern, sorted within each column.
    row_idx: Vec<usize>,
    /// Whether each DOF is free.
    keep: Vec<bool>,
    /// Each DOF's index among the free ones (`usize::MAX` when not free).
    new_index: Vec<usize>,
    /// The free DOFs' indices in the pattern, ascending.
    kept_columns: Vec<usize>,
}

impl FreePattern {
    /// Positions in the pattern of pattern column `j`'s free rows.
    fn kept_rows(&self, j: usize) -> impl Iterator<Item = usize> + '_ {
        (self.col_ptr[j]..self.col_ptr[j + 1]).filter(|&p| self.keep[self.row_idx[p]])
    }

    /// Free column `c`'s rows from the diagonal down, as free indices, with their positions in
    /// the pattern.
    fn lower_entries(&self, c: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        let j = self.kept_columns[c];
        (self.col_ptr[j]..self.col_ptr[j + 1]).filter_map(move |p| {
            let r = self.row_idx[p];
            (r >= j && self.keep[r]).then(|| (self.new_index[r], p))
        })
    }
}

/// The first half of [`assemble_keeping`], where moreover the ids of `scalar` among `node_ids`
/// are scalar points: their one DOF (`id:s`) is slot 0 of their 6-DOF block, the other five
/// slots are never DOFs (not reported as auto-constrained); elements place a scalar point's DOF
/// at slot 0 of its block. Builds the pattern, scatters every element's contribution colour by
/// colour and chooses the free DOFs, for [`Scattered::full`] or [`Scattered::lower`] to gather.
pub fn scatter<E, F>(
    node_ids: &[u64],
    scalar: &BTreeSet<u64>,
    elements: &[Vec<usize>],
    constraints: &BTreeSet<DofId>,
    keep_dofs: &BTreeSet<DofId>,
    contribution: F,
) -> Result<Scattered, E>
where
    F: Fn(usize) -> Result<Contribution, E> + Sync,
    E: Send,
{
    let n_nodes = node_ids.len();
    // Node adjacency (sorted neighbour lists, self included).
    let mut adj: Vec<Vec<u32>> = (0..n_nodes).map(|a| vec![a as u32]).collect();
    for nodes in elements {
        for &a in nodes {
            for &b in nodes {
                adj[a].push(b as u32);
            }
        }
    }
    adj.par_iter_mut().for_each(|v| {
        v.sort_unstable();
        v.dedup();
    });
    // Column pointers: column 6a+c has 6·deg(a) rows.
    let n = 6 * n_nodes;
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0usize);
    for neighbours in &adj {
        for _ in 0..6 {
            let last = *col_ptr.last().unwrap_or(&0);
            col_ptr.push(last + 6 * neighbours.len());
        }
    }
    let nnz = col_ptr[n];
    let mut row_idx = vec![0usize; nnz];
    split_at_offsets(&mut row_idx, &col_ptr)
        .into_par_iter()
        .with_min_len(1024)
        .enumerate()
        .for_each(|(j, rows)| {
            for (k, &b) in adj[j / 6].iter().enumerate() {
                for r in 0..6 {
                    rows[6 * k + r] = 6 * b as usize + r;
                }
            }
        });
    // Written before the scatter adds to them (see `written_zeros_f64`).
    let mut kv = crate::core::memory::written_zeros_f64(nnz);
    let mut mv = crate::core::memory::written_zeros_f64(nnz);
    let colours = colour(elements, n_nodes);
    {
        let (kp, mp) = (SharedValues(kv.as_mut_ptr()), SharedValues(mv.as_mut_ptr()));
        for group in &colours {
            group.par_iter().try_for_each(|&e| -> Result<(), E> {
                let c = contribution(e)?;
                scatter_element(&c, &adj, &col_ptr, &kp, &mp);
                Ok(())
            })?;
        }
    }
    // Free DOFs: not constrained, and holding some stiffness or mass.
    let diag = |vals: &[f64], j: usize| -> f64 {
        let a = j / 6;
        let k = adj[a].binary_search(&(a as u32)).unwrap_or(0);
        vals[col_ptr[j] + 6 * k + j % 6]
    };
    let mut auto = Vec::new();
    let mut keep = vec![false; n];
    let mut dofs = Vec::new();
    let mut total = n;
    for j in 0..n {
        let node = node_ids[j / 6];
        let d = if scalar.contains(&node) {
            if j % 6 != 0 {
                total -= 1;
                continue;
            }
            DofId::new(node, Component::Scalar)
        } else {
            DofId::new(node, Component::ALL[j % 6])
        };
        if constraints.contains(&d) {
            continue;
        }
        if diag(&kv, j) == 0.0 && diag(&mv, j) == 0.0 && !keep_dofs.contains(&d) {
            auto.push(d);
            continue;
        }
        keep[j] = true;
        dofs.push(d);
    }
    let new_index: Vec<usize> = {
        let mut next = 0;
        keep.iter()
            .map(|&k| {
                if k {
                    next += 1;
                    next - 1
                } else {
                    usize::MAX
                }
            })
            .collect()
    };
    let kept_columns: Vec<usize> = (0..n).filter(|&j| keep[j]).collect();
    let info = AssemblyInfo {
        total_dofs: total,
        free_dofs: dofs.len(),
        nnz: 0,
        colours: colours.len(),
        auto_constrained: auto,
        dependent: Vec::new(),
    };
    let pattern = FreePattern {
        col_ptr,
        row_idx,
        keep,
        new_index,
        kept_columns,
    };
    Ok(Scattered {
        pattern,
        kv,
        mv,
        dofs,
        info,
    })
}

impl Scattered {
    /// The free DOFs' full `K` and `M`: the pattern once for both, then each matrix's values;
    /// every column is filled on its own (in parallel, the same result whatever the threads).
    pub fn full(self) -> (SystemMatrices, AssemblyInfo) {
        let Self {
            pattern,
            kv,
            mv,
            dofs,
            mut info,
        } = self;
        let kept = &pattern.kept_columns;
        let kept_rows = |j: usize| pattern.kept_rows(j);
        let counts: Vec<usize> = kept.par_iter().map(|&j| kept_rows(j).count()).collect();
        let mut ptr = Vec::with_capacity(kept.len() + 1);
        ptr.push(0usize);
        for c in &counts {
            ptr.push(ptr[ptr.len() - 1] + c);
        }
        drop(counts);
        let row_idx = &pattern.row_idx;
        let rows = gather_kept(&ptr, kept, &kept_rows, |p| pattern.new_index[row_idx[p]]);
        let extract = |vals: Vec<f64>| gather_kept(&ptr, kept, &kept_rows, |p| vals[p]);
        let k_values = extract(kv);
        let m_values = extract(mv);
        let nf = kept.len();
        drop(pattern);
        // Rows are sorted within each column and in range by construction.
        let symbolic = SymbolicSparseColMat::new_checked(nf, nf, ptr, None, rows);
        let sys = SystemMatrices {
            dofs,
            k: SparseMatrix::new(symbolic.clone(), k_values),
            m: SparseMatrix::new(symbolic, m_values),
            c: None,
            d: None,
        };
        info.nnz = sys.k.compute_nnz();
        (sys, info)
    }

    /// The free DOFs' `K` and `M` as lower triangles, gathered straight into triplets.
    pub fn lower(self) -> (LowerSystem, AssemblyInfo) {
        let Self {
            pattern,
            kv,
            mv,
            dofs,
            mut info,
        } = self;
        let nf = pattern.kept_columns.len();
        let entries = |c: usize| pattern.lower_entries(c);
        let (rows, cols, [k, m]) = if nf <= INT32_INDEXED {
            let (r, c, v) = gather_triplets(nf, entries, |i| i as i32, [&kv, &mv]);
            (TripletIndices::I32(r), TripletIndices::I32(c), v)
        } else {
            let (r, c, v) = gather_triplets(nf, entries, |i| i as i64, [&kv, &mv]);
            (TripletIndices::I64(r), TripletIndices::I64(c), v)
        };
        crate::core::memory::drop_in_background((pattern, kv, mv));
        // `M` has the same pattern; its own copy of the indices, for a table of its own.
        let (m_rows, m_cols) = rayon::join(|| rows.clone(), || cols.clone());
        // Stored entries of the full matrix: each off-diagonal one twice.
        info.nnz = 2 * k.len() - dofs.len();
        let sys = LowerSystem {
            dofs,
            k: LowerTriplets {
                rows,
                cols,
                values: k,
            },
            m: LowerTriplets {
                rows: m_rows,
                cols: m_cols,
                values: m,
            },
        };
        (sys, info)
    }
}

fn scatter_element(
    c: &Contribution,
    adj: &[Vec<u32>],
    col_ptr: &[usize],
    kp: &SharedValues,
    mp: &SharedValues,
) {
    let nn = c.nodes.len();
    for (bj, &a) in c.nodes.iter().enumerate() {
        for (bi, &b) in c.nodes.iter().enumerate() {
            // Position of node b in column block of node a.
            let Ok(k) = adj[a].binary_search(&(b as u32)) else {
                continue;
            };
            for cc in 0..6 {
                let base = col_ptr[6 * a + cc] + 6 * k;
                for r in 0..6 {
                    let (i, j) = (6 * bi + r, 6 * bj + cc);
                    debug_assert!(i < 6 * nn && j < 6 * nn);
                    let (kval, mval) = (c.matrices.k[(i, j)], c.matrices.m[(i, j)]);
                    // SAFETY: `base + r` is inside column 6a+cc; elements of one colour share no
                    // node, so no other thread writes the block (b, a) at the same time.
                    unsafe {
                        *kp.0.add(base + r) += kval;
                        *mp.0.add(base + r) += mval;
                    }
                }
            }
        }
    }
}

/// `value(p)` for the stored positions `p` that `positions(j)` gives of each column `j` of
/// `columns`, into the slices of `ptr`: column by column in parallel.
fn gather_kept<T, P>(
    ptr: &[usize],
    columns: &[usize],
    positions: &(impl Fn(usize) -> P + Sync),
    value: impl Fn(usize) -> T + Sync,
) -> Vec<T>
where
    T: Copy + Default + Send,
    P: Iterator<Item = usize>,
{
    let mut out = vec![T::default(); ptr[ptr.len() - 1]];
    split_at_offsets(&mut out, ptr)
        .into_par_iter()
        .zip(columns)
        .with_min_len(1024)
        .for_each(|(out, &j)| {
            for (o, p) in out.iter_mut().zip(positions(j)) {
                *o = value(p);
            }
        });
    out
}

/// Index of every node id in a sorted list.
pub fn node_index(node_ids: &[u64]) -> HashMap<u64, usize> {
    node_ids.iter().enumerate().map(|(i, n)| (*n, i)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// Axial bars along x between consecutive nodes: K from the assembly equals the hand result.
    #[test]
    fn bar_chain_assembles_like_the_textbook() {
        let nodes: Vec<u64> = vec![10, 20, 30];
        let elements = vec![vec![0, 1], vec![1, 2]];
        let k = 5.0;
        let bar = |_: usize| -> Result<Contribution, ()> {
            let mut km = Mat::zeros(12, 12);
            let mut mm = Mat::zeros(12, 12);
            for (i, j, v) in [(0, 0, k), (6, 6, k), (0, 6, -k), (6, 0, -k)] {
                km[(i, j)] = v;
            }
            for i in 0..12 {
                mm[(i, i)] = if i % 6 < 3 { 0.5 } else { 0.0 };
            }
            Ok(Contribution {
                nodes: vec![],
                matrices: ElementMatrices { k: km, m: mm },
            })
        };
        let with_nodes = |e: usize| {
            bar(e).map(|mut c| {
                c.nodes = elements[e].clone();
                c
            })
        };
        let constraints: BTreeSet<DofId> = [DofId::new(10, Component::Ux)].into();
        let (sys, info) = assemble(&nodes, &elements, &constraints, with_nodes).unwrap();
        assert_eq!(info.colours, 2);
        // Free: ux, uy, uz at 20 and 30 plus uy, uz at 10 (mass only); rotations have nothing.
        assert_eq!(sys.dofs.len(), 8);
        assert_eq!(info.auto_constrained.len(), 9);
        let kd = sys.k_dense();
        let ix = sys.dof_index();
        let (a, b) = (ix[&"20:ux".parse().unwrap()], ix[&"30:ux".parse().unwrap()]);
        assert_eq!(kd[(a, a)], 2.0 * k);
        assert_eq!(kd[(a, b)], -k);
        assert_eq!(kd[(b, b)], k);
        sys.validate().unwrap();
    }

    #[test]
    fn colouring_separates_elements_sharing_nodes() {
        let elements = vec![vec![0, 1], vec![1, 2], vec![2, 3], vec![4, 5]];
        let colours = colour(&elements, 6);
        assert_eq!(colours, vec![vec![0, 2, 3], vec![1]]);
    }
}
