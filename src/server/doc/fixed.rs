//! The fixed image of a two-image session (BigWarp's workflow: `trimorph editor DEF
//! --moving M --fixed F`), and the names of drag steps in the undo history.
//!
//! The deformation maps MOVING pixel coordinates to FIXED pixel coordinates (as `trimorph
//! register` and a fit with `src` in MOVING and `dst` in FIXED do): the document's frame is
//! the moving image, drawn un-warped in the left panel where the pairs' `src` points are
//! clicked; the fixed image is drawn in the right panel with the warped moving image
//! `O(q) = M(phi^-1(q))` over it, where the pairs' `dst` points are clicked. Without a fixed
//! image the page shows one panel, as before.

use super::{Doc, Frame, Op};
use crate::edit::script::{Motion, Translate};
use crate::server::views::WarpNodes;
use crate::server::ServerError;
use image::DynamicImage;
use std::path::PathBuf;
use std::sync::Arc;

impl Doc {
    /// Sets the fixed image (two panels in the page).
    pub fn set_fixed(&mut self, path: PathBuf, image: DynamicImage) -> Result<(), ServerError> {
        self.fixed = Some(Frame::new(path, image)?);
        Ok(())
    }

    /// The fixed image, if any.
    pub fn fixed(&self) -> Option<&Frame> {
        self.fixed.as_ref()
    }

    /// The forward-warp nodes of a `w x h` frame with spacing `step`, located once per
    /// grid ([`WarpNodes`]).
    pub fn forward_nodes(&self, w: u32, h: u32, step: u32) -> Arc<WarpNodes> {
        let mut cell = self.warp_nodes.borrow_mut();
        match &*cell {
            Some(n) if n.key == (w, h, step) => n.clone(),
            _ => {
                let n = Arc::new(WarpNodes::locate(self.spline().mesh(), w, h, step));
                *cell = Some(n.clone());
                n
            }
        }
    }

    /// [`Doc::forward_nodes`] of the frame (`None` without a frame).
    pub fn forward_nodes_of_frame(&self, step: u32) -> Option<Arc<WarpNodes>> {
        let f = self.frame()?;
        let (w, h) = (f.image.width().max(1), f.image.height().max(1));
        Some(self.forward_nodes(w, h, step.clamp(1, 64)))
    }

    /// The live warp's basis for a translation of the current selection (xy mode): phi at
    /// the forward-grid nodes of a `w x h` frame with spacing `step` for the selection-time
    /// positions (`v = 0`) and its change per pixel of `v_x` and of `v_y`, so that
    /// `phi_v(node) = p0 + v_x gx + v_y gy` (the anchors and derived points are affine in
    /// `v`, [`crate::edit::preview`], and phi is linear in them). Found by three exact
    /// updates (`v` = 0, (1, 0), (0, 1)) after which the last drag step is re-applied, so
    /// the spline is left exactly as it was; `None` without an xy selection.
    pub fn translate_basis(&mut self, w: u32, h: u32, step: u32) -> Option<[Vec<[f64; 2]>; 3]> {
        if self.editor.selection().is_none_or(|s| s.mode != crate::edit::Mode::Xy) {
            return None;
        }
        let nodes = self.forward_nodes(w, h, step);
        let mut at = |v: [f64; 2]| -> Option<Vec<[f64; 2]>> {
            self.apply(&Motion::Translate(Translate { by: v.to_vec() })).ok()?;
            let cache = self.spline().eval_cache();
            Some(
                nodes
                    .at
                    .iter()
                    .map(|n| n.map_or([f64::NAN, f64::NAN], |(t, b)| cache.value(t, b)))
                    .collect(),
            )
        };
        let probes = (|| Some([at([0.0, 0.0])?, at([1.0, 0.0])?, at([0.0, 1.0])?]))();
        let back =
            self.last_op.clone().unwrap_or(Motion::Translate(Translate { by: vec![0.0; 2] }));
        if self.apply(&back).is_err() {
            return None;
        }
        let [p0, px, py] = probes?;
        let diff = |a: &[[f64; 2]]| -> Vec<[f64; 2]> {
            a.iter().zip(&p0).map(|(q, o)| [q[0] - o[0], q[1] - o[1]]).collect()
        };
        let (gx, gy) = (diff(&px), diff(&py));
        Some([p0, gx, gy])
    }

    /// The undo history's name of a drag with `op` of the current selection
    /// (`translate of point 12 (xy)`, `rotate of 3 points (xy)`).
    pub(super) fn drag_label(&self, op: &Op) -> String {
        let verb = match op {
            Motion::Translate(_) => "translate",
            Motion::Rotate(_) => "rotate",
            Motion::Scale(_) => "scale",
        };
        match self.editor.selection() {
            Some(sel) => {
                let what = match &sel.anchors[..] {
                    [one] => format!("point {}", one.index()),
                    many => format!("{} points", many.len()),
                };
                format!("{verb} of {what} ({})", sel.mode.name())
            }
            None => verb.to_string(),
        }
    }
}
