//! Fitting a deformation to matched landmarks (see the submodules).
//!
//! * [`landmarks`]: the landmark pair type and its text formats (CSV, BigWarp, JSON).
//!
//! Points are pixel coordinates throughout: pixel `(i, j)` is centred at `(i, j)`, `x` to
//! the right, `y` downwards.

pub mod landmarks;
mod rng;
