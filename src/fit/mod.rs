//! Fitting a deformation to matched landmarks (see the submodules).

pub mod basis;
pub mod chol;
pub mod hard;
pub mod landmarks;
pub mod objective;
pub mod param;
pub mod solve;
#[cfg(test)]
mod tests;
