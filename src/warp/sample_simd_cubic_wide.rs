//! Bicubic resampling of 16-bit and `f32` images, 1 to 4 channels (x86_64 AVX2): gray
//! eight positions per vector (one lane each), gray + alpha four (two lanes each), RGB and
//! RGBA two (four lanes each).
//!
//! The scalar path ([`super::sample::Source::sample_into`], `Interp::Bicubic`) computes,
//! for a position `(x, y)` with `x0 = floor(x)`, `y0 = floor(y)`, `fx = (x - x0) as f32`,
//! `fy = (y - y0) as f32`, Keys' kernel (`a = -0.5`)
//!
//! ```text
//!   K(t) = (1.5 s - 2.5) s s + 1            s = |t| < 1
//!        = ((-0.5 s + 2.5) s - 4) s + 2     1 <= s < 2
//!        = 0                                otherwise
//! ```
//!
//! (each product and sum taken left to right), the weights `wx = [K(fx + 1), K(fx),
//! K(fx - 1), K(fx - 2)]`, likewise `wy` from `fy`, and for each channel `c`, with the taps
//! `v(i, j) = I(x0 + i - 1, y0 + j - 1)[c]` as `f32` (`i, j` in `0..4`, coordinates clamped
//! to the image; 16-bit samples are exact in `f32`):
//!
//! ```text
//!   row_j = (((0 + wx0 v(0, j)) + wx1 v(1, j)) + wx2 v(2, j)) + wx3 v(3, j)
//!   acc   = (((0 + wy0 row_0) + wy1 row_1) + wy2 row_2) + wy3 row_3
//!   lo    = +inf, then lo = v if v < lo for v = v(1, 1), v(2, 1), v(1, 2), v(2, 2)
//!   hi    = -inf, then hi = v if v > hi, for the same taps in the same order
//!   c     = clamp(acc, lo, hi)          (acc < lo gives lo, then > hi gives hi)
//!   out   = trunc(clamp(c + 0.5, 0, 65535))      (u16)
//!   out   = c                                    (f32: no rounding, no clamp to a range)
//! ```
//!
//! in `f32`, each operation rounded (no fused multiply-add). The vector path does the same
//! operations in the same order on `f32` lanes: the floors and fractions in `f64`
//! (`vroundpd` plus `+0.0`, exact subtraction, one rounding to `f32` as `as f32` does;
//! [`super::sample_simd::avx2::floor`]), `K` on both of its branches with the branch chosen
//! by the same comparisons, the sums from `+0.0` in the order above (so a sum of `-0.0`
//! terms is `+0.0` on both paths), separate multiplies and adds (the helpers of
//! [`super::sample_simd_cubic`]). `lo` and `hi` are folded as `vminps(v, lo)` and
//! `vmaxps(v, hi)`, which are `v < lo ? v : lo` and `v > hi ? v : hi`: a `NaN` tap is
//! skipped and of equal taps (`-0.0`, `+0.0`) the first stays, as in the scalar compares;
//! the clamp is done by compare and blend, the 16-bit rounding by
//! [`super::sample_simd::avx2::round_clamp`]. Scalar and vector code run under the same
//! MXCSR (rounding mode, no flush of subnormals), so every lane is bit-identical to the
//! scalar result, infinities and the default `NaN` of an invalid operation (`inf - inf`,
//! `0 inf`) included. (With `NaN` samples both paths give a `NaN` at the same lanes, but
//! which payload wins when two meet depends on the operand order the compiler picks for
//! the scalar sums; and four `NaN` centre taps make the scalar `f32::clamp` panic. The
//! tests draw no `NaN` samples.)
//!
//! **Taps.** The vector path takes a position only when no tap is clamped:
//! `1 <= x0 <= w - 3` and `1 <= y0 <= h - 3` (so `w, h >= 4`). With
//! `k = (y0 - 1) w + x0 - 1` (the pixel index of tap `v(0, 0)`; the image is `w x h`, `NC`
//! samples per pixel, row-major, `n = NC w h` samples), row `j` of the taps is the `4 NC`
//! samples from `NC (k + j w)`, and `0 <= k`, `k + 3 w + 3 = (y0 + 2) w + x0 + 2 <=
//! (h - 1) w + w - 1 = h w - 1`. Every load below starts at or after the first tap of its
//! row (`>= 0`) and ends at or before the row's last tap, `NC (k + j w + 3) + NC - 1 <=
//! NC (k + 3 w + 3) + NC - 1 <= n - 1`; offsets are in samples (two bytes for `u16`, four
//! for `f32`):
//!
//! * gray, `u16`: each position loads four samples (64 bits) from `k + j w`; `f32`: four
//!   floats (128 bits) from `k + j w`. The last sample read is `k + j w + 3`.
//! * gray + alpha: each position loads eight samples (`u16`: 128 bits, `f32`: 256 bits) from
//!   `2 (k + j w)`; the last read is `2 (k + j w) + 7 = 2 (k + j w + 3) + 1`.
//! * RGBA, `u16`: each position loads eight samples from `4 (k + j w)` (taps 0, 1) and eight
//!   from `4 (k + j w) + 8` (taps 2, 3), the last `4 (k + j w) + 15 = 4 (k + j w + 3) + 3`;
//!   `f32`: four floats from `4 (k + j w) + 4 i` for tap `i`, the last
//!   `4 (k + j w) + 15` too.
//! * RGB, `u16`: each position loads eight samples from `3 (k + j w)` (taps 0 and 1 in
//!   samples 0..6) and eight from `3 (k + j w) + 4` (taps 2 and 3 in samples 2..8), the
//!   last `3 (k + j w) + 11 = 3 (k + j w + 3) + 2`; `f32`: four floats from
//!   `3 (k + j w) + 3 i` for taps `i = 0, 1, 2` (the fourth float, the next tap's first
//!   channel, gives a lane whose result is dropped; the last read is `3 (k + j w) + 9`) and
//!   four from `3 (k + j w) + 8` for tap 3 (its channels in lanes 1..4, moved to 0..3),
//!   the last `3 (k + j w) + 11 = 3 (k + j w + 3) + 2`.
//!
//! A group of eight (gray) or four (the others) positions is taken on the vector path only
//! when all its lanes pass; any other group (outside the mesh, `NaN`, taps across the image
//! border) and the tail are done pixel by pixel by the scalar path. Out-of-range and `NaN`
//! coordinates convert to `i32::MIN` and so fail the test. Offsets fit in `i32` and
//! `isize`: `n < 2^31` ([`super::sample_simd::avx2_fits`]).

#[cfg(target_arch = "x86_64")]
use super::sample_simd::avx2_fits;

/// Fills the `NC`-sample pixels `out[NC i ..]` for every position `pos[i]`
/// (`i < min(pos.len(), out.len() / NC)`) of a `w x h` image `data` (`NC` = 1 to 4
/// interleaved 16-bit channels) by bicubic interpolation, with `scalar(p, px)` writing the
/// pixels the vector path does not take. Returns `false` (and writes nothing) when the
/// vector path is not available: not x86_64, no AVX2, `NC` not 1 to 4, or an image too
/// large for 32-bit offsets.
pub(super) fn bicubic16<const NC: usize>(
    data: &[u16],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [u16],
    scalar: impl Fn(&[f64; 2], &mut [u16]),
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if (1..=4).contains(&NC) && avx2_fits(data.len(), w, h, NC) {
        if NC == 1 {
            // SAFETY: AVX2 is available and `data` holds at least `w h < 2^31` samples
            // (`avx2_fits`), as `avx2::bicubic_gray16` requires.
            unsafe { avx2::bicubic_gray16(data, w, h, pos, out, &scalar) };
        } else if NC == 2 {
            // SAFETY: AVX2 is available and `data` holds at least `2 w h < 2^31` samples
            // (`avx2_fits`), as `avx2::bicubic_la16` requires.
            unsafe { avx2::bicubic_la16(data, w, h, pos, out, &scalar) };
        } else {
            // SAFETY: `NC` is 3 or 4 (checked just above); AVX2 is available and `data`
            // holds at least `NC w h < 2^31` samples (`avx2_fits`), as
            // `avx2::bicubic_color16` requires.
            unsafe { avx2::bicubic_color16::<NC>(data, w, h, pos, out, &scalar) };
        }
        return true;
    }
    let _ = (data, w, h, pos, out, scalar);
    false
}

/// [`bicubic16`] for `f32` samples (`NC` = 1 to 4 interleaved channels), the results kept
/// as computed. Returns `false` (and writes nothing) when the vector path is not available.
pub(super) fn bicubic_f32<const NC: usize>(
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
            // (`avx2_fits`), as `avx2::bicubic_gray_f32` requires.
            unsafe { avx2::bicubic_gray_f32(data, w, h, pos, out, &scalar) };
        } else if NC == 2 {
            // SAFETY: AVX2 is available and `data` holds at least `2 w h < 2^31` floats
            // (`avx2_fits`), as `avx2::bicubic_la_f32` requires.
            unsafe { avx2::bicubic_la_f32(data, w, h, pos, out, &scalar) };
        } else {
            // SAFETY: `NC` is 3 or 4 (checked just above); AVX2 is available and `data`
            // holds at least `NC w h < 2^31` floats (`avx2_fits`), as
            // `avx2::bicubic_color_f32` requires.
            unsafe { avx2::bicubic_color_f32::<NC>(data, w, h, pos, out, &scalar) };
        }
        return true;
    }
    let _ = (data, w, h, pos, out, scalar);
    false
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use crate::warp::sample_simd::avx2::{lanes4, lanes8, round_clamp};
    use crate::warp::sample_simd_cubic::avx2::{clamp, dot4, inside4, inside8, weights};
    use std::arch::x86_64::*;

    /// Zero byte for `_mm_shuffle_epi8`.
    const Z: i8 = -128;

    /// The scalar sums and clamp of the module docs on eight lanes, for the weights `wx`,
    /// `wy` and the taps `taps(j)` of row `j`: `acc` summed from `+0.0` row by row, `lo`
    /// and `hi` folded over `v(1, 1)`, `v(2, 1)`, `v(1, 2)`, `v(2, 2)` in that order by
    /// `vminps(v, lo)`, `vmaxps(v, hi)`; returns `clamp(acc, lo, hi)`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn cubic(
        wx: &[__m256; 4],
        wy: &[__m256; 4],
        mut taps: impl FnMut(usize) -> [__m256; 4],
    ) -> __m256 {
        let mut acc = _mm256_setzero_ps();
        let (mut lo, mut hi) = (_mm256_set1_ps(f32::INFINITY), _mm256_set1_ps(f32::NEG_INFINITY));
        for (j, wyj) in wy.iter().enumerate() {
            let v = taps(j);
            if j == 1 || j == 2 {
                for vi in [v[1], v[2]] {
                    lo = _mm256_min_ps(vi, lo);
                    hi = _mm256_max_ps(vi, hi);
                }
            }
            acc = _mm256_add_ps(acc, _mm256_mul_ps(*wyj, dot4(wx, &v)));
        }
        clamp(acc, lo, hi)
    }

    /// Eight positions' rows of four taps (`r[p]`: tap `i` in lane `i`) as four vectors,
    /// tap `i` of position `p` in lane `p` of vector `i`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn transpose8x4(r: &[__m128; 8]) -> [__m256; 4] {
        let v = |p: usize| _mm256_set_m128(r[p + 4], r[p]);
        // [p0t0 p1t0 p0t1 p1t1 | p4t0 p5t0 p4t1 p5t1], [p0t2 p1t2 p0t3 p1t3 | ...], ...
        let (a, b) = (_mm256_unpacklo_ps(v(0), v(1)), _mm256_unpackhi_ps(v(0), v(1)));
        let (c, d) = (_mm256_unpacklo_ps(v(2), v(3)), _mm256_unpackhi_ps(v(2), v(3)));
        let pd = _mm256_castps_pd;
        let lo = |x: __m256, y: __m256| _mm256_castpd_ps(_mm256_unpacklo_pd(pd(x), pd(y)));
        let hi = |x: __m256, y: __m256| _mm256_castpd_ps(_mm256_unpackhi_pd(pd(x), pd(y)));
        [lo(a, c), hi(a, c), lo(b, d), hi(b, d)]
    }

    /// The pixel index `k = y0 w + x0 - (w + 1)` of tap `v(0, 0)` of four positions.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn corner4(x0: __m128i, y0: __m128i, w: usize) -> [i32; 4] {
        let (wv, c) = (_mm_set1_epi32(w as i32), _mm_set1_epi32(w as i32 + 1));
        let k = _mm_sub_epi32(_mm_add_epi32(_mm_mullo_epi32(y0, wv), x0), c);
        let mut ks = [0i32; 4];
        // SAFETY: four i32 into a four-i32 array; unaligned store.
        unsafe { _mm_storeu_si128(ks.as_mut_ptr() as *mut __m128i, k) };
        ks
    }

    /// [`corner4`] of eight positions.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn corner8(x0: __m256i, y0: __m256i, w: usize) -> [i32; 8] {
        let (wv, c) = (_mm256_set1_epi32(w as i32), _mm256_set1_epi32(w as i32 + 1));
        let k = _mm256_sub_epi32(_mm256_add_epi32(_mm256_mullo_epi32(y0, wv), x0), c);
        let mut ks = [0i32; 8];
        // SAFETY: eight i32 into an eight-i32 array; unaligned store.
        unsafe { _mm256_storeu_si256(ks.as_mut_ptr() as *mut __m256i, k) };
        ks
    }

    /// The x and y weights of four positions (`wxy`: lanes 0..4 x, 4..8 y) spread over
    /// eight lanes: gray + alpha (`pair = None`) two lanes per position, RGB and RGBA
    /// (`Some(pair)`) four lanes for each of positions `2 pair` and `2 pair + 1`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn spread(wxy: &[__m256; 4], pair: Option<usize>) -> ([__m256; 4], [__m256; 4]) {
        let (ix, iy) = match pair {
            None => (
                _mm256_setr_epi32(0, 0, 1, 1, 2, 2, 3, 3),
                _mm256_setr_epi32(4, 4, 5, 5, 6, 6, 7, 7),
            ),
            Some(0) => (
                _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1),
                _mm256_setr_epi32(4, 4, 4, 4, 5, 5, 5, 5),
            ),
            Some(_) => (
                _mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3),
                _mm256_setr_epi32(6, 6, 6, 6, 7, 7, 7, 7),
            ),
        };
        (wxy.map(|v| _mm256_permutevar8x32_ps(v, ix)), wxy.map(|v| _mm256_permutevar8x32_ps(v, iy)))
    }

    /// 8 x i32 in 0..=65535 as u16 in the low 128 bits (lanes in order).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn pack16(r: __m256i) -> __m128i {
        // Per 128-bit lane r0..r3 (r4..r7) in the low 64 bits; gather those two halves.
        _mm256_castsi256_si128(_mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_packus_epi32(r, r)))
    }

    /// See [`super::bicubic16`] with `NC = 1`: eight positions at a time, one lane each.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= w h` and `w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bicubic_gray16(
        data: &[u16],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u16],
        scalar: &impl Fn(&[f64; 2], &mut [u16]),
    ) {
        let n = pos.len().min(out.len());
        let groups = n / 8;
        // Lane bounds x0 <= w - 3, y0 <= h - 3: with w h < 2^31 they fit in i32 (and are
        // negative when w or h < 3, rejecting every lane).
        let xmax = _mm256_set1_epi32(w as i32 - 3);
        let ymax = _mm256_set1_epi32(h as i32 - 3);
        let top = _mm256_set1_ps(65535.0);
        let base = data.as_ptr();
        for g in 0..groups {
            let i = 8 * g;
            // SAFETY: i + 8 <= n <= pos.len(): 16 f64 for 8 contiguous positions.
            let (x0, y0, ok, fx, fy) = lanes8(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if !inside8(ok, x0, y0) {
                for k in i..i + 8 {
                    scalar(&pos[k], &mut out[k..k + 1]);
                }
                continue;
            }
            let ks = corner8(x0, y0, w);
            let acc = cubic(&weights(fx), &weights(fy), |j| {
                let jw = (j * w) as isize;
                // SAFETY: every lane passed 1 <= x0 <= w - 3, 1 <= y0 <= h - 3; the four
                // samples read from k + j w are the row's taps, inside 0 .. w h <=
                // data.len() by the bounds in the module docs; unaligned 64-bit loads.
                let r = ks.map(|k| unsafe {
                    let p = base.offset(k as isize + jw) as *const __m128i;
                    _mm_castsi128_ps(_mm_cvtepu16_epi32(_mm_loadl_epi64(p)))
                });
                transpose8x4(&r).map(|t| _mm256_cvtepi32_ps(_mm256_castps_si256(t)))
            });
            // SAFETY: i + 8 <= n <= out.len(): eight u16 writable at out[i..]; unaligned.
            _mm_storeu_si128(
                out.as_mut_ptr().add(i) as *mut __m128i,
                pack16(round_clamp(acc, top)),
            );
        }
        for k in 8 * groups..n {
            scalar(&pos[k], &mut out[k..k + 1]);
        }
    }

    /// See [`super::bicubic16`] with `NC = 2`: four positions at a time, two lanes each.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= 2 w h` and `2 w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bicubic_la16(
        data: &[u16],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u16],
        scalar: &impl Fn(&[f64; 2], &mut [u16]),
    ) {
        let n = pos.len().min(out.len() / 2);
        let groups = n / 4;
        // Lane bounds as in the module docs; negative when w or h < 3 (every lane rejected).
        let xmax = _mm_set1_epi32(w as i32 - 3);
        let ymax = _mm_set1_epi32(h as i32 - 3);
        let top = _mm256_set1_ps(65535.0);
        let base = data.as_ptr();
        for g in 0..groups {
            let i = 4 * g;
            // SAFETY: i + 4 <= n <= pos.len(): 8 contiguous f64.
            let (x0, y0, ok, fx4, fy4) = lanes4(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if !inside4(ok, x0, y0) {
                for k in i..i + 4 {
                    scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
                }
                continue;
            }
            let ks = corner4(x0, y0, w);
            let (wx, wy) = spread(&weights(_mm256_set_m128(fy4, fx4)), None);
            let acc = cubic(&wx, &wy, |j| {
                let jw = (j * w) as isize;
                // SAFETY: every lane passed 1 <= x0 <= w - 3, 1 <= y0 <= h - 3; the eight
                // samples read from 2 (k + j w) are the row's taps, inside 0 .. 2 w h <=
                // data.len() by the bounds in the module docs; unaligned 128-bit loads.
                let r = ks.map(|k| unsafe {
                    _mm_loadu_si128(base.offset(2 * (k as isize + jw)) as *const __m128i)
                });
                // Transpose the 32-bit taps: [p0 p1 p2 p3] of tap i, two channels each.
                let (a, b) = (_mm_unpacklo_epi32(r[0], r[1]), _mm_unpackhi_epi32(r[0], r[1]));
                let (c, d) = (_mm_unpacklo_epi32(r[2], r[3]), _mm_unpackhi_epi32(r[2], r[3]));
                let cv = |x: __m128i| _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(x));
                [
                    cv(_mm_unpacklo_epi64(a, c)),
                    cv(_mm_unpackhi_epi64(a, c)),
                    cv(_mm_unpacklo_epi64(b, d)),
                    cv(_mm_unpackhi_epi64(b, d)),
                ]
            });
            // SAFETY: i + 4 <= n <= out.len() / 2: eight u16 writable at out[2 i..];
            // unaligned.
            _mm_storeu_si128(
                out.as_mut_ptr().add(2 * i) as *mut __m128i,
                pack16(round_clamp(acc, top)),
            );
        }
        for k in 4 * groups..n {
            scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
        }
    }

    /// See [`super::bicubic16`] with `NC` = 3 or 4: four positions at a time, two pixels
    /// per vector, four lanes per pixel (RGB: the fourth lane is zero and its result
    /// dropped).
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `NC` is 3 or 4; `data.len() >= NC w h` and `NC w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bicubic_color16<const NC: usize>(
        data: &[u16],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u16],
        scalar: &impl Fn(&[f64; 2], &mut [u16]),
    ) {
        let n = pos.len().min(out.len() / NC);
        let groups = n / 4;
        let xmax = _mm_set1_epi32(w as i32 - 3);
        let ymax = _mm_set1_epi32(h as i32 - 3);
        let top = _mm256_set1_ps(65535.0);
        // Two loads of eight samples per row (RGB: from samples 0 and 4, RGBA: 0 and 8),
        // each to two taps of four samples (RGB: shuffled, the fourth zero).
        let second = if NC == 3 { 4isize } else { 8isize };
        let sa = _mm_setr_epi8(0, 1, 2, 3, 4, 5, Z, Z, 6, 7, 8, 9, 10, 11, Z, Z);
        let sb = _mm_setr_epi8(4, 5, 6, 7, 8, 9, Z, Z, 10, 11, 12, 13, 14, 15, Z, Z);
        let base = data.as_ptr();
        let mut px = [0u16; 8];
        for g in 0..groups {
            let i = 4 * g;
            // SAFETY: i + 4 <= n <= pos.len(): 8 contiguous f64.
            let (x0, y0, ok, fx4, fy4) = lanes4(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if !inside4(ok, x0, y0) {
                for k in i..i + 4 {
                    scalar(&pos[k], &mut out[NC * k..NC * k + NC]);
                }
                continue;
            }
            let ks = corner4(x0, y0, w);
            let wxy = weights(_mm256_set_m128(fy4, fx4));
            for pair in 0..2 {
                let (wx, wy) = spread(&wxy, Some(pair));
                let (k0, k1) = (ks[2 * pair] as isize, ks[2 * pair + 1] as isize);
                let acc = cubic(&wx, &wy, |j| {
                    let o = |k: isize| NC as isize * (k + (j * w) as isize);
                    // SAFETY: both lanes passed 1 <= x0 <= w - 3, 1 <= y0 <= h - 3; the
                    // eight samples from NC (k + j w) and the eight from NC (k + j w) + 4
                    // (RGB) or + 8 (RGBA) lie within the row's taps, inside
                    // 0 .. NC w h <= data.len() by the bounds in the module docs; unaligned
                    // 128-bit loads.
                    let rd = |o: isize| unsafe {
                        let (a, b) = (base.offset(o), base.offset(o + second));
                        let a = _mm_loadu_si128(a as *const __m128i);
                        let b = _mm_loadu_si128(b as *const __m128i);
                        if NC == 3 {
                            (_mm_shuffle_epi8(a, sa), _mm_shuffle_epi8(b, sb))
                        } else {
                            (a, b)
                        }
                    };
                    // [t0 | t1] and [t2 | t3] of each pixel, four samples per tap.
                    let ((a0, b0), (a1, b1)) = (rd(o(k0)), rd(o(k1)));
                    let cv = |x: __m128i| _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(x));
                    [
                        cv(_mm_unpacklo_epi64(a0, a1)),
                        cv(_mm_unpackhi_epi64(a0, a1)),
                        cv(_mm_unpacklo_epi64(b0, b1)),
                        cv(_mm_unpackhi_epi64(b0, b1)),
                    ]
                });
                // SAFETY: `px` is eight u16; unaligned store.
                _mm_storeu_si128(px.as_mut_ptr() as *mut __m128i, pack16(round_clamp(acc, top)));
                let j = NC * (i + 2 * pair);
                out[j..j + NC].copy_from_slice(&px[..NC]);
                out[j + NC..j + 2 * NC].copy_from_slice(&px[4..4 + NC]);
            }
        }
        for k in 4 * groups..n {
            scalar(&pos[k], &mut out[NC * k..NC * k + NC]);
        }
    }

    /// See [`super::bicubic_f32`] with `NC = 1`: eight positions at a time, one lane each.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= w h` and `w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bicubic_gray_f32(
        data: &[f32],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [f32],
        scalar: &impl Fn(&[f64; 2], &mut [f32]),
    ) {
        let n = pos.len().min(out.len());
        let groups = n / 8;
        let xmax = _mm256_set1_epi32(w as i32 - 3);
        let ymax = _mm256_set1_epi32(h as i32 - 3);
        let base = data.as_ptr();
        for g in 0..groups {
            let i = 8 * g;
            // SAFETY: i + 8 <= n <= pos.len(): 16 f64 for 8 contiguous positions.
            let (x0, y0, ok, fx, fy) = lanes8(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if !inside8(ok, x0, y0) {
                for k in i..i + 8 {
                    scalar(&pos[k], &mut out[k..k + 1]);
                }
                continue;
            }
            let ks = corner8(x0, y0, w);
            let acc = cubic(&weights(fx), &weights(fy), |j| {
                let jw = (j * w) as isize;
                // SAFETY: every lane passed 1 <= x0 <= w - 3, 1 <= y0 <= h - 3; the four
                // floats read from k + j w are the row's taps, inside 0 .. w h <=
                // data.len() by the bounds in the module docs; unaligned 128-bit loads.
                let r = ks.map(|k| unsafe { _mm_loadu_ps(base.offset(k as isize + jw)) });
                transpose8x4(&r)
            });
            // SAFETY: i + 8 <= n <= out.len(): eight floats writable at out[i..]; unaligned.
            _mm256_storeu_ps(out.as_mut_ptr().add(i), acc);
        }
        for k in 8 * groups..n {
            scalar(&pos[k], &mut out[k..k + 1]);
        }
    }

    /// See [`super::bicubic_f32`] with `NC = 2`: four positions at a time, two lanes each.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= 2 w h` and `2 w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bicubic_la_f32(
        data: &[f32],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [f32],
        scalar: &impl Fn(&[f64; 2], &mut [f32]),
    ) {
        let n = pos.len().min(out.len() / 2);
        let groups = n / 4;
        let xmax = _mm_set1_epi32(w as i32 - 3);
        let ymax = _mm_set1_epi32(h as i32 - 3);
        let base = data.as_ptr();
        for g in 0..groups {
            let i = 4 * g;
            // SAFETY: i + 4 <= n <= pos.len(): 8 contiguous f64.
            let (x0, y0, ok, fx4, fy4) = lanes4(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if !inside4(ok, x0, y0) {
                for k in i..i + 4 {
                    scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
                }
                continue;
            }
            let ks = corner4(x0, y0, w);
            let (wx, wy) = spread(&weights(_mm256_set_m128(fy4, fx4)), None);
            let acc = cubic(&wx, &wy, |j| {
                let jw = (j * w) as isize;
                // SAFETY: every lane passed 1 <= x0 <= w - 3, 1 <= y0 <= h - 3; the eight
                // floats read from 2 (k + j w) are the row's taps, inside 0 .. 2 w h <=
                // data.len() by the bounds in the module docs; unaligned 256-bit loads.
                let r = ks.map(|k| unsafe {
                    _mm256_castps_pd(_mm256_loadu_ps(base.offset(2 * (k as isize + jw))))
                });
                // [p0t0 p1t0 | p0t2 p1t2], [p0t1 p1t1 | p0t3 p1t3], likewise p2, p3.
                let (a, b) = (_mm256_unpacklo_pd(r[0], r[1]), _mm256_unpackhi_pd(r[0], r[1]));
                let (c, d) = (_mm256_unpacklo_pd(r[2], r[3]), _mm256_unpackhi_pd(r[2], r[3]));
                [
                    _mm256_permute2f128_pd::<0x20>(a, c),
                    _mm256_permute2f128_pd::<0x20>(b, d),
                    _mm256_permute2f128_pd::<0x31>(a, c),
                    _mm256_permute2f128_pd::<0x31>(b, d),
                ]
                .map(|v| _mm256_castpd_ps(v))
            });
            // SAFETY: i + 4 <= n <= out.len() / 2: eight floats writable at out[2 i..];
            // unaligned.
            _mm256_storeu_ps(out.as_mut_ptr().add(2 * i), acc);
        }
        for k in 4 * groups..n {
            scalar(&pos[k], &mut out[2 * k..2 * k + 2]);
        }
    }

    /// See [`super::bicubic_f32`] with `NC` = 3 or 4: four positions at a time, two pixels
    /// per vector, four lanes per pixel (RGB: the fourth lane's result is dropped).
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `NC` is 3 or 4; `data.len() >= NC w h` and `NC w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bicubic_color_f32<const NC: usize>(
        data: &[f32],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [f32],
        scalar: &impl Fn(&[f64; 2], &mut [f32]),
    ) {
        let n = pos.len().min(out.len() / NC);
        let groups = n / 4;
        let xmax = _mm_set1_epi32(w as i32 - 3);
        let ymax = _mm_set1_epi32(h as i32 - 3);
        // Where tap i's four floats are loaded in its row: RGB's last from one float early.
        let at = if NC == 3 { [0isize, 3, 6, 8] } else { [0isize, 4, 8, 12] };
        let base = data.as_ptr();
        let mut px = [0f32; 8];
        for g in 0..groups {
            let i = 4 * g;
            // SAFETY: i + 4 <= n <= pos.len(): 8 contiguous f64.
            let (x0, y0, ok, fx4, fy4) = lanes4(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if !inside4(ok, x0, y0) {
                for k in i..i + 4 {
                    scalar(&pos[k], &mut out[NC * k..NC * k + NC]);
                }
                continue;
            }
            let ks = corner4(x0, y0, w);
            let wxy = weights(_mm256_set_m128(fy4, fx4));
            for pair in 0..2 {
                let (wx, wy) = spread(&wxy, Some(pair));
                let (k0, k1) = (ks[2 * pair] as isize, ks[2 * pair + 1] as isize);
                let acc = cubic(&wx, &wy, |j| {
                    let (o0, o1) = (
                        NC as isize * (k0 + (j * w) as isize),
                        NC as isize * (k1 + (j * w) as isize),
                    );
                    // SAFETY: both lanes passed 1 <= x0 <= w - 3, 1 <= y0 <= h - 3; the four
                    // floats from NC (k + j w) + at[i] lie within the row's taps (RGB: the
                    // last at NC (k + j w) + 11), inside 0 .. NC w h <= data.len() by the
                    // bounds in the module docs; unaligned 128-bit loads.
                    let v = at.map(|a| unsafe {
                        _mm256_loadu2_m128(base.offset(o1 + a), base.offset(o0 + a))
                    });
                    if NC == 3 {
                        [v[0], v[1], v[2], _mm256_permute_ps::<0b11_11_10_01>(v[3])]
                    } else {
                        v
                    }
                });
                // SAFETY: `px` is eight floats; unaligned store.
                _mm256_storeu_ps(px.as_mut_ptr(), acc);
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
    use crate::warp::Interp::Bicubic;

    family!(Cubic16, u16, bicubic16);
    family!(CubicF32, f32, bicubic_f32);

    #[test]
    fn bicubic16_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<u16, Cubic16>(Bicubic, &[1, 2, 3, 4], 181, 2000);
    }

    #[test]
    fn bicubic_f32_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<f32, CubicF32>(Bicubic, &[1, 2, 3, 4], 191, 2000);
    }

    /// Signed zeros, ties, the border, infinities and `NaN` in either coordinate; for
    /// `f32`, images of `-0.0` and of `-0.0`, `+0.0`, `-1.0`, `1.0` mixed (where the order
    /// of the `lo`, `hi` fold and the sums from `+0.0` decide the sign of a zero).
    #[test]
    fn bicubic_wide_special_positions_match_the_scalar_path() {
        harness::special::<u16, Cubic16>(Bicubic, &[1, 2, 3, 4], 185);
        harness::special::<f32, CubicF32>(Bicubic, &[1, 2, 3, 4], 195);
    }

    /// The loads start on the image's first taps and end on its last (module docs).
    #[test]
    fn bicubic_wide_loads_at_the_corner_cells_stay_inside_the_image() {
        harness::bottom_right::<u16, Cubic16>(Bicubic, &[1, 2, 3, 4]);
        harness::bottom_right::<f32, CubicF32>(Bicubic, &[1, 2, 3, 4]);
    }

    /// Groups of eight (gray) and four (the others).
    #[test]
    fn bicubic_wide_interior_groups_take_the_vector_path() {
        harness::assert_vectorized::<u16, Cubic16>(Bicubic, &[1, 2, 3, 4]);
        harness::assert_vectorized::<f32, CubicF32>(Bicubic, &[1, 2, 3, 4]);
    }

    bit_identity_proptest!(
        bicubic16_bit_identical_on_random_images,
        u16,
        Cubic16,
        Bicubic,
        [1, 2, 3, 4],
        "Random 16-bit images of 1 to 4 channels (extreme values included) and random \
         positions, borders and outside included."
    );

    bit_identity_proptest!(
        bicubic_f32_bit_identical_on_random_images,
        f32,
        CubicF32,
        Bicubic,
        [1, 2, 3, 4],
        "Random float images of 1 to 4 channels (signed zeros, subnormals, huge values and \
         infinities included) and random positions, borders and outside included."
    );
}
