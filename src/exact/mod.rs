//! Exact integer and rational linear algebra (thesis Part I, ch. 4 and 6-9).
//!
//! * [`Int`]: exact integers with an `i64` fast path; [`Rat`]: exact rationals over them.
//! * [`IntMatrix`] / [`SparseIntMatrix`]: dense and sparse integer matrices.
//! * [`Ldu`]: fraction-free LDU factoring `A = Pr L D^-1 U Pc` of any integer matrix, with
//!   None / GCD / Turner simplification, rank, redundant rows, exact solve and consistency.
//! * [`WeightedLsq`]: weighted least squares under the independent constraints (Alg. 15).
//! * [`modp`], [`crt`], [`modular`]: the multi-modular path for large systems: sparse LU
//!   modulo word-size primes, Chinese remaindering, rational reconstruction with early
//!   termination, and an exact verification of every answer.
//! * [`gcd`]: Lehmer's gcd and Wang's rational reconstruction on 64-bit limbs, in place.
//! * [`radix`]: decimal text of big integers (two interleaved reciprocal divisions).
//! * [`lowest`]: lowest terms of many values over one denominator, with a few gcds and
//!   products instead of one gcd per value.

#[cfg(feature = "study")]
pub mod bitgrowth;
pub mod crt;
pub(crate) mod dixon;
pub(crate) mod gcd;
pub mod int;
pub mod ldu;
pub mod lowest;
pub mod lsq;
pub mod matrix;
pub mod modp;
pub(crate) mod modular;
pub mod radix;
#[cfg(test)]
pub(crate) mod reference;

pub use int::{Int, IntView};
pub use ldu::{Ldu, LduOptions, Pivoting, Simplification};
pub use lsq::WeightedLsq;
pub use matrix::{
    exact_decimal, parse_rat, rat_from_big, rat_from_f64, rat_from_i128, rat_int, rat_to_big,
    rat_to_f64, rat_to_string, IntMatrix, ParseRatError, Rat, ScaledVec, SparseIntMatrix,
};
