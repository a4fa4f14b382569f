//! Moving data through a deformation: points (both directions) and images.
//!
//! **Which way the maps run.** `phi` maps the reference domain to the deformed plane, both
//! in mesh coordinates (for images: pixels, x to the right, y down, pixel `(i, j)` centred
//! at `(i, j)`).
//!
//! * points: [`forward`] is `p -> phi(p)`; [`inverse()`] is `q -> phi^-1(q)`;
//! * images: the output is `O(q) = I(phi^-1(q))`, so a feature at `p` in the input appears
//!   at `phi(p)` in the output. The inverse is solved by Newton's method on a coarse grid
//!   of output nodes and interpolated inside a cell only where a bound on the second
//!   derivatives of `phi` proves the error is below the tolerance (0.01 px by default);
//!   other cells are split down to single pixels, each solved by Newton (see [`remap`] and
//!   [`inverse()`]). Pixels whose preimage is outside the mesh get the background value (and
//!   alpha 0).
//! * folds: where `phi` is not injective a pixel has several preimages; pieces whose
//!   orientation disagrees are split down to 1 px, pieces of reversed orientation are drawn
//!   as folded, and the pixels next to the crease are solved by Newton seeded from the
//!   piece's affine inverse (so a fold shows one of its layers, not a blend; see [`remap`]
//!   for the paths and the time bound, [`RemapStats::paths_line`] for the counts).
//!   [`field::jacobian_det`] (its [`field::FoldReport`]) says where folds are.
//!
//! * tiles: [`tiles::warp_tile_into`] computes one output rectangle from only the input
//!   window [`tiles::TilePlanner`] certifies it needs, bit-identical to the whole warp (for
//!   out-of-core and distributed warps).
//!
//! Images keep their type: 8- and 16-bit gray, gray+alpha, RGB, RGBA and 32-bit float RGB
//! and RGBA; every channel is resampled with the same map (nearest, bilinear or bicubic).

pub mod colormesh;
pub mod edge;
pub mod field;
pub mod inverse;
pub mod map2;
pub(crate) mod pullback;
pub mod remap;
pub mod sample;
mod sample_simd;
mod sample_simd512;
mod sample_simd_color;
mod sample_simd_color16;
mod sample_simd_cubic;
mod sample_simd_cubic_wide;
mod sample_simd_float;
mod sample_simd_nearest;
#[cfg(test)]
mod simd_harness;
pub mod tiles;

use crate::spline::Spline;
pub use edge::EdgeMode;
use image::{DynamicImage, ImageBuffer};
use inverse::{InverseMap, InverseOptions, Preimage};
pub use map2::{pull_back_map, warp_map, AffineMap, Map2};
use rayon::prelude::*;
use remap::{BandScratch, RemapOptions, RemapPlan, RemapStats};
use sample::{Source, Texel};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Resampling of the input image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Interp {
    /// Nearest pixel.
    Nearest,
    /// Bilinear.
    #[default]
    Bilinear,
    /// Bicubic (Keys, a = -0.5), clamped to the sample range.
    Bicubic,
}

impl Interp {
    /// The names [`Interp`]'s `FromStr` takes (`--interp`, Python's `interp=`), in the
    /// order of the variants.
    pub const NAMES: [&'static str; 3] = ["nearest", "bilinear", "bicubic"];
}

/// An interpolation name that is none of [`Interp::NAMES`] (the text given).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown interpolation `{0}` (use nearest, bilinear or bicubic)")]
pub struct UnknownInterp(pub String);

impl std::str::FromStr for Interp {
    type Err = UnknownInterp;
    fn from_str(s: &str) -> Result<Interp, UnknownInterp> {
        match s {
            "nearest" => Ok(Interp::Nearest),
            "bilinear" => Ok(Interp::Bilinear),
            "bicubic" => Ok(Interp::Bicubic),
            _ => Err(UnknownInterp(s.to_string())),
        }
    }
}

/// Errors of warping.
#[derive(Debug, thiserror::Error)]
pub enum WarpError {
    /// The image type is not supported.
    #[error("unsupported image type {0:?} (use 8/16-bit gray, gray+alpha, RGB, RGBA or 32-bit float RGB/RGBA)")]
    Unsupported(image::ColorType),
    /// An edge mode a tiled warp (OME-Zarr, Dask) cannot apply.
    #[error(
        "--mode reflect is not available for tiled warps (OME-Zarr inputs, Dask): a tile reads \
         only the input window its preimages reach, not the mirrored pixels; use constant or edge"
    )]
    ReflectTiled,
    /// The image has no pixels.
    #[error("the image is empty (0 pixels)")]
    Empty,
    /// The caller's [`crate::cancel::Cancel`] token was set: the warp stopped between bands
    /// and its outputs are incomplete.
    #[error("the warp was cancelled")]
    Cancelled,
    /// [`warp_map`] was given a map without an inverse ([`Map2::has_inverse`]).
    #[error("the map has no inverse: O(q) = I(m^-1(q)) needs one (use pull_back_map for R(p) = F(m(p)))")]
    NoInverse,
    /// Pages of a stack differ in size.
    #[error("all pages must have one size: expected {expected:?}, found {found:?}")]
    PageSize {
        /// The first page's size.
        expected: (u32, u32),
        /// The differing page's size.
        found: (u32, u32),
    },
    /// Caller-owned buffers do not fit their layout ([`warp_samples_into`]).
    #[error(transparent)]
    Layout(#[from] LayoutError),
    /// A tile or its input window does not fit ([`tiles::warp_tile_into`]).
    #[error(transparent)]
    Tile(#[from] tiles::TileError),
    /// The output pages would exceed the process's memory budget ([`crate::memory`]).
    #[error(transparent)]
    Memory(#[from] crate::memory::OverBudget),
    /// The background value is not a sample of the image's type ([`check_background`]).
    #[error("--background {}: {why}; give a value in that range", short_number(*.value))]
    Background {
        /// The value given.
        value: f64,
        /// What the type holds.
        why: &'static str,
    },
}

/// A number as written by a person: `300`, `12.5`, `1e300` (not 300 digits).
fn short_number(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// Checks that `value` is a sample the pages' type holds, so that nothing is clamped or
/// rounded silently: 8-bit samples are whole numbers 0 to 255, 16-bit 0 to 65535, float
/// samples any finite number.
///
/// ```
/// use trimorph::warp::{check_background, Samples};
/// assert!(check_background(255.0, &Samples::U8(&[])).is_ok());
/// assert!(check_background(300.0, &Samples::U8(&[])).is_err());
/// assert!(check_background(12.5, &Samples::U16(&[])).is_err());
/// assert!(check_background(-3.5, &Samples::F32(&[])).is_ok());
/// ```
pub fn check_background(value: f64, like: &Samples<'_>) -> Result<(), WarpError> {
    let (max, why) = match like {
        Samples::U8(_) => (255.0, "8-bit samples are whole numbers from 0 to 255"),
        Samples::U16(_) => (65535.0, "16-bit samples are whole numbers from 0 to 65535"),
        Samples::F32(_) => {
            return if value.is_finite() && value.abs() <= f32::MAX as f64 {
                Ok(())
            } else {
                Err(WarpError::Background { value, why: "float samples are finite numbers" })
            };
        }
    };
    if !(0.0..=max).contains(&value) || value.fract() != 0.0 {
        return Err(WarpError::Background { value, why });
    }
    Ok(())
}

/// What happened while warping an image: the statistics of its preimages
/// ([`RemapStats`]: pixels, outside, largest error bound, Newton solves, folds).
pub type WarpReport = RemapStats;

/// `phi(p)` for each point (`None` outside the mesh).
pub fn forward(s: &Spline, pts: &[[f64; 2]]) -> Vec<Option<[f64; 2]>> {
    let mut out = vec![None; pts.len()];
    s.eval_many(pts, &mut out);
    out
}

/// `phi^-1(q)` for each point (`None` when no preimage within the tolerance exists),
/// polished to machine precision ([`InverseMap::polish`]: `|phi(p) - q|` at the rounding
/// level of evaluating `phi`).
pub fn inverse(s: &Spline, pts: &[[f64; 2]], opts: InverseOptions) -> Vec<Option<Preimage>> {
    let map = InverseMap::new(s, opts);
    let mut prev: Option<Preimage> = None;
    pts.iter()
        .map(|q| {
            let r = map.invert(*q, prev.as_ref()).map(|r| map.polish(*q, r));
            if r.is_some() {
                prev = r;
            }
            r
        })
        .collect()
}

/// The preimage of every pixel centre of a `w x h` output, row by row in parallel.
pub fn preimages(s: &Spline, w: u32, h: u32, opts: InverseOptions) -> Vec<Option<Preimage>> {
    let map = InverseMap::new(s, opts);
    (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut prev: Option<Preimage> = None;
            let map = &map;
            (0..w).map(move |x| {
                let r = map.invert([x as f64, y as f64], prev.as_ref());
                if r.is_some() {
                    prev = r;
                }
                r
            })
        })
        .collect()
}

/// Options of [`warp_pages`].
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct WarpOptions {
    /// Resampling of the input.
    pub interp: Interp,
    /// Value of every colour channel where the preimage is outside the mesh, and in
    /// [`EdgeMode::Constant`] where it is outside the source image (alpha is 0 there).
    pub background: f64,
    /// Preimage computation: tolerance (0.01 px by default) and coarse cell size.
    pub remap: RemapOptions,
    /// What samples read outside the source image ([`edge`]; default
    /// [`EdgeMode::Constant`]: the background).
    pub mode: EdgeMode,
}

/// A page's samples, borrowed, by sample type.
pub(super) enum Src<'a> {
    U8(Source<'a, u8>),
    U16(Source<'a, u16>),
    F32(Source<'a, f32>),
}

/// One band of a page's output, by sample type.
enum Dst<'a> {
    U8(&'a mut [u8]),
    U16(&'a mut [u16]),
    F32(&'a mut [f32]),
}

/// A page's output buffer, by sample type.
pub(super) enum Buf {
    U8(Vec<u8>),
    U16(Vec<u16>),
    F32(Vec<f32>),
}

pub(super) fn source(img: &DynamicImage) -> Result<Src<'_>, WarpError> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let nc = img.color().channel_count() as usize;
    Ok(match img {
        DynamicImage::ImageLuma8(b) => Src::U8(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageLumaA8(b) => Src::U8(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageRgb8(b) => Src::U8(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageRgba8(b) => Src::U8(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageLuma16(b) => Src::U16(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageLumaA16(b) => Src::U16(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageRgb16(b) => Src::U16(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageRgba16(b) => Src::U16(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageRgb32F(b) => Src::F32(Source { data: b.as_raw(), w, h, nc }),
        DynamicImage::ImageRgba32F(b) => Src::F32(Source { data: b.as_raw(), w, h, nc }),
        other => return Err(WarpError::Unsupported(other.color())),
    })
}

/// `buf` as an image of `like`'s type and `w x h` pixels.
pub(super) fn rebuild(like: &DynamicImage, w: u32, h: u32, buf: Buf) -> DynamicImage {
    macro_rules! back {
        ($v:ident, $data:expr) => {
            DynamicImage::$v(ImageBuffer::from_raw(w, h, $data).expect("sizes match"))
        };
    }
    match (like, buf) {
        (DynamicImage::ImageLuma8(_), Buf::U8(d)) => back!(ImageLuma8, d),
        (DynamicImage::ImageLumaA8(_), Buf::U8(d)) => back!(ImageLumaA8, d),
        (DynamicImage::ImageRgb8(_), Buf::U8(d)) => back!(ImageRgb8, d),
        (DynamicImage::ImageRgba8(_), Buf::U8(d)) => back!(ImageRgba8, d),
        (DynamicImage::ImageLuma16(_), Buf::U16(d)) => back!(ImageLuma16, d),
        (DynamicImage::ImageLumaA16(_), Buf::U16(d)) => back!(ImageLumaA16, d),
        (DynamicImage::ImageRgb16(_), Buf::U16(d)) => back!(ImageRgb16, d),
        (DynamicImage::ImageRgba16(_), Buf::U16(d)) => back!(ImageRgba16, d),
        (DynamicImage::ImageRgb32F(_), Buf::F32(d)) => back!(ImageRgb32F, d),
        (_, Buf::F32(d)) => back!(ImageRgba32F, d),
        _ => unreachable!("buffers are made from the page's own type"),
    }
}

pub(crate) fn fill<T: Texel>(
    src: &Source<'_, T>,
    pos: &[[f64; 2]],
    out: &mut [T],
    interp: Interp,
    background: f64,
    mode: EdgeMode,
) {
    use edge::fill_pixels_mode as f;
    match src.nc {
        1 => f::<T, 1>(src, pos, out, interp, background, mode),
        2 => f::<T, 2>(src, pos, out, interp, background, mode),
        3 => f::<T, 3>(src, pos, out, interp, background, mode),
        _ => f::<T, 4>(src, pos, out, interp, background, mode),
    }
}

/// A borrowed image buffer of one page: interleaved channels, rows top to bottom
/// (`w * h * nc` samples).
#[derive(Clone, Copy, Debug)]
pub enum Samples<'a> {
    /// 8-bit samples.
    U8(&'a [u8]),
    /// 16-bit samples.
    U16(&'a [u16]),
    /// 32-bit float samples.
    F32(&'a [f32]),
}

/// A mutable image buffer of one page, laid out like [`Samples`].
#[derive(Debug)]
pub enum SamplesMut<'a> {
    /// 8-bit samples.
    U8(&'a mut [u8]),
    /// 16-bit samples.
    U16(&'a mut [u16]),
    /// 32-bit float samples.
    F32(&'a mut [f32]),
}

impl Samples<'_> {
    fn len(&self) -> usize {
        match self {
            Samples::U8(d) => d.len(),
            Samples::U16(d) => d.len(),
            Samples::F32(d) => d.len(),
        }
    }
}

impl SamplesMut<'_> {
    fn len(&self) -> usize {
        match self {
            SamplesMut::U8(d) => d.len(),
            SamplesMut::U16(d) => d.len(),
            SamplesMut::F32(d) => d.len(),
        }
    }
}

/// The pixel layout of the pages given to [`warp_samples_into`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Channels per pixel, 1 to 4: gray, gray + alpha, RGB, RGBA. The last channel of 2 or 4
    /// is alpha (0 where the preimage is outside the mesh).
    pub channels: usize,
}

/// Errors of [`warp_samples_into`] about its buffers.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum LayoutError {
    /// Channels outside 1..=4.
    #[error("{0} channels per pixel (use 1 to 4: gray, gray+alpha, RGB, RGBA)")]
    Channels(usize),
    /// A buffer's length is not `width * height * channels`.
    #[error(
        "buffer {index} has {found} samples, expected {expected} ({width}x{height}x{channels})"
    )]
    Length {
        /// Which buffer (inputs first, then outputs).
        index: usize,
        /// Its length.
        found: usize,
        /// `width * height * channels`.
        expected: usize,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Channels.
        channels: usize,
    },
    /// Input and output counts or sample types differ.
    #[error("{inputs} input pages but {outputs} outputs, or their sample types differ")]
    Mismatch {
        /// Inputs.
        inputs: usize,
        /// Outputs.
        outputs: usize,
    },
}

/// Warps pages of one layout into caller-owned buffers: `O(q) = I(phi^-1(q))` for every
/// page, with one preimage computation per band of rows shared by all pages. The `_into`
/// form of [`warp_pages`] (which calls it), for callers that own their memory (the Python
/// bindings write straight into a numpy array). `progress` gets the rows finished.
pub fn warp_samples_into(
    s: &Spline,
    layout: Layout,
    pages: &[Samples<'_>],
    outs: &mut [SamplesMut<'_>],
    opts: &WarpOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<WarpReport, WarpError> {
    warp_samples_sized_into(s, layout, pages, (layout.width, layout.height), outs, opts, progress)
}

/// [`warp_samples_into`] onto an output grid of another size: `pages` have `layout`, each
/// output `out_size.0 x out_size.1` pixels with `layout.channels` channels (e.g. a moving
/// image resampled onto a fixed image's grid by a registration).
pub fn warp_samples_sized_into(
    s: &Spline,
    layout: Layout,
    pages: &[Samples<'_>],
    out_size: (u32, u32),
    outs: &mut [SamplesMut<'_>],
    opts: &WarpOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<WarpReport, WarpError> {
    let never = crate::cancel::Cancel::never();
    warp_samples_cancellable(s, layout, pages, out_size, outs, opts, progress, &never)
}

/// [`warp_samples_sized_into`] that stops when `cancel` is set: every worker looks at it
/// before each band of rows, and the call then returns [`WarpError::Cancelled`] (the
/// outputs hold the bands finished so far).
#[allow(clippy::too_many_arguments)]
pub fn warp_samples_cancellable(
    s: &Spline,
    layout: Layout,
    pages: &[Samples<'_>],
    out_size: (u32, u32),
    outs: &mut [SamplesMut<'_>],
    opts: &WarpOptions,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &crate::cancel::Cancel,
) -> Result<WarpReport, WarpError> {
    let Layout { width: iw, height: ih, channels: nc } = layout;
    let (w, h) = out_size;
    if !(1..=4).contains(&nc) {
        return Err(LayoutError::Channels(nc).into());
    }
    let same_types = pages.iter().zip(outs.iter()).all(|(p, o)| {
        matches!(
            (p, o),
            (Samples::U8(_), SamplesMut::U8(_))
                | (Samples::U16(_), SamplesMut::U16(_))
                | (Samples::F32(_), SamplesMut::F32(_))
        )
    });
    if pages.len() != outs.len() || !same_types {
        return Err(LayoutError::Mismatch { inputs: pages.len(), outputs: outs.len() }.into());
    }
    if let Some(first) = pages.first() {
        check_background(opts.background, first)?;
    }
    let expected_in = iw as usize * ih as usize * nc;
    let expected_out = w as usize * h as usize * nc;
    let lens = pages
        .iter()
        .map(|p| (p.len(), expected_in, iw, ih))
        .chain(outs.iter().map(|o| (o.len(), expected_out, w, h)));
    for (index, (found, expected, width, height)) in lens.enumerate() {
        if found != expected {
            let e = LayoutError::Length { index, found, expected, width, height, channels: nc };
            return Err(e.into());
        }
    }
    if pages.is_empty() {
        return Ok(WarpReport::default());
    }
    let (wu, hu) = (iw as usize, ih as usize);
    let srcs: Vec<Src<'_>> = pages
        .iter()
        .map(|p| match *p {
            Samples::U8(data) => Src::U8(Source { data, w: wu, h: hu, nc }),
            Samples::U16(data) => Src::U16(Source { data, w: wu, h: hu, nc }),
            Samples::F32(data) => Src::F32(Source { data, w: wu, h: hu, nc }),
        })
        .collect();
    // The plan gets what the memory budget leaves beside the pages in and out.
    let sample_bytes = |k: usize, p: &Samples<'_>| match p {
        Samples::U8(_) => k as u64,
        Samples::U16(_) => 2 * k as u64,
        Samples::F32(_) => 4 * k as u64,
    };
    let held: u64 = pages.iter().map(|p| sample_bytes(p.len(), p)).sum::<u64>().saturating_mul(2);
    let plan =
        RemapPlan::new_within(s, w, h, opts.remap, crate::memory::limit().saturating_sub(held))?;
    let band_px = plan.band_rows() as usize * w as usize;
    if plan.num_bands() == 0 {
        return Err(WarpError::Empty);
    }
    // Transpose: for each band, the band's slice of every page.
    let chunk = (band_px * nc).max(1);
    let mut bands: Vec<Vec<Dst<'_>>> = (0..plan.num_bands()).map(|_| Vec::new()).collect();
    for out in outs.iter_mut() {
        match out {
            SamplesMut::U8(d) => {
                d.chunks_mut(chunk).zip(&mut bands).for_each(|(c, b)| b.push(Dst::U8(c)))
            }
            SamplesMut::U16(d) => {
                d.chunks_mut(chunk).zip(&mut bands).for_each(|(c, b)| b.push(Dst::U16(c)))
            }
            SamplesMut::F32(d) => {
                d.chunks_mut(chunk).zip(&mut bands).for_each(|(c, b)| b.push(Dst::F32(c)))
            }
        }
    }
    let (interp, bg, mode) = (opts.interp, opts.background, opts.mode);
    // One worker per thread, each with its own band buffers (allocated once, not per rayon
    // split: a split's buffer would be a fresh 2 MiB to zero or fault in), taking the next
    // band from a shared counter until none is left.
    let workers = rayon::current_num_threads().clamp(1, bands.len());
    let bands: Vec<Mutex<Vec<Dst<'_>>>> = bands.into_iter().map(Mutex::new).collect();
    let next = AtomicUsize::new(0);
    let stats = (0..workers)
        .into_par_iter()
        .map(|_| {
            let (mut pos, mut scratch) = (vec![[0.0f64; 2]; band_px], BandScratch::default());
            let mut st = RemapStats::default();
            loop {
                if cancel.is_cancelled() {
                    break;
                }
                let b = next.fetch_add(1, Ordering::Relaxed);
                let Some(cell) = bands.get(b) else { break };
                let dsts = std::mem::take(&mut *cell.lock().unwrap_or_else(|e| e.into_inner()));
                st.merge(&plan.fill_band_with(b, &mut pos, None, &mut scratch));
                for (dst, src) in dsts.into_iter().zip(&srcs) {
                    let n = match &dst {
                        Dst::U8(d) => d.len(),
                        Dst::U16(d) => d.len(),
                        Dst::F32(d) => d.len(),
                    };
                    let pos = &pos[..n / nc];
                    match (dst, src) {
                        (Dst::U8(d), Src::U8(s)) => fill(s, pos, d, interp, bg, mode),
                        (Dst::U16(d), Src::U16(s)) => fill(s, pos, d, interp, bg, mode),
                        (Dst::F32(d), Src::F32(s)) => fill(s, pos, d, interp, bg, mode),
                        _ => unreachable!("sample types are checked above"),
                    }
                }
                progress(plan.band_rows().min(h - b as u32 * plan.band_rows()) as u64);
            }
            st
        })
        .reduce(RemapStats::default, |mut a, b| {
            a.merge(&b);
            a
        });
    if cancel.is_cancelled() {
        return Err(WarpError::Cancelled);
    }
    Ok(stats)
}

/// Warps pages of one size the same way: `O(q) = I(phi^-1(q))`, each output the size and
/// type of its input. The preimages are computed once per band of rows and shared by all
/// pages ([`warp_samples_into`]); `progress` is called with the number of output rows
/// finished (from any thread).
pub fn warp_pages(
    s: &Spline,
    pages: &[DynamicImage],
    opts: &WarpOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Vec<DynamicImage>, WarpReport), WarpError> {
    let size = pages.first().map_or((0, 0), |p| (p.width(), p.height()));
    warp_pages_sized(s, pages, size, opts, progress)
}

/// [`warp_pages`] onto an output grid of `out_size` pixels (each output of its input's
/// type).
pub fn warp_pages_sized(
    s: &Spline,
    pages: &[DynamicImage],
    out_size: (u32, u32),
    opts: &WarpOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Vec<DynamicImage>, WarpReport), WarpError> {
    let Some(first) = pages.first() else { return Ok((Vec::new(), WarpReport::default())) };
    let (w, h) = (first.width(), first.height());
    let (ow, oh) = out_size;
    if let Some(p) = pages.iter().find(|p| (p.width(), p.height()) != (w, h)) {
        return Err(WarpError::PageSize { expected: (w, h), found: (p.width(), p.height()) });
    }
    let nc = first.color().channel_count() as usize;
    let srcs = pages.iter().map(source).collect::<Result<Vec<_>, _>>()?;
    if let Some(p) = pages.iter().find(|p| p.color().channel_count() as usize != nc) {
        return Err(WarpError::Unsupported(p.color()));
    }
    let samples: Vec<Samples<'_>> = srcs
        .iter()
        .map(|s| match s {
            Src::U8(s) => Samples::U8(s.data),
            Src::U16(s) => Samples::U16(s.data),
            Src::F32(s) => Samples::F32(s.data),
        })
        .collect();
    // The inputs are held while the outputs (as large) are written.
    let in_bytes: u64 = pages.iter().map(|p| p.as_bytes().len() as u64).sum();
    crate::memory::check(in_bytes.saturating_mul(2), || {
        format!(
            "warping {} page(s) of {w} x {h} {:?} (input and output)",
            pages.len(),
            first.color()
        )
    })?;
    let out_len = ow as usize * oh as usize * nc;
    let mut bufs: Vec<Buf> = samples
        .iter()
        .map(|s| match s {
            Samples::U8(_) => Buf::U8(vec![0; out_len]),
            Samples::U16(_) => Buf::U16(vec![0; out_len]),
            Samples::F32(_) => Buf::F32(vec![0.0; out_len]),
        })
        .collect();
    let mut outs: Vec<SamplesMut<'_>> = bufs
        .iter_mut()
        .map(|b| match b {
            Buf::U8(d) => SamplesMut::U8(d),
            Buf::U16(d) => SamplesMut::U16(d),
            Buf::F32(d) => SamplesMut::F32(d),
        })
        .collect();
    let layout = Layout { width: w, height: h, channels: nc };
    let stats = warp_samples_sized_into(s, layout, &samples, out_size, &mut outs, opts, progress)?;
    drop(outs);
    let out = pages.iter().zip(bufs).map(|(p, b)| rebuild(p, ow, oh, b)).collect();
    Ok((out, stats))
}

/// Warps an image: `O(q) = I(phi^-1(q))`, same size and type as the input.
pub fn warp_image(
    s: &Spline,
    img: &DynamicImage,
    interp: Interp,
    background: f64,
    opts: InverseOptions,
) -> Result<(DynamicImage, WarpReport), WarpError> {
    let wo = WarpOptions {
        interp,
        background,
        remap: RemapOptions { inverse: opts, ..Default::default() },
        mode: EdgeMode::default(),
    };
    let (mut out, rep) = warp_pages(s, std::slice::from_ref(img), &wo, &|_| {})?;
    Ok((out.pop().expect("one page in, one page out"), rep))
}

#[cfg(test)]
mod tests;
