//! Criterion benches of 2DSD (issue: spline deformations).
//!
//! * `select_update_1000`: Select (ExpandDerived, RelMagnitude, ECLES initialize) plus the
//!   first translate for one anchor on a ~1,000-triangle Delaunay mesh; target 2 ms.
//! * `drag_update_1000`: each further translate (dragging); target 0.2 ms.
//! * `eval_1e6`: phi at 10^6 points (coherent scan lines) on all cores; target 20 M points/s.
//! * `certify`: the det J certificate ([`trimorph::spline::jacobian`]) of a 200-triangle
//!   degree-5 spline (a 10 x 10 grid with two vertices dragged): `certify_200_deg5` from the
//!   exact points on all cores, `triangle_deg5` one triangle from `f64` points with a reused
//!   [`Certifier`] (the optimizer's call), per triangle.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use trimorph::ecles::InitOptions;
use trimorph::edit::select::Neighborhood;
use trimorph::edit::{Editor, Mode};
use trimorph::exact::{rat_int, Int, Rat};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::jacobian::{certify, Certifier, CertifyOptions, RAT_ROUNDING};
use trimorph::spline::{ControlPoint, Spline};

fn mesh_1000() -> Mesh {
    let mut rng = SmallRng::seed_from_u64(5);
    let pts: Vec<[f64; 2]> =
        (0..520).map(|_| [rng.gen_range(0.0..1000.0), rng.gen_range(0.0..800.0)]).collect();
    Mesh::delaunay(&pts, MeshOptions::default()).unwrap()
}

fn bench(c: &mut Criterion) {
    let mesh = mesh_1000();
    eprintln!("mesh: {} triangles, {} vertices", mesh.num_triangles(), mesh.num_vertices());
    let spline = Spline::identity(mesh.clone(), 5).unwrap();
    let v = (0..mesh.num_vertices())
        .find(|&v| !mesh.is_border_vertex(v) && mesh.vertex_degree(v) == 6)
        .unwrap_or(0);
    let mut ed = Editor::new(spline.clone());
    {
        let sel = ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
        eprintln!(
            "single vertex anchor: {} derived, {} relevant conditions, rank {}",
            sel.derived.len(),
            sel.relevant(),
            sel.rank()
        );
    }
    let by = [Rat::new(Int::from(7), Int::from(2)), rat_int(-2)];
    // Each measured edit starts from a fresh identity spline (cloning it is not timed), so
    // the figures do not include the growth of rationals over a long edit history.
    let fresh = Editor::new(spline.clone());
    c.bench_function("select_update_1000/vertex_anchor", |b| {
        b.iter_batched_ref(
            || fresh.clone(),
            |ed| {
                ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
                ed.translate(&by).unwrap();
                black_box(ed.spline().num_points())
            },
            BatchSize::LargeInput,
        )
    });
    // An edge point anchor (the worked example's type).
    let e = spline.layout().point(mesh.vertex_triangles(v)[0], [0, 3, 2]);
    c.bench_function("select_update_1000/edge_anchor", |b| {
        b.iter_batched_ref(
            || fresh.clone(),
            |ed| {
                ed.select(&[ControlPoint(e)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
                ed.translate(&by).unwrap();
                black_box(ed.spline().num_points())
            },
            BatchSize::LargeInput,
        )
    });
    // ECLES alone on the real relevant systems of these selections: factoring + one update
    // (issue 2's "typical single-anchor relevant system" target: 1 ms).
    for (name, anchor) in [("vertex", v), ("edge", e)] {
        let mut probe = fresh.clone();
        let sel = probe
            .select(&[ControlPoint(anchor)], &[], &Neighborhood::Radius(2), Mode::Xy)
            .unwrap()
            .clone();
        eprintln!(
            "{name} anchor relevant system: {} x {} (rank {})",
            sel.relevant(),
            sel.derived.len(),
            sel.rank()
        );
        let sys = spline.system();
        let target: Vec<Vec<Rat>> = sel
            .anchors
            .iter()
            .map(|a| spline.points()[a.index()].iter().zip(&by).map(|(p, d)| p + d).collect())
            .collect();
        let (anchors, derived) =
            (ControlPoint::indices(&sel.anchors), ControlPoint::indices(&sel.derived));
        c.bench_function(&format!("ecles_2dsd_single_anchor/{name}_factor+update"), |b| {
            b.iter(|| {
                let opts = InitOptions { strong: true, ..Default::default() };
                let mut s = sys.initialize(spline.points(), &anchors, &derived, opts).unwrap();
                s.update(&target, None, None).unwrap();
                black_box(s.derived_scaled().len())
            })
        });
    }
    let mut ed = fresh.clone();
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
    let mut k = 0i64;
    c.bench_function("drag_update_1000/vertex_anchor", |b| {
        b.iter(|| {
            k += 1;
            ed.translate(&[Rat::new(Int::from(k % 17), Int::from(4)), rat_int(1)]).unwrap();
            black_box(ed.spline().num_points())
        })
    });

    let mut k2 = 0.0f64;
    ed.preview_translate([0.0, 0.0]).unwrap();
    c.bench_function("drag_preview_1000/vertex_anchor_f64", |b| {
        b.iter(|| {
            k2 += 0.25;
            black_box(ed.preview_translate([k2 % 4.0, 1.0]).unwrap().len())
        })
    });

    let (lo, hi) = mesh.bbox();
    let n = 1000usize;
    let pts: Vec<[f64; 2]> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f64 / n as f64, (i / n) as f64 / n as f64);
            [lo[0] + (hi[0] - lo[0]) * x, lo[1] + (hi[1] - lo[1]) * y]
        })
        .collect();
    let mut out = vec![None; pts.len()];
    let mut g = c.benchmark_group("eval_1e6");
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.sample_size(10);
    g.bench_function("phi_grid_scan", |b| b.iter(|| spline.eval_many(black_box(&pts), &mut out)));
    g.finish();
    bench_certify(c);
}

/// A 10 x 10 grid (200 triangles) of 511 x 511, degree 5, two interior vertices dragged.
fn dragged_200() -> Spline {
    let mesh = Mesh::grid(10, 10, 511.0, 511.0, MeshOptions::default()).unwrap();
    let mut ed = Editor::new(Spline::identity(mesh.clone(), 5).unwrap());
    let inner: Vec<usize> =
        (0..mesh.num_vertices()).filter(|&v| !mesh.is_border_vertex(v)).collect();
    for (k, &v) in [inner[20], inner[50]].iter().enumerate() {
        ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
        ed.translate(&[rat_int(12 * (k as i64 * 2 - 1)), rat_int(6)]).unwrap();
    }
    ed.into_spline()
}

fn bench_certify(c: &mut Criterion) {
    let s = dragged_200();
    let opts = CertifyOptions::default();
    assert_eq!(s.mesh().num_triangles(), 200);
    let cert = certify(&s, &opts);
    eprintln!(
        "certify: fold-free {}, lower bound {}, sampled minimum {}",
        cert.fold_free, cert.lower_bound, cert.sampled_min
    );
    type Patch = ([[f64; 2]; 3], Vec<[f64; 2]>);
    let patches: Vec<Patch> = (0..200)
        .map(|t| {
            let m = s.mesh();
            let tri = m.triangle(t).map(|v| m.vertex(v));
            (tri, s.layout().patches()[t].iter().map(|&p| s.point_f64(p)).collect())
        })
        .collect();
    let mut g = c.benchmark_group("certify");
    g.sample_size(20);
    g.bench_function("certify_200_deg5", |b| b.iter(|| black_box(certify(&s, &opts).lower_bound)));
    g.throughput(Throughput::Elements(200));
    let mut cer = Certifier::new(5);
    g.bench_function("triangle_deg5", |b| {
        b.iter(|| {
            let mut lb = f64::INFINITY;
            for (tri, pts) in &patches {
                lb = lb.min(cer.triangle(*tri, pts, RAT_ROUNDING, &opts).lower_bound);
            }
            black_box(lb)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
