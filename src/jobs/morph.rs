//! The file job behind `trimorph morph` ([`MorphJob`]): the morph made from its input files
//! ([`crate::jobs::morph_inputs`]), then its files ([`write_morph`]) in one folder, written
//! all or nothing: `frame_000.png` ..., an endlessly looping `morph.gif` and `morph.apng`,
//! `contact-sheet.png`, and the two deformations `phi_ab.json` (A's pixels -> B's pixels,
//! with the similarity that aligned B, [`SIMILARITY_KEY`]) and `phi_ba.json`. The command
//! line only parses its options, shows the progress and prints the job's notes and report.
//!
//! **All or nothing.** The files go into a sibling folder swapped into place at the end
//! ([`crate::io::folder::Staged`]), so a failed or killed morph leaves the earlier output as
//! it was, and a shorter run leaves no stale frames (only files of the morph's own naming,
//! [`is_output_name`], are replaced or removed). An animation given another place
//! ([`MorphFileOptions::gif`], [`MorphFileOptions::apng`]) outside the folder is written
//! beside its place and renamed before the folder is swapped in; one inside the folder is
//! written into the stage under a temporary name and copied to its place after the swap.
//!
//! **Streaming.** Frames are computed a batch at a time in parallel (one frame per thread of
//! the pool), written (PNG, GIF, APNG) while the next batch is computed, and dropped; only a
//! thumbnail of each stays for the contact sheet. Two batches, the encoders and the
//! thumbnails are counted in the memory budget ([`crate::memory`]); a tight budget makes the
//! batch smaller, down to one frame. The two deformations (thousands of exact rationals to
//! print) are written on their own threads while the frames are computed.
//!
//! **Certificates.** For a morph fitted to landmarks, every frame's two blended maps are
//! certified fold-free: one family certificate ([`Morph::certify_blends`]) covers every frame
//! with shape weight in `[0, 1]`; the others (caricatures, or families it cannot prove) are
//! certified one by one ([`Morph::check_frame`]), and [`MorphFilesReport::uncertified`]
//! lists the times where that fails.

use crate::exact::matrix::rat_to_f64;
use crate::exact::Rat;
use crate::io::folder::{MadeFolders, Staged};
use crate::io::{deformation, temp_name, write_atomic, AtomicFile, IoError};
use crate::jobs::morph_inputs::{MadeMorph, MorphInputError, MorphInputs, MorphNote};
use crate::memory::OverBudget;
use crate::morph::align::{Similarity, SIMILARITY_KEY};
use crate::morph::output::{
    frame_name, is_output_name, png_bytes, streaming_memory, AnimationWriter, EncodeError,
};
use crate::morph::{times_between, FrameStats, Morph, MorphError};
use crate::spline::Spline;
use crate::timing::Phases;
use image::DynamicImage;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Most frames of a morph. Frames are streamed (one batch in memory at a time), so memory
/// does not set this limit; it bounds the contact sheet (a thumbnail of every frame is kept
/// for it: 1,250 rows at the limit) and the run time. The thumbnails and the sheet are
/// counted in the memory budget.
pub const MAX_FRAMES: usize = 10_000;
/// Largest `|t|` of a time range (a caricature far beyond the landmarks): beyond it the
/// blended control points overflow `f64` and the warp never ends.
pub const MAX_TIME: f64 = 100.0;
/// Frames computed at once: this many per thread of the pool.
const BATCH_PER_THREAD: usize = 1;
/// Width of the contact sheet's thumbnails, px.
const THUMB: u32 = 160;
/// Thumbnails per row of the contact sheet, at most.
const SHEET_COLUMNS: usize = 8;

/// What to write, and where (see the module documentation).
#[derive(Clone, Debug)]
pub struct MorphFileOptions {
    /// The output folder.
    pub output: PathBuf,
    /// The GIF's place (default `output/morph.gif`).
    pub gif: Option<PathBuf>,
    /// The APNG's place (default `output/morph.apng`).
    pub apng: Option<PathBuf>,
    /// Frames, at least 2 (the first at `range.0`, the last at `range.1`).
    pub frames: usize,
    /// The times of the first and the last frame (0 is A, 1 is B; outside [0, 1] a
    /// caricature), each within [`MAX_TIME`] of 0.
    pub range: (f64, f64),
    /// Draw the frames as colored triangle meshes of this lattice step (px, 8-bit RGBA)
    /// instead of resampling the images.
    pub preview: Option<u32>,
    /// The background of a preview, in the working type's sample units (as
    /// [`crate::morph::MorphOptions::background`]).
    pub background: f64,
    /// Delay between animation frames, ms.
    pub delay_ms: u32,
}

impl MorphFileOptions {
    /// The options for `frames` frames from A to B into `output`, with the defaults of
    /// `trimorph morph` (animations in the folder, no preview, 100 ms a frame).
    pub fn new(output: impl Into<PathBuf>, frames: usize) -> MorphFileOptions {
        MorphFileOptions {
            output: output.into(),
            gif: None,
            apng: None,
            frames,
            range: (0.0, 1.0),
            preview: None,
            background: 0.0,
            delay_ms: 100,
        }
    }

    /// Checks the frame count and the time range (the errors name them as the command line
    /// does: `--frames`, `--range`).
    pub fn validate(&self) -> Result<(), MorphFilesError> {
        check_frames(self.frames)?;
        check_range(self.range)
    }

    /// Where the GIF goes.
    pub fn gif_path(&self) -> PathBuf {
        self.gif.clone().unwrap_or_else(|| self.output.join("morph.gif"))
    }

    /// Where the APNG goes.
    pub fn apng_path(&self) -> PathBuf {
        self.apng.clone().unwrap_or_else(|| self.output.join("morph.apng"))
    }

    /// Where the contact sheet goes.
    pub fn sheet_path(&self) -> PathBuf {
        self.output.join("contact-sheet.png")
    }
}

/// Checks a frame count: 2 to [`MAX_FRAMES`].
pub fn check_frames(frames: usize) -> Result<(), MorphFilesError> {
    if frames < 2 {
        return Err(MorphFilesError::TooFewFrames { frames });
    }
    if frames > MAX_FRAMES {
        return Err(MorphFilesError::TooManyFrames { frames });
    }
    Ok(())
}

/// Checks a time range: finite, each end within [`MAX_TIME`] of 0.
pub fn check_range((t0, t1): (f64, f64)) -> Result<(), MorphFilesError> {
    if !(t0.is_finite() && t1.is_finite()) || t0.abs() > MAX_TIME || t1.abs() > MAX_TIME {
        return Err(MorphFilesError::TimesOutOfRange { t0, t1 });
    }
    Ok(())
}

/// What [`write_morph`] did.
#[derive(Clone, Debug, Default)]
pub struct MorphFilesReport {
    /// Pixels over all frames with a preimage in neither image (they show the background).
    pub uncovered: usize,
    /// Pixels over all frames whose preimage took a per-pixel Newton solve.
    pub newton_solves: usize,
    /// The times whose two blended maps are not certified fold-free (only for a morph fitted
    /// to landmarks; empty otherwise).
    pub uncertified: Vec<f64>,
    /// The largest landmark residual of the two fitted maps, px (0 for a morph not fitted to
    /// landmarks).
    pub largest_residual: f64,
    /// Where the GIF, the APNG and the contact sheet went.
    pub gif: PathBuf,
    /// See [`gif`](Self::gif).
    pub apng: PathBuf,
    /// See [`gif`](Self::gif).
    pub sheet: PathBuf,
    /// Wall time of each phase, ms, in order: `frames and encoding`, `checks`,
    /// `deformations` (the part not hidden behind the frames), `sheet`.
    pub phases: Vec<(&'static str, f64)>,
}

/// Errors of [`write_morph`].
#[derive(Debug, thiserror::Error)]
pub enum MorphFilesError {
    /// Fewer than 2 frames ([`check_frames`]).
    #[error("--frames must be at least 2 (the first frame is A, the last B), got {frames}")]
    TooFewFrames {
        /// The frame count given.
        frames: usize,
    },
    /// More than [`MAX_FRAMES`] frames ([`check_frames`]).
    #[error(
        "--frames: at most {MAX_FRAMES} (a thumbnail of every frame is kept for the contact \
         sheet), got {frames}"
    )]
    TooManyFrames {
        /// The frame count given.
        frames: usize,
    },
    /// A time that is not finite or lies beyond [`MAX_TIME`] of 0 ([`check_range`]).
    #[error("--range: times must lie within -{MAX_TIME}..{MAX_TIME}, got `{t0},{t1}`")]
    TimesOutOfRange {
        /// The first frame's time.
        t0: f64,
        /// The last frame's time.
        t1: f64,
    },
    /// The morph failed (a frame, a blend, a certificate).
    #[error(transparent)]
    Morph(#[from] MorphError),
    /// Encoding a frame, an animation or the contact sheet failed.
    #[error(transparent)]
    Encode(#[from] EncodeError),
    /// The output needs more memory than the budget allows.
    #[error(transparent)]
    Memory(#[from] OverBudget),
    /// The output folder cannot be made.
    #[error("cannot create {}", path.display())]
    Folder {
        /// The folder.
        path: PathBuf,
        /// The cause.
        #[source]
        source: IoError,
    },
    /// A file cannot be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: IoError,
    },
}

fn write_err(path: &Path) -> impl FnOnce(IoError) -> MorphFilesError + '_ {
    move |source| MorphFilesError::Write { path: path.to_path_buf(), source }
}

/// Writes the morph's files into [`MorphFileOptions::output`], all or nothing (see the
/// module documentation). `progress` is called once per computed frame, from any thread.
pub fn write_morph(
    morph: &Morph,
    o: &MorphFileOptions,
    progress: &(dyn Fn() + Sync),
) -> Result<MorphFilesReport, MorphFilesError> {
    o.validate()?;
    let mut ph = Phases::new();
    let stage = Staged::begin(&o.output, is_output_name)
        .map_err(|source| MorphFilesError::Folder { path: o.output.clone(), source })?;
    // The folders of --gif and --apng are made as the output folder is.
    let mut made = MadeFolders::default();
    for p in [o.gif.as_ref(), o.apng.as_ref()].into_iter().flatten() {
        made.parent_of(p).map_err(|source| MorphFilesError::Folder { path: p.clone(), source })?;
    }
    let exact_times = times_between(o.frames, o.range.0, o.range.1)?;
    let times: Vec<f64> = exact_times.iter().map(rat_to_f64).collect();
    let (fw, fh) = (morph.image_a().width(), morph.image_a().height());
    let px = u64::from(fw) * u64::from(fh);
    let bpp = match o.preview {
        Some(_) => 4,
        None => morph.image_a().color().bytes_per_pixel() as u64,
    };
    let cols = o.frames.min(SHEET_COLUMNS);
    let need = |batch: usize| {
        // Two batches: one computed while the other is written.
        let frames = crate::memory::bytes_of(2 * batch as u64, px.saturating_mul(2 * bpp));
        frames.saturating_add(streaming_memory((fw, fh), o.frames, batch, THUMB, cols))
    };
    let mut batch = (rayon::current_num_threads() * BATCH_PER_THREAD).clamp(1, o.frames);
    while batch > 1 && need(batch) > crate::memory::limit() {
        batch -= 1;
    }
    crate::memory::check(need(batch), || {
        format!(
            "{batch} frame(s) of {fw} x {fh} at a time, with the GIF and APNG encoders, {} \
             thumbnails and the contact sheet",
            o.frames
        )
    })?;
    let (gif, apng, sheet) = (o.gif_path(), o.apng_path(), o.sheet_path());
    let target = stage.target().to_path_buf();
    let inside = |p: &Path| {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::canonicalize(dir).is_ok_and(|d| d.starts_with(&target))
    };
    let open = |given: Option<&PathBuf>,
                name: &str,
                path: &Path|
     -> Result<(AtomicFile, Option<String>), MorphFilesError> {
        let (to, later) = match given {
            None => (stage.path(name), None),
            Some(p) if !inside(p) => (p.clone(), None),
            Some(_) => {
                let tmp = temp_name(name);
                (stage.path(&tmp), Some(tmp))
            }
        };
        Ok((AtomicFile::create(&to).map_err(write_err(path))?, later))
    };
    let (mut gif_file, gif_later) = open(o.gif.as_ref(), "morph.gif", &gif)?;
    let (mut apng_file, apng_later) = open(o.apng.as_ref(), "morph.apng", &apng)?;

    // The deformations, on their own threads while the frames are computed: each is a few
    // thousand exact rationals to print. `phi_ab.json` keeps the similarity, so that reading
    // it back (`Morph::from_deformations_with`) gives this very morph.
    let write_def = |name: &str, s: &Spline, sim: Option<&Similarity>| {
        let p = stage.path(name);
        let mut doc = deformation::to_json_with(s, None, &[]);
        if let (Some(sim), Some(obj)) = (sim, doc.as_object_mut()) {
            obj.insert(SIMILARITY_KEY.into(), sim.to_json());
        }
        write_atomic(&p, crate::io::json_rows(&doc).as_bytes()).map_err(write_err(&p))
    };
    let raw = morph.phi_ab_raw()?;
    let (frames_done, defs) = std::thread::scope(|scope| {
        let ab = scope.spawn(|| write_def("phi_ab.json", &raw, Some(morph.similarity())));
        let ba = scope.spawn(|| write_def("phi_ba.json", morph.phi_ba(), None));
        let frames = write_frames(
            morph,
            o,
            &stage,
            &exact_times,
            batch,
            AnimationWriter::new(
                &mut gif_file,
                &mut apng_file,
                (fw, fh),
                o.frames,
                o.delay_ms,
                THUMB,
            )?,
            progress,
            &mut ph,
        );
        let join = |h: std::thread::ScopedJoinHandle<'_, Result<(), MorphFilesError>>| {
            h.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        };
        let defs = join(ab).and(join(ba));
        Ok::<_, MorphFilesError>((frames, defs))
    })?;
    let (sink, uncovered, newton_solves) = frames_done?;
    let uncertified = if morph.fit_summaries().is_some() {
        let bad = uncertified_times(morph, &exact_times, &times)?;
        ph.mark("checks");
        bad
    } else {
        Vec::new()
    };
    defs?;
    ph.mark("deformations");
    let pm = sink.finish(&times, cols)?;
    gif_file.commit().map_err(write_err(&gif))?;
    apng_file.commit().map_err(write_err(&apng))?;
    let bytes = pm
        .encode_png()
        .map_err(|e| EncodeError::Frames(format!("encoding the contact sheet: {e}")))?;
    drop(pm);
    write_atomic(&stage.path("contact-sheet.png"), &bytes).map_err(write_err(&sheet))?;
    stage.commit().map_err(|source| MorphFilesError::Write { path: o.output.clone(), source })?;
    // Animations inside the output folder: now in it under their temporary names.
    for (later, path) in [(gif_later, &gif), (apng_later, &apng)] {
        if let Some(tmp) = later {
            let from = target.join(tmp);
            let copied = (|| -> Result<(), IoError> {
                let mut to = AtomicFile::create(path)?;
                let werr = |source| IoError::Write { path: path.clone(), source };
                let mut src = std::fs::File::open(&from).map_err(werr)?;
                std::io::copy(&mut src, &mut to).map_err(werr)?;
                to.commit()
            })();
            let _ = std::fs::remove_file(&from);
            copied.map_err(write_err(path))?;
        }
    }
    ph.mark("sheet");
    let largest_residual = if morph.fit_summaries().is_some() {
        [0.0, 1.0]
            .iter()
            .map(|&t| morph.landmark_errors(t))
            .collect::<Result<Vec<_>, _>>()?
            .concat()
            .iter()
            .flatten()
            .fold(0.0f64, |m, &e| if e.is_finite() { m.max(e) } else { m })
    } else {
        0.0
    };
    made.keep();
    Ok(MorphFilesReport {
        uncovered,
        newton_solves,
        uncertified,
        largest_residual,
        gif,
        apng,
        sheet,
        phases: ph.rows().to_vec(),
    })
}

type Sink<'f> = AnimationWriter<&'f mut AtomicFile, &'f mut AtomicFile>;

/// Computes the frames batch by batch, each batch written (PNGs into the stage, GIF and
/// APNG into `sink`) while the next is computed; returns the sink, the uncovered pixels and
/// the Newton solves.
#[allow(clippy::too_many_arguments)]
fn write_frames<'f>(
    morph: &Morph,
    o: &MorphFileOptions,
    stage: &Staged,
    exact_times: &[Rat],
    batch: usize,
    mut sink: Sink<'f>,
    progress: &(dyn Fn() + Sync),
    ph: &mut Phases,
) -> Result<(Sink<'f>, usize, usize), MorphFilesError> {
    let preview = match o.preview {
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
            let bg = (o.background / full * 255.0).round().clamp(0.0, 255.0) as u8;
            Some((pv, bg))
        }
        None => None,
    };
    let compute = |ts: &[Rat]| -> Result<(Vec<DynamicImage>, usize, usize), MorphFilesError> {
        match &preview {
            None => {
                let out: Vec<(DynamicImage, FrameStats)> = ts
                    .par_iter()
                    .map(|t| {
                        let f = morph.frame_with_stats(t);
                        progress();
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
                        progress();
                        let (w, h) = (pm.width(), pm.height());
                        let img = image::RgbaImage::from_raw(w, h, pm.take())
                            .ok_or_else(|| EncodeError::Frames("preview size".into()))?;
                        Ok(DynamicImage::ImageRgba8(img))
                    })
                    .collect::<Result<_, MorphFilesError>>()?;
                Ok((frames, 0, 0))
            }
        }
    };
    let write = |sink: &mut Sink<'f>, first: usize, frames: &[DynamicImage]| {
        let (pngs, anims) = rayon::join(
            || {
                frames.par_iter().enumerate().try_for_each(|(k, f)| {
                    let p = stage.path(&frame_name(first + k, o.frames));
                    write_atomic(&p, &png_bytes(f)?).map_err(write_err(&p))
                })
            },
            || sink.push_batch(frames),
        );
        pngs?;
        anims.map_err(MorphFilesError::from)
    };
    let (mut uncovered, mut newton_solves) = (0, 0);
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
    Ok((sink, uncovered, newton_solves))
}

/// The times (of `exact_times`, printed as `times`) whose blended maps are not certified
/// fold-free: the family certificate first, then frame by frame what it does not cover.
fn uncertified_times(
    morph: &Morph,
    exact_times: &[Rat],
    times: &[f64],
) -> Result<Vec<f64>, MorphFilesError> {
    let family = morph.certify_blends();
    let covered = family[0] && family[1];
    let shape = morph.options().shape;
    let bad = exact_times
        .par_iter()
        .zip(times)
        .map(|(t, &tf)| -> Result<Option<f64>, MorphFilesError> {
            let s = rat_to_f64(&shape.at_exact(t));
            if covered && (0.0..=1.0).contains(&s) {
                return Ok(None);
            }
            let c = morph.check_frame(t)?;
            Ok((!(c.fold_free[0] && c.fold_free[1])).then_some(tf))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(bad.into_iter().flatten().collect())
}

/// The whole of `trimorph morph`: the morph made from its input files, then its files
/// written. [`MorphJob::make`] and [`MorphJob::write`] are the two halves (a caller shows
/// the notes of the first while the second runs); [`MorphJob::run`] does both.
#[derive(Clone, Debug)]
pub struct MorphJob {
    /// The images, the maps' source and the options.
    pub inputs: MorphInputs,
    /// What to write, and where. The preview's background is the settings'
    /// ([`crate::jobs::morph_inputs::MorphSettings::background`]); `files.background` is
    /// not read.
    pub files: MorphFileOptions,
}

/// Why a morph job failed.
#[derive(Debug, thiserror::Error)]
pub enum MorphJobError {
    /// Reading the inputs or making the morph.
    #[error(transparent)]
    Inputs(#[from] MorphInputError),
    /// The frame count or time range, or writing the files.
    #[error(transparent)]
    Files(#[from] MorphFilesError),
}

/// What a [`MorphJob`] did: the notes of making the morph and the report of its files.
#[derive(Clone, Debug)]
pub struct MorphOutcome {
    /// The fits' summaries and warnings and the alignment ([`MadeMorph::notes`]).
    pub notes: Vec<MorphNote>,
    /// What writing the files did.
    pub files: MorphFilesReport,
    /// Frames written.
    pub frames: usize,
    /// The frames' size (A's), px.
    pub size: (u32, u32),
    /// The output folder.
    pub output: PathBuf,
    /// Whether the maps were fitted to landmarks.
    pub from_landmarks: bool,
    /// Wall time of each phase: `read`, `fits`, then [`MorphFilesReport::phases`].
    pub phases: Phases,
}

impl MorphOutcome {
    /// The notes and warnings about the frames written (pixels no image covers, times not
    /// certified fold-free), as `trimorph morph` prints them.
    pub fn frame_notes(&self) -> Vec<String> {
        let rep = &self.files;
        let mut out = Vec::new();
        if rep.uncovered > 0 {
            out.push(format!(
                "note: {} pixels over all frames have a preimage in neither image (they show \
                 --background)",
                rep.uncovered
            ));
        }
        if !rep.uncertified.is_empty() {
            let ts: Vec<String> = rep.uncertified.iter().map(|t| format!("{t:.3}")).collect();
            out.push(format!(
                "warning: the blended maps are not certified fold-free at t = {}",
                ts.join(", ")
            ));
        }
        out
    }

    /// The line on the inverse maps' per-pixel Newton solves (`--timings`).
    pub fn newton_line(&self) -> String {
        format!(
            "inverse maps: {} pixels solved by per-pixel Newton over all frames",
            self.files.newton_solves
        )
    }

    /// The summary line: frames, size, the files, and the landmarks' largest residual.
    pub fn summary(&self) -> String {
        let rep = &self.files;
        let residual = if self.from_landmarks {
            format!("; largest landmark fit residual {:.3} px", rep.largest_residual)
        } else {
            String::new()
        };
        format!(
            "{} frames ({} x {}) in {}; {}, {}, {}{}",
            self.frames,
            self.size.0,
            self.size.1,
            self.output.display(),
            rep.gif.display(),
            rep.apng.display(),
            rep.sheet.display(),
            residual
        )
    }
}

impl MorphJob {
    /// Checks the frame count ([`check_frames`]), then makes the morph from its inputs
    /// ([`MorphInputs::make`]).
    pub fn make(&self) -> Result<MadeMorph, MorphJobError> {
        check_frames(self.files.frames)?;
        Ok(self.inputs.make()?)
    }

    /// Writes the files of the morph `made` ([`write_morph`]); `progress` is called once
    /// per computed frame, from any thread.
    pub fn write(
        &self,
        made: &MadeMorph,
        progress: &(dyn Fn() + Sync),
    ) -> Result<MorphOutcome, MorphJobError> {
        let files =
            MorphFileOptions { background: self.inputs.settings.background, ..self.files.clone() };
        let report = write_morph(&made.morph, &files, progress)?;
        let mut phases = made.phases.clone();
        for &(name, ms) in &report.phases {
            phases.add(name, ms);
        }
        let a = made.morph.image_a();
        Ok(MorphOutcome {
            notes: made.notes.clone(),
            files: report,
            frames: files.frames,
            size: (a.width(), a.height()),
            output: files.output,
            from_landmarks: made.from_landmarks,
            phases,
        })
    }

    /// Runs the job: [`MorphJob::make`], then [`MorphJob::write`].
    pub fn run(&self, progress: &(dyn Fn() + Sync)) -> Result<MorphOutcome, MorphJobError> {
        let made = self.make()?;
        self.write(&made, progress)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::landmarks::LandmarkSource;
    use crate::jobs::morph_inputs::{MorphSettings, MorphSource};

    fn gray(w: u32, h: u32) -> DynamicImage {
        DynamicImage::ImageLuma8(image::GrayImage::from_fn(w, h, |x, y| {
            image::Luma([((x * 7 + y * 3) % 256) as u8])
        }))
    }

    fn job(dir: &Path, source: MorphSource, frames: usize) -> MorphJob {
        MorphJob {
            inputs: MorphInputs {
                a: dir.join("a.png"),
                b: dir.join("b.png"),
                source,
                settings: MorphSettings::default(),
            },
            files: MorphFileOptions::new(dir.join("out"), frames),
        }
    }

    #[test]
    fn a_job_writes_the_morph_of_its_files_and_reads_its_own_maps_back() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let l = d.join("l.csv");
        let landmarks = MorphSource::Landmarks(LandmarkSource::File(l.clone()));
        // The frame count is checked before anything is read.
        let e = job(d, landmarks.clone(), 1).make().err().unwrap();
        assert!(matches!(e, MorphJobError::Files(MorphFilesError::TooFewFrames { frames: 1 })));
        gray(40, 30).save(d.join("a.png")).unwrap();
        gray(36, 32).save(d.join("b.png")).unwrap();
        std::fs::write(&l, "p,5,5,6,5\nq,30,6,29,7\nr,8,22,8,24\ns,28,24,27,25\n").unwrap();
        let done = job(d, landmarks, 3).run(&|| {}).unwrap();
        assert!(done.from_landmarks && done.frames == 3 && done.size == (40, 30));
        assert!(matches!(done.notes.last(), Some(MorphNote::Aligned { .. })));
        let out = d.join("out");
        assert!(done.summary().starts_with(&format!("3 frames (40 x 30) in {}; ", out.display())));
        assert!(done.summary().contains("; largest landmark fit residual "));
        let phases: Vec<&str> = done.phases.rows().iter().map(|r| r.0).collect();
        assert_eq!(phases[..3], ["read", "fits", "frames and encoding"]);
        for f in ["frame_000.png", "frame_002.png", "phi_ab.json", "phi_ba.json", "morph.gif"] {
            assert!(out.join(f).is_file(), "{f}");
        }
        // The maps written, given back: the stored similarity aligns B again.
        std::fs::rename(out.join("phi_ab.json"), d.join("phi_ab.json")).unwrap();
        let given = MorphSource::Deformations { phi_ab: d.join("phi_ab.json"), phi_ba: None };
        let done = job(d, given, 2).run(&|| {}).unwrap();
        assert!(!done.from_landmarks);
        assert!(matches!(done.notes[0], MorphNote::SimilarityRead { .. }));
        assert!(!done.summary().contains("residual"));
    }

    #[test]
    fn frame_counts_and_time_ranges_are_typed_errors_with_their_texts() {
        let e = check_frames(1).unwrap_err();
        assert!(matches!(e, MorphFilesError::TooFewFrames { frames: 1 }));
        assert_eq!(
            e.to_string(),
            "--frames must be at least 2 (the first frame is A, the last B), got 1"
        );
        let e = check_frames(MAX_FRAMES + 1).unwrap_err();
        assert!(matches!(e, MorphFilesError::TooManyFrames { frames: 10_001 }));
        assert_eq!(
            e.to_string(),
            "--frames: at most 10000 (a thumbnail of every frame is kept for the contact sheet), \
             got 10001"
        );
        assert!(check_frames(2).is_ok() && check_frames(MAX_FRAMES).is_ok());
        let e = check_range((0.0, 200.0)).unwrap_err();
        assert!(matches!(e, MorphFilesError::TimesOutOfRange { t0: 0.0, t1: 200.0 }));
        assert_eq!(e.to_string(), "--range: times must lie within -100..100, got `0,200`");
        assert!(check_range((f64::NAN, 1.0)).is_err());
        assert!(check_range((-MAX_TIME, MAX_TIME)).is_ok());
    }
}
