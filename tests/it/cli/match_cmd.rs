//! `trimorph match` from outside: landmarks between an image and a shifted copy, in every
//! format, and clean failures on bad input.

use crate::common;
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

/// Nucleus tracks of the bundled time-lapse: `(frame 0 position, frame k position)` of every
/// track present in both frames.
fn tracks(f0: u32, f1: u32) -> Vec<([f64; 2], [f64; 2])> {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/timelapse/tracks.csv");
    let mut by: std::collections::BTreeMap<u32, std::collections::BTreeMap<u32, [f64; 2]>> =
        Default::default();
    for line in std::fs::read_to_string(p).unwrap().lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        by.entry(v[0] as u32).or_default().insert(v[1] as u32, [v[3], v[2]]);
    }
    by.values().filter_map(|t| Some((*t.get(&f0)?, *t.get(&f1)?))).collect()
}

/// For landmarks between frames f0 and f1: (nuclei with at least one match that agrees with
/// the nucleus's track, matches near a track that disagree with it by more than 8 px).
fn score(lms: &[trimorph::fit::landmarks::Landmark], f0: u32, f1: u32) -> (usize, usize) {
    let t = tracks(f0, f1);
    let (mut nuclei, mut wrong) = (std::collections::BTreeSet::new(), 0);
    for l in lms {
        let d = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        let (k, near) =
            (0..t.len()).map(|k| (k, d(t[k].0, l.src))).min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        if near > 25.0 {
            continue;
        }
        let track = [t[k].1[0] - t[k].0[0], t[k].1[1] - t[k].0[1]];
        let moved = [l.dst[0] - l.src[0], l.dst[1] - l.src[1]];
        if d(track, moved) <= 8.0 {
            nuclei.insert(k);
        } else {
            wrong += 1;
        }
    }
    (nuclei.len(), wrong)
}

/// Issue 23: on nuclei that move independently, one global affine model keeps the matches
/// of a few nuclei only; `--model local` keeps matches on most of them, and each agrees with
/// the hand-made track of its nucleus.
#[test]
fn match_local_keeps_independently_moving_nuclei() {
    let dir = tempfile::tempdir().unwrap();
    let frame = |k: u32| {
        format!("{}/data/microscopy/timelapse/frame_{k:02}.png", env!("CARGO_MANIFEST_DIR"))
    };
    for (f1, more) in [(3u32, 3usize), (9, 2)] {
        let mut found = vec![];
        for model in ["affine", "local"] {
            let out = dir.path().join(format!("{model}_{f1}.csv"));
            let o = trimorph(&["match", &frame(0), &frame(f1), "-o", s(&out), "--model", model]);
            ok(&o);
            let stdout = String::from_utf8_lossy(&o.stdout);
            let lms = parse(&std::fs::read_to_string(&out).unwrap(), LandmarkFormat::Csv).unwrap();
            let (nuclei, wrong) = score(&lms, 0, f1);
            assert!(wrong <= lms.len() / 20, "{model} 0->{f1}: {wrong} of {} wrong", lms.len());
            if model == "local" {
                assert!(stdout.contains("local model,") && stdout.contains("group"), "{stdout}");
                assert!(!stdout.contains("affine"), "{stdout}");
            }
            found.push((lms.len(), nuclei));
        }
        let ((na, ka), (nl, kl)) = (found[0], found[1]);
        assert!(nl > na && kl >= ka + more, "0->{f1}: affine {na} on {ka}, local {nl} on {kl}");
    }
}

#[test]
fn match_models_and_their_options() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.png");
    cell().save(&a).unwrap();
    let b = dir.path().join("b.png");
    shifted(&cell(), 7, -4).save(&b).unwrap();
    let out = dir.path().join("h.csv");
    let o = trimorph(&["match", s(&a), s(&b), "-o", s(&out), "--model", "homography"]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("homography ["));
    let lms = parse(&std::fs::read_to_string(&out).unwrap(), LandmarkFormat::Csv).unwrap();
    assert!(
        lms.len() >= 20
            && lms
                .iter()
                .all(|l| { (l.dst[0] - l.src[0] - 7.0).hypot(l.dst[1] - l.src[1] + 4.0) <= 1.5 })
    );
    std::fs::write(&out, "old").unwrap();
    for (extra, msg) in [
        (vec!["--model", "local", "--min-support", "3"], "min_support 3"),
        (vec!["--model", "local", "--neighbours", "2"], "neighbours 2"),
    ] {
        let mut args = vec!["match", s(&a), s(&b), "-o", s(&out)];
        args.extend(extra);
        let o = trimorph(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains(msg) && stderr.contains("a.png"), "{stderr}");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "old");
    }
    let o = trimorph(&["match", s(&a), s(&b), "-o", s(&out), "--model", "spline"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("affine, homography, local"));
}
