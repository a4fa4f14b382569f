//! Criterion benches of fitting and warping at users' sizes (issue 51).
//!
//! The time-lapse tracks of frames 0 and 9 (`data/microscopy/timelapse/tracks_0_9.csv`),
//! scaled from 511 to 4096 pixels, fitted with all defaults (`fit --size 4096,4096`: a
//! landmark-adapted mesh with two far-field rings, 16 times the frame), then a 4096 x 4096
//! 8-bit gray image warped through the fit (bilinear, 0.01 px):
//!
//! * `warp_4096_default_fit`: the warp alone (inverse-map plan and resampling);
//! * `warp_4096_fit_without_rings`: the same through the fit with `--far-rings 0`, whose mesh
//!   is the frame and its margin only: the "grid speed" the default fit must match;
//! * `fit_then_warp_4096_default`: the whole pipeline, fit then warp.
//!
//! Many landmarks (issue 51, point 2): `fit_10000_landmarks_4096` fits 10,000 pairs of a
//! smooth field (12 px at most) over a 4096^2 frame with all defaults: a mesh over 1,000
//! thinned sources, the variable-space squares fit and its GCV weight search
//! ([`trimorph::fit::smooth_sparse`]), the exact rounding and the certificate.
//!
//! Targets (issue 51): the warp through the default fit costs what a warp through a mesh of
//! the frame costs; 10,000 landmarks fit in at most 10 s (goal 1 s). Run with
//! `cargo bench --bench scale`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use image::{DynamicImage, GrayImage, Luma};
use std::hint::black_box;
use std::path::Path;
use trimorph::fit::frame::{fit_frame, FrameFitOptions};
use trimorph::fit::landmarks::Landmark;
use trimorph::io::landmarks::read_landmarks;
use trimorph::warp::{warp_pages, WarpOptions};

const N: u32 = 4096;

fn tracks() -> Vec<Landmark> {
    let k = N as f64 / 511.0;
    read_landmarks(Path::new("data/microscopy/timelapse/tracks_0_9.csv"))
        .expect("bundled tracks")
        .into_iter()
        .map(|l| Landmark { src: l.src.map(|v| v * k), dst: l.dst.map(|v| v * k), ..l })
        .collect()
}

fn bench(c: &mut Criterion) {
    let lms = tracks();
    let size = [N as f64, N as f64];
    let fo = FrameFitOptions::default();
    let ringed = fit_frame(&lms, size, &fo).expect("default fit").fit.spline;
    let mut no_rings = FrameFitOptions::default();
    no_rings.mesh.far_rings = 0;
    let plain = fit_frame(&lms, size, &no_rings).expect("fit without rings").fit.spline;
    let img = DynamicImage::ImageLuma8(GrayImage::from_fn(N, N, |x, y| {
        Luma([((x / 7 + y / 5) % 2 * 200 + (x ^ y) % 50) as u8])
    }));
    let opts = WarpOptions::default();
    let one = std::slice::from_ref(&img);
    let mut g = c.benchmark_group("scale");
    g.sample_size(10);
    g.throughput(Throughput::Elements(N as u64 * N as u64));
    g.bench_function("warp_4096_default_fit", |b| {
        b.iter(|| black_box(warp_pages(&ringed, one, &opts, &|_| {}).unwrap()))
    });
    g.bench_function("warp_4096_fit_without_rings", |b| {
        b.iter(|| black_box(warp_pages(&plain, one, &opts, &|_| {}).unwrap()))
    });
    g.bench_function("fit_then_warp_4096_default", |b| {
        b.iter(|| {
            let s = fit_frame(&lms, size, &fo).unwrap().fit.spline;
            black_box(warp_pages(&s, one, &opts, &|_| {}).unwrap())
        })
    });
    g.finish();
    let many = field_landmarks(10_000);
    let mut g = c.benchmark_group("scale");
    g.sample_size(10);
    g.bench_function("fit_10000_landmarks_4096", |b| {
        b.iter(|| black_box(fit_frame(&many, size, &fo).unwrap().fit.report.fit.rms))
    });
    g.finish();
}

/// `n` pairs of a smooth field over the 4096^2 frame (sources from a fixed LCG).
fn field_landmarks(n: usize) -> Vec<Landmark> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        state =
            state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * (N as f64 - 1.0)
    };
    let tau = std::f64::consts::TAU;
    (0..n)
        .map(|i| {
            let p = [next(), next()];
            let (x, y) = (p[0] / N as f64, p[1] / N as f64);
            let dst = [
                p[0] + 12.0 * (tau * x).sin() * (0.5 * tau * y).cos() + 5.0 * y,
                p[1] - 9.0 * (0.75 * tau * x + 0.3).cos() * (0.5 * tau * y).sin() + 3.0 * x,
            ];
            Landmark { name: Some(format!("p{i}")), src: p, dst, weight: 1.0 }
        })
        .collect()
}

criterion_group!(benches, bench);
criterion_main!(benches);
