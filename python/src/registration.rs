//! `trimorph.register`: registration from the images themselves (`trimorph register`).

use crate::arrays::{numpy_to_image, points_in, PointOrder};
use crate::deformation::Deformation;
use crate::errors::value_error;
use crate::values::landmarks_of;
use crate::watch::{CancelToken, Watch};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::atomic::Ordering::Relaxed;
use trimorph::register::image::{Channel, Mask};
use trimorph::register::samples::SampleOptions;
use trimorph::register::{register as register_on, Input, Metric, Prealign, RegisterOptions};
use trimorph::spline::ImageFrame;

fn input(
    py: Python<'_>,
    image: &Bound<'_, PyAny>,
    mask: Option<&Bound<'_, PyAny>>,
    name: &str,
) -> PyResult<Input> {
    let (img, _) = numpy_to_image(py, image, name)?;
    let channel = Channel::from_image(&img, std::path::Path::new(name)).map_err(value_error)?;
    let mask = match mask {
        Some(m) => {
            let what = format!("mask_{name}");
            let (mimg, _) = numpy_to_image(py, m, &what)?;
            Some((Mask::from_image(&mimg), PathBuf::from(what)))
        }
        None => None,
    };
    Ok(Input { image: channel, name: PathBuf::from(name), mask })
}

/// Registers `moving` to `fixed` (numpy arrays, 2D grey or (h, w, c) colour, any dtype
/// trimorph reads; different sizes allowed) like `trimorph register`: returns the
/// Deformation phi mapping MOVING pixels to FIXED pixels (so `phi.warp(moving)` resamples
/// MOVING onto FIXED), exactly C1 and certified fold-free; its `report` holds the
/// registration report. `metric` is "ncc", "ssd" or "mi"; `src`/`dst` add landmarks
/// (MOVING -> FIXED; `hard=True` meets them exactly); `init` starts from a deformation
/// whose pinned points stay pinned. `order` is the columns' order of `src` and `dst`:
/// "xy" (x, y) or "rc" (row, col), as in `fit`. `bend` is relative to the metric, as
/// `--bend` (mi multiplies it by 1000). `mesh_levels` and `refine_share` are those of
/// `--mesh-levels` and `--refine-share` (the mesh pyramid; default 3 levels). Releases the GIL.
#[pyfunction]
#[pyo3(signature = (fixed, moving, metric = "ncc", mask_fixed = None, mask_moving = None,
    src = None, dst = None, weights = None, hard = false, landmark_weight = 0.25, init = None,
    prealign = "affine", levels = None, spacing = 48.0, bend = 1.0, iterations = 30,
    samples = 32768, order = "xy", progress = None, cancel = None, mesh_levels = None,
    refine_share = 1.0))]
#[allow(clippy::too_many_arguments)]
pub fn register<'py>(
    py: Python<'py>,
    fixed: &Bound<'py, PyAny>,
    moving: &Bound<'py, PyAny>,
    metric: &str,
    mask_fixed: Option<&Bound<'_, PyAny>>,
    mask_moving: Option<&Bound<'_, PyAny>>,
    src: Option<&Bound<'_, PyAny>>,
    dst: Option<&Bound<'_, PyAny>>,
    weights: Option<Vec<f64>>,
    hard: bool,
    landmark_weight: f64,
    init: Option<PyRef<'_, Deformation>>,
    prealign: &str,
    levels: Option<u32>,
    spacing: f64,
    bend: f64,
    iterations: u64,
    samples: usize,
    order: &str,
    progress: Option<Bound<'py, PyAny>>,
    cancel: Option<&Bound<'py, CancelToken>>,
    mesh_levels: Option<u32>,
    refine_share: f64,
) -> PyResult<Deformation> {
    let watch = Watch::new(progress, cancel)?;
    let order = PointOrder::parse(order)?;
    let metric: Metric = metric.parse().map_err(value_error)?;
    let prealign: Prealign = prealign.parse().map_err(value_error)?;
    let f = input(py, fixed, mask_fixed, "fixed")?;
    let m = input(py, moving, mask_moving, "moving")?;
    let landmarks = match (src, dst) {
        (Some(s), Some(d)) => {
            let (s, d) = (points_in(py, s, "src", order)?, points_in(py, d, "dst", order)?);
            landmarks_of(&s, &d, weights, None)?
        }
        (None, None) => Vec::new(),
        _ => {
            return Err(value_error(
                "give both src and dst (landmarks MOVING -> FIXED), or neither",
            ))
        }
    };
    if hard && landmarks.is_empty() {
        return Err(value_error("hard=True needs landmarks (src and dst)"));
    }
    let (init_spline, pinned) = match init {
        Some(d) => {
            let pinned = match d.kept.get("pinned") {
                Some(v) => trimorph::io::deformation::pinned_from_str(
                    &serde_json::json!({ "pinned": v }).to_string(),
                )
                .map_err(value_error)?,
                None => Vec::new(),
            };
            (Some(d.spline.clone()), pinned)
        }
        None => (None, Vec::new()),
    };
    let opts = RegisterOptions {
        metric,
        levels,
        prealign,
        spacing,
        mesh_levels,
        refine_share,
        bend,
        max_iters: iterations,
        samples: SampleOptions { max_samples: samples },
        landmarks,
        landmark_weight,
        hard,
        init: init_spline,
        pinned,
        ..RegisterOptions::default()
    };
    // Progress counts optimizer iterations against their caps: per level the affine
    // pre-alignment's (without `init`, unless `prealign="none"`) and the spline's.
    let nl = opts.level_count(&f, &m) as u64;
    let affine =
        if opts.init.is_none() && opts.prealign != Prealign::None { opts.affine_iters } else { 0 };
    let total = nl * (affine + opts.max_iters);
    let r = watch
        .run(py, total, |sh| {
            let done = sh.counter();
            let tick: trimorph::register::Progress =
                std::sync::Arc::new(move |_: &str, _: u64, _: f64| {
                    // One more iteration, never past the caps' sum.
                    let _ = done.fetch_update(Relaxed, Relaxed, |n| Some((n + 1).min(total)));
                });
            let opts = RegisterOptions { progress: Some(tick), cancel: sh.cancel.clone(), ..opts };
            register_on(&f, &m, &opts)
        })?
        .map_err(value_error)?;
    let mut spline = r.spline;
    let frame = ImageFrame::new([f.image.w as f64, f.image.h as f64]).map_err(value_error)?;
    spline.set_frame(Some(frame));
    let report = serde_json::to_value(&r.report).map_err(value_error)?;
    let mut d = Deformation::new(spline);
    d.set_report(report);
    Ok(d)
}
