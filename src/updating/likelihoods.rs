//! The likelihoods of the Laplace posterior and of TMCMC ([`super::posterior`], docs/theory.md
//! §12, §15): what each updating method fits, predicted at parameter values with its Jacobian
//! in unity coordinates — modal FRFs (P-C), FRFs by direct solution (RFM), FRFs over modal
//! damping (damping identification), natural-frequency ratios and MAC-paired mode shapes
//! (inverse eigensensitivity, TMCMC), FRFs up to the scale or phase the correlation coefficients
//! `χ_s`, `χ_a` are blind to (TMCMC) — and
//! the natural frequencies of the predictive bands.

use super::eigensensitivity::mac_pairs;
use super::model::{ModalState, ParametricModel, UpdatingError};
use super::posterior::{FrfLayout, Likelihood, Prediction};
use crate::core::DofId;
use crate::core::sparse::SparseMatrix;
use crate::eigen::ModeSelection;
use crate::frf::direct::DynamicStiffness;
use crate::frf::{DirectDamping, FrfSet, ModalDamping, Quantity};
use crate::sensitivity::{
    ModalFrfModel, damping_sensitivities, eigenvalue_sensitivity, frf_sensitivities,
    mode_shape_sensitivities,
};
use faer::{Mat, MatRef, c64};
use rayon::prelude::*;
use std::f64::consts::PI;

/// The elastic natural frequencies of a model (Hz) and their unity derivatives
/// `∂f_r/∂u_j = φ_j ∂λ_r/∂φ_j / (8π² f_r)` (5.3), for the predictive bands.
pub struct NaturalFrequencies<'a> {
    /// The model.
    pub model: &'a dyn ParametricModel,
    /// Its modal basis.
    pub selection: ModeSelection,
    /// How many elastic modes to report at most.
    pub count: usize,
    /// Report the elastic modes up to this frequency, Hz.
    pub max_hz: f64,
}

impl NaturalFrequencies<'_> {
    /// The reported modes: the first `count` elastic ones up to `max_hz`.
    fn elastic(&self, eigenvalues: &[f64]) -> Vec<usize> {
        (0..eigenvalues.len())
            .filter(|&r| eigenvalues[r] > 0.0 && eigenvalues[r].sqrt() / (2.0 * PI) <= self.max_hz)
            .take(self.count)
            .collect()
    }

    /// Their natural frequencies, Hz.
    fn elastic_hz(&self, eigenvalues: &[f64]) -> Vec<f64> {
        self.elastic(eigenvalues)
            .iter()
            .map(|&r| eigenvalues[r].sqrt() / (2.0 * PI))
            .collect()
    }

    /// The frequencies of [`Self::at`] at a posterior sample, from
    /// [`super::model::sample_state`] and without sensitivities.
    pub fn sampled(&self, values: &[f64]) -> Result<Vec<f64>, UpdatingError> {
        let state = super::model::sample_state(self.model, values, self.selection)?;
        Ok(self.elastic_hz(&state.modes.eigenvalues))
    }

    /// `(f_r, ∂f_r/∂u)` of the first `count` elastic modes at `values`.
    #[allow(clippy::type_complexity)]
    pub fn at(&self, values: &[f64]) -> Result<(Vec<f64>, Vec<Vec<f64>>), UpdatingError> {
        let (state, _) = self.model.modal_state(values, self.selection)?;
        let dl: Vec<Vec<f64>> = state
            .projected
            .iter()
            .map(|d| eigenvalue_sensitivity(&state.modes.eigenvalues, d))
            .collect();
        let elastic = self.elastic(&state.modes.eigenvalues);
        let f = self.elastic_hz(&state.modes.eigenvalues);
        let g = elastic
            .iter()
            .zip(&f)
            .map(|(&r, &fr)| {
                (0..values.len())
                    .map(|j| dl[j][r] / (8.0 * PI * PI * fr))
                    .collect()
            })
            .collect();
        Ok((f, g))
    }
}

/// The rows of a complex FRF likelihood: for each line, each pair, `Re` then `Im`.
fn stack_frf(values: MatRef<'_, c64>, lines: &[usize]) -> Vec<f64> {
    let mut out = Vec::with_capacity(2 * lines.len() * values.ncols());
    for &k in lines {
        for q in 0..values.ncols() {
            let h = values[(k, q)];
            out.push(h.re);
            out.push(h.im);
        }
    }
    out
}

fn pair_labels(measured: &FrfSet) -> Vec<String> {
    measured
        .pairs
        .iter()
        .map(|p| format!("{}/{}", p.response, p.excitation))
        .collect()
}

/// The data half of [`Likelihood`] for the FRF likelihoods: everything but `predict`, read from
/// their `data: FrfData` (one noise group per FRF, never pooled).
macro_rules! frf_data_rows {
    () => {
        fn measured(&self) -> &[f64] {
            &self.data.y
        }
        fn groups(&self) -> &[usize] {
            &self.data.groups
        }
        fn group_names(&self) -> Vec<String> {
            self.data.layout.pairs.clone()
        }
        fn pooled(&self) -> bool {
            false
        }
        fn scale(&self) -> Vec<f64> {
            self.data.scale.clone()
        }
        fn frf_layout(&self) -> Option<FrfLayout> {
            Some(self.data.layout.clone())
        }
    };
}

/// The measured side shared by the FRF likelihoods.
struct FrfData {
    y: Vec<f64>,
    groups: Vec<usize>,
    scale: Vec<f64>,
    layout: FrfLayout,
}

impl FrfData {
    fn new(measured: &FrfSet, lines: &[usize]) -> Self {
        let y = stack_frf(measured.values.as_ref(), lines);
        let nq = measured.pairs.len();
        let groups = (0..y.len()).map(|i| (i / 2) % nq).collect();
        let scale = (0..y.len())
            .map(|i| y[2 * (i / 2)].hypot(y[2 * (i / 2) + 1]))
            .collect();
        FrfData {
            y,
            groups,
            scale,
            layout: FrfLayout {
                freqs_hz: lines.iter().map(|&k| measured.freqs_hz[k]).collect(),
                pairs: pair_labels(measured),
            },
        }
    }
}

/// Jacobian rows from `∂H/∂u` per parameter (`N_lines × N_pairs` each), stacked like
/// [`stack_frf`].
fn stack_jacobian(sens: &[Mat<c64>], rows: usize) -> Mat<f64> {
    Mat::from_fn(rows, sens.len(), |i, c| {
        let (kq, part) = (i / 2, i % 2);
        let nq = sens[c].ncols();
        let h = sens[c][(kq / nq, kq % nq)];
        if part == 0 { h.re } else { h.im }
    })
}

/// The output-error likelihood of a modal FRF model (the P-C's predictions): `H` by modal
/// summation with the method's modal damping, `∂H/∂u` from the exact modal sensitivities (§3;
/// with the static correction of the truncated modes when the model gives the physical
/// matrices).
pub struct ModalFrfLikelihood<'a> {
    model: &'a dyn ParametricModel,
    measured: &'a FrfSet,
    lines: Vec<usize>,
    selection: ModeSelection,
    damping: ModalDamping,
    data: FrfData,
}

impl<'a> ModalFrfLikelihood<'a> {
    /// On `lines` (indices of measured lines) of `measured`.
    pub fn new(
        model: &'a dyn ParametricModel,
        measured: &'a FrfSet,
        lines: Vec<usize>,
        selection: ModeSelection,
        damping: ModalDamping,
    ) -> Self {
        let data = FrfData::new(measured, &lines);
        ModalFrfLikelihood {
            model,
            measured,
            lines,
            selection,
            damping,
            data,
        }
    }
}

/// Every measured line except those within `resonance_lines` line spacings of a natural
/// frequency of the model at `values` when the predictions are undamped (undefined there).
pub fn likelihood_lines(
    model: &dyn ParametricModel,
    measured: &FrfSet,
    values: &[f64],
    selection: ModeSelection,
    undamped: bool,
    resonance_lines: f64,
) -> Result<Vec<usize>, UpdatingError> {
    if !undamped {
        return Ok((0..measured.freqs_hz.len()).collect());
    }
    let (state, _) = model.modal_state(values, selection)?;
    Ok(super::pc::off_resonance_lines(
        &measured.freqs_hz,
        &state.modes.frequencies_hz(),
        resonance_lines.max(1.0),
    ))
}

fn restrict(set: &FrfSet, lines: &[usize]) -> Mat<c64> {
    Mat::from_fn(lines.len(), set.pairs.len(), |i, q| {
        set.values[(lines[i], q)]
    })
}

impl ModalFrfLikelihood<'_> {
    /// The stacked rows of the modal prediction at `state`, at the likelihood's lines.
    fn rows_at(&self, state: &ModalState) -> Result<Vec<f64>, UpdatingError> {
        let predicted = super::pc::predict(state, self.measured, &self.damping)?;
        let h = restrict(&predicted, &self.lines);
        let all: Vec<usize> = (0..self.lines.len()).collect();
        Ok(stack_frf(h.as_ref(), &all))
    }
}

impl Likelihood for ModalFrfLikelihood<'_> {
    frf_data_rows!();

    fn predict_sample(&self, values: &[f64]) -> Result<Vec<f64>, UpdatingError> {
        let state = super::model::sample_state(self.model, values, self.selection)?;
        self.rows_at(&state)
    }

    fn predict(&self, values: &[f64], jacobian: bool) -> Result<Prediction, UpdatingError> {
        let (state, evaluated) = self.model.modal_state(values, self.selection)?;
        let out = self.rows_at(&state)?;
        let jacobian = if jacobian {
            Some(modal_jacobian(
                &state,
                evaluated.as_ref(),
                values,
                self.measured,
                &self.data.layout.freqs_hz,
                &self.damping,
                out.len(),
            )?)
        } else {
            None
        };
        Ok(Prediction {
            values: out,
            jacobian,
        })
    }
}

fn modal_jacobian(
    state: &ModalState,
    evaluated: Option<&super::model::Evaluated>,
    values: &[f64],
    measured: &FrfSet,
    freqs_hz: &[f64],
    damping: &ModalDamping,
    rows: usize,
) -> Result<Mat<f64>, UpdatingError> {
    let dofs = measured.dofs();
    let shapes = state.shapes_at(&dofs)?;
    let modal = ModalFrfModel {
        eigenvalues: &state.modes.eigenvalues,
        shapes: shapes.as_ref(),
        dofs: &dofs,
        damping,
    };
    let corrections = match evaluated {
        Some(ev) => Some(state.shape_corrections(ev, values, &dofs)?),
        None => None,
    };
    let sens = frf_sensitivities(
        &modal,
        &measured.pairs,
        freqs_hz,
        measured.quantity,
        &state.projected,
        corrections.as_deref(),
    )?;
    Ok(stack_jacobian(&sens, rows))
}

/// The modal damping of every mode of the basis from the parameter values.
pub type DampingOf<'a> = Box<dyn Fn(&[f64]) -> ModalDamping + Sync + 'a>;

/// The output-error likelihood of the modal damping identification: the spatial model fixed
/// on `state`, the parameters the loss factors (or ratios) of `modes`, `∂H/∂u` from the exact
/// damping sensitivities (6.8, 6.11).
pub struct DampingLikelihood<'a> {
    state: &'a ModalState,
    measured: &'a FrfSet,
    lines: Vec<usize>,
    /// The damping of every mode of the basis from the parameter values.
    damping: DampingOf<'a>,
    modes: Vec<usize>,
    data: FrfData,
}

impl<'a> DampingLikelihood<'a> {
    /// On `lines` of `measured`; `damping` maps parameter values to the basis's damping,
    /// `modes` are the identified modes (0-based), one per parameter.
    pub fn new(
        state: &'a ModalState,
        measured: &'a FrfSet,
        lines: Vec<usize>,
        damping: DampingOf<'a>,
        modes: Vec<usize>,
    ) -> Self {
        let data = FrfData::new(measured, &lines);
        DampingLikelihood {
            state,
            measured,
            lines,
            damping,
            modes,
            data,
        }
    }
}

impl Likelihood for DampingLikelihood<'_> {
    frf_data_rows!();

    fn predict(&self, values: &[f64], jacobian: bool) -> Result<Prediction, UpdatingError> {
        let damping = (self.damping)(values);
        let predicted = super::pc::predict(self.state, self.measured, &damping)?;
        let h = restrict(&predicted, &self.lines);
        let all: Vec<usize> = (0..self.lines.len()).collect();
        let out = stack_frf(h.as_ref(), &all);
        let jacobian = if jacobian {
            let dofs = self.measured.dofs();
            let shapes = self.state.shapes_at(&dofs)?;
            let modal = ModalFrfModel {
                eigenvalues: &self.state.modes.eigenvalues,
                shapes: shapes.as_ref(),
                dofs: &dofs,
                damping: &damping,
            };
            let per_mode = damping_sensitivities(
                &modal,
                &self.measured.pairs,
                &self.data.layout.freqs_hz,
                self.measured.quantity,
            )?;
            let cols = super::damping::unity_columns(&per_mode, &self.modes, values);
            Some(stack_jacobian(&cols, out.len()))
        } else {
            None
        };
        Ok(Prediction {
            values: out,
            jacobian,
        })
    }
}

/// `A x` for sparse `A` and complex `x`.
fn spmv(a: &SparseMatrix, x: &[c64]) -> Vec<c64> {
    let mut y = vec![c64::new(0.0, 0.0); a.nrows()];
    let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    for j in 0..a.ncols() {
        for k in cp[j]..cp[j + 1] {
            y[ri[k]] += x[j] * v[k];
        }
    }
    y
}

/// The output-error likelihood of the full model's direct FRFs (the RFM's predictions):
/// `α = Z(ω)⁻¹`, `Z = (1 + iη)K − ω²M`, and the exact sensitivity
/// `∂α_ij/∂u = −φ_p (Z⁻¹e_i)ᵀ (∂Z/∂φ_p) (Z⁻¹e_j)` (§3, `Z` symmetric), in the measured quantity;
/// through a test map `e_i` is the measured DOF's weights `w_i` on model DOFs (14.7).
pub struct DirectFrfLikelihood<'a> {
    model: &'a dyn ParametricModel,
    measured: &'a FrfSet,
    eta: f64,
    data: FrfData,
}

impl<'a> DirectFrfLikelihood<'a> {
    /// On `lines` of `measured` with the uniform structural loss factor `eta`.
    pub fn new(
        model: &'a dyn ParametricModel,
        measured: &'a FrfSet,
        lines: Vec<usize>,
        eta: f64,
    ) -> Self {
        let data = FrfData::new(measured, &lines);
        DirectFrfLikelihood {
            model,
            measured,
            eta,
            data,
        }
    }
}

impl Likelihood for DirectFrfLikelihood<'_> {
    frf_data_rows!();

    fn predict(&self, values: &[f64], jacobian: bool) -> Result<Prediction, UpdatingError> {
        let ev = self.model.evaluate(values)?;
        let sys = &ev.system;
        let index = sys.dof_index();
        // The distinct DOFs every pair needs, solved once per line.
        let mut dofs: Vec<crate::core::DofId> = Vec::new();
        for p in &self.measured.pairs {
            for d in [p.response, p.excitation] {
                if !dofs.contains(&d) {
                    dofs.push(d);
                }
            }
        }
        // Each measured DOF as weighted unit loads on model rows: itself with weight 1, or
        // through a test map `w_t` (14.7), so that `h_ij = w_iᵀ Z⁻¹ w_j`.
        let loads: Vec<Vec<(usize, f64)>> = match self.model.sensors() {
            None => dofs
                .iter()
                .map(|d| {
                    index.get(d).map(|&r| vec![(r, 1.0)]).ok_or_else(|| {
                        UpdatingError::Data(format!(
                            "measured DOF {d} is not a free DOF of the model"
                        ))
                    })
                })
                .collect::<Result<_, _>>()?,
            Some(map) => {
                let (model, w) = map
                    .resolve(&dofs, |d| index.contains_key(d))
                    .map_err(|e| UpdatingError::Data(e.to_string()))?;
                let rows: Vec<usize> = model.iter().map(|d| index[d]).collect();
                w.0.into_iter()
                    .map(|t| t.into_iter().map(|(k, w)| (rows[k], w)).collect())
                    .collect()
            }
        };
        let at = |x: &Mat<c64>, i: usize, j: usize| {
            let (&(r0, w0), rest) = loads[i].split_first().expect("a load has a term");
            (rest.iter()).fold(x[(r0, j)] * w0, |acc, &(r, w)| acc + x[(r, j)] * w)
        };
        let col = |d: &crate::core::DofId| dofs.iter().position(|x| x == d).unwrap_or(0);
        let pairs: Vec<(usize, usize)> = (self.measured.pairs.iter())
            .map(|p| (col(&p.response), col(&p.excitation)))
            .collect();
        let z = DynamicStiffness::new(
            sys,
            &DirectDamping {
                structural_eta: self.eta,
                rayleigh: None,
            },
        )?;
        let n = sys.n();
        let eta = self.eta;
        let per_line: Vec<(Vec<c64>, Vec<Vec<c64>>)> = self
            .data
            .layout
            .freqs_hz
            .par_iter()
            .map(|&f| {
                let w = 2.0 * PI * f;
                let factor = self.measured.quantity.factor(w);
                let factor = if self.measured.quantity == Quantity::Receptance {
                    c64::new(1.0, 0.0)
                } else {
                    factor
                };
                let mut b = Mat::<c64>::zeros(n, loads.len());
                for (c, load) in loads.iter().enumerate() {
                    for &(r, w) in load {
                        b[(r, c)] += c64::new(w, 0.0);
                    }
                }
                let x = z.solve(f, b.as_ref(), faer::Par::Seq)?;
                let h: Vec<c64> = pairs.iter().map(|&(i, j)| at(&x, i, j) * factor).collect();
                let mut d = Vec::new();
                if jacobian {
                    let cols: Vec<Vec<c64>> = (0..loads.len())
                        .map(|c| (0..n).map(|i| x[(i, c)]).collect())
                        .collect();
                    for ((dk, dm), &v) in ev.derivatives.iter().zip(values) {
                        // ∂Z x_j for every solved column j.
                        let dz: Vec<Vec<c64>> = cols
                            .iter()
                            .map(|xc| {
                                let (kx, mx) = (spmv(dk, xc), spmv(dm, xc));
                                kx.iter()
                                    .zip(&mx)
                                    .map(|(a, b)| c64::new(1.0, eta) * a - b * (w * w))
                                    .collect()
                            })
                            .collect();
                        d.push(
                            pairs
                                .iter()
                                .map(|&(i, j)| {
                                    let s = (0..n).fold(c64::new(0.0, 0.0), |acc, k| {
                                        acc + cols[i][k] * dz[j][k]
                                    });
                                    -s * v * factor
                                })
                                .collect(),
                        );
                    }
                }
                Ok((h, d))
            })
            .collect::<Result<_, UpdatingError>>()?;
        let nq = pairs.len();
        let mut out = Vec::with_capacity(2 * nq * per_line.len());
        for (h, _) in &per_line {
            for v in h {
                out.push(v.re);
                out.push(v.im);
            }
        }
        let jacobian = jacobian.then(|| {
            Mat::from_fn(out.len(), values.len(), |i, c| {
                let (kq, part) = (i / 2, i % 2);
                let v = per_line[kq / nq].1[c][kq % nq];
                if part == 0 { v.re } else { v.im }
            })
        });
        Ok(Prediction {
            values: out,
            jacobian,
        })
    }
}

/// The likelihood of measured modal data: natural frequencies, and optionally mode shapes.
///
/// Frequency rows `f_A,r/f_X,r` against 1, so that a noise level is a relative frequency error;
/// Jacobian `(φ_j ∂λ_r/∂φ_j)/(8π² f_A,r f_X,r)` (5.3). Without shapes the pairs are held as
/// given. With shapes at measured DOFs every evaluation pairs each measured mode with the model
/// mode of highest MAC (greedy, in measured order) and adds one row per measured DOF: the
/// measured shape scaled to unit length, `x̂`, against the model shape `a` at those DOFs scaled
/// by the least-squares modal scale factor, `g = a (aᵀx̂)/(aᵀa)` — so `|x̂ − g|² = 1 − MAC` and a
/// noise level is that of a unit-length measured shape's components. `∂g` follows from the
/// mode-shape sensitivities `∂a` ([`mode_shape_sensitivities`], with the static correction of
/// the truncated modes when the model gives its matrices):
/// `∂g = [∂a (aᵀx̂) + a (∂aᵀx̂)]/(aᵀa) − 2 a (aᵀx̂)(aᵀ∂a)/(aᵀa)²`.
pub struct ModalDataLikelihood<'a> {
    model: &'a dyn ParametricModel,
    selection: ModeSelection,
    /// `(measured f_X in Hz, index of the paired model mode)`; the index is only used without
    /// shapes.
    pairs: Vec<(f64, usize)>,
    /// The measured DOFs and the unit-length measured shapes there (`DOFs × modes`).
    shapes: Option<(Vec<DofId>, Mat<f64>)>,
    y: Vec<f64>,
    groups: Vec<usize>,
}

impl<'a> ModalDataLikelihood<'a> {
    /// Natural frequencies only. `pairs`: each measured frequency (Hz) with the index of its
    /// model mode in the basis.
    pub fn new(
        model: &'a dyn ParametricModel,
        selection: ModeSelection,
        pairs: Vec<(f64, usize)>,
    ) -> Self {
        let y = vec![1.0; pairs.len()];
        let groups = (0..pairs.len()).collect();
        ModalDataLikelihood {
            model,
            selection,
            pairs,
            shapes: None,
            y,
            groups,
        }
    }

    /// With the measured shapes at `dofs` (`DOFs × modes`, one column per measured frequency,
    /// in order): MAC-paired at every evaluation, one row per DOF and mode; the noise group of
    /// mode `r`'s shape rows is `modes + r`.
    pub fn with_shapes(
        mut self,
        dofs: Vec<DofId>,
        shapes: MatRef<'_, f64>,
    ) -> Result<Self, UpdatingError> {
        let nx = self.pairs.len();
        if shapes.ncols() != nx || shapes.nrows() != dofs.len() || dofs.is_empty() {
            return Err(UpdatingError::Data(format!(
                "{} measured shapes at {} DOFs for {nx} measured frequencies and {} DOFs",
                shapes.ncols(),
                shapes.nrows(),
                dofs.len()
            )));
        }
        let mut unit = shapes.to_owned();
        for r in 0..nx {
            let norm = (0..dofs.len())
                .map(|i| unit[(i, r)].powi(2))
                .sum::<f64>()
                .sqrt();
            if !(norm > 0.0 && norm.is_finite()) {
                return Err(UpdatingError::Data(format!(
                    "the measured shape of the mode at {:.4} Hz is zero (or not finite) at the measured DOFs",
                    self.pairs[r].0
                )));
            }
            for i in 0..dofs.len() {
                unit[(i, r)] /= norm;
            }
        }
        for r in 0..nx {
            for i in 0..dofs.len() {
                self.y.push(unit[(i, r)]);
                self.groups.push(nx + r);
            }
        }
        self.shapes = Some((dofs, unit));
        Ok(self)
    }

    /// The paired model mode of every measured mode at `state`, and the model shapes at the
    /// measured DOFs (with shapes).
    fn paired(&self, state: &ModalState) -> Result<(Vec<usize>, Option<Mat<f64>>), UpdatingError> {
        let lambda = &state.modes.eigenvalues;
        let Some((dofs, unit)) = &self.shapes else {
            let modes: Vec<usize> = self.pairs.iter().map(|&(_, a)| a).collect();
            if let Some(&a) = modes.iter().find(|&&a| a >= lambda.len()) {
                return Err(UpdatingError::Data(format!(
                    "mode {} left the modal basis of {} modes",
                    a + 1,
                    lambda.len()
                )));
            }
            return Ok((modes, None));
        };
        let a = state.shapes_at(dofs)?;
        let elastic: Vec<usize> = (0..lambda.len()).filter(|&r| lambda[r] > 0.0).collect();
        let modes = mac_pairs(unit.as_ref(), a.as_ref(), &elastic, 0.0)
            .into_iter()
            .zip(&self.pairs)
            .map(|(p, &(fx, _))| {
                p.map(|(r, _)| r).ok_or_else(|| {
                    UpdatingError::Data(format!(
                        "no elastic model mode is left to pair with the measured mode at {fx:.4} Hz: widen the modal basis"
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
        Ok((modes, Some(a)))
    }

    /// The rows at `state` for the paired `modes`.
    fn rows(&self, lambda: &[f64], modes: &[usize], a: Option<&Mat<f64>>) -> Vec<f64> {
        let mut out: Vec<f64> = self
            .pairs
            .iter()
            .zip(modes)
            .map(|(&(fx, _), &r)| lambda[r].max(0.0).sqrt() / (2.0 * PI) / fx)
            .collect();
        if let (Some((_, unit)), Some(a)) = (&self.shapes, a) {
            for (x, &r) in modes.iter().enumerate() {
                let (aa, ax) = shape_products(a.as_ref(), r, unit.as_ref(), x);
                let msf = if aa > 0.0 { ax / aa } else { 0.0 };
                out.extend((0..a.nrows()).map(|i| msf * a[(i, r)]));
            }
        }
        out
    }
}

/// `(aᵀa, aᵀx̂)` of model mode `r` and measured mode `x`.
fn shape_products(a: MatRef<'_, f64>, r: usize, unit: MatRef<'_, f64>, x: usize) -> (f64, f64) {
    (0..a.nrows()).fold((0.0, 0.0), |(aa, ax), i| {
        (aa + a[(i, r)] * a[(i, r)], ax + a[(i, r)] * unit[(i, x)])
    })
}

impl Likelihood for ModalDataLikelihood<'_> {
    fn measured(&self) -> &[f64] {
        &self.y
    }
    fn groups(&self) -> &[usize] {
        &self.groups
    }
    fn group_names(&self) -> Vec<String> {
        let freq = self.pairs.iter().map(|(f, _)| format!("{f:.6} Hz"));
        match &self.shapes {
            None => freq.collect(),
            Some(_) => {
                let shapes = self.pairs.iter().map(|(f, _)| format!("shape {f:.6} Hz"));
                freq.chain(shapes).collect()
            }
        }
    }
    fn pooled(&self) -> bool {
        true
    }
    fn scale(&self) -> Vec<f64> {
        vec![1.0; self.y.len()]
    }

    fn predict_sample(&self, values: &[f64]) -> Result<Vec<f64>, UpdatingError> {
        let state = super::model::sample_state(self.model, values, self.selection)?;
        let (modes, a) = self.paired(&state)?;
        Ok(self.rows(&state.modes.eigenvalues, &modes, a.as_ref()))
    }

    fn predict(&self, values: &[f64], jacobian: bool) -> Result<Prediction, UpdatingError> {
        let (state, evaluated) = self.model.modal_state(values, self.selection)?;
        let lambda = &state.modes.eigenvalues;
        let (modes, a) = self.paired(&state)?;
        let out = self.rows(lambda, &modes, a.as_ref());
        if !jacobian {
            return Ok(Prediction {
                values: out,
                jacobian: None,
            });
        }
        let np = values.len();
        let nx = self.pairs.len();
        let mut jac = Mat::<f64>::zeros(out.len(), np);
        for (j, d) in state.projected.iter().enumerate() {
            let dl = eigenvalue_sensitivity(lambda, d);
            for (x, (&(fx, _), &r)) in self.pairs.iter().zip(&modes).enumerate() {
                let fa = lambda[r].max(0.0).sqrt() / (2.0 * PI);
                jac[(x, j)] = dl[r] / (8.0 * PI * PI * fa.max(f64::MIN_POSITIVE) * fx);
            }
        }
        if let (Some((dofs, unit)), Some(a)) = (&self.shapes, &a) {
            let corrections = match &evaluated {
                Some(ev) => Some(state.shape_corrections(ev, values, dofs)?),
                None => None,
            };
            let da = mode_shape_sensitivities(
                lambda,
                a.as_ref(),
                &modes,
                &state.projected,
                corrections.as_deref(),
            );
            let nd = dofs.len();
            for (j, da) in da.iter().enumerate() {
                for (x, &r) in modes.iter().enumerate() {
                    let (aa, ax) = shape_products(a.as_ref(), r, unit.as_ref(), x);
                    if aa <= 0.0 {
                        continue;
                    }
                    let (mut dax, mut ada) = (0.0, 0.0);
                    for i in 0..nd {
                        dax += da[(i, x)] * unit[(i, x)];
                        ada += a[(i, r)] * da[(i, x)];
                    }
                    for i in 0..nd {
                        jac[(nx + x * nd + i, j)] = (da[(i, x)] * ax + a[(i, r)] * dax) / aa
                            - 2.0 * a[(i, r)] * ax * ada / (aa * aa);
                    }
                }
            }
        }
        Ok(Prediction {
            values: out,
            jacobian: Some(jac),
        })
    }
}

/// Which correlation coefficient a [`CorrelationLikelihood`] is built on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coefficient {
    /// `χ_s` (4.8): the FRFs up to a complex scale per line.
    Shape,
    /// `χ_a` (4.9): the FRFs up to a phase per line.
    Amplitude,
}

/// The likelihood of a correlation coefficient (the P-C's objective, §4): the measured FRFs at
/// a line, `x`, against the modal prediction `a` with what the coefficient is blind to fitted
/// at that line — for `χ_s` a complex scale, `p = a (aᴴx)/(aᴴa)`, and then
/// `|x − p|² = X (1 − χ_s)`; for `χ_a` a phase, `p = a e^{i arg(aᴴx)}`, and
/// `|x − p|² = X + A − 2|c| = (X + A)(1 − χ_a)`. The rows are those of the FRF likelihoods
/// (per line, per pair, real then imaginary part) and so is the noise: the Gaussian of the
/// residuals is the FRF output error with the scale (phase) of every line profiled out — the
/// likelihood of data whose force calibration (phase reference) is not trusted, on the
/// coefficient the P-C drives to 1. The evidence counts every row; the two (one) degrees of
/// freedom a line's fit takes are not subtracted. `∂p` from the modal FRF sensitivities:
/// `∂p = (∂s) a + s ∂a`, `s = u/A` (`u = aᴴx`) with `∂s = (∂a)ᴴx/A − u 2Re(aᴴ∂a)/A²`, or
/// `s = u/|u|` with `∂s = ∂u/|u| − u Re(ū ∂u)/|u|³`.
pub struct CorrelationLikelihood<'a> {
    frf: ModalFrfLikelihood<'a>,
    coefficient: Coefficient,
}

impl<'a> CorrelationLikelihood<'a> {
    /// On `lines` (indices of measured lines) of `measured`, predicted by modal summation.
    pub fn new(
        model: &'a dyn ParametricModel,
        measured: &'a FrfSet,
        lines: Vec<usize>,
        selection: ModeSelection,
        damping: ModalDamping,
        coefficient: Coefficient,
    ) -> Self {
        CorrelationLikelihood {
            frf: ModalFrfLikelihood::new(model, measured, lines, selection, damping),
            coefficient,
        }
    }

    /// The fitted predictions and, given the FRF Jacobian, theirs, from the FRF rows `h`
    /// (stacked as [`stack_frf`]).
    fn fitted(&self, h: &[f64], dh: Option<&Mat<f64>>) -> (Vec<f64>, Option<Mat<f64>>) {
        let nq = self.frf.measured.pairs.len();
        let np = dh.map_or(0, |d| d.ncols());
        let mut out = vec![0.0; h.len()];
        let mut jac = dh.map(|_| Mat::<f64>::zeros(h.len(), np));
        let y = &self.frf.data.y;
        let at = |v: &dyn Fn(usize) -> f64, base: usize, q: usize| {
            c64::new(v(base + 2 * q), v(base + 2 * q + 1))
        };
        for l in 0..self.frf.lines.len() {
            let base = 2 * nq * l;
            let x: Vec<c64> = (0..nq).map(|q| at(&|i| y[i], base, q)).collect();
            let a: Vec<c64> = (0..nq).map(|q| at(&|i| h[i], base, q)).collect();
            let u = a
                .iter()
                .zip(&x)
                .fold(c64::new(0.0, 0.0), |s, (a, x)| s + a.conj() * x);
            let aa: f64 = a.iter().map(|a| a.norm_sqr()).sum();
            let s = match self.coefficient {
                _ if aa == 0.0 || u.norm() == 0.0 => c64::new(0.0, 0.0),
                Coefficient::Shape => u / aa,
                Coefficient::Amplitude => u / u.norm(),
            };
            for q in 0..nq {
                let p = s * a[q];
                out[base + 2 * q] = p.re;
                out[base + 2 * q + 1] = p.im;
            }
            let (Some(d), Some(j)) = (dh, jac.as_mut()) else {
                continue;
            };
            if s == c64::new(0.0, 0.0) {
                continue;
            }
            for c in 0..np {
                let da: Vec<c64> = (0..nq).map(|q| at(&|i| d[(i, c)], base, q)).collect();
                let du = da
                    .iter()
                    .zip(&x)
                    .fold(c64::new(0.0, 0.0), |s, (d, x)| s + d.conj() * x);
                let ds = match self.coefficient {
                    Coefficient::Shape => {
                        let daa: f64 = 2.0
                            * a.iter()
                                .zip(&da)
                                .map(|(a, d)| (a.conj() * d).re)
                                .sum::<f64>();
                        du / aa - u * (daa / (aa * aa))
                    }
                    Coefficient::Amplitude => {
                        let n = u.norm();
                        du / n - u * ((u.conj() * du).re / (n * n * n))
                    }
                };
                for q in 0..nq {
                    let dp = ds * a[q] + s * da[q];
                    j[(base + 2 * q, c)] = dp.re;
                    j[(base + 2 * q + 1, c)] = dp.im;
                }
            }
        }
        (out, jac)
    }
}

impl Likelihood for CorrelationLikelihood<'_> {
    fn measured(&self) -> &[f64] {
        self.frf.measured()
    }
    fn groups(&self) -> &[usize] {
        self.frf.groups()
    }
    fn group_names(&self) -> Vec<String> {
        self.frf.group_names()
    }
    fn pooled(&self) -> bool {
        false
    }
    fn scale(&self) -> Vec<f64> {
        self.frf.scale()
    }
    fn frf_layout(&self) -> Option<FrfLayout> {
        self.frf.frf_layout()
    }

    fn predict_sample(&self, values: &[f64]) -> Result<Vec<f64>, UpdatingError> {
        let h = self.frf.predict_sample(values)?;
        Ok(self.fitted(&h, None).0)
    }

    fn predict(&self, values: &[f64], jacobian: bool) -> Result<Prediction, UpdatingError> {
        let h = self.frf.predict(values, jacobian)?;
        let (values, jacobian) = self.fitted(&h.values, h.jacobian.as_ref());
        Ok(Prediction { values, jacobian })
    }
}
