//! `trimorph match`: automatic landmarks between two images (ORB, ratio + cross check, then
//! an affine, homography or local model), written as CSV, BigWarp or JSON.

use super::common::choice;
use super::{Exit, EXIT_INPUT};
use crate::fit::features::{
    gray8, match_images, FeatureError, LocalOptions, MatchOptions, ModelKind, MIN_SIDE,
};
use crate::fit::landmarks::LandmarkFormat;
use crate::io::landmarks::write_landmarks;
use crate::io::raster::read_stack;
use anyhow::Result;
use image::GrayImage;
use std::path::{Path, PathBuf};

/// The model that separates true matches from false ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum ModelArg {
    /// One affine map of the whole image (RANSAC).
    Affine,
    /// One plane projective map (RANSAC): another view of a flat scene.
    Homography,
    /// Each match agrees with its neighbours: objects that move independently.
    Local,
}

impl From<ModelArg> for ModelKind {
    fn from(m: ModelArg) -> ModelKind {
        match m {
            ModelArg::Affine => ModelKind::Affine,
            ModelArg::Homography => ModelKind::Homography,
            ModelArg::Local => ModelKind::Local,
        }
    }
}

/// Arguments of `trimorph match`.
#[derive(Clone, Debug, clap::Args)]
pub(crate) struct MatchCli {
    /// Image A (any type; converted to 8-bit gray, deep images scaled by their max).
    a: PathBuf,
    /// Image B.
    b: PathBuf,
    /// Output landmarks.
    #[arg(short, long)]
    output: PathBuf,
    /// Lowe's ratio for descriptor matches.
    #[arg(long, default_value_t = 0.8)]
    ratio: f32,
    /// Inlier threshold (pixels): the residual of a match under its model.
    #[arg(long, default_value_t = 3.0)]
    threshold: f64,
    /// Most ORB keypoints per image.
    #[arg(long, default_value_t = 1000)]
    features: usize,
    /// Output format: csv, bigwarp or json (any case).
    #[arg(long, default_value = "csv", value_parser = choice::<LandmarkFormat>(&LandmarkFormat::NAMES))]
    format: LandmarkFormat,
    /// The model: affine (one map of the image), homography, or local (each match agrees
    /// with its neighbours, for objects that move independently).
    #[arg(long, value_enum, default_value_t = ModelArg::Affine)]
    model: ModelArg,
    /// Local model: neighbours of each match that may support it.
    #[arg(long, default_value_t = LocalOptions::default().neighbours)]
    neighbours: usize,
    /// Local model: matches (counting the match itself) that must follow its local map.
    #[arg(long, default_value_t = LocalOptions::default().min_support)]
    min_support: usize,
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
fn explain(args: &MatchCli, e: &FeatureError) -> String {
    let file = |which: char| if which == 'A' { &args.a } else { &args.b }.display().to_string();
    let by_hand = "give landmarks by hand instead (a CSV: name,src_x,src_y,dst_x,dst_y)";
    let other = match args.model {
        ModelArg::Local => "",
        _ => "; if parts of the scene move independently, try --model local",
    };
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
             or --threshold{other}, or {by_hand}",
            args.a.display(),
            args.b.display()
        ),
        e if e.is_option() => {
            format!("{} vs {}: {e}; see trimorph match --help", args.a.display(), args.b.display())
        }
        _ => format!("{} vs {}: {e}", args.a.display(), args.b.display()),
    }
}

/// Runs `trimorph match`: landmarks with `src` in A's pixel coordinates and `dst` in B's.
pub(super) fn run(args: MatchCli) -> Result<()> {
    let a = load(&args.a)?;
    let b = load(&args.b)?;
    let mut opts = MatchOptions {
        ratio: args.ratio,
        features: args.features,
        model: args.model.into(),
        local: LocalOptions {
            neighbours: args.neighbours,
            min_support: args.min_support,
            ..Default::default()
        },
        ..Default::default()
    };
    opts.ransac.threshold = args.threshold;
    let r = match_images(&a, &b, &opts).map_err(|e| input_error(explain(&args, &e)))?;
    write_landmarks(&args.output, &r.landmarks, args.format)?;
    let st = &r.stats;
    println!(
        "keypoints {} / {}, matches {}, inliers {} (rms {:.3} px), {}",
        st.keypoints[0], st.keypoints[1], st.matches, st.inliers, st.rms, st.model
    );
    Ok(())
}

impl MatchCli {
    /// The command's files ([`crate::io::clash`]).
    pub(super) fn files(
        &self,
        f: crate::io::clash::CommandFiles,
    ) -> crate::io::clash::CommandFiles {
        f.input("image A", Some(&self.a))
            .input("image B", Some(&self.b))
            .output("--output", Some(&self.output))
    }
}
