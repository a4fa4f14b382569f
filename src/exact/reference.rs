//! Test-only reference: textbook Gaussian elimination on `BigRational`, independent of the
//! fraction-free code, used as an oracle.

use num_rational::BigRational;
use num_traits::Zero;

/// Rank of a rational matrix given as rows.
pub fn rank(rows: &[Vec<BigRational>]) -> usize {
    let mut m = rows.to_vec();
    let nrows = m.len();
    let cols = m.first().map_or(0, Vec::len);
    let mut rank = 0;
    for c in 0..cols {
        let Some(p) = (rank..nrows).find(|&i| !m[i][c].is_zero()) else { continue };
        m.swap(rank, p);
        for i in rank + 1..nrows {
            if !m[i][c].is_zero() {
                let f = &m[i][c] / &m[rank][c];
                for j in c..cols {
                    let t = &f * &m[rank][j];
                    m[i][j] -= t;
                }
            }
        }
        rank += 1;
    }
    rank
}
