//! Free interface with force coupling, Lombard et al. (1997) (thesis §3.5.4, 3.40–3.53: (3.40),
//! (3.41), (3.42), (3.43), (3.44), (3.45), (3.46), (3.47), (3.48), (3.49), (3.50), (3.51), (3.52),
//! (3.53)).
//!
//! Component `k` is described by its free modes and residual flexibility (3.40):
//! `x = Φ q + R_{:,j} F_j`. The internal DOFs are split into masters `m` (physical DOFs kept,
//! chosen by Effective Independence) and slaves. The master rows give
//! `q = Φ_m⁺ (x_m − R_mj F_j)` (3.41), so (3.42, 3.43)
//! `x = Φ Φ_m⁺ x_m + (R_{:,j} − Φ Φ_m⁺ R_mj) F_j`, and at the junction `x_j = A x_m + B F_j`
//! with `A = Φ_j Φ_m⁺`, `B = R_jj − Φ_j Φ_m⁺ R_mj`.
//!
//! **Coupling, any number of boundaries.** The thesis writes (3.44–3.47: (3.44), (3.45), (3.46),
//! (3.47)) for one boundary. Here every junction DOF is treated at once: with `L_k` selecting
//! component `k`'s junction DOFs from the global junction vector `x_J` and `P_k` its masters from
//! all masters `x_M`, compatibility `x^k_j = L_k x_J` gives `F^k_j = B_k⁻¹ (L_k x_J − A_k P_k x_M)`
//! (3.44), and equilibrium `Σ_k L_kᵀ F^k_j = 0` (3.45) gives `x_J = S⁻¹ W x_M`,
//! `S = Σ L_kᵀ B_k⁻¹ L_k`, `W = Σ L_kᵀ B_k⁻¹ A_k P_k` (3.46). Each component then maps all masters
//! to its DOFs, `x^k = T_k x_M` (3.48–3.50: (3.48), (3.49), (3.50)), and `K_c = Σ T_kᵀ K_k T_k` is
//! a plain sum (3.51). For one boundary this is exactly (3.46–3.47: (3.46), (3.47)).
//!
//! **Effective Independence** (Kammer 1991): from candidate rows of `Φ`, repeatedly drop the
//! candidates contributing least to the Fisher information, `E = diag(Φ_c (Φ_cᵀΦ_c)⁻¹ Φ_cᵀ)`,
//! until the target count remains (a tenth of the excess per step, then one at a time; ties by
//! DOF order).
//!
//! **Second level** (3.52, 3.53): from the lowest modes `Φ` of the coupled model, keep masters
//! `m1` (Effective Independence again) and condense `x_m2 = Φ_m2 Φ_m1⁺ x_m1`.
//!
//! The coupling static-condenses the junction (junction forces are eliminated through a
//! frequency-independent relation), so unlike the classical methods the result cannot
//! reproduce the full model exactly for any number of modes; its reduced model has
//! `Σ_k n_m,k < N` coordinates. It converges as the component cut-off rises (tested).

use super::craig_bampton::split;
use super::free_interface::{free_modes, residual_flexibility};
use super::linalg::{inverse, pinv_full_column_rank, project};
use super::{
    ComponentReduction, Coordinate, Coupling, JunctionFlexibility, ReducedModel, ReductionError,
    ReductionInfo, SecondLevel,
};
use crate::core::DofId;
use crate::eigen::{ModeSelection, SparseEigenParams};
use crate::fe::SystemMatrices;
use faer::{Mat, MatRef, Side};
use std::collections::{BTreeSet, HashMap};

/// How master DOFs are chosen per substructure.
#[derive(Clone, Debug, PartialEq)]
pub struct MasterSelection {
    /// Candidate DOFs (`None`: every internal translational DOF).
    pub candidates: Option<Vec<DofId>>,
    /// DOFs always kept as masters (e.g. measured DOFs); must be internal DOFs.
    pub required: Vec<DofId>,
    /// Masters per kept component mode (at least 1: `Φ_m` needs full column rank).
    pub per_mode: f64,
}

impl Default for MasterSelection {
    fn default() -> Self {
        MasterSelection {
            candidates: None,
            required: Vec::new(),
            per_mode: 1.0,
        }
    }
}

/// Effective Independence: indices into the rows of `phi` (`n_c × m`) of the `target` rows kept,
/// ascending; `required[i]` rows are never dropped. Errors name why (`Φ_cᵀΦ_c` singular: the
/// candidates cannot resolve the modes).
pub fn effective_independence(
    phi: MatRef<'_, f64>,
    target: usize,
    required: &[bool],
) -> Result<Vec<usize>, String> {
    let m = phi.ncols();
    let mut active: Vec<usize> = (0..phi.nrows()).collect();
    if target < m {
        return Err(format!("{target} masters cannot resolve {m} modes"));
    }
    loop {
        let a = Mat::from_fn(active.len(), m, |i, j| phi[(active[i], j)]);
        let f = a.transpose() * &a;
        let llt = f.llt(Side::Lower).map_err(|_| {
            "the candidates' mode shapes are linearly dependent (Fisher information singular)"
                .to_string()
        })?;
        if active.len() <= target {
            return Ok(active);
        }
        let mut y = a.transpose().to_owned();
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            llt.L(),
            y.as_mut(),
            faer::Par::Seq,
        );
        let mut e: Vec<(f64, usize)> = (0..active.len())
            .filter(|&i| !required[active[i]])
            .map(|i| ((0..m).map(|r| y[(r, i)] * y[(r, i)]).sum::<f64>(), i))
            .collect();
        if e.is_empty() {
            return Ok(active);
        }
        e.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let excess = active.len() - target;
        let drop = (excess / 10).max(1).min(e.len());
        let gone: BTreeSet<usize> = e[..drop].iter().map(|x| x.1).collect();
        active = active
            .into_iter()
            .enumerate()
            .filter(|(i, _)| !gone.contains(i))
            .map(|(_, r)| r)
            .collect();
    }
}

/// Force-coupling analysis of substructure `name` (3.40–3.43: (3.40), (3.41), (3.42), (3.43)): free
/// modes, residual flexibility, masters by Effective Independence among its internal candidates.
pub fn force_coupling(
    name: &str,
    sys: &SystemMatrices,
    junction: &[DofId],
    internal: &[DofId],
    modes: ModeSelection,
    masters: &MasterSelection,
    eigen: &SparseEigenParams,
) -> Result<ComponentReduction, ReductionError> {
    let (j_idx, _) = split(sys, junction)?;
    let index = sys.dof_index();
    let free = free_modes(name, sys, modes, eigen)?;
    let (n, m, nj) = (sys.n(), free.len(), j_idx.len());
    let rigid = free.eigenvalues.iter().filter(|l| **l == 0.0).count();
    let internal_set: BTreeSet<DofId> = internal.iter().copied().collect();
    let junction_set: BTreeSet<DofId> = junction.iter().copied().collect();
    let mut cand: Vec<DofId> = match &masters.candidates {
        None => internal
            .iter()
            .copied()
            .filter(|d| !d.comp.is_rotation())
            .collect(),
        Some(c) => c
            .iter()
            .copied()
            .filter(|d| internal_set.contains(d))
            .collect(),
    };
    let masters_err = |candidates: usize, detail: String| ReductionError::Masters {
        substructure: name.to_string(),
        candidates,
        modes: m,
        detail,
    };
    for d in &masters.required {
        if junction_set.contains(d) {
            return Err(masters_err(
                cand.len(),
                format!("required master {d} is a junction DOF; masters must be internal"),
            ));
        }
        if internal_set.contains(d) {
            cand.push(*d);
        }
    }
    cand.sort_unstable();
    cand.dedup();
    let required: Vec<bool> = cand.iter().map(|d| masters.required.contains(d)).collect();
    let n_required = required.iter().filter(|r| **r).count();
    let target = ((masters.per_mode.max(1.0) * m as f64).ceil() as usize).max(n_required);
    if cand.len() < target {
        return Err(masters_err(
            cand.len(),
            format!("{target} masters are needed"),
        ));
    }
    let rows: Vec<usize> = cand.iter().map(|d| index[d]).collect();
    let phi_c = Mat::from_fn(rows.len(), m, |i, j| free.shapes[(rows[i], j)]);
    let chosen = effective_independence(phi_c.as_ref(), target, &required)
        .map_err(|e| masters_err(cand.len(), e))?;
    let m_idx: Vec<usize> = chosen.iter().map(|&c| rows[c]).collect();
    let nm = m_idx.len();
    let phi_m = Mat::from_fn(nm, m, |i, j| free.shapes[(m_idx[i], j)]);
    let (pinv, cond) = pinv_full_column_rank(phi_m.as_ref()).ok_or_else(|| {
        masters_err(
            cand.len(),
            "the modes restricted to the chosen masters are rank deficient".into(),
        )
    })?;
    let g = &free.shapes * &pinv; // Φ Φ_m⁺, N × n_m
    let mut t = Mat::zeros(n, nm + nj);
    let flexibility = if nj > 0 {
        let rj = residual_flexibility(name, sys, &free, &j_idx, eigen.par)?; // R_{:,j}
        let rmj = Mat::from_fn(nm, nj, |a, b| rj[(m_idx[a], b)]);
        let h = &rj - &g * &rmj; // R_{:,j} − Φ Φ_m⁺ R_mj
        for i in 0..n {
            for c in 0..nm {
                t[(i, c)] = g[(i, c)];
            }
            for c in 0..nj {
                t[(i, nm + c)] = h[(i, c)];
            }
        }
        Some(JunctionFlexibility {
            a: Mat::from_fn(nj, nm, |a, b| g[(j_idx[a], b)]),
            b: Mat::from_fn(nj, nj, |a, b| h[(j_idx[a], b)]),
        })
    } else {
        for i in 0..n {
            for c in 0..nm {
                t[(i, c)] = g[(i, c)];
            }
        }
        None
    };
    let mut coords: Vec<Coordinate> = m_idx
        .iter()
        .map(|&r| Coordinate::Dof(sys.dofs[r]))
        .collect();
    coords.extend(j_idx.iter().map(|&r| Coordinate::Force(sys.dofs[r])));
    Ok(ComponentReduction {
        substructure: name.to_string(),
        dofs: sys.dofs.clone(),
        junction: junction.to_vec(),
        k: project(&sys.k, t.as_ref()),
        m: project(&sys.m, t.as_ref()),
        t,
        coords,
        mode_frequencies_hz: free.frequencies_hz(),
        flexibility,
        info: ReductionInfo {
            rigid_body_modes: rigid,
            masters: nm,
            master_condition: cond,
            seconds: 0.0,
        },
    })
}

/// Global master coordinates and each component's dense coupling `C_k` (3.44–3.50: (3.44), (3.45),
/// (3.46), (3.47), (3.48), (3.49), (3.50); generalised to every junction DOF at once; see the
/// module documentation).
pub(super) fn couple(
    junction: &[DofId],
    components: &[ComponentReduction],
) -> Result<(Vec<Coordinate>, Vec<Coupling>), ReductionError> {
    let mut coords = Vec::new();
    let mut master_at: Vec<Vec<usize>> = Vec::with_capacity(components.len());
    for c in components {
        let mut at = Vec::new();
        for coord in &c.coords {
            if let Coordinate::Dof(_) = coord {
                at.push(coords.len());
                coords.push(coord.clone());
            }
        }
        master_at.push(at);
    }
    let n_m = coords.len();
    let n_j = junction.len();
    let jindex: HashMap<DofId, usize> = junction.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    // Per component: L_k (indices into the junction), B_k⁻¹, B_k⁻¹ A_k P_k.
    let mut parts = Vec::with_capacity(components.len());
    let mut s = Mat::<f64>::zeros(n_j, n_j);
    let mut w = Mat::<f64>::zeros(n_j, n_m);
    for (k, c) in components.iter().enumerate() {
        let l: Vec<usize> = c
            .junction
            .iter()
            .map(|d| {
                jindex.get(d).copied().ok_or_else(|| {
                    ReductionError::Replace(format!(
                        "substructure `{}`: {d} is not a junction DOF of the partition",
                        c.substructure
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
        let Some(fx) = &c.flexibility else {
            parts.push(None);
            continue;
        };
        let binv = inverse(&fx.b).ok_or_else(|| ReductionError::SingularCoupling {
            detail: format!(
                "the interface flexibility B of substructure `{}` is singular",
                c.substructure
            ),
        })?;
        // B⁻¹ A P_k as a (n_j,k × n_M) block.
        let ba = &binv * &fx.a;
        let mut bap = Mat::zeros(l.len(), n_m);
        for (col, &g) in master_at[k].iter().enumerate() {
            for r in 0..l.len() {
                bap[(r, g)] = ba[(r, col)];
            }
        }
        for (a, &ga) in l.iter().enumerate() {
            for (b, &gb) in l.iter().enumerate() {
                s[(ga, gb)] += binv[(a, b)];
            }
            for g in 0..n_m {
                w[(ga, g)] += bap[(a, g)];
            }
        }
        parts.push(Some((l, binv, bap)));
    }
    let x = if n_j > 0 {
        let sinv = inverse(&s).ok_or_else(|| ReductionError::SingularCoupling {
            detail: format!("S is {n_j}x{n_j} and singular"),
        })?;
        &sinv * &w // x_J = S⁻¹ W x_M
    } else {
        Mat::zeros(0, n_m)
    };
    let mut couplings = Vec::with_capacity(components.len());
    for (k, c) in components.iter().enumerate() {
        let nm_k = master_at[k].len();
        let mut cm = Mat::zeros(c.coords.len(), n_m);
        for (col, &g) in master_at[k].iter().enumerate() {
            cm[(col, g)] = 1.0;
        }
        if let Some((l, binv, bap)) = &parts[k] {
            // F_j = B⁻¹ (L x_J − A P x_M) = B⁻¹ L X x_M − B⁻¹ A P x_M.
            let lx = Mat::from_fn(l.len(), n_m, |r, g| x[(l[r], g)]);
            let f = binv * &lx - bap;
            for r in 0..l.len() {
                for g in 0..n_m {
                    cm[(nm_k + r, g)] = f[(r, g)];
                }
            }
        }
        couplings.push(Coupling::Dense(cm));
    }
    Ok((coords, couplings))
}

/// Second-level condensation (3.52, 3.53) of a force-coupled model, in place.
pub(super) fn second_level(r: &mut ReducedModel, sl: &SecondLevel) -> Result<(), ReductionError> {
    let n = r.n();
    let modes = r.modes(ModeSelection::Count(sl.modes.min(n)))?;
    let p = modes.len();
    let required: Vec<bool> = r
        .coords
        .iter()
        .map(|c| matches!(c, Coordinate::Dof(d) if sl.required.contains(d)))
        .collect();
    for d in &sl.required {
        if !r.coords.contains(&Coordinate::Dof(*d)) {
            return Err(ReductionError::Masters {
                substructure: "second level".into(),
                candidates: n,
                modes: p,
                detail: format!("required DOF {d} is not a master of the first level"),
            });
        }
    }
    let err = |detail: String| ReductionError::Masters {
        substructure: "second level".into(),
        candidates: n,
        modes: p,
        detail,
    };
    let keep =
        effective_independence(modes.shapes.as_ref(), sl.keep.min(n), &required).map_err(err)?;
    let drop: Vec<usize> = (0..n).filter(|i| !keep.contains(i)).collect();
    let phi1 = Mat::from_fn(keep.len(), p, |i, j| modes.shapes[(keep[i], j)]);
    let (pinv, _) = pinv_full_column_rank(phi1.as_ref())
        .ok_or_else(|| err("the kept masters do not resolve the modes".into()))?;
    let phi2 = Mat::from_fn(drop.len(), p, |i, j| modes.shapes[(drop[i], j)]);
    let g = &phi2 * &pinv;
    let mut t2 = Mat::zeros(n, keep.len());
    for (c, &i) in keep.iter().enumerate() {
        t2[(i, c)] = 1.0;
    }
    for (a, &i) in drop.iter().enumerate() {
        for c in 0..keep.len() {
            t2[(i, c)] = g[(a, c)];
        }
    }
    for cp in r.couplings.iter_mut() {
        if let Coupling::Dense(c) = cp {
            *c = &*c * &t2;
        }
    }
    r.k = super::linalg::symmetrise(&(t2.transpose() * &r.k * &t2));
    r.m = super::linalg::symmetrise(&(t2.transpose() * &r.m * &t2));
    r.coords = keep.iter().map(|&i| r.coords[i].clone()).collect();
    Ok(())
}
