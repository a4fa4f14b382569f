//! Criterion benches of automatic landmarks on real data (two consecutive 511 x 511 frames of
//! the fluorescence time-lapse in `data/microscopy/timelapse/`).
//!
//! * `orb_match_511`: ORB (1000 keypoints) in both frames, ratio + cross-check matching and
//!   RANSAC affine ([`match_images`] with default options).
//! * `lk_track_50_511`: pyramidal Lucas-Kanade (window 21, 3 levels) of 50 points on a
//!   10 x 5 grid, with the forward-backward check ([`track_points`], default options).
//!
//! First run (2 cores shared with other builds, load average about 5, so upper bounds):
//! `orb_match_511` 144 ms (1013 / 1004 keypoints, 248 matches, 248 inliers);
//! `lk_track_50_511` 55 ms (19 of the 50 grid points tracked; the others lie on flat
//! background or fail the forward-backward check).

use criterion::{criterion_group, criterion_main, Criterion};
use image::GrayImage;
use std::hint::black_box;
use trimorph::fit::features::{match_images, MatchOptions};
use trimorph::fit::track::{track_points, TrackOptions};

fn frame(k: usize) -> GrayImage {
    let p = format!("{}/data/microscopy/timelapse/frame_{k:02}.png", env!("CARGO_MANIFEST_DIR"));
    image::open(p).unwrap().to_luma8()
}

fn bench(c: &mut Criterion) {
    let (a, b) = (frame(0), frame(1));
    let opts = MatchOptions::default();
    let r = match_images(&a, &b, &opts).unwrap();
    eprintln!(
        "orb_match_511: keypoints {:?}, matches {}, inliers {}, affine {}",
        r.stats.keypoints, r.stats.matches, r.stats.inliers, r.stats.model
    );
    c.bench_function("orb_match_511", |bn| {
        bn.iter(|| match_images(black_box(&a), black_box(&b), &opts).unwrap())
    });

    let pts: Vec<[f64; 2]> = (0..10)
        .flat_map(|i| (0..5).map(move |j| [30.0 + 50.0 * i as f64, 40.0 + 100.0 * j as f64]))
        .collect();
    let topts = TrackOptions::default();
    let t = track_points(&a, &b, &pts, None, &topts).unwrap();
    eprintln!("lk_track_50_511: {} of 50 points tracked", t.iter().flatten().count());
    c.bench_function("lk_track_50_511", |bn| {
        bn.iter(|| track_points(black_box(&a), black_box(&b), &pts, None, &topts).unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
