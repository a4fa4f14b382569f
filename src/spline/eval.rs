//! Evaluating phi and its Jacobian in `f64` (Bernstein form, thesis eq. 12.1-12.2).
//!
//! On triangle `t = (v0, v1, v2)` with barycentric coordinates `(b0, b1, b2)` of `p`:
//!
//! ```text
//!   phi(p) = sum_{i+j+k=d} d!/(i! j! k!) b0^i b1^j b2^k q^t_ijk
//!   d phi / d x_a = d * sum_{|m|=d-1} B^(d-1)_m(b) (g0_a q_(m+e0) + g1_a q_(m+e1) + g2_a q_(m+e2))
//! ```
//!
//! where `g_c = grad b_c` (constant on the triangle). Both the argument and the result are in
//! mesh coordinates (the map runs from the reference domain to the deformed plane).

use super::layout::multi_indices;

/// Per-triangle data for fast evaluation: the affine frame and the control points in file
/// order, as `f64`.
#[derive(Clone, Debug)]
pub struct EvalCache {
    degree: usize,
    /// Multinomial coefficient of each local point (file order), degree d.
    coef: Vec<f64>,
    /// Multi-indices, degree d.
    mi: Vec<[usize; 3]>,
    /// Multi-indices and coefficients of degree d-1 (for the Jacobian).
    mi1: Vec<[usize; 3]>,
    coef1: Vec<f64>,
    /// For m of degree d-1, the local positions of m+e0, m+e1, m+e2.
    up: Vec<[usize; 3]>,
    /// Control points, `npatch` per triangle.
    pts: Vec<[f64; 2]>,
    /// Frame: origin v0 and gradients of b1 and b2.
    frames: Vec<Frame>,
}

/// Affine frame of a triangle: `b1 = g1 . (p - o)`, `b2 = g2 . (p - o)`, `b0 = 1 - b1 - b2`.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    o: [f64; 2],
    g1: [f64; 2],
    g2: [f64; 2],
}

impl Frame {
    /// The frame of the triangle with the given vertices.
    pub fn new(v: [[f64; 2]; 3]) -> Frame {
        let (e1, e2) =
            ([v[1][0] - v[0][0], v[1][1] - v[0][1]], [v[2][0] - v[0][0], v[2][1] - v[0][1]]);
        let det = e1[0] * e2[1] - e2[0] * e1[1];
        Frame { o: v[0], g1: [e2[1] / det, -e2[0] / det], g2: [-e1[1] / det, e1[0] / det] }
    }
    /// Barycentric coordinates of `p`.
    #[inline]
    pub fn bary(&self, p: [f64; 2]) -> [f64; 3] {
        let (dx, dy) = (p[0] - self.o[0], p[1] - self.o[1]);
        let b1 = self.g1[0] * dx + self.g1[1] * dy;
        let b2 = self.g2[0] * dx + self.g2[1] * dy;
        [1.0 - b1 - b2, b1, b2]
    }
    /// Gradients of `(b0, b1, b2)`.
    pub fn gradients(&self) -> [[f64; 2]; 3] {
        [[-self.g1[0] - self.g2[0], -self.g1[1] - self.g2[1]], self.g1, self.g2]
    }
}

/// The inverse of the collocation matrix `C[p][m] = B_m(x_p)` of the degree-`k` Bernstein
/// basis at the uniform domain points `x_p = p / k` (both in [`multi_indices`] order), by
/// Gauss-Jordan elimination with partial pivoting (the matrix is small and well conditioned).
fn collocation_inverse(
    k: usize,
    mi: &[[usize; 3]],
    basis: &dyn Fn([f64; 3]) -> Vec<f64>,
) -> Vec<Vec<f64>> {
    let n = mi.len();
    if k == 0 {
        return vec![vec![1.0]];
    }
    let mut a: Vec<Vec<f64>> = mi
        .iter()
        .map(|p| basis([p[0] as f64 / k as f64, p[1] as f64 / k as f64, p[2] as f64 / k as f64]))
        .collect();
    let mut inv: Vec<Vec<f64>> =
        (0..n).map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect()).collect();
    for c in 0..n {
        let piv = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs())).unwrap_or(c);
        a.swap(c, piv);
        inv.swap(c, piv);
        let d = a[c][c];
        for j in 0..n {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for r in 0..n {
            if r != c {
                let f = a[r][c];
                if f != 0.0 {
                    for j in 0..n {
                        a[r][j] -= f * a[c][j];
                        inv[r][j] -= f * inv[c][j];
                    }
                }
            }
        }
    }
    // inv maps values at domain points (rows of C indexed by p) to coefficients: c = C^-1 v.
    inv
}

fn multinomials(d: usize, mi: &[[usize; 3]]) -> Vec<f64> {
    let fact = |n: usize| (1..=n).map(|x| x as f64).product::<f64>();
    mi.iter().map(|m| fact(d) / (fact(m[0]) * fact(m[1]) * fact(m[2]))).collect()
}

impl EvalCache {
    /// Builds the cache from triangle vertex coordinates and the patch control points.
    pub fn new(
        degree: usize,
        triangles: &[[[f64; 2]; 3]],
        patch_points: Vec<[f64; 2]>,
    ) -> EvalCache {
        let mi = multi_indices(degree);
        let coef = multinomials(degree, &mi);
        let mi1 = if degree >= 1 { multi_indices(degree - 1) } else { Vec::new() };
        let coef1 = multinomials(degree.saturating_sub(1), &mi1);
        let up = mi1
            .iter()
            .map(|m| {
                [0, 1, 2].map(|c| {
                    let mut n = *m;
                    n[c] += 1;
                    super::layout::local_index(degree, n[0], n[1])
                })
            })
            .collect();
        let frames = triangles.iter().map(|v| Frame::new(*v)).collect();
        EvalCache { degree, coef, mi, mi1, coef1, up, pts: patch_points, frames }
    }

    /// Number of local points per triangle.
    pub fn per_patch(&self) -> usize {
        self.mi.len()
    }

    /// Sets one slot (`triangle * per_patch + local index`) of the patch control points.
    #[inline]
    pub fn set_slot(&mut self, slot: usize, q: [f64; 2]) {
        self.pts[slot] = q;
    }

    /// The control point in slot `slot` of the flattened patch array (`per_patch()` slots
    /// per triangle, in file order).
    pub fn patch_point(&self, slot: usize) -> [f64; 2] {
        self.pts[slot]
    }

    /// Replaces the control points of the patches (same layout).
    pub fn set_points(&mut self, patch_points: Vec<[f64; 2]>) {
        assert_eq!(patch_points.len(), self.pts.len());
        self.pts = patch_points;
    }

    /// The frame of triangle `t`.
    pub fn frame(&self, t: usize) -> &Frame {
        &self.frames[t]
    }

    #[inline]
    fn powers(&self, b: [f64; 3], d: usize) -> [[f64; 16]; 3] {
        let mut pw = [[1.0f64; 16]; 3];
        for c in 0..3 {
            for e in 1..=d.min(15) {
                pw[c][e] = pw[c][e - 1] * b[c];
            }
        }
        pw
    }

    /// phi on triangle `t` at barycentric coordinates `b`.
    #[inline]
    pub fn value(&self, t: usize, b: [f64; 3]) -> [f64; 2] {
        let d = self.degree;
        let n = self.mi.len();
        let q = &self.pts[t * n..(t + 1) * n];
        if d > 15 {
            return self.value_slow(q, b);
        }
        let pw = self.powers(b, d);
        let (mut x, mut y) = (0.0, 0.0);
        for ((m, c), p) in self.mi.iter().zip(&self.coef).zip(q) {
            let w = c * pw[0][m[0]] * pw[1][m[1]] * pw[2][m[2]];
            x += w * p[0];
            y += w * p[1];
        }
        [x, y]
    }

    fn value_slow(&self, q: &[[f64; 2]], b: [f64; 3]) -> [f64; 2] {
        let (mut x, mut y) = (0.0, 0.0);
        for ((m, c), p) in self.mi.iter().zip(&self.coef).zip(q) {
            let w = c * b[0].powi(m[0] as i32) * b[1].powi(m[1] as i32) * b[2].powi(m[2] as i32);
            x += w * p[0];
            y += w * p[1];
        }
        [x, y]
    }

    /// A bound `M` with `|D^2 phi(p)[u, u]| <= M |u|^2` for every `p` in triangle `t` and
    /// every direction `u` (mesh units).
    ///
    /// The second directional derivative is a Bernstein polynomial of degree `d - 2`:
    /// `D_u^2 phi = d (d-1) sum_{|m|=d-2} B_m(b) u^T H_m u` with
    /// `H_m = sum_{k,l} g_k g_l^T q_(m+e_k+e_l)` (per output coordinate, `g_k = grad b_k`).
    /// Bernstein weights are non-negative and sum to one, so
    /// `|u^T H u| <= max_m rho(H_m) |u|^2` per coordinate (`rho`: spectral radius of the
    /// symmetric 2x2 matrix); the two coordinates combine in the Euclidean norm.
    pub fn second_derivative_bound(&self, t: usize) -> f64 {
        let d = self.degree;
        if d < 2 {
            return 0.0;
        }
        let n = self.mi.len();
        let q = &self.pts[t * n..(t + 1) * n];
        let worst = hessian_rho(d, self.frames[t].gradients(), q);
        (d * (d - 1)) as f64 * worst[0].hypot(worst[1]) * (1.0 + 1e-9)
    }

    /// A bound `E` with `|D^2 (phi - f psi)(p)[u, u]| <= E |u|^2` for every `p` of the mesh
    /// and every direction `u`, where `phi` is this spline and `psi` the spline of `other`
    /// (the same mesh and degree); `f64::INFINITY` if `other` is on another mesh or degree.
    ///
    /// Per triangle, the bound of [`second_derivative_bound`](Self::second_derivative_bound)
    /// applied to the control points `q_i - f o_i` of `phi - f psi` (the Hessian is linear in
    /// the control points), plus their rounding: each computed difference is within
    /// `2 eps (|f o_i| + |q_i - f o_i|)` of the exact one, and a control-point error `e`
    /// moves every `H_m` by at most `G^2 |e|` per coordinate (`G = sum_k |g_k|`), which
    /// also covers the rounding of the Hessian sums and of `rho` (each entry of `H_m` sums
    /// nine products of size at most `G^2 max |q_i - f o_i|`; `64 eps` times that).
    ///
    /// With it, `|D^2 phi| <= |f| M_psi + E` wherever `M_psi` bounds `|D^2 psi|`: the plans
    /// of a morph's frames, `(1 - s) id + s phi` with exact blends rounded to `f64`, reuse the
    /// bounds of `phi` scaled by `s` ([`crate::warp::remap::CurvatureBounds`]); there `E` is
    /// a few rounding errors.
    pub fn second_derivative_excess_bound(&self, other: &EvalCache, f: f64) -> f64 {
        let d = self.degree;
        if d != other.degree
            || self.pts.len() != other.pts.len()
            || self.frames.len() != other.frames.len()
        {
            return f64::INFINITY;
        }
        if d < 2 {
            return 0.0;
        }
        let n = self.mi.len();
        let eps = f64::EPSILON;
        let mut diff = vec![[0.0f64; 2]; n];
        let mut out = 0.0f64;
        for (t, (fa, fb)) in self.frames.iter().zip(&other.frames).enumerate() {
            let g = fa.gradients();
            if g != fb.gradients() || fa.o != fb.o {
                return f64::INFINITY;
            }
            let (q, o) = (&self.pts[t * n..(t + 1) * n], &other.pts[t * n..(t + 1) * n]);
            let (mut err, mut big) = (0.0f64, 0.0f64);
            for ((slot, qi), oi) in diff.iter_mut().zip(q).zip(o) {
                for r in 0..2 {
                    let fo = f * oi[r];
                    slot[r] = qi[r] - fo;
                    err = err.max(2.0 * eps * (fo.abs() + slot[r].abs()));
                    big = big.max(slot[r].abs());
                }
            }
            let worst = hessian_rho(d, g, &diff);
            let gsum: f64 = g.iter().map(|v| v[0].hypot(v[1])).sum();
            let slack = std::f64::consts::SQRT_2 * gsum * gsum * (err + 64.0 * eps * big);
            let e = (d * (d - 1)) as f64 * (worst[0].hypot(worst[1]) + slack) * (1.0 + 1e-9);
            if !e.is_finite() {
                return f64::INFINITY;
            }
            out = out.max(e);
        }
        out
    }

    /// The Hessian coefficients of triangle `t`: for each multi-index `m` of degree `d - 2`
    /// (in [`multi_indices`] order), `H_m = sum_{k,l} g_k g_l^T q_(m+e_k+e_l)` as
    /// `[h00, h11, h01]` for x then for y; `D^2 phi = d(d-1) sum_m B_m(b) H_m`.
    fn hessian_coefficients(&self, t: usize) -> Vec<[f64; 6]> {
        let d = self.degree;
        let n = self.mi.len();
        let q = &self.pts[t * n..(t + 1) * n];
        let g = self.frames[t].gradients();
        multi_indices(d - 2)
            .iter()
            .map(|m| {
                let mut h = [0.0f64; 6];
                for k in 0..3 {
                    for l in 0..3 {
                        let mut idx = *m;
                        idx[k] += 1;
                        idx[l] += 1;
                        let v = q[super::layout::local_index(d, idx[0], idx[1])];
                        for r in 0..2 {
                            h[3 * r] += g[k][0] * g[l][0] * v[r];
                            h[3 * r + 1] += g[k][1] * g[l][1] * v[r];
                            h[3 * r + 2] += 0.5 * (g[k][0] * g[l][1] + g[k][1] * g[l][0]) * v[r];
                        }
                    }
                }
                h
            })
            .collect()
    }

    /// Bounds on `|D^2 phi|` (as in [`second_derivative_bound`](Self::second_derivative_bound))
    /// over the `n^2` sub-triangles of the uniform `n`-subdivision of triangle `t`, each with
    /// its vertices (barycentric).
    ///
    /// Each sub-triangle's Bernstein coefficients of the Hessian are obtained exactly (up to
    /// rounding) from the Hessian's values at its domain points: a fixed linear map (the
    /// inverse of the Bernstein collocation matrix at the uniform domain points), the same for
    /// every sub-triangle in its own barycentric coordinates. The convex-hull bound of
    /// [`second_derivative_bound`](Self::second_derivative_bound) is then applied per
    /// sub-triangle, so the bounds approach the true local maximum as `n` grows.
    pub fn second_derivative_bounds_uniform(
        &self,
        t: usize,
        n: usize,
    ) -> Vec<([[f64; 3]; 3], f64)> {
        self.second_derivative_bounds_uniform_by(t, n, true)
    }

    /// [`second_derivative_bounds_uniform`](Self::second_derivative_bounds_uniform), with the
    /// shared-coefficient path for degree 5 ([`cubic_bounds_uniform`]) when `cubic` is true,
    /// else the per-sub-triangle collocation inverse for every degree (tests compare them).
    pub(crate) fn second_derivative_bounds_uniform_by(
        &self,
        t: usize,
        n: usize,
        cubic: bool,
    ) -> Vec<([[f64; 3]; 3], f64)> {
        let d = self.degree;
        let n = n.max(1);
        if d < 2 {
            return Vec::new();
        }
        let k = d - 2;
        let coef = self.hessian_coefficients(t);
        let mi = multi_indices(k);
        let fact = |n: usize| (1..=n).map(|x| x as f64).product::<f64>();
        let multi: Vec<f64> =
            mi.iter().map(|m| fact(k) / (fact(m[0]) * fact(m[1]) * fact(m[2]))).collect();
        let basis = |b: [f64; 3]| -> Vec<f64> {
            mi.iter()
                .zip(&multi)
                .map(|(m, c)| {
                    c * b[0].powi(m[0] as i32) * b[1].powi(m[1] as i32) * b[2].powi(m[2] as i32)
                })
                .collect()
        };
        // Values of the Hessian on the refined lattice (resolution n*k), indexed (i, j) with
        // barycentrics (1 - (i+j)/N, i/N, j/N).
        let big = n * k.max(1);
        let stride = big + 1;
        let mut vals = vec![[0.0f64; 6]; stride * stride];
        // `basis(b)` without allocating, powers by repeated multiplication: the same values as
        // `powi` up to 3 (degree 5), a few ulps apart above, far inside the bound's margin.
        let mut pw = vec![[1.0f64; 3]; k + 1];
        let mut w = vec![0.0f64; mi.len()];
        let bigf = big as f64;
        let mut value_at = |i: f64, j: f64| {
            let b = [1.0 - (i + j) / bigf, i / bigf, j / bigf];
            for e in 1..=k {
                pw[e] = [0, 1, 2].map(|a| pw[e - 1][a] * b[a]);
            }
            for ((wm, m), c) in w.iter_mut().zip(&mi).zip(&multi) {
                *wm = c * pw[m[0]][0] * pw[m[1]][1] * pw[m[2]][2];
            }
            let mut h = [0.0f64; 6];
            for (wm, cm) in w.iter().zip(&coef) {
                for e in 0..6 {
                    h[e] += wm * cm[e];
                }
            }
            h
        };
        if k == 3 && cubic {
            cubic_lattice_values(&mut vals, big, &mut value_at);
        } else {
            for i in 0..=big {
                for j in 0..=big - i {
                    vals[i * stride + j] = value_at(i as f64, j as f64);
                }
            }
        }
        let scale = (d * (d - 1)) as f64;
        if k == 3 && cubic {
            return cubic_bounds_uniform(&vals, n, scale);
        }
        let minv = collocation_inverse(k, &mi, &basis);
        let mut out = Vec::with_capacity(n * n);
        let mut local = vec![[0.0f64; 6]; mi.len()];
        for i in 0..n {
            for j in 0..n - i {
                let mut subs = vec![[(i, j), (i + 1, j), (i, j + 1)]];
                if i + j + 1 < n {
                    subs.push([(i + 1, j), (i + 1, j + 1), (i, j + 1)]);
                }
                for sub in subs {
                    // Domain point alpha of the sub-triangle, on the refined lattice.
                    for (slot, a) in local.iter_mut().zip(&mi) {
                        let li = a[0] * sub[0].0 + a[1] * sub[1].0 + a[2] * sub[2].0;
                        let lj = a[0] * sub[0].1 + a[1] * sub[1].1 + a[2] * sub[2].1;
                        *slot = vals[li * stride + lj];
                    }
                    let mut worst = [0.0f64; 2];
                    for row in &minv {
                        let mut h = [0.0f64; 6];
                        for (w, v) in row.iter().zip(&local) {
                            for e in 0..6 {
                                h[e] += w * v[e];
                            }
                        }
                        for (r, w) in worst.iter_mut().enumerate() {
                            *w = w.max(rho(&h, r));
                        }
                    }
                    out.push(sub_bound(sub, n, scale, worst));
                }
            }
        }
        out
    }

    /// A box `(lo, hi)` containing `phi(T)` for triangle `t`: the bounding box of its control
    /// points. The Bernstein weights are non-negative and sum to one, so every value of the
    /// patch is a convex combination of its control points (thesis ch. 12, convex hull
    /// property of Bezier triangles).
    pub fn patch_bbox(&self, t: usize) -> ([f64; 2], [f64; 2]) {
        let n = self.mi.len();
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for q in &self.pts[t * n..(t + 1) * n] {
            for a in 0..2 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a]);
            }
        }
        (lo, hi)
    }

    /// The images `[phi(v0), phi(v1), phi(v2)]` of triangle `t`'s vertices and a bound
    /// `delta` with `|phi(p) - A(p)| <= delta` on the whole triangle, `A` the affine map
    /// through those three images.
    ///
    /// `A` written in degree `d` has the control points `a_m = (m0 q_d00 + m1 q_0d0 + m2
    /// q_00d) / d` (degree elevation of a linear polynomial), so `phi - A` has the control
    /// points `q_m - a_m`; Bernstein weights are non-negative and sum to one, so
    /// `|phi(p) - A(p)| <= max_m |q_m - a_m|` (Euclidean norm; `delta` carries a relative
    /// slack of `1e-9` and `1e-9` absolute for its own rounding).
    pub fn affine_defect(&self, t: usize) -> ([[f64; 2]; 3], f64) {
        let d = self.degree;
        let n = self.mi.len();
        let q = &self.pts[t * n..(t + 1) * n];
        let mut corner = [[0.0f64; 2]; 3];
        for (m, p) in self.mi.iter().zip(q) {
            for (c, v) in corner.iter_mut().enumerate() {
                if m[c] == d {
                    *v = *p;
                }
            }
        }
        if d == 0 {
            return ([q[0]; 3], 0.0);
        }
        let df = d as f64;
        let mut worst = 0.0f64;
        let mut scale = 0.0f64;
        for (m, p) in self.mi.iter().zip(q) {
            let a = [0, 1].map(|r| {
                (m[0] as f64 * corner[0][r]
                    + m[1] as f64 * corner[1][r]
                    + m[2] as f64 * corner[2][r])
                    / df
            });
            worst = worst.max((p[0] - a[0]).hypot(p[1] - a[1]));
            scale = scale.max(p[0].abs().max(p[1].abs()));
        }
        (corner, worst * (1.0 + 1e-9) + 1e-9 * (1.0 + scale))
    }

    /// A bound `L` with `|J(p) u| <= L |u|` for every `p` in triangle `t` (spectral norm of
    /// the Jacobian; mesh units in and out).
    ///
    /// By the formula of the module docs, `J = d sum_{|m|=d-1} B_m(b) J_m` with the constant
    /// matrices `J_m[r][a] = sum_c g_c[a] q_(m+e_c)[r]`; the weights `B_m` are non-negative
    /// and sum to one and the norm is convex, so `|J|_2 <= d max_m |J_m|_2` (the spectral
    /// norm of a 2x2 matrix in closed form, `sqrt((F + sqrt(F^2 - 4 D^2)) / 2)` with `F` the
    /// squared Frobenius norm and `D` the determinant).
    pub fn jacobian_bound(&self, t: usize) -> f64 {
        let d = self.degree;
        if d == 0 {
            return 0.0;
        }
        let n = self.mi.len();
        let q = &self.pts[t * n..(t + 1) * n];
        let g = self.frames[t].gradients();
        let mut worst = 0.0f64;
        for up in &self.up {
            let mut j = [[0.0f64; 2]; 2];
            for (axis, col) in [0, 1].into_iter().zip([0, 1]) {
                for r in 0..2 {
                    j[r][col] = g[0][axis] * q[up[0]][r]
                        + g[1][axis] * q[up[1]][r]
                        + g[2][axis] * q[up[2]][r];
                }
            }
            let fro2 = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            let s2 = (fro2 + (fro2 * fro2 - 4.0 * det * det).max(0.0).sqrt()) / 2.0;
            worst = worst.max(s2.sqrt());
        }
        // Relative slack for the rounding of the closed form.
        d as f64 * worst * (1.0 + 1e-9)
    }

    /// Jacobian `[[dphi_x/dx, dphi_x/dy], [dphi_y/dx, dphi_y/dy]]` on triangle `t`.
    pub fn jacobian(&self, t: usize, b: [f64; 3]) -> [[f64; 2]; 2] {
        let d = self.degree;
        let n = self.mi.len();
        let q = &self.pts[t * n..(t + 1) * n];
        let g = self.frames[t].gradients();
        let mut j = [[0.0; 2]; 2];
        for ((m, c), up) in self.mi1.iter().zip(&self.coef1).zip(&self.up) {
            let w = c
                * b[0].powi(m[0] as i32)
                * b[1].powi(m[1] as i32)
                * b[2].powi(m[2] as i32)
                * d as f64;
            for axis in 0..2 {
                for r in 0..2 {
                    let dq = g[0][axis] * q[up[0]][r]
                        + g[1][axis] * q[up[1]][r]
                        + g[2][axis] * q[up[2]][r];
                    j[r][axis] += w * dq;
                }
            }
        }
        j
    }
}

/// Per output coordinate, `max_m rho(H_m)` for the Hessian coefficients
/// `H_m = sum_{k,l} g_k g_l^T q_(m+e_k+e_l)` of a degree-`d` patch `q` (file order) with
/// barycentric gradients `g` (see [`EvalCache::second_derivative_bound`]).
fn hessian_rho(d: usize, g: [[f64; 2]; 3], q: &[[f64; 2]]) -> [f64; 2] {
    let mut worst = [0.0f64; 2];
    for m in multi_indices(d - 2) {
        let mut h = [[0.0f64; 3]; 2];
        for k in 0..3 {
            for l in 0..3 {
                let mut idx = m;
                idx[k] += 1;
                idx[l] += 1;
                let v = q[super::layout::local_index(d, idx[0], idx[1])];
                for r in 0..2 {
                    h[r][0] += g[k][0] * g[l][0] * v[r];
                    h[r][1] += g[k][1] * g[l][1] * v[r];
                    h[r][2] += 0.5 * (g[k][0] * g[l][1] + g[k][1] * g[l][0]) * v[r];
                }
            }
        }
        for r in 0..2 {
            let [p, s, c] = h[r];
            let rho = ((p + s) / 2.0).abs() + (((p - s) / 2.0).powi(2) + c * c).sqrt();
            worst[r] = worst[r].max(rho);
        }
    }
    worst
}

/// The sub-triangle `sub` (vertices on the `n`-lattice, `(i, j)` with barycentrics
/// `(1 - (i+j)/n, i/n, j/n)`) with its bound `scale |(worst_0, worst_1)|`, widened by a
/// relative `1e-6` for the rounding of the coefficients.
fn sub_bound(
    sub: [(usize, usize); 3],
    n: usize,
    scale: f64,
    worst: [f64; 2],
) -> ([[f64; 3]; 3], f64) {
    let bary = |(i, j): (usize, usize)| {
        let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
        [1.0 - a - b, a, b]
    };
    (sub.map(bary), scale * worst[0].hypot(worst[1]) * (1.0 + 1e-6) + 1e-300)
}

/// A bound on the spectral norm of the symmetric matrices `[[p, c], [c, s]]` of output `r`
/// of a Hessian coefficient `h = (p0, s0, c0, p1, s1, c1)`: `|p + s| / 2 + sqrt(((p - s) / 2)^2 + c^2)`.
#[inline(always)]
fn rho(h: &[f64; 6], r: usize) -> f64 {
    let (p, s, c) = (h[3 * r], h[3 * r + 1], h[3 * r + 2]);
    ((p + s) / 2.0).abs() + (((p - s) / 2.0).powi(2) + c * c).sqrt()
}

/// [`EvalCache::second_derivative_bounds_uniform`] for a cubic Hessian (degree 5), from its
/// values `vals` on the refined lattice of resolution `3n` (row `i`, column `j`, stride
/// `3n + 1`).
///
/// The Hessian restricted to the `n`-subdivision is a continuous piecewise cubic, whose
/// Bernstein coefficients stand one per point of the refined lattice: the domain points of
/// the sub-triangles, shared where sub-triangles meet. So each coefficient (and its norm
/// bound [`rho`]) is computed once, not once per sub-triangle holding it (Farin, *Triangular
/// Bernstein-Bezier patches*, sec. 2; thesis ch. 12):
/// * at a sub-triangle vertex the coefficient is the value;
/// * on an edge from `e0` to `e3` with interior points `e1`, `e2` (at 1/3 and 2/3), the
///   restriction is a univariate cubic with `27 p(e1) = 8 b0 + 12 b1 + 6 b2 + b3` and
///   `27 p(e2) = b0 + 6 b1 + 12 b2 + 8 b3`, so with `A = 27 p(e1) - 8 b0 - b3` and
///   `B = 27 p(e2) - b0 - 8 b3`: `b1 = (2A - B) / 18`, `b2 = (2B - A) / 18`;
/// * at the centroid, where `B_alpha = 6 / (27 alpha!)`:
///   `b111 = (27 p(c) - sum of vertex coefficients - 3 sum of edge coefficients) / 6`.
///
/// The same coefficients (up to rounding) as the collocation inverse of the general path
/// (compared in the tests), in about a fifth of the time.
fn cubic_bounds_uniform(vals: &[[f64; 6]], n: usize, scale: f64) -> Vec<([[f64; 3]; 3], f64)> {
    let big = 3 * n;
    let stride = big + 1;
    let at = |i: usize, j: usize| i * stride + j;
    let mut coef = vec![[0.0f64; 6]; stride * stride];
    let comb = |terms: &[(f64, &[f64; 6])], div: f64| -> [f64; 6] {
        let mut h = [0.0f64; 6];
        for (w, v) in terms {
            for e in 0..6 {
                h[e] += w * v[e];
            }
        }
        h.map(|x| x / div)
    };
    // Vertices, then each edge of the subdivision once (its two interior points).
    for i in (0..=big).step_by(3) {
        for j in (0..=big - i).step_by(3) {
            coef[at(i, j)] = vals[at(i, j)];
        }
    }
    let mut edge = |e: [(usize, usize); 4]| {
        let [b0, v1, v2, b3] = e.map(|(i, j)| vals[at(i, j)]);
        let a = comb(&[(27.0, &v1), (-8.0, &b0), (-1.0, &b3)], 1.0);
        let b = comb(&[(27.0, &v2), (-1.0, &b0), (-8.0, &b3)], 1.0);
        coef[at(e[1].0, e[1].1)] = comb(&[(2.0, &a), (-1.0, &b)], 18.0);
        coef[at(e[2].0, e[2].1)] = comb(&[(2.0, &b), (-1.0, &a)], 18.0);
    };
    for i in (0..=big).step_by(3) {
        for j in (0..=big - i).step_by(3) {
            if i + j < big {
                // Along i, along j, and the diagonal from (i + 3, j) to (i, j + 3).
                edge([(i, j), (i + 1, j), (i + 2, j), (i + 3, j)]);
                edge([(i, j), (i, j + 1), (i, j + 2), (i, j + 3)]);
                edge([(i + 3, j), (i + 2, j + 1), (i + 1, j + 2), (i, j + 3)]);
            }
        }
    }
    // Centroids: up triangles at (i + 1, j + 1), down ones at (i + 2, j + 2).
    let domain = |v: [(usize, usize); 3]| {
        let p = |a: usize, b: usize, c: usize| {
            let (i, j) =
                (a * v[0].0 + b * v[1].0 + c * v[2].0, a * v[0].1 + b * v[1].1 + c * v[2].1);
            (i / 3, j / 3)
        };
        let verts = [p(3, 0, 0), p(0, 3, 0), p(0, 0, 3)];
        let edges = [p(2, 1, 0), p(1, 2, 0), p(0, 2, 1), p(0, 1, 2), p(1, 0, 2), p(2, 0, 1)];
        (verts, edges, p(1, 1, 1))
    };
    let subs = |i: usize, j: usize| {
        let up = [(3 * i, 3 * j), (3 * i + 3, 3 * j), (3 * i, 3 * j + 3)];
        let down = [(3 * i + 3, 3 * j), (3 * i + 3, 3 * j + 3), (3 * i, 3 * j + 3)];
        (up, (i + j + 1 < n).then_some(down))
    };
    for i in 0..n {
        for j in 0..n - i {
            let (up, down) = subs(i, j);
            for v in std::iter::once(up).chain(down) {
                let (verts, edges, c) = domain(v);
                let mut h = vals[at(c.0, c.1)].map(|x| 27.0 * x);
                for (w, pts) in [(1.0, &verts[..]), (3.0, &edges[..])] {
                    for &(a, b) in pts {
                        for e in 0..6 {
                            h[e] -= w * coef[at(a, b)][e];
                        }
                    }
                }
                coef[at(c.0, c.1)] = h.map(|x| x / 6.0);
            }
        }
    }
    // Norm bounds of the lattice's points only (the array's other half is unused).
    let mut norms = vec![[0.0f64; 2]; stride * stride];
    for i in 0..=big {
        for j in 0..=big - i {
            let h = &coef[at(i, j)];
            norms[at(i, j)] = [rho(h, 0), rho(h, 1)];
        }
    }
    let mut out = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n - i {
            let (up, down) = subs(i, j);
            for v in std::iter::once(up).chain(down) {
                let (verts, edges, c) = domain(v);
                let mut worst = norms[at(c.0, c.1)];
                for &(a, b) in verts.iter().chain(&edges) {
                    let r = norms[at(a, b)];
                    worst = [worst[0].max(r[0]), worst[1].max(r[1])];
                }
                out.push(sub_bound(v.map(|(a, b)| (a / 3, b / 3)), n, scale, worst));
            }
        }
    }
    out
}

/// Fills `vals` (stride `big + 1`) with a cubic's values on the lattice `i + j <= big` from
/// `value_at(i, j)` (any real `i`, `j`): along each row `i` the values are a cubic in `j`,
/// so four evaluations per row (at `j = 0, L/3, 2L/3, L`, `L = big - i`) and Lagrange
/// interpolation between them give the rest, four multiply-adds per value instead of a
/// Bernstein evaluation. Equispaced interpolation inside its four nodes is well conditioned
/// (its weights sum in absolute value to at most 1.7), so the values are those of direct
/// evaluation to a few ulps.
fn cubic_lattice_values(
    vals: &mut [[f64; 6]],
    big: usize,
    value_at: &mut dyn FnMut(f64, f64) -> [f64; 6],
) {
    let stride = big + 1;
    for i in 0..=big {
        let len = big - i;
        let row = &mut vals[i * stride..i * stride + len + 1];
        let fi = i as f64;
        if len < 3 {
            for (j, v) in row.iter_mut().enumerate() {
                *v = value_at(fi, j as f64);
            }
            continue;
        }
        let l = len as f64;
        let nodes = [0.0, 1.0, 2.0, 3.0].map(|m| value_at(fi, m * l / 3.0));
        for (j, v) in row.iter_mut().enumerate() {
            let t = 3.0 * j as f64 / l;
            let w = [
                -(t - 1.0) * (t - 2.0) * (t - 3.0) / 6.0,
                t * (t - 2.0) * (t - 3.0) / 2.0,
                -t * (t - 1.0) * (t - 3.0) / 2.0,
                t * (t - 1.0) * (t - 2.0) / 6.0,
            ];
            let mut h = [0.0f64; 6];
            for (wm, nm) in w.iter().zip(&nodes) {
                for e in 0..6 {
                    h[e] += wm * nm[e];
                }
            }
            *v = h;
        }
    }
}
