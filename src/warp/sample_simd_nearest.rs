//! Nearest-neighbour resampling of 8-bit, 16-bit and `f32` images with 1 to 4 channels,
//! eight positions at a time (x86_64 AVX2).
//!
//! The scalar path ([`super::sample::fill_pixels`], which gives a position whose `x` is
//! `NaN` the background, and [`super::sample::Source::sample_into`] for the others) copies
//! the `NC` samples of pixel `(i, j)`,
//!
//! ```text
//!   i = clamp(round(x) as isize, 0, w - 1),   j = clamp(round(y) as isize, 0, h - 1),
//! ```
//!
//! with `round` rounding half away from zero (`f64::round`) and `as isize` saturating
//! (`NaN` gives 0). The vector path computes the same `(i, j)` in `f64` for eight positions:
//!
//! ```text
//!   c = min(max(x, 0), w - 1),   t = floor(c),   i = t + (c - t >= 0.5 ? 1 : 0),
//! ```
//!
//! likewise `j` from `y` and `h - 1`, then converts them to `i32` (exact: integers in
//! `0 .. 2^31`). The two agree for every `x` that is not `NaN`:
//!
//! * clamping first changes nothing, because `round` is monotone and fixes the integers
//!   `0` and `m = w - 1`: `x < 0` gives `round(x) <= 0` and `x > m` gives `round(x) >= m`
//!   (also where `as isize` saturates), so both sides clamp to the same end;
//! * for `c >= 0` the fraction `c - floor(c)` is exact (`c < 1`: `floor(c) = 0`; `c >= 1`:
//!   `floor(c) >= c / 2`, Sterbenz), and rounding half away from zero is `floor(c)` plus one
//!   exactly when that fraction is at least `1/2` (`floor(c + 0.5)` would not do:
//!   `0.49999999999999994 + 0.5` rounds to `1`);
//! * `max(NaN, 0)` is `0` (`vmaxpd` returns its second operand when one is `NaN`), so a
//!   `NaN` `y` gives row 0, as `NaN as isize` does; `-0.0` gives `0`; infinities clamp.
//!
//! A group of eight positions with a `NaN` `x` (background) is done pixel by pixel by the
//! scalar path, as is the tail of fewer than eight; every other group takes the vector
//! path, borders and positions outside the image included (they clamp).
//!
//! **Loads.** The pixel index `k = j w + i` lies in `0 ..= w h - 1` (`0 <= i <= w - 1`,
//! `0 <= j <= h - 1`; below `2^31`, so the `i32` product does not overflow), and the `NC`
//! samples copied, `NC k ..= NC k + NC - 1`, end at most on sample `NC w h - 1`, the last of
//! the image. The samples are copied as they are (no arithmetic), so floats keep their bits,
//! signed zeros and all.

#[cfg(target_arch = "x86_64")]
use super::sample_simd::avx2_fits;

/// Fills the `NC`-sample pixels `out[NC i ..]` for every position `pos[i]`
/// (`i < min(pos.len(), out.len() / NC)`) of a `w x h` image `data` (`NC` = 1 to 4
/// interleaved channels) with the nearest pixel, with `scalar(p, px)` writing the pixels the
/// vector path does not take. Returns `false` (and writes nothing) when the vector path is
/// not available: not x86_64, no AVX2, `NC` not 1 to 4, an empty image, or an image too
/// large for 32-bit offsets.
pub(super) fn nearest<T: Copy, const NC: usize>(
    data: &[T],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
    out: &mut [T],
    scalar: impl Fn(&[f64; 2], &mut [T]),
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if (1..=4).contains(&NC) && avx2_fits(data.len(), w, h, NC) {
        // SAFETY: AVX2 is available, `w, h >= 1` and `data` holds at least `NC w h < 2^31`
        // samples (`avx2_fits`), as `avx2::nearest` requires.
        unsafe { avx2::nearest::<T, NC>(data, w, h, pos, out, &scalar) };
        return true;
    }
    let _ = (data, w, h, pos, out, scalar);
    false
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use crate::warp::sample_simd::avx2::xy4;
    use std::arch::x86_64::*;

    /// Eight positions: the pixel index `k = j w + i` of each (i32), and a bit per lane
    /// (movemask order) whose `x` is `NaN`.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `pp` points to 16 readable `f64`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn index8(pp: *const f64, xm: __m256d, ym: __m256d, wv: __m256i) -> (__m256i, i32) {
        // SAFETY: 16 f64 readable at pp (caller), 8 at each of pp and pp + 8.
        let ((xa, ya), (xb, yb)) = (xy4(pp), xy4(pp.add(8)));
        let nan = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_UNORD_Q>(xa, xa))
            | _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_UNORD_Q>(xb, xb)) << 4;
        let (i, j) = (
            _mm256_set_m128i(round_clamp(xb, xm), round_clamp(xa, xm)),
            _mm256_set_m128i(round_clamp(yb, ym), round_clamp(ya, ym)),
        );
        (_mm256_add_epi32(_mm256_mullo_epi32(j, wv), i), nan)
    }

    /// `clamp(round(v) as isize, 0, m)` on four lanes (module docs).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn round_clamp(v: __m256d, m: __m256d) -> __m128i {
        let c = _mm256_min_pd(_mm256_max_pd(v, _mm256_setzero_pd()), m);
        let t = _mm256_floor_pd(c);
        let up = _mm256_cmp_pd::<_CMP_GE_OQ>(_mm256_sub_pd(c, t), _mm256_set1_pd(0.5));
        let r = _mm256_add_pd(t, _mm256_and_pd(up, _mm256_set1_pd(1.0)));
        _mm256_cvttpd_epi32(r)
    }

    /// See [`super::nearest`].
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2; `w, h >= 1`; `data.len() >= NC w h` and `NC w h < 2^31`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn nearest<T: Copy, const NC: usize>(
        data: &[T],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [T],
        scalar: &impl Fn(&[f64; 2], &mut [T]),
    ) {
        let n = pos.len().min(out.len() / NC);
        let groups = n / 8;
        let xm = _mm256_set1_pd((w - 1) as f64);
        let ym = _mm256_set1_pd((h - 1) as f64);
        let wv = _mm256_set1_epi32(w as i32);
        let base = data.as_ptr();
        let mut ks = [0i32; 8];
        for g in 0..groups {
            let i = 8 * g;
            // SAFETY: i + 8 <= n <= pos.len(): 16 f64 for 8 contiguous positions.
            let (k, nan) = index8(pos.as_ptr().add(i) as *const f64, xm, ym, wv);
            if nan != 0 {
                for k in i..i + 8 {
                    scalar(&pos[k], &mut out[NC * k..NC * k + NC]);
                }
                continue;
            }
            // SAFETY: `ks` is eight i32; unaligned store.
            _mm256_storeu_si256(ks.as_mut_ptr() as *mut __m256i, k);
            let dst = out.as_mut_ptr();
            for (l, &k) in ks.iter().enumerate() {
                // SAFETY: 0 <= k <= w h - 1 (module docs), so the NC samples from NC k
                // end at NC w h - 1 < data.len(); i + 8 <= n <= out.len() / NC, so
                // NC (i + l) + NC <= out.len(); `data` and `out` do not overlap.
                std::ptr::copy_nonoverlapping(base.add(NC * k as usize), dst.add(NC * (i + l)), NC);
            }
        }
        for k in 8 * groups..n {
            scalar(&pos[k], &mut out[NC * k..NC * k + NC]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp::simd_harness::{self as harness, bit_identity_proptest, family};
    use crate::warp::Interp::Nearest;

    family!(Near8, u8, nearest::<u8, NC>, std::convert::identity);
    family!(Near16, u16, nearest::<u16, NC>, std::convert::identity);
    family!(NearF, f32, nearest::<f32, NC>, std::convert::identity);

    const ALL: &[usize] = &[1, 2, 3, 4];

    #[test]
    fn u8_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<u8, Near8>(Nearest, ALL, 180, 1500);
    }

    #[test]
    fn u16_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<u16, Near16>(Nearest, ALL, 184, 1500);
    }

    /// Bit for bit (`to_bits`), with every kind of float sample (negative, huge,
    /// subnormal, infinite, signed zeros) and all kinds mixed.
    #[test]
    fn float_vector_paths_match_the_scalar_path_bit_for_bit() {
        harness::sweep::<f32, NearF>(Nearest, ALL, 188, 1500);
    }

    /// Ties (`k + 0.5` rounds away from zero, the `f64`s beside it do not), signed zeros,
    /// `-0.5`, the border and one past it, infinities, `NaN` in `x` (background) or `y`
    /// (row 0, as `NaN as isize` is 0).
    #[test]
    fn ties_signed_zeros_and_borders_match_the_scalar_path() {
        harness::special::<u8, Near8>(Nearest, ALL, 190);
        harness::special::<u16, Near16>(Nearest, ALL, 194);
        harness::special::<f32, NearF>(Nearest, ALL, 198);
    }

    /// The last pixel's samples are the buffer's last (module docs).
    #[test]
    fn loads_of_the_last_pixel_stay_inside_the_image() {
        harness::bottom_right::<u8, Near8>(Nearest, ALL);
        harness::bottom_right::<u16, Near16>(Nearest, ALL);
        harness::bottom_right::<f32, NearF>(Nearest, ALL);
    }

    #[test]
    fn interior_groups_take_the_vector_path() {
        harness::assert_vectorized::<u8, Near8>(Nearest, ALL);
        harness::assert_vectorized::<u16, Near16>(Nearest, ALL);
        harness::assert_vectorized::<f32, NearF>(Nearest, ALL);
    }

    bit_identity_proptest!(
        u8_bit_identical_on_random_images,
        u8,
        Near8,
        Nearest,
        [1, 2, 3, 4],
        "Random 8-bit images of 1 to 4 channels and random positions, borders, outside, \
         huge and `NaN` included."
    );

    bit_identity_proptest!(
        u16_bit_identical_on_random_images,
        u16,
        Near16,
        Nearest,
        [1, 2, 3, 4],
        "Random 16-bit images of 1 to 4 channels and random positions, borders, outside, \
         huge and `NaN` included."
    );

    bit_identity_proptest!(
        float_bit_identical_on_random_images,
        f32,
        NearF,
        Nearest,
        [1, 2, 3, 4],
        "Random float images of 1 to 4 channels (negative, huge, subnormal, infinite and \
         signed-zero samples included) and random positions."
    );
}
