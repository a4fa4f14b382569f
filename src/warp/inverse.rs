//! The inverse of a spline deformation, `q -> p = phi^-1(q)`, by Newton's method.
//!
//! Seeds come from a forward sampling of every triangle (`phi` at a barycentric lattice),
//! stored in a bucket grid over the deformed plane; for coherent queries (image rows) the
//! previous solution is the seed. Newton runs `p <- p - J(p)^-1 (phi(p) - q)` until the
//! residual `r = |phi(p) - q|` is tiny. The reported error bound on `p` is
//! `|J(p)^-1|_2 * r * 1.01` (first order in `r`, which is far below the tolerance when it is
//! accepted); a point is returned only when that bound is at most the requested tolerance
//! (0.01 px by default) and `p` lies in the mesh. Both `p` and `q` are in mesh (pixel)
//! coordinates.
//!
//! Point queries ([`crate::warp::inverse`], `warp --points --inverse`) are then *polished*
//! ([`InverseMap::polish`]): Newton goes on until its step stops shrinking or falls below
//! [`POLISH_ULPS`] ulps of the coordinate, which leaves `|phi(p) - q|` at the `f64` rounding
//! level of evaluating `phi` (about 1e-13 px on 500 px frames). Image warps skip it: their
//! interpolation error is far above the tolerance already.

/// Slack on first-order error bounds (1 %): the bounds drop the second-order term of a
/// residual that is far below the tolerance, and this covers it and the bound's own f64
/// rounding. Used here and by [`crate::warp::remap`].
pub const FIRST_ORDER_SLACK: f64 = 1.01;

use crate::spline::Spline;

/// Polishing ([`InverseMap::polish`]) stops once a Newton step is at most this many units in
/// the last place of the coordinate (`POLISH_ULPS * f64::EPSILON * (1 + |p|)`): below that,
/// the step is rounding noise of `phi(p) - q`.
pub const POLISH_ULPS: f64 = 4.0;

/// At most this many polishing steps (Newton converges quadratically: from the accepted
/// 1e-5 px two or three steps reach the rounding floor).
pub const POLISH_MAX_STEPS: usize = 8;

/// Options of [`InverseMap`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseOptions {
    /// Largest accepted error bound on `p` (mesh units).
    pub tolerance: f64,
    /// Newton iterations per seed.
    pub max_iter: usize,
    /// Forward samples per triangle side.
    pub samples: usize,
}

impl Default for InverseOptions {
    fn default() -> Self {
        InverseOptions { tolerance: 0.01, max_iter: 25, samples: 6 }
    }
}

/// A solution of `phi(p) = q`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preimage {
    /// The point `p` in the reference domain.
    pub p: [f64; 2],
    /// Triangle containing `p`.
    pub triangle: usize,
    /// Guaranteed (first-order) bound on the error of `p`.
    pub error_bound: f64,
}

/// Precomputed seeds for inverting a spline.
pub struct InverseMap<'a> {
    spline: &'a Spline,
    opts: InverseOptions,
    lo: [f64; 2],
    hi: [f64; 2],
    /// Twice the largest gap between neighbouring forward samples, plus one unit.
    margin: f64,
    cell: f64,
    nx: usize,
    ny: usize,
    /// Per bucket: (reference point, triangle) of the samples whose image falls in it.
    buckets: Vec<Vec<([f64; 2], usize)>>,
}

impl<'a> InverseMap<'a> {
    /// Samples `spline` forward and builds the seed index.
    pub fn new(spline: &'a Spline, opts: InverseOptions) -> InverseMap<'a> {
        let m = spline.mesh();
        let cache = spline.eval_cache();
        let k = opts.samples.max(1);
        let mut samples = Vec::new();
        let mut gap = 0.0f64;
        for t in 0..m.num_triangles() {
            let v = m.triangle(t).map(|x| m.vertex(x));
            let first = samples.len();
            for i in 0..=k {
                for j in 0..=k - i {
                    let b =
                        [i as f64 / k as f64, j as f64 / k as f64, (k - i - j) as f64 / k as f64];
                    let p = [0, 1].map(|a| b[0] * v[0][a] + b[1] * v[1][a] + b[2] * v[2][a]);
                    samples.push((cache.value(t, b), p, t));
                }
            }
            let (mut tlo, mut thi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for (q, _, _) in &samples[first..] {
                for a in 0..2 {
                    tlo[a] = tlo[a].min(q[a]);
                    thi[a] = thi[a].max(q[a]);
                }
            }
            gap = gap.max((thi[0] - tlo[0]).hypot(thi[1] - tlo[1]) / k as f64);
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (q, _, _) in &samples {
            for a in 0..2 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a]);
            }
        }
        let area = ((hi[0] - lo[0]) * (hi[1] - lo[1])).max(1e-12);
        let cell = (area / (samples.len() as f64 / 4.0).max(1.0)).sqrt().max(1e-9);
        let nx = (((hi[0] - lo[0]) / cell) as usize + 1).min(4096);
        let ny = (((hi[1] - lo[1]) / cell) as usize + 1).min(4096);
        let mut buckets = vec![Vec::new(); nx * ny];
        let margin = 2.0 * gap + 1.0;
        let map = InverseMap { spline, opts, lo, hi, margin, cell, nx, ny, buckets: Vec::new() };
        for (q, p, t) in samples {
            let (bx, by) = map.bucket(q);
            buckets[by * nx + bx].push((p, t));
        }
        InverseMap { buckets, ..map }
    }

    fn bucket(&self, q: [f64; 2]) -> (usize, usize) {
        let fx = ((q[0] - self.lo[0]) / self.cell).floor().clamp(0.0, (self.nx - 1) as f64);
        let fy = ((q[1] - self.lo[1]) / self.cell).floor().clamp(0.0, (self.ny - 1) as f64);
        (fx as usize, fy as usize)
    }

    /// Newton from `p0`; `None` if it leaves the mesh or does not converge.
    fn newton(&self, q: [f64; 2], p0: [f64; 2], hint: Option<usize>) -> Option<Preimage> {
        let m = self.spline.mesh();
        let cache = self.spline.eval_cache();
        let mut p = p0;
        let mut t = hint;
        let scale = 1.0 + q[0].abs().max(q[1].abs());
        for _ in 0..self.opts.max_iter {
            let (tri, b) = m.locate(p, t)?;
            t = Some(tri);
            let f = cache.value(tri, b);
            let r = [f[0] - q[0], f[1] - q[1]];
            let j = cache.jacobian(tri, b);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if det.abs() < 1e-300 {
                return None;
            }
            let rn = r[0].hypot(r[1]);
            // |J^-1|_2 from the singular values of the 2x2 Jacobian.
            let fro2 = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
            let smax = ((fro2 + ((fro2 * fro2 - 4.0 * det * det).max(0.0)).sqrt()) / 2.0).sqrt();
            let inv_norm = smax / det.abs();
            if rn <= 1e-12 * scale || rn * inv_norm <= self.opts.tolerance * 1e-3 {
                return Some(Preimage {
                    p,
                    triangle: tri,
                    error_bound: rn * inv_norm * FIRST_ORDER_SLACK,
                });
            }
            let dp =
                [(j[1][1] * r[0] - j[0][1] * r[1]) / det, (-j[1][0] * r[0] + j[0][0] * r[1]) / det];
            p = [p[0] - dp[0], p[1] - dp[1]];
        }
        None
    }

    /// Newton's method for `phi(p) = q` from the seed `p0` only (`triangle`: a hint for
    /// locating `p0`), with the same acceptance test and error bound as [`InverseMap::invert`].
    /// At most [`InverseOptions::max_iter`] iterations; `None` if it leaves the mesh, meets a
    /// singular Jacobian or does not converge.
    pub fn invert_from(
        &self,
        q: [f64; 2],
        p0: [f64; 2],
        triangle: Option<usize>,
    ) -> Option<Preimage> {
        self.newton(q, p0, triangle)
    }

    /// Newton from the accepted preimage `pre` of `q` to machine precision: steps go on while
    /// they shrink and are above [`POLISH_ULPS`] ulps of the coordinate (at most
    /// [`POLISH_MAX_STEPS`]); the point with the smallest residual `|phi(p) - q|` is returned,
    /// with its error bound. A step that leaves the mesh or meets a singular Jacobian stops
    /// the polishing (`pre` or the best point so far is kept).
    pub fn polish(&self, q: [f64; 2], pre: Preimage) -> Preimage {
        let m = self.spline.mesh();
        let cache = self.spline.eval_cache();
        let (mut best, mut best_r) = (pre, f64::INFINITY);
        let (mut p, mut t, mut last_step) = (pre.p, pre.triangle, f64::INFINITY);
        for _ in 0..=POLISH_MAX_STEPS {
            let Some((tri, b)) = m.locate(p, Some(t)) else { break };
            t = tri;
            let f = cache.value(tri, b);
            let r = [f[0] - q[0], f[1] - q[1]];
            let j = cache.jacobian(tri, b);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if det.abs() < 1e-300 {
                break;
            }
            let rn = r[0].hypot(r[1]);
            if rn < best_r {
                let fro2 = j.iter().flatten().map(|v| v * v).sum::<f64>();
                let smax = ((fro2 + (fro2 * fro2 - 4.0 * det * det).max(0.0).sqrt()) / 2.0).sqrt();
                let bound = rn * smax / det.abs() * FIRST_ORDER_SLACK;
                (best, best_r) = (Preimage { p, triangle: tri, error_bound: bound }, rn);
            }
            let dp =
                [(j[1][1] * r[0] - j[0][1] * r[1]) / det, (-j[1][0] * r[0] + j[0][0] * r[1]) / det];
            let step = dp[0].hypot(dp[1]);
            let floor = POLISH_ULPS * f64::EPSILON * (1.0 + p[0].abs().max(p[1].abs()));
            if rn == 0.0 || step <= floor || step >= last_step {
                break;
            }
            last_step = step;
            p = [p[0] - dp[0], p[1] - dp[1]];
        }
        best
    }

    /// `phi^-1(q)`; `hint` is a nearby preimage (e.g. the previous pixel's), tried first.
    pub fn invert(&self, q: [f64; 2], hint: Option<&Preimage>) -> Option<Preimage> {
        if let Some(h) = hint {
            if let Some(s) = self.newton(q, h.p, Some(h.triangle)) {
                return Some(s);
            }
        }
        self.invert_from_buckets(q)
    }

    /// `phi^-1(q)` from the forward samples alone: Newton from at most 12 samples whose
    /// images lie in `q`'s bucket or the nearest rings around it, nearest rings first.
    pub fn invert_from_buckets(&self, q: [f64; 2]) -> Option<Preimage> {
        // Seeds from the bucket of q and its neighbours, nearest images first.
        let (bx, by) = self.bucket(q);
        let mut seeds: Vec<([f64; 2], usize)> = Vec::new();
        for ring in 0..3usize {
            for y in by.saturating_sub(ring)..=(by + ring).min(self.ny - 1) {
                for x in bx.saturating_sub(ring)..=(bx + ring).min(self.nx - 1) {
                    if x.abs_diff(bx).max(y.abs_diff(by)) == ring {
                        seeds.extend(self.buckets[y * self.nx + x].iter().copied());
                    }
                }
            }
            if seeds.len() >= 3 {
                break;
            }
        }
        seeds.into_iter().take(12).find_map(|(p, t)| self.newton(q, p, Some(t)))
    }

    /// A box `(lo, hi)` that contains `phi(mesh)`: the bounding box of the forward samples,
    /// grown by twice the largest gap between neighbouring samples (plus one unit). Points
    /// outside it have no preimage.
    pub fn deformed_bbox(&self) -> ([f64; 2], [f64; 2]) {
        let m = self.margin;
        ([self.lo[0] - m, self.lo[1] - m], [self.hi[0] + m, self.hi[1] + m])
    }

    /// The spline being inverted.
    pub fn spline(&self) -> &'a Spline {
        self.spline
    }

    /// The options used.
    pub fn options(&self) -> &InverseOptions {
        &self.opts
    }
}
