//! `POST /api/register` (issue 50): a two-image session registered again from its pixels,
//! from the deformation being edited, the pinned points held exactly, one undo step.

use super::doc::Doc;
use super::tests::call;
use crate::register::frame_mesh;
use crate::spline::Spline;
use serde_json::{json, Value};

/// A 120 x 100 crop of the bundled cell image (MOVING) and the same scene seen shifted by
/// (3, -2) pixels (FIXED), both set in a document over MOVING's registration mesh.
fn session(root: &std::path::Path) -> Doc {
    let cell = image::open("data/microscopy/cell.png").unwrap().to_luma8();
    let crop = |x, y| image::imageops::crop_imm(&cell, x, y, 120, 100).to_image();
    let (moving, fixed) = (crop(200, 240), crop(197, 242));
    let s = Spline::identity(frame_mesh(120, 100, 40.0).unwrap(), 5).unwrap();
    let mut d = Doc::new(s, root);
    d.set_frame("moving.png".into(), image::DynamicImage::ImageLuma8(moving)).unwrap();
    d.set_fixed("fixed.png".into(), image::DynamicImage::ImageLuma8(fixed)).unwrap();
    d
}

/// The mesh vertex nearest to `p`.
fn vertex_near(d: &Doc, p: [f64; 2]) -> usize {
    let m = d.spline().mesh();
    let dist = |v: usize| (m.vertex(v)[0] - p[0]).hypot(m.vertex(v)[1] - p[1]);
    (0..m.num_vertices()).min_by(|&a, &b| dist(a).total_cmp(&dist(b))).unwrap()
}

#[test]
fn re_registering_improves_the_match_keeps_the_pinned_point_and_undoes() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = session(dir.path());
    // A hand correction near the middle: the anchor becomes pinned.
    let c = vertex_near(&d, [60.0, 50.0]);
    call(&mut d, "POST", "/api/select", json!({"anchors": [c], "radius": 1}));
    let (st, v) = call(&mut d, "POST", "/api/update", json!({"op": "translate", "v": [3.0, -2.0]}));
    assert_eq!(st, 200, "{v}");
    let corrected = d.spline().points()[c].clone();
    let before = d.spline().points().to_vec();
    let (st, v) = call(&mut d, "POST", "/api/register", json!({"iterations": 15}));
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["metric"], "ncc");
    assert_eq!(v["pinned"], 1);
    assert_eq!(v["pairs"], 0);
    assert_eq!(v["fold_free"], true, "{v}");
    let (b, a) = (v["metric_before"].as_f64().unwrap(), v["metric_after"].as_f64().unwrap());
    assert!(a < 0.5 * b, "the match improves: {b} -> {a}");
    assert!(v.get("state").is_some(), "geometry and state ride along: {v}");
    // The pinned point is held exactly; the rest moved; the result is exactly C1.
    assert_eq!(d.spline().points()[c], corrected);
    assert_ne!(d.spline().points(), &before[..]);
    d.spline().check_c1().unwrap();
    // phi maps MOVING to FIXED: the scene point at MOVING's (60, 30) is FIXED's (63, 28).
    let m = d.spline().eval([60.0, 30.0], None).unwrap();
    assert!((m[0] - 63.0).hypot(m[1] - 28.0) < 0.5, "{m:?}");
    // One undo step, named.
    let (_, st) = call(&mut d, "GET", "/api/state", Value::Null);
    assert_eq!(st["undo"], 2, "{st}");
    call(&mut d, "POST", "/api/undo", Value::Null);
    assert_eq!(d.spline().points(), &before[..]);
}

#[test]
fn re_registering_is_refused_without_two_images_or_with_bad_options() {
    let dir = tempfile::tempdir().unwrap();
    let mut one = super::tests::doc(dir.path());
    let (st, v) = call(&mut one, "POST", "/api/register", Value::Null);
    assert_eq!(st, 422, "{v}");
    assert!(v["error"].as_str().unwrap().contains("--fixed"), "{v}");
    let mut d = session(dir.path());
    let before = d.spline().points().to_vec();
    let (st, v) = call(&mut d, "POST", "/api/register", json!({"hard": true}));
    assert_eq!(st, 422, "{v}");
    assert!(v["error"].as_str().unwrap().contains("pairs"), "{v}");
    for body in [json!({"metric": "cc"}), json!({"iterations": -1}), json!({"pairs": 1})] {
        let (st, v) = call(&mut d, "POST", "/api/register", body.clone());
        assert_eq!(st, 400, "{body}: {v}");
    }
    assert_eq!(d.spline().points(), &before[..], "a refusal changes nothing");
}
