//! The editor's answers byte for byte: a fixed session on two small documents, each answer
//! compared with `tests/golden/editor_answers.txt` (captured from the `serde_json::Value`
//! answers before they became typed, [`super::api`]), with the timings and the temporary
//! folder masked. `TRIMORPH_REGENERATE_GOLDEN=1` rewrites the file (review its diff).

use super::doc::Doc;
use super::handle;
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::Spline;
use serde_json::{json, Value};
use std::path::Path;

fn gray(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> image::DynamicImage {
    image::DynamicImage::ImageLuma8(image::GrayImage::from_fn(w, h, |x, y| image::Luma([f(x, y)])))
}

/// A quintic identity on a 2 x 2 grid of 32 x 32 pixels, with a 33 x 33 moving frame and a
/// 40 x 30 fixed image.
fn small(root: &Path) -> Doc {
    let mesh = Mesh::grid(2, 2, 32.0, 32.0, MeshOptions::default()).unwrap();
    let mut d = Doc::new(Spline::identity(mesh, 5).unwrap(), root);
    d.set_frame("moving.png".into(), gray(33, 33, |x, y| ((x * 7 + y) % 256) as u8)).unwrap();
    d.set_fixed("fixed.png".into(), gray(40, 30, |x, y| ((x + 5 * y) % 256) as u8)).unwrap();
    d
}

/// The same grid in 2.5D (z layers) with a small worm model.
fn small25(root: &Path) -> Doc {
    use crate::prism::organism::{worm, WormOptions};
    let mesh = Mesh::grid(2, 2, 32.0, 32.0, MeshOptions::default()).unwrap();
    let mut s = Spline::identity(mesh, 5).unwrap();
    let z = crate::prism::identity_layers(&s, crate::exact::rat_int(-4), crate::exact::rat_int(4))
        .unwrap();
    s.set_z_layers(Some(z));
    let mut m = worm(&WormOptions { length: 12.0, radius: 2.0, bend: 1.0, rings: 4, around: 4 });
    for v in m.vertices.iter_mut() {
        v[0] += 10.0;
        v[1] += 16.0;
    }
    let mut d = Doc::new(s, root);
    d.set_model("worm.obj".into(), m).unwrap();
    d
}

/// The vertex at (16, 16).
fn centre(d: &Doc) -> usize {
    let m = d.spline().mesh();
    (0..m.num_vertices()).find(|&v| m.vertex(v) == [16.0, 16.0]).unwrap()
}

/// `text` with the number after each timing key written `0`, and `root` written `ROOT`.
fn mask(text: &str, root: &Path) -> String {
    let mut out = text.replace(&root.display().to_string(), "ROOT");
    for key in ["\"server_ms\":", "\"update_ms\":", "\"last_update_ms\":"] {
        let mut from = 0;
        while let Some(i) = out[from..].find(key) {
            let start = from + i + key.len();
            let len = out[start..]
                .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
                .unwrap_or(out.len() - start);
            out.replace_range(start..start + len, "0");
            from = start;
        }
    }
    out
}

/// One line per request: method, URL, status and the masked answer.
fn session(d: &mut Doc, root: &Path, requests: &[(&str, &str, Value)], out: &mut String) {
    for (method, url, body) in requests {
        let b = if body.is_null() { Vec::new() } else { body.to_string().into_bytes() };
        let r = handle(d, method, url, &b);
        assert_eq!(r.content_type, "application/json", "{method} {url}");
        let text = String::from_utf8(r.body).unwrap();
        out.push_str(&format!("{method} {url} {} {}\n", r.status, mask(&text, root)));
    }
}

fn transcript() -> String {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let mut out = String::new();
    let mut d = small(root);
    let c = centre(&d);
    let null = Value::Null;
    session(
        &mut d,
        root,
        &[
            ("GET", "/api/state", null.clone()),
            ("POST", "/api/pick", json!({"x": 16.2, "y": 15.9})),
            ("POST", "/api/pick", json!({"x": 16.2, "y": 15.9, "max_dist": 0.01})),
            ("POST", "/api/select", json!({"anchors": [c], "radius": 1})),
            ("POST", "/api/update", json!({"op": "translate", "v": [1.5, -0.5]})),
            ("POST", "/api/update?warp=8", json!({"op": "translate", "v": [2.25, -0.75]})),
            ("GET", "/api/state", null.clone()),
            ("POST", "/api/clear", null.clone()),
            ("POST", "/api/select?warp=8", json!({"anchors": [c], "radius": null})),
            ("POST", "/api/update", json!({"op": "rotate", "center": [16, 16], "angle": 0.1})),
            ("POST", "/api/update", json!({"op": "scale", "center": [16, 16], "factor": 1.1})),
            ("POST", "/api/undo", null.clone()),
            ("POST", "/api/redo", null.clone()),
            ("POST", "/api/clear", null.clone()),
            ("POST", "/api/landmarks/add", json!({"src": [5, 5], "dst": [6, 5.5]})),
            ("POST", "/api/landmarks/add", json!({"src": [27, 5], "dst": [26, 6], "name": "b"})),
            ("POST", "/api/landmarks/add", json!({"src": [5, 27], "dst": [5.5, 26]})),
            ("POST", "/api/landmarks/add", json!({"src": [27, 27], "dst": [26.5, 27.5]})),
            ("POST", "/api/landmarks/move", json!({"index": 0, "dst": [6.5, 5.25]})),
            ("POST", "/api/landmarks/active", json!({"index": 2, "active": false})),
            ("POST", "/api/landmarks/add", json!({"src": [40, 40], "dst": [41, 41]})),
            ("GET", "/api/landmarks", null.clone()),
            ("POST", "/api/landmarks/delete", json!({"index": 4})),
            ("POST", "/api/refit", json!({})),
            ("POST", "/api/undo", null.clone()),
            ("POST", "/api/landmarks/export", json!({"path": "l.csv", "format": "csv"})),
            ("POST", "/api/stat", json!({"path": "s.json"})),
            ("POST", "/api/save", json!({"path": "s.json", "scene": true})),
            ("POST", "/api/save", json!({"path": "d.json"})),
            ("POST", "/api/stat", json!({"path": "s.json"})),
            ("POST", "/api/export", json!({"kind": "warped", "path": "w.png"})),
            ("POST", "/api/export", json!({"kind": "obj", "path": "w.obj"})),
            ("POST", "/api/load", json!({"path": "d.json"})),
            ("POST", "/api/landmarks/import", json!({"path": "l.csv"})),
            ("POST", "/api/refit", json!({"landmarks": "l.csv", "hard": true})),
            ("GET", "/api/geometry?full=1", null.clone()),
            ("GET", "/api/warp?step=16", null.clone()),
            ("GET", "/api/warp?forward=1&step=16", null.clone()),
            ("POST", "/api/undo", null.clone()),
            ("POST", "/api/redo", null.clone()),
            ("POST", "/api/redo", null.clone()),
        ],
        &mut out,
    );
    let mut d = small25(root);
    session(
        &mut d,
        root,
        &[
            ("GET", "/api/state", null.clone()),
            ("POST", "/api/select", json!({"anchors": [c], "radius": 1, "mode": "z1"})),
            ("POST", "/api/update", json!({"op": "translate", "v": [0.5]})),
            ("GET", "/api/state", null.clone()),
            ("GET", "/api/geometry?full=1", null.clone()),
            ("POST", "/api/stat", json!({"path": "s.json"})),
            ("POST", "/api/save", json!({"path": "m.json", "scene": true})),
            ("POST", "/api/export", json!({"kind": "obj", "path": "w.obj"})),
        ],
        &mut out,
    );
    out
}

#[test]
fn answers_are_byte_for_byte_those_of_the_golden_session() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/editor_answers.txt");
    let got = transcript();
    if std::env::var_os("TRIMORPH_REGENERATE_GOLDEN").is_some() {
        std::fs::write(&path, &got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap();
    for (k, (g, w)) in got.lines().zip(want.lines()).enumerate() {
        assert_eq!(g, w, "answer {} differs", k + 1);
    }
    assert_eq!(got.lines().count(), want.lines().count());
}
