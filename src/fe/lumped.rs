//! Assembly of a [`LumpedModel`] into system matrices.
//!
//! A spring of stiffness `k` between DOFs `a` and `b` adds `k [[1, −1], [−1, 1]]` to rows and
//! columns `(a, b)`; to ground it adds `k` to `(a, a)`. Dampers `c`, `d` assemble the same way into
//! `C` and `D`; masses go on the diagonal of `M`.

use super::system::{SystemMatrices, SystemMatricesError};
use crate::core::sparse::{SparseMatrix, sparse_from_triplets};
use crate::model::{LumpedModel, LumpedModelError};

/// Why a lumped model could not be assembled.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LumpedAssemblyError {
    /// The model is inconsistent.
    #[error(transparent)]
    Model(#[from] LumpedModelError),
    /// Matrix construction failed.
    #[error(transparent)]
    Matrices(#[from] SystemMatricesError),
    /// A parameter names a mass or spring the model does not have.
    #[error("{0} does not exist in the lumped model")]
    UnknownTarget(String),
}

/// Assembles `K`, `M` and, where any spring carries dampers, `C` and `D`.
pub fn assemble_lumped(model: &LumpedModel) -> Result<SystemMatrices, LumpedAssemblyError> {
    model.validate()?;
    let n = model.dofs.len();
    let index: std::collections::HashMap<_, _> = model
        .dofs
        .iter()
        .enumerate()
        .map(|(i, d)| (*d, i))
        .collect();
    let mut k = Vec::new();
    let mut c = Vec::new();
    let mut d = Vec::new();
    for s in &model.springs {
        let a = index[&s.from];
        let b = s.to.map(|t| index[&t]);
        for (list, value) in [
            (&mut k, s.stiffness),
            (&mut c, s.viscous),
            (&mut d, s.structural),
        ] {
            if value == 0.0 {
                continue;
            }
            list.push((a, a, value));
            if let Some(b) = b {
                list.push((b, b, value));
                list.push((a, b, -value));
                list.push((b, a, -value));
            }
        }
    }
    let m: Vec<_> = model
        .masses
        .iter()
        .map(|ms| (index[&ms.dof], index[&ms.dof], ms.value))
        .collect();
    let optional = |name, t: Vec<(usize, usize, f64)>| -> Result<_, SystemMatricesError> {
        if t.is_empty() {
            Ok(None)
        } else {
            Ok(Some(sparse_from_triplets(name, n, &t)?))
        }
    };
    Ok(SystemMatrices {
        dofs: model.dofs.clone(),
        k: sparse_from_triplets("K", n, &k).map_err(SystemMatricesError::from)?,
        m: sparse_from_triplets("M", n, &m).map_err(SystemMatricesError::from)?,
        c: optional("C", c)?,
        d: optional("D", d)?,
    })
}

/// What a lumped-model parameter is: the value of one mass or one spring's stiffness.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LumpedTarget {
    /// `masses[i].value`.
    Mass(usize),
    /// `springs[i].stiffness`.
    Spring(usize),
}

/// `(∂K/∂p, ∂M/∂p)` of a lumped model: the unit spring pattern or the unit mass entry (both
/// enter linearly, so the derivative is exact and constant).
pub fn lumped_derivative(
    model: &LumpedModel,
    target: LumpedTarget,
) -> Result<(SparseMatrix, SparseMatrix), LumpedAssemblyError> {
    let mut unit = LumpedModel {
        dofs: model.dofs.clone(),
        masses: Vec::new(),
        springs: Vec::new(),
    };
    match target {
        LumpedTarget::Mass(i) => {
            let mut m = model
                .masses
                .get(i)
                .ok_or_else(|| LumpedAssemblyError::UnknownTarget(format!("mass {i}")))?
                .clone();
            m.value = 1.0;
            unit.masses.push(m);
        }
        LumpedTarget::Spring(i) => {
            let mut s = model
                .springs
                .get(i)
                .ok_or_else(|| LumpedAssemblyError::UnknownTarget(format!("spring {i}")))?
                .clone();
            s.stiffness = 1.0;
            s.viscous = 0.0;
            s.structural = 0.0;
            unit.springs.push(s);
        }
    }
    let sys = assemble_lumped(&unit)?;
    Ok((sys.k, sys.m))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_dof_chain_has_the_textbook_stiffness() {
        let sys = assemble_lumped(&LumpedModel::chain(&[1.0, 1.3, 1.0, 1.0], 1e4)).unwrap();
        let k = sys.k_dense();
        let expected = [
            [2.0, -1.0, 0.0, 0.0],
            [-1.0, 2.0, -1.0, 0.0],
            [0.0, -1.0, 2.0, -1.0],
            [0.0, 0.0, -1.0, 2.0],
        ];
        for i in 0..4 {
            for j in 0..4 {
                assert_eq!(k[(i, j)], 1e4 * expected[i][j]);
            }
        }
        let m = sys.m_dense();
        assert_eq!(m[(1, 1)], 1.3);
        assert_eq!(m[(0, 1)], 0.0);
        assert!(sys.c.is_none() && sys.d.is_none());
        sys.validate().unwrap();
    }

    #[test]
    fn duplicate_entries_are_summed() {
        let a = sparse_from_triplets("K", 2, &[(0, 0, 1.0), (0, 0, 2.5), (1, 0, 1.0)]).unwrap();
        let d = crate::core::sparse::sparse_to_dense(&a);
        assert_eq!(d[(0, 0)], 3.5);
        assert_eq!(d[(1, 0)], 1.0);
    }

    #[test]
    fn unknown_dof_is_named() {
        let mut model = LumpedModel::chain(&[1.0, 1.0], 1.0);
        model.masses[0].dof = "9:ux".parse().unwrap();
        let e = assemble_lumped(&model).unwrap_err().to_string();
        assert!(e.contains("9:ux") && e.contains("1:ux, 2:ux"), "{e}");
    }
}
