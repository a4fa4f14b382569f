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
//! | `GET /api/image.png` | | the frame |
//! | `GET /api/jacobian.png` | | det J overlay ([`views::jacobian_png`]) |
//! | `POST /api/pick` | `{x, y, max_dist?}` | `{index, point}` (nearest control point) |
//! | `POST /api/select` | `{anchors, radius?, mode?}` (`radius` null: all) | selection |
//! | `POST /api/update` | `{op: translate, v}` / `{op: rotate, center, angle}` / `{op: scale, center, factor}` | geometry |
//! | `POST /api/clear` | | state |
//! | `POST /api/undo`, `/api/redo` | | geometry |
//! | `POST /api/save` | `{path, scene?}` | `{saved}` |
//! | `POST /api/load` | `{path}` | state |
//! | `POST /api/export` | `{kind: obj / warped, path}` | `{saved}` |
//! | `POST /api/refit` | `{landmarks, hard?}` | fit summary |
//!
//! The state and every geometry answer (select, update, undo, redo) also carry the det J
//! certificate ([`crate::spline::jacobian`]): `fold_free` (certified), `folding_triangles`,
//! `undecided_triangles`, `det_j_lower_bound`, `det_j_sampled_min`, and in geometry answers
//! `folding_outline` (the deformed corners of each folding triangle, 6 numbers each). A drag
//! re-certifies only the triangles around the points it moved.
//!
//! Errors answer `{"error": message}` with 400 (bad request), 403 (path outside the
//! folder), 404, 413 (body over [`MAX_BODY`] bytes) or 422 (an edit or file the engine
//! refuses; the document is unchanged).
//!
//! # Safety
//!
//! The server binds 127.0.0.1 only, reads at most [`MAX_BODY`] bytes of a request body,
//! serves only the embedded assets, and confines every file path to the folder it was
//! started in ([`paths::confine`]).

pub mod doc;
pub mod paths;
pub mod views;

#[cfg(test)]
mod tests;

use crate::edit::Mode;
use doc::{Doc, Op};
use serde_json::{json, Value};
use std::io::Read;
use std::net::SocketAddr;
use std::time::Instant;

/// Largest accepted request body (bytes).
pub const MAX_BODY: usize = 1 << 20;

/// The embedded page.
const ASSETS: [(&str, &str, &str); 3] = [
    ("/", "text/html; charset=utf-8", include_str!("assets/index.html")),
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
fn text<'a>(b: &'a Value, k: &str) -> Result<&'a str, ServerError> {
    field(b, k)?.as_str().ok_or_else(|| ServerError::BadRequest(format!("`{k}` must be a string")))
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
            let i = doc.editor().nearest_points(&[p])[0];
            let q = doc.spline().point_f64(i);
            if (q[0] - p[0]).hypot(q[1] - p[1]) > max {
                return Ok(Json(json!({ "index": null })));
            }
            Ok(Json(json!({ "index": i, "point": q })))
        }
        ("POST", "/api/select") => {
            let b = parse()?;
            let bad = || ServerError::BadRequest("`anchors` must be an array of indices".into());
            let anchors: Vec<usize> = field(&b, "anchors")?
                .as_array()
                .ok_or_else(bad)?
                .iter()
                .map(|v| v.as_u64().map(|x| x as usize).ok_or_else(bad))
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
            let sel = doc.select(&anchors, radius, mode)?;
            Ok(with_geometry(doc, sel))
        }
        ("POST", "/api/update") => {
            let b = parse()?;
            let op = match text(&b, "op")? {
                "translate" => Op::Translate(nums(&b, "v")?),
                "rotate" => {
                    let c = nums(&b, "center")?;
                    if c.len() != 2 {
                        return Err(ServerError::BadRequest("`center` needs 2 values".into()));
                    }
                    Op::Rotate { center: [c[0], c[1]], angle: num(&b, "angle")? }
                }
                "scale" => Op::Scale { center: nums(&b, "center")?, factor: num(&b, "factor")? },
                other => {
                    return Err(ServerError::BadRequest(format!(
                        "unknown op `{other}` (translate, rotate or scale)"
                    )))
                }
            };
            doc.update(&op)?;
            Ok(with_geometry(doc, json!({ "update_ms": doc.last_update_ms })))
        }
        ("POST", "/api/clear") => {
            doc.clear_selection();
            Ok(Json(doc.state()))
        }
        ("POST", "/api/undo") => {
            doc.undo()?;
            Ok(with_geometry(doc, json!({})))
        }
        ("POST", "/api/redo") => {
            doc.redo()?;
            Ok(with_geometry(doc, json!({})))
        }
        ("POST", "/api/save") => {
            let b = parse()?;
            let scene = b.get("scene").and_then(Value::as_bool).unwrap_or(false);
            let p = doc.save(text(&b, "path")?, scene)?;
            Ok(Json(json!({ "saved": p.display().to_string() })))
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
            let r = doc.refit(text(&b, "landmarks")?, hard)?;
            Ok(with_geometry(doc, r))
        }
        (_, p) if p.starts_with("/api/") => {
            Err(ServerError::NotFound(format!("{method} {p} is not part of the API")))
        }
        _ => Err(ServerError::NotFound(format!("{path}: only the embedded page is served"))),
    }
}

/// A running editor server.
pub struct Server {
    http: tiny_http::Server,
    addr: SocketAddr,
}

impl Server {
    /// Binds `127.0.0.1:port` (`0`: any free port).
    pub fn bind(port: u16) -> Result<Server, ServerError> {
        let io = |e: &dyn std::fmt::Display| {
            ServerError::Io(format!("cannot listen on 127.0.0.1:{port}: {e}"))
        };
        let listener = std::net::TcpListener::bind(("127.0.0.1", port)).map_err(|e| io(&e))?;
        // No Nagle delay: a drag step answers ~100 KB, whose last segment would otherwise
        // wait for the browser's delayed ACK (~40 ms). Accepted sockets inherit the option.
        socket2::SockRef::from(&listener).set_nodelay(true).map_err(|e| io(&e))?;
        let http = tiny_http::Server::from_listener(listener, None).map_err(|e| io(&e))?;
        let addr = http
            .server_addr()
            .to_ip()
            .ok_or_else(|| ServerError::Io("not an IP listener".into()))?;
        Ok(Server { http, addr })
    }

    /// The bound address (always on 127.0.0.1).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Serves requests one at a time until `stop` returns true (checked between requests
    /// and every 200 ms).
    pub fn run(&self, doc: &mut Doc, stop: &dyn Fn() -> bool) {
        while !stop() {
            let req = match self.http.recv_timeout(std::time::Duration::from_millis(200)) {
                Ok(Some(r)) => r,
                Ok(None) => continue,
                Err(_) => break,
            };
            serve_one(doc, req);
        }
    }
}

fn serve_one(doc: &mut Doc, mut req: tiny_http::Request) {
    let method = req.method().as_str().to_uppercase();
    let url = req.url().to_string();
    let reply = if req.body_length().is_some_and(|n| n > MAX_BODY) {
        Reply::error(&ServerError::TooLarge)
    } else {
        let mut body = Vec::new();
        match req.as_reader().take(MAX_BODY as u64 + 1).read_to_end(&mut body) {
            Ok(_) if body.len() > MAX_BODY => Reply::error(&ServerError::TooLarge),
            Ok(_) => handle(doc, &method, &url, &body),
            Err(e) => Reply::error(&ServerError::BadRequest(format!("reading the body: {e}"))),
        }
    };
    let header = tiny_http::Header::from_bytes(&b"Content-Type"[..], reply.content_type.as_bytes())
        .expect("static header");
    let nocache = tiny_http::Header::from_bytes(&b"Cache-Control"[..], &b"no-store"[..])
        .expect("static header");
    let resp = tiny_http::Response::from_data(reply.body)
        .with_status_code(reply.status)
        .with_header(header)
        .with_header(nocache);
    let _ = req.respond(resp);
}
