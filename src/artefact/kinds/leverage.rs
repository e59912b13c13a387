//! The `leverage` kind: error localisation, the leverage (5.9) of every candidate parameter
//! (docs/theory.md §7), as tables a user can plot without femu.
//!
//! | table (Parquet) | columns |
//! |---|---|
//! | `candidates` | `candidate, kind, set, value, leverage, normalised, rank, change, residual_fraction` |
//! | `members` | `candidate, element` |
//! | `lines` | `freq_hz, chi_s, chi_a, used` |

use super::{Kind, Layout, TableLayout, col, expect_kind, meta, meta_value, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::localisation::{Candidate, LeverageMap};

/// One row of `candidates`.
#[derive(Clone, Debug, PartialEq)]
pub struct LeverageRow {
    /// Parameter name, or `e<id>` for one element.
    pub candidate: String,
    /// Parameter kind (`youngs_modulus`, …).
    pub kind: String,
    /// Element set, or `element <id>`.
    pub set: String,
    /// Current value `φ_i`.
    pub value: f64,
    /// `L_i` (5.9).
    pub leverage: f64,
    /// `L_i / max L`.
    pub normalised: f64,
    /// 1 for the largest leverage.
    pub rank: usize,
    /// Relative change of `φ_i` alone (5.6).
    pub change: f64,
    /// `L_i / εᵀε`.
    pub residual_fraction: f64,
}

/// One row of `lines`.
#[derive(Clone, Debug, PartialEq)]
pub struct LineRow {
    /// Measured line, Hz.
    pub freq_hz: f64,
    /// Shape correlation of the prediction (4.8).
    pub chi_s: f64,
    /// Amplitude correlation (4.9).
    pub chi_a: f64,
    /// Whether it is an updating line.
    pub used: bool,
}

/// A leverage map as stored.
#[derive(Clone, Debug, PartialEq)]
pub struct LeverageRecord {
    /// The band the lines were restricted to, Hz.
    pub band_hz: Option<[f64; 2]>,
    /// Updating lines used.
    pub lines_used: usize,
    /// `εᵀε`.
    pub residual_norm2: f64,
    /// Modes of the prediction.
    pub modes: usize,
    /// Per candidate.
    pub candidates: Vec<LeverageRow>,
    /// `(candidate, element)` for every element of every candidate.
    pub members: Vec<(String, i64)>,
    /// Per measured line.
    pub lines: Vec<LineRow>,
}

impl LeverageRecord {
    /// The record of `map`; `band_hz` the band the lines were restricted to.
    pub fn new(map: &LeverageMap, band_hz: Option<[f64; 2]>) -> Self {
        let lev: Vec<f64> = map.fits.iter().map(|f| f.leverage).collect();
        let top = lev.iter().copied().fold(0.0_f64, f64::max);
        let rank = ranks(&lev);
        let candidates = map
            .candidates
            .iter()
            .enumerate()
            .map(|(i, c)| LeverageRow {
                candidate: c.name.clone(),
                kind: kind_name(c),
                set: c.set.clone(),
                value: c.value,
                leverage: lev[i],
                normalised: if top > 0.0 { lev[i] / top } else { 0.0 },
                rank: rank[i],
                change: map.fits[i].change,
                residual_fraction: if map.residual_norm2 > 0.0 {
                    lev[i] / map.residual_norm2
                } else {
                    0.0
                },
            })
            .collect();
        let mut used = vec![false; map.lines.chi_s.len()];
        for &k in &map.chosen {
            used[k] = true;
        }
        let lines = (0..used.len())
            .map(|k| LineRow {
                freq_hz: map.freqs_hz[k],
                chi_s: map.lines.chi_s[k],
                chi_a: map.lines.chi_a[k],
                used: used[k],
            })
            .collect();
        LeverageRecord {
            band_hz,
            lines_used: map.chosen.len(),
            residual_norm2: map.residual_norm2,
            modes: map.natural_hz.len(),
            candidates,
            members: members_of(&map.candidates),
            lines,
        }
    }
}

/// The `leverage` kind.
pub struct LeverageKind;

impl Kind for LeverageKind {
    const KIND: ArtefactKind = ArtefactKind::Leverage;
    const NAME: &'static str = "leverage";
    type Value = LeverageRecord;

    fn layout() -> Layout {
        Layout {
            tables: vec![candidates_layout(), members_layout(), lines_layout()],
            meta: vec![
                meta("equation", "the leverage's definition (5.9)"),
                meta(
                    "band_hz",
                    "the band the lines were restricted to, null for none",
                ),
                meta("lines_used", "updating lines used"),
                meta("residual_norm2", "eps^T eps"),
                meta("modes", "modes of the prediction"),
                meta("candidates", "number of candidates"),
                meta("top_candidate", "the candidate of rank 1, null for none"),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(r: &LeverageRecord) -> Artefact {
        write(r)
    }

    fn from_artefact(a: &Artefact) -> Result<LeverageRecord, ArtefactError> {
        read(a)
    }
}

fn candidates_layout() -> TableLayout {
    table(
        "candidates",
        Storage::Parquet,
        true,
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
    )
}

fn lines_layout() -> TableLayout {
    table(
        "lines",
        Storage::Parquet,
        true,
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
    )
}

/// The `members` table of both localisation kinds.
pub(crate) fn members_layout() -> TableLayout {
    table(
        "members",
        Storage::Parquet,
        true,
        vec![
            col("candidate", "string", "", "candidate name"),
            col(
                "element",
                "int64",
                "",
                "an element of the candidate's group",
            ),
        ],
    )
}

fn kind_name(c: &Candidate) -> String {
    serde_json::to_value(&c.kind)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| format!("{:?}", c.kind))
}

/// `(candidate, element)` for every element of every candidate.
pub(crate) fn members_of(candidates: &[Candidate]) -> Vec<(String, i64)> {
    candidates
        .iter()
        .flat_map(|c| c.elements.iter().map(|e| (c.name.clone(), *e as i64)))
        .collect()
}

/// The `members` table.
pub(crate) fn members_table(members: &[(String, i64)]) -> Table {
    Table::new()
        .with(
            "candidate",
            Column::Str(members.iter().map(|m| m.0.clone()).collect()),
        )
        .with(
            "element",
            Column::I64(members.iter().map(|m| m.1).collect()),
        )
}

/// The `members` table read back.
pub(crate) fn read_members(a: &Artefact) -> Result<Vec<(String, i64)>, ArtefactError> {
    let t = a.table("members")?;
    let (c, e) = (
        t.strs("members", "candidate")?,
        t.i64s("members", "element")?,
    );
    Ok(c.iter().cloned().zip(e.iter().copied()).collect())
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
    write(&LeverageRecord::new(map, band_hz))
}

fn write(r: &LeverageRecord) -> Artefact {
    let c = &r.candidates;
    let f = |g: fn(&LeverageRow) -> f64| Column::F64(c.iter().map(g).collect());
    let s = |g: fn(&LeverageRow) -> &String| Column::Str(c.iter().map(|x| g(x).clone()).collect());
    let candidates = Table::new()
        .with("candidate", s(|x| &x.candidate))
        .with("kind", s(|x| &x.kind))
        .with("set", s(|x| &x.set))
        .with("value", f(|x| x.value))
        .with("leverage", f(|x| x.leverage))
        .with("normalised", f(|x| x.normalised))
        .with(
            "rank",
            Column::I64(c.iter().map(|x| x.rank as i64).collect()),
        )
        .with("change", f(|x| x.change))
        .with("residual_fraction", f(|x| x.residual_fraction));
    let l = &r.lines;
    let lines = Table::new()
        .with(
            "freq_hz",
            Column::F64(l.iter().map(|x| x.freq_hz).collect()),
        )
        .with("chi_s", Column::F64(l.iter().map(|x| x.chi_s).collect()))
        .with("chi_a", Column::F64(l.iter().map(|x| x.chi_a).collect()))
        .with(
            "used",
            Column::I64(l.iter().map(|x| x.used as i64).collect()),
        );
    let best = c.iter().find(|x| x.rank == 1).map(|x| x.candidate.clone());
    Artefact::new(LeverageKind::KIND)
        .with_meta("equation", "L_i = (S_i^T eps)^2 / (S_i^T S_i) (5.9)".into())
        .with_meta(
            "band_hz",
            r.band_hz
                .map_or(serde_json::Value::Null, |b| serde_json::json!(b)),
        )
        .with_meta("lines_used", r.lines_used.into())
        .with_meta("residual_norm2", r.residual_norm2.into())
        .with_meta("modes", r.modes.into())
        .with_meta("candidates", c.len().into())
        .with_meta(
            "top_candidate",
            best.map_or(serde_json::Value::Null, serde_json::Value::from),
        )
        .with_table("candidates", candidates, Storage::Parquet)
        .with_table("members", members_table(&r.members), Storage::Parquet)
        .with_table("lines", lines, Storage::Parquet)
}

fn read(a: &Artefact) -> Result<LeverageRecord, ArtefactError> {
    expect_kind(a, LeverageKind::KIND)?;
    let n = "candidates";
    let t = a.table(n)?;
    let s = |c: &str| t.strs(n, c);
    let f = |c: &str| t.f64s(n, c);
    let (name, kind, set, rank) = (s("candidate")?, s("kind")?, s("set")?, t.i64s(n, "rank")?);
    let (value, lev, norm, change, frac) = (
        f("value")?,
        f("leverage")?,
        f("normalised")?,
        f("change")?,
        f("residual_fraction")?,
    );
    let candidates = (0..name.len())
        .map(|i| LeverageRow {
            candidate: name[i].clone(),
            kind: kind[i].clone(),
            set: set[i].clone(),
            value: value[i],
            leverage: lev[i],
            normalised: norm[i],
            rank: rank[i].max(0) as usize,
            change: change[i],
            residual_fraction: frac[i],
        })
        .collect();
    let n = "lines";
    let t = a.table(n)?;
    let (fr, cs, ca, used) = (
        t.f64s(n, "freq_hz")?,
        t.f64s(n, "chi_s")?,
        t.f64s(n, "chi_a")?,
        t.i64s(n, "used")?,
    );
    let lines = (0..fr.len())
        .map(|k| LineRow {
            freq_hz: fr[k],
            chi_s: cs[k],
            chi_a: ca[k],
            used: used[k] != 0,
        })
        .collect();
    Ok(LeverageRecord {
        band_hz: meta_value(a, "band_hz")?,
        lines_used: meta_value(a, "lines_used")?,
        residual_norm2: meta_value(a, "residual_norm2")?,
        modes: meta_value(a, "modes")?,
        candidates,
        members: read_members(a)?,
        lines,
    })
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
        .zip(rank.iter())
        .map(|((n, l), r)| (n.clone(), *l, *r))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranks_are_descending_and_stable() {
        assert_eq!(ranks(&[0.5, 2.0, 0.5, 1.0]), vec![3, 1, 4, 2]);
    }
}
