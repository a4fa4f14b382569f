//! File jobs: the library calls behind the `trimorph` subcommands. Each reads its inputs,
//! computes with the layers below, writes its outputs atomically (temporary file, then
//! rename: [`crate::io::write_atomic`]) and returns a typed report whose methods give the
//! lines the command line prints. Nothing here prints or exits; errors are [`JobError`],
//! whose text (with its sources joined by `": "`) is the command line's message.
//!
//! * [`warp`]: images, colored meshes and points through a deformation, and image -> mesh;
//! * [`field`]: dense displacement fields (TIFF, `.npy`, ITK `.h5`, OME-Zarr) and the
//!   Jacobian-determinant map;
//! * [`model`]: 2.5D models: binding to a prism layer, moving through `psi`, drawing, and
//!   the bundled organism;
//! * [`spline`]: reference meshes, edit scripts, the C1 check and pictures of a
//!   deformation;
//! * [`fit`]: fits to landmark files, one deformation or a scene over a frame sequence;
//! * [`sequence`]: a sequence fit's inputs and its frame store (every frame's files, all
//!   or nothing);
//! * [`register`]: registration from the images; [`register_frames`]: every frame of a
//!   sequence registered to a reference frame, with resume and shards;
//! * [`solve`]: an ECLES problem file solved and its solution written (errors typed with
//!   the JSON object `trimorph solve` prints);
//! * [`morph`]: the morph of two image files: [`morph_inputs`] reads the images, the
//!   landmarks or the given deformations and makes the morph (options, checks, fits, the
//!   warnings as data); [`morph`] writes its files in one folder, all or nothing;
//! * [`bitgrowth`]: the bit-size study of the exact factoring (CSV and plots);
//! * [`demo`]: the demonstration on bundled data, written into one folder;
//! * [`values`]: the text forms of option values (sizes, grids, shards, time ranges) and
//!   their limits; [`options`]: the errors of bad option values.
//!
//! Layer: above [`crate::render`] and [`crate::io`], below [`crate::server`] and the
//! command line.

#[cfg(feature = "study")]
pub mod bitgrowth;
pub mod demo;
pub mod field;
pub mod fit;
pub mod model;
pub mod morph;
pub mod morph_inputs;
pub mod options;
pub mod register;
pub mod register_frames;
pub mod sequence;
pub mod solve;
pub mod spline;
pub mod values;
pub mod warp;

use crate::io::deformation::{self, DeformationError, LastEdit};
use crate::io::IoError;
use crate::spline::Spline;
pub use options::OptionError;
use std::path::{Path, PathBuf};

/// A boxed error (the cause of a [`JobError::Context`]).
pub type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// Why a file job failed. The text names what is at fault the way the command line does: an
/// option by its flag (`--size`), an input by its file.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// A bad option value or combination of options (the text names the option).
    #[error(transparent)]
    Option(#[from] OptionError),
    /// A control point of the deformation file `file` lies beyond
    /// [`MAX_COORD`](crate::spline::check::MAX_COORD) pixels, where `f64` keeps none of the
    /// mesh's digits (`point` says which and where).
    #[error(
        "{}: {point}, beyond {} pixels: the fit works in pixel coordinates; correct that point",
        file.display(),
        crate::spline::check::MAX_COORD
    )]
    FarPoint {
        /// The deformation file.
        file: PathBuf,
        /// The point and its position.
        point: String,
    },
    /// The edits of the script `script` moved a control point beyond
    /// [`MAX_COORD`](crate::spline::check::MAX_COORD) pixels (nothing is written).
    #[error(
        "{}: after the edits {point}, beyond {} pixels: refused (nothing written)",
        script.display(),
        crate::spline::check::MAX_COORD
    )]
    FarAfterEdits {
        /// The edit script.
        script: PathBuf,
        /// The point and its position.
        point: String,
    },
    /// The deformation maps the whole mesh onto a point or a line (issue 54: reported as
    /// not overlapping the image).
    #[error(
        "{}: the deformation maps the whole mesh onto {what} (all its control points lie there), so det J is 0 everywhere and no pixel has a preimage; use a deformation that keeps an area, e.g. make one with `trimorph mesh` or fit again",
        deformation.display()
    )]
    Collapsed {
        /// The deformation file.
        deformation: PathBuf,
        /// "the point (x, y)" or "a line through (x, y) and (x, y)".
        what: String,
    },
    /// The deformed mesh misses the image entirely: every output pixel would be background.
    #[error(
        "{}: the deformed mesh does not overlap the {}x{} image {} at all (every output pixel would be background); mesh coordinates are the image's pixels: use the deformation made for this image",
        deformation.display(),
        size.0,
        size.1,
        image.display()
    )]
    NoOverlap {
        /// The deformation file.
        deformation: PathBuf,
        /// The image file.
        image: PathBuf,
        /// The image's size, `(w, h)`.
        size: (u32, u32),
    },
    /// The fit is too large for the solver: the deformation's doing (its mesh and degree).
    #[error("{}: {source}", deformation.display())]
    TooLarge {
        /// The deformation file.
        deformation: PathBuf,
        /// The fit's refusal ([`FitError::TooLarge`](crate::fit::FitError::TooLarge)).
        #[source]
        source: crate::fit::FitError,
    },
    /// A scene file's up axis is not `x`, `y` or `z`.
    #[error("{}: {reason}", scene.display())]
    SceneUp {
        /// The scene file.
        scene: PathBuf,
        /// What is wrong with its key.
        reason: String,
    },
    /// A failure about one input or output: `context` names it (and what was being done);
    /// `source` is the cause.
    #[error("{context}")]
    Context {
        /// The file, or what was being done with it.
        context: String,
        /// The cause.
        #[source]
        source: BoxError,
    },
    /// Reading or writing a file.
    #[error(transparent)]
    Io(#[from] IoError),
    /// Writing a report line (to a stream the caller gave).
    #[error(transparent)]
    Output(std::io::Error),
    /// A library error that names its own subject.
    #[error(transparent)]
    Lib(#[from] LibError),
}

/// Defines [`LibError`] (one transparent variant per error type of a layer below) and the
/// conversion of each type into [`JobError::Lib`].
macro_rules! lib_errors {
    ($($(#[$doc:meta])* $variant:ident($t:ty),)+) => {
        /// The errors of the layers below that a job passes on as they are.
        #[derive(Debug, thiserror::Error)]
        pub enum LibError {
            $($(#[$doc])* #[error(transparent)] $variant(#[from] $t),)+
        }
        $(impl From<$t> for JobError {
            fn from(e: $t) -> JobError {
                JobError::Lib(e.into())
            }
        })+
    };
}

lib_errors!(
    /// Warping images.
    Warp(crate::warp::WarpError),
    /// Reading or writing raster images.
    Raster(crate::io::raster::RasterError),
    /// OME-Zarr stores.
    Ngff(crate::io::ngff::NgffError),
    /// ITK transforms.
    Itk(crate::io::itk::ItkError),
    /// Pictures.
    Render(crate::render::deformation::RenderError),
    /// Colored meshes.
    ColorMesh(crate::warp::colormesh::ColorMeshError),
    /// Colored mesh files.
    MeshFile(crate::io::colormesh::MeshFileError),
    /// Point files.
    Points(crate::io::points::PointsError),
    /// Reference meshes.
    Mesh(crate::mesh::MeshError),
    /// Splines.
    Spline(crate::spline::SplineError),
    /// Prism layers and models bound to them.
    Prism(crate::prism::PrismError),
    /// Model files.
    Model(crate::io::model::ModelIoError),
    /// JSON.
    Json(serde_json::Error),
    /// The bundled data.
    Bundled(crate::bundled::BundledError),
    /// Registration.
    Register(crate::register::RegisterError),
    /// Sequence registration (boxed: it is large).
    RegisterFrames(Box<crate::register::frames::FramesError>),
    /// Frame sequences (boxed: it is large).
    Frames(Box<crate::io::frames::FramesError>),
);

impl From<crate::register::frames::FramesError> for JobError {
    fn from(e: crate::register::frames::FramesError) -> JobError {
        Box::new(e).into()
    }
}

impl From<crate::io::frames::FramesError> for JobError {
    fn from(e: crate::io::frames::FramesError) -> JobError {
        Box::new(e).into()
    }
}

impl JobError {
    /// A [`JobError::Context`]: `source` about `context`.
    pub fn context(
        context: impl Into<String>,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> JobError {
        JobError::Context { context: context.into(), source: Box::new(source) }
    }
}

/// Result of a file job.
pub type JobResult<T> = Result<T, JobError>;

/// Reads a deformation file (format v1; `-` for standard input); a parse error names the
/// file (`cannot read deformation PATH: ...`).
pub fn read_deformation(path: &Path) -> JobResult<(Spline, Option<LastEdit>)> {
    let text = crate::io::read_text(path)?;
    parse_deformation(&text, path)
}

/// Parses the text of the deformation file `path` (errors as [`read_deformation`]).
pub fn parse_deformation(text: &str, path: &Path) -> JobResult<(Spline, Option<LastEdit>)> {
    deformation::from_str(text).map_err(|e: DeformationError| {
        JobError::context(format!("cannot read deformation {}", path.display()), e)
    })
}

pub use crate::io::MAX_RASTER_PIXELS;

/// Whether a `w` x `h` raster is non-empty and within [`MAX_RASTER_PIXELS`].
pub fn raster_fits(w: u32, h: u32) -> bool {
    w != 0 && h != 0 && (w as u64) * (h as u64) <= MAX_RASTER_PIXELS
}

/// The lower-case extension of `path` (empty when it has none).
fn ext_of(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase()
}
