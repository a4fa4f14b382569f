//! Fitting a deformation to matched landmarks (see the submodules).

pub mod landmarks;
