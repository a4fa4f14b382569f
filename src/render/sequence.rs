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

use crate::fit::sequence::{Frame, FrameResult, Store, StoreError, Stored};
use crate::io::model::{save_model, ModelIoError};
use crate::io::raster::{write_stack, RasterError, Stack};
use crate::io::{deformation, read_text, write_atomic, IoError};
use crate::prism::{deform, Binding, Model};
use crate::render::deformation::{save_png, RenderError};
use crate::render::overlay::{overlay, silhouette, Mark};
use crate::warp::pullback::pull_back;
use crate::warp::{Interp, WarpError};
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
    pub model: Option<&'a (PathBuf, Model, Binding)>,
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
        let float = matches!(
            frame.image,
            image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)
        ) || self.gray_float[index];
        self.path(&frame.name, if float { "registered.tif" } else { "registered.png" })
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
        write_atomic(&self.path(stem, "json"), deformation::to_string(s, None).as_bytes())?;
        let (w, h) = (frame.image.width(), frame.image.height());
        let reg = pull_back(s, &frame.image, w, h, Interp::Bilinear, self.background)?;
        let stack = Stack { pages: vec![reg], gray_float: self.gray_float[r.index] };
        write_stack(&self.registered(r.index, frame), &stack)?;
        let mut outline = Vec::new();
        if let Some((_, m, b)) = self.model {
            let moved = deform(m, b, s);
            save_model(m, &moved, &self.path(stem, "obj"))?;
            outline = silhouette(&moved, &m.triangles);
        }
        let marks: Vec<Mark> =
            r.report.residuals.iter().map(|x| Mark { mapped: x.mapped, target: x.dst }).collect();
        let ov = overlay(frame.gray().as_raw(), w, h, &outline, &marks)
            .ok_or(FrameFilesError::EmptyFrame)?;
        save_png(&ov, &self.path(stem, "overlay.png"))?;
        let text = serde_json::to_string_pretty(&r.report_json())?;
        write_atomic(&self.path(stem, "report.json"), text.as_bytes())?;
        Ok(())
    }
}

impl Store for FrameFiles<'_> {
    fn stored(&self, index: usize, frame: &Frame) -> Result<Stored, StoreError> {
        let report = read_text(&self.path(&frame.name, "report.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
        let missing: Vec<String> = self
            .outputs(index, frame)
            .iter()
            .filter(|p| !p.exists())
            .map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())
            .collect();
        let spline = read_text(&self.path(&frame.name, "json"))
            .ok()
            .and_then(|t| deformation::from_str(&t).ok())
            .map(|(s, _)| s);
        Ok(Stored { report, missing, spline })
    }

    fn save(&self, result: &FrameResult, frame: &Frame) -> Result<(), StoreError> {
        self.write(result, frame).map_err(Into::into)
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
        let st = files.stored(0, &frames[0]).unwrap();
        assert!(st.missing.is_empty() && st.report.is_some() && st.spline.is_some());
        assert_eq!(seq.run_frame(0, &files, &|_| {}).unwrap().action, Action::Skipped);
    }
}
