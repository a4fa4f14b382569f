use super::*;
use crate::rng::SplitMix64;

fn cell() -> GrayImage {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/cell.png");
    image::open(p).unwrap().to_luma8()
}

/// `out(q) = img(inv(q))` with bilinear interpolation (0 outside).
fn resample(img: &GrayImage, inv: &Affine2) -> GrayImage {
    pull_back(img, inv, img.width(), img.height())
}

fn assert_landmarks_follow(r: &MatchResult, truth: &Affine2, tol: f64) {
    for l in &r.landmarks {
        let m = truth.apply(l.src);
        let e = ((m[0] - l.dst[0]).powi(2) + (m[1] - l.dst[1]).powi(2)).sqrt();
        assert!(
            e <= tol,
            "{:?}: {:?} -> {:?}, expected {m:?} (error {e:.2})",
            l.name,
            l.src,
            l.dst
        );
    }
    assert_eq!(r.stats.inliers, r.landmarks.len());
    assert_eq!(r.landmarks[0].name.as_deref(), Some("m0"));
}

#[test]
fn affine_fit_is_exact_on_three_points_and_rejects_collinear() {
    let t = Affine2 { a: [[1.1, -0.2], [0.3, 0.9]], b: [5.0, -3.0] };
    let s = [[0.0, 0.0], [10.0, 1.0], [2.0, 7.0]];
    let d: Vec<[f64; 2]> = s.iter().map(|p| t.apply(*p)).collect();
    let f = Affine2::fit(&s, &d).unwrap();
    for r in 0..2 {
        assert!((f.b[r] - t.b[r]).abs() < 1e-12);
        for c in 0..2 {
            assert!((f.a[r][c] - t.a[r][c]).abs() < 1e-12);
        }
    }
    let line = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [5.0, 5.0]];
    assert!(Affine2::fit(&line, &line).is_none());
    assert!(Affine2::fit(&s[..2], &d[..2]).is_none());
}

#[test]
fn ransac_recovers_affine_with_30_percent_outliers() {
    let truth = Affine2 { a: [[0.95, -0.17], [0.21, 1.04]], b: [12.5, -7.25] };
    let mut rng = SplitMix64::new(99);
    let mut uniform =
        |lo: f64, hi: f64| lo + (hi - lo) * (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    let (mut src, mut dst, mut is_out) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..200 {
        let p = [uniform(0.0, 500.0), uniform(0.0, 600.0)];
        let outlier = k % 10 < 3;
        let q = if outlier {
            // Gross outliers: at least 40 px away from the truth.
            let m = truth.apply(p);
            let (r, th) = (uniform(40.0, 300.0), uniform(0.0, std::f64::consts::TAU));
            [m[0] + r * th.cos(), m[1] + r * th.sin()]
        } else {
            truth.apply(p)
        };
        src.push(p);
        dst.push(q);
        is_out.push(outlier);
    }
    let (model, inliers) = ransac_affine(&src, &dst, &RansacOptions::default()).unwrap();
    let expected: Vec<usize> = (0..200).filter(|&k| !is_out[k]).collect();
    assert_eq!(inliers, expected);
    for r in 0..2 {
        assert!((model.b[r] - truth.b[r]).abs() < 1e-6, "{model} vs {truth}");
        for c in 0..2 {
            assert!((model.a[r][c] - truth.a[r][c]).abs() < 1e-6, "{model} vs {truth}");
        }
    }
    // Deterministic for a seed.
    assert_eq!(ransac_affine(&src, &dst, &RansacOptions::default()).unwrap().1, inliers);
}

#[test]
fn ransac_errors() {
    let s = [[0.0, 0.0], [1.0, 0.0]];
    assert!(matches!(
        ransac_affine(&s, &s, &RansacOptions::default()),
        Err(FeatureError::TooFewMatches { found: 2, .. })
    ));
    // Collinear points only: every sample is degenerate.
    let line: Vec<[f64; 2]> = (0..10).map(|k| [k as f64, 2.0 * k as f64]).collect();
    assert!(matches!(
        ransac_affine(&line, &line, &RansacOptions::default()),
        Err(FeatureError::NoConsensus { best: 0, .. })
    ));
    // Random pairs: no model has 6 inliers within 0.01 px.
    let mut rng = SplitMix64::new(5);
    let mut r = || (rng.next_u64() % 1000) as f64;
    let (a, b): (Vec<[f64; 2]>, Vec<[f64; 2]>) = (0..12).map(|_| ([r(), r()], [r(), r()])).unzip();
    let opts = RansacOptions { threshold: 0.01, ..Default::default() };
    assert!(matches!(ransac_affine(&a, &b, &opts), Err(FeatureError::NoConsensus { .. })));
    let bad = RansacOptions { threshold: -1.0, ..Default::default() };
    let e = ransac_affine(&a, &b, &bad).unwrap_err();
    assert!(matches!(e, FeatureError::Threshold { threshold: -1.0 }) && e.is_option());
    assert_eq!(e.to_string(), "invalid option: threshold -1 is not a finite number > 0");
    let bad = RansacOptions { confidence: 0.0, ..Default::default() };
    let e = ransac_affine(&a, &b, &bad).unwrap_err();
    assert!(matches!(e, FeatureError::Confidence { confidence: 0.0 }) && e.is_option());
    assert_eq!(e.to_string(), "invalid option: confidence 0 not in (0, 1]");
}

#[test]
fn cell_matches_its_integer_translation() {
    let a = cell();
    let shift = Affine2 { a: Affine2::IDENTITY.a, b: [9.0, -6.0] };
    let inv = Affine2 { a: Affine2::IDENTITY.a, b: [-9.0, 6.0] };
    let b = resample(&a, &inv);
    let r = match_images(&a, &b, &MatchOptions::default()).unwrap();
    assert_landmarks_follow(&r, &shift, 1.5);
    let FittedModel::Affine(affine) = r.stats.model else { panic!("{:?}", r.stats.model) };
    assert!((affine.b[0] - 9.0).abs() < 0.5 && (affine.b[1] + 6.0).abs() < 0.5);
    // Without refinement the ORB positions keep their pyramid-level rounding: the
    // landmarks still agree with the fitted model within the threshold, less tightly.
    let raw = MatchOptions { refine: false, ..Default::default() };
    let r0 = match_images(&a, &b, &raw).unwrap();
    assert!(r.stats.refined && !r0.stats.refined);
    assert!(r0.stats.rms <= 3.0 && r.stats.rms < r0.stats.rms, "{:?} {:?}", r.stats, r0.stats);
}

#[test]
fn cell_matches_its_rotation_and_scale() {
    let a = cell();
    let (s, th) = (1.04f64, 4.0f64.to_radians());
    let c = [275.0, 330.0];
    let lin = [[s * th.cos(), -s * th.sin()], [s * th.sin(), s * th.cos()]];
    // q = c + lin (p - c)
    let fwd = Affine2 {
        a: lin,
        b: [c[0] - lin[0][0] * c[0] - lin[0][1] * c[1], c[1] - lin[1][0] * c[0] - lin[1][1] * c[1]],
    };
    let (ci, si) = (th.cos() / s, th.sin() / s);
    let ilin = [[ci, si], [-si, ci]];
    let inv = Affine2 {
        a: ilin,
        b: [
            c[0] - ilin[0][0] * c[0] - ilin[0][1] * c[1],
            c[1] - ilin[1][0] * c[0] - ilin[1][1] * c[1],
        ],
    };
    let b = resample(&a, &inv);
    let r = match_images(&a, &b, &MatchOptions::default()).unwrap();
    assert_landmarks_follow(&r, &fwd, 1.5);
}

#[test]
fn match_errors() {
    let small = GrayImage::new(40, 100);
    let big = cell();
    let o = MatchOptions::default();
    assert!(matches!(
        match_images(&small, &big, &o),
        Err(FeatureError::TooSmall { which: 'A', .. })
    ));
    let flat = GrayImage::from_pixel(200, 200, image::Luma([90]));
    assert!(matches!(match_images(&big, &flat, &o), Err(FeatureError::NoFeatures { which: 'B' })));
    let bad = MatchOptions { ratio: 1.5, ..Default::default() };
    let e = match_images(&big, &big, &bad).unwrap_err();
    assert!(matches!(e, FeatureError::Ratio { ratio: 1.5 }) && e.is_option());
    assert_eq!(e.to_string(), "invalid option: ratio 1.5 not in (0, 1]");
    let bad = MatchOptions { features: 2, ..Default::default() };
    let e = match_images(&big, &big, &bad).unwrap_err();
    assert!(matches!(e, FeatureError::FeatureCount { features: 2, .. }) && e.is_option());
    assert_eq!(e.to_string(), "invalid option: features 2 must be >= 3 and levels 8 >= 1");
}

#[test]
fn gray8_scales_deep_images_by_their_max() {
    let g16 = image::ImageBuffer::from_fn(4, 1, |x, _| image::Luma([x as u16 * 1000]));
    let g = gray8(&image::DynamicImage::ImageLuma16(g16));
    assert_eq!(g.as_raw(), &[0, 85, 170, 255]);
    let f = image::ImageBuffer::from_fn(3, 1, |x, _| image::Rgb([x as f32 * 0.25; 3]));
    let g = gray8(&image::DynamicImage::ImageRgb32F(f));
    assert_eq!(g.as_raw(), &[0, 128, 255]);
    let c = image::RgbImage::from_pixel(2, 2, image::Rgb([200, 200, 200]));
    assert_eq!(gray8(&image::DynamicImage::ImageRgb8(c)).as_raw(), &[200; 4]);
    let z = image::ImageBuffer::from_pixel(2, 1, image::Luma([0u16]));
    assert_eq!(gray8(&image::DynamicImage::ImageLuma16(z)).as_raw(), &[0, 0]);
}

/// A projective view of the plane: a homography with a visible perspective part.
fn perspective() -> Homography {
    Homography { h: [[1.02, 0.05, 8.0], [-0.03, 0.97, -5.0], [2.0e-4, -1.5e-4, 1.0]] }
}

#[test]
fn homography_fit_is_exact_on_four_points_and_rejects_degenerate_samples() {
    let t = perspective();
    let s = [[0.0, 0.0], [400.0, 10.0], [380.0, 500.0], [-20.0, 450.0]];
    let d: Vec<[f64; 2]> = s.iter().map(|p| t.apply(*p)).collect();
    let f = Homography::fit(&s, &d).unwrap();
    for p in [[100.0, 200.0], [333.0, 44.0], [0.0, 0.0]] {
        let (a, b) = (f.apply(p), t.apply(p));
        assert!((a[0] - b[0]).abs() < 1e-8 && (a[1] - b[1]).abs() < 1e-8, "{f} vs {t}");
    }
    // Three of four on a line, too few points, a mirror image.
    let line = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.0, 5.0]];
    assert!(Homography::fit(&line, &d).is_none());
    assert!(Homography::fit(&s[..3], &d[..3]).is_none());
    let mirrored: Vec<[f64; 2]> = d.iter().map(|q| [-q[0], q[1]]).collect();
    assert!(Homography::fit(&s, &mirrored).is_none());
    // Beyond the horizon line (w <= 0) a homography is undefined: NaN, never an inlier.
    let h = Homography { h: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-0.01, 0.0, 1.0]] };
    assert!(h.apply([100.0, 0.0])[0].is_nan() && h.apply([200.0, 3.0])[1].is_nan());
    assert!(h.apply([50.0, 0.0])[0].is_finite());
}

#[test]
fn ransac_recovers_a_homography_with_30_percent_outliers() {
    let truth = perspective();
    let mut rng = SplitMix64::new(3);
    let mut uniform =
        |lo: f64, hi: f64| lo + (hi - lo) * (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    let (mut src, mut dst, mut good) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..150 {
        let p = [uniform(0.0, 500.0), uniform(0.0, 600.0)];
        let m = truth.apply(p);
        let q = if k % 10 < 3 {
            let (r, th) = (uniform(40.0, 300.0), uniform(0.0, std::f64::consts::TAU));
            [m[0] + r * th.cos(), m[1] + r * th.sin()]
        } else {
            m
        };
        src.push(p);
        dst.push(q);
        good.push(k % 10 >= 3);
    }
    let (model, inliers) = ransac_homography(&src, &dst, &RansacOptions::default()).unwrap();
    assert_eq!(inliers, (0..150).filter(|&k| good[k]).collect::<Vec<_>>());
    for p in [[10.0, 10.0], [490.0, 590.0], [250.0, 300.0]] {
        let (a, b) = (model.apply(p), truth.apply(p));
        assert!((a[0] - b[0]).hypot(a[1] - b[1]) < 1e-6, "{model} vs {truth}");
    }
    // The affine model cannot follow the perspective part over the whole image.
    let (_, affine) = ransac_affine(&src, &dst, &RansacOptions::default()).unwrap();
    assert!(affine.len() < inliers.len(), "{} vs {}", affine.len(), inliers.len());
}

#[test]
fn sampling_draws_distinct_indices_and_keeps_the_affine_sequence() {
    // The generic sampler draws, for 3 indices, exactly what the affine RANSAC drew before
    // it was generic (so `trimorph match` results did not change).
    let mut a = SplitMix64::new(11);
    let mut b = SplitMix64::new(11);
    for _ in 0..1000 {
        let n = 3 + (a.next_u64() % 50) as usize;
        let _ = b.next_u64();
        let got = models::sample_for_tests::<3>(&mut a, n);
        let i = b.below(n);
        let mut j = b.below(n - 1);
        j += (j >= i) as usize;
        let mut k = b.below(n - 2);
        for m in [i.min(j), i.max(j)] {
            k += (k >= m) as usize;
        }
        assert_eq!(got, [i, j, k]);
        let four = models::sample_for_tests::<4>(&mut a, n + 1);
        let _ = models::sample_for_tests::<4>(&mut b, n + 1);
        let mut u = four.to_vec();
        u.sort_unstable();
        u.dedup();
        assert!(u.len() == 4 && u.iter().all(|&x| x < n + 1), "{four:?}");
    }
}

#[test]
fn cell_matches_its_perspective_view_with_the_homography_model() {
    let a = cell();
    let t = Homography { h: [[1.0, 0.03, 6.0], [-0.02, 1.0, -4.0], [5e-5, 4e-5, 1.0]] };
    // b(q) = a(t^-1 q): sample a at the inverse image of each pixel of b.
    let (w, h) = a.dimensions();
    let inv = {
        let m = t.h;
        let c = |r: usize, k: usize| {
            let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
            let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
            m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
        };
        Homography { h: std::array::from_fn(|r| std::array::from_fn(|k| c(k, r))) }
    };
    let b = pull_back(&a, &inv, w, h);
    let opts = MatchOptions { model: ModelKind::Homography, ..Default::default() };
    let r = match_images(&a, &b, &opts).unwrap();
    assert!(matches!(r.stats.model, FittedModel::Homography(_)) && r.landmarks.len() >= 20);
    for l in &r.landmarks {
        let m = t.apply(l.src);
        assert!((m[0] - l.dst[0]).hypot(m[1] - l.dst[1]) <= 1.5, "{l:?} expected {m:?}");
    }
    assert!(r.stats.model.to_string().starts_with("homography ["));
    // The affine model follows the same matches less closely (0.27 px rms against 0.06).
    let affine = match_images(&a, &b, &MatchOptions::default()).unwrap();
    assert!(r.stats.rms * 2.0 < affine.stats.rms, "{} vs {}", r.stats.rms, affine.stats.rms);
}

#[test]
fn local_model_options_are_checked() {
    let a = cell();
    for local in [
        LocalOptions { neighbours: 2, ..Default::default() },
        LocalOptions { min_support: 3, ..Default::default() },
        LocalOptions { max_stretch: 0.5, ..Default::default() },
        LocalOptions { max_stretch: f64::NAN, ..Default::default() },
    ] {
        let o = MatchOptions { model: ModelKind::Local, local, ..Default::default() };
        let e = match_images(&a, &a, &o).unwrap_err();
        assert!(e.is_option(), "{e}");
        assert!(e.to_string().starts_with("invalid option: local model: "), "{e}");
    }
}
