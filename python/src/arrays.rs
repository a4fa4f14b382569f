//! numpy arrays in and out: images (2-D, H x W x C, and stacks of either, their axes read
//! by [`crate::axes`]) of `uint8`, `uint16` or `float32`, and point lists `(n, 2)` of
//! `float64` (in `(x, y)` or `(row, col)` order, [`PointOrder`]).
//!
//! Images are read without a copy when C-contiguous (otherwise copied once into C order),
//! and results are handed to numpy without a copy (`PyArray::from_vec`).

use crate::errors::value_error;
use crate::watch::Watch;
use numpy::{
    dtype, Element, PyArray1, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn,
    PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use std::borrow::Cow;
use trimorph::spline::Spline;
use trimorph::warp::{
    warp_samples_cancellable, Layout, Samples, SamplesMut, WarpOptions, WarpReport,
};

/// A sample type trimorph warps.
pub trait Sample: Element + Copy + Default + Send + Sync + 'static {
    /// The library's borrowed view.
    fn samples(d: &[Self]) -> Samples<'_>;
    /// The library's mutable view.
    fn samples_mut(d: &mut [Self]) -> SamplesMut<'_>;
}

macro_rules! sample {
    ($t:ty, $v:ident) => {
        impl Sample for $t {
            fn samples(d: &[Self]) -> Samples<'_> {
                Samples::$v(d)
            }
            fn samples_mut(d: &mut [Self]) -> SamplesMut<'_> {
                SamplesMut::$v(d)
            }
        }
    };
}
sample!(u8, U8);
sample!(u16, U16);
sample!(f32, F32);

/// The image dimensions `(height, width, channels)` of a 2-D or 3-D shape.
pub fn image_dims(shape: &[usize]) -> PyResult<(usize, usize, usize)> {
    match *shape {
        [h, w] => Ok((h, w, 1)),
        [h, w, c] if c >= 1 => Ok((h, w, c)),
        _ => Err(value_error(format!(
            "expected an image of shape (H, W) or (H, W, C) with C >= 1, got shape {shape:?}"
        ))),
    }
}

/// The samples of `a` in C order: borrowed when contiguous, else copied once.
///
/// `as_slice` alone is not enough: it also accepts Fortran-ordered arrays, whose samples
/// are then in column order (a bug caught by `test_non_contiguous_input_gives_the_contiguous_result`).
pub fn c_order<'a, T: Element + Copy>(a: &'a PyReadonlyArrayDyn<'_, T>) -> Cow<'a, [T]> {
    if a.is_c_contiguous() {
        if let Ok(s) = a.as_slice() {
            return Cow::Borrowed(s);
        }
    }
    // `iter` walks the logical (C) order whatever the strides.
    Cow::Owned(a.as_array().iter().copied().collect())
}

/// A fresh numpy array of `shape` owning `data` (no copy).
pub fn to_numpy<'py, T: Element>(
    py: Python<'py>,
    data: Vec<T>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    PyArray1::from_vec(py, data).reshape(shape.to_vec())
}

/// The sizes of an image array in the order `warp_typed` reads it: `planes` stacked
/// planes of `h x w` pixels of `c` channels (C order: plane, y, x, channel).
#[derive(Clone, Copy, Debug)]
struct Dims {
    planes: usize,
    h: usize,
    w: usize,
    c: usize,
}

/// Warps an image array of sample type `T` laid out as `dims`: `O(q) = I(phi^-1(q))`, same
/// shape and dtype. All planes go through one library call (one preimage computation).
///
/// Up to 4 channels go through the library as they are, with its conventions (2 and 4
/// channels: the last is alpha, 0 where the preimage is outside the mesh), exactly as
/// `trimorph warp` treats a gray+alpha or RGBA file. More channels are warped as independent
/// gray planes (no alpha).
fn warp_typed<'py, T: Sample>(
    py: Python<'py>,
    s: &Spline,
    a: &Bound<'py, PyArrayDyn<T>>,
    dims: Dims,
    opts: &WarpOptions,
    watch: &Watch<'py>,
) -> PyResult<(Bound<'py, PyAny>, WarpReport, f64)> {
    let ro = a.readonly();
    let shape = ro.shape().to_vec();
    let Dims { planes, h, w, c } = dims;
    let (Ok(wu), Ok(hu)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(value_error(format!("image of shape {shape:?} is too large")));
    };
    let data = c_order(&ro);
    // Timed from the output's allocation, as `warp_pages` (the Rust API) allocates its own.
    let t0 = std::time::Instant::now();
    let mut out = vec![T::default(); data.len()];
    let plane = h * w * c;
    let report = if c <= 4 {
        let layout = Layout { width: wu, height: hu, channels: c };
        watch.run(py, hu as u64, |sh| {
            let ins: Vec<Samples<'_>> = data.chunks(plane).map(T::samples).collect();
            let mut outs: Vec<SamplesMut<'_>> =
                out.chunks_mut(plane).map(|p| T::samples_mut(p)).collect();
            let size = (wu, hu);
            let rows = |n| sh.add(n);
            warp_samples_cancellable(s, layout, &ins, size, &mut outs, opts, &rows, &sh.cancel)
        })?
    } else {
        watch.run(py, hu as u64, |sh| {
            // Plane p, channel k is gray page p * c + k.
            let gray: Vec<Vec<T>> = data
                .chunks(plane)
                .flat_map(|p| (0..c).map(move |k| p.iter().skip(k).step_by(c).copied().collect()))
                .collect();
            let mut outs: Vec<Vec<T>> =
                (0..planes * c).map(|_| vec![T::default(); w * h]).collect();
            let ins: Vec<Samples<'_>> = gray.iter().map(|p| T::samples(p)).collect();
            let mut outs_v: Vec<SamplesMut<'_>> =
                outs.iter_mut().map(|p| T::samples_mut(p)).collect();
            let layout = Layout { width: wu, height: hu, channels: 1 };
            let rows = |n| sh.add(n);
            let r = warp_samples_cancellable(
                s,
                layout,
                &ins,
                (wu, hu),
                &mut outs_v,
                opts,
                &rows,
                &sh.cancel,
            );
            drop(outs_v);
            for (g, page) in outs.iter().enumerate() {
                let (p, k) = (g / c, g % c);
                let dst = &mut out[p * plane..(p + 1) * plane];
                for (i, v) in page.iter().enumerate() {
                    dst[i * c + k] = *v;
                }
            }
            r
        })?
    }
    .map_err(value_error)?;
    let inner = t0.elapsed().as_secs_f64();
    Ok((to_numpy(py, out, &shape)?.into_any(), report, inner))
}

/// Warps a numpy image of dtype `uint8`, `uint16` or `float32`, its axes read by
/// [`crate::axes::resolve`] from `channel_axis` and `stack_axis` (see [`warp_typed`]).
/// Returns the image (same shape, dtype and axis order, C-contiguous), the library's report,
/// and the seconds spent in the library call alone (for the numpy-overhead benchmark,
/// `python/benches/numpy_overhead.py`).
pub fn warp_any<'py>(
    py: Python<'py>,
    s: &Spline,
    array: &Bound<'py, PyAny>,
    opts: &WarpOptions,
    channel_axis: Option<isize>,
    stack_axis: Option<&Bound<'py, PyAny>>,
    watch: &Watch<'py>,
) -> PyResult<(Bound<'py, PyAny>, WarpReport, f64)> {
    let a = array
        .cast::<PyUntypedArray>()
        .map_err(|_| value_error("expected a numpy array (use numpy.asarray)"))?;
    let shape = a.shape().to_vec();
    let axes = crate::axes::resolve_py(&shape, channel_axis, stack_axis)?;
    if shape.contains(&0) {
        return Err(value_error(format!("the image is empty (shape {shape:?})")));
    }
    let nd = shape.len();
    // The array as (planes..., y, x, channels): the stack axes first, the channel axis last.
    let mut from = axes.stacks.clone();
    let mut to: Vec<usize> = (0..from.len()).collect();
    if let Some(k) = axes.channel {
        from.push(k);
        to.push(nd - 1);
    }
    let moved = from != to;
    let np = py.import("numpy")?;
    let canonical = if moved {
        np.call_method1("moveaxis", (a, from.clone(), to.clone()))?
    } else {
        a.clone().into_any()
    };
    let spatial: Vec<usize> =
        (0..nd).filter(|i| !axes.stacks.contains(i) && Some(*i) != axes.channel).collect();
    let dims = Dims {
        planes: axes.stacks.iter().map(|&k| shape[k]).product(),
        h: shape[spatial[0]],
        w: shape[spatial[1]],
        c: axes.channel.map_or(1, |k| shape[k]),
    };
    let dt = a.dtype();
    let (out, report, secs) = if dt.is_equiv_to(&dtype::<u8>(py)) {
        warp_typed(py, s, canonical.cast::<PyArrayDyn<u8>>()?, dims, opts, watch)
    } else if dt.is_equiv_to(&dtype::<u16>(py)) {
        warp_typed(py, s, canonical.cast::<PyArrayDyn<u16>>()?, dims, opts, watch)
    } else if dt.is_equiv_to(&dtype::<f32>(py)) {
        warp_typed(py, s, canonical.cast::<PyArrayDyn<f32>>()?, dims, opts, watch)
    } else {
        Err(value_error(format!(
            "unsupported dtype {dt} (use uint8, uint16 or float32; convert with .astype)"
        )))
    }?;
    if !moved {
        return Ok((out, report, secs));
    }
    let back = np.call_method1("moveaxis", (out, to, from))?;
    Ok((np.call_method1("ascontiguousarray", (back,))?, report, secs))
}

/// The order of the two columns of a point array (keyword `order` of the point APIs):
/// trimorph's `(x, y)`, or numpy's `(row, col)` = `(y, x)` (napari Points layers,
/// scikit-image). The same pixel centres either way: only the columns are swapped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PointOrder {
    /// `(x, y)`: x to the right, y down (trimorph's, the default).
    Xy,
    /// `(row, col)`: `(y, x)`.
    Rc,
}

impl PointOrder {
    /// `"xy"` or `"rc"`.
    pub fn parse(order: &str) -> PyResult<PointOrder> {
        match order {
            "xy" => Ok(PointOrder::Xy),
            "rc" => Ok(PointOrder::Rc),
            other => Err(value_error(format!(
                "order must be \"xy\" ((x, y) columns, trimorph's) or \"rc\" ((row, col), \
                 napari's and scikit-image's), got {other:?}"
            ))),
        }
    }

    /// A point in this order as `(x, y)`, or an `(x, y)` point in this order (a swap is its
    /// own inverse).
    fn swap(self, p: [f64; 2]) -> [f64; 2] {
        match self {
            PointOrder::Xy => p,
            PointOrder::Rc => [p[1], p[0]],
        }
    }
}

/// `(n, 2)` float64 points from any array-like (converted by `numpy.asarray`), in `order`,
/// as `(x, y)`.
pub fn points_in(
    py: Python<'_>,
    xy: &Bound<'_, PyAny>,
    what: &str,
    order: PointOrder,
) -> PyResult<Vec<[f64; 2]>> {
    let np = py.import("numpy")?;
    let arr = np.call_method1("asarray", (xy, "float64"))?;
    let a = arr.cast::<PyArrayDyn<f64>>()?.readonly();
    let shape = a.shape().to_vec();
    let n = match *shape {
        [n, 2] => n,
        [0] => 0,
        _ => {
            return Err(value_error(format!(
                "{what}: expected points of shape (n, 2), got shape {shape:?}"
            )))
        }
    };
    let v = c_order(&a);
    Ok((0..n).map(|i| order.swap([v[2 * i], v[2 * i + 1]])).collect())
}

/// `(x, y)` points as an `(n, 2)` float64 array in `order`, NaN rows for `None`.
pub fn points_out<'py>(
    py: Python<'py>,
    pts: &[Option<[f64; 2]>],
    order: PointOrder,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let flat: Vec<f64> =
        pts.iter().flat_map(|p| p.map_or([f64::NAN; 2], |p| order.swap(p))).collect();
    to_numpy(py, flat, &[pts.len(), 2])
}

/// A decoded image as a numpy array: `(H, W)` for one channel, `(H, W, C)` otherwise, of
/// dtype `uint8`, `uint16` or `float32`. `gray` keeps only the first channel (a gray float
/// image held as RGB).
pub fn image_to_numpy<'py>(
    py: Python<'py>,
    img: &image::DynamicImage,
    gray: bool,
) -> PyResult<Bound<'py, PyAny>> {
    use image::DynamicImage as D;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let nc = img.color().channel_count() as usize;
    let shape: Vec<usize> = if nc == 1 || gray { vec![h, w] } else { vec![h, w, nc] };
    fn out<'py, T: Element + Copy>(
        py: Python<'py>,
        v: &[T],
        nc: usize,
        gray: bool,
        shape: &[usize],
    ) -> PyResult<Bound<'py, PyAny>> {
        let v: Vec<T> =
            if gray && nc > 1 { v.iter().step_by(nc).copied().collect() } else { v.to_vec() };
        Ok(to_numpy(py, v, shape)?.into_any())
    }
    match img {
        D::ImageLuma8(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageLumaA8(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageRgb8(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageRgba8(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageLuma16(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageLumaA16(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageRgb16(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageRgba16(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageRgb32F(b) => out(py, b.as_raw(), nc, gray, &shape),
        D::ImageRgba32F(b) => out(py, b.as_raw(), nc, gray, &shape),
        other => Err(value_error(format!("unsupported image type {:?}", other.color()))),
    }
}

/// A numpy image as an `image::DynamicImage` for the library calls that take one (the
/// morph): 1 to 4 channels of `uint8` / `uint16`; `float32` with 1 (held as RGB, as the
/// command line reads gray float TIFF), 3 or 4 channels. Returns the image and whether it
/// was gray float.
pub fn numpy_to_image(
    py: Python<'_>,
    array: &Bound<'_, PyAny>,
    what: &str,
) -> PyResult<(image::DynamicImage, bool)> {
    use image::{DynamicImage as D, ImageBuffer};
    let a = array
        .cast::<PyUntypedArray>()
        .map_err(|_| value_error(format!("{what}: expected a numpy array")))?;
    let (h, w, c) = image_dims(a.shape())?;
    let (w32, h32) = (w as u32, h as u32);
    let bad = || value_error(format!("{what}: {c} channels of {} are not supported", a.dtype()));
    macro_rules! buf {
        ($t:ty) => {{
            let ro = a.cast::<PyArrayDyn<$t>>()?.readonly();
            c_order(&ro).into_owned()
        }};
    }
    let dt = a.dtype();
    let img = if dt.is_equiv_to(&dtype::<u8>(py)) {
        let v = buf!(u8);
        match c {
            1 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageLuma8),
            2 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageLumaA8),
            3 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageRgb8),
            4 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageRgba8),
            _ => return Err(bad()),
        }
    } else if dt.is_equiv_to(&dtype::<u16>(py)) {
        let v = buf!(u16);
        match c {
            1 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageLuma16),
            2 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageLumaA16),
            3 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageRgb16),
            4 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageRgba16),
            _ => return Err(bad()),
        }
    } else if dt.is_equiv_to(&dtype::<f32>(py)) {
        let v = buf!(f32);
        match c {
            1 => {
                let rgb: Vec<f32> = v.iter().flat_map(|&x| [x, x, x]).collect();
                return ImageBuffer::from_raw(w32, h32, rgb)
                    .map(|b| (D::ImageRgb32F(b), true))
                    .ok_or_else(bad);
            }
            3 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageRgb32F),
            4 => ImageBuffer::from_raw(w32, h32, v).map(D::ImageRgba32F),
            _ => return Err(bad()),
        }
    } else {
        return Err(value_error(format!(
            "{what}: unsupported dtype {dt} (uint8, uint16, float32)"
        )));
    };
    img.map(|i| (i, false)).ok_or_else(bad)
}

fn ngff_error(e: trimorph::io::ngff::NgffError) -> PyErr {
    match e {
        trimorph::io::ngff::NgffError::Io(io) => crate::errors::io_error(&io),
        other => value_error(other),
    }
}

/// `trimorph.read_ome_zarr(path)`: the full-resolution level of an OME-Zarr image (Zarr v2
/// or v3; axes `[t,] [c,] y, x`; uint8, uint16 or float32) as `(array, axes)`: the array in
/// the store's axis order and dtype, and the axis names. The same reader as
/// `trimorph warp --image X.zarr`.
#[pyfunction]
pub fn read_ome_zarr<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(Bound<'py, PyAny>, Vec<String>)> {
    let img = py.detach(|| trimorph::io::ngff::read_image(&path)).map_err(ngff_error)?;
    let planes: Vec<Bound<'py, PyAny>> =
        img.pages.iter().map(|p| image_to_numpy(py, p, true)).collect::<PyResult<_>>()?;
    let shape: Vec<usize> = img.shape.iter().map(|&n| n as usize).collect();
    let stacked = py.import("numpy")?.call_method1("stack", (planes,))?;
    let arr = stacked.call_method1("reshape", (shape,))?;
    Ok((arr, img.axes.iter().map(|a| a.name.clone()).collect()))
}

/// `trimorph.read_image(path)`: the pages of a PNG / TIFF / JPEG file as numpy arrays, with
/// the command line's decoder (`trimorph warp --image` reads files this way). One page:
/// `(H, W)` or `(H, W, C)`; several: stacked on a leading axis. An OME-Zarr store (`.zarr`)
/// is read by [`read_ome_zarr`] (the array only).
#[pyfunction]
pub fn read_image<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyAny>> {
    if trimorph::io::ngff::is_zarr_path(&path) {
        return Ok(read_ome_zarr(py, path)?.0);
    }
    let stack = py.detach(|| trimorph::io::raster::read_stack(&path)).map_err(|e| match e {
        trimorph::io::raster::RasterError::Io(io) => crate::errors::io_error(&io),
        e @ trimorph::io::raster::RasterError::Header(
            trimorph::io::raster::HeaderError::Memory { .. },
        ) => pyo3::exceptions::PyMemoryError::new_err(e.to_string()),
        other => value_error(other),
    })?;
    let arrays: Vec<Bound<'py, PyAny>> = stack
        .pages
        .iter()
        .map(|p| image_to_numpy(py, p, stack.gray_float))
        .collect::<PyResult<_>>()?;
    if arrays.len() == 1 {
        return Ok(arrays.into_iter().next().expect("one page"));
    }
    py.import("numpy")?.call_method1("stack", (arrays,))
}
