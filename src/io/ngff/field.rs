//! Displacement fields as OME-Zarr stores: the `displacements` and `bijection`
//! transformations of NGFF 0.6 (the coordinate-transformations RFC-5, part of the 0.6
//! specification: sections "coordinateTransformations metadata", "coordinates and
//! displacements", "bijection" and "scene metadata").
//!
//! # What the proposal says, and what is followed
//!
//! * *"coordinateTransformations" metadata*: a transformation is a function of points from
//!   its `input` coordinate system to its `output` one (the "forward" direction); `input`
//!   and `output` are objects naming a coordinate system (`{"name": ...}`).
//!   Transformations between images live in the `scene` object of a parent group, with the
//!   coordinate systems they join; arrays that hold their parameters go in a group named
//!   `coordinateTransformations`.
//! * *coordinates and displacements*: a `displacements` transformation names an array by
//!   `path`; a point `x` of the input system maps to `x + d(x)`, with `d` looked up in the
//!   array (interpolated, `linear` by default). The array has one dimension per input axis
//!   plus one `displacement` axis (`"discrete": true`) whose length is the number of output
//!   axes; **the i-th component is the displacement along the i-th output axis**. The
//!   proposal recommends (SHOULD) that axis last; trimorph's issue fixes it **first**, as in
//!   the specification's example `displacements/displacement_field.json`, so the array is
//!   `(c, y, x)`, and since the axes are ordered `(y, x)`, **`c = 0` is the y displacement
//!   and `c = 1` the x displacement** (the specification's 2D example says the same: "the
//!   y-displacement is first").
//! * *bijection*: an invertible transformation with explicit `forward` (input -> output)
//!   and `inverse` (output -> input) members, which may omit their own `input`/`output`.
//! * *Coordinate convention*: the centre of the first pixel is the origin and pixel centres
//!   sit at integer coordinates, which is trimorph's convention. By default the units are
//!   **pixels** of the images (no `unit` is written). With a [`Physical`] placement (spacing
//!   `s`, origin `o`, `unit`), pixel centre `(i, j)` lies at `o + s * (i, j)`: the space axes
//!   carry the unit, the array's level maps to its coordinate system by `scale` `(1, sy, sx)`
//!   (then `translation` `(0, oy, ox)` when the origin is not 0), and the displacements are
//!   physical lengths, `s * d` per axis.
//! * *"multiscales" metadata*: each field is stored as a one-level multiscale group (as in
//!   the specification's example). Its coordinate system has the axes `c` (`displacement`),
//!   `y`, `x` and is named like the transformation's input system (`warped` for the inverse
//!   field, `original` for the forward one), as the specification's example does: the
//!   field's coordinates are the points of the input system.
//!
//! # Layout (Zarr v3)
//!
//! ```text
//! F.zarr/zarr.json                      attributes.ome: version "0.6", scene:
//!                                       coordinateSystems ["original", "warped"] and
//!                                       coordinateTransformations [the transformation];
//!                                       attributes.trimorph: notes
//! F.zarr/coordinateTransformations/inverse/zarr.json   multiscale "inverse", system
//!                                       "warped" (c, y, x)
//! F.zarr/coordinateTransformations/inverse/0           float64 (2, H, W), fill NaN
//! F.zarr/coordinateTransformations/forward/...         the same for the forward field
//! ```
//!
//! # Which way each runs
//!
//! `phi` maps the original image's pixels to the warped image's pixels (a feature at `p`
//! in the input of `trimorph warp --image` appears at `phi(p)` in its output).
//!
//! | `trimorph field DEF -o F.zarr` | transformation | input -> output | array over | value at a pixel |
//! |---|---|---|---|---|
//! | (default) | `displacements` `inverse` | `warped` -> `original` | warped grid, `q` | `v(q) = phi^-1(q) - q` |
//! | `--inverse` | `displacements` `forward` | `original` -> `warped` | original grid, `p` | `u(p) = phi(p) - p` |
//! | `--both` | `bijection` `phi` (forward = `forward`, inverse = `inverse`) | `original` -> `warped` | both | both |
//!
//! The default is the resampling direction (like the ITK file): to render the original
//! image in the warped frame, look up `original(q + v(q))` at each warped pixel `q`. This
//! is opposite to the `.npy` / `.tif` default (`u`), which is unchanged. Where a map is
//! undefined (no preimage, or outside the mesh) both components are NaN.

use super::{write_store_atomic, NgffError};
use crate::spline::Physical;
use crate::warp::field::Field64;
use serde_json::{json, Value};
use std::path::Path;
use std::sync::Arc;
use zarrs::array::codec::ZstdCodec;
use zarrs::array::{data_type, ArrayBuilder, ArrayMetadataOptions};
use zarrs::filesystem::FilesystemStore;
use zarrs::group::GroupBuilder;

/// The NGFF version written in `ome.version`: the 0.6 specification, which holds the
/// coordinate-transformations proposal (scenes, displacement fields, bijections).
pub const NGFF_VERSION: &str = "0.6";

/// Name of the coordinate system of the original (input) image's pixels.
pub const ORIGINAL: &str = "original";
/// Name of the coordinate system of the warped (output) image's pixels.
pub const WARPED: &str = "warped";
/// Largest chunk side of a field array (each chunk is `2 x 256 x 256` float64, 1 MiB).
pub const FIELD_CHUNK: u64 = 256;
/// zstd level of the field arrays.
const ZSTD_LEVEL: i32 = 3;

/// The space axes `(y, x)`, with the placement's unit when it states one.
fn space_axes(physical: &Physical) -> Vec<Value> {
    ["y", "x"]
        .iter()
        .map(|n| match &physical.unit {
            Some(u) => json!({"name": n, "type": "space", "unit": u}),
            None => json!({"name": n, "type": "space"}),
        })
        .collect()
}

/// The transformation from the level-0 array's indices `(c, j, i)` to the field's
/// coordinate system `system`: a `scale` `(1, sy, sx)`, followed by a `translation`
/// `(0, oy, ox)` when the origin is not 0 (the two forms NGFF allows in `datasets`).
fn level_transform(system: &str, physical: &Physical) -> Value {
    let [sx, sy] = physical.spacing;
    let [ox, oy] = physical.origin;
    let scale = json!({"type": "scale", "scale": [1.0, sy, sx]});
    let io = |mut t: Value| {
        t["input"] = json!({"path": "0"});
        t["output"] = json!({"name": system});
        t
    };
    if physical.origin == [0.0; 2] {
        io(scale)
    } else {
        io(json!({
            "type": "sequence",
            "transformations": [scale, {"type": "translation", "translation": [0.0, oy, ox]}]
        }))
    }
}

/// The `ome` attributes of the field group `name`, whose points are those of `system`.
fn field_attrs(name: &str, system: &str, physical: &Physical) -> Value {
    let mut axes = vec![json!({"name": "c", "type": "displacement", "discrete": true})];
    axes.extend(space_axes(physical));
    json!({
        "version": NGFF_VERSION,
        "multiscales": [{
            "name": name,
            "coordinateSystems": [{"name": system, "axes": axes}],
            "datasets": [{
                "path": "0",
                "coordinateTransformations": [level_transform(system, physical)]
            }]
        }]
    })
}

fn obj(v: Value) -> serde_json::Map<String, Value> {
    match v {
        Value::Object(m) => m,
        _ => unreachable!("built as an object"),
    }
}

/// Writes one field as the multiscale group `coordinateTransformations/{name}` (coordinate
/// system `system`) with its level `0` array `(2, H, W)`: `[0]` = y displacement, `[1]` = x
/// displacement, each scaled by the placement's spacing along its axis.
fn write_field(
    store: &Arc<FilesystemStore>,
    (name, system): (&str, &str),
    f: &Field64,
    physical: &Physical,
    werr: &dyn Fn(String) -> NgffError,
) -> Result<(), NgffError> {
    let group = format!("/coordinateTransformations/{name}");
    GroupBuilder::new()
        .attributes(obj(json!({ "ome": field_attrs(name, system, physical) })))
        .build(store.clone(), &group)
        .map_err(|e| werr(e.to_string()))?
        .store_metadata()
        .map_err(|e| werr(e.to_string()))?;
    let (w, h) = (f.width as u64, f.height as u64);
    let array = ArrayBuilder::new(
        vec![2, h, w],
        vec![2, h.min(FIELD_CHUNK), w.min(FIELD_CHUNK)],
        data_type::float64(),
        f64::NAN,
    )
    .bytes_to_bytes_codecs(vec![Arc::new(ZstdCodec::new(ZSTD_LEVEL, false))])
    .dimension_names(Some(["c", "y", "x"]))
    .build(store.clone(), &format!("{group}/0"))
    .map_err(|e| werr(e.to_string()))?;
    array
        .store_metadata_opt(&ArrayMetadataOptions::default().with_include_zarrs_metadata(false))
        .map_err(|e| werr(e.to_string()))?;
    let n = f.data.len();
    let [sx, sy] = physical.spacing;
    let mut data = vec![0.0f64; 2 * n];
    for (i, v) in f.data.iter().enumerate() {
        data[i] = sy * v[1];
        data[n + i] = sx * v[0];
    }
    array.store_array_subset(&array.subset_all(), &data[..]).map_err(|e| werr(e.to_string()))
}

/// A `displacements` transformation entry for the field `name`.
fn displacements(name: &str) -> Value {
    json!({
        "type": "displacements",
        "name": name,
        "path": format!("coordinateTransformations/{name}"),
        "interpolation": "linear"
    })
}

/// `{"name": system}`, a reference to a coordinate system of the scene.
fn system(name: &str) -> Value {
    json!({ "name": name })
}

/// Writes a displacement-field store at `path` (atomically; see the module docs for the
/// layout and the direction table): `inverse` alone is a `displacements` transformation
/// `warped -> original` holding `v(q) = phi^-1(q) - q`; `forward` alone one
/// `original -> warped` holding `u(p) = phi(p) - p`; both a `bijection`
/// `original -> warped` with `forward = u` and `inverse = v`. The grids are placed in
/// physical space by `physical` ([`Physical::pixels`]: values in pixels); NaN where
/// undefined.
pub fn write_displacements(
    path: &Path,
    forward: Option<&Field64>,
    inverse: Option<&Field64>,
    physical: &Physical,
) -> Result<(), NgffError> {
    let werr = |reason: String| NgffError::Write { store: path.to_path_buf(), reason };
    physical.validate().map_err(|e| werr(format!("physical placement: {e}")))?;
    let transform = match (forward, inverse) {
        (None, None) => return Err(werr("no field to write".into())),
        (Some(_), None) => {
            let mut t = displacements("forward");
            t["input"] = system(ORIGINAL);
            t["output"] = system(WARPED);
            t
        }
        (None, Some(_)) => {
            let mut t = displacements("inverse");
            t["input"] = system(WARPED);
            t["output"] = system(ORIGINAL);
            t
        }
        (Some(_), Some(_)) => json!({
            "type": "bijection",
            "name": "phi",
            "input": system(ORIGINAL),
            "output": system(WARPED),
            "forward": displacements("forward"),
            "inverse": displacements("inverse")
        }),
    };
    for f in forward.iter().chain(inverse.iter()) {
        if f.data.len() != f.width as usize * f.height as usize || f.data.is_empty() {
            return Err(werr(format!(
                "a {}x{} field holds {} values",
                f.width,
                f.height,
                f.data.len()
            )));
        }
    }
    let units = match &physical.unit {
        _ if physical.is_pixels() => "pixels; pixel (i, j) is centred at x = i, y = j".to_string(),
        u => format!(
            "{}; pixel (i, j) is centred at x = {} + {} i, y = {} + {} j",
            u.as_deref().unwrap_or("physical units (unit not stated)"),
            physical.origin[0],
            physical.spacing[0],
            physical.origin[1],
            physical.spacing[1]
        ),
    };
    let root = json!({
        "ome": {
            "version": NGFF_VERSION,
            "scene": {
                "coordinateSystems": [
                    {"name": ORIGINAL, "axes": space_axes(physical)},
                    {"name": WARPED, "axes": space_axes(physical)}
                ],
                "coordinateTransformations": [transform]
            }
        },
        "trimorph": {
            "map": "phi maps the original image's pixels to the warped image's pixels (trimorph warp --image: output(q) = input(phi^-1(q)))",
            "fields": {
                "inverse": "v(q) = phi^-1(q) - q at each pixel centre q of the warped grid (resampling direction)",
                "forward": "u(p) = phi(p) - p at each pixel centre p of the original grid"
            },
            "components": "axis c: c = 0 is the y displacement, c = 1 the x displacement (the i-th component is along the i-th output axis)",
            "units": units,
            "undefined": "NaN where the map is undefined (no preimage, or outside the mesh)"
        }
    });
    write_store_atomic(path, |tmp| {
        let store = Arc::new(FilesystemStore::new(tmp).map_err(|e| werr(e.to_string()))?);
        GroupBuilder::new()
            .attributes(obj(root))
            .build(store.clone(), "/")
            .map_err(|e| werr(e.to_string()))?
            .store_metadata()
            .map_err(|e| werr(e.to_string()))?;
        GroupBuilder::new()
            .build(store.clone(), "/coordinateTransformations")
            .map_err(|e| werr(e.to_string()))?
            .store_metadata()
            .map_err(|e| werr(e.to_string()))?;
        if let Some(f) = forward {
            write_field(&store, ("forward", ORIGINAL), f, physical, &werr)?;
        }
        if let Some(f) = inverse {
            write_field(&store, ("inverse", WARPED), f, physical, &werr)?;
        }
        Ok(())
    })
}
