//! The editor's HTTP/1.1 transport and the gate every request passes.
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
//! * **Stalled or slow clients** (denial of service): requests are served by a pool of
//!   [`WORKERS`] threads, each request must arrive within the read timeout (else 408) and
//!   each answer leave within the write timeout; bodies are capped at
//!   [`super::MAX_BODY`] bytes (413) and headers at [`MAX_HEAD`] bytes (431). One stalled
//!   client holds one worker for at most the read timeout; the others keep answering.
//!
//! Out of scope: a local attacker with the user's own account (they can read the
//! terminal), and TLS (the server binds loopback only; nothing leaves the machine).
//!
//! # Checks, in order
//!
//! The first five run on the request line and headers, before any byte of the body is
//! read: a client without the token cannot make the server buffer a body.
//!
//! | check | applies to | refused with |
//! |---|---|---|
//! | exactly one `Host` header (RFC 9112, 3.2) | every request | 400 |
//! | `Host` is `127.0.0.1:P` or `localhost:P` | every request | 403 |
//! | `Origin`, if sent, is `http://127.0.0.1:P` or `http://localhost:P` | every request | 403 |
//! | `Sec-Fetch-Site`, if sent, is `same-origin` or `none` | `/api/` | 403 |
//! | `X-Trimorph-Token: T` or cookie `trimorph_token_P=T` | `/api/` | 401 |
//! | a non-empty body is `Content-Type: application/json` | `/api/` | 415 |
//!
//! Loading the page as `/?token=T` (the address `trimorph editor` prints) sets the cookie,
//! so the page's images (`<img src=/api/...>`) and reloads without the query work.
//!
//! Every connection carries one request (`Connection: close`): a worker is busy only while
//! a request is read, handled and answered, never with an idle keep-alive connection.

use super::ServerError;
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::{Duration, Instant};

/// Worker threads serving requests concurrently.
pub const WORKERS: usize = 4;
/// Largest accepted request line and headers (bytes).
pub const MAX_HEAD: usize = 16 << 10;
/// Default time a client has to send a whole request.
pub const READ_TIMEOUT: Duration = Duration::from_secs(5);
/// Default time an answer may take to leave.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(10);
/// The token header.
pub const TOKEN_HEADER: &str = "x-trimorph-token";

/// A parsed request.
#[derive(Debug, Default)]
pub struct Request {
    /// Upper-case method.
    pub method: String,
    /// The target (path and query).
    pub target: String,
    /// Headers, names lower-case, in order.
    pub headers: Vec<(String, String)>,
    /// The body (chunked bodies decoded).
    pub body: Vec<u8>,
}

impl Request {
    /// The first header called `name` (lower-case).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }

    /// The value of cookie `name`, if sent.
    pub fn cookie(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .filter(|(k, _)| k == "cookie")
            .flat_map(|(_, v)| v.split(';'))
            .filter_map(|c| c.trim().split_once('='))
            .find(|(k, _)| *k == name)
            .map(|(_, v)| v)
    }
}

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

impl Guard {
    /// A guard for `port` with `token`.
    pub fn new(token: String, port: u16) -> Guard {
        Guard { token, port }
    }

    /// A guard with a fresh 128-bit token from the operating system's generator.
    pub fn random(port: u16) -> Guard {
        use rand::RngCore;
        let mut b = [0u8; 16];
        rand::rngs::OsRng.fill_bytes(&mut b);
        Guard::new(b.iter().map(|x| format!("{x:02x}")).collect(), port)
    }

    /// The session token.
    pub fn token(&self) -> &str {
        &self.token
    }

    /// The session cookie's name (per port: two editors on one machine do not mix).
    pub fn cookie_name(&self) -> String {
        format!("trimorph_token_{}", self.port)
    }

    fn is_local(&self, authority: &str) -> bool {
        let a = authority.to_ascii_lowercase();
        a == format!("127.0.0.1:{}", self.port) || a == format!("localhost:{}", self.port)
    }

    /// Checks `req` (see the module docs). `Ok(true)`: the page was loaded with the right
    /// token, the answer sets the cookie.
    pub fn admit(&self, req: &Request) -> Result<bool, ServerError> {
        let host = req.header("host").unwrap_or("");
        if !self.is_local(host) {
            return Err(ServerError::Forbidden(format!(
                "Host `{host}` is not this editor (127.0.0.1:{p} or localhost:{p})",
                p = self.port
            )));
        }
        if let Some(o) = req.header("origin") {
            let local = o
                .strip_prefix("http://")
                .is_some_and(|rest| self.is_local(rest.trim_end_matches('/')));
            if !local {
                return Err(ServerError::Forbidden(format!("requests from `{o}` are refused")));
            }
        }
        let (path, query) = req.target.split_once('?').unwrap_or((&req.target, ""));
        if !path.starts_with("/api/") {
            let with_token = query.split('&').any(|q| {
                q.strip_prefix("token=")
                    .is_some_and(|t| same_secret(t.as_bytes(), self.token.as_bytes()))
            });
            return Ok(path == "/" && with_token);
        }
        if let Some(site) = req.header("sec-fetch-site") {
            if site != "same-origin" && site != "none" {
                return Err(ServerError::Forbidden(format!("a {site} request is refused")));
            }
        }
        let name = self.cookie_name();
        let sent = req.header(TOKEN_HEADER).or_else(|| req.cookie(&name));
        if !sent.is_some_and(|t| same_secret(t.as_bytes(), self.token.as_bytes())) {
            return Err(ServerError::Unauthorized(
                "missing or wrong session token: open the address `trimorph editor` printed \
                 (…/?token=…), or send the `X-Trimorph-Token` header"
                    .into(),
            ));
        }
        if !req.body.is_empty() {
            let ct = req.header("content-type").unwrap_or("");
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

/// Why no request could be read.
#[derive(Debug)]
pub enum ReadFail {
    /// The client closed or sent nothing: no answer.
    Gone,
    /// Answer this error, then close.
    Answer(ServerError),
}

impl From<ServerError> for ReadFail {
    fn from(e: ServerError) -> ReadFail {
        ReadFail::Answer(e)
    }
}

/// Buffered reading of one request from a stream, all of it before `deadline`.
struct Input<'a> {
    s: &'a TcpStream,
    buf: Vec<u8>,
    pos: usize,
    deadline: Instant,
}

impl Input<'_> {
    /// Reads more bytes; false at end of stream.
    fn fill(&mut self) -> Result<bool, ReadFail> {
        let left = self.deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(ServerError::Timeout.into());
        }
        self.s.set_read_timeout(Some(left)).map_err(|e| ServerError::Io(e.to_string()))?;
        if self.pos > 0 && self.pos == self.buf.len() {
            self.buf.clear();
            self.pos = 0;
        }
        let mut chunk = [0u8; 16 << 10];
        match (&*self.s).read(&mut chunk) {
            Ok(0) => Ok(false),
            Ok(n) => {
                self.buf.extend_from_slice(&chunk[..n]);
                Ok(true)
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                Err(ServerError::Timeout.into())
            }
            Err(_) => Err(ReadFail::Gone),
        }
    }

    /// One line without its CRLF (at most `max` bytes).
    fn line(&mut self, max: usize) -> Result<String, ReadFail> {
        loop {
            if let Some(i) = self.buf[self.pos..].windows(2).position(|w| w == b"\r\n") {
                let l = String::from_utf8_lossy(&self.buf[self.pos..self.pos + i]).into_owned();
                self.pos += i + 2;
                return Ok(l);
            }
            if self.buf.len() - self.pos > max {
                return Err(ServerError::HeadTooLarge.into());
            }
            if !self.fill()? {
                return Err(ReadFail::Gone);
            }
        }
    }

    /// `n` bytes into `out`.
    fn take(&mut self, n: usize, out: &mut Vec<u8>) -> Result<(), ReadFail> {
        while self.buf.len() - self.pos < n {
            if !self.fill()? {
                return Err(ServerError::BadRequest("the body ended early".into()).into());
            }
        }
        out.extend_from_slice(&self.buf[self.pos..self.pos + n]);
        self.pos += n;
        Ok(())
    }
}

/// Reads one request from `s`, all of it within `timeout`, the body capped at `max_body`.
/// `admit_head` sees the request line and headers before any byte of the body is read (the
/// token check: a client without the token cannot make the server buffer a body).
pub fn read_request(
    s: &TcpStream,
    timeout: Duration,
    max_body: usize,
    admit_head: &dyn Fn(&Request) -> Result<(), ServerError>,
) -> Result<Request, ReadFail> {
    let mut input = Input { s, buf: Vec::new(), pos: 0, deadline: Instant::now() + timeout };
    let first = match input.line(MAX_HEAD) {
        Err(ReadFail::Answer(ServerError::Timeout)) if input.buf.is_empty() => {
            return Err(ReadFail::Gone)
        }
        r => r?,
    };
    let mut parts = first.split(' ');
    let (method, target, version) = (parts.next(), parts.next(), parts.next());
    let (Some(method), Some(target), Some(version)) = (method, target, version) else {
        return Err(ServerError::BadRequest(format!("request line `{first}`")).into());
    };
    if !version.starts_with("HTTP/1.") || !target.starts_with('/') {
        return Err(ServerError::BadRequest(format!("request line `{first}`")).into());
    }
    let mut req = Request {
        method: method.to_ascii_uppercase(),
        target: target.to_string(),
        ..Default::default()
    };
    let mut head = first.len();
    loop {
        let l = input.line(MAX_HEAD)?;
        head += l.len() + 2;
        if head > MAX_HEAD {
            return Err(ServerError::HeadTooLarge.into());
        }
        if l.is_empty() {
            break;
        }
        let (k, v) = l
            .split_once(':')
            .ok_or_else(|| ServerError::BadRequest(format!("header line `{l}`")))?;
        req.headers.push((k.trim().to_ascii_lowercase(), v.trim().to_string()));
    }
    // RFC 9112 section 3.2: a request with more than one Host header is answered 400.
    if req.headers.iter().filter(|(k, _)| k == "host").count() > 1 {
        return Err(ServerError::BadRequest("more than one Host header".into()).into());
    }
    admit_head(&req)?;
    if req.header("expect").is_some_and(|e| e.eq_ignore_ascii_case("100-continue")) {
        let _ = (&*s).write_all(b"HTTP/1.1 100 Continue\r\n\r\n");
    }
    let chunked =
        req.header("transfer-encoding").is_some_and(|t| t.to_ascii_lowercase().contains("chunked"));
    if chunked {
        let mut body = Vec::new();
        loop {
            let l = input.line(64)?;
            let hex = l.split(';').next().unwrap_or("").trim();
            let n = usize::from_str_radix(hex, 16)
                .map_err(|_| ServerError::BadRequest(format!("chunk size `{l}`")))?;
            if n == 0 {
                // Trailers, up to the empty line.
                while !input.line(MAX_HEAD)?.is_empty() {}
                break;
            }
            // `n` may be anything up to usize::MAX: compare without adding (an overflowing
            // sum once let a body past the cap).
            if n > max_body.saturating_sub(body.len()) {
                return Err(ServerError::TooLarge.into());
            }
            input.take(n, &mut body)?;
            input.line(2)?;
        }
        req.body = body;
    } else if let Some(len) = req.header("content-length") {
        let n: usize =
            len.parse().map_err(|_| ServerError::BadRequest(format!("Content-Length `{len}`")))?;
        if n > max_body {
            return Err(ServerError::TooLarge.into());
        }
        input.take(n, &mut req.body)?;
    }
    Ok(req)
}

/// The reason phrase of a status.
fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        401 => "Unauthorized",
        403 => "Forbidden",
        404 => "Not Found",
        408 => "Request Timeout",
        413 => "Payload Too Large",
        415 => "Unsupported Media Type",
        422 => "Unprocessable Entity",
        431 => "Request Header Fields Too Large",
        _ => "Internal Server Error",
    }
}

/// Writes an answer and closes the connection (after reading what the client still
/// sends for a moment, so that the answer is not lost to a connection reset).
pub fn respond(
    s: &TcpStream,
    status: u16,
    content_type: &str,
    body: &[u8],
    set_cookie: Option<&str>,
    timeout: Duration,
) {
    let mut head = format!(
        "HTTP/1.1 {status} {}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\n\
         Cache-Control: no-store\r\nConnection: close\r\nX-Content-Type-Options: nosniff\r\n\
         Referrer-Policy: no-referrer\r\nX-Frame-Options: DENY\r\n\
         Content-Security-Policy: default-src 'self'; img-src 'self' blob: data:; frame-ancestors 'none'\r\n",
        reason(status),
        body.len()
    );
    if let Some(c) = set_cookie {
        head.push_str(&format!("Set-Cookie: {c}\r\n"));
    }
    head.push_str("\r\n");
    let _ = s.set_write_timeout(Some(timeout));
    let mut w = s;
    let mut msg = head.into_bytes();
    msg.extend_from_slice(body);
    if w.write_all(&msg).is_err() {
        return;
    }
    let _ = w.flush();
    let _ = s.shutdown(Shutdown::Write);
    // Drain briefly: closing with unread input would reset the connection.
    let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
    let mut sink = [0u8; 16 << 10];
    let mut left = 2 * super::MAX_BODY;
    let mut r = s;
    while left > 0 {
        match r.read(&mut sink) {
            Ok(0) | Err(_) => break,
            Ok(n) => left = left.saturating_sub(n),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(target: &str, headers: &[(&str, &str)], body: &[u8]) -> Request {
        Request {
            method: "POST".into(),
            target: target.into(),
            headers: headers.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
            body: body.to_vec(),
        }
    }

    #[test]
    fn the_guard_checks_host_origin_token_and_content_type() {
        let g = Guard::new("abc123".into(), 4000);
        let h = ("host", "127.0.0.1:4000");
        let t = (TOKEN_HEADER, "abc123");
        let j = ("content-type", "application/json; charset=utf-8");
        assert!(matches!(g.admit(&req("/api/state", &[h, t], b"")), Ok(false)));
        assert!(g.admit(&req("/api/save", &[("host", "LOCALHOST:4000"), t, j], b"{}")).is_ok());
        let cookie = ("cookie", "a=b; trimorph_token_4000=abc123");
        assert!(g.admit(&req("/api/save", &[h, cookie, j], b"{}")).is_ok());
        let status = |r: Request| g.admit(&r).err().map(|e| e.status());
        assert_eq!(status(req("/api/state", &[h], b"")), Some(401));
        assert_eq!(status(req("/api/state", &[h, (TOKEN_HEADER, "abc12")], b"")), Some(401));
        assert_eq!(
            status(req("/api/state", &[h, ("cookie", "trimorph_token_4001=abc123")], b"")),
            Some(401)
        );
        for host in ["evil.example:4000", "127.0.0.1:4001", "127.0.0.1", ""] {
            assert_eq!(status(req("/api/state", &[("host", host), t], b"")), Some(403), "{host}");
            assert_eq!(status(req("/", &[("host", host)], b"")), Some(403), "{host}");
        }
        for o in ["http://evil.example", "null", "https://127.0.0.1:4000", "http://127.0.0.1:4001"]
        {
            assert_eq!(status(req("/api/state", &[h, t, ("origin", o)], b"")), Some(403), "{o}");
        }
        assert!(g
            .admit(&req("/api/state", &[h, t, ("origin", "http://127.0.0.1:4000")], b""))
            .is_ok());
        assert_eq!(
            status(req("/api/state", &[h, t, ("sec-fetch-site", "cross-site")], b"")),
            Some(403)
        );
        for ct in ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data", ""] {
            let r = req("/api/save", &[h, t, ("content-type", ct)], b"{\"path\":\"x\"}");
            assert_eq!(status(r), Some(415), "{ct}");
        }
        // The page: served to anyone local, the cookie only with the right token.
        assert!(matches!(g.admit(&req("/?token=abc123", &[h], b"")), Ok(true)));
        assert!(matches!(g.admit(&req("/?token=abc", &[h], b"")), Ok(false)));
        assert!(matches!(g.admit(&req("/app.js?token=abc123", &[h], b"")), Ok(false)));
    }

    #[test]
    fn random_tokens_are_128_bit_hex_and_differ() {
        let (a, b) = (Guard::random(1), Guard::random(1));
        assert_eq!(a.token().len(), 32);
        assert!(a.token().bytes().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a.token(), b.token());
    }
}
