//! Dataset 55 records to one set of test modes: real shapes over the measured DOFs, in
//! ascending frequency.
//!
//! A complex shape is made real by the rotation that maximises the norm of its real part,
//! `θ = ½ arg Σ φ_i²`, `φ_real = Re(φ e^{−iθ})`; how far it was from real is its mode phase
//! collinearity `MPC = (|Σ φ_i²| / Σ |φ_i|²)²` (1 for a real or monophase shape, 0 for a
//! circular one; the eigenvalue form of Pappa's MPC). The sign is fixed so the largest
//! component is positive. Values are in each node's displacement frame, as read; a DOF whose
//! value is zero in every mode was not measured and is left out (note 15 of the dataset
//! description pads unused directions with zeros).

use super::dataset55::{ModeKind55, Uff55};
use super::{UffError, UffFile};
use crate::core::{Component, DofId};
use faer::{Mat, c64};
use std::collections::{BTreeMap, BTreeSet};

/// Modes read from a test: what correlation and updating need, and what they came from.
#[derive(Clone, Debug, PartialEq)]
pub struct TestModes {
    /// Rows of the shapes, ascending by node then component.
    pub dofs: Vec<DofId>,
    /// Undamped natural frequencies, Hz, ascending.
    pub freqs_hz: Vec<f64>,
    /// Real shapes, one column per mode, as measured (not mass-normalised).
    pub shapes: Mat<f64>,
    /// Viscous damping ratio per mode.
    pub damping_ratios: Vec<f64>,
    /// Mode phase collinearity per mode (1 for a real shape).
    pub collinearity: Vec<f64>,
    /// Modal mass per mode as written (0 when the file gives none).
    pub modal_mass: Vec<f64>,
    /// Mode number per mode (record 7 field 4).
    pub source_mode: Vec<i64>,
    /// Line of each mode's dataset.
    pub source_line: Vec<usize>,
    /// What was converted or assumed.
    pub notes: Vec<String>,
}

/// The components of a dataset 55 record's values, in order (note 3 of the description).
fn components(per_node: usize) -> &'static [Component] {
    &Component::ALL[..per_node]
}

/// `(θ, MPC)` of a complex shape: the rotation to real and the mode phase collinearity.
pub fn realisation(phi: &[c64]) -> (f64, f64) {
    let sum_sq: c64 = phi.iter().map(|v| v * v).sum();
    let sum_abs: f64 = phi.iter().map(|v| v.norm_sqr()).sum();
    if sum_abs == 0.0 {
        return (0.0, 1.0);
    }
    let theta = 0.5 * sum_sq.im.atan2(sum_sq.re);
    let mpc = (sum_sq.norm() / sum_abs).powi(2);
    (theta, mpc)
}

/// The modes of a file's dataset 55 records.
pub fn to_test_modes(file: &UffFile) -> Result<TestModes, UffError> {
    let records = &file.shapes;
    if records.is_empty() {
        return Err(UffError::NoShapes {
            skipped: file.skipped_shapes,
        });
    }
    // Two records of one mode number (and load case) are a contradiction, not two modes.
    let mut by_mode: BTreeMap<(i64, i64), &Uff55> = BTreeMap::new();
    for r in records {
        if let Some(first) = by_mode.insert((r.load_case, r.mode), r) {
            return Err(UffError::ShapeConflict {
                file: r.file.clone(),
                line: r.line,
                what: format!(
                    "dataset 55 of mode {} (load case {}) appears twice",
                    r.mode, r.load_case
                ),
                first: first.line,
            });
        }
    }
    let mut notes = Vec::new();
    // Every DOF any record gives a non-zero value.
    let mut measured: BTreeSet<DofId> = BTreeSet::new();
    let mut all: BTreeSet<DofId> = BTreeSet::new();
    for r in records {
        for (node, values) in &r.nodes {
            for (comp, v) in components(r.per_node).iter().zip(values) {
                let d = DofId::new(*node, *comp);
                all.insert(d);
                if *v != c64::new(0.0, 0.0) {
                    measured.insert(d);
                }
            }
        }
    }
    let dofs: Vec<DofId> = measured.iter().copied().collect();
    let dropped = all.len() - dofs.len();
    if dropped > 0 {
        notes.push(format!(
            "{}: {dropped} DOF(s) zero in every mode left out as not measured",
            records[0].file
        ));
    }
    let row: BTreeMap<DofId, usize> = dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let mut order: Vec<&Uff55> = records.iter().collect();
    order.sort_by(|a, b| {
        let fa = a.kind.frequency_and_damping().0;
        let fb = b.kind.frequency_and_damping().0;
        fa.total_cmp(&fb).then(a.mode.cmp(&b.mode))
    });
    let m = order.len();
    let mut out = TestModes {
        dofs,
        freqs_hz: Vec::with_capacity(m),
        shapes: Mat::zeros(row.len(), m),
        damping_ratios: Vec::with_capacity(m),
        collinearity: Vec::with_capacity(m),
        modal_mass: Vec::with_capacity(m),
        source_mode: Vec::with_capacity(m),
        source_line: Vec::with_capacity(m),
        notes,
    };
    let mut complex_modes = 0;
    for (c, r) in order.iter().enumerate() {
        let (f, zeta) = r.kind.frequency_and_damping();
        if !(f.is_finite() && f >= 0.0) {
            return Err(UffError::ShapeConflict {
                file: r.file.clone(),
                line: r.line,
                what: format!("mode {} has frequency {f} Hz", r.mode),
                first: r.line,
            });
        }
        let mut phi = vec![c64::new(0.0, 0.0); row.len()];
        for (node, values) in &r.nodes {
            for (comp, v) in components(r.per_node).iter().zip(values) {
                if let Some(&i) = row.get(&DofId::new(*node, *comp)) {
                    phi[i] = *v;
                }
            }
        }
        let (theta, mpc) = if r.complex {
            complex_modes += 1;
            realisation(&phi)
        } else {
            (0.0, 1.0)
        };
        let rot = c64::new(theta.cos(), -theta.sin());
        let mut real: Vec<f64> = phi.iter().map(|v| (v * rot).re).collect();
        let big = real
            .iter()
            .copied()
            .fold(0.0_f64, |a, v| if v.abs() > a.abs() { v } else { a });
        if big < 0.0 {
            real.iter_mut().for_each(|v| *v = -*v);
        }
        for (i, v) in real.into_iter().enumerate() {
            out.shapes[(i, c)] = v;
        }
        out.freqs_hz.push(f);
        out.damping_ratios.push(zeta);
        out.collinearity.push(mpc);
        out.modal_mass.push(match r.kind {
            ModeKind55::Normal { modal_mass, .. } => modal_mass,
            ModeKind55::Complex { .. } => 0.0,
        });
        out.source_mode.push(r.mode);
        out.source_line.push(r.line);
        if mpc < 0.9 {
            out.notes.push(format!(
                "{}:{}: mode {} at {f:.4} Hz is strongly complex (MPC {mpc:.3}); its real part after the best rotation is used",
                r.file, r.line, r.mode
            ));
        }
    }
    if complex_modes > 0 {
        out.notes.push(format!(
            "{}: {complex_modes} complex mode(s) made real by the rotation that maximises their real part; natural frequency |λ|/2π and damping ratio −Re λ/|λ| from the eigenvalue (rad/s)",
            records[0].file
        ));
    }
    Ok(out)
}
