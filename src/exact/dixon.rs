//! Dixon's p-adic lifting for nonsingular sparse integer systems (Dixon 1982), with an
//! exact, self-certifying termination.
//!
//! For `A y = c` (`A` nonsingular `k x k`, `c` integer) and one prime `p` with `A mod p`
//! factored once ([`LuModP`], Markowitz order), the lifting keeps the exact identity
//!
//! ```text
//!     A y_j + p^j r_j = c,      y_j = sum_{i<j} x_i p^i,     r_0 = c,
//!     x_j = A^-1 r_j mod p  (symmetric digit in (-p/2, p/2)),   r_(j+1) = (r_j - A x_j) / p
//! ```
//!
//! (the division is exact). The residual stays as small as `A`'s row sums, so each step is
//! one triangular solve modulo `p` and one sparse product in 128-bit integers.
//!
//! 1. **Denominator.** The solution is `y = Y / D`. Lifting `c` and reconstructing the single
//!    random combination `s = w . y` from `s mod p^j` (Wang's rational reconstruction, at
//!    steps growing by half) gives `D` as soon as `p^j` exceeds about `2 |num(s)| D`: the
//!    work follows the size of the answer, not a determinant bound (output-sensitive early
//!    termination). Balanced bounds make most residues reconstruct to *some* fraction, so a
//!    candidate is taken only when two consecutive attempts agree. Attempts come at steps
//!    growing by a quarter; each success is confirmed by an attempt at the very next step
//!    (a spurious fraction does not survive one more digit), so the lifting stops one step
//!    after the first attempt that finds the true `D`, not a quarter later (the 400 x 800
//!    benchmark: 118 steps a column instead of 147; issue 24).
//! 2. **Numerators.** `D` may lack a prime `q` of the common denominator when the
//!    combination's numerator happens to be divisible by it (chance about `1/q`: a factor 2
//!    every other time), so the numerators are lifted for `D' = D S`, with `S` a product of
//!    small prime powers ([`SMOOTH`], 29 bits; the 400 x 800 criterion instance missed a
//!    factor 2 and lifted 236 numerator steps before reconstructing entry by entry, instead
//!    of 54). With `D'` for `D`: lifting `D c` gives the *integer* vector `Y`; with symmetric digits the
//!    residual becomes exactly zero once `p^j > 2 |Y|`, and then `A Y = D c` holds exactly
//!    by the identity above. If it does not vanish within a bound, `D` missed a factor (the
//!    combination cancelled it) and `D y` is reconstructed entry by entry from its residues
//!    modulo `p^j` instead.
//!
//! The caller still verifies the result exactly (see [`super::modular::verify`]).

use super::int::{Int, IntView};
use super::matrix::{ScaledVec, SparseIntMatrix};
use super::modp::{primes, rows_mod, LuModP, SolveStats, Zp};
use num_bigint::BigInt;
use num_integer::Integer;
use num_traits::{One, Zero};
use rayon::prelude::*;

/// Largest absolute entry of `A` for the 128-bit residual products.
const MAX_ENTRY: i64 = 1 << 56;

/// Lifting steps allowed for the denominator phase (about 600,000 bits of answer).
const MAX_STEPS: usize = 10_000;

/// Small primes the numerator phase multiplies the denominator by (`2^8 3^4 5^2 7 11 13`,
/// about 2^29), in case the reconstructed combination's denominator missed some of them.
const SMOOTH: u64 = 256 * 81 * 25 * 7 * 11 * 13;

struct Lifter<'a> {
    a: &'a SparseIntMatrix,
    lu: LuModP,
    /// `lu` in gather form, for the one solve per step.
    solver: super::modp::LuSolver,
    /// The numerator phase's factor ([`SMOOTH`]; 1 only in the test that shows why).
    smooth: u64,
    /// Rows of `A` as `(column, value)` in `i64`.
    rows: Vec<Vec<(usize, i64)>>,
}

impl Lifter<'_> {
    /// One step: digits `x` (symmetric) of `A^-1 r mod p`, then `r <- (r - A x) / p`.
    fn step(&self, r: &mut [Int], x: &mut [i64], bm: &mut [u64], xm: &mut [u64]) -> bool {
        let zp = &self.lu.zp;
        let p = zp.p;
        for (o, v) in bm.iter_mut().zip(r.iter()) {
            *o = zp.from_int(v);
        }
        if self.solver.solve(bm, xm).is_none() {
            return false;
        }
        for (o, &v) in x.iter_mut().zip(xm.iter()) {
            let u = zp.from_mont(v);
            *o = if u > p / 2 { u as i64 - p as i64 } else { u as i64 };
        }
        let pi = p as i128;
        let p_inv = inverse_mod_2_128(p);
        for (ri, row) in r.iter_mut().zip(&self.rows) {
            let mut ax: i128 = 0;
            for &(j, v) in row {
                ax += v as i128 * x[j] as i128;
            }
            *ri = match ri.view() {
                IntView::Small(s) => {
                    let t = s as i128 - ax;
                    debug_assert!(t % pi == 0);
                    // An exact quotient is the product with p's inverse modulo 2^128 (no
                    // 128-bit division: it was a library call per entry and step).
                    let q = (t as u128).wrapping_mul(p_inv) as i128;
                    debug_assert_eq!(q, t / pi);
                    Int::from_i128(q)
                }
                IntView::Big(b) => {
                    let t = b - BigInt::from(ax);
                    debug_assert!((&t % BigInt::from(p)).is_zero());
                    Int::from_big(t / BigInt::from(p))
                }
            };
        }
        true
    }
}

/// Solves `A X = B` for the columns `b` by lifting; `None` when lifting does not apply
/// (large entries, singular modulo the primes tried) or does not terminate.
pub fn solve(a: &SparseIntMatrix, b: &[ScaledVec]) -> Option<(Vec<ScaledVec>, SolveStats)> {
    let k = a.rows();
    let mut rows = Vec::with_capacity(k);
    for i in 0..k {
        let mut r = Vec::with_capacity(a.row(i).len());
        for (j, v) in a.row(i) {
            match v.as_i64() {
                Some(s) if s.unsigned_abs() < MAX_ENTRY as u64 => r.push((*j, s)),
                _ => return None,
            }
        }
        rows.push(r);
    }
    let lu = primes(3).into_iter().find_map(|p| {
        let zp = Zp::new(p);
        let lu = LuModP::factor(zp, k, rows_mod(&zp, a));
        (lu.rank() == k).then_some(lu)
    })?;
    let solver = lu.solver();
    let lifter = Lifter { a, lu, solver, rows, smooth: SMOOTH };
    let sols: Vec<Option<(ScaledVec, usize)>> =
        b.par_iter().map(|col| lifter.solve_column(col)).collect();
    let mut stats = SolveStats::default();
    let mut out = Vec::with_capacity(b.len());
    for s in sols {
        let (v, steps) = s?;
        stats.primes += steps;
        out.push(v);
    }
    Some((out, stats))
}

impl Lifter<'_> {
    fn solve_column(&self, col: &ScaledVec) -> Option<(ScaledVec, usize)> {
        let k = self.a.rows();
        if col.num.iter().all(Int::is_zero_int) {
            return Some((ScaledVec::new(vec![Int::zero(); k], Int::one()), 0));
        }
        let t0 = std::time::Instant::now();
        let p = BigInt::from(self.lu.zp.p);
        let (mut bm, mut xm, mut x) = (vec![0u64; k], vec![0u64; k], vec![0i64; k]);
        // Phase 1: the denominator of w . y.
        let w: Vec<i64> = (0..k).map(|i| 1 + ((i as i64 * 7919 + 13) % 65_521)).collect();
        let mut r = col.num.clone();
        let (mut s, mut pj) = (BigInt::zero(), BigInt::one());
        let mut schedule = Schedule::new();
        let mut den = None;
        let mut steps = 0;
        while steps < MAX_STEPS {
            if !self.step(&mut r, &mut x, &mut bm, &mut xm) {
                return None;
            }
            let wx: i128 = w.iter().zip(&x).map(|(&wi, &xi)| wi as i128 * xi as i128).sum();
            s += &pj * BigInt::from(wx);
            pj *= &p;
            steps += 1;
            if r.iter().all(Int::is_zero_int) {
                den = Some(BigInt::one()); // an integer solution: the lifting ended
                break;
            }
            if steps >= schedule.next {
                if let Some(d) = schedule.attempt(steps, wang_den(&s.mod_floor(&pj), &pj)) {
                    den = Some(d);
                    break;
                }
            }
        }
        let den = den?;
        let phase1 = (steps, t0.elapsed().as_secs_f64());
        // Phase 2: the integer numerators Y of D' c, D' = D times SMOOTH: the denominator of
        // one combination `w . y` misses a prime q of the common denominator with chance
        // about 1/q (a factor 2 half the time), and then Y would not be integral; with
        // SMOOTH's small primes in D' it still is, for about half a step more.
        let den = den * self.smooth;
        let dint = Int::from_big(den.clone());
        let mut r: Vec<Int> = col.num.iter().map(|v| v * &dint).collect();
        let mut digits: Vec<Vec<i64>> = Vec::new();
        let trace = std::env::var_os("TRIMORPH_TRACE").is_some();
        let limit = 2 * steps + 20;
        let mut exact = true;
        loop {
            if r.iter().all(Int::is_zero_int) {
                break;
            }
            if digits.len() >= limit {
                exact = false;
                break;
            }
            if !self.step(&mut r, &mut x, &mut bm, &mut xm) {
                return None;
            }
            digits.push(x.clone());
        }
        let pu = self.lu.zp.p;
        // p^(2^l) for the divide-and-conquer conversion of the digits.
        let mut powers = vec![BigInt::from(pu)];
        while (1usize << powers.len()) < digits.len() {
            let last = powers.last().expect("nonempty");
            powers.push(last * last);
        }
        let y: Vec<Int> = (0..k)
            .into_par_iter()
            .map(|i| {
                let d: Vec<i64> = digits.iter().map(|x| x[i]).collect();
                Int::from_big(from_digits(&d, &powers))
            })
            .collect();
        let total = steps + digits.len();
        if trace && total > 200 {
            eprintln!(
                "trace: lifting: denominator {} bits after {} steps ({:.3} s), numerators {} steps, done {:.3} s",
                den.bits(),
                phase1.0,
                phase1.1,
                digits.len(),
                t0.elapsed().as_secs_f64()
            );
        }
        if exact {
            return Some((ScaledVec::new(y, &dint * &col.den), total));
        }
        // D y is not integral: D missed a factor of the common denominator (the random
        // combination cancelled it). Reconstruct D y modulo p^j entry by entry instead.
        let modulus = BigInt::from(pu).pow(digits.len() as u32);
        let vals: Vec<num_bigint::BigUint> =
            y.iter().map(|v| v.to_big().mod_floor(&modulus).magnitude().clone()).collect();
        let z = super::crt::reconstruct_common(&vals, modulus.magnitude())?;
        Some((ScaledVec::new(z.num, &(&z.den * &dint) * &col.den), total))
    }
}

/// `p^-1 mod 2^128` for odd `p` (Newton's iteration doubles the correct low bits: p is its
/// own inverse modulo 8, then 6, 12, ..., 192 bits).
fn inverse_mod_2_128(p: u64) -> u128 {
    let p = p as u128;
    let mut inv = p;
    for _ in 0..6 {
        inv = inv.wrapping_mul(2u128.wrapping_sub(p.wrapping_mul(inv)));
    }
    debug_assert_eq!(p.wrapping_mul(inv), 1);
    inv
}

/// The scheduled attempt after step `j` (growing by a quarter).
fn attempt_after(j: usize) -> usize {
    j + j / 4 + 1
}

/// When phase 1 tries a reconstruction, and when it takes one (module docs).
struct Schedule {
    /// The step of the next attempt.
    next: usize,
    /// The last attempt's denominator, while it waits for its confirmation.
    pending: Option<BigInt>,
}

impl Schedule {
    fn new() -> Schedule {
        Schedule { next: 2, pending: None }
    }

    /// Records the attempt at `step` (`found`: its denominator, if it reconstructed) and
    /// returns the denominator to take, if two consecutive attempts agree. Two consecutive
    /// attempts must agree: a lone early success can be spurious (found on the 102-triangle
    /// select-all, where it sent the solve to CRT). A new success is confirmed at the next
    /// step; anything else returns to the schedule.
    fn attempt(&mut self, step: usize, found: Option<BigInt>) -> Option<BigInt> {
        if found.is_some() && found == self.pending {
            return found;
        }
        let confirming = self.pending.is_some();
        self.next = if found.is_some() && !confirming { step + 1 } else { attempt_after(step) };
        self.pending = if confirming { None } else { found };
        None
    }
}

/// `sum_i d_i p^i` for signed digits `d`, by halves (`powers[l] = p^(2^l)`): a balanced
/// product tree uses the fast multiplication where Horner's rule would be quadratic.
fn from_digits(d: &[i64], powers: &[BigInt]) -> BigInt {
    if d.len() <= 8 {
        let mut acc = BigInt::zero();
        for &x in d.iter().rev() {
            acc *= &powers[0];
            acc += x;
        }
        return acc;
    }
    let mut l = 0;
    while (2usize << l) < d.len() {
        l += 1;
    }
    let (lo, hi) = d.split_at(1 << l);
    from_digits(lo, powers) + from_digits(hi, powers) * &powers[l]
}

/// The denominator of Wang's reconstruction of `u mod m` (`0 <= u < m`, bounds
/// `sqrt(m / 2)`), by [`super::gcd::wang_den`].
fn wang_den(u: &BigInt, m: &BigInt) -> Option<BigInt> {
    super::gcd::wang_den(u.magnitude(), m.magnitude()).map(BigInt::from)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::ldu::{Ldu, LduOptions};
    use crate::exact::Rat;

    #[test]
    fn lifting_matches_the_fraction_free_solve() {
        let rows: Vec<Vec<(usize, Int)>> = (0..30)
            .map(|i: usize| {
                vec![
                    (i, Int::from(7 + (i % 5) as i64)),
                    ((i + 1) % 30, Int::from(-3)),
                    ((i * 7 + 2) % 30, Int::from(2 + (i % 3) as i64)),
                ]
            })
            .map(|mut r| {
                r.sort_by_key(|e| e.0);
                r.dedup_by_key(|e| e.0);
                r
            })
            .collect();
        let a = SparseIntMatrix::from_rows(30, rows).unwrap();
        let b: Vec<Rat> =
            (0..30).map(|i| Rat::new(Int::from(i as i64 - 11), Int::from(3))).collect();
        let want = Ldu::factor(&a, LduOptions::default()).solve(&b).unwrap();
        let (got, stats) = solve(&a, &[ScaledVec::from_rats(&b)]).unwrap();
        assert_eq!(got[0].to_rats(), want);
        assert!(stats.primes >= 2);
    }

    /// The bug of the first lifting version: it took the denominator from the first rational
    /// reconstruction that succeeded. With balanced bounds most residues reconstruct to
    /// *some* fraction, so an answer larger than the first modulus gave a spurious
    /// denominator, the numerator phase could not end exactly, and the solve fell back to
    /// CRT (the 102-triangle select-all). Here the first attempt that reconstructs gives a
    /// wrong denominator, and lifting still returns the exact answer.
    #[test]
    fn dixon_denominator_needs_two_agreeing_attempts() {
        use rand::{Rng, SeedableRng};
        let k = 40;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(24);
        let rows: Vec<Vec<(usize, Int)>> = (0..k)
            .map(|i| {
                let mut r: Vec<(usize, Int)> = (0..6)
                    .map(|_| {
                        (rng.gen_range(0..k), Int::from(rng.gen_range(-(1i64 << 50)..1 << 50)))
                    })
                    .collect();
                r.push((i, Int::from(1i64 << 52)));
                r.sort_by_key(|e| e.0);
                r.dedup_by_key(|e| e.0);
                r
            })
            .collect();
        let a = SparseIntMatrix::from_rows(k, rows).unwrap();
        let b: Vec<Rat> = (0..k).map(|i| Rat::from_integer(Int::from(i as i64 - 17))).collect();
        let want = Ldu::factor(&a, LduOptions::default()).solve(&b).unwrap();
        let col = ScaledVec::from_rats(&b);
        // Phase 1 by hand for two steps: the first reconstruction attempt.
        let lu = primes(1)
            .into_iter()
            .map(|p| LuModP::factor(Zp::new(p), k, rows_mod(&Zp::new(p), &a)))
            .next()
            .unwrap();
        assert_eq!(lu.rank(), k);
        let rows64 = (0..k)
            .map(|i| a.row(i).iter().map(|(j, v)| (*j, v.as_i64().unwrap())).collect())
            .collect();
        let solver = lu.solver();
        let lifter = Lifter { a: &a, lu, solver, rows: rows64, smooth: SMOOTH };
        let w: Vec<i64> = (0..k).map(|i| 1 + ((i as i64 * 7919 + 13) % 65_521)).collect();
        let (mut bm, mut xm, mut x) = (vec![0u64; k], vec![0u64; k], vec![0i64; k]);
        let (mut r, mut s, mut pj) = (col.num.clone(), BigInt::zero(), BigInt::one());
        let p = BigInt::from(lifter.lu.zp.p);
        // The old rule: the first attempt (same schedule as `solve_column`) that reconstructs.
        let ws = want
            .iter()
            .zip(&w)
            .fold(Rat::zero(), |acc, (y, &wi)| acc + y * Rat::from_integer(Int::from(wi)));
        let (mut steps, mut next_try, mut first) = (0usize, 2usize, None);
        while first.is_none() && steps < 30 {
            assert!(lifter.step(&mut r, &mut x, &mut bm, &mut xm));
            let wx: i128 = w.iter().zip(&x).map(|(&wi, &xi)| wi as i128 * xi as i128).sum();
            s += &pj * BigInt::from(wx);
            pj *= &p;
            steps += 1;
            if steps >= next_try {
                next_try = steps + steps / 4 + 1;
                first = wang_den(&s.mod_floor(&pj), &pj).map(|d| (d, steps));
            }
        }
        let (first, at) = first.expect("some early attempt reconstructs");
        assert!(at < 24, "the first success comes early ({at} steps)");
        assert_ne!(Int::from_big(first), ws.denom().clone(), "and it is spurious");
        // The answer needs far more digits than the old numerator phase allowed after a
        // denominator taken that early (2 * steps + 20 digits).
        assert!(ws.denom().bits() > (2 * at as u64 + 20) * 62);
        let (got, stats) = solve(&a, std::slice::from_ref(&col)).expect("lifting certifies");
        assert_eq!(got[0].to_rats(), want);
        assert!(stats.primes > 24, "{stats:?}");
    }

    /// A success is confirmed at the next step and taken only when it repeats; a failed
    /// confirmation returns to the quarter-growing schedule; failures never wait.
    #[test]
    fn the_schedule_confirms_each_success_at_the_next_step() {
        let d = |v: i64| Some(BigInt::from(v));
        let mut s = Schedule::new();
        assert_eq!(s.next, 2);
        assert_eq!(s.attempt(2, None), None);
        assert_eq!(s.next, attempt_after(2));
        assert_eq!(s.attempt(3, d(7)), None);
        assert_eq!(s.next, 4, "confirm at the next step");
        assert_eq!(s.attempt(4, d(11)), None, "a different denominator is not taken");
        assert_eq!(s.next, attempt_after(4));
        assert!(s.pending.is_none(), "nor kept as the next confirmation's reference");
        assert_eq!(s.attempt(6, d(11)), None, "a new success after a failed confirmation");
        assert_eq!(s.next, 7);
        assert_eq!(s.attempt(7, d(11)), d(11), "taken when it repeats");
        let mut s = Schedule::new();
        assert_eq!(s.attempt(100, d(5)), None);
        assert_eq!(s.attempt(101, None), None);
        assert_eq!(s.next, attempt_after(101));
    }

    /// Exact quotients by multiplication with the inverse modulo 2^128, at the ends of the
    /// range the residual products reach.
    #[test]
    fn exact_division_by_the_inverse_modulo_2_128() {
        for &p in &primes(3) {
            let inv = inverse_mod_2_128(p);
            for q in [
                0i128,
                1,
                -1,
                12345,
                -(1 << 60),
                1 << 64,
                -(1i128 << 64) + 7,
                i128::MAX / p as i128,
                i128::MIN / p as i128 + 1,
            ] {
                let t = q * p as i128;
                assert_eq!((t as u128).wrapping_mul(inv) as i128, q, "p {p} q {q}");
            }
        }
    }

    /// A banded integer system like the 400 x 800 benchmark's Gram matrix, smaller.
    fn banded(k: usize, seed: u64) -> (SparseIntMatrix, ScaledVec) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(seed);
        let rows: Vec<Vec<(usize, Int)>> = (0..k)
            .map(|i| {
                let mut r: Vec<(usize, Int)> = (0..4)
                    .map(|_| {
                        let j = (i + rng.gen_range(0..9)).saturating_sub(4).min(k - 1);
                        (j, Int::from(rng.gen_range(-20i64..=20)))
                    })
                    .collect();
                r.push((i, Int::from(2 * rng.gen_range(10i64..30))));
                r.sort_by_key(|e| e.0);
                r.dedup_by_key(|e| e.0);
                r.retain(|e| !e.1.is_zero());
                r
            })
            .collect();
        let a = SparseIntMatrix::from_rows(k, rows).unwrap();
        let b: Vec<Rat> =
            (0..k).map(|i| Rat::from_integer(Int::from((i % 7) as i64 - 3))).collect();
        (a, ScaledVec::from_rats(&b))
    }

    /// The combination `w . y` sometimes lacks a small prime of the common denominator (a
    /// factor 2 about every other time); without [`SMOOTH`] the numerator phase then runs
    /// to its limit and reconstructs entry by entry (the criterion 400 x 800 instance: 236
    /// numerator steps instead of 54). With it the numerators end exactly, in far fewer
    /// steps, on every system here; both give the fraction-free answer.
    #[test]
    fn smooth_factors_keep_the_numerator_phase_exact() {
        let mut slower = 0;
        for seed in 0..12u64 {
            let (a, col) = banded(60, seed);
            let Ok(want) = Ldu::factor(&a, LduOptions::default()).solve(&col.to_rats()) else {
                continue;
            };
            let zp = Zp::new(primes(1)[0]);
            let lu = LuModP::factor(zp, a.rows(), rows_mod(&zp, &a));
            if lu.rank() < a.rows() {
                continue;
            }
            let rows: Vec<Vec<(usize, i64)>> = (0..a.rows())
                .map(|i| a.row(i).iter().map(|(j, v)| (*j, v.as_i64().unwrap())).collect())
                .collect();
            let mk = |smooth| Lifter {
                a: &a,
                lu: lu.clone(),
                solver: lu.solver(),
                rows: rows.clone(),
                smooth,
            };
            let (with, n_with) = mk(SMOOTH).solve_column(&col).unwrap();
            let (without, n_without) = mk(1).solve_column(&col).unwrap();
            assert_eq!(with.to_rats(), want, "seed {seed}");
            assert_eq!(without.to_rats(), want, "seed {seed}");
            assert!(n_with <= n_without + 1, "seed {seed}: {n_with} > {n_without}");
            if n_without > n_with + 10 {
                slower += 1;
            }
        }
        assert!(slower > 0, "some system's combination misses a small prime");
    }
}
