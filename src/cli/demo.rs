//! `trimorph demo`: the main job on bundled data.
//!
//! 1. ECLES on the bundled constraint problems (`examples/*.json`).
//! 2. 2DSD on the bundled microscope image `data/microscopy/cell.png`: a 6x6-cell reference
//!    grid over the image, three local edits (translate, rotate, scale), an exact C1 check,
//!    before/after pictures over the image, and the image warped through the deformation
//!    (as an image and as a colored triangle mesh).
//! 3. 2.5D on the generated worm model: a 16-prism layer, a z1 edit and an xy edit, the
//!    model moved through psi, and the top and oblique views.

use super::solve::{compact_pretty, solve_text, PARALLELOGRAM, PUMP, THESIS};
use super::spline_cmds;
use crate::io::model::UpAxis;
use crate::io::write_atomic;
use crate::render::model::View;
use anyhow::{Context, Result};
use serde_json::json;
use std::io::Write;
use std::path::Path;

/// The demo's edit script (also written next to its outputs).
pub fn demo_script() -> serde_json::Value {
    // Grid vertices are at multiples of (550/6, 660/6) = (91.67, 110).
    let (gx, gy) = (550.0 / 6.0, 110.0);
    let disk = |cx: f64, cy: f64| {
        json!([
            [cx, cy],
            [cx + gx / 5.0, cy],
            [cx - gx / 5.0, cy],
            [cx, cy + gy / 5.0],
            [cx, cy - gy / 5.0]
        ])
    };
    json!([
        {"anchors": {"near": [[5.0 * gx, 3.0 * gy]]}, "neighborhood": 3,
         "op": "translate", "by": [-35, 25]},
        {"anchors": {"near": disk(2.0 * gx, 2.0 * gy)}, "neighborhood": 3,
         "op": "rotate", "center": [2.0 * gx, 2.0 * gy], "angle": 0.6},
        {"anchors": {"near": disk(3.0 * gx, 5.0 * gy)}, "neighborhood": 3,
         "op": "scale", "center": [3.0 * gx, 5.0 * gy], "factor": 1.5}
    ])
}

/// Runs the demo, writing into `dir`.
pub fn run(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut o = std::io::stdout().lock();
    writeln!(
        o,
        "trimorph demo\n\n== 1. exact constrained editing (ECLES) on the bundled examples\n"
    )?;
    for (name, text, what) in [
        ("pump", PUMP, "four pumps, p0 + p1 = p2, p3 = p2 + 5; set p0 = 4"),
        ("thesis_8_3", THESIS, "thesis 8.3/9.2: rank-3 system with 2 redundant rows, hints all 1"),
        ("parallelogram_2d", PARALLELOGRAM, "thesis fig. 2.1: drag one corner of a parallelogram"),
    ] {
        let out = solve_text(text, name)?;
        let path = dir.join(format!("{name}.solution.json"));
        write_atomic(&path, compact_pretty(&out).as_bytes())?;
        writeln!(o, "{name}: {what}")?;
        writeln!(
            o,
            "  rank {}  relevant {}  redundant {}",
            out["rank"], out["relevant"], out["redundant"]
        )?;
        writeln!(o, "  P = {}", out["P"])?;
        writeln!(o, "  every constraint holds exactly: {}", out["all_constraints_hold"])?;
        writeln!(o, "  -> {}\n", path.display())?;
    }
    drop(o);

    let mut o = std::io::stdout().lock();
    writeln!(o, "== 2. a C1 spline deformation over a microscope image (2DSD)\n")?;
    drop(o);
    let img = dir.join("cell.png");
    write_atomic(&img, crate::bundled::CELL_PNG)?;
    let id = dir.join("identity.json");
    spline_cmds::mesh(spline_cmds::MeshArgs {
        points: None,
        outline: None,
        grid: Some("6x6"),
        size: Some("550,660"),
        obj: None,
        degree: 5,
        snap: Some(16),
        landmarks: None,
        margin: None,
        max_edge: None,
        min_angle: 20.0,
        z_range: None,
        output: &id,
    })?;
    let script = dir.join("edits.json");
    write_atomic(&script, serde_json::to_string_pretty(&demo_script())?.as_bytes())?;
    let edited = dir.join("edited.json");
    spline_cmds::edit(&id, &script, &edited, Some(24))?;
    let (s, _) = crate::io::deformation::from_str(&std::fs::read_to_string(&edited)?)?;
    let rep = spline_cmds::check_report_with(&s, 12, false);
    let before = dir.join("before.png");
    let after = dir.join("after.png");
    spline_cmds::render(&id, &before, Some(&img), "mesh,points", "800,600", &Default::default())?;
    spline_cmds::render(
        &edited,
        &after,
        Some(&img),
        "mesh,points",
        "800,600",
        &Default::default(),
    )?;
    let warped = dir.join("warped.png");
    super::warp_cmd::run(super::warp_cmd::WarpArgs {
        deformation: &edited,
        image: Some(&img),
        points: None,
        mesh: None,
        model: None,
        output: &warped,
        size: None,
        inverse: false,
        interp: crate::warp::Interp::Bicubic,
        background: Some(0.0),
        tolerance: 0.01,
        verbose: false,
        up: UpAxis::Z,
    })?;
    // The same edit on a colored triangle mesh of the image (the fast preview path).
    let cmesh = dir.join("cell_mesh.ply");
    super::warp_cmd::colormesh(&img, &cmesh, 2, false)?;
    let warped_mesh = dir.join("warped_mesh.png");
    super::warp_cmd::run(super::warp_cmd::WarpArgs {
        deformation: &edited,
        image: None,
        points: None,
        mesh: Some(&cmesh),
        model: None,
        output: &warped_mesh,
        size: None,
        inverse: false,
        interp: crate::warp::Interp::Bilinear,
        background: None,
        tolerance: 0.01,
        verbose: false,
        up: UpAxis::Z,
    })?;
    let mut o = std::io::stdout().lock();
    writeln!(
        o,
        "check: {} C1 conditions, nonzero residuals: {}, min det J = {:.3}, folds: {}",
        rep["c1_conditions"],
        rep["c1_nonzero_residuals"],
        rep["min_jacobian_det"].as_f64().unwrap_or(f64::NAN),
        rep["folds"]
    )?;
    writeln!(o, "\nthe same from the command line:")?;
    writeln!(o, "  trimorph mesh --grid 6x6 --size 550,660 -o {}", id.display())?;
    writeln!(
        o,
        "  trimorph edit {} --script {} -o {}",
        id.display(),
        script.display(),
        edited.display()
    )?;
    writeln!(o, "  trimorph check {}", edited.display())?;
    writeln!(
        o,
        "  trimorph render {} --background {} -o {}",
        edited.display(),
        img.display(),
        after.display()
    )?;
    writeln!(
        o,
        "  trimorph warp {} --image {} --interp bicubic -o {}",
        edited.display(),
        img.display(),
        warped.display()
    )?;
    writeln!(o, "  trimorph colormesh {} -o {} --step 2", img.display(), cmesh.display())?;
    writeln!(
        o,
        "  trimorph warp {} --mesh {} -o {}",
        edited.display(),
        cmesh.display(),
        warped_mesh.display()
    )?;
    drop(o);
    let models = dir.join("models");
    println!("\n== 3. 2.5D: the worm model in a layer of prisms (thesis Part III)\n");
    super::model_cmd::worm_cmd(&models)?;
    let (worm, prisms) = (models.join("worm.obj"), models.join("worm_prisms.obj"));
    let scene = models.join("scene.json");
    super::model_cmd::bind_cmd(super::model_cmd::BindArgs {
        model: &worm,
        mesh: Some(&prisms),
        auto: false,
        grid: "4x2",
        margin: 0.05,
        range: None,
        degree: 5,
        output: &scene,
        extra: super::model_cmd::BindExtra {
            up: super::model_cmd::UpArgs { up: UpAxis::Z },
            snap: None,
        },
    })?;
    let zscript = models.join("edits.json");
    let edits = json!([
        {"anchors": {"near": [[500, 0]]}, "mode": "z1", "op": "translate", "by": [120], "neighborhood": 2},
        {"anchors": {"near": [[250, 100]]}, "mode": "xy", "op": "translate", "by": [40, -30], "neighborhood": 2}
    ]);
    write_atomic(&zscript, serde_json::to_string_pretty(&edits)?.as_bytes())?;
    let zedited = models.join("edited.json");
    spline_cmds::edit(&scene, &zscript, &zedited, Some(24))?;
    let moved = models.join("worm_moved.obj");
    super::model_cmd::warp_model(&zedited, &worm, &moved, UpAxis::Z)?;
    for (name, view) in [("top", View::Top), ("oblique", View::Oblique)] {
        let png = models.join(format!("view_{name}.png"));
        super::model_cmd::render_model(&zedited, &worm, &png, None, view, "800,600", UpAxis::Z)?;
    }
    println!(
        "\nthe same from the command line:\n  trimorph model worm -o {d}\n  trimorph model bind --model {w} --mesh {p} -o {sc}\n  trimorph edit {sc} --script {e} -o {ed}\n  trimorph warp {ed} --model {w} -o {m}\n  trimorph render {ed} --model {w} --view oblique -o {d}/view_oblique.png",
        d = models.display(),
        w = worm.display(),
        p = prisms.display(),
        sc = scene.display(),
        e = zscript.display(),
        ed = zedited.display(),
        m = moved.display()
    );
    super::demo_fit::run(&dir.join("fit"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::edit::script::{Op, Script};

    #[test]
    fn the_demo_script_reads_as_three_moves() {
        let s = Script::from_value(&super::demo_script()).unwrap();
        let names: Vec<&str> = s.ops.iter().map(Op::name).collect();
        assert_eq!(names, ["translate", "rotate", "scale"]);
    }
}
