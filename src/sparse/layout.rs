//! Row-major copies of column blocks, for kernels that want a row's values side by side.
//!
//! Copying a tall `n × b` block between column-major and row-major one column at a time
//! strides through the whole row-major array `b` times, which on large models takes longer
//! than the sparse product it feeds. Here rows are taken in tiles that stay in cache while all
//! columns pass, and the tiles are shared among the threads unless `par` is [`Par::Seq`].

use faer::{MatMut, MatRef, Par};
use rayon::prelude::*;

/// Rows per tile: a tile of 16 columns is 64 KiB.
const TILE: usize = 512;

/// `out[i·s + c] = x[(i, c)]`, rows `s ≥ b` values apart (`s = out.len() / n`; the values
/// beyond `b` in each row are left as they are).
pub fn to_row_major(x: MatRef<'_, f64>, out: &mut [f64], par: Par) {
    let (n, b) = (x.nrows(), x.ncols());
    if b == 0 || n == 0 {
        return;
    }
    let stride = out.len() / n;
    assert!(
        stride >= b && out.len() == n * stride,
        "rows of at least {b} values"
    );
    let fill = |(t, tile): (usize, &mut [f64])| {
        let first = t * TILE;
        for c in 0..b {
            let col = x.col(c);
            for (r, row) in tile.chunks_exact_mut(stride).enumerate() {
                row[c] = col[first + r];
            }
        }
    };
    if par.degree() > 1 {
        out.par_chunks_mut(TILE * stride).enumerate().for_each(fill);
    } else {
        out.chunks_mut(TILE * stride).enumerate().for_each(fill);
    }
}

/// `x[(i, c)] = rows[i·s + c]`, rows `s ≥ b` values apart (`s = rows.len() / n`).
pub fn from_row_major(rows: &[f64], x: MatMut<'_, f64>, par: Par) {
    let (n, b) = (x.nrows(), x.ncols());
    if b == 0 || n == 0 {
        return;
    }
    let stride = rows.len() / n;
    assert!(
        stride >= b && rows.len() == n * stride,
        "rows of at least {b} values"
    );
    if n > TILE && par.degree() > 1 {
        let half = (n / 2).div_ceil(TILE) * TILE;
        let (top, bottom) = x.split_at_row_mut(half);
        let (rows_top, rows_bottom) = rows.split_at(half * stride);
        rayon::join(
            || from_row_major(rows_top, top, par),
            || from_row_major(rows_bottom, bottom, par),
        );
    } else {
        let mut x = x;
        for c in 0..b {
            let mut col = x.as_mut().col_mut(c);
            for (r, row) in rows.chunks_exact(stride).enumerate() {
                col[r] = row[c];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    #[test]
    fn round_trip_over_partial_tiles() {
        for par in [Par::Seq, Par::rayon(2)] {
            round_trip(par);
        }
    }

    fn round_trip(par: Par) {
        let x = Mat::from_fn(3 * TILE + 17, 5, |i, j| (i * 10 + j) as f64);
        let mut rows = vec![0.0; x.nrows() * 5];
        to_row_major(x.as_ref(), &mut rows, par);
        assert_eq!(rows[(2 * TILE + 3) * 5 + 4], x[(2 * TILE + 3, 4)]);
        let mut back = Mat::zeros(x.nrows(), 5);
        from_row_major(&rows, back.as_mut(), par);
        assert_eq!(back, x);
        // Rows padded to 8 values: the padding is left alone.
        let mut padded = vec![-1.0; x.nrows() * 8];
        to_row_major(x.as_ref(), &mut padded, par);
        assert_eq!(padded[(2 * TILE + 3) * 8 + 4], x[(2 * TILE + 3, 4)]);
        assert_eq!(padded[(2 * TILE + 3) * 8 + 5], -1.0);
        let mut back = Mat::zeros(x.nrows(), 5);
        from_row_major(&padded, back.as_mut(), par);
        assert_eq!(back, x);
    }
}
