//! `trimorph morph` end to end: outputs, golden frames and refused inputs.
//!
//! Golden frames (`--no-align`): a 128 x 128 crop (x 272.., y 120..) of time-lapse frames 0 and 9 with the
//! three tracks inside it as landmarks, 3 frames. Regenerate after an intended change with
//! `TRIMORPH_REGENERATE_GOLDEN=1 cargo test --test cli_morph` and review the PNGs.
//! Tolerance as in `tests/golden.rs`: every channel within `common::GOLDEN_MAX_DIFF` (2) levels, at most
//! `common::GOLDEN_MAX_OFF` (64) pixels differing at all.

use crate::common;
use common::trimorph;

use image::DynamicImage;
use std::path::{Path, PathBuf};

const CROP: (u32, u32) = (272, 120);

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/microscopy/timelapse").join(name)
}

/// Cropped inputs and shifted landmarks in `dir`.
fn crop_inputs(dir: &Path) -> (String, String, String) {
    let crop = |f: &str, out: &str| {
        let p = dir.join(out);
        image::open(data(f)).unwrap().crop_imm(CROP.0, CROP.1, 128, 128).save(&p).unwrap();
        p.display().to_string()
    };
    let (a, b) = (crop("frame_00.png", "a.png"), crop("frame_09.png", "b.png"));
    let text = std::fs::read_to_string(data("landmarks_00_09.csv")).unwrap();
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if ["track3", "track5", "track10"].contains(&f[0]) {
            let v: Vec<f64> = f[1..5].iter().map(|s| s.parse().unwrap()).collect();
            let (dx, dy) = (f64::from(CROP.0), f64::from(CROP.1));
            csv += &format!("{},{},{},{},{}\n", f[0], v[0] - dx, v[1] - dy, v[2] - dx, v[3] - dy);
        }
    }
    let l = dir.join("l.csv");
    std::fs::write(&l, csv).unwrap();
    (a, b, l.display().to_string())
}

fn compare(name: &str, got: &DynamicImage) {
    common::compare_golden(name, got);
}

#[test]
fn morph_writes_frames_animations_and_sheet_and_matches_golden_frames() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, l) = crop_inputs(dir.path());
    let out = dir.path().join("out");
    let gif = dir.path().join("anim.gif");
    let o = trimorph(&[
        "morph",
        &a,
        &b,
        "--landmarks",
        &l,
        "--frames",
        "3",
        "-o",
        out.to_str().unwrap(),
        "--gif",
        gif.to_str().unwrap(),
        // Raw coordinates: the last frame is B itself (alignment: `real_pair_*` below).
        "--no-align",
        // The golden frames predate the edge modes: the dissolve of edge-clamped samples
        // where neither image has a pixel (the default shows the background there:
        // `tests/morph_real.rs`).
        "--mode",
        "edge",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "contact-sheet.png",
            "frame_000.png",
            "frame_001.png",
            "frame_002.png",
            "morph.apng",
            "phi_ab.json",
            "phi_ba.json"
        ]
    );
    assert!(std::fs::metadata(&gif).unwrap().len() > 0);
    let frames: Vec<DynamicImage> =
        (0..3).map(|k| image::open(out.join(format!("frame_{k:03}.png"))).unwrap()).collect();
    // The end frames are the inputs (preimages within 0.01 px: at most one level).
    for (f, input) in [(&frames[0], &a), (&frames[2], &b)] {
        let want = image::open(input).unwrap().to_luma8();
        let got = f.to_luma8();
        let d = got.pixels().zip(want.pixels()).map(|(x, y)| x.0[0].abs_diff(y.0[0]));
        assert!(d.max().unwrap() <= 1);
    }
    for (k, f) in frames.iter().enumerate() {
        compare(&format!("morph_frame_{k:03}.png"), f);
    }
}

#[test]
fn bad_inputs_exit_1_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, l) = crop_inputs(dir.path());
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let bad_lm = dir.path().join("bad.csv");
    std::fs::write(
        &bad_lm,
        "name,src_x,src_y,dst_x,dst_y\na,1,1,2,2\nb,100,5,300,5\nc,5,90,6,91\n",
    )
    .unwrap();
    let missing = dir.path().join("missing.png");
    let cases: [(Vec<&str>, &str); 5] = [
        (vec![&a, &b, "--landmarks", &l, "--range", "0", "-o", out], "--range"),
        (vec![missing.to_str().unwrap(), &b, "--landmarks", &l, "-o", out], "cannot read image A"),
        (vec![&a, &b, "--landmarks", &l, "--frames", "1", "-o", out], "at least 2"),
        (vec![&a, &b, "--landmarks", bad_lm.to_str().unwrap(), "-o", out], "outside image B"),
        (vec![&a, &b, "--landmarks", &a, "-o", out], "cannot read landmarks"),
    ];
    for (args, msg) in cases {
        let mut full = vec!["morph"];
        full.extend(args);
        let o = trimorph(&full);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{full:?}: {err}");
        assert!(err.contains(msg), "{full:?}: expected `{msg}` in: {err}");
    }
}

/// `morph --range` is parsed by clap (the library's `check_range` limits): a bad value
/// exits 1 with `error: --range: reason` before any image is read, and nothing is written.
#[test]
fn bad_time_ranges_are_refused_by_the_option_parser() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let out = dir.path().join("out");
    for (value, want) in [
        ("0", "error: --range: expected T0,T1 (two numbers), got `0`"),
        ("0,nan", "error: --range: expected T0,T1 (two numbers), got `0,nan`"),
        ("-0.5,101", "error: --range: times must lie within -100..100, got `-0.5,101`"),
    ] {
        let args = ["morph", a, b, "--landmarks", a, "--range", value, "-o", out.to_str().unwrap()];
        let o = trimorph(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{value}: {err}");
        assert!(err.starts_with(want), "{value}: {err}");
        assert!(!out.exists());
    }
}

#[test]
fn preview_path_writes_colour_mesh_frames_starting_at_a() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, l) = crop_inputs(dir.path());
    let out = dir.path().join("out");
    let o = trimorph(&[
        "morph",
        &a,
        &b,
        "--landmarks",
        &l,
        "--frames",
        "4",
        "--preview",
        "1",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.stderr.is_empty(), "--quiet prints nothing");
    let f0 = image::open(out.join("frame_000.png")).unwrap().to_luma8();
    let f3 = image::open(out.join("frame_003.png")).unwrap().to_luma8();
    let want = image::open(&a).unwrap().to_luma8();
    // Inside the outer ring (half covered by the mesh) frame 0 is A.
    for (x, y, p) in f0.enumerate_pixels() {
        if x > 0 && y > 0 && x < 127 && y < 127 {
            assert!(p.0[0].abs_diff(want.get_pixel(x, y).0[0]) <= 1, "({x}, {y})");
        }
    }
    assert_ne!(f0.as_raw(), f3.as_raw());
    assert!(out.join("morph.gif").exists() && out.join("contact-sheet.png").exists());
}

#[test]
fn range_makes_a_caricature() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, l) = crop_inputs(dir.path());
    let run = |range: &str, out: &Path| {
        let o = trimorph(&[
            "morph",
            &a,
            &b,
            "--landmarks",
            &l,
            "--frames",
            "2",
            "--quiet",
            "--no-align",
            "--range",
            range,
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        image::open(out.join("frame_001.png")).unwrap().to_luma8()
    };
    let plain = run("0,1", &dir.path().join("plain"));
    let over = run("0,1.5", &dir.path().join("over"));
    let b = image::open(&b).unwrap().to_luma8();
    assert!(plain.pixels().zip(b.pixels()).all(|(x, y)| x.0[0].abs_diff(y.0[0]) <= 1));
    assert_ne!(over.as_raw(), b.as_raw());
}

#[test]
fn morph_from_a_fitted_deformation_starts_at_a_and_ends_near_b() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, l) = crop_inputs(dir.path());
    let s = |p: &Path| p.display().to_string();
    let mesh = dir.path().join("mesh.json");
    let phi = dir.path().join("phi.json");
    let o = trimorph(&["mesh", "--grid", "4x4", "--size", "127,127", "-o", &s(&mesh)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = trimorph(&["fit", &s(&mesh), "--landmarks", &l, "-o", &s(&phi)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("out");
    let o = trimorph(&[
        "morph",
        &a,
        &b,
        "--phi-ab",
        &s(&phi),
        "--frames",
        "3",
        "--background",
        "255",
        "--cells",
        "4",
        "--no-align",
        "-o",
        &s(&out),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let f0 = image::open(out.join("frame_000.png")).unwrap().to_luma8();
    let f2 = image::open(out.join("frame_002.png")).unwrap().to_luma8();
    let (ia, ib) = (image::open(&a).unwrap().to_luma8(), image::open(&b).unwrap().to_luma8());
    let diff = |x: &image::GrayImage, y: &image::GrayImage| {
        x.as_raw().iter().zip(y.as_raw()).map(|(p, q)| p.abs_diff(*q)).max().unwrap()
    };
    assert!(diff(&f0, &ia) <= 1, "frame 0 differs from A by {}", diff(&f0, &ia));
    assert!(diff(&f2, &ib) <= 1, "last frame differs from B by {}", diff(&f2, &ib));
    assert!(out.join("contact-sheet.png").exists() && out.join("morph.gif").exists());

    // Landmarks and --phi-ab together are refused; --phi-ba needs --phi-ab.
    let o = trimorph(&["morph", &a, &b, "--landmarks", &l, "--phi-ab", &s(&phi), "-o", &s(&out)]);
    assert_eq!(o.status.code(), Some(1), "usage error exits 1, not 2 (unsolvable)");
    let o = trimorph(&["morph", &a, &b, "--phi-ba", &s(&phi), "-o", &s(&out)]);
    assert_eq!(o.status.code(), Some(1), "usage error exits 1, not 2 (unsolvable)");
    let o = trimorph(&["morph", &a, &b, "--phi-ab", &l, "-o", &s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot read deformation"));
}

fn real(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/morph").join(name).display().to_string()
}

/// The real pair (B rotated, scaled, of another size and type): the similarity is printed,
/// `phi_ab.json` / `phi_ba.json` hold exactly the library's maps and are read back by
/// `--phi-ab` / `--phi-ba`, and the frames are 16-bit RGB.
#[test]
fn real_pair_prints_the_similarity_and_writes_deformations_that_read_back() {
    use trimorph::io::deformation;
    use trimorph::morph::{Morph, MorphOptions};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let (a, b, l) = (real("nuclei_a.png"), real("nuclei_b.png"), real("nuclei_landmarks.csv"));
    let o = trimorph(&[
        "morph",
        &a,
        &b,
        "--landmarks",
        &l,
        "--frames",
        "3",
        "-o",
        out.to_str().unwrap(),
    ]);
    common::ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("B aligned to A by the similarity: scale 0.5"), "{err}");
    assert!(err.contains("certified fold-free"), "{err}");
    let f1 = image::open(out.join("frame_001.png")).unwrap();
    assert_eq!(f1.color(), image::ColorType::Rgb16);
    assert_eq!((f1.width(), f1.height()), (184, 184));

    let read =
        |n: &str| deformation::from_str(&std::fs::read_to_string(out.join(n)).unwrap()).unwrap().0;
    let (ab, ba) = (read("phi_ab.json"), read("phi_ba.json"));
    let m = Morph::new(
        &image::open(&a).unwrap(),
        &image::open(&b).unwrap(),
        &trimorph::io::landmarks::read_landmarks(Path::new(&l)).unwrap(),
        &MorphOptions::default(),
    )
    .unwrap();
    assert_eq!(ab.points(), m.phi_ab_raw().unwrap().points(), "phi_ab.json is phi_A->B exactly");
    assert_eq!(ba.points(), m.phi_ba().points(), "phi_ba.json is phi_B->A exactly");

    let out2 = dir.path().join("out2");
    let (pa, pb) = (out.join("phi_ab.json"), out.join("phi_ba.json"));
    let o = trimorph(&[
        "morph",
        &a,
        &b,
        "--phi-ab",
        pa.to_str().unwrap(),
        "--phi-ba",
        pb.to_str().unwrap(),
        "--frames",
        "3",
        "-o",
        out2.to_str().unwrap(),
    ]);
    common::ok(&o);
    let err2 = String::from_utf8_lossy(&o.stderr);
    assert!(err2.contains("similarity read from") && err2.contains("morph_similarity"), "{err2}");
    // phi_ab.json keeps the similarity exactly: the same morph, the same files.
    let line = |e: &str| e.lines().find(|l| l.starts_with("B aligned")).unwrap().to_string();
    assert_eq!(line(&err2), line(&err));
    for k in 0..3 {
        let n = format!("frame_{k:03}.png");
        assert!(
            std::fs::read(out.join(&n)).unwrap() == std::fs::read(out2.join(&n)).unwrap(),
            "{n}"
        );
    }

    // Without the key (a deformation from elsewhere), the similarity is re-estimated from
    // phi_ab's samples: close to, not equal to, the landmarks' one.
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&pa).unwrap()).unwrap();
    doc.as_object_mut().unwrap().remove("morph_similarity").unwrap();
    let plain = dir.path().join("plain.json");
    std::fs::write(&plain, doc.to_string()).unwrap();
    let out3 = dir.path().join("out3");
    let run3 = |phi: &Path, to: &Path| {
        trimorph(&[
            "morph",
            &a,
            &b,
            "--phi-ab",
            phi.to_str().unwrap(),
            "--phi-ba",
            pb.to_str().unwrap(),
            "--frames",
            "3",
            "-o",
            to.to_str().unwrap(),
        ])
    };
    let o = run3(&plain, &out3);
    common::ok(&o);
    let err3 = String::from_utf8_lossy(&o.stderr);
    assert!(err3.contains("B aligned to A by the similarity: scale 0.5"), "{err3}");
    assert!(!err3.contains("similarity read from"), "{err3}");
    let diff = |x: &DynamicImage, y: &DynamicImage| {
        let (x, y) = (x.to_rgb8(), y.to_rgb8());
        x.as_raw().iter().zip(y.as_raw()).filter(|(p, q)| p.abs_diff(**q) > 2).count()
    };
    let open = |d: &Path, k: usize| image::open(d.join(format!("frame_{k:03}.png"))).unwrap();
    assert_eq!(diff(&open(&out3, 0), &open(&out, 0)), 0, "frame 0 is A in both runs");
    assert!(diff(&open(&out3, 2), &open(&out, 2)) > 0);

    // A malformed stored similarity is refused, naming the file and the key.
    doc["morph_similarity"] = serde_json::json!({"a": "1/0", "b": "0", "tx": "0", "ty": "0"});
    std::fs::write(&plain, doc.to_string()).unwrap();
    let o = run3(&plain, &dir.path().join("out4"));
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("plain.json") && e.contains("morph_similarity") && e.contains("\"a\""),
        "{e}"
    );
}

#[test]
fn no_align_keeps_raw_coordinates_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let (a, b, l) = (real("nuclei_a.png"), real("nuclei_b.png"), real("nuclei_landmarks.csv"));
    let o = trimorph(&[
        "morph",
        &a,
        &b,
        "--landmarks",
        &l,
        "--frames",
        "2",
        "--no-align",
        "-o",
        out.to_str().unwrap(),
    ]);
    common::ok(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("raw pixel coordinates (--no-align)"));
    // The last frame is B's top-left 184 x 184 corner (phi_B->1 is the identity).
    let last = image::open(out.join("frame_001.png")).unwrap().to_luma16();
    let bi = image::open(&b).unwrap().to_luma16();
    let d = (0..184).flat_map(|y| (0..184).map(move |x| (x, y)));
    let worst =
        d.map(|(x, y)| last.get_pixel(x, y)[0].abs_diff(bi.get_pixel(x, y)[0])).max().unwrap();
    assert!(worst <= 257, "{worst}");
}

/// Issue 52: `morph --landmarks-src A.pts --landmarks-dst B.txt` (iBUG `.pts`, 1-based, and an
/// ITK point set) makes the same fits as the equivalent landmark CSV: the same `phi_ab.json`
/// and `phi_ba.json`, byte for byte.
#[test]
fn a_point_file_pair_morphs_as_the_equivalent_landmark_csv() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (a, b) = (real("nuclei_a.png"), real("nuclei_b.png"));
    // The real landmarks on a grid of 1/16 px, so that the .pts shift by 1 is exact.
    let text = std::fs::read_to_string(real("nuclei_landmarks.csv")).unwrap();
    let q = |v: &str| (v.parse::<f64>().unwrap() * 16.0).round() / 16.0;
    let (mut csv, mut pts, mut itk) =
        (String::from("name,src_x,src_y,dst_x,dst_y\n"), String::new(), String::new());
    let mut n = 0;
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let v = [q(f[1]), q(f[2]), q(f[3]), q(f[4])];
        csv += &format!(",{},{},{},{}\n", v[0], v[1], v[2], v[3]);
        pts += &format!("{} {}\n", v[0] + 1.0, v[1] + 1.0);
        itk += &format!("{} {}\n", v[2], v[3]);
        n += 1;
    }
    let (l, src, dst) = (p("l.csv"), p("a.pts"), p("b.txt"));
    std::fs::write(&l, csv).unwrap();
    std::fs::write(&src, format!("version: 1\nn_points: {n}\n{{\n{pts}}}\n")).unwrap();
    std::fs::write(&dst, format!("index\n{n}\n{itk}")).unwrap();
    let morph = |landmarks: &[&str], out: &str| {
        let out = p(out);
        let args = ["morph", &a, &b, "--frames", "2", "--quiet", "-o", &out];
        common::ok(&trimorph(&[&args[..], landmarks].concat()));
        let read = |f: &str| std::fs::read_to_string(Path::new(&out).join(f)).unwrap();
        (read("phi_ab.json"), read("phi_ba.json"))
    };
    let want = morph(&["--landmarks", &l], "csv");
    let got = morph(&["--landmarks-src", &src, "--landmarks-dst", &dst], "pair");
    assert!(got == want, "the pair's fits differ from the CSV's");
    // The pair excludes --landmarks and --phi-ab, and needs both files.
    let out = p("refused");
    for extra in [
        vec!["--landmarks-src", &src, "--landmarks-dst", &dst, "--landmarks", &l],
        vec!["--landmarks-src", &src, "--landmarks-dst", &dst, "--phi-ab", &l],
        vec!["--landmarks-src", &src],
    ] {
        let o = trimorph(&[&["morph", &a, &b, "-o", &out][..], &extra].concat());
        assert_eq!(o.status.code(), Some(1), "{extra:?}");
        assert!(!Path::new(&out).exists(), "{extra:?}");
    }
}

fn face(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/faces").join(name).display().to_string()
}

/// The portraits of `data/faces` with their iBUG `.pts` files: by default both fits meet
/// every landmark (printed residuals 0.0xx px, no warning); `--bend` smooths and then the
/// missed landmarks are named in a warning; `--hard --pin-frame` meets them exactly with the
/// border pinned.
#[test]
fn faces_morph_meets_its_landmarks_and_names_the_ones_it_misses() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| {
        let out = dir.path().join(format!("out{}", extra.len()));
        let (a, b, la, lb) =
            (face("takeo.png"), face("einstein.jpg"), face("takeo.pts"), face("einstein.pts"));
        let mut args = vec!["morph", &a, &b, "--landmarks-src", &la, "--landmarks-dst", &lb];
        args.extend(["--frames", "2", "-o", out.to_str().unwrap()]);
        args.extend(extra);
        let o = trimorph(&args);
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let residuals = |err: &str| -> Vec<f64> {
        err.lines()
            .filter(|l| l.starts_with("fit "))
            .map(|l| {
                let t = l.split("largest residual ").nth(1).unwrap();
                t.split(' ').next().unwrap().parse().unwrap()
            })
            .collect()
    };
    let plain = run(&[]);
    assert!(residuals(&plain).iter().all(|&r| r <= 0.1), "{plain}");
    assert!(!plain.contains("warning"), "{plain}");
    let smooth = run(&["--bend", "1e-6"]);
    assert!(smooth.contains("landmark(s) missed by more than 0.1 px: #"), "{smooth}");
    assert!(residuals(&smooth).iter().any(|&r| r > 1.0), "{smooth}");
    let hard = run(&["--hard", "--pin-frame", "--bend", "1e-11"]);
    assert_eq!(residuals(&hard), [0.0, 0.0], "{hard}");
    assert!(!hard.contains("warning"), "{hard}");
}

/// Issue 54: `--gif NEW/x.gif` failed (after the fits) when `NEW` did not exist, though the
/// morph makes its `-o` folder. The folders of `--gif` and `--apng` are made now, and a
/// morph that fails removes them again.
#[test]
fn gif_and_apng_folders_are_made_and_removed_again_on_failure() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, lms) = crop_inputs(dir.path());
    let d = |n: &str| dir.path().join(n).display().to_string();
    let o = trimorph(&[
        "morph",
        &a,
        &b,
        "--landmarks",
        &lms,
        "--frames",
        "3",
        "-o",
        &d("m"),
        "--gif",
        &d("new/sub/x.gif"),
        "--apng",
        &d("other/x.apng"),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        dir.path().join("new/sub/x.gif").is_file() && dir.path().join("other/x.apng").is_file()
    );
    // The --apng folder cannot be made (a file is in the way) after the --gif folders
    // were: nothing of them is left.
    let blocked = format!("{a}/x.apng");
    let o = trimorph(&[
        "morph",
        &a,
        &b,
        "--landmarks",
        &lms,
        "--frames",
        "3",
        "-o",
        &d("m2"),
        "--gif",
        &d("gone/sub/x.gif"),
        "--apng",
        &blocked,
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!dir.path().join("gone").exists() && !dir.path().join("m2").exists());
}
