//! The gate every request to the editor passes, in front of the handlers; the transport
//! (hyper's HTTP/1.1 on a small tokio runtime) is in [`super::net`].
//!
//! # Threat model
//!
//! The editor runs on a shared desktop while its user browses the web. It can write files
//! in the folder it was started in, so whoever can drive its API can overwrite them. The
//! attackers considered are:
//!
//! * **Any web page** the user visits (cross-site requests). A page can send "simple"
//!   requests to `http://127.0.0.1:P/` without CORS preflight (`text/plain` or form
//!   bodies, no custom headers), and it can guess the port. Refused by three independent
//!   checks: the per-session token ([`Guard::token`]), which such a page cannot know; the
//!   `Origin` check (a browser names the page's origin on every cross-origin POST); and
//!   the content type (`application/json` is not a simple type, so a cross-origin page
//!   cannot send it without a preflight, which the server never answers with CORS
//!   headers).
//! * **DNS rebinding**: a page at `evil.example` whose name is re-pointed to 127.0.0.1
//!   becomes same-origin with the editor and could read the answers. Refused by the
//!   `Host` check: only `127.0.0.1:P` and `localhost:P` are served, and the token is
//!   still needed.
//! * **Other local users** on the same machine can connect to 127.0.0.1 too. They cannot
//!   read the token (printed only on the editor's own stdout; the session cookie is
//!   `HttpOnly`, `SameSite=Strict` and named after the port); answers carry
//!   `Referrer-Policy: no-referrer`, so the address with the token does not leak in a
//!   `Referer` header.
//! * **Stalled, slow or many clients** (denial of service). The transport is asynchronous
//!   (one tokio task per connection, not a thread), so a stalled connection costs a few
//!   kilobytes and no worker. Heads are parsed by hyper and must be complete within the
//!   read timeout ([`READ_TIMEOUT`]; else the connection is closed, no answer) and at most
//!   [`MAX_HEAD`] bytes (hyper answers 431); a body must be complete within the read
//!   timeout from the end of its head (408) and is read through a hard cap of
//!   [`super::MAX_BODY`] bytes (413); an answer must make progress within the write
//!   timeout ([`WRITE_TIMEOUT`]). At most [`super::net::MAX_CONNECTIONS`] connections are
//!   open at once; when all are taken, the oldest connection whose request has not passed
//!   the token check (a stalled head, say) is dropped to make room, so clients without the
//!   token cannot lock out one that has it.
//!
//! Out of scope: a local attacker with the user's own account (they can read the
//! terminal), and TLS (the server binds loopback only; nothing leaves the machine).
//!
//! # Checks, in order
//!
//! All of them run on the request line and headers ([`Gate::admit_head`]), before any byte
//! of the body is read or buffered: a client without the token cannot make the server
//! buffer a body, and a declared length over the cap is refused at once.
//!
//! | check | applies to | refused with |
//! |---|---|---|
//! | a well-formed HTTP/1.x head (hyper), at most [`MAX_HEAD`] bytes | every request | 400 / 431, no body |
//! | the target in origin form (`/path?query`) | every request | 400 |
//! | exactly one `Host` header (RFC 9112, 3.2) | every request | 400 |
//! | `Host` is `127.0.0.1:P` or `localhost:P` | every request | 403 |
//! | `Origin`, if sent, is `http://127.0.0.1:P` or `http://localhost:P` | every request | 403 |
//! | `Sec-Fetch-Site`, if sent, is `same-origin` or `none` | `/api/` | 403 |
//! | `X-Trimorph-Token: T` or cookie `trimorph_token_P=T` | `/api/` | 401 |
//! | a body (`Content-Length` > 0 or chunked) is `Content-Type: application/json` | `/api/` | 415 |
//! | a declared `Content-Length` at most [`super::MAX_BODY`] | every request | 413 |
//!
//! Then the body is read (hyper decodes chunked bodies) through
//! [`http_body_util::Limited`]: 413 as soon as more than [`super::MAX_BODY`] bytes have
//! arrived, 408 when it is not complete within the read timeout, 400 when it is malformed.
//! Only then does the handler run ([`super::handle`]), with the whole body.
//!
//! Loading the page as `/?token=T` (the address `trimorph editor` prints) sets the cookie,
//! so the page's images (`<img src=/api/...>`) and reloads without the query work.
//!
//! Every connection carries one request (`Connection: close`): a connection is open only
//! while a request is read, handled and answered, never idle between requests.

use super::{Reply, ServerError};
use http_body_util::{BodyExt, Full, Limited};
use hyper::body::{Body, Bytes};
use hyper::header::{self, HeaderMap, HeaderValue};
use hyper::{Request, Response, StatusCode};
use std::future::Future;
use std::time::Duration;

/// Largest accepted request line and headers (bytes).
pub const MAX_HEAD: usize = 16 << 10;
/// Default time a client has to send a request's head, and then its body.
pub const READ_TIMEOUT: Duration = Duration::from_secs(5);
/// Default time an answer may go without progress while it is written.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(10);
/// The token header.
pub const TOKEN_HEADER: &str = "x-trimorph-token";

/// The session's secret and the port it is bound to; decides which requests pass.
#[derive(Clone, Debug)]
pub struct Guard {
    token: String,
    port: u16,
}

/// Equality that takes the same time wherever the first difference is.
fn same_secret(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// The first header called `name`, as text (`""` when not valid text).
fn header<'a>(h: &'a HeaderMap, name: &str) -> Option<&'a str> {
    h.get(name).map(|v| v.to_str().unwrap_or(""))
}

/// The value of cookie `name`, if sent (in any `Cookie` header).
fn cookie<'a>(h: &'a HeaderMap, name: &str) -> Option<&'a str> {
    h.get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|c| c.trim().split_once('='))
        .find(|(k, _)| *k == name)
        .map(|(_, v)| v)
}

impl Guard {
    /// A guard for `port` with `token`.
    pub fn new(token: String, port: u16) -> Guard {
        Guard { token, port }
    }

    /// A guard with a fresh 128-bit token from the operating system's generator.
    pub fn random(port: u16) -> Guard {
        let mut b = [0u8; 16];
        getrandom::fill(&mut b).expect("the operating system's random generator failed");
        Guard::new(b.iter().map(|x| format!("{x:02x}")).collect(), port)
    }

    /// The session token.
    pub fn token(&self) -> &str {
        &self.token
    }

    /// The port the guard admits in `Host` and `Origin`.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// The session cookie's name (per port: two editors on one machine do not mix).
    pub fn cookie_name(&self) -> String {
        format!("trimorph_token_{}", self.port)
    }

    /// The `Set-Cookie` value that hands the token to the page.
    pub fn set_cookie(&self) -> String {
        format!("{}={}; Path=/; HttpOnly; SameSite=Strict", self.cookie_name(), self.token)
    }

    fn is_local(&self, authority: &str) -> bool {
        let a = authority.to_ascii_lowercase();
        a == format!("127.0.0.1:{}", self.port) || a == format!("localhost:{}", self.port)
    }

    /// Checks a request's head: its `target` (path and query), its headers, and whether a
    /// body follows (see the module docs). `Ok(true)`: the page was loaded with the right
    /// token, the answer sets the cookie.
    pub fn admit(
        &self,
        target: &str,
        headers: &HeaderMap,
        has_body: bool,
    ) -> Result<bool, ServerError> {
        // RFC 9112 section 3.2: a request with more than one Host header is answered 400.
        if headers.get_all(header::HOST).iter().count() > 1 {
            return Err(ServerError::BadRequest("more than one Host header".into()));
        }
        let host = header(headers, "host").unwrap_or("");
        if !self.is_local(host) {
            return Err(ServerError::Forbidden(format!(
                "Host `{host}` is not this editor (127.0.0.1:{p} or localhost:{p})",
                p = self.port
            )));
        }
        if let Some(o) = header(headers, "origin") {
            let local = o
                .strip_prefix("http://")
                .is_some_and(|rest| self.is_local(rest.trim_end_matches('/')));
            if !local {
                return Err(ServerError::Forbidden(format!("requests from `{o}` are refused")));
            }
        }
        let (path, query) = target.split_once('?').unwrap_or((target, ""));
        if !path.starts_with("/api/") {
            let with_token = query.split('&').any(|q| {
                q.strip_prefix("token=")
                    .is_some_and(|t| same_secret(t.as_bytes(), self.token.as_bytes()))
            });
            return Ok(path == "/" && with_token);
        }
        if let Some(site) = header(headers, "sec-fetch-site") {
            if site != "same-origin" && site != "none" {
                return Err(ServerError::Forbidden(format!("a {site} request is refused")));
            }
        }
        let name = self.cookie_name();
        let sent = header(headers, TOKEN_HEADER).or_else(|| cookie(headers, &name));
        if !sent.is_some_and(|t| same_secret(t.as_bytes(), self.token.as_bytes())) {
            return Err(ServerError::Unauthorized(
                "missing or wrong session token: open the address `trimorph editor` printed \
                 (…/?token=…), or send the `X-Trimorph-Token` header"
                    .into(),
            ));
        }
        if has_body {
            let ct = header(headers, "content-type").unwrap_or("");
            let media = ct.split(';').next().unwrap_or("").trim().to_ascii_lowercase();
            if media != "application/json" {
                return Err(ServerError::UnsupportedMediaType(format!(
                    "the body must be sent as application/json, not `{ct}`"
                )));
            }
        }
        Ok(false)
    }
}

/// An admitted request with its whole body, for the handler.
#[derive(Debug)]
pub struct Call {
    /// The method (`GET`, `POST`, ...).
    pub method: String,
    /// The target (path and query).
    pub target: String,
    /// The body (chunked bodies decoded).
    pub body: Vec<u8>,
}

/// What passed the head's checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Admitted {
    /// An `/api/` request with the token.
    Api,
    /// The page or an asset; `true`: loaded with the right `?token=`, the answer sets the
    /// cookie.
    Page(bool),
}

/// The checks in front of the handlers: the [`Guard`], the body cap and the body deadline.
#[derive(Clone, Debug)]
pub struct Gate {
    /// Who is admitted.
    pub guard: Guard,
    /// Largest body (bytes).
    pub max_body: usize,
    /// Time a body has to arrive once its head has.
    pub body_timeout: Duration,
}

impl Gate {
    /// A gate with `guard`, the body capped at [`super::MAX_BODY`] and `body_timeout`.
    pub fn new(guard: Guard, body_timeout: Duration) -> Gate {
        Gate { guard, max_body: super::MAX_BODY, body_timeout }
    }

    /// Every check that needs only the head (see the module docs), in order.
    pub fn admit_head<B: Body>(&self, req: &Request<B>) -> Result<Admitted, ServerError> {
        let uri = req.uri();
        let target = match uri.path_and_query() {
            Some(pq) if uri.scheme().is_none() && pq.as_str().starts_with('/') => pq.as_str(),
            _ => return Err(ServerError::BadRequest(format!("request target `{uri}`"))),
        };
        let hint = req.body().size_hint();
        let has_body = hint.exact() != Some(0);
        let set_cookie = self.guard.admit(target, req.headers(), has_body)?;
        if hint.lower() > self.max_body as u64 {
            return Err(ServerError::TooLarge);
        }
        Ok(if target.starts_with("/api/") { Admitted::Api } else { Admitted::Page(set_cookie) })
    }

    /// Answers `req`: the head's checks ([`Gate::admit_head`]; `admitted` is called once
    /// they pass, before the body is read), then the body, capped and with a deadline, then
    /// `dispatch` (the handler).
    pub async fn answer<B, D, F>(
        &self,
        req: Request<B>,
        admitted: impl FnOnce(Admitted),
        dispatch: D,
    ) -> Response<Full<Bytes>>
    where
        B: Body,
        B::Error: Into<Box<dyn std::error::Error + Send + Sync>>,
        D: FnOnce(Call) -> F,
        F: Future<Output = Reply>,
    {
        let adm = match self.admit_head(&req) {
            Ok(a) => a,
            Err(e) => return respond(Reply::error(&e), None),
        };
        admitted(adm);
        let (head, body) = req.into_parts();
        let collected =
            tokio::time::timeout(self.body_timeout, Limited::new(body, self.max_body).collect())
                .await;
        let body = match collected {
            Err(_) => return respond(Reply::error(&ServerError::Timeout), None),
            Ok(Err(e)) if e.is::<http_body_util::LengthLimitError>() => {
                return respond(Reply::error(&ServerError::TooLarge), None)
            }
            Ok(Err(e)) => {
                let e = ServerError::BadRequest(format!("the body could not be read: {e}"));
                return respond(Reply::error(&e), None);
            }
            Ok(Ok(b)) => b.to_bytes().to_vec(),
        };
        let target = head.uri.path_and_query().map_or("/", |pq| pq.as_str()).to_string();
        let call = Call { method: head.method.as_str().to_string(), target, body };
        let reply = dispatch(call).await;
        let cookie = (adm == Admitted::Page(true)).then(|| self.guard.set_cookie());
        respond(reply, cookie)
    }
}

/// The HTTP answer of `reply`, with the headers every answer carries.
pub fn respond(reply: Reply, set_cookie: Option<String>) -> Response<Full<Bytes>> {
    let status = StatusCode::from_u16(reply.status).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
    let len = reply.body.len();
    let mut r = Response::new(Full::new(Bytes::from(reply.body)));
    *r.status_mut() = status;
    let h = r.headers_mut();
    let fixed = [
        (header::CONTENT_TYPE, reply.content_type),
        (header::CACHE_CONTROL, "no-store"),
        (header::CONNECTION, "close"),
        (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        (header::REFERRER_POLICY, "no-referrer"),
        (header::X_FRAME_OPTIONS, "DENY"),
        (
            header::CONTENT_SECURITY_POLICY,
            "default-src 'self'; img-src 'self' blob: data:; frame-ancestors 'none'",
        ),
    ];
    for (k, v) in fixed {
        h.insert(k, HeaderValue::from_static(v));
    }
    h.insert(header::CONTENT_LENGTH, HeaderValue::from(len));
    if let Some(c) = set_cookie.and_then(|c| HeaderValue::from_str(&c).ok()) {
        h.insert(header::SET_COOKIE, c);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(list: &[(&str, &str)]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for (k, v) in list {
            h.append(
                header::HeaderName::from_bytes(k.as_bytes()).unwrap(),
                HeaderValue::from_str(v).unwrap(),
            );
        }
        h
    }

    #[test]
    fn the_guard_checks_host_origin_token_and_content_type() {
        let g = Guard::new("abc123".into(), 4000);
        let admit =
            |target: &str, h: &[(&str, &str)], body: bool| g.admit(target, &headers(h), body);
        let h = ("host", "127.0.0.1:4000");
        let t = (TOKEN_HEADER, "abc123");
        let j = ("content-type", "application/json; charset=utf-8");
        assert!(matches!(admit("/api/state", &[h, t], false), Ok(false)));
        assert!(admit("/api/save", &[("host", "LOCALHOST:4000"), t, j], true).is_ok());
        let cookie = ("cookie", "a=b; trimorph_token_4000=abc123");
        assert!(admit("/api/save", &[h, cookie, j], true).is_ok());
        let status = |r: Result<bool, ServerError>| r.err().map(|e| e.status());
        assert_eq!(status(admit("/api/state", &[h], false)), Some(401));
        assert_eq!(status(admit("/api/state", &[h, (TOKEN_HEADER, "abc12")], false)), Some(401));
        assert_eq!(
            status(admit("/api/state", &[h, ("cookie", "trimorph_token_4001=abc123")], false)),
            Some(401)
        );
        for host in ["evil.example:4000", "127.0.0.1:4001", "127.0.0.1", ""] {
            assert_eq!(status(admit("/api/state", &[("host", host), t], false)), Some(403));
            assert_eq!(status(admit("/", &[("host", host)], false)), Some(403), "{host}");
        }
        assert_eq!(status(admit("/api/state", &[t], false)), Some(403), "no Host");
        assert_eq!(
            status(admit("/api/state", &[h, ("host", "evil.example"), t], false)),
            Some(400)
        );
        for o in ["http://evil.example", "null", "https://127.0.0.1:4000", "http://127.0.0.1:4001"]
        {
            assert_eq!(
                status(admit("/api/state", &[h, t, ("origin", o)], false)),
                Some(403),
                "{o}"
            );
        }
        assert!(admit("/api/state", &[h, t, ("origin", "http://127.0.0.1:4000")], false).is_ok());
        assert_eq!(
            status(admit("/api/state", &[h, t, ("sec-fetch-site", "cross-site")], false)),
            Some(403)
        );
        for ct in ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data", ""] {
            let r = admit("/api/save", &[h, t, ("content-type", ct)], true);
            assert_eq!(status(r), Some(415), "{ct}");
        }
        // The page: served to anyone local, the cookie only with the right token.
        assert!(matches!(admit("/?token=abc123", &[h], false), Ok(true)));
        assert!(matches!(admit("/?token=abc", &[h], false), Ok(false)));
        assert!(matches!(admit("/app.js?token=abc123", &[h], false), Ok(false)));
    }

    /// The gate's order on whole requests (without sockets): the head's refusals come before
    /// the body is touched, a declared length over the cap is 413 at once, and the handler
    /// sees exactly the admitted requests.
    #[test]
    fn the_gate_refuses_on_the_head_and_caps_the_body() {
        use std::cell::Cell;
        let gate = Gate::new(Guard::new("t0".into(), 9), Duration::from_secs(1));
        let rt = tokio::runtime::Builder::new_current_thread().enable_time().build().unwrap();
        let calls = Cell::new(0);
        let run = |target: &str, h: &[(&str, &str)], body: &str| -> (u16, Option<Admitted>) {
            let mut req = Request::new(Full::new(Bytes::from(body.to_string())));
            *req.uri_mut() = target.parse().unwrap();
            *req.method_mut() = hyper::Method::POST;
            *req.headers_mut() = headers(h);
            let adm = Cell::new(None);
            let r = rt.block_on(gate.answer(
                req,
                |a| adm.set(Some(a)),
                |c: Call| {
                    calls.set(calls.get() + 1);
                    async move { Reply::json(&serde_json::json!({ "len": c.body.len() })) }
                },
            ));
            (r.status().as_u16(), adm.get())
        };
        let (h, t, j) =
            (("host", "127.0.0.1:9"), (TOKEN_HEADER, "t0"), ("content-type", "application/json"));
        assert_eq!(run("/api/pick", &[h, t, j], "{}"), (200, Some(Admitted::Api)));
        assert_eq!(run("/api/pick", &[h, j], "{}"), (401, None));
        assert_eq!(run("http://127.0.0.1:9/api/pick", &[h, t, j], "{}"), (400, None));
        let big = " ".repeat(gate.max_body + 1);
        assert_eq!(run("/api/pick", &[h, t, j], &big), (413, None));
        assert_eq!(run("/?token=t0", &[h], ""), (200, Some(Admitted::Page(true))));
        assert_eq!(calls.get(), 2, "the handler runs for admitted requests only");
        let ok = respond(Reply::json(&serde_json::json!({})), Some(gate.guard.set_cookie()));
        let hv = |k: &str| ok.headers().get(k).unwrap().to_str().unwrap().to_string();
        assert_eq!(hv("connection"), "close");
        assert_eq!(hv("referrer-policy"), "no-referrer");
        assert!(hv("set-cookie").starts_with("trimorph_token_9=t0;"));
    }

    #[test]
    fn random_tokens_are_128_bit_hex_and_differ() {
        let (a, b) = (Guard::random(1), Guard::random(1));
        assert_eq!(a.token().len(), 32);
        assert!(a.token().bytes().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a.token(), b.token());
    }
}
