//! The JSON summary of a sequence run (the file of `trimorph fit --frames ... --report`):
//! per frame what was done and why, the fit and hold-out errors, drift and tracking losses,
//! then the pooled TRE and the largest drift (see the parent module's docs).

use super::{Action, Anchor, Errors, SequenceSummary};
use serde_json::{json, Value};

impl SequenceSummary {
    /// The summary as JSON; `anchor` is the tracking's anchor (`None`: not tracked).
    pub fn to_json(&self, anchor: Option<Anchor>) -> Value {
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
