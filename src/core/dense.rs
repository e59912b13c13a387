//! Small helpers on dense matrices shared by the numerical modules.

use faer::MatRef;

/// Largest absolute entry of a dense matrix.
pub fn max_abs(a: MatRef<'_, f64>) -> f64 {
    let mut s = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            s = s.max(a[(i, j)].abs());
        }
    }
    s
}
