//! Multi-modular exact solving with a final exact verification.
//!
//! # Nonsingular systems ([`solve_nonsingular`])
//!
//! For a nonsingular `k x k` integer matrix `A` and rational right-hand sides `B = N / e`:
//!
//! 1. modulo the first prime `p_1`, a sparse LU with Markowitz pivoting ([`LuModP`]) fixes
//!    a fill-reducing pivot sequence; every further prime replays it (a prime on which a
//!    pivot or `e` vanishes is skipped);
//! 2. the solutions `X mod p_i` are combined by Chinese remaindering ([`CrtVec`]), a batch
//!    of primes at a time (in parallel);
//! 3. whenever the modulus has grown by half since the last attempt, rational reconstruction
//!    proposes `X = Y / d` (one common denominator, output-sensitive: the number of primes
//!    follows the size of the *answer*, not the Hadamard bound of the matrix);
//! 4. the candidate is **verified exactly**: `A Y = d B` in integers. Only a verified
//!    candidate is returned; a wrong one (too few primes) just means more primes.
//!
//! The first method tried is Dixon's p-adic lifting ([`super::dixon`]): one LU modulo one
//! prime, then `O(size of the answer)` cheap lifting steps; the CRT method above is the
//! fallback. Both end with the same exact verification.
//!
//! This is the multi-modular method of FLINT, LinBox and IML (see e.g. Cabay 1971; Wang,
//! Guy and Davenport 1982 for the reconstruction).
//!
//! # Rank and redundancy ([`certified_basis`])
//!
//! The rank modulo `p` never exceeds the rank over `Q`, and rows independent modulo `p` are
//! independent over `Q`. So the pivot rows `I` (columns `J`) of one LU modulo `p` are
//! independent, and the rank is exactly `|I|` once every other row `z` is shown to depend
//! on them: a certificate `c_z` with `R_z = c_z^T R_I` exactly (over *all* columns), found
//! by solving `R_IJ^T c_z = R_zJ^T` as above. A failed certificate means the prime was
//! unlucky; the next prime is tried, and after a few the caller falls back to the
//! fraction-free path. The certificates also decide consistency exactly: `R x = b` is
//! solvable iff `b_z = c_z . b_I` for every redundant `z` (eq. 8.10 of the 2017 thesis in
//! this basis).
//!
//! # One canonical redundant set
//!
//! A rank-deficient matrix has many bases of its rows; the one reported is the
//! *lexicographically first*: row `i` is redundant iff it is a combination of the rows
//! `0..i`. The LU modulo `p` takes its pivot rows in index order
//! ([`LuModP::factor_in_row_order`]), and each certificate must use only independent rows
//! before `z`. That certifies the set exactly: every reported `z` depends on earlier rows,
//! so the lexicographically first basis lies inside `I`; `I` is independent and as large as
//! the rank, so the two are equal. A prime that breaks this (a row independent over `Q`
//! but zero modulo `p`) fails the check and the next prime is tried. The fraction-free path
//! reports the same set (computed here), so `"redundant"` is identical on both paths.

use super::crt::CrtVec;
use super::int::Int;
use super::matrix::{ScaledVec, SparseIntMatrix};
use super::modp::{primes, rows_mod, LuModP, SolveStats, Zp};
use num_traits::{One, Zero};
use rayon::prelude::*;

/// Most primes a solve may use before it gives up (about 250,000 bits of answer).
pub const MAX_PRIMES: usize = 4096;

/// Primes combined per round (solved in parallel).
const BATCH: usize = 8;

/// Why a modular computation gave no certified answer (the caller falls back).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ModularError {
    /// The matrix is singular modulo every prime tried (so probably singular).
    #[error("the matrix is singular modulo the primes tried")]
    Singular,
    /// No verified answer within [`MAX_PRIMES`] primes.
    #[error("no verified reconstruction within {0} primes")]
    NoCertificate(usize),
    /// The certificates of the redundant rows failed on every prime tried.
    #[error("the rank modulo p could not be certified")]
    RankNotCertified,
}

/// A hook that may alter a reconstructed candidate before verification (tests use it to
/// inject a wrong reconstruction).
pub type Tamper<'a> = &'a (dyn Fn(&mut [ScaledVec]) + Sync);

/// Solves `A X = B` exactly for nonsingular square `a` and the columns `b` (see the module
/// docs). Returns one [`ScaledVec`] per column.
pub fn solve_nonsingular(
    a: &SparseIntMatrix,
    b: &[ScaledVec],
) -> Result<(Vec<ScaledVec>, SolveStats), ModularError> {
    solve_nonsingular_with(a, b, None)
}

/// [`solve_nonsingular`] with an optional [`Tamper`] hook: Dixon lifting first, the
/// multi-modular (CRT) solve when lifting does not apply or does not certify.
pub fn solve_nonsingular_with(
    a: &SparseIntMatrix,
    b: &[ScaledVec],
    tamper: Option<Tamper<'_>>,
) -> Result<(Vec<ScaledVec>, SolveStats), ModularError> {
    let mut rejected = 0;
    if let Some((mut x, stats)) = super::dixon::solve(a, b) {
        if let Some(t) = tamper {
            t(&mut x);
        }
        let t0 = std::time::Instant::now();
        let ok = x.iter().zip(b).all(|(x, bc)| verify(a, x, bc));
        if std::env::var_os("TRIMORPH_TRACE").is_some() {
            eprintln!("trace: exact verification {:.3} s", t0.elapsed().as_secs_f64());
        }
        if ok {
            return Ok((x, stats));
        }
        rejected = 1;
    }
    if std::env::var_os("TRIMORPH_TRACE").is_some() {
        eprintln!("trace: lifting gave no verified answer for a {0} x {0} system; CRT", a.rows());
    }
    solve_crt(a, b, tamper).map(|(x, mut st)| {
        st.rejected += rejected;
        (x, st)
    })
}

/// The multi-modular (CRT) solve of [`solve_nonsingular`].
pub fn solve_crt(
    a: &SparseIntMatrix,
    b: &[ScaledVec],
    tamper: Option<Tamper<'_>>,
) -> Result<(Vec<ScaledVec>, SolveStats), ModularError> {
    let k = a.rows();
    assert_eq!(a.cols(), k, "square matrix");
    assert!(b.iter().all(|c| c.len() == k), "right-hand sides of length k");
    let mut stats = SolveStats::default();
    if k == 0 {
        return Ok((b.iter().map(|_| ScaledVec::new(Vec::new(), Int::one())).collect(), stats));
    }
    // First prime(s): the pivot sequence.
    let ps = primes(MAX_PRIMES.min(64));
    let mut order = None;
    for &p in ps.iter().take(3) {
        let zp = Zp::new(p);
        let lu = LuModP::factor(zp, k, rows_mod(&zp, a));
        if lu.rank() == k {
            order = Some(lu.pivots);
            break;
        }
    }
    let order = order.ok_or(ModularError::Singular)?;
    let mut crt: Vec<CrtVec> = b.iter().map(|_| CrtVec::new(k)).collect();
    let mut next = 0usize;
    let mut last_try_bits = 0u64;
    while next < MAX_PRIMES {
        let batch = primes((next + BATCH).min(MAX_PRIMES));
        let batch = &batch[next..];
        next += batch.len();
        let results: Vec<Option<(u64, Vec<Vec<u64>>)>> =
            batch.par_iter().map(|&p| solve_mod(a, b, &order, p)).collect();
        for (p, cols) in results.into_iter().flatten() {
            for (c, r) in crt.iter_mut().zip(&cols) {
                c.add(p, r);
            }
            stats.primes += 1;
        }
        let bits = crt[0].modulus_bits();
        if bits < last_try_bits + last_try_bits / 2 + 60 {
            continue;
        }
        last_try_bits = bits;
        let cand: Option<Vec<ScaledVec>> = crt.iter().map(CrtVec::reconstruct).collect();
        let Some(mut cand) = cand else { continue };
        if let Some(t) = tamper {
            t(&mut cand);
        }
        if cand.iter().zip(b).all(|(x, bc)| verify(a, x, bc)) {
            return Ok((cand, stats));
        }
        stats.rejected += 1;
    }
    Err(ModularError::NoCertificate(MAX_PRIMES))
}

/// `X mod p` for every column (plain residues), or `None` for an unusable prime.
fn solve_mod(
    a: &SparseIntMatrix,
    b: &[ScaledVec],
    order: &[(usize, usize)],
    p: u64,
) -> Option<(u64, Vec<Vec<u64>>)> {
    let zp = Zp::new(p);
    let lu = LuModP::refactor(zp, a.cols(), rows_mod(&zp, a), order).ok()?;
    let k = a.rows();
    let mut out = Vec::with_capacity(b.len());
    let mut x = vec![0u64; k];
    for col in b {
        let d = zp.from_int(&col.den);
        if d == 0 {
            return None;
        }
        let dinv = zp.inv(d);
        let mut rhs: Vec<u64> = col.num.iter().map(|v| zp.mul(zp.from_int(v), dinv)).collect();
        lu.solve(&mut rhs, &mut x)?;
        out.push(x.iter().map(|&v| zp.from_mont(v)).collect());
    }
    Some((p, out))
}

/// Exact check `A (Y / d) = N / e`, i.e. `e A Y = d N`, in integers.
pub fn verify(a: &SparseIntMatrix, x: &ScaledVec, b: &ScaledVec) -> bool {
    (0..a.rows()).into_par_iter().all(|i| {
        let mut acc = Int::zero();
        for (j, v) in a.row(i) {
            if !x.num[*j].is_zero() {
                acc += &(v * &x.num[*j]);
            }
        }
        &acc * &b.den == &x.den * &b.num[i]
    })
}

/// A certified basis of the rows of an integer matrix (see the module docs).
#[derive(Clone, Debug)]
pub struct CertifiedBasis {
    /// Independent rows `I`, in pivot order.
    pub independent: Vec<usize>,
    /// Pivot columns `J`, in pivot order (`R_IJ` is nonsingular).
    pub pivot_cols: Vec<usize>,
    /// Redundant rows, ascending.
    pub redundant: Vec<usize>,
    /// For `redundant[k]`: `R_z = certificates[k] . R_I` (entries in the order of
    /// `independent`), checked exactly.
    pub certificates: Vec<ScaledVec>,
    /// Primes used by the certificate solve.
    pub stats: SolveStats,
}

impl CertifiedBasis {
    /// The rank.
    pub fn rank(&self) -> usize {
        self.independent.len()
    }

    /// The first redundant row `z` (ascending) whose value `b_z` differs from `c_z . b_I`
    /// for the column `b = num / den` (length = rows of the matrix), i.e. where `R x = b` is
    /// inconsistent; `None` when it is consistent.
    pub fn first_inconsistent(&self, b: &ScaledVec) -> Option<usize> {
        self.redundant.iter().zip(&self.certificates).find_map(|(&z, c)| {
            let mut acc = Int::zero();
            for (k, &i) in self.independent.iter().enumerate() {
                if !c.num[k].is_zero() && !b.num[i].is_zero() {
                    acc += &(&c.num[k] * &b.num[i]);
                }
            }
            // sum_k c_k b_k = acc / (c.den b.den) must equal b_z = b.num[z] / b.den.
            (acc != &c.den * &b.num[z]).then_some(z)
        })
    }
}

/// Certified rank, independent rows and dependency certificates of `r` (module docs).
pub fn certified_basis(r: &SparseIntMatrix) -> Result<CertifiedBasis, ModularError> {
    let (m, n) = (r.rows(), r.cols());
    for &p in primes(3).iter() {
        let zp = Zp::new(p);
        let lu = LuModP::factor_in_row_order(zp, n, rows_mod(&zp, r));
        let independent: Vec<usize> = lu.pivots.iter().map(|e| e.0).collect();
        let pivot_cols: Vec<usize> = lu.pivots.iter().map(|e| e.1).collect();
        let redundant = lu.zero_rows.clone();
        let rank = independent.len();
        if redundant.is_empty() {
            return Ok(CertifiedBasis {
                independent,
                pivot_cols,
                redundant,
                certificates: Vec::new(),
                stats: SolveStats::default(),
            });
        }
        // R_IJ^T (rank x rank): row a = pivot column J_a, column b = independent row I_b.
        let mut col_pos = vec![usize::MAX; n];
        for (a, &j) in pivot_cols.iter().enumerate() {
            col_pos[j] = a;
        }
        let mut t_rows: Vec<Vec<(usize, Int)>> = vec![Vec::new(); rank];
        for (bi, &i) in independent.iter().enumerate() {
            for (j, v) in r.row(i) {
                if col_pos[*j] != usize::MAX {
                    t_rows[col_pos[*j]].push((bi, v.clone()));
                }
            }
        }
        let mt = SparseIntMatrix::from_rows(rank, t_rows).expect("indices < rank");
        let rhs: Vec<ScaledVec> = redundant
            .iter()
            .map(|&z| {
                let mut v = vec![Int::zero(); rank];
                for (j, val) in r.row(z) {
                    if col_pos[*j] != usize::MAX {
                        v[col_pos[*j]] = val.clone();
                    }
                }
                ScaledVec::new(v, Int::one())
            })
            .collect();
        let Ok((certs, stats)) = solve_nonsingular(&mt, &rhs) else { continue };
        // The certificate solved the pivot columns; check every column, and that row z
        // depends on earlier rows only (the canonical set, module docs).
        let ok = redundant.par_iter().zip(&certs).all(|(&z, c)| {
            if independent.iter().zip(&c.num).any(|(&i, v)| i > z && !v.is_zero()) {
                return false;
            }
            let mut acc: std::collections::BTreeMap<usize, Int> = Default::default();
            for (k, &i) in independent.iter().enumerate() {
                if c.num[k].is_zero() {
                    continue;
                }
                for (j, v) in r.row(i) {
                    *acc.entry(*j).or_insert_with(Int::zero) += &(&c.num[k] * v);
                }
            }
            acc.retain(|_, v| !v.is_zero());
            let want: std::collections::BTreeMap<usize, Int> =
                r.row(z).iter().map(|(j, v)| (*j, v * &c.den)).collect();
            acc == want
        });
        if ok {
            debug_assert_eq!(rank + redundant.len(), m);
            return Ok(CertifiedBasis {
                independent,
                pivot_cols,
                redundant,
                certificates: certs,
                stats,
            });
        }
    }
    Err(ModularError::RankNotCertified)
}

#[cfg(test)]
mod tests;
