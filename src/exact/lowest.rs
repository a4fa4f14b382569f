//! Lowest terms of many fractions over one denominator, with few gcds.
//!
//! An exact solve gives its values as integer numerators over one common denominator,
//! `x_i = N_i / D` ([`super::ScaledVec`]). Printing them in lowest terms needs
//! `g_i = gcd(N_i, D)` for every entry; at thousands of bits one gcd costs some 15 us, and
//! `trimorph solve`'s 400 x 800 benchmark has 1,598 of them (issue 24). Yet such solutions
//! have very few distinct `g_i` (seven on that benchmark: 30 for most entries, a few huge
//! ones for values with small denominators). This module finds them with a handful of gcds
//! and proves the rest with products.
//!
//! **The identities.** For integers `a, b, m`:
//! 1. `gcd(a b, m) = 1` exactly when `gcd(a, m) = 1` and `gcd(b, m) = 1`; and
//!    `gcd(a b mod m, m) = gcd(a b, m)`.
//! 2. If `g | N` and `g | D`, then `gcd(N, D) = g gcd(N / g, D / g)`.
//! 3. If `h = gcd(prod_j x_j, m)`, then `gcd(x_i, m) = gcd(x_i, h)` for every `i`: the left
//!    side divides `x_i`, hence the product, and `m`, hence `h`; and `h | m`.
//!
//! **The method.**
//! 1. *Candidates.* `gcd(N_i, D)` exactly for up to [`SEEDS`] entries spread over the vector
//!    (Lehmer's gcd, [`super::gcd`]); their distinct values, largest first, and 1. If the
//!    seeds show more than half as many distinct values as there are seeds, the common
//!    factors are diverse (the select-all edit
//!    of a 102-triangle spline: a different ~970-bit factor for each seed), classes would not
//!    prove themselves, and every entry gets its own gcd instead.
//! 2. *Classes.* Each entry goes to the largest candidate `g` that divides `N_i` (one
//!    division), keeping `x_i = N_i / g`.
//! 3. *Proof per class.* With `d = D / g = 2^k d'` (`d'` odd): `h = gcd(P, d')`, times `2^k`
//!    if some `x_i` of the class is even, where `P = prod x_i R^-(n) mod d'` is a Montgomery
//!    product (`R = 2^(64 l)` for `d'` of `l` limbs; `R` is a unit modulo `d'`, so
//!    `gcd(P, d') = gcd(prod x_i, d')`). That is one Montgomery multiplication per entry,
//!    `2 l^2` word products, and one gcd per class. `h` is a multiple of
//!    `gcd(prod x_i, d)` and divides `d`, which is all identity 3 needs. If `h = 1`, every
//!    `x_i / d` of the class is in lowest terms (identities 1 and 2).
//! 4. *Otherwise* some entries share more with `d`, and `gcd(x_i, d) = gcd(x_i, h)`
//!    (identity 3). A short `h` gets `e_i = gcd(x_i mod h, h)` per entry (cheap). A wide
//!    one (a large factor that no seed revealed, shared by a few entries, such as one
//!    coordinate's values with small denominators) is split: the entries divisible by `h`
//!    have `e_i = h`, and the others are proved again modulo `h` (steps 3 and 4 with `h` for
//!    `d`), a few levels deep before falling back to a gcd per entry. Each `x_i / d` becomes
//!    `(x_i / e_i) / (d / e_i)`.
//! 5. *A sample first.* A large class is first tried on a sample of [`SAMPLE`] entries. If
//!    they already share a wide factor with `d`, the sample's own gcds say which case it
//!    is. Many distinct wide gcds (diverse factors) give every entry its own gcd at once,
//!    with no product that could not prove anything. A few recurring ones (a wide factor
//!    that no seed revealed, shared by a minority of the class: the criterion 400 x 800
//!    instance's second coordinate, where 91 of 772 values have small denominators) split
//!    the class: an entry divisible by such an `f` has `gcd(x_i, d) = f gcd(x_i / f, d / f)`
//!    (identity 2), and each part goes through steps 3 and 4 on its own.
//!
//! Every answer is exact whatever the candidates are: they only decide how much work
//! step 4 has left. The result equals `Ratio::new` entry by entry (tested).

use super::{Int, IntView, Rat};
use num_bigint::{BigInt, BigUint, Sign};
use num_integer::Integer;
use num_traits::{One, Zero};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};

/// How many entries get an exact gcd to seed the candidate divisors.
pub const SEEDS: usize = 8;

/// Entries per product chunk (the products of a class run in parallel chunks).
const CHUNK: usize = 64;

/// Below this many entries, or for a word-size denominator, every entry is reduced on its
/// own (`Ratio::new`).
const BATCH_MIN: usize = 32;

/// `num[i] / den` in lowest terms for every `i` (denominators positive).
///
/// # Panics
/// Panics when `den` is zero.
///
/// ```
/// use trimorph::exact::{lowest::lowest_terms, Int, Rat};
/// let den: Int = "600000000000000000000000000000".parse().unwrap();
/// let num: Vec<Int> = [-300000000000000000000000000000i128, 7, 0, 1200000000000000000000000000000]
///     .iter().map(|&v| Int::from_i128(v)).collect();
/// let r = lowest_terms(&num, &den);
/// assert_eq!(r[0], Rat::new(Int::from(-1), Int::from(2)));
/// assert_eq!(r[1], Rat::new(Int::from(7), den.clone()));
/// assert_eq!(r[2], Rat::new(Int::from(0), Int::from(1)));
/// assert_eq!(r[3], Rat::new(Int::from(2), Int::from(1)));
/// ```
pub fn lowest_terms(num: &[Int], den: &Int) -> Vec<Rat> {
    reduce(num, den, &AtomicUsize::new(0))
}

/// [`lowest_terms`], counting in `gcds` the gcds taken modulo more than [`REFINE_WIDE`]
/// bits (the costly ones the classes exist to avoid; the tests check that they are few).
fn reduce(num: &[Int], den: &Int, gcds: &AtomicUsize) -> Vec<Rat> {
    assert!(!den.is_zero(), "zero denominator");
    let big_den = match den.view() {
        IntView::Big(b) if num.len() >= BATCH_MIN => b,
        _ => return num.par_iter().map(|n| Rat::new(n.clone(), den.clone())).collect(),
    };
    let sign = big_den.sign();
    let d = big_den.magnitude();
    let mags: Vec<BigUint> = num.par_iter().map(magnitude).collect();
    let (candidates, uniform) = candidates(&mags, d);
    if !uniform {
        // Diverse common factors (a select-all edit's values): one gcd per entry.
        gcds.fetch_add(num.len(), Ordering::Relaxed);
        return num.par_iter().map(|n| Rat::new(n.clone(), den.clone())).collect();
    }
    // Step 2: each entry's class (largest candidate dividing it) and quotient.
    let classed: Vec<(usize, BigUint)> =
        mags.into_par_iter().map(|n| classify(n, &candidates)).collect();
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); candidates.len()];
    for (i, (c, x)) in classed.iter().enumerate() {
        if !x.is_zero() {
            members[*c].push(i);
        }
    }
    let mut out: Vec<Option<Rat>> = vec![None; num.len()];
    for (c, idx) in members.iter().enumerate() {
        if idx.is_empty() {
            continue;
        }
        let dc = d / &candidates[c];
        let xs: Vec<(usize, &BigUint)> = idx.iter().map(|&i| (i, &classed[i].1)).collect();
        let mut extra: Vec<Option<BigUint>> = vec![None; num.len()];
        for (i, e) in shared_factors(&xs, &dc, REFINE_DEPTH, gcds) {
            extra[i] = Some(e);
        }
        let reduced: Vec<(usize, Rat)> = idx
            .par_iter()
            .map(|&i| {
                let x = &classed[i].1;
                let e = extra[i].clone().unwrap_or_else(BigUint::one);
                let (n, dd) = if e.is_one() { (x.clone(), dc.clone()) } else { (x / &e, &dc / &e) };
                let neg = (num[i].signum_i32() < 0) != (sign == Sign::Minus);
                let n = BigInt::from_biguint(if neg { Sign::Minus } else { Sign::Plus }, n);
                (i, Rat::new_raw(Int::from_big(n), Int::from_big(BigInt::from(dd))))
            })
            .collect();
        for (i, r) in reduced {
            out[i] = Some(r);
        }
    }
    out.into_iter().map(|r| r.unwrap_or_else(Rat::zero)).collect()
}

/// Entries of a class whose product is tried first ([`shared_factors`]).
const SAMPLE: usize = 16;

/// Levels of step 4's refinement before it takes a gcd per entry.
const REFINE_DEPTH: usize = 3;

/// `h` wider than this (bits) is refined by another product rather than a gcd per entry.
const REFINE_WIDE: u64 = 128;

/// Steps 3 and 4: `gcd(x_i, m)` for each `(i, x_i)` of `xs`, listed only where it is not 1.
///
/// `h` = [`shared_part`]: if it is 1, every `x_i` is coprime to `m`. Otherwise
/// `gcd(x_i, m) = gcd(x_i, h)` (identity 3). A short `h` gets a gcd per entry (cheap). A
/// wide one (a large factor shared by a few entries that no seed revealed, such as the
/// values with small denominators of one coordinate) is split: entries divisible by `h` have
/// `gcd = h`, and the rest are refined the same way modulo `h`, down to `depth` levels.
fn shared_factors(
    xs: &[(usize, &BigUint)],
    m: &BigUint,
    depth: usize,
    gcds: &AtomicUsize,
) -> Vec<(usize, BigUint)> {
    if xs.is_empty() {
        return Vec::new();
    }
    let per_entry = |xs: &[(usize, &BigUint)], h: &BigUint| -> Vec<(usize, BigUint)> {
        if h.bits() > REFINE_WIDE {
            gcds.fetch_add(xs.len(), Ordering::Relaxed);
        }
        xs.par_iter()
            .map(|&(i, x)| (i, super::gcd::gcd_biguint(&(x % h), h)))
            .filter(|(_, e)| !e.is_one())
            .collect()
    };
    // A sample first. If a few entries already share a wide factor with `m`, either the
    // factors are diverse (a select-all edit's values: a gcd per entry is cheaper than
    // products that would not prove anything), or one wide factor that no seed revealed
    // recurs (the values with small denominators of one coordinate): the sample's own gcds
    // name it, and the class splits by it.
    if depth == REFINE_DEPTH && xs.len() > 4 * SAMPLE {
        let step = xs.len() / SAMPLE;
        let sample: Vec<&BigUint> = xs.iter().step_by(step).map(|e| e.1).collect();
        if shared_part(sample.clone(), m).bits() > REFINE_WIDE {
            gcds.fetch_add(sample.len(), Ordering::Relaxed);
            let mut wide: Vec<BigUint> = sample
                .par_iter()
                .map(|x| super::gcd::gcd_biguint(&(*x % m), m))
                .filter(|g| g.bits() > REFINE_WIDE)
                .collect();
            let hits = wide.len();
            wide.sort_unstable_by(|a, b| b.cmp(a));
            wide.dedup();
            if 2 * wide.len() > hits.max(2) || hits > SAMPLE / 2 {
                return per_entry(xs, m);
            }
            return split_by(xs, m, &wide, depth - 1, gcds);
        }
    }
    let h = shared_part(xs.iter().map(|e| e.1).collect(), m);
    if h.is_one() {
        return Vec::new();
    }
    if depth == 0 || h.bits() <= REFINE_WIDE {
        return per_entry(xs, &h);
    }
    let divisible: Vec<bool> = xs.par_iter().map(|&(_, x)| (x % &h).is_zero()).collect();
    let (zero, rest): (Vec<_>, Vec<_>) =
        xs.iter().zip(&divisible).partition(|&(_, &is_zero)| is_zero);
    if zero.is_empty() && &h == m {
        return per_entry(xs, &h); // no progress to make by splitting
    }
    let rest: Vec<(usize, &BigUint)> = rest.into_iter().map(|(&e, _)| e).collect();
    let mut out: Vec<(usize, BigUint)> = zero.into_iter().map(|(e, _)| (e.0, h.clone())).collect();
    out.extend(shared_factors(&rest, &h, depth - 1, gcds));
    out
}

/// [`shared_factors`] for a class split by divisors `fs` of `m` (largest first): an entry
/// divisible by `f` (the first such) has `gcd(x, m) = f gcd(x / f, m / f)` (identity 2),
/// found for the whole sub-class at once; entries divisible by none are refined modulo `m`.
fn split_by(
    xs: &[(usize, &BigUint)],
    m: &BigUint,
    fs: &[BigUint],
    depth: usize,
    gcds: &AtomicUsize,
) -> Vec<(usize, BigUint)> {
    let which: Vec<Option<(usize, BigUint)>> = xs
        .par_iter()
        .map(|&(_, x)| {
            fs.iter().enumerate().find_map(|(k, f)| {
                let (q, r) = x.div_rem(f);
                r.is_zero().then_some((k, q))
            })
        })
        .collect();
    let mut out = Vec::new();
    for (k, f) in fs.iter().enumerate() {
        let quotients: Vec<(usize, BigUint)> = xs
            .iter()
            .zip(&which)
            .filter_map(|(&(i, _), w)| w.as_ref().filter(|w| w.0 == k).map(|w| (i, w.1.clone())))
            .collect();
        if quotients.is_empty() {
            continue;
        }
        let mf = m / f;
        let refs: Vec<(usize, &BigUint)> = quotients.iter().map(|(i, q)| (*i, q)).collect();
        let mut sub: HashMap<usize, BigUint> =
            shared_factors(&refs, &mf, depth, gcds).into_iter().collect();
        out.extend(
            refs.iter().map(|&(i, _)| (i, sub.remove(&i).map_or_else(|| f.clone(), |g| g * f))),
        );
    }
    let rest: Vec<(usize, &BigUint)> =
        xs.iter().zip(&which).filter(|(_, w)| w.is_none()).map(|(&e, _)| e).collect();
    out.extend(shared_factors(&rest, m, depth, gcds));
    out
}

/// Step 3: a divisor `h` of `d` that every `gcd(x_i, d)` divides; 1 exactly when every
/// `x_i` is coprime to `d` (see the module docs).
fn shared_part(xs: Vec<&BigUint>, d: &BigUint) -> BigUint {
    let k = d.trailing_zeros().unwrap_or(0);
    let odd = d >> k;
    let two =
        if k > 0 && xs.iter().any(|x| !x.bit(0)) { BigUint::one() << k } else { BigUint::one() };
    if odd.is_one() {
        return two;
    }
    let mont = Montgomery::new(&odd);
    let prod = xs
        .par_chunks(CHUNK)
        .map(|ch| {
            let mut acc = mont.one();
            let mut t = vec![0u64; mont.m.len() + 1];
            for x in ch {
                if x.bits() > 64 * mont.m.len() as u64 {
                    mont.mul(&mut acc, &(*x % &odd).to_u64_digits(), &mut t);
                } else {
                    mont.mul(&mut acc, &x.to_u64_digits(), &mut t);
                }
            }
            acc
        })
        .reduce(
            || mont.one(),
            |mut a, b| {
                let mut t = vec![0u64; mont.m.len() + 1];
                mont.mul(&mut a, &b, &mut t);
                a
            },
        );
    two * super::gcd::gcd_biguint(&limbs_to_big(&prod), &odd)
}

use super::gcd::to_big as limbs_to_big;

/// Montgomery multiplication modulo an odd `m` of `l` limbs, `R = 2^(64 l)` (Koc, Acar and
/// Kaliski, "Analyzing and comparing Montgomery multiplication algorithms", 1996: CIOS).
struct Montgomery {
    /// The modulus, `l` little-endian limbs (top limb nonzero).
    m: Vec<u64>,
    /// `-m^-1 mod 2^64`.
    minv: u64,
}

impl Montgomery {
    fn new(m: &BigUint) -> Montgomery {
        let m = m.to_u64_digits();
        debug_assert!(m[0] & 1 == 1);
        // Newton's iteration doubles the correct low bits of m^-1 each round (5 -> 320).
        let mut inv = m[0];
        for _ in 0..6 {
            inv = inv.wrapping_mul(2u64.wrapping_sub(m[0].wrapping_mul(inv)));
        }
        Montgomery { m, minv: inv.wrapping_neg() }
    }

    /// The residue 1 (any unit would do: the products only feed a gcd with `m`).
    fn one(&self) -> Vec<u64> {
        let mut one = vec![0u64; self.m.len()];
        one[0] = 1;
        one
    }

    /// `a <- a b R^-1 mod m` for `a < m` and `b < R` (at most `l` limbs), without
    /// allocating (`t` has `l + 1` limbs). After `i` rounds `t = (a b_(<i) + Q m) / 2^(64 i)`
    /// with `Q < 2^(64 i)`, so `t < 2 m` throughout and its top limb is 0 or 1.
    fn mul(&self, a: &mut [u64], b: &[u64], t: &mut [u64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("bmi2") {
            // SAFETY: the CPU supports BMI2 (detected just above).
            return unsafe { self.mul_bmi2(a, b, t) };
        }
        self.mul_any(a, b, t)
    }

    /// [`Montgomery::mul`] compiled with BMI2 (`mulx`: a product that leaves the carry flag
    /// alone, so the two carry chains interleave better); the same integer operations.
    ///
    /// # Safety
    ///
    /// The CPU supports BMI2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "bmi2")]
    unsafe fn mul_bmi2(&self, a: &mut [u64], b: &[u64], t: &mut [u64]) {
        self.mul_any(a, b, t)
    }

    #[inline(always)]
    fn mul_any(&self, a: &mut [u64], b: &[u64], t: &mut [u64]) {
        let (m, l) = (&self.m[..], self.m.len());
        let (a, t) = (&mut a[..l], &mut t[..l + 1]);
        t.fill(0);
        for i in 0..l {
            let bi = b.get(i).copied().unwrap_or(0) as u128;
            // t <- (t + a bi + q m) / 2^64 with q chosen so the low word vanishes; the two
            // carry chains run side by side (FIOS).
            let s = t[0] as u128 + a[0] as u128 * bi;
            let q = (s as u64).wrapping_mul(self.minv) as u128;
            let (mut c1, mut c2) = (s >> 64, (s as u64 as u128 + q * m[0] as u128) >> 64);
            for j in 1..l {
                let s = t[j] as u128 + a[j] as u128 * bi + c1;
                c1 = s >> 64;
                let r = s as u64 as u128 + q * m[j] as u128 + c2;
                c2 = r >> 64;
                t[j - 1] = r as u64;
            }
            let s = t[l] as u128 + c1 + c2;
            t[l - 1] = s as u64;
            t[l] = (s >> 64) as u64;
        }
        // t[0..=l] < 2 m: subtract m once if needed.
        let ge = t[l] != 0 || t[..l].iter().rev().cmp(m.iter().rev()) != std::cmp::Ordering::Less;
        if ge {
            let mut borrow = 0u64;
            for j in 0..l {
                let (d1, b1) = t[j].overflowing_sub(m[j]);
                let (d2, b2) = d1.overflowing_sub(borrow);
                a[j] = d2;
                borrow = (b1 | b2) as u64;
            }
        } else {
            a.copy_from_slice(&t[..l]);
        }
    }
}

fn magnitude(n: &Int) -> BigUint {
    match n.view() {
        IntView::Small(v) => BigUint::from(v.unsigned_abs()),
        IntView::Big(b) => b.magnitude().clone(),
    }
}

/// Step 1: the distinct `gcd(N_i, D)` of up to [`SEEDS`] nonzero entries spread over the
/// vector, largest first, then 1 (always last, so every entry has a class).
/// Also returns whether the seeds show few distinct gcds (at most half as many values as
/// seeds, 1 included): if not, the entries' common factors are too diverse for classes to
/// pay off.
fn candidates(mags: &[BigUint], d: &BigUint) -> (Vec<BigUint>, bool) {
    let nonzero: Vec<usize> = (0..mags.len()).filter(|&i| !mags[i].is_zero()).collect();
    let step = nonzero.len().div_ceil(SEEDS).max(1);
    let mut c: Vec<BigUint> =
        nonzero.par_iter().step_by(step).map(|&i| super::gcd::gcd_biguint(&mags[i], d)).collect();
    let seeds = c.len();
    c.sort_unstable_by(|a, b| b.cmp(a));
    c.dedup();
    let few = 2 * c.len() <= seeds.max(2);
    c.retain(|g| !g.is_one());
    c.push(BigUint::one());
    (c, few)
}

/// Step 2: the first (largest) candidate dividing `n`, and `n` divided by it. Zero goes to
/// the last class with quotient zero (and is skipped by the caller).
fn classify(n: BigUint, candidates: &[BigUint]) -> (usize, BigUint) {
    let last = candidates.len() - 1;
    if n.is_zero() {
        return (last, n);
    }
    for (c, g) in candidates[..last].iter().enumerate() {
        if g.bits() > n.bits() {
            continue;
        }
        let (q, r) = n.div_rem(g);
        if r.is_zero() {
            return (c, q);
        }
    }
    (last, n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn int(b: BigInt) -> Int {
        Int::from_big(b)
    }

    /// Each entry equals `Ratio::new` (one gcd per entry), and is in lowest terms with a
    /// positive denominator.
    fn check(num: &[Int], den: &Int) {
        let fast = lowest_terms(num, den);
        assert_eq!(fast.len(), num.len());
        for (i, (f, n)) in fast.iter().zip(num).enumerate() {
            let slow = Rat::new(n.clone(), den.clone());
            assert_eq!(f, &slow, "entry {i}");
            assert_eq!(f.numer(), slow.numer(), "entry {i}: numerator");
            assert_eq!(f.denom(), slow.denom(), "entry {i}: denominator");
            assert!(f.denom().signum_i32() > 0);
        }
    }

    /// A denominator of a few thousand bits made of small and large factors.
    fn big_den(seed: u64) -> BigInt {
        let mut d = BigInt::from(2 * 3 * 5 * 59);
        let mut x = BigInt::from(seed | 1);
        for k in 0..40u64 {
            x = (&x * BigInt::from(6364136223846793005u64)
                + BigInt::from(1442695040888963407u64 + k))
                % (BigInt::one() << 80u32);
            d *= &x + 1;
        }
        d
    }

    /// The benchmark's shape: most values share one small factor with the denominator, a
    /// few have small denominators (huge shared factors), some share other small factors
    /// not among the seeds, some are zero or negative; and a negative denominator.
    #[test]
    fn mixed_classes_equal_per_entry_reduction() {
        for seed in [1u64, 7, 99] {
            let d = big_den(seed);
            let mut num = Vec::new();
            for i in 0..300u64 {
                let k = BigInt::from(i * 7919 + seed) * BigInt::from(1_000_003u64).pow(20);
                let n = match i % 10 {
                    0 => (&d / 30) * BigInt::from(i as i64 - 150), // small denominators
                    1 => k * 6,
                    2 => k * 1770 * -1,
                    3 => BigInt::zero(),
                    4 => k * 59 * 59,
                    _ => k * 30 + 30,
                };
                num.push(int(n));
            }
            check(&num, &int(d.clone()));
            check(&num, &int(-d));
        }
    }

    /// Shared factors that no seed revealed and that are large: the classes' proofs fail and
    /// step 4 takes over (wide `h`).
    #[test]
    fn large_unseen_factors_are_found_by_the_refinement() {
        let d = big_den(3);
        let f1 = BigInt::from(1u64 << 61) * 3 + 1; // a wide factor...
        let d = &d * &f1;
        let num: Vec<Int> = (0..200u64)
            .map(|i| {
                let base = BigInt::from(i + 2).pow(30);
                int(if i % 37 == 5 { base * &f1 } else { base * 30 + 1 })
            })
            .collect();
        check(&num, &int(d));
    }

    /// Values with small denominators (numerators that are multiples of nearly all of `D`)
    /// that no seed picked: their class's shared part is as wide as `d`, and the split by
    /// divisibility proves the rest with one more product (the 400 x 800 benchmark's second
    /// coordinate).
    #[test]
    fn wide_unseen_shared_parts_are_split_by_divisibility() {
        let d = big_den(11) * BigInt::from(7u64).pow(60);
        let n = 240usize;
        let step = n.div_ceil(SEEDS);
        let num: Vec<Int> = (0..n)
            .map(|i| {
                let k = BigInt::from(i as i64 * 31 + 5);
                int(if i % step == 3 { (&d / 30) * k } else { k.pow(40) * 30 + 30 })
            })
            .collect();
        check(&num, &int(d));
    }

    /// Values with small denominators that no seed picked but that the class's sample hits
    /// (the 400 x 800 benchmark's criterion instance): the sample's gcds name the wide
    /// factor and the class splits by it, instead of a gcd per entry modulo the whole
    /// denominator. `D = 30 7^300 11^300 13^300`; every value shares exactly 30 with it
    /// except four, which share `30 11^300 13^300`.
    #[test]
    fn a_wide_factor_in_the_sample_splits_the_class() {
        let p = |b: u64| BigInt::from(b).pow(300);
        let d = BigInt::from(30) * p(7) * p(11) * p(13);
        let n = 288usize;
        assert_eq!(n.div_ceil(SEEDS), 36, "seeds at multiples of 36");
        let wide = |i: usize| i % 72 == 18; // 18, 90, 162, 234
        let num: Vec<Int> = (0..n)
            .map(|i| {
                let k = BigInt::from(i as i64 + 2);
                let unit = k.pow(20) * 7 * 11 * 13 + 1; // coprime to 7, 11 and 13
                int(if wide(i) { unit * 30 * p(11) * p(13) } else { unit * 30 })
            })
            .collect();
        let gcds = AtomicUsize::new(0);
        let fast = reduce(&num, &int(d.clone()), &gcds);
        for (i, (f, v)) in fast.iter().zip(&num).enumerate() {
            let slow = Rat::new(v.clone(), int(d.clone()));
            assert_eq!((f.numer(), f.denom()), (slow.numer(), slow.denom()), "entry {i}");
            let expect = if wide(i) { p(7) } else { &d / 30 };
            assert_eq!(f.denom(), &int(expect), "entry {i}");
        }
        let taken = gcds.load(Ordering::Relaxed);
        assert!(taken <= SAMPLE + 1, "{taken} wide gcds for {n} entries");
        check(&num, &int(-d));
    }

    #[test]
    fn integers_and_word_denominators() {
        let d = big_den(5);
        let num: Vec<Int> = (0..100i64).map(|i| int(&d * BigInt::from(i - 50))).collect();
        check(&num, &int(d));
        let num: Vec<Int> = (0..100i64).map(|i| Int::from(i * 3 - 77)).collect();
        check(&num, &Int::from(-12));
        check(&[], &Int::from(5));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// `mul` equals `a b R^-1 mod m` computed with big integers, for odd moduli of 1 to
        /// 12 limbs, including `b` above `m`.
        #[test]
        fn montgomery_product_equals_the_definition(
            m in prop::collection::vec(any::<u64>(), 1..12),
            a in prop::collection::vec(any::<u64>(), 1..12),
            b in prop::collection::vec(any::<u64>(), 1..12),
        ) {
            let mut m = m;
            m[0] |= 1;
            let l = m.len();
            if m[l - 1] == 0 { m[l - 1] = 1; }
            let mb = limbs_to_big(&m);
            let mont = Montgomery::new(&mb);
            let av = limbs_to_big(&a) % &mb;
            let bv = limbs_to_big(&b[..b.len().min(l)]);
            let mut acc = av.to_u64_digits();
            acc.resize(l, 0);
            let mut t = vec![0u64; l + 1];
            mont.mul(&mut acc, &bv.to_u64_digits(), &mut t);
            let r = BigUint::one() << (64 * l);
            let rinv = BigInt::from(r).modinv(&BigInt::from(mb.clone())).unwrap();
            let want = (BigInt::from(av * bv) * rinv).mod_floor(&BigInt::from(mb.clone()));
            prop_assert_eq!(BigInt::from(limbs_to_big(&acc)), want);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(40))]

        /// Random numerators built from a random pool of factors of a random denominator.
        #[test]
        fn random_vectors_equal_per_entry_reduction(
            den_limbs in prop::collection::vec(any::<u64>(), 2..20),
            pool in prop::collection::vec(1u64..1_000_000, 1..6),
            picks in prop::collection::vec((0usize..6, any::<u64>(), any::<bool>()), 32..120),
        ) {
            let mut d = BigInt::from_biguint(Sign::Plus, BigUint::new(
                den_limbs.iter().flat_map(|&l| [l as u32, (l >> 32) as u32]).collect(),
            )) + 1;
            for &p in &pool {
                d *= p;
            }
            let num: Vec<Int> = picks
                .iter()
                .map(|&(k, r, neg)| {
                    let f = pool.get(k).copied().unwrap_or(1);
                    let n = BigInt::from(r) * f * if neg { -1 } else { 1 };
                    int(n)
                })
                .collect();
            check(&num, &int(d));
        }
    }
}
