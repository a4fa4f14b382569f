//! `trimorph morph A B --landmarks L.csv --frames N -o DIR`: frames, animations, contact sheet,
//! and the fitted deformations `phi_ab.json` (A's pixels -> B's pixels) and `phi_ba.json`
//! (B's pixels -> A's pixels), readable by `--phi-ab` / `--phi-ba`.

use super::common::progress_bar;
use crate::exact::matrix::rat_to_f64;
use crate::exact::Rat;
use crate::io::folder::Staged;
use crate::io::landmarks::read_landmarks;
use crate::io::raster::read_stack;
use crate::io::{deformation, read_text, temp_name, write_atomic, AtomicFile};
use crate::morph::align::{Similarity, SIMILARITY_KEY};
use crate::morph::output::{
    frame_name, is_output_name, png_bytes, streaming_memory, AnimationWriter,
};
use crate::morph::{times_between, FrameStats, Morph, MorphOptions, Schedule};
use crate::spline::Spline;
use crate::warp::Interp;
use anyhow::{anyhow, bail, Context, Result};
use image::DynamicImage;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `trimorph morph`.
pub struct MorphArgs<'a> {
    pub a: &'a Path,
    pub b: &'a Path,
    pub landmarks: Option<&'a Path>,
    pub phi_ab: Option<&'a Path>,
    pub phi_ba: Option<&'a Path>,
    pub cells: usize,
    pub align: bool,
    pub timings: bool,
    pub background: f64,
    pub frames: usize,
    pub range: &'a str,
    pub output: &'a Path,
    pub gif: Option<&'a Path>,
    pub apng: Option<&'a Path>,
    pub shape: Schedule,
    pub color: Schedule,
    pub interp: Interp,
    pub preview: Option<u32>,
    pub delay_ms: u32,
    pub quiet: bool,
}

fn first_page(path: &Path, which: &str) -> Result<DynamicImage> {
    let stack = read_stack(path)
        .with_context(|| format!("cannot read image {which} {}", path.display()))?;
    stack.pages.into_iter().next().ok_or_else(|| anyhow!("image {which} has no pages"))
}

/// Most frames of a morph. Frames are streamed (one batch in memory at a time), so memory
/// does not set this limit; it bounds the contact sheet (a thumbnail of every frame is kept
/// for it: 1,250 rows at the limit) and the run time. The thumbnails and the sheet are
/// counted in the memory budget.
const MAX_FRAMES: usize = 10_000;
/// Frames computed at once: this many per thread of the pool.
const BATCH_PER_THREAD: usize = 1;
/// Width of the contact sheet's thumbnails, px.
const THUMB: u32 = 160;
/// Largest `|t|` of `--range` (a caricature far beyond the landmarks).
const MAX_TIME: f64 = 100.0;
/// Largest `--cells`: finer meshes exceed the fit's size limit
/// ([`crate::fit::solve::MAX_FIT_VARIABLES`]).
const MAX_CELLS: usize = 48;

/// Phase timings for `--timings`.
struct Phases {
    on: bool,
    last: Instant,
    start: Instant,
    rows: Vec<(&'static str, f64)>,
}

impl Phases {
    fn new(on: bool) -> Phases {
        let now = Instant::now();
        Phases { on, last: now, start: now, rows: Vec::new() }
    }

    /// Adds the time since the last mark to the phase `name` (a phase marked again, as
    /// the frames and their encoding batch after batch, adds up).
    fn mark(&mut self, name: &'static str) {
        let now = Instant::now();
        let ms = (now - self.last).as_secs_f64() * 1e3;
        match self.rows.iter_mut().find(|(n, _)| *n == name) {
            Some(row) => row.1 += ms,
            None => self.rows.push((name, ms)),
        }
        self.last = now;
    }

    fn print(&self) {
        if !self.on {
            return;
        }
        let total = (Instant::now() - self.start).as_secs_f64() * 1e3;
        let parts: Vec<String> = self.rows.iter().map(|(n, ms)| format!("{n} {ms:.1}")).collect();
        eprintln!("timings (ms): {}; total {total:.1}", parts.join(", "));
    }
}

/// Runs the command.
pub fn run(a: MorphArgs<'_>) -> Result<()> {
    let mut ph = Phases::new(a.timings);
    if a.frames < 2 {
        bail!("--frames must be at least 2 (the first frame is A, the last B), got {}", a.frames);
    }
    if a.frames > MAX_FRAMES {
        bail!(
            "--frames: at most {MAX_FRAMES} (a thumbnail of every frame is kept for the \
             contact sheet), got {}",
            a.frames
        );
    }
    let (shape, color, interp) = (a.shape, a.color, a.interp);
    let (t0, t1) = a
        .range
        .split_once(',')
        .and_then(|(x, y)| Some((x.trim().parse::<f64>().ok()?, y.trim().parse::<f64>().ok()?)))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .ok_or_else(|| anyhow!("--range: expected T0,T1 (two numbers), got `{}`", a.range))?;
    // Far outside 0..1 the blended control points overflow f64 and the warp never ends.
    if t0.abs() > MAX_TIME || t1.abs() > MAX_TIME {
        bail!("--range: times must lie within -{MAX_TIME}..{MAX_TIME}, got `{}`", a.range);
    }
    let (img_a, img_b) = rayon::join(|| first_page(a.a, "A"), || first_page(a.b, "B"));
    let (img_a, img_b) = (img_a?, img_b?);
    ph.mark("read");
    if a.cells == 0 || a.cells > MAX_CELLS {
        bail!("--cells must be between 1 and {MAX_CELLS}, got {}", a.cells);
    }
    if !(a.background.is_finite() && a.background >= 0.0) {
        bail!("--background must be a number >= 0 (sample units), got {}", a.background);
    }
    let opts = MorphOptions {
        shape,
        color,
        interp,
        cells: a.cells,
        align: a.align,
        background: a.background,
        ..MorphOptions::default()
    };
    let load = |p: &Path| -> Result<Spline> {
        let (s, _) = deformation::from_str(&read_text(p)?)
            .with_context(|| format!("cannot read deformation {}", p.display()))?;
        Ok(s)
    };
    let morph = match (a.landmarks, a.phi_ab) {
        (Some(l), _) => {
            let lms = read_landmarks(l)
                .with_context(|| format!("cannot read landmarks {}", l.display()))?;
            let m = Morph::new(&img_a, &img_b, &lms, &opts)
                .with_context(|| format!("landmarks {}", l.display()))?;
            if let (Some([ab, ba]), false) = (m.fit_summaries(), a.quiet) {
                for (dir, f) in [("A->B", ab), ("B->A", ba)] {
                    eprintln!(
                        "fit {dir}: {} triangles, margin {} px, largest residual {:.3} px, \
                         certified fold-free (det J >= {:.3}){}",
                        f.triangles,
                        f.margin,
                        f.max_residual,
                        f.det_j_lower_bound,
                        if f.covers_frame { ", covers A's frame" } else { "" }
                    );
                    if !f.conflicts.is_empty() {
                        let pairs: Vec<String> =
                            f.conflicts.iter().map(|[x, y]| format!("{x} and {y}")).collect();
                        eprintln!(
                            "warning: fit {dir}: these landmark pairs cross, so following them \
                             would fold the map; the morph stays fold-free and misses them \
                             (largest residual {:.2} px): {}",
                            f.max_residual,
                            pairs.join(", ")
                        );
                    }
                }
            }
            m
        }
        (None, Some(p)) => {
            let text = read_text(p)?;
            let (phi_ab, _) = deformation::from_str(&text)
                .with_context(|| format!("cannot read deformation {}", p.display()))?;
            let stored = if a.align { stored_similarity(&text, p)? } else { None };
            let phi_ba = a.phi_ba.map(load).transpose()?;
            let given = stored.is_some();
            let m = Morph::from_deformations_with(&img_a, &img_b, phi_ab, phi_ba, stored, &opts)?;
            if given && !a.quiet {
                eprintln!("similarity read from {} ({SIMILARITY_KEY})", p.display());
            }
            let cov = m.coverage();
            if cov < 1.0 && !a.quiet {
                eprintln!(
                    "note: {} covers {:.1}% of A; the rest of A has no preimage in any frame",
                    p.display(),
                    100.0 * cov
                );
            }
            m
        }
        (None, None) => bail!("give --landmarks L.csv or --phi-ab DEF.json"),
    };
    if !a.quiet {
        if a.align {
            eprintln!("B aligned to A by the similarity: {}", morph.similarity());
        } else {
            eprintln!("B kept in its raw pixel coordinates (--no-align)");
        }
    }
    ph.mark("fits");
    // All or nothing: the files go into a sibling folder swapped into place at the end, so a
    // failed or killed morph leaves the earlier output as it was, and a shorter run leaves no
    // stale frames (only files of the morph's own naming are replaced or removed).
    let stage = Staged::begin(a.output, is_output_name)
        .with_context(|| format!("cannot create {}", a.output.display()))?;

    let exact_times = times_between(a.frames, t0, t1)?;
    let mut newton_solves = 0;
    let times: Vec<f64> = exact_times.iter().map(rat_to_f64).collect();
    // Frames are streamed: computed a batch at a time in parallel, written (PNG, GIF, APNG)
    // and dropped; only a thumbnail of each stays for the contact sheet. The budget is one
    // batch (each frame, its PNG bytes and its RGBA copy) with the encoders and thumbnails;
    // a tight budget makes the batch smaller, down to one frame.
    let (fw, fh) = (morph.image_a().width(), morph.image_a().height());
    let px = fw as u64 * fh as u64;
    let bpp = match a.preview {
        Some(_) => 4,
        None => morph.image_a().color().bytes_per_pixel() as u64,
    };
    let cols = a.frames.min(8);
    let need = |batch: usize| {
        // Two batches: one computed while the other is written.
        let frames = crate::memory::bytes_of(2 * batch as u64, px.saturating_mul(2 * bpp));
        frames.saturating_add(streaming_memory((fw, fh), a.frames, batch, THUMB, cols))
    };
    let mut batch = (rayon::current_num_threads() * BATCH_PER_THREAD).clamp(1, a.frames);
    while batch > 1 && need(batch) > crate::memory::limit() {
        batch -= 1;
    }
    crate::memory::check(need(batch), || {
        format!(
            "{batch} frame(s) of {fw} x {fh} at a time, with the GIF and APNG encoders, {} \
             thumbnails and the contact sheet",
            a.frames
        )
    })?;
    let gif = a.gif.map(Path::to_path_buf).unwrap_or_else(|| a.output.join("morph.gif"));
    let apng = a.apng.map(Path::to_path_buf).unwrap_or_else(|| a.output.join("morph.apng"));
    let sheet: PathBuf = a.output.join("contact-sheet.png");
    // The animations go into the folder unless --gif / --apng name another place. A place
    // outside the folder is written beside it and put in place before the folder is swapped
    // in (a failure there leaves the folder as it was); a place inside it is written into
    // the stage under a temporary name and copied to its place after the swap.
    let target = stage.target().to_path_buf();
    let inside = |p: &Path| {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::canonicalize(dir).is_ok_and(|d| d.starts_with(&target))
    };
    let open =
        |given: Option<&Path>, name: &str, path: &Path| -> Result<(AtomicFile, Option<String>)> {
            let (to, later) = match given {
                None => (stage.path(name), None),
                Some(p) if !inside(p) => (p.to_path_buf(), None),
                Some(_) => {
                    let tmp = temp_name(name);
                    (stage.path(&tmp), Some(tmp))
                }
            };
            let f = AtomicFile::create(&to)
                .with_context(|| format!("cannot write {}", path.display()))?;
            Ok((f, later))
        };
    let (mut gif_file, gif_later) = open(a.gif, "morph.gif", &gif)?;
    let (mut apng_file, apng_later) = open(a.apng, "morph.apng", &apng)?;
    let mut sink =
        AnimationWriter::new(&mut gif_file, &mut apng_file, (fw, fh), a.frames, a.delay_ms, THUMB)?;
    let preview = match a.preview {
        Some(step) => {
            let pv = morph.preview(step)?;
            // The preview is 8-bit: scale the background from the working type's range.
            let full = match morph.image_a().color().bytes_per_pixel()
                / morph.image_a().color().channel_count()
            {
                1 => 255.0,
                2 => 65535.0,
                _ => 1.0,
            };
            let bg = (a.background / full * 255.0).round().clamp(0.0, 255.0) as u8;
            Some((pv, bg))
        }
        None => None,
    };
    let bar = progress_bar(a.frames as u64, !a.quiet, "morph");
    let mut uncovered = 0;
    // One batch of frames is computed while the one before is written (PNGs) and encoded
    // (GIF, APNG): two batches are alive at a time (`need` counts them).
    let compute = |ts: &[Rat]| -> Result<(Vec<DynamicImage>, usize, usize)> {
        match &preview {
            None => {
                let out: Vec<(DynamicImage, FrameStats)> = ts
                    .par_iter()
                    .map(|t| {
                        let f = morph.frame_with_stats(t);
                        bar.inc(1);
                        f
                    })
                    .collect::<Result<_, _>>()?;
                let unc = out.iter().map(|(_, st)| st.uncovered).sum();
                let newton = out.iter().map(|(_, st)| st.newton_solves).sum();
                Ok((out.into_iter().map(|(f, _)| f).collect(), unc, newton))
            }
            Some((pv, bg)) => {
                let frames = ts
                    .par_iter()
                    .map(|t| {
                        let pm = morph.preview_frame_exact(pv, t, [*bg, *bg, *bg, 255])?;
                        bar.inc(1);
                        let img = image::RgbaImage::from_raw(pm.width(), pm.height(), pm.take())
                            .expect("sizes match");
                        Ok(DynamicImage::ImageRgba8(img))
                    })
                    .collect::<Result<_>>()?;
                Ok((frames, 0, 0))
            }
        }
    };
    let write = |sink: &mut AnimationWriter<_, _>, first: usize, frames: &[DynamicImage]| {
        let (pngs, anims) = rayon::join(
            || {
                frames.par_iter().enumerate().try_for_each(|(k, f)| -> Result<()> {
                    let p = stage.path(&frame_name(first + k, a.frames));
                    write_atomic(&p, &png_bytes(f)?)
                        .with_context(|| format!("cannot write {}", p.display()))
                })
            },
            || sink.push_batch(frames),
        );
        pngs?;
        anims.map_err(anyhow::Error::from)
    };
    let chunks: Vec<&[Rat]> = exact_times.chunks(batch).collect();
    let mut done: Option<Vec<DynamicImage>> = None;
    for k in 0..=chunks.len() {
        let (next, written) = rayon::join(
            || chunks.get(k).map(|ts| compute(ts)).transpose(),
            || match &done {
                Some(frames) => write(&mut sink, (k - 1) * batch, frames),
                None => Ok(()),
            },
        );
        written?;
        done = match next? {
            Some((frames, unc, newton)) => {
                uncovered += unc;
                newton_solves += newton;
                Some(frames)
            }
            None => None,
        };
        ph.mark("frames and encoding");
    }
    bar.finish_and_clear();
    if uncovered > 0 && !a.quiet {
        eprintln!(
            "note: {uncovered} pixels over all frames have a preimage in neither image \
             (they show --background)"
        );
    }
    // Every frame's two maps: certified fold-free, and covering A's frame.
    // One family certificate covers every frame with shape weight in [0, 1]; the others
    // (caricatures, or families not proven that way) are certified one by one.
    if a.landmarks.is_some() {
        let family = morph.certify_blends();
        let covered = family[0] && family[1];
        let shape = morph.options().shape;
        let bad: Vec<String> = exact_times
            .par_iter()
            .zip(&times)
            .map(|(t, &tf)| -> Result<Option<String>> {
                let s = rat_to_f64(&shape.at_exact(t));
                if covered && (0.0..=1.0).contains(&s) {
                    return Ok(None);
                }
                let c = morph.check_frame(t)?;
                Ok((!(c.fold_free[0] && c.fold_free[1])).then(|| format!("{tf:.3}")))
            })
            .collect::<Result<Vec<_>>>()?
            .into_iter()
            .flatten()
            .collect();
        if !bad.is_empty() && !a.quiet {
            eprintln!(
                "warning: the blended maps are not certified fold-free at t = {}",
                bad.join(", ")
            );
        }
        ph.mark("checks");
    }
    let write_def = |name: &str, s: &Spline, sim: Option<&Similarity>| -> Result<()> {
        let p = stage.path(name);
        let mut doc = deformation::to_json_with(s, None, &[]);
        if let (Some(sim), Some(obj)) = (sim, doc.as_object_mut()) {
            obj.insert(SIMILARITY_KEY.into(), sim.to_json());
        }
        write_atomic(&p, crate::io::json_rows(&doc).as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))
    };
    // Both at once: each is a few thousand exact rationals to print. `phi_ab.json` keeps the
    // similarity, so that `--phi-ab` gives this very morph back.
    let raw = morph.phi_ab_raw()?;
    let sim = morph.similarity();
    let (ab, ba) = rayon::join(
        || write_def("phi_ab.json", &raw, Some(sim)),
        || write_def("phi_ba.json", morph.phi_ba(), None),
    );
    ab?;
    ba?;
    ph.mark("deformations");
    let pm = sink.finish(&times, cols)?;
    gif_file.commit().with_context(|| format!("cannot write {}", gif.display()))?;
    apng_file.commit().with_context(|| format!("cannot write {}", apng.display()))?;
    let bytes = pm.encode_png().map_err(|e| anyhow!("encoding the contact sheet: {e}"))?;
    drop(pm);
    write_atomic(&stage.path("contact-sheet.png"), &bytes)
        .with_context(|| format!("cannot write {}", sheet.display()))?;
    stage.commit().with_context(|| format!("cannot write {}", a.output.display()))?;
    // Animations inside the output folder: now in it under their temporary names.
    for (later, path) in [(gif_later, &gif), (apng_later, &apng)] {
        if let Some(tmp) = later {
            let from = target.join(tmp);
            let copied = (|| -> Result<()> {
                let mut to = AtomicFile::create(path)?;
                std::io::copy(&mut std::fs::File::open(&from)?, &mut to)?;
                Ok(to.commit()?)
            })();
            let _ = std::fs::remove_file(&from);
            copied.with_context(|| format!("cannot write {}", path.display()))?;
        }
    }
    ph.mark("sheet");
    if a.timings {
        eprintln!(
            "inverse maps: {newton_solves} pixels solved by per-pixel Newton over all frames"
        );
    }
    ph.print();

    let worst = [0.0, 1.0]
        .iter()
        .map(|&t| morph.landmark_errors(t))
        .collect::<Result<Vec<_>, _>>()?
        .concat()
        .iter()
        .flatten()
        .fold(0.0f64, |m, &e| if e.is_finite() { m.max(e) } else { m });
    if !a.quiet {
        let residual = if a.landmarks.is_some() {
            format!("; largest landmark fit residual {worst:.3} px")
        } else {
            String::new()
        };
        eprintln!(
            "{} frames ({} x {}) in {}; {}, {}, {}{}",
            a.frames,
            morph.image_a().width(),
            morph.image_a().height(),
            a.output.display(),
            gif.display(),
            apng.display(),
            sheet.display(),
            residual
        );
    }
    Ok(())
}

/// The similarity stored in a deformation file's [`SIMILARITY_KEY`], if it has one.
fn stored_similarity(text: &str, path: &Path) -> Result<Option<Similarity>> {
    let doc: serde_json::Value = serde_json::from_str(text)
        .with_context(|| format!("cannot read deformation {}", path.display()))?;
    doc.get(SIMILARITY_KEY)
        .map(Similarity::from_json)
        .transpose()
        .with_context(|| format!("{}: key {SIMILARITY_KEY}", path.display()))
}
