//! Smooth minimization through `argmin`: a cost with its analytic gradient, run by argmin's
//! `Executor` with its L-BFGS solver (Nocedal & Wright, *Numerical Optimization*, 2nd ed.,
//! Alg. 7.4 and 7.5) and More-Thuente line search (strong Wolfe conditions).
//!
//! [`Smooth`] adapts a closure `x -> (F(x), grad F(x))` to argmin's `CostFunction` and
//! `Gradient`: the line search asks for both at the same trial points, so the last
//! evaluation is cached and each trial point is evaluated once. The best point evaluated is
//! kept too, so a run that ends in a failed line search (argmin returns an error then)
//! still returns the best point it reached, with [`Termination::NoDescent`].
//!
//! The termination reason is typed ([`Termination`]) and written into every report by its
//! snake-case name.

use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{
    CostFunction, Error, Executor, Gradient, IterState, State, TerminationReason,
    TerminationStatus, KV,
};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;
use serde::Serialize;
use std::sync::{Arc, Mutex};

/// Why an optimization stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    /// A convergence test held (gradient or cost change below its tolerance).
    Converged,
    /// The iteration cap was reached.
    MaxIterations,
    /// No step length decreased the cost (line search failed): the best point is kept.
    NoDescent,
    /// Nothing to optimize (no variables, or the start is already optimal).
    Exact,
    /// The caller's [`crate::cancel::Cancel`] token was set: stopped after an iteration,
    /// the best point so far kept.
    Cancelled,
}

impl Termination {
    /// The name written in reports.
    pub fn name(self) -> &'static str {
        match self {
            Termination::Converged => "converged",
            Termination::MaxIterations => "max_iterations",
            Termination::NoDescent => "no_descent",
            Termination::Exact => "exact",
            Termination::Cancelled => "cancelled",
        }
    }

    fn from_argmin(r: &TerminationReason) -> Termination {
        match r {
            TerminationReason::MaxItersReached => Termination::MaxIterations,
            TerminationReason::SolverConverged | TerminationReason::TargetCostReached => {
                Termination::Converged
            }
            _ => Termination::NoDescent,
        }
    }
}

/// Options of [`minimize`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MinimizeOptions {
    /// Iteration cap.
    pub max_iters: u64,
    /// Stop when the gradient's norm falls below this.
    pub tol_grad: f64,
    /// Stop when the cost changes by less than this between iterations.
    pub tol_cost: f64,
    /// L-BFGS memory (pairs kept).
    pub memory: usize,
    /// The largest change of one variable in the first step (`None`: the raw gradient
    /// step). L-BFGS has no curvature information at its first step and takes `-grad F`;
    /// the cost is scaled by `first_step / |grad F(x0)|_inf` so that this step moves no
    /// variable by more than `first_step` (the scale does not change the minimizer, and
    /// L-BFGS's later steps do not depend on it). Costs are reported unscaled.
    pub first_step: Option<f64>,
}

impl Default for MinimizeOptions {
    fn default() -> Self {
        MinimizeOptions {
            max_iters: 100,
            tol_grad: 1e-8,
            tol_cost: 1e-9,
            memory: 7,
            first_step: None,
        }
    }
}

/// The result of [`minimize`].
#[derive(Clone, Debug, PartialEq)]
pub struct Minimum {
    /// The best point evaluated.
    pub x: Vec<f64>,
    /// Its cost.
    pub cost: f64,
    /// Solver iterations.
    pub iterations: u64,
    /// Cost and gradient evaluations.
    pub evaluations: u64,
    /// Why the run stopped.
    pub termination: Termination,
}

/// The line search stops bracketing when its interval is narrower than this fraction of
/// the step (argmin's default, `1e-10`, spends dozens of evaluations on a cost with tiny
/// jumps, such as an image metric whose samples enter and leave the image).
pub const LINE_WIDTH_TOLERANCE: f64 = 1e-3;

type Eval<'a> = dyn Fn(&[f64]) -> (f64, Vec<f64>) + Sync + 'a;

/// A smooth cost for argmin: `eval(x) = (F(x), grad F(x))`, cached (see the module docs).
pub struct Smooth<'a> {
    eval: &'a Eval<'a>,
    seen: &'a Seen,
}

/// An evaluated point: `(x, F(x), grad F(x))`.
type Point = (Vec<f64>, f64, Vec<f64>);

/// What a [`Smooth`] remembers: the last evaluation, the best point and the count.
#[derive(Default)]
pub struct Seen {
    last: Mutex<Option<Point>>,
    best: Mutex<Option<(f64, Vec<f64>)>>,
    count: Mutex<u64>,
}

impl<'a> Smooth<'a> {
    /// Wraps `eval`, remembering into `seen`.
    pub fn new(eval: &'a Eval<'a>, seen: &'a Seen) -> Smooth<'a> {
        Smooth { eval, seen }
    }

    fn at(&self, x: &[f64]) -> (f64, Vec<f64>) {
        let seen = self.seen;
        let mut last = seen.last.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((lx, f, g)) = last.as_ref() {
            if lx.as_slice() == x {
                return (*f, g.clone());
            }
        }
        let (f, g) = (self.eval)(x);
        *seen.count.lock().unwrap_or_else(|e| e.into_inner()) += 1;
        let mut best = seen.best.lock().unwrap_or_else(|e| e.into_inner());
        if f.is_finite() && best.as_ref().is_none_or(|(bf, _)| f < *bf) {
            *best = Some((f, x.to_vec()));
        }
        *last = Some((x.to_vec(), f, g.clone()));
        (f, g)
    }
}

impl CostFunction for Smooth<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
        Ok(self.at(x).0)
    }
}

impl Gradient for Smooth<'_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, x: &Vec<f64>) -> Result<Vec<f64>, Error> {
        Ok(self.at(x).1)
    }
}

/// Called after every iteration with `(iteration, cost)`.
pub type Progress = Arc<dyn Fn(u64, f64) + Send + Sync>;

/// Reports each iteration to the caller's progress (if any) and stops the run (an error the
/// `Executor` passes up) once the cancel token is set.
struct Observer(Option<Progress>, f64, crate::cancel::Cancel);

impl Observe<IterState<Vec<f64>, Vec<f64>, (), (), (), f64>> for Observer {
    fn observe_iter(
        &mut self,
        state: &IterState<Vec<f64>, Vec<f64>, (), (), (), f64>,
        _kv: &KV,
    ) -> Result<(), Error> {
        if let Some(p) = &self.0 {
            p(state.get_iter(), state.get_cost() / self.1);
        }
        self.2.check()?;
        Ok(())
    }
}

/// Minimizes `eval` from `x0` by L-BFGS under argmin's `Executor` (module docs).
/// `progress`, when given, observes every iteration; a set `cancel` token stops the run
/// after the current iteration ([`Termination::Cancelled`], the best point kept).
pub fn minimize(
    eval: &Eval<'_>,
    x0: Vec<f64>,
    opts: &MinimizeOptions,
    progress: Option<Progress>,
    cancel: &crate::cancel::Cancel,
) -> Minimum {
    let (f0, g0) = eval(&x0);
    if x0.is_empty() || opts.max_iters == 0 {
        return Minimum {
            x: x0,
            cost: f0,
            iterations: 0,
            evaluations: 1,
            termination: Termination::Exact,
        };
    }
    let gmax = g0.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let k = match opts.first_step {
        Some(step) if gmax > 0.0 && gmax.is_finite() && step > 0.0 => step / gmax,
        _ => 1.0,
    };
    let scaled = |x: &[f64]| {
        let (f, mut g) = eval(x);
        g.iter_mut().for_each(|v| *v *= k);
        (f * k, g)
    };
    let seen = Seen::default();
    let problem = Smooth::new(&scaled, &seen);
    problem.at(&x0);
    let line = MoreThuenteLineSearch::new().with_width_tolerance(LINE_WIDTH_TOLERANCE);
    let solver = line
        .and_then(|line| LBFGS::new(line, opts.memory.max(1)).with_tolerance_grad(opts.tol_grad))
        .and_then(|s| s.with_tolerance_cost(opts.tol_cost));
    let run = solver.and_then(|solver| {
        let mut ex = Executor::new(problem, solver)
            .configure(|state| state.param(x0.clone()).max_iters(opts.max_iters))
            .timer(false);
        if progress.is_some() || *cancel != crate::cancel::Cancel::never() {
            ex = ex.add_observer(Observer(progress, k, cancel.clone()), ObserverMode::Always);
        }
        ex.run()
    });
    let evaluations = *seen.count.lock().unwrap_or_else(|e| e.into_inner());
    let (bf, bx) = seen
        .best
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone()
        .map_or((f0, x0.clone()), |(f, x)| (f / k, x));
    match run {
        Ok(res) => {
            let state = res.state();
            let termination = match state.get_termination_status() {
                TerminationStatus::Terminated(r) => Termination::from_argmin(r),
                TerminationStatus::NotTerminated => Termination::MaxIterations,
            };
            Minimum { x: bx, cost: bf, iterations: state.get_iter(), evaluations, termination }
        }
        Err(_) if cancel.is_cancelled() => Minimum {
            x: bx,
            cost: bf,
            iterations: 0,
            evaluations,
            termination: Termination::Cancelled,
        },
        // A failed line search: no step length gave a decrease; keep the best point.
        Err(_) => Minimum {
            x: bx,
            cost: bf,
            iterations: 0,
            evaluations,
            termination: Termination::NoDescent,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lbfgs_minimizes_the_rosenbrock_function_under_the_executor() {
        let eval = |x: &[f64]| {
            let (a, b) = (x[0], x[1]);
            let f = (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2);
            let g = vec![-2.0 * (1.0 - a) - 400.0 * a * (b - a * a), 200.0 * (b - a * a)];
            (f, g)
        };
        let seen = Arc::new(Mutex::new(0u64));
        let s2 = seen.clone();
        let m = minimize(
            &eval,
            vec![-1.2, 1.0],
            &MinimizeOptions { max_iters: 200, ..Default::default() },
            Some(Arc::new(move |_, _| *s2.lock().unwrap() += 1)),
            &crate::cancel::Cancel::never(),
        );
        assert!((m.x[0] - 1.0).abs() < 1e-4 && (m.x[1] - 1.0).abs() < 1e-4, "{m:?}");
        assert_eq!(m.termination, Termination::Converged);
        assert_eq!(*seen.lock().unwrap(), m.iterations);
    }

    #[test]
    fn a_cancel_token_stops_the_run_after_the_iteration_that_set_it() {
        let eval = |x: &[f64]| {
            let (a, b) = (x[0], x[1]);
            let f = (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2);
            let g = vec![-2.0 * (1.0 - a) - 400.0 * a * (b - a * a), 200.0 * (b - a * a)];
            (f, g)
        };
        let cancel = crate::cancel::Cancel::new();
        let (c2, seen) = (cancel.clone(), Arc::new(Mutex::new(0u64)));
        let s2 = seen.clone();
        let m = minimize(
            &eval,
            vec![-1.2, 1.0],
            &MinimizeOptions { max_iters: 200, ..Default::default() },
            Some(Arc::new(move |it, _| {
                *s2.lock().unwrap() = it;
                if it >= 5 {
                    c2.cancel();
                }
            })),
            &cancel,
        );
        assert_eq!(m.termination, Termination::Cancelled);
        assert_eq!(*seen.lock().unwrap(), 5, "no iteration after the one that cancelled");
        assert!(m.cost < 24.2, "the best point so far is kept: {}", m.cost);
        assert_eq!(serde_json::to_string(&m.termination).unwrap(), "\"cancelled\"");
    }

    #[test]
    fn the_iteration_cap_is_reported_as_such() {
        let eval = |x: &[f64]| {
            let f = (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
            let g = vec![
                -2.0 * (1.0 - x[0]) - 400.0 * x[0] * (x[1] - x[0] * x[0]),
                200.0 * (x[1] - x[0] * x[0]),
            ];
            (f, g)
        };
        let m = minimize(
            &eval,
            vec![-1.2, 1.0],
            &MinimizeOptions { max_iters: 3, ..Default::default() },
            None,
            &crate::cancel::Cancel::never(),
        );
        assert_eq!(m.termination, Termination::MaxIterations);
        assert_eq!(m.iterations, 3);
        assert_eq!(serde_json::to_string(&m.termination).unwrap(), "\"max_iterations\"");
    }
}
