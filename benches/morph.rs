//! Morphing, as whole runs and split by phase, at the two targets of issue 17:
//!
//! * `small_*`: the bundled real pair `data/morph/` (A 184 x 184 RGB8, B 250 x 230 grey16,
//!   8 landmarks), 11 frames (target: the whole command under 0.2 s);
//! * `rgb512_*`: time-lapse frames 0 and 9 as 512 x 512 RGB, 14 landmarks, 30 frames
//!   (target: under 1 s).
//!
//! Phases: `fits` (alignment and both certified fits), `blend` (one frame's two exact
//! control-point blends, reduced), `plan` (two fresh inverse-map plans), `plan_scaled` (the
//! same from the fitted maps' curvature bounds, scaled: what a frame does), `frame` (one whole
//! frame: blends, plans, resampling, dissolve), `check` (one frame's two certificates),
//! `frames` (all frames), `png`, `gif`, `apng`, `sheet` (encodings of all frames), and `whole`
//! (everything the command does except reading and writing files), `files` (everything the
//! command does except reading its inputs: the fits and
//! [`trimorph::jobs::morph::write_morph`], files written and synced).

use criterion::{criterion_group, criterion_main, Criterion};
use image::DynamicImage;
use std::path::Path;
use trimorph::fit::landmarks::Landmark;
use trimorph::io::landmarks::read_landmarks;
use trimorph::jobs::morph::{write_morph, MorphFileOptions};
use trimorph::morph::output::{apng_bytes, contact_sheet, gif_bytes, png_bytes};
use trimorph::morph::{frame_times, frame_times_exact, Morph, MorphOptions};
use trimorph::warp::remap::{CurvatureBounds, RemapPlan};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn rgb512(name: &str) -> DynamicImage {
    let g = image::open(root().join("data/microscopy/timelapse").join(name)).unwrap().to_rgb8();
    // 511 x 511 gray -> 512 x 512 RGB (edge row and column repeated).
    DynamicImage::ImageRgb8(image::RgbImage::from_fn(512, 512, |x, y| {
        *g.get_pixel(x.min(510), y.min(510))
    }))
}

fn whole(a: &DynamicImage, b: &DynamicImage, lms: &[Landmark], n: usize) -> usize {
    let m = Morph::new(a, b, lms, &MorphOptions::default()).unwrap();
    let times = frame_times_exact(n);
    let frames = m.frames_at(&times, &|| {}).unwrap();
    let (gif, (apng, (sheet, png))) = rayon::join(
        || gif_bytes(&frames, 100).unwrap().len(),
        || {
            rayon::join(
                || apng_bytes(&frames, 100).unwrap().len(),
                || {
                    rayon::join(
                        || contact_sheet(&frames, &frame_times(n), 8, 160).unwrap().width(),
                        || {
                            use rayon::prelude::*;
                            frames.par_iter().map(|f| png_bytes(f).unwrap().len()).sum::<usize>()
                        },
                    )
                },
            )
        },
    );
    gif + apng + sheet as usize + png
}

fn group(
    c: &mut Criterion,
    tag: &str,
    a: &DynamicImage,
    b: &DynamicImage,
    lms: &[Landmark],
    n: usize,
) {
    let opts = MorphOptions::default();
    let mut g = c.benchmark_group("morph");
    g.sample_size(10);
    g.bench_function(format!("{tag}_whole_{n}_frames"), |bn| bn.iter(|| whole(a, b, lms, n)));
    // The command's whole job but reading the inputs: fits, then every file written
    // atomically into a staged folder (frames, GIF, APNG, sheet, both deformations).
    let dir = tempfile::tempdir().unwrap();
    let files = MorphFileOptions::new(dir.path().join("out"), n);
    g.bench_function(format!("{tag}_files_{n}_frames"), |bn| {
        bn.iter(|| {
            let m = Morph::new(a, b, lms, &opts).unwrap();
            write_morph(&m, &files, &|| {}).unwrap().newton_solves
        })
    });
    g.bench_function(format!("{tag}_fits"), |bn| bn.iter(|| Morph::new(a, b, lms, &opts).unwrap()));
    let m = Morph::new(a, b, lms, &opts).unwrap();
    let half = trimorph::exact::Rat::new(1.into(), 2.into());
    g.bench_function(format!("{tag}_blend"), |bn| {
        bn.iter(|| (m.phi_a_exact(&half).unwrap(), m.phi_b_exact(&half).unwrap()))
    });
    let (sa, sb) = (m.phi_a_exact(&half).unwrap(), m.phi_b_exact(&half).unwrap());
    let (w, h) = (a.width(), a.height());
    g.bench_function(format!("{tag}_plan"), |bn| {
        bn.iter(|| {
            let ro = opts.remap;
            (RemapPlan::new(&sa, w, h, ro), RemapPlan::new(&sb, w, h, ro))
        })
    });
    // What a frame does: the fitted maps' curvature bounds, computed once per morph, scaled.
    let (ca, cb) = (CurvatureBounds::new(m.phi_ab()), CurvatureBounds::new(m.phi_ba()));
    g.bench_function(format!("{tag}_plan_scaled"), |bn| {
        bn.iter(|| {
            let ro = opts.remap;
            let pa = RemapPlan::new_scaled(&sa, w, h, ro, &ca, 0.5);
            (pa, RemapPlan::new_scaled(&sb, w, h, ro, &cb, 0.5))
        })
    });
    g.bench_function(format!("{tag}_frame"), |bn| bn.iter(|| m.frame_exact(&half).unwrap()));
    g.bench_function(format!("{tag}_check"), |bn| bn.iter(|| m.check_frame(&half).unwrap()));
    let times = frame_times_exact(n);
    g.bench_function(format!("{tag}_frames"), |bn| {
        bn.iter(|| m.frames_at(&times, &|| {}).unwrap())
    });
    let frames = m.frames_at(&times, &|| {}).unwrap();
    g.bench_function(format!("{tag}_png"), |bn| {
        use rayon::prelude::*;
        bn.iter(|| frames.par_iter().map(|f| png_bytes(f).unwrap().len()).sum::<usize>())
    });
    g.bench_function(format!("{tag}_gif"), |bn| bn.iter(|| gif_bytes(&frames, 100).unwrap()));
    g.bench_function(format!("{tag}_apng"), |bn| bn.iter(|| apng_bytes(&frames, 100).unwrap()));
    g.bench_function(format!("{tag}_sheet"), |bn| {
        bn.iter(|| contact_sheet(&frames, &frame_times(n), 8, 160).unwrap())
    });
    g.finish();
}

fn bench(c: &mut Criterion) {
    let d = root().join("data/morph");
    let lms = read_landmarks(&d.join("nuclei_landmarks.csv")).unwrap();
    let a = image::open(d.join("nuclei_a.png")).unwrap();
    let b = image::open(d.join("nuclei_b.png")).unwrap();
    group(c, "small", &a, &b, &lms, 11);
    let t = root().join("data/microscopy/timelapse");
    let lms = read_landmarks(&t.join("landmarks_00_09.csv")).unwrap();
    let (a, b) = (rgb512("frame_00.png"), rgb512("frame_09.png"));
    group(c, "rgb512", &a, &b, &lms, 30);
}

criterion_group!(benches, bench);
criterion_main!(benches);
