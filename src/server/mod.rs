//! `trimorph editor`: a local web editor for manual correction passes (PrisMystic, thesis
//! ch. 17-18; MSc dissertation appendix A), served over HTTP on 127.0.0.1 only.
//!
//! The page (plain HTML/JS/CSS embedded in the binary) draws what the engine computes
//! ([`views`]) and sends edits as JSON; the engine does all the geometry with the 2DSD
//! editing algorithm ([`crate::edit`]): a drag calls `select` once and `update` for each
//! mouse move, each update an exact ECLES update.
//!
//! # API (JSON bodies and answers)
//!
//! | request | body | answer |
//! |---|---|---|
//! | `GET /api/state` | | [`Doc::state`] |
//! | `GET /api/geometry[?full=1]` | | [`views::geometry`] |
//! | `GET /api/image.png` | | the frame (the moving image) |
//! | `GET /api/fixed.png` | | the fixed image of a two-image session ([`doc::Doc::fixed`]) |
//! | `GET /api/jacobian.png` | | det J overlay ([`views::jacobian_png`]) |
//! | `GET /api/warp[?step=8]` | | the live warp's coarse inverse map ([`views::inverse_grid`]) |
//! | `GET /api/warp?forward=1[&step=8]` | | the live warp's coarse forward map ([`views::forward_grid`]) |
//! | `POST /api/pick` | `{x, y, max_dist?}` | `{index, point}` (nearest control point) |
//! | `POST /api/select[?warp=8]` | `{anchors, radius?, mode?}` (`radius` null: all) | selection (with `warp`, xy mode and a frame: the live warp's basis for a translation, [`views::translate_grid`]) |
//! | `POST /api/update[?warp=8]` | `{op: translate, v}` (or `by`) / `{op: rotate, center, angle}` / `{op: scale, center, factor}`: a [`crate::edit::script::Motion`] | geometry (with `warp`: the forward map, [`views::forward_grid`], when a frame is loaded) |
//! | `POST /api/clear` | | state |
//! | `POST /api/undo`, `/api/redo` | | geometry and `undid` / `redid`: what the step was (a step is a drag, a load over the same mesh, a re-fit or a pair change: [`doc::history`]) |
//! | `POST /api/save` | `{path, scene?}` | `{saved, written}` (`written`: a scene's copies of its model and frame) |
//! | `POST /api/stat` | `{path}` | `{exists, same_layout, scene_copies}` (asked before a save or load) |
//! | `POST /api/load` | `{path}` | state |
//! | `POST /api/export` | `{kind: obj / warped, path}` | `{saved}` |
//! | `POST /api/refit` | `{landmarks?, hard?}` (`landmarks`: a file; none: the doc's pairs) | fit summary (with the pairs' `landmarks` list when fitted from them) |
//! | `GET /api/landmarks` | | the pairs ([`doc::Doc::pairs_json`], with the `undo` / `redo` counts) |
//! | `POST /api/landmarks/add` | `{src, dst, name?}` | the pairs, `index` of the new one |
//! | `POST /api/landmarks/move` | `{index, src?, dst?}` | the pairs |
//! | `POST /api/landmarks/delete` | `{index}` | the pairs |
//! | `POST /api/landmarks/active` | `{index, active}` | the pairs (an inactive pair is kept but not fitted) |
//! | `POST /api/landmarks/import` | `{path}` (CSV, BigWarp CSV or JSON) | the pairs |
//! | `POST /api/landmarks/export` | `{path, format: csv / bigwarp / json}` | `{saved}` |
//!
//! The state and every geometry answer (select, update, undo, redo) also carry the det J
//! certificate ([`crate::spline::jacobian`]): `fold_free` (certified), `folding_triangles`,
//! `undecided_triangles`, `det_j_lower_bound`, `det_j_sampled_min`, and in geometry answers
//! `folding_outline` (the deformed corners of each folding triangle, 6 numbers each). A drag
//! re-certifies only the triangles around the points it moved.
//!
//! Errors answer `{"error": message}` with 400 (bad request), 401 (no or wrong session
//! token), 403 (path outside the folder, foreign `Host` or `Origin`), 404, 408 (a body not
//! complete within the read timeout), 413 (body over [`MAX_BODY`] bytes), 415 (body not
//! `application/json`) or 422 (an edit or file the engine refuses; the document is
//! unchanged). A head that HTTP/1.1 cannot parse is answered by hyper itself, 400 (or 431:
//! headers over [`http::MAX_HEAD`] bytes) without a body.
//!
//! # Safety
//!
//! The threat model and the checks are in [`http`]: a per-session token on every `/api/`
//! request (printed in the address, `http://127.0.0.1:P/?token=T`), `Host` and `Origin`
//! limited to this server, JSON bodies only as `application/json`, all checked on the head
//! before any body byte is read. The transport ([`net`]: hyper's HTTP/1.1 on a one-thread
//! tokio runtime) has header, body and write deadlines and a connection cap that clients
//! without the token cannot fill; the handlers run one at a time on the thread that owns
//! the document. Besides, the server binds 127.0.0.1 only, reads at most [`MAX_BODY`]
//! bytes of a request body, serves only the embedded assets, and confines every file path
//! to the folder it was started in ([`paths::confine`]).

pub mod doc;
pub mod http;
pub mod net;
pub mod paths;
pub mod start;
pub mod views;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_answers;
#[cfg(test)]
mod tests_bigwarp;
#[cfg(test)]
mod tests_http;
#[cfg(test)]
mod tests_pairs;

use crate::edit::Mode;
use crate::spline::ControlPoint;
use doc::{Doc, Op};
use serde_json::{json, Value};
use std::time::Instant;

pub use net::{serve_bytes, Server, ACCEPT_POLL};

/// Largest accepted request body (bytes).
pub const MAX_BODY: usize = 1 << 20;

/// The embedded page (the script is five classic scripts sharing one global scope, loaded
/// in this order by `index.html`).
const ASSETS: [(&str, &str, &str); 7] = [
    ("/", "text/html; charset=utf-8", include_str!("assets/index.html")),
    ("/core.js", "text/javascript; charset=utf-8", include_str!("assets/core.js")),
    ("/draw.js", "text/javascript; charset=utf-8", include_str!("assets/draw.js")),
    ("/warp.js", "text/javascript; charset=utf-8", include_str!("assets/warp.js")),
    ("/pairs.js", "text/javascript; charset=utf-8", include_str!("assets/pairs.js")),
    ("/app.js", "text/javascript; charset=utf-8", include_str!("assets/app.js")),
    ("/style.css", "text/css; charset=utf-8", include_str!("assets/style.css")),
];

/// Why a request failed (each maps to one HTTP status).
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// Malformed request (400).
    #[error("bad request: {0}")]
    BadRequest(String),
    /// A path outside the editor's folder (403).
    #[error("forbidden: {0}")]
    Forbidden(String),
    /// Unknown route or missing file (404).
    #[error("not found: {0}")]
    NotFound(String),
    /// Missing or wrong session token (401).
    #[error("unauthorized: {0}")]
    Unauthorized(String),
    /// A request body not sent as `application/json` (415).
    #[error("unsupported media type: {0}")]
    UnsupportedMediaType(String),
    /// The request's body did not arrive within the read timeout (408).
    #[error("the request did not arrive in time")]
    Timeout,
    /// Body too large (413).
    #[error("request body over {MAX_BODY} bytes")]
    TooLarge,
    /// The engine refused (unsolvable edit, bad file; 422). Nothing changed.
    #[error("{0}")]
    Unprocessable(String),
    /// Reading or writing a file failed (500).
    #[error("i/o: {0}")]
    Io(String),
}

impl ServerError {
    /// The HTTP status.
    pub fn status(&self) -> u16 {
        match self {
            ServerError::BadRequest(_) => 400,
            ServerError::Forbidden(_) => 403,
            ServerError::NotFound(_) => 404,
            ServerError::Unauthorized(_) => 401,
            ServerError::UnsupportedMediaType(_) => 415,
            ServerError::Timeout => 408,
            ServerError::TooLarge => 413,
            ServerError::Unprocessable(_) => 422,
            ServerError::Io(_) => 500,
        }
    }
}

/// An answer: status, content type, body.
#[derive(Debug)]
pub struct Reply {
    /// HTTP status.
    pub status: u16,
    /// Content type.
    pub content_type: &'static str,
    /// Body.
    pub body: Vec<u8>,
}

impl Reply {
    fn json(v: &Value) -> Reply {
        Reply { status: 200, content_type: "application/json", body: v.to_string().into_bytes() }
    }
    fn error(e: &ServerError) -> Reply {
        Reply {
            status: e.status(),
            content_type: "application/json",
            body: json!({ "error": e.to_string() }).to_string().into_bytes(),
        }
    }
}

fn field<'a>(b: &'a Value, k: &str) -> Result<&'a Value, ServerError> {
    b.get(k).ok_or_else(|| ServerError::BadRequest(format!("missing `{k}`")))
}
fn num(b: &Value, k: &str) -> Result<f64, ServerError> {
    field(b, k)?
        .as_f64()
        .filter(|v| v.is_finite())
        .ok_or_else(|| ServerError::BadRequest(format!("`{k}` must be a finite number")))
}
fn nums(b: &Value, k: &str) -> Result<Vec<f64>, ServerError> {
    let bad = || ServerError::BadRequest(format!("`{k}` must be an array of finite numbers"));
    field(b, k)?
        .as_array()
        .ok_or_else(bad)?
        .iter()
        .map(|v| v.as_f64().filter(|x| x.is_finite()).ok_or_else(bad))
        .collect()
}
fn pt(b: &Value, k: &str) -> Result<[f64; 2], ServerError> {
    match nums(b, k)?[..] {
        [x, y] => Ok([x, y]),
        _ => Err(ServerError::BadRequest(format!("`{k}` must be 2 numbers [x, y]"))),
    }
}
fn opt_pt(b: &Value, k: &str) -> Result<Option<[f64; 2]>, ServerError> {
    match b.get(k) {
        None | Some(Value::Null) => Ok(None),
        Some(_) => pt(b, k).map(Some),
    }
}
fn index(b: &Value) -> Result<usize, ServerError> {
    field(b, "index")?
        .as_u64()
        .map(|i| i as usize)
        .ok_or_else(|| ServerError::BadRequest("`index` must be an integer >= 0".into()))
}
fn text<'a>(b: &'a Value, k: &str) -> Result<&'a str, ServerError> {
    field(b, k)?.as_str().ok_or_else(|| ServerError::BadRequest(format!("`{k}` must be a string")))
}

/// The positive integer `k=N` of a query (`None` when absent).
fn step_query(query: &str, k: &str) -> Result<Option<u32>, ServerError> {
    query
        .split('&')
        .find_map(|q| q.strip_prefix(k).and_then(|r| r.strip_prefix('=')))
        .map(|v| v.parse::<u32>().ok().filter(|&n| n > 0))
        .map(|v| {
            v.ok_or_else(|| ServerError::BadRequest(format!("`{k}` must be a positive integer")))
        })
        .transpose()
}

/// Handles one request against the document (the HTTP-free core, used by tests too).
pub fn handle(doc: &mut Doc, method: &str, url: &str, body: &[u8]) -> Reply {
    let t0 = Instant::now();
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    if method == "GET" {
        if let Some((_, ct, text)) = ASSETS.iter().find(|(p, _, _)| *p == path) {
            return Reply { status: 200, content_type: ct, body: text.as_bytes().to_vec() };
        }
    }
    let r = route(doc, method, path, query, body);
    match r {
        Ok(Answer::Json(mut v)) => {
            if let Some(o) = v.as_object_mut() {
                o.insert("server_ms".into(), json!(t0.elapsed().as_secs_f64() * 1e3));
            }
            Reply::json(&v)
        }
        Ok(Answer::Text(mut text)) => {
            // A JSON object: `server_ms` goes before its closing brace.
            if text.ends_with('}') {
                text.pop();
                let ms = t0.elapsed().as_secs_f64() * 1e3;
                text.push_str(&format!(
                    "{}\"server_ms\":{ms}}}",
                    if text.len() > 1 { "," } else { "" }
                ));
            }
            Reply { status: 200, content_type: "application/json", body: text.into_bytes() }
        }
        Ok(Answer::Png(bytes)) => Reply { status: 200, content_type: "image/png", body: bytes },
        Err(e) => Reply::error(&e),
    }
}

enum Answer {
    Json(Value),
    /// A JSON object already written as text (the geometry answers).
    Text(String),
    Png(Vec<u8>),
}

/// The entries of the object `extra`, the geometry and the state, as one JSON object.
fn with_geometry(doc: &Doc, extra: Value) -> Answer {
    let mut out = views::JsonObject::new();
    out.extend(&extra);
    views::write_geometry(doc, false, &mut out);
    out.value("state", &doc.state());
    Answer::Text(out.finish())
}

fn route(
    doc: &mut Doc,
    method: &str,
    path: &str,
    query: &str,
    body: &[u8],
) -> Result<Answer, ServerError> {
    use Answer::{Json, Png};
    let parse = || -> Result<Value, ServerError> {
        if body.is_empty() {
            return Ok(json!({}));
        }
        serde_json::from_slice(body).map_err(|e| ServerError::BadRequest(format!("JSON: {e}")))
    };
    match (method, path) {
        ("GET", "/api/state") => Ok(Json(doc.state())),
        ("GET", "/api/geometry") => {
            Ok(Answer::Text(views::geometry(doc, query.split('&').any(|q| q == "full=1"))))
        }
        ("GET", "/api/image.png") => match doc.frame() {
            Some(f) => Ok(Png(f.png.clone())),
            None => Err(ServerError::NotFound("no image is loaded".into())),
        },
        ("GET", "/api/fixed.png") => match doc.fixed() {
            Some(f) => Ok(Png(f.png.clone())),
            None => Err(ServerError::NotFound("no fixed image is loaded".into())),
        },
        ("GET", "/api/warp") => {
            let forward = query.split('&').any(|q| q == "forward=1");
            let step = query
                .split('&')
                .find_map(|q| q.strip_prefix("step="))
                .map(|v| v.parse::<u32>())
                .transpose()
                .map_err(|_| ServerError::BadRequest("`step` must be a positive integer".into()))?
                .unwrap_or(views::WARP_STEP);
            let grid = if forward { views::forward_grid } else { views::inverse_grid };
            grid(doc, step)
                .map(Answer::Text)
                .ok_or_else(|| ServerError::NotFound("no image is loaded".into()))
        }
        ("GET", "/api/jacobian.png") => {
            let (w, h) = match doc.frame() {
                Some(f) => (f.image.width(), f.image.height()),
                None => {
                    let m = doc.spline().mesh();
                    let (mut w, mut h) = (1.0f64, 1.0f64);
                    for v in 0..m.num_vertices() {
                        let p = m.vertex(v);
                        w = w.max(p[0] + 1.0);
                        h = h.max(p[1] + 1.0);
                    }
                    (w.min(4096.0) as u32, h.min(4096.0) as u32)
                }
            };
            views::jacobian_png(doc, w, h).map(Png).map_err(|e| ServerError::Io(e.to_string()))
        }
        ("POST", "/api/pick") => {
            let b = parse()?;
            let p = [num(&b, "x")?, num(&b, "y")?];
            let max = b.get("max_dist").and_then(Value::as_f64).unwrap_or(f64::INFINITY);
            let i = doc.editor().nearest_points(&[p])[0].index();
            let q = doc.spline().point_f64(i);
            if (q[0] - p[0]).hypot(q[1] - p[1]) > max {
                return Ok(Json(json!({ "index": null })));
            }
            Ok(Json(json!({ "index": i, "point": q })))
        }
        ("POST", "/api/select") => {
            let b = parse()?;
            let bad = || ServerError::BadRequest("`anchors` must be an array of indices".into());
            let anchors: Vec<ControlPoint> = field(&b, "anchors")?
                .as_array()
                .ok_or_else(bad)?
                .iter()
                .map(|v| v.as_u64().map(|x| ControlPoint(x as usize)).ok_or_else(bad))
                .collect::<Result<_, _>>()?;
            let radius = match b.get("radius") {
                None | Some(Value::Null) => None,
                Some(v) => Some(v.as_u64().ok_or_else(|| {
                    ServerError::BadRequest("`radius` must be an integer >= 0 or null".into())
                })? as usize),
            };
            let mode: Mode = match b.get("mode").and_then(Value::as_str) {
                Some(m) => m.parse().map_err(ServerError::BadRequest)?,
                None => Mode::Xy,
            };
            let warp = step_query(query, "warp")?;
            let sel = doc.select(&anchors, radius, mode)?;
            let mut answer = with_geometry(doc, sel);
            if let (Some(step), Answer::Text(text)) = (warp, &mut answer) {
                if let Some(grid) = views::translate_grid(doc, step) {
                    text.pop();
                    text.push_str(",\"warp\":");
                    text.push_str(&grid);
                    text.push('}');
                }
            }
            Ok(answer)
        }
        ("POST", "/api/update") => {
            let b = parse()?;
            let op = Op::from_value(&b).map_err(|e| ServerError::BadRequest(e.to_string()))?;
            let warp = step_query(query, "warp")?;
            doc.update(&op)?;
            let mut answer = with_geometry(doc, json!({ "update_ms": doc.last_update_ms }));
            if let (Some(step), Answer::Text(text)) = (warp, &mut answer) {
                if let Some(grid) = views::forward_grid(doc, step) {
                    // Before the closing brace of the geometry object.
                    text.pop();
                    text.push_str(",\"warp\":");
                    text.push_str(&grid);
                    text.push('}');
                }
            }
            Ok(answer)
        }
        ("POST", "/api/clear") => {
            doc.clear_selection();
            Ok(Json(doc.state()))
        }
        ("POST", "/api/undo") => {
            let what = doc.undo()?;
            Ok(with_geometry(doc, json!({ "undid": what })))
        }
        ("POST", "/api/redo") => {
            let what = doc.redo()?;
            Ok(with_geometry(doc, json!({ "redid": what })))
        }
        ("POST", "/api/save") => {
            let b = parse()?;
            let scene = b.get("scene").and_then(Value::as_bool).unwrap_or(false);
            let (p, written) = doc.save(text(&b, "path")?, scene)?;
            Ok(Json(json!({ "saved": p.display().to_string(), "written": written })))
        }
        ("POST", "/api/stat") => {
            let b = parse()?;
            Ok(Json(doc.stat(text(&b, "path")?)?))
        }
        ("POST", "/api/load") => {
            let b = parse()?;
            doc.load(text(&b, "path")?)?;
            Ok(Json(doc.state()))
        }
        ("POST", "/api/export") => {
            let b = parse()?;
            let path = text(&b, "path")?;
            let p = match text(&b, "kind")? {
                "obj" | "model" => doc.export_model(path)?,
                "warped" | "image" => doc.export_warped(path)?,
                other => {
                    return Err(ServerError::BadRequest(format!(
                        "unknown export `{other}` (obj or warped)"
                    )))
                }
            };
            Ok(Json(json!({ "saved": p.display().to_string() })))
        }
        ("POST", "/api/refit") => {
            let b = parse()?;
            let hard = b.get("hard").and_then(Value::as_bool).unwrap_or(false);
            let r = match b.get("landmarks") {
                None | Some(Value::Null) => doc.refit_pairs(hard)?,
                Some(_) => doc.refit(text(&b, "landmarks")?, hard)?,
            };
            Ok(with_geometry(doc, r))
        }
        ("GET", "/api/landmarks") => Ok(Json(doc.pairs_json())),
        ("POST", "/api/landmarks/add") => {
            let b = parse()?;
            let name = match b.get("name") {
                None | Some(Value::Null) => None,
                Some(_) => Some(text(&b, "name")?.to_string()).filter(|n| !n.is_empty()),
            };
            let i = doc.add_pair(name, pt(&b, "src")?, pt(&b, "dst")?)?;
            let mut v = doc.pairs_json();
            v["index"] = json!(i);
            Ok(Json(v))
        }
        ("POST", "/api/landmarks/move") => {
            let b = parse()?;
            doc.move_pair(index(&b)?, opt_pt(&b, "src")?, opt_pt(&b, "dst")?)?;
            Ok(Json(doc.pairs_json()))
        }
        ("POST", "/api/landmarks/delete") => {
            let b = parse()?;
            doc.delete_pair(index(&b)?)?;
            Ok(Json(doc.pairs_json()))
        }
        ("POST", "/api/landmarks/active") => {
            let b = parse()?;
            let active = field(&b, "active")?
                .as_bool()
                .ok_or_else(|| ServerError::BadRequest("`active` must be true or false".into()))?;
            doc.set_active(index(&b)?, active)?;
            Ok(Json(doc.pairs_json()))
        }
        ("POST", "/api/landmarks/import") => {
            let b = parse()?;
            doc.import_pairs(text(&b, "path")?)?;
            Ok(Json(doc.pairs_json()))
        }
        ("POST", "/api/landmarks/export") => {
            let b = parse()?;
            let f = doc::pairs::format_named(text(&b, "format")?)?;
            let p = doc.export_pairs(text(&b, "path")?, f)?;
            Ok(Json(json!({ "saved": p.display().to_string() })))
        }
        (_, p) if p.starts_with("/api/") => {
            Err(ServerError::NotFound(format!("{method} {p} is not part of the API")))
        }
        _ => Err(ServerError::NotFound(format!("{path}: only the embedded page is served"))),
    }
}
