//! Select-all edits on a large mesh through the command line (issue: exact core at scale,
//! point 4): `trimorph edit` with `"neighborhood": "all"` in its default bounded mode takes
//! the determining-set path (`edit::global`), with `--unbounded` the modular path of ECLES,
//! and the result is exactly C1.

use crate::common;

use common::{edit_script, ok, s, trimorph};
use std::path::{Path, PathBuf};
use trimorph::exact::rat_to_f64;
use trimorph::spline::Spline;

/// `trimorph mesh --points` of `n` points in `[0, size]^2` from a fixed xorshift generator
/// (seed `seed`, coordinates in thousandths): the deformation file and the spline read back.
fn delaunay_mesh(dir: &Path, seed: u64, n: usize, size: f64) -> (PathBuf, Spline) {
    let mut x = seed;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % (size as u64 * 1000)) as f64 / 1000.0
    };
    let pts: String = (0..n).map(|_| format!("{},{}\n", next(), next())).collect();
    let csv = dir.join("points.csv");
    std::fs::write(&csv, pts).unwrap();
    let mesh = dir.join("mesh.json");
    ok(&trimorph(&["mesh", "--points", s(&csv), "-o", s(&mesh)]));
    let text = std::fs::read_to_string(&mesh).unwrap();
    let (spline, _) = trimorph::io::deformation::from_str(&text).unwrap();
    (mesh, spline)
}

#[test]
fn a_select_all_edit_of_a_600_triangle_mesh_is_exactly_c1_and_moves_the_anchor() {
    let dir = tempfile::tempdir().unwrap();
    // 300 points in [0, 200]^2 from a fixed generator.
    let (mesh, before) = delaunay_mesh(dir.path(), 0x2545_F491_4F6C_DD1D, 300, 200.0);
    assert!(before.mesh().num_triangles() > 550, "{} triangles", before.mesh().num_triangles());
    let script = dir.path().join("all.json");
    std::fs::write(
        &script,
        r#"[{"op": "translate", "anchors": {"near": [[100, 100]]}, "neighborhood": "all", "by": [3, "-2"]}]"#,
    )
    .unwrap();
    let out = dir.path().join("edited.json");
    let o = edit_script(&mesh, &script, &out);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let n = before.num_points();
    assert!(stdout.contains(&format!("1 anchors, {} derived", n - 1)), "{stdout}");
    assert!(
        stdout.contains("strongly solvable") && stdout.contains("C1 holds exactly"),
        "{stdout}"
    );
    // The line says which path ran.
    assert!(stdout.contains("(solved in determining-set coordinates)"), "{stdout}");
    let (after, _) =
        trimorph::io::deformation::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    after.check_c1().expect("C1 exactly, checked in rationals");
    // The anchor is the control point nearest (100, 100); it lands within the bounded
    // mode's tolerance of its target.
    let anchor = (0..n)
        .min_by(|&a, &b| {
            let d = |i: usize| {
                let p = before.point_f64(i);
                (p[0] - 100.0).powi(2) + (p[1] - 100.0).powi(2)
            };
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let (p, q) = (&before.points()[anchor], &after.points()[anchor]);
    let moved = [rat_to_f64(&q[0]) - rat_to_f64(&p[0]), rat_to_f64(&q[1]) - rat_to_f64(&p[1])];
    assert!((moved[0] - 3.0).abs() < 1e-4 && (moved[1] + 2.0).abs() < 1e-4, "{moved:?}");
    // Points near the anchor follow; the check command agrees.
    let moved_points = (0..n).filter(|&i| before.point_f64(i) != after.point_f64(i)).count();
    assert!(moved_points > n / 10, "{moved_points} of {n} points moved");
    ok(&trimorph(&["check", s(&out)]));
}

/// `trimorph edit --unbounded` keeps exact values, so a select-all edit cannot take the
/// determining-set path; it runs on ECLES's modular path (issue 24, point 4) and gives the
/// fraction-free sessions' exact values.
#[test]
fn an_unbounded_select_all_edit_runs_on_the_modular_path_with_the_sessions_values() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, before) = delaunay_mesh(dir.path(), 0x9E37_79B9_7F4A_7C15, 24, 100.0);
    let script_text = r#"[{"op": "rotate", "anchors": {"near": [[50, 50]]}, "neighborhood": "all", "center": [40, 45], "angle": 0.2},
        {"op": "translate", "anchors": {"near": [[20, 70]]}, "neighborhood": "all", "by": [2, "-1/3"]}]"#;
    let script = dir.path().join("all.json");
    std::fs::write(&script, script_text).unwrap();
    let out = dir.path().join("edited.json");
    let o = trimorph(&["edit", s(&mesh), "--script", s(&script), "--unbounded", "-o", s(&out)]);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(stdout.matches("(solved on the modular path)").count(), 2, "{stdout}");
    let (after, _) =
        trimorph::io::deformation::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    after.check_c1().expect("C1 exactly, checked in rationals");
    // The same script on fraction-free sessions, through the library.
    let mut ed = trimorph::edit::Editor::new(before.clone());
    ed.set_modular_path(Some(usize::MAX));
    let reports = trimorph::edit::script::Script::from_json_str(script_text).unwrap().run(&mut ed);
    assert_eq!(reports.unwrap().len(), 2);
    assert!(!ed.selection().unwrap().is_modular());
    let text = |s: &Spline| -> Vec<String> {
        s.points().iter().flatten().map(trimorph::exact::rat_to_string).collect()
    };
    assert_eq!(text(&after), text(ed.spline()), "the sessions' exact values");
    ok(&trimorph(&["check", s(&out)]));
}
