//! The morph's two fits on landmark-adapted meshes ([`crate::fit::frame`]), each covering
//! `A`'s frame and certified fold-free.
//!
//! **Maps and units** (pixel centres at integers, `x` right, `y` down):
//!
//! * `S`: `B`'s pixels -> `A`'s pixels, the landmarks' similarity ([`super::align`]);
//!   the identity with `--no-align`.
//! * `phi_ab`: `A`'s pixels -> `A`'s pixels, fitted to `L_A -> S(L_B)` over a mesh of `A`'s
//!   rectangle plus a margin. It is `S ∘ phi_{A->B}` where `phi_{A->B}` (written as
//!   `phi_ab.json`) maps `A`'s pixels to `B`'s own pixels.
//! * `phi_ba`: `B`'s pixels -> `A`'s pixels, fitted to `L_B -> L_A` over a mesh of `B`'s own
//!   rectangle (`B`'s size) plus a margin chosen so that it covers `A`'s frame (written as
//!   `phi_ba.json`, no similarity involved).
//!
//! The margin: let `M` be the landmarks' least-squares affine map (source pixels -> `A`'s
//! pixels). The margin is the larger of the default ([`default_margin`] of the source size)
//! and what makes `M^-1` of each corner of `A`'s frame lie inside the domain, plus 2 px;
//! it is doubled (up to [`MAX_DOUBLINGS`] times) while [`covers_frame`] cannot prove that
//! the fitted map covers `A`'s frame `[-0.5, w_A - 0.5] x [-0.5, h_A - 0.5]`.
//!
//! **Fidelity.** By default both fits interpolate (the bending weight
//! [`crate::fit::smooth::INTERPOLATING_BEND`], with the fold barrier): `phi_ab(L_A) = S(L_B)`
//! and `phi_ba(L_B) = L_A` within [`MISS_TOLERANCE`]. A landmark missed by more is listed in
//! [`MapSummary::misses`] (the CLI warns with its name), which happens only where the barrier
//! had to act, i.e. where following the landmarks exactly would fold the map.
//!
//! **Pinned frame** ([`frame_pins`]). With `--pin-frame`, points along `A`'s frame border
//! `p` become landmarks of both fits, `p -> p` for `phi_ab` and `S^-1(p) -> p` for
//! `phi_ba`: the border of every frame stays where it is in `A` (and in `B` after the
//! alignment), and only what the landmarks move moves.
//!
//! **Folds.** Both fits run with the fold barrier ([`crate::fit::FitOptions`]),
//! whose every accepted step is certified `det J > 0`. Landmarks that force a fold (pairs
//! that cross, [`crate::fit::affine::crossing_pairs`]) are then not followed exactly: the
//! morph is made, fold-free, and [`MapSummary::conflicts`] names the pairs (the CLI warns
//! with their names and the residuals). A result that is *not* certified (possible only with
//! the barrier off, [`crate::fit::FitOptions::barrier`] `None`) is refused
//! ([`super::MorphError::Folds`]), naming the crossing pairs, because a folded map shows
//! creases and torn strips in the middle frames.

use super::align::Similarity;
use super::MorphError;
use crate::fit::affine::{affine_fit, crossing_pairs};
use crate::fit::frame::{covers_frame, fit_frame, FrameFitOptions, FrameReport};
use crate::fit::landmarks::Landmark;
use crate::fit::{FitError, FitReport};
use crate::mesh::{default_margin, AdaptOptions};
use crate::spline::Spline;
use serde::Serialize;

/// Margin doublings tried when a fit does not cover `A`'s frame.
pub const MAX_DOUBLINGS: usize = 3;

/// One of the morph's fits: its spline and reports.
#[derive(Clone, Debug)]
pub struct MapFit {
    /// The fitted spline (see the module docs for its direction).
    pub spline: Spline,
    /// The fit's report (residuals, certificate, conflicts).
    pub report: FitReport,
    /// Mesh and margin (its `covers_frame` refers to `A`'s frame).
    pub frame: FrameReport,
}

/// A summary of a [`MapFit`] for reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapSummary {
    /// Mesh triangles.
    pub triangles: usize,
    /// Margin (pixels of the source image).
    pub margin: f64,
    /// Certified `det J > 0` on the whole domain.
    pub fold_free: bool,
    /// The certified lower bound of `det J`.
    pub det_j_lower_bound: f64,
    /// Proven to cover `A`'s frame.
    pub covers_frame: bool,
    /// Largest landmark residual (pixels of `A`).
    pub max_residual: f64,
    /// Landmark pairs that cross (names or indices), when the barrier had to act: the fit
    /// stays fold-free and does not follow them exactly (see the module docs).
    pub conflicts: Vec<[String; 2]>,
    /// Landmarks missed by more than [`MISS_TOLERANCE`] (name or `#index`, residual in
    /// pixels of `A`), largest first.
    pub misses: Vec<(String, f64)>,
    /// Fit time (ms).
    pub time_ms: f64,
}

/// Largest landmark residual (pixels) of an interpolating morph fit; larger ones are
/// reported ([`MapSummary::misses`]).
pub const MISS_TOLERANCE: f64 = 0.1;

/// Name prefix of the border landmarks that `--pin-frame` adds ([`frame_pins`]).
pub const PIN_PREFIX: &str = "frame-pin-";

/// The border landmarks of `--pin-frame` (module docs): pixel centres of `A`'s outer rows
/// and columns (`size_a` in pixels), at most [`PIN_SPACING`] apart (and at most
/// [`MAX_PINS_PER_SIDE`] per side), as `(for phi_ab, for phi_ba)`.
///
/// For `phi_ba` the source is `S^-1(p)` rounded to multiples of `1/16` px and the target is
/// `S` of that source (within 0.05 px of `p`): sources on the meshes' snapping grid are mesh
/// vertices exactly, which keeps each pin's row to one control point (a hard fit's rows of
/// off-vertex points along a line couple into groups it cannot solve). A point within 1 px
/// of a landmark's source in `A` is left out (the landmark holds it), and so is, for
/// `phi_ba`, a point whose preimage lies outside `B`'s landmark frame (`B` has no pixels
/// there).
pub fn frame_pins(
    lms: &[Landmark],
    size_a: [f64; 2],
    size_b: [f64; 2],
    sim: &Similarity,
) -> (Vec<Landmark>, Vec<Landmark>) {
    let [w, h] = [size_a[0] - 1.0, size_a[1] - 1.0];
    let steps = |len: f64| ((len / PIN_SPACING).ceil() as usize).clamp(1, MAX_PINS_PER_SIDE);
    let (nx, ny) = (steps(w), steps(h));
    let at = |len: f64, i: usize, n: usize| (len * i as f64 / n as f64).round();
    let mut border: Vec<[f64; 2]> = Vec::with_capacity(2 * (nx + ny));
    for i in 0..nx {
        let x = at(w, i, nx);
        border.push([x, 0.0]);
        border.push([w - x, h]);
    }
    for j in 0..ny {
        let y = at(h, j, ny);
        border.push([w, y]);
        border.push([0.0, h - y]);
    }
    border.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    border.dedup();
    let near = |p: [f64; 2]| lms.iter().any(|l| (l.src[0] - p[0]).hypot(l.src[1] - p[1]) < 1.0);
    let sixteenth = |v: f64| (v * 16.0).round() / 16.0;
    let (mut ab, mut ba) = (Vec::new(), Vec::new());
    for (k, p) in border.into_iter().filter(|&p| !near(p)).enumerate() {
        let name = Some(format!("{PIN_PREFIX}{k}"));
        ab.push(Landmark { name: name.clone(), src: p, dst: p, weight: 1.0 });
        let q = sim.inverse(p).map(sixteenth);
        if crate::mesh::in_landmark_frame(q, size_b) {
            ba.push(Landmark { name, src: q, dst: sim.apply(q), weight: 1.0 });
        }
    }
    (ab, ba)
}

/// Largest spacing (pixels of `A`) of the `--pin-frame` border points.
pub const PIN_SPACING: f64 = 16.0;

/// Most `--pin-frame` border points per side.
pub const MAX_PINS_PER_SIDE: usize = 64;

impl MapFit {
    /// The summary.
    pub fn summary(&self) -> MapSummary {
        MapSummary {
            triangles: self.frame.triangles,
            margin: self.frame.margin,
            fold_free: self.report.fold_free,
            det_j_lower_bound: self.report.det_j_lower_bound,
            covers_frame: self.frame.covers_frame,
            max_residual: self.report.fit.max,
            conflicts: self.report.conflicts.clone(),
            misses: misses(&self.report.residuals),
            time_ms: self.report.time_ms,
        }
    }
}

/// The landmarks missed by more than [`MISS_TOLERANCE`], largest first.
fn misses(res: &[crate::fit::Residual]) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = res
        .iter()
        .enumerate()
        .filter(|(_, r)| r.residual > MISS_TOLERANCE || r.residual.is_nan())
        .map(|(i, r)| (r.name.clone().unwrap_or_else(|| format!("#{i}")), r.residual))
        .collect();
    v.sort_by(|a, b| b.1.total_cmp(&a.1));
    v
}

/// The margin that makes the affine map `m` (source -> `A`) cover `A`'s frame `dst` from
/// a source rectangle `src` (at least `base`).
fn covering_margin(m: &[[f64; 3]; 2], src: [f64; 2], dst: [f64; 2], base: f64) -> f64 {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let mut need: f64 = 0.0;
    let (w, h) = (dst[0], dst[1]);
    for c in [[-0.5, -0.5], [w - 0.5, -0.5], [-0.5, h - 0.5], [w - 0.5, h - 0.5]] {
        let v = [c[0] - m[0][2], c[1] - m[1][2]];
        let p = [(m[1][1] * v[0] - m[0][1] * v[1]) / det, (-m[1][0] * v[0] + m[0][0] * v[1]) / det];
        need = need
            .max(-0.5 - p[0])
            .max(-0.5 - p[1])
            .max(p[0] - (src[0] - 0.5))
            .max(p[1] - (src[1] - 0.5));
    }
    base.max((need + 2.0).ceil())
}

/// Fits `lms` (sources in a `src`-sized image, targets in `A`'s pixels) so that the map
/// covers `A`'s frame `dst` (module docs); `dir` names the fit in errors.
pub fn fit_covering(
    lms: &[Landmark],
    src: [f64; 2],
    dst: [f64; 2],
    mesh: &AdaptOptions,
    opts: &FrameFitOptions,
    dir: &'static str,
) -> Result<MapFit, MorphError> {
    let err = |source: FitError| MorphError::Fit { dir, source };
    let m = affine_fit(lms).map_err(err)?;
    let base = mesh.margin.unwrap_or_else(|| default_margin(src[0], src[1]));
    let mut margin = if mesh.margin.is_some() { base } else { covering_margin(&m, src, dst, base) };
    let mut doublings = 0;
    loop {
        let o = FrameFitOptions {
            mesh: AdaptOptions { margin: Some(margin), ..mesh.clone() },
            ..opts.clone()
        };
        let f = fit_frame(lms, src, &o).map_err(err)?;
        let covered = covers_frame(&f.fit.spline, [-0.5, -0.5], [dst[0] - 0.5, dst[1] - 0.5]);
        if covered || mesh.margin.is_some() || doublings == MAX_DOUBLINGS {
            let mut frame = f.frame;
            frame.covers_frame = covered;
            if !f.fit.report.fold_free {
                return Err(fold_error(lms, dir, &f.fit.report));
            }
            return Ok(MapFit { spline: f.fit.spline, report: f.fit.report, frame });
        }
        margin *= 2.0;
        doublings += 1;
    }
}

/// The error for a fit that is not certified fold-free, naming the crossing pairs.
fn fold_error(lms: &[Landmark], dir: &'static str, r: &FitReport) -> MorphError {
    let name = |i: usize| match &lms[i].name {
        Some(n) => format!("{i} ({n})"),
        None => format!("{i}"),
    };
    let mut pairs: Vec<String> = crossing_pairs(lms)
        .into_iter()
        .map(|(i, j)| format!("{} and {}", name(i), name(j)))
        .collect();
    if pairs.is_empty() {
        pairs = r.conflicts.iter().map(|[a, b]| format!("{a} and {b}")).collect();
    }
    MorphError::Folds { dir, lower_bound: r.det_j_lower_bound, pairs }
}
