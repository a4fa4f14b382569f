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
//! from the level before (the same spline space at every level: the coarse levels see
//! blurred images, not a coarser spline).

use super::image::Level;
use super::metric::Metric;
use super::samples::{image_term, SampleOptions, SampleSet, SplineSamples};
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
        let u = self.on_mesh.map(pts);
        let term = image_term(self.metric, self.fixed, &self.set, &u, grad);
        let g = if grad { self.on_mesh.pull(&term.d_u, pts.len()) } else { Vec::new() };
        (term.value, g, term.valid)
    }
}

/// `F(x)` and its gradient (module docs) for the objective `obj` (bending, landmarks,
/// barrier) and the image term `term`.
pub fn total(obj: &Objective, term: &LevelTerm<'_>, x: &[f64]) -> (f64, Vec<f64>, f64) {
    let n = obj.param.var_of.len();
    let mut gx = vec![0.0; x.len()];
    let t = obj.eval(x, Some(&mut gx));
    let mut pts = vec![[0.0f64; 2]; n];
    obj.param.points_into(x, &mut pts);
    let (e, mut g, valid) = term.eval(&pts, true);
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

/// Runs the spline stage at one level from `x`; returns the new `x` and the level's report.
pub fn run_level(
    obj: &Objective,
    term: &LevelTerm<'_>,
    x: Vec<f64>,
    level: u32,
    max_iters: u64,
    progress: Option<&Progress>,
) -> (Vec<f64>, LevelReport) {
    let t0 = Instant::now();
    let eval = |x: &[f64]| {
        let (f, g, _) = total(obj, term, x);
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
    // A first step of at most half a pixel of the level per control point.
    let first_step = Some(0.5 * (1u64 << level) as f64);
    let opts =
        MinimizeOptions { max_iters, tol_grad: 1e-10, tol_cost: 1e-9, memory: 10, first_step };
    let variables = x.len();
    let m = minimize(&eval, x, &opts, cb);
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
    };
    (m.x, report)
}
