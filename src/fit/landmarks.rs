//! Landmark pairs: a source point in the reference domain and a target point in the image.

/// One matched pair: `src` in the reference domain (mesh coordinates), `dst` where the
/// deformation should send it (image pixels), with a weight and an optional name.
#[derive(Clone, Debug, PartialEq)]
pub struct Landmark {
    /// Name (unique names are kept through every format).
    pub name: Option<String>,
    /// Source point (reference domain).
    pub src: [f64; 2],
    /// Target point (image).
    pub dst: [f64; 2],
    /// Weight (finite, > 0; default 1).
    pub weight: f64,
}
