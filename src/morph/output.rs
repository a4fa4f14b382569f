//! Encoding a morph's frames: PNG per frame, animated GIF and APNG, and a contact sheet.
//!
//! Two ways, with byte-identical results (`tests::streaming_matches_the_whole_vec_encoders`):
//!
//! * streaming, [`AnimationWriter`]: the frames are pushed one batch at a time, in order;
//!   each is encoded into the GIF and the APNG as it comes (written to any [`Write`], for
//!   `trimorph morph` an atomic file), and only a thumbnail is kept for the contact sheet.
//!   Memory is one batch of frames plus the encoders and the thumbnails
//!   ([`streaming_memory`]), whatever the number of frames;
//! * whole, [`gif_bytes`], [`apng_bytes`], [`contact_sheet`]: every frame at once, to memory
//!   (the reference, and what the benchmarks time).
//!
//! The animations are 8-bit RGBA (gray and 16-bit frames are converted); the GIF palette is
//! quantized per frame (NeuQuant, speed 10, as the `image` crate's GIF encoder does), and
//! the frames are quantized and LZW-compressed (`morph::lzw`) in parallel, then written
//! in order: the same frames as `image`'s sequential encoder, in smaller or equal LZW streams
//! (`tests::gif_decodes_to_the_image_crates_gif`). The APNG is told the frame
//! count before the first frame (its `acTL` chunk comes first), so a streaming writer is made
//! for a known number of frames.

use crate::render::font::draw_text;
use image::{DynamicImage, ImageFormat, RgbaImage};
use rayon::prelude::*;
use std::borrow::Cow;
use std::io::{Cursor, Write};
use tiny_skia::{Color, Pixmap};

/// Errors of encoding.
#[derive(Debug, thiserror::Error)]
pub enum EncodeError {
    /// The `image` crate failed (PNG, GIF).
    #[error("encoding: {0}")]
    Image(#[from] image::ImageError),
    /// The `png` crate failed (APNG).
    #[error("encoding APNG: {0}")]
    Png(#[from] png::EncodingError),
    /// The `gif` crate failed.
    #[error("encoding GIF: {0}")]
    Gif(#[from] gif::EncodingError),
    /// No frames, or a frame of another size.
    #[error("{0}")]
    Frames(String),
}

/// `frame_000.png`, `frame_001.png`, ... (at least 3 digits).
pub fn frame_name(k: usize, n: usize) -> String {
    let digits = n.saturating_sub(1).to_string().len().max(3);
    format!("frame_{k:0digits$}.png")
}

/// Whether `name` is a file `trimorph morph` writes into its output folder: a frame
/// (`frame_` digits `.png`), `phi_ab.json`, `phi_ba.json`, `morph.gif`, `morph.apng` or
/// `contact-sheet.png`. Only these are replaced or removed when a morph rewrites a folder
/// ([`crate::io::folder`]).
pub fn is_output_name(name: &str) -> bool {
    let frame = name
        .strip_prefix("frame_")
        .and_then(|r| r.strip_suffix(".png"))
        .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()));
    frame
        || matches!(
            name,
            "phi_ab.json" | "phi_ba.json" | "morph.gif" | "morph.apng" | "contact-sheet.png"
        )
}

/// A frame as PNG bytes (its own type and bit depth).
pub fn png_bytes(img: &DynamicImage) -> Result<Vec<u8>, EncodeError> {
    let mut buf = Cursor::new(Vec::new());
    // PNG has no float samples: float frames become 16-bit.
    let img = match img {
        DynamicImage::ImageRgb32F(_) => &DynamicImage::ImageRgb16(img.to_rgb16()),
        DynamicImage::ImageRgba32F(_) => &DynamicImage::ImageRgba16(img.to_rgba16()),
        _ => img,
    };
    img.write_to(&mut buf, ImageFormat::Png)?;
    Ok(buf.into_inner())
}

fn rgba_frames(frames: &[DynamicImage]) -> Result<Vec<RgbaImage>, EncodeError> {
    let first = frames.first().ok_or_else(|| EncodeError::Frames("no frames".into()))?;
    let size = (first.width(), first.height());
    frames
        .iter()
        .map(|f| {
            if (f.width(), f.height()) != size {
                return Err(EncodeError::Frames(format!(
                    "frames differ in size: {:?} and {:?}",
                    size,
                    (f.width(), f.height())
                )));
            }
            Ok(f.to_rgba8())
        })
        .collect()
}

/// An endlessly looping animated GIF, `delay_ms` per frame.
pub fn gif_bytes(frames: &[DynamicImage], delay_ms: u32) -> Result<Vec<u8>, EncodeError> {
    let rgba = rgba_frames(frames)?;
    let (w, h) = gif_size(rgba[0].dimensions())?;
    let encoded: Vec<gif::Frame<'static>> =
        rgba.par_iter().map(|f| gif_frame(f, gif_delay(delay_ms))).collect();
    let mut enc = gif_encoder(Vec::new(), w, h)?;
    for f in &encoded {
        enc.write_lzw_pre_encoded_frame(f)?;
    }
    Ok(enc.into_inner()?)
}

/// A GIF encoder for `w x h` frames, looping forever.
fn gif_encoder<W: Write>(out: W, w: u16, h: u16) -> Result<gif::Encoder<W>, EncodeError> {
    let mut enc = gif::Encoder::new(out, w, h, &[])?;
    enc.set_repeat(gif::Repeat::Infinite)?;
    Ok(enc)
}

/// The frame size as a GIF's, which is at most `65535 x 65535`.
fn gif_size((w, h): (u32, u32)) -> Result<(u16, u16), EncodeError> {
    match (u16::try_from(w), u16::try_from(h)) {
        (Ok(w), Ok(h)) => Ok((w, h)),
        _ => Err(EncodeError::Frames(format!(
            "a GIF is at most {} x {} pixels, the frames are {w} x {h}",
            u16::MAX,
            u16::MAX
        ))),
    }
}

/// A GIF frame delay: hundredths of a second, at most `u16::MAX` (as `image` saturates it).
fn gif_delay(delay_ms: u32) -> u16 {
    (delay_ms / 10).try_into().unwrap_or(u16::MAX)
}

/// One GIF frame: palette by NeuQuant at speed 10 (exact for at most 256 colours), restored
/// to background after display, LZW-compressed ([`super::lzw`], for
/// [`gif::Encoder::write_lzw_pre_encoded_frame`]); independent of the other frames, so
/// frames are made in parallel.
fn gif_frame(f: &RgbaImage, delay: u16) -> gif::Frame<'static> {
    let (w, h) = (f.width() as u16, f.height() as u16);
    let mut px = f.as_raw().clone();
    let mut frame = exact_palette_frame(w, h, &mut px)
        .unwrap_or_else(|| gif::Frame::from_rgba_speed(w, h, &mut px, 10));
    frame.delay = delay;
    frame.dispose = gif::DisposalMethod::Background;
    frame.buffer = Cow::Owned(super::lzw::gif_lzw(&frame.buffer));
    frame
}

/// [`gif::Frame::from_rgba_speed`] for a frame of at most 256 colours (a grey image, say),
/// the same frame from hash tables instead of its ordered maps (`None` for more colours:
/// NeuQuant then). As there: every alpha but 0 becomes 255, every transparent pixel takes
/// the first transparent pixel's value, and the palette is the colours in `(r, g, b, a)`
/// order (here `u32` keys `r << 24 | g << 16 | b << 8 | a`, which sort the same way).
fn exact_palette_frame(w: u16, h: u16, px: &mut [u8]) -> Option<gif::Frame<'static>> {
    let mut transparent: Option<[u8; 4]> = None;
    for p in px.chunks_exact_mut(4) {
        if p[3] != 0 {
            p[3] = 0xFF;
        } else if let Some(t) = transparent {
            p.copy_from_slice(&t);
        } else {
            transparent = Some([p[0], p[1], p[2], p[3]]);
        }
    }
    let key = |p: &[u8]| u32::from_be_bytes([p[0], p[1], p[2], p[3]]);
    let mut table = ColorTable::new();
    for p in px.chunks_exact(4) {
        if !table.insert(key(p)) {
            return None;
        }
    }
    let mut colors = table.keys();
    colors.sort_unstable();
    for (i, &c) in colors.iter().enumerate() {
        table.set_index(c, i as u8);
    }
    let palette = colors.iter().flat_map(|c| [(c >> 24) as u8, (c >> 16) as u8, (c >> 8) as u8]);
    let index = |p: &[u8]| table.index(key(p));
    Some(gif::Frame {
        width: w,
        height: h,
        buffer: Cow::Owned(px.chunks_exact(4).map(index).collect()),
        palette: Some(palette.collect()),
        transparent: transparent.map(|t| index(&t)),
        ..gif::Frame::default()
    })
}

/// An open-addressing set of at most 256 colours, with a palette index per colour.
struct ColorTable {
    /// `(colour + 1, index)`; 0 marks an empty slot (a colour may be 0).
    slots: Box<[(u64, u8); ColorTable::SIZE]>,
    len: usize,
}

impl ColorTable {
    const SIZE: usize = 1024;

    fn new() -> ColorTable {
        ColorTable { slots: Box::new([(0, 0); ColorTable::SIZE]), len: 0 }
    }

    /// The slot of `c`: where it is, or the empty slot where it would go.
    #[inline]
    fn slot(&self, c: u32) -> usize {
        let mut i = (c.wrapping_mul(0x9E37_79B9) >> 22) as usize;
        let k = u64::from(c) + 1;
        while self.slots[i].0 != 0 && self.slots[i].0 != k {
            i = (i + 1) % ColorTable::SIZE;
        }
        i
    }

    /// Adds `c`; false if that would make more than 256 colours.
    #[inline]
    fn insert(&mut self, c: u32) -> bool {
        let i = self.slot(c);
        if self.slots[i].0 == 0 {
            if self.len == 256 {
                return false;
            }
            self.slots[i].0 = u64::from(c) + 1;
            self.len += 1;
        }
        true
    }

    fn keys(&self) -> Vec<u32> {
        self.slots.iter().filter(|s| s.0 != 0).map(|s| (s.0 - 1) as u32).collect()
    }

    fn set_index(&mut self, c: u32, index: u8) {
        let i = self.slot(c);
        self.slots[i].1 = index;
    }

    /// The index of a colour in the table (0 for one not in it, as `gif` does).
    #[inline]
    fn index(&self, c: u32) -> u8 {
        let i = self.slot(c);
        if self.slots[i].0 == 0 {
            0
        } else {
            self.slots[i].1
        }
    }
}

/// An endlessly looping animated PNG (8-bit RGBA), `delay_ms` per frame, fast compression.
pub fn apng_bytes(frames: &[DynamicImage], delay_ms: u32) -> Result<Vec<u8>, EncodeError> {
    let rgba = rgba_frames(frames)?;
    let (w, h) = rgba[0].dimensions();
    let mut buf = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut buf, w, h);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        // fdeflate's fast mode: the animation is a preview of the frames (written losslessly
        // beside it); about 4x faster to encode than the balanced default, somewhat larger.
        enc.set_compression(png::Compression::Fast);
        enc.set_animated(rgba.len() as u32, 0)?;
        enc.set_frame_delay(delay_ms.min(u16::MAX as u32) as u16, 1000)?;
        let mut writer = enc.write_header()?;
        for f in &rgba {
            writer.write_image_data(f.as_raw())?;
        }
        writer.finish()?;
    }
    Ok(buf)
}

/// A contact sheet: the frames as thumbnails (at most `thumb` px wide), `cols` per row,
/// each labelled with its `t`, on white.
pub fn contact_sheet(
    frames: &[DynamicImage],
    times: &[f64],
    cols: usize,
    thumb: u32,
) -> Result<Pixmap, EncodeError> {
    let rgba = rgba_frames(frames)?;
    let (w, h) = rgba[0].dimensions();
    let (tw, th) = thumb_size(w, h, thumb);
    let thumbs: Vec<RgbaImage> = rgba.iter().map(|f| thumbnail(f, tw, th)).collect();
    sheet_of(&thumbs, times, cols, tw, th)
}

/// The size of a thumbnail of a `w x h` frame, at most `thumb` px wide.
fn thumb_size(w: u32, h: u32, thumb: u32) -> (u32, u32) {
    let tw = thumb.clamp(1, w.max(1));
    let th = ((u64::from(h) * u64::from(tw)) / u64::from(w.max(1))).max(1) as u32;
    (tw, th)
}

fn thumbnail(f: &RgbaImage, tw: u32, th: u32) -> RgbaImage {
    image::imageops::resize(f, tw, th, image::imageops::FilterType::Triangle)
}

/// The layout of the contact sheet of `n` thumbnails of `tw x th`: columns, rows, size.
fn sheet_layout(n: usize, cols: usize, tw: u32, th: u32) -> (usize, u32, u32) {
    let cols = cols.clamp(1, n.max(1));
    let rows = n.div_ceil(cols);
    let sw = cols as u32 * (tw + SHEET_PAD) + SHEET_PAD;
    let sh = rows as u32 * (th + SHEET_PAD + SHEET_LABEL) + SHEET_PAD;
    (cols, sw, sh)
}

const SHEET_PAD: u32 = 6;
const SHEET_LABEL: u32 = 14;

/// The contact sheet of the thumbnails `thumbs` (each `tw x th`), labelled with `times`.
fn sheet_of(
    thumbs: &[RgbaImage],
    times: &[f64],
    cols: usize,
    tw: u32,
    th: u32,
) -> Result<Pixmap, EncodeError> {
    let (pad, label) = (SHEET_PAD, SHEET_LABEL);
    let (cols, sw, sh) = sheet_layout(thumbs.len(), cols, tw, th);
    let mut sheet = RgbaImage::from_pixel(sw, sh, image::Rgba([255, 255, 255, 255]));
    for (k, small) in thumbs.iter().enumerate() {
        let (c, r) = ((k % cols) as u32, (k / cols) as u32);
        let (x, y) = (pad + c * (tw + pad), pad + r * (th + pad + label) + label);
        image::imageops::overlay(&mut sheet, small, i64::from(x), i64::from(y));
    }
    // Opaque pixels are the same premultiplied.
    let mut pm = Pixmap::from_vec(
        sheet.into_raw(),
        tiny_skia::IntSize::from_wh(sw, sh).ok_or_else(|| EncodeError::Frames("size".into()))?,
    )
    .ok_or_else(|| EncodeError::Frames("contact sheet too large".into()))?;
    for (k, t) in times.iter().enumerate().take(thumbs.len()) {
        let (c, r) = ((k % cols) as u32, (k / cols) as u32);
        let (x, y) = (pad + c * (tw + pad), pad + r * (th + pad + label) + 2);
        draw_text(&mut pm, x as i32, y as i32, &format!("t={t:.2}"), 1, Color::BLACK);
    }
    Ok(pm)
}

/// Bytes an [`AnimationWriter`] holds at most besides the frames given to it, for `frames` frames of
/// `width x height` pushed `batch` at a time, a sheet of `cols` columns: per frame of a
/// batch, its 8-bit RGBA copy and its GIF frame (quantized in parallel: a working copy,
/// palette indices, compressed data; 10 bytes a pixel with the copy), the APNG encoder's
/// buffers (filter rows and compressed data: counted as 14 bytes a pixel), every thumbnail,
/// and at the end the sheet (drawn, then copied once more to be encoded). Frames that are
/// 8-bit RGBA already are not copied (counted anyway).
pub fn streaming_memory(
    (width, height): (u32, u32),
    frames: usize,
    batch: usize,
    thumb: u32,
    cols: usize,
) -> u64 {
    let px = u64::from(width) * u64::from(height);
    let (tw, th) = thumb_size(width, height, thumb);
    let thumbs = (frames as u64).saturating_mul(u64::from(tw) * u64::from(th) * 4);
    let (_, sw, sh) = sheet_layout(frames, cols, tw, th);
    let sheet = u64::from(sw) * u64::from(sh) * 4;
    let streaming = (batch as u64).saturating_mul(px * 10).saturating_add(px * 14);
    streaming.max(sheet.saturating_mul(2)).saturating_add(thumbs)
}

/// A morph's animations written as its frames come (see the module documentation): an
/// endlessly looping GIF and APNG, `delay_ms` per frame, exactly as [`gif_bytes`] and
/// [`apng_bytes`] encode them, and the thumbnails of the [`contact_sheet`].
///
/// Frames are pushed in order with [`push`](Self::push) or [`push_batch`](Self::push_batch);
/// after the announced number of frames, [`finish`](Self::finish) ends both animations and
/// returns the contact sheet (after writing the GIF's trailer, reporting its write errors).
pub struct AnimationWriter<G: Write, A: Write> {
    gif: gif::Encoder<G>,
    apng: png::Writer<A>,
    /// GIF frame delay, hundredths of a second.
    delay: u16,
    size: (u32, u32),
    frames: usize,
    thumb: (u32, u32),
    thumbs: Vec<RgbaImage>,
}

impl<G: Write + Send, A: Write + Send> AnimationWriter<G, A> {
    /// A writer for `frames` frames of `width x height`, GIF into `gif`, APNG into `apng`,
    /// thumbnails at most `thumb` px wide. Writes the APNG's header at once (the GIF's comes
    /// with the first frame).
    pub fn new(
        gif: G,
        apng: A,
        (width, height): (u32, u32),
        frames: usize,
        delay_ms: u32,
        thumb: u32,
    ) -> Result<Self, EncodeError> {
        if frames == 0 || width == 0 || height == 0 {
            return Err(EncodeError::Frames("no frames".into()));
        }
        let (gw, gh) = gif_size((width, height))?;
        let count = u32::try_from(frames)
            .map_err(|_| EncodeError::Frames(format!("{frames} frames: too many for an APNG")))?;
        let g = gif_encoder(gif, gw, gh)?;
        let mut enc = png::Encoder::new(apng, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        // As apng_bytes: fdeflate's fast mode.
        enc.set_compression(png::Compression::Fast);
        enc.set_animated(count, 0)?;
        enc.set_frame_delay(delay_ms.min(u16::MAX as u32) as u16, 1000)?;
        let apng = enc.write_header()?;
        Ok(AnimationWriter {
            gif: g,
            apng,
            delay: gif_delay(delay_ms),
            size: (width, height),
            frames,
            thumb: thumb_size(width, height, thumb),
            thumbs: Vec::with_capacity(frames),
        })
    }

    /// Encodes one frame (see [`push_batch`](Self::push_batch)).
    pub fn push(&mut self, frame: &DynamicImage) -> Result<(), EncodeError> {
        self.push_batch(std::slice::from_ref(frame))
    }

    /// Encodes the next frames, in order: their RGBA conversions, GIF frames and thumbnails
    /// in parallel, the APNG frames beside them.
    pub fn push_batch(&mut self, frames: &[DynamicImage]) -> Result<(), EncodeError> {
        if self.thumbs.len() + frames.len() > self.frames {
            return Err(EncodeError::Frames(format!(
                "more than the {} frames announced",
                self.frames
            )));
        }
        if let Some(f) = frames.iter().find(|f| (f.width(), f.height()) != self.size) {
            return Err(EncodeError::Frames(format!(
                "frames differ in size: {:?} and {:?}",
                self.size,
                (f.width(), f.height())
            )));
        }
        let rgba: Vec<Cow<'_, RgbaImage>> = frames
            .par_iter()
            .map(|f| match f {
                DynamicImage::ImageRgba8(x) => Cow::Borrowed(x),
                _ => Cow::Owned(f.to_rgba8()),
            })
            .collect();
        let (tw, th) = self.thumb;
        let delay = self.delay;
        let (gif, apng) = (&mut self.gif, &mut self.apng);
        let (g, (a, thumbs)) = rayon::join(
            || -> Result<(), EncodeError> {
                let encoded: Vec<gif::Frame<'static>> =
                    rgba.par_iter().map(|f| gif_frame(f, delay)).collect();
                for f in &encoded {
                    gif.write_lzw_pre_encoded_frame(f)?;
                }
                Ok(())
            },
            || {
                rayon::join(
                    || -> Result<(), EncodeError> {
                        for f in &rgba {
                            apng.write_image_data(f.as_raw())?;
                        }
                        Ok(())
                    },
                    || rgba.par_iter().map(|f| thumbnail(f, tw, th)).collect::<Vec<_>>(),
                )
            },
        );
        g?;
        a?;
        self.thumbs.extend(thumbs);
        Ok(())
    }

    /// Ends both animations (the GIF's trailer, the APNG's last chunk) and returns the
    /// contact sheet of the frames, `cols` per row, labelled with `times`. Fails when fewer
    /// frames than announced were pushed.
    pub fn finish(self, times: &[f64], cols: usize) -> Result<Pixmap, EncodeError> {
        if self.thumbs.len() != self.frames {
            return Err(EncodeError::Frames(format!(
                "{} of the {} frames announced were given",
                self.thumbs.len(),
                self.frames
            )));
        }
        let AnimationWriter { gif, apng, thumb: (tw, th), thumbs, .. } = self;
        gif.into_inner()?;
        apng.finish()?;
        sheet_of(&thumbs, times, cols, tw, th)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(n: usize, w: u32, h: u32) -> Vec<DynamicImage> {
        (0..n)
            .map(|k| {
                let img = image::ImageBuffer::from_fn(w, h, |x, y| {
                    let v = (x * 7 + y * 3 + k as u32 * 40) % 256;
                    image::Rgb([v as u16 * 200, (x * 900) as u16, (y * 1100 + k as u32) as u16])
                });
                DynamicImage::ImageRgb16(img)
            })
            .collect()
    }

    /// The streaming writer, fed in batches of 1, 2 and 3, writes the very bytes of the
    /// whole-Vec encoders: GIF, APNG and the contact sheet (16-bit RGB frames, converted).
    #[test]
    fn streaming_matches_the_whole_vec_encoders() {
        let fr = frames(5, 37, 23);
        let times: Vec<f64> = (0..5).map(|k| k as f64 / 4.0).collect();
        let (gif, apng) = (gif_bytes(&fr, 70).unwrap(), apng_bytes(&fr, 70).unwrap());
        let sheet = contact_sheet(&fr, &times, 3, 20).unwrap();
        for batch in [1, 2, 3] {
            let (mut g, mut a) = (Vec::new(), Vec::new());
            let mut w = AnimationWriter::new(&mut g, &mut a, (37, 23), 5, 70, 20).unwrap();
            for b in fr.chunks(batch) {
                w.push_batch(b).unwrap();
            }
            let s = w.finish(&times, 3).unwrap();
            assert!(g == gif, "GIF differs, batches of {batch}");
            assert!(a == apng, "APNG differs, batches of {batch}");
            assert!(s.data() == sheet.data(), "contact sheet differs, batches of {batch}");
            assert_eq!((s.width(), s.height()), (sheet.width(), sheet.height()));
        }
        // 8-bit RGBA frames are encoded without a copy: the same bytes.
        let rgba: Vec<DynamicImage> =
            fr.iter().map(|f| DynamicImage::ImageRgba8(f.to_rgba8())).collect();
        let (mut g, mut a) = (Vec::new(), Vec::new());
        let mut w = AnimationWriter::new(&mut g, &mut a, (37, 23), 5, 70, 20).unwrap();
        for f in &rgba {
            w.push(f).unwrap();
        }
        w.finish(&times, 3).unwrap();
        assert!(g == gif_bytes(&rgba, 70).unwrap() && a == apng_bytes(&rgba, 70).unwrap());
    }

    /// Every frame of a GIF as the decoder gives it: size, palette, indices, transparent
    /// index, delay, disposal; and the loop count.
    fn gif_contents(bytes: &[u8]) -> (Vec<String>, gif::Repeat) {
        let mut o = gif::DecodeOptions::new();
        o.set_color_output(gif::ColorOutput::Indexed);
        let mut d = o.read_info(bytes).unwrap();
        let mut out = Vec::new();
        while let Some(f) = d.read_next_frame().unwrap() {
            out.push(format!(
                "{}x{} {:?} {:?} {:?} {} {:?}",
                f.width, f.height, f.palette, f.buffer, f.transparent, f.delay, f.dispose
            ));
        }
        (out, d.repeat())
    }

    /// The parallel GIF frames decode to exactly what the `image` crate's sequential
    /// encoder's do (palettes, indices, timing, looping): only the LZW streams differ
    /// ([`super::super::lzw`]).
    #[test]
    fn gif_decodes_to_the_image_crates_gif() {
        use image::codecs::gif::{GifEncoder, Repeat};
        // Grey frames (at most 256 colours: the exact palette) and RGBA frames with
        // transparent pixels, besides the colourful ones (NeuQuant).
        let grey: Vec<DynamicImage> = frames(4, 40, 30).iter().map(|f| f.grayscale()).collect();
        let holes: Vec<DynamicImage> = frames(3, 33, 17)
            .iter()
            .map(|f| {
                let mut x = f.to_rgba8();
                for (k, p) in x.pixels_mut().enumerate() {
                    p.0[3] = [0, 255, 3, 0][k % 4];
                }
                DynamicImage::ImageRgba8(x)
            })
            .collect();
        let few: Vec<DynamicImage> = holes
            .iter()
            .map(|f| {
                let mut x = f.to_rgba8();
                for p in x.pixels_mut() {
                    p.0 = [p.0[0] & 0xC0, p.0[1] & 0x80, 0, p.0[3]];
                }
                DynamicImage::ImageRgba8(x)
            })
            .collect();
        let cases = [
            (frames(5, 37, 23), 70),
            (frames(3, 64, 9), 1_000_000),
            (frames(1, 1, 1), 5),
            (grey, 40),
            (holes, 40),
            (few, 40),
        ];
        let exact = |f: &DynamicImage| {
            let (w, h) = (f.width() as u16, f.height() as u16);
            exact_palette_frame(w, h, &mut f.to_rgba8().into_raw()).is_some()
        };
        assert!(exact(&cases[3].0[0]) && exact(&cases[5].0[0]));
        assert!(!exact(&cases[0].0[0]) && !exact(&cases[4].0[0]));
        for (fr, delay) in cases {
            let (n, w, h) = (fr.len(), fr[0].width(), fr[0].height());
            let mut want = Vec::new();
            {
                let mut enc = GifEncoder::new_with_speed(&mut want, 10);
                enc.set_repeat(Repeat::Infinite).unwrap();
                let d = image::Delay::from_numer_denom_ms(delay, 1);
                enc.encode_frames(
                    fr.iter().map(|f| image::Frame::from_parts(f.to_rgba8(), 0, 0, d)),
                )
                .unwrap();
            }
            let got = gif_contents(&gif_bytes(&fr, delay).unwrap());
            assert!(got == gif_contents(&want), "{n} frames of {w} x {h}");
            assert_eq!(got.0.len(), n);
        }
    }

    #[test]
    fn the_announced_frame_count_and_size_are_enforced() {
        let fr = frames(3, 10, 8);
        let (mut g, mut a) = (Vec::new(), Vec::new());
        let mut w = AnimationWriter::new(&mut g, &mut a, (10, 8), 2, 100, 20).unwrap();
        let e = w.push_batch(&fr).unwrap_err().to_string();
        assert!(e.contains("more than the 2 frames"), "{e}");
        let e = w.push(&frames(1, 11, 8)[0]).unwrap_err().to_string();
        assert!(e.contains("differ in size"), "{e}");
        w.push(&fr[0]).unwrap();
        let e = w.finish(&[0.0, 1.0], 2).err().unwrap().to_string();
        assert!(e.contains("1 of the 2 frames"), "{e}");
        let (mut g, mut a) = (Vec::new(), Vec::new());
        let e = AnimationWriter::new(&mut g, &mut a, (70_000, 8), 2, 100, 20).err().unwrap();
        assert!(e.to_string().contains("GIF is at most 65535"), "{e}");
    }

    #[test]
    fn memory_counts_a_batch_not_every_frame() {
        // Large frames, few of them: the streaming phase is the larger one.
        let one = streaming_memory((1000, 1000), 10, 1, 160, 8);
        let four = streaming_memory((1000, 1000), 10, 4, 160, 8);
        assert_eq!(four - one, 3 * 10_000_000, "each frame of a batch: RGBA copy, GIF frame");
        let more = streaming_memory((1000, 1000), 20, 1, 160, 8);
        assert_eq!(more - one, 10 * 160 * 160 * 4, "each further frame: a thumbnail");
        // Many small frames: the contact sheet at the end is the larger phase.
        let (_, sw, sh) = sheet_layout(1000, 8, 100, 100);
        let sheet = u64::from(sw) * u64::from(sh) * 4;
        let thumbs = 1000 * 100 * 100 * 4;
        assert_eq!(streaming_memory((100, 100), 1000, 2, 160, 8), 2 * sheet + thumbs);
    }
}
