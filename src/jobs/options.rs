//! [`OptionError`]: a bad option value or combination of options, one variant per rule, so
//! that a library user can tell them apart; each text names the option the way the command
//! line spells it (the Python keywords have the same names).

use crate::fit::FitError;
use std::path::PathBuf;

/// A bad option value or a bad combination of options (inside [`super::JobError::Option`]).
#[derive(Debug, thiserror::Error)]
pub enum OptionError {
    /// A number outside its range (`--trials`, `--snap`, `--bounded-bits`, `--margin`):
    /// printed as the flag followed by its rule.
    #[error("{flag} {rule}")]
    OutOfRange {
        /// The option, e.g. `--trials`.
        flag: &'static str,
        /// What its value must be, e.g. `must be at least 1`.
        rule: &'static str,
    },
    /// `model bind` needs exactly one of `--mesh` and `--auto`.
    #[error("give exactly one of --mesh T.obj or --auto")]
    MeshOrAuto,
    /// `model bind --mesh` over a mesh with no `z = b > 0` and no `--range`.
    #[error("the reference mesh has no z = b > 0 on its vertices: give --range A,B")]
    NoRange,
    /// `field --both` with `--inverse`.
    #[error("--both writes both directions; leave out --inverse")]
    BothWithInverse,
    /// `fit --pin` without a deformation to take the pinned values from.
    #[error("--pin needs a deformation (DEF) whose control points it names")]
    PinWithoutDeformation,
    /// `bench bitgrowth --only TEXT` matches no experiment.
    #[error("no experiment id contains {0:?}")]
    NoExperiment(String),
    /// An output whose file type cannot hold what is written (or an input it needs is
    /// missing): the file and what it must be.
    #[error("{}: {expected}", path.display())]
    OutputType {
        /// The output file.
        path: PathBuf,
        /// What it must be, e.g. `the Jacobian map is a PNG picture; name it .png`.
        expected: &'static str,
    },
    /// A field grid that is empty or larger than [`super::MAX_RASTER_PIXELS`] (the size
    /// given or the deformation's default).
    #[error(
        "{}: field size {}x{} is empty or too large (at most 10^8 pixels); give --size W,H",
        deformation.display(),
        size.0,
        size.1
    )]
    FieldSize {
        /// The deformation file.
        deformation: PathBuf,
        /// The grid, `(w, h)`.
        size: (u32, u32),
    },
    /// A picture of a warped mesh that is empty or larger than
    /// [`super::MAX_RASTER_PIXELS`].
    #[error(
        "--size {},{}: each side must be positive and the area at most 10^8 pixels",
        size.0,
        size.1
    )]
    PictureSize {
        /// The size given, `(w, h)`.
        size: (u32, u32),
    },
    /// The background of a mesh picture is not a gray level.
    #[error("--background for a mesh picture is a gray level 0..255, not {0}")]
    MeshBackground(f64),
    /// `--holdout` would keep every landmark out of the fit.
    #[error("--holdout {holdout}: only {landmarks} landmarks, at least one must be fitted")]
    Holdout {
        /// Landmarks asked to be held out.
        holdout: usize,
        /// Landmarks in the file.
        landmarks: usize,
    },
    /// `--pin edited` on a deformation that records no corrected points.
    #[error(
        "--pin edited: {} records no corrected points (save it from the editor after an edit)",
        deformation.display()
    )]
    NoEditedPoints {
        /// The deformation file.
        deformation: PathBuf,
    },
    /// The pinned points cannot be held (the fit's refusal, about the deformation's points).
    #[error("--pin: {}: {source}", deformation.display())]
    Pin {
        /// The deformation file.
        deformation: PathBuf,
        /// The fit's refusal.
        #[source]
        source: FitError,
    },
    /// The fit's options refused by the fit ([`FitError::is_option`]).
    #[error(transparent)]
    Fit(FitError),
}
