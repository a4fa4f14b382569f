//! Exact linear combinations of rationals on a common denominator, in `i128`.
//!
//! The C1 conditions and the determining-set formulas ([`super::mds`]) are sums
//! `sum_k c_k x_k` of a few rationals `x_k = n_k / d_k` with rational coefficients. Adding
//! them one by one as reduced fractions costs a gcd per addition. Here each sum is put over
//! one common denominator `L = lcm(d_k)` and evaluated as the integer `sum_k c_k n_k L / d_k`,
//! with one gcd at the end. The C1 check ([`comb_is_zero`]) runs in `i128` with every
//! operation checked, and on overflow in exact integers on the same common denominator; the
//! determining-set plan ([`IntPlan`]) does the same value by value: each numerator, sum and
//! reduction on `i128` while it fits, in exact integers of any size where it does not.
//! Either way the results are the same exact values as fraction arithmetic, only with far
//! fewer gcds and allocations.

use crate::exact::{rat_from_i128, Int, IntView, Rat};
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

/// One coordinate's numerators `N_p` (see [`IntPlan`]): `word[p]` while the value fits in
/// `i128`, `wide[p]` otherwise (most values fit: one allocation per wide value only).
struct Numerators {
    word: Vec<i128>,
    wide: Vec<Option<Int>>,
}

impl Numerators {
    fn zeros(n: usize) -> Numerators {
        Numerators { word: vec![0; n], wide: vec![None; n] }
    }

    /// `N_p` as an exact integer.
    fn get(&self, p: usize) -> Int {
        match &self.wide[p] {
            Some(v) => v.clone(),
            None => Int::from_i128(self.word[p]),
        }
    }

    fn set(&mut self, p: usize, v: Int) {
        match int_i128(&v) {
            Some(x) => self.word[p] = x,
            None => self.wide[p] = Some(v),
        }
    }

    /// `N_p` on a machine word, if it fits.
    fn word(&self, p: usize) -> Option<i128> {
        self.wide[p].is_none().then(|| self.word[p])
    }
}

/// `sum_j m_j N_j` on machine words, or `None` when a value, a term or a partial sum does
/// not fit in `i128`.
fn word_dot(row: &[(usize, i128)], num: &Numerators) -> Option<i128> {
    let mut acc: i128 = 0;
    for &(j, m) in row {
        acc = acc.checked_add(m.checked_mul(num.word(j)?)?)?;
    }
    Some(acc)
}

/// `sum_j m_j N_j` in exact integers of any size.
fn exact_dot(row: &[(usize, Int)], num: &Numerators) -> Int {
    let mut acc = Int::from(0);
    for (j, m) in row {
        acc += &(m * &num.get(*j));
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
    /// The same values as `i128` where they fit (the common case): the numerator sweep and
    /// the checks then run on machine words while their sums fit.
    words: WordPlan,
}

/// [`IntPlan`]'s denominators and multipliers as `i128`, where they fit.
#[derive(Clone, Debug)]
struct WordPlan {
    /// `E_p` per point.
    den: Vec<Option<i128>>,
    /// Per dependent (in the order of [`IntPlan::terms`]): its `(j, m_j)` in `mult`, when
    /// every `m_j` fits.
    rows: Vec<Option<std::ops::Range<usize>>>,
    mult: Vec<(usize, i128)>,
    /// The check multipliers, per condition.
    checks: Vec<Option<[(usize, i128); 4]>>,
}

impl WordPlan {
    fn of(den: &[Int], terms: &[(usize, Vec<(usize, Int)>)], checks: &[[(usize, Int); 4]]) -> Self {
        let mut mult = Vec::new();
        let rows = terms
            .iter()
            .map(|(_, row)| {
                let start = mult.len();
                for (j, m) in row {
                    match int_i128(m) {
                        Some(m) => mult.push((*j, m)),
                        None => {
                            mult.truncate(start);
                            return None;
                        }
                    }
                }
                Some(start..mult.len())
            })
            .collect();
        let checks = checks
            .iter()
            .map(|row| {
                let w = row.each_ref().map(|(j, m)| int_i128(m).map(|m| (*j, m)));
                Some([w[0]?, w[1]?, w[2]?, w[3]?])
            })
            .collect();
        WordPlan { den: den.iter().map(int_i128).collect(), rows, mult, checks }
    }
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
        let checks: Vec<_> = conditions
            .par_iter()
            .map(|(m, c)| check_i128(m, c, &den).unwrap_or_else(|| check_big(m, c, &den)))
            .collect();
        let words = WordPlan::of(&den, &terms, &checks);
        IntPlan { den, terms, checks, words }
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
        let bad = (0..self.checks.len())
            .into_par_iter()
            .position_first(|i| num.iter().any(|num| !self.condition_holds(i, num)));
        if let Some(i) = bad {
            return Err(i);
        }
        self.reduce(values, &dd, &num);
        Ok(())
    }

    /// Whether condition `i` holds on one coordinate's numerators, exactly.
    fn condition_holds(&self, i: usize, num: &Numerators) -> bool {
        match self.words.checks[i].as_ref().and_then(|row| word_dot(row, num)) {
            Some(acc) => acc == 0,
            None => exact_dot(&self.checks[i], num).is_zero_int(),
        }
    }

    /// The common denominator `D` of the free values and every point's numerator `N_p`
    /// per coordinate (`x_p = N_p / (D E_p)`).
    fn numerators(
        &self,
        values: &[Vec<Rat>],
        is_free: impl Fn(usize) -> bool + Sync,
    ) -> (Int, Vec<Numerators>) {
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
        let dd_word = int_i128(&dd);
        // The coordinates are independent: one numerator sweep per coordinate, in parallel
        // (the sweep itself follows the evaluation order); each sum on machine words when
        // it fits, in exact integers otherwise.
        let num: Vec<Numerators> = (0..dim)
            .into_par_iter()
            .map(|a| {
                let mut num = Numerators::zeros(n);
                for (p, v) in values.iter().enumerate() {
                    if is_free(p) {
                        let x = &v[a];
                        let word =
                            (|| int_i128(x.numer())?.checked_mul(dd_word? / int_i128(x.denom())?))(
                            );
                        match word {
                            Some(w) => num.word[p] = w,
                            None => num.set(p, x.numer() * &dd.div_exact(x.denom())),
                        }
                    }
                }
                for ((p, row), range) in self.terms.iter().zip(&self.words.rows) {
                    let word = range.clone().and_then(|r| word_dot(&self.words.mult[r], &num));
                    match word {
                        Some(w) => num.word[*p] = w,
                        None => {
                            let v = exact_dot(row, &num);
                            num.set(*p, v);
                        }
                    }
                }
                num
            })
            .collect();
        (dd, num)
    }

    /// Writes the dependents' values `N_p / (D E_p)` in lowest terms.
    fn reduce(&self, values: &mut [Vec<Rat>], dd: &Int, num: &[Numerators]) {
        let dd_word = int_i128(dd);
        // The reductions (one gcd per value, on machine words where the numerator and
        // `D E_p` fit) are independent: in parallel.
        let reduced: Vec<Vec<Rat>> = self
            .terms
            .par_iter()
            .map(|&(p, _)| {
                let d_word = dd_word.zip(self.words.den[p]).and_then(|(a, b)| a.checked_mul(b));
                num.iter()
                    .map(|num| match (num.word(p), d_word) {
                        (Some(x), Some(d)) => rat_from_i128(x, d),
                        _ => Rat::new(num.get(p), dd * &self.den[p]),
                    })
                    .collect()
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
        /// fit (a wide numerator, a term or a partial sum beyond `i128`).
        #[test]
        fn word_sums_equal_exact_sums(
            terms in proptest::collection::vec(
                (0usize..6, prop_oneof![-(1i64 << 20)..(1 << 20), any::<i64>()]),
                0..8,
            ),
            num in proptest::collection::vec(prop_oneof![-(1i64 << 30)..(1 << 30), any::<i64>()], 6),
            wide in proptest::option::of((0usize..6, 40u32..100)),
        ) {
            let mut vals = Numerators::zeros(6);
            for (p, &x) in num.iter().enumerate() {
                let mut v = Int::from(x);
                if let Some((j, bits)) = wide {
                    if j == p {
                        v = &v * &Int::from_i128(1i128 << bits);
                    }
                }
                vals.set(p, v);
            }
            let row: Vec<(usize, Int)> = terms.iter().map(|&(j, m)| (j, Int::from(m))).collect();
            let words: Vec<(usize, i128)> = terms.iter().map(|&(j, m)| (j, i128::from(m))).collect();
            let exact = exact_dot(&row, &vals);
            match word_dot(&words, &vals) {
                Some(v) => prop_assert_eq!(Int::from_i128(v), exact),
                None => {
                    let mut acc = Int::from(0);
                    let mut beyond = false;
                    for (j, m) in &row {
                        let t = m * &vals.get(*j);
                        acc += &t;
                        beyond |= vals.word(*j).is_none()
                            || int_i128(&t).is_none()
                            || int_i128(&acc).is_none();
                    }
                    prop_assert!(beyond, "gave up on sums that fit");
                }
            }
        }

        /// A plan whose formulas mix multipliers on words and beyond `i128` (so the sweep
        /// switches between machine words and exact integers point by point) gives the
        /// values of rational arithmetic, and its checks decide exactly.
        #[test]
        fn mixed_width_plans_equal_rational_evaluation(
            coefs in proptest::collection::vec(
                proptest::collection::vec((-(1i64 << 40)..(1 << 40), 1i64..(1 << 40), 0u32..3), 1..4),
                1..6,
            ),
            free in proptest::collection::vec((any::<i64>(), 0u32..40), 3),
        ) {
            // Points 0..3 free, then one dependent per formula, each using the points
            // before it; a power `p` scales a coefficient by 2^(60 p) / 3^p.
            let big = Rat::new(Int::from_i128(1i128 << 60), Int::from(3));
            let formulas: Vec<Vec<(usize, Rat)>> = coefs
                .iter()
                .enumerate()
                .map(|(k, f)| {
                    f.iter()
                        .enumerate()
                        .map(|(i, &(n, d, p))| {
                            let mut c = r(n, d);
                            for _ in 0..p {
                                c = &c * &big;
                            }
                            ((i * 7 + k) % (3 + k), c)
                        })
                        .collect()
                })
                .collect();
            let n = 3 + formulas.len();
            let order: Vec<usize> = (3..n).collect();
            // One condition per dependent that holds (x_p - sum c_j x_j = 0 is not a
            // 4-member integer condition in general, so use x_p - x_p = 0 and one that fails
            // unless x_p = 0).
            let conditions: Vec<([usize; 4], [i64; 4])> =
                (3..n).map(|p| ([p, p, 0, 0], [1, -1, 0, 0])).collect();
            let plan = IntPlan::new(n, &order, |p| &formulas[p - 3][..], &conditions);
            let mut values: Vec<Vec<Rat>> = free
                .iter()
                .map(|&(x, b)| vec![Rat::new(Int::from(x), Int::from_i128(1i128 << b))])
                .chain((3..n).map(|_| vec![Rat::zero()]))
                .collect();
            let mut want = values.clone();
            for p in 3..n {
                let v = formulas[p - 3].iter().fold(Rat::zero(), |a, (j, c)| a + c * &want[*j][0]);
                want[p][0] = v;
            }
            prop_assert_eq!(plan.recompute_verified(&mut values, |p| p < 3), Ok(()));
            prop_assert_eq!(&values, &want);
            // A condition that fails on a nonzero value is reported.
            if let Some(p) = (3..n).find(|&p| !want[p][0].is_zero()) {
                let bad = IntPlan::new(n, &order, |q| &formulas[q - 3][..], &[([p, 0, 0, 0], [1, 0, 0, 0])]);
                let mut v = want.clone();
                v[p][0] = Rat::zero();
                prop_assert_eq!(bad.recompute_verified(&mut v, |q| q < 3), Err(0));
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
