//! The editor's undo history: one step per drag, load over the same mesh, re-fit, or
//! landmark-pair edit (add, move, delete, import).
//!
//! A [`Step`] holds the parts of the document a change replaced (the spline, the pairs, or
//! both, as a scene load over the same mesh does); undoing it swaps those parts with the
//! document's current ones and pushes the swapped-out parts on the redo stack, so redo is
//! the same operation in the other direction. The spline is restored exactly (it is an
//! exact rational spline, cloned, never recomputed); pairs are restored as they were, in
//! their order and with their names.
//!
//! Every step is named after the change it takes back (`drag of point 12`, `adding pair
//! P3`, `re-fit to 5 pairs`, ...): the page says what an undo or a redo did, and its
//! buttons say what they would do ([`Doc::history_labels`]).
//!
//! At most [`UNDO_LIMIT`] steps are kept; a new change clears the redo stack.

use super::pairs::Pair;
use super::{edit_err, Doc};
use crate::server::ServerError;
use crate::spline::Spline;

/// Most undo steps kept (older ones are dropped).
pub const UNDO_LIMIT: usize = 200;

/// What one undo (or redo) step restores: the parts of the document the change replaced.
#[derive(Clone, Debug, Default)]
pub struct Step {
    /// The spline before the change (`None`: the change left the spline alone).
    pub spline: Option<Spline>,
    /// The landmark pairs before the change (`None`: the change left the pairs alone).
    pub pairs: Option<Vec<Pair>>,
    /// The change, in words (`drag of point 12`).
    pub what: String,
}

impl Step {
    /// A step restoring the spline `s`, taking back the change `what`.
    pub fn spline(s: Spline, what: String) -> Step {
        Step { spline: Some(s), pairs: None, what }
    }

    /// A step restoring the pairs `p`, taking back the change `what`.
    pub fn pairs(p: Vec<Pair>, what: String) -> Step {
        Step { spline: None, pairs: Some(p), what }
    }
}

impl Doc {
    /// Records a change as one undo step and clears the redo stack.
    pub(super) fn push_step(&mut self, step: Step) {
        self.undo.push(step);
        if self.undo.len() > UNDO_LIMIT {
            self.undo.remove(0);
        }
        self.redo.clear();
    }

    /// Records a change `what` of the spline (from `s`).
    pub(super) fn push_undo(&mut self, s: Spline, what: String) {
        self.push_step(Step::spline(s, what));
    }

    /// Records a change `what` of the pairs (from `p`).
    pub(super) fn push_pairs_undo(&mut self, p: Vec<Pair>, what: String) {
        self.push_step(Step::pairs(p, what));
    }

    /// Undoes the last change (an edit, a load over the same mesh, a re-fit, or a change
    /// of the landmark pairs); returns what it took back.
    pub fn undo(&mut self) -> Result<String, ServerError> {
        self.step_history(true)
    }

    /// Redoes the last undone change; returns what it did again.
    pub fn redo(&mut self) -> Result<String, ServerError> {
        self.step_history(false)
    }

    /// Undo steps and redo steps held.
    pub fn history_len(&self) -> (usize, usize) {
        (self.undo.len(), self.redo.len())
    }

    /// What the next undo and the next redo would take back or do again (`None`: nothing).
    pub fn history_labels(&self) -> (Option<&str>, Option<&str>) {
        (self.undo.last().map(|s| s.what.as_str()), self.redo.last().map(|s| s.what.as_str()))
    }

    /// Moves one step from one history stack into the document, pushing the parts it
    /// replaces on the other stack; on failure both stacks and the document stay as they
    /// were.
    fn step_history(&mut self, undo: bool) -> Result<String, ServerError> {
        let what = if undo { "nothing to undo" } else { "nothing to redo" };
        let from = if undo { &mut self.undo } else { &mut self.redo };
        let target = from.pop().ok_or(ServerError::Unprocessable(what.into()))?;
        let mut back = Step { what: target.what.clone(), ..Step::default() };
        if let Some(s) = &target.spline {
            let cur = self.editor.spline().clone();
            if let Err(e) = self.editor.replace_spline(s.clone()) {
                let from = if undo { &mut self.undo } else { &mut self.redo };
                from.push(target);
                return Err(edit_err(e));
            }
            back.spline = Some(cur);
            self.cert.refresh_all(self.editor.spline());
        }
        if let Some(p) = target.pairs {
            back.pairs = Some(std::mem::replace(&mut self.landmarks, p));
        }
        let to = if undo { &mut self.redo } else { &mut self.undo };
        let what = back.what.clone();
        to.push(back);
        self.before_drag = None;
        Ok(what)
    }
}
