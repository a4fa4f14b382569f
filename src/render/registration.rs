//! The registration overlay: FIXED and MOVING in two colours, before and after, side by side.
//!
//! Each panel has FIXED's size. FIXED is drawn in magenta (red + blue) and MOVING in green,
//! each grey level stretched between its 1st and 99th percentile (MOVING's as given for
//! both of its panels): where the two agree the
//! panel is grey-white, where they disagree it is magenta or green. The left panel shows
//! MOVING as given, on the same pixel grid (no transform); the right one MOVING resampled
//! onto FIXED through the registration.

use super::font::draw_text;
use tiny_skia::{Color, Pixmap};

/// The 1st and 99th percentiles of the finite values.
fn percentiles(v: &[f32]) -> (f32, f32) {
    let mut s: Vec<f32> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return (0.0, 1.0);
    }
    s.sort_by(f32::total_cmp);
    (s[s.len() / 100], s[(s.len() * 99) / 100])
}

/// Values stretched to `[0, 1]` between `lo` and `hi`.
fn stretch(v: &[f32], (lo, hi): (f32, f32)) -> Vec<f32> {
    let d = if hi > lo { hi - lo } else { 1.0 };
    v.iter().map(|&x| ((x - lo) / d).clamp(0.0, 1.0)).collect()
}

/// The overlay picture (`w x h` is FIXED's size; `moving_as_given` is MOVING's grey values
/// on FIXED's grid, NaN where it has none; `moving_after` the same through the
/// registration). Two panels with a 8-pixel gap, labelled `before` and `after`.
pub fn overlay(
    w: usize,
    h: usize,
    fixed: &[f32],
    moving_as_given: &[f32],
    moving_after: &[f32],
) -> Pixmap {
    let gap = 8;
    let (pw, ph) = ((2 * w + gap) as u32, h as u32);
    let mut pm = Pixmap::new(pw.max(1), ph.max(1)).expect("non-empty");
    pm.fill(Color::from_rgba8(255, 255, 255, 255));
    let f = stretch(fixed, percentiles(fixed));
    // Both MOVING panels with MOVING's own percentiles (the resampled one has background
    // where MOVING does not reach, which would shift its percentiles).
    let range = percentiles(moving_as_given);
    let to8 = |v: f32| (v * 255.0).round() as u8;
    for (panel, mov) in [moving_as_given, moving_after].into_iter().enumerate() {
        let m = stretch(mov, range);
        let x0 = panel * (w + gap);
        let data = pm.data_mut();
        for y in 0..h {
            for x in 0..w {
                let k = y * w + x;
                let g = if mov[k].is_finite() { m[k] } else { 0.0 };
                let i = 4 * (y * pw as usize + x0 + x);
                data[i] = to8(f[k]);
                data[i + 1] = to8(g);
                data[i + 2] = to8(f[k]);
                data[i + 3] = 255;
            }
        }
    }
    let scale = if h >= 300 { 2 } else { 1 };
    let white = Color::from_rgba8(255, 255, 0, 255);
    draw_text(&mut pm, 6, 4, "before", scale, white);
    draw_text(&mut pm, (w + gap + 6) as i32, 4, "after", scale, white);
    pm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agreeing_images_are_grey_and_disagreeing_ones_coloured() {
        let (w, h) = (40, 30);
        let f: Vec<f32> = (0..w * h).map(|k| (k % w) as f32).collect();
        let shifted: Vec<f32> = (0..w * h).map(|k| ((k % w + 20) % w) as f32).collect();
        let pm = overlay(w, h, &f, &shifted, &f);
        let px = |x: usize, y: usize| {
            let i = 4 * (y * (2 * w + 8) + x);
            [pm.data()[i], pm.data()[i + 1], pm.data()[i + 2]]
        };
        // After: equal channels (grey), away from the label.
        let a = px(w + 8 + 30, 25);
        assert_eq!(a[0], a[1]);
        // Before: green and magenta differ.
        let b = px(30, 25);
        assert!(b[0].abs_diff(b[1]) > 100, "{b:?}");
        assert_eq!(pm.width() as usize, 2 * w + 8);
    }
}
