//! What a fit returns ([`Fit`]): the typed report ([`FitReport`], written as JSON by
//! `--report` and returned as a dict by Python, keys in field order), the landmarks'
//! residuals, the one-line summary every fit prints, and the warnings for a result that is
//! not certified fold-free or whose landmarks cross.

use super::error::FitError;
use super::landmarks::Landmark;
use super::objective::LossKind;
use super::options::{Bend, FitOptions};
use crate::spline::jacobian::CertifyOptions;
use crate::spline::Spline;
use serde::{Serialize, Serializer};
use std::fmt;
use std::time::Instant;

/// A `det J` bound as text: three decimals, or two significant digits for a positive bound
/// below 0.001 (which three decimals would print as `0.000`, as if it were not positive).
///
/// ```
/// use trimorph::fit::report::det_text;
/// assert_eq!(det_text(0.5), "0.500");
/// assert_eq!(det_text(0.00042), "4.2e-4");
/// assert_eq!(det_text(-2.125), "-2.125");
/// ```
pub fn det_text(v: f64) -> String {
    if v > 0.0 && v < 1e-3 {
        format!("{v:.1e}")
    } else {
        format!("{v:.3}")
    }
}

/// The first solver run of a soft fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// Nothing to solve: no variable (every point pinned or outside the radius).
    None,
    /// The squares minimizer, solved directly (one Gauss-Newton step of a linear problem).
    GaussNewton,
    /// Iteratively reweighted squares (the robust losses).
    Irls,
}

/// The exact step after the soft fit ([`super::hard`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExactStep {
    /// The landmarks became hard constraints (`--hard`).
    Hard,
    /// Pinned control points were restored exactly (the editor's corrections).
    Pinned,
}

/// How a fit solved: the first run, whether Newton's method with the fold barrier
/// followed, and the exact step. Written as one word: `gauss-newton`, `irls` or `none`,
/// then `+newton`, then `+hard` or `+pinned` (`gauss-newton+newton+hard`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FitMethod {
    /// The first run.
    pub solver: Solver,
    /// The barrier acted: Newton's method ran after it.
    pub newton: bool,
    /// The exact step, if any.
    pub exact: Option<ExactStep>,
}

impl FitMethod {
    /// `solver` alone: no Newton run, no exact step.
    pub fn new(solver: Solver) -> FitMethod {
        FitMethod { solver, newton: false, exact: None }
    }
}

impl fmt::Display for FitMethod {
    /// ```
    /// use trimorph::fit::report::{ExactStep, FitMethod, Solver};
    /// let m = FitMethod { solver: Solver::GaussNewton, newton: true, exact: Some(ExactStep::Hard) };
    /// assert_eq!(m.to_string(), "gauss-newton+newton+hard");
    /// assert_eq!(FitMethod::new(Solver::Irls).to_string(), "irls");
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self.solver {
            Solver::None => "none",
            Solver::GaussNewton => "gauss-newton",
            Solver::Irls => "irls",
        })?;
        if self.newton {
            f.write_str("+newton")?;
        }
        match self.exact {
            Some(ExactStep::Hard) => f.write_str("+hard"),
            Some(ExactStep::Pinned) => f.write_str("+pinned"),
            None => Ok(()),
        }
    }
}

impl Serialize for FitMethod {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// Why a fit's solver stopped (written `exact`, `converged`, `no descent` or
/// `iteration cap`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum FitTermination {
    /// The squares minimizer itself: the barrier was off or not needed.
    #[serde(rename = "exact")]
    Exact,
    /// Newton's method with the barrier converged ([`super::newton`]).
    #[serde(rename = "converged")]
    Converged,
    /// No step length decreased the barrier's objective.
    #[serde(rename = "no descent")]
    NoDescent,
    /// Newton's method reached its iteration cap ([`FitOptions::max_iters`]).
    #[serde(rename = "iteration cap")]
    IterationCap,
}

impl FitTermination {
    /// The name written in reports and summaries.
    pub const fn name(self) -> &'static str {
        match self {
            FitTermination::Exact => "exact",
            FitTermination::Converged => "converged",
            FitTermination::NoDescent => "no descent",
            FitTermination::IterationCap => "iteration cap",
        }
    }
}

impl fmt::Display for FitTermination {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for LossKind {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
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
    /// The solver runs, written `gauss-newton` or `irls` (robust losses; `none` without
    /// variables), `+newton` when the barrier acted, `+hard` or `+pinned` after the exact
    /// step.
    pub method: FitMethod,
    /// The data loss (written by its name, without its scale).
    pub loss: LossKind,
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
    /// Why the solver stopped.
    pub termination: FitTermination,
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

pub(super) fn label(l: &Landmark) -> String {
    l.name.clone().unwrap_or_else(|| "-".into())
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

/// The report of a fitted spline: residuals, the `det J` certificate, the counts (the
/// solver's choices are set by the caller).
#[allow(clippy::too_many_arguments)]
pub(super) fn build(
    fitted: &Spline,
    lms: &[Landmark],
    opts: &FitOptions,
    method: FitMethod,
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
        loss: opts.loss.kind(),
        bend: bend_weight(opts.bend),
        bend_auto: false,
        gcv_rms: None,
        loo_rms: None,
        bend_criterion: None,
        termination: FitTermination::Exact,
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

/// The weight of a fixed [`Bend`], or the default where cross-validation cannot choose.
pub(super) fn bend_weight(b: Bend) -> f64 {
    match b {
        Bend::Weight(w) => w,
        Bend::Auto => super::smooth::DEFAULT_BEND,
    }
}

impl FitReport {
    /// One line per fit: landmark residuals, held-out TRE, the bending weight (when chosen
    /// by cross-validation), `det J` (sampled and certified), the solver and its termination, and
    /// whether C1 holds exactly.
    pub fn summary_line(&self) -> String {
        let r = self;
        let mut s =
            format!("{} landmarks: rms {:.3} px, max {:.3} px", r.fit.count, r.fit.rms, r.fit.max);
        if let Some(h) = &r.holdout {
            s += &format!(
                "; held-out TRE rms {:.3} px, max {:.3} px ({})",
                h.tre.rms, h.tre.max, h.tre.count
            );
        }
        if r.bend_auto {
            s += &format!("; bend {:.2e} (auto", r.bend);
            if let Some(l) = r.loo_rms {
                s += &format!(", leave-one-out {l:.3} px");
            } else if let (Some(g), Some(c)) = (r.gcv_rms, r.bend_criterion) {
                s += &format!(", {} {g:.3} px", c.name());
            }
            s += ")";
        }
        s += &format!(
            "; min det J {:.3}{}, certified >= {}{}; {} ({} iterations, {}, {} variables) in \
             {:.1} ms; C1 exact: {}",
            r.min_det_j,
            if r.folds { " (FOLDS)" } else { "" },
            det_text(r.det_j_lower_bound),
            if r.fold_free { " (fold-free)" } else { "" },
            r.method,
            r.iterations,
            r.termination,
            r.variables,
            r.time_ms,
            if r.exact_c1 { "yes" } else { "NO" }
        );
        s
    }

    /// The warnings of a fit: landmark pairs that cross (a fold or a strong twist), and a result
    /// that folds or is not certified fold-free, with what to do (`barrier`: whether the
    /// fold barrier was on).
    pub fn warnings(&self, barrier: bool) -> Vec<String> {
        let mut out = Vec::new();
        if !self.conflicts.is_empty() {
            let pairs: Vec<String> =
                self.conflicts.iter().map(|[a, b]| format!("{a} and {b}")).collect();
            out.push(format!(
                "these landmark pairs cross (the targets reverse their order against the \
                 landmarks' affine map), which a fold-free map follows only by twisting \
                 strongly between them: {}; check or remove one of each pair",
                pairs.join(", ")
            ));
        }
        if self.fold_free {
            return out;
        }
        let what = if self.folds { "folds" } else { "is not certified fold-free" };
        let hint = if !barrier {
            "turn the fold barrier on (drop --no-barrier) or raise --bend"
        } else {
            "the landmarks demand a fold (crossing pairs?) or a very strong bend: check the \
             landmarks with the largest residuals, or raise --bend"
        };
        out.push(format!(
            "the fit {what} (sampled min det J {:.3}, certified lower bound {:.3}); {hint}",
            self.min_det_j, self.det_j_lower_bound
        ));
        out
    }
}
