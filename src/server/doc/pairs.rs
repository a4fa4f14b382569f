//! Landmark pairs kept in the editor's document (issue 22 point 4: the point pairs of a
//! manual correction pass, PrisMystic, 2017 thesis ch. 17-18, clicked as in Fiji's BigWarp).
//!
//! A pair is a [`Landmark`]: `src` in the reference domain (the frame shown un-warped),
//! `dst` in the target (the current view), both in pixels (x right, y down, pixel centres
//! at integers). Its residual under the current map is
//!
//! `r = |phi(src) - dst|` (pixels; `None` when `src` lies outside the mesh),
//!
//! the distance the deformation misses the target by; the list also gives
//! `rms = sqrt(sum r^2 / n)` and `max = max r` over the pairs with a residual.
//!
//! Pairs are saved in scenes under `"landmarks"` in the JSON landmark format of
//! [`crate::fit::landmarks`] (`{"name", "src", "dst", "weight"}`), imported and exported as
//! the project's landmark CSV or BigWarp CSV with the library's readers and writers, and
//! re-fitted with [`Doc::refit_pairs`] (the corrected control points pinned).
//!
//! Every change of the pairs (add, move, delete, import) is one undo step of the document's
//! history ([`super::history`]), as drags and re-fits are: Ctrl+Z in the page takes back a
//! misplaced pair as it takes back a drag.

use super::{within, Doc, MAX_COORD};
use crate::fit::landmarks::{self, Landmark, LandmarkFormat};
use crate::io::landmarks::{read_landmarks, write_landmarks};
use crate::server::paths::confine;
use crate::server::ServerError;
use serde_json::{json, Value};
use std::path::PathBuf;

/// Most pairs a document holds (a click tool, not a point cloud).
pub const MAX_PAIRS: usize = 10_000;

/// Longest accepted pair name (bytes).
pub const MAX_NAME: usize = 200;

fn refuse(msg: String) -> ServerError {
    ServerError::Unprocessable(msg)
}

/// `p` as a point within [`MAX_COORD`], or a 422 naming `what`.
fn point(what: &str, p: [f64; 2]) -> Result<[f64; 2], ServerError> {
    if p.iter().all(|&x| within(x)) {
        Ok(p)
    } else {
        Err(refuse(format!(
            "{what} {p:?} is not a finite point within {MAX_COORD} pixels: refused"
        )))
    }
}

/// Checks every pair (finite points within [`MAX_COORD`], weight > 0, unique names).
fn check_all(lms: &[Landmark], origin: &str) -> Result<(), ServerError> {
    if lms.len() > MAX_PAIRS {
        return Err(refuse(format!("{origin}: {} pairs, more than {MAX_PAIRS}", lms.len())));
    }
    let mut seen = std::collections::HashMap::new();
    for (i, l) in lms.iter().enumerate() {
        let which =
            format!("{origin}: pair {} ({})", i + 1, l.name.as_deref().unwrap_or("unnamed"));
        point(&format!("{which} src"), l.src)?;
        point(&format!("{which} dst"), l.dst)?;
        if !(l.weight.is_finite() && l.weight > 0.0) {
            return Err(refuse(format!("{which}: weight {} must be finite and > 0", l.weight)));
        }
        if let Some(n) = &l.name {
            if n.len() > MAX_NAME {
                return Err(refuse(format!("{which}: name longer than {MAX_NAME} bytes")));
            }
            if let Some(first) = seen.insert(n.as_str(), i) {
                return Err(refuse(format!(
                    "{origin}: pairs {} and {} are both named `{n}`",
                    first + 1,
                    i + 1
                )));
            }
        }
    }
    Ok(())
}

/// The export format named `f` (`csv` or `bigwarp`; JSON too).
pub fn format_named(f: &str) -> Result<LandmarkFormat, ServerError> {
    f.parse().map_err(|_| {
        ServerError::BadRequest(format!("unknown landmark format `{f}` (csv, bigwarp or json)"))
    })
}

impl Doc {
    /// The landmark pairs.
    pub fn pairs(&self) -> &[Landmark] {
        &self.landmarks
    }

    /// Replaces the pairs (checked as [`Doc::add_pair`] checks one), without an undo step
    /// (the document's starting pairs; the page's changes are undoable).
    pub fn set_pairs(&mut self, lms: Vec<Landmark>) -> Result<(), ServerError> {
        check_all(&lms, "landmarks")?;
        self.landmarks = lms;
        Ok(())
    }

    /// Replaces the pairs with `next` (already checked) as one undo step.
    fn change_pairs(&mut self, next: Vec<Landmark>) {
        let before = std::mem::replace(&mut self.landmarks, next);
        self.push_pairs_undo(before);
    }

    /// Adds a pair (one undo step); an unnamed pair is called `P<k>` with the first free
    /// `k >= 1`.
    /// Refuses (422) points that are not finite or beyond [`MAX_COORD`], and a name in use.
    pub fn add_pair(
        &mut self,
        name: Option<String>,
        src: [f64; 2],
        dst: [f64; 2],
    ) -> Result<usize, ServerError> {
        let name = match name {
            Some(n) => n,
            None => (1..)
                .map(|k| format!("P{k}"))
                .find(|n| !self.landmarks.iter().any(|l| l.name.as_deref() == Some(n)))
                .unwrap_or_default(),
        };
        let mut next = self.landmarks.clone();
        next.push(Landmark { name: Some(name), src, dst, weight: 1.0 });
        check_all(&next, "new pair")?;
        self.change_pairs(next);
        Ok(self.landmarks.len() - 1)
    }

    /// Moves one or both points of pair `index` (0-based); one undo step.
    pub fn move_pair(
        &mut self,
        index: usize,
        src: Option<[f64; 2]>,
        dst: Option<[f64; 2]>,
    ) -> Result<(), ServerError> {
        let n = self.landmarks.len();
        if index >= n {
            return Err(refuse(format!("no pair {index} (there are {n})")));
        }
        let src = src.map(|p| point("src", p)).transpose()?;
        let dst = dst.map(|p| point("dst", p)).transpose()?;
        let mut next = self.landmarks.clone();
        let l = &mut next[index];
        if let Some(p) = src {
            l.src = p;
        }
        if let Some(p) = dst {
            l.dst = p;
        }
        self.change_pairs(next);
        Ok(())
    }

    /// Deletes pair `index` (0-based); the others keep their order and names. One undo
    /// step.
    pub fn delete_pair(&mut self, index: usize) -> Result<(), ServerError> {
        if index >= self.landmarks.len() {
            return Err(refuse(format!("no pair {index} (there are {})", self.landmarks.len())));
        }
        let mut next = self.landmarks.clone();
        next.remove(index);
        self.change_pairs(next);
        Ok(())
    }

    /// The pairs with `phi(src)` and their residual `|phi(src) - dst|` (pixels, `null`
    /// outside the mesh), `rms` and `max` over the pairs with a residual (`null`
    /// without any), and the history's `undo` and `redo` step counts (a pair change is
    /// one step).
    pub fn pairs_json(&self) -> Value {
        let s = self.spline();
        let mut sum = 0.0;
        let mut max: Option<f64> = None;
        let mut n = 0usize;
        let pairs: Vec<Value> = self
            .landmarks
            .iter()
            .map(|l| {
                let m = s.eval(l.src, None);
                let r = m.map(|q| (q[0] - l.dst[0]).hypot(q[1] - l.dst[1]));
                if let Some(r) = r {
                    sum += r * r;
                    n += 1;
                    max = Some(max.map_or(r, |m: f64| m.max(r)));
                }
                json!({"name": l.name, "src": l.src, "dst": l.dst, "weight": l.weight,
                       "mapped": m, "residual": r})
            })
            .collect();
        let rms = (n > 0).then(|| (sum / n as f64).sqrt());
        let (undo, redo) = self.history_len();
        json!({ "pairs": pairs, "rms": rms, "max": max, "undo": undo, "redo": redo })
    }

    /// Replaces the pairs with those of the landmark file `rel` (CSV, BigWarp or JSON,
    /// detected as `trimorph fit` does) inside the root; one undo step.
    pub fn import_pairs(&mut self, rel: &str) -> Result<(), ServerError> {
        let path = confine(&self.root, rel, false)?;
        let lms = read_landmarks(&path).map_err(|e| refuse(format!("{rel}: {e}")))?;
        check_all(&lms, rel)?;
        self.change_pairs(lms);
        Ok(())
    }

    /// Writes the pairs to `rel` inside the root in `format` (atomically).
    pub fn export_pairs(&self, rel: &str, format: LandmarkFormat) -> Result<PathBuf, ServerError> {
        let path = self.output_path(rel)?;
        write_landmarks(&path, &self.landmarks, format)
            .map_err(|e| ServerError::Io(e.to_string()))?;
        Ok(path)
    }

    /// The pairs as a scene's `"landmarks"` value (the JSON landmark format's array).
    pub(super) fn pairs_scene_value(&self) -> Value {
        let text = landmarks::to_json(&self.landmarks).unwrap_or_else(|_| "{}".into());
        serde_json::from_str::<Value>(&text)
            .ok()
            .and_then(|v| v.get("landmarks").cloned())
            .unwrap_or_else(|| json!([]))
    }

    /// Re-fits from the document's pairs (soft, or `hard`: exact), holding every corrected
    /// control point exactly; one undoable step. The answer is [`Doc::refit`]'s with the
    /// pairs' residuals after the fit under `"landmarks"`.
    pub fn refit_pairs(&mut self, hard: bool) -> Result<Value, ServerError> {
        if self.landmarks.is_empty() {
            return Err(refuse("no landmark pairs to fit: place some first".into()));
        }
        let lms = self.landmarks.clone();
        let mut v = self.refit_with(&lms, hard)?;
        v["landmarks"] = self.pairs_json();
        Ok(v)
    }
}

/// The pairs of a scene's `"landmarks"` value (`None`: no such key); `rel` names the
/// file in errors. Refuses (422) pairs [`Doc::set_pairs`] would refuse.
pub fn pairs_from_scene(v: &Value, rel: &str) -> Result<Option<Vec<Landmark>>, ServerError> {
    let Some(l) = v.get("landmarks") else { return Ok(None) };
    let text = json!({ "landmarks": l }).to_string();
    let lms =
        landmarks::parse_json(&text).map_err(|e| refuse(format!("{rel}: \"landmarks\": {e}")))?;
    check_all(&lms, rel)?;
    Ok(Some(lms))
}
