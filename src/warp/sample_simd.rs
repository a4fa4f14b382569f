//! Bilinear resampling of 8- and 16-bit gray images, eight pixels at a time (x86_64 AVX2).
//! Where the CPU has AVX-512 with VBMI, 8-bit gray runs sixteen at a time
//! ([`super::sample_simd512`], same arithmetic, bit-identical, which also chooses between
//! the two), handing the groups it cannot take to the AVX2 kernel here.
//!
//! The 16-bit path ([`bilinear_gray16`]) is the same arithmetic with 16-bit taps and the
//! clamp at 65535; its tap layout is in its docs. Gray + alpha and colour images:
//! [`super::sample_simd_color`] (8-bit), [`super::sample_simd_color16`] (16-bit); `f32`
//! images: [`super::sample_simd_float`]; bicubic, 1 to 4 channels: 8-bit
//! [`super::sample_simd_cubic`], 16-bit and `f32` [`super::sample_simd_cubic_wide`];
//! nearest (every type): [`super::sample_simd_nearest`]. Their tests share `simd_harness`.
//! What they share is in this module: the check every safe wrapper makes before it calls
//! an AVX2 kernel ([`avx2_fits`]) and the lane helpers ([`avx2::lanes8`],
//! [`avx2::lanes4`], [`avx2::floor`], [`avx2::bilerp`], [`avx2::round_clamp`]).
//!
//! The scalar path ([`super::sample::fill_pixels`]) computes, for a position `(x, y)` with
//! `x0 = floor(x)`, `y0 = floor(y)`, `fx = (x - x0) as f32`, `fy = (y - y0) as f32` and the
//! taps `a = I(x0, y0)`, `b = I(x0 + 1, y0)`, `e = I(x0, y0 + 1)`, `f = I(x0 + 1, y0 + 1)`:
//!
//! ```text
//!   t = a + (b - a) fx,   u = e + (f - e) fx,   v = t + (u - t) fy,
//!   out = trunc(clamp(v + 0.5, 0, 255))
//! ```
//!
//! in `f32`, each operation rounded (no fused multiply-add). The vector path here does the
//! same operations in the same order on eight lanes: the floors and fractions in `f64`
//! (`vroundpd`, exact subtraction, then one rounding to `f32` as `as f32` does), the
//! interpolation in `f32` with separate multiplies and adds, the final conversion by
//! truncation. So its output is bit-identical to the scalar path's. The floor adds `+0.0`
//! to `vroundpd`'s result ([`avx2::floor`]), because `fast_floor(-0.0)` is `+0.0`: so the
//! fraction at `x = -0.0` is `-0.0` on both paths, which `f32` samples of `-0.0` can tell
//! from `+0.0` (for integer samples the sign of a zero is lost in the rounding anyway).
//!
//! **Taps.** With `k = y0 w + x0` (the image is `w x h`, one byte per pixel, row-major),
//! the two top taps are bytes `k, k + 1` and the two bottom taps are bytes `k + w, k + w + 1`.
//! Each lane gathers the 32-bit word at byte `k` (taps `a, b` in its low two bytes) and the
//! word at byte `k + w - 2` (taps `e, f` in its high two bytes). A group of eight is taken on
//! the vector path only when every lane has `0 <= x0 < w - 1` and `0 <= y0 < h - 1` (so
//! `w, h >= 2`); then both words lie inside the image:
//!
//! ```text
//!   k + 3       <= (h - 2) w + (w - 2) + 3 = (h - 1) w + 1 <= h w - 1      (w >= 2)
//!   k + w - 2   >= 0                                                      (w >= 2)
//!   k + w + 1   <= (h - 2) w + (w - 2) + w + 1 = h w - 1
//! ```
//!
//! Any other group (a position outside the mesh, `NaN`, or a neighbourhood crossing the
//! image border) is done pixel by pixel by the scalar path, as is the tail of fewer than
//! eight pixels. Out-of-range and `NaN` coordinates convert to `i32::MIN` and so fail the
//! test.
//!
//! **Windows** (8-bit gray). The consecutive pixels of a smooth map read neighbourhoods
//! close together, and two gathers cost more than the arithmetic of a group. So when the
//! eight lanes have `x0 - xm <= 14` and `y0 - ym <= 1` (`xm`, `ym` the lanes' minima), the
//! taps come from 16-byte windows of the rows `ym`, `ym + 1` (and `ym + 2` when some lane
//! has `y0 = ym + 1`), each starting at column `xm`, by byte shuffles (`vpshufb`, each lane's
//! indices `[d, d + 1, d, d + 1]` with `d = x0 - xm <= 14`, so at most 15: inside the
//! window). A lane of row `y0 = ym + r` takes its top taps from window `r` and its bottom
//! taps from window `r + 1`, the bytes `y0 w + x0 + {0, 1}` and `(y0 + 1) w + x0 + {0, 1}`:
//! the gathered taps, so the result is the same. The windows are bytes
//! `s .. s + 16`, `s + w .. s + w + 16` (and `s + 2w .. s + 2w + 16`) with `s = ym w + xm >= 0`;
//! they are read only when the last ends at most at `data.len()`, otherwise the group
//! gathers. A window may run past the end of its row into the next one: those bytes are
//! never selected (every lane has `x0 + 1 <= w - 1`).

/// Whether the AVX2 kernels of `sample_simd*` may run on a `w x h` image of `nc` samples
/// per pixel held in a buffer of `len` samples: the CPU has AVX2 (detected at run time),
/// `w, h >= 1`, `nc w h <= len` and `nc w h < 2^31` (so every sample offset, and every byte
/// offset scaled by the gathers, fits in `i32`). Each kernel's safe wrapper calls into its
/// `avx2` module only when this holds, and its `SAFETY` comment cites it.
#[cfg(target_arch = "x86_64")]
pub(super) fn avx2_fits(len: usize, w: usize, h: usize, nc: usize) -> bool {
    let n = w.checked_mul(h).and_then(|n| n.checked_mul(nc));
    w >= 1
        && h >= 1
        && n.is_some_and(|n| n <= len && n < i32::MAX as usize)
        && std::arch::is_x86_feature_detected!("avx2")
}

/// Fills `out[i]` for every position `pos[i]` (`i < min(pos.len(), out.len())`) of a
/// `w x h` gray image `data` by bilinear interpolation, eight pixels at a time (the AVX2
/// kernel), with `scalar(p)` giving the value of the pixels the vector path does not take.
/// Returns `false` (and writes nothing) when the vector path is not available: not x86_64,
/// no AVX2, or an image too large for 32-bit offsets. The entry point that also takes the
/// AVX-512 kernel is [`super::sample_simd512::bilinear_gray8`].
pub(super) fn bilinear_gray8_avx2(
    data: &[u8],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [u8],
    scalar: impl Fn(&[f64; 2]) -> u8,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if avx2_fits(data.len(), w, h, 1) {
        // SAFETY: AVX2 is available and `data` holds at least `w h < 2^31` bytes
        // (`avx2_fits`), as `avx2::bilinear_gray8` requires.
        unsafe { avx2::bilinear_gray8(data, w, h, pos, out, &scalar) };
        return true;
    }
    let _ = (data, w, h, pos, out, scalar);
    false
}

/// Fills `out[i]` for every position `pos[i]` (`i < min(pos.len(), out.len())`) of a
/// `w x h` 16-bit gray image `data` by bilinear interpolation, as [`bilinear_gray8`] does
/// for 8-bit images, with `scalar(p)` for the pixels the vector path does not take.
/// Returns `false` (and writes nothing) when the vector path is not available.
///
/// **Taps.** With `k = y0 w + x0`, each lane gathers the 32-bit word at sample `k` (taps
/// `a, b` in its low and high halves) and the word at sample `k + w` (taps `e, f`). When
/// `0 <= x0 <= w - 2` and `0 <= y0 <= h - 2` both words lie inside the image: the last
/// sample read is `k + w + 1 <= (h - 2) w + (w - 2) + w + 1 = h w - 1`. Byte offsets are
/// `2 k`, so the gather scale is 2 and `k` itself must fit in `i32` (`w h < 2^31`).
pub(super) fn bilinear_gray16(
    data: &[u16],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [u16],
    scalar: impl Fn(&[f64; 2]) -> u16,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if avx2_fits(data.len(), w, h, 1) {
        // SAFETY: AVX2 is available and `data` holds at least `w h < 2^31` samples
        // (`avx2_fits`), as `avx2::bilinear_gray16` requires.
        unsafe { avx2::bilinear_gray16(data, w, h, pos, out, &scalar) };
        return true;
    }
    let _ = (data, w, h, pos, out, scalar);
    false
}

#[cfg(target_arch = "x86_64")]
pub(super) mod avx2 {
    use std::arch::x86_64::*;

    /// See [`super::bilinear_gray8_avx2`].
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= w h` and `w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(in crate::warp) unsafe fn bilinear_gray8(
        data: &[u8],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u8],
        scalar: &impl Fn(&[f64; 2]) -> u8,
    ) {
        let n = pos.len().min(out.len());
        let groups = n / 8;
        // Lane bounds: x0 <= w - 2 and y0 <= h - 2, i.e. x0 < w - 1 and y0 < h - 1. With
        // w h < 2^31 both fit in i32 (and are -1 when the image is one pixel wide or high,
        // rejecting every lane).
        let xmax = _mm256_set1_epi32(w as i32 - 2);
        let ymax = _mm256_set1_epi32(h as i32 - 2);
        let wv = _mm256_set1_epi32(w as i32);
        let below = _mm256_set1_epi32(w as i32 - 2);
        let byte = _mm256_set1_epi32(0xff);
        let top = _mm256_set1_ps(255.0);
        let base = data.as_ptr() as *const i32;
        for g in 0..groups {
            let i = 8 * g;
            // SAFETY: i + 8 <= n <= pos.len(): 16 f64 for 8 contiguous positions.
            let (x0, y0, ok, fx, fy) = lanes8(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if _mm256_movemask_ps(_mm256_castsi256_ps(ok)) != 0xff {
                for k in i..i + 8 {
                    out[k] = scalar(&pos[k]);
                }
                continue;
            }
            // SAFETY: every lane passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2 (so w, h >= 2),
            // as `window8` requires.
            let (wt, wb) = match window8(data, w, x0, y0) {
                Some(taps) => taps,
                None => {
                    let k = _mm256_add_epi32(_mm256_mullo_epi32(y0, wv), x0);
                    // SAFETY: every lane passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2 (so
                    // w, h >= 2); the words read are bytes k .. k + 3 and
                    // k + w - 2 .. k + w + 1, inside 0 .. w h <= data.len() by the bounds
                    // in the module docs.
                    (
                        _mm256_i32gather_epi32::<1>(base, k),
                        _mm256_i32gather_epi32::<1>(base, _mm256_add_epi32(k, below)),
                    )
                }
            };
            let a = _mm256_cvtepi32_ps(_mm256_and_si256(wt, byte));
            let b = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32::<8>(wt), byte));
            let e = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32::<16>(wb), byte));
            let f = _mm256_cvtepi32_ps(_mm256_srli_epi32::<24>(wb));
            let r = round_clamp(bilerp(a, b, e, f, fx, fy), top);
            // 8 x i32 in 0..=255 -> bytes: per 128-bit lane, r0..r3 (resp. r4..r7) in the
            // low four bytes.
            let r16 = _mm256_packus_epi32(r, r);
            let r8 = _mm256_packus_epi16(r16, r16);
            let lo = _mm_cvtsi128_si32(_mm256_castsi256_si128(r8)) as u32;
            let hi = _mm_cvtsi128_si32(_mm256_extracti128_si256::<1>(r8)) as u32;
            let bytes = (lo as u64 | (hi as u64) << 32).to_le_bytes();
            out[i..i + 8].copy_from_slice(&bytes);
        }
        for k in 8 * groups..n {
            out[k] = scalar(&pos[k]);
        }
    }

    /// The minimum of the eight lanes, in every lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn min8(v: __m256i) -> __m256i {
        let m = _mm256_min_epi32(v, _mm256_permute2x128_si256::<1>(v, v));
        let m = _mm256_min_epi32(m, _mm256_shuffle_epi32::<0b01_00_11_10>(m));
        _mm256_min_epi32(m, _mm256_shuffle_epi32::<0b10_11_00_01>(m))
    }

    /// The taps of [`bilinear_gray8`] from two or three 16-byte row windows instead of two
    /// gathers, when the eight neighbourhoods are close together, as they are for the
    /// consecutive pixels of a smooth map (module docs, **Windows**): the words `(wt, wb)`
    /// with `a, b` in bytes 0, 1 of `wt` and `e, f` in bytes 2, 3 of `wb`, the bytes the
    /// gathers would give there. `None` when the lanes are too far apart or a window would
    /// end past `data`.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2, and every lane has `0 <= x0 <= w - 2`, `0 <= y0 <= h - 2`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn window8(
        data: &[u8],
        w: usize,
        x0: __m256i,
        y0: __m256i,
    ) -> Option<(__m256i, __m256i)> {
        let (xm, ym) = (min8(x0), min8(y0));
        let (d, e) = (_mm256_sub_epi32(x0, xm), _mm256_sub_epi32(y0, ym));
        let far = _mm256_or_si256(
            _mm256_cmpgt_epi32(d, _mm256_set1_epi32(14)),
            _mm256_cmpgt_epi32(e, _mm256_set1_epi32(1)),
        );
        if _mm256_movemask_epi8(far) != 0 {
            return None;
        }
        let lower = _mm256_cmpeq_epi32(e, _mm256_set1_epi32(1));
        let two_rows = _mm256_movemask_epi8(lower) != 0;
        // Lanes are non-negative (caller), so the minima are too.
        let (xs, ys) = (_mm256_cvtsi256_si32(xm) as usize, _mm256_cvtsi256_si32(ym) as usize);
        let start = ys * w + xs;
        let last = start + if two_rows { 2 * w } else { w } + 16;
        if last > data.len() {
            return None;
        }
        let p = data.as_ptr().add(start);
        // SAFETY: the windows are bytes start .. start + 16 of rows ys, ys + 1 (and ys + 2
        // when two_rows), all below `last <= data.len()`.
        let row =
            |r: usize| _mm256_broadcastsi128_si256(_mm_loadu_si128(p.add(r * w) as *const __m128i));
        // Lane index bytes [d, d + 1, d, d + 1]: byte 0 of each lane to all four, plus
        // 0x01000100. With d <= 14 every index is at most 15, inside the 16-byte window.
        let spread = _mm256_setr_epi8(
            0, 0, 0, 0, 4, 4, 4, 4, 8, 8, 8, 8, 12, 12, 12, 12, 0, 0, 0, 0, 4, 4, 4, 4, 8, 8, 8, 8,
            12, 12, 12, 12,
        );
        let idx = _mm256_add_epi32(_mm256_shuffle_epi8(d, spread), _mm256_set1_epi32(0x0100_0100));
        let (r0, r1) = (row(0), row(1));
        let (t0, t1) = (_mm256_shuffle_epi8(r0, idx), _mm256_shuffle_epi8(r1, idx));
        if !two_rows {
            return Some((t0, t1));
        }
        let t2 = _mm256_shuffle_epi8(row(2), idx);
        Some((_mm256_blendv_epi8(t0, t1, lower), _mm256_blendv_epi8(t1, t2, lower)))
    }

    /// The scalar `fast_floor` on four lanes: `floor(v) + 0`, which is `floor(v)` except
    /// that `floor(-0.0) = -0.0` becomes `+0.0`, as the integer round trip of `fast_floor`
    /// makes it. The sign matters: the fraction `v - floor(v)` of `v = -0.0` is then `-0.0`
    /// as in the scalar path (not `+0.0`), and with `f32` samples of `-0.0` the sign of the
    /// fraction reaches the sign of a zero result.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) fn floor(v: __m256d) -> __m256d {
        _mm256_add_pd(_mm256_floor_pd(v), _mm256_setzero_pd())
    }

    /// Four positions `[x0, y0, x1, y1, ...]` at `pp` as `([x0 x1 x2 x3], [y0 y1 y2 y3])`:
    /// two unaligned loads, then unpack (`[x0 x2 x1 x3]`) and a lane permute.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `pp` points to 8 readable `f64`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) unsafe fn xy4(pp: *const f64) -> (__m256d, __m256d) {
        // SAFETY: 8 f64 readable at pp (caller); unaligned loads.
        let (v0, v1) = (_mm256_loadu_pd(pp), _mm256_loadu_pd(pp.add(4)));
        (
            _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_unpacklo_pd(v0, v1)),
            _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_unpackhi_pd(v0, v1)),
        )
    }

    /// Eight positions: `x0`, `y0` (i32), the lanes that may take the vector path (all
    /// bits set where `0 <= x0 <= xmax` and `0 <= y0 <= ymax`), and `fx`, `fy` (f32), as
    /// in [`bilinear_gray8`] (the floors by [`floor`]).
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `pp` points to 16 readable `f64`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) unsafe fn lanes8(
        pp: *const f64,
        xmax: __m256i,
        ymax: __m256i,
    ) -> (__m256i, __m256i, __m256i, __m256, __m256) {
        let minus1 = _mm256_set1_epi32(-1);
        // SAFETY: 16 f64 readable at pp (caller), 8 at each of pp and pp + 8.
        let ((xa, ya), (xb, yb)) = (xy4(pp), xy4(pp.add(8)));
        let (fxa, fya) = (floor(xa), floor(ya));
        let (fxb, fyb) = (floor(xb), floor(yb));
        let x0 = _mm256_set_m128i(_mm256_cvttpd_epi32(fxb), _mm256_cvttpd_epi32(fxa));
        let y0 = _mm256_set_m128i(_mm256_cvttpd_epi32(fyb), _mm256_cvttpd_epi32(fya));
        let ok = _mm256_and_si256(
            _mm256_and_si256(_mm256_cmpgt_epi32(x0, minus1), _mm256_cmpgt_epi32(y0, minus1)),
            _mm256_andnot_si256(
                _mm256_or_si256(_mm256_cmpgt_epi32(x0, xmax), _mm256_cmpgt_epi32(y0, ymax)),
                minus1,
            ),
        );
        let fx = _mm256_set_m128(
            _mm256_cvtpd_ps(_mm256_sub_pd(xb, fxb)),
            _mm256_cvtpd_ps(_mm256_sub_pd(xa, fxa)),
        );
        let fy = _mm256_set_m128(
            _mm256_cvtpd_ps(_mm256_sub_pd(yb, fyb)),
            _mm256_cvtpd_ps(_mm256_sub_pd(ya, fya)),
        );
        (x0, y0, ok, fx, fy)
    }

    /// Four positions: `x0`, `y0` (i32), the lanes that may take the vector path (all bits
    /// set where `0 <= x0 <= xmax` and `0 <= y0 <= ymax`), and `fx`, `fy` (f32), as
    /// [`lanes8`] does for eight.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `pp` points to 8 readable `f64`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) unsafe fn lanes4(
        pp: *const f64,
        xmax: __m128i,
        ymax: __m128i,
    ) -> (__m128i, __m128i, __m128i, __m128, __m128) {
        let minus1 = _mm_set1_epi32(-1);
        // SAFETY: 8 f64 readable at pp (caller).
        let (xs, ys) = xy4(pp);
        let (fxs, fys) = (floor(xs), floor(ys));
        let (x0, y0) = (_mm256_cvttpd_epi32(fxs), _mm256_cvttpd_epi32(fys));
        let ok = _mm_and_si128(
            _mm_and_si128(_mm_cmpgt_epi32(x0, minus1), _mm_cmpgt_epi32(y0, minus1)),
            _mm_andnot_si128(
                _mm_or_si128(_mm_cmpgt_epi32(x0, xmax), _mm_cmpgt_epi32(y0, ymax)),
                minus1,
            ),
        );
        let fx = _mm256_cvtpd_ps(_mm256_sub_pd(xs, fxs));
        let fy = _mm256_cvtpd_ps(_mm256_sub_pd(ys, fys));
        (x0, y0, ok, fx, fy)
    }

    /// The scalar path's interpolation on eight lanes: `t = a + (b - a) fx`,
    /// `u = e + (f - e) fx`, `v = t + (u - t) fy`, each operation rounded to `f32` (separate
    /// multiplies and adds, no fused multiply-add).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) fn bilerp(
        a: __m256,
        b: __m256,
        e: __m256,
        f: __m256,
        fx: __m256,
        fy: __m256,
    ) -> __m256 {
        let t = _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), fx));
        let u = _mm256_add_ps(e, _mm256_mul_ps(_mm256_sub_ps(f, e), fx));
        _mm256_add_ps(t, _mm256_mul_ps(_mm256_sub_ps(u, t), fy))
    }

    /// `Texel::from_f32` for integer samples on eight lanes: `trunc(clamp(v + 0.5, 0, top))`
    /// as i32 (a `NaN` lane gives 0, as `NaN as u8` does: `max` returns its second operand).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) fn round_clamp(v: __m256, top: __m256) -> __m256i {
        let v = _mm256_max_ps(_mm256_add_ps(v, _mm256_set1_ps(0.5)), _mm256_setzero_ps());
        _mm256_cvttps_epi32(_mm256_min_ps(v, top))
    }

    /// See [`super::bilinear_gray16`].
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= w h` and `w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bilinear_gray16(
        data: &[u16],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u16],
        scalar: &impl Fn(&[f64; 2]) -> u16,
    ) {
        let n = pos.len().min(out.len());
        let groups = n / 8;
        let xmax = _mm256_set1_epi32(w as i32 - 2);
        let ymax = _mm256_set1_epi32(h as i32 - 2);
        let wv = _mm256_set1_epi32(w as i32);
        let low = _mm256_set1_epi32(0xffff);
        let top = _mm256_set1_ps(65535.0);
        let base = data.as_ptr() as *const i32;
        for g in 0..groups {
            let i = 8 * g;
            // SAFETY: i + 8 <= n <= pos.len(): 16 f64 for 8 contiguous positions.
            let (x0, y0, ok, fx, fy) = lanes8(pos.as_ptr().add(i) as *const f64, xmax, ymax);
            if _mm256_movemask_ps(_mm256_castsi256_ps(ok)) != 0xff {
                for k in i..i + 8 {
                    out[k] = scalar(&pos[k]);
                }
                continue;
            }
            let k = _mm256_add_epi32(_mm256_mullo_epi32(y0, wv), x0);
            // SAFETY: every lane passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2; the words read
            // are samples k, k + 1 and k + w, k + w + 1, inside 0 .. w h <= data.len()
            // (function docs); byte offsets 2 k (scale 2), k < 2^31.
            let wt = _mm256_i32gather_epi32::<2>(base, k);
            let wb = _mm256_i32gather_epi32::<2>(base, _mm256_add_epi32(k, wv));
            let a = _mm256_cvtepi32_ps(_mm256_and_si256(wt, low));
            let b = _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(wt));
            let e = _mm256_cvtepi32_ps(_mm256_and_si256(wb, low));
            let f = _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(wb));
            let r = round_clamp(bilerp(a, b, e, f, fx, fy), top);
            // 8 x i32 in 0..=65535 -> u16: per 128-bit lane r0..r3 (r4..r7) in the low
            // 64 bits; gather those two halves into the low 128 bits.
            let r16 = _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_packus_epi32(r, r));
            // SAFETY: i + 8 <= n <= out.len(): eight u16 writable at out[i..]; unaligned.
            _mm_storeu_si128(out.as_mut_ptr().add(i) as *mut __m128i, _mm256_castsi256_si128(r16));
        }
        for k in 8 * groups..n {
            out[k] = scalar(&pos[k]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp::simd_harness::{self as harness, bit_identity_proptest, family};
    use crate::warp::Interp::Bilinear;

    // The AVX2 kernel alone (the AVX-512 one and the choice between them: `sample_simd512`).
    family!(Gray8Avx2, u8, bilinear_gray8_avx2, gray);
    family!(Gray16, u16, bilinear_gray16, gray);

    #[test]
    fn vector_path_matches_the_scalar_path_bit_for_bit() {
        harness::sweep::<u8, Gray8Avx2>(Bilinear, &[1], 5, 2000);
    }

    #[test]
    fn gray16_vector_path_matches_the_scalar_path_bit_for_bit() {
        harness::sweep::<u16, Gray16>(Bilinear, &[1], 16, 2000);
    }

    /// Rows of a smooth map, where the 8-bit kernel loads row windows instead of gathering
    /// (module docs, **Windows**): one or two source rows, near or too far apart, up to the
    /// image's last bytes.
    #[test]
    fn row_windows_match_the_scalar_path() {
        harness::smooth_rows::<u8, Gray8Avx2>(Bilinear, &[1], 41);
        harness::smooth_rows::<u16, Gray16>(Bilinear, &[1], 43);
    }

    /// Signed zeros, ties, the border, infinities and `NaN` in either coordinate.
    #[test]
    fn special_positions_match_the_scalar_path() {
        harness::special::<u8, Gray8Avx2>(Bilinear, &[1], 6);
        harness::special::<u16, Gray16>(Bilinear, &[1], 17);
    }

    /// The last bytes (samples) read are the image's last (module docs).
    #[test]
    fn loads_at_the_bottom_right_cell_stay_inside_the_image() {
        harness::bottom_right::<u8, Gray8Avx2>(Bilinear, &[1]);
        harness::bottom_right::<u16, Gray16>(Bilinear, &[1]);
    }

    #[test]
    fn interior_groups_take_the_vector_path() {
        harness::assert_vectorized::<u8, Gray8Avx2>(Bilinear, &[1]);
        harness::assert_vectorized::<u16, Gray16>(Bilinear, &[1]);
    }

    bit_identity_proptest!(
        gray16_bit_identical_on_random_images,
        u16,
        Gray16,
        Bilinear,
        [1],
        "Random 16-bit images (extreme values included) and random positions."
    );

    bit_identity_proptest!(
        gray8_avx2_bit_identical_on_random_images,
        u8,
        Gray8Avx2,
        Bilinear,
        [1],
        "Random 8-bit images and random positions, the AVX2 kernel alone."
    );
}
