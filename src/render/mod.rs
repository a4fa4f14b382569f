//! Rendering.
pub mod plot;
