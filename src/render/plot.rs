//! A small, dependency-light line-plot renderer that writes PNG files.
//!
//! It is meant for plotting experiment results, e.g. "largest bit size of the
//! factor entries vs. matrix size `m`, one line per method", and deliberately
//! supports only what that needs:
//!
//! * a white canvas with a framed plot area, light-grey grid lines and
//!   outward tick marks at "nice" values (steps of 1, 2 or 5 times a power of
//!   ten), with tick labels;
//! * an optional base-10 logarithmic y axis ([`LinePlot::log_y`]) with ticks
//!   at powers of ten and minor grid lines in between;
//! * a title, an x-axis label and a (vertical) y-axis label;
//! * every [`Series`] drawn as an anti-aliased polyline with small markers at
//!   its data points (the marker shape cycles through circle, square,
//!   triangle and diamond so lines stay distinguishable in greyscale);
//! * a legend box listing the series, placed in the corner of the plot area
//!   that hides the fewest data points.
//!
//! Points with a non-finite coordinate (and, on a log axis, points with
//! `y <= 0`) are skipped and break the line, like a gap in the data. Empty
//! plots, single points and constant data all render: a degenerate axis range
//! is widened to a non-zero span.
//!
//! Drawing uses [`tiny_skia`]; text uses the built-in bitmap font in
//! [`super::font`], so no system fonts are needed. [`LinePlot::save_png`]
//! writes atomically: the PNG goes to a temporary file in the target
//! directory, which is then renamed over the destination.
//!
//! ```no_run
//! use trimorph::render::plot::{LinePlot, Series, PALETTE};
//! let mut plot = LinePlot::new("Factor growth", "matrix size m", "max bits");
//! plot.add_series(Series::new("GCD", vec![(2.0, 3.0), (4.0, 9.0)], PALETTE[0]));
//! plot.save_png(std::path::Path::new("growth.png")).unwrap();
//! ```

use std::fs::{self, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

use tiny_skia::{
    Color, FillRule, LineCap, LineJoin, Mask, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform,
};

use super::font;

/// A qualitative colour palette (the "tab10" colours) for series.
pub const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

const GRID_MAJOR: [u8; 3] = [220, 220, 220];
const GRID_MINOR: [u8; 3] = [240, 240, 240];
const AXIS: [u8; 3] = [60, 60, 60];
const TEXT: [u8; 3] = [25, 25, 25];
const LEGEND_BORDER: [u8; 3] = [170, 170, 170];
/// Smallest plot area (in pixels, each direction) the layout accepts.
const MIN_PLOT_AREA: i32 = 16;

/// Errors from rendering or saving a plot.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Creating, writing or renaming a file failed.
    #[error("I/O error on {}", path.display())]
    Io {
        /// The file that was being written or renamed.
        path: PathBuf,
        /// The underlying I/O error.
        source: io::Error,
    },
    /// PNG encoding failed.
    #[error("PNG encoding failed: {0}")]
    Encode(String),
    /// The image size is outside
    /// [`LinePlot::MIN_SIZE`]..=[`LinePlot::MAX_SIZE`], or too small to fit
    /// the labels around the plot area.
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
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, color: [u8; 3]) -> Self {
        Series {
            label: label.into(),
            points,
            color,
        }
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
        LinePlot {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            series: Vec::new(),
            width: 800,
            height: 600,
            log_y: false,
        }
    }
}

/// Sizes derived from the image size: font scales, spacing, line widths.
struct Style {
    scale: u32,
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
        let s = scale as i32;
        Style {
            scale,
            title_scale: scale + 1,
            pad: 5 * s,
            gap: 3 * s,
            tick: 4 * s,
            line_width: 0.5 + scale as f32,
            marker_radius: 1.0 + 1.5 * scale as f32,
        }
    }
}

/// An axis: its data-space range (log10 space for a log axis) and ticks.
#[derive(Debug)]
struct Axis {
    min: f64,
    max: f64,
    /// Major ticks: position (in axis space) and label.
    ticks: Vec<(f64, String)>,
    /// Minor grid positions (in axis space), unlabelled.
    minor: Vec<f64>,
}

impl Axis {
    fn frac(&self, v: f64) -> f64 {
        (v - self.min) / (self.max - self.min)
    }

    fn max_label_width(&self, scale: u32) -> i32 {
        self.ticks
            .iter()
            .map(|(_, l)| font::text_width(l, scale) as i32)
            .max()
            .unwrap_or(0)
    }
}

/// The plot area in pixels: frame lines are at columns `x0`, `x0 + w` and
/// rows `y0`, `y0 + h`.
#[derive(Clone, Copy, Debug)]
struct Area {
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
}

impl Area {
    fn map_x(&self, axis: &Axis, x: f64) -> f64 {
        f64::from(self.x0) + 0.5 + axis.frac(x) * f64::from(self.w)
    }

    fn map_y(&self, axis: &Axis, y: f64) -> f64 {
        f64::from(self.y0) + 0.5 + (1.0 - axis.frac(y)) * f64::from(self.h)
    }
}

impl LinePlot {
    /// Smallest accepted image width or height in pixels.
    pub const MIN_SIZE: u32 = 64;
    /// Largest accepted image width or height in pixels.
    pub const MAX_SIZE: u32 = 16384;

    /// Creates an empty 800x600 plot with the given title and axis labels.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        LinePlot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            ..LinePlot::default()
        }
    }

    /// Appends a series; returns `self` for chaining.
    pub fn add_series(&mut self, series: Series) -> &mut Self {
        self.series.push(series);
        self
    }

    /// Returns the plot with the image size set to `width` x `height`.
    pub fn with_size(mut self, width: u32, height: u32) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    /// Returns the plot with the logarithmic y axis switched on or off.
    pub fn with_log_y(mut self, log_y: bool) -> Self {
        self.log_y = log_y;
        self
    }

    /// Renders the plot into a new pixmap of `width` x `height` pixels.
    ///
    /// Fails with [`PlotError::InvalidSize`] if the size is out of range or
    /// leaves no room for the plot area after the labels are laid out.
    pub fn render(&self) -> Result<Pixmap, PlotError> {
        let (width, height) = (self.width, self.height);
        let invalid = PlotError::InvalidSize { width, height };
        let range = Self::MIN_SIZE..=Self::MAX_SIZE;
        if !range.contains(&width) || !range.contains(&height) {
            return Err(invalid);
        }
        let mut pixmap =
            Pixmap::new(width, height).ok_or(PlotError::InvalidSize { width, height })?;
        pixmap.fill(Color::WHITE);
        let st = Style::for_size(width, height);
        let th = font::text_height(st.scale) as i32;

        let data = self.prepared_points();
        let (x_range, y_range) = data_bounds(&data);

        // Vertical layout first: the y ticks depend only on the plot height.
        let top = st.pad
            + if self.title.is_empty() {
                0
            } else {
                font::text_height(st.title_scale) as i32 + st.pad
            };
        let x_label_h = if self.x_label.is_empty() {
            0
        } else {
            st.gap + th
        };
        let bottom_margin = st.tick + st.gap + th + x_label_h + st.pad;
        let plot_h = height as i32 - top - bottom_margin;
        if plot_h < MIN_PLOT_AREA {
            return Err(invalid);
        }
        let y_target = (plot_h / (30 * st.scale as i32)).clamp(2, 10) as usize;
        let y_axis = match (self.log_y, y_range) {
            (true, Some((lo, hi))) => log_axis(lo, hi, y_target),
            (true, None) => log_axis(0.0, 1.0, y_target),
            (false, Some((lo, hi))) => linear_axis(lo, hi, y_target),
            (false, None) => linear_axis(0.0, 1.0, y_target),
        };

        // Horizontal layout: left margin from the y tick labels, right margin
        // wide enough for half of the last x tick label.
        let y_label_w = if self.y_label.is_empty() {
            0
        } else {
            th + st.gap
        };
        let left = st.pad + y_label_w + y_axis.max_label_width(st.scale) + st.gap + st.tick;
        let (x_lo, x_hi) = x_range.unwrap_or((0.0, 1.0));
        let mut right_margin = 2 * st.pad;
        let mut plot_w;
        let mut x_axis;
        let mut attempts = 0;
        loop {
            plot_w = width as i32 - left - right_margin;
            if plot_w < MIN_PLOT_AREA {
                return Err(invalid);
            }
            x_axis = fit_x_axis(x_lo, x_hi, plot_w, &st);
            let last_half = x_axis
                .ticks
                .last()
                .map_or(0, |(_, l)| font::text_width(l, st.scale) as i32 / 2);
            attempts += 1;
            if last_half + st.pad / 2 <= right_margin || attempts >= 3 {
                break;
            }
            right_margin = last_half + st.pad / 2;
        }
        let area = Area {
            x0: left,
            y0: top,
            w: plot_w,
            h: plot_h,
        };

        self.draw_grid_and_axes(&mut pixmap, area, &x_axis, &y_axis, &st);
        self.draw_labels(&mut pixmap, area, &st);
        let pixel_points: Vec<Vec<Option<(f32, f32)>>> = data
            .iter()
            .map(|pts| {
                pts.iter()
                    .map(|p| {
                        p.map(|(x, y)| to_pixel(area.map_x(&x_axis, x), area.map_y(&y_axis, y)))
                    })
                    .collect()
            })
            .collect();
        self.draw_series(&mut pixmap, area, &pixel_points, &st);
        self.draw_legend(&mut pixmap, area, &pixel_points, &st);
        Ok(pixmap)
    }

    /// Renders the plot and writes it as a PNG file at `path`.
    ///
    /// The data is first written (and synced) to a uniquely named temporary
    /// file in the same directory, which is then renamed to `path`, so
    /// `path` never holds a partially written image. On failure the
    /// temporary file is removed.
    pub fn save_png(&self, path: &Path) -> Result<(), PlotError> {
        let pixmap = self.render()?;
        let bytes = pixmap
            .encode_png()
            .map_err(|e| PlotError::Encode(e.to_string()))?;
        write_atomically(path, &bytes)
    }

    /// Per series, the valid points in axis space (`y` as log10 on a log
    /// axis); `None` marks a skipped point, which breaks the line.
    fn prepared_points(&self) -> Vec<Vec<Option<(f64, f64)>>> {
        self.series
            .iter()
            .map(|s| {
                s.points
                    .iter()
                    .map(|&(x, y)| {
                        if !x.is_finite() || !y.is_finite() {
                            None
                        } else if self.log_y {
                            (y > 0.0).then(|| (x, y.log10()))
                        } else {
                            Some((x, y))
                        }
                    })
                    .collect()
            })
            .collect()
    }

    fn draw_grid_and_axes(&self, pm: &mut Pixmap, a: Area, xa: &Axis, ya: &Axis, st: &Style) {
        let (x1, y1) = (a.x0 + a.w, a.y0 + a.h);
        for &v in &ya.minor {
            let y = a.map_y(ya, v).floor() as i32;
            fill_px(pm, a.x0, y, a.w, 1, GRID_MINOR);
        }
        for (v, _) in &xa.ticks {
            let x = a.map_x(xa, *v).floor() as i32;
            fill_px(pm, x, a.y0, 1, a.h, GRID_MAJOR);
        }
        for (v, _) in &ya.ticks {
            let y = a.map_y(ya, *v).floor() as i32;
            fill_px(pm, a.x0, y, a.w, 1, GRID_MAJOR);
        }
        // Frame.
        fill_px(pm, a.x0, a.y0, a.w + 1, 1, AXIS);
        fill_px(pm, a.x0, y1, a.w + 1, 1, AXIS);
        fill_px(pm, a.x0, a.y0, 1, a.h + 1, AXIS);
        fill_px(pm, x1, a.y0, 1, a.h + 1, AXIS);
        // Ticks and tick labels.
        let th = font::text_height(st.scale) as i32;
        let text = color(TEXT);
        for (v, label) in &xa.ticks {
            let x = a.map_x(xa, *v).floor() as i32;
            fill_px(pm, x, y1 + 1, 1, st.tick, AXIS);
            let tw = font::text_width(label, st.scale) as i32;
            let ty = y1 + 1 + st.tick + st.gap;
            font::draw_text(pm, x - tw / 2, ty, label, st.scale, text);
        }
        for (v, label) in &ya.ticks {
            let y = a.map_y(ya, *v).floor() as i32;
            fill_px(pm, a.x0 - st.tick, y, st.tick, 1, AXIS);
            let tw = font::text_width(label, st.scale) as i32;
            let tx = a.x0 - st.tick - st.gap - tw;
            font::draw_text(pm, tx, y - th / 2, label, st.scale, text);
        }
    }

    fn draw_labels(&self, pm: &mut Pixmap, a: Area, st: &Style) {
        let th = font::text_height(st.scale) as i32;
        let text = color(TEXT);
        let center_x = a.x0 + a.w / 2;
        if !self.title.is_empty() {
            // Shrink a long title to fit; centre it over the plot area if
            // possible, else over the image.
            let avail = pm.width() as i32 - 2 * st.pad;
            let mut scale = st.title_scale;
            while scale > 1 && font::text_width(&self.title, scale) as i32 > avail {
                scale -= 1;
            }
            let tw = font::text_width(&self.title, scale) as i32;
            let max_x = (pm.width() as i32 - st.pad - tw).max(st.pad);
            let x = (center_x - tw / 2).clamp(st.pad, max_x);
            let th_title = font::text_height(st.title_scale) as i32;
            let y = st.pad + (th_title - font::text_height(scale) as i32) / 2;
            font::draw_text(pm, x, y, &self.title, scale, text);
        }
        if !self.x_label.is_empty() {
            let tw = font::text_width(&self.x_label, st.scale) as i32;
            let y = a.y0 + a.h + 1 + st.tick + st.gap + th + st.gap;
            font::draw_text(pm, center_x - tw / 2, y, &self.x_label, st.scale, text);
        }
        if !self.y_label.is_empty() {
            let tw = font::text_width(&self.y_label, st.scale) as i32;
            let y = a.y0 + a.h / 2 - tw / 2;
            font::draw_text_vertical(pm, st.pad, y, &self.y_label, st.scale, text);
        }
    }

    fn draw_series(&self, pm: &mut Pixmap, a: Area, pts: &[Vec<Option<(f32, f32)>>], st: &Style) {
        // Clip to the plot area, grown so markers on the frame stay whole.
        let grow = st.marker_radius * 1.3 + 1.0;
        let clip = Rect::from_xywh(
            a.x0 as f32 - grow,
            a.y0 as f32 - grow,
            a.w as f32 + 1.0 + 2.0 * grow,
            a.h as f32 + 1.0 + 2.0 * grow,
        );
        let mut mask = Mask::new(pm.width(), pm.height());
        if let (Some(mask), Some(clip)) = (mask.as_mut(), clip) {
            let path = PathBuilder::from_rect(clip);
            mask.fill_path(&path, FillRule::Winding, false, Transform::identity());
        }
        let stroke = Stroke {
            width: st.line_width,
            line_cap: LineCap::Round,
            line_join: LineJoin::Round,
            ..Stroke::default()
        };
        for (idx, (series, points)) in self.series.iter().zip(pts).enumerate() {
            let paint = paint(series.color);
            let mut line = PathBuilder::new();
            let mut prev: Option<(f32, f32)> = None;
            for p in points {
                match (prev, *p) {
                    (Some(_), Some((x, y))) => line.line_to(x, y),
                    (None, Some((x, y))) => line.move_to(x, y),
                    _ => {}
                }
                prev = *p;
            }
            if let Some(path) = line.finish() {
                pm.stroke_path(&path, &paint, &stroke, Transform::identity(), mask.as_ref());
            }
            let mut markers = PathBuilder::new();
            for &(x, y) in points.iter().flatten() {
                push_marker(&mut markers, idx, x, y, st.marker_radius);
            }
            if let Some(path) = markers.finish() {
                pm.fill_path(
                    &path,
                    &paint,
                    FillRule::Winding,
                    Transform::identity(),
                    mask.as_ref(),
                );
            }
        }
    }

    fn draw_legend(&self, pm: &mut Pixmap, a: Area, pts: &[Vec<Option<(f32, f32)>>], st: &Style) {
        if self.series.is_empty() {
            return;
        }
        let th = font::text_height(st.scale) as i32;
        let inner = 2 * st.gap;
        let row_h = th + st.gap;
        let swatch_w = 20 * st.scale as i32;
        let label_w = self
            .series
            .iter()
            .map(|s| font::text_width(&s.label, st.scale) as i32)
            .max()
            .unwrap_or(0);
        let box_w = inner + swatch_w + 2 * st.gap + label_w + inner;
        let box_h = 2 * inner + self.series.len() as i32 * row_h - st.gap;
        let margin = 2 * st.gap;
        let (l, r) = (a.x0 + margin, a.x0 + a.w - margin - box_w);
        let (t, b) = (a.y0 + margin, a.y0 + a.h - margin - box_h);
        let candidates = [(r, t), (l, t), (r, b), (l, b)];
        let samples = sample_points(pts);
        let (bx, by) = choose_corner(&candidates, box_w, box_h, &samples, st.marker_radius);

        fill_px(pm, bx, by, box_w, box_h, [255, 255, 255]);
        fill_px(pm, bx, by, box_w, 1, LEGEND_BORDER);
        fill_px(pm, bx, by + box_h - 1, box_w, 1, LEGEND_BORDER);
        fill_px(pm, bx, by, 1, box_h, LEGEND_BORDER);
        fill_px(pm, bx + box_w - 1, by, 1, box_h, LEGEND_BORDER);
        let stroke = Stroke {
            width: st.line_width,
            line_cap: LineCap::Round,
            ..Stroke::default()
        };
        for (i, s) in self.series.iter().enumerate() {
            let row_y = by + inner + i as i32 * row_h;
            let cy = row_y as f32 + th as f32 / 2.0;
            let (sx0, sx1) = ((bx + inner) as f32, (bx + inner + swatch_w) as f32);
            let paint = paint(s.color);
            let mut pb = PathBuilder::new();
            pb.move_to(sx0, cy);
            pb.line_to(sx1, cy);
            if let Some(path) = pb.finish() {
                pm.stroke_path(&path, &paint, &stroke, Transform::identity(), None);
            }
            let mut mb = PathBuilder::new();
            push_marker(&mut mb, i, (sx0 + sx1) / 2.0, cy, st.marker_radius);
            if let Some(path) = mb.finish() {
                pm.fill_path(
                    &path,
                    &paint,
                    FillRule::Winding,
                    Transform::identity(),
                    None,
                );
            }
            let tx = bx + inner + swatch_w + 2 * st.gap;
            font::draw_text(pm, tx, row_y, &s.label, st.scale, color(TEXT));
        }
    }
}

/// Converts a mapped coordinate to `f32`, clamped so it stays finite.
fn to_pixel(x: f64, y: f64) -> (f32, f32) {
    const LIMIT: f64 = 1.0e7;
    (x.clamp(-LIMIT, LIMIT) as f32, y.clamp(-LIMIT, LIMIT) as f32)
}

/// Bounding ranges `(x_min, x_max)` and `(y_min, y_max)` of the valid points.
type Bounds = Option<(f64, f64)>;

fn data_bounds(data: &[Vec<Option<(f64, f64)>>]) -> (Bounds, Bounds) {
    let grow = |r: Bounds, v: f64| Some(r.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))));
    let mut xr = None;
    let mut yr = None;
    for &(x, y) in data.iter().flatten().flatten() {
        xr = grow(xr, x);
        yr = grow(yr, y);
    }
    (xr, yr)
}

/// Fraction of the data span added as empty margin on each side of an axis,
/// so markers at the extremes do not sit on the frame.
const AXIS_MARGIN: f64 = 0.05;

/// Number of multiples of `step` in `[lo, hi]` and the first/last multiple
/// index, or `None` if the count is not a sensible small number.
fn tick_span(lo: f64, hi: f64, step: f64) -> Option<(i64, i64)> {
    let (a, b) = ((lo / step).ceil(), (hi / step).floor());
    if !a.is_finite() || !b.is_finite() || b < a || b - a > 1000.0 {
        return None;
    }
    Some((a as i64, b as i64))
}

/// A 1-2-5 tick step (1, 2 or 5 times a power of ten) for `[lo, hi]` giving
/// at least two ticks and as close to `target` ticks as possible.
fn nice_step(lo: f64, hi: f64, target: usize) -> Option<f64> {
    let target = target.max(2);
    let raw = (hi - lo) / target as f64;
    if !raw.is_finite() || raw <= 0.0 {
        return None;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let mut best: Option<(usize, f64)> = None;
    for m in [1.0, 2.0, 5.0, 10.0, 20.0] {
        let step = m * mag;
        let Some((a, b)) = tick_span(lo, hi, step) else {
            continue;
        };
        let count = (b - a + 1) as usize;
        if count < 2 {
            continue;
        }
        let diff = count.abs_diff(target);
        if best.map_or(true, |(d, _)| diff < d) {
            best = Some((diff, step));
        }
    }
    best.map(|(_, step)| step)
}

/// Widens an empty or degenerate range `[lo, hi]` to a positive span.
fn widen(lo: f64, hi: f64) -> (f64, f64) {
    if hi > lo && (hi - lo).is_finite() {
        return (lo, hi);
    }
    if hi > lo {
        // Span overflows: shrink to a representable range (data is clipped).
        let q = f64::MAX / 4.0;
        return (lo.max(-q), hi.min(q));
    }
    let v = lo;
    let pad = if v == 0.0 { 1.0 } else { v.abs() * 0.1 };
    if v + pad > v - pad {
        (v - pad, v + pad)
    } else {
        (v - 1.0, v + 1.0)
    }
}

/// A linear axis covering `[lo, hi]` plus a small margin, with about
/// `target` ticks at multiples of a 1-2-5 step.
fn linear_axis(lo: f64, hi: f64, target: usize) -> Axis {
    let (lo, hi) = widen(lo, hi);
    let m = (hi - lo) * AXIS_MARGIN;
    let (lo, hi) = if (lo - m).is_finite() && (hi + m).is_finite() {
        (lo - m, hi + m)
    } else {
        (lo, hi)
    };
    let sci = use_scientific(lo.abs().max(hi.abs()));
    let spanned = nice_step(lo, hi, target).and_then(|s| Some((s, tick_span(lo, hi, s)?)));
    let ticks = match spanned {
        Some((step, (a, b))) => (a..=b)
            .map(|k| {
                let v = k as f64 * step;
                (v, format_tick(v, step, sci))
            })
            .collect(),
        // Unreasonable range (e.g. near f64::MAX): label just the ends.
        None => vec![
            (lo, format_tick(lo, hi - lo, sci)),
            (hi, format_tick(hi, hi - lo, sci)),
        ],
    };
    Axis {
        min: lo,
        max: hi,
        ticks,
        minor: Vec::new(),
    }
}

/// A log10 axis for data whose log10 lies in `[lo, hi]`.
///
/// Major ticks sit at powers of ten, every `k`-th decade so there are about
/// `target` of them; minor grid lines at 2..9 times each power of ten are
/// added when every decade is ticked. If the data plus margin contain at
/// least two powers of ten the axis ends at the margin, otherwise it is
/// widened to whole decades.
fn log_axis(lo: f64, hi: f64, target: usize) -> Axis {
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else {
        (lo - 1.0, hi + 1.0)
    };
    let m = (hi - lo) * AXIS_MARGIN;
    let (mut lo, mut hi) = (lo - m, hi + m);
    if hi.floor() - lo.ceil() < 1.0 {
        (lo, hi) = (lo.floor(), hi.ceil());
    }
    let (a, b) = (lo.ceil(), hi.floor());
    let k = ((b - a) / (target.max(2) - 1) as f64).ceil().max(1.0);
    let ticks = ((a / k).ceil() as i64..=(b / k).floor() as i64)
        .map(|i| {
            let d = i as f64 * k;
            (d, format_decade(d as i32))
        })
        .collect();
    let mut minor = Vec::new();
    if k == 1.0 {
        let mut d = lo.floor();
        while d < hi {
            minor.extend(
                (2..10)
                    .map(|m| d + f64::from(m).log10())
                    .filter(|v| (lo..=hi).contains(v)),
            );
            d += 1.0;
        }
    }
    Axis {
        min: lo,
        max: hi,
        ticks,
        minor,
    }
}

/// An x axis whose tick labels fit side by side in `plot_w` pixels.
fn fit_x_axis(lo: f64, hi: f64, plot_w: i32, st: &Style) -> Axis {
    let mut target = (plot_w / (50 * st.scale as i32)).clamp(2, 12) as usize;
    loop {
        let axis = linear_axis(lo, hi, target);
        let needed: i32 = axis
            .ticks
            .iter()
            .map(|(_, l)| font::text_width(l, st.scale) as i32 + 4 * st.gap)
            .sum();
        if needed <= plot_w || target <= 2 {
            return axis;
        }
        target -= 1;
    }
}

/// Whether tick labels for values up to `max_abs` use `1.5e7` notation.
fn use_scientific(max_abs: f64) -> bool {
    max_abs >= 1e6 || (max_abs > 0.0 && max_abs < 1e-3)
}

/// Formats tick value `v` on an axis with tick spacing `step`, with just
/// enough digits to tell neighbouring ticks apart.
fn format_tick(v: f64, step: f64, scientific: bool) -> String {
    let v = if v.abs() < step.abs() * 1e-6 { 0.0 } else { v };
    let step_exp = step.abs().log10().floor() as i32;
    if scientific && v != 0.0 {
        let v_exp = v.abs().log10().floor() as i32;
        let digits = (v_exp - step_exp).clamp(0, 15) as usize;
        let s = format!("{v:.digits$e}");
        match s.split_once('e') {
            Some((mant, exp)) if mant.contains('.') => {
                let mant = mant.trim_end_matches('0').trim_end_matches('.');
                format!("{mant}e{exp}")
            }
            _ => s,
        }
    } else {
        let decimals = (-step_exp).clamp(0, 15) as usize;
        format!("{v:.decimals$}")
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
    match idx % 4 {
        0 => pb.push_circle(x, y, r),
        1 => {
            let h = r * 0.9;
            if let Some(rect) = Rect::from_ltrb(x - h, y - h, x + h, y + h) {
                pb.push_rect(rect);
            }
        }
        2 => {
            let q = r * 1.25;
            pb.move_to(x, y - q);
            pb.line_to(x + q * 0.866, y + q * 0.5);
            pb.line_to(x - q * 0.866, y + q * 0.5);
            pb.close();
        }
        _ => {
            let q = r * 1.25;
            pb.move_to(x, y - q);
            pb.line_to(x + q, y);
            pb.line_to(x, y + q);
            pb.line_to(x - q, y);
            pb.close();
        }
    }
}

/// Data points plus a few points along each segment, in pixel coordinates.
fn sample_points(pts: &[Vec<Option<(f32, f32)>>]) -> Vec<(f32, f32)> {
    let mut out = Vec::new();
    for series in pts {
        for pair in series.windows(2) {
            if let [Some(p), Some(q)] = pair {
                out.extend((1..8).map(|i| {
                    let t = i as f32 / 8.0;
                    (p.0 + (q.0 - p.0) * t, p.1 + (q.1 - p.1) * t)
                }));
            }
        }
        out.extend(series.iter().flatten().copied());
    }
    out
}

/// Picks the first candidate top-left corner whose `w` x `h` box (grown by
/// `slack`) covers the fewest sample points.
fn choose_corner(
    candidates: &[(i32, i32)],
    w: i32,
    h: i32,
    samples: &[(f32, f32)],
    slack: f32,
) -> (i32, i32) {
    let count = |&(x, y): &(i32, i32)| {
        let (l, t) = (x as f32 - slack, y as f32 - slack);
        let (r, b) = ((x + w) as f32 + slack, (y + h) as f32 + slack);
        samples
            .iter()
            .filter(|(px, py)| *px >= l && *px <= r && *py >= t && *py <= b)
            .count()
    };
    let mut best = candidates[0];
    let mut best_n = count(&best);
    for c in &candidates[1..] {
        let n = count(c);
        if n < best_n {
            best = *c;
            best_n = n;
        }
    }
    best
}

fn color(rgb: [u8; 3]) -> Color {
    Color::from_rgba8(rgb[0], rgb[1], rgb[2], 255)
}

fn paint(rgb: [u8; 3]) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(color(rgb));
    p.anti_alias = true;
    p
}

/// Fills an axis-aligned pixel rectangle without anti-aliasing.
fn fill_px(pm: &mut Pixmap, x: i32, y: i32, w: i32, h: i32, rgb: [u8; 3]) {
    if w <= 0 || h <= 0 {
        return;
    }
    if let Some(rect) = Rect::from_xywh(x as f32, y as f32, w as f32, h as f32) {
        let mut p = paint(rgb);
        p.anti_alias = false;
        pm.fill_rect(rect, &p, Transform::identity(), None);
    }
}

/// Writes `bytes` to a temporary sibling of `path`, syncs it, then renames it
/// to `path`; the temporary file is removed if any step fails.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .ok_or_else(|| PlotError::InvalidPath(path.to_path_buf()))?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let mut attempt = 0;
    let (tmp, mut file) = loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp_name = format!(
            ".{}.{}-{}-{}.tmp",
            name.to_string_lossy(),
            std::process::id(),
            nanos,
            n
        );
        let tmp = dir.join(tmp_name);
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(f) => break (tmp, f),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempt < 16 => attempt += 1,
            Err(source) => return Err(PlotError::Io { path: tmp, source }),
        }
    };
    let written = file.write_all(bytes).and_then(|()| file.sync_all());
    drop(file);
    let result = match written {
        Ok(()) => fs::rename(&tmp, path).map_err(|source| PlotError::Io {
            path: path.to_path_buf(),
            source,
        }),
        Err(source) => Err(PlotError::Io {
            path: tmp.clone(),
            source,
        }),
    };
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Number of opaque pixels exactly equal to `rgb`.
    fn count_color(pm: &Pixmap, rgb: [u8; 3]) -> usize {
        pm.pixels()
            .iter()
            .filter(|c| c.alpha() == 255 && [c.red(), c.green(), c.blue()] == rgb)
            .count()
    }

    fn sample_plot() -> LinePlot {
        let mut plot = LinePlot::new("Max bits vs m", "matrix size m", "max bit size");
        let ms = [2.0, 4.0, 8.0, 16.0, 32.0];
        plot.add_series(Series::new(
            "None",
            ms.iter().map(|&m| (m, m * m * 3.0)).collect(),
            PALETTE[0],
        ));
        plot.add_series(Series::new(
            "GCD",
            ms.iter().map(|&m| (m, m * 10.0)).collect(),
            PALETTE[1],
        ));
        plot.add_series(Series::new(
            "Turner",
            ms.iter().map(|&m| (m, m * 4.0 + 1.0)).collect(),
            PALETTE[2],
        ));
        plot
    }

    fn labels(a: &Axis) -> Vec<&str> {
        a.ticks.iter().map(|(_, l)| l.as_str()).collect()
    }

    fn assert_ticks_inside(a: &Axis) {
        assert!(a.max > a.min, "{a:?}");
        for (v, _) in &a.ticks {
            assert!(*v >= a.min && *v <= a.max, "{a:?}");
        }
    }

    #[test]
    fn nice_steps_are_1_2_5() {
        let close = |a: Option<f64>, b: f64| (a.unwrap() - b).abs() <= 1e-12 * b.abs();
        assert!(close(nice_step(0.0, 10.0, 5), 2.0));
        assert!(close(nice_step(0.0, 10.0, 2), 10.0));
        assert!(close(nice_step(0.0, 10.0, 3), 5.0));
        assert!(close(nice_step(0.0, 1.0, 10), 0.1));
        assert!(close(nice_step(0.0, 0.011, 5), 0.002));
        assert!(close(nice_step(0.0, 2100.0, 5), 500.0));
        assert!(close(nice_step(3.0, 4.0, 2), 1.0));
        assert!(close(nice_step(3.0, 4.0, 3), 0.5));
        assert_eq!(nice_step(1.0, 1.0, 5), None);
        assert_eq!(nice_step(0.0, f64::NAN, 5), None);
    }

    #[test]
    fn linear_axis_ticks() {
        let a = linear_axis(0.0, 9.3, 5);
        assert!(a.min < 0.0 && a.max > 9.3);
        assert_eq!(labels(&a), ["0", "2", "4", "6", "8"]);
        assert_ticks_inside(&a);

        let a = linear_axis(-0.3, 0.25, 5);
        assert_eq!(labels(&a), ["-0.3", "-0.2", "-0.1", "0.0", "0.1", "0.2"]);

        let a = linear_axis(0.0, 3.0e7, 4);
        assert_eq!(labels(&a), ["0", "1e7", "2e7", "3e7"]);
    }

    #[test]
    fn degenerate_ranges_get_a_span() {
        for v in [0.0, 5.0, -3.0, 1e-300, 1e300] {
            let a = linear_axis(v, v, 5);
            assert!(a.min < v && v < a.max, "{v}: {a:?}");
            assert!(a.ticks.len() >= 2);
            assert_ticks_inside(&a);
        }
        let a = linear_axis(-f64::MAX, f64::MAX, 5);
        assert!(a.max > a.min && (a.max - a.min).is_finite());
        assert_ticks_inside(&a);
        let a = log_axis(2.0, 2.0, 5);
        assert!(a.min < 2.0 && a.max > 2.0);
        assert_ticks_inside(&a);
    }

    #[test]
    fn tick_formatting() {
        assert_eq!(format_tick(1.5e6, 5e5, true), "1.5e6");
        assert_eq!(format_tick(2.0e6, 5e5, true), "2e6");
        assert_eq!(format_tick(0.0, 5e5, true), "0");
        assert_eq!(format_tick(2.5, 0.5, false), "2.5");
        assert_eq!(format_tick(1e-17, 0.1, false), "0.0");
        assert_eq!(format_tick(300.0, 100.0, false), "300");
        assert_eq!(format_decade(0), "1");
        assert_eq!(format_decade(3), "1000");
        assert_eq!(format_decade(-2), "0.01");
        assert_eq!(format_decade(9), "1e9");
        assert_eq!(format_decade(-7), "1e-7");
    }

    #[test]
    fn log_axis_uses_decades() {
        let a = log_axis(0.0, 5.3, 10);
        assert!(a.min < 0.0 && a.max > 5.3);
        assert_eq!(labels(&a), ["1", "10", "100", "1000", "10000", "100000"]);
        assert!(!a.minor.is_empty());
        assert!(a.minor.iter().all(|v| *v >= a.min && *v <= a.max));
        assert_ticks_inside(&a);
        // Less than a decade of data: widened to whole decades.
        let a = log_axis(1.3, 1.9, 5);
        assert_eq!((a.min, a.max), (1.0, 2.0));
        assert_eq!(labels(&a), ["10", "100"]);
        let wide = log_axis(-100.0, 100.0, 5);
        assert!((2..=5).contains(&wide.ticks.len()), "{:?}", wide.ticks);
        assert!(wide.minor.is_empty());
        assert_ticks_inside(&wide);
    }

    #[test]
    fn render_draws_every_series_colour() {
        let plot = sample_plot();
        let pm = plot.render().unwrap();
        assert_eq!((pm.width(), pm.height()), (800, 600));
        for s in &plot.series {
            let n = count_color(&pm, s.color);
            assert!(n > 50, "series {} has only {n} pixels", s.label);
        }
        assert!(count_color(&pm, [255, 255, 255]) > 800 * 600 / 2);
        assert!(count_color(&pm, GRID_MAJOR) > 100);
        assert!(count_color(&pm, AXIS) > 1000);
        assert!(count_color(&pm, TEXT) > 100);
    }

    #[test]
    fn render_small_plot() {
        let pm = sample_plot().with_size(200, 150).render().unwrap();
        for s in &sample_plot().series {
            assert!(count_color(&pm, s.color) > 5);
        }
    }

    #[test]
    fn log_y_with_positive_data() {
        let mut plot = sample_plot().with_log_y(true);
        plot.series[0].points.push((64.0, 0.0)); // skipped on a log axis
        plot.series[1].points.push((64.0, -5.0)); // skipped on a log axis
        let pm = plot.render().unwrap();
        for s in &plot.series {
            assert!(count_color(&pm, s.color) > 50);
        }
        assert!(count_color(&pm, GRID_MINOR) > 100);
    }

    #[test]
    fn log_y_without_positive_data() {
        let mut plot = LinePlot::new("t", "x", "y").with_log_y(true);
        plot.add_series(Series::new(
            "neg",
            vec![(1.0, -1.0), (2.0, 0.0)],
            PALETTE[3],
        ));
        let pm = plot.render().unwrap();
        assert!(count_color(&pm, PALETTE[3]) > 0); // legend swatch only
    }

    #[test]
    fn empty_plot_renders_axes() {
        let pm = LinePlot::new("", "", "").render().unwrap();
        assert!(count_color(&pm, AXIS) > 1000);
        assert!(count_color(&pm, TEXT) > 0);
        let pm = LinePlot::new("Empty", "x", "y").render().unwrap();
        assert!(count_color(&pm, AXIS) > 1000);
    }

    #[test]
    fn edge_case_data() {
        let cases: Vec<Vec<(f64, f64)>> = vec![
            vec![],
            vec![(3.0, 7.0)],
            vec![(1.0, 5.0), (2.0, 5.0), (3.0, 5.0)],
            vec![(4.0, 1.0), (4.0, 2.0)],
            vec![
                (f64::NAN, 1.0),
                (1.0, f64::INFINITY),
                (2.0, 2.0),
                (3.0, f64::NAN),
                (4.0, 3.0),
            ],
            vec![(f64::NAN, f64::NAN)],
            vec![(-1e300, 1e300), (1e300, -1e300)],
            vec![(0.0, 1e-300), (1e-300, 0.0)],
        ];
        for (i, pts) in cases.into_iter().enumerate() {
            let valid = pts.iter().any(|(x, y)| x.is_finite() && y.is_finite());
            for log_y in [false, true] {
                let mut plot = LinePlot::new("edge", "x", "y").with_log_y(log_y);
                plot.add_series(Series::new("s", pts.clone(), [200, 0, 200]));
                let pm = plot.render().unwrap_or_else(|e| panic!("case {i}: {e}"));
                if valid && !log_y {
                    // Legend plus at least one on-plot marker.
                    assert!(count_color(&pm, [200, 0, 200]) > 20, "case {i}");
                }
            }
        }
    }

    #[test]
    fn single_point_draws_marker() {
        let mut plot = LinePlot::new("one", "x", "y");
        plot.add_series(Series::new("", vec![(1.0, 1.0)], [10, 200, 10]));
        let with_point = count_color(&plot.render().unwrap(), [10, 200, 10]);
        plot.series[0].points.clear();
        let legend_only = count_color(&plot.render().unwrap(), [10, 200, 10]);
        assert!(with_point > legend_only);
    }

    #[test]
    fn invalid_sizes_are_rejected() {
        for (w, h) in [(0, 100), (100, 0), (10, 10), (20000, 100)] {
            let err = LinePlot::default().with_size(w, h).render().unwrap_err();
            assert!(
                matches!(err, PlotError::InvalidSize { width, height } if (width, height) == (w, h))
            );
        }
        // Minimal size with long labels still works or fails cleanly.
        let mut plot = LinePlot::new("a very long title indeed", "x label", "y label");
        plot.width = LinePlot::MIN_SIZE;
        plot.height = LinePlot::MIN_SIZE;
        let _ = plot.render();
    }

    #[test]
    fn legend_avoids_data() {
        let candidates = [(100, 0), (0, 0), (100, 100), (0, 100)];
        let samples = vec![(120.0, 10.0), (5.0, 5.0), (110.0, 110.0)];
        assert_eq!(choose_corner(&candidates, 50, 50, &samples, 0.0), (0, 100));
        assert_eq!(choose_corner(&candidates, 50, 50, &[], 0.0), (100, 0));
    }

    #[test]
    fn save_png_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.png");
        let plot = sample_plot().with_size(320, 240);
        plot.save_png(&path).unwrap();
        // Overwriting an existing file works too.
        plot.save_png(&path).unwrap();
        let bytes = fs::read(&path).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        let back = Pixmap::load_png(&path).unwrap();
        assert_eq!((back.width(), back.height()), (320, 240));
        assert_eq!(back.data(), plot.render().unwrap().data());
        let names: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, [std::ffi::OsString::from("plot.png")]);
    }

    #[test]
    fn save_png_in_std_temp_dir() {
        let unique = format!(
            "trimorph-plot-test-{}-{}",
            std::process::id(),
            SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .unwrap()
                .as_nanos()
        );
        let dir = std::env::temp_dir().join(unique);
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("empty.png");
        let result = LinePlot::new("empty", "x", "y").save_png(&path);
        let loaded = Pixmap::load_png(&path).map(|p| (p.width(), p.height()));
        let _ = fs::remove_dir_all(&dir);
        result.unwrap();
        assert_eq!(loaded.unwrap(), (800, 600));
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

        let bad = sample_plot().with_size(1, 1);
        let path = dir.path().join("bad.png");
        assert!(matches!(
            bad.save_png(&path),
            Err(PlotError::InvalidSize { .. })
        ));
        assert!(!path.exists());
    }
}
