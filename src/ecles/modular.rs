//! The multi-modular path of ECLES Initialize + Update for large edits (issue 24).
//!
//! Same problem and same answer as [`super::Session`] (thesis Alg. 1-5 and 15), computed with
//! [`crate::exact::modular`] instead of the fraction-free LDU:
//!
//! 1. relevant sets `E`, `F'` (Alg. 2) and `R_ED`, `R_EA`, `C = Q_E - R_EF' P_F'` as usual;
//! 2. a [`certified_basis`] of the rows of `R_ED`: rank, independent rows `I`, redundant rows
//!    with exact dependency certificates `R_z = c_z R_I`;
//! 3. strong solvability (eqs. 8.15-8.16) and weak solvability (eq. 8.10) decided exactly
//!    by the certificates: column `b` is consistent iff `b_z = c_z . b_I` for every
//!    redundant `z`;
//! 4. the derived values: with full column rank the unique solution of `R_IJ x = b_I`; else
//!    the weighted least squares `x'' = h - W^-1 A^T Lambda`, `G Lambda = A h - b`,
//!    `G = A W^-1 A^T`, `A = R_I` (eqs. 9.6-9.8), with `Lambda` from [`solve_nonsingular`]
//!    (exactly verified) and `x''` computed from it in exact integers.
//!
//! The minimizer is unique, so `P` is bit-identical to the fraction-free path; the rank too.
//! The redundant rows are the canonical set (each depends on the relevant rows before it,
//! [`ConstraintSystem::canonical_redundant`]), which `trimorph solve` reports on both paths.
//! Any failure to certify returns `None` and the caller runs the fraction-free path.

use super::session::{check_edit, check_rows, check_weights};
use super::{ConstraintSystem, EclesError};
use crate::exact::int::Int;
use crate::exact::lsq::gram;
use crate::exact::matrix::{Rat, ScaledVec, SparseIntMatrix};
use crate::exact::modular::{certified_basis, solve_nonsingular, CertifiedBasis};
use num_traits::{One, Zero};
use rayon::prelude::*;

/// The outcome of a modular edit: the same quantities as a [`super::Session`] after one
/// update.
#[derive(Clone, Debug)]
pub struct ModularEdit {
    /// Relevant constraints (sorted).
    pub relevant: Vec<usize>,
    /// Fixed relevant parameters (sorted).
    pub fixed_relevant: Vec<usize>,
    /// Rank of `R_ED`.
    pub rank: usize,
    /// Redundant relevant constraints (sorted original indices).
    pub redundant: Vec<usize>,
    /// New derived values, one [`ScaledVec`] per coordinate (in the order of `derived`).
    pub derived_values: Vec<ScaledVec>,
    /// Primes used (basis certificates + solve).
    pub primes: usize,
}

fn column(rows: &[Vec<Rat>], j: usize) -> ScaledVec {
    ScaledVec::from_rats(&rows.iter().map(|r| r[j].clone()).collect::<Vec<_>>())
}

impl ConstraintSystem {
    /// `R_ED`: the relevant rows and the derived columns (in the order of `derived`).
    fn r_ed(&self, relevant: &[usize], derived: &[usize]) -> SparseIntMatrix {
        let md: std::collections::HashMap<usize, usize> =
            derived.iter().enumerate().map(|(k, &s)| (s, k)).collect();
        self.r.select_with(relevant, |c| md.get(&c).copied(), derived.len())
    }

    /// The canonical redundant set of the relevant constraints (sorted original indices):
    /// constraint `relevant[z]` is redundant iff row `z` of `R_ED` is a combination of the
    /// rows before it (see [`crate::exact::modular`]), certified exactly. The fraction-free
    /// path reports this set too, so both paths name the same constraints. `None` when no
    /// prime certified it (then the caller keeps its own certified set).
    pub fn canonical_redundant(&self, relevant: &[usize], derived: &[usize]) -> Option<Vec<usize>> {
        let basis = certified_basis(&self.r_ed(relevant, derived)).ok()?;
        Some(basis.redundant.iter().map(|&k| relevant[k]).collect())
    }

    /// ECLES Initialize + one Update on the modular path (module docs). `Ok(None)` when the
    /// modular computation could not be certified (run the fraction-free path instead).
    /// Errors are those of [`ConstraintSystem::initialize`] and [`super::Session::update`].
    #[allow(clippy::too_many_arguments)]
    pub fn edit_modular(
        &self,
        p: &[Vec<Rat>],
        anchors: &[usize],
        derived: &[usize],
        anchor_values: &[Vec<Rat>],
        hints: &[Vec<Rat>],
        weights: &[Rat],
        strong: bool,
    ) -> Result<Option<ModularEdit>, EclesError> {
        match self.plan_modular(p, anchors, derived, strong)? {
            Some(plan) => plan.update(anchor_values, hints, weights),
            None => Ok(None),
        }
    }

    /// ECLES Initialize on the modular path: the relevant sets, a certified basis of the rows
    /// of `R_ED` (rank and redundant constraints) and, with `strong`, the strong solvability
    /// check (eqs. 8.15-8.16), which do not depend on the anchors' new values. Each
    /// [`ModularPlan::update`] then solves one edit. `Ok(None)` when no prime certified
    /// the basis (run the fraction-free path instead).
    pub fn plan_modular(
        &self,
        p: &[Vec<Rat>],
        anchors: &[usize],
        derived: &[usize],
        strong: bool,
    ) -> Result<Option<ModularPlan>, EclesError> {
        check_edit(p, anchors, derived, self.params(), self.d)?;
        let (relevant, fixed_relevant) = self.extract_relevant(anchors, derived);
        let map_cols = |cols: &[usize]| -> std::collections::HashMap<usize, usize> {
            cols.iter().enumerate().map(|(k, &s)| (s, k)).collect()
        };
        let (ma, mf) = (map_cols(anchors), map_cols(&fixed_relevant));
        let r_ed = self.r_ed(&relevant, derived);
        let r_ea = self.r.select_with(&relevant, |c| ma.get(&c).copied(), anchors.len());
        let r_ef = self.r.select_with(&relevant, |c| mf.get(&c).copied(), fixed_relevant.len());
        let trace = std::env::var_os("TRIMORPH_TRACE").is_some();
        let t0 = std::time::Instant::now();
        let Ok(basis) = certified_basis(&r_ed) else { return Ok(None) };
        if trace {
            eprintln!(
                "trace: certified basis of {} x {}: rank {}, {} certificates, {} lifting steps, {:.3} s",
                r_ed.rows(),
                r_ed.cols(),
                basis.rank(),
                basis.certificates.len(),
                basis.stats.primes,
                t0.elapsed().as_secs_f64()
            );
        }
        // C = Q_E - R_EF' P_F'.
        let p_f: Vec<Vec<Rat>> = fixed_relevant.iter().map(|&s| p[s].clone()).collect();
        let rf = r_ef.mul_rat(&p_f);
        let c: Vec<Vec<Rat>> = relevant
            .iter()
            .enumerate()
            .map(|(k, &i)| (0..self.d).map(|j| sub(&self.q[i][j], rf[k].get(j))).collect())
            .collect();
        if strong {
            for a in 0..anchors.len() {
                let col = ScaledVec::new(
                    (0..relevant.len()).map(|i| r_ea.get(i, a)).collect(),
                    Int::one(),
                );
                if let Some(z) = basis.first_inconsistent(&col) {
                    return Err(EclesError::NotStronglySolvable {
                        constraint: relevant[z],
                        cause: format!("anchor {}", anchors[a]),
                    });
                }
            }
            for j in 0..self.d {
                if let Some(z) = basis.first_inconsistent(&column(&c, j)) {
                    return Err(EclesError::NotStronglySolvable {
                        constraint: relevant[z],
                        cause: "the fixed parameters".into(),
                    });
                }
            }
        }
        let a_hat = r_ed.select(
            &basis.independent,
            &(0..derived.len()).map(Some).collect::<Vec<_>>(),
            derived.len(),
        );
        let mut redundant: Vec<usize> = basis.redundant.iter().map(|&k| relevant[k]).collect();
        redundant.sort_unstable();
        Ok(Some(ModularPlan {
            d: self.d,
            anchors: anchors.len(),
            derived: derived.to_vec(),
            relevant,
            fixed_relevant,
            redundant,
            r_ea,
            c,
            a_hat,
            basis,
            strong,
        }))
    }
}

/// `a - v` (`a` when there is no `v`).
fn sub(a: &Rat, v: Option<&Rat>) -> Rat {
    match v {
        Some(v) => a - v,
        None => a.clone(),
    }
}

/// ECLES initialized on the modular path ([`ConstraintSystem::plan_modular`]): what one
/// selection keeps between edits (the relevant sets, the certified basis, `C`), so each
/// edit ([`ModularPlan::update`]) only checks weak solvability and solves.
#[derive(Clone, Debug)]
pub struct ModularPlan {
    d: usize,
    anchors: usize,
    derived: Vec<usize>,
    relevant: Vec<usize>,
    fixed_relevant: Vec<usize>,
    redundant: Vec<usize>,
    /// `R_EA`: relevant rows, anchor columns.
    r_ea: SparseIntMatrix,
    /// `C = Q_E - R_EF' P_F'`.
    c: Vec<Vec<Rat>>,
    /// `R_I`: the independent rows, derived columns.
    a_hat: SparseIntMatrix,
    basis: CertifiedBasis,
    strong: bool,
}

impl ModularPlan {
    /// Relevant constraints (sorted).
    pub fn relevant(&self) -> &[usize] {
        &self.relevant
    }
    /// Fixed relevant parameters (sorted).
    pub fn fixed_relevant(&self) -> &[usize] {
        &self.fixed_relevant
    }
    /// Rank of `R_ED`.
    pub fn rank(&self) -> usize {
        self.basis.rank()
    }
    /// Redundant relevant constraints, the canonical set (sorted).
    pub fn redundant(&self) -> &[usize] {
        &self.redundant
    }
    /// Whether strong solvability was checked (and holds).
    pub fn strong(&self) -> bool {
        self.strong
    }

    /// ECLES Update on the modular path: weak solvability (eq. 8.10) of these anchor
    /// values, then the derived values nearest the hints (Alg. 15). `Ok(None)` when the
    /// solve could not be certified (run the fraction-free path instead). Nothing is kept:
    /// a failed update changes nothing.
    pub fn update(
        &self,
        anchor_values: &[Vec<Rat>],
        hints: &[Vec<Rat>],
        weights: &[Rat],
    ) -> Result<Option<ModularEdit>, EclesError> {
        let derived = &self.derived;
        check_rows("anchor values", anchor_values, self.anchors, self.d)?;
        check_rows("hints", hints, derived.len(), self.d)?;
        check_weights(weights, derived)?;
        let (basis, relevant) = (&self.basis, &self.relevant);
        let trace = std::env::var_os("TRIMORPH_TRACE").is_some();
        let t0 = std::time::Instant::now();
        let mut primes = basis.stats.primes;
        // B = C - R_EA P'_A.
        let ka = self.r_ea.mul_rat(anchor_values);
        let b: Vec<Vec<Rat>> = self
            .c
            .iter()
            .zip(&ka)
            .map(|(c, k)| (0..self.d).map(|j| sub(&c[j], k.get(j))).collect())
            .collect();
        let b_cols: Vec<ScaledVec> = (0..self.d).map(|j| column(&b, j)).collect();
        for (j, col) in b_cols.iter().enumerate() {
            if let Some(z) = basis.first_inconsistent(col) {
                return Err(EclesError::NotWeaklySolvable { constraint: relevant[z], column: j });
            }
        }
        let rank = basis.rank();
        // Right-hand sides on the independent rows, in pivot order.
        let b_hat: Vec<ScaledVec> = b_cols
            .iter()
            .map(|col| {
                ScaledVec::new(
                    basis.independent.iter().map(|&i| col.num[i].clone()).collect(),
                    col.den.clone(),
                )
            })
            .collect();
        let a_hat = &self.a_hat;
        let derived_values = if rank == derived.len() {
            // Unique: R_IJ y = b_I with the columns in pivot order.
            let mut pos = vec![0usize; derived.len()];
            for (a, &j) in basis.pivot_cols.iter().enumerate() {
                pos[j] = a;
            }
            let m = a_hat.select(
                &(0..rank).collect::<Vec<_>>(),
                &pos.iter().map(|&a| Some(a)).collect::<Vec<_>>(),
                rank,
            );
            let Ok((ys, st)) = solve_nonsingular(&m, &b_hat) else { return Ok(None) };
            primes += st.primes;
            ys.into_iter()
                .map(|y| {
                    let num = (0..derived.len()).map(|j| y.num[pos[j]].clone()).collect();
                    ScaledVec::new(num, y.den)
                })
                .collect()
        } else {
            match least_squares(a_hat, weights, &b_hat, hints, self.d) {
                Some((v, st)) => {
                    primes += st;
                    v
                }
                None => return Ok(None),
            }
        };
        if trace {
            eprintln!(
                "trace: derived values after {:.3} s ({primes} steps)",
                t0.elapsed().as_secs_f64()
            );
        }
        Ok(Some(ModularEdit {
            relevant: self.relevant.clone(),
            fixed_relevant: self.fixed_relevant.clone(),
            rank,
            redundant: self.redundant.clone(),
            derived_values,
            primes,
        }))
    }
}

/// `x'' = h - W^-1 A^T Lambda` with `(scale G) Lambda = scale (A h - b)` (module docs), all
/// coordinates at once. Mirrors [`crate::exact::WeightedLsq::solve_scaled`].
fn least_squares(
    a: &SparseIntMatrix,
    weights: &[Rat],
    b_hat: &[ScaledVec],
    hints: &[Vec<Rat>],
    d: usize,
) -> Option<(Vec<ScaledVec>, usize)> {
    let (r, n) = (a.rows(), a.cols());
    let (g, scale, factor) = gram(a, weights);
    let h_cols: Vec<ScaledVec> = (0..d).map(|j| column(hints, j)).collect();
    // R = bd * A hn - hd * bn, so that A h - b = R / (hd bd); right-hand side scale * R.
    let rhs: Vec<ScaledVec> = h_cols
        .iter()
        .zip(b_hat)
        .map(|(h, b)| {
            let num = (0..r)
                .map(|i| {
                    let mut acc = Int::zero();
                    for (s, v) in a.row(i) {
                        if !h.num[*s].is_zero() {
                            acc += &(v * &h.num[*s]);
                        }
                    }
                    &Int::cross(&b.den, &acc, &h.den, &b.num[i]) * &scale
                })
                .collect();
            ScaledVec::new(num, Int::one())
        })
        .collect();
    let busy: Vec<usize> = (0..d).filter(|&j| rhs[j].num.iter().any(|v| !v.is_zero())).collect();
    let mut out: Vec<ScaledVec> = h_cols.clone();
    if busy.is_empty() {
        return Some((out, 0));
    }
    let busy_rhs: Vec<ScaledVec> = busy.iter().map(|&j| rhs[j].clone()).collect();
    let t0 = std::time::Instant::now();
    let (lams, st) = solve_nonsingular(&g, &busy_rhs).ok()?;
    if std::env::var_os("TRIMORPH_TRACE").is_some() {
        eprintln!(
            "trace: G Lambda = v ({} x {}, {} nonzeros): {:.3} s, {} lifting steps, Lambda denominator {} bits",
            g.rows(),
            g.cols(),
            (0..g.rows()).map(|i| g.row(i).len()).sum::<usize>(),
            t0.elapsed().as_secs_f64(),
            st.primes,
            lams.first().map_or(0, |l| l.den.bits())
        );
    }
    // The columns in parallel, and each column's entries (the big products) in parallel.
    let solved: Vec<(usize, ScaledVec)> = busy
        .par_iter()
        .zip(lams)
        .map(|(&j, lam)| {
            let mut atl = vec![Int::zero(); n];
            for (i, li) in lam.num.iter().enumerate() {
                if li.is_zero() {
                    continue;
                }
                for (s, v) in a.row(i) {
                    atl[*s] += &(li * v);
                }
            }
            // scale G Lambda = scale R with Lambda = L / LD, so lambda = Lambda / (hd bd) and
            // x'' = hn / hd - factor * atl / (scale * LD * hd * bd).
            let (h, b) = (&h_cols[j], &b_hat[j]);
            let k = &(&scale * &lam.den) * &b.den;
            let num = h
                .num
                .par_iter()
                .zip(atl.par_iter().zip(&factor))
                .map(|(hn, (a, f))| Int::cross(hn, &k, f, a))
                .collect();
            (j, ScaledVec::new(num, &k * &h.den))
        })
        .collect();
    for (j, v) in solved {
        out[j] = v;
    }
    Some((out, st.primes))
}
