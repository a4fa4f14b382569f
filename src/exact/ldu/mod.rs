//! Fraction-free LDU factoring of integer matrices of any shape and rank.
//!
//! For an `m x n` integer matrix `A` of rank `r` the factoring is
//!
//! ```text
//!     A = Pr L D^-1 U Pc                                   (thesis eq. 4.1, after Jeffrey 2010)
//! ```
//!
//! with `L` (`m x r`) lower trapezoidal, `D` (`r x r`) diagonal, `U` (`r x n`) upper
//! trapezoidal, all **integer**, and `Pr`, `Pc` permutations. Concretely, with
//! `row_perm` and `col_perm` as returned by [`Ldu::row_perm`] and [`Ldu::col_perm`]:
//!
//! ```text
//!     A[row_perm[i]][col_perm[j]] = sum_k  L[i][k] * U[k][j] / D[k]
//! ```
//!
//! The first `r` rows of `L` (`L^`) and first `r` columns of `U` (`U^`) are triangular with
//! nonzero diagonals. The rows `row_perm[0..r]` of `A` are a maximal set of independent
//! constraints; the rows `row_perm[r..m]` are *redundant* (linear combinations of them). The
//! null parts of the thesis's square working matrices are never stored (Alg. 6, step 15).
//!
//! Modules: `factor` computes the factoring (Algorithms 6-13), [`solve`] solves and checks
//! consistency (Algorithm 14, eqs. 8.10 and 8.15-8.16), [`reconstruct`] rebuilds `A` from its
//! factors (used by the tests to check the identity exactly).
//!
//! ```
//! use trimorph::exact::{Int, IntMatrix, Ldu, LduOptions};
//! // Example (4.3) of the 2017 thesis: rank 3.
//! let a = IntMatrix::from_i64_rows(4, &[
//!     vec![4, 9, 16, 29], vec![-1, -6, -19, -16], vec![1, 5, 15, 19],
//!     vec![5, 6, -1, -12], vec![5, 10, 15, 20],
//! ]);
//! let f = Ldu::factor(&a.to_sparse(), LduOptions::default());
//! assert_eq!(f.rank(), 3);
//! assert_eq!(f.redundant_rows().len(), 2);
//! assert!(f.reconstructs(&a.to_sparse()));
//! ```

pub mod dense;
mod factor;
pub mod reconstruct;
pub mod solve;

use super::int::Int;
use super::matrix::SparseIntMatrix;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// How common factors are removed during elimination (thesis ch. 7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Simplification {
    /// Plain fraction-free elimination: bit sizes grow exponentially with the rank.
    None,
    /// Divide each updated row by the gcd of its entries (Alg. 11-12).
    Gcd,
    /// Turner's gcd-free exact division by the previous pivot (Bareiss; Alg. 13).
    #[default]
    Turner,
}

impl FromStr for Simplification {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "none" => Ok(Simplification::None),
            "gcd" => Ok(Simplification::Gcd),
            "turner" => Ok(Simplification::Turner),
            _ => Err(format!("unknown simplification method `{s}` (use none, gcd or turner)")),
        }
    }
}

impl fmt::Display for Simplification {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Simplification::None => "none",
            Simplification::Gcd => "gcd",
            Simplification::Turner => "turner",
        })
    }
}

/// How the pivot is chosen among all remaining nonzeros (full pivoting).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Pivoting {
    /// The nonzero of least Markowitz cost, ties broken by smallest magnitude: limits fill-in
    /// on sparse matrices and equals `SmallestMagnitude` on dense ones.
    #[default]
    Markowitz,
    /// The nonzero of smallest magnitude (thesis Alg. 7).
    SmallestMagnitude,
    /// Diagonal entries only, least Markowitz cost first (minimum degree). Only for
    /// symmetric positive definite matrices, whose diagonal pivots never vanish; keeps the
    /// factoring symmetric and the fill low. Falls back to `Markowitz` if a diagonal pivot
    /// would be zero.
    SymmetricMarkowitz,
}

/// Options of [`Ldu::factor`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct LduOptions {
    /// Common-factor removal.
    pub simplification: Simplification,
    /// Pivot choice.
    pub pivoting: Pivoting,
}

impl LduOptions {
    /// Options with the given simplification and the default (Markowitz) pivoting.
    pub fn with(simplification: Simplification) -> LduOptions {
        LduOptions { simplification, pivoting: Pivoting::Markowitz }
    }
}

/// A fraction-free LDU factoring `A = Pr L D^-1 U Pc` (see the module docs).
#[derive(Clone, Debug)]
pub struct Ldu {
    m: usize,
    n: usize,
    rank: usize,
    row_perm: Vec<usize>,
    col_perm: Vec<usize>,
    /// Row `i` (by position) of `L`: `(k, L[i][k])`, sorted by `k`.
    l_rows: Vec<Vec<(usize, Int)>>,
    d: Vec<Int>,
    /// Row `k` of `U`: `(j, U[k][j])` by column position, sorted; the first entry is `(k, pivot)`.
    u_rows: Vec<Vec<(usize, Int)>>,
    /// Column `k` of `L`: `(i, L[i][k])` by row position, sorted; the first entry is `(k, L_kk)`.
    l_cols: Vec<Vec<(usize, Int)>>,
    /// Simplification used; with `Turner` the factors have Jeffrey's form
    /// (`L_kk = U_kk = p_k`, `D_k = p_(k-1) p_k`) and solves run in integers.
    simplification: Simplification,
}

/// A violated invariant found by [`Ldu::sanity_check`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("LDU invariant violated: {0}")]
pub struct InvariantError(pub String);

impl Ldu {
    /// Factors the sparse integer matrix `a`.
    pub fn factor(a: &SparseIntMatrix, opts: LduOptions) -> Ldu {
        factor::factor(a, opts)
    }

    /// Number of rows of `A`.
    pub fn rows(&self) -> usize {
        self.m
    }
    /// Number of columns of `A`.
    pub fn cols(&self) -> usize {
        self.n
    }
    /// The rank `r`.
    pub fn rank(&self) -> usize {
        self.rank
    }
    /// `row_perm[i]` is the row of `A` at position `i`; the first `rank` are independent.
    pub fn row_perm(&self) -> &[usize] {
        &self.row_perm
    }
    /// `col_perm[j]` is the column of `A` at position `j`; the first `rank` are pivot columns.
    pub fn col_perm(&self) -> &[usize] {
        &self.col_perm
    }
    /// Rows of `A` that form a maximal independent set (the non-redundant constraints).
    pub fn independent_rows(&self) -> &[usize] {
        &self.row_perm[..self.rank]
    }
    /// Rows of `A` that are linear combinations of the independent ones (redundant).
    pub fn redundant_rows(&self) -> &[usize] {
        &self.row_perm[self.rank..]
    }
    /// Row `i` of `L` (by position) as sorted `(k, value)` pairs.
    pub fn l_row(&self, i: usize) -> &[(usize, Int)] {
        &self.l_rows[i]
    }
    /// The diagonal of `D`.
    pub fn d(&self) -> &[Int] {
        &self.d
    }
    /// The simplification the factoring was computed with.
    pub fn simplification(&self) -> Simplification {
        self.simplification
    }
    /// Row `k` of `U` (by column position) as sorted `(j, value)` pairs.
    pub fn u_row(&self, k: usize) -> &[(usize, Int)] {
        &self.u_rows[k]
    }

    /// Largest bit size over all entries of `L`, `D` and `U` (thesis ch. 7).
    pub fn max_bits(&self) -> u64 {
        let l = self.l_rows.iter().flatten().map(|(_, v)| v.bits());
        let u = self.u_rows.iter().flatten().map(|(_, v)| v.bits());
        l.chain(u).chain(self.d.iter().map(Int::bits)).max().unwrap_or(0)
    }

    /// Number of stored nonzeros in `L` and `U` (a measure of fill-in).
    pub fn nnz(&self) -> usize {
        self.l_rows.iter().map(Vec::len).sum::<usize>()
            + self.u_rows.iter().map(Vec::len).sum::<usize>()
    }

    /// Checks the structural invariants: permutations, triangular shapes, nonzero diagonals.
    pub fn sanity_check(&self) -> Result<(), InvariantError> {
        let err = |s: String| Err(InvariantError(s));
        let is_perm = |p: &[usize], len: usize| {
            let mut seen = vec![false; len];
            p.len() == len && p.iter().all(|&i| i < len && !std::mem::replace(&mut seen[i], true))
        };
        if !is_perm(&self.row_perm, self.m) {
            return err("row_perm is not a permutation".into());
        }
        if !is_perm(&self.col_perm, self.n) {
            return err("col_perm is not a permutation".into());
        }
        let r = self.rank;
        if self.d.len() != r || self.u_rows.len() != r || self.l_rows.len() != self.m {
            return err("factor sizes do not match the rank".into());
        }
        if self.d.iter().any(Int::is_zero_int) {
            return err("zero in D".into());
        }
        for (k, row) in self.u_rows.iter().enumerate() {
            match row.first() {
                Some((j, v)) if *j == k && !v.is_zero_int() => {}
                _ => return err(format!("U row {k} has no nonzero diagonal")),
            }
            if row.windows(2).any(|w| w[0].0 >= w[1].0) || row.iter().any(|(j, _)| *j >= self.n) {
                return err(format!("U row {k} is not sorted or out of range"));
            }
            if row.iter().any(|(_, v)| v.is_zero_int()) {
                return err(format!("U row {k} stores a zero"));
            }
        }
        for (i, row) in self.l_rows.iter().enumerate() {
            if row.windows(2).any(|w| w[0].0 >= w[1].0) || row.iter().any(|(k, _)| *k >= r) {
                return err(format!("L row {i} is not sorted or out of range"));
            }
            if i < r {
                match row.last() {
                    Some((k, v)) if *k == i && !v.is_zero_int() => {}
                    _ => return err(format!("L row {i} has no nonzero diagonal")),
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
