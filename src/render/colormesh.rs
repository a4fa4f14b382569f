//! Drawing a [`ColorMesh`] into a pixmap, antialiased and without seams.
//!
//! # Convention
//!
//! Mesh point `(x, y)` lands at the centre of pixel `(x, y)` (x right, y down), as everywhere
//! in [`crate::warp`]: the tiny-skia path goes through `(x + 0.5, y + 0.5)`. A mesh made by
//! [`ColorMesh::from_image`] therefore covers the image's pixel centres, and the outermost
//! ring of pixels is only half covered (a quarter at the corners).
//!
//! # Math
//!
//! The drawing is `out = field * coverage over background` (premultiplied source-over):
//!
//! * **coverage** is tiny-skia's antialiased coverage of the union of all triangles, filled
//!   as *one* path with the non-zero rule. The path is the sum of the triangles' boundaries,
//!   each triangle taken with positive orientation (so folded, inverted triangles add to the
//!   winding instead of cancelling), with edges traversed both ways removed: its winding
//!   number at a point is the number of triangles covering it. For a fold-free mesh that is
//!   just the mesh border, which keeps the fill cheap (one path of 400,000 triangle edges
//!   takes tiny-skia ~0.1 s at 512x512; the border a few ms);
//! * **field** is a color per pixel centre `q`, computed here in parallel over bands of rows:
//!   for a triangle `p0 p1 p2` the barycentric coordinates of `q` are
//!   `l_i = E_i(q) / E(p0, p1, p2)`, with `E_i` the edge function of the edge opposite `p_i`.
//!   If all `l_i >= -1e-9` the pixel is inside and gets `sum l_i c_i` (per-vertex colors
//!   `c_i`, interpolated premultiplied) or the triangle's flat color. A pixel centre within
//!   [`BORDER`] pixels outside every triangle (an antialiased border pixel) gets the color of
//!   the nearest point of the nearest triangle, so border pixels are not darkened by a
//!   transparent field. Where triangles overlap (folds) the **later triangle in the list
//!   wins**; inside always beats border. Pixels near no triangle stay transparent. The
//!   nearest point lies on the union's boundary, hence on the outline (below), so only the
//!   triangles with an edge on the outline are searched: a few hundred of a fold-free
//!   mesh's 100,000.
//!
//! The field is then painted through the path with a [`Pattern`] shader (nearest filter,
//! identity transform), so every pixel with full coverage gets exactly its field color.
//!
//! # Why this design
//!
//! tiny-skia cannot draw per-vertex colors (no Gouraud triangles or mesh gradients; see
//! linebender/tiny-skia issue #53), and filling adjacent triangles one by one with
//! antialiasing leaves seams: a pixel on a shared edge covered half by each triangle ends up
//! `1 - (1 - 1/2)^2 = 3/4` opaque (conflation artefacts). Filling the union once computes the
//! coverage of the whole mesh, so inner edges are invisible, and the colors come from the
//! field, which is exact at pixel centres.

use rayon::prelude::*;
use tiny_skia::{
    ColorU8, FillRule, FilterQuality, Paint, PathBuilder, Pattern, Pixmap, PremultipliedColorU8,
    SpreadMode, Transform,
};

use crate::warp::colormesh::{ColorMesh, ColorMeshError, Colors};

/// How far outside the triangles (in pixels, from the pixel centre) the color field is
/// extended for antialiased border pixels; more than `sqrt(2) / 2`, the farthest a pixel
/// centre can be from a path crossing its pixel.
pub const BORDER: f64 = 1.0;
/// Rows of the color field per parallel band.
const BAND: usize = 16;
/// Barycentric tolerance of the inside test (points on shared edges are inside both).
const EPS: f64 = 1e-9;
/// Path coordinates are clamped to this magnitude (f32 range; only affects triangles with a
/// vertex more than 10^12 pixels away).
const FAR: f64 = 1e12;

/// Draws `mesh` on a new `width x height` pixmap filled with `background` (straight RGBA8;
/// `None`: transparent). See the module docs for the convention.
pub fn rasterize(
    mesh: &ColorMesh,
    width: u32,
    height: u32,
    background: Option<[u8; 4]>,
) -> Result<Pixmap, ColorMeshError> {
    let mut pm = Pixmap::new(width, height).ok_or(ColorMeshError::CanvasSize { width, height })?;
    if let Some([r, g, b, a]) = background {
        pm.pixels_mut().fill(ColorU8::from_rgba(r, g, b, a).premultiply());
    }
    rasterize_into(mesh, &mut pm)?;
    Ok(pm)
}

/// Draws `mesh` over the current content of `pixmap` (premultiplied source-over). The mesh
/// is validated first.
pub fn rasterize_into(mesh: &ColorMesh, pixmap: &mut Pixmap) -> Result<(), ColorMeshError> {
    mesh.validate()?;
    let (w, h) = (pixmap.width(), pixmap.height());
    let (loops, border) = outline(mesh, w, h);
    let field = color_field(mesh, w, h, &border)
        .ok_or(ColorMeshError::CanvasSize { width: w, height: h })?;
    let pt = |v: u32| {
        let p = mesh.vertices[v as usize];
        ((p[0].clamp(-FAR, FAR) + 0.5) as f32, (p[1].clamp(-FAR, FAR) + 0.5) as f32)
    };
    let mut pb = PathBuilder::new();
    for lp in loops {
        let (x, y) = pt(lp[0]);
        pb.move_to(x, y);
        for &v in &lp[1..] {
            let (x, y) = pt(v);
            pb.line_to(x, y);
        }
        pb.close();
    }
    let Some(path) = pb.finish() else { return Ok(()) };
    let paint = Paint {
        shader: Pattern::new(
            field.as_ref(),
            SpreadMode::Pad,
            FilterQuality::Nearest,
            1.0,
            Transform::identity(),
        ),
        anti_alias: true,
        ..Paint::default()
    };
    pixmap.fill_path(&path, &paint, FillRule::Winding, Transform::identity(), None);
    Ok(())
}

/// The outline of the drawn triangles (non-degenerate, near the canvas), as closed loops of
/// vertex indices: the sum of the triangles' boundaries, each triangle taken with positive
/// orientation, where an edge traversed both ways cancels. Its winding number is, at every
/// point, the number of drawn triangles covering it, so filling it (non-zero) fills exactly
/// the union; a fold-free mesh reduces to its border, which tiny-skia fills far faster than
/// every triangle.
///
/// Also returns, per triangle, whether one of its edges is on the outline (a *border
/// triangle*). The union's boundary lies on the outline (the coverage count changes only
/// across it), so the point of the union nearest to an uncovered pixel centre lies on a
/// border triangle: the border pass of [`fill_band`] needs only those.
fn outline(mesh: &ColorMesh, w: u32, h: u32) -> (Vec<Vec<u32>>, Vec<bool>) {
    // Undirected edges (low, high) with +1 for low -> high and -1 for high -> low, bucketed
    // by `low` (counting sort: offsets `start`).
    let nv = mesh.vertices.len();
    let mut start = vec![0usize; nv + 1];
    let mut edges: Vec<(u32, u32, i32)> = Vec::with_capacity(3 * mesh.triangles.len());
    for t in &mesh.triangles {
        let p = t.map(|i| mesh.vertices[i as usize]);
        let area = edge(p[0], p[1], p[2]);
        if area == 0.0 || !overlaps(&p, w, h, 1.0) {
            continue;
        }
        let [a, b, c] = if area > 0.0 { *t } else { [t[0], t[2], t[1]] };
        for (u, v) in [(a, b), (b, c), (c, a)] {
            edges.push((u.min(v), u.max(v), if u < v { 1 } else { -1 }));
            start[u.min(v) as usize + 1] += 1;
        }
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    let mut bucket = vec![(0u32, 0i32); edges.len()];
    let mut fill = start.clone();
    for &(lo, hi, s) in &edges {
        bucket[fill[lo as usize]] = (hi, s);
        fill[lo as usize] += 1;
    }
    // Net directed edges (from, to), sorted by `from`.
    let mut left: Vec<(u32, u32)> = Vec::new();
    for lo in 0..nv {
        let b = &mut bucket[start[lo]..start[lo + 1]];
        b.sort_unstable_by_key(|e| e.0);
        for run in b.chunk_by(|x, y| x.0 == y.0) {
            let net: i32 = run.iter().map(|e| e.1).sum();
            let e = if net > 0 { (lo as u32, run[0].0) } else { (run[0].0, lo as u32) };
            left.extend(std::iter::repeat_n(e, net.unsigned_abs() as usize));
        }
    }
    left.sort_unstable();
    let mut on_outline: Vec<(u32, u32)> = left.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
    on_outline.sort_unstable();
    on_outline.dedup();
    let border = mesh
        .triangles
        .iter()
        .map(|t| {
            [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
                .iter()
                .any(|&(a, b)| on_outline.binary_search(&(a.min(b), a.max(b))).is_ok())
        })
        .collect();
    // Every vertex has as many net edges in as out, so a walk along unused edges can only
    // get stuck where it started: each walk is a closed loop.
    let mut used = vec![false; left.len()];
    let mut cursor = 0;
    let mut loops = Vec::new();
    while let Some(first) = (cursor..left.len()).find(|&i| !used[i]) {
        cursor = first;
        let mut lp = vec![left[first].0];
        let mut e = first;
        loop {
            used[e] = true;
            let at = left[e].1;
            let from = left.partition_point(|x| x.0 < at);
            match (from..left.len()).take_while(|&i| left[i].0 == at).find(|&i| !used[i]) {
                Some(next) => {
                    lp.push(at);
                    e = next;
                }
                None => break,
            }
        }
        loops.push(lp);
    }
    (loops, border)
}

/// Edge function `(b - a) x (q - a)`: twice the signed area of `a b q`.
fn edge(a: [f64; 2], b: [f64; 2], q: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])
}

/// Whether the bounding box of `p`, grown by `margin`, meets the pixel centres of the canvas.
fn overlaps(p: &[[f64; 2]; 3], w: u32, h: u32, margin: f64) -> bool {
    let lo = |a: usize| p.iter().map(|q| q[a]).fold(f64::INFINITY, f64::min) - margin;
    let hi = |a: usize| p.iter().map(|q| q[a]).fold(f64::NEG_INFINITY, f64::max) + margin;
    hi(0) >= 0.0 && lo(0) <= f64::from(w) - 1.0 && hi(1) >= 0.0 && lo(1) <= f64::from(h) - 1.0
}

/// Colors to interpolate: per-vertex premultiplied floats, or per-triangle premultiplied.
enum Shade {
    Vertex(Vec<[f32; 4]>),
    Flat(Vec<PremultipliedColorU8>),
}

impl Shade {
    fn new(colors: &Colors) -> Shade {
        match colors {
            Colors::PerVertex(c) => Shade::Vertex(
                c.iter()
                    .map(|&[r, g, b, a]| {
                        let s = f32::from(a) / 255.0;
                        [f32::from(r) * s, f32::from(g) * s, f32::from(b) * s, f32::from(a)]
                    })
                    .collect(),
            ),
            Colors::PerTriangle(c) => Shade::Flat(
                c.iter()
                    .map(|&[r, g, b, a]| ColorU8::from_rgba(r, g, b, a).premultiply())
                    .collect(),
            ),
        }
    }

    /// The color of triangle `t` (vertices `tri`) at barycentric coordinates `l`.
    fn at(&self, t: usize, tri: [u32; 3], l: [f64; 3]) -> PremultipliedColorU8 {
        match self {
            Shade::Flat(c) => c[t],
            Shade::Vertex(c) => {
                let mut acc = [0f32; 4];
                for (k, &v) in tri.iter().enumerate() {
                    let lk = l[k] as f32;
                    for (a, cv) in acc.iter_mut().zip(c[v as usize]) {
                        *a += lk * cv;
                    }
                }
                // Round half up (no libm call): the values are non-negative.
                let q = acc.map(|v| (v.clamp(0.0, 255.0) + 0.5) as u8);
                let a = q[3];
                PremultipliedColorU8::from_rgba(q[0].min(a), q[1].min(a), q[2].min(a), a)
                    .unwrap_or(PremultipliedColorU8::TRANSPARENT)
            }
        }
    }
}

/// The color field of a valid mesh on a `w x h` canvas (see the module docs), or `None` if
/// the size is not a valid pixmap. `border` flags the border triangles ([`outline`]).
fn color_field(mesh: &ColorMesh, w: u32, h: u32, border: &[bool]) -> Option<Pixmap> {
    let mut field = Pixmap::new(w, h)?;
    let (wu, hu) = (w as usize, h as usize);
    let nbands = hu.div_ceil(BAND);
    // Bin the triangles (in order, so later still wins) by the bands their grown box meets.
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); nbands];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let p = tri.map(|i| mesh.vertices[i as usize]);
        if edge(p[0], p[1], p[2]) == 0.0 || !overlaps(&p, w, h, BORDER) {
            continue;
        }
        let ys = p.map(|q| q[1]);
        let y0 = (ys.iter().fold(f64::INFINITY, |a, &b| a.min(b)) - BORDER).ceil().max(0.0);
        let y1 = (ys.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b)) + BORDER).floor();
        let y1 = y1.min(hu as f64 - 1.0);
        for bin in &mut bins[y0 as usize / BAND..=y1 as usize / BAND] {
            bin.push(t as u32);
        }
    }
    let shade = Shade::new(&mesh.colors);
    field
        .pixels_mut()
        .par_chunks_mut(wu * BAND)
        .zip(bins.par_iter())
        .enumerate()
        .for_each(|(b, (rows, tris))| fill_band(mesh, &shade, tris, border, b * BAND, wu, rows));
    Some(field)
}

/// Fills the rows `y0 ..` of the field (`rows`, `w` pixels each) from the triangles `tris`:
/// first the pixel centres inside triangles (later wins), then the border pixels left (the
/// nearest of the border triangles, flagged in `border`, wins).
fn fill_band(
    mesh: &ColorMesh,
    shade: &Shade,
    tris: &[u32],
    border: &[bool],
    y0: usize,
    w: usize,
    rows: &mut [PremultipliedColorU8],
) {
    let nrows = rows.len() / w;
    // Pixel columns and band rows of `p`'s bounding box grown by `margin`. (Truncating
    // casts after clamping stand in for ceil / floor, which are library calls.)
    let pixels = |p: &[[f64; 2]; 3], margin: f64| {
        let span = |a: usize, n: usize, off: usize| {
            let lo = p.iter().map(|q| q[a]).fold(f64::INFINITY, f64::min) - margin - off as f64;
            let hi = p.iter().map(|q| q[a]).fold(f64::NEG_INFINITY, f64::max) + margin - off as f64;
            // For x >= 0: ceil(x) is trunc(x), plus 1 if x has a fraction; floor(x) + 1 is
            // trunc(x) + 1.
            let lo = lo.clamp(0.0, n as f64);
            let lo = lo as usize + usize::from((lo as usize as f64) < lo);
            let hi = if hi < 0.0 { 0 } else { (hi.min(n as f64 - 1.0) as usize) + 1 };
            lo..hi.max(lo)
        };
        (span(0, w, 0), span(1, nrows, y0))
    };
    let triangle = |t: u32| {
        let tri = mesh.triangles[t as usize];
        (t as usize, tri, tri.map(|i| mesh.vertices[i as usize]))
    };
    let mut inside = vec![false; rows.len()];
    for (t, tri, p) in tris.iter().map(|&t| triangle(t)) {
        let inv = 1.0 / edge(p[0], p[1], p[2]);
        let (xs, ys) = pixels(&p, 0.0);
        for (y, x) in ys.flat_map(|y| xs.clone().map(move |x| (y, x))) {
            let q = [x as f64, (y0 + y) as f64];
            let l =
                [edge(p[1], p[2], q), edge(p[2], p[0], q), edge(p[0], p[1], q)].map(|e| e * inv);
            if l.iter().all(|&v| v >= -EPS) {
                rows[y * w + x] = shade.at(t, tri, l.map(|v| v.max(0.0)));
                inside[y * w + x] = true;
            }
        }
    }
    if inside.iter().all(|&b| b) {
        return; // no border pixel in this band (the mesh covers it)
    }
    // Squared distance of the border color stored so far.
    let mut dist2 = vec![f64::INFINITY; rows.len()];
    for (t, tri, p) in tris.iter().filter(|&&t| border[t as usize]).map(|&t| triangle(t)) {
        let (xs, ys) = pixels(&p, BORDER);
        for (y, x) in ys.flat_map(|y| xs.clone().map(move |x| (y, x))) {
            let i = y * w + x;
            if inside[i] {
                continue;
            }
            let (d2, l) = nearest(&p, [x as f64, (y0 + y) as f64]);
            if d2 <= BORDER * BORDER && d2 < dist2[i] {
                rows[i] = shade.at(t, tri, l);
                dist2[i] = d2;
            }
        }
    }
}

/// Squared distance from `q` to the boundary of triangle `p` and the barycentric
/// coordinates of the nearest boundary point.
fn nearest(p: &[[f64; 2]; 3], q: [f64; 2]) -> (f64, [f64; 3]) {
    let mut best = (f64::INFINITY, [1.0, 0.0, 0.0]);
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        let (a, b) = (p[i], p[j]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let s = if len2 > 0.0 {
            (((q[0] - a[0]) * dx + (q[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (ex, ey) = (q[0] - a[0] - s * dx, q[1] - a[1] - s * dy);
        let d2 = ex * ex + ey * ey;
        if d2 < best.0 {
            let mut l = [0.0; 3];
            (l[i], l[j]) = (1.0 - s, s);
            best = (d2, l);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp::colormesh::ColorMode;
    use image::{DynamicImage, Rgba, RgbaImage};

    /// An opaque image with no smooth structure (every pixel differs from its neighbours).
    fn noisy(w: u32, h: u32) -> RgbaImage {
        RgbaImage::from_fn(w, h, |x, y| {
            let v = (x * 7919 + y * 104_729) ^ (x * y * 31);
            Rgba([v as u8, (v >> 8) as u8, (v >> 3) as u8 ^ 0x5a, 255])
        })
    }

    fn rgba(pm: &Pixmap, x: u32, y: u32) -> [u8; 4] {
        let c = pm.pixel(x, y).expect("inside").demultiply();
        [c.red(), c.green(), c.blue(), c.alpha()]
    }

    fn flat(vertices: Vec<[f64; 2]>, triangles: Vec<[u32; 3]>, c: Vec<[u8; 4]>) -> ColorMesh {
        ColorMesh { vertices, triangles, colors: Colors::PerTriangle(c) }
    }

    #[test]
    fn per_vertex_step_1_reproduces_the_image() {
        let (w, h) = (40, 30);
        let img = noisy(w, h);
        let m =
            ColorMesh::from_image(&DynamicImage::ImageRgba8(img.clone()), 1, ColorMode::PerVertex)
                .unwrap();
        let pm = rasterize(&m, w, h, None).unwrap();
        for y in 0..h {
            for x in 0..w {
                let (got, want) = (rgba(&pm, x, y), img.get_pixel(x, y).0);
                let ring = [x == 0 || x == w - 1, y == 0 || y == h - 1];
                match ring.iter().filter(|&&r| r).count() {
                    // Fully covered: exact.
                    0 => assert_eq!(got, want, "({x}, {y})"),
                    // Outer ring: half (corners a quarter) covered, right color.
                    n => {
                        let cov = if n == 1 { 128 } else { 64 };
                        assert!(got[3].abs_diff(cov) <= 2, "({x}, {y}) alpha {}", got[3]);
                        for c in 0..3 {
                            assert!(got[c].abs_diff(want[c]) <= 2, "({x}, {y}) {got:?} {want:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn flat_step_1_is_close_on_smooth_images() {
        // Slopes (4, 0), (0, 3), (2, 2) per pixel; a flat triangle's mean is its centroid's
        // value, at most 2/3 px from each of its corners in x and y: error <= (|gx| + |gy|)
        // 2/3, plus 1 for the rounding of the mean.
        let slopes = [[4.0, 0.0], [0.0, 3.0], [2.0, 2.0]];
        let img = RgbaImage::from_fn(40, 30, |x, y| {
            Rgba([(4 * x) as u8, (3 * y) as u8, (2 * x + 2 * y) as u8, 255])
        });
        let m = ColorMesh::from_image(&DynamicImage::ImageRgba8(img.clone()), 1, ColorMode::Flat)
            .unwrap();
        let pm = rasterize(&m, 40, 30, Some([0, 0, 0, 255])).unwrap();
        let mut worst = 0.0f64;
        for y in 1..29 {
            for x in 1..39 {
                let (got, want) = (rgba(&pm, x, y), img.get_pixel(x, y).0);
                assert_eq!(got[3], 255);
                for (c, g) in slopes.iter().enumerate() {
                    let err = f64::from(got[c].abs_diff(want[c]));
                    assert!(err <= (g[0] + g[1]) * 2.0 / 3.0 + 1.0, "({x}, {y}) {got:?} {want:?}");
                    worst = worst.max(err);
                }
            }
        }
        assert!(worst > 0.0, "flat colors are means, not samples");
    }

    #[test]
    fn a_shifted_mesh_moves_features_exactly() {
        let (w, h) = (40, 30);
        let img = noisy(w, h);
        let mut m =
            ColorMesh::from_image(&DynamicImage::ImageRgba8(img.clone()), 1, ColorMode::PerVertex)
                .unwrap();
        for v in &mut m.vertices {
            (v[0], v[1]) = (v[0] + 3.0, v[1] + 2.0);
        }
        let bg = [10, 20, 30, 255];
        let pm = rasterize(&m, w, h, Some(bg)).unwrap();
        for y in 0..h {
            for x in 0..w {
                let got = rgba(&pm, x, y);
                if x >= 4 && y >= 3 {
                    assert_eq!(got, img.get_pixel(x - 3, y - 2).0, "({x}, {y})");
                } else if x < 3 || y < 2 {
                    assert_eq!(got, bg, "({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn slanted_edges_are_antialiased_without_dark_fringes() {
        let m = flat(
            vec![[2.0, 2.0], [27.0, 9.0], [8.0, 25.0]],
            vec![[0, 1, 2]],
            vec![[200, 40, 90, 255]],
        );
        let pm = rasterize(&m, 30, 30, None).unwrap();
        let partial: Vec<[u8; 4]> = (0..30)
            .flat_map(|y| (0..30).map(move |x| (x, y)))
            .map(|(x, y)| rgba(&pm, x, y))
            .filter(|c| c[3] > 0 && c[3] < 255)
            .collect();
        assert!(partial.len() > 20, "{} partially covered pixels", partial.len());
        // Total coverage is the triangle's area (266.5 px^2): border pixels whose centre is
        // outside the triangle still get their share (a transparent field there would lose
        // about half a pixel-row along the perimeter, ~9 px^2).
        let total: f64 = pm.pixels().iter().map(|p| f64::from(p.alpha()) / 255.0).sum();
        assert!((total - 266.5).abs() < 1.5, "coverage {total}");
        // The border pixels carry the triangle's color, only less opaque (premultiplied
        // rounding allows a small error at low alpha).
        for c in partial.iter().filter(|c| c[3] >= 32) {
            for (k, want) in [200u8, 40, 90].iter().enumerate() {
                assert!(c[k].abs_diff(*want) <= 8, "{c:?}");
            }
        }
    }

    #[test]
    fn shared_slanted_edges_leave_no_seam() {
        // A quad split along a slanted diagonal, same color on both sides: opaque everywhere
        // inside, in particular along the diagonal.
        let v = vec![[1.0, 1.0], [20.0, 3.0], [18.0, 17.0], [2.0, 15.0]];
        let c = [90, 160, 30, 255];
        let m = flat(v, vec![[0, 1, 2], [0, 2, 3]], vec![c, c]);
        let pm = rasterize(&m, 22, 20, None).unwrap();
        for k in 1..16 {
            let t = f64::from(k) / 16.0;
            let (x, y) = (1.0 + 17.0 * t, 1.0 + 16.0 * t);
            assert_eq!(rgba(&pm, x.round() as u32, y.round() as u32), c, "at ({x}, {y})");
        }
    }

    #[test]
    fn folds_later_triangle_wins_and_inverted_triangles_still_fill() {
        // Two overlapping triangles of opposite orientation.
        let v = vec![[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]];
        let (red, blue) = ([255, 0, 0, 255], [0, 0, 255, 255]);
        let m = flat(v.clone(), vec![[0, 1, 2], [0, 3, 1]], vec![red, blue]);
        let pm = rasterize(&m, 12, 12, None).unwrap();
        assert_eq!(rgba(&pm, 6, 2), blue, "overlap: the later triangle");
        assert_eq!(rgba(&pm, 2, 6), red);
        assert_eq!(rgba(&pm, 8, 6), blue);
        let m = flat(v, vec![[0, 3, 1], [0, 1, 2]], vec![blue, red]);
        let pm = rasterize(&m, 12, 12, None).unwrap();
        assert_eq!(rgba(&pm, 6, 2), red);
    }

    #[test]
    fn per_vertex_colors_interpolate_linearly() {
        let v = vec![[0.0, 0.0], [20.0, 0.0], [0.0, 20.0]];
        let c = vec![[0, 0, 0, 255], [200, 0, 0, 255], [0, 100, 0, 255]];
        let m = ColorMesh { vertices: v, triangles: vec![[0, 1, 2]], colors: Colors::PerVertex(c) };
        let pm = rasterize(&m, 24, 24, None).unwrap();
        assert_eq!(rgba(&pm, 5, 5), [50, 25, 0, 255]);
        assert_eq!(rgba(&pm, 10, 4), [100, 20, 0, 255]);
    }

    #[test]
    fn outline_is_the_border_without_folds_and_keeps_fold_edges() {
        let m = ColorMesh::from_image(&DynamicImage::ImageRgba8(noisy(6, 5)), 1, ColorMode::Flat)
            .unwrap();
        let (loops, _) = outline(&m, 6, 5);
        assert_eq!(loops.len(), 1);
        let mut border = loops[0].clone();
        border.sort_unstable();
        let want: Vec<u32> =
            (0..30).filter(|v| v % 6 == 0 || v % 6 == 5 || v / 6 % 4 == 0).collect();
        assert_eq!(border, want);
        // A fold: the second triangle is inverted; the shared edge 0-1 is kept (twice).
        let v = vec![[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]];
        let m = flat(v, vec![[0, 1, 2], [0, 3, 1]], vec![[0; 4]; 2]);
        let edges: usize = outline(&m, 12, 12).0.iter().map(Vec::len).sum();
        assert_eq!(edges, 6);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

        /// The border pass over the border triangles only gives the field of the pass over
        /// every triangle, also with folds (jittered grids fold often) and off-canvas parts.
        #[test]
        fn border_triangles_suffice_for_the_border_pass(
            jitter in proptest::collection::vec((-4.0f64..4.0, -4.0f64..4.0), 36),
            shift in (-6.0f64..6.0, -6.0f64..6.0),
        ) {
            let vertices: Vec<[f64; 2]> = (0..36)
                .map(|k| {
                    let (dx, dy) = jitter[k];
                    [(k % 6) as f64 * 4.0 + 2.0 + dx + shift.0, (k / 6) as f64 * 4.0 + 2.0 + dy + shift.1]
                })
                .collect();
            let mut triangles = Vec::new();
            for r in 0..5u32 {
                for c in 0..5u32 {
                    let v = r * 6 + c;
                    triangles.push([v, v + 1, v + 7]);
                    triangles.push([v, v + 7, v + 6]);
                }
            }
            let colors = (0..36u32).map(|k| [(k * 7) as u8, (k * 31) as u8, (k * 13) as u8, 255]);
            let m = ColorMesh { vertices, triangles, colors: Colors::PerVertex(colors.collect()) };
            let (w, h) = (26, 25);
            let (_, border) = outline(&m, w, h);
            let fast = color_field(&m, w, h, &border).unwrap();
            let full = color_field(&m, w, h, &vec![true; m.triangles.len()]).unwrap();
            for (i, (a, b)) in fast.pixels().iter().zip(full.pixels()).enumerate() {
                let (a, b) = ([a.red(), a.green(), a.blue(), a.alpha()], [b.red(), b.green(), b.blue(), b.alpha()]);
                proptest::prop_assert!(
                    a.iter().zip(&b).all(|(x, y)| x.abs_diff(*y) <= 1),
                    "pixel ({}, {}): {:?} vs {:?}", i % w as usize, i / w as usize, a, b
                );
            }
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let mut m = flat(vec![[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]], vec![[0, 1, 2]], vec![[0; 4]]);
        assert!(matches!(rasterize(&m, 0, 10, None), Err(ColorMeshError::CanvasSize { .. })));
        m.triangles[0][1] = 3;
        assert!(matches!(rasterize(&m, 10, 10, None), Err(ColorMeshError::Index { .. })));
        // Far-away and degenerate triangles are harmless.
        let m = flat(
            vec![[0.0, 0.0], [1e300, 0.0], [0.0, 5.0], [3.0, 3.0]],
            vec![[0, 1, 2], [0, 3, 3]],
            vec![[9, 9, 9, 255]; 2],
        );
        let pm = rasterize(&m, 10, 10, None).unwrap();
        assert_eq!(rgba(&pm, 1, 1), [9, 9, 9, 255]);
    }
}
