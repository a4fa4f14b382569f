//! `trimorph field DEF -o F.h5`: the ITK HDF5 displacement-field transform, read back and
//! compared with the library's point maps at pixel centres (issue 20, item 2).

use crate::common;
use common::{ok, s, trimorph};
use std::path::{Path, PathBuf};
use trimorph::io::itk::{read_h5, TRANSFORM_TYPE};
use trimorph::warp::inverse::InverseOptions;

/// The inverse tolerance of `field` and `warp` (px): every preimage of the field is within
/// it of the Newton solution `warp --points --inverse` gives.
const INVERSE_TOL: f64 = 0.01;

/// A real deformation with visible displacement and an undefined border: the bundled nucleus
/// tracks (frame 0 -> 9 of the time-lapse) fitted over a 6 x 6 grid on the 511 x 511 frame.
fn fitted(dir: &Path) -> PathBuf {
    let (mesh, def) = (dir.join("ref.json"), dir.join("def.json"));
    ok(&trimorph(&["mesh", "--grid", "6x6", "--size", "511,511", "-o", s(&mesh)]));
    let lms = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/timelapse/tracks_0_9.csv");
    ok(&trimorph(&["fit", s(&mesh), "--landmarks", lms, "-o", s(&def)]));
    def
}

fn spline(def: &Path) -> trimorph::spline::Spline {
    trimorph::io::deformation::from_str(&std::fs::read_to_string(def).unwrap()).unwrap().0
}

fn centres(w: u32, h: u32) -> Vec<[f64; 2]> {
    (0..h).flat_map(|y| (0..w).map(move |x| [x as f64, y as f64])).collect()
}

/// The default file holds phi^-1(q) - q on the pixel grid (origin 0, spacing 1, identity
/// direction: grid index (x, y) is the physical point (x, y), trimorph's centre of pixel
/// (x, y)), equal to `warp --points --inverse` within the inverse tolerance, with NaN exactly
/// where the image warp has no preimage (up to pixels on the rim within the tolerance).
#[test]
fn default_h5_is_the_inverse_map_on_the_pixel_grid() {
    let dir = tempfile::tempdir().unwrap();
    let def = fitted(dir.path());
    let h5 = dir.path().join("F.h5");
    let o = trimorph(&["field", s(&def), "-o", s(&h5)]);
    ok(&o);
    let line = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(line.contains(TRANSFORM_TYPE) && line.contains("511x511"), "{line}");
    assert!(line.contains("phi^-1(q) - q") && line.contains("warp --points --inverse"), "{line}");
    let f = read_h5(&h5).unwrap();
    assert_eq!(f.fixed_parameters(), [511.0, 511.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 1.0]);
    assert_eq!(f.data.len(), 511 * 511);
    let undefined = f.undefined();
    assert!(undefined > 1000, "the fitted map leaves part of the frame uncovered");
    assert!(line.contains(&format!("({undefined} pixels undefined")), "{line}");
    let s = spline(&def);
    let pts = centres(511, 511);
    let newton = trimorph::warp::inverse(&s, &pts, InverseOptions::default());
    let (mut worst, mut rim, mut moved) = (0.0f64, 0, 0.0f64);
    for (i, (q, r)) in pts.iter().zip(&newton).enumerate() {
        let d = f.data[i];
        match (r, d[0].is_nan()) {
            (Some(r), false) => {
                let p = [q[0] + d[0], q[1] + d[1]];
                worst = worst.max((p[0] - r.p[0]).abs().max((p[1] - r.p[1]).abs()));
                moved = moved.max(d[0].hypot(d[1]));
            }
            (None, true) => {}
            _ => {
                // Defined in one map only: must be next to an undefined pixel of the field.
                let (x, y) = (i % 511, i / 511);
                let near = [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)].iter().any(|(dx, dy)| {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    (0..511).contains(&nx)
                        && (0..511).contains(&ny)
                        && f.data[ny as usize * 511 + nx as usize][0].is_nan()
                });
                assert!(near || d[0].is_nan(), "pixel ({x}, {y}) differs away from the rim");
                rim += 1;
            }
        }
    }
    assert!(worst <= INVERSE_TOL, "preimages differ by {worst} px");
    assert!(rim <= 50, "{rim} pixels differ in definedness");
    assert!(moved > 10.0, "a real deformation moves pixels visibly ({moved} px)");
}

/// `--inverse` writes the other direction, phi(p) - p, bit for bit what `warp::forward`
/// gives at the pixel centres (the same f64 evaluation).
#[test]
fn inverse_flag_writes_the_forward_map() {
    let dir = tempfile::tempdir().unwrap();
    let def = fitted(dir.path());
    let h5 = dir.path().join("Fi.hdf5");
    let jac = dir.path().join("j.png");
    let o = trimorph(&[
        "field",
        s(&def),
        "--inverse",
        "-o",
        s(&h5),
        "--size",
        "300,200",
        "--jacobian",
        s(&jac),
    ]);
    ok(&o);
    assert!(jac.exists(), "--jacobian works with .h5 too");
    let line = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(line.contains("phi(p) - p") && line.contains("300x200"), "{line}");
    let f = read_h5(&h5).unwrap();
    assert_eq!(f.size, [300, 200]);
    let pts = centres(300, 200);
    let fwd = trimorph::warp::forward(&spline(&def), &pts);
    for ((p, q), d) in pts.iter().zip(&fwd).zip(&f.data) {
        let q = q.expect("the reference mesh covers the frame");
        assert_eq!(*d, [q[0] - p[0], q[1] - p[1]], "at {p:?}");
    }
    assert_eq!(f.undefined(), 0);
}

/// Bad output names and sizes exit 1 with the file named, and write nothing.
#[test]
fn bad_names_and_sizes_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let def = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "20,10", "-o", s(&def)]));
    let bad = dir.path().join("F.h6");
    let o = trimorph(&["field", s(&def), "-o", s(&bad)]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("F.h6") && e.contains(".h5"), "{e}");
    let h5 = dir.path().join("F.h5");
    for size in ["0,10", "20000,20000", "12"] {
        let o = trimorph(&["field", s(&def), "-o", s(&h5), "--size", size]);
        assert_eq!(o.status.code(), Some(1), "--size {size}");
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains("--size") || e.contains("id.json"), "--size {size}: {e}");
    }
    assert!(!h5.exists() && !bad.exists(), "nothing written");
    // A file that is not a transform names itself when read.
    std::fs::write(&h5, b"not hdf5").unwrap();
    let e = read_h5(&h5).unwrap_err().to_string();
    assert!(e.contains("F.h5"), "{e}");
}

/// Issue 51: a fit over `--size W,H` records its frame (the file's `"frame"` key), and
/// `field` without `--size` writes that frame's grid, not the far-field rings' extent
/// (16 times the frame: a 511 x 511 fit gave a 5176 x 5176 field, 428 MB). An edit keeps
/// the frame; `--size` still overrides it.
#[test]
fn field_defaults_to_the_frame_a_fit_was_made_for() {
    let dir = tempfile::tempdir().unwrap();
    let def = dir.path().join("fit.json");
    let lms = concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/timelapse/tracks_0_9.csv");
    ok(&trimorph(&["fit", "--size", "520,515", "--landmarks", lms, "-o", s(&def)]));
    let text = std::fs::read_to_string(&def).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(doc["frame"]["size"], serde_json::json!([520.0, 515.0]), "{}", doc["frame"]);
    let sp = spline(&def);
    assert!(sp.mesh().bbox().1[0] > 3000.0, "far rings present");
    let h5 = dir.path().join("F.h5");
    let o = trimorph(&["field", s(&def), "-o", s(&h5)]);
    ok(&o);
    let f = read_h5(&h5).unwrap();
    assert_eq!(f.fixed_parameters()[..2], [520.0, 515.0]);
    assert_eq!(f.data.len(), 520 * 515);
    // An edit keeps the frame.
    let script = dir.path().join("e.json");
    std::fs::write(&script, r#"[{"op": "translate", "anchors": [0], "by": [0.5, 0.0]}]"#).unwrap();
    let edited = dir.path().join("edited.json");
    ok(&common::edit_script(&def, &script, &edited));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&edited).unwrap()).unwrap();
    assert_eq!(doc["frame"]["size"], serde_json::json!([520.0, 515.0]));
    // --size overrides it.
    ok(&trimorph(&["field", s(&def), "-o", s(&h5), "--size", "40,30"]));
    assert_eq!(read_h5(&h5).unwrap().data.len(), 40 * 30);
}
