//! Arithmetic modulo word-size primes and sparse LU factoring modulo `p`.
//!
//! # Primes and arithmetic
//!
//! [`primes`] lists the primes below `2^62` from the top down (deterministic Miller-Rabin for
//! 64-bit integers). [`Zp`] does arithmetic modulo one of them in Montgomery form:
//! `x` is stored as `x R mod p` with `R = 2^64`, and a product costs two 64 x 64 -> 128-bit
//! multiplications and no division (`redc(t) = (t + ((t * -p^-1) mod R) p) / R`).
//!
//! # Sparse LU modulo p
//!
//! [`LuModP::factor`] eliminates an `m x n` matrix (rows of `(column, value)` in Montgomery
//! form) by right-looking Gaussian elimination with full pivoting, choosing at each step the
//! nonzero of least Markowitz cost `(row nonzeros - 1)(column nonzeros - 1)` (ties: lowest
//! row, then lowest column, so the order depends only on the values modulo `p`), the same
//! fill-reducing rule as the fraction-free [`crate::exact::Ldu`] (thesis ch. 6 uses the
//! smallest magnitude; Markowitz 1957 is the classical sparse choice). With
//! [`LuModP::refactor`] the pivot sequence of an earlier factoring is replayed for another
//! prime (no search); a pivot that vanishes modulo the new prime makes it fail, and the
//! caller takes another prime.
//!
//! [`LuModP::factor_in_row_order`] takes the pivot *rows* in index order (the first row
//! that has not reduced to zero; its column of fewest nonzeros): its pivot rows are then the
//! lexicographically first basis of the rows modulo `p`, each zero row depends on the rows
//! before it, which is how [`crate::exact::modular::certified_basis`] names one canonical
//! redundant set.
//!
//! The factoring is `Pr A Pc = L U` with `L` unit lower trapezoidal and `U` upper
//! trapezoidal: the rows `row_order[..rank]` are independent modulo `p` (hence independent
//! over the rationals), the rows `row_order[rank..]` reduce to zero modulo `p`.

use super::matrix::SparseIntMatrix;
use std::sync::{Mutex, OnceLock};

/// Largest prime we use is below this bound.
pub const PRIME_BOUND: u64 = 1 << 62;

fn mulmod_slow(a: u64, b: u64, p: u64) -> u64 {
    ((a as u128 * b as u128) % p as u128) as u64
}

fn powmod_slow(mut a: u64, mut e: u64, p: u64) -> u64 {
    let mut r = 1u64;
    a %= p;
    while e > 0 {
        if e & 1 == 1 {
            r = mulmod_slow(r, a, p);
        }
        a = mulmod_slow(a, a, p);
        e >>= 1;
    }
    r
}

/// Deterministic Miller-Rabin for 64-bit integers (bases: the first 12 primes).
pub fn is_prime_u64(n: u64) -> bool {
    if n < 2 {
        return false;
    }
    const BASES: [u64; 12] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37];
    for b in BASES {
        if n.is_multiple_of(b) {
            return n == b;
        }
    }
    let (mut d, mut s) = (n - 1, 0);
    while d.is_multiple_of(2) {
        d /= 2;
        s += 1;
    }
    'outer: for a in BASES {
        let mut x = powmod_slow(a, d, n);
        if x == 1 || x == n - 1 {
            continue;
        }
        for _ in 1..s {
            x = mulmod_slow(x, x, n);
            if x == n - 1 {
                continue 'outer;
            }
        }
        return false;
    }
    true
}

/// The first `count` primes below [`PRIME_BOUND`], largest first (computed once, cached).
pub fn primes(count: usize) -> Vec<u64> {
    static CACHE: OnceLock<Mutex<Vec<u64>>> = OnceLock::new();
    let mut c = CACHE.get_or_init(|| Mutex::new(Vec::new())).lock().expect("prime cache");
    let mut n = c.last().map_or(PRIME_BOUND - 1, |&p| p - 2);
    while c.len() < count {
        if is_prime_u64(n) {
            c.push(n);
        }
        n -= 2;
    }
    c[..count].to_vec()
}

/// Arithmetic modulo an odd prime `p < 2^62` in Montgomery form (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct Zp {
    /// The prime.
    pub p: u64,
    /// `-p^-1 mod 2^64`.
    pinv_neg: u64,
    /// `R^2 mod p`.
    r2: u64,
}

impl Zp {
    /// Arithmetic modulo the odd prime `p < 2^62`.
    pub fn new(p: u64) -> Zp {
        assert!(!p.is_multiple_of(2) && p < PRIME_BOUND, "odd prime below 2^62");
        let mut inv: u64 = 1; // Newton: inv = p^-1 mod 2^64
        for _ in 0..6 {
            inv = inv.wrapping_mul(2u64.wrapping_sub(p.wrapping_mul(inv)));
        }
        let r = ((1u128 << 64) % p as u128) as u64;
        let r2 = mulmod_slow(r, r, p);
        Zp { p, pinv_neg: inv.wrapping_neg(), r2 }
    }

    #[inline(always)]
    fn redc(&self, t: u128) -> u64 {
        let m = (t as u64).wrapping_mul(self.pinv_neg);
        let u = ((t + m as u128 * self.p as u128) >> 64) as u64;
        if u >= self.p {
            u - self.p
        } else {
            u
        }
    }

    /// Montgomery product `a b R^-1`.
    #[inline(always)]
    pub fn mul(&self, a: u64, b: u64) -> u64 {
        self.redc(a as u128 * b as u128)
    }
    /// `a + b`.
    #[inline(always)]
    pub fn add(&self, a: u64, b: u64) -> u64 {
        let s = a + b;
        if s >= self.p {
            s - self.p
        } else {
            s
        }
    }
    /// `a - b`.
    #[inline(always)]
    pub fn sub(&self, a: u64, b: u64) -> u64 {
        if a >= b {
            a - b
        } else {
            a + self.p - b
        }
    }
    /// `-a`.
    #[inline(always)]
    pub fn neg(&self, a: u64) -> u64 {
        if a == 0 {
            0
        } else {
            self.p - a
        }
    }
    /// Montgomery form of the residue `a < p`.
    #[inline]
    pub fn to_mont(&self, a: u64) -> u64 {
        self.mul(a, self.r2)
    }
    /// Residue `< p` of the Montgomery value `a`.
    #[inline]
    pub fn from_mont(&self, a: u64) -> u64 {
        self.redc(a as u128)
    }
    /// Montgomery form of a signed integer.
    pub fn from_i64(&self, v: i64) -> u64 {
        let r = v.rem_euclid(self.p as i64) as u64;
        self.to_mont(r)
    }
    /// Montgomery form of an exact integer.
    pub fn from_int(&self, v: &crate::exact::Int) -> u64 {
        match v.view() {
            crate::exact::IntView::Small(s) => self.from_i64(s),
            crate::exact::IntView::Big(b) => {
                let r = b.magnitude() % self.p;
                let r = num_traits::ToPrimitive::to_u64(&r).expect("remainder below p");
                let r = if b.sign() == num_bigint::Sign::Minus && r != 0 { self.p - r } else { r };
                self.to_mont(r)
            }
        }
    }
    /// Inverse of a nonzero Montgomery value (Fermat: `a^(p-2)`).
    pub fn inv(&self, a: u64) -> u64 {
        assert!(a != 0, "inverse of zero modulo {}", self.p);
        let mut e = self.p - 2;
        let mut base = a;
        let mut r = self.to_mont(1);
        while e > 0 {
            if e & 1 == 1 {
                r = self.mul(r, base);
            }
            base = self.mul(base, base);
            e >>= 1;
        }
        r
    }
}

/// A sparse row: `(column, Montgomery value)` sorted by column, no zeros.
pub type ModRow = Vec<(u32, u64)>;

/// A sparse LU factoring modulo `p` (see the module docs).
#[derive(Clone, Debug)]
pub struct LuModP {
    /// The arithmetic.
    pub zp: Zp,
    /// Rows and columns of `A`.
    pub m: usize,
    /// Columns.
    pub n: usize,
    /// Pivot sequence `(row, column)`; its length is the rank modulo `p`.
    pub pivots: Vec<(usize, usize)>,
    /// Step `k`: the rows `t` it updated with their multipliers `l_tk`
    /// (`row_t <- row_t - l_tk row_(pivot k)`).
    pub l_steps: Vec<Vec<(u32, u64)>>,
    /// `U` row of step `k` (the pivot row when it was chosen, pivot entry included).
    pub u_rows: Vec<ModRow>,
    /// Inverse of each pivot.
    pub pivot_inv: Vec<u64>,
    /// Rows that reduced to zero (original numbering, ascending).
    pub zero_rows: Vec<usize>,
}

/// A pivot of a replayed sequence vanished modulo the new prime.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("pivot {step} vanishes modulo {p}")]
pub struct BadPrime {
    /// The prime.
    pub p: u64,
    /// The step whose pivot is zero.
    pub step: usize,
}

struct Work {
    rows: Vec<ModRow>,
    active: Vec<bool>,
    col_count: Vec<usize>,
    col_rows: Vec<Vec<u32>>,
    scratch: ModRow,
}

fn value_at(r: &ModRow, c: u32) -> Option<u64> {
    r.binary_search_by_key(&c, |e| e.0).ok().map(|k| r[k].1)
}

impl LuModP {
    /// Factors the matrix whose rows are `rows` (`n` columns) with Markowitz pivoting.
    pub fn factor(zp: Zp, n: usize, rows: Vec<ModRow>) -> LuModP {
        Self::run(zp, n, rows, Mode::Markowitz).expect("a free search never fails")
    }

    /// Factors taking the pivot rows in index order (see the module docs): the pivot rows are
    /// the lexicographically first basis of the rows modulo `p`.
    pub fn factor_in_row_order(zp: Zp, n: usize, rows: Vec<ModRow>) -> LuModP {
        Self::run(zp, n, rows, Mode::RowOrder).expect("a free search never fails")
    }

    /// Factors with the pivot sequence of `order` (an earlier factoring of the same integer
    /// matrix modulo another prime). Fails if a pivot vanishes modulo this prime.
    pub fn refactor(
        zp: Zp,
        n: usize,
        rows: Vec<ModRow>,
        order: &[(usize, usize)],
    ) -> Result<LuModP, BadPrime> {
        Self::run(zp, n, rows, Mode::Replay(order))
    }

    fn run(zp: Zp, n: usize, rows: Vec<ModRow>, mode: Mode<'_>) -> Result<LuModP, BadPrime> {
        let m = rows.len();
        let mut w = Work {
            active: vec![true; m],
            col_count: vec![0; n],
            col_rows: vec![Vec::new(); n],
            rows,
            scratch: Vec::new(),
        };
        for (i, r) in w.rows.iter().enumerate() {
            for &(c, _) in r {
                w.col_count[c as usize] += 1;
                w.col_rows[c as usize].push(i as u32);
            }
        }
        let mut lu = LuModP {
            zp,
            m,
            n,
            pivots: Vec::new(),
            l_steps: Vec::new(),
            u_rows: Vec::new(),
            pivot_inv: Vec::new(),
            zero_rows: Vec::new(),
        };
        let mut step = 0;
        let mut next_row = 0;
        loop {
            let (rho, gamma) = match mode {
                Mode::Replay(o) => match o.get(step) {
                    Some(&pc) => pc,
                    None => break,
                },
                Mode::Markowitz => match w.choose() {
                    Some(pc) => pc,
                    None => break,
                },
                Mode::RowOrder => match w.choose_in_row_order(&mut next_row) {
                    Some(pc) => pc,
                    None => break,
                },
            };
            let p = value_at(&w.rows[rho], gamma as u32)
                .filter(|_| w.active[rho])
                .ok_or(BadPrime { p: zp.p, step })?;
            let pinv = zp.inv(p);
            let pivot_row = std::mem::take(&mut w.rows[rho]);
            w.active[rho] = false;
            for &(c, _) in &pivot_row {
                w.col_count[c as usize] -= 1;
            }
            let cand = std::mem::take(&mut w.col_rows[gamma]);
            let mut l = Vec::new();
            for &t in &cand {
                let t = t as usize;
                if !w.active[t] {
                    continue;
                }
                let Some(c) = value_at(&w.rows[t], gamma as u32) else { continue };
                if l.last().is_some_and(|&(lt, _)| lt == t as u32) {
                    continue;
                }
                let f = zp.mul(c, pinv);
                w.eliminate(&zp, t, &pivot_row, f, gamma as u32);
                l.push((t as u32, f));
            }
            l.sort_unstable_by_key(|e| e.0);
            l.dedup_by_key(|e| e.0);
            lu.pivots.push((rho, gamma));
            lu.l_steps.push(l);
            lu.u_rows.push(pivot_row);
            lu.pivot_inv.push(pinv);
            step += 1;
        }
        lu.zero_rows = (0..m).filter(|&i| w.active[i]).collect();
        if matches!(mode, Mode::Replay(_)) && lu.zero_rows.iter().any(|&i| !w.rows[i].is_empty()) {
            // The replayed sequence is shorter than the rank modulo this prime: the first
            // prime was unlucky, not this one; report it as a mismatch all the same.
            return Err(BadPrime { p: zp.p, step });
        }
        Ok(lu)
    }

    /// The rank modulo `p`.
    pub fn rank(&self) -> usize {
        self.pivots.len()
    }

    /// Solves `A x = b` modulo `p` for `b` (Montgomery values, length `m`), with the
    /// non-pivot unknowns at zero. Returns `None` when a zero row of the factoring has a
    /// nonzero right-hand side (inconsistent modulo `p`).
    pub fn solve(&self, b: &mut [u64], x: &mut [u64]) -> Option<()> {
        let zp = &self.zp;
        for (k, l) in self.l_steps.iter().enumerate() {
            let bk = b[self.pivots[k].0];
            if bk == 0 {
                continue;
            }
            for &(t, f) in l {
                let t = t as usize;
                b[t] = zp.sub(b[t], zp.mul(f, bk));
            }
        }
        if self.zero_rows.iter().any(|&i| b[i] != 0) {
            return None;
        }
        x.iter_mut().for_each(|v| *v = 0);
        for k in (0..self.rank()).rev() {
            let (rho, gamma) = self.pivots[k];
            let mut acc = b[rho];
            for &(j, u) in &self.u_rows[k] {
                if j as usize != gamma {
                    let xj = x[j as usize];
                    if xj != 0 {
                        acc = zp.sub(acc, zp.mul(u, xj));
                    }
                }
            }
            x[gamma] = zp.mul(acc, self.pivot_inv[k]);
        }
        Some(())
    }
}

/// [`LuModP::solve`] rearranged for many right-hand sides (Dixon lifting solves once per
/// step): both triangular solves as dot products ("gather" form, `L` stored by rows), each
/// summed in 128 bits and reduced once per [`LAZY_TERMS`] products. Montgomery reduction is
/// linear modulo `p`, so `REDC(a b + c d + ...) = REDC(a b) + REDC(c d) + ...`, and a sum of
/// four products of residues below `p < 2^62` stays below `4 p^2 < p 2^64`, the input bound
/// of one reduction. The results are the same residues as [`LuModP::solve`]'s.
#[derive(Clone, Debug)]
pub struct LuSolver {
    zp: Zp,
    /// Row of each pivot step, and its column.
    pivots: Vec<(usize, usize)>,
    /// For pivot step `k`: the pivot rows of the earlier steps whose multipliers reach row
    /// `pivots[k].0`, with those multipliers.
    l_rows: Vec<Vec<(u32, u64)>>,
    /// For each zero row: its original index and the pivot rows that reach it.
    zero_rows: Vec<(usize, Vec<(u32, u64)>)>,
    /// `U` row of step `k` without its pivot entry.
    u_rows: Vec<ModRow>,
    pivot_inv: Vec<u64>,
}

/// Products summed before one Montgomery reduction in [`LuSolver`].
const LAZY_TERMS: usize = 4;

impl LuModP {
    /// The gather-form solver of this factorization ([`LuSolver`]).
    pub fn solver(&self) -> LuSolver {
        let mut by_row: Vec<Vec<(u32, u64)>> = vec![Vec::new(); self.m];
        for (l, &(r, _)) in self.l_steps.iter().zip(&self.pivots) {
            for &(t, f) in l {
                by_row[t as usize].push((r as u32, f));
            }
        }
        let l_rows = self.pivots.iter().map(|&(r, _)| std::mem::take(&mut by_row[r])).collect();
        let zero_rows =
            self.zero_rows.iter().map(|&r| (r, std::mem::take(&mut by_row[r]))).collect();
        let u_rows = self
            .u_rows
            .iter()
            .zip(&self.pivots)
            .map(|(row, &(_, g))| row.iter().copied().filter(|&(j, _)| j as usize != g).collect())
            .collect();
        LuSolver {
            zp: self.zp,
            pivots: self.pivots.clone(),
            l_rows,
            zero_rows,
            u_rows,
            pivot_inv: self.pivot_inv.clone(),
        }
    }
}

impl LuSolver {
    /// `sum c_i v[j_i]` (Montgomery form) over `terms` `(j_i, c_i)`, reduced once per
    /// [`LAZY_TERMS`] products.
    #[inline(always)]
    fn dot(&self, terms: &[(u32, u64)], v: &[u64]) -> u64 {
        let zp = &self.zp;
        let mut acc = 0u64;
        for chunk in terms.chunks(LAZY_TERMS) {
            let mut t = 0u128;
            for &(j, c) in chunk {
                t += c as u128 * v[j as usize] as u128;
            }
            acc = zp.add(acc, zp.redc(t));
        }
        acc
    }

    /// Same as [`LuModP::solve`]: `x` with `A x = b` (`b` in Montgomery form, overwritten),
    /// or `None` when `b` is inconsistent modulo `p`.
    pub fn solve(&self, b: &mut [u64], x: &mut [u64]) -> Option<()> {
        let zp = &self.zp;
        // Forward, in place: b[row_k] -= sum of the earlier pivot rows' final values times
        // their multipliers (those rows are final: no later step touches a pivot row).
        for (&(r, _), terms) in self.pivots.iter().zip(&self.l_rows) {
            b[r] = zp.sub(b[r], self.dot(terms, b));
        }
        for (r, terms) in &self.zero_rows {
            if zp.sub(b[*r], self.dot(terms, b)) != 0 {
                return None;
            }
        }
        x.iter_mut().for_each(|v| *v = 0);
        for k in (0..self.pivots.len()).rev() {
            let acc = zp.sub(b[self.pivots[k].0], self.dot(&self.u_rows[k], x));
            x[self.pivots[k].1] = zp.mul(acc, self.pivot_inv[k]);
        }
        Some(())
    }
}

/// How [`LuModP::run`] picks its pivots.
#[derive(Clone, Copy)]
enum Mode<'a> {
    /// Least Markowitz cost over the whole active matrix.
    Markowitz,
    /// The first row (by index) that has not reduced to zero, its sparsest column.
    RowOrder,
    /// A given sequence.
    Replay(&'a [(usize, usize)]),
}

impl Work {
    /// The first active nonzero row at or after `*next` and its column of fewest nonzeros
    /// (ties: lowest column). Rows before `*next` are pivots or zero, and a zero row stays
    /// zero, so the cursor only moves forward.
    fn choose_in_row_order(&self, next: &mut usize) -> Option<(usize, usize)> {
        while *next < self.rows.len() {
            let t = *next;
            if self.active[t] && !self.rows[t].is_empty() {
                let &(c, _) = self.rows[t]
                    .iter()
                    .min_by_key(|&&(c, _)| (self.col_count[c as usize], c))
                    .expect("nonempty row");
                return Some((t, c as usize));
            }
            *next += 1;
        }
        None
    }

    fn choose(&self) -> Option<(usize, usize)> {
        let mut best: Option<(usize, usize, usize)> = None; // (cost, row, col)
        for (t, r) in self.rows.iter().enumerate() {
            if !self.active[t] || r.is_empty() {
                continue;
            }
            let rl = r.len() - 1;
            if best.is_some_and(|(bc, _, _)| bc == 0) {
                break;
            }
            for &(c, _) in r {
                let cost = rl * (self.col_count[c as usize] - 1);
                if best.is_none_or(|(bc, _, _)| cost < bc) {
                    best = Some((cost, t, c as usize));
                }
            }
        }
        best.map(|(_, t, c)| (t, c))
    }

    /// `row_t <- row_t - f row_pivot`, dropping column `gamma` and cancellations.
    fn eliminate(&mut self, zp: &Zp, t: usize, pr: &ModRow, f: u64, gamma: u32) {
        let old = std::mem::take(&mut self.rows[t]);
        let out = &mut self.scratch;
        out.clear();
        out.reserve(old.len() + pr.len());
        let (mut i, mut j) = (0, 0);
        while i < old.len() || j < pr.len() {
            let ci = old.get(i).map_or(u32::MAX, |e| e.0);
            let cj = pr.get(j).map_or(u32::MAX, |e| e.0);
            let (col, v, was) = if ci == cj {
                let v = zp.sub(old[i].1, zp.mul(f, pr[j].1));
                i += 1;
                j += 1;
                (ci, v, true)
            } else if ci < cj {
                i += 1;
                (ci, old[i - 1].1, true)
            } else {
                j += 1;
                (cj, zp.neg(zp.mul(f, pr[j - 1].1)), false)
            };
            if v == 0 || col == gamma {
                if was {
                    self.col_count[col as usize] -= 1;
                }
                continue;
            }
            if !was {
                self.col_count[col as usize] += 1;
                self.col_rows[col as usize].push(t as u32);
            }
            out.push((col, v));
        }
        let mut fresh = old;
        fresh.clear();
        fresh.extend_from_slice(out);
        self.rows[t] = fresh;
    }
}

/// Rows of `a` modulo `zp` (Montgomery form).
pub fn rows_mod(zp: &Zp, a: &SparseIntMatrix) -> Vec<ModRow> {
    (0..a.rows())
        .map(|i| {
            a.row(i)
                .iter()
                .filter_map(|(c, v)| {
                    let m = zp.from_int(v);
                    (m != 0).then_some((*c as u32, m))
                })
                .collect()
        })
        .collect()
}

/// Statistics of a modular solve (the multi-modular one of [`super::modular`] and Dixon's
/// lifting in [`super::dixon`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolveStats {
    /// Primes combined.
    pub primes: usize,
    /// Candidates rejected by the exact verification.
    pub rejected: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primes_are_prime_and_descending() {
        let ps = primes(5);
        assert!(ps.windows(2).all(|w| w[0] > w[1]));
        assert!(ps.iter().all(|&p| is_prime_u64(p) && p < PRIME_BOUND));
        assert!(!is_prime_u64(PRIME_BOUND - 1) || ps[0] == PRIME_BOUND - 1);
        assert!(is_prime_u64(1_000_000_007) && !is_prime_u64(1_000_000_007 * 3));
    }

    #[test]
    fn montgomery_matches_u128() {
        let p = primes(1)[0];
        let zp = Zp::new(p);
        for (a, b) in [(3u64, 5u64), (p - 1, p - 2), (123_456_789_012, 987_654_321_098)] {
            let m = zp.from_mont(zp.mul(zp.to_mont(a), zp.to_mont(b)));
            assert_eq!(m, mulmod_slow(a, b, p));
            let ia = zp.inv(zp.to_mont(a));
            assert_eq!(zp.from_mont(zp.mul(ia, zp.to_mont(a))), 1);
        }
        assert_eq!(zp.from_mont(zp.from_i64(-1)), p - 1);
    }

    #[test]
    fn rank_and_solve_modulo_p() {
        // Thesis example (4.3): rank 3.
        let zp = Zp::new(primes(1)[0]);
        let a = [
            [4i64, 9, 16, 29],
            [-1, -6, -19, -16],
            [1, 5, 15, 19],
            [5, 6, -1, -12],
            [5, 10, 15, 20],
        ];
        let rows_for = |zp: &Zp| -> Vec<ModRow> {
            a.iter()
                .map(|r| {
                    r.iter()
                        .enumerate()
                        .filter(|e| *e.1 != 0)
                        .map(|(j, &v)| (j as u32, zp.from_i64(v)))
                        .collect()
                })
                .collect()
        };
        let lu = LuModP::factor(zp, 4, rows_for(&zp));
        assert_eq!(lu.rank(), 3);
        assert_eq!(lu.zero_rows.len(), 2);
        // b = A (1, 2, 3, 4): consistent; the solution reproduces b.
        let b: Vec<i64> = a.iter().map(|r| r[0] + 2 * r[1] + 3 * r[2] + 4 * r[3]).collect();
        let mut bm: Vec<u64> = b.iter().map(|&v| zp.from_i64(v)).collect();
        let mut x = vec![0; 4];
        lu.solve(&mut bm, &mut x).unwrap();
        for (r, &bi) in a.iter().zip(&b) {
            let mut acc = 0;
            for (j, &v) in r.iter().enumerate() {
                acc = zp.add(acc, zp.mul(zp.from_i64(v), x[j]));
            }
            assert_eq!(acc, zp.from_i64(bi));
        }
        let mut bad: Vec<u64> = b.iter().map(|&v| zp.from_i64(v)).collect();
        bad[4] = zp.add(bad[4], zp.to_mont(1));
        assert!(lu.solve(&mut bad, &mut x).is_none());
        let zq = Zp::new(primes(2)[1]);
        let again = LuModP::refactor(zq, 4, rows_for(&zq), &lu.pivots).unwrap();
        assert_eq!(again.rank(), 3);
    }

    /// The gather-form solver gives [`LuModP::solve`]'s residues on random sparse systems,
    /// square and rectangular, full-rank and rank-deficient (consistent and inconsistent
    /// right-hand sides), with entries near `p`.
    #[test]
    fn gather_solver_equals_the_scatter_solve() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(7);
        for &p in &primes(2) {
            let zp = Zp::new(p);
            for case in 0..60 {
                let (m, n) = (rng.gen_range(1..40), rng.gen_range(1..40));
                let density = rng.gen_range(1..6);
                let rows: Vec<ModRow> = (0..m)
                    .map(|_| {
                        let mut r: ModRow = (0..density)
                            .map(|_| {
                                let v = if rng.gen_bool(0.3) {
                                    p - 1 - rng.gen_range(0..3)
                                } else {
                                    rng.gen_range(1..p)
                                };
                                (rng.gen_range(0..n) as u32, zp.to_mont(v))
                            })
                            .collect();
                        r.sort_by_key(|e| e.0);
                        r.dedup_by_key(|e| e.0);
                        r
                    })
                    .collect();
                // Some rows repeated (rank deficiency).
                let mut rows = rows;
                if case % 3 == 0 && m > 2 {
                    rows[m - 1] = rows[0].clone();
                }
                let lu = LuModP::factor(zp, n, rows.clone());
                let solver = lu.solver();
                for trial in 0..4 {
                    let b: Vec<u64> = (0..m).map(|_| zp.to_mont(rng.gen_range(0..p))).collect();
                    let b = if trial == 0 {
                        // A consistent right-hand side: A x0.
                        let x0: Vec<u64> =
                            (0..n).map(|_| zp.to_mont(rng.gen_range(0..p))).collect();
                        rows.iter()
                            .map(|r| {
                                r.iter()
                                    .fold(0, |acc, &(j, v)| zp.add(acc, zp.mul(v, x0[j as usize])))
                            })
                            .collect()
                    } else {
                        b
                    };
                    let (mut b1, mut x1) = (b.clone(), vec![0u64; n]);
                    let (mut b2, mut x2) = (b.clone(), vec![0u64; n]);
                    let r1 = lu.solve(&mut b1, &mut x1);
                    let r2 = solver.solve(&mut b2, &mut x2);
                    assert_eq!(r1, r2, "case {case} trial {trial}");
                    if r1.is_some() {
                        assert_eq!(x1, x2, "case {case} trial {trial}");
                    }
                }
            }
        }
    }
}
