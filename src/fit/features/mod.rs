//! Automatic landmarks between two gray images: ORB features, descriptor matching, and a
//! robust model that separates true matches from false ones: one affine map, one
//! homography, or local consistency ([`ModelKind`]).
//!
//! # Coordinates
//!
//! Pixel coordinates: pixel `(i, j)` (column `i`, row `j`) is centred at `(x, y) = (i, j)`,
//! `x` to the right, `y` downwards. A returned [`Landmark`] has `src` in image A and `dst`
//! in image B.
//!
//! # Method
//!
//! 1. ORB keypoints and 256-bit rotated-BRIEF descriptors in each image (kornia's
//!    [`OrbDetector`]: multi-scale FAST with Harris scores, at most
//!    [`MatchOptions::features`] keypoints).
//! 2. Brute-force Hamming matching. A pair `(i, j)` is kept when `j` is the nearest
//!    descriptor of B to descriptor `i` of A, `i` is the nearest of A to `j` (mutual or cross
//!    check), and Lowe's ratio test holds: `d(i, j) < ratio * d(i, j')` with `j'` the second
//!    nearest of B.
//! 3. The model ([`MatchOptions::model`]):
//!    * `Affine` (default): RANSAC on `dst = A src + b` (6 unknowns, samples of 3), then
//!      least-squares refits until the inliers are stable ([`models`]).
//!    * `Homography`: the same on a plane projective map (8 unknowns, samples of 4,
//!      normalized DLT), for views of a flat scene from another camera position.
//!    * `Local`: no global map; every match must be followed by a plausible local affine
//!      map of its neighbourhood ([`local`]), so objects that move independently (cells in a
//!      time-lapse) all keep their matches.
//!
//!    Inliers are the matches whose residual under their map is at most
//!    [`RansacOptions::threshold`] pixels.
//! 4. Sub-pixel refinement ([`MatchOptions::refine`], on by default). ORB positions are
//!    integers of the pyramid level a keypoint was found at, so a keypoint of level `l` is
//!    off by up to about `1.2^l / 2` pixels.
//!    * Global models: B is resampled on A's grid through the model `M`, `B'(p) = B(M(p))`
//!      (bilinear), so that what remains between A and `B'` is small; each inlier's `src` is
//!      kept, tracked from A to `B'` by pyramidal Lucas-Kanade ([`track_points`], 2 levels,
//!      forward-backward check) to `q`, and its new `dst` is `M(q)`.
//!    * Local model: each inlier is tracked from A to B directly, starting at its `dst`
//!      (both images padded with 0 to a common size first; the padding changes no
//!      coordinate, the origin being the top-left pixel of both).
//!
//!    Pairs lost by the tracker, leaving B, or moving farther than the inlier threshold from
//!    the prediction are dropped, and step 3's refit (or filter) is repeated on the refined
//!    pairs. When too few pairs survive, the unrefined result is returned
//!    ([`MatchStats::refined`] is then `false`).

pub mod local;
pub mod models;

pub use local::{local_filter, LocalFit, LocalOptions};
pub use models::{
    ransac, ransac_affine, ransac_homography, Affine2, Homography, PointModel, RansacOptions,
};

use super::landmarks::Landmark;
use super::track::{track_points, TrackOptions};
use image::GrayImage;
use kornia_image::{Image, ImageSize};
use kornia_imgproc::features::{match_descriptors, OrbDetector, OrbFeatures};

/// Smallest accepted image side (pixels); ORB needs a 20-pixel border around its keypoints.
pub const MIN_SIDE: u32 = 64;

/// Errors of automatic matching.
#[derive(Debug, thiserror::Error)]
pub enum FeatureError {
    /// An image is smaller than [`MIN_SIDE`] on a side.
    #[error("image {which} is {width}x{height}; both sides must be at least {min} pixels")]
    TooSmall {
        /// `A` or `B`.
        which: char,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// The minimum side.
        min: u32,
    },
    /// No ORB keypoint was found in an image (flat or textureless).
    #[error("no features found in image {which}")]
    NoFeatures {
        /// `A` or `B`.
        which: char,
    },
    /// Fewer descriptor matches survived the ratio test and the cross check than the model
    /// needs.
    #[error(
        "only {found} descriptor matches (at least {needed} are needed for the {model} model)"
    )]
    TooFewMatches {
        /// Matches found.
        found: usize,
        /// The model (`affine`, `homography`, `local`).
        model: &'static str,
        /// Matches the model needs.
        needed: usize,
    },
    /// No model is supported by enough matches.
    #[error(
        "no consensus: the best {model} model has {best} inliers of {matches} matches, \
         {required} required"
    )]
    NoConsensus {
        /// Inliers of the best model (0 when every sample was degenerate).
        best: usize,
        /// Matches given to the model.
        matches: usize,
        /// Required inliers.
        required: usize,
        /// The model (`affine`, `homography`, `local`).
        model: &'static str,
    },
    /// [`MatchOptions::features`] below 3 or [`MatchOptions::levels`] 0.
    #[error("invalid option: features {features} must be >= 3 and levels {levels} >= 1")]
    FeatureCount {
        /// The features asked for.
        features: usize,
        /// The pyramid levels asked for.
        levels: usize,
    },
    /// [`MatchOptions::ratio`] outside `(0, 1]`.
    #[error("invalid option: ratio {ratio} not in (0, 1]")]
    Ratio {
        /// The ratio given.
        ratio: f32,
    },
    /// A RANSAC threshold ([`RansacOptions::threshold`]) that is not a finite number `> 0`.
    #[error("invalid option: threshold {threshold} is not a finite number > 0")]
    Threshold {
        /// The threshold given (pixels).
        threshold: f64,
    },
    /// A RANSAC confidence ([`RansacOptions::confidence`]) outside `(0, 1]`.
    #[error("invalid option: confidence {confidence} not in (0, 1]")]
    Confidence {
        /// The confidence given.
        confidence: f64,
    },
    /// The local model's neighbours below 3 or its minimum support below 4
    /// ([`LocalOptions`]).
    #[error(
        "invalid option: local model: neighbours {neighbours} must be >= 3 and min_support \
         {min_support} >= 4"
    )]
    LocalSupport {
        /// [`LocalOptions::neighbours`] given.
        neighbours: usize,
        /// [`LocalOptions::min_support`] given.
        min_support: usize,
    },
    /// The local model's largest stretch ([`LocalOptions::max_stretch`]) is not a finite
    /// number `>= 1`.
    #[error("invalid option: local model: max_stretch {max_stretch} must be a finite number >= 1")]
    LocalStretch {
        /// The stretch given.
        max_stretch: f64,
    },
    /// The sub-pixel refinement failed.
    #[error("refinement: {0}")]
    Track(#[from] super::track::TrackError),
    /// The feature detector failed.
    #[error("ORB detection failed: {0}")]
    Orb(#[from] kornia_image::ImageError),
}

impl FeatureError {
    /// Whether an option is out of range (the variants whose text starts `invalid
    /// option`), rather than the images or the matches being at fault.
    pub fn is_option(&self) -> bool {
        matches!(
            self,
            FeatureError::FeatureCount { .. }
                | FeatureError::Ratio { .. }
                | FeatureError::Threshold { .. }
                | FeatureError::Confidence { .. }
                | FeatureError::LocalSupport { .. }
                | FeatureError::LocalStretch { .. }
        )
    }
}

/// Which model separates true matches from false ones (module documentation, step 3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ModelKind {
    /// One affine map of the whole image.
    #[default]
    Affine,
    /// One plane projective map of the whole image.
    Homography,
    /// Local consistency: each match agrees with its neighbours.
    Local,
}

impl ModelKind {
    /// `affine`, `homography` or `local`.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Affine => "affine",
            ModelKind::Homography => "homography",
            ModelKind::Local => "local",
        }
    }
}

/// Settings of [`match_images`].
#[derive(Clone, Debug, PartialEq)]
pub struct MatchOptions {
    /// Most ORB keypoints per image (default 1000).
    pub features: usize,
    /// Pyramid levels of the detector, scale step 1.2 (default 8).
    pub levels: usize,
    /// Lowe's ratio: best distance < `ratio` x second best (default 0.8).
    pub ratio: f32,
    /// Largest accepted Hamming distance (of 256 bits), if any (default none).
    pub max_distance: Option<u32>,
    /// The model (default affine).
    pub model: ModelKind,
    /// RANSAC settings (inlier threshold 3 px, 2000 samples, seed 0); the local model uses
    /// the threshold and `min_inliers` (fewest kept matches in all).
    pub ransac: RansacOptions,
    /// Settings of the local model.
    pub local: LocalOptions,
    /// Refine the inliers' `dst` to sub-pixel accuracy with Lucas-Kanade (default true).
    pub refine: bool,
}

impl Default for MatchOptions {
    fn default() -> Self {
        Self {
            features: 1000,
            levels: 8,
            ratio: 0.8,
            max_distance: None,
            model: ModelKind::Affine,
            ransac: RansacOptions::default(),
            local: LocalOptions::default(),
            refine: true,
        }
    }
}

/// The fitted model of a match.
#[derive(Clone, Debug, PartialEq)]
pub enum FittedModel {
    /// The refitted affine map `dst = a src + b`.
    Affine(Affine2),
    /// The refitted homography.
    Homography(Homography),
    /// The local model: sizes of the groups of kept matches linked by support, largest
    /// first.
    Local {
        /// Group sizes, largest first.
        groups: Vec<usize>,
    },
}

impl std::fmt::Display for FittedModel {
    /// `affine [..]`, `homography [..]`, or `local model, G groups (sizes ...)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FittedModel::Affine(a) => write!(f, "affine {a}"),
            FittedModel::Homography(h) => write!(f, "homography {h}"),
            FittedModel::Local { groups } => {
                let shown: Vec<String> = groups.iter().take(12).map(|g| g.to_string()).collect();
                let more = if groups.len() > 12 { ", ..." } else { "" };
                write!(
                    f,
                    "local model, {} group{} of {}{more} matches",
                    groups.len(),
                    if groups.len() == 1 { "" } else { "s" },
                    shown.join(", ")
                )
            }
        }
    }
}

/// Counts and the model of a match.
#[derive(Clone, Debug, PartialEq)]
pub struct MatchStats {
    /// ORB keypoints (with descriptors) in A and in B.
    pub keypoints: [usize; 2],
    /// Descriptor matches after the ratio test and the cross check.
    pub matches: usize,
    /// Inliers (the returned landmarks).
    pub inliers: usize,
    /// The fitted model.
    pub model: FittedModel,
    /// Root-mean-square residual of the inliers under their model (pixels; the local
    /// model: each under its own local map).
    pub rms: f64,
    /// Whether `dst` was refined by Lucas-Kanade (step 4 of the module documentation).
    pub refined: bool,
}

/// The result of [`match_images`].
#[derive(Clone, Debug, PartialEq)]
pub struct MatchResult {
    /// Inlier landmarks `m0, m1, ...`: `src` in A, `dst` in B, weight 1.
    pub landmarks: Vec<Landmark>,
    /// Counts and the model.
    pub stats: MatchStats,
}

type Pairs = Vec<([f64; 2], [f64; 2])>;

fn orb(img: &GrayImage, which: char, opts: &MatchOptions) -> Result<OrbFeatures, FeatureError> {
    let (width, height) = img.dimensions();
    if width < MIN_SIDE || height < MIN_SIDE {
        return Err(FeatureError::TooSmall { which, width, height, min: MIN_SIDE });
    }
    let size = ImageSize { width: width as usize, height: height as usize };
    let k = Image::<u8, 1>::from_size_slice(size, img.as_raw())?;
    let det =
        OrbDetector { n_keypoints: opts.features, n_scales: opts.levels, ..Default::default() };
    let f = det.detect_and_extract_u8(&k)?;
    if f.is_empty() {
        return Err(FeatureError::NoFeatures { which });
    }
    Ok(f)
}

/// `B o M` on A's pixel grid: `out(p) = b(M(p))`, bilinear, 0 outside `b`.
fn pull_back<M: PointModel>(b: &GrayImage, model: &M, w: u32, h: u32) -> GrayImage {
    let (bw, bh) = (b.width() as i64, b.height() as i64);
    let raw = b.as_raw();
    let at = |x: i64, y: i64| {
        if x < 0 || y < 0 || x >= bw || y >= bh {
            0.0
        } else {
            raw[(y * bw + x) as usize] as f64
        }
    };
    GrayImage::from_fn(w, h, |x, y| {
        let q = model.apply([x as f64, y as f64]);
        if !(q[0].is_finite() && q[1].is_finite()) {
            return image::Luma([0]);
        }
        let (x0, y0) = (q[0].floor(), q[1].floor());
        let (fx, fy) = (q[0] - x0, q[1] - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        let v = (1.0 - fy) * ((1.0 - fx) * at(i, j) + fx * at(i + 1, j))
            + fy * ((1.0 - fx) * at(i, j + 1) + fx * at(i + 1, j + 1));
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    })
}

fn inside(b: &GrayImage, r: [f64; 2]) -> bool {
    r[0] >= 0.0 && r[1] >= 0.0 && r[0] <= (b.width() - 1) as f64 && r[1] <= (b.height() - 1) as f64
}

/// Step 4 for a global model (see the module documentation); `None` when too few pairs
/// survive.
fn refine_global<M: PointModel>(
    a: &GrayImage,
    b: &GrayImage,
    pairs: &[([f64; 2], [f64; 2])],
    model: &M,
    ransac: &RansacOptions,
) -> Result<Option<(M, Pairs)>, FeatureError> {
    let warped = pull_back(b, model, a.width(), a.height());
    let src: Vec<[f64; 2]> = pairs.iter().map(|p| p.0).collect();
    let opts = TrackOptions { max_level: 1, ..Default::default() };
    let tracked = track_points(a, &warped, &src, None, &opts)?;
    let t2 = ransac.threshold * ransac.threshold;
    let (mut s, mut d) = (Vec::new(), Vec::new());
    for (p, q) in src.iter().zip(&tracked) {
        let Some(q) = q else { continue };
        let (g, r) = (model.apply(*p), model.apply(*q));
        if inside(b, r) && (r[0] - g[0]).powi(2) + (r[1] - g[1]).powi(2) <= t2 {
            s.push(*p);
            d.push(r);
        }
    }
    let Some(start) = M::fit(&s, &d) else { return Ok(None) };
    Ok(models::refit_inliers(start, &s, &d, ransac)
        .map(|(model, idx)| (model, idx.iter().map(|&k| (s[k], d[k])).collect())))
}

/// `img` padded with 0 on the right and bottom to `w x h` (coordinates unchanged).
fn padded(img: &GrayImage, w: u32, h: u32) -> GrayImage {
    if img.dimensions() == (w, h) {
        return img.clone();
    }
    let mut out = GrayImage::new(w, h);
    image::imageops::replace(&mut out, img, 0, 0);
    out
}

/// Step 4 for the local model: the tracked pairs, before the filter is run again.
fn refine_local(
    a: &GrayImage,
    b: &GrayImage,
    pairs: &[([f64; 2], [f64; 2])],
    threshold: f64,
) -> Result<Pairs, FeatureError> {
    let (w, h) = (a.width().max(b.width()), a.height().max(b.height()));
    let (pa, pb) = (padded(a, w, h), padded(b, w, h));
    let src: Vec<[f64; 2]> = pairs.iter().map(|p| p.0).collect();
    let init: Vec<[f64; 2]> = pairs.iter().map(|p| p.1).collect();
    let opts = TrackOptions { max_level: 1, ..Default::default() };
    let tracked = track_points(&pa, &pb, &src, Some(&init), &opts)?;
    let t2 = threshold * threshold;
    Ok(pairs
        .iter()
        .zip(&tracked)
        .filter_map(|(&(p, d), q)| {
            let q = (*q)?;
            (inside(b, q) && (q[0] - d[0]).powi(2) + (q[1] - d[1]).powi(2) <= t2).then_some((p, q))
        })
        .collect())
}

fn rms_of<M: PointModel>(model: &M, pairs: &[([f64; 2], [f64; 2])]) -> f64 {
    let ss: f64 = pairs
        .iter()
        .map(|&(s, d)| {
            let m = model.apply(s);
            (m[0] - d[0]).powi(2) + (m[1] - d[1]).powi(2)
        })
        .sum();
    (ss / pairs.len().max(1) as f64).sqrt()
}

/// Steps 3-4 for a global model `M`: the inlier pairs, the model, their rms, refined or not.
fn global<M: PointModel>(
    a: &GrayImage,
    b: &GrayImage,
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    opts: &MatchOptions,
) -> Result<(Pairs, M, bool), FeatureError> {
    let (mut model, inliers) = ransac::<M>(src, dst, &opts.ransac)?;
    let mut pairs: Pairs = inliers.iter().map(|&k| (src[k], dst[k])).collect();
    let mut refined = false;
    if opts.refine {
        if let Some((m, better)) = refine_global(a, b, &pairs, &model, &opts.ransac)? {
            (model, pairs, refined) = (m, better, true);
        }
    }
    Ok((pairs, model, refined))
}

/// Steps 3-4 for the local model: the kept pairs, the fit, refined or not.
fn local_model(
    a: &GrayImage,
    b: &GrayImage,
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    opts: &MatchOptions,
) -> Result<(Pairs, LocalFit, bool), FeatureError> {
    models::check_options(&opts.ransac)?;
    let LocalOptions { neighbours, min_support, max_stretch, .. } = opts.local;
    if neighbours < 3 || min_support < 4 {
        return Err(FeatureError::LocalSupport { neighbours, min_support });
    }
    if !(max_stretch >= 1.0 && max_stretch.is_finite()) {
        return Err(FeatureError::LocalStretch { max_stretch });
    }
    let required = opts.ransac.min_inliers.max(opts.local.min_support);
    let t = opts.ransac.threshold;
    let fit = local_filter(src, dst, t, &opts.local);
    if fit.inliers.len() < required {
        return Err(FeatureError::NoConsensus {
            best: fit.inliers.len(),
            matches: src.len(),
            required,
            model: "local",
        });
    }
    let pairs: Pairs = fit.inliers.iter().map(|&k| (src[k], dst[k])).collect();
    if opts.refine {
        let tracked = refine_local(a, b, &pairs, t)?;
        let (s, d): (Vec<[f64; 2]>, Vec<[f64; 2]>) = tracked.iter().copied().unzip();
        let again = local_filter(&s, &d, t, &opts.local);
        if again.inliers.len() >= required {
            let better = again.inliers.iter().map(|&k| tracked[k]).collect();
            return Ok((better, again, true));
        }
    }
    Ok((pairs, fit, false))
}

/// Finds landmarks between gray images `a` and `b` (see the module documentation).
pub fn match_images(
    a: &GrayImage,
    b: &GrayImage,
    opts: &MatchOptions,
) -> Result<MatchResult, FeatureError> {
    if opts.features < 3 || opts.levels == 0 {
        return Err(FeatureError::FeatureCount { features: opts.features, levels: opts.levels });
    }
    if !(opts.ratio > 0.0 && opts.ratio <= 1.0) {
        return Err(FeatureError::Ratio { ratio: opts.ratio });
    }
    let fa = orb(a, 'A', opts)?;
    let fb = orb(b, 'B', opts)?;
    let mut pairs = match_descriptors(
        &fa.descriptors,
        &fb.descriptors,
        opts.max_distance,
        true,
        Some(opts.ratio),
    );
    pairs.sort_unstable();
    let needed = match opts.model {
        ModelKind::Affine => 3,
        ModelKind::Homography => 4,
        ModelKind::Local => 4,
    };
    if pairs.len() < needed {
        return Err(FeatureError::TooFewMatches {
            found: pairs.len(),
            model: opts.model.name(),
            needed,
        });
    }
    let pt = |p: [f32; 2]| [p[0] as f64, p[1] as f64];
    let src: Vec<[f64; 2]> = pairs.iter().map(|&(i, _)| pt(fa.keypoints_xy[i])).collect();
    let dst: Vec<[f64; 2]> = pairs.iter().map(|&(_, j)| pt(fb.keypoints_xy[j])).collect();
    let (kept, model, rms, refined) = match opts.model {
        ModelKind::Affine => {
            let (p, m, r) = global::<Affine2>(a, b, &src, &dst, opts)?;
            let rms = rms_of(&m, &p);
            (p, FittedModel::Affine(m), rms, r)
        }
        ModelKind::Homography => {
            let (p, m, r) = global::<Homography>(a, b, &src, &dst, opts)?;
            let rms = rms_of(&m, &p);
            (p, FittedModel::Homography(m), rms, r)
        }
        ModelKind::Local => {
            let (p, fit, r) = local_model(a, b, &src, &dst, opts)?;
            let ss: f64 = fit.residuals.iter().map(|r| r * r).sum();
            let rms = (ss / fit.residuals.len().max(1) as f64).sqrt();
            (p, FittedModel::Local { groups: fit.groups }, rms, r)
        }
    };
    let landmarks: Vec<Landmark> = kept
        .iter()
        .enumerate()
        .map(|(n, &(s, d))| Landmark { name: Some(format!("m{n}")), src: s, dst: d, weight: 1.0 })
        .collect();
    let stats = MatchStats {
        keypoints: [fa.len(), fb.len()],
        matches: pairs.len(),
        inliers: landmarks.len(),
        model,
        rms,
        refined,
    };
    Ok(MatchResult { landmarks, stats })
}

/// Any image as 8-bit gray: 8-bit images through the usual luma weights; deeper images
/// (16-bit, float) through 16-bit or float luma, then scaled so that their largest value
/// becomes 255 (an all-zero image stays 0; negative values become 0).
pub fn gray8(img: &image::DynamicImage) -> GrayImage {
    use image::DynamicImage as D;
    match img {
        D::ImageLuma8(g) => g.clone(),
        D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => img.to_luma8(),
        D::ImageLuma16(_) | D::ImageLumaA16(_) | D::ImageRgb16(_) | D::ImageRgba16(_) => {
            let l = img.to_luma16();
            let max = l.as_raw().iter().copied().max().unwrap_or(0).max(1) as f64;
            GrayImage::from_fn(l.width(), l.height(), |x, y| {
                image::Luma([(l.get_pixel(x, y)[0] as f64 * 255.0 / max).round() as u8])
            })
        }
        _ => {
            let l = img.to_luma32f();
            let max = l.as_raw().iter().copied().filter(|v| v.is_finite()).fold(0.0f32, f32::max);
            let k = if max > 0.0 { 255.0 / max } else { 0.0 };
            GrayImage::from_fn(l.width(), l.height(), |x, y| {
                let v = l.get_pixel(x, y)[0];
                image::Luma([if v.is_finite() {
                    (v * k).round().clamp(0.0, 255.0) as u8
                } else {
                    0
                }])
            })
        }
    }
}
#[cfg(test)]
mod tests;
