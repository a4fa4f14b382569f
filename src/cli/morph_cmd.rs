//! `trimorph morph A B --landmarks L.csv --frames N -o DIR`: frames, animations, contact sheet,
//! and the fitted deformations `phi_ab.json` (A's pixels -> B's pixels) and `phi_ba.json`
//! (B's pixels -> A's pixels), readable by `--phi-ab` / `--phi-ba`. The job is
//! [`crate::jobs::morph::MorphJob`]; this layer builds it from the options, shows the
//! progress bar and prints the job's notes and report.

use super::args::MorphCli;
use super::common::progress_bar;
use crate::io::landmarks::LandmarkSource;
use crate::jobs::morph::{MorphFileOptions, MorphJob};
use crate::jobs::morph_inputs::{MorphInputs, MorphSettings, MorphSource};
use anyhow::{bail, Result};

/// Where the maps come from, by the options given.
fn source(a: &MorphCli) -> Result<MorphSource> {
    Ok(match (&a.landmarks, &a.landmarks_src, &a.landmarks_dst, &a.phi_ab) {
        (Some(l), _, _, _) => MorphSource::Landmarks(LandmarkSource::File(l.clone())),
        (None, Some(src), Some(dst), _) => {
            MorphSource::Landmarks(LandmarkSource::Pair { src: src.clone(), dst: dst.clone() })
        }
        (None, _, _, Some(p)) => {
            MorphSource::Deformations { phi_ab: p.clone(), phi_ba: a.phi_ba.clone() }
        }
        _ => bail!(
            "give --landmarks L.csv, --landmarks-src A.pts --landmarks-dst B.pts, or --phi-ab DEF.json"
        ),
    })
}

/// Runs the command.
pub fn run(a: &MorphCli) -> Result<()> {
    let settings = MorphSettings {
        shape: a.shape,
        color: a.color,
        interp: a.interp,
        cells: a.cells,
        align: !a.no_align,
        background: a.background,
        pin_frame: a.pin_frame,
        mode: a.mode,
        bend: a.bend,
        hard: a.hard,
    };
    let files = MorphFileOptions {
        output: a.output.clone(),
        gif: a.gif.clone(),
        apng: a.apng.clone(),
        frames: a.frames,
        range: a.range,
        preview: a.preview,
        background: a.background,
        delay_ms: a.delay,
    };
    let job = MorphJob {
        inputs: MorphInputs { a: a.a.clone(), b: a.b.clone(), source: source(a)?, settings },
        files,
    };
    let made = job.make()?;
    if !a.quiet {
        for note in &made.notes {
            eprintln!("{note}");
        }
    }
    let bar = progress_bar(a.frames as u64, !a.quiet, "morph");
    let done = job.write(&made, &|| bar.inc(1))?;
    bar.finish_and_clear();
    if !a.quiet {
        for line in done.frame_notes() {
            eprintln!("{line}");
        }
    }
    if a.timings {
        eprintln!("{}", done.newton_line());
        eprintln!("timings (ms): {}", done.phases.line());
    }
    if !a.quiet {
        eprintln!("{}", done.summary());
    }
    Ok(())
}
