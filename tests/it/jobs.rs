//! The file jobs ([`trimorph::jobs`]) called directly through the library's public API: each
//! writes its files and returns the report the command line prints.

use std::path::Path;
use trimorph::io::model::UpAxis;
use trimorph::jobs::field::{write_field, write_jacobian_map, FieldOptions};
use trimorph::jobs::fit::{FitJob, FitStart};
use trimorph::jobs::model::{bind_model, warp_model, write_worm, BindOptions};
use trimorph::jobs::spline::{build_mesh, edit_file, write_identity, EditLog, MeshSource};
use trimorph::jobs::warp::{colormesh, warp_points, ImageInput, MeshInput};
use trimorph::jobs::{read_deformation, JobError, OptionError};
use trimorph::mesh::{AdaptOptions, MeshOptions};
use trimorph::warp::{Interp, WarpOptions};

/// An identity deformation over a `cols x rows` grid of `w x h` pixels, written to `path`.
fn identity(path: &Path, w: f64, h: f64) -> String {
    let grid = MeshSource::Grid { cols: 4, rows: 3, width: w, height: h };
    let mesh = build_mesh(&grid, MeshOptions { grid: 16 }).unwrap();
    write_identity(mesh, 5, None, None, path).unwrap()
}

#[test]
fn mesh_edit_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    let line = identity(&id, 64.0, 48.0);
    assert!(
        line.starts_with("identity deformation of degree 5: 20 vertices, 24 triangles"),
        "{line}"
    );
    let script = dir.path().join("edits.json");
    std::fs::write(
        &script,
        r#"[{"anchors": {"near": [[32, 24]]}, "neighborhood": 2, "op": "translate", "by": [3, -2]}]"#,
    )
    .unwrap();
    let out = dir.path().join("edited.json");
    let mut lines = Vec::new();
    let rep = edit_file(&id, &script, &out, Some(24), &mut |l| {
        if let EditLog::Op(l) = l {
            lines.push(l);
        }
        Ok(())
    })
    .unwrap();
    assert_eq!(rep.operations, 1);
    assert_eq!(lines.len(), 1);
    assert!(lines[0].starts_with("operation 0: "), "{}", lines[0]);
    assert!(rep.summary().starts_with("1 operations applied; C1 holds exactly -> "));
    let (s, last) = read_deformation(&out).unwrap();
    s.check_c1().unwrap();
    assert!(last.is_some());
    // A missing deformation names the file.
    let e = read_deformation(&dir.path().join("none.json")).unwrap_err();
    assert!(matches!(e, JobError::Io(_)) && e.to_string().contains("none.json"), "{e}");
}

#[test]
fn image_points_mesh_and_field_through_the_identity() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (40u32, 30u32);
    let def = dir.path().join("id.json");
    identity(&def, f64::from(w - 1), f64::from(h - 1));
    let (s, _) = read_deformation(&def).unwrap();
    // An image: same size and pixels (up to the inverse's tolerance), nothing outside.
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 6) as u8, (y * 8) as u8, 99]));
    let input_path = dir.path().join("in.png");
    img.save(&input_path).unwrap();
    let input = ImageInput::read(&input_path).unwrap();
    assert_eq!((input.size(), input.rows()), ((w, h), u64::from(h)));
    let out = dir.path().join("out.png");
    let opts = WarpOptions { interp: Interp::Nearest, ..Default::default() };
    let done = std::sync::atomic::AtomicU64::new(0);
    let rep = input
        .warp_to(&s, &def, &out, &opts, &|n| {
            done.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
    assert_eq!(done.into_inner(), u64::from(h));
    assert_eq!(rep.warp.outside, 0);
    assert!(rep.folds().is_ok());
    assert!(rep.summary_line().starts_with("40x30 Rgb8 -> "), "{}", rep.summary_line());
    assert_eq!(image::open(&out).unwrap().to_rgb8(), img);
    // Points: forward, one outside the mesh left empty.
    let pts = dir.path().join("p.csv");
    std::fs::write(&pts, "x,y\n3.5,4.25\n500,500\n").unwrap();
    let pout = dir.path().join("q.csv");
    let prep = warp_points(&s, &pts, &pout, false, Default::default()).unwrap();
    assert_eq!((prep.rows, prep.missing), (2, 1));
    assert!(prep.missing_warning().is_some());
    let text = std::fs::read_to_string(&pout).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    let (x, y) = rows[1].split_once(',').unwrap();
    let (x, y): (f64, f64) = (x.parse().unwrap(), y.parse().unwrap());
    assert!((x - 3.5).abs() < 1e-9 && (y - 4.25).abs() < 1e-9, "{text}");
    assert_eq!(rows[2], ",", "{text}");
    // The image as a colored mesh, and that mesh through phi.
    let mesh_path = dir.path().join("m.ply");
    let line = colormesh(&input_path, &mesh_path, 2, false).unwrap();
    assert!(line.ends_with(&format!("(per-vertex colours) -> {}", mesh_path.display())));
    let moved = MeshInput::deform(&s, &mesh_path).unwrap();
    assert_eq!(moved.dropped, 0);
    let drawn = dir.path().join("m.png");
    assert!(MeshInput::draws(&drawn));
    let line = moved.save(&drawn, None, None).unwrap();
    assert!(line.ends_with("(40x30, antialiased)"), "{line}");
    // The forward field of the identity is zero; the Jacobian map has det J = 1.
    let field = FieldOptions { output: dir.path().join("f.npy"), ..Default::default() };
    let lines = write_field(&s, &def, (w, h), &field).unwrap();
    assert_eq!(lines.len(), 1);
    assert!(lines[0].starts_with("forward (phi(p) - p) displacement field 40x30"), "{}", lines[0]);
    let jac = write_jacobian_map(&s, (w, h), &dir.path().join("j.png")).unwrap();
    assert!(jac[0].contains("min det J 1.0000; 0 of"), "{}", jac[0]);
    // Wrong file types are refused before anything is computed.
    let bad = FieldOptions { output: dir.path().join("f.txt"), ..Default::default() };
    assert!(matches!(bad.check_paths(), Err(JobError::Option(OptionError::OutputType { .. }))));
}

#[test]
fn worm_bound_and_moved_through_psi() {
    let dir = tempfile::tempdir().unwrap();
    let line = write_worm(dir.path()).unwrap();
    assert!(line.contains("reference prisms (16 triangles)"), "{line}");
    let worm = dir.path().join("worm.obj");
    let scene = dir.path().join("scene.json");
    let rep = bind_model(&BindOptions {
        model: worm.clone(),
        mesh: Some(dir.path().join("worm_prisms.obj")),
        auto: false,
        grid: Default::default(),
        margin: 0.05,
        range: None,
        degree: 5,
        output: scene.clone(),
        up: UpAxis::Z,
        snap: None,
    })
    .unwrap();
    assert_eq!(rep.prisms, 16);
    assert!(rep.outside.is_empty());
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&scene).unwrap()).unwrap();
    assert_eq!(v["model"], "worm.obj");
    let moved = dir.path().join("moved.obj");
    let w = warp_model(&scene, &worm, &moved, UpAxis::Z).unwrap();
    assert_eq!(w.vertices, rep.vertices);
    assert!(moved.exists());
}

#[test]
fn a_fit_over_an_adapted_mesh_writes_its_report() {
    let dir = tempfile::tempdir().unwrap();
    let lms = dir.path().join("l.csv");
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    for (i, (x, y)) in
        [(20, 20), (80, 25), (50, 60), (25, 85), (85, 80), (55, 30)].iter().enumerate()
    {
        csv += &format!("p{i},{x},{y},{},{}\n", x + 2, y - 1);
    }
    std::fs::write(&lms, csv).unwrap();
    let job = FitJob {
        start: FitStart::Frame { size: [100.0, 100.0], adapt: AdaptOptions::default() },
        landmarks: lms.into(),
        output: dir.path().join("fit.json"),
        report: Some(dir.path().join("fit.report.json")),
        holdout: 0,
        seed: 1,
        pin: None,
        fit: Default::default(),
    };
    let mut warnings = Vec::new();
    let done = job.run(&mut |w| warnings.push(w)).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert!(done.frame.as_ref().is_some_and(|f| f.covers_frame));
    assert!(done.report.fit.max < 0.5, "{}", done.report.summary_line());
    let summary = done.summary();
    assert!(summary.starts_with("adapted mesh: "), "{summary}");
    assert!(summary.contains("6 landmarks: rms "), "{summary}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("fit.report.json")).unwrap())
            .unwrap();
    assert!(report["frame"]["covers_frame"].as_bool().unwrap());
    read_deformation(&dir.path().join("fit.json")).unwrap();
}

#[test]
fn the_editor_starts_on_the_bundled_scene() {
    let dir = tempfile::tempdir().unwrap();
    let doc = trimorph::server::start::initial_doc(&Default::default(), dir.path()).unwrap();
    let state = doc.state();
    assert_eq!(state.name.as_deref(), Some("bundled worm scene"), "{state:?}");
}
