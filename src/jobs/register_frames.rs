//! The file job behind `trimorph register --frames DIR --reference FRAME -o OUT`: every frame
//! of a folder (or a multi-page TIFF) registered to one of them
//! ([`crate::register::frames`]), each frame's results kept in folder OUT so that a rerun,
//! or another shard, resumes where the last one stopped.
//!
//! Per frame `<stem>` (the frame's name): `<stem>.json` (`phi`: the frame's pixels -> the
//! reference's pixels, the reference's frame recorded), `<stem>.registered.png` (the frame
//! resampled onto the reference's grid, in the frame's type; `.registered.tif` for float
//! frames), `<stem>.overlay.png` (reference magenta, frame green, before and after) and
//! `<stem>.report.json`, written last: a frame counts as done only once its report exists.
//! Every file is written to a temporary file and renamed ([`crate::io::write_atomic`]).

use super::register::{first_page, resampled};
use super::sequence::{registered_file, stored_files};
use super::{JobError, JobResult};
use crate::fit::sequence::{Frame, StoreError};
use crate::io::frames::read_frames;
use crate::io::raster::{write_stack, Stack};
use crate::io::{deformation, write_atomic};
use crate::register::frames::{
    find_reference, FrameOutcome, FrameRegistration, FrameStore, FramesOptions, FramesSummary,
    RegisterFrames, StoredFrame, WarmStart,
};
use crate::register::image::{Channel, Mask};
use crate::register::{Input, RegisterOptions};
use crate::spline::ImageFrame;
use std::path::{Path, PathBuf};

/// What a sequence registration reads and writes.
#[derive(Clone, Debug, Default)]
pub struct RegisterFramesJob {
    /// The frames: a folder of images or a multi-page TIFF ([`read_frames`]).
    pub frames: PathBuf,
    /// The reference frame: a name, a file name or an index from 0.
    pub reference: String,
    /// The output folder (made when missing).
    pub out: PathBuf,
    /// The reference's mask.
    pub mask_fixed: Option<PathBuf>,
    /// Every other frame's mask.
    pub mask_moving: Option<PathBuf>,
    /// The summary report (JSON).
    pub report: Option<PathBuf>,
    /// Where each solve starts.
    pub warm_start: WarmStart,
    /// Only shard `i` of `n`.
    pub shard: Option<(usize, usize)>,
}

/// The folder of a sequence registration's outputs (module docs).
pub struct RegisteredFrames<'a> {
    /// The folder.
    pub out: &'a Path,
    /// Per frame, whether it is float gray (held as RGB float, written back as gray).
    pub gray_float: &'a [bool],
    /// The reference frame, registered against (for the overlays and the output grid).
    pub reference: &'a Frame,
    /// The reference's frame size `[w, h]`, recorded in every deformation.
    pub size: [f64; 2],
}

impl RegisteredFrames<'_> {
    fn path(&self, stem: &str, ext: &str) -> PathBuf {
        self.out.join(format!("{stem}.{ext}"))
    }

    /// The resampled frame's file (`.tif` for float frames).
    pub fn registered(&self, index: usize, frame: &Frame) -> PathBuf {
        registered_file(self.out, frame, self.gray_float[index])
    }

    /// Every output of a frame except the report.
    pub fn outputs(&self, index: usize, frame: &Frame) -> Vec<PathBuf> {
        vec![
            self.path(&frame.name, "json"),
            self.registered(index, frame),
            self.path(&frame.name, "overlay.png"),
        ]
    }

    fn channel(frame: &Frame) -> Result<Input, JobError> {
        let name = PathBuf::from(&frame.source);
        let image = Channel::from_image(&frame.image, &name)?;
        Ok(Input { image, name, mask: None })
    }

    /// Writes a frame's files, the report last.
    pub fn write(&self, r: &FrameRegistration, frame: &Frame) -> JobResult<()> {
        let mut s = r.spline.clone();
        s.set_frame(Some(
            ImageFrame::new(self.size).map_err(|e| JobError::context(&self.reference.source, e))?,
        ));
        // Everything computed first, then written.
        let text = deformation::to_string(&s, None);
        let (fixed, moving) = (Self::channel(self.reference)?, Self::channel(frame)?);
        let (warped, overlay) = resampled(&s, (&fixed, &moving, &frame.image), true, true)?;
        let warped = warped.ok_or(JobError::context(
            &frame.source,
            std::io::Error::other("resampling gave no image"),
        ))?;
        write_atomic(&self.path(&frame.name, "json"), text.as_bytes())?;
        let stack = Stack { pages: vec![warped], gray_float: self.gray_float[r.index] };
        write_stack(&self.registered(r.index, frame), &stack)?;
        if let Some(png) = overlay {
            write_atomic(&self.path(&frame.name, "overlay.png"), &png)?;
        }
        write_atomic(&self.path(&frame.name, "report.json"), r.report_text().as_bytes())?;
        Ok(())
    }
}

impl FrameStore for RegisteredFrames<'_> {
    fn stored(&self, index: usize, frame: &Frame) -> Result<StoredFrame, StoreError> {
        let (report, missing, spline) =
            stored_files(self.out, &frame.name, &self.outputs(index, frame));
        Ok(StoredFrame { report, missing, spline })
    }

    fn save(&self, result: &FrameRegistration, frame: &Frame) -> Result<(), StoreError> {
        self.write(result, frame).map_err(Into::into)
    }
}

fn mask(path: Option<&Path>) -> JobResult<Option<(Mask, PathBuf)>> {
    Ok(match path {
        Some(m) => Some((Mask::from_image(&first_page(m)?.0), m.to_path_buf())),
        None => None,
    })
}

/// Runs the job (module docs): reads the frames and masks, registers the frames of the shard
/// that are not current in OUT, writes the summary when asked. `progress` hears of every
/// frame.
pub fn run(
    job: &RegisterFramesJob,
    register: RegisterOptions,
    progress: &dyn Fn(&FrameOutcome),
) -> JobResult<FramesSummary> {
    let (frames, gray_float) = read_frames(&job.frames)?;
    let reference = find_reference(&frames, &job.reference)?;
    let opts = FramesOptions {
        register,
        reference,
        warm_start: job.warm_start,
        shard: job.shard,
        mask_fixed: mask(job.mask_fixed.as_deref())?,
        mask_moving: mask(job.mask_moving.as_deref())?,
        key_extra: [("registered".to_string(), "bilinear, background 0".to_string())].into(),
    };
    let seq = RegisterFrames::new(&frames, opts)?;
    if job.frames.is_dir() && crate::io::clash::same_file(&job.frames, &job.out) {
        // The outputs would be read as frames by the next run.
        return Err(JobError::context(
            format!("--output {}", job.out.display()),
            std::io::Error::other("it is the frames folder; write the results to another folder"),
        ));
    }
    std::fs::create_dir_all(&job.out).map_err(|e| {
        JobError::context(format!("cannot make the output folder {}", job.out.display()), e)
    })?;
    let r = &frames[reference];
    let files = RegisteredFrames {
        out: &job.out,
        gray_float: &gray_float,
        reference: r,
        size: [r.image.width() as f64, r.image.height() as f64],
    };
    let summary = seq.run(&files, progress)?;
    if let Some(p) = &job.report {
        write_atomic(p, summary.to_text().as_bytes())?;
    }
    Ok(summary)
}
