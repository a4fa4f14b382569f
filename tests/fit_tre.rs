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
use trimorph::fit::{fit, residuals, Bend, FitOptions};
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

fn rms(e: &[f64]) -> f64 {
    (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
}

#[test]
fn spline_fit_is_no_worse_than_thin_plate_spline_on_held_out_landmarks() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/cell.png");
    let img = image::open(path).unwrap().to_luma8();
    assert_eq!(img.dimensions(), (W as u32, H as u32));
    let pts = common::features::feature_points(&img, 40, 45.0);
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
    let base = Tps::new(&fitted).errors(&held);
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
