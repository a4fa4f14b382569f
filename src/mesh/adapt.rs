//! Landmark-adapted reference meshes: a refined constrained Delaunay mesh of the frame
//! rectangle extended by a margin, with every landmark source as a vertex.
//!
//! The 2017 thesis builds its reference meshes as Delaunay triangulations of the points the
//! user cares about (section 18.2); a regular grid ignores the data (landmarks crowding into
//! one region get no local control there, empty regions carry variables for nothing). Here
//! the mesh is built from the data:
//!
//! 1. The *frame* is the image rectangle `[-1/2, W - 1/2] x [-1/2, H - 1/2]` (pixel `(i, j)`
//!    is centred at `(i, j)`), the *domain* the frame grown by `margin` pixels on every side.
//!    The margin lets the fitted map pull the frame's border inwards without leaving part of
//!    the frame uncovered.
//! 2. The domain's border (split into pieces of at most `max_edge`), the landmark sources
//!    (snapped to the mesh grid; coinciding sources share one vertex) and any extra points
//!    are triangulated by spade's constrained Delaunay triangulation with the border as
//!    constraint edges, then refined by spade's Delaunay refinement (Ruppert / Chew) until no
//!    angle is below `min_angle` and no triangle is larger than an equilateral triangle of
//!    side `max_edge`. Refinement adds Steiner points only where triangles are skinny, that
//!    is around clustered landmarks; regions without landmarks stay coarse.
//! 3. The refined points are snapped to the grid and triangulated again (constrained Delaunay
//!    of the snapped points inside the snapped border), so the result is a valid mesh in the
//!    sense of [`Mesh`] whatever the rounding.
//!
//! 4. Optionally, `far_rings` *far-field rings* are added outside the domain: rectangles
//!    about the domain's centre, each [`FAR_RING_RATIO`] times the size of the one inside it
//!    (8 vertices each: corners and side midpoints, snapped), triangulated with the rest
//!    (constrained Delaunay inside the outermost ring). They are not refined: a few dozen
//!    large triangles. A fit's bending energy is then taken over a region 4^r times the
//!    domain's size, close to the whole plane, so the smoothest map through the landmarks
//!    approaches the thin-plate spline's (which minimizes the same energy over all of
//!    `R^2`, Duchon 1977) instead of bending freely at the domain's border (the natural
//!    boundary of a bounded domain). [`crate::fit::frame`] uses 2 rings by default.
//!
//! Each landmark source that is representable on the snapping grid is a mesh vertex
//! exactly, so its image `phi(s)` is that vertex's control point: the spline has a value of
//! its own at every landmark (local control).

use std::collections::HashMap;

use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
};

use super::{Mesh, MeshError, MeshOptions};

/// Options of [`Mesh::landmark_adapted`].
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptOptions {
    /// Pixels added to the frame on every side (`None`: [`default_margin`]).
    pub margin: Option<f64>,
    /// Longest allowed edge (pixels; `None`: a quarter of the frame's larger side).
    pub max_edge: Option<f64>,
    /// Smallest angle the refinement aims for (degrees, in `(0, 33]`; default
    /// [`DEFAULT_MIN_ANGLE`]).
    pub min_angle: f64,
    /// Snapping denominator of the mesh (see the [module docs](super)).
    pub grid: i64,
    /// Further points to insert as vertices (e.g. to break up a singular vertex).
    pub extra_points: Vec<[f64; 2]>,
    /// Far-field rings around the domain (see the [module docs](self); default 0, at most
    /// [`MAX_FAR_RINGS`]).
    pub far_rings: usize,
}

/// The refinement's default smallest angle (degrees).
///
/// 15 rather than the 20 used before: refinement to 20 degrees adds Steiner points
/// around every skinny triangle of the landmarks' Delaunay triangulation, which costs
/// variables without helping the fit. Measured on 500 random landmarks over a 511 x 511 frame
/// (the `fit_frame` bench): 2,126 triangles and 25,582 variables at 20 degrees, 1,642 and
/// 19,774 at 15 (about a quarter less time); the held-out TRE of `tests/it/fit/real.rs` (two
/// fields, 30 and 60 landmarks, with and without noise) moved by at most 0.3 %, as often
/// down as up (at 12 and 10 degrees as well).
pub const DEFAULT_MIN_ANGLE: f64 = 15.0;

/// Each far-field ring is this many times the size of the rectangle inside it.
pub const FAR_RING_RATIO: f64 = 4.0;

/// The most far-field rings (the outermost is then `4^4 = 256` times the domain's size).
pub const MAX_FAR_RINGS: usize = 4;

impl Default for AdaptOptions {
    fn default() -> Self {
        AdaptOptions {
            margin: None,
            max_edge: None,
            min_angle: DEFAULT_MIN_ANGLE,
            grid: 16,
            extra_points: Vec::new(),
            far_rings: 0,
        }
    }
}

/// The default margin for a `w x h` frame: a tenth of the larger side, at least 8 px,
/// rounded up to whole pixels.
pub fn default_margin(w: f64, h: f64) -> f64 {
    (0.1 * w.max(h)).max(8.0).ceil()
}

/// A landmark-adapted mesh and where its parts are.
#[derive(Clone, Debug)]
pub struct AdaptedMesh {
    /// The mesh.
    pub mesh: Mesh,
    /// For each input source, its vertex.
    pub landmark_vertex: Vec<usize>,
    /// The domain rectangle `(lo, hi)` (the frame grown by the margin).
    pub domain: ([f64; 2], [f64; 2]),
    /// The outermost rectangle of the mesh: the domain, or the last far-field ring.
    pub outer: ([f64; 2], [f64; 2]),
    /// The margin used (pixels).
    pub margin: f64,
    /// Vertices added by the refinement (not landmarks, not border corners).
    pub steiner: usize,
    /// Whether spade's refinement met every angle and size limit.
    pub refinement_complete: bool,
}

impl AdaptedMesh {
    /// Whether vertex `v` lies on the mesh's outer border (the domain's, or the outermost
    /// far-field ring's).
    pub fn on_border(&self, v: usize) -> bool {
        self.mesh.is_border_vertex(v)
    }
}

/// The most points the refinement may add per input point (a bound on the mesh size).
const STEINER_PER_POINT: usize = 8;

/// How far (pixels) a landmark may lie past the frame's outer edge: 1/2, so a `w x h` frame
/// accepts landmarks in `[-1, w] x [-1, h]`, up to one pixel beyond the outermost pixel
/// centres (`0` and `w - 1`).
///
/// Landmark files written by other tools put border points there: ITK and elastix point
/// sets often mark the far edge of a 221-pixel-wide image as `x = 221` (the image's extent
/// read as `[0, w]`), and 1-based files (iBUG `.pts`) give the edge as `0.5` or `0` before
/// the shift to 0-based, `-0.5` or `-1` after. A point further out than that is a wrong
/// `--size` or a wrong column rather than a border point, and is refused. The mesh's domain
/// always contains such points ([`Mesh::landmark_adapted`] grows a smaller margin to
/// reach them), so the fit has a value of its own at each.
pub const FRAME_SLACK: f64 = 0.5;

/// Whether `p` lies in a `size = [w, h]` frame grown by [`FRAME_SLACK`], that is in
/// `[-1, w] x [-1, h]` (finite coordinates only).
pub fn in_landmark_frame(p: [f64; 2], size: [f64; 2]) -> bool {
    let lo = -0.5 - FRAME_SLACK;
    let [w, h] = size;
    p[0] >= lo && p[1] >= lo && p[0] <= w - 0.5 + FRAME_SLACK && p[1] <= h - 0.5 + FRAME_SLACK
}

/// How far (pixels, `>= 0`) the farthest source lies past the frame `[-1/2, w - 1/2] x
/// [-1/2, h - 1/2]` (0 when all lie in it).
fn overshoot(sources: &[[f64; 2]], [w, h]: [f64; 2]) -> f64 {
    sources.iter().fold(0.0f64, |m, p| {
        m.max(-0.5 - p[0]).max(-0.5 - p[1]).max(p[0] - (w - 0.5)).max(p[1] - (h - 0.5))
    })
}

/// Checks a frame size (finite, from 1 to 1e6 pixels each way) and that every source lies
/// in the frame `[-1/2, w - 1/2] x [-1/2, h - 1/2]` grown by [`FRAME_SLACK`] (that is in
/// `[-1, w] x [-1, h]`), in that order: the input checks of [`Mesh::landmark_adapted`], for
/// callers that want them before other work.
pub fn check_frame(sources: &[[f64; 2]], size: [f64; 2]) -> Result<(), MeshError> {
    let [w, h] = size;
    if !(w.is_finite() && h.is_finite() && w >= 1.0 && h >= 1.0 && w <= 1e6 && h <= 1e6) {
        return Err(MeshError::BadAdapt(format!(
            "frame size {w} x {h}: width and height must be from 1 to 1e6"
        )));
    }
    for (index, p) in sources.iter().enumerate() {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(MeshError::NotFinite { vertex: index });
        }
        if !in_landmark_frame(*p, size) {
            return Err(MeshError::OutsideFrame { index, x: p[0], y: p[1], w, h });
        }
    }
    Ok(())
}

impl Mesh {
    /// The landmark-adapted mesh of a `size = [w, h]` frame (see the module docs). Every
    /// source must lie in the frame `[-1/2, w - 1/2] x [-1/2, h - 1/2]` grown by
    /// [`FRAME_SLACK`] ([`check_frame`]). A margin smaller than the distance from the frame
    /// to the farthest source is grown to it (rounded up to the snapping grid), so the
    /// domain contains every source; [`AdaptedMesh::margin`] is the margin used.
    pub fn landmark_adapted(
        sources: &[[f64; 2]],
        size: [f64; 2],
        opts: &AdaptOptions,
    ) -> Result<AdaptedMesh, MeshError> {
        let bad = |m: String| Err(MeshError::BadAdapt(m));
        check_frame(sources, size)?;
        let [w, h] = size;
        let margin = opts.margin.unwrap_or_else(|| default_margin(w, h));
        if !(margin.is_finite() && (0.0..=1e6).contains(&margin)) {
            return bad(format!("margin {margin} must be a finite number from 0 to 1e6"));
        }
        let max_edge = opts.max_edge.unwrap_or(0.25 * w.max(h)).max(0.0);
        if !(max_edge.is_finite() && max_edge >= 1.0) {
            return bad(format!("max edge {max_edge} must be at least 1 pixel"));
        }
        if !(opts.min_angle.is_finite() && opts.min_angle > 0.0 && opts.min_angle <= 33.0) {
            return bad(format!(
                "min angle {} must be above 0 and at most 33 degrees (refinement does not \
                 terminate beyond)",
                opts.min_angle
            ));
        }
        if opts.far_rings > MAX_FAR_RINGS {
            return bad(format!("far rings {}: at most {MAX_FAR_RINGS}", opts.far_rings));
        }
        let grid = super::validate::check_grid(MeshOptions { grid: opts.grid })?;
        let g = grid as f64;
        let snap = |v: f64| (v * g).round() / g;
        // Sources past the frame's edge (at most FRAME_SLACK) stay inside the domain.
        let margin = margin.max((overshoot(sources, size) * g).ceil() / g);
        let lo = [snap(-0.5 - margin), snap(-0.5 - margin)];
        let hi = [snap(w - 0.5 + margin), snap(h - 0.5 + margin)];

        // Input points: sources (deduplicated after snapping), extra points, border points.
        let mut pts: Vec<[f64; 2]> = Vec::new();
        let mut at: HashMap<[i64; 2], usize> = HashMap::new();
        let mut landmark_vertex = Vec::with_capacity(sources.len());
        let key = |p: [f64; 2]| [(p[0] * g).round() as i64, (p[1] * g).round() as i64];
        for &p in sources {
            let k = key(p);
            let i = *at.entry(k).or_insert_with(|| {
                pts.push(p);
                pts.len() - 1
            });
            landmark_vertex.push(i);
        }
        {
            for &p in &opts.extra_points {
                if p[0].is_finite()
                    && p[1].is_finite()
                    && p[0] > lo[0]
                    && p[1] > lo[1]
                    && p[0] < hi[0]
                    && p[1] < hi[1]
                {
                    at.entry(key(p)).or_insert_with(|| {
                        pts.push(p);
                        pts.len() - 1
                    });
                }
            }
        }
        let border = border_points(lo, hi, max_edge);
        let first_border = pts.len();
        for &p in &border {
            if at.insert(key(p), pts.len()).is_some() {
                // A source on the domain border happens only when the margin is no more
                // than the source's distance past the frame (e.g. 0): keep the source there.
                continue;
            }
            pts.push(p);
        }

        // Refine in floating point with spade.
        let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
        let mut handles = Vec::with_capacity(pts.len());
        for p in &pts {
            let hnd = cdt
                .insert(Point2::new(p[0], p[1]))
                .map_err(|e| MeshError::BadAdapt(format!("spade refused a point: {e:?}")))?;
            handles.push(hnd);
        }
        let ring: Vec<usize> = {
            let mut r: Vec<usize> = (first_border..pts.len()).collect();
            r.extend(
                landmark_vertex
                    .iter()
                    .copied()
                    .filter(|&i| on_rect(pts[i], lo, hi))
                    .collect::<Vec<_>>(),
            );
            r.sort_by(|&a, &b| {
                perimeter_pos(pts[a], lo, hi).total_cmp(&perimeter_pos(pts[b], lo, hi))
            });
            r.dedup();
            r
        };
        for k in 0..ring.len() {
            let (a, b) = (handles[ring[k]], handles[ring[(k + 1) % ring.len()]]);
            cdt.add_constraint(a, b);
        }
        let max_area = max_edge * max_edge * 3f64.sqrt() / 4.0;
        let params = RefinementParameters::<f64>::new()
            .exclude_outer_faces(true)
            .with_angle_limit(AngleLimit::from_deg(opts.min_angle))
            .with_max_allowed_area(max_area)
            // Triangles below a quarter pixel are not refined further (clustered landmarks
            // would otherwise draw points without end).
            .with_min_required_area(0.25)
            .with_max_additional_vertices(STEINER_PER_POINT * pts.len() + 64);
        let result = cdt.refine(params);

        // Every vertex of the refined triangulation, snapped; the inputs keep their indices.
        let mut all: Vec<[f64; 2]> = pts.clone();
        for v in cdt.vertices().skip(pts.len()) {
            let p = v.position();
            let mut q = [p.x, p.y];
            // Points spade put on the border stay on it exactly.
            for a in 0..2 {
                if (q[a] - lo[a]).abs() < 1e-9 {
                    q[a] = lo[a];
                }
                if (q[a] - hi[a]).abs() < 1e-9 {
                    q[a] = hi[a];
                }
            }
            if q[0] < lo[0] || q[1] < lo[1] || q[0] > hi[0] || q[1] > hi[1] {
                continue;
            }
            if at.insert(key(q), all.len()).is_none() {
                all.push(q);
            }
        }
        let steiner = all.len() - pts.len();
        // The far-field rings: corners and side midpoints of growing rectangles.
        let (mut olo, mut ohi) = (lo, hi);
        let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        let half = [0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1])];
        let mut f = 1.0;
        for _ in 0..opts.far_rings {
            f *= FAR_RING_RATIO;
            olo = [snap(centre[0] - f * half[0]), snap(centre[1] - f * half[1])];
            ohi = [snap(centre[0] + f * half[0]), snap(centre[1] + f * half[1])];
            let mid = [snap(centre[0]), snap(centre[1])];
            for q in [
                [olo[0], olo[1]],
                [mid[0], olo[1]],
                [ohi[0], olo[1]],
                [ohi[0], mid[1]],
                [ohi[0], ohi[1]],
                [mid[0], ohi[1]],
                [olo[0], ohi[1]],
                [olo[0], mid[1]],
            ] {
                if at.insert(key(q), all.len()).is_none() {
                    all.push(q);
                }
            }
        }
        let mut outline: Vec<usize> =
            (0..all.len()).filter(|&i| on_rect(all[i], olo, ohi)).collect();
        outline.sort_by(|&a, &b| {
            perimeter_pos(all[a], olo, ohi).total_cmp(&perimeter_pos(all[b], olo, ohi))
        });
        let mesh = Mesh::constrained_delaunay(&all, &outline, MeshOptions { grid })?;
        Ok(AdaptedMesh {
            mesh,
            landmark_vertex,
            domain: (lo, hi),
            outer: (olo, ohi),
            margin,
            steiner,
            refinement_complete: result.refinement_complete,
        })
    }
}

/// Points along the border of `[lo, hi]`, corners included, no piece longer than `max_edge`.
fn border_points(lo: [f64; 2], hi: [f64; 2], max_edge: f64) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    let corners = [[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]];
    for k in 0..4 {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let len = (b[0] - a[0]).abs() + (b[1] - a[1]).abs();
        let n = (len / max_edge).ceil().max(1.0) as usize;
        for i in 0..n {
            let t = i as f64 / n as f64;
            out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    out
}

fn on_rect(p: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> bool {
    p[0] == lo[0] || p[0] == hi[0] || p[1] == lo[1] || p[1] == hi[1]
}

/// Position along the perimeter (counter-clockwise in x-right, y-up coordinates, starting
/// at `lo`): bottom side, right side, top side, left side.
fn perimeter_pos(p: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> f64 {
    let (wx, wy) = (hi[0] - lo[0], hi[1] - lo[1]);
    if p[1] == lo[1] && p[0] < hi[0] {
        p[0] - lo[0]
    } else if p[0] == hi[0] && p[1] < hi[1] {
        wx + (p[1] - lo[1])
    } else if p[1] == hi[1] && p[0] > lo[0] {
        wx + wy + (hi[0] - p[0])
    } else {
        2.0 * wx + wy + (hi[1] - p[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cluster() -> Vec<[f64; 2]> {
        // 30 landmarks crowded into one corner of a 200 x 150 frame, 4 spread elsewhere.
        let mut v: Vec<[f64; 2]> = (0..30)
            .map(|i| {
                let a = i as f64 * 0.7;
                [20.0 + 12.0 * (a.cos() + 1.0) + i as f64 * 0.3, 25.0 + 10.0 * (a.sin() + 1.0)]
            })
            .collect();
        v.extend([[150.0, 30.0], [180.0, 120.0], [40.0, 130.0], [100.0, 75.0]]);
        v
    }

    #[test]
    fn adapted_mesh_has_every_landmark_as_a_vertex_and_covers_the_margin() {
        let src = cluster();
        let a = Mesh::landmark_adapted(&src, [200.0, 150.0], &AdaptOptions::default()).unwrap();
        a.mesh.sanity_check().unwrap();
        for (i, &v) in a.landmark_vertex.iter().enumerate() {
            let p = a.mesh.vertex(v);
            assert!(
                (p[0] - src[i][0]).abs() <= 1.0 / 32.0 && (p[1] - src[i][1]).abs() <= 1.0 / 32.0
            );
        }
        let (lo, hi) = a.mesh.bbox();
        assert_eq!(lo, [-20.5, -20.5]);
        assert_eq!(hi, [219.5, 169.5]);
        let area: f64 = (0..a.mesh.num_triangles())
            .map(|t| a.mesh.twice_area_int(t) as f64 / (2.0 * 256.0))
            .sum();
        assert!((area - 240.0 * 190.0).abs() < 1e-6, "the mesh fills the domain: {area}");
    }

    #[test]
    fn refinement_is_local_to_the_landmarks() {
        let a =
            Mesh::landmark_adapted(&cluster(), [200.0, 150.0], &AdaptOptions::default()).unwrap();
        // Triangles near the cluster are much smaller than far away.
        let m = &a.mesh;
        let (mut near, mut far) = (Vec::new(), Vec::new());
        for t in 0..m.num_triangles() {
            let c = m.triangle(t).map(|v| m.vertex(v));
            let cx = (c[0][0] + c[1][0] + c[2][0]) / 3.0;
            let cy = (c[0][1] + c[1][1] + c[2][1]) / 3.0;
            let area = m.twice_area_int(t) as f64 / 512.0;
            if cx < 60.0 && cy < 60.0 {
                near.push(area);
            } else if cx > 120.0 && cy > 80.0 {
                far.push(area);
            }
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!(mean(&near) * 5.0 < mean(&far), "near {} far {}", mean(&near), mean(&far));
    }

    #[test]
    fn coinciding_sources_share_a_vertex_and_outside_sources_are_refused() {
        let src = [[10.0, 10.0], [10.0, 10.0], [50.0, 20.0], [30.0, 40.0]];
        let a = Mesh::landmark_adapted(&src, [64.0, 64.0], &AdaptOptions::default()).unwrap();
        assert_eq!(a.landmark_vertex[0], a.landmark_vertex[1]);
        let e = Mesh::landmark_adapted(&[[70.0, 3.0]], [64.0, 64.0], &AdaptOptions::default())
            .unwrap_err();
        assert!(matches!(e, MeshError::OutsideFrame { index: 0, .. }), "{e}");
    }

    /// Issue 52: landmarks on the frame's outer edge, as ITK (`x = w`) and 1-based files
    /// (`-0.5` or `-1` after the shift) write them, are accepted: up to FRAME_SLACK past the
    /// frame, `[-1, w] x [-1, h]`, and no further.
    #[test]
    fn border_landmarks_up_to_one_pixel_past_the_last_centre_are_accepted() {
        assert_eq!(FRAME_SLACK, 0.5);
        let size = [221.0, 160.0];
        for p in [[220.5, 3.0], [221.0, 3.0], [-1.0, -1.0], [-0.5, 160.0], [221.0, 160.0]] {
            check_frame(&[p], size).unwrap_or_else(|e| panic!("{p:?}: {e}"));
            assert!(in_landmark_frame(p, size), "{p:?}");
        }
        for p in [[222.5, 3.0], [221.25, 3.0], [3.0, 160.01], [-1.5, 3.0], [3.0, -1.0625]] {
            let e = check_frame(&[[5.0, 5.0], p], size).unwrap_err();
            assert!(matches!(e, MeshError::OutsideFrame { index: 1, .. }), "{p:?}: {e}");
            assert!(e.to_string().contains("x from -1 to width"), "{e}");
        }
        // The domain contains border sources, also with no margin asked for: the margin
        // grows to the farthest source (rounded up to the grid).
        let src = [[221.0, 3.0], [-1.0, 80.0], [100.0, 160.0], [100.0, 50.0], [30.0, 20.0]];
        for margin in [None, Some(0.0), Some(0.2)] {
            let opts = AdaptOptions { margin, ..AdaptOptions::default() };
            let a = Mesh::landmark_adapted(&src, size, &opts).unwrap();
            a.mesh.sanity_check().unwrap();
            let (lo, hi) = a.domain;
            assert!(lo[0] <= -1.0 && hi[0] >= 221.0 && hi[1] >= 160.0, "{margin:?}: {lo:?} {hi:?}");
            assert!(a.margin >= 0.5, "{margin:?}: {}", a.margin);
            for (i, &v) in a.landmark_vertex.iter().enumerate() {
                assert_eq!(a.mesh.vertex(v), src[i], "{margin:?}");
            }
        }
        let opts = AdaptOptions { margin: Some(0.0), ..AdaptOptions::default() };
        let a =
            Mesh::landmark_adapted(&[[220.8, 3.0], [3.0, 3.0], [9.0, 90.0]], size, &opts).unwrap();
        assert_eq!((a.margin, a.domain.1[0]), (0.3125, 220.8125));
        // Sources inside the frame keep a margin of 0 (nothing changes for them).
        let a =
            Mesh::landmark_adapted(&[[220.5, 3.0], [3.0, 3.0], [9.0, 90.0]], size, &opts).unwrap();
        assert_eq!((a.margin, a.domain), (0.0, ([-0.5, -0.5], [220.5, 159.5])));
    }

    #[test]
    fn no_landmarks_give_a_coarse_mesh_of_the_domain() {
        let a = Mesh::landmark_adapted(&[], [100.0, 80.0], &AdaptOptions::default()).unwrap();
        a.mesh.sanity_check().unwrap();
        assert!(a.mesh.num_triangles() < 80, "{}", a.mesh.num_triangles());
    }

    #[test]
    fn far_rings_surround_the_domain_and_keep_its_mesh() {
        let src = cluster();
        let plain = Mesh::landmark_adapted(&src, [200.0, 150.0], &AdaptOptions::default()).unwrap();
        let opts = AdaptOptions { far_rings: 2, ..AdaptOptions::default() };
        let a = Mesh::landmark_adapted(&src, [200.0, 150.0], &opts).unwrap();
        a.mesh.sanity_check().unwrap();
        // The domain as before, the outer rectangle 16 times its size about its centre.
        assert_eq!(a.domain, plain.domain);
        assert_eq!(a.outer, ([-1820.5, -1445.5], [2019.5, 1594.5]));
        assert_eq!(a.mesh.bbox(), a.outer);
        // The same landmark vertices at the same places, 8 more vertices per ring.
        assert_eq!(a.mesh.num_vertices(), plain.mesh.num_vertices() + 16);
        for (&v, &w) in a.landmark_vertex.iter().zip(&plain.landmark_vertex) {
            assert_eq!(a.mesh.vertex(v), plain.mesh.vertex(w));
        }
        // The whole outer rectangle is covered, the domain's border is inside.
        let area: f64 = (0..a.mesh.num_triangles())
            .map(|t| a.mesh.twice_area_int(t) as f64 / (2.0 * 256.0))
            .sum();
        assert!((area - 3840.0 * 3040.0).abs() < 1e-3, "{area}");
        let corner = (0..a.mesh.num_vertices()).find(|&v| a.mesh.vertex(v) == [-20.5, -20.5]);
        assert!(!a.on_border(corner.expect("the domain's corner is a vertex")));
        let e = Mesh::landmark_adapted(
            &src,
            [200.0, 150.0],
            &AdaptOptions { far_rings: MAX_FAR_RINGS + 1, ..AdaptOptions::default() },
        )
        .unwrap_err();
        assert!(e.to_string().contains("far rings 5"), "{e}");
    }

    /// Bug: with far-field rings the bounding box is 16 times the domain's size, and the
    /// uniform bucket grid of point location put the whole domain into a handful of buckets
    /// (about 400 triangles each for 500 landmarks), so each query tested them all. Crowded
    /// buckets now get grids of their own.
    #[test]
    fn far_ring_meshes_locate_points_without_scanning_the_domain() {
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let src: Vec<[f64; 2]> =
            (0..500).map(|_| [5.0 + 500.0 * next(), 5.0 + 500.0 * next()]).collect();
        let opts = AdaptOptions { far_rings: 2, ..AdaptOptions::default() };
        let a = Mesh::landmark_adapted(&src, [511.0, 511.0], &opts).unwrap();
        a.mesh.sanity_check().unwrap();
        let most = a.mesh.locator.max_bucket();
        assert!(most <= 40, "a query tests up to {most} triangles");
        // Buckets split into grids of their own keep no list of their own.
        assert_eq!(a.mesh.locator.stored(), a.mesh.locator.stats().1);
        // Every landmark is found in a triangle that contains it (checked exactly against
        // the barycentric coordinates' signs), from scratch.
        for &p in &src {
            let (t, b) = a.mesh.locate(p, None).expect("inside the mesh");
            assert!(b.iter().all(|&l| l >= -1e-9), "{p:?} in {t}: {b:?}");
        }
        // Points far out in the rings too.
        for p in [[-1500.0, -1200.0], [1900.0, 1500.0], [255.0, -1000.0]] {
            assert!(a.mesh.locate(p, None).is_some(), "{p:?}");
        }
    }
}
