//! `trimorph match`: automatic landmarks between two images (ORB, ratio + cross check,
//! RANSAC on an affine model), written as CSV, BigWarp or JSON.

use super::{Exit, EXIT_INPUT};
use crate::fit::features::{gray8, match_images, FeatureError, MatchOptions, MIN_SIDE};
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

/// The message for a failed match: the file at fault when one image is, and what to do.
fn explain(args: &MatchArgs, e: &FeatureError) -> String {
    let file = |which: char| if which == 'A' { args.a } else { args.b }.display().to_string();
    let by_hand = "give landmarks by hand instead (a CSV: name,src_x,src_y,dst_x,dst_y)";
    match e {
        FeatureError::TooSmall { which, .. } => {
            format!("{}: {e}; use an image of at least {MIN_SIDE}x{MIN_SIDE}", file(*which))
        }
        FeatureError::NoFeatures { which } => format!(
            "{}: {e} (it is flat or has no texture at ORB's scales); {by_hand}",
            file(*which)
        ),
        FeatureError::TooFewMatches { .. } | FeatureError::NoConsensus { .. } => format!(
            "{} vs {}: {e}; the images may not show the same scene: try a larger --ratio \
             or --threshold, or {by_hand}",
            args.a.display(),
            args.b.display()
        ),
        FeatureError::Options(_) => {
            format!("{} vs {}: {e}; see trimorph match --help", args.a.display(), args.b.display())
        }
        _ => format!("{} vs {}: {e}", args.a.display(), args.b.display()),
    }
}

/// Runs `trimorph match`: landmarks with `src` in A's pixel coordinates and `dst` in B's.
pub(super) fn run(args: MatchArgs) -> Result<()> {
    let format: LandmarkFormat = args.format.parse().map_err(|e| input_error(format!("{e}")))?;
    let a = load(args.a)?;
    let b = load(args.b)?;
    let mut opts =
        MatchOptions { ratio: args.ratio, features: args.features, ..Default::default() };
    opts.ransac.threshold = args.threshold;
    let r = match_images(&a, &b, &opts).map_err(|e| input_error(explain(&args, &e)))?;
    write_landmarks(args.output, &r.landmarks, format)?;
    let st = &r.stats;
    println!(
        "keypoints {} / {}, matches {}, inliers {} (rms {:.3} px), affine {}",
        st.keypoints[0], st.keypoints[1], st.matches, st.inliers, st.rms, st.affine
    );
    Ok(())
}
