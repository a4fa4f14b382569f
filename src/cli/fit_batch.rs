//! `trimorph fit --model SCENE.json --frames DIR|STACK.tif --landmarks L -o OUTDIR`: a scene
//! (a deformation, usually 2.5D, with its model) fitted to every frame of a sequence. The
//! work is [`crate::fit::sequence`]; this layer reads the inputs, writes the outputs and
//! prints. 2D frames need no scene: `trimorph fit DEF.json --frames ...` starts every frame
//! from any deformation, and `trimorph fit --size W,H --frames ...` from the identity over
//! a mesh adapted to the landmarks' sources ([`SceneSource::Landmarks`]).
//!
//! * Landmarks: `L` gives sources in the scene's reference domain and targets in the first
//!   frame; with `--track` the targets are followed by pyramidal Lucas-Kanade, from the
//!   previous frame (`--anchor chain`, the default), from the first frame (`--anchor first`)
//!   or from key frames (`--anchor keyframes --key-every N`); points lost by the tracker drop
//!   out of later frames. A directory `L` holds one file per frame instead (`<frame
//!   stem>.csv`, `.json` or BigWarp). Landmarks named like a model landmark take their
//!   source from that model vertex, projected to xy. `--holdout K` keeps the same K
//!   landmarks out of every frame's fit and reports their error (TRE).
//! * Fits: with `--track` in frame order, each warm-started from the previous frame's
//!   result; without, independent frames run in parallel (rayon).
//! * Outputs per frame `<stem>`: `<stem>.json` (deformation), `<stem>.registered.png` (the
//!   frame pulled back onto the reference through phi, in the frame's type and channels,
//!   `--background` where phi leaves the frame; `.registered.tif` for float frames),
//!   `<stem>.obj` (the deformed model), `<stem>.overlay.png` (frame, model outline,
//!   landmarks) and `<stem>.report.json` (written last: residuals, RMS, max, TRE, min det J,
//!   iterations, time, tracking losses, drift, and the resume key). `--report FILE` writes a
//!   summary of the sequence.
//! * Resumable: a frame is skipped when its report's resume key (inputs and options) equals
//!   this run's and every output is present; otherwise it is fitted again, saying why.
//!   `--shard i/n` takes the `i`-th of `n` contiguous frame ranges, so array jobs on a
//!   cluster split a sequence with no coordination (tracking always starts from the first
//!   frame, which is cheap).

use super::common::{progress_bar, say};
use super::fit_args::FitCli;
use super::fit_cmd::fit_error;
use crate::fit::sequence::choose_anchor;
use crate::jobs::fit::{SequenceJob, SequenceJobError};
use crate::jobs::sequence::SceneSource;
use anyhow::Result;
use std::path::Path;

/// A library error as the CLI reports it (fit errors keep their exit code).
fn sequence_error(e: SequenceJobError) -> anyhow::Error {
    match e {
        SequenceJobError::Fit { frame, error } => fit_error(error).context(frame.to_string()),
        other => anyhow::Error::new(other),
    }
}

/// Runs the batch fit of `scene` over `frames`; see the module docs.
pub fn run(a: &FitCli, scene: SceneSource, frames: &Path) -> Result<()> {
    let fit = a.fit_options()?;
    let track = choose_anchor(a.track, a.anchor, a.key_every)?;
    let job = SequenceJob {
        scene,
        model: a.model_file.clone(),
        frames: frames.into(),
        // clap refuses --landmarks-src/--landmarks-dst with --frames.
        landmarks: a.landmarks.clone().ok_or_else(|| {
            anyhow::anyhow!("--frames needs --landmarks (a landmark file or folder)")
        })?,
        track,
        background: a.background,
        fit,
        holdout: a.holdout,
        seed: a.seed,
        shard: a.shard,
        output: a.output.clone(),
        report: a.report.clone(),
    };
    let bar = std::sync::OnceLock::new();
    let outcome = job.run(
        &mut |n| {
            let _ = bar.set(progress_bar(n as u64, n > 1, "fit"));
        },
        &|| {
            if let Some(b) = bar.get() {
                b.inc(1)
            }
        },
    );
    if let Some(b) = bar.get() {
        b.finish_and_clear();
    }
    let outcome = outcome.map_err(sequence_error)?;
    for line in &outcome.lines {
        say(line)?;
    }
    job.write_report(&outcome)?;
    Ok(())
}
