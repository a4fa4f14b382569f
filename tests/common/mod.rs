//! Helpers shared by the CLI integration tests.
#![allow(dead_code)]

pub mod delaunay;
pub mod features;
pub mod tps;

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `trimorph` binary with `args`.
pub fn trimorph(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trimorph")).args(args).output().expect("runs")
}

/// Asserts success, printing both streams otherwise.
pub fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "stdout: {}\nstderr: {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A path as `&str`.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Golden-image tolerance: every channel of every pixel within this many levels.
pub const GOLDEN_MAX_DIFF: u8 = 2;
/// Golden-image tolerance: at most this many pixels may differ at all.
pub const GOLDEN_MAX_OFF: usize = 64;

/// `trimorph edit INPUT --script SCRIPT -o OUT`.
pub fn edit_script(input: &Path, script: &Path, out: &Path) -> Output {
    trimorph(&["edit", s(input), "--script", s(script), "-o", s(out)])
}

/// The folder of golden images.
pub fn golden_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// Compares `got` with the golden image `name` (same size and type; tolerance
/// [`GOLDEN_MAX_DIFF`] levels, at most [`GOLDEN_MAX_OFF`] pixels differing), or stores it when
/// `TRIMORPH_REGENERATE_GOLDEN` is set.
pub fn compare_golden(name: &str, got: &image::DynamicImage) {
    use image::GenericImageView;
    let p = golden_dir().join(name);
    if std::env::var_os("TRIMORPH_REGENERATE_GOLDEN").is_some() {
        got.save(&p).unwrap();
        return;
    }
    let want = image::open(&p).unwrap_or_else(|e| panic!("{}: {e} (regenerate?)", p.display()));
    assert_eq!(want.dimensions(), got.dimensions(), "{name}: size");
    assert_eq!(want.color(), got.color(), "{name}: type");
    let (a, b) = (want.to_rgba8(), got.to_rgba8());
    let mut off = 0;
    for (pa, pb) in a.pixels().zip(b.pixels()) {
        let d = pa.0.iter().zip(pb.0).map(|(x, y)| x.abs_diff(y)).max().unwrap_or(0);
        assert!(d <= GOLDEN_MAX_DIFF, "{name}: a pixel differs by {d} > {GOLDEN_MAX_DIFF}");
        off += (d > 0) as usize;
    }
    assert!(off <= GOLDEN_MAX_OFF, "{name}: {off} pixels differ (at most {GOLDEN_MAX_OFF} may)");
}

/// `m` at `(x, y)`, bilinear, clamped to the image (for resampling test images through a
/// known map).
pub fn bilinear(m: &image::GrayImage, x: f64, y: f64) -> f64 {
    let (w, h) = m.dimensions();
    let (x, y) = (x.clamp(0.0, w as f64 - 1.001), y.clamp(0.0, h as f64 - 1.001));
    let (i, j) = (x.floor() as u32, y.floor() as u32);
    let (fx, fy) = (x - i as f64, y - j as f64);
    let p = |a: u32, b: u32| m.get_pixel(a, b).0[0] as f64;
    (1.0 - fy) * ((1.0 - fx) * p(i, j) + fx * p(i + 1, j))
        + fy * ((1.0 - fx) * p(i, j + 1) + fx * p(i + 1, j + 1))
}
