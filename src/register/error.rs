//! Why a registration could not be made.

use std::path::PathBuf;

/// Errors of [`super::register`]. Each names the image or the part of the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum RegisterError {
    /// The caller's [`crate::cancel::Cancel`] token was set
    /// ([`super::RegisterOptions::cancel`]).
    #[error("the registration was cancelled")]
    Cancelled,
    /// A float image holds NaN or infinite pixels.
    #[error("{image}: pixel ({x}, {y}) is not a finite number (NaN or infinite); replace such pixels or mask them out before registering")]
    NonFinite {
        /// The image.
        image: PathBuf,
        /// Column of the first such pixel.
        x: usize,
        /// Row.
        y: usize,
    },
    /// An image has the same value everywhere (inside its mask): nothing to register by.
    #[error(
        "{image}: the image is constant ({value}) inside its mask; there is nothing to register by"
    )]
    Constant {
        /// The image.
        image: PathBuf,
        /// Its value.
        value: f32,
    },
    /// A mask holds no pixel.
    #[error("{mask}: the mask is empty (no pixel above half its largest value)")]
    EmptyMask {
        /// The mask.
        mask: PathBuf,
    },
    /// A mask's size differs from its image's.
    #[error("{mask}: the mask is {mask_w} x {mask_h} pixels but its image {image} is {image_w} x {image_h}")]
    MaskSize {
        /// The mask.
        mask: PathBuf,
        /// The image.
        image: PathBuf,
        /// Mask width.
        mask_w: usize,
        /// Mask height.
        mask_h: usize,
        /// Image width.
        image_w: usize,
        /// Image height.
        image_h: usize,
    },
    /// An image is too small to register.
    #[error("{image}: {w} x {h} pixels is too small to register (at least 16 x 16)")]
    TooSmall {
        /// The image.
        image: PathBuf,
        /// Width.
        w: usize,
        /// Height.
        h: usize,
    },
    /// After the pre-alignment too few moving samples land on the fixed image.
    #[error("the images do not overlap after the pre-alignment: only {percent:.1} % of MOVING's samples land on FIXED (at least {needed} % are needed); check that the images show the same scene, or start from --init")]
    NoOverlap {
        /// Share of the samples inside FIXED (percent).
        percent: f64,
        /// The share needed (percent).
        needed: f64,
    },
    /// An option is out of range.
    #[error("{0}")]
    Option(String),
    /// Building the mesh or the spline failed.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// The spline could not be made.
    #[error(transparent)]
    Spline(#[from] crate::spline::SplineError),
    /// The determining set could not be made.
    #[error(transparent)]
    Mds(#[from] crate::spline::mds::MdsError),
    /// The landmarks or the exact constraints failed.
    #[error(transparent)]
    Fit(#[from] crate::fit::FitError),
    /// The optimizer failed.
    #[error("the optimizer failed: {0}")]
    Optimizer(String),
}
