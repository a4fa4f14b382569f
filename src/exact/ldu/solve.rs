//! Exact solution of `A x = b` from the factoring (thesis ch. 8, Algorithm 14).
//!
//! With `A = Pr L D^-1 U Pc`, put `y = D^-1 U Pc x` and split `Pr^-1 b` into its first `r`
//! entries `b^` and the rest `b~`. Then `L^ y = b^` (forward substitution) and the system is
//! consistent exactly when `L~ y = b~` (weak solvability, eq. 8.10). A solution is
//! `U^ x^ = D y` (back substitution) with the free part `x~ = 0` (eqs. 8.5-8.9), mapped back
//! through `Pc`.
//!
//! With Turner's simplification the factors have Jeffrey's form and everything runs in
//! integers: the forward substitution replays the Bareiss steps on `b` (each division is
//! exact), and by Cramer's rule `p_r x^` is an integer vector (`p_r` = the last pivot =
//! `+-det` of the pivot block), so the back substitution also divides exactly. The only
//! rationals are the final `x_j = X_j / p_r`. Other simplifications use rational
//! substitution.
//!
//! Note: the printed solution (8.22) of the thesis applies `Pc` the wrong way round; the
//! correct basic solution of example (8.17) for its pivot choice is `(59, -95/2, 0, 23/2)`.

use super::{Ldu, Simplification};
use crate::exact::int::Int;
use crate::exact::matrix::Rat;
use num_integer::Integer;
use num_traits::{One, Zero};

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
        self.first_inconsistent(b).is_none()
    }

    /// The first row of `A` (original numbering) whose equation `b` cannot satisfy, if any.
    pub fn first_inconsistent(&self, b: &[Rat]) -> Option<usize> {
        if self.simplification == Simplification::Turner {
            let (bi, _) = scale_to_int(b);
            self.forward_int(&bi).1
        } else {
            self.forward(b).1
        }
    }

    /// Pivot `p_k` for `k = 0..=r`, with `p_0 = 1` (Turner factorings).
    fn pivot(&self, k: usize) -> Int {
        if k == 0 {
            Int::one()
        } else {
            self.u_rows[k - 1][0].1.clone()
        }
    }

    /// Turner only: replays the Bareiss elimination on the integer vector `b` (original row
    /// order). Returns the transformed pivot-row entries `beta_k` (so that `U x = beta`) and
    /// the first inconsistent row (original numbering).
    fn forward_int(&self, b: &[Int]) -> (Vec<Int>, Option<usize>) {
        assert_eq!(b.len(), self.m, "right-hand side has {} rows, expected {}", b.len(), self.m);
        let mut w: Vec<Int> = self.row_perm.iter().map(|&i| b[i].clone()).collect();
        let mut stage = vec![0usize; self.m];
        let pivots: Vec<Int> = (0..=self.rank).map(|k| self.pivot(k)).collect();
        let bring = |w: &mut Int, stage: &mut usize, k: usize| {
            if *stage != k {
                if !w.is_zero() {
                    *w = (&*w * &pivots[k]).div_exact(&pivots[*stage]);
                }
                *stage = k;
            }
        };
        for k in 0..self.rank {
            let (prev, p) = (&pivots[k], &pivots[k + 1]);
            let (wk, sk) = (&mut w[k], &mut stage[k]);
            bring(wk, sk, k);
            let wk = w[k].clone();
            for (t, c) in &self.l_cols[k][1..] {
                let (wt, st) = (&mut w[*t], &mut stage[*t]);
                bring(wt, st, k);
                if wt.is_zero() && wk.is_zero() {
                    *st = k + 1;
                    continue;
                }
                *wt = Int::cross(p, wt, c, &wk).div_exact(prev);
                *st = k + 1;
            }
        }
        let bad = (self.rank..self.m).find(|&i| !w[i].is_zero()).map(|i| self.row_perm[i]);
        w.truncate(self.rank);
        (w, bad)
    }

    /// Turner only: integer back substitution. Returns `X` (original column order) and the
    /// common denominator `p_r`, with `x = X / p_r` the basic solution.
    fn back_int(&self, beta: &[Int]) -> (Vec<Int>, Int) {
        let r = self.rank;
        let det = self.pivot(r);
        let mut xp = vec![Int::zero(); r];
        for k in (0..r).rev() {
            let row = &self.u_rows[k];
            let mut acc = &det * &beta[k];
            for (j, u) in &row[1..] {
                if *j < r && !xp[*j].is_zero() {
                    acc -= &(u * &xp[*j]);
                }
            }
            xp[k] = acc.div_exact(&row[0].1);
        }
        let mut x = vec![Int::zero(); self.n];
        for (j, v) in xp.into_iter().enumerate() {
            x[self.col_perm[j]] = v;
        }
        (x, det)
    }

    /// Solves `A x = b` and returns the basic solution as integer numerators over one common
    /// denominator: `x_j = num[j] / den`, or the first inconsistent row.
    pub fn solve_scaled(&self, b: &[Rat]) -> Result<(Vec<Int>, Int), Inconsistent> {
        if self.simplification != Simplification::Turner {
            let x = self.solve(b)?;
            let den = x.iter().fold(Int::one(), |acc, v| acc.lcm(v.denom()));
            let num = x.iter().map(|v| (v * Rat::from_integer(den.clone())).to_integer()).collect();
            return Ok((num, den));
        }
        let (bi, bden) = scale_to_int(b);
        let (beta, bad) = self.forward_int(&bi);
        if let Some(row) = bad {
            return Err(Inconsistent { row, column: 0 });
        }
        let (x, det) = self.back_int(&beta);
        Ok((x, &det * &bden))
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
        if self.simplification == Simplification::Turner {
            let (x, den) = self.solve_scaled(b)?;
            return Ok(x.into_iter().map(|v| Rat::new(v, den.clone())).collect());
        }
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

/// `b` as integers over a common positive denominator: `b = num / den`.
pub fn scale_to_int(b: &[Rat]) -> (Vec<Int>, Int) {
    let v = crate::exact::matrix::ScaledVec::from_rats(b);
    (v.num, v.den)
}
