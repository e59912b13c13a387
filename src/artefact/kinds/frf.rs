//! The `frf` kind: frequency response functions as one long table, one row per line and pair,
//! pair-major.
//!
//! | table (storage) | columns |
//! |---|---|
//! | `frf` (Parquet) | `freq_hz, response, excitation, re, im` |

use super::{Kind, Layout, col, expect_kind, meta, meta_opt, table};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind, Column, Storage, Table};
use crate::core::DofId;
use crate::frf::{FrfPair, FrfSet, Quantity};
use faer::{Mat, c64};

/// The `frf` kind.
pub struct FrfKind;

impl Kind for FrfKind {
    const KIND: ArtefactKind = ArtefactKind::Frf;
    const NAME: &'static str = "frf";
    type Value = FrfSet;

    fn layout() -> Layout {
        Layout {
            tables: vec![table(
                "frf",
                Storage::Parquet,
                true,
                vec![
                    col("freq_hz", "float64", "Hz", "frequency line"),
                    col("response", "string", "", "response DOF node:comp"),
                    col("excitation", "string", "", "excitation DOF node:comp"),
                    col("re", "float64", "meta.units.re", "real part"),
                    col("im", "float64", "meta.units.im", "imaginary part"),
                ],
            )],
            meta: vec![
                meta("quantity", "receptance, mobility or accelerance"),
                meta("units", "unit of each column"),
                meta("n_lines", "frequency lines"),
                meta("n_frfs", "response/excitation pairs"),
                meta_opt("import_notes", "what frf.import noted about the file"),
                meta_opt(
                    "synthesis_warnings",
                    "what frf.synthesise warned about (e.g. map DOFs the model lacks, taken as zero)",
                ),
            ],
            blobs: vec![],
        }
    }

    fn to_artefact(set: &FrfSet) -> Artefact {
        frf_to_artefact(set)
    }

    fn from_artefact(a: &Artefact) -> Result<FrfSet, ArtefactError> {
        frf_from_artefact(a)
    }
}

/// FRFs as an artefact (long table: one row per line and pair, pair-major).
pub fn frf_to_artefact(set: &FrfSet) -> Artefact {
    let (nl, np) = (set.freqs_hz.len(), set.pairs.len());
    let mut freq = Vec::with_capacity(nl * np);
    let (mut resp, mut exc) = (Vec::with_capacity(nl * np), Vec::with_capacity(nl * np));
    let (mut re, mut im) = (Vec::with_capacity(nl * np), Vec::with_capacity(nl * np));
    for (p, pair) in set.pairs.iter().enumerate() {
        let (r, e) = (pair.response.to_string(), pair.excitation.to_string());
        for (k, f) in set.freqs_hz.iter().enumerate() {
            freq.push(*f);
            resp.push(r.clone());
            exc.push(e.clone());
            re.push(set.values[(k, p)].re);
            im.push(set.values[(k, p)].im);
        }
    }
    let table = Table::new()
        .with("freq_hz", Column::F64(freq))
        .with("response", Column::Str(resp))
        .with("excitation", Column::Str(exc))
        .with("re", Column::F64(re))
        .with("im", Column::F64(im));
    Artefact::new(FrfKind::KIND)
        .with_meta("quantity", set.quantity.name().into())
        .with_meta("units", serde_json::json!({"freq_hz": "Hz", "re": set.quantity.unit(), "im": set.quantity.unit()}))
        .with_meta("n_lines", nl.into())
        .with_meta("n_frfs", np.into())
        .with_table("frf", table, Storage::Parquet)
}

/// FRFs from an artefact: rows grouped by (response, excitation) in order of first appearance,
/// every FRF on the same ascending lines.
pub fn frf_from_artefact(a: &Artefact) -> Result<FrfSet, ArtefactError> {
    let kind = ArtefactKind::Frf;
    expect_kind(a, kind)?;
    let q = a.meta_str("quantity")?;
    let quantity = Quantity::from_name(q).ok_or_else(|| {
        ArtefactError::schema(
            kind,
            format!("quantity `{q}` is not one of receptance, mobility, accelerance"),
        )
    })?;
    let t = a.table("frf")?;
    let f = t.f64s("frf", "freq_hz")?;
    let r = t.strs("frf", "response")?;
    let e = t.strs("frf", "excitation")?;
    let (re, im) = (t.f64s("frf", "re")?, t.f64s("frf", "im")?);
    let mut pairs: Vec<FrfPair> = Vec::new();
    let mut rows: Vec<Vec<usize>> = Vec::new();
    let mut last: Option<(&String, &String, usize)> = None;
    for row in 0..f.len() {
        let slot = match last {
            Some((lr, le, s)) if lr == &r[row] && le == &e[row] => s,
            _ => {
                let parse = |s: &String, col: &str| {
                    s.parse::<DofId>().map_err(|err| {
                        ArtefactError::schema(
                            kind,
                            format!("table `frf` row {row} column `{col}`: {err}"),
                        )
                    })
                };
                let pair = FrfPair {
                    response: parse(&r[row], "response")?,
                    excitation: parse(&e[row], "excitation")?,
                };
                match pairs.iter().position(|p| *p == pair) {
                    Some(s) => s,
                    None => {
                        pairs.push(pair);
                        rows.push(Vec::new());
                        pairs.len() - 1
                    }
                }
            }
        };
        rows[slot].push(row);
        last = Some((&r[row], &e[row], slot));
    }
    let Some(first) = rows.first() else {
        return Err(ArtefactError::schema(kind, "table `frf` has no rows"));
    };
    let freqs: Vec<f64> = first.iter().map(|&i| f[i]).collect();
    if freqs
        .windows(2)
        .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
    {
        return Err(ArtefactError::schema(
            kind,
            format!(
                "FRF {}/{}: frequencies must strictly increase",
                pairs[0].response, pairs[0].excitation
            ),
        ));
    }
    let mut values = Mat::<c64>::zeros(freqs.len(), pairs.len());
    for (p, idx) in rows.iter().enumerate() {
        let same = idx.len() == freqs.len()
            && idx
                .iter()
                .zip(&freqs)
                .all(|(&i, fr)| (f[i] - fr).abs() <= 1e-9 * fr.abs().max(1.0));
        if !same {
            return Err(ArtefactError::schema(
                kind,
                format!(
                    "FRF {}/{} has {} lines that differ from the first FRF's {} lines; every FRF must share one set of lines",
                    pairs[p].response,
                    pairs[p].excitation,
                    idx.len(),
                    freqs.len()
                ),
            ));
        }
        for (k, &i) in idx.iter().enumerate() {
            values[(k, p)] = c64::new(re[i], im[i]);
        }
    }
    Ok(FrfSet {
        quantity,
        freqs_hz: freqs,
        pairs,
        values,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_mismatch_is_reported() {
        let dofs: Vec<DofId> = vec!["1:ux".parse().unwrap(), "2:uz".parse().unwrap()];
        let set = FrfSet {
            quantity: Quantity::Mobility,
            freqs_hz: vec![1.0, 2.0, 3.0],
            pairs: FrfSet::all_pairs(&dofs, &dofs[..1]),
            values: Mat::from_fn(3, 2, |k, p| c64::new(k as f64, p as f64 - 0.5)),
        };
        let a = frf_to_artefact(&set);
        let mut broken = a.clone();
        if let Some((t, _)) = broken.tables.get_mut("frf")
            && let Column::F64(f) = &mut t.columns[0].1
        {
            f[4] = 2.5;
        }
        let e = frf_from_artefact(&broken).unwrap_err().to_string();
        assert!(e.contains("2:uz/1:ux"), "{e}");
    }
}
