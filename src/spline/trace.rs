//! A certificate for whole families of blended maps: `tr(A J) > 0` on every triangle.
//!
//! For a map `phi` with Jacobian `J` and `det J > 0`, the blend with the identity
//! `phi_s = (1 - s) id + s phi` has
//!
//! ```text
//!   det J_s = (1 - s)^2 + s (1 - s) tr J + s^2 det J,
//! ```
//!
//! so `tr J >= 0` everywhere makes every `phi_s`, `0 <= s <= 1`, fold-free at once (each
//! term is `>= 0` and the first or the last is positive). The morph's other family,
//! `s S + (1 - s) phi` with a similarity `S(p) = K p + t`, `K = [[a, -b], [b, a]]`, has
//! `J_s = K (s I + (1 - s) K^-1 J)` and `K^-1 = K^T / (a^2 + b^2)`, so the condition is
//! `tr(K^T J) >= 0`. Both are `tr(A J) > 0` for a constant `A`.
//!
//! `tr(A J)` is linear in the control points. On triangle `T` with edges `E = [e1 e2]` and
//! the differences `D1_m, D2_m` of [`super::jacobian`], `J = d sum_m B^{d-1}_m [D1_m D2_m]
//! E^-1`, so with `N = E^-1 A`
//!
//! ```text
//!   tr(A J) = d sum_m B^{d-1}_m t_m,   t_m = N00 D1_m.x + N01 D1_m.y + N10 D2_m.x + N11 D2_m.y,
//! ```
//!
//! a Bernstein polynomial: `min_m t_m > 0` proves `tr(A J) > 0` on `T`. Rounding is bounded
//! as in [`super::jacobian`] (Higham's `gamma_k` on the absolute sums, the inputs' relative
//! error on the differences, and `N`'s own error); no subdivision: near-identity blends
//! have `tr J` close to 2, and a triangle that fails only sends the caller back to the
//! per-map certificate.

use super::Spline;
use rayon::prelude::*;

const U: f64 = f64::EPSILON / 2.0;

fn gamma(k: usize) -> f64 {
    let ku = k as f64 * U;
    ku / (1.0 - ku)
}

/// Whether `tr(A J) > 0` is proven on every triangle of `s` (see the module docs), for the
/// control points rounded from their exact values and `A` given in `f64` with relative
/// error at most `a_rel_err` per entry.
pub fn certify_trace(s: &Spline, a: [[f64; 2]; 2], a_rel_err: f64) -> bool {
    let d = s.degree();
    let up = super::jacobian::difference_indices(d);
    let q: Vec<[f64; 2]> = (0..s.num_points()).into_par_iter().map(|p| s.point_f64(p)).collect();
    let rho = super::jacobian::RAT_ROUNDING;
    let m = s.mesh();
    (0..m.num_triangles()).into_par_iter().all(|t| {
        let tri = m.triangle(t).map(|v| m.vertex(v));
        let pts: Vec<[f64; 2]> = s.layout().patches()[t].iter().map(|&p| q[p]).collect();
        triangle_trace_positive(tri, &pts, &up, a, a_rel_err, rho)
    })
}

/// [`certify_trace`] on one triangle with patch points `pts` (relative error `rho`).
fn triangle_trace_positive(
    tri: [[f64; 2]; 3],
    pts: &[[f64; 2]],
    up: &[[usize; 3]],
    a: [[f64; 2]; 2],
    a_rel_err: f64,
    rho: f64,
) -> bool {
    if pts.iter().any(|p| !p[0].is_finite() || !p[1].is_finite()) {
        return false;
    }
    let e1 = [tri[1][0] - tri[0][0], tri[1][1] - tri[0][1]];
    let e2 = [tri[2][0] - tri[0][0], tri[2][1] - tri[0][1]];
    let (x, y) = (e1[0] * e2[1], e2[0] * e1[1]);
    let de = x - y;
    let de_err = gamma(4) * (x.abs() + y.abs());
    if de.abs() <= 2.0 * de_err {
        return false;
    }
    // E^-1 = [[e2y, -e2x], [-e1y, e1x]] / det E (vertices are exact), N = E^-1 A.
    let inv = [[e2[1] / de, -e2[0] / de], [-e1[1] / de, e1[0] / de]];
    let n = [0, 1].map(|i| [0, 1].map(|j| inv[i][0] * a[0][j] + inv[i][1] * a[1][j]));
    // Relative error of each N entry: the division and det E's error, A's error, the
    // product and the sum.
    let n_rel = gamma(4) + de_err / (de.abs() - de_err) + a_rel_err * (1.0 + gamma(2));
    let n_abs: f64 = n.iter().flatten().map(|v| v.abs()).sum::<f64>() * (1.0 + n_rel);
    let qmax = pts.iter().fold(0.0f64, |acc, p| acc.max(p[0].abs()).max(p[1].abs()));
    let h = 2.0 * rho * qmax;
    up.iter().all(|u| {
        let (p0, p1, p2) = (pts[u[0]], pts[u[1]], pts[u[2]]);
        let d1 = [p1[0] - p0[0], p1[1] - p0[1]];
        let d2 = [p2[0] - p0[0], p2[1] - p0[1]];
        let terms = [n[0][0] * d1[0], n[0][1] * d1[1], n[1][0] * d2[0], n[1][1] * d2[1]];
        let tm: f64 = terms.iter().sum();
        let abs: f64 = terms.iter().map(|v| v.abs()).sum();
        // Computation (a difference, a product, three additions), N's error, and the
        // inputs' error on each difference, with a safety factor.
        let err = ((gamma(6) + n_rel * (1.0 + gamma(6))) * abs + n_abs * (h + gamma(1) * h))
            * (1.0 + 1e-9);
        tm > err
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::{rat_int, Rat};
    use crate::mesh::{Mesh, MeshOptions};

    /// The affine map `p -> B p` as a degree-5 spline over a grid.
    fn affine(b: [[i64; 2]; 2]) -> Spline {
        let mesh = Mesh::grid(3, 2, 30.0, 20.0, MeshOptions::default()).unwrap();
        let id = Spline::identity(mesh.clone(), 5).unwrap();
        let pts: Vec<Vec<Rat>> = id
            .points()
            .iter()
            .map(|p| (0..2).map(|r| rat_int(b[r][0]) * &p[0] + rat_int(b[r][1]) * &p[1]).collect())
            .collect();
        Spline::from_points(mesh, 5, pts, None).unwrap()
    }

    #[test]
    fn the_trace_of_affine_maps_decides() {
        let id = [[1.0, 0.0], [0.0, 1.0]];
        // Rotations by 45 degrees (scaled): tr = 2 > 0; by 135 degrees: tr = -2.
        assert!(certify_trace(&affine([[1, -1], [1, 1]]), id, 0.0));
        assert!(!certify_trace(&affine([[-1, -1], [1, -1]]), id, 0.0));
        // A quarter turn has tr = 0: not proven positive.
        assert!(!certify_trace(&affine([[0, -1], [1, 0]]), id, 0.0));
        // With A = K^T for K the 135-degree map itself, tr(K^T K) = |K|^2 > 0.
        let k = [[-1.0, -1.0], [1.0, -1.0]];
        let kt = [[k[0][0], k[1][0]], [k[0][1], k[1][1]]];
        assert!(certify_trace(&affine([[-1, -1], [1, -1]]), kt, 0.0));
    }

    #[test]
    fn a_certified_trace_makes_every_blend_fold_free() {
        use crate::spline::jacobian::{certify, CertifyOptions};
        // A shear-and-stretch with positive trace: every blend with the identity certified.
        let s = affine([[2, 1], [0, 1]]);
        assert!(certify_trace(&s, [[1.0, 0.0], [0.0, 1.0]], 0.0));
        let id = Spline::identity(s.mesh().clone(), 5).unwrap();
        for k in 0..=10 {
            let w = Rat::new(crate::exact::Int::from(k), crate::exact::Int::from(10));
            let pts: Vec<Vec<Rat>> = id
                .points()
                .iter()
                .zip(s.points())
                .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x + &(&w * &(y - x))).collect())
                .collect();
            let blend = Spline::from_points(s.mesh().clone(), 5, pts, None).unwrap();
            assert!(certify(&blend, &CertifyOptions::default()).fold_free, "w = {k}/10");
        }
    }
}
