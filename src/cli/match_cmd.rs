//! `trimorph match`: automatic landmarks between two images (ORB, ratio + cross check,
//! RANSAC on an affine model), written as CSV, BigWarp or JSON.

use super::{Exit, EXIT_INPUT};
use crate::fit::features::{gray8, match_images, MatchOptions};
use crate::fit::landmarks::LandmarkFormat;
use crate::io::landmarks::write_landmarks;
use crate::io::raster::read_stack;
use anyhow::Result;
use image::GrayImage;
use std::path::Path;

/// Arguments of `trimorph match`.
pub(super) struct MatchArgs<'a> {
    pub a: &'a Path,
    pub b: &'a Path,
    pub output: &'a Path,
    pub ratio: f32,
    pub threshold: f64,
    pub features: usize,
    pub format: &'a str,
}

fn input_error(message: String) -> anyhow::Error {
    Exit { code: EXIT_INPUT, message, printed: false }.into()
}

/// The first page of an image file as 8-bit gray.
fn load(path: &Path) -> Result<GrayImage> {
    let stack = read_stack(path).map_err(|e| input_error(e.to_string()))?;
    Ok(gray8(&stack.pages[0]))
}

/// Runs `trimorph match`: landmarks with `src` in A's pixel coordinates and `dst` in B's.
pub(super) fn run(args: MatchArgs) -> Result<()> {
    let format: LandmarkFormat = args.format.parse().map_err(|e| input_error(format!("{e}")))?;
    let a = load(args.a)?;
    let b = load(args.b)?;
    let mut opts =
        MatchOptions { ratio: args.ratio, features: args.features, ..Default::default() };
    opts.ransac.threshold = args.threshold;
    let r = match_images(&a, &b, &opts)
        .map_err(|e| input_error(format!("{} vs {}: {e}", args.a.display(), args.b.display())))?;
    write_landmarks(args.output, &r.landmarks, format)?;
    let st = &r.stats;
    println!(
        "keypoints {} / {}, matches {}, inliers {} (rms {:.3} px), affine {}",
        st.keypoints[0], st.keypoints[1], st.matches, st.inliers, st.rms, st.affine
    );
    Ok(())
}
