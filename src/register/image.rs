//! The images of a registration: one grey channel in `f32`, its mask, the Gaussian pyramid,
//! and the smooth interpolant sampled by the metric.
//!
//! **Grey values.** Every type trimorph reads is registered as grey
//! ([`image::DynamicImage::to_luma32f`]: 8- and 16-bit scaled to `[0, 1]`, float kept,
//! colour by Rec. 709 luma). Float images with NaN or infinite pixels are refused.
//!
//! **Pyramid.** Level 0 is the image; level `l + 1` is level `l` blurred by a Gaussian of
//! `sigma = 1` pixel (`imageproc::filter::gaussian_blur_f32`) and reduced by 2 by averaging
//! 2 x 2 blocks. Pixel `i` of level `l` is centred at `2^l i + (2^l - 1) / 2` in level-0
//! pixels ([`Level::to_full`]); an odd last row or column is dropped.
//!
//! **Interpolant.** The metric samples `F` off the pixel grid. It uses the uniform cubic
//! B-spline with the pixel values as coefficients (no prefilter),
//! `F(x, y) = sum_ij f_ij N3(x - i) N3(y - j)`: twice continuously differentiable, so the
//! cost is smooth and its gradient, `dF/dx = sum_ij f_ij N3'(x - i) N3(y - j)`, is exact (the
//! test checks it by finite differences). Without prefilter the spline smooths by the
//! kernel `[1, 4, 1] / 6` at the pixel centres, so the values sampled on the grid of the
//! other image are smoothed by the same kernel ([`Channel::smoothed141`],
//! `imageproc::filter::separable_filter_equal`): both sides see the same blur. Outside the
//! image's pixel centres grown by half a pixel a sample is invalid.

use super::error::RegisterError;
use image::{DynamicImage, ImageBuffer, Luma};
use std::path::Path;

/// One grey channel, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// Width (pixels).
    pub w: usize,
    /// Height (pixels).
    pub h: usize,
    /// `w * h` values.
    pub data: Vec<f32>,
}

type GrayF = ImageBuffer<Luma<f32>, Vec<f32>>;

impl Channel {
    /// The grey channel of `img` (see the module docs); `name` is what errors call it.
    pub fn from_image(img: &DynamicImage, name: &Path) -> Result<Channel, RegisterError> {
        let g = img.to_luma32f();
        let (w, h) = (g.width() as usize, g.height() as usize);
        let data = g.into_raw();
        if let Some(k) = data.iter().position(|v| !v.is_finite()) {
            return Err(RegisterError::NonFinite {
                image: name.to_path_buf(),
                x: k % w.max(1),
                y: k / w.max(1),
            });
        }
        Ok(Channel { w, h, data })
    }

    /// The value of pixel `(x, y)`.
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.w + x]
    }

    fn to_buffer(&self) -> GrayF {
        ImageBuffer::from_raw(self.w as u32, self.h as u32, self.data.clone())
            .expect("w * h values")
    }

    fn from_buffer(b: GrayF) -> Channel {
        let (w, h) = (b.width() as usize, b.height() as usize);
        Channel { w, h, data: b.into_raw() }
    }

    /// The next pyramid level: blurred (`sigma = 1`) and reduced by 2 x 2 block means.
    pub fn reduced(&self) -> Channel {
        let blurred = if self.w >= 2 && self.h >= 2 {
            Channel::from_buffer(imageproc::filter::gaussian_blur_f32(&self.to_buffer(), 1.0))
        } else {
            self.clone()
        };
        let (w, h) = ((self.w / 2).max(1), (self.h / 2).max(1));
        let mut data = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let (x0, y0) = (2 * x, 2 * y);
                let (x1, y1) = ((x0 + 1).min(self.w - 1), (y0 + 1).min(self.h - 1));
                let s = blurred.at(x0, y0)
                    + blurred.at(x1, y0)
                    + blurred.at(x0, y1)
                    + blurred.at(x1, y1);
                data.push(0.25 * s);
            }
        }
        Channel { w, h, data }
    }

    /// The image smoothed by the separable kernel `[1, 4, 1] / 6` (the cubic B-spline's
    /// values at the pixel centres; borders replicated).
    pub fn smoothed141(&self) -> Channel {
        if self.w < 2 || self.h < 2 {
            return self.clone();
        }
        let k = [1.0f32 / 6.0, 4.0 / 6.0, 1.0 / 6.0];
        Channel::from_buffer(imageproc::filter::separable_filter_equal(&self.to_buffer(), &k))
    }

    /// The smallest and largest values among `mask`ed pixels (all when `None`).
    pub fn range(&self, mask: Option<&Mask>) -> (f32, f32) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for (k, &v) in self.data.iter().enumerate() {
            if mask.is_none_or(|m| m.on[k]) {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (lo, hi)
    }

    /// `F` and its gradient at `(x, y)` in this image's pixels (see the module docs), or
    /// `None` outside the pixel centres grown by half a pixel. Coefficients beyond the
    /// border repeat the border pixels.
    #[inline]
    pub fn sample(&self, x: f64, y: f64) -> Option<(f64, [f64; 2])> {
        let (wf, hf) = (self.w as f64, self.h as f64);
        if !(x >= -0.5 && y >= -0.5 && x <= wf - 0.5 && y <= hf - 0.5) {
            return None;
        }
        let (fx, fy) = (x.floor(), y.floor());
        let (tx, ty) = (x - fx, y - fy);
        let (bx, dbx) = cubic_weights(tx);
        let (by, dby) = cubic_weights(ty);
        let (ix, iy) = (fx as isize - 1, fy as isize - 1);
        let clamp_x = |i: isize| i.clamp(0, self.w as isize - 1) as usize;
        let clamp_y = |i: isize| i.clamp(0, self.h as isize - 1) as usize;
        let cols = [0, 1, 2, 3].map(|k| clamp_x(ix + k));
        let mut v = 0.0;
        let mut gx = 0.0;
        let mut gy = 0.0;
        for (r, (&wy, &dwy)) in by.iter().zip(&dby).enumerate() {
            let row = &self.data[clamp_y(iy + r as isize) * self.w..][..self.w];
            let mut sv = 0.0;
            let mut sd = 0.0;
            for (k, &c) in cols.iter().enumerate() {
                let p = row[c] as f64;
                sv += bx[k] * p;
                sd += dbx[k] * p;
            }
            v += wy * sv;
            gx += wy * sd;
            gy += dwy * sv;
        }
        Some((v, [gx, gy]))
    }
}

/// The cubic B-spline's weights of the four coefficients around a point at fraction `t`
/// past the second, and their derivatives.
#[inline]
fn cubic_weights(t: f64) -> ([f64; 4], [f64; 4]) {
    let s = 1.0 - t;
    let t2 = t * t;
    let t3 = t2 * t;
    (
        [
            s * s * s / 6.0,
            (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
            (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
            t3 / 6.0,
        ],
        [-0.5 * s * s, (3.0 * t2 - 4.0 * t) / 2.0, (-3.0 * t2 + 2.0 * t + 1.0) / 2.0, 0.5 * t2],
    )
}

/// Which pixels take part: `true` inside.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    /// Width (pixels).
    pub w: usize,
    /// Height (pixels).
    pub h: usize,
    /// `w * h` flags.
    pub on: Vec<bool>,
}

impl Mask {
    /// The mask of an image: pixels whose grey value is above half its range are inside
    /// (a binary mask saved as 0 / 255, 0 / 1 or 0 / 65535 reads as intended).
    pub fn from_image(img: &DynamicImage) -> Mask {
        let g = img.to_luma32f();
        let (w, h) = (g.width() as usize, g.height() as usize);
        let data = g.into_raw();
        let hi = data.iter().copied().filter(|v| v.is_finite()).fold(0.0f32, f32::max);
        let on = data.iter().map(|&v| v.is_finite() && v > 0.5 * hi && v > 0.0).collect();
        Mask { w, h, on }
    }

    /// Pixels inside.
    pub fn count(&self) -> usize {
        self.on.iter().filter(|&&b| b).count()
    }

    /// The mask of the next pyramid level: a block is inside when at least two of its four
    /// pixels are.
    pub fn reduced(&self) -> Mask {
        let (w, h) = ((self.w / 2).max(1), (self.h / 2).max(1));
        let mut on = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let (x0, y0) = (2 * x, 2 * y);
                let (x1, y1) = ((x0 + 1).min(self.w - 1), (y0 + 1).min(self.h - 1));
                let n = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]
                    .iter()
                    .filter(|&&(a, b)| self.on[b * self.w + a])
                    .count();
                on.push(n >= 2);
            }
        }
        Mask { w, h, on }
    }

    /// Whether the point `(x, y)` (this mask's pixels) falls on a pixel inside.
    #[inline]
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let (i, j) = (x.round(), y.round());
        if i < 0.0 || j < 0.0 || i >= self.w as f64 || j >= self.h as f64 {
            return false;
        }
        self.on[j as usize * self.w + i as usize]
    }
}

/// One pyramid level of an image: the channel, its mask and its scale.
#[derive(Clone, Debug)]
pub struct Level {
    /// The level's pixels.
    pub image: Channel,
    /// Its mask (`None`: every pixel).
    pub mask: Option<Mask>,
    /// The level number `l` (pixels are `2^l` level-0 pixels wide).
    pub level: u32,
}

impl Level {
    /// The level-0 position of this level's point `p`.
    #[inline]
    pub fn to_full(&self, p: [f64; 2]) -> [f64; 2] {
        let s = (1u64 << self.level) as f64;
        let o = 0.5 * (s - 1.0);
        [s * p[0] + o, s * p[1] + o]
    }

    /// This level's position of the level-0 point `p`.
    #[inline]
    pub fn from_full(&self, p: [f64; 2]) -> [f64; 2] {
        let s = (1u64 << self.level) as f64;
        let o = 0.5 * (s - 1.0);
        [(p[0] - o) / s, (p[1] - o) / s]
    }

    /// `F` and its gradient with respect to level-0 coordinates at the level-0 point `p`
    /// moved into the image's domain (the pixel centres grown by half a pixel) when it lies
    /// beyond: the interpolant continued by its border values, constant across the border
    /// (a zero gradient across it), and the mask not looked at. For the samples a run keeps
    /// whatever the map does ([`super::samples::Membership`]).
    #[inline]
    pub fn sample_clamped(&self, p: [f64; 2]) -> (f64, [f64; 2]) {
        let q = self.from_full(p);
        let (wf, hf) = (self.image.w as f64 - 0.5, self.image.h as f64 - 0.5);
        let x = q[0].clamp(-0.5, wf);
        let y = q[1].clamp(-0.5, hf);
        let s = (1u64 << self.level) as f64;
        let (v, g) = self.image.sample(x, y).unwrap_or((0.0, [0.0, 0.0]));
        // Clamped coordinates (NaN included) do not move with p.
        let kx = if x == q[0] { 1.0 / s } else { 0.0 };
        let ky = if y == q[1] { 1.0 / s } else { 0.0 };
        (v, [g[0] * kx, g[1] * ky])
    }

    /// `F` and its gradient with respect to level-0 coordinates at the level-0 point `p`,
    /// or `None` outside the image or its mask.
    #[inline]
    pub fn sample_full(&self, p: [f64; 2]) -> Option<(f64, [f64; 2])> {
        let q = self.from_full(p);
        if let Some(m) = &self.mask {
            if !m.contains(q[0], q[1]) {
                return None;
            }
        }
        let s = (1u64 << self.level) as f64;
        self.image.sample(q[0], q[1]).map(|(v, g)| (v, [g[0] / s, g[1] / s]))
    }
}

/// The Gaussian pyramid of an image and its mask: `levels` levels (at least one).
pub fn pyramid(image: &Channel, mask: Option<&Mask>, levels: u32) -> Vec<Level> {
    let mut out = vec![Level { image: image.clone(), mask: mask.cloned(), level: 0 }];
    for l in 1..levels.max(1) {
        let prev = out.last().expect("level 0 is there");
        out.push(Level {
            image: prev.image.reduced(),
            mask: prev.mask.as_ref().map(Mask::reduced),
            level: l,
        });
    }
    out
}

/// The number of pyramid levels for images whose shorter side is `side` pixels: halve
/// while the coarsest level keeps at least 48 pixels, at most `max`.
pub fn auto_levels(side: usize, max: u32) -> u32 {
    let mut n = 1;
    let mut s = side;
    while n < max && s / 2 >= 48 {
        s /= 2;
        n += 1;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Channel {
        let data = (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f32, (k / w) as f32);
                (0.3 * x).sin() + (0.2 * y).cos() + 0.01 * x * y
            })
            .collect();
        Channel { w, h, data }
    }

    #[test]
    fn cubic_weights_sum_to_one_and_their_derivatives_to_zero() {
        for t in [0.0, 0.25, 0.5, 0.99] {
            let (b, d) = cubic_weights(t);
            assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(d.iter().sum::<f64>().abs() < 1e-12);
        }
    }

    #[test]
    fn the_interpolant_gradient_matches_finite_differences() {
        let c = ramp(20, 16);
        let h = 1e-5;
        for &(x, y) in &[(3.3, 4.7), (10.01, 2.5), (15.9, 12.2), (0.2, 0.3)] {
            let (_, g) = c.sample(x, y).unwrap();
            let fx = (c.sample(x + h, y).unwrap().0 - c.sample(x - h, y).unwrap().0) / (2.0 * h);
            let fy = (c.sample(x, y + h).unwrap().0 - c.sample(x, y - h).unwrap().0) / (2.0 * h);
            assert!((g[0] - fx).abs() < 1e-6 && (g[1] - fy).abs() < 1e-6, "{g:?} {fx} {fy}");
        }
    }

    #[test]
    fn the_interpolant_on_the_grid_is_the_141_smoothing() {
        let c = ramp(12, 10);
        let s = c.smoothed141();
        for (x, y) in [(3usize, 4usize), (6, 6), (8, 2)] {
            let v = c.sample(x as f64, y as f64).unwrap().0;
            assert!((v - s.at(x, y) as f64).abs() < 1e-5, "{v} {}", s.at(x, y));
        }
    }

    #[test]
    fn samples_outside_the_image_are_invalid() {
        let c = ramp(8, 8);
        assert!(c.sample(-0.6, 3.0).is_none());
        assert!(c.sample(3.0, 7.6).is_none());
        assert!(c.sample(-0.5, 7.5).is_some());
    }

    #[test]
    fn pyramid_levels_map_centres_consistently() {
        let c = ramp(64, 48);
        let p = pyramid(&c, None, 3);
        assert_eq!((p[2].image.w, p[2].image.h), (16, 12));
        // Level-2 pixel 0 covers level-0 pixels 0..4, centred at 1.5.
        assert_eq!(p[2].to_full([0.0, 0.0]), [1.5, 1.5]);
        assert_eq!(p[2].from_full([1.5, 5.5]), [0.0, 1.0]);
        assert_eq!(auto_levels(512, 4), 4);
        assert_eq!(auto_levels(100, 4), 2);
    }

    #[test]
    fn binary_masks_read_as_intended_and_reduce() {
        let img = DynamicImage::ImageLuma8(ImageBuffer::from_fn(4, 4, |x, _| {
            Luma([if x < 2 { 0u8 } else { 255 }])
        }));
        let m = Mask::from_image(&img);
        assert_eq!(m.count(), 8);
        let r = m.reduced();
        assert_eq!(r.on, vec![false, true, false, true]);
    }
}
