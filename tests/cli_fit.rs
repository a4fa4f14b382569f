//! `trimorph fit` through the binary: single fits, reports, hard mode, errors and exit codes,
//! frame sequences (tracking, resumability, shards).

mod common;
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

/// A textured frame and the same frame shifted by (dx, dy).
fn frame(dx: f64, dy: f64) -> image::GrayImage {
    image::GrayImage::from_fn(160, 120, |x, y| {
        let (u, v) = (x as f64 - dx, y as f64 - dy);
        let g = 128.0 + 60.0 * (u / 7.0).sin() * (v / 9.0).cos() + 40.0 * ((u + v) / 13.0).sin();
        image::Luma([g.clamp(0.0, 255.0) as u8])
    })
}

#[test]
fn frame_sequences_track_resume_and_shard() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    fs::create_dir_all(&frames).unwrap();
    for k in 0..4 {
        frame(1.5 * k as f64, -(k as f64)).save(frames.join(format!("f{k}.png"))).unwrap();
    }
    let scene = dir.path().join("scene.json");
    ok(&trimorph(&["mesh", "--grid", "4x3", "--size", "160,120", "-o", s(&scene)]));
    let lms = dir.path().join("l.csv");
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    for (i, p) in
        [[40.0, 30.0], [120.0, 30.0], [40.0, 90.0], [120.0, 90.0], [80.0, 60.0], [60.0, 45.0]]
            .iter()
            .enumerate()
    {
        csv += &format!("m{i},{},{},{},{}\n", p[0], p[1], p[0], p[1]);
    }
    fs::write(&lms, csv).unwrap();
    let out = dir.path().join("out");
    let run = |extra: &[&str]| {
        let mut a = vec![
            "fit",
            "--model",
            s(&scene),
            "--frames",
            s(&frames),
            "--landmarks",
            s(&lms),
            "--track",
            "-o",
            s(&out),
        ];
        a.extend_from_slice(extra);
        let o = trimorph(&a);
        ok(&o);
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let first = run(&["--shard", "0/2"]);
    assert!(first.contains("2 frames fitted") && first.contains("frames 0..2 of 4"), "{first}");
    assert!(!out.join("f2.report.json").exists());
    let second = run(&[]);
    assert!(second.contains("2 frames fitted, 2 skipped"), "{second}");
    for k in 0..4 {
        for ext in ["json", "registered.png", "overlay.png", "report.json"] {
            assert!(out.join(format!("f{k}.{ext}")).exists(), "f{k}.{ext}");
        }
    }
    // The tracked motion is the frames' shift: frame 3 moved by (4.5, -3).
    let r: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("f3.report.json")).unwrap()).unwrap();
    let res = r["residuals"].as_array().unwrap();
    assert!(res.len() >= 4, "tracked landmarks left: {}", res.len());
    for l in res {
        let (src, dst) = (&l["src"], &l["dst"]);
        let d = [
            dst[0].as_f64().unwrap() - src[0].as_f64().unwrap(),
            dst[1].as_f64().unwrap() - src[1].as_f64().unwrap(),
        ];
        assert!((d[0] - 4.5).abs() < 0.5 && (d[1] + 3.0).abs() < 0.5, "tracked shift {d:?}");
    }
}

/// Bug: the cause of an I/O error was printed twice ("...: No such file ...: No such file ...").
#[test]
fn missing_landmark_file_error_names_the_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let def = reference(dir.path());
    let o = trimorph(&[
        "fit",
        s(&def),
        "--landmarks",
        "no-such.csv",
        "-o",
        s(&dir.path().join("o.json")),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no-such.csv"), "{err}");
    assert_eq!(err.matches("os error 2").count(), 1, "{err}");
}

#[test]
fn pin_edited_holds_the_points_an_editor_file_records() {
    let dir = tempfile::tempdir().unwrap();
    let def = reference(dir.path());
    // An editor-saved file: the reference with one corner point recorded as corrected.
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&def).unwrap()).unwrap();
    v["pinned"] = serde_json::json!([7]);
    let edited = dir.path().join("edited.json");
    std::fs::write(&edited, v.to_string()).unwrap();
    let lms = dir.path().join("l.csv");
    std::fs::write(
        &lms,
        "name,src_x,src_y,dst_x,dst_y\na,30,30,33,31\nb,170,30,172,33\nc,30,120,31,118\nd,170,120,173,121\ne,100,75,104,77\n",
    )
    .unwrap();
    let out = dir.path().join("refit.json");
    let o =
        trimorph(&["fit", s(&edited), "--landmarks", s(&lms), "--pin", "edited", "-o", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let a: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&def).unwrap()).unwrap();
    let b: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(a["points"][7], b["points"][7], "pinned point 7 kept exactly");
    assert_ne!(a["points"][20], b["points"][20], "the rest was fitted");
    ok(&trimorph(&["check", s(&out)]));
    // Without recorded points, or with a bad list, the command explains.
    let o = trimorph(&["fit", s(&def), "--landmarks", s(&lms), "--pin", "edited", "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("records no corrected points"));
    let o = trimorph(&["fit", s(&def), "--landmarks", s(&lms), "--pin", "3,x", "-o", s(&out)]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("`x` is not a control point index"));
}
