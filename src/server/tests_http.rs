//! The HTTP layer over real sockets: the token, Host, Origin and content-type checks, a
//! stalled client, and concurrent requests ([`super::http`]).

use super::tests::{http, Running};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

fn raw(addr: std::net::SocketAddr, text: &str) -> (u16, String) {
    let (st, body) = http(addr, text, b"");
    (st, String::from_utf8_lossy(&body).into_owned())
}

#[test]
fn api_requests_need_the_session_token() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Running::start(dir.path(), Duration::from_secs(5));
    let a = srv.addr;
    let no_token = format!("GET /api/state HTTP/1.1\r\nHost: {a}\r\nConnection: close\r\n\r\n");
    assert_eq!(raw(a, &no_token).0, 401);
    let wrong = format!(
        "GET /api/state HTTP/1.1\r\nHost: {a}\r\nX-Trimorph-Token: {}0\r\nConnection: close\r\n\r\n",
        srv.token
    );
    assert_eq!(raw(a, &wrong).0, 401);
    assert_eq!(raw(a, &srv.head("GET", "/api/state", "")).0, 200);
    // The page loads without the token, but only the address with it sets the cookie.
    let page = |q: &str| {
        let mut s = TcpStream::connect(a).unwrap();
        write!(s, "GET /{q} HTTP/1.1\r\nHost: {a}\r\nConnection: close\r\n\r\n").unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        out
    };
    let plain = page("");
    assert!(plain.starts_with("HTTP/1.1 200") && !plain.contains("Set-Cookie"), "{plain}");
    let with = page(&format!("?token={}", srv.token));
    let name = format!("trimorph_token_{}", a.port());
    let cookie = with
        .lines()
        .find_map(|l| l.strip_prefix("Set-Cookie: "))
        .unwrap_or_else(|| panic!("no cookie: {with}"));
    assert!(cookie.starts_with(&format!("{name}={};", srv.token)), "{cookie}");
    assert!(cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"), "{cookie}");
    assert!(with.contains("Referrer-Policy: no-referrer"), "the token must not leak");
    // The cookie alone admits an API request (the page's <img> requests).
    let by_cookie = format!(
        "GET /api/image.png HTTP/1.1\r\nHost: {a}\r\nCookie: {name}={}\r\nConnection: close\r\n\r\n",
        srv.token
    );
    assert_ne!(raw(a, &by_cookie).0, 401);
}

#[test]
fn foreign_hosts_origins_and_non_json_bodies_are_refused_before_anything_happens() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Running::start(dir.path(), Duration::from_secs(5));
    let a = srv.addr;
    let save = br#"{"path": "x.json"}"#;
    let post = |head: String| {
        let (st, b) = http(a, &head, save);
        (st, String::from_utf8_lossy(&b).into_owned())
    };
    let len = format!("Content-Length: {}\r\n", save.len());
    // DNS rebinding: a foreign Host, even with the token.
    let rebound = format!(
        "POST /api/save HTTP/1.1\r\nHost: evil.example:{}\r\nX-Trimorph-Token: {}\r\nContent-Type: application/json\r\n{len}Connection: close\r\n\r\n",
        a.port(),
        srv.token
    );
    assert_eq!(post(rebound).0, 403);
    let foreign = format!("Origin: http://evil.example\r\nContent-Type: application/json\r\n{len}");
    let (st, v) = post(srv.head("POST", "/api/save", &foreign));
    assert_eq!(st, 403, "{v}");
    // The cross-site "simple request": text/plain.
    let (st, v) =
        post(srv.head("POST", "/api/save", &format!("Content-Type: text/plain\r\n{len}")));
    assert_eq!(st, 415, "{v}");
    assert!(!dir.path().join("x.json").exists(), "a refused request wrote a file");
    let ok = format!(
        "Origin: http://127.0.0.1:{}\r\nContent-Type: application/json; charset=utf-8\r\n{len}",
        a.port()
    );
    let (st, v) = post(srv.head("POST", "/api/save", &ok));
    assert_eq!(st, 200, "{v}");
    assert!(dir.path().join("x.json").exists());
    let local = format!(
        "GET /api/state HTTP/1.1\r\nHost: localhost:{}\r\nX-Trimorph-Token: {}\r\nConnection: close\r\n\r\n",
        a.port(),
        srv.token
    );
    assert_eq!(raw(a, &local).0, 200);
}

#[test]
fn a_stalled_client_does_not_block_others_and_times_out() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Running::start(dir.path(), Duration::from_millis(800));
    let a = srv.addr;
    // One client declares a body and stops sending; another sends nothing at all.
    let mut stalled = TcpStream::connect(a).unwrap();
    let head = srv.head(
        "POST",
        "/api/select",
        "Content-Type: application/json\r\nContent-Length: 100\r\n",
    );
    stalled.write_all(head.as_bytes()).unwrap();
    stalled.write_all(b"{\"anch").unwrap();
    let _silent = TcpStream::connect(a).unwrap();
    std::thread::sleep(Duration::from_millis(50));
    let t0 = Instant::now();
    let (st, _) = raw(a, &srv.head("GET", "/api/state", ""));
    let took = t0.elapsed();
    assert_eq!(st, 200);
    assert!(took < Duration::from_secs(1), "answered after {took:?}");
    // The stalled request is answered 408 once the read timeout is over.
    stalled.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut out = String::new();
    let _ = stalled.read_to_string(&mut out);
    assert!(out.starts_with("HTTP/1.1 408"), "{out}");
}

#[test]
fn concurrent_requests_are_all_answered() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Running::start(dir.path(), Duration::from_secs(5));
    let t0 = Instant::now();
    std::thread::scope(|s| {
        let hs: Vec<_> = (0..8)
            .map(|k| {
                let srv = &srv;
                s.spawn(move || {
                    for i in 0..10 {
                        let body = format!(r#"{{"x": {}, "y": {}}}"#, 10 * k, 7 * i);
                        let head = srv.head(
                            "POST",
                            "/api/pick",
                            &format!(
                                "Content-Type: application/json\r\nContent-Length: {}\r\n",
                                body.len()
                            ),
                        );
                        let (st, out) = http(srv.addr, &head, body.as_bytes());
                        assert_eq!(st, 200, "{}", String::from_utf8_lossy(&out));
                        let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
                        assert!(v["index"].is_u64(), "{v}");
                    }
                })
            })
            .collect();
        for h in hs {
            h.join().unwrap();
        }
    });
    assert!(t0.elapsed() < Duration::from_secs(30));
}

/// Sends `head` and then `body` slowly enough to matter, and reads the answer's status.
fn status_after(addr: std::net::SocketAddr, head: &str, body: &[u8]) -> (u16, Duration) {
    let t0 = Instant::now();
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(head.as_bytes()).unwrap();
    let _ = s.write_all(body);
    let mut out = String::new();
    let _ = s.read_to_string(&mut out);
    let st = out.get(9..12).and_then(|c| c.parse().ok()).unwrap_or(0);
    (st, t0.elapsed())
}

/// Bug: a chunk of size 1 then one of size `ffffffffffffffff` overflowed the length sum, so
/// the cap never fired and the server buffered what arrived until its deadline (RSS 34 ->
/// 1,062 MiB), before the token was even checked. Now the token is checked on the head,
/// before any body byte is read, and the cap is compared without adding.
#[test]
fn a_chunk_length_overflow_is_refused_before_anything_is_buffered() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Running::start(dir.path(), Duration::from_secs(5));
    let a = srv.addr;
    let chunks = b"1\r\n{\r\nffffffffffffffff\r\nxxxxxxxxxxxxxxxx";
    // Without the token: 401 at once, the body never read.
    let head = format!(
        "POST /api/save HTTP/1.1\r\nHost: {a}\r\nContent-Type: application/json\r\n\
         Transfer-Encoding: chunked\r\nConnection: close\r\n\r\n"
    );
    let (st, took) = status_after(a, &head, chunks);
    assert_eq!(st, 401);
    assert!(took < Duration::from_secs(2), "answered after {took:?}");
    // With the token: 413 on the second chunk's size, not a timeout.
    let head = srv.head(
        "POST",
        "/api/save",
        "Content-Type: application/json\r\nTransfer-Encoding: chunked\r\n",
    );
    let (st, took) = status_after(a, &head, chunks);
    assert_eq!(st, 413);
    assert!(took < Duration::from_secs(2), "answered after {took:?}");
}

/// RFC 9112 section 3.2: a request with two Host headers gets 400, even when the first one
/// is this editor's (it was accepted).
#[test]
fn a_duplicated_host_header_is_a_bad_request() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Running::start(dir.path(), Duration::from_secs(5));
    let a = srv.addr;
    let twice = srv.head("GET", "/api/state", "Host: evil.example\r\n");
    assert_eq!(raw(a, &twice).0, 400);
    assert_eq!(raw(a, &srv.head("GET", "/api/state", "")).0, 200);
}
