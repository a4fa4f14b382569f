//! The test harness shared by the vector resampling kernels (`sample_simd*`): one generic
//! comparison of a kernel with the scalar reference [`Source::sample_into`], bit for bit
//! (floats by their bit patterns), parameterised by the sample type `T` and the channel
//! count `NC`, and the scenarios every kernel is put through:
//!
//! * [`sweep`]: fixed seeds, images of several sizes (one pixel wide or high, barely large
//!   enough, wide, tall) and every kind of sample [`TestTexel::random`] draws, sampled at
//!   runs of inside, border, outside, `NaN` and huge positions ([`positions`]), for every
//!   start and remainder length modulo the group size;
//! * [`bottom_right`]: an image in a buffer of exactly `NC w h` samples, sampled at its
//!   last interior cell (and, for bicubic, its first; for nearest, its last pixel), where
//!   the loads end on (start at) the image's last (first) tap;
//! * [`special`]: every pair of the coordinates where rounding and flooring turn
//!   ([`special_coords`]: signed zeros, `.5` ties and their neighbouring `f64`s, the image
//!   border, infinities, `NaN`), on images of every kind of sample, at every start modulo
//!   eight;
//! * [`smooth_rows`]: rows of positions through rotations, scalings and mirrors, as a
//!   smooth map gives them (the row-window loads of the 8-bit kernel);
//! * [`scalar_calls`]: how many of 19 inside positions the kernel left to the scalar path
//!   (3 when every full group was vectorized);
//! * [`random_image`]: one random image and 200 random positions, for the proptests.
//!
//! A kernel module's tests name its kernels once as a [`Family`] (with [`family!`]: one
//! kernel per channel count) and call the scenarios with the channel counts to cover; a
//! kernel that returns `false` has no vector path on this machine, and then there is
//! nothing to compare. [`bit_identity_proptest!`] writes the proptest of a family.

use super::sample::{Source, Texel};
use super::Interp;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::cell::Cell;

/// A kernel under test: `(data, w, h, pos, out, scalar)`, `scalar(p, px)` writing a pixel
/// the vector path leaves; returns `false` (and writes nothing) without a vector path.
pub(super) type Kernel<T> =
    fn(&[T], usize, usize, &[[f64; 2]], &mut [T], &dyn Fn(&[f64; 2], &mut [T])) -> bool;

/// The kernels of one module, one per channel count `NC` (as a [`Kernel`]).
pub(super) trait Family<T> {
    /// The kernel for `NC` channels.
    fn run<const NC: usize>(
        data: &[T],
        w: usize,
        h: usize,
        pos: &[[f64; 2]],
        out: &mut [T],
        scalar: &dyn Fn(&[f64; 2], &mut [T]),
    ) -> bool;
}

/// `family!(Name, T, kernel)`: a unit struct `Name` whose [`Family::run`] is
/// `kernel::<NC>` (a function taking `scalar` as `impl Fn(&[f64; 2], &mut [T])`);
/// `family!(Name, T, kernel, gray)`: the same for a one-channel kernel taking `scalar` as
/// `impl Fn(&[f64; 2]) -> T` (through [`one_channel`]).
macro_rules! family {
    ($name:ident, $t:ty, $kernel:ident, gray) => {
        $crate::warp::simd_harness::family!(
            $name,
            $t,
            $kernel,
            $crate::warp::simd_harness::one_channel
        );
    };
    ($name:ident, $t:ty, $kernel:ident) => {
        $crate::warp::simd_harness::family!($name, $t, $kernel::<NC>, std::convert::identity);
    };
    ($name:ident, $t:ty, $kernel:expr, $wrap:path) => {
        struct $name;
        impl $crate::warp::simd_harness::Family<$t> for $name {
            fn run<const NC: usize>(
                data: &[$t],
                w: usize,
                h: usize,
                pos: &[[f64; 2]],
                out: &mut [$t],
                scalar: &dyn Fn(&[f64; 2], &mut [$t]),
            ) -> bool {
                $kernel(data, w, h, pos, out, $wrap(scalar))
            }
        }
    };
}
pub(super) use family;

/// A one-channel `scalar(p, px)` as `scalar(p) -> T` (for the gray kernels).
pub(super) fn one_channel<T: Texel>(
    scalar: &dyn Fn(&[f64; 2], &mut [T]),
) -> impl Fn(&[f64; 2]) -> T + '_ {
    move |p| {
        let mut px = [T::from_f32(0.0)];
        scalar(p, &mut px);
        px[0]
    }
}

/// `bit_identity_proptest!(name, T, Family, interp, [NC, ...], doc)`: a proptest `name`
/// running [`random_image`] on 64 random images (1 to 39 pixels a side, every kind of
/// sample and all kinds mixed) for each channel count.
macro_rules! bit_identity_proptest {
    ($name:ident, $t:ty, $fam:ty, $interp:expr, [$($nc:literal),+], $doc:literal) => {
        proptest::proptest! {
            #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
            #[doc = $doc]
            #[test]
            fn $name(w in 1usize..40, h in 1usize..40, seed in 0u64..1_000_000, kind in 0u8..6) {
                $($crate::warp::simd_harness::random_image::<$t, $fam, $nc>(
                    $interp, w, h, seed, kind,
                );)+
            }
        }
    };
}
pub(super) use bit_identity_proptest;

/// Calls `$f::<T, NC>(F::run::<NC>, args...)` for the channel count `nc` (1 to 4).
macro_rules! by_nc {
    ($nc:expr, $f:ident, $t:ty, $fam:ty, ($($arg:expr),*)) => {
        match $nc {
            1 => $f::<$t, 1>(<$fam>::run::<1>, $($arg),*),
            2 => $f::<$t, 2>(<$fam>::run::<2>, $($arg),*),
            3 => $f::<$t, 3>(<$fam>::run::<3>, $($arg),*),
            4 => $f::<$t, 4>(<$fam>::run::<4>, $($arg),*),
            nc => panic!("no kernel for {nc} channels"),
        }
    };
}

/// A sample type the harness can draw, build and compare.
pub(super) trait TestTexel: Texel + std::fmt::Debug {
    /// How many kinds of random samples [`TestTexel::random`] draws (`0..KINDS`).
    const KINDS: u8;
    /// The bit pattern (the value for integers).
    fn bits(self) -> u32;
    /// A random sample of kind `kind`: integers uniform, only the extremes, or near the
    /// top (the clamp); floats ordinary, extreme (signed zeros, the largest and smallest
    /// normals, infinities), subnormal, huge of either sign, or in 0..1.
    fn random(rng: &mut SmallRng, kind: u8) -> Self;
    /// A deterministic sample for index `v` (patterned images).
    fn pattern(v: usize) -> Self;
}

/// The integer samples: `near` is the low end of the "near the top" kind.
macro_rules! int_texel {
    ($t:ty, $near:expr, $mul:expr) => {
        impl TestTexel for $t {
            const KINDS: u8 = 3;
            fn bits(self) -> u32 {
                self as u32
            }
            fn random(rng: &mut SmallRng, kind: u8) -> $t {
                match kind {
                    0 => rng.gen(),
                    1 => [0, <$t>::MAX][rng.gen_range(0..2)],
                    _ => rng.gen_range($near..=<$t>::MAX),
                }
            }
            fn pattern(v: usize) -> $t {
                (v * $mul % (<$t>::MAX as usize + 1)) as $t
            }
        }
    };
}
int_texel!(u8, 250, 37);
int_texel!(u16, 65000, 3779);

impl TestTexel for f32 {
    const KINDS: u8 = 5;
    fn bits(self) -> u32 {
        self.to_bits()
    }
    fn random(rng: &mut SmallRng, kind: u8) -> f32 {
        let sign = if rng.gen() { 1.0 } else { -1.0 };
        match kind {
            0 => rng.gen_range(-1000.0..1000.0),
            1 => {
                let e = [
                    0.0,
                    -0.0,
                    1.0,
                    f32::MAX,
                    f32::MIN_POSITIVE,
                    f32::from_bits(1),
                    1e30,
                    f32::INFINITY,
                    rng.gen(),
                ];
                sign * e[rng.gen_range(0..e.len())]
            }
            2 => sign * f32::from_bits(rng.gen_range(1..0x0080_0000)),
            3 => sign * 10f32.powf(rng.gen_range(20.0..38.5)),
            _ => rng.gen(),
        }
    }
    fn pattern(v: usize) -> f32 {
        (v * 37 % 101) as f32 - 50.25
    }
}

/// Positions for the bit-identity tests: runs of 1 to 24 of one kind (inside, on the right
/// and bottom edges, on integers, outside, NaN, huge, at least one pixel from every edge),
/// so that some groups are all inside and others mix kinds.
pub(super) fn positions(rng: &mut SmallRng, w: usize, h: usize, n: usize) -> Vec<[f64; 2]> {
    let (wf, hf) = (w as f64, h as f64);
    let mut pos = Vec::new();
    while pos.len() < n {
        let (kind, run) = (rng.gen_range(0..10), rng.gen_range(1..25));
        for _ in 0..run {
            pos.push(match kind {
                0 => [(wf - 1.0) * rng.gen::<f64>(), hf - 1.0 - rng.gen::<f64>()],
                1 => [wf - 1.0, rng.gen_range(0.0..hf)],
                2 => [rng.gen_range(0..w) as f64, rng.gen_range(0..h) as f64],
                3 => [rng.gen_range(-3.0..wf + 3.0), rng.gen_range(-3.0..hf + 3.0)],
                4 => [f64::NAN, f64::NAN],
                5 => [1e12 * rng.gen::<f64>() - 5e11, 0.5],
                6 => [
                    1.0 + (wf - 3.0).max(0.0) * rng.gen::<f64>(),
                    1.0 + (hf - 3.0).max(0.0) * rng.gen::<f64>(),
                ],
                _ => [(wf - 1.0) * rng.gen::<f64>(), (hf - 1.0) * rng.gen::<f64>()],
            });
        }
    }
    pos.truncate(n);
    pos
}

/// The scalar reference: `Source::sample_into`, 7 in every channel at `NaN`.
pub(super) fn reference<T: Texel>(src: &Source<'_, T>, interp: Interp, p: &[f64; 2], px: &mut [T]) {
    if p[0].is_nan() {
        px.fill(T::from_f32(7.0));
    } else {
        src.sample_into(*p, interp, px);
    }
}

/// Runs `kernel` on `pos` and compares every pixel with [`reference`] bit for bit; `false`
/// when there is no vector path (nothing compared).
pub(super) fn check<T: TestTexel, const NC: usize>(
    kernel: Kernel<T>,
    interp: Interp,
    data: &[T],
    w: usize,
    h: usize,
    pos: &[[f64; 2]],
) -> bool {
    let src = Source { data, w, h, nc: NC };
    let mut out = vec![T::from_f32(0.0); NC * pos.len()];
    if !kernel(data, w, h, pos, &mut out, &|p, px| reference(&src, interp, p, px)) {
        return false;
    }
    let mut want = [T::from_f32(0.0); NC];
    for (k, p) in pos.iter().enumerate() {
        reference(&src, interp, p, &mut want);
        let got = &out[NC * k..NC * k + NC];
        let (gb, wb): (Vec<u32>, Vec<u32>) =
            (got.iter().map(|v| v.bits()).collect(), want.iter().map(|v| v.bits()).collect());
        assert_eq!(gb, wb, "{interp:?} NC {NC}, {w}x{h} at {p:?}: {got:?} vs {want:?}");
    }
    true
}

/// `len` random samples of kind `kind`, or of every kind mixed (each sample its own) when
/// `kind >= T::KINDS`.
pub(super) fn image<T: TestTexel>(rng: &mut SmallRng, len: usize, kind: u8) -> Vec<T> {
    (0..len)
        .map(|_| {
            let k = if kind < T::KINDS { kind } else { rng.gen_range(0..T::KINDS) };
            T::random(rng, k)
        })
        .collect()
}

/// The deterministic bit-identity sweep (module docs): seed `seed`, every kind of sample
/// and all kinds mixed,
/// `npos` positions per image, every start (0, 1, 3, 5) and length 0 to 24, and the whole.
fn sweep_nc<T: TestTexel, const NC: usize>(
    kernel: Kernel<T>,
    interp: Interp,
    seed: u64,
    npos: usize,
) {
    let mut rng = SmallRng::seed_from_u64(seed);
    let sizes = [(37usize, 23usize), (2, 2), (1, 9), (64, 1), (300, 5), (3, 2), (4, 4), (5, 7)];
    for (w, h) in sizes {
        for kind in 0..=T::KINDS {
            let data = image::<T>(&mut rng, NC * w * h, kind);
            let pos = positions(&mut rng, w, h, npos);
            for len in (0..=24).chain([pos.len() - 5]) {
                for start in [0, 1, 3, 5] {
                    if !check::<T, NC>(kernel, interp, &data, w, h, &pos[start..start + len]) {
                        return; // no vector path on this machine: nothing to compare
                    }
                }
            }
        }
    }
}

/// Rows of positions as a smooth map gives them (consecutive pixels close together, where
/// kernels may load row windows instead of gathering): every pixel row of an output of the
/// image's size through an affine map about the image centre, rotated by -40 to 40
/// degrees, scaled by 0.4 to 2.5 (upsampling to downsampling), mirrored or not, shifted by
/// a random fraction, so that groups lie in one or two source rows, near together or too
/// far apart, and reach the right and bottom border and beyond; on random images of several
/// sizes (buffers of exactly `NC w h` samples, so a window past the last row would be
/// caught as a read out of bounds by the slice bounds or Miri), each from every start
/// `0..8`.
fn smooth_rows_nc<T: TestTexel, const NC: usize>(kernel: Kernel<T>, interp: Interp, seed: u64) {
    let mut rng = SmallRng::seed_from_u64(seed);
    for (w, h) in [(40usize, 37usize), (300, 5), (17, 90), (16, 3), (129, 66)] {
        let data = image::<T>(&mut rng, NC * w * h, T::KINDS);
        for _ in 0..12 {
            let a = rng.gen_range(-40f64..40.0).to_radians();
            let k = rng.gen_range(0.4f64..2.5);
            let m = if rng.gen_bool(0.3) { -1.0 } else { 1.0 };
            let shift = [rng.gen_range(-0.5f64..0.5), rng.gen_range(-0.5f64..0.5)];
            let (c, s) = (k * a.cos(), k * a.sin());
            let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
            let pos: Vec<[f64; 2]> = (0..w * h)
                .map(|i| {
                    let (x, y) = (m * ((i % w) as f64 - cx), (i / w) as f64 - cy);
                    [cx + c * x - s * y + shift[0], cy + s * x + c * y + shift[1]]
                })
                .collect();
            for start in 0..8.min(pos.len()) {
                if !check::<T, NC>(kernel, interp, &data, w, h, &pos[start..]) {
                    return; // no vector path on this machine: nothing to compare
                }
            }
        }
    }
}

/// [`smooth_rows_nc`] for each channel count of `ncs`, seeds `seed`, `seed + 1`, ...
pub(super) fn smooth_rows<T: TestTexel, F: Family<T>>(interp: Interp, ncs: &[usize], seed: u64) {
    for (s, &nc) in (seed..).zip(ncs) {
        by_nc!(nc, smooth_rows_nc, T, F, (interp, s));
    }
}

/// The loads stay inside the image (the kernels' module docs): an image in a buffer of
/// exactly `NC w h` samples, sampled at its bottom-right interior cell (bicubic: also its
/// top-left one; nearest: its bottom-right pixel), for images barely large enough and
/// larger.
fn bottom_right_nc<T: TestTexel, const NC: usize>(kernel: Kernel<T>, interp: Interp) {
    // The last cell on the vector path: x0 = w - 2 (bilinear) or w - 3 (bicubic, whose
    // taps reach x0 + 2), likewise for y; bicubic's first is x0 = y0 = 1.
    // Nearest's last pixel is x = w - 1, reached here from x = w - 0.25 (rounded to w and
    // clamped), likewise y = h - 0.75.
    let (m, sizes): (usize, &[(usize, usize)]) = match interp {
        Interp::Bicubic => (3, &[(4, 4), (6, 4), (4, 9), (7, 5)]),
        Interp::Nearest => (1, &[(1, 1), (2, 2), (5, 3), (2, 7), (1, 9), (9, 1)]),
        Interp::Bilinear => (2, &[(2, 2), (5, 3), (2, 7)]),
    };
    for &(w, h) in sizes {
        let data: Vec<T> = (0..NC * w * h).map(T::pattern).collect();
        let last = [(w - m) as f64 + 0.75, (h - m) as f64 + 0.25];
        let first = if m == 3 { [1.25, 1.5] } else { last };
        let pos: Vec<[f64; 2]> = (0..17).map(|k| if k % 2 == 0 { last } else { first }).collect();
        check::<T, NC>(kernel, interp, &data, w, h, &pos);
        check::<T, NC>(kernel, interp, &data, w, h, &vec![last; 17]);
    }
}

/// The coordinates along an axis of `n` pixels where rounding (nearest) and flooring
/// (bilinear, bicubic) turn or where signs and clamps matter: both zeros, the `.5` ties
/// (`-0.5`, `0.5`, `1.5`, `2.5`, `n - 1.5`, `n - 0.5`) with the `f64` just below and above
/// each, `0.49999999999999994` (where `floor(x + 0.5)` would round up), integers, the last
/// pixel and one past it, huge values and infinities of either sign, and `NaN`.
pub(super) fn special_coords(n: usize) -> Vec<f64> {
    let last = n as f64 - 1.0;
    let mut c = vec![0.0, -0.0, 1.0, 2.0, last, last + 1.0, 1e12, -1e12, 3.25, last - 0.75];
    c.extend([f64::INFINITY, f64::NEG_INFINITY, f64::NAN]);
    for t in [-0.5, 0.5, 1.5, 2.5, last - 0.5, last + 0.5] {
        c.extend([t.next_down(), t, t.next_up()]);
    }
    c
}

/// Every pair `(x, y)` of [`special_coords`] (`x` the outer loop, so that most groups share
/// one `x` and a `NaN` `x` spoils only its own groups), on images of several sizes, of
/// every kind of sample, of `-0.0` only, and of `-0.0`, `0.0`, `-1.0` and `1.0` mixed
/// (where the sign of a zero position reaches the sign of a zero result), compared with
/// [`reference`] bit for bit from every start `0..8`.
fn special_nc<T: TestTexel, const NC: usize>(kernel: Kernel<T>, interp: Interp, seed: u64) {
    let mut rng = SmallRng::seed_from_u64(seed);
    for (w, h) in [(1usize, 1usize), (2, 2), (3, 5), (6, 4), (17, 9)] {
        let (xs, ys) = (special_coords(w), special_coords(h));
        let pos: Vec<[f64; 2]> = xs.iter().flat_map(|&x| ys.iter().map(move |&y| [x, y])).collect();
        for kind in 0..=T::KINDS + 2 {
            let data: Vec<T> = if kind <= T::KINDS {
                image::<T>(&mut rng, NC * w * h, kind)
            } else if kind == T::KINDS + 1 {
                vec![T::from_f32(-0.0); NC * w * h]
            } else {
                let zeros = [-0.0, 0.0, -1.0, 1.0];
                (0..NC * w * h).map(|_| T::from_f32(zeros[rng.gen_range(0..4)])).collect()
            };
            for start in 0..8 {
                if !check::<T, NC>(kernel, interp, &data, w, h, &pos[start..]) {
                    return; // no vector path on this machine: nothing to compare
                }
            }
        }
    }
}

/// [`special_nc`] for each channel count of `ncs`, seeds `seed`, `seed + 1`, ...
pub(super) fn special<T: TestTexel, F: Family<T>>(interp: Interp, ncs: &[usize], seed: u64) {
    for (s, &nc) in (seed..).zip(ncs) {
        by_nc!(nc, special_nc, T, F, (interp, s));
    }
}

/// Samples 19 inside positions of a patterned 16 x 16 image (inside for bilinear and
/// bicubic alike), checks them against [`reference`] and returns how many the kernel left
/// to the scalar path (`None` without a vector path): 3 when it vectorized every full
/// group of four or eight.
fn scalar_calls<T: TestTexel, const NC: usize>(kernel: Kernel<T>, interp: Interp) -> Option<usize> {
    let (w, h) = (16usize, 16usize);
    let data: Vec<T> = (0..NC * w * h).map(T::pattern).collect();
    let src = Source { data: &data, w, h, nc: NC };
    let pos: Vec<[f64; 2]> =
        (0..19).map(|k| [1.3 + 0.6 * k as f64, 13.9 - 0.6 * k as f64]).collect();
    let mut out = vec![T::from_f32(0.0); NC * pos.len()];
    let calls = Cell::new(0);
    let scalar = |p: &[f64; 2], px: &mut [T]| {
        calls.set(calls.get() + 1);
        reference(&src, interp, p, px)
    };
    let vector = kernel(&data, w, h, &pos, &mut out, &scalar);
    let mut want = [T::from_f32(0.0); NC];
    for (k, p) in pos.iter().enumerate() {
        reference(&src, interp, p, &mut want);
        let got: Vec<u32> = out[NC * k..NC * k + NC].iter().map(|v| v.bits()).collect();
        assert_eq!(got, want.map(T::bits), "{interp:?} NC {NC} at {p:?}");
    }
    vector.then(|| calls.get())
}

/// One random `w x h` image of sample kind `kind` (all mixed if `kind >= T::KINDS`; seed
/// `seed`) at 200 random positions,
/// checked bit for bit (the proptests).
pub(super) fn random_image<T: TestTexel, F: Family<T>, const NC: usize>(
    interp: Interp,
    w: usize,
    h: usize,
    seed: u64,
    kind: u8,
) {
    let mut rng = SmallRng::seed_from_u64(seed);
    let data = image::<T>(&mut rng, NC * w * h, kind);
    let pos = positions(&mut rng, w, h, 200);
    check::<T, NC>(F::run::<NC>, interp, &data, w, h, &pos);
}

/// [`sweep_nc`] for each channel count of `ncs`, seeds `seed`, `seed + 1`, ...
pub(super) fn sweep<T: TestTexel, F: Family<T>>(
    interp: Interp,
    ncs: &[usize],
    seed: u64,
    npos: usize,
) {
    for (s, &nc) in (seed..).zip(ncs) {
        by_nc!(nc, sweep_nc, T, F, (interp, s, npos));
    }
}

/// [`bottom_right_nc`] for each channel count of `ncs`.
pub(super) fn bottom_right<T: TestTexel, F: Family<T>>(interp: Interp, ncs: &[usize]) {
    for &nc in ncs {
        by_nc!(nc, bottom_right_nc, T, F, (interp));
    }
}

/// For each channel count of `ncs`: every full group of the 19 inside positions of
/// [`scalar_calls`] took the vector path, only the tail of three the scalar one.
pub(super) fn assert_vectorized<T: TestTexel, F: Family<T>>(interp: Interp, ncs: &[usize]) {
    for &nc in ncs {
        if let Some(calls) = by_nc!(nc, scalar_calls, T, F, (interp)) {
            assert_eq!(
                calls, 3,
                "{interp:?} NC {nc}: every full group vectorized, a tail of three"
            );
        }
    }
}
