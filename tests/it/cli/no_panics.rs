//! Adversarial command lines that used to panic, abort on a failed allocation or hang: each
//! must now exit 1 with a message naming the problem, and never print "panicked".

use crate::common;

use common::{ok, s, trimorph};
use std::fs;
use std::path::Path;
use std::process::Output;

/// Asserts exit code 1, no panic, and a message on stderr containing `needle`.
fn fails_with(o: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "panicked: {err}");
    assert_eq!(o.status.code(), Some(1), "stderr: {err}");
    assert!(err.contains(needle), "expected `{needle}` in: {err}");
}

/// Three landmark pairs well inside a 40 x 40 image.
fn landmarks(dir: &Path) -> String {
    let p = dir.join("lm.csv");
    fs::write(&p, "name,src_x,src_y,dst_x,dst_y\na,5,5,6,6\nb,30,8,31,8\nc,12,30,12,31\n").unwrap();
    s(&p).to_string()
}

/// A 40 x 40 gray PNG.
fn image(dir: &Path) -> String {
    let p = dir.join("a.png");
    image::GrayImage::from_fn(40, 40, |x, y| image::Luma([(x * 5 + y * 3) as u8]))
        .save(&p)
        .unwrap();
    s(&p).to_string()
}

#[test]
fn model_bind_grid_product_overflow_is_an_error() {
    // `c * r` overflowed usize: a panic in debug builds, a huge allocation in release.
    let dir = tempfile::tempdir().unwrap();
    let worm = dir.path().join("worm");
    ok(&trimorph(&["model", "worm", "-o", s(&worm)]));
    let out = dir.path().join("b.json");
    let o = trimorph(&[
        "model",
        "bind",
        "--model",
        s(&worm.join("worm.obj")),
        "--auto",
        "--grid",
        "4294967296x4294967296",
        "-o",
        s(&out),
    ]);
    fails_with(&o, "--grid");
}

#[test]
fn fit_shard_with_huge_numbers_does_not_overflow() {
    // `i * frames / n` overflowed usize for a valid `i < n` (shard i/n of 2 frames is 0..1).
    let dir = tempfile::tempdir().unwrap();
    let worm = dir.path().join("worm");
    ok(&trimorph(&["model", "worm", "-o", s(&worm)]));
    let scene = dir.path().join("scene.json");
    ok(&trimorph(&[
        "model",
        "bind",
        "--model",
        s(&worm.join("worm.obj")),
        "--mesh",
        s(&worm.join("worm_prisms.obj")),
        "-o",
        s(&scene),
    ]));
    let frames = dir.path().join("frames");
    fs::create_dir_all(&frames).unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/microscopy/timelapse");
    for k in 0..2 {
        let name = format!("frame_0{k}.png");
        fs::copy(data.join(&name), frames.join(&name)).unwrap();
    }
    let lm = dir.path().join("lm.csv");
    fs::write(
        &lm,
        "name,src_x,src_y,dst_x,dst_y\na,10,10,12,12\nb,100,100,101,100\nc,200,50,200,55\n",
    )
    .unwrap();
    let o = trimorph(&[
        "fit",
        "--model",
        s(&scene),
        "--frames",
        s(&frames),
        "--landmarks",
        s(&lm),
        "-o",
        s(&dir.path().join("out")),
        "--shard",
        "9223372036854775807/18446744073709551615",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("frames 0..1 of 2"), "{o:?}");
}

/// `trimorph morph A A --landmarks L -o OUT` on a 40 x 40 image, with `extra` arguments.
fn morph_with(extra: &[&str]) -> Output {
    let dir = tempfile::tempdir().unwrap();
    let (a, lm) = (image(dir.path()), landmarks(dir.path()));
    let out = dir.path().join("m");
    let mut args = vec!["morph", &a, &a, "--landmarks", &lm, "-o", s(&out)];
    args.extend_from_slice(extra);
    trimorph(&args)
}

#[test]
fn morph_cells_too_many_is_an_error() {
    // --cells 100000: Mesh::grid asked for 160 GB and the process aborted.
    fails_with(&morph_with(&["--frames", "2", "--cells", "100000"]), "--cells");
}

#[test]
fn morph_range_far_outside_is_an_error() {
    // --range 1e300,1e301: the blended points overflowed f64 and the warp never ended.
    fails_with(&morph_with(&["--frames", "2", "--range", "1e300,1e301"]), "--range");
}

#[test]
fn morph_frames_too_many_is_an_error() {
    // --frames 100000000: every frame is held in memory for the animations.
    fails_with(&morph_with(&["--frames", "100000000"]), "--frames");
}

#[test]
fn fit_with_too_many_variables_is_an_error() {
    // A 64 x 64 grid: the dense normal matrix needed ~20 GB (and a 128 x 128 grid aborted on
    // a failed 315 GB allocation).
    let dir = tempfile::tempdir().unwrap();
    let def = dir.path().join("m.json");
    ok(&trimorph(&["mesh", "--grid", "64x64", "--size", "40,40", "-o", s(&def)]));
    let lm = landmarks(dir.path());
    let o = trimorph(&["fit", s(&def), "--landmarks", &lm, "-o", s(&dir.path().join("f.json"))]);
    fails_with(&o, "variable control points");
}

#[test]
fn mesh_with_too_many_control_points_is_an_error() {
    // 300 x 300 cells at degree 15: 20 million exact control points, an allocation abort.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.json");
    let o = trimorph(&[
        "mesh",
        "--grid",
        "300x300",
        "--size",
        "300,300",
        "--degree",
        "15",
        "-o",
        s(&out),
    ]);
    fails_with(&o, "use a coarser mesh or a lower degree");
    assert!(!out.exists());
}
