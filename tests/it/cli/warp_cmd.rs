//! `trimorph warp` from outside: images keep size, type and bit depth; points go both ways.

use crate::common;
use common::*;

#[test]
fn identity_warp_keeps_16_bit_tiff_and_points_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "3x3", "--size", "47,31", "-o", s(&id)]));
    let img: image::ImageBuffer<image::Luma<u16>, Vec<u16>> =
        image::ImageBuffer::from_fn(48, 32, |x, y| image::Luma([(x * 1000 + y * 17) as u16]));
    let inp = dir.path().join("in.tif");
    img.save(&inp).unwrap();
    let out = dir.path().join("out.tif");
    ok(&trimorph(&["warp", s(&id), "--image", s(&inp), "-o", s(&out)]));
    let back = image::open(&out).unwrap();
    assert_eq!(back.color(), image::ColorType::L16);
    assert_eq!(back.to_luma16(), img);

    // Edit, then warp points forward and back.
    let script = dir.path().join("e.json");
    std::fs::write(
        &script,
        r#"[{"anchors": {"near": [[15.67, 10.33]]}, "op": "translate", "by": [2, 1]}]"#,
    )
    .unwrap();
    let ed = dir.path().join("ed.json");
    ok(&trimorph(&["edit", s(&id), "--script", s(&script), "-o", s(&ed)]));
    let pts = dir.path().join("p.csv");
    std::fs::write(&pts, "x,y\n15.67,10.33\n30,20\n-3,4\n").unwrap();
    let q = dir.path().join("q.csv");
    ok(&trimorph(&["warp", s(&ed), "--points", s(&pts), "-o", s(&q)]));
    let qt = std::fs::read_to_string(&q).unwrap();
    assert_eq!(qt.lines().count(), 4);
    assert!(qt.lines().last().unwrap() == ",", "outside point written empty: {qt}");
    let b = dir.path().join("b.csv");
    ok(&trimorph(&["warp", s(&ed), "--points", s(&q), "--inverse", "-o", s(&b)]));
    let rows: Vec<Vec<f64>> = std::fs::read_to_string(&b)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| *l != ",")
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert!((rows[0][0] - 15.67).abs() < 0.01 && (rows[0][1] - 10.33).abs() < 0.01, "{rows:?}");
    assert!((rows[1][0] - 30.0).abs() < 0.01 && (rows[1][1] - 20.0).abs() < 0.01);
}

#[test]
fn bad_warp_inputs_exit_1_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "20,20", "-o", s(&id)]));
    let txt = dir.path().join("not_an_image.png");
    std::fs::write(&txt, "hello").unwrap();
    let out = dir.path().join("o.png");
    for args in [
        vec!["warp", s(&id), "--image", s(&txt), "-o", s(&out)],
        vec!["warp", s(&id), "-o", s(&out)],
        vec!["warp", s(&id), "--image", s(&txt), "--interp", "sinc", "-o", s(&out)],
    ] {
        let r = trimorph(&args);
        assert_eq!(r.status.code(), Some(1), "{args:?}");
        assert!(!out.exists());
    }
}

#[test]
fn field_and_jacobian_maps() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "20,10", "-o", s(&id)]));
    let npy = dir.path().join("f.npy");
    let jac = dir.path().join("j.png");
    let o = trimorph(&["field", s(&id), "-o", s(&npy), "--jacobian", s(&jac)]);
    ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    // The grid records the 20 x 10 frame: the field covers its pixels, not the 21 x 11
    // pixel centres of the mesh's extent.
    assert!(text.contains("0 of 200 samples fold"), "{text}");
    let b = std::fs::read(&npy).unwrap();
    assert_eq!(&b[..6], b"\x93NUMPY");
    let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
    assert!(std::str::from_utf8(&b[10..10 + hl]).unwrap().contains("(10, 20, 2)"));
    // The identity has zero displacement everywhere (up to f64 evaluation rounding).
    assert!(b[10 + hl..]
        .chunks(4)
        .all(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]).abs() < 1e-9));
    let j = image::open(&jac).unwrap().to_rgba8();
    assert_eq!(j.get_pixel(5, 5).0, [255, 255, 255, 255], "det J = 1 is white");
    let tif = dir.path().join("f.tif");
    ok(&trimorph(&["field", s(&id), "--inverse", "-o", s(&tif), "--size", "25,12"]));
    let t = image::open(&tif).unwrap();
    assert_eq!((t.width(), t.height(), t.color()), (25, 12, image::ColorType::Rgb32F));
    let px = t.to_rgb32f();
    let v = px.get_pixel(3, 3).0;
    assert!(v[0].abs() < 1e-9 && v[1].abs() < 1e-9 && v[2] == 1.0, "{v:?}");
    assert_eq!(px.get_pixel(24, 11).0[2], 0.0, "outside the mesh is marked invalid");
    let bad = trimorph(&["field", s(&id), "-o", s(&dir.path().join("f.txt"))]);
    assert_eq!(bad.status.code(), Some(1));
}

/// Bug found in review: `field --jacobian J.tif` wrote PNG bytes into a `.tif` file, and a bad
/// Jacobian name was noticed only after the field was written. Both names are checked first.
#[test]
fn field_checks_both_output_names_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "20,20", "-o", s(&id)]));
    let npy = dir.path().join("f.npy");
    let jac = dir.path().join("j.tif");
    let o = trimorph(&["field", s(&id), "-o", s(&npy), "--jacobian", s(&jac)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("name it .png"));
    assert!(!npy.exists() && !jac.exists(), "nothing written");
}

/// A deformation file whose map is `phi(p) = A p + b` with integer `A` and `b` (C1 and
/// exact), on a `cols x rows` grid over `[0, w] x [0, h]`.
fn affine_file(
    dir: &std::path::Path,
    name: &str,
    w: f64,
    h: f64,
    a: [[i64; 2]; 2],
    b: [i64; 2],
) -> std::path::PathBuf {
    use trimorph::exact::{rat_int, Rat};
    let mesh =
        trimorph::mesh::Mesh::grid(3, 3, w, h, trimorph::mesh::MeshOptions::default()).unwrap();
    let id = trimorph::spline::Spline::identity(mesh.clone(), 5).unwrap();
    let pts: Vec<Vec<Rat>> = id
        .points()
        .iter()
        .map(|p| {
            (0..2)
                .map(|r| &p[0] * rat_int(a[r][0]) + &p[1] * rat_int(a[r][1]) + rat_int(b[r]))
                .collect()
        })
        .collect();
    let s = trimorph::spline::Spline::from_points(mesh, 5, pts, None).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, trimorph::io::deformation::to_string(&s, None)).unwrap();
    path
}

#[test]
fn every_page_of_a_tiff_stack_is_warped_the_same_way() {
    let dir = tempfile::tempdir().unwrap();
    let def = affine_file(dir.path(), "shift.json", 39.0, 29.0, [[1, 0], [0, 1]], [3, 2]);
    let pages: Vec<image::ImageBuffer<image::Luma<u16>, Vec<u16>>> = (0..3)
        .map(|k| {
            image::ImageBuffer::from_fn(40, 30, |x, y| {
                image::Luma([(x * 1000 + y * 17 + k * 7) as u16])
            })
        })
        .collect();
    let stack = trimorph::io::raster::Stack {
        pages: pages.iter().cloned().map(image::DynamicImage::ImageLuma16).collect(),
        gray_float: false,
    };
    let inp = dir.path().join("stack.tif");
    trimorph::io::raster::write_stack(&inp, &stack).unwrap();
    let out = dir.path().join("out.tif");
    let o = trimorph(&["warp", s(&def), "--image", s(&inp), "-o", s(&out), "--background", "9"]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("3 pages"));
    let back = trimorph::io::raster::read_stack(&out).unwrap();
    assert_eq!(back.pages.len(), 3);
    for (k, (page, src)) in back.pages.iter().zip(&pages).enumerate() {
        let g = page.as_luma16().expect("16-bit gray kept");
        for (x, y, v) in g.enumerate_pixels() {
            let expect = if x >= 3 && y >= 2 { src.get_pixel(x - 3, y - 2)[0] } else { 9 };
            assert_eq!(v[0], expect, "page {k} at ({x}, {y})");
        }
    }
    // A stack cannot be written to a PNG: exit 1, nothing written.
    let png = dir.path().join("out.png");
    let r = trimorph(&["warp", s(&def), "--image", s(&inp), "-o", s(&png)]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("only TIFF"));
    assert!(!png.exists());
}

#[test]
fn jpeg_input_and_identity_keep_every_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let def = affine_file(dir.path(), "id.json", 31.0, 23.0, [[1, 0], [0, 1]], [0, 0]);
    let img =
        image::RgbImage::from_fn(32, 24, |x, y| image::Rgb([(x * 8) as u8, (y * 10) as u8, 128]));
    let jpg = dir.path().join("in.jpg");
    img.save(&jpg).unwrap();
    let decoded = image::open(&jpg).unwrap().to_rgb8();
    for interp in ["nearest", "bilinear", "bicubic"] {
        let out = dir.path().join(format!("out_{interp}.png"));
        ok(&trimorph(&["warp", s(&def), "--image", s(&jpg), "--interp", interp, "-o", s(&out)]));
        let back = image::open(&out).unwrap();
        assert_eq!(back.color(), image::ColorType::Rgb8);
        assert_eq!(back.to_rgb8(), decoded, "{interp}");
    }
}

#[test]
fn folds_are_reported_by_warp() {
    let dir = tempfile::tempdir().unwrap();
    // A mirror: phi(x, y) = (39 - x, y) reverses orientation everywhere (det J = -1).
    let def = affine_file(dir.path(), "mirror.json", 39.0, 29.0, [[-1, 0], [0, 1]], [39, 0]);
    let img = image::GrayImage::from_fn(40, 30, |x, y| image::Luma([(x * 6 + y) as u8]));
    let inp = dir.path().join("in.png");
    img.save(&inp).unwrap();
    let out = dir.path().join("out.png");
    let o = trimorph(&["warp", s(&def), "--image", s(&inp), "--interp", "nearest", "-o", s(&out)]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("phi folds over the output: 1200 pixels"), "{err}");
    // The mirror is still injective, so the picture is the mirrored input.
    let back = image::open(&out).unwrap().to_luma8();
    for (x, y, v) in back.enumerate_pixels() {
        assert_eq!(v[0], img.get_pixel(39 - x, y)[0]);
    }
    // The identity is certified fold-free.
    let id = affine_file(dir.path(), "id.json", 39.0, 29.0, [[1, 0], [0, 1]], [0, 0]);
    let o = trimorph(&["warp", s(&id), "--image", s(&inp), "-o", s(&out)]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("folds: none"));
}

#[test]
fn colored_meshes_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbaImage::from_fn(40, 30, |x, y| {
        image::Rgba([(x * 6) as u8, (y * 8) as u8, 77, 255])
    });
    let inp = dir.path().join("in.png");
    img.save(&inp).unwrap();
    let ply = dir.path().join("m.ply");
    ok(&trimorph(&["colormesh", s(&inp), "-o", s(&ply), "--step", "1"]));
    // Shift by (3, 2): the picture moves by exactly (3, 2) at fully covered pixels.
    let def = affine_file(dir.path(), "shift.json", 39.0, 29.0, [[1, 0], [0, 1]], [3, 2]);
    let png = dir.path().join("m.png");
    ok(&trimorph(&["warp", s(&def), "--mesh", s(&ply), "-o", s(&png), "--size", "44,33"]));
    let pic = image::open(&png).unwrap().to_rgba8();
    assert_eq!(pic.dimensions(), (44, 33));
    for y in 3..31 {
        for x in 4..42 {
            assert_eq!(pic.get_pixel(x, y).0, img.get_pixel(x - 3, y - 2).0, "({x}, {y})");
        }
    }
    assert_eq!(pic.get_pixel(0, 0).0[3], 0, "transparent where nothing is drawn");
    // The moved mesh can be saved too, and read back.
    let obj = dir.path().join("moved.obj");
    ok(&trimorph(&["warp", s(&def), "--mesh", s(&ply), "-o", s(&obj)]));
    let moved = trimorph::io::colormesh::load(&obj).unwrap();
    let (lo, _) = moved.vertices.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(l, h), v| {
        ([l[0].min(v[0]), l[1].min(v[1])], [h[0].max(v[0]), h[1].max(v[1])])
    });
    assert!((lo[0] - 3.0).abs() < 1e-6 && (lo[1] - 2.0).abs() < 1e-6, "{lo:?}");
    // Wrong output kind: exit 1.
    let bad = trimorph(&["warp", s(&def), "--mesh", s(&ply), "-o", s(&dir.path().join("m.txt"))]);
    assert_eq!(bad.status.code(), Some(1));
}

/// A Netpbm file by hand: `magic`, size, maxval and big-endian samples.
fn netpbm(magic: &str, w: u32, h: u32, maxval: u32, samples: &[u16]) -> Vec<u8> {
    let mut b = format!("{magic}\n# by hand\n{w} {h}\n{maxval}\n").into_bytes();
    for &v in samples {
        if maxval > 255 {
            b.extend(v.to_be_bytes());
        } else {
            b.push(v as u8);
        }
    }
    b
}

/// PNM (PGM, PPM) images are read wherever images are, and written when the output is named
/// `.pgm` / `.ppm`: a warp of a PNM equals the warp of the same pixels as PNG, and the output
/// is a real P5 / P6 file. Before, `.pgm` and `.ppm` were refused as unknown formats.
#[test]
fn pnm_images_warp_like_the_same_pixels_as_png() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let id = d.join("id.json");
    ok(&trimorph(&["mesh", "--grid", "3x3", "--size", "39,29", "-o", s(&id)]));
    let script = d.join("e.json");
    std::fs::write(
        &script,
        r#"[{"anchors": {"near": [[13, 9.67]]}, "op": "translate", "by": [2, 1]}]"#,
    )
    .unwrap();
    let ed = d.join("ed.json");
    ok(&trimorph(&["edit", s(&id), "--script", s(&script), "-o", s(&ed)]));
    let (w, h) = (40u32, 30u32);
    let gray: Vec<u16> = (0..w * h).map(|i| ((i * 7) % 251) as u16).collect();
    let gray16: Vec<u16> = (0..w * h).map(|i| (i * 53) as u16).collect();
    let rgb: Vec<u16> = (0..w * h * 3).map(|i| ((i * 11) % 256) as u16).collect();
    let cases: [(&str, &str, u32, &[u16], &str); 3] = [
        ("g.pgm", "P5", 255, &gray, "P5"),
        ("g16.pgm", "P5", 65535, &gray16, "P5"),
        ("c.ppm", "P6", 255, &rgb, "P6"),
    ];
    for (name, magic, maxval, samples, out_magic) in cases {
        let pnm = d.join(name);
        std::fs::write(&pnm, netpbm(magic, w, h, maxval, samples)).unwrap();
        let img = image::open(&pnm).unwrap();
        let png = d.join(format!("{name}.png"));
        img.save(&png).unwrap();
        let (out_pnm, out_png) = (d.join(format!("w.{name}")), d.join(format!("w.{name}.png")));
        ok(&trimorph(&["warp", s(&ed), "--image", s(&pnm), "-o", s(&out_pnm)]));
        ok(&trimorph(&["warp", s(&ed), "--image", s(&png), "-o", s(&out_png)]));
        let bytes = std::fs::read(&out_pnm).unwrap();
        assert!(bytes.starts_with(out_magic.as_bytes()), "{name}: not {out_magic}");
        let (a, b) = (image::open(&out_pnm).unwrap(), image::open(&out_png).unwrap());
        assert_eq!(a.color(), img.color(), "{name}: type kept");
        assert_eq!(a.as_bytes(), b.as_bytes(), "{name}: PNM and PNG warps differ");
        assert_ne!(a.as_bytes(), img.as_bytes(), "{name}: the warp moved nothing");
        // Round trip: the identity warp of the written file gives its pixels back.
        let again = d.join(format!("again.{name}"));
        ok(&trimorph(&["warp", s(&id), "--image", s(&out_pnm), "-o", s(&again)]));
        assert_eq!(std::fs::read(&again).unwrap(), bytes, "{name}: round trip");
    }
    // The other readers: a PPM background, PGM frames of a folder, PGM morph inputs.
    let r = d.join("r.png");
    ok(&trimorph(&["render", s(&ed), "--background", s(&d.join("c.ppm")), "-o", s(&r)]));
    assert_eq!(image::open(&r).unwrap().width(), w);
    let frames = d.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..2 {
        std::fs::copy(d.join("g.pgm"), frames.join(format!("f{k}.pgm"))).unwrap();
    }
    let lms = d.join("l.csv");
    std::fs::write(
        &lms,
        "name,src_x,src_y,dst_x,dst_y\na,10,10,10,10\nb,30,10,30,10\nc,20,20,20,20\n",
    )
    .unwrap();
    let fit_out = d.join("fit");
    let o = trimorph(&[
        "fit",
        "--model",
        s(&ed),
        "--frames",
        s(&frames),
        "--landmarks",
        s(&lms),
        "-o",
        s(&fit_out),
    ]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("2 frames fitted"));
    let m = d.join("m");
    let pgm = d.join("g.pgm");
    ok(&trimorph(&[
        "morph",
        s(&pgm),
        s(&pgm),
        "--landmarks",
        s(&lms),
        "--frames",
        "2",
        "-o",
        s(&m),
    ]));
    assert!(m.join("frame_001.png").exists());
}

/// The Jacobian map has a colour bar below it: the map's pixels stay where they were (the top
/// `w x h`, transparent beside it), and the strip shows the fold red, the ramp from det J 1/4
/// (blue) through 1 (white) to 4 (orange), and dark tick labels.
#[test]
fn jacobian_map_has_a_colour_bar_below() {
    use trimorph::warp::field::det_color;
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "20,10", "-o", s(&id)]));
    let (npy, jac) = (dir.path().join("f.npy"), dir.path().join("j.png"));
    let o = trimorph(&["field", s(&id), "-o", s(&npy), "--jacobian", s(&jac)]);
    ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("map 20x10 with its colour bar below (360x50 in all)"), "{text}");
    let j = image::open(&jac).unwrap().to_rgba8();
    assert_eq!(j.dimensions(), (360, 50));
    for y in 0..10 {
        for x in 0..20 {
            assert_eq!(j.get_pixel(x, y).0, [255, 255, 255, 255], "map pixel ({x}, {y})");
        }
        assert_eq!(j.get_pixel(30, y).0[3], 0, "beside the map");
    }
    let strip: Vec<[u8; 4]> = (10..50)
        .flat_map(|y| (0..360).map(move |x| (x, y)))
        .map(|(x, y)| j.get_pixel(x, y).0)
        .collect();
    for d in [0.0, 0.25, 0.5, 2.0, 4.0] {
        assert!(strip.contains(&det_color(d)), "the bar shows det J {d}");
    }
    let dark = strip.iter().filter(|p| p[0] < 80 && p[1] < 80 && p[2] < 80).count();
    assert!(dark > 60, "tick labels: {dark} dark pixels");
}

/// `warp --points --inverse` on a real fit: `phi(phi^-1(q))` is within 1e-9 px of `q` (Newton
/// polished to machine precision; it was 5.8e-6 px at the acceptance tolerance alone).
#[test]
fn inverse_points_of_a_real_fit_reach_machine_precision() {
    let dir = tempfile::tempdir().unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let lms = root.join("data/microscopy/timelapse/tracks_0_9.csv");
    let fit = dir.path().join("fit.json");
    ok(&trimorph(&["fit", "--size", "511,511", "--landmarks", s(&lms), "-o", s(&fit)]));
    let mut csv = String::from("x,y\n");
    for k in 0..400 {
        let (i, j) = (k % 20, k / 20);
        csv.push_str(&format!("{},{}\n", 13.7 + 24.3 * i as f64, 9.1 + 24.9 * j as f64));
    }
    let q = dir.path().join("q.csv");
    std::fs::write(&q, &csv).unwrap();
    let (p, back) = (dir.path().join("p.csv"), dir.path().join("back.csv"));
    ok(&trimorph(&["warp", s(&fit), "--points", s(&q), "--inverse", "-o", s(&p)]));
    ok(&trimorph(&["warp", s(&fit), "--points", s(&p), "-o", s(&back)]));
    let rows = |path: &std::path::Path| -> Vec<Option<[f64; 2]>> {
        let text = std::fs::read_to_string(path).unwrap();
        text.lines()
            .skip(1)
            .map(|l| {
                let (a, b) = l.split_once(',').unwrap();
                Some([a.parse().ok()?, b.parse().ok()?])
            })
            .collect()
    };
    let (qs, ps, backs) = (rows(&q), rows(&p), rows(&back));
    let (mut worst, mut n) = (0.0f64, 0);
    for ((q, p), b) in qs.iter().zip(&ps).zip(&backs) {
        if p.is_none() {
            continue;
        }
        let (q, b) = (q.unwrap(), b.expect("phi of a preimage is defined"));
        worst = worst.max((b[0] - q[0]).hypot(b[1] - q[1]));
        n += 1;
    }
    assert!(n > 300, "only {n} of 400 points have a preimage");
    assert!(worst <= 1e-9, "max |phi(phi^-1(q)) - q| = {worst:e} px");
}

/// Bug (issue 54): `--background 300`, `-5` or `1e300` on an 8-bit image were clamped
/// silently. A background the image's samples cannot hold is refused, naming the range;
/// nothing is written. The same for the morph's frames.
#[test]
fn a_background_the_samples_cannot_hold_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let id = d.join("id.json");
    ok(&trimorph(&["mesh", "--grid", "3x3", "--size", "40,30", "-o", s(&id)]));
    let (g8, g16, gf) = (d.join("g8.png"), d.join("g16.png"), d.join("gf.tif"));
    image::GrayImage::from_fn(40, 30, |x, y| image::Luma([(x + y) as u8])).save(&g8).unwrap();
    image::ImageBuffer::<image::Luma<u16>, _>::from_fn(40, 30, |x, _| {
        image::Luma([x as u16 * 999])
    })
    .save(&g16)
    .unwrap();
    image::DynamicImage::ImageRgb32F(image::Rgb32FImage::from_fn(40, 30, |x, _| {
        image::Rgb([x as f32 / 40.0, 0.5, -1.0])
    }))
    .save(&gf)
    .unwrap();
    let out = d.join("out.png");
    for (img, bg, range) in [
        (&g8, "300", "0 to 255"),
        (&g8, "-5", "0 to 255"),
        (&g8, "12.5", "0 to 255"),
        (&g8, "1e300", "0 to 255"),
        (&g16, "70000", "0 to 65535"),
    ] {
        let o = trimorph(&[
            "warp",
            s(&id),
            "--image",
            s(img),
            "-o",
            s(&out),
            &format!("--background={bg}"),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{bg}: {err}");
        assert!(err.contains(&format!("--background {bg}:")) && err.contains(range), "{err}");
        assert!(!out.exists());
    }
    ok(&trimorph(&["warp", s(&id), "--image", s(&g8), "-o", s(&out), "--background", "255"]));
    let fo = d.join("out.tif");
    ok(&trimorph(&["warp", s(&id), "--image", s(&gf), "-o", s(&fo), "--background=-3.5"]));
}

/// Bug (issue 54): `-o x.jpg` of a 16-bit, gray+alpha or float image was written as 8-bit
/// without alpha (the summary still said `La16`), and a float image to `.pgm` suggested
/// `.ppm`, `.pam` and `.png`, which all refuse it. Formats that cannot hold the samples are
/// refused, suggesting only formats that can; nothing is written.
#[test]
fn outputs_that_cannot_hold_the_samples_are_refused_with_formats_that_can() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let id = d.join("id.json");
    ok(&trimorph(&["mesh", "--grid", "3x3", "--size", "40,30", "-o", s(&id)]));
    let (g16, la8, gf, rgb) =
        (d.join("g16.png"), d.join("la8.png"), d.join("gf.tif"), d.join("rgb.png"));
    image::ImageBuffer::<image::Luma<u16>, _>::from_fn(40, 30, |x, _| {
        image::Luma([x as u16 * 999])
    })
    .save(&g16)
    .unwrap();
    image::GrayAlphaImage::from_fn(40, 30, |x, y| image::LumaA([x as u8, y as u8]))
        .save(&la8)
        .unwrap();
    image::DynamicImage::ImageRgb32F(image::Rgb32FImage::from_fn(40, 30, |x, _| {
        image::Rgb([x as f32 / 40.0, 0.5, -1.0])
    }))
    .save(&gf)
    .unwrap();
    image::RgbImage::from_fn(40, 30, |x, y| image::Rgb([x as u8, y as u8, 7])).save(&rgb).unwrap();
    for (input, out, want) in [
        (
            &g16,
            "o.jpg",
            "a JPEG holds 8-bit gray or RGB only, not L16 (use .png or .tif, which keeps it)",
        ),
        (&la8, "o.jpeg", "a JPEG holds 8-bit gray or RGB only, not La8 (use .png or .tif"),
        (&gf, "o.jpg", "not Rgb32F (use .tif, which keeps it)"),
        (&gf, "o.png", "a PNG holds 8- or 16-bit samples, not Rgb32F (use .tif)"),
        (&gf, "o.pgm", "a PGM holds 8- or 16-bit gray, not Rgb32F (use .tif)"),
        (&rgb, "o.pgm", "not Rgb8 (use .ppm, .pam, .png or .tif)"),
    ] {
        let o_path = d.join(out);
        let o = trimorph(&["warp", s(&id), "--image", s(input), "-o", s(&o_path)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{out}: {err}");
        assert!(err.contains(want) && err.contains(out), "{out}: {err}");
        assert!(!o_path.exists());
    }
    ok(&trimorph(&["warp", s(&id), "--image", s(&rgb), "-o", s(&d.join("fine.jpg"))]));
}

/// Bug (issue 54): a 16-bit TIFF with 5 samples per pixel (RGB and two extra samples,
/// `tests/data/rgb16_5samples.tif`, written by tifffile) was read as RGB and written back
/// with two channels dropped. It is refused before decoding, naming the sample count.
#[test]
fn a_tiff_with_more_samples_than_its_colour_type_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "8,6", "-o", s(&id)]));
    let out = dir.path().join("o.tif");
    let o = trimorph(&["warp", s(&id), "--image", "tests/data/rgb16_5samples.tif", "-o", s(&out)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("rgb16_5samples.tif, page 0")
            && err.contains("with 5 samples per pixel (2 beyond"),
        "{err}"
    );
    assert!(!out.exists());
}

/// Issue 52: `--mode constant|edge|reflect` (scikit-image's names) decide what samples read
/// outside the input image, inside the mesh. A translation by (-5, -5) over a mesh twice the
/// image's size: output columns 35..39 of a 40 x 30 image have preimages 40..44, past the
/// last column (39). Constant (the default) gives the background there, edge repeats column
/// 39, reflect mirrors about it (40 -> 38, 41 -> 37, ...).
#[test]
fn edge_modes_decide_what_lies_beyond_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (40u32, 30u32);
    let def = affine_file(
        dir.path(),
        "shift.json",
        2.0 * w as f64,
        2.0 * h as f64,
        [[1, 0], [0, 1]],
        [-5, -5],
    );
    let img = image::GrayImage::from_fn(w, h, |x, y| image::Luma([(3 * x + 2 * y + 1) as u8]));
    let input = dir.path().join("in.png");
    img.save(&input).unwrap();
    let run = |mode: Option<&str>| {
        let out = dir.path().join(format!("out_{}.png", mode.unwrap_or("default")));
        let mut args = vec!["warp", def.to_str().unwrap(), "--image", input.to_str().unwrap()];
        args.extend(["--background", "9", "-o", out.to_str().unwrap()]);
        if let Some(m) = mode {
            args.extend(["--mode", m]);
        }
        let o = trimorph(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        image::open(&out).unwrap().to_luma8()
    };
    let v = |x: u32, y: u32| img.get_pixel(x, y).0[0];
    let (default, constant, edge, reflect) =
        (run(None), run(Some("constant")), run(Some("edge")), run(Some("reflect")));
    assert_eq!(default, constant);
    for y in 0..h - 5 {
        for x in 0..w - 5 {
            // Inside: every mode is the shifted image.
            for o in [&constant, &edge, &reflect] {
                assert_eq!(o.get_pixel(x, y).0[0], v(x + 5, y + 5));
            }
        }
        for x in w - 5..w {
            let p = x + 5; // 40..44
            assert_eq!(constant.get_pixel(x, y).0[0], 9, "({x}, {y})");
            assert_eq!(edge.get_pixel(x, y).0[0], v(w - 1, y + 5), "({x}, {y})");
            assert_eq!(reflect.get_pixel(x, y).0[0], v(2 * (w - 1) - p, y + 5), "({x}, {y})");
        }
    }
    let o = trimorph(&[
        "warp",
        def.to_str().unwrap(),
        "--image",
        input.to_str().unwrap(),
        "--mode",
        "wrap",
        "-o",
        "x.png",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("constant, edge or reflect"), "{err}");
}
