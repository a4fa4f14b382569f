//! The fitting quality bar (issue: fitting, point 6), on a real microscope image.
//!
//! The bundled cell image (`data/microscopy/cell.png`, 550 x 660) is deformed by a known
//! smooth map that is not one of our splines (a sum of sinusoids). Forty landmarks are
//! placed at strong image features (largest gradient, spread out); thirty are fitted and the
//! other ten measure the target registration error (TRE). A thin-plate spline fitted to the
//! same thirty landmarks is the baseline; the spline fit must be no worse, and must not fold.
//! Both numbers are printed (`cargo test --test fit_tre -- --nocapture`).

#![allow(clippy::needless_range_loop)]

mod common;

use common::tps::Tps;
use trimorph::fit::landmarks::Landmark;
use trimorph::fit::solve::{fit, residuals, Bend, FitOptions};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::Spline;

const W: f64 = 550.0;
const H: f64 = 660.0;

/// The known deformation (pixels to pixels).
fn truth(p: [f64; 2]) -> [f64; 2] {
    use std::f64::consts::TAU;
    let (x, y) = (p[0], p[1]);
    [
        x + 9.0 * (TAU * y / 420.0).sin() + 4.0 * (TAU * (x + y) / 610.0).sin() + 3.0,
        y + 7.0 * (TAU * x / 380.0).cos() - 3.5 * (TAU * y / 500.0).sin() - 2.0,
    ]
}

/// Forty feature points: the pixels of largest gradient magnitude (central differences),
/// at least 45 px apart and 20 px inside the border.
fn feature_points(img: &image::GrayImage, n: usize) -> Vec<[f64; 2]> {
    let (w, h) = img.dimensions();
    let g = |x: u32, y: u32| img.get_pixel(x, y)[0] as f64;
    let mut cand: Vec<(f64, [f64; 2])> = Vec::new();
    for y in 20..h - 20 {
        for x in 20..w - 20 {
            let gx = g(x + 1, y) - g(x - 1, y);
            let gy = g(x, y + 1) - g(x, y - 1);
            cand.push((gx * gx + gy * gy, [x as f64, y as f64]));
        }
    }
    cand.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut out: Vec<[f64; 2]> = Vec::new();
    for (_, p) in cand {
        if out.iter().all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) >= 45.0) {
            out.push(p);
            if out.len() == n {
                break;
            }
        }
    }
    out
}

fn rms(e: &[f64]) -> f64 {
    (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
}

#[test]
fn spline_fit_is_no_worse_than_thin_plate_spline_on_held_out_landmarks() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/cell.png");
    let img = image::open(path).unwrap().to_luma8();
    assert_eq!(img.dimensions(), (W as u32, H as u32));
    let pts = feature_points(&img, 40);
    assert_eq!(pts.len(), 40);
    let lms: Vec<Landmark> = pts
        .iter()
        .enumerate()
        .map(|(i, &p)| Landmark { name: Some(format!("f{i}")), src: p, dst: truth(p), weight: 1.0 })
        .collect();
    // Every fourth landmark is held out (10 of 40), spread like the rest.
    let held: Vec<Landmark> = lms.iter().skip(3).step_by(4).cloned().collect();
    let fitted: Vec<Landmark> =
        lms.iter().enumerate().filter(|(i, _)| i % 4 != 3).map(|(_, l)| l.clone()).collect();
    assert_eq!((fitted.len(), held.len()), (30, 10));

    let mesh = Mesh::grid(10, 12, W, H, MeshOptions::default()).unwrap();
    let s = Spline::identity(mesh, 5).unwrap();
    // (lambda = 1e-4 px^2 as a scale-free weight: lambda / (sum w * area).)
    let bend = Bend::Weight(1e-4 / (30.0 * W * H));
    let f = fit(&s, &fitted, &FitOptions { bend, ..FitOptions::default() }).unwrap();
    let ours: Vec<f64> = residuals(&f.spline, &held).unwrap().iter().map(|r| r.residual).collect();
    let tps = Tps::new(&fitted);
    let base: Vec<f64> = held
        .iter()
        .map(|l| {
            let m = tps.eval(l.src);
            (m[0] - l.dst[0]).hypot(m[1] - l.dst[1])
        })
        .collect();
    let (tre, tre_tps) = (rms(&ours), rms(&base));
    eprintln!(
        "held-out TRE (rms px): spline {tre:.3}, thin-plate spline {tre_tps:.3}; fit rms {:.4}; \
         min det J {:.3}; {} ({} iterations, {:.1} ms)",
        f.report.fit.rms,
        f.report.min_det_j,
        f.report.method,
        f.report.iterations,
        f.report.time_ms
    );
    assert!(tre <= tre_tps, "spline TRE {tre} worse than TPS {tre_tps}");
    assert!(!f.report.folds && f.report.min_det_j > 0.0);
    assert!(f.report.exact_c1);
}
