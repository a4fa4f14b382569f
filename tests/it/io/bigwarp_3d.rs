//! BigWarp 3D landmark tables through `trimorph fit` (issue 20, item 4): constant z is
//! dropped with a warning, varying z is refused naming the file and line.

use crate::common;
use common::{ok, s, trimorph};

const TABLE_3D: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/bigwarp_3d.csv");
const TRACKS: &str =
    concat!(env!("CARGO_MANIFEST_DIR"), "/data/microscopy/timelapse/tracks_0_9.csv");

/// `tests/data/bigwarp_3d.csv` is BigWarp's 3D export of the bundled tracks
/// (`data/microscopy/timelapse/tracks_0_9.csv`, moving = frame 0, fixed = frame 9, z = 0):
/// it fits to the same file as the 2D CSV, and `fit` warns that z was dropped.
#[test]
fn a_3d_table_with_constant_z_fits_as_the_2d_one_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.json"), dir.path().join("b.json"));
    let o = trimorph(&["fit", "--size", "511,511", "--landmarks", TABLE_3D, "-o", s(&a)]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning:") && err.contains("bigwarp_3d.csv") && err.contains("z dropped"),
        "{err}"
    );
    assert!(err.contains("constant on all 14 rows"), "{err}");
    let o = trimorph(&["fit", "--size", "511,511", "--landmarks", TRACKS, "-o", s(&b)]);
    ok(&o);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("z dropped"));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap(), "same deformation");
    // The library reads the same landmarks (BigWarp moving -> src, fixed -> dst).
    let (l3, notes) =
        trimorph::io::landmarks::read_landmarks_with_notes(std::path::Path::new(TABLE_3D)).unwrap();
    let l2 = trimorph::io::landmarks::read_landmarks(std::path::Path::new(TRACKS)).unwrap();
    assert_eq!(l3, l2);
    let z = notes.constant_z.expect("z was dropped");
    assert_eq!((z.moving, z.fixed, z.rows), (0.0, 0.0, 14));
}

/// A 3D table whose z varies cannot be fitted by a 2D deformation: exit 1, naming the file,
/// the line and the reason, and no output.
#[test]
fn a_3d_table_with_varying_z_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(TABLE_3D).unwrap();
    // Line 5 moves to the plane z = 3 in the moving image.
    let varied: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 4 {
                let mut f: Vec<&str> = l.split(',').collect();
                f[4] = "\"3.0\"";
                f.join(",")
            } else {
                l.to_string()
            }
        })
        .collect();
    let lms = dir.path().join("varying_z.csv");
    std::fs::write(&lms, varied.join("\n") + "\n").unwrap();
    let out = dir.path().join("o.json");
    let o = trimorph(&["fit", "--size", "511,511", "--landmarks", s(&lms), "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("varying_z.csv") && err.contains("line 5"), "{err}");
    assert!(err.contains("moving z is 3") && err.contains("varying z"), "{err}");
    assert!(!out.exists());
}
