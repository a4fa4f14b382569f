//! The fitting quality bar (issue: fitting, point 6), on a real microscope image.
//!
//! The bundled cell image (`data/microscopy/cell.png`, 550 x 660) is deformed by a known
//! smooth map that is not one of our splines (a sum of sinusoids). Forty landmarks are
//! placed at strong image features (largest gradient, spread out); thirty are fitted and the
//! other ten measure the target registration error (TRE). A thin-plate spline fitted to the
//! same thirty landmarks is the baseline; the spline fit must be no worse, and must not fold.
//! Both numbers are printed (`cargo test --test fit_tre -- --nocapture`).

#![allow(clippy::needless_range_loop)]

use trimorph::fit::landmarks::Landmark;
use trimorph::fit::solve::{fit, residuals, FitOptions};
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

/// Thin-plate spline through the landmarks: `f(p) = a + A p + sum_i w_i U(|p - s_i|)`,
/// `U(r) = r^2 log r`, solved per coordinate from the standard bordered system.
struct Tps {
    src: Vec<[f64; 2]>,
    coef: [Vec<f64>; 2],
}

impl Tps {
    fn u(r: f64) -> f64 {
        if r <= 0.0 {
            0.0
        } else {
            r * r * r.ln()
        }
    }

    fn new(lms: &[Landmark]) -> Tps {
        let n = lms.len();
        let m = n + 3;
        let mut a = vec![vec![0.0; m]; m];
        for i in 0..n {
            for j in 0..n {
                let (p, q) = (lms[i].src, lms[j].src);
                a[i][j] = Self::u((p[0] - q[0]).hypot(p[1] - q[1]));
            }
            let row = [1.0, lms[i].src[0], lms[i].src[1]];
            for k in 0..3 {
                a[i][n + k] = row[k];
                a[n + k][i] = row[k];
            }
        }
        let solve = |rhs: Vec<f64>| -> Vec<f64> {
            let mut a = a.clone();
            let mut b = rhs;
            for c in 0..m {
                let p = (c..m).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs())).unwrap();
                a.swap(c, p);
                b.swap(c, p);
                for r in c + 1..m {
                    let f = a[r][c] / a[c][c];
                    let (top, bot) = a.split_at_mut(r);
                    for (x, y) in bot[0][c..m].iter_mut().zip(&top[c][c..m]) {
                        *x -= f * y;
                    }
                    b[r] -= f * b[c];
                }
            }
            let mut x = vec![0.0; m];
            for r in (0..m).rev() {
                let s: f64 = (r + 1..m).map(|k| a[r][k] * x[k]).sum();
                x[r] = (b[r] - s) / a[r][r];
            }
            x
        };
        let rhs = |c: usize| {
            let mut v: Vec<f64> = lms.iter().map(|l| l.dst[c]).collect();
            v.extend([0.0; 3]);
            v
        };
        Tps { src: lms.iter().map(|l| l.src).collect(), coef: [solve(rhs(0)), solve(rhs(1))] }
    }

    fn eval(&self, p: [f64; 2]) -> [f64; 2] {
        let n = self.src.len();
        [0, 1].map(|c| {
            let w = &self.coef[c];
            let mut v = w[n] + w[n + 1] * p[0] + w[n + 2] * p[1];
            for (i, s) in self.src.iter().enumerate() {
                v += w[i] * Self::u((p[0] - s[0]).hypot(p[1] - s[1]));
            }
            v
        })
    }
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
    let f = fit(&s, &fitted, &FitOptions { bend: 1e-4, ..FitOptions::default() }).unwrap();
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
