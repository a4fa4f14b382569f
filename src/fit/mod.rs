//! Fitting a deformation to matched landmarks (see the submodules).
//!
//! * [`landmarks`]: the landmark pair type and its text formats (CSV, BigWarp, JSON);
//! * [`features`]: automatic landmarks between two images (ORB, ratio + cross check,
//!   RANSAC on an affine model);
//! * [`track`]: pyramidal Lucas-Kanade tracking of points between frames;
//! * [`sequence`]: one scene fitted to every frame of a sequence (tracked or given targets,
//!   anchoring, held-out landmarks, warm starts, resume keys, shards);
//! * [`fit()`]: the fit itself, one entry point with its [`FitOptions`] ([`options`]),
//!   returning a [`Fit`] with its typed [`FitReport`] ([`report`]); the soft fit in [`solve`]
//!   (objective in [`objective`], bending energy and basis rows in
//!   [`basis`], the MDS parameterization in [`param`], the squares fit in landmark space and
//!   the automatic smoothing weight in [`smooth`] (in variable space for many landmarks,
//!   [`smooth_sparse`]), Newton's method with the fold barrier in
//!   [`newton`] on the sparse Cholesky of [`sparse`], exact interpolation in
//!   MDS coordinates in [`hard`] and [`hard_solve`]);
//! * [`frame`]: a fit from landmarks alone, over a landmark-adapted mesh that covers the
//!   whole frame.
//!
//! Points are pixel coordinates throughout: pixel `(i, j)` is centred at `(i, j)`, `x` to
//! the right, `y` downwards.

pub mod affine;
pub mod basis;
mod entry;
mod error;
pub mod features;
pub mod frame;
pub mod hard;
pub mod hard_solve;
#[cfg(test)]
mod hard_tests;
pub mod landmarks;
pub mod newton;
pub mod objective;
pub mod optim;
pub mod options;
pub mod param;
pub mod report;
pub mod sequence;
pub mod smooth;
pub mod smooth_sparse;
pub mod solve;
pub use crate::sparse;
#[cfg(test)]
mod tests;
pub mod track;

pub use entry::{fit, fit_with};
pub use error::FitError;
pub use options::{Bend, BendError, FitOptions};
pub use report::{residuals, with_holdout, Fit, FitReport, HoldoutReport, Residual, Stats};
