//! Pictures of 2.5D deformations of 3D models, PrisMystic's views (thesis ch. 18; MSc
//! dissertation ch. 5): the model deformed by `psi = (phi, alpha0 sigma0 + alpha1 sigma1)`
//! (see [`crate::prism`]), as tiny-skia pixmaps (save with [`super::deformation::save_png`]).
//!
//! # Top view ([`View::Top`], xy mode)
//!
//! Orthographic, seen from `+z`: `(x, y, z)` is drawn at `(ox + s x, oy + s y)`, x right and
//! **y down**, as in [`super::deformation`]: over a background image (the microscope frame
//! being matched) the canvas is the image and `(x, y)` the centre of pixel `(x, y)` (`s = 1`,
//! `ox = oy = 1/2`); without one, the bounding box of everything drawn is fitted into
//! `width x height` with a 5% margin, keeping the aspect ratio, on white. Drawn in order:
//!
//! * the model's projection, each triangle flat with brightness `0.3 + 0.7 |n_z|` (`n` its
//!   unit normal), the highest (largest mean z) in front, composited as one layer at 60%
//!   opacity so the background shows through evenly. The colours are the triangles filled
//!   without antialiasing in depth order; the coverage is one antialiased fill of the union
//!   of all triangles, which depends on x and y only (z edits change shading, not outline);
//! * the deformed reference mesh `phi(T)`, each edge sampled at `samples_per_edge + 1`
//!   points of its patch (border edges thicker), and the control points of `phi`.
//!
//! # Oblique view ([`View::Oblique`], z0 / z1 modes)
//!
//! Orthographic, z up. Azimuth `theta` turns the scene about the z axis,
//! `u = x cos theta - y sin theta`, `v = x sin theta + y cos theta`; elevation `eps` tilts it:
//!
//! ```text
//!   X = u,   Y = v sin eps - z cos eps   (y down),   depth = v cos eps + z sin eps
//! ```
//!
//! (depth grows toward the viewer; `eps = 90`, `theta = 0` is the top view, lower elevations
//! tip it back, the camera above its bottom edge). `(X, Y)` is fitted into the canvas as in
//! the top view without background (background images are not used here). All primitives
//! are sorted by the depth of their centres and painted back to front (painter's algorithm):
//!
//! * the surfaces `sigma0` (blue) and `sigma1` (red), translucent: each triangle of `T` is
//!   cut into `samples_per_edge^2` sub-triangles, a vertex at reference point `(x, y)` lifted
//!   to `(phi(x, y), sigma_l(x, y))`; the walls over the border edges of `T`, between them,
//!   translucent grey, cut likewise. Both are Lambert-shaded like the model;
//! * the mesh edges on both surfaces, the vertical edges at border vertices and the control
//!   points of both surfaces, `(q_i, z0_i)` and `(q_i, z1_i)` (what z0 / z1 edits move), all
//!   sorted one sample spacing in front of the surfaces they lie on;
//! * the model, opaque, each triangle flat-shaded by a fixed light from the upper left in
//!   front: `0.3 + 0.7 max(0, n . l)`, two-sided (`n` turned toward the viewer).
//!
//! Translucent fills are not antialiased, so sub-triangles tile without seams; opaque model
//! triangles are antialiased and grown by 0.7 pixels so neighbours leave no seams. Sorting
//! by centres approximates the painter's algorithm: interpenetrating primitives may be
//! ordered wrongly over a few pixels. Point clouds (models without triangles) show nothing.

use std::str::FromStr;

use rayon::prelude::*;
use tiny_skia::{
    FillRule, FilterQuality, Paint, PathBuilder, Pattern, Pixmap, SpreadMode, Transform,
};

use super::deformation::{
    blank, dots, draw_legend, edge_curve, paint, polyline, stroke, RenderError, Rgba, Swatch,
    View as Frame,
};
use crate::exact::rat_to_f64;
use crate::prism::{Model, PrismError};
use crate::spline::Spline;

const MODEL: [u8; 3] = [60, 170, 90];
/// Opacity of the model's projection in the top view.
const MODEL_OPACITY: f32 = 0.6;
const MESH: Rgba = [25, 25, 25, 255];
const HALO: Rgba = [255, 255, 255, 120];
const POINT: Rgba = [110, 110, 110, 255];
/// Colours of `sigma0`, `sigma1` and the walls, and the alpha of their fills.
const LAYER: [[u8; 3]; 2] = [[60, 110, 220], [220, 90, 60]];
const WALL: [u8; 3] = [150, 150, 150];
const SURFACE_ALPHA: u8 = 80;
const WALL_ALPHA: u8 = 50;
/// Colours of the edges (and control points) of `sigma0`, `sigma1` and the walls.
const LAYER_EDGE: [Rgba; 2] = [[30, 60, 160, 255], [170, 50, 30, 255]];
const WALL_EDGE: Rgba = [90, 90, 90, 255];
/// Smallest brightness of a shaded face.
const AMBIENT: f64 = 0.3;

/// Which picture [`render_model`] draws.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum View {
    /// Orthographic view from above (xy mode): model projection, `phi(T)`, control points.
    #[default]
    Top,
    /// Oblique orthographic view (z0 / z1 modes): both surfaces, the walls, the shaded model.
    Oblique,
}

impl View {
    /// The names [`View`]'s `FromStr` takes (`render --view`).
    pub const NAMES: [&'static str; 2] = ["top", "oblique"];
}

impl FromStr for View {
    type Err = RenderError;

    /// `top` or `oblique` (case-insensitive, surrounding spaces ignored); anything else is
    /// [`RenderError::UnknownView`] naming the word.
    fn from_str(s: &str) -> Result<View, RenderError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "top" => Ok(View::Top),
            "oblique" => Ok(View::Oblique),
            _ => Err(RenderError::UnknownView(s.to_string())),
        }
    }
}

/// What [`render_model`] draws and how large (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ModelRenderOptions {
    /// Output width in pixels (ignored in the top view with a background image).
    pub width: u32,
    /// Output height in pixels (ignored in the top view with a background image).
    pub height: u32,
    /// Top or oblique view.
    pub view: View,
    /// Draw the mesh: `phi(T)` (top view), or its edges on both surfaces and the vertical
    /// edges at border vertices (oblique view).
    pub show_mesh: bool,
    /// Draw the control points: of `phi` (top view), of both surfaces (oblique view).
    pub show_points: bool,
    /// Draw the translucent surfaces and walls (oblique view only).
    pub show_surfaces: bool,
    /// Segments per mesh edge; the oblique view cuts every triangle of `T` into the square
    /// of this many sub-triangles (and every wall quadrilateral likewise).
    pub samples_per_edge: usize,
    /// Oblique camera: rotation of the scene about the z axis, in degrees.
    pub azimuth_deg: f64,
    /// Oblique camera: angle of the line of sight above the xy plane, in degrees (90: top).
    pub elevation_deg: f64,
}

impl Default for ModelRenderOptions {
    /// 800x600, top view, mesh, points and surfaces on, 12 samples per edge, azimuth -35,
    /// elevation 30.
    fn default() -> Self {
        ModelRenderOptions {
            width: 800,
            height: 600,
            view: View::Top,
            show_mesh: true,
            show_points: true,
            show_surfaces: true,
            samples_per_edge: 12,
            azimuth_deg: -35.0,
            elevation_deg: 30.0,
        }
    }
}

/// Renders `model`, whose vertices `psi` moved to `deformed`, with the deformation `spline`
/// (see the module docs). `background` is used by the top view only.
///
/// Errors: [`RenderError::Model`] if `deformed` does not have one position per model vertex,
/// a triangle refers to a missing vertex, or the oblique view must draw the surfaces, mesh or
/// points of a spline without z layers; [`RenderError::Size`] for a bad canvas size.
pub fn render_model(
    spline: &Spline,
    model: &Model,
    deformed: &[[f64; 3]],
    background: Option<&Pixmap>,
    opts: &ModelRenderOptions,
) -> Result<Pixmap, RenderError> {
    let count = model.vertices.len();
    if deformed.len() != count {
        let found = deformed.len();
        return Err(RenderError::Model(format!("{found} deformed positions for {count} vertices")));
    }
    if let Some((i, t)) =
        model.triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&v| v as usize >= count))
    {
        return Err(RenderError::Model(format!("triangle {i} {t:?}: only {count} vertices")));
    }
    match opts.view {
        View::Top => top_view(spline, model, deformed, background, opts),
        View::Oblique => oblique_view(spline, model, deformed, opts),
    }
}

fn top_view(
    spline: &Spline,
    model: &Model,
    deformed: &[[f64; 3]],
    background: Option<&Pixmap>,
    opts: &ModelRenderOptions,
) -> Result<Pixmap, RenderError> {
    let mesh = spline.mesh();
    let n = opts.samples_per_edge.max(1);
    let edges = (0..mesh.num_edges()).into_par_iter().filter(|_| opts.show_mesh);
    let curves: Vec<_> =
        edges.map(|e| (edge_curve(spline, e, n), mesh.is_border_edge(e))).collect();
    let points = (0..spline.num_points()).filter(|_| opts.show_points);
    let points: Vec<[f64; 2]> = points.map(|i| spline.point_f64(i)).collect();
    let xy: Vec<[f64; 2]> = deformed.iter().map(|p| [p[0], p[1]]).collect();
    let (mut pm, frame) = match background {
        Some(bg) => (bg.clone(), Frame::PIXELS),
        None => {
            let pm = blank(opts.width, opts.height)?;
            let all = xy.iter().chain(curves.iter().flat_map(|c| &c.0)).chain(&points);
            let frame = Frame::fit(all.copied(), pm.width(), pm.height());
            (pm, frame)
        }
    };
    let mut legend: Vec<(String, Swatch)> = Vec::new();
    if !model.triangles.is_empty() {
        projection(&mut pm, &frame, model, deformed);
        let a = (MODEL_OPACITY * 255.0) as u8;
        legend.push(("model".into(), Swatch::Fill(rgba(MODEL, a))));
    }
    if opts.show_mesh {
        for (border, width) in [(false, 1.0), (true, 2.0)] {
            let mut pb = PathBuilder::new();
            for (c, _) in curves.iter().filter(|c| c.1 == border) {
                polyline(&mut pb, &frame, c);
            }
            if background.is_some() {
                stroke(&mut pm, pb.clone(), HALO, width + 1.5);
            }
            stroke(&mut pm, pb, MESH, width);
        }
        legend.push(("deformed mesh".into(), Swatch::Line(MESH, 1.0)));
    }
    if opts.show_points {
        let centres: Vec<(f32, f32)> = points.iter().filter_map(|&p| frame.map(p)).collect();
        dots(&mut pm, &centres, 1.2, POINT);
        legend.push(("control points".into(), Swatch::Dot(POINT, 1.5)));
    }
    let every = (xy.len() / 4096).max(1);
    let all = xy.iter().step_by(every).chain(curves.iter().flat_map(|c| &c.0)).chain(&points);
    let samples: Vec<(f32, f32)> = all.filter_map(|&p| frame.map(p)).collect();
    draw_legend(&mut pm, &legend, &samples);
    Ok(pm)
}

/// Draws the model's projection onto `pm` (see the module docs): a colour field of the
/// triangles in depth order, painted through the antialiased union of all triangles.
fn projection(pm: &mut Pixmap, frame: &Frame, model: &Model, deformed: &[[f64; 3]]) {
    let mut faces: Vec<(f64, Canvas3, Rgba)> = model
        .triangles
        .par_iter()
        .filter_map(|t| {
            let p = t.map(|i| deformed[i as usize]);
            let q = p.map(|v| frame.map([v[0], v[1]]));
            let q = [q[0]?, q[1]?, q[2]?];
            let z = (p[0][2] + p[1][2] + p[2][2]) / 3.0;
            let light = AMBIENT + (1.0 - AMBIENT) * unit_normal(p)[2].abs();
            z.is_finite().then(|| (z, q, shade(MODEL, light, 255)))
        })
        .collect();
    // The union path, in model order (independent of z), every triangle turned the same way
    // so that overlaps add up under the non-zero rule.
    let mut union = PathBuilder::new();
    for (_, q, _) in &faces {
        let cross = (q[1].0 - q[0].0) * (q[2].1 - q[0].1) - (q[1].1 - q[0].1) * (q[2].0 - q[0].0);
        triangle(&mut union, if cross < 0.0 { [q[0], q[2], q[1]] } else { *q });
    }
    let (Some(path), Some(mut field)) = (union.finish(), Pixmap::new(pm.width(), pm.height()))
    else {
        return;
    };
    faces.par_sort_by(|a, b| a.0.total_cmp(&b.0));
    for (_, q, c) in &faces {
        fill_triangle(&mut field, *q, *c, false);
    }
    dilate(&mut field);
    let (spread, filter) = (SpreadMode::Pad, FilterQuality::Nearest);
    let shader = Pattern::new(field.as_ref(), spread, filter, MODEL_OPACITY, Transform::identity());
    let paint = Paint { shader, anti_alias: true, ..Paint::default() };
    pm.fill_path(&path, &paint, FillRule::Winding, Transform::identity(), None);
}

/// Gives every transparent pixel next to (8-neighbourhood) a coloured one that neighbour's
/// colour, so antialiased border pixels whose centre no triangle covers get a colour.
fn dilate(pm: &mut Pixmap) {
    let (w, h) = (pm.width() as i64, pm.height() as i64);
    let src = pm.pixels().to_vec();
    for (i, px) in pm.pixels_mut().iter_mut().enumerate().filter(|(_, p)| p.alpha() == 0) {
        let (x, y) = (i as i64 % w, i as i64 / w);
        let near = (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (x + dx, y + dy)));
        let inside = |&(x, y): &(i64, i64)| x >= 0 && y >= 0 && x < w && y < h;
        if let Some(q) =
            near.filter(inside).map(|(x, y)| src[(y * w + x) as usize]).find(|q| q.alpha() > 0)
        {
            *px = q;
        }
    }
}

/// A primitive of the oblique view, in camera coordinates (`X`, `Y` down).
#[derive(Clone, Copy, Debug)]
enum Shape {
    /// A filled triangle; `true`: an opaque model face (antialiased, grown against seams).
    Tri([[f64; 2]; 3], Rgba, bool),
    /// A line segment 1 pixel wide, or a dot if both ends are the same.
    Mark([[f64; 2]; 2], Rgba),
}

impl Shape {
    fn points(&self) -> &[[f64; 2]] {
        match self {
            Shape::Tri(q, ..) => q,
            Shape::Mark(q, _) => q,
        }
    }
}

/// A primitive and the depth of its centre (larger: nearer the viewer).
type Prim = (f64, Shape);

/// A triangle in canvas coordinates.
type Canvas3 = [(f32, f32); 3];

/// The oblique camera (see the module docs): the world directions of the canvas axes and of
/// the viewer, and the light.
struct Camera {
    right: [f64; 3],
    down: [f64; 3],
    toward: [f64; 3],
    light: [f64; 3],
}

impl Camera {
    fn new(azimuth_deg: f64, elevation_deg: f64) -> Camera {
        let (st, ct) = azimuth_deg.to_radians().sin_cos();
        let (se, ce) = elevation_deg.to_radians().sin_cos();
        let (right, ev) = ([ct, -st, 0.0], [st, ct, 0.0]);
        let down = [se * ev[0], se * ev[1], -ce];
        let toward = [ce * ev[0], ce * ev[1], se];
        // From the upper left, in front: (right, down, toward) = (-0.4, -0.6, 0.7).
        let l: [f64; 3] =
            std::array::from_fn(|k| -0.4 * right[k] - 0.6 * down[k] + 0.7 * toward[k]);
        Camera { right, down, toward, light: normalize(l) }
    }

    /// Canvas position (before fitting) and depth of world point `p`.
    fn project(&self, p: [f64; 3]) -> ([f64; 2], f64) {
        ([dot(self.right, p), dot(self.down, p)], dot(self.toward, p))
    }

    /// The face `p`, Lambert-shaded (two-sided), with alpha `alpha`.
    fn face(&self, p: [[f64; 3]; 3], rgb: [u8; 3], alpha: u8, opaque: bool) -> Prim {
        let q = p.map(|v| self.project(v));
        let mut n = unit_normal(p);
        if dot(n, self.toward) < 0.0 {
            n = n.map(|c| -c);
        }
        let light = AMBIENT + (1.0 - AMBIENT) * dot(n, self.light).max(0.0);
        let depth = (q[0].1 + q[1].1 + q[2].1) / 3.0;
        (depth, Shape::Tri(q.map(|v| v.0), shade(rgb, light, alpha), opaque))
    }

    /// The segment `p` (a dot if its ends are the same), moved `bias` toward the viewer in
    /// the depth order.
    fn mark(&self, p: [[f64; 3]; 2], c: Rgba, bias: f64) -> Prim {
        let (a, b) = (self.project(p[0]), self.project(p[1]));
        ((a.1 + b.1) / 2.0 + bias, Shape::Mark([a.0, b.0], c))
    }
}

fn oblique_view(
    spline: &Spline,
    model: &Model,
    deformed: &[[f64; 3]],
    opts: &ModelRenderOptions,
) -> Result<Pixmap, RenderError> {
    let mut pm = blank(opts.width, opts.height)?;
    let z = spline.z_layers();
    if (opts.show_surfaces || opts.show_mesh || opts.show_points) && z.is_none() {
        return Err(RenderError::Model(PrismError::NotPrism.to_string()));
    }
    let (mesh, cache, n) = (spline.mesh(), spline.eval_cache(), opts.samples_per_edge.max(1));
    let cam = &Camera::new(opts.azimuth_deg, opts.elevation_deg);
    // (phi, [sigma0, sigma1]) at a point of triangle t; the point at height r / n between them.
    let at = |t: usize, b: [f64; 3]| (cache.value(t, b), spline.eval_z(t, b).unwrap_or([0.0; 2]));
    let up = |(p, z): ([f64; 2], [f64; 2]), r: usize| {
        [p[0], p[1], z[0] + (z[1] - z[0]) * r as f64 / n as f64]
    };
    // Lines and dots sort one sample spacing in front of the surfaces they lie on.
    let edges = mesh.edges();
    let length: f64 = edges.iter().map(|e| dist(mesh.vertex(e.v[0]), mesh.vertex(e.v[1]))).sum();
    let bias = length / (edges.len().max(1) * n) as f64;
    let mut prims: Vec<Prim> = Vec::new();
    let mut legend: Vec<(String, Swatch)> = Vec::new();
    if opts.show_surfaces {
        let row = |j: usize| j * (n + 1) - j * j.saturating_sub(1) / 2;
        prims.par_extend((0..mesh.num_triangles()).into_par_iter().flat_map_iter(|t| {
            let grid: Vec<_> = (0..=n)
                .flat_map(|j| (0..=n - j).map(move |i| [n - i - j, i, j]))
                .map(|b| at(t, b.map(|c| c as f64 / n as f64)))
                .collect();
            let mut out = Vec::with_capacity(2 * n * n);
            for (l, j) in [0, 1].into_iter().flat_map(|l| (0..n).map(move |j| (l, j))) {
                let v = |i: usize, j: usize| up(grid[row(j) + i], l * n);
                for i in 0..n - j {
                    let tri = [v(i, j), v(i + 1, j), v(i, j + 1)];
                    out.push(cam.face(tri, LAYER[l], SURFACE_ALPHA, false));
                    if i + j + 1 < n {
                        let down = [v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)];
                        out.push(cam.face(down, LAYER[l], SURFACE_ALPHA, false));
                    }
                }
            }
            out
        }));
        legend.push(("top surface (sigma1)".into(), Swatch::Fill(rgba(LAYER[1], 160))));
        legend.push(("bottom surface (sigma0)".into(), Swatch::Fill(rgba(LAYER[0], 160))));
        legend.push(("walls".into(), Swatch::Fill(rgba(WALL, 120))));
    }
    // Per edge: its curves on both surfaces; on the border, the wall and its vertical ends.
    prims.par_extend((0..edges.len()).into_par_iter().flat_map_iter(|e| {
        let (border, mut out) = (mesh.is_border_edge(e), Vec::new());
        if !(opts.show_mesh || border && opts.show_surfaces) {
            return out;
        }
        let s = edge_samples(spline, e, n, at);
        let v = |k: usize, r: usize| up(s[k], r);
        for (k, l) in (0..n).flat_map(|k| [(k, 0), (k, 1)]).filter(|_| opts.show_mesh) {
            out.push(cam.mark([v(k, l * n), v(k + 1, l * n)], LAYER_EDGE[l], bias));
        }
        let ends = [0, n].into_iter().filter(|_| border && opts.show_mesh);
        for (k, r) in ends.flat_map(|k| (0..n).map(move |r| (k, r))) {
            out.push(cam.mark([v(k, r), v(k, r + 1)], WALL_EDGE, bias));
        }
        let wall = (0..n).filter(|_| border && opts.show_surfaces);
        for (k, r) in wall.flat_map(|k| (0..n).map(move |r| (k, r))) {
            let (a, b, c, d) = (v(k, r), v(k + 1, r), v(k + 1, r + 1), v(k, r + 1));
            out.push(cam.face([a, b, c], WALL, WALL_ALPHA, false));
            out.push(cam.face([a, c, d], WALL, WALL_ALPHA, false));
        }
        out
    }));
    if let (true, Some(z)) = (opts.show_points, z) {
        for (i, zs) in z.z0.iter().zip(&z.z1).enumerate() {
            let (p, zs) = (spline.point_f64(i), [rat_to_f64(zs.0), rat_to_f64(zs.1)]);
            prims.extend((0..2).map(|l| cam.mark([up((p, zs), l * n); 2], LAYER_EDGE[l], bias)));
        }
    }
    prims.par_extend(model.triangles.par_iter().filter_map(|t| {
        let p = t.map(|i| deformed[i as usize]);
        p.iter().flatten().all(|c| c.is_finite()).then(|| cam.face(p, MODEL, 255, true))
    }));
    if !model.triangles.is_empty() {
        legend.push(("model".into(), Swatch::Fill(rgba(MODEL, 255))));
    }

    prims.par_sort_by(|a, b| a.0.total_cmp(&b.0));
    let frame =
        Frame::fit(prims.iter().flat_map(|p| p.1.points()).copied(), opts.width, opts.height);
    let map = |q: [[f64; 2]; 3]| Some([frame.map(q[0])?, frame.map(q[1])?, frame.map(q[2])?]);
    for (_, shape) in &prims {
        match *shape {
            Shape::Tri(q, c, opaque) => {
                let Some(q) = map(q) else { continue };
                fill_triangle(&mut pm, if opaque { grow(q, 0.7) } else { q }, c, opaque);
            }
            Shape::Mark([a, b], c) if a == b => {
                dots(&mut pm, &Vec::from_iter(frame.map(a)), 1.5, c)
            }
            Shape::Mark(q, c) => {
                let mut pb = PathBuilder::new();
                polyline(&mut pb, &frame, &q);
                stroke(&mut pm, pb, c, 1.0);
            }
        }
    }
    let every = (prims.len() / 4096).max(1);
    let samples: Vec<(f32, f32)> =
        prims.iter().step_by(every).filter_map(|p| frame.map(p.1.points()[0])).collect();
    draw_legend(&mut pm, &legend, &samples);
    Ok(pm)
}

/// `(phi, [sigma0, sigma1])` along mesh edge `e` at `n + 1` equally spaced parameters, on
/// the patch of one of its triangles (`at` evaluates a triangle at barycentric coordinates).
fn edge_samples<F>(spline: &Spline, e: usize, n: usize, at: F) -> Vec<([f64; 2], [f64; 2])>
where
    F: Fn(usize, [f64; 3]) -> ([f64; 2], [f64; 2]),
{
    let (mesh, edge) = (spline.mesh(), spline.mesh().edges()[e]);
    let t = edge.tris[0].or(edge.tris[1]).expect("an edge has a triangle");
    let local = |v: usize| mesh.triangle(t).iter().position(|&w| w == v).expect("in triangle");
    let (a, b) = (local(edge.v[0]), local(edge.v[1]));
    (0..=n)
        .map(|i| {
            let mut bary = [0.0; 3];
            bary[b] = i as f64 / n as f64;
            bary[a] = 1.0 - bary[b];
            at(t, bary)
        })
        .collect()
}

/// Moves the vertices of a canvas triangle `d` pixels away from its centroid, so adjacent
/// antialiased opaque triangles overlap slightly and leave no seams.
fn grow(q: Canvas3, d: f32) -> Canvas3 {
    let c = ((q[0].0 + q[1].0 + q[2].0) / 3.0, (q[0].1 + q[1].1 + q[2].1) / 3.0);
    q.map(|(x, y)| {
        let l = (x - c.0).hypot(y - c.1);
        if l > 0.0 {
            (x + d * (x - c.0) / l, y + d * (y - c.1) / l)
        } else {
            (x, y)
        }
    })
}

fn triangle(pb: &mut PathBuilder, q: Canvas3) {
    pb.move_to(q[0].0, q[0].1);
    pb.line_to(q[1].0, q[1].1);
    pb.line_to(q[2].0, q[2].1);
    pb.close();
}

fn fill_triangle(pm: &mut Pixmap, q: Canvas3, c: Rgba, antialias: bool) {
    let mut pb = PathBuilder::new();
    triangle(&mut pb, q);
    let Some(path) = pb.finish() else { return };
    let mut paint = paint(c);
    paint.anti_alias = antialias;
    pm.fill_path(&path, &paint, FillRule::Winding, Transform::identity(), None);
}

fn rgba(c: [u8; 3], a: u8) -> Rgba {
    [c[0], c[1], c[2], a]
}

/// `c` scaled by `light` (clamped to `[0, 1]`), with alpha `a`.
fn shade(c: [u8; 3], light: f64, a: u8) -> Rgba {
    let l = light.clamp(0.0, 1.0);
    rgba(c.map(|v| (f64::from(v) * l).round() as u8), a)
}

/// The unit normal `(b - a) x (c - a) / |...|` of a triangle (zero if degenerate).
fn unit_normal([a, b, c]: [[f64; 3]; 3]) -> [f64; 3] {
    let (u, v) = ([b[0] - a[0], b[1] - a[1], b[2] - a[2]], [c[0] - a[0], c[1] - a[1], c[2] - a[2]]);
    normalize([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]])
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = dot(v, v).sqrt();
    v.map(|c| if l > 0.0 { c / l } else { 0.0 })
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::{select::Neighborhood, Editor, Mode};
    use crate::exact::rat_int;
    use crate::prism::organism::{worm, WormOptions};
    use crate::prism::{auto_mesh, bind, deform, identity_layers};
    use crate::spline::ControlPoint;

    /// The default worm (20,000 triangles) moved by `shift` in xy, in a 4 x 2 prism mesh of
    /// degree 5 with identity layers (as in the prism tests).
    fn scene(shift: [f64; 2]) -> (Model, Spline) {
        let mut m = worm(&WormOptions::default());
        for v in &mut m.vertices {
            (v[0], v[1]) = (v[0] + shift[0], v[1] + shift[1]);
        }
        let (mesh, [a, b]) = auto_mesh(&m, 4, 2, 0.05).unwrap();
        let mut s = Spline::identity(mesh, 5).unwrap();
        let z = identity_layers(&s, rat_int(a.floor() as i64 - 1), rat_int(b.ceil() as i64 + 1));
        s.set_z_layers(Some(z.unwrap()));
        (m, s)
    }

    /// `s` after translating the neighbourhood of an interior vertex by `by` in `mode`.
    fn edited(s: &Spline, mode: Mode, by: &[i64]) -> Spline {
        let v = (0..s.mesh().num_vertices()).find(|&v| !s.mesh().is_border_vertex(v)).unwrap();
        let mut ed = Editor::new(s.clone());
        ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), mode).unwrap();
        ed.translate(&by.iter().map(|&b| rat_int(b)).collect::<Vec<_>>()).unwrap();
        ed.into_spline()
    }

    fn draw(m: &Model, s: &Spline, bg: Option<&Pixmap>, o: &ModelRenderOptions) -> Pixmap {
        render_model(s, m, &deform(m, &bind(m, s).unwrap(), s), bg, o).unwrap()
    }

    fn rgb(pm: &Pixmap, x: u32, y: u32) -> [u8; 3] {
        let p = pm.pixel(x, y).unwrap().demultiply();
        [p.red(), p.green(), p.blue()]
    }

    fn model_only(view: View) -> ModelRenderOptions {
        let o = ModelRenderOptions { width: 640, height: 480, view, ..Default::default() };
        ModelRenderOptions { show_mesh: false, show_points: false, show_surfaces: false, ..o }
    }

    #[test]
    fn top_view_has_the_requested_size_and_shows_the_model_in_the_middle() {
        let (m, s) = scene([0.0, 0.0]);
        let pm = draw(&m, &s, None, &ModelRenderOptions { width: 640, ..Default::default() });
        assert_eq!((pm.width(), pm.height()), (640, 600));
        // Everything drawn fits a wide box: the middle of the top edge stays white.
        assert_eq!(rgb(&pm, 320, 15), [255; 3]);
        // Model only: the fitted box is the worm's, centred on (500, 0), inside the body.
        let [r, g, b] = rgb(&draw(&m, &s, None, &model_only(View::Top)), 320, 240);
        assert!(g > r + 30 && g > b + 30, "{:?}", [r, g, b]);
    }

    #[test]
    fn top_view_over_an_image_is_translucent_in_image_coordinates() {
        let (m, s) = scene([100.0, 200.0]);
        let image = |k: u8| {
            let mut pm = Pixmap::new(1200, 400).unwrap();
            for (i, p) in pm.pixels_mut().iter_mut().enumerate() {
                let (x, y) = ((i % 1200) as u8, (i / 1200) as u8);
                *p = tiny_skia::ColorU8::from_rgba(x ^ k, y ^ k, 128, 255).premultiply();
            }
            pm
        };
        let (dark, light) = (image(0), image(255));
        let o = ModelRenderOptions { width: 100, height: 100, ..Default::default() };
        let (a, b) = (draw(&m, &s, Some(&dark), &o), draw(&m, &s, Some(&light), &o));
        assert_eq!((a.width(), a.height()), (1200, 400));
        for t in [0.2, 0.45, 0.7, 0.9] {
            // The top vertex of a ring: its xy is on the centre line, in the body.
            let v = m.vertices[1 + (t * 250.0) as usize * 40 + 10];
            let (x, y) = (v[0].round() as u32, v[1].round() as u32);
            // Covered (differs from the image) but translucent (depends on the image).
            assert_ne!(rgb(&a, x, y), rgb(&dark, x, y), "{t}");
            assert_ne!(rgb(&b, x, y), rgb(&light, x, y), "{t}");
            assert_ne!(rgb(&a, x, y), rgb(&b, x, y), "{t}");
        }
        // Far from the model and the mesh (y < 60) the image is untouched.
        for x in (300..900).step_by(50) {
            assert_eq!(a.pixel(x, 30), dark.pixel(x, 30), "{x}");
        }
    }

    #[test]
    fn z_edits_change_the_oblique_view_but_not_the_top_silhouette() {
        let (m, s) = scene([100.0, 200.0]);
        let raised = edited(&s, Mode::Z1, &[300]);
        let o = ModelRenderOptions { view: View::Oblique, ..Default::default() };
        let sum = |pm: &Pixmap| pm.data().iter().map(|&c| u64::from(c)).sum::<u64>();
        let (before, after) = (draw(&m, &s, None, &o), draw(&m, &raised, None, &o));
        assert_eq!((before.width(), before.height()), (800, 600));
        assert_ne!(sum(&before), sum(&after));
        // Top view of the model alone on a transparent canvas: z edits never move x or y, so
        // the coverage (alpha) is identical; the shading by n_z changes.
        let clear = Pixmap::new(1200, 400).unwrap();
        let o = model_only(View::Top);
        let (before, after) = (draw(&m, &s, Some(&clear), &o), draw(&m, &raised, Some(&clear), &o));
        let alpha = |pm: &Pixmap| pm.pixels().iter().map(|p| p.alpha()).collect::<Vec<_>>();
        assert_eq!(alpha(&before), alpha(&after));
        assert!(alpha(&before).iter().filter(|&&a| a > 0).count() > 10_000);
        assert_ne!(before.data(), after.data());
    }

    #[test]
    fn oblique_view_shades_the_model_under_the_surfaces() {
        let (m, s) = scene([0.0, 0.0]);
        let pm = draw(&m, &s, None, &model_only(View::Oblique));
        assert_eq!((pm.width(), pm.height()), (640, 480));
        let [r, g, b] = rgb(&pm, 320, 240);
        assert!(g > r + 30 && g > b + 30, "{:?}", [r, g, b]);
        assert_eq!(rgb(&pm, 320, 10), [255; 3]);
        // Seen from above, the red top surface is in front of the model, the blue bottom one
        // behind it: the model turns redder, not bluer.
        let o = ModelRenderOptions { show_surfaces: true, ..model_only(View::Oblique) };
        let [r2, _, b2] = rgb(&draw(&m, &s, None, &o), 320, 240);
        assert!(i32::from(r2) - i32::from(b2) > i32::from(r) - i32::from(b) + 20, "{r2} {b2}");
    }

    #[test]
    fn the_nearest_face_is_in_front_in_both_views() {
        let (_, s) = scene([0.0, 0.0]);
        // A flat square at z = -10 under a tilted one (z = 10 + y / 4), shaded differently.
        let quad = |z: fn(f64) -> f64| {
            [[-50.0, -50.0], [50.0, -50.0], [50.0, 50.0], [-50.0, 50.0]].map(|[x, y]| [x, y, z(y)])
        };
        let (low, high) = (quad(|_| -10.0), quad(|y| 10.0 + y / 4.0));
        let model = |squares: &[[[f64; 3]; 4]]| {
            // Tiny triangles at opposite corners fix the fitted frame.
            let (a, b) = (-150.0, 150.0);
            let mut vertices = vec![[a; 3], [a + 1.0, a, a], [a, a + 1.0, a], [b; 3]];
            vertices.extend([[b - 1.0, b, b], [b, b - 1.0, b]]);
            let mut triangles = vec![[0, 1, 2], [3, 4, 5]];
            for q in squares {
                let k = vertices.len() as u32;
                vertices.extend(q);
                triangles.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
            }
            Model { vertices, triangles, ..Default::default() }
        };
        for view in [View::Top, View::Oblique] {
            let pick = |squares: &[[[f64; 3]; 4]]| {
                let (m, o) = (model(squares), model_only(view));
                rgb(&render_model(&s, &m, &m.vertices, None, &o).unwrap(), 320, 240)
            };
            let front = pick(&[high]);
            assert_ne!(front, pick(&[low]), "{view:?}");
            assert_eq!(pick(&[low, high]), front, "{view:?}");
            assert_eq!(pick(&[high, low]), front, "{view:?}");
        }
    }

    #[test]
    fn bad_words_and_inputs_are_errors() {
        assert_eq!("top".parse::<View>().unwrap(), View::Top);
        assert_eq!(" Oblique ".parse::<View>().unwrap(), View::Oblique);
        let err = "side".parse::<View>().unwrap_err();
        assert!(matches!(err, RenderError::UnknownView(_)) && err.to_string().contains("'side'"));
        let (m, s) = scene([0.0, 0.0]);
        let o = ModelRenderOptions::default();
        let short = &m.vertices[1..];
        assert!(matches!(render_model(&s, &m, short, None, &o), Err(RenderError::Model(_))));
        let mut flat = s.clone();
        flat.set_z_layers(None);
        let o = ModelRenderOptions { view: View::Oblique, ..o };
        let err = render_model(&flat, &m, &m.vertices, None, &o).unwrap_err();
        assert!(err.to_string().contains("z layers"), "{err}");
        assert!(render_model(&flat, &m, &m.vertices, None, &model_only(View::Oblique)).is_ok());
        let o = ModelRenderOptions { width: 8, ..o };
        let small = render_model(&s, &m, &m.vertices, None, &o);
        assert!(matches!(small, Err(RenderError::Size { .. })));
    }
}
