//! The `Map2` trait from outside: a thin-plate spline baseline and an affine map go through
//! the same generic resampling as the spline (`warp::pull_back_map`, `warp::warp_map`).

use crate::common;
use common::tps::Tps;
use std::path::Path;
use trimorph::fit::landmarks::Landmark;
use trimorph::geom::{Point, Vector};
use trimorph::warp::{pull_back_map, warp_map, AffineMap, Interp, Map2};

fn frame(name: &str) -> image::DynamicImage {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/microscopy/timelapse").join(name);
    image::open(p).unwrap()
}

fn lm(src: [f64; 2], dst: [f64; 2]) -> Landmark {
    Landmark { name: None, src, dst, weight: 1.0 }
}

/// A TPS through identity landmarks is the identity: pulling a real frame back through it
/// gives the frame, exactly.
#[test]
fn an_identity_tps_pulls_a_real_frame_back_unchanged() {
    let img = frame("frame_00.png");
    let pts = [[40.0, 60.0], [400.0, 80.0], [250.0, 300.0], [90.0, 450.0], [470.0, 470.0]];
    let tps = Tps::new(&pts.map(|p| lm(p, p)));
    let (w, h) = (img.width(), img.height());
    let out = pull_back_map(&tps, &img, w, h, Interp::Bilinear, 0.0).unwrap();
    assert_eq!(out.to_luma8(), img.to_luma8());
}

/// The TPS's analytic Jacobian matches central differences (1e-6 relative, step 1e-3 px),
/// and the map interpolates its landmarks.
#[test]
fn tps_jacobian_matches_finite_differences() {
    let src = [[40.0, 60.0], [400.0, 80.0], [250.0, 300.0], [90.0, 450.0], [470.0, 470.0]];
    let dst = [[45.0, 58.0], [396.0, 90.0], [262.0, 296.0], [80.0, 455.0], [470.0, 480.0]];
    let lms: Vec<Landmark> = src.iter().zip(&dst).map(|(s, d)| lm(*s, *d)).collect();
    let tps = Tps::new(&lms);
    for (s, d) in src.iter().zip(&dst) {
        let q = tps.value(Point::from(*s)).unwrap();
        assert!((q.x - d[0]).abs() < 1e-6 && (q.y - d[1]).abs() < 1e-6);
    }
    let h = 1e-3;
    for p in [[100.0, 100.0], [300.0, 200.0], [250.0, 301.0]] {
        let j = tps.jacobian(p.into()).unwrap();
        for c in 0..2 {
            let mut a = p;
            let mut b = p;
            a[c] += h;
            b[c] -= h;
            let (fa, fb) = (tps.value(a.into()).unwrap(), tps.value(b.into()).unwrap());
            let (fa, fb) = (fa.to_array(), fb.to_array());
            for r in 0..2 {
                let fd = (fa[r] - fb[r]) / (2.0 * h);
                assert!((fd - j[r][c]).abs() <= 1e-6 * (1.0 + fd.abs()), "{p:?} {r} {c}");
            }
        }
    }
}

/// An affine map warps a real frame both ways: `warp_map` then `pull_back_map` through the
/// same map gives the frame back wherever the round trip stays inside it (nearest
/// neighbour and a whole-pixel shift, so exactly).
#[test]
fn an_affine_round_trip_on_a_real_frame_is_exact_inside() {
    let img = frame("frame_03.png");
    let m = AffineMap { a: [[1.0, 0.0], [0.0, 1.0]], b: Vector::new(7.0, -4.0) };
    let warped = warp_map(&m, &img, Interp::Nearest, 0.0).unwrap();
    let (w, h) = (img.width(), img.height());
    let back = pull_back_map(&m, &warped, w, h, Interp::Nearest, 0.0).unwrap().to_luma8();
    let orig = img.to_luma8();
    for y in 4..h {
        for x in 0..w - 7 {
            assert_eq!(back.get_pixel(x, y), orig.get_pixel(x, y), "({x}, {y})");
        }
    }
}
