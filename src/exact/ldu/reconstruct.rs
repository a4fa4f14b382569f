//! Rebuilding `A` from its factors: `A[row_perm[i]][col_perm[j]] = sum_k L[i][k] U[k][j] / D[k]`.
//!
//! Used by the tests (including property tests) to check the factoring identity exactly: the
//! sum is computed in exact rationals and must be an integer equal to the original entry.

use super::Ldu;
use crate::exact::matrix::{Rat, SparseIntMatrix};
use num_traits::Zero;

impl Ldu {
    /// The matrix `Pr L D^-1 U Pc` as exact rationals, in the original row and column order.
    pub fn reconstruct(&self) -> Vec<Vec<Rat>> {
        let mut out = vec![vec![Rat::zero(); self.n]; self.m];
        for (i, lrow) in self.l_rows.iter().enumerate() {
            let orow = &mut out[self.row_perm[i]];
            for (k, l) in lrow {
                let f = Rat::new(l.clone(), self.d[*k].clone());
                for (j, u) in &self.u_rows[*k] {
                    orow[self.col_perm[*j]] += &f * Rat::from_integer(u.clone());
                }
            }
        }
        out
    }

    /// True when the factors rebuild `a` exactly.
    pub fn reconstructs(&self, a: &SparseIntMatrix) -> bool {
        if a.rows() != self.m || a.cols() != self.n {
            return false;
        }
        let r = self.reconstruct();
        (0..self.m).all(|i| (0..self.n).all(|j| r[i][j] == Rat::from_integer(a.get(i, j))))
    }
}
