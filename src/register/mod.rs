//! Registration from the images themselves: a C1 spline `phi` from MOVING's pixels to
//! FIXED's pixels that makes `F(phi(y))` look like `M(y)`, with optional landmarks (soft or
//! exact) and points pinned in the editor, certified fold-free.
//!
//! **Direction.** `phi` maps MOVING pixel coordinates to FIXED pixel coordinates, as a fit
//! with `src` in MOVING and `dst` in FIXED does; warping MOVING through `phi`
//! (`O(q) = M(phi^-1(q))`, [`crate::warp`]) resamples it onto FIXED. The cost is measured
//! on MOVING's grid: `E = sum_i rho(M(y_i), F(phi(y_i)))` over MOVING's pixels `y_i`. There
//! the spline is linear in its control points with fixed Bernstein weights (the mesh lives
//! in MOVING's pixels), so the gradient is exact and cheap: `dE/dq = sum_i dE/df_i
//! grad F(phi(y_i)) B(y_i)`, the image gradient at `phi(y_i)` times `dphi/dq`
//! ([`samples`]).
//!
//! **Steps** ([`register`]):
//! 1. Both images become grey `f32` ([`image::Channel`]), with masks; Gaussian pyramids of
//!    up to 4 levels ([`image::pyramid`], `imageproc`).
//! 2. Pre-alignment ([`affine`]): an affine map (or a translation) from the images,
//!    coarse to fine, by L-BFGS under argmin's `Executor`.
//! 3. The spline: degree 5 over a regular mesh of MOVING's frame, exactly the
//!    pre-alignment to start with ([`Spline::affine`], coefficients rounded to `2^-24`), or
//!    the `--init` deformation (over its own mesh). The mesh is the coarsest of a mesh
//!    pyramid ([`pyramid`]): cells of `2^(K-1)` times [`RegisterOptions::spacing`] pixels,
//!    refined (nested, so the spline is carried over exactly) before each of the `K - 1`
//!    finest image levels.
//! 4. The spline stage ([`deform`]) coarse to fine: image term + bending + soft landmarks +
//!    fold barrier, by L-BFGS under argmin's `Executor` ([`crate::fit::optim`]).
//! 5. Exact output: the free points rounded to `2^-grid_bits` (finer where the mesh amplifies
//!    a rounding, [`crate::spline::mds::rounding_bits`]), the dependents computed
//!    exactly (so the spline is exactly C1), then with `hard` every landmark met exactly
//!    and every pinned point restored ([`crate::fit::hard::exact_constraints`]), and the
//!    Bernstein certificate of `det J > 0` ([`crate::spline::jacobian::certify`]).
//!
//! Metrics: [`metric`]. Positions are pixels: pixel `(i, j)` centred at `(i, j)`.

pub(crate) mod affine;
pub(crate) mod deform;
mod error;
pub mod frames;
pub mod image;
pub(crate) mod metric;
pub mod pyramid;
pub mod samples;
#[cfg(test)]
mod tests;

pub use affine::Prealign;
pub use error::RegisterError;
pub use metric::Metric;

use crate::fit::landmarks::Landmark;
use crate::fit::objective::{data_row, Barrier, Loss, Objective};
use crate::fit::optim::Termination;
use crate::fit::param::{grid_rat, Param};
use crate::fit::{residuals, FitOptions, Residual, Stats};
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::jacobian::CertifyOptions;
use crate::spline::mds::Mds;
use crate::spline::{ControlPoint, Spline};
use image::{Channel, Mask};
use samples::SampleOptions;
use serde::Serialize;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// Called during the solves with `(stage, iteration, cost)`.
pub type Progress = Arc<dyn Fn(&str, u64, f64) + Send + Sync>;

/// An image to register: its grey channel and optional mask, and the names errors use.
#[derive(Clone, Debug)]
pub struct Input {
    /// The grey values.
    pub image: Channel,
    /// The image's name (its file).
    pub name: PathBuf,
    /// The mask and its name.
    pub mask: Option<(Mask, PathBuf)>,
}

impl Input {
    /// Checks the size, the mask (same size, not empty) and that the image is not constant
    /// inside its mask.
    pub fn validate(&self) -> Result<(), RegisterError> {
        let (w, h) = (self.image.w, self.image.h);
        if w < 16 || h < 16 {
            return Err(RegisterError::TooSmall { image: self.name.clone(), w, h });
        }
        if let Some((m, mp)) = &self.mask {
            if (m.w, m.h) != (w, h) {
                return Err(RegisterError::MaskSize {
                    mask: mp.clone(),
                    image: self.name.clone(),
                    mask_w: m.w,
                    mask_h: m.h,
                    image_w: w,
                    image_h: h,
                });
            }
            if m.count() == 0 {
                return Err(RegisterError::EmptyMask { mask: mp.clone() });
            }
        }
        let (lo, hi) = self.image.range(self.mask.as_ref().map(|m| &m.0));
        if lo >= hi {
            return Err(RegisterError::Constant { image: self.name.clone(), value: lo });
        }
        Ok(())
    }
}

/// Options of [`register`].
#[derive(Clone)]
pub struct RegisterOptions {
    /// The metric (default [`Metric::Ncc`]).
    pub metric: Metric,
    /// Pyramid levels (`None`: up to 4, the coarsest at least 48 pixels across).
    pub levels: Option<u32>,
    /// The pre-alignment (default affine; skipped when starting from `init`).
    pub prealign: Prealign,
    /// Mesh cell size in MOVING's pixels (default 48): the finest mesh level's cells.
    pub spacing: f64,
    /// Mesh levels ([`pyramid`]): the spline stage starts on cells `2^(mesh_levels - 1)`
    /// times `spacing` and refines before each of the finest image levels. `None`:
    /// [`DEFAULT_MESH_LEVELS`]. Always one level (a single mesh) when starting from `init`
    /// or with pinned points, and at most the number of pyramid levels.
    pub mesh_levels: Option<u32>,
    /// The share `theta` of the refinement indicator the refined triangles carry (default
    /// [`DEFAULT_REFINE_SHARE`]; 1 refines every triangle).
    pub refine_share: f64,
    /// Spline degree (default 5).
    pub degree: usize,
    /// Bending weight (default [`DEFAULT_BEND`]), relative to the metric: the bending
    /// energy's weight `lambda` is `bend * metric.bend_scale()` ([`Metric::bend_scale`]).
    pub bend: f64,
    /// The fold barrier's floor (relative to the pre-alignment's area scale; default 0.1).
    pub floor: f64,
    /// L-BFGS iterations per level of the spline stage (default 30).
    pub max_iters: u64,
    /// L-BFGS iterations per level of the pre-alignment (default 60).
    pub affine_iters: u64,
    /// Samples per level.
    pub samples: SampleOptions,
    /// Landmarks (`src` in MOVING, `dst` in FIXED), with their weights.
    pub landmarks: Vec<Landmark>,
    /// Weight of each landmark: `landmark_weight * w_i` times one image sample (its squared
    /// distance in pixels against one sample's metric term; default [`DEFAULT_LANDMARK_WEIGHT`]).
    pub landmark_weight: f64,
    /// Landmarks are met exactly.
    pub hard: bool,
    /// The start (`None`: the pre-alignment over a new mesh).
    pub init: Option<Spline>,
    /// Control points of `init` held at their values (pinned in the editor).
    pub pinned: Vec<ControlPoint>,
    /// Rounding to exact values moves no control point by more than `2^-grid_bits` px
    /// (default 20; the free points' grid is finer where the mesh amplifies a rounding,
    /// [`crate::spline::mds::rounding_bits`]).
    pub grid_bits: u32,
    /// Observes every solver iteration.
    pub progress: Option<Progress>,
    /// Stops the registration after the current iteration when set
    /// ([`RegisterError::Cancelled`]; default: never).
    pub cancel: crate::cancel::Cancel,
}

/// The default bending weight: chosen on the synthetic pairs of `tests/it/register.rs`
/// (known smooth warps of real microscopy images with noise).
pub const DEFAULT_BEND: f64 = 1.0;

/// The default number of mesh levels without landmarks ([`RegisterOptions::mesh_levels`]).
///
/// Measured with `benches/register_compare.py` (three real microscopy images warped by a
/// known field, 512^2 to 550 x 660, mean endpoint error in px against elastix's default
/// B-spline registration): one mesh of 48 px cells gives 0.080 / 0.742 / 0.894 px in
/// 1.28 / 0.68 / 0.71 s, three levels (192, 96, 48 px, every triangle refined) 0.082 /
/// 0.700 / 0.580 px in 0.70 / 0.54 / 0.73 s (elastix 0.089 / 2.01 / 2.85 px in 2-3 s;
/// 0.085 / 0.704 / 0.538 px once a run's samples keep their membership,
/// [`samples::Membership`]);
/// with a finer known field (`--knots 12`) 0.111 / 0.751 / 1.19 px against 0.092 / 0.780 /
/// 1.159 px. At twice the size (1024^2 to 1100 x 1320) three levels give 0.250 / 1.089 /
/// 0.80 px in 1.05-1.53 s (one level: 0.263 / 1.126 / 1.515 px; elastix 0.250 / 4.79 /
/// 6.80 px in 5.5-6.9 s).
///
/// With landmarks too: on the textured pair of `tests/it/register.rs` with 12 noisy
/// landmarks three levels end 0.057 px from the held-out truth, one level 0.063 px; on its
/// masked pair (the right half seen only by 16 landmarks) 0.66 px against a thin-plate
/// spline's 0.69 px, as one level does, once each refinement starts from the landmark fit
/// where the image holds nothing (`landmark_start`; without it 1.06 px).
pub const DEFAULT_MESH_LEVELS: u32 = 3;

/// The default refinement share ([`RegisterOptions::refine_share`]).
pub const DEFAULT_REFINE_SHARE: f64 = 1.0;

impl RegisterOptions {
    /// The number of pyramid levels a registration of `fixed` and `moving` runs: `levels`,
    /// else as many as the smaller image's side allows (at most 4), clamped to 1..=8.
    pub fn level_count(&self, fixed: &Input, moving: &Input) -> u32 {
        let side = fixed.image.w.min(fixed.image.h).min(moving.image.w).min(moving.image.h);
        self.levels.unwrap_or_else(|| image::auto_levels(side, 4)).clamp(1, 8)
    }
}

impl Default for RegisterOptions {
    fn default() -> Self {
        RegisterOptions {
            metric: Metric::Ncc,
            levels: None,
            prealign: Prealign::Affine,
            spacing: 48.0,
            mesh_levels: None,
            refine_share: DEFAULT_REFINE_SHARE,
            degree: 5,
            bend: DEFAULT_BEND,
            floor: crate::fit::options::DEFAULT_MIN_DET,
            max_iters: 30,
            affine_iters: 60,
            samples: SampleOptions::default(),
            landmarks: Vec::new(),
            landmark_weight: DEFAULT_LANDMARK_WEIGHT,
            hard: false,
            init: None,
            pinned: Vec::new(),
            grid_bits: 20,
            progress: None,
            cancel: crate::cancel::Cancel::never(),
        }
    }
}

impl std::fmt::Debug for RegisterOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RegisterOptions")
            .field("metric", &self.metric)
            .field("levels", &self.levels)
            .field("prealign", &self.prealign)
            .field("spacing", &self.spacing)
            .field("bend", &self.bend)
            .field("landmarks", &self.landmarks.len())
            .field("hard", &self.hard)
            .finish_non_exhaustive()
    }
}

/// One solver run of a registration.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LevelReport {
    /// `affine` or `spline`.
    pub stage: String,
    /// Pyramid level (0 is full resolution).
    pub level: u32,
    /// Moving samples.
    pub samples: usize,
    /// Unknowns.
    pub variables: usize,
    /// Solver iterations.
    pub iterations: u64,
    /// Cost and gradient evaluations.
    pub evaluations: u64,
    /// Why the run stopped.
    pub termination: Termination,
    /// The metric at the start of the run (this level's images).
    pub metric_before: f64,
    /// The metric at its end.
    pub metric_after: f64,
    /// Wall time (ms).
    pub time_ms: f64,
    /// The spline's mesh triangles during the run (spline runs only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub triangles: Option<usize>,
}

/// Where the spline stage started when landmarks were given.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SplineStart {
    /// The pre-alignment (or `--init`): the landmark fit scored worse.
    Prealigned,
    /// The fit of bending and landmarks alone.
    LandmarkFit,
}

/// The landmarks' share of a registration report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LandmarkReport {
    /// Landmarks given.
    pub count: usize,
    /// The spline stage's start: the coarsest level runs from the pre-alignment and from the
    /// landmark fit, and the run with the lower objective (image term + bending + landmarks)
    /// goes on.
    pub start: SplineStart,
    /// Met exactly.
    pub hard: bool,
    /// Residual statistics (pixels).
    pub fit: Stats,
    /// Per landmark.
    pub residuals: Vec<Residual>,
}

/// What [`register`] reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RegisterReport {
    /// The metric's name.
    pub metric: Metric,
    /// The metric at full resolution before registering (the images as given, identity).
    pub metric_before: f64,
    /// After the pre-alignment.
    pub metric_prealigned: f64,
    /// After the whole registration (the exact output spline).
    pub metric_after: f64,
    /// The pre-alignment's kind.
    pub prealign: Prealign,
    /// The pre-alignment map `[[a, b, c], [d, e, f]]`.
    pub affine: [[f64; 3]; 2],
    /// Every solver run, in order.
    pub levels: Vec<LevelReport>,
    /// Pyramid levels.
    pub pyramid_levels: u32,
    /// Mesh levels the spline stage ran on ([`pyramid`]).
    pub mesh_levels: u32,
    /// The refinements between them, coarsest first.
    pub refinements: Vec<pyramid::RefineStep>,
    /// Mesh triangles and vertices.
    pub triangles: usize,
    /// Mesh vertices.
    pub vertices: usize,
    /// Free variables of the spline stage.
    pub variables: usize,
    /// Certified `det J > 0` everywhere (Bernstein certificate).
    pub fold_free: bool,
    /// The certified lower bound of `det J`.
    pub det_j_lower_bound: f64,
    /// The smallest sampled `det J`.
    pub min_det_j: f64,
    /// Exactly C1 (always, by construction; checked in rationals).
    pub exact_c1: bool,
    /// The landmarks, when given.
    pub landmarks: Option<LandmarkReport>,
    /// Wall time (ms).
    pub time_ms: f64,
}

/// A registration: the spline and its report.
#[derive(Clone, Debug)]
pub struct Registration {
    /// `phi`: MOVING pixels -> FIXED pixels.
    pub spline: Spline,
    /// The report.
    pub report: RegisterReport,
}

/// The default landmark weight: one landmark counts as this many image samples (per squared
/// pixel). Chosen on the pairs of `tests/it/register.rs` (12 or 16 landmarks with 0.25 px of
/// noise), held-out error with the mesh pyramid by weight:
///
/// | weight | 1 | 0.5 | 0.25 | 0.1 |
/// |---|---|---|---|---|
/// | textured pair (image alone 0.0584 px) | 0.0625 | 0.0596 | 0.0571 | 0.0561 |
/// | MOVING masked to its left half, right half (TPS 0.690 px) | 0.655 | 0.657 | 0.658 | 0.659 |
///
/// Where the image is textured, landmarks this noisy pull the fine meshes off at a weight
/// of 1 (worse than the image term alone); where the image sees nothing they carry the map
/// at any of these weights, as nothing else competes there but the bending.
pub const DEFAULT_LANDMARK_WEIGHT: f64 = 0.25;

/// The share of MOVING's samples that must land on FIXED after the pre-alignment.
pub const MIN_OVERLAP: f64 = 0.1;
/// A variable the image term does not see after a refinement of the mesh pyramid (no sample
/// falls on its support): its part of the image curvature is below this share of the mean ([`deform::image_sees`],
/// [`pyramid::unseen_from`]).
const UNSEEN: f64 = 1e-6;

/// A regular mesh of `cols x rows` cells of about `spacing` pixels over MOVING's frame
/// `[-0.5, w - 0.5] x [-0.5, h - 0.5]`, each cell split along its rising diagonal.
pub fn frame_mesh(w: usize, h: usize, spacing: f64) -> Result<Mesh, RegisterError> {
    frame_mesh_on(w, h, spacing, 16)
}

/// [`frame_mesh`] with vertices snapped to `1 / grid` pixels.
fn frame_mesh_on(w: usize, h: usize, spacing: f64, grid: i64) -> Result<Mesh, RegisterError> {
    if !(spacing.is_finite() && spacing >= 4.0) {
        return Err(RegisterError::Option(format!(
            "the mesh spacing must be at least 4 pixels, got {spacing}"
        )));
    }
    let cols = ((w as f64 / spacing).round() as usize).max(1);
    let rows = ((h as f64 / spacing).round() as usize).max(1);
    let (w, h) = (w as f64, h as f64);
    Ok(Mesh::grid_from([-0.5, -0.5], cols, rows, w, h, MeshOptions { grid })?)
}

/// The metric of the whole images at full resolution for control points `pts` of `s`.
fn full_metric(
    s: &Spline,
    pts: &[[f64; 2]],
    metric: Metric,
    fixed: &image::Level,
    moving: &image::Level,
    samples: SampleOptions,
) -> f64 {
    deform::LevelTerm::new(s, fixed, moving, metric, samples).eval(pts, false).0
}

fn points_f64(s: &Spline) -> Vec<[f64; 2]> {
    (0..s.num_points()).map(|p| s.point_f64(p)).collect()
}

/// After a refinement with landmarks: the new mesh's local control lets the landmarks pull
/// where the coarser meshes could not, but where the image term sees nothing only the
/// landmarks and the bending move the new variables, and L-BFGS would take many iterations
/// to carry their pull there. So the variables the image term does not see
/// ([`deform::image_sees`], as [`pyramid::unseen_from`] without landmarks) start from the
/// landmark fit over the new mesh, the others from the prolonged map `x`. Any variables
/// make an exactly C1 spline.
///
/// (Bug: each variable started between the two, weighted by the image term's share of its
/// curvature. With two mesh levels on the textured pair of `tests/it/register.rs` that
/// share was well below 1 where the image does hold the map, the start moved towards the
/// landmarks-only fit, the metric rose fourteenfold at the refinement, and 30 iterations
/// ended 0.33 px from the truth against 0.072 px for the image alone; now 0.073 px.)
fn landmark_start(
    obj: &Objective,
    term: &deform::LevelTerm<'_>,
    x: &[f64],
    s: &Spline,
    mds: &Mds,
    landmarks: &[Landmark],
    fo: &FitOptions,
) -> Result<Vec<f64>, RegisterError> {
    let fit = crate::fit::fit_with(s, mds, landmarks, fo, Instant::now())?.spline;
    let xf = variables_of(&obj.param, &fit);
    Ok(pyramid::unseen_from(x, &xf, &deform::image_sees(obj, term, x, UNSEEN)))
}

/// The variables of `param` at the control points of `s` (a spline over the same mesh).
fn variables_of(param: &Param, s: &Spline) -> Vec<f64> {
    let nv = param.nv();
    let mut x = vec![0.0; 2 * nv];
    for (p, k) in param.var_of.iter().enumerate() {
        if let Some(k) = *k {
            [x[k], x[nv + k]] = s.point_f64(p);
        }
    }
    x
}

/// Registers MOVING to FIXED (module docs).
pub fn register(
    fixed: &Input,
    moving: &Input,
    opts: &RegisterOptions,
) -> Result<Registration, RegisterError> {
    let start = Instant::now();
    fixed.validate()?;
    moving.validate()?;
    if !(opts.bend.is_finite() && opts.bend >= 0.0) {
        return Err(RegisterError::Option(format!(
            "the bending weight must be >= 0, got {}",
            opts.bend
        )));
    }
    if !(opts.landmark_weight.is_finite() && opts.landmark_weight >= 0.0) {
        return Err(RegisterError::Option(format!(
            "the landmark weight must be >= 0, got {}",
            opts.landmark_weight
        )));
    }
    if !(opts.floor.is_finite() && opts.floor < 1.0) {
        return Err(RegisterError::Option(format!(
            "the determinant floor must be below 1, got {}",
            opts.floor
        )));
    }
    if let Some(k) = opts.mesh_levels.filter(|k| !(1..=8).contains(k)) {
        return Err(RegisterError::Option(format!("mesh levels must be 1 to 8, got {k}")));
    }
    if !(opts.refine_share > 0.0 && opts.refine_share <= 1.0) {
        return Err(RegisterError::Option(format!(
            "the refinement share must be in (0, 1], got {}",
            opts.refine_share
        )));
    }
    if opts.hard && opts.landmarks.is_empty() {
        return Err(RegisterError::Option("--hard needs landmarks".into()));
    }
    if let Some((i, l)) =
        opts.landmarks.iter().enumerate().find(|(_, l)| !(l.weight.is_finite() && l.weight >= 0.0))
    {
        return Err(RegisterError::Option(format!(
            "landmark {} has weight {}; weights must be finite and >= 0",
            l.name.clone().unwrap_or_else(|| format!("#{i}")),
            l.weight
        )));
    }
    let nl = opts.level_count(fixed, moving);
    // A given mesh (init, pinned points) is kept as it is.
    let mesh_levels = if opts.init.is_some() || !opts.pinned.is_empty() {
        1
    } else {
        opts.mesh_levels.unwrap_or(DEFAULT_MESH_LEVELS).min(nl)
    };
    let fp = image::pyramid(&fixed.image, fixed.mask.as_ref().map(|m| &m.0), nl);
    let mp = image::pyramid(&moving.image, moving.mask.as_ref().map(|m| &m.0), nl);
    let frame = affine::AffineFrame::new(moving.image.w, moving.image.h);
    let mut levels = Vec::new();

    // The start: the pre-alignment over a new mesh, or the given deformation.
    let (s0, th, prealigned) = match &opts.init {
        Some(s) => (s.clone(), frame.start(fixed.image.w, fixed.image.h), None),
        None => {
            let (th, reps) = affine::prealign(
                opts.prealign,
                opts.metric,
                &fp,
                &mp,
                &frame,
                opts.affine_iters,
                (opts.progress.as_ref(), &opts.cancel),
            );
            opts.cancel.check().map_err(|_| RegisterError::Cancelled)?;
            levels.extend(reps);
            let a = frame.matrix(&th);
            let ar = a.map(|row| row.map(|v| grid_rat(v, crate::fit::frame::AFFINE_BITS)));
            let mesh =
                pyramid::coarse_mesh(moving.image.w, moving.image.h, opts.spacing, mesh_levels)?;
            (Spline::affine(mesh, opts.degree, &ar)?, th, Some(ar))
        }
    };
    let affine =
        if opts.init.is_some() { [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] } else { frame.matrix(&th) };
    let det_a = affine[0][0] * affine[1][1] - affine[0][1] * affine[1][0];

    // Overlap after the pre-alignment, on the finest level.
    let p0 = points_f64(&s0);
    let check = deform::LevelTerm::new(&s0, &fp[0], &mp[0], opts.metric, opts.samples);
    let (metric_prealigned, _, valid) = check.eval(&p0, false);
    let n0 = check.set.len().max(1) as f64;
    let share = valid as f64 / n0;
    if share < MIN_OVERLAP {
        return Err(RegisterError::NoOverlap {
            percent: 100.0 * share,
            needed: 100.0 * MIN_OVERLAP,
        });
    }
    let metric_before = {
        let id = Spline::identity(s0.mesh().clone(), 1)?;
        full_metric(&id, &points_f64(&id), opts.metric, &fp[0], &mp[0], opts.samples)
    };
    drop(check);

    // The spline stage, with the metric's bending scale.
    let bend = opts.bend * opts.metric.bend_scale();
    let mds = Mds::new(&s0)?;
    let n = s0.num_points();
    let mut is_var = vec![true; n];
    for p in &opts.pinned {
        if p.index() < n {
            is_var[p.index()] = false;
        }
    }
    // With landmarks, the spline stage may start from the landmark fit (bending and landmarks
    // only, solved directly, [`crate::fit::fit_with`]): where the image term sees
    // nothing (flat or masked parts) L-BFGS would take many iterations to carry the
    // landmarks' pull there, and the fit puts it there at once. Where the image is textured
    // and the landmarks are few and noisy, the fit (which nearly interpolates them) is a
    // worse start than the pre-alignment: on the test image of `tests/it/register.rs`
    // (12 landmarks with 0.25 px noise) it doubles the metric, and 30 iterations per level
    // end 3x further from the truth. So the coarsest level runs from both, and the run that
    // ends with the lower objective (image term + bending + landmarks) goes on; the report
    // lists that run and names its start ([`SplineStart`]).
    // The fit's weights are those of the finest level: there the registration's objective
    // is `sum LW w_i |r_i|^2 / N + (bend / A) E` (N samples, A MOVING's area) away from the
    // image term, which is the fit's `sum w_i |r_i|^2 + lambda E` with
    // `lambda = bend N / (A LW)`, and the fit's scale-free weight is `lambda / (sum w_i A)`.
    let fit_options = (opts.landmarks.len() >= 3 && opts.landmark_weight > 0.0).then(|| {
        let area = (moving.image.w * moving.image.h) as f64;
        let sum_w: f64 = opts.landmarks.iter().map(|l| l.weight).sum::<f64>().max(1e-300);
        let lambda = bend * n0 / (area * opts.landmark_weight);
        FitOptions {
            pinned: opts.pinned.clone(),
            bend: crate::fit::Bend::Weight(lambda / (sum_w * area)),
            bend_area: Some(area),
            ..FitOptions::default()
        }
    });
    let s_fit = match &fit_options {
        Some(fo) => {
            Some(crate::fit::fit_with(&s0, &mds, &opts.landmarks, fo, Instant::now())?.spline)
        }
        None => None,
    };
    let barrier = Barrier::with_floor(opts.floor)
        .map_err(|e| RegisterError::Option(e.to_string()))?
        .relative_to(det_a);
    let area = (moving.image.w * moving.image.h) as f64;
    // The objective (bending, landmarks, barrier) over the spline space of `s`'s mesh, the
    // variables starting at `s`'s free points.
    let objective = |s: &Spline, mds: &Mds, is_var: &[bool]| -> Result<Objective, RegisterError> {
        let param = Param::new(s, mds, is_var);
        // Each landmark weighs `landmark_weight * w_i` times one image sample (the image term
        // is a mean over the level's samples, so the rows are rescaled by 1 / samples per
        // level).
        let mut rows = Vec::with_capacity(opts.landmarks.len());
        for (i, l) in opts.landmarks.iter().enumerate() {
            let row =
                data_row(s, l.src, l.dst, opts.landmark_weight * l.weight).ok_or_else(|| {
                    RegisterError::Option(format!(
                        "landmark {} at ({}, {}) lies outside MOVING's mesh",
                        l.name.clone().unwrap_or_else(|| format!("#{i}")),
                        l.src[0],
                        l.src[1]
                    ))
                })?;
            rows.push(row);
        }
        Ok(Objective::new(
            s,
            param,
            rows,
            Loss::Squares,
            bend / area,
            Some(barrier),
            crate::spline::jacobian::SAMPLE_LEVEL,
        ))
    };
    let mut obj = objective(s_fit.as_ref().unwrap_or(&s0), &mds, &is_var)?;
    // The pre-alignment in the same variables (the pinned points are equal in both).
    let mut x_prealigned = s_fit.is_some().then(|| variables_of(&obj.param, &s0));
    let mut spline_start = SplineStart::LandmarkFit;
    let mut x = obj.param.x0();
    let mut variables = x.len();
    let (mut cur, mut mds) = (s0, mds);
    let mut mesh_level = mesh_levels - 1;
    let mut refinements = Vec::new();
    let mut row_scale = 1.0;
    for l in (0..nl as usize).rev() {
        let mut refined = false;
        // The mesh pyramid: refine (exactly, the same map) until this level's mesh.
        while mesh_level > pyramid::mesh_level(l as u32, mesh_levels) {
            let bits = crate::spline::mds::rounding_bits(mds.amplification(), opts.grid_bits);
            let exact =
                cur.with_determined_points(&mds, obj.param.rounded_points(&cur, &x, bits))?;
            let (fine, step) = pyramid::refine(
                &exact,
                (&fp[l], &mp[l]),
                opts.metric,
                opts.samples,
                opts.refine_share,
            )?;
            refinements.push(step);
            mds = Mds::new(&fine)?;
            obj = objective(&fine, &mds, &vec![true; fine.num_points()])?;
            cur = fine;
            x = obj.param.x0();
            variables = x.len();
            row_scale = 1.0;
            mesh_level -= 1;
            refined = true;
        }
        let term = deform::LevelTerm::new(&cur, &fp[l], &mp[l], opts.metric, opts.samples);
        let scale = 1.0 / term.set.len().max(1) as f64;
        obj.scale_weights(&vec![scale / row_scale; obj.rows().len()]);
        row_scale = scale;
        if let (true, Some(fo)) = (refined, &fit_options) {
            x = landmark_start(&obj, &term, &x, &cur, &mds, &opts.landmarks, fo)?;
        } else if let (true, Some(a)) = (refined, &prealigned) {
            let pre =
                variables_of(&obj.param, &Spline::affine(cur.mesh().clone(), opts.degree, a)?);
            x = pyramid::unseen_from(&x, &pre, &deform::image_sees(&obj, &term, &x, UNSEEN));
        }
        let watch = (opts.progress.as_ref(), &opts.cancel);
        let (mut nx, mut rep) = deform::run_level(&obj, &term, x, l as u32, opts.max_iters, watch);
        opts.cancel.check().map_err(|_| RegisterError::Cancelled)?;
        if let Some(xp) = x_prealigned.take() {
            // The coarsest level from the pre-alignment too; the lower objective wins.
            let (px, prep) = deform::run_level(&obj, &term, xp, l as u32, opts.max_iters, watch);
            opts.cancel.check().map_err(|_| RegisterError::Cancelled)?;
            if deform::total(&obj, &term, &px).0 < deform::total(&obj, &term, &nx).0 {
                (nx, rep) = (px, prep);
                spline_start = SplineStart::Prealigned;
            }
        }
        x = nx;
        rep.triangles = Some(cur.mesh().num_triangles());
        levels.push(rep);
    }

    // Exact output, rounded so that no control point moves more than 2^-grid_bits px.
    let bits = crate::spline::mds::rounding_bits(mds.amplification(), opts.grid_bits);
    let rounded = obj.param.rounded_points(&cur, &x, bits);
    let soft = cur.with_determined_points(&mds, rounded)?;
    let spline = if opts.hard || !opts.pinned.is_empty() {
        let fo = FitOptions {
            hard: opts.hard,
            pinned: opts.pinned.clone(),
            grid_bits: bits,
            ..FitOptions::default()
        };
        crate::fit::hard::exact_constraints(&cur, &mds, &soft, &opts.landmarks, &fo)?
    } else {
        soft
    };
    let cert = crate::spline::jacobian::certify(&spline, &CertifyOptions::default());
    let metric_after =
        full_metric(&spline, &points_f64(&spline), opts.metric, &fp[0], &mp[0], opts.samples);
    let landmarks = if opts.landmarks.is_empty() {
        None
    } else {
        let res = residuals(&spline, &opts.landmarks)?;
        Some(LandmarkReport {
            count: opts.landmarks.len(),
            start: if s_fit.is_some() { spline_start } else { SplineStart::Prealigned },
            hard: opts.hard,
            fit: Stats::of(&res),
            residuals: res,
        })
    };
    let report = RegisterReport {
        metric: opts.metric,
        metric_before,
        metric_prealigned,
        metric_after,
        prealign: if opts.init.is_some() { Prealign::None } else { opts.prealign },
        affine,
        levels,
        pyramid_levels: nl,
        mesh_levels,
        refinements,
        triangles: spline.mesh().num_triangles(),
        vertices: spline.mesh().num_vertices(),
        variables,
        fold_free: cert.fold_free,
        det_j_lower_bound: cert.lower_bound,
        min_det_j: cert.sampled_min,
        exact_c1: true,
        landmarks,
        time_ms: start.elapsed().as_secs_f64() * 1e3,
    };
    Ok(Registration { spline, report })
}
