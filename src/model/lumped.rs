//! Lumped-parameter models: point masses and springs (with optional dampers) between DOFs
//! or to ground. Enough for spring-mass chains such as the thesis's four-DOF system (§2.5.3).

use crate::core::DofId;
use std::collections::BTreeSet;

/// A point mass (or rotary inertia) on one DOF, in kg (kg·m² on a rotation).
#[derive(Clone, Debug, PartialEq)]
pub struct LumpedMass {
    /// The DOF carrying the mass.
    pub dof: DofId,
    /// Mass value in SI units.
    pub value: f64,
}

/// A spring between two DOFs, or from one DOF to ground when `to` is `None`.
#[derive(Clone, Debug, PartialEq)]
pub struct LumpedSpring {
    /// First end.
    pub from: DofId,
    /// Second end, or ground.
    pub to: Option<DofId>,
    /// Stiffness `k` in N/m (N·m/rad on rotations).
    pub stiffness: f64,
    /// Viscous damping coefficient `c` in N·s/m.
    pub viscous: f64,
    /// Structural (hysteretic) damping coefficient `d` in N/m, entering as `i d`.
    pub structural: f64,
}

/// A lumped model: its DOFs in order, masses and springs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LumpedModel {
    /// DOFs in the order of the matrices' rows.
    pub dofs: Vec<DofId>,
    /// Point masses.
    pub masses: Vec<LumpedMass>,
    /// Springs.
    pub springs: Vec<LumpedSpring>,
}

/// Why a lumped model is not valid.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LumpedModelError {
    /// A mass or spring names a DOF outside the model's list.
    #[error("{what} #{index} refers to DOF {dof}, which is not among the model's DOFs {known}")]
    UnknownDof {
        /// `mass` or `spring`.
        what: &'static str,
        /// Zero-based position in its list.
        index: usize,
        /// The offending DOF.
        dof: DofId,
        /// The valid DOFs, listed.
        known: String,
    },
    /// A DOF appears twice in the DOF list.
    #[error("DOF {0} is listed twice")]
    DuplicateDof(DofId),
    /// A value is negative or not finite.
    #[error("{what} #{index}: {field} = {value} must be finite and >= 0")]
    BadValue {
        /// `mass` or `spring`.
        what: &'static str,
        /// Zero-based position in its list.
        index: usize,
        /// Field name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A spring connects a DOF to itself.
    #[error("spring #{0} connects DOF {1} to itself; omit `to` for a spring to ground")]
    SelfLoop(usize, DofId),
    /// No DOF at all.
    #[error("the model has no DOFs")]
    Empty,
}

impl LumpedModel {
    /// Checks DOF references and values.
    pub fn validate(&self) -> Result<(), LumpedModelError> {
        if self.dofs.is_empty() {
            return Err(LumpedModelError::Empty);
        }
        let mut seen = BTreeSet::new();
        for d in &self.dofs {
            if !seen.insert(*d) {
                return Err(LumpedModelError::DuplicateDof(*d));
            }
        }
        let known = || {
            self.dofs
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let check = |what, index, field, value: f64| {
            if value.is_finite() && value >= 0.0 {
                Ok(())
            } else {
                Err(LumpedModelError::BadValue {
                    what,
                    index,
                    field,
                    value,
                })
            }
        };
        for (i, m) in self.masses.iter().enumerate() {
            if !seen.contains(&m.dof) {
                return Err(LumpedModelError::UnknownDof {
                    what: "mass",
                    index: i,
                    dof: m.dof,
                    known: known(),
                });
            }
            check("mass", i, "value", m.value)?;
        }
        for (i, s) in self.springs.iter().enumerate() {
            for d in std::iter::once(s.from).chain(s.to) {
                if !seen.contains(&d) {
                    return Err(LumpedModelError::UnknownDof {
                        what: "spring",
                        index: i,
                        dof: d,
                        known: known(),
                    });
                }
            }
            if s.to == Some(s.from) {
                return Err(LumpedModelError::SelfLoop(i, s.from));
            }
            check("spring", i, "k", s.stiffness)?;
            check("spring", i, "c", s.viscous)?;
            check("spring", i, "d", s.structural)?;
        }
        Ok(())
    }

    /// The four-DOF chain of the thesis (§2.5.3): four masses between two grounds, five
    /// springs of stiffness `k`; `masses` in kg.
    pub fn chain(masses: &[f64], k: f64) -> Self {
        let dofs: Vec<DofId> = (1..=masses.len() as u64)
            .map(|n| DofId::new(n, crate::core::Component::Ux))
            .collect();
        let mut springs = Vec::new();
        for i in 0..=dofs.len() {
            let (from, to) = match i {
                0 => (dofs[0], None),
                i if i == dofs.len() => (dofs[i - 1], None),
                i => (dofs[i - 1], Some(dofs[i])),
            };
            springs.push(LumpedSpring {
                from,
                to,
                stiffness: k,
                viscous: 0.0,
                structural: 0.0,
            });
        }
        let masses = dofs
            .iter()
            .zip(masses)
            .map(|(d, m)| LumpedMass { dof: *d, value: *m })
            .collect();
        LumpedModel {
            dofs,
            masses,
            springs,
        }
    }
}
