//! numpy arrays in and out: images (2-D, or H x W x C) of `uint8`, `uint16` or `float32`,
//! and point lists `(n, 2)` of `float64`.
//!
//! Images are read without a copy when C-contiguous (otherwise copied once into C order),
//! and results are handed to numpy without a copy (`PyArray::from_vec`).

use crate::errors::value_error;
use numpy::{
    dtype, Element, PyArray1, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn,
    PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use std::borrow::Cow;
use trimorph::spline::Spline;
use trimorph::warp::{warp_samples_into, Layout, Samples, SamplesMut, WarpOptions, WarpReport};

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

/// Warps one image array of sample type `T`: `O(q) = I(phi^-1(q))`, same shape and dtype.
///
/// Up to 4 channels go through the library in one call, with its conventions (2 and 4
/// channels: the last is alpha, 0 where the preimage is outside the mesh), exactly as
/// `trimorph warp` treats a gray+alpha or RGBA file. More channels are warped as independent
/// gray planes sharing one preimage computation (no alpha).
fn warp_typed<'py, T: Sample>(
    py: Python<'py>,
    s: &Spline,
    a: &Bound<'py, PyArrayDyn<T>>,
    opts: &WarpOptions,
) -> PyResult<(Bound<'py, PyAny>, WarpReport, f64)> {
    let ro = a.readonly();
    let shape = ro.shape().to_vec();
    let (h, w, c) = image_dims(&shape)?;
    if h == 0 || w == 0 {
        return Err(value_error(format!("the image is empty (shape {shape:?})")));
    }
    let (wu, hu) = (u32::try_from(w), u32::try_from(h));
    let (Ok(wu), Ok(hu)) = (wu, hu) else {
        return Err(value_error(format!("image of shape {shape:?} is too large")));
    };
    let data = c_order(&ro);
    // Timed from the output's allocation, as `warp_pages` (the Rust API) allocates its own.
    let t0 = std::time::Instant::now();
    let mut out = vec![T::default(); data.len()];
    let report = if c <= 4 {
        let layout = Layout { width: wu, height: hu, channels: c };
        py.detach(|| {
            warp_samples_into(
                s,
                layout,
                &[T::samples(&data)],
                &mut [T::samples_mut(&mut out)],
                opts,
                &|_| {},
            )
        })
    } else {
        py.detach(|| {
            let planes: Vec<Vec<T>> =
                (0..c).map(|k| data.iter().skip(k).step_by(c).copied().collect()).collect();
            let mut outs: Vec<Vec<T>> = (0..c).map(|_| vec![T::default(); w * h]).collect();
            let ins: Vec<Samples<'_>> = planes.iter().map(|p| T::samples(p)).collect();
            let mut outs_v: Vec<SamplesMut<'_>> =
                outs.iter_mut().map(|p| T::samples_mut(p)).collect();
            let layout = Layout { width: wu, height: hu, channels: 1 };
            let r = warp_samples_into(s, layout, &ins, &mut outs_v, opts, &|_| {});
            drop(outs_v);
            for (k, plane) in outs.iter().enumerate() {
                for (i, v) in plane.iter().enumerate() {
                    out[i * c + k] = *v;
                }
            }
            r
        })
    }
    .map_err(value_error)?;
    let inner = t0.elapsed().as_secs_f64();
    Ok((to_numpy(py, out, &shape)?.into_any(), report, inner))
}

/// Warps a numpy image of dtype `uint8`, `uint16` or `float32` (see [`warp_typed`]).
/// Returns the image, the library's report, and the seconds spent in the library call
/// alone (for the numpy-overhead benchmark, `python/benches/numpy_overhead.py`).
pub fn warp_any<'py>(
    py: Python<'py>,
    s: &Spline,
    array: &Bound<'py, PyAny>,
    opts: &WarpOptions,
) -> PyResult<(Bound<'py, PyAny>, WarpReport, f64)> {
    let a = array
        .cast::<PyUntypedArray>()
        .map_err(|_| value_error("expected a numpy array (use numpy.asarray)"))?;
    let dt = a.dtype();
    if dt.is_equiv_to(&dtype::<u8>(py)) {
        warp_typed(py, s, a.cast::<PyArrayDyn<u8>>()?, opts)
    } else if dt.is_equiv_to(&dtype::<u16>(py)) {
        warp_typed(py, s, a.cast::<PyArrayDyn<u16>>()?, opts)
    } else if dt.is_equiv_to(&dtype::<f32>(py)) {
        warp_typed(py, s, a.cast::<PyArrayDyn<f32>>()?, opts)
    } else {
        Err(value_error(format!(
            "unsupported dtype {dt} (use uint8, uint16 or float32; convert with .astype)"
        )))
    }
}

/// `(n, 2)` float64 points from any array-like (converted by `numpy.asarray`).
pub fn points_in(py: Python<'_>, xy: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f64; 2]>> {
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
    Ok((0..n).map(|i| [v[2 * i], v[2 * i + 1]]).collect())
}

/// `(n, 2)` float64 array, NaN rows for `None`.
pub fn points_out<'py>(
    py: Python<'py>,
    pts: &[Option<[f64; 2]>],
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let flat: Vec<f64> = pts.iter().flat_map(|p| p.unwrap_or([f64::NAN; 2])).collect();
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
        e @ trimorph::io::raster::RasterError::Memory { .. } => {
            pyo3::exceptions::PyMemoryError::new_err(e.to_string())
        }
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
