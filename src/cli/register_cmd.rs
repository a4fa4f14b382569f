//! `trimorph register FIXED MOVING -o DEF.json`: registration from the images themselves
//! (a thin layer over [`crate::jobs::register`]); `trimorph register --frames DIR --reference
//! FRAME -o OUT`: every frame registered to one of them (over [`crate::jobs::register_frames`]).

use super::common::{choice, say, spinner, text};
use crate::jobs::register::{run as run_job, RegisterFiles};
use crate::jobs::register_frames::RegisterFramesJob;
use crate::jobs::values::parse_shard;
use crate::register::frames::{reason_text, FrameAction, FrameOutcome, WarmStart};
use crate::register::{Metric, Prealign, Progress, RegisterOptions};
use anyhow::Result;
use indicatif::ProgressBar;
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `trimorph register`.
#[derive(Clone, Debug, clap::Args)]
pub(crate) struct RegisterCli {
    /// The fixed image (the grid MOVING is resampled onto). Any type trimorph reads; colour
    /// is registered as grey.
    #[arg(required_unless_present = "frames")]
    fixed: Option<PathBuf>,
    /// The moving image.
    #[arg(required_unless_present = "frames")]
    moving: Option<PathBuf>,
    /// Output deformation: phi maps MOVING pixels to FIXED pixels, so
    /// `trimorph warp DEF --image MOVING` resamples MOVING onto FIXED. With --frames, the
    /// output folder: per frame <stem>.json, .registered.png (.tif for float frames),
    /// .overlay.png and .report.json.
    #[arg(short, long)]
    output: PathBuf,
    /// Also write MOVING resampled on FIXED's grid (FIXED's size, MOVING's type).
    #[arg(long, value_name = "IMAGE")]
    warped: Option<PathBuf>,
    /// Write the report (JSON): metric before and after, per level iterations, termination
    /// and time, the fold certificate, landmark residuals. With --frames, a summary of the
    /// run (every frame has its own report).
    #[arg(long, value_name = "JSON")]
    report: Option<PathBuf>,
    /// Write a two-colour overlay (FIXED magenta, MOVING green) before and after (PNG).
    #[arg(long, value_name = "PNG")]
    overlay: Option<PathBuf>,
    /// Register every frame of a sequence (a folder of images or a multi-page TIFF) to the
    /// --reference frame instead of FIXED MOVING. Resumable: a frame whose report's resume
    /// key matches this run and whose outputs are all there is skipped.
    #[arg(long, value_name = "DIR|STACK",
          conflicts_with_all = ["fixed", "moving", "warped", "overlay", "landmarks", "init"])]
    frames: Option<PathBuf>,
    /// With --frames, the frame every frame is registered to: its name (file stem), its file
    /// name or its index from 0.
    #[arg(long, value_name = "FRAME", requires = "frames")]
    reference: Option<String>,
    /// With --frames, where each frame's solve starts: chain (from the result of its
    /// neighbour on the reference's side; default), keyframes (key frames every --key-every
    /// N frames from the reference chain, the others start from their key frame) or none
    /// (every frame from its own pre-alignment).
    #[arg(long, value_name = "chain|keyframes|none", requires = "frames",
          value_parser = clap::builder::PossibleValuesParser::new(WarmStart::NAMES))]
    warm_start: Option<String>,
    /// Key frame spacing of --warm-start keyframes.
    #[arg(long, value_name = "N", requires = "frames")]
    key_every: Option<usize>,
    /// With --frames, only the i-th of n contiguous frame ranges (e.g. 0/4), for cluster
    /// array jobs.
    #[arg(long, value_parser = text(parse_shard), requires = "frames")]
    shard: Option<(usize, usize)>,
    /// Similarity metric: ncc (one modality, any gain and offset), ssd (one modality, same
    /// exposure) or mi (Mattes mutual information: different stains or modalities).
    #[arg(long, default_value = "ncc", value_parser = choice::<Metric>(&Metric::NAMES))]
    metric: Metric,
    /// FIXED's mask (pixels above half its largest value count).
    #[arg(long, value_name = "IMAGE")]
    mask_fixed: Option<PathBuf>,
    /// MOVING's mask.
    #[arg(long, value_name = "IMAGE")]
    mask_moving: Option<PathBuf>,
    /// Landmarks added to the image term (CSV `name,src_x,src_y,dst_x,dst_y[,weight]`,
    /// BigWarp CSV or JSON; src in MOVING, dst in FIXED).
    #[arg(long, value_name = "FILE")]
    landmarks: Option<PathBuf>,
    /// Weight of the landmark term against the image term: one landmark counts as this
    /// many image samples per squared pixel.
    #[arg(long, default_value_t = crate::register::DEFAULT_LANDMARK_WEIGHT)]
    landmark_weight: f64,
    /// Meet the landmarks exactly (checked in rationals).
    #[arg(long, requires = "landmarks")]
    hard: bool,
    /// Start from this deformation (a fit, an edit, an earlier registration) instead of a
    /// pre-alignment; its pinned points stay pinned.
    #[arg(long, value_name = "DEF")]
    init: Option<PathBuf>,
    /// Pre-alignment from the images: affine, translation or none.
    #[arg(long, default_value = "affine", value_parser = parse_prealign)]
    prealign: Prealign,
    /// Pyramid levels (default: up to 4, the coarsest at least 48 pixels across).
    #[arg(long)]
    levels: Option<u32>,
    /// Mesh cell size (MOVING pixels) of the finest mesh level.
    #[arg(long, default_value_t = RegisterOptions::default().spacing)]
    spacing: f64,
    /// Mesh levels: the spline starts on cells 2^(N-1) times --spacing and is refined
    /// exactly before each of the N-1 finest pyramid levels (1: one mesh throughout; a
    /// deformation given by --init keeps its mesh). Default: 3.
    #[arg(long, value_name = "N")]
    mesh_levels: Option<u32>,
    /// Share of the refinement indicator (the image term's pull on a twice finer mesh) that
    /// the refined triangles carry, in (0, 1]; 1 refines every triangle.
    #[arg(long, default_value_t = RegisterOptions::default().refine_share, value_name = "THETA")]
    refine_share: f64,
    /// Bending weight (larger: smoother), relative to the metric: mi multiplies it by 1000,
    /// as its cost is on another scale than ncc's or ssd's.
    #[arg(long, default_value_t = RegisterOptions::default().bend)]
    bend: f64,
    /// Most samples per pyramid level (a regular subset of MOVING's pixels beyond it).
    #[arg(long, default_value_t = RegisterOptions::default().samples.max_samples)]
    samples: usize,
    /// L-BFGS iterations per pyramid level.
    #[arg(long, default_value_t = RegisterOptions::default().max_iters)]
    iterations: u64,
    /// Print every solver iteration (stage, iteration, cost) on standard error.
    #[arg(long)]
    verbose: bool,
}

fn parse_prealign(s: &str) -> Result<Prealign, String> {
    s.parse()
}

/// Runs `trimorph register`.
pub(super) fn run(args: RegisterCli) -> Result<()> {
    let mut opts = RegisterOptions {
        metric: args.metric,
        levels: args.levels,
        prealign: args.prealign,
        spacing: args.spacing,
        mesh_levels: args.mesh_levels,
        refine_share: args.refine_share,
        bend: args.bend,
        max_iters: args.iterations,
        samples: crate::register::samples::SampleOptions { max_samples: args.samples },
        landmark_weight: args.landmark_weight,
        hard: args.hard,
        ..RegisterOptions::default()
    };
    // --verbose prints every iteration; otherwise the latest one shows on a spinner line
    // while stderr is a terminal.
    let spinner = spinner(!args.verbose, "register");
    opts.progress = Some(progress(args.verbose, spinner.clone()));
    if let Some(frames) = &args.frames {
        let done = run_frames(&args, frames, opts, &spinner);
        spinner.finish_and_clear();
        return done;
    }
    let (Some(fixed), Some(moving)) = (args.fixed.clone(), args.moving.clone()) else {
        anyhow::bail!("give FIXED and MOVING, or --frames DIR --reference FRAME");
    };
    let files = RegisterFiles {
        fixed,
        moving,
        mask_fixed: args.mask_fixed,
        mask_moving: args.mask_moving,
        landmarks: args.landmarks,
        init: args.init,
        output: args.output.clone(),
        warped: args.warped,
        report: args.report,
        overlay: args.overlay,
    };
    let out = run_job(&files, opts);
    spinner.finish_and_clear();
    let out = out?;
    let r = &out.report;
    let iters: u64 = r.levels.iter().map(|l| l.iterations).sum();
    say(format!(
        "{} {:.4} -> {:.4} (pre-aligned {:.4}), {} levels, {} iterations, {:.0} ms",
        r.metric.name(),
        r.metric_before,
        r.metric_after,
        r.metric_prealigned,
        r.pyramid_levels,
        iters,
        r.time_ms
    ))?;
    // The mesh pyramid's triangles per mesh level, e.g. "18 -> 72 -> 288 triangles".
    let mut meshes: Vec<usize> = r.levels.iter().filter_map(|l| l.triangles).collect();
    meshes.dedup();
    let meshes = if meshes.len() > 1 {
        meshes.iter().map(|t| t.to_string()).collect::<Vec<_>>().join(" -> ")
    } else {
        r.triangles.to_string()
    };
    say(format!(
        "{}: det J >= {:.4} ({}), exactly C1, {} triangles, {} variables",
        args.output.display(),
        r.det_j_lower_bound,
        if r.fold_free { "certified fold-free" } else { "NOT certified fold-free" },
        meshes,
        r.variables
    ))?;
    if let Some(l) = &r.landmarks {
        say(format!(
            "landmarks: {} ({}), residual rms {:.4} px, max {:.4} px",
            l.count,
            if l.hard { "exact" } else { "soft" },
            l.fit.rms,
            l.fit.max
        ))?;
    }
    Ok(())
}

/// The solver's progress `(stage, iteration, cost)`: a line on stderr per iteration when
/// `verbose`, else the spinner's message.
fn progress(verbose: bool, spinner: ProgressBar) -> Progress {
    if verbose {
        Arc::new(|stage: &str, it: u64, cost: f64| {
            eprintln!("{stage}: iteration {it}, cost {cost:.6}");
        })
    } else {
        Arc::new(move |stage: &str, it: u64, cost: f64| {
            spinner.set_message(format!("{stage}, iteration {it}, cost {cost:.4}"));
        })
    }
}

/// One line per frame of a sequence registration.
fn frame_line(o: &FrameOutcome) -> String {
    let f = &o.figures;
    let cert = match (f.fold_free, f.det_j_lower_bound) {
        (Some(true), Some(b)) => format!("certified fold-free (det J >= {b:.4})"),
        (Some(false), Some(b)) => format!("NOT certified fold-free (det J >= {b:.4})"),
        _ => "no certificate stored".to_string(),
    };
    match &o.action {
        FrameAction::Skipped => format!("{}: skipped (its stored results are current)", o.frame),
        FrameAction::Reference(r) => {
            format!("{}: the reference (identity), {}", o.frame, reason_text(r))
        }
        FrameAction::Registered(r) => format!(
            "{}: {:.4} -> {:.4}, {cert}, from {}, {:.0} ms ({})",
            o.frame,
            f.metric_before.unwrap_or(f64::NAN),
            f.metric_after.unwrap_or(f64::NAN),
            o.warm_start.as_deref().unwrap_or("its pre-alignment"),
            o.time_ms,
            reason_text(r)
        ),
    }
}

/// `trimorph register --frames DIR --reference FRAME -o OUT`.
fn run_frames(
    args: &RegisterCli,
    frames: &std::path::Path,
    opts: RegisterOptions,
    spinner: &ProgressBar,
) -> Result<()> {
    let reference = args.reference.clone().ok_or_else(|| {
        anyhow::anyhow!("--frames needs --reference FRAME (a frame's name or index)")
    })?;
    let warm_start =
        WarmStart::from_name(args.warm_start.as_deref().unwrap_or("chain"), args.key_every)?;
    let job = RegisterFramesJob {
        frames: frames.to_path_buf(),
        reference,
        out: args.output.clone(),
        mask_fixed: args.mask_fixed.clone(),
        mask_moving: args.mask_moving.clone(),
        report: args.report.clone(),
        warm_start,
        shard: args.shard,
    };
    let summary = crate::jobs::register_frames::run(&job, opts, &|o| {
        spinner.suspend(|| {
            let _ = say(frame_line(o));
        });
    })?;
    if summary.range[0] == summary.range[1] {
        say(format!("this shard holds none of the {} frames", summary.frames))?;
        return Ok(());
    }
    say(format!(
        "frames {} to {} of {}: {} registered, {} skipped, reference {}; {} not certified fold-free; {:.0} ms",
        summary.range[0],
        summary.range[1].saturating_sub(1),
        summary.frames,
        summary.registered,
        summary.skipped,
        summary.reference,
        summary.not_fold_free.len(),
        summary.time_ms
    ))?;
    Ok(())
}

impl RegisterCli {
    /// The command's files ([`crate::io::clash`]).
    pub(super) fn files(
        &self,
        f: crate::io::clash::CommandFiles,
    ) -> crate::io::clash::CommandFiles {
        if self.frames.is_some() {
            // The output is a folder of per-frame files named after the frames.
            return f
                .input("--frames", self.frames.as_deref())
                .input("--mask-fixed", self.mask_fixed.as_deref())
                .input("--mask-moving", self.mask_moving.as_deref())
                .output("--report", self.report.as_deref());
        }
        f.input("FIXED", self.fixed.as_deref())
            .input("MOVING", self.moving.as_deref())
            .input("--mask-fixed", self.mask_fixed.as_deref())
            .input("--mask-moving", self.mask_moving.as_deref())
            .input("--landmarks", self.landmarks.as_deref())
            .input("--init", self.init.as_deref())
            .output("--output", Some(&self.output))
            .output("--warped", self.warped.as_deref())
            .output("--report", self.report.as_deref())
            .output("--overlay", self.overlay.as_deref())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn without_verbose_the_solver_progress_becomes_the_spinner_message() {
        let bar = ProgressBar::hidden();
        let p = progress(false, bar.clone());
        p("spline level 1", 7, 0.123456);
        assert_eq!(bar.message(), "spline level 1, iteration 7, cost 0.1235");
        // --verbose (show = false): no spinner at all.
        assert!(spinner(false, "register").is_hidden());
    }

    #[test]
    fn the_bend_help_names_the_mi_scale_the_library_uses() {
        use clap::Args;
        let cmd = RegisterCli::augment_args(clap::Command::new("register"));
        let help = cmd
            .get_arguments()
            .find(|a| a.get_id() == "bend")
            .and_then(|a| a.get_help())
            .map(|h| h.to_string())
            .unwrap();
        let scale = crate::register::metric::MI_BEND_SCALE;
        assert!(help.contains(&format!("by {scale}")), "{help}");
    }
}
