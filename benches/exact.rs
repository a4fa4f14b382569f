//! Criterion benches of the exact core at scale (issue 24), each a whole `trimorph solve`
//! process (read JSON, solve, write JSON):
//!
//! * `solve_process/select_all_102`: select-all edit of a degree-5 C1 spline over a
//!   102-triangle random Delaunay mesh (740 x 1301 C1 matrix, rank 646), the control point
//!   nearest the middle moved (the problem of `examples/c1_select_all.rs 102 7`);
//! * `solve_process/select_all_1000`: the same over 1,000 triangles (target < 10 s; far
//!   slower today, so it runs only with `EXACT_BENCH_ONLY=select_all_1000`);
//! * `solve_process/sparse_400x800`: 400 x 800 banded random matrix (4 nonzeros per row,
//!   entries in [-20, 20]), one anchor, every other parameter derived;
//! * `edit_process/select_all_edit_1000`: `trimorph edit` of a 1,000-triangle spline, one
//!   anchor translated with every other point derived, in the default bounded mode (the
//!   determining-set path; target < 10 s, goal 1 s).
//! * `edit_process/select_all_unbounded_rotate_100`: `trimorph edit --unbounded` of a
//!   100-triangle spline, a select-all rotation with exact values (ECLES's modular path).
//!
//! * `exact_parts/decimal_200_x_3300_bits`, `exact_parts/lowest_terms_800_x_3300_bits`: the
//!   output's two costliest parts on their own, at the 400 x 800 solve's sizes.
//!
//! The FLINT comparison is `benches/flint_fflu.py` (needs python-flint), the scaling series
//! `benches/exact_scaling.sh`.

use criterion::{criterion_group, criterion_main, Criterion};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;
use trimorph::exact::rat_to_string;
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::Spline;

/// The identity spline of degree 5 over a random Delaunay mesh of at least `triangles`
/// triangles in [0, 200]^2 (the mesh of `examples/c1_select_all.rs`, seed 7).
fn select_all_spline(triangles: usize) -> Spline {
    let mut k = 3 + triangles / 2;
    let mesh = loop {
        let mut rng = SmallRng::seed_from_u64(7);
        let pts: Vec<[f64; 2]> =
            (0..k).map(|_| [rng.gen_range(0.0..200.0), rng.gen_range(0.0..200.0)]).collect();
        let m = Mesh::delaunay(&pts, MeshOptions::default()).unwrap();
        if m.num_triangles() >= triangles {
            break m;
        }
        k += 1;
    };
    Spline::identity(mesh, 5).unwrap()
}

fn select_all(triangles: usize) -> String {
    let s = select_all_spline(triangles);
    let rows: Vec<Vec<(usize, i64)>> = (0..s.c1_matrix().rows())
        .map(|i| {
            s.c1_matrix().row(i).iter().map(|(j, v)| (*j, v.to_string().parse().unwrap())).collect()
        })
        .collect();
    let p: Vec<[String; 2]> =
        s.points().iter().map(|q| [rat_to_string(&q[0]), rat_to_string(&q[1])]).collect();
    // The control point nearest the middle of the mesh (as `examples/c1_select_all.rs`
    // picks it). It must lie in some C1 condition: an inner control point of a triangle
    // lies in none, and moving it leaves every derived point where it is, a trivial solve.
    let anchor = (0..s.num_points())
        .min_by(|&a, &b| {
            let d = |i: usize| {
                let q = s.point_f64(i);
                (q[0] - 100.0).powi(2) + (q[1] - 100.0).powi(2)
            };
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    assert!(
        rows.iter().any(|r| r.iter().any(|&(j, _)| j == anchor)),
        "the anchor must be constrained"
    );
    problem(&rows, &p, anchor)
}

fn banded() -> String {
    let (m, n): (usize, usize) = (400, 800);
    let mut rng = SmallRng::seed_from_u64(42);
    let rows: Vec<Vec<(usize, i64)>> = (0..m)
        .map(|i| {
            let c = i * n / m;
            let (lo, hi) = (c.saturating_sub(8), (c + 8).min(n - 1));
            let mut cols: Vec<usize> = Vec::new();
            while cols.len() < 4 {
                let j = rng.gen_range(lo..=hi);
                if !cols.contains(&j) {
                    cols.push(j);
                }
            }
            cols.into_iter()
                .map(|j| (j, [-1, 1][rng.gen_range(0..2)] * rng.gen_range(1..=20)))
                .collect()
        })
        .collect();
    let p: Vec<[String; 2]> = (0..n).map(|j| [(j % 7).to_string(), (j % 5).to_string()]).collect();
    // Q = R P keeps the current state consistent.
    let mut text = problem(&rows, &p, 0);
    let q: Vec<String> = rows
        .iter()
        .map(|r| {
            let (a, b) = r.iter().fold((0i64, 0i64), |(a, b), &(j, v)| {
                (a + v * (j % 7) as i64, b + v * (j % 5) as i64)
            });
            format!("[{a},{b}]")
        })
        .collect();
    text.insert_str(1, &format!("\"Q\": [{}],", q.join(",")));
    text
}

/// A problem with sparse `R`, anchor `anchor` moved by (1/2, 1/3), all others derived.
fn problem(rows: &[Vec<(usize, i64)>], p: &[[String; 2]], anchor: usize) -> String {
    let mut t = String::from("{\"R\": {\"rows\": [");
    for (i, r) in rows.iter().enumerate() {
        let e: Vec<String> = r.iter().map(|(j, v)| format!("[{j},{v}]")).collect();
        let _ = write!(t, "{}[{}]", if i > 0 { "," } else { "" }, e.join(","));
    }
    t.push_str("]}, \"P\": [");
    let pr: Vec<String> = p.iter().map(|q| format!("[\"{}\",\"{}\"]", q[0], q[1])).collect();
    t.push_str(&pr.join(","));
    let _ = write!(
        t,
        "], \"anchors\": {{\"{anchor}\": [\"{}\", \"{}\"]}}, \"derived\": [",
        moved(&p[anchor][0], 2),
        moved(&p[anchor][1], 3)
    );
    let d: Vec<String> = (0..p.len()).filter(|&i| i != anchor).map(|i| i.to_string()).collect();
    t.push_str(&d.join(","));
    t.push_str("]}");
    t
}

fn moved(v: &str, k: i64) -> String {
    let r = trimorph::exact::parse_rat(v).unwrap()
        + trimorph::exact::Rat::new(1.into(), trimorph::exact::Int::from(k));
    rat_to_string(&r)
}

fn run(f: &Path, out: &Path) {
    let o = Command::new(env!("CARGO_BIN_EXE_trimorph"))
        .args(["solve", f.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("solve_process");
    g.sample_size(10);
    let only = std::env::var("EXACT_BENCH_ONLY").unwrap_or_default();
    for (name, text) in [
        ("sparse_400x800", banded()),
        ("select_all_102", select_all(102)),
        ("select_all_1000", String::new()),
    ] {
        if !only.is_empty() && !name.contains(&only) {
            continue;
        }
        // The 1,000-triangle select-all takes far more than a bench run (see the README's
        // scaling figures): it runs only when asked for by name.
        let text = if name == "select_all_1000" {
            if !only.contains("select_all_1000") {
                continue;
            }
            select_all(1000)
        } else {
            text
        };
        let f = dir.path().join(format!("{name}.json"));
        std::fs::write(&f, &text).unwrap();
        // EXACT_BENCH_DUMP=DIR keeps a copy of each problem (for benches/flint_fflu.py).
        if let Ok(keep) = std::env::var("EXACT_BENCH_DUMP") {
            std::fs::create_dir_all(&keep).unwrap();
            std::fs::write(Path::new(&keep).join(format!("{name}.json")), &text).unwrap();
        }
        let out = dir.path().join(format!("{name}.out.json"));
        g.bench_function(name, |b| b.iter(|| run(&f, &out)));
    }
    g.finish();
}

/// `trimorph edit` of a 1,000-triangle spline: a select-all translation in the default
/// bounded mode (the determining-set path, `edit::global`), as a whole process.
fn bench_edit(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let s = select_all_spline(1000);
    let def = dir.path().join("mesh1000.json");
    std::fs::write(&def, trimorph::io::deformation::to_string(&s, None)).unwrap();
    let script = dir.path().join("all.json");
    std::fs::write(
        &script,
        r#"[{"op": "translate", "anchors": {"near": [[100, 100]]}, "neighborhood": "all", "by": [3, "-2"]}]"#,
    )
    .unwrap();
    let out = dir.path().join("edited.json");
    let mut g = c.benchmark_group("edit_process");
    g.sample_size(10);
    g.bench_function("select_all_edit_1000", |b| {
        b.iter(|| {
            let o = Command::new(env!("CARGO_BIN_EXE_trimorph"))
                .args(["edit", def.to_str().unwrap(), "--script", script.to_str().unwrap()])
                .args(["-o", out.to_str().unwrap()])
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        })
    });
    // Exact (unbounded) values: a select-all rotation of a 100-triangle spline on ECLES's
    // modular path (the fraction-free sessions took about 13 s).
    let def100 = dir.path().join("mesh100.json");
    std::fs::write(&def100, trimorph::io::deformation::to_string(&select_all_spline(100), None))
        .unwrap();
    let rot = dir.path().join("rotate.json");
    std::fs::write(
        &rot,
        r#"[{"op": "rotate", "anchors": {"near": [[100, 100]]}, "neighborhood": "all", "center": [90, 95], "angle": 0.2}]"#,
    )
    .unwrap();
    g.bench_function("select_all_unbounded_rotate_100", |b| {
        b.iter(|| {
            let o = Command::new(env!("CARGO_BIN_EXE_trimorph"))
                .args(["edit", def100.to_str().unwrap(), "--script", rot.to_str().unwrap()])
                .args(["--unbounded", "-o", out.to_str().unwrap()])
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            assert!(String::from_utf8_lossy(&o.stdout).contains("modular path"));
        })
    });
    g.finish();
}

/// The two costliest parts of writing an exact solution, on numbers of the 400 x 800
/// solve's size (3,300 bits): decimal text (`exact::radix`) and lowest terms over one
/// denominator (`exact::lowest`, 800 values sharing a factor 30 with it).
fn bench_parts(c: &mut Criterion) {
    use num_bigint::BigUint;
    use trimorph::exact::Int;
    let mut rng = SmallRng::seed_from_u64(11);
    let mut big = |bits: usize| -> BigUint {
        let words: Vec<u32> = (0..bits.div_ceil(32)).map(|_| rng.gen()).collect();
        BigUint::new(words) >> (bits.div_ceil(32) * 32 - bits) | (BigUint::from(1u32) << (bits - 1))
    };
    let xs: Vec<BigUint> = (0..200).map(|_| big(3300)).collect();
    let den = big(3300) * 30u32;
    let num: Vec<Int> = (0..800).map(|_| Int::from_big((big(3290) * 30u32).into())).collect();
    let den = Int::from_big(den.into());
    let mut g = c.benchmark_group("exact_parts");
    g.bench_function("decimal_200_x_3300_bits", |b| {
        b.iter(|| {
            let mut s = String::with_capacity(200 * 1000);
            for x in &xs {
                trimorph::exact::radix::push_decimal(x, &mut s);
            }
            s.len()
        })
    });
    g.sample_size(20);
    g.bench_function("lowest_terms_800_x_3300_bits", |b| {
        b.iter(|| trimorph::exact::lowest::lowest_terms(&num, &den).len())
    });
    g.finish();
}

criterion_group!(benches, bench, bench_edit, bench_parts);
criterion_main!(benches);
