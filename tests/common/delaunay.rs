//! The classic Delaunay morph, as a baseline: the Delaunay triangulation (spade) of the
//! blended landmarks `L_t = (1 - t) L_A + t S(L_B)` plus a frame ring (`A`'s 4 corners and 4
//! edge midpoints, fixed), one affine map per triangle back to `A` (vertices `L_A`, ring)
//! and to `B` (vertices `L_B`, `S^-1(ring)`), bilinear sampling clamped to the edge, and the
//! cross-dissolve `(1 - t) A + t B`. Pixels outside every triangle keep the nearest
//! triangle's map (the ring spans the frame, so there are none inside it). Grey `f32`.

use spade::{DelaunayTriangulation, Point2, Triangulation};

/// A grey `f32` image.
#[derive(Clone, Debug)]
pub struct Grey {
    pub w: usize,
    pub h: usize,
    pub v: Vec<f32>,
}

impl Grey {
    /// The luminance of any image, in `[0, 1]`.
    pub fn of(img: &image::DynamicImage) -> Grey {
        let g = img.to_luma32f();
        Grey { w: g.width() as usize, h: g.height() as usize, v: g.into_raw() }
    }

    /// Bilinear sample, clamped to the edge.
    pub fn at(&self, p: [f64; 2]) -> f32 {
        let x = p[0].clamp(0.0, (self.w - 1) as f64);
        let y = p[1].clamp(0.0, (self.h - 1) as f64);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.w - 1), (y0 + 1).min(self.h - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let g = |x: usize, y: usize| self.v[y * self.w + x];
        let top = g(x0, y0) + (g(x1, y0) - g(x0, y0)) * fx;
        let bot = g(x0, y1) + (g(x1, y1) - g(x0, y1)) * fx;
        top + (bot - top) * fy
    }
}

/// The frame ring of a `w x h` frame: corners and edge midpoints (pixel centres).
pub fn ring(w: usize, h: usize) -> Vec<[f64; 2]> {
    let (x, y) = ((w - 1) as f64, (h - 1) as f64);
    vec![
        [0.0, 0.0],
        [x / 2.0, 0.0],
        [x, 0.0],
        [x, y / 2.0],
        [x, y],
        [x / 2.0, y],
        [0.0, y],
        [0.0, y / 2.0],
    ]
}

/// The Delaunay triangles of `pts` (indices into `pts`).
pub fn delaunay(pts: &[[f64; 2]]) -> Vec<[usize; 3]> {
    let mut t = DelaunayTriangulation::<Point2<f64>>::new();
    let mut index = Vec::new();
    for p in pts {
        index.push(t.insert(Point2::new(p[0], p[1])).expect("finite").index());
    }
    // spade numbers vertices in insertion order unless points coincide.
    let back: std::collections::HashMap<usize, usize> =
        index.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    t.inner_faces().map(|f| f.vertices().map(|v| back[&v.fix().index()])).collect()
}

/// Barycentric coordinates of `q` in triangle `t` of `pts`.
fn bary(pts: &[[f64; 2]], t: [usize; 3], q: [f64; 2]) -> [f64; 3] {
    let [a, b, c] = t.map(|i| pts[i]);
    let d = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
    let l1 = ((q[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (q[1] - a[1])) / d;
    let l2 = ((b[0] - a[0]) * (q[1] - a[1]) - (q[0] - a[0]) * (b[1] - a[1])) / d;
    [1.0 - l1 - l2, l1, l2]
}

/// The baseline's frame and triangulation.
pub struct Baseline {
    /// The frame (`A`'s size).
    pub frame: Grey,
    /// Vertices in the frame: `L_t` then the ring.
    pub vertices: Vec<[f64; 2]>,
    /// Triangles.
    pub triangles: Vec<[usize; 3]>,
}

/// The Delaunay morph frame at `t` (module docs). `la`: landmarks in `A`; `lb`: in `B`'s own
/// pixels; `s_inv`: `B`-side images of frame points (`S^-1`).
pub fn morph_frame(
    a: &Grey,
    b: &Grey,
    la: &[[f64; 2]],
    lb: &[[f64; 2]],
    s: impl Fn([f64; 2]) -> [f64; 2],
    s_inv: impl Fn([f64; 2]) -> [f64; 2],
    t: f64,
) -> Baseline {
    let ring = ring(a.w, a.h);
    let lt: Vec<[f64; 2]> = la
        .iter()
        .zip(lb)
        .map(|(p, q)| {
            let q = s(*q);
            [(1.0 - t) * p[0] + t * q[0], (1.0 - t) * p[1] + t * q[1]]
        })
        .chain(ring.iter().copied())
        .collect();
    let va: Vec<[f64; 2]> = la.iter().copied().chain(ring.iter().copied()).collect();
    let vb: Vec<[f64; 2]> = lb.iter().copied().chain(ring.iter().map(|&r| s_inv(r))).collect();
    let tris = delaunay(&lt);
    let mut v = vec![0.0f32; a.w * a.h];
    for y in 0..a.h {
        for x in 0..a.w {
            let q = [x as f64, y as f64];
            // The containing triangle, or the least-outside one.
            let (mut best, mut score) = (tris[0], f64::NEG_INFINITY);
            for &tr in &tris {
                let l = bary(&lt, tr, q);
                let m = l[0].min(l[1]).min(l[2]);
                if m > score {
                    (best, score) = (tr, m);
                }
                if m >= 0.0 {
                    break;
                }
            }
            let l = bary(&lt, best, q);
            let pa = [0, 1].map(|k| (0..3).map(|j| l[j] * va[best[j]][k]).sum::<f64>());
            let pb = [0, 1].map(|k| (0..3).map(|j| l[j] * vb[best[j]][k]).sum::<f64>());
            v[y * a.w + x] = (1.0 - t as f32) * a.at(pa) + t as f32 * b.at(pb);
        }
    }
    Baseline { frame: Grey { w: a.w, h: a.h, v }, vertices: lt, triangles: tris }
}

/// The crease figure: the mean jump of the gradient magnitude across the interior edges of
/// `tris` (over `verts`) in excess of its smooth variation: with `G = |grad I|` (central
/// differences) at `p + k d n` (`n` the edge normal, `d` pixels),
/// `|(G_1 - G_-1) - ((G_3 - G_1) + (G_-1 - G_-3)) / 2|`, which is 0 where `G` varies linearly
/// and the jump where `G` steps at the edge (a piecewise-affine warp's crease); sampled at 9
/// points per edge (fractions 0.1 .. 0.9). Points closer than 2 px to the border are skipped.
pub fn crease(img: &Grey, verts: &[[f64; 2]], tris: &[[usize; 3]], d: f64) -> f64 {
    let (w, h) = (img.w, img.h);
    let mut g = Grey { w, h, v: vec![0.0; w * h] };
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let gx = (img.v[i + 1] - img.v[i - 1]) / 2.0;
            let gy = (img.v[i + w] - img.v[i - w]) / 2.0;
            g.v[i] = gx.hypot(gy);
        }
    }
    let mut count = std::collections::HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (i, j) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
            *count.entry((i, j)).or_insert(0) += 1;
        }
    }
    let margin = 2.0;
    let inside = |p: [f64; 2]| {
        p[0] >= margin
            && p[1] >= margin
            && p[0] <= w as f64 - 1.0 - margin
            && p[1] <= h as f64 - 1.0 - margin
    };
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (&(i, j), &c) in &count {
        if c != 2 {
            continue;
        }
        let (p, q) = (verts[i], verts[j]);
        let len = (q[0] - p[0]).hypot(q[1] - p[1]);
        if len < 1e-9 {
            continue;
        }
        let nrm = [-(q[1] - p[1]) / len, (q[0] - p[0]) / len];
        for k in 1..10 {
            let f = k as f64 / 10.0;
            let m = [p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1])];
            let at = |k: f64| [m[0] + k * d * nrm[0], m[1] + k * d * nrm[1]];
            let pts = [at(-3.0), at(-1.0), at(1.0), at(3.0)];
            if pts.iter().all(|&p| inside(p)) {
                let gv = pts.map(|p| f64::from(g.at(p)));
                let jump = gv[2] - gv[1];
                let sides = ((gv[3] - gv[2]) + (gv[1] - gv[0])) / 2.0;
                sum += (jump - sides).abs();
                n += 1;
            }
        }
    }
    sum / n.max(1) as f64
}
