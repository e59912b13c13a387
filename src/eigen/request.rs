//! The modes a Nastran `EIGRL` asks for: a band `[V1, V2]` in Hz and a count `ND`, combined as
//! the Quick Reference Guide's EIGRL remark tabulates (roots in ascending order):
//!
//! | V1 | V2 | ND | modes |
//! |---|---|---|---|
//! | V1 | V2 | ND | the lowest ND in `[V1, V2]`, or all in it if fewer |
//! | V1 | V2 | –  | all in `[V1, V2]` |
//! | V1 | –  | ND | the lowest ND at or above V1 |
//! | V1 | –  | –  | the lowest one at or above V1 |
//! | –  | V2 | ND | the lowest ND below V2 |
//! | –  | V2 | –  | all below V2 |
//! | –  | –  | ND | the lowest ND |
//! | –  | –  | –  | the lowest one |
//!
//! A `V1` of zero or below is no lower end (rigid-body modes at "0 Hz" stay in).

use super::{ModeSelection, Modes};
use std::ops::Range;

/// A band and count of modes, as an EIGRL gives them.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EigenRequest {
    /// Lower end of the band, Hz (`V1`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_hz: Option<f64>,
    /// Upper end of the band, Hz (`V2`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_hz: Option<f64>,
    /// Number of modes desired (`ND`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<usize>,
}

impl EigenRequest {
    /// The modes asked for. `solve` returns the lowest modes of a selection in ascending order;
    /// with a lower end and no upper one it is called again with a larger count (at least doubled) until
    /// `ND` modes at or above `V1` are found or the model has no more.
    pub fn select<E>(
        &self,
        mut solve: impl FnMut(ModeSelection) -> Result<Modes, E>,
    ) -> Result<Modes, E> {
        let lower = self.min_hz.filter(|v| *v > 0.0);
        let wanted = match (self.max_hz, self.count) {
            (_, Some(n)) => n,
            (Some(_), None) => usize::MAX,
            (None, None) => 1,
        };
        let below = |m: &Modes| {
            lower.map_or(0, |v1| {
                m.frequencies_hz().iter().filter(|f| **f < v1).count()
            })
        };
        let modes = match self.max_hz {
            Some(v2) => solve(ModeSelection::BelowHz(v2))?,
            None => {
                let mut asked = wanted;
                loop {
                    let m = solve(ModeSelection::Count(asked))?;
                    let skipped = below(&m);
                    if m.len() < asked || m.len() - skipped >= wanted {
                        break m;
                    }
                    asked = (wanted + skipped).max(asked.saturating_mul(2));
                }
            }
        };
        let first = below(&modes);
        let last = first.saturating_add(wanted).min(modes.len());
        Ok(modes.keep(first..last))
    }

    /// `V1 = …, V2 = …, ND = …` for messages.
    pub fn describe(&self) -> String {
        let show = |v: Option<String>| v.unwrap_or_else(|| "blank".into());
        format!(
            "V1 = {}, V2 = {}, ND = {}",
            show(self.min_hz.map(|v| format!("{v} Hz"))),
            show(self.max_hz.map(|v| format!("{v} Hz"))),
            show(self.count.map(|n| n.to_string()))
        )
    }
}

impl Modes {
    /// The modes of `range` (ascending order kept); rigid-body modes counted among them.
    pub fn keep(&self, range: Range<usize>) -> Modes {
        let range =
            range.start.min(self.len())..range.end.min(self.len()).max(range.start.min(self.len()));
        let rigid = (range.start..range.end)
            .filter(|r| *r < self.rigid_body_modes)
            .count();
        Modes {
            eigenvalues: self.eigenvalues[range.clone()].to_vec(),
            shapes: self.shapes.subcols(range.start, range.len()).to_owned(),
            residuals: self.residuals[range.clone()].to_vec(),
            orthogonality_error: self.orthogonality_error,
            rigid_body_modes: rigid,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;
    use std::f64::consts::PI;

    /// A "model" with modes at 0, 0, 1, 2, …, 9 Hz: `solve` keeps what a solver would.
    fn solve(selection: ModeSelection, calls: &mut Vec<ModeSelection>) -> Result<Modes, ()> {
        calls.push(selection);
        let all: Vec<f64> = [0.0, 0.0]
            .into_iter()
            .chain((1..10).map(f64::from))
            .collect();
        let n = match selection {
            ModeSelection::All => all.len(),
            ModeSelection::Count(n) => n.min(all.len()),
            ModeSelection::BelowHz(f) => all.iter().filter(|x| **x <= f).count(),
        };
        Ok(Modes {
            eigenvalues: all[..n].iter().map(|f| (2.0 * PI * f).powi(2)).collect(),
            shapes: Mat::from_fn(3, n, |i, j| (i + 10 * j) as f64),
            residuals: vec![1e-12; n],
            orthogonality_error: 1e-14,
            rigid_body_modes: 2.min(n),
        })
    }

    fn hz(r: EigenRequest) -> (Vec<f64>, usize) {
        let mut calls = Vec::new();
        let m = r.select(|s| solve(s, &mut calls)).unwrap();
        let f = m
            .frequencies_hz()
            .iter()
            .map(|f| (f * 1e9).round() / 1e9)
            .collect();
        (f, m.rigid_body_modes)
    }

    fn req(v1: Option<f64>, v2: Option<f64>, nd: Option<usize>) -> EigenRequest {
        EigenRequest {
            min_hz: v1,
            max_hz: v2,
            count: nd,
        }
    }

    #[test]
    fn every_row_of_the_eigrl_table() {
        assert_eq!(
            hz(req(Some(2.5), Some(7.5), Some(3))).0,
            vec![3.0, 4.0, 5.0]
        );
        assert_eq!(
            hz(req(Some(2.5), Some(4.5), Some(9))).0,
            vec![3.0, 4.0],
            "fewer in band than ND"
        );
        assert_eq!(hz(req(Some(2.5), Some(5.0), None)).0, vec![3.0, 4.0, 5.0]);
        assert_eq!(
            hz(req(Some(2.5), None, Some(4))).0,
            vec![3.0, 4.0, 5.0, 6.0]
        );
        assert_eq!(hz(req(Some(2.5), None, None)).0, vec![3.0]);
        assert_eq!(hz(req(None, Some(3.5), Some(3))), (vec![0.0, 0.0, 1.0], 2));
        assert_eq!(
            hz(req(None, Some(3.5), None)).0,
            vec![0.0, 0.0, 1.0, 2.0, 3.0]
        );
        assert_eq!(hz(req(None, None, Some(4))), (vec![0.0, 0.0, 1.0, 2.0], 2));
        assert_eq!(hz(req(None, None, None)).0, vec![0.0]);
        assert_eq!(
            hz(req(Some(0.0), None, Some(3))).0,
            vec![0.0, 0.0, 1.0],
            "V1 = 0 keeps rigid modes"
        );
        assert_eq!(
            hz(req(Some(8.5), None, Some(5))).0,
            vec![9.0],
            "the model runs out of modes"
        );
    }

    #[test]
    fn a_lower_end_asks_again_for_the_modes_below_it_and_keeps_their_shapes_aligned() {
        let mut calls = Vec::new();
        let m = req(Some(3.5), None, Some(2))
            .select(|s| solve(s, &mut calls))
            .unwrap();
        assert_eq!(calls, [2, 4, 8].map(ModeSelection::Count).to_vec());
        // Modes 4 and 5 Hz are the 6th and 7th of the model (index 5 and 6).
        assert_eq!((m.shapes[(0, 0)], m.shapes[(0, 1)]), (50.0, 60.0));
        assert_eq!(m.rigid_body_modes, 0);
    }
}
