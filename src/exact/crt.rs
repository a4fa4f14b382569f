//! Chinese remaindering and rational reconstruction.
//!
//! [`CrtVec`] accumulates a vector of residues modulo a growing product `M = p_1 ... p_k` of
//! word-size primes (incremental Garner step: `x <- x + M ((r - x) M^-1 mod p)`).
//!
//! [`CrtVec::reconstruct`] recovers rationals `n_i / d` from residues `u_i = n_i d^-1 mod M`
//! (Wang's half-extended Euclid; Wang, Guy and Davenport 1982): the fraction with
//! `|n| <= N`, `0 < d <= D`, `2 N D < M` is unique when it exists; we take `N = D =
//! floor(sqrt(M / 2))`. Entries share a common denominator in our solves, so the
//! reconstruction is output-sensitive: it keeps the product `D_c` of the denominators found
//! so far and, for each next entry, first tries `D_c u_i mod M` (symmetric residue) as the
//! numerator; only when that is too large does it run the Euclid on it. A successful
//! reconstruction is only a candidate: the callers verify it exactly before use.

use num_bigint::{BigInt, BigUint, Sign};
use num_integer::Integer;
use num_traits::{One, ToPrimitive, Zero};

use super::int::Int;
use super::matrix::ScaledVec;

/// A vector of residues modulo a product of primes.
#[derive(Clone, Debug)]
pub struct CrtVec {
    modulus: BigUint,
    values: Vec<BigUint>,
    primes: usize,
}

fn inv_mod_u64(a: u64, p: u64) -> u64 {
    let (mut t, mut nt) = (0i128, 1i128);
    let (mut r, mut nr) = (p as i128, a as i128);
    while nr != 0 {
        let q = r / nr;
        (t, nt) = (nt, t - q * nt);
        (r, nr) = (nr, r - q * nr);
    }
    debug_assert!(r == 1, "not invertible");
    t.rem_euclid(p as i128) as u64
}

impl CrtVec {
    /// `len` residues modulo 1.
    pub fn new(len: usize) -> CrtVec {
        CrtVec { modulus: BigUint::one(), values: vec![BigUint::zero(); len], primes: 0 }
    }

    /// Number of primes combined so far.
    pub fn primes(&self) -> usize {
        self.primes
    }

    /// Bit size of the modulus.
    pub fn modulus_bits(&self) -> u64 {
        self.modulus.bits()
    }

    /// Combines residues `r` (plain residues `< p`, not Montgomery) modulo a new prime `p`.
    pub fn add(&mut self, p: u64, r: &[u64]) {
        assert_eq!(r.len(), self.values.len());
        let mmod = (&self.modulus % p).to_u64().expect("below p");
        let minv = inv_mod_u64(mmod, p);
        for (x, &ri) in self.values.iter_mut().zip(r) {
            let xm = (&*x % p).to_u64().expect("below p");
            let diff = if ri >= xm { ri - xm } else { ri + p - xm };
            let k = ((diff as u128 * minv as u128) % p as u128) as u64;
            if k != 0 {
                *x += &self.modulus * k;
            }
        }
        self.modulus *= p;
        self.primes += 1;
    }

    /// Candidate rationals over one common denominator (see the module docs), or `None`
    /// when some entry has no fraction within the bounds yet (more primes are needed).
    pub fn reconstruct(&self) -> Option<ScaledVec> {
        reconstruct_common(&self.values, &self.modulus)
    }
}

/// Rational reconstruction of residues `values` modulo `modulus` over one common
/// denominator (see the module docs), or `None` when some entry has no fraction within
/// the bounds.
pub fn reconstruct_common(values: &[BigUint], modulus: &BigUint) -> Option<ScaledVec> {
    let m = BigInt::from_biguint(Sign::Plus, modulus.clone());
    let bound = BigInt::from_biguint(Sign::Plus, (modulus >> 1u32).sqrt());
    let half = &m >> 1u32;
    let mut den = BigInt::one();
    let mut nums: Vec<BigInt> = Vec::with_capacity(values.len());
    for u in values {
        if u.is_zero() {
            nums.push(BigInt::zero());
            continue;
        }
        let u = BigInt::from_biguint(Sign::Plus, u.clone());
        let mut y = if den.is_one() { u.clone() } else { (&u * &den).mod_floor(&m) };
        if y > half {
            y -= &m;
        }
        if y.magnitude() <= bound.magnitude() {
            nums.push(y);
            continue;
        }
        let (a, b) = wang(&y.mod_floor(&m), &m, &bound)?;
        // value = a / (b den): scale the earlier numerators by b.
        if (&den * &b) > bound {
            return None;
        }
        for v in nums.iter_mut() {
            *v *= &b;
        }
        den *= &b;
        nums.push(a);
    }
    Some(ScaledVec::new(nums.into_iter().map(Int::from_big).collect(), Int::from_big(den)))
}

/// Wang's rational reconstruction of `u mod m` with numerator and denominator at most `bound`.
fn wang(u: &BigInt, m: &BigInt, bound: &BigInt) -> Option<(BigInt, BigInt)> {
    let (mut r0, mut r1) = (m.clone(), u.clone());
    let (mut t0, mut t1) = (BigInt::zero(), BigInt::one());
    while r1.magnitude() > bound.magnitude() {
        let (q, r) = r0.div_rem(&r1);
        r0 = std::mem::replace(&mut r1, r);
        let nt = &t0 - &q * &t1;
        t0 = std::mem::replace(&mut t1, nt);
    }
    if t1.is_zero() || t1.magnitude() > bound.magnitude() || !r1.gcd(&t1).is_one() {
        return None;
    }
    if t1.sign() == Sign::Minus {
        Some((-r1, -t1))
    } else {
        Some((r1, t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::modp::primes;
    use crate::exact::Rat;

    fn residue(n: i64, d: i64, p: u64) -> u64 {
        let nn = n.rem_euclid(p as i64) as u64;
        let dd = d.rem_euclid(p as i64) as u64;
        ((nn as u128 * inv_mod_u64(dd, p) as u128) % p as u128) as u64
    }

    #[test]
    fn reconstructs_small_fractions_with_a_common_denominator() {
        let vals = [(3i64, 7i64), (-5, 21), (0, 1), (1_000_000_000_007, 3)];
        let mut c = CrtVec::new(vals.len());
        let ps = primes(3);
        for &p in &ps {
            let r: Vec<u64> = vals.iter().map(|&(n, d)| residue(n, d, p)).collect();
            c.add(p, &r);
        }
        let v = c.reconstruct().unwrap();
        for (i, &(n, d)) in vals.iter().enumerate() {
            assert_eq!(v.get(i), Rat::new(Int::from(n), Int::from(d)));
        }
    }

    #[test]
    fn too_few_primes_give_no_candidate_or_a_wrong_one() {
        // A 200-bit fraction cannot come from one 62-bit prime.
        let big = BigInt::from(3).pow(120u32);
        let p = primes(1)[0];
        let r = (&big % p).to_u64().unwrap();
        let mut c = CrtVec::new(1);
        c.add(p, &[r]);
        if let Some(v) = c.reconstruct() {
            assert_ne!(v.get(0), Rat::from_integer(Int::from_big(big)));
        }
    }
}
