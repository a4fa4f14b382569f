//! Text for pictures: anti-aliased glyphs of a bundled outline font, blended into a
//! [`tiny_skia::Pixmap`].
//!
//! The face is DejaVu Sans (subset to printable ASCII, Latin-1, Greek and a few symbols such
//! as `≤`, `≥`, `−`, `→`; `data/fonts/`, Bitstream Vera licence, see `data/SOURCES.md`),
//! built into the binary. Glyph outlines are scaled and rasterised by `ab_glyph` (exact
//! area coverage of each pixel by the quadratic outline), placed along the advance widths
//! with the font's pair kerning, and blended source-over into the pixmap with coverage times
//! the colour's alpha. Pixels outside the pixmap are clipped.
//!
//! Sizes keep the integer `scale` of the former bitmap font: one line at `scale` is
//! [`text_height`] = `LINE_PX * scale` pixels tall (ascender to descender), and `(x, y)` is
//! the top-left corner of the line box, so callers lay text out the same way. Only single
//! lines are drawn; characters the face lacks (control characters, most of Unicode beyond
//! Latin-1 and Greek) are drawn as `?`.

use ab_glyph::{point, Font, FontRef, GlyphId, PxScale, ScaleFont};
use std::sync::OnceLock;
use tiny_skia::{Color, Pixmap, PremultipliedColorU8};

/// Height in pixels of one line of text at scale 1 (the font's ascender to descender).
pub const LINE_PX: u32 = 12;

/// The bundled face (DejaVu Sans, subset; see the module docs).
const FONT_BYTES: &[u8] = include_bytes!("../../data/fonts/DejaVuSans-subset.ttf");

/// Longest line laid out, in pixels (longer text is cut there).
const MAX_LINE_PX: f32 = 1.0e5;

fn face() -> &'static FontRef<'static> {
    static FACE: OnceLock<FontRef<'static>> = OnceLock::new();
    FACE.get_or_init(|| FontRef::try_from_slice(FONT_BYTES).expect("the bundled font parses"))
}

/// The glyph drawn for `c`: its own, or `?` when the face has none.
fn glyph_id(c: char) -> GlyphId {
    let f = face();
    match f.glyph_id(c) {
        GlyphId(0) => f.glyph_id('?'),
        id => id,
    }
}

/// Whether the bundled face has a glyph of its own for `c` (others are drawn as `?`).
pub fn has_glyph(c: char) -> bool {
    face().glyph_id(c) != GlyphId(0)
}

fn px_scale(scale: u32) -> PxScale {
    PxScale::from((LINE_PX * scale) as f32)
}

/// Pen positions of the glyphs of `text` at `scale` (kerned advances from 0) and the end
/// position.
fn layout(text: &str, scale: u32) -> (Vec<(GlyphId, f32)>, f32) {
    let sf = face().as_scaled(px_scale(scale));
    let (mut caret, mut prev, mut out) = (0.0f32, None, Vec::new());
    for c in text.chars() {
        let id = glyph_id(c);
        if let Some(p) = prev {
            caret += sf.kern(p, id);
        }
        if caret > MAX_LINE_PX {
            break;
        }
        out.push((id, caret));
        caret += sf.h_advance(id);
        prev = Some(id);
    }
    (out, caret.min(MAX_LINE_PX))
}

/// Width in pixels of `text` drawn at `scale` (the sum of kerned advances, rounded up; 0 for
/// empty text or scale 0).
pub fn text_width(text: &str, scale: u32) -> u32 {
    if scale == 0 || text.is_empty() {
        return 0;
    }
    layout(text, scale).1.ceil() as u32
}

/// Height in pixels of one line of text at `scale` (`LINE_PX * scale`).
pub fn text_height(scale: u32) -> u32 {
    LINE_PX.saturating_mul(scale)
}

/// Calls `f(x, y, coverage)` for every pixel the glyphs of `text` cover, in line-box
/// coordinates (origin at the top-left of the line, y down; ink may reach slightly outside
/// `[0, text_width) x [0, text_height)`).
fn for_each_covered(text: &str, scale: u32, mut f: impl FnMut(i64, i64, f32)) {
    if scale == 0 {
        return;
    }
    let font = face();
    let s = px_scale(scale);
    let ascent = font.as_scaled(s).ascent();
    for (id, x) in layout(text, scale).0 {
        let g = id.with_scale_and_position(s, point(x, ascent));
        if let Some(o) = font.outline_glyph(g) {
            let b = o.px_bounds();
            let (bx, by) = (b.min.x as i64, b.min.y as i64);
            o.draw(|gx, gy, c| f(bx + i64::from(gx), by + i64::from(gy), c));
        }
    }
}

/// Draws `text` horizontally with the top-left corner of its line box at (`x`, `y`),
/// anti-aliased, blended source-over (a translucent colour is honoured); clipped to the
/// pixmap; a `scale` of 0 draws nothing.
pub fn draw_text(pixmap: &mut Pixmap, x: i32, y: i32, text: &str, scale: u32, color: Color) {
    let (w, h) = (i64::from(pixmap.width()), i64::from(pixmap.height()));
    let pixels = pixmap.pixels_mut();
    for_each_covered(text, scale, |tx, ty, c| {
        let (px, py) = (i64::from(x) + tx, i64::from(y) + ty);
        if (0..w).contains(&px) && (0..h).contains(&py) {
            let i = (py * w + px) as usize;
            pixels[i] = blend(color, c, pixels[i]);
        }
    });
}

/// Draws `text` rotated 90° counter-clockwise (reading bottom to top), as used for a y-axis
/// label.
///
/// (`x`, `y`) is the top-left corner of the rotated bounding box, which is [`text_height`]
/// pixels wide and [`text_width`] pixels tall; the first character sits at the bottom.
/// Clipping and blending are as in [`draw_text`].
pub fn draw_text_vertical(
    pixmap: &mut Pixmap,
    x: i32,
    y: i32,
    text: &str,
    scale: u32,
    color: Color,
) {
    let total = i64::from(text_width(text, scale));
    let (w, h) = (i64::from(pixmap.width()), i64::from(pixmap.height()));
    let pixels = pixmap.pixels_mut();
    for_each_covered(text, scale, |tx, ty, c| {
        // Line-box pixel (tx, ty) turns to (ty, total - 1 - tx).
        let (px, py) = (i64::from(x) + ty, i64::from(y) + total - 1 - tx);
        if (0..w).contains(&px) && (0..h).contains(&py) {
            let i = (py * w + px) as usize;
            pixels[i] = blend(color, c, pixels[i]);
        }
    });
}

/// Source-over of `color` with coverage `cov` (0..1) onto the premultiplied `dst`.
fn blend(color: Color, cov: f32, dst: PremultipliedColorU8) -> PremultipliedColorU8 {
    let a = (color.alpha() * cov.clamp(0.0, 1.0)).clamp(0.0, 1.0);
    let mix = |s: f32, d: u8| (s * a * 255.0 + f32::from(d) * (1.0 - a)).round().clamp(0.0, 255.0);
    let out_a = mix(1.0, dst.alpha());
    let ch = |s: f32, d: u8| mix(s, d).min(out_a) as u8;
    let (r, g, b) =
        (ch(color.red(), dst.red()), ch(color.green(), dst.green()), ch(color.blue(), dst.blue()));
    PremultipliedColorU8::from_rgba(r, g, b, out_a as u8).unwrap_or(dst)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn white(w: u32, h: u32) -> Pixmap {
        let mut p = Pixmap::new(w, h).unwrap();
        p.fill(Color::WHITE);
        p
    }

    /// Bounding box (x0, y0, x1, y1), inclusive, of all non-white pixels.
    fn ink_bbox(p: &Pixmap) -> Option<(u32, u32, u32, u32)> {
        let mut bb: Option<(u32, u32, u32, u32)> = None;
        for y in 0..p.height() {
            for x in 0..p.width() {
                let c = p.pixel(x, y).unwrap();
                if (c.red(), c.green(), c.blue()) != (255, 255, 255) {
                    bb = Some(match bb {
                        None => (x, y, x, y),
                        Some((a, b, c, d)) => (a.min(x), b.min(y), c.max(x), d.max(y)),
                    });
                }
            }
        }
        bb
    }

    /// The ink of `text` at `scale` as coverage rows (0 white .. 1 black).
    fn ink(text: &str, scale: u32) -> Vec<Vec<f32>> {
        let (w, h) = (text_width(text, scale) + 4, text_height(scale) + 4);
        let mut p = white(w, h);
        draw_text(&mut p, 2, 2, text, scale, Color::BLACK);
        (0..h)
            .map(|y| {
                (0..w).map(|x| 1.0 - f32::from(p.pixel(x, y).unwrap().red()) / 255.0).collect()
            })
            .collect()
    }

    #[test]
    fn widths_and_heights() {
        assert_eq!(text_width("", 3), 0);
        assert_eq!(text_width("x", 0), 0);
        assert_eq!(text_height(1), LINE_PX);
        assert_eq!(text_height(3), 3 * LINE_PX);
        let (i, m) = (text_width("i", 1), text_width("m", 1));
        assert!(i >= 2 && m > 2 * i, "proportional: i {i}, m {m}");
        // Twice the scale is twice the width, within the rounding of each.
        let (a, b) = (text_width("control points", 1), text_width("control points", 2));
        assert!(b.abs_diff(2 * a) <= 2, "{a} {b}");
        assert!(text_width("abc", 1) < text_width("abcd", 1));
    }

    #[test]
    fn the_face_covers_ascii_latin1_and_the_symbols_used() {
        for c in (32u8..=126).map(char::from).chain("äéßµ≤≥−→φσ×·".chars()) {
            assert!(has_glyph(c), "{c:?}");
        }
        assert!(!has_glyph('\n') && !has_glyph('\u{4e00}'));
        // Missing glyphs are drawn as '?'.
        assert_eq!(ink("\u{4e00}", 1), ink("?", 1));
    }

    #[test]
    fn letters_are_told_apart() {
        // The old bitmap's misprints: lower-case p and g drawn as capitals and digits.
        for (a, b) in [("p", "P"), ("g", "9"), ("l", "1"), ("o", "0"), ("s", "S")] {
            assert_ne!(ink(a, 1), ink(b, 1), "{a} vs {b}");
        }
        // Descenders reach below the baseline, capitals do not.
        let low = |t: &str| {
            let rows = ink(t, 2);
            rows.iter().rposition(|r| r.iter().any(|&c| c > 0.3)).unwrap()
        };
        assert!(low("p") > low("P") + 2, "p {} P {}", low("p"), low("P"));
    }

    #[test]
    fn draw_text_stays_in_its_box_and_is_anti_aliased() {
        let mut p = white(200, 60);
        draw_text(&mut p, 10, 5, "Hg", 2, Color::BLACK);
        let (x0, y0, x1, y1) = ink_bbox(&p).unwrap();
        assert!(x0 >= 10 && y0 >= 5, "{x0} {y0}");
        assert!(x1 <= 10 + text_width("Hg", 2) && y1 < 5 + text_height(2), "{x1} {y1}");
        let reds: Vec<u8> = (y0..=y1)
            .flat_map(|y| (x0..=x1).map(move |x| (x, y)))
            .map(|(x, y)| p.pixel(x, y).unwrap().red())
            .collect();
        assert!(reds.contains(&0), "solid stems");
        assert!(reds.iter().any(|&r| r > 40 && r < 215), "grey edge pixels");
    }

    #[test]
    fn draw_text_vertical_rotates() {
        let mut p = white(40, 120);
        let text = "Hi";
        draw_text_vertical(&mut p, 3, 7, text, 1, Color::BLACK);
        let (x0, y0, x1, y1) = ink_bbox(&p).unwrap();
        assert!(x0 >= 3 && x1 < 3 + text_height(1), "{x0} {x1}");
        assert!(y0 >= 7 && y1 < 7 + text_width(text, 1), "{y0} {y1}");
        // The horizontal ink, turned: the first letter at the bottom.
        let h = ink(text, 1);
        let mut q = white(40, 120);
        draw_text_vertical(&mut q, 3, 7, text, 1, Color::BLACK);
        let total = text_width(text, 1) as usize;
        for (ty, row) in h.iter().enumerate().skip(2).take(text_height(1) as usize) {
            for (tx, &c) in row.iter().enumerate().skip(2).take(total) {
                let got = q.pixel(3 + (ty - 2) as u32, 7 + (total - 1 - (tx - 2)) as u32);
                let got = 1.0 - f32::from(got.unwrap().red()) / 255.0;
                assert!((got - c).abs() < 0.01, "({tx}, {ty}): {got} vs {c}");
            }
        }
    }

    #[test]
    fn clipping_and_translucency() {
        let mut p = white(20, 20);
        draw_text(&mut p, -7, -3, "WW", 3, Color::BLACK);
        draw_text(&mut p, 1000, 1000, "x", 1, Color::BLACK);
        draw_text_vertical(&mut p, -50, -50, "long text", 4, Color::BLACK);
        let mut q = white(20, 20);
        // Large enough that the bar's middle is fully covered: there the result is the
        // colour's half alpha exactly (at scale 1 anti-aliasing never reaches full coverage).
        draw_text(&mut q, 0, 0, "|", 4, Color::from_rgba8(0, 0, 0, 128));
        let darkest =
            (0..20 * 20).map(|i| q.pixel(i % 20, i / 20).unwrap()).min_by_key(|c| c.red());
        let c = darkest.unwrap();
        assert_eq!(c.alpha(), 255);
        assert!(c.red() > 100 && c.red() < 150, "half blend, got {}", c.red());
    }
}
