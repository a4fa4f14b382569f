//! Reading and writing images, including multi-page TIFF stacks.
//!
//! A [`Stack`] is one or more pages of one size and type. PNG, JPEG and Netpbm files (PGM,
//! PPM, PBM, PAM: <https://netpbm.sourceforge.net/doc/pnm.html>) hold one page;
//! TIFF files hold any number, read and written page by page with the `tiff` crate. Types
//! kept exactly: 8- and 16-bit gray, gray+alpha, RGB and RGBA, and 32-bit float gray, RGB
//! and RGBA. Float gray pages are held as RGB float with three equal channels (the `image`
//! crate has no float gray type) and written back as float gray. Decoding is bounded: every
//! page's header is checked first ([`super::image_use::check_header`]: at most
//! [`MAX_PIXELS`] per page, the memory budget for what the command keeps, [`ImageUse`]), and
//! nothing is allocated for a page that fails.

use super::image_use::check_header_against;
pub use super::image_use::{HeaderError, ImageUse, MAX_PIXELS};
use super::tiff_checks;
use super::{write_atomic, IoError};
use image::{DynamicImage, ImageBuffer, ImageFormat};
use std::io::Cursor;
use std::path::{Path, PathBuf};

/// Errors of image input and output.
#[derive(Debug, thiserror::Error)]
pub enum RasterError {
    /// File-system error.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The file could not be decoded.
    #[error(
        "{path}: cannot decode image: {reason} (is the file complete, and a PNG, TIFF, JPEG or PNM?)"
    )]
    Decode {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// A page's pixel type is not supported.
    #[error("{path}, page {page}: unsupported pixel type {kind} (use 8/16-bit gray, gray+alpha, RGB, RGBA or 32-bit float gray/RGB/RGBA)")]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// Page number (0-based).
        page: usize,
        /// The type found.
        kind: String,
    },
    /// The header check refused the image before decoding ([`HeaderError`]: too many
    /// pixels, too large for its use, or over the memory budget).
    #[error(transparent)]
    Header(#[from] HeaderError),
    /// A page's samples cannot be read as one of the types kept (a gray+alpha TIFF whose
    /// second sample is not marked as unassociated alpha).
    #[error("{path}, page {page}: {reason}")]
    Samples {
        /// The file.
        path: PathBuf,
        /// Page number (0-based).
        page: usize,
        /// What the samples are and what to do.
        reason: String,
    },
    /// Pages differ in size or type.
    #[error("{path}, page {page}: all pages of a stack must have the size and type of page 0")]
    Mixed {
        /// The file.
        path: PathBuf,
        /// Page number (0-based).
        page: usize,
    },
    /// The output cannot hold what is being written.
    #[error("{path}: {reason}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}

/// Pages of one size and type.
#[derive(Clone, Debug)]
pub struct Stack {
    /// The pages.
    pub pages: Vec<DynamicImage>,
    /// The pages are float gray held as RGB float (written back as float gray).
    pub gray_float: bool,
}

fn is_tiff(path: &Path) -> bool {
    matches!(
        path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(),
        Some("tif" | "tiff")
    )
}

/// Reads an image file: every page of a TIFF, the single page of other formats (decoded
/// and kept as they are: [`ImageUse::DECODE`]).
pub fn read_stack(path: &Path) -> Result<Stack, RasterError> {
    read_stack_as(path, &ImageUse::DECODE)
}

/// Reads an image file for `usage`: every page's header is checked
/// ([`super::image_use::check_header`]) before the page is decoded.
pub fn read_stack_as(path: &Path, usage: &ImageUse) -> Result<Stack, RasterError> {
    use std::io::{Read, Seek};
    let read_err = |source| IoError::Read { path: path.to_path_buf(), source };
    // A TIFF is decoded from the file itself, so its strips go straight from the page cache
    // into the decoded buffer (no whole-file copy in memory: one buffer of the image's size
    // less to fault in and fill, about 4 ms of a 4096^2 gray warp). Other formats, and
    // TIFFs too short to sniff, are read whole.
    let mut file = std::fs::File::open(path).map_err(read_err)?;
    let len = file.metadata().map_err(read_err)?.len();
    let mut magic = [0u8; 4];
    if len >= 8 && file.read_exact(&mut magic).is_ok() && has_tiff_magic(&magic) {
        file.rewind().map_err(read_err)?;
        let reader = std::io::BufReader::with_capacity(64 << 10, file);
        return read_tiff(path, reader, len, crate::memory::limit(), usage);
    }
    let bytes = std::fs::read(path).map_err(read_err)?;
    decode_stack_as(&bytes, path, usage)
}

/// Whether `bytes` begin as a classic TIFF (42) or a BigTIFF (43), either byte order.
fn has_tiff_magic(bytes: &[u8]) -> bool {
    [b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"].iter().any(|m| bytes.starts_with(*m))
}

/// Decodes an image held in memory, as [`read_stack`] decodes a file (the format is found
/// from the content, not from `path`, which only names the input in errors): the same
/// size limits, memory budget and completeness checks.
pub fn decode_stack(bytes: &[u8], path: &Path) -> Result<Stack, RasterError> {
    decode_stack_as(bytes, path, &ImageUse::DECODE)
}

/// [`decode_stack`] for `usage` ([`read_stack_as`]).
pub fn decode_stack_as(bytes: &[u8], path: &Path, usage: &ImageUse) -> Result<Stack, RasterError> {
    let derr = |reason: String| RasterError::Decode { path: path.to_path_buf(), reason };
    let budget = crate::memory::limit();
    if has_tiff_magic(bytes) {
        return read_tiff(path, Cursor::new(bytes), bytes.len() as u64, budget, usage);
    }
    let mut reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| derr(e.to_string()))?;
    if reader.format().is_none() {
        return Err(derr("unknown image format (use PNG, TIFF, JPEG or PNM)".into()));
    }
    // The header alone first: a page too large for the use is refused before a decoder
    // exists (the budget is checked again below with the decoder's exact sample size).
    let (w, h) = reader.into_dimensions().map_err(|e| derr(e.to_string()))?;
    check_header_against(budget, path, 0, w, h, Some(0), 0, usage, "")?;
    reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| derr(e.to_string()))?;
    // The decoder's own limits as well, enforced before it allocates.
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(w);
    limits.max_image_height = Some(h);
    limits.max_alloc = Some(decoder_limit(budget));
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(|e| derr(e.to_string()))?;
    let need = image::ImageDecoder::total_bytes(&decoder);
    let color = format!("{:?}", image::ImageDecoder::color_type(&decoder));
    check_header_against(budget, path, 0, w, h, Some(need), 0, usage, &color)?;
    if reader_format_is_jpeg(bytes) && !jpeg_is_complete(bytes) {
        return Err(derr(
            "the JPEG stream ends before its end-of-image marker (the file is truncated)".into(),
        ));
    }
    let img = DynamicImage::from_decoder(decoder).map_err(|e| derr(e.to_string()))?;
    check_type(path, 0, &img)?;
    Ok(Stack { pages: vec![img], gray_float: false })
}

/// Reads one image to show as a picture (the editor's frame, [`ImageUse::PICTURE`]): the
/// single page of a PNG or JPEG, the first page of a TIFF, at most as large as the largest
/// background `render` draws, with the memory budget and the completeness checks of
/// [`read_stack`].
pub fn read_image(path: &Path) -> Result<DynamicImage, RasterError> {
    Ok(read_stack_as(path, &ImageUse::PICTURE)?.pages.swap_remove(0))
}

fn check_type(path: &Path, page: usize, img: &DynamicImage) -> Result<(), RasterError> {
    match img {
        DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageRgb8(_)
        | DynamicImage::ImageRgba8(_)
        | DynamicImage::ImageLuma16(_)
        | DynamicImage::ImageLumaA16(_)
        | DynamicImage::ImageRgb16(_)
        | DynamicImage::ImageRgba16(_)
        | DynamicImage::ImageRgb32F(_)
        | DynamicImage::ImageRgba32F(_) => Ok(()),
        other => Err(RasterError::Unsupported {
            path: path.to_path_buf(),
            page,
            kind: format!("{:?}", other.color()),
        }),
    }
}

/// The decoders' own allocation limit under the memory budget `budget`: no page the budget
/// accepts is larger, and a file cannot make a decoder allocate more for anything else
/// (found by fuzzing: a TIFF tag declaring 2^28 values made the `tiff` crate reserve
/// 11 GiB for them, from a 623-byte file, when its limit was `MAX_PIXELS * 16`).
fn decoder_limit(budget: u64) -> u64 {
    budget.min(MAX_PIXELS * 16)
}

/// Every page of the TIFF read by `reader` (`file_len` bytes long), under the memory budget
/// `budget`.
fn read_tiff<R: std::io::Read + std::io::Seek>(
    path: &Path,
    reader: R,
    file_len: u64,
    budget: u64,
    usage: &ImageUse,
) -> Result<Stack, RasterError> {
    use tiff::decoder::{Decoder, DecodingResult, Limits};
    use tiff::ColorType as C;
    let derr = |e: tiff::TiffError| RasterError::Decode {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    // Two limits: while tags are read, what a file of this length can hold (a tag's values
    // lie in the file: at most one per byte, each held in a 32-byte `Value`); while a page
    // is decoded, the budget (the page itself was checked against it first).
    let with_limit = |bytes: u64| {
        let mut limits = Limits::default();
        limits.decoding_buffer_size = usize::try_from(bytes).unwrap_or(usize::MAX);
        limits
    };
    let tag_limits =
        with_limit(decoder_limit(budget).min(file_len.saturating_mul(64).max(1 << 20)));
    let page_limits = with_limit(decoder_limit(budget));
    let mut dec = Decoder::new(reader).map_err(derr)?.with_limits(tag_limits.clone());
    let mut pages = Vec::new();
    let mut gray_float = false;
    let mut held = 0u64;
    loop {
        let page = pages.len();
        let (w, h) = dec.dimensions().map_err(derr)?;
        check_header_against(budget, path, page, w, h, Some(0), held, usage, "")?;
        let ct = tiff_checks::colortype(&mut dec).map_err(|e| match e {
            Ok(e) => derr(e),
            Err(reason) => RasterError::Samples { path: path.to_path_buf(), page, reason },
        })?;
        // Every page's decoded samples stay: the budget covers the pages so far and this
        // one (float gray is widened to RGB, and briefly held twice).
        let page_bytes = tiff_page_bytes(w, h, ct);
        let color = format!("{ct:?}");
        held = check_header_against(budget, path, page, w, h, page_bytes, held, usage, &color)?;
        tiff_checks::check_strips(&mut dec, file_len).map_err(|reason| RasterError::Decode {
            path: path.to_path_buf(),
            reason: format!("page {page}: {reason}"),
        })?;
        let unsupported =
            |kind: String| RasterError::Unsupported { path: path.to_path_buf(), page, kind };
        // Extra samples beyond the colour type's (a 5-sample RGB page decodes as RGB, the
        // other two dropped): refused, never lost silently.
        let channels: u32 = match ct {
            C::Gray(_) => 1,
            C::GrayA(_) => 2,
            C::RGB(_) => 3,
            C::RGBA(_) => 4,
            _ => 0,
        };
        let spp = dec.get_tag_u32(tiff::tags::Tag::SamplesPerPixel).unwrap_or(channels.max(1));
        if channels > 0 && spp != channels {
            return Err(unsupported(format!(
                "{ct:?} with {spp} samples per pixel ({} beyond the colour type's; trimorph \
                 reads 1 to 4 samples: split the channels into separate pages or files first)",
                spp.saturating_sub(channels)
            )));
        }
        dec = dec.with_limits(page_limits.clone());
        let data = dec.read_image().map_err(derr)?;
        dec = dec.with_limits(tag_limits.clone());
        let bad = || RasterError::Decode {
            path: path.to_path_buf(),
            reason: format!("page {page}: sample count does not match {w} x {h} {ct:?}"),
        };
        macro_rules! buf {
            ($v:ident, $d:expr) => {
                DynamicImage::$v(ImageBuffer::from_raw(w, h, $d).ok_or_else(bad)?)
            };
        }
        let img = match (ct, data) {
            (C::Gray(8), DecodingResult::U8(d)) => buf!(ImageLuma8, d),
            (C::GrayA(8), DecodingResult::U8(d)) => buf!(ImageLumaA8, d),
            (C::RGB(8), DecodingResult::U8(d)) => buf!(ImageRgb8, d),
            (C::RGBA(8), DecodingResult::U8(d)) => buf!(ImageRgba8, d),
            (C::Gray(16), DecodingResult::U16(d)) => buf!(ImageLuma16, d),
            (C::GrayA(16), DecodingResult::U16(d)) => buf!(ImageLumaA16, d),
            (C::RGB(16), DecodingResult::U16(d)) => buf!(ImageRgb16, d),
            (C::RGBA(16), DecodingResult::U16(d)) => buf!(ImageRgba16, d),
            (C::RGB(32), DecodingResult::F32(d)) => buf!(ImageRgb32F, d),
            (C::RGBA(32), DecodingResult::F32(d)) => buf!(ImageRgba32F, d),
            (C::Gray(32), DecodingResult::F32(d)) => {
                gray_float = true;
                let rgb: Vec<f32> = d.iter().flat_map(|&v| [v, v, v]).collect();
                buf!(ImageRgb32F, rgb)
            }
            (ct, _) => return Err(unsupported(format!("{ct:?}"))),
        };
        if let Some(first) = pages.first() {
            let first: &DynamicImage = first;
            if (first.width(), first.height(), first.color()) != (w, h, img.color())
                || (gray_float != matches!(ct, C::Gray(32)))
            {
                return Err(RasterError::Mixed { path: path.to_path_buf(), page });
            }
        }
        pages.push(img);
        if usage.first_page_only || !dec.more_images() {
            break;
        }
        dec.next_image().map_err(derr)?;
    }
    Ok(Stack { pages, gray_float })
}

/// Bytes of one decoded TIFF page as it is held ([`Stack`]): samples of the colour type,
/// with 32-bit float gray widened to RGB (plus the gray buffer while it is widened).
fn tiff_page_bytes(w: u32, h: u32, ct: tiff::ColorType) -> Option<u64> {
    use tiff::ColorType as C;
    let px = u64::from(w).checked_mul(u64::from(h))?;
    let (channels, bits) = match ct {
        C::Gray(b) => (1, b),
        C::GrayA(b) => (2, b),
        C::RGB(b) => (3, b),
        C::RGBA(b) => (4, b),
        C::CMYK(b) => (4, b),
        _ => (4, 32),
    };
    let bytes = px.checked_mul(channels)?.checked_mul(u64::from(bits).div_ceil(8))?;
    if matches!(ct, C::Gray(32)) {
        bytes.checked_mul(4)
    } else {
        Some(bytes)
    }
}

fn reader_format_is_jpeg(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0xFF, 0xD8, 0xFF])
}

/// A JPEG is complete when an end-of-image marker (`FF D9`) follows its last start-of-scan
/// marker (`FF DA`). Inside entropy-coded data every `FF` byte is followed by `00` or a
/// restart marker, so neither marker can appear there by accident; an embedded thumbnail's
/// end marker comes before the main image's scans and does not count.
fn jpeg_is_complete(bytes: &[u8]) -> bool {
    let last_sos = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]);
    match last_sos {
        Some(i) => bytes[i..].windows(2).any(|w| w == [0xFF, 0xD9]),
        None => false,
    }
}

/// Writes a stack atomically: TIFF (any number of pages, types kept), or PNG / JPEG / PNM (one
/// page; JPEG holds 8-bit gray and RGB only; PNM as the extension says, see `encode_pnm`).
pub fn write_stack(path: &Path, stack: &Stack) -> Result<(), RasterError> {
    if is_tiff(path) {
        return write_tiff(path, stack);
    }
    let eerr = |reason: String| RasterError::Encode { path: path.to_path_buf(), reason };
    if stack.pages.len() != 1 {
        return Err(eerr(format!(
            "{} pages: only TIFF (.tif) holds a stack of pages",
            stack.pages.len()
        )));
    }
    let fmt = ImageFormat::from_path(path).map_err(|_| {
        eerr("unknown image extension (use .png, .tif, .jpg, .pgm, .ppm or .pam)".into())
    })?;
    let page = &stack.pages[0];
    // Formats that cannot hold the page's samples are refused, never converted silently.
    let float = matches!(page, DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_));
    let kind =
        if stack.gray_float { "float gray".to_string() } else { format!("{:?}", page.color()) };
    match fmt {
        ImageFormat::Jpeg
            if !matches!(page, DynamicImage::ImageLuma8(_) | DynamicImage::ImageRgb8(_)) =>
        {
            return Err(eerr(format!(
                "a JPEG holds 8-bit gray or RGB only, not {kind} (use {}, which keeps it)",
                if float { ".tif" } else { ".png or .tif" }
            )));
        }
        ImageFormat::Png if float => {
            return Err(eerr(format!("a PNG holds 8- or 16-bit samples, not {kind} (use .tif)")));
        }
        _ => {}
    }
    let bytes = if fmt == ImageFormat::Pnm {
        super::pnm::encode_pnm(path, page, stack.gray_float).map_err(eerr)?
    } else {
        let mut out = Cursor::new(Vec::new());
        page.write_to(&mut out, fmt).map_err(|e| eerr(e.to_string()))?;
        out.into_inner()
    };
    write_atomic(path, &bytes)?;
    Ok(())
}

/// [`write_stack`] for a TIFF: encoded into the temporary file directly where it can seek
/// (the encoder patches offsets), so the samples go from the image to the page cache with
/// no copy of the whole file in memory (about 5 ms of a 4096^2 gray warp). A FIFO or device,
/// opened once, gets the bytes encoded in memory.
fn write_tiff(path: &Path, stack: &Stack) -> Result<(), RasterError> {
    let eerr = |e: tiff::TiffError| RasterError::Encode {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let mut f = crate::io::AtomicFile::create(path)?;
    if f.seekable() {
        encode_tiff_into(&mut f, stack, CLASSIC_TIFF_MAX).map_err(eerr)?;
    } else {
        let bytes = encode_tiff(stack).map_err(eerr)?;
        std::io::Write::write_all(&mut f, &bytes)
            .map_err(|source| IoError::Write { path: path.to_path_buf(), source })?;
    }
    Ok(f.commit()?)
}

/// Classic TIFF addresses at most 4 GiB; larger stacks are written as BigTIFF (which
/// Fiji, tifffile and libtiff read), with a margin for the directories.
const CLASSIC_TIFF_MAX: u64 = (4 << 30) - (16 << 20);

fn encode_tiff(stack: &Stack) -> Result<Vec<u8>, tiff::TiffError> {
    encode_tiff_above(stack, CLASSIC_TIFF_MAX)
}

/// [`encode_tiff`] with BigTIFF above `classic_max` bytes of samples.
fn encode_tiff_above(stack: &Stack, classic_max: u64) -> Result<Vec<u8>, tiff::TiffError> {
    let raw = sample_bytes(stack);
    // Samples plus directories and strip tables: one allocation, no regrowth.
    let cap = raw.saturating_add(stack.pages.len() as u64 * 65_536).min(isize::MAX as u64);
    let mut out = Cursor::new(Vec::with_capacity(cap as usize));
    encode_tiff_into(&mut out, stack, classic_max)?;
    Ok(out.into_inner())
}

/// Encodes `stack` as TIFF into `out` (BigTIFF above `classic_max` bytes of samples).
fn encode_tiff_into<W: std::io::Write + std::io::Seek>(
    out: &mut W,
    stack: &Stack,
    classic_max: u64,
) -> Result<(), tiff::TiffError> {
    use tiff::encoder::TiffEncoder;
    if sample_bytes(stack) > classic_max {
        encode_pages(&mut TiffEncoder::new_big(out)?, stack)
    } else {
        encode_pages(&mut TiffEncoder::new(out)?, stack)
    }
}

/// Bytes of samples in all pages of `stack`.
fn sample_bytes(stack: &Stack) -> u64 {
    stack.pages.iter().map(|p| p.as_bytes().len() as u64).sum()
}

fn encode_pages<W: std::io::Write + std::io::Seek, K: tiff::encoder::TiffKind>(
    enc: &mut tiff::encoder::TiffEncoder<W, K>,
    stack: &Stack,
) -> Result<(), tiff::TiffError> {
    use tiff::encoder::colortype as ct;
    {
        for page in &stack.pages {
            let (w, h) = (page.width(), page.height());
            match page {
                DynamicImage::ImageLuma8(b) => enc.write_image::<ct::Gray8>(w, h, b.as_raw())?,
                DynamicImage::ImageLumaA8(b) => {
                    // TIFF gray+alpha is not in the encoder: store as RGBA with equal colours.
                    let d: Vec<u8> =
                        b.as_raw().chunks(2).flat_map(|p| [p[0], p[0], p[0], p[1]]).collect();
                    enc.write_image::<ct::RGBA8>(w, h, &d)?
                }
                DynamicImage::ImageRgb8(b) => enc.write_image::<ct::RGB8>(w, h, b.as_raw())?,
                DynamicImage::ImageRgba8(b) => enc.write_image::<ct::RGBA8>(w, h, b.as_raw())?,
                DynamicImage::ImageLuma16(b) => enc.write_image::<ct::Gray16>(w, h, b.as_raw())?,
                DynamicImage::ImageLumaA16(b) => {
                    let d: Vec<u16> =
                        b.as_raw().chunks(2).flat_map(|p| [p[0], p[0], p[0], p[1]]).collect();
                    enc.write_image::<ct::RGBA16>(w, h, &d)?
                }
                DynamicImage::ImageRgb16(b) => enc.write_image::<ct::RGB16>(w, h, b.as_raw())?,
                DynamicImage::ImageRgba16(b) => enc.write_image::<ct::RGBA16>(w, h, b.as_raw())?,
                DynamicImage::ImageRgb32F(b) if stack.gray_float => {
                    let d: Vec<f32> = b.as_raw().chunks(3).map(|p| p[0]).collect();
                    enc.write_image::<ct::Gray32Float>(w, h, &d)?
                }
                DynamicImage::ImageRgb32F(b) => {
                    enc.write_image::<ct::RGB32Float>(w, h, b.as_raw())?
                }
                DynamicImage::ImageRgba32F(b) => {
                    enc.write_image::<ct::RGBA32Float>(w, h, b.as_raw())?
                }
                _ => {
                    return Err(tiff::TiffError::UnsupportedError(
                        tiff::TiffUnsupportedError::UnknownInterpretation,
                    ))
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{Luma, Rgb};

    #[test]
    fn stacks_beyond_4_gib_are_written_as_bigtiff_and_read_back() {
        // Found by the adversarial pass: a 5 GiB stack failed at the end with "format size
        // limits exceeded" after the whole warp. The threshold is lowered to test it.
        let pages: Vec<DynamicImage> = (0..3)
            .map(|k| {
                DynamicImage::ImageLuma8(ImageBuffer::from_fn(9, 4, |x, y| {
                    Luma([(x + y * 9 + k) as u8])
                }))
            })
            .collect();
        let stack = Stack { pages, gray_float: false };
        let big = encode_tiff_above(&stack, 0).unwrap();
        assert!(big.starts_with(b"II+\0"), "BigTIFF header");
        assert!(encode_tiff(&stack).unwrap().starts_with(b"II*\0"), "classic below the limit");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.tif");
        std::fs::write(&p, &big).unwrap();
        let back = read_stack(&p).unwrap();
        assert_eq!(back.pages.len(), 3);
        for (a, b) in back.pages.iter().zip(&stack.pages) {
            assert_eq!(a.as_bytes(), b.as_bytes());
        }
    }

    #[test]
    fn tiff_stacks_round_trip_every_type() {
        let dir = tempfile::tempdir().unwrap();
        let g16: Vec<DynamicImage> = (0..3)
            .map(|k| {
                DynamicImage::ImageLuma16(ImageBuffer::from_fn(7, 5, |x, y| {
                    Luma([(x * 1000 + y * 7 + k * 30000) as u16])
                }))
            })
            .collect();
        let rgb8 = vec![DynamicImage::ImageRgb8(ImageBuffer::from_fn(4, 3, |x, y| {
            Rgb([x as u8, y as u8, 200])
        }))];
        let f32g: Vec<DynamicImage> = (0..2)
            .map(|k| {
                DynamicImage::ImageRgb32F(ImageBuffer::from_fn(3, 2, |x, _| {
                    let v = x as f32 * 0.25 - k as f32;
                    Rgb([v, v, v])
                }))
            })
            .collect();
        for (pages, gray_float) in [(g16, false), (rgb8, false), (f32g, true)] {
            let p = dir.path().join("s.tif");
            let st = Stack { pages: pages.clone(), gray_float };
            write_stack(&p, &st).unwrap();
            let back = read_stack(&p).unwrap();
            assert_eq!(back.gray_float, gray_float);
            assert_eq!(back.pages.len(), pages.len());
            for (a, b) in back.pages.iter().zip(&pages) {
                assert_eq!(a.color(), b.color());
                assert_eq!(a.as_bytes(), b.as_bytes());
            }
        }
    }

    #[test]
    fn decoding_from_memory_matches_reading_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let img = DynamicImage::ImageRgb16(ImageBuffer::from_fn(5, 3, |x, y| {
            Rgb([x as u16 * 1000, y as u16 * 77, 65535])
        }));
        for name in ["m.png", "m.tif", "m.pam"] {
            let p = dir.path().join(name);
            write_stack(&p, &Stack { pages: vec![img.clone()], gray_float: false }).unwrap();
            let bytes = std::fs::read(&p).unwrap();
            // The format comes from the content: the name only labels errors.
            let mem = decode_stack(&bytes, Path::new("memory")).unwrap();
            let file = read_stack(&p).unwrap();
            assert_eq!(mem.pages.len(), 1);
            assert_eq!(mem.pages[0].color(), file.pages[0].color(), "{name}");
            assert_eq!(mem.pages[0].as_bytes(), file.pages[0].as_bytes(), "{name}");
        }
        let e = decode_stack(b"P5\n3 2\n255\n\x01", Path::new("short.pgm")).unwrap_err();
        assert!(e.to_string().contains("short.pgm"), "{e}");
    }

    /// A classic little-endian TIFF of two 1 x 1 gray pages whose second page declares
    /// `strips` strip offsets (stored at byte 8, so the file is as short as one page).
    fn tiff_with_strip_count(strips: u32) -> Vec<u8> {
        let entry = |tag: u16, ty: u16, count: u32, value: u32| {
            [&tag.to_le_bytes()[..], &ty.to_le_bytes(), &count.to_le_bytes(), &value.to_le_bytes()]
                .concat()
        };
        let ifd_len = 2 + 9 * 12 + 4;
        let (ifd0, ifd1) = (8u32, 8 + ifd_len as u32);
        let data = ifd1 + ifd_len as u32;
        let ifd = |strip_count: u32, next: u32| {
            let mut v = 9u16.to_le_bytes().to_vec();
            for (tag, ty, count, value) in [
                (256, 3, 1, 1),
                (257, 3, 1, 1),
                (258, 3, 1, 8),
                (259, 3, 1, 1),
                (262, 3, 1, 1),
                (273, 4, strip_count, if strip_count == 1 { data } else { 8 }),
                (277, 3, 1, 1),
                (278, 3, 1, 1),
                (279, 4, 1, 1),
            ] {
                v.extend(entry(tag, ty, count, value));
            }
            v.extend(next.to_le_bytes());
            v
        };
        let mut t = b"II*\0".to_vec();
        t.extend(ifd0.to_le_bytes());
        t.extend(ifd(1, ifd1));
        t.extend(ifd(strips, 0));
        t.push(77);
        t
    }

    #[test]
    fn a_tiff_tag_declaring_more_values_than_the_file_holds_is_refused_before_allocation() {
        // Found by fuzzing (`image_decode_warp`): 2^28 strip offsets in a 623-byte file made
        // the tiff crate reserve 11 GiB for them (its limit was MAX_PIXELS * 16 bytes).
        let p = Path::new("strips.tif");
        let from = |b: &[u8], budget| {
            read_tiff(p, Cursor::new(b), b.len() as u64, budget, &ImageUse::DECODE)
        };
        let ok = from(&tiff_with_strip_count(1), 64 << 20).unwrap();
        assert_eq!(ok.pages.len(), 2);
        assert_eq!(ok.pages[1].as_bytes(), [77]);
        let bomb = tiff_with_strip_count(1 << 28);
        let e = from(&bomb, 64 << 20).unwrap_err().to_string();
        assert!(e.contains("strips.tif") && e.contains("limits"), "{e}");
        // Under any budget: the tag limit comes from the file's length.
        let e = from(&bomb, MAX_PIXELS * 16).unwrap_err().to_string();
        assert!(e.contains("limits"), "{e}");
        // Read from the file itself (read_stack's TIFF path): the same refusal and pages.
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("strips.tif");
        std::fs::write(&f, &bomb).unwrap();
        let e = read_stack(&f).unwrap_err().to_string();
        assert!(e.contains("strips.tif") && e.contains("limits"), "{e}");
        std::fs::write(&f, tiff_with_strip_count(1)).unwrap();
        assert_eq!(read_stack(&f).unwrap().pages[1].as_bytes(), [77]);
    }

    /// A TIFF streamed into its temporary file is, byte for byte, the TIFF encoded in
    /// memory (the path a FIFO or device gets), for one and for several pages.
    #[test]
    fn a_tiff_streamed_to_its_file_is_the_one_encoded_in_memory() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("s.tif");
        let g = DynamicImage::ImageLuma8(ImageBuffer::from_fn(300, 200, |x, y| {
            image::Luma([(x ^ y) as u8])
        }));
        let c = DynamicImage::ImageRgb8(ImageBuffer::from_fn(300, 200, |x, y| {
            image::Rgb([x as u8, y as u8, (x + y) as u8])
        }));
        for pages in [vec![g.clone()], vec![c.clone(), c]] {
            let stack = Stack { pages, gray_float: false };
            write_stack(&f, &stack).unwrap();
            assert_eq!(std::fs::read(&f).unwrap(), encode_tiff(&stack).unwrap());
        }
        let names: Vec<_> =
            std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["s.tif"], "no temporary file is left");
    }

    /// A TIFF read from its file (decoded from the file, not a copy in memory) gives what
    /// the same bytes decode to, page for page and sample for sample; a file cut short is
    /// refused in both.
    #[test]
    fn a_tiff_read_from_its_file_matches_its_bytes_decoded() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("two.tif");
        let a = DynamicImage::ImageLuma16(ImageBuffer::from_fn(37, 23, |x, y| {
            image::Luma([(x * 977 + y * 13) as u16])
        }));
        let b = DynamicImage::ImageLuma16(ImageBuffer::from_fn(37, 23, |x, y| {
            image::Luma([(x * 7 + y * 1313) as u16])
        }));
        write_stack(&f, &Stack { pages: vec![a, b], gray_float: false }).unwrap();
        let bytes = std::fs::read(&f).unwrap();
        let (from_file, from_bytes) = (read_stack(&f).unwrap(), decode_stack(&bytes, &f).unwrap());
        assert_eq!(from_file.pages.len(), 2);
        for (x, y) in from_file.pages.iter().zip(&from_bytes.pages) {
            assert_eq!(x.color(), y.color());
            assert_eq!(x.as_bytes(), y.as_bytes());
        }
        std::fs::write(&f, &bytes[..bytes.len() - 40]).unwrap();
        assert!(read_stack(&f).is_err());
        assert!(decode_stack(&bytes[..bytes.len() - 40], &f).is_err());
    }

    #[test]
    fn bad_files_are_named_errors() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.png");
        std::fs::write(&p, b"not an image").unwrap();
        let e = read_stack(&p).unwrap_err().to_string();
        assert!(e.contains("x.png"), "{e}");
        let t = dir.path().join("t.tif");
        std::fs::write(&t, b"II*\0\x08\0\0\0\xff\xff").unwrap();
        assert!(read_stack(&t).is_err());
        // Two pages cannot go to a PNG.
        let img = DynamicImage::ImageLuma8(ImageBuffer::from_pixel(2, 2, Luma([1u8])));
        let st = Stack { pages: vec![img.clone(), img], gray_float: false };
        let e = write_stack(&dir.path().join("o.png"), &st).unwrap_err().to_string();
        assert!(e.contains("only TIFF"), "{e}");
        assert!(!dir.path().join("o.png").exists());
    }
}
