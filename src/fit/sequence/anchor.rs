//! Following the first frame's targets through a sequence: chained or anchored tracking,
//! and the drift between the two (see the parent module for the definitions).

use crate::fit::landmarks::Landmark;
use crate::fit::track::{track_points, TrackError, TrackOptions};
use image::GrayImage;
use serde::Serialize;

/// Which frame a frame's points are tracked from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anchor {
    /// From the previous frame (errors accumulate along the sequence).
    Chain,
    /// From the first frame, starting from the previous frame's positions.
    First,
    /// Every `n`-th frame (`0, n, 2n, ...`) is a key frame tracked from the first frame;
    /// the others are tracked from the key frame before them. Both start from the previous
    /// frame's positions. `n >= 1`; `KeyFrames(1)` is [`Anchor::First`].
    KeyFrames(usize),
}

impl Anchor {
    /// The frame that frame `k >= 1` is tracked from, and whether the previous frame's
    /// positions are the starting guess.
    pub(super) fn reference(self, k: usize) -> (usize, bool) {
        match self {
            Anchor::Chain => (k - 1, false),
            Anchor::First => (0, true),
            Anchor::KeyFrames(n) => {
                let r = k / n.max(1) * n.max(1);
                (if r == k { 0 } else { r }, true)
            }
        }
    }
}

impl std::fmt::Display for Anchor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Anchor::Chain => write!(f, "chain"),
            Anchor::First => write!(f, "first"),
            Anchor::KeyFrames(n) => write!(f, "keyframes every {n}"),
        }
    }
}

/// How far the chained targets of a frame are from the anchored ones.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Drift {
    /// Root mean square distance (pixels).
    pub rms: f64,
    /// Largest distance (pixels).
    pub max: f64,
    /// Number of points tracked by both (the distances are over these).
    pub points: usize,
}

/// The targets of every frame, as tracked.
#[derive(Clone, Debug, PartialEq)]
pub struct Tracking {
    /// Per frame, the points still tracked: `(index in the first frame's list, landmark
    /// with its target in this frame)`.
    pub sets: Vec<Vec<(usize, Landmark)>>,
    /// Per frame, how many points were lost going into it (0 for the first frame).
    pub lost: Vec<usize>,
    /// Per frame, the drift between chained and anchored targets (`None` where no point is
    /// tracked by both).
    pub drift: Vec<Option<Drift>>,
}

/// Every frame's position of every point (`None`: lost), frame by frame.
pub type Positions = Vec<Vec<Option<[f64; 2]>>>;

/// Every frame's position of every point (`None`: lost), tracked with `anchor`. The error
/// names the frame being tracked into.
pub fn follow(
    frames: &[&GrayImage],
    first: &[[f64; 2]],
    anchor: Anchor,
    opts: &TrackOptions,
) -> Result<Positions, (usize, TrackError)> {
    let m = first.len();
    let mut pos: Positions = Vec::with_capacity(frames.len());
    if frames.is_empty() {
        return Ok(pos);
    }
    pos.push(first.iter().map(|p| Some(*p)).collect());
    for k in 1..frames.len() {
        let (r, guess) = anchor.reference(k);
        let alive: Vec<usize> =
            (0..m).filter(|&i| pos[k - 1][i].is_some() && pos[r][i].is_some()).collect();
        let src: Vec<[f64; 2]> = alive.iter().filter_map(|&i| pos[r][i]).collect();
        let init: Vec<[f64; 2]> = alive.iter().filter_map(|&i| pos[k - 1][i]).collect();
        let moved = track_points(frames[r], frames[k], &src, guess.then_some(&init[..]), opts)
            .map_err(|e| (k, e))?;
        let mut next = vec![None; m];
        for (&i, q) in alive.iter().zip(moved) {
            next[i] = q;
        }
        pos.push(next);
    }
    Ok(pos)
}

/// The drift of each frame: RMS and largest distance between `a` and `b` over the points
/// present in both.
pub fn drift(a: &[Vec<Option<[f64; 2]>>], b: &[Vec<Option<[f64; 2]>>]) -> Vec<Option<Drift>> {
    a.iter()
        .zip(b)
        .map(|(pa, pb)| {
            let d: Vec<f64> = pa
                .iter()
                .zip(pb)
                .filter_map(|(p, q)| {
                    let (p, q) = ((*p)?, (*q)?);
                    Some(((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt())
                })
                .collect();
            (!d.is_empty()).then(|| Drift {
                rms: (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt(),
                max: d.iter().copied().fold(0.0, f64::max),
                points: d.len(),
            })
        })
        .collect()
}

/// Tracks the targets of `first` (in frame 0) through `frames` with `anchor`, and measures
/// the drift against the other kind of tracking: against chained tracking when anchored,
/// against tracking from the first frame when chained.
pub fn track_targets(
    frames: &[&GrayImage],
    first: &[Landmark],
    anchor: Anchor,
    opts: &TrackOptions,
) -> Result<Tracking, (usize, TrackError)> {
    let pts: Vec<[f64; 2]> = first.iter().map(|l| l.dst).collect();
    let pos = follow(frames, &pts, anchor, opts)?;
    let other = if anchor == Anchor::Chain { Anchor::First } else { Anchor::Chain };
    let cmp = follow(frames, &pts, other, opts)?;
    let sets: Vec<Vec<(usize, Landmark)>> = pos
        .iter()
        .map(|p| {
            first
                .iter()
                .enumerate()
                .zip(p)
                .filter_map(|((i, l), q)| q.map(|d| (i, Landmark { dst: d, ..l.clone() })))
                .collect()
        })
        .collect();
    let lost = (0..sets.len())
        .map(|k| if k == 0 { 0 } else { sets[k - 1].len() - sets[k].len() })
        .collect();
    Ok(Tracking { sets, lost, drift: drift(&pos, &cmp) })
}

/// Why `track`, `anchor` and `key_every` do not choose a way of tracking (the messages name
/// the command-line options; the Python keywords have the same names).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AnchorChoiceError {
    /// An anchor or a key frame spacing without tracking.
    #[error("--anchor and --key-every choose how --track follows the landmarks; add --track")]
    NoTrack,
    /// Key frames every 0 frames.
    #[error("--key-every must be at least 1")]
    KeyEveryZero,
    /// Key frames without a spacing.
    #[error("--anchor keyframes needs --key-every N (a key frame every N frames)")]
    NoKeyEvery,
    /// A spacing with another anchor.
    #[error("--key-every goes with --anchor keyframes")]
    KeyEveryWithout,
    /// An unknown anchor name (from [`AnchorKind`]'s `from_str`).
    #[error("--anchor: {0}")]
    Unknown(#[from] UnknownAnchor),
}

/// Which frame each frame is tracked from, without the key frame spacing: what `--anchor`
/// and the Python `anchor=` keyword name (`chain`, `first` or `keyframes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AnchorKind {
    /// [`Anchor::Chain`]: the previous frame (the default).
    Chain,
    /// [`Anchor::First`]: the first frame.
    First,
    /// [`Anchor::KeyFrames`]: key frames every `key_every` frames.
    KeyFrames,
}

impl AnchorKind {
    /// The names `from_str` accepts, in the order of the variants.
    pub const NAMES: [&'static str; 3] = ["chain", "first", "keyframes"];
}

impl std::str::FromStr for AnchorKind {
    type Err = UnknownAnchor;
    /// `chain`, `first` or `keyframes`, exactly.
    fn from_str(name: &str) -> Result<AnchorKind, UnknownAnchor> {
        match name {
            "chain" => Ok(AnchorKind::Chain),
            "first" => Ok(AnchorKind::First),
            "keyframes" => Ok(AnchorKind::KeyFrames),
            other => Err(UnknownAnchor(other.to_string())),
        }
    }
}

/// An anchor name that is none of [`AnchorKind::NAMES`] (the text given).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown anchor `{0}` (use chain, first or keyframes)")]
pub struct UnknownAnchor(pub String);

/// How a sequence is tracked: `None` without `track`; with it, `anchor` (`chain`, the default,
/// `first` or `keyframes`, which needs `key_every >= 1`).
pub fn choose_anchor(
    track: bool,
    anchor: Option<AnchorKind>,
    key_every: Option<usize>,
) -> Result<Option<Anchor>, AnchorChoiceError> {
    if !track {
        return if anchor.is_some() || key_every.is_some() {
            Err(AnchorChoiceError::NoTrack)
        } else {
            Ok(None)
        };
    }
    match (anchor.unwrap_or(AnchorKind::Chain), key_every) {
        (AnchorKind::Chain, None) => Ok(Some(Anchor::Chain)),
        (AnchorKind::First, None) => Ok(Some(Anchor::First)),
        (AnchorKind::KeyFrames, Some(n)) if n >= 1 => Ok(Some(Anchor::KeyFrames(n))),
        (AnchorKind::KeyFrames, Some(_)) => Err(AnchorChoiceError::KeyEveryZero),
        (AnchorKind::KeyFrames, None) => Err(AnchorChoiceError::NoKeyEvery),
        (AnchorKind::Chain | AnchorKind::First, Some(_)) => Err(AnchorChoiceError::KeyEveryWithout),
    }
}

#[cfg(test)]
mod choice_tests {
    use super::*;

    #[test]
    fn anchors_are_chosen_as_the_command_line_spells_them() {
        let kind = |name: &str| Some(name.parse::<AnchorKind>().unwrap());
        assert_eq!(choose_anchor(false, None, None), Ok(None));
        assert_eq!(choose_anchor(true, None, None), Ok(Some(Anchor::Chain)));
        assert_eq!(choose_anchor(true, kind("first"), None), Ok(Some(Anchor::First)));
        assert_eq!(choose_anchor(true, kind("keyframes"), Some(3)), Ok(Some(Anchor::KeyFrames(3))));
        assert_eq!(choose_anchor(false, kind("first"), None), Err(AnchorChoiceError::NoTrack));
        assert_eq!(
            choose_anchor(true, kind("keyframes"), Some(0)),
            Err(AnchorChoiceError::KeyEveryZero)
        );
        assert_eq!(
            choose_anchor(true, kind("keyframes"), None),
            Err(AnchorChoiceError::NoKeyEvery)
        );
        assert_eq!(choose_anchor(true, None, Some(2)), Err(AnchorChoiceError::KeyEveryWithout));
        let e = AnchorChoiceError::from("middle".parse::<AnchorKind>().unwrap_err());
        assert_eq!(
            e.to_string(),
            "--anchor: unknown anchor `middle` (use chain, first or keyframes)"
        );
    }
}
