//! Point-to-point models for [`super::match_images`] and their robust fits.
//!
//! A [`PointModel`] maps a point of image A to image B. Two global models:
//!
//! * [`Affine2`], `q = A p + b` (6 unknowns, minimal sample 3): least squares from the
//!   centred normal equations (see [`Affine2::fit`]).
//! * [`Homography`], `q = (H [p; 1])_xy / (H [p; 1])_z` (8 unknowns up to scale, minimal
//!   sample 4): the normalized direct linear transform (Hartley and Zisserman, *Multiple View
//!   Geometry*, 2nd ed., algorithm 4.2). Both point sets are moved to their centroid and
//!   scaled to a mean distance of `sqrt 2`; each pair gives two rows of `M h = 0`,
//!   `[-x -y -1 0 0 0 ux uy u]` and `[0 0 0 -x -y -1 vx vy v]`; `h` is the eigenvector of
//!   `M^T M` of the smallest eigenvalue (faer's self-adjoint eigensolver), and the
//!   normalizations are undone, `H = T_B^-1 H_n T_A`, scaled so that `H[2][2] = 1` when it
//!   is not tiny. A point whose projective weight `(H [p; 1])_z` is not positive is sent to
//!   NaN (it lies on or behind the horizon line of `H`), so it is never an inlier. A fit is
//!   refused when the system has a second (near-)zero eigenvalue (relative `1e-12`), when
//!   three of a minimal sample are (nearly) collinear, or when `H` reverses the orientation
//!   at a sample point (`det dq/dp <= 0`): a real view of a plane never mirrors it.
//!
//! [`ransac`] is generic over the model: minimal samples drawn by the seeded
//! [`SplitMix64`] (so results are deterministic), consensus = the pairs with residual
//! `|M(p) - q| <= threshold`, ties broken by the smaller sum of squared residuals, the number
//! of samples adapting to the best inlier ratio `w`, `N = log(1 - conf) / log(1 - w^s)`
//! (`s` the sample size), then least-squares refits on the consensus until the inlier set is
//! stable (at most 10 times).

use super::FeatureError;
use crate::rng::SplitMix64;

/// A map from image A's pixel coordinates to image B's, fitted to point pairs.
pub trait PointModel: Copy + std::fmt::Display {
    /// Pairs in a minimal sample.
    const SAMPLE: usize;
    /// Name of the model (`affine`, `homography`).
    const NAME: &'static str;
    /// The least-squares model of the pairs `src[k] -> dst[k]`; `None` with fewer than
    /// [`Self::SAMPLE`] pairs, mismatched lengths or a degenerate configuration.
    fn fit(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Option<Self>;
    /// The image of `p` (NaN where the model is undefined).
    fn apply(&self, p: [f64; 2]) -> [f64; 2];
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

impl PointModel for Affine2 {
    const SAMPLE: usize = 3;
    const NAME: &'static str = "affine";
    fn fit(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Option<Self> {
        Affine2::fit(src, dst)
    }
    fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        Affine2::apply(self, p)
    }
}

/// A plane projective map `q = (H [p; 1])_xy / (H [p; 1])_z` (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homography {
    /// The 3 x 3 matrix, row-major, scaled so that `h[2][2] = 1` unless that entry is tiny.
    pub h: [[f64; 3]; 3],
}

/// Relative size below which a second eigenvalue of `M^T M` makes a homography fit
/// degenerate, and below which a sample triangle's area counts as collinear.
const HOMOGRAPHY_DEGENERATE: f64 = 1e-12;

impl Homography {
    /// The identity map.
    pub const IDENTITY: Homography =
        Homography { h: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] };

    /// The image of `p`; NaN where the projective weight `(H [p; 1])_z` is not positive.
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let h = &self.h;
        let w = h[2][0] * p[0] + h[2][1] * p[1] + h[2][2];
        if w.is_nan() || w <= 0.0 {
            return [f64::NAN, f64::NAN];
        }
        [
            (h[0][0] * p[0] + h[0][1] * p[1] + h[0][2]) / w,
            (h[1][0] * p[0] + h[1][1] * p[1] + h[1][2]) / w,
        ]
    }

    /// `det dq/dp` at `p` (its sign is the orientation of the map there).
    pub fn jacobian_det(&self, p: [f64; 2]) -> f64 {
        // For q = (a.p~ / w, b.p~ / w): det J = det(H) / w^3.
        let h = &self.h;
        let w = h[2][0] * p[0] + h[2][1] * p[1] + h[2][2];
        det3(h) / (w * w * w)
    }

    /// The normalized DLT fit (see the module documentation).
    pub fn fit(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Option<Homography> {
        let n = src.len();
        if n < 4 || dst.len() != n {
            return None;
        }
        if n == 4 && (has_collinear_triple(src) || has_collinear_triple(dst)) {
            return None;
        }
        let (ta, tb) = (normalization(src)?, normalization(dst)?);
        let mut m = [[0.0f64; 9]; 9];
        for (p, q) in src.iter().zip(dst) {
            let (x, y) = (ta[0] * (p[0] - ta[1]), ta[0] * (p[1] - ta[2]));
            let (u, v) = (tb[0] * (q[0] - tb[1]), tb[0] * (q[1] - tb[2]));
            let rows = [
                [-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u],
                [0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v],
            ];
            for r in &rows {
                for i in 0..9 {
                    for k in 0..9 {
                        m[i][k] += r[i] * r[k];
                    }
                }
            }
        }
        let mm = faer::Mat::<f64>::from_fn(9, 9, |i, k| m[i][k]);
        let eig = mm.self_adjoint_eigen(faer::Side::Lower).ok()?;
        let s = eig.S().column_vector();
        let mut order: [usize; 9] = std::array::from_fn(|k| k);
        order.sort_by(|&a, &b| s[a].total_cmp(&s[b]));
        let (s0, s1, s8) = (s[order[0]], s[order[1]], s[order[8]]);
        if s8.is_nan() || s8 <= 0.0 || s1 <= HOMOGRAPHY_DEGENERATE * s8 || !s0.is_finite() {
            return None;
        }
        let u = eig.U();
        let hn: [[f64; 3]; 3] =
            std::array::from_fn(|r| std::array::from_fn(|c| u[(3 * r + c, order[0])]));
        // H = T_B^-1 Hn T_A with T = [[k, 0, -k cx], [0, k, -k cy], [0, 0, 1]].
        let t_a = [[ta[0], 0.0, -ta[0] * ta[1]], [0.0, ta[0], -ta[0] * ta[2]], [0.0, 0.0, 1.0]];
        let t_b_inv = [[1.0 / tb[0], 0.0, tb[1]], [0.0, 1.0 / tb[0], tb[2]], [0.0, 0.0, 1.0]];
        let mut h = mul3(&t_b_inv, &mul3(&hn, &t_a));
        let norm = h.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return None;
        }
        let scale = if h[2][2].abs() > 1e-9 * norm { h[2][2] } else { norm };
        for v in h.iter_mut().flatten() {
            *v /= scale;
        }
        // Positive projective weight at the first source point (H and -H are the same map).
        let w0 = h[2][0] * src[0][0] + h[2][1] * src[0][1] + h[2][2];
        if w0 < 0.0 {
            for v in h.iter_mut().flatten() {
                *v = -*v;
            }
        }
        let model = Homography { h };
        let faithful =
            src.iter().all(|&p| model.jacobian_det(p) > 0.0 && model.apply(p)[0].is_finite());
        faithful.then_some(model)
    }
}

fn det3(h: &[[f64; 3]; 3]) -> f64 {
    h[0][0] * (h[1][1] * h[2][2] - h[1][2] * h[2][1])
        - h[0][1] * (h[1][0] * h[2][2] - h[1][2] * h[2][0])
        + h[0][2] * (h[1][0] * h[2][1] - h[1][1] * h[2][0])
}

fn mul3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| a[r][k] * b[k][c]).sum()))
}

/// Hartley's normalization `[k, cx, cy]`: `p -> k (p - c)`, centroid `c`, mean distance
/// `sqrt 2` after scaling; `None` when all points coincide.
fn normalization(p: &[[f64; 2]]) -> Option<[f64; 3]> {
    let n = p.len() as f64;
    let c = p.iter().fold([0.0, 0.0], |a, q| [a[0] + q[0] / n, a[1] + q[1] / n]);
    let mean = p.iter().map(|q| (q[0] - c[0]).hypot(q[1] - c[1])).sum::<f64>() / n;
    (mean > 0.0 && mean.is_finite()).then(|| [std::f64::consts::SQRT_2 / mean, c[0], c[1]])
}

/// Whether three of the four points are (nearly) on one line: a triangle's doubled area at
/// most [`HOMOGRAPHY_DEGENERATE`] times the square of the points' spread.
fn has_collinear_triple(p: &[[f64; 2]]) -> bool {
    let spread = p
        .iter()
        .flat_map(|a| p.iter().map(move |b| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)))
        .fold(0.0f64, f64::max);
    let area = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs()
    };
    let tol = 1e-6 * spread;
    [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]
        .iter()
        .any(|&[i, j, k]| area(p[i], p[j], p[k]) <= tol)
}

impl std::fmt::Display for Homography {
    /// `[h00 h01 h02; h10 h11 h12; h20 h21 h22]`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let h = &self.h;
        write!(
            f,
            "[{:.4} {:.4} {:.2}; {:.4} {:.4} {:.2}; {:.3e} {:.3e} {:.4}]",
            h[0][0], h[0][1], h[0][2], h[1][0], h[1][1], h[1][2], h[2][0], h[2][1], h[2][2]
        )
    }
}

impl PointModel for Homography {
    const SAMPLE: usize = 4;
    const NAME: &'static str = "homography";
    fn fit(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Option<Self> {
        Homography::fit(src, dst)
    }
    fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        Homography::apply(self, p)
    }
}

/// RANSAC settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RansacOptions {
    /// Inlier threshold on the residual, in pixels (default 3).
    pub threshold: f64,
    /// Largest number of minimal samples (default 2000).
    pub iterations: usize,
    /// Confidence of the adaptive stop, in (0, 1) (default 0.999); 1 disables it.
    pub confidence: f64,
    /// Fewest inliers for a consensus (default 6, at least the model's sample size).
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
pub(super) fn consensus<M: PointModel>(
    model: &M,
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    t2: f64,
) -> (Vec<usize>, f64) {
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

/// `S` distinct indices below `n` (`n >= S`): each drawn uniformly among those not drawn yet.
fn sample<const S: usize>(rng: &mut SplitMix64, n: usize) -> [usize; S] {
    let mut out = [0usize; S];
    let mut sorted = [0usize; S];
    for m in 0..S {
        let mut r = rng.below(n - m);
        for &s in &sorted[..m] {
            r += (r >= s) as usize;
        }
        out[m] = r;
        let pos = sorted[..m].partition_point(|&s| s < r);
        sorted.copy_within(pos..m, pos + 1);
        sorted[pos] = r;
    }
    out
}

/// [`sample`] for the tests of the parent module.
#[cfg(test)]
pub(super) fn sample_for_tests<const S: usize>(rng: &mut SplitMix64, n: usize) -> [usize; S] {
    sample::<S>(rng, n)
}

/// Checks the options shared by every RANSAC fit.
pub(super) fn check_options(opts: &RansacOptions) -> Result<(), FeatureError> {
    if !(opts.threshold > 0.0 && opts.threshold.is_finite()) {
        return Err(FeatureError::Threshold { threshold: opts.threshold });
    }
    if !(opts.confidence > 0.0 && opts.confidence <= 1.0) {
        return Err(FeatureError::Confidence { confidence: opts.confidence });
    }
    Ok(())
}

/// Robust fit of model `M`: RANSAC then least-squares refits (see the module
/// documentation). Returns the model and the sorted indices of its inliers.
pub fn ransac<M: PointModel>(
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    opts: &RansacOptions,
) -> Result<(M, Vec<usize>), FeatureError> {
    check_options(opts)?;
    let n = src.len().min(dst.len());
    let required = opts.min_inliers.max(M::SAMPLE);
    if n < M::SAMPLE {
        return Err(FeatureError::TooFewMatches { found: n, model: M::NAME, needed: M::SAMPLE });
    }
    let t2 = opts.threshold * opts.threshold;
    let mut rng = SplitMix64::new(opts.seed);
    let mut best: Option<(M, usize, f64)> = None;
    let mut needed = opts.iterations;
    let mut it = 0;
    let (mut s, mut d) = (Vec::with_capacity(M::SAMPLE), Vec::with_capacity(M::SAMPLE));
    while it < needed.min(opts.iterations) {
        it += 1;
        s.clear();
        d.clear();
        let mut pick = [0usize; 4];
        match M::SAMPLE {
            3 => pick[..3].copy_from_slice(&sample::<3>(&mut rng, n)),
            _ => pick = sample::<4>(&mut rng, n),
        }
        for &k in &pick[..M::SAMPLE] {
            s.push(src[k]);
            d.push(dst[k]);
        }
        let Some(model) = M::fit(&s, &d) else { continue };
        let (idx, ssr) = consensus(&model, &src[..n], &dst[..n], t2);
        let better = match &best {
            None => true,
            Some((_, c, s)) => idx.len() > *c || (idx.len() == *c && ssr < *s),
        };
        if better {
            best = Some((model, idx.len(), ssr));
            let w = idx.len() as f64 / n as f64;
            if opts.confidence < 1.0 {
                let miss = 1.0 - w.powi(M::SAMPLE as i32);
                needed = if miss <= 0.0 {
                    it
                } else {
                    ((1.0 - opts.confidence).ln() / miss.ln()).ceil().max(1.0) as usize
                };
            }
        }
    }
    let no = |best| FeatureError::NoConsensus { best, matches: n, required, model: M::NAME };
    let (model, count, _) = best.ok_or(no(0))?;
    if count < required {
        return Err(no(count));
    }
    refit_inliers(model, &src[..n], &dst[..n], opts).ok_or(no(count))
}

/// [`ransac`] on the affine model.
pub fn ransac_affine(
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    opts: &RansacOptions,
) -> Result<(Affine2, Vec<usize>), FeatureError> {
    ransac(src, dst, opts)
}

/// [`ransac`] on the homography.
pub fn ransac_homography(
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    opts: &RansacOptions,
) -> Result<(Homography, Vec<usize>), FeatureError> {
    ransac(src, dst, opts)
}

/// Least-squares refits and inlier updates from `model` until stable; `None` when fewer
/// than `opts.min_inliers` (at least the sample size) pairs agree with `model`.
pub(super) fn refit_inliers<M: PointModel>(
    mut model: M,
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    opts: &RansacOptions,
) -> Option<(M, Vec<usize>)> {
    let (required, t2) = (opts.min_inliers.max(M::SAMPLE), opts.threshold.powi(2));
    let (mut inliers, _) = consensus(&model, src, dst, t2);
    if inliers.len() < required {
        return None;
    }
    for _ in 0..10 {
        let s: Vec<[f64; 2]> = inliers.iter().map(|&k| src[k]).collect();
        let d: Vec<[f64; 2]> = inliers.iter().map(|&k| dst[k]).collect();
        let Some(refit) = M::fit(&s, &d) else { break };
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
