//! The fast path: the derived values as an affine function of anchors and hints.
//!
//! For a session whose edit is weakly solvable, ECLES.Update computes (Alg. 4, 15)
//!
//! ```text
//!     P''_D = P'_D - M (A^ P'_D - B^),   B^ = C^ - K^ P'_A,   M = W^-1 A^T G^-1
//!           = (I - M A^) P'_D  +  (-M K^) P'_A  +  M C^
//!           =        H   P'_D  +      J  P'_A   +   c
//! ```
//!
//! with `A^` the independent rows of `R_ED`, `K^ = R_EA` and `C^ = Q_E - R_EF' P_F'` on the
//! same rows. When `R_ED` has full column rank the solution is unique and `H = 0`. The same
//! `H` and `J` act on every coordinate; `c` has `d` columns. The map is exact ([`AffineMap`])
//! and as `f64` ([`AffineMapF64`]) for optimizers and editors that evaluate many candidate
//! anchor positions; it is valid wherever the edit is weakly solvable (everywhere when it is
//! strongly solvable). Finish with one exact [`Session::update`] to certify the result.

use super::{EclesError, Session};
use crate::exact::matrix::{rat_to_f64, Rat};
use num_traits::{One, Zero};

/// `P''_D = H P'_D + J P'_A + c`, exact.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AffineMap {
    /// Number of anchors `|A|`.
    pub na: usize,
    /// Dimension `d` of each parameter.
    pub d: usize,
    /// `|D| x |D|`; `None` when the solution does not depend on the hints (`H = 0`).
    pub h: Option<Vec<Vec<Rat>>>,
    /// `|D| x |A|`.
    pub j: Vec<Vec<Rat>>,
    /// `|D| x d`.
    pub c: Vec<Vec<Rat>>,
}

/// [`AffineMap`] in `f64`, row-major, for fast evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct AffineMapF64 {
    /// Number of derived parameters.
    pub nd: usize,
    /// Number of anchors.
    pub na: usize,
    /// Dimension of each parameter.
    pub d: usize,
    /// `nd x nd`, row-major; empty when `H = 0`.
    pub h: Vec<f64>,
    /// `nd x na`, row-major.
    pub j: Vec<f64>,
    /// `nd x d`, row-major.
    pub c: Vec<f64>,
}

impl AffineMap {
    /// Applies the map exactly (`anchors`: `|A|` rows of `d`; `hints`: `|D|` rows of `d`).
    pub fn apply(&self, anchors: &[Vec<Rat>], hints: &[Vec<Rat>]) -> Vec<Vec<Rat>> {
        let mut out = self.c.clone();
        for (s, row) in out.iter_mut().enumerate() {
            for (a, jv) in self.j[s].iter().enumerate() {
                if !jv.is_zero() {
                    for (k, o) in row.iter_mut().enumerate() {
                        *o += jv * &anchors[a][k];
                    }
                }
            }
            if let Some(h) = &self.h {
                for (t, hv) in h[s].iter().enumerate() {
                    if !hv.is_zero() {
                        for (k, o) in row.iter_mut().enumerate() {
                            *o += hv * &hints[t][k];
                        }
                    }
                }
            }
        }
        out
    }

    /// The nearest-`f64` version of the map.
    pub fn to_f64(&self) -> AffineMapF64 {
        let flat = |m: &[Vec<Rat>]| m.iter().flatten().map(rat_to_f64).collect::<Vec<f64>>();
        AffineMapF64 {
            nd: self.c.len(),
            na: self.na,
            d: self.d,
            h: self.h.as_deref().map(flat).unwrap_or_default(),
            j: flat(&self.j),
            c: flat(&self.c),
        }
    }
}

impl AffineMapF64 {
    /// Evaluates `out = H hints + J anchors + c`; all arrays row-major (`anchors`: `na x d`,
    /// `hints` and `out`: `nd x d`). `hints` is ignored when `H = 0`. Allocates nothing.
    ///
    /// # Panics
    /// Panics when a slice has the wrong length.
    pub fn eval_into(&self, anchors: &[f64], hints: &[f64], out: &mut [f64]) {
        let (nd, na, d) = (self.nd, self.na, self.d);
        assert_eq!(anchors.len(), na * d, "anchors length");
        assert_eq!(out.len(), nd * d, "output length");
        out.copy_from_slice(&self.c);
        for s in 0..nd {
            let o = &mut out[s * d..(s + 1) * d];
            for (a, &jv) in self.j[s * na..(s + 1) * na].iter().enumerate() {
                if jv != 0.0 {
                    for k in 0..d {
                        o[k] += jv * anchors[a * d + k];
                    }
                }
            }
            if !self.h.is_empty() {
                assert_eq!(hints.len(), nd * d, "hints length");
                for (t, &hv) in self.h[s * nd..(s + 1) * nd].iter().enumerate() {
                    if hv != 0.0 {
                        for k in 0..d {
                            o[k] += hv * hints[t * d + k];
                        }
                    }
                }
            }
        }
    }

    /// Folds fixed hints into `c`, leaving a map of the anchors alone (`H = 0`).
    pub fn with_fixed_hints(&self, hints: &[f64]) -> AffineMapF64 {
        let mut c = vec![0.0; self.nd * self.d];
        let zero_anchors = vec![0.0; self.na * self.d];
        self.eval_into(&zero_anchors, hints, &mut c);
        AffineMapF64 { h: Vec::new(), c, ..self.clone() }
    }
}

impl Session {
    /// The exact affine map of this session for the given weights (default 1); see the
    /// module docs (`crate::ecles::affine`).
    pub fn affine_map(&mut self, weights: Option<&[Rat]>) -> Result<AffineMap, EclesError> {
        let weights = self.weights_or_default(weights)?;
        let (nd, na, d) = (self.derived.len(), self.anchors.len(), self.d);
        let rows: Vec<usize> = self.ldu.independent_rows().to_vec();
        let m = self.relevant.len();
        // Columns of K = R_EA and C over all relevant rows (the solve reads the rows it needs).
        let r_ea = self.r_ea.clone();
        let c_all = self.c.clone();
        let k_col =
            |a: usize| -> Vec<Rat> { (0..m).map(|i| Rat::from_integer(r_ea.get(i, a))).collect() };
        let c_col = |j: usize| -> Vec<Rat> { c_all.iter().map(|r| r[j].clone()).collect() };
        let mut jm = vec![vec![Rat::zero(); na]; nd];
        let mut cm = vec![vec![Rat::zero(); d]; nd];
        if self.ldu.rank() == nd {
            // Unique: x = S b with S the (consistent-part) solution operator.
            for a in 0..na {
                let x = self.ldu.back(&self.ldu.forward(&k_col(a)).0);
                for s in 0..nd {
                    jm[s][a] = -x[s].clone();
                }
            }
            for j in 0..d {
                let x = self.ldu.back(&self.ldu.forward(&c_col(j)).0);
                for s in 0..nd {
                    cm[s][j] = x[s].clone();
                }
            }
            return Ok(AffineMap { na, d, h: None, j: jm, c: cm });
        }
        let lsq = self.lsq_for(&weights)?;
        let pick = |v: Vec<Rat>| -> Vec<Rat> { rows.iter().map(|&i| v[i].clone()).collect() };
        for a in 0..na {
            let corr = lsq.correction(&pick(k_col(a)));
            for s in 0..nd {
                jm[s][a] = -corr[s].clone();
            }
        }
        for j in 0..d {
            let corr = lsq.correction(&pick(c_col(j)));
            for s in 0..nd {
                cm[s][j] = corr[s].clone();
            }
        }
        let a_hat = lsq.matrix();
        let mut h = vec![vec![Rat::zero(); nd]; nd];
        for t in 0..nd {
            let col: Vec<Rat> =
                (0..a_hat.rows()).map(|i| Rat::from_integer(a_hat.get(i, t))).collect();
            let corr = if col.iter().all(Zero::is_zero) {
                vec![Rat::zero(); nd]
            } else {
                lsq.correction(&col)
            };
            for s in 0..nd {
                h[s][t] = if s == t { Rat::one() } else { Rat::zero() } - &corr[s];
            }
        }
        Ok(AffineMap { na, d, h: Some(h), j: jm, c: cm })
    }
}
