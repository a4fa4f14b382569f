//! The picture of a Jacobian determinant map with its colour bar (`trimorph field --jacobian`).
//!
//! The map keeps its pixels where they are: pixel `(x, y)` of the picture, for `x < w` and
//! `y < h`, is the colour ([`crate::warp::field::det_color`]) of `det J` at field pixel
//! `(x, y)`, transparent outside the mesh, so the top `w x h` of the picture still lies over
//! the image pixel for pixel. The bar is a white strip **below** the map (the picture is wider
//! than `w` only when the map is narrower than the bar needs): the label `det J`, a red
//! swatch for folds (`≤0`), and the colour ramp on its log scale from 1/4 (blue, saturated
//! below) through 1 (white) to 4 (orange, saturated above), with ticks and labels at
//! 1/4, 1/2, 1, 2 and 4.

use tiny_skia::{Color, Pixmap, PremultipliedColorU8};

use super::deformation::RenderError;
use super::font;
use crate::warp::field::det_color;

/// Tick values of the ramp and their labels.
pub const TICKS: [(f64, &str); 5] =
    [(0.25, "≤0.25"), (0.5, "0.5"), (1.0, "1"), (2.0, "2"), (4.0, "≥4")];

/// Where the parts of the colour bar are in the picture (pixels; ranges end-exclusive).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarLayout {
    /// Picture width and height (map plus strip).
    pub width: u32,
    /// Picture height: the map's `h` plus the strip.
    pub height: u32,
    /// Text scale of the labels (see [`font::text_height`]).
    pub scale: u32,
    /// Rows of the ramp and the fold swatch.
    pub bar_y: (u32, u32),
    /// Columns of the fold swatch.
    pub fold_x: (u32, u32),
    /// Columns of the ramp: `ramp_x.0` is `det J = 1/4`, `ramp_x.1 - 1` is 4.
    pub ramp_x: (u32, u32),
    /// First row of the tick labels.
    pub label_y: u32,
}

impl BarLayout {
    /// The layout for a `w x h` map: text scale `clamp(w / 400, 1, 4)`, the strip
    /// `40 * scale` pixels tall, at least `360 * scale` pixels wide.
    pub fn new(w: u32, h: u32) -> BarLayout {
        let k = (w / 400).clamp(1, 4);
        let pad = 6 * k;
        let width = w.max(360 * k);
        let title = font::text_width("det J", k);
        let fold_x = (pad + title + pad, pad + title + pad + 16 * k);
        let half_last = font::text_width(TICKS[4].1, k) / 2;
        // A span divisible by 4 puts the ticks (1/4 of the log range apart) on exact columns.
        let x0 = fold_x.1 + 2 * pad + font::text_width(TICKS[0].1, k) / 2;
        let span = (width - pad - half_last - 1 - x0) / 4 * 4;
        let ramp_x = (x0, x0 + span + 1);
        let bar_y = (h + pad, h + pad + 12 * k);
        let label_y = bar_y.1 + 4 * k;
        let height = label_y + font::text_height(k) + pad;
        BarLayout { width, height, scale: k, bar_y, fold_x, ramp_x, label_y }
    }

    /// The ramp column of `det J = d` (clamped to the ramp's ends).
    pub fn x_of(&self, d: f64) -> u32 {
        let t = ((d.log2() / 2.0).clamp(-1.0, 1.0) + 1.0) / 2.0;
        let (a, b) = (f64::from(self.ramp_x.0), f64::from(self.ramp_x.1 - 1));
        (a + t * (b - a)).round() as u32
    }

    /// `det J` shown at ramp column `x`.
    fn d_of(&self, x: u32) -> f64 {
        let (a, b) = (f64::from(self.ramp_x.0), f64::from(self.ramp_x.1 - 1));
        let t = (f64::from(x) - a) / (b - a);
        (2.0 * (2.0 * t - 1.0)).exp2()
    }
}

/// The picture of the `w x h` map `dets` (row-major `det J`, NaN outside the mesh) with the
/// colour bar below it (see the module docs), and its layout.
pub fn jacobian_picture(dets: &[f64], w: u32, h: u32) -> Result<(Pixmap, BarLayout), RenderError> {
    let size_err = RenderError::Size { width: w, height: h };
    if w == 0 || h == 0 || dets.len() != w as usize * h as usize {
        return Err(size_err);
    }
    let l = BarLayout::new(w, h);
    let mut pm = Pixmap::new(l.width, l.height).ok_or(size_err)?;
    let put = |pm: &mut Pixmap, x: u32, y: u32, c: [u8; 4]| {
        let i = (y * l.width + x) as usize;
        pm.pixels_mut()[i] = tiny_skia::ColorU8::from_rgba(c[0], c[1], c[2], c[3]).premultiply();
    };
    for y in 0..h {
        for x in 0..w {
            put(&mut pm, x, y, det_color(dets[(y * w + x) as usize]));
        }
    }
    let white = PremultipliedColorU8::from_rgba(255, 255, 255, 255).expect("opaque");
    for p in &mut pm.pixels_mut()[(h * l.width) as usize..] {
        *p = white;
    }
    let k = l.scale;
    for y in l.bar_y.0..l.bar_y.1 {
        for x in l.fold_x.0..l.fold_x.1 {
            put(&mut pm, x, y, det_color(0.0));
        }
        for x in l.ramp_x.0..l.ramp_x.1 {
            put(&mut pm, x, y, det_color(l.d_of(x)));
        }
    }
    let grey = [120, 120, 120, 255];
    let (t0, t1) = (l.bar_y.0, l.bar_y.1);
    for x in (l.fold_x.0..l.fold_x.1).chain(l.ramp_x.0..l.ramp_x.1) {
        put(&mut pm, x, t0 - 1, grey);
        put(&mut pm, x, t1, grey);
    }
    let text = Color::from_rgba8(25, 25, 25, 255);
    let th = font::text_height(k);
    font::draw_text(
        &mut pm,
        (6 * k) as i32,
        (t0 + (t1 - t0) / 2) as i32 - th as i32 / 2,
        "det J",
        k,
        text,
    );
    let centred = |pm: &mut Pixmap, cx: u32, label: &str| {
        let x = cx as i32 - font::text_width(label, k) as i32 / 2;
        font::draw_text(pm, x, l.label_y as i32, label, k, text);
    };
    centred(&mut pm, (l.fold_x.0 + l.fold_x.1) / 2, "≤0");
    for (d, label) in TICKS {
        let x = l.x_of(d);
        for y in t1..t1 + 3 * k {
            put(&mut pm, x, y, [25, 25, 25, 255]);
        }
        centred(&mut pm, x, label);
    }
    Ok((pm, l))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rgba(pm: &Pixmap, x: u32, y: u32) -> [u8; 4] {
        let c = pm.pixel(x, y).unwrap().demultiply();
        [c.red(), c.green(), c.blue(), c.alpha()]
    }

    #[test]
    fn map_pixels_stay_and_the_bar_reads_the_scale() {
        let (w, h) = (50u32, 30u32);
        let dets: Vec<f64> = (0..w * h)
            .map(|i| if i % w < 5 { f64::NAN } else { 0.1 + (i % w) as f64 / 10.0 })
            .collect();
        let (pm, l) = jacobian_picture(&dets, w, h).unwrap();
        assert_eq!((pm.width(), l.width), (360, 360), "a narrow map gets a full-width bar");
        assert_eq!(pm.height(), h + 40);
        for y in 0..h {
            for x in 0..w {
                assert_eq!(rgba(&pm, x, y), det_color(dets[(y * w + x) as usize]), "({x}, {y})");
            }
            assert_eq!(rgba(&pm, w + 3, y)[3], 0, "beside the map stays transparent");
        }
        let y = (l.bar_y.0 + l.bar_y.1) / 2;
        for (d, _) in TICKS {
            assert_eq!(rgba(&pm, l.x_of(d), y), det_color(d), "ramp at {d}");
        }
        assert_eq!(rgba(&pm, l.x_of(1.0), y), [255, 255, 255, 255]);
        assert_eq!(rgba(&pm, l.fold_x.0 + 2, y), [220, 0, 0, 255], "fold swatch");
        // Tick labels: dark ink under every tick.
        for (d, label) in TICKS {
            let x = l.x_of(d);
            let dark = (l.label_y..l.label_y + font::text_height(1))
                .flat_map(|yy| (x.saturating_sub(8)..x + 8).map(move |xx| (xx, yy)))
                .filter(|&(xx, yy)| rgba(&pm, xx.min(359), yy)[0] < 100)
                .count();
            assert!(dark > 3, "label {label} at x {x}: {dark} dark pixels");
        }
        assert!(l.x_of(0.25) < l.x_of(0.5) && l.x_of(2.0) < l.x_of(4.0));
        assert_eq!(l.x_of(1.0) * 2, l.ramp_x.0 + l.ramp_x.1 - 1);
    }

    #[test]
    fn wide_maps_keep_their_width_and_scale_the_text() {
        let (w, h) = (1000u32, 10u32);
        let (pm, l) = jacobian_picture(&vec![1.0; (w * h) as usize], w, h).unwrap();
        assert_eq!((pm.width(), l.scale, pm.height()), (1000, 2, h + 80));
        assert!(jacobian_picture(&[1.0; 3], 2, 2).is_err());
    }
}
