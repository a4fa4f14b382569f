//! Interim fold certificate (to be replaced by the full certificate with subdivision):
//! the Bernstein coefficients of `det J` bound it from below on each triangle.

use super::layout::{local_index, multi_indices};
use super::Spline;

/// A certificate summary.
#[derive(Clone, Debug, PartialEq)]
pub struct DetJ {
    /// A lower bound of `det J` over the mesh (the smallest Bernstein coefficient).
    pub lower_bound: f64,
    /// Whether every coefficient is positive.
    pub fold_free: bool,
}

fn fact(n: usize) -> f64 {
    (1..=n).map(|x| x as f64).product()
}

fn multinomial(m: [usize; 3]) -> f64 {
    fact(m[0] + m[1] + m[2]) / (fact(m[0]) * fact(m[1]) * fact(m[2]))
}

/// The smallest Bernstein coefficient of `det J` on triangle `t` for points `p`.
fn min_coefficient(s: &Spline, t: usize, p: &[[f64; 2]]) -> f64 {
    let d = s.degree();
    let tri = s.mesh().triangle(t).map(|v| s.mesh().vertex(v));
    let g = super::eval::Frame::new(tri).gradients();
    let patch = &s.layout().patches()[t];
    let mi = multi_indices(d - 1);
    let js: Vec<[[f64; 2]; 2]> = mi
        .iter()
        .map(|m| {
            let mut j = [[0.0; 2]; 2];
            for c in 0..3 {
                let mut u = *m;
                u[c] += 1;
                let q = p[patch[local_index(d, u[0], u[1])]];
                for r in 0..2 {
                    for a in 0..2 {
                        j[r][a] += d as f64 * g[c][a] * q[r];
                    }
                }
            }
            j
        })
        .collect();
    let mut coef = std::collections::HashMap::new();
    for (i, m) in mi.iter().enumerate() {
        for (k, n) in mi.iter().enumerate() {
            let gg = [m[0] + n[0], m[1] + n[1], m[2] + n[2]];
            let (a, b) = (js[i], js[k]);
            let mixed = 0.5
                * (a[0][0] * b[1][1] + b[0][0] * a[1][1] - a[0][1] * b[1][0] - b[0][1] * a[1][0]);
            *coef.entry(gg).or_insert(0.0) +=
                multinomial(*m) * multinomial(*n) / multinomial(gg) * mixed;
        }
    }
    coef.values().fold(f64::INFINITY, |a, &b| a.min(b))
}

/// Whether every triangle's coefficients are positive for control points `p`.
pub fn certify_points(s: &Spline, p: &[[f64; 2]]) -> bool {
    (0..s.mesh().num_triangles()).all(|t| min_coefficient(s, t, p) > 0.0)
}

/// The certificate of a spline.
pub fn certify(s: &Spline) -> DetJ {
    let p: Vec<[f64; 2]> = (0..s.num_points()).map(|i| s.point_f64(i)).collect();
    let lb = (0..s.mesh().num_triangles())
        .map(|t| min_coefficient(s, t, &p))
        .fold(f64::INFINITY, f64::min);
    DetJ { lower_bound: lb, fold_free: lb > 0.0 }
}
