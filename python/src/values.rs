//! Values between the library and Python: landmarks from parallel point lists, and a
//! report (any serializable value) as a Python dict.

use crate::errors::value_error;
use pyo3::prelude::*;
use trimorph::fit::landmarks::Landmark;

/// Landmarks from parallel point lists, optional weights and names.
pub fn landmarks_of(
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    weights: Option<Vec<f64>>,
    names: Option<Vec<String>>,
) -> PyResult<Vec<Landmark>> {
    if src.len() != dst.len() {
        return Err(value_error(format!(
            "src has {} points but dst has {}; give one target per source",
            src.len(),
            dst.len()
        )));
    }
    let n = src.len();
    let weights = weights.unwrap_or_else(|| vec![1.0; n]);
    if weights.len() != n {
        return Err(value_error(format!("weights has {} values for {n} landmarks", weights.len())));
    }
    if let Some(names) = &names {
        if names.len() != n {
            return Err(value_error(format!("names has {} values for {n} landmarks", names.len())));
        }
    }
    Ok((0..n)
        .map(|i| Landmark {
            name: names.as_ref().map(|v| v[i].clone()),
            src: src[i],
            dst: dst[i],
            weight: weights[i],
        })
        .collect())
}

/// A Python dict from a serializable value (through `json.loads`, so numbers keep their
/// JSON meaning).
pub fn to_dict(py: Python<'_>, v: &serde_json::Value) -> PyResult<Py<PyAny>> {
    let text = serde_json::to_string(v).map_err(value_error)?;
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}
