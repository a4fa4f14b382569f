//! The squares fit in variable space, for many landmarks: one sparse factorization per
//! bending weight, and the weight chosen by generalized cross-validation with a randomized
//! trace.
//!
//! [`super::smooth`] solves in landmark space: its `k x k` matrix `M = A K^-1 A^T` and that
//! matrix's eigen decomposition cost `O(k^2)` memory and `O(k^3)` time in the number `k` of
//! landmarks (10,000 landmarks: 800 MB and minutes). Above [`LANDMARK_SPACE_MAX`] landmarks
//! the fit instead solves the normal equations over the variables, per coordinate,
//!
//! ```text
//!   (A^T W A + lambda K') x = A^T W (t - r) - lambda b',
//!   K' = K + r_0 I,   b' = b - r_0 x_warm,
//! ```
//!
//! the minimizer of `sum_i w_i (a_i^T x + r_i - t_i)^2 + lambda (x^T K x + 2 b^T x + r_0 |x -
//! x_warm|^2)`: the same objective as the landmark-space smoother, with the same ridge `r_0`
//! ([`super::smooth::RIDGE`] times `K`'s mean diagonal). The matrix is sparse: a landmark in
//! triangle `T` couples only the variables `T`'s patch depends on, which `K`'s block over `T`
//! already couples, so the data add values to `K`'s pattern and no entry. The symbolic
//! Cholesky analysis is done once; each weight costs one numeric factorization
//! ([`crate::sparse`]). Memory and time grow with the mesh, and only linearly with `k`.
//!
//! **The weight.** With `S = A^T W A + lambda K'` and the influence matrix
//! `H = W^1/2 A S^-1 A^T W^1/2` (per coordinate), generalized cross-validation (Craven and
//! Wahba 1979; Wahba, *Spline Models for Observational Data*, 1990, section 4.3) scores
//!
//! ```text
//!   GCV(lambda) = (RSS_w / sum w) / (1 - tr H / k)^2,     RSS_w = sum_i w_i |phi(s_i) - t_i|^2,
//! ```
//!
//! the same score as the landmark-space smoother's GCV, with the leave-one-out denominators
//! `1 - H_ii` replaced by their mean (the exact leave-one-out residuals would need `H`'s
//! diagonal, that is `k` solves). `tr H` is estimated by Hutchinson's estimator
//! (Hutchinson 1989; Girard 1989): for random signs `z in {-1, 1}^k`,
//! `E[z^T H z] = tr H`, and `z^T H z = u^T S^-1 u` with `u = A^T W^1/2 z`, one sparse solve
//! per probe. [`GCV_PROBES`] probes are drawn once, from a fixed seed, and reused for every
//! weight (common random numbers), so the score is a smooth, reproducible function of
//! `lambda` whose error is a shift common to nearby weights. The estimate's standard
//! deviation is at most `sqrt(2 tr H / p)` for `p` probes (the eigenvalues of `H` lie in
//! `[0, 1]`): with 10,000 landmarks and `tr H = 3,000`, about 27, under 0.3 % of `k`.
//!
//! The search runs over `log10 bend` in the landmark-space smoother's range `[-11, 2]`: a
//! grid of step [`COARSE_STEP`], then golden-section search in the two steps around the
//! best grid point, to a width of [`FINE_WIDTH`].

use super::error::FitError;
use super::objective::Objective;
use super::smooth::{bending_structure, Choice};
use super::sparse::{Factor, Pattern};
use crate::memory;
use rayon::prelude::*;

/// Above this many landmarks, [`super::solve`] uses this variable-space smoother instead of
/// the landmark-space one (whose `k x k` eigen decomposition takes about 0.4 s at 1,000).
pub const LANDMARK_SPACE_MAX: usize = 1000;

/// Random probes of the trace estimate (see the module docs).
pub const GCV_PROBES: usize = 8;

/// The searched range of `log10 bend` (that of [`super::smooth`]).
const BEND_LOG_RANGE: (f64, f64) = (-11.0, 2.0);

/// Step of the coarse grid of `log10 bend`.
pub const COARSE_STEP: f64 = 1.0;

/// Width (in `log10 bend`) at which the golden-section search stops.
pub const FINE_WIDTH: f64 = 0.05;

/// One landmark's row over the variables, given by positions in its triangle's variables.
struct LocalRow {
    /// The triangle whose patch gives the row.
    tri: usize,
    /// `(position in the triangle's variables, coefficient)`, positions ascending.
    entries: Vec<(u32, f64)>,
    /// `t_i - r_i` per coordinate (the target less the fixed points' share).
    gap: [f64; 2],
}

/// The squares problem over the variables (see the module docs).
pub struct SparseSmoother {
    nv: usize,
    pattern: Pattern,
    /// Each triangle's variables, ascending (the pattern's cliques).
    locals: Vec<Vec<usize>>,
    /// Where each triangle's lower-triangle values start in the pattern's order.
    offset: Vec<usize>,
    /// `K`'s values in the pattern's order (cliques only; the ridge is on the diagonal).
    bend: Vec<f64>,
    /// The ridge `r_0` of `K' = K + r_0 I`.
    ridge: f64,
    rows: Vec<LocalRow>,
    weights: Vec<f64>,
    /// `-b'` per coordinate: the right-hand side's bending part per unit `lambda`.
    rhs_bend: [Vec<f64>; 2],
    /// `sum w |Omega|`: `lambda = bend * scale`.
    scale: f64,
}

/// The `i`-th pseudo-random sign of probe `p` (SplitMix64 of a fixed seed; reproducible).
fn probe_sign(p: usize, i: usize) -> f64 {
    let mut z = (p as u64) << 40 ^ i as u64 ^ 0x9E37_79B9_7F4A_7C15;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    if z & 1 == 0 {
        1.0
    } else {
        -1.0
    }
}

impl SparseSmoother {
    /// Builds the variable-space problem of an objective (its loss and barrier are ignored).
    /// Refuses with [`FitError::Memory`] when the Cholesky factor would not fit in the
    /// memory budget ([`crate::memory`]).
    pub fn new(obj: &Objective) -> Result<SparseSmoother, FitError> {
        let nv = obj.param.nv();
        let mut trace = crate::timing::Trace::new("sparse smoother");
        let (locals, pattern, bv, ridge) = bending_structure(obj, &mut trace)?;
        // The factor's values, the assembled matrix and the pattern's values, held at once
        // by each of rayon's workers (the weight search factors in parallel).
        let per_worker = (pattern.factor_len() as u64).saturating_add(2 * pattern.len() as u64);
        let need = memory::bytes_of(per_worker, 8 * rayon::current_num_threads().max(1) as u64);
        memory::check(need, || {
            format!(
                "the sparse Cholesky factor of a fit with {nv} variables per coordinate and {} \
                 landmarks",
                obj.rows().len()
            )
        })?;
        let mut offset = Vec::with_capacity(locals.len());
        let mut total = 0usize;
        for l in &locals {
            offset.push(total);
            total += l.len() * (l.len() + 1) / 2;
        }
        let super::objective::BendingValues { values: bend, b, .. } = bv;
        debug_assert_eq!(bend.len(), total);
        let warm = obj.param.x0();
        let rhs_bend = [0, 1].map(|c| {
            b[c].iter().zip(&warm[c * nv..(c + 1) * nv]).map(|(bv, w)| ridge * w - bv).collect()
        });
        let rows: Vec<LocalRow> = obj
            .variable_rows()
            .into_iter()
            .zip(obj.rows())
            .map(|((row, r0, t), dr)| {
                let local = &locals[dr.triangle];
                let entries = row
                    .iter()
                    .map(|&(v, a)| {
                        let z = local.binary_search(&v).map_err(|_| {
                            FitError::Internal(format!(
                                "a landmark's variable {v} is not one of its triangle's"
                            ))
                        })?;
                        Ok((z as u32, a))
                    })
                    .collect::<Result<Vec<_>, FitError>>()?;
                Ok(LocalRow { tri: dr.triangle, entries, gap: [t[0] - r0[0], t[1] - r0[1]] })
            })
            .collect::<Result<_, FitError>>()?;
        trace.mark("landmark rows");
        let weights: Vec<f64> = obj.rows().iter().map(|r| r.weight).collect();
        let scale = weights.iter().sum::<f64>() * obj.reference_area();
        Ok(SparseSmoother {
            nv,
            pattern,
            locals,
            offset,
            bend,
            ridge,
            rows,
            weights,
            rhs_bend,
            scale,
        })
    }

    /// `lambda` for a scale-free weight.
    pub fn lambda(&self, bend: f64) -> f64 {
        bend * self.scale
    }

    /// The weight of row `i`, times `scale[i]` when given.
    fn weight(&self, i: usize, scale: Option<&[f64]>) -> f64 {
        self.weights[i] * scale.map_or(1.0, |s| s[i])
    }

    /// Factors `S = A^T W A + lambda K'` (data weights multiplied by `scale`).
    fn factor(&self, lambda: f64, scale: Option<&[f64]>) -> Result<Factor, FitError> {
        let mut values = Vec::with_capacity(self.pattern.len());
        values.extend(self.bend.iter().map(|v| lambda * v));
        for (i, r) in self.rows.iter().enumerate() {
            let w = self.weight(i, scale);
            let off = self.offset[r.tri];
            for (n1, &(z1, a1)) in r.entries.iter().enumerate() {
                let base = off + z1 as usize * (z1 as usize + 1) / 2;
                for &(z2, a2) in &r.entries[..=n1] {
                    values[base + z2 as usize] += w * a1 * a2;
                }
            }
        }
        values.extend(std::iter::repeat_n(lambda * self.ridge, self.nv));
        self.pattern.factor(&values).map_err(|_| FitError::Singular(0))
    }

    /// Adds `A^T diag(f) v` to `out` (`nv` entries), `v` one value per landmark.
    fn scatter(&self, v: impl Fn(usize) -> f64, f: impl Fn(usize) -> f64, out: &mut [f64]) {
        for (i, r) in self.rows.iter().enumerate() {
            let s = f(i) * v(i);
            if s == 0.0 {
                continue;
            }
            let local = &self.locals[r.tri];
            for &(z, a) in &r.entries {
                out[local[z as usize]] += s * a;
            }
        }
    }

    /// The minimizer for `lambda` with the factor of `S`: `2 nv` entries, coordinate-major.
    fn solve_with(&self, f: &Factor, lambda: f64, scale: Option<&[f64]>) -> Vec<f64> {
        let nv = self.nv;
        let mut x = vec![0.0; 2 * nv];
        for c in 0..2 {
            let xc = &mut x[c * nv..(c + 1) * nv];
            for (o, rb) in xc.iter_mut().zip(&self.rhs_bend[c]) {
                *o = lambda * rb;
            }
            self.scatter(|i| self.rows[i].gap[c], |i| self.weight(i, scale), xc);
        }
        f.solve_many(&mut x, nv, 2);
        x
    }

    /// The minimizer for `bend`, with data weights multiplied by `scale` (robust losses).
    /// Returns `x` (`2 nv` entries, coordinate-major).
    pub fn solve(&self, bend: f64, scale: Option<&[f64]>) -> Result<Vec<f64>, FitError> {
        let lambda = self.lambda(bend);
        let f = self.factor(lambda, scale)?;
        Ok(self.solve_with(&f, lambda, scale))
    }

    /// `sum_i w_i |a_i^T x - (t_i - r_i)|^2` over both coordinates.
    fn rss(&self, x: &[f64]) -> f64 {
        let nv = self.nv;
        let mut sum = 0.0;
        for (r, w) in self.rows.iter().zip(&self.weights) {
            let local = &self.locals[r.tri];
            for c in 0..2 {
                let mut y = 0.0;
                for &(z, a) in &r.entries {
                    y += a * x[c * nv + local[z as usize]];
                }
                let e = y - r.gap[c];
                sum += w * e * e;
            }
        }
        sum
    }

    /// GCV's pieces at a scale-free weight: `(RSS_w / sum w / (1 - tr H / k)^2, tr H)`.
    fn gcv(&self, bend: f64, probes: &[f64], np: usize) -> Result<(f64, f64), FitError> {
        let (k, nv) = (self.rows.len(), self.nv);
        let lambda = self.lambda(bend);
        let f = self.factor(lambda, None)?;
        let x = self.solve_with(&f, lambda, None);
        let mut v = probes.to_vec();
        f.solve_many(&mut v, nv, np);
        let tr: f64 = probes.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>() / np as f64;
        let sum_w: f64 = self.weights.iter().sum();
        let den = (1.0 - tr / k as f64).max(1e-12);
        Ok((self.rss(&x) / sum_w / (den * den), tr))
    }

    /// Chooses the bending weight by GCV with a randomized trace (see the module docs).
    /// `None` when there are too few landmarks ([`super::smooth::MIN_GCV_LANDMARKS`]).
    pub fn choose(&self) -> Result<Option<Choice>, FitError> {
        let (k, nv) = (self.rows.len(), self.nv);
        if k < super::smooth::MIN_GCV_LANDMARKS {
            return Ok(None);
        }
        // u_p = A^T W^1/2 z_p, the probes mapped to the variables, probe-major.
        let np = GCV_PROBES;
        let mut probes = vec![0.0; np * nv];
        for p in 0..np {
            self.scatter(
                |i| probe_sign(p, i),
                |i| self.weights[i].sqrt(),
                &mut probes[p * nv..(p + 1) * nv],
            );
        }
        let score = |l: f64| self.gcv(10f64.powf(l), &probes, np);
        let (lo, hi) = BEND_LOG_RANGE;
        let n = ((hi - lo) / COARSE_STEP + 1e-9).floor() as usize + 1;
        // The grid's weights are independent: scored on rayon's workers (each factorization
        // runs on one thread, see `crate::sparse`), then compared in order.
        let logs: Vec<f64> = (0..n).map(|i| lo + i as f64 * COARSE_STEP).collect();
        let scores = logs.par_iter().map(|&l| score(l)).collect::<Result<Vec<_>, _>>()?;
        let mut best = (f64::INFINITY, lo, 0.0);
        for (&l, &(s, tr)) in logs.iter().zip(&scores) {
            // Ties (a flat score near interpolation) go to the smaller weight.
            if s < best.0 * (1.0 - 1e-12) {
                best = (s, l, tr);
            }
        }
        // Golden-section search in the two steps around the best grid point.
        let phi = (5f64.sqrt() - 1.0) / 2.0;
        let (mut a, mut b) = ((best.1 - COARSE_STEP).max(lo), (best.1 + COARSE_STEP).min(hi));
        let mut c = b - phi * (b - a);
        let mut d = a + phi * (b - a);
        let mut sc = score(c)?;
        let mut sd = score(d)?;
        while b - a > FINE_WIDTH {
            if sc.0 <= sd.0 {
                (b, d, sd) = (d, c, sc);
                c = b - phi * (b - a);
                sc = score(c)?;
            } else {
                (a, c, sc) = (c, d, sd);
                d = a + phi * (b - a);
                sd = score(d)?;
            }
        }
        for (s, l) in [(sc, c), (sd, d)] {
            if s.0 < best.0 * (1.0 - 1e-12) {
                best = (s.0, l, s.1);
            }
        }
        Ok(Some(Choice {
            bend: 10f64.powf(best.1),
            gcv_rms: best.0.sqrt(),
            loo_rms: None,
            dof: best.2,
            criterion: super::smooth::BendCriterion::RandomizedGcv,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::landmarks::Landmark;
    use crate::fit::smooth::Smoother;
    use crate::fit::{solve::objective, FitOptions};
    use crate::mesh::{Mesh, MeshOptions};
    use crate::spline::Spline;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    fn truth(p: [f64; 2]) -> [f64; 2] {
        let (x, y) = (p[0], p[1]);
        [x + 6.0 * (y / 60.0).sin() + 3.0, y + 5.0 * (x / 80.0).cos() - 2.0]
    }

    /// A 10 x 5 grid spline over 500 x 250 and `n` landmarks of `truth` with noise `sigma`.
    fn problem(n: usize, sigma: f64, seed: u64) -> (Spline, Vec<Landmark>) {
        let mesh = Mesh::grid(10, 5, 500.0, 250.0, MeshOptions::default()).unwrap();
        let s = Spline::identity(mesh, 5).unwrap();
        let mut rng = SmallRng::seed_from_u64(seed);
        let lms = (0..n)
            .map(|i| {
                let src = [rng.gen_range(5.0..495.0), rng.gen_range(5.0..245.0)];
                let t = truth(src);
                let dst = [
                    t[0] + sigma * rng.gen_range(-1.7..1.7),
                    t[1] + sigma * rng.gen_range(-1.7..1.7),
                ];
                Landmark { name: Some(format!("l{i}")), src, dst, weight: 1.0 + (i % 3) as f64 }
            })
            .collect();
        (s, lms)
    }

    /// Both smoothers minimize the same objective: at fixed weights, and with the data
    /// weights rescaled (robust losses), their minimizers map the landmarks to within
    /// 1e-5 px of each other. (Not closer at stiff weights: the landmark-space matrix
    /// `A K'^-1 A^T` has eigenvalues up to `1 / RIDGE` times the rest along the affine maps,
    /// which costs it about nine digits there; measured 1.6e-6 px at bend 10.)
    #[test]
    fn variable_space_equals_landmark_space_at_fixed_weights() {
        let (s, lms) = problem(60, 1.0, 3);
        let obj =
            objective(&s, &lms, &FitOptions { barrier: None, ..FitOptions::default() }).unwrap();
        let (dense, sparse) = (Smoother::new(&obj).unwrap(), SparseSmoother::new(&obj).unwrap());
        assert_eq!(dense.lambda(0.5), sparse.lambda(0.5));
        let scale: Vec<f64> = (0..lms.len()).map(|i| 0.2 + (i % 5) as f64 * 0.3).collect();
        for bend in [1e-9, 1e-5, 1e-2, 10.0] {
            for sc in [None, Some(&scale[..])] {
                let a = obj.mapped(&dense.solve(bend, sc).unwrap());
                let b = obj.mapped(&sparse.solve(bend, sc).unwrap());
                let worst = a
                    .iter()
                    .zip(&b)
                    .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]))
                    .fold(0.0, f64::max);
                assert!(worst < 1e-5, "bend {bend}, scaled {}: {worst} px", sc.is_some());
            }
        }
    }

    /// The randomized trace lies within four of its standard deviations, sqrt(2 tr H / p),
    /// of the exact trace (k solves with the unit vectors).
    #[test]
    fn randomized_trace_is_within_its_stated_deviation() {
        let (s, lms) = problem(200, 1.0, 4);
        let obj =
            objective(&s, &lms, &FitOptions { barrier: None, ..FitOptions::default() }).unwrap();
        let sm = SparseSmoother::new(&obj).unwrap();
        let (k, nv, np) = (lms.len(), sm.nv, GCV_PROBES);
        let mut probes = vec![0.0; np * nv];
        for p in 0..np {
            sm.scatter(
                |i| probe_sign(p, i),
                |i| sm.weights[i].sqrt(),
                &mut probes[p * nv..(p + 1) * nv],
            );
        }
        for bend in [1e-8, 1e-5, 1e-3] {
            let (_, estimate) = sm.gcv(bend, &probes, np).unwrap();
            let f = sm.factor(sm.lambda(bend), None).unwrap();
            let mut exact = 0.0;
            for i in 0..k {
                let mut u = vec![0.0; nv];
                sm.scatter(|j| f64::from(u8::from(j == i)), |j| sm.weights[j].sqrt(), &mut u);
                let mut v = u.clone();
                f.solve(&mut v);
                exact += u.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>();
            }
            let sd = (2.0 * exact / np as f64).sqrt();
            assert!(exact > 1.0 && exact < k as f64, "tr H = {exact}");
            assert!((estimate - exact).abs() <= 4.0 * sd, "bend {bend}: {estimate} vs {exact}");
        }
    }

    /// On noisy landmarks, the weight GCV picks recovers the true map about as well as the
    /// exact leave-one-out choice (held-out error within 10 %), and both beat interpolation.
    #[test]
    fn gcv_choice_recovers_the_map_like_leave_one_out() {
        let (s, lms) = problem(300, 1.5, 5);
        let obj =
            objective(&s, &lms, &FitOptions { barrier: None, ..FitOptions::default() }).unwrap();
        let (dense, sparse) = (Smoother::new(&obj).unwrap(), SparseSmoother::new(&obj).unwrap());
        let gcv = sparse.choose().unwrap().unwrap();
        let loo = dense.choose().unwrap().unwrap();
        assert_eq!(gcv.criterion, super::super::smooth::BendCriterion::RandomizedGcv);
        assert!(gcv.loo_rms.is_none() && gcv.gcv_rms > 1.0, "{gcv:?}");
        // Held-out error against the true map at the two choices and near interpolation.
        // (Held-out points as landmarks onto the truth: the same variables, every free point.)
        let held: Vec<Landmark> = (0..400)
            .map(|i| {
                let src = [10.0 + (i % 20) as f64 * 24.0, 10.0 + (i / 20) as f64 * 11.5];
                Landmark { name: None, src, dst: truth(src), weight: 1.0 }
            })
            .collect();
        let obj_held =
            objective(&s, &held, &FitOptions { barrier: None, ..FitOptions::default() }).unwrap();
        assert_eq!(obj_held.param.nv(), obj.param.nv());
        let err = |bend: f64| {
            let r = obj_held.residual_lengths(&sparse.solve(bend, None).unwrap());
            (r.iter().map(|e| e * e).sum::<f64>() / r.len() as f64).sqrt()
        };
        let (eg, el, ei) = (err(gcv.bend), err(loo.bend), err(1e-11));
        assert!(eg <= 1.1 * el, "GCV {eg} px against leave-one-out {el} px");
        assert!(eg < ei, "GCV {eg} px against interpolation {ei} px");
    }
}
