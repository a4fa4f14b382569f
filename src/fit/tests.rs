//! Tests of the fit: gradients against finite differences, the Gauss-Newton step, recovery
//! of smooth maps, robustness to bad matches, the fold barrier, exactness of the result.

use super::landmarks::Landmark;
use super::objective::{Barrier, Loss};
use super::report::{ExactStep, FitMethod, FitTermination, Solver};
use super::solve::objective;
use super::{fit, Bend, FitError, FitOptions};
use crate::exact::rat_int;
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::{ControlPoint, Spline};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

fn grid_spline() -> Spline {
    let mesh = Mesh::grid(10, 5, 500.0, 250.0, MeshOptions::default()).unwrap();
    Spline::identity(mesh, 5).unwrap()
}

fn smooth_map(p: [f64; 2]) -> [f64; 2] {
    let (x, y) = (p[0], p[1]);
    [x + 6.0 * (y / 60.0).sin() + 3.0 + 0.02 * y, y + 5.0 * (x / 80.0).cos() - 2.0 - 0.01 * x]
}

fn landmarks(n: usize, seed: u64, f: impl Fn([f64; 2]) -> [f64; 2]) -> Vec<Landmark> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let s = [rng.gen_range(10.0..490.0), rng.gen_range(10.0..240.0)];
            Landmark { name: Some(format!("l{i}")), src: s, dst: f(s), weight: 1.0 }
        })
        .collect()
}

#[test]
fn gradient_matches_finite_differences_for_every_loss_and_the_barrier() {
    let s = grid_spline();
    let lms = landmarks(20, 1, smooth_map);
    for loss in [Loss::Squares, Loss::Huber(2.0), Loss::Cauchy(3.0)] {
        let opts = FitOptions {
            loss,
            bend: Bend::Weight(0.5),
            barrier: Some(Barrier { floor: 0.1, tau: 1.2, mu: 3.0 }),
            ..FitOptions::default()
        };
        let obj = objective(&s, &lms, &opts).unwrap();
        let mut rng = SmallRng::seed_from_u64(2);
        let x: Vec<f64> = obj.param.x0().iter().map(|v| v + rng.gen_range(-1.5..1.5)).collect();
        let mut g = vec![0.0; x.len()];
        let t = obj.eval(&x, Some(&mut g));
        assert!(t.barrier > 0.0, "the barrier must be active somewhere in this test");
        for k in (0..x.len()).step_by(37) {
            let h = 1e-4;
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[k] += h;
            xm[k] -= h;
            let fd = (obj.eval(&xp, None).total - obj.eval(&xm, None).total) / (2.0 * h);
            let tol = 1e-5 * (1.0 + g[k].abs().max(fd.abs()));
            assert!((fd - g[k]).abs() < tol, "{loss:?} var {k}: analytic {} fd {fd}", g[k]);
        }
    }
}

#[test]
fn a_cancelled_fit_returns_cancelled() {
    let s = grid_spline();
    let lms = landmarks(12, 3, smooth_map);
    let cancel = crate::cancel::Cancel::new();
    cancel.cancel();
    let opts = FitOptions { cancel, ..FitOptions::default() };
    assert!(matches!(fit(&s, &lms, &opts), Err(FitError::Cancelled)));
}

#[test]
fn gauss_newton_step_is_the_minimizer_of_the_squares_problem() {
    let s = grid_spline();
    let lms = landmarks(40, 3, smooth_map);
    let opts = FitOptions { barrier: None, ..FitOptions::default() };
    let f = fit(&s, &lms, &opts).unwrap();
    assert_eq!(f.report.method, FitMethod::new(Solver::GaussNewton));
    assert_eq!(serde_json::to_value(&f.report).unwrap()["method"], "gauss-newton");
    // Gradient at the (exact, rounded) result is ~0 relative to the gradient at the start.
    let obj = objective(&f.spline, &lms, &opts).unwrap();
    let mut g = vec![0.0; 2 * obj.param.nv()];
    obj.eval(&obj.param.x0(), Some(&mut g));
    let obj0 = objective(&s, &lms, &opts).unwrap();
    let mut g0 = vec![0.0; g.len()];
    obj0.eval(&obj0.param.x0(), Some(&mut g0));
    let n = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
    assert!(n(&g) < 1e-6 * n(&g0), "{} vs {}", n(&g), n(&g0));
    assert!(f.report.exact_c1);
}

#[test]
fn smooth_map_is_recovered_at_held_out_points() {
    let s = grid_spline();
    let lms = landmarks(50, 4, smooth_map);
    let held = landmarks(30, 5, smooth_map);
    // (lambda = 1e-3 px^2 as a scale-free weight.)
    let bend = Bend::Weight(1e-3 / (50.0 * 500.0 * 250.0));
    let f = fit(&s, &lms, &FitOptions { bend, ..FitOptions::default() }).unwrap();
    let tre = super::residuals(&f.spline, &held).unwrap();
    let worst = tre.iter().map(|r| r.residual).fold(0.0, f64::max);
    eprintln!("{:?} fit rms {} tre max {worst}", f.report.method, f.report.fit.rms);
    assert!(f.report.fit.rms < 0.2, "fit rms {}", f.report.fit.rms);
    assert!(worst < 1.5, "held-out error {worst}");
    assert!(!f.report.folds);
}

#[test]
fn robust_losses_ignore_gross_outliers() {
    let s = grid_spline();
    let mut lms = landmarks(50, 6, smooth_map);
    for l in lms.iter_mut().take(5) {
        l.dst[0] += 60.0;
        l.dst[1] -= 45.0;
    }
    let held = landmarks(30, 7, smooth_map);
    let err = |loss| {
        // A stiff spline: fitting one bad match would cost more bending than its (bounded)
        // robust loss, so the robust fits drop them; squares cannot.
        // (lambda = 10 px^2: the scale-free weight is lambda / (sum w * area).)
        let bend = Bend::Weight(10.0 / (50.0 * 500.0 * 250.0));
        let f = fit(&s, &lms, &FitOptions { loss, bend, ..FitOptions::default() }).unwrap();
        eprintln!("{loss:?}: {} iterations, {:.1} ms", f.report.iterations, f.report.time_ms);
        let r = super::residuals(&f.spline, &held).unwrap();
        (r.iter().map(|x| x.residual * x.residual).sum::<f64>() / r.len() as f64).sqrt()
    };
    let (sq, cauchy) = (err(Loss::Squares), err(Loss::Cauchy(2.0)));
    let huber = err(Loss::Huber(2.0));
    eprintln!("held-out rms: squares {sq}, huber {huber}, cauchy {cauchy}");
    assert!(cauchy < 0.5 * sq && cauchy < 3.0, "squares {sq}, cauchy {cauchy}");
}

#[test]
fn barrier_keeps_det_j_above_its_floor_where_squares_fold() {
    let s = grid_spline();
    // Two nearby sources pulled across each other: the squares fit folds.
    let lms = vec![
        Landmark { name: None, src: [200.0, 120.0], dst: [260.0, 120.0], weight: 1.0 },
        Landmark { name: None, src: [240.0, 120.0], dst: [190.0, 120.0], weight: 1.0 },
        Landmark { name: None, src: [50.0, 50.0], dst: [50.0, 50.0], weight: 1.0 },
        Landmark { name: None, src: [450.0, 200.0], dst: [450.0, 200.0], weight: 1.0 },
    ];
    // (lambda = 1e-3 px^2 as a scale-free weight.)
    let bend = Bend::Weight(1e-3 / (4.0 * 500.0 * 250.0));
    let plain =
        fit(&s, &lms, &FitOptions { barrier: None, bend, ..FitOptions::default() }).unwrap();
    assert!(plain.report.folds, "min det {}", plain.report.min_det_j);
    let guarded = fit(&s, &lms, &FitOptions { bend, ..FitOptions::default() }).unwrap();
    eprintln!("{:?} {}", guarded.report.min_det_j, guarded.report.termination);
    assert!(!guarded.report.folds && guarded.report.min_det_j > 0.05);
    assert!(guarded.report.fold_free, "certified: {}", guarded.report.det_j_lower_bound);
    assert!(guarded.report.method.newton);
    // The crossing pair is named.
    assert_eq!(guarded.report.conflicts, vec![["#0".to_string(), "#1".to_string()]]);
}

#[test]
fn result_is_exactly_c1_and_input_untouched() {
    let s = grid_spline();
    let before = s.points().to_vec();
    let f = fit(&s, &landmarks(10, 8, smooth_map), &FitOptions::default()).unwrap();
    assert_eq!(s.points(), &before[..]);
    f.spline.check_c1().unwrap();
}

#[test]
fn bad_landmarks_are_refused() {
    let s = grid_spline();
    let mut lms = landmarks(5, 9, smooth_map);
    assert_eq!(fit(&s, &[], &FitOptions::default()).unwrap_err(), FitError::NoLandmarks);
    lms[2].src = [900.0, 10.0];
    assert!(matches!(
        fit(&s, &lms, &FitOptions::default()),
        Err(FitError::OutsideMesh { index: 2, .. })
    ));
    lms[2].src = [f64::NAN, 10.0];
    assert!(matches!(fit(&s, &lms, &FitOptions::default()), Err(FitError::BadLandmark { .. })));
    lms[2].src = [10.0, 10.0];
    lms[2].weight = 0.0;
    assert!(matches!(fit(&s, &lms, &FitOptions::default()), Err(FitError::BadLandmark { .. })));
}

#[test]
fn bad_options_are_typed_errors_naming_their_values() {
    let s = grid_spline();
    let lms = landmarks(5, 9, smooth_map);
    let d = FitOptions::default;
    let barrier = Barrier { floor: 0.5, tau: 0.3, mu: 1.0 };
    let cases = [
        (
            FitOptions { bend: Bend::Weight(-1.0), ..d() },
            FitError::BendWeight { weight: -1.0 },
            "invalid fit option: bending weight -1 must be finite and >= 0",
        ),
        (
            FitOptions { loss: Loss::Huber(0.0), ..d() },
            FitError::LossScale { scale: 0.0 },
            "invalid fit option: loss scale 0 must be finite and > 0",
        ),
        (
            FitOptions { barrier: Some(barrier), ..d() },
            FitError::BarrierShape { barrier },
            "invalid fit option: barrier needs floor < threshold and a positive weight",
        ),
        (
            FitOptions { grid_bits: 61, ..d() },
            FitError::Sampling { det_level: d().det_level, grid_bits: 61 },
            "invalid fit option: det level and grid bits must be positive (grid bits at most 60)",
        ),
    ];
    for (opts, want, text) in cases {
        let e = fit(&s, &lms, &opts).unwrap_err();
        assert_eq!(e, want);
        assert_eq!(e.to_string(), text);
        assert!(e.is_option() && !e.is_unsolvable());
    }
    assert!(!FitError::NoLandmarks.is_option());
}

#[test]
fn bad_mesh_options_of_a_frame_fit_are_option_errors() {
    use super::frame::{fit_frame, FrameFitOptions};
    let lms = landmarks(5, 9, smooth_map);
    let mut opts = FrameFitOptions::default();
    opts.mesh.min_angle = 40.0;
    let e = fit_frame(&lms, [500.0, 250.0], &opts).unwrap_err();
    assert!(matches!(e, FitError::AdaptedMesh(crate::mesh::MeshError::BadAdapt(_))), "{e}");
    assert!(e.is_option());
    assert!(e.to_string().starts_with("invalid fit option: landmark mesh: min angle 40"), "{e}");
}

/// Bug: a landmark target of 1e300 made `trimorph fit` run for minutes (soft and hard fits);
/// huge coordinates and weights are now refused up front.
#[test]
fn huge_landmark_coordinates_are_refused_instead_of_hanging() {
    let s = grid_spline();
    let mut lms = landmarks(5, 9, smooth_map);
    for hard in [false, true] {
        let opts = FitOptions { hard, ..FitOptions::default() };
        lms[1].dst = [1e300, 1.0];
        assert!(matches!(fit(&s, &lms, &opts), Err(FitError::BadLandmark { index: 1, .. })));
        lms[1].dst = lms[1].src;
        lms[1].weight = 1e300;
        assert!(matches!(fit(&s, &lms, &opts), Err(FitError::BadLandmark { index: 1, .. })));
        lms[1].weight = 1.0;
    }
}

#[test]
fn radius_limits_the_change_to_the_landmarks_neighbourhood() {
    let s = grid_spline();
    let lms = vec![Landmark { name: None, src: [120.0, 80.0], dst: [126.0, 83.0], weight: 1.0 }];
    let f = fit(&s, &lms, &FitOptions { radius: Some(2), ..FitOptions::default() }).unwrap();
    assert!(f.report.fit.max < 0.01, "{:?}", f.report.fit);
    // Far away, phi is still the identity exactly.
    for p in [[450.0, 200.0], [480.0, 20.0]] {
        assert_eq!(f.spline.eval(p, None).unwrap(), s.eval(p, None).unwrap());
    }
}

#[test]
fn hard_mode_interpolates_exactly_in_rational_arithmetic() {
    use crate::exact::Rat;
    let s = grid_spline();
    // Sources on the 2^-8 grid, so the constraint is phi(s_i) = t_i for the given s_i.
    let mut lms = landmarks(12, 10, smooth_map);
    for l in lms.iter_mut() {
        l.src = l.src.map(|v| (v * 256.0).round() / 256.0);
    }
    let f = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap();
    f.spline.check_c1().unwrap();
    for l in &lms {
        let (row, tgt) = super::hard::landmark_row(&s, l).unwrap();
        for a in 0..2 {
            let mut acc = Rat::from_integer(0.into());
            for (p, c) in &row {
                acc += Rat::from_integer(c.clone()) * &f.spline.points()[*p][a];
            }
            assert_eq!(acc, tgt[a], "landmark {:?} coordinate {a}", l.name);
        }
    }
    assert!(f.report.fit.max < 1e-5, "{:?}", f.report.fit);
    assert_eq!(f.report.method.exact, Some(ExactStep::Hard));
    assert!(f.report.method.to_string().ends_with("+hard"));
}

#[test]
fn hard_mode_reports_contradictory_landmarks() {
    let s = grid_spline();
    let lms = vec![
        Landmark { name: Some("a".into()), src: [100.0, 100.0], dst: [105.0, 100.0], weight: 1.0 },
        Landmark { name: Some("b".into()), src: [100.0, 100.0], dst: [95.0, 100.0], weight: 1.0 },
        Landmark { name: None, src: [300.0, 100.0], dst: [300.0, 100.0], weight: 1.0 },
    ];
    let e = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap_err();
    assert!(matches!(e, FitError::Conflicting { .. }), "{e}");
}

mod props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]
        /// Whatever the landmarks, the fit is C1 exactly (checked in rational arithmetic),
        /// never worse than the warm start on its own objective, and leaves the input alone.
        #[test]
        fn fits_are_exactly_c1_and_improve_the_objective(
            pts in prop::collection::vec((5.0f64..495.0, 5.0f64..245.0, -12.0f64..12.0, -12.0f64..12.0), 3..25),
            bend in 0.001f64..1.0,
            robust in 0usize..3,
        ) {
            let s = grid_spline();
            let lms: Vec<Landmark> = pts
                .iter()
                .map(|&(x, y, dx, dy)| Landmark { name: None, src: [x, y], dst: [x + dx, y + dy], weight: 1.0 })
                .collect();
            let loss = [Loss::Squares, Loss::Huber(2.0), Loss::Cauchy(2.0)][robust];
            let f = fit(&s, &lms, &FitOptions { loss, bend: Bend::Weight(bend), ..FitOptions::default() }).unwrap();
            prop_assert!(f.spline.check_c1().is_ok());
            prop_assert!(f.report.exact_c1);
            prop_assert!(f.report.cost_final <= f.report.cost_initial + 1e-9);
        }
    }
}

#[test]
fn pinned_points_keep_their_input_values_exactly() {
    // A hand-corrected start: one interior corner point moved off the identity.
    let mesh = Mesh::grid(4, 4, 100.0, 100.0, MeshOptions::default()).unwrap();
    let id = Spline::identity(mesh, 5).unwrap();
    let mut ed = crate::edit::Editor::new(id);
    let v = (0..ed.spline().mesh().num_vertices())
        .find(|&v| {
            let p = ed.spline().mesh().vertex(v);
            (p[0] - 50.0).abs() < 1e-9 && (p[1] - 50.0).abs() < 1e-9
        })
        .unwrap();
    ed.select(
        &[ControlPoint(v)],
        &[],
        &crate::edit::select::Neighborhood::Radius(3),
        crate::edit::Mode::Xy,
    )
    .unwrap();
    ed.translate(&[rat_int(3), rat_int(-2)]).unwrap();
    let corrected = ed.into_spline();
    let lms: Vec<Landmark> = [[20.0, 20.0], [80.0, 25.0], [30.0, 75.0], [70.0, 70.0], [50.0, 30.0]]
        .iter()
        .map(|&p| Landmark { name: None, src: p, dst: [p[0] + 1.5, p[1] + 0.5], weight: 1.0 })
        .collect();
    for hard in [false, true] {
        let opts = FitOptions { pinned: vec![ControlPoint(v)], hard, ..FitOptions::default() };
        let f = fit(&corrected, &lms, &opts).unwrap();
        assert_eq!(f.spline.points()[v], corrected.points()[v], "hard = {hard}");
        f.spline.check_c1().unwrap();
        assert_eq!(
            f.report.method.exact,
            Some(if hard { ExactStep::Hard } else { ExactStep::Pinned })
        );
        // The rest did fit: residuals well below the 1.6 px offset.
        assert!(f.report.fit.rms < 0.8, "hard = {hard}: rms {}", f.report.fit.rms);
    }
    let bad = FitOptions { pinned: vec![ControlPoint(usize::MAX)], ..FitOptions::default() };
    let e = fit(&corrected, &lms, &bad).unwrap_err();
    let n = corrected.num_points();
    assert_eq!(e, FitError::NoSuchPinned { point: ControlPoint(usize::MAX), points: n });
    assert!(e.is_option());
    assert_eq!(
        e.to_string(),
        format!(
            "invalid fit option: pinned control point {} does not exist (the spline has {n})",
            usize::MAX
        )
    );
}

/// The automatic weight minimizes the leave-one-out score computed in closed form: that
/// score equals the one got by refitting without each landmark in turn (its weight scaled
/// by 1e-12), and no weight on a grid around the choice scores lower.
#[test]
fn leave_one_out_choice_matches_refits_without_each_landmark() {
    use super::smooth::Smoother;
    let s = grid_spline();
    let mut rng = SmallRng::seed_from_u64(11);
    let mut lms = landmarks(24, 5, smooth_map);
    for l in &mut lms {
        l.dst[0] += rng.gen_range(-1.5..1.5);
        l.dst[1] += rng.gen_range(-1.5..1.5);
    }
    let obj = objective(&s, &lms, &FitOptions { barrier: None, ..FitOptions::default() }).unwrap();
    let sm = Smoother::new(&obj).unwrap();
    let c = sm.choose().unwrap().expect("24 landmarks are enough to choose");
    let refit = |bend: f64| {
        let k = lms.len();
        let mut sum = 0.0;
        for i in 0..k {
            let mut scale = vec![1.0; k];
            scale[i] = 1e-12; // effectively left out (0 would make the system singular)
            let x = sm.solve(bend, Some(&scale)).unwrap();
            sum += obj.residual_lengths(&x)[i].powi(2);
        }
        (sum / k as f64).sqrt()
    };
    let at = refit(c.bend);
    let loo = c.loo_rms.expect("landmark space gives leave-one-out");
    assert!((at - loo).abs() <= 1e-6 * at, "closed form {loo} vs refits {at}");
    for f in [0.3, 0.6, 1.6, 3.0] {
        assert!(refit(c.bend * f) >= at * (1.0 - 1e-9), "bend {} x {f} scores lower", c.bend);
    }
    assert!(c.bend > 1e-10 && c.bend < 1.0, "noisy targets call for some smoothing: {}", c.bend);
}

/// Bug (issue 51, found this session): landmarks of a large image onto a small one (a
/// morph's B -> A fit, det A about 0.04) ran Newton with the fold barrier to its 200-iteration
/// cap for 540 s over 3,732 triangles: the barrier's absolute floor (det J >= 0.1) was above
/// the whole map's own det, and the default edge length filled the covering margin (3,641
/// px) with frame-sized triangles. The floor is now relative to det A and the edges follow
/// the frame's scale: the fit is exact (no barrier needed), certified and small.
#[test]
fn a_shrinking_landmark_set_fits_without_fighting_the_barrier() {
    use super::frame::{fit_frame, FrameFitOptions};
    let mut rng = SmallRng::seed_from_u64(68);
    let lms: Vec<Landmark> = (0..40)
        .map(|k| {
            let src: [f64; 2] = [rng.gen_range(200.0..600.0), rng.gen_range(250.0..750.0)];
            let wob = [(src[1] / 90.0).sin() * 2.0, (src[0] / 70.0).cos() * 2.0];
            let dst = [src[0] * 0.19 + wob[0], src[1] * 0.21 + wob[1]];
            Landmark { name: Some(format!("p{k}")), src, dst, weight: 1.0 }
        })
        .collect();
    let f = fit_frame(&lms, [817.0, 1024.0], &FrameFitOptions::default()).unwrap();
    let r = &f.fit.report;
    assert_ne!(r.termination, FitTermination::IterationCap, "{r:?}");
    assert!(r.fold_free, "{r:?}");
    assert!(f.frame.covers_frame);
    assert!(f.frame.margin > 2000.0, "the covering margin is large: {}", f.frame.margin);
    assert!(f.frame.triangles < 1_000, "{} triangles", f.frame.triangles);
    // The barrier relative to the affine map: same shape, floor and threshold scaled.
    let b = Barrier::with_floor(0.1).unwrap();
    let rel = b.relative_to(0.04);
    assert!((rel.floor - 0.004).abs() < 1e-15 && (rel.tau - 0.012).abs() < 1e-15);
    assert!((b.eval2(0.2).0 - rel.eval2(0.008).0).abs() < 1e-12, "beta(det / det_a)");
    assert_eq!(b.relative_to(3.0), b, "maps that enlarge keep the absolute floor");
}
