//! `trimorph fit --model SCENE.json --frames DIR|STACK.tif --landmarks L -o OUTDIR`: a scene
//! (a deformation, usually 2.5D, with its model) fitted to every frame of a sequence. The
//! work is [`crate::fit::sequence`]; this layer reads the inputs, writes the outputs and
//! prints.
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

use super::fit_cmd::{fit_error, summary, SolverArgs};
use crate::fit::sequence::{Action, Anchor, Event, Frame, SequenceError};
use crate::io::write_atomic;
use crate::render::sequence::{choose_anchor, SequenceInputs};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Arguments of the batch fit.
pub struct BatchArgs<'a> {
    pub scene: &'a Path,
    pub model: Option<&'a Path>,
    pub frames: &'a Path,
    pub landmarks: &'a Path,
    pub track: bool,
    /// `chain`, `first` or `keyframes` (`None`: chain).
    pub anchor: Option<&'a str>,
    /// Key frame spacing of `--anchor keyframes`.
    pub key_every: Option<usize>,
    pub holdout: usize,
    pub seed: u64,
    /// Registered frames' value outside the map (sample units).
    pub background: f64,
    pub output: &'a Path,
    /// Sequence summary (JSON).
    pub report: Option<&'a Path>,
    pub shard: Option<&'a str>,
    pub solver: SolverArgs<'a>,
}

/// A library error as the CLI reports it (fit errors keep their exit code).
fn sequence_error(e: SequenceError, a: &BatchArgs, frames: &[Frame]) -> anyhow::Error {
    match e {
        SequenceError::Fit { index, source, .. } => fit_error(source).context(format!(
            "frame {} ({}; landmarks {}{})",
            frames[index].name,
            frames[index].source,
            a.landmarks.display(),
            if a.track && !a.landmarks.is_dir() { ", tracked from the first frame" } else { "" }
        )),
        SequenceError::Store { index, source, .. } => {
            anyhow::Error::from_boxed(source).context(format!("frame {}", frames[index].name))
        }
        other => anyhow::Error::new(other),
    }
}

/// Runs the batch fit; see the module docs.
pub fn run(a: BatchArgs) -> Result<()> {
    let t0 = Instant::now();
    let fit_opts = a.solver.options()?;
    let shard = a.shard.map(super::common::parse_shard).transpose()?;
    let track = choose_anchor(a.track, a.anchor, a.key_every)?;
    let inputs =
        SequenceInputs::load(a.scene, a.model, a.frames, a.landmarks, track, a.background)?;
    let frames = &inputs.frames[..];
    let anchor = inputs.anchor();
    let seq = inputs
        .sequence(fit_opts, a.holdout, a.seed, shard)
        .map_err(|e| sequence_error(e, &a, frames))?;
    let (lo, hi) = seq.range();
    std::fs::create_dir_all(a.output)
        .with_context(|| format!("cannot create {}", a.output.display()))?;
    // Leftovers of an earlier run that was killed mid-write.
    crate::io::remove_stale_temps(a.output, crate::io::STALE_AFTER);
    let store = inputs.files(a.output);
    let bar = super::common::progress_bar((hi - lo) as u64, hi - lo > 1, "fit");
    let on_event = |e: Event<'_>| {
        if let Event::Frame(_) = e {
            bar.inc(1)
        }
    };
    let result = seq.run(&store, &on_event);
    bar.finish_and_clear();
    let sum = result.map_err(|e| sequence_error(e, &a, frames))?;
    let mut stdout = std::io::stdout();
    for f in &sum.frames {
        let drift = f
            .drift
            .map(|d| format!("; drift {:.3} px ({} points)", d.rms, d.points))
            .unwrap_or_default();
        match (&f.action, &f.report) {
            (Action::Skipped, _) => writeln!(stdout, "{}: done before, skipped", f.name)?,
            (Action::Fitted(crate::fit::sequence::Reason::New), Some(r)) => {
                writeln!(stdout, "{}: {}{drift}", f.name, summary(r))?
            }
            (Action::Fitted(why), Some(r)) => {
                writeln!(stdout, "{}: {why}; {}{drift}", f.name, summary(r))?
            }
            (Action::Fitted(why), None) => writeln!(stdout, "{}: {why}", f.name)?,
        }
    }
    let fitted = sum.fitted();
    writeln!(
        stdout,
        "{fitted} frames fitted, {} skipped, frames {lo}..{hi} of {} (landmarks{} in {:.0} ms; total {:.1} s) -> {}",
        sum.frames.len() - fitted,
        frames.len(),
        if anchor.is_some() { " tracked" } else { "" },
        sum.track_ms,
        t0.elapsed().as_secs_f64(),
        a.output.display()
    )?;
    if let Some(t) = &sum.tre {
        writeln!(
            stdout,
            "held-out TRE over {} frames: rms {:.3} px, max {:.3} px ({} residuals; held out: {})",
            t.frames,
            t.rms,
            t.max,
            t.count,
            seq.held_out().iter().cloned().collect::<Vec<_>>().join(", ")
        )?;
    }
    if let (Some(an), Some(d)) = (anchor, &sum.drift_max) {
        let vs =
            if an == Anchor::Chain { "tracking from the first frame" } else { "chained tracking" };
        writeln!(
            stdout,
            "tracking ({an}): largest drift against {vs} {:.3} px RMS, {:.3} px max ({} points)",
            d.rms, d.max, d.points
        )?;
    }
    if let Some(p) = a.report {
        let text = serde_json::to_string_pretty(&sum.to_json(anchor))?;
        write_atomic(p, text.as_bytes())?;
    }
    Ok(())
}
