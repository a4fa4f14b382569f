//! One rule for every command (issue 54): an output that is one of the command's inputs, or
//! another of its outputs, is refused before anything runs, with exit 1, a message naming
//! both files, and every file left byte for byte as it was.

use crate::common;
use common::{ok, s, trimorph};
use std::fs;
use std::path::{Path, PathBuf};

/// Runs `args`, expects the clash refusal naming `role`, and checks that every file of the
/// folder is unchanged.
fn refused(d: &Path, args: &[&str], role: &str, other: &str) {
    let before = snapshot(d);
    let o = trimorph(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
    assert!(
        err.contains(&format!("{role} ")) && err.contains(&format!("is the same file as {other}")),
        "{args:?}: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(snapshot(d), before, "{args:?} changed a file");
}

fn snapshot(d: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<(PathBuf, Vec<u8>)> = fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let b = fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    v.sort();
    v
}

/// Every command that reads and writes files, each with an output set to one of its inputs
/// (through another spelling of the path where it can), then outputs set to each other.
#[test]
fn every_command_refuses_to_write_over_its_inputs_or_twice_to_one_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |n: &str| d.join(n);
    let def = p("def.json");
    ok(&trimorph(&["mesh", "--grid", "3x3", "--size", "60,60", "-o", s(&def)]));
    let img = p("img.png");
    image::GrayImage::from_fn(60, 60, |x, y| image::Luma([(x * 3 + y * 2) as u8]))
        .save(&img)
        .unwrap();
    let img2 = p("img2.png");
    image::GrayImage::from_fn(60, 60, |x, y| image::Luma([(x * 2 + y * 3) as u8]))
        .save(&img2)
        .unwrap();
    fs::write(p("pts.csv"), "x,y\n10,10\n50,12\n30,45\n12,40\n").unwrap();
    fs::write(
        p("lms.csv"),
        "name,src_x,src_y,dst_x,dst_y\na,10,10,11,10\nb,50,12,50,13\nc,30,45,31,44\nd,12,40,12,41\n",
    )
    .unwrap();
    fs::write(p("script.json"), r#"[{"op": "translate", "anchors": [0], "by": [1, 0]}]"#).unwrap();
    fs::copy("examples/pump.json", p("problem.json")).unwrap();
    fs::copy("data/models/ant.ply", p("ant.ply")).unwrap();
    let dotted = |n: &str| format!("{}/./{n}", d.display());
    let (def_s, img_s, img2_s) = (s(&def).to_string(), s(&img).to_string(), s(&img2).to_string());
    let (pts, lms, script) = (p("pts.csv"), p("lms.csv"), p("script.json"));
    let (pts_s, lms_s, script_s) =
        (s(&pts).to_string(), s(&lms).to_string(), s(&script).to_string());
    let problem = s(&p("problem.json")).to_string();
    let ant = s(&p("ant.ply")).to_string();
    let out = |n: &str| s(&p(n)).to_string();
    let cases: Vec<(Vec<String>, &str, &str)> = vec![
        (
            vec!["solve".into(), problem.clone(), "-o".into(), problem.clone()],
            "--output",
            "the input SYSTEM",
        ),
        (
            vec!["mesh".into(), "--points".into(), pts_s.clone(), "-o".into(), dotted("pts.csv")],
            "--output",
            "the input --points",
        ),
        (
            vec![
                "edit".into(),
                def_s.clone(),
                "--script".into(),
                script_s.clone(),
                "-o".into(),
                dotted("def.json"),
            ],
            "--output",
            "the input DEFORMATION",
        ),
        (
            vec![
                "edit".into(),
                def_s.clone(),
                "--script".into(),
                script_s.clone(),
                "-o".into(),
                script_s.clone(),
            ],
            "--output",
            "the input --script",
        ),
        (
            vec![
                "render".into(),
                def_s.clone(),
                "--background".into(),
                img_s.clone(),
                "-o".into(),
                img_s.clone(),
            ],
            "--output",
            "the input --background",
        ),
        (
            vec![
                "model".into(),
                "bind".into(),
                "--model".into(),
                ant.clone(),
                "-o".into(),
                ant.clone(),
            ],
            "--output",
            "the input --model",
        ),
        (
            vec!["colormesh".into(), img_s.clone(), "-o".into(), img_s.clone()],
            "--output",
            "the input IMAGE",
        ),
        (
            vec![
                "warp".into(),
                def_s.clone(),
                "--image".into(),
                img_s.clone(),
                "-o".into(),
                dotted("img.png"),
            ],
            "--output",
            "the input --image",
        ),
        (
            vec![
                "warp".into(),
                def_s.clone(),
                "--points".into(),
                pts_s.clone(),
                "-o".into(),
                pts_s.clone(),
            ],
            "--output",
            "the input --points",
        ),
        (
            vec!["field".into(), def_s.clone(), "-o".into(), def_s.clone()],
            "--output",
            "the input DEFORMATION",
        ),
        (
            vec!["match".into(), img_s.clone(), img2_s.clone(), "-o".into(), img_s.clone()],
            "--output",
            "the input image A",
        ),
        (
            vec![
                "fit".into(),
                def_s.clone(),
                "--landmarks".into(),
                lms_s.clone(),
                "-o".into(),
                dotted("lms.csv"),
            ],
            "--output",
            "the input --landmarks",
        ),
        (
            vec!["register".into(), img_s.clone(), img2_s.clone(), "-o".into(), img2_s.clone()],
            "--output",
            "the input MOVING",
        ),
        (
            vec![
                "morph".into(),
                img_s.clone(),
                img2_s.clone(),
                "--landmarks".into(),
                lms_s.clone(),
                "-o".into(),
                out("m"),
                "--gif".into(),
                img_s.clone(),
            ],
            "--gif",
            "the input image A",
        ),
        // Two outputs on one file.
        (
            vec![
                "fit".into(),
                "--size".into(),
                "60,60".into(),
                "--landmarks".into(),
                lms_s.clone(),
                "-o".into(),
                out("f.json"),
                "--report".into(),
                dotted("f.json"),
            ],
            "--report",
            "the output --output",
        ),
        (
            vec![
                "field".into(),
                def_s.clone(),
                "-o".into(),
                out("j.png"),
                "--jacobian".into(),
                out("j.png"),
            ],
            "--jacobian",
            "the output --output",
        ),
        (
            vec![
                "register".into(),
                img_s.clone(),
                img2_s.clone(),
                "-o".into(),
                out("r.json"),
                "--warped".into(),
                out("w.png"),
                "--overlay".into(),
                out("w.png"),
            ],
            "--overlay",
            "the output --warped",
        ),
        (
            vec![
                "morph".into(),
                img_s.clone(),
                img2_s.clone(),
                "--landmarks".into(),
                lms_s.clone(),
                "--frames".into(),
                "4".into(),
                "-o".into(),
                out("m"),
                "--apng".into(),
                format!("{}/frame_002.png", out("m")),
            ],
            "--output",
            "the output --apng",
        ),
    ];
    for (args, role, other) in &cases {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(d, &a, role, other);
    }
    // The same commands with distinct files run (the rule refuses clashes only).
    ok(&trimorph(&[
        "fit",
        "--size",
        "60,60",
        "--landmarks",
        &lms_s,
        "-o",
        &out("f.json"),
        "--report",
        &out("f_report.json"),
    ]));
    ok(&trimorph(&["warp", &def_s, "--image", &img_s, "-o", &out("img_warped.png")]));
}
