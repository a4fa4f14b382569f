//! Morphing: 30 frames of 512 x 512 RGB, end to end (fits, blends, warps, cross-dissolve),
//! excluding file writing and animation encoding.

use criterion::{criterion_group, criterion_main, Criterion};
use image::DynamicImage;
use std::path::Path;
use trimorph::io::landmarks::read_landmarks;
use trimorph::morph::{Morph, MorphOptions};

fn input(name: &str) -> DynamicImage {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/microscopy/timelapse");
    let g = image::open(dir.join(name)).unwrap().to_rgb8();
    // 511 x 511 gray -> 512 x 512 RGB (edge row and column repeated).
    DynamicImage::ImageRgb8(image::RgbImage::from_fn(512, 512, |x, y| {
        *g.get_pixel(x.min(510), y.min(510))
    }))
}

fn bench(c: &mut Criterion) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/microscopy/timelapse");
    let lms = read_landmarks(&dir.join("landmarks_00_09.csv")).unwrap();
    let (a, b) = (input("frame_00.png"), input("frame_09.png"));
    let opts = MorphOptions::default();
    let mut g = c.benchmark_group("morph");
    g.sample_size(10);
    g.bench_function("fit_both_512", |bn| bn.iter(|| Morph::new(&a, &b, &lms, &opts).unwrap()));
    let m = Morph::new(&a, &b, &lms, &opts).unwrap();
    g.bench_function("one_frame_512_rgb", |bn| bn.iter(|| m.frame(0.5).unwrap()));
    g.bench_function("30_frames_512_rgb_end_to_end", |bn| {
        bn.iter(|| {
            let m = Morph::new(&a, &b, &lms, &opts).unwrap();
            m.frames(30, &|| {}).unwrap()
        })
    });
    for step in [2u32, 4] {
        let pv = m.preview(step).unwrap();
        g.bench_function(format!("30_preview_frames_512_step{step}"), |bn| {
            bn.iter(|| {
                (0..30)
                    .map(|k| m.preview_frame(&pv, k as f64 / 29.0, [0, 0, 0, 255]).unwrap())
                    .collect::<Vec<_>>()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
