//! Receptance by a reduced-order frequency sweep: multi-point Krylov moment matching with an
//! a-posteriori estimate per line (docs/theory.md §13).
//!
//! About an expansion frequency `ω_j` the dynamic stiffness is `Z(ω) = A_j − (ω² − ω_j²) M + …`
//! with `A_j = K − ω_j² M`, so the block Krylov space
//! `span{A_j⁻¹F, (A_j⁻¹M) A_j⁻¹F, …, (A_j⁻¹M)^(b−1) A_j⁻¹F}` holds the first `b` moments of
//! the undamped receptance in `ω² − ω_j²` (13.1). The union over the expansion points,
//! orthonormalised, is a real basis `V`; the model is projected by Galerkin,
//! `Z_r(ω) = Vᵀ Z(ω) V = K_r + iD_r + iωC_r − ω² M_r` with every damping of the model and of the
//! request (proportional or not), and a line solves `Z_r(ω) y = Vᵀ F`, `x = V y` (13.2).
//!
//! The estimate of a line is its relative load residual `max_k ‖Z(ω) V y_k − f_k‖₂ / ‖f_k‖₂`
//! over the excitations (13.3): the reduced answer is the exact response to the load `F − R`,
//! so the estimate is a backward error, computed with the full matrices. Points are added
//! greedily, each at the line of the largest estimate, until every line meets the tolerance.

use super::direct::{DampingScalars, DirectDamping, DirectError, DynamicStiffness};
use super::{FrfPair, FrfSet, Quantity, convert_from_receptance};
use crate::fe::SystemMatrices;
use crate::sparse::sym_matvec;
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::{Accum, Mat, MatRef, Par, c64};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;

/// How the sweep builds its basis and when it stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KrylovOptions {
    /// Largest relative load residual accepted at any line (13.3).
    pub tolerance: f64,
    /// Krylov blocks per expansion point (each one column per excitation).
    pub blocks_per_point: usize,
    /// Most expansion points before the sweep gives up.
    pub max_points: usize,
}

impl Default for KrylovOptions {
    fn default() -> Self {
        KrylovOptions {
            tolerance: 1e-6,
            blocks_per_point: 8,
            max_points: 40,
        }
    }
}

/// What a sweep did besides its values.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KrylovReport {
    /// Expansion frequencies, Hz, in the order they were added.
    pub expansion_hz: Vec<f64>,
    /// Columns of the final basis.
    pub basis_size: usize,
    /// The estimate (13.3) of every line.
    pub estimates: Vec<f64>,
}

/// Why a sweep failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum KrylovError {
    /// The model, a DOF or a factorisation failed as for a direct FRF.
    #[error(transparent)]
    Direct(#[from] DirectError),
    /// The estimate stayed above the tolerance.
    #[error(
        "the Krylov sweep did not meet its tolerance: after {points} expansion points ({basis} basis vectors) the line at {worst_hz} Hz has a relative load residual of {estimate:.2e} > {tolerance:.0e}; raise `krylov.max_points` or `krylov.blocks_per_point`, loosen `krylov.tolerance`, or use `method: direct`"
    )]
    NotConverged {
        /// Expansion points used.
        points: usize,
        /// Basis columns.
        basis: usize,
        /// The worst line, Hz.
        worst_hz: f64,
        /// Its estimate.
        estimate: f64,
        /// The tolerance asked for.
        tolerance: f64,
    },
}

impl crate::core::InputFault for KrylovError {
    fn is_input(&self) -> bool {
        match self {
            KrylovError::Direct(e) => e.is_input(),
            KrylovError::NotConverged { .. } => false,
        }
    }
}

/// Receptance (converted to `quantity`) of `pairs` at `freqs_hz` by the reduced sweep.
pub fn krylov_receptance(
    sys: &SystemMatrices,
    damping: &DirectDamping,
    pairs: &[FrfPair],
    freqs_hz: &[f64],
    quantity: Quantity,
    options: &KrylovOptions,
) -> Result<(FrfSet, KrylovReport), KrylovError> {
    let n = sys.n();
    let index = sys.dof_index();
    let row = |d: &crate::core::DofId| index.get(d).copied().ok_or(DirectError::UnknownDof(*d, n));
    let mut excitations: Vec<usize> = Vec::new();
    let mut responses: Vec<usize> = Vec::new();
    let (mut exc_slot, mut resp_slot) = (HashMap::new(), HashMap::new());
    let mut reads = Vec::with_capacity(pairs.len());
    for p in pairs {
        let (i, j) = (row(&p.response)?, row(&p.excitation)?);
        let e = *exc_slot.entry(j).or_insert_with(|| {
            excitations.push(j);
            excitations.len() - 1
        });
        let r = *resp_slot.entry(i).or_insert_with(|| {
            responses.push(i);
            responses.len() - 1
        });
        reads.push((r, e));
    }
    let mut set = FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: freqs_hz.to_vec(),
        pairs: pairs.to_vec(),
        values: Mat::zeros(freqs_hz.len(), pairs.len()),
    };
    let mut report = KrylovReport::default();
    if pairs.is_empty() || freqs_hz.is_empty() {
        convert_from_receptance(&mut set, quantity);
        return Ok((set, report));
    }
    let z = DynamicStiffness::new(sys, damping)?;
    let load = Mat::<f64>::from_fn(n, excitations.len(), |i, k| {
        f64::from(u8::from(i == excitations[k]))
    });
    let coefficients = DampingScalars::new(damping);
    let mut basis = Basis::new(sys, &load);
    let mut tried: Vec<f64> = Vec::new();
    let done = crate::core::progress::task(
        || format!("FRF lines (Krylov, {n} DOFs): expansion points"),
        options.max_points as u64,
    );
    // The greedy search runs on a training subset of about TRAINING_LINES lines; once they
    // all meet the tolerance, every line is checked, and a line that fails joins the search.
    let stride = freqs_hz.len().div_ceil(TRAINING_LINES).max(1);
    let mut training: Vec<usize> = (0..freqs_hz.len()).step_by(stride).collect();
    if training.last() != Some(&(freqs_hz.len() - 1)) {
        training.push(freqs_hz.len() - 1);
    }
    let mut next = freqs_hz[freqs_hz.len() / 2];
    loop {
        tried.push(next);
        done.advance(1);
        if let Some(hz) = basis.add_point(&z, next, options.blocks_per_point, n)? {
            report.expansion_hz.push(hz);
        }
        let mut checked: Vec<usize> = training.clone();
        let mut lines = basis.evaluate(&coefficients, freqs_hz, &checked, &responses);
        let met = |lines: &[(Mat<c64>, f64)]| lines.iter().all(|l| l.1 <= options.tolerance);
        if met(&lines) && checked.len() < freqs_hz.len() {
            checked = (0..freqs_hz.len()).collect();
            lines = basis.evaluate(&coefficients, freqs_hz, &checked, &responses);
            training = checked.clone();
        }
        if met(&lines) {
            for (k, (x, estimate)) in lines.into_iter().enumerate() {
                for (p, &(r, e)) in reads.iter().enumerate() {
                    set.values[(k, p)] = x[(r, e)];
                }
                report.estimates.push(estimate);
            }
            report.basis_size = basis.v.ncols();
            convert_from_receptance(&mut set, quantity);
            return Ok((set, report));
        }
        let by_estimate = |a: &(usize, f64), b: &(usize, f64)| a.1.total_cmp(&b.1);
        let estimates = || checked.iter().zip(&lines).map(|(&k, l)| (k, l.1));
        let (worst_line, estimate) = estimates()
            .max_by(by_estimate)
            .unwrap_or((0, f64::INFINITY));
        let untried = estimates()
            .filter(|(k, _)| !tried.contains(&freqs_hz[*k]))
            .max_by(by_estimate);
        match untried {
            Some((k, _)) if tried.len() < options.max_points => next = freqs_hz[k],
            _ => {
                return Err(KrylovError::NotConverged {
                    points: report.expansion_hz.len(),
                    basis: basis.v.ncols(),
                    worst_hz: freqs_hz[worst_line],
                    estimate,
                    tolerance: options.tolerance,
                });
            }
        }
    }
}

/// Lines of the greedy search's training subset (every line is checked at the end).
const TRAINING_LINES: usize = 200;

/// The orthonormal basis, the full matrices' products with it and the reduced matrices.
struct Basis<'a> {
    sys: &'a SystemMatrices,
    load: &'a Mat<f64>,
    /// `n × q`, orthonormal columns.
    v: Mat<f64>,
    /// `K V`, `M V`, `C V`, `D V` (the model's own `C`, `D` where it has them).
    kv: Mat<f64>,
    mv: Mat<f64>,
    cv: Option<Mat<f64>>,
    dv: Option<Mat<f64>>,
    /// `Vᵀ K V`, `Vᵀ M V`, `Vᵀ C V`, `Vᵀ D V`, `Vᵀ F`.
    kr: Mat<f64>,
    mr: Mat<f64>,
    cr: Option<Mat<f64>>,
    dr: Option<Mat<f64>>,
    fr: Mat<f64>,
}

/// Relative norm below which a new direction is taken as already in the basis.
const DEFLATION: f64 = 1e-10;

impl<'a> Basis<'a> {
    fn new(sys: &'a SystemMatrices, load: &'a Mat<f64>) -> Self {
        let n = sys.n();
        let empty = || Mat::<f64>::zeros(n, 0);
        Basis {
            sys,
            load,
            v: empty(),
            kv: empty(),
            mv: empty(),
            cv: sys.c.as_ref().map(|_| empty()),
            dv: sys.d.as_ref().map(|_| empty()),
            kr: Mat::zeros(0, 0),
            mr: Mat::zeros(0, 0),
            cr: sys.c.as_ref().map(|_| Mat::zeros(0, 0)),
            dr: sys.d.as_ref().map(|_| Mat::zeros(0, 0)),
            fr: Mat::zeros(0, load.ncols()),
        }
    }

    /// Adds the Krylov blocks of the undamped `A_j = K − ω_j² M` at `f_hz` (13.1); an exactly
    /// singular `A_j` moves the point by a part in 10⁴. Each block is orthonormalised against
    /// the point's earlier blocks (its own Arnoldi process) before it joins the basis, and the
    /// next block is `A_j⁻¹ [M W, C W, D W]` with the model's own `C`, `D` (non-proportional
    /// damping moves the response out of the undamped moments' space; the proportional parts
    /// `ηK`, `αM + βK` stay in it). The frequency used, or `None` when no nearby `A_j` could be
    /// factored.
    fn add_point(
        &mut self,
        z: &DynamicStiffness,
        f_hz: f64,
        blocks: usize,
        n: usize,
    ) -> Result<Option<f64>, KrylovError> {
        let mut ws = z.real_workspace();
        let Some(hz) = [f_hz, f_hz * (1.0 + 1e-4) + 1e-4]
            .into_iter()
            .find(|&hz| z.factor_undamped(&mut ws, hz, Par::rayon(0)).is_ok())
        else {
            return Ok(None);
        };
        let mut local = Mat::<f64>::zeros(n, 0);
        let mut rhs: Vec<Mat<f64>> = vec![self.load.clone()];
        for _ in 0..blocks {
            let width: usize = rhs.iter().map(|m| m.ncols()).sum();
            let mut block = Mat::<f64>::zeros(n, width);
            let mut at = 0;
            for m in &rhs {
                block
                    .as_mut()
                    .subcols_mut(at, m.ncols())
                    .copy_from(m.as_ref());
                at += m.ncols();
            }
            z.solve_factored(&ws, block.as_mut());
            let fresh = orthonormal_against(&local, block.as_ref());
            if fresh.ncols() == 0 {
                break;
            }
            self.extend(fresh.as_ref());
            append_columns(&mut local, fresh.as_ref());
            let product = |a: &crate::core::sparse::SparseMatrix| {
                let mut y = Mat::<f64>::zeros(n, fresh.ncols());
                sym_matvec(a, fresh.as_ref(), y.as_mut(), Par::rayon(0));
                y
            };
            rhs = [Some(&self.sys.m), self.sys.c.as_ref(), self.sys.d.as_ref()]
                .into_iter()
                .flatten()
                .map(product)
                .collect();
        }
        Ok(Some(hz))
    }

    /// Appends the directions of `x` that the basis lacks (orthonormalised against it), and
    /// extends the products and the reduced matrices. The number of columns added.
    fn extend(&mut self, x: MatRef<'_, f64>) -> usize {
        let n = self.v.nrows();
        let x = orthonormal_against(&self.v, x);
        let added = x.ncols();
        if added == 0 {
            return 0;
        }
        let q = self.v.ncols();
        append_columns(&mut self.v, x.as_ref());
        let v = self.v.as_ref();
        let product = |a: &crate::core::sparse::SparseMatrix| {
            let mut y = Mat::<f64>::zeros(n, added);
            sym_matvec(a, x.as_ref(), y.as_mut(), Par::rayon(0));
            y
        };
        let (kx, mx) = (product(&self.sys.k), product(&self.sys.m));
        self.kr = grow(&self.kr, v, kx.as_ref());
        self.mr = grow(&self.mr, v, mx.as_ref());
        append_columns(&mut self.kv, kx.as_ref());
        append_columns(&mut self.mv, mx.as_ref());
        if let (Some(c), Some(cv), Some(cr)) = (self.sys.c.as_ref(), &mut self.cv, &mut self.cr) {
            let cx = product(c);
            *cr = grow(cr, v, cx.as_ref());
            append_columns(cv, cx.as_ref());
        }
        if let (Some(d), Some(dv), Some(dr)) = (self.sys.d.as_ref(), &mut self.dv, &mut self.dr) {
            let dx = product(d);
            *dr = grow(dr, v, dx.as_ref());
            append_columns(dv, dx.as_ref());
        }
        let fx = x.transpose() * self.load;
        self.fr = Mat::from_fn(q + added, self.load.ncols(), |i, k| {
            if i < q {
                self.fr[(i, k)]
            } else {
                fx[(i - q, k)]
            }
        });
        added
    }

    /// The reduced solution at the `responses` rows (response × excitation) and the estimate
    /// (13.2, 13.3) of each of the `lines` (indices into `freqs_hz`); lines in parallel chunks,
    /// each line's arithmetic fixed.
    fn evaluate(
        &self,
        c: &DampingScalars,
        freqs_hz: &[f64],
        lines: &[usize],
        responses: &[usize],
    ) -> Vec<(Mat<c64>, f64)> {
        let freqs_hz: Vec<f64> = lines.iter().map(|&k| freqs_hz[k]).collect();
        let q = self.v.ncols();
        let p = self.load.ncols();
        let rows = Mat::<f64>::from_fn(responses.len(), q, |i, k| self.v[(responses[i], k)]);
        let load_norms: Vec<f64> = (0..p)
            .map(|k| norm(&self.load.col(k).iter().copied().collect::<Vec<_>>()))
            .collect();
        let chunk = 16;
        freqs_hz
            .par_chunks(chunk)
            .flat_map_iter(|lines| {
                // The reduced solutions of the chunk, real and imaginary parts side by side.
                let mut y = Mat::<f64>::zeros(q, 2 * p * lines.len());
                for (l, &f) in lines.iter().enumerate() {
                    let w = 2.0 * PI * f;
                    let (a, b) = c.at(w);
                    let zr = Mat::<c64>::from_fn(q, q, |i, j| {
                        let mut v = a * self.kr[(i, j)] + b * self.mr[(i, j)];
                        if let Some(d) = &self.dr {
                            v += c64::new(0.0, d[(i, j)]);
                        }
                        if let Some(cr) = &self.cr {
                            v += c64::new(0.0, w * cr[(i, j)]);
                        }
                        v
                    });
                    let rhs = Mat::<c64>::from_fn(q, p, |i, k| c64::new(self.fr[(i, k)], 0.0));
                    let sol = zr.partial_piv_lu().solve(&rhs);
                    for k in 0..p {
                        for i in 0..q {
                            y[(i, 2 * p * l + k)] = sol[(i, k)].re;
                            y[(i, 2 * p * l + p + k)] = sol[(i, k)].im;
                        }
                    }
                }
                let times = |m: &Mat<f64>| {
                    let mut out = Mat::<f64>::zeros(m.nrows(), y.ncols());
                    matmul(out.as_mut(), Accum::Replace, m, &y, 1.0, Par::Seq);
                    out
                };
                let (ky, my) = (times(&self.kv), times(&self.mv));
                let cy = self.cv.as_ref().map(times);
                let dy = self.dv.as_ref().map(times);
                let xy = times(&rows);
                lines
                    .iter()
                    .enumerate()
                    .map(|(l, &f)| {
                        let w = 2.0 * PI * f;
                        let (a, b) = c.at(w);
                        let at = |m: &Mat<f64>, i: usize, k: usize| {
                            c64::new(m[(i, 2 * p * l + k)], m[(i, 2 * p * l + p + k)])
                        };
                        let mut estimate = 0.0f64;
                        for (k, load_norm) in load_norms.iter().enumerate() {
                            let mut sum = 0.0;
                            for i in 0..ky.nrows() {
                                let mut r = a * at(&ky, i, k) + b * at(&my, i, k)
                                    - c64::new(self.load[(i, k)], 0.0);
                                if let Some(d) = &dy {
                                    r += c64::new(0.0, 1.0) * at(d, i, k);
                                }
                                if let Some(cy) = &cy {
                                    r += c64::new(0.0, w) * at(cy, i, k);
                                }
                                sum += r.norm_sqr();
                            }
                            let e = sum.sqrt() / load_norm;
                            estimate = estimate.max(if e.is_finite() { e } else { f64::INFINITY });
                        }
                        let x = Mat::<c64>::from_fn(responses.len(), p, |i, k| at(&xy, i, k));
                        (x, estimate)
                    })
                    .collect::<Vec<_>>()
            })
            .collect()
    }
}

/// The columns of `x` orthonormalised against the orthonormal columns of `v` and each other
/// (two passes of Gram-Schmidt; the products sequential, as their sums over the rows must not
/// depend on the thread count), without those whose remainder is below [`DEFLATION`] of their
/// norm (already in the span).
fn orthonormal_against(v: &Mat<f64>, x: MatRef<'_, f64>) -> Mat<f64> {
    let n = x.nrows();
    let before: Vec<f64> = (0..x.ncols())
        .map(|k| norm(&x.col(k).iter().copied().collect::<Vec<_>>()))
        .collect();
    let mut x = x.to_owned();
    if v.ncols() > 0 {
        for _ in 0..2 {
            let mut c = Mat::<f64>::zeros(v.ncols(), x.ncols());
            matmul(c.as_mut(), Accum::Replace, v.transpose(), &x, 1.0, Par::Seq);
            matmul(x.as_mut(), Accum::Add, v, &c, -1.0, Par::Seq);
        }
    }
    let mut fresh: Vec<Vec<f64>> = Vec::new();
    for (k, &before) in before.iter().enumerate() {
        if before == 0.0 || !before.is_finite() {
            continue;
        }
        let mut col: Vec<f64> = x.col(k).iter().copied().collect();
        for _ in 0..2 {
            for f in &fresh {
                let d = dot(f, &col);
                for (value, &u) in col.iter_mut().zip(f) {
                    *value -= d * u;
                }
            }
        }
        let after = norm(&col);
        if after > DEFLATION * before {
            col.iter_mut().for_each(|value| *value /= after);
            fresh.push(col);
        }
    }
    Mat::from_fn(n, fresh.len(), |i, k| fresh[k][i])
}

/// Appends the columns of `b` to `a` in place, the column capacity grown geometrically.
fn append_columns(a: &mut Mat<f64>, b: MatRef<'_, f64>) {
    let (n, q) = (a.nrows(), a.ncols());
    let wanted = q + b.ncols();
    a.reserve(n, wanted.max(2 * q));
    a.resize_with(n, wanted, |i, j| b[(i, j - q)]);
}

/// The reduced matrix `Vᵀ A V` grown by the new columns: `v` is the whole new basis and `ax`
/// the product of `A` with its last `ax.ncols()` columns; the new rows mirror the new columns.
fn grow(old: &Mat<f64>, v: MatRef<'_, f64>, ax: MatRef<'_, f64>) -> Mat<f64> {
    let q = old.nrows();
    let mut block = Mat::<f64>::zeros(v.ncols(), ax.ncols());
    matmul(
        block.as_mut(),
        Accum::Replace,
        v.transpose(),
        ax,
        1.0,
        Par::Seq,
    );
    let size = v.ncols();
    Mat::from_fn(size, size, |i, j| match (i < q, j < q) {
        (true, true) => old[(i, j)],
        (_, false) => block[(i, j - q)],
        (false, true) => block[(j, i - q)],
    })
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::fe::element::MassKind;
    use crate::fe::model_assembly::assemble_model;
    use crate::frf::direct::{DirectSolver, direct_receptance_by};
    use crate::model::generate::{FlatPlate, PlateSupport, flat_plate, steel};

    /// The clamped 0.6 m × 0.4 m × 4 mm steel plate of 8 × 8 shells (294 DOFs), undamped.
    pub(crate) fn clamped_plate() -> SystemMatrices {
        let model = flat_plate(&FlatPlate {
            a: 0.6,
            b: 0.4,
            nx: 8,
            ny: 8,
            thickness: 0.004,
            material: steel(),
            support: PlateSupport::ClampedEdge,
        });
        assemble_model(&model, MassKind::Consistent).unwrap().0
    }

    /// The clamped plate with non-proportional damping: dashpots to ground at three nodes,
    /// structural `η` and Rayleigh.
    fn damped_plate() -> (SystemMatrices, DirectDamping) {
        let mut sys = clamped_plate();
        let n = sys.n();
        let uz: Vec<usize> = (0..n)
            .filter(|&i| sys.dofs[i].comp == crate::core::Component::Uz)
            .collect();
        let c: Vec<(usize, usize, f64)> = [3, uz.len() / 2, uz.len() - 5]
            .iter()
            .map(|&k| (uz[k], uz[k], 8.0))
            .collect();
        sys.c = Some(crate::core::sparse::sparse_from_triplets("C", n, &c).unwrap());
        let damping = DirectDamping {
            structural_eta: 0.004,
            rayleigh: Some((0.5, 2e-7)),
        };
        (sys, damping)
    }

    /// Against the direct `LDLᵀ` at every line of 0–1500 Hz (the first ~25 modes, resonances
    /// included): within 1e-8 of each FRF's peak (1.5e-11 measured). The estimate bounds the
    /// backward error in the load (1e-6 by default); the residual left is high-frequency
    /// content that the response barely amplifies, so the FRF error is far below it.
    #[test]
    fn krylov_agrees_with_direct_on_a_damped_plate() {
        let (sys, damping) = damped_plate();
        let uz: Vec<_> = sys
            .dofs
            .iter()
            .filter(|d| d.comp == crate::core::Component::Uz)
            .copied()
            .collect();
        let picked = [uz[4], uz[20], uz[31]];
        let pairs = FrfSet::all_pairs(&picked, &picked[..2]);
        let freqs = crate::frf::frequency_lines(0.0, 1500.0, 2.5);
        let options = KrylovOptions::default();
        let (rom, report) = krylov_receptance(
            &sys,
            &damping,
            &pairs,
            &freqs,
            Quantity::Accelerance,
            &options,
        )
        .unwrap();
        let (direct, _) = direct_receptance_by(
            &sys,
            &damping,
            &pairs,
            &freqs,
            Quantity::Accelerance,
            DirectSolver::Ldlt,
        )
        .unwrap();
        assert!(report.estimates.iter().all(|&e| e <= options.tolerance));
        assert!(report.basis_size < sys.n() / 2, "{report:?}");
        for p in 0..pairs.len() {
            let peak = (0..freqs.len())
                .map(|k| direct.values[(k, p)].norm())
                .fold(0.0, f64::max);
            for (k, f) in freqs.iter().enumerate() {
                let d = (rom.values[(k, p)] - direct.values[(k, p)]).norm();
                assert!(d <= 1e-8 * peak, "pair {p} at {f} Hz: {d:e} of {peak:e}");
            }
        }
    }

    /// The estimate is the relative load residual: recomputed from the dense `Z(ω)` and the
    /// reduced answer at every DOF (all DOFs as responses), they agree to round-off.
    #[test]
    fn the_estimate_is_the_load_residual() {
        let (sys, damping) = damped_plate();
        let n = sys.n();
        let excitation = sys.dofs[n / 2 + 2];
        let pairs = FrfSet::all_pairs(&sys.dofs, &[excitation]);
        let freqs = [40.0, 333.0, 910.0];
        let options = KrylovOptions {
            tolerance: 1e300,
            blocks_per_point: 3,
            max_points: 1,
        };
        let (rom, report) = krylov_receptance(
            &sys,
            &damping,
            &pairs,
            &freqs,
            Quantity::Receptance,
            &options,
        )
        .unwrap();
        let (k, m) = (sys.k_dense(), sys.m_dense());
        let c = crate::core::sparse::sparse_to_dense(sys.c.as_ref().unwrap());
        let (alpha, beta) = damping.rayleigh.unwrap();
        let j = sys.dof_index()[&excitation];
        for (l, &f) in freqs.iter().enumerate() {
            let w = 2.0 * PI * f;
            let mut worst_residual = 0.0;
            for i in 0..n {
                let mut r = c64::new(-f64::from(u8::from(i == j)), 0.0);
                for a in 0..n {
                    let z = c64::new(
                        k[(i, a)] - w * w * m[(i, a)],
                        damping.structural_eta * k[(i, a)]
                            + w * (c[(i, a)] + alpha * m[(i, a)] + beta * k[(i, a)]),
                    );
                    r += z * rom.values[(l, a)];
                }
                worst_residual += r.norm_sqr();
            }
            let residual = f64::sqrt(worst_residual);
            let estimate = report.estimates[l];
            assert!(
                (residual - estimate).abs() <= 1e-8 * estimate.max(1e-6),
                "{f} Hz: residual {residual:e}, estimate {estimate:e}"
            );
        }
        // One point of three blocks leaves the far lines visibly unconverged.
        assert!(report.estimates[2] > 1e-3, "{report:?}");
    }

    /// The same numbers on one thread and on two, bit for bit (digests must not depend on the
    /// machine's cores).
    #[test]
    fn the_sweep_does_not_depend_on_the_thread_count() {
        let (sys, damping) = damped_plate();
        let pairs = FrfSet::all_pairs(&sys.dofs[40..43], &sys.dofs[41..42]);
        let freqs = crate::frf::frequency_lines(0.0, 1000.0, 5.0);
        let sweep = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    krylov_receptance(
                        &sys,
                        &damping,
                        &pairs,
                        &freqs,
                        Quantity::Mobility,
                        &KrylovOptions::default(),
                    )
                    .unwrap()
                })
        };
        let ((one, r1), (two, r2)) = (sweep(1), sweep(2));
        assert_eq!(one.values, two.values);
        assert_eq!(r1, r2);
    }

    /// A tolerance the points allowed cannot meet is an error naming the worst line and what
    /// to change, not a silently poor FRF.
    #[test]
    fn an_unmet_tolerance_is_an_error() {
        let (sys, damping) = damped_plate();
        let pairs = FrfSet::all_pairs(&sys.dofs[10..11], &sys.dofs[10..11]);
        let freqs = crate::frf::frequency_lines(0.0, 1500.0, 5.0);
        let options = KrylovOptions {
            tolerance: 1e-10,
            blocks_per_point: 2,
            max_points: 2,
        };
        let e = krylov_receptance(
            &sys,
            &damping,
            &pairs,
            &freqs,
            Quantity::Receptance,
            &options,
        )
        .unwrap_err();
        let text = e.to_string();
        assert!(
            matches!(e, KrylovError::NotConverged { points: 2, .. }),
            "{text}"
        );
        assert!(
            text.contains("krylov.max_points") && text.contains("Hz"),
            "{text}"
        );
    }
}
