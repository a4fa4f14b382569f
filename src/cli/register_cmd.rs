//! `trimorph register FIXED MOVING -o DEF.json`: registration from the images themselves
//! (a thin layer over [`crate::jobs::register`]).

use super::common::{choice, say};
use crate::jobs::register::{run as run_job, RegisterFiles};
use crate::register::{Metric, Prealign, RegisterOptions};
use anyhow::Result;
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `trimorph register`.
#[derive(Clone, Debug, clap::Args)]
pub(crate) struct RegisterCli {
    /// The fixed image (the grid MOVING is resampled onto). Any type trimorph reads; colour
    /// is registered as grey.
    fixed: PathBuf,
    /// The moving image.
    moving: PathBuf,
    /// Output deformation: phi maps MOVING pixels to FIXED pixels, so
    /// `trimorph warp DEF --image MOVING` resamples MOVING onto FIXED.
    #[arg(short, long)]
    output: PathBuf,
    /// Also write MOVING resampled on FIXED's grid (FIXED's size, MOVING's type).
    #[arg(long, value_name = "IMAGE")]
    warped: Option<PathBuf>,
    /// Write the report (JSON): metric before and after, per level iterations, termination
    /// and time, the fold certificate, landmark residuals.
    #[arg(long, value_name = "JSON")]
    report: Option<PathBuf>,
    /// Write a two-colour overlay (FIXED magenta, MOVING green) before and after (PNG).
    #[arg(long, value_name = "PNG")]
    overlay: Option<PathBuf>,
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
    /// Weight of the landmark term against the image term.
    #[arg(long, default_value_t = 1.0)]
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
    /// Mesh cell size (MOVING pixels).
    #[arg(long, default_value_t = RegisterOptions::default().spacing)]
    spacing: f64,
    /// Bending weight (larger: smoother).
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
        bend: args.bend,
        max_iters: args.iterations,
        samples: crate::register::samples::SampleOptions { max_samples: args.samples },
        landmark_weight: args.landmark_weight,
        hard: args.hard,
        ..RegisterOptions::default()
    };
    if args.verbose {
        opts.progress = Some(Arc::new(|stage: &str, it: u64, cost: f64| {
            eprintln!("{stage}: iteration {it}, cost {cost:.6}");
        }));
    }
    let files = RegisterFiles {
        fixed: args.fixed,
        moving: args.moving,
        mask_fixed: args.mask_fixed,
        mask_moving: args.mask_moving,
        landmarks: args.landmarks,
        init: args.init,
        output: args.output.clone(),
        warped: args.warped,
        report: args.report,
        overlay: args.overlay,
    };
    let out = run_job(&files, opts)?;
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
    say(format!(
        "{}: det J >= {:.4} ({}), exactly C1, {} triangles, {} variables",
        args.output.display(),
        r.det_j_lower_bound,
        if r.fold_free { "certified fold-free" } else { "NOT certified fold-free" },
        r.triangles,
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

impl RegisterCli {
    /// The command's files ([`crate::io::clash`]).
    pub(super) fn files(
        &self,
        f: crate::io::clash::CommandFiles,
    ) -> crate::io::clash::CommandFiles {
        f.input("FIXED", Some(&self.fixed))
            .input("MOVING", Some(&self.moving))
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
