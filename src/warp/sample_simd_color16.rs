//! Bilinear resampling of 16-bit gray + alpha, RGB and RGBA images (x86_64 AVX2): gray +
//! alpha eight pixels per vector and channel, RGB and RGBA two pixels per vector.
//!
//! The scalar path ([`super::sample::fill_pixels`]) computes, for each channel `c` of a
//! position `(x, y)` with `x0 = floor(x)`, `y0 = floor(y)`, `fx = (x - x0) as f32`,
//! `fy = (y - y0) as f32` and the taps `a = I(x0, y0)[c]`, `b = I(x0 + 1, y0)[c]`,
//! `e = I(x0, y0 + 1)[c]`, `f = I(x0 + 1, y0 + 1)[c]`:
//!
//! ```text
//!   t = a + (b - a) fx,   u = e + (f - e) fx,   v = t + (u - t) fy,
//!   out = trunc(clamp(v + 0.5, 0, 65535))
//! ```
//!
//! in `f32`, each operation rounded (no fused multiply-add). The vector path does the same
//! operations in the same order, one `f32` lane per channel (16-bit samples are exact in
//! `f32`): for gray + alpha one vector holds channel 0 of eight pixels and another their
//! channel 1; for RGB and RGBA a 256-bit vector holds two pixels of four lanes each (RGB:
//! the fourth lane is zero and its result dropped). The floors and fractions are computed
//! eight (RGB, RGBA: four) positions at a time in `f64` (`vroundpd`, exact subtraction, one
//! rounding to `f32` as `as f32` does), the final conversion by truncation, so the output
//! is bit-identical to the scalar path's.
//!
//! **Taps.** With `k = y0 w + x0` (the image is `w x h`, `NC` = 2, 3 or 4 samples per pixel,
//! row-major, `NC w h` samples), the taps `a, b` are the `2 NC` samples from `NC k` and
//! `e, f` the `2 NC` samples from `NC (k + w)`. Offsets below are in samples (two bytes):
//!
//! * gray + alpha: each lane gathers the 32-bit words (one pixel each) at samples `2 k`
//!   (`a`), `2 k + 2` (`b`), `2 (k + w)` (`e`) and `2 (k + w) + 2` (`f`); the last sample
//!   read is `2 (k + w) + 3 <= 2 ((h - 2) w + (w - 2) + w) + 3 = 2 h w - 1`.
//! * RGBA: each pixel loads eight samples from `4 k` and from `4 (k + w)`; the last sample
//!   read is `4 (k + w) + 7 <= 4 ((h - 2) w + (w - 2) + w) + 7 = 4 h w - 1`.
//! * RGB: each pixel loads eight samples from `3 k` (taps in samples 0..6) and from
//!   `3 (k + w) - 2` (taps in samples 2..8), so that the bottom load ends on the last tap:
//!   `3 (k + w) + 5 <= 3 h w - 1`; it starts at `3 (k + w) - 2 >= 3 w - 2 >= 4`, and the top
//!   load ends at `3 k + 7 <= 3 ((h - 2) w + w - 2) + 7 = 3 (h - 1) w + 1 <= 3 h w - 1`
//!   (`w >= 2`).
//!
//! for every lane with `0 <= x0 <= w - 2` and `0 <= y0 <= h - 2` (so `w, h >= 2`). A group
//! of eight (RGB, RGBA: four) positions is taken on the vector path only when all its lanes
//! pass; any other group (outside the mesh, `NaN`, a neighbourhood across the image border)
//! and the tail are done pixel by pixel by the scalar path. Out-of-range and `NaN`
//! coordinates convert to `i32::MIN` and so fail the test.

#[cfg(target_arch = "x86_64")]
use super::sample_simd::avx2_fits;

/// Fills the `NC`-sample pixels `out[NC i ..]` for every position `pos[i]`
/// (`i < min(pos.len(), out.len() / NC)`) of a `w x h` image `data` (`NC` = 2, 3 or 4
/// interleaved 16-bit channels) by bilinear interpolation, with `scalar(p, px)` writing the
/// pixels the vector path does not take. Returns `false` (and writes nothing) when the
/// vector path is not available: not x86_64, no AVX2, `NC` not 2, 3 or 4, or an image too
/// large for 32-bit offsets.
pub(super) fn bilinear_color16<const NC: usize>(
    data: &[u16],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [u16],
    scalar: impl Fn(&[f64; 2], &mut [u16]),
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if (2..=4).contains(&NC) && avx2_fits(data.len(), w, h, NC) {
        if NC == 2 {
            // SAFETY: AVX2 is available and `data` holds at least `2 w h < 2^31` samples
            // (`avx2_fits`), as `avx2::bilinear_la16` requires.
            unsafe { avx2::bilinear_la16(data, w, h, pos, out, &scalar) };
        } else {
            // SAFETY: `NC` is 3 or 4 (checked just above); AVX2 is available and `data`
            // holds at least `NC w h < 2^31` samples (`avx2_fits`), as
            // `avx2::bilinear_color16` requires.
            unsafe { avx2::bilinear_color16::<NC>(data, w, h, pos, out, &scalar) };
        }
        return true;
    }
    let _ = (data, w, h, pos, out, scalar);
    false
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use crate::warp::sample_simd::avx2::{bilerp, lanes4, lanes8, round_clamp};
    use std::arch::x86_64::*;

    /// Zero byte for `_mm_shuffle_epi8`.
    const Z: i8 = -128;

    /// See [`super::bilinear_color16`] with `NC = 2`: eight positions at a time, one vector
    /// per channel.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= 2 w h` and `2 w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bilinear_la16(
        data: &[u16],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u16],
        scalar: &impl Fn(&[f64; 2], &mut [u16]),
    ) {
        let n = pos.len().min(out.len() / 2);
        let groups = n / 8;
        // Lane bounds as in the module docs; -1 when w or h is 1 (every lane rejected).
        let xmax = _mm256_set1_epi32(w as i32 - 2);
        let ymax = _mm256_set1_epi32(h as i32 - 2);
        let wv = _mm256_set1_epi32(w as i32);
        let one = _mm256_set1_epi32(1);
        let low = _mm256_set1_epi32(0xffff);
        let top = _mm256_set1_ps(65535.0);
        let base = data.as_ptr() as *const i32;
        for g in 0..groups {
            let i = 8 * g;
            // SAFETY: i + 8 <= n <= pos.len(): 16 f64 for 8 contiguous positions.
            let (x0, y0, ok, fx, fy) = lanes8(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if _mm256_movemask_ps(_mm256_castsi256_ps(ok)) != 0xff {
                for k in i..i + 8 {
                    scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
                }
                continue;
            }
            let k = _mm256_add_epi32(_mm256_mullo_epi32(y0, wv), x0);
            let kd = _mm256_add_epi32(k, wv);
            // SAFETY: every lane passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2; the words read
            // (one pixel each, pixel indices k, k + 1, k + w, k + w + 1) are samples
            // 2 k .. 2 k + 3 and 2 (k + w) .. 2 (k + w) + 3, inside 0 .. 2 w h <= data.len()
            // by the bounds in the module docs; byte offsets 4 x the pixel index (scale 4),
            // k + w + 1 < w h < 2^31.
            let wa = _mm256_i32gather_epi32::<4>(base, k);
            let wb = _mm256_i32gather_epi32::<4>(base, _mm256_add_epi32(k, one));
            let we = _mm256_i32gather_epi32::<4>(base, kd);
            let wf = _mm256_i32gather_epi32::<4>(base, _mm256_add_epi32(kd, one));
            // Word [c0 c1]: channel 0 in the low half, channel 1 in the high half.
            let c0 = |x: __m256i| _mm256_cvtepi32_ps(_mm256_and_si256(x, low));
            let c1 = |x: __m256i| _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(x));
            let v0 = bilerp(c0(wa), c0(wb), c0(we), c0(wf), fx, fy);
            let v1 = bilerp(c1(wa), c1(wb), c1(we), c1(wf), fx, fy);
            // Per lane the pixel's two samples as one 32-bit word.
            let r = _mm256_or_si256(
                round_clamp(v0, top),
                _mm256_slli_epi32::<16>(round_clamp(v1, top)),
            );
            // SAFETY: i + 8 <= n <= out.len() / 2: sixteen u16 writable at out[2 i..];
            // unaligned.
            _mm256_storeu_si256(out.as_mut_ptr().add(2 * i) as *mut __m256i, r);
        }
        for k in 8 * groups..n {
            scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
        }
    }

    /// See [`super::bilinear_color16`] with `NC` = 3 or 4: four positions at a time, two
    /// pixels per vector.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `NC` is 3 or 4; `data.len() >= NC w h` and `NC w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bilinear_color16<const NC: usize>(
        data: &[u16],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u16],
        scalar: &impl Fn(&[f64; 2], &mut [u16]),
    ) {
        let n = pos.len().min(out.len() / NC);
        let groups = n / 4;
        // Lane bounds as in the module docs; -1 when w or h is 1 (every lane rejected).
        let xmax = _mm_set1_epi32(w as i32 - 2);
        let ymax = _mm_set1_epi32(h as i32 - 2);
        let wv = _mm_set1_epi32(w as i32);
        // The eight samples of one pixel's row load are shuffled to [a | b], four samples
        // per tap (RGB: the fourth zero).
        let (sh_top, sh_bot, below) = if NC == 4 {
            let s = _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
            (s, s, 0isize)
        } else {
            (
                _mm_setr_epi8(0, 1, 2, 3, 4, 5, Z, Z, 6, 7, 8, 9, 10, 11, Z, Z),
                _mm_setr_epi8(4, 5, 6, 7, 8, 9, Z, Z, 10, 11, 12, 13, 14, 15, Z, Z),
                -2isize,
            )
        };
        let top = _mm256_set1_ps(65535.0);
        let spread =
            [_mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1), _mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3)];
        let base = data.as_ptr();
        let mut ks = [0i32; 4];
        let mut px = [0u16; 8];
        for g in 0..groups {
            let i = 4 * g;
            // SAFETY: i + 4 <= n <= pos.len(): 8 contiguous f64.
            let (x0, y0, ok, fx4, fy4) = lanes4(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if _mm_movemask_ps(_mm_castsi128_ps(ok)) != 0xf {
                for k in i..i + 4 {
                    scalar(&pos[k], &mut out[NC * k..NC * k + NC]);
                }
                continue;
            }
            let (fx4, fy4) = (_mm256_castps128_ps256(fx4), _mm256_castps128_ps256(fy4));
            // SAFETY: `ks` is four i32; unaligned store.
            _mm_storeu_si128(
                ks.as_mut_ptr() as *mut __m128i,
                _mm_add_epi32(_mm_mullo_epi32(y0, wv), x0),
            );
            for (pair, idx) in spread.iter().enumerate() {
                let (k0, k1) = (ks[2 * pair] as isize, ks[2 * pair + 1] as isize);
                let nc = NC as isize;
                let w = w as isize;
                // SAFETY: both lanes passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2 (so
                // 0 <= k < w h - w); the eight samples read from NC k and from
                // NC (k + w) + below lie inside 0 .. NC w h <= data.len() by the bounds in
                // the module docs; unaligned 128-bit loads.
                let rd = |o: isize| _mm_loadu_si128(base.offset(o) as *const __m128i);
                let t0 = _mm_shuffle_epi8(rd(nc * k0), sh_top);
                let t1 = _mm_shuffle_epi8(rd(nc * k1), sh_top);
                let b0 = _mm_shuffle_epi8(rd(nc * (k0 + w) + below), sh_bot);
                let b1 = _mm_shuffle_epi8(rd(nc * (k1 + w) + below), sh_bot);
                // [a0 | a1], [b0 | b1], [e0 | e1], [f0 | f1]: four u16 per pixel, widened.
                let cv = |x: __m128i| _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(x));
                let a = cv(_mm_unpacklo_epi64(t0, t1));
                let b = cv(_mm_unpackhi_epi64(t0, t1));
                let e = cv(_mm_unpacklo_epi64(b0, b1));
                let f = cv(_mm_unpackhi_epi64(b0, b1));
                let fx = _mm256_permutevar8x32_ps(fx4, *idx);
                let fy = _mm256_permutevar8x32_ps(fy4, *idx);
                let r = round_clamp(bilerp(a, b, e, f, fx, fy), top);
                // 8 x i32 in 0..=65535 -> u16: per 128-bit lane the pixel's four samples in
                // the low 64 bits; gathered into the low 128 bits, [pixel 0 | pixel 1].
                let r16 = _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_packus_epi32(r, r));
                // SAFETY: `px` is eight u16; unaligned store.
                _mm_storeu_si128(px.as_mut_ptr() as *mut __m128i, _mm256_castsi256_si128(r16));
                let j = NC * (i + 2 * pair);
                out[j..j + NC].copy_from_slice(&px[..NC]);
                out[j + NC..j + 2 * NC].copy_from_slice(&px[4..4 + NC]);
            }
        }
        for k in 4 * groups..n {
            scalar(&pos[k], &mut out[NC * k..NC * k + NC]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp::simd_harness::{self as harness, bit_identity_proptest, family};
    use crate::warp::Interp::Bilinear;

    family!(Color16, u16, bilinear_color16);

    #[test]
    fn la16_rgb16_and_rgba16_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<u16, Color16>(Bilinear, &[2, 3, 4], 48, 2000);
    }

    /// Signed zeros, ties, the border, infinities and `NaN` in either coordinate.
    #[test]
    fn special_positions_match_the_scalar_path() {
        harness::special::<u16, Color16>(Bilinear, &[2, 3, 4], 49);
    }

    /// The loads end exactly on the last sample of the image (module docs).
    #[test]
    fn loads_at_the_bottom_right_cell_stay_inside_the_image() {
        harness::bottom_right::<u16, Color16>(Bilinear, &[2, 3, 4]);
    }

    /// Groups of eight (gray + alpha) and four (RGB, RGBA).
    #[test]
    fn interior_groups_take_the_vector_path() {
        harness::assert_vectorized::<u16, Color16>(Bilinear, &[2, 3, 4]);
    }

    bit_identity_proptest!(
        color16_bit_identical_on_random_images,
        u16,
        Color16,
        Bilinear,
        [2, 3, 4],
        "Random 16-bit gray + alpha, RGB and RGBA images (extreme values included) and \
         random positions, borders and outside included."
    );
}
