use super::doc::Doc;
use super::*;
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::{ControlPoint, Spline};
use serde_json::{json, Value};
use std::io::{Read as _, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

pub(super) fn doc(root: &std::path::Path) -> Doc {
    let mesh = Mesh::grid(4, 4, 100.0, 100.0, MeshOptions::default()).unwrap();
    Doc::new(Spline::identity(mesh, 5).unwrap(), root)
}

pub(super) fn call(d: &mut Doc, method: &str, url: &str, body: Value) -> (u16, Value) {
    let b = if body.is_null() { Vec::new() } else { body.to_string().into_bytes() };
    let r = handle(d, method, url, &b);
    let v = serde_json::from_slice(&r.body).unwrap_or(Value::Null);
    (r.status, v)
}

/// The vertex at (50, 50): an interior corner point (corner points come first).
fn centre(d: &Doc) -> usize {
    let m = d.spline().mesh();
    (0..m.num_vertices()).find(|&v| m.vertex(v) == [50.0, 50.0]).unwrap()
}

#[test]
fn select_update_undo_redo_round_trip_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let before = d.spline().points().to_vec();
    let c = centre(&d);
    let (st, v) = call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    assert_eq!(st, 200, "{v}");
    assert!(!v["derived"].as_array().unwrap().is_empty());
    for step in 1..=3 {
        let (st, v) = call(
            &mut d,
            "POST",
            "/api/update",
            json!({"op": "translate", "v": [step as f64 * 1.5, -1.0]}),
        );
        assert_eq!(st, 200, "{v}");
        let p: Vec<f64> =
            v["points"][c].as_array().unwrap().iter().filter_map(Value::as_f64).collect();
        assert_eq!(p, [50.0 + step as f64 * 1.5, 49.0]);
    }
    let q = d.spline().point_f64(c);
    assert_eq!(q, [54.5, 49.0]);
    d.spline().check_c1().unwrap();
    let (_, st) = call(&mut d, "GET", "/api/state", Value::Null);
    assert_eq!(st["undo"], 1, "one drag = one undo step");
    assert_eq!(st["pinned"], json!([c]));
    let after = d.spline().points().to_vec();
    assert_eq!(call(&mut d, "POST", "/api/undo", Value::Null).0, 200);
    assert_eq!(d.spline().points(), &before[..]);
    assert_eq!(call(&mut d, "POST", "/api/redo", Value::Null).0, 200);
    assert_eq!(d.spline().points(), &after[..]);
    let (st, v) = call(&mut d, "POST", "/api/redo", Value::Null);
    assert_eq!(st, 422, "{v}");
    assert!(v["error"].as_str().unwrap().contains("nothing to redo"));
}

#[test]
fn a_refused_edit_answers_422_and_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let c = centre(&d);
    let (st, v) = call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 1}));
    assert_eq!(st, 200, "{v}");
    let before = d.spline().points().to_vec();
    for body in [
        json!({"op": "scale", "center": [50.0, 50.0], "factor": -1.0}),
        json!({"op": "translate", "v": [1.0]}),
        json!({"op": "scale", "center": [50.0], "factor": 2.0}),
    ] {
        let (st, v) = call(&mut d, "POST", "/api/update", body.clone());
        assert_eq!(st, 422, "{body}: {v}");
        assert_eq!(d.spline().points(), &before[..], "{body} changed the spline");
    }
    assert_eq!(call(&mut d, "GET", "/api/state", Value::Null).1["undo"], 0);
    // Anchors that are no control points, empty anchor sets, bad modes.
    let n = d.spline().num_points();
    for (body, status) in [
        (json!({"anchors": [n + 5]}), 422),
        (json!({"anchors": []}), 422),
        (json!({"anchors": [c, c]}), 422),
        (json!({"anchors": [c], "mode": "z0"}), 422),
        (json!({"anchors": [c], "mode": "zz"}), 400),
        (json!({"anchors": "x"}), 400),
    ] {
        let (st, v) = call(&mut d, "POST", "/api/select", body.clone());
        assert_eq!(st, status, "{body}: {v}");
        assert!(v["error"].is_string());
    }
    let (st, _) = call(&mut d, "POST", "/api/update", json!({"op": "spin", "v": [1.0]}));
    assert_eq!(st, 400);
    let r = handle(&mut d, "POST", "/api/update", br#"{"op": "translate", "v": [1e400, 0]}"#);
    assert_eq!(r.status, 400);
}

#[test]
fn rotate_and_scale_keep_c1_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let c = centre(&d);
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 3}));
    let (st, v) = call(
        &mut d,
        "POST",
        "/api/update",
        json!({"op": "rotate", "center": [40.0, 40.0], "angle": 0.2}),
    );
    assert_eq!(st, 200, "{v}");
    d.spline().check_c1().unwrap();
    let (st, v) = call(
        &mut d,
        "POST",
        "/api/update",
        json!({"op": "scale", "center": [50.0, 50.0], "factor": 1.25}),
    );
    assert_eq!(st, 200, "{v}");
    d.spline().check_c1().unwrap();
}

#[test]
fn save_and_load_stay_inside_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let c = centre(&d);
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [2.0, 1.0]}));
    let (st, v) = call(&mut d, "POST", "/api/save", json!({"path": "e.json"}));
    assert_eq!(st, 200, "{v}");
    let text = std::fs::read_to_string(dir.path().join("e.json")).unwrap();
    let (s, _) = crate::io::deformation::from_str(&text).unwrap();
    assert_eq!(s.points(), d.spline().points());
    assert_eq!(crate::io::deformation::pinned_from_str(&text).unwrap(), vec![ControlPoint(c)]);
    for p in ["../e.json", "/tmp/e.json", "a/../../e.json"] {
        let (st, v) = call(&mut d, "POST", "/api/save", json!({ "path": p }));
        assert_eq!(st, 403, "{p}: {v}");
        let (st, _) = call(&mut d, "POST", "/api/load", json!({ "path": p }));
        assert_eq!(st, 403, "{p}");
    }
    // A bad file changes nothing.
    std::fs::write(dir.path().join("bad.json"), "{\"format\": 3").unwrap();
    let pts = d.spline().points().to_vec();
    let (st, v) = call(&mut d, "POST", "/api/load", json!({"path": "bad.json"}));
    assert_eq!(st, 422, "{v}");
    assert_eq!(d.spline().points(), &pts[..]);
    // Loading the identity back over the same mesh is one undoable step.
    let id = Spline::identity(d.spline().mesh().clone(), 5).unwrap();
    std::fs::write(dir.path().join("id.json"), crate::io::deformation::to_string(&id, None))
        .unwrap();
    let (st, v) = call(&mut d, "POST", "/api/load", json!({"path": "id.json"}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(d.spline().points(), id.points());
    call(&mut d, "POST", "/api/undo", Value::Null);
    assert_eq!(d.spline().points(), &pts[..]);
}

#[test]
fn only_embedded_assets_and_the_api_are_served() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("secret.txt"), "x").unwrap();
    let mut d = doc(dir.path());
    let r = handle(&mut d, "GET", "/", b"");
    assert_eq!(r.status, 200);
    assert!(String::from_utf8_lossy(&r.body).contains("trimorph editor"));
    assert_eq!(handle(&mut d, "GET", "/app.js", b"").status, 200);
    for p in ["/secret.txt", "/../secret.txt", "/src/server/mod.rs", "/api/nothing", "/index.html"]
    {
        assert_eq!(handle(&mut d, "GET", p, b"").status, 404, "{p}");
    }
    assert_eq!(handle(&mut d, "POST", "/api/select", b"{not json").status, 400);
    let g = call(&mut d, "GET", "/api/geometry?full=1", Value::Null).1;
    assert_eq!(g["points"].as_array().unwrap().len(), d.spline().num_points());
    assert_eq!(g["quads"].as_array().unwrap().len(), d.spline().quads().len());
    assert!(!g["net"].as_array().unwrap().is_empty());
    assert_eq!(handle(&mut d, "GET", "/api/jacobian.png", b"").content_type, "image/png");
}

/// A raw HTTP/1.1 request; returns the status and the body.
pub(super) fn http(addr: SocketAddr, head: &str, body: &[u8]) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.write_all(head.as_bytes()).unwrap();
    let _ = s.write_all(body);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out);
    let status = text.split_whitespace().nth(1).and_then(|x| x.parse().ok()).unwrap_or(0);
    let body = match out.windows(4).position(|w| w == b"\r\n\r\n") {
        Some(i) => out[i + 4..].to_vec(),
        None => Vec::new(),
    };
    (status, body)
}

/// A server on a free port with `doc` in a thread; stopped and joined on drop.
pub(super) struct Running {
    pub addr: SocketAddr,
    pub token: String,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Running {
    pub fn start(root: &std::path::Path, read_timeout: std::time::Duration) -> Running {
        Running::start_with(root, read_timeout, super::net::MAX_CONNECTIONS)
    }

    /// [`Running::start`] with at most `max_connections` connections at once.
    pub fn start_with(
        root: &std::path::Path,
        read_timeout: std::time::Duration,
        max_connections: usize,
    ) -> Running {
        let server = Server::bind(0)
            .unwrap()
            .with_timeouts(read_timeout, std::time::Duration::from_secs(5))
            .with_max_connections(max_connections);
        let (addr, token) = (server.addr(), server.token().to_string());
        let stop = Arc::new(AtomicBool::new(false));
        let stop2 = stop.clone();
        let root = root.to_path_buf();
        let thread = std::thread::spawn(move || {
            let mut d = doc(&root);
            server.run(&mut d, &|| stop2.load(Ordering::Relaxed));
        });
        Running { addr, token, stop, thread: Some(thread) }
    }

    /// Request headers with the right Host and token.
    pub fn head(&self, method: &str, path: &str, extra: &str) -> String {
        format!(
            "{method} {path} HTTP/1.1\r\nHost: {}\r\nX-Trimorph-Token: {}\r\n{extra}Connection: close\r\n\r\n",
            self.addr, self.token
        )
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn the_server_binds_loopback_and_bounds_request_bodies() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Running::start(dir.path(), std::time::Duration::from_secs(5));
    let addr = srv.addr;
    assert!(addr.ip().is_loopback(), "{addr}");
    assert_eq!(addr.ip().to_string(), "127.0.0.1");
    let (st, body) = http(addr, &srv.head("GET", "/api/state", ""), b"");
    assert_eq!(st, 200);
    let v: Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["degree"], 5);
    // Declared too large: refused without reading it.
    let cl = format!("Content-Type: application/json\r\nContent-Length: {}\r\n", MAX_BODY + 1);
    let (st, _) = http(addr, &srv.head("POST", "/api/select", &cl), b"{}");
    assert_eq!(st, 413);
    // Chunked and too large: cut off after MAX_BODY bytes.
    let big = vec![b' '; MAX_BODY + 10];
    let mut chunked = format!("{:x}\r\n", big.len()).into_bytes();
    chunked.extend(&big);
    chunked.extend(b"\r\n0\r\n\r\n");
    let te = "Content-Type: application/json\r\nTransfer-Encoding: chunked\r\n";
    let (st, _) = http(addr, &srv.head("POST", "/api/select", te), &chunked);
    assert_eq!(st, 413);
    // A small chunked body is decoded.
    let body = br#"{"x": 50, "y": 50}"#;
    let mut small = format!("{:x}\r\n", body.len()).into_bytes();
    small.extend(body.as_slice());
    small.extend(b"\r\n0\r\n\r\n");
    let (st, out) = http(addr, &srv.head("POST", "/api/pick", te), &small);
    assert_eq!(st, 200, "{}", String::from_utf8_lossy(&out));
    let (st, _) = http(addr, &srv.head("GET", "/etc/passwd", ""), b"");
    assert_eq!(st, 404);
}

/// A 2.5D document with a small worm model and a 101 x 101 frame.
fn doc25(root: &std::path::Path) -> Doc {
    use crate::prism::organism::{worm, WormOptions};
    let mesh = Mesh::grid(4, 4, 100.0, 100.0, MeshOptions::default()).unwrap();
    let mut s = Spline::identity(mesh, 5).unwrap();
    let z =
        crate::prism::identity_layers(&s, crate::exact::rat_int(-10), crate::exact::rat_int(10))
            .unwrap();
    s.set_z_layers(Some(z));
    let mut m = worm(&WormOptions { length: 60.0, radius: 5.0, bend: 5.0, rings: 20, around: 8 });
    for v in m.vertices.iter_mut() {
        v[0] += 20.0;
        v[1] += 50.0;
    }
    let mut d = Doc::new(s, root);
    d.set_model("worm.obj".into(), m).unwrap();
    let img = image::GrayImage::from_fn(101, 101, |x, y| image::Luma([((x * 2 + y) % 256) as u8]));
    d.set_frame("frame.png".into(), image::DynamicImage::ImageLuma8(img)).unwrap();
    d
}

#[test]
fn z_modes_edit_the_layers_and_move_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc25(dir.path());
    let c = centre(&d);
    let z1_before = d.spline().z_layers().unwrap().z1.clone();
    let model_before = d.deformed_model().unwrap();
    let (st, v) =
        call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2, "mode": "z1"}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["z1"].as_array().unwrap().len(), d.spline().num_points(), "z views in z modes");
    let (st, v) = call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [4.0]}));
    assert_eq!(st, 200, "{v}");
    let z = d.spline().z_layers().unwrap();
    assert_eq!(z.z1[c], &z1_before[c] + crate::exact::rat_int(4));
    assert_ne!(d.deformed_model().unwrap(), model_before, "the model's top moved");
    d.spline().check_c1().unwrap();
    // xy answers leave the z views out.
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    let (_, v) = call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [1.0, 0.0]}));
    assert!(v.get("z1").is_none() && v.get("model").is_none() && v["model_outline"].is_array());
}

#[test]
fn export_and_scene_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc25(dir.path());
    let c = centre(&d);
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [3.0, 2.0]}));
    let (st, v) = call(&mut d, "POST", "/api/export", json!({"kind": "obj", "path": "w.obj"}));
    assert_eq!(st, 200, "{v}");
    let m = crate::io::model::load_model(&dir.path().join("w.obj")).unwrap();
    assert_eq!(m.vertices.len(), d.model().unwrap().model.vertices.len());
    let (st, v) = call(&mut d, "POST", "/api/export", json!({"kind": "warped", "path": "w.png"}));
    assert_eq!(st, 200, "{v}");
    let img = image::open(dir.path().join("w.png")).unwrap();
    assert_eq!((img.width(), img.height()), (101, 101));
    let (st, _) = call(&mut d, "POST", "/api/export", json!({"kind": "svg", "path": "w.svg"}));
    assert_eq!(st, 400);
    // A scene names its model and image; loading it back restores everything.
    crate::io::model::save_model(
        &d.model().unwrap().model,
        &d.model().unwrap().model.vertices,
        &dir.path().join("worm.obj"),
    )
    .unwrap();
    d.frame().unwrap().image.save(dir.path().join("frame.png")).unwrap();
    let (st, v) = call(&mut d, "POST", "/api/save", json!({"path": "scene.json", "scene": true}));
    assert_eq!(st, 200, "{v}");
    let text = std::fs::read_to_string(dir.path().join("scene.json")).unwrap();
    assert!(text.contains("\"model\"") && text.contains("\"image\""));
    let mut e = doc(dir.path());
    let (st, v) = call(&mut e, "POST", "/api/load", json!({"path": "scene.json"}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(e.spline().points(), d.spline().points());
    assert!(e.model().is_some() && e.frame().is_some());
    assert_eq!(e.pinned().iter().copied().collect::<Vec<_>>(), vec![ControlPoint(c)]);
}

#[test]
fn refit_holds_the_corrected_points_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let c = centre(&d);
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [2.0, -1.0]}));
    let corrected = d.spline().points()[c].clone();
    std::fs::write(
        dir.path().join("l.csv"),
        "name,src_x,src_y,dst_x,dst_y\na,20,20,22,21\nb,80,20,81,22\nc,20,80,21,79\nd,80,80,82,81\n",
    )
    .unwrap();
    let (st, v) = call(&mut d, "POST", "/api/refit", json!({"landmarks": "l.csv", "hard": true}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["pinned"], 1);
    assert_eq!(d.spline().points()[c], corrected);
    d.spline().check_c1().unwrap();
    assert_eq!(call(&mut d, "GET", "/api/state", Value::Null).1["undo"], 2);
    let (st, _) = call(&mut d, "POST", "/api/refit", json!({"landmarks": "../l.csv"}));
    assert_eq!(st, 403);
}

/// The geometry is written as text without a `Value` tree: it must still be valid JSON, and
/// the mesh polylines (sample points located once per document) must be phi along each
/// reference edge after edits.
#[test]
fn geometry_text_is_json_and_the_mesh_lines_follow_phi() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let c = centre(&d);
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    let (st, v) = call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [3, -2]}));
    assert_eq!(st, 200, "{v}");
    assert!(v["server_ms"].as_f64().is_some() && v["state"]["undo"].is_number(), "{v}");
    let (_, g) = call(&mut d, "GET", "/api/geometry?full=1", Value::Null);
    let (s, mesh) = (d.spline(), d.spline().mesh());
    let mut edges: Vec<(usize, usize)> = (0..mesh.num_triangles())
        .flat_map(|t| {
            let v = mesh.triangle(t);
            [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])].map(|(a, b)| (a.min(b), a.max(b)))
        })
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let lines = g["mesh"].as_array().unwrap();
    assert_eq!(lines.len(), edges.len());
    for (line, &(a, b)) in lines.iter().zip(&edges) {
        let line = line.as_array().unwrap();
        assert_eq!(line.len(), doc::EDGE_SAMPLES + 1);
        for (k, q) in line.iter().enumerate() {
            let u = k as f64 / doc::EDGE_SAMPLES as f64;
            let (pa, pb) = (mesh.vertex(a), mesh.vertex(b));
            let p = [pa[0] + u * (pb[0] - pa[0]), pa[1] + u * (pb[1] - pa[1])];
            let want = s.eval(p, None).unwrap();
            for i in 0..2 {
                let got = q[i].as_f64().unwrap();
                assert!((got - want[i]).abs() <= 5e-4 + 1e-9, "edge {a}-{b} sample {k}");
            }
        }
    }
    assert_eq!(g["points"].as_array().unwrap().len(), s.num_points());
}

#[test]
fn json_object_writes_null_for_non_finite_numbers() {
    let mut o = views::JsonObject::new();
    o.numbers("a", [1.0, f64::NAN, 2.5, f64::INFINITY]);
    o.points("p", [[0.1234, -7.0]]);
    o.value("s", &json!({"k": "x\"y"}));
    let v: Value = serde_json::from_str(&o.finish()).unwrap();
    assert_eq!(v["a"].to_string(), "[1,null,2.5,null]");
    assert_eq!(v["p"][0][0].as_f64(), Some(0.123));
    assert_eq!(v["s"]["k"], "x\"y");
    assert_eq!(views::JsonObject::new().finish(), "{}");
    // Rounded to 1/1000 and written without float formatting: check against it.
    let samples = [0.0, -0.0, 0.0004, -0.0004, 0.0005, 1.05, -1.05, 12.3456, -0.001, 99.9999];
    let more = [-7.25, 1e14, -3e15, 123456.789, 0.010, 5e-7];
    let mut o = views::JsonObject::new();
    o.numbers("n", samples.iter().chain(&more).copied());
    let v: Value = serde_json::from_str(&o.finish()).unwrap();
    for (got, x) in v["n"].as_array().unwrap().iter().zip(samples.iter().chain(&more)) {
        let want = (x * 1000.0).round() / 1000.0;
        assert_eq!(got.as_f64().unwrap(), want, "{x} written as {got}");
    }
}

#[test]
fn drag_answers_carry_the_det_j_certificate_of_the_whole_spline() {
    use crate::spline::jacobian::{certify, CertifyOptions};
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let (_, st) = call(&mut d, "GET", "/api/state", Value::Null);
    assert_eq!(st["fold_free"], true);
    assert_eq!(st["folding_triangles"], json!([]));
    let c = centre(&d);
    let (st, _) = call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 1}));
    assert_eq!(st, 200);
    // Small steps stay fold-free; dragging past the neighbour vertex (25 away) folds.
    for (dx, fold_free) in [(3.0, true), (35.0, false), (2.0, true)] {
        let (st, v) =
            call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [dx, 0.0]}));
        assert_eq!(st, 200, "{v}");
        let full = certify(d.spline(), &CertifyOptions::default());
        assert_eq!(v["fold_free"], fold_free, "drag by {dx}");
        assert_eq!(v["folding_triangles"], json!(full.folding), "the cache agrees with a full run");
        assert_eq!(v["det_j_lower_bound"].as_f64(), Some(full.lower_bound));
        assert_eq!(v["det_j_sampled_min"].as_f64(), Some(full.sampled_min));
        assert_eq!(v["state"]["fold_free"], fold_free);
        assert_eq!(v["folding_outline"].as_array().unwrap().len(), 6 * full.folding.len());
    }
    call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [35.0, 0.0]}));
    let (_, v) = call(&mut d, "POST", "/api/undo", Value::Null);
    assert_eq!(v["fold_free"], true, "undo restores the identity");
}

/// Regression test: the API accepted `translate [1e308, 1e308]` and the next answer had
/// `null` coordinates.
#[test]
fn absurd_values_are_refused_with_422_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let c = centre(&d);
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    let (st, _) = call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [2.0, 1.0]}));
    assert_eq!(st, 200);
    let before = d.spline().points().to_vec();
    for body in [
        json!({"op": "translate", "v": [1e308, 1e308]}),
        json!({"op": "translate", "v": [2e6, 0.0]}),
        json!({"op": "rotate", "center": [1e300, 0.0], "angle": 0.1}),
        json!({"op": "rotate", "center": [50.0, 50.0], "angle": 1e9}),
        json!({"op": "scale", "center": [50.0, 50.0], "factor": 1e9}),
        json!({"op": "scale", "center": [50.0, 50.0], "factor": 1e-9}),
        // Arguments within range whose result is not: 5e5 * 3 away from the centre.
        json!({"op": "scale", "center": [-5e5, 0.0], "factor": 3.0}),
    ] {
        let (st, v) = call(&mut d, "POST", "/api/update", body.clone());
        assert_eq!(st, 422, "{body}: {v}");
        assert_eq!(d.spline().points(), &before[..], "{body} changed the spline");
    }
    // The drag goes on from where it was; one undo step in all.
    let (st, v) = call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [3.0, 1.0]}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(d.spline().point_f64(c), [53.0, 51.0]);
    assert!(v["points"].as_array().unwrap().iter().all(|p| p[0].is_number() && p[1].is_number()));
    assert_eq!(call(&mut d, "GET", "/api/state", Value::Null).1["undo"], 1);
    // A file with an absurd control point is refused on load.
    // (All points shifted: an affine map stays C1.)
    let mut far = d.spline().clone();
    let shift = crate::exact::rat_int(10_000_000);
    let pts: Vec<Vec<crate::exact::Rat>> =
        far.points().iter().map(|p| vec![&p[0] + &shift, p[1].clone()]).collect();
    far.set_points(pts).unwrap();
    std::fs::write(dir.path().join("far.json"), crate::io::deformation::to_string(&far, None))
        .unwrap();
    let (st, v) = call(&mut d, "POST", "/api/load", json!({"path": "far.json"}));
    assert_eq!(st, 422, "{v}");
    assert!(v["error"].as_str().unwrap().contains("control point 0 is at"), "{v}");
    assert_eq!(d.spline().point_f64(c), [53.0, 51.0]);
}

/// "Save scene" dropped the bundled model and frame without saying so.
#[test]
fn a_scene_keeps_its_model_and_frame_and_stat_answers_before_saves_and_loads() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc25(dir.path()); // model and frame have no file in the folder
    let (_, v) = call(&mut d, "POST", "/api/stat", json!({"path": "s.json"}));
    assert_eq!(v["exists"], false);
    assert_eq!(v["scene_copies"], json!([]));
    let (st, v) = call(&mut d, "POST", "/api/save", json!({"path": "s.json", "scene": true}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["written"], json!(["s.model.obj", "s.frame.png"]));
    let (_, v) = call(&mut d, "POST", "/api/stat", json!({"path": "s.json"}));
    assert_eq!(v["exists"], true);
    assert_eq!(v["same_layout"], true);
    assert_eq!(v["scene_copies"], json!(["s.model.obj", "s.frame.png"]));
    let other = Mesh::grid(3, 3, 100.0, 100.0, MeshOptions::default()).unwrap();
    let mut e = Doc::new(Spline::identity(other, 5).unwrap(), dir.path());
    let (_, v) = call(&mut e, "POST", "/api/stat", json!({"path": "s.json"}));
    assert_eq!(v["same_layout"], false, "another mesh: a new document");
    let (st, v) = call(&mut e, "POST", "/api/load", json!({"path": "s.json"}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(e.model().unwrap().model.vertices, d.model().unwrap().model.vertices);
    let (f, g) = (&e.frame().unwrap().image, &d.frame().unwrap().image);
    assert_eq!(f.to_luma8().into_raw(), g.to_luma8().into_raw());
    // In a subfolder, the keys are relative to the scene's folder.
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let (st, v) = call(&mut e, "POST", "/api/save", json!({"path": "sub/t.json", "scene": true}));
    assert_eq!(st, 200, "{v}");
    let text = std::fs::read_to_string(dir.path().join("sub/t.json")).unwrap();
    let j: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        (j["model"].as_str(), j["image"].as_str()),
        (Some("t.model.obj"), Some("t.frame.png"))
    );
    let mut f2 = doc(dir.path());
    let (st, v) = call(&mut f2, "POST", "/api/load", json!({"path": "sub/t.json"}));
    assert_eq!(st, 200, "{v}");
    assert!(f2.model().is_some() && f2.frame().is_some());
}

#[test]
fn the_live_warp_map_is_phi_inverse_at_the_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc25(dir.path()); // 101 x 101 frame
    let c = centre(&d);
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [6.0, -4.0]}));
    let (st, g) = call(&mut d, "GET", "/api/warp?step=8", Value::Null);
    assert_eq!(st, 200, "{g}");
    let (nx, ny) = (g["nx"].as_u64().unwrap() as usize, g["ny"].as_u64().unwrap() as usize);
    assert_eq!((nx, ny), (14, 14), "nodes 0, 8, ..., 96, 100");
    let map = g["map"].as_array().unwrap();
    assert_eq!(map.len(), 2 * nx * ny);
    let mut found = 0;
    for j in 0..ny {
        for i in 0..nx {
            let q = [(8 * i).min(100) as f64, (8 * j).min(100) as f64];
            let (px, py) = (map[2 * (j * nx + i)].as_f64(), map[2 * (j * nx + i) + 1].as_f64());
            let (Some(px), Some(py)) = (px, py) else { continue };
            found += 1;
            let back = d.spline().eval([px, py], None).unwrap();
            let err = (back[0] - q[0]).hypot(back[1] - q[1]);
            assert!(err < 0.02, "node {q:?}: phi(phi^-1) = {back:?}");
        }
    }
    assert!(found > nx * ny * 9 / 10, "{found} of {} nodes have a preimage", nx * ny);
    assert_eq!(call(&mut d, "GET", "/api/warp?step=x", Value::Null).0, 400);
    assert_eq!(call(&mut doc(dir.path()), "GET", "/api/warp", Value::Null).0, 404);
}

/// Bug (issue 23): a scene made with `model bind --up y` did not record the axis, so the
/// editor read its model z-up. The axis is now kept with the model: files are written in the
/// model's own axes and a saved scene records it, so loading the scene turns the model back.
#[test]
fn a_y_up_model_keeps_its_axis_through_export_scene_save_and_load() {
    use crate::io::model::{load_model, UpAxis, SCENE_UP_KEY};
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc25(dir.path());
    let z_up = d.deformed_model().unwrap();
    let m = load_model_back(&d, dir.path(), "plain.obj");
    assert_close_3(&m, &z_up, "a z-up model is written as it is");
    // The same model, declared y-up in its file.
    let model = crate::prism::organism::worm(&crate::prism::organism::WormOptions {
        length: 60.0,
        radius: 5.0,
        bend: 5.0,
        rings: 20,
        around: 8,
    });
    let mut model = model;
    model.vertices = z_up.clone();
    d.set_model_up("worm_y.obj".into(), model, UpAxis::Y).unwrap();
    let file = load_model_back(&d, dir.path(), "y.obj");
    let want: Vec<[f64; 3]> = z_up.iter().map(|&v| UpAxis::Y.from_z_up(v)).collect();
    assert_close_3(&file, &want, "exported in the file's axes");
    d.save("s.json", true).unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("s.json")).unwrap()).unwrap();
    assert_eq!(v[SCENE_UP_KEY], "y");
    let copy = load_model(&dir.path().join(v["model"].as_str().unwrap())).unwrap();
    assert_close_3(&copy.vertices, &want, "the scene's model copy is in the file's axes");
    let mut e = doc25(dir.path());
    e.load("s.json").unwrap();
    assert_close_3(&e.deformed_model().unwrap(), &z_up, "loaded turned back to z-up");
}

/// Vertex lists equal within 1e-9 px (the identity's evaluation rounds in the last digits).
fn assert_close_3(a: &[[f64; 3]], b: &[[f64; 3]], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    for (p, q) in a.iter().zip(b) {
        assert!((0..3).all(|k| (p[k] - q[k]).abs() <= 1e-9), "{what}: {p:?} vs {q:?}");
    }
}

fn load_model_back(d: &Doc, root: &std::path::Path, name: &str) -> Vec<[f64; 3]> {
    d.export_model(name).unwrap();
    crate::io::model::load_model(&root.join(name)).unwrap().vertices
}

/// Bug: "export warped" with the path field at the frame's name replaced the raw image
/// without a word. Saves and exports never write over the image or the model the editor
/// works on; other names are written (the page asks before replacing them).
#[test]
fn an_export_over_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc25(dir.path());
    std::fs::write(dir.path().join("frame.png"), b"raw frame").unwrap();
    std::fs::write(dir.path().join("worm.obj"), b"raw model").unwrap();
    for (kind, path) in [("warped", "frame.png"), ("obj", "worm.obj"), ("warped", "./frame.png")] {
        let (st, v) = call(&mut d, "POST", "/api/export", json!({"kind": kind, "path": path}));
        assert_eq!(st, 403, "{kind} {path}: {v}");
        assert!(v.to_string().contains("replace an input"), "{v}");
    }
    let (st, _) = call(&mut d, "POST", "/api/save", json!({"path": "frame.png"}));
    assert_eq!(st, 403);
    assert_eq!(std::fs::read(dir.path().join("frame.png")).unwrap(), b"raw frame");
    assert_eq!(std::fs::read(dir.path().join("worm.obj")).unwrap(), b"raw model");
    let (st, v) = call(&mut d, "POST", "/api/export", json!({"kind": "warped", "path": "w.png"}));
    assert_eq!(st, 200, "{v}");
}
