//! What the page draws, computed by the engine (the page never evaluates the spline).
//!
//! All positions are mesh coordinates (= pixel coordinates of the reference image).
//!
//! * `points`: the control points `q_m` (xy), and in 2.5D the scalar control values of
//!   `sigma0` and `sigma1` (`z0`, `z1`);
//! * `mesh`: the deformed reference mesh, each mesh edge as a polyline of
//!   [`EDGE_SAMPLES`] + 1 points of `phi` along it;
//! * `model`: the deformed model `psi(v)` (x, y, z per vertex), and `model_outline`, its
//!   silhouette seen from `+z` as segments;
//! * static parts (with `full`): the control net (pairs of point indices), the C1
//!   quadrilaterals (4 point indices each, thesis ch. 14: `l, r, p, n`), the model's
//!   triangles;
//! * `selection`: anchors, derived points and the relevant non-redundant constraints of the
//!   current edit (indices into the quadrilaterals).

use super::doc::Doc;
use serde_json::{json, Value};

/// Segments per mesh edge in the `mesh` polylines.
pub const EDGE_SAMPLES: usize = 8;

/// Rounds to 1/1000 pixel to keep the JSON short (far below what a screen shows).
fn r3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// The geometry for the page; `full` adds the parts that do not change during edits.
pub fn geometry(doc: &Doc, full: bool) -> Value {
    let s = doc.spline();
    let n = s.num_points();
    let points: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            let p = s.point_f64(i);
            [r3(p[0]), r3(p[1])]
        })
        .collect();
    // Unique mesh edges, sampled along the reference edge and mapped by phi.
    let mesh = s.mesh();
    let mut edges: Vec<(usize, usize)> = Vec::with_capacity(3 * mesh.num_triangles());
    for t in 0..mesh.num_triangles() {
        let v = mesh.triangle(t);
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    edges.dedup();
    let cache = s.eval_cache();
    let mut polylines: Vec<Vec<[f64; 2]>> = Vec::with_capacity(edges.len());
    let mut hint = None;
    for &(a, b) in &edges {
        let (pa, pb) = (mesh.vertex(a), mesh.vertex(b));
        let mut line = Vec::with_capacity(EDGE_SAMPLES + 1);
        for k in 0..=EDGE_SAMPLES {
            let u = k as f64 / EDGE_SAMPLES as f64;
            let p = [pa[0] + u * (pb[0] - pa[0]), pa[1] + u * (pb[1] - pa[1])];
            if let Some((t, beta)) = mesh.locate(p, hint) {
                hint = Some(t);
                let q = cache.value(t, beta);
                line.push([r3(q[0]), r3(q[1])]);
            }
        }
        polylines.push(line);
    }
    let mut out = json!({
        "points": points,
        "mesh": polylines,
    });
    // The z values and the model in 3D are for the z modes' views: sent with `full`, or
    // when the selection is in a z mode (keeps xy drag answers small).
    let zview =
        full || doc.editor().selection().is_some_and(|sel| sel.mode != crate::edit::Mode::Xy);
    if let Some(z) = s.z_layers().filter(|_| zview) {
        let f = |v: &[crate::exact::Rat]| -> Vec<f64> {
            v.iter().map(|x| r3(crate::exact::rat_to_f64(x))).collect()
        };
        out["z0"] = json!(f(&z.z0));
        out["z1"] = json!(f(&z.z1));
        out["z_range"] =
            json!([crate::exact::rat_to_f64(&z.range[0]), crate::exact::rat_to_f64(&z.range[1])]);
    }
    if let Some(v) = doc.deformed_model() {
        // Top view: the silhouette as segments (x0, y0, x1, y1), cheap to stroke; the
        // vertices (x, y, z) for the oblique view.
        let tris = &doc.model().expect("a deformed model has a model").model.triangles;
        let outline: Vec<f64> = crate::render::overlay::silhouette(&v, tris)
            .iter()
            .flat_map(|[a, b]| [r3(a[0]), r3(a[1]), r3(b[0]), r3(b[1])])
            .collect();
        out["model_outline"] = json!(outline);
        if zview {
            let flat: Vec<f64> = v.iter().flat_map(|p| [r3(p[0]), r3(p[1]), r3(p[2])]).collect();
            out["model"] = json!(flat);
        }
    }
    if let Some(sel) = doc.editor().selection() {
        let session = sel.session();
        let redundant: std::collections::BTreeSet<usize> =
            session.redundant().into_iter().collect();
        let relevant: Vec<usize> =
            session.relevant().iter().copied().filter(|c| !redundant.contains(c)).collect();
        out["selection"] = json!({
            "anchors": sel.anchors,
            "derived": sel.derived,
            "constraints": relevant,
        });
    }
    if full {
        let idx = doc.editor().index();
        let mut net: Vec<[usize; 2]> = Vec::new();
        for (a, nb) in idx.net.iter().enumerate() {
            net.extend(nb.iter().filter(|&&b| b > a).map(|&b| [a, b]));
        }
        let quads: Vec<[usize; 4]> = s.quads().iter().map(|q| [q.l, q.p, q.r, q.n]).collect();
        out["net"] = json!(net);
        out["quads"] = json!(quads);
        out["reference"] = json!((0..mesh.num_vertices())
            .map(|v| {
                let p = mesh.vertex(v);
                [r3(p[0]), r3(p[1])]
            })
            .collect::<Vec<_>>());
        if let Some(m) = doc.model() {
            out["model_triangles"] = json!(m.model.triangles);
        }
    }
    out
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
