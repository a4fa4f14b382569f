//! The editor's request bodies as typed values ([`serde::Deserialize`]), one per `POST`
//! endpoint with a body in the API table of [`crate::server`].
//!
//! A body is read by [`read_body`]: the project's strict JSON reader first
//! ([`crate::json::parse`]: a key given twice in one object is refused), then the type,
//! through `serde_path_to_error` so that a bad field is named. An empty body is `{}`; a
//! body that is not a JSON object is refused. Every refusal is a 400
//! ([`ServerError::BadRequest`]): `` missing `x` ``, `` `x` must be a finite number ``, ...
//!
//! `POST /api/update`'s body is a drag step, [`crate::edit::script::Motion`] with `f64`
//! numbers ([`super::doc::Op`]), read the same way; its own reader names the bad key.
//!
//! Keys a body does not know are ignored (the page and scripts may send more than an
//! endpoint reads). A known key of the wrong type is refused naming it, optional ones
//! included; `null` stands for an absent optional key. Before the bodies were typed they
//! were read with plain `serde_json` into a `Value`: a repeated key then kept its last
//! value, and an optional `max_dist`, `scene`, `hard` or `mode` of another type was taken
//! as absent; both are 400s now.

use super::ServerError;
use crate::edit::Mode;
use crate::spline::ControlPoint;
use serde::de::{DeserializeOwned, Error as _};
use serde::{Deserialize, Deserializer};
use serde_json::Value;

/// Reads a request body as `T` (see the module docs).
pub fn read_body<T: DeserializeOwned>(body: &[u8]) -> Result<T, ServerError> {
    let bad = |e: &dyn std::fmt::Display| ServerError::BadRequest(format!("JSON: {e}"));
    let text = std::str::from_utf8(body).map_err(|e| bad(&e))?;
    // The strict reader checks the keys as it builds a `Value` (the body is any JSON
    // text until then); the type is read from that value, its path naming a bad field.
    let v = if text.is_empty() {
        serde_json::json!({})
    } else {
        crate::json::parse(text).map_err(|e| bad(&e))?
    };
    if !v.is_object() {
        return Err(ServerError::BadRequest("the body must be a JSON object".into()));
    }
    serde_path_to_error::deserialize(&v).map_err(|e| {
        let message = e.inner().to_string();
        let path = e.path().to_string();
        let root = e.path().iter().next().is_none();
        ServerError::BadRequest(
            match message.strip_prefix("missing field `").and_then(|m| m.strip_suffix('`')) {
                Some(field) if root => format!("missing `{field}`"),
                Some(field) => format!("missing `{path}.{field}`"),
                None if root => message,
                None if message.starts_with("must be") => format!("`{path}` {message}"),
                None => format!("`{path}`: {message}"),
            },
        )
    })
}

/// `POST /api/pick`: the control point nearest to `(x, y)`, if within `max_dist`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Pick {
    /// x (pixels).
    #[serde(deserialize_with = "finite")]
    pub x: f64,
    /// y (pixels).
    #[serde(deserialize_with = "finite")]
    pub y: f64,
    /// Farthest accepted distance (pixels; absent: any).
    #[serde(default, deserialize_with = "opt_number")]
    pub max_dist: Option<f64>,
}

/// `POST /api/select`: 2DSD.Select.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Select {
    /// The anchors (point indices).
    #[serde(deserialize_with = "anchors")]
    pub anchors: Vec<ControlPoint>,
    /// The neighbourhood radius on the control net (`null` or absent: all points).
    #[serde(default, deserialize_with = "radius")]
    pub radius: Option<usize>,
    /// `xy` (absent or `null`), `z0` or `z1`.
    #[serde(default, deserialize_with = "mode")]
    pub mode: Mode,
}

/// `POST /api/save`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Save {
    /// The file, inside the editor's folder.
    #[serde(deserialize_with = "text")]
    pub path: String,
    /// Save a scene (the model, frame, fixed image and pairs too; absent: no).
    #[serde(default, deserialize_with = "opt_flag")]
    pub scene: bool,
}

/// A body naming one file inside the editor's folder: `POST /api/stat`, `/api/load`,
/// `/api/landmarks/import`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct PathBody {
    /// The file.
    #[serde(deserialize_with = "text")]
    pub path: String,
}

/// What `POST /api/export` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportKind {
    /// The deformed model (`obj`, or `model`).
    Model,
    /// The frame warped by phi (`warped`, or `image`).
    Warped,
}

/// `POST /api/export`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Export {
    /// `obj` (or `model`) or `warped` (or `image`).
    #[serde(deserialize_with = "export_kind")]
    pub kind: ExportKind,
    /// The file, inside the editor's folder.
    #[serde(deserialize_with = "text")]
    pub path: String,
}

/// `POST /api/refit`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Refit {
    /// A landmark file inside the editor's folder (absent or `null`: the document's
    /// active pairs).
    #[serde(default, deserialize_with = "opt_text")]
    pub landmarks: Option<String>,
    /// Make the landmarks exact too (absent: no).
    #[serde(default, deserialize_with = "opt_flag")]
    pub hard: bool,
}

/// `POST /api/register`: register the moving image to the fixed one again, starting from
/// the current deformation, the pinned points kept.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Register {
    /// `ncc`, `ssd` or `mi` (absent or `null`: `ncc`).
    #[serde(default, deserialize_with = "opt_metric")]
    pub metric: Option<crate::register::Metric>,
    /// Solver iterations per pyramid level (absent or `null`: the command line's default).
    #[serde(default, deserialize_with = "opt_count")]
    pub iterations: Option<u64>,
    /// Add the document's active landmark pairs to the image term (absent: no).
    #[serde(default, deserialize_with = "opt_flag")]
    pub pairs: bool,
    /// With `pairs`, meet them exactly (absent: no).
    #[serde(default, deserialize_with = "opt_flag")]
    pub hard: bool,
}

/// `POST /api/landmarks/add`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct AddPair {
    /// The point in the reference (the moving image).
    #[serde(deserialize_with = "point")]
    pub src: [f64; 2],
    /// The point in the target (the fixed image).
    #[serde(deserialize_with = "point")]
    pub dst: [f64; 2],
    /// Its name (absent, `null` or empty: `P<k>`).
    #[serde(default, deserialize_with = "opt_text")]
    pub name: Option<String>,
}

/// `POST /api/landmarks/move`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct MovePair {
    /// The pair (0-based).
    #[serde(deserialize_with = "index")]
    pub index: usize,
    /// Its new `src` (absent or `null`: unchanged).
    #[serde(default, deserialize_with = "opt_point")]
    pub src: Option<[f64; 2]>,
    /// Its new `dst` (absent or `null`: unchanged).
    #[serde(default, deserialize_with = "opt_point")]
    pub dst: Option<[f64; 2]>,
}

/// `POST /api/landmarks/delete`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct PairIndex {
    /// The pair (0-based).
    #[serde(deserialize_with = "index")]
    pub index: usize,
}

/// `POST /api/landmarks/active`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct SetActive {
    /// The pair (0-based).
    #[serde(deserialize_with = "index")]
    pub index: usize,
    /// Whether it is fitted.
    #[serde(deserialize_with = "flag")]
    pub active: bool,
}

/// `POST /api/landmarks/export`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct ExportPairs {
    /// The file, inside the editor's folder.
    #[serde(deserialize_with = "text")]
    pub path: String,
    /// `csv`, `bigwarp` or `json` (checked by [`super::doc::pairs::format_named`]).
    #[serde(deserialize_with = "text")]
    pub format: String,
}

// The fields' readers. Each maps a wrong value to "must be ..." (the key is added from
// the `serde_path_to_error` path: "`x` must be a finite number").

fn must<E: serde::de::Error>(what: &str) -> impl Fn(E) -> E + '_ {
    move |_| E::custom(format_args!("must be {what}"))
}

fn finite<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    f64::deserialize(d)
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| D::Error::custom("must be a finite number"))
}

fn opt_number<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    Option::<f64>::deserialize(d).map_err(must("a number or null"))
}

// An array field is read as a `Value` first, then checked: read element by element, its
// error would name the element (`src[1]`) with the array's message.
fn point<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    let bad = || D::Error::custom("must be an array of finite numbers");
    let v = Value::deserialize(d)?;
    let v: Vec<f64> = v
        .as_array()
        .ok_or_else(bad)?
        .iter()
        .map(|x| x.as_f64().filter(|x| x.is_finite()).ok_or_else(bad))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y] => Ok([x, y]),
        _ => Err(D::Error::custom("must be 2 numbers [x, y]")),
    }
}

fn opt_point<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
    #[derive(Deserialize)]
    struct P(#[serde(deserialize_with = "point")] [f64; 2]);
    Option::<P>::deserialize(d).map(|p| p.map(|p| p.0))
}

fn index<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    usize::deserialize(d).map_err(must("an integer >= 0"))
}

fn anchors<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<ControlPoint>, D::Error> {
    let bad = || D::Error::custom("must be an array of indices");
    let v = Value::deserialize(d)?;
    let v = v.as_array().ok_or_else(bad)?;
    v.iter().map(|x| x.as_u64().map(|i| ControlPoint(i as usize)).ok_or_else(bad)).collect()
}

fn radius<'de, D: Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
    Option::<usize>::deserialize(d).map_err(must("an integer >= 0 or null"))
}

fn mode<'de, D: Deserializer<'de>>(d: D) -> Result<Mode, D::Error> {
    match Option::<String>::deserialize(d).map_err(must("xy, z0 or z1"))? {
        Some(m) => m.parse().map_err(D::Error::custom),
        None => Ok(Mode::Xy),
    }
}

fn text<'de, D: Deserializer<'de>>(d: D) -> Result<String, D::Error> {
    String::deserialize(d).map_err(must("a string"))
}

fn opt_text<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    Option::<String>::deserialize(d).map_err(must("a string or null"))
}

fn flag<'de, D: Deserializer<'de>>(d: D) -> Result<bool, D::Error> {
    bool::deserialize(d).map_err(must("true or false"))
}

fn opt_flag<'de, D: Deserializer<'de>>(d: D) -> Result<bool, D::Error> {
    Ok(Option::<bool>::deserialize(d).map_err(must("true, false or null"))?.unwrap_or(false))
}

fn opt_metric<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<Option<crate::register::Metric>, D::Error> {
    match opt_text(d)? {
        None => Ok(None),
        Some(t) => t.parse().map(Some).map_err(D::Error::custom),
    }
}

fn opt_count<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u64>, D::Error> {
    Option::<u64>::deserialize(d).map_err(must("an integer >= 0 or null"))
}

fn export_kind<'de, D: Deserializer<'de>>(d: D) -> Result<ExportKind, D::Error> {
    match text(d)?.as_str() {
        "obj" | "model" => Ok(ExportKind::Model),
        "warped" | "image" => Ok(ExportKind::Warped),
        other => Err(D::Error::custom(format_args!("unknown export `{other}` (obj or warped)"))),
    }
}
