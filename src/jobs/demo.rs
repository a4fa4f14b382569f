//! The demonstration on bundled data (`trimorph demo`), written into one folder, with the
//! report lines written to two streams (`out`: what each step did; `err`: notes and
//! warnings), exactly as the subcommands it stands for print them:
//!
//! 1. ECLES on the bundled constraint problems ([`crate::bundled::ECLES_EXAMPLES`]).
//! 2. 2DSD on the bundled microscope image: a 6x6-cell reference grid over the image, three
//!    local edits (translate, rotate, scale: [`demo_script`]), an exact C1 check,
//!    before/after pictures over the image, and the image warped through the deformation
//!    (as an image and as a colored triangle mesh).
//! 3. 2.5D on the generated worm model: a 16-prism layer, a z1 edit and an xy edit, the
//!    model moved through psi, and the top and oblique views (`models/`).
//! 4. The main job (`fit/`): an organism model fitted to a real time-lapse from tracked
//!    nuclei ([`crate::bundled::TIMELAPSE_FRAMES`]): per frame the deformation, the deformed
//!    model, an overlay, the registered frame and a report.

use super::fit::SequenceJob;
use super::model::{self as model_job, outside_warning, BindOptions};
use super::spline::{build_mesh, edit_file, render_file, write_identity, EditLog, MeshSource};
use super::warp::{colormesh, ImageInput, MeshInput};
use super::{read_deformation, JobError, JobResult};
use crate::ecles::problem::Problem;
use crate::fit::{Bend, FitOptions};
use crate::io::model::{save_model, UpAxis};
use crate::io::{deformation, write_atomic};
use crate::mesh::MeshOptions;
use crate::render::deformation::RenderOptions;
use crate::render::model::View;
use crate::warp::remap::RemapOptions;
use crate::warp::{Interp, WarpOptions};
use serde_json::json;
use std::io::Write;
use std::path::Path;

/// The demo's edit script over the 6x6 grid of the 550 x 660 cell image (also written
/// next to its outputs): a translation, a rotation and a scaling of local anchors.
pub(crate) fn demo_script() -> serde_json::Value {
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

/// The two report streams of the demo.
struct Log<'a> {
    out: &'a mut dyn Write,
    err: &'a mut dyn Write,
}

impl Log<'_> {
    fn out(&mut self, text: impl std::fmt::Display) -> JobResult<()> {
        writeln!(self.out, "{text}").map_err(JobError::Output)
    }

    fn warn(&mut self, warning: Option<String>) -> JobResult<()> {
        match warning {
            Some(w) => writeln!(self.err, "warning: {w}").map_err(JobError::Output),
            None => Ok(()),
        }
    }

    /// `trimorph edit DEF --script SCRIPT -o OUT` (bounded exactness, 24 bits).
    fn edit(&mut self, def: &Path, script: &Path, output: &Path) -> JobResult<()> {
        let (out, err) = (&mut *self.out, &mut *self.err);
        let rep = edit_file(def, script, output, Some(24), &mut |l| match l {
            EditLog::Note(n) => writeln!(err, "note: {n}"),
            EditLog::Op(line) => writeln!(out, "{line}"),
        })
        .map_err(|e| match e {
            super::spline::EditFileError::Job(e) => e,
            super::spline::EditFileError::Log(e) => JobError::Output(e),
            e => JobError::context("edit", e),
        })?;
        self.out(rep.summary())?;
        self.warn(rep.fold_warning())
    }

    /// `trimorph render DEF [--background IMG] -o OUT` (mesh and points, 800 x 600).
    fn render(&mut self, def: &Path, background: Option<&Path>, output: &Path) -> JobResult<()> {
        let (s, last) = read_deformation(def)?;
        let mut opts = RenderOptions::parse_show("mesh,points")?;
        (opts.width, opts.height) = (800, 600);
        let (w, h) = render_file(&s, last.as_ref(), output, background, &opts)?;
        self.out(format_args!("{w}x{h} -> {}", output.display()))
    }
}

/// Runs the demo into `dir` (see the module documentation), writing its report lines to
/// `out` and its notes and warnings to `err`.
pub fn run_demo(dir: &Path, out: &mut dyn Write, err: &mut dyn Write) -> JobResult<()> {
    let mut log = Log { out, err };
    std::fs::create_dir_all(dir)
        .map_err(|e| JobError::context(format!("cannot create {}", dir.display()), e))?;
    log.out("trimorph demo\n\n== 1. exact constrained editing (ECLES) on the bundled examples\n")?;
    solve_examples(dir, &mut log)?;
    spline_part(dir, &mut log)?;
    prism_part(&dir.join("models"), &mut log)?;
    fit_part(&dir.join("fit"), &mut log)
}

/// Part 1: the bundled ECLES problems solved, each written as `NAME.solution.json`.
fn solve_examples(dir: &Path, log: &mut Log) -> JobResult<()> {
    let what = [
        "four pumps, p0 + p1 = p2, p3 = p2 + 5; set p0 = 4",
        "thesis 8.3/9.2: rank-3 system with 2 redundant rows, hints all 1",
        "thesis fig. 2.1: drag one corner of a parallelogram",
    ];
    for ((name, text), what) in crate::bundled::ECLES_EXAMPLES.into_iter().zip(what) {
        let problem = Problem::from_json(text).map_err(|e| JobError::context(name, e))?;
        let out = problem.solve().map_err(|e| JobError::context(name, e))?.to_json();
        let path = dir.join(format!("{name}.solution.json"));
        write_atomic(&path, crate::io::json_rows(&out).as_bytes())?;
        log.out(format_args!("{name}: {what}"))?;
        log.out(format_args!(
            "  rank {}  relevant {}  redundant {}",
            out["rank"], out["relevant"], out["redundant"]
        ))?;
        log.out(format_args!("  P = {}", out["P"]))?;
        log.out(format_args!("  every constraint holds exactly: {}", out["all_constraints_hold"]))?;
        log.out(format_args!("  -> {}\n", path.display()))?;
    }
    Ok(())
}

/// Part 2: a C1 spline deformation over the microscope image.
fn spline_part(dir: &Path, log: &mut Log) -> JobResult<()> {
    log.out("== 2. a C1 spline deformation over a microscope image (2DSD)\n")?;
    let img = dir.join("cell.png");
    write_atomic(&img, crate::bundled::CELL_PNG)?;
    let id = dir.join("identity.json");
    let grid = MeshSource::Grid { cols: 6, rows: 6, width: 550.0, height: 660.0 };
    let mesh = build_mesh(&grid, MeshOptions { grid: 16 })?;
    log.out(write_identity(mesh, 5, None, grid.frame(), &id)?)?;
    let script = dir.join("edits.json");
    write_atomic(&script, serde_json::to_string_pretty(&demo_script())?.as_bytes())?;
    let edited = dir.join("edited.json");
    log.edit(&id, &script, &edited)?;
    let (s, _) = read_deformation(&edited)?;
    let rep = crate::spline::check::check_report_with(&s, 12, false);
    let (before, after) = (dir.join("before.png"), dir.join("after.png"));
    log.render(&id, Some(&img), &before)?;
    log.render(&edited, Some(&img), &after)?;
    let warped = dir.join("warped.png");
    let wo = WarpOptions {
        interp: Interp::Bicubic,
        background: 0.0,
        remap: RemapOptions::default(),
        mode: Default::default(),
    };
    let w = ImageInput::read(&img)?.warp_to(&s, &edited, &warped, &wo, &|_| {})?;
    log.out(w.summary_line())?;
    match w.folds() {
        Ok(line) => log.out(line)?,
        Err(warning) => log.warn(Some(warning))?,
    }
    log.warn(w.tolerance_warning(wo.remap.inverse.tolerance))?;
    // The same edit on a colored triangle mesh of the image (the fast preview path).
    let cmesh = dir.join("cell_mesh.ply");
    log.out(colormesh(&img, &cmesh, 2, false)?)?;
    let warped_mesh = dir.join("warped_mesh.png");
    let m = MeshInput::deform(&s, &cmesh)?;
    log.warn(m.dropped_warning(&cmesh))?;
    log.out(m.save(&warped_mesh, None, None)?)?;
    log.out(format_args!(
        "check: {} C1 conditions, nonzero residuals: {}, min det J = {:.3}, folds: {}",
        rep.c1_conditions, rep.c1_nonzero_residuals, rep.min_jacobian_det, rep.folds
    ))?;
    let (i, e, sc, im) = (id.display(), edited.display(), script.display(), img.display());
    log.out(format_args!(
        "\nthe same from the command line:\n  trimorph mesh --grid 6x6 --size 550,660 -o {i}\n  \
         trimorph edit {i} --script {sc} -o {e}\n  trimorph check {e}\n  \
         trimorph render {e} --background {im} -o {}\n  \
         trimorph warp {e} --image {im} --interp bicubic -o {}\n  \
         trimorph colormesh {im} -o {} --step 2\n  trimorph warp {e} --mesh {} -o {}",
        after.display(),
        warped.display(),
        cmesh.display(),
        cmesh.display(),
        warped_mesh.display()
    ))
}

/// Part 3: the worm model in a layer of prisms, edited, moved and drawn.
fn prism_part(models: &Path, log: &mut Log) -> JobResult<()> {
    log.out("\n== 3. 2.5D: the worm model in a layer of prisms (thesis Part III)\n")?;
    log.out(model_job::write_worm(models)?)?;
    let (worm, prisms) = (models.join("worm.obj"), models.join("worm_prisms.obj"));
    let scene = models.join("scene.json");
    let bound = model_job::bind_model(&BindOptions {
        model: worm.clone(),
        mesh: Some(prisms.clone()),
        auto: false,
        grid: Default::default(),
        margin: 0.05,
        range: None,
        degree: 5,
        output: scene.clone(),
        up: UpAxis::Z,
        snap: None,
    })?;
    log.out(bound.summary())?;
    log.warn(outside_warning(&bound.outside))?;
    let zscript = models.join("edits.json");
    let edits = json!([
        {"anchors": {"near": [[500, 0]]}, "mode": "z1", "op": "translate", "by": [120], "neighborhood": 2},
        {"anchors": {"near": [[250, 100]]}, "mode": "xy", "op": "translate", "by": [40, -30], "neighborhood": 2}
    ]);
    write_atomic(&zscript, serde_json::to_string_pretty(&edits)?.as_bytes())?;
    let zedited = models.join("edited.json");
    log.edit(&scene, &zscript, &zedited)?;
    let moved = models.join("worm_moved.obj");
    let w = model_job::warp_model(&zedited, &worm, &moved, UpAxis::Z)?;
    log.out(w.summary_line())?;
    log.warn(outside_warning(&w.outside))?;
    let (s, _) = read_deformation(&zedited)?;
    let model = model_job::load_model(&worm, UpAxis::Z)?;
    for (name, view) in [("top", View::Top), ("oblique", View::Oblique)] {
        let png = models.join(format!("view_{name}.png"));
        let ((w, h), outside) = model_job::render_model(&s, &model, &png, None, view, (800, 600))?;
        log.out(format_args!("{w}x{h} -> {}", png.display()))?;
        log.warn(outside_warning(&outside))?;
    }
    log.out(format_args!(
        "\nthe same from the command line:\n  trimorph model worm -o {d}\n  trimorph model bind --model {w} --mesh {p} -o {sc}\n  trimorph edit {sc} --script {e} -o {ed}\n  trimorph warp {ed} --model {w} -o {m}\n  trimorph render {ed} --model {w} --view oblique -o {d}/view_oblique.png",
        d = models.display(),
        w = worm.display(),
        p = prisms.display(),
        sc = scene.display(),
        e = zscript.display(),
        ed = zedited.display(),
        m = moved.display()
    ))
}

/// Per-frame landmark CSVs from the bundled tracks (`track_id,frame,y,x`): source = the
/// nucleus in frame 0, target = the same nucleus in frame k. Returns the number of tracks.
fn write_landmarks(dir: &Path, frames: usize) -> JobResult<usize> {
    let pos = crate::bundled::track_positions()?;
    let ids: Vec<u32> = pos.keys().filter(|k| k.1 == 0).map(|k| k.0).collect();
    std::fs::create_dir_all(dir)
        .map_err(|e| JobError::context(format!("cannot create {}", dir.display()), e))?;
    for k in 0..frames as u32 {
        let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
        for &id in &ids {
            if let (Some(s), Some(t)) = (pos.get(&(id, 0)), pos.get(&(id, k))) {
                csv += &format!("nucleus_{id},{},{},{},{}\n", s[0], s[1], t[0], t[1]);
            }
        }
        write_atomic(&dir.join(format!("frame_{k:02}.csv")), csv.as_bytes())?;
    }
    Ok(ids.len())
}

/// Removes what an earlier demo's fit wrote into `out` (per frame `frame_KK.json`, `.obj`,
/// `.overlay.png`, `.registered.png`, `.report.json`); other files are the user's and stay.
fn clear_outputs(out: &Path, frames: usize) -> JobResult<()> {
    for k in 0..frames {
        for ext in ["json", "obj", "overlay.png", "registered.png", "report.json"] {
            let p = out.join(format!("frame_{k:02}.{ext}"));
            match std::fs::remove_file(&p) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(JobError::context(format!("cannot clear {}", p.display()), e))
                }
                _ => {}
            }
        }
    }
    Ok(())
}

/// Part 4 (the main job): the organism model fitted to the bundled time-lapse.
fn fit_part(dir: &Path, log: &mut Log) -> JobResult<()> {
    const FRAMES: [&[u8]; 10] = crate::bundled::TIMELAPSE_FRAMES;
    log.out(
        "\n== 4. fitting: an organism model fitted to a real time-lapse from tracked nuclei\n",
    )?;
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames)
        .map_err(|e| JobError::context(format!("cannot create {}", frames.display()), e))?;
    for (k, bytes) in FRAMES.iter().enumerate() {
        write_atomic(&frames.join(format!("frame_{k:02}.png")), bytes)?;
    }
    let lms = dir.join("landmarks");
    let tracks = write_landmarks(&lms, FRAMES.len())?;
    let (s, model, _) = crate::bundled::scene()?;
    let model_path = dir.join("worm.obj");
    save_model(&model, &model.vertices, &model_path)?;
    let scene = dir.join("scene.json");
    let mut v = deformation::to_json(&s, None);
    v["model"] = serde_json::Value::from("worm.obj");
    write_atomic(&scene, crate::io::json_rows(&v).as_bytes())?;
    let out = dir.join("out");
    // A fresh run each time (the fit is resumable and would skip finished frames): the
    // outputs an earlier demo wrote are removed, and nothing else in the folder.
    clear_outputs(&out, FRAMES.len())?;
    log.out(format_args!(
        "{} frames, {tracks} tracked nuclei, model {} ({} triangles), mesh {} triangles",
        FRAMES.len(),
        model_path.display(),
        model.triangles.len(),
        s.mesh().num_triangles()
    ))?;
    // The fit's defaults (squares, the default barrier and iteration cap), with a fixed
    // bending weight.
    let fit = FitOptions { bend: Bend::Weight(1e-6), ..FitOptions::default() };
    let job = SequenceJob {
        scene: scene.clone().into(),
        model: None,
        frames: frames.clone(),
        landmarks: lms.clone(),
        track: None,
        background: 0.0,
        fit,
        holdout: 0,
        seed: 1,
        shard: None,
        output: out.clone(),
        report: None,
    };
    let outcome = job.run(&mut |_| {}, &|| {}).map_err(|e| JobError::context("fit", e))?;
    for line in &outcome.lines {
        log.out(line)?;
    }
    log.out(format_args!(
        "per frame in {o}: FRAME.json (deformation), FRAME.obj (deformed model), FRAME.overlay.png, FRAME.registered.png, FRAME.report.json",
        o = out.display()
    ))?;
    log.out(format_args!(
        "\nthe same from the command line:\n  trimorph fit --model {sc} --frames {f} --landmarks {l} --bend 1e-6 -o {o}\n  (or --landmarks {l}/frame_00.csv --track: follow the nuclei with Lucas-Kanade instead)",
        sc = scene.display(),
        f = frames.display(),
        l = lms.display(),
        o = out.display()
    ))
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
