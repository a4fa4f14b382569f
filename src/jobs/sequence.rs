//! The files of a sequence fit ([`crate::fit::sequence`]): a [`Store`] that keeps every
//! frame's results in one folder, so that a rerun (or another shard, or a single-frame task
//! of [`crate::fit::sequence::Sequence::run_frame`]) resumes where the last one stopped.
//!
//! Per frame `<stem>` (the frame's name): `<stem>.json` (the fitted deformation),
//! `<stem>.registered.png` (the frame pulled back onto the reference through `phi`,
//! bilinear, in the frame's type and channels, the background value where `phi` leaves the
//! frame; `.registered.tif` for float frames), `<stem>.obj` (the deformed model, when there
//! is one), `<stem>.overlay.png` (frame, model outline, landmarks) and `<stem>.report.json`,
//! written last: a frame counts as done only once its report exists. Every file is written
//! to a temporary file and renamed ([`crate::io::write_atomic`]).
//!
//! [`SequenceInputs`] reads everything `trimorph fit --model SCENE --frames F --landmarks L`
//! reads (the scene, its model bound to it, the frames, every frame's targets and the
//! resume-key entries the files depend on), so that the command line and the Python
//! bindings (`trimorph.FrameSequence`) fit and write exactly the same.

use crate::fit::sequence::{
    check_names, content_hash, Anchor, Frame, FrameResult, Sequence, SequenceError,
    SequenceOptions, Store, StoreError, Stored, StoredReport, Targets,
};
use crate::fit::track::TrackOptions;
use crate::fit::FitOptions;
use crate::io::deformation::DeformationError;
use crate::io::frames::{read_frames, read_targets, scene_model, FramesError, InputsError};
use crate::io::model::{save_model, ModelIoError, UpAxis};
use crate::io::raster::{write_stack, RasterError, Stack};
use crate::io::{deformation, read_text, write_atomic, IoError};
use crate::prism::{bind, deform, Binding, Model, PrismError};
use crate::render::deformation::{save_png, RenderError};
use crate::render::overlay::{overlay, silhouette, Mark};
use crate::spline::Spline;
use crate::warp::pullback::pull_back;
use crate::warp::{Interp, WarpError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Why a frame's files could not be written.
#[derive(Debug, thiserror::Error)]
pub enum FrameFilesError {
    /// Writing a file.
    #[error(transparent)]
    Io(#[from] IoError),
    /// Pulling the frame back.
    #[error(transparent)]
    Warp(#[from] WarpError),
    /// Encoding the registered frame.
    #[error(transparent)]
    Raster(#[from] RasterError),
    /// Writing the deformed model.
    #[error(transparent)]
    Model(#[from] ModelIoError),
    /// Writing the overlay.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// A frame with no pixels.
    #[error("empty frame")]
    EmptyFrame,
    /// Encoding the report.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}

/// The folder of a sequence fit's outputs; see the module docs.
pub struct FrameFiles<'a> {
    /// The folder.
    pub out: &'a Path,
    /// The model carried along (its file, the model and its binding to the scene).
    pub model: Option<&'a (PathBuf, Model, Binding, UpAxis)>,
    /// Per frame, whether it is float gray (held as RGB float, written back as gray).
    pub gray_float: &'a [bool],
    /// The registered frames' value where `phi` leaves the frame (sample units).
    pub background: f64,
}

impl FrameFiles<'_> {
    fn path(&self, stem: &str, ext: &str) -> PathBuf {
        self.out.join(format!("{stem}.{ext}"))
    }

    /// The registered frame's file (`.tif` for float frames).
    pub fn registered(&self, index: usize, frame: &Frame) -> PathBuf {
        registered_file(self.out, frame, self.gray_float[index])
    }

    /// Every output of a frame except the report.
    pub fn outputs(&self, index: usize, frame: &Frame) -> Vec<PathBuf> {
        let mut v = vec![
            self.path(&frame.name, "json"),
            self.registered(index, frame),
            self.path(&frame.name, "overlay.png"),
        ];
        if self.model.is_some() {
            v.push(self.path(&frame.name, "obj"));
        }
        v
    }

    /// Writes a frame's files, the report last.
    pub fn write(&self, r: &FrameResult, frame: &Frame) -> Result<(), FrameFilesError> {
        let stem = &frame.name;
        let s = &r.spline;
        let text = deformation::to_string_with_landmarks(s, &r.landmarks);
        write_atomic(&self.path(stem, "json"), text.as_bytes())?;
        let (w, h) = (frame.image.width(), frame.image.height());
        let reg = pull_back(s, &frame.image, w, h, Interp::Bilinear, self.background)?;
        let stack = Stack { pages: vec![reg], gray_float: self.gray_float[r.index] };
        write_stack(&self.registered(r.index, frame), &stack)?;
        let mut outline = Vec::new();
        if let Some((_, m, b, up)) = self.model {
            let moved = deform(m, b, s);
            // In the model file's axes.
            let file: Vec<[f64; 3]> = moved.iter().map(|&v| up.from_z_up(v)).collect();
            save_model(m, &file, &self.path(stem, "obj"))?;
            outline = silhouette(&moved, &m.triangles);
        }
        let marks: Vec<Mark> =
            r.report.residuals.iter().map(|x| Mark { mapped: x.mapped, target: x.dst }).collect();
        let ov = overlay(frame.gray().as_raw(), w, h, &outline, &marks)
            .ok_or(FrameFilesError::EmptyFrame)?;
        save_png(&ov, &self.path(stem, "overlay.png"))?;
        write_atomic(&self.path(stem, "report.json"), r.report_text().as_bytes())?;
        Ok(())
    }
}

/// `<stem>.registered.png` in `out`, or `.registered.tif` for a float frame (float gray
/// held as RGB float when `gray_float`), for sequence fits and registrations alike.
pub(crate) fn registered_file(out: &Path, frame: &Frame, gray_float: bool) -> PathBuf {
    let float = matches!(
        frame.image,
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)
    ) || gray_float;
    out.join(format!("{}.{}", frame.name, if float { "registered.tif" } else { "registered.png" }))
}

/// What a frame folder holds for frame `stem`: its `report.json` text, the names of the
/// `outputs` that are missing, and its deformation (`<stem>.json`) when it reads.
pub(crate) fn stored_files(
    out: &Path,
    stem: &str,
    outputs: &[PathBuf],
) -> (Option<String>, Vec<String>, Option<Spline>) {
    let report = read_text(&out.join(format!("{stem}.report.json"))).ok();
    let missing = outputs
        .iter()
        .filter(|p| !p.exists())
        .map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())
        .collect();
    let spline = read_text(&out.join(format!("{stem}.json")))
        .ok()
        .and_then(|t| deformation::from_str(&t).ok())
        .map(|(s, _)| s);
    (report, missing, spline)
}

impl Store for FrameFiles<'_> {
    fn stored(&self, index: usize, frame: &Frame) -> Result<Stored, StoreError> {
        let (report, missing, spline) =
            stored_files(self.out, &frame.name, &self.outputs(index, frame));
        Ok(Stored { report: report.map(StoredReport::new), missing, spline })
    }

    fn save(&self, result: &FrameResult, frame: &Frame) -> Result<(), StoreError> {
        self.write(result, frame).map_err(Into::into)
    }
}

/// Why the inputs of a sequence fit could not be read.
#[derive(Debug, thiserror::Error)]
pub enum SequenceInputsError {
    /// A background that is not a number.
    #[error("--background must be a finite number (sample units), got {0}")]
    Background(f64),
    /// The scene file cannot be read.
    #[error(transparent)]
    SceneIo(IoError),
    /// The scene is not a deformation.
    #[error("cannot read scene {}: {source}", path.display())]
    Scene {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: DeformationError,
    },
    /// The model does not fit the scene.
    #[error("cannot bind model {}: {source}", path.display())]
    Bind {
        /// The model file.
        path: PathBuf,
        /// The cause.
        source: PrismError,
    },
    /// The model file cannot be read (for its hash).
    #[error("cannot read model {}: {source}", path.display())]
    ModelFile {
        /// The model file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The model or the landmarks.
    #[error(transparent)]
    Inputs(#[from] InputsError),
    /// The frames.
    #[error(transparent)]
    Frames(#[from] FramesError),
    /// Frames with one name.
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    /// The 2D scene cannot be built from the landmarks ([`SceneSource::Landmarks`]).
    #[error("cannot build the reference mesh from the landmarks' sources: {0}")]
    SceneMesh(String),
}

/// Where a sequence's scene (the deformation every frame's fit starts from) comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneSource {
    /// A deformation file: a 2.5D scene from `trimorph model bind`, or any 2D deformation
    /// (`trimorph fit DEF --frames ...`).
    File(PathBuf),
    /// A 2D scene made from the landmarks, for frames without a scene (`trimorph fit
    /// --frames DIR --landmarks L --size W,H`): the identity of degree `degree` over the
    /// mesh adapted to every source of every frame over the `size` frame (as `trimorph mesh
    /// --landmarks --size`, with `adapt`; `adapt.grid` 0 takes the sources' grid), its
    /// frame recorded.
    Landmarks {
        /// The frame `[width, height]` in pixels.
        size: [f64; 2],
        /// The adapted mesh's options (far-field rings included).
        adapt: crate::mesh::AdaptOptions,
        /// The spline's degree.
        degree: usize,
    },
}

impl From<PathBuf> for SceneSource {
    fn from(p: PathBuf) -> SceneSource {
        SceneSource::File(p)
    }
}

impl From<&Path> for SceneSource {
    fn from(p: &Path) -> SceneSource {
        SceneSource::File(p.to_path_buf())
    }
}

/// Every distinct source of the targets (all frames'), in order of first appearance.
fn all_sources(t: &Targets) -> Vec<crate::fit::landmarks::Landmark> {
    let lists: Vec<&[crate::fit::landmarks::Landmark]> = match t {
        Targets::Fixed(l) => vec![&l[..]],
        Targets::PerFrame(v) => v.iter().map(|l| &l[..]).collect(),
        Targets::Tracked { first, .. } => vec![&first[..]],
    };
    let mut seen = std::collections::HashSet::new();
    lists
        .into_iter()
        .flatten()
        .filter(|l| seen.insert((l.src[0].to_bits(), l.src[1].to_bits())))
        .cloned()
        .collect()
}

/// The identity over the mesh adapted to the targets' sources ([`SceneSource::Landmarks`]).
fn landmark_scene(
    t: &Targets,
    size: [f64; 2],
    adapt: &crate::mesh::AdaptOptions,
    degree: usize,
) -> Result<Spline, SequenceInputsError> {
    let lms = all_sources(t);
    let sources: Vec<[f64; 2]> = lms.iter().map(|l| l.src).collect();
    let mut ao = adapt.clone();
    if ao.grid == 0 {
        ao.grid = crate::fit::frame::source_grid(&lms);
    }
    let bad = |e: String| SequenceInputsError::SceneMesh(e);
    let mesh = crate::mesh::Mesh::landmark_adapted(&sources, size, &ao)
        .map_err(|e| bad(e.to_string()))?
        .mesh;
    let mut s = Spline::identity(mesh, degree).map_err(|e| bad(e.to_string()))?;
    s.set_frame(crate::spline::ImageFrame::new(size).ok());
    Ok(s)
}

/// Everything a sequence fit reads, loaded (see the module docs).
pub struct SequenceInputs {
    /// The scene (every frame's fit starts from it, or from the previous frame's result).
    pub scene: Spline,
    /// The scene's model: its file, the model and its binding to the scene.
    pub model: Option<(PathBuf, Model, Binding, UpAxis)>,
    /// The frames, in order.
    pub frames: Vec<Frame>,
    /// Per frame, whether it is float gray.
    pub gray_float: Vec<bool>,
    /// Every frame's targets.
    pub targets: Targets,
    /// Resume-key entries of the outputs: the model file's hash, the resampling.
    pub key_extra: BTreeMap<String, String>,
    /// The registered frames' value where `phi` leaves the frame (sample units).
    pub background: f64,
}

impl SequenceInputs {
    /// Reads the scene (and its model: `model`, else the scene's `"model"` key, bound to the
    /// scene), the frames (a folder or a stack, [`read_frames`]) and the landmarks
    /// ([`read_targets`]; tracked with `track`), in this order, as `trimorph fit --frames`
    /// (the error is boxed: it is large).
    pub fn load(
        scene: &SceneSource,
        model: Option<&Path>,
        frames: &Path,
        landmarks: &Path,
        track: Option<Anchor>,
        background: f64,
    ) -> Result<SequenceInputs, Box<SequenceInputsError>> {
        Self::read(scene, model, frames, landmarks, track, background).map_err(Box::new)
    }

    fn read(
        scene: &SceneSource,
        model: Option<&Path>,
        frames: &Path,
        landmarks: &Path,
        track: Option<Anchor>,
        background: f64,
    ) -> Result<SequenceInputs, SequenceInputsError> {
        if !background.is_finite() {
            return Err(SequenceInputsError::Background(background));
        }
        let scene = match scene {
            SceneSource::File(p) => p,
            SceneSource::Landmarks { size, adapt, degree } => {
                // A 2D scene: no model; the mesh comes from the landmarks, read first.
                let mut key_extra = BTreeMap::new();
                key_extra
                    .insert("registered".to_string(), format!("bilinear, background {background}"));
                let (frames, gray_float) = read_frames(frames)?;
                check_names(&frames)?;
                let track = track.map(|a| (a, TrackOptions::default()));
                let targets = read_targets(landmarks, &frames, None, track)?;
                let spline = landmark_scene(&targets, *size, adapt, *degree)?;
                return Ok(SequenceInputs {
                    scene: spline,
                    model: None,
                    frames,
                    gray_float,
                    targets,
                    key_extra,
                    background,
                });
            }
        };
        let text = read_text(scene).map_err(SequenceInputsError::SceneIo)?;
        let (spline, _) = deformation::from_str(&text)
            .map_err(|source| SequenceInputsError::Scene { path: scene.to_path_buf(), source })?;
        let mut key_extra = BTreeMap::new();
        let model = match scene_model(scene, model)? {
            Some((p, m, up)) => {
                let b = bind(&m, &spline)
                    .map_err(|source| SequenceInputsError::Bind { path: p.clone(), source })?;
                let bytes = std::fs::read(&p)
                    .map_err(|source| SequenceInputsError::ModelFile { path: p.clone(), source })?;
                key_extra.insert("model_hash".to_string(), content_hash(&bytes));
                Some((p, m, b, up))
            }
            None => None,
        };
        key_extra.insert("registered".to_string(), format!("bilinear, background {background}"));
        let (frames, gray_float) = read_frames(frames)?;
        check_names(&frames)?;
        let track = track.map(|a| (a, TrackOptions::default()));
        let targets =
            read_targets(landmarks, &frames, model.as_ref().map(|(_, m, _, _)| m), track)?;
        Ok(SequenceInputs {
            scene: spline,
            model,
            frames,
            gray_float,
            targets,
            key_extra,
            background,
        })
    }

    /// The anchor of a tracked sequence.
    pub fn anchor(&self) -> Option<Anchor> {
        match &self.targets {
            Targets::Tracked { anchor, .. } => Some(*anchor),
            _ => None,
        }
    }

    /// The sequence to fit with these fit options, hold-out and shard (the resume key
    /// gets [`SequenceInputs::key_extra`]).
    pub fn sequence(
        &self,
        fit: FitOptions,
        holdout: usize,
        seed: u64,
        shard: Option<(usize, usize)>,
    ) -> Result<Sequence<'_>, SequenceError> {
        let opts = SequenceOptions { fit, holdout, seed, shard, key_extra: self.key_extra.clone() };
        Sequence::new(&self.scene, &self.frames, self.targets.clone(), opts)
    }

    /// The files of the fit in folder `out` (see [`FrameFiles`]).
    pub fn files<'a>(&'a self, out: &'a Path) -> FrameFiles<'a> {
        FrameFiles {
            out,
            model: self.model.as_ref(),
            gray_float: &self.gray_float,
            background: self.background,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::landmarks::Landmark;
    use crate::fit::sequence::{Action, Sequence, SequenceOptions, Targets};
    use crate::mesh::{Mesh, MeshOptions};
    use crate::spline::Spline;

    #[test]
    fn inputs_name_the_bad_scene_and_refuse_a_nan_background() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.json");
        std::fs::write(&scene, "{\"not\": \"a deformation\"}").unwrap();
        let lms = dir.path().join("l.csv");
        let e = SequenceInputs::load(&scene.as_path().into(), None, dir.path(), &lms, None, 0.0)
            .err()
            .unwrap();
        assert!(
            e.to_string().starts_with(&format!("cannot read scene {}", scene.display())),
            "{e}"
        );
        let e =
            SequenceInputs::load(&scene.as_path().into(), None, dir.path(), &lms, None, f64::NAN)
                .err()
                .unwrap();
        assert!(matches!(*e, SequenceInputsError::Background(_)), "{e}");
    }

    #[test]
    fn a_frame_writes_every_file_and_a_rerun_skips_it() {
        let s = Spline::identity(Mesh::grid(2, 2, 40.0, 30.0, MeshOptions::default()).unwrap(), 5)
            .unwrap();
        let img = image::GrayImage::from_fn(40, 30, |x, y| image::Luma([(x * 5 + y * 3) as u8]));
        let frames = vec![Frame::new("a", "a.png", image::DynamicImage::ImageLuma8(img))];
        let lms: Vec<Landmark> = [[10.0, 10.0], [30.0, 10.0], [20.0, 20.0]]
            .iter()
            .map(|&p| Landmark { name: None, src: p, dst: [p[0] + 1.0, p[1]], weight: 1.0 })
            .collect();
        let seq =
            Sequence::new(&s, &frames, Targets::Fixed(lms), SequenceOptions::default()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let files =
            FrameFiles { out: dir.path(), model: None, gray_float: &[false], background: 0.0 };
        assert_eq!(files.stored(0, &frames[0]).unwrap().missing.len(), 3);
        let o = seq.run_frame(0, &files, &|_| {}).unwrap();
        assert!(matches!(o.action, Action::Fitted(_)));
        for name in ["a.json", "a.registered.png", "a.overlay.png", "a.report.json"] {
            assert!(dir.path().join(name).is_file(), "{name}");
        }
        // The frame's deformation carries the landmarks it was fitted to (issue 53), and
        // still reads as a deformation.
        let text = std::fs::read_to_string(dir.path().join("a.json")).unwrap();
        let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
        let carried = doc[deformation::LANDMARKS_KEY].as_array().unwrap();
        assert_eq!(carried.len(), 3);
        assert_eq!(carried[2]["dst"], serde_json::json!([21.0, 20.0]));
        let st = files.stored(0, &frames[0]).unwrap();
        assert!(st.missing.is_empty() && st.report.is_some() && st.spline.is_some());
        assert_eq!(seq.run_frame(0, &files, &|_| {}).unwrap().action, Action::Skipped);
    }
}
