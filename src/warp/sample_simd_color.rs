//! Bilinear resampling of 8-bit gray + alpha, RGB and RGBA images (x86_64 AVX2): RGB and
//! RGBA two pixels per vector, gray + alpha eight pixels per vector and channel.
//!
//! The scalar path ([`super::sample::fill_pixels`]) computes, for each channel `c` of a
//! position `(x, y)` with `x0 = floor(x)`, `y0 = floor(y)`, `fx = (x - x0) as f32`,
//! `fy = (y - y0) as f32` and the taps `a = I(x0, y0)[c]`, `b = I(x0 + 1, y0)[c]`,
//! `e = I(x0, y0 + 1)[c]`, `f = I(x0 + 1, y0 + 1)[c]`:
//!
//! ```text
//!   t = a + (b - a) fx,   u = e + (f - e) fx,   v = t + (u - t) fy,
//!   out = trunc(clamp(v + 0.5, 0, 255))
//! ```
//!
//! in `f32`, each operation rounded (no fused multiply-add). The vector path does the same
//! operations in the same order, one `f32` lane per channel: for RGB and RGBA a 256-bit
//! vector holds two pixels of four lanes each (RGB: the fourth lane is zero and its result
//! dropped); for gray + alpha one vector holds channel 0 of eight pixels and another their
//! channel 1. The floors and fractions are computed four (gray + alpha: eight) positions at
//! a time in `f64` (`vroundpd`, exact subtraction, one rounding to `f32` as `as f32` does),
//! so the output is bit-identical to the scalar path's.
//!
//! **Taps.** With `k = y0 w + x0` (the image is `w x h`, `NC` = 2, 3 or 4 bytes per pixel,
//! row-major, `n = NC w h` bytes), the taps `a, b` are the `2 NC` bytes from `NC k` and
//! `e, f` the `2 NC` bytes from `NC (k + w)`. RGB and RGBA load eight bytes of each row per
//! pixel, gray + alpha gathers four:
//!
//! * gray + alpha (`NC` = 2): each lane gathers the 32-bit word at byte `2 k` (`a, b`) and the
//!   word at byte `2 (k + w)` (`e, f`); the last byte read is
//!   `2 (k + w) + 3 <= 2 ((h - 2) w + (w - 2) + w) + 3 = 2 h w - 1`.
//! * RGBA: from `4 k` and from `4 (k + w)`; the last byte read is
//!   `4 (k + w) + 7 <= 4 ((h - 2) w + (w - 2) + w) + 7 = 4 h w - 1`.
//! * RGB: from `3 k` (taps in bytes 0..6) and from `3 (k + w) - 2` (taps in bytes 2..8), so
//!   that the bottom load ends on the last tap: `3 (k + w) + 5 <= 3 h w - 1`; it starts at
//!   `3 (k + w) - 2 >= 3 w - 2 >= 4`, and the top load ends at
//!   `3 k + 7 <= 3 ((h - 2) w + w - 2) + 7 = 3 (h - 1) w + 1 <= 3 h w - 1` (`w >= 2`).
//!
//! for every lane with `0 <= x0 <= w - 2` and `0 <= y0 <= h - 2` (so `w, h >= 2`). A group
//! of four (gray + alpha: eight) positions is taken on the vector path only when all its
//! lanes pass; any other group (outside the mesh, `NaN`, a neighbourhood across the image
//! border) and the tail of fewer than four (eight) are done pixel by pixel by the scalar
//! path.

#[cfg(target_arch = "x86_64")]
use super::sample_simd::avx2_fits;

/// Fills the `NC`-byte pixels `out[NC i ..]` for every position `pos[i]`
/// (`i < min(pos.len(), out.len() / NC)`) of a `w x h` image `data` (`NC` = 2, 3 or 4
/// interleaved 8-bit channels) by bilinear interpolation, with `scalar(p, px)` writing the
/// pixels the vector path does not take. Returns `false` (and writes nothing) when the
/// vector path is not available: not x86_64, no AVX2, `NC` not 2, 3 or 4, or an image too
/// large for 32-bit offsets.
pub(super) fn bilinear_color8<const NC: usize>(
    data: &[u8],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [u8],
    scalar: impl Fn(&[f64; 2], &mut [u8]),
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if (2..=4).contains(&NC) && avx2_fits(data.len(), w, h, NC) {
        if NC == 2 {
            // SAFETY: AVX2 is available and `data` holds at least `2 w h < 2^31` bytes
            // (`avx2_fits`), as `avx2::bilinear_la8` requires.
            unsafe { avx2::bilinear_la8(data, w, h, pos, out, &scalar) };
        } else {
            // SAFETY: `NC` is 3 or 4 (checked just above); AVX2 is available and `data`
            // holds at least `NC w h < 2^31` bytes (`avx2_fits`), as `avx2::bilinear_color8`
            // requires.
            unsafe { avx2::bilinear_color8::<NC>(data, w, h, pos, out, &scalar) };
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

    /// See [`super::bilinear_color8`].
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `NC` is 3 or 4; `data.len() >= NC w h` and `NC w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bilinear_color8<const NC: usize>(
        data: &[u8],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u8],
        scalar: &impl Fn(&[f64; 2], &mut [u8]),
    ) {
        let n = pos.len().min(out.len() / NC);
        let groups = n / 4;
        // Lane bounds as in the module docs; -1 when w or h is 1 (every lane rejected).
        let xmax = _mm_set1_epi32(w as i32 - 2);
        let ymax = _mm_set1_epi32(h as i32 - 2);
        let wv = _mm_set1_epi32(w as i32);
        // Per pair of pixels (p, p'), the 16 bytes [p's 8 | p''s 8] of one row are shuffled
        // to [a_p a_p' | b_p b_p'], four bytes per tap (RGB: the fourth zero).
        let (sh_top, sh_bot, below) = if NC == 4 {
            let s = _mm_setr_epi8(0, 1, 2, 3, 8, 9, 10, 11, 4, 5, 6, 7, 12, 13, 14, 15);
            (s, s, 0isize)
        } else {
            (
                _mm_setr_epi8(0, 1, 2, Z, 8, 9, 10, Z, 3, 4, 5, Z, 11, 12, 13, Z),
                _mm_setr_epi8(2, 3, 4, Z, 10, 11, 12, Z, 5, 6, 7, Z, 13, 14, 15, Z),
                -2isize,
            )
        };
        let top = _mm256_set1_ps(255.0);
        let spread =
            [_mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1), _mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3)];
        let base = data.as_ptr();
        let mut ks = [0i32; 4];
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
                // 0 <= k < w h - w); the eight bytes read from NC k and from
                // NC (k + w) + below lie inside 0 .. NC w h <= data.len() by the bounds in
                // the module docs; unaligned 64-bit loads.
                let rd = |o: isize| _mm_loadl_epi64(base.offset(o) as *const __m128i);
                let t16 = _mm_unpacklo_epi64(rd(nc * k0), rd(nc * k1));
                let b16 = _mm_unpacklo_epi64(rd(nc * (k0 + w) + below), rd(nc * (k1 + w) + below));
                let t16 = _mm_shuffle_epi8(t16, sh_top);
                let b16 = _mm_shuffle_epi8(b16, sh_bot);
                let a = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(t16));
                let b = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_srli_si128::<8>(t16)));
                let e = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(b16));
                let f = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_srli_si128::<8>(b16)));
                let fx = _mm256_permutevar8x32_ps(fx4, *idx);
                let fy = _mm256_permutevar8x32_ps(fy4, *idx);
                let r = round_clamp(bilerp(a, b, e, f, fx, fy), top);
                // 8 x i32 in 0..=255 -> per 128-bit lane, the pixel's four bytes lowest.
                let r16 = _mm256_packus_epi32(r, r);
                let r8 = _mm256_packus_epi16(r16, r16);
                let lo = (_mm_cvtsi128_si32(_mm256_castsi256_si128(r8)) as u32).to_le_bytes();
                let hi =
                    (_mm_cvtsi128_si32(_mm256_extracti128_si256::<1>(r8)) as u32).to_le_bytes();
                let j = NC * (i + 2 * pair);
                out[j..j + NC].copy_from_slice(&lo[..NC]);
                out[j + NC..j + 2 * NC].copy_from_slice(&hi[..NC]);
            }
        }
        for k in 4 * groups..n {
            scalar(&pos[k], &mut out[NC * k..NC * k + NC]);
        }
    }

    /// See [`super::bilinear_color8`] with `NC = 2` (gray + alpha): eight positions at a
    /// time, one vector per channel.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= 2 w h` and `2 w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bilinear_la8(
        data: &[u8],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u8],
        scalar: &impl Fn(&[f64; 2], &mut [u8]),
    ) {
        let n = pos.len().min(out.len() / 2);
        let groups = n / 8;
        // Lane bounds as in the module docs; -1 when w or h is 1 (every lane rejected).
        let xmax = _mm256_set1_epi32(w as i32 - 2);
        let ymax = _mm256_set1_epi32(h as i32 - 2);
        let wv = _mm256_set1_epi32(w as i32);
        let byte = _mm256_set1_epi32(0xff);
        let top = _mm256_set1_ps(255.0);
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
            // SAFETY: every lane passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2; the words read
            // are bytes 2 k .. 2 k + 3 and 2 (k + w) .. 2 (k + w) + 3, inside
            // 0 .. 2 w h <= data.len() by the bounds in the module docs; byte offsets 2 k
            // (scale 2), k + w < w h < 2^31.
            let wt = _mm256_i32gather_epi32::<2>(base, k);
            let wb = _mm256_i32gather_epi32::<2>(base, _mm256_add_epi32(k, wv));
            // Word [c0 c1 c0' c1']: channel 0 of the left and right taps in bytes 0 and 2,
            // channel 1 in bytes 1 and 3.
            let ch = |x: __m256i| _mm256_cvtepi32_ps(_mm256_and_si256(x, byte));
            let v0 = bilerp(
                ch(wt),
                ch(_mm256_srli_epi32::<16>(wt)),
                ch(wb),
                ch(_mm256_srli_epi32::<16>(wb)),
                fx,
                fy,
            );
            let v1 = bilerp(
                ch(_mm256_srli_epi32::<8>(wt)),
                ch(_mm256_srli_epi32::<24>(wt)),
                ch(_mm256_srli_epi32::<8>(wb)),
                ch(_mm256_srli_epi32::<24>(wb)),
                fx,
                fy,
            );
            // Per lane the pixel's two bytes as one u16 (0..=65535, kept by the unsigned
            // pack); per 128-bit lane r0..r3 (r4..r7) in the low 64 bits, gathered into the
            // low 128 bits.
            let r =
                _mm256_or_si256(round_clamp(v0, top), _mm256_slli_epi32::<8>(round_clamp(v1, top)));
            let r16 = _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_packus_epi32(r, r));
            // SAFETY: i + 8 <= n <= out.len() / 2: sixteen bytes writable at out[2 i..];
            // unaligned.
            _mm_storeu_si128(
                out.as_mut_ptr().add(2 * i) as *mut __m128i,
                _mm256_castsi256_si128(r16),
            );
        }
        for k in 8 * groups..n {
            scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp::simd_harness::{self as harness, bit_identity_proptest, family};
    use crate::warp::Interp::Bilinear;

    family!(Color8, u8, bilinear_color8);

    #[test]
    fn rgb_and_rgba_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<u8, Color8>(Bilinear, &[3, 4], 34, 2000);
    }

    #[test]
    fn gray_alpha_vector_path_matches_the_scalar_path_bit_for_bit() {
        harness::sweep::<u8, Color8>(Bilinear, &[2], 28, 2000);
    }

    /// Signed zeros, ties, the border, infinities and `NaN` in either coordinate.
    #[test]
    fn special_positions_match_the_scalar_path() {
        harness::special::<u8, Color8>(Bilinear, &[2, 3, 4], 29);
    }

    /// The loads end exactly on the last byte of the image (module docs).
    #[test]
    fn loads_at_the_bottom_right_cell_stay_inside_the_image() {
        harness::bottom_right::<u8, Color8>(Bilinear, &[2, 3, 4]);
    }

    /// Groups of four (RGB, RGBA).
    #[test]
    fn interior_groups_take_the_vector_path() {
        harness::assert_vectorized::<u8, Color8>(Bilinear, &[3, 4]);
    }

    #[test]
    fn interior_groups_of_eight_take_the_gray_alpha_vector_path() {
        harness::assert_vectorized::<u8, Color8>(Bilinear, &[2]);
    }

    bit_identity_proptest!(
        color8_bit_identical_on_random_images,
        u8,
        Color8,
        Bilinear,
        [2, 3, 4],
        "Random gray + alpha, RGB and RGBA images (extreme values included) and random \
         positions, borders and outside included."
    );
}
