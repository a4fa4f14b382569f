//! Encoding a morph's frames: PNG per frame, animated GIF and APNG, and a contact sheet.
//!
//! Everything is encoded to memory; the caller writes it atomically
//! ([`crate::io::write_atomic`]). The animations are 8-bit RGBA (gray and 16-bit frames are
//! converted); the GIF palette is quantized per frame by the `image` crate.

use crate::render::font::draw_text;
use image::codecs::gif::{GifEncoder, Repeat};
use image::{DynamicImage, Frame, ImageFormat, RgbaImage};
use std::io::Cursor;
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
    let mut buf = Vec::new();
    {
        let mut enc = GifEncoder::new_with_speed(&mut buf, 10);
        enc.set_repeat(Repeat::Infinite)?;
        let delay = image::Delay::from_numer_denom_ms(delay_ms, 1);
        enc.encode_frames(rgba.into_iter().map(|f| Frame::from_parts(f, 0, 0, delay)))?;
    }
    Ok(buf)
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
    let tw = thumb.clamp(1, w.max(1));
    let th = ((u64::from(h) * u64::from(tw)) / u64::from(w)).max(1) as u32;
    let cols = cols.clamp(1, rgba.len());
    let rows = rgba.len().div_ceil(cols);
    let (pad, label) = (6u32, 14u32);
    let sw = cols as u32 * (tw + pad) + pad;
    let sh = rows as u32 * (th + pad + label) + pad;
    let mut sheet = RgbaImage::from_pixel(sw, sh, image::Rgba([255, 255, 255, 255]));
    for (k, f) in rgba.iter().enumerate() {
        let small = image::imageops::resize(f, tw, th, image::imageops::FilterType::Triangle);
        let (c, r) = ((k % cols) as u32, (k / cols) as u32);
        let (x, y) = (pad + c * (tw + pad), pad + r * (th + pad + label) + label);
        image::imageops::overlay(&mut sheet, &small, i64::from(x), i64::from(y));
    }
    // Opaque pixels are the same premultiplied.
    let mut pm = Pixmap::from_vec(
        sheet.into_raw(),
        tiny_skia::IntSize::from_wh(sw, sh).ok_or_else(|| EncodeError::Frames("size".into()))?,
    )
    .ok_or_else(|| EncodeError::Frames("contact sheet too large".into()))?;
    for (k, t) in times.iter().enumerate().take(rgba.len()) {
        let (c, r) = ((k % cols) as u32, (k / cols) as u32);
        let (x, y) = (pad + c * (tw + pad), pad + r * (th + pad + label) + 2);
        draw_text(&mut pm, x as i32, y as i32, &format!("t={t:.2}"), 1, Color::BLACK);
    }
    Ok(pm)
}
