//! The one check of an image's declared size, made from its header before anything is
//! decoded ([`check_header`]), and how a command will use the image it reads
//! ([`ImageUse`]).
//!
//! Every image reader ([`super::raster::read_stack_as`], the TIFF pages, PNG, JPEG and PNM
//! through the `image` crate) reads the header first, asks this check, and only then lets a
//! decoder allocate. The check covers, in checked arithmetic:
//!
//! * the page's pixels: at least one, at most [`MAX_PIXELS`];
//! * the largest side the use allows ([`ImageUse::max_side`]: a picture shown by the editor
//!   is held to the largest background `render` draws);
//! * the memory budget ([`crate::memory`]): the decoded pages so far and this one, times the
//!   copies the command keeps while it runs ([`ImageUse::copies`]: a warp holds its input,
//!   its output and the output's encoding).
//!
//! Issue 54: a 669-byte JPEG declaring 20000 x 20000 RGB was decoded (1.2 GB) before the
//! warp found that the input, the output and its encoding exceeded the budget; now the
//! header alone is enough to refuse it.

use std::path::{Path, PathBuf};

/// Largest number of pixels per page accepted when decoding (2^30, e.g. 32768 x 32768).
pub const MAX_PIXELS: u64 = 1 << 30;

/// The largest side (pixels) of a picture trimorph draws: a rendered deformation, a plot,
/// a background under a mesh (`render --size`, `render --background`, the editor's frame).
/// Defined here, below the renderer, because readers hold images to it too.
pub const MAX_DRAWN_SIDE: u32 = 16384;

/// Why an image is refused on its header, before any decoding ([`check_header`]).
#[derive(Debug, thiserror::Error)]
pub enum HeaderError {
    /// A page is larger than [`MAX_PIXELS`] or empty.
    #[error("{path}, page {page}: the image declares {width} x {height} pixels, outside 1 .. 2^30 pixels, so it is not decoded; crop or split it into smaller images")]
    Size {
        /// The file.
        path: PathBuf,
        /// Page number (0-based).
        page: usize,
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
    },
    /// The image is larger than its use allows ([`ImageUse::max_side`]).
    #[error("{path}: the image is {width} x {height} pixels; a picture shown under the mesh is at most {max} x {max} pixels (as for `render --background`), so it is not decoded: scale it down")]
    TooLargeFor {
        /// The file.
        path: PathBuf,
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// The largest side.
        max: u32,
    },
    /// Decoding would exceed the process's memory budget ([`crate::memory`]).
    #[error("{path}: {source}")]
    Memory {
        /// The file.
        path: PathBuf,
        /// The budget check that failed.
        source: crate::memory::OverBudget,
    },
}

/// How a command uses an image it reads: what the header check allows ([`check_header`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageUse {
    /// Bytes the command holds per decoded byte while it runs (at least 1).
    pub copies: u64,
    /// The largest width and height (`None`: only [`MAX_PIXELS`] per page); refused as a
    /// picture too large to show ([`HeaderError::TooLargeFor`]).
    pub max_side: Option<u32>,
    /// Only the first page is read (the others of a TIFF are not looked at).
    pub first_page_only: bool,
    /// What the command does with the image, for messages (empty: only decoding).
    pub what: &'static str,
}

impl ImageUse {
    /// Decoded and kept as it is: `register`, `morph`, `match`, frames, `colormesh`.
    pub const DECODE: ImageUse =
        ImageUse { copies: 1, max_side: None, first_page_only: false, what: "" };
    /// Warped: the input, the output and its encoding are held at once (`warp --image`).
    pub const WARP: ImageUse = ImageUse {
        copies: 3,
        max_side: None,
        first_page_only: false,
        what: "for warping (input, output and its encoding)",
    };
    /// A picture shown under the mesh (the editor's frame): the first page, at most the
    /// largest picture trimorph draws ([`MAX_DRAWN_SIDE`] per side), held decoded and as
    /// the PNG sent to the page.
    pub const PICTURE: ImageUse = ImageUse {
        copies: 2,
        max_side: Some(MAX_DRAWN_SIDE),
        first_page_only: true,
        what: "as a picture (decoded and as PNG)",
    };
}

/// The pixels of a `width x height` page when it holds 1 to [`MAX_PIXELS`] of them, in
/// checked arithmetic (`None` when empty, too large or overflowing). Every reader's size
/// rule: [`check_header`] and the OME-Zarr planes ([`super::ngff`]).
pub(crate) fn page_pixels(width: u64, height: u64) -> Option<u64> {
    width.checked_mul(height).filter(|&n| n > 0 && n <= MAX_PIXELS)
}

/// Checks page `page` of `path`, declared `width x height` with `bytes` decoded bytes
/// (`None`: the product overflowed), after `held` bytes of earlier pages, for `usage`
/// (`color` names the pixel type in messages). Returns the bytes held with this page.
///
/// ```
/// use std::path::Path;
/// use trimorph::io::image_use::{check_header, ImageUse};
/// let p = Path::new("bomb.png");
/// // 30000 x 30000 is too large for a picture, whatever the budget.
/// assert!(check_header(p, 0, 30000, 30000, Some(900_000_000), 0, &ImageUse::PICTURE, "L8")
///     .is_err());
/// assert!(check_header(p, 0, 0, 10, Some(0), 0, &ImageUse::DECODE, "L8").is_err());
/// assert_eq!(check_header(p, 0, 8, 8, Some(64), 0, &ImageUse::DECODE, "L8").unwrap(), 64);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn check_header(
    path: &Path,
    page: usize,
    width: u32,
    height: u32,
    bytes: Option<u64>,
    held: u64,
    usage: &ImageUse,
    color: &str,
) -> Result<u64, HeaderError> {
    let budget = crate::memory::limit();
    check_header_against(budget, path, page, width, height, bytes, held, usage, color)
}

/// [`check_header`] under the memory budget `budget`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn check_header_against(
    budget: u64,
    path: &Path,
    page: usize,
    width: u32,
    height: u32,
    bytes: Option<u64>,
    held: u64,
    usage: &ImageUse,
    color: &str,
) -> Result<u64, HeaderError> {
    if page_pixels(u64::from(width), u64::from(height)).is_none() {
        return Err(HeaderError::Size { path: path.to_path_buf(), page, width, height });
    }
    if let Some(max) = usage.max_side.filter(|&m| width > m || height > m) {
        return Err(HeaderError::TooLargeFor { path: path.to_path_buf(), width, height, max });
    }
    let total = bytes.and_then(|b| b.checked_add(held));
    let need = total.and_then(|t| t.checked_mul(usage.copies.max(1))).unwrap_or(u64::MAX);
    crate::memory::check_against(budget, need, || {
        let pages = if page == 0 { String::new() } else { format!("{} page(s) of ", page + 1) };
        let what = if usage.what.is_empty() { String::new() } else { format!(" {}", usage.what) };
        format!("decoding {pages}{width} x {height} {color}{what}")
    })
    .map_err(|source| HeaderError::Memory { path: path.to_path_buf(), source })?;
    Ok(total.unwrap_or(u64::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 54: the budget counts the copies the command keeps, so that a warp's input is
    /// refused from its header when input, output and encoding would not fit.
    #[test]
    fn the_header_check_counts_the_copies_a_command_keeps() {
        let p = Path::new("x.jpg");
        let mb = 1 << 20;
        let check = |u: &ImageUse| {
            check_header_against(64 * mb, p, 0, 4096, 2048, Some(24 * mb), 0, u, "Rgb8")
        };
        assert_eq!(check(&ImageUse::DECODE).unwrap(), 24 * mb);
        let warp = check(&ImageUse::WARP);
        let e = warp.unwrap_err().to_string();
        assert!(e.contains("x.jpg: decoding 4096 x 2048 Rgb8 for warping"), "{e}");
        assert!(e.contains("needs 72.0 MiB"), "{e}");
    }

    /// Sizes whose products overflow are refused, never wrapped.
    #[test]
    fn overflowing_sizes_are_refused() {
        assert_eq!(page_pixels(1 << 33, 1 << 31), None);
        assert_eq!(page_pixels(0, 10), None);
        assert_eq!(page_pixels(1 << 15, 1 << 15), Some(MAX_PIXELS));
        assert_eq!(page_pixels(1 << 15, (1 << 15) + 1), None);
        let p = Path::new("x.tif");
        let e = check_header(p, 0, u32::MAX, u32::MAX, None, 0, &ImageUse::DECODE, "L8");
        assert!(matches!(e, Err(HeaderError::Size { .. })), "{e:?}");
        let e = check_header(p, 3, 8, 8, None, u64::MAX, &ImageUse::WARP, "L8");
        assert!(matches!(e, Err(HeaderError::Memory { .. })), "{e:?}");
    }

    /// Issue 54: the editor took a 30000 x 30000 PNG that `render --background` refuses.
    #[test]
    fn a_picture_is_held_to_the_largest_background() {
        let p = Path::new("bomb.png");
        let side = MAX_DRAWN_SIDE;
        let e = check_header(p, 0, side + 1, 8, Some(1), 0, &ImageUse::PICTURE, "L8")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bomb.png: the image is 16385 x 8 pixels"), "{e}");
        assert!(check_header(p, 0, side, side, Some(1), 0, &ImageUse::PICTURE, "L8").is_ok());
    }
}
