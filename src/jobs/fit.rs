//! Fits as files (`trimorph fit`):
//!
//! * [`FitJob`]: one deformation fitted to a landmark file, from a deformation (warm start)
//!   or over a mesh adapted to the landmarks in a frame, written with its report;
//! * [`SequenceJob`]: a scene fitted to every frame of a sequence (`--model SCENE --frames
//!   DIR`): the inputs read by [`crate::jobs::sequence::SequenceInputs`], the fits run by
//!   [`crate::fit::sequence::Sequence`] (resumable, sharded), every frame's files written
//!   into one folder ([`crate::jobs::sequence::FrameFiles`]) and the summary lines
//!   returned.

use super::OptionError;
use super::{BoxError, JobError};
use crate::fit::frame::{fit_frame, FrameFitOptions, FrameReport};
use crate::fit::landmarks::{holdout, Landmark};
use crate::fit::sequence::{Anchor, Event, Frame, SequenceError};
use crate::fit::{fit, with_holdout, FitError, FitOptions, FitReport};
use crate::io::landmarks::LandmarkSource;
use crate::io::{deformation, read_text, write_atomic};
use crate::jobs::sequence::{SceneSource, SequenceInputs, SequenceInputsError};
use crate::mesh::AdaptOptions;
use crate::spline::check::absurd_point;
use crate::spline::{ControlPoint, Spline};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to fit and where (see `trimorph fit --help` for the files).
#[derive(Clone, Debug)]
pub struct SequenceJob {
    /// The scene: a deformation file (usually from `model bind`), or a 2D scene made from
    /// the landmarks ([`SceneSource`]).
    pub scene: SceneSource,
    /// The scene's model file (default: the scene's `"model"` key).
    pub model: Option<PathBuf>,
    /// A folder of images or a multi-page TIFF.
    pub frames: PathBuf,
    /// Landmarks (targets in the first frame), or a folder of per-frame files.
    pub landmarks: PathBuf,
    /// Follow the landmarks from frame to frame from this anchor (`None`: not tracked).
    pub track: Option<Anchor>,
    /// Registered frames' value outside the map (sample units).
    pub background: f64,
    /// Options of every frame's fit.
    pub fit: FitOptions,
    /// Landmarks kept out of every fit (0: none), chosen with `seed`.
    pub holdout: usize,
    /// Seed of the hold-out choice.
    pub seed: u64,
    /// Only the `i`-th of `n` contiguous frame ranges.
    pub shard: Option<(usize, usize)>,
    /// The output folder.
    pub output: PathBuf,
    /// The sequence summary (JSON), if wanted.
    pub report: Option<PathBuf>,
}

/// Why a sequence job failed.
#[derive(Debug, thiserror::Error)]
pub enum SequenceJobError {
    /// A frame's fit failed (see [`FitError::is_unsolvable`]).
    #[error("{frame}")]
    Fit {
        /// The frame.
        frame: Box<FitFrame>,
        /// The fit's error.
        #[source]
        error: FitError,
    },
    /// A frame's files could not be written.
    #[error("frame {frame}")]
    Store {
        /// The frame's name.
        frame: String,
        /// The cause.
        #[source]
        error: BoxError,
    },
    /// The sequence (frames, targets, options).
    #[error(transparent)]
    Sequence(SequenceError),
    /// The inputs.
    #[error(transparent)]
    Inputs(#[from] Box<SequenceInputsError>),
    /// The output folder or the summary file.
    #[error(transparent)]
    Job(#[from] JobError),
}

/// The frame whose fit failed, as errors name it: `frame NAME (READ FROM; landmarks L[,
/// tracked from the first frame])`.
#[derive(Clone, Debug)]
pub struct FitFrame {
    /// The frame's name.
    pub name: String,
    /// Where the frame was read from.
    pub read_from: String,
    /// The landmark file.
    pub landmarks: String,
    /// Whether the targets were tracked from the first frame.
    pub tracked: bool,
}

impl std::fmt::Display for FitFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "frame {} ({}; landmarks {}{})",
            self.name,
            self.read_from,
            self.landmarks,
            if self.tracked { ", tracked from the first frame" } else { "" }
        )
    }
}

impl SequenceJob {
    fn error(&self, e: SequenceError, frames: &[Frame]) -> SequenceJobError {
        match e {
            SequenceError::Fit { index, source, .. } => SequenceJobError::Fit {
                frame: Box::new(FitFrame {
                    name: frames[index].name.clone(),
                    read_from: frames[index].source.clone(),
                    landmarks: self.landmarks.display().to_string(),
                    tracked: self.track.is_some() && !self.landmarks.is_dir(),
                }),
                error: source,
            },
            SequenceError::Store { index, source, .. } => {
                SequenceJobError::Store { frame: frames[index].name.clone(), error: source }
            }
            other => SequenceJobError::Sequence(other),
        }
    }

    /// Runs the job: reads the inputs, fits the frames of the shard (`on_start` hears how
    /// many, `on_frame` each one done) and writes every frame's files. Returns the report
    /// lines (one per frame, the totals, the TRE and drift lines) and the summary, which
    /// [`SequenceJob::write_report`] writes.
    pub fn run(
        &self,
        on_start: &mut dyn FnMut(usize),
        on_frame: &(dyn Fn() + Sync),
    ) -> Result<SequenceOutcome, SequenceJobError> {
        let t0 = Instant::now();
        let inputs = SequenceInputs::load(
            &self.scene,
            self.model.as_deref(),
            &self.frames,
            &self.landmarks,
            self.track,
            self.background,
        )?;
        let frames = &inputs.frames[..];
        let anchor = inputs.anchor();
        let seq = inputs
            .sequence(self.fit.clone(), self.holdout, self.seed, self.shard)
            .map_err(|e| self.error(e, frames))?;
        let (lo, hi) = seq.range();
        let out = &self.output;
        std::fs::create_dir_all(out)
            .map_err(|e| JobError::context(format!("cannot create {}", out.display()), e))?;
        // Leftovers of an earlier run that was killed mid-write.
        crate::io::remove_stale_temps(out, crate::io::STALE_AFTER);
        let store = inputs.files(out);
        on_start(hi - lo);
        let on_event = |e: Event<'_>| {
            if let Event::Frame(_) = e {
                on_frame()
            }
        };
        let sum = seq.run(&store, &on_event).map_err(|e| self.error(e, frames))?;
        let mut lines = sum.frame_lines();
        let fitted = sum.fitted();
        lines.push(format!(
            "{fitted} frames fitted, {} skipped, frames {lo}..{hi} of {} (landmarks{} in {:.0} ms; total {:.1} s) -> {}",
            sum.frames.len() - fitted,
            frames.len(),
            if anchor.is_some() { " tracked" } else { "" },
            sum.track_ms,
            t0.elapsed().as_secs_f64(),
            out.display()
        ));
        lines.extend(sum.tre_line(seq.held_out()));
        lines.extend(sum.drift_line(anchor));
        Ok(SequenceOutcome { lines, summary: sum.report(anchor) })
    }

    /// Writes the summary of a run to [`SequenceJob::report`], if set.
    pub fn write_report(&self, outcome: &SequenceOutcome) -> Result<(), JobError> {
        if let Some(p) = &self.report {
            let text = outcome.summary.to_text()?;
            write_atomic(p, text.as_bytes())?;
        }
        Ok(())
    }
}

/// What [`SequenceJob::run`] did.
#[derive(Clone, Debug)]
pub struct SequenceOutcome {
    /// The report lines.
    pub lines: Vec<String>,
    /// The sequence summary (the `--report` file).
    pub summary: crate::fit::sequence::SequenceReport,
}

/// Where a single fit starts.
#[derive(Clone, Debug)]
pub enum FitStart {
    /// A deformation file (the warm start; its mesh is used).
    Deformation(PathBuf),
    /// A frame `[width, height]` in pixels: the fit builds a mesh adapted to the landmarks
    /// over it ([`crate::fit::frame::fit_frame`]) and covers the whole frame.
    Frame {
        /// The frame's size.
        size: [f64; 2],
        /// Margin, longest edge and smallest angle of the adapted mesh (`grid` 0: from the
        /// sources).
        adapt: AdaptOptions,
    },
}

/// One deformation fitted to the landmarks of a file (`trimorph fit`).
#[derive(Clone, Debug)]
pub struct FitJob {
    /// Where the fit starts.
    pub start: FitStart,
    /// The landmarks: a landmark file (CSV, BigWarp CSV or JSON), or two point files
    /// (sources and targets: iBUG `.pts`, ITK point sets, CSV `x,y`).
    pub landmarks: LandmarkSource,
    /// The fitted deformation's file.
    pub output: PathBuf,
    /// The report (JSON), if wanted.
    pub report: Option<PathBuf>,
    /// Landmarks kept out of the fit (0: none), chosen with `seed`; their error is the TRE.
    pub holdout: usize,
    /// Seed of the hold-out choice.
    pub seed: u64,
    /// Control points held exactly (a deformation start only).
    pub pin: Option<Pin>,
    /// The fit's options.
    pub fit: FitOptions,
}

/// The control points a fit holds exactly at their values in the input deformation
/// (`--pin`). Parsed from `edited` or a comma list of control point indices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Pin {
    /// The points the deformation file records as corrected by hand in the editor (its
    /// `"pinned"` key).
    Edited,
    /// These control points.
    Points(Vec<ControlPoint>),
}

impl std::str::FromStr for Pin {
    type Err = PinError;
    /// `edited`, or a comma list of control point indices (surrounding spaces ignored).
    fn from_str(list: &str) -> Result<Pin, PinError> {
        if list.trim() == "edited" {
            return Ok(Pin::Edited);
        }
        list.split(',')
            .map(|t| {
                t.trim()
                    .parse::<usize>()
                    .map(ControlPoint)
                    .map_err(|_| PinError(t.trim().to_string()))
            })
            .collect::<Result<_, _>>()
            .map(Pin::Points)
    }
}

/// A `--pin` item that is not a control point index (the text given, trimmed).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a control point index")]
pub struct PinError(pub String);

/// Why a single fit failed.
#[derive(Debug, thiserror::Error)]
pub enum FitJobError {
    /// The fit failed on the landmarks of `file` (see [`FitError::is_unsolvable`]).
    #[error("{file}: {error}")]
    Landmarks {
        /// The landmark file (or both point files, `SRC and DST`).
        file: String,
        /// The fit's error.
        error: FitError,
    },
    /// Anything else.
    #[error(transparent)]
    Job(#[from] JobError),
}

/// What [`FitJob::run`] did.
#[derive(Clone, Debug)]
pub struct FitOutcome {
    /// The fit's report.
    pub report: FitReport,
    /// The adapted mesh, for a frame start.
    pub frame: Option<FrameReport>,
    /// The output file.
    pub output: PathBuf,
}

impl FitOutcome {
    /// The report lines: the adapted mesh (frame starts), the fit's summary and the output.
    pub fn summary(&self) -> String {
        let frame = self.frame.as_ref().map(|f| {
            format!(
                "adapted mesh: {} vertices, {} triangles ({} added by refinement), margin {} px, \
                 grid 1/{}; covers the frame: {}\n",
                f.vertices,
                f.triangles,
                f.steiner,
                f.margin,
                f.grid,
                if f.covers_frame { "yes (certified)" } else { "not certified" },
            )
        });
        format!(
            "{}{}\n-> {}",
            frame.unwrap_or_default(),
            self.report.summary_line(),
            self.output.display()
        )
    }
}

impl FitJob {
    /// Runs the fit and writes the deformation (and the report). `warn` hears the
    /// landmark file's notes as they are read (a dropped constant z; with hard constraints,
    /// coordinates an `f64` cannot hold as written).
    pub fn run(&self, warn: &mut dyn FnMut(String)) -> Result<FitOutcome, FitJobError> {
        let landmarks = &self.landmarks;
        let in_landmarks =
            |error: FitError| FitJobError::Landmarks { file: landmarks.to_string(), error };
        let mut opts = self.fit.clone();
        let def = match &self.start {
            FitStart::Deformation(d) => d,
            FitStart::Frame { size, adapt } => {
                if self.pin.is_some() {
                    return Err(JobError::from(OptionError::PinWithoutDeformation).into());
                }
                let (fitted, held) = self.read_split(warn)?;
                let fopts = FrameFitOptions { mesh: adapt.clone(), degree: 5, fit: opts };
                let r = fit_frame(&fitted, *size, &fopts).map_err(in_landmarks)?;
                let rep = with_holdout(r.fit.report, &r.fit.spline, &held).map_err(in_landmarks)?;
                return self.write(&r.fit.spline, &fitted, rep, Some(r.frame));
            }
        };
        let text = read_text(def).map_err(JobError::from)?;
        let (s, _) = super::parse_deformation(&text, def)?;
        // Far points (a file translated by 1e160, say) lose every digit of their position in
        // f64, so the fit's system is singular; that is the file's doing, not the landmarks'.
        if let Some(what) = absurd_point(&s) {
            return Err(JobError::FarPoint { file: def.clone(), point: what }.into());
        }
        if let Some(pin) = &self.pin {
            opts.pinned = pinned(pin, &text, def)?;
        }
        let (fitted, held) = self.read_split(warn)?;
        // A fit too large for the solver is the deformation's doing (its mesh and degree);
        // every other fit error is about the landmarks.
        let in_file = |e: FitError| -> FitJobError {
            match e {
                FitError::TooLarge { .. } => {
                    JobError::TooLarge { deformation: def.clone(), source: e }.into()
                }
                // Options come from the command line, not from the landmark file: `--pin`
                // names the deformation's control points.
                FitError::NoSuchPinned { .. } if self.pin.is_some() => {
                    JobError::from(OptionError::Pin { deformation: def.clone(), source: e }).into()
                }
                e if e.is_option() => JobError::from(OptionError::Fit(e)).into(),
                e => in_landmarks(e),
            }
        };
        let f = fit(&s, &fitted, &opts).map_err(in_file)?;
        let rep = with_holdout(f.report, &f.spline, &held).map_err(in_file)?;
        self.write(&f.spline, &fitted, rep, None)
    }

    /// The landmarks, split into fitted and held-out ones.
    fn read_split(
        &self,
        warn: &mut dyn FnMut(String),
    ) -> Result<(Vec<Landmark>, Vec<Landmark>), JobError> {
        let (path, k) = (&self.landmarks, self.holdout);
        let (lms, notes) = path
            .read_with_notes()
            .map_err(|e| JobError::context(format!("cannot read landmarks {path}"), e))?;
        if let Some(z) = &notes.constant_z {
            warn(format!("{path}: {z}"));
        }
        if self.fit.hard {
            for n in &notes.approximations {
                warn(format!("{path}: {n}"));
            }
        }
        if k == 0 {
            return Ok((lms, Vec::new()));
        }
        if k >= lms.len() {
            return Err(OptionError::Holdout { holdout: k, landmarks: lms.len() }.into());
        }
        holdout(&lms, k, self.seed).map_err(|e| JobError::context(e.to_string(), e))
    }

    /// Writes the deformation, carrying the landmarks it was fitted to (`fitted`, under
    /// [`deformation::LANDMARKS_KEY`]: the editor's re-fit keeps them), and the report.
    fn write(
        &self,
        s: &Spline,
        fitted: &[Landmark],
        report: FitReport,
        frame: Option<FrameReport>,
    ) -> Result<FitOutcome, FitJobError> {
        let text = deformation::to_string_with_landmarks(s, fitted);
        write_atomic(&self.output, text.as_bytes()).map_err(JobError::from)?;
        if let Some(path) = &self.report {
            let mut v = serde_json::to_value(&report).map_err(JobError::from)?;
            if let Some(f) = &frame {
                v["frame"] = serde_json::to_value(f).map_err(JobError::from)?;
            }
            let text = serde_json::to_string_pretty(&v).map_err(JobError::from)?;
            write_atomic(path, text.as_bytes()).map_err(JobError::from)?;
        }
        Ok(FitOutcome { report, frame, output: self.output.clone() })
    }
}

/// The control points `pin` names (`edited`: the file's recorded corrections).
fn pinned(pin: &Pin, text: &str, def: &Path) -> Result<Vec<ControlPoint>, JobError> {
    match pin {
        Pin::Points(p) => Ok(p.clone()),
        Pin::Edited => {
            let p = deformation::pinned_from_str(text)
                .map_err(|e| JobError::context(format!("--pin edited: {}", def.display()), e))?;
            if p.is_empty() {
                return Err(OptionError::NoEditedPoints { deformation: def.to_path_buf() }.into());
            }
            Ok(p)
        }
    }
}
