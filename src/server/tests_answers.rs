//! The editor's answers byte for byte: a fixed session on two small documents, each answer
//! compared with `tests/golden/editor_answers.txt` (captured from the `serde_json::Value`
//! answers before they became typed, [`super::answers`]), with the timings and the temporary
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

/// Each object's keys in `text` (compact JSON), in the order written, outermost first.
fn object_keys(text: &str) -> Vec<Vec<String>> {
    // A stack of open containers: `Some(keys)` for an object, `None` for an array.
    let mut open: Vec<Option<Vec<String>>> = Vec::new();
    let mut done = Vec::new();
    let mut chars = text.char_indices();
    let mut prev = ' ';
    while let Some((i, c)) = chars.next() {
        match c {
            '{' => open.push(Some(Vec::new())),
            '[' => open.push(None),
            '}' | ']' => {
                if let Some(Some(keys)) = open.pop() {
                    done.push((open.len(), keys));
                }
            }
            '"' => {
                let mut end = i + 1;
                while let Some((j, d)) = chars.next() {
                    if d == '\\' {
                        chars.next();
                    } else if d == '"' {
                        end = j;
                        break;
                    }
                }
                if let (true, Some(Some(keys))) = (prev == '{' || prev == ',', open.last_mut()) {
                    keys.push(text[i + 1..end].to_string());
                }
            }
            _ => {}
        }
        prev = c;
    }
    done.sort_by_key(|(depth, _)| *depth);
    done.into_iter().map(|(_, keys)| keys).collect()
}

/// The keys of a state, in the order written.
const STATE_KEYS: [&str; 20] = [
    "name",
    "degree",
    "points",
    "triangles",
    "z_modes",
    "model",
    "frame",
    "fixed",
    "undo",
    "redo",
    "undo_next",
    "redo_next",
    "pinned",
    "selection",
    "last_update_ms",
    "fold_free",
    "folding_triangles",
    "undecided_triangles",
    "det_j_lower_bound",
    "det_j_sampled_min",
];

/// Each answer's keys are written in the documented order ([`super::answers`]: the order
/// of the `serde_json::Value` maps the answers were before, which kept their insertion
/// order), every optional part present, `server_ms` last; the same order in the answers
/// of a whole session.
#[test]
fn keys_are_written_in_the_documented_order() {
    use super::answers::*;
    use crate::fit::report::{ExactStep, FitMethod, Solver};
    use crate::spline::ControlPoint;
    let image = || Some(ImageInfo { path: "a.png".into(), width: 3, height: 2 });
    let det_j = Certificate {
        fold_free: true,
        folding_triangles: vec![1],
        undecided_triangles: vec![0],
        det_j_lower_bound: 0.5,
        det_j_sampled_min: 0.75,
    };
    let state = State {
        name: Some("d.json".into()),
        degree: 5,
        points: 9,
        triangles: 2,
        z_modes: false,
        model: Some("m.obj".into()),
        frame: image(),
        fixed: image(),
        undo: 2,
        redo: 1,
        undo_next: Some("y".into()),
        redo_next: Some("x".into()),
        pinned: vec![ControlPoint(3)],
        selection: Some(StateSelection {
            anchors: vec![ControlPoint(1)],
            derived: vec![ControlPoint(2)],
            strong: true,
            mode: "xy",
        }),
        last_update_ms: 1.5,
        det_j: det_j.clone(),
    };
    let row = PairRow {
        name: Some("P1".into()),
        src: [0.0, 1.0],
        dst: [1.0, 2.0],
        weight: 1.0,
        active: true,
        mapped: Some([1.5, 2.5]),
        residual: Some(0.25),
    };
    let pairs = Pairs {
        pairs: vec![row],
        rms: Some(0.5),
        max: Some(0.5),
        undo: 1,
        redo: 0,
        index: Some(0),
    };
    let method =
        FitMethod { solver: Solver::GaussNewton, newton: true, exact: Some(ExactStep::Pinned) };
    let refit = Refitted {
        method,
        rms: 0.5,
        max: 1.0,
        pinned: 1,
        min_det_j: 0.5,
        landmarks: Some(pairs.clone()),
    };
    let selected = Selected {
        anchors: vec![ControlPoint(1)],
        derived: vec![],
        theta: vec![0.5],
        strong: true,
        relevant: 4,
        rank: 3,
        solver: "modular",
    };
    let pair_keys = ["pairs", "rms", "max", "undo", "redo", "index"];
    let row_keys = ["name", "src", "dst", "weight", "active", "mapped", "residual"];
    let image_keys = ["path", "width", "height"];
    let text = |v: &dyn erased::Answer| v.text();
    let cases: Vec<(String, Vec<&[&str]>)> = vec![
        (
            text(&state),
            vec![&STATE_KEYS, &image_keys, &image_keys, &["anchors", "derived", "strong", "mode"]],
        ),
        (text(&pairs), vec![&pair_keys, &row_keys]),
        (
            text(&refit),
            vec![
                &["method", "rms", "max", "pinned", "min_det_j", "landmarks"],
                &pair_keys,
                &row_keys,
            ],
        ),
        (
            text(&selected),
            vec![&["anchors", "derived", "theta", "strong", "relevant", "rank", "solver"]],
        ),
        (
            text(&GeometrySelection { anchors: vec![], derived: vec![], constraints: vec![1] }),
            vec![&["anchors", "derived", "constraints"]],
        ),
        (text(&det_j), vec![&STATE_KEYS[15..]]),
        (text(&Picked { index: Some(1), point: Some([1.0, 2.0]) }), vec![&["index", "point"]]),
        (text(&Picked { index: None, point: None }), vec![&["index"]]),
        (
            text(&Stat { exists: true, same_layout: Some(true), scene_copies: vec![] }),
            vec![&["exists", "same_layout", "scene_copies"]],
        ),
        (text(&SavedScene { saved: "s".into(), written: vec![] }), vec![&["saved", "written"]]),
        (text(&Saved { saved: "s".into() }), vec![&["saved"]]),
        (
            text(&super::answers::Registered {
                metric: crate::register::Metric::Ncc,
                metric_before: 0.5,
                metric_after: 0.1,
                fold_free: true,
                det_j_lower_bound: 0.5,
                pinned: 1,
                pairs: 0,
                iterations: 30,
                time_ms: 1.0,
            }),
            vec![&[
                "metric",
                "metric_before",
                "metric_after",
                "fold_free",
                "det_j_lower_bound",
                "pinned",
                "pairs",
                "iterations",
                "time_ms",
            ]],
        ),
        (text(&Updated { update_ms: 1.0 }), vec![&["update_ms"]]),
        (text(&Undid { undid: "u".into() }), vec![&["undid"]]),
        (text(&Redid { redid: "r".into() }), vec![&["redid"]]),
        (text(&ErrorAnswer { error: "e".into() }), vec![&["error"]]),
    ];
    for (text, want) in &cases {
        let got = object_keys(text);
        let want: Vec<Vec<String>> =
            want.iter().map(|k| k.iter().map(|s| s.to_string()).collect()).collect();
        assert_eq!(got, want, "{text}");
    }
    // The same order in a whole session's answers, `server_ms` last; the geometry answers
    // (their own keys, the geometry's, then `state`) in their nested state.
    let mut states = 0;
    for line in transcript().lines() {
        let mut f = line.splitn(4, ' ');
        let (url, body) = (f.nth(1).unwrap(), f.nth(1).unwrap());
        let keys = object_keys(body);
        let top = &keys[0];
        if body.starts_with("{\"error\"") {
            assert_eq!(top, &["error"], "{line}");
            continue;
        }
        assert_eq!(top.last().map(String::as_str), Some("server_ms"), "{line}");
        if let Some(st) = keys.iter().find(|k| k.len() == 20 && k[0] == "name") {
            assert_eq!(st, &STATE_KEYS, "{url}");
            states += 1;
        }
    }
    assert!(states > 10, "{states} states seen");
}

mod erased {
    /// A typed answer as JSON text.
    pub trait Answer {
        fn text(&self) -> String;
    }
    impl<T: serde::Serialize> Answer for T {
        fn text(&self) -> String {
            serde_json::to_string(self).unwrap()
        }
    }
}

/// A body that is not JSON, not an object, or has a bad or missing field is refused with
/// 400 and a message naming the field ([`super::requests`]); unknown keys are ignored.
#[test]
fn bad_bodies_are_refused_with_400_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = small(dir.path());
    for (url, body, want) in [
        ("/api/pick", r#"{"y": 1}"#, "missing `x`"),
        ("/api/pick", r#"{"x": "a", "y": 1}"#, "`x` must be a finite number"),
        ("/api/pick", r#"{"x": 1e400, "y": 1}"#, "`x` must be a finite number"),
        ("/api/pick", r#"{"x": 1, "y": 1, "max_dist": "far"}"#, "`max_dist` must be a number"),
        ("/api/select", r#"{"anchors": "x"}"#, "`anchors` must be an array of indices"),
        ("/api/select", r#"{"anchors": [0], "radius": -1}"#, "`radius` must be an integer >= 0"),
        ("/api/select", r#"{"anchors": [0], "mode": "zz"}"#, "unknown mode `zz`"),
        ("/api/select", r#"{"anchors": [0], "mode": 1}"#, "`mode` must be xy, z0 or z1"),
        ("/api/update", r#"{"op": "translate"}"#, "translate needs \"by\""),
        ("/api/update", r#"{"op": "translate", "v": ["a", 1]}"#, "v: "),
        ("/api/update", r#"{"op": "spin"}"#, "unknown op `spin`"),
        ("/api/save", r#"{"path": 5}"#, "`path` must be a string"),
        ("/api/save", r#"{"path": "a.json", "scene": "yes"}"#, "`scene` must be true, false"),
        ("/api/export", r#"{"kind": "svg", "path": "w.svg"}"#, "unknown export `svg`"),
        ("/api/refit", r#"{"landmarks": 3}"#, "`landmarks` must be a string"),
        ("/api/landmarks/add", r#"{"src": [1, 1, 1], "dst": [1, 1]}"#, "`src` must be 2 numbers"),
        ("/api/landmarks/add", r#"{"src": [1, "x"], "dst": [1, 1]}"#, "`src` must be an array"),
        ("/api/landmarks/add", r#"{"src": [1, 1], "dst": [1, 1], "name": 7}"#, "`name` must be"),
        ("/api/landmarks/move", r#"{"index": -1}"#, "`index` must be an integer >= 0"),
        ("/api/landmarks/move", r#"{"index": 0, "dst": [1]}"#, "`dst` must be 2 numbers"),
        (
            "/api/landmarks/active",
            r#"{"index": 0, "active": "yes"}"#,
            "`active` must be true or false",
        ),
        ("/api/landmarks/delete", r#"{}"#, "missing `index`"),
        ("/api/landmarks/export", r#"{"path": "l.csv"}"#, "missing `format`"),
        ("/api/landmarks/import", r#"{"path": null}"#, "`path` must be a string"),
        ("/api/stat", r#"{"path": "a", "path": "b"}"#, "duplicate key \"path\""),
        ("/api/load", "[1]", "the body must be a JSON object"),
        ("/api/stat", "{not json", "JSON: "),
        ("/api/stat", "", "missing `path`"),
    ] {
        let r = handle(&mut d, "POST", url, body.as_bytes());
        let v: Value = serde_json::from_slice(&r.body).unwrap();
        assert_eq!(r.status, 400, "{url} {body}: {v}");
        let msg = v["error"].as_str().unwrap();
        assert!(msg.contains(want), "{url} {body}: {msg:?} does not say {want:?}");
    }
    let r = handle(&mut d, "POST", "/api/stat", br#"{"path": "s.json", "more": [1, {"a": 2}]}"#);
    assert_eq!(r.status, 200, "unknown keys are ignored");
    let r = handle(&mut d, "POST", "/api/pick", br#"{"x": 1.50, "y": 1e+1, "max_dist": null}"#);
    assert_eq!(r.status, 200, "any spelling of a number, null for an absent key");
}
