//! Geometry for the certified inverse: local bounds on `D^2 phi` over the reference domain,
//! border tests, and small triangle helpers (see the parent module for the bound).

use crate::mesh::Mesh;
use crate::spline::eval::EvalCache;
use crate::spline::Spline;
use rayon::prelude::*;

/// A box of the reference domain `(lo, hi)` and a bound on `|D^2 phi|` in it.
pub(super) type BoxBound = ([f64; 2], [f64; 2], f64);

/// The lattice of a plan over the mesh's bounding box: squares of side `cell`, the last row
/// and column narrower so that the lattice ends exactly on the box.
pub(super) struct Lattice {
    lo: [f64; 2],
    hi: [f64; 2],
    pub(super) cell: f64,
    nx: usize,
    ny: usize,
}

impl Lattice {
    pub(super) fn new(s: &Spline, cell: f64) -> Lattice {
        let (lo, hi) = s.mesh().bbox();
        let nx = ((hi[0] - lo[0]) / cell).ceil() as usize + 1;
        let ny = ((hi[1] - lo[1]) / cell).ceil() as usize + 1;
        Lattice { lo, hi, cell, nx, ny }
    }

    /// Lattice point `(i, j)`.
    pub(super) fn at(&self, i: usize, j: usize) -> [f64; 2] {
        let x = if i + 1 == self.nx { self.hi[0] } else { self.lo[0] + i as f64 * self.cell };
        let y = if j + 1 == self.ny { self.hi[1] } else { self.lo[1] + j as f64 * self.cell };
        [x, y]
    }

    /// The squares `i in ia..ib`, `j in ja..jb` (square (i, j) spans lattice points i, i+1
    /// and j, j+1): all of them, or those meeting the window.
    pub(super) fn span(
        &self,
        window: Option<([f64; 2], [f64; 2])>,
    ) -> (usize, usize, usize, usize) {
        let span = |lo_w: f64, hi_w: f64, o: f64, n: usize| {
            let a = ((lo_w - o) / self.cell).floor() - 1.0;
            let b = ((hi_w - o) / self.cell).floor() + 2.0;
            let clamp = |v: f64| v.clamp(0.0, n.saturating_sub(1) as f64) as usize;
            (clamp(a), clamp(b))
        };
        let ((ia, ib), (ja, jb)) = match window {
            None => ((0, self.nx.saturating_sub(1)), (0, self.ny.saturating_sub(1))),
            Some((wl, wh)) => {
                (span(wl[0], wh[0], self.lo[0], self.nx), span(wl[1], wh[1], self.lo[1], self.ny))
            }
        };
        (ia, ib, ja, jb)
    }
}

/// About how many local curvature bounds a plan computes (see [`bucket_for`]).
const CURVATURE_BOUNDS: f64 = 16_000.0;

/// Curvature buckets: as small as 8 px where that costs at most about 16,000 local bounds
/// over the mesh (a sub-triangle per bucket), never coarser than 32 px. Finer buckets give
/// tighter local bounds on strongly bent maps, so larger pieces pass.
pub(super) fn bucket_for(m: &Mesh) -> f64 {
    let (blo, bhi) = m.bbox();
    let area = ((bhi[0] - blo[0]) * (bhi[1] - blo[1])).max(0.0);
    (2.0 * area / CURVATURE_BOUNDS).sqrt().clamp(8.0, 32.0)
}

/// The local bounds on `|D^2 phi|` a [`RemapPlan`](super::RemapPlan) computes for a spline
/// `phi`, kept for the plans of other splines on its mesh
/// ([`RemapPlan::new_scaled`](super::RemapPlan::new_scaled)): a morph computes them once per
/// fitted map instead of once per frame, since a frame's map `(1 - s) id + s phi` has
/// `D^2 = s D^2 phi`.
#[derive(Clone, Debug)]
pub struct CurvatureBounds {
    grid: CurvatureGrid,
    bucket: f64,
    cache: EvalCache,
}

impl CurvatureBounds {
    /// The bounds of `s` over its whole mesh.
    pub fn new(s: &Spline) -> CurvatureBounds {
        let bucket = bucket_for(s.mesh());
        CurvatureBounds {
            grid: CurvatureGrid::new(s, bucket, None),
            bucket,
            cache: s.eval_cache().clone(),
        }
    }

    pub(super) fn grid(&self) -> &CurvatureGrid {
        &self.grid
    }

    pub(super) fn bucket(&self) -> f64 {
        self.bucket
    }

    pub(super) fn cache(&self) -> &EvalCache {
        &self.cache
    }
}

/// Local bounds on `D^2 phi` and border flags in a grid of buckets over the reference domain.
#[derive(Clone, Debug)]
pub(super) struct CurvatureGrid {
    lo: [f64; 2],
    cell: f64,
    /// Buckets of the whole grid over the mesh's bounding box, per axis.
    full: [usize; 2],
    /// The buckets stored: `off[a] .. off[a] + n[a]` of the whole grid per axis (all of
    /// them without a window; those a window's queries can touch with one).
    off: [usize; 2],
    nx: usize,
    ny: usize,
    m2: Vec<f64>,
    /// Per bucket, the border edges whose bounding boxes overlap it.
    border: Vec<Vec<u32>>,
    /// Border edge segments.
    segs: Vec<[[f64; 2]; 2]>,
    /// The mesh is not convex: a square with its corners inside may still leave it.
    pub(super) concave: bool,
}

impl CurvatureGrid {
    /// The grid over the mesh's bounding box, with `bucket`-wide buckets (coarser when
    /// there would be more than a million). With `window`, only the triangles that meet
    /// it (grown by a bucket) are bounded: the buckets that meet the window get exactly
    /// the whole grid's bounds (a bucket's bound is the largest over the sub-triangles
    /// overlapping it, all of which belong to such triangles); the others stay 0 and must
    /// not be asked.
    /// The grid's origin, bucket side, whole size, and the offset and size of the part
    /// stored for `window`.
    #[allow(clippy::type_complexity)]
    fn dims(
        s: &Spline,
        bucket: f64,
        window: Option<([f64; 2], [f64; 2])>,
    ) -> ([f64; 2], f64, [usize; 2], [usize; 2], usize, usize) {
        let (lo, hi) = s.mesh().bbox();
        let mut cell = bucket.max(1e-9);
        while ((hi[0] - lo[0]) / cell) * ((hi[1] - lo[1]) / cell) > 1.0e6 {
            cell *= 2.0;
        }
        let full = [((hi[0] - lo[0]) / cell) as usize + 1, ((hi[1] - lo[1]) / cell) as usize + 1];
        // With a window, only the buckets its queries can touch (the window's, one more on
        // every side) are stored: on a mesh with far-field rings the whole grid is a million
        // buckets, of which a warp of the frame asks a few thousand.
        let (off, nx, ny) = match window {
            None => ([0, 0], full[0], full[1]),
            Some((wlo, whi)) => {
                let r = |a: usize| {
                    let f = |v: f64| ((v - lo[a]) / cell).floor().clamp(0.0, (full[a] - 1) as f64);
                    let (a0, a1) = (f(wlo[a]) as usize, f(whi[a]) as usize);
                    (a0.saturating_sub(1), (a1 + 1).min(full[a] - 1))
                };
                let ((x0, x1), (y0, y1)) = (r(0), r(1));
                ([x0, y0], x1 + 1 - x0, y1 + 1 - y0)
            }
        };
        (lo, cell, full, off, nx, ny)
    }

    /// The number of buckets [`CurvatureGrid::new`] stores (to check a budget first).
    pub(super) fn stored_for(s: &Spline, bucket: f64, window: Option<([f64; 2], [f64; 2])>) -> u64 {
        let (.., nx, ny) = CurvatureGrid::dims(s, bucket, window);
        nx as u64 * ny as u64
    }

    pub(super) fn new(
        s: &Spline,
        bucket: f64,
        window: Option<([f64; 2], [f64; 2])>,
    ) -> CurvatureGrid {
        let m = s.mesh();
        let (lo, cell, full, off, nx, ny) = CurvatureGrid::dims(s, bucket, window);
        let mut g = CurvatureGrid {
            lo,
            cell,
            full,
            off,
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
                if let Some((wlo, whi)) = window {
                    let c = cell;
                    let meets = tlo[0] <= whi[0] + c
                        && thi[0] >= wlo[0] - c
                        && tlo[1] <= whi[1] + c
                        && thi[1] >= wlo[1] - c;
                    if !meets {
                        return Vec::new();
                    }
                }
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

    /// The buckets of the whole grid that the box `[lo, hi]` overlaps along `axis`
    /// (clamped to the grid), as stored indices: `None` where that range leaves the stored
    /// part (only possible with a window).
    fn range(&self, lo: f64, hi: f64, axis: usize) -> Option<(usize, usize)> {
        let n = self.full[axis];
        let f = |v: f64| ((v - self.lo[axis]) / self.cell).floor().clamp(0.0, (n - 1) as f64);
        let (a, b) = (f(lo) as usize, f(hi) as usize);
        let (o, m) = (self.off[axis], if axis == 0 { self.nx } else { self.ny });
        (a >= o && b < o + m).then(|| (a - o, b - o))
    }

    /// Calls `f` on the stored buckets that the box overlaps (the part of the box outside
    /// the stored buckets is no window query's business).
    fn for_buckets(
        &mut self,
        lo: [f64; 2],
        hi: [f64; 2],
        mut f: impl FnMut(usize, &mut [f64], &mut [Vec<u32>]),
    ) {
        let clip = |g: &CurvatureGrid, a: usize, l: f64, h: f64| {
            let n = g.full[a];
            let idx = |v: f64| ((v - g.lo[a]) / g.cell).floor().clamp(0.0, (n - 1) as f64) as usize;
            let (o, m) = (g.off[a], if a == 0 { g.nx } else { g.ny });
            let (x0, x1) = (idx(l).max(o), idx(h).min(o + m - 1));
            (x0 <= x1).then(|| (x0 - o, x1 - o))
        };
        let (Some((x0, x1)), Some((y0, y1))) =
            (clip(self, 0, lo[0], hi[0]), clip(self, 1, lo[1], hi[1]))
        else {
            return;
        };
        for y in y0..=y1 {
            for x in x0..=x1 {
                f(y * self.nx + x, &mut self.m2, &mut self.border);
            }
        }
    }

    /// The largest bound over the buckets overlapping the box (infinite for a box that
    /// leaves a window's stored buckets: no bound is known there).
    pub(super) fn bound(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        let (Some((x0, x1)), Some((y0, y1))) =
            (self.range(lo[0], hi[0], 0), self.range(lo[1], hi[1], 1))
        else {
            return f64::INFINITY;
        };
        let mut m = 0.0f64;
        for y in y0..=y1 {
            for x in x0..=x1 {
                m = m.max(self.m2[y * self.nx + x]);
            }
        }
        m
    }

    /// Whether a border edge of the mesh meets the open box `(lo, hi)` (assumed to, for a
    /// box that leaves a window's stored buckets).
    pub(super) fn crosses_border(&self, lo: [f64; 2], hi: [f64; 2]) -> bool {
        let (Some((x0, x1)), Some((y0, y1))) =
            (self.range(lo[0], hi[0], 0), self.range(lo[1], hi[1], 1))
        else {
            return true;
        };
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

    /// Buckets stored (for tests and diagnostics).
    #[cfg(test)]
    pub(super) fn stored(&self) -> usize {
        self.m2.len()
    }
}

/// Whether the segment has a point strictly inside the box (Liang-Barsky clipping, then the
/// midpoint of the clipped piece; a segment along the box's side does not count).
pub(super) fn segment_meets_open_box(s: [[f64; 2]; 2], lo: [f64; 2], hi: [f64; 2]) -> bool {
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
pub(super) fn affine_inverse_norm(p: [[f64; 2]; 3], q: [[f64; 2]; 3]) -> Option<f64> {
    let (sp, sq) = (signed_area(p), signed_area(q));
    if sp * sq == 0.0 || !(sp * sq).is_finite() {
        return None;
    }
    // A = Qe Pe^-1 = B / sp with B = Qe adj(Pe); |A^-1| = smax(A) / |det A| and
    // det B = sq sp, so |A^-1| = (smax(B) / |sp|) / (|sq sp| / sp^2) = smax(B) / |sq|: one
    // division instead of five.
    let pe = [[p[1][0] - p[0][0], p[2][0] - p[0][0]], [p[1][1] - p[0][1], p[2][1] - p[0][1]]];
    let qe = [[q[1][0] - q[0][0], q[2][0] - q[0][0]], [q[1][1] - q[0][1], q[2][1] - q[0][1]]];
    let adj = [[pe[1][1], -pe[0][1]], [-pe[1][0], pe[0][0]]];
    let b = [0, 1].map(|r| [0, 1].map(|c| qe[r][0] * adj[0][c] + qe[r][1] * adj[1][c]));
    let det = b[0][0] * b[1][1] - b[0][1] * b[1][0];
    let fro2 = b[0][0] * b[0][0] + b[0][1] * b[0][1] + b[1][0] * b[1][0] + b[1][1] * b[1][1];
    let smax = ((fro2 + ((fro2 * fro2 - 4.0 * det * det).max(0.0)).sqrt()) / 2.0).sqrt();
    Some(smax / sq.abs())
}

/// A box of the deformed plane clipped to a `w x h` output, as inclusive pixel bounds.
pub(super) fn clip_box(lo: [f64; 2], hi: [f64; 2], w: usize, h: usize) -> [u32; 4] {
    let c = |v: f64, n: usize| v.round().clamp(0.0, n.saturating_sub(1) as f64) as u32;
    [c(lo[0], w), c(lo[1], h), c(hi[0], w), c(hi[1], h)]
}

pub(super) fn signed_area(v: [[f64; 2]; 3]) -> f64 {
    (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1])
}

pub(super) fn bbox(v: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
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
pub(super) fn is_convex(m: &crate::mesh::Mesh) -> bool {
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
