//! Criterion benches of the exact layer (issue: foundation, speed targets).
//!
//! * `ecles_single_anchor_60`: initialize (factor R_ED, ~60 x 60 sparse, small entries) plus
//!   one update, and the update alone; target: 1 ms or less for both together.
//! * `sparse_400x800`: 400 x 800, 4 nonzeros per row in random columns near the diagonal,
//!   entries in [-20, 20]: sparse factoring (Turner, GCD) vs the dense Bareiss baseline;
//!   target: sparse at least 5x faster.
//! * `affine_f64_eval`: one evaluation of the f64 fast path of a 60-derived session.

use criterion::{criterion_group, criterion_main, Criterion};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use trimorph::ecles::{ConstraintSystem, InitOptions};
use trimorph::exact::ldu::dense::factor_dense_turner;
use trimorph::exact::{rat_int, Int, Ldu, LduOptions, Rat, Simplification, SparseIntMatrix};

fn banded(
    m: usize,
    n: usize,
    per_row: usize,
    spread: usize,
    bound: i64,
    seed: u64,
) -> SparseIntMatrix {
    let mut rng = SmallRng::seed_from_u64(seed);
    let rows = (0..m)
        .map(|i| {
            let center = i * n / m.max(1);
            let lo = center.saturating_sub(spread);
            let hi = (center + spread).min(n - 1);
            let mut cols: Vec<usize> = Vec::new();
            while cols.len() < per_row.min(hi - lo + 1) {
                let c = rng.gen_range(lo..=hi);
                if !cols.contains(&c) {
                    cols.push(c);
                }
            }
            cols.into_iter()
                .map(|c| {
                    let mut v = 0;
                    while v == 0 {
                        v = rng.gen_range(-bound..=bound);
                    }
                    (c, Int::from(v))
                })
                .collect()
        })
        .collect();
    SparseIntMatrix::from_rows(n, rows).unwrap()
}

/// A C1-like system: each constraint ties 4 nearby 2D points with small integer coefficients
/// summing to zero (affine invariance), 60 derived + 1 anchor + fixed neighbours.
fn spline_like() -> (ConstraintSystem, Vec<Vec<Rat>>, Vec<usize>, Vec<usize>) {
    let n = 90;
    let m = 60;
    let mut rng = SmallRng::seed_from_u64(3);
    let rows = (0..m)
        .map(|i| {
            let base = i * (n - 4) / m;
            let mut cols: Vec<usize> = Vec::new();
            while cols.len() < 4 {
                let c = base + rng.gen_range(0..6).min(n - 1 - base);
                if !cols.contains(&c) {
                    cols.push(c);
                }
            }
            let a: i64 = rng.gen_range(1..=16);
            let b: i64 = rng.gen_range(1..=16);
            let c: i64 = rng.gen_range(1..=16);
            vec![
                (cols[0], Int::from(a)),
                (cols[1], Int::from(b)),
                (cols[2], Int::from(c)),
                (cols[3], Int::from(-(a + b + c))),
            ]
        })
        .collect();
    let r = SparseIntMatrix::from_rows(n, rows).unwrap();
    let p: Vec<Vec<Rat>> =
        (0..n).map(|s| vec![rat_int(s as i64 % 7), rat_int(s as i64 % 5)]).collect();
    let q = r.mul_rat(&p);
    let sys = ConstraintSystem::new(r, q).unwrap();
    let anchors = vec![45];
    let derived: Vec<usize> = (15..76).filter(|&s| s != 45).collect();
    (sys, p, anchors, derived)
}

fn bench(c: &mut Criterion) {
    let (sys, p, anchors, derived) = spline_like();
    let newa = vec![vec![Rat::new(Int::from(11), Int::from(2)), rat_int(3)]];
    {
        let s = sys.initialize(&p, &anchors, &derived, InitOptions::default()).unwrap();
        eprintln!(
            "spline-like session: |E| = {}, |D| = {}, rank {}",
            s.relevant().len(),
            derived.len(),
            s.rank()
        );
    }
    c.bench_function("ecles_single_anchor_60/initialize+update", |b| {
        b.iter(|| {
            let mut s = sys.initialize(&p, &anchors, &derived, InitOptions::default()).unwrap();
            s.update(&newa, None, None).unwrap();
            black_box(s.derived_scaled().len())
        })
    });
    c.bench_function("ecles_single_anchor_60/initialize+update+reduce", |b| {
        b.iter(|| {
            let mut s = sys.initialize(&p, &anchors, &derived, InitOptions::default()).unwrap();
            s.update(&newa, None, None).unwrap();
            black_box(s.derived_values().len())
        })
    });
    let mut s = sys.initialize(&p, &anchors, &derived, InitOptions::default()).unwrap();
    s.update(&newa, None, None).unwrap();
    c.bench_function("ecles_single_anchor_60/update", |b| {
        b.iter(|| {
            s.update(&newa, None, None).unwrap();
            black_box(s.derived_scaled().len())
        })
    });
    let map = s.affine_map(None).unwrap().to_f64();
    let hints: Vec<f64> = s.derived_f64().into_iter().flatten().collect();
    let fixed = map.with_fixed_hints(&hints);
    let mut out = vec![0.0; derived.len() * 2];
    c.bench_function("affine_f64_eval/60_derived", |b| {
        b.iter(|| {
            fixed.eval_into(black_box(&[5.5, 3.0]), &[], &mut out);
            black_box(out[0])
        })
    });

    let a = banded(400, 800, 4, 8, 20, 42);
    let dense = a.to_dense();
    let mut g = c.benchmark_group("sparse_400x800");
    g.sample_size(10);
    for method in [Simplification::Turner, Simplification::Gcd] {
        g.bench_function(format!("sparse_{method}"), |b| {
            b.iter(|| black_box(Ldu::factor(&a, LduOptions::with(method)).rank()))
        });
    }
    g.bench_function("dense_bareiss_baseline", |b| {
        b.iter(|| black_box(factor_dense_turner(&dense).rank()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
