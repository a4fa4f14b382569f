//! The editor end to end in a real headless browser: `tests/e2e/editor.mjs` (playwright-core
//! driving Debian's Chromium) starts `trimorph editor` on the bundled scene, checks that the
//! API refuses requests without the session token, opens the printed address (with the
//! token), presses on an anchor and drags it at once (before the selection answered),
//! checks through the API that it moved exactly as the pointer did (the drag ends under
//! the pointer), that the map folds and saving asked for confirmation, that the save
//! message stays, that a second save asks before overwriting, toggles the help panel
//! (`?`), compares the live warped frame with `trimorph warp` of the same state (mean
//! absolute difference <= 1 gray level, <= 0.5 % of pixels off by more than 8), runs
//! `trimorph check` (exact C1), takes screenshots (`target/e2e/editor.png`,
//! `editor_warp.png`), taps another point (press and release at once, then moves without a
//! button: a selection, no edit), undoes with Ctrl+Z; then in z1 mode drags the point up
//! and checks that sigma1 rose there and the oblique view shows
//! (`target/e2e/editor_z1.png`).
//!
//! It also measures the live warp's latency: a point dragged step by step, each step timed
//! in the page from the pointer event to the redraw with that step's warped frame.
//!
//! `editor_two_images_in_headless_chromium` runs `tests/e2e/bigwarp.mjs`: the two-image
//! session (BigWarp's workflow) over 512 x 512 time-lapse frames 0 and 9, started from a
//! `trimorph fit` whose deformation carries its landmarks (see that script), with the live
//! warp's latency on 512 x 512 (`target/e2e/editor_two*.png`).
//!
//! Needs `node`, Chromium (`/usr/bin/chromium` or `$CHROMIUM`) and
//! `tests/e2e/node_modules` (`npm ci` in `tests/e2e`); `.ci/run` installs them and sets
//! `TRIMORPH_E2E=1`, which makes their absence a failure instead of a skip.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

/// One browser at a time: the two tests measure latencies on a 2-core machine.
static BROWSER: Mutex<()> = Mutex::new(());

/// Chromium's path, or `None` (the test is skipped) when node, Chromium or the node
/// modules are missing and `TRIMORPH_E2E` is not 1.
fn browser_ready() -> Option<String> {
    let e2e = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/e2e");
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    let node_ok = Command::new("node").arg("--version").output().is_ok_and(|o| o.status.success());
    let ready = node_ok
        && Path::new(&chromium).exists()
        && e2e.join("node_modules/playwright-core").exists();
    if !ready {
        let required = std::env::var("TRIMORPH_E2E").is_ok_and(|v| v == "1");
        assert!(
            !required,
            "TRIMORPH_E2E=1 but node, {chromium} or tests/e2e/node_modules is missing"
        );
        eprintln!("skipped: node, {chromium} or tests/e2e/node_modules missing (see .ci/run)");
        return None;
    }
    Some(chromium)
}

/// Runs `tests/e2e/SCRIPT BINARY WORK SHOT` and returns its JSON summary line.
fn run_script(script: &str, work: &Path, shot: &Path, chromium: &str) -> serde_json::Value {
    let e2e = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/e2e");
    let o = Command::new("node")
        .arg(e2e.join(script))
        .arg(env!("CARGO_BIN_EXE_trimorph"))
        .arg(work)
        .arg(shot)
        .env("CHROMIUM", chromium)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "e2e failed:\n{out}\n{err}");
    let line = out.lines().rev().find(|l| l.starts_with('{')).expect("a JSON summary");
    let v: serde_json::Value = serde_json::from_str(line).unwrap();
    assert_eq!(v["ok"], true, "{line}");
    v
}

fn shots_dir() -> PathBuf {
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/e2e");
    std::fs::create_dir_all(&shots).unwrap();
    shots
}

#[test]
fn editor_drag_in_headless_chromium() {
    let Some(chromium) = browser_ready() else { return };
    let _one = BROWSER.lock().unwrap_or_else(|e| e.into_inner());
    let work = tempfile::tempdir().unwrap();
    let shots = shots_dir();
    let shot = shots.join("editor.png");
    let v = run_script("editor.mjs", work.path(), &shot, &chromium);
    let line = v.to_string();
    assert!(v["drag_steps"].as_u64().unwrap() >= 10, "{line}");
    eprintln!("editor e2e: {line}");
    let png = image::open(&shot).unwrap();
    assert_eq!((png.width(), png.height()), (1100, 800));
    assert!(work.path().join("e2e.json").exists());
    assert!(shots.join("editor_z1.png").exists(), "the z1-mode screenshot");
    assert!(shots.join("editor_warp.png").exists(), "the live-warp screenshot");
    assert!(v["drag_error_px"].as_f64().unwrap() < 0.01, "the drag ends under the pointer: {line}");
    assert!(v["live_warp_vs_cli"]["mean_abs"].as_f64().unwrap() <= 1.0, "{line}");
    assert!(shots.join("editor_landmarks.png").exists(), "the landmarks screenshot");
    let lm = &v["landmarks"];
    assert!(
        lm["rms_after"].as_f64().unwrap() < lm["rms_before"].as_f64().unwrap(),
        "the re-fit lowers the residuals: {line}"
    );
    assert!(
        work.path().join("e2e_pairs.csv").exists() && work.path().join("e2e_bigwarp.csv").exists()
    );
}

/// A time-lapse frame grown to 512 x 512 (its last row and column repeated).
fn frame_512(name: &str) -> image::GrayImage {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let f = image::open(root.join("data/microscopy/timelapse").join(name)).unwrap().to_luma8();
    image::GrayImage::from_fn(512, 512, |x, y| {
        *f.get_pixel(x.min(f.width() - 1), y.min(f.height() - 1))
    })
}

#[test]
fn editor_two_images_in_headless_chromium() {
    let Some(chromium) = browser_ready() else { return };
    let _one = BROWSER.lock().unwrap_or_else(|e| e.into_inner());
    let work = tempfile::tempdir().unwrap();
    frame_512("frame_00.png").save(work.path().join("moving.png")).unwrap();
    frame_512("frame_09.png").save(work.path().join("fixed.png")).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(
        root.join("data/microscopy/timelapse/landmarks_00_09.csv"),
        work.path().join("landmarks.csv"),
    )
    .unwrap();
    let shots = shots_dir();
    let shot = shots.join("editor_two.png");
    let v = run_script("bigwarp.mjs", work.path(), &shot, &chromium);
    let line = v.to_string();
    eprintln!("editor two-image e2e: {line}");
    let png = image::open(&shot).unwrap();
    assert_eq!((png.width(), png.height()), (1400, 800));
    assert!(shots.join("editor_two_colors.png").exists());
    assert!(v["far_moved_max_px"].as_f64().unwrap() <= 3.0, "{line}");
    assert!(v["live_warp_latency_ms"]["n"].as_u64().unwrap() >= 30, "{line}");
    assert!(
        work.path().join("two_scene.json").exists() && work.path().join("corrected.json").exists()
    );
}
