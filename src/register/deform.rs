//! The spline stage: the C1 spline's free points moved to minimize
//!
//! ```text
//!   F(x) = E(F, M; phi_x)                                 image term (super::samples)
//!        + lambda sum_T E_T(phi_x) / |Omega|              bending, per unit of area
//!        + sum_i w_i |phi_x(s_i) - t_i|^2 / n              soft landmarks (pixels^2)
//!        + mu sum_T |T|/n_s sum beta(det J)               fold barrier
//! ```
//!
//! over the free points `x` of the spline's minimal determining set (every `x` is an
//! exactly C1 spline: [`crate::fit::param`]). The last three terms are the landmark fit's
//! objective ([`crate::fit::objective::Objective`]: the same bending matrices, landmark rows
//! and barrier), so the registration and the fit share their regularization; the image term
//! is added beside it with its analytic gradient. Each pyramid level (coarsest first) is
//! one L-BFGS run under argmin's `Executor` ([`crate::fit::optim::minimize`]), warm-started
//! from the level before: the same map, in the same spline space or, after a refinement of
//! the mesh pyramid ([`super::pyramid`]), in a finer space that contains it. Within a run
//! the image term sums over the samples inside FIXED at the run's start
//! ([`super::samples::Membership`]), so that no sample crossing FIXED's border makes the
//! cost jump under the line search.
//!
//! **Preconditioning.** The curvature of `F` differs by orders of magnitude between
//! variables: a free point under textured image is held by thousands of samples, one in a
//! flat or masked part only by the bending energy and the landmarks. L-BFGS's single scale
//! cannot serve both, and the second kind would take hundreds of iterations to move. Each
//! level therefore runs in `z = sqrt(D) x` with `D` a Gauss-Newton estimate of the
//! Hessian's diagonal at the level's start ([`jacobi`]): the image term's
//! `(1/N) sum_i B_p(y_i)^2 (dF/dx_c)^2 / var F` per control point and coordinate, pulled to
//! the variables through the determining set's rows (`sum_p d_p R_pk^2`, cross terms
//! dropped), plus the bending matrix's diagonal and the landmark rows' spread diagonals.
//!
//! A landmark row `w (b . x - t)^2` over the `m` control points of its triangle is rank one:
//! its curvature `2 w |b|^2` acts along one direction only. Its diagonal `2 w b_p^2` would
//! shrink every one of the `m` points' steps as if each were that stiff, and the image term
//! could then barely move the points near a landmark: on the textured test pair of
//! `tests/it/register.rs` (12 landmarks with 0.25 px noise), 30 iterations per level ended
//! at 0.115 px of held-out error against the image term's 0.072 px alone. Each point
//! therefore gets the mean curvature over the row's directions, `2 w b_p^2 / m` (0.066 px
//! there; where only the landmarks and the bending hold a point, the landmark fit is the
//! start, see [`super::register`]).

use super::image::Level;
use super::metric::Metric;
use super::samples::{image_term, membership, Membership, SampleOptions, SampleSet, SplineSamples};
use super::{LevelReport, Progress};
use crate::fit::objective::Objective;
use crate::fit::optim::{minimize, MinimizeOptions};
use crate::spline::Spline;
use std::time::Instant;

/// The image side of the spline stage at one level.
pub struct LevelTerm<'a> {
    /// The fixed level.
    pub fixed: &'a Level,
    /// The moving samples.
    pub set: SampleSet,
    /// Where they fall on the mesh.
    pub on_mesh: SplineSamples,
    /// The metric.
    pub metric: Metric,
}

impl<'a> LevelTerm<'a> {
    /// The samples of level `moving` against `fixed` on `s`'s mesh.
    pub fn new(
        s: &Spline,
        fixed: &'a Level,
        moving: &Level,
        metric: Metric,
        samples: SampleOptions,
    ) -> LevelTerm<'a> {
        let set = SampleSet::new(moving, fixed, samples);
        let on_mesh = SplineSamples::new(s, &set);
        LevelTerm { fixed, set, on_mesh, metric }
    }

    /// `(E, dE/dq)` over all control points `pts` (the gradient when `grad`), and the
    /// number of valid samples.
    pub fn eval(&self, pts: &[[f64; 2]], grad: bool) -> (f64, Vec<[f64; 2]>, usize) {
        self.eval_kept(pts, grad, None)
    }

    /// [`LevelTerm::eval`] over the samples `keep` names (`None`: those inside FIXED),
    /// continued beyond FIXED's border ([`Membership`]).
    pub fn eval_kept(
        &self,
        pts: &[[f64; 2]],
        grad: bool,
        keep: Option<&[bool]>,
    ) -> (f64, Vec<[f64; 2]>, usize) {
        let u = self.on_mesh.map(pts);
        let term = image_term(self.metric, self.fixed, &self.set, &u, grad, keep);
        let g = if grad { self.on_mesh.pull(&term.d_u, pts.len()) } else { Vec::new() };
        (term.value, g, term.valid)
    }

    /// The samples inside FIXED (and its mask) for control points `pts`.
    pub fn membership(&self, pts: &[[f64; 2]]) -> Membership {
        membership(self.fixed, &self.on_mesh.map(pts))
    }
}

/// `F(x)` and its gradient (module docs) for the objective `obj` (bending, landmarks,
/// barrier) and the image term `term`.
pub fn total(obj: &Objective, term: &LevelTerm<'_>, x: &[f64]) -> (f64, Vec<f64>, f64) {
    total_kept(obj, term, x, None)
}

/// [`total`] over the samples `keep` names ([`LevelTerm::eval_kept`]).
pub fn total_kept(
    obj: &Objective,
    term: &LevelTerm<'_>,
    x: &[f64],
    keep: Option<&[bool]>,
) -> (f64, Vec<f64>, f64) {
    let n = obj.param.var_of.len();
    let mut gx = vec![0.0; x.len()];
    let t = obj.eval(x, Some(&mut gx));
    let mut pts = vec![[0.0f64; 2]; n];
    obj.param.points_into(x, &mut pts);
    let (e, mut g, valid) = term.eval_kept(&pts, true, keep);
    if valid == 0 || !t.total.is_finite() {
        return (f64::INFINITY, vec![0.0; x.len()], e);
    }
    let mut gi = vec![0.0; x.len()];
    obj.param.backprop(&mut g, &mut gi);
    for (a, b) in gx.iter_mut().zip(&gi) {
        *a += b;
    }
    (t.total + e, gx, e)
}

/// The image term's Gauss-Newton curvature per control point and coordinate at the control
/// points `pts` (module docs): `(1/N) sum_i B_p(y_i)^2 (dF/dx_c)^2 / var F`.
pub fn image_curvature(term: &LevelTerm<'_>, pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let u = term.on_mesh.map(pts);
    let (lo, hi) = term.set.scale.f_range;
    let var_f = (0.25 * (hi - lo) * (hi - lo)).max(1e-30);
    let nf = term.set.len().max(1) as f64;
    let sq: Vec<[f64; 2]> = u
        .iter()
        .map(|&p| {
            term.fixed.sample_full(p).map_or([0.0, 0.0], |(_, g)| {
                [g[0] * g[0] / (nf * var_f), g[1] * g[1] / (nf * var_f)]
            })
        })
        .collect();
    term.on_mesh.pull_squared(&sq, pts.len())
}

/// The preconditioner `D` (module docs): one positive entry per variable.
pub fn jacobi(obj: &Objective, term: &LevelTerm<'_>, x: &[f64]) -> Vec<f64> {
    let (_, d) = jacobi_parts(obj, term, x);
    // A floor: a variable that nothing holds keeps a scale of 1e-6 of the mean.
    let mean = d.iter().sum::<f64>() / d.len().max(1) as f64;
    let floor = (1e-6 * mean).max(1e-300);
    d.iter().map(|&v| v.max(floor)).collect()
}

/// Per variable, whether the image term sees it: its part of `D` ([`jacobi`]) is at least
/// `rel` times the mean over the variables (and positive). With a tiny `rel`, those it does
/// not see lie where no sample falls (masked out, outside FIXED).
pub fn image_sees(obj: &Objective, term: &LevelTerm<'_>, x: &[f64], rel: f64) -> Vec<bool> {
    let (image, _) = jacobi_parts(obj, term, x);
    let mean = image.iter().sum::<f64>() / image.len().max(1) as f64;
    image.iter().map(|&v| v >= rel * mean && v > 0.0).collect()
}

/// The image term's part of `D` and the whole `D`, before the floor.
fn jacobi_parts(obj: &Objective, term: &LevelTerm<'_>, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = obj.param.var_of.len();
    let nv = obj.param.nv();
    let mut pts = vec![[0.0f64; 2]; n];
    obj.param.points_into(x, &mut pts);
    let d_points = image_curvature(term, &pts);
    let rows = obj.param.rows();
    let mut d = vec![0.0; 2 * nv];
    for (p, row) in rows.iter().enumerate() {
        for &(k, c) in row {
            d[k] += d_points[p][0] * c * c;
            d[nv + k] += d_points[p][1] * c * c;
        }
    }
    let image = d.clone();
    for r in obj.rows() {
        // A landmark row is rank one: its curvature `2 w |b|^2` lies along one direction of
        // the row's `m` points, so each point gets the mean over directions, `2 w b_p^2 / m`.
        let m = r.row.len().max(1) as f64;
        for &(p, b) in &r.row {
            for &(k, c) in &rows[p] {
                let v = 2.0 * r.weight * b * b * c * c / m;
                d[k] += v;
                d[nv + k] += v;
            }
        }
    }
    for (k, v) in obj.bending_diagonal().into_iter().enumerate() {
        d[k] += 2.0 * obj.bend * v;
        d[nv + k] += 2.0 * obj.bend * v;
    }
    (image, d)
}

/// Runs the spline stage at one level from `x`; returns the new `x` and the level's report.
pub fn run_level(
    obj: &Objective,
    term: &LevelTerm<'_>,
    x: Vec<f64>,
    level: u32,
    max_iters: u64,
    (progress, cancel): (Option<&Progress>, &crate::cancel::Cancel),
) -> (Vec<f64>, LevelReport) {
    let t0 = Instant::now();
    let sd: Vec<f64> = jacobi(obj, term, &x).iter().map(|v| v.sqrt()).collect();
    // The samples of the run: those inside FIXED at its start ([`Membership`]).
    let keep = {
        let mut pts = vec![[0.0f64; 2]; obj.param.var_of.len()];
        obj.param.points_into(&x, &mut pts);
        term.membership(&pts)
    };
    // In z = sqrt(D) x: F(z / sqrt(D)), gradient grad_x / sqrt(D).
    let eval = |z: &[f64]| {
        let xs: Vec<f64> = z.iter().zip(&sd).map(|(a, s)| a / s).collect();
        let (f, mut g, _) = total_kept(obj, term, &xs, Some(&keep));
        g.iter_mut().zip(&sd).for_each(|(a, s)| *a /= s);
        (f, g)
    };
    let metric_at = |x: &[f64]| {
        let mut pts = vec![[0.0f64; 2]; obj.param.var_of.len()];
        obj.param.points_into(x, &mut pts);
        term.eval(&pts, false).0
    };
    let before = metric_at(&x);
    let cb = progress.map(|p| {
        let p = p.clone();
        let stage = format!("spline level {level}");
        std::sync::Arc::new(move |it: u64, c: f64| p(&stage, it, c)) as crate::fit::optim::Progress
    });
    // Preconditioned, -grad_z is about a Newton step; the first step still moves no variable
    // by more than half a pixel of the level in x (z changes by sqrt(D_k) per pixel).
    let smallest = sd.iter().copied().fold(f64::INFINITY, f64::min);
    let first_step = Some(0.5 * (1u64 << level) as f64 * smallest.max(1e-300));
    let opts =
        MinimizeOptions { max_iters, tol_grad: 1e-12, tol_cost: 1e-12, memory: 10, first_step };
    let variables = x.len();
    let z0: Vec<f64> = x.iter().zip(&sd).map(|(a, s)| a * s).collect();
    let mut m = minimize(&eval, z0, &opts, cb, cancel);
    m.x.iter_mut().zip(&sd).for_each(|(a, s)| *a /= s);
    let after = metric_at(&m.x);
    let report = LevelReport {
        stage: "spline".into(),
        level,
        samples: term.set.len(),
        variables,
        iterations: m.iterations,
        evaluations: m.evaluations,
        termination: m.termination,
        metric_before: before,
        metric_after: after,
        time_ms: t0.elapsed().as_secs_f64() * 1e3,
        triangles: None,
    };
    (m.x, report)
}
