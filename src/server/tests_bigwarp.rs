//! The two-image session (issue 53, BigWarp's workflow): the fixed image, active flags,
//! BigWarp tables with flags, the live warp's forward map, the undo history's names, the
//! landmarks a fit carries (a correction re-fit keeps them), and the gate on the new paths.

use super::doc::pairs::Pair;
use super::doc::Doc;
use super::tests::{call, doc, http, Running};
use crate::fit::landmarks::Landmark;
use crate::fit::{fit, FitOptions};
use crate::server::start::{initial_doc, StartOptions};
use serde_json::{json, Value};
use std::path::Path;

fn gray(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> image::DynamicImage {
    image::DynamicImage::ImageLuma8(image::GrayImage::from_fn(w, h, |x, y| image::Luma([f(x, y)])))
}

/// The 100 x 100 identity document with a 101 x 101 moving frame and a 120 x 90 fixed
/// image, both written in `root`.
fn two_images(root: &Path) -> Doc {
    let mut d = doc(root);
    let m = gray(101, 101, |x, y| ((x * 2 + y) % 256) as u8);
    let f = gray(120, 90, |x, y| ((x + 3 * y) % 256) as u8);
    m.save(root.join("moving.png")).unwrap();
    f.save(root.join("fixed.png")).unwrap();
    d.set_frame("moving.png".into(), m).unwrap();
    d.set_fixed("fixed.png".into(), f).unwrap();
    d
}

#[test]
fn the_fixed_image_is_served_listed_kept_in_scenes_and_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = two_images(dir.path());
    let r = super::handle(&mut d, "GET", "/api/fixed.png", b"");
    assert_eq!((r.status, r.content_type), (200, "image/png"));
    let back = image::load_from_memory(&r.body).unwrap();
    assert_eq!((back.width(), back.height()), (120, 90));
    let (_, st) = call(&mut d, "GET", "/api/state", Value::Null);
    assert_eq!(st["fixed"]["width"], 120, "{st}");
    assert_eq!(st["frame"]["width"], 101);
    // A scene keeps both images; loading it in a fresh document brings them back.
    let (s, v) = call(&mut d, "POST", "/api/save", json!({"path": "s.json", "scene": true}));
    assert_eq!(s, 200, "{v}");
    let text = std::fs::read_to_string(dir.path().join("s.json")).unwrap();
    let scene: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        (scene["image"].as_str(), scene["fixed"].as_str()),
        (Some("moving.png"), Some("fixed.png"))
    );
    let mut e = doc(dir.path());
    assert_eq!(super::handle(&mut e, "GET", "/api/fixed.png", b"").status, 404);
    let (s, v) = call(&mut e, "POST", "/api/load", json!({"path": "s.json"}));
    assert_eq!(s, 200, "{v}");
    assert_eq!(e.fixed().map(|f| f.image.width()), Some(120));
    // `trimorph editor s.json` opens it the same way.
    let opts = StartOptions { deformation: Some(dir.path().join("s.json")), ..Default::default() };
    let started = initial_doc(&opts, dir.path()).unwrap();
    assert_eq!(started.fixed().map(|f| f.image.height()), Some(90));
    // Exports never replace an input, the fixed image included.
    let before = std::fs::read(dir.path().join("fixed.png")).unwrap();
    let (s, v) =
        call(&mut d, "POST", "/api/export", json!({"kind": "warped", "path": "fixed.png"}));
    assert_eq!(s, 403, "{v}");
    assert_eq!(std::fs::read(dir.path().join("fixed.png")).unwrap(), before);
}

#[test]
fn inactive_pairs_stay_listed_but_are_not_fitted_nor_counted() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    for (s, t) in
        [([20.0, 20.0], [22.0, 21.0]), ([80.0, 80.0], [82.0, 81.0]), ([50.0, 50.0], [70.0, 50.0])]
    {
        assert_eq!(call(&mut d, "POST", "/api/landmarks/add", json!({"src": s, "dst": t})).0, 200);
    }
    let (_, all) = call(&mut d, "GET", "/api/landmarks", Value::Null);
    let (st, v) =
        call(&mut d, "POST", "/api/landmarks/active", json!({"index": 2, "active": false}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["pairs"][2]["active"], false);
    assert_eq!(v["pairs"].as_array().unwrap().len(), 3, "an inactive pair stays in the table");
    assert!(
        v["max"].as_f64().unwrap() < all["max"].as_f64().unwrap(),
        "the 20 px outlier no longer counts"
    );
    assert_eq!(v["undo"], 4, "switching a pair off is one undo step");
    // Switching it off again changes nothing and records nothing.
    let (_, again) =
        call(&mut d, "POST", "/api/landmarks/active", json!({"index": 2, "active": false}));
    assert_eq!(again["undo"], 4);
    let (st, r) = call(&mut d, "POST", "/api/refit", json!({"hard": true}));
    assert_eq!(st, 200, "{r}");
    let mapped = d.spline().eval([50.0, 50.0], None).unwrap();
    assert!((mapped[0] - 70.0).abs() > 10.0, "the inactive pair was fitted: {mapped:?}");
    assert!(r["landmarks"]["max"].as_f64().unwrap() < 1e-6, "the active pairs are met");
    // The flag is undone like any change, and kept by scenes.
    let (_, u) = call(&mut d, "POST", "/api/undo", Value::Null);
    assert_eq!(u["undid"], "re-fit to 2 pairs", "{u}");
    let (_, u) = call(&mut d, "POST", "/api/undo", Value::Null);
    assert_eq!(u["undid"], "switching pair P3 off", "{u}");
    assert!(d.pairs()[2].active);
    call(&mut d, "POST", "/api/redo", Value::Null);
    call(&mut d, "POST", "/api/save", json!({"path": "s.json", "scene": true}));
    let mut e = doc(dir.path());
    assert_eq!(call(&mut e, "POST", "/api/load", json!({"path": "s.json"})).0, 200);
    assert_eq!(e.pairs(), d.pairs());
    assert!(!e.pairs()[2].active);
    // Refusals change nothing.
    let before = d.pairs().to_vec();
    for (body, want) in [
        (json!({"index": 9, "active": true}), 422),
        (json!({"index": 0, "active": "yes"}), 400),
        (json!({"index": 0}), 400),
        (json!({"active": true}), 400),
    ] {
        let (st, v) = call(&mut d, "POST", "/api/landmarks/active", body.clone());
        assert_eq!(st, want, "{body}: {v}");
        assert_eq!(d.pairs(), &before[..]);
    }
    // All pairs off: nothing to fit.
    for i in 0..2 {
        call(&mut d, "POST", "/api/landmarks/active", json!({"index": i, "active": false}));
    }
    let (st, v) = call(&mut d, "POST", "/api/refit", json!({}));
    assert_eq!(st, 422, "{v}");
    assert!(v["error"].as_str().unwrap().contains("switched off"), "{v}");
}

#[test]
fn bigwarp_tables_keep_the_flags_and_csv_gets_the_active_pairs() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    call(&mut d, "POST", "/api/landmarks/add", json!({"src": [10.25, 20.5], "dst": [11, 22]}));
    call(&mut d, "POST", "/api/landmarks/add", json!({"src": [60, 70], "dst": [61.125, 69]}));
    call(&mut d, "POST", "/api/landmarks/active", json!({"index": 1, "active": false}));
    for (file, format) in [("bw.csv", "bigwarp"), ("l.csv", "csv")] {
        let (st, v) =
            call(&mut d, "POST", "/api/landmarks/export", json!({"path": file, "format": format}));
        assert_eq!(st, 200, "{v}");
    }
    let bw = std::fs::read_to_string(dir.path().join("bw.csv")).unwrap();
    assert_eq!(
        bw,
        "\"P1\",\"true\",\"10.25\",\"20.5\",\"11\",\"22\"\n\"P2\",\"false\",\"60\",\"70\",\"61.125\",\"69\"\n"
    );
    let csv = std::fs::read_to_string(dir.path().join("l.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "header and the active pair: {csv}");
    let mut e = doc(dir.path());
    let (st, v) = call(&mut e, "POST", "/api/landmarks/import", json!({"path": "bw.csv"}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(e.pairs(), d.pairs(), "a BigWarp round trip keeps names, points and flags");
    let (st, _) = call(&mut e, "POST", "/api/landmarks/import", json!({"path": "l.csv"}));
    assert_eq!(st, 200);
    assert_eq!(e.pairs(), &d.pairs()[..1]);
}

#[test]
fn the_forward_map_is_phi_at_the_nodes_and_rides_on_drag_steps() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = two_images(dir.path());
    let m = d.spline().mesh();
    let c = (0..m.num_vertices()).find(|&v| m.vertex(v) == [50.0, 50.0]).unwrap();
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    let (st, v) =
        call(&mut d, "POST", "/api/update?warp=8", json!({"op": "translate", "v": [6.0, -4.0]}));
    assert_eq!(st, 200, "{v}");
    let g = &v["warp"];
    assert_eq!(g["forward"], true);
    assert_eq!(g["target"], json!([120, 90]), "drawn over the fixed image");
    let (nx, ny) = (g["nx"].as_u64().unwrap() as usize, g["ny"].as_u64().unwrap() as usize);
    assert_eq!((nx, ny), (14, 14), "nodes 0, 8, ..., 96, 100 of the 101 x 101 frame");
    let map = g["map"].as_array().unwrap();
    let mut inside = 0;
    for j in 0..ny {
        for i in 0..nx {
            let p = [(8 * i).min(100) as f64, (8 * j).min(100) as f64];
            let k = 2 * (j * nx + i);
            match (map[k].as_f64(), map[k + 1].as_f64(), d.spline().eval(p, None)) {
                (Some(x), Some(y), Some(q)) => {
                    inside += 1;
                    assert!((x - q[0]).abs() <= 5e-4 && (y - q[1]).abs() <= 5e-4, "{p:?}");
                }
                (None, None, None) => {}
                other => panic!("node {p:?}: {other:?}"),
            }
        }
    }
    assert_eq!(inside, nx * ny, "the mesh covers the frame");
    // The same map on request; without a frame there is none.
    let (st, h) = call(&mut d, "GET", "/api/warp?forward=1", Value::Null);
    assert_eq!(st, 200);
    assert_eq!(h["map"], g["map"]);
    assert_eq!(call(&mut doc(dir.path()), "GET", "/api/warp?forward=1", Value::Null).0, 404);
    // Without the query the answer is as before; a bad step is refused before the edit.
    let (_, plain) =
        call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [1.0, 0.0]}));
    assert!(plain.get("warp").is_none());
    let before = d.spline().points().to_vec();
    let (st, _) =
        call(&mut d, "POST", "/api/update?warp=0", json!({"op": "translate", "v": [9.0, 0.0]}));
    assert_eq!(st, 400);
    assert_eq!(d.spline().points(), &before[..]);
}

#[test]
fn undo_and_redo_say_what_they_took_back() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = doc(dir.path());
    let m = d.spline().mesh();
    let c = (0..m.num_vertices()).find(|&v| m.vertex(v) == [50.0, 50.0]).unwrap();
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 1}));
    call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [2.0, 0.0]}));
    call(&mut d, "POST", "/api/landmarks/add", json!({"src": [5, 5], "dst": [6, 6]}));
    let (_, st) = call(&mut d, "GET", "/api/state", Value::Null);
    assert_eq!(st["undo_next"], "adding pair P1");
    assert_eq!(st["redo_next"], Value::Null);
    let (_, u) = call(&mut d, "POST", "/api/undo", Value::Null);
    assert_eq!(u["undid"], "adding pair P1");
    let (_, u) = call(&mut d, "POST", "/api/undo", Value::Null);
    assert_eq!(u["undid"], format!("translate of point {c} (xy)"));
    assert_eq!(u["state"]["redo_next"], format!("translate of point {c} (xy)"));
    let (_, r) = call(&mut d, "POST", "/api/redo", Value::Null);
    assert_eq!(r["redid"], format!("translate of point {c} (xy)"));
}

/// A smooth warp of the 100 x 100 square: up to 12 px.
fn bend(p: [f64; 2]) -> [f64; 2] {
    use std::f64::consts::PI;
    let (u, v) = (p[0] / 100.0, p[1] / 100.0);
    [p[0] + 12.0 * (PI * v).sin() * u, p[1] - 10.0 * (PI * u).sin() * v * v]
}

/// The deformation `trimorph fit` writes for 25 landmarks of [`bend`] (with them under
/// `"landmarks"`), as `fit.json` in `root`; returns the fitted spline's file text.
fn fitted_file(root: &Path) -> Vec<Landmark> {
    let d = doc(root);
    let mut lms = Vec::new();
    for j in 0..5 {
        for i in 0..5 {
            let src = [10.0 + 20.0 * i as f64, 10.0 + 20.0 * j as f64];
            lms.push(Landmark { name: Some(format!("f{i}{j}")), src, dst: bend(src), weight: 1.0 });
        }
    }
    let f = fit(d.spline(), &lms, &FitOptions::default()).unwrap();
    let text = crate::io::deformation::to_string_with_landmarks(&f.spline, &lms);
    std::fs::write(root.join("fit.json"), text).unwrap();
    lms
}

/// Issue 53: a 3-pair correction re-fitted over a fit moved points far from the
/// corrections by 30-50 px, the fit's own landmarks being lost. The deformation now
/// carries them: the editor opens it with those pairs, and the re-fit with 3 corrections
/// keeps far points where the fit put them (while dropping them, as before, does not).
#[test]
fn a_three_pair_correction_over_a_fit_keeps_distant_points() {
    let dir = tempfile::tempdir().unwrap();
    let lms = fitted_file(dir.path());
    let opts =
        StartOptions { deformation: Some(dir.path().join("fit.json")), ..Default::default() };
    let start = |with_fit: bool| -> (Doc, crate::spline::Spline) {
        let mut d = initial_doc(&opts, dir.path()).unwrap();
        assert_eq!(d.pairs().len(), lms.len(), "the fit's landmarks come in as pairs");
        assert!(d.pairs().iter().zip(&lms).all(|(p, l)| p.active && p.landmark == *l));
        if !with_fit {
            d.set_pairs(Vec::new()).unwrap();
        }
        let fitted = d.spline().clone();
        // Three corrections near (15, 15): 3 px right of where the fit sends them.
        for src in [[12.0, 12.0], [20.0, 14.0], [14.0, 22.0]] {
            let q = fitted.eval(src, None).unwrap();
            let (st, v) = call(
                &mut d,
                "POST",
                "/api/landmarks/add",
                json!({"src": src, "dst": [q[0] + 3.0, q[1]]}),
            );
            assert_eq!(st, 200, "{v}");
        }
        let (st, v) = call(&mut d, "POST", "/api/refit", json!({}));
        assert_eq!(st, 200, "{v}");
        (d, fitted)
    };
    // Far from the corrections: x or y >= 60.
    let far: Vec<[f64; 2]> = (0..=10)
        .flat_map(|j| (0..=10).map(move |i| [10.0 * i as f64, 10.0 * j as f64]))
        .filter(|p| p[0] >= 60.0 || p[1] >= 60.0)
        .collect();
    let moved = |d: &Doc, fitted: &crate::spline::Spline| {
        far.iter()
            .map(|&p| {
                let (a, b) = (fitted.eval(p, None).unwrap(), d.spline().eval(p, None).unwrap());
                (a[0] - b[0]).hypot(a[1] - b[1])
            })
            .fold(0.0, f64::max)
    };
    let (kept, fitted) = start(true);
    let keep = moved(&kept, &fitted);
    assert!(keep < 1.0, "with the fit's landmarks, far points moved by up to {keep} px");
    let corrected = kept.spline().eval([15.0, 16.0], None).unwrap();
    let was = fitted.eval([15.0, 16.0], None).unwrap();
    assert!(corrected[0] - was[0] > 1.5, "the correction took: {was:?} -> {corrected:?}");
    let (lost, fitted) = start(false);
    let drop = moved(&lost, &fitted);
    assert!(drop > 5.0, "without them the re-fit loses the fit: far points moved {drop} px");
    eprintln!("far points moved: {keep:.3} px with the fit's landmarks, {drop:.1} px without");
}

#[test]
fn pairs_from_a_file_reject_a_bad_active_flag() {
    let v = json!({"landmarks": [{"src": [1, 2], "dst": [3, 4], "active": "no"}]});
    assert!(super::doc::pairs::pairs_from_scene(&v, "x.json").is_err());
    let v = json!({"landmarks": [{"src": [1, 2], "dst": [3, 4], "active": false}, {"src": [5, 6], "dst": [7, 8]}]});
    let p = super::doc::pairs::pairs_from_scene(&v, "x.json").unwrap().unwrap();
    assert_eq!(p.iter().map(|p: &Pair| p.active).collect::<Vec<_>>(), [false, true]);
}

/// The new paths pass the same gate as the others: no token 401, a foreign Host or Origin
/// 403, a body that is not JSON 415; with everything right they answer.
#[test]
fn the_new_paths_are_behind_the_gate() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Running::start(dir.path(), std::time::Duration::from_secs(5));
    let a = srv.addr;
    let body = br#"{"index": 0, "active": false}"#;
    for (method, path, b) in [
        ("GET", "/api/fixed.png", &b""[..]),
        ("GET", "/api/warp?forward=1", &b""[..]),
        ("POST", "/api/landmarks/active", &body[..]),
        ("POST", "/api/update?warp=8", &br#"{"op": "translate", "v": [1, 0]}"#[..]),
    ] {
        let ct = if b.is_empty() {
            String::new()
        } else {
            format!("Content-Type: application/json\r\nContent-Length: {}\r\n", b.len())
        };
        let no_token =
            format!("{method} {path} HTTP/1.1\r\nHost: {a}\r\n{ct}Connection: close\r\n\r\n");
        assert_eq!(http(a, &no_token, b).0, 401, "{method} {path} without the token");
        let foreign =
            srv.head(method, path, &ct).replace(&format!("Host: {a}"), "Host: evil.example");
        assert_eq!(http(a, &foreign, b).0, 403, "{method} {path} with a foreign Host");
        let origin = srv.head(method, path, &format!("{ct}Origin: http://evil.example\r\n"));
        assert_eq!(http(a, &origin, b).0, 403, "{method} {path} with a foreign Origin");
        if !b.is_empty() {
            let plain = srv.head(method, path, &ct.replace("application/json", "text/plain"));
            assert_eq!(http(a, &plain, b).0, 415, "{method} {path} as text/plain");
        }
        // Admitted: the handler answers (404 no fixed image / no frame, 422 no pair or no
        // selection; never a gate refusal).
        let st = http(a, &srv.head(method, path, &ct), b).0;
        assert!(matches!(st, 404 | 422), "{method} {path}: {st}");
    }
}

/// The live warp's basis on a select answer: `map + v_x gx + v_y gy` is the forward map
/// the exact update for `v` answers, and asking for it leaves the spline as it was.
#[test]
fn the_translate_basis_predicts_the_exact_forward_map() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = two_images(dir.path());
    let m = d.spline().mesh();
    let c = (0..m.num_vertices()).find(|&v| m.vertex(v) == [50.0, 50.0]).unwrap();
    let before = d.spline().points().to_vec();
    let (st, s) = call(&mut d, "POST", "/api/select?warp=8", json!({"anchors": [c], "radius": 2}));
    assert_eq!(st, 200, "{s}");
    assert_eq!(d.spline().points(), &before[..], "the probes leave the spline as it was");
    let basis = &s["warp"];
    let nums = |k: &str| -> Vec<f64> {
        basis[k].as_array().unwrap().iter().map(|x| x.as_f64().unwrap_or(f64::NAN)).collect()
    };
    let (p0, gx, gy) = (nums("map"), nums("gx"), nums("gy"));
    assert!(gx.iter().any(|&g| g > 0.1), "the nodes near the anchor follow it");
    for v in [[6.0, -4.0], [-2.5, 7.25]] {
        let (st, u) =
            call(&mut d, "POST", "/api/update?warp=8", json!({"op": "translate", "v": v}));
        assert_eq!(st, 200, "{u}");
        let exact: Vec<f64> =
            u["warp"]["map"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        for k in 0..exact.len() {
            let want = p0[k] + v[0] * gx[k] + v[1] * gy[k];
            assert!((want - exact[k]).abs() < 4e-3, "node value {k}: {want} vs {}", exact[k]);
        }
    }
    // After a drag step the probes re-apply it: the spline stays where the step put it.
    let moved = d.spline().points().to_vec();
    let (st, again) =
        call(&mut d, "POST", "/api/select?warp=8", json!({"anchors": [c], "radius": 2}));
    assert_eq!(st, 200, "{again}");
    assert_eq!(d.spline().points(), &moved[..]);
    // No basis without the query, nor in a z mode or without a frame.
    let (_, plain) = call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 2}));
    assert!(plain.get("warp").is_none());
    let mut bare = doc(dir.path());
    let (st, v) =
        call(&mut bare, "POST", "/api/select?warp=8", json!({"anchors": [c], "radius": 2}));
    assert_eq!(st, 200, "{v}");
    assert!(v.get("warp").is_none());
}
