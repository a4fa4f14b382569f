//! Rendering: pictures (plots, deformations, models, colored meshes, overlays), the text
//! font and the triangle rasterizer they share. Only drawing: the files of the jobs that
//! write many pictures (a sequence fit, a morph) are in [`crate::jobs`].
pub mod colorbar;
pub mod colormesh;
pub mod deformation;
pub mod font;
pub mod model;
pub mod overlay;
pub mod plot;
pub mod registration;
