use super::deform::{total, LevelTerm};
use super::image::{pyramid, Channel, Mask};
use super::*;
use crate::fit::objective::{Barrier, Loss, Objective};
use crate::fit::param::Param;

/// A crop of the bundled cell image as a channel.
pub(super) fn cell_crop(x0: u32, y0: u32, w: u32, h: u32) -> Channel {
    let img = ::image::load_from_memory(crate::bundled::CELL_PNG).expect("bundled");
    let g = img.to_luma32f();
    let data = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| g.get_pixel(x0 + x, y0 + y).0[0])
        .collect();
    Channel { w: w as usize, h: h as usize, data }
}

/// A known smooth map from FIXED to MOVING pixels.
fn psi(p: [f64; 2]) -> [f64; 2] {
    [
        p[0] + 1.5 + 1.2 * (p[1] * 0.05).sin(),
        p[1] - 1.0 + 1.0 * (p[0] * 0.04).cos() + 0.01 * (p[0] - 40.0),
    ]
}

/// FIXED = MOVING resampled through `psi`: `F(x) = M(psi(x))`.
fn warped(m: &Channel) -> Channel {
    let mut data = Vec::with_capacity(m.w * m.h);
    for y in 0..m.h {
        for x in 0..m.w {
            let q = psi([x as f64, y as f64]);
            let qx = q[0].clamp(-0.5, m.w as f64 - 0.5);
            let qy = q[1].clamp(-0.5, m.h as f64 - 0.5);
            data.push(m.sample(qx, qy).expect("inside").0 as f32);
        }
    }
    Channel { data, ..m.clone() }
}

fn input(c: Channel, name: &str) -> Input {
    Input { image: c, name: name.into(), mask: None }
}

#[test]
fn the_registration_gradient_matches_finite_differences() {
    let m = cell_crop(200, 250, 64, 64);
    let f = warped(&m);
    let fp = pyramid(&f, None, 1);
    let mp = pyramid(&m, None, 1);
    let mesh = frame_mesh(64, 64, 32.0).unwrap();
    let s = Spline::identity(mesh, 5).unwrap();
    let mds = Mds::new(&s).unwrap();
    let param = Param::new(&s, &mds, &vec![true; s.num_points()]);
    let lm = [Landmark { name: None, src: [20.0, 30.0], dst: [22.0, 29.0], weight: 1.0 }];
    let rows = vec![crate::fit::objective::data_row(&s, lm[0].src, lm[0].dst, 0.5).unwrap()];
    let barrier = Barrier::with_floor(0.1).unwrap();
    let obj = Objective::new(&s, param, rows, Loss::Squares, 1e-3, Some(barrier), 4);
    for metric in [Metric::Ssd, Metric::Ncc, Metric::Mi] {
        let term = LevelTerm::new(&s, &fp[0], &mp[0], metric, Default::default());
        let mut x = obj.param.x0();
        // Away from the identity, so every term has a gradient.
        for (k, v) in x.iter_mut().enumerate() {
            *v += 0.3 * ((k as f64) * 0.7).sin();
        }
        let (_, g, _) = total(&obj, &term, &x);
        let h = 1e-5;
        for k in [0, 7, 31, x.len() / 2 + 5, x.len() - 3] {
            let mut xp = x.clone();
            xp[k] += h;
            let mut xm = x.clone();
            xm[k] -= h;
            let num = (total(&obj, &term, &xp).0 - total(&obj, &term, &xm).0) / (2.0 * h);
            let tol = 1e-4 * (num.abs() + g[k].abs()) + 1e-8;
            assert!((num - g[k]).abs() < tol, "{metric:?} variable {k}: {num} vs {}", g[k]);
        }
    }
}

/// Mean of `|psi(phi(y)) - y|` over MOVING's pixels at least `border` from its edges.
fn mean_error(s: &Spline, w: usize, h: usize, border: usize) -> f64 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for y in (border..h - border).step_by(2) {
        for x in (border..w - border).step_by(2) {
            let p = [x as f64, y as f64];
            let q = psi(s.eval(p, None).unwrap());
            sum += (q[0] - p[0]).hypot(q[1] - p[1]);
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn a_known_smooth_warp_of_a_real_image_is_recovered() {
    let m = cell_crop(150, 200, 160, 160);
    let f = warped(&m);
    let opts = RegisterOptions { spacing: 40.0, ..RegisterOptions::default() };
    let reg = register(&input(f, "fixed"), &input(m, "moving"), &opts).unwrap();
    let r = &reg.report;
    assert!(r.fold_free && r.det_j_lower_bound > 0.0, "{r:?}");
    assert!(r.metric_after < 0.5 * r.metric_before, "{r:?}");
    let err = mean_error(&reg.spline, 160, 160, 12);
    let id = Spline::identity(reg.spline.mesh().clone(), 5).unwrap();
    let before = mean_error(&id, 160, 160, 12);
    assert!(before > 1.5, "{before}");
    assert!(err < 0.35, "mean endpoint error {err} px (identity: {before})");
    reg.spline.check_c1().unwrap();
}

#[test]
fn a_cancelled_registration_returns_cancelled() {
    let m = cell_crop(150, 200, 96, 96);
    let f = warped(&m);
    let cancel = crate::cancel::Cancel::new();
    cancel.cancel();
    let opts = RegisterOptions { spacing: 40.0, cancel, ..RegisterOptions::default() };
    let r = register(&input(f, "fixed"), &input(m, "moving"), &opts);
    assert!(matches!(r, Err(RegisterError::Cancelled)), "{:?}", r.err());
}

#[test]
fn hard_landmarks_hold_exactly_in_rationals() {
    let m = cell_crop(150, 200, 96, 96);
    let f = warped(&m);
    // Targets from the known map's inverse, slightly off, to see that they are met exactly.
    let lms: Vec<Landmark> = [[30.0, 30.0], [60.0, 40.0], [45.0, 70.0]]
        .iter()
        .enumerate()
        .map(|(i, &p)| Landmark {
            name: Some(format!("L{i}")),
            src: p,
            dst: [p[0] - 1.25, p[1] + 0.75],
            weight: 1.0,
        })
        .collect();
    let opts = RegisterOptions {
        spacing: 32.0,
        landmarks: lms.clone(),
        hard: true,
        levels: Some(2),
        max_iters: 20,
        ..RegisterOptions::default()
    };
    let reg = register(&input(f, "fixed"), &input(m, "moving"), &opts).unwrap();
    for l in &lms {
        let (src, dst) = crate::fit::hard::exact_landmark(l);
        let (t, b) = crate::fit::hard::locate_exact(&reg.spline, &src).unwrap();
        let row = crate::fit::hard::bernstein_row(&reg.spline, t, &b);
        for c in 0..2 {
            let v = row.iter().fold(crate::exact::Rat::from_integer(0.into()), |a, (p, w)| {
                a + w * &reg.spline.points()[*p][c]
            });
            assert_eq!(v, dst[c]);
        }
    }
    let lr = reg.report.landmarks.as_ref().unwrap();
    assert!(lr.hard && lr.fit.max < 1e-9);
    assert!(reg.report.fold_free);
}

#[test]
fn bad_inputs_are_refused_with_their_names() {
    let m = cell_crop(150, 200, 64, 64);
    let flat = Channel { data: vec![0.5; 64 * 64], ..m.clone() };
    let e =
        register(&input(m.clone(), "f.png"), &input(flat, "m.png"), &RegisterOptions::default())
            .unwrap_err();
    assert!(matches!(e, RegisterError::Constant { .. }) && e.to_string().contains("m.png"), "{e}");
    let mut with_mask = input(m.clone(), "f.png");
    with_mask.mask = Some((Mask { w: 64, h: 64, on: vec![false; 64 * 64] }, "mask.png".into()));
    let e =
        register(&with_mask, &input(m.clone(), "m.png"), &RegisterOptions::default()).unwrap_err();
    assert!(matches!(e, RegisterError::EmptyMask { .. }) && e.to_string().contains("mask.png"));
    with_mask.mask = Some((Mask { w: 60, h: 64, on: vec![true; 60 * 64] }, "mask.png".into()));
    let e =
        register(&with_mask, &input(m.clone(), "m.png"), &RegisterOptions::default()).unwrap_err();
    assert!(matches!(e, RegisterError::MaskSize { .. }), "{e}");
    // Far apart: after a translation-free start the moving image lands off the fixed one.
    let init_far = {
        let mesh = frame_mesh(64, 64, 32.0).unwrap();
        let r = |v: i64| crate::exact::Rat::from_integer(v.into());
        Spline::affine(mesh, 5, &[[r(1), r(0), r(500)], [r(0), r(1), r(0)]]).unwrap()
    };
    let opts = RegisterOptions { init: Some(init_far), ..RegisterOptions::default() };
    let e = register(&input(m.clone(), "f.png"), &input(m.clone(), "m.png"), &opts).unwrap_err();
    assert!(matches!(e, RegisterError::NoOverlap { .. }), "{e}");
    let nan = {
        let mut c = m.clone();
        c.data[70] = f32::NAN;
        c
    };
    let img = ::image::DynamicImage::ImageRgb32F(::image::ImageBuffer::from_fn(64, 64, |x, y| {
        let v = nan.data[(y * 64 + x) as usize];
        ::image::Rgb([v, v, v])
    }));
    let e = Channel::from_image(&img, std::path::Path::new("nan.tif")).unwrap_err();
    assert!(e.to_string().contains("nan.tif") && e.to_string().contains("(6, 1)"), "{e}");
}

#[test]
fn the_mesh_pyramid_refines_exactly_between_levels_and_recovers_the_warp() {
    let m = cell_crop(150, 200, 160, 160);
    let f = warped(&m);
    let opts = RegisterOptions {
        spacing: 20.0,
        levels: Some(3),
        mesh_levels: Some(3),
        refine_share: 1.0,
        ..RegisterOptions::default()
    };
    let reg = register(&input(f.clone(), "fixed"), &input(m.clone(), "moving"), &opts).unwrap();
    let r = &reg.report;
    assert_eq!(r.mesh_levels, 3);
    // 2 x 2 cells of 80 px, then every triangle split in four twice.
    let tris: Vec<usize> =
        r.levels.iter().filter(|l| l.stage == "spline").map(|l| l.triangles.unwrap()).collect();
    assert_eq!(tris, [8, 32, 128]);
    assert_eq!(r.refinements.len(), 2);
    assert_eq!((r.refinements[0].red, r.refinements[0].green), (8, 0));
    assert_eq!((r.refinements[1].red, r.refinements[1].green), (32, 0));
    assert_eq!(r.triangles, 128);
    assert!(r.fold_free, "{r:?}");
    reg.spline.check_c1().unwrap();
    let err = mean_error(&reg.spline, 160, 160, 12);
    assert!(err < 0.35, "mean endpoint error {err} px");
    // Adaptive: fewer triangles split, still exact and certified.
    let adaptive = RegisterOptions { refine_share: 0.5, ..opts.clone() };
    let reg = register(&input(f.clone(), "fixed"), &input(m.clone(), "moving"), &adaptive).unwrap();
    let r = &reg.report;
    assert!(r.refinements.iter().all(|s| s.marked >= 1), "{:?}", r.refinements);
    assert!(r.triangles < 128 && r.triangles > 8, "{}", r.triangles);
    assert!(r.fold_free);
    reg.spline.check_c1().unwrap();
    // A given mesh is kept: one mesh level.
    let init = Spline::identity(frame_mesh(160, 160, 40.0).unwrap(), 5).unwrap();
    let keep = RegisterOptions { init: Some(init), levels: Some(2), ..opts };
    let reg = register(&input(f, "fixed"), &input(m, "moving"), &keep).unwrap();
    assert_eq!((reg.report.mesh_levels, reg.report.triangles), (1, 32));
    assert!(reg.report.refinements.is_empty());
}

#[test]
fn the_refinement_indicator_is_largest_where_the_images_disagree() {
    // FIXED = MOVING with a local bump of 2 px around (96, 64); elsewhere equal.
    let m = cell_crop(150, 200, 128, 128);
    let mut f = m.clone();
    for y in 0..128 {
        for x in 0..128 {
            let (dx, dy) = (x as f64 - 96.0, y as f64 - 64.0);
            let b = 2.0 * (-(dx * dx + dy * dy) / (2.0 * 12.0 * 12.0)).exp();
            f.data[y * 128 + x] = m.sample(x as f64 + b, y as f64).expect("inside").0 as f32;
        }
    }
    let fp = pyramid(&f, None, 1);
    let mp = pyramid(&m, None, 1);
    let s = Spline::identity(frame_mesh(128, 128, 32.0).unwrap(), 5).unwrap();
    let eta = pyramid::indicator(&s, &fp[0], &mp[0], Metric::Ncc, Default::default()).unwrap();
    let mesh = s.mesh();
    let centroid = |t: usize| {
        let v = mesh.triangle(t).map(|v| mesh.vertex(v));
        [(v[0][0] + v[1][0] + v[2][0]) / 3.0, (v[0][1] + v[1][1] + v[2][1]) / 3.0]
    };
    let total: f64 = eta.iter().sum();
    let far: f64 = (0..eta.len()).filter(|&t| centroid(t)[0] < 48.0).map(|t| eta[t]).sum();
    assert!(total > 0.0 && far < 0.02 * total, "far {far} of {total}");
    let top = (0..eta.len()).max_by(|&a, &b| eta[a].total_cmp(&eta[b])).unwrap();
    let c = centroid(top);
    assert!((c[0] - 96.0).hypot(c[1] - 64.0) < 32.0, "largest at {c:?}");
    // Doerfler's half: only triangles near the bump.
    let marked = pyramid::doerfler(&eta, 0.5);
    for t in (0..eta.len()).filter(|&t| marked[t]) {
        assert!(centroid(t)[0] > 48.0, "triangle {t} at {:?}", centroid(t));
    }
}
