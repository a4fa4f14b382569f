use super::*;
use image::{GrayImage, RgbImage};

fn lm(src: [f64; 2], dst: [f64; 2]) -> Landmark {
    Landmark { name: None, src, dst, weight: 1.0 }
}

fn landmarks() -> Vec<Landmark> {
    vec![
        lm([10.0, 10.0], [12.0, 11.0]),
        lm([50.0, 12.0], [47.0, 14.0]),
        lm([30.0, 35.0], [33.0, 31.0]),
        lm([12.0, 40.0], [10.0, 38.0]),
        lm([52.0, 40.0], [50.0, 42.0]),
    ]
}

/// A smooth pattern with some structure (8-bit gray).
fn pattern(w: u32, h: u32, phase: f64) -> DynamicImage {
    GrayImage::from_fn(w, h, |x, y| {
        let v = 128.0 + 60.0 * ((x as f64 + phase) / 5.0).sin() + 50.0 * (y as f64 / 7.0).cos();
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    })
    .into()
}

/// Raw coordinates: `B` is not aligned, so the last frame is `B` itself.
fn raw() -> MorphOptions {
    MorphOptions { align: false, ..MorphOptions::default() }
}

fn max_diff(a: &DynamicImage, b: &DynamicImage) -> u8 {
    let (a, b) = (a.to_rgba8(), b.to_rgba8());
    a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| x.abs_diff(*y)).max().unwrap()
}

#[test]
fn blended_control_points_equal_a_direct_fit_to_intermediate_landmarks() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    for t in [0.25, 0.5, 1.5, -0.5] {
        let blended = m.phi_a_at(t).unwrap();
        let lt = m.landmarks_at(t).unwrap();
        let direct_lms: Vec<Landmark> =
            landmarks().iter().zip(&lt).map(|(l, q)| lm(l.src, *q)).collect();
        let id = Spline::identity(m.phi_ab().mesh().clone(), 5).unwrap();
        let direct = fit(&id, &direct_lms, &m.options().fit).unwrap().spline;
        let mut worst = 0.0f64;
        for i in 0..blended.num_points() {
            let (p, q) = (blended.point_f64(i), direct.point_f64(i));
            worst = worst.max((p[0] - q[0]).abs()).max((p[1] - q[1]).abs());
        }
        // Where the barrier does not act, the blend is the direct fit up to the fits' rounding
        // of free points to multiples of 2^-20 px and their ridge anchored at the warm start
        // (the affine map for the morph's fit, the identity here): within 2e-4 px per unit
        // of |s| (the difference is scaled by s).
        let tol = 2e-4 * f64::abs(t).max(1.0);
        assert!(worst < tol, "t = {t}: control points differ by {worst}");
        blended.check_c1().unwrap();
    }
}

#[test]
fn blends_are_exactly_c1_and_end_at_identity_and_fit() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(56, 44, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    let id_a = Spline::identity(m.phi_ab().mesh().clone(), m.phi_ab().degree()).unwrap();
    assert_eq!(m.phi_a_at(0.0).unwrap().points(), id_a.points());
    assert_eq!(m.phi_a_at(1.0).unwrap().points(), m.phi_ab().points());
    let sim_b = similarity_points(m.phi_ba(), &m.sim).unwrap();
    assert_eq!(m.phi_b_at(1.0).unwrap().points(), &sim_b[..]);
    assert_eq!(m.phi_b_at(0.0).unwrap().points(), m.phi_ba().points());
    for s in [0.3, 2.0, -1.0] {
        m.phi_a_at(s).unwrap().check_c1().unwrap();
        m.phi_b_at(s).unwrap().check_c1().unwrap();
    }
}

/// The frames render with unreduced blends (no gcds): the same exact values and the same
/// `f64` control points as the reduced [`Morph::phi_a_exact`] / [`Morph::phi_b_exact`].
#[test]
fn frame_maps_are_the_exact_blends_without_reduction() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(56, 44, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    for (n, d) in [(1i64, 3i64), (7, 10), (-1, 2), (3, 2)] {
        let s = Rat::new(Int::from(n), Int::from(d));
        let (fa, fb) = m.frame_maps(&s).unwrap();
        let (ea, eb) = (m.phi_a_exact(&s).unwrap(), m.phi_b_exact(&s).unwrap());
        for (f, e) in [(&fa, &ea), (&fb, &eb)] {
            assert_eq!(f.points(), e.points());
            let (cf, ce) = (f.eval_cache(), e.eval_cache());
            for k in 0..f.mesh().num_triangles() * cf.per_patch() {
                let (x, y) = (cf.patch_point(k), ce.patch_point(k));
                assert_eq!(x.map(f64::to_bits), y.map(f64::to_bits), "{n}/{d}: slot {k}");
            }
        }
        // Unreduced somewhere: the gcds were really skipped.
        assert!(fa.points().iter().flatten().any(|r| r.numer().gcd_int(r.denom()) != Int::from(1)));
    }
}

#[test]
fn exact_and_float_times_give_the_same_frame() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    let third = Rat::new(Int::from(1), Int::from(3));
    let (x, y) = (m.frame_exact(&third).unwrap(), m.frame(1.0 / 3.0).unwrap());
    assert!(max_diff(&x, &y) <= 1);
    let (p, q) = (m.phi_a_exact(&third).unwrap(), m.phi_a_at(1.0 / 3.0).unwrap());
    for i in 0..p.num_points() {
        let (u, v) = (p.point_f64(i), q.point_f64(i));
        assert!((u[0] - v[0]).abs() < 1e-9 && (u[1] - v[1]).abs() < 1e-9);
    }
}

#[test]
fn first_frame_is_a_and_last_is_b() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &raw()).unwrap();
    let frames = m.frames(3, &|| {}).unwrap();
    assert_eq!(frames.len(), 3);
    // Preimages are within 0.01 px of the pixel centres: at most one level of rounding.
    assert!(max_diff(&frames[0], &a) <= 1, "frame 0 vs A: {}", max_diff(&frames[0], &a));
    assert!(max_diff(&frames[2], &b) <= 1, "frame 2 vs B: {}", max_diff(&frames[2], &b));
    // The middle frame is neither.
    assert!(max_diff(&frames[1], &a) > 10 && max_diff(&frames[1], &b) > 10);
}

#[test]
fn b_of_another_size_ends_as_b_on_a_s_grid() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(56, 44, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &raw()).unwrap();
    let last = m.frame(1.0).unwrap();
    assert_eq!((last.width(), last.height()), (64, 48));
    let crop = last.crop_imm(0, 0, 56, 44);
    assert!(max_diff(&crop, &b) <= 1);
}

#[test]
fn landmarks_land_on_the_intermediate_landmarks() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    let end_a = m.landmark_errors(1.0).unwrap();
    let end_b = m.landmark_errors(0.0).unwrap();
    let fit_a = end_a.iter().map(|e| e[0]).fold(0.0, f64::max);
    let fit_b = end_b.iter().map(|e| e[1]).fold(0.0, f64::max);
    assert!(fit_a < 0.5 && fit_b < 0.5, "fit residuals {fit_a}, {fit_b}");
    for t in frame_times(7).into_iter().chain([1.4]) {
        for e in m.landmark_errors(t).unwrap() {
            // phi_{A->t} = (1 - t) id + t phi_{A->B}: the residual scales with t.
            assert!(e[0] <= t.abs() * fit_a + 1e-6, "t = {t}: A side {}", e[0]);
            assert!(e[1] <= (1.0 - t).abs() * fit_b + 1e-6, "t = {t}: B side {}", e[1]);
        }
    }
}

#[test]
fn a_bright_dot_follows_its_landmark() {
    // A dot at a landmark in A and at its match in B shows up at L_t in the middle frame.
    let dot = |c: [f64; 2]| -> DynamicImage {
        GrayImage::from_fn(64, 48, |x, y| {
            let d2 = (x as f64 - c[0]).powi(2) + (y as f64 - c[1]).powi(2);
            image::Luma([(250.0 * (-d2 / 4.0).exp()) as u8])
        })
        .into()
    };
    let lms = landmarks();
    let (a, b) = (dot(lms[2].src), dot(lms[2].dst));
    let m = Morph::new(&a, &b, &lms, &MorphOptions::default()).unwrap();
    let mid = m.frame(0.5).unwrap().to_luma8();
    let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
    for (x, y, p) in mid.enumerate_pixels() {
        let v = f64::from(p.0[0]);
        sx += v * x as f64;
        sy += v * y as f64;
        sw += v;
    }
    let (cx, cy) = (sx / sw, sy / sw);
    let want = m.landmarks_at(0.5).unwrap()[2];
    assert!((cx - want[0]).hypot(cy - want[1]) < 0.5, "dot at ({cx}, {cy}), want {want:?}");
}

#[test]
fn types_are_combined() {
    let a = pattern(64, 48, 0.0);
    let b: DynamicImage = RgbImage::from_pixel(64, 48, image::Rgb([200, 10, 10])).into();
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    let f = m.frame(0.5).unwrap();
    assert_eq!(f.color(), image::ColorType::Rgb8);
    let a16: DynamicImage = a.to_luma16().into();
    let m = Morph::new(&a16, &a, &landmarks(), &MorphOptions::default()).unwrap();
    assert_eq!(m.frame(0.5).unwrap().color(), image::ColorType::L16);
}

#[test]
fn bad_inputs_are_refused() {
    let a = pattern(64, 48, 0.0);
    let o = MorphOptions::default();
    assert!(matches!(
        Morph::new(&a, &a, &landmarks()[..2], &o),
        Err(MorphError::TooFewLandmarks(2))
    ));
    let mut lms = landmarks();
    lms[1].dst = [70.0, 5.0];
    let e = Morph::new(&a, &a, &lms, &o).unwrap_err();
    assert!(matches!(e, MorphError::OutsideImage { index: 1, image: 'B', .. }), "{e}");
    let m = Morph::new(&a, &a, &landmarks(), &o).unwrap();
    assert!(matches!(m.frames(1, &|| {}), Err(MorphError::Frames(1))));
}

/// Issue 52: landmarks on an image's outer edge (up to one pixel past the last pixel
/// centre, as ITK writes them) are accepted on both sides; further out is refused.
#[test]
fn border_landmarks_are_accepted_up_to_one_pixel_past_the_last_centre() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(66, 50, 2.0));
    let o = MorphOptions::default();
    let mut lms = landmarks();
    lms.push(lm([64.0, 20.0], [66.0, 18.0]));
    lms.push(lm([-1.0, 47.5], [-0.5, 50.0]));
    let m = Morph::new(&a, &b, &lms, &o).unwrap();
    for e in m.landmark_errors(1.0).unwrap() {
        assert!(e[0].is_finite(), "{e:?}");
    }
    lms[5].dst = [67.5, 18.0];
    let e = Morph::new(&a, &b, &lms, &o).unwrap_err();
    assert!(matches!(e, MorphError::OutsideImage { index: 5, image: 'B', .. }), "{e}");
    assert!(e.to_string().contains("x from -1 to 66, y from -1 to 50"), "{e}");
}

#[test]
fn preview_starts_at_a_and_moves_with_phi() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    let pv = m.preview(1).unwrap();
    let p0 = m.preview_frame(&pv, 0.0, [0, 0, 0, 255]).unwrap();
    let a8 = a.to_luma8();
    let mut worst = 0u8;
    // The outermost ring of pixels is only half covered by the mesh (see
    // `render::colormesh`); compare inside it.
    for (i, px) in p0.pixels().iter().enumerate() {
        let (x, y) = (i % 64, i / 64);
        if x > 0 && y > 0 && x < 63 && y < 47 {
            worst = worst.max(px.red().abs_diff(a8.as_raw()[i]));
        }
    }
    assert!(worst <= 1, "preview at t = 0 differs from A by {worst}");
    let p1 = m.preview_frame(&pv, 1.0, [0, 0, 0, 255]).unwrap();
    assert_ne!(p0.data(), p1.data());
}

#[test]
fn caricature_frames_extrapolate_the_shape() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    let ts = times_between(3, -0.5, 1.5).unwrap();
    assert_eq!(ts.iter().map(rat_to_f64).collect::<Vec<_>>(), vec![-0.5, 0.5, 1.5]);
    let frames = m.frames_at(&ts, &|| {}).unwrap();
    assert_eq!(frames.len(), 3);
    // The middle one is the ordinary t = 0.5 frame; the ends differ from A and B.
    assert!(max_diff(&frames[1], &m.frame(0.5).unwrap()) <= 1);
    assert!(max_diff(&frames[0], &a) > 10 && max_diff(&frames[2], &b) > 10);
    let sp = m.phi_a_exact(&ts[2]).unwrap();
    sp.check_c1().unwrap();
    // Landmarks go 1.5 times as far as from A to B, up to 1.5 times the fit residual.
    let errs = m.landmark_errors(1.5).unwrap();
    let fit = m.landmark_errors(1.0).unwrap().iter().map(|e| e[0]).fold(0.0, f64::max);
    assert!(errs.iter().all(|e| e[0] <= 1.5 * fit + 1e-6));
}

#[test]
fn schedules() {
    assert_eq!(Schedule::Smooth.at(0.5), 0.5);
    assert_eq!(Schedule::Smooth.at(0.25), 0.15625);
    assert_eq!(Schedule::Smooth.at(1.5), 1.5);
    assert_eq!("smooth".parse::<Schedule>(), Ok(Schedule::Smooth));
    assert!("cubic".parse::<Schedule>().is_err());
    assert_eq!(frame_times(3), vec![0.0, 0.5, 1.0]);
    let half = frame_times_exact(3)[1].clone();
    assert_eq!(half, Rat::new(Int::from(1), Int::from(2)));
    let quarter = Rat::new(Int::from(1), Int::from(4));
    assert_eq!(rat_to_f64(&Schedule::Smooth.at_exact(&quarter)), 0.15625);
    assert_eq!(
        Schedule::Smooth.at_exact(&Rat::from_integer(Int::from(2))),
        Rat::from_integer(Int::from(2))
    );
}

#[test]
fn animations_decode_with_every_frame() {
    let frames: Vec<DynamicImage> = (0..4).map(|k| pattern(20, 10, k as f64)).collect();
    let apng = output::apng_bytes(&frames, 100).unwrap();
    let dec = png::Decoder::new(std::io::Cursor::new(&apng)).read_info().unwrap();
    assert_eq!(dec.info().animation_control().unwrap().num_frames, 4);
    let gif = output::gif_bytes(&frames, 100).unwrap();
    use image::AnimationDecoder;
    let n = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(gif))
        .unwrap()
        .into_frames()
        .count();
    assert_eq!(n, 4);
    assert_eq!(output::frame_name(7, 30), "frame_007.png");
    assert_eq!(output::frame_name(7, 1500), "frame_0007.png");
    assert!(output::is_output_name("frame_007.png") && output::is_output_name("morph.gif"));
    assert!(!output::is_output_name("frame_.png") && !output::is_output_name("frame_x.png"));
    assert!(!output::is_output_name("notes.txt") && !output::is_output_name("frame_1.png.bak"));
    let sheet = output::contact_sheet(&frames, &frame_times(4), 2, 20).unwrap();
    assert!(sheet.width() > 40 && sheet.height() > 20);
}

#[test]
fn preview_vertices_follow_the_exact_blend() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let m = Morph::new(&a, &b, &landmarks(), &MorphOptions::default()).unwrap();
    let pv = m.preview(4).unwrap();
    let (nv, nt) = pv.size();
    assert!(nv > 100 && nt > 150, "{nv} vertices, {nt} triangles");
    for s in [0.0, 0.37, 1.0, 1.4] {
        let phi = m.phi_a_at(s).unwrap();
        let mut worst = 0.0f64;
        for (v, q) in pv.mesh.vertices.iter().zip(&pv.targets) {
            let lin = [v[0] + s * (q[0] - v[0]), v[1] + s * (q[1] - v[1])];
            let e = phi.eval(*v, None).unwrap();
            worst = worst.max((lin[0] - e[0]).abs()).max((lin[1] - e[1]).abs());
        }
        // Named tolerance: f64 rounding of the spline evaluation, far below a pixel.
        assert!(worst < 1e-9, "s = {s}: linear preview differs from the blend by {worst}");
    }
}

#[test]
fn a_morph_from_both_deformations_equals_the_landmark_morph() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(56, 44, 3.0));
    let opts = raw();
    let m = Morph::new(&a, &b, &landmarks(), &opts).unwrap();
    let d =
        Morph::from_deformations(&a, &b, m.phi_ab_raw().unwrap(), Some(m.phi_ba().clone()), &opts)
            .unwrap();
    assert_eq!(d.coverage(), 1.0);
    assert!(d.landmark_errors(0.5).unwrap().is_empty());
    for t in [0.0, 0.4, 1.0] {
        assert_eq!(max_diff(&m.frame(t).unwrap(), &d.frame(t).unwrap()), 0, "t = {t}");
        d.phi_a_at(t).unwrap().check_c1().unwrap();
    }
}

#[test]
fn a_morph_from_one_deformation_fits_the_reverse_and_ends_at_a_and_b() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let opts = raw();
    let m = Morph::new(&a, &b, &landmarks(), &opts).unwrap();
    let d = Morph::from_deformations(&a, &b, m.phi_ab().clone(), None, &opts).unwrap();
    // The fitted reverse approximately inverts phi_ab (within a tenth of a pixel here).
    let mut worst = 0.0f64;
    for l in landmarks() {
        let q = d.phi_ab().eval(l.src, None).unwrap();
        let back = d.phi_ba().eval(q, None).unwrap();
        worst = worst.max((back[0] - l.src[0]).hypot(back[1] - l.src[1]));
    }
    assert!(worst < 0.1, "phi_ba(phi_ab(p)) is {worst} px from p");
    assert!(max_diff(&d.frame(0.0).unwrap(), &a) <= 1);
    assert!(max_diff(&d.frame(1.0).unwrap(), &b) <= 1);
    d.phi_b_at(0.3).unwrap().check_c1().unwrap();
}

#[test]
fn a_deformation_not_covering_a_leaves_background_and_reports_coverage() {
    let (a, b) = (pattern(64, 48, 0.0), pattern(64, 48, 3.0));
    let mesh = Mesh::grid(4, 4, 31.0, 47.0, MeshOptions::default()).unwrap();
    let half = Spline::identity(mesh, 5).unwrap();
    let opts = MorphOptions { background: 255.0, ..raw() };
    let d = Morph::from_deformations(&a, &b, half, None, &opts).unwrap();
    let cov = d.coverage();
    assert!((0.45..0.55).contains(&cov), "coverage {cov}");
    let f = d.frame(0.0).unwrap().to_luma8();
    // Only B has a preimage there (phi_{B->0} = phi_ba covers A's frame): B shows, even at
    // t = 0, and no pixel shows the background.
    assert_ne!(f.get_pixel(60, 20)[0], 255, "a pixel only B covers shows B");
    assert_eq!(f.get_pixel(10, 20)[0], a.to_luma8().get_pixel(10, 20)[0]);
}

/// Where `B`'s preimage leaves `B`'s pixels inside `A`'s frame, the dissolve fades to `A`
/// over the feather band instead of stepping (job.rs, **Feathering**); deep inside both it is
/// the plain dissolve.
#[test]
fn the_dissolve_fades_across_b_s_border_instead_of_stepping() {
    let a: DynamicImage = GrayImage::from_pixel(64, 48, image::Luma([40])).into();
    let b: DynamicImage = GrayImage::from_pixel(40, 30, image::Luma([220])).into();
    let lms = vec![
        lm([5.0, 5.0], [5.5, 5.0]),
        lm([35.0, 5.0], [34.0, 5.5]),
        lm([5.0, 25.0], [5.0, 24.5]),
        lm([35.0, 25.0], [35.5, 25.0]),
        lm([20.0, 15.0], [20.0, 15.0]),
    ];
    let m = Morph::new(&a, &b, &lms, &raw()).unwrap();
    let f = m.frame(0.5).unwrap().to_luma8();
    assert_eq!(f.get_pixel(18, 14)[0], 130, "plain dissolve deep inside both");
    assert_eq!(f.get_pixel(60, 14)[0], 40, "A alone beyond B");
    // Along a row crossing B's right border, and a column crossing its bottom border: no
    // step near the hard switch's 90 levels.
    let row: Vec<i32> = (20..60).map(|x| i32::from(f.get_pixel(x, 14)[0])).collect();
    let col: Vec<i32> = (10..46).map(|y| i32::from(f.get_pixel(18, y)[0])).collect();
    for (what, line) in [("row 14", &row), ("column 18", &col)] {
        let step = line.windows(2).map(|w| (w[1] - w[0]).abs()).max().unwrap();
        assert!(step <= 30, "{what}: a step of {step} levels: {line:?}");
        assert!(line.first() > line.last(), "{what} goes from the dissolve to A: {line:?}");
    }
}

/// Issue 56: the `--cells` limit is the library's, so a library caller asking for a
/// 100000-cell grid is refused before the grid is built (it asked for 160 GB).
#[test]
fn cells_outside_one_to_max_are_refused() {
    assert!(check_cells(1).is_ok() && check_cells(MAX_CELLS).is_ok());
    for bad in [0, MAX_CELLS + 1, 100_000] {
        let e = check_cells(bad).unwrap_err();
        assert!(matches!(e, MorphError::Cells(n) if n == bad), "{e:?}");
        assert!(e.to_string().contains("--cells"), "{e}");
    }
}
