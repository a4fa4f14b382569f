//! The fit's options and their defaults: the one place every default and limit of a fit is
//! spelled. The command line (`cli::fit_args`), the Python bindings and the morph take their
//! defaults from the constants here.

use super::objective::{Barrier, Loss};
use crate::spline::ControlPoint;

/// Default floor of the fold barrier: `det J` is kept above it at the samples (`--min-det`).
pub const DEFAULT_MIN_DET: f64 = 0.1;

/// Default threshold of the fold barrier: it acts on samples with `det J` below this (the
/// floor plus the barrier's band, [`Barrier::BAND`]).
pub const DEFAULT_BARRIER_TAU: f64 = DEFAULT_MIN_DET + Barrier::BAND;

/// Default iteration cap of the barrier's Newton method (`--max-iters`).
pub const DEFAULT_MAX_ITERS: u64 = 200;

/// Default scale of the robust losses, Huber and Cauchy (pixels; `--loss-scale`).
pub const DEFAULT_LOSS_SCALE: f64 = 2.0;

/// Default rounding grid of the exact result: control points move at most `2^-20` px.
pub const DEFAULT_GRID_BITS: u32 = 20;

/// The fold barrier every fit uses unless told otherwise: floor [`DEFAULT_MIN_DET`],
/// threshold [`DEFAULT_BARRIER_TAU`], weight 1.
pub const DEFAULT_BARRIER: Barrier =
    Barrier { floor: DEFAULT_MIN_DET, tau: DEFAULT_BARRIER_TAU, mu: 1.0 };

/// Largest accepted landmark coordinate and weight magnitude: beyond it the fit's exact and
/// floating-point arithmetic stops being meaningful (and a hard fit would grow huge
/// rationals).
pub const MAX_LANDMARK_VALUE: f64 = 1e9;

/// The most variable control points a soft fit takes (a bound on its memory: the landmark
/// space solver stores `nv x k` numbers, the Newton step a sparse factor).
pub const MAX_FIT_VARIABLES: usize = 32_768;

/// Options of [`super::fit`].
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// Data loss (default squares).
    pub loss: Loss,
    /// The scale-free bending weight (default [`Bend::Auto`]; see [`super::smooth`]).
    pub bend: Bend,
    /// Fold barrier; `None` turns it off (default [`DEFAULT_BARRIER`]).
    pub barrier: Option<Barrier>,
    /// Variables: free points within this many control-net steps of the landmarks'
    /// triangles (`None`: every free point; default).
    pub radius: Option<usize>,
    /// Iteration cap of the barrier's Newton method (default [`DEFAULT_MAX_ITERS`]).
    pub max_iters: u64,
    /// Landmarks become hard constraints `phi(s_i) = t_i` ([`super::hard`]).
    pub hard: bool,
    /// Rounding to exact values moves no control point by more than `2^-grid_bits` px
    /// (default [`DEFAULT_GRID_BITS`]): the free points are rounded to multiples of `2^-grid_bits`, or of a
    /// finer power of two where the mesh amplifies a rounding
    /// ([`crate::spline::mds::rounding_bits`]; the report's `rounding_bits`).
    pub grid_bits: u32,
    /// Barycentric sample level of `det J` in the barrier (default
    /// [`crate::spline::jacobian::SAMPLE_LEVEL`], 8: 45 samples per triangle, the sample set
    /// every command reports).
    pub det_level: usize,
    /// Control points pinned at their values in the input spline (e.g. points corrected
    /// by hand in the editor). They are held exactly: the soft fit does not vary them and
    /// an ECLES update ([`super::hard`]) makes the result exactly C1 with every pinned point
    /// at its input value (default: none).
    pub pinned: Vec<ControlPoint>,
    /// Hold the spline's border fixed: no free point that a control point of a border edge
    /// depends on varies, so `phi` on the border stays as in the warm start (default false;
    /// the landmark-adapted fit sets it, see [`super::frame`]).
    pub pin_border: bool,
    /// The area `|Omega|` (square pixels) in `lambda = bend * sum w * |Omega|`, so that a
    /// weight means the same whatever lies far outside the landmarks (`None`: the mesh's
    /// area; [`super::frame`] sets the frame grown by its margin, leaving out the far-field
    /// rings).
    pub bend_area: Option<f64>,
    /// Stops the fit between Newton iterations when set ([`FitError::Cancelled`]; default:
    /// never).
    pub cancel: crate::cancel::Cancel,
}

/// The bending weight of a fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bend {
    /// Chosen by leave-one-out cross-validation on the landmarks ([`super::smooth`]).
    Auto,
    /// This scale-free weight (`lambda = bend * sum w * |Omega|`).
    Weight(f64),
}

impl std::str::FromStr for Bend {
    type Err = BendError;
    /// `auto` or a finite weight `>= 0` (surrounding spaces ignored).
    fn from_str(t: &str) -> Result<Bend, BendError> {
        match t.trim() {
            "auto" => Ok(Bend::Auto),
            t => match t.parse::<f64>() {
                Ok(w) if w.is_finite() && w >= 0.0 => Ok(Bend::Weight(w)),
                _ => Err(BendError(t.to_string())),
            },
        }
    }
}

/// A bending weight that is neither `auto` nor a finite number `>= 0` (the text given,
/// trimmed).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is neither `auto` nor a finite number >= 0")]
pub struct BendError(pub String);

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            loss: Loss::Squares,
            bend: Bend::Auto,
            barrier: Some(DEFAULT_BARRIER),
            radius: None,
            max_iters: DEFAULT_MAX_ITERS,
            hard: false,
            grid_bits: DEFAULT_GRID_BITS,
            det_level: crate::spline::jacobian::SAMPLE_LEVEL,
            pinned: Vec::new(),
            pin_border: false,
            bend_area: None,
            cancel: crate::cancel::Cancel::never(),
        }
    }
}
