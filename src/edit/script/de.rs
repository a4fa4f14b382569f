//! The JSON forms of the edit-script fields: each field is read through a
//! [`serde_json::Value`] so that every accepted spelling of today's files keeps working (a
//! number or an exact string for coordinates, `null` for "the default") and every message
//! says what was expected. The field's key is added by the caller from the
//! `serde_path_to_error` path.

use super::Anchors;
use crate::edit::select::Neighborhood;
use crate::edit::Mode;
use crate::exact::{parse_rat, rat_to_string, Rat};
use crate::spline::ControlPoint;
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::{json, Value};

/// A number type of the operations: exact rationals ([`Rat`]) in edit scripts, finite `f64`
/// in the editor server's drag steps (which the server turns into exact values itself).
pub trait Coordinate: Clone + Sized {
    /// Reads one number from JSON (the message says what is wrong otherwise).
    fn from_json(v: &Value) -> Result<Self, String>;
    /// The JSON form (read back exactly by [`Coordinate::from_json`]).
    fn to_json(&self) -> Value;
}

impl Coordinate for Rat {
    /// A JSON number (its decimal text, read exactly) or a string: an integer, a decimal
    /// like `1.25e-3` or `p/q`.
    fn from_json(v: &Value) -> Result<Rat, String> {
        let text = match v {
            Value::Number(n) => n.to_string(),
            Value::String(s) => s.clone(),
            _ => return Err(format!("`{v}` is not a number")),
        };
        parse_rat(&text).map_err(|e| e.to_string())
    }
    /// The exact value as a string (`"-7/2"`, `"12"`).
    fn to_json(&self) -> Value {
        Value::String(rat_to_string(self))
    }
}

impl Coordinate for f64 {
    /// A JSON number with a finite `f64` value.
    fn from_json(v: &Value) -> Result<f64, String> {
        v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| format!("`{v}` is not a finite number"))
    }
    fn to_json(&self) -> Value {
        json!(self)
    }
}

fn value<'de, D: Deserializer<'de>>(d: D) -> Result<Value, D::Error> {
    Value::deserialize(d)
}

/// `v` as a point index.
fn index(v: &Value) -> Result<usize, String> {
    v.as_u64().map(|u| u as usize).ok_or_else(|| format!("`{v}` is not a point index"))
}

/// `v` as a control point (its index).
fn point(v: &Value) -> Result<ControlPoint, String> {
    index(v).map(ControlPoint)
}

/// `v` as an array of point indices.
fn index_list(v: &Value) -> Result<Vec<usize>, String> {
    v.as_array()
        .ok_or_else(|| "expected an array of point indices".to_string())?
        .iter()
        .map(index)
        .collect()
}

/// `v` as an array of arrays of point indices.
fn index_list_list(v: &Value) -> Result<Vec<Vec<usize>>, String> {
    match v {
        Value::Array(a) => a.iter().map(index_list).collect(),
        x => Err(format!("expected an array of index lists, found {x}")),
    }
}

/// `v` as an array of numbers.
fn number_list<N: Coordinate>(v: &Value) -> Result<Vec<N>, String> {
    v.as_array()
        .ok_or_else(|| "expected an array of numbers".to_string())?
        .iter()
        .map(N::from_json)
        .collect()
}

fn numbers_json<N: Coordinate>(v: &[N]) -> Value {
    Value::Array(v.iter().map(N::to_json).collect())
}

/// An array of numbers.
pub mod numbers {
    use super::*;
    /// Reads the array.
    pub fn deserialize<'de, D: Deserializer<'de>, N: Coordinate>(d: D) -> Result<Vec<N>, D::Error> {
        number_list(&value(d)?).map_err(D::Error::custom)
    }
    /// Writes the array.
    pub fn serialize<S: Serializer, N: Coordinate>(v: &[N], s: S) -> Result<S::Ok, S::Error> {
        numbers_json(v).serialize(s)
    }
}

/// One number.
pub mod number {
    use super::*;
    /// Reads the number.
    pub fn deserialize<'de, D: Deserializer<'de>, N: Coordinate>(d: D) -> Result<N, D::Error> {
        N::from_json(&value(d)?).map_err(D::Error::custom)
    }
    /// Writes the number.
    pub fn serialize<S: Serializer, N: Coordinate>(v: &N, s: S) -> Result<S::Ok, S::Error> {
        v.to_json().serialize(s)
    }
}

/// A point `[x, y]`.
pub mod point {
    use super::*;
    /// Reads the point.
    pub fn deserialize<'de, D: Deserializer<'de>, N: Coordinate>(d: D) -> Result<[N; 2], D::Error> {
        let v: Vec<N> = number_list(&value(d)?).map_err(D::Error::custom)?;
        <[N; 2]>::try_from(v).map_err(|_| D::Error::custom("expected [x, y]"))
    }
    /// Writes the point.
    pub fn serialize<S: Serializer, N: Coordinate>(v: &[N; 2], s: S) -> Result<S::Ok, S::Error> {
        numbers_json(v).serialize(s)
    }
}

/// A finite angle in radians.
pub mod angle {
    use super::*;
    /// Reads the angle.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        value(d)?
            .as_f64()
            .filter(|a| a.is_finite())
            .ok_or_else(|| D::Error::custom("expected a number (radians)"))
    }
    /// Writes the angle.
    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(*v)
    }
}

/// Anchors: point indices, or `{"near": [[x, y], ...]}`.
pub mod anchors {
    use super::*;
    /// Reads the anchors.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Anchors, D::Error> {
        let near_form = "expected {\"near\": [[x, y], ...]}";
        match value(d)? {
            Value::Array(a) => a.iter().map(point).collect::<Result<_, _>>().map(Anchors::Points),
            Value::Object(o) => {
                let list = o.get("near").and_then(Value::as_array).ok_or_else(|| near_form.into());
                list.and_then(|l| {
                    l.iter()
                        .map(|p| {
                            let v = p
                                .as_array()
                                .filter(|a| a.len() == 2)
                                .and_then(|a| Some([a[0].as_f64()?, a[1].as_f64()?]));
                            v.ok_or_else(|| format!("near: `{p}` is not [x, y]"))
                        })
                        .collect::<Result<_, _>>()
                        .map(Anchors::Near)
                })
            }
            x => Err(format!("expected point indices or {{\"near\": [[x, y], ...]}}, found {x}")),
        }
        .map_err(D::Error::custom)
    }
    /// Writes the anchors.
    pub fn serialize<S: Serializer>(v: &Anchors, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Anchors::Points(p) => p.serialize(s),
            Anchors::Near(p) => json!({ "near": p }).serialize(s),
        }
    }
}

/// Derived points: indices (`null`: none).
pub mod derived {
    use super::*;
    /// Reads the points.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<ControlPoint>, D::Error> {
        match value(d)? {
            Value::Null => Ok(Vec::new()),
            Value::Array(a) => a.iter().map(point).collect(),
            x => Err(format!("expected an array, found {x}")),
        }
        .map_err(D::Error::custom)
    }
    /// Writes the points (as indices).
    pub fn serialize<S: Serializer>(v: &[ControlPoint], s: S) -> Result<S::Ok, S::Error> {
        v.serialize(s)
    }
}

/// The neighbourhood of a move when the field is missing or `null`.
pub fn default_hood() -> Neighborhood {
    Neighborhood::Radius(2)
}

/// The initial derived set: a radius on the control net, or `"all"` (`null`: radius 2).
pub mod hood {
    use super::*;
    /// Reads the neighbourhood.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Neighborhood, D::Error> {
        match value(d)? {
            Value::Null => Ok(default_hood()),
            Value::String(s) if s == "all" => Ok(Neighborhood::All),
            Value::Number(n) if n.as_u64().is_some() => Ok(Neighborhood::Radius(
                n.as_u64().expect("the match guard checked as_u64") as usize,
            )),
            x => Err(format!("expected a whole number or \"all\", found {x}")),
        }
        .map_err(D::Error::custom)
    }
    /// Writes the neighbourhood.
    pub fn serialize<S: Serializer>(v: &Neighborhood, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Neighborhood::All => s.serialize_str("all"),
            Neighborhood::Radius(r) => s.serialize_u64(*r as u64),
        }
    }
}

/// The mode: `"xy"`, `"z0"` or `"z1"` (`null`: xy).
pub mod mode {
    use super::*;
    /// Reads the mode.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Mode, D::Error> {
        match value(d)? {
            Value::Null => Ok(Mode::Xy),
            Value::String(s) => s.parse(),
            x => Err(format!("expected \"xy\", \"z0\" or \"z1\", found {x}")),
        }
        .map_err(D::Error::custom)
    }
    /// Writes the mode.
    pub fn serialize<S: Serializer>(v: &Mode, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(v.name())
    }
}

/// An array of point indices.
pub mod indices {
    use super::*;
    /// Reads the indices.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<usize>, D::Error> {
        index_list(&value(d)?).map_err(D::Error::custom)
    }
    /// Writes the indices.
    pub fn serialize<S: Serializer>(v: &[usize], s: S) -> Result<S::Ok, S::Error> {
        v.serialize(s)
    }
}

/// An array of index lists.
pub mod index_lists {
    use super::*;
    /// Reads the lists.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Vec<usize>>, D::Error> {
        index_list_list(&value(d)?).map_err(D::Error::custom)
    }
    /// Writes the lists.
    pub fn serialize<S: Serializer>(v: &[Vec<usize>], s: S) -> Result<S::Ok, S::Error> {
        v.serialize(s)
    }
}

/// An array of index pairs `[a, b]`.
pub mod pairs {
    use super::*;
    /// Reads the pairs.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<[usize; 2]>, D::Error> {
        index_list_list(&value(d)?)
            .and_then(|l| {
                l.into_iter()
                    .map(|p| <[usize; 2]>::try_from(p).map_err(|_| "each entry is [a, b]".into()))
                    .collect()
            })
            .map_err(D::Error::custom)
    }
    /// Writes the pairs.
    pub fn serialize<S: Serializer>(v: &[[usize; 2]], s: S) -> Result<S::Ok, S::Error> {
        v.serialize(s)
    }
}
