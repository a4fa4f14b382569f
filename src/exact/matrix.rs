//! Integer matrices (dense and sparse) and exact rationals.
//!
//! [`IntMatrix`] is a dense row-major integer matrix; [`SparseIntMatrix`] stores each row as
//! a list of `(column, value)` pairs sorted by column with no explicit zeros. Both use
//! [`Int`] entries. [`Rat`] is `Ratio<Int>`, the exact rational used for right-hand sides,
//! parameter values and solutions; it converts losslessly to and from `num_rational`'s
//! `BigRational`, the type of the public API boundary.

use super::int::Int;
use num_bigint::BigInt;
use num_rational::{BigRational, Ratio};
use num_traits::{One, Signed, ToPrimitive, Zero};
use std::fmt;

/// Exact rational with the small-integer fast path of [`Int`].
pub type Rat = Ratio<Int>;

/// Converts a `BigRational` into a [`Rat`].
pub fn rat_from_big(r: &BigRational) -> Rat {
    Rat::new_raw(Int::from_big(r.numer().clone()), Int::from_big(r.denom().clone()))
}

/// Converts a [`Rat`] into a `BigRational` (already in lowest terms).
pub fn rat_to_big(r: &Rat) -> BigRational {
    BigRational::new_raw(r.numer().to_big(), r.denom().to_big())
}

/// `n / d` in lowest terms with a positive denominator, reduced on machine words: the same
/// value as `Rat::new(n.into(), d.into())` without a `BigInt` gcd for values beyond `i64`.
///
/// # Panics
/// Panics if `d` is zero.
///
/// ```
/// use trimorph::exact::{rat_from_i128, Int, Rat};
/// let r = rat_from_i128(-(1i128 << 100), -(3i128 << 98));
/// assert_eq!(r, Rat::new(Int::from(4), Int::from(3)));
/// ```
pub fn rat_from_i128(n: i128, d: i128) -> Rat {
    assert!(d != 0, "rational with a zero denominator");
    let g = num_integer::Integer::gcd(&n.unsigned_abs(), &d.unsigned_abs());
    let (p, q) = (n.unsigned_abs() / g, d.unsigned_abs() / g);
    // Both are below 2^127 unless g = 1 and a value is i128::MIN: then the general path.
    match (i128::try_from(p), i128::try_from(q)) {
        (Ok(p), Ok(q)) => {
            let p = if (n < 0) != (d < 0) { -p } else { p };
            Rat::new_raw(Int::from_i128(p), Int::from_i128(q))
        }
        _ => Rat::new(Int::from_i128(n), Int::from_i128(d)),
    }
}

/// A [`Rat`] from an integer.
pub fn rat_int(v: i64) -> Rat {
    Rat::from_integer(Int::from(v))
}

/// Nearest `f64` of an exact rational (exact when both parts fit in 53 bits).
pub fn rat_to_f64(r: &Rat) -> f64 {
    match (r.numer().as_i64(), r.denom().as_i64()) {
        (Some(n), Some(d))
            if n.unsigned_abs() < (1u64 << 53) && d.unsigned_abs() < (1u64 << 53) =>
        {
            n as f64 / d as f64
        }
        _ => rat_to_big(r).to_f64().unwrap_or(f64::NAN),
    }
}

/// Exact rational value of a finite `f64` (every finite double is a dyadic rational).
pub fn rat_from_f64(v: f64) -> Option<Rat> {
    BigRational::from_float(v).map(|b| rat_from_big(&b))
}

/// Formats a rational as `"p"` or `"p/q"` in lowest terms (the deformation-file convention).
/// Accepts unreduced values (see [`ScaledVec::to_rats_raw`]).
pub fn rat_to_string(r: &Rat) -> String {
    let reduced;
    let r = if r.denom().is_one() {
        r
    } else {
        reduced = r.reduced();
        &reduced
    };
    if r.denom().is_one() {
        r.numer().to_string()
    } else {
        format!("{}/{}", r.numer(), r.denom())
    }
}

/// Largest decimal exponent [`parse_rat`] accepts: `1e10000` is a 33,000-bit integer, and
/// every larger exponent would make the exact arithmetic crawl.
pub const MAX_DECIMAL_EXPONENT: i64 = 10_000;

/// Error from [`parse_rat`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ParseRatError {
    /// Not an integer, decimal or fraction.
    #[error("`{0}` is not an exact number (expected an integer, a decimal like 1.25e-3, or p/q)")]
    Syntax(String),
    /// A decimal exponent beyond [`MAX_DECIMAL_EXPONENT`].
    #[error(
        "`{0}`: the exponent is beyond +-{max}; write the number at a smaller scale",
        max = MAX_DECIMAL_EXPONENT
    )]
    Exponent(String),
}

/// Parses an exact rational from `"p"`, `"p/q"` or a decimal such as `"-1.25e-3"`.
///
/// Decimals are read exactly (`"0.1"` is 1/10, not the nearest double).
pub fn parse_rat(text: &str) -> Result<Rat, ParseRatError> {
    let err = || ParseRatError::Syntax(text.to_string());
    let t = text.trim();
    if t.is_empty() {
        return Err(err());
    }
    if let Some((p, q)) = t.split_once('/') {
        // Fast path: both parts fit in i64 (deformation files: dyadic fractions), reduced
        // with a machine-word gcd; the same value in lowest terms as the general path.
        if let (Ok(p), Ok(q)) = (p.trim().parse::<i64>(), q.trim().parse::<i64>()) {
            if q == 0 {
                return Err(err());
            }
            return Ok(rat_from_i128(p.into(), q.into()));
        }
        let p: BigInt = p.trim().parse().map_err(|_| err())?;
        let q: BigInt = q.trim().parse().map_err(|_| err())?;
        if q.is_zero() {
            return Err(err());
        }
        // Dyadic fast path (the deformation files' exact points): `q = ±2^k` is reduced by
        // shifting out the common factors of two, without a `BigInt` gcd.
        if let Some(k) = q.trailing_zeros().filter(|&k| q.magnitude().bits() == k + 1) {
            let shift = p.trailing_zeros().map_or(k, |t| t.min(k));
            let (p, q) = (&p >> shift, &q >> shift);
            let (p, q) = if q.is_negative() { (-p, -q) } else { (p, q) };
            return Ok(Rat::new_raw(Int::from_big(p), Int::from_big(q)));
        }
        return Ok(rat_from_big(&BigRational::new(p, q)));
    }
    let (mant, exp) = match t.find(['e', 'E']) {
        Some(i) => {
            let e = &t[i + 1..];
            let digits = e.strip_prefix(['-', '+']).unwrap_or(e);
            if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                return Err(err());
            }
            // Any run of digits too long for i64 is beyond the limit too.
            let exp = e.parse::<i64>().unwrap_or(i64::MAX);
            (&t[..i], exp)
        }
        None => (t, 0),
    };
    let (neg, mant) = match mant.strip_prefix('-') {
        Some(m) => (true, m),
        None => (false, mant.strip_prefix('+').unwrap_or(mant)),
    };
    let (ip, fp) = mant.split_once('.').unwrap_or((mant, ""));
    if ip.is_empty() && fp.is_empty() {
        return Err(err());
    }
    if !ip.bytes().chain(fp.bytes()).all(|b| b.is_ascii_digit()) {
        return Err(err());
    }
    if exp.saturating_abs() > MAX_DECIMAL_EXPONENT {
        return Err(ParseRatError::Exponent(text.to_string()));
    }
    let scale = exp - fp.len() as i64;
    // Fast path: at most 18 digits and a power of ten below 10^19 (every coordinate and
    // coefficient a problem file usually holds), reduced with a machine-word gcd; the same
    // value in lowest terms as the general path below.
    if ip.len() + fp.len() <= 18 && scale.abs() <= 18 {
        let m = ip.bytes().chain(fp.bytes()).fold(0u64, |m, b| m * 10 + u64::from(b - b'0'));
        let (m, p) = (m as i128, 10i128.pow(scale.unsigned_abs() as u32));
        let m = if neg { -m } else { m };
        return Ok(if scale >= 0 { rat_from_i128(m * p, 1) } else { rat_from_i128(m, p) });
    }
    let digits: BigInt = format!("0{ip}{fp}").parse().map_err(|_| err())?;
    let ten = BigInt::from(10);
    let v = if scale >= 0 {
        BigRational::from_integer(digits * num_traits::pow(ten, scale as usize))
    } else {
        BigRational::new(digits, num_traits::pow(ten, (-scale) as usize))
    };
    Ok(rat_from_big(&if neg { -v } else { v }))
}

/// The exact value of the decimal text that `v` was read from: the shortest decimal that
/// reads back to `v` (Rust's `{}` formatting of `f64`), parsed exactly.
///
/// Every decimal text with at most 15 significant digits (and an exponent within the
/// `f64` range) *is* that shortest decimal, so `exact_decimal("0.1".parse()?)` is `1/10`,
/// not the dyadic rational [`rat_from_f64`] gives. Texts with more digits than an `f64`
/// holds come back as the shortest round-trip decimal, which differs from the text (the
/// landmark readers report such fields, `crate::fit::landmarks::Approximation`).
/// `None` for a non-finite `v`.
pub fn exact_decimal(v: f64) -> Option<Rat> {
    if !v.is_finite() {
        return None;
    }
    // `{}` never writes an exponent: large and tiny values come out in full digits.
    parse_rat(&format!("{v}")).ok()
}

/// A dense row-major matrix of exact integers.
#[derive(Clone, PartialEq, Eq)]
pub struct IntMatrix {
    rows: usize,
    cols: usize,
    data: Vec<Int>,
}

impl IntMatrix {
    /// The `rows x cols` zero matrix.
    pub fn zeros(rows: usize, cols: usize) -> IntMatrix {
        IntMatrix { rows, cols, data: vec![Int::zero(); rows * cols] }
    }

    /// Builds a matrix from rows of `i64`; all rows must have `cols` entries.
    ///
    /// # Panics
    /// Panics when a row has the wrong length.
    pub fn from_i64_rows(cols: usize, rows: &[Vec<i64>]) -> IntMatrix {
        let mut m = IntMatrix::zeros(rows.len(), cols);
        for (i, r) in rows.iter().enumerate() {
            assert_eq!(r.len(), cols, "row {i} has {} entries, expected {cols}", r.len());
            for (j, v) in r.iter().enumerate() {
                m.set(i, j, Int::from(*v));
            }
        }
        m
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }
    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }
    /// Entry `(i, j)`.
    pub fn get(&self, i: usize, j: usize) -> &Int {
        &self.data[i * self.cols + j]
    }
    /// Sets entry `(i, j)`.
    pub fn set(&mut self, i: usize, j: usize, v: Int) {
        self.data[i * self.cols + j] = v;
    }
    /// Row `i` as a slice.
    pub fn row(&self, i: usize) -> &[Int] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// The sparse form of this matrix.
    pub fn to_sparse(&self) -> SparseIntMatrix {
        let rows = (0..self.rows)
            .map(|i| {
                self.row(i)
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| !v.is_zero())
                    .map(|(j, v)| (j, v.clone()))
                    .collect()
            })
            .collect();
        SparseIntMatrix { rows: self.rows, cols: self.cols, row_entries: rows }
    }

    /// Largest bit size among the entries.
    pub fn max_bits(&self) -> u64 {
        self.data.iter().map(Int::bits).max().unwrap_or(0)
    }
}

impl fmt::Debug for IntMatrix {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "IntMatrix {}x{} [", self.rows, self.cols)?;
        for i in 0..self.rows {
            writeln!(f, "  {:?}", self.row(i))?;
        }
        write!(f, "]")
    }
}

/// A sparse integer matrix stored by rows: each row is a list of `(column, value)` pairs,
/// sorted by column, with no zero values.
#[derive(Clone, PartialEq, Eq, Debug)]
pub struct SparseIntMatrix {
    rows: usize,
    cols: usize,
    row_entries: Vec<Vec<(usize, Int)>>,
}

/// Error building a sparse matrix from entries.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SparseBuildError {
    /// A column index is outside `0..cols`.
    #[error("row {row}: column {col} is outside 0..{cols}")]
    ColumnOutOfRange {
        /// Row of the bad entry.
        row: usize,
        /// The column index given.
        col: usize,
        /// Number of columns.
        cols: usize,
    },
}

impl SparseIntMatrix {
    /// An empty (all-zero) `rows x cols` matrix.
    pub fn zeros(rows: usize, cols: usize) -> SparseIntMatrix {
        SparseIntMatrix { rows, cols, row_entries: vec![Vec::new(); rows] }
    }

    /// Builds a matrix from per-row entry lists in any order; duplicates are summed and
    /// zeros dropped.
    pub fn from_rows(
        cols: usize,
        rows: Vec<Vec<(usize, Int)>>,
    ) -> Result<SparseIntMatrix, SparseBuildError> {
        let mut out = Vec::with_capacity(rows.len());
        for (i, mut r) in rows.into_iter().enumerate() {
            if let Some(&(col, _)) = r.iter().find(|(c, _)| *c >= cols) {
                return Err(SparseBuildError::ColumnOutOfRange { row: i, col, cols });
            }
            r.sort_by_key(|(c, _)| *c);
            let mut merged: Vec<(usize, Int)> = Vec::with_capacity(r.len());
            for (c, v) in r {
                match merged.last_mut() {
                    Some((lc, lv)) if *lc == c => *lv += &v,
                    _ => merged.push((c, v)),
                }
            }
            merged.retain(|(_, v)| !v.is_zero());
            out.push(merged);
        }
        Ok(SparseIntMatrix { rows: out.len(), cols, row_entries: out })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }
    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }
    /// Row `i` as sorted `(column, value)` pairs.
    pub fn row(&self, i: usize) -> &[(usize, Int)] {
        &self.row_entries[i]
    }
    /// Number of stored nonzeros.
    pub fn nnz(&self) -> usize {
        self.row_entries.iter().map(Vec::len).sum()
    }
    /// Entry `(i, j)` (zero when not stored).
    pub fn get(&self, i: usize, j: usize) -> Int {
        let r = &self.row_entries[i];
        match r.binary_search_by_key(&j, |(c, _)| *c) {
            Ok(k) => r[k].1.clone(),
            Err(_) => Int::zero(),
        }
    }

    /// The dense form of this matrix.
    pub fn to_dense(&self) -> IntMatrix {
        let mut m = IntMatrix::zeros(self.rows, self.cols);
        for (i, r) in self.row_entries.iter().enumerate() {
            for (j, v) in r {
                m.set(i, *j, v.clone());
            }
        }
        m
    }

    /// The submatrix with the given rows and columns, renumbered in the given order.
    /// `col_map[j]` is the new index of old column `j`, or `None` to drop it.
    pub fn select(&self, rows: &[usize], col_map: &[Option<usize>], new_cols: usize) -> Self {
        self.select_with(rows, |c| col_map[c], new_cols)
    }

    /// Like [`SparseIntMatrix::select`] with the column map as a function.
    pub fn select_with<F: Fn(usize) -> Option<usize>>(
        &self,
        rows: &[usize],
        col_map: F,
        new_cols: usize,
    ) -> Self {
        let row_entries = rows
            .iter()
            .map(|&i| {
                let mut r: Vec<(usize, Int)> = self.row_entries[i]
                    .iter()
                    .filter_map(|(c, v)| col_map(*c).map(|nc| (nc, v.clone())))
                    .collect();
                r.sort_by_key(|(c, _)| *c);
                r
            })
            .collect();
        SparseIntMatrix { rows: rows.len(), cols: new_cols, row_entries }
    }

    /// Largest bit size among the entries.
    pub fn max_bits(&self) -> u64 {
        self.row_entries.iter().flatten().map(|(_, v)| v.bits()).max().unwrap_or(0)
    }

    /// `self * x` for a rational matrix `x` with `cols` rows of `d` columns.
    pub fn mul_rat(&self, x: &[Vec<Rat>]) -> Vec<Vec<Rat>> {
        let d = x.first().map_or(0, Vec::len);
        self.row_entries
            .iter()
            .map(|r| {
                let mut acc = vec![Rat::zero(); d];
                for (c, v) in r {
                    let vr = Rat::from_integer(v.clone());
                    for (k, a) in acc.iter_mut().enumerate() {
                        *a += &vr * &x[*c][k];
                    }
                }
                acc
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_rat_forms() {
        assert_eq!(parse_rat("3").unwrap(), rat_int(3));
        assert_eq!(parse_rat("-6/4").unwrap(), Rat::new(Int::from(-3), Int::from(2)));
        assert_eq!(parse_rat("0.1").unwrap(), Rat::new(Int::from(1), Int::from(10)));
        assert_eq!(parse_rat("-1.25e-3").unwrap(), Rat::new(Int::from(-1), Int::from(800)));
        assert_eq!(parse_rat("2E3").unwrap(), rat_int(2000));
        assert_eq!(parse_rat(".5").unwrap(), Rat::new(Int::from(1), Int::from(2)));
        for bad in ["", "1/0", "abc", "1.2.3", "NaN", "inf", "1e", "--1", ".", "1e-", "1e+-2"] {
            assert!(matches!(parse_rat(bad), Err(ParseRatError::Syntax(_))), "{bad}");
        }
        assert_eq!(parse_rat("1e+2").unwrap(), rat_int(100));
        assert!(parse_rat("1e10000").is_ok() && parse_rat("1e-10000").is_ok());
        // Fuzzing (solve_json) made `11e6198`-style inputs; beyond the limit they get their
        // own message, also when the exponent does not fit an i64.
        for far in ["1e10001", "1e-10001", "5e99999999999999999999999", "2e-99999999999999999999"] {
            let e = parse_rat(far).unwrap_err();
            assert!(matches!(e, ParseRatError::Exponent(_)), "{far}");
            assert!(e.to_string().contains("exponent is beyond"), "{e}");
        }
    }

    /// The dyadic fast path of big `p / ±2^k` gives `BigRational::new`'s value in lowest
    /// terms: zero, signs, odd and even numerators, denominators beyond `i64` and `i128`.
    #[test]
    fn dyadic_fast_path_matches_the_bigint_gcd() {
        let big = "961347583071961347583071961347583071961347583071";
        let mut texts = Vec::new();
        for num in ["0", "1", "-1", "6", "-6", big, &format!("-{big}"), &format!("{big}0")] {
            for k in [0u32, 1, 3, 63, 64, 100, 200] {
                let q = BigInt::from(2).pow(k);
                texts.push(format!("{num}/{q}"));
                texts.push(format!("{num}/-{q}"));
                let p: BigInt = num.parse().unwrap();
                texts.push(format!("{}/{q}", &p << 70u32));
            }
        }
        for t in texts {
            let (p, q) = t.split_once('/').unwrap();
            let want = BigRational::new(p.parse().unwrap(), q.parse().unwrap());
            let got = parse_rat(&t).unwrap();
            assert_eq!(rat_to_big(&got), want, "{t}");
            assert!(got.denom().is_positive(), "{t}");
            assert_eq!(got, rat_from_big(&want), "{t}: the representation too");
        }
    }

    /// The machine-word fast path of `p/q` gives the general path's value in lowest terms,
    /// signs and extremes included (`i64::MIN / -1` overflows i64, not the i128 it uses).
    #[test]
    fn fraction_fast_path_matches_the_bigint_path() {
        let m = i64::MAX;
        let n = i64::MIN;
        let cases = [(416148729i64, 1048576i64), (-6, 4), (6, -4), (-6, -4), (0, -7), (n, -1)];
        let more = [(n, n), (m, n), (n, 2), (m, m - 1), (12, 1), (-3616467, 524288)];
        for (p, q) in cases.into_iter().chain(more) {
            let want = rat_from_big(&BigRational::new(BigInt::from(p), BigInt::from(q)));
            let got = parse_rat(&format!("{p}/{q}")).unwrap();
            assert_eq!(got, want, "{p}/{q}");
            assert_eq!(rat_to_string(&got), rat_to_string(&want));
            assert_eq!(
                (got.numer().as_i64(), got.denom().as_i64()),
                (want.numer().as_i64(), want.denom().as_i64())
            );
        }
        assert!(matches!(parse_rat("5/0"), Err(ParseRatError::Syntax(_))));
        assert!(matches!(parse_rat("-5/-0"), Err(ParseRatError::Syntax(_))));
    }

    /// The value of decimal text `sign ip . fp e exp`, computed independently in BigRational.
    fn decimal_by_bigint(neg: bool, ip: &str, fp: &str, exp: i64) -> Rat {
        let digits: BigInt = format!("0{ip}{fp}").parse().unwrap();
        let scale = exp - fp.len() as i64;
        let p = num_traits::pow(BigInt::from(10), scale.unsigned_abs() as usize);
        let v = if scale >= 0 {
            BigRational::from_integer(digits * p)
        } else {
            BigRational::new(digits, p)
        };
        rat_from_big(&if neg { -v } else { v })
    }

    proptest::proptest! {
        /// Lowest terms on machine words equal `Rat::new`, signs and extremes included (zero
        /// numerators too: `0 / d` is `0 / 1`).
        #[test]
        fn fractions_reduced_on_words_equal_rat_new(
            x in proptest::prop_oneof![proptest::num::i128::ANY, -1000i128..1000, proptest::strategy::Just(i128::MIN)],
            den in proptest::prop_oneof![proptest::num::i128::ANY, -1000i128..1000, proptest::strategy::Just(i128::MIN)],
        ) {
            proptest::prop_assume!(den != 0);
            proptest::prop_assert_eq!(
                rat_from_i128(x, den),
                Rat::new(Int::from_i128(x), Int::from_i128(den))
            );
        }
    }

    proptest::proptest! {
        /// The machine-word fast path of decimals (up to 18 digits, powers of ten up to
        /// 10^18) and the general path on both sides of its limits give one value in lowest
        /// terms.
        #[test]
        fn decimal_fast_path_matches_the_bigint_path(
            neg in proptest::bool::ANY,
            ip in "[0-9]{0,12}",
            fp in "[0-9]{0,12}",
            exp in -25i64..25,
        ) {
            proptest::prop_assume!(!(ip.is_empty() && fp.is_empty()));
            let sign = if neg { "-" } else { "" };
            let text = match (fp.is_empty(), exp) {
                (true, 0) => format!("{sign}{ip}"),
                (true, e) => format!("{sign}{ip}e{e}"),
                (false, 0) => format!("{sign}{ip}.{fp}"),
                (false, e) => format!("{sign}{ip}.{fp}E{e}"),
            };
            let want = decimal_by_bigint(neg, &ip, &fp, exp);
            let got = parse_rat(&text).unwrap();
            proptest::prop_assert_eq!(&got, &want, "{}", text);
            proptest::prop_assert_eq!(rat_to_string(&got), rat_to_string(&want));
        }
    }

    #[test]
    fn decimal_fast_path_edges() {
        for (text, ip, fp, exp) in [
            ("999999999999999999", "999999999999999999", "", 0),
            ("999999999999999999e18", "999999999999999999", "", 18),
            ("-0.000000000000000001", "0", "000000000000000001", 0),
            ("1e-18", "1", "", -18),
            ("1e19", "1", "", 19),
            ("-0", "0", "", 0),
            ("0.000", "0", "000", 0),
            ("9999999999999999999", "9999999999999999999", "", 0),
        ] {
            let neg = text.starts_with('-');
            assert_eq!(parse_rat(text).unwrap(), decimal_by_bigint(neg, ip, fp, exp), "{text}");
        }
        assert_eq!(rat_to_string(&parse_rat("-0.000").unwrap()), "0");
    }

    #[test]
    fn exact_decimal_reads_back_the_typed_text() {
        let r = |t: &str| parse_rat(t).unwrap();
        for text in
            ["0.1", "123.4567", "-0.0001", "510.9999", "1e23", "1e-300", "0.30000000000000004"]
        {
            let v: f64 = text.parse().unwrap();
            assert_eq!(exact_decimal(v).unwrap(), r(text), "{text}");
            assert_ne!(exact_decimal(v).unwrap(), rat_from_f64(v).unwrap(), "{text}");
        }
        assert_eq!(exact_decimal(-7.25).unwrap(), r("-29/4"));
        assert_eq!(exact_decimal(0.0).unwrap(), rat_int(0));
        assert!(exact_decimal(f64::NAN).is_none() && exact_decimal(f64::INFINITY).is_none());
        // More digits than an f64 holds: the shortest round-trip decimal, not the text.
        let v: f64 = "12.34567890123456789".parse().unwrap();
        assert_eq!(exact_decimal(v).unwrap(), r("12.345678901234567"));
    }

    #[test]
    fn rat_string_round_trip() {
        let r = Rat::new(Int::from(-10), Int::from(4));
        assert_eq!(rat_to_string(&r), "-5/2");
        assert_eq!(parse_rat(&rat_to_string(&r)).unwrap(), r);
        assert_eq!(rat_to_string(&rat_int(7)), "7");
        assert_eq!(rat_to_f64(&r), -2.5);
    }

    #[test]
    fn sparse_build_merges_and_validates() {
        let m = SparseIntMatrix::from_rows(
            3,
            vec![vec![(2, Int::from(1)), (0, Int::from(2)), (2, Int::from(-1))], vec![]],
        )
        .unwrap();
        assert_eq!(m.row(0), &[(0, Int::from(2))]);
        assert_eq!(m.nnz(), 1);
        assert!(SparseIntMatrix::from_rows(2, vec![vec![(5, Int::from(1))]]).is_err());
        assert_eq!(m.to_dense().to_sparse(), m);
    }
}

/// A rational vector stored as integer numerators over one common positive denominator,
/// `v[i] = num[i] / den`. [`ScaledVec::reduce_content`] divides out the common content
/// `gcd(den, num[0], num[1], ...)`; constructors do not (it costs a big gcd per entry).
///
/// Exact solves produce vectors in this form for free (one determinant as denominator);
/// keeping them so avoids a big gcd per entry. [`ScaledVec::to_rats`] gives each entry in
/// lowest terms when needed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScaledVec {
    /// Numerators.
    pub num: Vec<Int>,
    /// Common denominator (positive).
    pub den: Int,
}

impl ScaledVec {
    /// Builds `num / den` (any nonzero `den`), making the denominator positive.
    ///
    /// # Panics
    /// Panics when `den` is zero.
    pub fn new(num: Vec<Int>, den: Int) -> ScaledVec {
        assert!(!den.is_zero(), "zero denominator");
        let mut v = ScaledVec { num, den };
        v.normalize_sign();
        v
    }

    /// The vector of rationals `r` over the least common denominator.
    pub fn from_rats(r: &[Rat]) -> ScaledVec {
        let den = r.iter().fold(Int::one(), |acc, v| {
            if v.denom().is_one() {
                acc
            } else {
                num_integer::Integer::lcm(&acc, v.denom())
            }
        });
        let num = r
            .iter()
            .map(|v| {
                if den.is_one() {
                    v.numer().clone()
                } else {
                    (v.numer() * &den).div_exact(v.denom())
                }
            })
            .collect();
        ScaledVec { num, den }
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.num.len()
    }
    /// True when there are no entries.
    pub fn is_empty(&self) -> bool {
        self.num.is_empty()
    }

    /// Entry `i` in lowest terms.
    pub fn get(&self, i: usize) -> Rat {
        Rat::new(self.num[i].clone(), self.den.clone())
    }

    /// All entries in lowest terms ([`super::lowest::lowest_terms`]: a few gcds and a
    /// product per class of entries instead of one gcd per entry).
    pub fn to_rats(&self) -> Vec<Rat> {
        super::lowest::lowest_terms(&self.num, &self.den)
    }

    /// All entries as rationals over the common denominator, *not* reduced (no gcd per
    /// entry). Equality, ordering and hashing of `Ratio` treat them correctly, and any
    /// arithmetic reduces its result; [`rat_to_string`] reduces before printing.
    pub fn to_rats_raw(&self) -> Vec<Rat> {
        self.num.iter().map(|n| Rat::new_raw(n.clone(), self.den.clone())).collect()
    }

    /// Nearest `f64` of each entry.
    pub fn to_f64(&self) -> Vec<f64> {
        let d = self.den.to_f64_lossy();
        if d.is_finite() && self.den.bits() < 1000 {
            self.num.iter().map(|n| n.to_f64_lossy() / d).collect()
        } else {
            // The value of n / d does not need lowest terms (no gcd per entry).
            self.to_rats_raw().iter().map(rat_to_f64).collect()
        }
    }

    fn normalize_sign(&mut self) {
        if self.den.signum_i32() < 0 {
            self.den = -std::mem::take(&mut self.den);
            for v in self.num.iter_mut() {
                *v = -std::mem::take(v);
            }
        }
    }

    /// Divides numerators and denominator by their common content, so that
    /// `gcd(den, num[0], num[1], ...) = 1`.
    pub fn reduce_content(&mut self) {
        if self.den.is_one() {
            return;
        }
        let mut g = self.den.clone();
        for v in &self.num {
            if g.is_one() {
                return;
            }
            if !v.is_zero() {
                g = g.gcd_int(v);
            }
        }
        if !g.is_one() {
            self.den = self.den.div_exact(&g);
            for v in self.num.iter_mut() {
                if !v.is_zero() {
                    *v = v.div_exact(&g);
                }
            }
        }
    }
}
