//! Rendering: pictures (plots, deformations, models, colored meshes) and the files of the
//! jobs that write many of them (a sequence fit, a morph).
pub mod colorbar;
pub mod colormesh;
pub mod deformation;
pub mod font;
pub mod model;
pub mod morph_files;
pub mod overlay;
pub mod plot;
pub mod registration;
pub mod sequence;
