//! Preimages of every pixel centre of an output image, fast and with an error bound.
//!
//! Solving `phi(p) = q` by Newton at each of 16 million pixels costs seconds. Evaluating
//! `phi` forward is much cheaper, so this module covers the reference domain with a lattice
//! of squares ([`RemapOptions::cell`] pixels, split in two triangles each), maps the
//! lattice forward, and rasterizes the deformed triangles into the output: a pixel centre
//! `q` inside the image `(Q0, Q1, Q2)` of a lattice triangle `(P0, P1, P2)` gets
//! `p~ = sum lambda_i P_i`, with `lambda` the barycentric coordinates of `q` in
//! `(Q0, Q1, Q2)`; that is, `p~ = L^-1(q)` for the affine interpolant `L` of `phi`.
//!
//! **The bound.** For a point `p` of a triangle and `|D^2 phi[u, u]| <= M |u|^2` on it
//! (Taylor with integral remainder; `phi` is C1 and piecewise polynomial, so this holds
//! across mesh edges too):
//!
//! ```text
//!   |phi(p) - L(p)| <= M/2 sum_i lambda_i |P_i - p|^2 <= M R^2 / 2 = M (a^2 + b^2) / 8
//! ```
//!
//! for a right triangle with legs `a, b` (circumradius `R`). With `A` the linear part of
//! `L` and `|J - A| <= M diam` on the triangle, `|J^-1| <= K = |A^-1| / (1 - |A^-1| M diam)`,
//! so `|p~ - phi^-1(q)| <= K M (a^2 + b^2) / 8` (to first order in this tiny defect; reported
//! times 1.01). A triangle is rasterized when its bound is at most the tolerance (0.01 px by
//! default); otherwise its square is split in four, down to squares of 1/4 px, which are
//! always accepted and their bound reported. `M` comes from
//! [`EvalCache::second_derivative_bounds_uniform`](crate::spline::eval::EvalCache::second_derivative_bounds_uniform)
//! over small sub-triangles, kept in a grid of buckets over the reference domain.
//!
//! The bound also certifies `det J != 0` on the piece (`|J - A| < |A^-1|^-1`), so a piece
//! keeps one orientation throughout: pieces with `det J > 0` everywhere in the output mean
//! `phi` does not fold there.
//!
//! **Borders and folds.** Squares with a corner outside the mesh are split to the smallest
//! size; the output pixels around such pieces are then solved by Newton ([`InverseMap`])
//! one by one, as are smallest pieces that still miss the bound. Pieces with reversed
//! orientation (`det J < 0`) and smallest pieces across a crease (`det J = 0`) are drawn and
//! counted as folded ([`RemapStats::folded`], [`RemapStats::fold_box`]). Where `phi` is not
//! injective a pixel has several preimages and shows the layer rasterized last (lattice
//! order, row by row), never a blend.
//!
//! Coordinates: output pixel `(i, j)` is the point `q = (i, j)` of the deformed plane;
//! preimages are in mesh (input pixel) units.

use super::inverse::{InverseMap, InverseOptions, Preimage};
use super::sample::fast_floor;
use crate::spline::Spline;
use rayon::prelude::*;

/// Options of the fast preimage computation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RemapOptions {
    /// Newton options; `inverse.tolerance` is the guaranteed error bound (pixels).
    pub inverse: InverseOptions,
    /// Side of the coarse lattice squares (reference pixels; 32 by default).
    pub cell: f64,
    /// Rows of output per band (bands are processed in parallel; 32 by default).
    pub band_rows: u32,
}

impl Default for RemapOptions {
    fn default() -> Self {
        RemapOptions { inverse: InverseOptions::default(), cell: 32.0, band_rows: 32 }
    }
}

/// Smallest lattice square (reference pixels).
const MIN_SQUARE: f64 = 0.0625;

/// What a preimage computation found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RemapStats {
    /// Pixels without a preimage (outside the deformed mesh).
    pub outside: usize,
    /// Largest error bound over the pixels that have a preimage (pixels).
    pub max_error_bound: f64,
    /// Pixels solved one by one by Newton (near the border of the deformed mesh).
    pub newton_solves: usize,
    /// Pixels filled from the forward lattice under a proven bound.
    pub interpolated: usize,
    /// Pixels filled from pieces where `phi` folds (orientation reversed); they are not
    /// counted in `max_error_bound`.
    pub folded: usize,
    /// Output box `[x0, y0, x1, y1]` (pixels, inclusive) of the folded pieces drawn.
    pub fold_box: Option<[u32; 4]>,
}

impl RemapStats {
    /// Adds another band's figures.
    pub fn merge(&mut self, o: &RemapStats) {
        self.outside += o.outside;
        self.max_error_bound = self.max_error_bound.max(o.max_error_bound);
        self.newton_solves += o.newton_solves;
        self.interpolated += o.interpolated;
        self.folded += o.folded;
        self.fold_box = match (self.fold_box, o.fold_box) {
            (Some(a), Some(b)) => {
                Some([a[0].min(b[0]), a[1].min(b[1]), a[2].max(b[2]), a[3].max(b[3])])
            }
            (a, b) => a.or(b),
        };
    }
}

/// A box of the reference domain `(lo, hi)` and a bound on `|D^2 phi|` in it.
type BoxBound = ([f64; 2], [f64; 2], f64);

/// Local bounds on `D^2 phi` and border flags in a grid of buckets over the reference domain.
struct CurvatureGrid {
    lo: [f64; 2],
    cell: f64,
    nx: usize,
    ny: usize,
    m2: Vec<f64>,
    /// Per bucket, the border edges whose bounding boxes overlap it.
    border: Vec<Vec<u32>>,
    /// Border edge segments.
    segs: Vec<[[f64; 2]; 2]>,
    /// The mesh is not convex: a square with its corners inside may still leave it.
    concave: bool,
}

impl CurvatureGrid {
    fn new(s: &Spline, bucket: f64) -> CurvatureGrid {
        let m = s.mesh();
        let (lo, hi) = m.bbox();
        let mut cell = bucket.max(1e-9);
        while ((hi[0] - lo[0]) / cell) * ((hi[1] - lo[1]) / cell) > 1.0e6 {
            cell *= 2.0;
        }
        let nx = ((hi[0] - lo[0]) / cell) as usize + 1;
        let ny = ((hi[1] - lo[1]) / cell) as usize + 1;
        let mut g = CurvatureGrid {
            lo,
            cell,
            nx,
            ny,
            m2: vec![0.0; nx * ny],
            border: vec![Vec::new(); nx * ny],
            segs: Vec::new(),
            concave: !is_convex(m),
        };
        let cache = s.eval_cache();
        // Per triangle, bounds on an n x n subdivision (sub-triangles about a bucket wide).
        let per_tri: Vec<Vec<BoxBound>> = (0..m.num_triangles())
            .into_par_iter()
            .map(|t| {
                let v = m.triangle(t).map(|i| m.vertex(i));
                let (tlo, thi) = bbox(&v);
                let n =
                    (((thi[0] - tlo[0]).max(thi[1] - tlo[1]) / cell).ceil() as usize).clamp(1, 64);
                cache
                    .second_derivative_bounds_uniform(t, n)
                    .into_iter()
                    .map(|(sub, bound)| {
                        let pts = sub.map(|b| {
                            [0, 1].map(|a| b[0] * v[0][a] + b[1] * v[1][a] + b[2] * v[2][a])
                        });
                        let (slo, shi) = bbox(&pts);
                        (slo, shi, bound)
                    })
                    .collect()
            })
            .collect();
        for (slo, shi, bound) in per_tri.into_iter().flatten() {
            g.for_buckets(slo, shi, |k, m2, _| m2[k] = m2[k].max(bound));
        }
        for e in m.edges().iter().filter(|e| e.tris[0].is_none() || e.tris[1].is_none()) {
            let seg = [m.vertex(e.v[0]), m.vertex(e.v[1])];
            let (blo, bhi) = bbox(&seg);
            let id = g.segs.len() as u32;
            g.segs.push(seg);
            g.for_buckets(blo, bhi, |k, _, b| b[k].push(id));
        }
        g
    }

    fn range(&self, lo: f64, hi: f64, axis: usize, n: usize) -> (usize, usize) {
        let f = |v: f64| ((v - self.lo[axis]) / self.cell).floor().clamp(0.0, (n - 1) as f64);
        (f(lo) as usize, f(hi) as usize)
    }

    fn for_buckets(
        &mut self,
        lo: [f64; 2],
        hi: [f64; 2],
        mut f: impl FnMut(usize, &mut [f64], &mut [Vec<u32>]),
    ) {
        let (x0, x1) = self.range(lo[0], hi[0], 0, self.nx);
        let (y0, y1) = self.range(lo[1], hi[1], 1, self.ny);
        for y in y0..=y1 {
            for x in x0..=x1 {
                f(y * self.nx + x, &mut self.m2, &mut self.border);
            }
        }
    }

    /// The largest bound over the buckets overlapping the box.
    fn bound(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        let (x0, x1) = self.range(lo[0], hi[0], 0, self.nx);
        let (y0, y1) = self.range(lo[1], hi[1], 1, self.ny);
        let mut m = 0.0f64;
        for y in y0..=y1 {
            for x in x0..=x1 {
                m = m.max(self.m2[y * self.nx + x]);
            }
        }
        m
    }

    /// Whether a border edge of the mesh meets the open box `(lo, hi)`.
    fn crosses_border(&self, lo: [f64; 2], hi: [f64; 2]) -> bool {
        let (x0, x1) = self.range(lo[0], hi[0], 0, self.nx);
        let (y0, y1) = self.range(lo[1], hi[1], 1, self.ny);
        for y in y0..=y1 {
            for x in x0..=x1 {
                for &e in &self.border[y * self.nx + x] {
                    if segment_meets_open_box(self.segs[e as usize], lo, hi) {
                        return true;
                    }
                }
            }
        }
        false
    }
}

/// Whether the segment has a point strictly inside the box (Liang-Barsky clipping, then the
/// midpoint of the clipped piece; a segment along the box's side does not count).
fn segment_meets_open_box(s: [[f64; 2]; 2], lo: [f64; 2], hi: [f64; 2]) -> bool {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let d = [s[1][0] - s[0][0], s[1][1] - s[0][1]];
    for a in 0..2 {
        if d[a] == 0.0 {
            if s[0][a] <= lo[a] || s[0][a] >= hi[a] {
                return false;
            }
        } else {
            let (ta, tb) = ((lo[a] - s[0][a]) / d[a], (hi[a] - s[0][a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    if t0 > t1 {
        return false;
    }
    let t = (t0 + t1) / 2.0;
    let m = [s[0][0] + t * d[0], s[0][1] + t * d[1]];
    (0..2).all(|a| m[a] > lo[a] && m[a] < hi[a])
}

/// `|A^-1|_2` for the affine map taking triangle `p` to triangle `q`, or `None` if the
/// image is degenerate.
fn affine_inverse_norm(p: [[f64; 2]; 3], q: [[f64; 2]; 3]) -> Option<f64> {
    let (sp, sq) = (signed_area(p), signed_area(q));
    if sp * sq == 0.0 || !(sp * sq).is_finite() {
        return None;
    }
    let pe = [[p[1][0] - p[0][0], p[2][0] - p[0][0]], [p[1][1] - p[0][1], p[2][1] - p[0][1]]];
    let qe = [[q[1][0] - q[0][0], q[2][0] - q[0][0]], [q[1][1] - q[0][1], q[2][1] - q[0][1]]];
    let pinv = [[pe[1][1] / sp, -pe[0][1] / sp], [-pe[1][0] / sp, pe[0][0] / sp]];
    let a = [0, 1].map(|r| [0, 1].map(|c| qe[r][0] * pinv[0][c] + qe[r][1] * pinv[1][c]));
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let fro2 = a[0][0].powi(2) + a[0][1].powi(2) + a[1][0].powi(2) + a[1][1].powi(2);
    let smax = ((fro2 + ((fro2 * fro2 - 4.0 * det * det).max(0.0)).sqrt()) / 2.0).sqrt();
    Some(smax / det.abs())
}

/// A box of the deformed plane clipped to a `w x h` output, as inclusive pixel bounds.
fn clip_box(lo: [f64; 2], hi: [f64; 2], w: usize, h: usize) -> [u32; 4] {
    let c = |v: f64, n: usize| v.round().clamp(0.0, n.saturating_sub(1) as f64) as u32;
    [c(lo[0], w), c(lo[1], h), c(hi[0], w), c(hi[1], h)]
}

fn signed_area(v: [[f64; 2]; 3]) -> f64 {
    (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1])
}

fn bbox(v: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in v {
        for a in 0..2 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// Whether the mesh covers its convex hull (total triangle area equals the hull's area).
fn is_convex(m: &crate::mesh::Mesh) -> bool {
    let mut pts: Vec<[f64; 2]> = m.vertices().to_vec();
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let ordered: Vec<[f64; 2]> =
            if pass == 0 { pts.clone() } else { pts.iter().rev().copied().collect() };
        for p in ordered {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    let hull_area: f64 = (0..hull.len())
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        .abs()
        / 2.0;
    let mesh_area: f64 = (0..m.num_triangles()).map(|t| m.twice_area_int(t) as f64).sum::<f64>()
        / (2.0 * (m.grid_denominator() as f64).powi(2));
    (hull_area - mesh_area).abs() <= 1e-9 * hull_area.max(1e-300)
}

/// An accepted lattice triangle (from the splitting path): reference vertices, images.
#[derive(Clone, Copy, Debug)]
struct Tri {
    p: [[f64; 2]; 3],
    q: [[f64; 2]; 3],
    /// Output rows spanned.
    y: [f64; 2],
    bound: f64,
    folded: bool,
}

/// A lattice square cut into `k x k` equal rectangles (each in two triangles) that all meet
/// the bound; the images of its `(k+1)^2` grid points are in [`Pieces::pool`].
#[derive(Clone, Copy, Debug)]
struct Block {
    p0: [f64; 2],
    step: [f64; 2],
    k: usize,
    off: usize,
    y: [f64; 2],
    bound: f64,
    /// The image is reversed (det J < 0 on the whole block).
    folded: bool,
}

#[inline(always)]
fn fast_ceil(x: f64) -> f64 {
    -fast_floor(-x)
}

/// Rasterizes the image `q` of the reference triangle `p` into the band `out` (rows
/// `y0 ..`, `w` per row): each covered pixel centre gets `L^-1(q)`. Returns the number of
/// pixels written.
#[inline]
fn raster(
    p: &[[f64; 2]; 3],
    q: &[[f64; 2]; 3],
    out: &mut [[f64; 2]],
    y0: usize,
    w: usize,
    mut fold_mask: Option<(&mut [bool], bool)>,
) -> usize {
    let rows = out.len() / w;
    let (e1, e2) = ([q[1][0] - q[0][0], q[1][1] - q[0][1]], [q[2][0] - q[0][0], q[2][1] - q[0][1]]);
    let det = e1[0] * e2[1] - e2[0] * e1[1];
    if det == 0.0 || !det.is_finite() {
        return 0;
    }
    let inv = [[e2[1] / det, -e2[0] / det], [-e1[1] / det, e1[0] / det]];
    let (lo, hi) = bbox(q);
    let ya = fast_ceil(lo[1] - 1e-7).max(y0 as f64) as usize;
    let yb = (fast_floor(hi[1] + 1e-7) as isize).min((y0 + rows) as isize - 1);
    let xa = fast_ceil(lo[0] - 1e-7).max(0.0) as usize;
    let xb = (fast_floor(hi[0] + 1e-7) as isize).min(w as isize - 1);
    if yb < ya as isize || xb < xa as isize {
        return 0;
    }
    let (pe1, pe2) =
        ([p[1][0] - p[0][0], p[1][1] - p[0][1]], [p[2][0] - p[0][0], p[2][1] - p[0][1]]);
    // lambda_k(x, y) = c_k + bx_k x + by_k y (lambda_0 = 1 - lambda_1 - lambda_2). Where
    // bx_k != 0, lambda_k >= -eps is the half-line x >= or <= alpha_k + beta_k y, so a row's
    // span costs a few multiply-adds; p(x, y) is affine too.
    let eps = 1e-9;
    let c1 = -inv[0][0] * q[0][0] - inv[0][1] * q[0][1];
    let c2 = -inv[1][0] * q[0][0] - inv[1][1] * q[0][1];
    let c = [1.0 - c1 - c2, c1, c2];
    let bx = [-inv[0][0] - inv[1][0], inv[0][0], inv[1][0]];
    let by = [-inv[0][1] - inv[1][1], inv[0][1], inv[1][1]];
    let (mut lower, mut upper, mut flat) = ([[0.0f64; 2]; 3], [[0.0f64; 2]; 3], [[0.0f64; 2]; 3]);
    let (mut nl, mut nu, mut nf) = (0, 0, 0);
    for k in 0..3 {
        if bx[k] == 0.0 {
            flat[nf] = [c[k], by[k]];
            nf += 1;
        } else {
            let line = [(-eps - c[k]) / bx[k], -by[k] / bx[k]];
            if bx[k] > 0.0 {
                lower[nl] = line;
                nl += 1;
            } else {
                upper[nu] = line;
                nu += 1;
            }
        }
    }
    // p = p0 + lambda_1 pe1 + lambda_2 pe2 = pc + px x + py y.
    let px = [bx[1] * pe1[0] + bx[2] * pe2[0], bx[1] * pe1[1] + bx[2] * pe2[1]];
    let py = [by[1] * pe1[0] + by[2] * pe2[0], by[1] * pe1[1] + by[2] * pe2[1]];
    let pc = [p[0][0] + c[1] * pe1[0] + c[2] * pe2[0], p[0][1] + c[1] * pe1[1] + c[2] * pe2[1]];
    let mut written = 0;
    for y in ya..=yb as usize {
        let yf = y as f64;
        if flat[..nf].iter().any(|f| f[0] + f[1] * yf < -eps) {
            continue;
        }
        let mut lo_x = xa as f64;
        for l in &lower[..nl] {
            lo_x = lo_x.max(l[0] + l[1] * yf);
        }
        let mut hi_x = xb as f64;
        for u in &upper[..nu] {
            hi_x = hi_x.min(u[0] + u[1] * yf);
        }
        if hi_x < lo_x {
            continue;
        }
        let (x0, x1) = (fast_ceil(lo_x), fast_floor(hi_x));
        if x1 < x0 {
            continue;
        }
        let (x0, x1) = (x0 as usize, x1 as usize);
        let row = &mut out[(y - y0) * w..(y - y0 + 1) * w];
        let start =
            [pc[0] + py[0] * yf + px[0] * x0 as f64, pc[1] + py[1] * yf + px[1] * x0 as f64];
        for (k, o) in row[x0..=x1].iter_mut().enumerate() {
            let kf = k as f64;
            *o = [start[0] + kf * px[0], start[1] + kf * px[1]];
        }
        written += x1 + 1 - x0;
        if let Some((mask, folded)) = fold_mask.as_mut() {
            mask[(y - y0) * w + x0..=(y - y0) * w + x1].fill(*folded);
        }
    }
    written
}

/// A lattice corner's image and the mesh triangle it lies in (`None`: outside the mesh).
type Corner = Option<([f64; 2], usize)>;

/// The pieces of one lattice row, with the output rows they span.
struct Pieces {
    blocks: Vec<Block>,
    /// Images of the blocks' grid points.
    pool: Vec<[f64; 2]>,
    tris: Vec<Tri>,
    /// Output boxes `[x0, y0, x1, y1]` whose unfilled pixels Newton must solve.
    newton: Vec<[f64; 4]>,
    /// Smallest and largest output `y` of the pieces.
    y: [f64; 2],
}

impl Default for Pieces {
    fn default() -> Self {
        Pieces {
            blocks: Vec::new(),
            pool: Vec::new(),
            tris: Vec::new(),
            newton: Vec::new(),
            y: [f64::INFINITY, f64::NEG_INFINITY],
        }
    }
}

/// A plan for the preimages of a `w x h` output: the forward lattice, refined and binned.
pub struct RemapPlan<'a> {
    map: InverseMap<'a>,
    opts: RemapOptions,
    w: u32,
    h: u32,
    /// Per lattice row, its accepted pieces.
    rows: Vec<Pieces>,
    bands: usize,
}

struct Refiner<'s> {
    s: &'s Spline,
    curv: CurvatureGrid,
    tol: f64,
}

impl Refiner<'_> {
    fn eval(&self, p: [f64; 2], hint: Option<usize>) -> Corner {
        let (t, b) = self.s.mesh().locate(p, hint)?;
        Some((self.s.eval_cache().value(t, b), t))
    }

    /// Bound of interpolating over the triangle, or `None` if it must be split.
    fn tri_bound(&self, p: [[f64; 2]; 3], q: [[f64; 2]; 3], m2: f64) -> Option<f64> {
        let ainv = affine_inverse_norm(p, q)?;
        if m2 == 0.0 {
            return Some(0.0);
        }
        let d2 = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2);
        let (l01, l02, l12) = (d2(p[0], p[1]), d2(p[0], p[2]), d2(p[1], p[2]));
        let diam = l01.max(l02).max(l12).sqrt();
        let shrink = 1.0 - ainv * m2 * diam;
        if shrink <= 0.5 {
            return None;
        }
        // Largest of sum lambda_i |P_i - p|^2 is the squared circumradius for right and
        // obtuse-free lattice triangles: the hypotenuse squared over 4.
        let r2 = l01.max(l02).max(l12) / 4.0;
        Some(1.01 * ainv / shrink * m2 * r2 / 2.0)
    }

    /// Tries to cut the square (all corners inside, not crossing the border) into `k x k`
    /// rectangles that all meet the bound, `k` chosen from the bound itself.
    fn block(&self, p: [[f64; 2]; 4], qt: [Corner; 4], m2: f64, out: &mut Pieces) -> bool {
        let q = qt.map(|c| c.map(|c| c.0).unwrap_or([0.0; 2]));
        let (sx, sy) = (p[1][0] - p[0][0], p[2][1] - p[0][1]);
        let k = if m2 == 0.0 {
            1
        } else {
            // |A^-1| of the two halves; a leg `a` meets the bound when K M a^2 / 4 <= tol.
            let ainv = [[0, 1, 3], [0, 3, 2]]
                .iter()
                .map(|h| affine_inverse_norm(h.map(|i| p[i]), h.map(|i| q[i])))
                .try_fold(0.0f64, |a, b| Some(a.max(b?)));
            let Some(ainv) = ainv else { return false };
            let leg = (4.0 * self.tol / (1.1 * ainv * m2)).sqrt();
            (sx.max(sy) / leg).ceil().max(1.0) as usize
        };
        if k > 1 && (sx.max(sy) / k as f64) < MIN_SQUARE.max(0.5) {
            return false;
        }
        let off = out.pool.len();
        let step = [sx / k as f64, sy / k as f64];
        let mut hint = qt[0].map(|c| c.1);
        for j in 0..=k {
            for i in 0..=k {
                let c = match (i == 0 || i == k, j == 0 || j == k) {
                    (true, true) => qt[(i / k) + 2 * (j / k)],
                    _ => self
                        .eval([p[0][0] + i as f64 * step[0], p[0][1] + j as f64 * step[1]], hint),
                };
                let Some((v, t)) = c else {
                    out.pool.truncate(off);
                    return false;
                };
                hint = Some(t);
                out.pool.push(v);
            }
        }
        let mut worst = 0.0f64;
        let mut sign = 0.0f64;
        let n = k + 1;
        for j in 0..k {
            for i in 0..k {
                let (x0, y0) = (p[0][0] + i as f64 * step[0], p[0][1] + j as f64 * step[1]);
                let pp = [
                    [x0, y0],
                    [x0 + step[0], y0],
                    [x0, y0 + step[1]],
                    [x0 + step[0], y0 + step[1]],
                ];
                let b = off + j * n + i;
                let qq = [out.pool[b], out.pool[b + 1], out.pool[b + n], out.pool[b + n + 1]];
                for h in [[0, 1, 3], [0, 3, 2]] {
                    let (pt, qt) = (h.map(|c| pp[c]), h.map(|c| qq[c]));
                    let sg = (signed_area(pt) * signed_area(qt)).signum();
                    if sign == 0.0 {
                        sign = sg;
                    }
                    match self.tri_bound(pt, qt, m2) {
                        Some(bd) if bd <= self.tol && sg == sign => worst = worst.max(bd),
                        _ => {
                            out.pool.truncate(off);
                            return false;
                        }
                    }
                }
            }
        }
        let (lo, hi) = bbox(&out.pool[off..]);
        out.blocks.push(Block {
            p0: p[0],
            step,
            k,
            off,
            y: [lo[1], hi[1]],
            bound: worst,
            folded: sign < 0.0,
        });
        true
    }

    /// Refines the square with corners `p = [p00, p10, p01, p11]` (images `q`).
    fn square(&self, p: [[f64; 2]; 4], qt: [Corner; 4], out: &mut Pieces) {
        let q = qt.map(|c| c.map(|c| c.0));
        let side = (p[1][0] - p[0][0]).max(p[2][1] - p[0][1]);
        let (lo, hi) = bbox(&p);
        let m2 = self.curv.bound(lo, hi);
        let smallest = side <= MIN_SQUARE;
        let all = q.iter().all(Option::is_some);
        let none = q.iter().all(Option::is_none);
        // Corners inside and no border edge through it: the whole square is in the mesh.
        // Corners outside and no border edge through it: the whole square is outside.
        let crossing = (none || self.curv.concave) && self.curv.crosses_border(lo, hi);
        if none && !crossing {
            return;
        }
        if all && !crossing && !smallest && self.block(p, qt, m2, out) {
            return;
        }
        if all && (!crossing || smallest) {
            let qv = q.map(|v| v.unwrap_or([0.0; 2]));
            let halves = [[0, 1, 3], [0, 3, 2]];
            let bounds = halves.map(|h| {
                let (pt, qt) = (h.map(|i| p[i]), h.map(|i| qv[i]));
                self.tri_bound(pt, qt, m2).filter(|b| *b <= self.tol)
            });
            if smallest || bounds.iter().all(Option::is_some) {
                // At the smallest size: halves that meet the bound or fold are drawn; any
                // other half is left to Newton, pixel by pixel.
                for (k, h) in halves.iter().enumerate() {
                    let (pt, qt) = (h.map(|i| p[i]), h.map(|i| qv[i]));
                    let folded = signed_area(pt) * signed_area(qt) <= 0.0;
                    let (lo, hi) = bbox(&qt);
                    match bounds[k] {
                        Some(b) => {
                            out.tris.push(Tri { p: pt, q: qt, y: [lo[1], hi[1]], bound: b, folded })
                        }
                        None if folded => out.tris.push(Tri {
                            p: pt,
                            q: qt,
                            y: [lo[1], hi[1]],
                            bound: f64::INFINITY,
                            folded,
                        }),
                        None => {
                            out.newton.push([lo[0] - 1.0, lo[1] - 1.0, hi[0] + 1.0, hi[1] + 1.0])
                        }
                    }
                }
                return;
            }
        }
        if smallest {
            // A piece across the border of the mesh: Newton for the pixels around it.
            let imgs: Vec<[f64; 2]> = q.iter().flatten().copied().collect();
            if !imgs.is_empty() {
                let (l, h) = bbox(&imgs);
                out.newton.push([l[0] - 1.0, l[1] - 1.0, h[0] + 1.0, h[1] + 1.0]);
            }
            return;
        }
        let mid = |a: [f64; 2], b: [f64; 2]| [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
        let (top, left, right, bottom) =
            (mid(p[0], p[1]), mid(p[0], p[2]), mid(p[1], p[3]), mid(p[2], p[3]));
        let centre = mid(p[0], p[3]);
        let hint = qt.iter().flatten().map(|c| c.1).next();
        let [mt, ml, mc, mr, mb] = [top, left, centre, right, bottom].map(|x| self.eval(x, hint));
        self.square([p[0], top, left, centre], [qt[0], mt, ml, mc], out);
        self.square([top, p[1], centre, right], [mt, qt[1], mc, mr], out);
        self.square([left, centre, p[2], bottom], [ml, mc, qt[2], mb], out);
        self.square([centre, right, bottom, p[3]], [mc, mr, mb, qt[3]], out);
    }
}

impl<'a> RemapPlan<'a> {
    /// Maps the lattice forward, refines it under the bound and bins the triangles by band.
    pub fn new(s: &'a Spline, w: u32, h: u32, opts: RemapOptions) -> RemapPlan<'a> {
        let cell = if opts.cell.is_finite() && opts.cell >= MIN_SQUARE { opts.cell } else { 8.0 };
        let opts = RemapOptions { cell, band_rows: opts.band_rows.max(1), ..opts };
        let map = InverseMap::new(s, opts.inverse);
        let refiner = Refiner { s, curv: CurvatureGrid::new(s, 32.0), tol: opts.inverse.tolerance };
        // Lattice over the mesh's bounding box; squares of side `cell`, the last row and
        // column narrower so that the lattice ends exactly on the box.
        let (lo, hi) = s.mesh().bbox();
        let nx = ((hi[0] - lo[0]) / cell).ceil() as usize + 1;
        let ny = ((hi[1] - lo[1]) / cell).ceil() as usize + 1;
        let at = |i: usize, j: usize| {
            let x = if i + 1 == nx { hi[0] } else { lo[0] + i as f64 * cell };
            let y = if j + 1 == ny { hi[1] } else { lo[1] + j as f64 * cell };
            [x, y]
        };
        let pts: Vec<[f64; 2]> = (0..ny).flat_map(|j| (0..nx).map(move |i| at(i, j))).collect();
        let vals: Vec<Corner> = pts
            .par_chunks(nx)
            .flat_map_iter(|row| {
                let refiner = &refiner;
                let mut hint = None;
                row.iter().map(move |&p| {
                    let c = refiner.eval(p, hint);
                    hint = c.map(|c| c.1).or(hint);
                    c
                })
            })
            .collect();
        let rows: Vec<Pieces> = (0..ny.saturating_sub(1))
            .into_par_iter()
            .map(|j| {
                let mut out = Pieces::default();
                for i in 0..nx - 1 {
                    let k = j * nx + i;
                    let (p, q) = (
                        [pts[k], pts[k + 1], pts[k + nx], pts[k + nx + 1]],
                        [vals[k], vals[k + 1], vals[k + nx], vals[k + nx + 1]],
                    );
                    if p[1][0] > p[0][0] && p[2][1] > p[0][1] {
                        refiner.square(p, q, &mut out);
                    }
                }
                // Keep what can reach the output, and note the rows spanned.
                let (wf, hf) = (w as f64, h as f64);
                out.tris.retain(|t| t.y[1] >= -0.5 && t.y[0] <= hf);
                out.blocks.retain(|b| b.y[1] >= -0.5 && b.y[0] <= hf);
                out.newton.retain(|r| r[3] >= 0.0 && r[1] <= hf && r[2] >= 0.0 && r[0] <= wf);
                for y in out.tris.iter().map(|t| t.y).chain(out.blocks.iter().map(|b| b.y)) {
                    out.y = [out.y[0].min(y[0]), out.y[1].max(y[1])];
                }
                for r in &out.newton {
                    out.y = [out.y[0].min(r[1]), out.y[1].max(r[3])];
                }
                out
            })
            .collect();
        let bands = (h as usize).div_ceil(opts.band_rows as usize);
        RemapPlan { map, opts, w, h, rows, bands }
    }

    /// Triangles rasterized and Newton boxes (for diagnostics).
    pub fn debug_counts(&self) -> String {
        let tris: usize = self.rows.iter().map(|r| r.tris.len()).sum();
        let blocks: usize = self.rows.iter().map(|r| r.blocks.len()).sum();
        let pool: usize = self.rows.iter().map(|r| r.pool.len()).sum();
        let boxes: usize = self.rows.iter().map(|r| r.newton.len()).sum();
        format!("{blocks} blocks ({pool} points), {tris} tris, {boxes} newton boxes")
    }

    /// Output width and height.
    pub fn size(&self) -> (u32, u32) {
        (self.w, self.h)
    }

    /// Rows per band ([`RemapPlan::fill_band`] fills one band).
    pub fn band_rows(&self) -> u32 {
        self.opts.band_rows
    }

    /// Number of bands covering the output.
    pub fn num_bands(&self) -> usize {
        self.bands
    }

    /// Fills the preimages of the pixel rows of band `band` (rows `band * band_rows ..`) into
    /// `out` (row-major, `w` per row; `[NaN, NaN]` where there is none).
    pub fn fill_band(&self, band: usize, out: &mut [[f64; 2]]) -> RemapStats {
        let w = self.w as usize;
        let rows_total = self.h as usize;
        let y0 = band * self.opts.band_rows as usize;
        let rows = (self.opts.band_rows as usize).min(self.h as usize - y0);
        let out = &mut out[..rows * w];
        out.fill([f64::NAN; 2]);
        let mut st = RemapStats::default();
        let (ylo, yhi) = (y0 as f64 - 1.0, (y0 + rows) as f64 + 1.0);
        let near: Vec<&Pieces> =
            self.rows.iter().filter(|r| r.y[1] >= ylo && r.y[0] <= yhi).collect();
        // Which pixels the last piece drawn there is folded (only when there are folds).
        let any_fold = near
            .iter()
            .any(|r| r.blocks.iter().any(|b| b.folded) || r.tris.iter().any(|t| t.folded));
        let mut mask = any_fold.then(|| vec![false; rows * w]);
        for r in &near {
            for b in &r.blocks {
                if b.y[1] < ylo || b.y[0] > yhi {
                    continue;
                }
                let n = b.k + 1;
                let mut written = 0;
                for j in 0..b.k {
                    let py = b.p0[1] + j as f64 * b.step[1];
                    for i in 0..b.k {
                        let o = b.off + j * n + i;
                        let qq = [r.pool[o], r.pool[o + 1], r.pool[o + n], r.pool[o + n + 1]];
                        let (qlo, qhi) = (
                            qq.iter().map(|v| v[1]).fold(f64::INFINITY, f64::min),
                            qq.iter().map(|v| v[1]).fold(f64::NEG_INFINITY, f64::max),
                        );
                        if qhi < ylo || qlo > yhi {
                            continue;
                        }
                        let px = b.p0[0] + i as f64 * b.step[0];
                        let pp = [
                            [px, py],
                            [px + b.step[0], py],
                            [px, py + b.step[1]],
                            [px + b.step[0], py + b.step[1]],
                        ];
                        for h in [[0, 1, 3], [0, 3, 2]] {
                            written += raster(
                                &h.map(|c| pp[c]),
                                &h.map(|c| qq[c]),
                                out,
                                y0,
                                w,
                                mask.as_deref_mut().map(|m| (m, b.folded)),
                            );
                        }
                    }
                }
                if b.folded {
                    if written > 0 {
                        let (lo, hi) = bbox(&r.pool[b.off..b.off + n * n]);
                        st.merge(&RemapStats {
                            fold_box: Some(clip_box(lo, hi, w, rows_total)),
                            ..Default::default()
                        });
                    }
                } else if written > 0 {
                    st.max_error_bound = st.max_error_bound.max(b.bound);
                }
            }
            for t in &r.tris {
                if t.y[1] < ylo || t.y[0] > yhi {
                    continue;
                }
                let written =
                    raster(&t.p, &t.q, out, y0, w, mask.as_deref_mut().map(|m| (m, t.folded)));
                if t.folded {
                    if written > 0 {
                        let (lo, hi) = bbox(&t.q);
                        st.merge(&RemapStats {
                            fold_box: Some(clip_box(lo, hi, w, rows_total)),
                            ..Default::default()
                        });
                    }
                } else if written > 0 {
                    st.max_error_bound = st.max_error_bound.max(t.bound);
                }
            }
        }
        st.folded = mask.as_ref().map_or(0, |m| m.iter().filter(|&&f| f).count());
        // Newton for the unfilled pixels near border pieces (each pixel tried once).
        let boxes: Vec<&[f64; 4]> =
            near.iter().flat_map(|r| &r.newton).filter(|r| r[3] >= ylo && r[1] <= yhi).collect();
        let mut tried = vec![false; if boxes.is_empty() { 0 } else { rows * w }];
        for r in boxes {
            let ya = r[1].ceil().max(y0 as f64) as usize;
            let yb = (r[3].floor() as isize).min((y0 + rows) as isize - 1);
            let xa = r[0].ceil().max(0.0) as usize;
            let xb = (r[2].floor() as isize).min(w as isize - 1);
            for y in ya as isize..=yb {
                let y = y as usize;
                let mut prev: Option<Preimage> = None;
                for x in xa as isize..=xb {
                    let k = (y - y0) * w + x as usize;
                    let o = &mut out[k];
                    if !o[0].is_nan() || tried[k] {
                        continue;
                    }
                    tried[k] = true;
                    if let Some(pm) = self.map.invert([x as f64, y as f64], prev.as_ref()) {
                        *o = pm.p;
                        st.newton_solves += 1;
                        st.max_error_bound = st.max_error_bound.max(pm.error_bound);
                        prev = Some(pm);
                    }
                }
            }
        }
        st.outside = out.iter().filter(|p| p[0].is_nan()).count();
        st.interpolated = rows * w - st.outside - st.newton_solves;
        st
    }
}

/// The preimage of every pixel centre of a `w x h` output (row-major; `[NaN, NaN]` where
/// there is none), with statistics. Parallel over bands of rows.
pub fn preimage_grid(
    s: &Spline,
    w: u32,
    h: u32,
    opts: RemapOptions,
) -> (Vec<[f64; 2]>, RemapStats) {
    let plan = RemapPlan::new(s, w, h, opts);
    let band = plan.band_rows() as usize * w as usize;
    let mut out = vec![[0.0f64; 2]; w as usize * h as usize];
    let stats = out
        .par_chunks_mut(band.max(1))
        .enumerate()
        .map(|(b, chunk)| plan.fill_band(b, chunk))
        .reduce(RemapStats::default, |mut a, b| {
            a.merge(&b);
            a
        });
    (out, stats)
}
