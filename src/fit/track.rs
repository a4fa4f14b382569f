//! Tracking points from one frame to the next: pyramidal Lucas-Kanade with a
//! forward-backward check.
//!
//! # Coordinates
//!
//! Pixel coordinates: pixel `(i, j)` (column `i`, row `j`) is centred at `(x, y) = (i, j)`,
//! `x` to the right, `y` downwards. A point is inside a `w x h` frame when
//! `0 <= x <= w - 1` and `0 <= y <= h - 1`.
//!
//! # Method
//!
//! For a point `p` of `prev`, Lucas-Kanade looks for the displacement `d` that minimises
//! `sum_{u in W} (next(p + u + d) - prev(p + u))^2` over a 21 x 21 window `W`, by Gauss-Newton
//! steps `d += G^-1 sum grad(prev) (prev - next)` with the structure tensor
//! `G = sum grad grad^T`, coarse to fine over a Gaussian pyramid of `max_level + 1` levels
//! (each level halves the size, so displacements up to about `10 * 2^max_level` pixels are
//! found). kornia's [`calc_optical_flow_pyr_lk`] does this on `f32` images; the 8-bit frames
//! are scaled to `[0, 1]` first. A point is lost (`None`) when kornia reports failure (a
//! window leaving the image, or a structure tensor whose smaller eigenvalue per window
//! pixel is below [`TrackOptions::min_eigen`], i.e. a flat or edge-only patch), when the
//! tracked point is outside `next`, or when tracking it back from `next` to `prev` lands
//! more than [`TrackOptions::fb_threshold`] pixels from where it started (the
//! forward-backward check of Kalal et al. 2010).
//!
//! Built without the `kornia` Cargo feature, [`track_points`] always returns
//! [`TrackError::Unavailable`] (so a tracked frame sequence fails with that message).

use image::GrayImage;
#[cfg(feature = "kornia")]
use kornia_image::{Image, ImageSize};
#[cfg(feature = "kornia")]
use kornia_imgproc::optical_flow_pyr_lk::{
    calc_optical_flow_pyr_lk, BorderMode, PyrLKError, PyrLKParams, TermCriteria,
};

/// Errors of point tracking.
#[derive(Debug, thiserror::Error)]
pub enum TrackError {
    /// The two frames differ in size.
    #[error("frames differ in size: {prev:?} and {next:?}")]
    SizeMismatch {
        /// Size of `prev` (width, height).
        prev: (u32, u32),
        /// Size of `next`.
        next: (u32, u32),
    },
    /// The initial guesses are not one per point.
    #[error("{init} initial positions for {points} points")]
    InitLength {
        /// Number of initial guesses.
        init: usize,
        /// Number of points.
        points: usize,
    },
    /// A point or initial guess is not finite.
    #[error("point {index} is not finite")]
    NonFinite {
        /// Its index.
        index: usize,
    },
    /// A forward-backward threshold ([`TrackOptions::fb_threshold`]) that is not `> 0`.
    #[error("invalid option: fb_threshold {threshold} is not > 0")]
    FbThreshold {
        /// The threshold given (pixels).
        threshold: f64,
    },
    /// kornia's tracker failed.
    #[cfg(feature = "kornia")]
    #[error("Lucas-Kanade tracking failed: {0}")]
    Lk(#[from] PyrLKError),
    /// A frame could not be handed to kornia.
    #[cfg(feature = "kornia")]
    #[error("frame conversion failed: {0}")]
    Image(#[from] kornia_image::ImageError),
    /// This build has no tracker (built without the `kornia` feature).
    #[cfg(not(feature = "kornia"))]
    #[error("point tracking is not available: this build of trimorph has no kornia (Cargo feature `kornia`)")]
    Unavailable,
}

/// Settings of [`track_points`].
#[derive(Clone, Debug, PartialEq)]
pub struct TrackOptions {
    /// Coarsest pyramid level (0: single scale; default 3).
    pub max_level: usize,
    /// Most Gauss-Newton iterations per level (default 30).
    pub max_iter: usize,
    /// Stop iterating when the update is shorter than this (pixels; default 0.01).
    pub epsilon: f32,
    /// Smallest accepted eigenvalue of the structure tensor divided by the window's 441
    /// pixels, for intensities in `[0, 1]` (default 1e-6: the low-contrast phase image
    /// `data/microscopy/cell.png` has values between 3e-6 and 1e-5 at typical points; a
    /// flat patch has 0).
    pub min_eigen: f32,
    /// Largest forward-backward error in pixels; `None` skips the check (default 1.0).
    pub fb_threshold: Option<f64>,
}

impl Default for TrackOptions {
    fn default() -> Self {
        Self { max_level: 3, max_iter: 30, epsilon: 0.01, min_eigen: 1e-6, fb_threshold: Some(1.0) }
    }
}

/// The frame as a kornia `f32` image with values in `[0, 1]`.
#[cfg(feature = "kornia")]
fn to_f32(img: &GrayImage) -> Result<Image<f32, 1>, kornia_image::ImageError> {
    let size = ImageSize { width: img.width() as usize, height: img.height() as usize };
    let data: Vec<f32> = img.as_raw().iter().map(|&v| v as f32 / 255.0).collect();
    Image::new(size, data)
}

/// Tracks `pts` from `prev` to `next` (see the module documentation). `init`, when given,
/// holds one starting guess in `next` per point (for example a predicted position).
/// Returns the position in `next` of each point, `None` where it was lost.
#[cfg(feature = "kornia")]
pub fn track_points(
    prev: &GrayImage,
    next: &GrayImage,
    pts: &[[f64; 2]],
    init: Option<&[[f64; 2]]>,
    opts: &TrackOptions,
) -> Result<Vec<Option<[f64; 2]>>, TrackError> {
    if prev.dimensions() != next.dimensions() {
        return Err(TrackError::SizeMismatch { prev: prev.dimensions(), next: next.dimensions() });
    }
    if let Some(i) = init {
        if i.len() != pts.len() {
            return Err(TrackError::InitLength { init: i.len(), points: pts.len() });
        }
    }
    if let Some(index) =
        pts.iter().chain(init.unwrap_or(&[])).position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(TrackError::NonFinite { index: index % pts.len().max(1) });
    }
    if let Some(t) = opts.fb_threshold {
        if t.is_nan() || t <= 0.0 {
            return Err(TrackError::FbThreshold { threshold: t });
        }
    }
    if pts.is_empty() {
        return Ok(Vec::new());
    }
    let (w, h) = prev.dimensions();
    let (fp, fn_) = (to_f32(prev)?, to_f32(next)?);
    let params = PyrLKParams {
        win_size: 21,
        max_level: opts.max_level,
        max_iter: opts.max_iter,
        epsilon: opts.epsilon,
        min_eigen_threshold: opts.min_eigen,
        use_initial_flow: init.is_some(),
        term_criteria: TermCriteria::Both,
        border_mode: BorderMode::Clamp,
    };
    let to32 = |p: &[f64; 2]| [p[0] as f32, p[1] as f32];
    let p32: Vec<[f32; 2]> = pts.iter().map(to32).collect();
    let i32s: Option<Vec<[f32; 2]>> = init.map(|i| i.iter().map(to32).collect());
    let fwd = calc_optical_flow_pyr_lk(&fp, &fn_, &p32, i32s.as_deref(), &params)?;
    let inside = |p: [f32; 2]| {
        p[0].is_finite()
            && p[1].is_finite()
            && p[0] >= 0.0
            && p[1] >= 0.0
            && p[0] <= (w - 1) as f32
            && p[1] <= (h - 1) as f32
    };
    let mut out: Vec<Option<[f64; 2]>> = fwd
        .next_pts
        .iter()
        .zip(&fwd.status)
        .map(|(&q, &s)| (s != 0 && inside(q)).then(|| [q[0] as f64, q[1] as f64]))
        .collect();
    if let Some(t) = opts.fb_threshold {
        let back_params = PyrLKParams { use_initial_flow: true, ..params };
        let back = calc_optical_flow_pyr_lk(&fn_, &fp, &fwd.next_pts, Some(&p32), &back_params)?;
        for (k, o) in out.iter_mut().enumerate() {
            let b = back.next_pts[k];
            let e = ((b[0] as f64 - pts[k][0]).powi(2) + (b[1] as f64 - pts[k][1]).powi(2)).sqrt();
            if back.status[k] == 0 || e.is_nan() || e > t {
                *o = None;
            }
        }
    }
    Ok(out)
}

/// [`track_points`] in a build without the `kornia` feature: always
/// [`TrackError::Unavailable`].
#[cfg(not(feature = "kornia"))]
pub fn track_points(
    _prev: &GrayImage,
    _next: &GrayImage,
    _pts: &[[f64; 2]],
    _init: Option<&[[f64; 2]]>,
    _opts: &TrackOptions,
) -> Result<Vec<Option<[f64; 2]>>, TrackError> {
    Err(TrackError::Unavailable)
}

#[cfg(all(test, feature = "kornia"))]
mod tests {
    use super::*;

    fn cell() -> GrayImage {
        let p = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/cell.png");
        image::open(p).unwrap().to_luma8()
    }

    /// `out(x, y) = img(x - dx, y - dy)`, 0 outside.
    fn shifted(img: &GrayImage, dx: i64, dy: i64) -> GrayImage {
        let (w, h) = img.dimensions();
        GrayImage::from_fn(w, h, |x, y| {
            let (sx, sy) = (x as i64 - dx, y as i64 - dy);
            if sx < 0 || sy < 0 || sx >= w as i64 || sy >= h as i64 {
                image::Luma([0])
            } else {
                *img.get_pixel(sx as u32, sy as u32)
            }
        })
    }

    #[test]
    fn tracks_a_shifted_cell_image_within_0_3_px() {
        let a = cell();
        let b = shifted(&a, 3, -2);
        let pts: Vec<[f64; 2]> = (0..12)
            .flat_map(|i| (0..14).map(move |j| [40.0 + 40.0 * i as f64, 40.0 + 42.0 * j as f64]))
            .collect();
        let r = track_points(&a, &b, &pts, None, &TrackOptions::default()).unwrap();
        let tracked: Vec<_> = pts.iter().zip(&r).filter_map(|(p, q)| q.map(|q| (p, q))).collect();
        assert!(tracked.len() * 2 >= pts.len(), "only {} of {} tracked", tracked.len(), pts.len());
        for (p, q) in tracked {
            let e = ((q[0] - p[0] - 3.0).powi(2) + (q[1] - p[1] + 2.0).powi(2)).sqrt();
            assert!(e < 0.3, "{p:?} -> {q:?}: error {e:.3}");
        }
        // An initial guess gives the same answers.
        let guess: Vec<[f64; 2]> = pts.iter().map(|p| [p[0] + 2.0, p[1] - 1.0]).collect();
        let g = track_points(&a, &b, &pts, Some(&guess), &TrackOptions::default()).unwrap();
        for (x, y) in r.iter().zip(&g) {
            if let (Some(x), Some(y)) = (x, y) {
                assert!((x[0] - y[0]).abs() < 0.1 && (x[1] - y[1]).abs() < 0.1);
            }
        }
    }

    #[test]
    fn points_leaving_the_image_are_lost() {
        let a = cell();
        let w = a.width();
        // Shift right by 3 and up by 2: points in the last 3 columns or the first 2 rows
        // leave the frame.
        let b = shifted(&a, 3, -2);
        let pts = [
            [(w - 2) as f64, 300.0],
            [(w - 1) as f64, 200.0],
            [250.0, 1.0],
            [400.0, 0.0],
            [(w - 1) as f64, 0.5],
        ];
        let r = track_points(&a, &b, &pts, None, &TrackOptions::default()).unwrap();
        assert_eq!(r, vec![None; pts.len()], "{r:?}");
        let none = TrackOptions { fb_threshold: None, ..Default::default() };
        let r = track_points(&a, &b, &pts, None, &none).unwrap();
        assert_eq!(r, vec![None; pts.len()], "without the fb check: {r:?}");
    }

    #[test]
    fn flat_patches_are_lost_and_inputs_are_checked() {
        let flat = GrayImage::from_pixel(128, 128, image::Luma([100]));
        let r = track_points(&flat, &flat, &[[64.0, 64.0]], None, &TrackOptions::default());
        assert_eq!(r.unwrap(), vec![None]);
        let other = GrayImage::new(128, 100);
        assert!(matches!(
            track_points(&flat, &other, &[[1.0, 1.0]], None, &TrackOptions::default()),
            Err(TrackError::SizeMismatch { .. })
        ));
        assert!(matches!(
            track_points(&flat, &flat, &[[1.0, 1.0]], Some(&[]), &TrackOptions::default()),
            Err(TrackError::InitLength { init: 0, points: 1 })
        ));
        assert!(matches!(
            track_points(&flat, &flat, &[[f64::NAN, 1.0]], None, &TrackOptions::default()),
            Err(TrackError::NonFinite { index: 0 })
        ));
        assert_eq!(
            track_points(&flat, &flat, &[], None, &TrackOptions::default()).unwrap(),
            vec![]
        );
        let bad = TrackOptions { fb_threshold: Some(0.0), ..TrackOptions::default() };
        let e = track_points(&flat, &flat, &[[1.0, 1.0]], None, &bad).unwrap_err();
        assert!(matches!(e, TrackError::FbThreshold { threshold: 0.0 }));
        assert_eq!(e.to_string(), "invalid option: fb_threshold 0 is not > 0");
    }
}
