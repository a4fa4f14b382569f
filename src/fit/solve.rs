//! The soft fit: the objective's variables, the solver runs and the exact result. The entry
//! point, [`super::fit`], runs it, or the exact fit of [`super::hard`] which starts from it.
//!
//! 1. The landmarks' source points are located in the mesh (each gives a fixed row over the
//!    control points); the variables are the free points of the spline's minimal determining
//!    set, all of them or those within `radius` control-net steps of the landmarks'
//!    triangles ([`super::param`]), less the pinned ones (and, with
//!    [`FitOptions::pin_border`], every free point the border depends on).
//! 2. *Squares*: the exact minimizer of data plus bending, computed in landmark space
//!    ([`super::smooth`]) with the scale-free bending weight chosen by exact leave-one-out
//!    cross-validation ([`Bend::Auto`]) or given; above [`LANDMARK_SPACE_MAX`] landmarks, in
//!    variable space with one sparse factorization per weight and the weight chosen by GCV
//!    with a randomized trace ([`super::smooth_sparse`]; the report's `bend_criterion` says
//!    which). *Huber, Cauchy*: iteratively reweighted squares on the same smoother.
//! 3. *Barrier*: if some `det J` sample of that minimizer is below the barrier's threshold,
//!    Newton's method with the barrier's Hessian ([`super::newton`]) runs from the best
//!    start whose `det J > 0` is certified (the minimizer itself, or the warm start); every
//!    accepted step is certified fold-free, so the result is.
//! 4. The `f64` result is made exact: variables rounded to multiples of `2^-20`, dependents
//!    recomputed in rational arithmetic by the MDS formulas, and the C1 conditions checked
//!    exactly ([`crate::spline::Spline::from_points`]). The saved deformation is therefore C1
//!    exactly, and can be edited further by hand.

use super::error::FitError;
use super::landmarks::Landmark;
use super::newton::newton;
use super::objective::{data_row, Loss, Objective, TriangleTerms};
use super::options::{Bend, FitOptions, MAX_FIT_VARIABLES, MAX_LANDMARK_VALUE};
use super::param::Param;
use super::report::{bend_weight, label, Fit, FitMethod, FitTermination, Solver};
use super::smooth::Smoother;
use super::smooth_sparse::{SparseSmoother, LANDMARK_SPACE_MAX};
use crate::edit::select::{neighborhood, Neighborhood, SelectIndex};
use crate::spline::jacobian::CertifyOptions;
use crate::spline::mds::Mds;
use crate::spline::Spline;
use std::time::Instant;

/// Checks landmark values (finite, at most [`MAX_LANDMARK_VALUE`] in magnitude, weight > 0).
pub fn validate(lms: &[Landmark]) -> Result<(), FitError> {
    for (index, l) in lms.iter().enumerate() {
        let bad = |why: &str| FitError::BadLandmark { index, name: label(l), why: why.into() };
        if !l.src.iter().chain(&l.dst).all(|v| v.is_finite()) {
            return Err(bad("a coordinate is not finite"));
        }
        if l.src.iter().chain(&l.dst).any(|v| v.abs() > MAX_LANDMARK_VALUE) {
            return Err(bad(
                "a coordinate is beyond 1e9 in magnitude; landmarks are in the image's pixels \
                 (rescale the file)",
            ));
        }
        if !(l.weight.is_finite() && l.weight > 0.0 && l.weight <= MAX_LANDMARK_VALUE) {
            return Err(bad("the weight must be finite, positive and at most 1e9"));
        }
    }
    Ok(())
}

fn check_options(o: &FitOptions) -> Result<(), FitError> {
    if let Bend::Weight(weight) = o.bend {
        if !(weight.is_finite() && weight >= 0.0) {
            return Err(FitError::BendWeight { weight });
        }
    }
    match o.loss {
        Loss::Huber(scale) | Loss::Cauchy(scale) if !(scale.is_finite() && scale > 0.0) => {
            return Err(FitError::LossScale { scale });
        }
        _ => {}
    }
    if let Some(b) = o.barrier {
        if !(b.floor.is_finite() && b.tau.is_finite() && b.tau > b.floor && b.mu > 0.0) {
            return Err(FitError::BarrierShape { barrier: b });
        }
    }
    if o.det_level == 0 || o.grid_bits == 0 || o.grid_bits > 60 {
        return Err(FitError::Sampling { det_level: o.det_level, grid_bits: o.grid_bits });
    }
    Ok(())
}

fn check_pinned(o: &FitOptions, n: usize) -> Result<(), FitError> {
    match o.pinned.iter().find(|p| p.index() >= n) {
        Some(&point) => Err(FitError::NoSuchPinned { point, points: n }),
        None => Ok(()),
    }
}

/// The variables' objective for these landmarks (exposed for tests and benches).
pub fn objective(s: &Spline, lms: &[Landmark], opts: &FitOptions) -> Result<Objective, FitError> {
    objective_with(s, &Mds::new(s)?, lms, opts)
}

/// [`objective`] with a prebuilt determining set.
pub fn objective_with(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
) -> Result<Objective, FitError> {
    objective_with_terms(s, mds, lms, opts, None)
}

/// [`objective_with`] with the triangles' terms possibly prebuilt (at `opts.det_level`).
fn objective_with_terms(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
    terms: Option<TriangleTerms>,
) -> Result<Objective, FitError> {
    check_options(opts)?;
    if lms.is_empty() {
        return Err(FitError::NoLandmarks);
    }
    validate(lms)?;
    let mut rows = Vec::with_capacity(lms.len());
    let mut tris = Vec::new();
    for (index, l) in lms.iter().enumerate() {
        let r = data_row(s, l.src, l.dst, l.weight).ok_or(FitError::OutsideMesh {
            index,
            name: label(l),
            x: l.src[0],
            y: l.src[1],
        })?;
        if let Some((t, _)) = s.mesh().locate(l.src, None) {
            tris.push(t);
        }
        rows.push(r);
    }
    let n = s.num_points();
    check_pinned(opts, n)?;
    let is_var = match opts.radius {
        None => vec![true; n],
        Some(r) => {
            let mut seeds: Vec<usize> =
                tris.iter().flat_map(|&t| s.layout().patches()[t].iter().copied()).collect();
            seeds.sort_unstable();
            seeds.dedup();
            let idx = SelectIndex::new(s);
            let mut is_var = vec![false; n];
            for p in
                seeds.iter().copied().chain(neighborhood(&idx, &seeds, &Neighborhood::Radius(r)))
            {
                is_var[p] = true;
            }
            is_var
        }
    };
    let mut is_var = is_var;
    for p in &opts.pinned {
        is_var[p.index()] = false;
    }
    let param =
        if opts.pin_border { border_closed(s, mds, is_var) } else { Param::new(s, mds, &is_var) };
    let terms = terms.unwrap_or_else(|| TriangleTerms::new(s, opts.det_level));
    let mut obj = Objective::with_terms(param, rows, opts.loss, 0.0, opts.barrier, terms);
    obj.bend_area = opts.bend_area;
    // lambda = bend * sum w * area (see `super::smooth`); with `Bend::Auto` the solver sets it.
    if let Bend::Weight(w) = opts.bend {
        obj.bend = w * lms.iter().map(|l| l.weight).sum::<f64>() * obj.reference_area();
    }
    Ok(obj)
}

/// The parameterization in which no control point of a border edge depends on a variable:
/// free points the border depends on are fixed too, until none is left.
fn border_closed(s: &Spline, mds: &Mds, mut is_var: Vec<bool>) -> Param {
    let m = s.mesh();
    let d = s.degree();
    let mut border: Vec<usize> = Vec::new();
    for e in 0..m.num_edges() {
        if m.is_border_edge(e) {
            let v = m.edges()[e].v;
            border.extend(v);
            border.extend((1..d).map(|k| m.num_vertices() + (d - 1) * e + (k - 1)));
        }
    }
    border.sort_unstable();
    border.dedup();
    for &p in &border {
        is_var[p] = false;
    }
    loop {
        let param = Param::new(s, mds, &is_var);
        let rows = param.rows();
        let mut changed = false;
        for &p in &border {
            for &(k, _) in &rows[p] {
                let q = param.vars[k];
                if is_var[q] {
                    is_var[q] = false;
                    changed = true;
                }
            }
        }
        if !changed {
            return param;
        }
    }
}

/// The soft fit (no landmark rows, no ECLES step; pinned free points do not vary).
pub(super) fn fit_soft(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
    start: Instant,
) -> Result<Fit, FitError> {
    fit_soft_terms(s, mds, lms, opts, start, None)
}

/// [`fit_soft`] with the triangles' terms possibly prebuilt.
pub(super) fn fit_soft_terms(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
    start: Instant,
    terms: Option<TriangleTerms>,
) -> Result<Fit, FitError> {
    let mut trace = crate::timing::Trace::new("fit");
    let mut obj = objective_with_terms(s, mds, lms, opts, terms)?;
    trace.mark("objective");
    let nv = obj.param.nv();
    let x0 = obj.param.x0();
    let out = if nv == 0 {
        Solved {
            x: x0.clone(),
            method: FitMethod::new(Solver::None),
            iterations: 0,
            bend: bend_weight(opts.bend),
            choice: None,
            termination: FitTermination::Exact,
        }
    } else {
        solve(&mut obj, s, &x0, opts)?
    };
    trace.mark("solve");
    // The costs (floating point) beside the exact points and their C1 check.
    let ((cost_initial, cost_final), fitted) = rayon::join(
        || (obj.eval(&x0, None).total, obj.eval(&out.x, None).total),
        || s.with_determined_points(mds, obj.param.rounded_points(s, &out.x, opts.grid_bits)),
    );
    let fitted = fitted?;
    trace.mark("exact points + C1 check | costs");
    crate::alloc::drop_in_background(obj);
    let mut rep = super::report::build(
        &fitted,
        lms,
        opts,
        out.method,
        nv,
        out.iterations,
        cost_initial,
        cost_final,
        start,
    )?;
    rep.bend = out.bend;
    rep.bend_auto = matches!(opts.bend, Bend::Auto);
    rep.gcv_rms = out.choice.map(|c| c.gcv_rms);
    rep.loo_rms = out.choice.and_then(|c| c.loo_rms);
    rep.bend_criterion = out.choice.map(|c| c.criterion);
    rep.termination = out.termination;
    trace.mark("report (residuals, certificate)");
    rep.conflicts = super::affine::crossing_pairs(lms)
        .into_iter()
        .map(|(i, j)| [i, j].map(|k| lms[k].name.clone().unwrap_or_else(|| format!("#{k}"))))
        .collect();
    Ok(Fit { spline: fitted, report: rep })
}

/// The squares fit of [`solve`]: in landmark space (few landmarks, exact leave-one-out) or
/// in variable space (many, [`super::smooth_sparse`]).
enum Smoothers {
    Landmarks(Smoother),
    Variables(SparseSmoother),
}

impl Smoothers {
    fn lambda(&self, bend: f64) -> f64 {
        match self {
            Smoothers::Landmarks(s) => s.lambda(bend),
            Smoothers::Variables(s) => s.lambda(bend),
        }
    }

    fn choose(&self) -> Result<Option<super::smooth::Choice>, FitError> {
        match self {
            Smoothers::Landmarks(s) => s.choose(),
            Smoothers::Variables(s) => s.choose(),
        }
    }

    fn solve(&self, bend: f64, scale: Option<&[f64]>) -> Result<Vec<f64>, FitError> {
        match self {
            Smoothers::Landmarks(s) => s.solve(bend, scale),
            Smoothers::Variables(s) => s.solve(bend, scale),
        }
    }
}

/// What [`solve`] found.
struct Solved {
    x: Vec<f64>,
    method: FitMethod,
    iterations: u64,
    bend: f64,
    choice: Option<super::smooth::Choice>,
    termination: FitTermination,
}

/// Iterations of reweighted squares for the robust losses.
pub const IRLS_ITERATIONS: usize = 50;
/// IRLS stops when no variable moves more than this (pixels).
pub const IRLS_TOL: f64 = 1e-7;

/// The solver runs of a soft fit (see the module docs). Sets `obj.bend` to `lambda`.
fn solve(
    obj: &mut Objective,
    s: &Spline,
    x0: &[f64],
    opts: &FitOptions,
) -> Result<Solved, FitError> {
    let nv = obj.param.nv();
    if nv > MAX_FIT_VARIABLES {
        return Err(FitError::TooLarge { variables: nv });
    }
    let mut trace = crate::timing::Trace::new("fit solve");
    let sm = if obj.rows().len() > LANDMARK_SPACE_MAX {
        Smoothers::Variables(SparseSmoother::new(obj)?)
    } else {
        Smoothers::Landmarks(Smoother::new(obj)?)
    };
    trace.mark("smoother");
    let choice = match opts.bend {
        Bend::Auto => sm.choose()?,
        Bend::Weight(_) => None,
    };
    trace.mark("cross-validated choice");
    let bend = choice.map_or(bend_weight(opts.bend), |c| c.bend);
    obj.bend = sm.lambda(bend);
    let mut x = sm.solve(bend, None)?;
    trace.mark("squares solve");
    let mut iterations = 1u64;
    let mut method = FitMethod::new(Solver::GaussNewton);
    if opts.loss != Loss::Squares {
        // IRLS: data weight w_i psi(r_i) / 2 (psi = rho'(r) / r), from the squares fit.
        method.solver = Solver::Irls;
        for _ in 0..IRLS_ITERATIONS {
            let scale: Vec<f64> =
                obj.residual_lengths(&x).iter().map(|&r| 0.5 * obj.loss.eval(r).1).collect();
            let next = sm.solve(bend, Some(&scale))?;
            iterations += 1;
            let step = next.iter().zip(&x).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            x = next;
            if step < IRLS_TOL {
                break;
            }
        }
    }
    let Some(barrier) = opts.barrier else {
        return Ok(Solved {
            x,
            method,
            iterations,
            bend,
            choice,
            termination: FitTermination::Exact,
        });
    };
    if obj.eval(&x, None).min_det >= barrier.tau {
        return Ok(Solved {
            x,
            method,
            iterations,
            bend,
            choice,
            termination: FitTermination::Exact,
        });
    }
    // Newton with the barrier from the best start that is certified fold-free and above the
    // barrier's floor: the squares minimizer or the warm start, whichever costs less.
    // Accepted iterates are certified with a margin, so that rounding the result to exact
    // values (about 2^-grid_bits px per point) cannot undo the proof.
    let margin = CERT_MARGIN * barrier.floor;
    let certify = |p: &[[f64; 2]]| certified(s, p, margin);
    let mut pts = vec![[0.0f64; 2]; obj.param.var_of.len()];
    let mut start: Option<(f64, Vec<f64>)> = None;
    for cand in [&x[..], x0] {
        let t = obj.eval(cand, None);
        obj.param.points_into(cand, &mut pts);
        if t.total.is_finite()
            && t.min_det > barrier.floor
            && start.as_ref().is_none_or(|(f, _)| t.total < *f)
            && certify(&pts)
        {
            start = Some((t.total, cand.to_vec()));
        }
    }
    let require = start.is_some();
    let start = start.map_or(x, |(_, v)| v);
    let out = newton(obj, &start, opts.max_iters, (require, &opts.cancel), &certify)?;
    Ok(Solved {
        x: out.x,
        method: FitMethod { newton: true, ..method },
        iterations: iterations + out.iterations,
        bend,
        choice,
        termination: out.termination,
    })
}

/// The certified lower bound of `det J` that Newton's accepted iterates keep, as a fraction
/// of the barrier's floor (which holds at the samples only).
pub const CERT_MARGIN: f64 = 0.1;

/// Whether `det J > margin` is proven on every triangle for control points `p` (`f64`).
fn certified(s: &Spline, p: &[[f64; 2]], margin: f64) -> bool {
    crate::spline::jacobian::certify_points_above(s, p, margin, &CertifyOptions::default())
}
