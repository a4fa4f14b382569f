//! Bilinear resampling of 8-bit gray images sixteen pixels at a time (x86_64 AVX-512 with
//! VBMI), the wider form of [`super::sample_simd::bilinear_gray8_avx2`], and
//! [`bilinear_gray8`], which runs it where the CPU allows and the AVX2 kernel elsewhere.
//!
//! **Arithmetic.** The same as the AVX2 kernel's and the scalar path's (see
//! [`super::sample_simd`]): floors in `f64` (`vrndscalepd` towards minus infinity, plus
//! `+0.0` so that `-0.0` floors to `+0.0` as `fast_floor` does), fractions by exact
//! subtraction rounded once to `f32`, the interpolation `t = a + (b - a) fx`,
//! `u = e + (f - e) fx`, `v = t + (u - t) fy` in `f32` with separate multiplies and adds,
//! and `trunc(clamp(v + 0.5, 0, 255))`. So the output is bit-identical to both.
//!
//! **Lanes.** A group of sixteen positions takes the vector path only when every lane has
//! `0 <= x0 <= w - 2` and `0 <= y0 <= h - 2` (so `w, h >= 2`); any other group, and the
//! tail of fewer than sixteen, goes to the AVX2 kernel (which takes its groups of eight or
//! hands them to the scalar path).
//!
//! **Taps.** With `xm`, `ym` the lanes' minima, `d = x0 - xm` and `e = y0 - ym`: when
//! `d <= 62` and `e <= 1` in every lane, the taps come from 64-byte windows of the rows
//! `ym`, `ym + 1` (and `ym + 2` when some lane has `e = 1`) starting at column `xm`, by byte
//! permutes (`vpermb`, each lane's indices `[d, d + 1, d, d + 1]`, at most 63: inside the
//! window). A lane of row `ym + e` takes its top taps `a, b` from window `e` and its bottom
//! taps `e, f` from window `e + 1`: the bytes `y0 w + x0 + {0, 1}` and
//! `(y0 + 1) w + x0 + {0, 1}`. The windows are bytes `s .. s + 64`, `s + w .. s + w + 64`
//! (and `s + 2w .. s + 2w + 64`), `s = ym w + xm >= 0`; they are read only when the last one
//! ends at most at `data.len()`. A window may run past the end of its row into the next:
//! those bytes are never selected (every lane has `x0 + 1 <= w - 1`). Otherwise each lane
//! gathers the words at bytes `k = y0 w + x0` and `k + w - 2`, as the AVX2 kernel does
//! (inside the image by the bounds in [`super::sample_simd`]'s docs, with `w h < 2^31`).

/// Fills `out[i]` for every position `pos[i]` (`i < min(pos.len(), out.len())`) of a
/// `w x h` gray image `data` by bilinear interpolation, with `scalar(p)` giving the value of
/// the pixels the vector path does not take: sixteen at a time where the CPU has AVX-512
/// ([`avx512_fits`]), else eight ([`super::sample_simd::bilinear_gray8_avx2`]). Returns `false` (and writes nothing) when the
/// vector path is not available: not x86_64, no AVX2, or an image too large for 32-bit
/// offsets.
pub(super) fn bilinear_gray8(
    data: &[u8],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [u8],
    scalar: impl Fn(&[f64; 2]) -> u8,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if avx512_fits(data.len(), w, h) {
        // SAFETY: AVX2 and AVX-512 F, BW, DQ, VL, VBMI are available and `data` holds at
        // least `w h < 2^31` bytes (`avx512_fits`), as the AVX-512 kernel requires.
        unsafe { avx512::bilinear_gray8(data, w, h, pos, out, &scalar) };
        return true;
    }
    super::sample_simd::bilinear_gray8_avx2(data, w, h, pos, out, scalar)
}

/// Whether the AVX-512 kernel may run: the CPU has AVX-512 F, BW, DQ, VL and VBMI (detected
/// at run time) besides what [`super::sample_simd::avx2_fits`] requires.
#[cfg(target_arch = "x86_64")]
pub(super) fn avx512_fits(len: usize, w: usize, h: usize) -> bool {
    super::sample_simd::avx2_fits(len, w, h, 1)
        && std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512dq")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512vbmi")
}

#[cfg(target_arch = "x86_64")]
pub(super) mod avx512 {
    use std::arch::x86_64::*;

    /// [`crate::warp::sample_simd::bilinear_gray8_avx2`] sixteen pixels at a time (module docs);
    /// groups it cannot take, and the tail, go to the AVX2 kernel.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2 and AVX-512 F, BW, DQ, VL and VBMI; `data.len() >= w h` and
    /// `w h < 2^31` ([`super::avx512_fits`]).
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512dq,avx512vl,avx512vbmi")]
    pub(in crate::warp) unsafe fn bilinear_gray8(
        data: &[u8],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u8],
        scalar: &impl Fn(&[f64; 2]) -> u8,
    ) {
        use crate::warp::sample_simd::avx2::bilinear_gray8 as eight;
        let n = pos.len().min(out.len());
        let xmax = _mm512_set1_epi32(w as i32 - 2);
        let ymax = _mm512_set1_epi32(h as i32 - 2);
        let minus1 = _mm512_set1_epi32(-1);
        let wv = _mm512_set1_epi32(w as i32);
        let below = _mm512_set1_epi32(w as i32 - 2);
        let byte = _mm512_set1_epi32(0xff);
        let top = _mm512_set1_ps(255.0);
        let half = _mm512_set1_ps(0.5);
        let even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
        let odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
        let base = data.as_ptr() as *const i32;
        let mut i = 0;
        while i + 16 <= n {
            // SAFETY: i + 16 <= n <= pos.len(): 32 f64 readable at pos[i..].
            let pp = pos.as_ptr().add(i) as *const f64;
            let (v0, v1) = (_mm512_loadu_pd(pp), _mm512_loadu_pd(pp.add(8)));
            let (v2, v3) = (_mm512_loadu_pd(pp.add(16)), _mm512_loadu_pd(pp.add(24)));
            let (xa, ya) =
                (_mm512_permutex2var_pd(v0, even, v1), _mm512_permutex2var_pd(v0, odd, v1));
            let (xb, yb) =
                (_mm512_permutex2var_pd(v2, even, v3), _mm512_permutex2var_pd(v2, odd, v3));
            let zero = _mm512_setzero_pd();
            let floor = |v: __m512d| {
                _mm512_add_pd(_mm512_roundscale_pd::<{ _MM_FROUND_TO_NEG_INF }>(v), zero)
            };
            let (fxa, fya, fxb, fyb) = (floor(xa), floor(ya), floor(xb), floor(yb));
            let join_i =
                |lo: __m256i, hi: __m256i| _mm512_inserti64x4::<1>(_mm512_castsi256_si512(lo), hi);
            let join_f =
                |lo: __m256, hi: __m256| _mm512_insertf32x8::<1>(_mm512_castps256_ps512(lo), hi);
            let x0 = join_i(_mm512_cvttpd_epi32(fxa), _mm512_cvttpd_epi32(fxb));
            let y0 = join_i(_mm512_cvttpd_epi32(fya), _mm512_cvttpd_epi32(fyb));
            let ok = _mm512_cmpgt_epi32_mask(x0, minus1)
                & _mm512_cmpgt_epi32_mask(y0, minus1)
                & _mm512_cmple_epi32_mask(x0, xmax)
                & _mm512_cmple_epi32_mask(y0, ymax);
            if ok != 0xffff {
                // SAFETY: as this function's contract (the AVX2 kernel's is a subset).
                eight(data, w, h, &pos[i..i + 16], &mut out[i..i + 16], scalar);
                i += 16;
                continue;
            }
            let fx = join_f(
                _mm512_cvtpd_ps(_mm512_sub_pd(xa, fxa)),
                _mm512_cvtpd_ps(_mm512_sub_pd(xb, fxb)),
            );
            let fy = join_f(
                _mm512_cvtpd_ps(_mm512_sub_pd(ya, fya)),
                _mm512_cvtpd_ps(_mm512_sub_pd(yb, fyb)),
            );
            // SAFETY: every lane passed 0 <= x0 <= w - 2, 0 <= y0 <= h - 2.
            let (wt, wb) = match window16(data, w, x0, y0) {
                Some(taps) => taps,
                None => {
                    let k = _mm512_add_epi32(_mm512_mullo_epi32(y0, wv), x0);
                    // SAFETY: the words at bytes k .. k + 3 and k + w - 2 .. k + w + 1 lie
                    // inside 0 .. w h <= data.len() (module docs).
                    (
                        _mm512_i32gather_epi32::<1>(k, base),
                        _mm512_i32gather_epi32::<1>(_mm512_add_epi32(k, below), base),
                    )
                }
            };
            let a = _mm512_cvtepi32_ps(_mm512_and_si512(wt, byte));
            let b = _mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32::<8>(wt), byte));
            let e = _mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32::<16>(wb), byte));
            let f = _mm512_cvtepi32_ps(_mm512_srli_epi32::<24>(wb));
            let t = _mm512_add_ps(a, _mm512_mul_ps(_mm512_sub_ps(b, a), fx));
            let u = _mm512_add_ps(e, _mm512_mul_ps(_mm512_sub_ps(f, e), fx));
            let v = _mm512_add_ps(t, _mm512_mul_ps(_mm512_sub_ps(u, t), fy));
            let v = _mm512_max_ps(_mm512_add_ps(v, half), _mm512_setzero_ps());
            let r = _mm512_cvttps_epi32(_mm512_min_ps(v, top));
            // SAFETY: i + 16 <= n <= out.len(): 16 bytes writable at out[i..]; unaligned.
            _mm_storeu_si128(out.as_mut_ptr().add(i) as *mut __m128i, _mm512_cvtepi32_epi8(r));
            i += 16;
        }
        // SAFETY: as above.
        eight(data, w, h, &pos[i..n], &mut out[i..n], scalar);
    }

    /// The taps `(wt, wb)` of sixteen lanes from 64-byte row windows (module docs,
    /// **Taps**), or `None` when the lanes are too far apart or a window would end past
    /// `data`.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX-512 F, BW and VBMI, and every lane has `0 <= x0 <= w - 2`,
    /// `0 <= y0 <= h - 2`.
    #[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
    #[inline]
    unsafe fn window16(
        data: &[u8],
        w: usize,
        x0: __m512i,
        y0: __m512i,
    ) -> Option<(__m512i, __m512i)> {
        let (xs, ys) = (_mm512_reduce_min_epi32(x0), _mm512_reduce_min_epi32(y0));
        let d = _mm512_sub_epi32(x0, _mm512_set1_epi32(xs));
        let e = _mm512_sub_epi32(y0, _mm512_set1_epi32(ys));
        let far = _mm512_cmpgt_epi32_mask(d, _mm512_set1_epi32(62))
            | _mm512_cmpgt_epi32_mask(e, _mm512_set1_epi32(1));
        if far != 0 {
            return None;
        }
        let lower = _mm512_cmpeq_epi32_mask(e, _mm512_set1_epi32(1));
        // Lanes are non-negative (caller), so the minima are too.
        let start = ys as usize * w + xs as usize;
        let last = start + if lower != 0 { 2 * w } else { w } + 64;
        if last > data.len() {
            return None;
        }
        let p = data.as_ptr().add(start);
        // SAFETY: the windows are bytes start .. start + 64 of rows ys, ys + 1 (and ys + 2
        // when some lane is in the lower row), all below `last <= data.len()`.
        let row = |r: usize| _mm512_loadu_si512(p.add(r * w) as *const _);
        // Each lane's index bytes [d, d + 1, d, d + 1] (d <= 62): byte 0 of the lane to all
        // four, plus 0x01000100.
        let spread = _mm512_set4_epi32(0x0c0c_0c0c, 0x0808_0808, 0x0404_0404, 0);
        let idx = _mm512_add_epi32(_mm512_shuffle_epi8(d, spread), _mm512_set1_epi32(0x0100_0100));
        let (r0, r1) = (row(0), row(1));
        let (t0, t1) = (_mm512_permutexvar_epi8(idx, r0), _mm512_permutexvar_epi8(idx, r1));
        if lower == 0 {
            return Some((t0, t1));
        }
        let t2 = _mm512_permutexvar_epi8(idx, row(2));
        Some((_mm512_mask_blend_epi32(lower, t0, t1), _mm512_mask_blend_epi32(lower, t1, t2)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp::simd_harness::{self as harness, bit_identity_proptest, family};
    use crate::warp::Interp::Bilinear;

    // The AVX-512 kernel where the CPU has it, else the AVX2 one (whose own tests are in
    // `sample_simd`).
    family!(Gray8, u8, bilinear_gray8, gray);

    #[test]
    fn vector_path_matches_the_scalar_path_bit_for_bit() {
        harness::sweep::<u8, Gray8>(Bilinear, &[1], 5, 2000);
    }

    /// Rows of a smooth map, where the kernels load row windows instead of gathering.
    #[test]
    fn row_windows_match_the_scalar_path() {
        harness::smooth_rows::<u8, Gray8>(Bilinear, &[1], 41);
    }

    /// Signed zeros, ties, the border, infinities and `NaN` in either coordinate.
    #[test]
    fn special_positions_match_the_scalar_path() {
        harness::special::<u8, Gray8>(Bilinear, &[1], 6);
    }

    /// The last bytes read are the image's last (module docs).
    #[test]
    fn loads_at_the_bottom_right_cell_stay_inside_the_image() {
        harness::bottom_right::<u8, Gray8>(Bilinear, &[1]);
    }

    #[test]
    fn interior_groups_take_the_vector_path() {
        harness::assert_vectorized::<u8, Gray8>(Bilinear, &[1]);
    }

    bit_identity_proptest!(
        gray8_bit_identical_on_random_images,
        u8,
        Gray8,
        Bilinear,
        [1],
        "Random 8-bit images (extreme values included) and random positions."
    );
}
