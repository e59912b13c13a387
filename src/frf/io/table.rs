//! Measured FRFs from a long-format table, one row per frequency line and DOF pair, as users who
//! come from Python write them: columns `freq_hz, response, excitation, re, im`, optionally
//! `quantity` (receptance, mobility, accelerance) and `unit` (any label the UFF reader knows:
//! `m/s^2/N`, `g/N`, `(1/N)*(m/s²)`, `mm/N`). CSV text is read here; a Parquet table is read by
//! the caller into a [`LongTable`]. DOF labels are femu's (`12:uz`) or a signed axis (`12:+Z`,
//! `12:-Z`, `12:Z-`); a negative direction negates the values so that they refer to the positive
//! axis. Everything converted or assumed is returned as notes; errors name the file, the row
//! (and for CSV the line) and the column.

use super::uff::{LINE_TOLERANCE, frf_unit_si};
use crate::core::DofId;
use crate::frf::{FrfPair, FrfSet, Quantity};
use faer::{Mat, c64};
use std::collections::HashMap;

/// The columns of a long-format FRF table.
#[derive(Clone, Debug, Default)]
pub struct LongTable {
    /// File, for messages.
    pub file: String,
    /// True for CSV (rows are named with their line, the header being line 1).
    pub csv: bool,
    /// Frequency of each row, Hz.
    pub freq_hz: Vec<f64>,
    /// Response DOF label of each row.
    pub response: Vec<String>,
    /// Excitation DOF label of each row.
    pub excitation: Vec<String>,
    /// Real part of each row.
    pub re: Vec<f64>,
    /// Imaginary part of each row.
    pub im: Vec<f64>,
    /// The optional `quantity` column.
    pub quantity: Option<Vec<String>>,
    /// The optional `unit` column.
    pub unit: Option<Vec<String>>,
}

impl LongTable {
    /// Where row `i` (0-based data row) is.
    fn at(&self, i: usize, column: &str) -> String {
        if self.csv {
            format!("{}:{}: row {}, column `{column}`", self.file, i + 2, i + 1)
        } else {
            format!("{}: row {}, column `{column}`", self.file, i + 1)
        }
    }
}

/// Required columns.
pub const COLUMNS: [&str; 5] = ["freq_hz", "response", "excitation", "re", "im"];

/// Reads CSV text (comma, semicolon or tab separated, a header row naming the columns in any
/// order; extra columns are ignored, and said so).
pub fn parse_csv(text: &str, file: &str) -> Result<(LongTable, Vec<String>), String> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or_else(|| format!("{file}: empty; expected a header row {}", COLUMNS.join(",")))?;
    let sep = [',', ';', '\t']
        .into_iter()
        .max_by_key(|s| header.matches(*s).count())
        .unwrap_or(',');
    let names: Vec<String> = header
        .split(sep)
        .map(|s| s.trim().trim_matches('"').to_string())
        .collect();
    let index = |c: &str| names.iter().position(|n| n == c);
    let mut idx = [0usize; 5];
    for (k, c) in COLUMNS.iter().enumerate() {
        idx[k] = index(c).ok_or_else(|| {
            format!(
                "{file}:1: no column `{c}`; the header names {}; expected {} (and optionally quantity, unit)",
                names.join(", "),
                COLUMNS.join(", ")
            )
        })?;
    }
    let (q_idx, u_idx) = (index("quantity"), index("unit"));
    let mut notes = Vec::new();
    let extra: Vec<&String> = names
        .iter()
        .filter(|n| !COLUMNS.contains(&n.as_str()) && *n != "quantity" && *n != "unit")
        .collect();
    if !extra.is_empty() {
        notes.push(format!(
            "{file}: columns not read: {}",
            extra
                .iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let mut t = LongTable {
        file: file.to_string(),
        csv: true,
        quantity: q_idx.map(|_| Vec::new()),
        unit: u_idx.map(|_| Vec::new()),
        ..Default::default()
    };
    for (no, line) in lines {
        let cells: Vec<&str> = line
            .split(sep)
            .map(|s| s.trim().trim_matches('"'))
            .collect();
        let row = t.freq_hz.len() + 1;
        let cell = |k: usize, c: &str| {
            cells.get(k).copied().ok_or_else(|| {
                format!(
                    "{file}:{}: row {row}, column `{c}`: missing ({} cells, the header has {})",
                    no + 1,
                    cells.len(),
                    names.len()
                )
            })
        };
        let real = |k: usize, c: &str| -> Result<f64, String> {
            let s = cell(k, c)?;
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "{file}:{}: row {row}, column `{c}`: `{s}` is not a finite number",
                        no + 1
                    )
                })
        };
        t.freq_hz.push(real(idx[0], "freq_hz")?);
        t.response.push(cell(idx[1], "response")?.to_string());
        t.excitation.push(cell(idx[2], "excitation")?.to_string());
        t.re.push(real(idx[3], "re")?);
        t.im.push(real(idx[4], "im")?);
        if let (Some(k), Some(v)) = (q_idx, t.quantity.as_mut()) {
            v.push(cell(k, "quantity")?.to_string());
        }
        if let (Some(k), Some(v)) = (u_idx, t.unit.as_mut()) {
            v.push(cell(k, "unit")?.to_string());
        }
    }
    Ok((t, notes))
}

/// A DOF label and its sign: `12:uz`, `12:+Z`, `12:-Z`, `12:Z-`, `12:+RX`.
pub fn signed_dof(label: &str) -> Option<(DofId, f64)> {
    let (node, comp) = label.trim().split_once(':')?;
    let comp = comp.trim();
    let (sign, bare) = if let Some(c) = comp.strip_prefix('-').or_else(|| comp.strip_suffix('-')) {
        (-1.0, c)
    } else if let Some(c) = comp.strip_prefix('+').or_else(|| comp.strip_suffix('+')) {
        (1.0, c)
    } else {
        (1.0, comp)
    };
    let dof: DofId = format!("{}:{}", node.trim(), bare).parse().ok()?;
    (!dof.comp.is_scalar()).then_some((dof, sign))
}

/// The one value a column holds (or a parameter), checked constant.
fn constant<'a>(
    t: &LongTable,
    col: Option<&'a Vec<String>>,
    name: &str,
) -> Result<Option<&'a str>, String> {
    let Some(v) = col else { return Ok(None) };
    let Some(first) = v.first() else {
        return Ok(None);
    };
    if let Some(i) = v.iter().position(|x| x != first) {
        return Err(format!(
            "{}: `{}` where row 1 has `{first}`; one table holds one {name}",
            t.at(i, name),
            v[i]
        ));
    }
    Ok(Some(first.as_str()))
}

/// The quantity and the factor to SI from the `quantity` and `unit` columns or parameters.
fn quantity_of(
    t: &LongTable,
    quantity: Option<&str>,
    unit: Option<&str>,
    notes: &mut Vec<String>,
) -> Result<(Quantity, f64), String> {
    let q_col = constant(t, t.quantity.as_ref(), "quantity")?;
    let u_col = constant(t, t.unit.as_ref(), "unit")?;
    let q = q_col.or(quantity);
    let u = u_col.or(unit);
    let named = match q {
        None => None,
        Some(q) => Some(Quantity::from_name(q.trim()).ok_or_else(|| {
            format!(
                "{}: quantity `{q}`; valid: receptance, mobility, accelerance",
                t.file
            )
        })?),
    };
    match (named, u) {
        (_, Some(u)) => {
            let (uq, factor) = frf_unit_si(u).ok_or_else(|| {
                format!(
                    "{}: unit `{u}` is not a translational motion over a force (e.g. m/N, m/s/N, m/s^2/N, g/N, mm/s/N, (1/N)*(m/s²))",
                    t.file
                )
            })?;
            if let Some(q) = named
                && q != uq
            {
                return Err(format!(
                    "{}: quantity `{}` but unit `{u}` is a {} unit",
                    t.file,
                    q.name(),
                    uq.name()
                ));
            }
            if factor != 1.0 {
                notes.push(format!(
                    "{}: values in `{u}` converted to SI {}: ×{factor:e}",
                    t.file,
                    uq.unit()
                ));
            }
            Ok((uq, factor))
        }
        (Some(q), None) => {
            notes.push(format!(
                "{}: no unit given; the {} values are taken as SI ({})",
                t.file,
                q.name(),
                q.unit()
            ));
            Ok((q, 1.0))
        }
        (None, None) => Err(format!(
            "{}: neither a `quantity` nor a `unit` column, nor the stage's `quantity`/`unit` parameter, says what the values are (receptance m/N, mobility m/s/N, accelerance m/s^2/N, or a unit such as g/N)",
            t.file
        )),
    }
}

/// Groups a long table into an FRF set: pairs in order of first appearance, each pair's rows
/// sorted by frequency, every pair on the same lines (within [`LINE_TOLERANCE`] relative).
pub fn table_to_frf_set(
    t: &LongTable,
    quantity: Option<&str>,
    unit: Option<&str>,
) -> Result<(FrfSet, Vec<String>), String> {
    let n = t.freq_hz.len();
    if n == 0 {
        return Err(format!("{}: no rows", t.file));
    }
    let mut notes = Vec::new();
    let (q, factor) = quantity_of(t, quantity, unit, &mut notes)?;
    let mut pairs: Vec<FrfPair> = Vec::new();
    let mut rows: Vec<Vec<usize>> = Vec::new();
    let mut signs: Vec<f64> = Vec::new();
    let mut slot: HashMap<(&str, &str), usize> = HashMap::new();
    for i in 0..n {
        let key = (t.response[i].as_str(), t.excitation[i].as_str());
        let s = match slot.get(&key) {
            Some(&s) => s,
            None => {
                let dof = |label: &str, col: &str| {
                    signed_dof(label).ok_or_else(|| {
                        format!(
                            "{}: `{label}` is not a DOF; valid: node:component as femu writes it (12:uz, 12:rx) or a signed axis (12:+Z, 12:-Z, 12:Z-)",
                            t.at(i, col)
                        )
                    })
                };
                let (r, rs) = dof(key.0, "response")?;
                let (e, es) = dof(key.1, "excitation")?;
                let pair = FrfPair {
                    response: r,
                    excitation: e,
                };
                if let Some(p) = pairs.iter().position(|p| *p == pair) {
                    let first = rows[p][0];
                    return Err(format!(
                        "{}: `{}` / `{}` is the pair {r}/{e} of row {} written another way (`{}` / `{}`); one pair, one spelling",
                        t.at(i, "response"),
                        key.0,
                        key.1,
                        first + 1,
                        t.response[first],
                        t.excitation[first]
                    ));
                }
                pairs.push(pair);
                rows.push(Vec::new());
                signs.push(rs * es);
                if rs * es < 0.0 {
                    notes.push(format!(
                        "{}: H({}, {}) has one negative direction; values negated to refer to {r} and {e}",
                        t.file, key.0, key.1
                    ));
                }
                slot.insert(key, pairs.len() - 1);
                pairs.len() - 1
            }
        };
        rows[s].push(i);
    }
    for r in rows.iter_mut() {
        r.sort_by(|&a, &b| t.freq_hz[a].total_cmp(&t.freq_hz[b]));
    }
    let same = |a: f64, b: f64| (a - b).abs() <= LINE_TOLERANCE * a.abs().max(b.abs());
    for (p, r) in rows.iter().enumerate() {
        for w in r.windows(2) {
            if same(t.freq_hz[w[0]], t.freq_hz[w[1]]) {
                return Err(format!(
                    "{}: {} Hz for H({}, {}) again, as in row {}; duplicated rows",
                    t.at(w[0].max(w[1]), "freq_hz"),
                    t.freq_hz[w[1]],
                    pairs[p].response,
                    pairs[p].excitation,
                    w[0].min(w[1]) + 1
                ));
            }
        }
    }
    let freqs: Vec<f64> = rows[0].iter().map(|&i| t.freq_hz[i]).collect();
    for (p, r) in rows.iter().enumerate().skip(1) {
        let pair = |k: usize| format!("H({}, {})", pairs[k].response, pairs[k].excitation);
        if let Some(k) = (0..freqs.len().min(r.len())).find(|&k| !same(freqs[k], t.freq_hz[r[k]])) {
            let i = r[k];
            return Err(format!(
                "{}: line {} of {} is {} Hz where {} has {} Hz; every pair must have the same lines",
                t.at(i, "freq_hz"),
                k + 1,
                pair(p),
                t.freq_hz[i],
                pair(0),
                freqs[k]
            ));
        }
        if r.len() != freqs.len() {
            let (short, long, missing) = if r.len() < freqs.len() {
                (pair(p), pair(0), freqs[r.len()])
            } else {
                (pair(0), pair(p), t.freq_hz[r[freqs.len()]])
            };
            return Err(format!(
                "{}: {short} has {} lines and {long} {}; {short} is missing {missing} Hz and any line after it",
                t.file,
                r.len().min(freqs.len()),
                r.len().max(freqs.len())
            ));
        }
    }
    let mut values = Mat::<c64>::zeros(freqs.len(), pairs.len());
    for (p, r) in rows.iter().enumerate() {
        let s = signs[p] * factor;
        for (k, &i) in r.iter().enumerate() {
            values[(k, p)] = c64::new(t.re[i], t.im[i]) * s;
        }
    }
    Ok((
        FrfSet {
            quantity: q,
            freqs_hz: freqs,
            pairs,
            values,
        },
        notes,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &str = "freq_hz,response,excitation,re,im,unit\n\
        10,3:+Z,1:+Z,1,2,g/N\n\
        20,3:+Z,1:+Z,3,4,g/N\n\
        20,4:-Z,1:+Z,5,6,g/N\n\
        10,4:-Z,1:+Z,7,8,g/N\n";

    #[test]
    fn a_csv_table_reads_to_a_set_in_si_with_signs_and_notes() {
        let (t, notes) = parse_csv(CSV, "m.csv").unwrap();
        assert!(notes.is_empty());
        let (set, notes) = table_to_frf_set(&t, None, None).unwrap();
        assert_eq!(set.quantity, Quantity::Accelerance);
        assert_eq!(set.freqs_hz, vec![10.0, 20.0]);
        assert_eq!(set.pairs[1].response, "4:uz".parse().unwrap());
        let g = 9.80665;
        assert_eq!(set.values[(0, 0)], c64::new(g, 2.0 * g));
        // Row order within a pair does not matter; -Z negates.
        assert_eq!(set.values[(0, 1)], c64::new(-7.0 * g, -8.0 * g));
        assert!(notes.iter().any(|n| n.contains("×9.80665e0")), "{notes:?}");
        assert!(notes.iter().any(|n| n.contains("negated")), "{notes:?}");
    }

    #[test]
    fn table_faults_name_file_row_and_column() {
        let err = |text: &str| {
            let (t, _) = parse_csv(text, "m.csv").unwrap();
            table_to_frf_set(&t, None, Some("m/N")).unwrap_err()
        };
        let h = "freq_hz,response,excitation,re,im\n";
        let dup = err(&format!(
            "{h}10,3:uz,1:uz,1,0\n20,3:uz,1:uz,1,0\n10,3:uz,1:uz,1,0\n"
        ));
        assert!(
            dup.starts_with("m.csv:4: row 3, column `freq_hz`") && dup.contains("duplicated"),
            "{dup}"
        );
        let missing = err(&format!(
            "{h}10,3:uz,1:uz,1,0\n20,3:uz,1:uz,1,0\n10,4:uz,1:uz,1,0\n"
        ));
        assert!(missing.contains("is missing 20 Hz"), "{missing}");
        let uneven = err(&format!(
            "{h}10,3:uz,1:uz,1,0\n20,3:uz,1:uz,1,0\n10,4:uz,1:uz,1,0\n21,4:uz,1:uz,1,0\n"
        ));
        assert!(
            uneven.starts_with("m.csv:5: row 4, column `freq_hz`") && uneven.contains("same lines"),
            "{uneven}"
        );
        let bad = err(&format!("{h}10,3:up,1:uz,1,0\n"));
        assert!(
            bad.starts_with("m.csv:2: row 1, column `response`"),
            "{bad}"
        );
        let nan = parse_csv(&format!("{h}10,3:uz,1:uz,x,0\n"), "m.csv").unwrap_err();
        assert!(nan.starts_with("m.csv:2: row 1, column `re`"), "{nan}");
        let (t, _) = parse_csv(&format!("{h}10,3:uz,1:uz,1,0\n"), "m.csv").unwrap();
        let none = table_to_frf_set(&t, None, None).unwrap_err();
        assert!(none.contains("says what the values are"), "{none}");
        let clash = table_to_frf_set(&t, Some("mobility"), Some("m/N")).unwrap_err();
        assert!(clash.contains("receptance unit"), "{clash}");
    }
}
