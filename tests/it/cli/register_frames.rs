//! `trimorph register --frames DIR --reference FRAME -o OUT` through the binary: a drifting
//! sequence made from the bundled cell image by known warps is registered to its first
//! frame; every frame's deformation recovers its warp, is certified fold-free, and the
//! reference gets the identity. Then resume (a rerun skips, a changed option or a missing
//! output runs again, saying why), shards, the summary report and the refusals.

use crate::common;
use common::{ok, s, trimorph};
use image::{GrayImage, Luma};
use std::fs;
use std::path::Path;

/// The base image: a 180 x 170 crop of the bundled cell image (8-bit).
fn base() -> GrayImage {
    let cell = image::open("data/microscopy/cell.png").unwrap().to_luma8();
    image::imageops::crop_imm(&cell, 170, 220, 180, 170).to_image()
}

/// Frame `k`'s pixels -> the base's (= frame 0's) pixels: a drift of (2.5, -1.5) px per frame
/// and a growing smooth wobble.
fn psi(k: usize, p: [f64; 2]) -> [f64; 2] {
    let k = k as f64;
    [p[0] + 2.5 * k + 0.5 * k * (p[1] / 30.0).sin(), p[1] - 1.5 * k + 0.4 * k * (p[0] / 40.0).cos()]
}

/// Frame `k`: the base through `psi(k)`, bilinear.
fn frame(m: &GrayImage, k: usize) -> GrayImage {
    GrayImage::from_fn(m.width(), m.height(), |x, y| {
        let q = psi(k, [x as f64, y as f64]);
        Luma([crate::common::bilinear(m, q[0], q[1]).round() as u8])
    })
}

fn frames(dir: &Path, n: usize) -> std::path::PathBuf {
    let fd = dir.join("frames");
    fs::create_dir_all(&fd).unwrap();
    let b = base();
    for k in 0..n {
        frame(&b, k).save(fd.join(format!("t{k:02}.png"))).unwrap();
    }
    fd
}

/// The mean distance between `phi(q)` (through `trimorph warp --points`) and `psi(k, q)`
/// over interior probes of frame `k`.
fn endpoint_error(def: &Path, k: usize, tmp: &Path) -> f64 {
    let probes: Vec<[f64; 2]> = (0..5)
        .flat_map(|i| (0..4).map(move |j| [40.0 + 25.0 * i as f64, 40.0 + 25.0 * j as f64]))
        .collect();
    let pts = tmp.join(format!("probes{k}.csv"));
    let mut csv = String::from("x,y\n");
    for p in &probes {
        csv += &format!("{},{}\n", p[0], p[1]);
    }
    fs::write(&pts, csv).unwrap();
    let moved = tmp.join(format!("moved{k}.csv"));
    ok(&trimorph(&["warp", s(def), "--points", s(&pts), "-o", s(&moved)]));
    let text = fs::read_to_string(&moved).unwrap();
    let errs: Vec<f64> = text
        .lines()
        .skip(1)
        .zip(&probes)
        .map(|(line, p)| {
            let v: Vec<f64> = line.split(',').map(|t| t.trim().parse().unwrap()).collect();
            let q = psi(k, *p);
            (v[0] - q[0]).hypot(v[1] - q[1])
        })
        .collect();
    errs.iter().sum::<f64>() / errs.len() as f64
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(p).unwrap()).unwrap()
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn a_drifting_sequence_is_registered_to_its_reference_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fd = frames(d, 4);
    let out = d.join("out");
    let rep = d.join("summary.json");
    let args = |extra: &[&str]| {
        let mut v = vec!["register", "--frames", s(&fd), "--reference", "t00", "-o", s(&out)];
        v.extend_from_slice(&["--spacing", "45", "--report", s(&rep)]);
        v.extend_from_slice(extra);
        v.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run = |extra: &[&str]| {
        let a = args(extra);
        let o = trimorph(&a.iter().map(String::as_str).collect::<Vec<_>>());
        ok(&o);
        o
    };
    let o = run(&[]);
    let text = stdout(&o);
    assert!(text.contains("t00: the reference (identity)"), "{text}");
    assert!(text.contains("t02:") && text.contains("from t01"), "chain warm start: {text}");
    assert!(text.contains("4 registered, 0 skipped"), "{text}");
    // Every frame's files; the reference is the identity and resamples to itself.
    for k in 0..4 {
        for ext in ["json", "registered.png", "overlay.png", "report.json"] {
            assert!(out.join(format!("t{k:02}.{ext}")).is_file(), "t{k:02}.{ext}");
        }
    }
    let r0 = json(&out.join("t00.report.json"));
    assert_eq!(r0["is_reference"], true);
    assert_eq!(r0["fold_free"], true);
    assert!(endpoint_error(&out.join("t00.json"), 0, d) < 1e-9);
    let same = image::open(out.join("t00.registered.png")).unwrap().to_luma8();
    let orig = image::open(fd.join("t00.png")).unwrap().to_luma8();
    assert_eq!(same.dimensions(), orig.dimensions());
    let worst = same.pixels().zip(orig.pixels()).map(|(a, b)| a.0[0].abs_diff(b.0[0])).max();
    assert!(worst.unwrap() <= 1, "the reference resamples to itself");
    // Frames 1-3 recover their known warps, certified fold-free.
    for k in 1..4 {
        let r = json(&out.join(format!("t{k:02}.report.json")));
        assert_eq!(r["fold_free"], true, "t{k:02}");
        assert_eq!(r["reference"], "t00");
        assert_eq!(r["is_reference"], false);
        assert!(r["metric_after"].as_f64().unwrap() < r["metric_before"].as_f64().unwrap());
        assert!(r["resume"]["frame_pixels"].is_string());
        let e = endpoint_error(&out.join(format!("t{k:02}.json")), k, d);
        assert!(e < 0.5, "t{k:02}: mean endpoint error {e} px");
    }
    assert_eq!(json(&out.join("t03.report.json"))["warm_start"], "t02");
    assert_eq!(json(&out.join("t01.report.json"))["warm_start"], serde_json::Value::Null);
    let sum = json(&rep);
    assert_eq!(sum["registered"], 4);
    assert_eq!(sum["entries"].as_array().unwrap().len(), 4);
    assert_eq!(sum["not_fold_free"], serde_json::json!([]));
    let before = fs::read(out.join("t02.json")).unwrap();

    // A rerun skips every frame and leaves the files as they were.
    let text = stdout(&run(&[]));
    assert!(text.contains("0 registered, 4 skipped"), "{text}");
    assert_eq!(fs::read(out.join("t02.json")).unwrap(), before);
    // A missing output runs its frame again, saying which.
    fs::remove_file(out.join("t01.overlay.png")).unwrap();
    let text = stdout(&run(&[]));
    assert!(text.contains("output missing (t01.overlay.png)"), "{text}");
    assert!(text.contains("1 registered, 3 skipped"), "{text}");
    // A changed option runs every frame again, naming the entry.
    let text = stdout(&run(&["--bend", "2"]));
    assert!(text.contains("inputs or options changed (options)"), "{text}");
    assert!(text.contains("4 registered, 0 skipped"), "{text}");
}

#[test]
fn shards_split_the_frames_and_warm_starts_follow_the_rule() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fd = frames(d, 4);
    let out = d.join("out");
    // Reference t02 by index; shard 0/2 covers t00 and t01, registered outwards (t01 first).
    let o = trimorph(&[
        "register",
        "--frames",
        s(&fd),
        "--reference",
        "2",
        "-o",
        s(&out),
        "--shard",
        "0/2",
        "--warm-start",
        "none",
        "--iterations",
        "5",
    ]);
    ok(&o);
    let text = stdout(&o);
    assert!(text.contains("frames 0 to 1 of 4:"), "{text}");
    assert!(out.join("t00.report.json").is_file() && out.join("t01.report.json").is_file());
    assert!(!out.join("t02.json").exists() && !out.join("t03.json").exists());
    for k in 0..2 {
        let r = json(&out.join(format!("t{k:02}.report.json")));
        assert_eq!(r["reference"], "t02");
        assert_eq!(r["warm_start"], serde_json::Value::Null, "--warm-start none");
    }
    // Key frames every 2 from the reference t00: t01 starts from its pre-alignment, t02 is
    // a key frame (from the reference: its pre-alignment), t03 starts from t02.
    let out2 = d.join("out2");
    let o = trimorph(&[
        "register",
        "--frames",
        s(&fd),
        "--reference",
        "t00.png",
        "-o",
        s(&out2),
        "--warm-start",
        "keyframes",
        "--key-every",
        "2",
        "--iterations",
        "5",
    ]);
    ok(&o);
    let ws: Vec<serde_json::Value> = (1..4)
        .map(|k| json(&out2.join(format!("t{k:02}.report.json")))["warm_start"].clone())
        .collect();
    assert_eq!(ws, [serde_json::Value::Null, serde_json::Value::Null, "t02".into()]);
}

#[test]
fn bad_sequence_registrations_exit_1_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fd = frames(d, 2);
    let out = d.join("out");
    let reg = |extra: &[&str]| {
        let mut v = vec!["register", "--frames", s(&fd), "-o", s(&out)];
        v.extend_from_slice(extra);
        trimorph(&v)
    };
    let o = reg(&["--reference", "nope"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("nope") && err.contains("t00"), "{err}");
    let o = reg(&["--reference", "t00", "--warm-start", "keyframes"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--key-every"));
    let o = reg(&[]);
    assert_ne!(o.status.code(), Some(0), "--reference is needed");
    assert!(!out.exists(), "nothing is written on bad input");
    // The frames folder as the output folder, and FIXED MOVING beside --frames.
    let o = trimorph(&["register", "--frames", s(&fd), "--reference", "t00", "-o", s(&fd)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("frames folder"));
    assert_eq!(fs::read_dir(&fd).unwrap().count(), 2, "nothing written into the frames");
    let f0 = fd.join("t00.png");
    let o = trimorph(&["register", s(&f0), s(&f0), "--frames", s(&fd), "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot be used with"));
    // A frame too small to register is named.
    let tiny = d.join("tiny");
    fs::create_dir_all(&tiny).unwrap();
    for k in 0..2 {
        GrayImage::from_fn(12, 12, |x, y| Luma([(x * 20 + y * 3 + k) as u8]))
            .save(tiny.join(format!("s{k}.png")))
            .unwrap();
    }
    let o = trimorph(&["register", "--frames", s(&tiny), "--reference", "s0", "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("s0.png") && err.contains("too small"), "{err}");
    assert!(!out.exists(), "nothing is written on bad input");
}
