//! Edge modes: what a sample reads where its interpolation support leaves the source image.
//!
//! A warp pulls the source back, `O(q) = I(phi^-1(q))`, and `phi^-1(q)` can lie outside the
//! source's pixels, inside the mesh or not. The three modes use scikit-image's names
//! (`skimage.transform.warp(..., mode=)`) and, for bilinear sampling, its values exactly:
//!
//! * [`EdgeMode::Constant`] (the default, as in scikit-image, ITK and elastix): the image is
//!   extended by the background value (every colour channel; alpha 0). A tap outside the
//!   pixels reads that value, so a sample within one pixel outside the image blends the edge
//!   pixel with the background, and one farther out is the background (with alpha 0).
//! * [`EdgeMode::Edge`]: taps are clamped to the nearest edge pixel (the edge pixels repeat;
//!   OpenCV's `BORDER_REPLICATE`; trimorph's behaviour before version 0.x made this a mode).
//! * [`EdgeMode::Reflect`]: the image is mirrored about its first and last pixel centres
//!   (`d c b | a b c d | c b a`, numpy's and scikit-image's `reflect`, OpenCV's
//!   `BORDER_REFLECT_101`): tap index `i` reads pixel `r(i)`, `r(i) = |i| mod 2(n - 1)`
//!   folded back into `[0, n - 1]`.
//!
//! In every mode, pixels whose preimage does not exist (outside the mesh) get the background.
//!
//! **How.** The samplers ([`super::sample::fill_pixels`], with their vector paths) clamp.
//! Their vector paths take only positions whose neighbourhood lies inside the image and hand
//! the others to a scalar closure, which offers them to a hook first; [`fill_pixels_mode`]'s
//! hook computes, with the scalar [`sample_mode`], each pixel whose support leaves the
//! image (nearest, whose vector path clamps by itself, is revisited after the samplers): bilinear `x < 0` or `x > w - 1` (or `y`), bicubic
//! `x < 1` or `x >= w - 2` (its taps `floor(x) - 1 ..= floor(x) + 2`), nearest
//! `round(x) < 0` or `round(x) > w - 1`. Every other pixel keeps the samplers' exact value,
//! so in [`EdgeMode::Edge`] nothing changes and elsewhere only a band along the image's
//! border costs more.

use super::sample::{fast_floor, fill_pixels, fill_pixels_with, keys, Source, Texel};
use super::Interp;

/// What taps outside the source image read (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum EdgeMode {
    /// The background value (alpha 0).
    #[default]
    Constant,
    /// The nearest edge pixel.
    Edge,
    /// The image mirrored about its first and last pixel centres.
    Reflect,
}

impl EdgeMode {
    /// The mode's name (`constant`, `edge`, `reflect`: scikit-image's).
    pub fn name(self) -> &'static str {
        match self {
            EdgeMode::Constant => "constant",
            EdgeMode::Edge => "edge",
            EdgeMode::Reflect => "reflect",
        }
    }
}

/// A mode name that is not `constant`, `edge` or `reflect`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown edge mode `{0}` (use constant, edge or reflect)")]
pub struct EdgeModeError(pub String);

impl std::str::FromStr for EdgeMode {
    type Err = EdgeModeError;
    fn from_str(s: &str) -> Result<EdgeMode, EdgeModeError> {
        match s.trim() {
            "constant" => Ok(EdgeMode::Constant),
            "edge" => Ok(EdgeMode::Edge),
            "reflect" => Ok(EdgeMode::Reflect),
            other => Err(EdgeModeError(other.to_string())),
        }
    }
}

/// Pixel index `i` mirrored into `0 .. n` about the first and last pixel centres.
///
/// ```
/// use trimorph::warp::edge::reflect_index;
/// let r: Vec<isize> = (-3..7).map(|i| reflect_index(i, 4)).collect();
/// assert_eq!(r, [3, 2, 1, 0, 1, 2, 3, 2, 1, 0]);
/// assert_eq!(reflect_index(-5, 1), 0);
/// ```
pub fn reflect_index(i: isize, n: usize) -> isize {
    if n <= 1 {
        return 0;
    }
    let period = 2 * (n as isize - 1);
    let m = i.rem_euclid(period);
    if m > n as isize - 1 {
        period - m
    } else {
        m
    }
}

/// Whether a sample at `p` reads taps outside a `w x h` image (module docs).
#[inline]
fn leaves(p: [f64; 2], interp: Interp, w: usize, h: usize) -> bool {
    let (wm, hm) = (w as f64 - 1.0, h as f64 - 1.0);
    match interp {
        Interp::Bilinear => p[0] < 0.0 || p[1] < 0.0 || p[0] > wm || p[1] > hm,
        Interp::Bicubic => p[0] < 1.0 || p[1] < 1.0 || p[0] >= wm - 1.0 || p[1] >= hm - 1.0,
        Interp::Nearest => {
            let (x, y) = (p[0].round(), p[1].round());
            x < 0.0 || y < 0.0 || x > wm || y > hm
        }
    }
}

/// One sample at `p` (not `NaN`) with the taps of `mode` (module docs), into `out`
/// (`src.nc` channels); `background` is the constant mode's value (alpha 0).
pub fn sample_mode<T: Texel>(
    src: &Source<'_, T>,
    p: [f64; 2],
    interp: Interp,
    mode: EdgeMode,
    background: f64,
    out: &mut [T],
) {
    if mode == EdgeMode::Edge {
        src.sample_into(p, interp, out);
        return;
    }
    let nc = src.nc;
    let alpha = nc == 2 || nc == 4;
    let bg = background as f32;
    let fill_bg = |out: &mut [T]| {
        for (c, o) in out.iter_mut().enumerate() {
            *o = T::from_f32(if alpha && c == nc - 1 { 0.0 } else { bg });
        }
    };
    // Positions beyond every tap's reach (or not finite) read only the background; the
    // mirror is periodic, so a far position is first moved by whole periods `2(n - 1)`.
    let far = |v: f64, n: usize| !(v > -3.0 && v < n as f64 + 2.0);
    let period = |n: usize| 2.0 * (n.max(2) - 1) as f64;
    let p = match mode {
        _ if !(p[0].is_finite() && p[1].is_finite()) => return fill_bg(out),
        EdgeMode::Constant if far(p[0], src.w) || far(p[1], src.h) => return fill_bg(out),
        EdgeMode::Reflect => [
            if far(p[0], src.w) { p[0].rem_euclid(period(src.w)) } else { p[0] },
            if far(p[1], src.h) { p[1].rem_euclid(period(src.h)) } else { p[1] },
        ],
        _ => p,
    };
    // Tap (x, y) of channel c: the pixel, the background, or the mirrored pixel.
    let tap = |x: isize, y: isize, c: usize| -> f32 {
        let inside = x >= 0 && y >= 0 && (x as usize) < src.w && (y as usize) < src.h;
        let (x, y) = match (inside, mode) {
            (true, _) => (x as usize, y as usize),
            (false, EdgeMode::Reflect) => {
                (reflect_index(x, src.w) as usize, reflect_index(y, src.h) as usize)
            }
            (false, _) => return if alpha && c == nc - 1 { 0.0 } else { bg },
        };
        src.data[(y * src.w + x) * nc + c].to_f32()
    };
    // Positions are now within a few pixels of the image; the clamp only guards the
    // `isize` arithmetic.
    let clamp_i = |v: f64, n: usize| -> isize {
        let lim = 4 * n as isize + 8;
        if v.is_finite() {
            (v as isize).clamp(-lim, lim)
        } else if v > 0.0 {
            lim
        } else {
            -lim
        }
    };
    match interp {
        Interp::Nearest => {
            let (x, y) = (clamp_i(p[0].round(), src.w), clamp_i(p[1].round(), src.h));
            for (c, o) in out.iter_mut().enumerate() {
                *o = T::from_f32(tap(x, y, c));
            }
        }
        Interp::Bilinear => {
            let (fx0, fy0) = (fast_floor(p[0]), fast_floor(p[1]));
            let (fx, fy) = ((p[0] - fx0) as f32, (p[1] - fy0) as f32);
            let (x0, y0) = (clamp_i(fx0, src.w), clamp_i(fy0, src.h));
            for (c, o) in out.iter_mut().enumerate() {
                let (a, b) = (tap(x0, y0, c), tap(x0 + 1, y0, c));
                let (e, f) = (tap(x0, y0 + 1, c), tap(x0 + 1, y0 + 1, c));
                let t = a + (b - a) * fx;
                let u = e + (f - e) * fx;
                *o = T::from_f32(t + (u - t) * fy);
            }
        }
        Interp::Bicubic => {
            let (fx0, fy0) = (fast_floor(p[0]), fast_floor(p[1]));
            let (fx, fy) = ((p[0] - fx0) as f32, (p[1] - fy0) as f32);
            let (x0, y0) = (clamp_i(fx0, src.w), clamp_i(fy0, src.h));
            let wx = [keys(fx + 1.0), keys(fx), keys(fx - 1.0), keys(fx - 2.0)];
            let wy = [keys(fy + 1.0), keys(fy), keys(fy - 1.0), keys(fy - 2.0)];
            for (c, o) in out.iter_mut().enumerate() {
                let (mut acc, mut lo, mut hi) = (0.0f32, f32::INFINITY, f32::NEG_INFINITY);
                for (j, wyj) in wy.iter().enumerate() {
                    let mut row = 0.0f32;
                    for (i, wxi) in wx.iter().enumerate() {
                        let v = tap(x0 + i as isize - 1, y0 + j as isize - 1, c);
                        if (1..=2).contains(&i) && (1..=2).contains(&j) {
                            lo = lo.min(v);
                            hi = hi.max(v);
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

/// [`fill_pixels`] with taps outside the image read as `mode` says (module docs): the
/// samplers' values where the support lies inside the image, [`sample_mode`] where it
/// leaves it, the background (alpha 0) for a `NaN` position.
pub fn fill_pixels_mode<T: Texel, const NC: usize>(
    src: &Source<'_, T>,
    pos: &[[f64; 2]],
    out: &mut [T],
    interp: Interp,
    background: f64,
    mode: EdgeMode,
) {
    if mode == EdgeMode::Edge {
        return fill_pixels::<T, NC>(src, pos, out, interp, background);
    }
    // Bilinear and bicubic: the samplers offer every border position to the hook, so the
    // pixels whose support leaves the image are done once, in the mode.
    let beyond = |p: &[f64; 2], px: &mut [T]| {
        let out = leaves(*p, interp, src.w, src.h);
        if out {
            sample_mode(src, *p, interp, mode, background, px);
        }
        out
    };
    fill_pixels_with::<T, NC>(src, pos, out, interp, background, beyond);
    if interp != Interp::Nearest {
        return;
    }
    // Nearest: the vector path clamps by itself, so the pixels are revisited.
    for (p, px) in pos.iter().zip(out.chunks_exact_mut(NC)) {
        if !p[0].is_nan() && leaves(*p, interp, src.w, src.h) {
            sample_mode(src, *p, interp, mode, background, px);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::simd_harness::{image, positions, TestTexel};
    use super::*;
    use rand::rngs::SmallRng;
    use rand::SeedableRng;

    fn img() -> (Vec<u8>, usize, usize) {
        // 4 x 3, values 10 * (y * 4 + x) + 10.
        ((0..12).map(|k| 10 * k as u8 + 10).collect(), 4, 3)
    }

    #[test]
    fn constant_blends_the_edge_pixel_with_the_background_then_is_the_background() {
        let (d, w, h) = img();
        let s = Source { data: &d, w, h, nc: 1 };
        let pos = [[-0.5, 0.0], [-1.0, 0.0], [3.25, 1.0], [4.0, 1.0], [1.0, 1.0], [f64::NAN, 0.0]];
        let mut out = [0u8; 6];
        fill_pixels_mode::<u8, 1>(&s, &pos, &mut out, Interp::Bilinear, 200.0, EdgeMode::Constant);
        // Pixel (0, 0) = 10 halfway to 200; 200 at one pixel out; (3, 1) = 80 a quarter of
        // the way to 200; inside unchanged; no preimage: background.
        assert_eq!(out, [105, 200, 110, 200, 60, 200]);
        fill_pixels_mode::<u8, 1>(&s, &pos, &mut out, Interp::Bilinear, 200.0, EdgeMode::Edge);
        assert_eq!(out, [10, 10, 80, 80, 60, 200]);
    }

    #[test]
    fn reflect_mirrors_about_the_edge_pixel_centres() {
        let (d, w, h) = img();
        let s = Source { data: &d, w, h, nc: 1 };
        // x = -1 reads pixel 1; x = 4 reads pixel 2; y = -1 reads row 1; x = -0.5 is the
        // mean of pixels 1 and 0.
        let pos = [[-1.0, 0.0], [4.0, 0.0], [0.0, -1.0], [-0.5, 0.0], [-7.0, 0.0]];
        let mut out = [0u8; 5];
        fill_pixels_mode::<u8, 1>(&s, &pos, &mut out, Interp::Bilinear, 0.0, EdgeMode::Reflect);
        assert_eq!(out, [20, 30, 50, 15, 20]);
        let mut near = [0u8; 5];
        fill_pixels_mode::<u8, 1>(&s, &pos, &mut near, Interp::Nearest, 0.0, EdgeMode::Reflect);
        // Nearest rounds half away from zero: -0.5 -> -1 -> pixel 1.
        assert_eq!(near, [20, 30, 50, 20, 20]);
    }

    #[test]
    fn alpha_is_zero_in_the_constant_extension() {
        let d: Vec<u8> = vec![100, 255, 100, 255, 100, 255, 100, 255];
        let s = Source { data: &d, w: 2, h: 2, nc: 2 };
        let mut out = [0u8; 4];
        let pos = [[-0.5, 0.5], [-3.0, 0.0]];
        fill_pixels_mode::<u8, 2>(&s, &pos, &mut out, Interp::Bilinear, 0.0, EdgeMode::Constant);
        assert_eq!(out, [50, 128, 0, 0]);
    }

    #[test]
    fn far_and_infinite_positions_do_not_overflow() {
        let (d, w, h) = img();
        let s = Source { data: &d, w, h, nc: 1 };
        let pos = [[1e300, 0.0], [-1e300, 1.0], [f64::INFINITY, 0.0], [f64::NEG_INFINITY, 2.0]];
        for mode in [EdgeMode::Constant, EdgeMode::Reflect, EdgeMode::Edge] {
            for interp in [Interp::Nearest, Interp::Bilinear, Interp::Bicubic] {
                let mut out = [0u8; 4];
                fill_pixels_mode::<u8, 1>(&s, &pos, &mut out, interp, 7.0, mode);
                match mode {
                    EdgeMode::Constant => assert_eq!(out, [7; 4], "{interp:?}"),
                    // Not finite: no mirror position either.
                    EdgeMode::Reflect => assert_eq!(out[2..], [7; 2], "{interp:?}"),
                    EdgeMode::Edge => {}
                }
            }
        }
    }

    #[test]
    fn inside_the_image_every_mode_is_the_sampler() {
        let d: Vec<u8> = (0..36).map(|k| (k * 37 % 251) as u8).collect();
        let s = Source { data: &d, w: 6, h: 6, nc: 1 };
        // Bicubic taps of x in [1, 3) are pixels 0..=4 of 6: inside.
        let pos: Vec<[f64; 2]> =
            (0..40).map(|k| [1.0 + 0.05 * k as f64, 1.0 + (0.07 * k as f64) % 1.9]).collect();
        for interp in [Interp::Nearest, Interp::Bilinear, Interp::Bicubic] {
            let mut want = vec![0u8; 40];
            fill_pixels::<u8, 1>(&s, &pos, &mut want, interp, 0.0);
            for mode in [EdgeMode::Constant, EdgeMode::Reflect] {
                let mut got = vec![0u8; 40];
                fill_pixels_mode::<u8, 1>(&s, &pos, &mut got, interp, 0.0, mode);
                assert_eq!(got, want, "{interp:?} {mode:?}");
            }
        }
    }

    /// The old two passes: every sampler clamps, then each pixel whose support leaves the
    /// image is recomputed in the mode.
    fn two_passes<T: Texel, const NC: usize>(
        src: &Source<'_, T>,
        pos: &[[f64; 2]],
        out: &mut [T],
        interp: Interp,
        background: f64,
        mode: EdgeMode,
    ) {
        fill_pixels::<T, NC>(src, pos, out, interp, background);
        for (p, px) in pos.iter().zip(out.chunks_exact_mut(NC)) {
            if !p[0].is_nan() && leaves(*p, interp, src.w, src.h) {
                sample_mode(src, *p, interp, mode, background, px);
            }
        }
    }

    fn fused_equals_two_passes<T: TestTexel, const NC: usize>(seed: u64) {
        let mut rng = SmallRng::seed_from_u64(seed);
        for (w, h) in [(37, 29), (5, 4), (64, 3)] {
            let data: Vec<T> = image(&mut rng, w * h * NC, T::KINDS);
            let src = Source { data: &data, w, h, nc: NC };
            let pos = positions(&mut rng, w, h, 3000);
            for interp in [Interp::Nearest, Interp::Bilinear, Interp::Bicubic] {
                for mode in [EdgeMode::Constant, EdgeMode::Reflect] {
                    let mut want = vec![T::from_f32(0.0); NC * pos.len()];
                    two_passes::<T, NC>(&src, &pos, &mut want, interp, 9.0, mode);
                    let mut got = vec![T::from_f32(0.0); NC * pos.len()];
                    fill_pixels_mode::<T, NC>(&src, &pos, &mut got, interp, 9.0, mode);
                    let bits = |v: &[T]| v.iter().map(|x| x.bits()).collect::<Vec<u32>>();
                    assert_eq!(bits(&got), bits(&want), "{w}x{h} NC {NC} {interp:?} {mode:?}");
                }
            }
        }
    }

    /// The border pixels are done once, through the samplers' hook, with the vector paths on
    /// (where the CPU has them): the same bits as sampling everything clamped and then
    /// recomputing each pixel whose support leaves the image.
    #[test]
    fn the_hook_equals_the_second_pass_bit_for_bit() {
        fused_equals_two_passes::<u8, 1>(1);
        fused_equals_two_passes::<u8, 2>(2);
        fused_equals_two_passes::<u8, 3>(3);
        fused_equals_two_passes::<u8, 4>(4);
        fused_equals_two_passes::<u16, 1>(5);
        fused_equals_two_passes::<u16, 3>(6);
        fused_equals_two_passes::<u16, 4>(7);
        fused_equals_two_passes::<f32, 1>(8);
        fused_equals_two_passes::<f32, 2>(9);
        fused_equals_two_passes::<f32, 4>(10);
    }

    #[test]
    fn names_parse_back() {
        for m in [EdgeMode::Constant, EdgeMode::Edge, EdgeMode::Reflect] {
            assert_eq!(m.name().parse::<EdgeMode>(), Ok(m));
        }
        assert!("wrap".parse::<EdgeMode>().unwrap_err().to_string().contains("constant"));
    }
}
