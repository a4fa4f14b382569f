//! Exact linear combinations of rationals on a common denominator, in `i128`.
//!
//! The C1 conditions and the determining-set formulas ([`super::mds`]) are sums
//! `sum_k c_k x_k` of a few rationals `x_k = n_k / d_k` with rational coefficients. Adding
//! them one by one as reduced fractions costs a gcd per addition. Here each sum is put over
//! one common denominator `L = lcm(d_k)` and evaluated as the integer `sum_k c_k n_k L / d_k`,
//! with one gcd at the end. The C1 check ([`comb_is_zero`]) runs in `i128` with every
//! operation checked, and on overflow in exact integers on the same common denominator; the
//! determining-set plan ([`IntPlan`]) uses exact integers of any size. Either way the
//! results are the same exact values as fraction arithmetic, only with far fewer gcds.

use crate::exact::{Int, IntView, Rat};
use num_integer::Integer;
use num_traits::ToPrimitive;
use rayon::prelude::*;

/// `i128` value of an exact integer, if it fits.
pub(crate) fn int_i128(x: &Int) -> Option<i128> {
    match x.view() {
        IntView::Small(v) => Some(v as i128),
        IntView::Big(b) => b.to_i128(),
    }
}

/// Greatest common divisor of `a` and `b` (`gcd(0, 0) = 0`): Stein's binary algorithm, as
/// `num_integer` implements it.
pub(crate) fn gcd_u128(a: u128, b: u128) -> u128 {
    num_integer::Integer::gcd(&a, &b)
}

/// Least common multiple of two positive integers, or `None` on overflow.
pub(crate) fn lcm_i128(a: i128, b: i128) -> Option<i128> {
    debug_assert!(a > 0 && b > 0);
    let g = gcd_u128(a as u128, b as u128) as i128;
    (a / g).checked_mul(b)
}

/// Whether `sum_k c_k x_k = 0` exactly, for integer coefficients: `Some(answer)` from the
/// `i128` path, `None` when a number does not fit.
pub(crate) fn int_comb_is_zero(terms: &[(i64, &Rat)]) -> Option<bool> {
    let mut l: i128 = 1;
    for (_, x) in terms {
        let d = int_i128(x.denom())?;
        l = lcm_i128(l, d)?;
    }
    let mut acc: i128 = 0;
    for (c, x) in terms {
        let n = int_i128(x.numer())?;
        let d = int_i128(x.denom())?;
        let t = (*c as i128).checked_mul(n)?.checked_mul(l / d)?;
        acc = acc.checked_add(t)?;
    }
    Some(acc == 0)
}

/// Whether `sum_k c_k x_k = 0` exactly, for rationals of any size: [`int_comb_is_zero`] in
/// `i128` when nothing overflows, else the same sum on one common denominator
/// `L = lcm(d_k)` in exact integers, `sum_k c_k n_k (L / d_k) = 0` (one gcd per distinct
/// denominator, none per addition; the sign of `L > 0` does not matter for a zero test).
pub(crate) fn comb_is_zero(terms: &[(i64, &Rat)]) -> bool {
    if let Some(z) = int_comb_is_zero(terms) {
        return z;
    }
    let Some((_, first)) = terms.first() else {
        return true;
    };
    let mut l = first.denom().clone();
    for (_, x) in &terms[1..] {
        let d = x.denom();
        if d != &l {
            let g = l.gcd_int(d);
            l = &l.div_exact(&g) * d;
        }
    }
    let mut acc = Int::from(0);
    for (c, x) in terms {
        if *c == 0 || x.numer().is_zero_int() {
            continue;
        }
        let t = &Int::from(*c) * x.numer();
        if x.denom() == &l {
            acc += &t;
        } else {
            acc += &(&t * &l.div_exact(x.denom()));
        }
    }
    acc.is_zero_int()
}

/// `sum_j m_j N_j` on machine words, or `None` when a term or a partial sum does not fit
/// in `i128` (most of a plan's sums do: one allocation per value instead of one per term).
fn dot_i128(row: &[(usize, Int)], num: &[Int]) -> Option<i128> {
    let mut acc: i128 = 0;
    for (j, m) in row {
        acc = acc.checked_add(int_i128(m)?.checked_mul(int_i128(&num[*j])?)?)?;
    }
    Some(acc)
}

/// `sum_j m_j N_j` in exact integers of any size.
fn dot_big(row: &[(usize, Int)], num: &[Int]) -> Int {
    let mut acc = Int::from(0);
    for (j, m) in row {
        acc += &(m * &num[*j]);
    }
    acc
}

/// A dependent's denominator `E_p = lcm_j (d_j E_j)` and multipliers
/// `m_j = n_j E_p / (d_j E_j)` (for `c_j = n_j / d_j`) on machine words: the values
/// [`IntPlan::new`] computes in exact integers, or `None` when one does not fit in `i128`.
fn dependent_i128(f: &[(usize, Rat)], den: &[Int]) -> Option<(Int, Vec<(usize, Int)>)> {
    let mut parts: Vec<(usize, i128, i128)> = Vec::with_capacity(f.len());
    let mut e: i128 = 1;
    for (j, c) in f {
        let t = int_i128(c.denom())?.checked_mul(int_i128(&den[*j])?)?;
        e = lcm_i128(e, t)?;
        parts.push((*j, int_i128(c.numer())?, t));
    }
    let mut row = Vec::with_capacity(parts.len());
    for (j, a, t) in parts {
        row.push((j, Int::from_i128(a.checked_mul(e / t)?)));
    }
    Some((Int::from_i128(e), row))
}

/// [`dependent_i128`] in exact integers of any size.
fn dependent_big(f: &[(usize, Rat)], den: &[Int]) -> (Int, Vec<(usize, Int)>) {
    let mut e = Int::from(1);
    let parts: Vec<(usize, &Int, Int)> =
        f.iter().map(|(j, c)| (*j, c.numer(), c.denom() * &den[*j])).collect();
    for (_, _, t) in &parts {
        e = e.lcm(t);
    }
    let row = parts.into_iter().map(|(j, a, t)| (j, a * &e.div_exact(&t))).collect();
    (e, row)
}

/// [`check_i128`] in exact integers of any size.
fn check_big(m: &[usize; 4], c: &[i64; 4], den: &[Int]) -> [(usize, Int); 4] {
    let mut l = Int::from(1);
    for &j in m {
        if den[j] != l {
            l = l.lcm(&den[j]);
        }
    }
    [0, 1, 2, 3].map(|k| (m[k], &Int::from(c[k]) * &l.div_exact(&den[m[k]])))
}

/// A condition's multipliers `c_k L / E_(m_k)`, `L = lcm_k E_(m_k)`, on machine words (as
/// [`IntPlan::new`] computes them in exact integers), or `None` when one does not fit in
/// `i128`.
fn check_i128(m: &[usize; 4], c: &[i64; 4], den: &[Int]) -> Option<[(usize, Int); 4]> {
    let mut l: i128 = 1;
    let mut d = [0i128; 4];
    for k in 0..4 {
        d[k] = int_i128(&den[m[k]])?;
        l = lcm_i128(l, d[k])?;
    }
    let mut out = [0i128; 4];
    for k in 0..4 {
        out[k] = i128::from(c[k]).checked_mul(l / d[k])?;
    }
    Some([0, 1, 2, 3].map(|k| (m[k], Int::from_i128(out[k]))))
}

/// The determining-set formulas on common denominators (see [`super::mds::Mds`]): each
/// point `p` gets a structural denominator `E_p` (1 for free points) and each dependent
/// `p = sum_j c_j x_j` the integer multipliers `m_j = c_j E_p / E_j`, so that with the free
/// values over one denominator `D` (`x_j = N_j / (D E_j)`) the numerators obey
/// `N_p = sum_j m_j N_j`: integer products and sums, and one gcd per value at the end
/// instead of one per operation.
#[derive(Clone, Debug)]
pub(crate) struct IntPlan {
    /// `E_p` per point.
    den: Vec<Int>,
    /// Per dependent, in evaluation order: the point and its `(j, m_j)`.
    terms: Vec<(usize, Vec<(usize, Int)>)>,
    /// Per C1 condition `sum_k c_k x_(m_k) = 0` (the spline's quads, in order): its members
    /// and the integer multipliers `c_k L / E_(m_k)`, `L = lcm_k E_(m_k)`, so that the
    /// condition holds iff `sum_k c_k (L / E_(m_k)) N_(m_k) = 0` on the numerators (the
    /// common factor `D L` dropped).
    checks: Vec<[(usize, Int); 4]>,
}

impl IntPlan {
    /// The plan for dependents `order` (each using only free points and earlier dependents)
    /// with formulas `formula(p)`, and the checks of the conditions `sum_k coef_k x_(m_k) = 0`
    /// given as `(members, coefficients)`.
    pub(crate) fn new<'a>(
        n: usize,
        order: &[usize],
        formula: impl Fn(usize) -> &'a [(usize, Rat)],
        conditions: &[([usize; 4], [i64; 4])],
    ) -> IntPlan {
        let mut den = vec![Int::from(1); n];
        let mut terms = Vec::with_capacity(order.len());
        for &p in order {
            let f = formula(p);
            let (e, row) = dependent_i128(f, &den).unwrap_or_else(|| dependent_big(f, &den));
            den[p] = e;
            terms.push((p, row));
        }
        let checks = conditions
            .par_iter()
            .map(|(m, c)| check_i128(m, c, &den).unwrap_or_else(|| check_big(m, c, &den)))
            .collect();
        IntPlan { den, terms, checks }
    }

    /// Recomputes every dependent from the current values of the free points (`values[p]`
    /// has one entry per coordinate), exactly: the same reduced fractions as evaluating the
    /// formulas in rational arithmetic.
    pub(crate) fn recompute(
        &self,
        values: &mut [Vec<Rat>],
        is_free: impl Fn(usize) -> bool + Sync,
    ) {
        let (dd, num) = self.numerators(values, is_free);
        self.reduce(values, &dd, &num);
    }

    /// [`recompute`](Self::recompute), then every condition given to [`new`](Self::new)
    /// checked exactly on the numerators (before the reduction): `Err(i)` names the first
    /// condition that fails, and `values` is then left as it was.
    pub(crate) fn recompute_verified(
        &self,
        values: &mut [Vec<Rat>],
        is_free: impl Fn(usize) -> bool + Sync,
    ) -> Result<(), usize> {
        let (dd, num) = self.numerators(values, is_free);
        let bad = self.checks.par_iter().position_first(|row| {
            num.iter().any(|num| match dot_i128(row, num) {
                Some(acc) => acc != 0,
                None => !dot_big(row, num).is_zero_int(),
            })
        });
        if let Some(i) = bad {
            return Err(i);
        }
        self.reduce(values, &dd, &num);
        Ok(())
    }

    /// The common denominator `D` of the free values and every point's numerator `N_p`
    /// per coordinate (`x_p = N_p / (D E_p)`).
    fn numerators(
        &self,
        values: &[Vec<Rat>],
        is_free: impl Fn(usize) -> bool + Sync,
    ) -> (Int, Vec<Vec<Int>>) {
        let n = values.len();
        let dim = values.first().map_or(0, |v| v.len());
        // D: the lcm of the free values' denominators.
        let mut dd = Int::from(1);
        for (p, v) in values.iter().enumerate() {
            if is_free(p) {
                for x in v {
                    if x.denom() != &dd {
                        dd = dd.lcm(x.denom());
                    }
                }
            }
        }
        // The coordinates are independent: one numerator sweep per coordinate, in parallel
        // (the sweep itself follows the evaluation order).
        let num: Vec<Vec<Int>> = (0..dim)
            .into_par_iter()
            .map(|a| {
                let mut num = vec![Int::from(0); n];
                for (p, v) in values.iter().enumerate() {
                    if is_free(p) {
                        num[p] = v[a].numer() * &dd.div_exact(v[a].denom());
                    }
                }
                for (p, row) in &self.terms {
                    num[*p] = match dot_i128(row, &num) {
                        Some(acc) => Int::from_i128(acc),
                        None => dot_big(row, &num),
                    };
                }
                num
            })
            .collect();
        (dd, num)
    }

    /// Writes the dependents' values `N_p / (D E_p)` in lowest terms.
    fn reduce(&self, values: &mut [Vec<Rat>], dd: &Int, num: &[Vec<Int>]) {
        // The reductions (one gcd per value) are independent: in parallel.
        let reduced: Vec<Vec<Rat>> = self
            .terms
            .par_iter()
            .map(|(p, _)| {
                let d = dd * &self.den[*p];
                num.iter().map(|num| Rat::new(num[*p].clone(), d.clone())).collect()
            })
            .collect();
        for ((p, _), v) in self.terms.iter().zip(reduced) {
            values[*p] = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_traits::Zero;
    use proptest::prelude::*;

    fn r(n: i64, d: i64) -> Rat {
        Rat::new(Int::from(n), Int::from(d))
    }

    proptest! {
        /// Sums on machine words equal the exact ones, or give up only when a value does not
        /// fit.
        #[test]
        fn word_sums_equal_exact_sums(
            terms in proptest::collection::vec(
                (0usize..6, prop_oneof![-(1i64 << 20)..(1 << 20), any::<i64>()]),
                0..8,
            ),
            num in proptest::collection::vec(prop_oneof![-(1i64 << 30)..(1 << 30), any::<i64>()], 6),
            wide in proptest::option::of(0usize..6),
        ) {
            let mut num: Vec<Int> = num.iter().map(|&x| Int::from(x)).collect();
            if let Some(j) = wide {
                num[j] = &num[j] * &Int::from_i128(1i128 << 100);
            }
            let row: Vec<(usize, Int)> = terms.iter().map(|&(j, m)| (j, Int::from(m))).collect();
            let exact = dot_big(&row, &num);
            match dot_i128(&row, &num) {
                Some(v) => prop_assert_eq!(Int::from_i128(v), exact),
                None => {
                    // Some term or partial sum is beyond i128.
                    let mut acc = Int::from(0);
                    let mut beyond = false;
                    for (j, m) in &row {
                        let t = m * &num[*j];
                        acc += &t;
                        beyond |= int_i128(&t).is_none() || int_i128(&acc).is_none();
                    }
                    prop_assert!(beyond, "gave up on sums that fit");
                }
            }
        }

        /// The machine-word plan steps give exactly the exact-integer ones, or give up.
        #[test]
        fn word_plan_steps_equal_exact_integer_ones(
            coefs in proptest::collection::vec((-(1i64 << 40)..(1 << 40), 1i64..(1 << 40)), 1..8),
            dens in proptest::collection::vec(prop_oneof![1i64..1000, 1i64..(1 << 62)], 8),
            c in proptest::array::uniform4(-(1i64 << 30)..(1 << 30)),
        ) {
            let den: Vec<Int> = dens.iter().map(|&d| Int::from(d)).collect();
            let f: Vec<(usize, Rat)> =
                coefs.iter().enumerate().map(|(j, &(n, d))| (j, r(n, d))).collect();
            if let Some(got) = dependent_i128(&f, &den) {
                prop_assert_eq!(got, dependent_big(&f, &den));
            }
            let m = [0, 3, 5, 7];
            if let Some(got) = check_i128(&m, &c, &den) {
                prop_assert_eq!(got, check_big(&m, &c, &den));
            }
            // Small values always stay on the words.
            let small: Vec<Int> = dens.iter().map(|&d| Int::from(d % 1000 + 1)).collect();
            prop_assert!(check_i128(&m, &c, &small).is_some());
        }
    }

    #[test]
    fn gcd_and_lcm_agree_with_the_definitions() {
        assert_eq!(gcd_u128(0, 0), 0);
        assert_eq!(gcd_u128(0, 12), 12);
        assert_eq!(gcd_u128(48, 18), 6);
        assert_eq!(lcm_i128(4, 6), Some(12));
        assert_eq!(lcm_i128(i128::MAX, 2), None);
    }

    #[test]
    fn a_nonzero_sum_is_reported_nonzero() {
        let t = [(3i64, r(1, 6)), (-2, r(5, 4)), (1, r(7, 3))];
        let want = t.iter().fold(Rat::zero(), |a, (c, x)| a + Rat::from_integer(Int::from(*c)) * x);
        // 3/6 - 10/4 + 7/3 = (6 - 30 + 28) / 12 = 1/3: not zero.
        assert_eq!(want, r(1, 3));
        let refs: Vec<(i64, &Rat)> = t.iter().map(|(c, x)| (*c, x)).collect();
        assert_eq!(int_comb_is_zero(&refs), Some(false));
    }

    #[test]
    fn overflow_is_reported_not_wrapped() {
        let big = Rat::new(Int::from_i128(1i128 << 100), Int::from(3));
        assert!(int_comb_is_zero(&[(i64::MAX, &big), (i64::MAX, &big)]).is_none());
        assert!(int_comb_is_zero(&[(i64::MAX, &Rat::new(Int::from_i128(1 << 120), Int::from(1)))])
            .is_none());
    }

    #[test]
    fn sums_too_large_for_i128_are_decided_exactly() {
        // x = 2^100 / 3, y = 2^101 / 9 (reduced): 2 x - 3 y = 2^101/3 - 2^101/3 = 0, but the
        // i128 path overflows on i64::MAX-sized coefficients.
        let x = Rat::new(Int::from_i128(1i128 << 100), Int::from(3));
        let y = Rat::new(Int::from_i128(1i128 << 101), Int::from(9));
        assert!(comb_is_zero(&[(2, &x), (-3, &y)]));
        assert!(!comb_is_zero(&[(2, &x), (-3, &y), (1, &r(1, 7))]));
        let huge = Rat::new(Int::from_i128(i128::MAX), Int::from(5))
            * Rat::from_integer(Int::from(1i64 << 40));
        assert!(int_comb_is_zero(&[(i64::MAX, &huge), (-i64::MAX, &huge)]).is_none());
        assert!(comb_is_zero(&[(i64::MAX, &huge), (-i64::MAX, &huge)]));
        assert!(!comb_is_zero(&[(i64::MAX, &huge), (-i64::MAX + 1, &huge)]));
        assert!(comb_is_zero(&[]));
    }

    /// A plan for `x2 = x0 / 2 + x1 / 3` (points 0, 1 free) with the condition
    /// `6 x2 - 3 x0 - 2 x1 + 0 x0 = 0`, which the formula satisfies, and one it does not.
    fn plan_with(condition: [i64; 4]) -> IntPlan {
        let formula = [(0usize, r(1, 2)), (1usize, r(1, 3))];
        IntPlan::new(
            3,
            &[2],
            |p| if p == 2 { &formula[..] } else { &[] },
            &[([2, 0, 1, 0], [6, -3, -2, 0]), ([2, 0, 1, 0], condition)],
        )
    }

    #[test]
    fn verified_recompute_checks_every_condition_on_the_numerators() {
        let start =
            || vec![vec![r(5, 7), r(-1, 4)], vec![r(3, 11), r(9, 2)], vec![r(0, 1), r(0, 1)]];
        // Both conditions hold: the same values as the plain recompute.
        let good = plan_with([12, -6, -4, 0]);
        let (mut a, mut b) = (start(), start());
        good.recompute(&mut a, |p| p < 2);
        assert_eq!(good.recompute_verified(&mut b, |p| p < 2), Ok(()));
        assert_eq!(a, b);
        assert_eq!(a[2][0], r(5, 14) + r(1, 11));
        // A condition the formulas do not satisfy (a wrong coefficient, injected): reported
        // by its index, and the values are left untouched.
        let bad = plan_with([6, -3, -1, -1]);
        let mut c = start();
        assert_eq!(bad.recompute_verified(&mut c, |p| p < 2), Err(1));
        assert_eq!(c, start());
    }

    proptest! {
        /// Sums of big rationals (numerators and denominators up to about 2^190, so the
        /// `i128` path overflows): the common-denominator test agrees with fraction sums.
        #[test]
        fn big_sums_equal_rational_sums(
            t in proptest::collection::vec((-50i64..50, any::<i64>(), 1i64..500, 0u32..3), 1..6),
            zero in any::<bool>(),
        ) {
            let scale = Rat::new(Int::from_i128(i128::MAX), Int::from(1))
                * Rat::new(Int::from(1i64 << 62), Int::from_i128((1i128 << 100) + 1));
            let mut terms: Vec<(i64, Rat)> = t
                .iter()
                .map(|&(c, n, d, p)| {
                    let mut x = Rat::new(Int::from(n), Int::from(d));
                    for _ in 0..p {
                        x = &x * &scale;
                    }
                    (c, x)
                })
                .collect();
            if zero {
                // Append the negated sum as a last term with coefficient 1: the total is 0.
                let s = terms.iter().fold(Rat::zero(), |a, (c, x)| a + Rat::from_integer(Int::from(*c)) * x);
                terms.push((-1, s));
            }
            let want = terms.iter().fold(Rat::zero(), |a, (c, x)| a + Rat::from_integer(Int::from(*c)) * x);
            let refs: Vec<(i64, &Rat)> = terms.iter().map(|(c, x)| (*c, x)).collect();
            prop_assert_eq!(comb_is_zero(&refs), want.is_zero());
        }

        #[test]
        fn integer_sums_equal_rational_sums(
            t in proptest::collection::vec((-50i64..50, -1000i64..1000, 1i64..500), 0..6)
        ) {
            let terms: Vec<(i64, Rat)> = t.iter().map(|&(c, n, d)| (c, r(n, d))).collect();
            let want = terms.iter().fold(Rat::zero(), |a, (c, x)| a + Rat::from_integer(Int::from(*c)) * x);
            let refs: Vec<(i64, &Rat)> = terms.iter().map(|(c, x)| (*c, x)).collect();
            prop_assert_eq!(int_comb_is_zero(&refs).unwrap(), want.is_zero());
        }
    }
}
