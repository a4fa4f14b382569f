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
//! Each pair has an active flag (BigWarp's): only active pairs are fitted and counted in
//! `rms` and `max`; an inactive pair stays in the table, drawn dimmed, until it is switched
//! on again or deleted.
//!
//! Pairs are saved in scenes under `"landmarks"` in the JSON landmark format of
//! [`crate::fit::landmarks`] (`{"name", "src", "dst", "weight"}`, and `"active": false` on
//! an inactive pair), imported and exported as the project's landmark CSV or BigWarp CSV
//! with the library's readers and writers (BigWarp keeps the flags; CSV and JSON, which
//! have none, get the active pairs only), and re-fitted with [`Doc::refit_pairs`] (the
//! corrected control points pinned).
//!
//! A deformation written by `trimorph fit` or `trimorph register` carries the landmarks it
//! was fitted to under the same key ([`crate::io::deformation::LANDMARKS_KEY`]): opening it
//! gives those pairs, so a re-fit keeps them and adds the corrections placed in the page.
//!
//! Every change of the pairs (add, move, delete, import) is one undo step of the document's
//! history ([`super::history`]), as drags and re-fits are: Ctrl+Z in the page takes back a
//! misplaced pair as it takes back a drag.

use super::{within, Doc, MAX_COORD};
use crate::fit::landmarks::{self, Landmark, LandmarkFormat};
use crate::io::landmarks::{read_landmarks_flagged, write_landmarks_flagged};
use crate::server::answers::{PairRow, Pairs, Refitted};
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

/// One landmark pair of the document and its active flag.
#[derive(Clone, Debug, PartialEq)]
pub struct Pair {
    /// The landmark: `src` in the moving image (the reference), `dst` in the fixed image.
    pub landmark: Landmark,
    /// Whether the pair is fitted (BigWarp's active flag).
    pub active: bool,
}

impl Pair {
    /// An active pair.
    pub fn active(landmark: Landmark) -> Pair {
        Pair { landmark, active: true }
    }

    /// The pair's name, or `pair K` (1-based) for an unnamed one.
    fn label(&self, index: usize) -> String {
        match &self.landmark.name {
            Some(n) => format!("pair {n}"),
            None => format!("pair {}", index + 1),
        }
    }
}

/// Checks every pair (finite points within [`MAX_COORD`], weight > 0, unique names).
fn check_all(pairs: &[Pair], origin: &str) -> Result<(), ServerError> {
    if pairs.len() > MAX_PAIRS {
        return Err(refuse(format!("{origin}: {} pairs, more than {MAX_PAIRS}", pairs.len())));
    }
    let mut seen = std::collections::HashMap::new();
    for (i, l) in pairs.iter().map(|p| &p.landmark).enumerate() {
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
    pub fn pairs(&self) -> &[Pair] {
        &self.landmarks
    }

    /// The active pairs' landmarks (what a re-fit uses).
    pub fn active_landmarks(&self) -> Vec<Landmark> {
        self.landmarks.iter().filter(|p| p.active).map(|p| p.landmark.clone()).collect()
    }

    /// Replaces the pairs (checked as [`Doc::add_pair`] checks one), without an undo step
    /// (the document's starting pairs; the page's changes are undoable).
    pub fn set_pairs(&mut self, pairs: Vec<Pair>) -> Result<(), ServerError> {
        check_all(&pairs, "landmarks")?;
        self.landmarks = pairs;
        Ok(())
    }

    /// Replaces the pairs with `next` (already checked) as one undo step called `what`.
    fn change_pairs(&mut self, next: Vec<Pair>, what: String) {
        let before = std::mem::replace(&mut self.landmarks, next);
        self.push_pairs_undo(before, what);
    }

    /// Pair `index`, or a 422 naming how many there are.
    fn pair_at(&self, index: usize) -> Result<&Pair, ServerError> {
        self.landmarks
            .get(index)
            .ok_or_else(|| refuse(format!("no pair {index} (there are {})", self.landmarks.len())))
    }

    /// Adds an active pair (one undo step); an unnamed pair is called `P<k>` with the first
    /// free `k >= 1`.
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
                .find(|n| !self.landmarks.iter().any(|p| p.landmark.name.as_deref() == Some(n)))
                .unwrap_or_default(),
        };
        let mut next = self.landmarks.clone();
        next.push(Pair::active(Landmark { name: Some(name), src, dst, weight: 1.0 }));
        check_all(&next, "new pair")?;
        let what = format!("adding {}", next[next.len() - 1].label(next.len() - 1));
        self.change_pairs(next, what);
        Ok(self.landmarks.len() - 1)
    }

    /// Moves one or both points of pair `index` (0-based); one undo step.
    pub fn move_pair(
        &mut self,
        index: usize,
        src: Option<[f64; 2]>,
        dst: Option<[f64; 2]>,
    ) -> Result<(), ServerError> {
        self.pair_at(index)?;
        let src = src.map(|p| point("src", p)).transpose()?;
        let dst = dst.map(|p| point("dst", p)).transpose()?;
        let mut next = self.landmarks.clone();
        let l = &mut next[index].landmark;
        if let Some(p) = src {
            l.src = p;
        }
        if let Some(p) = dst {
            l.dst = p;
        }
        let what = format!("moving {}", next[index].label(index));
        self.change_pairs(next, what);
        Ok(())
    }

    /// Switches pair `index` on (fitted) or off; one undo step (none when it already is).
    pub fn set_active(&mut self, index: usize, active: bool) -> Result<(), ServerError> {
        if self.pair_at(index)?.active == active {
            return Ok(());
        }
        let mut next = self.landmarks.clone();
        next[index].active = active;
        let what =
            format!("switching {} {}", next[index].label(index), if active { "on" } else { "off" });
        self.change_pairs(next, what);
        Ok(())
    }

    /// Deletes pair `index` (0-based); the others keep their order and names. One undo
    /// step.
    pub fn delete_pair(&mut self, index: usize) -> Result<(), ServerError> {
        let what = format!("deleting {}", self.pair_at(index)?.label(index));
        let mut next = self.landmarks.clone();
        next.remove(index);
        self.change_pairs(next, what);
        Ok(())
    }

    /// The pairs with `phi(src)`, their residual `|phi(src) - dst|` (pixels, `null`
    /// outside the mesh) and `active` flag, `rms` and `max` over the active pairs with a
    /// residual (`null` without any), and the history's `undo` and `redo` step counts (a
    /// pair change is one step).
    pub fn pairs_json(&self) -> Pairs {
        let s = self.spline();
        let mut sum = 0.0;
        let mut max: Option<f64> = None;
        let mut n = 0usize;
        let pairs: Vec<PairRow> = self
            .landmarks
            .iter()
            .map(|p| {
                let l = &p.landmark;
                let m = s.eval(l.src, None);
                let r = m.map(|q| (q[0] - l.dst[0]).hypot(q[1] - l.dst[1]));
                if let Some(r) = r.filter(|_| p.active) {
                    sum += r * r;
                    n += 1;
                    max = Some(max.map_or(r, |m: f64| m.max(r)));
                }
                PairRow {
                    name: l.name.clone(),
                    src: l.src,
                    dst: l.dst,
                    weight: l.weight,
                    active: p.active,
                    mapped: m,
                    residual: r,
                }
            })
            .collect();
        let rms = (n > 0).then(|| (sum / n as f64).sqrt());
        let (undo, redo) = self.history_len();
        Pairs { pairs, rms, max, undo, redo, index: None }
    }

    /// Replaces the pairs with those of the landmark file `rel` (CSV, BigWarp or JSON,
    /// detected as `trimorph fit` does; a BigWarp table's inactive rows come in switched
    /// off) inside the root; one undo step.
    pub fn import_pairs(&mut self, rel: &str) -> Result<(), ServerError> {
        let path = confine(&self.root, rel, false)?;
        let rows = read_landmarks_flagged(&path).map_err(|e| refuse(format!("{rel}: {e}")))?;
        let pairs: Vec<Pair> =
            rows.into_iter().map(|(landmark, active)| Pair { landmark, active }).collect();
        check_all(&pairs, rel)?;
        self.change_pairs(pairs, format!("importing {rel}"));
        Ok(())
    }

    /// Writes the pairs to `rel` inside the root in `format` (atomically): BigWarp with
    /// every pair and its flag, CSV and JSON with the active pairs.
    pub fn export_pairs(&self, rel: &str, format: LandmarkFormat) -> Result<PathBuf, ServerError> {
        let path = self.output_path(rel)?;
        let (lms, active): (Vec<Landmark>, Vec<bool>) =
            self.landmarks.iter().map(|p| (p.landmark.clone(), p.active)).unzip();
        write_landmarks_flagged(&path, &lms, &active, format)
            .map_err(|e| ServerError::Io(e.to_string()))?;
        Ok(path)
    }

    /// The pairs as a scene's `"landmarks"` value (the JSON landmark format's array, with
    /// `"active": false` on inactive pairs): part of the deformation file `io` writes from
    /// a `Value`.
    pub(super) fn pairs_scene_value(&self) -> Value {
        let lms: Vec<Landmark> = self.landmarks.iter().map(|p| p.landmark.clone()).collect();
        let mut list = crate::io::deformation::landmarks_value(&lms);
        if let Some(a) = list.as_array_mut() {
            for (v, p) in a.iter_mut().zip(&self.landmarks) {
                if !p.active {
                    v["active"] = json!(false);
                }
            }
        }
        list
    }

    /// Re-fits from the document's active pairs (soft, or `hard`: exact), holding every
    /// corrected control point exactly; one undoable step. The answer is [`Doc::refit`]'s
    /// with the pairs' residuals after the fit under `"landmarks"`.
    pub fn refit_pairs(&mut self, hard: bool) -> Result<Refitted, ServerError> {
        let lms = self.active_landmarks();
        if lms.is_empty() {
            return Err(refuse(if self.landmarks.is_empty() {
                "no landmark pairs to fit: place some first".into()
            } else {
                "every landmark pair is switched off: switch some on to fit".into()
            }));
        }
        let what = format!("re-fit to {} pairs", lms.len());
        let r = self.refit_with(&lms, hard, what)?;
        Ok(Refitted { landmarks: Some(self.pairs_json()), ..r })
    }
}

/// The pairs of a scene's (or a fit's deformation's) `"landmarks"` value (`None`: no such
/// key), each active unless it has `"active": false`; `rel` names the file in errors.
/// Refuses (422) pairs [`Doc::set_pairs`] would refuse, and an `active` that is not a
/// boolean. A scene is `io::deformation`'s file, read as an untyped value (its other keys
/// are any deformation's), hence the `Value`.
pub(crate) fn pairs_from_scene(v: &Value, rel: &str) -> Result<Option<Vec<Pair>>, ServerError> {
    let Some(l) = v.get("landmarks") else { return Ok(None) };
    let text = json!({ "landmarks": l }).to_string();
    let lms =
        landmarks::parse_json(&text).map_err(|e| refuse(format!("{rel}: \"landmarks\": {e}")))?;
    let mut pairs = Vec::with_capacity(lms.len());
    for (i, landmark) in lms.into_iter().enumerate() {
        let active = match l.get(i).and_then(|x| x.get("active")) {
            None => true,
            Some(Value::Bool(b)) => *b,
            Some(other) => {
                return Err(refuse(format!(
                    "{rel}: \"landmarks\"[{i}].active is {other}, not true or false"
                )))
            }
        };
        pairs.push(Pair { landmark, active });
    }
    check_all(&pairs, rel)?;
    Ok(Some(pairs))
}
