//! Displacement fields as OME-Zarr stores: the `displacements` and `bijection`
//! transformations of the NGFF coordinate-transformations proposal (RFC-5, in the
//! 0.6 development specification).
//!
//! # What the proposal says, and what is followed
//!
//! * *"coordinateTransformations" metadata*: a transformation is a function of points from
//!   its `input` coordinate system to its `output` one (the "forward" direction).
//!   Transformations between images live in the attributes of a parent group; arrays that
//!   hold their parameters go in a group named `coordinateTransformations`.
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
//!   sit at integer coordinates, which is trimorph's convention: units are **pixels** of
//!   the images (not a UDUNITS length, so no `unit` is written).
//! * *"multiscales" metadata*: each field is stored as a one-level multiscale group (as in
//!   the specification's example) whose coordinate system, named like its transformation,
//!   has the axes `c` (`displacement`), `y`, `x`; level `0` maps to it by a unit `scale`.
//!
//! # Layout (Zarr v3)
//!
//! ```text
//! F.zarr/zarr.json                      attributes.ome: version, coordinateSystems
//!                                       ["original", "warped"], coordinateTransformations
//!                                       [the transformation]; attributes.trimorph: notes
//! F.zarr/coordinateTransformations/inverse/zarr.json   multiscale "inverse" (c, y, x)
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
use crate::warp::field::Field64;
use serde_json::{json, Value};
use std::path::Path;
use std::sync::Arc;
use zarrs::array::codec::ZstdCodec;
use zarrs::array::{data_type, ArrayBuilder, ArrayMetadataOptions};
use zarrs::filesystem::FilesystemStore;
use zarrs::group::GroupBuilder;

/// The NGFF version written in `ome.version` (the coordinate-transformations proposal is
/// part of the 0.6 development specification).
pub const NGFF_VERSION: &str = "0.6.dev3";

/// Name of the coordinate system of the original (input) image's pixels.
pub const ORIGINAL: &str = "original";
/// Name of the coordinate system of the warped (output) image's pixels.
pub const WARPED: &str = "warped";
/// Largest chunk side of a field array (each chunk is `2 x 256 x 256` float64, 1 MiB).
pub const FIELD_CHUNK: u64 = 256;
/// zstd level of the field arrays.
const ZSTD_LEVEL: i32 = 3;

fn space_axes() -> Value {
    json!([{"name": "y", "type": "space"}, {"name": "x", "type": "space"}])
}

/// The multiscale attributes of one field group named `name`.
fn field_attrs(name: &str) -> Value {
    let mut axes = vec![json!({"name": "c", "type": "displacement", "discrete": true})];
    axes.extend(space_axes().as_array().expect("a list").iter().cloned());
    let cs = json!({"name": name, "axes": axes});
    json!({
        "version": NGFF_VERSION,
        "name": name,
        "multiscales": [{
            "name": name,
            "coordinateSystems": [cs],
            "datasets": [{
                "path": "0",
                "coordinateTransformations": [
                    {"type": "scale", "scale": [1.0, 1.0, 1.0], "input": "0", "output": name}
                ]
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

/// Writes one field as the multiscale group `coordinateTransformations/{name}` with its
/// level `0` array `(2, H, W)`: `[0]` = y displacement, `[1]` = x displacement.
fn write_field(
    store: &Arc<FilesystemStore>,
    name: &str,
    f: &Field64,
    werr: &dyn Fn(String) -> NgffError,
) -> Result<(), NgffError> {
    let group = format!("/coordinateTransformations/{name}");
    GroupBuilder::new()
        .attributes(obj(json!({ "ome": field_attrs(name) })))
        .build(store.clone(), &group)
        .map_err(|e| werr(e.to_string()))?
        .store_metadata()
        .map_err(|e| werr(e.to_string()))?;
    let (w, h) = (f.width as u64, f.height as u64);
    let array_attrs = json!({ "ome": {
        "version": NGFF_VERSION,
        "coordinateSystems": field_attrs(name)["multiscales"][0]["coordinateSystems"].clone(),
        "coordinateTransformations": [
            {"type": "scale", "scale": [1.0, 1.0, 1.0], "input": "0", "output": name}
        ]
    }});
    let array = ArrayBuilder::new(
        vec![2, h, w],
        vec![2, h.min(FIELD_CHUNK), w.min(FIELD_CHUNK)],
        data_type::float64(),
        f64::NAN,
    )
    .bytes_to_bytes_codecs(vec![Arc::new(ZstdCodec::new(ZSTD_LEVEL, false))])
    .dimension_names(Some(["c", "y", "x"]))
    .attributes(obj(array_attrs))
    .build(store.clone(), &format!("{group}/0"))
    .map_err(|e| werr(e.to_string()))?;
    array
        .store_metadata_opt(&ArrayMetadataOptions::default().with_include_zarrs_metadata(false))
        .map_err(|e| werr(e.to_string()))?;
    let n = f.data.len();
    let mut data = vec![0.0f64; 2 * n];
    for (i, v) in f.data.iter().enumerate() {
        data[i] = v[1];
        data[n + i] = v[0];
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

/// Writes a displacement-field store at `path` (atomically; see the module docs for the
/// layout and the direction table): `inverse` alone is a `displacements` transformation
/// `warped -> original` holding `v(q) = phi^-1(q) - q`; `forward` alone one
/// `original -> warped` holding `u(p) = phi(p) - p`; both a `bijection`
/// `original -> warped` with `forward = u` and `inverse = v`. Values are pixels, NaN where
/// undefined.
pub fn write_displacements(
    path: &Path,
    forward: Option<&Field64>,
    inverse: Option<&Field64>,
) -> Result<(), NgffError> {
    let werr = |reason: String| NgffError::Write { store: path.to_path_buf(), reason };
    let transform = match (forward, inverse) {
        (None, None) => return Err(werr("no field to write".into())),
        (Some(_), None) => {
            let mut t = displacements("forward");
            t["input"] = json!(ORIGINAL);
            t["output"] = json!(WARPED);
            t
        }
        (None, Some(_)) => {
            let mut t = displacements("inverse");
            t["input"] = json!(WARPED);
            t["output"] = json!(ORIGINAL);
            t
        }
        (Some(_), Some(_)) => json!({
            "type": "bijection",
            "name": "phi",
            "input": ORIGINAL,
            "output": WARPED,
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
    let root = json!({
        "ome": {
            "version": NGFF_VERSION,
            "coordinateSystems": [
                {"name": ORIGINAL, "axes": space_axes()},
                {"name": WARPED, "axes": space_axes()}
            ],
            "coordinateTransformations": [transform]
        },
        "trimorph": {
            "map": "phi maps the original image's pixels to the warped image's pixels (trimorph warp --image: output(q) = input(phi^-1(q)))",
            "fields": {
                "inverse": "v(q) = phi^-1(q) - q at each pixel centre q of the warped grid (resampling direction)",
                "forward": "u(p) = phi(p) - p at each pixel centre p of the original grid"
            },
            "components": "axis c: c = 0 is the y displacement, c = 1 the x displacement (the i-th component is along the i-th output axis)",
            "units": "pixels; pixel (i, j) is centred at x = i, y = j",
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
            write_field(&store, "forward", f, &werr)?;
        }
        if let Some(f) = inverse {
            write_field(&store, "inverse", f, &werr)?;
        }
        Ok(())
    })
}
