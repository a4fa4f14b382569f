//! Edit scripts: the 2DSD editing operations (thesis ch. 14; see [`crate::edit`]) as typed
//! values, read from JSON, and an interpreter that applies a whole script or nothing.
//!
//! One vocabulary serves `trimorph edit` (a JSON array of operations), the editor server's
//! drag steps (`POST /api/update`, [`Motion`] with `f64` numbers) and library callers
//! (for instance a list of dicts from Python, converted to a [`serde_json::Value`]).
//!
//! # Operations
//!
//! A *move* ([`Op::Move`]) selects points ([`Target`]: `anchors` as point indices or
//! `{"near": [[x, y], ...]}` in the deformed plane, optional `derived`, `neighborhood` (a
//! radius on the control net, default 2, or `"all"`) and `mode` (`xy`, `z0`, `z1`)) and
//! moves them ([`Motion`]):
//!
//! * `{"op": "translate", "by": [dx, dy]}` (`"v"` is accepted for `"by"`);
//! * `{"op": "rotate", "center": [x, y], "angle": radians}`;
//! * `{"op": "scale", "center": [x, y], "factor": f}`.
//!
//! Numbers of scripts are exact: a JSON number is read from its decimal text, and a string
//! may also hold `p/q`. A *constrain* operation ([`Op::Constrain`], [`Constraints`]) adds
//! extra affine constraints ([`crate::edit::extra`]): `pin`, `horizontal`, `vertical`,
//! `equal_displacement`. Unknown keys are ignored.
//!
//! # Errors and transactions
//!
//! [`Script::from_value`] reads every operation before anything runs; its errors name the
//! operation's index and the key ([`ScriptError::Parse`]). [`run_script`] applies the
//! operations in order; if one fails, the editor is put back exactly as it was before the
//! script (spline, constraints and selection), and the error names the operation.

mod de;
#[cfg(test)]
mod tests;

pub use de::Coordinate;

use super::extra::{Extra, ExtraError};
use super::select::Neighborhood;
use super::{exact, EditError, Editor, LastEdit, Mode};
use crate::ecles::EclesError;
use crate::exact::Rat;
use crate::spline::ControlPoint;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// The anchors of a move.
#[derive(Clone, Debug, PartialEq)]
pub enum Anchors {
    /// These control points (point indices in JSON).
    Points(Vec<ControlPoint>),
    /// The control points nearest to these positions in the deformed plane (the current
    /// control points), found when the operation runs; consecutive repeats are dropped.
    Near(Vec<[f64; 2]>),
}

impl Anchors {
    /// The anchors for the editor's current spline.
    pub fn resolve(&self, ed: &Editor) -> Vec<ControlPoint> {
        match self {
            Anchors::Points(p) => p.clone(),
            Anchors::Near(pos) => {
                let mut points = ed.nearest_points(pos);
                points.dedup();
                points
            }
        }
    }
}

/// Which control points a move changes (2DSD.Select, [`Editor::select`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Target {
    /// The anchors.
    #[serde(with = "de::anchors")]
    pub anchors: Anchors,
    /// Points added to the initial derived set (default none).
    #[serde(default, with = "de::derived", skip_serializing_if = "Vec::is_empty")]
    pub derived: Vec<ControlPoint>,
    /// The initial derived set around the anchors (default radius 2).
    #[serde(default = "de::default_hood", with = "de::hood")]
    pub neighborhood: Neighborhood,
    /// Which spline the move edits (default xy).
    #[serde(default, with = "de::mode")]
    pub mode: Mode,
}

/// A translation by `by` (2 values in xy mode, 1 in z modes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "N: Coordinate")]
pub struct Translate<N> {
    /// The translation (`"v"` in the editor server's requests).
    #[serde(alias = "v", with = "de::numbers")]
    pub by: Vec<N>,
}

/// A rotation about `center` by `angle` radians (xy mode).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "N: Coordinate")]
pub struct Rotate<N> {
    /// The centre.
    #[serde(with = "de::point")]
    pub center: [N; 2],
    /// The angle in radians (finite).
    #[serde(with = "de::angle")]
    pub angle: f64,
}

/// A scaling about `center` (2 values in xy mode, 1 in z modes) by `factor` > 0.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "N: Coordinate")]
pub struct Scale<N> {
    /// The centre.
    #[serde(with = "de::numbers")]
    pub center: Vec<N>,
    /// The factor.
    #[serde(with = "de::number")]
    pub factor: N,
}

/// How a move changes the selected points, relative to their positions at selection time.
/// Scripts use exact numbers (`N` = [`Rat`]); the editor server reads `f64` and makes them
/// exact with [`Motion::to_exact`].
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "op", rename_all = "lowercase", bound = "N: Coordinate")]
pub enum Motion<N = Rat> {
    /// `{"op": "translate", "by": [...]}` ([`Editor::translate`]).
    Translate(Translate<N>),
    /// `{"op": "rotate", "center": [x, y], "angle": a}` ([`Editor::rotate`]).
    Rotate(Rotate<N>),
    /// `{"op": "scale", "center": [...], "factor": f}` ([`Editor::scale`]).
    Scale(Scale<N>),
}

/// What is wrong with one field of an operation: its key (empty for the operation as a
/// whole) and the message.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}{message}", if key.is_empty() { String::new() } else { format!("{key}: ") })]
pub struct FieldError {
    /// The key path (`by`, `anchors`; empty: the whole operation).
    pub key: String,
    /// What is wrong.
    pub message: String,
}

impl FieldError {
    fn whole(message: impl Into<String>) -> FieldError {
        FieldError { key: String::new(), message: message.into() }
    }
}

/// Reads `T` from `v`, naming the key of a bad field; `what` names the operation in the
/// message for a missing field (`translate needs "by"`).
fn read<T: DeserializeOwned>(v: &Value, what: &str) -> Result<T, FieldError> {
    serde_path_to_error::deserialize(v).map_err(|e| {
        let message = e.inner().to_string();
        let key =
            if e.path().iter().next().is_none() { String::new() } else { e.path().to_string() };
        match message.strip_prefix("missing field `").and_then(|m| m.strip_suffix('`')) {
            Some(field) if key.is_empty() => FieldError::whole(format!("{what} needs \"{field}\"")),
            _ => FieldError { key, message },
        }
    })
}

/// The `"op"` of an operation object.
fn op_name(v: &Value) -> Option<&str> {
    v.get("op").and_then(Value::as_str)
}

impl<N: Coordinate> Motion<N> {
    /// Reads a motion from a JSON object (`op` and its arguments; other keys are ignored).
    pub(crate) fn from_value(v: &Value) -> Result<Motion<N>, FieldError> {
        match op_name(v) {
            Some("translate") => read(v, "translate").map(Motion::Translate),
            Some("rotate") => read(v, "rotate").map(Motion::Rotate),
            Some("scale") => read(v, "scale").map(Motion::Scale),
            Some(other) => Err(FieldError::whole(format!(
                "unknown op `{other}` (use translate, rotate or scale)"
            ))),
            None => {
                Err(FieldError::whole("missing \"op\" (translate, rotate, scale or constrain)"))
            }
        }
    }

    /// The operation's name (`translate`, `rotate`, `scale`).
    pub fn name(&self) -> &'static str {
        match self {
            Motion::Translate(_) => "translate",
            Motion::Rotate(_) => "rotate",
            Motion::Scale(_) => "scale",
        }
    }
}

impl<'de, N: Coordinate> Deserialize<'de> for Motion<N> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Motion::from_value(&Value::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

impl Motion<f64> {
    /// The same motion with exact values (each `f64` exactly; [`exact`]).
    pub fn to_exact(&self) -> Result<Motion, EditError> {
        let all = |v: &[f64]| v.iter().map(|&x| exact(x)).collect::<Result<Vec<Rat>, _>>();
        Ok(match self {
            Motion::Translate(t) => Motion::Translate(Translate { by: all(&t.by)? }),
            Motion::Rotate(r) => Motion::Rotate(Rotate {
                center: [exact(r.center[0])?, exact(r.center[1])?],
                angle: r.angle,
            }),
            Motion::Scale(s) => {
                Motion::Scale(Scale { center: all(&s.center)?, factor: exact(s.factor)? })
            }
        })
    }
}

impl Motion {
    /// Applies the motion to the editor's current selection ([`Editor::translate`],
    /// [`Editor::rotate`], [`Editor::scale`]); on failure the spline is unchanged.
    pub fn apply(&self, ed: &mut Editor) -> Result<(), EditError> {
        match self {
            Motion::Translate(t) => ed.translate(&t.by),
            Motion::Rotate(r) => ed.rotate(r.center.clone(), r.angle),
            Motion::Scale(s) => ed.scale(&s.center, &s.factor),
        }
    }
}

/// Extra affine constraints to add ([`Extra`]); at least one.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Constraints {
    /// Points that keep their position.
    #[serde(default, with = "de::indices", skip_serializing_if = "Vec::is_empty")]
    pub pin: Vec<usize>,
    /// Lists of points that keep a common y.
    #[serde(default, with = "de::index_lists", skip_serializing_if = "Vec::is_empty")]
    pub horizontal: Vec<Vec<usize>>,
    /// Lists of points that keep a common x.
    #[serde(default, with = "de::index_lists", skip_serializing_if = "Vec::is_empty")]
    pub vertical: Vec<Vec<usize>>,
    /// Pairs of points that move by the same displacement.
    #[serde(default, with = "de::pairs", skip_serializing_if = "Vec::is_empty")]
    pub equal_displacement: Vec<[usize; 2]>,
}

impl Constraints {
    /// Whether no constraint is given.
    pub fn is_empty(&self) -> bool {
        self.pin.is_empty()
            && self.horizontal.is_empty()
            && self.vertical.is_empty()
            && self.equal_displacement.is_empty()
    }

    /// The constraints for the current `points`, in the order pin, horizontal, vertical,
    /// equal displacement (each must hold for the points).
    pub fn build(&self, points: &[Vec<Rat>]) -> Result<Vec<Extra>, ExtraError> {
        let mut out: Vec<Extra> =
            self.pin.iter().map(|&i| Extra::pin(i, points)).collect::<Result<_, _>>()?;
        for (lists, axis) in [(&self.horizontal, 1), (&self.vertical, 0)] {
            for l in lists {
                out.push(Extra::line(l.clone(), axis, points)?);
            }
        }
        for &[a, b] in &self.equal_displacement {
            out.push(Extra::equal_displacement(a, b, points)?);
        }
        Ok(out)
    }
}

/// One operation of an edit script.
#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    /// Select points and move them.
    Move {
        /// The selection.
        target: Target,
        /// The motion.
        motion: Motion,
    },
    /// Add extra constraints (ends the selection).
    Constrain(Constraints),
}

impl Op {
    /// Reads one operation from a JSON object. A constrain operation's errors name the
    /// operation kind ([`ScriptError::Parse`]'s `kind`).
    fn read(v: &Value) -> Result<Op, (Option<&'static str>, FieldError)> {
        if !v.is_object() {
            return Err((None, FieldError::whole("expected an object")));
        }
        if op_name(v) == Some("constrain") {
            let c: Constraints = read(v, "constrain").map_err(|e| (Some("constrain"), e))?;
            if c.is_empty() {
                let m = "no constraint given (pin, horizontal, vertical or equal_displacement)";
                return Err((Some("constrain"), FieldError::whole(m)));
            }
            return Ok(Op::Constrain(c));
        }
        if v.get("anchors").is_none() {
            return Err((
                None,
                FieldError::whole(
                    "missing \"anchors\" (point indices or {\"near\": [[x, y], ...]})",
                ),
            ));
        }
        let target = read(v, "the move").map_err(|e| (None, e))?;
        let motion = Motion::from_value(v).map_err(|e| (None, e))?;
        Ok(Op::Move { target, motion })
    }

    /// Reads one operation from a JSON object.
    pub(crate) fn from_value(v: &Value) -> Result<Op, FieldError> {
        Op::read(v).map_err(|(_, e)| e)
    }

    /// The JSON form (read back by [`Op::from_value`] as the same operation).
    pub(crate) fn to_value(&self) -> Value {
        let (first, second) = match self {
            Op::Move { target, motion } => {
                (serde_json::to_value(target), serde_json::to_value(motion))
            }
            Op::Constrain(c) => {
                (Ok(serde_json::json!({"op": "constrain"})), serde_json::to_value(c))
            }
        };
        let (mut a, b) = (first.expect("plain data"), second.expect("plain data"));
        if let (Some(a), Value::Object(b)) = (a.as_object_mut(), b) {
            a.extend(b);
        }
        a
    }

    /// The operation's name (`translate`, `rotate`, `scale`, `constrain`).
    pub fn name(&self) -> &'static str {
        match self {
            Op::Move { motion, .. } => motion.name(),
            Op::Constrain(_) => "constrain",
        }
    }
}

impl Serialize for Op {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.to_value().serialize(s)
    }
}

impl<'de> Deserialize<'de> for Op {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Op::from_value(&Value::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

/// Why an edit script was refused. After any error the editor is as it was before.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScriptError {
    /// The text is not JSON.
    #[error(
        "line {line}: not valid JSON ({message}); an edit script is a JSON array of operations"
    )]
    Json {
        /// The line of the syntax error.
        line: usize,
        /// The parser's message.
        message: String,
    },
    /// The JSON is not an array.
    #[error("expected a JSON array of operations, e.g. [{{\"op\": \"translate\", ...}}]")]
    NotArray,
    /// An operation is malformed.
    #[error("operation {index}{}: {error}", kind.map(|k| format!(" ({k})")).unwrap_or_default())]
    Parse {
        /// The operation's index in the script.
        index: usize,
        /// The operation kind when the message names it (constrain).
        kind: Option<&'static str>,
        /// The field and what is wrong with it.
        #[source]
        error: FieldError,
    },
    /// The editor refused a move (an unsolvable one carries the failed condition).
    #[error("operation {index} ({kind}): {source}")]
    Edit {
        /// The operation's index.
        index: usize,
        /// The operation's name.
        kind: &'static str,
        /// The editor's error.
        #[source]
        source: EditError,
    },
    /// A constraint of a constrain operation is malformed or does not hold.
    #[error("operation {index} (constrain): {source}")]
    Constraint {
        /// The operation's index.
        index: usize,
        /// What is wrong.
        #[source]
        source: ExtraError,
    },
    /// The editor refused a constraint.
    #[error("operation {index} (constrain): {source}")]
    ConstraintRefused {
        /// The operation's index.
        index: usize,
        /// The editor's error.
        #[source]
        source: EditError,
    },
}

impl ScriptError {
    /// The index of the operation at fault (none for a script that is not an array).
    pub fn index(&self) -> Option<usize> {
        match self {
            ScriptError::Json { .. } | ScriptError::NotArray => None,
            ScriptError::Parse { index, .. }
            | ScriptError::Edit { index, .. }
            | ScriptError::Constraint { index, .. }
            | ScriptError::ConstraintRefused { index, .. } => Some(*index),
        }
    }

    /// Whether a move was refused as not solvable (`trimorph edit` exits with 2 then).
    pub fn is_unsolvable(&self) -> bool {
        matches!(
            self,
            ScriptError::Edit {
                source: EditError::Ecles(
                    EclesError::NotWeaklySolvable { .. } | EclesError::NotStronglySolvable { .. }
                ),
                ..
            }
        )
    }
}

/// What one operation did.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum OpReport {
    /// A move.
    Moved {
        /// Its anchors.
        anchors: Vec<ControlPoint>,
        /// Its derived points (after ExpandDerived).
        derived: Vec<ControlPoint>,
        /// Relevant C1 conditions of the (first) ECLES session.
        relevant: usize,
        /// Their rank.
        rank: usize,
        /// Strongly solvable (otherwise weakly).
        strong: bool,
        /// Solved in the coordinates of the minimal determining set ([`super::Selection::is_global`]:
        /// a large bounded select-all edit) rather than by ECLES sessions.
        determining_set: bool,
        /// Solved on ECLES's modular path ([`super::Selection::is_modular`]: a large exact
        /// selection) rather than by fraction-free sessions.
        modular: bool,
    },
    /// A constrain operation.
    Constrained {
        /// Constraints it added.
        added: usize,
        /// Constraints in force after it.
        in_force: usize,
    },
}

impl OpReport {
    /// The anchors and derived points of a move (saved in deformation files).
    pub fn last_edit(&self) -> Option<LastEdit> {
        match self {
            OpReport::Moved { anchors, derived, .. } => {
                Some(LastEdit { anchors: anchors.clone(), derived: derived.clone() })
            }
            OpReport::Constrained { .. } => None,
        }
    }
}

/// The anchors and derived points of the last move of `reports`.
pub fn last_edit(reports: &[OpReport]) -> Option<LastEdit> {
    reports.iter().rev().find_map(OpReport::last_edit)
}

/// An edit script: operations applied in order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Script {
    /// The operations.
    pub ops: Vec<Op>,
}

impl Script {
    /// Reads a script from a JSON array of operation objects.
    pub(crate) fn from_value(v: &Value) -> Result<Script, ScriptError> {
        let list = v.as_array().ok_or(ScriptError::NotArray)?;
        let ops = list
            .iter()
            .enumerate()
            .map(|(index, op)| {
                Op::read(op).map_err(|(kind, error)| ScriptError::Parse { index, kind, error })
            })
            .collect::<Result<_, _>>()?;
        Ok(Script { ops })
    }

    /// Reads a script from JSON text.
    pub fn from_json_str(text: &str) -> Result<Script, ScriptError> {
        let v: Value = crate::json::parse(text)
            .map_err(|e| ScriptError::Json { line: e.line(), message: e.to_string() })?;
        Script::from_value(&v)
    }

    /// Runs the script on `ed` ([`run_script`] without a progress callback).
    pub fn run(&self, ed: &mut Editor) -> Result<Vec<OpReport>, ScriptError> {
        run_script(ed, &self.ops, &mut |_, _| {})
    }
}

/// Applies one operation (not transactional on its own: [`run_script`] restores the editor).
fn apply_op(ed: &mut Editor, op: &Op, index: usize) -> Result<OpReport, ScriptError> {
    match op {
        Op::Move { target, motion } => {
            let kind = motion.name();
            let wrap = |source| ScriptError::Edit { index, kind, source };
            let anchors = target.anchors.resolve(ed);
            ed.select(&anchors, &target.derived, &target.neighborhood, target.mode)
                .map_err(wrap)?;
            motion.apply(ed).map_err(wrap)?;
            let sel = ed.selection().expect("select succeeded above, so a selection is set");
            Ok(OpReport::Moved {
                anchors: sel.anchors.clone(),
                derived: sel.derived.clone(),
                relevant: sel.relevant(),
                rank: sel.rank(),
                strong: sel.strong,
                determining_set: sel.is_global(),
                modular: sel.is_modular(),
            })
        }
        Op::Constrain(c) => {
            let new = c
                .build(ed.spline().points())
                .map_err(|source| ScriptError::Constraint { index, source })?;
            let added = new.len();
            for e in new {
                ed.add_constraint(e)
                    .map_err(|source| ScriptError::ConstraintRefused { index, source })?;
            }
            Ok(OpReport::Constrained { added, in_force: ed.constraints().len() })
        }
    }
}

/// Applies `ops` to `ed` in order, calling `on_op(index, report)` after each. Returns what
/// each operation did. All or nothing: on an error the editor (spline, constraints,
/// selection) is restored to its state before the first operation.
pub fn run_script(
    ed: &mut Editor,
    ops: &[Op],
    on_op: &mut dyn FnMut(usize, &OpReport),
) -> Result<Vec<OpReport>, ScriptError> {
    let saved = ed.clone();
    let mut done = Vec::with_capacity(ops.len());
    for (k, op) in ops.iter().enumerate() {
        match apply_op(ed, op, k) {
            Ok(r) => {
                on_op(k, &r);
                done.push(r);
            }
            Err(e) => {
                *ed = saved;
                return Err(e);
            }
        }
    }
    Ok(done)
}
