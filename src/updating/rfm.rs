//! The response function method of Lin and Ewins (docs/theory.md §6; thesis 2.22–2.24: (2.22),
//! (2.23), (2.24)), the baseline.
//!
//! For excitation `i` at a line `ω`: `α_A(ω) ΔZ(ω) α_Xi(ω) = α_Ai(ω) − α_Xi(ω)` with
//! `ΔZ = Σ_j φ_j (∂Z/∂φ_j) Δφ_j/φ_j` and `∂Z/∂φ = (1 + iη) ∂K/∂φ − ω² ∂M/∂φ` (uniform structural
//! loss factor `η`, `D = ηK`). Only measured rows are kept; unmeasured entries of `α_Xi` are
//! taken from the model (Visser and Imregun). `α_A` comes from a sparse solution of
//! `Z(ω) X = [e_r …, e_i]` (measured rows by symmetry of `Z`). Real and imaginary parts are
//! stacked (2.24), solved by SVD least squares, and the whole is iterated because the
//! sensitivity is a secant evaluated at the current model (2.27). Through a test map
//! (docs/theory.md (14.7)) a measured DOF is a load `w` on the model (its weighted model DOFs):
//! the equations read `w_rᵀ α_A ΔZ α̂_X w_e = w_rᵀ (α_A − α_X) w_e` in the test's own units, and
//! the measured values enter the column `α̂_X w_e` as the least change of the analytical one
//! that reproduces them (14.11) — the plain substitution when a measured DOF is one model DOF.

use super::model::{ParametricModel, UpdatingError};
use super::solve::{diagnostics, least_squares};
use super::{IterationRecord, Step, UpdateMethod};
use crate::core::DofId;
use crate::core::sparse::SparseMatrix;
use crate::correlation::frf::{amplitude_correlation, shape_correlation};
use crate::frf::direct::DynamicStiffness;
use crate::frf::{DirectDamping, FrfSet, Quantity};
use faer::{Mat, c64};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;

/// Settings of the RFM.
#[derive(Clone, Debug)]
pub struct RfmSettings {
    /// Lines (Hz) at which the equations are written; each must be a measured line.
    pub lines_hz: Vec<f64>,
    /// Uniform structural loss factor of the model (`D = ηK`).
    pub eta: f64,
    /// Stop when every relative change is below this.
    pub tolerance: f64,
    /// Singular values below `rcond·σ_max` are dropped in the least-squares solution.
    pub rcond: f64,
}

impl Default for RfmSettings {
    fn default() -> Self {
        RfmSettings {
            lines_hz: Vec::new(),
            eta: 0.0,
            tolerance: 1e-8,
            rcond: 1e-12,
        }
    }
}

/// The RFM against one measured FRF set.
pub struct ResponseFunctionMethod<'a> {
    /// Measured FRFs (any quantity; converted to receptance).
    pub measured: &'a FrfSet,
    /// Settings.
    pub settings: RfmSettings,
}

/// A measured DOF's load on the model: `(free DOF index, weight)` terms, `w` of (14.6).
type Load = Vec<(usize, f64)>;

/// `wᵀ v` for a load `w` and a model vector given by `v(i)`.
fn read(load: &Load, v: impl Fn(usize) -> c64) -> c64 {
    load.iter()
        .fold(c64::new(0.0, 0.0), |acc, &(i, w)| acc + v(i) * w)
}

/// Puts the measured responses into the analytical column `hat = α_A w_e` (Visser and
/// Imregun's substitution), so that `w_rᵀ hat` is the measured value for every measured
/// response `r`. A response that is one model DOF `a` times `w` sets `hat[a] = h_r / w` — the
/// plain substitution, exactly as without a map when `w = 1`. Responses that combine several
/// model DOFs (interpolated or skewed sensors) cannot be written into entries; `hat` then gets
/// the least change that makes the measured values exact, `hat += W_rᵀ g` with
/// `(W_r W_rᵀ) g = h − W_r α_A w_e` (minimum norm; dependent rows by the pseudo-inverse at
/// `rcond`), which is the substitution again when the loads are single DOFs.
fn measured_in_place(
    hat: &mut [c64],
    resp: &[(Load, usize)],
    measured: &[c64],
    model_h: &[c64],
    rcond: f64,
) {
    let single = resp.iter().all(|(l, _)| l.len() == 1);
    let mut rows: Vec<usize> = resp.iter().map(|(l, _)| l[0].0).collect();
    rows.sort_unstable();
    rows.dedup();
    if single && rows.len() == resp.len() {
        for ((l, _), h) in resp.iter().zip(measured) {
            let (a, w) = l[0];
            hat[a] = h / w;
        }
        return;
    }
    let m = resp.len();
    let gram = Mat::from_fn(m, m, |c, d| {
        let mut g = 0.0;
        for &(a, wa) in &resp[c].0 {
            for &(b, wb) in &resp[d].0 {
                if a == b {
                    g += wa * wb;
                }
            }
        }
        g
    });
    let gap: Vec<c64> = measured.iter().zip(model_h).map(|(h, a)| h - a).collect();
    let re = least_squares(
        gram.as_ref(),
        &gap.iter().map(|v| v.re).collect::<Vec<_>>(),
        rcond,
    );
    let im = least_squares(
        gram.as_ref(),
        &gap.iter().map(|v| v.im).collect::<Vec<_>>(),
        rcond,
    );
    for (c, (l, _)) in resp.iter().enumerate() {
        let g = c64::new(re[c], im[c]);
        for &(a, w) in l {
            hat[a] += g * w;
        }
    }
}

/// `A x` for sparse `A` and complex `x`.
fn spmv(a: &SparseMatrix, x: &[c64]) -> Vec<c64> {
    let mut y = vec![c64::new(0.0, 0.0); a.nrows()];
    let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    for j in 0..a.ncols() {
        let xj = x[j];
        if xj.re == 0.0 && xj.im == 0.0 {
            continue;
        }
        for k in cp[j]..cp[j + 1] {
            y[ri[k]] += xj * v[k];
        }
    }
    y
}

impl ResponseFunctionMethod<'_> {
    /// Measured line index of each chosen line.
    fn line_indices(&self) -> Result<Vec<usize>, UpdatingError> {
        let f = &self.measured.freqs_hz;
        self.settings
            .lines_hz
            .iter()
            .map(|&l| {
                f.iter()
                    .position(|&x| (x - l).abs() <= 1e-9 * l.abs().max(1.0))
                    .ok_or_else(|| {
                        UpdatingError::Settings(format!(
                            "RFM line {l} Hz is not a measured line (measured {} lines, {} … {} Hz)",
                            f.len(),
                            f.first().copied().unwrap_or(f64::NAN),
                            f.last().copied().unwrap_or(f64::NAN)
                        ))
                    })
            })
            .collect()
    }
}

impl UpdateMethod for ResponseFunctionMethod<'_> {
    fn iterate(
        &self,
        model: &dyn ParametricModel,
        values: &[f64],
        iteration: usize,
    ) -> Result<Step, UpdatingError> {
        let s = &self.settings;
        let n_par = values.len();
        if s.lines_hz.is_empty() {
            return Err(UpdatingError::Settings(
                "the RFM needs at least one line in `lines_hz`".into(),
            ));
        }
        let lines = self.line_indices()?;
        let ev = model.evaluate(values)?;
        let sys = &ev.system;
        let index: HashMap<DofId, usize> = sys.dof_index();
        let free = |d: &DofId| {
            index.get(d).copied().ok_or_else(|| {
                UpdatingError::Data(format!(
                    "measured DOF {d} is not a free DOF of the model ({} DOFs)",
                    sys.n()
                ))
            })
        };
        // A measured DOF's load on the model: itself with weight 1, or through a test map its
        // weighted model DOFs (14.6), constrained ones dropped (they move with zero).
        let load = |d: &DofId| -> Result<Load, UpdatingError> {
            let Some(map) = model.sensors() else {
                return Ok(vec![(free(d)?, 1.0)]);
            };
            let terms = map.get(d).ok_or_else(|| {
                UpdatingError::Data(format!("measured DOF {d} is not in the test map"))
            })?;
            let l: Load = terms
                .iter()
                .filter(|(_, w)| *w != 0.0)
                .filter_map(|(a, w)| index.get(a).map(|&i| (i, *w)))
                .collect();
            if l.is_empty() {
                return Err(UpdatingError::Data(format!(
                    "measured DOF {d}: the test map names only constrained DOFs or DOFs the model does not have ({})",
                    terms
                        .iter()
                        .map(|(a, w)| format!("{w:.4} × {a}"))
                        .collect::<Vec<_>>()
                        .join(" + ")
                )));
            }
            Ok(l)
        };
        // Measured pairs grouped by excitation: (excitation load, [(response load, pair)]).
        type Group = (DofId, Load, Vec<(Load, usize)>);
        let mut groups: Vec<Group> = Vec::new();
        for (q, p) in self.measured.pairs.iter().enumerate() {
            let r = load(&p.response)?;
            match groups.iter_mut().find(|g| g.0 == p.excitation) {
                Some(g) => g.2.push((r, q)),
                None => groups.push((p.excitation, load(&p.excitation)?, vec![(r, q)])),
            }
        }
        let z = DynamicStiffness::new(
            sys,
            &DirectDamping {
                structural_eta: s.eta,
                rayleigh: None,
            },
        )?;
        let n = sys.n();
        // Per line: the real equations and the correlation at the line.
        type LineRows = (Vec<Vec<f64>>, Vec<f64>, f64, f64);
        let per_line: Vec<Result<LineRows, UpdatingError>> = lines
            .par_iter()
            .map(|&k| {
                let f = self.measured.freqs_hz[k];
                let w = 2.0 * PI * f;
                let factor = self.measured.quantity.factor(w);
                if factor.norm() == 0.0 && self.measured.quantity != Quantity::Receptance {
                    return Err(UpdatingError::Settings(format!(
                        "RFM line {f} Hz: a {} cannot be turned into a receptance at 0 Hz",
                        self.measured.quantity.name()
                    )));
                }
                let mut rows: Vec<Vec<f64>> = Vec::new();
                let mut rhs: Vec<f64> = Vec::new();
                let (mut xs, mut as_) = (Vec::new(), Vec::new());
                for (_, exc_load, resp) in &groups {
                    // Columns: every measured response's load `w_r`, then the excitation's
                    // `w_e`; by the symmetry of `Z`, column `c` is `(w_cᵀ α_A)ᵀ`.
                    let loads: Vec<&Load> = resp.iter().map(|(l, _)| l).chain([exc_load]).collect();
                    let mut b = Mat::<c64>::zeros(n, loads.len());
                    for (c, l) in loads.iter().enumerate() {
                        for &(j, wj) in l.iter() {
                            b[(j, c)] += c64::new(wj, 0.0);
                        }
                    }
                    let x = z.solve(f, b.as_ref(), faer::Par::rayon(0))?;
                    let exc = loads.len() - 1;
                    let model_h: Vec<c64> =
                        resp.iter().map(|(l, _)| read(l, |i| x[(i, exc)])).collect();
                    let measured: Vec<c64> = resp
                        .iter()
                        .map(|&(_, q)| self.measured.values[(k, q)] / factor)
                        .collect();
                    // α̂_X w_e: the analytical column with the measured values in place.
                    let mut hat: Vec<c64> = (0..n).map(|i| x[(i, exc)]).collect();
                    measured_in_place(&mut hat, resp, &measured, &model_h, s.rcond);
                    // φ_j ∂Z_j α̂ w_e for every parameter.
                    let dz_hat: Vec<Vec<c64>> = ev
                        .derivatives
                        .iter()
                        .zip(values)
                        .map(|((dk, dm), &v)| {
                            let kx = spmv(dk, &hat);
                            let mx = spmv(dm, &hat);
                            kx.iter()
                                .zip(&mx)
                                .map(|(a, b)| (c64::new(1.0, s.eta) * a - b * (w * w)) * v)
                                .collect()
                        })
                        .collect();
                    for c in 0..resp.len() {
                        // w_rᵀ α_A ∂Z α̂ w_e = (α_A w_r)ᵀ ∂Z α̂ w_e.
                        let coeffs: Vec<c64> = dz_hat
                            .iter()
                            .map(|dzh| {
                                (0..n).fold(c64::new(0.0, 0.0), |acc, i| acc + x[(i, c)] * dzh[i])
                            })
                            .collect();
                        let res = model_h[c] - measured[c];
                        rows.push(coeffs.iter().map(|v| v.re).collect());
                        rhs.push(res.re);
                        rows.push(coeffs.iter().map(|v| v.im).collect());
                        rhs.push(res.im);
                        xs.push(measured[c]);
                        as_.push(model_h[c]);
                    }
                }
                Ok((
                    rows,
                    rhs,
                    shape_correlation(&xs, &as_),
                    amplitude_correlation(&xs, &as_),
                ))
            })
            .collect();
        let mut rows = Vec::new();
        let mut rhs = Vec::new();
        let (mut cs, mut ca) = (Vec::new(), Vec::new());
        for r in per_line {
            let (r, b, chi_s, chi_a) = r?;
            rows.extend(r);
            rhs.extend(b);
            cs.push(chi_s);
            ca.push(chi_a);
        }
        // Rows that are identically zero (imaginary parts of an undamped model) carry nothing.
        let keep: Vec<usize> = (0..rows.len())
            .filter(|&i| rows[i].iter().any(|v| *v != 0.0) || rhs[i] != 0.0)
            .collect();
        let a = Mat::from_fn(keep.len(), n_par, |i, j| rows[keep[i]][j]);
        let b: Vec<f64> = keep.iter().map(|&i| rhs[i]).collect();
        let delta = least_squares(a.as_ref(), &b, s.rcond);
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let record = IterationRecord {
            iteration,
            values: values.to_vec(),
            relative_change: delta,
            active: vec![true; n_par],
            lines_used: lines.len(),
            mean_chi_s: mean(&cs),
            mean_chi_a: mean(&ca),
            residual_norm: b.iter().map(|v| v * v).sum::<f64>().sqrt(),
            condition_limit: f64::NAN,
            smoothing: 0.0,
            smoothed_mean_chi: f64::NAN,
            diagnostics: diagnostics(a.as_ref()),
        };
        Ok(Step::new(record, None))
    }

    fn converged_by_step(&self, relative_change: &[f64]) -> bool {
        relative_change
            .iter()
            .all(|d| d.abs() < self.settings.tolerance)
    }
}
