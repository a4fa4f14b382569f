//! Registering every frame of a sequence to one reference frame (`trimorph register --frames
//! DIR --reference FRAME`), with warm starts, resumable runs and shards, and no file code:
//! the caller's [`FrameStore`] keeps the results.
//!
//! **Direction.** Frame `k`'s deformation `phi_k` maps frame `k`'s pixels to the reference
//! frame's pixels: the reference is FIXED and frame `k` is MOVING of [`super::register`], so
//! warping frame `k` through `phi_k` resamples it onto the reference (drift correction of a
//! time-lapse). The reference frame's own deformation is the exact identity over the same
//! regular mesh ([`super::frame_mesh`]).
//!
//! **Warm starts** ([`WarmStart`]). Let `r` be the reference and `d = |k - r|` frame `k`'s
//! distance from it. Frame `k`'s solve starts from the result of frame `s(k)` on the same
//! side of `r`, instead of its own pre-alignment:
//! * [`WarmStart::Chain`]: `s = k -+ 1` (distance `d - 1`), so a slow drift never leaves the
//!   reach of one solve;
//! * [`WarmStart::KeyFrames`]`(n)`: frames at distances `n, 2n, ...` are key frames and chain
//!   among themselves (distance `d - n`); every other frame starts from its key frame
//!   (distance `n floor(d / n)`), so a poor result spoils at most the frames up to the next
//!   key frame;
//! * [`WarmStart::None`]: every frame starts from its own pre-alignment.
//!
//! A source at distance 0 (the reference itself) means the frame's own pre-alignment. A
//! source of another size than frame `k` (its mesh covers another frame) is not used.
//! Frames run in order of distance on each side, so a source is always done first.
//!
//! **Resume and shards.** As for sequence fits ([`crate::fit::sequence`]): before frame `k`
//! runs, the store says what it holds. The frame's [`ResumeKey`] records what the result is
//! computed from: its name and pixels, the reference's name and pixels, the masks, the
//! registration options, the warm-start rule and the caller's entries
//! ([`FramesOptions::key_extra`]). A frame is skipped only when its stored key is equal and
//! every other output is there; a skipped frame's stored deformation still serves as a warm
//! start. Shard `i` of `n` runs frames `floor(i F / n) .. floor((i + 1) F / n)`
//! ([`shard_range`]); its first frames start from what the other shards have stored, else
//! from their own pre-alignment.

use super::image::{Channel, Mask};
use super::{frame_mesh, register, Input, Metric, RegisterError, RegisterOptions, RegisterReport};
use crate::fit::sequence::{
    check_names, content_hash, image_hash, shard_range, Frame, Reason, ResumeKey, SequenceError,
    StoreError,
};
use crate::spline::Spline;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::time::Instant;

/// Where each frame's solve starts (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum WarmStart {
    /// From the neighbour on the reference's side (the default).
    #[default]
    Chain,
    /// From key frames every `n >= 1` frames from the reference.
    KeyFrames(usize),
    /// From the frame's own pre-alignment.
    None,
}

impl WarmStart {
    /// The names of the rules, as the command line spells them.
    pub const NAMES: [&'static str; 3] = ["chain", "keyframes", "none"];

    /// The rule named `name` (one of [`WarmStart::NAMES`]); `key_every` is the key frame
    /// spacing, needed by `keyframes` and refused by the others.
    pub fn from_name(name: &str, key_every: Option<usize>) -> Result<WarmStart, FramesError> {
        let bad = |m: String| Err(FramesError::Option(m));
        match (name, key_every) {
            ("keyframes", Some(0)) => bad("--key-every must be at least 1".into()),
            ("keyframes", Some(n)) => Ok(WarmStart::KeyFrames(n)),
            ("keyframes", None) => {
                bad("--warm-start keyframes needs --key-every N (a key frame every N frames)"
                    .into())
            }
            (_, Some(_)) if Self::NAMES.contains(&name) => {
                bad("--key-every goes with --warm-start keyframes".into())
            }
            ("chain", None) => Ok(WarmStart::Chain),
            ("none", None) => Ok(WarmStart::None),
            _ => bad(format!(
                "--warm-start: unknown rule `{name}`; expected one of {}",
                Self::NAMES.join(", ")
            )),
        }
    }

    /// The frame whose result frame `k` starts from when `r` is the reference (`None`: its
    /// own pre-alignment).
    pub fn source(self, k: usize, r: usize) -> Option<usize> {
        let d = k.abs_diff(r);
        if d == 0 {
            return None;
        }
        let at = match self {
            WarmStart::None => return None,
            WarmStart::Chain => d - 1,
            WarmStart::KeyFrames(n) => {
                let n = n.max(1);
                if d.is_multiple_of(n) {
                    d - n
                } else {
                    d - d % n
                }
            }
        };
        (at > 0).then(|| if k > r { r + at } else { r - at })
    }
}

impl std::fmt::Display for WarmStart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WarmStart::Chain => write!(f, "chain"),
            WarmStart::KeyFrames(n) => write!(f, "keyframes every {n}"),
            WarmStart::None => write!(f, "none"),
        }
    }
}

/// Why a sequence registration could not run.
#[derive(Debug, thiserror::Error)]
pub enum FramesError {
    /// An option out of range.
    #[error("{0}")]
    Option(String),
    /// No frame has the reference's name.
    #[error("--reference {given}: no frame is named so (frames: {names}); give a frame's name, file name or index from 0")]
    NoReference {
        /// What was asked for.
        given: String,
        /// The first frames' names.
        names: String,
    },
    /// Two frames with one name, or a bad shard.
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    /// A frame could not be registered.
    #[error("frame {frame}: {source}")]
    Register {
        /// The frame's source.
        frame: String,
        /// The cause.
        source: RegisterError,
    },
    /// The store failed.
    #[error("frame {frame}: {source}")]
    Store {
        /// The frame's name.
        frame: String,
        /// The cause.
        source: StoreError,
    },
}

/// Options of a sequence registration.
#[derive(Clone, Debug, Default)]
pub struct FramesOptions {
    /// Each frame's registration (no landmarks, no `init`, no pinned points: every frame
    /// starts from its pre-alignment or its warm start).
    pub register: RegisterOptions,
    /// The reference frame's index.
    pub reference: usize,
    /// Where each solve starts.
    pub warm_start: WarmStart,
    /// Only shard `i` of `n`.
    pub shard: Option<(usize, usize)>,
    /// The reference's mask and its name (FIXED's mask of every registration).
    pub mask_fixed: Option<(Mask, PathBuf)>,
    /// The mask of every other frame and its name.
    pub mask_moving: Option<(Mask, PathBuf)>,
    /// Entries the caller adds to every resume key (e.g. how the outputs are resampled).
    pub key_extra: BTreeMap<String, String>,
}

/// The reference asked for: a frame's name, its file name (as `Frame::source` ends) or an
/// index from 0.
pub fn find_reference(frames: &[Frame], given: &str) -> Result<usize, FramesError> {
    let by_name = frames.iter().position(|f| {
        f.name == given || std::path::Path::new(&f.source).file_name().is_some_and(|n| n == given)
    });
    if let Some(i) = by_name {
        return Ok(i);
    }
    match given.parse::<usize>() {
        Ok(i) if i < frames.len() => Ok(i),
        _ => {
            let mut names: Vec<&str> = frames.iter().take(5).map(|f| f.name.as_str()).collect();
            if frames.len() > 5 {
                names.push("...");
            }
            Err(FramesError::NoReference { given: given.to_string(), names: names.join(", ") })
        }
    }
}

/// One frame's result.
#[derive(Clone, Debug)]
pub struct FrameRegistration {
    /// The frame's index.
    pub index: usize,
    /// The frame's name.
    pub frame: String,
    /// The reference frame's name.
    pub reference: String,
    /// `phi_k`: the frame's pixels -> the reference's pixels.
    pub spline: Spline,
    /// The registration's report (`None` for the reference frame itself).
    pub report: Option<RegisterReport>,
    /// The frame the solve started from (`None`: its own pre-alignment).
    pub warm_start: Option<String>,
    /// What the result was computed from.
    pub key: ResumeKey,
}

/// A frame's report file: the registration's report and where the frame stands.
#[derive(Serialize)]
struct FrameReportFile<'a> {
    frame: &'a str,
    reference: &'a str,
    is_reference: bool,
    warm_start: Option<&'a str>,
    /// The reference frame's identity only: certified fold-free, `det J = 1`.
    #[serde(skip_serializing_if = "Option::is_none")]
    fold_free: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    det_j_lower_bound: Option<f64>,
    #[serde(flatten)]
    registration: Option<&'a RegisterReport>,
    resume: &'a BTreeMap<String, String>,
}

impl FrameRegistration {
    /// The frame's report (JSON): `frame`, `reference`, `is_reference`, `warm_start`, the
    /// [`RegisterReport`]'s keys (not for the reference) and `resume` (the key).
    pub fn report_text(&self) -> String {
        let file = FrameReportFile {
            frame: &self.frame,
            reference: &self.reference,
            is_reference: self.report.is_none(),
            warm_start: self.warm_start.as_deref(),
            fold_free: self.report.is_none().then_some(true),
            det_j_lower_bound: self.report.is_none().then_some(1.0),
            registration: self.report.as_ref(),
            resume: &self.key.0,
        };
        serde_json::to_string_pretty(&file).expect("a report serializes")
    }
}

/// The figures of a stored frame report that a summary lists.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StoredFigures {
    /// The metric before registering.
    pub metric_before: Option<f64>,
    /// The metric after.
    pub metric_after: Option<f64>,
    /// Certified fold-free.
    pub fold_free: Option<bool>,
    /// The certified lower bound of `det J`.
    pub det_j_lower_bound: Option<f64>,
}

/// The keys of a stored report that a rerun reads. Not `#[serde(flatten)]`: with
/// serde_json's `arbitrary_precision` (on in this crate) a flattened struct cannot read
/// numbers, and every stored report would look unkeyed.
#[derive(Deserialize)]
struct StoredReportFile {
    resume: Option<BTreeMap<String, String>>,
    metric_before: Option<f64>,
    metric_after: Option<f64>,
    fold_free: Option<bool>,
    det_j_lower_bound: Option<f64>,
}

/// What a [`FrameStore`] holds for a frame.
#[derive(Clone, Debug, Default)]
pub struct StoredFrame {
    /// The stored report's text (`None`: none).
    pub report: Option<String>,
    /// Outputs other than the report that are missing (names, for messages).
    pub missing: Vec<String>,
    /// The stored deformation (a warm start for the frames after it).
    pub spline: Option<Spline>,
}

impl StoredFrame {
    fn parsed(&self) -> Option<(Option<ResumeKey>, StoredFigures)> {
        let text = self.report.as_ref()?;
        match serde_json::from_str::<StoredReportFile>(text) {
            Ok(f) => Some((
                f.resume.map(ResumeKey),
                StoredFigures {
                    metric_before: f.metric_before,
                    metric_after: f.metric_after,
                    fold_free: f.fold_free,
                    det_j_lower_bound: f.det_j_lower_bound,
                },
            )),
            Err(_) => Some((None, StoredFigures::default())),
        }
    }
}

/// Where the results go: the caller's files, a database, memory.
pub trait FrameStore: Sync {
    /// What is stored for frame `index`.
    fn stored(&self, index: usize, frame: &Frame) -> Result<StoredFrame, StoreError>;
    /// Keeps a frame's result.
    fn save(&self, result: &FrameRegistration, frame: &Frame) -> Result<(), StoreError>;
}

/// What happened to a frame.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameAction {
    /// The reference frame: its identity was written, for this reason.
    Reference(Reason),
    /// Registered, for this reason.
    Registered(Reason),
    /// Its stored results are current.
    Skipped,
}

/// One frame of a run.
#[derive(Clone, Debug)]
pub struct FrameOutcome {
    /// The frame's index.
    pub index: usize,
    /// Its name.
    pub frame: String,
    /// What happened.
    pub action: FrameAction,
    /// Where its solve started (registered frames).
    pub warm_start: Option<String>,
    /// The figures: this run's report, or the stored one's.
    pub figures: StoredFigures,
    /// Wall time (ms).
    pub time_ms: f64,
}

/// One line of a run's summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SummaryEntry {
    /// The frame's name.
    pub frame: String,
    /// `reference`, `registered` or `skipped`.
    pub action: &'static str,
    /// Why it ran (`null` when skipped).
    pub reason: Option<String>,
    /// Where its solve started.
    pub warm_start: Option<String>,
    /// Its figures.
    #[serde(flatten)]
    pub figures: StoredFigures,
    /// Wall time (ms).
    pub time_ms: f64,
}

/// A run's summary (`trimorph register --frames ... --report R.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FramesSummary {
    /// The reference frame's name.
    pub reference: String,
    /// The metric.
    pub metric: Metric,
    /// The warm-start rule.
    pub warm_start: String,
    /// Frames in the sequence.
    pub frames: usize,
    /// The frames this run covered, `[lo, hi)`.
    pub range: [usize; 2],
    /// Registered now.
    pub registered: usize,
    /// Skipped (current results stored).
    pub skipped: usize,
    /// Every frame of the range that is not certified fold-free (from this run or stored).
    pub not_fold_free: Vec<String>,
    /// Per frame, in frame order.
    pub entries: Vec<SummaryEntry>,
    /// Wall time (ms).
    pub time_ms: f64,
}

impl FramesSummary {
    /// As pretty JSON.
    pub fn to_text(&self) -> String {
        serde_json::to_string_pretty(self).expect("a summary serializes")
    }
}

/// Why a frame runs, in a registration's words.
pub fn reason_text(r: &Reason) -> String {
    match r {
        Reason::New => "new".into(),
        Reason::Unkeyed => "earlier report has no resume key".into(),
        Reason::Changed(c) => format!("inputs or options changed ({})", c.join(", ")),
        Reason::Missing(m) => format!("output missing ({})", m.join(", ")),
    }
}

/// A sequence to register (module docs).
pub struct RegisterFrames<'a> {
    frames: &'a [Frame],
    opts: FramesOptions,
}

fn fnv_mask(m: &Option<(Mask, PathBuf)>) -> String {
    match m {
        None => "none".into(),
        Some((m, _)) => {
            let bits: Vec<u8> = m.on.iter().map(|&b| b as u8).collect();
            format!("{}x{} {}", m.w, m.h, content_hash(&bits))
        }
    }
}

impl<'a> RegisterFrames<'a> {
    /// Checks the frames (at least two, unique names), the reference, the shard and that the
    /// options carry no landmarks, start or pinned points.
    pub fn new(
        frames: &'a [Frame],
        opts: FramesOptions,
    ) -> Result<RegisterFrames<'a>, FramesError> {
        if frames.len() < 2 {
            return Err(FramesError::Option(format!(
                "a sequence registration needs at least two frames, got {}",
                frames.len()
            )));
        }
        check_names(frames)?;
        if opts.reference >= frames.len() {
            return Err(FramesError::Option(format!(
                "reference frame {} is out of range (0..{})",
                opts.reference,
                frames.len()
            )));
        }
        if let Some((i, n)) = opts.shard {
            if i >= n {
                return Err(SequenceError::Shard { i, n }.into());
            }
        }
        let r = &opts.register;
        if !r.landmarks.is_empty() || r.init.is_some() || !r.pinned.is_empty() || r.hard {
            return Err(FramesError::Option(
                "a sequence registration takes no landmarks, --hard or --init".into(),
            ));
        }
        if let WarmStart::KeyFrames(0) = opts.warm_start {
            return Err(FramesError::Option("--key-every must be at least 1".into()));
        }
        // Sizes and masks before anything runs, so a bad frame late in the sequence is
        // named before any result is written.
        for (k, f) in frames.iter().enumerate() {
            let (w, h) = (f.image.width() as usize, f.image.height() as usize);
            let name = PathBuf::from(&f.source);
            let err = |source| FramesError::Register { frame: f.source.clone(), source };
            if w < 16 || h < 16 {
                return Err(err(RegisterError::TooSmall { image: name, w, h }));
            }
            let mask = if k == opts.reference { &opts.mask_fixed } else { &opts.mask_moving };
            if let Some((m, mp)) = mask {
                if (m.w, m.h) != (w, h) {
                    return Err(err(RegisterError::MaskSize {
                        mask: mp.clone(),
                        image: name,
                        mask_w: m.w,
                        mask_h: m.h,
                        image_w: w,
                        image_h: h,
                    }));
                }
            }
        }
        Ok(RegisterFrames { frames, opts })
    }

    /// The frames this run covers, `lo..hi`.
    pub fn range(&self) -> (usize, usize) {
        match self.opts.shard {
            Some((i, n)) => shard_range(i, n, self.frames.len()),
            None => (0, self.frames.len()),
        }
    }

    /// The order frames `lo..hi` run in: the reference, then outwards on each side.
    pub fn order(&self) -> Vec<usize> {
        let (lo, hi) = self.range();
        let r = self.opts.reference;
        let mut v: Vec<usize> = (lo..hi).filter(|&k| k >= r).collect();
        v.extend((lo..hi).filter(|&k| k < r).rev());
        v
    }

    /// Frame `k`'s resume key (module docs).
    pub fn key(&self, k: usize) -> ResumeKey {
        let f = &self.frames[k];
        let r = &self.frames[self.opts.reference];
        let o = &self.opts.register;
        let mut key = ResumeKey::default();
        key.set("frame", f.name.clone())
            .set("frame_pixels", image_hash(&f.image))
            .set("reference", r.name.clone())
            .set("reference_pixels", image_hash(&r.image))
            .set("mask_fixed", fnv_mask(&self.opts.mask_fixed))
            .set("mask_moving", fnv_mask(&self.opts.mask_moving))
            .set("warm_start", self.opts.warm_start.to_string())
            .set(
                "options",
                format!(
                    "metric {} levels {:?} prealign {:?} spacing {} degree {} bend {} floor {} \
                     iterations {} affine iterations {} samples {} grid bits {}",
                    o.metric.name(),
                    o.levels,
                    o.prealign,
                    o.spacing,
                    o.degree,
                    o.bend,
                    o.floor,
                    o.max_iters,
                    o.affine_iters,
                    o.samples.max_samples,
                    o.grid_bits
                ),
            );
        for (k, v) in &self.opts.key_extra {
            key.set(k, v.clone());
        }
        key
    }

    fn input(&self, k: usize, mask: &Option<(Mask, PathBuf)>) -> Result<Input, FramesError> {
        let f = &self.frames[k];
        let err = |source| FramesError::Register { frame: f.source.clone(), source };
        let image = Channel::from_image(&f.image, std::path::Path::new(&f.source)).map_err(err)?;
        let input = Input { image, name: PathBuf::from(&f.source), mask: mask.clone() };
        input.validate().map_err(err)?;
        Ok(input)
    }

    fn same_size(&self, a: usize, b: usize) -> bool {
        let (fa, fb) = (&self.frames[a].image, &self.frames[b].image);
        (fa.width(), fa.height()) == (fb.width(), fb.height())
    }

    /// Registers the range's frames that are not current in `store`, saving each as it is
    /// done; `progress` hears of every frame.
    pub fn run(
        &self,
        store: &dyn FrameStore,
        progress: &dyn Fn(&FrameOutcome),
    ) -> Result<FramesSummary, FramesError> {
        let start = Instant::now();
        let r = self.opts.reference;
        let reference = self.frames[r].name.clone();
        let mut done: HashMap<usize, Spline> = HashMap::new();
        let mut outcomes = Vec::new();
        // The reference is checked (constant, empty mask) before any frame is written.
        let fixed = self.input(r, &self.opts.mask_fixed)?;
        for k in self.order() {
            let t0 = Instant::now();
            let frame = &self.frames[k];
            let store_err = |source| FramesError::Store { frame: frame.name.clone(), source };
            let key = self.key(k);
            let stored = store.stored(k, frame).map_err(store_err)?;
            let reason = match stored.parsed() {
                None => Reason::New,
                Some((None, _)) => Reason::Unkeyed,
                Some((Some(old), figures)) => {
                    let changed = key.changed(&old);
                    if !changed.is_empty() {
                        Reason::Changed(changed)
                    } else if !stored.missing.is_empty() {
                        Reason::Missing(stored.missing.clone())
                    } else {
                        if let Some(s) = stored.spline {
                            done.insert(k, s);
                        }
                        let o = FrameOutcome {
                            index: k,
                            frame: frame.name.clone(),
                            action: FrameAction::Skipped,
                            warm_start: None,
                            figures,
                            time_ms: t0.elapsed().as_secs_f64() * 1e3,
                        };
                        progress(&o);
                        outcomes.push(o);
                        continue;
                    }
                }
            };
            let (spline, report, warm_start, action) = if k == r {
                let (w, h) = (frame.image.width() as usize, frame.image.height() as usize);
                let mesh = frame_mesh(w, h, self.opts.register.spacing).map_err(|source| {
                    FramesError::Register { frame: frame.source.clone(), source }
                })?;
                let s = Spline::identity(mesh, self.opts.register.degree).map_err(|e| {
                    FramesError::Register { frame: frame.source.clone(), source: e.into() }
                })?;
                (s, None, None, FrameAction::Reference(reason))
            } else {
                let moving = self.input(k, &self.opts.mask_moving)?;
                let mut opts = self.opts.register.clone();
                let mut warm_start = None;
                if let Some(s) = self.opts.warm_start.source(k, r).filter(|&s| self.same_size(s, k))
                {
                    let from = match done.get(&s) {
                        Some(sp) => Some(sp.clone()),
                        None => {
                            store
                                .stored(s, &self.frames[s])
                                .map_err(|source| FramesError::Store {
                                    frame: self.frames[s].name.clone(),
                                    source,
                                })?
                                .spline
                        }
                    };
                    if let Some(sp) = from {
                        opts.init = Some(sp);
                        warm_start = Some(self.frames[s].name.clone());
                    }
                }
                let reg = register(&fixed, &moving, &opts).map_err(|source| {
                    FramesError::Register { frame: frame.source.clone(), source }
                })?;
                (reg.spline, Some(reg.report), warm_start, FrameAction::Registered(reason))
            };
            let result = FrameRegistration {
                index: k,
                frame: frame.name.clone(),
                reference: reference.clone(),
                spline,
                report,
                warm_start,
                key,
            };
            store.save(&result, frame).map_err(store_err)?;
            let figures = match &result.report {
                Some(rep) => StoredFigures {
                    metric_before: Some(rep.metric_before),
                    metric_after: Some(rep.metric_after),
                    fold_free: Some(rep.fold_free),
                    det_j_lower_bound: Some(rep.det_j_lower_bound),
                },
                None => StoredFigures {
                    fold_free: Some(true),
                    det_j_lower_bound: Some(1.0),
                    ..StoredFigures::default()
                },
            };
            let o = FrameOutcome {
                index: k,
                frame: frame.name.clone(),
                action,
                warm_start: result.warm_start.clone(),
                figures,
                time_ms: t0.elapsed().as_secs_f64() * 1e3,
            };
            done.insert(k, result.spline);
            progress(&o);
            outcomes.push(o);
        }
        outcomes.sort_by_key(|o| o.index);
        let (lo, hi) = self.range();
        let entries: Vec<SummaryEntry> = outcomes
            .into_iter()
            .map(|o| {
                let (action, reason) = match o.action {
                    FrameAction::Reference(r) => ("reference", Some(reason_text(&r))),
                    FrameAction::Registered(r) => ("registered", Some(reason_text(&r))),
                    FrameAction::Skipped => ("skipped", None),
                };
                SummaryEntry {
                    frame: o.frame,
                    action,
                    reason,
                    warm_start: o.warm_start,
                    figures: o.figures,
                    time_ms: o.time_ms,
                }
            })
            .collect();
        Ok(FramesSummary {
            reference,
            metric: self.opts.register.metric,
            warm_start: self.opts.warm_start.to_string(),
            frames: self.frames.len(),
            range: [lo, hi],
            registered: entries.iter().filter(|e| e.action != "skipped").count(),
            skipped: entries.iter().filter(|e| e.action == "skipped").count(),
            not_fold_free: entries
                .iter()
                .filter(|e| e.figures.fold_free != Some(true))
                .map(|e| e.frame.clone())
                .collect(),
            entries,
            time_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }
}

#[cfg(test)]
mod tests;
