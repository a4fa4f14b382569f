//! Exact solution of `A x = b` from the factoring (thesis ch. 8, Algorithm 14).
//!
//! With `A = Pr L D^-1 U Pc`, put `y = D^-1 U Pc x` and split `Pr^-1 b` into its first `r`
//! entries `b^` and the rest `b~`. Then `L^ y = b^` (forward substitution) and the system is
//! consistent exactly when `L~ y = b~` (weak solvability, eq. 8.10). A solution is
//! `U^ x^ = D y` (back substitution) with the free part `x~ = 0` (eqs. 8.5-8.9), mapped back
//! through `Pc`.
//!
//! Note: the printed solution (8.22) of the thesis applies `Pc` the wrong way round; the
//! correct basic solution of example (8.17) for its pivot choice is `(59, -95/2, 0, 23/2)`.

use super::Ldu;
use crate::exact::matrix::Rat;
use num_traits::Zero;

/// A right-hand side that the system cannot satisfy.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("inconsistent system: row {row} (column {column} of the right-hand side) contradicts the independent rows")]
pub struct Inconsistent {
    /// The row of `A` (original numbering) whose equation fails.
    pub row: usize,
    /// The column of the right-hand side that fails.
    pub column: usize,
}

impl Ldu {
    /// Forward substitution: `y` with `L^ y = b^`, for `b` in the original row order.
    /// Returns `y` and the first redundant row whose equation `L~ y = b~` fails, if any.
    pub fn forward(&self, b: &[Rat]) -> (Vec<Rat>, Option<usize>) {
        assert_eq!(b.len(), self.m, "right-hand side has {} rows, expected {}", b.len(), self.m);
        let r = self.rank;
        let mut y: Vec<Rat> = Vec::with_capacity(r);
        for i in 0..r {
            let row = &self.l_rows[i];
            let (diag, rest) = row.split_last().expect("L^ has a diagonal");
            let mut acc = b[self.row_perm[i]].clone();
            for (k, l) in rest {
                acc -= &y[*k] * Rat::from_integer(l.clone());
            }
            y.push(acc / Rat::from_integer(diag.1.clone()));
        }
        let bad = (r..self.m).find(|&i| {
            let mut acc = Rat::zero();
            for (k, l) in &self.l_rows[i] {
                acc += &y[*k] * Rat::from_integer(l.clone());
            }
            acc != b[self.row_perm[i]]
        });
        (y, bad.map(|i| self.row_perm[i]))
    }

    /// Weak solvability (eq. 8.10): whether `A x = b` has a solution.
    pub fn is_consistent(&self, b: &[Rat]) -> bool {
        self.forward(b).1.is_none()
    }

    /// Back substitution from `y`: the basic solution with the non-pivot unknowns at zero,
    /// in the original column order.
    pub fn back(&self, y: &[Rat]) -> Vec<Rat> {
        let r = self.rank;
        let mut xp = vec![Rat::zero(); self.n]; // by column position
        for k in (0..r).rev() {
            let row = &self.u_rows[k];
            let mut acc = &y[k] * Rat::from_integer(self.d[k].clone());
            for (j, u) in &row[1..] {
                if *j < r {
                    acc -= &xp[*j] * Rat::from_integer(u.clone());
                }
            }
            xp[k] = acc / Rat::from_integer(row[0].1.clone());
        }
        let mut x = vec![Rat::zero(); self.n];
        for (j, v) in xp.into_iter().enumerate() {
            x[self.col_perm[j]] = v;
        }
        x
    }

    /// Solves `A x = b` exactly (Algorithm 14): the basic solution, or the failing row.
    pub fn solve(&self, b: &[Rat]) -> Result<Vec<Rat>, Inconsistent> {
        let (y, bad) = self.forward(b);
        match bad {
            Some(row) => Err(Inconsistent { row, column: 0 }),
            None => Ok(self.back(&y)),
        }
    }

    /// Solves `A X = B` for `B` with `d` columns (`m` rows of `d` values); returns `n` rows of
    /// `d` values.
    pub fn solve_multi(&self, b: &[Vec<Rat>]) -> Result<Vec<Vec<Rat>>, Inconsistent> {
        let d = b.first().map_or(0, Vec::len);
        let mut x = vec![vec![Rat::zero(); d]; self.n];
        for c in 0..d {
            let col: Vec<Rat> = b.iter().map(|r| r[c].clone()).collect();
            let sol = self.solve(&col).map_err(|e| Inconsistent { column: c, ..e })?;
            for (i, v) in sol.into_iter().enumerate() {
                x[i][c] = v;
            }
        }
        Ok(x)
    }
}
