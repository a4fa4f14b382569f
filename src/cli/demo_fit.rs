//! Demo part 4 (the main job): an organism model fitted to a real time-lapse from landmarks.
//!
//! Bundled data only: ten frames of a fluorescence time-lapse of moving nuclei and hand-made
//! tracks of the nucleus centres (`data/microscopy/timelapse`, compiled into the binary).
//! The reference is the first frame. A worm-like organism model (generated, lying across the
//! frame) sits in a layer of prisms over an 8x8-cell mesh of the frame; each frame's fit
//! sends the nuclei of frame 0 to where the tracks put them, and carries the model along.

use super::fit_batch::{self, BatchArgs};
use super::fit_cmd::SolverArgs;
use crate::io::deformation;
use crate::io::model::save_model;
use crate::io::write_atomic;
use anyhow::{Context, Result};
use std::path::Path;

const FRAMES: [&[u8]; 10] = crate::bundled::TIMELAPSE_FRAMES;

/// Per-frame landmark CSVs from the tracks (`track_id,frame,y,x`): source = the nucleus in
/// frame 0, target = the same nucleus in frame k. Returns the number of tracks used.
fn write_landmarks(dir: &Path) -> Result<usize> {
    let pos = crate::bundled::track_positions()?;
    let ids: Vec<u32> = pos.keys().filter(|k| k.1 == 0).map(|k| k.0).collect();
    std::fs::create_dir_all(dir)?;
    for k in 0..FRAMES.len() as u32 {
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

/// Removes what an earlier demo's batch wrote into `out` (per frame `frame_KK.json`, `.obj`,
/// `.overlay.png`, `.registered.png`, `.report.json`); other files are the user's and stay.
fn clear_outputs(out: &Path) -> Result<()> {
    for k in 0..FRAMES.len() {
        for ext in ["json", "obj", "overlay.png", "registered.png", "report.json"] {
            let p = out.join(format!("frame_{k:02}.{ext}"));
            match std::fs::remove_file(&p) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(e).with_context(|| format!("cannot clear {}", p.display()))
                }
                _ => {}
            }
        }
    }
    Ok(())
}

/// Runs demo part 4 into `dir`.
pub fn run(dir: &Path) -> Result<()> {
    println!(
        "\n== 4. fitting: an organism model fitted to a real time-lapse from tracked nuclei\n"
    );
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames)?;
    for (k, bytes) in FRAMES.iter().enumerate() {
        write_atomic(&frames.join(format!("frame_{k:02}.png")), bytes)?;
    }
    let lms = dir.join("landmarks");
    let tracks = write_landmarks(&lms)?;
    let (s, model, _) = crate::bundled::scene()?;
    let model_path = dir.join("worm.obj");
    save_model(&model, &model.vertices, &model_path)?;
    let scene = dir.join("scene.json");
    let mut v = deformation::to_json(&s, None);
    v["model"] = serde_json::Value::from("worm.obj");
    write_atomic(&scene, crate::io::json_rows(&v).as_bytes())?;
    let out = dir.join("out");
    // A fresh run each time (the batch is resumable and would skip finished frames): the
    // outputs an earlier demo wrote are removed, and nothing else in the folder.
    clear_outputs(&out)?;
    println!(
        "{} frames, {tracks} tracked nuclei, model {} ({} triangles), mesh {} triangles",
        FRAMES.len(),
        model_path.display(),
        model.triangles.len(),
        s.mesh().num_triangles()
    );
    fit_batch::run(BatchArgs {
        scene: &scene,
        model: None,
        frames: &frames,
        landmarks: &lms,
        track: false,
        anchor: None,
        key_every: None,
        holdout: 0,
        seed: 1,
        background: 0.0,
        output: &out,
        report: None,
        shard: None,
        solver: SolverArgs {
            loss: "squares",
            loss_scale: 2.0,
            bend: "1e-6",
            hard: false,
            radius: None,
            min_det: 0.1,
            no_barrier: false,
            max_iters: 200,
        },
    })?;
    println!(
        "per frame in {o}: FRAME.json (deformation), FRAME.obj (deformed model), FRAME.overlay.png, FRAME.registered.png, FRAME.report.json",
        o = out.display()
    );
    println!(
        "\nthe same from the command line:\n  trimorph fit --model {sc} --frames {f} --landmarks {l} --bend 1e-6 -o {o}\n  (or --landmarks {l}/frame_00.csv --track: follow the nuclei with Lucas-Kanade instead)",
        sc = scene.display(),
        f = frames.display(),
        l = lms.display(),
        o = out.display()
    );
    Ok(())
}
