//! Which axes of an image array are y, x, channels and stacked planes (`channel_axis`,
//! `stack_axis` of `Deformation.warp` and `trimorph.dask.warp`, as in scikit-image).
//!
//! The rule (the package docstring states it for users):
//!
//! * `channel_axis` names the axis of channels, `stack_axis` the axis (or a tuple of axes)
//!   of planes warped one by one; the two axes left are y then x, in order;
//! * without keywords, a 2-D array is `(Y, X)`, and a 3-D array is `(Y, X, C)` only when
//!   that cannot be misread: its last axis has 1 to 4 channels and its first axis more than
//!   4 pixels (an RGB photo, napari's `(Y, X, 3)`). Any other 3-D array, e.g. a time-lapse
//!   `(20, 511, 511)` or a channels-first `(3, 511, 511)`, is refused with a message naming
//!   the readings and the keyword of each (it was read as `(Y, X, C)` before: 511
//!   channels);
//! * with `stack_axis` only, the planes (the axes left) follow the rule above, so
//!   `(T, Y, X, C)` needs only `stack_axis=0`; with `channel_axis` only, the rest must be
//!   `(Y, X)`: a stack always names its axes.
//!
//! Axes may be negative (counted from the end); the result is normalised (non-negative).

use crate::errors::value_error;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

/// The resolved layout of an image array: which axes hold stacked planes and which
/// channels; the other two are y and x, in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImageAxes {
    /// The axes of planes warped one by one (a time-lapse's t, a z-stack's z, an OME-Zarr
    /// image's t and c), in the array's order.
    pub stacks: Vec<usize>,
    /// The axis of channels (1 to 4: gray, gray + alpha, RGB, RGBA; more: warped alike).
    pub channel: Option<usize>,
}

/// A shape as Python prints it: `(5, 511, 511)`, `(7,)`.
fn py_shape(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", ")),
    }
}

/// Stack axes as the keyword is written: `0`, or `(0, 1)`.
fn py_axes(axes: &[usize]) -> String {
    match axes {
        [k] => k.to_string(),
        _ => py_shape(axes),
    }
}

/// `axis` (may be negative) as an index into `shape`'s axes.
fn normalise(axis: isize, shape: &[usize], what: &str) -> Result<usize, String> {
    let n = shape.len() as isize;
    if (-n..n).contains(&axis) {
        Ok(axis.rem_euclid(n) as usize)
    } else {
        Err(format!(
            "{what}={axis} is out of range for an array of shape {} ({n} axes)",
            py_shape(shape)
        ))
    }
}

/// The message refusing `shape` whose three axes `rest` hold one non-spatial axis that no
/// keyword names: each reading and its keyword.
fn ambiguous(shape: &[usize], rest: [usize; 3], stacks: &[usize]) -> String {
    let [a, _, c] = rest;
    let (na, nb, nc) = (shape[rest[0]], shape[rest[1]], shape[rest[2]]);
    let mut readings = Vec::new();
    if stacks.is_empty() {
        readings.push(format!(
            "a stack of {na} planes of {nb} x {nc} (Y, X) pixels: pass stack_axis={a}"
        ));
    }
    readings
        .push(format!("{na} channels first, of a {nb} x {nc} (Y, X) image: pass channel_axis={a}"));
    readings
        .push(format!("a {na} x {nb} (Y, X) image with {nc} channels last: pass channel_axis={c}"));
    let within = if stacks.is_empty() {
        String::new()
    } else {
        format!(" (its planes besides stack_axis={})", py_axes(stacks))
    };
    format!(
        "an array of shape {} is ambiguous{within}: it can be {}. Without keywords, \
         3 axes are read as (Y, X, C) only when the last has 1 to 4 channels and the first \
         more than 4 pixels",
        py_shape(shape),
        readings.join("; or ")
    )
}

/// Resolves the axes of an array of `shape` (see the module docs).
pub fn resolve(
    shape: &[usize],
    channel_axis: Option<isize>,
    stack_axes: &[isize],
) -> Result<ImageAxes, String> {
    let nd = shape.len();
    if nd < 2 {
        return Err(format!(
            "expected an image array with y and x axes, (Y, X), (Y, X, C), a stack \
             (T, Y, X) or (T, Y, X, C) in any axis order, got shape {}",
            py_shape(shape)
        ));
    }
    let channel = channel_axis.map(|a| normalise(a, shape, "channel_axis")).transpose()?;
    let mut stacks = Vec::with_capacity(stack_axes.len());
    for &a in stack_axes {
        let k = normalise(a, shape, "stack_axis")?;
        if stacks.contains(&k) || channel == Some(k) {
            return Err(format!(
                "axis {k} of shape {} is named twice by channel_axis and stack_axis",
                py_shape(shape)
            ));
        }
        stacks.push(k);
    }
    stacks.sort_unstable();
    let named = stacks.len() + usize::from(channel.is_some());
    let keywords = || {
        let mut k = Vec::new();
        if let Some(c) = channel {
            k.push(format!("channel_axis={c}"));
        }
        if !stacks.is_empty() {
            k.push(format!("stack_axis={}", py_axes(&stacks)));
        }
        k.join(" and ")
    };
    if nd < named + 2 {
        return Err(format!(
            "an array of shape {} has {nd} axes: no room for y and x besides {}",
            py_shape(shape),
            keywords()
        ));
    }
    if nd == named + 2 {
        return Ok(ImageAxes { stacks, channel });
    }
    if nd > named + 3 || channel.is_some() {
        let unnamed = nd - 2 - named;
        let given = if named == 0 { String::new() } else { format!(" and {}", keywords()) };
        return Err(format!(
            "an array of shape {} has {unnamed} more {} than y, x{given}: name the axes of \
             planes with stack_axis (one axis or a tuple, e.g. stack_axis=0 for \
             (T, Y, X, C), stack_axis=(0, 1) for OME-Zarr's (T, C, Y, X)) and the channels, \
             if any, with channel_axis",
            py_shape(shape),
            if unnamed == 1 { "axis" } else { "axes" }
        ));
    }
    let rest: Vec<usize> = (0..nd).filter(|i| !stacks.contains(i)).collect();
    let rest = [rest[0], rest[1], rest[2]];
    let (first, last) = (shape[rest[0]], shape[rest[2]]);
    if (1..=4).contains(&last) && first > 4 {
        Ok(ImageAxes { stacks, channel: Some(rest[2]) })
    } else {
        Err(ambiguous(shape, rest, &stacks))
    }
}

/// `stack_axis` as Python gives it: None, an int, or a sequence of ints.
pub fn stack_axes(stack_axis: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<isize>> {
    let Some(v) = stack_axis else { return Ok(Vec::new()) };
    if let Ok(k) = v.extract::<isize>() {
        return Ok(vec![k]);
    }
    v.extract::<Vec<isize>>().map_err(|_| {
        PyTypeError::new_err(format!(
            "stack_axis must be an int or a tuple of ints (the axes of planes), got {}",
            v.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into())
        ))
    })
}

/// Resolves the axes of an array of `shape` from the Python keywords (`ValueError` when
/// ambiguous or impossible, `TypeError` for a `stack_axis` that is not ints).
pub fn resolve_py(
    shape: &[usize],
    channel_axis: Option<isize>,
    stack_axis: Option<&Bound<'_, PyAny>>,
) -> PyResult<ImageAxes> {
    resolve(shape, channel_axis, &stack_axes(stack_axis)?).map_err(value_error)
}

/// `trimorph._image_axes(shape, channel_axis=None, stack_axis=None)`: the resolved
/// `(stack_axes, channel_axis)` of an array of `shape` (a tuple of non-negative axes, in
/// order, and an axis or None), as `Deformation.warp` reads it; `ValueError` naming the
/// readings when ambiguous. `trimorph.dask.warp` reads arrays with it, so both agree.
#[pyfunction]
#[pyo3(name = "_image_axes", signature = (shape, channel_axis = None, stack_axis = None))]
pub fn image_axes(
    shape: Vec<usize>,
    channel_axis: Option<isize>,
    stack_axis: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Vec<usize>, Option<usize>)> {
    let a = resolve_py(&shape, channel_axis, stack_axis)?;
    Ok((a.stacks, a.channel))
}
