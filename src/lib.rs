//! trimorph
pub mod exact;
pub mod ecles;
pub mod render;
