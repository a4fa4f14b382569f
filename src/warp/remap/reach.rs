//! Which lattice squares a plan for a `w x h` output needs: the reference region whose image
//! can come near the output.
//!
//! A frame fit's mesh has far-field rings ([`crate::mesh::AdaptOptions::far_rings`]) 16 times
//! the frame's size, so a plan over the mesh's whole bounding box would map and refine 256
//! times the lattice squares that can draw into the frame. This module bounds the
//! reference points `p` with `phi(p)` within `reach` of the output's pixel centres
//! `R = [0, w - 1] x [0, h - 1]`, triangle by triangle:
//!
//! * on triangle `T` with vertex images `q_0, q_1, q_2`, `A_T` the affine map through them
//!   and `delta_T` the bound of [`EvalCache::affine_defect`], `|phi(p) - A_T(p)| <=
//!   delta_T`, so `phi(p)` within `reach` of `R` puts `A_T(p)` in `R` grown by `reach +
//!   delta_T` (a rectangle);
//! * that rectangle clipped to the image triangle `A_T(T)` (Sutherland-Hodgman) and mapped
//!   back by `A_T^-1` (barycentric coordinates) bounds the part of `T` that can reach `R`;
//!   the union of those parts' bounding boxes, grown by one pixel for rounding, is the
//!   window.
//!
//! With the reach of [`lattice_reach`] (`sqrt 2 L c + 2 L + 2` for `|J| <= L` and lattice
//! cell `c`), every lattice square whose pieces can draw into the output has a corner
//! whose image is that close to `R` ([`crate::warp::tiles`] proves the reach), so it meets
//! the window, and the windowed plan draws exactly what the whole plan draws
//! ([`super::RemapPlan::new_window`]). Triangles whose image is degenerate count whole when
//! their control points' box comes near `R`. The argument walks straight segments inside
//! the mesh, so on a non-convex mesh the whole mesh is planned.
//!
//! [`EvalCache::affine_defect`]: crate::spline::eval::EvalCache::affine_defect

use super::geometry::signed_area;
use crate::spline::Spline;
use rayon::prelude::*;

/// The part of the reference domain a plan must cover.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Reach {
    /// All of it (a non-convex mesh, or a bound that is not finite).
    All,
    /// No point's image comes near the output: every pixel is background.
    Nothing,
    /// The box `(lo, hi)` of the reference points whose image can come near the output.
    Window([f64; 2], [f64; 2]),
}

/// How far (output pixels) the corners of a lattice square of side `cell` can be from an
/// output pixel that one of its pieces draws: `sqrt 2 L c + 2 L + 2` for `|J| <= L`
/// ([`crate::warp::tiles`], module docs).
pub(crate) fn lattice_reach(lip: f64, cell: f64) -> f64 {
    std::f64::consts::SQRT_2 * lip * cell + 2.0 * lip + 2.0
}

/// What part of one triangle can map near an output rectangle ([`triangle_part`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Part {
    /// No bound (a control point that is not finite).
    Unbounded,
    /// No point of the triangle maps within the reach.
    Outside,
    /// The points that can are inside this box `(lo, hi)` (not grown for rounding).
    Box([f64; 2], [f64; 2]),
}

/// The box of the points of triangle `t` whose image can come within `reach` of the
/// rectangle `out = ([x0, y0], [x1, y1])` (module docs).
pub(crate) fn triangle_part(s: &Spline, t: usize, out: ([f64; 2], [f64; 2]), reach: f64) -> Part {
    let (m, cache) = (s.mesh(), s.eval_cache());
    let (olo, ohi) = out;
    let (q, delta) = cache.affine_defect(t);
    if !delta.is_finite() || q.iter().flatten().any(|v| !v.is_finite()) {
        return Part::Unbounded;
    }
    let g = reach + delta;
    let (rlo, rhi) = ([olo[0] - g, olo[1] - g], [ohi[0] + g, ohi[1] + g]);
    let v = m.triangle(t).map(|i| m.vertex(i));
    let area = signed_area(q);
    let scale = q.iter().flatten().fold(1.0f64, |a, x| a.max(x.abs()));
    if area.abs() <= 1e-9 * scale * scale {
        // Degenerate image: the whole triangle if its control points come near.
        let (clo, chi) = cache.patch_bbox(t);
        let near = (0..2).all(|a| clo[a] <= rhi[a] + delta && chi[a] >= rlo[a] - delta);
        let (lo, hi) = super::geometry::bbox(&v);
        return if near { Part::Box(lo, hi) } else { Part::Outside };
    }
    let poly = clip_to_box(&q, rlo, rhi);
    if poly.is_empty() {
        return Part::Outside;
    }
    // Back to the reference triangle through barycentric coordinates in the image.
    let mut pts = [[0.0f64; 2]; 7];
    for (x, p) in poly.iter().zip(pts.iter_mut()) {
        let l1 = (signed_area([q[0], *x, q[2]]) / area).clamp(0.0, 1.0);
        let l2 = (signed_area([q[0], q[1], *x]) / area).clamp(0.0, 1.0);
        let l0 = (1.0 - l1 - l2).max(0.0);
        *p = [0, 1].map(|a| l0 * v[0][a] + l1 * v[1][a] + l2 * v[2][a]);
    }
    let (lo, hi) = super::geometry::bbox(&pts[..poly.len()]);
    Part::Box(lo, hi)
}

/// The window of the reference domain whose image comes within `reach` of the output
/// rectangle `[x0, x1] x [y0, y1]` (pixel centres), as in the module docs.
pub(crate) fn reach_window(s: &Spline, out: ([f64; 2], [f64; 2]), reach: f64) -> Reach {
    let m = s.mesh();
    if !reach.is_finite() || !super::mesh_is_convex(m) {
        return Reach::All;
    }
    let parts: Result<Vec<_>, ()> = (0..m.num_triangles())
        .into_par_iter()
        .map(|t| match triangle_part(s, t, out, reach) {
            Part::Unbounded => Err(()),
            Part::Outside => Ok(None),
            Part::Box(lo, hi) => Ok(Some((lo, hi))),
        })
        .collect();
    let Ok(parts) = parts else { return Reach::All };
    let mut acc: Option<([f64; 2], [f64; 2])> = None;
    for (lo, hi) in parts.into_iter().flatten() {
        let (alo, ahi) = acc.get_or_insert((lo, hi));
        for a in 0..2 {
            alo[a] = alo[a].min(lo[a]);
            ahi[a] = ahi[a].max(hi[a]);
        }
    }
    match acc {
        None => Reach::Nothing,
        // One pixel (and a relative 1e-12) for the rounding of the clip and the inverse.
        Some((lo, hi)) => {
            let pad = |v: f64| 1.0 + 1e-12 * v.abs();
            Reach::Window(
                [lo[0] - pad(lo[0]), lo[1] - pad(lo[1])],
                [hi[0] + pad(hi[0]), hi[1] + pad(hi[1])],
            )
        }
    }
}

/// The window of a whole `w x h` output's plan with lattice cell `cell`: [`reach_window`]
/// with the reach of [`lattice_reach`] for the largest `|J|` over the mesh.
pub(crate) fn plan_window(s: &Spline, w: u32, h: u32, cell: f64) -> Reach {
    if w == 0 || h == 0 {
        return Reach::Nothing;
    }
    let cache = s.eval_cache();
    let lip = (0..s.mesh().num_triangles())
        .into_par_iter()
        .map(|t| cache.jacobian_bound(t))
        .reduce(|| 0.0, f64::max);
    let out = ([0.0, 0.0], [f64::from(w) - 1.0, f64::from(h) - 1.0]);
    reach_window(s, out, lattice_reach(lip, cell))
}

/// The polygon `tri` clipped to the box `[lo, hi]` (Sutherland-Hodgman, one side at a
/// time); empty when they do not meet.
fn clip_to_box(tri: &[[f64; 2]; 3], lo: [f64; 2], hi: [f64; 2]) -> Vec<[f64; 2]> {
    let mut poly: Vec<[f64; 2]> = tri.to_vec();
    for (axis, bound, keep_above) in
        [(0, lo[0], true), (0, hi[0], false), (1, lo[1], true), (1, hi[1], false)]
    {
        if poly.is_empty() {
            break;
        }
        let inside = |p: &[f64; 2]| if keep_above { p[axis] >= bound } else { p[axis] <= bound };
        let mut next = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let (ia, ib) = (inside(&a), inside(&b));
            if ia {
                next.push(a);
            }
            if ia != ib {
                let t = (bound - a[axis]) / (b[axis] - a[axis]);
                let mut x = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                x[axis] = bound;
                next.push(x);
            }
        }
        poly = next;
    }
    poly
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{AdaptOptions, Mesh};

    #[test]
    fn a_triangle_clipped_to_a_box_keeps_what_is_inside() {
        let tri = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]];
        let p = clip_to_box(&tri, [-1.0, -1.0], [4.0, 4.0]);
        let (lo, hi) = crate::warp::remap::geometry::bbox(&p);
        assert_eq!((lo, hi), ([0.0, 0.0], [4.0, 4.0]));
        assert!(clip_to_box(&tri, [20.0, 20.0], [30.0, 30.0]).is_empty());
        // Wholly inside: unchanged.
        assert_eq!(clip_to_box(&tri, [-5.0, -5.0], [50.0, 50.0]).len(), 3);
    }

    /// A ringed identity mesh over a 200 x 100 frame: the window is the frame grown by the
    /// reach (and a pixel), not the rings' 16-fold extent.
    #[test]
    fn the_window_of_an_identity_over_far_rings_is_the_frame_grown_by_the_reach() {
        let opts = AdaptOptions { far_rings: 2, ..AdaptOptions::default() };
        let lms = [[20.0, 20.0], [180.0, 30.0], [100.0, 80.0], [60.0, 50.0]];
        let m = Mesh::landmark_adapted(&lms, [200.0, 100.0], &opts).unwrap().mesh;
        let (blo, bhi) = m.bbox();
        assert!(bhi[0] - blo[0] > 1000.0, "rings present: {blo:?} {bhi:?}");
        let s = Spline::identity(m, 5).unwrap();
        let reach = 10.0;
        let Reach::Window(lo, hi) = reach_window(&s, ([0.0, 0.0], [199.0, 99.0]), reach) else {
            panic!("a window")
        };
        // Identity: delta is rounding only, so the window is R grown by reach plus the pad.
        for (got, want) in
            [(lo[0], -reach), (lo[1], -reach), (hi[0], 199.0 + reach), (hi[1], 99.0 + reach)]
        {
            assert!((got - want).abs() <= 1.0 + 1e-6, "{got} vs {want}");
        }
        // Far outside: nothing reaches.
        assert_eq!(reach_window(&s, ([1e5, 1e5], [1e5 + 10.0, 1e5 + 10.0]), reach), Reach::Nothing);
    }
}
