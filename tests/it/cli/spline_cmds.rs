//! `trimorph mesh`, `edit` and `check` from outside, through the binary.

use crate::common;
use common::*;

use serde_json::{json, Value};
use std::path::Path;

fn read(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn check(p: &Path) -> Value {
    let o = trimorph(&["check", p.to_str().unwrap()]);
    ok(&o);
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn grid_mesh_counts_and_identity_check() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", out.to_str().unwrap()]));
    let doc = read(&out);
    assert_eq!(doc["format"], "trimorph.deformation");
    assert_eq!(doc["version"], 1);
    assert_eq!(doc["degree"], 5);
    assert_eq!(doc["points"].as_array().unwrap().len(), 121);
    assert_eq!(doc["patches"][0].as_array().unwrap().len(), 21);
    let rep = check(&out);
    assert_eq!(rep["c1_conditions"], 40);
    assert!(rep.get("c1_residuals").is_none(), "the list only with --residuals");
    let o = trimorph(&["check", out.to_str().unwrap(), "--residuals"]);
    ok(&o);
    let full: Value = serde_json::from_slice(&o.stdout).unwrap();
    let res = full["c1_residuals"].as_array().unwrap();
    assert_eq!(res.len(), 40);
    assert!(res.iter().all(|r| r == &json!(["0", "0"])));
    assert_eq!(rep["c1_holds"], true);
    assert_eq!(rep["folds"], false);
    assert!((rep["min_jacobian_det"].as_f64().unwrap() - 1.0).abs() < 1e-9);
}

#[test]
fn points_and_obj_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let pts = dir.path().join("pts.csv");
    std::fs::write(&pts, "x,y\n0,0\n100,0\n100,80\n0,80\n50,40\n30,60\n").unwrap();
    let out = dir.path().join("d.json");
    ok(&trimorph(&[
        "mesh",
        "--points",
        pts.to_str().unwrap(),
        "--degree",
        "6",
        "-o",
        out.to_str().unwrap(),
    ]));
    assert_eq!(read(&out)["degree"], 6);
    assert_eq!(check(&out)["c1_holds"], true);
    let obj = dir.path().join("t.obj");
    std::fs::write(&obj, "v 0 0 1\nv 10 0 1\nv 10 10 1\nv 0 10 1\nf 1 2 3\nf 1 3 4\n").unwrap();
    let out2 = dir.path().join("o.json");
    ok(&trimorph(&[
        "mesh",
        "--obj",
        obj.to_str().unwrap(),
        "--z-range",
        "-1,1",
        "-o",
        out2.to_str().unwrap(),
    ]));
    let doc = read(&out2);
    assert_eq!(doc["z_range"], json!([-1.0, 1.0]));
    assert_eq!(doc["exact"]["z0"][0], "-1");
}

#[test]
fn bad_mesh_inputs_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.json");
    let o = out.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["mesh", "-o", o], "exactly one of"),
        (vec!["mesh", "--grid", "2x", "--size", "1,1", "-o", o], "--grid"),
        (vec!["mesh", "--grid", "2x2", "-o", o], "--size"),
        (vec!["mesh", "--grid", "2x2", "--size", "10,10", "--degree", "0", "-o", o], "degree"),
    ];
    for (args, needle) in cases {
        let r = trimorph(&args);
        assert_eq!(r.status.code(), Some(1), "{args:?}");
        assert!(
            String::from_utf8_lossy(&r.stderr).contains(needle),
            "{args:?}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        assert!(!out.exists());
    }
    let pts = dir.path().join("line.csv");
    std::fs::write(&pts, "0,0\n1,1\n2,2\n").unwrap();
    let r = trimorph(&["mesh", "--points", pts.to_str().unwrap(), "-o", o]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).to_lowercase().contains("collinear"));
}

/// `mesh --z-range` is parsed by clap (`prism::ZRange`): a bad value exits 1 with
/// `error: --z-range: reason` before any mesh is built, and nothing is written.
#[test]
fn bad_z_ranges_are_refused_by_the_option_parser() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("z.json");
    let o = out.to_str().unwrap();
    for (value, want) in [
        ("1", "error: --z-range: expected A,B"),
        ("1,0", "error: --z-range: need A < B"),
        ("-1,-1", "error: --z-range: need A < B"),
        ("a,1", "error: --z-range: `a` is not an exact number"),
        // Bug (issue 54): accepted, then `warp --model` wrote NaN coordinates.
        ("-1e400,1e400", "error: --z-range: a negative number of about 401 digits is too large"),
        ("0,2e12", "error: --z-range: 2e12 is too large: z values must be below 2^40"),
    ] {
        let args = ["mesh", "--grid", "2x2", "--size", "10,10", "--z-range", value, "-o", o];
        let r = trimorph(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{value}: {err}");
        assert!(err.starts_with(want), "{value}: {err}");
        assert!(!out.exists());
    }
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "10,10", "--z-range", "-1/2,3", "-o", o]));
    assert_eq!(read(&out)["exact"]["z_range"], json!(["-1/2", "3"]));
}

#[test]
fn edit_script_translate_rotate_scale() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "4x3", "--size", "400,300", "-o", id.to_str().unwrap()]));
    let script = dir.path().join("edits.json");
    std::fs::write(
        &script,
        json!([
            {"anchors": {"near": [[200, 100]]}, "neighborhood": 3, "op": "translate", "by": [12.5, "-7/2"]},
            {"anchors": {"near": [[100, 200]]}, "op": "rotate", "center": [100, 200], "angle": 0.2},
            {"anchors": {"near": [[300, 200]]}, "neighborhood": "all", "op": "scale", "center": [300, 200], "factor": 1.25}
        ])
        .to_string(),
    )
    .unwrap();
    let out = dir.path().join("out.json");
    let o = edit_script(&id, &script, &out);
    ok(&o);
    let doc = read(&out);
    assert!(doc["last_edit"]["anchors"].as_array().unwrap().len() == 1);
    let rep = check(&out);
    assert_eq!(rep["c1_holds"], true);
    assert_eq!(rep["c1_max_abs_residual"], "0");
}

#[test]
fn translated_anchor_lands_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "4x3", "--size", "400,300", "-o", id.to_str().unwrap()]));
    let script = dir.path().join("t.json");
    std::fs::write(
        &script,
        json!([{"anchors": {"near": [[200, 100]]}, "op": "translate", "by": [12.5, "-7/2"]}])
            .to_string(),
    )
    .unwrap();
    let out = dir.path().join("out.json");
    ok(&edit_script(&id, &script, &out));
    let doc = read(&out);
    // The control point at (200, 100) (a mesh vertex) moved by exactly (12.5, -3.5).
    let v = doc["vertices"]
        .as_array()
        .unwrap()
        .iter()
        .position(|v| v == &json!([200.0, 100.0]))
        .unwrap();
    assert_eq!(doc["exact"]["points"][v], json!(["425/2", "193/2"]));
    assert_eq!(doc["last_edit"]["anchors"], json!([v]));
    // Points outside the edit are untouched: compare with the identity file.
    let before = read(&id);
    let moved: Vec<u64> = doc["last_edit"]["derived"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    for (i, (a, b)) in before["exact"]["points"]
        .as_array()
        .unwrap()
        .iter()
        .zip(doc["exact"]["points"].as_array().unwrap())
        .enumerate()
    {
        if i != v && !moved.contains(&(i as u64)) {
            assert_eq!(a, b, "point {i}");
        }
    }
}

#[test]
fn unsolvable_or_bad_scripts_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", id.to_str().unwrap()]));
    let out = dir.path().join("out.json");
    let cases = [
        (json!([{"anchors": [0], "op": "fly"}]), 1, "unknown op"),
        (json!([{"anchors": [99999], "op": "translate", "by": [1, 1]}]), 1, "does not exist"),
        (json!([{"anchors": [0], "op": "translate", "by": [1]}]), 1, "2 values"),
        (json!({"anchors": [0]}), 1, "array"),
        (json!([{"anchors": [0], "mode": "z0", "op": "translate", "by": [1]}]), 1, "2.5D"),
    ];
    for (script, code, needle) in cases {
        let f = dir.path().join("s.json");
        std::fs::write(&f, script.to_string()).unwrap();
        let r = edit_script(&id, &f, &out);
        assert_eq!(r.status.code(), Some(code), "{script}");
        assert!(
            String::from_utf8_lossy(&r.stderr).contains(needle),
            "{script}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        assert!(!out.exists());
    }
    // A broken file is refused by edit and reported by check.
    let mut doc = read(&id);
    doc["exact"]["points"][40] = json!(["1/3", "0"]);
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, doc.to_string()).unwrap();
    let f = dir.path().join("s.json");
    std::fs::write(&f, json!([{"anchors": [0], "op": "translate", "by": [1, 1]}]).to_string())
        .unwrap();
    let r = edit_script(&bad, &f, &out);
    assert_eq!(r.status.code(), Some(1));
    let r = trimorph(&["check", bad.to_str().unwrap()]);
    assert_eq!(r.status.code(), Some(1));
    let rep: Value = serde_json::from_slice(&r.stdout).unwrap();
    assert_eq!(rep["c1_holds"], false);
    let n = rep["c1_nonzero_residuals"].as_u64().unwrap();
    assert!(n > 0);
    let err = String::from_utf8_lossy(&r.stderr);
    let total = rep["c1_conditions"].as_u64().unwrap();
    assert!(err.contains(&format!("C1 FAILS ({n} of {total} conditions nonzero")), "{err}");
}

/// `check` prints thousands of `"0"` lines no more: the JSON keeps every key but
/// `c1_residuals` (only with `--residuals`), and stderr has one summary line with the C1
/// verdict and count, the fold-free verdict, the sampled minimum and the certified bound.
#[test]
fn check_prints_a_one_line_summary_and_residuals_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "8x6", "--size", "160,120", "-o", out.to_str().unwrap()]));
    let short = trimorph(&["check", out.to_str().unwrap()]);
    ok(&short);
    let stdout = String::from_utf8_lossy(&short.stdout);
    assert!(stdout.lines().count() < 40, "{stdout}");
    let rep: Value = serde_json::from_str(&stdout).unwrap();
    let err = String::from_utf8_lossy(&short.stderr);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{err}");
    let n = rep["c1_conditions"].as_u64().unwrap();
    assert!(n > 300);
    let line = lines[0];
    assert!(line.starts_with(&format!("{}: C1 holds ({n} of {n}", out.display())), "{line}");
    assert!(line.contains("certified fold-free") && !line.contains("NOT"), "{line}");
    let lb = rep["det_j_lower_bound"].as_f64().unwrap();
    assert!(line.contains(&format!("sampled min {:.6}", rep["min_jacobian_det"].as_f64().unwrap())));
    assert!(line.contains(&format!("certified lower bound {lb:.6}")), "{line}");
    let full = trimorph(&["check", out.to_str().unwrap(), "--residuals"]);
    ok(&full);
    let mut full: Value = serde_json::from_slice(&full.stdout).unwrap();
    let list = full.as_object_mut().unwrap().remove("c1_residuals").unwrap();
    assert_eq!(list.as_array().unwrap().len() as u64, n);
    assert_eq!(full, rep, "every other key is the same with and without --residuals");
}

#[test]
fn render_writes_png_with_and_without_background() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "3x2", "--size", "120,80", "-o", id.to_str().unwrap()]));
    let png = dir.path().join("r.png");
    ok(&trimorph(&[
        "render",
        id.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--show",
        "all",
        "--size",
        "300,200",
    ]));
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // A background sets the output size.
    let bg = dir.path().join("bg.png");
    image::GrayImage::from_pixel(120, 80, image::Luma([90u8])).save(&bg).unwrap();
    let png2 = dir.path().join("r2.png");
    ok(&trimorph(&[
        "render",
        id.to_str().unwrap(),
        "-o",
        png2.to_str().unwrap(),
        "--background",
        bg.to_str().unwrap(),
    ]));
    let img = image::open(&png2).unwrap();
    assert_eq!((img.width(), img.height()), (120, 80));
    let bad = trimorph(&[
        "render",
        id.to_str().unwrap(),
        "-o",
        png2.to_str().unwrap(),
        "--show",
        "sparkles",
    ]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("sparkles"));
    let missing = trimorph(&[
        "render",
        id.to_str().unwrap(),
        "-o",
        png2.to_str().unwrap(),
        "--background",
        "/nonexistent.png",
    ]);
    assert_eq!(missing.status.code(), Some(1));
}

#[test]
fn constraints_in_scripts_persist_and_can_make_edits_unsolvable() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "4x3", "--size", "80,60", "-o", id.to_str().unwrap()]));
    let doc = read(&id);
    let vertex = |x: f64, y: f64| {
        doc["vertices"].as_array().unwrap().iter().position(|v| v == &json!([x, y])).unwrap()
    };
    let row: Vec<usize> = [0.0, 20.0, 40.0, 60.0, 80.0].iter().map(|&x| vertex(x, 20.0)).collect();
    let a = vertex(40.0, 40.0);
    let script = dir.path().join("s.json");
    std::fs::write(
        &script,
        json!([
            {"op": "constrain", "horizontal": [row], "pin": [a]},
            {"anchors": [row[2]], "neighborhood": 1, "op": "translate", "by": [1, 3]}
        ])
        .to_string(),
    )
    .unwrap();
    let out = dir.path().join("out.json");
    ok(&edit_script(&id, &script, &out));
    let d = read(&out);
    assert_eq!(d["constraints"].as_array().unwrap().len(), 2);
    for &p in &row {
        assert_eq!(d["exact"]["points"][p][1], "23", "point {p} left the line");
    }
    assert_eq!(d["exact"]["points"][a], json!(["40", "40"]));
    // The stored pin makes moving that vertex unsolvable: exit 2, nothing written.
    std::fs::write(&script, json!([{"anchors": [a], "op": "translate", "by": [1, 0]}]).to_string())
        .unwrap();
    let out2 = dir.path().join("out2.json");
    let r = edit_script(&out, &script, &out2);
    assert_eq!(r.status.code(), Some(2), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(String::from_utf8_lossy(&r.stderr).contains("not weakly solvable"));
    assert!(!out2.exists());
    // A constraint that does not hold is refused.
    std::fs::write(
        &script,
        json!([{"op": "constrain", "vertical": [[row[0], row[1]]]}]).to_string(),
    )
    .unwrap();
    let r = edit_script(&id, &script, &out2);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("vertical line"));
}

/// Bug: `check --samples 18446744073709551615` scanned forever; the count is now bounded.
#[test]
fn check_refuses_a_sample_count_that_would_never_finish() {
    let dir = tempfile::tempdir().unwrap();
    let def = dir.path().join("d.json");
    ok(&trimorph(&["mesh", "--grid", "1x1", "--size", "10,10", "-o", def.to_str().unwrap()]));
    let o = trimorph(&["check", def.to_str().unwrap(), "--samples", "18446744073709551615"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("at most 1000 samples"));
    ok(&trimorph(&["check", def.to_str().unwrap(), "--samples", "1000"]));
}

/// A deformation file of the shift `phi(p) = p + b` on a 3 x 2 grid over `[0, w] x [0, h]`.
fn shifted_file(dir: &Path, w: f64, h: f64, b: [i64; 2]) -> std::path::PathBuf {
    use trimorph::exact::{rat_int, Rat};
    let mesh = trimorph::mesh::Mesh::grid(3, 2, w, h, Default::default()).unwrap();
    let id = trimorph::spline::Spline::identity(mesh.clone(), 5).unwrap();
    let pts: Vec<Vec<Rat>> =
        id.points().iter().map(|p| vec![&p[0] + rat_int(b[0]), &p[1] + rat_int(b[1])]).collect();
    let s = trimorph::spline::Spline::from_points(mesh, 5, pts, None).unwrap();
    let path = dir.join("shift.json");
    std::fs::write(&path, trimorph::io::deformation::to_string(&s, None)).unwrap();
    path
}

/// `render --landmarks`: the source as an orange cross, phi(source) as a green dot, the target
/// as a magenta ring and the residual line between them, at their pixels over a background;
/// the same landmarks as JSON draw the same picture; with `--model` it is refused.
#[test]
fn render_draws_landmarks_where_they_are() {
    use trimorph::render::deformation::{LM_MAPPED, LM_RESIDUAL, LM_SOURCE, LM_TARGET};
    let dir = tempfile::tempdir().unwrap();
    let def = shifted_file(dir.path(), 300.0, 200.0, [20, 10]);
    let bg = dir.path().join("black.png");
    image::RgbaImage::from_pixel(400, 300, image::Rgba([0, 0, 0, 255])).save(&bg).unwrap();
    let lms = dir.path().join("l.csv");
    std::fs::write(&lms, "name,src_x,src_y,dst_x,dst_y\na,150,100,210,160\nb,100,150,90,200\n")
        .unwrap();
    let draw = |extra: &[&str], name: &str| {
        let out = dir.path().join(name);
        let mut args = vec!["render", s(&def), "-o", s(&out), "--background", s(&bg)];
        args.extend_from_slice(&["--show", "mesh"]);
        args.extend_from_slice(extra);
        ok(&trimorph(&args));
        image::open(&out).unwrap().to_rgb8()
    };
    let with = draw(&["--landmarks", s(&lms)], "with.png");
    let without = draw(&[], "without.png");
    let near = |img: &image::RgbImage, (x, y): (u32, u32), c: [u8; 4], r: u32| {
        let close = |p: &image::Rgb<u8>| (0..3).all(|k| p.0[k].abs_diff(c[k]) <= 40);
        (y - r..=y + r).any(|yy| (x - r..=x + r).any(|xx| close(img.get_pixel(xx, yy))))
    };
    // phi(s) = s + (20, 10); targets as given; the midpoint of each residual line.
    let checks = [
        ("phi(a)", (170, 110), LM_MAPPED, 0),
        ("phi(b)", (120, 160), LM_MAPPED, 0),
        ("source a", (150, 100), LM_SOURCE, 1),
        ("source b", (100, 150), LM_SOURCE, 1),
        ("target a", (215, 160), LM_TARGET, 1),
        ("target b", (90, 205), LM_TARGET, 1),
        ("residual a", (190, 135), LM_RESIDUAL, 1),
        ("residual b", (105, 180), LM_RESIDUAL, 1),
    ];
    for (what, at, c, r) in checks {
        assert!(near(&with, at, c, r), "{what}: {:?} at {at:?}", with.get_pixel(at.0, at.1));
        assert!(!near(&without, at, c, r), "{what}: without --landmarks");
    }
    // The same landmarks in JSON draw the same picture.
    let json = dir.path().join("l.json");
    let text = r#"{"landmarks": [{"name": "a", "src": [150, 100], "dst": [210, 160]},
                   {"name": "b", "src": [100, 150], "dst": [90, 200]}]}"#;
    std::fs::write(&json, text).unwrap();
    assert!(draw(&["--landmarks", s(&json)], "json.png") == with, "JSON = CSV");
    // Without a background the view fits the landmarks in too.
    let out = dir.path().join("fit.png");
    ok(&trimorph(&["render", s(&def), "-o", s(&out), "--landmarks", s(&lms)]));
    let img = image::open(&out).unwrap().to_rgb8();
    assert!(img.pixels().any(|p| p.0 == [LM_MAPPED[0], LM_MAPPED[1], LM_MAPPED[2]]));
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "name,src_x,src_y,dst_x,dst_y\na,1,2,x,4\n").unwrap();
    let o = trimorph(&["render", s(&def), "-o", s(&out), "--landmarks", s(&bad)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains(s(&bad)));
}
