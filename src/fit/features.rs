//! Automatic landmarks between two gray images: ORB features, descriptor matching and
//! RANSAC on an affine model.
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
//! 3. RANSAC on the affine model `dst = A src + b` (6 unknowns): minimal samples of 3
//!    matches (seeded, so the result is deterministic), exact fit, consensus = the matches
//!    whose residual `|A src + b - dst|` is at most [`RansacOptions::threshold`] pixels;
//!    ties are broken by the smaller sum of squared residuals. The number of samples adapts
//!    to the best inlier ratio `w` seen so far, `N = log(1 - p) / log(1 - w^3)` with
//!    confidence `p`, capped by [`RansacOptions::iterations`].
//! 4. Least-squares refit of the affine map on the consensus, recomputation of the inliers
//!    with the refitted map, repeated until the inlier set is stable (at most 10 times).
//! 5. Sub-pixel refinement ([`MatchOptions::refine`], on by default). ORB positions are
//!    integers of the pyramid level a keypoint was found at, so a keypoint of level `l` is
//!    off by up to about `1.2^l / 2` pixels. B is resampled on A's grid through the affine
//!    model, `B'(p) = B(A p + b)` (bilinear), so that what remains between A and `B'` is
//!    small; each inlier's `src` is kept, tracked from A to `B'` by pyramidal Lucas-Kanade
//!    ([`track_points`], 2 levels, forward-backward check) to `q`, and its new `dst` is
//!    `A q + b`. Pairs lost by the tracker, leaving B, or moving farther than the inlier
//!    threshold from the prediction are dropped, and step 4 is repeated on the refined
//!    pairs. When fewer than [`RansacOptions::min_inliers`] pairs survive, the unrefined
//!    result is returned ([`MatchStats::refined`] is then `false`).
//!
//! The least-squares affine fit centres both point sets at their means `ms`, `md`, and
//! solves `A S = C` with `S = sum (s - ms)(s - ms)^T` and `C = sum (d - md)(s - ms)^T`, then
//! `b = md - A ms`; with 3 non-collinear points the fit is exact.

use super::landmarks::Landmark;
use super::rng::SplitMix64;
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
    /// Fewer than 3 descriptor matches survived the ratio test and the cross check.
    #[error("only {found} descriptor matches (at least 3 are needed for an affine model)")]
    TooFewMatches {
        /// Matches found.
        found: usize,
    },
    /// RANSAC found no affine model supported by enough matches.
    #[error(
        "RANSAC found no consensus: best affine model has {best} inliers of {matches} \
         matches, {required} required"
    )]
    NoConsensus {
        /// Inliers of the best model (0 when every sample was degenerate).
        best: usize,
        /// Matches given to RANSAC.
        matches: usize,
        /// Required inliers.
        required: usize,
    },
    /// An option is out of range.
    #[error("invalid option: {0}")]
    Options(String),
    /// The sub-pixel refinement failed.
    #[error("refinement: {0}")]
    Track(#[from] super::track::TrackError),
    /// The feature detector failed.
    #[error("ORB detection failed: {0}")]
    Orb(#[from] kornia_image::ImageError),
}

/// A 2D affine map `p -> a p + b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine2 {
    /// The linear part, row-major: `a[r][c]`.
    pub a: [[f64; 2]; 2],
    /// The translation.
    pub b: [f64; 2],
}

impl Affine2 {
    /// The identity map.
    pub const IDENTITY: Affine2 = Affine2 { a: [[1.0, 0.0], [0.0, 1.0]], b: [0.0, 0.0] };

    /// `a p + b`.
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        [
            self.a[0][0] * p[0] + self.a[0][1] * p[1] + self.b[0],
            self.a[1][0] * p[0] + self.a[1][1] * p[1] + self.b[1],
        ]
    }

    /// The least-squares affine map sending `src[k]` near `dst[k]` (see the module
    /// documentation); `None` with fewer than 3 pairs, mismatched lengths or (nearly)
    /// collinear sources.
    pub fn fit(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Option<Affine2> {
        let n = src.len();
        if n < 3 || dst.len() != n {
            return None;
        }
        let mean = |p: &[[f64; 2]]| {
            let s = p.iter().fold([0.0, 0.0], |a, q| [a[0] + q[0], a[1] + q[1]]);
            [s[0] / n as f64, s[1] / n as f64]
        };
        let (ms, md) = (mean(src), mean(dst));
        let (mut s, mut c) = ([[0.0; 2]; 2], [[0.0; 2]; 2]);
        for (p, q) in src.iter().zip(dst) {
            let u = [p[0] - ms[0], p[1] - ms[1]];
            let v = [q[0] - md[0], q[1] - md[1]];
            for r in 0..2 {
                for k in 0..2 {
                    s[r][k] += u[r] * u[k];
                    c[r][k] += v[r] * u[k];
                }
            }
        }
        let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
        let tr = s[0][0] + s[1][1];
        if det.is_nan() || det <= 1e-12 * tr * tr {
            return None;
        }
        let inv = [[s[1][1] / det, -s[0][1] / det], [-s[1][0] / det, s[0][0] / det]];
        let mut a = [[0.0; 2]; 2];
        for r in 0..2 {
            for k in 0..2 {
                a[r][k] = c[r][0] * inv[0][k] + c[r][1] * inv[1][k];
            }
        }
        let b =
            [md[0] - a[0][0] * ms[0] - a[0][1] * ms[1], md[1] - a[1][0] * ms[0] - a[1][1] * ms[1]];
        Some(Affine2 { a, b })
    }
}

impl std::fmt::Display for Affine2 {
    /// `[a00 a01 b0; a10 a11 b1]` with 4 decimals.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (a, b) = (self.a, self.b);
        write!(
            f,
            "[{:.4} {:.4} {:.2}; {:.4} {:.4} {:.2}]",
            a[0][0], a[0][1], b[0], a[1][0], a[1][1], b[1]
        )
    }
}

/// RANSAC settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RansacOptions {
    /// Inlier threshold on the residual, in pixels (default 3).
    pub threshold: f64,
    /// Largest number of 3-point samples (default 2000).
    pub iterations: usize,
    /// Confidence of the adaptive stop, in (0, 1) (default 0.999); 1 disables it.
    pub confidence: f64,
    /// Fewest inliers for a consensus (default 6, at least 3).
    pub min_inliers: usize,
    /// Seed of the sampler.
    pub seed: u64,
}

impl Default for RansacOptions {
    fn default() -> Self {
        Self { threshold: 3.0, iterations: 2000, confidence: 0.999, min_inliers: 6, seed: 0 }
    }
}

/// The inliers of `model` (indices) and their sum of squared residuals.
fn consensus(model: &Affine2, src: &[[f64; 2]], dst: &[[f64; 2]], t2: f64) -> (Vec<usize>, f64) {
    let mut idx = Vec::new();
    let mut ssr = 0.0;
    for (k, (p, q)) in src.iter().zip(dst).enumerate() {
        let m = model.apply(*p);
        let r2 = (m[0] - q[0]).powi(2) + (m[1] - q[1]).powi(2);
        if r2 <= t2 {
            idx.push(k);
            ssr += r2;
        }
    }
    (idx, ssr)
}

/// Robust affine fit: RANSAC then least-squares refit (see the module documentation).
/// Returns the model and the sorted indices of its inliers.
pub fn ransac_affine(
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    opts: &RansacOptions,
) -> Result<(Affine2, Vec<usize>), FeatureError> {
    if !(opts.threshold > 0.0 && opts.threshold.is_finite()) {
        return Err(FeatureError::Options(format!(
            "threshold {} is not a finite number > 0",
            opts.threshold
        )));
    }
    if !(opts.confidence > 0.0 && opts.confidence <= 1.0) {
        return Err(FeatureError::Options(format!("confidence {} not in (0, 1]", opts.confidence)));
    }
    let n = src.len().min(dst.len());
    let required = opts.min_inliers.max(3);
    if n < 3 {
        return Err(FeatureError::TooFewMatches { found: n });
    }
    let t2 = opts.threshold * opts.threshold;
    let mut rng = SplitMix64::new(opts.seed);
    let mut best: Option<(Affine2, usize, f64)> = None;
    let mut needed = opts.iterations;
    let mut it = 0;
    while it < needed.min(opts.iterations) {
        it += 1;
        let i = rng.below(n);
        let mut j = rng.below(n - 1);
        j += (j >= i) as usize;
        let mut k = rng.below(n - 2);
        for m in [i.min(j), i.max(j)] {
            k += (k >= m) as usize;
        }
        let Some(model) = Affine2::fit(&[src[i], src[j], src[k]], &[dst[i], dst[j], dst[k]]) else {
            continue;
        };
        let (idx, ssr) = consensus(&model, &src[..n], &dst[..n], t2);
        let better = match &best {
            None => true,
            Some((_, c, s)) => idx.len() > *c || (idx.len() == *c && ssr < *s),
        };
        if better {
            best = Some((model, idx.len(), ssr));
            let w = idx.len() as f64 / n as f64;
            if opts.confidence < 1.0 {
                let miss = 1.0 - w.powi(3);
                needed = if miss <= 0.0 {
                    it
                } else {
                    ((1.0 - opts.confidence).ln() / miss.ln()).ceil().max(1.0) as usize
                };
            }
        }
    }
    let no = |best| FeatureError::NoConsensus { best, matches: n, required };
    let (model, count, _) = best.ok_or(no(0))?;
    if count < required {
        return Err(no(count));
    }
    refit_inliers(model, &src[..n], &dst[..n], opts).ok_or(no(count))
}

/// Step 4: least-squares refits and inlier updates from `model` until stable; `None` when
/// fewer than `opts.min_inliers` (at least 3) pairs agree with `model`.
fn refit_inliers(
    mut model: Affine2,
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    opts: &RansacOptions,
) -> Option<(Affine2, Vec<usize>)> {
    let (required, t2) = (opts.min_inliers.max(3), opts.threshold.powi(2));
    let (mut inliers, _) = consensus(&model, src, dst, t2);
    if inliers.len() < required {
        return None;
    }
    for _ in 0..10 {
        let s: Vec<[f64; 2]> = inliers.iter().map(|&k| src[k]).collect();
        let d: Vec<[f64; 2]> = inliers.iter().map(|&k| dst[k]).collect();
        let Some(refit) = Affine2::fit(&s, &d) else { break };
        let (again, _) = consensus(&refit, src, dst, t2);
        if again.len() < required {
            break;
        }
        model = refit;
        if again == inliers {
            break;
        }
        inliers = again;
    }
    Some((model, inliers))
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
    /// RANSAC settings (inlier threshold 3 px, 2000 samples, seed 0).
    pub ransac: RansacOptions,
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
            ransac: RansacOptions::default(),
            refine: true,
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
    /// RANSAC inliers (the returned landmarks).
    pub inliers: usize,
    /// The refitted affine model `dst = a src + b`.
    pub affine: Affine2,
    /// Root-mean-square residual of the inliers under `affine` (pixels).
    pub rms: f64,
    /// Whether `dst` was refined by Lucas-Kanade (step 5 of the module documentation).
    pub refined: bool,
}

/// The result of [`match_images`].
#[derive(Clone, Debug, PartialEq)]
pub struct MatchResult {
    /// Inlier landmarks `m0, m1, ...`: `src` in A, `dst` in B, weight 1.
    pub landmarks: Vec<Landmark>,
    /// Counts and the affine model.
    pub stats: MatchStats,
}

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

/// `B o affine` on A's pixel grid: `out(p) = b(affine(p))`, bilinear, 0 outside `b`.
fn pull_back(b: &GrayImage, affine: &Affine2, w: u32, h: u32) -> GrayImage {
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
        let q = affine.apply([x as f64, y as f64]);
        let (x0, y0) = (q[0].floor(), q[1].floor());
        let (fx, fy) = (q[0] - x0, q[1] - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        let v = (1.0 - fy) * ((1.0 - fx) * at(i, j) + fx * at(i + 1, j))
            + fy * ((1.0 - fx) * at(i, j + 1) + fx * at(i + 1, j + 1));
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    })
}

/// Step 5: Lucas-Kanade refinement of the inliers' `dst` (see the module documentation);
/// `None` when too few pairs survive.
#[allow(clippy::type_complexity)]
fn refine(
    a: &GrayImage,
    b: &GrayImage,
    pairs: &[([f64; 2], [f64; 2])],
    affine: &Affine2,
    ransac: &RansacOptions,
) -> Result<Option<(Affine2, Vec<([f64; 2], [f64; 2])>)>, FeatureError> {
    let warped = pull_back(b, affine, a.width(), a.height());
    let src: Vec<[f64; 2]> = pairs.iter().map(|p| p.0).collect();
    let opts = TrackOptions { max_level: 1, ..Default::default() };
    let tracked = track_points(a, &warped, &src, None, &opts)?;
    let t2 = ransac.threshold * ransac.threshold;
    let (mut s, mut d) = (Vec::new(), Vec::new());
    for (p, q) in src.iter().zip(&tracked) {
        let Some(q) = q else { continue };
        let (g, r) = (affine.apply(*p), affine.apply(*q));
        let inside = r[0] >= 0.0
            && r[1] >= 0.0
            && r[0] <= (b.width() - 1) as f64
            && r[1] <= (b.height() - 1) as f64;
        if inside && (r[0] - g[0]).powi(2) + (r[1] - g[1]).powi(2) <= t2 {
            s.push(*p);
            d.push(r);
        }
    }
    let Some(start) = Affine2::fit(&s, &d) else { return Ok(None) };
    Ok(refit_inliers(start, &s, &d, ransac)
        .map(|(model, idx)| (model, idx.iter().map(|&k| (s[k], d[k])).collect())))
}

/// Finds landmarks between gray images `a` and `b` (see the module documentation).
pub fn match_images(
    a: &GrayImage,
    b: &GrayImage,
    opts: &MatchOptions,
) -> Result<MatchResult, FeatureError> {
    if opts.features < 3 || opts.levels == 0 {
        return Err(FeatureError::Options(format!(
            "features {} must be >= 3 and levels {} >= 1",
            opts.features, opts.levels
        )));
    }
    if !(opts.ratio > 0.0 && opts.ratio <= 1.0) {
        return Err(FeatureError::Options(format!("ratio {} not in (0, 1]", opts.ratio)));
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
    if pairs.len() < 3 {
        return Err(FeatureError::TooFewMatches { found: pairs.len() });
    }
    let pt = |p: [f32; 2]| [p[0] as f64, p[1] as f64];
    let src: Vec<[f64; 2]> = pairs.iter().map(|&(i, _)| pt(fa.keypoints_xy[i])).collect();
    let dst: Vec<[f64; 2]> = pairs.iter().map(|&(_, j)| pt(fb.keypoints_xy[j])).collect();
    let (mut affine, inliers) = ransac_affine(&src, &dst, &opts.ransac)?;
    let mut pairs: Vec<([f64; 2], [f64; 2])> = inliers.iter().map(|&k| (src[k], dst[k])).collect();
    let mut refined = false;
    if opts.refine {
        if let Some((model, better)) = refine(a, b, &pairs, &affine, &opts.ransac)? {
            (affine, pairs, refined) = (model, better, true);
        }
    }
    let landmarks: Vec<Landmark> = pairs
        .iter()
        .enumerate()
        .map(|(n, &(s, d))| Landmark { name: Some(format!("m{n}")), src: s, dst: d, weight: 1.0 })
        .collect();
    let ss: f64 = landmarks
        .iter()
        .map(|l| {
            let m = affine.apply(l.src);
            (m[0] - l.dst[0]).powi(2) + (m[1] - l.dst[1]).powi(2)
        })
        .sum();
    let stats = MatchStats {
        keypoints: [fa.len(), fb.len()],
        matches: pairs.len(),
        inliers: landmarks.len(),
        affine,
        rms: (ss / landmarks.len() as f64).sqrt(),
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
mod tests {
    use super::*;

    fn cell() -> GrayImage {
        let p = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/cell.png");
        image::open(p).unwrap().to_luma8()
    }

    /// `out(q) = img(inv(q))` with bilinear interpolation (0 outside).
    fn resample(img: &GrayImage, inv: &Affine2) -> GrayImage {
        let (w, h) = img.dimensions();
        let at = |x: i64, y: i64| {
            if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                0.0
            } else {
                img.get_pixel(x as u32, y as u32)[0] as f64
            }
        };
        GrayImage::from_fn(w, h, |x, y| {
            let p = inv.apply([x as f64, y as f64]);
            let (x0, y0) = (p[0].floor(), p[1].floor());
            let (fx, fy) = (p[0] - x0, p[1] - y0);
            let (x0, y0) = (x0 as i64, y0 as i64);
            let v = (1.0 - fy) * ((1.0 - fx) * at(x0, y0) + fx * at(x0 + 1, y0))
                + fy * ((1.0 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
            image::Luma([v.round().clamp(0.0, 255.0) as u8])
        })
    }

    fn assert_landmarks_follow(r: &MatchResult, truth: &Affine2, tol: f64) {
        for l in &r.landmarks {
            let m = truth.apply(l.src);
            let e = ((m[0] - l.dst[0]).powi(2) + (m[1] - l.dst[1]).powi(2)).sqrt();
            assert!(
                e <= tol,
                "{:?}: {:?} -> {:?}, expected {m:?} (error {e:.2})",
                l.name,
                l.src,
                l.dst
            );
        }
        assert_eq!(r.stats.inliers, r.landmarks.len());
        assert_eq!(r.landmarks[0].name.as_deref(), Some("m0"));
    }

    #[test]
    fn affine_fit_is_exact_on_three_points_and_rejects_collinear() {
        let t = Affine2 { a: [[1.1, -0.2], [0.3, 0.9]], b: [5.0, -3.0] };
        let s = [[0.0, 0.0], [10.0, 1.0], [2.0, 7.0]];
        let d: Vec<[f64; 2]> = s.iter().map(|p| t.apply(*p)).collect();
        let f = Affine2::fit(&s, &d).unwrap();
        for r in 0..2 {
            assert!((f.b[r] - t.b[r]).abs() < 1e-12);
            for c in 0..2 {
                assert!((f.a[r][c] - t.a[r][c]).abs() < 1e-12);
            }
        }
        let line = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [5.0, 5.0]];
        assert!(Affine2::fit(&line, &line).is_none());
        assert!(Affine2::fit(&s[..2], &d[..2]).is_none());
    }

    #[test]
    fn ransac_recovers_affine_with_30_percent_outliers() {
        let truth = Affine2 { a: [[0.95, -0.17], [0.21, 1.04]], b: [12.5, -7.25] };
        let mut rng = SplitMix64::new(99);
        let mut uniform =
            |lo: f64, hi: f64| lo + (hi - lo) * (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let (mut src, mut dst, mut is_out) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..200 {
            let p = [uniform(0.0, 500.0), uniform(0.0, 600.0)];
            let outlier = k % 10 < 3;
            let q = if outlier {
                // Gross outliers: at least 40 px away from the truth.
                let m = truth.apply(p);
                let (r, th) = (uniform(40.0, 300.0), uniform(0.0, std::f64::consts::TAU));
                [m[0] + r * th.cos(), m[1] + r * th.sin()]
            } else {
                truth.apply(p)
            };
            src.push(p);
            dst.push(q);
            is_out.push(outlier);
        }
        let (model, inliers) = ransac_affine(&src, &dst, &RansacOptions::default()).unwrap();
        let expected: Vec<usize> = (0..200).filter(|&k| !is_out[k]).collect();
        assert_eq!(inliers, expected);
        for r in 0..2 {
            assert!((model.b[r] - truth.b[r]).abs() < 1e-6, "{model} vs {truth}");
            for c in 0..2 {
                assert!((model.a[r][c] - truth.a[r][c]).abs() < 1e-6, "{model} vs {truth}");
            }
        }
        // Deterministic for a seed.
        assert_eq!(ransac_affine(&src, &dst, &RansacOptions::default()).unwrap().1, inliers);
    }

    #[test]
    fn ransac_errors() {
        let s = [[0.0, 0.0], [1.0, 0.0]];
        assert!(matches!(
            ransac_affine(&s, &s, &RansacOptions::default()),
            Err(FeatureError::TooFewMatches { found: 2 })
        ));
        // Collinear points only: every sample is degenerate.
        let line: Vec<[f64; 2]> = (0..10).map(|k| [k as f64, 2.0 * k as f64]).collect();
        assert!(matches!(
            ransac_affine(&line, &line, &RansacOptions::default()),
            Err(FeatureError::NoConsensus { best: 0, .. })
        ));
        // Random pairs: no model has 6 inliers within 0.01 px.
        let mut rng = SplitMix64::new(5);
        let mut r = || (rng.next_u64() % 1000) as f64;
        let (a, b): (Vec<[f64; 2]>, Vec<[f64; 2]>) =
            (0..12).map(|_| ([r(), r()], [r(), r()])).unzip();
        let opts = RansacOptions { threshold: 0.01, ..Default::default() };
        assert!(matches!(ransac_affine(&a, &b, &opts), Err(FeatureError::NoConsensus { .. })));
        let bad = RansacOptions { threshold: -1.0, ..Default::default() };
        assert!(matches!(ransac_affine(&a, &b, &bad), Err(FeatureError::Options(_))));
    }

    #[test]
    fn cell_matches_its_integer_translation() {
        let a = cell();
        let shift = Affine2 { a: Affine2::IDENTITY.a, b: [9.0, -6.0] };
        let inv = Affine2 { a: Affine2::IDENTITY.a, b: [-9.0, 6.0] };
        let b = resample(&a, &inv);
        let r = match_images(&a, &b, &MatchOptions::default()).unwrap();
        assert_landmarks_follow(&r, &shift, 1.5);
        assert!((r.stats.affine.b[0] - 9.0).abs() < 0.5 && (r.stats.affine.b[1] + 6.0).abs() < 0.5);
        // Without refinement the ORB positions keep their pyramid-level rounding: the
        // landmarks still agree with the fitted model within the threshold, less tightly.
        let raw = MatchOptions { refine: false, ..Default::default() };
        let r0 = match_images(&a, &b, &raw).unwrap();
        assert!(r.stats.refined && !r0.stats.refined);
        assert!(r0.stats.rms <= 3.0 && r.stats.rms < r0.stats.rms, "{:?} {:?}", r.stats, r0.stats);
    }

    #[test]
    fn cell_matches_its_rotation_and_scale() {
        let a = cell();
        let (s, th) = (1.04f64, 4.0f64.to_radians());
        let c = [275.0, 330.0];
        let lin = [[s * th.cos(), -s * th.sin()], [s * th.sin(), s * th.cos()]];
        // q = c + lin (p - c)
        let fwd = Affine2 {
            a: lin,
            b: [
                c[0] - lin[0][0] * c[0] - lin[0][1] * c[1],
                c[1] - lin[1][0] * c[0] - lin[1][1] * c[1],
            ],
        };
        let (ci, si) = (th.cos() / s, th.sin() / s);
        let ilin = [[ci, si], [-si, ci]];
        let inv = Affine2 {
            a: ilin,
            b: [
                c[0] - ilin[0][0] * c[0] - ilin[0][1] * c[1],
                c[1] - ilin[1][0] * c[0] - ilin[1][1] * c[1],
            ],
        };
        let b = resample(&a, &inv);
        let r = match_images(&a, &b, &MatchOptions::default()).unwrap();
        assert_landmarks_follow(&r, &fwd, 1.5);
    }

    #[test]
    fn match_errors() {
        let small = GrayImage::new(40, 100);
        let big = cell();
        let o = MatchOptions::default();
        assert!(matches!(
            match_images(&small, &big, &o),
            Err(FeatureError::TooSmall { which: 'A', .. })
        ));
        let flat = GrayImage::from_pixel(200, 200, image::Luma([90]));
        assert!(matches!(
            match_images(&big, &flat, &o),
            Err(FeatureError::NoFeatures { which: 'B' })
        ));
        let bad = MatchOptions { ratio: 1.5, ..Default::default() };
        assert!(matches!(match_images(&big, &big, &bad), Err(FeatureError::Options(_))));
    }

    #[test]
    fn gray8_scales_deep_images_by_their_max() {
        let g16 = image::ImageBuffer::from_fn(4, 1, |x, _| image::Luma([x as u16 * 1000]));
        let g = gray8(&image::DynamicImage::ImageLuma16(g16));
        assert_eq!(g.as_raw(), &[0, 85, 170, 255]);
        let f = image::ImageBuffer::from_fn(3, 1, |x, _| image::Rgb([x as f32 * 0.25; 3]));
        let g = gray8(&image::DynamicImage::ImageRgb32F(f));
        assert_eq!(g.as_raw(), &[0, 128, 255]);
        let c = image::RgbImage::from_pixel(2, 2, image::Rgb([200, 200, 200]));
        assert_eq!(gray8(&image::DynamicImage::ImageRgb8(c)).as_raw(), &[200; 4]);
        let z = image::ImageBuffer::from_pixel(2, 1, image::Luma([0u16]));
        assert_eq!(gray8(&image::DynamicImage::ImageLuma16(z)).as_raw(), &[0, 0]);
    }
}
