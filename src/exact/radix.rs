//! Decimal text of big integers, faster than `num-bigint`'s `Display`.
//!
//! An exact solve writes thousands of integers of thousands of bits (`trimorph solve`'s
//! 400 x 800 benchmark: 1,598 numerators of about 1,000 digits; issue 24), and their decimal
//! text was a fifth of the whole process.
//!
//! **Method.** The number, as 64-bit limbs `x`, is divided in place by `D = 10^19` (the
//! largest power of ten below `2^64`) from the top limb down; each division of a two-limb
//! `(r, x_i)` with `r < D` by `D` uses Moller and Granlund's reciprocal ("Improved division
//! by invariant integers", IEEE Trans. Computers 60(2), 2011, Algorithm 4): with
//! `v = floor((2^128 - 1) / D) - 2^64` (`D` is normalized: `2^63 <= D < 2^64`),
//! `<q1, q0> = v r + <r, x_i>`, `q = q1 + 1`, `rem = x_i - q D mod 2^64`, then at most two
//! corrections. Two multiplications and no hardware division per limb.
//!
//! Each sweep divides by `D` four times, each division trailing the one before by one limb:
//! `x = D Q1 + r1`, `Q1 = D Q2 + r2`, `Q2 = D Q3 + r3`, `Q3 = D Q4 + r4`, so
//! `x = D^4 Q4 + D^3 r4 + D^2 r3 + D r2 + r1`. The four remainder chains are independent,
//! so the processor overlaps their latencies (two chains: 4.3 us for a 3,300-bit number;
//! four: 3.65 us). Splitting wide numbers by a power of ten first (one `num-bigint`
//! division, then two halves) gained nothing below 5,000 bits and was not kept. The base-`D` digits,
//! most significant first, each padded to 19 decimal digits but the first, are the text.

use num_bigint::BigUint;

/// `10^19`, the largest power of ten below `2^64`.
const D: u64 = 10_000_000_000_000_000_000;

/// Moller-Granlund reciprocal of `D`: `floor((2^128 - 1) / D) - 2^64`.
const V: u64 = ((u128::MAX / D as u128) - (1u128 << 64)) as u64;

/// `(<u1, u0> / D, <u1, u0> mod D)` for `u1 < D`.
#[inline(always)]
fn div_d(u1: u64, u0: u64) -> (u64, u64) {
    let qq = (V as u128 * u1 as u128).wrapping_add(((u1 as u128) << 64) | u0 as u128);
    let mut q = ((qq >> 64) as u64).wrapping_add(1);
    let mut r = u0.wrapping_sub(q.wrapping_mul(D));
    // Taken about half the time: a mask, not a branch.
    let mask = ((r > qq as u64) as u64).wrapping_neg();
    q = q.wrapping_add(mask);
    r = r.wrapping_add(mask & D);
    if r >= D {
        q += 1;
        r -= D;
    }
    (q, r)
}

/// Appends the decimal digits of the little-endian limbs `x` (consumed) to `out`.
fn push_limbs(mut x: Vec<u64>, out: &mut Vec<u8>) {
    while x.last() == Some(&0) {
        x.pop();
    }
    // Base-D digits, least significant first.
    let mut digits: Vec<u64> = Vec::with_capacity(x.len() * 64 / 63 + 2);
    while x.len() > 2 {
        let (mut r1, mut r2, mut r3, mut r4) = (0u64, 0u64, 0u64, 0u64);
        for limb in x.iter_mut().rev() {
            let (q1, s1) = div_d(r1, *limb);
            let (q2, s2) = div_d(r2, q1);
            let (q3, s3) = div_d(r3, q2);
            let (q4, s4) = div_d(r4, q3);
            (r1, r2, r3, r4) = (s1, s2, s3, s4);
            *limb = q4;
        }
        digits.extend_from_slice(&[r1, r2, r3, r4]);
        while x.last() == Some(&0) {
            x.pop();
        }
    }
    let mut top = x.iter().rev().fold(0u128, |acc, &l| (acc << 64) | l as u128);
    while top >= D as u128 {
        digits.push((top % D as u128) as u64);
        top /= D as u128;
    }
    digits.push(top as u64);
    while digits.len() > 1 && digits.last() == Some(&0) {
        digits.pop();
    }
    let mut buf = itoa_buf();
    let mut it = digits.iter().rev();
    if let Some(&first) = it.next() {
        out.extend_from_slice(fmt_u64(first, &mut buf, false));
    }
    for &d in it {
        out.extend_from_slice(fmt_u64(d, &mut buf, true));
    }
}

fn itoa_buf() -> [u8; 20] {
    [b'0'; 20]
}

/// "00" .. "99".
const PAIRS: [u8; 200] = {
    let mut t = [0u8; 200];
    let mut i = 0;
    while i < 100 {
        t[2 * i] = b'0' + (i / 10) as u8;
        t[2 * i + 1] = b'0' + (i % 10) as u8;
        i += 1;
    }
    t
};
/// The decimal digits of `v` (`< 10^19` when `pad`), zero-padded to 19 when `pad`.
fn fmt_u64(v: u64, buf: &mut [u8; 20], pad: bool) -> &[u8] {
    // Eight digits at a time: 10^19 = 10^3 * 10^8 * 10^8; each 8-digit block in pairs.
    let (hi, lo) = (v / 100_000_000, (v % 100_000_000) as u32);
    let (top, mid) = (hi / 100_000_000, (hi % 100_000_000) as u32);
    let put8 = |buf: &mut [u8; 20], at: usize, mut x: u32| {
        for k in (0..4).rev() {
            let p = (x % 100) as usize * 2;
            x /= 100;
            buf[at + 2 * k] = PAIRS[p];
            buf[at + 2 * k + 1] = PAIRS[p + 1];
        }
    };
    put8(buf, 12, lo);
    put8(buf, 4, mid);
    let mut t = top; // < 10^4 when v < 10^20
    for k in (0..4).rev() {
        buf[k] = b'0' + (t % 10) as u8;
        t /= 10;
    }
    let start = if pad { 1 } else { buf.iter().position(|&c| c != b'0').unwrap_or(19).min(19) };
    &buf[start..]
}

/// Appends the decimal text of `x` to `out`.
///
/// ```
/// use num_bigint::BigUint;
/// let x = BigUint::from(10u32).pow(40) + 7u32;
/// let mut s = String::new();
/// trimorph::exact::radix::push_decimal(&x, &mut s);
/// assert_eq!(s, x.to_string());
/// ```
pub fn push_decimal(x: &BigUint, out: &mut String) {
    let mut bytes = Vec::with_capacity((x.bits() as usize * 3) / 10 + 2);
    push_limbs(x.to_u64_digits(), &mut bytes);
    // One validation per number (the digits are ASCII by construction).
    out.push_str(std::str::from_utf8(&bytes).expect("ASCII digits"));
}

/// The decimal text of `x` (equal to `x.to_string()`).
pub fn decimal(x: &BigUint) -> String {
    let mut bytes = Vec::with_capacity((x.bits() as usize * 3) / 10 + 2);
    push_limbs(x.to_u64_digits(), &mut bytes);
    String::from_utf8(bytes).expect("ASCII digits")
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn reciprocal_division_is_exact_at_the_edges() {
        for &(u1, u0) in
            &[(0, 0), (0, D - 1), (0, D), (0, u64::MAX), (D - 1, u64::MAX), (D - 1, 0), (1, 0)]
        {
            let n = ((u1 as u128) << 64) | u0 as u128;
            assert_eq!(
                div_d(u1, u0),
                ((n / D as u128) as u64, (n % D as u128) as u64),
                "{u1} {u0}"
            );
        }
    }

    #[test]
    fn powers_of_ten_and_their_neighbours() {
        for k in 0..200u32 {
            let p = BigUint::from(10u32).pow(k);
            for x in [p.clone(), &p + 1u32, if k > 0 { &p - 1u32 } else { p.clone() }] {
                assert_eq!(decimal(&x), x.to_string(), "10^{k}");
            }
        }
        assert_eq!(decimal(&BigUint::from(0u32)), "0");
        let ones = (BigUint::from(1u32) << 6400u32) - 1u32;
        assert_eq!(decimal(&ones), ones.to_string());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        #[test]
        fn equals_num_bigint(limbs in prop::collection::vec(any::<u64>(), 0..90)) {
            let x = BigUint::from_slice(
                &limbs.iter().flat_map(|&l| [l as u32, (l >> 32) as u32]).collect::<Vec<_>>(),
            );
            prop_assert_eq!(decimal(&x), x.to_string());
        }

        #[test]
        fn two_word_division_equals_u128(u1 in 0..D, u0 in any::<u64>()) {
            let n = ((u1 as u128) << 64) | u0 as u128;
            prop_assert_eq!(div_d(u1, u0), ((n / D as u128) as u64, (n % D as u128) as u64));
        }
    }
}
