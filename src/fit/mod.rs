//! Fitting a deformation to matched landmarks (see the submodules).
//!
//! * [`landmarks`]: the landmark pair type and its text formats (CSV, BigWarp, JSON);
//! * [`features`]: automatic landmarks between two images (ORB, ratio + cross check,
//!   RANSAC on an affine model);
//! * [`track`]: pyramidal Lucas-Kanade tracking of points between frames;
//! * [`solve`]: the fit itself (objective in [`objective`], bending energy and basis rows in
//!   [`basis`], the MDS parameterization in [`param`], the envelope Cholesky in [`chol`],
//!   exact interpolation in MDS coordinates in [`hard`] and [`hard_solve`]).
//!
//! Points are pixel coordinates throughout: pixel `(i, j)` is centred at `(i, j)`, `x` to
//! the right, `y` downwards.

pub mod basis;
pub mod chol;
pub mod features;
pub mod hard;
pub mod hard_solve;
#[cfg(test)]
mod hard_tests;
pub mod landmarks;
pub mod objective;
pub mod param;
mod rng;
pub mod solve;
#[cfg(test)]
mod tests;
pub mod track;
