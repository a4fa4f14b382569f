//! Landmark pairs in the editor's document (issue 22 point 4): the endpoints, file round
//! trips, re-fits and scenes.

use super::tests::{call, doc};
use serde_json::{json, Value};

/// phi is evaluated in `f64` (Bezier de Casteljau on the cached control points): the
/// identity reproduces a point to about 1e-13 px.
const EVAL_TOL: f64 = 1e-9;

fn close(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= EVAL_TOL)
}

fn residuals(v: &Value) -> Vec<f64> {
    v["pairs"].as_array().unwrap().iter().map(|p| p["residual"].as_f64().unwrap()).collect()
}

/// Four pairs whose targets are off the identity by 1-2 px.
fn place_four(d: &mut super::doc::Doc) -> Value {
    let mut last = Value::Null;
    for (s, t) in [
        ([20.0, 20.0], [22.0, 21.0]),
        ([80.0, 20.0], [81.0, 22.0]),
        ([20.0, 80.0], [21.0, 79.0]),
        ([80.0, 80.0], [82.0, 81.0]),
    ] {
        let (st, v) = call(d, "POST", "/api/landmarks/add", json!({"src": s, "dst": t}));
        assert_eq!(st, 200, "{v}");
        last = v;
    }
    last
}

fn undo_steps(d: &mut super::doc::Doc) -> u64 {
    call(d, "GET", "/api/state", Value::Null).1["undo"].as_u64().unwrap()
}

fn undo(d: &mut super::doc::Doc, which: &str) {
    let (st, v) = call(d, "POST", &format!("/api/{which}"), Value::Null);
    assert_eq!(st, 200, "{which}: {v}");
}

#[test]
fn pairs_are_added_moved_deleted_and_listed_with_their_residuals() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let (st, v) = call(&mut d, "GET", "/api/landmarks", Value::Null);
    assert_eq!((st, v["pairs"].as_array().unwrap().len()), (200, 0));
    assert!(v["rms"].is_null());
    let v = place_four(&mut d);
    assert_eq!(v["index"], 3);
    let names: Vec<&str> =
        v["pairs"].as_array().unwrap().iter().map(|p| p["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["P1", "P2", "P3", "P4"]);
    // The identity map: the residual is |src - dst|.
    let r = residuals(&v);
    assert!(close(&r, &[5f64.sqrt(), 5f64.sqrt(), 2f64.sqrt(), 5f64.sqrt()]), "{r:?}");
    assert!(close(&[v["max"].as_f64().unwrap()], &[5f64.sqrt()]));
    let (st, v) =
        call(&mut d, "POST", "/api/landmarks/move", json!({"index": 1, "dst": [80.0, 23.0]}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["pairs"][1]["src"], json!([80.0, 20.0]));
    assert!(close(&residuals(&v)[1..2], &[3.0]), "{v}");
    let (_, v) =
        call(&mut d, "POST", "/api/landmarks/move", json!({"index": 2, "src": [21.0, 79.0]}));
    assert!(close(&residuals(&v)[2..3], &[0.0]), "{v}");
    let (st, v) = call(&mut d, "POST", "/api/landmarks/delete", json!({"index": 0}));
    assert_eq!(st, 200, "{v}");
    let names: Vec<&str> =
        v["pairs"].as_array().unwrap().iter().map(|p| p["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["P2", "P3", "P4"], "the others keep their names");
    // A new unnamed pair takes the first free name.
    let (_, v) =
        call(&mut d, "POST", "/api/landmarks/add", json!({"src": [50, 50], "dst": [50, 50]}));
    assert_eq!(v["pairs"][3]["name"], "P1");
    let (st, v) = call(
        &mut d,
        "POST",
        "/api/landmarks/add",
        json!({"src": [1, 1], "dst": [1, 1], "name": "P2"}),
    );
    assert_eq!(st, 422, "a name in use: {v}");
    assert_eq!(d.pairs().len(), 4);
}

#[test]
fn absurd_pairs_are_refused_with_422_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    place_four(&mut d);
    let before = d.pairs().to_vec();
    for (url, body, want) in [
        ("/api/landmarks/add", json!({"src": [1e308, 1e308], "dst": [1, 1]}), 422),
        ("/api/landmarks/add", json!({"src": [1, 1], "dst": [2e6, 0]}), 422),
        ("/api/landmarks/add", json!({"src": [1, 1, 1], "dst": [1, 1]}), 400),
        ("/api/landmarks/add", json!({"src": [1, "x"], "dst": [1, 1]}), 400),
        ("/api/landmarks/add", json!({"dst": [1, 1]}), 400),
        ("/api/landmarks/move", json!({"index": 0, "src": [1e300, 0]}), 422),
        ("/api/landmarks/move", json!({"index": 9, "src": [1, 1]}), 422),
        ("/api/landmarks/move", json!({"index": -1, "src": [1, 1]}), 400),
        ("/api/landmarks/delete", json!({"index": 4}), 422),
        ("/api/landmarks/export", json!({"path": "l.csv", "format": "xml"}), 400),
    ] {
        let (st, v) = call(&mut d, "POST", url, body.clone());
        assert_eq!(st, want, "{url} {body}: {v}");
        assert!(v["error"].is_string());
        assert_eq!(d.pairs(), &before[..], "{url} {body} changed the pairs");
    }
}

#[test]
fn pairs_round_trip_through_csv_and_bigwarp_files_inside_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    place_four(&mut d);
    call(&mut d, "POST", "/api/landmarks/move", json!({"index": 0, "dst": [22.125, 20.7]}));
    for (file, format) in [("l.csv", "csv"), ("bw.csv", "bigwarp")] {
        let (st, v) =
            call(&mut d, "POST", "/api/landmarks/export", json!({"path": file, "format": format}));
        assert_eq!(st, 200, "{v}");
        let text = std::fs::read_to_string(dir.path().join(file)).unwrap();
        assert_eq!(text.starts_with('"'), format == "bigwarp", "{text}");
        let mut e = doc(dir.path());
        let (st, v) = call(&mut e, "POST", "/api/landmarks/import", json!({"path": file}));
        assert_eq!(st, 200, "{v}");
        assert_eq!(e.pairs(), d.pairs(), "{format} round trip");
        assert_eq!(v["pairs"].as_array().unwrap().len(), 4);
    }
    let (st, _) =
        call(&mut d, "POST", "/api/landmarks/export", json!({"path": "../x.csv", "format": "csv"}));
    assert_eq!(st, 403);
    let (st, _) = call(&mut d, "POST", "/api/landmarks/import", json!({"path": "../l.csv"}));
    assert_eq!(st, 403);
    std::fs::write(dir.path().join("bad.csv"), "a,1,2,3,inf\n").unwrap();
    let before = d.pairs().to_vec();
    let (st, v) = call(&mut d, "POST", "/api/landmarks/import", json!({"path": "bad.csv"}));
    assert_eq!(st, 422, "{v}");
    assert!(v["error"].as_str().unwrap().contains("bad.csv"), "{v}");
    assert_eq!(d.pairs(), &before[..]);
}

#[test]
fn refit_from_the_pairs_lowers_the_residuals_and_is_one_undo_step() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let before = place_four(&mut d);
    let steps = undo_steps(&mut d);
    let (st, v) = call(&mut d, "POST", "/api/refit", json!({"hard": false}));
    assert_eq!(st, 200, "{v}");
    let soft = v["landmarks"]["rms"].as_f64().unwrap();
    assert!(soft < 0.5 * before["rms"].as_f64().unwrap(), "soft {soft} vs {}", before["rms"]);
    assert_eq!(undo_steps(&mut d), steps + 1, "a re-fit is one undo step");
    let (st, v) = call(&mut d, "POST", "/api/refit", json!({"hard": true}));
    assert_eq!(st, 200, "{v}");
    let hard = v["landmarks"]["max"].as_f64().unwrap();
    assert!(hard < 1e-6, "hard re-fit leaves {hard} px");
    // The listed residuals are those of the current map.
    let (_, l) = call(&mut d, "GET", "/api/landmarks", Value::Null);
    assert_eq!(l["max"], v["landmarks"]["max"]);
    call(&mut d, "POST", "/api/undo", Value::Null);
    call(&mut d, "POST", "/api/undo", Value::Null);
    let (_, l) = call(&mut d, "GET", "/api/landmarks", Value::Null);
    assert_eq!(l["rms"], before["rms"], "undo restores the map the residuals are measured on");
    let mut e = doc(dir.path());
    let (st, v) = call(&mut e, "POST", "/api/refit", json!({}));
    assert_eq!(st, 422, "no pairs: {v}");
}

#[test]
fn scenes_keep_the_pairs_and_plain_files_keep_the_current_ones() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    place_four(&mut d);
    let (st, v) = call(&mut d, "POST", "/api/save", json!({"path": "s.json", "scene": true}));
    assert_eq!(st, 200, "{v}");
    let (st, _) = call(&mut d, "POST", "/api/save", json!({"path": "plain.json"}));
    assert_eq!(st, 200);
    let text = std::fs::read_to_string(dir.path().join("plain.json")).unwrap();
    assert!(!text.contains("\"landmarks\""), "a plain deformation file has no pairs");
    let mut e = doc(dir.path());
    let (st, v) = call(&mut e, "POST", "/api/load", json!({"path": "s.json"}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(e.pairs(), d.pairs());
    call(&mut e, "POST", "/api/landmarks/delete", json!({"index": 0}));
    call(&mut e, "POST", "/api/load", json!({"path": "plain.json"}));
    assert_eq!(e.pairs().len(), 3, "a file without pairs keeps the current ones");
    // A scene whose pairs are absurd is refused whole.
    let bad = text.trim_end().trim_end_matches('}').to_string()
        + ",\"landmarks\":[{\"src\":[1e300,0],\"dst\":[0,0]}]}";
    std::fs::write(dir.path().join("bad.json"), bad).unwrap();
    let (st, v) = call(&mut e, "POST", "/api/load", json!({"path": "bad.json"}));
    assert_eq!(st, 422, "{v}");
    assert_eq!(e.pairs().len(), 3);
}

#[test]
fn every_pair_change_is_one_undo_step_and_redo_replays_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let mut states = vec![d.pairs().to_vec()];
    place_four(&mut d);
    states.push(d.pairs().to_vec());
    call(&mut d, "POST", "/api/landmarks/move", json!({"index": 1, "dst": [80.0, 23.0]}));
    states.push(d.pairs().to_vec());
    call(&mut d, "POST", "/api/landmarks/delete", json!({"index": 0}));
    states.push(d.pairs().to_vec());
    std::fs::write(dir.path().join("two.csv"), "a,1,2,3,4,1\nb,5,6,7,8,1\n").unwrap();
    let (st, v) = call(&mut d, "POST", "/api/landmarks/import", json!({"path": "two.csv"}));
    assert_eq!(st, 200, "{v}");
    assert_eq!((v["undo"].as_u64(), v["redo"].as_u64()), (Some(7), Some(0)), "{v}");
    let last = d.pairs().to_vec();
    // Refused changes record nothing.
    let (st, _) = call(&mut d, "POST", "/api/landmarks/delete", json!({"index": 9}));
    assert_eq!((st, undo_steps(&mut d)), (422, 7));
    // Back through the import, the delete and the move, each exactly.
    for want in states.iter().rev().take(3) {
        undo(&mut d, "undo");
        assert_eq!(d.pairs(), &want[..]);
    }
    // The four adds, one by one.
    for k in (0..4).rev() {
        undo(&mut d, "undo");
        assert_eq!(d.pairs(), &states[1][..k]);
    }
    let (st, v) = call(&mut d, "POST", "/api/undo", Value::Null);
    assert_eq!(st, 422, "{v}");
    for _ in 0..7 {
        undo(&mut d, "redo");
    }
    assert_eq!(d.pairs(), &last[..], "redo replays every change");
    // A new change after an undo drops the redo steps.
    undo(&mut d, "undo");
    call(&mut d, "POST", "/api/landmarks/add", json!({"src": [5, 5], "dst": [6, 6]}));
    let (_, v) = call(&mut d, "GET", "/api/landmarks", Value::Null);
    assert_eq!(v["redo"], 0, "{v}");
}

#[test]
fn pair_changes_and_drags_share_one_history_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let identity = d.spline().points().to_vec();
    let m = d.spline().mesh();
    let c = (0..m.num_vertices()).find(|&v| m.vertex(v) == [50.0, 50.0]).unwrap();
    place_four(&mut d);
    let four = d.pairs().to_vec();
    let (st, _) = call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    assert_eq!(st, 200);
    let (st, _) = call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [3.0, 1.0]}));
    assert_eq!(st, 200);
    call(&mut d, "POST", "/api/clear", Value::Null);
    let dragged = d.spline().points().to_vec();
    call(&mut d, "POST", "/api/landmarks/delete", json!({"index": 2}));
    // Undo takes back the delete first (the map keeps the drag), then the drag (the pairs
    // stay), and the residuals follow the map.
    undo(&mut d, "undo");
    assert_eq!((d.pairs(), d.spline().points()), (&four[..], &dragged[..]));
    undo(&mut d, "undo");
    assert_eq!((d.pairs(), d.spline().points()), (&four[..], &identity[..]));
    let (_, v) = call(&mut d, "GET", "/api/landmarks", Value::Null);
    let r = residuals(&v);
    assert!(close(&r, &[5f64.sqrt(), 5f64.sqrt(), 2f64.sqrt(), 5f64.sqrt()]), "{r:?}");
    d.spline().check_c1().unwrap();
}

#[test]
fn a_scene_loaded_over_the_same_mesh_takes_back_map_and_pairs_in_one_step() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    place_four(&mut d);
    let (st, _) = call(&mut d, "POST", "/api/save", json!({"path": "s.json", "scene": true}));
    assert_eq!(st, 200);
    let mut e = doc(dir.path());
    call(&mut e, "POST", "/api/landmarks/add", json!({"src": [9, 9], "dst": [9, 9]}));
    let mine = e.pairs().to_vec();
    let steps = undo_steps(&mut e);
    let (st, v) = call(&mut e, "POST", "/api/load", json!({"path": "s.json"}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(undo_steps(&mut e), steps + 1);
    assert_eq!(e.pairs(), d.pairs());
    undo(&mut e, "undo");
    assert_eq!(e.pairs(), &mine[..], "the load's undo restores the pairs it replaced");
    undo(&mut e, "redo");
    assert_eq!(e.pairs(), d.pairs());
}
