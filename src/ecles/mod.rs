//! ECLES: editing parameters under exact affine constraints (thesis Part I, ch. 2 and 5; the
//! 2015 ECLeS paper).
//!
//! An object is described by `n` parameters `p_s`, each a point of `R^d` (an `n x d` matrix
//! `P`), tied by `m` affine constraints
//!
//! ```text
//!     R P = Q          R: m x n integer (sparse),  Q: m x d rational.
//! ```
//!
//! An edit names **anchors** `A` (their new values `P'_A` are imposed), **derived** parameters
//! `D` (they may move; hints `P'_D` say where they should preferably go) and keeps every other
//! parameter fixed (`F`). Only the *relevant* constraints `E` (rows touching `A` or `D`) and the
//! *fixed relevant* parameters `F'` (fixed ones that appear in `E`) matter (Alg. 2), so the
//! edit reduces to the small system (eq. 2.3)
//!
//! ```text
//!     R_ED P''_D = Q_E - R_EA P'_A - R_EF' P_F'.
//! ```
//!
//! [`ConstraintSystem::initialize`] (Alg. 1) factors `R_ED` once with the exact fraction-free
//! LDU, which also yields its rank and the redundant relevant constraints, and optionally
//! checks strong solvability (eqs. 8.15-8.16: solvable for *every* `P'_A`).
//! [`Session::update`] (Alg. 4) checks weak solvability (eq. 8.10: solvable for *these*
//! `P'_A`), then picks the `P''_D` nearest the hints in the weighted sense
//! `sum_s w_s |p''_s - p'_s|^2` under the constraints (Alg. 15). Results are exact rationals
//! and satisfy every constraint exactly. A failed update changes nothing.
//!
//! For dragging and optimization, [`Session::affine_map`] exposes the map
//! `P''_D = H P'_D + J P'_A + c`, exact and as `f64`, so thousands of candidate anchor
//! positions can be evaluated per second; one exact update then certifies the final state.
//!
//! ```
//! use trimorph::ecles::{ConstraintSystem, InitOptions};
//! use trimorph::exact::{IntMatrix, rat_int};
//! // The four pumps of thesis eq. 2.2: p1 + p2 = p3, p4 = p3 + 5.
//! let r = IntMatrix::from_i64_rows(4, &[vec![1, 1, -1, 0], vec![0, 0, -1, 1]]).to_sparse();
//! let sys = ConstraintSystem::new(r, vec![vec![rat_int(0)], vec![rat_int(5)]]).unwrap();
//! let p = vec![vec![rat_int(1)], vec![rat_int(2)], vec![rat_int(3)], vec![rat_int(8)]];
//! // Set pump 1 to 4; pumps 2 and 3 may adjust, pump 4 is fixed.
//! let mut s = sys.initialize(&p, &[0], &[1, 2], InitOptions::default()).unwrap();
//! s.update(&[vec![rat_int(4)]], None, None).unwrap();
//! assert_eq!(s.derived_values(), vec![vec![rat_int(-1)], vec![rat_int(3)]]);
//! ```

mod affine;
mod input;
pub(crate) mod modular;
pub(crate) mod output;
pub mod problem;
mod session;

pub use affine::{AffineMap, AffineMapF64};
pub use session::{InitOptions, Session};

use crate::exact::matrix::{Rat, SparseIntMatrix};
use num_traits::Zero;

/// Errors of the ECLES layer. Every error leaves the session it came from unchanged.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EclesError {
    /// A matrix or list has the wrong size.
    #[error("{what}: expected {expected}, found {found}")]
    Dimension {
        /// What was being checked.
        what: String,
        /// Expected size.
        expected: usize,
        /// Size found.
        found: usize,
    },
    /// A parameter index is out of range.
    #[error("{what}: parameter index {index} is out of range (there are {n} parameters)")]
    IndexOutOfRange {
        /// Which list held it.
        what: &'static str,
        /// The index.
        index: usize,
        /// Number of parameters.
        n: usize,
    },
    /// An index appears twice in a list.
    #[error("{what}: parameter {index} is listed twice")]
    Duplicate {
        /// Which list.
        what: &'static str,
        /// The index.
        index: usize,
    },
    /// A parameter is both an anchor and derived.
    #[error("parameter {index} is both an anchor and derived; a parameter can be only one")]
    AnchorAlsoDerived {
        /// The index.
        index: usize,
    },
    /// No anchors given.
    #[error("the edit has no anchors: name at least one parameter to move")]
    NoAnchors,
    /// A weight is not positive.
    #[error("weight of parameter {index} is {value}; weights must be positive")]
    NonPositiveWeight {
        /// The parameter index.
        index: usize,
        /// The weight, as text.
        value: String,
    },
    /// Strong solvability (eqs. 8.15-8.16) fails.
    #[error("not strongly solvable: relevant constraint {constraint} cannot be kept for every value of {cause}; add derived parameters near it")]
    NotStronglySolvable {
        /// The constraint (original index) that would be violated.
        constraint: usize,
        /// `anchor k` or `the fixed parameters`.
        cause: String,
    },
    /// Weak solvability (eq. 8.10) fails for these anchor values.
    #[error("not weakly solvable: with these anchor values, constraint {constraint} (coordinate {column}) cannot be satisfied by moving the derived parameters")]
    NotWeaklySolvable {
        /// The constraint (original index) that cannot be satisfied.
        constraint: usize,
        /// The coordinate (column of P) that fails.
        column: usize,
    },
}

/// The constraints `R P = Q` of an object with `n` parameters in `R^d`.
#[derive(Clone, Debug)]
pub struct ConstraintSystem {
    r: SparseIntMatrix,
    q: Vec<Vec<Rat>>,
    d: usize,
    /// For each parameter, the constraints that involve it.
    param_rows: Vec<Vec<usize>>,
}

impl ConstraintSystem {
    /// A system from `R` (`m x n`) and `Q` (`m` rows of `d` values, `d >= 1`).
    pub fn new(r: SparseIntMatrix, q: Vec<Vec<Rat>>) -> Result<ConstraintSystem, EclesError> {
        if q.len() != r.rows() {
            return Err(EclesError::Dimension {
                what: "rows of Q (one per constraint)".into(),
                expected: r.rows(),
                found: q.len(),
            });
        }
        let d = q.first().map_or(1, Vec::len);
        if let Some((i, row)) = q.iter().enumerate().find(|(_, row)| row.len() != d) {
            return Err(EclesError::Dimension {
                what: format!("columns of Q row {i}"),
                expected: d,
                found: row.len(),
            });
        }
        Self::with_dim(r, q, d)
    }

    /// A homogeneous system `R P = 0` with parameters in `R^d`.
    pub fn homogeneous(r: SparseIntMatrix, d: usize) -> ConstraintSystem {
        let q = vec![vec![Rat::zero(); d]; r.rows()];
        Self::with_dim(r, q, d).expect("sizes match")
    }

    /// A system whose `Q` may have zero rows (`m = 0`) with an explicit dimension `d`.
    pub fn with_dim(
        r: SparseIntMatrix,
        q: Vec<Vec<Rat>>,
        d: usize,
    ) -> Result<ConstraintSystem, EclesError> {
        if q.len() != r.rows() {
            return Err(EclesError::Dimension {
                what: "rows of Q".into(),
                expected: r.rows(),
                found: q.len(),
            });
        }
        if let Some(row) = q.iter().find(|row| row.len() != d) {
            return Err(EclesError::Dimension {
                what: "columns of Q".into(),
                expected: d,
                found: row.len(),
            });
        }
        let mut param_rows = vec![Vec::new(); r.cols()];
        for i in 0..r.rows() {
            for (c, _) in r.row(i) {
                param_rows[*c].push(i);
            }
        }
        Ok(ConstraintSystem { r, q, d, param_rows })
    }

    /// Number of parameters `n`.
    pub fn params(&self) -> usize {
        self.r.cols()
    }
    /// Number of constraints `m`.
    pub fn constraints(&self) -> usize {
        self.r.rows()
    }
    /// Dimension `d` of each parameter.
    pub fn dim(&self) -> usize {
        self.d
    }
    /// The coefficient matrix `R`.
    pub fn matrix(&self) -> &SparseIntMatrix {
        &self.r
    }
    /// The right-hand side `Q`.
    pub fn rhs(&self) -> &[Vec<Rat>] {
        &self.q
    }
    /// Constraints that involve parameter `s`.
    pub fn constraints_of(&self, s: usize) -> &[usize] {
        &self.param_rows[s]
    }

    /// The constraints (with coordinate) that `p` violates, in order; empty when `R P = Q`
    /// holds exactly.
    pub fn violations(&self, p: &[Vec<Rat>]) -> Vec<(usize, usize)> {
        let rp = self.r.mul_rat(p);
        let mut out = Vec::new();
        for (i, (row, q)) in rp.iter().zip(&self.q).enumerate() {
            for c in 0..self.d {
                let lhs = row.get(c).cloned().unwrap_or_else(Rat::zero);
                if lhs != q[c] {
                    out.push((i, c));
                }
            }
        }
        out
    }

    /// True when `R P = Q` holds exactly.
    pub fn is_satisfied(&self, p: &[Vec<Rat>]) -> bool {
        self.violations(p).is_empty()
    }

    /// The same exact check as [`ConstraintSystem::is_satisfied`] without any gcd: each row
    /// sum is accumulated as an unreduced fraction (terms over the same denominator, such as
    /// the common denominator of an exact solve, are added directly) and compared with `Q`
    /// by cross multiplication. `p` may hold unreduced values (`Rat::new_raw`).
    pub fn is_satisfied_fast(&self, p: &[Vec<Rat>]) -> bool {
        use crate::exact::Int;
        use num_traits::One;
        use rayon::prelude::*;
        (0..self.r.rows()).into_par_iter().all(|i| {
            (0..self.d).all(|c| {
                let (mut num, mut den) = (Int::zero(), Int::one());
                for (j, v) in self.r.row(i) {
                    let x = &p[*j][c];
                    if x.numer().is_zero() {
                        continue;
                    }
                    let t = v * x.numer();
                    if x.denom() == &den {
                        num += &t;
                    } else if den.is_one() {
                        num = &(&num * x.denom()) + &t;
                        den = x.denom().clone();
                    } else {
                        // num / den + t / xd = (num xd + t den) / (den xd)
                        num = Int::cross(&num, x.denom(), &-t, &den);
                        den = &den * x.denom();
                    }
                }
                let q = &self.q[i][c];
                &num * q.denom() == &den * q.numer()
            })
        })
    }

    /// Relevant constraints `E` and fixed relevant parameters `F'` (Alg. 2), both sorted.
    pub fn extract_relevant(
        &self,
        anchors: &[usize],
        derived: &[usize],
    ) -> (Vec<usize>, Vec<usize>) {
        let n = self.params();
        let mut moving = vec![false; n];
        for &s in anchors.iter().chain(derived) {
            moving[s] = true;
        }
        let mut e: Vec<usize> = anchors
            .iter()
            .chain(derived)
            .flat_map(|&s| self.param_rows[s].iter().copied())
            .collect();
        e.sort_unstable();
        e.dedup();
        let mut f: Vec<usize> = e
            .iter()
            .flat_map(|&i| self.r.row(i).iter().map(|(c, _)| *c))
            .filter(|&c| !moving[c])
            .collect();
        f.sort_unstable();
        f.dedup();
        (e, f)
    }
}

#[cfg(test)]
mod tests;
