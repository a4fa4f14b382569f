//! `trimorph fit` through the binary: single fits, reports, hard mode, errors and exit codes
//! (here); frame sequences (tracking, resumability, shards: [`sequences`]); landmark point
//! files ([`point_files`]).

use crate::common;
mod point_files;
mod sequences;
use common::{ok, s, trimorph};
use std::fs;
use std::path::Path;

fn smooth(p: [f64; 2]) -> [f64; 2] {
    [p[0] + 4.0 * (p[1] / 50.0).sin() + 2.0, p[1] + 3.0 * (p[0] / 70.0).cos()]
}

fn write_landmarks(path: &Path, n: usize) {
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y,weight\n");
    for i in 0..n {
        let p = [15.0 + (i * 37 % 170) as f64, 12.0 + (i * 53 % 120) as f64];
        let q = smooth(p);
        csv += &format!("p{i},{},{},{},{},1\n", p[0], p[1], q[0], q[1]);
    }
    fs::write(path, csv).unwrap();
}

fn reference(dir: &Path) -> std::path::PathBuf {
    let def = dir.join("ref.json");
    ok(&trimorph(&["mesh", "--grid", "5x4", "--size", "200,150", "-o", s(&def)]));
    def
}

#[test]
fn fit_writes_an_exactly_c1_deformation_and_a_report_with_tre() {
    let dir = tempfile::tempdir().unwrap();
    let def = reference(dir.path());
    let lms = dir.path().join("l.csv");
    write_landmarks(&lms, 30);
    let (out, rep) = (dir.path().join("fit.json"), dir.path().join("rep.json"));
    let o = trimorph(&[
        "fit",
        s(&def),
        "--landmarks",
        s(&lms),
        "-o",
        s(&out),
        "--report",
        s(&rep),
        "--holdout",
        "5",
    ]);
    ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("held-out TRE") && text.contains("C1 exact: yes"), "{text}");
    let r: serde_json::Value = serde_json::from_str(&fs::read_to_string(&rep).unwrap()).unwrap();
    assert_eq!(r["fit"]["count"], 25);
    assert_eq!(r["holdout"]["tre"]["count"], 5);
    assert!(r["fit"]["rms"].as_f64().unwrap() < 0.05);
    assert!(r["holdout"]["tre"]["rms"].as_f64().unwrap() < 2.0);
    assert_eq!(r["exact_c1"], true);
    assert_eq!(r["folds"], false);
    // The output is a normal deformation: `check` verifies C1 exactly, and it can be edited.
    ok(&trimorph(&["check", s(&out)]));
    let script = dir.path().join("e.json");
    fs::write(&script, r#"[{"anchors": {"near": [[80, 60]]}, "op": "translate", "by": [2, 1]}]"#)
        .unwrap();
    ok(&trimorph(&[
        "edit",
        s(&out),
        "--script",
        s(&script),
        "-o",
        s(&dir.path().join("e.out.json")),
    ]));
}

#[test]
fn robust_and_hard_fits_run_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let def = reference(dir.path());
    let lms = dir.path().join("l.csv");
    write_landmarks(&lms, 12);
    for extra in [&["--loss", "cauchy"][..], &["--loss", "huber", "--loss-scale", "1"], &["--hard"]]
    {
        let out = dir.path().join("o.json");
        let mut args = vec!["fit", s(&def), "--landmarks", s(&lms), "-o", s(&out)];
        args.extend_from_slice(extra);
        let o = trimorph(&args);
        ok(&o);
        if extra == ["--hard"] {
            assert!(String::from_utf8_lossy(&o.stdout).contains("+hard"));
        }
    }
}

#[test]
fn bad_inputs_exit_1_contradictions_exit_2_and_nothing_is_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let def = reference(dir.path());
    let out = dir.path().join("keep.json");
    fs::write(&out, "precious").unwrap();
    let cases: Vec<(&str, i32)> = vec![
        ("name,src_x,src_y,dst_x,dst_y\na,10,10,nan,3\n", 1),
        ("name,src_x,src_y,dst_x,dst_y\na,900,10,3,3\n", 1),
        ("name,src_x,src_y\na,1,2\n", 1),
        ("name,src_x,src_y,dst_x,dst_y\na,50,50,55,50\nb,50,50,45,50\nc,150,100,150,100\n", 2),
    ];
    for (i, (text, code)) in cases.iter().enumerate() {
        let lms = dir.path().join(format!("bad{i}.csv"));
        fs::write(&lms, text).unwrap();
        let o = trimorph(&["fit", s(&def), "--landmarks", s(&lms), "-o", s(&out), "--hard"]);
        assert_eq!(
            o.status.code(),
            Some(*code),
            "case {i}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!String::from_utf8_lossy(&o.stderr).trim().is_empty());
        assert_eq!(fs::read_to_string(&out).unwrap(), "precious");
    }
    let o = trimorph(&["fit", "--landmarks", "x.csv", "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1));
}

/// Issue 16 point 4: `--hard` meets the decimals as written, says which ones an f64 cannot
/// hold, and tells contradictory from too many constraints (issue 23), both exit 2.
#[test]
fn hard_fit_reports_approximated_values_and_its_diagnostics() {
    let dir = tempfile::tempdir().unwrap();
    let def = reference(dir.path());
    let lms = dir.path().join("l.csv");
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    for i in 0..12 {
        let p = [15.1234 + (i * 37 % 170) as f64, 12.5678 + (i * 53 % 120) as f64];
        let q = smooth(p);
        csv += &format!("p{i},{:.4},{:.4},{:.4},{:.4}\n", p[0], p[1], q[0], q[1]);
    }
    csv += "long,100.5,60.25,101.12345678901234567890,61\n";
    fs::write(&lms, &csv).unwrap();
    let out = dir.path().join("o.json");
    let rep = dir.path().join("r.json");
    let o = trimorph(&[
        "fit",
        s(&def),
        "--landmarks",
        s(&lms),
        "-o",
        s(&out),
        "--report",
        s(&rep),
        "--hard",
    ]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("landmark 12 (long): dst_x 101.12345678901234567890 is approximated by 101.12345678901235 (difference"),
        "{err}"
    );
    assert_eq!(err.matches("is approximated").count(), 1, "{err}");
    let r: serde_json::Value = serde_json::from_str(&fs::read_to_string(&rep).unwrap()).unwrap();
    assert!(r["fit"]["max"].as_f64().unwrap() < 1e-9, "{r}");
    ok(&trimorph(&["check", s(&out)]));
    // The soft fit does not print the notes.
    let o = trimorph(&["fit", s(&def), "--landmarks", s(&lms), "-o", s(&out)]);
    ok(&o);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("approximated"));
    // Too many constraints: 7 landmarks on one segment in one triangle (a quintic takes 6).
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    for i in 0..7 {
        let x = 10.0 + 2.5 * i as f64;
        csv += &format!("s{i},{x},4,{},4\n", x + if i % 2 == 0 { 1.0 } else { -1.0 });
    }
    fs::write(&lms, &csv).unwrap();
    let o = trimorph(&["fit", s(&def), "--landmarks", s(&lms), "-o", s(&out), "--hard"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("too many constraints for the mesh") && err.contains("(s"), "{err}");
    assert!(err.contains("finer mesh, fewer landmarks, or the soft fit"), "{err}");
}

/// Issue 16: `fit --size` (no deformation) builds the landmark-adapted mesh, reports the
/// certificate, the chosen smoothing and the frame coverage, and writes an exactly C1 file
/// that `check` accepts; `mesh --landmarks` writes that mesh with every source a vertex.
#[test]
fn fit_with_size_adapts_the_mesh_and_reports_certificate_smoothing_and_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let lms = dir.path().join("l.csv");
    write_landmarks(&lms, 30);
    let (out, rep) = (dir.path().join("fit.json"), dir.path().join("rep.json"));
    let o = trimorph(&[
        "fit",
        "--size",
        "200,150",
        "--landmarks",
        s(&lms),
        "-o",
        s(&out),
        "--report",
        s(&rep),
        "--holdout",
        "5",
    ]);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("adapted mesh:") && stdout.contains("covers the frame: yes"),
        "{stdout}"
    );
    let r: serde_json::Value = serde_json::from_str(&fs::read_to_string(&rep).unwrap()).unwrap();
    assert_eq!(r["fold_free"], true, "{r}");
    assert_eq!(r["bend_auto"], true);
    assert!(r["loo_rms"].as_f64().unwrap() > 0.0);
    assert!(r["det_j_lower_bound"].as_f64().unwrap() > 0.0);
    assert_eq!(r["frame"]["covers_frame"], true);
    assert!(r["frame"]["margin"].as_f64().unwrap() >= 20.0);
    assert_eq!(r["holdout"]["tre"]["count"], 5);
    ok(&trimorph(&["check", s(&out)]));
    // The mesh alone: every landmark source is a vertex of it.
    let mesh = dir.path().join("mesh.json");
    let o = trimorph(&["mesh", "--landmarks", s(&lms), "--size", "200,150", "-o", s(&mesh)]);
    ok(&o);
    let d: serde_json::Value = serde_json::from_str(&fs::read_to_string(&mesh).unwrap()).unwrap();
    let verts = d["vertices"].as_array().unwrap();
    for line in fs::read_to_string(&lms).unwrap().lines().skip(1) {
        let f: Vec<f64> = line.split(',').skip(1).take(2).map(|v| v.parse().unwrap()).collect();
        assert!(
            verts.iter().any(|v| v[0].as_f64() == Some(f[0]) && v[1].as_f64() == Some(f[1])),
            "source {f:?} is not a vertex"
        );
    }
    // A bad --bend is refused.
    let o = trimorph(&[
        "fit",
        "--size",
        "200,150",
        "--landmarks",
        s(&lms),
        "-o",
        s(&out),
        "--bend",
        "x",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--bend"));
}

/// Bug: with a landmark outside `--size` whose target also made the landmarks' affine map
/// degenerate, `fit --size` blamed the whole set ("reverses orientation (determinant
/// 0.000)") instead of the landmark outside the frame. Each landmark's own problem now comes
/// first, named, exit 1, nothing written.
#[test]
fn a_source_outside_the_frame_is_named_before_the_sets_degenerate_map() {
    let dir = tempfile::tempdir().unwrap();
    let lms = dir.path().join("l.csv");
    fs::write(&lms, "name,src_x,src_y,dst_x,dst_y\na,10,10,11,11\nb,600,20,21,21\nc,30,90,31,31\n")
        .unwrap();
    let out = dir.path().join("f.json");
    for cmd in ["fit", "mesh"] {
        let o = trimorph(&[cmd, "--size", "512,512", "--landmarks", s(&lms), "-o", s(&out)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{cmd}: {err}");
        assert!(err.contains("l.csv") && err.contains("landmark 1"), "{cmd}: {err}");
        assert!(err.contains("(600, 20) lies outside the 512 x 512 frame"), "{cmd}: {err}");
        assert!(!out.exists());
    }
}

/// Issue 23: a deformation translated by 1e160 (exactly C1, but its f64 positions keep no
/// digit of the mesh) made the fit blame the landmark file for a singular system; it is
/// refused naming the deformation and the point.
#[test]
fn a_deformation_beyond_the_pixel_range_is_refused_naming_the_file_and_the_point() {
    use num_rational::BigRational;
    let dir = tempfile::tempdir().unwrap();
    let def = reference(dir.path());
    let lms = dir.path().join("l.csv");
    write_landmarks(&lms, 12);
    let mut v: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&def).unwrap()).unwrap();
    let big: BigRational = "1".parse::<BigRational>().unwrap()
        * BigRational::from_integer(num_bigint::BigInt::from(10u32).pow(160));
    for p in v["exact"]["points"].as_array_mut().unwrap() {
        let x: BigRational = p[0].as_str().unwrap().parse().unwrap();
        p[0] = serde_json::Value::String((x + &big).to_string());
    }
    for p in v["points"].as_array_mut().unwrap() {
        p[0] = serde_json::json!(p[0].as_f64().unwrap() + 1e160);
    }
    let far = dir.path().join("far.json");
    fs::write(&far, serde_json::to_string(&v).unwrap()).unwrap();
    let out = dir.path().join("fit.json");
    let o = trimorph(&["fit", s(&far), "--landmarks", s(&lms), "-o", s(&out)]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("far.json") && stderr.contains("control point 0"), "{stderr}");
    assert!(stderr.contains("beyond") && !stderr.contains("l.csv"), "{stderr}");
    assert!(!out.exists());
}

/// Bug (issue 19): the CLI parsed `--loss`, `--min-det` and `--bend` itself, and accepted
/// `--loss huber --loss-scale=0` (a Huber loss of scale 0). It now uses the library's
/// parsers (`Loss::from_name`, `Barrier::with_floor`, `Bend::from_str`), so both refuse the
/// same values: exit 1, naming the option, nothing written.
#[test]
fn solver_options_are_checked_by_the_library_parsers() {
    let dir = tempfile::tempdir().unwrap();
    let lms = dir.path().join("l.csv");
    fs::write(&lms, "name,src_x,src_y,dst_x,dst_y\na,10,10,11,10\nb,50,10,50,12\nc,30,40,31,41\n")
        .unwrap();
    let out = dir.path().join("f.json");
    for (extra, want) in [
        (&["--loss", "huber", "--loss-scale=0"][..], "--loss: the huber loss needs a finite scale"),
        (&["--loss", "cauchy", "--loss-scale=inf"], "--loss: the cauchy loss needs a finite scale"),
        (&["--loss", "l1"], "--loss: unknown loss `l1`"),
        (&["--min-det", "1.5"], "--min-det: the determinant floor must be a number below 1"),
        (&["--bend=-1e-3"], "--bend: `-1e-3` is neither `auto` nor a finite number >= 0"),
    ] {
        let mut a = vec!["fit", "--size", "60,50", "--landmarks", s(&lms), "-o", s(&out)];
        a.extend_from_slice(extra);
        let o = trimorph(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{extra:?}: {err}");
        assert!(err.contains(want), "{extra:?}: {err}");
        assert!(!out.exists());
    }
    // The accepted forms still fit.
    ok(&trimorph(&[
        "fit",
        "--size",
        "60,50",
        "--landmarks",
        s(&lms),
        "-o",
        s(&out),
        "--loss",
        "l2",
        "--bend",
        " auto ",
    ]));
}

/// `fit --size` surrounds the adapted mesh with two far-field rings by default (the mesh
/// reaches 16 times the domain's size), `--far-rings 0` leaves the domain's border free,
/// and `mesh --landmarks --far-rings 1` writes the rings too. Either fit covers the frame.
#[test]
fn far_rings_extend_the_fitted_mesh_and_can_be_turned_off() {
    let dir = tempfile::tempdir().unwrap();
    let lms = dir.path().join("l.csv");
    write_landmarks(&lms, 30);
    let bbox = |p: &Path| {
        let text = fs::read_to_string(p).unwrap();
        trimorph::io::deformation::from_str(&text).unwrap().0.mesh().bbox()
    };
    let fit = |extra: &[&str], name: &str| {
        let (out, rep) = (dir.path().join(name), dir.path().join(format!("{name}.rep.json")));
        let mut a = vec!["fit", "--landmarks", s(&lms), "--size", "200,150", "-o", s(&out)];
        a.extend_from_slice(&["--report", s(&rep)]);
        a.extend_from_slice(extra);
        ok(&trimorph(&a));
        let r: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(&rep).unwrap()).unwrap();
        assert_eq!(r["frame"]["covers_frame"], true, "{r}");
        assert_eq!(r["fold_free"], true, "{r}");
        (bbox(&out), r["frame"]["margin"].as_f64().unwrap())
    };
    let ((lo, hi), m) = fit(&[], "ringed.json");
    let (w, h) = (200.0 + 2.0 * m, 150.0 + 2.0 * m);
    assert!((hi[0] - lo[0] - 16.0 * w).abs() < 1.0 && (hi[1] - lo[1] - 16.0 * h).abs() < 1.0);
    let ((lo, hi), m) = fit(&["--far-rings", "0"], "free.json");
    assert_eq!((lo, hi), ([-0.5 - m, -0.5 - m], [199.5 + m, 149.5 + m]));
    let mesh = dir.path().join("mesh.json");
    let a = ["mesh", "--landmarks", s(&lms), "--size", "200,150", "--far-rings", "1"];
    ok(&trimorph(&[&a[..], &["-o", s(&mesh)]].concat()));
    let (lo, hi) = bbox(&mesh);
    assert!((hi[0] - lo[0] - 4.0 * 240.0).abs() < 1.0, "{lo:?} {hi:?}");
}
