//! Bernstein basis rows for fitting: where a landmark's image `phi(s)` comes from, the
//! first derivatives used for `det J`, and the exact thin-plate bending energy of a patch.
//!
//! On triangle `t` with barycentric coordinates `b` (thesis eq. 12.1, 12.2), all in mesh
//! coordinates:
//!
//! ```text
//!   phi(s)         = sum_{|m|=d} B^d_m(b) q_m                       (a fixed row over q)
//!   d phi / d x_a  = d sum_{|m|=d-1} B^(d-1)_m(b) sum_c g_c[a] q_(m+e_c)
//!   d2 phi / dx_a dx_b = d(d-1) sum_{|m|=d-2} B^(d-2)_m(b) sum_{k,l} g_k[a] g_l[b] q_(m+e_k+e_l)
//! ```
//!
//! with `g_c = grad b_c`. The bending (thin-plate) energy of one coordinate `f` of `phi`,
//!
//! ```text
//!   E_T(f) = int_T f_xx^2 + 2 f_xy^2 + f_yy^2 dA,
//! ```
//!
//! is a quadratic form `q^T K_T q` in the patch's control points, computed exactly (up to
//! `f64` rounding) from the Bernstein product integral
//!
//! ```text
//!   int_T B^k_m B^k_n dA = C(k, m) C(k, n) / C(2k, m + n) * 2 |T| / ((2k + 1)(2k + 2)),
//! ```
//!
//! `C` the multinomial coefficients (the product of two degree-`k` Bernstein polynomials is a
//! scaled degree-`2k` one, whose integral is `|T| / C(2k + 2, 2)`).

use crate::spline::eval::Frame;
use crate::spline::layout::{local_index, multi_indices};
use crate::spline::Spline;

fn fact(n: usize) -> f64 {
    (1..=n).map(|x| x as f64).product()
}

fn multinomial(m: [usize; 3]) -> f64 {
    fact(m[0] + m[1] + m[2]) / (fact(m[0]) * fact(m[1]) * fact(m[2]))
}

/// `B^k_m(b)` for every `m` of degree `k` in [`multi_indices`] order.
pub fn bernstein(k: usize, b: [f64; 3]) -> Vec<f64> {
    multi_indices(k)
        .iter()
        .map(|m| {
            multinomial(*m)
                * b[0].powi(m[0] as i32)
                * b[1].powi(m[1] as i32)
                * b[2].powi(m[2] as i32)
        })
        .collect()
}

/// A sparse row over control points: `(global point, weight)`.
pub type Row = Vec<(usize, f64)>;

/// The frame (affine map to barycentric coordinates) of triangle `t` in mesh coordinates.
pub fn frame(s: &Spline, t: usize) -> Frame {
    let tri = s.mesh().triangle(t);
    Frame::new(tri.map(|v| s.mesh().vertex(v)))
}

/// The row of `phi(p)` for `p` with barycentric coordinates `b` in triangle `t`.
pub fn value_row(s: &Spline, t: usize, b: [f64; 3]) -> Row {
    let d = s.degree();
    let patch = &s.layout().patches()[t];
    multi_indices(d)
        .iter()
        .zip(bernstein(d, b))
        .map(|(m, w)| (patch[local_index(d, m[0], m[1])], w))
        .collect()
}

/// The rows of `d phi / dx` and `d phi / dy` at barycentric `b` in triangle `t`, as local
/// weights over the patch's points (file order of the patch).
#[cfg(test)]
pub fn derivative_rows(s: &Spline, t: usize, b: [f64; 3]) -> [Vec<f64>; 2] {
    DerivativeStencil::new(s.degree(), &[b]).rows(frame(s, t).gradients()).remove(0)
}

/// The parts of [`derivative_rows`] that do not depend on the triangle, for a list of
/// barycentric sample points: `d phi / dx_a = sum_m sum_c d B^(d-1)_m(b) g_c[a] q_(m+e_c)`
/// with `g_c` the gradient of the triangle's barycentric coordinate `c`. The Bernstein
/// values (the same for every triangle) are computed once; per triangle only the gradients
/// enter, in the same order of operations as the direct sum (so the rows are bit for bit
/// the same).
#[derive(Clone, Debug)]
pub struct DerivativeStencil {
    /// Patch size `(d + 1)(d + 2) / 2`.
    n: usize,
    /// Per sample: `(local index of m + e_c, c, d B_m(b))` in the sum's order.
    terms: Vec<Vec<(usize, usize, f64)>>,
}

impl DerivativeStencil {
    /// The stencil of degree `d` at the samples `bs`.
    pub fn new(d: usize, bs: &[[f64; 3]]) -> DerivativeStencil {
        let mi = multi_indices(d - 1);
        let terms = bs
            .iter()
            .map(|&b| {
                let mut out = Vec::with_capacity(3 * mi.len());
                for (m, w) in mi.iter().zip(bernstein(d - 1, b)) {
                    for c in 0..3 {
                        let mut up = *m;
                        up[c] += 1;
                        out.push((local_index(d, up[0], up[1]), c, d as f64 * w));
                    }
                }
                out
            })
            .collect();
        DerivativeStencil { n: (d + 1) * (d + 2) / 2, terms }
    }

    /// The derivative rows at every sample for a triangle whose barycentric gradients are
    /// `g` ([`Frame::gradients`]).
    pub fn rows(&self, g: [[f64; 2]; 3]) -> Vec<[Vec<f64>; 2]> {
        self.terms
            .iter()
            .map(|terms| {
                let mut out = [vec![0.0; self.n], vec![0.0; self.n]];
                for &(k, c, dw) in terms {
                    for a in 0..2 {
                        out[a][k] += dw * g[c][a];
                    }
                }
                out
            })
            .collect()
    }
}

/// The parts of the bending matrix shared by every triangle of a degree: the multi-indices
/// of degree `d - 2` and their Bernstein Gram matrix on a triangle of unit area.
#[derive(Clone, Debug)]
pub struct Bending {
    d: usize,
    mk: Vec<[usize; 3]>,
    gram_unit: Vec<f64>,
}

impl Bending {
    /// The shared parts for degree `d`.
    pub fn new(d: usize) -> Bending {
        let k = d.saturating_sub(2);
        let mk = multi_indices(k);
        let nk = mk.len();
        let scale = 2.0 / (((2 * k + 1) * (2 * k + 2)) as f64);
        let mut gram_unit = vec![0.0; nk * nk];
        for (i, a) in mk.iter().enumerate() {
            for (j, b) in mk.iter().enumerate() {
                let sum = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
                gram_unit[i * nk + j] =
                    multinomial(*a) * multinomial(*b) / multinomial(sum) * scale;
            }
        }
        Bending { d, mk, gram_unit }
    }

    /// `K_T` of triangle `t` (local patch order, `n x n` row-major): `E_T(f) = q^T K_T q`
    /// for each coordinate. See the module docs.
    pub fn matrix(&self, s: &Spline, t: usize) -> Vec<f64> {
        let d = self.d;
        let n = (d + 1) * (d + 2) / 2;
        if d < 2 {
            return vec![0.0; n * n];
        }
        let (mk, nk) = (&self.mk, self.mk.len());
        let g = frame(s, t).gradients();
        let tri = s.mesh().triangle(t).map(|v| s.mesh().vertex(v));
        let area = 0.5
            * ((tri[1][0] - tri[0][0]) * (tri[2][1] - tri[0][1])
                - (tri[2][0] - tri[0][0]) * (tri[1][1] - tri[0][1]))
                .abs();
        let dd = (d * (d - 1)) as f64;
        let mut kmat = vec![0.0; n * n];
        let mut l = vec![0.0; nk * n];
        let mut gl = vec![0.0; nk * n];
        // L_ab (nk x n) for (a, b) in xx, yy, xy with weights 1, 1, 2; K += w L^T G L.
        for (a, b, w) in [(0usize, 0usize, 1.0f64), (1, 1, 1.0), (0, 1, 2.0)] {
            l.fill(0.0);
            gl.fill(0.0);
            for (i, m) in mk.iter().enumerate() {
                for kk in 0..3 {
                    for ll in 0..3 {
                        let mut idx = *m;
                        idx[kk] += 1;
                        idx[ll] += 1;
                        l[i * n + local_index(d, idx[0], idx[1])] += dd * g[kk][a] * g[ll][b];
                    }
                }
            }
            for i in 0..nk {
                for j in 0..nk {
                    let gv = self.gram_unit[i * nk + j] * area;
                    for c in 0..n {
                        gl[i * n + c] += gv * l[j * n + c];
                    }
                }
            }
            for i in 0..nk {
                for r in 0..n {
                    let lv = l[i * n + r];
                    if lv != 0.0 {
                        for c in 0..n {
                            kmat[r * n + c] += w * lv * gl[i * n + c];
                        }
                    }
                }
            }
        }
        kmat
    }
}

/// The bending matrix `K_T` of triangle `t` ([`Bending::matrix`]).
#[cfg(test)]
pub fn bending_matrix(s: &Spline, t: usize) -> Vec<f64> {
    Bending::new(s.degree()).matrix(s, t)
}

/// Barycentric sample points of level `k` in a triangle (`(k+1)(k+2)/2` points, vertices
/// and edges included).
pub fn sample_points(k: usize) -> Vec<[f64; 3]> {
    multi_indices(k).iter().map(|m| m.map(|c| c as f64 / k as f64)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::{rat_from_f64, Rat};
    use crate::mesh::{Mesh, MeshOptions};

    /// The spline of the quadratic map `phi(x, y) = (x + a x^2, y + b x y)`: each control
    /// point is the polar form (blossom) of the map at the triangle's vertices repeated as
    /// its multi-index says.
    fn bent_spline() -> Spline {
        let mesh = Mesh::grid(2, 2, 40.0, 30.0, MeshOptions::default()).unwrap();
        let id = Spline::identity(mesh, 5).unwrap();
        // The blossom of x^2 at (p1..p5) is the mean of x_i x_j over ordered pairs i != j.
        let (a, b) = (0.01, 0.02);
        let lay = id.layout();
        let mesh = id.mesh();
        let d = 5;
        let mut pts: Vec<Vec<Rat>> = id.points().to_vec();
        for t in 0..mesh.num_triangles() {
            let tri = mesh.triangle(t).map(|v| mesh.vertex(v));
            for m in multi_indices(d) {
                let mut args: Vec<[f64; 2]> = Vec::new();
                for c in 0..3 {
                    for _ in 0..m[c] {
                        args.push(tri[c]);
                    }
                }
                let (mut xx, mut xy, mut cnt) = (0.0, 0.0, 0.0);
                for i in 0..d {
                    for j in 0..d {
                        if i != j {
                            xx += args[i][0] * args[j][0];
                            xy += args[i][0] * args[j][1];
                            cnt += 1.0;
                        }
                    }
                }
                let mx = args.iter().map(|p| p[0]).sum::<f64>() / d as f64;
                let my = args.iter().map(|p| p[1]).sum::<f64>() / d as f64;
                let p = lay.point(t, m);
                pts[p] = vec![
                    rat_from_f64(mx + a * xx / cnt).unwrap(),
                    rat_from_f64(my + b * xy / cnt).unwrap(),
                ];
            }
        }
        Spline::from_points_unchecked(id.mesh().clone(), 5, pts, None).unwrap()
    }

    #[test]
    fn bending_energy_of_a_quadratic_map_is_exact() {
        let s = bent_spline();
        // phi_x = x + a x^2: f_xx = 2a -> E = 4 a^2 |domain|; phi_y = y + b x y: f_xy = b ->
        // E = 2 b^2 |domain|.
        let (a, b, area) = (0.01f64, 0.02f64, 40.0 * 30.0);
        let mut ex = 0.0;
        let mut ey = 0.0;
        for t in 0..s.mesh().num_triangles() {
            let k = bending_matrix(&s, t);
            let patch = &s.layout().patches()[t];
            let n = patch.len();
            for r in 0..n {
                for c in 0..n {
                    let (p, q) = (s.point_f64(patch[r]), s.point_f64(patch[c]));
                    ex += p[0] * k[r * n + c] * q[0];
                    ey += p[1] * k[r * n + c] * q[1];
                }
            }
        }
        assert!((ex - 4.0 * a * a * area).abs() < 1e-9 * (1.0 + ex.abs()), "{ex}");
        assert!((ey - 2.0 * b * b * area).abs() < 1e-9, "{ey}");
    }

    #[test]
    fn value_and_derivative_rows_match_the_evaluator() {
        let s = bent_spline();
        for (t, b) in [(0usize, [0.2, 0.3, 0.5]), (5, [0.7, 0.1, 0.2]), (3, [1.0, 0.0, 0.0])] {
            let row = value_row(&s, t, b);
            let mut v = [0.0; 2];
            for (p, w) in &row {
                let q = s.point_f64(*p);
                v[0] += w * q[0];
                v[1] += w * q[1];
            }
            let tri = s.mesh().triangle(t).map(|i| s.mesh().vertex(i));
            let x = [
                b[0] * tri[0][0] + b[1] * tri[1][0] + b[2] * tri[2][0],
                b[0] * tri[0][1] + b[1] * tri[1][1] + b[2] * tri[2][1],
            ];
            let (a, bb) = (0.01, 0.02);
            let want = [x[0] + a * x[0] * x[0], x[1] + bb * x[0] * x[1]];
            assert!((v[0] - want[0]).abs() < 1e-9 && (v[1] - want[1]).abs() < 1e-9);
            let [dx, dy] = derivative_rows(&s, t, b);
            let patch = &s.layout().patches()[t];
            let mut j = [[0.0; 2]; 2];
            for (k, &p) in patch.iter().enumerate() {
                let q = s.point_f64(p);
                for c in 0..2 {
                    j[c][0] += dx[k] * q[c];
                    j[c][1] += dy[k] * q[c];
                }
            }
            let want_j = [[1.0 + 2.0 * a * x[0], 0.0], [bb * x[1], 1.0 + bb * x[0]]];
            for r in 0..2 {
                for c in 0..2 {
                    assert!((j[r][c] - want_j[r][c]).abs() < 1e-9, "{j:?} {want_j:?}");
                }
            }
        }
    }
}
