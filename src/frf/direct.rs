//! Receptance by direct solution of the dynamic stiffness (docs/theory.md §1, 1.14):
//! `α(ω) = Z(ω)⁻¹`, `Z(ω) = K + iD + iωC − ω² M`, one sparse complex LU per frequency line, the
//! symbolic analysis shared by all lines. Exact for any damping, proportional or not.

use super::{FrfPair, FrfSet, Quantity, convert_from_receptance};
use crate::core::DofId;
use crate::core::sparse::sparse_triplets;
use crate::fe::SystemMatrices;
use crate::sparse::{Lu, SparseSolve, SymbolicLu};
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Mat, MatRef, Par, c64};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;

/// Damping added to the model's own `C` and `D` for a direct solution.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DirectDamping {
    /// Uniform structural loss factor: `D += η K`.
    pub structural_eta: f64,
    /// Rayleigh viscous damping `C += α M + β K`, `(α, β)`.
    pub rayleigh: Option<(f64, f64)>,
}

/// Why a direct FRF could not be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DirectError {
    /// A pair names a DOF the model does not hold.
    #[error("DOF {0} is not a DOF of the model ({1} DOFs)")]
    UnknownDof(DofId, usize),
    /// `Z(ω)` is singular at a line.
    #[error(
        "the dynamic stiffness is singular at {0} Hz (an undamped resonance, or a rigid-body mode at 0 Hz); move the line or add damping"
    )]
    Singular(f64),
    /// Sparse factorisation failed for another reason.
    #[error("sparse LU failed: {0}")]
    Factorisation(String),
}

impl crate::core::InputFault for DirectError {
    fn is_input(&self) -> bool {
        matches!(self, DirectError::UnknownDof(..))
    }
}

/// Receptance (converted to `quantity`) of `pairs` at `freqs_hz` by `α = Z⁻¹`.
pub fn direct_receptance(
    sys: &SystemMatrices,
    damping: &DirectDamping,
    pairs: &[FrfPair],
    freqs_hz: &[f64],
    quantity: Quantity,
) -> Result<FrfSet, DirectError> {
    let n = sys.n();
    let index = sys.dof_index();
    let row = |d: &DofId| index.get(d).copied().ok_or(DirectError::UnknownDof(*d, n));
    // Excitation columns to solve for, and where each pair reads its answer.
    let mut excitations: Vec<usize> = Vec::new();
    let mut exc_slot: HashMap<usize, usize> = HashMap::new();
    let mut reads = Vec::with_capacity(pairs.len());
    for p in pairs {
        let (i, j) = (row(&p.response)?, row(&p.excitation)?);
        let slot = *exc_slot.entry(j).or_insert_with(|| {
            excitations.push(j);
            excitations.len() - 1
        });
        reads.push((i, slot));
    }

    let z = DynamicStiffness::new(sys, damping)?;
    let lines: Vec<Result<Vec<c64>, DirectError>> = freqs_hz
        .par_iter()
        .map(|&f| {
            let mut rhs = Mat::<c64>::zeros(n, excitations.len());
            for (s, &j) in excitations.iter().enumerate() {
                rhs[(j, s)] = c64::new(1.0, 0.0);
            }
            // Lines run in parallel; each line's factorisation and solve may split further.
            let x = z.solve(f, rhs.as_ref(), Par::rayon(0))?;
            let out: Vec<c64> = reads.iter().map(|&(i, s)| x[(i, s)]).collect();
            if out.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())) {
                return Err(DirectError::Singular(f));
            }
            Ok(out)
        })
        .collect();
    let mut values = Mat::<c64>::zeros(freqs_hz.len(), pairs.len());
    for (k, line) in lines.into_iter().enumerate() {
        for (p, v) in line?.into_iter().enumerate() {
            values[(k, p)] = v;
        }
    }
    let mut set = FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: freqs_hz.to_vec(),
        pairs: pairs.to_vec(),
        values,
    };
    convert_from_receptance(&mut set, quantity);
    Ok(set)
}

/// `Z(ω) = K + iD + iωC − ω²M` with its sparsity pattern and symbolic LU analysed once, so
/// that solving at many lines costs one numeric factorisation each.
pub struct DynamicStiffness {
    n: usize,
    /// Entries in column-major order with their `[K, M, C, D]` coefficients.
    entries: Vec<((usize, usize), [f64; 4])>,
    symbolic: SymbolicSparseColMat<usize>,
    argsort: faer::sparse::Argsort<usize>,
    symbolic_lu: SymbolicLu,
}

impl DynamicStiffness {
    /// The pattern of `K`, `M`, `C`, `D` of `sys` with `damping` added.
    pub fn new(sys: &SystemMatrices, damping: &DirectDamping) -> Result<Self, DirectError> {
        let n = sys.n();
        let (eta, (ra, rb)) = (
            damping.structural_eta,
            damping.rayleigh.unwrap_or((0.0, 0.0)),
        );
        let mut coef: HashMap<(usize, usize), [f64; 4]> = HashMap::new(); // [K, M, C, D]
        let mut add = |mat: &crate::core::sparse::SparseMatrix, slot: usize| {
            for (i, j, v) in sparse_triplets(mat) {
                coef.entry((i, j)).or_insert([0.0; 4])[slot] += v;
            }
        };
        add(&sys.k, 0);
        add(&sys.m, 1);
        if let Some(c) = &sys.c {
            add(c, 2);
        }
        if let Some(d) = &sys.d {
            add(d, 3);
        }
        let mut entries: Vec<((usize, usize), [f64; 4])> = coef.into_iter().collect();
        entries.sort_unstable_by_key(|e| (e.0.1, e.0.0));
        for (_, c) in entries.iter_mut() {
            c[2] += ra * c[1] + rb * c[0];
            c[3] += eta * c[0];
        }
        let idx: Vec<Pair<usize, usize>> = entries
            .iter()
            .map(|((i, j), _)| Pair { row: *i, col: *j })
            .collect();
        let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(n, n, &idx)
            .map_err(|e| DirectError::Factorisation(format!("{e:?}")))?;
        let symbolic_lu = SymbolicLu::new(symbolic.as_ref())
            .map_err(|e| DirectError::Factorisation(format!("{e:?}")))?;
        Ok(DynamicStiffness {
            n,
            entries,
            symbolic,
            argsort,
            symbolic_lu,
        })
    }

    /// Size of `Z`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// The LU factor of `Z(ω)` at `f_hz`, made with parallelism `par`.
    pub fn factor(&self, f_hz: f64, par: Par) -> Result<Lu<'_, c64>, DirectError> {
        let w = 2.0 * PI * f_hz;
        let vals: Vec<c64> = self
            .entries
            .iter()
            .map(|(_, [k, m, c, d])| c64::new(k - w * w * m, d + w * c))
            .collect();
        let z = SparseColMat::new_from_argsort(self.symbolic.clone(), &self.argsort, &vals)
            .map_err(|e| DirectError::Factorisation(format!("{e:?}")))?;
        Lu::new(&self.symbolic_lu, z.as_ref(), par).map_err(|_| DirectError::Singular(f_hz))
    }

    /// `Z(ω) X = rhs` at `f_hz`, factored and solved with parallelism `par`.
    pub fn solve(
        &self,
        f_hz: f64,
        rhs: MatRef<'_, c64>,
        par: Par,
    ) -> Result<Mat<c64>, DirectError> {
        let lu = self.factor(f_hz, par)?;
        let mut x = rhs.to_owned();
        lu.solve_in_place(x.as_mut(), par);
        if x.col_iter()
            .any(|c| c.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())))
        {
            return Err(DirectError::Singular(f_hz));
        }
        Ok(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eigen::{ModeSelection, dense_generalized};
    use crate::fe::lumped::assemble_lumped;
    use crate::frf::{ModalDamping, modal_receptance};
    use crate::model::LumpedModel;

    /// Modal summation over all modes with uniform `η` equals `(K(1 + iη) − ω²M)⁻¹`.
    #[test]
    fn modal_and_direct_agree_with_all_modes() {
        let sys = assemble_lumped(&LumpedModel::chain(&[1.0, 1.3, 1.0, 1.0], 1e4)).unwrap();
        let modes = dense_generalized(
            sys.k_dense().as_ref(),
            sys.m_dense().as_ref(),
            &sys.dofs,
            ModeSelection::All,
        )
        .unwrap();
        let pairs = FrfSet::all_pairs(&sys.dofs, &sys.dofs);
        let freqs = crate::frf::frequency_lines(0.0, 40.0, 0.25);
        for q in [
            Quantity::Receptance,
            Quantity::Mobility,
            Quantity::Accelerance,
        ] {
            let direct = direct_receptance(
                &sys,
                &DirectDamping {
                    structural_eta: 0.02,
                    rayleigh: None,
                },
                &pairs,
                &freqs,
                q,
            )
            .unwrap();
            let modal = modal_receptance(
                &modes,
                &sys.dofs,
                &ModalDamping::Structural(vec![0.02]),
                &pairs,
                &freqs,
                q,
            )
            .unwrap();
            for k in 0..freqs.len() {
                for p in 0..pairs.len() {
                    let (a, b) = (direct.values[(k, p)], modal.values[(k, p)]);
                    // Both are backward stable; the peak amplitude is 1/(η λ m) so allow 1e-10 relative.
                    assert!(
                        (a - b).norm() <= 1e-10 * a.norm().max(1e-12),
                        "{q:?} line {k} pair {p}: {a} vs {b}"
                    );
                }
            }
        }
    }

    /// Maxwell–Betti reciprocity: `α_ij = α_ji` for any symmetric `K`, `M`, `C`, `D`, here on the
    /// assembled bent-plate benchmark (shells and beams) with structural damping.
    #[test]
    fn receptances_are_reciprocal() {
        let model = crate::model::generate::bent_plate(&Default::default());
        let (sys, _) = crate::fe::model_assembly::assemble_model(
            &model,
            crate::fe::element::MassKind::Consistent,
        )
        .unwrap();
        let dofs: Vec<crate::core::DofId> = ["1:uz", "60:ux", "100010:ry", "120:uz"]
            .iter()
            .map(|s| s.parse().unwrap())
            .collect();
        let pairs = FrfSet::all_pairs(&dofs, &dofs);
        let r = direct_receptance(
            &sys,
            &DirectDamping {
                structural_eta: 0.01,
                rayleigh: None,
            },
            &pairs,
            &[3.0, 47.5, 160.0],
            Quantity::Receptance,
        )
        .unwrap();
        for (p, pair) in pairs.iter().enumerate() {
            let q = pairs
                .iter()
                .position(|x| x.response == pair.excitation && x.excitation == pair.response)
                .unwrap();
            // Z(ω) of a free-free shell model is ill-conditioned near its rigid-body modes
            // (cond ≈ λ_max/ω² ≈ 1e8 at 3 Hz): LU round-off alone allows ~1e-8 relative.
            for k in 0..3 {
                let (a, b) = (r.values[(k, p)], r.values[(k, q)]);
                assert!(
                    (a - b).norm() <= 1e-6 * a.norm().max(b.norm()),
                    "{pair:?} line {k}: {a} vs {b}"
                );
            }
        }
    }

    /// Two DOFs, analytic receptance: `α = adj(Z) / det(Z)`.
    #[test]
    fn two_dof_matches_the_closed_form() {
        let model = LumpedModel::chain(&[2.0, 3.0], 500.0);
        let mut sys = assemble_lumped(&model).unwrap();
        sys.c = Some(crate::core::sparse::sparse_from_triplets("C", 2, &[(0, 0, 1.5)]).unwrap());
        let pairs = FrfSet::all_pairs(&sys.dofs, &sys.dofs);
        let freqs = [0.0, 1.7, 4.2];
        let r = direct_receptance(
            &sys,
            &DirectDamping::default(),
            &pairs,
            &freqs,
            Quantity::Receptance,
        )
        .unwrap();
        for (row, f) in freqs.iter().enumerate() {
            let w = 2.0 * PI * f;
            let z11 = c64::new(1000.0 - w * w * 2.0, 1.5 * w);
            let z22 = c64::new(1000.0 - w * w * 3.0, 0.0);
            let z12 = c64::new(-500.0, 0.0);
            let det = z11 * z22 - z12 * z12;
            let exact = [z22 / det, -z12 / det, -z12 / det, z11 / det];
            for (p, e) in exact.iter().enumerate() {
                assert!((r.values[(row, p)] - e).norm() <= 1e-13 * e.norm());
            }
        }
    }

    #[test]
    fn free_body_at_zero_hz_is_singular() {
        let model = LumpedModel {
            dofs: vec!["1:ux".parse().unwrap()],
            masses: vec![crate::model::LumpedMass {
                dof: "1:ux".parse().unwrap(),
                value: 1.0,
            }],
            springs: vec![],
        };
        let sys = assemble_lumped(&model).unwrap();
        let pairs = FrfSet::all_pairs(&sys.dofs, &sys.dofs);
        let e = direct_receptance(
            &sys,
            &DirectDamping::default(),
            &pairs,
            &[0.0],
            Quantity::Receptance,
        )
        .unwrap_err();
        assert_eq!(e, DirectError::Singular(0.0));
    }
}
