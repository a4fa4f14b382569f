//! `trimorph fit --model SCENE.json --frames DIR|STACK.tif --landmarks L -o OUTDIR`: a scene
//! (a deformation, usually 2.5D, with its model) fitted to every frame of a sequence.
//!
//! * Landmarks: `L` gives sources in the scene's reference domain and targets in the first
//!   frame; with `--track` the targets are followed frame to frame by pyramidal Lucas-Kanade
//!   (points lost by the tracker drop out of later frames). A directory `L` holds one file
//!   per frame instead (`<frame stem>.csv`, `.json` or BigWarp). Landmarks named like a
//!   model landmark take their source from that model vertex, projected to xy.
//! * Fits: with `--track` in frame order, each warm-started from the previous frame's
//!   result; without, independent frames run in parallel (rayon).
//! * Outputs per frame `<stem>`: `<stem>.json` (deformation), `<stem>.registered.png` (the
//!   frame pulled back onto the reference through phi), `<stem>.obj` (the deformed model),
//!   `<stem>.overlay.png` (frame, model outline, landmarks) and `<stem>.report.json`
//!   (written last: residuals, RMS, max, min det J, iterations, time, tracking losses).
//! * Resumable: a frame whose report exists is skipped (its deformation is read back for
//!   the warm start). `--shard i/n` takes the `i`-th of `n` contiguous frame ranges, so array
//!   jobs on a cluster split a sequence with no coordination (tracking always starts from
//!   the first frame, which is cheap).

use super::fit_cmd::{fit_error, summary, SolverArgs};
use crate::fit::landmarks::Landmark;
use crate::fit::solve::{fit, FitOptions, FitReport};
use crate::fit::track::{track_points, TrackOptions};
use crate::io::landmarks::read_landmarks;
use crate::io::model::{load_model, save_model};
use crate::io::{deformation, read_text, write_atomic};
use crate::prism::{bind, deform, Binding, Model};
use crate::render::deformation::save_png;
use crate::render::overlay::{overlay, silhouette, Mark};
use crate::spline::Spline;
use crate::warp::pullback::pull_back_gray8;
use anyhow::{anyhow, bail, Context, Result};
use image::GrayImage;
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of the batch fit.
pub struct BatchArgs<'a> {
    pub scene: &'a Path,
    pub model: Option<&'a Path>,
    pub frames: &'a Path,
    pub landmarks: &'a Path,
    pub track: bool,
    pub output: &'a Path,
    pub shard: Option<&'a str>,
    pub solver: SolverArgs<'a>,
}

/// A frame: its name and 8-bit gray pixels.
struct Frame {
    stem: String,
    /// Where it was read from (named in errors): its file, or `STACK.tif, page N`.
    source: String,
    img: GrayImage,
}

fn to_gray8(img: image::DynamicImage) -> GrayImage {
    match img {
        image::DynamicImage::ImageLuma16(g) => {
            let max = g.pixels().map(|p| p[0]).max().unwrap_or(1).max(1) as f64;
            GrayImage::from_fn(g.width(), g.height(), |x, y| {
                image::Luma([((g.get_pixel(x, y)[0] as f64) * 255.0 / max).round() as u8])
            })
        }
        other => other.to_luma8(),
    }
}

/// The frames of a directory (sorted image files) or of a (multi-page) TIFF.
fn read_frames(path: &Path) -> Result<Vec<Frame>> {
    if path.is_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(path)
            .with_context(|| format!("cannot list {}", path.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                matches!(
                    p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(),
                    Some("png" | "tif" | "tiff" | "jpg" | "jpeg")
                )
            })
            .collect();
        files.sort();
        if files.is_empty() {
            bail!("no image files (png, tif, jpg) in {}", path.display());
        }
        files
            .iter()
            .map(|f| {
                // Through the raster reader: sizes are checked before decoding.
                let mut stack = crate::io::raster::read_stack(f)
                    .with_context(|| format!("cannot read frame {}", f.display()))?;
                let img = stack.pages.swap_remove(0);
                let stem =
                    f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                Ok(Frame { stem, source: f.display().to_string(), img: to_gray8(img) })
            })
            .collect()
    } else {
        let stack = crate::io::raster::read_stack(path)
            .with_context(|| format!("cannot read frames {}", path.display()))?;
        let base = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        Ok(stack
            .pages
            .into_iter()
            .enumerate()
            .map(|(i, p)| Frame {
                stem: format!("{base}_{i:03}"),
                source: format!("{}, page {i}", path.display()),
                img: to_gray8(p),
            })
            .collect())
    }
}

/// `i/n` → the half-open frame range of shard `i` (0-based) of `n`.
pub fn shard_range(spec: &str, frames: usize) -> Result<(usize, usize)> {
    let (i, n) = spec
        .split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse::<usize>().ok()?, n.trim().parse::<usize>().ok()?)))
        .filter(|&(i, n)| n >= 1 && i < n)
        .ok_or_else(|| anyhow!("--shard: expected i/n with 0 <= i < n, e.g. 0/4"))?;
    // In u128: `i * frames` overflows usize for huge (but valid) `i/n`; the quotients are
    // at most `frames`, so they fit back.
    let at = |k: usize| (k as u128 * frames as u128 / n as u128) as usize;
    Ok((at(i), at(i + 1)))
}

/// The scene's model: `--model-file`, else the scene's `"model"` key (relative to the scene).
fn scene_model(scene: &Path, explicit: Option<&Path>) -> Result<Option<(PathBuf, Model)>> {
    let path = match explicit {
        Some(p) => Some(p.to_path_buf()),
        None => {
            let v: serde_json::Value = serde_json::from_str(&read_text(scene)?)?;
            v.get("model").and_then(|m| m.as_str()).map(|m| {
                let p = PathBuf::from(m);
                if p.is_absolute() {
                    p
                } else {
                    scene.parent().unwrap_or(Path::new(".")).join(p)
                }
            })
        }
    };
    match path {
        None => Ok(None),
        Some(p) => {
            let m = load_model(&p).with_context(|| format!("cannot load model {}", p.display()))?;
            Ok(Some((p, m)))
        }
    }
}

fn name_sources(lms: &mut [Landmark], model: Option<&Model>) {
    let Some(m) = model else { return };
    for l in lms.iter_mut() {
        if let Some((_, v)) = l.name.as_ref().and_then(|n| m.landmarks.iter().find(|(k, _)| k == n))
        {
            let p = m.vertices[*v as usize];
            l.src = [p[0], p[1]];
        }
    }
}

/// Per-frame landmark sets (all frames), and the number of tracked points lost per frame.
fn frame_landmarks(
    a: &BatchArgs,
    frames: &[Frame],
    model: Option<&Model>,
) -> Result<(Vec<Vec<Landmark>>, Vec<usize>)> {
    if a.landmarks.is_dir() {
        let mut out = Vec::with_capacity(frames.len());
        for f in frames {
            let p = ["csv", "json"]
                .iter()
                .map(|e| a.landmarks.join(format!("{}.{e}", f.stem)))
                .find(|p| p.exists())
                .ok_or_else(|| {
                    anyhow!("no landmarks for frame {} in {}", f.stem, a.landmarks.display())
                })?;
            let mut l =
                read_landmarks(&p).with_context(|| format!("cannot read {}", p.display()))?;
            name_sources(&mut l, model);
            out.push(l);
        }
        return Ok((out, vec![0; frames.len()]));
    }
    let mut first = read_landmarks(a.landmarks)
        .with_context(|| format!("cannot read landmarks {}", a.landmarks.display()))?;
    name_sources(&mut first, model);
    if !a.track {
        return Ok((vec![first; frames.len()], vec![0; frames.len()]));
    }
    let mut sets = vec![first];
    let mut lost = vec![0];
    for k in 1..frames.len() {
        let prev = &sets[k - 1];
        let pts: Vec<[f64; 2]> = prev.iter().map(|l| l.dst).collect();
        let moved =
            track_points(&frames[k - 1].img, &frames[k].img, &pts, None, &TrackOptions::default())
                .with_context(|| format!("tracking into frame {}", frames[k].stem))?;
        let next: Vec<Landmark> = prev
            .iter()
            .zip(moved)
            .filter_map(|(l, m)| m.map(|d| Landmark { dst: d, ..l.clone() }))
            .collect();
        lost.push(prev.len() - next.len());
        sets.push(next);
    }
    Ok((sets, lost))
}

/// Writes every output of one frame (the report last).
#[allow(clippy::too_many_arguments)]
fn write_outputs(
    out: &Path,
    frame: &Frame,
    s: &Spline,
    report: &FitReport,
    lost: usize,
    model: Option<&(PathBuf, Model, Binding)>,
) -> Result<()> {
    let stem = &frame.stem;
    write_atomic(&out.join(format!("{stem}.json")), deformation::to_string(s, None).as_bytes())?;
    let (w, h) = (frame.img.width() as usize, frame.img.height() as usize);
    let reg = pull_back_gray8(s, frame.img.as_raw(), w, h, w, h, 0);
    let mut pm =
        tiny_skia::Pixmap::new(w as u32, h as u32).ok_or_else(|| anyhow!("empty frame"))?;
    for (d, &g) in pm.pixels_mut().iter_mut().zip(&reg) {
        *d = tiny_skia::ColorU8::from_rgba(g, g, g, 255).premultiply();
    }
    save_png(&pm, &out.join(format!("{stem}.registered.png")))?;
    let mut outline = Vec::new();
    if let Some((_, m, b)) = model {
        let moved = deform(m, b, s);
        save_model(m, &moved, &out.join(format!("{stem}.obj")))?;
        outline = silhouette(&moved, &m.triangles);
    }
    let marks: Vec<Mark> =
        report.residuals.iter().map(|r| Mark { mapped: r.mapped, target: r.dst }).collect();
    let ov = overlay(frame.img.as_raw(), w as u32, h as u32, &outline, &marks)
        .ok_or_else(|| anyhow!("empty frame"))?;
    save_png(&ov, &out.join(format!("{stem}.overlay.png")))?;
    let mut v = serde_json::to_value(report)?;
    v["frame"] = serde_json::Value::from(stem.as_str());
    v["tracking_lost"] = serde_json::Value::from(lost);
    write_atomic(
        &out.join(format!("{stem}.report.json")),
        serde_json::to_string_pretty(&v)?.as_bytes(),
    )?;
    Ok(())
}

/// Runs the batch fit; see the module docs.
pub fn run(a: BatchArgs) -> Result<()> {
    let t0 = Instant::now();
    let opts: FitOptions = a.solver.options()?;
    let (scene, _) = deformation::from_str(&read_text(a.scene)?)
        .with_context(|| format!("cannot read scene {}", a.scene.display()))?;
    let model = scene_model(a.scene, a.model)?;
    let bound = match model {
        Some((p, m)) => {
            let b =
                bind(&m, &scene).with_context(|| format!("cannot bind model {}", p.display()))?;
            Some((p, m, b))
        }
        None => None,
    };
    let frames = read_frames(a.frames)?;
    let (sets, lost) = frame_landmarks(&a, &frames, bound.as_ref().map(|(_, m, _)| m))?;
    let t_track = t0.elapsed();
    let (lo, hi) = match a.shard {
        Some(spec) => shard_range(spec, frames.len())?,
        None => (0, frames.len()),
    };
    std::fs::create_dir_all(a.output)
        .with_context(|| format!("cannot create {}", a.output.display()))?;
    // Leftovers of an earlier run that was killed mid-write.
    crate::io::remove_stale_temps(a.output, crate::io::STALE_AFTER);
    let done = |k: usize| a.output.join(format!("{}.report.json", frames[k].stem)).exists();
    let bar = super::warp_cmd::progress_bar((hi - lo) as u64, hi - lo > 1, "fit");
    let fit_one = |k: usize, warm: &Spline| -> Result<Option<(Spline, FitReport)>> {
        if done(k) {
            bar.inc(1);
            return Ok(None);
        }
        let f = fit(warm, &sets[k], &opts).map_err(fit_error).with_context(|| {
            format!(
                "frame {} ({}; landmarks {}{})",
                frames[k].stem,
                frames[k].source,
                a.landmarks.display(),
                if a.track { ", tracked from the first frame" } else { "" }
            )
        })?;
        write_outputs(a.output, &frames[k], &f.spline, &f.report, lost[k], bound.as_ref())?;
        bar.inc(1);
        Ok(Some((f.spline, f.report)))
    };
    let results: Vec<(usize, Option<FitReport>)> = if a.track {
        // In order, warm-started from the previous frame's result (read back when skipped).
        let mut warm = if lo > 0 {
            let prev = a.output.join(format!("{}.json", frames[lo - 1].stem));
            match read_text(&prev).ok().and_then(|t| deformation::from_str(&t).ok()) {
                Some((s, _)) => s,
                None => scene.clone(),
            }
        } else {
            scene.clone()
        };
        let mut out = Vec::new();
        for k in lo..hi {
            match fit_one(k, &warm)? {
                Some((s, r)) => {
                    warm = s;
                    out.push((k, Some(r)));
                }
                None => {
                    let p = a.output.join(format!("{}.json", frames[k].stem));
                    if let Some((s, _)) =
                        read_text(&p).ok().and_then(|t| deformation::from_str(&t).ok())
                    {
                        warm = s;
                    }
                    out.push((k, None));
                }
            }
        }
        out
    } else {
        (lo..hi)
            .into_par_iter()
            .map(|k| fit_one(k, &scene).map(|r| (k, r.map(|x| x.1))))
            .collect::<Result<Vec<_>>>()?
    };
    bar.finish_and_clear();
    let mut stdout = std::io::stdout();
    let mut fitted = 0;
    for (k, r) in &results {
        match r {
            Some(r) => {
                fitted += 1;
                writeln!(stdout, "{}: {}", frames[*k].stem, summary(r))?;
            }
            None => writeln!(stdout, "{}: done before, skipped", frames[*k].stem)?,
        }
    }
    writeln!(
        stdout,
        "{fitted} frames fitted, {} skipped, frames {lo}..{hi} of {} (landmarks{} in {:.0} ms; total {:.1} s) -> {}",
        results.len() - fitted,
        frames.len(),
        if a.track { " tracked" } else { "" },
        t_track.as_secs_f64() * 1e3,
        t0.elapsed().as_secs_f64(),
        a.output.display()
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::shard_range;

    #[test]
    fn shards_cover_every_frame_once() {
        for n in 1..7 {
            let mut next = 0;
            for i in 0..n {
                let (lo, hi) = shard_range(&format!("{i}/{n}"), 10).unwrap();
                assert_eq!(lo, next);
                next = hi;
            }
            assert_eq!(next, 10);
        }
        assert!(shard_range("3/3", 10).is_err());
        assert!(shard_range("x", 10).is_err());
    }
}
