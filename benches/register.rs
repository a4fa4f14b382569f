//! Criterion benches of `register` (issue 50): the bundled immunohistochemistry image
//! (`data/microscopy/ihc.png`, grey) as MOVING, FIXED = MOVING through a known smooth map
//! (a shift, a 1.2 degree rotation and two waves of about 1.5 px; bilinear), all defaults
//! (ncc, affine pre-alignment, degree 5 over 48 px cells, up to 4 levels):
//!
//! * `register_512`: 512 x 512;
//! * `register_1024`: the image scaled to 1024 x 1024 (Catmull-Rom), the map scaled alike.
//!
//! elastix's default B-spline registration takes about 1.2 s on these 512^2 pairs here
//! (`benches/register_compare.py`). Run with `cargo bench --bench register`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::PathBuf;
use trimorph::register::image::Channel;
use trimorph::register::{register, Input, RegisterOptions};

fn moving(side: u32) -> Channel {
    let img = image::open("data/microscopy/ihc.png").expect("bundled image");
    let img = if side == 512 {
        img
    } else {
        img.resize_exact(side, side, image::imageops::FilterType::CatmullRom)
    };
    Channel::from_image(&img, std::path::Path::new("ihc.png")).expect("finite")
}

fn fixed(m: &Channel) -> Channel {
    let k = m.w as f64 / 512.0;
    let (cx, cy) = (0.5 * (m.w as f64 - 1.0), 0.5 * (m.h as f64 - 1.0));
    let a = 1.2f64.to_radians();
    let mut data = Vec::with_capacity(m.w * m.h);
    for y in 0..m.h {
        for x in 0..m.w {
            let (xf, yf) = (x as f64, y as f64);
            let qx = cx + a.cos() * (xf - cx) - a.sin() * (yf - cy)
                + k * (-2.0 + 1.2 * (yf / (29.0 * k)).cos());
            let qy = cy
                + a.sin() * (xf - cx)
                + a.cos() * (yf - cy)
                + k * (1.5 + 1.5 * (xf / (37.0 * k)).sin());
            let (qx, qy) = (qx.clamp(0.0, m.w as f64 - 1.001), qy.clamp(0.0, m.h as f64 - 1.001));
            let (i, j) = (qx.floor() as usize, qy.floor() as usize);
            let (fx, fy) = ((qx - i as f64) as f32, (qy - j as f64) as f32);
            let p = |a: usize, b: usize| m.at(a, b);
            data.push(
                (1.0 - fy) * ((1.0 - fx) * p(i, j) + fx * p(i + 1, j))
                    + fy * ((1.0 - fx) * p(i, j + 1) + fx * p(i + 1, j + 1)),
            );
        }
    }
    Channel { data, ..m.clone() }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("register");
    g.sample_size(10);
    for side in [512u32, 1024] {
        let m = moving(side);
        let f = fixed(&m);
        let fi = Input { image: f, name: PathBuf::from("fixed"), mask: None };
        let mi = Input { image: m, name: PathBuf::from("moving"), mask: None };
        let opts = RegisterOptions::default();
        let r = register(&fi, &mi, &opts).expect("registers");
        assert!(r.report.fold_free);
        g.bench_function(format!("register_{side}"), |b| {
            b.iter(|| black_box(register(&fi, &mi, &opts).expect("registers")))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
