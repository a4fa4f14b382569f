//! The fit: options, the solver runs, exact certification and the report.
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

use super::landmarks::Landmark;
use super::newton::newton;
use super::objective::{data_row, Barrier, Loss, Objective, TriangleTerms};
use super::param::Param;
use super::smooth::{Smoother, DEFAULT_BEND};
use super::smooth_sparse::{SparseSmoother, LANDMARK_SPACE_MAX};
use crate::edit::select::{neighborhood, Neighborhood, SelectIndex};
use crate::spline::jacobian::CertifyOptions;
use crate::spline::mds::Mds;
use crate::spline::{ControlPoint, Spline};
use serde::Serialize;
use std::time::Instant;

pub use super::error::FitError;

/// Options of [`fit`].
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// Data loss (default squares).
    pub loss: Loss,
    /// The scale-free bending weight (default [`Bend::Auto`]; see [`super::smooth`]).
    pub bend: Bend,
    /// Fold barrier; `None` turns it off (default floor 0.1, threshold 0.3, weight 1).
    pub barrier: Option<Barrier>,
    /// Variables: free points within this many control-net steps of the landmarks'
    /// triangles (`None`: every free point; default).
    pub radius: Option<usize>,
    /// Iteration cap of the barrier's Newton method (default 200).
    pub max_iters: u64,
    /// Landmarks become hard constraints `phi(s_i) = t_i` ([`super::hard`]).
    pub hard: bool,
    /// Rounding to exact values moves no control point by more than `2^-grid_bits` px
    /// (default 20): the free points are rounded to multiples of `2^-grid_bits`, or of a
    /// finer power of two where the mesh amplifies a rounding
    /// ([`crate::spline::mds::rounding_bits`]; the report's `rounding_bits`).
    pub grid_bits: u32,
    /// Barycentric sample level of `det J` in the barrier (default
    /// [`crate::spline::jacobian::SAMPLE_LEVEL`], 8: 45 samples per triangle, the sample set
    /// every command reports).
    pub det_level: usize,
    /// Control points pinned at their values in the input spline (e.g. points corrected
    /// by hand in the editor). They are held exactly: the soft fit does not vary them and
    /// an ECLES update ([`super::hard`]) makes the result exactly C1 with every pinned point
    /// at its input value (default: none).
    pub pinned: Vec<ControlPoint>,
    /// Hold the spline's border fixed: no free point that a control point of a border edge
    /// depends on varies, so `phi` on the border stays as in the warm start (default false;
    /// the landmark-adapted fit sets it, see [`super::frame`]).
    pub pin_border: bool,
    /// The area `|Omega|` (square pixels) in `lambda = bend * sum w * |Omega|`, so that a
    /// weight means the same whatever lies far outside the landmarks (`None`: the mesh's
    /// area; [`super::frame`] sets the frame grown by its margin, leaving out the far-field
    /// rings).
    pub bend_area: Option<f64>,
    /// Stops the fit between Newton iterations when set ([`FitError::Cancelled`]; default:
    /// never).
    pub cancel: crate::cancel::Cancel,
}

/// The bending weight of a fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bend {
    /// Chosen by leave-one-out cross-validation on the landmarks ([`super::smooth`]).
    Auto,
    /// This scale-free weight (`lambda = bend * sum w * |Omega|`).
    Weight(f64),
}

impl std::str::FromStr for Bend {
    type Err = BendError;
    /// `auto` or a finite weight `>= 0` (surrounding spaces ignored).
    fn from_str(t: &str) -> Result<Bend, BendError> {
        match t.trim() {
            "auto" => Ok(Bend::Auto),
            t => match t.parse::<f64>() {
                Ok(w) if w.is_finite() && w >= 0.0 => Ok(Bend::Weight(w)),
                _ => Err(BendError(t.to_string())),
            },
        }
    }
}

/// A bending weight that is neither `auto` nor a finite number `>= 0` (the text given,
/// trimmed).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is neither `auto` nor a finite number >= 0")]
pub struct BendError(pub String);

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            loss: Loss::Squares,
            bend: Bend::Auto,
            barrier: Some(Barrier { floor: 0.1, tau: 0.3, mu: 1.0 }),
            radius: None,
            max_iters: 200,
            hard: false,
            grid_bits: 20,
            det_level: crate::spline::jacobian::SAMPLE_LEVEL,
            pinned: Vec::new(),
            pin_border: false,
            bend_area: None,
            cancel: crate::cancel::Cancel::never(),
        }
    }
}

/// One landmark's result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Residual {
    /// Name.
    pub name: Option<String>,
    /// Source point.
    pub src: [f64; 2],
    /// Target point.
    pub dst: [f64; 2],
    /// `phi(src)`.
    pub mapped: [f64; 2],
    /// `|phi(src) - dst|` (pixels).
    pub residual: f64,
}

/// Residual statistics of a set of landmarks.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Stats {
    /// Number of landmarks.
    pub count: usize,
    /// Root mean square residual.
    pub rms: f64,
    /// Mean residual.
    pub mean: f64,
    /// Largest residual.
    pub max: f64,
}

impl Stats {
    /// Statistics of residuals.
    pub fn of(r: &[Residual]) -> Stats {
        let n = r.len().max(1) as f64;
        Stats {
            count: r.len(),
            rms: (r.iter().map(|x| x.residual * x.residual).sum::<f64>() / n).sqrt(),
            mean: r.iter().map(|x| x.residual).sum::<f64>() / n,
            max: r.iter().map(|x| x.residual).fold(0.0, f64::max),
        }
    }
}

/// What a fit did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitReport {
    /// `gauss-newton` or `irls` (robust losses), `+newton` when the barrier acted, `+hard`
    /// or `+pinned` after the exact step.
    pub method: String,
    /// Loss name.
    pub loss: String,
    /// The scale-free bending weight used.
    pub bend: f64,
    /// Whether it was chosen by cross-validation (`--bend auto`).
    pub bend_auto: bool,
    /// The GCV estimate of the landmarks' prediction error at that weight (pixels; auto only).
    pub gcv_rms: Option<f64>,
    /// Leave-one-out error of the landmarks' squares fit at that weight, the score the
    /// weight minimizes (pixels; auto only).
    pub loo_rms: Option<f64>,
    /// The score the automatic weight minimized: `leave_one_out` (exact, in landmark space,
    /// up to [`LANDMARK_SPACE_MAX`] landmarks) or `randomized_gcv` (more landmarks,
    /// [`super::smooth_sparse`]); auto only.
    pub bend_criterion: Option<super::smooth::BendCriterion>,
    /// Why the solver stopped: `exact` (the squares minimizer, no barrier needed),
    /// `converged`, `no descent` or `iteration cap` (Newton with the barrier).
    pub termination: String,
    /// Number of variables (2 per free point that moves).
    pub variables: usize,
    /// Solver iterations (Gauss-Newton counts 1).
    pub iterations: u64,
    /// Objective before and after.
    pub cost_initial: f64,
    /// Objective at the result.
    pub cost_final: f64,
    /// Per-landmark residuals of the fitted landmarks.
    pub residuals: Vec<Residual>,
    /// Their statistics.
    pub fit: Stats,
    /// Held-out landmarks (target registration error), when any.
    pub holdout: Option<HoldoutReport>,
    /// Smallest sampled `det J` of the result.
    pub min_det_j: f64,
    /// Whether some sample has `det J <= 0` (a fold).
    pub folds: bool,
    /// `det J > 0` is proven on every triangle (certificate, not samples).
    pub fold_free: bool,
    /// A certified lower bound of `det J` over the whole mesh.
    pub det_j_lower_bound: f64,
    /// Nearby landmark pairs whose order the targets reverse against the landmarks' affine
    /// map (names, or `#index`, [`super::affine::crossing_pairs`]): swapped or crossing
    /// landmarks, which a fold-free fit follows only by a strong twist, if at all. Listed
    /// for every fit; a strong local rotation (over 90 degrees against the affine map) lists
    /// pairs too, though it needs no fold.
    pub conflicts: Vec<[String; 2]>,
    /// The result satisfies every C1 condition exactly (checked in rational arithmetic).
    pub exact_c1: bool,
    /// The free points were rounded to multiples of `2^-rounding_bits`: at least
    /// [`FitOptions::grid_bits`], finer where the mesh's determining set amplifies a
    /// rounding ([`crate::spline::mds::rounding_bits`]).
    pub rounding_bits: u32,
    /// Wall time of the fit (milliseconds).
    pub time_ms: f64,
}

/// Residuals of landmarks kept out of the fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HoldoutReport {
    /// Per landmark.
    pub residuals: Vec<Residual>,
    /// Statistics (the TRE).
    pub tre: Stats,
}

/// A fitted deformation and its report.
#[derive(Clone, Debug)]
pub struct Fit {
    /// The result (C1 exactly).
    pub spline: Spline,
    /// The report.
    pub report: FitReport,
}

fn label(l: &Landmark) -> String {
    l.name.clone().unwrap_or_else(|| "-".into())
}

/// Largest accepted landmark coordinate and weight magnitude: beyond it the fit's exact and
/// floating-point arithmetic stops being meaningful (and a hard fit would grow huge
/// rationals).
pub const MAX_LANDMARK_VALUE: f64 = 1e9;

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

/// `phi(src)` against `dst` for each landmark.
pub fn residuals(s: &Spline, lms: &[Landmark]) -> Result<Vec<Residual>, FitError> {
    lms.iter()
        .enumerate()
        .map(|(index, l)| {
            let m = s.eval(l.src, None).ok_or(FitError::OutsideMesh {
                index,
                name: label(l),
                x: l.src[0],
                y: l.src[1],
            })?;
            Ok(Residual {
                name: l.name.clone(),
                src: l.src,
                dst: l.dst,
                mapped: m,
                residual: (m[0] - l.dst[0]).hypot(m[1] - l.dst[1]),
            })
        })
        .collect()
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

/// Fits `s` to the landmarks (see the module docs). `s` is the warm start; it is not changed.
pub fn fit(s: &Spline, lms: &[Landmark], opts: &FitOptions) -> Result<Fit, FitError> {
    let start = Instant::now();
    fit_with(s, &Mds::new(s)?, lms, opts, start)
}

/// [`fit`] with the spline's determining set already built (it is the costly exact part of
/// a small fit); `start` is when the caller's timing began.
pub fn fit_with(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
    start: Instant,
) -> Result<Fit, FitError> {
    fit_with_terms(s, mds, lms, opts, start, None)
}

/// [`fit_with`] with the triangles' terms possibly prebuilt (for `s` at `opts.det_level`;
/// used by the soft fit only).
pub(super) fn fit_with_terms(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
    start: Instant,
    terms: Option<TriangleTerms>,
) -> Result<Fit, FitError> {
    opts.cancel.check().map_err(|_| FitError::Cancelled)?;
    // Round the free points finely enough that no control point moves more than
    // 2^-grid_bits px (a near-singular vertex of the mesh amplifies a rounding by up to
    // 10^8: rounded at 2^-20 such a fit folded while its floating-point solution did not).
    let opts = &FitOptions {
        grid_bits: crate::spline::mds::rounding_bits(mds.amplification(), opts.grid_bits),
        ..opts.clone()
    };
    if opts.hard || !opts.pinned.is_empty() {
        return super::hard::fit_hard(s, mds, lms, opts, start);
    }
    // The exact evaluation plan of the determining set is needed only at the end (the
    // fitted points in rationals): built on another thread while the fit solves.
    rayon::join(|| fit_soft_terms(s, mds, lms, opts, start, terms), || mds.prepare()).0
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
fn fit_soft_terms(
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
            method: "none".into(),
            iterations: 0,
            bend: bend_weight(opts.bend),
            choice: None,
            termination: "exact".into(),
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
    let mut rep = report(
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

/// The most variable control points a soft fit takes (a bound on its memory: the landmark
/// space solver stores `nv x k` numbers, the Newton step a sparse factor).
pub const MAX_FIT_VARIABLES: usize = 32_768;

/// The weight of a fixed [`Bend`], or the default where cross-validation cannot choose.
fn bend_weight(b: Bend) -> f64 {
    match b {
        Bend::Weight(w) => w,
        Bend::Auto => DEFAULT_BEND,
    }
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
    method: String,
    iterations: u64,
    bend: f64,
    choice: Option<super::smooth::Choice>,
    termination: String,
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
    let mut method = "gauss-newton".to_string();
    if opts.loss != Loss::Squares {
        // IRLS: data weight w_i psi(r_i) / 2 (psi = rho'(r) / r), from the squares fit.
        method = "irls".into();
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
        return Ok(Solved { x, method, iterations, bend, choice, termination: "exact".into() });
    };
    if obj.eval(&x, None).min_det >= barrier.tau {
        return Ok(Solved { x, method, iterations, bend, choice, termination: "exact".into() });
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
        method: format!("{method}+newton"),
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

#[allow(clippy::too_many_arguments)]
pub(super) fn report(
    fitted: &Spline,
    lms: &[Landmark],
    opts: &FitOptions,
    method: String,
    nv: usize,
    iterations: u64,
    cost_initial: f64,
    cost_final: f64,
    start: Instant,
) -> Result<FitReport, FitError> {
    let res = residuals(fitted, lms)?;
    // The certificate also gives the common sampled minimum of every command (the level-8
    // lattice, `spline::jacobian::SAMPLE_LEVEL`).
    let cert = crate::spline::jacobian::certify(fitted, &CertifyOptions::default());
    let min_det = cert.sampled_min;
    Ok(FitReport {
        method,
        loss: opts.loss.name().into(),
        bend: bend_weight(opts.bend),
        bend_auto: false,
        gcv_rms: None,
        loo_rms: None,
        bend_criterion: None,
        termination: "exact".into(),
        variables: 2 * nv,
        iterations,
        cost_initial,
        cost_final,
        fit: Stats::of(&res),
        residuals: res,
        holdout: None,
        min_det_j: min_det,
        folds: min_det <= 0.0,
        fold_free: cert.fold_free,
        det_j_lower_bound: cert.lower_bound,
        conflicts: Vec::new(),
        // Every caller built `fitted` with `with_points` / `with_determined_points` /
        // `from_points`, which check each C1 condition exactly and fail otherwise (a second
        // check would only repeat it).
        exact_c1: true,
        rounding_bits: opts.grid_bits,
        time_ms: start.elapsed().as_secs_f64() * 1e3,
    })
}

/// Adds the held-out landmarks' residuals (the TRE) to a report.
pub fn with_holdout(
    mut report: FitReport,
    s: &Spline,
    held: &[Landmark],
) -> Result<FitReport, FitError> {
    if !held.is_empty() {
        let r = residuals(s, held)?;
        report.holdout = Some(HoldoutReport { tre: Stats::of(&r), residuals: r });
    }
    Ok(report)
}
