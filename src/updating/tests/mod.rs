//! The updating methods on the four-DOF chain of C1 (thesis §2.5.3): truth all masses 1 kg,
//! analytical model `m2 = 1.3 kg`, five springs `1e4 N/m`, the four masses as parameters.
//!
//! The tests are grouped by topic in the submodules; the models and measurements more than
//! one of them uses are built here.

mod analyses;
mod damping;
mod predictor_corrector;
mod rfm;
mod sensitivities;
mod sensors;

use super::*;
use crate::eigen::ModeSelection;
use crate::fe::lumped::{LumpedTarget, assemble_lumped, lumped_derivative};
use crate::frf::{DirectDamping, FrfSet, ModalDamping, Quantity, direct_receptance};
use crate::model::LumpedModel;

/// The four-DOF chain (springs 1e4 N/m) with `masses`, each mass an updating parameter.
pub(crate) fn chain_model(masses: &[f64]) -> LinearModel {
    let lumped = LumpedModel::chain(masses, 1e4);
    let sys = assemble_lumped(&lumped).unwrap();
    let params = (0..masses.len())
        .map(|i| {
            let (dk, dm) = lumped_derivative(&lumped, LumpedTarget::Mass(i)).unwrap();
            (
                UpdatingParameter {
                    name: format!("m{}", i + 1),
                    initial: masses[i],
                    lower: 0.01,
                    upper: 100.0,
                },
                dk,
                dm,
            )
        })
        .collect();
    LinearModel::new(sys, params).unwrap()
}

/// The true chain's (1 kg masses) receptances to a force at its first DOF, structural
/// damping `eta`.
pub(crate) fn measured(eta: f64, freqs: &[f64]) -> FrfSet {
    let sys = assemble_lumped(&LumpedModel::chain(&[1.0; 4], 1e4)).unwrap();
    let pairs = FrfSet::all_pairs(&sys.dofs, &sys.dofs[..1]);
    direct_receptance(
        &sys,
        &DirectDamping {
            structural_eta: eta,
            rayleigh: None,
        },
        &pairs,
        freqs,
        Quantity::Receptance,
    )
    .unwrap()
}

/// The clamped bent plate without its bar, thickness parameters on strips 1, 4 and 9: the
/// model of the FRF sensitivity checks.
pub(super) fn clamped_plate_three_strips() -> crate::model::Model {
    bent_plate_with_strip_thicknesses(
        crate::model::generate::BentPlate {
            clamped: true,
            with_bar: false,
            ..Default::default()
        },
        &[1, 4, 9],
    )
}

/// Its three measured DOFs, uz at the free corner (the excitation) and two more.
pub(super) fn three_measured_dofs() -> Vec<crate::core::DofId> {
    ["113:uz", "56:uz", "110:uz"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect()
}

/// The C2 bent plate of `geometry` with the thicknesses of `strips` as parameters (bounds
/// 0.1–10 mm), named `t<strip>`.
fn bent_plate_with_strip_thicknesses(
    geometry: crate::model::generate::BentPlate,
    strips: &[usize],
) -> crate::model::Model {
    use crate::model::{Parameter, ParameterKind};
    let mut model = crate::model::generate::bent_plate(&geometry);
    for s in strips {
        model.parameters.push(Parameter {
            name: format!("t{s}"),
            kind: ParameterKind::ShellThickness,
            set: format!("strip_{s}"),
            lower: 1e-4,
            upper: 1e-2,
        });
    }
    model
}

/// Modal receptances of the true chain (all masses 1 kg) with per-mode `damping`.
fn measured_with_modal_damping(damping: &ModalDamping, freqs: &[f64]) -> FrfSet {
    let sys = assemble_lumped(&LumpedModel::chain(&[1.0; 4], 1e4)).unwrap();
    let (modes, _) = crate::eigen::lowest_modes(
        &sys.k,
        &sys.m,
        &sys.dofs,
        ModeSelection::All,
        &Default::default(),
    )
    .unwrap();
    let pairs = FrfSet::all_pairs(&sys.dofs, &sys.dofs[..1]);
    crate::frf::modal_receptance(
        &modes,
        &sys.dofs,
        damping,
        &pairs,
        freqs,
        Quantity::Receptance,
    )
    .unwrap()
}
