//! Exact reduced row echelon forms for the determining set's local systems
//! ([`super::mds::Mds`], ring 2 of each vertex): the same reduced rows computed in the
//! narrowest exact type that holds them. Fraction-free Gauss-Jordan elimination (Bareiss
//! 1968) runs on `i128` entries (products formed in 256 bits), then on 256-bit entries
//! (products in 512 bits, `bnum`), then on exact integers of any size, and as a last resort
//! in fractions ([`rref`]). The reduced row echelon form is unique, so every path gives the
//! same rows; only the pivot rows become fractions ([`pivot_formulas`]).

use crate::exact::{rat_from_i128, Int, Rat};
use bnum::cast::As;
use bnum::types::{I256, I512};
use num_traits::Zero;

/// A dependent's formula: `sum c_j x_j` as `(j, c_j)`.
pub(super) type Formula = Vec<(usize, Rat)>;

/// Reduced row echelon form over the rationals, pivots searched in column order among the
/// first `ncand` columns.
pub(super) fn rref(rows: &mut [Vec<Rat>], ncand: usize) -> Vec<(usize, usize)> {
    let mut pivots = Vec::new();
    let mut r = 0;
    for c in 0..ncand {
        let Some(p) = (r..rows.len()).find(|&i| !rows[i][c].is_zero()) else { continue };
        rows.swap(r, p);
        let inv = rows[r][c].recip();
        // The rows are sparse (a quadrilateral condition has four members): only the pivot
        // row's nonzero entries take part, which leaves every value as the dense loops would.
        let mut nz: Vec<usize> = Vec::new();
        for (j, x) in rows[r].iter_mut().enumerate() {
            if !x.is_zero() {
                *x *= &inv;
                nz.push(j);
            }
        }
        let pivot_row = rows[r].clone();
        for (i, row) in rows.iter_mut().enumerate() {
            if i != r && !row[c].is_zero() {
                let f = row[c].clone();
                for &j in &nz {
                    row[j] -= &f * &pivot_row[j];
                }
            }
        }
        pivots.push((r, c));
        r += 1;
    }
    pivots
}

/// A fixed-width integer for [`rref_fixed`]: the fraction-free step `(p x - a y) / prev`,
/// exact (Bareiss: `prev` divides it), with the products formed in a type twice as wide.
/// The minors of an elimination fit in a width far more often than the products before
/// each division (two minors' product) do.
pub(super) trait Word: Copy + PartialEq + Send + Sync {
    /// Zero.
    fn zero() -> Self;
    /// One.
    fn one() -> Self;
    /// `(p x - a y) / prev`, or `None` when the division is not exact or the quotient does
    /// not fit.
    fn step(p: Self, x: Self, a: Self, y: Self, prev: Self) -> Option<Self>;
}

impl Word for i128 {
    fn zero() -> Self {
        0
    }
    fn one() -> Self {
        1
    }
    #[inline]
    fn step(p: i128, x: i128, a: i128, y: i128, prev: i128) -> Option<i128> {
        let narrow =
            p.checked_mul(x).and_then(|px| a.checked_mul(y).and_then(|ay| px.checked_sub(ay)));
        if let Some(t) = narrow {
            if prev == 1 {
                return Some(t);
            }
            // One division (on 64 bits when both fit), checked by multiplying back:
            // |q prev| <= |t|, so the product cannot overflow.
            let q = match (i64::try_from(t), i64::try_from(prev)) {
                (Ok(t), Ok(d)) => i128::from(t.checked_div(d)?),
                _ => t.checked_div(prev)?,
            };
            return (q * prev == t).then_some(q);
        }
        // |p x|, |a y| <= 2^254: neither the products nor their difference overflow.
        let w = |v: i128| -> I256 { v.as_() };
        exact_quotient(w(p) * w(x) - w(a) * w(y), prev)
    }
}

/// The inverse of an odd `d` modulo 2^128 (Newton's iteration `x <- x (2 - d x)` doubles
/// the number of correct low bits; `x = d` is right to 3 bits, as `d^2 = 1 mod 8`).
fn inverse_mod_2_128(d: u128) -> u128 {
    debug_assert!(d & 1 == 1, "only odd numbers are invertible modulo 2^128");
    let mut x = d;
    for _ in 0..6 {
        x = x.wrapping_mul(2u128.wrapping_sub(d.wrapping_mul(x)));
    }
    x
}

/// `t / d` when the division is exact and the quotient fits in `i128` (`d != 0`), else
/// `None`: by exact division (Jebelean 1993) instead of a long division. With
/// `d = 2^s d'` (`d'` odd), an exact quotient `q` satisfies `t / 2^s = q d'`, so
/// `q = (t / 2^s) d'^-1 mod 2^128`, which is `q` itself when `q` fits in `i128`. One
/// 256-bit product then checks the candidate: `q d = t` holds exactly when both conditions
/// do.
fn exact_quotient(t: I256, d: i128) -> Option<i128> {
    if d == 0 {
        return None;
    }
    let s = d.trailing_zeros();
    let low: u128 = t.as_();
    if low & ((1u128 << s) - 1) != 0 {
        return None;
    }
    let shifted: u128 = (t >> s).as_();
    let q = shifted.wrapping_mul(inverse_mod_2_128((d >> s) as u128)) as i128;
    let w = |v: i128| -> I256 { v.as_() };
    (w(q) * w(d) == t).then_some(q)
}

impl Word for I256 {
    fn zero() -> Self {
        0i128.as_()
    }
    fn one() -> Self {
        1i128.as_()
    }
    #[inline]
    fn step(p: I256, x: I256, a: I256, y: I256, prev: I256) -> Option<I256> {
        let narrow =
            p.checked_mul(x).and_then(|px| a.checked_mul(y).and_then(|ay| px.checked_sub(ay)));
        if let Some(t) = narrow {
            return if prev == I256::one() {
                Some(t)
            } else {
                let q = t.checked_div(prev)?;
                (q * prev == t).then_some(q)
            };
        }
        // |p x|, |a y| <= 2^510: neither the products nor their difference overflow.
        let w = |v: I256| -> I512 { v.as_() };
        let t = w(p) * w(x) - w(a) * w(y);
        let q = t.checked_div(w(prev))?;
        if q * w(prev) != t {
            return None;
        }
        let narrow: I256 = q.as_();
        (w(narrow) == q).then_some(narrow)
    }
}

/// [`rref`] of an integer matrix by fraction-free Gauss-Jordan elimination: each step
/// replaces every other row by `(p row_i - a_i row_r) / p_prev` (`p` the pivot, `a_i` the
/// row's entry in the pivot column, `p_prev` the previous pivot), an exact division, since
/// every entry is then a minor of the matrix (Bareiss 1968). Pivots are chosen as [`rref`]
/// chooses them (first nonzero row, columns in order among the first `ncand`), and the
/// reduced row echelon form is unique, so dividing each pivot row by its pivot gives
/// exactly [`rref`]'s rows, with integer operations instead of a gcd per operation.
/// Returns the pivots, or `None` when a number does not fit in `W` or a division is not
/// exact (the caller then tries a wider type, then [`rref_big`]); the rows are left as they
/// are then.
pub(super) fn rref_fixed<W: Word>(
    rows: &mut [Vec<W>],
    ncand: usize,
) -> Option<Vec<(usize, usize)>> {
    let mut pivots = Vec::new();
    let (zero, one) = (W::zero(), W::one());
    let mut prev = one;
    let mut r = 0;
    let mut work: Vec<Vec<W>> = rows.to_vec();
    for c in 0..ncand {
        let Some(p) = (r..work.len()).find(|&i| work[i][c] != zero) else { continue };
        work.swap(r, p);
        let piv = work[r][c];
        let (before, rest) = work.split_at_mut(r);
        let (pivot_row, after) = rest.split_first_mut().expect("row r exists");
        for row in before.iter_mut().chain(after.iter_mut()) {
            let a = row[c];
            for (x, &y) in row.iter_mut().zip(pivot_row.iter()) {
                // The rows are sparse: an entry with x = 0 and a y = 0 stays 0 (t = 0), and
                // the first step divides by 1; both skip the division.
                if *x == zero && (a == zero || y == zero) {
                    continue;
                }
                *x = W::step(piv, *x, a, y, prev)?;
            }
        }
        prev = piv;
        pivots.push((r, c));
        r += 1;
    }
    rows.clone_from_slice(&work);
    Some(pivots)
}

/// [`rref_fixed`] on `i128` entries.
pub(super) fn rref_int(rows: &mut [Vec<i128>], ncand: usize) -> Option<Vec<(usize, usize)>> {
    rref_fixed(rows, ncand)
}

/// An exact integer from a 256-bit one.
fn int_of_i256(x: I256) -> Int {
    match i128::try_from(x) {
        Ok(v) => Int::from_i128(v),
        Err(_) => Int::from_big(num_bigint::BigInt::from_signed_bytes_le(&x.to_le_bytes())),
    }
}

/// [`rref_int`] in exact integers of any size (the same steps, each division checked):
/// for eliminations whose minors do not fit in `i128`. Returns the pivots, or `None` when a
/// division is not exact (the caller then runs [`rref`]); the rows are then unspecified.
pub(super) fn rref_big(rows: &mut [Vec<Int>], ncand: usize) -> Option<Vec<(usize, usize)>> {
    let mut pivots = Vec::new();
    let mut prev = Int::from(1);
    let mut r = 0;
    for c in 0..ncand {
        let Some(p) = (r..rows.len()).find(|&i| !rows[i][c].is_zero_int()) else { continue };
        rows.swap(r, p);
        let piv = rows[r][c].clone();
        let (before, rest) = rows.split_at_mut(r);
        let (pivot_row, after) = rest.split_first_mut().expect("row r exists");
        let first = pivots.is_empty();
        for row in before.iter_mut().chain(after.iter_mut()) {
            let a = row[c].clone();
            for (x, y) in row.iter_mut().zip(pivot_row.iter()) {
                if x.is_zero_int() && (a.is_zero_int() || y.is_zero_int()) {
                    continue;
                }
                let t = &(&piv * &*x) - &(&a * y);
                if first {
                    *x = t;
                } else if !(&t % &prev).is_zero_int() {
                    return None;
                } else {
                    *x = t.div_exact(&prev);
                }
            }
        }
        prev = piv;
        pivots.push((r, c));
        r += 1;
    }
    Some(pivots)
}

/// An entry of a reduced row: an exact integer of some width, or a fraction.
pub(super) trait Entry {
    /// Whether it is zero.
    fn is_zero_entry(&self) -> bool;
    /// `self / den` in lowest terms (`den` nonzero).
    fn ratio(&self, den: &Self) -> Rat;
}

impl Entry for i128 {
    fn is_zero_entry(&self) -> bool {
        *self == 0
    }
    fn ratio(&self, den: &i128) -> Rat {
        rat_from_i128(*self, *den)
    }
}

impl Entry for I256 {
    fn is_zero_entry(&self) -> bool {
        *self == I256::zero()
    }
    fn ratio(&self, den: &I256) -> Rat {
        match (i128::try_from(*self), i128::try_from(*den)) {
            (Ok(x), Ok(d)) => rat_from_i128(x, d),
            _ => Rat::new(int_of_i256(*self), int_of_i256(*den)),
        }
    }
}

impl Entry for Int {
    fn is_zero_entry(&self) -> bool {
        self.is_zero_int()
    }
    fn ratio(&self, den: &Int) -> Rat {
        Rat::new(self.clone(), den.clone())
    }
}

impl Entry for Rat {
    fn is_zero_entry(&self) -> bool {
        self.is_zero()
    }
    fn ratio(&self, den: &Rat) -> Rat {
        self / den
    }
}

/// The dependents of a reduced system (rows after [`rref_fixed`], [`rref_big`] or
/// [`rref`]): each pivot `(r, c)` makes `cols[c] = -sum_(j != c) (row_r[j] / row_r[c])
/// all[j]`. `None` when a row without a pivot is not zero (the conditions constrain the
/// parameters: a singular vertex).
pub(super) fn pivot_formulas<E: Entry>(
    rows: &[Vec<E>],
    pivots: &[(usize, usize)],
    cols: &[usize],
    all: &[usize],
) -> Option<Vec<(usize, Formula)>> {
    for (i, row) in rows.iter().enumerate() {
        if !pivots.iter().any(|&(r, _)| r == i) && row.iter().any(|x| !x.is_zero_entry()) {
            return None;
        }
    }
    Some(
        pivots
            .iter()
            .map(|&(r, c)| {
                let den = &rows[r][c];
                let f: Formula = (0..all.len())
                    .filter(|&j| j != c && !rows[r][j].is_zero_entry())
                    .map(|j| (all[j], -rows[r][j].ratio(den)))
                    .collect();
                (cols[c], f)
            })
            .collect(),
    )
}

/// The fractions of reduced rows: pivot rows divided by their pivot, other rows as they
/// are (the rows [`rref`] gives, for comparing the integer eliminations with it).
#[cfg(test)]
pub(super) fn rows_to_rat<E: Entry>(
    rows: &[Vec<E>],
    pivots: &[(usize, usize)],
    one: &E,
) -> Vec<Vec<Rat>> {
    rows.iter()
        .enumerate()
        .map(|(i, row)| {
            let den = pivots.iter().find(|&&(r, _)| r == i).map_or(one, |&(r, c)| &rows[r][c]);
            row.iter().map(|x| if x.is_zero_entry() { Rat::zero() } else { x.ratio(den) }).collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn to_rat(rows: &[Vec<i128>]) -> Vec<Vec<Rat>> {
        rows.iter()
            .map(|r| r.iter().map(|&x| Rat::from_integer(Int::from_i128(x))).collect())
            .collect()
    }

    #[test]
    fn fraction_free_rref_of_a_rank_deficient_matrix_matches_fractions() {
        // Row 3 = row 1 + row 2, and column 1 = 2 * column 0: pivots skip column 1.
        let m = vec![
            vec![2, 4, 1, 0, 3],
            vec![1, 2, 0, 5, -1],
            vec![3, 6, 1, 5, 2],
            vec![0, 0, 7, 1, 1],
        ];
        let mut ints = m.clone();
        let pivots = rref_int(&mut ints, 4).expect("small numbers fit");
        let mut rats = to_rat(&m);
        assert_eq!(pivots, rref(&mut rats, 4));
        assert_eq!(pivots, vec![(0, 0), (1, 2), (2, 3)]);
        assert_eq!(rows_to_rat(&ints, &pivots, &1), rats);
    }

    #[test]
    fn fraction_free_rref_reports_overflow() {
        let big = i128::MAX / 3;
        let mut m = vec![vec![big, 1, 2], vec![3, big, 5]];
        let before = m.clone();
        assert_eq!(rref_int(&mut m, 2), None);
        assert_eq!(m, before, "rows untouched on overflow");
    }

    /// The pivot rows of an exact elimination equal the rational one's (`rats`), and each
    /// other row is zero in both or in neither.
    fn same_reduced_rows(
        got: &[Vec<Rat>],
        rats: &[Vec<Rat>],
        pivots: &[(usize, usize)],
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        for &(r, _) in pivots {
            prop_assert_eq!(&got[r], &rats[r]);
        }
        for i in 0..rats.len() {
            if !pivots.iter().any(|&(r, _)| r == i) {
                let zero_int = got[i].iter().all(|x| x.is_zero());
                let zero_rat = rats[i].iter().all(|x| x.is_zero());
                prop_assert_eq!(zero_int, zero_rat);
            }
        }
        Ok(())
    }

    proptest! {
        /// Random small integer matrices, often rank deficient (rows repeated with a
        /// multiple): the fraction-free elimination gives the same pivots and the same reduced
        /// rows as the elimination in fractions.
        #[test]
        fn fraction_free_rref_equals_rational_rref(
            base in proptest::collection::vec(proptest::collection::vec(-9i64..10, 7), 1..6),
            dup in proptest::option::of((0usize..6, -3i64..4)),
            ncand in 1usize..8,
        ) {
            let mut m: Vec<Vec<i128>> =
                base.iter().map(|r| r.iter().map(|&x| i128::from(x)).collect()).collect();
            if let Some((i, k)) = dup {
                let r: Vec<i128> = m[i % m.len()].iter().map(|&x| x * i128::from(k)).collect();
                m.push(r);
            }
            let mut ints = m.clone();
            let pivots = rref_int(&mut ints, ncand.min(7)).expect("small numbers fit");
            let mut rats = to_rat(&m);
            prop_assert_eq!(&pivots, &rref(&mut rats, ncand.min(7)));
            same_reduced_rows(&rows_to_rat(&ints, &pivots, &1), &rats, &pivots)?;
        }

        /// Matrices whose minors overflow `i128` (entries up to 2^45, as C1 conditions on a
        /// fine snapping grid have): the elimination in exact integers gives the same pivots
        /// and reduced rows as the one in fractions, while the `i128` one gives up.
        #[test]
        fn big_fraction_free_rref_equals_rational_rref(
            base in proptest::collection::vec(proptest::collection::vec(-9i64..10, 7), 2..7),
            scale in proptest::collection::vec(1i64..(1 << 45), 7),
            dup in proptest::option::of((0usize..7, -3i64..4)),
            ncand in 1usize..8,
        ) {
            let mut m: Vec<Vec<i128>> = base
                .iter()
                .map(|r| r.iter().zip(&scale).map(|(&x, &s)| i128::from(x) * i128::from(s) + i128::from(x.signum())).collect())
                .collect();
            if let Some((i, k)) = dup {
                let r: Vec<i128> = m[i % m.len()].iter().map(|&x| x * i128::from(k)).collect();
                m.push(r);
            }
            let ncand = ncand.min(7);
            let mut big: Vec<Vec<Int>> =
                m.iter().map(|r| r.iter().map(|&x| Int::from_i128(x)).collect()).collect();
            let pivots = rref_big(&mut big, ncand).expect("fraction-free divisions are exact");
            let mut rats = to_rat(&m);
            prop_assert_eq!(&pivots, &rref(&mut rats, ncand));
            same_reduced_rows(&rows_to_rat(&big, &pivots, &Int::from(1)), &rats, &pivots)?;
        }
    }

    #[test]
    fn fraction_free_rref_forms_products_beyond_i128_in_256_bits() {
        // Entries near 2^30: the 4 x 4 minors (about 2^122) fit in i128, but the products
        // before each exact division (two minors, about 2^215) do not. The old i128-only step
        // gave up here and sent most ring-2 systems of a fit to big integers.
        let e = 1i128 << 30;
        let m: Vec<Vec<i128>> = (0..4)
            .map(|i| (0..6).map(|j| e + ((i * 7 + j * 13) % 11) * 1_000_003 - 5 * i).collect())
            .collect();
        let mut ints = m.clone();
        let pivots = rref_int(&mut ints, 6).expect("the minors fit in i128");
        let mut rats = to_rat(&m);
        assert_eq!(pivots, rref(&mut rats, 6));
        assert_eq!(rows_to_rat(&ints, &pivots, &1), rats);
        // The last step multiplies the leading 3 x 3 minor by another 3 x 3 minor: beyond
        // i128, so the 256-bit branch was taken.
        let det3 = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        assert!(det3 != 0 && det3.checked_mul(det3).is_none(), "the test must reach 256 bits");
    }

    #[test]
    fn a_step_whose_quotient_exceeds_i128_gives_up() {
        let step = <i128 as Word>::step;
        let big = i128::MAX / 2;
        assert_eq!(step(big, big, 0, 0, 1), None);
        assert_eq!(step(big, big, 0, 0, 3), None, "quotient about 2^250");
        assert_eq!(step(big, 4, 1, 1, 2), None, "not exact: 4 big - 1 is odd");
        assert_eq!(step(big, 4, 2, 2, 2), Some(2 * big - 2));
    }

    #[test]
    fn a_256_bit_step_forms_its_products_in_512_bits() {
        let w = |v: i128| -> I256 { v.as_() };
        let step = <I256 as Word>::step;
        let big = w(i128::MAX) * w(1 << 100); // about 2^227
        assert_eq!(step(big, big, w(0), w(0), w(1)), None, "quotient about 2^454");
        assert_eq!(step(big, w(4), w(2), w(2), w(2)), Some(big * w(2) - w(2)));
        assert_eq!(step(big, big, w(1), big, big), Some(big - w(1)), "products near 2^454");
        assert_eq!(step(big, w(4), w(1), w(1), w(2)), None, "not exact");
    }

    fn w256(v: i128) -> I256 {
        v.as_()
    }

    /// A matrix whose 3 x 3 minors (of 2^44-sized entries, about 2^132) overflow i128 but
    /// fit 256 bits.
    fn minors_beyond_i128() -> Vec<Vec<i128>> {
        let e = 1i128 << 44;
        let m = vec![vec![e + 1, e - 3, 7, 1], vec![e - 5, e + 9, e, 2], vec![3, e + 1, e - 1, 3]];
        assert_eq!(rref_int(&mut m.clone(), 3), None);
        m
    }

    #[test]
    fn minors_beyond_i128_are_eliminated_in_256_bits() {
        let m = minors_beyond_i128();
        let mut wide: Vec<Vec<I256>> =
            m.iter().map(|r| r.iter().map(|&x| x.as_()).collect()).collect();
        let pivots = rref_fixed(&mut wide, 3).expect("the minors fit in 256 bits");
        let mut rats = to_rat(&m);
        assert_eq!(pivots, rref(&mut rats, 3));
        assert_eq!(rows_to_rat(&wide, &pivots, &w256(1)), rats);
        // Values beyond i128 convert exactly, with their sign.
        let x = w256(i128::MIN) * w256(1 << 90) + w256(3);
        let want = num_bigint::BigInt::from(i128::MIN) * (num_bigint::BigInt::from(1) << 90) + 3;
        assert_eq!(int_of_i256(x), Int::from_big(want));
        assert_eq!(int_of_i256(w256(-5)), Int::from(-5));
    }

    proptest! {
        /// Exact division by the inverse modulo 2^128 gives the quotient exactly when the
        /// division is exact and the quotient fits in i128 (signs, powers of two in the
        /// divisor and extremes included), and nothing otherwise.
        #[test]
        fn exact_quotients_equal_long_division(
            q in prop_oneof![any::<i128>(), -1000i128..1000, Just(i128::MIN), Just(i128::MAX)],
            d in prop_oneof![any::<i128>(), -1000i128..1000, Just(i128::MIN), Just(1i128 << 100)],
            shift in 0u32..130,
            off in prop_oneof![Just(0i128), -3i128..4],
        ) {
            prop_assume!(d != 0);
            let w = |v: i128| -> I256 { v.as_() };
            // Products beyond i128, shifted quotients and inexact divisions.
            let t = w(q) * w(d) + w(off);
            let qq = if shift < 128 { q >> shift } else { 0 };
            let t2 = w(qq) * w(d) + w(off);
            for t in [t, t2, w(q) << (shift % 120)] {
                let want = t.checked_div(w(d)).filter(|x| *x * w(d) == t).and_then(|x| i128::try_from(x).ok());
                prop_assert_eq!(exact_quotient(t, d), want);
            }
        }
    }

    #[test]
    fn inverses_modulo_2_128_invert() {
        for d in [1u128, 3, 5, 7, 255, u128::MAX, (1u128 << 127) + 1, 0x1234_5678_9abc_def1] {
            assert_eq!(d.wrapping_mul(inverse_mod_2_128(d)), 1, "{d}");
        }
    }

    #[test]
    fn fraction_free_rref_in_big_integers_takes_over_from_i128() {
        let m = minors_beyond_i128();
        let mut big: Vec<Vec<Int>> =
            m.iter().map(|r| r.iter().map(|&x| Int::from_i128(x)).collect()).collect();
        let pivots = rref_big(&mut big, 3).unwrap();
        let mut rats = to_rat(&m);
        assert_eq!(pivots, rref(&mut rats, 3));
        assert_eq!(rows_to_rat(&big, &pivots, &Int::from(1)), rats);
    }
}
