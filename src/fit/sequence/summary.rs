//! The JSON summary of a sequence run (the file of `trimorph fit --frames ... --report`):
//! per frame what was done and why, the fit and hold-out errors, drift and tracking losses,
//! then the pooled TRE and the largest drift (see the parent module's docs); and a frame's
//! report as a store keeps it ([`StoredReport`]).

use super::{Action, Anchor, Drift, Errors, Pooled, SequenceSummary};
use serde::Serialize;

/// A frame's report as a [`super::Store`] keeps it: the JSON text of
/// [`super::FrameResult::report_text`]. Resuming reads the resume key and the error statistics
/// back from it; a text that is not a JSON object counts as no report (the frame is fitted
/// as new).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StoredReport(String);

impl StoredReport {
    /// A report from its stored text.
    pub fn new(text: impl Into<String>) -> StoredReport {
        StoredReport(text.into())
    }

    /// The stored text.
    pub fn text(&self) -> &str {
        &self.0
    }

    /// The text's JSON object (`None`: not one).
    pub(super) fn object(&self) -> Option<serde_json::Value> {
        serde_json::from_str::<serde_json::Value>(&self.0).ok().filter(|v| v.is_object())
    }
}

/// The summary file of a sequence run ([`SequenceSummary::report`]; `trimorph fit --frames
/// ... --report`), its keys in the order of the fields below (the order the file has had
/// since it was first written).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SequenceReport {
    /// One entry per frame of the run, in order.
    pub frames: Vec<FrameEntry>,
    /// The run's frames `lo..hi` (a shard of the sequence).
    pub range: [usize; 2],
    /// Frames in the sequence.
    pub total: usize,
    /// The tracking's anchor (`first`, `chain`, `keyframes every N`; `None`: not tracked).
    pub anchor: Option<String>,
    /// TRE over the run's frames, when landmarks were held out.
    pub tre: Option<Pooled>,
    /// The largest drift over the run's frames (tracked sequences).
    pub drift_max: Option<Drift>,
    /// Tracking time (milliseconds; 0 when not tracked).
    pub track_ms: f64,
}

/// A frame's entry in a [`SequenceReport`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameEntry {
    /// The frame's name.
    pub frame: String,
    /// `fitted` or `skipped` (its stored results were current).
    pub action: &'static str,
    /// Why it was fitted (`None`: skipped).
    pub reason: Option<String>,
    /// Residuals of the fitted landmarks.
    pub fit: Option<Errors>,
    /// TRE of the held-out landmarks.
    pub tre: Option<Errors>,
    /// Drift of the tracked targets (tracked sequences).
    pub drift: Option<Drift>,
    /// Tracked points lost going into this frame.
    pub tracking_lost: usize,
}

impl SequenceReport {
    /// The file's text: pretty JSON.
    pub fn to_text(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self)
    }
}

impl SequenceSummary {
    /// The summary file's contents; `anchor` is the tracking's anchor (`None`: not
    /// tracked).
    pub fn report(&self, anchor: Option<Anchor>) -> SequenceReport {
        let frames = self
            .frames
            .iter()
            .map(|f| {
                let (action, reason) = match &f.action {
                    Action::Skipped => ("skipped", None),
                    Action::Fitted(r) => ("fitted", Some(r.to_string())),
                };
                FrameEntry {
                    frame: f.name.clone(),
                    action,
                    reason,
                    fit: f.fit,
                    tre: f.tre,
                    drift: f.drift,
                    tracking_lost: f.lost,
                }
            })
            .collect();
        SequenceReport {
            frames,
            range: [self.range.0, self.range.1],
            total: self.total,
            anchor: anchor.map(|a| a.to_string()),
            tre: self.tre,
            drift_max: self.drift_max,
            track_ms: self.track_ms,
        }
    }
}

impl SequenceSummary {
    /// One line per frame of the run: skipped (done before), or fitted (with the reason
    /// when it is not new) with its fit summary ([`crate::fit::FitReport::summary_line`])
    /// and drift.
    pub fn frame_lines(&self) -> Vec<String> {
        self.frames
            .iter()
            .map(|f| {
                let drift = f
                    .drift
                    .map(|d| format!("; drift {:.3} px ({} points)", d.rms, d.points))
                    .unwrap_or_default();
                match (&f.action, &f.report) {
                    (Action::Skipped, _) => format!("{}: done before, skipped", f.name),
                    (Action::Fitted(super::Reason::New), Some(r)) => {
                        format!("{}: {}{drift}", f.name, r.summary_line())
                    }
                    (Action::Fitted(why), Some(r)) => {
                        format!("{}: {why}; {}{drift}", f.name, r.summary_line())
                    }
                    (Action::Fitted(why), None) => format!("{}: {why}", f.name),
                }
            })
            .collect()
    }

    /// The pooled held-out TRE (`held`: the names held out), when landmarks were held out.
    pub fn tre_line(&self, held: &std::collections::BTreeSet<String>) -> Option<String> {
        self.tre.as_ref().map(|t| {
            format!(
                "held-out TRE over {} frames: rms {:.3} px, max {:.3} px ({} residuals; held out: {})",
                t.frames,
                t.rms,
                t.max,
                t.count,
                held.iter().cloned().collect::<Vec<_>>().join(", ")
            )
        })
    }

    /// The largest drift of a tracked run against the other way of tracking.
    pub fn drift_line(&self, anchor: Option<Anchor>) -> Option<String> {
        let (an, d) = (anchor?, self.drift_max.as_ref()?);
        let vs =
            if an == Anchor::Chain { "tracking from the first frame" } else { "chained tracking" };
        Some(format!(
            "tracking ({an}): largest drift against {vs} {:.3} px RMS, {:.3} px max ({} points)",
            d.rms, d.max, d.points
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::super::{FrameOutcome, Reason};
    use super::*;

    /// The summary file keeps the form it had as a JSON map built key by key (issue 56
    /// typed it): the keys in that order, `null` for what a frame lacks. (The order is
    /// the struct's now, whatever `serde_json`'s map does in a given build.)
    #[test]
    fn the_summary_file_is_written_as_before() {
        let e = |count, rms, max| Some(Errors { count, rms, max });
        let frame = |index: usize, action, fit, tre, drift| FrameOutcome {
            index,
            name: format!("f{index}"),
            action,
            report: None,
            fit,
            tre,
            drift,
            lost: index,
        };
        let drift = Drift { rms: 0.5, max: 1.25, points: 7 };
        let sum = SequenceSummary {
            frames: vec![
                frame(0, Action::Skipped, e(3, 0.25, 0.5), None, None),
                frame(
                    1,
                    Action::Fitted(Reason::New),
                    e(3, 0.125, 0.25),
                    e(1, 2.0, 2.0),
                    Some(drift),
                ),
            ],
            range: (0, 2),
            total: 4,
            track_ms: 12.5,
            tre: Some(Pooled { frames: 1, count: 1, rms: 2.0, max: 2.0 }),
            drift_max: Some(drift),
        };
        let text = sum.report(Some(Anchor::First)).to_text().unwrap();
        let want = r#"{
  "frames": [
    {
      "frame": "f0",
      "action": "skipped",
      "reason": null,
      "fit": {
        "count": 3,
        "rms": 0.25,
        "max": 0.5
      },
      "tre": null,
      "drift": null,
      "tracking_lost": 0
    },
    {
      "frame": "f1",
      "action": "fitted",
      "reason": "new",
      "fit": {
        "count": 3,
        "rms": 0.125,
        "max": 0.25
      },
      "tre": {
        "count": 1,
        "rms": 2.0,
        "max": 2.0
      },
      "drift": {
        "rms": 0.5,
        "max": 1.25,
        "points": 7
      },
      "tracking_lost": 1
    }
  ],
  "range": [
    0,
    2
  ],
  "total": 4,
  "anchor": "first",
  "tre": {
    "frames": 1,
    "count": 1,
    "rms": 2.0,
    "max": 2.0
  },
  "drift_max": {
    "rms": 0.5,
    "max": 1.25,
    "points": 7
  },
  "track_ms": 12.5
}"#;
        assert_eq!(text, want);
        assert_eq!(sum.report(None).anchor, None);
    }
}
