//! The `eigenvalue_sensitivity` kind: eigenvalue sensitivities (5.3) of candidate parameters
//! for chosen modes (docs/theory.md §7), as tables a user can plot without femu.
//!
//! | table (Parquet) | columns |
//! |---|---|
//! | `sensitivities` | `candidate, mode, freq_hz, value, normalised` |
//! | `modes` | `mode, freq_hz, largest` |
//! | `members` | `candidate, element` |

use super::leverage::{members_layout, members_of, members_table, read_members};
use super::{Kind, Layout, col, expect_kind, meta, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::localisation::EigenMap;

/// One row of `sensitivities`.
#[derive(Clone, Debug, PartialEq)]
pub struct SensitivityRow {
    /// Parameter name, or `e<id>`.
    pub candidate: String,
    /// Mode number, 1-based over all modes.
    pub mode: i64,
    /// Its natural frequency, Hz.
    pub freq_hz: f64,
    /// `φ_i ∂λ_r/∂φ_i` (5.3).
    pub value: f64,
    /// `value / max |value|` of the mode.
    pub normalised: f64,
}

/// An eigenvalue-sensitivity map as stored.
#[derive(Clone, Debug, PartialEq)]
pub struct EigenSensitivityRecord {
    /// Candidates (the `candidates` count in the metadata).
    pub candidates: usize,
    /// Candidate-major, mode-minor.
    pub sensitivities: Vec<SensitivityRow>,
    /// Per mode: number, natural frequency (Hz), max |value| over candidates.
    pub modes: Vec<(i64, f64, f64)>,
    /// `(candidate, element)` for every element of every candidate.
    pub members: Vec<(String, i64)>,
}

impl EigenSensitivityRecord {
    /// The record of `map`.
    pub fn new(map: &EigenMap) -> Self {
        let mut sensitivities = Vec::new();
        for (i, c) in map.candidates.iter().enumerate() {
            for (k, &m) in map.modes.iter().enumerate() {
                sensitivities.push(SensitivityRow {
                    candidate: c.name.clone(),
                    mode: m as i64,
                    freq_hz: map.freqs_hz[k],
                    value: map.values[i][k],
                    normalised: map.normalised[i][k],
                });
            }
        }
        let modes = map
            .modes
            .iter()
            .enumerate()
            .map(|(k, &m)| {
                let largest = map.values.iter().fold(0.0_f64, |a, v| a.max(v[k].abs()));
                (m as i64, map.freqs_hz[k], largest)
            })
            .collect();
        EigenSensitivityRecord {
            candidates: map.candidates.len(),
            sensitivities,
            modes,
            members: members_of(&map.candidates),
        }
    }
}

/// The `eigenvalue_sensitivity` kind.
pub struct EigenvalueSensitivityKind;

impl Kind for EigenvalueSensitivityKind {
    const KIND: ArtefactKind = ArtefactKind::EigenvalueSensitivity;
    const NAME: &'static str = "eigenvalue_sensitivity";
    type Value = EigenSensitivityRecord;

    fn layout() -> Layout {
        let s = Storage::Parquet;
        Layout {
            tables: vec![
                table(
                    "sensitivities",
                    s,
                    true,
                    vec![
                        col("candidate", "string", "", "parameter name, or e<id>"),
                        col("mode", "int64", "", "mode number, 1-based over all modes"),
                        col("freq_hz", "float64", "Hz", "natural frequency"),
                        col(
                            "value",
                            "float64",
                            "rad^2/s^2",
                            "phi_i d(lambda_r)/d(phi_i) (5.3), unity-based",
                        ),
                        col(
                            "normalised",
                            "float64",
                            "",
                            "value / max |value| of the mode",
                        ),
                    ],
                ),
                table(
                    "modes",
                    s,
                    true,
                    vec![
                        col("mode", "int64", "", "mode number"),
                        col("freq_hz", "float64", "Hz", "natural frequency"),
                        col(
                            "largest",
                            "float64",
                            "rad^2/s^2",
                            "max |value| over candidates",
                        ),
                    ],
                ),
                members_layout(),
            ],
            meta: vec![
                meta("equation", "the sensitivity's definition (5.3)"),
                meta("candidates", "number of candidates"),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(r: &EigenSensitivityRecord) -> Artefact {
        write(r)
    }

    fn from_artefact(a: &Artefact) -> Result<EigenSensitivityRecord, ArtefactError> {
        read(a)
    }
}

/// An eigenvalue-sensitivity map as an artefact.
pub fn eigen_map_to_artefact(map: &EigenMap) -> Artefact {
    write(&EigenSensitivityRecord::new(map))
}

fn write(r: &EigenSensitivityRecord) -> Artefact {
    let s = &r.sensitivities;
    let f = |g: fn(&SensitivityRow) -> f64| Column::F64(s.iter().map(g).collect());
    let m = &r.modes;
    Artefact::new(EigenvalueSensitivityKind::KIND)
        .with_meta(
            "equation",
            "phi_i d(lambda_r)/d(phi_i) = phi_i phi_r^T (dK - lambda_r dM) phi_r (5.3)".into(),
        )
        .with_meta("candidates", r.candidates.into())
        .with_table(
            "sensitivities",
            Table::new()
                .with(
                    "candidate",
                    Column::Str(s.iter().map(|x| x.candidate.clone()).collect()),
                )
                .with("mode", Column::I64(s.iter().map(|x| x.mode).collect()))
                .with("freq_hz", f(|x| x.freq_hz))
                .with("value", f(|x| x.value))
                .with("normalised", f(|x| x.normalised)),
            Storage::Parquet,
        )
        .with_table(
            "modes",
            Table::new()
                .with("mode", Column::I64(m.iter().map(|x| x.0).collect()))
                .with("freq_hz", Column::F64(m.iter().map(|x| x.1).collect()))
                .with("largest", Column::F64(m.iter().map(|x| x.2).collect())),
            Storage::Parquet,
        )
        .with_table("members", members_table(&r.members), Storage::Parquet)
}

fn read(a: &Artefact) -> Result<EigenSensitivityRecord, ArtefactError> {
    expect_kind(a, EigenvalueSensitivityKind::KIND)?;
    let n = "sensitivities";
    let t = a.table(n)?;
    let (cand, mode) = (t.strs(n, "candidate")?, t.i64s(n, "mode")?);
    let (freq, value, norm) = (
        t.f64s(n, "freq_hz")?,
        t.f64s(n, "value")?,
        t.f64s(n, "normalised")?,
    );
    let sensitivities = (0..cand.len())
        .map(|k| SensitivityRow {
            candidate: cand[k].clone(),
            mode: mode[k],
            freq_hz: freq[k],
            value: value[k],
            normalised: norm[k],
        })
        .collect();
    let n = "modes";
    let t = a.table(n)?;
    let (mode, freq, largest) = (
        t.i64s(n, "mode")?,
        t.f64s(n, "freq_hz")?,
        t.f64s(n, "largest")?,
    );
    Ok(EigenSensitivityRecord {
        candidates: super::meta_value(a, "candidates")?,
        sensitivities,
        modes: (0..mode.len())
            .map(|k| (mode[k], freq[k], largest[k]))
            .collect(),
        members: read_members(a)?,
    })
}
