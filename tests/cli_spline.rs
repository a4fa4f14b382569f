//! `trimorph mesh`, `edit` and `check` from outside, through the binary.

mod common;
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
    let res = rep["c1_residuals"].as_array().unwrap();
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
    let o = trimorph(&[
        "edit",
        id.to_str().unwrap(),
        "--script",
        script.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
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
    ok(&trimorph(&[
        "edit",
        id.to_str().unwrap(),
        "--script",
        script.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]));
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
        let r = trimorph(&[
            "edit",
            id.to_str().unwrap(),
            "--script",
            f.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
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
    let r = trimorph(&[
        "edit",
        bad.to_str().unwrap(),
        "--script",
        f.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.status.code(), Some(1));
    let r = trimorph(&["check", bad.to_str().unwrap()]);
    assert_eq!(r.status.code(), Some(1));
    let rep: Value = serde_json::from_slice(&r.stdout).unwrap();
    assert_eq!(rep["c1_holds"], false);
    assert!(rep["c1_nonzero_residuals"].as_u64().unwrap() > 0);
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
    ok(&trimorph(&[
        "edit",
        id.to_str().unwrap(),
        "--script",
        script.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]));
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
    let r = trimorph(&[
        "edit",
        out.to_str().unwrap(),
        "--script",
        script.to_str().unwrap(),
        "-o",
        out2.to_str().unwrap(),
    ]);
    assert_eq!(r.status.code(), Some(2), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(String::from_utf8_lossy(&r.stderr).contains("not weakly solvable"));
    assert!(!out2.exists());
    // A constraint that does not hold is refused.
    std::fs::write(
        &script,
        json!([{"op": "constrain", "vertical": [[row[0], row[1]]]}]).to_string(),
    )
    .unwrap();
    let r = trimorph(&[
        "edit",
        id.to_str().unwrap(),
        "--script",
        script.to_str().unwrap(),
        "-o",
        out2.to_str().unwrap(),
    ]);
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
