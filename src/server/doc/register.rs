//! Re-registering a two-image session from its pixels (`POST /api/register`): the moving
//! image (the document's frame) registered to the fixed image again by
//! [`crate::register::register`], starting from the deformation being edited, with every
//! control point pinned in the editor held at its value, and optionally the active landmark
//! pairs in the image term (soft, or exact with `hard`). So a registration can be corrected
//! by hand and registered again without losing the corrections. One undo step takes it back.

use super::{edit_err, Doc};
use crate::register::image::Channel;
use crate::register::{register, Input, RegisterOptions};
use crate::server::answers::Registered;
use crate::server::requests::Register;
use crate::server::ServerError;

impl Doc {
    /// Registers the moving image to the fixed one from the current deformation (module
    /// docs). Refused (422) without both images, with `hard` and no active pair, or when the
    /// registration fails; the document is then unchanged.
    pub fn reregister(&mut self, req: &Register) -> Result<Registered, ServerError> {
        let refuse = |m: String| ServerError::Unprocessable(m);
        let (Some(moving), Some(fixed)) = (self.frame(), self.fixed()) else {
            return Err(refuse(
                "re-registering needs the moving and the fixed image: start the editor with \
                 --moving M --fixed F"
                    .into(),
            ));
        };
        let input = |f: &super::Frame| -> Result<Input, ServerError> {
            let image =
                Channel::from_image(&f.image, &f.path).map_err(|e| refuse(e.to_string()))?;
            Ok(Input { image, name: f.path.clone(), mask: None })
        };
        let (fixed, moving) = (input(fixed)?, input(moving)?);
        let landmarks = if req.pairs { self.active_landmarks() } else { Vec::new() };
        if req.hard && landmarks.is_empty() {
            return Err(refuse("hard needs active landmark pairs (and pairs: true)".into()));
        }
        let defaults = RegisterOptions::default();
        let opts = RegisterOptions {
            metric: req.metric.unwrap_or(defaults.metric),
            max_iters: req.iterations.unwrap_or(defaults.max_iters),
            init: Some(self.spline().clone()),
            pinned: self.pinned.iter().copied().collect(),
            hard: req.hard,
            landmarks,
            ..defaults
        };
        let reg =
            register(&fixed, &moving, &opts).map_err(|e| refuse(format!("registration: {e}")))?;
        let r = &reg.report;
        let answer = Registered {
            metric: r.metric,
            metric_before: r.metric_prealigned,
            metric_after: r.metric_after,
            fold_free: r.fold_free,
            det_j_lower_bound: r.det_j_lower_bound,
            pinned: opts.pinned.len(),
            pairs: opts.landmarks.len(),
            iterations: r.levels.iter().map(|l| l.iterations).sum(),
            time_ms: r.time_ms,
        };
        let cur = self.editor.spline().clone();
        self.editor.replace_spline(reg.spline).map_err(edit_err)?;
        let what = format!("re-register ({})", r.metric.name());
        self.push_undo(cur, what);
        self.before_drag = None;
        self.cert.refresh_all(self.editor.spline());
        Ok(answer)
    }
}
