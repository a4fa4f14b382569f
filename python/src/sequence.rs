//! `trimorph.FrameSequence`: one scene fitted to the frames of a sequence, one frame per
//! call, for task graphs (`trimorph.dask.fit_frames`) and array jobs.
//!
//! `FrameSequence(model, frames, landmarks, out_dir, **options)` reads what
//! `trimorph fit --model MODEL --frames FRAMES --landmarks LANDMARKS -o OUT_DIR` reads
//! ([`trimorph::jobs::sequence::SequenceInputs`]), and `run_frame(k)` is
//! [`trimorph::fit::sequence::Sequence::run_frame`] on the command line's file store
//! ([`trimorph::jobs::sequence::FrameFiles`]): it writes exactly the files `fit --frames`
//! writes for frame `k` (each atomically, the report last), or skips the frame when its
//! stored report's resume key is current. The fit of frame `k` changes the scene `phi` so
//! that the landmark sources (reference pixels) land on their targets (frame pixels); see
//! the library's `fit::sequence` docs for targets, tracking, hold-out and resume.
//!
//! A tracked sequence (`track=True`) warm-starts frame `k` from the stored result of frame
//! `k - 1`, so its frames must run in order to equal the command line; other frames are
//! independent. Pickling rebuilds the object from its arguments (paths made absolute), so it
//! can be sent to other processes.

use crate::errors::{io_error, unsolvable, value_error, variant_name};
use crate::fitting::fit_options;
use crate::values::to_dict;
use pyo3::exceptions::{PyIndexError, PyOSError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::{Path, PathBuf};
use trimorph::fit::sequence::{choose_anchor, AnchorChoiceError, AnchorKind};
use trimorph::fit::sequence::{Action, SequenceError};
use trimorph::fit::FitOptions;
use trimorph::jobs::sequence::{SceneSource, SequenceInputs, SequenceInputsError};
use trimorph::mesh::AdaptOptions;

/// A sequence's input error as a Python exception: unreadable files `OSError`, the rest
/// `ValueError` (the library's message names the file and the element).
fn inputs_exc(e: SequenceInputsError) -> PyErr {
    match e {
        SequenceInputsError::SceneIo(io) => io_error(&io),
        e @ SequenceInputsError::ModelFile { .. } => PyOSError::new_err(e.to_string()),
        e => value_error(e),
    }
}

/// A sequence error as a Python exception: unsolvable hard fits `UnsolvableError`, a store
/// that cannot write `OSError`, a frame index out of range `IndexError`, the rest
/// `ValueError`.
fn sequence_exc(py: Python<'_>, e: SequenceError) -> PyErr {
    match &e {
        SequenceError::Fit { source, .. } if source.is_unsolvable() => {
            unsolvable(py, &variant_name(source), &e)
        }
        SequenceError::Store { .. } => PyOSError::new_err(e.to_string()),
        SequenceError::FrameIndex { .. } => PyIndexError::new_err(e.to_string()),
        _ => value_error(e),
    }
}

/// An absolute path (so that a pickled sequence means the same files in another process).
fn absolute(p: PathBuf) -> PyResult<PathBuf> {
    std::path::absolute(&p)
        .map_err(|e| PyOSError::new_err(format!("cannot resolve {}: {e}", p.display())))
}

/// One scene fitted to every frame of a sequence, one frame at a time: the per-frame work of
/// `trimorph fit --model MODEL --frames FRAMES --landmarks LANDMARKS -o OUT_DIR`.
#[pyclass(module = "trimorph._trimorph")]
pub struct FrameSequence {
    inputs: SequenceInputs,
    fit: FitOptions,
    holdout: usize,
    seed: u64,
    out: PathBuf,
    /// The scene's path (absolute), or None for a 2D scene made from the landmarks.
    model: Option<PathBuf>,
    /// The other positional arguments (absolute paths: frames, landmarks, out_dir), for
    /// pickling.
    paths: [PathBuf; 3],
    /// The keyword arguments as given, for pickling.
    kwargs: Py<PyDict>,
}

#[pymethods]
impl FrameSequence {
    /// Reads the scene `model` (a deformation JSON, usually from `trimorph model bind`), its
    /// model (`model_file`, else the scene's "model" key), the frames (a folder of images or
    /// a multi-page TIFF) and the landmarks (a file: targets in the first frame, tracked with
    /// `track=True`; a folder: one `<frame>.csv`/`.json` per frame), as `trimorph fit
    /// --frames` does. The keywords are its options: `track`, `anchor` ("chain", "first",
    /// "keyframes"), `key_every`, `holdout`, `seed`, `background`, `loss`, `loss_scale`,
    /// `bend`, `hard`, `barrier` (False is `--no-barrier`), `min_det`, `max_iters`, `radius`.
    /// Bad input raises ValueError naming the file; unreadable files OSError.
    #[new]
    #[pyo3(signature = (model, frames, landmarks, out_dir, *, size = None, track = false, anchor = None,
        key_every = None, holdout = 0, seed = 1, background = 0.0, model_file = None,
        loss = "squares", loss_scale = 2.0, bend = None, hard = false, barrier = true,
        min_det = 0.1, max_iters = 200, radius = None))]
    fn new(
        py: Python<'_>,
        model: Option<PathBuf>,
        frames: PathBuf,
        landmarks: PathBuf,
        out_dir: PathBuf,
        size: Option<(f64, f64)>,
        track: bool,
        anchor: Option<String>,
        key_every: Option<usize>,
        holdout: usize,
        seed: u64,
        background: f64,
        model_file: Option<PathBuf>,
        loss: &str,
        loss_scale: f64,
        bend: Option<Bound<'_, PyAny>>,
        hard: bool,
        barrier: bool,
        min_det: f64,
        max_iters: u64,
        radius: Option<usize>,
    ) -> PyResult<FrameSequence> {
        let model = model.map(absolute).transpose()?;
        let paths = [absolute(frames)?, absolute(landmarks)?, absolute(out_dir)?];
        // Missing inputs are FileNotFoundError, as documented, before any other check of
        // the arguments (a missing folder with no scene and no size named the scene).
        for (what, p) in [
            ("scene", model.as_deref()),
            ("frames", Some(&*paths[0])),
            ("landmarks", Some(&*paths[1])),
        ] {
            if let Some(p) = p.filter(|p| !p.exists()) {
                return Err(pyo3::exceptions::PyFileNotFoundError::new_err(format!(
                    "{what} {} does not exist",
                    p.display()
                )));
            }
        }
        let kwargs = PyDict::new(py);
        kwargs.set_item("size", size)?;
        kwargs.set_item("track", track)?;
        kwargs.set_item("anchor", &anchor)?;
        kwargs.set_item("key_every", key_every)?;
        kwargs.set_item("holdout", holdout)?;
        kwargs.set_item("seed", seed)?;
        kwargs.set_item("background", background)?;
        let model_file = model_file.map(absolute).transpose()?;
        kwargs.set_item("model_file", &model_file)?;
        kwargs.set_item("loss", loss)?;
        kwargs.set_item("loss_scale", loss_scale)?;
        kwargs.set_item("bend", &bend)?;
        kwargs.set_item("hard", hard)?;
        kwargs.set_item("barrier", barrier)?;
        kwargs.set_item("min_det", min_det)?;
        kwargs.set_item("max_iters", max_iters)?;
        kwargs.set_item("radius", radius)?;
        let fit = fit_options(
            loss,
            loss_scale,
            bend.as_ref(),
            hard,
            barrier,
            min_det,
            max_iters,
            radius,
        )?;
        let anchor = anchor
            .as_deref()
            .map(str::parse::<AnchorKind>)
            .transpose()
            .map_err(AnchorChoiceError::from)
            .and_then(|kind| choose_anchor(track, kind, key_every))
            .map_err(value_error)?;
        let scene = match (&model, size) {
            (Some(m), None) => SceneSource::File(m.clone()),
            (None, Some((w, h))) => SceneSource::Landmarks {
                size: [w, h],
                adapt: AdaptOptions {
                    far_rings: trimorph::fit::frame::FAR_RINGS,
                    ..AdaptOptions::default()
                },
                degree: 5,
            },
            _ => {
                return Err(value_error(
                    "give the scene (model=SCENE.json, or any 2D deformation) or size=(w, h) \
                     (a 2D scene over a mesh adapted to the landmarks), not both",
                ))
            }
        };
        let inputs = py
            .detach(|| {
                SequenceInputs::load(
                    &scene,
                    model_file.as_deref(),
                    &paths[0],
                    &paths[1],
                    anchor,
                    background,
                )
            })
            .map_err(|e| inputs_exc(*e))?;
        // The checks of the sequence itself (a hold-out that leaves landmarks to fit, ...).
        inputs.sequence(fit.clone(), holdout, seed, None).map_err(|e| sequence_exc(py, e))?;
        Ok(FrameSequence {
            inputs,
            fit,
            holdout,
            seed,
            out: paths[2].clone(),
            model,
            paths,
            kwargs: kwargs.unbind(),
        })
    }

    /// Number of frames.
    fn __len__(&self) -> usize {
        self.inputs.frames.len()
    }

    /// The frames' names, in order (each frame's outputs are `<name>.json`, ...).
    #[getter]
    fn names(&self) -> Vec<String> {
        self.inputs.frames.iter().map(|f| f.name.clone()).collect()
    }

    /// Whether the landmarks are tracked (frame `k` then warm-starts from frame `k - 1`'s
    /// stored result, so frames must run in order).
    #[getter]
    fn tracked(&self) -> bool {
        self.inputs.anchor().is_some()
    }

    /// The output folder (absolute).
    #[getter]
    fn out_dir(&self) -> PathBuf {
        self.out.clone()
    }

    /// Fits frame `k` and writes its files into `out_dir` (those of `trimorph fit --frames`,
    /// each atomically, the report last), or skips it when its stored results are current.
    /// Returns the frame's report (the `<name>.report.json` dict) with `status` ("fitted" or
    /// "skipped") and `reason` (why it was fitted; None when skipped). Releases the GIL.
    fn run_frame(&self, py: Python<'_>, k: usize) -> PyResult<Py<PyAny>> {
        let (action, report) = py
            .detach(|| -> Result<_, SequenceError> {
                let store_err = |source| SequenceError::Store {
                    index: k,
                    name: self.inputs.frames.get(k).map(|f| f.name.clone()).unwrap_or_default(),
                    source,
                };
                if k < self.inputs.frames.len() {
                    std::fs::create_dir_all(&self.out).map_err(|e| store_err(Box::new(e)))?;
                }
                let seq = self.inputs.sequence(self.fit.clone(), self.holdout, self.seed, None)?;
                let files = self.inputs.files(&self.out);
                let o = seq.run_frame(k, &files, &|_| {})?;
                use trimorph::fit::sequence::Store;
                let stored = files.stored(k, &self.inputs.frames[k]).map_err(store_err)?;
                Ok((o.action, stored.report))
            })
            .map_err(|e| sequence_exc(py, e))?;
        let missing = || {
            PyOSError::new_err(format!(
                "frame {k}: no report in {} after the fit",
                self.out.display()
            ))
        };
        let mut report = report
            .and_then(|r| serde_json::from_str::<serde_json::Value>(r.text()).ok())
            .filter(|v| v.is_object())
            .ok_or_else(missing)?;
        let (status, reason) = match action {
            Action::Skipped => ("skipped", serde_json::Value::Null),
            Action::Fitted(r) => ("fitted", r.to_string().into()),
        };
        report["status"] = status.into();
        report["reason"] = reason;
        to_dict(py, &report)
    }

    /// Pickles as `functools.partial(FrameSequence, **options)(model, frames, landmarks,
    /// out_dir)`: the receiver reads the inputs again.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let py = slf.py();
        let me = slf.borrow();
        let partial = py.import("functools")?.getattr("partial")?;
        let make = partial.call((slf.get_type(),), Some(me.kwargs.bind(py)))?;
        let model = me.model.as_ref().map(|p| p.as_path().into_pyobject(py)).transpose()?;
        let model = match model {
            Some(m) => m.into_any(),
            None => py.None().into_bound(py),
        };
        let mut args = vec![model];
        for p in &me.paths {
            args.push(p.as_path().into_pyobject(py)?.into_any());
        }
        let args = PyTuple::new(py, args)?;
        Ok((make, args))
    }

    fn __repr__(&self) -> String {
        let show = |p: &Path| p.display().to_string();
        format!(
            "FrameSequence({} frames of {}, scene {}, landmarks {}{}, out {})",
            self.inputs.frames.len(),
            show(&self.paths[0]),
            self.model.as_deref().map_or("made from the landmarks".to_string(), show),
            show(&self.paths[1]),
            if self.tracked() { ", tracked" } else { "" },
            show(&self.out)
        )
    }
}
