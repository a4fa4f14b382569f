//! Newton's method for the fit with the fold barrier on, with a certified line search, as an
//! argmin `Solver` ([`CertifiedNewton`]) run by argmin's `Executor` ([`newton`]).
//!
//! The objective `F` ([`super::objective`]) is the data term, the bending energy and the
//! barrier `mu sum_s w_s beta(det J(s))` over the `det J` samples. Its Gauss-Newton Hessian
//! in the variables `x` (both coordinates, `2 nv x 2 nv`) is
//!
//! ```text
//!   H = sum_i w_i psi(r_i) a_i a_i^T (per coordinate)  +  2 lambda K (per coordinate)
//!     + mu sum_s w_s beta''(det_s) g_s g_s^T,          g_s = d det_s / d x,
//! ```
//!
//! with `psi = rho'(r) / r` (2 for squares: the data and bending parts are exact) and the
//! barrier's term kept to its positive semidefinite part (`beta` is convex; the dropped
//! `beta' d^2 det / dx^2` is indefinite). `H` is sparse (a triangle couples only the variables
//! its patch depends on) and factored by a sparse Cholesky ([`super::sparse`]) with a
//! pattern built once. Each step `dx = -H^-1 grad F` is searched backwards from length 1
//! (Armijo, `c = 1e-4`); a trial point is accepted only if the caller's certificate proves
//! `det J > 0` on every triangle, so every accepted iterate, and the result, is certified
//! fold-free when the start is. The run stops when the Newton decrement
//! `-grad F . dx / 2` (the decrease the step predicts) falls below
//! `max(NEWTON_TOL * max(1, F), NEWTON_TOL_PX^2 * sum_i w_i)`, when no step length
//! decreases `F`, or at the iteration cap; [`Outcome::termination`] says which. The second
//! bound is what moving every landmark by [`NEWTON_TOL_PX`] would change in the data term:
//! below it, further steps cannot move the fit by a visible amount. (The Hessian drops the
//! barrier's indefinite part, so near an optimum where the barrier acts the iterates
//! converge linearly and slowly: on 80 landmarks under a 2.5 rad swirl, 200 iterations
//! (10 s) ended at the cap with the fit long settled; the bound stops them after 70.)

use super::error::FitError;
use super::objective::{det_gradient, sample_jacobian, Objective, TriangleBlock as TriInfo};
use super::report::FitTermination;
use super::sparse::Pattern;
use argmin::core::{
    CostFunction, Error as ArgminError, Executor, Gradient, IterState, Problem, Solver, State,
    TerminationReason, KV,
};

/// Relative size of the Newton decrement at which the run stops.
pub const NEWTON_TOL: f64 = 1e-10;

/// Landmark displacement (pixels) whose effect on the data term bounds the Newton
/// decrement at which the run stops (see the module docs).
pub const NEWTON_TOL_PX: f64 = 1e-3;

/// Halvings of the step before the line search gives up.
const MAX_HALVINGS: usize = 40;

/// How a Newton run ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The result.
    pub x: Vec<f64>,
    /// Newton iterations.
    pub iterations: u64,
    /// `Converged`, `NoDescent` (no step length decreases F) or `IterationCap`.
    pub termination: FitTermination,
}

/// The Hessian's structure and the fixed parts of its values.
struct Structure {
    nv: usize,
    tris: Vec<TriInfo>,
    /// Each data row over its triangle's variables: `(position in `local`, coefficient)`.
    rows: Vec<Vec<(usize, f64)>>,
    /// The data rows of each triangle (a landmark's row lies within its triangle's block,
    /// so the data add values to the triangles' blocks and no entry: the pattern does not
    /// grow with the number of landmarks).
    rows_of: Vec<Vec<usize>>,
    pattern: Pattern,
}

impl Structure {
    fn new(obj: &Objective) -> Result<Structure, FitError> {
        let nv = obj.param.nv();
        let tris = obj.triangle_blocks();
        let mut rows_of = vec![Vec::new(); tris.len()];
        let rows = obj
            .variable_rows()
            .into_iter()
            .zip(obj.rows())
            .enumerate()
            .map(|(i, ((row, _, _), dr))| {
                let local = &tris[dr.triangle].local;
                rows_of[dr.triangle].push(i);
                row.iter()
                    .map(|&(v, a)| {
                        let z = local.iter().position(|&l| l == v).ok_or_else(|| {
                            FitError::Internal(format!(
                                "a landmark's variable {v} is not one of its triangle's"
                            ))
                        })?;
                        Ok((z, a))
                    })
                    .collect::<Result<Vec<_>, FitError>>()
            })
            .collect::<Result<Vec<_>, FitError>>()?;
        let mut entries = Vec::new();
        Self::visit(nv, &tris, |r, c| entries.push((r, c)));
        let pattern =
            Pattern::new(2 * nv, &entries).map_err(|e| FitError::Solver(e.to_string()))?;
        Ok(Structure { nv, tris, rows, rows_of, pattern })
    }

    /// Visits the pattern's entries in their fixed order: per triangle the xx block's lower
    /// triangle, the yy block's, the yx block; the diagonal.
    fn visit(nv: usize, tris: &[TriInfo], mut f: impl FnMut(usize, usize)) {
        for t in tris {
            let l = &t.local;
            for off in [0, nv] {
                for &a in l {
                    for &b in l {
                        if a >= b {
                            f(a + off, b + off);
                        }
                    }
                }
            }
            for &a in l {
                for &b in l {
                    f(a + nv, b);
                }
            }
        }
        for i in 0..2 * nv {
            f(i, i);
        }
    }

    /// The Hessian's values at `x` in the pattern's order, with `ridge` on the diagonal.
    fn values(&self, obj: &Objective, x: &[f64], ridge: f64, out: &mut Vec<f64>) {
        let nv = self.nv;
        out.clear();
        let mut p = vec![[0.0f64; 2]; obj.param.var_of.len()];
        obj.param.points_into(x, &mut p);
        let lambda = obj.bend;
        let (mu, barrier) = match obj.barrier {
            Some(b) => (b.mu, Some(b)),
            None => (0.0, None),
        };
        let mut q = [[0.0f64; 2]; 64];
        let mut gx: Vec<f64> = Vec::new();
        let mut gy: Vec<f64> = Vec::new();
        let mut bx: Vec<f64> = Vec::new();
        let mut by: Vec<f64> = Vec::new();
        let mut bxy: Vec<f64> = Vec::new();
        // The data rows' Gauss-Newton weights w_i psi(r_i).
        let res = obj.residual_lengths(x);
        let data: Vec<f64> =
            obj.rows().iter().zip(&res).map(|(dr, r)| dr.weight * obj.loss.eval(*r).1).collect();
        for ((tri, info), mine) in obj.tris().iter().zip(&self.tris).zip(&self.rows_of) {
            let (m, u) = (tri.patch.len(), info.local.len());
            for (a, &j) in tri.patch.iter().enumerate() {
                q[a] = p[j];
            }
            bx.clear();
            bx.extend(info.bend.iter().map(|v| 2.0 * lambda * v));
            by.clear();
            by.extend_from_slice(&bx);
            bxy.clear();
            bxy.resize(u * u, 0.0);
            if let Some(b) = barrier {
                for [dx, dy] in &tri.samples {
                    let (j, det) = sample_jacobian(dx, dy, &q[..m]);
                    let (_, _, d2) = b.eval2(det);
                    if d2 == 0.0 {
                        continue;
                    }
                    let f = mu * tri.sample_weight * d2;
                    gx.clear();
                    gx.resize(u, 0.0);
                    gy.clear();
                    gy.resize(u, 0.0);
                    for a in 0..m {
                        let da = det_gradient(dx[a], dy[a], &j);
                        for z in 0..u {
                            let s = info.st[a * u + z];
                            if s != 0.0 {
                                gx[z] += s * da[0];
                                gy[z] += s * da[1];
                            }
                        }
                    }
                    for z1 in 0..u {
                        for z2 in 0..u {
                            bx[z1 * u + z2] += f * gx[z1] * gx[z2];
                            by[z1 * u + z2] += f * gy[z1] * gy[z2];
                            bxy[z1 * u + z2] += f * gy[z1] * gx[z2];
                        }
                    }
                }
            }
            for &i in mine {
                let row = &self.rows[i];
                for &(z1, va) in row {
                    for &(z2, vb) in row {
                        let v = data[i] * va * vb;
                        bx[z1 * u + z2] += v;
                        by[z1 * u + z2] += v;
                    }
                }
            }
            let l = &info.local;
            for blk in [&bx, &by] {
                for (z1, &a) in l.iter().enumerate() {
                    for (z2, &b) in l.iter().enumerate() {
                        if a >= b {
                            out.push(blk[z1 * u + z2]);
                        }
                    }
                }
            }
            out.extend_from_slice(&bxy);
        }
        out.extend(std::iter::repeat_n(ridge, 2 * nv));
        debug_assert_eq!(out.len(), self.pattern.len());
    }
}

/// The fit's objective as an argmin problem (cost and gradient of [`Objective::eval`]).
pub struct FitProblem<'a>(pub &'a Objective);

impl CostFunction for FitProblem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, ArgminError> {
        Ok(self.0.eval(x, None).total)
    }
}

impl Gradient for FitProblem<'_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, x: &Vec<f64>) -> Result<Vec<f64>, ArgminError> {
        let mut g = vec![0.0; x.len()];
        self.0.eval(x, Some(&mut g));
        Ok(g)
    }
}

type NewtonState = IterState<Vec<f64>, Vec<f64>, (), (), (), f64>;

/// Newton's method with the fold barrier and the certified backtracking line search (module
/// docs) as an argmin [`Solver`]: one `next_iter` is one Newton step (Hessian values,
/// sparse Cholesky with a growing ridge when it fails, the step, the certified line
/// search). It ends the run itself with `SolverConverged` (the decrement is below the
/// tolerance) or `SolverExit("no descent")`; argmin's `Executor` adds the iteration cap.
pub struct CertifiedNewton<'a> {
    obj: &'a Objective,
    st: Structure,
    pairs: Vec<(usize, usize)>,
    require: bool,
    certify: &'a dyn Fn(&[[f64; 2]]) -> bool,
    cancel: crate::cancel::Cancel,
    ridge_scale: f64,
    settled: f64,
    /// The last step's factor and Hessian values, whose buffers the next step reuses.
    spare: Option<crate::sparse::Factor>,
    vals: Vec<f64>,
}

impl<'a> CertifiedNewton<'a> {
    /// The solver for `obj`; see [`newton`] for `require` and `certify`.
    pub fn new(
        obj: &'a Objective,
        require: bool,
        certify: &'a dyn Fn(&[[f64; 2]]) -> bool,
    ) -> Result<CertifiedNewton<'a>, FitError> {
        let st = Structure::new(obj)?;
        let pairs = pattern_pairs(&st);
        let settled =
            NEWTON_TOL_PX * NEWTON_TOL_PX * obj.rows().iter().map(|r| r.weight).sum::<f64>();
        Ok(CertifiedNewton {
            obj,
            st,
            pairs,
            require,
            certify,
            cancel: crate::cancel::Cancel::never(),
            ridge_scale: 1e-12,
            settled,
            spare: None,
            vals: Vec::new(),
        })
    }
}

impl<'a> Solver<FitProblem<'a>, NewtonState> for CertifiedNewton<'a> {
    fn name(&self) -> &str {
        "certified Newton"
    }

    fn init(
        &mut self,
        problem: &mut Problem<FitProblem<'a>>,
        state: NewtonState,
    ) -> Result<(NewtonState, Option<KV>), ArgminError> {
        let x = state.get_param().cloned().unwrap_or_default();
        let f = problem.cost(&x)?;
        let g = problem.gradient(&x)?;
        Ok((state.param(x).cost(f).gradient(g), None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<FitProblem<'a>>,
        mut state: NewtonState,
    ) -> Result<(NewtonState, Option<KV>), ArgminError> {
        if self.cancel.is_cancelled() {
            return Err(FitError::Cancelled.into());
        }
        let obj = self.obj;
        let nv = obj.param.nv();
        let x = state.take_param().unwrap_or_default();
        let g = state.take_gradient().unwrap_or_default();
        let f = state.get_cost();
        let mut vals = std::mem::take(&mut self.vals);
        vals.clear();
        self.st.values(obj, &x, 0.0, &mut vals);
        let mean_diag = {
            let mut s = 0.0;
            for (&(r, c), v) in self.pairs.iter().zip(&vals) {
                if r == c {
                    s += v;
                }
            }
            (s / (2 * nv) as f64).max(f64::MIN_POSITIVE)
        };
        let n = vals.len();
        let factor = loop {
            for v in &mut vals[n - 2 * nv..] {
                *v = self.ridge_scale * mean_diag;
            }
            match self.st.pattern.refactor(&vals, self.spare.take()) {
                Ok(fa) => break fa,
                Err(_) if self.ridge_scale < 1e-2 => self.ridge_scale *= 100.0,
                Err(e) => return Err(FitError::Solver(e.to_string()).into()),
            }
        };
        let mut dx: Vec<f64> = g.iter().map(|v| -v).collect();
        factor.solve(&mut dx);
        self.spare = Some(factor);
        self.vals = vals;
        let slope: f64 = g.iter().zip(&dx).map(|(a, b)| a * b).sum();
        if -slope * 0.5 < (NEWTON_TOL * f.abs().max(1.0)).max(self.settled) {
            let state = state.param(x).cost(f).gradient(g);
            return Ok((state.terminate_with(TerminationReason::SolverConverged), None));
        }
        let mut pts = vec![[0.0f64; 2]; obj.param.var_of.len()];
        let mut alpha = 1.0;
        let mut xt = vec![0.0; 2 * nv];
        for _ in 0..MAX_HALVINGS {
            for ((t, a), d) in xt.iter_mut().zip(&x).zip(&dx) {
                *t = a + alpha * d;
            }
            let ok = !self.require || {
                obj.param.points_into(&xt, &mut pts);
                (self.certify)(&pts)
            };
            if ok {
                let t = obj.eval(&xt, None);
                // With a certified start the iterates also stay above the barrier's floor
                // (its finite continuation below is for uncertified starts only).
                let inside = !self.require || obj.barrier.is_none_or(|b| t.min_det > b.floor);
                let ft = t.total;
                if inside && ft.is_finite() && ft <= f + 1e-4 * alpha * slope {
                    let gt = problem.gradient(&xt)?;
                    return Ok((state.param(xt).cost(ft).gradient(gt), None));
                }
            }
            alpha *= 0.5;
        }
        let state = state.param(x).cost(f).gradient(g);
        Ok((state.terminate_with(TerminationReason::SolverExit(NO_DESCENT.into())), None))
    }
}

/// The termination of a Newton run that found no step length decreasing the cost.
const NO_DESCENT: &str = FitTermination::NoDescent.name();

/// Runs Newton's method from `start` (see the module docs) as [`CertifiedNewton`] under
/// argmin's `Executor`. `certify` receives the control points of a trial iterate and
/// answers whether `det J > 0` is proven on every triangle; with `require`, trial points it
/// refuses, or whose sampled `det J` is not above the barrier's floor, are never accepted
/// (the start must satisfy both). A set `cancel` token stops it before the next iteration
/// with [`FitError::Cancelled`].
pub fn newton(
    obj: &Objective,
    start: &[f64],
    max_iters: u64,
    (require, cancel): (bool, &crate::cancel::Cancel),
    certify: &dyn Fn(&[[f64; 2]]) -> bool,
) -> Result<Outcome, FitError> {
    if max_iters == 0 {
        return Ok(Outcome {
            x: start.to_vec(),
            iterations: 0,
            termination: FitTermination::IterationCap,
        });
    }
    let mut solver = CertifiedNewton::new(obj, require, certify)?;
    solver.cancel = cancel.clone();
    let res = Executor::new(FitProblem(obj), solver)
        .configure(|state| state.param(start.to_vec()).max_iters(max_iters))
        .timer(false)
        .run()
        .map_err(|e| match e.downcast::<FitError>() {
            Ok(fe) => fe,
            Err(other) => FitError::Solver(other.to_string()),
        })?;
    let state = res.state();
    let termination = match state.get_termination_reason() {
        Some(TerminationReason::SolverConverged) => FitTermination::Converged,
        Some(TerminationReason::SolverExit(why)) if why == NO_DESCENT => FitTermination::NoDescent,
        _ => FitTermination::IterationCap,
    };
    let x = state.get_param().cloned().unwrap_or_else(|| start.to_vec());
    Ok(Outcome { x, iterations: state.get_iter(), termination })
}

fn pattern_pairs(st: &Structure) -> Vec<(usize, usize)> {
    let mut v = Vec::with_capacity(st.pattern.len());
    Structure::visit(st.nv, &st.tris, |r, c| v.push((r, c)));
    v
}
