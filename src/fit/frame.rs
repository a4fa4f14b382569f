//! Fitting a frame from its landmarks alone: the landmark-adapted mesh, an affine warm
//! start whose border is held, and full coverage of the frame.
//!
//! Given landmarks (sources and targets in pixels) and the frame size `w x h`:
//!
//! 1. `A` is the weighted least-squares affine map of the landmarks,
//!    `A = argmin sum_i w_i |A s_i - t_i|^2` (6 unknowns; at least 3 landmarks not on one
//!    line, and `det A > 0`: a mirror image is refused).
//! 2. The mesh is [`Mesh::landmark_adapted`] with a margin large enough that `A` maps the
//!    domain over the whole frame: every frame corner `c` has `A^-1 c` inside the domain
//!    (the default margin grows when it does not). Its vertices are the landmarks' sources,
//!    or, above [`MAX_VERTEX_SOURCES`] landmarks in a soft fit, a spread subset of them
//!    ([`thin_sources`]): the other landmarks lie inside triangles, and the number of
//!    variables stays that of 1,000 landmarks however many are given.
//! 3. Around the domain the mesh has [`FAR_RINGS`] far-field rings, rectangles 4 and 16
//!    times its size ([`crate::mesh::AdaptOptions::far_rings`]), so the bending energy is
//!    taken over nearly the whole plane, as a thin-plate spline's is: without them the
//!    domain's free border (natural boundary) lets the map bend there for nothing, and the
//!    smoothest map through the landmarks extrapolates worse near the frame's edges
//!    (measured in `tests/it/fit/real.rs`: with two rings the noise-free held-out error equals
//!    the thin-plate spline's to within 1 %; without, it was 11 % worse with 60 landmarks
//!    and 19 % worse on a local swirl). Scale-free bending weights still refer to the
//!    domain's area ([`FitOptions::bend_area`]).
//! 4. The warm start is `A` itself, exactly (its coefficients rounded to multiples of
//!    [`AFFINE_BITS`] bits). The outer border is free: beyond the landmarks the fit
//!    continues as smoothly as the bending energy allows, which is how a thin-plate spline
//!    extrapolates (towards an affine map). Holding the border at `A` instead
//!    ([`FitOptions::pin_border`]) biases every landmark near the border and is not the
//!    default.
//!
//! **Coverage.** If the border curve `phi(dD)` avoids the frame and winds once around it,
//! every frame point `q` has degree `deg(phi, D, q) = 1`, hence a preimage: warping a frame
//! through the fit leaves no background pixel in the frame. [`covers_frame`] proves this
//! from the border edges' Bezier control points; when it fails with the automatic margin,
//! the margin is doubled and the fit run again (up to [`MAX_MARGIN_DOUBLINGS`] times), and
//! the report's `covers_frame` says whether it was proven.

pub use super::affine::affine_fit;
use super::entry::fit_with_terms;
use super::error::FitError;
use super::landmarks::Landmark;
use super::objective::TriangleTerms;
use super::options::FitOptions;
use super::report::Fit;
use super::solve::validate;
use crate::mesh::{default_margin, AdaptOptions, Mesh, MeshError};
use crate::spline::mds::{Mds, MdsError};
use crate::spline::Spline;
use serde::Serialize;

/// The affine warm start's coefficients are multiples of `2^-AFFINE_BITS`.
pub const AFFINE_BITS: u32 = 24;

/// Snapping grids tried for the mesh (smallest first): `16 * 5^k`, which represent every
/// source given with up to `k` decimals (in pixels) exactly.
const GRIDS: [i64; 6] = [16, 80, 400, 2000, 10_000, 50_000];

/// Attempts at breaking up a vertex that has no local determining set.
const MAX_MDS_RETRIES: usize = 8;

/// The largest [`Mds::amplification`] the adapted fit accepts before it breaks up the vertex
/// where the blow-up starts (well-shaped meshes stay below a few thousand; the faces pair of
/// `tests/it/morph/faces.rs` had one vertex at 3e6, and at 1.3e9 with one more decimal).
pub const MAX_AMPLIFICATION: f64 = 1e5;

/// Control point `p`'s nominal position (its domain point), in `f64`.
fn nominal_f64(s: &Spline, p: usize) -> [f64; 2] {
    let q = &s.nominal()[p];
    [crate::exact::rat_to_f64(&q[0]), crate::exact::rat_to_f64(&q[1])]
}

/// The mesh vertex nearest `p`.
fn nearest_vertex(m: &Mesh, p: [f64; 2]) -> usize {
    (0..m.num_vertices())
        .min_by(|&a, &b| {
            let (u, v) = (m.vertex(a), m.vertex(b));
            let d = |q: [f64; 2]| (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
            d(u).total_cmp(&d(v))
        })
        .unwrap_or(0)
}

/// Far-field rings of the frame fit's mesh (see the module docs and
/// [`crate::mesh::AdaptOptions::far_rings`]): the outermost is 16 times the domain's size.
pub const FAR_RINGS: usize = 2;

/// Options of [`fit_frame`].
#[derive(Clone, Debug, PartialEq)]
pub struct FrameFitOptions {
    /// The mesh (its `grid` is chosen from the sources when left at 0).
    pub mesh: AdaptOptions,
    /// The spline's degree (default 5).
    pub degree: usize,
    /// The fit.
    pub fit: FitOptions,
}

impl Default for FrameFitOptions {
    fn default() -> Self {
        FrameFitOptions {
            mesh: AdaptOptions { grid: 0, far_rings: FAR_RINGS, ..AdaptOptions::default() },
            degree: 5,
            fit: FitOptions::default(),
        }
    }
}

/// What [`fit_frame`] adds to a fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameReport {
    /// The frame size.
    pub size: [f64; 2],
    /// The margin used (pixels).
    pub margin: f64,
    /// The mesh's snapping grid.
    pub grid: i64,
    /// Mesh vertices, triangles, and vertices added by the refinement.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// Refinement points.
    pub steiner: usize,
    /// The affine map held on the border: `[[a, b, c], [d, e, f]]`, `A(x, y) = (a x + b y +
    /// c, d x + e y + f)`.
    pub affine: [[f64; 3]; 2],
    /// The fitted map is certified to cover the whole frame (see the module docs).
    pub covers_frame: bool,
}

/// A fit over a landmark-adapted mesh.
#[derive(Clone, Debug)]
pub struct FrameFit {
    /// The fitted spline and its report.
    pub fit: Fit,
    /// Mesh, border and coverage.
    pub frame: FrameReport,
}

/// The most landmark sources that become mesh vertices in a soft fit. Above it, the mesh's
/// vertices are a subset of the sources spread like them ([`thin_sources`]), and the fit
/// solves in variable space ([`super::smooth_sparse`]): the spline's variables then grow
/// with this cap, not with the number of landmarks. Equal to
/// [`super::smooth_sparse::LANDMARK_SPACE_MAX`], so that the mesh of 1,001 landmarks is about
/// that of 1,000.
pub const MAX_VERTEX_SOURCES: usize = super::smooth_sparse::LANDMARK_SPACE_MAX;

/// At most `cap` of `sources`, spread as they are: the largest radius `r` (to a relative
/// 1/64, by bisection) for which keeping each source (in the given order) that has no kept
/// source within `r` keeps at most `cap` of them. Where the sources are sparser than `r`,
/// every one is kept; where they crowd, they are kept about `r` apart (a Poisson-disc
/// subset). Deterministic for a given order.
pub fn thin_sources(sources: &[[f64; 2]], cap: usize) -> Vec<[f64; 2]> {
    if sources.len() <= cap {
        return sources.to_vec();
    }
    let keep = |r: f64| -> Vec<[f64; 2]> {
        let mut cells: std::collections::HashMap<(i64, i64), Vec<[f64; 2]>> =
            std::collections::HashMap::new();
        let mut kept = Vec::new();
        let r2 = r * r;
        for &p in sources {
            let c = ((p[0] / r).floor() as i64, (p[1] / r).floor() as i64);
            let near = (-1..=1).any(|dx| {
                (-1..=1).any(|dy| {
                    cells.get(&(c.0 + dx, c.1 + dy)).is_some_and(|v| {
                        v.iter().any(|q| (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) < r2)
                    })
                })
            });
            if !near {
                cells.entry(c).or_default().push(p);
                kept.push(p);
            }
        }
        kept
    };
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in sources {
        for c in 0..2 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    // `r_hi` keeps one point; `r_lo = 0` keeps all (more than `cap`).
    let mut r_hi = ((hi[0] - lo[0]).hypot(hi[1] - lo[1])).max(1.0) * 2.0;
    let mut r_lo = 0.0;
    let mut best = keep(r_hi);
    while r_hi - r_lo > r_hi / 64.0 {
        let r = 0.5 * (r_lo + r_hi);
        let k = keep(r);
        if k.len() <= cap {
            r_hi = r;
            best = k;
        } else {
            r_lo = r;
        }
    }
    best
}

/// The margin that makes `A` map the domain over the whole frame (at least `base`).
fn covering_margin(a: &[[f64; 3]; 2], w: f64, h: f64, base: f64) -> f64 {
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let mut need: f64 = 0.0;
    for c in [[-0.5, -0.5], [w - 0.5, -0.5], [-0.5, h - 0.5], [w - 0.5, h - 0.5]] {
        let v = [c[0] - a[0][2], c[1] - a[1][2]];
        let p = [(a[1][1] * v[0] - a[0][1] * v[1]) / det, (-a[1][0] * v[0] + a[0][0] * v[1]) / det];
        need = need.max(-0.5 - p[0]).max(-0.5 - p[1]).max(p[0] - (w - 0.5)).max(p[1] - (h - 0.5));
    }
    // Two pixels of slack beyond the corners' preimages.
    base.max((need + 2.0).ceil())
}

/// The smallest grid of [`GRIDS`] on which every source is exact.
pub fn source_grid(lms: &[Landmark]) -> i64 {
    GRIDS
        .iter()
        .copied()
        .find(|&g| {
            lms.iter().all(|l| {
                l.src.iter().all(|&v| {
                    let s = v * g as f64;
                    s.abs() < 1e12 && (s - s.round()).abs() <= 1e-9 * s.abs().max(1.0)
                })
            })
        })
        .unwrap_or(GRIDS[0])
}

/// The exact spline of the affine map `a` over `mesh`, its coefficients rounded to
/// multiples of `2^-AFFINE_BITS` ([`Spline::affine`]: C1 by construction).
fn affine_spline(mesh: Mesh, degree: usize, a: &[[f64; 3]; 2]) -> Result<Spline, FitError> {
    let coef = a.map(|row| row.map(|v| super::param::grid_rat(v, AFFINE_BITS)));
    Ok(Spline::affine(mesh, degree, &coef)?)
}

/// Margin doublings tried when a fit does not cover the frame.
const MAX_MARGIN_DOUBLINGS: usize = 3;

/// Fits a `size = [w, h]` frame to landmarks with no deformation given (see the module
/// docs).
pub fn fit_frame(
    lms: &[Landmark],
    size: [f64; 2],
    opts: &FrameFitOptions,
) -> Result<FrameFit, FitError> {
    validate(lms)?;
    // Each landmark's own problems (outside the frame) before the set's (degenerate map).
    let sources: Vec<[f64; 2]> = lms.iter().map(|l| l.src).collect();
    crate::mesh::check_frame(&sources, size).map_err(|e| mesh_error(lms, e))?;
    let a = affine_fit(lms)?;
    let [w, h] = size;
    let base = opts.mesh.margin.unwrap_or_else(|| default_margin(w, h));
    let mut margin =
        if opts.mesh.margin.is_some() { base } else { covering_margin(&a, w, h, base) };
    let grid = if opts.mesh.grid > 0 { opts.mesh.grid } else { source_grid(lms) };
    let mut doublings = 0;
    loop {
        let (adapted, f) = fit_on_mesh(lms, size, &a, margin, grid, opts)?;
        let mut trace = crate::timing::Trace::new("fit_frame");
        let covered = covers_frame(&f.spline, [-0.5, -0.5], [w - 0.5, h - 0.5]);
        trace.mark("coverage check");
        if covered || opts.mesh.margin.is_some() || doublings == MAX_MARGIN_DOUBLINGS {
            let frame = FrameReport {
                size,
                margin: adapted.margin,
                grid,
                vertices: adapted.mesh.num_vertices(),
                triangles: adapted.mesh.num_triangles(),
                steiner: adapted.steiner,
                affine: a,
                covers_frame: covered,
            };
            let mut f = f;
            // The frame the fit is for, recorded with the spline (fields and exports default
            // to it, not to the far rings' extent). `check_frame` has validated the size.
            f.spline.set_frame(crate::spline::ImageFrame::new(size).ok());
            return Ok(FrameFit { fit: f, frame });
        }
        margin *= 2.0;
        doublings += 1;
    }
}

/// A landmark-adapted mesh's error as a fit error, naming the landmark outside the frame.
fn mesh_error(lms: &[Landmark], e: MeshError) -> FitError {
    match e {
        MeshError::OutsideFrame { index, x, y, w, h } => FitError::BadLandmark {
            index,
            name: lms[index].name.clone().unwrap_or_else(|| "-".into()),
            why: format!(
                "source point ({x}, {y}) lies outside the {w} x {h} frame (pixel centres run \
                 from 0 to width - 1 and height - 1; a landmark may lie up to one pixel beyond \
                 them, x from -1 to width, y from -1 to height); check --size and the columns"
            ),
        },
        e => FitError::AdaptedMesh(e),
    }
}

/// The adapted mesh with this margin and the fit over it.
fn fit_on_mesh(
    lms: &[Landmark],
    size: [f64; 2],
    a: &[[f64; 3]; 2],
    margin: f64,
    grid: i64,
    opts: &FrameFitOptions,
) -> Result<(crate::mesh::AdaptedMesh, Fit), FitError> {
    let sources: Vec<[f64; 2]> = lms.iter().map(|l| l.src).collect();
    // Many landmarks: a subset of them make the mesh (a hard fit needs every one).
    let sources = if opts.fit.hard { sources } else { thin_sources(&sources, MAX_VERTEX_SOURCES) };
    let mut mesh_opts = AdaptOptions { margin: Some(margin), grid, ..opts.mesh.clone() };
    // The default longest edge is a quarter of the frame's larger side *in the frame*: a
    // map that shrinks (`det A < 1`, a large image's landmarks onto a small one) shows the
    // reference plane reduced by `sqrt(det A)`, and its covering margin is as much larger,
    // so its reference edges may be as much longer (for the same look in the frame, and
    // far fewer triangles in the margin).
    if mesh_opts.max_edge.is_none() {
        let det_a = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        let shrink = if det_a.is_finite() && det_a > 0.0 { det_a.sqrt().min(1.0) } else { 1.0 };
        mesh_opts.max_edge = Some(0.25 * size[0].max(size[1]) / shrink);
    }
    let mut tries = 0;
    let start = std::time::Instant::now();
    let mut trace = crate::timing::Trace::new("fit_frame");
    let (adapted, spline, mds, terms) = loop {
        let adapted =
            Mesh::landmark_adapted(&sources, size, &mesh_opts).map_err(|e| mesh_error(lms, e))?;
        trace.mark("adapted mesh");
        let spline = affine_spline(adapted.mesh.clone(), opts.degree, a)?;
        trace.mark("affine spline");
        // The determining set (exact eliminations) and the triangles' objective terms
        // (floating point) depend on the spline only: built side by side.
        let level = opts.fit.det_level;
        let (mm, terms) = rayon::join(
            || Mds::new(&spline),
            || (level > 0).then(|| TriangleTerms::new(&spline, level)),
        );
        trace.mark("determining set | triangle terms");
        // A vertex that is singular, or nearly so (its determining set amplifies a change
        // of the free points more than MAX_AMPLIFICATION), is broken up by a point inside
        // one of its triangles: near it the spline space is nearly degenerate, fits miss
        // their landmarks by pixels, and the result flips with the fourth decimal of a
        // coordinate (which moves the vertices a little closer to or away from the
        // singular configuration).
        let bad = match &mm {
            Ok(mds) if tries < MAX_MDS_RETRIES => mds
                .first_amplified(MAX_AMPLIFICATION)
                .map(|p| nearest_vertex(&adapted.mesh, nominal_f64(&spline, p))),
            Ok(_) => None,
            Err(MdsError::Singular(v)) if tries < MAX_MDS_RETRIES => Some(*v),
            Err(_) => None,
        };
        match (mm, bad) {
            (Ok(mds), None) => break (adapted, spline, mds, terms),
            (_, Some(v)) => {
                // Break the vertex's symmetric star with a point inside one of its triangles.
                let m = &adapted.mesh;
                let t = m.vertex_triangles(v)[0];
                let c = m.triangle(t).map(|i| m.vertex(i));
                mesh_opts.extra_points.push([
                    (c[0][0] + c[1][0] + c[2][0]) / 3.0,
                    (c[0][1] + c[1][1] + c[2][1]) / 3.0,
                ]);
                tries += 1;
            }
            (Err(e), None) => return Err(e.into()),
        }
    };
    // Scale-free weights refer to the domain (frame and margin), not to the far rings.
    let (lo, hi) = adapted.domain;
    let mut fit_opts = opts.fit.clone();
    fit_opts.bend_area.get_or_insert((hi[0] - lo[0]) * (hi[1] - lo[1]));
    // det J measured against the landmarks' own scale of area (`Barrier::relative_to`).
    let det_a = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    fit_opts.barrier = fit_opts.barrier.map(|b| b.relative_to(det_a));
    let f = fit_with_terms(&spline, &mds, lms, &fit_opts, start, terms)?;
    crate::alloc::drop_in_background((spline, mds));
    Ok((adapted, f))
}

/// Separation (pixels) by which the border curve must clear the frame in [`covers_frame`]:
/// far above the `f64` rounding of the control points (about `1e-13` px).
pub const COVER_CLEARANCE: f64 = 1e-6;

/// Subdivision depth of a border curve piece in [`covers_frame`].
const COVER_DEPTH: usize = 8;

/// Whether `phi` certainly covers the frame `[lo, hi]`: its border curve `phi(dD)` stays
/// outside the frame and winds once around it, so every frame point has degree 1, hence a
/// preimage (the degree argument of the module docs). Each border edge's image is the
/// Bezier curve of the edge's control points, inside their convex hull: a piece whose points
/// all lie beyond one side of the frame (by [`COVER_CLEARANCE`]) clears it; others are split
/// by de Casteljau's algorithm, up to [`COVER_DEPTH`] times. The winding number is that of the
/// control polygons (homotopic to the curve within the hulls, which miss the frame).
pub fn covers_frame(s: &Spline, lo: [f64; 2], hi: [f64; 2]) -> bool {
    let m = s.mesh();
    let d = s.degree();
    let c = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let clear = |q: &[[f64; 2]]| {
        q.iter().all(|p| p[0] < lo[0] - COVER_CLEARANCE)
            || q.iter().all(|p| p[0] > hi[0] + COVER_CLEARANCE)
            || q.iter().all(|p| p[1] < lo[1] - COVER_CLEARANCE)
            || q.iter().all(|p| p[1] > hi[1] + COVER_CLEARANCE)
    };
    let mut angle = 0.0;
    for e in 0..m.num_edges() {
        if !m.is_border_edge(e) {
            continue;
        }
        let ed = m.edges()[e];
        // The border runs counter-clockwise along the edge as its one triangle traverses it.
        let forward = ed.tris[0].is_some();
        let mut ids: Vec<usize> = std::iter::once(ed.v[0])
            .chain((1..d).map(|k| m.num_vertices() + (d - 1) * e + (k - 1)))
            .chain(std::iter::once(ed.v[1]))
            .collect();
        if !forward {
            ids.reverse();
        }
        let q: Vec<[f64; 2]> = ids.iter().map(|&p| s.point_f64(p)).collect();
        let mut stack = vec![(q, 0usize)];
        let mut pieces: Vec<Vec<[f64; 2]>> = Vec::new();
        while let Some((q, depth)) = stack.pop() {
            if clear(&q) {
                pieces.push(q);
            } else if depth == COVER_DEPTH {
                return false;
            } else {
                let (l, r) = split_half(&q);
                // Left half first in traversal order: push the right half first.
                stack.push((r, depth + 1));
                stack.push((l, depth + 1));
            }
        }
        for q in pieces {
            for w in q.windows(2) {
                let (a, b) = ([w[0][0] - c[0], w[0][1] - c[1]], [w[1][0] - c[0], w[1][1] - c[1]]);
                angle += (a[0] * b[1] - a[1] * b[0]).atan2(a[0] * b[0] + a[1] * b[1]);
            }
        }
    }
    (angle / std::f64::consts::TAU - 1.0).abs() < 0.25
}

/// De Casteljau's split of a Bezier curve at its parameter midpoint.
fn split_half(q: &[[f64; 2]]) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let mut work = q.to_vec();
    let mut left = vec![work[0]];
    let mut right = vec![work[work.len() - 1]];
    while work.len() > 1 {
        work = work
            .windows(2)
            .map(|w| [0.5 * (w[0][0] + w[1][0]), 0.5 * (w[0][1] + w[1][1])])
            .collect();
        left.push(work[0]);
        right.push(work[work.len() - 1]);
    }
    right.reverse();
    (left, right)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    /// Thinning keeps at most the cap, keeps everything under it, and spreads like a
    /// Poisson-disc subset: every dropped source lies nearer to a kept one than any two kept
    /// sources lie to each other, so crowds are thinned and isolated sources kept.
    #[test]
    fn thinned_sources_are_a_spread_subset_within_the_cap() {
        let mut rng = SmallRng::seed_from_u64(51);
        let mut pts: Vec<[f64; 2]> =
            (0..3000).map(|_| [rng.gen_range(0.0..4096.0), rng.gen_range(0.0..4096.0)]).collect();
        // A crowd of 2,000 in a 100 px square, and its exact duplicates.
        pts.extend((0..2000).map(|_| [rng.gen_range(500.0..600.0), rng.gen_range(500.0..600.0)]));
        pts.extend_from_within(3000..3100);
        assert_eq!(thin_sources(&pts[..800], 1000), pts[..800].to_vec());
        let kept = thin_sources(&pts, 1000);
        assert!(kept.len() <= 1000 && kept.len() > 900, "{} kept", kept.len());
        assert_eq!(kept, thin_sources(&pts, 1000), "deterministic");
        let d = |a: &[f64; 2], b: &[f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        let mut closest_kept = f64::INFINITY;
        for (i, a) in kept.iter().enumerate() {
            assert!(pts.contains(a), "a kept point is a source");
            for b in &kept[i + 1..] {
                closest_kept = closest_kept.min(d(a, b));
            }
        }
        let farthest_dropped = pts
            .iter()
            .map(|p| kept.iter().map(|k| d(p, k)).fold(f64::INFINITY, f64::min))
            .fold(0.0, f64::max);
        assert!(farthest_dropped < closest_kept, "{farthest_dropped} vs {closest_kept}");
        let in_crowd = kept
            .iter()
            .filter(|p| (500.0..600.0).contains(&p[0]) && (500.0..600.0).contains(&p[1]))
            .count();
        assert!(in_crowd < 20, "the crowd is thinned to a few: {in_crowd}");
    }
}
