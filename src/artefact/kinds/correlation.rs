//! The `correlation` kind: FRF correlation, `χ_s`, `χ_a` per line (4.8, 4.9) and FRAC per FRF
//! (1.19), with a summary in the metadata.
//!
//! | table (storage) | columns |
//! |---|---|
//! | `lines` (Parquet) | `freq_hz, chi_s, chi_a` |
//! | `frac` (Parquet) | `response, excitation, frac` |

use super::{Kind, Layout, col, expect_kind, meta, parse_dofs, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::correlation::FrfCorrelation;
use crate::frf::FrfPair;

/// The `correlation` kind.
pub struct CorrelationKind;

impl Kind for CorrelationKind {
    const KIND: ArtefactKind = ArtefactKind::Correlation;
    const NAME: &'static str = "correlation";
    type Value = FrfCorrelation;

    fn layout() -> Layout {
        Layout {
            tables: vec![
                table(
                    "lines",
                    Storage::Parquet,
                    true,
                    vec![
                        col("freq_hz", "float64", "Hz", "frequency line"),
                        col(
                            "chi_s",
                            "float64",
                            "",
                            "shape correlation coefficient (4.8)",
                        ),
                        col(
                            "chi_a",
                            "float64",
                            "",
                            "amplitude correlation coefficient (4.9)",
                        ),
                    ],
                ),
                table(
                    "frac",
                    Storage::Parquet,
                    true,
                    vec![
                        col("response", "string", "", "response DOF"),
                        col("excitation", "string", "", "excitation DOF"),
                        col(
                            "frac",
                            "float64",
                            "",
                            "FRF assurance criterion over all lines (1.19)",
                        ),
                    ],
                ),
            ],
            meta: vec![meta(
                "summary",
                "mean and smallest chi_s, chi_a, mean chi (4.23), mean FRAC, lines, FRFs",
            )],
            blobs: vec![],
        }
    }

    fn to_artefact(c: &FrfCorrelation) -> Artefact {
        correlation_to_artefact(c)
    }

    fn from_artefact(a: &Artefact) -> Result<FrfCorrelation, ArtefactError> {
        correlation_from_artefact(a)
    }
}

/// A correlation as an artefact.
pub fn correlation_to_artefact(c: &FrfCorrelation) -> Artefact {
    let lines = Table::new()
        .with("freq_hz", Column::F64(c.freqs_hz.clone()))
        .with("chi_s", Column::F64(c.chi_s.clone()))
        .with("chi_a", Column::F64(c.chi_a.clone()));
    let frac = Table::new()
        .with(
            "response",
            Column::Str(c.pairs.iter().map(|p| p.response.to_string()).collect()),
        )
        .with(
            "excitation",
            Column::Str(c.pairs.iter().map(|p| p.excitation.to_string()).collect()),
        )
        .with("frac", Column::F64(c.frac.clone()));
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    Artefact::new(CorrelationKind::KIND)
        .with_meta(
            "summary",
            serde_json::json!({
                "mean_chi_s": c.mean_chi_s(),
                "mean_chi_a": c.mean_chi_a(),
                "mean_chi": c.mean_chi(),
                "min_chi_s": min(&c.chi_s),
                "min_chi_a": min(&c.chi_a),
                "mean_frac": if c.frac.is_empty() { 0.0 } else { c.frac.iter().sum::<f64>() / c.frac.len() as f64 },
                "n_lines": c.freqs_hz.len(),
                "n_frfs": c.pairs.len(),
            }),
        )
        .with_table("lines", lines, Storage::Parquet)
        .with_table("frac", frac, Storage::Parquet)
}

/// A correlation from an artefact.
pub fn correlation_from_artefact(a: &Artefact) -> Result<FrfCorrelation, ArtefactError> {
    let kind = ArtefactKind::Correlation;
    expect_kind(a, kind)?;
    let l = a.table("lines")?;
    let fr = a.table("frac")?;
    let resp = parse_dofs(kind, "frac", fr.strs("frac", "response")?)?;
    let exc = parse_dofs(kind, "frac", fr.strs("frac", "excitation")?)?;
    Ok(FrfCorrelation {
        freqs_hz: l.f64s("lines", "freq_hz")?.to_vec(),
        chi_s: l.f64s("lines", "chi_s")?.to_vec(),
        chi_a: l.f64s("lines", "chi_a")?.to_vec(),
        pairs: resp
            .into_iter()
            .zip(exc)
            .map(|(response, excitation)| FrfPair {
                response,
                excitation,
            })
            .collect(),
        frac: fr.f64s("frac", "frac")?.to_vec(),
    })
}
