//! `trimorph fit DEF.json --landmarks L -o OUT.json` (or `--landmarks-src S --landmarks-dst D`
//! instead of `--landmarks`): one deformation fitted to landmarks
//! ([`crate::jobs::fit::FitJob`]); this layer parses the options, maps errors to exit codes
//! and prints.

use super::common::{error_text, say};
use super::fit_args::FitCli;
use super::{Exit, EXIT_UNSOLVABLE};
use crate::fit::FitError;
use crate::jobs::fit::{FitJob, FitJobError, FitStart};
use anyhow::{anyhow, Result};

/// Maps a fit error to the CLI's exit codes: unsolvable hard constraints exit 2.
pub fn fit_error(e: FitError) -> anyhow::Error {
    if e.is_unsolvable() {
        anyhow::Error::new(Exit { code: EXIT_UNSOLVABLE, message: e.to_string(), printed: false })
    } else {
        anyhow::Error::new(e)
    }
}

/// `trimorph fit (DEF | --size W,H) --landmarks L -o OUT [--report R] [--holdout k]`.
pub fn run_single(a: &FitCli) -> Result<()> {
    let fit = a.fit_options()?;
    let start = match (&a.deformation, a.size) {
        (Some(d), _) => FitStart::Deformation(d.clone()),
        (None, size) => {
            if a.pin.is_some() {
                anyhow::bail!("--pin needs a deformation (DEF) whose control points it names");
            }
            let adapt = a.adapt_options();
            // `run` comes here only with --size when DEF is absent.
            let size = size.ok_or_else(|| anyhow!("give DEF.json or --size W,H"))?;
            FitStart::Frame { size, adapt }
        }
    };
    let barrier = fit.barrier.is_some();
    let job = FitJob {
        start,
        landmarks: a.landmark_source()?,
        output: a.output.clone(),
        report: a.report.clone(),
        holdout: a.holdout,
        seed: a.seed,
        pin: a.pin.clone(),
        fit,
    };
    let done = job.run(&mut |w| eprintln!("warning: {w}")).map_err(|e| match e {
        // Prefixed with the landmark file it is about (keeping the exit code).
        FitJobError::Landmarks { file, error } => match fit_error(error).downcast::<Exit>() {
            Ok(x) => Exit { message: format!("{file}: {}", x.message), ..x }.into(),
            Err(e) => anyhow!("{file}: {}", error_text(&e)),
        },
        FitJobError::Job(e) => e.into(),
    })?;
    say(done.summary())?;
    for w in done.report.warnings(barrier) {
        eprintln!("warning: {w}");
    }
    Ok(())
}
