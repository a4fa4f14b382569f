//! Bilinear resampling of 32-bit float images, 1 to 4 channels (x86_64 AVX2).
//!
//! The scalar path ([`super::sample::fill_pixels`]) computes, for each channel `c` of a
//! position `(x, y)` with `x0 = floor(x)`, `y0 = floor(y)`, `fx = (x - x0) as f32`,
//! `fy = (y - y0) as f32` and the taps `a = I(x0, y0)[c]`, `b = I(x0 + 1, y0)[c]`,
//! `e = I(x0, y0 + 1)[c]`, `f = I(x0 + 1, y0 + 1)[c]`:
//!
//! ```text
//!   t = a + (b - a) fx,   u = e + (f - e) fx,   out = t + (u - t) fy
//! ```
//!
//! in `f32`, each operation rounded (no fused multiply-add), and keeps `out` as it is. The
//! vector path does the same operations in the same order on `f32` lanes, under the same
//! rounding mode and without flushing subnormals (the same MXCSR governs scalar and vector
//! code), so every lane is bit-identical to the scalar result: infinities and the `NaN` an
//! invalid operation makes (`inf - inf`, `0 inf`) included, since an operation on one `NaN`
//! returns that `NaN` and the only `NaN` made here is the default one. The floors and
//! fractions are computed in `f64` (`vroundpd` plus `+0.0`, exact subtraction, one rounding
//! to `f32` as `as f32` does), so that `x = -0.0` has the fraction `-0.0` as in the scalar
//! path and an image of `-0.0` samples gives `-0.0` there, not `+0.0`
//! ([`super::sample_simd::avx2::floor`]). Layouts:
//!
//! * gray: eight positions per vector, one lane each;
//! * gray + alpha: four positions per vector, two lanes each (in the order 0 2 1 3, put
//!   back in order before the store);
//! * RGB and RGBA: two positions per vector, four lanes each (RGB: the fourth lane repeats
//!   the third channel and its result is dropped).
//!
//! **Taps.** With `k = y0 w + x0` (the image is `w x h`, `NC` floats per pixel, row-major,
//! `NC w h` floats), the taps `a, b` are the `2 NC` floats from `NC k` and `e, f` the `2 NC`
//! floats from `NC (k + w)`. Offsets below are in floats:
//!
//! * gray: each lane gathers the floats `k`, `k + 1`, `k + w` and `k + w + 1`; the last is
//!   `k + w + 1 <= (h - 2) w + (w - 2) + w + 1 = h w - 1`.
//! * gray + alpha: each position loads four floats from `2 k` and from `2 (k + w)`; the last
//!   float read is `2 (k + w) + 3 <= 2 ((h - 2) w + (w - 2) + w) + 3 = 2 h w - 1`.
//! * RGBA: each position loads eight floats from `4 k` and from `4 (k + w)`; the last float
//!   read is `4 (k + w) + 7 <= 4 ((h - 2) w + (w - 2) + w) + 7 = 4 h w - 1`.
//! * RGB: each position loads eight floats from `3 k` (taps in floats 0..6) and from
//!   `3 (k + w) - 2` (taps in floats 2..8), so that the bottom load ends on the last tap:
//!   `3 (k + w) + 5 <= 3 h w - 1`; it starts at `3 (k + w) - 2 >= 3 w - 2 >= 4`, and the top
//!   load ends at `3 k + 7 <= 3 ((h - 2) w + w - 2) + 7 = 3 (h - 1) w + 1 <= 3 h w - 1`
//!   (`w >= 2`).
//!
//! for every lane with `0 <= x0 <= w - 2` and `0 <= y0 <= h - 2` (so `w, h >= 2`). A group
//! of eight (gray) or four (the others) positions is taken on the vector path only when all
//! its lanes pass; any other group (outside the mesh, `NaN`, a neighbourhood across the
//! image border) and the tail are done pixel by pixel by the scalar path. Out-of-range and
//! `NaN` coordinates convert to `i32::MIN` and so fail the test.

#[cfg(target_arch = "x86_64")]
use super::sample_simd::avx2_fits;

/// Fills the `NC`-float pixels `out[NC i ..]` for every position `pos[i]`
/// (`i < min(pos.len(), out.len() / NC)`) of a `w x h` image `data` (`NC` = 1 to 4
/// interleaved `f32` channels) by bilinear interpolation, with `scalar(p, px)` writing the
/// pixels the vector path does not take. Returns `false` (and writes nothing) when the
/// vector path is not available: not x86_64, no AVX2, `NC` not 1 to 4, or an image too
/// large for 32-bit offsets.
pub(super) fn bilinear_f32<const NC: usize>(
    data: &[f32],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [f32],
    scalar: impl Fn(&[f64; 2], &mut [f32]),
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if (1..=4).contains(&NC) && avx2_fits(data.len(), w, h, NC) {
        if NC == 1 {
            // SAFETY: AVX2 is available and `data` holds at least `w h < 2^31` floats
            // (`avx2_fits`), as `avx2::bilinear_gray` requires.
            unsafe { avx2::bilinear_gray(data, w, h, pos, out, &scalar) };
        } else if NC == 2 {
            // SAFETY: AVX2 is available and `data` holds at least `2 w h < 2^31` floats
            // (`avx2_fits`), as `avx2::bilinear_la` requires.
            unsafe { avx2::bilinear_la(data, w, h, pos, out, &scalar) };
        } else {
            // SAFETY: `NC` is 3 or 4 (checked just above); AVX2 is available and `data`
            // holds at least `NC w h < 2^31` floats (`avx2_fits`), as `avx2::bilinear_color`
            // requires.
            unsafe { avx2::bilinear_color::<NC>(data, w, h, pos, out, &scalar) };
        }
        return true;
    }
    let _ = (data, w, h, pos, out, scalar);
    false
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use crate::warp::sample_simd::avx2::{bilerp, lanes4, lanes8};
    use std::arch::x86_64::*;

    /// See [`super::bilinear_f32`] with `NC = 1`: eight positions at a time.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= w h` and `w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bilinear_gray(
        data: &[f32],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [f32],
        scalar: &impl Fn(&[f64; 2], &mut [f32]),
    ) {
        let n = pos.len().min(out.len());
        let groups = n / 8;
        // Lane bounds as in the module docs; -1 when w or h is 1 (every lane rejected).
        let xmax = _mm256_set1_epi32(w as i32 - 2);
        let ymax = _mm256_set1_epi32(h as i32 - 2);
        let wv = _mm256_set1_epi32(w as i32);
        let one = _mm256_set1_epi32(1);
        let base = data.as_ptr();
        for g in 0..groups {
            let i = 8 * g;
            // SAFETY: i + 8 <= n <= pos.len(): 16 f64 for 8 contiguous positions.
            let (x0, y0, ok, fx, fy) = lanes8(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if _mm256_movemask_ps(_mm256_castsi256_ps(ok)) != 0xff {
                for k in i..i + 8 {
                    scalar(&pos[k], &mut out[k..k + 1]);
                }
                continue;
            }
            let k = _mm256_add_epi32(_mm256_mullo_epi32(y0, wv), x0);
            let kd = _mm256_add_epi32(k, wv);
            // SAFETY: every lane passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2; the floats read
            // are k, k + 1, k + w, k + w + 1, inside 0 .. w h <= data.len() by the bounds in
            // the module docs; byte offsets 4 x the index (scale 4), k + w + 1 < 2^31.
            let a = _mm256_i32gather_ps::<4>(base, k);
            let b = _mm256_i32gather_ps::<4>(base, _mm256_add_epi32(k, one));
            let e = _mm256_i32gather_ps::<4>(base, kd);
            let f = _mm256_i32gather_ps::<4>(base, _mm256_add_epi32(kd, one));
            let v = bilerp(a, b, e, f, fx, fy);
            // SAFETY: i + 8 <= n <= out.len(): eight floats writable at out[i..]; unaligned.
            _mm256_storeu_ps(out.as_mut_ptr().add(i), v);
        }
        for k in 8 * groups..n {
            scalar(&pos[k], &mut out[k..k + 1]);
        }
    }

    /// See [`super::bilinear_f32`] with `NC = 2`: four positions at a time, two lanes each.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= 2 w h` and `2 w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bilinear_la(
        data: &[f32],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [f32],
        scalar: &impl Fn(&[f64; 2], &mut [f32]),
    ) {
        let n = pos.len().min(out.len() / 2);
        let groups = n / 4;
        let xmax = _mm_set1_epi32(w as i32 - 2);
        let ymax = _mm_set1_epi32(h as i32 - 2);
        let wv = _mm_set1_epi32(w as i32);
        // Positions in the order 0 2 | 1 3, two lanes each (the order of the 64-bit unpacks).
        let order = _mm256_setr_epi32(0, 0, 2, 2, 1, 1, 3, 3);
        let base = data.as_ptr();
        let mut ks = [0i32; 4];
        for g in 0..groups {
            let i = 4 * g;
            // SAFETY: i + 4 <= n <= pos.len(): 8 contiguous f64.
            let (x0, y0, ok, fx4, fy4) = lanes4(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if _mm_movemask_ps(_mm_castsi128_ps(ok)) != 0xf {
                for k in i..i + 4 {
                    scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
                }
                continue;
            }
            // SAFETY: `ks` is four i32; unaligned store.
            _mm_storeu_si128(
                ks.as_mut_ptr() as *mut __m128i,
                _mm_add_epi32(_mm_mullo_epi32(y0, wv), x0),
            );
            let k = ks.map(|k| 2 * k as isize);
            let kd = ks.map(|k| 2 * (k as isize + w as isize));
            // SAFETY: every lane passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2; the four floats
            // read from 2 k and from 2 (k + w) lie inside 0 .. 2 w h <= data.len() by the
            // bounds in the module docs; unaligned 128-bit loads.
            let rd = |o: isize| _mm_loadu_ps(base.offset(o));
            // [a_p b_p | a_q b_q] for the positions p, q (two floats per tap).
            let two = |p: isize, q: isize| _mm256_set_m128(rd(q), rd(p));
            let (t01, t23) = (two(k[0], k[1]), two(k[2], k[3]));
            let (b01, b23) = (two(kd[0], kd[1]), two(kd[2], kd[3]));
            let lo = |x: __m256, y: __m256| {
                _mm256_castpd_ps(_mm256_unpacklo_pd(_mm256_castps_pd(x), _mm256_castps_pd(y)))
            };
            let hi = |x: __m256, y: __m256| {
                _mm256_castpd_ps(_mm256_unpackhi_pd(_mm256_castps_pd(x), _mm256_castps_pd(y)))
            };
            let fx = _mm256_permutevar8x32_ps(_mm256_castps128_ps256(fx4), order);
            let fy = _mm256_permutevar8x32_ps(_mm256_castps128_ps256(fy4), order);
            let v = bilerp(lo(t01, t23), hi(t01, t23), lo(b01, b23), hi(b01, b23), fx, fy);
            // [v0 v2 v1 v3] -> [v0 v1 v2 v3], two floats each.
            let v = _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(v)));
            // SAFETY: i + 4 <= n <= out.len() / 2: eight floats writable at out[2 i..];
            // unaligned.
            _mm256_storeu_ps(out.as_mut_ptr().add(2 * i), v);
        }
        for k in 4 * groups..n {
            scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
        }
    }

    /// See [`super::bilinear_f32`] with `NC` = 3 or 4: four positions at a time, two per
    /// vector.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `NC` is 3 or 4; `data.len() >= NC w h` and `NC w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bilinear_color<const NC: usize>(
        data: &[f32],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [f32],
        scalar: &impl Fn(&[f64; 2], &mut [f32]),
    ) {
        let n = pos.len().min(out.len() / NC);
        let groups = n / 4;
        let xmax = _mm_set1_epi32(w as i32 - 2);
        let ymax = _mm_set1_epi32(h as i32 - 2);
        let wv = _mm_set1_epi32(w as i32);
        // RGB: the eight floats of one position's row load are permuted to [a | b], four
        // floats per tap (the fourth repeats the third).
        let (sh_top, sh_bot, below) = (
            _mm256_setr_epi32(0, 1, 2, 2, 3, 4, 5, 5),
            _mm256_setr_epi32(2, 3, 4, 4, 5, 6, 7, 7),
            if NC == 4 { 0isize } else { -2isize },
        );
        let spread =
            [_mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1), _mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3)];
        let base = data.as_ptr();
        let mut ks = [0i32; 4];
        let mut px = [0f32; 8];
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
                // 0 <= k < w h - w); the eight floats read from NC k and from
                // NC (k + w) + below lie inside 0 .. NC w h <= data.len() by the bounds in
                // the module docs; unaligned 256-bit loads.
                let rd = |o: isize| _mm256_loadu_ps(base.offset(o));
                let (mut t0, mut t1) = (rd(nc * k0), rd(nc * k1));
                let (mut b0, mut b1) = (rd(nc * (k0 + w) + below), rd(nc * (k1 + w) + below));
                if NC == 3 {
                    t0 = _mm256_permutevar8x32_ps(t0, sh_top);
                    t1 = _mm256_permutevar8x32_ps(t1, sh_top);
                    b0 = _mm256_permutevar8x32_ps(b0, sh_bot);
                    b1 = _mm256_permutevar8x32_ps(b1, sh_bot);
                }
                // [a0 | a1], [b0 | b1], [e0 | e1], [f0 | f1].
                let a = _mm256_permute2f128_ps::<0x20>(t0, t1);
                let b = _mm256_permute2f128_ps::<0x31>(t0, t1);
                let e = _mm256_permute2f128_ps::<0x20>(b0, b1);
                let f = _mm256_permute2f128_ps::<0x31>(b0, b1);
                let fx = _mm256_permutevar8x32_ps(fx4, *idx);
                let fy = _mm256_permutevar8x32_ps(fy4, *idx);
                let v = bilerp(a, b, e, f, fx, fy);
                let j = NC * (i + 2 * pair);
                if NC == 4 {
                    // SAFETY: i + 4 <= n <= out.len() / 4, so j + 8 <= 4 (i + 4) <= out.len():
                    // eight floats writable at out[j..]; unaligned.
                    _mm256_storeu_ps(out.as_mut_ptr().add(j), v);
                } else {
                    // SAFETY: `px` is eight f32; unaligned store.
                    _mm256_storeu_ps(px.as_mut_ptr(), v);
                    out[j..j + NC].copy_from_slice(&px[..NC]);
                    out[j + NC..j + 2 * NC].copy_from_slice(&px[4..4 + NC]);
                }
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

    family!(Float, f32, bilinear_f32);

    /// Bit for bit (`to_bits`), with every kind of float sample (negative, huge,
    /// subnormal, infinite, signed zeros) and all kinds mixed.
    #[test]
    fn float_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<f32, Float>(Bilinear, &[1, 2, 3, 4], 32, 1500);
    }

    /// Positions with signed zero coordinates (`x = -0.0`, `y = -0.0`) on images of
    /// `-0.0` samples, where the sign of the fractions `fx`, `fy` decides the sign of a
    /// zero result, and the other coordinates where flooring turns (`.5`, integers, the
    /// border, infinities, `NaN`).
    #[test]
    fn signed_zero_positions_and_samples_match_the_scalar_path() {
        harness::special::<f32, Float>(Bilinear, &[1, 2, 3, 4], 36);
    }

    /// The loads end exactly on the last float of the image (module docs).
    #[test]
    fn loads_at_the_bottom_right_cell_stay_inside_the_image() {
        harness::bottom_right::<f32, Float>(Bilinear, &[1, 2, 3, 4]);
    }

    /// Groups of eight (gray) and four (the others).
    #[test]
    fn interior_groups_take_the_vector_path() {
        harness::assert_vectorized::<f32, Float>(Bilinear, &[1, 2, 3, 4]);
    }

    bit_identity_proptest!(
        float_bit_identical_on_random_images,
        f32,
        Float,
        Bilinear,
        [1, 2, 3, 4],
        "Random float images of 1 to 4 channels (negative, huge, subnormal and infinite \
         values included) and random positions, borders and outside included."
    );
}
