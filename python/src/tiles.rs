//! Tiled warps for out-of-core and distributed use (`trimorph.dask.warp`): which input a
//! tile needs ([`tile_inputs`]) and the warp of one tile from that input alone
//! ([`warp_tile`]), bit-identical to the tile's pixels of `Deformation.warp` on the whole
//! image (the library's `warp::tiles`).
//!
//! Rectangles are `(y0, x0, h, w)` in pixels, numpy order (rows first).

use crate::arrays::{c_order, to_numpy, Sample};
use crate::deformation::{warp_options, Deformation};
use crate::errors::value_error;
use numpy::PyUntypedArrayMethods;
use numpy::{dtype, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray};
use pyo3::prelude::*;
use trimorph::warp::remap::RemapOptions;
use trimorph::warp::tiles::{warp_tile_into, Rect, TileLayout, TilePlanner};
use trimorph::warp::{Samples, SamplesMut, WarpOptions};

/// A rectangle as Python gives it: `(y0, x0, h, w)`.
type PyRect = (u32, u32, u32, u32);

/// A `(y0, x0, h, w)` rectangle as the library's.
fn rect((y0, x0, h, w): PyRect) -> Rect {
    Rect { x0, y0, w, h }
}

/// The remap options `Deformation.warp` uses for `tolerance`.
fn remap_options(tolerance: f64) -> PyResult<RemapOptions> {
    Ok(warp_options("bilinear", 0.0, tolerance, "constant")?.remap)
}

/// For each output tile `(y0, x0, h, w)` of an image of `shape = (H, W)`, the input
/// rectangle its warp reads (`None`: the tile is all background and reads nothing). The
/// rectangles come from bounds on the spline (its Jacobian and control points), not from
/// solving the inverse, so they cost little; `resolution` (reference pixels, default a tenth
/// of the smallest tile side, at least 32) trades planning time for tighter rectangles.
#[pyfunction]
#[pyo3(signature = (deformation, shape, tiles, tolerance = 0.01, resolution = None, mode = "constant"))]
pub fn tile_inputs(
    py: Python<'_>,
    deformation: &Deformation,
    shape: (u32, u32),
    tiles: Vec<PyRect>,
    tolerance: f64,
    resolution: Option<f64>,
    mode: &str,
) -> PyResult<Vec<Option<PyRect>>> {
    let ro = remap_options(tolerance)?;
    let mode = warp_options("bilinear", 0.0, tolerance, mode)?.mode;
    let (h, w) = shape;
    let smallest = tiles.iter().map(|t| t.2.min(t.3)).min().unwrap_or(0) as f64;
    let res = resolution.unwrap_or((smallest / 10.0).max(32.0));
    let s = &deformation.spline;
    Ok(py.detach(|| {
        let planner = TilePlanner::with_resolution(s, (w, h), &ro, res);
        tiles
            .iter()
            .map(|&t| planner.input_rect_for(rect(t), mode).map(|r| (r.y0, r.x0, r.h, r.w)))
            .collect()
    }))
}

fn warp_tile_typed<'py, T: Sample>(
    py: Python<'py>,
    deformation: &Deformation,
    a: &Bound<'py, PyArrayDyn<T>>,
    origin: (u32, u32),
    shape: (u32, u32),
    tile: Rect,
    opts: &WarpOptions,
    channels: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let ro = a.readonly();
    let wshape = ro.shape().to_vec();
    let (planes, wh, ww, nc) = match (channels, &*wshape) {
        (false, &[wh, ww]) => (1, wh, ww, 1),
        (false, &[n, wh, ww]) => (n, wh, ww, 1),
        (true, &[wh, ww, c]) if (1..=4).contains(&c) => (1, wh, ww, c),
        (true, &[n, wh, ww, c]) if (1..=4).contains(&c) => (n, wh, ww, c),
        (false, _) => {
            return Err(value_error(format!(
                "window: expected shape (h, w) or (planes, h, w), got {wshape:?}"
            )))
        }
        (true, _) => {
            return Err(value_error(format!(
                "window: expected shape (h, w, c) or (planes, h, w, c) with 1 to 4 channels \
                 c, got {wshape:?}"
            )))
        }
    };
    let (Ok(wh32), Ok(ww32)) = (u32::try_from(wh), u32::try_from(ww)) else {
        return Err(value_error(format!("window of shape {wshape:?} is too large")));
    };
    let window = Rect { x0: origin.1, y0: origin.0, w: ww32, h: wh32 };
    let data = c_order(&ro);
    let plane = wh * ww * nc;
    let out_plane = tile.len() * nc;
    let mut out = vec![T::default(); planes * out_plane];
    let s = &deformation.spline;
    let (h, w) = shape;
    py.detach(|| {
        let ins: Vec<Samples<'_>> =
            (0..planes).map(|k| T::samples(&data[k * plane..(k + 1) * plane])).collect();
        let mut outs: Vec<SamplesMut<'_>> =
            out.chunks_mut(out_plane.max(1)).take(planes).map(|c| T::samples_mut(c)).collect();
        let layout = TileLayout { size: (w, h), tile, window, channels: nc };
        warp_tile_into(s, layout, &ins, &mut outs, opts)
    })
    .map_err(value_error)?;
    let mut oshape: Vec<usize> = Vec::new();
    if wshape.len() == 3 + usize::from(channels) {
        oshape.push(planes);
    }
    oshape.extend([tile.h as usize, tile.w as usize]);
    if channels {
        oshape.push(nc);
    }
    Ok(to_numpy(py, out, &oshape)?.into_any())
}

/// Warps the output tile `(y0, x0, h, w)` of an image of `shape = (H, W)` from `window`, the
/// input pixels of the rectangle at `origin = (y, x)` (a 2-D array, or `(planes, h, w)` for
/// planes warped alike), which must contain `tile_inputs` of the tile. With
/// `channel_axis=-1` the window's last axis holds 1 to 4 channels (`(h, w, c)` or
/// `(planes, h, w, c)`: gray, gray + alpha, RGB, RGBA, as `Deformation.warp` reads them);
/// no other channel axis is taken (move it last with `numpy.moveaxis`). Returns the tile
/// (the window's layout), bit-identical to the same pixels of `Deformation.warp` on the
/// whole image with the same `interp`, `background` and `tolerance`. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (deformation, window, origin, shape, tile, interp = "bilinear", background = 0.0, tolerance = 0.01, mode = "constant", channel_axis = None))]
#[allow(clippy::too_many_arguments)]
pub fn warp_tile<'py>(
    py: Python<'py>,
    deformation: &Deformation,
    window: &Bound<'py, PyAny>,
    origin: (u32, u32),
    shape: (u32, u32),
    tile: PyRect,
    interp: &str,
    background: f64,
    tolerance: f64,
    mode: &str,
    channel_axis: Option<isize>,
) -> PyResult<Bound<'py, PyAny>> {
    let opts = warp_options(interp, background, tolerance, mode)?;
    let tile = rect(tile);
    let a = window
        .cast::<PyUntypedArray>()
        .map_err(|_| value_error("window: expected a numpy array (use numpy.asarray)"))?;
    let nd = a.ndim() as isize;
    let channels = match channel_axis {
        None => false,
        Some(k) if k == -1 || k == nd - 1 => true,
        Some(k) => {
            return Err(value_error(format!(
                "channel_axis={k}: a window's channels must be its last axis (-1); move them \
                 there with numpy.moveaxis"
            )))
        }
    };
    let dt = a.dtype();
    if dt.is_equiv_to(&dtype::<u8>(py)) {
        warp_tile_typed(
            py,
            deformation,
            a.cast::<PyArrayDyn<u8>>()?,
            origin,
            shape,
            tile,
            &opts,
            channels,
        )
    } else if dt.is_equiv_to(&dtype::<u16>(py)) {
        warp_tile_typed(
            py,
            deformation,
            a.cast::<PyArrayDyn<u16>>()?,
            origin,
            shape,
            tile,
            &opts,
            channels,
        )
    } else if dt.is_equiv_to(&dtype::<f32>(py)) {
        warp_tile_typed(
            py,
            deformation,
            a.cast::<PyArrayDyn<f32>>()?,
            origin,
            shape,
            tile,
            &opts,
            channels,
        )
    } else {
        Err(value_error(format!(
            "window: unsupported dtype {dt} (use uint8, uint16 or float32; convert with .astype)"
        )))
    }
}
