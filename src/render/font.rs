//! A tiny built-in bitmap font for labelling plots.
//!
//! The font is a hand-drawn 5x7 pixel face covering the printable ASCII range
//! `32..=126` (space, digits, upper- and lower-case letters and punctuation).
//! Glyphs are stored as seven rows of five bits each; bit 4 is the leftmost
//! column. Every glyph occupies a cell of [`GLYPH_WIDTH`] x [`GLYPH_HEIGHT`]
//! pixels and the pen advances by [`ADVANCE`] pixels (one column of spacing),
//! all multiplied by an integer `scale` factor when drawn.
//!
//! Text is drawn straight into a [`tiny_skia::Pixmap`] without anti-aliasing
//! (the pixels are either on or off), blended source-over with the given
//! colour, and clipped to the pixmap bounds. Only single-line text is
//! supported; characters outside the table (including control characters and
//! non-ASCII) are drawn as `?`.
//!
//! This keeps the plot renderer free of any font or text-shaping dependency.

use tiny_skia::{Color, Pixmap, PremultipliedColorU8};

/// Width of one glyph in font pixels (before scaling).
pub const GLYPH_WIDTH: u32 = 5;
/// Height of one glyph in font pixels (before scaling).
pub const GLYPH_HEIGHT: u32 = 7;
/// Horizontal pen advance per character in font pixels (glyph + 1 column gap).
pub const ADVANCE: u32 = GLYPH_WIDTH + 1;

/// First character code covered by [`GLYPHS`].
const FIRST: u32 = 32;
/// Last character code covered by [`GLYPHS`].
const LAST: u32 = 126;

/// Glyph bitmaps for ASCII 32..=126, seven rows each, bit 4 = leftmost column.
#[rustfmt::skip]
const GLYPHS: [[u8; 7]; 95] = [
    [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00], // ' '
    [0x04, 0x04, 0x04, 0x04, 0x04, 0x00, 0x04], // '!'
    [0x0A, 0x0A, 0x00, 0x00, 0x00, 0x00, 0x00], // '"'
    [0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A], // '#'
    [0x04, 0x0F, 0x14, 0x0E, 0x05, 0x1E, 0x04], // '$'
    [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03], // '%'
    [0x0C, 0x12, 0x14, 0x08, 0x15, 0x12, 0x0D], // '&'
    [0x04, 0x04, 0x08, 0x00, 0x00, 0x00, 0x00], // '\''
    [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02], // '('
    [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08], // ')'
    [0x00, 0x04, 0x15, 0x0E, 0x15, 0x04, 0x00], // '*'
    [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00], // '+'
    [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08], // ','
    [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00], // '-'
    [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C], // '.'
    [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00], // '/'
    [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E], // '0'
    [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E], // '1'
    [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F], // '2'
    [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E], // '3'
    [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02], // '4'
    [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E], // '5'
    [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E], // '6'
    [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08], // '7'
    [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E], // '8'
    [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C], // '9'
    [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00], // ':'
    [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x04, 0x08], // ';'
    [0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02], // '<'
    [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00], // '='
    [0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08], // '>'
    [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04], // '?'
    [0x0E, 0x11, 0x01, 0x0D, 0x15, 0x15, 0x0E], // '@'
    [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11], // 'A'
    [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E], // 'B'
    [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E], // 'C'
    [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C], // 'D'
    [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F], // 'E'
    [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10], // 'F'
    [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F], // 'G'
    [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11], // 'H'
    [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E], // 'I'
    [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C], // 'J'
    [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11], // 'K'
    [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F], // 'L'
    [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11], // 'M'
    [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11], // 'N'
    [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E], // 'O'
    [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10], // 'P'
    [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D], // 'Q'
    [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11], // 'R'
    [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E], // 'S'
    [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04], // 'T'
    [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E], // 'U'
    [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04], // 'V'
    [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A], // 'W'
    [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11], // 'X'
    [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04], // 'Y'
    [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F], // 'Z'
    [0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E], // '['
    [0x00, 0x10, 0x08, 0x04, 0x02, 0x01, 0x00], // '\\'
    [0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E], // ']'
    [0x04, 0x0A, 0x11, 0x00, 0x00, 0x00, 0x00], // '^'
    [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F], // '_'
    [0x08, 0x04, 0x02, 0x00, 0x00, 0x00, 0x00], // '`'
    [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F], // 'a'
    [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E], // 'b'
    [0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E], // 'c'
    [0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F], // 'd'
    [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E], // 'e'
    [0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08], // 'f'
    [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E], // 'g'
    [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11], // 'h'
    [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E], // 'i'
    [0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0C], // 'j'
    [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12], // 'k'
    [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E], // 'l'
    [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11], // 'm'
    [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11], // 'n'
    [0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E], // 'o'
    [0x00, 0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10], // 'p'
    [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x01], // 'q'
    [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10], // 'r'
    [0x00, 0x00, 0x0F, 0x10, 0x0E, 0x01, 0x1E], // 's'
    [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06], // 't'
    [0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D], // 'u'
    [0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04], // 'v'
    [0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A], // 'w'
    [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11], // 'x'
    [0x00, 0x11, 0x11, 0x11, 0x0F, 0x01, 0x0E], // 'y'
    [0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F], // 'z'
    [0x02, 0x04, 0x04, 0x08, 0x04, 0x04, 0x02], // '{'
    [0x04, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04], // '|'
    [0x08, 0x04, 0x04, 0x02, 0x04, 0x04, 0x08], // '}'
    [0x00, 0x00, 0x08, 0x15, 0x02, 0x00, 0x00], // '~'
];

/// Returns the 5x7 bitmap for `c`, or `None` if `c` is not printable ASCII.
///
/// Each of the seven entries is one row (top to bottom); bit 4 is the
/// leftmost column and bit 0 the rightmost.
pub fn glyph(c: char) -> Option<&'static [u8; 7]> {
    let code = c as u32;
    if (FIRST..=LAST).contains(&code) {
        Some(&GLYPHS[(code - FIRST) as usize])
    } else {
        None
    }
}

/// Bitmap actually drawn for `c`: its own glyph, or `?` if it has none.
fn glyph_or_fallback(c: char) -> &'static [u8; 7] {
    glyph(c).unwrap_or(&GLYPHS[('?' as u32 - FIRST) as usize])
}

/// Width in pixels of `text` drawn at `scale` (0 for empty text or scale 0).
///
/// Every character advances by [`ADVANCE`] font pixels; the trailing gap after
/// the last character is not counted, so one character is exactly
/// `GLYPH_WIDTH * scale` wide. Saturates at `u32::MAX`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u64;
    if n == 0 {
        return 0;
    }
    let w = (n * u64::from(ADVANCE) - 1) * u64::from(scale);
    u32::try_from(w).unwrap_or(u32::MAX)
}

/// Height in pixels of one line of text at `scale` (`GLYPH_HEIGHT * scale`).
pub fn text_height(scale: u32) -> u32 {
    GLYPH_HEIGHT.saturating_mul(scale)
}

/// Draws `text` horizontally with its top-left corner at (`x`, `y`).
///
/// Each font pixel becomes a `scale` x `scale` block filled with `color`
/// (blended source-over, so a translucent colour is honoured). Pixels outside
/// the pixmap are clipped; a `scale` of 0 draws nothing.
pub fn draw_text(pixmap: &mut Pixmap, x: i32, y: i32, text: &str, scale: u32, color: Color) {
    let src = color.premultiply().to_color_u8();
    let s = i64::from(scale);
    for (i, c) in text.chars().enumerate() {
        let cell_x = i64::from(x) + i as i64 * i64::from(ADVANCE) * s;
        if cell_x >= i64::from(pixmap.width()) {
            break;
        }
        for_each_lit(glyph_or_fallback(c), |col, row| {
            let px = cell_x + i64::from(col) * s;
            let py = i64::from(y) + i64::from(row) * s;
            fill_block(pixmap, px, py, s, s, src);
        });
    }
}

/// Draws `text` rotated 90° counter-clockwise (reading bottom to top), as
/// used for a y-axis label.
///
/// (`x`, `y`) is the top-left corner of the rotated bounding box, which is
/// [`text_height`] pixels wide and [`text_width`] pixels tall; the first
/// character sits at the bottom. Clipping and blending are as in
/// [`draw_text`].
pub fn draw_text_vertical(
    pixmap: &mut Pixmap,
    x: i32,
    y: i32,
    text: &str,
    scale: u32,
    color: Color,
) {
    let src = color.premultiply().to_color_u8();
    let s = i64::from(scale);
    let total = i64::from(text_width(text, scale));
    for (i, c) in text.chars().enumerate() {
        let along = i as i64 * i64::from(ADVANCE) * s;
        if along >= total {
            break;
        }
        for_each_lit(glyph_or_fallback(c), |col, row| {
            // Unrotated pixel block at (tx, ty) maps to (ty, total - tx - s).
            let tx = along + i64::from(col) * s;
            let ty = i64::from(row) * s;
            let px = i64::from(x) + ty;
            let py = i64::from(y) + total - tx - s;
            fill_block(pixmap, px, py, s, s, src);
        });
    }
}

/// Calls `f(col, row)` for every lit pixel of a glyph bitmap.
fn for_each_lit(rows: &[u8; 7], mut f: impl FnMut(u32, u32)) {
    for (row, bits) in rows.iter().enumerate() {
        for col in 0..GLYPH_WIDTH {
            if bits & (1 << (GLYPH_WIDTH - 1 - col)) != 0 {
                f(col, row as u32);
            }
        }
    }
}

/// Blends `src` source-over into the `w` x `h` block at (`x`, `y`), clipped.
fn fill_block(pixmap: &mut Pixmap, x: i64, y: i64, w: i64, h: i64, src: PremultipliedColorU8) {
    let pw = i64::from(pixmap.width());
    let ph = i64::from(pixmap.height());
    let (x0, x1) = (x.max(0), (x + w).min(pw));
    let (y0, y1) = (y.max(0), (y + h).min(ph));
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    let pixels = pixmap.pixels_mut();
    for py in y0..y1 {
        for px in x0..x1 {
            let idx = (py * pw + px) as usize;
            pixels[idx] = blend_over(src, pixels[idx]);
        }
    }
}

/// Source-over compositing of premultiplied colours.
fn blend_over(src: PremultipliedColorU8, dst: PremultipliedColorU8) -> PremultipliedColorU8 {
    let inv = 255 - u32::from(src.alpha());
    let mix = |s: u8, d: u8| -> u8 {
        let v = u32::from(s) + (u32::from(d) * inv + 127) / 255;
        v.min(255) as u8
    };
    let a = mix(src.alpha(), dst.alpha());
    let r = mix(src.red(), dst.red()).min(a);
    let g = mix(src.green(), dst.green()).min(a);
    let b = mix(src.blue(), dst.blue()).min(a);
    PremultipliedColorU8::from_rgba(r, g, b, a).unwrap_or(dst)
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

    #[test]
    fn text_width_and_height() {
        assert_eq!(text_width("", 3), 0);
        assert_eq!(text_width("A", 1), 5);
        assert_eq!(text_width("AB", 1), 11);
        assert_eq!(text_width("abc", 2), (3 * 6 - 1) * 2);
        assert_eq!(text_width("x", 0), 0);
        assert_eq!(text_height(3), 21);
        // Non-ASCII characters count as one (fallback) glyph each.
        assert_eq!(text_width("é", 1), 5);
    }

    #[test]
    fn every_printable_ascii_has_a_glyph() {
        for code in 32u8..=126 {
            let c = code as char;
            let g = glyph(c).expect("glyph present");
            assert!(g.iter().all(|r| *r < 32), "row too wide for {c:?}");
            let lit: u32 = g.iter().map(|r| r.count_ones()).sum();
            if c == ' ' {
                assert_eq!(lit, 0);
            } else {
                assert!(lit > 0, "glyph for {c:?} is blank");
            }
        }
        assert!(glyph('\n').is_none());
        assert!(glyph('\u{7f}').is_none());
    }

    #[test]
    fn glyphs_are_distinct() {
        for a in 33u8..=126 {
            for b in (a + 1)..=126 {
                assert_ne!(glyph(a as char), glyph(b as char), "{} vs {}", a as char, b as char);
            }
        }
    }

    #[test]
    fn draw_text_stays_in_its_box() {
        let mut p = white(100, 40);
        draw_text(&mut p, 10, 5, "H1", 2, Color::BLACK);
        // 'H' is lit in its first column and top row; the rightmost ink is
        // column 3 of '1' (second cell, 6 font pixels right); both glyphs
        // reach the bottom row.
        let (x0, y0, x1, y1) = ink_bbox(&p).unwrap();
        assert_eq!((x0, y0), (10, 5));
        assert_eq!((x1, y1), (10 + (6 + 3) * 2 + 1, 5 + 7 * 2 - 1));
        assert!(x1 < 10 + text_width("H1", 2));
        let c = p.pixel(10, 5).unwrap();
        assert_eq!((c.red(), c.green(), c.blue(), c.alpha()), (0, 0, 0, 255));
    }

    #[test]
    fn draw_text_vertical_rotates() {
        let mut p = white(40, 100);
        let text = "Hi";
        draw_text_vertical(&mut p, 3, 7, text, 1, Color::BLACK);
        let (x0, y0, x1, y1) = ink_bbox(&p).unwrap();
        assert!(x0 >= 3 && x1 < 3 + text_height(1));
        assert!(y0 >= 7 && y1 < 7 + text_width(text, 1));
        // 'H' row 0, col 0 is lit: maps to x = 3, y = 7 + width - 1.
        let c = p.pixel(3, 7 + text_width(text, 1) - 1).unwrap();
        assert_eq!(c.red(), 0);
    }

    #[test]
    fn clipping_and_translucency() {
        let mut p = white(20, 20);
        draw_text(&mut p, -7, -3, "WW", 3, Color::BLACK);
        draw_text(&mut p, 1000, 1000, "x", 1, Color::BLACK);
        draw_text_vertical(&mut p, -50, -50, "long text", 4, Color::BLACK);
        let mut q = white(10, 10);
        draw_text(&mut q, 0, 0, "|", 1, Color::from_rgba8(0, 0, 0, 128));
        let c = q.pixel(2, 0).unwrap();
        assert_eq!(c.alpha(), 255);
        assert!(c.red() > 100 && c.red() < 150, "half blend, got {}", c.red());
    }
}
