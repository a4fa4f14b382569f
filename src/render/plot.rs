//! A small, dependency-light line-plot renderer writing PNG files, e.g. for
//! "largest bit size of the factor entries vs. matrix size `m`, one line per
//! method". A [`LinePlot`] draws grid lines and labelled ticks at "nice"
//! values (1, 2 or 5 times a power of ten; powers of ten if
//! [`LinePlot::log_y`]), a title, axis labels, each [`Series`] as an
//! anti-aliased polyline with markers, and a legend in the plot corner that
//! hides the least data. Points with a non-finite coordinate (or `y <= 0` on
//! a log axis) are skipped and break the line; degenerate ranges are widened.
//! Text uses the bundled outline font of [`super::font`] (DejaVu Sans, anti-aliased).
//!
//! ```no_run
//! use trimorph::render::plot::{LinePlot, Series, PALETTE};
//! let mut plot = LinePlot::new("Factor growth", "matrix size m", "max bits");
//! plot.add_series(Series::new("GCD", vec![(2.0, 3.0), (4.0, 9.0)], PALETTE[0]));
//! plot.save_png(std::path::Path::new("growth.png")).unwrap();
//! ```

use std::io;
use std::path::{Path, PathBuf};

use tiny_skia::{
    Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform,
};

use super::font;

/// A qualitative colour palette (the "tab10" colours) for series.
#[rustfmt::skip]
pub const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189],
    [140, 86, 75], [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207],
];

const WHITE: [u8; 3] = [255, 255, 255];
const GRID_MAJOR: [u8; 3] = [220, 220, 220];
const AXIS: [u8; 3] = [60, 60, 60];
const TEXT: [u8; 3] = [25, 25, 25];
const LEGEND_BORDER: [u8; 3] = [170, 170, 170];
/// Smallest plot area (in pixels, each direction) the layout accepts.
const MIN_PLOT_AREA: i32 = 16;
/// Fraction of the data span added as margin on each side of an axis.
const AXIS_MARGIN: f64 = 0.05;

/// Errors from rendering or saving a plot.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Creating, writing or renaming the (temporary) file failed.
    #[error("I/O error writing {}", path.display())]
    Io {
        /// The destination file.
        path: PathBuf,
        /// The underlying I/O error.
        source: io::Error,
    },
    /// PNG encoding failed.
    #[error("PNG encoding failed: {0}")]
    Encode(String),
    /// The size is outside [`LinePlot::MIN_SIZE`]..=[`LinePlot::MAX_SIZE`],
    /// or too small to fit the labels around the plot area.
    #[error("invalid plot size {width}x{height}")]
    InvalidSize {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
    },
    /// The output path has no file name.
    #[error("invalid output path {}", .0.display())]
    InvalidPath(PathBuf),
}

/// One line of a plot: labelled data points drawn in one colour.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Name shown in the legend.
    pub label: String,
    /// Data points `(x, y)`, connected in the given order.
    pub points: Vec<(f64, f64)>,
    /// Line and marker colour as RGB.
    pub color: [u8; 3],
}

impl Series {
    /// Creates a series from its legend label, points and RGB colour.
    pub fn new(label: &str, points: Vec<(f64, f64)>, color: [u8; 3]) -> Self {
        Series { label: label.to_owned(), points, color }
    }
}

/// A line plot: a set of [`Series`] plus title, axis labels and image size.
#[derive(Clone, Debug, PartialEq)]
pub struct LinePlot {
    /// Title drawn above the plot area (empty for none).
    pub title: String,
    /// Label under the x axis (empty for none).
    pub x_label: String,
    /// Label left of the y axis, drawn vertically (empty for none).
    pub y_label: String,
    /// The lines to draw, in drawing and legend order.
    pub series: Vec<Series>,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Use a base-10 logarithmic y axis (non-positive y values are skipped).
    pub log_y: bool,
}

impl Default for LinePlot {
    /// An empty 800x600 plot with a linear y axis and no labels.
    fn default() -> Self {
        LinePlot::new("", "", "")
    }
}

/// Sizes derived from the image size: font scales, spacing, line widths.
struct Style {
    scale: u32,
    /// Height of one line of tick/label text.
    th: i32,
    title_scale: u32,
    pad: i32,
    gap: i32,
    tick: i32,
    line_width: f32,
    marker_radius: f32,
}

impl Style {
    fn for_size(width: u32, height: u32) -> Self {
        let scale = if width.min(height) >= 480 { 2 } else { 1 };
        let (s, f) = (scale as i32, scale as f32);
        Style {
            scale,
            th: font::text_height(scale) as i32,
            title_scale: scale + 1,
            pad: 5 * s,
            gap: 3 * s,
            tick: 4 * s,
            line_width: 0.5 + f,
            marker_radius: 1.0 + 1.5 * f,
        }
    }

    /// Width of `text` at the tick/label scale.
    fn text_w(&self, text: &str) -> i32 {
        font::text_width(text, self.scale) as i32
    }
}

/// An axis: its range (in log10 space for a log axis) and ticks.
#[derive(Debug)]
struct Axis {
    min: f64,
    max: f64,
    /// Major ticks: position (in axis space) and label.
    ticks: Vec<(f64, String)>,
}

/// The plot area: frame lines at columns `x0`, `x0 + w`, rows `y0`, `y0 + h`.
#[derive(Clone, Copy, Debug)]
struct Area {
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
}

impl Area {
    fn map_x(&self, ax: &Axis, x: f64) -> f64 {
        f64::from(self.x0) + 0.5 + (x - ax.min) / (ax.max - ax.min) * f64::from(self.w)
    }

    fn map_y(&self, ax: &Axis, y: f64) -> f64 {
        f64::from(self.y0) + 0.5 + (ax.max - y) / (ax.max - ax.min) * f64::from(self.h)
    }
}

/// Per series, points in pixel coordinates; `None` is a skipped point.
type PixelPoints = Vec<Vec<Option<(f32, f32)>>>;

impl LinePlot {
    /// Smallest accepted image width or height in pixels.
    pub const MIN_SIZE: u32 = 64;
    /// Largest accepted image width or height in pixels.
    pub const MAX_SIZE: u32 = crate::io::image_use::MAX_DRAWN_SIDE;

    /// Creates an empty 800x600 plot with the given title and axis labels.
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Self {
        LinePlot {
            title: title.to_owned(),
            x_label: x_label.to_owned(),
            y_label: y_label.to_owned(),
            series: Vec::new(),
            width: 800,
            height: 600,
            log_y: false,
        }
    }

    /// Appends a series; returns `self` for chaining.
    pub fn add_series(&mut self, series: Series) -> &mut Self {
        self.series.push(series);
        self
    }

    /// Returns the plot with the image size set to `width` x `height`.
    pub fn with_size(mut self, width: u32, height: u32) -> Self {
        (self.width, self.height) = (width, height);
        self
    }

    /// Renders the plot into a new pixmap of `width` x `height` pixels.
    ///
    /// Fails with [`PlotError::InvalidSize`] if the size is out of range or
    /// leaves no room for the plot area once the labels are laid out.
    pub fn render(&self) -> Result<Pixmap, PlotError> {
        let (width, height) = (self.width, self.height);
        let invalid = || PlotError::InvalidSize { width, height };
        let sizes = Self::MIN_SIZE..=Self::MAX_SIZE;
        if !sizes.contains(&width) || !sizes.contains(&height) {
            return Err(invalid());
        }
        let mut pixmap = Pixmap::new(width, height).ok_or_else(invalid)?;
        pixmap.fill(Color::WHITE);
        let st = Style::for_size(width, height);
        let data: Vec<_> = (self.series.iter()).map(|s| self.axis_points(s)).collect();
        let valid = || data.iter().flatten().flatten();

        // Vertical layout first: the y ticks depend only on the plot height.
        let title_h = font::text_height(st.title_scale) as i32 + st.pad;
        let top = st.pad + if_set(&self.title, title_h);
        let x_label_h = if_set(&self.x_label, st.gap + st.th);
        let plot_h = height as i32 - top - (st.tick + st.gap + st.th + x_label_h + st.pad);
        let y_target = (plot_h / (30 * st.scale as i32)).clamp(2, 10) as usize;
        let (y_lo, y_hi) = bounds(valid().map(|p| p.1)).unwrap_or((0.0, 1.0));
        let make_y_axis = if self.log_y { log_axis } else { linear_axis };
        let y_axis = make_y_axis(y_lo, y_hi, y_target);

        // Horizontal layout: the left margin fits the y tick labels, the
        // right one half of the last x tick label (which is centred).
        let y_label_w = if_set(&self.y_label, st.th + st.gap);
        let y_ticks_w = y_axis.ticks.iter().map(|(_, l)| st.text_w(l)).max();
        let left = st.pad + y_label_w + y_ticks_w.unwrap_or(0) + st.gap + st.tick;
        let (x_lo, x_hi) = bounds(valid().map(|p| p.0)).unwrap_or((0.0, 1.0));
        let x_axis_for = |right| fit_x_axis(x_lo, x_hi, width as i32 - left - right, &st);
        let last_tick = x_axis_for(2 * st.pad).ticks.pop();
        let half_label = last_tick.map_or(0, |(_, l)| st.text_w(&l) / 2);
        let right = (2 * st.pad).max(half_label + st.pad / 2);
        let x_axis = x_axis_for(right);
        let (x0, y0, w, h) = (left, top, width as i32 - left - right, plot_h);
        if w < MIN_PLOT_AREA || h < MIN_PLOT_AREA {
            return Err(invalid());
        }
        let area = Area { x0, y0, w, h };

        self.draw_axes(&mut pixmap, area, &x_axis, &y_axis, &st);
        self.draw_labels(&mut pixmap, area, &st);
        let to_px = |&(x, y): &(f64, f64)| {
            let clamp = |v: f64| v.clamp(-1e7, 1e7) as f32;
            (clamp(area.map_x(&x_axis, x)), clamp(area.map_y(&y_axis, y)))
        };
        let pixel_points: PixelPoints =
            (data.iter()).map(|pts| pts.iter().map(|p| p.as_ref().map(to_px)).collect()).collect();
        self.draw_series(&mut pixmap, &pixel_points, &st);
        self.draw_legend(&mut pixmap, area, &pixel_points, &st);
        Ok(pixmap)
    }

    /// Renders the plot and writes it as a PNG file at `path`.
    ///
    /// The PNG is written and synced to a uniquely named temporary file in
    /// the same directory, then renamed to `path`, so `path` never holds a
    /// partial image. On failure the temporary file is removed.
    pub fn save_png(&self, path: &Path) -> Result<(), PlotError> {
        let png = self.render()?.encode_png();
        let bytes = png.map_err(|e| PlotError::Encode(e.to_string()))?;
        write_atomically(path, &bytes)
    }

    /// The points of `s` in axis space (`y` as log10 on a log axis); `None`
    /// marks a skipped point (non-finite, or `y <= 0` on a log axis).
    fn axis_points(&self, s: &Series) -> Vec<Option<(f64, f64)>> {
        let valid = |&(x, y): &(f64, f64)| match (x.is_finite() && y.is_finite(), self.log_y) {
            (false, _) => None,
            (true, true) => (y > 0.0).then(|| (x, y.log10())),
            (true, false) => Some((x, y)),
        };
        s.points.iter().map(valid).collect()
    }

    fn draw_axes(&self, pm: &mut Pixmap, a: Area, xa: &Axis, ya: &Axis, st: &Style) {
        let y1 = a.y0 + a.h;
        for (v, label) in &xa.ticks {
            let x = a.map_x(xa, *v) as i32;
            fill_px(pm, x, a.y0, 1, a.h, GRID_MAJOR);
            fill_px(pm, x, y1 + 1, 1, st.tick, AXIS);
            let (tx, ty) = (x - st.text_w(label) / 2, y1 + 1 + st.tick + st.gap);
            font::draw_text(pm, tx, ty, label, st.scale, color(TEXT));
        }
        for (v, label) in &ya.ticks {
            let y = a.map_y(ya, *v) as i32;
            fill_px(pm, a.x0, y, a.w, 1, GRID_MAJOR);
            fill_px(pm, a.x0 - st.tick, y, st.tick, 1, AXIS);
            let x = a.x0 - st.tick - st.gap - st.text_w(label);
            font::draw_text(pm, x, y - st.th / 2, label, st.scale, color(TEXT));
        }
        frame_px(pm, a.x0, a.y0, a.w + 1, a.h + 1, AXIS);
    }

    fn draw_labels(&self, pm: &mut Pixmap, a: Area, st: &Style) {
        let text = color(TEXT);
        let center_x = a.x0 + a.w / 2;
        if !self.title.is_empty() {
            // Shrink a long title; centre it over the plot area, in the image.
            let avail = pm.width() as i32 - 2 * st.pad;
            let fits = font::text_width(&self.title, st.title_scale) as i32 <= avail;
            let scale = if fits { st.title_scale } else { st.scale };
            let tw = font::text_width(&self.title, scale) as i32;
            let x = (center_x - tw / 2).clamp(st.pad, (st.pad + avail - tw).max(st.pad));
            let dy = (font::text_height(st.title_scale) - font::text_height(scale)) as i32 / 2;
            font::draw_text(pm, x, st.pad + dy, &self.title, scale, text);
        }
        if !self.x_label.is_empty() {
            let x = center_x - st.text_w(&self.x_label) / 2;
            let y = a.y0 + a.h + 1 + st.tick + 2 * st.gap + st.th;
            font::draw_text(pm, x, y, &self.x_label, st.scale, text);
        }
        if !self.y_label.is_empty() {
            let y = a.y0 + a.h / 2 - st.text_w(&self.y_label) / 2;
            font::draw_text_vertical(pm, st.pad, y, &self.y_label, st.scale, text);
        }
    }

    fn draw_series(&self, pm: &mut Pixmap, pts: &PixelPoints, st: &Style) {
        for (idx, (series, points)) in self.series.iter().zip(pts).enumerate() {
            let mut line = PathBuilder::new();
            let mut markers = PathBuilder::new();
            let mut prev = None;
            for p in points {
                match (prev, *p) {
                    (Some(_), Some((x, y))) => line.line_to(x, y),
                    (None, Some((x, y))) => line.move_to(x, y),
                    _ => {}
                }
                if let Some((x, y)) = *p {
                    push_marker(&mut markers, idx, x, y, st.marker_radius);
                }
                prev = *p;
            }
            draw_path(pm, line, series.color, Some(st.line_width));
            draw_path(pm, markers, series.color, None);
        }
    }

    fn draw_legend(&self, pm: &mut Pixmap, a: Area, pts: &PixelPoints, st: &Style) {
        let (th, inner) = (st.th, 2 * st.gap);
        let (row_h, swatch_w) = (th + st.gap, 20 * st.scale as i32);
        let Some(label_w) = self.series.iter().map(|s| st.text_w(&s.label)).max() else {
            return; // no series, no legend
        };
        let box_w = 2 * inner + swatch_w + 2 * st.gap + label_w;
        let box_h = 2 * inner + self.series.len() as i32 * row_h - st.gap;
        let margin = 2 * st.gap;
        let (l, r) = (a.x0 + margin, a.x0 + a.w - margin - box_w);
        let (t, b) = (a.y0 + margin, a.y0 + a.h - margin - box_h);
        let corners = [(r, t), (l, t), (r, b), (l, b)];
        let (bx, by) = choose_corner(&corners, (box_w, box_h), pts, st.marker_radius);

        fill_px(pm, bx, by, box_w, box_h, WHITE);
        frame_px(pm, bx, by, box_w, box_h, LEGEND_BORDER);
        for (i, s) in self.series.iter().enumerate() {
            let row_y = by + inner + i as i32 * row_h;
            let cy = row_y as f32 + th as f32 / 2.0;
            let (sx0, sx1) = ((bx + inner) as f32, (bx + inner + swatch_w) as f32);
            let mut line = PathBuilder::new();
            line.move_to(sx0, cy);
            line.line_to(sx1, cy);
            draw_path(pm, line, s.color, Some(st.line_width));
            let mut marker = PathBuilder::new();
            push_marker(&mut marker, i, (sx0 + sx1) / 2.0, cy, st.marker_radius);
            draw_path(pm, marker, s.color, None);
            let tx = bx + inner + swatch_w + 2 * st.gap;
            font::draw_text(pm, tx, row_y, &s.label, st.scale, color(TEXT));
        }
    }
}

/// `(min, max)` of `values`, or `None` if there are none.
fn bounds(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let grow = |r: Option<(f64, f64)>, v: f64| r.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v)));
    values.fold(None, |r, v| Some(grow(r, v)))
}

/// Indices of the first and last multiple of `step` in `[lo, hi]`, or `None`
/// if there are none or implausibly many.
fn tick_span(lo: f64, hi: f64, step: f64) -> Option<(i64, i64)> {
    let (a, b) = ((lo / step).ceil(), (hi / step).floor());
    let ok = a.is_finite() && b.is_finite() && a <= b && b - a <= 1000.0;
    ok.then_some((a as i64, b as i64))
}

/// A 1-2-5 step (1, 2 or 5 times a power of ten) giving at least two ticks
/// in `[lo, hi]` and as close to `target` ticks as possible.
fn nice_step(lo: f64, hi: f64, target: usize) -> Option<f64> {
    let target = target.max(2);
    let raw = (hi - lo) / target as f64;
    if !raw.is_finite() || raw <= 0.0 {
        return None;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let candidates = [1.0, 2.0, 5.0, 10.0, 20.0].into_iter().filter_map(|m| {
        let (a, b) = tick_span(lo, hi, m * mag)?;
        let count = (b - a + 1) as usize;
        (count >= 2).then_some((count.abs_diff(target), m * mag))
    });
    // `min_by_key` keeps the first (smallest) step among equally good ones.
    candidates.min_by_key(|c| c.0).map(|(_, step)| step)
}

/// Widens an empty range `[lo, lo]` to a positive span around `lo`.
fn widen(lo: f64, hi: f64) -> (f64, f64) {
    let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
    match (hi > lo, lo + pad > lo - pad) {
        (true, _) => (lo, hi),
        (false, true) => (lo - pad, lo + pad),
        (false, false) => (lo - 1.0, lo + 1.0),
    }
}

/// A linear axis covering `[lo, hi]` plus a margin, with about `target`
/// ticks at multiples of a 1-2-5 step.
fn linear_axis(lo: f64, hi: f64, target: usize) -> Axis {
    let (lo, hi) = widen(lo, hi);
    let m = Some((hi - lo) * AXIS_MARGIN).filter(|m| (hi - lo + 2.0 * m).is_finite());
    let (lo, hi) = (lo - m.unwrap_or(0.0), hi + m.unwrap_or(0.0));
    // Scientific notation (`1.5e7`) for very large or very small values.
    let max_abs = lo.abs().max(hi.abs());
    let sci = !(1e-3..1e6).contains(&max_abs);
    let ticks = match nice_step(lo, hi, target).and_then(|s| Some((s, tick_span(lo, hi, s)?))) {
        Some((step, (a, b))) => {
            (a..=b).map(|k| (k as f64 * step, format_tick(k as f64 * step, step, sci))).collect()
        }
        // Absurd range (e.g. near f64::MAX): label just the ends.
        None => [lo, hi].map(|v| (v, format_tick(v, hi - lo, sci))).to_vec(),
    };
    let (min, max) = (lo, hi);
    Axis { min, max, ticks }
}

/// A log10 axis for data whose log10 lies in `[lo, hi]`.
///
/// Ticks sit at every `k`-th power of ten (about `target` of them). The axis
/// ends at the data plus margin if that holds two powers of ten, else it is
/// widened to whole decades.
fn log_axis(lo: f64, hi: f64, target: usize) -> Axis {
    let m = if hi > lo { hi - lo } else { 20.0 } * AXIS_MARGIN;
    let (mut min, mut max) = (lo - m, hi + m);
    if max.floor() - min.ceil() < 1.0 {
        (min, max) = (min.floor(), max.ceil());
    }
    let (a, b) = (min.ceil(), max.floor());
    let k = ((b - a) / (target.max(2) - 1) as f64).ceil().max(1.0);
    let ticks = ((a / k).ceil() as i64..=(b / k).floor() as i64)
        .map(|i| (i as f64 * k, format_decade((i as f64 * k) as i32)))
        .collect();
    Axis { min, max, ticks }
}

/// An x axis whose tick labels fit side by side in `plot_w` pixels.
fn fit_x_axis(lo: f64, hi: f64, plot_w: i32, st: &Style) -> Axis {
    let mut target = (plot_w / (50 * st.scale as i32)).clamp(2, 12) as usize;
    loop {
        let axis = linear_axis(lo, hi, target);
        let widths = axis.ticks.iter().map(|(_, l)| st.text_w(l) + 4 * st.gap);
        let needed: i32 = widths.sum();
        if needed <= plot_w || target <= 2 {
            return axis;
        }
        target -= 1;
    }
}

/// Formats tick value `v` on an axis with tick spacing `step`, with just
/// enough digits to tell neighbouring ticks apart.
fn format_tick(v: f64, step: f64, scientific: bool) -> String {
    let v = if v.abs() < step.abs() * 1e-6 { 0.0 } else { v };
    let step_exp = step.abs().log10().floor() as i32;
    if !scientific || v == 0.0 {
        let decimals = (-step_exp).clamp(0, 15) as usize;
        return format!("{v:.decimals$}");
    }
    let digits = (v.abs().log10().floor() as i32 - step_exp).clamp(0, 15) as usize;
    let s = format!("{v:.digits$e}");
    match s.split_once('e') {
        Some((mant, exp)) if mant.contains('.') => {
            format!("{}e{exp}", mant.trim_end_matches('0').trim_end_matches('.'))
        }
        _ => s,
    }
}

/// Label for the power of ten `10^d`: plain for moderate `d`, else `1e{d}`.
fn format_decade(d: i32) -> String {
    match d {
        0..=5 => format!("1{}", "0".repeat(d as usize)),
        -3..=-1 => format!("0.{}1", "0".repeat((-d - 1) as usize)),
        _ => format!("1e{d}"),
    }
}

/// Adds marker shape `idx % 4` (circle, square, triangle, diamond) at (x, y).
fn push_marker(pb: &mut PathBuilder, idx: usize, x: f32, y: f32, r: f32) {
    let q = r * 1.25;
    let polygon: &[(f32, f32)] = match idx % 4 {
        0 => return pb.push_circle(x, y, r),
        1 => &[(-0.72, -0.72), (0.72, -0.72), (0.72, 0.72), (-0.72, 0.72)],
        2 => &[(0.0, -1.0), (0.866, 0.5), (-0.866, 0.5)],
        _ => &[(0.0, -1.0), (1.0, 0.0), (0.0, 1.0), (-1.0, 0.0)],
    };
    pb.move_to(x + q * polygon[0].0, y + q * polygon[0].1);
    for &(dx, dy) in &polygon[1..] {
        pb.line_to(x + q * dx, y + q * dy);
    }
    pb.close();
}

/// Strokes the path in `pb` with round caps and joins if `width` is given,
/// else fills it; anti-aliased, in colour `rgb`.
fn draw_path(pm: &mut Pixmap, pb: PathBuilder, rgb: [u8; 3], width: Option<f32>) {
    let Some(path) = pb.finish() else { return };
    let (paint, id) = (paint(rgb, true), Transform::identity());
    if let Some(width) = width {
        let mut stroke = Stroke::default();
        (stroke.width, stroke.line_cap) = (width, LineCap::Round);
        stroke.line_join = LineJoin::Round;
        pm.stroke_path(&path, &paint, &stroke, id, None);
    } else {
        pm.fill_path(&path, &paint, FillRule::Winding, id, None);
    }
}

/// The first candidate top-left corner whose `size` box, grown by `r`,
/// covers the fewest data points and points sampled along line segments.
fn choose_corner(cands: &[(i32, i32)], size: (i32, i32), pts: &PixelPoints, r: f32) -> (i32, i32) {
    let mut samples: Vec<(f32, f32)> = pts.iter().flatten().flatten().copied().collect();
    for pair in pts.iter().flat_map(|s| s.windows(2)) {
        if let [Some((x0, y0)), Some((x1, y1))] = *pair {
            let lerp = |t: f32| (x0 + (x1 - x0) * t, y0 + (y1 - y0) * t);
            samples.extend((1..8).map(|i| lerp(i as f32 / 8.0)));
        }
    }
    let covered = |&(x, y): &(i32, i32)| {
        let (x0, y0) = (x as f32 - r, y as f32 - r);
        let (x1, y1) = ((x + size.0) as f32 + r, (y + size.1) as f32 + r);
        let inside = |&&(px, py): &&(f32, f32)| px >= x0 && px <= x1 && py >= y0 && py <= y1;
        samples.iter().filter(inside).count()
    };
    let best = cands.iter().min_by_key(|c| covered(c));
    best.copied().unwrap_or_default()
}

/// `v` if `text` is non-empty, else 0.
fn if_set(text: &str, v: i32) -> i32 {
    v * i32::from(!text.is_empty())
}

fn color(rgb: [u8; 3]) -> Color {
    Color::from_rgba8(rgb[0], rgb[1], rgb[2], 255)
}

fn paint(rgb: [u8; 3], anti_alias: bool) -> Paint<'static> {
    let mut p = Paint::default();
    (p.anti_alias, p.shader) = (anti_alias, tiny_skia::Shader::SolidColor(color(rgb)));
    p
}

/// Fills an axis-aligned pixel rectangle without anti-aliasing.
fn fill_px(pm: &mut Pixmap, x: i32, y: i32, w: i32, h: i32, rgb: [u8; 3]) {
    if let Some(rect) = Rect::from_xywh(x as f32, y as f32, w as f32, h as f32) {
        pm.fill_rect(rect, &paint(rgb, false), Transform::identity(), None);
    }
}

/// Draws the 1-pixel outline of the pixel rectangle at (x, y) of size w x h.
fn frame_px(pm: &mut Pixmap, x: i32, y: i32, w: i32, h: i32, rgb: [u8; 3]) {
    fill_px(pm, x, y, w, 1, rgb);
    fill_px(pm, x, y + h - 1, w, 1, rgb);
    fill_px(pm, x, y, 1, h, rgb);
    fill_px(pm, x + w - 1, y, 1, h, rgb);
}

/// Writes `bytes` through [`crate::io::write_atomic`] (temporary sibling, sync, rename).
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    if path.file_name().is_none() {
        return Err(PlotError::InvalidPath(path.to_path_buf()));
    }
    crate::io::write_atomic(path, bytes).map_err(|e| match e {
        crate::io::IoError::Write { path, source } | crate::io::IoError::Read { path, source } => {
            PlotError::Io { path, source }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    /// Number of opaque pixels exactly equal to `rgb`.
    fn count(pm: &Pixmap, rgb: [u8; 3]) -> usize {
        let want = tiny_skia::PremultipliedColorU8::from_rgba(rgb[0], rgb[1], rgb[2], 255);
        pm.pixels().iter().filter(|c| Some(**c) == want).count()
    }

    fn sample_plot() -> LinePlot {
        let mut plot = LinePlot::new("Max bits vs m", "matrix size m", "max bit size");
        let line = |f: fn(f64) -> f64| [2.0, 4.0, 8.0, 16.0, 32.0].map(|m| (m, f(m))).to_vec();
        plot.add_series(Series::new("None", line(|m| m * m * 3.0), PALETTE[0]))
            .add_series(Series::new("GCD", line(|m| m * 10.0), PALETTE[1]))
            .add_series(Series::new("Turner", line(|m| m * 4.0 + 1.0), PALETTE[2]));
        plot
    }

    /// Checks the axis invariants and returns its tick labels.
    fn labels(a: &Axis) -> Vec<&str> {
        let inside = |t: &(f64, String)| t.0 >= a.min && t.0 <= a.max;
        assert!(a.max > a.min && a.ticks.iter().all(inside), "{a:?}");
        a.ticks.iter().map(|(_, l)| l.as_str()).collect()
    }

    #[test]
    fn nice_ticks_and_labels() {
        let steps = [(10.0, 5, 2.0), (10.0, 3, 5.0), (1.0, 10, 0.1), (2100.0, 5, 500.0)];
        for (hi, t, want) in steps {
            let got = nice_step(0.0, hi, t).unwrap();
            assert!((got - want).abs() <= 1e-12 * want, "0..{hi}/{t}: {got}");
        }
        assert_eq!(nice_step(1.0, 1.0, 5), None);
        assert_eq!(labels(&linear_axis(0.0, 9.3, 5)), ["0", "2", "4", "6", "8"]);
        let a = linear_axis(-0.3, 0.25, 5);
        assert_eq!(labels(&a), ["-0.3", "-0.2", "-0.1", "0.0", "0.1", "0.2"]);
        let a = linear_axis(0.0, 3.0e7, 4);
        assert_eq!(labels(&a), ["0", "1e7", "2e7", "3e7"]);
        for v in [0.0, 5.0, -3.0, 1e-300, 1e300] {
            let a = linear_axis(v, v, 5);
            assert!(a.min < v && v < a.max && labels(&a).len() >= 2, "{v}");
        }
        let a = log_axis(0.0, 5.3, 10);
        assert_eq!(labels(&a), ["1", "10", "100", "1000", "10000", "100000"]);
        let a = log_axis(1.3, 1.9, 5); // within one decade: whole decades
        assert_eq!((a.min, a.max, labels(&a)), (1.0, 2.0, vec!["10", "100"]));
        assert!((2..=5).contains(&labels(&log_axis(-100.0, 100.0, 5)).len()));
        assert!(labels(&log_axis(2.0, 2.0, 5)).len() >= 2);
        assert_eq!(format_tick(1.5e6, 5e5, true), "1.5e6");
        assert_eq!(format_tick(1e-17, 0.1, false), "0.0");
        let decades = [0, 3, -2, 9, -7].map(format_decade);
        assert_eq!(decades, ["1", "1000", "0.01", "1e9", "1e-7"]);
    }

    #[test]
    fn render_draws_every_series_colour() {
        for (w, h, min) in [(800, 600, 50), (200, 150, 5)] {
            for log_y in [false, true] {
                let mut plot = sample_plot().with_size(w, h);
                plot.log_y = log_y;
                let pm = plot.render().unwrap();
                assert_eq!((pm.width(), pm.height()), (w, h));
                for s in &plot.series {
                    let n = count(&pm, s.color);
                    assert!(n > min, "{w}x{h}: series {} has only {n} pixels", s.label);
                }
                assert!(count(&pm, WHITE) > (w * h / 2) as usize);
                assert!(count(&pm, GRID_MAJOR) > 20 && count(&pm, TEXT) > 50);
            }
        }
        for plot in [LinePlot::default(), LinePlot::new("Empty", "x", "y")] {
            let pm = plot.render().unwrap(); // no series: axes only
            assert!(count(&pm, AXIS) > 1000 && count(&pm, TEXT) > 0);
        }
    }

    #[test]
    fn edge_case_data() {
        let (nan, inf, big) = (f64::NAN, f64::INFINITY, f64::MAX);
        let cases = [
            vec![],
            vec![(3.0, 7.0)],
            vec![(1.0, 5.0), (2.0, 5.0), (3.0, 5.0)],
            vec![(4.0, 1.0), (4.0, 2.0), (1.0, -1.0), (2.0, 0.0)],
            vec![(nan, 1.0), (1.0, inf), (2.0, 2.0), (3.0, nan), (4.0, 3.0)],
            vec![(-1e300, 1e300), (1e300, -1e300), (-big, big), (big, -big)],
            vec![(0.0, 1e-300), (1e-300, 0.0), (-inf, nan)],
        ];
        let purple = [200, 0, 200];
        for (i, pts) in cases.into_iter().enumerate() {
            for log_y in [false, true] {
                let mut plot = LinePlot::new("edge", "x", "y");
                plot.add_series(Series::new("s", pts.clone(), purple)).log_y = log_y;
                let pm = plot.render().unwrap_or_else(|e| panic!("case {i}: {e}"));
                assert!(count(&pm, purple) > 0, "case {i}: legend missing");
            }
        }
        // A single point or constant data shows markers beyond the legend.
        let mut plot = LinePlot::new("one", "x", "y");
        plot.add_series(Series::new("", vec![], purple));
        let legend_only = count(&plot.render().unwrap(), purple);
        for pts in [vec![(1.0, 1.0)], vec![(1.0, 5.0), (2.0, 5.0)]] {
            plot.series[0].points = pts;
            assert!(count(&plot.render().unwrap(), purple) > legend_only + 10);
        }
    }

    #[test]
    fn invalid_sizes_are_rejected() {
        for (width, height) in [(0, 100), (100, 0), (10, 10), (20000, 100)] {
            let err = sample_plot().with_size(width, height).render().unwrap_err();
            let want = PlotError::InvalidSize { width, height };
            assert_eq!(err.to_string(), want.to_string());
        }
        let min = LinePlot::MIN_SIZE; // long labels: renders or fails cleanly
        let _ = sample_plot().with_size(min, min).render();
    }

    #[test]
    fn legend_avoids_data() {
        let corners = [(100, 0), (0, 0), (100, 100), (0, 100)];
        let pts = vec![vec![Some((120.0, 10.0)), None, Some((5.0, 5.0))]];
        assert_eq!(choose_corner(&corners, (50, 50), &pts, 0.0), (100, 100));
        let line = vec![vec![Some((110.0, 10.0)), Some((10.0, 10.0))]];
        assert_eq!(choose_corner(&corners, (50, 50), &line, 0.0), (100, 100));
        assert_eq!(choose_corner(&corners, (50, 50), &vec![], 0.0), (100, 0));
    }

    #[test]
    fn save_png_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.png");
        let plot = sample_plot().with_size(320, 240);
        plot.save_png(&path).unwrap();
        plot.save_png(&path).unwrap(); // overwriting works too
        assert_eq!(&fs::read(&path).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
        let back = Pixmap::load_png(&path).unwrap();
        assert_eq!((back.width(), back.height()), (320, 240));
        assert_eq!(back.data(), plot.render().unwrap().data());
        let mut names = fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name());
        assert_eq!(names.next().unwrap(), "plot.png");
        assert!(names.next().is_none(), "temporary file left behind");
    }

    #[test]
    fn save_png_errors() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("no-such-dir").join("plot.png");
        let err = sample_plot().save_png(&missing).unwrap_err();
        assert!(matches!(err, PlotError::Io { .. }), "{err:?}");
        assert!(fs::read_dir(dir.path()).unwrap().next().is_none());
        let err = sample_plot().save_png(Path::new("/")).unwrap_err();
        assert!(matches!(err, PlotError::InvalidPath(_)), "{err:?}");
        let path = dir.path().join("bad.png");
        let err = sample_plot().with_size(1, 600).save_png(&path).unwrap_err();
        assert!(matches!(err, PlotError::InvalidSize { .. }) && !path.exists());
    }
}
