//! Rendering.
pub mod font;
pub mod plot;
