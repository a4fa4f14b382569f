//! Pictures of spline deformations: the deformed reference mesh phi(T), the Bezier control
//! net, the C1 quadrilateral conditions and the anchors / derived points of the last edit,
//! optionally drawn over a background image (for example the microscope frame being matched).
//!
//! # Coordinate convention
//!
//! Mesh coordinates are pixel-like: x to the right and **y down**, like image rows.
//!
//! * With a background image the output has the image's size and mesh coordinate `(x, y)` is
//!   drawn at the centre of pixel `(x, y)` (scale 1, no offset; the requested width and height
//!   are ignored).
//! * Without one, the union of the deformed mesh, the control points (and the reference mesh
//!   when shown) is fitted into `width x height` with a 5% margin on each side, preserving the
//!   aspect ratio, still y down, on a white background.
//!
//! Mesh edges are sampled exactly: the edge between local vertices `a`, `b` of a triangle `t`
//! is evaluated on the patch of `t` at barycentric coordinates `(1 - s) e_a + s e_b`, so no
//! point location is needed. Lines are about 1 pixel wide (border edges 2 pixels) so large
//! meshes stay readable. A small legend in the corner covering the least of the drawing lists
//! the layers shown.
//!
//! Landmarks ([`RenderOptions::landmarks`], `trimorph render --landmarks`) are drawn last:
//! each source `s_i` as an orange cross, its image `phi(s_i)` as a green dot and the target
//! `t_i` as a magenta ring, with a teal line from `phi(s_i)` to `t_i` (its length is the
//! residual of the fit). A source outside the mesh has no image: only its cross and ring.

use std::io;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use tiny_skia::{
    Color, ColorU8, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, PremultipliedColorU8,
    Rect, Stroke, Transform,
};

use super::font;
use crate::edit::LastEdit;
use crate::fit::landmarks::Landmark;
use crate::spline::{ControlPoint, Spline};

/// Smallest accepted output width or height in pixels.
pub const MIN_SIZE: u32 = 16;
/// Largest accepted output width or height in pixels.
pub const MAX_SIZE: u32 = crate::io::image_use::MAX_DRAWN_SIDE;
/// Fraction of the output size left empty on each side when fitting (no background).
const MARGIN: f64 = 0.05;

pub(super) type Rgba = [u8; 4];
const MESH: Rgba = [25, 25, 25, 255];
const HALO: Rgba = [255, 255, 255, 120];
const REFERENCE: Rgba = [150, 170, 215, 255];
const NET: Rgba = [140, 140, 140, 255];
const QUAD: Rgba = [255, 150, 0, 70];
const POINT: Rgba = [110, 110, 110, 255];
const ANCHOR: Rgba = [220, 20, 20, 255];
const DERIVED: Rgba = [30, 90, 230, 255];
const TEXT: Rgba = [25, 25, 25, 255];
const LEGEND_BG: Rgba = [255, 255, 255, 210];
const LEGEND_BORDER: Rgba = [170, 170, 170, 255];
/// Landmark source `s_i` (a cross).
pub const LM_SOURCE: Rgba = [255, 130, 0, 255];
/// Landmark image `phi(s_i)` (a dot).
pub const LM_MAPPED: Rgba = [20, 170, 60, 255];
/// Landmark target `t_i` (a ring).
pub const LM_TARGET: Rgba = [230, 0, 200, 255];
/// The residual line from `phi(s_i)` to `t_i`.
pub const LM_RESIDUAL: Rgba = [0, 150, 190, 255];

/// What to draw and how large (see the module docs for the coordinate convention).
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Output width in pixels (ignored with a background image).
    pub width: u32,
    /// Output height in pixels (ignored with a background image).
    pub height: u32,
    /// Draw the deformed mesh phi(T) (border edges thicker).
    pub show_mesh: bool,
    /// Draw the Bezier control net (thin grey lines between adjacent control points).
    pub show_net: bool,
    /// Draw each C1 quadrilateral condition as a translucent polygon `l -> p -> r -> n`.
    pub show_constraints: bool,
    /// Draw the control points, and the anchors / derived points of the last edit.
    pub show_points: bool,
    /// Draw the undeformed reference mesh T, faintly.
    pub show_reference: bool,
    /// Line segments per mesh edge (each edge is evaluated at this many plus one points).
    pub samples_per_edge: usize,
    /// Landmarks to draw (source, `phi(source)`, target and the residual line; see the
    /// module docs); none by default.
    pub landmarks: Vec<Landmark>,
}

impl Default for RenderOptions {
    /// 800x600, mesh and points on, net, constraints and reference off, 16 samples per edge.
    fn default() -> Self {
        RenderOptions {
            width: 800,
            height: 600,
            show_mesh: true,
            show_net: false,
            show_constraints: false,
            show_points: true,
            show_reference: false,
            samples_per_edge: 16,
            landmarks: Vec::new(),
        }
    }
}

/// The layers of a picture (`--show`): which of the deformed mesh, the control net, the C1
/// conditions, the control points and the reference mesh are drawn. Parsed from a comma
/// list of [`RenderOptions::LAYERS`] (case-insensitive, surrounding spaces ignored); an
/// unknown word, or an empty list, is a [`RenderError::UnknownLayer`] naming it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Layers {
    /// [`RenderOptions::show_mesh`].
    pub mesh: bool,
    /// [`RenderOptions::show_net`].
    pub net: bool,
    /// [`RenderOptions::show_constraints`].
    pub constraints: bool,
    /// [`RenderOptions::show_points`].
    pub points: bool,
    /// [`RenderOptions::show_reference`].
    pub reference: bool,
}

impl std::str::FromStr for Layers {
    type Err = RenderError;
    fn from_str(list: &str) -> Result<Layers, RenderError> {
        let mut l = Layers::default();
        let mut any = false;
        for word in list.split(',').map(str::trim).filter(|w| !w.is_empty()) {
            match word.to_ascii_lowercase().as_str() {
                "mesh" => l.mesh = true,
                "net" => l.net = true,
                "constraints" => l.constraints = true,
                "points" => l.points = true,
                "reference" => l.reference = true,
                "all" => {
                    (l.mesh, l.net, l.constraints, l.points, l.reference) =
                        (true, true, true, true, true)
                }
                _ => return Err(RenderError::UnknownLayer(word.to_string())),
            }
            any = true;
        }
        if !any {
            return Err(RenderError::UnknownLayer(String::new()));
        }
        Ok(l)
    }
}

impl RenderOptions {
    /// Layer names accepted by [`parse_show`](Self::parse_show) and by [`Layers`].
    pub const LAYERS: [&'static str; 6] =
        ["mesh", "net", "constraints", "points", "reference", "all"];

    /// Default options with exactly the layers `layers` switched on.
    pub fn with_layers(layers: Layers) -> RenderOptions {
        RenderOptions {
            show_mesh: layers.mesh,
            show_net: layers.net,
            show_constraints: layers.constraints,
            show_points: layers.points,
            show_reference: layers.reference,
            ..RenderOptions::default()
        }
    }

    /// Default options with exactly the layers in the comma-separated `list` switched on:
    /// `mesh`, `net`, `constraints`, `points`, `reference` or `all` (case-insensitive,
    /// surrounding spaces ignored). An unknown word, or an empty list, is an error naming it.
    pub fn parse_show(list: &str) -> Result<RenderOptions, RenderError> {
        list.parse().map(RenderOptions::with_layers)
    }
}

/// Errors of loading a background, rendering or saving a picture.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The background image could not be read or decoded.
    #[error("cannot read image {}: {message}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A layer name given to [`RenderOptions::parse_show`] is unknown (empty: no layer given).
    #[error("unknown layer '{0}'; choose from mesh, net, constraints, points, reference, all")]
    UnknownLayer(String),
    /// The output size is outside [`MIN_SIZE`]..=[`MAX_SIZE`].
    #[error(
        "invalid picture size {width}x{height} (each side must be {MIN_SIZE} to {MAX_SIZE} pixels)"
    )]
    Size {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// Writing the (temporary) file or renaming it failed.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The destination file.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// PNG encoding failed.
    #[error("PNG encoding failed: {0}")]
    Encode(String),
    /// A view name given to [`crate::render::model::View`]'s `from_str` is unknown.
    #[error("unknown view '{0}'; choose top or oblique")]
    UnknownView(String),
    /// The model, its deformed positions or the deformation cannot be drawn together (for
    /// example a length mismatch, or an oblique view of a deformation without z layers).
    #[error("cannot draw the model: {0}")]
    Model(String),
}

/// Reads a PNG, JPEG, TIFF or PNM image (8- or 16-bit gray, gray + alpha, RGB or RGBA; 16-bit
/// samples are scaled to 8 bits) into an RGBA pixmap, for use as a background. The format is
/// detected from the content, not the file name.
pub fn load_background(path: &Path) -> Result<Pixmap, RenderError> {
    let err = |message: String| RenderError::Image { path: path.to_path_buf(), message };
    let mut reader = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| err(e.to_string()))?;
    // Refuse oversized images from their header, before the decoder allocates.
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_SIZE);
    limits.max_image_height = Some(MAX_SIZE);
    reader.limits(limits);
    if reader.format().is_none() {
        return Err(err("unrecognised image format (expected PNG, JPEG, TIFF or PNM)".into()));
    }
    let limit_err = |e: image::ImageError| match e {
        image::ImageError::Limits(_) => err(format!(
            "the image is larger than {MAX_SIZE} x {MAX_SIZE} pixels, the largest background \
             (it is not decoded); scale it down"
        )),
        e => err(e.to_string()),
    };
    let decoder = reader.into_decoder().map_err(limit_err)?;
    // Decoded, its 8-bit RGBA copy and the pixmap.
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    let need =
        image::ImageDecoder::total_bytes(&decoder).saturating_add(2 * 4 * w as u64 * h as u64);
    crate::memory::check(need, || format!("a {w} x {h} background"))
        .map_err(|e| err(e.to_string()))?;
    let img = image::DynamicImage::from_decoder(decoder).map_err(limit_err)?.to_rgba8();
    let (width, height) = img.dimensions();
    if !(1..=MAX_SIZE).contains(&width) || !(1..=MAX_SIZE).contains(&height) {
        return Err(RenderError::Size { width, height });
    }
    let mut pm = Pixmap::new(width, height).ok_or(RenderError::Size { width, height })?;
    for (dst, src) in pm.pixels_mut().iter_mut().zip(img.pixels()) {
        let [r, g, b, a] = src.0;
        *dst = ColorU8::from_rgba(r, g, b, a).premultiply();
    }
    Ok(pm)
}

/// Renders the deformation `spline` (see the module docs). `last` marks the anchors (red open
/// circles) and derived points (blue dots) of the last edit when points are shown; indices out
/// of range are ignored. With `background` the output has its size and shows it through.
pub fn render(
    spline: &Spline,
    last: Option<&LastEdit>,
    background: Option<&Pixmap>,
    opts: &RenderOptions,
) -> Result<Pixmap, RenderError> {
    let mesh = spline.mesh();
    let n = opts.samples_per_edge.max(1);
    let curves: Vec<(Vec<[f64; 2]>, bool)> = (0..mesh.num_edges())
        .into_par_iter()
        .map(|e| (edge_curve(spline, e, n), mesh.is_border_edge(e)))
        .collect();
    let points: Vec<[f64; 2]> = (0..spline.num_points()).map(|i| spline.point_f64(i)).collect();
    let srcs: Vec<[f64; 2]> = opts.landmarks.iter().map(|l| l.src).collect();
    let mapped = crate::warp::forward(spline, &srcs);

    let (mut pm, view) = match background {
        Some(bg) => (bg.clone(), View::PIXELS),
        None => {
            let (width, height) = (opts.width, opts.height);
            let pm = blank(width, height)?;
            let reference = mesh.vertices().iter().filter(|_| opts.show_reference);
            let lms = opts.landmarks.iter().flat_map(|l| [l.src, l.dst]);
            let all = curves.iter().flat_map(|c| &c.0).chain(&points).chain(reference);
            let all = all.copied().chain(lms).chain(mapped.iter().flatten().copied());
            (pm, View::fit(all, width, height))
        }
    };
    let mut legend: Vec<(String, Swatch)> = Vec::new();

    if opts.show_reference {
        let mut pb = PathBuilder::new();
        for e in mesh.edges() {
            polyline(&mut pb, &view, &[mesh.vertex(e.v[0]), mesh.vertex(e.v[1])]);
        }
        stroke(&mut pm, pb, REFERENCE, 0.8);
        legend.push(("reference mesh".into(), Swatch::Line(REFERENCE, 0.8)));
    }
    if opts.show_constraints {
        for q in spline.quads() {
            let mut pb = PathBuilder::new();
            polyline(&mut pb, &view, &[q.l, q.p, q.r, q.n].map(|i| points[i]));
            pb.close();
            fill(&mut pm, pb, QUAD);
        }
        legend.push(("C1 conditions".into(), Swatch::Fill(QUAD)));
    }
    if opts.show_net {
        let mut pb = PathBuilder::new();
        for (a, adj) in spline.layout().control_net().iter().enumerate() {
            for &b in adj.iter().filter(|&&b| b > a) {
                polyline(&mut pb, &view, &[points[a], points[b]]);
            }
        }
        stroke(&mut pm, pb, NET, 0.6);
        legend.push(("control net".into(), Swatch::Line(NET, 0.6)));
    }
    if opts.show_mesh {
        for (border, width) in [(false, 1.0), (true, 2.0)] {
            let mut pb = PathBuilder::new();
            for (c, _) in curves.iter().filter(|c| c.1 == border) {
                polyline(&mut pb, &view, c);
            }
            if background.is_some() {
                // A light halo keeps the lines visible on dark images.
                stroke(&mut pm, pb.clone(), HALO, width + 1.5);
            }
            stroke(&mut pm, pb, MESH, width);
        }
        legend.push(("deformed mesh".into(), Swatch::Line(MESH, 1.0)));
    }
    if opts.show_points {
        let centres: Vec<(f32, f32)> = points.iter().filter_map(|&p| view.map(p)).collect();
        dots(&mut pm, &centres, 1.2, POINT);
        legend.push(("control points".into(), Swatch::Dot(POINT, 1.5)));
        if let Some(last) = last {
            let at = |idx: &[ControlPoint]| -> Vec<(f32, f32)> {
                idx.iter()
                    .filter_map(|i| points.get(i.index()).and_then(|&p| view.map(p)))
                    .collect()
            };
            dots(&mut pm, &at(&last.derived), 2.5, DERIVED);
            let mut pb = PathBuilder::new();
            for (x, y) in at(&last.anchors) {
                pb.push_circle(x, y, 5.0);
            }
            stroke(&mut pm, pb, ANCHOR, 1.5);
            let (na, nd) = (last.anchors.len(), last.derived.len());
            legend.push((format!("anchors ({na})"), Swatch::Ring(ANCHOR, 4.0)));
            legend.push((format!("derived ({nd})"), Swatch::Dot(DERIVED, 2.5)));
        }
    }
    if !opts.landmarks.is_empty() {
        draw_landmarks(&mut pm, &view, &opts.landmarks, &mapped, &mut legend);
    }
    let samples: Vec<(f32, f32)> =
        (curves.iter().flat_map(|c| &c.0).chain(&points)).filter_map(|&p| view.map(p)).collect();
    draw_legend(&mut pm, &legend, &samples);
    Ok(pm)
}

/// Draws the landmarks (see the module docs): `mapped[i]` is `phi(s_i)`, `None` outside the
/// mesh. Adds their legend entries.
fn draw_landmarks(
    pm: &mut Pixmap,
    view: &View,
    lms: &[Landmark],
    mapped: &[Option<[f64; 2]>],
    legend: &mut Vec<(String, Swatch)>,
) {
    let mut lines = PathBuilder::new();
    for (l, m) in lms.iter().zip(mapped) {
        if let Some(m) = m {
            polyline(&mut lines, view, &[*m, l.dst]);
        }
    }
    stroke(pm, lines, LM_RESIDUAL, 1.5);
    let (mut cross, mut rings) = (PathBuilder::new(), PathBuilder::new());
    for l in lms {
        if let Some((x, y)) = view.map(l.src) {
            let r = 4.0;
            cross.move_to(x - r, y - r);
            cross.line_to(x + r, y + r);
            cross.move_to(x - r, y + r);
            cross.line_to(x + r, y - r);
        }
        if let Some((x, y)) = view.map(l.dst) {
            rings.push_circle(x, y, 5.0);
        }
    }
    stroke(pm, cross, LM_SOURCE, 1.8);
    stroke(pm, rings, LM_TARGET, 1.8);
    let at: Vec<(f32, f32)> = mapped.iter().flatten().filter_map(|&p| view.map(p)).collect();
    dots(pm, &at, 2.8, LM_MAPPED);
    let n = lms.len();
    legend.push((format!("landmark sources ({n})"), Swatch::Cross(LM_SOURCE, 4.0)));
    legend.push(("φ(source)".into(), Swatch::Dot(LM_MAPPED, 2.8)));
    legend.push(("targets".into(), Swatch::Ring(LM_TARGET, 4.0)));
    legend.push(("residual φ(s) → t".into(), Swatch::Line(LM_RESIDUAL, 1.5)));
}

/// A white `width x height` canvas; [`RenderError::Size`] unless both are in
/// [`MIN_SIZE`]..=[`MAX_SIZE`].
pub(super) fn blank(width: u32, height: u32) -> Result<Pixmap, RenderError> {
    let sizes = MIN_SIZE..=MAX_SIZE;
    if !sizes.contains(&width) || !sizes.contains(&height) {
        return Err(RenderError::Size { width, height });
    }
    let mut pm = Pixmap::new(width, height).ok_or(RenderError::Size { width, height })?;
    pm.fill(Color::WHITE);
    Ok(pm)
}

/// Writes `pixmap` as a PNG file at `path` with [`crate::io::write_atomic`]: encoded, written
/// and synced to a uniquely named temporary file in the same directory, then renamed over
/// `path`, so `path` never holds a half-written file (FIFOs and devices are written in
/// place, symbolic links and permissions are kept). On failure the temporary file is removed.
pub fn save_png(pixmap: &Pixmap, path: &Path) -> Result<(), RenderError> {
    let bytes = pixmap.encode_png().map_err(|e| RenderError::Encode(e.to_string()))?;
    if path.file_name().is_none() {
        let source = io::Error::new(io::ErrorKind::InvalidInput, "no file name");
        return Err(RenderError::Io { path: path.to_path_buf(), source });
    }
    crate::io::write_atomic(path, &bytes).map_err(|e| match e {
        crate::io::IoError::Write { path, source } | crate::io::IoError::Read { path, source } => {
            RenderError::Io { path, source }
        }
    })
}

/// phi along mesh edge `e` at `n + 1` equally spaced parameters, evaluated exactly on the
/// patch of one of its triangles.
pub(super) fn edge_curve(spline: &Spline, e: usize, n: usize) -> Vec<[f64; 2]> {
    let mesh = spline.mesh();
    let edge = mesh.edges()[e];
    let t = edge.tris[0].or(edge.tris[1]).expect("an edge has a triangle");
    let tri = mesh.triangle(t);
    let local = |v: usize| tri.iter().position(|&w| w == v).expect("edge vertex in triangle");
    let (a, b) = (local(edge.v[0]), local(edge.v[1]));
    let cache = spline.eval_cache();
    (0..=n)
        .map(|i| {
            let s = i as f64 / n as f64;
            let mut bary = [0.0; 3];
            bary[a] = 1.0 - s;
            bary[b] = s;
            cache.value(t, bary)
        })
        .collect()
}

/// Mesh coordinates to canvas coordinates: `(ox + scale x, oy + scale y)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct View {
    scale: f64,
    ox: f64,
    oy: f64,
}

impl View {
    /// Background-image coordinates: mesh point `(x, y)` at the centre of pixel `(x, y)`.
    pub(super) const PIXELS: View = View { scale: 1.0, ox: 0.5, oy: 0.5 };

    /// Fits the finite `points` into `width x height` with [`MARGIN`], centred.
    pub(super) fn fit(points: impl Iterator<Item = [f64; 2]>, width: u32, height: u32) -> View {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points.filter(|p| p[0].is_finite() && p[1].is_finite()) {
            for a in 0..2 {
                (lo[a], hi[a]) = (lo[a].min(p[a]), hi[a].max(p[a]));
            }
        }
        let size = [f64::from(width), f64::from(height)];
        if lo[0] > hi[0] {
            return View { scale: 1.0, ox: 0.0, oy: 0.0 };
        }
        let fit = |a: usize| {
            let span = hi[a] - lo[a];
            if span > 0.0 {
                size[a] * (1.0 - 2.0 * MARGIN) / span
            } else {
                f64::INFINITY
            }
        };
        let scale = fit(0).min(fit(1));
        let scale = if scale.is_finite() && scale > 0.0 { scale } else { 1.0 };
        let off = |a: usize| size[a] / 2.0 - scale * (lo[a] + hi[a]) / 2.0;
        View { scale, ox: off(0), oy: off(1) }
    }

    /// Canvas position of mesh point `p` (clamped far off-canvas), `None` if not finite.
    pub(super) fn map(&self, p: [f64; 2]) -> Option<(f32, f32)> {
        let (x, y) = (self.ox + self.scale * p[0], self.oy + self.scale * p[1]);
        let ok = x.is_finite() && y.is_finite();
        ok.then(|| (x.clamp(-1e7, 1e7) as f32, y.clamp(-1e7, 1e7) as f32))
    }
}

/// Appends the polyline through `pts` (broken at non-finite points) to `pb`.
pub(super) fn polyline(pb: &mut PathBuilder, view: &View, pts: &[[f64; 2]]) {
    let mut open = false;
    for p in pts {
        let m = view.map(*p);
        match (m, open) {
            (Some((x, y)), true) => pb.line_to(x, y),
            (Some((x, y)), false) => pb.move_to(x, y),
            (None, _) => {}
        }
        open = m.is_some();
    }
}

pub(super) fn paint(rgba: Rgba) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(rgba[0], rgba[1], rgba[2], rgba[3]);
    p.anti_alias = true;
    p
}

/// Strokes `pb` anti-aliased with round caps and joins.
pub(super) fn stroke(pm: &mut Pixmap, pb: PathBuilder, rgba: Rgba, width: f32) {
    let Some(path) = pb.finish() else { return };
    let stroke =
        Stroke { width, line_cap: LineCap::Round, line_join: LineJoin::Round, ..Stroke::default() };
    pm.stroke_path(&path, &paint(rgba), &stroke, Transform::identity(), None);
}

/// Fills `pb` anti-aliased (non-zero winding).
fn fill(pm: &mut Pixmap, pb: PathBuilder, rgba: Rgba) {
    let Some(path) = pb.finish() else { return };
    pm.fill_path(&path, &paint(rgba), FillRule::Winding, Transform::identity(), None);
}

/// Fills anti-aliased discs of radius `r` around the canvas points `centres` (coverage from
/// the distance of each pixel centre; much faster than a path for many tiny dots).
pub(super) fn dots(pm: &mut Pixmap, centres: &[(f32, f32)], r: f32, rgba: Rgba) {
    let (w, h) = (pm.width() as i64, pm.height() as i64);
    let alpha = f32::from(rgba[3]) / 255.0;
    let pixels = pm.pixels_mut();
    for &(cx, cy) in centres {
        let span = |c: f32, n: i64| {
            (((c - r - 1.0).floor() as i64).max(0), ((c + r + 1.0).ceil() as i64).min(n))
        };
        let ((x0, x1), (y0, y1)) = (span(cx, w), span(cy, h));
        for y in y0..y1 {
            for x in x0..x1 {
                let d = (x as f32 + 0.5 - cx).hypot(y as f32 + 0.5 - cy);
                let cov = (r + 0.5 - d).clamp(0.0, 1.0) * alpha;
                if cov <= 0.0 {
                    continue;
                }
                let px = &mut pixels[(y * w + x) as usize];
                let mix = |src: u8, dst: u8| {
                    (f32::from(src) * cov + f32::from(dst) * (1.0 - cov)).round() as u8
                };
                let a = mix(255, px.alpha());
                let (r, g, b) =
                    (mix(rgba[0], px.red()), mix(rgba[1], px.green()), mix(rgba[2], px.blue()));
                *px = PremultipliedColorU8::from_rgba(r.min(a), g.min(a), b.min(a), a)
                    .expect("premultiplied: channels at most alpha");
            }
        }
    }
}

/// How a legend entry is pictured.
#[derive(Clone, Copy, Debug)]
pub(super) enum Swatch {
    Line(Rgba, f32),
    Fill(Rgba),
    Dot(Rgba, f32),
    Ring(Rgba, f32),
    Cross(Rgba, f32),
}

/// Draws the legend in the image corner covering the fewest `samples` (canvas points).
pub(super) fn draw_legend(pm: &mut Pixmap, entries: &[(String, Swatch)], samples: &[(f32, f32)]) {
    let (w, h) = (pm.width() as i32, pm.height() as i32);
    let scale = (w.min(h) / 500).clamp(1, 4) as u32;
    let s = scale as i32;
    let (th, pad, swatch_w) = (font::text_height(scale) as i32, 3 * s, 12 * s);
    let Some(label_w) = entries.iter().map(|e| font::text_width(&e.0, scale) as i32).max() else {
        return;
    };
    let row_h = th + pad;
    let box_w = 3 * pad + swatch_w + label_w + pad;
    let box_h = 2 * pad + entries.len() as i32 * row_h - pad;
    let m = 2 * pad;
    if box_w + 2 * m > w || box_h + 2 * m > h {
        return; // too small a picture for a legend
    }
    let corners = [(m, m), (w - m - box_w, m), (m, h - m - box_h), (w - m - box_w, h - m - box_h)];
    let covered = |&&(x, y): &&(i32, i32)| {
        let inside = |p: &&(f32, f32)| {
            p.0 >= x as f32
                && p.0 <= (x + box_w) as f32
                && p.1 >= y as f32
                && p.1 <= (y + box_h) as f32
        };
        samples.iter().filter(inside).count()
    };
    let (bx, by) = *corners.iter().min_by_key(covered).expect("four corners");
    let rect = |x: i32, y: i32, rw: i32, rh: i32| {
        Rect::from_xywh(x as f32, y as f32, rw as f32, rh as f32).map(|r| {
            let mut pb = PathBuilder::new();
            pb.push_rect(r);
            pb
        })
    };
    if let Some(r) = rect(bx, by, box_w, box_h) {
        fill(pm, r, LEGEND_BG);
    }
    if let Some(r) = rect(bx, by, box_w, box_h) {
        stroke(pm, r, LEGEND_BORDER, 1.0);
    }
    for (i, (label, swatch)) in entries.iter().enumerate() {
        let y = by + pad + i as i32 * row_h;
        let (x0, x1, cy) =
            ((bx + pad) as f32, (bx + pad + swatch_w) as f32, y as f32 + th as f32 / 2.0);
        let (cx, f) = ((x0 + x1) / 2.0, scale as f32);
        let mut pb = PathBuilder::new();
        match *swatch {
            Swatch::Line(c, lw) => {
                pb.move_to(x0, cy);
                pb.line_to(x1, cy);
                stroke(pm, pb, c, lw * f);
            }
            Swatch::Fill(c) => {
                if let Some(r) = rect(bx + pad, y, swatch_w, th) {
                    fill(pm, r, c);
                }
            }
            Swatch::Dot(c, r) => {
                pb.push_circle(cx, cy, r * f);
                fill(pm, pb, c);
            }
            Swatch::Ring(c, r) => {
                pb.push_circle(cx, cy, r * f);
                stroke(pm, pb, c, 1.5);
            }
            Swatch::Cross(c, r) => {
                let r = r * f;
                pb.move_to(cx - r, cy - r);
                pb.line_to(cx + r, cy + r);
                pb.move_to(cx - r, cy + r);
                pb.line_to(cx + r, cy - r);
                stroke(pm, pb, c, 1.5);
            }
        }
        let c = Color::from_rgba8(TEXT[0], TEXT[1], TEXT[2], TEXT[3]);
        font::draw_text(pm, bx + 2 * pad + swatch_w + pad, y, label, scale, c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Mesh, MeshOptions};

    fn grid() -> Spline {
        let mesh = Mesh::grid(3, 2, 300.0, 200.0, MeshOptions::default()).unwrap();
        Spline::identity(mesh, 5).unwrap()
    }

    #[test]
    fn parse_show_layers() {
        let o = RenderOptions::parse_show("net, Points").unwrap();
        assert!(o.show_net && o.show_points && !o.show_mesh && !o.show_constraints);
        assert_eq!((o.width, o.height, o.samples_per_edge), (800, 600, 16));
        let o = RenderOptions::parse_show("all").unwrap();
        assert!(o.show_mesh && o.show_net && o.show_constraints && o.show_points);
        assert!(o.show_reference);
        for bad in ["mesh,grid", "", " , "] {
            let err = RenderOptions::parse_show(bad).unwrap_err();
            assert!(matches!(err, RenderError::UnknownLayer(_)), "{bad}: {err}");
        }
        let err = RenderOptions::parse_show("mesh,grid").unwrap_err().to_string();
        assert!(err.contains("'grid'"), "{err}");
    }

    #[test]
    fn view_fits_with_margin_and_keeps_aspect() {
        let v = View::fit([[0.0, 0.0], [300.0, 200.0]].into_iter(), 800, 600);
        assert!((v.scale - 2.4).abs() < 1e-12);
        assert_eq!(v.map([0.0, 0.0]), Some((40.0, 60.0)));
        assert_eq!(v.map([300.0, 200.0]), Some((760.0, 540.0)));
        assert_eq!(v.map([f64::NAN, 0.0]), None);
        let single = View::fit([[5.0, 5.0], [f64::NAN, 1.0]].into_iter(), 100, 100);
        assert_eq!((single.scale, single.map([5.0, 5.0])), (1.0, Some((50.0, 50.0))));
    }

    #[test]
    fn edge_curves_follow_the_identity() {
        let s = grid();
        for e in 0..s.mesh().num_edges() {
            let c = edge_curve(&s, e, 4);
            let ed = s.mesh().edges()[e];
            let (a, b) = (s.mesh().vertex(ed.v[0]), s.mesh().vertex(ed.v[1]));
            for (i, p) in c.iter().enumerate() {
                let t = i as f64 / 4.0;
                let want = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                assert!((p[0] - want[0]).abs() < 1e-9 && (p[1] - want[1]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn sizes_are_checked() {
        let o = RenderOptions { width: 8, ..RenderOptions::default() };
        assert!(matches!(render(&grid(), None, None, &o), Err(RenderError::Size { .. })));
        let o = RenderOptions::parse_show("all").unwrap();
        let pm = render(&grid(), Some(&LastEdit::default()), None, &o).unwrap();
        assert_eq!((pm.width(), pm.height()), (800, 600));
    }
}
