//! Eigenvalue-sensitivity maps (thesis 5.1–5.3: (5.1), (5.2), (5.3); docs/theory.md §7): for each
//! chosen mode `r` and candidate `i`, `φ_i ∂λ_r/∂φ_i = φ_i φ_rᵀ(∂K/∂φ_i − λ_r ∂M/∂φ_i)φ_r`,
//! unity-based (2.16), and the same normalised per mode by its largest magnitude over the
//! candidates. Only the diagonal of the projection (4.5) is needed, so each value is one quadratic
//! form over the candidate's own DOFs.

use super::candidates::LocalDerivative;
use crate::core::sparse::SparseMatrix;
use faer::MatRef;

/// `vᵀ A v` for a sparse `A` on local rows and `v` over the same rows.
fn quadratic(a: &SparseMatrix, v: &[f64]) -> f64 {
    let col_ptr = a.symbolic().col_ptr();
    let row_idx = a.symbolic().row_idx();
    let val = a.val();
    let mut s = 0.0;
    for j in 0..a.ncols() {
        let mut cj = 0.0;
        for k in col_ptr[j]..col_ptr[j + 1] {
            cj += val[k] * v[row_idx[k]];
        }
        s += cj * v[j];
    }
    s
}

/// `φ ∂λ_r/∂φ` (5.3) of one candidate for each of `modes` (columns of `phi`, all free DOFs).
pub fn eigenvalue_sensitivities(
    derivative: &LocalDerivative,
    value: f64,
    eigenvalues: &[f64],
    phi: MatRef<'_, f64>,
    modes: &[usize],
) -> Vec<f64> {
    modes
        .iter()
        .map(|&r| {
            let v: Vec<f64> = derivative.rows.iter().map(|&i| phi[(i, r)]).collect();
            value * (quadratic(&derivative.dk, &v) - eigenvalues[r] * quadratic(&derivative.dm, &v))
        })
        .collect()
}

/// Each column of `values` (candidates × modes, row-major per candidate) divided by its largest
/// magnitude; a column of zeros stays zero.
pub fn normalise_columns(values: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n_modes = values.first().map_or(0, |v| v.len());
    let largest: Vec<f64> = (0..n_modes)
        .map(|r| values.iter().fold(0.0_f64, |a, v| a.max(v[r].abs())))
        .collect();
    values
        .iter()
        .map(|v| {
            v.iter()
                .zip(&largest)
                .map(|(x, l)| if *l > 0.0 { x / l } else { 0.0 })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eigen::{ModeSelection, SparseEigenParams, lowest_modes};
    use crate::fe::element::MassKind;
    use crate::fe::model_assembly::assemble_model;
    use crate::localisation::candidates::element_candidates;
    use crate::model::generate::{FlatPlate, PlateSupport, flat_plate, steel};
    use crate::model::{Parameter, ParameterKind};
    use crate::sensitivity::eigenvalue_sensitivity;

    fn plate() -> crate::model::Model {
        flat_plate(&FlatPlate {
            a: 0.4,
            b: 0.3,
            nx: 4,
            ny: 3,
            thickness: 2e-3,
            material: steel(),
            support: PlateSupport::ClampedEdge,
        })
    }

    fn modes(model: &crate::model::Model) -> (crate::fe::SystemMatrices, crate::eigen::Modes) {
        let (sys, _) = assemble_model(model, MassKind::Consistent).unwrap();
        let (m, _) = lowest_modes(
            &sys.k,
            &sys.m,
            &sys.dofs,
            ModeSelection::Count(4),
            &SparseEigenParams::default(),
        )
        .unwrap();
        (sys, m)
    }

    /// `φ ∂λ_r/∂φ` of one element's E and thickness equals a central difference of the
    /// re-solved eigenvalues (relative step 1e-4), and the full projection's diagonal.
    #[test]
    fn matches_a_central_difference() {
        let model = plate();
        let (sys, base) = modes(&model);
        let index = sys.dof_index();
        let chosen = [0, 1, 2, 3];
        for kind in [ParameterKind::YoungsModulus, ParameterKind::ShellThickness] {
            let c = element_candidates(&model, &kind, &[]).unwrap().remove(5);
            let d =
                LocalDerivative::new(&model, &c, &sys.dofs, &index, MassKind::Consistent).unwrap();
            let s = eigenvalue_sensitivities(
                &d,
                c.value,
                &base.eigenvalues,
                base.shapes.as_ref(),
                &chosen,
            );
            let full = eigenvalue_sensitivity(
                &base.eigenvalues,
                &d.projected(base.shapes.as_ref(), c.value),
            );
            let mut one = model.clone();
            one.sets.insert("one".into(), c.elements.clone());
            let p = Parameter {
                name: "p".into(),
                kind: kind.clone(),
                set: "one".into(),
                lower: 0.0,
                upper: 1.0,
            };
            let h = 1e-4;
            let at = |f: f64| {
                let mut m = one.clone();
                m.set_parameter_value(&p, c.value * f).unwrap();
                modes(&m).1.eigenvalues
            };
            let (up, down) = (at(1.0 + h), at(1.0 - h));
            for (k, &r) in chosen.iter().enumerate() {
                let fd = (up[r] - down[r]) / (2.0 * h);
                assert!(
                    (s[k] - fd).abs() <= 1e-5 * base.eigenvalues[r],
                    "{kind:?} mode {r}: {} vs {fd}",
                    s[k]
                );
                assert!((s[k] - full[r]).abs() <= 1e-10 * base.eigenvalues[r]);
            }
        }
    }

    #[test]
    fn normalised_per_mode() {
        let n = normalise_columns(&[vec![2.0, 0.0], vec![-4.0, 0.0], vec![1.0, 0.0]]);
        assert_eq!(n, vec![vec![0.5, 0.0], vec![-1.0, 0.0], vec![0.25, 0.0]]);
    }
}
