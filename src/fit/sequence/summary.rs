//! The JSON summary of a sequence run (the file of `trimorph fit --frames ... --report`):
//! per frame what was done and why, the fit and hold-out errors, drift and tracking losses,
//! then the pooled TRE and the largest drift (see the parent module's docs).

use super::{Action, Anchor, Errors, SequenceSummary};
use serde_json::{json, Value};

impl SequenceSummary {
    /// The summary as JSON; `anchor` is the tracking's anchor (`None`: not tracked).
    pub(crate) fn to_json(&self, anchor: Option<Anchor>) -> Value {
        let errors =
            |e: Option<Errors>| e.map(|e| json!({"count": e.count, "rms": e.rms, "max": e.max}));
        let frames: Vec<Value> = self
            .frames
            .iter()
            .map(|f| {
                let (action, reason) = match &f.action {
                    Action::Skipped => ("skipped", None),
                    Action::Fitted(r) => ("fitted", Some(r.to_string())),
                };
                json!({
                    "frame": f.name, "action": action, "reason": reason, "fit": errors(f.fit),
                    "tre": errors(f.tre), "drift": f.drift, "tracking_lost": f.lost,
                })
            })
            .collect();
        json!({
            "frames": frames,
            "range": [self.range.0, self.range.1],
            "total": self.total,
            "anchor": anchor.map(|a| a.to_string()),
            "tre": self.tre.map(|t| json!({"frames": t.frames, "count": t.count, "rms": t.rms, "max": t.max})),
            "drift_max": self.drift_max,
            "track_ms": self.track_ms,
        })
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
