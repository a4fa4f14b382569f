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
use super::ldu::{Ldu, LduOptions, Pivoting, Simplification};
use super::matrix::{Rat, ScaledVec, SparseIntMatrix};
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
    /// `scale / w_s`, an integer per unknown.
    factor: Vec<Int>,
    /// `adj = det * (scale G)^-1` (integer, by columns) and `det`, built on the fifth solve:
    /// repeated solves (dragging) then need products only, no exact divisions.
    adj: std::cell::OnceCell<(Vec<Vec<Int>>, Int)>,
    solves: std::cell::Cell<u32>,
}

/// `(scale G, scale, factor)` for `G = A W^-1 A^T` with positive `weights`: `scale` is the
/// lcm of the weights' numerators, so that `factor_s = scale / w_s` and `scale G` are
/// integers.
pub fn gram(a: &SparseIntMatrix, weights: &[Rat]) -> (SparseIntMatrix, Int, Vec<Int>) {
    let (r, n) = (a.rows(), a.cols());
    let scale_i = weights.iter().fold(Int::one(), |acc, w| acc.lcm(w.numer()));
    let factor: Vec<Int> =
        weights.iter().map(|w| scale_i.div_exact(w.numer()) * w.denom()).collect();
    let mut cols: Vec<Vec<(usize, &Int)>> = vec![Vec::new(); n];
    for i in 0..r {
        for (s, v) in a.row(i) {
            cols[*s].push((i, v));
        }
    }
    let mut g_rows: Vec<Vec<(usize, Int)>> = vec![Vec::new(); r];
    for (s, col) in cols.iter().enumerate() {
        for (i, ai) in col {
            let f = *ai * &factor[s];
            for (j, aj) in col {
                g_rows[*i].push((*j, &f * *aj));
            }
        }
    }
    (SparseIntMatrix::from_rows(r, g_rows).expect("indices < r"), scale_i, factor)
}

impl WeightedLsq {
    /// Builds and factors `G = A W^-1 A^T` for independent rows `a` and positive `weights`.
    /// `G` is always factored with Turner's simplification (integer solves); `method` is
    /// accepted for symmetry with the other factorings and reserved.
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
        let (gi, scale_i, factor) = gram(&a, weights);
        // Turner: the factoring of G then solves in integers.
        let g = Ldu::factor(
            &gi,
            LduOptions {
                simplification: Simplification::Turner,
                pivoting: Pivoting::SymmetricMarkowitz,
            },
        );
        let _ = method;
        if g.rank() != r {
            return Err(LsqError::DependentRows { rank: g.rank(), rows: r });
        }
        let scale = Rat::from_integer(scale_i);
        Ok(WeightedLsq {
            a,
            winv,
            g,
            scale,
            factor,
            adj: Default::default(),
            solves: Default::default(),
        })
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
    /// Computed in integers over one common denominator.
    pub fn correction(&self, v: &[Rat]) -> Vec<Rat> {
        let scaled: Vec<Rat> = v.iter().map(|x| x * &self.scale).collect();
        let (lambda, den) = self.g.solve_scaled(&scaled).expect("G is invertible");
        let mut acc = vec![Int::zero(); self.a.cols()];
        for (i, li) in lambda.iter().enumerate() {
            if li.is_zero() {
                continue;
            }
            for (s, v) in self.a.row(i) {
                acc[*s] += &(li * v);
            }
        }
        acc.into_iter()
            .zip(&self.winv)
            .map(|(x, w)| {
                if x.is_zero() {
                    Rat::zero()
                } else {
                    Rat::new(x * w.numer(), den.clone() * w.denom())
                }
            })
            .collect()
    }

    /// `(lambda, det)` with `(scale G)(lambda / det) = scale * resid`.
    fn lambda(&self, resid: &[Int], scale: &Int) -> (Vec<Int>, Int) {
        let n = self.solves.get();
        self.solves.set(n.saturating_add(1));
        let r = resid.len();
        // Build the adjugate once a drag is under way (after two 2D updates), not for a
        // one-off edit.
        if n >= 4 && self.adj.get().is_none() {
            let mut cols = Vec::with_capacity(r);
            let mut det = Int::one();
            for j in 0..r {
                let e: Vec<Rat> =
                    (0..r).map(|i| if i == j { Rat::one() } else { Rat::zero() }).collect();
                let (x, d) = self.g.solve_scaled(&e).expect("G is invertible");
                det = d;
                cols.push(x);
            }
            let _ = self.adj.set((cols, det));
        }
        if let Some((cols, det)) = self.adj.get() {
            let mut out = vec![Int::zero(); r];
            for (j, rj) in resid.iter().enumerate() {
                if rj.is_zero() {
                    continue;
                }
                let f = rj * scale;
                for (o, a) in out.iter_mut().zip(&cols[j]) {
                    if !a.is_zero() {
                        *o += &(a * &f);
                    }
                }
            }
            return (out, det.clone());
        }
        let rhs: Vec<Rat> = resid.iter().map(|v| Rat::from_integer(v * scale)).collect();
        self.g.solve_scaled(&rhs).expect("G is invertible")
    }

    /// The minimizer `x''` for one coordinate, all in integers: right-hand side `b` (length
    /// `r`) and hints `h` (length `n`) as scaled vectors; the result has denominator
    /// `scale * det * den(h) * den(b)` before normalization and needs no per-entry gcd.
    pub fn solve_scaled(&self, b: &ScaledVec, h: &ScaledVec) -> ScaledVec {
        let (r, n) = (self.a.rows(), self.a.cols());
        assert_eq!(b.len(), r, "right-hand side length");
        assert_eq!(h.len(), n, "hints length");
        // R = bd * A hn - hd * bn, so that A h - b = R / (hd * bd).
        let resid: Vec<Int> = (0..r)
            .map(|i| {
                let mut acc = Int::zero();
                for (s, v) in self.a.row(i) {
                    if !h.num[*s].is_zero() {
                        acc += &(v * &h.num[*s]);
                    }
                }
                Int::cross(&b.den, &acc, &h.den, &b.num[i])
            })
            .collect();
        if resid.iter().all(Int::is_zero_int) {
            return h.clone();
        }
        let scale = self.scale.to_integer();
        let (lambda, det) = self.lambda(&resid, &scale);
        let mut atl = vec![Int::zero(); n];
        for (i, li) in lambda.iter().enumerate() {
            if li.is_zero() {
                continue;
            }
            for (s, v) in self.a.row(i) {
                atl[*s] += &(li * v);
            }
        }
        // x'' = hn / hd - factor * atl / (scale * det * hd * bd)
        let k = &(&scale * &det) * &b.den;
        let num = h
            .num
            .iter()
            .zip(atl.iter().zip(&self.factor))
            .map(|(hn, (a, f))| Int::cross(hn, &k, f, a))
            .collect();
        ScaledVec::new(num, &k * &h.den)
    }

    /// The minimizer `x''` for right-hand side `b` (`r` rows of `d`) and hints `x'`
    /// (`n` rows of `d`), solved column by column.
    pub fn solve(&self, b: &[Vec<Rat>], hints: &[Vec<Rat>]) -> Vec<Vec<Rat>> {
        let d = hints.first().map_or(0, Vec::len);
        let n = self.a.cols();
        let mut x = vec![Vec::with_capacity(d); n];
        for c in 0..d {
            let bc: Vec<Rat> = b.iter().map(|r| r[c].clone()).collect();
            let hc: Vec<Rat> = hints.iter().map(|r| r[c].clone()).collect();
            let sol = self.solve_scaled(&ScaledVec::from_rats(&bc), &ScaledVec::from_rats(&hc));
            for (s, v) in sol.to_rats().into_iter().enumerate() {
                x[s].push(v);
            }
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::matrix::rat_int;

    /// Repeated solves switch to the cached adjugate of G; the results must not change.
    #[test]
    fn repeated_solves_agree_with_first_solves() {
        let rows: Vec<Vec<(usize, Int)>> = (0..6)
            .map(|i| {
                vec![(i, Int::from(3)), (i + 1, Int::from(-2)), (i + 3, Int::from(i as i64 - 2))]
            })
            .collect();
        let a = SparseIntMatrix::from_rows(9, rows).unwrap();
        let w: Vec<Rat> = (0..9).map(|s| Rat::new(Int::from(s as i64 + 1), Int::from(3))).collect();
        let warm = WeightedLsq::new(a.clone(), &w, Simplification::Turner).unwrap();
        for k in 0..12i64 {
            let b = ScaledVec::from_rats(
                &(0..6).map(|i| Rat::new(Int::from(i * k - 3), Int::from(7))).collect::<Vec<_>>(),
            );
            let h = ScaledVec::from_rats(&(0..9).map(|s| rat_int(s * k % 5)).collect::<Vec<_>>());
            let fresh = WeightedLsq::new(a.clone(), &w, Simplification::Turner).unwrap();
            let (x1, x2) = (warm.solve_scaled(&b, &h), fresh.solve_scaled(&b, &h));
            assert_eq!(x1.to_rats(), x2.to_rats(), "solve {k}");
        }
        assert!(warm.adj.get().is_some(), "the adjugate path was exercised");
    }
}
