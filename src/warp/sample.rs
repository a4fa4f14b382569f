//! Resampling an interleaved image at real positions: nearest, bilinear, bicubic.
//!
//! Positions are in pixel units with pixel `(i, j)` centred at `(i, j)`; reads outside the
//! image clamp to the edge. Integer samples are rounded to nearest and clamped to their
//! range; float samples are kept as computed. Bicubic uses Keys' kernel (`a = -0.5`) and
//! clamps the result to the range of the 2x2 neighbourhood, so it never rings beyond the
//! data.
//!
//! Bilinear resampling takes a vector path where the CPU has one (AVX2 on x86_64, detected
//! at run time) for every sample type and channel count: 8- and 16-bit gray
//! (`sample_simd`), 8-bit gray + alpha, RGB and RGBA (`sample_simd_color`), 16-bit gray +
//! alpha, RGB and RGBA (`sample_simd_color16`) and `f32` with 1 to 4 channels
//! (`sample_simd_float`), each bit-identical to the scalar arithmetic here (the `pixel`
//! closure of [`fill_pixels`], which also does the positions the vector paths leave:
//! `NaN`, borders, tails).
//!
//! Bicubic resampling of 8-bit images (gray, gray + alpha, RGB, RGBA) takes an AVX2 path
//! too (`sample_simd_cubic`: Keys' weights, the sixteen taps per channel and the clamp to
//! the 2x2 range in the same `f32` operations and order as [`Source::sample_into`], for
//! positions whose 4x4 neighbourhood lies inside the image), and so does bicubic resampling
//! of 16-bit and `f32` images with 1 to 4 channels (`sample_simd_cubic_wide`, the same
//! arithmetic with the 16-bit rounding or none).
//!
//! Nearest resampling takes an AVX2 path for every sample type and channel count
//! (`sample_simd_nearest`: eight positions rounded half away from zero and clamped to the
//! image in `f64` as `f64::round` and the clamp here do, then the `NC` samples of each
//! copied; only groups with a `NaN` `x`, the background, are left to the scalar path).
//! Scalar nearest is not memory-bound (two libm `round` calls, clamps and a copy of `nc`
//! samples of run-time length per pixel), so the vector path gains about 2x (`f32`, wide
//! pixels) to 5-14x (8- and 16-bit gray) in the criterion benches (README).

use super::{
    sample_simd, sample_simd512, sample_simd_color, sample_simd_color16, sample_simd_cubic,
    sample_simd_cubic_wide, sample_simd_float, sample_simd_nearest, Interp,
};

/// A channel value: `u8`, `u16` or `f32`.
pub trait Texel: Copy + Send + Sync + 'static {
    /// As `f32` (exact for `u8` and `u16`).
    fn to_f32(self) -> f32;
    /// From `f32`: rounded and clamped for integers.
    fn from_f32(v: f32) -> Self;
    /// The samples as bytes when `Self` is `u8` (for the vector paths), else `None`.
    fn as_bytes(s: &[Self]) -> Option<&[u8]> {
        let _ = s;
        None
    }
    /// The samples as mutable bytes when `Self` is `u8`, else `None`.
    fn as_bytes_mut(s: &mut [Self]) -> Option<&mut [u8]> {
        let _ = s;
        None
    }
    /// The samples as `u16` when `Self` is `u16` (for the vector paths), else `None`.
    fn as_u16s(s: &[Self]) -> Option<&[u16]> {
        let _ = s;
        None
    }
    /// The samples as mutable `u16` when `Self` is `u16`, else `None`.
    fn as_u16s_mut(s: &mut [Self]) -> Option<&mut [u16]> {
        let _ = s;
        None
    }
    /// The samples as `f32` when `Self` is `f32` (for the vector paths), else `None`.
    fn as_f32s(s: &[Self]) -> Option<&[f32]> {
        let _ = s;
        None
    }
    /// The samples as mutable `f32` when `Self` is `f32`, else `None`.
    fn as_f32s_mut(s: &mut [Self]) -> Option<&mut [f32]> {
        let _ = s;
        None
    }
}

impl Texel for u8 {
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        (v + 0.5).clamp(0.0, 255.0) as u8
    }
    fn as_bytes(s: &[u8]) -> Option<&[u8]> {
        Some(s)
    }
    fn as_bytes_mut(s: &mut [u8]) -> Option<&mut [u8]> {
        Some(s)
    }
}

impl Texel for u16 {
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        (v + 0.5).clamp(0.0, 65535.0) as u16
    }
    fn as_u16s(s: &[u16]) -> Option<&[u16]> {
        Some(s)
    }
    fn as_u16s_mut(s: &mut [u16]) -> Option<&mut [u16]> {
        Some(s)
    }
}

impl Texel for f32 {
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        v
    }
    fn as_f32s(s: &[f32]) -> Option<&[f32]> {
        Some(s)
    }
    fn as_f32s_mut(s: &mut [f32]) -> Option<&mut [f32]> {
        Some(s)
    }
}

/// A borrowed interleaved image: `nc` channels per pixel, row-major.
#[derive(Clone, Copy)]
pub struct Source<'a, T> {
    /// The samples.
    pub data: &'a [T],
    /// Width (pixels).
    pub w: usize,
    /// Height (pixels).
    pub h: usize,
    /// Channels per pixel.
    pub nc: usize,
}

/// `floor` without a libm call (`x` well inside the `i64` range, as pixel positions are).
#[inline(always)]
pub fn fast_floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

#[inline]
pub(crate) fn keys(t: f32) -> f32 {
    let t = t.abs();
    if t < 1.0 {
        (1.5 * t - 2.5) * t * t + 1.0
    } else if t < 2.0 {
        ((-0.5 * t + 2.5) * t - 4.0) * t + 2.0
    } else {
        0.0
    }
}

impl<T: Texel> Source<'_, T> {
    #[inline]
    fn at(&self, x: isize, y: isize, c: usize) -> f32 {
        let x = x.clamp(0, self.w as isize - 1) as usize;
        let y = y.clamp(0, self.h as isize - 1) as usize;
        self.data[(y * self.w + x) * self.nc + c].to_f32()
    }

    /// Writes the `nc` channels at `p` into `out`.
    #[inline]
    pub fn sample_into(&self, p: [f64; 2], interp: Interp, out: &mut [T]) {
        let nc = self.nc;
        match interp {
            Interp::Nearest => {
                let x = (p[0].round() as isize).clamp(0, self.w as isize - 1) as usize;
                let y = (p[1].round() as isize).clamp(0, self.h as isize - 1) as usize;
                let k = (y * self.w + x) * nc;
                out.copy_from_slice(&self.data[k..k + nc]);
            }
            Interp::Bilinear => {
                let (fx0, fy0) = (fast_floor(p[0]), fast_floor(p[1]));
                let (fx, fy) = ((p[0] - fx0) as f32, (p[1] - fy0) as f32);
                let (x0, y0) = (fx0 as isize, fy0 as isize);
                if x0 >= 0 && y0 >= 0 && (x0 as usize) + 1 < self.w && (y0 as usize) + 1 < self.h {
                    let k = (y0 as usize * self.w + x0 as usize) * nc;
                    let kd = k + self.w * nc;
                    let d = &self.data;
                    for c in 0..nc {
                        let top =
                            d[k + c].to_f32() + (d[k + nc + c].to_f32() - d[k + c].to_f32()) * fx;
                        let bot = d[kd + c].to_f32()
                            + (d[kd + nc + c].to_f32() - d[kd + c].to_f32()) * fx;
                        out[c] = T::from_f32(top + (bot - top) * fy);
                    }
                } else {
                    // Clamping `x0`, `y0` first leaves every tap where `at` puts it and keeps
                    // `x0 + 1` from overflowing (`x = inf` gives `x0 = isize::MAX`).
                    let (x0, y0) = (x0.clamp(-1, self.w as isize), y0.clamp(-1, self.h as isize));
                    for (c, o) in out.iter_mut().enumerate() {
                        let top = self.at(x0, y0, c) * (1.0 - fx) + self.at(x0 + 1, y0, c) * fx;
                        let bot =
                            self.at(x0, y0 + 1, c) * (1.0 - fx) + self.at(x0 + 1, y0 + 1, c) * fx;
                        *o = T::from_f32(top * (1.0 - fy) + bot * fy);
                    }
                }
            }
            Interp::Bicubic => {
                let (fx0, fy0) = (fast_floor(p[0]), fast_floor(p[1]));
                let (fx, fy) = ((p[0] - fx0) as f32, (p[1] - fy0) as f32);
                // Clamped as in the bilinear case: the taps `x0 - 1 ..= x0 + 2` stay the
                // same pixels and the offsets cannot overflow.
                let x0 = (fx0 as isize).clamp(-2, self.w as isize + 1);
                let y0 = (fy0 as isize).clamp(-2, self.h as isize + 1);
                let wx = [keys(fx + 1.0), keys(fx), keys(fx - 1.0), keys(fx - 2.0)];
                let wy = [keys(fy + 1.0), keys(fy), keys(fy - 1.0), keys(fy - 2.0)];
                for (c, o) in out.iter_mut().enumerate() {
                    let (mut acc, mut lo, mut hi) = (0.0f32, f32::INFINITY, f32::NEG_INFINITY);
                    for (j, wyj) in wy.iter().enumerate() {
                        let mut row = 0.0f32;
                        for (i, wxi) in wx.iter().enumerate() {
                            let v = self.at(x0 + i as isize - 1, y0 + j as isize - 1, c);
                            if (1..=2).contains(&i) && (1..=2).contains(&j) {
                                // Compares, not `f32::min` / `max`, whose pick between
                                // `-0.0` and `+0.0` is unspecified (LLVM may swap their
                                // operands): the first of equal taps stays, a `NaN` tap
                                // is skipped, as `vminps(v, lo)` / `vmaxps(v, hi)` do.
                                if v < lo {
                                    lo = v;
                                }
                                if v > hi {
                                    hi = v;
                                }
                            }
                            row += wxi * v;
                        }
                        acc += wyj * row;
                    }
                    *o = T::from_f32(acc.clamp(lo, hi));
                }
            }
        }
    }
}

/// The scalar pixel function `pixel` seen through a raw view of the samples (`as_bytes`,
/// `as_u16s` or `as_f32s`): how the vector paths compute the pixels they do not take.
fn scalar_pixels<'a, T: Texel, U: Copy + 'a, const NC: usize>(
    pixel: &'a impl Fn(&mut [T], &[f64; 2]),
    view: fn(&[T]) -> Option<&[U]>,
) -> impl Fn(&[f64; 2], &mut [U]) + 'a {
    move |p, dst| {
        let mut px = [T::from_f32(0.0); NC];
        pixel(&mut px, p);
        if let Some(b) = view(&px) {
            dst.copy_from_slice(b);
        }
    }
}

/// [`scalar_pixels`] for one channel, returning the sample.
fn scalar_gray<'a, T: Texel, U: Copy + Default + 'a>(
    pixel: &'a impl Fn(&mut [T], &[f64; 2]),
    view: fn(&[T]) -> Option<&[U]>,
) -> impl Fn(&[f64; 2]) -> U + 'a {
    move |p| {
        let mut px = [T::from_f32(0.0)];
        pixel(&mut px, p);
        view(&px).map_or(U::default(), |b| b[0])
    }
}

/// Fills `out` (`NC` channels per pixel) by sampling `src` at `pos` (`NaN`: background,
/// alpha 0). Monomorphized on the channel count, with the interpolation chosen once.
pub fn fill_pixels<T: Texel, const NC: usize>(
    src: &Source<'_, T>,
    pos: &[[f64; 2]],
    out: &mut [T],
    interp: Interp,
    background: f64,
) {
    fill_pixels_with::<T, NC>(src, pos, out, interp, background, |_, _| false);
}

/// [`fill_pixels`] with a hook for the pixels near the border: bilinear and bicubic
/// positions (not `NaN`) whose neighbourhood is not inside the image are first offered to
/// `beyond(p, px)`, which either writes the pixel and returns `true` or leaves it to the
/// clamped scalar sample. The vector paths compute only positions whose neighbourhood lies
/// inside the image and hand every other to the scalar closure, so `beyond` sees a superset
/// of the bilinear positions with `x < 0` or `x > w - 1` (or `y`), and of the bicubic ones
/// with `x < 1` or `x >= w - 2`: the edge modes ([`super::edge`]) need no second pass over
/// those. Nearest positions never reach it (the vector path clamps them itself).
pub(super) fn fill_pixels_with<T: Texel, const NC: usize>(
    src: &Source<'_, T>,
    pos: &[[f64; 2]],
    out: &mut [T],
    interp: Interp,
    background: f64,
    beyond: impl Fn(&[f64; 2], &mut [T]) -> bool,
) {
    debug_assert_eq!(src.nc, NC);
    let bg = T::from_f32(background as f32);
    let zero = T::from_f32(0.0);
    let has_alpha = NC == 2 || NC == 4;
    let outside = |px: &mut [T]| {
        px.fill(bg);
        if has_alpha {
            px[NC - 1] = zero;
        }
    };
    let (w, h) = (src.w, src.h);
    let d = src.data;
    match interp {
        Interp::Bilinear => {
            let pixel = |px: &mut [T], p: &[f64; 2]| {
                if p[0].is_nan() {
                    outside(px);
                    return;
                }
                let (fx0, fy0) = (fast_floor(p[0]), fast_floor(p[1]));
                let (x0, y0) = (fx0 as isize, fy0 as isize);
                if x0 >= 0 && y0 >= 0 && (x0 as usize) + 1 < w && (y0 as usize) + 1 < h {
                    let (fx, fy) = ((p[0] - fx0) as f32, (p[1] - fy0) as f32);
                    let k = (y0 as usize * w + x0 as usize) * NC;
                    let kd = k + w * NC;
                    let (top, bot) = (&d[k..k + 2 * NC], &d[kd..kd + 2 * NC]);
                    for c in 0..NC {
                        let (a, b) = (top[c].to_f32(), top[NC + c].to_f32());
                        let (e, f) = (bot[c].to_f32(), bot[NC + c].to_f32());
                        let t = a + (b - a) * fx;
                        let u = e + (f - e) * fx;
                        px[c] = T::from_f32(t + (u - t) * fy);
                    }
                } else if !beyond(p, px) {
                    src.sample_into(*p, Interp::Bilinear, px);
                }
            };
            if NC == 1 {
                if let (Some(d8), Some(o8)) = (T::as_bytes(d), T::as_bytes_mut(out)) {
                    let one = scalar_gray(&pixel, T::as_bytes);
                    if sample_simd512::bilinear_gray8(d8, w, h, pos, o8, one) {
                        return;
                    }
                }
                if let (Some(d16), Some(o16)) = (T::as_u16s(d), T::as_u16s_mut(out)) {
                    let one = scalar_gray(&pixel, T::as_u16s);
                    if sample_simd::bilinear_gray16(d16, w, h, pos, o16, one) {
                        return;
                    }
                }
            }
            if NC >= 2 {
                if let (Some(d8), Some(o8)) = (T::as_bytes(d), T::as_bytes_mut(out)) {
                    let one = scalar_pixels::<T, u8, NC>(&pixel, T::as_bytes);
                    if sample_simd_color::bilinear_color8::<NC>(d8, w, h, pos, o8, one) {
                        return;
                    }
                }
                if let (Some(d16), Some(o16)) = (T::as_u16s(d), T::as_u16s_mut(out)) {
                    let one = scalar_pixels::<T, u16, NC>(&pixel, T::as_u16s);
                    if sample_simd_color16::bilinear_color16::<NC>(d16, w, h, pos, o16, one) {
                        return;
                    }
                }
            }
            if let (Some(df), Some(of)) = (T::as_f32s(d), T::as_f32s_mut(out)) {
                let one = scalar_pixels::<T, f32, NC>(&pixel, T::as_f32s);
                if sample_simd_float::bilinear_f32::<NC>(df, w, h, pos, of, one) {
                    return;
                }
            }
            for (px, p) in out.chunks_exact_mut(NC).zip(pos) {
                pixel(px, p);
            }
        }
        Interp::Bicubic => {
            let pixel = |px: &mut [T], p: &[f64; 2]| {
                if p[0].is_nan() {
                    outside(px);
                } else if !beyond(p, px) {
                    src.sample_into(*p, Interp::Bicubic, px);
                }
            };
            if let (Some(d8), Some(o8)) = (T::as_bytes(d), T::as_bytes_mut(out)) {
                let one = scalar_pixels::<T, u8, NC>(&pixel, T::as_bytes);
                if sample_simd_cubic::bicubic8::<NC>(d8, w, h, pos, o8, one) {
                    return;
                }
            }
            if let (Some(d16), Some(o16)) = (T::as_u16s(d), T::as_u16s_mut(out)) {
                let one = scalar_pixels::<T, u16, NC>(&pixel, T::as_u16s);
                if sample_simd_cubic_wide::bicubic16::<NC>(d16, w, h, pos, o16, one) {
                    return;
                }
            }
            if let (Some(df), Some(of)) = (T::as_f32s(d), T::as_f32s_mut(out)) {
                let one = scalar_pixels::<T, f32, NC>(&pixel, T::as_f32s);
                if sample_simd_cubic_wide::bicubic_f32::<NC>(df, w, h, pos, of, one) {
                    return;
                }
            }
            for (px, p) in out.chunks_exact_mut(NC).zip(pos) {
                pixel(px, p);
            }
        }
        Interp::Nearest => {
            let pixel = |p: &[f64; 2], px: &mut [T]| {
                if p[0].is_nan() {
                    outside(px);
                } else {
                    src.sample_into(*p, Interp::Nearest, px);
                }
            };
            if sample_simd_nearest::nearest::<T, NC>(d, w, h, pos, out, pixel) {
                return;
            }
            for (px, p) in out.chunks_exact_mut(NC).zip(pos) {
                pixel(p, px);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::simd_harness::TestTexel;
    use super::*;

    #[test]
    fn bilinear_is_exact_at_centres_and_linear_between() {
        let data: Vec<u16> = (0..16).map(|v| v * 1000).collect(); // 4 x 4, one channel
        let s = Source { data: &data, w: 4, h: 4, nc: 1 };
        let mut o = [0u16];
        s.sample_into([2.0, 1.0], Interp::Bilinear, &mut o);
        assert_eq!(o[0], 6000);
        s.sample_into([2.5, 1.0], Interp::Bilinear, &mut o);
        assert_eq!(o[0], 6500);
        s.sample_into([3.0, 3.0], Interp::Bilinear, &mut o); // last pixel: clamped path
        assert_eq!(o[0], 15000);
        s.sample_into([1.0, 1.5], Interp::Bicubic, &mut o);
        assert_eq!(o[0], 7000);
        s.sample_into([0.6, 0.4], Interp::Nearest, &mut o);
        assert_eq!(o[0], 1000);
    }

    /// `fill_pixels` against `sample_into` (background and alpha 0 at `NaN`) bit for bit.
    fn check_fill<T: TestTexel, const NC: usize>(
        interp: Interp,
        data: &[T],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
    ) {
        let src = Source { data, w, h, nc: NC };
        let mut out = vec![T::from_f32(0.0); NC * pos.len()];
        fill_pixels::<T, NC>(&src, pos, &mut out, interp, 3.0);
        let mut want = [T::from_f32(0.0); NC];
        for (k, p) in pos.iter().enumerate() {
            if p[0].is_nan() {
                want.fill(T::from_f32(3.0));
                if NC.is_multiple_of(2) {
                    want[NC - 1] = T::from_f32(0.0);
                }
            } else {
                src.sample_into(*p, interp, &mut want);
            }
            let got: Vec<u32> = out[NC * k..NC * k + NC].iter().map(|&v| v.bits()).collect();
            assert_eq!(got, want.map(T::bits), "{interp:?} NC {NC}, {w}x{h} at {p:?}");
        }
    }

    /// Every sample type and channel count through `fill_pixels`, bilinear, bicubic and
    /// nearest, which takes the vector paths where the CPU has them: the same bits as the
    /// scalar path, for runs of inside, border, outside and `NaN` positions and every tail
    /// length.
    #[test]
    fn fill_pixels_is_bit_identical_to_the_scalar_path_for_every_type() {
        use super::super::simd_harness::{image, positions};
        use rand::rngs::SmallRng;
        use rand::SeedableRng;
        fn all<T: TestTexel, const NC: usize>(rng: &mut SmallRng) {
            for (w, h) in [(37usize, 23usize), (2, 2), (1, 9), (300, 5), (6, 5)] {
                let data = image::<T>(rng, NC * w * h, T::KINDS); // every kind mixed
                let pos = positions(rng, w, h, 1000);
                for interp in [Interp::Bilinear, Interp::Bicubic, Interp::Nearest] {
                    for len in (0..=17).chain([pos.len() - 3]) {
                        check_fill::<T, NC>(interp, &data, w, h, &pos[3..3 + len]);
                    }
                }
            }
        }
        let mut rng = SmallRng::seed_from_u64(18);
        let r = &mut rng;
        all::<u8, 1>(r);
        all::<u8, 2>(r);
        all::<u8, 3>(r);
        all::<u8, 4>(r);
        all::<u16, 1>(r);
        all::<u16, 2>(r);
        all::<u16, 3>(r);
        all::<u16, 4>(r);
        all::<f32, 1>(r);
        all::<f32, 2>(r);
        all::<f32, 3>(r);
        all::<f32, 4>(r);
    }

    #[test]
    fn rounding_and_clamping_of_integer_texels() {
        assert_eq!(u8::from_f32(254.6), 255);
        assert_eq!(u8::from_f32(300.0), 255);
        assert_eq!(u8::from_f32(-3.0), 0);
        assert_eq!(u16::from_f32(1.49), 1);
        assert_eq!(f32::from_f32(-3.5), -3.5);
    }
}
