//! `trimorph editor` through the binary: it prints its 127.0.0.1 address with the session
//! token and serves the API to requests that carry it;
//! bad inputs exit 1 with a message naming the file.

use crate::common;
use common::{edit_script, trimorph};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};

/// Also the regression test of a bug: the editor panicked (HTTP 500) when the process that
/// started it closed the pipe after reading the address line.
#[test]
fn editor_prints_a_loopback_address_and_serves_the_bundled_scene() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_trimorph"))
        .args(["editor", "--port", "0"])
        .current_dir(dir.path())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no address in `{line}`"))
        .to_string();
    let rest = url.strip_prefix("http://").unwrap();
    let (addr, query) = rest.split_once("/?token=").unwrap_or_else(|| panic!("no token: {line}"));
    assert!(addr.starts_with("127.0.0.1:"), "{line}");
    assert!(query.len() == 32 && query.bytes().all(|c| c.is_ascii_hexdigit()), "{line}");
    let get = |token: &str| {
        let mut s = TcpStream::connect(addr).unwrap();
        write!(
            s,
            "GET /api/state HTTP/1.1\r\nHost: {addr}\r\nX-Trimorph-Token: {token}\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        out
    };
    let out = get(query);
    let refused = get("0");
    child.kill().unwrap();
    let _ = child.wait();
    assert!(refused.starts_with("HTTP/1.1 401"), "{refused}");
    assert!(out.starts_with("HTTP/1.1 200"), "{out}");
    assert!(out.contains("\"points\":1681") && out.contains("bundled worm scene"), "{out}");
}

#[test]
fn editor_refuses_bad_inputs_before_serving() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.json");
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{\"format\": \"something else\"}").unwrap();
    for (file, msg) in [(&missing, "missing.json"), (&bad, "cannot read deformation")] {
        let o = trimorph(&["editor", file.to_str().unwrap(), "--port", "0"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(msg), "expected `{msg}` in: {err}");
    }
}

/// The editor's API refuses absurd values with 422; `trimorph edit` refuses them too
/// (exit 1, nothing written), and `check` reports non-finite control points as an error.
#[test]
fn edit_refuses_absurd_values_like_the_editor() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    let o = trimorph(&["mesh", "--grid", "4x3", "--size", "400,300", "-o", id.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let script = dir.path().join("edits.json");
    std::fs::write(
        &script,
        r#"[{"anchors": {"near": [[200, 100]]}, "neighborhood": 2, "op": "translate", "by": [1e308, 1e308]}]"#,
    )
    .unwrap();
    let out = dir.path().join("out.json");
    let o = edit_script(&id, &script, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("edits.json") && err.contains("beyond"), "{err}");
    assert!(!out.exists(), "nothing is written");
}

/// `trimorph editor SCENE.json` starts with the scene's landmark pairs.
#[test]
fn editor_starts_with_a_scenes_landmark_pairs() {
    use trimorph::mesh::{Mesh, MeshOptions};
    use trimorph::server::doc::Doc;
    use trimorph::spline::Spline;
    let dir = tempfile::tempdir().unwrap();
    let mesh = Mesh::grid(4, 4, 100.0, 100.0, MeshOptions::default()).unwrap();
    let mut d = Doc::new(Spline::identity(mesh, 5).unwrap(), dir.path());
    d.add_pair(Some("tip".into()), [20.0, 30.0], [22.5, 31.0]).unwrap();
    d.add_pair(None, [70.0, 60.0], [69.0, 64.0]).unwrap();
    d.save("s.json", true).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_trimorph"))
        .args(["editor", "s.json", "--port", "0"])
        .current_dir(dir.path())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("http://")).unwrap().to_string();
    let (addr, token) = url.strip_prefix("http://").unwrap().split_once("/?token=").unwrap();
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET /api/landmarks HTTP/1.1\r\nHost: {addr}\r\nX-Trimorph-Token: {token}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    child.kill().unwrap();
    let _ = child.wait();
    assert!(out.starts_with("HTTP/1.1 200"), "{out}");
    let body: serde_json::Value =
        serde_json::from_str(out.split("\r\n\r\n").nth(1).unwrap()).unwrap();
    let names: Vec<&str> =
        body["pairs"].as_array().unwrap().iter().map(|p| p["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["tip", "P1"], "{out}");
    assert_eq!(body["pairs"][0]["dst"], serde_json::json!([22.5, 31.0]));
}
