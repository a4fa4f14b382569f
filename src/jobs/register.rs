//! The file job behind `trimorph register`: read FIXED, MOVING, masks, landmarks and a start
//! deformation; register ([`crate::register::register`]); then write the deformation, the
//! resampled MOVING, the report and the overlay. Everything is computed before anything is
//! written, and each file is written atomically, so a failed run leaves no file behind.

use super::{read_deformation, JobError, JobResult};
use crate::io::raster::{read_stack, Stack};
use crate::io::{deformation, write_atomic};
use crate::register::image::{Channel, Mask};
use crate::register::{register, Input, RegisterOptions, RegisterReport};
use crate::spline::{ImageFrame, Spline};
use crate::warp::{warp_pages_sized, WarpOptions};
use image::DynamicImage;
use std::path::{Path, PathBuf};

/// The files of a registration.
#[derive(Clone, Debug, Default)]
pub struct RegisterFiles {
    /// FIXED.
    pub fixed: PathBuf,
    /// MOVING.
    pub moving: PathBuf,
    /// FIXED's mask.
    pub mask_fixed: Option<PathBuf>,
    /// MOVING's mask.
    pub mask_moving: Option<PathBuf>,
    /// Landmarks (`src` in MOVING, `dst` in FIXED).
    pub landmarks: Option<PathBuf>,
    /// Start deformation (its pinned points stay pinned).
    pub init: Option<PathBuf>,
    /// The deformation written.
    pub output: PathBuf,
    /// MOVING resampled onto FIXED's grid.
    pub warped: Option<PathBuf>,
    /// The report (JSON).
    pub report: Option<PathBuf>,
    /// The overlay picture (PNG).
    pub overlay: Option<PathBuf>,
}

pub(super) fn first_page(path: &Path) -> JobResult<(DynamicImage, bool)> {
    let stack = read_stack(path)?;
    let gray_float = stack.gray_float;
    let page = stack.pages.into_iter().next().ok_or_else(|| {
        JobError::context(
            path.display().to_string(),
            std::io::Error::other("the file holds no image"),
        )
    })?;
    Ok((page, gray_float))
}

fn input(path: &Path, mask: Option<&Path>) -> JobResult<(Input, DynamicImage, bool)> {
    let (img, gray_float) = first_page(path)?;
    let image = Channel::from_image(&img, path)?;
    let mask = match mask {
        Some(m) => Some((Mask::from_image(&first_page(m)?.0), m.to_path_buf())),
        None => None,
    };
    Ok((Input { image, name: path.to_path_buf(), mask }, img, gray_float))
}

/// MOVING resampled onto FIXED's grid through `spline` (FIXED's size, MOVING's type) when
/// `warped` or `overlay`, and the two-colour overlay PNG (FIXED magenta, MOVING green; before
/// and after) when `overlay`. `images` are FIXED, MOVING and MOVING's pixels as read.
pub(super) fn resampled(
    spline: &Spline,
    images: (&Input, &Input, &DynamicImage),
    warped: bool,
    overlay: bool,
) -> JobResult<(Option<DynamicImage>, Option<Vec<u8>>)> {
    let (fixed, moving, moving_img) = images;
    if !(warped || overlay) {
        return Ok((None, None));
    }
    let (fw, fh) = (fixed.image.w as u32, fixed.image.h as u32);
    let (pages, _) = warp_pages_sized(
        spline,
        std::slice::from_ref(moving_img),
        (fw, fh),
        &WarpOptions::default(),
        &|_| {},
    )?;
    let Some(wimg) = pages.into_iter().next() else { return Ok((None, None)) };
    if !overlay {
        return Ok((Some(wimg), None));
    }
    let after = Channel::from_image(&wimg, &moving.name)?.data;
    let mut given = vec![f32::NAN; (fw * fh) as usize];
    for y in 0..(fh as usize).min(moving.image.h) {
        for x in 0..(fw as usize).min(moving.image.w) {
            given[y * fw as usize + x] = moving.image.at(x, y);
        }
    }
    let pm = crate::render::registration::overlay(
        fw as usize,
        fh as usize,
        &fixed.image.data,
        &given,
        &after,
    );
    let png = pm.encode_png().map_err(|e| {
        JobError::context("encoding the overlay", std::io::Error::other(e.to_string()))
    })?;
    Ok((Some(wimg), Some(png)))
}

/// What [`run`] did.
#[derive(Clone, Debug)]
pub struct RegisterOutcome {
    /// The registration's report.
    pub report: RegisterReport,
    /// FIXED's size.
    pub fixed_size: (u32, u32),
}

/// Runs the job (module docs). `opts.init` and `opts.pinned` are read from `files.init`
/// and `opts.landmarks` from `files.landmarks` when given.
pub fn run(files: &RegisterFiles, mut opts: RegisterOptions) -> JobResult<RegisterOutcome> {
    let (fixed, fixed_img, _) = input(&files.fixed, files.mask_fixed.as_deref())?;
    let (moving, moving_img, moving_float) = input(&files.moving, files.mask_moving.as_deref())?;
    if let Some(l) = &files.landmarks {
        opts.landmarks = crate::io::landmarks::read_landmarks(l)
            .map_err(|e| JobError::context(l.display().to_string(), e))?;
    }
    if let Some(p) = &files.init {
        let text = crate::io::read_text(p)?;
        let (s, _) = read_deformation(p)?;
        opts.pinned = deformation::pinned_from_str(&text)
            .map_err(|e| JobError::context(p.display().to_string(), e))?;
        opts.init = Some(s);
    }
    let reg = register(&fixed, &moving, &opts)?;
    let (fw, fh) = (fixed.image.w as u32, fixed.image.h as u32);
    let mut spline = reg.spline;
    spline.set_frame(Some(
        ImageFrame::new([fw as f64, fh as f64])
            .map_err(|e| JobError::context(files.fixed.display().to_string(), e))?,
    ));
    // Everything to write, computed first.
    // The landmarks it was registered with ride along (the editor's re-fit keeps them).
    let def_text = deformation::to_string_with_landmarks(&spline, &opts.landmarks);
    let (warped, overlay_png) = resampled(
        &spline,
        (&fixed, &moving, &moving_img),
        files.warped.is_some(),
        files.overlay.is_some(),
    )?;
    let report_text = serde_json::to_string_pretty(&reg.report)?;
    drop(fixed_img);
    // Then written, each atomically.
    write_atomic(&files.output, def_text.as_bytes())?;
    if let (Some(path), Some(img)) = (&files.warped, warped) {
        let stack = Stack { pages: vec![img], gray_float: moving_float };
        super::warp::write_image_output(path, &stack, None)?;
    }
    if let (Some(path), Some(png)) = (&files.overlay, overlay_png) {
        write_atomic(path, &png)?;
    }
    if let Some(path) = &files.report {
        write_atomic(path, report_text.as_bytes())?;
    }
    Ok(RegisterOutcome { report: reg.report, fixed_size: (fw, fh) })
}
