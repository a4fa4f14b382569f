//! Lehmer's gcd on 64-bit limbs, updated in place.
//!
//! Lehmer's algorithm (Knuth, TAOCP vol. 2, 4.5.2, Algorithm L) runs the Euclidean steps on
//! the leading bits of `u >= v` in machine words, collecting the 2 x 2 cofactor matrix, and
//! then applies the matrix to the full numbers once. Two tests decide how far a pass may go.
//!
//! * **[`gcd_limbs`]: a valid reduction (Jebelean's idea, in the form of Moller, "On
//!   Schonhage's algorithm and subquadratic integer gcd computation", 2008, sec. 2).** Write
//!   `u = uh 2^s + ul`, `v = vh 2^s + vl` with `0 <= ul, vl < 2^s` and `uh` the leading 63
//!   bits. Euclid's steps on `(uh, vh)` give remainders `r_k = s_k uh + t_k vh` whose
//!   cofactors alternate in sign. The same row applied to the full numbers is
//!   `s_k u + t_k v = r_k 2^s + (s_k ul + t_k vl)`, and since the two terms of the bracket
//!   have opposite signs its magnitude is below `max(|s_k|, |t_k|) 2^s = |t_k| 2^s`
//!   (`|t_k| >= |s_k|` from the first step on). So the full row is nonnegative as long as
//!   `r_k >= |t_k|`: the pass stops before the first remainder below its cofactor, about
//!   halfway down the window (~31 bits per pass, one division per step). The matrix is a
//!   product of Euclid steps, so it is unimodular and `gcd(u', v') = gcd(u, v)`; the quotients
//!   need not be the full numbers' own. Every row taken is nonnegative, so `u + v` falls
//!   with each step and the loop ends.
//! * **[`wang_den`]: Collins' condition.** The half extended Euclid must visit the full
//!   numbers' own remainder sequence, so its passes continue only while the quotient is the
//!   same for both ends of the interval the leading 62 bits stand for (two divisions a step).
//!
//! Each update is one loop over the limbs of both numbers, with signed 128-bit carries and
//! no allocation. This is what makes exact output cheap: lowest terms need gcds of numbers
//! of thousands of bits (issue 24; see also [`super::lowest`]).
//!
//! [`wang_den`] is Wang's rational reconstruction (the half extended Euclid that stops at
//! the first remainder below `sqrt(m / 2)`) with the same word-level passes while the
//! remainders are far above the bound, then single steps; Dixon lifting calls it at every
//! termination attempt ([`super::dixon`]).

use num_bigint::BigUint;
use std::cmp::Ordering;

/// `gcd(u, v)` (nonnegative; `gcd(0, 0) = 0`).
pub fn gcd_biguint(u: &BigUint, v: &BigUint) -> BigUint {
    to_big(&gcd_limbs(u.to_u64_digits(), v.to_u64_digits()))
}

fn trim(x: &mut Vec<u64>) {
    while x.last() == Some(&0) {
        x.pop();
    }
}

fn cmp(a: &[u64], b: &[u64]) -> Ordering {
    a.len().cmp(&b.len()).then_with(|| a.iter().rev().cmp(b.iter().rev()))
}

fn bits(x: &[u64]) -> u64 {
    x.last().map_or(0, |t| 64 * x.len() as u64 - t.leading_zeros() as u64)
}

/// Bits `shift .. shift + 62` of `x`.
fn window(x: &[u64], shift: u64) -> u64 {
    let (i, off) = ((shift / 64) as usize, shift % 64);
    let lo = x.get(i).copied().unwrap_or(0) >> off;
    let hi = if off == 0 { 0 } else { x.get(i + 1).copied().unwrap_or(0) << (64 - off) };
    (lo | hi) & ((1u64 << 62) - 1)
}

fn to_u128(x: &[u64]) -> u128 {
    x.iter().rev().fold(0u128, |acc, &l| (acc << 64) | l as u128)
}

fn from_u128(v: u128) -> Vec<u64> {
    let mut out = vec![v as u64, (v >> 64) as u64];
    trim(&mut out);
    out
}

/// A number from little-endian 64-bit limbs.
pub(super) fn to_big(x: &[u64]) -> BigUint {
    let mut d32 = Vec::with_capacity(2 * x.len());
    for &l in x {
        d32.push(l as u32);
        d32.push((l >> 32) as u32);
    }
    BigUint::new(d32)
}

/// The gcd of two numbers given as little-endian limbs.
pub fn gcd_limbs(mut u: Vec<u64>, mut v: Vec<u64>) -> Vec<u64> {
    loop {
        trim(&mut u);
        trim(&mut v);
        if cmp(&u, &v) == Ordering::Less {
            std::mem::swap(&mut u, &mut v);
        }
        if v.is_empty() {
            return u;
        }
        if u.len() <= 2 {
            let (mut a, mut b) = (to_u128(&u), to_u128(&v));
            while b != 0 {
                (a, b) = (b, a % b);
            }
            return from_u128(a);
        }
        match reduction_pass(&u, &v) {
            Some(m) => m.apply(&mut u, &mut v),
            None => {
                // No word step was certain (v much shorter than u): one full division.
                let r = to_big(&u) % to_big(&v);
                u = std::mem::replace(&mut v, r.to_u64_digits());
            }
        }
    }
}

/// Magnitudes of a valid reduction's matrix: the rows `(s0, t0)`, `(s1, t1)` of the last two
/// remainders, with signs `(+, -)`, `(-, +)` after an even number of steps and the opposite
/// after an odd number (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Reduction {
    s0: u64,
    t0: u64,
    s1: u64,
    t1: u64,
    even: bool,
}

/// Bits `shift .. shift + 63` of `x`.
fn window63(x: &[u64], shift: u64) -> u64 {
    let (i, off) = ((shift / 64) as usize, shift % 64);
    let lo = x.get(i).copied().unwrap_or(0) >> off;
    let hi = if off == 0 { 0 } else { x.get(i + 1).copied().unwrap_or(0) << (64 - off) };
    (lo | hi) & ((1u64 << 63) - 1)
}

/// The longest run of Euclid steps on the leading 63 bits of `u >= v` (`u` of at least 64
/// bits) whose rows stay at least their cofactor (`r_k >= |t_k|`), or `None` when not even
/// one step qualifies (`v` much shorter than `u`). Every quantity stays below `2^64`:
/// `t_(k+1) = t_(k-1) + q t_k <= r_(k-1) + r_(k-1) < 2^64`.
fn reduction_pass(u: &[u64], v: &[u64]) -> Option<Reduction> {
    let shift = bits(u) - 63;
    let (mut r0, mut r1) = (window63(u, shift), window63(v, shift));
    if r1 == 0 {
        return None;
    }
    // Row 0 is (1, 0) and row 1 is (0, 1): r0 >= 0 and r1 >= 1 qualify.
    let (mut s0, mut t0, mut s1, mut t1) = (1u64, 0u64, 0u64, 1u64);
    let mut even = true;
    loop {
        let q = r0 / r1;
        let r2 = r0 - q * r1;
        let t2 = t0 + q * t1;
        if r2 < t2 {
            break;
        }
        let s2 = s0 + q * s1;
        (r0, r1) = (r1, r2);
        (s0, t0, s1, t1) = (s1, t1, s2, t2);
        even = !even;
    }
    (t0 != 0).then_some(Reduction { s0, t0, s1, t1, even })
}

impl Reduction {
    /// `(u, v) <- rows (u, v)` in place: after an even number of steps
    /// `(s0 u - t0 v, t1 v - s1 u)`, after an odd number `(t0 v - s0 u, s1 u - t1 v)`; both
    /// nonnegative by the pass's test. Each product is below `2^127` (`s, t < 2^63`).
    fn apply(self, u: &mut [u64], v: &mut Vec<u64>) {
        v.resize(u.len(), 0);
        if self.even {
            self.rows::<true>(u, v)
        } else {
            self.rows::<false>(u, v)
        }
    }

    #[inline(always)]
    fn rows<const EVEN: bool>(self, u: &mut [u64], v: &mut [u64]) {
        let (mut cu, mut cv) = (0i128, 0i128);
        for (uk, vk) in u.iter_mut().zip(v.iter_mut()) {
            let (x, y) = (*uk as u128, *vk as u128);
            let (s0x, t0y) = ((self.s0 as u128 * x) as i128, (self.t0 as u128 * y) as i128);
            let (t1y, s1x) = ((self.t1 as u128 * y) as i128, (self.s1 as u128 * x) as i128);
            let (a, b) = if EVEN {
                (s0x - t0y + cu, t1y - s1x + cv)
            } else {
                (t0y - s0x + cu, s1x - t1y + cv)
            };
            *uk = a as u64;
            *vk = b as u64;
            cu = a >> 64;
            cv = b >> 64;
        }
        debug_assert!(cu == 0 && cv == 0, "a valid reduction's rows are nonnegative");
    }
}

/// One Lehmer pass on the leading 62 bits of `u >= v` (`shift = bits(u) - 62`): the
/// cofactors `(a, b, c, d)`, or `None` when no word step is certain.
fn lehmer_pass(u: &[u64], v: &[u64]) -> Option<(i64, i64, i64, i64)> {
    let shift = bits(u) - 62;
    let (mut uh, mut vh) = (window(u, shift) as i64, window(v, shift) as i64);
    let (mut a, mut b, mut c, mut d): (i64, i64, i64, i64) = (1, 0, 0, 1);
    loop {
        if vh + c == 0 || vh + d == 0 {
            break;
        }
        let q = (uh + a) / (vh + c);
        if q != (uh + b) / (vh + d) {
            break;
        }
        (a, c) = (c, a - q * c);
        (b, d) = (d, b - q * d);
        (uh, vh) = (vh, uh - q * vh);
    }
    (b != 0).then_some((a, b, c, d))
}

/// `(u, v) <- (a u + b v, c u + d v)` in place (both results nonnegative, `u >= v`).
fn combine(u: &mut [u64], v: &mut Vec<u64>, (a, b, c, d): (i64, i64, i64, i64)) {
    v.resize(u.len(), 0);
    let (a, b, c, d) = (a as i128, b as i128, c as i128, d as i128);
    let (mut cu, mut cv) = (0i128, 0i128);
    for (uk, vk) in u.iter_mut().zip(v.iter_mut()) {
        let (x, y) = (*uk as i128, *vk as i128);
        let s = a * x + b * y + cu;
        let t = c * x + d * y + cv;
        *uk = s as u64;
        *vk = t as u64;
        cu = s >> 64;
        cv = t >> 64;
    }
    debug_assert!(cu == 0 && cv == 0, "Lehmer's combinations are nonnegative remainders");
}

/// The denominator of Wang's rational reconstruction of `u mod m` (`0 <= u < m`) with both
/// bounds `sqrt(m / 2)`: the `|t|` of the first remainder `r = s m + t u <= sqrt(m / 2)` of
/// the extended Euclidean algorithm, if `|t| <= sqrt(m / 2)` and `gcd(r, t) = 1`.
pub fn wang_den(u: &BigUint, m: &BigUint) -> Option<BigUint> {
    use num_bigint::{BigInt, Sign};
    use num_integer::Integer;
    use num_traits::{One, Signed, Zero};
    let bound = (m >> 1u32).sqrt();
    let bb = bound.bits();
    let (mut r0, mut r1) = (m.to_u64_digits(), u.to_u64_digits());
    let (mut t0, mut t1) = (BigInt::zero(), BigInt::one());
    // Word passes while the remainders are far above the bound: a pass leaves the remainder
    // above about 2^(bits(r0) - 63), so it cannot step over the first one below the bound.
    while bits(&r1) > bb + 130 {
        let Some((a, b, c, d)) = lehmer_pass(&r0, &r1) else {
            let (q, r) = to_big(&r0).div_rem(&to_big(&r1));
            r0 = std::mem::replace(&mut r1, r.to_u64_digits());
            let nt = &t0 - BigInt::from_biguint(Sign::Plus, q) * &t1;
            t0 = std::mem::replace(&mut t1, nt);
            continue;
        };
        combine(&mut r0, &mut r1, (a, b, c, d));
        trim(&mut r0);
        trim(&mut r1);
        let nt0 = &t0 * a + &t1 * b;
        let nt1 = &t0 * c + &t1 * d;
        (t0, t1) = (nt0, nt1);
        if bits(&r1) <= bb {
            return None; // stepped over the bound (not expected): no candidate this time
        }
    }
    let (mut r0, mut r1) = (to_big(&r0), to_big(&r1));
    while r1 > bound {
        let (q, r) = r0.div_rem(&r1);
        r0 = std::mem::replace(&mut r1, r);
        let nt = &t0 - BigInt::from_biguint(Sign::Plus, q) * &t1;
        t0 = std::mem::replace(&mut t1, nt);
    }
    let t = t1.magnitude();
    if t.is_zero() || t > &bound || !gcd_biguint(&r1, t).is_one() {
        return None;
    }
    Some(t1.abs().magnitude().clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_integer::Integer;
    use proptest::prelude::*;

    fn big(limbs: &[u64]) -> BigUint {
        to_big(limbs)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// Agrees with num-bigint's gcd on random numbers with a random common factor, of
        /// very different lengths too.
        #[test]
        fn limb_gcd_agrees_with_bigint(
            a in prop::collection::vec(any::<u64>(), 0..40),
            b in prop::collection::vec(any::<u64>(), 0..40),
            g in prop::collection::vec(any::<u64>(), 0..12),
        ) {
            let g = big(&g) + 1u32;
            let (x, y) = (big(&a) * &g, big(&b) * &g);
            prop_assert_eq!(gcd_biguint(&x, &y), x.gcd(&y));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// A reduction pass applied to the full numbers gives exactly the rows its matrix
        /// stands for, both nonnegative and with a smaller sum, whatever the bits below the
        /// window are (all zeros, all ones or random): the pass's test holds in the worst case.
        #[test]
        fn reduction_rows_are_nonnegative_below_any_window(
            hu in (1u64 << 62)..u64::MAX, hv in 0u64..u64::MAX, low_limbs in 1usize..4,
            fill_u in 0u8..3, fill_v in 0u8..3, seed in any::<u64>(),
        ) {
            use num_bigint::BigInt;
            let hv = hv % hu + 1;
            let low = |fill: u8, k: u64| -> Vec<u64> {
                (0..low_limbs as u64)
                    .map(|i| match fill {
                        0 => 0,
                        1 => u64::MAX,
                        _ => (seed ^ k).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(i as u32 * 7 + 3),
                    })
                    .collect()
            };
            let mut u = low(fill_u, 1);
            u.push(hu);
            let mut v = low(fill_v, 2);
            v.push(hv);
            let (bu, bv) = (BigInt::from(big(&u)), BigInt::from(big(&v)));
            if let Some(m) = reduction_pass(&u, &v) {
                let sign = if m.even { 1 } else { -1 };
                let u2 = (&bu * m.s0 - &bv * m.t0) * sign;
                let v2 = (&bv * m.t1 - &bu * m.s1) * sign;
                prop_assert!(u2 >= BigInt::from(0) && v2 >= BigInt::from(0));
                prop_assert!(&u2 + &v2 < &bu + &bv);
                let (mut uu, mut vv) = (u.clone(), v.clone());
                m.apply(&mut uu, &mut vv);
                prop_assert_eq!(BigInt::from(big(&uu)), u2);
                prop_assert_eq!(BigInt::from(big(&vv)), v2);
            }
        }
    }

    /// Consecutive Fibonacci numbers (all quotients 1: the most word steps per pass), a
    /// power of two against an odd number, zeros, and equal numbers.
    #[test]
    fn edge_cases() {
        let (mut f0, mut f1) = (BigUint::from(1u32), BigUint::from(1u32));
        for _ in 0..3000 {
            let f2 = &f0 + &f1;
            f0 = std::mem::replace(&mut f1, f2);
        }
        assert_eq!(gcd_biguint(&f1, &f0), BigUint::from(1u32));
        let p2 = BigUint::from(1u32) << 5000u32;
        let odd = (BigUint::from(3u32) << 4000u32) + 1u32;
        assert_eq!(gcd_biguint(&p2, &odd), BigUint::from(1u32));
        assert_eq!(gcd_biguint(&p2, &(&p2 >> 7u32)), &p2 >> 7u32);
        let z = BigUint::from(0u32);
        assert_eq!(gcd_biguint(&z, &z), z);
        assert_eq!(gcd_biguint(&odd, &z), odd);
        assert_eq!(gcd_biguint(&odd, &odd), odd);
    }

    /// The plain half extended Euclid (the reference for [`wang_den`]).
    fn wang_plain(u: &BigUint, m: &BigUint) -> Option<BigUint> {
        use num_bigint::BigInt;
        use num_traits::{One, Signed, Zero};
        let bound = BigInt::from((m >> 1u32).sqrt());
        let (mut r0, mut r1) = (BigInt::from(m.clone()), BigInt::from(u.clone()));
        let (mut t0, mut t1) = (BigInt::zero(), BigInt::one());
        while r1 > bound {
            let (q, r) = r0.div_rem(&r1);
            r0 = std::mem::replace(&mut r1, r);
            let nt = &t0 - &q * &t1;
            t0 = std::mem::replace(&mut t1, nt);
        }
        if t1.is_zero() || t1.abs() > bound || !r1.gcd(&t1).is_one() {
            return None;
        }
        Some(t1.abs().magnitude().clone())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(100))]

        /// Equal to the plain reconstruction on residues of true fractions (found) and on
        /// random residues (found or not), for moduli from one to thousands of bits.
        #[test]
        fn wang_den_agrees_with_the_plain_algorithm(
            num in prop::collection::vec(any::<u64>(), 1..20),
            den in prop::collection::vec(any::<u64>(), 1..20),
            noise in prop::collection::vec(any::<u64>(), 1..50),
            k in 1u32..3000,
        ) {
            let m = BigUint::from(1_000_000_007u64).pow(k / 8 + 1) * BigUint::from(3u32).pow(k % 8);
            let (n, d) = (big(&num) % &m, big(&den) % &m + 1u32);
            if let Some(di) = d.modinv(&m) {
                let u = (&n * di) % &m;
                prop_assert_eq!(wang_den(&u, &m), wang_plain(&u, &m));
            }
            let u = big(&noise) % &m;
            prop_assert_eq!(wang_den(&u, &m), wang_plain(&u, &m));
        }
    }
}
