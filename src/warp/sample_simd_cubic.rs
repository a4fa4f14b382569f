//! Bicubic resampling of 8-bit images, 1 to 4 channels (x86_64 AVX2): gray eight pixels
//! per vector, gray + alpha, RGB and RGBA two pixels per vector (four lanes each).
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
//! `v(i, j) = I(x0 + i - 1, y0 + j - 1)[c]` (`i, j` in `0..4`, coordinates clamped to the
//! image):
//!
//! ```text
//!   row_j = (((0 + wx0 v(0, j)) + wx1 v(1, j)) + wx2 v(2, j)) + wx3 v(3, j)
//!   acc   = (((0 + wy0 row_0) + wy1 row_1) + wy2 row_2) + wy3 row_3
//!   lo, hi = min, max of v(1, 1), v(2, 1), v(1, 2), v(2, 2)
//!   out   = trunc(clamp(clamp(acc, lo, hi) + 0.5, 0, 255))
//! ```
//!
//! in `f32`, each operation rounded (no fused multiply-add). The vector path does the same
//! operations in the same order on `f32` lanes: the floors and fractions in `f64`
//! (`vroundpd`, exact subtraction, one rounding to `f32` as `as f32` does), `K` on both of
//! its branches with the branch chosen by the same comparisons (`s < 1`, `s < 2`), the
//! sums from `0` in the order above, separate multiplies and adds. The taps are integers,
//! so `lo` and `hi` do not depend on the order of the `min`s and `max`s; `clamp(acc, lo,
//! hi)` is done as the scalar `f32::clamp` does it (`acc < lo` gives `lo`, then `> hi`
//! gives `hi`, by compare and blend), and the final rounding is
//! [`super::sample_simd::avx2::round_clamp`]. So every lane is bit-identical to the scalar
//! path.
//!
//! **Taps.** The vector path takes a position only when no tap is clamped:
//! `1 <= x0 <= w - 3` and `1 <= y0 <= h - 3` (so `w, h >= 4`). With
//! `k = (y0 - 1) w + x0 - 1` (the pixel index of tap `v(0, 0)`; the image is `w x h`, `NC`
//! bytes per pixel, row-major, `n = NC w h` bytes), row `j` of the taps is the `4 NC` bytes
//! from `NC (k + j w)`, and `0 <= k`, `k + 3 w + 3 = (y0 + 2) w + x0 + 2 <= h w - 1`:
//!
//! * gray: each lane gathers the 32-bit word at byte `k + j w` (the row's four taps); the
//!   last byte read is `k + 3 w + 3 <= h w - 1`.
//! * gray + alpha: each pixel loads the eight bytes from `2 (k + j w)`; the last byte read
//!   is `2 (k + 3 w) + 7 = 2 (k + 3 w + 3) + 1 <= 2 h w - 1`.
//! * RGBA: each pixel loads the sixteen bytes from `4 (k + j w)`; the last byte read is
//!   `4 (k + 3 w) + 15 = 4 (k + 3 w + 3) + 3 <= 4 h w - 1`.
//! * RGB: each pixel loads sixteen bytes, from `3 (k + j w)` for rows 0 to 2 (taps in bytes
//!   0..12) and from `3 (k + 3 w) - 4` for row 3 (taps in bytes 4..16), so that the last
//!   load ends on the last tap: `3 (k + 3 w) + 11 = 3 (k + 3 w + 3) + 2 <= 3 h w - 1`; it
//!   starts at `3 (k + 3 w) - 4 >= 9 w - 4 > 0`, and row 2's load ends at
//!   `3 (k + 2 w) + 15 = 3 ((y0 + 1) w + x0 + 4) <= 3 ((h - 2) w + w + 1) = 3 (h - 1) w + 3
//!   <= 3 h w - 1` (`w >= 4`).
//!
//! A group of eight (gray) or four (the others) positions is taken on the vector path only
//! when all its lanes pass; any other group (outside the mesh, `NaN`, taps across the image
//! border) and the tail are done pixel by pixel by the scalar path. Out-of-range and `NaN`
//! coordinates convert to `i32::MIN` and so fail the test.

#[cfg(target_arch = "x86_64")]
use super::sample_simd::avx2_fits;

/// Fills the `NC`-byte pixels `out[NC i ..]` for every position `pos[i]`
/// (`i < min(pos.len(), out.len() / NC)`) of a `w x h` image `data` (`NC` = 1 to 4
/// interleaved 8-bit channels) by bicubic interpolation, with `scalar(p, px)` writing the
/// pixels the vector path does not take. Returns `false` (and writes nothing) when the
/// vector path is not available: not x86_64, no AVX2, `NC` not 1 to 4, or an image too
/// large for 32-bit offsets.
pub(super) fn bicubic8<const NC: usize>(
    data: &[u8],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [u8],
    scalar: impl Fn(&[f64; 2], &mut [u8]),
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if (1..=4).contains(&NC) && avx2_fits(data.len(), w, h, NC) {
        if NC == 1 {
            // SAFETY: AVX2 is available and `data` holds at least `w h < 2^31` bytes
            // (`avx2_fits`), as `avx2::bicubic_gray8` requires.
            unsafe { avx2::bicubic_gray8(data, w, h, pos, out, &scalar) };
        } else {
            // SAFETY: `NC` is 2, 3 or 4 (checked just above); AVX2 is available and `data`
            // holds at least `NC w h < 2^31` bytes (`avx2_fits`), as `avx2::bicubic_color8`
            // requires.
            unsafe { avx2::bicubic_color8::<NC>(data, w, h, pos, out, &scalar) };
        }
        return true;
    }
    let _ = (data, w, h, pos, out, scalar);
    false
}

#[cfg(target_arch = "x86_64")]
pub(super) mod avx2 {
    use crate::warp::sample_simd::avx2::{lanes4, lanes8, round_clamp};
    use std::arch::x86_64::*;

    /// Zero byte for `_mm_shuffle_epi8`.
    const Z: i8 = -128;

    /// Keys' kernel on eight lanes, as the scalar `keys` computes it (module docs): both
    /// branches, then the one `s < 1`, `s < 2` choose (a `NaN` lane gives 0, as there).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn keys(t: __m256) -> __m256 {
        let s = _mm256_and_ps(t, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff)));
        let c = _mm256_set1_ps;
        let near = _mm256_add_ps(
            _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(c(1.5), s), c(2.5)), s), s),
            c(1.0),
        );
        let far = _mm256_add_ps(
            _mm256_mul_ps(
                _mm256_sub_ps(
                    _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(c(-0.5), s), c(2.5)), s),
                    c(4.0),
                ),
                s,
            ),
            c(2.0),
        );
        let lt1 = _mm256_cmp_ps::<_CMP_LT_OQ>(s, c(1.0));
        let lt2 = _mm256_cmp_ps::<_CMP_LT_OQ>(s, c(2.0));
        _mm256_blendv_ps(_mm256_blendv_ps(_mm256_setzero_ps(), far, lt2), near, lt1)
    }

    /// The four weights `[K(f + 1), K(f), K(f - 1), K(f - 2)]` of the fractions `f`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) fn weights(f: __m256) -> [__m256; 4] {
        let (one, two) = (_mm256_set1_ps(1.0), _mm256_set1_ps(2.0));
        [
            keys(_mm256_add_ps(f, one)),
            keys(f),
            keys(_mm256_sub_ps(f, one)),
            keys(_mm256_sub_ps(f, two)),
        ]
    }

    /// `row = (((0 + w0 v0) + w1 v1) + w2 v2) + w3 v3`, as the scalar loop sums a row of
    /// taps (and `acc` its rows).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) fn dot4(w: &[__m256; 4], v: &[__m256; 4]) -> __m256 {
        let mut s = _mm256_setzero_ps();
        for i in 0..4 {
            s = _mm256_add_ps(s, _mm256_mul_ps(w[i], v[i]));
        }
        s
    }

    /// `acc.clamp(lo, hi)` as `f32::clamp` does it: `lo` where `acc < lo`, then `hi` where
    /// the result is `> hi`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) fn clamp(acc: __m256, lo: __m256, hi: __m256) -> __m256 {
        let v = _mm256_blendv_ps(acc, lo, _mm256_cmp_ps::<_CMP_LT_OQ>(acc, lo));
        _mm256_blendv_ps(v, hi, _mm256_cmp_ps::<_CMP_GT_OQ>(v, hi))
    }

    /// Whether the taps of all eight lanes lie inside the image (module docs): `ok` from
    /// [`lanes8`] (`0 <= x0 <= w - 3`, `0 <= y0 <= h - 3`) and `x0, y0 >= 1`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) fn inside8(ok: __m256i, x0: __m256i, y0: __m256i) -> bool {
        let z = _mm256_setzero_si256();
        let pos = _mm256_and_si256(_mm256_cmpgt_epi32(x0, z), _mm256_cmpgt_epi32(y0, z));
        _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(ok, pos))) == 0xff
    }

    /// [`inside8`] for the four lanes of [`lanes4`].
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::warp) fn inside4(ok: __m128i, x0: __m128i, y0: __m128i) -> bool {
        let z = _mm_setzero_si128();
        let pos = _mm_and_si128(_mm_cmpgt_epi32(x0, z), _mm_cmpgt_epi32(y0, z));
        _mm_movemask_ps(_mm_castsi128_ps(_mm_and_si128(ok, pos))) == 0xf
    }

    /// See [`super::bicubic8`] with `NC = 1`: eight positions at a time, one lane each.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `data.len() >= w h` and `w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bicubic_gray8(
        data: &[u8],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u8],
        scalar: &impl Fn(&[f64; 2], &mut [u8]),
    ) {
        let n = pos.len().min(out.len());
        let groups = n / 8;
        // Lane bounds x0 <= w - 3, y0 <= h - 3: with w h < 2^31 they fit in i32 (and are
        // negative when w or h < 3, rejecting every lane).
        let xmax = _mm256_set1_epi32(w as i32 - 3);
        let ymax = _mm256_set1_epi32(h as i32 - 3);
        let wv = _mm256_set1_epi32(w as i32);
        let corner = _mm256_set1_epi32(w as i32 + 1);
        let byte = _mm256_set1_epi32(0xff);
        let (top, inf, ninf) = (
            _mm256_set1_ps(255.0),
            _mm256_set1_ps(f32::INFINITY),
            _mm256_set1_ps(f32::NEG_INFINITY),
        );
        let base = data.as_ptr() as *const i32;
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
            let (wx, wy) = (weights(fx), weights(fy));
            // k = (y0 - 1) w + x0 - 1 = y0 w + x0 - (w + 1).
            let mut k = _mm256_sub_epi32(_mm256_add_epi32(_mm256_mullo_epi32(y0, wv), x0), corner);
            let (mut acc, mut lo, mut hi) = (_mm256_setzero_ps(), inf, ninf);
            for (j, wyj) in wy.iter().enumerate() {
                // SAFETY: every lane passed 1 <= x0 <= w - 3, 1 <= y0 <= h - 3; the word
                // read is bytes k + j w .. k + j w + 3, inside 0 .. w h <= data.len() by the
                // bounds in the module docs; byte offsets (scale 1) below 2^31.
                let word = _mm256_i32gather_epi32::<1>(base, k);
                let tap = |s: __m256i| _mm256_cvtepi32_ps(_mm256_and_si256(s, byte));
                let v = [
                    tap(word),
                    tap(_mm256_srli_epi32::<8>(word)),
                    tap(_mm256_srli_epi32::<16>(word)),
                    _mm256_cvtepi32_ps(_mm256_srli_epi32::<24>(word)),
                ];
                if j == 1 || j == 2 {
                    lo = _mm256_min_ps(lo, _mm256_min_ps(v[1], v[2]));
                    hi = _mm256_max_ps(hi, _mm256_max_ps(v[1], v[2]));
                }
                acc = _mm256_add_ps(acc, _mm256_mul_ps(*wyj, dot4(&wx, &v)));
                k = _mm256_add_epi32(k, wv);
            }
            let r = round_clamp(clamp(acc, lo, hi), top);
            // 8 x i32 in 0..=255 -> bytes: per 128-bit lane, r0..r3 (resp. r4..r7) in the
            // low four bytes.
            let r16 = _mm256_packus_epi32(r, r);
            let r8 = _mm256_packus_epi16(r16, r16);
            let lo4 = _mm_cvtsi128_si32(_mm256_castsi256_si128(r8)) as u32;
            let hi4 = _mm_cvtsi128_si32(_mm256_extracti128_si256::<1>(r8)) as u32;
            out[i..i + 8].copy_from_slice(&(lo4 as u64 | (hi4 as u64) << 32).to_le_bytes());
        }
        for k in 8 * groups..n {
            scalar(&pos[k], &mut out[k..k + 1]);
        }
    }

    /// See [`super::bicubic8`] with `NC` = 2, 3 or 4: four positions at a time, two pixels
    /// per vector, four lanes per pixel (gray + alpha and RGB: the lanes past `NC` are zero
    /// and their results dropped).
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `NC` is 2, 3 or 4; `data.len() >= NC w h` and `NC w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn bicubic_color8<const NC: usize>(
        data: &[u8],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [u8],
        scalar: &impl Fn(&[f64; 2], &mut [u8]),
    ) {
        let n = pos.len().min(out.len() / NC);
        let groups = n / 4;
        // Lane bounds as in the module docs; negative when w or h < 3 (every lane rejected).
        let xmax = _mm_set1_epi32(w as i32 - 3);
        let ymax = _mm_set1_epi32(h as i32 - 3);
        let wv = _mm_set1_epi32(w as i32);
        let corner = _mm_set1_epi32(w as i32 + 1);
        // A row load (gray + alpha: 8 bytes, RGB and RGBA: 16) shuffled to four taps of
        // four bytes (channels past NC zero); RGB's last row is loaded 4 bytes early.
        let (sh, sh_last, last) = match NC {
            2 => {
                let s = _mm_setr_epi8(0, 1, Z, Z, 2, 3, Z, Z, 4, 5, Z, Z, 6, 7, Z, Z);
                (s, s, 0isize)
            }
            3 => (
                _mm_setr_epi8(0, 1, 2, Z, 3, 4, 5, Z, 6, 7, 8, Z, 9, 10, 11, Z),
                _mm_setr_epi8(4, 5, 6, Z, 7, 8, 9, Z, 10, 11, 12, Z, 13, 14, 15, Z),
                -4isize,
            ),
            _ => {
                let s = _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
                (s, s, 0isize)
            }
        };
        let (top, inf, ninf) = (
            _mm256_set1_ps(255.0),
            _mm256_set1_ps(f32::INFINITY),
            _mm256_set1_ps(f32::NEG_INFINITY),
        );
        // The weights of positions (p, p + 1) spread to four lanes each: x weights from
        // lanes 0..4 of [wx | wy], y weights from lanes 4..8.
        let spread = [
            (_mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1), _mm256_setr_epi32(4, 4, 4, 4, 5, 5, 5, 5)),
            (_mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3), _mm256_setr_epi32(6, 6, 6, 6, 7, 7, 7, 7)),
        ];
        let base = data.as_ptr();
        let mut ks = [0i32; 4];
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
            // [K(f + 1) | ...] of [fx0..fx3 | fy0..fy3]: the x and y weights at once.
            let wxy = weights(_mm256_set_m128(fy4, fx4));
            // SAFETY: `ks` is four i32; unaligned store.
            _mm_storeu_si128(
                ks.as_mut_ptr() as *mut __m128i,
                _mm_sub_epi32(_mm_add_epi32(_mm_mullo_epi32(y0, wv), x0), corner),
            );
            for (pair, (ix, iy)) in spread.iter().enumerate() {
                let wx = wxy.map(|v| _mm256_permutevar8x32_ps(v, *ix));
                let wy = wxy.map(|v| _mm256_permutevar8x32_ps(v, *iy));
                let (k0, k1) = (ks[2 * pair] as isize, ks[2 * pair + 1] as isize);
                let (nc, w) = (NC as isize, w as isize);
                let (mut acc, mut lo, mut hi) = (_mm256_setzero_ps(), inf, ninf);
                for (j, wyj) in wy.iter().enumerate() {
                    let (s, off) = if j == 3 { (sh_last, last) } else { (sh, 0) };
                    let jw = j as isize * w;
                    // SAFETY: both lanes passed 1 <= x0 <= w - 3, 1 <= y0 <= h - 3 (so
                    // 0 <= k, k + 3 w + 3 <= w h - 1); the bytes read (8 from 2 (k + j w),
                    // 16 from 3 (k + j w) or, for row 3, 3 (k + 3 w) - 4, 16 from
                    // 4 (k + j w)) lie inside 0 .. NC w h <= data.len() by the bounds in the
                    // module docs; unaligned loads.
                    let rd = |o: isize| {
                        let p = base.offset(nc * o + off) as *const __m128i;
                        let r = if NC == 2 { _mm_loadl_epi64(p) } else { _mm_loadu_si128(p) };
                        _mm_shuffle_epi8(r, s)
                    };
                    let (r0, r1) = (rd(k0 + jw), rd(k1 + jw));
                    // [t0 of p | t0 of p + 1], ..., four bytes (channels) per tap.
                    let (t01, t23) = (_mm_unpacklo_epi32(r0, r1), _mm_unpackhi_epi32(r0, r1));
                    let cv = |x: __m128i| _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(x));
                    let v = [
                        cv(t01),
                        cv(_mm_srli_si128::<8>(t01)),
                        cv(t23),
                        cv(_mm_srli_si128::<8>(t23)),
                    ];
                    if j == 1 || j == 2 {
                        lo = _mm256_min_ps(lo, _mm256_min_ps(v[1], v[2]));
                        hi = _mm256_max_ps(hi, _mm256_max_ps(v[1], v[2]));
                    }
                    acc = _mm256_add_ps(acc, _mm256_mul_ps(*wyj, dot4(&wx, &v)));
                }
                let r = round_clamp(clamp(acc, lo, hi), top);
                // 8 x i32 in 0..=255 -> per 128-bit lane, the pixel's four bytes lowest.
                let r16 = _mm256_packus_epi32(r, r);
                let r8 = _mm256_packus_epi16(r16, r16);
                let lo4 = (_mm_cvtsi128_si32(_mm256_castsi256_si128(r8)) as u32).to_le_bytes();
                let hi4 =
                    (_mm_cvtsi128_si32(_mm256_extracti128_si256::<1>(r8)) as u32).to_le_bytes();
                let j = NC * (i + 2 * pair);
                out[j..j + NC].copy_from_slice(&lo4[..NC]);
                out[j + NC..j + 2 * NC].copy_from_slice(&hi4[..NC]);
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

    family!(Cubic8, u8, bicubic8);

    #[test]
    fn bicubic8_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<u8, Cubic8>(Bicubic, &[1, 2, 3, 4], 81, 2000);
    }

    /// Signed zeros, ties, the border, infinities (the scalar path's overflow at `x0 + 2`
    /// before its clamp) and `NaN` in either coordinate.
    #[test]
    fn bicubic8_special_positions_match_the_scalar_path() {
        harness::special::<u8, Cubic8>(Bicubic, &[1, 2, 3, 4], 85);
    }

    /// The loads start on the image's first taps and end on its last (module docs).
    #[test]
    fn bicubic8_loads_at_the_corner_cells_stay_inside_the_image() {
        harness::bottom_right::<u8, Cubic8>(Bicubic, &[1, 2, 3, 4]);
    }

    /// Groups of eight (gray) and four (the others).
    #[test]
    fn bicubic8_interior_groups_take_the_vector_path() {
        harness::assert_vectorized::<u8, Cubic8>(Bicubic, &[1, 2, 3, 4]);
    }

    bit_identity_proptest!(
        bicubic8_bit_identical_on_random_images,
        u8,
        Cubic8,
        Bicubic,
        [1, 2, 3, 4],
        "Random 8-bit images of 1 to 4 channels (extreme values included) and random \
         positions, borders and outside included."
    );
}
