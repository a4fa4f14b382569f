//! Fitting from landmarks alone on real images: the landmark-adapted mesh, automatic
//! smoothing against a thin-plate spline on held-out landmarks (with and without noise on the
//! targets), certified fold-free fits of crowded landmarks, and full coverage of the frame.
//!
//! Print the figures with `cargo test --release --test fit_real -- --nocapture`.

mod common;

use common::tps::Tps;
use trimorph::fit::frame::{fit_frame, FrameFitOptions};
use trimorph::fit::landmarks::Landmark;
use trimorph::fit::residuals;

/// A small deterministic generator (SplitMix64) for splits and noise.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A standard normal sample (Box-Muller).
    fn normal(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// The known smooth deformation of the cell image (pixels to pixels): long waves.
fn truth(p: [f64; 2]) -> [f64; 2] {
    use std::f64::consts::TAU;
    let (x, y) = (p[0], p[1]);
    [
        x + 9.0 * (TAU * y / 420.0).sin() + 4.0 * (TAU * (x + y) / 610.0).sin() + 3.0,
        y + 7.0 * (TAU * x / 380.0).cos() - 3.5 * (TAU * y / 500.0).sin() - 2.0,
    ]
}

/// A second known deformation: a local swirl (up to 0.25 rad about (300, 220)), a bulge
/// near (150, 400) and a mild shear; most of the frame moves little, so how the map
/// continues beyond the landmarks matters.
fn swirl(p: [f64; 2]) -> [f64; 2] {
    let (x, y) = (p[0], p[1]);
    let (cx, cy) = (300.0, 220.0);
    let (dx, dy) = (x - cx, y - cy);
    let a = 0.25 * (-(dx * dx + dy * dy) / (2.0 * 140.0 * 140.0)).exp();
    let (c, s) = (a.cos(), a.sin());
    let (rx, ry) = (c * dx - s * dy, s * dx + c * dy);
    let b = 1.0 + 0.08 * (-((x - 150.0).powi(2) + (y - 400.0).powi(2)) / (2.0 * 90.0 * 90.0)).exp();
    [cx + rx * b + 0.02 * y + 4.0, cy + ry * b - 3.0]
}

fn cell() -> image::GrayImage {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/cell.png");
    image::open(path).unwrap().to_luma8()
}

fn rms(e: &[f64]) -> f64 {
    (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
}

/// `count` random splits of `n` feature points `sep` px apart into fitted and held-out
/// landmarks (`n / 4` held out), the targets given by `field`, with `noise` px of Gaussian
/// noise per coordinate on the fitted ones; `seed` drives the shuffles and the noise.
fn splits(
    field: fn([f64; 2]) -> [f64; 2],
    n: usize,
    sep: f64,
    noise: f64,
    seed: u64,
    count: usize,
) -> Vec<(Vec<Landmark>, Vec<Landmark>)> {
    let pts = common::features::feature_points(&cell(), n, sep);
    assert_eq!(pts.len(), n);
    let k = n - n / 4;
    let mut rng = Rng(seed);
    (0..count)
        .map(|_| {
            let mut idx: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                idx.swap(i, (rng.next() % (i as u64 + 1)) as usize);
            }
            let lm = |i: usize, noisy: bool, rng: &mut Rng| {
                let p = pts[i];
                let mut t = field(p);
                if noisy {
                    t[0] += noise * rng.normal();
                    t[1] += noise * rng.normal();
                }
                Landmark { name: Some(format!("f{i}")), src: p, dst: t, weight: 1.0 }
            };
            let fitted: Vec<Landmark> = idx[..k].iter().map(|&i| lm(i, true, &mut rng)).collect();
            let held: Vec<Landmark> = idx[k..].iter().map(|&i| lm(i, false, &mut rng)).collect();
            (fitted, held)
        })
        .collect()
}

/// The cell image's size, the frame of every fit here.
fn frame_size() -> [f64; 2] {
    let (w, h) = cell().dimensions();
    [w as f64, h as f64]
}

/// Held-out RMS error of a fitted frame.
fn held_out_tre(f: &trimorph::fit::frame::FrameFit, held: &[Landmark]) -> f64 {
    rms(&residuals(&f.fit.spline, held).unwrap().iter().map(|r| r.residual).collect::<Vec<_>>())
}

/// Held-out RMS error of the interpolating thin-plate spline.
fn tps_tre(fitted: &[Landmark], held: &[Landmark]) -> f64 {
    rms(&Tps::new(fitted).errors(held))
}

/// Mean held-out TRE over 5 random splits (see [`splits`], seed 7): (trimorph with `opts`,
/// TPS).
fn split_tre_with(
    field: fn([f64; 2]) -> [f64; 2],
    n: usize,
    sep: f64,
    noise: f64,
    opts: &FrameFitOptions,
) -> (f64, f64) {
    let (mut ours, mut base) = (Vec::new(), Vec::new());
    for (split, (fitted, held)) in splits(field, n, sep, noise, 7, 5).iter().enumerate() {
        let f = fit_frame(fitted, frame_size(), opts).unwrap();
        assert!(f.fit.report.fold_free && f.frame.covers_frame, "split {split}");
        let (r, b) = (held_out_tre(&f, held), tps_tre(fitted, held));
        eprintln!(
            "noise {noise}: split {split}: TRE trimorph {r:.3} px (bend {:.2e}, loo {:.3}), TPS {b:.3} px; {} triangles",
            f.fit.report.bend,
            f.fit.report.loo_rms.unwrap_or(f64::NAN),
            f.frame.triangles
        );
        ours.push(r);
        base.push(b);
    }
    (mean(&ours), mean(&base))
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// [`split_tre_with`] with the default options.
fn split_tre(field: fn([f64; 2]) -> [f64; 2], n: usize, sep: f64, noise: f64) -> (f64, f64) {
    split_tre_with(field, n, sep, noise, &FrameFitOptions::default())
}

// Measured (release, this data, leave-one-out choice of the weight over the mesh with two
// far-field rings, 15-degree refinement), mean held-out TRE trimorph / TPS in px:
//
// | field | landmarks | no noise      | 1.5 px noise  |
// |-------|-----------|---------------|---------------|
// | waves | 30        | 4.793 / 4.829 | 4.835 / 4.716 |
// | waves | 60        | 2.128 / 2.139 | 2.838 / 2.980 |
// | swirl | 30        | 3.591 / 3.630 | 3.845 / 3.863 |
// | swirl | 60        | 1.710 / 1.729 | 2.562 / 2.681 |
//
// Without noise the fit is at least as good as the interpolating TPS; with noise it is
// better with 60 landmarks (4 to 5 %) and on the swirl with 30, but 2.5 % worse on the
// waves with 30, where the model error (4.8 px) dwarfs the noise and the leave-one-out
// score still asks for some smoothing. There no weight at all beats TPS by more than 1 %
// (`with_30_noisy_landmarks_the_choice_is_near_the_best_weight_in_hindsight`), and over
// more splits the gap is 0.5 to 2 %. The bounds hold those figures with 1 % room for
// floating-point differences between machines.

#[test]
fn without_noise_the_fit_is_at_least_as_good_as_tps() {
    for (name, field) in [("waves", truth as fn([f64; 2]) -> [f64; 2]), ("swirl", swirl)] {
        for (n, sep) in [(40, 45.0), (80, 35.0)] {
            let (ours, tps) = split_tre(field, n, sep, 0.0);
            eprintln!(
                "{name}, no noise, {} landmarks: trimorph {ours:.3} px, TPS {tps:.3} px",
                n - n / 4
            );
            assert!(ours <= 1.01 * tps, "{name} {n}: trimorph {ours} vs TPS {tps}");
        }
    }
}

#[test]
fn with_noise_the_fit_beats_tps_given_enough_landmarks() {
    for (name, field) in [("waves", truth as fn([f64; 2]) -> [f64; 2]), ("swirl", swirl)] {
        let (ours, tps) = split_tre(field, 80, 35.0, 1.5);
        eprintln!("{name}, 1.5 px noise, 60 landmarks: trimorph {ours:.3} px, TPS {tps:.3} px");
        assert!(ours <= 0.97 * tps, "{name}: trimorph {ours} vs TPS {tps}");
        let (ours, tps) = split_tre(field, 40, 45.0, 1.5);
        eprintln!("{name}, 1.5 px noise, 30 landmarks: trimorph {ours:.3} px, TPS {tps:.3} px");
        let bound = if name == "waves" { 1.04 } else { 1.01 };
        assert!(ours <= bound * tps, "{name}: trimorph {ours} vs TPS {tps}");
    }
}

/// Why the fit only ties TPS with 30 noisy landmarks: there, no smoothing weight does better.
/// Over fresh random splits (seed 2026; `TRIMORPH_SPLITS`, default 20), the mean held-out
/// error of every fixed weight on a grid (`log10 bend` from -10 to -4, step 0.5) is compared
/// with the automatic choice and with TPS. The best weight in hindsight stays within 1 % of
/// TPS (the noise uses up the 1 % by which the noise-free fit beats it), and the
/// leave-one-out choice is within 2.5 % of that best weight.
///
/// Measured (release): with 20 splits, automatic / best / TPS 4.192 / 4.146 / 4.150 px on the
/// waves and 3.756 / 3.701 / 3.714 px on the swirl. With 60 splits of seed 2026, 4.315 /
/// 4.291 / 4.291 and 3.903 / 3.906 / 3.909. With 60 splits of seeds 7, 11 and 12345 (a grid
/// of step 0.25), best / TPS was 0.997 to 1.000 on the waves and 0.994 to 1.007 on the
/// swirl, automatic / TPS 1.005 to 1.011 and 1.007 to 1.019. With 60 landmarks the best
/// weight gains 5 to 7 % over TPS and the choice 4 to 6.5 %. Marginal likelihood (REML)
/// instead of leave-one-out, or the smallest weight within one paired standard error, moved
/// these ratios by under 1 %, so the leave-one-out choice stays.
#[test]
fn with_30_noisy_landmarks_the_choice_is_near_the_best_weight_in_hindsight() {
    use trimorph::fit::Bend;
    let count = std::env::var("TRIMORPH_SPLITS").map_or(20, |s| s.parse().unwrap());
    let logs: Vec<f64> = (0..13).map(|i| -10.0 + 0.5 * i as f64).collect();
    for (name, field) in [("waves", truth as fn([f64; 2]) -> [f64; 2]), ("swirl", swirl)] {
        let (mut auto, mut tps, mut fixed) = (Vec::new(), Vec::new(), vec![Vec::new(); logs.len()]);
        for (fitted, held) in splits(field, 40, 45.0, 1.5, 2026, count) {
            let f = fit_frame(&fitted, frame_size(), &FrameFitOptions::default()).unwrap();
            auto.push(held_out_tre(&f, &held));
            tps.push(tps_tre(&fitted, &held));
            for (l, out) in logs.iter().zip(&mut fixed) {
                let mut opts = FrameFitOptions::default();
                opts.fit.bend = Bend::Weight(10f64.powf(*l));
                out.push(held_out_tre(&fit_frame(&fitted, frame_size(), &opts).unwrap(), &held));
            }
        }
        let (auto, tps) = (mean(&auto), mean(&tps));
        let (best, at) = fixed
            .iter()
            .zip(&logs)
            .map(|(v, l)| (mean(v), *l))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap();
        eprintln!(
            "{name}, 1.5 px noise, 30 landmarks, {count} splits: automatic {auto:.3} px, best weight \
             1e{at} in hindsight {best:.3} px, interpolation {:.3} px, TPS {tps:.3} px",
            mean(&fixed[0])
        );
        assert!(best <= 1.01 * tps, "{name}: best weight {best} vs TPS {tps}");
        assert!(auto <= 1.025 * best, "{name}: automatic {auto} vs best weight {best}");
    }
}

/// Bug: with the domain's border free (no far-field rings), the smoothest map through the
/// landmarks bent for nothing near the border, and on the swirl its held-out error was
/// 19 % above the thin-plate spline's (4.33 against 3.63 px, 30 landmarks, no noise). The
/// rings bring it to the TPS's level.
#[test]
fn far_field_rings_bring_the_fit_to_the_thin_plate_level() {
    let mut free = FrameFitOptions::default();
    free.mesh.far_rings = 0;
    let (open, tps) = split_tre_with(swirl, 40, 45.0, 0.0, &free);
    let (ringed, _) = split_tre(swirl, 40, 45.0, 0.0);
    eprintln!(
        "swirl, 30 landmarks: free border {open:.3} px, far rings {ringed:.3} px, TPS {tps:.3} px"
    );
    assert!(open > 1.1 * tps, "the free border was expected to extrapolate worse: {open} vs {tps}");
    assert!(ringed <= 1.01 * tps && ringed < 0.9 * open, "{ringed} vs {open} / {tps}");
}

/// 68 landmarks crowded into one corner of a small frame, with a strong local swirl: the fit
/// over the adapted mesh is certified fold-free with the barrier on, follows the crowded
/// landmarks closely, and warping the frame through it leaves no background pixel.
#[test]
fn crowded_landmarks_fit_fold_free_and_the_warp_covers_the_frame() {
    use trimorph::warp::Interp;
    let (w, h) = (200.0, 150.0);
    let swirl = |p: [f64; 2]| {
        let (cx, cy) = (45.0, 40.0);
        let (dx, dy) = (p[0] - cx, p[1] - cy);
        let r = dx.hypot(dy);
        let a = 0.5 * (-r * r / (2.0 * 25.0 * 25.0)).exp();
        let (c, s) = (a.cos(), a.sin());
        [cx + c * dx - s * dy + 2.0, cy + s * dx + c * dy + 1.0]
    };
    let mut rng = Rng(3);
    let lms: Vec<Landmark> = (0..68)
        .map(|i| {
            let p = [10.0 + 70.0 * rng.uniform(), 8.0 + 65.0 * rng.uniform()];
            Landmark { name: Some(format!("p{i}")), src: p, dst: swirl(p), weight: 1.0 }
        })
        .collect();
    let f = fit_frame(&lms, [w, h], &FrameFitOptions::default()).unwrap();
    let r = &f.fit.report;
    eprintln!(
        "crowded: {} triangles, rms {:.3} px, max {:.3} px, bend {:.2e}, min det J {:.3} (certified >= {:.3}), {} {}, {:.1} ms",
        f.frame.triangles,
        r.fit.rms,
        r.fit.max,
        r.bend,
        r.min_det_j,
        r.det_j_lower_bound,
        r.method,
        r.termination,
        r.time_ms
    );
    assert!(r.fold_free && r.det_j_lower_bound > 0.0, "{r:?}");
    assert!(r.fit.rms < 0.5, "crowded landmarks need local control: rms {}", r.fit.rms);
    assert!(f.frame.covers_frame);
    // Every frame pixel has a preimage: warp an image with no zero pixel, background 0.
    let img = image::DynamicImage::ImageLuma8(image::GrayImage::from_fn(200, 150, |x, y| {
        image::Luma([10 + ((x * 7 + y * 3) % 200) as u8])
    }));
    // Edge mode: the background then marks exactly the pixels outside the mesh.
    let wo = trimorph::warp::WarpOptions {
        interp: Interp::Bilinear,
        mode: trimorph::warp::EdgeMode::Edge,
        ..Default::default()
    };
    let (out, _) = trimorph::warp::warp_pages(&f.fit.spline, &[img], &wo, &|_| {}).unwrap();
    let zeros = out[0].to_luma8().pixels().filter(|p| p[0] == 0).count();
    assert_eq!(zeros, 0, "background pixels inside the frame");
}

/// Bug: `fit --size ... --hard` on the bundled nucleus tracks folded (min det J -6.4). GCV
/// chose an almost affine soft fit (the nuclei move independently), and the exact step then
/// moved each landmark's vertex point by up to 45 px on its own. With hard landmarks the soft
/// fit now aims at the targets, and the exact result is certified fold-free.
#[test]
fn hard_fit_of_independently_moving_nuclei_is_fold_free() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/timelapse/tracks_0_9.csv");
    let lms = trimorph::io::landmarks::read_landmarks(std::path::Path::new(path)).unwrap();
    hard_fit_interpolating_fold_free(&lms, [511.0, 511.0]);
}

/// The hard frame fit of `lms`, asserted to interpolate them, certified fold-free and
/// covering the frame.
fn hard_fit_interpolating_fold_free(lms: &[Landmark], size: [f64; 2]) {
    let mut opts = FrameFitOptions::default();
    opts.fit.hard = true;
    let f = fit_frame(lms, size, &opts).unwrap();
    let r = &f.fit.report;
    // Exact in rationals (tests in fit::hard_tests); here evaluated in f64.
    assert!(r.fit.max < 1e-9, "hard landmarks are interpolated: {}", r.fit.max);
    assert!(r.fold_free && r.det_j_lower_bound > 0.0, "{r:?}");
    assert!(f.frame.covers_frame);
}

/// Bug: `fit --size ... --hard` folded (min det J -2.4) on 30 noisy landmarks where two
/// sources were 1.1 px apart, although a plain soft fit through them is fold-free. The
/// exact step corrected the soft start's residuals (up to 1.8 px at the near-interpolating
/// default weight) on the tiny triangles between the close pair. The soft start of a hard fit
/// now uses the interpolating weight, which leaves about 0.001 px for the exact step.
#[test]
fn hard_fit_of_close_noisy_landmarks_is_fold_free() {
    let pinch = |p: [f64; 2]| {
        let (dx, dy) = (p[0] - 260.0, p[1] - 240.0);
        let s = 1.0 - 0.12 * (-(dx * dx + dy * dy) / (2.0 * 110.0 * 110.0)).exp();
        [260.0 + s * dx + 6.0 + 5.0 * (p[1] / 70.0).sin(), 240.0 + s * dy - 4.0]
    };
    let mut rng = Rng(31);
    let mut lms: Vec<Landmark> = (0..29)
        .map(|i| {
            let p = [15.0 + 482.0 * rng.uniform(), 15.0 + 482.0 * rng.uniform()];
            let t = pinch(p);
            let t = [t[0] + 1.5 * rng.normal(), t[1] + 1.5 * rng.normal()];
            Landmark { name: Some(format!("p{i}")), src: p, dst: t, weight: 1.0 }
        })
        .collect();
    // A second landmark 1.1 px from the first, its target 5 px from the first's.
    let (s0, t0) = (lms[0].src, lms[0].dst);
    lms.push(Landmark {
        name: Some("close".into()),
        src: [s0[0] + 1.1, s0[1] + 0.2],
        dst: [t0[0] + 4.0, t0[1] - 3.0],
        weight: 1.0,
    });
    hard_fit_interpolating_fold_free(&lms, [512.0, 512.0]);
    // The soft fit through the same landmarks is fold-free too: the fold was not demanded.
    let mut soft = FrameFitOptions::default();
    soft.fit.bend = trimorph::fit::Bend::Weight(1e-9);
    assert!(fit_frame(&lms, [512.0, 512.0], &soft).unwrap().fit.report.fold_free);
}

/// Bug: 80 landmarks crowded into a corner of a 300 x 220 frame under a strong local swirl
/// (2.5 rad about (70, 60), `tests/data/crowded_swirl_80.csv`) ran the barrier's Newton
/// method to its cap of 200 iterations (10 s), the fit long settled: its decrement stopped
/// only at `1e-10` of the objective. The run now also stops once the decrement is below what
/// moving every landmark by 0.001 px would change ([`trimorph::fit::newton::NEWTON_TOL_PX`]).
///
/// Second bug, found later: the interpolating squares fit "folded" here (min det J -7.7)
/// only because one vertex of the adapted mesh was nearly singular (its determining set
/// amplified the 2^-20 rounding of the exact result by orders of magnitude). With that
/// vertex broken up ([`trimorph::fit::frame::MAX_AMPLIFICATION`]) the squares fit itself is
/// fold-free and the barrier has nothing to do; `tests/morph_faces.rs` keeps a real case
/// where it must act (and converge before the cap).
#[test]
fn a_strong_swirl_of_crowded_landmarks_fits_fold_free_without_the_newton_cap() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/crowded_swirl_80.csv");
    let lms = trimorph::io::landmarks::read_landmarks(std::path::Path::new(path)).unwrap();
    let f = fit_frame(&lms, [300.0, 220.0], &FrameFitOptions::default()).unwrap();
    let r = &f.fit.report;
    eprintln!(
        "crowded swirl: {} {} iterations, {}, rms {:.4} px, min det J {:.3} (>= {:.3}), {:.0} ms",
        r.method,
        r.iterations,
        r.termination,
        r.fit.rms,
        r.min_det_j,
        r.det_j_lower_bound,
        r.time_ms
    );
    assert!(r.iterations < 150, "{} iterations", r.iterations);
    use trimorph::fit::report::FitTermination;
    let done = [FitTermination::Converged, FitTermination::Exact];
    assert!(done.contains(&r.termination), "{}", r.termination);
    assert!(r.fold_free && r.fit.rms < 0.01, "{r:?}");
    assert!(f.frame.covers_frame);
}
