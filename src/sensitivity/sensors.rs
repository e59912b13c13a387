//! Measured DOFs as weighted combinations of model DOFs (docs/theory.md §14, (14.7)–(14.9)).
//!
//! A test map makes every measured DOF `t` the sum `u_t = Σ_a w_ta u_a` over model DOFs `a`
//! (shape functions × direction cosines, (14.6)); stacked, `u_test = W u`. Every quantity the
//! methods read at measured DOFs is linear in the rows it reads, so it follows the map by
//! reading it at the model DOFs the map names and combining the rows with `W`: mode shapes
//! `W Φ`, Wang's corrections `W ρ`, residual flexibilities `W R Wᵀ` and their derivatives, hence
//! the FRFs `W_r H W_eᵀ` (14.7) and every sensitivity `W_r ∂H W_eᵀ` (14.8). Without a map every
//! measured DOF is the model DOF of its own name with weight 1, which reads the rows as they
//! are, bit for bit.

use crate::core::DofId;
use faer::{Mat, MatRef};
use std::collections::BTreeMap;

/// Each measured DOF's weighted model DOFs: `u_t = Σ w_ta u_a` (14.6).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SensorMap {
    terms: BTreeMap<DofId, Vec<(DofId, f64)>>,
}

/// A measured DOF the map does not name.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("measured DOF {dof} is not in the test map; the map holds {known}")]
pub struct UnmappedDof {
    /// The measured DOF.
    pub dof: DofId,
    /// A short list of the DOFs the map holds.
    pub known: String,
}

impl SensorMap {
    /// The map from `(measured DOF, [(model DOF, weight)])` rows; rows of one measured DOF add.
    pub fn new(rows: impl IntoIterator<Item = (DofId, Vec<(DofId, f64)>)>) -> Self {
        let mut terms: BTreeMap<DofId, Vec<(DofId, f64)>> = BTreeMap::new();
        for (t, w) in rows {
            terms.entry(t).or_default().extend(w);
        }
        SensorMap { terms }
    }

    /// The weighted model DOFs of `dof`, if the map names it.
    pub fn get(&self, dof: &DofId) -> Option<&[(DofId, f64)]> {
        self.terms.get(dof).map(Vec::as_slice)
    }

    /// Whether the map names no measured DOF.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// The model DOFs `measured` reads, each once in order of first use, and `W` over them,
    /// keeping only the model DOFs `keep` accepts (constrained DOFs move with zero). A measured
    /// DOF the map does not name, or one left with no model DOF, is an error.
    pub fn resolve(
        &self,
        measured: &[DofId],
        keep: impl Fn(&DofId) -> bool,
    ) -> Result<(Vec<DofId>, RowWeights), ResolveError> {
        let mut model: Vec<DofId> = Vec::new();
        let mut position: BTreeMap<DofId, usize> = BTreeMap::new();
        let mut rows = Vec::with_capacity(measured.len());
        for d in measured {
            let terms = self.get(d).ok_or_else(|| {
                ResolveError::Unmapped(UnmappedDof {
                    dof: *d,
                    known: self.known(),
                })
            })?;
            let mut row = Vec::with_capacity(terms.len());
            for &(a, w) in terms {
                if !keep(&a) {
                    continue;
                }
                let i = *position.entry(a).or_insert_with(|| {
                    model.push(a);
                    model.len() - 1
                });
                row.push((i, w));
            }
            if row.is_empty() {
                return Err(ResolveError::NoModelDof {
                    dof: *d,
                    model: terms.iter().map(|(a, _)| a.to_string()).collect(),
                });
            }
            rows.push(row);
        }
        Ok((model, RowWeights(rows)))
    }

    fn known(&self) -> String {
        let mut s: Vec<String> = self.terms.keys().take(12).map(|k| k.to_string()).collect();
        if self.terms.len() > 12 {
            s.push(format!("… ({} in all)", self.terms.len()));
        }
        s.join(", ")
    }
}

/// Why measured DOFs could not be read through a map.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ResolveError {
    /// The map does not name the DOF.
    #[error(transparent)]
    Unmapped(UnmappedDof),
    /// Every model DOF the map names for it is constrained (or not in the model).
    #[error("measured DOF {dof} maps only to {}, none of them a free DOF of the model (constrained?)", model.join(", "))]
    NoModelDof {
        /// The measured DOF.
        dof: DofId,
        /// The model DOFs the map names.
        model: Vec<String>,
    },
}

/// `W`: per measured DOF, `(row, weight)` terms over the rows of a quantity read at model DOFs.
#[derive(Clone, Debug, PartialEq)]
pub struct RowWeights(pub Vec<Vec<(usize, f64)>>);

impl RowWeights {
    /// Measured DOFs.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether there is no measured DOF.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// `Σ_a w_ia a_aj`, summed from the first term (a single weight of 1 gives `a_aj` exactly).
    fn combine(terms: &[(usize, f64)], value: impl Fn(usize) -> f64) -> f64 {
        let mut it = terms.iter();
        let Some(&(r0, w0)) = it.next() else {
            return 0.0;
        };
        it.fold(w0 * value(r0), |acc, &(r, w)| acc + w * value(r))
    }

    /// `W A`: the rows of `a` (one per model DOF) combined per measured DOF.
    pub fn rows(&self, a: MatRef<'_, f64>) -> Mat<f64> {
        Mat::from_fn(self.len(), a.ncols(), |i, j| {
            Self::combine(&self.0[i], |r| a[(r, j)])
        })
    }

    /// `W A Wᵀ` of a square `a` over the model DOFs.
    pub fn both_sides(&self, a: MatRef<'_, f64>) -> Mat<f64> {
        let left = self.rows(a);
        Mat::from_fn(self.len(), self.len(), |i, j| {
            Self::combine(&self.0[j], |c| left[(i, c)])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::Component;

    fn d(n: u64, c: Component) -> DofId {
        DofId::new(n, c)
    }

    #[test]
    fn resolve_orders_model_dofs_and_drops_constrained_ones() {
        let map = SensorMap::new([
            (
                d(9001, Component::Uz),
                vec![(d(1, Component::Uz), 0.5), (d(2, Component::Uz), 0.5)],
            ),
            (d(9002, Component::Uz), vec![(d(2, Component::Uz), -1.0)]),
        ]);
        let (model, w) = map
            .resolve(&[d(9002, Component::Uz), d(9001, Component::Uz)], |_| true)
            .unwrap();
        assert_eq!(model, vec![d(2, Component::Uz), d(1, Component::Uz)]);
        assert_eq!(w.0, vec![vec![(0, -1.0)], vec![(1, 0.5), (0, 0.5)]]);
        let (model, w) = map
            .resolve(&[d(9001, Component::Uz)], |a| a.node != 1)
            .unwrap();
        assert_eq!((model.len(), w.0[0].clone()), (1, vec![(0, 0.5)]));
        assert!(matches!(
            map.resolve(&[d(9002, Component::Uz)], |a| a.node != 2),
            Err(ResolveError::NoModelDof { .. })
        ));
        let e = map.resolve(&[d(7, Component::Ux)], |_| true).unwrap_err();
        assert!(e.to_string().contains("7:ux is not in the test map"), "{e}");
    }

    #[test]
    fn unit_weights_read_rows_bit_for_bit_and_both_sides_is_w_a_wt() {
        let a = Mat::from_fn(3, 3, |i, j| {
            (i as f64 + 1.0) * 0.1 - (j as f64) * 0.37 - 0.0
        });
        let unit = RowWeights(vec![vec![(2, 1.0)], vec![(0, 1.0)]]);
        let r = unit.rows(a.as_ref());
        for j in 0..3 {
            assert_eq!(r[(0, j)].to_bits(), a[(2, j)].to_bits());
            assert_eq!(r[(1, j)].to_bits(), a[(0, j)].to_bits());
        }
        let w = RowWeights(vec![vec![(0, 0.25), (1, 0.75)], vec![(2, -1.0)]]);
        let dense = Mat::from_fn(2, 3, |i, j| {
            w.0[i].iter().filter(|t| t.0 == j).map(|t| t.1).sum::<f64>()
        });
        let expect = &dense * &a * dense.transpose();
        let got = w.both_sides(a.as_ref());
        for i in 0..2 {
            for j in 0..2 {
                assert!((got[(i, j)] - expect[(i, j)]).abs() < 1e-15);
            }
        }
    }
}
