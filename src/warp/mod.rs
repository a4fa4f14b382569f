//! Moving data through a deformation: points (both directions) and images.
//!
//! **Which way the maps run.** `phi` maps the reference domain to the deformed plane, both
//! in mesh coordinates (for images: pixels, x to the right, y down, pixel `(i, j)` centred
//! at `(i, j)`).
//!
//! * points: [`forward`] is `p -> phi(p)`; [`inverse`] is `q -> phi^-1(q)`;
//! * images: the output is `O(q) = I(phi^-1(q))`, so a feature at `p` in the input appears
//!   at `phi(p)` in the output. The inverse is computed by Newton's method (not
//!   approximated), with a per-pixel error bound (0.01 px by default, see [`inverse`]);
//!   pixels whose preimage is outside the mesh get the background value (and alpha 0).
//!
//! Images keep their type: 8- and 16-bit gray, gray+alpha, RGB, RGBA and 32-bit float RGB
//! and RGBA; every channel is resampled with the same map (nearest, bilinear or bicubic).

pub mod colormesh;
pub mod field;
pub mod inverse;

use crate::spline::Spline;
use image::{DynamicImage, ImageBuffer, Pixel, Primitive};
use inverse::{InverseMap, InverseOptions, Preimage};
use num_traits::{NumCast, ToPrimitive};
use rayon::prelude::*;

/// Resampling of the input image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Interp {
    /// Nearest pixel.
    Nearest,
    /// Bilinear.
    #[default]
    Bilinear,
    /// Bicubic (Keys, a = -0.5), clamped to the sample range.
    Bicubic,
}

impl std::str::FromStr for Interp {
    type Err = String;
    fn from_str(s: &str) -> Result<Interp, String> {
        match s {
            "nearest" => Ok(Interp::Nearest),
            "bilinear" => Ok(Interp::Bilinear),
            "bicubic" => Ok(Interp::Bicubic),
            _ => Err(format!("unknown interpolation `{s}` (use nearest, bilinear or bicubic)")),
        }
    }
}

/// Errors of warping.
#[derive(Debug, thiserror::Error)]
pub enum WarpError {
    /// The image type is not supported.
    #[error("unsupported image type {0:?} (use 8/16-bit gray, gray+alpha, RGB, RGBA or 32-bit float RGB/RGBA)")]
    Unsupported(image::ColorType),
}

/// What happened while warping an image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WarpReport {
    /// Output pixels.
    pub pixels: usize,
    /// Pixels whose preimage is outside the mesh (or not found within the tolerance).
    pub outside: usize,
    /// Largest error bound of an accepted preimage (pixels).
    pub max_error_bound: f64,
}

/// `phi(p)` for each point (`None` outside the mesh).
pub fn forward(s: &Spline, pts: &[[f64; 2]]) -> Vec<Option<[f64; 2]>> {
    let mut out = vec![None; pts.len()];
    s.eval_many(pts, &mut out);
    out
}

/// `phi^-1(q)` for each point (`None` when no preimage within the tolerance exists).
pub fn inverse(s: &Spline, pts: &[[f64; 2]], opts: InverseOptions) -> Vec<Option<Preimage>> {
    let map = InverseMap::new(s, opts);
    let mut prev: Option<Preimage> = None;
    pts.iter()
        .map(|q| {
            let r = map.invert(*q, prev.as_ref());
            if r.is_some() {
                prev = r;
            }
            r
        })
        .collect()
}

/// The preimage of every pixel centre of a `w x h` output, row by row in parallel.
pub fn preimages(s: &Spline, w: u32, h: u32, opts: InverseOptions) -> Vec<Option<Preimage>> {
    let map = InverseMap::new(s, opts);
    (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut prev: Option<Preimage> = None;
            let map = &map;
            (0..w).map(move |x| {
                let r = map.invert([x as f64, y as f64], prev.as_ref());
                if r.is_some() {
                    prev = r;
                }
                r
            })
        })
        .collect()
}

fn keys(t: f64) -> f64 {
    let t = t.abs();
    if t < 1.0 {
        1.5 * t * t * t - 2.5 * t * t + 1.0
    } else if t < 2.0 {
        -0.5 * t * t * t + 2.5 * t * t - 4.0 * t + 2.0
    } else {
        0.0
    }
}

/// Samples channel `c` of `img` at `p` (pixel coordinates, edge-clamped).
fn sample<P>(img: &ImageBuffer<P, Vec<P::Subpixel>>, p: [f64; 2], c: usize, interp: Interp) -> f64
where
    P: Pixel,
    P::Subpixel: ToPrimitive,
{
    let (w, h) = (img.width() as i64, img.height() as i64);
    let at = |x: i64, y: i64| -> f64 {
        let px = img.get_pixel(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32);
        px.channels()[c].to_f64().unwrap_or(0.0)
    };
    match interp {
        Interp::Nearest => at(p[0].round() as i64, p[1].round() as i64),
        Interp::Bilinear => {
            let (x0, y0) = (p[0].floor(), p[1].floor());
            let (fx, fy) = (p[0] - x0, p[1] - y0);
            let (x0, y0) = (x0 as i64, y0 as i64);
            let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
            let bot = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
            top * (1.0 - fy) + bot * fy
        }
        Interp::Bicubic => {
            let (x0, y0) = (p[0].floor(), p[1].floor());
            let (fx, fy) = (p[0] - x0, p[1] - y0);
            let (x0, y0) = (x0 as i64, y0 as i64);
            let (mut acc, mut lo, mut hi) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
            for j in -1..=2 {
                let wy = keys(fy - j as f64);
                for i in -1..=2 {
                    let v = at(x0 + i, y0 + j);
                    if (0..=1).contains(&i) && (0..=1).contains(&j) {
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                    acc += keys(fx - i as f64) * wy * v;
                }
            }
            // Clamp overshoot to the 2x2 neighbourhood (no ringing beyond the data).
            acc.clamp(lo, hi)
        }
    }
}

fn warp_buffer<P>(
    img: &ImageBuffer<P, Vec<P::Subpixel>>,
    pre: &[Option<Preimage>],
    interp: Interp,
    background: f64,
) -> ImageBuffer<P, Vec<P::Subpixel>>
where
    P: Pixel + Send + Sync,
    P::Subpixel: Primitive + ToPrimitive + NumCast + Send + Sync,
{
    let (w, h) = img.dimensions();
    let nc = P::CHANNEL_COUNT as usize;
    let has_alpha = nc == 2 || nc == 4;
    let (lo, hi) = (
        <P::Subpixel as Primitive>::DEFAULT_MIN_VALUE.to_f64().unwrap_or(0.0),
        <P::Subpixel as Primitive>::DEFAULT_MAX_VALUE.to_f64().unwrap_or(1.0),
    );
    let is_float = hi <= 1.0;
    let conv = |v: f64| -> P::Subpixel {
        let v = if is_float { v } else { v.round() };
        NumCast::from(v.clamp(lo, hi)).unwrap_or(<P::Subpixel as Primitive>::DEFAULT_MIN_VALUE)
    };
    let mut data: Vec<P::Subpixel> = vec![conv(0.0); (w * h) as usize * nc];
    data.par_chunks_mut(nc).zip(pre.par_iter()).for_each(|(px, pre)| match pre {
        Some(pm) => {
            for (c, out) in px.iter_mut().enumerate() {
                *out = conv(sample(img, pm.p, c, interp));
            }
        }
        None => {
            for (c, out) in px.iter_mut().enumerate() {
                *out = if has_alpha && c + 1 == nc { conv(lo) } else { conv(background) };
            }
        }
    });
    ImageBuffer::from_raw(w, h, data).expect("sizes match")
}

/// Warps an image: `O(q) = I(phi^-1(q))`, same size and type as the input.
pub fn warp_image(
    s: &Spline,
    img: &DynamicImage,
    interp: Interp,
    background: f64,
    opts: InverseOptions,
) -> Result<(DynamicImage, WarpReport), WarpError> {
    let (w, h) = (img.width(), img.height());
    let pre = preimages(s, w, h, opts);
    let report = WarpReport {
        pixels: pre.len(),
        outside: pre.iter().filter(|p| p.is_none()).count(),
        max_error_bound: pre.iter().flatten().map(|p| p.error_bound).fold(0.0, f64::max),
    };
    macro_rules! same_type {
        ($($v:ident),*) => {
            match img {
                $(DynamicImage::$v(b) => DynamicImage::$v(warp_buffer(b, &pre, interp, background)),)*
                other => return Err(WarpError::Unsupported(other.color())),
            }
        };
    }
    let out = same_type!(
        ImageLuma8,
        ImageLumaA8,
        ImageRgb8,
        ImageRgba8,
        ImageLuma16,
        ImageLumaA16,
        ImageRgb16,
        ImageRgba16,
        ImageRgb32F,
        ImageRgba32F
    );
    Ok((out, report))
}

#[cfg(test)]
mod tests;
