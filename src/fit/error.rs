//! [`FitError`]: why a fit failed, one variant per rule, each carrying the offending values.

use super::objective::Barrier;
use super::options::MAX_FIT_VARIABLES;
use crate::mesh::MeshError;
use crate::spline::mds::MdsError;
use crate::spline::{ControlPoint, SplineError};

/// Why a fit failed. The input deformation is never changed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// No landmarks to fit.
    #[error("no landmarks to fit; give at least one landmark pair")]
    NoLandmarks,
    /// A landmark with a non-finite coordinate or a weight that is not positive.
    #[error("landmark {index} ({name}): {why}")]
    BadLandmark {
        /// Index in the input.
        index: usize,
        /// Its name or `-`.
        name: String,
        /// What is wrong.
        why: String,
    },
    /// A source point outside the reference mesh.
    #[error("landmark {index} ({name}): source point ({x}, {y}) lies outside the mesh; move it inside the reference mesh or use a mesh that covers it")]
    OutsideMesh {
        /// Index in the input.
        index: usize,
        /// Its name or `-`.
        name: String,
        /// Source x.
        x: f64,
        /// Source y.
        y: f64,
    },
    /// No local determining set for this mesh.
    #[error("fitting needs a minimal determining set of the spline: {0}")]
    Mds(#[from] MdsError),
    /// The normal matrix is singular.
    #[error(
        "the landmarks do not determine the fit (normal matrix singular at variable {0}): give \
         at least 3 landmarks not on one line, or a positive bending weight"
    )]
    Singular(usize),
    /// A bending weight ([`super::options::Bend::Weight`]) that is not a finite number `>= 0`.
    #[error("invalid fit option: bending weight {weight} must be finite and >= 0")]
    BendWeight {
        /// The weight given.
        weight: f64,
    },
    /// The scale of a Huber or Cauchy loss is not a finite number `> 0`.
    #[error("invalid fit option: loss scale {scale} must be finite and > 0")]
    LossScale {
        /// The scale given.
        scale: f64,
    },
    /// A fold barrier whose floor is not below its threshold or whose weight is not
    /// positive.
    #[error("invalid fit option: barrier needs floor < threshold and a positive weight")]
    BarrierShape {
        /// The barrier given.
        barrier: Barrier,
    },
    /// A `det J` sample level of 0, or a rounding grid of 0 or more than 60 bits.
    #[error("invalid fit option: det level and grid bits must be positive (grid bits at most 60)")]
    Sampling {
        /// [`FitOptions::det_level`](super::options::FitOptions::det_level) given.
        det_level: usize,
        /// [`FitOptions::grid_bits`](super::options::FitOptions::grid_bits) given.
        grid_bits: u32,
    },
    /// A pinned control point ([`FitOptions::pinned`](super::options::FitOptions::pinned)) that the spline does not have.
    #[error(
        "invalid fit option: pinned control point {point} does not exist (the spline has \
         {points})"
    )]
    NoSuchPinned {
        /// The point named.
        point: ControlPoint,
        /// The spline's number of control points.
        points: usize,
    },
    /// The landmark-adapted mesh of a frame fit ([`super::frame`]) refused its options
    /// (frame size, margin, edge length, angle, snapping grid).
    #[error("invalid fit option: {0}")]
    AdaptedMesh(#[source] MeshError),
    /// The landmarks as a whole cannot determine a fit (too few, all on one line, or
    /// mirrored).
    #[error("{0}")]
    Landmarks(String),
    /// More variable control points than the dense normal matrix can hold.
    #[error(
        "the fit has {variables} variable control points, more than the {max} the solver \
         handles; use a coarser mesh or a --radius around the landmarks",
        max = MAX_FIT_VARIABLES
    )]
    TooLarge {
        /// The number of variable control points.
        variables: usize,
    },
    /// The optimizer failed.
    #[error("optimizer failed: {0}")]
    Solver(String),
    /// The caller's [`crate::cancel::Cancel`] token was set ([`super::FitOptions::cancel`]).
    #[error("the fit was cancelled")]
    Cancelled,
    /// The exact result is not C1 (a bug if it ever happens).
    #[error(transparent)]
    Spline(#[from] SplineError),
    /// Two landmarks with the same source (exactly, as written) and different targets.
    #[error("{first} and {second} have the same source ({x}, {y}) but different targets, so no deformation can meet both; correct or remove one of them, or fit without hard constraints")]
    Conflicting {
        /// `landmark i (name)` of the first.
        first: String,
        /// `landmark j (name)` of the second.
        second: String,
        /// Source x.
        x: f64,
        /// Source y.
        y: f64,
    },
    /// A hard landmark whose every control point is pinned, away from its target (issue
    /// 54: blamed "at most 21 landmarks per triangle").
    #[error("{landmark} cannot reach its target ({x}, {y}): every control point that moves it is pinned (--pin), and with them in place it maps to ({at_x}, {at_y}); pin fewer control points around it, move its target, or fit without --hard")]
    PinnedAway {
        /// `landmark i (name)`.
        landmark: String,
        /// Target x.
        x: f64,
        /// Target y.
        y: f64,
        /// Where the pinned points map the source, x.
        at_x: f64,
        /// Where the pinned points map the source, y.
        at_y: f64,
    },
    /// More hard constraints than the spline's local freedom.
    #[error("too many constraints for the mesh: {detail}; a degree-{degree} triangle takes at most {per_triangle} landmarks in general position (fewer on one line, at most degree + 1 on a segment); use a finer mesh, fewer landmarks, or the soft fit (without --hard)")]
    TooManyConstraints {
        /// Which landmarks (and pinned points) are involved.
        detail: String,
        /// The spline's degree.
        degree: usize,
        /// `(d + 1)(d + 2) / 2`.
        per_triangle: usize,
    },
    /// The fit's large buffers (the sparse factor of many landmarks' system) would exceed
    /// the memory budget ([`crate::memory`]).
    #[error(transparent)]
    Memory(#[from] crate::memory::OverBudget),
    /// An internal invariant failed (a bug, never the input's fault): reported as such,
    /// not as unsolvable constraints.
    #[error("internal error (please report it): {0}")]
    Internal(String),
}

impl FitError {
    /// Whether the fit's options are at fault (not the landmarks, the deformation or the
    /// solver): the variants whose text starts `invalid fit option`.
    pub fn is_option(&self) -> bool {
        matches!(
            self,
            FitError::BendWeight { .. }
                | FitError::LossScale { .. }
                | FitError::BarrierShape { .. }
                | FitError::Sampling { .. }
                | FitError::NoSuchPinned { .. }
                | FitError::AdaptedMesh(_)
        )
    }

    /// Whether no deformation can meet the hard constraints as given (conflicting targets,
    /// more constraints than the spline can hold): the command line exits 2 for these, the
    /// Python bindings raise `UnsolvableError`. Every other error is about the input.
    pub fn is_unsolvable(&self) -> bool {
        matches!(
            self,
            FitError::Conflicting { .. }
                | FitError::TooManyConstraints { .. }
                | FitError::PinnedAway { .. }
        )
    }
}
