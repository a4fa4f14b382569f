//! A generated organism-like model: a C. elegans-like tapered tube lying on the slide.
//!
//! The centre line runs along x from 0 to `length`, bent gently in the xy plane
//! (`y = bend sin(2 pi x / length)`), at `z = 0`. The radius grows from a rounded head,
//! is widest near the middle and tapers to a pointed tail:
//! `r(s) = radius * sin(pi s)^0.5 * (1 - 0.6 s^3)` for `s = x / length` in `[0, 1]`, plus
//! closing vertices at both tips. Rings are circles in the plane normal to the centre line.
//! Landmarks (named vertices): `head_tip`, `pharynx` (the dorsal surface at s = 0.13),
//! `vulva` (the ventral surface at s = 0.5) and `tail_tip`. Units are micrometres (an adult
//! is about 1 mm long and 60 um wide); the thesis' D. anser model (Table 19.1) has 38,000
//! vertices, this one about 10,000 by default.

use super::Model;
use std::f64::consts::PI;

/// Parameters of [`worm`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WormOptions {
    /// Length along x (um).
    pub length: f64,
    /// Largest radius (um).
    pub radius: f64,
    /// Amplitude of the bend in y (um).
    pub bend: f64,
    /// Rings along the body.
    pub rings: usize,
    /// Vertices per ring.
    pub around: usize,
}

impl Default for WormOptions {
    fn default() -> Self {
        WormOptions { length: 1000.0, radius: 32.0, bend: 60.0, rings: 250, around: 40 }
    }
}

/// The worm model: `2 * around * (rings - 1) + 2 * around` triangles (20,000 by default).
pub fn worm(o: &WormOptions) -> Model {
    let (n, m) = (o.rings.max(3), o.around.max(3));
    let centre = |s: f64| [s * o.length, o.bend * (2.0 * PI * s).sin(), 0.0];
    let tangent = |s: f64| {
        let d = [o.length, o.bend * 2.0 * PI * (2.0 * PI * s).cos()];
        let l = d[0].hypot(d[1]);
        [d[0] / l, d[1] / l]
    };
    let radius = |s: f64| o.radius * (PI * s).sin().max(0.0).sqrt() * (1.0 - 0.6 * s.powi(3));
    let mut vertices = Vec::with_capacity(n * m + 2);
    vertices.push(centre(0.0)); // head tip
    for i in 1..=n {
        let s = i as f64 / (n + 1) as f64;
        let (c, t, r) = (centre(s), tangent(s), radius(s));
        // Ring frame: side = the in-plane normal (-t_y, t_x), up = z.
        let side = [-t[1], t[0]];
        for j in 0..m {
            let th = 2.0 * PI * j as f64 / m as f64;
            let (cs, sn) = (th.cos(), th.sin());
            vertices.push([c[0] + r * cs * side[0], c[1] + r * cs * side[1], c[2] + r * sn]);
        }
    }
    vertices.push(centre(1.0)); // tail tip
    let tail = (vertices.len() - 1) as u32;
    let ring = |i: usize, j: usize| (1 + i * m + j % m) as u32;
    let mut triangles = Vec::with_capacity(2 * m * n);
    for j in 0..m {
        triangles.push([0, ring(0, j + 1), ring(0, j)]);
    }
    for i in 0..n - 1 {
        for j in 0..m {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    for j in 0..m {
        triangles.push([tail, ring(n - 1, j), ring(n - 1, j + 1)]);
    }
    // Landmarks: the ring vertex nearest to the wanted surface point.
    let at = |s: f64, angle: f64| {
        let i = ((s * (n + 1) as f64).round() as usize).clamp(1, n) - 1;
        let j = ((angle / (2.0 * PI) * m as f64).round() as usize) % m;
        ring(i, j)
    };
    let landmarks = vec![
        ("head_tip".to_string(), 0),
        ("pharynx".to_string(), at(0.13, PI / 2.0)),
        ("vulva".to_string(), at(0.5, 3.0 * PI / 2.0)),
        ("tail_tip".to_string(), tail),
    ];
    Model { vertices, triangles, landmarks }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_worm_is_a_closed_outward_surface_of_the_stated_size() {
        let o = WormOptions::default();
        let w = worm(&o);
        w.validate().unwrap();
        assert_eq!(w.triangles.len(), 20_000);
        // Closed: every edge is shared by exactly two triangles, in opposite directions.
        let mut edges = std::collections::HashMap::new();
        for t in &w.triangles {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        assert!(edges.iter().all(|(&(a, b), &c)| c == 1 && edges.get(&(b, a)) == Some(&1)));
        // Outward: the signed volume is positive and close to the integral of pi r^2.
        let vol: f64 = w
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| w.vertices[i as usize]);
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum();
        assert!(vol > 0.0);
        let (lo, hi) = w.bbox();
        assert!((hi[0] - lo[0] - o.length).abs() < 1e-9);
        assert!(hi[2] <= o.radius && lo[2] >= -o.radius);
        let names: Vec<&str> = w.landmarks.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["head_tip", "pharynx", "vulva", "tail_tip"]);
        // The pharynx landmark is on top (z > 0), the vulva underneath (z < 0).
        assert!(w.vertices[w.landmarks[1].1 as usize][2] > 0.0);
        assert!(w.vertices[w.landmarks[2].1 as usize][2] < 0.0);
    }
}
