//! Point location: per-triangle affine maps to barycentric coordinates and a bucket grid
//! over the bounding box, refined where triangles crowd.
//!
//! The grid has about one bucket per two triangles, and a triangle is listed in every
//! bucket its (slightly enlarged) bounding box meets. On a mesh of even density that puts a
//! few triangles in each bucket. Meshes of very uneven density are common here: the far-field
//! rings of a frame fit ([`super::AdaptOptions::far_rings`]) make the bounding box 16 times
//! the domain's size, so a uniform grid would put the whole domain (thousands of triangles)
//! into a handful of buckets and each query would test them all. So a bucket with more than
//! [`SPLIT`] triangles gets a grid of its own over its rectangle, built the same way, up to
//! [`MAX_DEPTH`] levels. A query descends from the root bucket containing `p` (clamped to
//! the grid) to a leaf bucket; since every level's bucket index is monotone in each
//! coordinate, a triangle containing `p` is listed in that leaf.

/// Relative tolerance for points on edges and vertices.
const TOL: f64 = 1e-12;

/// Offset of the bucket grid, as a fraction of the bucket size.
const OFFSET: f64 = 0.381_966;

/// A bucket listing more triangles than this gets a grid of its own.
const SPLIT: usize = 16;

/// Levels of grids below the root at most (a fan of many triangles around one vertex stays
/// crowded however fine the grid).
const MAX_DEPTH: usize = 3;

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

/// The bucket grids plus per-triangle barycentric maps.
#[derive(Clone, Debug)]
pub(super) struct Locator {
    maps: Vec<TriMap>,
    /// Query bounding box (mesh bounding box plus a small margin).
    lo: [f64; 2],
    hi: [f64; 2],
    grid: Grid,
}

/// A bucket grid over a rectangle; crowded buckets have grids of their own.
#[derive(Clone, Debug)]
struct Grid {
    /// Lower corner of the grid.
    origin: [f64; 2],
    /// Inverse bucket size.
    inv: [f64; 2],
    /// Buckets along x and y.
    dims: [usize; 2],
    /// Bucket `b` holds `items[start[b]..start[b + 1]]`.
    start: Vec<u32>,
    items: Vec<u32>,
    /// Per bucket: 0, or 1 + the index in `children` of its own grid.
    child: Vec<u32>,
    children: Vec<Grid>,
}

impl Grid {
    /// The grid over `[lo, hi]` of the triangles `ids`, whose bounding boxes are `boxes`.
    fn new(
        boxes: &[([f64; 2], [f64; 2])],
        ids: &[u32],
        (lo, hi): ([f64; 2], [f64; 2]),
        depth: usize,
    ) -> Grid {
        let (w, h) =
            ((hi[0] - lo[0]).max(f64::MIN_POSITIVE), (hi[1] - lo[1]).max(f64::MIN_POSITIVE));
        let target = (ids.len() as f64 / 2.0).max(1.0);
        let nx = ((target * w / h).sqrt().ceil() as usize).clamp(1, 1 << 12);
        let ny = ((target / nx as f64).ceil() as usize).clamp(1, 1 << 12);
        // Offset the buckets by an irrational-looking fraction of their size so that they do
        // not line up with the cells of regular grid meshes.
        let inv = [(nx as f64 - OFFSET) / w, (ny as f64 - OFFSET) / h];
        let mut g = Grid {
            origin: [lo[0] - OFFSET / inv[0], lo[1] - OFFSET / inv[1]],
            inv,
            dims: [nx, ny],
            start: vec![0; nx * ny + 1],
            items: Vec::new(),
            child: Vec::new(),
            children: Vec::new(),
        };
        let ranges: Vec<([usize; 2], [usize; 2])> = ids
            .iter()
            .map(|&t| {
                let (tlo, thi) = boxes[t as usize];
                (g.cell(tlo), g.cell(thi))
            })
            .collect();
        for (c0, c1) in &ranges {
            for iy in c0[1]..=c1[1] {
                for ix in c0[0]..=c1[0] {
                    g.start[iy * nx + ix + 1] += 1;
                }
            }
        }
        for b in 0..nx * ny {
            g.start[b + 1] += g.start[b];
        }
        let mut fill: Vec<u32> = g.start[..nx * ny].to_vec();
        g.items = vec![0; g.start[nx * ny] as usize];
        for (&t, (c0, c1)) in ids.iter().zip(ranges) {
            for iy in c0[1]..=c1[1] {
                for ix in c0[0]..=c1[0] {
                    let b = iy * nx + ix;
                    g.items[fill[b] as usize] = t;
                    fill[b] += 1;
                }
            }
        }
        g.child = vec![0; nx * ny];
        if depth < MAX_DEPTH {
            for b in 0..nx * ny {
                let here = &g.items[g.start[b] as usize..g.start[b + 1] as usize];
                if here.len() > SPLIT {
                    let (ix, iy) = ((b % nx) as f64, (b / nx) as f64);
                    let blo = [g.origin[0] + ix / inv[0], g.origin[1] + iy / inv[1]];
                    let bhi =
                        [g.origin[0] + (ix + 1.0) / inv[0], g.origin[1] + (iy + 1.0) / inv[1]];
                    let sub = Grid::new(boxes, here, (blo, bhi), depth + 1);
                    g.children.push(sub);
                    g.child[b] = g.children.len() as u32;
                }
            }
        }
        if !g.children.is_empty() {
            // A bucket with a grid of its own keeps no list: no query reads it.
            let (mut items, mut start) = (Vec::new(), vec![0u32; nx * ny + 1]);
            for b in 0..nx * ny {
                if g.child[b] == 0 {
                    items.extend_from_slice(&g.items[g.start[b] as usize..g.start[b + 1] as usize]);
                }
                start[b + 1] = items.len() as u32;
            }
            (g.items, g.start) = (items, start);
        }
        g
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

    /// The leaf bucket containing `p`: its triangles.
    fn leaf(&self, p: [f64; 2]) -> &[u32] {
        let mut g = self;
        loop {
            let c = g.cell(p);
            let b = c[1] * g.dims[0] + c[0];
            match g.child[b] {
                0 => return &g.items[g.start[b] as usize..g.start[b + 1] as usize],
                k => g = &g.children[k as usize - 1],
            }
        }
    }

    /// Leaf buckets and their entries, over all levels.
    #[cfg(test)]
    fn stats(&self) -> (usize, usize) {
        let mut out = (0, 0);
        for b in 0..self.child.len() {
            match self.child[b] {
                0 => {
                    out.0 += 1;
                    out.1 += (self.start[b + 1] - self.start[b]) as usize;
                }
                k => {
                    let (n, e) = self.children[k as usize - 1].stats();
                    out = (out.0 + n, out.1 + e);
                }
            }
        }
        out
    }

    /// Entries stored over all levels (leaf lists only, when nothing is kept twice).
    #[cfg(test)]
    fn stored(&self) -> usize {
        self.items.len() + self.children.iter().map(Grid::stored).sum::<usize>()
    }

    /// The largest number of triangles in a leaf bucket.
    #[cfg(test)]
    fn max_leaf(&self) -> usize {
        (0..self.child.len())
            .map(|b| match self.child[b] {
                0 => (self.start[b + 1] - self.start[b]) as usize,
                k => self.children[k as usize - 1].max_leaf(),
            })
            .max()
            .unwrap_or(0)
    }
}

impl Locator {
    /// Builds the maps and the bucket grids (about 2 triangles per bucket, see the module
    /// docs).
    pub(super) fn new(
        verts: &[[f64; 2]],
        tris: &[[usize; 3]],
        bbox: ([f64; 2], [f64; 2]),
    ) -> Locator {
        let (lo, hi) = bbox;
        let margin = 1e-9 * (hi[0] - lo[0]).hypot(hi[1] - lo[1]);
        let mut maps = Vec::with_capacity(tris.len());
        let mut boxes = Vec::with_capacity(tris.len());
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
            maps.push(TriMap { o: a, m, tol });
            let mg = 1e-9 * diam;
            let tlo = [a[0].min(b[0]).min(c[0]) - mg, a[1].min(b[1]).min(c[1]) - mg];
            let thi = [a[0].max(b[0]).max(c[0]) + mg, a[1].max(b[1]).max(c[1]) + mg];
            boxes.push((tlo, thi));
        }
        let ids: Vec<u32> = (0..tris.len() as u32).collect();
        let grid = Grid::new(&boxes, &ids, bbox, 0);
        Locator {
            maps,
            lo: [lo[0] - margin, lo[1] - margin],
            hi: [hi[0] + margin, hi[1] + margin],
            grid,
        }
    }

    /// Triangles whose (slightly enlarged) bounding box may contain `p`.
    pub(super) fn bucket_triangles(&self, p: [f64; 2]) -> impl Iterator<Item = usize> + '_ {
        self.grid.leaf(p).iter().map(|&t| t as usize)
    }

    /// Number of leaf buckets and their total number of entries.
    #[cfg(test)]
    pub(super) fn stats(&self) -> (usize, usize) {
        self.grid.stats()
    }

    /// Entries stored over all levels of the grid.
    #[cfg(test)]
    pub(super) fn stored(&self) -> usize {
        self.grid.stored()
    }

    /// The largest number of triangles a query tests (in a leaf bucket).
    #[cfg(test)]
    pub(super) fn max_bucket(&self) -> usize {
        self.grid.max_leaf()
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
