//! The editor's answers as typed values ([`serde::Serialize`]), one per kind of answer in
//! the API table of [`crate::server`].
//!
//! The wire format is a contract with the page (and with scripts driving the editor): each
//! answer is a JSON object whose keys are written in the order its fields are declared
//! here, `null` where a value is missing (`"model": null`), a key left out only where this
//! says so, and numbers written as `serde_json` writes them (an `f64` shortest round-trip,
//! `null` when not finite). That order is the one the editor wrote before its answers were
//! typed (the `serde_json::Value` maps it built kept their keys in insertion order: the
//! `zarr` feature's `zarrs` turns on `serde_json`'s `preserve_order`, and every build with
//! the command line has it); it no longer depends on the features. A test pins each
//! answer's keys (`keys_are_written_in_the_documented_order`) and a golden session
//! (`tests/golden/editor_answers.txt`) the bytes of a whole session.
//!
//! Every answer but an error also gets `server_ms` (the handler's time), as its last key. A
//! geometry answer is written as text ([`super::views::JsonObject`]): the answer's own
//! keys, the geometry's, then `state`.

use crate::fit::report::FitMethod;
use crate::spline::jacobian::DetJ;
use crate::spline::ControlPoint;

/// An error answer: `{"error": message}` (the status says which kind, [`super::ServerError`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ErrorAnswer {
    /// What went wrong.
    pub error: String,
}

/// An image of the document (`frame`, `fixed` in [`State`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ImageInfo {
    /// Its file (relative to the editor's folder when it was loaded from there).
    pub path: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// The current selection in [`State`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StateSelection {
    /// The anchors.
    pub anchors: Vec<ControlPoint>,
    /// The derived points.
    pub derived: Vec<ControlPoint>,
    /// Whether strong solvability holds.
    pub strong: bool,
    /// `xy`, `z0` or `z1`.
    pub mode: &'static str,
}

/// The document's summary (`GET /api/state`, `POST /api/clear`, `POST /api/load`, and
/// `state` in every geometry answer; [`super::doc::Doc::state`]), the det J certificate's
/// keys last.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct State {
    /// The document's name (its file; `null`: not saved or loaded yet).
    pub name: Option<String>,
    /// Polynomial degree of the spline.
    pub degree: usize,
    /// Number of control points.
    pub points: usize,
    /// Number of mesh triangles.
    pub triangles: usize,
    /// Whether the spline has z layers (2.5D: the z modes can be edited).
    pub z_modes: bool,
    /// The bound model's file (`null`: none).
    pub model: Option<String>,
    /// The frame (the moving image; `null`: none).
    pub frame: Option<ImageInfo>,
    /// The fixed image of a two-image session (`null`: none).
    pub fixed: Option<ImageInfo>,
    /// Undo steps held.
    pub undo: usize,
    /// Redo steps held.
    pub redo: usize,
    /// What the next undo would take back (`null`: nothing).
    pub undo_next: Option<String>,
    /// What the next redo would do again (`null`: nothing).
    pub redo_next: Option<String>,
    /// The points corrected by hand.
    pub pinned: Vec<ControlPoint>,
    /// The current selection (`null`: none).
    pub selection: Option<StateSelection>,
    /// Milliseconds of the last exact update.
    pub last_update_ms: f64,
    /// The det J certificate (its keys are the state's).
    #[serde(flatten)]
    pub det_j: Certificate,
}

/// The det J certificate's keys ([`crate::spline::jacobian`]), in [`State`] and in every
/// geometry answer.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Certificate {
    /// det J > 0 is certified on every triangle.
    pub fold_free: bool,
    /// Triangles with a proven fold.
    pub folding_triangles: Vec<usize>,
    /// Triangles neither certified nor proven to fold.
    pub undecided_triangles: Vec<usize>,
    /// A certified lower bound of det J over the mesh.
    pub det_j_lower_bound: f64,
    /// The smallest sampled det J.
    pub det_j_sampled_min: f64,
}

impl From<&DetJ> for Certificate {
    fn from(c: &DetJ) -> Certificate {
        Certificate {
            fold_free: c.fold_free,
            folding_triangles: c.folding.clone(),
            undecided_triangles: c.undecided.clone(),
            det_j_lower_bound: c.lower_bound,
            det_j_sampled_min: c.sampled_min,
        }
    }
}

/// The selection of a geometry answer (`selection` in [`super::views::geometry`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GeometrySelection {
    /// The anchors.
    pub anchors: Vec<ControlPoint>,
    /// The derived points.
    pub derived: Vec<ControlPoint>,
    /// The relevant non-redundant constraints (indices into the quadrilaterals).
    pub constraints: Vec<usize>,
}

/// What `POST /api/select` made ([`super::doc::Doc::select`]); the answer is these keys,
/// then the geometry's and the state.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Selected {
    /// The anchors.
    pub anchors: Vec<ControlPoint>,
    /// The derived points.
    pub derived: Vec<ControlPoint>,
    /// RelMagnitude of each derived point.
    pub theta: Vec<f64>,
    /// Whether strong solvability holds.
    pub strong: bool,
    /// Number of relevant conditions.
    pub relevant: usize,
    /// Rank of the relevant conditions.
    pub rank: usize,
    /// How the edit is solved: `determining_set`, `modular` or `sessions`.
    pub solver: &'static str,
}

/// The nearest control point (`POST /api/pick`): `{"index": null}` (no key `point`) when
/// it is farther than `max_dist`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Picked {
    /// The point's index (`null`: none within `max_dist`).
    pub index: Option<usize>,
    /// Its position (left out with `index: null`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point: Option<[f64; 2]>,
}

/// The time of a drag step (`POST /api/update`; then the geometry's keys and the state).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Updated {
    /// Milliseconds of the exact update.
    pub update_ms: f64,
}

/// What an undo took back (`POST /api/undo`; then the geometry's keys and the state).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Undid {
    /// The step, in words.
    pub undid: String,
}

/// What a redo did again (`POST /api/redo`; then the geometry's keys and the state).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Redid {
    /// The step, in words.
    pub redid: String,
}

/// A file written (`POST /api/export`, `POST /api/landmarks/export`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Saved {
    /// The file.
    pub saved: String,
}

/// A save (`POST /api/save`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SavedScene {
    /// The file.
    pub saved: String,
    /// The copies a scene save wrote beside it (its model and frame; paths relative to the
    /// editor's folder).
    pub written: Vec<String>,
}

/// What the page asks before a save or a load (`POST /api/stat`,
/// [`super::doc::Doc::stat`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Stat {
    /// Whether the file exists.
    pub exists: bool,
    /// Whether it is a deformation over the same mesh (`null`: not readable as one).
    pub same_layout: Option<bool>,
    /// Files a scene save would write besides, that exist already.
    pub scene_copies: Vec<String>,
}

/// A re-fit's summary (`POST /api/refit`, [`super::doc::Doc::refit`]; then the geometry's
/// keys and the state).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Refitted {
    /// How the fit solved ([`FitMethod`]).
    pub method: FitMethod,
    /// Root mean square landmark residual (pixels).
    pub rms: f64,
    /// Largest landmark residual (pixels).
    pub max: f64,
    /// Control points held exactly (corrected by hand).
    pub pinned: usize,
    /// Smallest sampled det J of the result.
    pub min_det_j: f64,
    /// The pairs after the fit, when it was fitted to the document's pairs (left out when
    /// fitted to a file).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub landmarks: Option<Pairs>,
}

/// `POST /api/register`'s answer (beside the geometry).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Registered {
    /// The metric's name.
    pub metric: crate::register::Metric,
    /// The metric of the deformation the registration started from.
    pub metric_before: f64,
    /// The metric after.
    pub metric_after: f64,
    /// Certified `det J > 0` everywhere.
    pub fold_free: bool,
    /// The certified lower bound of `det J`.
    pub det_j_lower_bound: f64,
    /// Control points held exactly (pinned in the editor).
    pub pinned: usize,
    /// Landmark pairs in the image term (0: none).
    pub pairs: usize,
    /// Solver iterations over every level.
    pub iterations: u64,
    /// Wall time (ms).
    pub time_ms: f64,
}

/// One landmark pair in [`Pairs`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PairRow {
    /// Its name.
    pub name: Option<String>,
    /// Its point in the reference (the moving image).
    pub src: [f64; 2],
    /// Its point in the target (the fixed image).
    pub dst: [f64; 2],
    /// Its weight.
    pub weight: f64,
    /// Whether it is fitted.
    pub active: bool,
    /// `phi(src)` (`null`: `src` outside the mesh).
    pub mapped: Option<[f64; 2]>,
    /// `|phi(src) - dst|` in pixels (`null`: `src` outside the mesh).
    pub residual: Option<f64>,
}

/// The landmark pairs (`GET /api/landmarks` and every `POST /api/landmarks/...` but
/// export; [`super::doc::Doc::pairs_json`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Pairs {
    /// The pairs, in order.
    pub pairs: Vec<PairRow>,
    /// Root mean square residual of the active pairs (`null`: none has one).
    pub rms: Option<f64>,
    /// Largest residual of the active pairs (`null`: none has one).
    pub max: Option<f64>,
    /// Undo steps held.
    pub undo: usize,
    /// Redo steps held.
    pub redo: usize,
    /// The new pair's index (`POST /api/landmarks/add` only; left out otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub index: Option<usize>,
}
