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
//! (docs/theory.md (14.7)) a measured DOF must be one model DOF times a weight `w` (a grid along
//! a model axis, e.g. a −Z sensor): the measured value enters `α_X` divided by `w_r w_e` and
//! each equation is scaled back by `w_r w_e`.

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
        // A measured DOF's model row and weight: itself with 1, or through a test map the one
        // model DOF it is a multiple of (the RFM puts measured values into the model's
        // receptance column, which a combination of several DOFs cannot enter).
        let row = |d: &DofId| -> Result<(usize, f64), UpdatingError> {
            let Some(map) = model.sensors() else {
                return Ok((free(d)?, 1.0));
            };
            match map.get(d) {
                Some([(a, w)]) if *w != 0.0 => Ok((free(a)?, *w)),
                Some(terms) => Err(UpdatingError::Data(format!(
                    "the RFM reads measured DOF {d} as one model DOF, but the test map makes it a combination of {} ({}); pair the test points to grids (method: nearest) along model axes, or use the P-C",
                    terms.len(),
                    terms
                        .iter()
                        .map(|(a, w)| format!("{w:.4} × {a}"))
                        .collect::<Vec<_>>()
                        .join(" + ")
                ))),
                None => Err(UpdatingError::Data(format!(
                    "measured DOF {d} is not in the test map"
                ))),
            }
        };
        // Measured pairs grouped by excitation, with the product of the pair's map weights.
        type Group = (usize, Vec<(usize, usize, f64)>); // (exc row, [(resp row, pair, w_r w_e)])
        let mut groups: Vec<Group> = Vec::new();
        for (q, p) in self.measured.pairs.iter().enumerate() {
            let ((r, wr), (e, we)) = (row(&p.response)?, row(&p.excitation)?);
            match groups.iter_mut().find(|g| g.0 == e) {
                Some(g) => g.1.push((r, q, wr * we)),
                None => groups.push((e, vec![(r, q, wr * we)])),
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
                for (e, resp) in &groups {
                    // Columns: every measured response row, then the excitation.
                    let mut cols: Vec<usize> = resp.iter().map(|(r, ..)| *r).collect();
                    cols.push(*e);
                    let mut b = Mat::<c64>::zeros(n, cols.len());
                    for (c, &j) in cols.iter().enumerate() {
                        b[(j, c)] = c64::new(1.0, 0.0);
                    }
                    let x = z.solve(f, b.as_ref(), faer::Par::rayon(0))?;
                    let exc = cols.len() - 1;
                    // α̂_Xi: analytical column with the measured entries in place.
                    let mut hat: Vec<c64> = (0..n).map(|i| x[(i, exc)]).collect();
                    let mut measured = Vec::with_capacity(resp.len());
                    for &(r, q, w) in resp {
                        // The model's receptance between the two model DOFs (14.7).
                        let v = self.measured.values[(k, q)] / factor / w;
                        hat[r] = v;
                        measured.push(v);
                    }
                    // φ_j ∂Z_j α̂ for every parameter.
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
                    for (c, &(r, _, wq)) in resp.iter().enumerate() {
                        // Row r of α_A is column r (Z symmetric).
                        let coeffs: Vec<c64> = dz_hat
                            .iter()
                            .map(|dzh| {
                                (0..n).fold(c64::new(0.0, 0.0), |acc, i| acc + x[(i, c)] * dzh[i])
                            })
                            .collect();
                        // In the measured pair's own scale: `w_r w_e` times the model's.
                        let res = (x[(r, exc)] - measured[c]) * wq;
                        rows.push(coeffs.iter().map(|v| (v * wq).re).collect());
                        rhs.push(res.re);
                        rows.push(coeffs.iter().map(|v| (v * wq).im).collect());
                        rhs.push(res.im);
                        xs.push(measured[c] * wq);
                        as_.push(x[(r, exc)] * wq);
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
