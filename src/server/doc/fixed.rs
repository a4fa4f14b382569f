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
use crate::edit::script::Motion;
use crate::server::ServerError;
use image::DynamicImage;
use crate::server::views::WarpNodes;
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
