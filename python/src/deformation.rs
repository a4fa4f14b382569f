//! `trimorph.Deformation`: a spline deformation `phi` and what can be done with it.
//!
//! Directions (the same as the library's, `trimorph::warp`): `phi` maps the reference
//! domain to the deformed plane, both in pixels (x right, y down, pixel `(i, j)` centred at
//! `(i, j)`). `map_points` is `p -> phi(p)`, `inverse_points` is `q -> phi^-1(q)`, and
//! `warp` computes `O(q) = I(phi^-1(q))`, so a feature at `p` in the input appears at
//! `phi(p)` in the output.

use crate::arrays::{points_in, points_out, to_numpy, warp_any, PointOrder};
use crate::errors::{io_error, value_error};
use crate::watch::{CancelToken, Cancelled, Watch};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::{Map, Value};
use std::path::PathBuf;
use trimorph::edit::extra::Extra;
use trimorph::edit::script::{Script, ScriptError};
use trimorph::edit::{Editor, LastEdit};
use trimorph::io::{deformation as dio, read_text, write_atomic, IoError};
use trimorph::jobs::spline::{build_mesh, MeshSource};
use trimorph::mesh::{AdaptOptions, Mesh, MeshOptions};
use trimorph::spline::Spline;
use trimorph::warp::inverse::InverseOptions;
use trimorph::warp::remap::RemapOptions;
use trimorph::warp::{field, EdgeMode, Interp, WarpOptions};

/// The largest field `field()` computes (pixels): the limit of `trimorph field`.
const MAX_FIELD_PIXELS: u64 = trimorph::io::MAX_RASTER_PIXELS;

/// A C1 spline deformation `phi: R^2 -> R^2` over a triangle mesh (pixel coordinates).
///
/// Besides the spline it keeps what a deformation file carries: the last edit, the stored
/// constraints (`"constraints"`, kept by every later edit), and the keys other tools add
/// (`"pinned"`, a scene's `"model"` / `"image"` / `"landmarks"`), so that load + save loses
/// nothing.
#[pyclass(module = "trimorph")]
pub struct Deformation {
    pub(crate) spline: Spline,
    pub(crate) last: Option<LastEdit>,
    pub(crate) extras: Vec<Extra>,
    pub(crate) kept: Map<String, Value>,
}

impl Deformation {
    /// A deformation without edit history or report.
    pub fn new(spline: Spline) -> Deformation {
        Deformation { spline, last: None, extras: Vec::new(), kept: Map::new() }
    }

    /// A deformation from a file's text (`source` names it in errors).
    fn parse(text: &str, source: &str) -> Result<Deformation, String> {
        let (spline, last) =
            dio::from_str(text).map_err(|e| format!("cannot read deformation {source}: {e}"))?;
        let extras = dio::constraints_from_str(text, &spline)
            .map_err(|e| format!("cannot read the constraints of {source}: {e}"))?;
        let doc: Value = serde_json::from_str(text).map_err(|e| format!("{source}: {e}"))?;
        let written = dio::to_json_with(&spline, last.as_ref(), &extras);
        let kept = match doc {
            Value::Object(m) => m.into_iter().filter(|(k, _)| written.get(k).is_none()).collect(),
            _ => Map::new(),
        };
        Ok(Deformation { spline, last, extras, kept })
    }

    /// The physical placement of a field: each part given, else the frame's recorded one,
    /// else pixels ([`trimorph::jobs::field::placement`]).
    fn placement(
        &self,
        spacing: Option<(f64, f64)>,
        origin: Option<(f64, f64)>,
        unit: Option<String>,
    ) -> PyResult<trimorph::spline::Physical> {
        let parts = trimorph::jobs::field::PlacementParts {
            spacing: spacing.map(|(x, y)| [x, y]),
            origin: origin.map(|(x, y)| [x, y]),
            unit,
        };
        trimorph::jobs::field::placement(&self.spline, &parts).map_err(value_error)
    }

    /// Stores a fit report with the deformation (key `"report"` of its file).
    pub(crate) fn set_report(&mut self, report: Value) {
        self.kept.insert("report".into(), report);
    }

    /// Stores the landmarks the deformation was fitted to (key `"landmarks"`, as `trimorph
    /// fit` writes them: the editor's re-fit keeps them).
    pub(crate) fn set_landmarks(&mut self, lms: &[trimorph::fit::landmarks::Landmark]) {
        use trimorph::io::deformation::{landmarks_value, LANDMARKS_KEY};
        self.kept.insert(LANDMARKS_KEY.into(), landmarks_value(lms));
    }

    /// The file's JSON text.
    fn text(&self) -> String {
        let mut v = dio::to_json_with(&self.spline, self.last.as_ref(), &self.extras);
        for (k, x) in &self.kept {
            v[k] = x.clone();
        }
        trimorph::io::json_rows(&v)
    }
}

pub(crate) fn inverse_options(tolerance: f64) -> PyResult<InverseOptions> {
    if !(tolerance > 0.0 && tolerance.is_finite()) {
        return Err(value_error("tolerance must be a positive number of pixels"));
    }
    Ok(InverseOptions { tolerance, ..Default::default() })
}

pub(crate) fn warp_options(
    interp: &str,
    background: f64,
    tolerance: f64,
    mode: &str,
) -> PyResult<WarpOptions> {
    let interp: Interp = interp.parse().map_err(value_error)?;
    if !background.is_finite() {
        return Err(value_error("background must be a finite number"));
    }
    Ok(WarpOptions {
        interp,
        background,
        remap: RemapOptions { inverse: inverse_options(tolerance)?, ..Default::default() },
        mode: mode.parse::<EdgeMode>().map_err(|e| value_error(format!("mode: {e}")))?,
    })
}

/// `(w, h)` as whole pixels within the field limit.
fn grid_size(size: Option<(u32, u32)>, s: &Spline) -> PyResult<(u32, u32)> {
    let (w, h) = match size {
        Some(wh) => wh,
        None => trimorph::jobs::field::default_size(s),
    };
    if w == 0 || h == 0 || w as u64 * h as u64 > MAX_FIELD_PIXELS {
        return Err(value_error(format!(
            "field size {w}x{h} is empty or too large (at most 10^8 pixels); give size=(W, H)"
        )));
    }
    Ok((w, h))
}

/// `(w, h)` of a frame as positive finite numbers.
fn frame_size(size: (f64, f64)) -> PyResult<[f64; 2]> {
    let (w, h) = size;
    if !(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()) {
        return Err(value_error(format!("size: width and height must be positive, got {size:?}")));
    }
    Ok([w, h])
}

#[pymethods]
impl Deformation {
    /// Reads a deformation file (JSON, the format `trimorph` writes).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Deformation> {
        let text = read_text(&path).map_err(|e| io_error(&e))?;
        let source = path.display().to_string();
        py.detach(|| Deformation::parse(&text, &source)).map_err(value_error)
    }

    /// A deformation from the JSON text of a deformation file.
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Deformation> {
        py.detach(|| Deformation::parse(text, "(text)")).map_err(value_error)
    }

    /// The deformation file's JSON text.
    fn to_json(&self) -> String {
        self.text()
    }

    /// Applies an edit script: a list of operations as dicts, exactly as in the JSON scripts
    /// of `trimorph edit` (e.g. `{"op": "translate", "anchors": [12], "by": [3, 0]}`;
    /// `rotate`, `scale`, `constrain`; exact values may be strings like "7/2"). All or
    /// nothing: if an operation fails, the deformation is left exactly as it was.
    /// Unsolvable moves raise `UnsolvableError`; malformed operations `ValueError` naming the
    /// operation's index and key. Returns one report dict per operation.
    ///
    /// `bounded_bits` (default 24, as `trimorph edit`): after each operation the free points
    /// of the edit are rounded to multiples of `2^-bits` and the rest recomputed exactly, so
    /// C1 still holds exactly but the numbers stay small over long histories; `None` keeps
    /// every value exact (as `trimorph edit --unbounded`).
    // The text signature spells the default (`Some(24)` shows as `...` otherwise).
    #[pyo3(signature = (ops, bounded_bits = Some(24)), text_signature = "(self, ops, bounded_bits=24)")]
    fn edit<'py>(
        &mut self,
        py: Python<'py>,
        ops: &Bound<'py, PyAny>,
        bounded_bits: Option<u32>,
    ) -> PyResult<Py<PyAny>> {
        if bounded_bits.is_some_and(|b| !(8..=62).contains(&b)) {
            return Err(value_error("bounded_bits must be between 8 and 62 (or None)"));
        }
        let text: String = py.import("json")?.call_method1("dumps", (ops,))?.extract()?;
        let script = Script::from_json_str(&text).map_err(value_error)?;
        let (spline, extras) = (self.spline.clone(), self.extras.clone());
        enum Fail {
            Stored(trimorph::edit::EditError),
            Script(ScriptError),
            Absurd(String),
        }
        let result = py.detach(move || -> Result<_, Fail> {
            let mut ed = Editor::new(spline);
            // As `trimorph edit`: a spline with no determining set keeps exact values.
            let note = ed.set_bounded(bounded_bits).err().map(|e| e.to_string());
            for e in extras {
                ed.add_constraint(e).map_err(Fail::Stored)?;
            }
            let reports = script.run(&mut ed).map_err(Fail::Script)?;
            // The editor's bound on coordinates (`trimorph edit` refuses the same).
            if let Some(what) = trimorph::server::doc::absurd_point(ed.spline()) {
                return Err(Fail::Absurd(what));
            }
            Ok((reports, ed, note))
        });
        let (reports, ed, note) = result.map_err(|f| match f {
            Fail::Script(e) if e.is_unsolvable() => {
                let kind = match &e {
                    ScriptError::Edit { source: trimorph::edit::EditError::Ecles(x), .. } => {
                        crate::errors::variant_name(x)
                    }
                    _ => "NotSolvable".to_string(),
                };
                crate::errors::unsolvable(py, &kind, &e)
            }
            Fail::Script(e) => value_error(&e),
            Fail::Stored(e) => crate::errors::TrimorphError::new_err(format!(
                "a stored constraint of this deformation does not hold: {e}"
            )),
            Fail::Absurd(what) => value_error(format!(
                "after the edits {what}, beyond {} pixels: refused (the deformation is unchanged)",
                trimorph::server::doc::MAX_COORD
            )),
        })?;
        if let Some(n) = note {
            let msg = format!("{n}; keeping exact values unbounded");
            PyErr::warn(
                py,
                &py.get_type::<pyo3::exceptions::PyUserWarning>(),
                &std::ffi::CString::new(msg)?,
                1,
            )?;
        }
        if let Some(l) = trimorph::edit::script::last_edit(&reports) {
            self.last = Some(l);
        }
        self.extras = ed.constraints().to_vec();
        self.spline = ed.into_spline();
        // The fit report described the map before the edit.
        self.kept.remove("report");
        let v = serde_json::to_value(&reports).map_err(value_error)?;
        crate::values::to_dict(py, &v)
    }

    /// The report of `trimorph check` as a dict: exact C1, the certified det J bounds, folds
    /// (`samples` per triangle side for the sampled minimum); the per-condition
    /// `c1_residuals` list only with `residuals=True`, as `trimorph check --residuals`.
    #[pyo3(signature = (samples = 12, residuals = false))]
    fn check(&self, py: Python<'_>, samples: usize, residuals: bool) -> PyResult<Py<PyAny>> {
        // As `trimorph check`: the scan costs samples^2 evaluations per triangle.
        if !(1..=1000).contains(&samples) {
            return Err(value_error(format!("samples {samples}: use 1 to 1000 per triangle side")));
        }
        let v = py.detach(|| {
            trimorph::spline::check::check_report_with(&self.spline, samples, residuals)
        });
        crate::values::to_dict(py, &serde_json::to_value(&v).map_err(value_error)?)
    }

    /// Writes the deformation file (atomically: a temporary file renamed into place).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let text = self.to_json();
        py.detach(|| write_atomic(&path, text.as_bytes())).map_err(|e: IoError| io_error(&e))
    }

    /// The identity over a `cols x rows` grid of cells (two triangles each) covering
    /// `size = (w, h)` pixels from the origin; `snap` is the mesh's snapping denominator.
    /// As `trimorph mesh --grid COLSxROWS --size W,H`: a whole-pixel size is recorded as the
    /// image frame (`frame`), so `field()` is `h x w` pixels, not the `(h + 1) x (w + 1)`
    /// pixel centres of the grid's extent.
    #[staticmethod]
    #[pyo3(signature = (cols, rows, size, degree = 5, snap = 16))]
    fn mesh_grid(
        cols: usize,
        rows: usize,
        size: (f64, f64),
        degree: usize,
        snap: i64,
    ) -> PyResult<Deformation> {
        let [w, h] = frame_size(size)?;
        if cols == 0 || rows == 0 || cols * rows > 1_000_000 {
            return Err(value_error(
                "cols and rows must be whole numbers >= 1 (at most 10^6 cells)",
            ));
        }
        let source = MeshSource::Grid { cols, rows, width: w, height: h };
        let mesh = build_mesh(&source, MeshOptions { grid: snap }).map_err(value_error)?;
        let mut s = Spline::identity(mesh, degree).map_err(value_error)?;
        s.set_frame(source.frame());
        Ok(Deformation::new(s))
    }

    /// The identity over a mesh adapted to landmark sources `src` ((n, 2) pixels) in a frame
    /// of `size = (w, h)`, like `trimorph mesh --landmarks`: refined where the landmarks are,
    /// with a margin around the frame so a fit keeps the whole frame covered. `far_rings`
    /// adds far-field rings around it (`trimorph mesh --far-rings`). `order` is the columns'
    /// order of `src`: "xy" or "rc" (row, col); `size` is `(w, h)` either way.
    #[staticmethod]
    #[pyo3(signature = (src, size, margin = None, max_edge = None, min_angle = 15.0, degree = 5, snap = None, far_rings = 0, order = "xy"))]
    fn mesh_landmarks(
        py: Python<'_>,
        src: &Bound<'_, PyAny>,
        size: (f64, f64),
        margin: Option<f64>,
        max_edge: Option<f64>,
        min_angle: f64,
        degree: usize,
        snap: Option<i64>,
        far_rings: usize,
        order: &str,
    ) -> PyResult<Deformation> {
        let size = frame_size(size)?;
        let sources = points_in(py, src, "src", PointOrder::parse(order)?)?;
        let lms = crate::values::landmarks_of(&sources, &sources, None, None)?;
        let grid = snap.unwrap_or_else(|| trimorph::fit::frame::source_grid(&lms));
        let ao =
            AdaptOptions { margin, max_edge, min_angle, grid, extra_points: Vec::new(), far_rings };
        let mesh =
            py.detach(|| Mesh::landmark_adapted(&sources, size, &ao)).map_err(value_error)?.mesh;
        let mut s = Spline::identity(mesh, degree).map_err(value_error)?;
        s.set_frame(trimorph::spline::ImageFrame::new(size).ok());
        Ok(Deformation::new(s))
    }

    /// Warps an image array: `O(q) = I(phi^-1(q))`, same shape, dtype and axis order
    /// (uint8, uint16 or float32). Releases the GIL.
    ///
    /// Axes, as in scikit-image: `channel_axis` names the axis of channels and
    /// `stack_axis` the axis (or a tuple of axes) of planes warped one by one (a
    /// time-lapse's t, a z-stack's z, OME-Zarr's t and c); they may be negative and
    /// anywhere, and the two axes left are y then x. Without them a 2-D array is `(Y, X)`
    /// and a 3-D array `(Y, X, C)` only when its last axis has 1 to 4 channels and its
    /// first more than 4 pixels; other 3-D arrays (a `(T, Y, X)` stack, channels first) are
    /// refused with a `ValueError` naming the readings and their keyword. With `stack_axis`
    /// alone the planes follow the same rule, so `(T, Y, X, C)` needs only `stack_axis=0`.
    /// 1 to 4 channels are gray, gray + alpha, RGB, RGBA (the alpha of 2 and 4 is 0 where
    /// the preimage is outside the mesh, as for such files); more are warped alike as
    /// independent planes, and so are planes (to warp 2 or 4 channels without alpha, name
    /// their axis in `stack_axis`). Every plane of a stack equals the warp of that plane
    /// alone.
    ///
    /// `interp` is "nearest", "bilinear" or "bicubic"; `background` fills pixels whose
    /// preimage is outside the mesh, and (`mode="constant"`, the default) outside the
    /// image; `mode` is scikit-image's: "constant", "edge" or "reflect". Bit-identical to
    /// `trimorph warp --image --mode`.
    ///
    /// `progress(done, total)`, when given, is called on the calling thread with the output
    /// rows finished, about every 20 ms and once at the end; `cancel` takes a
    /// `trimorph.CancelToken`. Ctrl-C (`KeyboardInterrupt`), an exception raised by
    /// `progress`, or a cancelled token (`trimorph.Cancelled`) stops the warp between bands
    /// of rows.
    #[pyo3(signature = (array, interp = "bilinear", background = 0.0, tolerance = 0.01, mode = "constant", channel_axis = None, stack_axis = None, progress = None, cancel = None))]
    fn warp<'py>(
        &self,
        py: Python<'py>,
        array: &Bound<'py, PyAny>,
        interp: &str,
        background: f64,
        tolerance: f64,
        mode: &str,
        channel_axis: Option<isize>,
        stack_axis: Option<&Bound<'py, PyAny>>,
        progress: Option<Bound<'py, PyAny>>,
        cancel: Option<&Bound<'py, CancelToken>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = warp_options(interp, background, tolerance, mode)?;
        let watch = Watch::new(progress, cancel)?;
        Ok(warp_any(py, &self.spline, array, &opts, channel_axis, stack_axis, &watch)?.0)
    }

    /// `warp` (the same keywords and axes), returning `(image, report, seconds)`: the
    /// library's report as a dict (pixels, outside, folded, max_error_bound, the inverse
    /// map's path counts) and the time spent in what the Rust API `warp_pages` also does
    /// (allocating the output and the library call), so that `total - seconds` is what
    /// numpy in and out costs (`python/benches/numpy_overhead.py`).
    #[pyo3(signature = (array, interp = "bilinear", background = 0.0, tolerance = 0.01, mode = "constant", channel_axis = None, stack_axis = None))]
    fn warp_profiled<'py>(
        &self,
        py: Python<'py>,
        array: &Bound<'py, PyAny>,
        interp: &str,
        background: f64,
        tolerance: f64,
        mode: &str,
        channel_axis: Option<isize>,
        stack_axis: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>, f64)> {
        let opts = warp_options(interp, background, tolerance, mode)?;
        let watch = Watch::new(None, None)?;
        let (img, r, secs) =
            warp_any(py, &self.spline, array, &opts, channel_axis, stack_axis, &watch)?;
        let d = PyDict::new(py);
        d.set_item("pixels", r.pixels)?;
        d.set_item("outside", r.outside)?;
        d.set_item("folded", r.folded)?;
        d.set_item("max_error_bound", r.max_error_bound)?;
        d.set_item("paths", r.paths_line())?;
        Ok((img, d, secs))
    }

    /// `phi(p)` for each row of `xy` ((n, 2) float64); NaN rows outside the mesh. `order`
    /// is the columns' order, of the input and the result alike: "xy" (x, y), trimorph's,
    /// or "rc" (row, col), napari's and scikit-image's.
    #[pyo3(signature = (xy, order = "xy"))]
    fn map_points<'py>(
        &self,
        py: Python<'py>,
        xy: &Bound<'py, PyAny>,
        order: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let order = PointOrder::parse(order)?;
        let pts = points_in(py, xy, "xy", order)?;
        let out = py.detach(|| trimorph::warp::forward(&self.spline, &pts));
        Ok(points_out(py, &out, order)?.into_any())
    }

    /// `phi^-1(q)` for each row of `xy` ((n, 2) float64), certified to `tolerance` pixels;
    /// NaN rows with no preimage in the mesh. The same as `trimorph warp --points --inverse`.
    /// `order` as in `map_points` ("xy" or "rc", input and result alike).
    #[pyo3(signature = (xy, tolerance = 0.01, order = "xy"))]
    fn inverse_points<'py>(
        &self,
        py: Python<'py>,
        xy: &Bound<'py, PyAny>,
        tolerance: f64,
        order: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let order = PointOrder::parse(order)?;
        let pts = points_in(py, xy, "xy", order)?;
        let opts = inverse_options(tolerance)?;
        let out: Vec<Option<[f64; 2]>> = py.detach(|| {
            trimorph::warp::inverse(&self.spline, &pts, opts)
                .into_iter()
                .map(|r| r.map(|r| r.p))
                .collect()
        });
        Ok(points_out(py, &out, order)?.into_any())
    }

    /// The displacement field on a `size = (W, H)` pixel grid (default: the image frame the
    /// deformation was made for, `frame`, else the mesh's extent from 0) as an (H, W, 2) float32 array, NaN where undefined: forward `phi(p) - p`, or
    /// with `inverse=True` `phi^-1(q) - q` (the same values as `trimorph field`).
    /// `progress(done, total)` hears of the rows finished and `cancel` takes a
    /// `trimorph.CancelToken`, as in `warp`; the inverse field stops between bands of rows.
    #[pyo3(signature = (inverse = false, size = None, progress = None, cancel = None))]
    fn field<'py>(
        &self,
        py: Python<'py>,
        inverse: bool,
        size: Option<(u32, u32)>,
        progress: Option<Bound<'py, PyAny>>,
        cancel: Option<&Bound<'py, CancelToken>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (w, h) = grid_size(size, &self.spline)?;
        let watch = Watch::new(progress, cancel)?;
        let f = watch.run(py, h as u64, |sh| {
            if inverse {
                let rows = |n| sh.add(n);
                let opts = InverseOptions::default();
                field::inverse_field_watched(&self.spline, w, h, opts, &rows, &sh.cancel)
            } else {
                let f = field::forward_field_f64(&self.spline, w, h);
                sh.add(h as u64);
                Ok(f)
            }
        })?;
        let Ok(f) = f else { return Err(Cancelled::new_err("cancelled")) };
        let flat: Vec<f32> = f.data.iter().flat_map(|v| [v[0] as f32, v[1] as f32]).collect();
        Ok(to_numpy(py, flat, &[h as usize, w as usize, 2])?.into_any())
    }

    /// Writes an ITK HDF5 transform (`DisplacementFieldTransform_double_2_2`, identity
    /// direction) over `size = (W, H)` (default: the image frame, `frame`, else the mesh's
    /// extent from 0), exactly as `trimorph field DEF -o F.h5`.
    ///
    /// Direction: by default the file holds `phi^-1(q) - q`, the direction ITK resamples in:
    /// SimpleITK's `Resample(moving, reference, transform)` reproduces `warp`, and
    /// `transform.TransformPoint(q)` is `inverse_points(q)`. With `inverse=True` it holds
    /// `phi(p) - p` (`TransformPoint(p)` is `map_points(p)`). Undefined displacements are NaN
    /// (ITK resamples them to the background). Returns the number of undefined grid points.
    ///
    /// Physical space: `spacing = (sx, sy)` and `origin = (ox, oy)` (default: the frame's
    /// recorded ones, see `with_frame`, else 1 and 0, ITK's pixel grid) place pixel centre
    /// `(i, j)` at `origin + spacing * (i, j)`; displacements are then physical, `spacing *`
    /// pixels. Resampling a SimpleITK image with that spacing and origin still reproduces
    /// `warp` on its array.
    #[pyo3(signature = (path, inverse = false, size = None, tolerance = 0.01, spacing = None, origin = None))]
    fn to_itk(
        &self,
        py: Python<'_>,
        path: PathBuf,
        inverse: bool,
        size: Option<(u32, u32)>,
        tolerance: f64,
        spacing: Option<(f64, f64)>,
        origin: Option<(f64, f64)>,
    ) -> PyResult<usize> {
        use trimorph::io::itk::{displacement_transform, write_h5, FieldDirection, ItkError};
        let (w, h) = grid_size(size, &self.spline)?;
        let opts = inverse_options(tolerance)?;
        let physical = self.placement(spacing, origin, None)?;
        let dir = if inverse { FieldDirection::Forward } else { FieldDirection::Resampling };
        py.detach(|| {
            let f = displacement_transform(&self.spline, w, h, dir, opts, &physical)?;
            write_h5(&f, &path)?;
            Ok(f.undefined())
        })
        .map_err(|e: ItkError| match e {
            ItkError::Io(io) => io_error(&io),
            other => value_error(other),
        })
    }

    /// Writes an OME-Zarr (NGFF 0.6 coordinate transformations) displacement store,
    /// exactly as `trimorph field DEF -o F.zarr`: a float64 `(2, H, W)` = `(c, y, x)` array
    /// (`c = 0` the y displacement, as the proposal orders components by output axis), NaN
    /// where undefined. By default `phi^-1(q) - q` (the resampling direction, from the
    /// `warped` to the `original` pixel coordinate system); `inverse=True` holds
    /// `phi(p) - p`; `both=True` a `bijection` with the two. Written atomically, NGFF 0.6.
    ///
    /// Physical space: `scale = (sx, sy)` (the pixel spacing, in trimorph's (x, y) order;
    /// NGFF's `scale` lists it as `(1, sy, sx)`), `origin = (ox, oy)` and `units` (e.g.
    /// `"micrometer"`, on both space axes); each defaults to the frame's recorded one (see
    /// `with_frame`), else pixels. Displacements are then physical, `scale *` pixels.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (path, inverse = false, both = false, size = None, tolerance = 0.01, scale = None, origin = None, units = None))]
    fn to_ngff(
        &self,
        py: Python<'_>,
        path: PathBuf,
        inverse: bool,
        both: bool,
        size: Option<(u32, u32)>,
        tolerance: f64,
        scale: Option<(f64, f64)>,
        origin: Option<(f64, f64)>,
        units: Option<String>,
    ) -> PyResult<()> {
        if both && inverse {
            return Err(value_error("both=True writes both directions; leave out inverse"));
        }
        let (w, h) = grid_size(size, &self.spline)?;
        let opts = inverse_options(tolerance)?;
        let physical = self.placement(scale, origin, units)?;
        py.detach(|| {
            let forward = (both || inverse).then(|| field::forward_field_f64(&self.spline, w, h));
            let backward =
                (both || !inverse).then(|| field::inverse_field_f64(&self.spline, w, h, opts));
            trimorph::io::ngff::field::write_displacements(
                &path,
                forward.as_ref(),
                backward.as_ref(),
                &physical,
            )
        })
        .map_err(|e| match e {
            trimorph::io::ngff::NgffError::Io(io) => io_error(&io),
            other => value_error(other),
        })
    }

    /// The fit report (a dict, the same keys as `trimorph fit --report`) when this
    /// deformation was made by `trimorph.fit`, else None. It is stored in the deformation's
    /// file (key `"report"`), so it survives `save` / `load`, `copy` and pickling.
    #[getter]
    fn report(&self, py: Python<'_>) -> PyResult<Option<Py<PyAny>>> {
        self.kept.get("report").map(|v| crate::values::to_dict(py, v)).transpose()
    }

    /// The image frame the deformation was made for, as a dict (`size` = `(w, h)` pixels;
    /// `spacing`, `origin`, `unit` when known), or None. `trimorph.fit(..., size=)`,
    /// `trimorph.register`, `Deformation.mesh_landmarks` and `Deformation.mesh_grid` (a
    /// whole-pixel size) record it; `field`, `to_itk` and `to_ngff` default to it.
    #[getter]
    fn frame(&self, py: Python<'_>) -> PyResult<Option<Py<PyAny>>> {
        self.spline
            .frame()
            .map(|f| {
                let v = serde_json::to_value(f).map_err(value_error)?;
                crate::values::to_dict(py, &v)
            })
            .transpose()
    }

    /// The spline's degree.
    #[getter]
    fn degree(&self) -> usize {
        self.spline.degree()
    }

    /// Number of control points.
    #[getter]
    fn num_points(&self) -> usize {
        self.spline.num_points()
    }

    /// Number of mesh vertices.
    #[getter]
    fn num_vertices(&self) -> usize {
        self.spline.mesh().num_vertices()
    }

    /// Number of mesh triangles.
    #[getter]
    fn num_triangles(&self) -> usize {
        self.spline.mesh().num_triangles()
    }

    /// The reference mesh's bounding box `((x0, y0), (x1, y1))`.
    #[getter]
    fn bbox(&self) -> ((f64, f64), (f64, f64)) {
        let (lo, hi) = self.spline.mesh().bbox();
        ((lo[0], lo[1]), (hi[0], hi[1]))
    }

    /// A copy that records the image frame `size = (w, h)` pixels (default: the recorded
    /// one) placed in physical space: `spacing = (sx, sy)` between pixel centres, `origin =
    /// (ox, oy)` the position of pixel (0, 0)'s centre, in `unit`s (each default: the
    /// recorded one). Pixel centre `(i, j)` lies at `origin + spacing * (i, j)`. `field`,
    /// `to_itk` and `to_ngff` then default to this frame and placement; the map itself
    /// (in pixels) is unchanged.
    #[pyo3(signature = (size = None, spacing = None, origin = None, unit = None))]
    fn with_frame(
        &self,
        size: Option<(f64, f64)>,
        spacing: Option<(f64, f64)>,
        origin: Option<(f64, f64)>,
        unit: Option<String>,
    ) -> PyResult<Deformation> {
        let recorded = self.spline.frame().cloned();
        let size = match (size, &recorded) {
            (Some(s), _) => frame_size(s)?,
            (None, Some(f)) => f.size,
            (None, None) => {
                return Err(value_error(
                    "this deformation records no frame: give size=(w, h) in pixels",
                ))
            }
        };
        let frame = trimorph::spline::ImageFrame::new(size).map_err(value_error)?;
        let parts = trimorph::jobs::field::PlacementParts {
            spacing: spacing.map(|(x, y)| [x, y]),
            origin: origin.map(|(x, y)| [x, y]),
            unit,
        };
        let physical =
            trimorph::jobs::field::placement(&self.spline, &parts).map_err(value_error)?;
        let frame = if physical.is_pixels() && recorded.as_ref().is_none_or(|f| f.spacing.is_none())
        {
            frame
        } else {
            frame.with_physical(&physical).map_err(value_error)?
        };
        let mut d = self.copy();
        d.spline.set_frame(Some(frame));
        Ok(d)
    }

    /// An independent copy.
    fn copy(&self) -> Deformation {
        Deformation {
            spline: self.spline.clone(),
            last: self.last.clone(),
            extras: self.extras.clone(),
            kept: self.kept.clone(),
        }
    }

    fn __copy__(&self) -> Deformation {
        self.copy()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyDict>) -> Deformation {
        self.copy()
    }

    /// Pickling (for `copy`, `multiprocessing`, Dask workers): the deformation file's text,
    /// exact, so the unpickled deformation warps bit for bit alike.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let f = py.import("trimorph")?.getattr("_deformation_from_json")?;
        Ok((f, (self.to_json(),)))
    }

    fn __repr__(&self) -> String {
        let (lo, hi) = self.spline.mesh().bbox();
        format!(
            "Deformation(degree={}, vertices={}, triangles={}, control_points={}, bbox=(({}, {}), ({}, {})))",
            self.spline.degree(),
            self.spline.mesh().num_vertices(),
            self.spline.mesh().num_triangles(),
            self.spline.num_points(),
            lo[0],
            lo[1],
            hi[0],
            hi[1]
        )
    }
}
