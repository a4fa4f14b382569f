//! Image morphing between two images `A` and `B` through matched landmarks.
//!
//! **Maps and units** (pixels, centres at integers, `x` right, `y` down; details in
//! [`fits`]). `S` ([`align`]): `B`'s pixels -> `A`'s pixels, the landmarks' least-squares
//! similarity (Umeyama; the identity with [`MorphOptions::align`] off). `phi_ab`: `A`'s
//! pixels -> `A`'s pixels, fitted to `L_A -> S(L_B)` (it is `S ∘ phi_{A->B}`, and
//! `phi_{A->B}` = [`Morph::phi_ab_raw`] maps `A`'s pixels to `B`'s own). `phi_ba`: `B`'s own
//! pixels -> `A`'s pixels, fitted to `L_B -> L_A` on a mesh over `B`'s rectangle.
//!
//! **Method.** With `s = alpha_shape(t)`, the intermediate landmarks are
//! `L_t = (1 - s) L_A + s S(L_B)` (in `A`'s pixels) and the frame's maps are
//!
//! ```text
//! phi_{A->t} = (1 - s) id + s phi_ab        (A's pixels -> frame, on phi_ab's mesh)
//! phi_{B->t} = s S + (1 - s) phi_ba         (B's pixels -> frame, on phi_ba's mesh)
//! ```
//!
//! Frame `t` (of `A`'s size) pulls `A` back through `phi_{A->t}` and `B` through
//! `phi_{B->t}` and cross-dissolves them with weight `c = alpha_color(t)` on `B`
//! ([`job`] for pixels only one image covers). `t = 0` is `A`, `t = 1` is `B` moved by
//! `S` into `A`'s frame. The two schedules are separate ([`Schedule`]); `alpha_shape` may
//! leave `[0, 1]` (caricature), `alpha_color` is clamped to `[0, 1]`.
//!
//! **Exact C1 blend.** The blends are formed control point by control point in exact
//! rational arithmetic (`S` has rational coefficients): the C1 conditions are linear and
//! invariant under affine maps, so an affine combination of exactly-C1 splines on one mesh is
//! exactly C1, for any `s` (also outside `[0, 1]`). The per-frame blend therefore skips the
//! exact re-check ([`Spline::set_points_c1_by_construction`]); the tests re-check it.
//!
//! **The fits** ([`fits`]) use [`crate::fit::frame::fit_frame`]: a landmark-adapted mesh
//! with a margin large enough that each map covers `A`'s frame (proven by
//! [`crate::fit::frame::covers_frame`]), the fold barrier on, and a certified `det J > 0`.
//! With a fixed bending weight and the barrier inactive the fit is linear in its targets, so
//! the blend `phi_{A->t}` equals a direct fit to `L_t` (up to the fits' 2^-20 px rounding and
//! their ridge anchored at the affine warm start); where the barrier acts, it does *not*:
//! the blend is then a convex combination of two certified maps, which [`Morph::check_frame`]
//! certifies again frame by frame. A landmark `L_A` lands at `L_t` up to `s` times the A->B
//! fit's residual ([`Morph::landmark_errors`]).
//!
//! **Sizes and types.** Output frames have `A`'s size; `B` keeps its own size and pixels
//! (neither padded nor cropped). Both images are converted to one common type, the richer of
//! the two: 8-bit unless either is 16-bit or float, grey unless either is colour, alpha if
//! either has alpha (RGB8 with grey16 gives RGB16).
//!
//! **Preview.** [`Morph::preview_frame`] draws `A` as a fine colour mesh ([`ColorMesh`]):
//! vertices moved by `phi_{A->t}`, vertex colours blended with `B`'s colour at
//! `phi_{A->B}(v)`, rasterized with tiny-skia.

pub mod align;
mod blend;
pub mod fits;
mod frames;
mod job;
mod lzw;
pub mod output;
mod preview;
#[cfg(test)]
mod tests;

use crate::exact::matrix::{rat_to_f64, Rat};
use crate::exact::Int;
use crate::fit::frame::FrameFitOptions;
use crate::fit::landmarks::Landmark;
use crate::fit::{fit, FitError, FitOptions};
use crate::mesh::{AdaptOptions, Mesh, MeshError, MeshOptions};
use crate::render::colormesh::rasterize;
use crate::spline::{Spline, SplineError};
use crate::warp::colormesh::{ColorMesh, ColorMeshError, ColorMode, Colors};
use crate::warp::remap::{CurvatureBounds, RemapOptions};
use crate::warp::sample::{Source, Texel};
use crate::warp::Interp;
use align::{umeyama, AlignError, Similarity};
use blend::Blend;
use fits::{fit_covering, MapSummary};
pub use frames::FrameCheck;
use image::DynamicImage;
use num_rational::BigRational;
pub use preview::Preview;
use serde::Serialize;
use std::sync::OnceLock;
use tiny_skia::Pixmap;

/// Why a morph cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum MorphError {
    /// Fewer than 3 landmark pairs.
    #[error("morphing needs at least 3 landmark pairs, found {0}")]
    TooFewLandmarks(usize),
    /// A landmark outside its image.
    #[error(
        "landmark {index} ({name}): point ({x}, {y}) lies outside image {image} \
         ({w} x {h} px: pixel centres run from 0 to {wm} and {hm}, and a landmark may lie up \
         to one pixel beyond them, x from -1 to {w}, y from -1 to {h}); correct or remove it",
        wm = .w.saturating_sub(1),
        hm = .h.saturating_sub(1)
    )]
    OutsideImage {
        /// Index in the input.
        index: usize,
        /// Its name or `-`.
        name: String,
        /// `A` (src) or `B` (dst).
        image: char,
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// Image width.
        w: u32,
        /// Image height.
        h: u32,
    },
    /// An image smaller than 2 x 2.
    #[error("image {0} is too small ({1} x {2} px; at least 2 x 2)")]
    TooSmall(char, u32, u32),
    /// Fewer than 2 frames.
    #[error("a morph needs at least 2 frames, got {0}")]
    Frames(usize),
    /// A grid over `B` with no cells or more than [`MAX_CELLS`] per side.
    #[error("--cells (cells per side of the mesh over B) must be between 1 and {max}, got {0}: finer meshes exceed the fit's size limit", max = MAX_CELLS)]
    Cells(usize),
    /// The background is not a sample of the frames' type.
    #[error(transparent)]
    Background(#[from] crate::warp::WarpError),
    /// A schedule value that is not finite.
    #[error("the schedule is not finite at t = {0}")]
    Schedule(f64),
    /// The mesh could not be built.
    #[error("mesh: {0}")]
    Mesh(#[from] MeshError),
    /// A fit failed.
    #[error("fitting {dir}: {source}")]
    Fit {
        /// `A->B` or `B->A`.
        dir: &'static str,
        /// The fit's error.
        source: FitError,
    },
    /// A blended spline is not C1 (a bug if it ever happens).
    #[error(transparent)]
    Spline(#[from] SplineError),
    /// The preview mesh.
    #[error("colour mesh: {0}")]
    ColorMesh(#[from] ColorMeshError),
    /// No similarity brings `B` into `A`'s frame.
    #[error("aligning B to A: {0}")]
    Align(#[from] AlignError),
    /// A fit cannot be certified fold-free: the landmarks force a fold.
    #[error(
        "fitting {dir}: the landmarks force a fold (certified det J lower bound {lower_bound:.3}); \
         {}; a morph through a folded map shows creases and torn strips, so correct or remove \
         one landmark of each pair",
        if pairs.is_empty() {
            "no single crossing pair was found, the landmarks as a whole demand it".to_string()
        } else {
            format!("these landmark pairs cross: {}", pairs.join(", "))
        }
    )]
    Folds {
        /// `A->B` or `B->A`.
        dir: &'static str,
        /// The certificate's lower bound of det J.
        lower_bound: f64,
        /// The crossing pairs, as `i (name) and j (name)`.
        pairs: Vec<String>,
    },
}

/// Largest [`MorphOptions::cells`]: finer grids exceed the fit's size limit
/// ([`crate::fit::options::MAX_FIT_VARIABLES`]).
pub const MAX_CELLS: usize = 48;

/// Checks [`MorphOptions::cells`]: 1 to [`MAX_CELLS`] ([`MorphError::Cells`] otherwise).
pub fn check_cells(cells: usize) -> Result<(), MorphError> {
    if (1..=MAX_CELLS).contains(&cells) {
        Ok(())
    } else {
        Err(MorphError::Cells(cells))
    }
}

/// A schedule `alpha(t)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Schedule {
    /// `alpha(t) = t`.
    #[default]
    Linear,
    /// Smoothstep `3t^2 - 2t^3` on `[0, 1]`, `t` outside.
    Smooth,
}

impl Schedule {
    /// `alpha(t)`.
    pub fn at(self, t: f64) -> f64 {
        match self {
            Schedule::Linear => t,
            Schedule::Smooth if (0.0..=1.0).contains(&t) => t * t * (3.0 - 2.0 * t),
            Schedule::Smooth => t,
        }
    }

    /// `alpha(t)` in exact arithmetic (the same formula as [`Schedule::at`]).
    pub fn at_exact(self, t: &Rat) -> Rat {
        let (zero, one) = (Rat::from_integer(Int::from(0)), Rat::from_integer(Int::from(1)));
        match self {
            Schedule::Smooth if *t >= zero && *t <= one => {
                let three = Rat::from_integer(Int::from(3));
                let two = Rat::from_integer(Int::from(2));
                t * t * (three - two * t)
            }
            _ => t.clone(),
        }
    }
}

impl Schedule {
    /// The names [`Schedule`]'s `FromStr` takes (`--shape`, `--color`, Python's `shape=`
    /// and `color=`).
    pub const NAMES: [&'static str; 2] = ["linear", "smooth"];
}

/// A schedule name that is none of [`Schedule::NAMES`] (the text given).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown schedule `{0}` (use linear or smooth)")]
pub struct UnknownSchedule(pub String);

impl std::str::FromStr for Schedule {
    type Err = UnknownSchedule;
    fn from_str(s: &str) -> Result<Schedule, UnknownSchedule> {
        match s {
            "linear" => Ok(Schedule::Linear),
            "smooth" => Ok(Schedule::Smooth),
            _ => Err(UnknownSchedule(s.to_string())),
        }
    }
}

/// Options of a [`Morph`].
#[derive(Clone, Debug, PartialEq)]
pub struct MorphOptions {
    /// Bring `B` into `A`'s frame by the landmarks' similarity (default true;
    /// [`align`]).
    pub align: bool,
    /// The landmark-adapted meshes of both fits (default: [`AdaptOptions::default`] with the
    /// snapping grid chosen from the landmarks; [`fits`] chooses the margin).
    pub mesh: AdaptOptions,
    /// Mesh cells per side of the grid mesh over `B` on which `phi_{B->A}` is fitted when
    /// only `phi_{A->B}` is given ([`Morph::from_deformations`]; default 8).
    pub cells: usize,
    /// Spline degree (default 5).
    pub degree: usize,
    /// Fit options of both fits (default: the fold barrier on, a fixed bending weight
    /// [`crate::fit::smooth::INTERPOLATING_BEND`], so both maps meet their landmarks; see
    /// the module docs and [`fits`]).
    pub fit: FitOptions,
    /// Resampling.
    pub interp: Interp,
    /// `alpha_shape`.
    pub shape: Schedule,
    /// `alpha_color` (clamped to `[0, 1]`).
    pub color: Schedule,
    /// Value of every channel where neither image has a preimage (alpha 0 there).
    pub background: f64,
    /// Preimage computation.
    pub remap: RemapOptions,
    /// Keep `A`'s frame border still in every frame (border landmarks, [`fits::frame_pins`];
    /// default false).
    pub pin_frame: bool,
    /// What a frame shows where neither image has a preimage on its pixels
    /// ([`crate::warp::edge`]; [`job`]): the background (default), the dissolve of the
    /// edge-clamped samples, or of the mirrored ones.
    pub mode: crate::warp::EdgeMode,
}

impl Default for MorphOptions {
    fn default() -> Self {
        MorphOptions {
            align: true,
            mesh: AdaptOptions { grid: 0, ..AdaptOptions::default() },
            cells: 8,
            degree: 5,
            // A fixed weight (not GCV): where the barrier does not act the fits are linear
            // in the targets (module docs). Interpolation: both maps meet their landmarks.
            fit: FitOptions {
                bend: crate::fit::Bend::Weight(crate::fit::smooth::INTERPOLATING_BEND),
                ..FitOptions::default()
            },
            interp: Interp::Bilinear,
            shape: Schedule::Linear,
            color: Schedule::Linear,
            background: 0.0,
            remap: RemapOptions::default(),
            pin_frame: false,
            mode: crate::warp::EdgeMode::Constant,
        }
    }
}

/// `t = k / (n - 1)` for `k = 0 .. n`.
pub fn frame_times(n: usize) -> Vec<f64> {
    (0..n).map(|k| if n < 2 { 0.0 } else { k as f64 / (n - 1) as f64 }).collect()
}

/// `t = k / (n - 1)` for `k = 0 .. n`, exactly. Small denominators keep the blended control
/// points short (blending with `1/29` as an `f64` costs several times more than `1/29`).
pub fn frame_times_exact(n: usize) -> Vec<Rat> {
    let d = Int::from(n.saturating_sub(1).max(1) as i64);
    (0..n).map(|k| Rat::new(Int::from(k as i64), d.clone())).collect()
}

/// The common working type of two images (see the module docs).
/// A type's sample depth: 0 (8-bit), 1 (16-bit) or 2 (float). A morph works in the deeper
/// of its two images' ([`common`]).
fn depth(c: image::ColorType) -> u8 {
    use image::ColorType as C;
    match c {
        C::Rgb32F | C::Rgba32F => 2,
        C::L16 | C::La16 | C::Rgb16 | C::Rgba16 => 1,
        _ => 0,
    }
}

/// Checks that `value` is a background sample of the type a morph of `a` and `b` works in
/// (the deeper of theirs): [`crate::warp::check_background`]'s rule, so that nothing is
/// clamped or rounded silently. The constructors check it before fitting (and
/// `trimorph morph` right after reading the images).
pub fn check_background(value: f64, a: &DynamicImage, b: &DynamicImage) -> Result<(), MorphError> {
    use crate::warp::Samples;
    let like = match depth(a.color()).max(depth(b.color())) {
        0 => Samples::U8(&[]),
        1 => Samples::U16(&[]),
        _ => Samples::F32(&[]),
    };
    Ok(crate::warp::check_background(value, &like)?)
}

fn common(a: &DynamicImage, b: &DynamicImage) -> (DynamicImage, DynamicImage) {
    let (ca, cb) = (a.color(), b.color());
    let d = depth(ca).max(depth(cb));
    let alpha = ca.has_alpha() || cb.has_alpha();
    let colour = ca.has_color() || cb.has_color() || d == 2;
    let conv = |x: &DynamicImage| -> DynamicImage {
        match (d, colour, alpha) {
            (0, false, false) => x.to_luma8().into(),
            (0, false, true) => x.to_luma_alpha8().into(),
            (0, true, false) => x.to_rgb8().into(),
            (0, true, true) => x.to_rgba8().into(),
            (1, false, false) => x.to_luma16().into(),
            (1, false, true) => x.to_luma_alpha16().into(),
            (1, true, false) => x.to_rgb16().into(),
            (1, true, true) => x.to_rgba16().into(),
            (_, _, false) => x.to_rgb32f().into(),
            (_, _, true) => x.to_rgba32f().into(),
        }
    };
    let keep = |x: &DynamicImage, conv_x: DynamicImage| {
        if x.color() == conv_x.color() {
            x.clone()
        } else {
            conv_x
        }
    };
    (keep(a, conv(a)), keep(b, conv(b)))
}

/// `n` times from `t0` to `t1`, equally spaced, exactly: `t0 + k (t1 - t0) / (n - 1)`.
pub fn times_between(n: usize, t0: f64, t1: f64) -> Result<Vec<Rat>, MorphError> {
    let (a, b) = (exact(t0)?, exact(t1)?);
    Ok(frame_times_exact(n).into_iter().map(|u| &a + &(&u * &(&b - &a))).collect())
}

/// `f64` as an exact rational.
fn exact(v: f64) -> Result<Rat, MorphError> {
    let r = BigRational::from_float(v).ok_or(MorphError::Schedule(v))?;
    Ok(Rat::new(Int::from_big(r.numer().clone()), Int::from_big(r.denom().clone())))
}

/// A morph: both images, the landmarks, the similarity and the two fitted deformations.
#[derive(Clone, Debug)]
pub struct Morph {
    a: DynamicImage,
    b: DynamicImage,
    landmarks: Vec<Landmark>,
    /// `S`: `B`'s pixels -> `A`'s pixels.
    sim: Similarity,
    /// `A`'s pixels -> `A`'s pixels (`S ∘ phi_{A->B}`).
    phi_ab: Spline,
    /// `B`'s pixels -> `A`'s pixels.
    phi_ba: Spline,
    /// The identity's control points (weight `1 - s`) and `phi_ab`'s (weight `s`).
    blend_a: Blend,
    /// `phi_ba`'s control points (weight `1 - s`) and `S`'s on its mesh (weight `s`).
    blend_b: Blend,
    /// The fits' summaries (`A->B`, `B->A`) for a morph made from landmarks.
    summaries: Option<[MapSummary; 2]>,
    opts: MorphOptions,
    /// The remap plans' curvature bounds of `phi_ab` and `phi_ba`, computed at the first
    /// frame: a frame's maps have `D^2 phi_{A->t} = s D^2 phi_ab` and
    /// `D^2 phi_{B->t} = (1 - s) D^2 phi_ba` ([`RemapPlan::new_scaled`]).
    curvature: OnceLock<[CurvatureBounds; 2]>,
}

/// `S` applied to every control point of the identity on `s`'s mesh, exactly.
fn similarity_points(s: &Spline, sim: &Similarity) -> Result<Vec<Vec<Rat>>, MorphError> {
    let id = Spline::identity(s.mesh().clone(), s.degree())?;
    Ok(id.points().iter().map(|p| sim.apply_exact(p)).collect())
}

/// `f` applied to every control point of `s`, exactly, as a spline on the same mesh (exactly
/// C1 when `f` is affine and `s` is: the C1 conditions are linear and affine-invariant).
fn map_points(s: &Spline, f: impl Fn(&[Rat]) -> Vec<Rat>) -> Result<Spline, MorphError> {
    let mut out = s.clone();
    out.set_points(s.points().iter().map(|p| f(p.as_slice())).collect())?;
    Ok(out)
}

/// Frame statistics of [`Morph::frame_with_stats`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FrameStats {
    /// Pixels where neither image has a preimage (they show the background).
    pub uncovered: usize,
    /// Pixels whose preimage needed a per-pixel Newton solve (both maps).
    pub newton_solves: usize,
    /// Pixels in the frame.
    pub pixels: usize,
}

fn check_inside(lms: &[Landmark], w: u32, h: u32, image: char) -> Result<(), MorphError> {
    for (index, l) in lms.iter().enumerate() {
        let p = if image == 'A' { l.src } else { l.dst };
        // The fits' own rule ([`crate::mesh::FRAME_SLACK`]): border landmarks are accepted.
        if !crate::mesh::in_landmark_frame(p, [f64::from(w), f64::from(h)]) {
            return Err(MorphError::OutsideImage {
                index,
                name: l.name.clone().unwrap_or_else(|| "-".into()),
                image,
                x: p[0],
                y: p[1],
                w,
                h,
            });
        }
    }
    Ok(())
}

impl Morph {
    /// Aligns `B` to `A` (unless [`MorphOptions::align`] is off) and fits `phi_ab` (mesh
    /// over `A`) and `phi_ba` (mesh over `B`), both covering `A`'s frame and certified
    /// fold-free ([`fits`]), in parallel.
    pub fn new(
        a: &DynamicImage,
        b: &DynamicImage,
        landmarks: &[Landmark],
        opts: &MorphOptions,
    ) -> Result<Morph, MorphError> {
        for (img, name) in [(a, 'A'), (b, 'B')] {
            if img.width() < 2 || img.height() < 2 {
                return Err(MorphError::TooSmall(name, img.width(), img.height()));
            }
        }
        if landmarks.len() < 3 {
            return Err(MorphError::TooFewLandmarks(landmarks.len()));
        }
        check_inside(landmarks, a.width(), a.height(), 'A')?;
        check_inside(landmarks, b.width(), b.height(), 'B')?;
        let sim = if opts.align {
            let (x, y): (Vec<_>, Vec<_>) = landmarks.iter().map(|l| (l.dst, l.src)).unzip();
            let w: Vec<f64> = landmarks.iter().map(|l| l.weight).collect();
            umeyama(&x, &y, &w)?
        } else {
            Similarity::identity()
        };
        check_background(opts.background, a, b)?;
        let (a, b) = common(a, b);
        let size = |i: &DynamicImage| [f64::from(i.width()), f64::from(i.height())];
        let (sa, sb) = (size(&a), size(&b));
        let mut to_a: Vec<Landmark> =
            landmarks.iter().map(|l| Landmark { dst: sim.apply(l.dst), ..l.clone() }).collect();
        let mut reversed: Vec<Landmark> =
            landmarks.iter().map(|l| Landmark { src: l.dst, dst: l.src, ..l.clone() }).collect();
        if opts.pin_frame {
            let (ab, ba) = fits::frame_pins(landmarks, sa, sb, &sim);
            to_a.extend(ab);
            reversed.extend(ba);
        }
        let fo =
            FrameFitOptions { mesh: opts.mesh.clone(), degree: opts.degree, fit: opts.fit.clone() };
        let (fab, fba) = rayon::join(
            || fit_covering(&to_a, sa, sa, &opts.mesh, &fo, "A->B"),
            || fit_covering(&reversed, sb, sa, &opts.mesh, &fo, "B->A"),
        );
        let (fab, fba) = (fab?, fba?);
        let id_a = Spline::identity(fab.spline.mesh().clone(), fab.spline.degree())?;
        Ok(Morph {
            blend_a: Blend::new(id_a.points(), fab.spline.points()),
            blend_b: Blend::new(fba.spline.points(), &similarity_points(&fba.spline, &sim)?),
            summaries: Some([fab.summary(), fba.summary()]),
            a,
            b,
            landmarks: landmarks.to_vec(),
            sim,
            phi_ab: fab.spline,
            phi_ba: fba.spline,
            opts: opts.clone(),
            curvature: OnceLock::new(),
        })
    }

    /// A morph from given deformations instead of landmarks: `phi_ab` maps `A`'s pixel
    /// coordinates to `B`'s, `phi_ba` the other way (as [`Morph::phi_ab_raw`] and
    /// [`Morph::phi_ba`] return them). Without `phi_ba`, it is fitted (with
    /// [`MorphOptions::fit`], on a `cells x cells` mesh over `B`) to `phi_ab` sampled on a
    /// 24 x 24 grid over `A` (pairs `(phi_ab(p), p)` with `phi_ab(p)` inside `B`).
    ///
    /// With [`MorphOptions::align`], the similarity `S` is the alignment the map implies:
    /// the least-squares similarity of the samples `phi_ab(p) -> p` on `A`'s frame border
    /// (all samples when fewer than 3 border ones land in `B`), so that `S ∘ phi_ab` moves
    /// the frame's border as little as a similarity allows: a map that takes `A`'s frame
    /// onto `B`'s gives a morph whose frame stays still. (The landmarks are not known here,
    /// so it is close to, not equal to, the landmark morph's.) The blends use each deformation's own mesh
    /// and degree (`phi_{A->t}` is `(1 - s) id + s S ∘ phi_ab` on `phi_ab`'s mesh), so they
    /// stay exactly C1. Pixels of `A` outside `phi_ab`'s domain have no preimage in any frame
    /// (they show `B`, or the background); [`Morph::coverage`] tells how much of `A` is
    /// covered. Such a morph has no landmarks ([`Morph::landmark_errors`] is empty).
    pub fn from_deformations(
        a: &DynamicImage,
        b: &DynamicImage,
        phi_ab: Spline,
        phi_ba: Option<Spline>,
        opts: &MorphOptions,
    ) -> Result<Morph, MorphError> {
        Morph::from_deformations_with(a, b, phi_ab, phi_ba, None, opts)
    }

    /// [`Morph::from_deformations`] with a given similarity `S` (`B`'s pixels -> `A`'s; for
    /// instance the one a landmark morph stored in its `phi_ab.json`) instead of one
    /// estimated from samples of `phi_ab`. With the landmark morph's own deformations and
    /// similarity, the morph is that morph exactly: `S ∘ S^-1 ∘ phi_ab` is computed in
    /// rationals. `None`: as [`Morph::from_deformations`]; [`MorphOptions::align`] off
    /// ignores `similarity`.
    pub fn from_deformations_with(
        a: &DynamicImage,
        b: &DynamicImage,
        phi_ab: Spline,
        phi_ba: Option<Spline>,
        similarity: Option<Similarity>,
        opts: &MorphOptions,
    ) -> Result<Morph, MorphError> {
        for (img, name) in [(a, 'A'), (b, 'B')] {
            if img.width() < 2 || img.height() < 2 {
                return Err(MorphError::TooSmall(name, img.width(), img.height()));
            }
        }
        check_background(opts.background, a, b)?;
        let (a, b) = common(a, b);
        let (bw, bh) = (f64::from(b.width() - 1), f64::from(b.height() - 1));
        let grid = 24;
        let pts: Vec<[f64; 2]> = (0..grid * grid)
            .map(|k| {
                let (i, j) = (k % grid, k / grid);
                [
                    f64::from(a.width() - 1) * i as f64 / (grid - 1) as f64,
                    f64::from(a.height() - 1) * j as f64 / (grid - 1) as f64,
                ]
            })
            .collect();
        let mut q = vec![None; pts.len()];
        phi_ab.eval_many(&pts, &mut q);
        let samples: Vec<Landmark> = pts
            .iter()
            .zip(&q)
            .filter_map(|(p, q)| {
                let q = (*q)?;
                let inside = q[0] >= 0.0 && q[1] >= 0.0 && q[0] <= bw && q[1] <= bh;
                inside.then_some(Landmark { name: None, src: q, dst: *p, weight: 1.0 })
            })
            .collect();
        // The alignment the map implies: the similarity of its samples on A's frame border
        // (so that the border moves as little as a similarity allows), or of all samples
        // when fewer than 3 border samples land in B.
        let on_border = |p: &[f64; 2]| {
            let (wa, ha) = (f64::from(a.width() - 1), f64::from(a.height() - 1));
            p[0] == 0.0 || p[1] == 0.0 || p[0] == wa || p[1] == ha
        };
        let border: Vec<&Landmark> = samples.iter().filter(|l| on_border(&l.dst)).collect();
        let fit_on: Vec<&Landmark> =
            if border.len() >= 3 { border } else { samples.iter().collect() };
        let sim = if let (true, Some(given)) = (opts.align, similarity) {
            given
        } else if opts.align && fit_on.len() >= 2 {
            let (x, y): (Vec<_>, Vec<_>) = fit_on.iter().map(|l| (l.src, l.dst)).unzip();
            umeyama(&x, &y, &vec![1.0; x.len()])?
        } else {
            Similarity::identity()
        };
        let phi_ba = match phi_ba {
            Some(s) => s,
            None => {
                if samples.len() < 3 {
                    return Err(MorphError::TooFewLandmarks(samples.len()));
                }
                check_cells(opts.cells)?;
                let mesh = Mesh::grid(opts.cells, opts.cells, bw, bh, MeshOptions::default())?;
                let id_b = Spline::identity(mesh, opts.degree)?;
                fit(&id_b, &samples, &opts.fit)
                    .map_err(|source| MorphError::Fit { dir: "B->A", source })?
                    .spline
            }
        };
        let phi_ab = map_points(&phi_ab, |p| sim.apply_exact(p))?;
        let id_a = Spline::identity(phi_ab.mesh().clone(), phi_ab.degree())?;
        Ok(Morph {
            blend_a: Blend::new(id_a.points(), phi_ab.points()),
            blend_b: Blend::new(phi_ba.points(), &similarity_points(&phi_ba, &sim)?),
            summaries: None,
            a,
            b,
            landmarks: Vec::new(),
            sim,
            phi_ab,
            phi_ba,
            opts: opts.clone(),
            curvature: OnceLock::new(),
        })
    }

    /// The similarity `S` (`B`'s pixels -> `A`'s pixels; the identity without alignment).
    pub fn similarity(&self) -> &Similarity {
        &self.sim
    }

    /// The summaries of the fits `A->B` and `B->A` (a morph from landmarks only).
    pub fn fit_summaries(&self) -> Option<&[MapSummary; 2]> {
        self.summaries.as_ref()
    }

    /// `phi_{A->B}`: `A`'s pixels -> `B`'s own pixels, `S^-1 ∘ phi_ab`, exactly (what
    /// `phi_ab.json` holds).
    pub fn phi_ab_raw(&self) -> Result<Spline, MorphError> {
        map_points(&self.phi_ab, |p| self.sim.inverse_exact(p))
    }

    /// The fraction of `A`'s pixels inside `phi_{A->B}`'s domain (sampled every 4 pixels);
    /// 1 for a morph made from landmarks.
    pub fn coverage(&self) -> f64 {
        let (w, h) = (self.a.width(), self.a.height());
        let pts: Vec<[f64; 2]> = (0..h)
            .step_by(4)
            .flat_map(|y| (0..w).step_by(4).map(move |x| [f64::from(x), f64::from(y)]))
            .collect();
        let mut q = vec![None; pts.len()];
        self.phi_ab.eval_many(&pts, &mut q);
        q.iter().filter(|q| q.is_some()).count() as f64 / pts.len().max(1) as f64
    }

    /// `A` in the working type.
    pub fn image_a(&self) -> &DynamicImage {
        &self.a
    }

    /// `B` in the working type.
    pub fn image_b(&self) -> &DynamicImage {
        &self.b
    }

    /// `phi_ab`: `A`'s pixels -> `A`'s pixels, `S ∘ phi_{A->B}` (the map `phi_{A->t}`
    /// blends with the identity; [`Morph::phi_ab_raw`] is `phi_{A->B}` itself).
    pub fn phi_ab(&self) -> &Spline {
        &self.phi_ab
    }

    /// `phi_ba`: `B`'s pixels -> `A`'s pixels (what `phi_ba.json` holds).
    pub fn phi_ba(&self) -> &Spline {
        &self.phi_ba
    }

    /// The options.
    pub fn options(&self) -> &MorphOptions {
        &self.opts
    }

    /// `phi_{A->t}` for the shape weight `s`: `(1 - s) id + s phi_{A->B}`, exactly.
    pub fn phi_a_at(&self, s: f64) -> Result<Spline, MorphError> {
        self.phi_a_exact(&exact(s)?)
    }

    /// [`Morph::phi_a_at`] for an exact `s`.
    pub fn phi_a_exact(&self, s: &Rat) -> Result<Spline, MorphError> {
        Ok(self.phi_ab.with_points_c1_by_construction(self.blend_a.at(s))?)
    }

    /// `phi_{B->t}` for the shape weight `s`: `s S + (1 - s) phi_ba` (`B`'s pixels -> `A`'s
    /// pixels), exactly.
    pub fn phi_b_at(&self, s: f64) -> Result<Spline, MorphError> {
        self.phi_b_exact(&exact(s)?)
    }

    /// [`Morph::phi_b_at`] for an exact `s`.
    pub fn phi_b_exact(&self, s: &Rat) -> Result<Spline, MorphError> {
        Ok(self.phi_ba.with_points_c1_by_construction(self.blend_b.at(s))?)
    }

    /// `(phi_{A->t}, phi_{B->t})` for rendering: the maps of [`Morph::phi_a_exact`] and
    /// [`Morph::phi_b_exact`] with their control points as unreduced fractions (the same
    /// values and `f64`s, without the gcds), built in parallel.
    fn frame_maps(&self, s: &Rat) -> Result<(Spline, Spline), MorphError> {
        let (sa, sb) = rayon::join(
            || self.phi_ab.with_points_c1_by_construction(self.blend_a.at_raw(s)),
            || self.phi_ba.with_points_c1_by_construction(self.blend_b.at_raw(s)),
        );
        Ok((sa?, sb?))
    }

    /// `alpha_shape(t)` and the clamped `alpha_color(t)`.
    pub fn weights(&self, t: f64) -> Result<(f64, f64), MorphError> {
        let (s, c) = (self.opts.shape.at(t), self.opts.color.at(t));
        if !(s.is_finite() && c.is_finite()) {
            return Err(MorphError::Schedule(t));
        }
        Ok((s, c.clamp(0.0, 1.0)))
    }

    /// The intermediate landmarks `L_t = (1 - s) L_A + s S(L_B)` (pixels of `A`).
    pub fn landmarks_at(&self, t: f64) -> Result<Vec<[f64; 2]>, MorphError> {
        let (s, _) = self.weights(t)?;
        Ok(self
            .landmarks
            .iter()
            .map(|l| {
                let d = self.sim.apply(l.dst);
                [0, 1].map(|k| (1.0 - s) * l.src[k] + s * d[k])
            })
            .collect())
    }

    /// For each landmark, `|phi_{A->t}(L_A) - L_t|` and `|phi_{B->t}(L_B) - L_t|` (pixels).
    pub fn landmark_errors(&self, t: f64) -> Result<Vec<[f64; 2]>, MorphError> {
        let (s, _) = self.weights(t)?;
        let (pa, pb) = (self.phi_a_at(s)?, self.phi_b_at(s)?);
        let lt = self.landmarks_at(t)?;
        let dist = |sp: &Spline, p: [f64; 2], q: [f64; 2]| {
            sp.eval(p, None).map_or(f64::INFINITY, |m| (m[0] - q[0]).hypot(m[1] - q[1]))
        };
        Ok(self
            .landmarks
            .iter()
            .zip(&lt)
            .map(|(l, &q)| [dist(&pa, l.src, q), dist(&pb, l.dst, q)])
            .collect())
    }
}
