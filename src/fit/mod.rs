//! Fitting a deformation to matched landmarks (see the submodules).
//!
//! * [`landmarks`]: the landmark pair type and its text formats (CSV, BigWarp, JSON);
//! * [`features`]: automatic landmarks between two images (ORB, ratio + cross check,
//!   RANSAC on an affine model);
//! * [`track`]: pyramidal Lucas-Kanade tracking of points between frames.
//!
//! Points are pixel coordinates throughout: pixel `(i, j)` is centred at `(i, j)`, `x` to
//! the right, `y` downwards.

pub mod features;
pub mod landmarks;
mod rng;
pub mod track;
