//! The options of `trimorph fit` (clap): one fit (`fit DEF --landmarks L -o OUT.json`, or
//! `--size W,H` instead of DEF), or a sequence (`--model SCENE.json --frames DIR`). Parsed
//! here, dispatched by `cli::run` to [`super::fit_cmd`] and [`super::fit_batch`].

use super::common::{choice, text};
use crate::fit::objective::{Barrier, Loss, LossKind};
use crate::fit::options::{DEFAULT_LOSS_SCALE, DEFAULT_MAX_ITERS, DEFAULT_MIN_DET};
use crate::fit::sequence::AnchorKind;
use crate::fit::{Bend, FitOptions};
use crate::io::landmarks::LandmarkSource;
use crate::jobs::fit::Pin;
use crate::jobs::values::{parse_frame_size, parse_sample, parse_shard};
use anyhow::anyhow;
use std::path::PathBuf;

/// The command line of `trimorph fit`.
#[derive(clap::Args, Debug)]
pub struct FitCli {
    /// The deformation to fit (the warm start); not with --model.
    pub deformation: Option<PathBuf>,
    /// Landmarks: CSV `name,src_x,src_y,dst_x,dst_y[,weight]`, Fiji BigWarp CSV or JSON
    /// (with --frames: targets in the first frame, or a directory of per-frame files).
    #[arg(long, required_unless_present = "landmarks_src")]
    pub landmarks: Option<PathBuf>,
    /// Instead of --landmarks: the landmarks' source points, one point file (iBUG/menpo
    /// .pts, 1-based; ITK/elastix point set; or CSV `x,y`), paired point by point with
    /// --landmarks-dst. Not with --frames.
    #[arg(long, value_name = "FILE", requires = "landmarks_dst",
          conflicts_with_all = ["landmarks", "frames"])]
    pub landmarks_src: Option<PathBuf>,
    /// The landmarks' target points (see --landmarks-src): as many as in that file, in the
    /// same order.
    #[arg(long, value_name = "FILE", requires = "landmarks_src")]
    pub landmarks_dst: Option<PathBuf>,
    /// Output deformation (single fit) or output folder (with --frames).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Report (JSON): residuals, RMS, max, held-out TRE, min det J, iterations, time
    /// (with --frames: a summary of the sequence; every frame has its own report).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Data loss: squares (also `l2`), huber or cauchy.
    #[arg(long, default_value = "squares", value_parser = choice::<LossKind>(&LossKind::NAMES))]
    pub loss: LossKind,
    /// Scale of the huber / cauchy loss (pixels).
    #[arg(long, default_value_t = DEFAULT_LOSS_SCALE)]
    pub loss_scale: f64,
    /// Weight of the bending (thin-plate) energy: `auto` (chosen by leave-one-out
    /// cross-validation on the landmarks) or a scale-free number (lambda = bend * sum of
    /// landmark weights * area, the frame and margin with --size, else the mesh's; 1e-11
    /// interpolates, 1e-7 already smooths strongly bent landmarks by pixels, 1 is very
    /// stiff).
    #[arg(long, default_value = "auto", value_parser = text(str::parse::<Bend>))]
    pub bend: Bend,
    /// Landmarks become hard constraints phi(s) = t (exact, through ECLES).
    #[arg(long)]
    pub hard: bool,
    /// Keep K landmarks (chosen at random, see --seed) out of the fit and report their
    /// error (TRE).
    #[arg(long, default_value_t = 0)]
    pub holdout: usize,
    /// Seed of the --holdout choice.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Only control points within R control-net steps of the landmarks move.
    #[arg(long)]
    pub radius: Option<usize>,
    /// Control points held exactly at their values in DEF: a comma list of indices, or
    /// `edited` for the points corrected by hand in `trimorph editor` (DEF's "pinned"
    /// key). With --hard, the landmarks are exact too.
    #[arg(long, value_name = "LIST", value_parser = text(str::parse::<Pin>))]
    pub pin: Option<Pin>,
    /// Floor that the fold barrier keeps det J above.
    #[arg(long, default_value_t = DEFAULT_MIN_DET)]
    pub min_det: f64,
    /// Turn the fold barrier off.
    #[arg(long)]
    pub no_barrier: bool,
    /// Iteration cap of the fit's Newton method (with the fold barrier; each accepted step is
    /// certified fold-free).
    #[arg(long, default_value_t = DEFAULT_MAX_ITERS)]
    pub max_iters: u64,
    /// Scene (deformation, usually from `model bind`) for a frame sequence.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// The scene's model file (default: the scene's "model" key).
    #[arg(long)]
    pub model_file: Option<PathBuf>,
    /// Frames: a folder of images or a multi-page TIFF.
    #[arg(long)]
    pub frames: Option<PathBuf>,
    /// Follow the landmarks from frame to frame (pyramidal Lucas-Kanade).
    #[arg(long)]
    pub track: bool,
    /// With --track, which frame each frame is tracked from: chain (the previous frame;
    /// default), first (the first frame: no drift over long sequences) or keyframes
    /// (every --key-every N frames a key frame tracked from the first, the others from
    /// their key frame).
    #[arg(long, value_name = "chain|first|keyframes",
          value_parser = choice::<AnchorKind>(&AnchorKind::NAMES))]
    pub anchor: Option<AnchorKind>,
    /// Key frame spacing of --anchor keyframes.
    #[arg(long, value_name = "N")]
    pub key_every: Option<usize>,
    /// With --frames: registered frames get this value (in the frame's sample units)
    /// where the deformation leaves the frame or the mesh.
    #[arg(long, default_value = "0", value_parser = text(parse_sample))]
    pub background: f64,
    /// Only the i-th of n contiguous frame ranges (e.g. 0/4), for cluster array jobs.
    #[arg(long, value_parser = text(parse_shard))]
    pub shard: Option<(usize, usize)>,
    /// With no DEF: the frame W,H in pixels; the fit builds a mesh adapted to the
    /// landmarks over it (see `trimorph mesh --landmarks`) and covers the whole frame.
    #[arg(long, value_parser = text(parse_frame_size))]
    pub size: Option<[f64; 2]>,
    /// With --size: pixels added around the frame (default: enough for full coverage,
    /// at least a tenth of the larger side).
    #[arg(long)]
    pub margin: Option<f64>,
    /// With --size: the adapted mesh's longest edge in pixels.
    #[arg(long)]
    pub max_edge: Option<f64>,
    /// With --size: the adapted mesh's smallest angle in degrees.
    #[arg(long, default_value_t = crate::mesh::DEFAULT_MIN_ANGLE)]
    pub min_angle: f64,
    /// With --size: far-field rings around the adapted mesh (0 to 4), each 4 times the size
    /// of the one inside: the bending energy then spans nearly the whole plane, as a
    /// thin-plate spline's does. 0 leaves the border free (natural boundary).
    #[arg(long, default_value_t = crate::fit::frame::FAR_RINGS)]
    pub far_rings: usize,
}

impl FitCli {
    /// The landmarks given: --landmarks, or --landmarks-src with --landmarks-dst (clap
    /// makes sure one of them is there).
    pub fn landmark_source(&self) -> anyhow::Result<LandmarkSource> {
        match (&self.landmarks, &self.landmarks_src, &self.landmarks_dst) {
            (Some(l), None, None) => Ok(LandmarkSource::File(l.clone())),
            (None, Some(src), Some(dst)) => {
                Ok(LandmarkSource::Pair { src: src.clone(), dst: dst.clone() })
            }
            _ => {
                Err(anyhow!("give --landmarks FILE, or --landmarks-src FILE --landmarks-dst FILE"))
            }
        }
    }

    /// The adapted mesh's options of `--size` (margin, longest edge, smallest angle, far
    /// rings; the grid from the sources).
    pub fn adapt_options(&self) -> crate::mesh::AdaptOptions {
        crate::mesh::AdaptOptions {
            margin: self.margin,
            max_edge: self.max_edge,
            min_angle: self.min_angle,
            grid: 0,
            extra_points: Vec::new(),
            far_rings: self.far_rings,
        }
    }

    /// The library's fit options, through the library's parsers (so the CLI and the
    /// library accept the same values).
    pub fn fit_options(&self) -> anyhow::Result<FitOptions> {
        let loss = Loss::new(self.loss, self.loss_scale).map_err(|e| anyhow!("--loss: {e}"))?;
        let barrier = if self.no_barrier {
            None
        } else {
            Some(Barrier::with_floor(self.min_det).map_err(|e| anyhow!("--min-det: {e}"))?)
        };
        Ok(FitOptions {
            loss,
            bend: self.bend,
            barrier,
            radius: self.radius,
            max_iters: self.max_iters,
            hard: self.hard,
            ..FitOptions::default()
        })
    }
}
