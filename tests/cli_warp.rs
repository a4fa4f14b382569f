//! `trimorph warp` from outside: images keep size, type and bit depth; points go both ways.

mod common;
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
    assert!(text.contains("0 of 231 samples fold"), "{text}");
    let b = std::fs::read(&npy).unwrap();
    assert_eq!(&b[..6], b"\x93NUMPY");
    let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
    assert!(std::str::from_utf8(&b[10..10 + hl]).unwrap().contains("(11, 21, 2)"));
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
