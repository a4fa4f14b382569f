//! Fitting one scene to every frame of a sequence: targets per frame (given, or tracked
//! from the first frame), held-out landmarks, warm starts, resumable runs and shards, with
//! a progress callback and no terminal or file code (the caller's [`Store`] keeps the
//! results).
//!
//! The scene is a deformation `phi` of the reference domain (usually a 2.5D PrisMystic
//! scene, 2017 thesis Part III, ch. 15-19: `psi = (phi, alpha0 sigma0 + alpha1 sigma1)`);
//! each frame's fit ([`crate::fit::fit`]) changes `phi` so that landmark sources in
//! the reference land on their targets in that frame. Tracking is not in the thesis: it is
//! pyramidal Lucas-Kanade ([`crate::fit::track`]).
//!
//! # Targets
//!
//! [`Targets::Fixed`] uses one landmark list for every frame, [`Targets::PerFrame`] one list
//! per frame, and [`Targets::Tracked`] follows the first frame's targets through the frames.
//! With `m` points, let `x_k^i` be point `i`'s target in frame `k` (`x_0^i` is given):
//!
//! * [`Anchor::Chain`]: `x_k = LK(F_{k-1} -> F_k, x_{k-1})`. Each step's error is added to
//!   the last, so the targets wander off the features over a long sequence (drift).
//! * [`Anchor::First`]: `x_k = LK(F_0 -> F_k, x_0)`, started from the guess `x_{k-1}`:
//!   every frame is compared with the first, so errors do not accumulate.
//! * [`Anchor::KeyFrames`]`(n)`: key frames `k = n, 2n, ...` as with `First`; any other
//!   frame from the key frame `r = n floor(k / n)` before it: `x_k = LK(F_r -> F_k, x_r)`,
//!   started from `x_{k-1}` (for features whose look changes slowly over the sequence).
//!
//! A point lost by the tracker (see [`crate::fit::track`]) stays lost in later frames.
//!
//! **Drift.** Every frame reports the drift `D_k = sqrt(mean_i |c_k^i - a_k^i|^2)` over the
//! points tracked in both, where `c` are the chained targets and `a` the anchored ones (the
//! anchor's targets; when the anchor is `Chain`, the targets tracked from the first frame
//! are computed for this comparison only). It is a measure of how far chaining would have
//! wandered, not an error against ground truth.
//!
//! # Held-out landmarks
//!
//! With `holdout = h > 0` the same landmarks are kept out of every frame's fit: `h` of the
//! first frame's list chosen by [`crate::fit::landmarks::holdout`] with the seed, identified
//! by name (unnamed ones by their position `#i` in their list; tracked ones by their
//! position in the first list). Each frame's report has their error (the TRE) and the
//! summary pools it over the frames: `rms = sqrt(sum_k n_k rms_k^2 / sum_k n_k)`.
//!
//! # Fitting order and resume
//!
//! Tracked sequences are fitted in frame order, each fit started from the previous frame's
//! result (a warm start); other sequences are fitted independently in parallel, from the
//! scene. Before fitting a frame the [`Store`] says what it holds for it. The frame's
//! [`ResumeKey`] records what the result is computed from: the frame's name and pixels, the
//! scene, the landmark input and this frame's actual targets, the kind of targets (anchor,
//! tracker settings), the fit options, the hold-out and its seed, and entries the caller
//! adds ([`SequenceOptions::key_extra`]). A frame is skipped only when the store has a
//! report with an equal key and every other output; otherwise it is fitted again and the
//! [`Reason`] says why. A shard (`i` of `n`) fits frames `floor(i F / n) .. floor((i + 1) F / n)`
//! of `F`; tracking always runs from the first frame (it is cheap), so shards agree.

mod anchor;
mod key;
mod summary;
pub use summary::{FrameEntry, SequenceReport, StoredReport};
#[cfg(test)]
mod tests;

pub use anchor::{
    choose_anchor, drift, follow, track_targets, Anchor, AnchorChoiceError, AnchorKind, Drift,
    Positions, Tracking, UnknownAnchor,
};
pub(crate) use key::image_hash;
pub use key::ResumeKey;

use super::landmarks::{holdout, Landmark};
use super::track::{TrackError, TrackOptions};
use super::{fit, with_holdout, FitError, FitOptions, FitReport};
use crate::spline::Spline;
use image::{DynamicImage, GrayImage};
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::time::Instant;

/// An error of the caller's [`Store`].
pub type StoreError = Box<dyn std::error::Error + Send + Sync>;

/// One frame: its name (unique in the sequence: the caller names its outputs after it), where
/// it came from (for messages), its pixels, and their 8-bit gray version for tracking.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Name, e.g. the file stem.
    pub name: String,
    /// Where it was read from, e.g. `dir/f0.png` or `stack.tif, page 3`.
    pub source: String,
    /// The pixels, any type.
    pub image: DynamicImage,
    gray: GrayImage,
}

impl Frame {
    /// A frame; the gray version is [`to_gray8`] of `image`.
    pub fn new(name: impl Into<String>, source: impl Into<String>, image: DynamicImage) -> Frame {
        let gray = to_gray8(&image);
        Frame { name: name.into(), source: source.into(), image, gray }
    }

    /// The 8-bit gray version (tracking, overlays).
    pub fn gray(&self) -> &GrayImage {
        &self.gray
    }
}

/// 8-bit gray for tracking: 16-bit gray is scaled so that its largest sample becomes 255
/// (microscopy frames rarely use the whole 16-bit range); everything else is converted by
/// the `image` crate (luma of colour, alpha dropped, float clamped to `[0, 1]`).
pub fn to_gray8(img: &DynamicImage) -> GrayImage {
    match img {
        DynamicImage::ImageLuma16(g) => {
            let max = g.pixels().map(|p| p[0]).max().unwrap_or(1).max(1) as f64;
            GrayImage::from_fn(g.width(), g.height(), |x, y| {
                image::Luma([((g.get_pixel(x, y)[0] as f64) * 255.0 / max).round() as u8])
            })
        }
        other => other.to_luma8(),
    }
}

/// Where each frame's targets come from (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub enum Targets {
    /// The same landmarks in every frame.
    Fixed(Vec<Landmark>),
    /// One landmark list per frame.
    PerFrame(Vec<Vec<Landmark>>),
    /// Targets in the first frame, followed through the others.
    Tracked {
        /// The first frame's landmarks.
        first: Vec<Landmark>,
        /// Which frame each frame is tracked from.
        anchor: Anchor,
        /// Tracker settings.
        options: TrackOptions,
    },
}

/// Options of a [`Sequence`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SequenceOptions {
    /// Options of every frame's fit.
    pub fit: FitOptions,
    /// Landmarks kept out of every fit (0: none).
    pub holdout: usize,
    /// Seed of the hold-out choice.
    pub seed: u64,
    /// Only shard `i` of `n` (`0 <= i < n`).
    pub shard: Option<(usize, usize)>,
    /// More resume-key entries, for whatever else the caller's outputs depend on (a model
    /// file, a resampling option, ...).
    pub key_extra: BTreeMap<String, String>,
}

/// Why a sequence cannot be fitted.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    /// No frames.
    #[error("the sequence has no frames")]
    NoFrames,
    /// Two frames with one name (their outputs would overwrite each other).
    #[error(
        "frames {first} and {second} have the same name \"{name}\": their outputs \
         ({name}.json, {name}.report.json, ...) would overwrite each other; rename one or \
         move it to another folder"
    )]
    SameName {
        /// The name.
        name: String,
        /// The first frame's source.
        first: String,
        /// The second frame's source.
        second: String,
    },
    /// Per-frame landmark lists that are not one per frame.
    #[error("{sets} landmark lists for {frames} frames")]
    Sets {
        /// Lists.
        sets: usize,
        /// Frames.
        frames: usize,
    },
    /// A hold-out that leaves nothing to fit.
    #[error(
        "cannot hold out {k} landmarks: the first frame has {len}, at least one must be fitted"
    )]
    Holdout {
        /// Requested.
        k: usize,
        /// Landmarks of the first frame.
        len: usize,
    },
    /// A shard out of range.
    #[error("shard {i}/{n}: expected 0 <= i < n")]
    Shard {
        /// Index.
        i: usize,
        /// Count.
        n: usize,
    },
    /// Key frames every 0 frames.
    #[error("key frames every 0 frames: the spacing must be at least 1")]
    KeyEvery,
    /// A frame index beyond the sequence ([`Sequence::run_frame`]).
    #[error("frame {index} does not exist (the sequence has {frames})")]
    FrameIndex {
        /// The index.
        index: usize,
        /// Frames in the sequence.
        frames: usize,
    },
    /// Tracking into a frame failed.
    #[error("tracking into frame {name}: {source}")]
    Track {
        /// The frame's index.
        index: usize,
        /// Its name.
        name: String,
        /// The cause.
        source: TrackError,
    },
    /// A frame's fit failed.
    #[error("frame {name}: {source}")]
    Fit {
        /// The frame's index.
        index: usize,
        /// Its name.
        name: String,
        /// The cause.
        source: FitError,
    },
    /// The store failed for a frame.
    #[error("frame {name}: {source}")]
    Store {
        /// The frame's index.
        index: usize,
        /// Its name.
        name: String,
        /// The cause.
        source: StoreError,
    },
}

/// What a [`Store`] holds for a frame.
#[derive(Clone, Debug, Default)]
pub struct Stored {
    /// The frame's report, as written from [`FrameResult::report_text`] (`None`: none).
    pub report: Option<StoredReport>,
    /// Outputs other than the report that are missing (names, for messages).
    pub missing: Vec<String>,
    /// The stored deformation (the next frame's warm start when this one is skipped).
    pub spline: Option<Spline>,
}

/// Where the results go: the caller's files, a database, memory.
pub trait Store: Sync {
    /// What is stored for frame `index`.
    fn stored(&self, index: usize, frame: &Frame) -> Result<Stored, StoreError>;
    /// Keeps a frame's result (called from several threads at once for untracked
    /// sequences).
    fn save(&self, result: &FrameResult, frame: &Frame) -> Result<(), StoreError>;
}

/// Why a frame is fitted.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Reason {
    /// Nothing stored.
    New,
    /// A stored report without a resume key (an older version wrote it).
    Unkeyed,
    /// The stored key differs in these entries.
    Changed(Vec<String>),
    /// These outputs are missing.
    Missing(Vec<String>),
}

impl std::fmt::Display for Reason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Reason::New => write!(f, "new"),
            Reason::Unkeyed => write!(f, "earlier report has no resume key, refitting"),
            Reason::Changed(c) => {
                write!(f, "options changed, refitting (changed: {})", c.join(", "))
            }
            Reason::Missing(m) => write!(f, "output missing ({}), refitting", m.join(", ")),
        }
    }
}

/// What happened to a frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Action {
    /// Fitted, for this reason.
    Fitted(Reason),
    /// Its stored results are current.
    Skipped,
}

/// Error statistics read from a report: count, RMS, max (pixels).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Errors {
    /// Landmarks.
    pub count: usize,
    /// Root mean square.
    pub rms: f64,
    /// Largest.
    pub max: f64,
}

impl Errors {
    fn from_json(v: &serde_json::Value) -> Option<Errors> {
        Some(Errors {
            count: v.get("count")?.as_u64()? as usize,
            rms: v.get("rms")?.as_f64()?,
            max: v.get("max")?.as_f64()?,
        })
    }
}

/// A frame just fitted, as given to [`Store::save`].
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// Index in the sequence.
    pub index: usize,
    /// The frame's name.
    pub name: String,
    /// The fitted deformation.
    pub spline: Spline,
    /// The landmarks it was fitted to (the held-out ones left out): its file carries them,
    /// as every fit's does, so the editor's re-fit keeps them.
    pub landmarks: Vec<Landmark>,
    /// The fit's report, with the held-out landmarks' TRE.
    pub report: FitReport,
    /// Tracked points lost going into this frame.
    pub lost: usize,
    /// Drift of the tracked targets (tracked sequences).
    pub drift: Option<Drift>,
    /// The anchor (tracked sequences).
    pub anchor: Option<Anchor>,
    /// What the result is computed from.
    pub key: ResumeKey,
}

impl FrameResult {
    /// The report to store, as pretty JSON: the [`FitReport`]'s keys, then `frame`,
    /// `tracking_lost`, `anchor` and `drift` (`null` when not tracked), and `resume` (the
    /// key).
    pub fn report_text(&self) -> String {
        /// The stored report: the fit's keys, then the frame's.
        #[derive(serde::Serialize)]
        struct Out<'a> {
            #[serde(flatten)]
            report: &'a FitReport,
            frame: &'a str,
            tracking_lost: usize,
            anchor: Option<String>,
            drift: Option<Drift>,
            resume: serde_json::Value,
        }
        let out = Out {
            report: &self.report,
            frame: &self.name,
            tracking_lost: self.lost,
            anchor: self.anchor.map(|a| a.to_string()),
            drift: self.drift,
            resume: self.key.to_json(),
        };
        serde_json::to_string_pretty(&out).unwrap_or_default()
    }
}

/// One frame's outcome.
#[derive(Clone, Debug)]
pub struct FrameOutcome {
    /// Index in the sequence.
    pub index: usize,
    /// The frame's name.
    pub name: String,
    /// Fitted (why) or skipped.
    pub action: Action,
    /// The report of a fitted frame.
    pub report: Option<FitReport>,
    /// Residuals of the fitted landmarks (from the stored report when skipped).
    pub fit: Option<Errors>,
    /// TRE of the held-out landmarks (from the stored report when skipped).
    pub tre: Option<Errors>,
    /// Drift of the tracked targets.
    pub drift: Option<Drift>,
    /// Tracked points lost going into the frame.
    pub lost: usize,
}

/// A progress event.
#[derive(Clone, Copy, Debug)]
pub enum Event<'a> {
    /// Tracking finished (`frames` frames, `ms` milliseconds).
    Tracked {
        /// Frames tracked.
        frames: usize,
        /// Time taken.
        ms: f64,
    },
    /// A frame is done (from any thread for untracked sequences).
    Frame(&'a FrameOutcome),
}

/// TRE pooled over frames.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Pooled {
    /// Frames with held-out landmarks.
    pub frames: usize,
    /// Held-out residuals in all.
    pub count: usize,
    /// `sqrt(sum_k n_k rms_k^2 / sum_k n_k)`.
    pub rms: f64,
    /// Largest over the frames.
    pub max: f64,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct SequenceSummary {
    /// The frames of the shard, in order.
    pub frames: Vec<FrameOutcome>,
    /// The shard's frames `lo..hi`.
    pub range: (usize, usize),
    /// Frames in the sequence.
    pub total: usize,
    /// Tracking time (milliseconds; 0 when not tracked).
    pub track_ms: f64,
    /// TRE over the shard's frames, when landmarks were held out.
    pub tre: Option<Pooled>,
    /// The largest drift over the shard's frames (tracked sequences).
    pub drift_max: Option<Drift>,
}

impl SequenceSummary {
    /// Frames fitted in this run.
    pub fn fitted(&self) -> usize {
        self.frames.iter().filter(|f| f.action != Action::Skipped).count()
    }
}

/// `floor(i F / n) .. floor((i + 1) F / n)`: the frames of shard `i` of `n` (`i < n`).
pub fn shard_range(i: usize, n: usize, frames: usize) -> (usize, usize) {
    // In u128: `i * frames` overflows usize for huge (but valid) `i/n`; the quotients are
    // at most `frames`, so they fit back.
    let at = |k: usize| (k as u128 * frames as u128 / n.max(1) as u128) as usize;
    (at(i), at(i + 1))
}

/// A sequence to fit (see the module docs).
pub struct Sequence<'a> {
    scene: &'a Spline,
    frames: &'a [Frame],
    targets: Targets,
    opts: SequenceOptions,
    range: (usize, usize),
    held: BTreeSet<String>,
}

/// A landmark's identity across frames: its name, else `#` and its position.
fn ident(i: usize, l: &Landmark) -> String {
    l.name.clone().unwrap_or_else(|| format!("#{i}"))
}

/// Hash of bytes (FNV-1a, 64 bit, 16 hex digits), for [`SequenceOptions::key_extra`]
/// entries such as a model file's content.
pub fn content_hash(bytes: &[u8]) -> String {
    key::Fnv::new().bytes(bytes).hex()
}

/// Checks that no two frames share a name (their outputs would overwrite each other).
pub fn check_names(frames: &[Frame]) -> Result<(), SequenceError> {
    let mut seen: HashMap<&str, &Frame> = HashMap::new();
    for f in frames {
        if let Some(g) = seen.insert(&f.name, f) {
            return Err(SequenceError::SameName {
                name: f.name.clone(),
                first: g.source.clone(),
                second: f.source.clone(),
            });
        }
    }
    Ok(())
}

impl<'a> Sequence<'a> {
    /// Checks the inputs: frames with distinct names, one landmark list per frame, a
    /// hold-out that leaves landmarks to fit, a shard in range.
    pub fn new(
        scene: &'a Spline,
        frames: &'a [Frame],
        targets: Targets,
        opts: SequenceOptions,
    ) -> Result<Sequence<'a>, SequenceError> {
        if frames.is_empty() {
            return Err(SequenceError::NoFrames);
        }
        check_names(frames)?;
        let reference: &[Landmark] = match &targets {
            Targets::Fixed(l) => l,
            Targets::PerFrame(v) if v.len() != frames.len() => {
                return Err(SequenceError::Sets { sets: v.len(), frames: frames.len() })
            }
            Targets::PerFrame(v) => &v[0],
            Targets::Tracked { anchor: Anchor::KeyFrames(0), .. } => {
                return Err(SequenceError::KeyEvery)
            }
            Targets::Tracked { first, .. } => first,
        };
        let mut held = BTreeSet::new();
        if opts.holdout > 0 {
            let k = opts.holdout;
            let tagged: Vec<Landmark> = reference
                .iter()
                .enumerate()
                .map(|(i, l)| Landmark { name: Some(ident(i, l)), ..l.clone() })
                .collect();
            let (_, out) = holdout(&tagged, k, opts.seed)
                .map_err(|_| SequenceError::Holdout { k, len: reference.len() })?;
            held = out.into_iter().filter_map(|l| l.name).collect();
        }
        let range = match opts.shard {
            Some((i, n)) if n == 0 || i >= n => return Err(SequenceError::Shard { i, n }),
            Some((i, n)) => shard_range(i, n, frames.len()),
            None => (0, frames.len()),
        };
        Ok(Sequence { scene, frames, targets, opts, range, held })
    }

    /// The frames this run covers (`lo..hi`).
    pub fn range(&self) -> (usize, usize) {
        self.range
    }

    /// Names of the held-out landmarks (see the module docs).
    pub fn held_out(&self) -> &BTreeSet<String> {
        &self.held
    }

    /// Tracks the targets of a tracked sequence (always from the first frame, so that every
    /// shard and every single-frame task agrees): the tracking and its time in ms.
    fn track(
        &self,
        progress: &(dyn Fn(Event<'_>) + Sync),
    ) -> Result<(Option<Tracking>, f64), SequenceError> {
        let t0 = Instant::now();
        let tracking = match &self.targets {
            Targets::Tracked { first, anchor, options } => {
                let grays: Vec<&GrayImage> = self.frames.iter().map(Frame::gray).collect();
                let t = track_targets(&grays, first, *anchor, options).map_err(|(k, e)| {
                    SequenceError::Track { index: k, name: self.frames[k].name.clone(), source: e }
                })?;
                Some(t)
            }
            _ => None,
        };
        let track_ms = if tracking.is_some() { t0.elapsed().as_secs_f64() * 1e3 } else { 0.0 };
        if tracking.is_some() {
            progress(Event::Tracked { frames: self.frames.len(), ms: track_ms });
        }
        Ok((tracking, track_ms))
    }

    /// The warm start of frame `k` in a tracked sequence: the store's deformation for frame
    /// `k - 1`, or the scene (frame 0, or nothing stored).
    fn warm_start(&self, k: usize, store: &dyn Store) -> Result<Spline, SequenceError> {
        if k == 0 {
            return Ok(self.scene.clone());
        }
        let prev =
            store.stored(k - 1, &self.frames[k - 1]).map_err(|e| self.store_err(k - 1, e))?;
        Ok(prev.spline.unwrap_or_else(|| self.scene.clone()))
    }

    /// Fits frame `k` alone (of all the frames, whatever the shard), for one task per frame
    /// (an array job, a task graph): exactly what [`Sequence::run`] does for that frame. A
    /// tracked sequence tracks from the first frame and warm-starts from the store's result
    /// for frame `k - 1` (the scene when there is none, so tasks must then run in frame order
    /// to match a whole run); the frame is skipped when the store's results are current, and
    /// a new result goes to `store` (a file store writes each output atomically, so a rerun
    /// resumes).
    pub fn run_frame(
        &self,
        k: usize,
        store: &dyn Store,
        progress: &(dyn Fn(Event<'_>) + Sync),
    ) -> Result<FrameOutcome, SequenceError> {
        if k >= self.frames.len() {
            return Err(SequenceError::FrameIndex { index: k, frames: self.frames.len() });
        }
        let (tracking, _) = self.track(progress)?;
        let sets = self.frame_sets(tracking.as_ref());
        let ctx = self.context(store, progress, &sets, tracking.as_ref());
        let warm = if tracking.is_some() { self.warm_start(k, store)? } else { self.scene.clone() };
        Ok(ctx.one(k, &warm)?.0)
    }

    /// Tracks the targets (tracked sequences), then fits the shard's frames, asking `store`
    /// what it holds and giving it every new result; `progress` hears of every step.
    pub fn run(
        &self,
        store: &dyn Store,
        progress: &(dyn Fn(Event<'_>) + Sync),
    ) -> Result<SequenceSummary, SequenceError> {
        let (tracking, track_ms) = self.track(progress)?;
        let sets = self.frame_sets(tracking.as_ref());
        let (lo, hi) = self.range;
        let ctx = self.context(store, progress, &sets, tracking.as_ref());
        let frames: Vec<FrameOutcome> = if tracking.is_some() {
            let mut warm = self.warm_start(lo, store)?;
            let mut out = Vec::with_capacity(hi - lo);
            for k in lo..hi {
                let (o, s) = ctx.one(k, &warm)?;
                if let Some(s) = s {
                    warm = s;
                }
                out.push(o);
            }
            out
        } else {
            (lo..hi)
                .into_par_iter()
                .map(|k| ctx.one(k, self.scene).map(|r| r.0))
                .collect::<Result<Vec<_>, _>>()?
        };
        let tres: Vec<Errors> = frames.iter().filter_map(|f| f.tre).collect();
        let count: usize = tres.iter().map(|t| t.count).sum();
        let tre = (count > 0).then(|| Pooled {
            frames: tres.len(),
            count,
            rms: (tres.iter().map(|t| t.count as f64 * t.rms * t.rms).sum::<f64>() / count as f64)
                .sqrt(),
            max: tres.iter().map(|t| t.max).fold(0.0, f64::max),
        });
        let drift_max =
            frames.iter().filter_map(|f| f.drift).max_by(|a, b| a.rms.total_cmp(&b.rms));
        Ok(SequenceSummary {
            frames,
            range: self.range,
            total: self.frames.len(),
            track_ms,
            tre,
            drift_max,
        })
    }

    /// What fitting one frame needs.
    fn context<'s>(
        &'s self,
        store: &'s dyn Store,
        progress: &'s (dyn Fn(Event<'_>) + Sync),
        sets: &'s [Vec<(String, Landmark)>],
        tracking: Option<&'s Tracking>,
    ) -> Ctx<'s, 'a> {
        Ctx { seq: self, store, progress, sets, tracking, scene_hash: key::spline_hash(self.scene) }
    }

    fn store_err(&self, index: usize, source: StoreError) -> SequenceError {
        SequenceError::Store { index, name: self.frames[index].name.clone(), source }
    }

    /// Every frame's landmarks with their identities.
    fn frame_sets(&self, tracking: Option<&Tracking>) -> Vec<Vec<(String, Landmark)>> {
        let tag = |l: &[Landmark]| -> Vec<(String, Landmark)> {
            l.iter().enumerate().map(|(i, l)| (ident(i, l), l.clone())).collect()
        };
        match (&self.targets, tracking) {
            (Targets::Fixed(l), _) => vec![tag(l); self.frames.len()],
            (Targets::PerFrame(v), _) => v.iter().map(|l| tag(l)).collect(),
            (Targets::Tracked { .. }, Some(t)) => t
                .sets
                .iter()
                .map(|s| s.iter().map(|(i, l)| (ident(*i, l), l.clone())).collect())
                .collect(),
            (Targets::Tracked { .. }, None) => unreachable!("tracked before fitting"),
        }
    }

    /// Frame `k`'s resume key.
    fn key(&self, k: usize, fitted: &[Landmark], held: &[Landmark], scene_hash: &str) -> ResumeKey {
        let f = &self.frames[k];
        let mut key = ResumeKey::default();
        key.set("frame", f.name.as_str())
            .set("frame_hash", key::image_hash(&f.image))
            .set("scene_hash", scene_hash)
            .set("targets_hash", key::landmarks_hash([fitted, held]))
            .set("fit", format!("{:?}", self.opts.fit))
            .set("holdout", format!("{} (seed {})", self.opts.holdout, self.opts.seed));
        let (kind, input) = match &self.targets {
            Targets::Fixed(l) => ("fixed".to_string(), key::landmarks_hash([&l[..]])),
            Targets::PerFrame(v) => ("per frame".to_string(), key::landmarks_hash([&v[k][..]])),
            Targets::Tracked { first, anchor, options } => (
                format!("tracked, anchor {anchor}, {options:?}"),
                key::landmarks_hash([&first[..]]),
            ),
        };
        key.set("targets", kind).set("landmarks_hash", input);
        for (n, v) in &self.opts.key_extra {
            key.set(n, v.as_str());
        }
        key
    }
}

/// What fitting one frame needs.
struct Ctx<'s, 'a> {
    seq: &'s Sequence<'a>,
    store: &'s dyn Store,
    progress: &'s (dyn Fn(Event<'_>) + Sync),
    sets: &'s [Vec<(String, Landmark)>],
    tracking: Option<&'s Tracking>,
    scene_hash: String,
}

impl Ctx<'_, '_> {
    /// Fits frame `k` from `warm` unless its stored results are current. Returns the
    /// outcome and the deformation to warm-start the next frame from (`None`: keep `warm`).
    fn one(
        &self,
        k: usize,
        warm: &Spline,
    ) -> Result<(FrameOutcome, Option<Spline>), SequenceError> {
        let seq = self.seq;
        let frame = &seq.frames[k];
        let (mut fitted, mut held) = (Vec::new(), Vec::new());
        for (id, l) in &self.sets[k] {
            if seq.held.contains(id) {
                held.push(l.clone())
            } else {
                fitted.push(l.clone())
            }
        }
        let key = seq.key(k, &fitted, &held, &self.scene_hash);
        let lost = self.tracking.map_or(0, |t| t.lost[k]);
        let drift = self.tracking.and_then(|t| t.drift[k]);
        let stored = self.store.stored(k, frame).map_err(|e| seq.store_err(k, e))?;
        let reason = match stored.report.as_ref().and_then(StoredReport::object) {
            None => Reason::New,
            Some(r) => match r.get("resume").and_then(ResumeKey::from_json) {
                None => Reason::Unkeyed,
                Some(old) if old != key => Reason::Changed(old.changed(&key)),
                Some(_) if !stored.missing.is_empty() => Reason::Missing(stored.missing.clone()),
                Some(_) => {
                    let get = |a: &str, b: &str| {
                        r.get(a).and_then(|v| v.get(b)).and_then(Errors::from_json)
                    };
                    let out = FrameOutcome {
                        index: k,
                        name: frame.name.clone(),
                        action: Action::Skipped,
                        report: None,
                        fit: r.get("fit").and_then(Errors::from_json),
                        tre: get("holdout", "tre"),
                        drift,
                        lost,
                    };
                    (self.progress)(Event::Frame(&out));
                    return Ok((out, stored.spline));
                }
            },
        };
        let fit_err = |source| SequenceError::Fit { index: k, name: frame.name.clone(), source };
        let f = fit(warm, &fitted, &seq.opts.fit).map_err(fit_err)?;
        let report = with_holdout(f.report, &f.spline, &held).map_err(fit_err)?;
        let anchor = match &seq.targets {
            Targets::Tracked { anchor, .. } => Some(*anchor),
            _ => None,
        };
        let result = FrameResult {
            index: k,
            name: frame.name.clone(),
            spline: f.spline,
            landmarks: fitted,
            report,
            lost,
            drift,
            anchor,
            key,
        };
        self.store.save(&result, frame).map_err(|e| seq.store_err(k, e))?;
        let errors = |s: &super::Stats| Errors { count: s.count, rms: s.rms, max: s.max };
        let out = FrameOutcome {
            index: k,
            name: frame.name.clone(),
            action: Action::Fitted(reason),
            fit: Some(errors(&result.report.fit)),
            tre: result.report.holdout.as_ref().map(|h| errors(&h.tre)),
            report: Some(result.report),
            drift,
            lost,
        };
        (self.progress)(Event::Frame(&out));
        Ok((out, Some(result.spline)))
    }
}
