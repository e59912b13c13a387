//! The `modal_correlation` artefact: two sets of modes compared (thesis §1.4, 3.54), as tables a
//! user can plot without femu.
//!
//! | table (Parquet) | columns |
//! |---|---|
//! | `pairs` | `reference_mode, predicted_mode, reference_hz, predicted_hz, eigenvalue_error, frequency_error, mac, in_band` |
//! | `mac` | `reference_mode, predicted_mode, mac` (every elastic pair) |
//! | `comac` | `dof, comac` |

use super::kinds::{ColumnLayout, TableLayout, col};
use super::{Artefact, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::correlation::ModeCorrelation;

/// What the tables are read against.
#[derive(Clone, Debug)]
pub struct ModalCorrelationContext<'a> {
    /// Natural frequencies of every reference mode, Hz.
    pub reference_hz: &'a [f64],
    /// Natural frequencies of every predicted mode, Hz.
    pub predicted_hz: &'a [f64],
    /// Rigid-body modes left out, (reference, predicted).
    pub rigid_body_modes: (usize, usize),
    /// Rows the shapes were compared over.
    pub dofs: &'a [DofId],
    /// Top of the validity band, Hz (pairs above it are `in_band = 0`).
    pub band_hz: Option<f64>,
    /// How pairs were found (`mac` or `order`) and the lowest MAC accepted.
    pub pairing: (&'a str, f64),
}

/// The comparison as an artefact; its meta holds the summary: pairs, unpaired reference modes,
/// the largest `|ε_λ|` and the smallest MAC among in-band pairs.
pub fn modal_correlation_to_artefact(
    c: &ModeCorrelation,
    at: &ModalCorrelationContext,
) -> Artefact {
    let in_band: Vec<bool> = c
        .pairs
        .iter()
        .map(|p| at.band_hz.is_none_or(|b| at.reference_hz[p.reference] <= b))
        .collect();
    let pairs = Table::new()
        .with(
            "reference_mode",
            Column::I64(c.pairs.iter().map(|p| p.reference as i64 + 1).collect()),
        )
        .with(
            "predicted_mode",
            Column::I64(c.pairs.iter().map(|p| p.predicted as i64 + 1).collect()),
        )
        .with(
            "reference_hz",
            Column::F64(
                c.pairs
                    .iter()
                    .map(|p| at.reference_hz[p.reference])
                    .collect(),
            ),
        )
        .with(
            "predicted_hz",
            Column::F64(
                c.pairs
                    .iter()
                    .map(|p| at.predicted_hz[p.predicted])
                    .collect(),
            ),
        )
        .with(
            "eigenvalue_error",
            Column::F64(c.pairs.iter().map(|p| p.eigenvalue_error).collect()),
        )
        .with(
            "frequency_error",
            Column::F64(c.pairs.iter().map(|p| p.frequency_error).collect()),
        )
        .with("mac", Column::F64(c.pairs.iter().map(|p| p.mac).collect()))
        .with(
            "in_band",
            Column::I64(in_band.iter().map(|b| *b as i64).collect()),
        );
    let (rr, pr) = at.rigid_body_modes;
    let (mut ri, mut pj, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..c.mac.nrows() {
        for j in 0..c.mac.ncols() {
            ri.push((i + rr + 1) as i64);
            pj.push((j + pr + 1) as i64);
            v.push(c.mac[(i, j)]);
        }
    }
    let mac = Table::new()
        .with("reference_mode", Column::I64(ri))
        .with("predicted_mode", Column::I64(pj))
        .with("mac", Column::F64(v));
    let comac = Table::new()
        .with(
            "dof",
            Column::Str(at.dofs.iter().map(|d| d.to_string()).collect()),
        )
        .with("comac", Column::F64(c.comac.clone()));
    let banded = || {
        c.pairs
            .iter()
            .zip(&in_band)
            .filter(|(_, b)| **b)
            .map(|(p, _)| p)
    };
    let max_error = banded()
        .map(|p| p.eigenvalue_error.abs())
        .fold(0.0, f64::max);
    let min_mac = banded().map(|p| p.mac).fold(f64::INFINITY, f64::min);
    Artefact::new(ArtefactKind::ModalCorrelation)
        .with_meta("pairing", at.pairing.0.into())
        .with_meta("min_mac_accepted", at.pairing.1.into())
        .with_meta(
            "rigid_body_modes",
            serde_json::json!({"reference": rr, "predicted": pr}),
        )
        .with_meta("n_dofs", at.dofs.len().into())
        .with_meta("band_hz", at.band_hz.into())
        .with_meta("n_pairs", c.pairs.len().into())
        .with_meta(
            "n_pairs_in_band",
            in_band.iter().filter(|b| **b).count().into(),
        )
        .with_meta(
            "unpaired_reference_modes",
            c.unpaired.iter().map(|r| r + 1).collect::<Vec<_>>().into(),
        )
        .with_meta("max_abs_eigenvalue_error_in_band", max_error.into())
        .with_meta(
            "min_mac_in_band",
            if min_mac.is_finite() {
                min_mac.into()
            } else {
                serde_json::Value::Null
            },
        )
        .with_table("pairs", pairs, Storage::Parquet)
        .with_table("mac", mac, Storage::Parquet)
        .with_table("comac", comac, Storage::Parquet)
}

/// Published layout of `modal_correlation`.
pub fn layout() -> Vec<TableLayout> {
    let t = |name, columns: Vec<ColumnLayout>| TableLayout {
        name,
        storage: "parquet",
        required: true,
        columns,
    };
    vec![
        t(
            "pairs",
            vec![
                col(
                    "reference_mode",
                    "int64",
                    "",
                    "reference mode, 1-based over all modes",
                ),
                col(
                    "predicted_mode",
                    "int64",
                    "",
                    "its partner, 1-based over all modes",
                ),
                col(
                    "reference_hz",
                    "float64",
                    "Hz",
                    "reference natural frequency",
                ),
                col(
                    "predicted_hz",
                    "float64",
                    "Hz",
                    "predicted natural frequency",
                ),
                col(
                    "eigenvalue_error",
                    "float64",
                    "",
                    "relative eigenvalue error (lambda - lambda_ref)/lambda_ref (3.54)",
                ),
                col("frequency_error", "float64", "", "(f - f_ref)/f_ref"),
                col(
                    "mac",
                    "float64",
                    "",
                    "modal assurance criterion of the pair (1.18)",
                ),
                col(
                    "in_band",
                    "int64",
                    "",
                    "1 when the reference mode is in the validity band",
                ),
            ],
        ),
        t(
            "mac",
            vec![
                col(
                    "reference_mode",
                    "int64",
                    "",
                    "elastic reference mode, 1-based",
                ),
                col(
                    "predicted_mode",
                    "int64",
                    "",
                    "elastic predicted mode, 1-based",
                ),
                col("mac", "float64", "", "their MAC"),
            ],
        ),
        t(
            "comac",
            vec![
                col("dof", "string", "", "shape row node:comp"),
                col("comac", "float64", "", "coordinate MAC over the pairs"),
            ],
        ),
    ]
}
