//! `trimorph match` from outside: landmarks between an image and a shifted copy, in every
//! format, and clean failures on bad input.

mod common;
use common::*;
use image::GrayImage;
use trimorph::fit::landmarks::{parse, LandmarkFormat};

fn cell() -> GrayImage {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/cell.png");
    image::open(p).unwrap().to_luma8()
}

/// `out(x, y) = img(x - dx, y - dy)`, 0 outside.
fn shifted(img: &GrayImage, dx: i64, dy: i64) -> GrayImage {
    let (w, h) = img.dimensions();
    GrayImage::from_fn(w, h, |x, y| {
        let (sx, sy) = (x as i64 - dx, y as i64 - dy);
        if sx < 0 || sy < 0 || sx >= w as i64 || sy >= h as i64 {
            image::Luma([0])
        } else {
            *img.get_pixel(sx as u32, sy as u32)
        }
    })
}

#[test]
fn match_finds_the_shift_in_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.png");
    cell().save(&a).unwrap();
    // B as a 16-bit TIFF: converted to 8-bit gray by its maximum.
    let b8 = shifted(&cell(), -5, 8);
    let b16 = image::ImageBuffer::from_fn(b8.width(), b8.height(), |x, y| {
        image::Luma([b8.get_pixel(x, y)[0] as u16 * 40])
    });
    let b = dir.path().join("b.tif");
    b16.save(&b).unwrap();
    for (file, fmt, f) in [
        ("l.csv", "csv", LandmarkFormat::Csv),
        ("bw.csv", "bigwarp", LandmarkFormat::BigWarp),
        ("l.json", "json", LandmarkFormat::Json),
    ] {
        let out = dir.path().join(file);
        let o = trimorph(&["match", s(&a), s(&b), "-o", s(&out), "--format", fmt]);
        ok(&o);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.contains("inliers") && stdout.contains("affine"), "{stdout}");
        let text = std::fs::read_to_string(&out).unwrap();
        let ext = if fmt == "json" { "json" } else { "csv" };
        assert_eq!(LandmarkFormat::detect(Some(ext), &text), f);
        let lms = parse(&text, f).unwrap();
        assert!(lms.len() >= 20, "{file}: {} landmarks", lms.len());
        for l in &lms {
            let (dx, dy) = (l.dst[0] - l.src[0], l.dst[1] - l.src[1]);
            assert!((dx + 5.0).hypot(dy - 8.0) <= 1.5, "{file}: {l:?}");
        }
    }
    // Options reach the matcher: a stricter ratio keeps fewer matches.
    let out = dir.path().join("strict.csv");
    let o =
        trimorph(&["match", s(&a), s(&b), "-o", s(&out), "--ratio", "0.5", "--features", "300"]);
    ok(&o);
    let strict = parse(&std::fs::read_to_string(&out).unwrap(), LandmarkFormat::Csv).unwrap();
    let loose = std::fs::read_to_string(dir.path().join("l.csv")).unwrap();
    assert!(strict.len() < parse(&loose, LandmarkFormat::Csv).unwrap().len());
}

#[test]
fn bad_input_exits_1_and_keeps_the_old_output() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.png");
    cell().save(&a).unwrap();
    let out = dir.path().join("l.csv");
    std::fs::write(&out, "old").unwrap();
    let garbage = dir.path().join("garbage.png");
    std::fs::write(&garbage, b"not an image").unwrap();
    let flat = dir.path().join("flat.png");
    GrayImage::from_pixel(200, 200, image::Luma([77])).save(&flat).unwrap();
    let tiny = dir.path().join("tiny.png");
    GrayImage::from_pixel(20, 20, image::Luma([7])).save(&tiny).unwrap();
    let missing = dir.path().join("missing.png");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec![s(&a), s(&missing)], "missing.png"),
        (vec![s(&garbage), s(&a)], "garbage.png"),
        (vec![s(&a), s(&flat)], "no features"),
        (vec![s(&tiny), s(&a)], "at least 64"),
        (vec![s(&a), s(&a), "--format", "xml"], "unknown landmark format"),
    ];
    for (args, msg) in cases {
        let mut full = vec!["match"];
        full.extend(&args);
        full.extend(["-o", s(&out)]);
        let o = trimorph(&full);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(msg), "{args:?}: {stderr}");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "old");
    }
}
