//! Rendering.
pub mod colorbar;
pub mod colormesh;
pub mod deformation;
pub mod font;
pub mod model;
pub mod overlay;
pub mod plot;
pub mod sequence;
