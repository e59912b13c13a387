//! FRF records grouped into one [`FrfSet`].

use super::{Uff58, UffError};
use crate::frf::{FrfPair, FrfSet};
use faer::Mat;
use std::collections::HashMap;

/// Relative tolerance within which two records' frequency lines are the same line.
pub const LINE_TOLERANCE: f64 = 1e-9;

/// Groups FRF records into one set: same quantity, same lines (within [`LINE_TOLERANCE`]
/// relative), strictly ascending lines, no pair twice. The lines are the first record's.
pub fn to_frf_set(frfs: &[Uff58]) -> Result<FrfSet, UffError> {
    let first = frfs.first().ok_or(UffError::NoFrfs)?;
    for (k, w) in first.freqs_hz.windows(2).enumerate() {
        if w[1] <= w[0] || w[1].is_nan() || w[0].is_nan() {
            return Err(UffError::NotAscending {
                file: first.file.clone(),
                line: first.line,
                index: k + 1,
                previous: w[0],
                next: w[1],
            });
        }
    }
    let inconsistent = |a: &Uff58, b: &Uff58, reason: String| UffError::Inconsistent {
        first_file: a.file.clone(),
        first_line: a.line,
        second_file: b.file.clone(),
        second_line: b.line,
        reason,
    };
    let mut seen: HashMap<FrfPair, &Uff58> = HashMap::new();
    for rec in frfs {
        if rec.quantity != first.quantity {
            return Err(inconsistent(
                first,
                rec,
                format!(
                    "the first holds {}, the second {}",
                    first.quantity.name(),
                    rec.quantity.name()
                ),
            ));
        }
        if rec.freqs_hz.len() != first.freqs_hz.len() {
            return Err(inconsistent(
                first,
                rec,
                format!(
                    "the first has {} frequency lines, the second {}",
                    first.freqs_hz.len(),
                    rec.freqs_hz.len()
                ),
            ));
        }
        for (k, (a, b)) in first.freqs_hz.iter().zip(&rec.freqs_hz).enumerate() {
            let gap = (a - b).abs();
            if gap > LINE_TOLERANCE * a.abs().max(b.abs()) || gap.is_nan() {
                return Err(inconsistent(
                    first,
                    rec,
                    format!(
                        "line {k} is {a} Hz in the first and {b} Hz in the second (more than {LINE_TOLERANCE:e} relative apart)"
                    ),
                ));
            }
        }
        if rec.values.len() != first.freqs_hz.len() {
            return Err(inconsistent(
                first,
                rec,
                format!(
                    "the second has {} values for {} lines",
                    rec.values.len(),
                    first.freqs_hz.len()
                ),
            ));
        }
        if let Some(prev) = seen.insert(rec.pair(), rec) {
            return Err(inconsistent(
                prev,
                rec,
                format!("both hold H({}, {})", rec.response, rec.reference),
            ));
        }
    }
    Ok(FrfSet {
        quantity: first.quantity,
        freqs_hz: first.freqs_hz.clone(),
        pairs: frfs.iter().map(Uff58::pair).collect(),
        values: Mat::from_fn(first.freqs_hz.len(), frfs.len(), |i, j| frfs[j].values[i]),
    })
}
