//! Criterion benches of fitting (issue: fitting, point 7).
//!
//! * `fit_50_landmarks_100_triangles`: 50 landmarks, a 100-triangle degree-5 mesh, squares
//!   loss, bending 0.01, barrier on; the whole `fit` call (objective, factorization, solve,
//!   exact certification, report). Target 20 ms.
//! * `fit_cauchy_50_landmarks_100_triangles`: the same with the Cauchy loss (IRLS).

use criterion::{criterion_group, criterion_main, Criterion};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use trimorph::fit::landmarks::Landmark;
use trimorph::fit::objective::Loss;
use trimorph::fit::solve::{fit, FitOptions};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::Spline;

fn setup() -> (Spline, Vec<Landmark>) {
    let mesh = Mesh::grid(10, 5, 511.0, 511.0, MeshOptions::default()).unwrap();
    let s = Spline::identity(mesh, 5).unwrap();
    let mut rng = SmallRng::seed_from_u64(11);
    let lms = (0..50)
        .map(|i| {
            let p = [rng.gen_range(5.0..505.0), rng.gen_range(5.0..505.0)];
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

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
