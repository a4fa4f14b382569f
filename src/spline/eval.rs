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
