//! The error-localisation artefacts (docs/theory.md §7), as tables a user can plot without femu.
//!
//! | kind | tables (Parquet) | columns |
//! |---|---|---|
//! | `leverage` | `candidates` | `candidate, kind, set, value, leverage, normalised, rank, change, residual_fraction` |
//! | | `members` | `candidate, element` |
//! | | `lines` | `freq_hz, chi_s, chi_a, used` |
//! | `eigenvalue_sensitivity` | `sensitivities` | `candidate, mode, freq_hz, value, normalised` |
//! | | `modes` | `mode, freq_hz, largest` |
//! | | `members` | `candidate, element` |

use super::kinds::{ColumnLayout, TableLayout, col};
use super::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::localisation::{Candidate, EigenMap, LeverageMap};

fn kind_name(c: &Candidate) -> String {
    serde_json::to_value(&c.kind)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| format!("{:?}", c.kind))
}

fn members(candidates: &[Candidate]) -> Table {
    let (mut names, mut ids) = (Vec::new(), Vec::new());
    for c in candidates {
        for e in &c.elements {
            names.push(c.name.clone());
            ids.push(*e as i64);
        }
    }
    Table::new()
        .with("candidate", Column::Str(names))
        .with("element", Column::I64(ids))
}

/// Rank of each value, 1 for the largest; ties keep candidate order.
pub fn ranks(values: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[b].total_cmp(&values[a]).then(a.cmp(&b)));
    let mut rank = vec![0; values.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[i] = r + 1;
    }
    rank
}

/// A leverage map as an artefact; `band_hz` the band the lines were restricted to.
pub fn leverage_to_artefact(map: &LeverageMap, band_hz: Option<[f64; 2]>) -> Artefact {
    let c = &map.candidates;
    let lev: Vec<f64> = map.fits.iter().map(|f| f.leverage).collect();
    let top = lev.iter().copied().fold(0.0_f64, f64::max);
    let rank = ranks(&lev);
    let candidates = Table::new()
        .with(
            "candidate",
            Column::Str(c.iter().map(|c| c.name.clone()).collect()),
        )
        .with("kind", Column::Str(c.iter().map(kind_name).collect()))
        .with(
            "set",
            Column::Str(c.iter().map(|c| c.set.clone()).collect()),
        )
        .with("value", Column::F64(c.iter().map(|c| c.value).collect()))
        .with("leverage", Column::F64(lev.clone()))
        .with(
            "normalised",
            Column::F64(
                lev.iter()
                    .map(|l| if top > 0.0 { l / top } else { 0.0 })
                    .collect(),
            ),
        )
        .with(
            "rank",
            Column::I64(rank.iter().map(|r| *r as i64).collect()),
        )
        .with(
            "change",
            Column::F64(map.fits.iter().map(|f| f.change).collect()),
        )
        .with(
            "residual_fraction",
            Column::F64(
                lev.iter()
                    .map(|l| {
                        if map.residual_norm2 > 0.0 {
                            l / map.residual_norm2
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            ),
        );
    let n = map.lines.chi_s.len();
    let mut used = vec![0i64; n];
    for &k in &map.chosen {
        used[k] = 1;
    }
    let lines = Table::new()
        .with("freq_hz", Column::F64(map.freqs_hz.clone()))
        .with("chi_s", Column::F64(map.lines.chi_s.clone()))
        .with("chi_a", Column::F64(map.lines.chi_a.clone()))
        .with("used", Column::I64(used));
    let best = rank.iter().position(|r| *r == 1).map(|i| c[i].name.clone());
    Artefact::new(ArtefactKind::Leverage)
        .with_meta("equation", "L_i = (S_i^T eps)^2 / (S_i^T S_i) (5.9)".into())
        .with_meta(
            "band_hz",
            band_hz.map_or(serde_json::Value::Null, |b| serde_json::json!(b)),
        )
        .with_meta("lines_used", map.chosen.len().into())
        .with_meta("residual_norm2", map.residual_norm2.into())
        .with_meta("modes", map.natural_hz.len().into())
        .with_meta("candidates", c.len().into())
        .with_meta(
            "top_candidate",
            best.map_or(serde_json::Value::Null, serde_json::Value::from),
        )
        .with_table("candidates", candidates, Storage::Parquet)
        .with_table("members", members(c), Storage::Parquet)
        .with_table("lines", lines, Storage::Parquet)
}

/// An eigenvalue-sensitivity map as an artefact.
pub fn eigen_map_to_artefact(map: &EigenMap) -> Artefact {
    let (mut cand, mut mode, mut freq, mut value, mut norm) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, c) in map.candidates.iter().enumerate() {
        for (k, &m) in map.modes.iter().enumerate() {
            cand.push(c.name.clone());
            mode.push(m as i64);
            freq.push(map.freqs_hz[k]);
            value.push(map.values[i][k]);
            norm.push(map.normalised[i][k]);
        }
    }
    let largest: Vec<f64> = (0..map.modes.len())
        .map(|k| map.values.iter().fold(0.0_f64, |a, v| a.max(v[k].abs())))
        .collect();
    Artefact::new(ArtefactKind::EigenvalueSensitivity)
        .with_meta(
            "equation",
            "phi_i d(lambda_r)/d(phi_i) = phi_i phi_r^T (dK - lambda_r dM) phi_r (5.3)".into(),
        )
        .with_meta("candidates", map.candidates.len().into())
        .with_table(
            "sensitivities",
            Table::new()
                .with("candidate", Column::Str(cand))
                .with("mode", Column::I64(mode))
                .with("freq_hz", Column::F64(freq))
                .with("value", Column::F64(value))
                .with("normalised", Column::F64(norm)),
            Storage::Parquet,
        )
        .with_table(
            "modes",
            Table::new()
                .with(
                    "mode",
                    Column::I64(map.modes.iter().map(|m| *m as i64).collect()),
                )
                .with("freq_hz", Column::F64(map.freqs_hz.clone()))
                .with("largest", Column::F64(largest)),
            Storage::Parquet,
        )
        .with_table("members", members(&map.candidates), Storage::Parquet)
}

/// `(candidate, leverage, rank)` of every candidate of a `leverage` artefact.
pub fn leverages(a: &Artefact) -> Result<Vec<(String, f64, i64)>, ArtefactError> {
    if a.kind != ArtefactKind::Leverage {
        return Err(ArtefactError::schema(
            a.kind,
            "expected a `leverage` artefact",
        ));
    }
    let t = a.table("candidates")?;
    let names = t.strs("candidates", "candidate")?;
    let lev = t.f64s("candidates", "leverage")?;
    let rank = t.i64s("candidates", "rank")?;
    Ok(names
        .iter()
        .zip(lev)
        .zip(rank)
        .map(|((n, l), r)| (n.clone(), *l, *r))
        .collect())
}

/// The published table layout of the two kinds.
pub fn layout(kind: ArtefactKind) -> Vec<TableLayout> {
    let t = |name, columns: Vec<ColumnLayout>| TableLayout {
        name,
        storage: "parquet",
        required: true,
        columns,
    };
    let members = t(
        "members",
        vec![
            col("candidate", "string", "", "candidate name"),
            col(
                "element",
                "int64",
                "",
                "an element of the candidate's group",
            ),
        ],
    );
    match kind {
        ArtefactKind::Leverage => vec![
            t(
                "candidates",
                vec![
                    col(
                        "candidate",
                        "string",
                        "",
                        "parameter name, or e<id> for one element",
                    ),
                    col(
                        "kind",
                        "string",
                        "",
                        "youngs_modulus, density, shell_thickness, ...",
                    ),
                    col("set", "string", "", "element set, or `element <id>`"),
                    col("value", "float64", "SI", "current value phi_i"),
                    col(
                        "leverage",
                        "float64",
                        "",
                        "L_i = (S_i^T eps)^2/(S_i^T S_i) (5.9)",
                    ),
                    col("normalised", "float64", "", "L_i / max L"),
                    col("rank", "int64", "", "1 = largest leverage"),
                    col(
                        "change",
                        "float64",
                        "",
                        "S_i^T eps/(S_i^T S_i): relative change of phi_i alone (5.6)",
                    ),
                    col(
                        "residual_fraction",
                        "float64",
                        "",
                        "L_i / eps^T eps: share of the residual parameter i alone removes",
                    ),
                ],
            ),
            members,
            t(
                "lines",
                vec![
                    col("freq_hz", "float64", "Hz", "measured line"),
                    col(
                        "chi_s",
                        "float64",
                        "",
                        "shape correlation of the prediction (4.8)",
                    ),
                    col("chi_a", "float64", "", "amplitude correlation (4.9)"),
                    col("used", "int64", "", "1 for an updating line (4.20, band)"),
                ],
            ),
        ],
        ArtefactKind::EigenvalueSensitivity => vec![
            t(
                "sensitivities",
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
            t(
                "modes",
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
            members,
        ],
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranks_are_descending_and_stable() {
        assert_eq!(ranks(&[0.5, 2.0, 0.5, 1.0]), vec![3, 1, 4, 2]);
    }
}
