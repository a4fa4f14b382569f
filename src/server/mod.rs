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
//! Each body is a typed value of [`requests`], read by [`requests::read_body`] through the
//! strict JSON reader (a key given twice is refused; unknown keys are ignored; a bad or
//! missing field is a 400 naming it). Each answer is a typed value of [`answers`], its keys
//! written in the order its fields are declared, then `server_ms` (the handler's time; not
//! in error answers). A geometry answer (select, update, undo, redo, refit) is its own
//! keys, then the geometry's ([`views::geometry`]), then `state` ([`answers::State`]),
//! then `server_ms`.
//!
//! | request | body | answer |
//! |---|---|---|
//! | `GET /api/state` | | [`answers::State`] ([`Doc::state`]) |
//! | `GET /api/geometry[?full=1]` | | [`views::geometry`] |
//! | `GET /api/image.png` | | the frame (the moving image) |
//! | `GET /api/fixed.png` | | the fixed image of a two-image session ([`doc::Doc::fixed`]) |
//! | `GET /api/jacobian.png` | | det J overlay ([`views::jacobian_png`]) |
//! | `GET /api/warp[?step=8]` | | the live warp's coarse inverse map ([`views::inverse_grid`]) |
//! | `GET /api/warp?forward=1[&step=8]` | | the live warp's coarse forward map ([`views::forward_grid`]) |
//! | `POST /api/pick` | [`requests::Pick`] `{x, y, max_dist?}` | [`answers::Picked`] `{index, point}` (nearest control point) |
//! | `POST /api/select[?warp=8]` | [`requests::Select`] `{anchors, radius?, mode?}` (`radius` null: all) | [`answers::Selected`] and geometry (with `warp`, xy mode and a frame: the live warp's basis for a translation, [`views::translate_grid`]) |
//! | `POST /api/update[?warp=8]` | `{op: translate, v}` (or `by`) / `{op: rotate, center, angle}` / `{op: scale, center, factor}`: a [`crate::edit::script::Motion`] ([`doc::Op`]) | [`answers::Updated`] `{update_ms}` and geometry (with `warp`: the forward map, [`views::forward_grid`], when a frame is loaded) |
//! | `POST /api/clear` | | [`answers::State`] |
//! | `POST /api/undo`, `/api/redo` | | [`answers::Undid`] `{undid}` / [`answers::Redid`] `{redid}` and geometry: what the step was (a step is a drag, a load over the same mesh, a re-fit or a pair change: [`doc::history`]) |
//! | `POST /api/save` | [`requests::Save`] `{path, scene?}` | [`answers::SavedScene`] `{saved, written}` (`written`: a scene's copies of its model and frame) |
//! | `POST /api/stat` | [`requests::PathBody`] `{path}` | [`answers::Stat`] `{exists, same_layout, scene_copies}` (asked before a save or load) |
//! | `POST /api/load` | [`requests::PathBody`] `{path}` | [`answers::State`] |
//! | `POST /api/export` | [`requests::Export`] `{kind: obj / warped, path}` | [`answers::Saved`] `{saved}` |
//! | `POST /api/refit` | [`requests::Refit`] `{landmarks?, hard?}` (`landmarks`: a file; none: the doc's pairs) | [`answers::Refitted`] (fit summary, with the pairs' `landmarks` list when fitted from them) and geometry |
//! | `POST /api/register` | [`requests::Register`] `{metric?, iterations?, pairs?, hard?}` | [`answers::Registered`] and geometry: the moving image registered to the fixed one again from the current deformation, the pinned points kept ([`doc::register`]; a two-image session only) |
//! | `GET /api/landmarks` | | [`answers::Pairs`] ([`doc::Doc::pairs_json`], with the `undo` / `redo` counts) |
//! | `POST /api/landmarks/add` | [`requests::AddPair`] `{src, dst, name?}` | [`answers::Pairs`], `index` of the new one |
//! | `POST /api/landmarks/move` | [`requests::MovePair`] `{index, src?, dst?}` | [`answers::Pairs`] |
//! | `POST /api/landmarks/delete` | [`requests::PairIndex`] `{index}` | [`answers::Pairs`] |
//! | `POST /api/landmarks/active` | [`requests::SetActive`] `{index, active}` | [`answers::Pairs`] (an inactive pair is kept but not fitted) |
//! | `POST /api/landmarks/import` | [`requests::PathBody`] `{path}` (CSV, BigWarp CSV or JSON) | [`answers::Pairs`] |
//! | `POST /api/landmarks/export` | [`requests::ExportPairs`] `{path, format: csv / bigwarp / json}` | [`answers::Saved`] `{saved}` |
//!
//! The state and every geometry answer (select, update, undo, redo) also carry the det J
//! certificate ([`crate::spline::jacobian`]): `fold_free` (certified), `folding_triangles`,
//! `undecided_triangles`, `det_j_lower_bound`, `det_j_sampled_min`, and in geometry answers
//! `folding_outline` (the deformed corners of each folding triangle, 6 numbers each). A drag
//! re-certifies only the triangles around the points it moved.
//!
//! Errors answer `{"error": message}` ([`answers::ErrorAnswer`]) with 400 (bad request), 401 (no or wrong session
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

pub mod answers;
pub mod doc;
pub mod http;
pub mod net;
pub mod paths;
pub mod requests;
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
#[cfg(test)]
mod tests_register;

use doc::{Doc, Op};
use requests::read_body;
use serde::Serialize;
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
    /// A JSON answer (the gate's tests answer with it).
    #[cfg(test)]
    fn json<T: Serialize + ?Sized>(v: &T) -> Reply {
        match serde_json::to_vec(v) {
            Ok(body) => Reply { status: 200, content_type: "application/json", body },
            Err(e) => Reply::error(&ServerError::Io(format!("writing the answer: {e}"))),
        }
    }
    fn error(e: &ServerError) -> Reply {
        let answer = answers::ErrorAnswer { error: e.to_string() };
        Reply {
            status: e.status(),
            content_type: "application/json",
            // A struct of one string: serde_json cannot fail to write it.
            body: serde_json::to_vec(&answer).unwrap_or_default(),
        }
    }
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
        Ok(Answer::Json(mut text)) => {
            // A typed answer's object: `server_ms` last, written as serde_json writes it.
            let ms = serde_json::to_string(&(t0.elapsed().as_secs_f64() * 1e3));
            if let (Some(b'}'), Ok(ms)) = (text.as_bytes().last(), ms) {
                text.pop();
                let comma = if text.len() > 1 { "," } else { "" };
                text.push_str(&format!("{comma}\"server_ms\":{ms}}}"));
            }
            Reply { status: 200, content_type: "application/json", body: text.into_bytes() }
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
    /// A typed answer ([`answers`]) written as a JSON object.
    Json(String),
    /// A JSON object already written as text (the geometry answers).
    Text(String),
    Png(Vec<u8>),
}

/// A typed answer ([`answers`]) as JSON text (a 500 if serde_json cannot write it, which
/// none of them gives it reason to).
fn json<T: Serialize>(v: T) -> Result<Answer, ServerError> {
    serde_json::to_string(&v)
        .map(Answer::Json)
        .map_err(|e| ServerError::Io(format!("writing the answer: {e}")))
}

/// The entries of the object `extra` (a typed answer), the geometry and the state, as one
/// JSON object.
fn with_geometry<T: Serialize>(doc: &Doc, extra: &T) -> Answer {
    let mut out = views::JsonObject::new();
    out.extend(extra);
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
    use Answer::Png;
    match (method, path) {
        ("GET", "/api/state") => json(doc.state()),
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
            let b: requests::Pick = read_body(body)?;
            let p = [b.x, b.y];
            let max = b.max_dist.unwrap_or(f64::INFINITY);
            let i = doc.editor().nearest_points(&[p])[0].index();
            let q = doc.spline().point_f64(i);
            if (q[0] - p[0]).hypot(q[1] - p[1]) > max {
                return json(answers::Picked { index: None, point: None });
            }
            json(answers::Picked { index: Some(i), point: Some(q) })
        }
        ("POST", "/api/select") => {
            let b: requests::Select = read_body(body)?;
            let warp = step_query(query, "warp")?;
            let sel = doc.select(&b.anchors, b.radius, b.mode)?;
            let mut answer = with_geometry(doc, &sel);
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
            // A drag step is an edit-script motion; its reader names the bad key.
            let op: Op = read_body(body)?;
            let warp = step_query(query, "warp")?;
            doc.update(&op)?;
            let mut answer =
                with_geometry(doc, &answers::Updated { update_ms: doc.last_update_ms });
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
            json(doc.state())
        }
        ("POST", "/api/undo") => {
            let undid = doc.undo()?;
            Ok(with_geometry(doc, &answers::Undid { undid }))
        }
        ("POST", "/api/redo") => {
            let redid = doc.redo()?;
            Ok(with_geometry(doc, &answers::Redid { redid }))
        }
        ("POST", "/api/save") => {
            let b: requests::Save = read_body(body)?;
            let (p, written) = doc.save(&b.path, b.scene)?;
            json(answers::SavedScene { saved: p.display().to_string(), written })
        }
        ("POST", "/api/stat") => {
            let b: requests::PathBody = read_body(body)?;
            json(doc.stat(&b.path)?)
        }
        ("POST", "/api/load") => {
            let b: requests::PathBody = read_body(body)?;
            doc.load(&b.path)?;
            json(doc.state())
        }
        ("POST", "/api/export") => {
            let b: requests::Export = read_body(body)?;
            let p = match b.kind {
                requests::ExportKind::Model => doc.export_model(&b.path)?,
                requests::ExportKind::Warped => doc.export_warped(&b.path)?,
            };
            json(answers::Saved { saved: p.display().to_string() })
        }
        ("POST", "/api/refit") => {
            let b: requests::Refit = read_body(body)?;
            let r = match &b.landmarks {
                None => doc.refit_pairs(b.hard)?,
                Some(file) => doc.refit(file, b.hard)?,
            };
            Ok(with_geometry(doc, &r))
        }
        ("POST", "/api/register") => {
            let b: requests::Register = read_body(body)?;
            let r = doc.reregister(&b)?;
            Ok(with_geometry(doc, &r))
        }
        ("GET", "/api/landmarks") => json(doc.pairs_json()),
        ("POST", "/api/landmarks/add") => {
            let b: requests::AddPair = read_body(body)?;
            let name = b.name.filter(|n| !n.is_empty());
            let i = doc.add_pair(name, b.src, b.dst)?;
            json(answers::Pairs { index: Some(i), ..doc.pairs_json() })
        }
        ("POST", "/api/landmarks/move") => {
            let b: requests::MovePair = read_body(body)?;
            doc.move_pair(b.index, b.src, b.dst)?;
            json(doc.pairs_json())
        }
        ("POST", "/api/landmarks/delete") => {
            let b: requests::PairIndex = read_body(body)?;
            doc.delete_pair(b.index)?;
            json(doc.pairs_json())
        }
        ("POST", "/api/landmarks/active") => {
            let b: requests::SetActive = read_body(body)?;
            doc.set_active(b.index, b.active)?;
            json(doc.pairs_json())
        }
        ("POST", "/api/landmarks/import") => {
            let b: requests::PathBody = read_body(body)?;
            doc.import_pairs(&b.path)?;
            json(doc.pairs_json())
        }
        ("POST", "/api/landmarks/export") => {
            let b: requests::ExportPairs = read_body(body)?;
            let f = doc::pairs::format_named(&b.format)?;
            let p = doc.export_pairs(&b.path, f)?;
            json(answers::Saved { saved: p.display().to_string() })
        }
        (_, p) if p.starts_with("/api/") => {
            Err(ServerError::NotFound(format!("{method} {p} is not part of the API")))
        }
        _ => Err(ServerError::NotFound(format!("{path}: only the embedded page is served"))),
    }
}
