//! [`Int`]: an exact integer that stays on the machine word while it fits.
//!
//! Fraction-free elimination on the sparse, small-coefficient systems that trimorph produces
//! keeps most entries far below 2^63, yet a few can grow without bound (the bit size grows
//! linearly with the rank under GCD or Turner simplification, thesis ch. 7). `Int` stores a
//! value as an `i64` when it fits and as a `num_bigint::BigInt` otherwise; every operation
//! checks for overflow and promotes, so results are always exact. The invariant "`Big` only
//! when the value does not fit in `i64`" makes equality and hashing structural.
//!
//! `Int` implements the `num-traits` / `num-integer` traits, so `num_rational::Ratio<Int>`
//! (see [`crate::exact::Rat`]) is an exact rational with the same fast path.

use num_bigint::{BigInt, BigUint, Sign};
use num_integer::Integer;
use num_traits::{FromPrimitive, Num, One, Signed, ToPrimitive, Zero};
use std::cmp::Ordering;
use std::fmt;
use std::ops::{
    Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Rem, RemAssign, Sub, SubAssign,
};
use std::str::FromStr;

/// An exact integer: stored on the machine word while it fits in an `i64`, as a `BigInt`
/// otherwise.
///
/// The representation is private: every constructor ([`From<i64>`], [`From<BigInt>`],
/// [`Int::from_big`], [`Int::from_i128`], the arithmetic operators) keeps the invariant that
/// a value which fits in `i64` is stored on the word, so equality, hashing and
/// [`Int::is_zero_int`] are structural and cheap. Read the value with [`Int::as_i64`],
/// [`Int::view`] or [`Int::to_big`].
#[derive(Clone)]
pub struct Int(Repr);

/// The private representation of [`Int`]; `Big` never holds a value that fits in `i64`.
#[derive(Clone)]
enum Repr {
    /// A value that fits in `i64`.
    Small(i64),
    /// A value outside the `i64` range (never a value that would fit).
    Big(BigInt),
}

/// A borrowed view of an [`Int`], for matching on the word fast path without allocating.
///
/// `Big` is only produced for values outside the `i64` range, so a caller that handles
/// `Small` fully never sees a `Big` that would fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntView<'a> {
    /// The value, which fits in `i64`.
    Small(i64),
    /// The value, which does not fit in `i64`.
    Big(&'a BigInt),
}

impl Int {
    /// The value as an `i64`, when it fits (`None` exactly when it does not).
    #[inline]
    pub fn as_i64(&self) -> Option<i64> {
        match self.0 {
            Repr::Small(v) => Some(v),
            Repr::Big(_) => None,
        }
    }

    /// A borrowed view of the value: `Small` when it fits in `i64`, `Big` otherwise.
    #[inline]
    pub fn view(&self) -> IntView<'_> {
        match &self.0 {
            Repr::Small(v) => IntView::Small(*v),
            Repr::Big(b) => IntView::Big(b),
        }
    }

    /// Wraps a `BigInt`, demoting it to `Small` when it fits.
    pub fn from_big(b: BigInt) -> Int {
        match b.to_i64() {
            Some(v) => Int(Repr::Small(v)),
            None => Int(Repr::Big(b)),
        }
    }

    /// The value as a `BigInt`.
    pub fn to_big(&self) -> BigInt {
        match self {
            Int(Repr::Small(v)) => BigInt::from(*v),
            Int(Repr::Big(b)) => b.clone(),
        }
    }

    /// Converts an `i128`, which may or may not fit in `i64`.
    #[inline]
    pub fn from_i128(v: i128) -> Int {
        if v >= i64::MIN as i128 && v <= i64::MAX as i128 {
            Int(Repr::Small(v as i64))
        } else {
            Int(Repr::Big(BigInt::from(v)))
        }
    }

    /// True when the value is zero.
    #[inline]
    pub fn is_zero_int(&self) -> bool {
        matches!(self, Int(Repr::Small(0)))
    }

    /// -1, 0 or 1.
    #[inline]
    pub fn signum_i32(&self) -> i32 {
        match self {
            Int(Repr::Small(v)) => v.signum() as i32,
            Int(Repr::Big(b)) => match b.sign() {
                Sign::Minus => -1,
                Sign::NoSign => 0,
                Sign::Plus => 1,
            },
        }
    }

    /// Compares absolute values.
    pub fn cmp_abs(&self, other: &Int) -> Ordering {
        match (self, other) {
            (Int(Repr::Small(a)), Int(Repr::Small(b))) => a.unsigned_abs().cmp(&b.unsigned_abs()),
            (Int(Repr::Small(_)), Int(Repr::Big(_))) => Ordering::Less,
            (Int(Repr::Big(_)), Int(Repr::Small(_))) => Ordering::Greater,
            (Int(Repr::Big(a)), Int(Repr::Big(b))) => a.magnitude().cmp(b.magnitude()),
        }
    }

    /// Number of bits of the magnitude (0 for zero). The "bit size" of ch. 7 of the thesis.
    pub fn bits(&self) -> u64 {
        match self {
            Int(Repr::Small(v)) => 64 - v.unsigned_abs().leading_zeros() as u64,
            Int(Repr::Big(b)) => b.bits(),
        }
    }

    /// Exact division; the caller guarantees that `d` divides `self`.
    ///
    /// # Panics
    /// Panics when `d` is zero. In debug builds also when the division is not exact.
    pub fn div_exact(&self, d: &Int) -> Int {
        match (self, d) {
            (Int(Repr::Small(a)), Int(Repr::Small(b))) => {
                debug_assert!(*b != 0 && a % b == 0, "inexact division {a} / {b}");
                match a.checked_div(*b) {
                    Some(q) => Int(Repr::Small(q)),
                    None => Int::from_i128(*a as i128 / *b as i128),
                }
            }
            (Int(Repr::Big(a)), Int(Repr::Small(b))) => {
                debug_assert!((a % *b).is_zero(), "inexact division");
                Int::from_big(a / *b)
            }
            (Int(Repr::Small(a)), Int(Repr::Big(b))) => {
                // |d| > |a| (so an exact quotient is 0) except for i64::MIN / 2^63 = -1.
                if *a == i64::MIN {
                    return Int::from_big(BigInt::from(*a) / b);
                }
                debug_assert!(*a == 0, "inexact division");
                Int(Repr::Small(0))
            }
            (Int(Repr::Big(a)), Int(Repr::Big(b))) => {
                debug_assert!((a % b).is_zero(), "inexact division");
                Int::from_big(a / b)
            }
        }
    }

    /// Greatest common divisor, always non-negative; gcd(0, 0) = 0.
    pub fn gcd_int(&self, other: &Int) -> Int {
        match (self, other) {
            (Int(Repr::Small(a)), Int(Repr::Small(b))) => {
                int_from_u64(gcd_u64(a.unsigned_abs(), b.unsigned_abs()))
            }
            (Int(Repr::Small(a)), Int(Repr::Big(b))) | (Int(Repr::Big(b)), Int(Repr::Small(a))) => {
                if *a == 0 {
                    return Int::from_big(b.abs());
                }
                // gcd(a, b) = gcd(a, b mod a), and b mod a fits in a word.
                let r = (b % BigInt::from(*a)).to_i64().expect("remainder fits");
                int_from_u64(gcd_u64(a.unsigned_abs(), r.unsigned_abs()))
            }
            (Int(Repr::Big(a)), Int(Repr::Big(b))) => {
                Int::from_big(BigInt::from(super::gcd::gcd_biguint(a.magnitude(), b.magnitude())))
            }
        }
    }

    /// `self * a - other * b`, the fraction-free elimination kernel, with one overflow check.
    #[inline]
    pub fn cross(a: &Int, x: &Int, b: &Int, y: &Int) -> Int {
        if let (
            Int(Repr::Small(a)),
            Int(Repr::Small(x)),
            Int(Repr::Small(b)),
            Int(Repr::Small(y)),
        ) = (a, x, b, y)
        {
            let v = (*a as i128) * (*x as i128) - (*b as i128) * (*y as i128);
            return Int::from_i128(v);
        }
        &(a * x) - &(b * y)
    }

    /// Appends the decimal text of the value to `out` (the same text as `Display`, without
    /// the formatter's intermediate copies).
    pub fn push_decimal(&self, out: &mut String) {
        match self {
            Int(Repr::Small(v)) => {
                use std::fmt::Write;
                write!(out, "{v}").expect("writing to a String");
            }
            Int(Repr::Big(b)) => {
                if b.sign() == num_bigint::Sign::Minus {
                    out.push('-');
                }
                super::radix::push_decimal(b.magnitude(), out);
            }
        }
    }

    /// Approximate value as `f64` (correctly rounded for `Small`, nearest for `Big`).
    pub fn to_f64_lossy(&self) -> f64 {
        match self {
            Int(Repr::Small(v)) => *v as f64,
            Int(Repr::Big(b)) => b.to_f64().unwrap_or(f64::NAN),
        }
    }
}

/// Lehmer's gcd (Knuth, TAOCP vol. 2, 4.5.2, Algorithm L): most Euclid steps run on
/// machine words, and the big numbers are updated in place once per ~30 bits
/// ([`super::gcd`]). (num-bigint's binary gcd is quadratic with a large constant.)
pub fn lehmer_gcd(u: BigUint, v: BigUint) -> BigUint {
    super::gcd::gcd_biguint(&u, &v)
}

fn int_from_u64(g: u64) -> Int {
    Int::from_i128(g as i128)
}

/// Greatest common divisor on machine words (`gcd(0, 0) = 0`): Stein's binary algorithm,
/// as `num_integer` implements it.
#[inline]
pub fn gcd_u64(a: u64, b: u64) -> u64 {
    num_integer::Integer::gcd(&a, &b)
}

impl Default for Int {
    fn default() -> Int {
        Int(Repr::Small(0))
    }
}

impl From<i64> for Int {
    fn from(v: i64) -> Int {
        Int(Repr::Small(v))
    }
}
impl From<i32> for Int {
    fn from(v: i32) -> Int {
        Int(Repr::Small(v as i64))
    }
}
impl From<BigInt> for Int {
    fn from(b: BigInt) -> Int {
        Int::from_big(b)
    }
}
impl From<Int> for BigInt {
    fn from(v: Int) -> BigInt {
        match v.0 {
            Repr::Small(s) => BigInt::from(s),
            Repr::Big(b) => b,
        }
    }
}
impl num_bigint::ToBigInt for Int {
    /// Always `Some`: every `Int` is an integer.
    fn to_bigint(&self) -> Option<BigInt> {
        Some(self.to_big())
    }
}
impl From<&Int> for BigInt {
    fn from(v: &Int) -> BigInt {
        v.to_big()
    }
}

impl PartialEq for Int {
    fn eq(&self, other: &Int) -> bool {
        match (self, other) {
            (Int(Repr::Small(a)), Int(Repr::Small(b))) => a == b,
            (Int(Repr::Big(a)), Int(Repr::Big(b))) => a == b,
            _ => false, // normalized: a Big never equals a Small
        }
    }
}
impl Eq for Int {}

impl std::hash::Hash for Int {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        match self {
            Int(Repr::Small(v)) => v.hash(state),
            Int(Repr::Big(b)) => b.hash(state),
        }
    }
}

impl PartialOrd for Int {
    fn partial_cmp(&self, other: &Int) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Int {
    fn cmp(&self, other: &Int) -> Ordering {
        match (self, other) {
            (Int(Repr::Small(a)), Int(Repr::Small(b))) => a.cmp(b),
            _ => self.to_big().cmp(&other.to_big()),
        }
    }
}

impl fmt::Display for Int {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Int(Repr::Small(v)) => fmt::Display::fmt(v, f),
            // The same text as num-bigint's, several times faster ([`super::radix`]).
            Int(Repr::Big(b)) => f.pad_integral(
                b.sign() != num_bigint::Sign::Minus,
                "",
                &super::radix::decimal(b.magnitude()),
            ),
        }
    }
}
impl fmt::Debug for Int {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl FromStr for Int {
    type Err = num_bigint::ParseBigIntError;
    fn from_str(s: &str) -> Result<Int, Self::Err> {
        Ok(Int::from_big(BigInt::from_str(s)?))
    }
}

macro_rules! binop {
    ($tr:ident, $m:ident, $checked:ident, $bigop:tt, $small_big:expr) => {
        impl $tr<&Int> for &Int {
            type Output = Int;
            #[inline]
            fn $m(self, rhs: &Int) -> Int {
                match (self, rhs) {
                    (Int(Repr::Small(a)), Int(Repr::Small(b))) => match a.$checked(*b) {
                        Some(v) => Int(Repr::Small(v)),
                        None => Int::from_i128((*a as i128) $bigop (*b as i128)),
                    },
                    (Int(Repr::Big(a)), Int(Repr::Small(b))) => Int::from_big(a $bigop *b),
                    (Int(Repr::Small(a)), Int(Repr::Big(b))) => Int::from_big($small_big(*a, b)),
                    (Int(Repr::Big(a)), Int(Repr::Big(b))) => Int::from_big(a $bigop b),
                }
            }
        }
        impl $tr<Int> for Int {
            type Output = Int;
            #[inline]
            fn $m(self, rhs: Int) -> Int {
                (&self).$m(&rhs)
            }
        }
        impl $tr<&Int> for Int {
            type Output = Int;
            #[inline]
            fn $m(self, rhs: &Int) -> Int {
                (&self).$m(rhs)
            }
        }
    };
}
binop!(Add, add, checked_add, +, |a: i64, b: &BigInt| b + a);
binop!(Sub, sub, checked_sub, -, |a: i64, b: &BigInt| -(b - a));
binop!(Mul, mul, checked_mul, *, |a: i64, b: &BigInt| b * a);

// Truncating division and remainder (as for primitive integers).
impl Div<&Int> for &Int {
    type Output = Int;
    fn div(self, rhs: &Int) -> Int {
        if let (Int(Repr::Small(a)), Int(Repr::Small(b))) = (self, rhs) {
            if let Some(v) = a.checked_div(*b) {
                return Int(Repr::Small(v));
            }
        }
        Int::from_big(self.to_big() / rhs.to_big())
    }
}
impl Div<Int> for Int {
    type Output = Int;
    fn div(self, rhs: Int) -> Int {
        &self / &rhs
    }
}
impl Rem<&Int> for &Int {
    type Output = Int;
    fn rem(self, rhs: &Int) -> Int {
        if let (Int(Repr::Small(a)), Int(Repr::Small(b))) = (self, rhs) {
            if let Some(v) = a.checked_rem(*b) {
                return Int(Repr::Small(v));
            }
        }
        Int::from_big(self.to_big() % rhs.to_big())
    }
}
impl Rem<Int> for Int {
    type Output = Int;
    fn rem(self, rhs: Int) -> Int {
        &self % &rhs
    }
}

impl Neg for Int {
    type Output = Int;
    fn neg(self) -> Int {
        match self {
            Int(Repr::Small(v)) => match v.checked_neg() {
                Some(n) => Int(Repr::Small(n)),
                None => Int(Repr::Big(-BigInt::from(v))),
            },
            Int(Repr::Big(b)) => Int::from_big(-b),
        }
    }
}
impl Neg for &Int {
    type Output = Int;
    fn neg(self) -> Int {
        self.clone().neg()
    }
}

impl AddAssign<&Int> for Int {
    fn add_assign(&mut self, rhs: &Int) {
        *self = &*self + rhs;
    }
}
impl SubAssign<&Int> for Int {
    fn sub_assign(&mut self, rhs: &Int) {
        *self = &*self - rhs;
    }
}
impl MulAssign<&Int> for Int {
    fn mul_assign(&mut self, rhs: &Int) {
        *self = &*self * rhs;
    }
}

macro_rules! assign_owned {
    ($tr:ident, $m:ident, $op:tt) => {
        impl $tr<Int> for Int {
            fn $m(&mut self, rhs: Int) {
                *self = &*self $op &rhs;
            }
        }
    };
}
assign_owned!(AddAssign, add_assign, +);
assign_owned!(SubAssign, sub_assign, -);
assign_owned!(MulAssign, mul_assign, *);
assign_owned!(DivAssign, div_assign, /);
assign_owned!(RemAssign, rem_assign, %);

impl Zero for Int {
    fn zero() -> Int {
        Int(Repr::Small(0))
    }
    fn is_zero(&self) -> bool {
        self.is_zero_int()
    }
}
impl One for Int {
    fn one() -> Int {
        Int(Repr::Small(1))
    }
}

impl Num for Int {
    type FromStrRadixErr = num_bigint::ParseBigIntError;
    fn from_str_radix(s: &str, radix: u32) -> Result<Int, Self::FromStrRadixErr> {
        Ok(Int::from_big(BigInt::from_str_radix(s, radix)?))
    }
}

impl Signed for Int {
    fn abs(&self) -> Int {
        if self.signum_i32() < 0 {
            -self
        } else {
            self.clone()
        }
    }
    fn abs_sub(&self, other: &Int) -> Int {
        if self <= other {
            Int::zero()
        } else {
            self - other
        }
    }
    fn signum(&self) -> Int {
        Int(Repr::Small(self.signum_i32() as i64))
    }
    fn is_positive(&self) -> bool {
        self.signum_i32() > 0
    }
    fn is_negative(&self) -> bool {
        self.signum_i32() < 0
    }
}

impl Integer for Int {
    fn div_floor(&self, other: &Int) -> Int {
        match (self, other) {
            (Int(Repr::Small(a)), Int(Repr::Small(b))) if !(*a == i64::MIN && *b == -1) => {
                Int(Repr::Small(Integer::div_floor(a, b)))
            }
            _ => Int::from_big(Integer::div_floor(&self.to_big(), &other.to_big())),
        }
    }
    fn mod_floor(&self, other: &Int) -> Int {
        match (self, other) {
            (Int(Repr::Small(a)), Int(Repr::Small(b))) if !(*a == i64::MIN && *b == -1) => {
                Int(Repr::Small(Integer::mod_floor(a, b)))
            }
            _ => Int::from_big(Integer::mod_floor(&self.to_big(), &other.to_big())),
        }
    }
    fn gcd(&self, other: &Int) -> Int {
        self.gcd_int(other)
    }
    fn lcm(&self, other: &Int) -> Int {
        if self.is_zero() || other.is_zero() {
            return Int::zero();
        }
        let g = self.gcd_int(other);
        (self.div_exact(&g) * other).abs()
    }
    fn is_multiple_of(&self, other: &Int) -> bool {
        if other.is_zero() {
            return self.is_zero();
        }
        (self % other).is_zero()
    }
    fn is_even(&self) -> bool {
        match self {
            Int(Repr::Small(v)) => v % 2 == 0,
            Int(Repr::Big(b)) => b.is_even(),
        }
    }
    fn is_odd(&self) -> bool {
        !self.is_even()
    }
    fn div_rem(&self, other: &Int) -> (Int, Int) {
        (self / other, self % other)
    }
}

impl ToPrimitive for Int {
    fn to_i64(&self) -> Option<i64> {
        match self {
            Int(Repr::Small(v)) => Some(*v),
            Int(Repr::Big(_)) => None,
        }
    }
    fn to_u64(&self) -> Option<u64> {
        match self {
            Int(Repr::Small(v)) => u64::try_from(*v).ok(),
            Int(Repr::Big(b)) => b.to_u64(),
        }
    }
    fn to_f64(&self) -> Option<f64> {
        Some(self.to_f64_lossy())
    }
}
impl FromPrimitive for Int {
    fn from_i64(n: i64) -> Option<Int> {
        Some(Int(Repr::Small(n)))
    }
    fn from_u64(n: u64) -> Option<Int> {
        Some(Int::from_i128(n as i128))
    }
}

#[cfg(test)]
mod tests {
    /// `push_decimal` writes `Display`'s text: words, their extremes, and big values of
    /// both signs.
    #[test]
    fn push_decimal_equals_display() {
        let big: BigInt = BigInt::from(10u32).pow(77) * 3 + 17;
        for v in [
            Int::from(0),
            Int::from(-7),
            Int::from(i64::MIN),
            Int::from(i64::MAX),
            Int::from_i128(i64::MAX as i128 + 1),
            Int::from_big(big.clone()),
            Int::from_big(-big),
        ] {
            let mut s = String::from("x=");
            v.push_decimal(&mut s);
            assert_eq!(s, format!("x={v}"));
        }
    }

    use super::*;
    use proptest::prelude::*;

    fn big(v: &Int) -> BigInt {
        v.to_big()
    }

    #[test]
    fn overflow_promotes_and_demotes() {
        let a = Int::from(i64::MAX);
        let s = &a + &Int::from(1);
        assert_eq!(s.as_i64(), None);
        let back = &s - &Int::from(1);
        assert_eq!(back.as_i64(), Some(i64::MAX));
        let m = &Int::from(i64::MIN) * &Int::from(-1);
        assert_eq!(big(&m), BigInt::from(i64::MAX) + 1);
        assert_eq!(-Int::from(i64::MIN), m);
    }

    #[test]
    fn gcd_of_min_is_big() {
        let g = Int::from(i64::MIN).gcd_int(&Int::from(0));
        assert_eq!(big(&g), BigInt::from(1u64 << 63));
        assert_eq!(Int::from(12).gcd_int(&Int::from(-18)), Int::from(6));
        assert_eq!(Int::from(0).gcd_int(&Int::from(0)), Int::from(0));
    }

    #[test]
    fn bits_matches_bigint() {
        for v in [0i64, 1, -1, 2, 3, 255, -256, i64::MAX, i64::MIN] {
            assert_eq!(Int::from(v).bits(), BigInt::from(v).bits(), "{v}");
        }
    }

    fn hash_of(v: &Int) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        v.hash(&mut h);
        h.finish()
    }

    /// Every way of building the same value gives equal `Int`s with equal hashes, the same
    /// `is_zero` and the same word view: the representation is canonical by construction.
    fn assert_canonical(v: i128) {
        let big = BigInt::from(v);
        let mut ways = vec![
            Int::from(big.clone()),
            Int::from_big(big.clone()),
            Int::from_i128(v),
            v.to_string().parse::<Int>().expect("decimal"),
            // Through a Big intermediate that demotes again.
            &(&Int::from_i128(v) + &Int::from(BigInt::from(u64::MAX) * 4))
                - &Int::from(BigInt::from(u64::MAX) * 4),
            (&Int::from_i128(v) * &Int::from(BigInt::from(i64::MAX) + 1))
                .div_exact(&Int::from(BigInt::from(i64::MAX) + 1)),
        ];
        if let Ok(s) = i64::try_from(v) {
            ways.push(Int::from(s));
            ways.push(<Int as FromPrimitive>::from_i64(s).expect("i64"));
        }
        let first = &ways[0];
        for w in &ways {
            assert_eq!(w, first, "{v}");
            assert_eq!(hash_of(w), hash_of(first), "{v}");
            assert_eq!(w.is_zero_int(), v == 0, "{v}");
            assert_eq!(Zero::is_zero(w), v == 0, "{v}");
            assert_eq!(w.as_i64(), i64::try_from(v).ok(), "{v}");
            assert_eq!(w.to_big(), big, "{v}");
            assert_eq!(w.cmp(first), Ordering::Equal, "{v}");
            match w.view() {
                IntView::Small(s) => assert_eq!(s as i128, v),
                IntView::Big(b) => {
                    assert_eq!(b, &big);
                    assert!(i64::try_from(v).is_err(), "{v} fits in i64 but was kept big");
                }
            }
        }
    }

    #[test]
    fn equality_hash_and_zero_agree_however_the_value_is_built() {
        let max = i64::MAX as i128;
        let min = i64::MIN as i128;
        for v in [0, 1, -1, max, min, max + 1, min - 1, -max, max * 3, min * 5] {
            assert_canonical(v);
        }
        // A BigInt zero built by arithmetic is the word zero.
        let z = Int::from(BigInt::from(i64::MAX) - BigInt::from(i64::MAX));
        assert!(z.is_zero_int());
        assert_eq!(z, Int::zero());
        assert_eq!(hash_of(&z), hash_of(&Int::zero()));
    }

    proptest! {
        #[test]
        fn lehmer_gcd_agrees_with_bigint(a in prop::collection::vec(any::<u64>(), 1..6), b in prop::collection::vec(any::<u64>(), 1..6), g in prop::collection::vec(any::<u64>(), 0..3)) {
            let mk = |v: &[u64]| v.iter().fold(BigUint::from(0u8), |acc, x| (acc << 64) + BigUint::from(*x));
            let (x, y, f) = (mk(&a), mk(&b), mk(&g) + 1u8);
            let (x, y) = (x * &f, y * &f);
            prop_assert_eq!(lehmer_gcd(x.clone(), y.clone()), x.gcd(&y));
        }

        #[test]
        fn built_from_i64_or_bigint_is_the_same_int(a in any::<i64>(), b in any::<i128>()) {
            assert_canonical(a as i128);
            assert_canonical(b);
        }

        #[test]
        fn ops_agree_with_bigint(a in any::<i64>(), b in any::<i64>(), c in any::<i64>(), d in any::<i64>()) {
            let (x, y) = (Int::from(a), Int::from(b));
            let (ba, bb) = (BigInt::from(a), BigInt::from(b));
            prop_assert_eq!(big(&(&x + &y)), &ba + &bb);
            prop_assert_eq!(big(&(&x - &y)), &ba - &bb);
            prop_assert_eq!(big(&(&x * &y)), &ba * &bb);
            let p = &x * &y; // often Big
            prop_assert_eq!(big(&(&p + &x)), &ba * &bb + &ba);
            prop_assert_eq!(big(&(&x + &p)), &ba * &bb + &ba);
            prop_assert_eq!(big(&(&p - &x)), &ba * &bb - &ba);
            prop_assert_eq!(big(&(&x - &p)), &ba - &ba * &bb);
            prop_assert_eq!(big(&(&x * &p)), &ba * &ba * &bb);
            prop_assert_eq!(big(&(&p * &p)), (&ba * &bb) * (&ba * &bb));
            prop_assert_eq!(big(&Int::cross(&p, &p, &x, &y)), (&ba * &bb) * (&ba * &bb) - &ba * &bb);
            prop_assert_eq!(big(&(&p * &p).div_exact(&p)), &ba * &bb);
            prop_assert_eq!(big(&p.gcd_int(&x)), (&ba * &bb).gcd(&ba));
            prop_assert_eq!(big(&x.gcd_int(&p)), (&ba * &bb).gcd(&ba));
            prop_assert_eq!(p.cmp_abs(&x), (&ba * &bb).magnitude().cmp(ba.magnitude()));
            if b != 0 {
                prop_assert_eq!(big(&p.div_exact(&y)), ba.clone());
                prop_assert_eq!(big(&Integer::div_floor(&x, &y)), Integer::div_floor(&ba, &bb));
                prop_assert_eq!(big(&Integer::mod_floor(&x, &y)), Integer::mod_floor(&ba, &bb));
            }
            let cr = Int::cross(&x, &y, &Int::from(c), &Int::from(d));
            prop_assert_eq!(big(&cr), &ba * &bb - BigInt::from(c) * BigInt::from(d));
            prop_assert_eq!(x.cmp(&y), a.cmp(&b));
        }
    }
}
