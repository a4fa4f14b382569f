//! Rendering.
pub mod deformation;
pub mod font;
pub mod plot;
