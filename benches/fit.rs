//! Criterion benches of fitting (issue: fitting, point 7).
//!
//! * `fit_50_landmarks_100_triangles`: 50 landmarks, a 100-triangle degree-5 mesh, squares
//!   loss, bending 0.01, barrier on; the whole `fit` call (objective, factorization, solve,
//!   exact certification, report). Target 20 ms.
//! * `fit_cauchy_50_landmarks_100_triangles`: the same with the Cauchy loss (IRLS).
//! * `fit_frame_50_auto` / `fit_frame_500_auto`: 50 / 500 landmarks over a 511 x 511 frame,
//!   no deformation given: the landmark-adapted mesh (two far-field rings, 15-degree
//!   refinement), the leave-one-out choice of the smoothing weight,
//!   the fit, the fold certificate and the coverage check (`fit::frame::fit_frame`). Targets
//!   20 ms and 200 ms.
//! * `track_and_fit_511`: one frame of a sequence: 50 landmarks tracked (pyramidal
//!   Lucas-Kanade, forward-backward check) from frame 0 to frame 1 of the bundled 511 x 511
//!   time-lapse, then the fit to the tracked points. Target 100 ms.
//! * `hard_100_grid`: `fit --hard` with 100 landmarks (4-decimal sources and targets) on a
//!   12 x 12 grid mesh over 511 x 511, degree 5: the soft fit, then the exact solve in MDS
//!   coordinates and the exact checks. Target 1 s.
//! * `hard_100_delaunay`: the same landmarks on a Delaunay mesh through their sources
//!   (snapping grid 10000, so each source is a vertex exactly).

use criterion::{criterion_group, criterion_main, Criterion};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use trimorph::fit::landmarks::Landmark;
use trimorph::fit::objective::Loss;
use trimorph::fit::track::{track_points, TrackOptions};
use trimorph::fit::{fit, FitOptions};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::Spline;

fn landmarks(n: usize, seed: u64) -> Vec<Landmark> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let p: [f64; 2] = [rng.gen_range(5.0..505.0), rng.gen_range(5.0..505.0)];
            let q = [p[0] + 6.0 * (p[1] / 70.0).sin() + 2.0, p[1] + 5.0 * (p[0] / 90.0).cos()];
            Landmark { name: Some(format!("l{i}")), src: p, dst: q, weight: 1.0 }
        })
        .collect()
}

fn bench_frame(c: &mut Criterion) {
    use trimorph::fit::frame::{fit_frame, FrameFitOptions};
    let mut g = c.benchmark_group("fit_frame");
    g.sample_size(10);
    for n in [50usize, 500] {
        let lms = landmarks(n, 5);
        let opts = FrameFitOptions::default();
        let f = fit_frame(&lms, [511.0, 511.0], &opts).unwrap();
        eprintln!(
            "{n} landmarks: {} triangles, margin {}, {} variables, bend {:.2e}, fold-free {}, covers {}, {:.1} ms",
            f.frame.triangles,
            f.frame.margin,
            f.fit.report.variables,
            f.fit.report.bend,
            f.fit.report.fold_free,
            f.frame.covers_frame,
            f.fit.report.time_ms
        );
        g.bench_function(format!("fit_frame_{n}_auto"), |b| {
            b.iter(|| black_box(fit_frame(&lms, [511.0, 511.0], &opts).unwrap().fit.report.fit.rms))
        });
    }
    g.finish();
}

fn setup() -> (Spline, Vec<Landmark>) {
    let mesh = Mesh::grid(10, 5, 511.0, 511.0, MeshOptions::default()).unwrap();
    let s = Spline::identity(mesh, 5).unwrap();
    let mut rng = SmallRng::seed_from_u64(11);
    let lms = (0..50)
        .map(|i| {
            let p: [f64; 2] = [rng.gen_range(5.0..505.0), rng.gen_range(5.0..505.0)];
            let q = [p[0] + 6.0 * (p[1] / 70.0).sin() + 2.0, p[1] + 5.0 * (p[0] / 90.0).cos()];
            Landmark { name: Some(format!("l{i}")), src: p, dst: q, weight: 1.0 }
        })
        .collect();
    (s, lms)
}

fn bench(c: &mut Criterion) {
    let (s, lms) = setup();
    eprintln!("mesh: {} triangles, {} control points", s.mesh().num_triangles(), s.num_points());
    let opts = FitOptions::default();
    let f = fit(&s, &lms, &opts).unwrap();
    eprintln!(
        "{} ({} variables), fit rms {:.4}",
        f.report.method, f.report.variables, f.report.fit.rms
    );
    c.bench_function("fit_50_landmarks_100_triangles", |b| {
        b.iter(|| black_box(fit(&s, &lms, &opts).unwrap().report.fit.rms))
    });
    let cauchy = FitOptions { loss: Loss::Cauchy(2.0), ..FitOptions::default() };
    c.bench_function("fit_cauchy_50_landmarks_100_triangles", |b| {
        b.iter(|| black_box(fit(&s, &lms, &cauchy).unwrap().report.fit.rms))
    });
}

/// The 50 strongest-gradient pixels of a frame, at least 30 px apart and 25 px inside.
fn features(img: &image::GrayImage, n: usize) -> Vec<[f64; 2]> {
    let (w, h) = img.dimensions();
    let g = |x: u32, y: u32| img.get_pixel(x, y)[0] as f64;
    let mut cand: Vec<(f64, [f64; 2])> = Vec::new();
    for y in 25..h - 25 {
        for x in 25..w - 25 {
            let (gx, gy) = (g(x + 1, y) - g(x - 1, y), g(x, y + 1) - g(x, y - 1));
            cand.push((gx * gx + gy * gy, [x as f64, y as f64]));
        }
    }
    cand.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut out: Vec<[f64; 2]> = Vec::new();
    for (_, p) in cand {
        if out.len() < n && out.iter().all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) >= 30.0) {
            out.push(p);
        }
    }
    out
}

fn bench_track(c: &mut Criterion) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/timelapse");
    let f0 = image::open(format!("{dir}/frame_00.png")).unwrap().to_luma8();
    let f1 = image::open(format!("{dir}/frame_01.png")).unwrap().to_luma8();
    let pts = features(&f0, 50);
    let mesh = Mesh::grid(10, 5, 511.0, 511.0, MeshOptions::default()).unwrap();
    let s = Spline::identity(mesh, 5).unwrap();
    let opts = FitOptions::default();
    let run = || {
        let moved = track_points(&f0, &f1, &pts, None, &TrackOptions::default()).unwrap();
        let lms: Vec<Landmark> = pts
            .iter()
            .zip(moved)
            .filter_map(|(p, m)| m.map(|d| Landmark { name: None, src: *p, dst: d, weight: 1.0 }))
            .collect();
        fit(&s, &lms, &opts).unwrap()
    };
    let f = run();
    eprintln!(
        "tracked {} of {} points; fit rms {:.3}",
        f.report.fit.count,
        pts.len(),
        f.report.fit.rms
    );
    c.bench_function("track_and_fit_511", |b| b.iter(|| black_box(run().report.fit.rms)));
}

/// 100 landmarks with 4-decimal coordinates (as typed in a landmark file).
fn landmarks4(n: usize) -> Vec<Landmark> {
    let dec4 = |v: f64| format!("{v:.4}").parse::<f64>().unwrap();
    let mut rng = SmallRng::seed_from_u64(21);
    (0..n)
        .map(|i| {
            let p = [dec4(rng.gen_range(3.0..508.0)), dec4(rng.gen_range(3.0..508.0))];
            let q = [p[0] + 6.0 * (p[1] / 70.0).sin() + 2.0, p[1] + 5.0 * (p[0] / 90.0).cos()];
            Landmark { name: Some(format!("l{i}")), src: p, dst: q.map(dec4), weight: 1.0 }
        })
        .collect()
}

fn bench_hard(c: &mut Criterion) {
    let lms = landmarks4(100);
    let grid =
        Spline::identity(Mesh::grid(12, 12, 511.0, 511.0, MeshOptions::default()).unwrap(), 5)
            .unwrap();
    let mut pts: Vec<[f64; 2]> = vec![[0.0, 0.0], [511.0, 0.0], [0.0, 511.0], [511.0, 511.0]];
    pts.extend(lms.iter().map(|l| l.src));
    let delaunay =
        Spline::identity(Mesh::delaunay(&pts, MeshOptions { grid: 10000 }).unwrap(), 5).unwrap();
    let hard = FitOptions { hard: true, ..FitOptions::default() };
    for (name, s) in [("hard_100_grid", &grid), ("hard_100_delaunay", &delaunay)] {
        let size =
            |f: &trimorph::fit::Fit| trimorph::io::deformation::to_string(&f.spline, None).len();
        let h = fit(s, &lms, &hard).unwrap();
        let soft = fit(s, &lms, &FitOptions::default()).unwrap();
        eprintln!(
            "{name}: {} triangles; hard {:.1} ms, file {} bytes; soft {:.1} ms, file {} bytes",
            s.mesh().num_triangles(),
            h.report.time_ms,
            size(&h),
            soft.report.time_ms,
            size(&soft)
        );
        c.bench_function(name, |b| {
            b.iter(|| black_box(fit(s, &lms, &hard).unwrap().report.fit.max))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench, bench_frame, bench_track
}
criterion_group! {
    name = hard_benches;
    config = Criterion::default().sample_size(10);
    targets = bench_hard
}
criterion_main!(benches, hard_benches);
