//! The fit's entry point: [`fit`] checks for a cancel, sets the rounding grid the mesh
//! needs, and runs the soft fit ([`super::solve`]) or, for hard landmarks and pinned points,
//! the exact fit ([`super::hard`], which starts from a soft fit). The pipeline, file by
//! file: [`super::options`] -> [`super::objective`] (with [`super::param`] and
//! [`super::basis`]) -> [`super::solve`] (smoothing in [`super::smooth`] /
//! [`super::smooth_sparse`], the barrier's Newton method in [`super::newton`]) ->
//! [`super::hard`] -> [`super::report`]; errors in [`super::error`].

use super::error::FitError;
use super::landmarks::Landmark;
use super::objective::TriangleTerms;
use super::options::FitOptions;
use super::report::Fit;
use crate::spline::mds::Mds;
use crate::spline::Spline;
use std::time::Instant;

/// Fits `s` to the landmarks (see [`super::solve`] and [`super::hard`]). `s` is the warm start; it is not changed.
pub fn fit(s: &Spline, lms: &[Landmark], opts: &FitOptions) -> Result<Fit, FitError> {
    let start = Instant::now();
    fit_with(s, &Mds::new(s)?, lms, opts, start)
}

/// [`fit`] with the spline's determining set already built (it is the costly exact part of
/// a small fit); `start` is when the caller's timing began.
pub fn fit_with(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
    start: Instant,
) -> Result<Fit, FitError> {
    fit_with_terms(s, mds, lms, opts, start, None)
}

/// [`fit_with`] with the triangles' terms possibly prebuilt (for `s` at `opts.det_level`;
/// used by the soft fit only).
pub(super) fn fit_with_terms(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
    start: Instant,
    terms: Option<TriangleTerms>,
) -> Result<Fit, FitError> {
    opts.cancel.check().map_err(|_| FitError::Cancelled)?;
    // Round the free points finely enough that no control point moves more than
    // 2^-grid_bits px (a near-singular vertex of the mesh amplifies a rounding by up to
    // 10^8: rounded at 2^-20 such a fit folded while its floating-point solution did not).
    let opts = &FitOptions {
        grid_bits: crate::spline::mds::rounding_bits(mds.amplification(), opts.grid_bits),
        ..opts.clone()
    };
    if opts.hard || !opts.pinned.is_empty() {
        return super::hard::fit_hard(s, mds, lms, opts, start);
    }
    // The exact evaluation plan of the determining set is needed only at the end (the
    // fitted points in rationals): built on another thread while the fit solves.
    rayon::join(|| super::solve::fit_soft_terms(s, mds, lms, opts, start, terms), || mds.prepare())
        .0
}
