//! The squares fit in landmark space, and the smoothing weight chosen by leave-one-out
//! cross-validation (exact for this linear smoother; GCV is reported beside it).
//!
//! Per coordinate, with variables `x` (see [`super::param`]), landmark rows `a_i` over the
//! variables (`phi(s_i) = a_i^T x + r_i`, `r_i` the fixed points' share), weights `w_i` and
//! the bending energy `E(x) = x^T K x + 2 b^T x + const` ([`super::basis`]), the squares fit
//! minimizes
//!
//! ```text
//!   sum_i w_i (a_i^T x + r_i - t_i)^2 + lambda E(x),      lambda = bend * sum_i w_i * |Omega|
//! ```
//!
//! `|Omega|` is the mesh's area, or [`super::options::FitOptions::bend_area`] when set (the
//! frame fit sets the frame grown by its margin, so far-field rings do not change what a
//! weight means). Both terms then scale as length^2 (the thin-plate energy is
//! dimensionless), so `bend` means the same for a 100 px and a 10,000 px image, and for 10 or
//! 1,000 landmarks.
//!
//! **Landmark space.** Let `x0 = -K^-1 b` (the smoothest map for the fixed points),
//! `y0 = A x0 + r` and `M = A K^-1 A^T` (`k x k`, `k` landmarks). The push-through identity
//! `(A^T W A + lambda K)^-1 A^T W = K^-1 A^T (M + lambda W^-1)^-1` gives the minimizer as
//!
//! ```text
//!   x = x0 + K^-1 A^T c,     c = (M + lambda W^-1)^-1 (t - y0),
//! ```
//!
//! so one sparse factorization of `K` serves every `lambda` and every reweighting (robust
//! losses): `M` is the Gram matrix `G^T G` of `G = L^-1 P A^T` (`K = P^T L L^T P`), whose
//! columns are forward substitutions of sparse landmark rows and stay zero outside a small
//! part of `L` ([`super::sparse::Factor::inverse_gram`]); each solve then costs one
//! `k x k` Cholesky factorization and one sparse solve with `K`.
//!
//! With `M~ = W^1/2 M W^1/2 = U diag(mu) U^T`, the fitted values are
//! `y = y0 + W^-1/2 H~ W^1/2 (t - y0)` with `H~ = U diag(mu / (mu + lambda)) U^T`, hence in
//! closed form for any `lambda`:
//!
//! ```text
//!   tr H = sum_j mu_j / (mu_j + lambda),
//!   RSS_w = sum_coordinates sum_j (lambda / (mu_j + lambda))^2 e_j^2,  e = U^T W^1/2 (t - y0),
//!   GCV(lambda) = (RSS_w / sum w) / (1 - tr H / k)^2                  (Craven & Wahba 1979),
//! ```
//!
//! and the leave-one-out residuals `(t_i - y_i) / (1 - H_ii)` are exact for this linear
//! smoother, with `1 - H~_ii = sum_j U_ij^2 lambda / (mu_j + lambda)` (rows of `U` have unit
//! length; no cancellation near interpolation). **The weight** minimizes the leave-one-out
//! score `LOO(lambda) = sum_i w_i |t_i - y_i|^2 / (1 - H_ii)^2 / sum w` over
//! `log10 bend` in `[-11, 2]`, on a grid of step 0.5 then one of step 0.05 around its best
//! point, each grid scored at once by two `k x k` products. It replaced GCV as the
//! criterion: over the far-field mesh of [`super::frame`], GCV's choice was worse than
//! interpolation with 30 noisy landmarks (4.96 against 4.69 px held-out, `tests/it/fit/real.rs`),
//! leave-one-out's better (4.84). `K` is positive definite when the border is pinned (its null space is the affine
//! maps); otherwise a ridge `r |x - x_warm|^2`, `r` = [`RIDGE`] times `K`'s mean diagonal,
//! keeps it definite: the affine part is then effectively unpenalized (`M` gets very large
//! eigenvalues there), and the warm start's cost still bounds the result's.

use super::error::FitError;
use super::objective::{BendingValues, Objective};
use super::sparse::{Factor, Pattern};
use faer::{Mat, Side};

/// Relative ridge added to the bending matrix's diagonal (see the module docs).
pub const RIDGE: f64 = 1e-9;

/// Largest `nv * k` (entries of `L^-1 P A^T`, at most) the smoother stores: 512 MiB of `f64`.
pub const MAX_SMOOTHER_ENTRIES: usize = 1 << 26;

/// The bending weights the cross-validation searches: `10^(BEND_LOG_RANGE.0 + i *
/// BEND_LOG_STEP)`, then a grid ten times finer around the best of them.
const BEND_LOG_RANGE: (f64, f64) = (-11.0, 2.0);
const BEND_LOG_STEP: f64 = 0.5;

/// Smallest `1 - H_ii` in the leave-one-out residual `(t_i - y_i) / (1 - H_ii)`: a guard
/// against dividing by zero only (near interpolation both tend to 0 in proportion, and
/// `1 - H_ii` is computed without cancellation).
const LOO_MIN_DENOMINATOR: f64 = 1e-300;

/// Fewest landmarks for which GCV is meaningful (below, the default weight is used).
pub const MIN_GCV_LANDMARKS: usize = 6;

/// The fixed bending weight used when it cannot be chosen by GCV (few landmarks): close to
/// interpolation (on a 500 x 250 frame with one landmark, `lambda` is about 0.01 px^2).
pub const DEFAULT_BEND: f64 = 1e-7;

/// The smallest weight the cross-validation searches (`10^BEND_LOG_RANGE.0`): interpolation
/// for every practical purpose (30 landmarks on a 512 x 512 frame miss their targets by
/// about 0.001 px), and numerically safe, being a weight the automatic choice often picks.
/// The soft start of a hard fit uses it ([`super::hard`]).
pub const INTERPOLATING_BEND: f64 = 1e-11;

/// The squares problem in landmark space (see the module docs).
pub struct Smoother {
    nv: usize,
    k: usize,
    /// The factorization of `K` (with the ridge).
    factor: Factor,
    /// The landmark rows `a_i` over the variables.
    cols: Vec<Vec<(usize, f64)>>,
    /// `A K^-1 A^T`, row-major `k x k`.
    m: Vec<f64>,
    /// `x0` per coordinate.
    x0: [Vec<f64>; 2],
    /// `t - y0` per landmark.
    gap: Vec<[f64; 2]>,
    weights: Vec<f64>,
    /// `sum w |Omega|`: `lambda = bend * scale`.
    scale: f64,
}

/// The outcome of the GCV search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    /// The chosen (scale-free) bending weight.
    pub bend: f64,
    /// `sqrt(GCV)` at it (pixels): the GCV estimate of the prediction error.
    pub gcv_rms: f64,
    /// Leave-one-out RMS error of the landmarks at it (pixels), exact for the squares fit
    /// (landmark space only).
    pub loo_rms: Option<f64>,
    /// Effective degrees of freedom `tr H` (per coordinate; estimated by the variable-space
    /// smoother).
    pub dof: f64,
    /// The score the weight minimizes.
    pub criterion: BendCriterion,
}

/// How an automatic bending weight was chosen (reported as `bend_criterion`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BendCriterion {
    /// Exact leave-one-out cross-validation in landmark space (up to
    /// [`super::smooth_sparse::LANDMARK_SPACE_MAX`] landmarks).
    LeaveOneOut,
    /// Generalized cross-validation with a randomized trace in variable space (more
    /// landmarks; [`super::smooth_sparse`]).
    RandomizedGcv,
}

impl BendCriterion {
    /// The name used in reports and summaries.
    pub fn name(self) -> &'static str {
        match self {
            BendCriterion::LeaveOneOut => "leave-one-out",
            BendCriterion::RandomizedGcv => "GCV, randomized trace",
        }
    }
}

/// Each triangle's variables, `K`'s pattern, its values, and the ridge `r_0`.
pub(super) type BendingStructure = (Vec<Vec<usize>>, Pattern, BendingValues, f64);

/// `K`'s structure and values, shared by both smoothers: each triangle's variables
/// (ascending: dense blocks), the pattern with its symbolic analysis (one thread) built
/// beside the numeric assembly (the others), and the ridge `r_0 = RIDGE` times `K`'s mean
/// diagonal. The pattern's diagonal entries come last, for the ridge.
pub(super) fn bending_structure(
    obj: &Objective,
    trace: &mut crate::timing::Trace,
) -> Result<BendingStructure, FitError> {
    let nv = obj.param.nv();
    let locals = obj.bending_locals();
    trace.mark("bending locals");
    let (pattern, bv) =
        rayon::join(|| Pattern::from_cliques(nv, &locals, true), || obj.bending_values(&locals));
    trace.mark("symbolic analysis | bending values");
    let pattern = pattern.map_err(|e| FitError::Solver(e.to_string()))?;
    let diag = bv.diag;
    let mean_diag = if diag.1 == 0 { 1.0 } else { (diag.0 / nv as f64).max(f64::MIN_POSITIVE) };
    Ok((locals, pattern, bv, RIDGE * mean_diag))
}

impl Smoother {
    /// Builds the landmark-space problem of an objective (its loss and barrier are ignored).
    pub fn new(obj: &Objective) -> Result<Smoother, FitError> {
        let nv = obj.param.nv();
        let rows = obj.variable_rows();
        let k = rows.len();
        if nv.saturating_mul(k.max(1)) > MAX_SMOOTHER_ENTRIES {
            return Err(FitError::TooLarge { variables: nv });
        }
        let mut trace = crate::timing::Trace::new("smoother");
        let (_, pattern, BendingValues { mut values, b, .. }, r) =
            bending_structure(obj, &mut trace)?;
        // The ridge on the diagonal (the last nv entries of the pattern).
        values.extend(std::iter::repeat_n(r, nv));
        let factor: Factor = pattern.factor(&values).map_err(|_| FitError::Singular(0))?;
        trace.mark("numeric Cholesky");
        // The ridge penalizes the distance to the warm start (not to the origin), so the
        // warm start's cost bounds the result's: x0 = -(K + r I)^-1 (b - r x_warm), the two
        // coordinates on two threads (each solve is sequential).
        let warm = obj.param.x0();
        let x0_of = |c: usize| {
            let mut v: Vec<f64> =
                b[c].iter().zip(&warm[c * nv..(c + 1) * nv]).map(|(x, w)| r * w - x).collect();
            factor.solve(&mut v);
            v
        };
        let (x0x, x0y) = rayon::join(|| x0_of(0), || x0_of(1));
        let x0 = [x0x, x0y];
        let cols: Vec<Vec<(usize, f64)>> = rows.iter().map(|(row, _, _)| row.clone()).collect();
        trace.mark("x0");
        let m = factor.inverse_gram(&cols);
        trace.mark("landmark Gram");
        let gap = rows
            .iter()
            .map(|(row, r0, t)| {
                let y = [0, 1].map(|c| r0[c] + row.iter().map(|&(a, w)| w * x0[c][a]).sum::<f64>());
                [t[0] - y[0], t[1] - y[1]]
            })
            .collect();
        let weights: Vec<f64> = obj.rows().iter().map(|r| r.weight).collect();
        let scale = weights.iter().sum::<f64>() * obj.reference_area();
        Ok(Smoother { nv, k, factor, cols, m, x0, gap, weights, scale })
    }

    /// `lambda` for a scale-free weight.
    pub fn lambda(&self, bend: f64) -> f64 {
        bend * self.scale
    }

    /// The minimizer for `bend`, with data weights multiplied by `scale` (robust losses).
    /// Returns `x` (`2 nv` entries, coordinate-major).
    pub fn solve(&self, bend: f64, scale: Option<&[f64]>) -> Result<Vec<f64>, FitError> {
        let (k, nv) = (self.k, self.nv);
        let lambda = self.lambda(bend);
        let mut x = [self.x0[0].clone(), self.x0[1].clone()].concat();
        if k == 0 {
            return Ok(x);
        }
        let a = Mat::<f64>::from_fn(k, k, |i, j| {
            let mut v = self.m[i * k + j];
            if i == j {
                let w = self.weights[i] * scale.map_or(1.0, |s| s[i]);
                v += lambda / w.max(f64::MIN_POSITIVE);
            }
            v
        });
        let llt = a.llt(Side::Lower).map_err(|_| FitError::Singular(0))?;
        let mut rhs = Mat::<f64>::from_fn(k, 2, |i, c| self.gap[i][c]);
        faer::linalg::solvers::Solve::solve_in_place(&llt, rhs.as_mut());
        // x = x0 + K^-1 A^T c, per coordinate.
        let mut b = vec![0.0; 2 * nv];
        for c in 0..2 {
            for (j, col) in self.cols.iter().enumerate() {
                let cj = rhs[(j, c)];
                for &(a, w) in col {
                    b[c * nv + a] += cj * w;
                }
            }
        }
        self.factor.solve_many(&mut b, nv, 2);
        for (xa, ba) in x.iter_mut().zip(&b) {
            *xa += ba;
        }
        Ok(x)
    }

    /// Chooses the bending weight by leave-one-out cross-validation (see the module docs).
    /// `None` when there are too few landmarks ([`MIN_GCV_LANDMARKS`]).
    pub fn choose(&self) -> Result<Option<Choice>, FitError> {
        let k = self.k;
        if k < MIN_GCV_LANDMARKS {
            return Ok(None);
        }
        let sw: Vec<f64> = self.weights.iter().map(|w| w.sqrt()).collect();
        let mt = Mat::<f64>::from_fn(k, k, |i, j| sw[i] * self.m[i * k + j] * sw[j]);
        let eig = mt
            .self_adjoint_eigen(Side::Lower)
            .map_err(|e| FitError::Solver(format!("eigen decomposition: {e:?}")))?;
        let u = eig.U();
        let mu: Vec<f64> = (0..k).map(|j| eig.S().column_vector()[j].max(0.0)).collect();
        // e = U^T W^1/2 gap, per coordinate.
        let g = Mat::<f64>::from_fn(k, 2, |i, c| sw[i] * self.gap[i][c]);
        let e = u.transpose() * &g;
        let u2 = Mat::<f64>::from_fn(k, k, |i, j| u[(i, j)] * u[(i, j)]);
        let sum_w: f64 = self.weights.iter().sum();
        // The leave-one-out score of a batch of weights, all at once, per weight (column):
        // 1 - H_ii = (U o U) f with f_j = lambda / (mu_j + lambda) (the rows of U have unit
        // length, so this has no cancellation near interpolation), and
        // W^1/2 (t - y) = U diag(f) e.
        let loo = |bends: &[f64]| -> Vec<f64> {
            let nb = bends.len();
            let lam: Vec<f64> = bends.iter().map(|&b| self.lambda(b)).collect();
            let f = Mat::<f64>::from_fn(k, nb, |j, l| lam[l] / (mu[j] + lam[l]));
            let q = Mat::<f64>::from_fn(k, 2 * nb, |j, l| {
                let (l, c) = (l % nb, l / nb);
                e[(j, c)] * lam[l] / (mu[j] + lam[l])
            });
            let (one_minus_h, r) = (&u2 * &f, u * &q);
            (0..nb)
                .map(|l| {
                    let mut sum = 0.0;
                    for i in 0..k {
                        let den = one_minus_h[(i, l)].max(LOO_MIN_DENOMINATOR);
                        let (a, b) = (r[(i, l)], r[(i, nb + l)]);
                        sum += (a * a + b * b) / (den * den);
                    }
                    sum / sum_w
                })
                .collect()
        };
        // A coarse grid of log10(bend), then a fine one around its best point.
        let grid = |from: f64, to: f64, step: f64| -> Vec<f64> {
            let n = ((to - from) / step + 1e-9).floor() as usize + 1;
            (0..n).map(|i| from + i as f64 * step).collect()
        };
        let best_of = |logs: &[f64]| -> (f64, f64) {
            let bends: Vec<f64> = logs.iter().map(|&l| 10f64.powf(l)).collect();
            let scores = loo(&bends);
            let mut best = (f64::INFINITY, logs[0]);
            for (&s, &l) in scores.iter().zip(logs) {
                // Ties (a flat score near interpolation) go to the smaller weight.
                if s < best.0 * (1.0 - 1e-12) {
                    best = (s, l);
                }
            }
            best
        };
        let coarse = best_of(&grid(BEND_LOG_RANGE.0, BEND_LOG_RANGE.1, BEND_LOG_STEP));
        let fine = best_of(&grid(
            (coarse.1 - BEND_LOG_STEP).max(BEND_LOG_RANGE.0),
            (coarse.1 + BEND_LOG_STEP).min(BEND_LOG_RANGE.1),
            BEND_LOG_STEP / 10.0,
        ));
        let (score, l) = if fine.0 < coarse.0 { fine } else { coarse };
        let bend = 10f64.powf(l);
        // GCV and the effective degrees of freedom at the choice, for the report.
        let lambda = self.lambda(bend);
        let (mut rss, mut tr) = (0.0, 0.0);
        for j in 0..k {
            let f = lambda / (mu[j] + lambda);
            rss += f * f * (e[(j, 0)] * e[(j, 0)] + e[(j, 1)] * e[(j, 1)]);
            tr += mu[j] / (mu[j] + lambda);
        }
        let den = (1.0 - tr / k as f64).max(1e-12);
        let gcv = rss / sum_w / (den * den);
        Ok(Some(Choice {
            bend,
            gcv_rms: gcv.sqrt(),
            loo_rms: Some(score.sqrt()),
            dof: tr,
            criterion: BendCriterion::LeaveOneOut,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hard fit's soft start uses the smallest weight the automatic choice searches.
    #[test]
    fn the_interpolating_weight_is_the_bottom_of_the_search() {
        assert_eq!(INTERPOLATING_BEND, 10f64.powf(BEND_LOG_RANGE.0));
    }
}
