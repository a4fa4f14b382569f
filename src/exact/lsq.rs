//! Weighted least squares under independent linear constraints (thesis ch. 9, Algorithm 15).
//!
//! Given an `r x n` integer matrix `A^` of full row rank, positive weights `w_s`, hints `x'`
//! and a right-hand side `b^`, find the `x''` that minimizes
//!
//! ```text
//!     S(x) = sum_s w_s (x_s - x'_s)^2      subject to   A^ x = b^.
//! ```
//!
//! At the optimum `W (x'' - x') = -A^T Lambda / 2` for Lagrange multipliers `Lambda`
//! (eqs. 9.1-9.4, with `M = 2W` of the thesis absorbed into `Lambda`), so
//!
//! ```text
//!     G Lambda = A^ x' - b^,   G = A^ W^-1 A^T   (r x r, symmetric positive definite)
//!     x'' = x' - W^-1 A^T Lambda                                      (eqs. 9.6, 9.8)
//! ```
//!
//! `G` is scaled to an integer matrix and factored once with the fraction-free LDU, so each
//! solve is exact and costs two triangular substitutions. `G` is sparse when the constraints
//! are local (each row of `A^` touches few unknowns), and the Markowitz pivoting keeps it so.
//!
//! ```
//! use trimorph::exact::{IntMatrix, WeightedLsq, Simplification, rat_int, Rat};
//! // Section 9.2 of the thesis: hints all 1, equal weights.
//! let a = IntMatrix::from_i64_rows(4, &[
//!     vec![-1, -6, -19, -16], vec![1, 5, 15, 19], vec![4, 9, 16, 29],
//! ]).to_sparse();
//! let lsq = WeightedLsq::new(a, &vec![rat_int(1); 4], Simplification::Gcd).unwrap();
//! let b = vec![vec![rat_int(42)], vec![rat_int(40)], vec![rat_int(142)]];
//! let x = lsq.solve(&b, &vec![vec![rat_int(1)]; 4]);
//! let half = |p: i64| Rat::new(p.into(), 2.into());
//! assert_eq!(x, vec![vec![half(3)], vec![half(-3)], vec![half(-23)], vec![half(23)]]);
//! ```

use super::int::Int;
use super::ldu::{Ldu, LduOptions, Simplification};
use super::matrix::{Rat, SparseIntMatrix};
use num_integer::Integer;
use num_traits::{One, Signed, Zero};

/// Errors building a [`WeightedLsq`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LsqError {
    /// A weight is zero or negative.
    #[error("weight of unknown {index} is {value}; weights must be positive")]
    NonPositiveWeight {
        /// Index of the unknown.
        index: usize,
        /// The weight given, as text.
        value: String,
    },
    /// Wrong number of weights.
    #[error("{found} weights given for {expected} unknowns")]
    WeightCount {
        /// Number of unknowns.
        expected: usize,
        /// Number of weights given.
        found: usize,
    },
    /// The constraint rows are not independent.
    #[error("the {rows} constraint rows are not independent (rank {rank})")]
    DependentRows {
        /// Rank found.
        rank: usize,
        /// Number of rows.
        rows: usize,
    },
}

/// A factored weighted least-squares problem; see the module docs.
#[derive(Clone, Debug)]
pub struct WeightedLsq {
    a: SparseIntMatrix,
    winv: Vec<Rat>,
    /// Factoring of `scale * G`.
    g: Ldu,
    scale: Rat,
}

impl WeightedLsq {
    /// Builds and factors `G = A W^-1 A^T` for independent rows `a` and positive `weights`.
    pub fn new(
        a: SparseIntMatrix,
        weights: &[Rat],
        method: Simplification,
    ) -> Result<WeightedLsq, LsqError> {
        let (r, n) = (a.rows(), a.cols());
        if weights.len() != n {
            return Err(LsqError::WeightCount { expected: n, found: weights.len() });
        }
        if let Some((index, w)) = weights.iter().enumerate().find(|(_, w)| !w.is_positive()) {
            return Err(LsqError::NonPositiveWeight { index, value: w.to_string() });
        }
        let winv: Vec<Rat> = weights.iter().map(|w| w.recip()).collect();
        // Columns of A, then G_ij = sum_s A_is A_js / w_s over shared unknowns s.
        let mut cols: Vec<Vec<(usize, &Int)>> = vec![Vec::new(); n];
        for i in 0..r {
            for (s, v) in a.row(i) {
                cols[*s].push((i, v));
            }
        }
        let mut g_rows: Vec<Vec<(usize, Rat)>> = vec![Vec::new(); r];
        for (s, col) in cols.iter().enumerate() {
            for (i, ai) in col {
                for (j, aj) in col {
                    let v = Rat::from_integer(*ai * *aj) * &winv[s];
                    g_rows[*i].push((*j, v));
                }
            }
        }
        let mut den = Int::one();
        let mut merged: Vec<Vec<(usize, Rat)>> = Vec::with_capacity(r);
        for mut row in g_rows {
            row.sort_by_key(|e| e.0);
            let mut out: Vec<(usize, Rat)> = Vec::with_capacity(row.len());
            for (j, v) in row {
                match out.last_mut() {
                    Some((lj, lv)) if *lj == j => *lv += v,
                    _ => out.push((j, v)),
                }
            }
            for (_, v) in &out {
                den = den.lcm(v.denom());
            }
            merged.push(out);
        }
        let scale = Rat::from_integer(den);
        let int_rows = merged
            .into_iter()
            .map(|row| row.into_iter().map(|(j, v)| (j, (v * &scale).to_integer())).collect())
            .collect();
        let gi = SparseIntMatrix::from_rows(r, int_rows).expect("indices < r");
        let g = Ldu::factor(&gi, LduOptions::with(method));
        if g.rank() != r {
            return Err(LsqError::DependentRows { rank: g.rank(), rows: r });
        }
        Ok(WeightedLsq { a, winv, g, scale })
    }

    /// Number of constraints `r`.
    pub fn constraints(&self) -> usize {
        self.a.rows()
    }
    /// Number of unknowns `n`.
    pub fn unknowns(&self) -> usize {
        self.a.cols()
    }
    /// The constraint matrix `A^`.
    pub fn matrix(&self) -> &SparseIntMatrix {
        &self.a
    }

    /// Lagrange multipliers `Lambda` with `G Lambda = v`, for one column `v` of length `r`.
    pub fn multipliers(&self, v: &[Rat]) -> Vec<Rat> {
        let scaled: Vec<Rat> = v.iter().map(|x| x * &self.scale).collect();
        self.g.solve(&scaled).expect("G is invertible")
    }

    /// `W^-1 A^T G^-1 v`: the correction that the constraints force for a residual `v`.
    pub fn correction(&self, v: &[Rat]) -> Vec<Rat> {
        let lambda = self.multipliers(v);
        let mut out = vec![Rat::zero(); self.a.cols()];
        for (i, li) in lambda.iter().enumerate() {
            if li.is_zero() {
                continue;
            }
            for (s, v) in self.a.row(i) {
                out[*s] += li * Rat::from_integer(v.clone());
            }
        }
        for (o, w) in out.iter_mut().zip(&self.winv) {
            *o *= w;
        }
        out
    }

    /// The minimizer `x''` for right-hand side `b` (`r` rows of `d`) and hints `x'`
    /// (`n` rows of `d`), solved column by column.
    pub fn solve(&self, b: &[Vec<Rat>], hints: &[Vec<Rat>]) -> Vec<Vec<Rat>> {
        let d = hints.first().map_or(0, Vec::len);
        let ax = self.a.mul_rat(hints);
        let mut x = hints.to_vec();
        for c in 0..d {
            let resid: Vec<Rat> = (0..self.a.rows()).map(|i| &ax[i][c] - &b[i][c]).collect();
            if resid.iter().all(Zero::is_zero) {
                continue;
            }
            for (s, corr) in self.correction(&resid).into_iter().enumerate() {
                x[s][c] -= corr;
            }
        }
        x
    }
}
