//! `trimorph.fit` and `trimorph.morph`: the library's landmark fit and image morph.
//!
//! `fit(src, dst, size=(w, h))` is `trimorph fit --size W,H` (a mesh adapted to the
//! landmarks, covering the frame, certified fold-free with the barrier on); with
//! `deformation=d` it is `trimorph fit DEF` (a fit on `d`'s mesh). The report is the same
//! JSON the command line writes with `--report`, as a dict.

use crate::arrays::{image_to_numpy, numpy_to_image, points_in, PointOrder};
use crate::deformation::Deformation;
use crate::errors::{unsolvable, value_error, variant_name};
use crate::values::landmarks_of;
use crate::watch::{CancelToken, Shared, Watch};
use pyo3::prelude::*;
use pyo3::types::PyList;
use trimorph::fit::frame::{fit_frame, FrameFitOptions};
use trimorph::fit::objective::{Barrier, Loss};
use trimorph::fit::{fit as fit_on, with_holdout, Bend, BendError, FitError, FitOptions};
use trimorph::jobs::morph_inputs::MorphSettings;
use trimorph::mesh::AdaptOptions;
use trimorph::morph::{times_between, Morph, MorphError, Schedule};
use trimorph::warp::Interp;

/// A fit error as the right Python exception.
pub fn fit_exc(py: Python<'_>, e: FitError) -> PyErr {
    if e.is_unsolvable() {
        unsolvable(py, &variant_name(&e), e)
    } else {
        match e {
            FitError::Internal(_) => crate::errors::TrimorphError::new_err(e.to_string()),
            other => value_error(other),
        }
    }
}

/// The keyword `bend`: "auto" or a weight >= 0 (`None` when not given).
fn bend_of(bend: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Bend>> {
    let Some(b) = bend else { return Ok(None) };
    match b.extract::<f64>() {
        Ok(w) => w.to_string().parse(),
        Err(_) => b.extract::<String>()?.parse(),
    }
    .map(Some)
    .map_err(|e: BendError| value_error(format!("bend: {e}")))
}

/// The library's fit options from the keywords of `fit` (and of `FrameSequence`): `loss`
/// "squares", "huber" or "cauchy" (scale `loss_scale` px), `bend` "auto" or a weight >= 0,
/// the fold barrier with floor `min_det` when `barrier`. The same options as `trimorph fit`'s
/// `--loss --loss-scale --bend --hard --no-barrier --min-det --max-iters --radius`.
pub fn fit_options(
    loss: &str,
    loss_scale: f64,
    bend: Option<&Bound<'_, PyAny>>,
    hard: bool,
    barrier: bool,
    min_det: f64,
    max_iters: u64,
    radius: Option<usize>,
) -> PyResult<FitOptions> {
    let bend = bend_of(bend)?.unwrap_or(Bend::Auto);
    Ok(FitOptions {
        loss: Loss::from_name(loss, loss_scale).map_err(|e| value_error(format!("loss: {e}")))?,
        bend,
        barrier: if barrier {
            Some(Barrier::with_floor(min_det).map_err(|e| value_error(format!("min_det: {e}")))?)
        } else {
            None
        },
        radius,
        max_iters,
        hard,
        ..FitOptions::default()
    })
}

/// Fits a deformation to landmarks `src -> dst` ((n, 2) pixel arrays).
///
/// Without `deformation`, the mesh is adapted to the landmarks over a frame of
/// `size = (w, h)` pixels and the fit covers the whole frame (`trimorph fit --size`); with
/// it, the fit runs on that deformation's mesh. `loss` is "squares", "huber" or "cauchy"
/// (scale `loss_scale` px), `bend` "auto" (leave-one-out cross-validation) or a weight >= 0,
/// `hard=True` makes every landmark an exact constraint, `barrier` keeps det J above
/// `min_det`. `far_rings` (with `size`) adds far-field rings around the adapted mesh
/// (`trimorph fit --far-rings`, default 2). `order` is the columns' order of `src` and
/// `dst`: "xy" (x, y), trimorph's, or "rc" (row, col), napari's and scikit-image's; `size`
/// is `(w, h)` either way. Returns a Deformation whose `report` holds the fit report.
/// Releases the GIL. `progress(done, total)` is called with `(1, 1)` when the fit is done;
/// `cancel` takes a `trimorph.CancelToken`. Ctrl-C, an exception from `progress`, or a
/// cancelled token (`trimorph.Cancelled`) stops the fit between Newton iterations.
// The signatures spell the defaults as literals so that `inspect.signature` shows them (a
// path shows as `...`); these keep them the library's (`fit::options`, the one source).
const _: () = assert!(trimorph::fit::frame::FAR_RINGS == 2);
const _: () = assert!(trimorph::fit::options::DEFAULT_LOSS_SCALE == 2.0);
const _: () = assert!(trimorph::fit::options::DEFAULT_MIN_DET == 0.1);
const _: () = assert!(trimorph::fit::options::DEFAULT_MAX_ITERS == 200);

#[pyfunction]
#[pyo3(signature = (src, dst, size = None, weights = None, names = None, loss = "squares",
    loss_scale = 2.0, bend = None, hard = false, barrier = true, min_det = 0.1, max_iters = 200,
    radius = None, margin = None, max_edge = None, min_angle = 15.0, deformation = None,
    far_rings = 2, order = "xy", progress = None, cancel = None))]
pub fn fit<'py>(
    py: Python<'py>,
    src: &Bound<'py, PyAny>,
    dst: &Bound<'py, PyAny>,
    size: Option<(f64, f64)>,
    weights: Option<Vec<f64>>,
    names: Option<Vec<String>>,
    loss: &str,
    loss_scale: f64,
    bend: Option<&Bound<'_, PyAny>>,
    hard: bool,
    barrier: bool,
    min_det: f64,
    max_iters: u64,
    radius: Option<usize>,
    margin: Option<f64>,
    max_edge: Option<f64>,
    min_angle: f64,
    deformation: Option<PyRef<'_, Deformation>>,
    far_rings: usize,
    order: &str,
    progress: Option<Bound<'py, PyAny>>,
    cancel: Option<&Bound<'py, CancelToken>>,
) -> PyResult<Deformation> {
    let order = PointOrder::parse(order)?;
    let (s, d) = (points_in(py, src, "src", order)?, points_in(py, dst, "dst", order)?);
    let lms = landmarks_of(&s, &d, weights, names)?;
    let opts = fit_options(loss, loss_scale, bend, hard, barrier, min_det, max_iters, radius)?;
    let watch = Watch::new(progress, cancel)?;
    let with_cancel = |sh: &Shared| FitOptions { cancel: sh.cancel.clone(), ..opts.clone() };
    match (deformation, size) {
        (Some(def), _) => {
            let spline = def.spline.clone();
            drop(def);
            let f = watch
                .run(py, 1, |sh| fit_on(&spline, &lms, &with_cancel(sh)))?
                .and_then(|f| {
                    let rep = with_holdout(f.report, &f.spline, &[])?;
                    Ok((f.spline, rep))
                })
                .map_err(|e| fit_exc(py, e))?;
            let report = serde_json::to_value(&f.1).map_err(value_error)?;
            let mut d = Deformation::new(f.0);
            d.set_report(report);
            d.set_landmarks(&lms);
            Ok(d)
        }
        (None, Some(size)) => {
            let size = [size.0, size.1];
            let fopts = FrameFitOptions {
                mesh: AdaptOptions {
                    margin,
                    max_edge,
                    min_angle,
                    grid: 0,
                    extra_points: Vec::new(),
                    far_rings,
                },
                degree: 5,
                fit: opts.clone(),
            };
            let r = watch
                .run(py, 1, |sh| {
                    fit_frame(&lms, size, &FrameFitOptions { fit: with_cancel(sh), ..fopts.clone() })
                })?
                .map_err(|e| fit_exc(py, e))?;
            let rep = with_holdout(r.fit.report, &r.fit.spline, &[]).map_err(|e| fit_exc(py, e))?;
            let mut v = serde_json::to_value(&rep).map_err(value_error)?;
            v["frame"] = serde_json::to_value(&r.frame).map_err(value_error)?;
            let mut d = Deformation::new(r.fit.spline);
            d.set_report(v);
            d.set_landmarks(&lms);
            Ok(d)
        }
        (None, None) => Err(value_error(
            "give size=(w, h) (the frame the landmarks live in) or deformation=d (a mesh to fit on)",
        )),
    }
}

fn morph_exc(py: Python<'_>, e: MorphError) -> PyErr {
    match e {
        MorphError::Fit { source, .. } if source.is_unsolvable() => {
            unsolvable(py, &variant_name(&source), source)
        }
        other => value_error(other),
    }
}

/// Morphs image `a` into image `b` (numpy arrays; the sizes and dtypes may differ) through
/// landmarks `src` (in `a`'s pixels) -> `dst` (in `b`'s pixels), like `trimorph morph`:
/// `b` is first brought into `a`'s frame by the landmarks' similarity (`align=True`), the
/// two maps are fitted fold-free, and `frames` images at `t = 0 .. 1` are returned as a list
/// of arrays of `a`'s frame and the morph's working type. Both maps interpolate the
/// landmarks unless `bend` ("auto" or a weight, as in `fit`) smooths them; `hard` meets them
/// exactly; `pin_frame` keeps `a`'s frame border still; `mode` ("constant", "edge",
/// "reflect") says what shows where neither image has a preimage on its pixels
/// (`--bend --hard --pin-frame --mode`). `order` is the columns' order of `src` and `dst`
/// ("xy" or "rc", as in `fit`). Releases the GIL.
#[pyfunction]
#[pyo3(signature = (a, b, src, dst, frames = 11, shape = "linear", color = "linear",
    interp = "bilinear", align = true, background = 0.0, t0 = 0.0, t1 = 1.0, bend = None,
    hard = false, pin_frame = false, mode = "constant", order = "xy"))]
#[allow(clippy::too_many_arguments)]
pub fn morph<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    src: &Bound<'py, PyAny>,
    dst: &Bound<'py, PyAny>,
    frames: usize,
    shape: &str,
    color: &str,
    interp: &str,
    align: bool,
    background: f64,
    t0: f64,
    t1: f64,
    bend: Option<&Bound<'py, PyAny>>,
    hard: bool,
    pin_frame: bool,
    mode: &str,
    order: &str,
) -> PyResult<Bound<'py, PyList>> {
    let (img_a, gray_a) = numpy_to_image(py, a, "a")?;
    let (img_b, gray_b) = numpy_to_image(py, b, "b")?;
    let order = PointOrder::parse(order)?;
    let (s, d) = (points_in(py, src, "src", order)?, points_in(py, dst, "dst", order)?);
    let lms = landmarks_of(&s, &d, None, None)?;
    if frames < 2 {
        return Err(value_error(format!("frames must be at least 2, got {frames}")));
    }
    // The options as `trimorph morph` builds them (`MorphSettings`, the morph's own default
    // bending weight, interpolation, unless `bend` is given). `background`: the library's
    // rule (a sample of the working type, checked before the fits;
    // `trimorph::morph::check_background`), as for `trimorph morph --background`.
    let opts = MorphSettings {
        shape: shape.parse::<Schedule>().map_err(|e| value_error(format!("shape: {e}")))?,
        color: color.parse::<Schedule>().map_err(|e| value_error(format!("color: {e}")))?,
        interp: interp.parse::<Interp>().map_err(value_error)?,
        align,
        background,
        pin_frame,
        mode: mode.parse().map_err(|e| value_error(format!("mode: {e}")))?,
        bend: bend_of(bend)?,
        hard,
        ..MorphSettings::default()
    }
    .options();
    let times = times_between(frames, t0, t1).map_err(value_error)?;
    let out = py
        .detach(|| {
            let m = Morph::new(&img_a, &img_b, &lms, &opts)?;
            m.frames_at(&times, &|| {})
        })
        .map_err(|e| morph_exc(py, e))?;
    let gray = gray_a && gray_b;
    let arrays: Vec<Bound<'py, PyAny>> =
        out.iter().map(|f| image_to_numpy(py, f, gray)).collect::<PyResult<_>>()?;
    PyList::new(py, arrays)
}
