//! What the page draws, computed by the engine (the page never evaluates the spline).
//!
//! All positions are mesh coordinates (= pixel coordinates of the reference image).
//!
//! * `points`: the control points `q_m` (xy), and in 2.5D the scalar control values of
//!   `sigma0` and `sigma1` (`z0`, `z1`);
//! * `mesh`: the deformed reference mesh, each mesh edge as a polyline of
//!   [`super::doc::EDGE_SAMPLES`] + 1 points of `phi` along it;
//! * `model`: the deformed model `psi(v)` (x, y, z per vertex), and `model_outline`, its
//!   silhouette seen from `+z` as segments;
//! * static parts (with `full`): the control net (pairs of point indices), the C1
//!   quadrilaterals (4 point indices each, thesis ch. 14: `l, r, p, n`), the model's
//!   triangles;
//! * `selection`: anchors, derived points and the relevant non-redundant constraints of the
//!   current edit (indices into the quadrilaterals).

use super::answers::{Certificate, GeometrySelection};
use super::doc::Doc;
use serde::Serialize;

/// A JSON object written straight to text. The big numeric arrays of the geometry go in
/// without a `serde_json::Value` tree: with serde_json's `arbitrary_precision` every number
/// in a `Value` is its own heap string, which made building the answer cost more than the
/// exact update it reports. The small parts are typed values ([`super::answers`]) written
/// as `serde_json` writes them.
pub struct JsonObject {
    buf: String,
}

impl JsonObject {
    /// An empty object.
    pub fn new() -> JsonObject {
        JsonObject { buf: String::from("{") }
    }

    fn key(&mut self, k: &str) {
        if self.buf.len() > 1 {
            self.buf.push(',');
        }
        self.push_json(k);
        self.buf.push(':');
    }

    /// Appends `v` rounded to 1/1000 pixel, which keeps the JSON short (far below what a
    /// screen shows). Non-finite numbers are written as `null`.
    /// Written as an integer and up to three decimals: shortest-float formatting took half
    /// of a z-mode drag step.
    fn num(&mut self, v: f64) {
        use std::fmt::Write;
        let m = (v * 1000.0).round();
        if !m.is_finite() {
            self.buf.push_str("null");
        } else if m.abs() >= 1e15 {
            let _ = write!(self.buf, "{}", m / 1000.0);
        } else {
            let m = m as i64;
            if m < 0 {
                self.buf.push('-');
            }
            let a = m.unsigned_abs();
            push_digits(&mut self.buf, a / 1000);
            let frac = a % 1000;
            if frac != 0 {
                self.buf.push('.');
                let d = [frac / 100, frac / 10 % 10, frac % 10];
                let keep = if d[2] != 0 {
                    3
                } else if d[1] != 0 {
                    2
                } else {
                    1
                };
                for &x in &d[..keep] {
                    self.buf.push(char::from(b'0' + x as u8));
                }
            }
        }
    }

    /// Appends `"k": text`, `text` being JSON already (a nested object).
    pub fn raw(&mut self, k: &str, text: &str) {
        self.key(k);
        self.buf.push_str(text);
    }

    /// `v` as `serde_json` writes it (`null` for a value it cannot write, which no answer
    /// has: their maps, if any, have string keys).
    fn push_json<T: Serialize + ?Sized>(&mut self, v: &T) {
        match serde_json::to_string(v) {
            Ok(text) => self.buf.push_str(&text),
            Err(_) => self.buf.push_str("null"),
        }
    }

    /// Appends `"k": value`.
    pub fn value<T: Serialize + ?Sized>(&mut self, k: &str, v: &T) {
        self.key(k);
        self.push_json(v);
    }

    /// Appends every entry of `v`, in the order written, if `v` is written as a JSON object
    /// (a struct of [`super::answers`]); nothing otherwise.
    pub fn extend<T: Serialize + ?Sized>(&mut self, v: &T) {
        let Ok(text) = serde_json::to_string(v) else { return };
        if let Some(inner) = text.strip_prefix('{').and_then(|t| t.strip_suffix('}')) {
            if !inner.is_empty() {
                if self.buf.len() > 1 {
                    self.buf.push(',');
                }
                self.buf.push_str(inner);
            }
        }
    }

    /// Appends `"k": [v, ...]`, each rounded to 1/1000.
    pub fn numbers(&mut self, k: &str, vals: impl IntoIterator<Item = f64>) {
        self.key(k);
        self.buf.push('[');
        for (i, v) in vals.into_iter().enumerate() {
            if i > 0 {
                self.buf.push(',');
            }
            self.num(v);
        }
        self.buf.push(']');
    }

    /// Appends `"k": [[x, y], ...]`, rounded to 1/1000.
    pub fn points(&mut self, k: &str, pts: impl IntoIterator<Item = [f64; 2]>) {
        self.key(k);
        self.push_points(pts);
    }

    fn push_points(&mut self, pts: impl IntoIterator<Item = [f64; 2]>) {
        self.buf.push('[');
        for (i, p) in pts.into_iter().enumerate() {
            self.buf.push_str(if i > 0 { ",[" } else { "[" });
            self.num(p[0]);
            self.buf.push(',');
            self.num(p[1]);
            self.buf.push(']');
        }
        self.buf.push(']');
    }

    /// The JSON text.
    pub fn finish(mut self) -> String {
        self.buf.push('}');
        self.buf
    }
}

/// Appends the decimal digits of `n` (no `fmt` machinery: this is the answer's hot loop).
fn push_digits(buf: &mut String, mut n: u64) {
    let mut tmp = [0u8; 20];
    let mut i = tmp.len();
    loop {
        i -= 1;
        tmp[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    buf.extend(tmp[i..].iter().map(|&b| char::from(b)));
}

impl Default for JsonObject {
    fn default() -> Self {
        JsonObject::new()
    }
}

/// The geometry for the page as a JSON object (see the module docs); `full` adds the parts
/// that do not change during edits.
pub fn geometry(doc: &Doc, full: bool) -> String {
    let mut out = JsonObject::new();
    write_geometry(doc, full, &mut out);
    out.finish()
}

/// Appends the geometry's entries to `out` ([`geometry`]).
pub fn write_geometry(doc: &Doc, full: bool, out: &mut JsonObject) {
    let s = doc.spline();
    out.points("points", (0..s.num_points()).map(|i| s.point_f64(i)));
    // Mesh edges, sampled along the reference edge and mapped by phi.
    let cache = s.eval_cache();
    let lines = doc.edge_samples();
    out.key("mesh");
    out.buf.push('[');
    for (i, line) in lines.iter().enumerate() {
        if i > 0 {
            out.buf.push(',');
        }
        out.push_points(line.iter().map(|&(t, beta)| cache.value(t, beta)));
    }
    out.buf.push(']');
    // The z values and the model in 3D are for the z modes' views: sent with `full`, or
    // when the selection is in a z mode (keeps xy drag answers small).
    let zview =
        full || doc.editor().selection().is_some_and(|sel| sel.mode != crate::edit::Mode::Xy);
    if let Some(z) = s.z_layers().filter(|_| zview) {
        let f =
            |v: &[crate::exact::Rat]| v.iter().map(crate::exact::rat_to_f64).collect::<Vec<_>>();
        out.numbers("z0", f(&z.z0));
        out.numbers("z1", f(&z.z1));
        out.value(
            "z_range",
            &[crate::exact::rat_to_f64(&z.range[0]), crate::exact::rat_to_f64(&z.range[1])],
        );
    }
    if let (Some(v), Some(m)) = (doc.deformed_model(), doc.model()) {
        // Top view: the silhouette as segments (x0, y0, x1, y1), cheap to stroke; the
        // vertices (x, y, z) for the oblique view.
        let segs = m.edges.segments(&v);
        out.numbers("model_outline", segs.iter().flat_map(|[a, b]| [a[0], a[1], b[0], b[1]]));
        if zview {
            out.numbers("model", v.iter().flat_map(|p| *p));
        }
    }
    // The certificate, and each folding triangle's deformed corners (x0, y0, x1, y1, x2, y2)
    // for the page to outline.
    let det_j = doc.det_j();
    out.extend(&Certificate::from(&det_j));
    out.numbers(
        "folding_outline",
        det_j.folding.iter().flat_map(|&t| {
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
                .into_iter()
                .flat_map(move |b| cache.value(t, b))
        }),
    );
    if let Some(sel) = doc.editor().selection() {
        let relevant = sel.independent_constraints(doc.editor().spline());
        out.value(
            "selection",
            &GeometrySelection {
                anchors: sel.anchors.clone(),
                derived: sel.derived.clone(),
                constraints: relevant,
            },
        );
    }
    if full {
        let idx = doc.editor().index();
        let mut net: Vec<[usize; 2]> = Vec::new();
        for (a, nb) in idx.net.iter().enumerate() {
            net.extend(nb.iter().filter(|&&b| b > a).map(|&b| [a, b]));
        }
        let quads: Vec<[usize; 4]> = s.quads().iter().map(|q| [q.l, q.p, q.r, q.n]).collect();
        out.value("net", &net);
        out.value("quads", &quads);
        let mesh = s.mesh();
        out.points("reference", (0..mesh.num_vertices()).map(|v| mesh.vertex(v)));
        if let Some(m) = doc.model() {
            out.value("model_triangles", &m.model.triangles);
        }
    }
}

/// The Jacobian determinant of `phi` as a colour overlay (PNG, `w x h` pixels of the
/// reference grid; colours of [`crate::warp::field::det_color`]: white 1, blue
/// compression, orange expansion, red folds, transparent outside the mesh).
pub fn jacobian_png(doc: &Doc, w: u32, h: u32) -> Result<Vec<u8>, image::ImageError> {
    let (dets, _) = crate::warp::field::jacobian_det(doc.spline(), w, h);
    let mut img = image::RgbaImage::new(w, h);
    for (px, d) in img.pixels_mut().zip(dets) {
        let mut c = crate::warp::field::det_color(d);
        c[3] = c[3].min(150);
        *px = image::Rgba(c);
    }
    let mut bytes = Vec::new();
    image::DynamicImage::ImageRgba8(img)
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)?;
    Ok(bytes)
}

/// Default node spacing of the live warp's inverse map (pixels).
pub const WARP_STEP: u32 = 8;

/// The live warp's coarse inverse map: `phi^-1` at the nodes `x_i = min(i * step, w - 1)`,
/// `y_j = min(j * step, h - 1)` of the `w x h` frame, as
/// `{step, width, height, nx, ny, map: [px, py, ...]}` (row by row, `null, null` where a
/// node has no preimage in the mesh). The page draws the warped frame
/// `O(q) = I(phi^-1(q))` (as `trimorph warp`) by interpolating the map bilinearly inside
/// each cell and sampling the frame bilinearly (pixel centres at integers). Newton per
/// node ([`crate::warp::inverse`]), rows in parallel.
pub fn inverse_grid(doc: &Doc, step: u32) -> Option<String> {
    use crate::warp::inverse::{InverseMap, InverseOptions};
    use rayon::prelude::*;
    let f = doc.frame()?;
    let (w, h) = (f.image.width().max(1), f.image.height().max(1));
    let step = step.clamp(1, 64);
    let nodes = |n: u32| (n.saturating_sub(1)).div_ceil(step) + 1;
    let (nx, ny) = (nodes(w), nodes(h));
    let at = |i: u32, n: u32| f64::from((i * step).min(n - 1));
    let map = InverseMap::new(doc.spline(), InverseOptions::default());
    let rows: Vec<Vec<[f64; 2]>> = (0..ny)
        .into_par_iter()
        .map(|j| {
            let mut prev = None;
            (0..nx)
                .map(|i| match map.invert([at(i, w), at(j, h)], prev.as_ref()) {
                    Some(p) => {
                        prev = Some(p);
                        p.p
                    }
                    None => [f64::NAN, f64::NAN],
                })
                .collect()
        })
        .collect();
    let mut out = JsonObject::new();
    out.value("step", &step);
    out.value("width", &w);
    out.value("height", &h);
    out.value("nx", &nx);
    out.value("ny", &ny);
    out.numbers("map", rows.iter().flatten().flat_map(|p| *p));
    Some(out.finish())
}

/// Where the nodes of the live warp's forward grid lie in the reference mesh: node
/// `(i, j)` is `p = (min(i * step, w - 1), min(j * step, h - 1))` of the `w x h` moving
/// frame, row by row; `None` where it is outside the mesh. The mesh never changes within a
/// document, so a grid is located once ([`Doc::forward_nodes`]).
pub struct WarpNodes {
    /// `(w, h, step)` the nodes were located for.
    pub key: (u32, u32, u32),
    /// Nodes per row and per column.
    pub nx: u32,
    /// Rows of nodes.
    pub ny: u32,
    /// Per node: (triangle, barycentrics), or `None` outside the mesh.
    pub at: Vec<Option<(usize, [f64; 3])>>,
}

impl WarpNodes {
    /// Locates the nodes of a `w x h` frame with spacing `step` in `mesh`.
    pub fn locate(mesh: &crate::mesh::Mesh, w: u32, h: u32, step: u32) -> WarpNodes {
        let nodes = |n: u32| (n.saturating_sub(1)).div_ceil(step) + 1;
        let (nx, ny) = (nodes(w), nodes(h));
        let at = |i: u32, n: u32| f64::from((i * step).min(n - 1));
        let mut hint = None;
        let mut out = Vec::with_capacity((nx * ny) as usize);
        for j in 0..ny {
            for i in 0..nx {
                let found = mesh.locate([at(i, w), at(j, h)], hint);
                hint = found.map(|f| f.0).or(hint);
                out.push(found);
            }
        }
        WarpNodes { key: (w, h, step), nx, ny, at: out }
    }
}

/// The live warp's coarse forward map: `phi` at the nodes `p_ij` of the moving frame
/// ([`WarpNodes`]), as `{forward: true, step, width, height, nx, ny, target: [W, H], map:
/// [x, y, ...]}` (row by row, `null, null` outside the mesh; `target`: the size of the
/// image the warp is drawn over, the fixed image's or else the frame's). The page draws
/// the warped frame `O(q) = I(phi^-1(q))` without inverting anything: each grid cell is
/// two triangles with corners `phi(p)` textured from `p`, so inside a triangle `phi^-1` is
/// the affine interpolant of the corners' (piecewise-linear `phi` between nodes 8 px
/// apart). Evaluating `phi` at the located nodes costs a few hundred microseconds, so the
/// map rides on every drag step's answer (`POST /api/update?warp=8`).
pub fn forward_grid(doc: &Doc, step: u32) -> Option<String> {
    let mut out = grid_header(doc, step)?;
    let (nodes, cache) = (doc.forward_nodes_of_frame(step)?, doc.spline().eval_cache());
    out.numbers(
        "map",
        nodes.at.iter().flat_map(|n| match n {
            Some((t, b)) => cache.value(*t, *b),
            None => [f64::NAN, f64::NAN],
        }),
    );
    Some(out.finish())
}

/// [`forward_grid`] for a translation of the current xy selection, as a basis
/// ([`Doc::translate_basis`]): `map` is phi at the nodes for the selection-time positions,
/// and `gx`, `gy` its change per pixel of the drag's `v_x`, `v_y` (`null`s outside the
/// mesh), so the page draws the warped frame of a drag step `v` from
/// `map + v_x gx + v_y gy` at once, before the exact update answers (the answer's mesh and
/// points follow). `None` without a frame or an xy selection.
pub fn translate_grid(doc: &mut Doc, step: u32) -> Option<String> {
    let mut out = grid_header(doc, step)?;
    let nodes = doc.forward_nodes_of_frame(step)?;
    let (w, h, step) = nodes.key;
    let [p0, gx, gy] = doc.translate_basis(w, h, step)?;
    out.numbers("map", p0.iter().flatten().copied());
    out.numbers("gx", gx.iter().flatten().copied());
    out.numbers("gy", gy.iter().flatten().copied());
    Some(out.finish())
}

/// The keys of a forward grid but its numbers.
fn grid_header(doc: &Doc, step: u32) -> Option<JsonObject> {
    let f = doc.frame()?;
    let (w, h) = (f.image.width().max(1), f.image.height().max(1));
    let nodes = doc.forward_nodes(w, h, step.clamp(1, 64));
    let target = doc.fixed().map_or((w, h), |x| (x.image.width(), x.image.height()));
    let mut out = JsonObject::new();
    out.value("forward", &true);
    out.value("step", &nodes.key.2);
    out.value("width", &w);
    out.value("height", &h);
    out.value("nx", &nodes.nx);
    out.value("ny", &nodes.ny);
    out.value("target", &[target.0, target.1]);
    Some(out)
}
