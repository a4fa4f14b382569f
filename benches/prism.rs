//! Criterion benches of 2.5D deformation (issue: 2.5D prisms).
//!
//! * `bind_38k`: binding a 38,000-vertex model (the size of the D. anser model, thesis
//!   Table 19.1) to a 16-prism reference mesh; target 50 ms.
//! * `deform_38k`: psi of all its vertices after binding; target 5 ms.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use trimorph::edit::select::Neighborhood;
use trimorph::edit::{Editor, Mode};
use trimorph::exact::{rat_int, Rat};
use trimorph::prism::organism::{worm, WormOptions};
use trimorph::prism::{auto_mesh, bind, deform, identity_layers};
use trimorph::spline::{ControlPoint, Spline};

fn bench(c: &mut Criterion) {
    let model = worm(&WormOptions { rings: 950, around: 40, ..Default::default() });
    assert!(model.vertices.len() >= 38_000);
    let (mesh, [a, b]) = auto_mesh(&model, 4, 2, 0.05).unwrap();
    let mut s = Spline::identity(mesh.clone(), 5).unwrap();
    let r = |v: f64| Rat::new((v.round() as i64).into(), 1.into());
    let z = identity_layers(&s, r(a) - rat_int(1), r(b) + rat_int(1)).unwrap();
    s.set_z_layers(Some(z));
    let v = (0..mesh.num_vertices()).find(|&v| !mesh.is_border_vertex(v)).unwrap();
    let mut ed = Editor::new(s);
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Z1).unwrap();
    ed.translate(&[rat_int(30)]).unwrap();
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
    ed.translate(&[rat_int(20), rat_int(-10)]).unwrap();
    let s = ed.into_spline();
    let mut g = c.benchmark_group("prism");
    g.bench_function("bind_38k", |bch| bch.iter(|| black_box(bind(&model, &s).unwrap())));
    let binding = bind(&model, &s).unwrap();
    g.bench_function("deform_38k", |bch| bch.iter(|| black_box(deform(&model, &binding, &s))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
