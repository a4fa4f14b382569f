//! 2.5D from outside: `trimorph model bind / worm`, `edit` in z modes, `warp --model`.

use crate::common;
use common::*;
use std::path::Path;

fn read_obj_vertices(p: &Path) -> Vec<[f64; 3]> {
    std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

#[test]
fn bind_edit_and_warp_a_model_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&trimorph(&["model", "worm", "-o", s(d)]));
    let (worm, prisms) = (d.join("worm.obj"), d.join("worm_prisms.obj"));
    assert!(d.join("worm.landmarks.json").exists());
    let scene = d.join("scene.json");
    let o =
        trimorph(&["model", "bind", "--model", s(&worm), "--mesh", s(&prisms), "-o", s(&scene)]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 outside"));
    let text = std::fs::read_to_string(&scene).unwrap();
    assert!(text.contains("\"z_range\"") && text.contains("\"z0\"") && text.contains("\"z1\""));

    // The identity leaves every vertex in place.
    let same = d.join("same.obj");
    ok(&trimorph(&["warp", s(&scene), "--model", s(&worm), "-o", s(&same)]));
    let (v0, v1) = (read_obj_vertices(&worm), read_obj_vertices(&same));
    assert_eq!(v0.len(), v1.len());
    for (a, b) in v0.iter().zip(&v1) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-9 * (1.0 + a[k].abs()), "{a:?} vs {b:?}");
        }
    }

    // A z1 edit: only z moves; then an xy edit: z stays.
    let script = d.join("z.json");
    std::fs::write(
        &script,
        r#"[{"anchors": {"near": [[500, 0]]}, "mode": "z1", "op": "translate", "by": [40]}]"#,
    )
    .unwrap();
    let zed = d.join("z_edit.json");
    ok(&trimorph(&["edit", s(&scene), "--script", s(&script), "-o", s(&zed)]));
    let zout = d.join("z.obj");
    ok(&trimorph(&["warp", s(&zed), "--model", s(&worm), "-o", s(&zout)]));
    let vz = read_obj_vertices(&zout);
    let mut moved = 0;
    for (a, b) in v1.iter().zip(&vz) {
        assert_eq!((a[0], a[1]), (b[0], b[1]), "a z edit moved x or y");
        moved += ((a[2] - b[2]).abs() > 1e-6) as usize;
    }
    assert!(moved > 100, "{moved}");
    let script = d.join("xy.json");
    std::fs::write(
        &script,
        r#"[{"anchors": {"near": [[250, 100]]}, "op": "translate", "by": [0, -40]}]"#,
    )
    .unwrap();
    let xyed = d.join("xy_edit.json");
    ok(&trimorph(&["edit", s(&zed), "--script", s(&script), "-o", s(&xyed)]));
    let xyout = d.join("xy.ply");
    ok(&trimorph(&["warp", s(&xyed), "--model", s(&worm), "-o", s(&xyout)]));
    let back = trimorph::io::model::load_model(&xyout).unwrap();
    assert_eq!(back.triangles.len(), 20_000);
    for (a, b) in vz.iter().zip(&back.vertices) {
        assert!((a[2] - b[2]).abs() < 1e-9, "an xy edit moved z");
    }
    // The deformed landmarks are written beside the output.
    assert!(d.join("xy.landmarks.json").exists());
    // The edited scene still has exact C1 (check exits 0).
    ok(&trimorph(&["check", s(&xyed)]));
}

#[test]
fn bad_model_inputs_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bad = d.join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 nan 0\n").unwrap();
    let out = d.join("o.json");
    for args in [
        vec!["model", "bind", "--model", s(&bad), "--auto", "-o", s(&out)],
        vec!["model", "bind", "--model", s(&bad), "-o", s(&out)],
    ] {
        let r = trimorph(&args);
        assert_eq!(r.status.code(), Some(1), "{args:?}");
        assert!(!out.exists());
    }
    // A plain 2D deformation has no z layers: warp --model says so.
    let id = d.join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "10,10", "-o", s(&id)]));
    let good = d.join("p.xyz");
    std::fs::write(&good, "1 1 0\n2 2 0\n").unwrap();
    let r = trimorph(&["warp", s(&id), "--model", s(&good), "-o", s(&d.join("o.xyz"))]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("no z layers"));
}

/// `model bind --grid` and `--range` are parsed by clap (`jobs::model::AutoGrid`,
/// `prism::ZRange`): a bad value exits 1 with `error: --flag: reason` and writes nothing; a
/// range may start with a minus sign.
#[test]
fn bad_bind_grids_and_ranges_are_refused_by_the_option_parser() {
    let dir = tempfile::tempdir().unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/models");
    let (worm, prisms) = (data.join("worm.obj"), data.join("worm_prisms.obj"));
    let out = dir.path().join("b.json");
    for (flag, value, want) in [
        ("--grid", "4", "error: --grid: expected COLSxROWS, e.g. 4x2"),
        ("--grid", "0x2", "error: --grid: expected COLSxROWS, e.g. 4x2"),
        ("--grid", "101x100", "error: --grid: expected COLSxROWS, e.g. 4x2"),
        ("--range", "1", "error: --range: expected A,B"),
        ("--range", "2,1", "error: --range: need A < B"),
        ("--range", "x,1", "error: --range: `x` is not an exact number"),
    ] {
        let r =
            trimorph(&["model", "bind", "--model", s(&worm), "--auto", flag, value, "-o", s(&out)]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{flag} {value}: {err}");
        assert!(err.starts_with(want), "{flag} {value}: {err}");
        assert!(!out.exists());
    }
    let o = trimorph(&[
        "model",
        "bind",
        "--model",
        s(&worm),
        "--mesh",
        s(&prisms),
        "--range",
        "-100,100",
        "-o",
        s(&out),
    ]);
    ok(&o);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(v["z_range"], serde_json::json!([-100.0, 100.0]));
}

#[test]
fn the_bundled_real_models_bind_and_warp() {
    let dir = tempfile::tempdir().unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/models");
    for (name, out) in [("bunny.obj", "b.obj"), ("ant.ply", "a.ply")] {
        let m = data.join(name);
        let scene = dir.path().join(format!("{name}.json"));
        let o = trimorph(&["model", "bind", "--model", s(&m), "--auto", "-o", s(&scene)]);
        ok(&o);
        assert!(String::from_utf8_lossy(&o.stdout).contains("0 outside"), "{name}");
        let moved = dir.path().join(out);
        ok(&trimorph(&["warp", s(&scene), "--model", s(&m), "-o", s(&moved)]));
        let (a, b) = (
            trimorph::io::model::load_model(&m).unwrap(),
            trimorph::io::model::load_model(&moved).unwrap(),
        );
        assert_eq!(a.triangles, b.triangles, "{name}: same topology");
        for (p, q) in a.vertices.iter().zip(&b.vertices) {
            assert!((0..3).all(|k| (p[k] - q[k]).abs() < 1e-6 * (1.0 + p[k].abs())), "{name}");
        }
    }
}

#[test]
fn render_a_model_from_the_top_and_obliquely() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/models");
    let (worm, prisms) = (data.join("worm.obj"), data.join("worm_prisms.obj"));
    let scene = d.join("scene.json");
    ok(&trimorph(&["model", "bind", "--model", s(&worm), "--mesh", s(&prisms), "-o", s(&scene)]));
    for view in ["top", "oblique"] {
        let png = d.join(format!("{view}.png"));
        ok(&trimorph(&[
            "render",
            s(&scene),
            "--model",
            s(&worm),
            "--view",
            view,
            "--size",
            "400,300",
            "-o",
            s(&png),
        ]));
        let img = image::open(&png).unwrap().to_rgba8();
        assert_eq!(img.dimensions(), (400, 300));
        // Something other than the white page is drawn near the centre.
        let c = img.get_pixel(200, 150).0;
        let drawn = (150..250).any(|x| img.get_pixel(x, 150).0 != [255, 255, 255, 255]);
        assert!(drawn, "{view}: {c:?}");
    }
    let bad = trimorph(&[
        "render",
        s(&scene),
        "--model",
        s(&worm),
        "--view",
        "side",
        "-o",
        s(&d.join("x.png")),
    ]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(!d.join("x.png").exists());
}

/// Same length, and every coordinate within 1e-9 (relative to 1 + |value|).
fn assert_close(got: &[[f64; 3]], want: &[[f64; 3]]) {
    assert_eq!(got.len(), want.len());
    for (i, (a, b)) in got.iter().zip(want).enumerate() {
        let ok = (0..3).all(|k| (a[k] - b[k]).abs() <= 1e-9 * (1.0 + b[k].abs()));
        assert!(ok, "vertex {i}: {a:?} vs {b:?}");
    }
}

/// The distinct x coordinates of a deformation's mesh vertices, sorted.
fn mesh_xs(scene: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(scene).unwrap();
    let (s, _) = trimorph::io::deformation::from_str(&text).unwrap();
    let mut xs: Vec<f64> = s.mesh().vertices().iter().map(|v| v[0]).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    xs
}

/// OFF models are read wherever OBJ models are; `--up x|y` takes a model whose up axis is
/// not z and writes it back in its own axes; `model bind --snap N` gives a unit-size model an
/// even grid. Before: `.off` was an unknown format, models were always z-up, and the
/// automatic mesh was snapped to 1/16 whatever the model's size.
#[test]
fn off_models_up_axes_and_bind_snap() {
    use trimorph::io::model::{load_model, save_model, UpAxis};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&trimorph(&["model", "worm", "-o", s(d)]));
    let (worm, prisms, scene) = (d.join("worm.obj"), d.join("worm_prisms.obj"), d.join("s.json"));
    ok(&trimorph(&["model", "bind", "--model", s(&worm), "--mesh", s(&prisms), "-o", s(&scene)]));
    let script = d.join("z.json");
    std::fs::write(
        &script,
        r#"[{"anchors": {"near": [[500, 0]]}, "mode": "z1", "op": "translate", "by": [40]},
            {"anchors": {"near": [[250, 100]]}, "op": "translate", "by": [0, -40]}]"#,
    )
    .unwrap();
    let ed = d.join("ed.json");
    ok(&trimorph(&["edit", s(&scene), "--script", s(&script), "-o", s(&ed)]));
    let via_obj = d.join("a.obj");
    ok(&trimorph(&["warp", s(&ed), "--model", s(&worm), "-o", s(&via_obj)]));
    let want = read_obj_vertices(&via_obj);

    // OFF: written by `warp -o X.off` (here the identity), read by warp and bind.
    let off = d.join("worm.off");
    ok(&trimorph(&["warp", s(&scene), "--model", s(&worm), "-o", s(&off)]));
    assert!(std::fs::read_to_string(&off).unwrap().starts_with("OFF\n"));
    let via_off = d.join("b.obj");
    ok(&trimorph(&["warp", s(&ed), "--model", s(&off), "-o", s(&via_off)]));
    assert_close(&read_obj_vertices(&via_off), &want);
    let s_off = d.join("s_off.json");
    let o = trimorph(&["model", "bind", "--model", s(&off), "--mesh", s(&prisms), "-o", s(&s_off)]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 outside"));

    // --up y: the same worm stored y-up.
    let w = load_model(&worm).unwrap();
    let turned: Vec<[f64; 3]> = w.vertices.iter().map(|&v| UpAxis::Y.from_z_up(v)).collect();
    let worm_y = d.join("worm_y.obj");
    save_model(&w, &turned, &worm_y).unwrap();
    let out_y = d.join("c.obj");
    let o = trimorph(&["warp", s(&ed), "--model", s(&worm_y), "--up", "y", "-o", s(&out_y)]);
    ok(&o);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("outside"));
    // Written back in the file's axes (y up).
    let turned_want: Vec<[f64; 3]> = want.iter().map(|&v| UpAxis::Y.from_z_up(v)).collect();
    assert_close(&read_obj_vertices(&out_y), &turned_want);
    // Read z-up, the y-up worm lies across the prisms: vertices fall outside.
    let o = trimorph(&["warp", s(&ed), "--model", s(&worm_y), "-o", s(&d.join("x.obj"))]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("outside the prisms"));
    let o = trimorph(&["warp", s(&ed), "--model", s(&worm_y), "--up", "w", "-o", s(&out_y)]);
    assert_eq!(o.status.code(), Some(1));

    // --snap: a unit-size model's automatic 4 x 2 mesh is even on a 1/1024 grid, uneven on the
    // default 1/16 grid.
    let (lo, hi) = w.bbox();
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let unit: Vec<[f64; 3]> =
        w.vertices.iter().map(|v| [0, 1, 2].map(|k| (v[k] - lo[k]) / size)).collect();
    let small = d.join("unit.obj");
    save_model(&w, &unit, &small).unwrap();
    let spread = |scene: &Path| {
        let xs = mesh_xs(scene);
        let steps: Vec<f64> = xs.windows(2).map(|p| p[1] - p[0]).collect();
        assert_eq!(steps.len(), 4, "{xs:?}");
        steps.iter().fold(0.0f64, |m, &a| m.max(a)) - steps.iter().fold(1.0f64, |m, &a| m.min(a))
    };
    let (coarse, fine) = (d.join("coarse.json"), d.join("fine.json"));
    ok(&trimorph(&["model", "bind", "--model", s(&small), "--auto", "-o", s(&coarse)]));
    ok(&trimorph(&[
        "model",
        "bind",
        "--model",
        s(&small),
        "--auto",
        "--snap",
        "1024",
        "-o",
        s(&fine),
    ]));
    assert!(spread(&coarse) > 0.03, "{}", spread(&coarse));
    assert!(spread(&fine) <= 1.0 / 1024.0 + 1e-12, "{}", spread(&fine));
    let o =
        trimorph(&["model", "bind", "--model", s(&small), "--auto", "--snap", "0", "-o", s(&fine)]);
    assert_eq!(o.status.code(), Some(1));
}

/// Bug (issue 23): `model bind --up y` did not record the axis in the scene, so
/// `fit --model SCENE --frames` read the scene's model z-up (it lay across the prisms) and
/// wrote the fitted models z-up. The scene now records `"model_up"`, and the sequence fit
/// loads the model turned and writes each frame's model in the file's axes.
#[test]
fn a_scene_bound_with_up_y_keeps_the_axis_through_a_sequence_fit() {
    use trimorph::io::model::{load_model, save_model, UpAxis};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&trimorph(&["model", "worm", "-o", s(d)]));
    let (worm, prisms) = (d.join("worm.obj"), d.join("worm_prisms.obj"));
    let w = load_model(&worm).unwrap();
    let turned: Vec<[f64; 3]> = w.vertices.iter().map(|&v| UpAxis::Y.from_z_up(v)).collect();
    let worm_y = d.join("worm_y.obj");
    save_model(&w, &turned, &worm_y).unwrap();
    let scene = d.join("scene_y.json");
    let o = trimorph(&[
        "model",
        "bind",
        "--model",
        s(&worm_y),
        "--mesh",
        s(&prisms),
        "--up",
        "y",
        "-o",
        s(&scene),
    ]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 outside"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&scene).unwrap()).unwrap();
    assert_eq!(v["model_up"], "y");
    // A z-up bind records nothing (its scene stays as it was).
    let scene_z = d.join("scene_z.json");
    ok(&trimorph(&["model", "bind", "--model", s(&worm), "--mesh", s(&prisms), "-o", s(&scene_z)]));
    let vz: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&scene_z).unwrap()).unwrap();
    assert!(vz.get("model_up").is_none());

    // One frame, identity landmarks inside the worm's footprint: the fit is the identity.
    let (lo, hi) = w.bbox();
    let frames = d.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    let (fw, fh) = ((hi[0] + 20.0) as u32, (hi[1] + 20.0) as u32);
    image::GrayImage::from_fn(fw, fh, |x, y| image::Luma([((x + 2 * y) % 251) as u8]))
        .save(frames.join("f0.png"))
        .unwrap();
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    for (i, (a, b)) in
        [(0.3, 0.3), (0.7, 0.3), (0.3, 0.7), (0.7, 0.7), (0.5, 0.5)].iter().enumerate()
    {
        let (x, y) = (lo[0] + a * (hi[0] - lo[0]), lo[1] + b * (hi[1] - lo[1]));
        csv += &format!("p{i},{x},{y},{x},{y}\n");
    }
    let lms = d.join("l.csv");
    std::fs::write(&lms, csv).unwrap();
    let out = d.join("out");
    ok(&trimorph(&[
        "fit",
        "--model",
        s(&scene),
        "--frames",
        s(&frames),
        "--landmarks",
        s(&lms),
        "-o",
        s(&out),
    ]));
    // The fitted model is written in the file's axes: the y-up worm itself, within the fit's
    // 1e-5 px (it is the identity up to the solver's rounding, about 1e-8 px here).
    let got = read_obj_vertices(&out.join("f0.obj"));
    assert_eq!(got.len(), turned.len());
    for (i, (a, b)) in got.iter().zip(&turned).enumerate() {
        assert!((0..3).all(|k| (a[k] - b[k]).abs() <= 1e-5), "vertex {i}: {a:?} vs {b:?}");
    }
}

/// Issue 52: `--up auto` takes the model's thinnest axis as up (a specimen lies flat), says
/// so, and refuses a model with no clearly thinnest axis, asking for `--up`; the default `z`
/// notes when the model is clearly thinnest along another axis (a y-up model on its side).
#[test]
fn up_auto_picks_the_thinnest_axis_and_the_default_notes_a_model_on_its_side() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&trimorph(&["model", "worm", "-o", s(d)]));
    // The worm turned y-up: (x, y, z) -> (x, z, y); its thickness (60) is now along y.
    let side = d.join("side.obj");
    let text = std::fs::read_to_string(d.join("worm.obj")).unwrap();
    let turned: String = text
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(v) => {
                let c: Vec<&str> = v.split_whitespace().collect();
                format!("v {} {} {}\n", c[0], c[2], c[1])
            }
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(&side, turned).unwrap();
    let bind = |up: Option<&str>, model: &Path, out: &str| {
        let out = d.join(out);
        let mut args = vec!["model", "bind", "--model", s(model), "--auto", "-o", s(&out)];
        if let Some(u) = up {
            args.extend(["--up", u]);
        }
        trimorph(&args)
    };
    let o = bind(None, &side, "a.json");
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("thinnest along y") && err.contains("--up y"), "{err}");
    let o = bind(Some("auto"), &side, "b.json");
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("--up auto: y is up"));
    let scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("b.json")).unwrap()).unwrap();
    assert_eq!(scene["model_up"], "y");
    // The worm as written (z-up): no note, and auto agrees.
    let o = bind(None, &d.join("worm.obj"), "c.json");
    ok(&o);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("note"));
    // A cube has no thinnest axis.
    let cube = d.join("cube.obj");
    std::fs::write(&cube, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\nf 1 2 3\nf 1 2 4\n")
        .unwrap();
    let o = bind(Some("auto"), &cube, "d.json");
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("cube.obj") && err.contains("give --up x, y or z"), "{err}");
}

/// Issue 52: `warp --model` and `render --model` through a folded map warn (they used to run
/// silently); through a fold-free one they do not.
#[test]
fn model_commands_warn_about_a_folded_map() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&trimorph(&["model", "worm", "-o", s(d)]));
    let worm = d.join("worm.obj");
    let scene = d.join("scene.json");
    ok(&trimorph(&["model", "bind", "--model", s(&worm), "--auto", "-o", s(&scene)]));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&scene).unwrap()).unwrap();
    let p = &v["vertices"][6];
    let script = d.join("fold.json");
    std::fs::write(
        &script,
        format!(
            r#"[{{"anchors": {{"near": [[{}, {}]]}}, "neighborhood": 0, "op": "translate", "by": [600, 0]}}]"#,
            p[0], p[1]
        ),
    )
    .unwrap();
    let folded = d.join("folded.json");
    trimorph(&["edit", s(&scene), "--script", s(&script), "-o", s(&folded)]);
    assert!(folded.exists());
    for (def, folds) in [(&scene, false), (&folded, true)] {
        let out = d.join("w.obj");
        let o = trimorph(&["warp", s(def), "--model", s(&worm), "-o", s(&out)]);
        ok(&o);
        let png = d.join("r.png");
        let r = trimorph(&["render", s(def), "--model", s(&worm), "-o", s(&png)]);
        ok(&r);
        for o in [o, r] {
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(err.contains("is not certified fold-free"), folds, "{err}");
        }
    }
}
