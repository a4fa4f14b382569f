//! Extra affine constraints on control points, kept exactly by ECLES together with the C1
//! conditions (the thesis's ch. 20 lists "more affine constraints" as future work).
//!
//! * `Pin`: a control point stays where it is (`x = X`, `y = Y`);
//! * `Horizontal` / `Vertical`: points stay on one horizontal (vertical) line, which may
//!   itself move (`y_i - y_0 = 0`, resp. `x_i - x_0 = 0`);
//! * `EqualDisplacement`: two points move by the same vector (`p_a - p_b` stays constant).
//!
//! Line constraints bind one coordinate only, so when extra constraints exist the editor
//! solves x and y as two one-dimensional ECLES systems: `[R_C1; R_extra,x] x = [0; q_x]` and
//! the same for y. A constraint is accepted only if the current control points satisfy it.

use crate::ecles::ConstraintSystem;
use crate::exact::{Int, Rat, SparseIntMatrix};
use num_traits::Zero;
use serde_json::{json, Value};

/// One extra constraint (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Extra {
    /// The point stays at `at`.
    Pin {
        /// Control point.
        point: usize,
        /// Its fixed position.
        at: [Rat; 2],
    },
    /// The points keep equal y.
    Horizontal(Vec<usize>),
    /// The points keep equal x.
    Vertical(Vec<usize>),
    /// `p_a - p_b` stays `delta`.
    EqualDisplacement {
        /// First point.
        a: usize,
        /// Second point.
        b: usize,
        /// The constant difference.
        delta: [Rat; 2],
    },
}

/// Errors creating a constraint.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ExtraError {
    /// An index is out of range.
    #[error("control point {index} does not exist (the spline has {count})")]
    PointIndex {
        /// The index.
        index: usize,
        /// Number of points.
        count: usize,
    },
    /// The constraint does not hold now.
    #[error("{0}")]
    NotSatisfied(String),
    /// Malformed description.
    #[error("{0}")]
    Malformed(String),
}

impl Extra {
    /// Builds a constraint from the current points, checking that it holds.
    pub fn pin(point: usize, points: &[Vec<Rat>]) -> Result<Extra, ExtraError> {
        check(&[point], points.len())?;
        Ok(Extra::Pin { point, at: [points[point][0].clone(), points[point][1].clone()] })
    }

    /// Points on one horizontal (`axis = 1`) or vertical (`axis = 0`) line.
    pub fn line(pts: Vec<usize>, axis: usize, points: &[Vec<Rat>]) -> Result<Extra, ExtraError> {
        check(&pts, points.len())?;
        if pts.len() < 2 {
            return Err(ExtraError::Malformed("a line constraint needs at least 2 points".into()));
        }
        if let Some(&p) = pts.iter().find(|&&p| points[p][axis] != points[pts[0]][axis]) {
            let (what, c) = if axis == 1 { ("horizontal", "y") } else { ("vertical", "x") };
            return Err(ExtraError::NotSatisfied(format!(
                "points {} and {p} are not on one {what} line ({c} = {} and {}); align them with an edit first",
                pts[0], points[pts[0]][axis], points[p][axis]
            )));
        }
        Ok(if axis == 1 { Extra::Horizontal(pts) } else { Extra::Vertical(pts) })
    }

    /// Two points that must move together.
    pub fn equal_displacement(
        a: usize,
        b: usize,
        points: &[Vec<Rat>],
    ) -> Result<Extra, ExtraError> {
        check(&[a, b], points.len())?;
        if a == b {
            return Err(ExtraError::Malformed(
                "equal displacement needs two different points".into(),
            ));
        }
        let delta = [&points[a][0] - &points[b][0], &points[a][1] - &points[b][1]];
        Ok(Extra::EqualDisplacement { a, b, delta })
    }

    /// The control points involved.
    pub fn points(&self) -> Vec<usize> {
        match self {
            Extra::Pin { point, .. } => vec![*point],
            Extra::Horizontal(p) | Extra::Vertical(p) => p.clone(),
            Extra::EqualDisplacement { a, b, .. } => vec![*a, *b],
        }
    }

    /// Rows `(coefficients, constant)` of this constraint for coordinate `axis`.
    fn rows(&self, axis: usize) -> Vec<(Vec<(usize, Int)>, Rat)> {
        let one = || Int::from(1);
        match self {
            Extra::Pin { point, at } => vec![(vec![(*point, one())], at[axis].clone())],
            Extra::Horizontal(p) | Extra::Vertical(p) => {
                let binds = matches!(self, Extra::Horizontal(_)) == (axis == 1);
                if !binds {
                    return Vec::new();
                }
                p[1..]
                    .iter()
                    .map(|&q| (vec![(q, one()), (p[0], Int::from(-1))], Rat::zero()))
                    .collect()
            }
            Extra::EqualDisplacement { a, b, delta } => {
                vec![(vec![(*a, one()), (*b, Int::from(-1))], delta[axis].clone())]
            }
        }
    }

    /// JSON form, as saved in deformation files (`"constraints"`).
    pub(crate) fn to_json(&self) -> Value {
        use crate::exact::rat_to_string as s;
        match self {
            Extra::Pin { point, at } => json!({"pin": point, "at": [s(&at[0]), s(&at[1])]}),
            Extra::Horizontal(p) => json!({"horizontal": p}),
            Extra::Vertical(p) => json!({"vertical": p}),
            Extra::EqualDisplacement { a, b, delta } => {
                json!({"equal_displacement": [a, b], "delta": [s(&delta[0]), s(&delta[1])]})
            }
        }
    }

    /// Reads the JSON form; constants absent from the JSON are taken from `points`. The
    /// constraint must hold for `points`.
    pub(crate) fn from_json(v: &Value, points: &[Vec<Rat>]) -> Result<Extra, ExtraError> {
        let bad = |m: &str| ExtraError::Malformed(format!("constraint {v}: {m}"));
        let idx =
            |x: &Value| x.as_u64().map(|u| u as usize).ok_or_else(|| bad("expected point indices"));
        let list = |x: &Value| -> Result<Vec<usize>, ExtraError> {
            x.as_array()
                .ok_or_else(|| bad("expected an array of point indices"))?
                .iter()
                .map(idx)
                .collect()
        };
        let o = v.as_object().ok_or_else(|| bad("expected an object"))?;
        let e = if let Some(p) = o.get("pin") {
            Extra::pin(idx(p)?, points)?
        } else if let Some(p) = o.get("horizontal") {
            Extra::line(list(p)?, 1, points)?
        } else if let Some(p) = o.get("vertical") {
            Extra::line(list(p)?, 0, points)?
        } else if let Some(p) = o.get("equal_displacement") {
            let l = list(p)?;
            if l.len() != 2 {
                return Err(bad("equal_displacement takes [a, b]"));
            }
            Extra::equal_displacement(l[0], l[1], points)?
        } else {
            return Err(bad("expected one of pin, horizontal, vertical, equal_displacement"));
        };
        // A stored constant must agree with the points.
        let stored = |k: &str| -> Result<Option<[Rat; 2]>, ExtraError> {
            match o.get(k).and_then(Value::as_array) {
                None => Ok(None),
                Some(a) if a.len() == 2 => {
                    let r = |x: &Value| {
                        let t = match x {
                            Value::String(s) => s.clone(),
                            other => other.to_string(),
                        };
                        crate::exact::parse_rat(&t).map_err(|e| bad(&e.to_string()))
                    };
                    Ok(Some([r(&a[0])?, r(&a[1])?]))
                }
                Some(_) => Err(bad("expected [x, y]")),
            }
        };
        match (&e, stored("at")?, stored("delta")?) {
            (Extra::Pin { at, point }, Some(s), _) if &s != at => {
                Err(ExtraError::NotSatisfied(format!(
                    "point {point} is pinned at ({}, {}) but is at ({}, {})",
                    s[0], s[1], at[0], at[1]
                )))
            }
            (Extra::EqualDisplacement { delta, a, b }, _, Some(s)) if &s != delta => {
                Err(ExtraError::NotSatisfied(format!(
                    "points {a} and {b} must differ by ({}, {}), not ({}, {})",
                    s[0], s[1], delta[0], delta[1]
                )))
            }
            _ => Ok(e),
        }
    }
}

fn check(pts: &[usize], count: usize) -> Result<(), ExtraError> {
    match pts.iter().find(|&&p| p >= count) {
        Some(&index) => Err(ExtraError::PointIndex { index, count }),
        None => Ok(()),
    }
}

/// The one-coordinate system `[R_C1; extra rows for axis]` with its right-hand side.
pub fn axis_system(c1: &SparseIntMatrix, extras: &[Extra], axis: usize) -> ConstraintSystem {
    let n = c1.cols();
    let mut rows: Vec<Vec<(usize, Int)>> = (0..c1.rows()).map(|i| c1.row(i).to_vec()).collect();
    let mut q: Vec<Vec<Rat>> = vec![vec![Rat::zero()]; c1.rows()];
    for e in extras {
        for (r, c) in e.rows(axis) {
            rows.push(r);
            q.push(vec![c]);
        }
    }
    let r = SparseIntMatrix::from_rows(n, rows).expect("indices checked");
    ConstraintSystem::with_dim(r, q, 1).expect("sizes match")
}
