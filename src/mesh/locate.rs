//! Point location: per-triangle affine maps to barycentric coordinates and a uniform bucket
//! grid over the bounding box.

/// Relative tolerance for points on edges and vertices.
const TOL: f64 = 1e-12;

/// Offset of the bucket grid, as a fraction of the bucket size.
const OFFSET: f64 = 0.381_966;

/// Barycentric map of one triangle: `l1 = m[0] dx + m[1] dy`, `l2 = m[2] dx + m[3] dy` with
/// `d = p - o`, `l0 = 1 - l1 - l2`; `p` is accepted when `l_k >= -tol[k]`.
#[derive(Clone, Copy, Debug)]
struct TriMap {
    o: [f64; 2],
    m: [f64; 4],
    tol: [f64; 3],
}

impl TriMap {
    #[inline]
    fn bary(&self, p: [f64; 2]) -> [f64; 3] {
        let (dx, dy) = (p[0] - self.o[0], p[1] - self.o[1]);
        let l1 = self.m[0] * dx + self.m[1] * dy;
        let l2 = self.m[2] * dx + self.m[3] * dy;
        [1.0 - l1 - l2, l1, l2]
    }

    #[inline]
    fn accept(&self, p: [f64; 2]) -> Option<[f64; 3]> {
        let l = self.bary(p);
        (l[0] >= -self.tol[0] && l[1] >= -self.tol[1] && l[2] >= -self.tol[2]).then_some(l)
    }
}

/// Uniform bucket grid plus per-triangle barycentric maps.
#[derive(Clone, Debug)]
pub(super) struct Locator {
    maps: Vec<TriMap>,
    /// Lower corner of the grid.
    origin: [f64; 2],
    /// Inverse bucket size.
    inv: [f64; 2],
    /// Buckets along x and y.
    dims: [usize; 2],
    /// Query bounding box (mesh bounding box plus a small margin).
    lo: [f64; 2],
    hi: [f64; 2],
    /// Bucket `b` holds `items[start[b]..start[b + 1]]`.
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Locator {
    /// Builds the maps and the bucket grid (about 2 triangles per bucket).
    pub(super) fn new(
        verts: &[[f64; 2]],
        tris: &[[usize; 3]],
        bbox: ([f64; 2], [f64; 2]),
    ) -> Locator {
        let (lo, hi) = bbox;
        let (w, h) =
            ((hi[0] - lo[0]).max(f64::MIN_POSITIVE), (hi[1] - lo[1]).max(f64::MIN_POSITIVE));
        let target = (tris.len() as f64 / 2.0).max(1.0);
        let nx = ((target * w / h).sqrt().ceil() as usize).clamp(1, 1 << 12);
        let ny = ((target / nx as f64).ceil() as usize).clamp(1, 1 << 12);
        let margin = 1e-9 * w.hypot(h);
        // Offset the buckets by an irrational-looking fraction of their size so that they do
        // not line up with the cells of regular grid meshes.
        let inv = [(nx as f64 - OFFSET) / w, (ny as f64 - OFFSET) / h];
        let mut loc = Locator {
            maps: Vec::with_capacity(tris.len()),
            origin: [lo[0] - OFFSET / inv[0], lo[1] - OFFSET / inv[1]],
            inv,
            dims: [nx, ny],
            lo: [lo[0] - margin, lo[1] - margin],
            hi: [hi[0] + margin, hi[1] + margin],
            start: vec![0; nx * ny + 1],
            items: Vec::new(),
        };
        let mut ranges = Vec::with_capacity(tris.len());
        for tri in tris {
            let [a, b, c] = tri.map(|v| verts[v]);
            let (e1, e2) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
            let det = e1[0] * e2[1] - e1[1] * e2[0];
            let len = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
            let lens = [len(b, c), len(c, a), len(a, b)];
            let diam = lens[0].max(lens[1]).max(lens[2]);
            // l_k = distance to edge k / height k, height k = det / |edge k|.
            let tol = lens.map(|l| TOL * diam * l / det);
            let m = [e2[1] / det, -e2[0] / det, -e1[1] / det, e1[0] / det];
            loc.maps.push(TriMap { o: a, m, tol });
            let mg = 1e-9 * diam;
            let tlo = [a[0].min(b[0]).min(c[0]) - mg, a[1].min(b[1]).min(c[1]) - mg];
            let thi = [a[0].max(b[0]).max(c[0]) + mg, a[1].max(b[1]).max(c[1]) + mg];
            let (c0, c1) = (loc.cell(tlo), loc.cell(thi));
            for iy in c0[1]..=c1[1] {
                for ix in c0[0]..=c1[0] {
                    loc.start[iy * nx + ix + 1] += 1;
                }
            }
            ranges.push((c0, c1));
        }
        for b in 0..nx * ny {
            loc.start[b + 1] += loc.start[b];
        }
        let mut fill: Vec<u32> = loc.start[..nx * ny].to_vec();
        loc.items = vec![0; loc.start[nx * ny] as usize];
        for (t, (c0, c1)) in ranges.into_iter().enumerate() {
            for iy in c0[1]..=c1[1] {
                for ix in c0[0]..=c1[0] {
                    let b = iy * nx + ix;
                    loc.items[fill[b] as usize] = t as u32;
                    fill[b] += 1;
                }
            }
        }
        loc
    }

    /// The bucket containing `p` (clamped to the grid). Monotone in each coordinate.
    #[inline]
    fn cell(&self, p: [f64; 2]) -> [usize; 2] {
        let f = |k: usize| {
            let x = ((p[k] - self.origin[k]) * self.inv[k]).floor();
            if x <= 0.0 {
                0
            } else {
                (x as usize).min(self.dims[k] - 1)
            }
        };
        [f(0), f(1)]
    }

    /// Triangles whose (slightly enlarged) bounding box may contain `p`.
    pub(super) fn bucket_triangles(&self, p: [f64; 2]) -> impl Iterator<Item = usize> + '_ {
        let c = self.cell(p);
        let b = c[1] * self.dims[0] + c[0];
        self.items[self.start[b] as usize..self.start[b + 1] as usize].iter().map(|&t| t as usize)
    }

    /// Number of buckets and total number of bucket entries.
    #[cfg(test)]
    pub(super) fn stats(&self) -> (usize, usize) {
        (self.dims[0] * self.dims[1], self.items.len())
    }

    /// Barycentric coordinates of `p` in triangle `t`.
    pub(super) fn barycentric(&self, t: usize, p: [f64; 2]) -> [f64; 3] {
        self.maps[t].bary(p)
    }

    /// See [`super::Mesh::locate`].
    pub(super) fn locate(
        &self,
        nbrs: &[[Option<usize>; 3]],
        p: [f64; 2],
        hint: Option<usize>,
    ) -> Option<(usize, [f64; 3])> {
        if let Some(h) = hint.filter(|&h| h < self.maps.len()) {
            if let Some(l) = self.maps[h].accept(p) {
                return Some((h, l));
            }
            for t in nbrs[h].iter().flatten() {
                if let Some(l) = self.maps[*t].accept(p) {
                    return Some((*t, l));
                }
            }
        }
        // Also rejects NaN.
        if !(p[0] >= self.lo[0] && p[0] <= self.hi[0] && p[1] >= self.lo[1] && p[1] <= self.hi[1]) {
            return None;
        }
        self.bucket_triangles(p).find_map(|t| self.maps[t].accept(p).map(|l| (t, l)))
    }
}
