//! Replays every saved fuzz input (`tests/fuzz_regressions/<target>/*`) through the same
//! function the fuzz target calls (`fuzz/targets.rs`): crashes the fuzzer found (each fixed
//! since) and a few interesting inputs from the corpora. A panic fails the test; the
//! `ldu_rebuild` target also asserts that A is rebuilt exactly from its factors.
//!
//! CI runs these files, not the fuzzer; see `fuzz/README.md` for the fuzzing runs.

#[path = "../fuzz/targets.rs"]
mod targets;

use std::path::Path;

fn replay(target: &str) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions").join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{}: no regression inputs", dir.display());
    for f in files {
        let data = std::fs::read(&f).unwrap();
        let name = f.display().to_string();
        let r = std::panic::catch_unwind(|| targets::run(target, &data));
        assert!(r.is_ok(), "{name} panics in fuzz target {target}");
    }
}

#[test]
fn every_target_has_a_regression_folder() {
    for t in targets::TARGETS {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions").join(t);
        assert!(dir.is_dir(), "{}", dir.display());
    }
}

#[test]
fn deformation_json() {
    replay("deformation_json");
}

#[test]
fn solve_json() {
    replay("solve_json");
}

#[test]
fn model_obj() {
    replay("model_obj");
}

#[test]
fn model_ply() {
    replay("model_ply");
}

#[test]
fn landmarks_csv() {
    replay("landmarks_csv");
}

#[test]
fn landmarks_bigwarp() {
    replay("landmarks_bigwarp");
}

#[test]
fn edit_script() {
    replay("edit_script");
}

#[test]
fn ldu_rebuild() {
    replay("ldu_rebuild");
}
